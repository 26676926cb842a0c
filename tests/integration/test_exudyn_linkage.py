"""Exudyn built from the descriptions (`exudyn_linkage`) against the generated reduced model.

Two independent implementations of every named case: the reduced model generated from the
description (minimal coordinates, sympy's Kane equations, compiled adaptive Runge-Kutta with
located events) and Exudyn (absolute coordinates, algebraic constraints, generalized-alpha
with a fixed step, reactions and drive moment from its own constraint multipliers). What
they share is the description, the contact law and the centred initial state.

Fast tests: the initial state carried to the bodies, and short windows (the first impacts)
where pointwise values can be compared before the impacts' phase errors separate the
trajectories. Slow tests: four revolutions per case (agreement and convergence),
the ideal-joint limit against validation/ideal_linkage.py, finite-difference sensitivities
through Exudyn. Every tolerance has its measured value beside it.
"""

from __future__ import annotations

import numpy as np
import pytest

from mbs_clearance import simulate
from mbs_clearance.backends import exudyn_linkage as xl
from mbs_clearance.model import cases
from mbs_clearance.model.linkage import GROUND
from mbs_clearance.solve.linkage_model import initial_state

pytestmark = pytest.mark.exudyn

CASE_NAMES = ("paper_slider_crank", "slider_crank_two_clearances", "four_bar")


def _world_point(linkage, states, body, point):
    if body == GROUND:
        return np.array(linkage.ground_points[point]), np.zeros(2)
    x, y, phi, vx, vy, w = states[body]
    px, py = dict((b.name, b) for b in linkage.bodies)[body].points[point]
    c, s = np.cos(phi), np.sin(phi)
    r = np.array([c * px - s * py, s * px + c * py])
    return np.array([x, y]) + r, np.array([vx, vy]) + w * np.array([-r[1], r[0]])


@pytest.mark.parametrize("name", CASE_NAMES)
def test_initial_body_states_are_the_centred_reduced_state(name):
    """`body_states` carries the reduced model's centred start to the bodies: every ideal
    joint's two points coincide (and move together), every journal sits at its bearing's
    centre with the same velocity (the velocity constraints of the centred start), and the
    velocities are the time derivatives of the positions (central differences)."""
    lk = cases.CASES[name]()
    y0 = initial_state(lk)
    n = len(lk.coordinates())
    q, qd = y0[:n], y0[n:2 * n]
    st = xl.body_states(lk, 0.0, q, qd)
    scale = lk.length_scale
    pairs = [(j.body_a, j.point_a, j.body_b, j.point_b) for j in lk.joints
             if not hasattr(j, "angle")]
    pairs += [(j.journal_body, j.journal_point, j.bearing_body, j.bearing_point)
              for j in lk.clearance_joints]
    for a, pa, b, pb in pairs:
        ra, va = _world_point(lk, st, a, pa)
        rb, vb = _world_point(lk, st, b, pb)
        assert np.abs(ra - rb).max() < 1e-12 * scale
        assert np.abs(va - vb).max() < 1e-9 * lk.drive.speed * scale
    dt = 1e-7 * lk.period
    plus = xl.body_states(lk, dt, q + dt * qd, qd)
    minus = xl.body_states(lk, -dt, q - dt * qd, qd)
    for body, s in st.items():
        rate = (np.array(plus[body][:3]) - np.array(minus[body][:3])) / (2 * dt)
        assert np.allclose(rate, s[3:], rtol=1e-6, atol=1e-6 * lk.drive.speed * scale)


# short windows: the first impacts, compared pointwise ----------------------------------
#: (case, end time s, steps): the windows hold the first impacts of every joint
WINDOWS = {"paper_slider_crank": (1e-4, 2e-7), "slider_crank_two_clearances": (1e-4, 2e-7)}


def _short_run(lk, end, step):
    model = xl.build(lk, xl.make_settings(dict(step_size=step)))
    xl.solve(model, end)
    t, reactions = xl._reactions(model)
    moment = -xl.stored(model, "drive")[:, 1]
    ecc = {cj.name: xl.stored(model, f"{cj.name}.displacement")[:, 1:3]
           for cj in lk.clearance_joints}
    return t, reactions, moment, ecc


