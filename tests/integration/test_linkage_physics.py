"""Physics of the generated models on the named cases, each against an independent reference.

- Ideal-joint limit (clearance 1e-7 m): reactions at the ground joints, shaking force, drive
  moment and the clearance joints' forces of the four-bar and of the two-joint slider-crank
  against the hand-written ideal models of validation/ideal_linkage.py (analytic closure,
  Newton-Euler). Compared by window averages (36 windows of 10 degrees of crank angle) and
  by the refined peak of the monitored force. Pointwise values are NOT compared: a
  frictionless clearance joint has an undamped sliding mode (the journal swings along the
  bearing wall at about sqrt(F / (m c))), excited by the centred start and by
  fast turns of the joint force; it averages out over a window but not at an instant.
- Energy balance with restitution 1 (no contact dissipation): the drive's work W (integrated
  with the state) equals the change of mechanical energy (kinetic + gravity + contact
  springs), to 1e-8 of the energy that flows through the drive.
- Convergence order of the integrator: the error of the state after one revolution against
  a tight-tolerance run falls in proportion to rtol (tolerance proportionality of the
  embedded Runge-Kutta pair, order ~1 in rtol); the four-bar, whose state after the start's
  impacts is sensitive, by its 4th revolution's peak. The four-bar's ideal limit is by
  window averages only (its sliding mode rides on the peak), over its first revolution.
- Each default's regime: the slider-cranks periodic (peaks agree between rtol 1e-10 and
  1e-11, events only in the first revolution, the peak repeating); the four-bar in
  continuous contact, not tolerance-sensitive, approaching its periodic orbit slowly.
"""

from __future__ import annotations

import numpy as np
import pytest

from mbs_clearance.generate.energy import mechanical_energy
from mbs_clearance.model.cases import four_bar, slider_crank_two_clearances

C_IDEAL = 1e-7          # m, the ideal-joint limit's clearance
#: per case: revolutions run, rtol, and where the compared windows start (in periods).
#: The four-bar runs one revolution at rtol 1e-8 (at rtol 1e-10 two revolutions reach
#: max_steps: the sliding mode at c = 1e-7 oscillates at ~ sqrt(F / (m c)) ~ 2e4 rad/s) and
#: is compared from 10 degrees on (the first window holds the journal's fall across the
#: clearance from the centred start); a second run at rtol 1e-7 shows that what remains
#: is not integration error.
IDEAL_SETTINGS = {
    "four_bar": dict(revolutions=1, rtol=1e-8, start=1 / 36, check_rtol=1e-7),
    "slider_crank_two_clearances": dict(revolutions=2, rtol=1e-10, start=1.0,
                                        check_rtol=None),
}
# (the rtol-proportionality test leaves the four-bar out: its end state after the start's
# impacts does not converge with rtol (errors 3.7e-4, 9.5e-3, 7.7e-3, 1.1e-2 at rtol 1e-6
# ... 1e-9 at 0.1 mm, measured with the v2 integrator); test_four_bar_default_regime shows
# its window averages converging instead)
N_WINDOWS = 36          # 10 degree windows of crank angle


def ideal_cases():
    return {
        "four_bar": four_bar(clearance=C_IDEAL),
        "slider_crank_two_clearances": slider_crank_two_clearances(
            crank_coupler_clearance=C_IDEAL, coupler_slider_clearance=C_IDEAL),
    }


def run(linkage, revolutions, **options):
    from mbs_clearance import simulate

    return simulate(linkage, revolutions, backend="reduced", **options)


def window_means(t, values, edges):
    """Time averages of `values` (n,) or (n, k) over the windows [edges[k], edges[k+1]]:
    trapezoidal rule on the samples inside, the window's ends linearly interpolated."""
    values = np.asarray(values, dtype=float)
    flat = values.reshape(len(t), -1)
    out = []
    for a, b in zip(edges[:-1], edges[1:]):
        inside = (t > a) & (t < b)
        tw = np.concatenate([[a], t[inside], [b]])
        vw = np.stack([np.concatenate([[np.interp(a, t, v)], v[inside], [np.interp(b, t, v)]])
                       for v in flat.T], axis=1)
        out.append(np.trapezoid(vw, tw, axis=0) / (b - a))
    return np.array(out).reshape((len(edges) - 1,) + values.shape[1:])


