"""The compiled integrator on problems with closed-form solutions."""

import math

import numba as nb
import numpy as np
import pytest

from mbs_clearance.numerics.integrator import (
    ACTION_SIG,
    EVENT_SIG,
    METHODS,
    MONITOR_SIG,
    N_CRESTS,
    RESULTS,
    RHS_SIG,
    STIFF_METHODS,
    _clear_of_surface,
    dense_eval,
    extra_stages,
    integrate,
    make_settings,
    rk_step,
)


@nb.njit(RHS_SIG)
def osc_rhs(t, y, p, d):
    d[0] = y[1]
    d[1] = -p[0] * p[0] * y[0]


@nb.njit(EVENT_SIG)
def never(t, y, p, j):
    return -1.0, 0.0


@nb.njit(ACTION_SIG)
def nothing(t, y, p, j):
    pass


def minus_x(rhs, event):
    """The monitor -y[0] as the last stage of a step of `rhs` with `event` (one joint)."""
    @nb.njit(MONITOR_SIG)
    def monitor(t, y, p, d, out, g, gd):
        rhs(t, y, p, d)
        g[0], gd[0] = event(t, y, p, 0)
        return -y[0]
    return monitor


osc_minus_x = minus_x(osc_rhs, never)


def run(rhs, event, action, monitor, y0, p, edges, rtol, method="dopri5", record=True,
        n_samples=3, h_max=10.0, n_mem=1, margin=0.0, n_events=1, atol=None, event_tol=1e-14,
        h0=0.0):
    """(ts, ys, ms, peaks, peak_t, counters, status) of `integrate` (memory: the last n_mem
    entries of p) for the toy model with kernels (rhs, event, action, monitor), run through
    the shared toy structure (`toy_rhs`, ...: see TOYS) with the toy's id after p."""
    tab = METHODS[method]
    p = np.asarray(p, float)
    toy = TOYS[(rhs, event, action, monitor)]
    settings = make_settings(rtol, np.full(len(y0), rtol) if atol is None else atol, len(y0),
                             h0=h0, h_max=h_max, record=record, event_tol=event_tol,
                             event_margin=margin, n_samples=n_samples, refine_iters=40,
                             n_dense=len(y0), n_events=n_events, mem_start=len(p) - n_mem,
                             n_mem=n_mem)
    out = integrate(toy_rhs, toy_event, toy_action, toy_monitor, np.asarray(y0, float),
                    np.append(p, float(toy)), np.asarray(edges, float), settings,
                    tab.arrays())
    return out[:6] + (RESULTS(out[7]),)


# bs3's and rodas4's kernels are compiled for this test alone (40 s from a cold cache): slow
@pytest.mark.parametrize("method", [pytest.param(m, marks=pytest.mark.slow)
                                    if m in ("bs3", "rodas4") else m for m in sorted(METHODS)])
def test_oscillator_error_decreases_with_rtol_at_the_expected_rate(method):
    errors, nfevs = [], []
    for rtol in (1e-5, 1e-7, 1e-9):
        ts, ys, *_ , counters, status = run(osc_rhs, never, nothing, osc_minus_x, [1.0, 0.0],
                                            [2.0, 0.0], [0.0, 10.0], rtol, method)
        errors.append(np.max(np.abs(ys[:, 0] - np.cos(2.0 * ts))))
        nfevs.append(counters[0])
        assert status is RESULTS.success
    assert errors[0] > errors[1] > errors[2]
    # error per function evaluation follows the order of the method: nfev ~ err^(-1/order)
    order = METHODS[method].order
    slope = -np.log(errors[2] / errors[0]) / np.log(nfevs[2] / nfevs[0])
    assert order - 1.5 < slope < order + 1.0


@pytest.mark.parametrize("method", [pytest.param(m, marks=pytest.mark.slow)
                                    if m in STIFF_METHODS else m for m in sorted(METHODS)])