@pytest.mark.parametrize("name", sorted(WINDOWS))
def test_first_impacts_reactions_and_drive_moment_pointwise(name):
    """Over a window holding the first impacts, at a fine step, Exudyn's ground-joint
    reactions (revolute and prismatic, from its multipliers), its drive moment and the
    journals' eccentricities agree pointwise with the reduced model's outputs (Newton on
    the subtrees, Kane's generalized force): this pins every sign convention of the
    builder. Measured (max difference / max value): reactions and moment <= 4e-4 ...
    see the assertion message; eccentricities <= 1e-3 of the clearance."""
    lk = cases.CASES[name]()
    end, step = WINDOWS[name]
    t, reactions, moment, ecc = _short_run(lk, end, step)
    ref = simulate(lk, 1, backend="reduced", rtol=1e-11, h_max=1e-6)
    m = ref.t <= end * (1 + 1e-9)

    def at(y):
        return np.interp(t, ref.t[m], y[m])

    for g, f in reactions.items():
        for k in range(2):
            scale = np.abs(ref.reactions[g][m, k]).max()
            if scale < 1e-9 * np.abs(ref.reactions[g][m]).max():
                # a frictionless guide's axial reaction: zero up to round-off in both
                assert np.abs(f[:, k]).max() < 1e-9 * np.abs(f).max()
                continue
            err = np.abs(f[:, k] - at(ref.reactions[g][:, k])).max() / scale
            assert err < 1e-2, f"{name} {g}[{k}]: {err:.2e} of its peak"
    err = np.abs(moment - at(ref.crank_moment)).max() / np.abs(ref.crank_moment[m]).max()
    assert err < 1e-2, f"{name} drive moment: {err:.2e} of its peak"
    for j, cj in enumerate(lk.clearance_joints):
        for k in range(2):
            err = np.abs(ecc[cj.name][:, k] - at(ref.eccentricity[:, j, k])).max()
            assert err < 2e-2 * cj.clearance, f"{name} {cj.name}: {err / cj.clearance:.2e} c"


def test_first_impacts_converge_at_second_order():
    """Halving the step over the first impacts of the two-joint slider-crank: the largest
    eccentricity difference to the reduced model (rtol 1e-11) falls by ~4 (measured: see
    the message); asserted >= 3 per halving."""
    lk = cases.slider_crank_two_clearances()
    end = 1e-4
    ref = simulate(lk, 1, backend="reduced", rtol=1e-11, h_max=1e-6)
    errors = []
    for step in (8e-7, 4e-7, 2e-7):
        t, _, _, ecc = _short_run(lk, end, step)
        err = 0.0
        for j, cj in enumerate(lk.clearance_joints):
            for k in range(2):
                err = max(err, np.abs(ecc[cj.name][:, k]
                                      - np.interp(t, ref.t, ref.eccentricity[:, j, k])).max())
        errors.append(err)
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(ratios > 3.0), f"errors {errors}, ratios {ratios}"


def test_refined_peak_of_a_parabola_is_exact():
    """`refined_peaks` recovers the vertex of a sampled parabola between the samples; where
    the largest sample of a revolution is at its end (no local maximum), that sample."""
    t = np.linspace(0.0, 2.0, 201)
    y = 5.0 - 3.0 * (t - 0.5037) ** 2
    peaks = xl.refined_peaks(t, y, 1.0, 2)
    assert peaks[0] == pytest.approx(5.0, rel=1e-14)
    assert peaks[1] == y[100]


@pytest.mark.parametrize("options, match", [
    (dict(step_size=1e-6, accuracy=1e-3), "not both"),
    (dict(accuracy=1.0), "accuracy"),
    (dict(steps_per_revolution=3), "steps_per_revolution"),
    (dict(contact="penalty"), "contact"),
    (dict(rtol=1e-8), "allowed"),
])
def test_bad_options_raise_before_building(monkeypatch, options, match):
    def fail(*args, **kwargs):
        raise AssertionError("the model was built despite a bad option")

    monkeypatch.setattr(xl, "build", fail)
    with pytest.raises(ValueError, match=match):
        simulate(cases.four_bar(), 1, backend="exudyn", **options)