_IDEAL_RUNS: dict = {}


def ideal_run(name, rtol=None):
    """Case `name` at clearance 1e-7 m over IDEAL_SETTINGS[name]'s revolutions (at its
    rtol, or `rtol`), with the ideal model's outputs at the same times; run once per
    session."""
    from validation.ideal_linkage import from_linkage, ideal_outputs

    settings = IDEAL_SETTINGS[name]
    rtol = settings["rtol"] if rtol is None else rtol
    if (name, rtol) not in _IDEAL_RUNS:
        lk = ideal_cases()[name]
        traj = run(lk, settings["revolutions"], rtol=rtol)
        loop = from_linkage(lk)
        _IDEAL_RUNS[name, rtol] = (lk, traj, loop, ideal_outputs(loop, traj.t))
    return _IDEAL_RUNS[name, rtol]


def _compared(name, rtol=None):
    """(label, simulated, ideal) series of case `name`'s clearance-1e-7 run, the window
    edges compared, and the times."""
    lk, traj, loop, ref = ideal_run(name, rtol)
    settings = IDEAL_SETTINGS[name]
    P = lk.period
    start, end = settings["start"] * P, settings["revolutions"] * P
    edges = np.linspace(start, end, int(round((end - start) / P * N_WINDOWS)) + 1)
    pairs = [("drive moment", traj.crank_moment, ref["drive_moment"]),
             ("shaking", traj.shaking_force, ref["shaking"])]
    for joint, force in traj.reactions.items():
        pairs.append((f"{joint} reaction", force, ref["ground_reactions"][joint]))
    for j, joint in enumerate(traj.joints):
        pairs.append((f"{joint} contact", traj.contact_force[:, j],
                      np.hypot(*ref["joint_force"][joint].T)))
    return pairs, edges, traj.t


@pytest.mark.slow
# the four-bar's journal at 1e-7 m rattles: the run's note is about single peaks, and this
# compares window averages
@pytest.mark.filterwarnings("ignore::mbs_clearance.AccuracyWarning")
@pytest.mark.parametrize("name", ["four_bar", "slider_crank_two_clearances"])
def test_ideal_limit_window_averages(name):
    """Window averages (10 degrees of crank angle) of every ground reaction, the shaking
    force and the drive moment agree with the ideal model to 1e-3 of their peak over the
    compared span (IDEAL_SETTINGS); the clearance joints' contact forces with the ideal
    joint forces' magnitudes likewise (the sliding mode's centripetal part rides on a
    magnitude: measured 7.3e-4 for the four-bar's joint, 2e-5 ... 4e-5 for its reactions,
    shaking force and drive moment at rtol 1e-8). Four-bar: the same window averages at
    rtol 1e-7 differ from those at 1e-8 by less than 2e-4 of the peak (measured 8.6e-5 on
    the drive moment), a fifth of the tolerance at most: the comparison is not limited by
    integration error (at rtol 1e-8, by proportionality, ~1e-5: the size of the reactions'
    residual 2e-5 ... 4e-5, far below the joint force's 7.3e-4, which is the sliding
    mode's)."""
    pairs, edges, t = _compared(name)
    inside = (t >= edges[0]) & (t <= edges[-1])
    means = {}
    for label, sim, ideal in pairs:
        scale = np.max(np.abs(ideal[inside]))
        means[label] = window_means(t, sim, edges) / scale
        err = np.max(np.abs(means[label] - window_means(t, ideal, edges) / scale))
        assert err < 1e-3, f"{name} {label}: {err:.2e} of the peak"
    check = IDEAL_SETTINGS[name]["check_rtol"]
    if check is not None:
        pairs, edges, t = _compared(name, check)
        inside = (t >= edges[0]) & (t <= edges[-1])
        diffs = {}
        for label, sim, ideal in pairs:
            scale = np.max(np.abs(ideal[inside]))
            diffs[label] = np.max(np.abs(window_means(t, sim, edges) / scale - means[label]))
        assert max(diffs.values()) < 2e-4, f"{name}: rtol {check:g} vs the run: {diffs}"


