"""Test models of the compiled core, in C (through the seam `mbs_core.h`), and the core's
own step functions built for the tests (`core_probe`). Shared by the core's tests.

The bouncing ball. Its state is unfolded so that an impact changes the memory only (the
seam's on_event may not write the state): y = (X, W[, Q]) with the physical height
h = X + alpha + beta t and velocity v = W + beta, (alpha, beta) memory. Between impacts
X' = W, W' = -g - c v (c: linear drag), and Q' = h^2 (a component outside the dense state:
the event functions and the monitor read y[:2]); optional further states follow Q through a
chain of first-order lags (y_k' = y_(k-1) - y_k), so that a run can take a state longer than
the integrator's short-state fast path. The joints: the floor (g_0 = -h) and a
ceiling at H (g_1 = h - H); at an impact v becomes -e v (beta changes, alpha keeps h
continuous) and the bounce count p[COUNT] grows. The monitor is h (the window's peak: the
apex heights) and its output v. Flags in p: NAN_AFTER (the right-hand side is NaN beyond
that time), CHATTER (every switching function is +1 and on_event does nothing: repeated
zero-length events) and TWIN (the second joint is the floor again, its action none: two
joints on their surface at every impact, switched together).
"""

from __future__ import annotations

import math

import numpy as np

from mbs_clearance.core.integrate import no_events_source
from mbs_clearance.numerics.integrator import make_settings

# the ball's parameter vector
GRAV, REST, CEIL, DRAG, NAN_AFTER, CHATTER, TWIN, ALPHA, BETA, COUNT, HALF_G = range(11)
BALL_MEM_START, BALL_N_MEM, BALL_N_P = ALPHA, 3, 11
_INDICES = "".join(f"#define {name} {value}\n" for name, value in dict(
    GRAV=GRAV, REST=REST, CEIL=CEIL, DRAG=DRAG, NAN_AFTER=NAN_AFTER, CHATTER=CHATTER, TWIN=TWIN,
    ALPHA=ALPHA, BETA=BETA, COUNT=COUNT, HALF_G=HALF_G, N_P=BALL_N_P).items())

BALL_C = r"""
#include <math.h>
#include "mbs_core.h"
""" + _INDICES + r"""
static void height(double t, const double *y, const double *p, double *h, double *v)
{
    *h = y[0] + p[ALPHA] + p[BETA] * t;
    *v = y[1] + p[BETA];
}

static void rhs(double t, const double *y, int64_t n, const double *p, double *dydt)
{
    double h, v;
    height(t, y, p, &h, &v);
    double bad = t > p[NAN_AFTER] ? NAN : 0.0;
    dydt[0] = y[1] + bad;
    dydt[1] = -p[GRAV] - p[DRAG] * v + bad;
    if (n > 2)
        dydt[2] = h * h + bad;
    for (int64_t k = 3; k < n; k++)
        dydt[k] = y[k - 1] - y[k] + bad;
}

static void event(double t, const double *y, const double *p, int64_t j, double *g_gd)
{
    double h, v;
    if (p[CHATTER] != 0.0) {
        g_gd[0] = 1.0;
        g_gd[1] = 0.0;
        return;
    }
    height(t, y, p, &h, &v);
    if (j == 0 || p[TWIN] != 0.0) {
        g_gd[0] = -h;
        g_gd[1] = -v;
    } else {
        g_gd[0] = h - p[CEIL];
        g_gd[1] = v;
    }
}

static void on_event(double t, const double *y, double *p, int64_t j)
{
    if (p[CHATTER] != 0.0 || (p[TWIN] != 0.0 && j == 1))
        return;
    double v = y[1] + p[BETA];
    double beta = -p[REST] * v - y[1];
    p[ALPHA] = p[ALPHA] + (p[BETA] - beta) * t;
    p[BETA] = beta;
    p[COUNT] += 1.0;
}

static double monitor(double t, const double *y, int64_t n, const double *p, double *dydt,
                      double *out, int64_t n_out, double *g, double *gd)
{
    double h, v, g_gd[2];
    rhs(t, y, n, p, dydt);
    height(t, y, p, &h, &v);
    if (n_out >= 1)
        out[0] = v;
    for (int64_t j = 0; j < 2; j++) {
        event(t, y, p, j, g_gd);
        g[j] = g_gd[0];
        gd[j] = g_gd[1];
    }
    return h;
}

static int prepare(double *p)
{
    p[HALF_G] = 0.5 * p[GRAV];
    return 0;
}

static const mbs_model RECORD = {3, 1, 2, ALPHA, 3, 1, HALF_G, N_P, rhs, event, on_event, monitor,
                                 prepare};

const mbs_model *mbs_model_record(void) { return &RECORD; }
"""