def test_accuracy_chooses_the_step_by_second_order():
    s = xl.make_settings(dict(accuracy=xl.ACCURACY_AT_DEFAULT / 4))
    lk = cases.paper_slider_crank()
    assert s.step(lk.period) == pytest.approx(xl.make_settings({}).step(lk.period) / 2)
    assert s.step(lk) == s.step(lk.period)


def test_default_step_and_tolerance_follow_the_contact_scales():
    """The slider-cranks keep period / 6000 and Newton's 1e-8 (their contacts are resolved
    and their roundoff floors ~3e-12); the four-bar's step is a 12th of its contact's
    linearised period (~1.9e-4 s at its load scale: 1.56e-5 s instead of 1 ms) and its
    tolerance 3 times its roundoff floor (~3.3e-8: 1.5 eps L / delta with L ~ 6.8 m,
    delta ~ 7e-8 m). The floor's estimate is checked against a direct evaluation: the
    contact force's change when its positions move by one rounding unit of L."""
    s = xl.make_settings({})
    for name in ("paper_slider_crank", "slider_crank_two_clearances"):
        lk = cases.CASES[name]()
        assert s.step(lk) == lk.period / xl.DEFAULT_STEPS_PER_REVOLUTION
        assert s.tolerance(lk) == xl.NEWTON_TOLERANCE
    fb = cases.four_bar()
    period, floor = xl.contact_scales(fb)
    assert 1e-4 < period < 3e-4 and s.step(fb) == period / xl.STEPS_PER_CONTACT_PERIOD
    assert 1e-8 < floor < 1e-7 and s.tolerance(fb) == xl.ROUNDOFF_MARGIN * floor
    assert xl.make_settings(dict(newton_tolerance=1e-9)).tolerance(fb) == 1e-9
    # independent: the force error of one rounding unit at L, relative to the load
    from mbs_clearance.laws.forces import contact_force

    cj = fb.clearance_joints[0]
    load = sum(b.mass for b in fb.bodies) * (fb.gravity + fb.drive.speed ** 2 * 6.75)
    delta = (load / cj.stiffness) ** (2 / 3)
    ulp = np.spacing(6.75)
    df = (contact_force(delta + ulp, 0.0, 1e-3, cj.stiffness, 1.0, 0)
          - contact_force(delta, 0.0, 1e-3, cj.stiffness, 1.0, 0))
    assert df / load == pytest.approx(floor, rel=0.6)    # ulp(L) / (eps L) is in [0.5, 1]


def test_four_bar_newton_converges_with_the_floor_tolerance():
    """The four-bar's persistent contact (10 N, penetration ~2e-8 m) at 2e-5 s: with
    Newton's relative tolerance below the residual's roundoff floor, Newton stalls
    (residual constant at ~1.3e-8 relative, contraction 1.0) and the run fails (at 1e-8 at
    0.24 s on one machine; the floor depends on the processor's arithmetic: on another
    1e-8 passes and 3e-9 fails, measured; 1e-9 is below it on both); with the automatic
    tolerance (3 x the floor) the same 0.3 s run passes and the contact stays closed with a
    force of the static order (< 50 N)."""
    fb = cases.four_bar()
    tight = xl.build(fb, xl.make_settings(dict(step_size=2e-5, newton_tolerance=1e-9)),
                     outputs=("contact",))
    with pytest.raises(RuntimeError, match="failed"):
        xl.solve(tight, 0.3)
    model = xl.build(fb, xl.make_settings(dict(step_size=2e-5)), outputs=("contact",))
    stats = xl.solve(model, 0.3)
    assert stats["newton_tolerance"] == xl.make_settings({}).tolerance(fb)
    f = xl.stored(model, "coupler_rocker.force")
    late = f[:, 0] > 0.2
    assert np.hypot(f[late, 1], f[late, 2]).max() < 50.0