@pytest.mark.slow
@pytest.mark.parametrize("name", ["slider_crank_two_clearances"])
def test_ideal_limit_peak_of_the_monitored_force(name):
    """The refined peak of the monitored force over the 2nd revolution against the ideal
    model's maximum (dense sampling refined by a bounded scalar search); the sliding mode
    rides on the peak, so the agreement is that of its amplitude (measured in the message).
    Not the four-bar: there the sliding mode's amplitude is of the order of the force
    itself (at c = 1e-7 m, rtol 1e-8, the pointwise |shaking| differs from the ideal by up
    to 2 x the ideal's peak over revolution 1, the peak is 92.5 N against the ideal
    31.7 N), so its peak measures the sliding mode, not the ideal limit; its window
    averages do (test_ideal_limit_window_averages)."""
    from scipy.optimize import minimize_scalar

    from validation.ideal_linkage import ideal_outputs

    lk, traj, loop, _ = ideal_run(name)
    P = lk.period

    def monitored(tt):
        o = ideal_outputs(loop, np.atleast_1d(tt))
        f = o["ground_reactions"][lk.monitor_joint] if lk.monitor_joint else o["shaking"]
        return np.hypot(f[:, 0], f[:, 1])

    tt = np.linspace(P, 2 * P, 7201)
    mag = monitored(tt)
    i = int(np.argmax(mag))
    res = minimize_scalar(lambda x: -monitored(x)[0], bounds=(tt[max(i - 1, 0)], tt[i + 1]),
                          method="bounded", options={"xatol": 1e-12 * P})
    ideal_peak = max(-res.fun, mag[i])
    rel = abs(traj.peaks[1] - ideal_peak) / ideal_peak
    assert rel < 5e-3, f"{name}: peak {traj.peaks[1]:.6g} vs ideal {ideal_peak:.6g}: {rel:.2e}"


def _mechanical_energy(lk, traj):
    """Kinetic + gravity + contact-spring energy along the run, from the generated model's
    own energy kernel at the recorded states (contact mode from the recorded phase)."""
    from mbs_clearance.generate import load_model
    from mbs_clearance.solve.linkage_model import pack_parameters

    model = load_model(lk)
    energy_of = mechanical_energy(lk)
    p = pack_parameters(lk, model)
    q = np.stack([traj.coordinates[c] for c in model.COORDINATES], axis=1)
    qd = np.stack([traj.rates[c] for c in model.COORDINATES], axis=1)
    y = np.concatenate([q, qd, traj.crank_work[:, None]], axis=1)
    energy = np.empty(len(traj.t))
    for i in range(len(traj.t)):
        for j in range(model.N_EVENTS):
            p[model.MEM_START + 2 * j] = float(traj.contact_phase[i, j])
        energy[i] = energy_of(traj.t[i], np.ascontiguousarray(y[i]), p)
    return energy


@pytest.mark.slow
@pytest.mark.parametrize("case, revolutions", [
    (lambda: four_bar(restitution=1.0), 1),
    (lambda: slider_crank_two_clearances(restitution=1.0), 2),
], ids=["four_bar", "slider_crank_two_clearances"])
def test_energy_balance_with_restitution_one(case, revolutions):
    """W(t) = E(t) - E(0) over two revolutions (the four-bar: one, of 6 s, whose journal
    bounces for the whole revolution at e = 1): the contact law is conservative at e = 1,
    so any difference is integration error; relative to the largest |W| (the energy that
    flows through the drive)."""
    lk = case()
    traj = run(lk, revolutions, rtol=1e-11)
    energy = _mechanical_energy(lk, traj)
    W = traj.crank_work
    scale = np.max(np.abs(W))
    assert scale > 0.0
    err = np.max(np.abs(W - (energy - energy[0])))
    assert err < 1e-8 * scale, f"energy balance off by {err / scale:.2e} of max |W|"
    assert traj.contact_phase.any()          # the balance went through contact phases


@pytest.mark.slow
@pytest.mark.parametrize("case", [slider_crank_two_clearances],
                         ids=["slider_crank_two_clearances"])