def test_dense_output_interpolates_to_its_order(method):
    tab = METHODS[method]
    # (a Rosenbrock method's K holds its work rows too: n + 3)
    K = np.zeros((tab.P.shape[0] + (5 if method in STIFF_METHODS else 0), 2))
    y0 = np.array([1.0, 0.0])
    f0 = np.array([0.0, -1.0])
    p = np.array([1.0, 0.0])
    errs = []
    for h in (0.4, 0.2) if method == "dop853" else (0.1, 0.05):
        y1, f1, tmp = np.empty(2), np.empty(2), np.empty(2)
        rk_step(osc_rhs, 0.0, y0, f0 * 0 + np.array([0.0, -1.0]), h, tab.A, tab.B, tab.C, K,
                p, y1, f1, tmp)
        extra_stages(osc_rhs, 0.0, y0, h, K, tab.A_extra, tab.C_extra, p, tmp)
        out = np.empty(2)
        dense_eval(y0, h, K, tab.P, 1.0, out, np.empty(tab.P.shape[0]))
        # the interpolant ends at the step, to rounding: DOP853's monomial coefficients reach
        # ~500, so its sums round at ~1e-13
        assert np.allclose(out, y1, rtol=0, atol=1e-13 if method == "dop853" else 1e-15)
        dense_eval(y0, h, K, tab.P, 0.37, out, np.empty(tab.P.shape[0]))
        errs.append(abs(out[0] - math.cos(0.37 * h)))
    # local interpolation error O(h^(q+1)) with q = order of the continuous extension
    q = tab.P.shape[1]
    assert errs[0] / errs[1] > 2 ** (q + 1) * 0.6


@nb.njit(RHS_SIG)
def nonlinear_rhs(t, y, p, d):
    d[0] = y[1] * math.cos(t)
    d[1] = -y[0] * y[0] + math.sin(3.0 * t)


def test_dop853_step_and_dense_output_match_scipy():
    """One DOP853 step of ours against scipy's DOP853 (same tableau, independent code): the
    same step, the same error estimate and the same continuous extension."""
    from scipy.integrate import DOP853

    tab = METHODS["dop853"]
    y0 = np.array([0.7, -0.3])
    p = np.zeros(1)
    h = 0.3

    def fun(t, y):
        d = np.empty(2)
        nonlinear_rhs(t, np.ascontiguousarray(y), p, d)
        return d

    ref = DOP853(fun, 0.0, y0, 1.0, first_step=h, rtol=1e-3, atol=1e-3)
    ref.step()
    assert ref.t == pytest.approx(h, rel=1e-15)
    K = np.zeros((tab.P.shape[0], 2))
    f0 = fun(0.0, y0)
    y1, f1, tmp = np.empty(2), np.empty(2), np.empty(2)
    rk_step(nonlinear_rhs, 0.0, y0, f0, h, tab.A, tab.B, tab.C, K, p, y1, f1, tmp)
    extra_stages(nonlinear_rhs, 0.0, y0, h, K, tab.A_extra, tab.C_extra, p, tmp)
    np.testing.assert_allclose(y1, ref.y, rtol=1e-14, atol=1e-15)
    dense = ref.dense_output()
    out = np.empty(2)
    for theta in (0.1, 0.5, 0.83):
        dense_eval(y0, h, K, tab.P, theta, out, np.empty(tab.P.shape[0]))
        np.testing.assert_allclose(out, dense(theta * h), rtol=1e-13, atol=1e-14)


@nb.njit(RHS_SIG)
def ball_rhs(t, y, p, d):
    d[0] = y[1]
    d[1] = -9.81


@nb.njit(EVENT_SIG)
def ball_event(t, y, p, j):
    return -y[0], -y[1]


ball_minus_x = minus_x(ball_rhs, ball_event)


@nb.njit(ACTION_SIG)
def ball_bounce(t, y, p, j):
    y[1] = -p[0] * y[1]
    p[1] += 1.0


def test_bouncing_ball_impact_times_are_located_exactly():
    """Ball dropped from 1 m, restitution 0.8: impact times t1 = sqrt(2/g), t_(k+1) = t_k +
    2 e^k v1 / g. The integrator must land on each of them (not the next step inside)."""
    g, e = 9.81, 0.8
    ts, ys, ms, _, _, counters, _ = run(ball_rhs, ball_event, ball_bounce, ball_minus_x, [1.0, 0.0],
                                     [e, 0.0], [0.0, 2.0], 1e-10, h_max=0.05)
    v1 = math.sqrt(2 * g)
    expected = [math.sqrt(2 / g)]
    for k in range(1, 6):
        expected.append(expected[-1] + 2 * e**k * v1 / g)
    expected = [t for t in expected if t < 2.0]
    assert counters[3] == len(expected)
    for t_imp in expected:
        assert np.min(np.abs(ts - t_imp)) < 1e-11
    assert ms[-1, 0] == len(expected)  # memory (bounce count) recorded with the steps