def test_a_newton_failure_at_the_automatic_tolerance_is_run_again_looser(monkeypatch):
    """The automatic tolerance is an estimate: where Newton fails at it, the run is built
    again with the tolerance loosened (`NEWTON_RETRY_FACTOR`), and gives exactly the run
    made with that tolerance given; a tolerance the user gave is never loosened. Forced on
    the paper case by an automatic tolerance of 1e-15 (below any residual's roundoff)."""
    lk = cases.paper_slider_crank()
    monkeypatch.setattr(xl, "NEWTON_TOLERANCE", 1e-15)
    monkeypatch.setattr(xl, "ROUNDOFF_MARGIN", 0.0)
    monkeypatch.setattr(xl, "NEWTON_RETRY_FACTOR", 1e7)
    with pytest.raises(xl.SolverFailure, match="failed"):
        simulate(lk, 1, backend="exudyn", newton_tolerance=1e-15)
    retried = simulate(lk, 1, backend="exudyn")
    assert retried.stats["newton_retries"] == 1
    assert retried.stats["newton_tolerance"] == pytest.approx(1e-8, rel=1e-12)
    given = simulate(lk, 1, backend="exudyn", newton_tolerance=retried.stats["newton_tolerance"])
    assert given.stats["newton_retries"] == 0
    np.testing.assert_array_equal(retried.peaks, given.peaks)
    # the peak-only run takes the same path
    from mbs_clearance import peak_base_force

    assert peak_base_force(lk, 1, backend="exudyn") == given.peaks[0]
    monkeypatch.setattr(xl, "NEWTON_RETRY_FACTOR", 2.0)
    with pytest.raises(xl.SolverFailure, match="also with Newton's tolerance loosened"):
        simulate(lk, 1, backend="exudyn")


# four revolutions per case (slow) ---------------------------------------------------------
#: cases whose default operating point is periodic, checked across the models at rev 4. The
#: four-bar's default (10 rpm, 0.01 mm) approaches its periodic motion slowly (the
#: frictionless sliding mode, docs/cases.md): it is compared by statistics over its 2nd
#: revolution (`test_four_bar_agrees_by_statistics`).
PERIODIC = ("paper_slider_crank", "slider_crank_two_clearances")

_RUNS: dict = {}


def four_revolutions(name, backend, **options):
    key = (name, backend, tuple(sorted(options.items())))
    if key not in _RUNS:
        _RUNS[key] = simulate(cases.CASES[name](), 4, backend=backend, **options)
    return _RUNS[key]


@pytest.mark.slow
@pytest.mark.parametrize("name", PERIODIC)
def test_periodic_cases_agree_at_the_default_step(name):
    """Reduced (rtol 1e-11) vs Exudyn (default step 2e-6 s): the 4th-revolution
    peak of the monitored force within 0.5 % and the RMS of the |shaking force| and of the
    drive moment within 2 % (measured: peak -2.0e-4 / -8.0e-5, RMS shaking -1.3e-5 /
    2.9e-5, RMS moment -4.5e-5 / 9.2e-6 for the paper / two-joint case). The periodic
    regime is shown by the reduced model: its peaks at rtol 1e-10 and 1e-11 agree to 1e-6
    and revolutions 3 and 4 repeat."""
    from validation.compare import compare

    ref = four_revolutions(name, "reduced", rtol=1e-11)
    loose = four_revolutions(name, "reduced", rtol=1e-10)
    assert abs(loose.peaks[3] / ref.peaks[3] - 1) < 1e-6
    assert abs(ref.peaks[3] / ref.peaks[2] - 1) < 1e-4
    ex = four_revolutions(name, "exudyn")
    r = compare(ref, ex, step_bars=False).revolution(4)
    assert abs(r.peak_rel_diff) < 5e-3, r.peak_rel_diff
    assert abs(r.shaking_rms_rel_diff) < 2e-2, r.shaking_rms_rel_diff
    assert abs(r.moment_rms_rel_diff) < 2e-2, r.moment_rms_rel_diff
    # tighter than required, at the measured level (a regression shows)
    assert abs(r.peak_rel_diff) < 5e-4 and abs(r.shaking_rms_rel_diff) < 1e-4


