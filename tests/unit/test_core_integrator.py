"""The compiled integrator (`mbs_clearance.core`): against closed forms (a linear
oscillator, a bouncing ball), the observed order of each method, the refined window peaks,
the statuses, every branch of the core on the ball, a crossing and return inside one step,
rodas4's order on a stiff problem, two runs in two threads at once; one step alone (the
dense output's order, DOP853 against scipy's, the cubic look); peaks inside a window's
first step and the higher of two near-tied crests (also on the slider-crank); two switching
functions (each with its own memory, two in one step, simultaneous, a grazing touch, the
impact times' order)."""

import gc
import math
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from mbs_clearance.core import build
from mbs_clearance.core.integrate import NO_EVENTS_C, integrate, model_record, no_events_source
from mbs_clearance.numerics.integrator import METHODS, N_CRESTS, RESULTS, make_settings

sys.path.insert(0, str(Path(__file__).parent))
from core_models import (  # noqa: E402
    BALL_C,
    BALL_MEM_START,
    COUNT,
    GRAZE_C,
    NONLINEAR_C,
    OSC_ABOVE_C,
    OSCILLATOR_C,
    TWO_C,
    TWO_MEM,
    TWO_N_MEM,
    ball_parameters,
    ball_settings,
    bounce_times,
    core_probe,
    switching_model,
    two_physical,
)

METHOD_NAMES = sorted(METHODS)


@pytest.fixture(scope="module")
def ball():
    return model_record(*build.load("test_ball", [("ball.c", BALL_C)]))


@pytest.fixture(scope="module")
def oscillator():
    return model_record(*build.load("test_oscillator", [("oscillator.c", OSCILLATOR_C)]))


def run_oscillator(model, y0, edges, rtol=1e-10, method="dopri5", **kwargs):
    """The oscillator x'' = -x (omega = 1) under `method`; returns integrate's tuple."""
    kwargs.setdefault("refine_iters", 24)
    settings = make_settings(rtol, np.full(2, rtol), 2, n_dense=2, mem_start=1, n_mem=0,
                             **kwargs)
    return integrate(model, np.asarray(y0, float), np.array([1.0]), np.asarray(edges, float),
                     settings, METHODS[method].arrays())


@pytest.mark.parametrize("method", METHOD_NAMES)
def test_oscillator_follows_its_closed_form(oscillator, method):
    t, y, memory, peaks, peak_t, counters, outputs, status = run_oscillator(
        oscillator, [1.0, 0.0], [0.0, 10.0], rtol=1e-10, method=method)
    assert status == RESULTS.success
    assert len(t) == counters[1] + 1 and t[0] == 0.0 and t[-1] == 10.0
    assert np.all(np.diff(t) > 0.0)
    # global error of a 10-s run at rtol = atol = 1e-10: a few hundred times the tolerance
    assert np.max(np.abs(y[:, 0] - np.cos(t))) < 1e-7
    assert np.max(np.abs(y[:, 1] + np.sin(t))) < 1e-7
    assert memory.shape == (len(t), 1) and outputs.shape == (len(t), 0)
    # the arrays own the core's buffers (no copy): writable, and they outlive the call's
    # result and later runs unchanged
    arrays = (t, y, memory, peaks, peak_t, counters, outputs)
    assert all(a.flags.writeable and a.flags.c_contiguous for a in arrays)
    kept = [a.copy() for a in arrays]
    gc.collect()
    for _ in range(3):
        run_oscillator(oscillator, [0.5, 0.5], [0.0, 10.0], method=method)
    assert all(np.array_equal(a, b) for a, b in zip(arrays, kept))


@pytest.mark.parametrize("method", METHOD_NAMES)
def test_each_method_converges_at_its_order(oscillator, method):
    """Fixed steps (h0 = h_max = h, tolerances so loose that no step is rejected): the
    error at t = 4 falls by 2^order per halving of h."""
    order = METHODS[method].order
    steps = (1.0, 0.5, 0.25) if method == "dop853" else (0.2, 0.1, 0.05)
    errors = []
    for h in steps:
        t, y, *_, counters, _, status = run_oscillator(
            oscillator, [1.0, 0.0], [0.0, 4.0], rtol=1e3, method=method, h0=h, h_max=h,
            refine_iters=0)
        assert status == RESULTS.success and counters[2] == 0
        assert counters[1] == round(4.0 / h)
        errors.append(abs(y[-1, 0] - math.cos(4.0)) + abs(y[-1, 1] + math.sin(4.0)))
    observed = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(observed - order) < 0.2), observed