# the linear oscillator x'' = -w^2 x (p = [w]); monitor x
OSCILLATOR_C = no_events_source("""
    dydt[0] = y[1];
    dydt[1] = -p[0] * p[0] * y[0];""", "y[0]", 2, 1, 1)


def switching_model(body: str, value: str, n_events: int, sizes: str) -> str:
    """The C source of a test model through the seam from `body` (its includes, ``rhs``,
    ``event`` and ``on_event``): a monitor that fills rhs's derivatives and every switching
    function and returns `value` (a C expression of t, y, p), no constants, and the record
    of `sizes` (n_state, n_q, n_events, mem_start, n_mem, n_out, const_start, n_p)."""
    return body + f"""
static double monitor(double t, const double *y, int64_t n, const double *p, double *dydt,
                      double *out, int64_t n_out, double *g, double *gd)
{{
    double g_gd[2];
    (void)out; (void)n_out;
    rhs(t, y, n, p, dydt);
    for (int64_t j = 0; j < {n_events}; j++) {{
        event(t, y, p, j, g_gd);
        g[j] = g_gd[0];
        gd[j] = g_gd[1];
    }}
    return {value};
}}

static int prepare(double *p) {{ (void)p; return 0; }}

static const mbs_model RECORD = {{{sizes}, rhs, event, on_event, monitor, prepare}};

const mbs_model *mbs_model_record(void) {{ return &RECORD; }}
"""


# x'' = -w^2 x with the switching function g = x - level (rate x'): the oscillator's position
# rising above a level (p = [w, level]); monitor x
OSC_ABOVE_C = switching_model(r"""
#include <math.h>
#include "mbs_core.h"

static void rhs(double t, const double *y, int64_t n, const double *p, double *dydt)
{
    (void)t; (void)n;
    dydt[0] = y[1];
    dydt[1] = -p[0] * p[0] * y[0];
}

static void event(double t, const double *y, const double *p, int64_t j, double *g_gd)
{
    (void)t; (void)j;
    g_gd[0] = y[0] - p[1];
    g_gd[1] = y[1];
}

static void on_event(double t, const double *y, double *p, int64_t j)
{
    (void)t; (void)y; (void)p; (void)j;
}
""", "y[0]", 1, "2, 1, 1, 2, 0, 0, 2, 2")

# a nonlinear, time-dependent pair: y0' = y1 cos t, y1' = -y0^2 + sin 3t; monitor y0
NONLINEAR_C = no_events_source("""
    dydt[0] = y[1] * cos(t);
    dydt[1] = -y[0] * y[0] + sin(3.0 * t);""", "y[0]", 2, 1, 1)


# Two independent bodies, x_j'' = -omega_j^2 x_j - a_j, each with a wall at w_j on the side
# s_j (g_j = s_j (x_j - w_j)): omega = 0 is a ball under gravity a (exactly integrated: the
# motion is quadratic), a = 0 an oscillator. An impact reverses the velocity with
# restitution e_j. As for the ball, the seam's on_event may not write the state: the
# physical motion is the state plus a free motion of the memory's coefficients (c1_j, c2_j)
# on the basis phi1 = cos(omega t), phi2 = sin(omega t) / omega (1 and t for omega = 0),
# whose Wronskian is 1: an impact at t with velocity v changes (c1, c2) by -dv (phi2, -phi1),
# dv = -(1 + e) v, leaving x continuous. Joint j's memory p[TWO_MEM + 4 j:]: its impact
# count, its last impact velocity, c1_j, c2_j. p = [omega0, omega1, a0, a1, w0, w1, s0, s1,
# e0, e1, memory (8)]; monitor x_0.
TWO_MEM, TWO_N_MEM = 10, 8
TWO_C = switching_model(f"#define MEM {TWO_MEM}\n" + r"""
#include <math.h>
#include "mbs_core.h"

/* phi1, phi2 and their rates at t for the angular frequency w */
static void basis(double w, double t, double *b)
{
    if (w == 0.0) {
        b[0] = 1.0; b[1] = t; b[2] = 0.0; b[3] = 1.0;
    } else {
        double c = cos(w * t), s = sin(w * t);
        b[0] = c; b[1] = s / w; b[2] = -w * s; b[3] = c;
    }
}

static void physical(double t, const double *y, const double *p, int64_t j, double *x,
                     double *v)
{
    double b[4];
    const double *c = p + MEM + 4 * j + 2;
    basis(p[j], t, b);
    *x = y[2 * j] + c[0] * b[0] + c[1] * b[1];
    *v = y[2 * j + 1] + c[0] * b[2] + c[1] * b[3];
}

static void rhs(double t, const double *y, int64_t n, const double *p, double *dydt)
{
    (void)t; (void)n;
    for (int64_t j = 0; j < 2; j++) {
        dydt[2 * j] = y[2 * j + 1];
        dydt[2 * j + 1] = -p[j] * p[j] * y[2 * j] - p[2 + j];
    }
}

static void event(double t, const double *y, const double *p, int64_t j, double *g_gd)
{
    double x, v;
    physical(t, y, p, j, &x, &v);
    g_gd[0] = p[6 + j] * (x - p[4 + j]);
    g_gd[1] = p[6 + j] * v;
}

static void on_event(double t, const double *y, double *p, int64_t j)
{
    double x, v, b[4];
    physical(t, y, p, j, &x, &v);
    double dv = -(1.0 + p[8 + j]) * v;
    double *mem = p + MEM + 4 * j;
    basis(p[j], t, b);
    mem[0] += 1.0;
    mem[1] = v;
    mem[2] -= dv * b[1];
    mem[3] += dv * b[0];
}

static double position0(double t, const double *y, const double *p)
{
    double x, v;
    physical(t, y, p, 0, &x, &v);
    return x;
}
""", "position0(t, y, p)", 2, f"4, 2, 2, MEM, {TWO_N_MEM}, 0, {TWO_MEM + TWO_N_MEM}, "
   f"{TWO_MEM + TWO_N_MEM}")


