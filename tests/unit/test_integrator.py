"""The compiled integrator on problems with closed-form solutions."""

import math

import numba as nb
import numpy as np
import pytest

from mbs_clearance.integrator import (
    ACTION_SIG,
    EVENT_SIG,
    METHODS,
    MONITOR_SIG,
    N_CRESTS,
    RHS_SIG,
    _clear_of_surface,
    dense_eval,
    extra_stages,
    integrate,
    rk_step,
)


@nb.njit(RHS_SIG)
def osc_rhs(t, y, p, d):
    d[0] = y[1]
    d[1] = -p[0] * p[0] * y[0]


@nb.njit(EVENT_SIG)
def never(t, y, p):
    return -1.0, 0.0


@nb.njit(ACTION_SIG)
def nothing(t, y, p):
    pass


def minus_x(rhs, event):
    """The monitor -y[0] as the last stage of a step of `rhs` with `event`."""
    @nb.njit(MONITOR_SIG)
    def monitor(t, y, p, d, out):
        rhs(t, y, p, d)
        g, gd = event(t, y, p)
        return -y[0], g, gd
    return monitor


osc_minus_x = minus_x(osc_rhs, never)


def run(rhs, event, action, monitor, y0, p, edges, rtol, method="dopri5", record=True,
        n_samples=3, h_max=10.0, n_mem=1, margin=0.0):
    tab = METHODS[method]
    p = np.asarray(p, float)
    return integrate(rhs, event, action, monitor, np.asarray(y0, float), p, len(p) - n_mem,
                     n_mem, np.asarray(edges, float), rtol, np.full(len(y0), rtol), len(y0),
                     0.0, h_max, 10**6, record, 1e-14, margin, n_samples, 40, tab.arrays(),
                     0, len(y0))[:6]


@pytest.mark.parametrize("method", sorted(METHODS))
def test_oscillator_error_decreases_with_rtol_at_the_expected_rate(method):
    errors, nfevs = [], []
    for rtol in (1e-5, 1e-7, 1e-9):
        ts, ys, *_ , counters = run(osc_rhs, never, nothing, osc_minus_x, [1.0, 0.0], [2.0, 0.0],
                                    [0.0, 10.0], rtol, method)
        errors.append(np.max(np.abs(ys[:, 0] - np.cos(2.0 * ts))))
        nfevs.append(counters[0])
        assert counters[4] == 0
    assert errors[0] > errors[1] > errors[2]
    # error per function evaluation follows the order of the method: nfev ~ err^(-1/order)
    order = METHODS[method].order
    slope = -np.log(errors[2] / errors[0]) / np.log(nfevs[2] / nfevs[0])
    assert order - 1.5 < slope < order + 1.0


@pytest.mark.parametrize("method", sorted(METHODS))
def test_dense_output_interpolates_to_its_order(method):
    tab = METHODS[method]
    K = np.zeros((tab.P.shape[0], 2))
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
def ball_event(t, y, p):
    return -y[0], -y[1]


ball_minus_x = minus_x(ball_rhs, ball_event)


@nb.njit(ACTION_SIG)
def ball_bounce(t, y, p):
    y[1] = -p[0] * y[1]
    p[1] += 1.0