def test_refined_peaks_find_the_maxima_between_samples(oscillator):
    """The monitor x(t) = cos(t - 0.5) from t = 0.5 has its maxima at 0.5 + 2 pi k; each
    window holds one, between two steps: refined to the integration accuracy, where the
    best sample falls short by about (omega h)^2 / 8."""
    start = 0.5
    edges = [start, 4.0, 9.0, 15.0]
    sampled = run_oscillator(oscillator, [1.0, 0.0], edges, rtol=1e-11, refine_iters=0)
    refined = run_oscillator(oscillator, [1.0, 0.0], edges, rtol=1e-11)
    crest_t = np.array([start, start + 2.0 * math.pi, start + 4.0 * math.pi])
    # the first window's maximum is its start (x = 1 there)
    assert refined[3][0] == 1.0 and refined[4][0] == start
    sample_err = np.abs(sampled[3][1:] - 1.0)
    refined_err = np.abs(refined[3][1:] - 1.0)
    assert np.all(refined_err < 1e-9)
    assert np.all(sample_err > 100.0 * refined_err)
    # the location of a quadratic maximum is known to about the square root of its value's
    # error (1e-11 here)
    assert np.allclose(refined[4][1:], crest_t[1:], atol=1e-5)
    assert np.all(refined[5][4] > 0) and sampled[5][4] == 0


def test_records_grow_beyond_their_first_allocation(oscillator):
    """More steps than the first record block (16384 rows): every accepted step kept."""
    t, y, *_, counters, _, status = run_oscillator(oscillator, [1.0, 0.0], [0.0, 20.0],
                                                   h_max=1e-3, refine_iters=0)
    assert status == RESULTS.success
    assert len(t) == counters[1] + 1 > 16384 * 1.2
    assert np.all(np.diff(t) > 0.0)
    assert np.max(np.abs(y[:, 0] - np.cos(t))) < 1e-8


@pytest.mark.parametrize("method", METHOD_NAMES)
def test_ball_bounces_at_its_closed_form_times(ball, method):
    """A ball dropped from 1 m (g = 9.81, restitution 0.8): its impacts, located and landed
    on, against the closed form, and the refined peak height of each window (one apex
    each) against e^(2k) h0."""
    g, e, h0 = 9.81, 0.8, 1.0
    impacts = bounce_times(h0, g, e, 5)
    flights = np.diff(np.concatenate([[0.0], impacts]))
    # window k + 1 from a quarter into flight k to a quarter into flight k + 1
    edges = np.concatenate([[0.0], impacts[:4] + 0.25 * flights[1:]])
    p = ball_parameters(g=g, e=e)
    settings = ball_settings(1e-10)
    t, y, memory, peaks, peak_t, counters, outputs, status = integrate(
        ball, np.array([h0, 0.0, 0.0]), p, edges, settings, METHODS[method].arrays())
    assert status == RESULTS.success
    count = memory[:, COUNT - BALL_MEM_START]
    bounced = t[1:][np.diff(count) > 0]
    n = len(bounced)
    assert n == 4 == counters[3] == p[COUNT]
    assert np.allclose(bounced, impacts[:n], rtol=1e-9, atol=0)
    # the height is h = X + alpha + beta t: zero at each landing
    h_at = (y[1:, 0] + memory[1:, 0] + memory[1:, 1] * t[1:])[np.diff(count) > 0]
    assert np.all(np.abs(h_at) < 1e-9)
    # the velocity output after each bounce: -e times the one before
    v = outputs[:, 0]
    ups = v[1:][np.diff(count) > 0]
    assert np.allclose(ups, e ** np.arange(1, n + 1) * g * impacts[0], rtol=1e-9)
    apex = h0 * e ** (2.0 * np.arange(len(peaks)))
    assert np.allclose(peaks, apex, rtol=1e-9, atol=0)
    apex_t = np.concatenate([[0.0], impacts[:3] + 0.5 * flights[1:4]])
    assert np.allclose(peak_t, apex_t, atol=1e-5)


def test_statuses(ball):
    """max_steps, step_underflow (the right-hand side NaN from t = 0.3 on: every step
    across it is rejected and shrunk to nothing) and event chatter (a switching function
    past its surface that no action turns: 21 zero-length events), each stopping the run
    where it happened."""
    y0 = np.array([1.0, 0.0, 0.0])
    edges = np.array([0.0, 2.0])
    tab = METHODS["dopri5"].arrays()
    t, *_, counters, _, status = integrate(ball, y0, ball_parameters(), edges,
                                           ball_settings(1e-8, max_steps=7), tab)
    assert RESULTS(status) is RESULTS.max_steps
    assert counters[1] + counters[2] == 7 and t[-1] < 2.0
    t, *_, counters, _, status = integrate(ball, y0, ball_parameters(nan_after=0.3), edges,
                                           ball_settings(1e-8), tab)
    assert RESULTS(status) is RESULTS.step_underflow
    assert 0.3 - 1e-12 < t[-1] <= 0.3 and counters[2] > 10
    t, *_, counters, _, status = integrate(ball, y0, ball_parameters(chatter=True), edges,
                                           ball_settings(1e-8), tab)
    assert RESULTS(status) is RESULTS.event_chatter
    assert counters[3] == 21 and counters[1] == 0 and list(t) == [0.0]