def two_physical(t, y, memory, p):
    """The two bodies' physical positions and velocities, each (len(t), 2), from a run's
    records (t, y, memory) of `TWO_C` with the parameters p."""
    x, v = np.empty((len(t), 2)), np.empty((len(t), 2))
    for j in range(2):
        w = p[j]
        c1, c2 = memory[:, 4 * j + 2], memory[:, 4 * j + 3]
        if w == 0.0:
            b = (np.ones_like(t), t, np.zeros_like(t), np.ones_like(t))
        else:
            b = (np.cos(w * t), np.sin(w * t) / w, -w * np.sin(w * t), np.cos(w * t))
        x[:, j] = y[:, 2 * j] + c1 * b[0] + c2 * b[1]
        v[:, j] = y[:, 2 * j + 1] + c1 * b[2] + c2 * b[3]
    return x, v


# One state at rest and two switching functions: joint 0 touches its surface at t = 1.5
# without crossing it (g = -(t - 1.5)^2); joint 1 crosses to positive for |t - 1| < 0.01
# only, with no rate (only samples can find it), until its action. The action of joint j
# sets the flag p[1 + 2 j] and stores the time in p[2 + 2 j] (memory p[1:5]).
GRAZE_C = switching_model(r"""
#include "mbs_core.h"

static void rhs(double t, const double *y, int64_t n, const double *p, double *dydt)
{
    (void)t; (void)y; (void)n; (void)p;
    dydt[0] = 0.0;
}

static void event(double t, const double *y, const double *p, int64_t j, double *g_gd)
{
    (void)y;
    if (j == 0) {
        g_gd[0] = -(t - 1.5) * (t - 1.5);
        g_gd[1] = -2.0 * (t - 1.5);
    } else if (p[1 + 2 * j] < 0.5) {
        g_gd[0] = 1e-4 - (t - 1.0) * (t - 1.0);
        g_gd[1] = 0.0;
    } else {
        g_gd[0] = -1.0;
        g_gd[1] = 0.0;
    }
}

static void on_event(double t, const double *y, double *p, int64_t j)
{
    (void)y;
    p[1 + 2 * j] = 1.0;
    p[2 + 2 * j] = t;
}

""", "0.0", 2, "1, 1, 2, 1, 4, 0, 5, 5")


def ball_parameters(g=9.81, e=0.8, ceiling=1e3, drag=0.0, nan_after=math.inf, chatter=False,
                    twin=False):
    """The ball's p (memory zero: h = X, v = W at the start)."""
    p = np.zeros(BALL_N_P)
    p[[GRAV, REST, CEIL, DRAG, NAN_AFTER, CHATTER, TWIN]] = (g, e, ceiling, drag, nan_after,
                                                             chatter, twin)
    p[HALF_G] = 0.5 * g
    return p