def test_bouncing_ball_impact_times_are_located_exactly():
    """Ball dropped from 1 m, restitution 0.8: impact times t1 = sqrt(2/g), t_(k+1) = t_k +
    2 e^k v1 / g. The integrator must land on each of them (not the next step inside)."""
    g, e = 9.81, 0.8
    ts, ys, ms, _, _, counters = run(ball_rhs, ball_event, ball_bounce, ball_minus_x, [1.0, 0.0],
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
def bump(t, y, p):
    # positive only for |t - 1| < 0.01: an excursion much shorter than the steps taken
    if p[0] < 0.5:
        return 1e-4 - (t - 1.0) ** 2, -2.0 * (t - 1.0)
    return -1.0, 0.0


@nb.njit(EVENT_SIG)
def bump_without_rate(t, y, p):
    # the same excursion, but the model reports no rate: only samples can find it
    return bump(t, y, p)[0], 0.0


bump_minus_x = minus_x(still, bump)
bump_only_minus_x = minus_x(still, bump_without_rate)


@nb.njit(ACTION_SIG)
def flag(t, y, p):
    p[0] = 1.0


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_interior_samples_catch_a_crossing_and_return_inside_one_step(method):
    # With no dynamics the step grows to h_max = 0.4 and step ends never see g > 0.
    # (dop853: its first look is the cubic Hermite one of `_clear_of_surface`, which must
    # send these steps to the full search)
    *_, counters = run(still, bump_without_rate, flag, bump_only_minus_x, [0.0], [0.0], [0.0, 3.0],
                       1e-8, n_samples=0, h_max=0.4, method=method)
    assert counters[3] == 0   # missed without interior samples: this is what they are for
    *_, counters = run(still, bump_without_rate, flag, bump_only_minus_x, [0.0], [0.0], [0.0, 3.0],
                       1e-8, n_samples=39, h_max=0.4, method=method)
    assert counters[3] == 1
    # with no interior samples at all, the rates at the step ends reveal the excursion: the
    # cubic Hermite interpolant of g rises to the surface, so the step is sampled finer
    *_, counters = run(still, bump, flag, bump_minus_x, [0.0], [0.0], [0.0, 3.0], 1e-8,
                       n_samples=0, h_max=0.4, margin=1e-3, method=method)
    assert counters[3] == 1


@nb.njit(EVENT_SIG)
def osc_above(t, y, p):
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
        g0, gd0 = osc_above(t, y, p)
        g1, gd1 = osc_above(t + h, y_new, p)
        got = _clear_of_surface(osc_above, t, y, y_new, K[0], K[B.shape[0]], h, p, g0, gd0,
                                g1, gd1, 1, 1e-14, margin, ytmp)
        assert got == clear, level


def test_window_peaks_are_refined_between_steps():
    # x = cos(2t): max of -x over [0, 3] is 1 at t = pi/2, in general between two steps
    ts, ys, _, peaks, peak_t, counters = run(osc_rhs, never, nothing, osc_minus_x, [1.0, 0.0],
                                             [2.0, 0.0], [0.0, 3.0], 1e-10)
    sampled = np.max(-ys[:, 0])
    # the refined peak is limited only by the global error of the solution (~1e-9 here) ...
    assert peaks[0] == pytest.approx(1.0, abs=1e-8)
    assert peak_t[0] == pytest.approx(math.pi / 2, abs=1e-4)
    # ... while the best step point misses it by the curvature times the step squared
    assert 1.0 - sampled > 100 * abs(1.0 - peaks[0])


@nb.njit(MONITOR_SIG)
def two_bumps(t, y, p, d, out):
    d[0] = 0.0
    # the maximum (1.0 at t = 0.1) sits inside the window's first step (0 to 0.25), while
    # the best step point is the window's end (0.9 at t = 1)
    m = math.exp(-((t - 0.1) / 0.15) ** 2) + 0.9 * math.exp(-((t - 1.0) / 0.3) ** 2)
    return m, -1.0, 0.0      # the event function `never`


def test_a_peak_inside_the_first_step_of_a_window_is_found():
    tab = METHODS["dopri5"]
    ts, _, _, peaks, peak_t, counters, _ = integrate(
        still, never, nothing, two_bumps, np.zeros(1), np.zeros(1), 0, 1, np.array([0.0, 1.0]),
        1e-8, np.full(1, 1e-8), 1, 0.25, 0.25, 1000, True, 1e-14, 0.0, 1, 40, tab.arrays(), 0,
        1)
    samples = [two_bumps(t, np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(0))[0] for t in ts]
    assert max(samples) < 0.95 and ts[1] >= 0.25   # no step point near the true peak
    grid = np.linspace(0.05, 0.15, 200001)     # the true maximum, on a fine grid
    values = [two_bumps(t, np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(0))[0] for t in grid]
    assert peaks[0] == pytest.approx(max(values), abs=1e-9)
    assert peak_t[0] == pytest.approx(grid[int(np.argmax(values))], abs=1e-5)


@nb.njit(MONITOR_SIG)
def near_tie(t, y, p, d, out):
    d[0] = 0.0
    # two narrow crests: the higher (1.0 at t = 0.35) falls between the steps (0.1 apart),
    # whose best sample is the lower crest's top (0.999 at t = 0.7)
    m = math.exp(-((t - 0.35) / 0.1) ** 2) + 0.999 * math.exp(-((t - 0.7) / 0.1) ** 2)
    return m, -1.0, 0.0      # the event function `never`


def test_the_higher_of_two_nearly_equal_crests_is_refined():
    """Top-k refinement: the best sample sits on the lower crest; refining only around it
    would return ~0.999, the true maximum (fine grid) is ~1.0 near t = 0.35."""
    tab = METHODS["dopri5"]
    ts, _, _, peaks, peak_t, counters, _ = integrate(
        still, never, nothing, near_tie, np.zeros(1), np.zeros(1), 0, 1, np.array([0.0, 1.0]),
        1e-8, np.full(1, 1e-8), 1, 0.1, 0.1, 1000, True, 1e-14, 0.0, 1, 40, tab.arrays(), 0, 1)
    samples = [near_tie(t, np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(0))[0] for t in ts]
    assert abs(ts[int(np.argmax(samples))] - 0.7) < 1e-9   # the best sample: the lower crest
    grid = np.linspace(0.3, 0.4, 200001)
    values = [near_tie(t, np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(0))[0] for t in grid]
    assert peaks[0] == pytest.approx(max(values), abs=1e-9)
    assert peak_t[0] == pytest.approx(grid[int(np.argmax(values))], abs=1e-5)
    # refined: the steps on both sides of each crest and the window's first and last steps,
    # no step twice (3 crests at most: the start sample, 0.3 and 0.7 -> at most 6 + 2 steps)
    assert 4 <= counters[5] <= 2 * N_CRESTS + 2


def test_near_tie_design_of_the_slider_crank_refines_the_right_crest():
    """At (L2, L3) = (0.0575, 0.105) of the GA box the rev-4 window has two crests of |F12|
    within 1.3e-4 of each other, one near each end of the window; refining around the best
    sample only picked the lower one (error 1.3e-4). Reference: rtol 1e-12."""
    from mbs_clearance import reduced
    from mbs_clearance.mechanism import SliderCrank
    from mbs_clearance.optimize import design_mechanism

    mech = design_mechanism(SliderCrank(), {"crank_length": 0.0575, "coupler_length": 0.105})
    ref = reduced.run(mech, 4, rtol=1e-12, record=False)
    out = reduced.run(mech, 4, record=False)
    assert abs(out[3][3] / ref[3][3] - 1.0) < 1e-5
    assert abs(out[4][3] - ref[4][3]) < 1e-3 * mech.period     # the same crest