def test_bad_input_is_refused_before_the_run(ball):
    y0 = np.array([1.0, 0.0, 0.0])
    tab = METHODS["dopri5"].arrays()
    with pytest.raises(ValueError, match="p must have the model's 11 entries"):
        integrate(ball, y0, np.zeros(4), np.array([0.0, 1.0]), ball_settings(), tab)
    with pytest.raises(ValueError, match="edges at least 2"):
        integrate(ball, y0, ball_parameters(), np.array([0.0]), ball_settings(), tab)
    with pytest.raises(ValueError, match="writable contiguous"):
        integrate(ball, y0, ball_parameters()[::1].tolist(), np.array([0.0, 1.0]),
                  ball_settings(), tab)


def test_out_of_memory_is_an_error_not_a_crash(ball):
    """Work arrays that cannot be allocated (2^40 event samples a step: tens of TB)."""
    with pytest.raises(MemoryError, match="ran out of memory"):
        integrate(ball, np.array([1.0, 0.0, 0.0]), ball_parameters(), np.array([0.0, 1.0]),
                  ball_settings(n_samples=2 ** 40), METHODS["dopri5"].arrays())


# ball runs through every branch of the core: (settings keywords, parameter keywords, y0)
BALL_CASES = [
    ({}, dict(drag=0.3, ceiling=0.8, e=0.9), (0.5, 3.0, 0.0)),
    (dict(event_control=True, event_margin=1e-4), dict(drag=0.3, ceiling=0.8, e=0.9),
     (0.5, 3.0, 0.0)),
    (dict(dense=3, n_samples=0, n_crests=1, refine_iters=5), dict(e=0.7), (1.0, 0.0, 0.0)),
    (dict(record=False), dict(drag=0.1, ceiling=0.9), (0.5, 3.0, 0.0)),
    ({}, dict(nan_after=1.3), (1.0, 0.0, 0.0)),
    ({}, dict(chatter=True), (1.0, 0.0, 0.0)),
    (dict(max_steps=30), dict(drag=0.3, ceiling=0.8), (0.5, 3.0, 0.0)),
    # two joints on their surface at once (the second switched with the first)
    ({}, dict(twin=True, e=0.9), (1.0, 0.0, 0.0)),
    # longer than the short-state fast paths (9 > 8 states)
    (dict(n_state=9, event_control=True), dict(drag=0.3, ceiling=0.8),
     (0.5, 3.0, 0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6)),
]


@pytest.mark.parametrize("method", METHOD_NAMES)
def test_ball_cases_reach_every_status_and_count_their_impacts(ball, method):
    """The ball through every branch of the core, for each method (the switching functions
    under error control or not, a state wider than the dense one, a state longer than the
    short-state fast paths, records off, crests refined): every status is reached; each
    located event is one action (the bounce count in p) or, for two joints on their
    surface at once, two events per action; where both surfaces are hit the highest point
    is the ceiling; a run without its record has the recorded run's peaks and counters bit
    for bit (recording changes nothing of the integration)."""
    edges = np.linspace(0.0, 4.0, 9)
    tab = METHODS[method].arrays()
    statuses = set()
    for skw, pkw, y0 in BALL_CASES:
        p = ball_parameters(**pkw)
        got = integrate(ball, np.array(y0), p, edges, ball_settings(1e-7, **skw), tab)
        status = RESULTS(got[7])
        statuses.add(status)
        if pkw.get("twin"):
            assert got[5][3] == 2 * p[COUNT] > 0
        elif status == RESULTS.success:
            assert got[5][3] == p[COUNT] > 0
        if pkw.get("ceiling", 1e3) < 1.0 and "max_steps" not in skw:
            assert got[5][3] > 4 and abs(np.max(got[3]) - pkw["ceiling"]) < 1e-9
        if skw.get("record") is False:
            p_rec = ball_parameters(**pkw)
            rec = integrate(ball, np.array(y0), p_rec, edges,
                            ball_settings(1e-7, **{**skw, "record": True}), tab)
            assert len(got[0]) <= 1 < len(rec[0])
            for a, b in zip(got[3:6], rec[3:6]):
                assert np.array_equal(a, b)
            assert np.array_equal(p, p_rec)
    assert statuses == set(RESULTS)