def test_error_falls_in_proportion_to_rtol(case):
    """Error of the coordinates and rates at the end of one revolution against rtol 1e-12:
    the log-log slope over rtol = 1e-6 ... 1e-9 is that of tolerance proportionality (an
    embedded pair with local extrapolation: global error ~ rtol^1; 0.7 ... 1.3 allows for
    the step-size controller's discrete choices), and the error at rtol 1e-9 is below
    1e-6 of the state's scale."""
    lk = case()

    def end_state(rtol):
        traj = run(lk, 1, rtol=rtol)
        names = sorted(traj.coordinates)
        return np.array([traj.coordinates[c][-1] for c in names]
                        + [traj.rates[c][-1] for c in names]), traj.t[-1]

    ref, t_ref = end_state(1e-12)
    rtols = np.array([1e-6, 1e-7, 1e-8, 1e-9])
    errs = []
    for rtol in rtols:
        y, t_end = end_state(rtol)
        assert t_end == t_ref
        errs.append(np.max(np.abs(y - ref) / (np.abs(ref) + 1e-3 * np.max(np.abs(ref)))))
    errs = np.array(errs)
    slope = np.polyfit(np.log(rtols), np.log(errs), 1)[0]
    assert 0.7 < slope < 1.3, f"errors {errs} at rtol {rtols}: slope {slope:.2f}"
    assert errs[-1] < 1e-6


def _coordinate_values(names, model, ref, i):
    """The ideal reference's values of the model's COORDINATES at sample i (absolute body
    angles, floating bodies' centres, slider coordinate) and their rates and accelerations."""
    q, qd, qdd = [], [], []
    for c in model.COORDINATES:
        body, _, coord = c.rpartition(".")
        if coord == "angle":
            k = names.index(body)
            q.append(ref["angles"][i, k])
            qd.append(ref["rates"][i, k])
            qdd.append(ref["accelerations"][i, k])
        elif coord in ("x", "y"):
            k, a = names.index(body), "xy".index(coord)
            q.append(ref["centres"][i, k, a])
            qd.append(ref["velocities"][i, k, a])
            qdd.append(ref["acc_centres"][i, k, a])
        else:
            q.append(ref["slider_position"][i])
            qd.append(ref["slider_rate"][i])
            qdd.append(ref["slider_acceleration"][i])
    return np.array(q), np.array(qd), np.array(qdd)


