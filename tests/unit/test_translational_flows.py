"""The tangent flow, the monodromy matrix and periodic orbits through the corners of a
translational clearance joint, and the finite-time Lyapunov exponent of a free linkage.
References: central differences of the one-revolution map (plain runs), an independent
plain `simulate` run from the orbit's state, and the separation of two nearby plain runs."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from mbs_clearance.model import cases

sys.path.insert(0, str(Path(__file__).parent))
from test_translational import guided  # noqa: E402

# ---------------------------------------------------------------- refusals (fast)

def test_free_linkage_refusals_before_any_work():
    """A free linkage has no drive period: the periodic orbits refuse it by that reason;
    its exponent takes duration= (a whole number of window=), not revolutions; a driven
    linkage's exponent refuses duration= and window=; `Flow` and `TangentFlow` refuse a free
    linkage unless given free=True. All before any model is loaded."""
    from mbs_clearance.analysis.lyapunov import lyapunov_exponent
    from mbs_clearance.analysis.periodic import continue_orbits, periodic_orbit

    lk = cases.flores_translational_slider_crank()
    with pytest.raises(ValueError, match="is free .*no drive period"):
        periodic_orbit(lk)
    with pytest.raises(ValueError, match="is free .*no drive period"):
        continue_orbits(lk, "guide.clearance", 1e-3, 2e-3)
    with pytest.raises(ValueError, match="is free .*give the exponent's duration="):
        lyapunov_exponent(lk)
    with pytest.raises(ValueError, match="no drive revolutions; give duration="):
        lyapunov_exponent(lk, revolutions=10, duration=0.01)
    with pytest.raises(ValueError, match=r"duration \(0.01 s\) must be a whole number of "
                                         r"windows \(window 0.003 s\)"):
        lyapunov_exponent(lk, duration=0.01, window=0.003)
    with pytest.raises(ValueError, match="window must be a finite number"):
        lyapunov_exponent(lk, duration=0.01, window=0.02)
    with pytest.raises(ValueError, match=r"transient \(windows not averaged\)"):
        lyapunov_exponent(lk, duration=0.01, window=0.005, transient=2)
    _, driven = guided()
    with pytest.raises(ValueError, match="is driven: .*duration= and window= are for a free"):
        lyapunov_exponent(driven, duration=0.01)
    # the flows map drive revolutions unless told the linkage is free
    from mbs_clearance.solve.flows import Flow, TangentFlow

    for kind in (Flow, TangentFlow):
        with pytest.raises(ValueError, match="is free .*a flow maps drive revolutions"):
            kind(lk)


# ---------------------------------------------------------------- the driven guide (slow)

def _fd_monodromy(sh, x, modes, vel, h):
    """Central differences (steps h of the scales) of the one-revolution map's plain runs,
    in the shooting's scaled variables: the state's and every contact's memory."""
    n2, S = sh.n2, sh.scale
    out = np.zeros((n2 + sh.J, n2 + sh.J))
    for i in range(n2 + sh.J):
        ends = []
        for sign in (1.0, -1.0):
            xx, vv = x.copy(), vel.copy()
            if i < n2:
                xx[i] += sign * h * S[i]
            else:
                vv[i - n2] += sign * h * S[i]
            xe, me, ve, _, _ = sh.value(xx, modes, vv)
            assert np.array_equal(me, modes)
            ends.append(np.concatenate([xe, ve]) / S)
        out[:, i] = (ends[0] - ends[1]) / (2.0 * h)
    return out