RENDEZVOUS_C = r"""
#define _POSIX_C_SOURCE 199309L
#include <time.h>
#include "mbs_core.h"
""" + NO_EVENTS_C + r"""
/* the first monitor call of each run enters a rendezvous: it counts itself in and waits
 * (at most 20 s) until two runs are in at once; the count it saw is kept per run */
static int inside = 0;
static int seen[2] = {0, 0};
static int entered[2] = {0, 0};

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static void rhs(double t, const double *y, int64_t n, const double *p, double *dydt)
{
    (void)t; (void)n; (void)p;
    dydt[0] = -y[0];
}


static double monitor(double t, const double *y, int64_t n, const double *p, double *dydt,
                      double *out, int64_t n_out, double *g, double *gd)
{
    (void)out; (void)n_out;
    int k = (int)p[0];
    if (!__atomic_exchange_n(&entered[k], 1, __ATOMIC_SEQ_CST)) {
        __atomic_add_fetch(&inside, 1, __ATOMIC_SEQ_CST);
        double until = now() + 20.0;
        while (__atomic_load_n(&inside, __ATOMIC_SEQ_CST) < 2 && now() < until)
            ;
        __atomic_store_n(&seen[k], __atomic_load_n(&inside, __ATOMIC_SEQ_CST),
                         __ATOMIC_SEQ_CST);
    }
    rhs(t, y, n, p, dydt);
    g[0] = -1.0;
    gd[0] = 0.0;
    return y[0];
}

static const mbs_model RECORD = {1, 1, 1, 1, 0, 0, 1, 1, rhs, event, on_event, monitor, prepare};

const mbs_model *mbs_model_record(void) { return &RECORD; }

int rendezvous_seen(int k) { return __atomic_load_n(&seen[k], __ATOMIC_SEQ_CST); }

void rendezvous_reset(void)
{
    for (int k = 0; k < 2; k++) {
        __atomic_store_n(&seen[k], 0, __ATOMIC_SEQ_CST);
        __atomic_store_n(&entered[k], 0, __ATOMIC_SEQ_CST);
    }
    __atomic_store_n(&inside, 0, __ATOMIC_SEQ_CST);
}
"""


def test_runs_in_two_threads_at_once():
    """cffi releases the GIL around every call of a C function (its documentation: "C
    function calls are done with the GIL released"); checked by counting: each of two
    threads' runs waits inside the core until the other's is inside too, and records how
    many it saw (with the GIL held the first would see only itself, after its wait)."""
    ffi, lib = build.load("test_rendezvous", [("rendezvous.c", RENDEZVOUS_C)],
                          cdef="int rendezvous_seen(int k); void rendezvous_reset(void);")
    lib.rendezvous_reset()
    model = model_record(ffi, lib)
    settings = make_settings(1e-6, np.full(1, 1e-6), 1, n_dense=1, mem_start=1, n_mem=0)
    results = {}

    def work(k):
        results[k] = integrate(model, np.array([1.0]), np.array([float(k)]),
                               np.array([0.0, 1.0]), settings, METHODS["dopri5"].arrays())

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert [lib.rendezvous_seen(k) for k in range(2)] == [2, 2]
    for k in range(2):
        assert results[k][7] == RESULTS.success
        assert abs(results[k][1][-1, 0] - math.exp(-1.0)) < 1e-5


# a state at rest and one switching function positive only for |t - 1| < 0.01 (p[0] = 0):
# an excursion much shorter than the steps taken; its action sets p[0] = 1 (the memory).
# With p[1] = 1 the model reports no rate of the switching function: only samples find it
BUMP_C = switching_model(r"""
#include "mbs_core.h"

static void rhs(double t, const double *y, int64_t n, const double *p, double *dydt)
{
    (void)t; (void)y; (void)n; (void)p;
    dydt[0] = 0.0;
}

static void event(double t, const double *y, const double *p, int64_t j, double *g_gd)
{
    (void)y; (void)j;
    if (p[0] < 0.5) {
        g_gd[0] = 1e-4 - (t - 1.0) * (t - 1.0);
        g_gd[1] = p[1] > 0.5 ? 0.0 : -2.0 * (t - 1.0);
    } else {
        g_gd[0] = -1.0;
        g_gd[1] = 0.0;
    }
}

static void on_event(double t, const double *y, double *p, int64_t j)
{
    (void)t; (void)y; (void)j;
    p[0] = 1.0;
}
""", "-y[0]", 1, "1, 1, 1, 0, 1, 0, 2, 2")


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_interior_samples_catch_a_crossing_and_return_inside_one_step(method):
    """With no dynamics the step grows to h_max = 0.4 and the step ends never see the
    switching function's excursion above zero (0.02 s wide): missed without interior
    samples and without its rate (this is what they are for), found with 39 samples; with
    no samples but the rate at the step ends, the cubic Hermite look rises to the surface
    and the step is searched finer."""
    model = model_record(*build.load("test_bump", [("bump.c", BUMP_C)]))

    def events(n_samples, rate, margin=0.0):
        p = np.array([0.0, 0.0 if rate else 1.0])
        settings = make_settings(1e-8, np.full(1, 1e-8), 1, h_max=0.4, event_tol=1e-14,
                                 event_margin=margin, n_samples=n_samples, n_dense=1,
                                 n_events=1, mem_start=0, n_mem=1)
        out = integrate(model, np.array([0.0]), p, np.array([0.0, 3.0]), settings,
                        METHODS[method].arrays())
        assert RESULTS(out[7]) == RESULTS.success
        assert out[5][3] == p[0]          # each located event ran the action once
        return out[5][3]

    assert events(0, rate=False) == 0
    assert events(39, rate=False) == 1
    assert events(0, rate=True, margin=1e-3) == 1