@pytest.mark.slow
@pytest.mark.parametrize("name", PERIODIC)
def test_difference_shrinks_at_second_order_as_the_step_halves(name):
    """Exudyn at 8, 4 and 2 us against the reduced model (rtol 1e-11), 4th revolution. The
    RMS difference of the |shaking force| falls by 2.6-3.6 per halving (paper) and 2.8-3.0
    (two joints) (measured; 4 = second order), asserted > 2.3. The paper case's peak error
    falls 1.4e-3 -> 4.9e-4 -> 2.0e-4 (asserted > 2 per halving); the two-joint case's peak
    error does not fall monotonically (2.2e-3, 2.3e-3, 8e-5, 1.1e-3 at 1 us: the crank
    joint's undamped sliding mode rides on the peak, its phase set by the step), so only
    its RMS is asserted there."""
    from validation.compare import compare

    ref = four_revolutions(name, "reduced", rtol=1e-11)
    rms, peak = [], []
    for step in (8e-6, 4e-6, 2e-6):
        ex = four_revolutions(name, "exudyn", step_size=step)
        r = compare(ref, ex, step_bars=False).revolution(4)
        rms.append(abs(r.shaking_rms_rel_diff))
        peak.append(abs(r.peak_rel_diff))
    rms, peak = np.array(rms), np.array(peak)
    assert np.all(rms[:-1] / rms[1:] > 2.3), rms
    if name == "paper_slider_crank":
        assert np.all(peak[:-1] / peak[1:] > 2.0), peak


@pytest.mark.slow
@pytest.mark.parametrize("name", PERIODIC)
def test_ideal_joint_limit_against_the_ideal_model(name):
    """Clearance 1e-7 m in every joint, Exudyn at its default step, 2nd revolution, against
    the hand-written ideal model (validation/ideal_linkage.py: analytic closure,
    Newton-Euler). Window averages (36 windows of 10 degrees) and pointwise values of the
    drive moment, the shaking force and every ground reaction within 1e-3 of their peak
    (measured: window <= 1.8e-4 / 4.3e-4, pointwise <= 3.4e-4 / 5.9e-4, paper / two-joint
    case), the refined peak of the monitored force within 1e-4 (measured 7e-7 / 1.4e-5).
    The residual is the clearance itself (1e-7 m against 10 mm bearings moves the force
    lines) plus the step's O(h^2) error; the frictionless sliding mode stays
    small here because Exudyn's numerical damping (rho_inf 0.9) removes it: pointwise
    values agree as well as window averages, unlike in the four-bar."""
    import sys
    from pathlib import Path

    from validation.ideal_linkage import from_linkage, ideal_outputs

    sys.path.insert(0, str(Path(__file__).parent))
    from test_linkage_physics import window_means

    if name == "paper_slider_crank":
        lk = cases.paper_slider_crank(journal_radius=0.01 - 1e-7)
    else:
        lk = cases.slider_crank_two_clearances(crank_coupler_clearance=1e-7,
                                               coupler_slider_clearance=1e-7)
    ex = simulate(lk, 2, backend="exudyn")
    t = ex.t
    ref = ideal_outputs(from_linkage(lk), t)
    P = lk.period
    edges = P + P * np.arange(37) / 36
    pairs = [("drive moment", ex.crank_moment, ref["drive_moment"]),
             ("shaking", ex.shaking_force, ref["shaking"])]
    pairs += [(g, f, ref["ground_reactions"][g]) for g, f in ex.reactions.items()]
    later = t >= P
    for label, sim, ideal in pairs:
        scale = np.max(np.abs(ideal[later]))
        window = np.max(np.abs(window_means(t, sim, edges) - window_means(t, ideal, edges)))
        point = np.max(np.abs(sim[later] - ideal[later]))
        assert window < 1e-3 * scale, f"{label}: window {window / scale:.2e}"
        assert point < 1e-3 * scale, f"{label}: pointwise {point / scale:.2e}"
    ideal_peak = np.hypot(*ref["ground_reactions"][lk.monitor_joint][later].T).max()
    assert abs(ex.peaks[1] / ideal_peak - 1) < 1e-4