@nb.njit(RHS_SIG)
def still(t, y, p, d):
    d[0] = 0.0


@nb.njit(EVENT_SIG)
def bump(t, y, p, j):
    # positive only for |t - 1| < 0.01: an excursion much shorter than the steps taken
    if p[0] < 0.5:
        return 1e-4 - (t - 1.0) ** 2, -2.0 * (t - 1.0)
    return -1.0, 0.0


@nb.njit(EVENT_SIG)
def bump_without_rate(t, y, p, j):
    # the same excursion, but the model reports no rate: only samples can find it
    return bump(t, y, p, j)[0], 0.0


bump_minus_x = minus_x(still, bump)
bump_only_minus_x = minus_x(still, bump_without_rate)


@nb.njit(ACTION_SIG)
def flag(t, y, p, j):
    p[0] = 1.0


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_interior_samples_catch_a_crossing_and_return_inside_one_step(method):
    # With no dynamics the step grows to h_max = 0.4 and step ends never see g > 0.
    # (dop853: its first look is the cubic Hermite one of `_clear_of_surface`, which must
    # send these steps to the full search)
    *_, counters, _ = run(still, bump_without_rate, flag, bump_only_minus_x, [0.0], [0.0],
                          [0.0, 3.0], 1e-8, n_samples=0, h_max=0.4, method=method)
    assert counters[3] == 0   # missed without interior samples: this is what they are for
    *_, counters, _ = run(still, bump_without_rate, flag, bump_only_minus_x, [0.0], [0.0],
                          [0.0, 3.0], 1e-8, n_samples=39, h_max=0.4, method=method)
    assert counters[3] == 1
    # with no interior samples at all, the rates at the step ends reveal the excursion: the
    # cubic Hermite interpolant of g rises to the surface, so the step is sampled finer
    *_, counters, _ = run(still, bump, flag, bump_minus_x, [0.0], [0.0], [0.0, 3.0], 1e-8,
                          n_samples=0, h_max=0.4, margin=1e-3, method=method)
    assert counters[3] == 1


@nb.njit(EVENT_SIG)
def osc_above(t, y, p, j):
    # g = y0 - level: the oscillator's position rising above a level
    return y[0] - p[1], y[1]


def test_cubic_look_declares_a_step_clear_only_far_from_the_surface():
    """`_clear_of_surface` on one resolved oscillator step (omega h = 0.2, y0 from its
    maximum 1 down to cos 0.2): clear when the level is far above the motion; not clear
    when the motion comes within twice the margin of it, nor when the step starts on it."""
    A, B, C, *_ = METHODS["dop853"].arrays()
    h, t = 0.2, 0.0
    y = np.array([1.0, 0.0])
    K = np.zeros((B.shape[0] + 4, 2))
    f = np.array([0.0, -1.0])
    y_new, f_new, ytmp = np.empty(2), np.empty(2), np.empty(2)
    margin = 1e-3
    for level, clear in ((2.0, True), (1.0 + 1.5 * margin, False), (1.0, False)):
        p = np.array([1.0, level])
        rk_step(osc_rhs, t, y, f, h, A, B, C, K, p, y_new, f_new, ytmp)
        g0, gd0 = (np.array([v]) for v in osc_above(t, y, p, 0))
        g1, gd1 = (np.array([v]) for v in osc_above(t + h, y_new, p, 0))
        got = _clear_of_surface(osc_above, t, y, y_new, K[0], K[B.shape[0]], h, p, g0, gd0,
                                g1, gd1, 1, 1e-14, margin, ytmp, np.empty(1), np.empty(1))
        assert got == clear, level


def test_window_peaks_are_refined_between_steps():
    # x = cos(2t): max of -x over [0, 3] is 1 at t = pi/2, in general between two steps
    ts, ys, _, peaks, peak_t, counters, _ = run(osc_rhs, never, nothing, osc_minus_x, [1.0, 0.0],
                                             [2.0, 0.0], [0.0, 3.0], 1e-10)
    sampled = np.max(-ys[:, 0])
    # the refined peak is limited only by the global error of the solution (~1e-9 here) ...
    assert peaks[0] == pytest.approx(1.0, abs=1e-8)
    assert peak_t[0] == pytest.approx(math.pi / 2, abs=1e-4)
    # ... while the best step point misses it by the curvature times the step squared
    assert 1.0 - sampled > 100 * abs(1.0 - peaks[0])