@pytest.mark.slow
def test_monodromy_through_corner_impacts_matches_differences_of_the_map():
    """The shooting's matrix (the variational run with one direction per state component and
    per corner memory) against central differences of plain runs of the same map, from the
    centred start of the guided slider-crank (500 rpm, c = 0.1 mm) over the first 0.035 s:
    the slider leaves the centre, its top corners strike the guide and it falls to the
    bottom: 8 corner onsets (3 of each top corner, 1 of each bottom one; measured). The
    state's rows and the end memories' rows (each set at its corner's last onset, with the
    event-time term): every entry equals the differences at step 1e-3 or 1e-4 of the scales
    within 5e-3 of the largest entry of its row (measured: at most 1.7e-3, in the coupler
    angle's row, whose entries are 3e-4 of the memories'; the differences' own error: 9e-3
    of the largest entry at step 1e-3, 3e-4 at 1e-4, 6e-4 at 1e-5 where rounding takes
    over). (A whole revolution contracts every perturbation by about 1e-9 as the slider
    settles after each impact sequence: its matrix is below the differences' resolution,
    hence the window.)"""
    from mbs_clearance.analysis.periodic import _Shooter

    _, lk = guided()
    sh = _Shooter(lk, 1, 1e-11, "dop853")
    sh.edges = np.array([0.0, 0.035])       # the map over a window of the first revolution
    n2 = sh.n2
    x = sh.y0[:n2].copy()
    modes, vel = sh.memory(sh.p0)
    xe, me, ve, ons, _, M = sh.jacobian(x, modes, vel)
    assert np.all(ons >= 1) and np.sum(ons) >= 6
    fd = np.array([_fd_monodromy(sh, x, modes, vel, h) for h in (1e-3, 1e-4)])
    err = np.abs(M[None] - fd).min(axis=0)
    rows = np.abs(M).max(axis=1)
    big = rows.max()
    print("largest entry", big, "largest error per row", err.max(axis=1) / rows)
    assert big > 0.1 and np.all(rows[:n2] > 1e-5)
    assert np.all(err <= 5e-3 * rows[:, None]), err / rows[:, None]
    # the end memories depend on the state (rows n2:) and not on the start's memories
    # (the corners are free at the start: each memory is overwritten before it acts)
    assert np.abs(M[n2:, :n2]).max() > 1e-3 * big
    assert np.abs(M[:, n2:]).max() == 0.0


@pytest.mark.slow
def test_periodic_orbit_of_the_guided_slider_crank():
    """The guided slider-crank's period-1 orbit (500 rpm, c = 0.1 mm; every corner starts
    a contact 6 times per revolution): an independent `simulate` run from the orbit's state
    (rtol 1e-11) returns to it within 1e-5 of the scales after one revolution; the Floquet
    multipliers (of the state and the four corners' memories) equal the eigenvalues of the
    central-difference matrix of the map within the differences' own error: all are tiny
    (the slider settles after each impact sequence: the orbit is strongly stable); the
    Lyapunov exponent with the memories' tangents carried is the log of the largest
    multiplier."""
    from mbs_clearance.analysis.periodic import _Shooter, periodic_orbit
    from mbs_clearance.solve.simulate import simulate

    _, lk = guided()
    orbit = periodic_orbit(lk, settle=4, trajectory=False)
    assert orbit.residual <= 1e-6 and orbit.stability == "stable"
    assert np.all(orbit.onsets >= 1) and len(orbit.unknowns) == 8
    run = simulate(lk, 1, rtol=1e-11, start=orbit.start())
    end = np.array([run.coordinates[c][-1] for c in lk.coordinates()]
                   + [run.rates[c][-1] for c in lk.coordinates()])
    n2 = len(end)
    back = np.abs(end - orbit.state) / orbit.scale[:n2]
    print("return residual (scaled)", back.max(), "multipliers", orbit.multipliers)
    assert back.max() <= 1e-5
    sh = _Shooter(lk, 1, 1e-11, "dop853")
    fd = [_fd_monodromy(sh, orbit.state, orbit.modes, orbit.impact_velocities, h)
          for h in (1e-3, 1e-4)]
    noise = np.abs(fd[1] - fd[0]).max()
    rho_fd = np.abs(np.linalg.eigvals(fd[0])).max()
    print("spectral radius", orbit.spectral_radius, "of the differences", rho_fd,
          "their error", noise)
    assert orbit.spectral_radius <= rho_fd + 3.0 * noise
    assert rho_fd <= orbit.spectral_radius + 3.0 * noise
    assert np.abs(orbit.monodromy - fd[0]).max() <= 3.0 * noise
    # Benettin's exponent carrying the memories' tangents is the hybrid map's: the log of
    # the largest multiplier (measured -20.2969 and -20.2980 per revolution); with the
    # memories' tangents reset each revolution the path through the memories of the corners
    # in contact at the section is cut, and the state contracts faster (-31.6)
    from mbs_clearance.analysis.lyapunov import lyapunov_exponent

    carry = lyapunov_exponent(lk, revolutions=8, transient=4, rtol=1e-10, memory="carry")
    reset = lyapunov_exponent(lk, revolutions=8, transient=4, rtol=1e-10)
    print("exponents per revolution: carry", carry.per_revolution, "reset",
          reset.per_revolution, "log of the largest multiplier",
          math.log(orbit.spectral_radius))
    assert carry.per_revolution == pytest.approx(math.log(orbit.spectral_radius), abs=0.01)
    assert (carry.regime, carry.verdict) == ("period_1", "negative")
    assert reset.per_revolution < carry.per_revolution - 5.0