@pytest.mark.slow
def test_four_bar_agrees_by_statistics():
    """The four-bar (not periodic: its frictionless sliding mode decays over many
    revolutions in the reduced model and is damped at once by Exudyn's rho_inf = 0.9), 2nd
    revolution, reduced (rtol 1e-11) vs Exudyn at its default (1.56e-5 s, Newton tolerance
    9.8e-8): the refined peak of the |shaking force| within 0.5 % (measured -0.22 %; 3.1e-5
    s: -0.04 %, 7.8e-6 s: +0.002 %: not monotone, the sliding mode rides on the peak), the
    RMS of the |shaking force| and of the drive moment within 2 % (measured -2e-5, -1.5e-4),
    window averages (36 of 10 degrees) of the shaking force and drive moment within 2e-3 of
    their peak (measured <= 7.4e-4 / 3.6e-4). Pointwise the models differ by the sliding
    mode (RMS 2.1 % / 6.8 %), which is physics of the reduced model, not step error."""
    import sys
    from pathlib import Path

    from validation.compare import compare

    sys.path.insert(0, str(Path(__file__).parent))
    from test_linkage_physics import window_means

    lk = cases.four_bar()
    ref = simulate(lk, 2, rtol=1e-11, h_max=1e-3)
    ex = simulate(lk, 2, backend="exudyn")
    assert ex.stats["newton_tolerance"] > xl.NEWTON_TOLERANCE
    r = compare(ref, ex, step_bars=False).revolution(2)
    assert abs(r.peak_rel_diff) < 5e-3, r.peak_rel_diff
    assert abs(r.shaking_rms_rel_diff) < 2e-2 and abs(r.moment_rms_rel_diff) < 2e-2
    P = lk.period
    edges = P + P * np.arange(37) / 36
    for a, b in ((ref.shaking_force, ex.shaking_force), (ref.crank_moment, ex.crank_moment)):
        scale = np.abs(a[ref.t >= P]).max()
        diff = np.abs(window_means(ref.t, a, edges) - window_means(ex.t, b, edges)).max()
        assert diff < 2e-3 * scale


@pytest.mark.slow
@pytest.mark.parametrize("name, rel", [("paper_slider_crank", 1e-3),
                                       ("slider_crank_two_clearances", 1e-2)])
def test_exudyn_finite_differences_converge_to_ddm(name, rel):
    """Central differences (relative step `rel`) through Exudyn of the monitored force over
    the 2nd revolution, for 3 parameters per case (validation/exudyn_sensitivity.py),
    against DDM on the generated model (rtol 1e-10), Exudyn at 4 and 2 us.
    The series d|F|/db (relative RMS difference) falls as the step halves in both cases
    (measured, paper: 0.55 / 0.59 / 0.90 -> 0.17 / 0.19 / 0.27 for coupler.mass,
    slider.mass, coupler.inertia; two joints: 0.69 / 0.80 / 1.4 -> 0.31 / 0.37 / 0.77): the
    derivative magnifies Exudyn's phase error at the contact frequency. The derivative of
    the RMS (an integral, no phase error; each RMS over the runs' own steps):
    paper 3.0e-3 / 4.8e-3 / 6.1e-3 -> 7.3e-4 / 1.1e-3 / 3.0e-3, asserted falling and
    < 5e-3; two joints 1.9e-3 / 4.2e-3 / 9.9e-3 -> 4.8e-3 / 8.1e-3 / 4.5e-3, not falling:
    the crank joint's sliding mode, whose phase the parameter moves, puts noise of that
    size into the differences (as it does into the case's peak, docs/exudyn.md), asserted
    < 1.5e-2 at both steps."""
    from validation.exudyn_sensitivity import compare_fd_ddm

    rows = compare_fd_ddm(name, (4e-6, 2e-6), rel=rel)
    coarse = {r["parameter"]: r for r in rows if r["step"] == 4e-6}
    fine = {r["parameter"]: r for r in rows if r["step"] == 2e-6}
    for p in fine:
        assert fine[p]["series"] < 0.8 * coarse[p]["series"], (p, coarse[p], fine[p])
        if name == "paper_slider_crank":
            assert fine[p]["rms"] < 5e-3, (p, fine[p])
            assert fine[p]["rms"] < coarse[p]["rms"], (p, coarse[p], fine[p])
        else:
            assert max(fine[p]["rms"], coarse[p]["rms"]) < 1.5e-2, (p, coarse[p], fine[p])


_SETTLED: dict = {}