@nb.njit(MONITOR_SIG)
def two_bumps(t, y, p, d, out, g, gd):
    d[0] = 0.0
    # the maximum (1.0 at t = 0.1) sits inside the window's first step (0 to 0.25), while
    # the best step point is the window's end (0.9 at t = 1)
    g[0], gd[0] = -1.0, 0.0      # the event function `never`
    return math.exp(-((t - 0.1) / 0.15) ** 2) + 0.9 * math.exp(-((t - 1.0) / 0.3) ** 2)


def test_a_peak_inside_the_first_step_of_a_window_is_found():
    ts, _, _, peaks, peak_t, counters, _ = run(still, never, nothing, two_bumps, [0.0], [0.0],
                                               [0.0, 1.0], 1e-8, n_samples=1, h_max=0.25,
                                               h0=0.25)
    samples = [_value(two_bumps, t) for t in ts]
    assert max(samples) < 0.95 and ts[1] >= 0.25   # no step point near the true peak
    grid = np.linspace(0.05, 0.15, 200001)     # the true maximum, on a fine grid
    values = [_value(two_bumps, t) for t in grid]
    assert peaks[0] == pytest.approx(max(values), abs=1e-9)
    assert peak_t[0] == pytest.approx(grid[int(np.argmax(values))], abs=1e-5)


def _value(monitor, t):
    """The monitor's value at t (one-state models)."""
    return monitor(t, np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(0), np.zeros(1),
                   np.zeros(1))


@nb.njit(MONITOR_SIG)
def near_tie(t, y, p, d, out, g, gd):
    d[0] = 0.0
    # two narrow crests: the higher (1.0 at t = 0.35) falls between the steps (0.1 apart),
    # whose best sample is the lower crest's top (0.999 at t = 0.7)
    g[0], gd[0] = -1.0, 0.0      # the event function `never`
    return math.exp(-((t - 0.35) / 0.1) ** 2) + 0.999 * math.exp(-((t - 0.7) / 0.1) ** 2)


def test_the_higher_of_two_nearly_equal_crests_is_refined():
    """Top-k refinement: the best sample sits on the lower crest; refining only around it
    would return ~0.999, the true maximum (fine grid) is ~1.0 near t = 0.35."""
    ts, _, _, peaks, peak_t, counters, _ = run(still, never, nothing, near_tie, [0.0], [0.0],
                                               [0.0, 1.0], 1e-8, n_samples=1, h_max=0.1,
                                               h0=0.1)
    samples = [_value(near_tie, t) for t in ts]
    assert abs(ts[int(np.argmax(samples))] - 0.7) < 1e-9   # the best sample: the lower crest
    grid = np.linspace(0.3, 0.4, 200001)
    values = [_value(near_tie, t) for t in grid]
    assert peaks[0] == pytest.approx(max(values), abs=1e-9)
    assert peak_t[0] == pytest.approx(grid[int(np.argmax(values))], abs=1e-5)
    # refined: the steps on both sides of each crest and the window's first and last steps,
    # no step twice (3 crests at most: the start sample, 0.3 and 0.7 -> at most 6 + 2 steps)
    assert 4 <= counters[4] <= 2 * N_CRESTS + 2


def test_near_tie_design_of_the_slider_crank_refines_the_right_crest():
    """At (L2, L3) = (0.0575, 0.105) of the GA box the rev-4 window has two crests of |F12|
    within 1.3e-4 of each other, one near each end of the window; refining around the best
    sample only picked the lower one (error 1.3e-4). Reference: rtol 1e-12."""
    from mbs_clearance.model.mechanism import SliderCrank
    from mbs_clearance.solve import reduced
    from mbs_clearance.studies.optimize import design_mechanism

    mech = design_mechanism(SliderCrank(), {"crank_length": 0.0575, "coupler_length": 0.105})
    ref = reduced.run(mech, 4, rtol=1e-12, record=False)
    out = reduced.run(mech, 4, record=False)
    assert abs(out[3][3] / ref[3][3] - 1.0) < 1e-5
    assert abs(out[4][3] - ref[4][3]) < 1e-3 * mech.period     # the same crest