def _nearby_runs(lk, v0, t1, eps, free=False):
    """Central difference (runs of the plain model from the start moved by +- eps v0,
    rtol 1e-11) of the state at t1: the separation of two nearby runs per unit of eps."""
    from mbs_clearance.solve.flows import Flow
    from mbs_clearance.solve.settings import RunSettings

    ends = []
    for sign in (1.0, -1.0):
        f = Flow(lk, RunSettings(rtol=1e-11, method="dop853"), free=free)
        n2 = len(v0)
        f.y[:n2] += sign * eps * v0
        f.advance(t1)
        ends.append(f.y[:n2].copy())
    return (ends[0] - ends[1]) / (2.0 * eps)


@pytest.mark.slow
def test_tangent_through_corner_impacts_matches_two_nearby_runs():
    """The tangent flow of the guided slider-crank from its centred start against the
    separation of two plain runs eps (scaled) apart along its start, after 0.01 s (the top
    corners' first impacts: growth 5.77) and after 0.035 s (8 corner onsets, the slider back
    on the bottom: growth 0.034): the separation converges to the tangent as eps falls, within
    2e-3 of its norm at eps 3e-4 and at least three times closer than at eps 1e-3 (measured:
    8.3e-4 and 8.8e-4 of the norm at 3e-4, 5.1e-3 and 5.5e-3 at 1e-3; at eps 1e-4 the runs'
    rounding takes over at 0.035 s)."""
    from mbs_clearance.solve.flows import TangentFlow
    from mbs_clearance.solve.settings import RunSettings

    _, lk = guided()
    tf = TangentFlow(lk, RunSettings(rtol=1e-10, method="dop853"))
    v0 = tf.tangent().copy()
    for t1 in (0.01, 0.035):
        tf.advance(t1)
        tan = tf.tangent() / tf.scale
        norm = np.linalg.norm(tan)
        err = [np.abs(tan - _nearby_runs(lk, v0, t1, eps) / tf.scale).max() / norm
               for eps in (1e-3, 3e-4)]
        print(t1, "growth", norm, "differences (of the norm) at eps 1e-3, 3e-4", err)
        assert err[1] <= 2e-3 and err[1] <= err[0] / 3.0