def ball_settings(rtol=1e-9, *, n_state=3, dense=2, event_control=False, **kwargs):
    """Settings of a ball run of `n_state` states: all under error control, the first
    `dense` read by the events and the monitor; with `event_control` the switching
    functions too."""
    atol = np.full(n_state + (4 if event_control else 0), 1e-10)
    kwargs.setdefault("n_samples", 3)
    kwargs.setdefault("event_tol", 1e-12)
    return make_settings(rtol, atol, n_state, n_dense=dense, n_events=2, mem_start=BALL_MEM_START,
                         n_mem=BALL_N_MEM, n_out=1, **kwargs)


def bounce_times(h0, g, e, count):
    """Closed form: the first `count` impact times of a ball dropped from rest at h0 (no
    drag), and the apex heights e^(2k) h0 between them."""
    t1 = math.sqrt(2.0 * h0 / g)
    times = [t1]
    for k in range(1, count):
        times.append(times[-1] + 2.0 * e ** k * t1)
    return np.array(times)



# the clearance joints' stages of core/runtime.h, exported for the tests (tuples as arrays)
_STAGES_C = r"""
#include "mbs_core.h"
#include "runtime.h"

void contact_stage_c(const double *x, double *out) {
    contact_stage(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8], x[9],
                  &out[0], &out[1], &out[2], &out[3], &out[4]);
}

void friction_stage_c(const double *x, const double *slots, double *out) {
    friction_stage(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8], x[9], x[10], x[11],
                   slots, &out[0], &out[1], &out[2], &out[3], &out[4], &out[5], &out[6]);
}

void lubricated_stage_c(const double *x, double *out) {
    lubricated_stage(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8], x[9], x[10],
                     x[11], x[12], x[13], x[14], x[15], x[16], x[17], &out[0], &out[1],
                     &out[2], &out[3], &out[4], &out[5], &out[6], &out[7], &out[8], &out[9]);
}
"""


def runtime_stages():
    """(contact_stage, friction_stage, lubricated_stage) of core/runtime.h as Python
    functions of the C arguments (friction_stage: the slots as a sequence), returning the
    C function's outputs as a tuple, in its order."""
    from pathlib import Path

    from mbs_clearance.core import build

    core = Path(build.__file__).parent
    sources = [("stages.c", _STAGES_C)] + [(h, (core / h).read_text()) for h in
                                           ("runtime.h", "laws_generated.h")]
    ffi, lib = build.load("runtime-stages-test", sources, cdef=(
        "void contact_stage_c(const double *x, double *out);"
        "void friction_stage_c(const double *x, const double *slots, double *out);"
        "void lubricated_stage_c(const double *x, double *out);"))

    def call(fn, n_out, *args, slots=None):
        x = np.ascontiguousarray(args, dtype=float)
        out = np.full(n_out, np.nan)
        extra = () if slots is None else (ffi.from_buffer(
            "double[]", np.ascontiguousarray(slots, dtype=float)),)
        fn(ffi.from_buffer("double[]", x), *extra, ffi.from_buffer("double[]", out))
        return tuple(float(v) for v in out)

    def contact(*args):
        return call(lib.contact_stage_c, 5, *args)

    def friction(*args):
        return call(lib.friction_stage_c, 7, *args[:-1], slots=args[-1])

    def lubricated(*args):
        return call(lib.lubricated_stage_c, 10, *args)

    return contact, friction, lubricated