# ---------------------------------------------------------------- J = 2 switching functions
# Two independent bodies, x_j'' = -omega_j^2 x_j - a_j, each with a wall at w_j on the side
# s_j (g_j = s_j (x_j - w_j)): omega = 0 is a ball under gravity a (exactly integrated: the
# motion is quadratic), a = 0 an oscillator. An impact reverses the velocity with
# restitution e_j, counts in memory p[10 + 2 j] and stores the impact velocity in
# p[11 + 2 j]. p = [omega0, omega1, a0, a1, w0, w1, s0, s1, e0, e1, memory (4)].
TWO_MEM = 10


@nb.njit(RHS_SIG)
def two_rhs(t, y, p, d):
    for j in range(2):
        d[2 * j] = y[2 * j + 1]
        d[2 * j + 1] = -p[j] * p[j] * y[2 * j] - p[2 + j]


@nb.njit(EVENT_SIG)
def two_event(t, y, p, j):
    return p[6 + j] * (y[2 * j] - p[4 + j]), p[6 + j] * y[2 * j + 1]


@nb.njit(ACTION_SIG)
def two_impact(t, y, p, j):
    p[TWO_MEM + 2 * j] += 1.0
    p[TWO_MEM + 2 * j + 1] = y[2 * j + 1]
    y[2 * j + 1] = -p[8 + j] * y[2 * j + 1]


@nb.njit(MONITOR_SIG)
def two_monitor(t, y, p, d, out, g, gd):
    two_rhs(t, y, p, d)
    for j in range(2):
        g[j], gd[j] = two_event(t, y, p, j)
    return y[0]


def run_two(p, y0, t_end, rtol, method="dopri5", h0=0.0, h_max=10.0, n_samples=3):
    p = np.concatenate([np.asarray(p, float), np.zeros(4)])
    ts, ys, ms, _, _, counters, status = run(
        two_rhs, two_event, two_impact, two_monitor, y0, p, [0.0, t_end], rtol, method=method,
        n_samples=n_samples, h_max=h_max, n_mem=4, n_events=2, atol=np.full(4, rtol),
        event_tol=1e-13, h0=h0)
    assert status is RESULTS.success
    return ts, ys, ms, counters, p


def oscillator_impacts(omega, wall, v0, e, t_end):
    """Closed form: x = (v0/omega) sin(omega t) hits the wall x = w at t1 with speed v1;
    reflected with -e v_k it swings back with amplitude A' (A' cos phi = w, A' sin phi =
    e v_k / omega) and meets the wall again after (2 pi - 2 phi) / omega at speed e v_k."""
    t = math.asin(wall * omega / v0) / omega
    v = v0 * math.cos(omega * t)
    times, speeds = [], []
    while t < t_end:
        times.append(t)
        speeds.append(v)
        phi = math.atan2(e * v / omega, wall)
        t += (2 * math.pi - 2 * phi) / omega
        v *= e
    return np.array(times), np.array(speeds)


OSC2 = dict(p=[2 * math.pi, 2.6 * math.pi, 0.0, 0.0, 0.6, 0.5, 1.0, 1.0, 0.9, 0.7],
            y0=[0.0, 2 * math.pi, 0.0, 2.6 * math.pi * 0.8])


def _osc2_reference(t_end):
    p = OSC2["p"]
    return [oscillator_impacts(p[j], p[4 + j], OSC2["y0"][2 * j + 1], p[8 + j], t_end)
            for j in range(2)]


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_two_joints_events_located_each_with_its_own_memory(method):
    """Both joints' impacts: landed on (|g_j| <= event_tol), at the closed-form times, each
    joint's count and impact velocity in its own memory entries, recorded with the steps
    (dop853 also checks the J-joint cubic look `_clear_of_surface`)."""
    t_end = 3.0
    ts, ys, ms, counters, p = run_two(OSC2["p"], OSC2["y0"], t_end, 1e-10, method)
    ref = _osc2_reference(t_end)
    assert counters[3] == sum(len(times) for times, _ in ref)
    for j, (times, speeds) in enumerate(ref):
        assert len(times) >= 3
        count = ms[:, 2 * j]
        hits = np.flatnonzero(np.diff(count) == 1) + 1    # the landed steps of joint j
        assert len(hits) == len(times) and count[-1] == len(times)
        np.testing.assert_allclose(ts[hits], times, rtol=0, atol=1e-8)
        # landed: the wall within event_tol (the velocity was reversed there)
        assert np.all(np.abs(ys[hits, 2 * j] - p[4 + j]) <= 1e-13)
        np.testing.assert_allclose(ms[hits, 2 * j + 1], speeds, rtol=1e-7)
        # the other joint's memory does not move at joint j's impacts
        other = ms[:, 2 * (1 - j)]
        assert np.all(other[hits] == other[hits - 1])