@pytest.mark.slow
def test_free_linkage_finite_time_exponent_matches_two_nearby_runs():
    """The finite-time exponent of the free translational-clearance benchmark (Flores, Leine
    and Glocker) over 0.02 s, through the corners' impacts: the tangent's growth (one window)
    equals that of two plain runs 1e-4 (scaled) apart along the same start direction within
    1e-3 (measured: growth 2.738, the vectors within 1.2e-4 of its norm); with two windows
    of 0.01 s the exponent is the mean of their log-growths per second."""
    from mbs_clearance.analysis.lyapunov import lyapunov_exponent
    from mbs_clearance.solve.flows import TangentFlow
    from mbs_clearance.solve.settings import RunSettings

    lk = cases.flores_translational_slider_crank()
    T = 0.02
    res = lyapunov_exponent(lk, duration=T, rtol=1e-10)
    assert len(res.log_growth) == 1 and res.window == T and res.regime == ""
    assert res.per_second == pytest.approx(res.log_growth[0] / T, rel=1e-12)
    tf = TangentFlow(lk, RunSettings(rtol=1e-10, method="dop853"), free=True)
    v0 = tf.tangent().copy()
    tf.advance(T)
    tan = tf.tangent() / tf.scale
    sep = _nearby_runs(lk, v0, T, 1e-4, free=True) / tf.scale
    growth = np.linalg.norm(sep)
    print("growth", np.linalg.norm(tan), "runs", growth, "exponent", res.per_second,
          "difference", np.abs(tan - sep).max() / growth)
    assert np.linalg.norm(tan) == pytest.approx(math.exp(res.log_growth[0]), rel=1e-9)
    assert res.per_second == pytest.approx(math.log(growth) / T, abs=1e-3 / T)
    assert np.abs(tan - sep).max() <= 1e-3 * growth
    two = lyapunov_exponent(lk, duration=T, window=T / 2, rtol=1e-10)
    assert len(two.log_growth) == 2 and two.window == pytest.approx(T / 2)
    assert two.per_second == pytest.approx(two.log_growth.mean() / (T / 2), rel=1e-12)


def test_cli_lyapunov_of_a_free_linkage_refuses_revolutions(capsys):
    """`mbs-clearance lyapunov` of a free case takes --duration (and --window), not
    --revolutions; a driven one refuses --duration; before any run."""
    from mbs_clearance.cli import main

    flores = ["lyapunov", "--case", "flores_translational_slider_crank"]
    for argv, message in ((flores + ["--revolutions", "10"], "not --revolutions"),
                          (flores, "give --duration"),
                          (["lyapunov", "--duration", "0.1"], "for a free linkage")):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
        assert message in capsys.readouterr().err


@pytest.mark.slow
def test_branch_over_the_guides_clearance_returns_under_plain_runs():
    """`continue_orbits` over the guide's clearance (0.1 mm upwards, six orbits): every orbit
    is stable with each corner starting a contact 6 times per revolution, and the last
    orbit's state comes back within 1e-5 of the scales after one revolution of an
    independent `simulate` run at its clearance (rtol 1e-11)."""
    from mbs_clearance.analysis.periodic import continue_orbits, with_field
    from mbs_clearance.solve.flows import _tangent_scale, prepare_flow
    from mbs_clearance.solve.linkage_model import Start
    from mbs_clearance.solve.simulate import simulate

    _, lk = guided()
    br = continue_orbits(lk, "guide.clearance", 1e-4, 1.5e-4, max_points=6, settle=4)
    assert len(br.values) == 6 and br.values[-1] > 1.05e-4 and np.all(br.stable)
    assert np.all(br.onsets == 6)
    design = with_field(lk, "guide.clearance", br.values[-1])
    start = Start(y=br.states[-1], modes=br.setup["modes"],
                  impact_velocities=br.impact_velocities[-1], revolutions=0,
                  linkage=design.name)
    run = simulate(design, 1, rtol=1e-11, start=start)
    end = np.array([run.coordinates[c][-1] for c in design.coordinates()]
                   + [run.rates[c][-1] for c in design.coordinates()])
    scale = _tangent_scale(prepare_flow(design))
    back = np.abs(end - br.states[-1]) / scale
    print("clearances", br.values, "return residual (scaled)", back.max())
    assert back.max() <= 1e-5