@pytest.mark.parametrize("name", ["four_bar", "slider_crank_two_clearances"])
def test_generated_dynamics_loaded_by_the_ideal_joint_forces(name):
    """No integration: at 24 instants of a revolution, put every journal where the ideal
    joint force would press it (eccentricity (c + delta) against the force, K delta^1.5 =
    |F|, penetration rate 0, contact mode, restitution 1) and the bodies at the ideal pose
    and rates. The generated model must then give the ideal accelerations, ground reactions,
    shaking force and drive moment (Newton-Euler of validation/ideal_linkage.py), up to the
    effect of the journals' offsets e = c + delta on the pose, ~ e / length, and of the
    rounding of delta (a difference of positions of order the link length).
    Four-bar at 60 rpm (inertia forces ~ 220 N; at the default 10 rpm the accelerations are
    36x smaller while the offsets' effect is not, 2.5e-6): c = 1e-8 m, steel (delta ~ 2e-8
    m): measured <= 1.1e-7 (at c = 1e-7: 6.3e-7, in proportion to c, so it is the offsets,
    not the equations). Slider-crank: its
    coupler turns by ~ 2 e / L3 and its end forces (~8 kN, nearly along it) then have a
    moment ~ e F about its centre against an inertia of only 2.5e-4 kg m^2: at c = 1e-7 m
    and steel (delta = 1.4e-6 m) the coupler angle's acceleration differs by 5e-5 of its
    scale, as that estimate predicts; so c = 1e-9 m and a 1000x stiffer material
    (E = 2.07e14 Pa, delta ~ 4e-9 m): measured <= 1.7e-7. Tolerance 1e-6 of each quantity's
    scale."""
    from mbs_clearance.generate import load_model
    from mbs_clearance.solve.linkage_model import pack_parameters
    from validation.ideal_linkage import from_linkage, ideal_outputs

    c, stiff = 1e-9, dict(youngs_modulus=2.07e14, restitution=1.0)
    lk = {"four_bar": four_bar(clearance=1e-8, restitution=1.0, crank_speed=2 * np.pi),
          "slider_crank_two_clearances": slider_crank_two_clearances(
              crank_coupler_clearance=c, coupler_slider_clearance=c, **stiff)}[name]
    model = load_model(lk)
    p = pack_parameters(lk, model)
    loop = from_linkage(lk)
    third = "rocker" if name == "four_bar" else "slider"
    names = ("crank", "coupler", third)
    t = lk.period * np.arange(24) / 24.0
    ref = ideal_outputs(loop, t)
    col = {k: i for i, k in enumerate(model.OUT_COLUMNS)}
    joints = {j.name: j for j in lk.clearance_joints}
    ys, ms, acc_err, acc_scale = [], [], [], []
    for i, ti in enumerate(t):
        q, qd, qdd_ideal = _coordinate_values(names, model, ref, i)
        target = []
        for jn in model.JOINTS:
            cj = joints[jn]
            f = ref["joint_force"][jn][i]      # on the later body of the loop
            later = names.index(cj.journal_body) > names.index(cj.bearing_body)
            on_journal = f if later else -f
            mag = np.hypot(*on_journal)
            delta = (mag / cj.stiffness) ** (2.0 / 3.0)
            target.extend(-(cj.clearance + delta) * on_journal / mag)
        target = np.array(target)
        for _ in range(20):                    # Newton: journal offsets = target
            res = model.closure(ti, q, p) - target
            q = q - np.linalg.solve(model.closure_jacobian(ti, q, p), res)
        assert np.max(np.abs(model.closure(ti, q, p) - target)) < 1e-15
        qd = np.linalg.solve(model.closure_jacobian(ti, q, p), -model.closure_rate(ti, q, p))
        for j in range(model.N_EVENTS):
            p[model.MEM_START + 2 * j] = 1.0
        y = np.concatenate([q, qd, [0.0]])
        dydt = np.empty(model.N_STATE)
        model.rhs(ti, y, p, dydt)
        acc_err.append(np.abs(dydt[model.N_Q:2 * model.N_Q] - qdd_ideal))
        acc_scale.append(np.abs(qdd_ideal))
        ys.append(y)
        ms.append(p[model.MEM_START:model.MEM_START + model.N_MEM].copy())
    acc_err, acc_scale = np.array(acc_err), np.array(acc_scale)
    rel = acc_err.max(axis=0) / acc_scale.max(axis=0)
    assert np.all(rel < 1e-6), dict(zip(model.COORDINATES, rel))
    out = model.outputs(t, np.array(ys), np.array(ms), p)
    checks = [("drive_moment", out[:, col["drive_moment"]], ref["drive_moment"]),
              ("shaking", out[:, [col["shaking_x"], col["shaking_y"]]], ref["shaking"])]
    for g in model.GROUND_JOINTS:
        checks.append((g, out[:, [col[f"{g}.reaction_x"], col[f"{g}.reaction_y"]]],
                       ref["ground_reactions"][g]))
    for jn in model.JOINTS:
        checks.append((jn, out[:, col[f"{jn}.contact_force"]],
                       np.hypot(*ref["joint_force"][jn].T)))
    for label, got, want in checks:
        err = np.max(np.abs(got - want)) / np.max(np.abs(want))
        assert err < 1e-6, f"{name} {label}: {err:.2e}"


# ------------------------------------------------------------- each default's regime
# (docs/cases.md "Regime of the defaults"; python -m validation.regime_scan NAME 8 adaptive
# 1e-10,1e-11 prints the same measurements)