def test_two_events_inside_one_step_are_both_found_in_time_order():
    """Two balls dropped from rest (exact quadratic motion), floors reached at 0.3 s and
    0.4 s; the first step (h0 = 0.5 s, accepted: no error) contains both impacts. The
    earlier one is landed on first, then the other, each at its closed-form time."""
    a = 9.81
    t_a, t_b = 0.3, 0.4
    p = [0.0, 0.0, a, a, 0.0, 0.0, -1.0, -1.0, 0.8, 0.5]
    y0 = [0.5 * a * t_a**2, 0.0, 0.5 * a * t_b**2, 0.0]
    ts, ys, ms, counters, _ = run_two(p, y0, 0.5, 1e-8, h0=0.5, h_max=0.5)
    assert counters[2] == 0                      # no rejection: the first step spans both
    assert ts[1] == pytest.approx(t_a, abs=1e-12) and ts[2] == pytest.approx(t_b, abs=1e-12)
    assert list(ms[1, [0, 2]]) == [1, 0] and list(ms[2, [0, 2]]) == [1, 1]
    assert ms[1, 1] == pytest.approx(-a * t_a, rel=1e-12)     # impact velocities
    assert ms[2, 3] == pytest.approx(-a * t_b, rel=1e-12)
    assert ys[2, 1] == pytest.approx(0.8 * a * t_a - a * (t_b - t_a), rel=1e-12)


def test_simultaneous_events_switch_both_joints_at_one_landing():
    """Two balls dropped from the same height hit their floors at the same instant: one
    landing switches both (no zero-length second event), each with its own restitution."""
    a = 9.81
    t_hit = 0.3
    p = [0.0, 0.0, a, a, 0.0, 0.0, -1.0, -1.0, 0.8, 0.5]
    y0 = [0.5 * a * t_hit**2, 0.0, 0.5 * a * t_hit**2, 0.0]
    ts, ys, ms, counters, _ = run_two(p, y0, 0.35, 1e-8)
    k = int(np.argmin(np.abs(ts - t_hit)))
    assert ts[k] == pytest.approx(t_hit, abs=1e-12)
    assert list(ms[k, [0, 2]]) == [1, 1] and list(ms[k - 1, [0, 2]]) == [0, 0]
    assert counters[3] == 2 and len(np.unique(ts)) == len(ts)
    assert ys[k, 1] == pytest.approx(0.8 * a * t_hit, rel=1e-12)
    assert ys[k, 3] == pytest.approx(0.5 * a * t_hit, rel=1e-12)


@nb.njit(EVENT_SIG)
def graze_event(t, y, p, j):
    if j == 0:
        # touches its surface at t = 1.5 without crossing it (g <= 0 exactly): no event
        return -((t - 1.5) ** 2), -2.0 * (t - 1.5)
    # crosses to positive for |t - 1| < 0.01 only (no rate: only samples can find it)
    if p[1 + 2 * j] < 0.5:
        return 1e-4 - (t - 1.0) ** 2, 0.0
    return -1.0, 0.0


@nb.njit(ACTION_SIG)
def graze_flag(t, y, p, j):
    p[1 + 2 * j] = 1.0
    p[2 + 2 * j] = t


@nb.njit(MONITOR_SIG)
def graze_monitor(t, y, p, d, out, g, gd):
    d[0] = 0.0
    for j in range(2):
        g[j], gd[j] = graze_event(t, y, p, j)
    return 0.0


# ---------------------------------------------------------------- one shared toy structure
# numba compiles `integrate` once per set of model kernels (their types), for about a minute
# in a new process (kernels defined here cannot use the package's disk cache). Every toy
# above therefore runs through one set of kernels that dispatch on the toy's id, the last
# entry of p (after the memory; the toys index p from the front): one compile in all.
OSC, BALL, BUMP_ONLY, BUMP, TWO_BUMPS, NEAR_TIE, TWO, GRAZE = range(8)

