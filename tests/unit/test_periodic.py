"""Periodic orbits by shooting and their Floquet multipliers, each checked against an
independent reference: central differences of the return map, the Lyapunov exponent of a
long run, the section a long run of the regime map's flow settles on, and the growth of a
run started on an unstable orbit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mbs_clearance import SliderCrank, continue_orbits, lyapunov_exponent, periodic_orbit
from mbs_clearance.analysis.periodic import return_map
from mbs_clearance.analysis.poincare import Flow, poincare_section
from validation.four_bar_orbit_checks import central_differences, flow_sections

PAPER = SliderCrank()                                       # 0.01 mm, 5000 rpm
#: 0.15 mm at 5000 rpm: the regime map's run is aperiodic there (no recurrence within 1e-3
#: of the clearance over 50 revolutions), its period-1 orbit unstable
LOOSE = PAPER.replace(journal_radius=PAPER.bearing_radius - 1.5e-4)


@pytest.fixture(scope="module")
def paper_orbit():
    # from 3 settling revolutions: Newton has work to do (residual 2.5e-3 of the clearance)
    return periodic_orbit(PAPER, settle=3)


def _mem_index(mech):
    from mbs_clearance.solve import reduced

    return reduced.MEM_START


def _central_differences(orbit, h=1e-4, rtol=1e-12):
    """The return map's derivative by central differences of its plain runs, in the
    scaled variables of the monodromy matrix (state, then the joint's impact velocity)."""
    n2 = len(orbit.state)
    scale = orbit.scale
    J = len(orbit.modes)
    vscale = PAPER.clearance * PAPER.crank_speed
    full_scale = np.concatenate([scale[:n2], np.full(J, vscale)])
    F = np.empty((n2 + J, n2 + J))
    for k in range(n2 + J):
        ends = []
        for sign in (1.0, -1.0):
            x = orbit.state.copy()
            v = orbit.impact_velocities.copy()
            if k < n2:
                x[k] += sign * h * full_scale[k]
            else:
                v[k - n2] += sign * h * full_scale[k]
            xe, _, ve, _ = return_map(orbit.mech, x, orbit.modes, v, rtol=rtol)
            ends.append(np.concatenate([xe, ve]) / full_scale)
        F[:, k] = (ends[0] - ends[1]) / (2 * h)
    return F


def test_multipliers_match_central_differences_of_the_return_map(paper_orbit):
    """The monodromy matrix of the variational run (state and memory columns) against
    central differences of the plain map: steps 1e-4 of the scales (clearances), rtol 1e-12;
    measured agreement 1.2e-5 of the largest entry (5.8), the differences' truncation and
    the runs' error."""
    orbit = paper_orbit
    *_, M = return_map(orbit.mech, orbit.state, orbit.modes, orbit.impact_velocities,
                       rtol=1e-12, jacobian=True)
    F = _central_differences(orbit)
    np.testing.assert_allclose(M, F, atol=1e-3 * np.max(np.abs(F)))
    # permanent contact: the memory is never overwritten, its multiplier exactly 1, so the
    # orbit's multipliers are those of the mechanical state (the module docstring)
    assert orbit.onsets.tolist() == [0] and orbit.modes.tolist() == [1.0]
    np.testing.assert_array_equal(M[-1], [0.0, 0.0, 0.0, 0.0, 1.0])
    np.testing.assert_allclose(np.sort_complex(orbit.multipliers),
                               np.sort_complex(np.linalg.eigvals(F[:4, :4])), atol=2e-3)


def test_largest_multiplier_is_the_lyapunov_exponent_of_a_long_run(paper_orbit):
    """On a stable period-1 orbit the largest exponent per revolution (Benettin's method
    over 100 revolutions, memory reset: a separate run and code path) is log |mu_max|;
    measured -1.712689 against -1.712689."""
    orbit = paper_orbit
    assert orbit.stability == "stable" and orbit.iterations >= 2
    assert orbit.residual <= 1e-6
    lam = lyapunov_exponent(PAPER).per_revolution
    assert math.log(orbit.spectral_radius) == pytest.approx(lam, rel=1e-3)


def test_paper_orbit_is_the_section_a_long_run_settles_on(paper_orbit):
    """100 revolutions of the regime map's plain flow (dopri5, from the centred start)
    end on the orbit found by shooting from 3 settling revolutions (dop853): measured
    within 8.7e-7 of the scales (clearances; clearance x speed for rates)."""
    orbit = paper_orbit
    flow = Flow(PAPER, rtol=1e-10)
    for k in range(100):
        flow.advance((k + 1) * PAPER.period)
    diff = (flow.y[:4] - orbit.state) / orbit.scale[:4]
    assert np.max(np.abs(diff)) < 1e-5
    mem = _mem_index(PAPER)
    # the same last contact onset (in the start-up): the same stored impact velocity, to
    # the two integrators' error (measured 8e-10 relative)
    assert flow.p[mem + 1] == pytest.approx(orbit.impact_velocities[0], rel=1e-6)
    # the orbit's Trajectory (a run of the paper's linkage from the orbit's state through
    # `simulate`) ends where it started
    traj = orbit.trajectory
    assert traj.t[-1] == pytest.approx(PAPER.period)
    for i, name in enumerate(traj.coordinates):
        series = traj.coordinates[name]
        assert series[0] == pytest.approx(orbit.state[i], abs=1e-9 * orbit.scale[i])
        assert series[-1] == pytest.approx(series[0], abs=1e-4 * orbit.scale[i])


def test_unstable_orbit_where_the_simulation_does_not_settle():
    """At 0.15 mm the regime map's run is aperiodic; shooting finds the period-1 orbit with
    a multiplier outside the unit circle (measured -2.527). Started on it (and on it plus
    1e-6 along its unstable eigenvector), the regime map's flow leaves it: the deviation at
    the section grows by |mu_max| per revolution (measured 2.52-2.53 over revolutions 4-12)."""
    sec = poincare_section(LOOSE, 100, 50)
    assert sec.regime not in ("period_1", "period_k")
    orbit = periodic_orbit(LOOSE, settle=60, trajectory=False, max_iterations=20)
    assert orbit.stability == "unstable"
    mu = orbit.multipliers[0]
    assert abs(mu) > 1.5
    w, V = np.linalg.eig(orbit.monodromy)
    v = np.real(V[:, np.argmax(np.abs(w))])
    v /= np.max(np.abs(v))
    mem = _mem_index(LOOSE)
    for eps in (0.0, 1e-6):
        flow = Flow(LOOSE, rtol=1e-11)
        flow.y[:4] = orbit.state + eps * v[:4] * orbit.scale[:4]
        flow.p[mem] = orbit.modes[0]
        flow.p[mem + 1] = orbit.impact_velocities[0]
        dev = []
        for k in range(12):
            flow.advance((k + 1) * LOOSE.period)
            dev.append(np.max(np.abs((flow.y[:4] - orbit.state) / orbit.scale[:4])))
        dev = np.array(dev)
        rate = (dev[11] / dev[3]) ** (1 / 8)
        assert rate == pytest.approx(abs(mu), rel=0.02)
        assert dev[-1] > 1e3 * max(dev[0], 1e-9)


@pytest.mark.parametrize("kwargs, message", [
    (dict(period=0), "period"),
    (dict(tol=0.0), "tol"),
    (dict(rtol=1e-2), "rtol"),
    (dict(max_iterations=0), "max_iterations"),
    (dict(guess=(np.zeros(3), [1.0], [0.1])), "state must be 4 finite numbers"),
    (dict(guess=(np.zeros(4), [0.5], [0.1])), "modes must be 1 values 0"),
    (dict(guess=(np.zeros(4), [1.0], [-1.0])), "impact_velocities"),
    (dict(guess="settled"), "guess must be"),
])
def test_bad_input_is_refused_before_computing(kwargs, message, monkeypatch):
    from mbs_clearance.analysis import periodic

    monkeypatch.setattr(periodic, "_newton", lambda *a, **k: pytest.fail("ran"))
    monkeypatch.setattr(periodic._Shooter, "jacobian", lambda *a, **k: pytest.fail("ran"))
    with pytest.raises(ValueError, match=message):
        periodic_orbit(PAPER, **kwargs)


def test_bad_input_of_the_continuation_is_refused_before_computing(monkeypatch):
    from mbs_clearance.analysis import periodic

    monkeypatch.setattr(periodic, "periodic_orbit", lambda *a, **k: pytest.fail("ran"))
    with pytest.raises(ValueError, match="unknown"):
        continue_orbits(PAPER, "no_such_field", 1e-5, 2e-5)
    with pytest.raises(ValueError, match="start and stop must differ"):
        continue_orbits(PAPER, "clearance", 1e-5, 1e-5)
    with pytest.raises(ValueError, match="clearance"):
        continue_orbits(PAPER, "clearance", 1e-5, 1.0)
    with pytest.raises(ValueError, match="mech must be"):
        periodic_orbit("paper")


def test_no_convergence_says_what_to_try():
    # from the centred start (no settling) one iteration cannot reach the orbit
    with pytest.raises(RuntimeError, match="try a guess from a settled run"):
        periodic_orbit(PAPER, settle=0, max_iterations=1, trajectory=False)


@pytest.fixture(scope="module")
def paper_branch():
    # 260 orbits along clearance from the paper's design, through its first period
    # doublings (224 orbits to the first)
    return continue_orbits(PAPER, "clearance", 1e-5, 2e-5, step=0.1, max_step=3.0,
                           max_points=260)


@pytest.mark.slow
def test_period_doublings_of_the_branch_are_where_plain_shooting_sees_minus_one(
        paper_branch):
    """Each period doubling located by bisection on the arclength (to +- 3e-10 m measured)
    is confirmed by plain shooting (no arclength, no bisection) at 20 tolerances either
    side, from the branch's orbit there: the multiplier nearest -1 lies on opposite sides
    of -1. Measured: doublings at 0.0121101 and 0.0121885 mm."""
    branch = paper_branch
    doublings = [p for p in branch.points if p.kind == "period_doubling"]
    assert doublings
    for p in doublings:
        assert p.tolerance < 1e-4 * p.value
        i = p.index
        guess = (branch.states[i], np.ones(1), branch.impact_velocities[i])
        sides = []
        for sign in (-1.0, 1.0):
            c = p.value + sign * 20 * max(p.tolerance, 1e-12)
            mech = PAPER.replace(journal_radius=PAPER.bearing_radius - c)
            orbit = periodic_orbit(mech, guess=guess, trajectory=False, max_iterations=20)
            mu = orbit.multipliers
            real = mu[np.abs(mu.imag) < 1e-9].real
            sides.append(real[np.argmin(np.abs(real + 1.0))])
        assert (sides[0] + 1.0) * (sides[1] + 1.0) < 0.0, sides


@pytest.mark.slow
def test_branch_points_are_orbits_of_the_map(paper_branch):
    """Every orbit of the branch is a fixed point of the plain map at its clearance (rtol
    as the shooting's) to the Newton tolerance, and its stability is the multipliers'."""
    from mbs_clearance.analysis.periodic import with_field

    branch = paper_branch
    for i in range(0, len(branch.values), 17):
        mech = with_field(PAPER, "clearance", branch.values[i])
        xe, me, ve, _ = return_map(mech, branch.states[i], np.ones(1),
                                   branch.impact_velocities[i])
        scale = np.concatenate([[PAPER.clearance / PAPER.coupler_length, PAPER.clearance],
                                PAPER.crank_speed * np.array([
                                    PAPER.clearance / PAPER.coupler_length,
                                    PAPER.clearance])])
        assert np.max(np.abs((xe - branch.states[i]) / scale)) < 1e-5
        mu = branch.multipliers[i]
        assert branch.stable[i] == bool(np.nanmax(np.abs(mu)) < 1.0)


@pytest.mark.slow
def test_switch_at_a_period_doubling_gives_orbits_of_period_two(paper_branch):
    """The branch born at the first period doubling (`switch_branch`): each of its orbits,
    run through the plain map (not the continuation's corrector), is back after two
    revolutions (to 1e-5 of the scales) and not after one (a period-1 orbit would be,
    to 1e-6); at its start its multipliers are the squares of the period-1 orbit's at the
    doubling (-1 squared: +1)."""
    from mbs_clearance.analysis.periodic import switch_branch, with_field

    branch = paper_branch
    pd = next(p for p in branch.points if p.kind == "period_doubling")
    doubled = switch_branch(branch, pd, max_points=6)
    assert doubled.period == 2 and len(doubled.values) >= 3
    np.testing.assert_allclose(np.sort(np.abs(doubled.multipliers[0])),
                               np.sort(np.abs(pd.multipliers) ** 2), atol=0.05)
    scale = np.array([PAPER.clearance / PAPER.coupler_length, PAPER.clearance])
    scale = np.concatenate([scale, PAPER.crank_speed * scale])
    for i in range(len(doubled.values)):
        mech = with_field(PAPER, "clearance", doubled.values[i])
        x, v = doubled.states[i], doubled.impact_velocities[i]
        x1, m1, v1, _ = return_map(mech, x, np.ones(1), v)
        x2, _, _, _ = return_map(mech, x1, m1, v1)
        assert np.max(np.abs((x2 - x) / scale)) < 1e-5
        assert np.max(np.abs((x1 - x) / scale)) > 1e-4


@pytest.mark.slow
def test_brute_force_from_the_branch_loses_period_one_at_the_located_doubling(paper_branch):
    """The regime map's rule (100 revolutions, 50 kept, rtol 1e-7) on plain runs started
    on the branch's orbit below the first doubling (its state and held impact velocity):
    period-1 10 nm before the located doubling, period-2 10 nm after it (measured on a
    5 nm grid: period-1 up to -5 nm, period-2 from the doubling itself)."""
    from mbs_clearance.analysis.periodic import with_field
    from mbs_clearance.analysis.poincare import classify, scale_samples, section_times

    branch = paper_branch
    pd = next(p for p in branch.points if p.kind == "period_doubling")
    below = (branch.values < pd.value) & (np.arange(len(branch.values)) <= pd.index)
    i = int(np.argmin(np.where(below, pd.value - branch.values, np.inf)))
    regimes = []
    for c in (pd.value - 1e-8, pd.value + 1e-8):
        mech = with_field(PAPER, "clearance", c)
        flow = Flow(mech)
        mem = _mem_index(mech)
        flow.y[:4] = branch.states[i]
        flow.p[mem:mem + 2] = 1.0, branch.impact_velocities[i, 0]
        samples = []
        for k, t in enumerate(section_times(mech, 100)):
            flow.advance(t)
            if k >= 50:
                samples.append(flow.section())
        regimes.append(classify(scale_samples(np.array(samples), flow.clearance,
                                              flow.omega))[:2])
    assert regimes == [("period_1", 1), ("period_k", 2)]


def test_switch_branch_refuses_a_point_that_is_not_a_doubling_of_the_branch():
    from mbs_clearance.analysis.periodic import Branch, BranchPoint, switch_branch

    fold = BranchPoint(kind="fold", value=1e-5, tolerance=1e-9, multipliers=np.ones(1))
    with pytest.raises(ValueError, match="Branch returned by continue_orbits"):
        switch_branch("branch", fold)
    branch = Branch(field="clearance", values=np.ones(1), states=np.ones((1, 4)),
                    impact_velocities=np.ones((1, 1)), multipliers=np.ones((1, 1)),
                    stable=np.ones(1, bool), onsets=np.zeros((1, 1)), points=[fold],
                    stopped="", setup={"mech": PAPER})
    with pytest.raises(ValueError, match="period doublings"):
        switch_branch(branch, fold)


def test_cli_orbits_prints_the_python_functions_multipliers(paper_orbit, capsys):
    """`orbits` prints the stability and the multipliers of `periodic_orbit` for the same
    design (the paper's by default; its default guess, 20 settling revolutions)."""
    import re

    from mbs_clearance.cli import main

    assert main(["orbits"]) == 0
    out = capsys.readouterr().out
    assert "period-1 orbit of the paper's slider-crank: stable" in out
    printed = [float(v) for v in re.findall(r"\|mu\| = (\S+)", out)]
    np.testing.assert_allclose(printed[:2], np.abs(paper_orbit.multipliers[:2]), rtol=1e-4)
    # magnitude and angle, not a complex number's repr; coordinates with units; the joint
    # by its name
    assert "j " not in out and "+0j" not in out
    mu = paper_orbit.multipliers[0]
    angle = float(re.search(r"angle ([-+]\d+\.\d) deg", out).group(1))
    assert angle == pytest.approx(math.degrees(np.angle(mu)), abs=0.051)
    state = out[out.index("state at the section:"):out.index("Floquet")].splitlines()[1:]
    coordinates = [line for line in state if not line.strip().startswith("joint")]
    assert len(coordinates) == len(paper_orbit.state)
    assert all(line.split()[-1] in ("m", "rad", "m/s", "rad/s") for line in coordinates)
    from mbs_clearance.solve.flows import joints_of

    assert f"joint {joints_of(paper_orbit.mech)[0]!r}: " in out and "joint 0" not in out


@pytest.mark.parametrize("argv, message", [
    (["--field", "clearance", "--start", "1e-5"], "--field, --start and --stop go together"),
    (["--plot", "x.png"], "--plot and --map draw a branch"),
    (["--period", "0"], "argument --period: must be an integer >= 1; got 0"),
])
def test_cli_orbits_bad_input_is_one_line_before_any_run(argv, message, capsys,
                                                          monkeypatch):
    from mbs_clearance.analysis import periodic
    from mbs_clearance.cli import main

    monkeypatch.setattr(periodic, "periodic_orbit", lambda *a, **k: pytest.fail("ran"))
    monkeypatch.setattr(periodic, "continue_orbits", lambda *a, **k: pytest.fail("ran"))
    with pytest.raises(SystemExit) as exc:
        main(["orbits", *argv])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


def test_cli_orbits_branch_writes_the_diagram(tmp_path, capsys):
    """A short branch over clearance: the summary line and the diagram's file."""
    from mbs_clearance.cli import main

    plot = tmp_path / "branch.png"
    assert main(["orbits", "--field", "clearance", "--start", "1e-5", "--stop", "1.01e-5",
                 "--max-points", "4", "--plot", str(plot)]) == 0
    out = capsys.readouterr().out
    assert "branch over clearance: 4 orbits of period 1" in out
    assert plot.stat().st_size > 10_000


def test_branch_over_crank_speed_runs_through_the_regime_maps_samples():
    """Continuation over crank speed (5000 - 5100 rpm, smooth and stable: 41 orbits) and
    the brute-force map at 5050 rpm (40 revolutions from the centred start, rtol 1e-10):
    the orbit shot there from the branch's nearest orbit has the map's section within 1e-3
    clearances in position and 1e-2 in rate (measured 1.8e-4 and 1.2e-3: the map's run
    settles on its own memory, 0.2540 m/s against the branch's held 0.2524)."""
    from mbs_clearance import regime_map
    from mbs_clearance.analysis.periodic import with_field

    speed = 5050 * math.pi / 30
    branch = continue_orbits(PAPER, "crank_speed", PAPER.crank_speed, 5100 * math.pi / 30,
                             max_points=80)
    assert branch.stopped == "reached stop" and branch.stable.all() and not branch.points
    ds = regime_map(PAPER, ["crank_speed=5050rpm"], revolutions=40, keep=9, max_period=4,
                    workers=1, rtol=1e-10).dataset
    assert int(ds["regime"].values[0]) == 2                 # period-1
    i = int(np.argmin(np.abs(branch.values - speed)))
    mech = with_field(PAPER, "crank_speed", speed)
    orbit = periodic_orbit(mech, guess=(branch.states[i], np.ones(1),
                                        branch.impact_velocities[i]), trajectory=False)
    flow = Flow(mech)
    flow.y[:4] = orbit.state
    mem = _mem_index(mech)
    flow.p[mem:mem + 2] = orbit.modes[0], orbit.impact_velocities[0]
    diff = (ds["section"].values[0, -1, 0] - flow.section()[0]) / (
        PAPER.clearance * np.array([1.0, 1.0, speed, speed]))
    assert np.max(np.abs(diff[:2])) < 1e-3
    assert np.max(np.abs(diff[2:])) < 1e-2


def test_tangent_turns_back_only_where_det_of_m_minus_i_changes_sign():
    """The continuation's tangent, oriented by the sign of det([Jg; t]), against closed
    forms. (a) P(z, u) = z + u - z^2: fixed points u = z^2, det(P' - I) = -2 z, a fold at
    z = 0, where (and only where) t_u must change sign. (b) A branch
    with multipliers 0 (det(P' - I) = 1, never a fold) whose state turns by more than a right
    angle over one step: t_u keeps its sign (orienting along the previous tangent flips it:
    the false fold)."""
    from mbs_clearance.analysis.periodic import _orientation, _tangent_of

    # (a) the fold of P(z, u) = z + u - z^2 (fixed points u = z^2) at z = 0
    def jac(z):
        return np.array([[-2.0 * z, 1.0]])          # [P_z - 1, P_u]

    zs = np.linspace(-1.0, 1.0, 21)
    t = _tangent_of(jac(zs[0]), np.array([1.0, 0.0]))
    o = _orientation(jac(zs[0]), t)
    signs = []
    for z in zs:
        t = _tangent_of(jac(z), t, o)
        # closed form: the null vector of [-2 z, 1] is (1, 2 z) / norm
        np.testing.assert_allclose(abs(t[1]), abs(2 * z) / math.hypot(1.0, 2 * z))
        signs.append(np.sign(t[1]) if z != 0.0 else 0.0)
    signs = np.array(signs)
    assert np.all(signs[zs < 0] == signs[0]) and np.all(signs[zs > 0] == -signs[0])
    # (b) P(z, u) = b(u) u-derivative rotating by 150 degrees per step, P_z = 0 (A - I = -I)
    t = np.array([0.0, 0.0, 1.0])
    for k, ang in enumerate(np.radians(np.arange(0.0, 900.0, 150.0))):
        b = 50.0 * np.array([math.cos(ang), math.sin(ang)])
        Jg = np.hstack([-np.eye(2), b[:, None]])
        if k == 0:
            t = _tangent_of(Jg, t)
            o = _orientation(Jg, t)
        flip = _tangent_of(Jg, t)                     # along the previous tangent only
        t = _tangent_of(Jg, t, o)
        np.testing.assert_allclose(t[:2], b * t[2], atol=1e-12)   # t_z = (I - P_z)^-1 P_u t_u
        assert t[2] > 0.0
        if k:
            assert flip[2] < 0.0


#: the four-bar's map is computed to about 1e-4 of the scales (its runs at rtol 1e-10,
#: 1e-11 and 1e-12 differ by up to 3.2e-4 in the rates; Newton stalls at 7e-5 - 1.2e-4
#: whatever the rtol): a Newton tolerance above that error
FOUR_BAR_TOL = 5e-4


@pytest.fixture(scope="module")
def four_bar_orbit():
    from mbs_clearance.model import cases

    # the default guess: 20 settling revolutions, smoothed (module docstring, "The guess")
    return periodic_orbit(cases.four_bar(), tol=FOUR_BAR_TOL, trajectory=False)


@pytest.mark.slow
def test_four_bar_orbit_is_where_a_long_run_settles(four_bar_orbit):
    """The four-bar (10 rpm) from its default guess: Newton converges (measured 3
    iterations, residual 1.0e-4), stable, multipliers 0.966 +- 0.141i (the weakly damped
    vibration of the joint) and two near 0. The regime map's flow (dopri5, rtol 1e-10,
    from the centred start) settles on it: the mean of its sections over revolutions
    101-150 lies within 2e-3 of the scales of the orbit in position and 0.5 in rate (the
    run's sections still scatter about it; `python -m validation.four_bar_orbit_checks`
    prints the measured differences and scatter, also over revolutions 161-200)."""
    from mbs_clearance.model import cases

    orbit = four_bar_orbit
    assert orbit.stability == "stable" and orbit.residual <= FOUR_BAR_TOL
    assert orbit.onsets.tolist() == [0] and orbit.iterations <= 6
    assert orbit.spectral_radius == pytest.approx(0.976, abs=0.01)
    sections = flow_sections(cases.four_bar(), 150, 4)[100:]
    diff = (np.mean(sections, axis=0) - orbit.state) / orbit.scale[:4]
    assert np.max(np.abs(diff[:2])) < 2e-3, diff
    assert np.max(np.abs(diff[2:])) < 0.5, diff


@pytest.mark.slow
def test_four_bar_monodromy_matches_central_differences_of_the_return_map(four_bar_orbit):
    """The four-bar orbit's monodromy matrix (variational run, scaled) against central
    differences of the plain map, steps 3e-4 of the scales (measured within about 2e-3 of
    its largest entry: `python -m validation.four_bar_orbit_checks`). Steps of 1e-3 and more
    leave the map's near-linear region (the vibration's phase after a revolution depends on
    its amplitude), steps of 1e-4 and less meet the map's error (about 1e-4 of the scales).
    The matrix is far from normal (rates rows a few hundred times the positions rows), so
    its eigenvalues move by O(0.1) under such entry errors: the entries are compared, and
    the multipliers are the eigenvalues of the matrix checked here."""
    orbit = four_bar_orbit
    F = central_differences(orbit, 3e-4)
    A = orbit.monodromy
    assert A.shape == (4, 4)            # permanent contact: the memory's held, not a column
    np.testing.assert_allclose(A, F, atol=3e-3 * np.max(np.abs(A)))
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A)),
                               np.sort_complex(orbit.multipliers))