def four_bar_settled_start():
    """The four-bar's state after 100 revolutions (reduced model, rtol 1e-10, about 70 s):
    the start's impacts and the sliding mode have settled (docs/cases.md)."""
    from mbs_clearance.solve.linkage_model import settled_start

    if "start" not in _SETTLED:
        _SETTLED["start"] = settled_start(cases.four_bar(), 100, rtol=1e-10)
    return _SETTLED["start"]


@pytest.mark.slow
def test_four_bar_from_a_settled_start_agrees_and_converges():
    """The four-bar in its periodic regime: both models started from the state
    after 100 revolutions (the same state, contact mode and impact velocity), revolution 1
    from there, reduced at rtol 1e-11 against Exudyn. At the default step (1.56e-5 s) the
    peak of the |shaking force| within 0.5 % and the RMS of it and of the drive moment
    within 2 % (measured: 6.6e-6, 8.0e-9, 3.4e-8). At 32, 16 and 8 times the default step
    (498, 249, 125 us) the peak error falls (measured on one machine: 4.8e-5, 3.1e-5, 5.3e-6,
    earlier 1.2e-4, 2.3e-5, 4.0e-7;
    at 500, 250, 125 us: 1.0e-4, 3.2e-5, 7.3e-6; on another: 4.5e-5, 2.2e-5, 4.5e-6, and
    with an event margin of 0.05 c, which moves the start at round-off: 8.2e-5, 1.3e-8,
    3.7e-6): the signed peak difference scatters with the exact step and
    the processor and can pass near zero, so no rate per halving is asserted, only that the
    error at 8 times the default step is below a fifth of that at 32 times (second order:
    1/16) and that none exceeds 2e-4. Below about 30 us it grows again (3.7e-6, 1.8e-6,
    6.6e-6, 4.9e-5, 2.8e-4 at 62, 31, 16, 7.8, 3.9 us): at fine steps Exudyn keeps a radial
    contact vibration of ~3e-11 m that coarse steps damp (docs/exudyn.md), which no test
    here hides: the default step's error is asserted."""
    from validation.compare import compare

    lk = cases.four_bar()
    start = four_bar_settled_start()
    ref = simulate(lk, 1, rtol=1e-11, start=start)
    ex = simulate(lk, 1, backend="exudyn", start=start)
    r = compare(ref, ex, revolutions=(1,), step_bars=False).revolution(1)
    assert abs(r.peak_rel_diff) < 5e-3, r.peak_rel_diff
    assert abs(r.shaking_rms_rel_diff) < 2e-2 and abs(r.moment_rms_rel_diff) < 2e-2
    # tighter than required, at the measured level (a regression shows)
    assert abs(r.peak_rel_diff) < 1e-4 and abs(r.shaking_rms_rel_diff) < 1e-6
    h0 = xl.make_settings({}).step(lk)
    peak = []
    for factor in (32, 16, 8):
        ex = simulate(lk, 1, backend="exudyn", start=start, step_size=factor * h0)
        r = compare(ref, ex, revolutions=(1,), step_bars=False).revolution(1)
        peak.append(abs(r.peak_rel_diff))
    peak = np.array(peak)
    assert peak[2] < peak[0] / 5.0 and peak.max() < 2e-4, peak


@pytest.mark.slow
def test_four_bar_exudyn_finite_differences_agree_with_ddm_from_a_settled_start():
    """Finite differences through Exudyn for the four-bar, from the state after 100
    revolutions (held fixed: from the centred start the sensitivities pass through its 325
    settling impacts and are ill-conditioned, docs/exudyn.md). Relative step 1e-3,
    revolution 1 from there, d RMS(|F|)/db of coupler.mass, rocker.mass and gravity
    against DDM (rtol 1e-9), each RMS over the runs' own steps in the Exudyn runs' window.
    Measured: 3.3e-6, 1.3e-5, 3.9e-6 at 15.6 us and 1.4e-5, 5.1e-6, 9.2e-6 at
    7.8 us, the level of the reduced model's own central differences at this relative step
    (3.5e-6, 6.5e-7, 4.4e-6): asserted < 5e-5 at both steps. (A trapezoid over 3000
    comparison samples instead has an error of 1e-4 to 1e-3 that depends on where the
    samples of the contacts fall and can look like convergence: no rate is asserted.)"""
    from validation.exudyn_sensitivity import compare_fd_ddm

    rows = compare_fd_ddm("four_bar", (1.5577e-5, 7.7885e-6), revolutions=1, rel=1e-3,
                          ddm_rtol=1e-9, settled=100)
    assert {r["parameter"] for r in rows} == {"coupler.mass", "rocker.mass", "gravity"}
    assert len(rows) == 6
    for r in rows:
        assert r["rms"] < 5e-5, r