# ---- the core's own step, continuous extension and cubic look, for the tests that check
# them alone: integrator.c is included whole (its functions are static) next to wrappers
_PROBE_C = r"""
#include <stdlib.h>
#include "integrator_core.h"

/* one step of size h from (t, y) of model m: its end into y1 (n,), the continuous
 * extension at each thetas[k] into dense (n_theta, n) */
int64_t probe_step_dense(const mbs_model *m, const mbs_tableau *tb, double t, const double *y,
                         int64_t n, double *p, double h, const double *thetas, int64_t n_theta,
                         double *y1, double *dense)
{
    run_ctx cx;
    step_work w;
    int64_t status = step_workspace(&cx, &w, m, tb, n, 0, 0, p, 0);
    if (status)
        return status;
    double *wts = alloc_d(tb->p_rows);
    if (!wts) {
        free(w.block);
        return STATUS_OUT_OF_MEMORY;
    }
    m->rhs(t, y, n, p, w.f0);
    rk_step(&cx, t, y, n, w.f0, h, w.K, p, y1, w.f_new, w.ytmp);
    extra_stages(&cx, t, y, n, h, w.K, p, w.ytmp);
    for (int64_t k = 0; k < n_theta; k++)
        dense_eval(&cx, y, n, h, w.K, thetas[k], dense + k * n, wts);
    free(wts);
    free(w.block);
    return 0;
}

/* one step of size h from (t, y) of model m (at most 8 switching functions), then the
 * cubic look at it, as the event search takes it: 1 (clear) or 0 into *clear */
int64_t probe_clear_of_surface(const mbs_model *m, const mbs_tableau *tb, double t,
                               const double *y, int64_t n, double *p, double h,
                               int64_t n_samples, double event_tol, double event_margin,
                               int64_t *clear)
{
    run_ctx cx;
    step_work w;
    const int64_t n_ev = m->n_events;
    if (n_ev > 8)
        return STATUS_BAD_ARGUMENT;
    int64_t status = step_workspace(&cx, &w, m, tb, n, 0, 0, p, 0);
    if (status)
        return status;
    double g0[8], gd0[8], g1[8], gd1[8], ga[8], gda[8], ggd[2];
    m->rhs(t, y, n, p, w.f0);
    rk_step(&cx, t, y, n, w.f0, h, w.K, p, w.y_new, w.f_new, w.ytmp);
    for (int64_t j = 0; j < n_ev; j++) {
        m->event(t, y, p, j, ggd);
        g0[j] = ggd[0];
        gd0[j] = ggd[1];
        m->event(t + h, w.y_new, p, j, ggd);
        g1[j] = ggd[0];
        gd1[j] = ggd[1];
    }
    *clear = clear_of_surface(&cx, t, y, n, w.y_new, w.K, w.K + cx.s * n, h, p, g0, gd0, g1,
                              gd1, n_ev, n_samples, event_tol, event_margin, w.ytmp, ga, gda);
    free(w.block);
    return 0;
}
"""


def core_probe():
    """(step_dense, clear_of_surface): the core's own functions on one step of a model's
    record (`integrate.model_record`) with a method's coefficients (``Tableau.arrays()``).

    ``step_dense(model, coefficients, t, y, p, h, thetas)``: (the step's end (n,), its
    continuous extension at each theta (len(thetas), n)). ``clear_of_surface(model,
    coefficients, t, y, p, h, n_samples, event_tol, event_margin)``: whether the cubic
    Hermite look declares the step clear of every switching surface."""
    from pathlib import Path

    from mbs_clearance.core import build
    from mbs_clearance.core.integrate import _tableau

    source = (Path(build.__file__).parent / "integrator.c").read_text()
    ffi, lib = build.load("test_core_probe", [("probe.c", _PROBE_C),
                                              ("integrator_core.h", source)], cdef=(
        "int64_t probe_step_dense(const mbs_model *m, const mbs_tableau *tb, double t, "
        "const double *y, int64_t n, double *p, double h, const double *thetas, "
        "int64_t n_theta, double *y1, double *dense);"
        "int64_t probe_clear_of_surface(const mbs_model *m, const mbs_tableau *tb, double t, "
        "const double *y, int64_t n, double *p, double h, int64_t n_samples, "
        "double event_tol, double event_margin, int64_t *clear);"))

    def arrays(model, coefficients, y, p):
        # the record and tableau in this library's ffi; y and p as C doubles
        rec = ffi.cast("const mbs_model *", int(ffi.cast("uintptr_t", model)))
        tb, keep = _tableau(ffi, coefficients)
        y = np.ascontiguousarray(y, dtype=float)
        p = np.array(p, dtype=float)
        return rec, tb, keep, y, p

    def ptr(a):
        return ffi.cast("double *", ffi.from_buffer(a))

    def step_dense(model, coefficients, t, y, p, h, thetas):
        rec, tb, keep, y, p = arrays(model, coefficients, y, p)
        thetas = np.ascontiguousarray(thetas, dtype=float)
        y1, dense = np.empty(y.shape[0]), np.empty((thetas.shape[0], y.shape[0]))
        status = lib.probe_step_dense(rec, tb, float(t), ptr(y), y.shape[0], ptr(p), float(h),
                                      ptr(thetas), thetas.shape[0], ptr(y1), ptr(dense))
        del keep
        assert status == 0, status
        return y1, dense

    def clear_of_surface(model, coefficients, t, y, p, h, n_samples, event_tol, event_margin):
        rec, tb, keep, y, p = arrays(model, coefficients, y, p)
        clear = ffi.new("int64_t *")
        status = lib.probe_clear_of_surface(rec, tb, float(t), ptr(y), y.shape[0], ptr(p),
                                            float(h), int(n_samples), float(event_tol),
                                            float(event_margin), clear)
        del keep
        assert status == 0, status
        return bool(clear[0])

    return step_dense, clear_of_surface