#: (rhs, event, on_event, monitor) of each toy -> its id
TOYS = {
    (osc_rhs, never, nothing, osc_minus_x): OSC,
    (ball_rhs, ball_event, ball_bounce, ball_minus_x): BALL,
    (still, bump_without_rate, flag, bump_only_minus_x): BUMP_ONLY,
    (still, bump, flag, bump_minus_x): BUMP,
    (still, never, nothing, two_bumps): TWO_BUMPS,
    (still, never, nothing, near_tie): NEAR_TIE,
    (two_rhs, two_event, two_impact, two_monitor): TWO,
    (still, graze_event, graze_flag, graze_monitor): GRAZE,
}


@nb.njit(RHS_SIG)
def toy_rhs(t, y, p, d):
    toy = p[p.shape[0] - 1]
    if toy == OSC:
        osc_rhs(t, y, p, d)
    elif toy == BALL:
        ball_rhs(t, y, p, d)
    elif toy == TWO:
        two_rhs(t, y, p, d)
    else:
        still(t, y, p, d)


@nb.njit(EVENT_SIG)
def toy_event(t, y, p, j):
    toy = p[p.shape[0] - 1]
    if toy == BALL:
        return ball_event(t, y, p, j)
    if toy == BUMP_ONLY:
        return bump_without_rate(t, y, p, j)
    if toy == BUMP:
        return bump(t, y, p, j)
    if toy == TWO:
        return two_event(t, y, p, j)
    if toy == GRAZE:
        return graze_event(t, y, p, j)
    return never(t, y, p, j)


@nb.njit(ACTION_SIG)
def toy_action(t, y, p, j):
    toy = p[p.shape[0] - 1]
    if toy == BALL:
        ball_bounce(t, y, p, j)
    elif toy == BUMP_ONLY or toy == BUMP:
        flag(t, y, p, j)
    elif toy == TWO:
        two_impact(t, y, p, j)
    elif toy == GRAZE:
        graze_flag(t, y, p, j)


@nb.njit(MONITOR_SIG)
def toy_monitor(t, y, p, d, out, g, gd):
    toy = p[p.shape[0] - 1]
    if toy == OSC:
        return osc_minus_x(t, y, p, d, out, g, gd)
    if toy == BALL:
        return ball_minus_x(t, y, p, d, out, g, gd)
    if toy == BUMP_ONLY:
        return bump_only_minus_x(t, y, p, d, out, g, gd)
    if toy == BUMP:
        return bump_minus_x(t, y, p, d, out, g, gd)
    if toy == TWO_BUMPS:
        return two_bumps(t, y, p, d, out, g, gd)
    if toy == NEAR_TIE:
        return near_tie(t, y, p, d, out, g, gd)
    if toy == TWO:
        return two_monitor(t, y, p, d, out, g, gd)
    return graze_monitor(t, y, p, d, out, g, gd)


def test_every_toy_runs_through_the_one_shared_structure():
    """The toys' kernels are compiled once: the toy's id selects its own kernels (each
    kernel's result and effect on y and p compared on one call per toy), and `run` refuses a
    kernel set that is not a registered toy."""
    for (rhs, event, action, monitor), toy in TOYS.items():
        n = 4 if toy == TWO else 2
        y = np.array([0.5, -0.25, 0.125, 0.0625])[:n]
        p = np.append(np.linspace(0.3, 1.2, 14), float(toy))
        results = []
        for kernels in ((rhs, event, action, monitor),
                        (toy_rhs, toy_event, toy_action, toy_monitor)):
            d, yy, pp = np.zeros(n), y.copy(), p.copy()
            g, gd = np.zeros(2), np.zeros(2)
            kernels[0](0.1, yy, pp, d)
            ev = [kernels[1](0.1, yy, pp, j) for j in range(2 if toy in (TWO, GRAZE) else 1)]
            m = kernels[3](0.1, yy, pp, np.zeros(n), np.zeros(0), g, gd)
            kernels[2](0.1, yy, pp, 0)
            results.append((d, ev, m, g, gd, yy, pp))
        for want, got in zip(*results):
            np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
    with pytest.raises(KeyError):
        run(osc_rhs, ball_event, nothing, osc_minus_x, [1.0, 0.0], [2.0, 0.0], [0.0, 1.0],
            1e-6)