@pytest.mark.slow
def test_four_bar_ideal_joint_limit_separates_the_sliding_mode():
    """The four-bar with clearance 1e-7 m in Exudyn (its default: step 7.2e-6 s, a 12th of
    the stiffer contact's period; Newton tolerance 4.6e-7 at that contact's roundoff
    floor), first revolution from 10 degrees on (the journal's fall across the clearance
    from the centred start before), against validation/ideal_linkage.py. Window averages
    (36) of the drive moment, shaking force and ground reactions within 2e-4 of their peak
    (measured <= 3.8e-5) and the peak of the |shaking force| within 5e-4 (measured 7e-5):
    the ideal limit. Pointwise the frictionless sliding mode (sqrt(F / (m c)) ~ 1.7e4 rad/s,
    h omega ~ 0.12, which generalized-alpha damps only slowly) is present, excited by the
    start and by the joint force's turns: the shaking force's x component differs by up to
    0.22 of its peak in the first three quarters (asserted > 1e-2: the mode is there, not
    hidden) and by 1.9e-3 in the last quarter, where it has decayed (asserted < 1e-2)."""
    import sys
    from pathlib import Path

    from validation.ideal_linkage import from_linkage, ideal_outputs

    sys.path.insert(0, str(Path(__file__).parent))
    from test_linkage_physics import window_means

    lk = cases.four_bar(clearance=1e-7)
    ex = simulate(lk, 1, backend="exudyn")
    t, P = ex.t, lk.period
    ref = ideal_outputs(from_linkage(lk), t)
    start = P / 36
    edges = start + (P - start) * np.arange(36) / 35
    later = t >= start
    pairs = [("drive moment", ex.crank_moment, ref["drive_moment"]),
             ("shaking", ex.shaking_force, ref["shaking"])]
    pairs += [(g, f, ref["ground_reactions"][g]) for g, f in ex.reactions.items()]
    for label, sim, ideal in pairs:
        scale = np.max(np.abs(ideal[later]))
        window = np.max(np.abs(window_means(t, sim, edges) - window_means(t, ideal, edges)))
        assert window < 2e-4 * scale, f"{label}: window {window / scale:.2e}"
    s, si = np.hypot(*ex.shaking_force.T), np.hypot(*ref["shaking"].T)
    assert abs(s[later].max() / si[later].max() - 1) < 5e-4
    d = np.abs(ex.shaking_force[:, 0] - ref["shaking"][:, 0])
    scale = np.abs(ref["shaking"][later, 0]).max()
    assert d[later & (t < 0.75 * P)].max() > 1e-2 * scale
    assert d[t >= 0.75 * P].max() < 1e-2 * scale


def test_peak_only_run_counts_a_ground_guides_reaction_in_the_shaking_force():
    """The translational benchmark monitoring its shaking force (no monitor joint): the
    peak-only Exudyn run's peak is the full run's (the ground guide's reaction, from its
    corners' loads, included), and it is not the crank pivot's alone, which is six times
    smaller here."""
    lk = cases.flores_translational_slider_crank().replace(monitor_joint=None)
    peak = xl.peak_exudyn_linkage(lk, duration=0.01, window=0.005)
    tr = xl.simulate_exudyn_linkage(lk, duration=0.01, window=0.005)
    assert peak == tr.peaks[-1]
    last = tr.t >= 0.005 - 1e-12
    pivot = float(np.hypot(*tr.reactions["crank_pivot"][last].T).max())
    assert peak > 2.0 * pivot
    assert peak >= float(np.hypot(*tr.shaking_force[last].T).max())