@pytest.mark.slow
@pytest.mark.parametrize("name, revolutions, settled", [
    ("paper_slider_crank", 8, 5e-7),
    ("slider_crank_two_clearances", 6, 1e-8),
])
def test_slider_crank_defaults_are_periodic(name, revolutions, settled):
    """Periodic regime of the default operating point: the peaks per revolution agree
    between rtol 1e-10 and 1e-11 (not tolerance-sensitive; measured <= 1.5e-9 from
    revolution 2 on), every contact event falls in the first revolution (the centred
    start's impacts; then continuous contact: the same pattern, none, in every
    revolution), and the peak repeats from one revolution to the next within `settled`
    at the last revolution (measured: paper 4.7e-8 at revolution 8, two joints 1.4e-9 at
    revolution 6), the change shrinking revolution by revolution (a stable orbit)."""
    from mbs_clearance.model.cases import CASES
    from validation.regime_scan import adaptive_peaks, periodicity

    lk = CASES[name]()
    runs = [adaptive_peaks(lk, revolutions, rtol) for rtol in (1e-10, 1e-11)]
    per = periodicity(runs)
    assert per["later_events"] == [0, 0]
    assert np.all(per["between_rtols"][1:] < 1e-8), per["between_rtols"]
    change = per["rev_to_rev"][2:]
    assert change[-1] < settled, change
    assert np.all(change[1:] < change[:-1] * 1.01), change


@pytest.mark.slow
def test_four_bar_default_regime():
    """The four-bar's default (10 rpm, 0.01 mm, e = 0.9), 4 revolutions at rtol 1e-10 and
    1e-11: every contact event in the first revolution (the centred start; then continuous
    contact), the peaks of revolutions 2-4 the same at both rtols (not
    tolerance-sensitive: measured <= 1.4e-6), while the peak still falls from revolution to
    revolution, the change shrinking (measured 1.2e-2, 5.5e-3 at revolutions 3, 4): the
    frictionless joint's sliding mode, excited by the start, decays slowly: the motion
    approaches a periodic orbit without reaching it (docs/cases.md). At the old default
    0.1 mm the same peaks differ by 1.5e-4 ... 2.6e-4 between these rtols."""
    from validation.regime_scan import periodicity

    runs = [four_bar_peaks(rtol) for rtol in (1e-10, 1e-11)]
    per = periodicity(runs)
    assert per["later_events"] == [0, 0]
    assert np.all(per["between_rtols"][1:] < 1e-5), per["between_rtols"]
    peaks, change = runs[1]["peaks"], per["rev_to_rev"][2:]
    assert np.all(np.diff(peaks[1:]) < 0) and change[1] < change[0], (peaks, change)


_FOUR_BAR_PEAKS: dict = {}


def four_bar_peaks(rtol):
    """`regime_scan.adaptive_peaks` of the default four-bar over 4 revolutions at `rtol`,
    run once per session."""
    from validation.regime_scan import adaptive_peaks

    if rtol not in _FOUR_BAR_PEAKS:
        _FOUR_BAR_PEAKS[rtol] = adaptive_peaks(four_bar(), 4, rtol)
    return _FOUR_BAR_PEAKS[rtol]


@pytest.mark.slow
def test_four_bar_peak_converges_with_rtol():
    """Convergence of the integrator on the four-bar, whose end state after the start's
    impacts is sensitive (the number of start impacts changes with rtol: 59, 523, 315, 331,
    325, 325 at rtol 1e-6 ... 1e-11): the 4th revolution's refined peak against rtol 1e-11
    falls with rtol from 1e-6 to 1e-8 at least in proportion to it (measured errors 2.3e-3,
    1.0e-4, 1.7e-6: log-log slope 1.6; 0.7 ... 2.2 allowed) and stays below 1e-5 at 1e-9.
    Finer than 1e-8 the peaks scatter at a few 1e-6 with the start impacts' sequence, and
    the reference with them: at rtol 1e-9 and 1e-10 against 1e-11, 3.0e-6 and 1.0e-7 (event
    margin 0.001 c) or 3.0e-7 and 2.2e-6 (a margin of 0.05 c), on one machine; 3.5e-7 and
    7e-8 on another with 0.05 c."""
    ref = four_bar_peaks(1e-11)["peaks"][3]
    rtols = np.array([1e-6, 1e-7, 1e-8])
    errs = np.array([abs(four_bar_peaks(r)["peaks"][3] / ref - 1.0) for r in rtols])
    assert np.all(np.diff(errs) < 0), errs
    slope = np.polyfit(np.log(rtols), np.log(errs), 1)[0]
    assert 0.7 < slope < 2.2, (errs, slope)
    fine = abs(four_bar_peaks(1e-9)["peaks"][3] / ref - 1.0)
    assert fine < 1e-5, fine