def test_grazing_touch_is_no_event_and_a_short_excursion_inside_a_step_is_found():
    """Joint 0 touches its surface (g = 0 at t = 1.5, negative around it): not an event.
    Joint 1 crosses and returns within 0.02 s, inside one step of 0.4 s, seen only by the
    interior samples: one event, located at its entry t = 0.99."""
    p = np.zeros(5)
    ts, _, ms, _, _, counters, status = run(still, graze_event, graze_flag, graze_monitor,
                                            [0.0], p, [0.0, 3.0], 1e-8, n_samples=39,
                                            h_max=0.4, n_mem=4, n_events=2)
    assert status is RESULTS.success and counters[3] == 1
    assert ms[-1, 0] == 0 and ms[-1, 2] == 1          # joint 0 never switched, joint 1 once
    assert ms[-1, 3] == pytest.approx(0.99, abs=1e-10)
    assert np.max(np.diff(ts)) > 0.3                  # steps far longer than the excursion


def test_two_joints_with_impacts_converge_at_the_method_order():
    """Error of the impact times (both joints, closed form) and of the final state against
    the function evaluations: nfev ~ err^(-1/order) with the events landed exactly."""
    t_end = 2.0
    ref = _osc2_reference(t_end)
    errors, nfevs = [], []
    for rtol in (1e-6, 1e-8, 1e-10):
        ts, ys, ms, counters, p = run_two(OSC2["p"], OSC2["y0"], t_end, rtol)
        err = 0.0
        for j, (times, _) in enumerate(ref):
            hits = np.flatnonzero(np.diff(ms[:, 2 * j]) == 1) + 1
            err = max(err, np.max(np.abs(ts[hits] - times)))
        errors.append(err)
        nfevs.append(counters[0])
    assert errors[0] > errors[1] > errors[2]
    slope = -np.log(errors[2] / errors[0]) / np.log(nfevs[2] / nfevs[0])
    order = METHODS["dopri5"].order
    assert order - 1.5 < slope < order + 1.0, (errors, nfevs)


# ---------------------------------------------------------------- the Rosenbrock method

STIFF_RATE = -1.0e4


@nb.njit(RHS_SIG)
def stiff_linear_rhs(t, y, p, d):
    d[0] = -y[0] + y[1] + math.sin(t)
    d[1] = p[0] * y[1]


def _stiff_linear_exact(t, y0, lam):
    """Closed form of y0' = -y0 + y1 + sin t, y1' = lam y1."""
    a = y0[1]
    c_exp = a / (lam + 1.0)

    def part(s):
        return c_exp * math.exp(lam * s) + (math.sin(s) - math.cos(s)) / 2.0
    c = y0[0] - part(0.0)
    return np.array([c * math.exp(-t) + part(t), a * math.exp(lam * t)])


@pytest.mark.slow
def test_rodas4_converges_at_order_4_on_a_stiff_linear_problem():
    """rodas4 with fixed steps h = 1/N on a linear problem with a fast mode (lambda = -1e4,
    h |lambda| from 1000 to 125: far outside every explicit method's stability region) and a
    time-dependent forcing (df/dt enters the stages), against the closed form at t = 1: the
    error falls 2^4-fold per halving (measured ratios 16.2, 16.1, 17.4), and the fast mode
    is damped, not amplified."""
    tab = METHODS["rodas4"]
    p = np.array([STIFF_RATE])
    y0 = np.array([1.0, 1.0])
    errors = []
    for n_steps in (10, 20, 40, 80):
        h = 1.0 / n_steps
        y, t = y0.copy(), 0.0
        K = np.zeros((tab.P.shape[0] + 5, 2))
        f, y_new, f_new, tmp = np.empty(2), np.empty(2), np.empty(2), np.empty(2)
        for k in range(n_steps):
            stiff_linear_rhs(t, y, p, f)
            rk_step(stiff_linear_rhs, t, y, f, h, tab.A, tab.B, tab.C, K, p, y_new, f_new, tmp)
            y = y_new.copy()
            t = (k + 1) * h
        errors.append(np.max(np.abs(y - _stiff_linear_exact(1.0, y0, STIFF_RATE))))
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(ratios > 2.0 ** 4 * 0.8) and np.all(ratios < 2.0 ** 4 * 1.5)
    assert errors[-1] < 1e-10