# y0' = -y0 + y1 + sin t, y1' = lambda y1 (p = [lambda]): a fast mode and a time-dependent
# forcing (df/dt enters a Rosenbrock method's stages)
STIFF_C = no_events_source("""
    dydt[0] = -y[0] + y[1] + sin(t);
    dydt[1] = p[0] * y[1];""", "y[0]", 2, 1, 1)


def _stiff_exact(t, y0, lam):
    """Closed form of y0' = -y0 + y1 + sin t, y1' = lam y1."""
    c_exp = y0[1] / (lam + 1.0)

    def part(s):
        return c_exp * math.exp(lam * s) + (math.sin(s) - math.cos(s)) / 2.0
    return np.array([(y0[0] - part(0.0)) * math.exp(-t) + part(t), y0[1] * math.exp(lam * t)])


def test_rodas4_converges_at_order_4_on_a_stiff_linear_problem():
    """rodas4's step map (`step_states`) with fixed steps h = 1/N on a linear problem with a
    fast mode (lambda = -1e4, h |lambda| from 1000 to 125: far outside every explicit
    method's stability region) against the closed form at t = 1: the error falls about
    2^4-fold per halving, and the fast mode is damped, not amplified."""
    from mbs_clearance.core.integrate import step_states

    model = model_record(*build.load("test_stiff", [("stiff.c", STIFF_C)]))
    p, y0, lam = np.array([-1.0e4]), np.array([1.0, 1.0]), -1.0e4
    co = METHODS["rodas4"].arrays()
    errors = []
    for n_steps in (10, 20, 40, 80):
        h, y = 1.0 / n_steps, y0.copy()
        for k in range(n_steps):
            y = step_states(model, k * h, y, p, np.array([h]), co, 0)[0][0]
        errors.append(np.max(np.abs(y - _stiff_exact(1.0, y0, lam))))
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(ratios > 2.0 ** 4 * 0.8) and np.all(ratios < 2.0 ** 4 * 1.5), ratios
    assert errors[-1] < 1e-10


# ---------------------------------------------------------------- one step, alone
@pytest.fixture(scope="module")
def probe():
    return core_probe()


def _model(label, source):
    return model_record(*build.load(label, [(label + ".c", source)]))


@pytest.mark.parametrize("method", METHOD_NAMES)
def test_dense_output_interpolates_to_its_order(oscillator, probe, method):
    """One step of the oscillator x'' = -x from (1, 0): the continuous extension ends at the
    step (to rounding) and its error at theta = 0.37 against cos(0.37 h) falls as
    h^(q + 1), q the order of the continuous extension (P's columns)."""
    step_dense, _ = probe
    co = METHODS[method].arrays()
    q = METHODS[method].P.shape[1]
    errs = []
    for h in (0.4, 0.2) if method == "dop853" else (0.1, 0.05):
        y1, dense = step_dense(oscillator, co, 0.0, [1.0, 0.0], [1.0], h, [1.0, 0.37])
        # DOP853's monomial coefficients reach ~500, so its sums round at ~1e-13
        assert np.allclose(dense[0], y1, rtol=0, atol=1e-13 if method == "dop853" else 1e-15)
        errs.append(abs(dense[1, 0] - math.cos(0.37 * h)))
    assert errs[0] / errs[1] > 2 ** (q + 1) * 0.6, errs