def test_a_corrector_iterate_outside_the_fields_range_is_a_failed_step():
    """A Newton iterate of the continuation's corrector can leave the field's range (from
    0.001 mm a step's iterate once asked for a clearance of 2e27 m): that is a step that
    did not converge (RuntimeError, which the corrector turns into a halved step), not an
    error that ends the continuation."""
    from mbs_clearance.analysis.periodic import _Continuation

    u0 = math.log(1e-5)
    con = _Continuation(PAPER, "clearance", 1, 1e-10, "dop853", True, math.log(10.0), u0)
    assert con.shooter(0.0) is con.shooter(0.0)             # the start: within range
    for uu in (30.0, 1e6):                  # 1e-5 x 10^30 m; exp overflows
        with pytest.raises(RuntimeError, match="outside the range of clearance"):
            con.shooter(uu)


@pytest.mark.slow
def test_branch_from_a_micrometre_passes_the_sharp_turn_without_a_fold():
    """From 0.001 mm the branch's section rate winds with the clearance (a helix in the
    scaled state); with the tangent oriented along the previous one a "fold" was reported
    at 0.00177 mm with no multiplier near +1. Now: no fold along the orbits past that turn,
    and det(M - I), the product of (mu - 1) over each orbit's multipliers, keeps its sign
    at every orbit (measured: every |mu| below 0.03). How far a number of orbits reaches
    moves with the start's last digits and the orbits' last bits (240 orbits have reached
    between 0.00178 mm, still in the turn, and 0.00194 mm), so the test takes the 400
    orbits docs/orbits.md measures
    (`python -m benchmarks.orbit_branch`: 0.00213 mm, about 5 minutes)."""
    mech = PAPER.replace(journal_radius=PAPER.bearing_radius - 1e-6)
    branch = continue_orbits(mech, "clearance", 1e-6, 1e-4, max_points=400)
    assert not [p for p in branch.points if p.kind == "fold"]
    assert branch.counters["unconfirmed_folds"] == 0
    assert branch.values.max() > 1.85e-6        # past the sharp turn at 0.00177 mm
    dets = [np.real(np.prod(mu[np.isfinite(mu)] - 1.0)) for mu in branch.multipliers]
    assert np.all(np.sign(dets) == np.sign(dets[0]))