def test_dop853_step_and_dense_output_match_scipy(probe):
    """One DOP853 step of the core against scipy's DOP853 (the same tableau, independent
    code) on a nonlinear, time-dependent pair: the same step end and the same continuous
    extension."""
    from scipy.integrate import DOP853

    step_dense, _ = probe
    model = _model("test_nonlinear", NONLINEAR_C)
    y0, h = np.array([0.7, -0.3]), 0.3

    def fun(t, y):
        return np.array([y[1] * math.cos(t), -y[0] ** 2 + math.sin(3.0 * t)])

    ref = DOP853(fun, 0.0, y0, 1.0, first_step=h, rtol=1e-3, atol=1e-3)
    ref.step()
    assert ref.t == pytest.approx(h, rel=1e-15)
    thetas = np.array([0.1, 0.5, 0.83])
    y1, dense = step_dense(model, METHODS["dop853"].arrays(), 0.0, y0, [0.0], h, thetas)
    np.testing.assert_allclose(y1, ref.y, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(dense, ref.dense_output()(thetas * h).T, rtol=1e-13, atol=1e-14)


def test_cubic_look_declares_a_step_clear_only_far_from_the_surface(probe):
    """The cubic look (`clear_of_surface`, one interior sample) on one resolved DOP853 step
    of the oscillator (omega h = 0.2, from its maximum 1 down to cos 0.2) against the
    switching function g = x - level: clear when the level is far above the motion; not
    clear when the motion comes within twice the margin of it, nor when the step starts on
    it."""
    _, clear_of_surface = probe
    model = _model("test_osc_above", OSC_ABOVE_C)
    co = METHODS["dop853"].arrays()
    margin = 1e-3
    for level, clear in ((2.0, True), (1.0 + 1.5 * margin, False), (1.0, False)):
        got = clear_of_surface(model, co, 0.0, [1.0, 0.0], [1.0, level], 0.2, 1, 1e-14, margin)
        assert got == clear, level


# ---------------------------------------------------------------- window peaks of a known value
# a state at rest whose monitored value is a given function of t (no switching)
TWO_BUMPS = "exp(-pow((t - 0.1) / 0.15, 2)) + 0.9 * exp(-pow((t - 1.0) / 0.3, 2))"
NEAR_TIE = "exp(-pow((t - 0.35) / 0.1, 2)) + 0.999 * exp(-pow((t - 0.7) / 0.1, 2))"


def two_bumps(t):
    return np.exp(-((t - 0.1) / 0.15) ** 2) + 0.9 * np.exp(-((t - 1.0) / 0.3) ** 2)


def near_tie(t):
    return np.exp(-((t - 0.35) / 0.1) ** 2) + 0.999 * np.exp(-((t - 0.7) / 0.1) ** 2)


def run_value(label, value, h):
    """A run over [0, 1] of the state at rest monitoring `value` (C, of t) in steps of h
    (h0 = h_max = h, one interior sample); returns integrate's tuple."""
    model = _model(label, no_events_source("    dydt[0] = 0.0;", value, 1, 1, 1))
    settings = make_settings(1e-8, np.full(1, 1e-8), 1, h0=h, h_max=h, event_tol=1e-14,
                             n_samples=1, refine_iters=40, n_dense=1, mem_start=1, n_mem=0)
    out = integrate(model, np.array([0.0]), np.array([0.0]), np.array([0.0, 1.0]), settings,
                    METHODS["dopri5"].arrays())
    assert RESULTS(out[7]) == RESULTS.success
    return out


def test_a_peak_inside_the_first_step_of_a_window_is_found():
    """The maximum (1.0 at t = 0.1) sits inside the window's first step (0 to 0.25), while
    the best step point is the window's end (0.9 at t = 1): refined to the maximum on a
    fine grid."""
    t, _, _, peaks, peak_t, *_ = run_value("test_two_bumps", TWO_BUMPS, 0.25)
    assert np.max(two_bumps(t)) < 0.95 and t[1] >= 0.25   # no step point near the true peak
    grid = np.linspace(0.05, 0.15, 200001)
    values = two_bumps(grid)
    assert peaks[0] == pytest.approx(np.max(values), abs=1e-9)
    assert peak_t[0] == pytest.approx(grid[np.argmax(values)], abs=1e-5)


def test_the_higher_of_two_nearly_equal_crests_is_refined():
    """Two narrow crests: the higher (1.0 at t = 0.35) falls between the steps (0.1 apart),
    whose best sample is the lower crest's top (0.999 at t = 0.7). Refining only around the
    best sample would return ~0.999; the window's top crests are refined, and the maximum
    is the one on a fine grid near t = 0.35."""
    t, _, _, peaks, peak_t, counters, _, _ = run_value("test_near_tie", NEAR_TIE, 0.1)
    assert abs(t[np.argmax(near_tie(t))] - 0.7) < 1e-9   # the best sample: the lower crest
    grid = np.linspace(0.3, 0.4, 200001)
    values = near_tie(grid)
    assert peaks[0] == pytest.approx(np.max(values), abs=1e-9)
    assert peak_t[0] == pytest.approx(grid[np.argmax(values)], abs=1e-5)
    # refined: the steps on both sides of each crest and the window's first and last steps,
    # no step twice (3 crests at most: the start sample, 0.3 and 0.7 -> at most 6 + 2 steps)
    assert 4 <= counters[4] <= 2 * N_CRESTS + 2


def test_near_tie_design_of_the_slider_crank_refines_the_right_crest():
    """At (L2, L3) = (0.0575, 0.105) of the GA box the 4th revolution's |F12| has two
    crests within 2e-4 of each other, at either end of the window (the reference's
    samples at rtol 1e-12 show both); the default run's peak is the higher one's, within
    1e-5 of the reference's and at its time (refining around the best sample only picked
    the lower one, 1.3e-4 off)."""
    from mbs_clearance import simulate
    from mbs_clearance.model.mechanism import SliderCrank
    from mbs_clearance.solve import reduced
    from mbs_clearance.studies.optimize import design_mechanism

    mech = design_mechanism(SliderCrank(), {"crank_length": 0.0575, "coupler_length": 0.105})
    ref = simulate(mech, 4, rtol=1e-12)
    period = mech.period
    f, t = ref.base_force_magnitude, ref.t
    first = (t >= 3.0 * period) & (t < 3.5 * period)
    last = (t >= 3.5 * period) & (t <= 4.0 * period)
    assert abs(f[first].max() / f[last].max() - 1.0) < 2e-4       # the near tie
    crest_t = t[last][np.argmax(f[last])]                           # the higher crest
    out = reduced.run(mech, 4, record=False)
    assert abs(out.peaks[3] / ref.peaks[3] - 1.0) < 1e-5
    assert abs(out.peak_times[3] - crest_t) < 1e-3 * period


# ---------------------------------------------------------------- two switching functions
def run_two(p, y0, t_end, rtol, method="dopri5", h0=0.0, h_max=10.0, n_samples=3):
    """The two bodies of `TWO_C` (p without memory) from y0 over [0, t_end]; returns
    (t, y, memory, counters, p with its memory, x, v) with the physical positions and
    velocities x, v (len(t), 2)."""
    model = _model("test_two", TWO_C)
    p = np.concatenate([np.asarray(p, float), np.zeros(TWO_N_MEM)])
    settings = make_settings(rtol, np.full(4, rtol), 4, h0=h0, h_max=h_max, event_tol=1e-13,
                             n_samples=n_samples, refine_iters=40, n_dense=4, n_events=2,
                             mem_start=TWO_MEM, n_mem=TWO_N_MEM)
    t, y, memory, _, _, counters, _, status = integrate(
        model, np.asarray(y0, float), p, np.array([0.0, t_end]), settings,
        METHODS[method].arrays())
    assert RESULTS(status) == RESULTS.success
    return (t, y, memory, counters, p, *two_physical(t, y, memory, p))


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


def _hits(memory, j):
    """The recorded steps that landed on an impact of joint j (its count grew)."""
    return np.flatnonzero(np.diff(memory[:, 4 * j]) == 1) + 1


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_two_joints_events_located_each_with_its_own_memory(method):
    """Two oscillators against their walls: both joints' impacts landed on (|g_j| <=
    event_tol), at the closed-form times, each joint's count and impact velocity in its own
    memory entries, recorded with the steps (dop853 also runs the cubic look on two
    switching functions)."""
    t_end = 3.0
    t, _, memory, counters, p, x, _ = run_two(OSC2["p"], OSC2["y0"], t_end, 1e-10, method)
    ref = _osc2_reference(t_end)
    assert counters[3] == sum(len(times) for times, _ in ref)
    for j, (times, speeds) in enumerate(ref):
        assert len(times) >= 3
        hits = _hits(memory, j)
        assert len(hits) == len(times) and memory[-1, 4 * j] == len(times)
        np.testing.assert_allclose(t[hits], times, rtol=0, atol=1e-8)
        # landed: the wall within event_tol, plus the rounding of x recomposed here from
        # the state and the memory (~1e-15)
        assert np.all(np.abs(x[hits, j] - p[4 + j]) <= 1e-13 + 1e-14)
        np.testing.assert_allclose(memory[hits, 4 * j + 1], speeds, rtol=1e-7)
        # the other joint's memory does not move at joint j's impacts
        other = memory[:, 4 * (1 - j):4 * (2 - j)]
        assert np.array_equal(other[hits], other[hits - 1])


def test_two_events_inside_one_step_are_both_found_in_time_order():
    """Two balls dropped from rest (exact quadratic motion), floors reached at 0.3 s and
    0.4 s; the first step (h0 = 0.5 s, accepted: no error) contains both impacts. The
    earlier one is landed on first, then the other, each at its closed-form time."""
    a = 9.81
    t_a, t_b = 0.3, 0.4
    p = [0.0, 0.0, a, a, 0.0, 0.0, -1.0, -1.0, 0.8, 0.5]
    y0 = [0.5 * a * t_a**2, 0.0, 0.5 * a * t_b**2, 0.0]
    t, _, memory, counters, _, _, v = run_two(p, y0, 0.5, 1e-8, h0=0.5, h_max=0.5)
    assert counters[2] == 0                      # no rejection: the first step spans both
    assert t[1] == pytest.approx(t_a, abs=1e-12) and t[2] == pytest.approx(t_b, abs=1e-12)
    assert list(memory[1, [0, 4]]) == [1, 0] and list(memory[2, [0, 4]]) == [1, 1]
    assert memory[1, 1] == pytest.approx(-a * t_a, rel=1e-12)     # impact velocities
    assert memory[2, 5] == pytest.approx(-a * t_b, rel=1e-12)
    assert v[2, 0] == pytest.approx(0.8 * a * t_a - a * (t_b - t_a), rel=1e-12)


def test_simultaneous_events_switch_both_joints_at_one_landing():
    """Two balls dropped from the same height hit their floors at the same instant: one
    landing switches both (no zero-length second event), each with its own restitution."""
    a = 9.81
    t_hit = 0.3
    p = [0.0, 0.0, a, a, 0.0, 0.0, -1.0, -1.0, 0.8, 0.5]
    y0 = [0.5 * a * t_hit**2, 0.0, 0.5 * a * t_hit**2, 0.0]
    t, _, memory, counters, _, _, v = run_two(p, y0, 0.35, 1e-8)
    k = int(np.argmin(np.abs(t - t_hit)))
    assert t[k] == pytest.approx(t_hit, abs=1e-12)
    assert list(memory[k, [0, 4]]) == [1, 1] and list(memory[k - 1, [0, 4]]) == [0, 0]
    assert counters[3] == 2 and len(np.unique(t)) == len(t)
    assert v[k, 0] == pytest.approx(0.8 * a * t_hit, rel=1e-12)
    assert v[k, 1] == pytest.approx(0.5 * a * t_hit, rel=1e-12)


def test_grazing_touch_is_no_event_and_a_short_excursion_inside_a_step_is_found():
    """Joint 0 touches its surface (g = 0 at t = 1.5, negative around it): not an event.
    Joint 1 crosses and returns within 0.02 s, inside one step of 0.4 s, seen only by the
    interior samples: one event, located at its entry t = 0.99."""
    model = _model("test_graze", GRAZE_C)
    settings = make_settings(1e-8, np.full(1, 1e-8), 1, h_max=0.4, event_tol=1e-14,
                             n_samples=39, refine_iters=40, n_dense=1, n_events=2,
                             mem_start=1, n_mem=4)
    t, _, memory, _, _, counters, _, status = integrate(
        model, np.array([0.0]), np.zeros(5), np.array([0.0, 3.0]), settings,
        METHODS["dopri5"].arrays())
    assert RESULTS(status) == RESULTS.success and counters[3] == 1
    assert memory[-1, 0] == 0 and memory[-1, 2] == 1    # joint 0 never switched, joint 1 once
    assert memory[-1, 3] == pytest.approx(0.99, abs=1e-10)
    assert np.max(np.diff(t)) > 0.3                    # steps far longer than the excursion


def test_two_joints_with_impacts_converge_at_the_method_order():
    """Error of the impact times (both joints, closed form) against the function
    evaluations: nfev ~ err^(-1/order) with the events landed exactly. From rtol 1e-7 on:
    at 1e-6 locating and landing the 7 impacts is a fixed cost of nearly a third of the
    run's evaluations (573 against 404 without the walls), which steepens the observed
    slope (measured 6.3 from 1e-6 to 1e-10; 5.7 from 1e-7 to 1e-11)."""
    t_end = 2.0
    ref = _osc2_reference(t_end)
    errors, nfevs = [], []
    for rtol in (1e-7, 1e-9, 1e-11):
        t, _, memory, counters, *_ = run_two(OSC2["p"], OSC2["y0"], t_end, rtol)
        errors.append(max(np.max(np.abs(t[_hits(memory, j)] - times))
                          for j, (times, _) in enumerate(ref)))
        nfevs.append(counters[0])
    assert errors[0] > errors[1] > errors[2]
    slope = -np.log(errors[2] / errors[0]) / np.log(nfevs[2] / nfevs[0])
    order = METHODS["dopri5"].order
    assert order - 1.5 < slope < order + 1.0, (errors, nfevs)


def test_the_core_sets_the_allocator_unless_told_not_to(monkeypatch):
    """On glibc the core keeps blocks below 32 MiB on the heap and up to 128 MiB of it
    mapped (`integrate.ALLOCATOR`: a run's records reuse the last run's pages); with
    MBS_CLEARANCE_MALLOC=default, or the user's own glibc tuning in the environment, it
    leaves the allocator alone."""
    import platform

    from mbs_clearance.core import integrate as ci

    for name in ("MBS_CLEARANCE_MALLOC", "MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_"):
        monkeypatch.delenv(name, raising=False)
    calls = []

    class Lib:
        def mbs_tune_allocator(self, *args):
            calls.append(args)
            return 1

    ci._tune_allocator(Lib())
    assert calls == [ci.ALLOCATOR]
    for name, value in (("MBS_CLEARANCE_MALLOC", "default"),
                        ("MALLOC_TRIM_THRESHOLD_", "1000000")):
        with monkeypatch.context() as m:
            m.setenv(name, value)
            ci._tune_allocator(Lib())
        assert len(calls) == 1, name
    _, lib = ci.core()
    glibc = platform.libc_ver()[0] == "glibc"
    assert lib.mbs_tune_allocator(*ci.ALLOCATOR) == (1 if glibc else 0)