@pytest.mark.slow
def test_period_one_boundary_over_crank_speed_by_continuation_and_brute_force():
    """Continuation over crank speed from the paper's design downwards: the first period
    doubling at 396.967 +- 0.012 rad/s (3790.7 rpm; 67 orbits, measured 7.1 s). The regime
    map's rule (100 revolutions, 50 kept) on runs started on the branch's nearest orbit
    above the doubling: period-1 3 rad/s above it (measured d_1 2.2e-5), period-2 2 rad/s
    below it (d_1 2.5). Measured on a 0.5 rad/s grid from -2 to +2 and at +-3, +-6: period-2
    from -3 to -1 and at +1.5, not settled (aperiodic) from -0.5 to +1, period-1 at +2
    (d_1 8.4e-4), +3 and +6, period-2 at +2.5 (started from another orbit of the branch):
    near the doubling the multiplier near -1 contracts slowly, so the brute-force boundary
    lies 1.5 - 3 rad/s above the located one, as over clearance; at -6 rad/s the run from
    the branch is period-1 again (not followed here)."""
    from mbs_clearance.analysis.periodic import with_field
    from mbs_clearance.analysis.poincare import classify, scale_samples, section_times

    branch = continue_orbits(PAPER, "crank_speed", PAPER.crank_speed, 1000 * math.pi / 30,
                             max_points=300, max_step=30.0, stop_at_first=True)
    pd = branch.points[0]
    assert pd.kind == "period_doubling" and pd.tolerance < 0.05
    assert pd.value == pytest.approx(396.967, abs=0.05)
    above = branch.values > pd.value
    regimes = []
    for w in (pd.value + 3.0, pd.value - 2.0):
        i = int(np.argmin(np.where(above, np.abs(branch.values - w), np.inf)))
        mech = with_field(PAPER, "crank_speed", w)
        flow = Flow(mech)
        mem = _mem_index(mech)
        flow.y[:4] = branch.states[i]
        flow.p[mem:mem + 2] = 1.0, branch.impact_velocities[i, 0]
        samples = []
        for k, t in enumerate(section_times(mech, 100)):
            flow.advance(t)
            if k >= 50:
                samples.append(flow.section())
        regimes.append(classify(scale_samples(np.array(samples), flow.clearance,
                                              flow.omega))[:2])
    assert regimes == [("period_1", 1), ("period_k", 2)]
