"""The Python binding of the compiled integrator (`integrator.c`, built once per process).

`integrate` takes a model as a pointer to its record (`mbs_model`, the seam of
`mbs_core.h`), the initial state, parameters, window edges, settings
(`numerics.integrator.make_settings`) and a method's coefficients, and returns the recorded
run. A model library (C sources built with `build.load`) exports its record with
``const mbs_model *mbs_model_record(void)``; `model_record` turns the ``(ffi, lib)`` of such a
library into the pointer `integrate` takes::

    ffi, lib = build.load("my_model", [("my_model.c", source)])
    model = model_record(ffi, lib)
    t, y, memory, peaks, peak_t, counters, outputs, status = integrate(
        model, y0, p, edges, make_settings(...), METHODS["dopri5"].arrays())

The call runs without the GIL (cffi releases it around every call of a C function), so
threads integrate in parallel.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

import numpy as np

from . import build

__all__ = ["core", "model_record", "integrate", "step_peaks", "step_value", "step_states",
           "with_parameter_length", "RecordKernels", "NO_EVENTS_C", "no_events_source",
           "OUT_OF_MEMORY", "BAD_ARGUMENT"]

#: negative statuses of the core (the others are `integrator.RESULTS`)
OUT_OF_MEMORY = -1
BAD_ARGUMENT = -2

#: the C of a model without switching (for hand-written models through the seam): its one
#: switching function always -1, no action, no constants
NO_EVENTS_C = r"""
static void event(double t, const double *y, const double *p, int64_t j, double *g_gd)
{
    (void)t; (void)y; (void)p; (void)j;
    g_gd[0] = -1.0;
    g_gd[1] = 0.0;
}

static void on_event(double t, const double *y, double *p, int64_t j)
{
    (void)t; (void)y; (void)p; (void)j;
}

static int prepare(double *p) { (void)p; return 0; }
"""



def no_events_source(rhs_body: str, value: str, n_state: int, n_q: int, n_p: int) -> str:
    """The C source of a hand-written model without switching, through the seam
    (`mbs_core.h`): `rhs_body` the statements of ``rhs(t, y, n, p, dydt)`` (n: the length of
    y, which may be the dense part only), `value` the C expression of the monitored value
    (of t, y, p), `n_state` states (`n_q` coordinates), p of `n_p` entries without memory or
    constants; `NO_EVENTS_C` for its switching function, action and prepare."""
    return ('#include <math.h>\n#include "mbs_core.h"\n' + NO_EVENTS_C + f"""
static void rhs(double t, const double *y, int64_t n, const double *p, double *dydt)
{{
    (void)t; (void)y; (void)n; (void)p;
{rhs_body}
}}

static double monitor(double t, const double *y, int64_t n, const double *p, double *dydt,
                      double *out, int64_t n_out, double *g, double *gd)
{{
    (void)out; (void)n_out;
    rhs(t, y, n, p, dydt);
    g[0] = -1.0;
    gd[0] = 0.0;
    return {value};
}}

static const mbs_model RECORD = {{{n_state}, {n_q}, 1, {n_p}, 0, 0, {n_p}, {n_p}, rhs, event,
                                 on_event, monitor, prepare}};

const mbs_model *mbs_model_record(void) {{ return &RECORD; }}
""")


_SOURCE = Path(__file__).resolve().parent / "integrator.c"
#: the core (compiled once, not per model) at -O3: its loops over the state (the stages'
#: combinations) vectorised, elementwise, so the same numbers as at -O2 (no reassociation)
CORE_FLAGS = tuple("-O3" if f == "-O2" else f for f in build.FLAGS)
_LOCK = threading.Lock()
_CORE: list = []


_CORE_CDEF = ("void mbs_free(void *data);\n"
              "int64_t mbs_tune_allocator(int64_t mmap_threshold, int64_t trim_threshold);")
#: glibc's allocator as the core sets it (bytes): blocks below 32 MiB from the heap, which
#: keeps up to 128 MiB free before returning memory; a run's records then reuse the last
#: run's pages (a DDM run of the paper case 37 -> 28 ms). Not where the user tuned it
#: (MALLOC_MMAP_THRESHOLD_ / MALLOC_TRIM_THRESHOLD_ set) or for MBS_CLEARANCE_MALLOC=default.
ALLOCATOR = (32 << 20, 128 << 20)


def _tune_allocator(lib) -> None:
    env = os.environ
    if (env.get("MBS_CLEARANCE_MALLOC", "").strip().lower() == "default"
            or "MALLOC_MMAP_THRESHOLD_" in env or "MALLOC_TRIM_THRESHOLD_" in env):
        return
    lib.mbs_tune_allocator(*ALLOCATOR)


def core():
    """(ffi, lib) of the compiled core, built (or found in the cache) on first use."""
    with _LOCK:
        if not _CORE:
            _CORE.append(build.load("core", [("integrator.c", _SOURCE.read_text())],
                                    cdef=_CORE_CDEF, flags=CORE_FLAGS))
            _tune_allocator(_CORE[0][1])
        return _CORE[0]


def model_record(ffi, lib):
    """The record of a model library (its ``(ffi, lib)`` from `build.load`, exporting
    ``mbs_model_record``) as a pointer of the core's ffi, for `integrate`. The library stays
    loaded for the life of the process (`build.load` keeps it)."""
    core_ffi, _ = core()
    address = int(ffi.cast("uintptr_t", lib.mbs_model_record()))
    if address == 0:
        raise ValueError("the model library returned no record (mbs_model_record() is NULL)")
    return core_ffi.cast("const mbs_model *", address)


def _doubles(name, value, ndim=1):
    arr = np.ascontiguousarray(value, dtype=float)
    if arr.ndim != ndim:
        raise ValueError(f"{name} must be a {ndim}-dimensional array of floats; got shape "
                         f"{arr.shape}")
    return arr


def _ptr(ffi):
    def ptr(arr):
        return ffi.cast("double *", ffi.from_buffer(arr))
    return ptr


def _tableau(ffi, coefficients):
    """(``mbs_tableau *``, the arrays it points into: keep them alive through the call) of
    the method's coefficients (``Tableau.arrays()``)."""
    A, B, C, E, E2, P, A_extra, C_extra, error_order, pi_alpha, pi_beta = coefficients
    A, P, A_extra = (_doubles(name, a, 2) for name, a in
                     (("A", A), ("P", P), ("A_extra", A_extra)))
    B, C, E, E2, C_extra = (_doubles(name, a) for name, a in
                            (("B", B), ("C", C), ("E", E), ("E2", E2), ("C_extra", C_extra)))
    ptr = _ptr(ffi)
    tb = ffi.new("mbs_tableau *")
    tb.A, tb.a_rows, tb.a_cols = ptr(A), A.shape[0], A.shape[1]
    tb.B, tb.n_b = ptr(B), B.shape[0]
    tb.C, tb.n_c = ptr(C), C.shape[0]
    tb.E, tb.n_e = ptr(E), E.shape[0]
    tb.E2, tb.n_e2 = ptr(E2), E2.shape[0]
    tb.P, tb.p_rows, tb.p_cols = ptr(P), P.shape[0], P.shape[1]
    tb.A_extra, tb.x_rows, tb.x_cols = ptr(A_extra), A_extra.shape[0], A_extra.shape[1]
    tb.C_extra, tb.n_c_extra = ptr(C_extra), C_extra.shape[0]
    tb.error_order, tb.pi_alpha, tb.pi_beta = float(error_order), float(pi_alpha), float(pi_beta)
    return tb, (A, B, C, E, E2, P, A_extra, C_extra)


def with_parameter_length(model, n_p: int):
    """A copy of the record `model` whose p has n_p entries (a sensitivity run's p: the
    model's, then the run's header and work space, all copied with the state wherever the
    integrator keeps one)."""
    ffi, _ = core()
    rec = ffi.new("mbs_model *")
    rec[0] = model[0]
    rec.n_p = int(n_p)
    return rec


def _check_status(status) -> None:
    if status == OUT_OF_MEMORY:
        raise MemoryError("the compiled step map ran out of memory")
    if status != 0:
        raise ValueError("the compiled step map refused its arguments (sizes of the "
                         "states, memories or p out of range)")


def step_peaks(model, t0s, y0s, mems, p, hs, coefficients, iters):
    """The maximum of the monitored value over the step map of each recorded step k (start
    t0s[k] in s, state y0s[k], memories mems[k], size hs[k] in s) by golden section with
    `iters` iterations, as the integrator's peak refinement; returns (values, times in s).
    p: the model's parameters (not changed)."""
    ffi, lib = core()
    t0s, hs = _doubles("t0s", t0s), _doubles("hs", hs)
    y0s, mems = _doubles("y0s", y0s, 2), _doubles("mems", mems, 2)
    p = _doubles("p", p)
    n_steps = t0s.shape[0]
    if not (y0s.shape[0] == mems.shape[0] == hs.shape[0] == n_steps) or p.shape[0] < model.n_p:
        raise ValueError(f"t0s, y0s, mems and hs need one row per step ({n_steps}) and p the "
                         f"model's {model.n_p} entries")
    tb, keep = _tableau(ffi, coefficients)
    vals, times = np.empty(n_steps), np.empty(n_steps)
    ptr = _ptr(ffi)
    status = lib.mbs_step_peaks(model, ptr(t0s), ptr(y0s), n_steps, y0s.shape[1], ptr(mems),
                                mems.shape[1], ptr(p), ptr(hs), tb, int(iters), ptr(vals),
                                ptr(times))
    del keep
    _check_status(status)
    return vals, times


def step_value(model, t0, y0, mem, p, h, coefficients):
    """The monitored value of the step map at t0 + h (s) from the state y0 with the
    memories mem; p: the model's parameters (not changed)."""
    ffi, lib = core()
    y0, mem, p = _doubles("y0", y0), _doubles("mem", mem), _doubles("p", p)
    if p.shape[0] < model.n_p:
        raise ValueError(f"p must have the model's {model.n_p} entries; got {p.shape[0]}")
    tb, keep = _tableau(ffi, coefficients)
    value = ffi.new("double *")
    ptr = _ptr(ffi)
    status = lib.mbs_step_value(model, float(t0), ptr(y0), y0.shape[0], ptr(mem),
                                mem.shape[0], ptr(p), float(h), tb, value)
    del keep
    _check_status(status)
    return float(value[0])


def step_states(model, t0, y0, p, hs, coefficients, n_out):
    """Steps of the sizes hs (s) from (t0, y0) with the memories in p (a writable float64
    array: the model's work entries are written): the states (len(hs), n) and the
    monitor's first n_out outputs (len(hs), n_out) at t0 + hs."""
    ffi, lib = core()
    y0, hs = _doubles("y0", y0), _doubles("hs", hs)
    if not (isinstance(p, np.ndarray) and p.dtype == np.float64 and p.ndim == 1
            and p.flags.c_contiguous and p.flags.writeable) or p.shape[0] < model.n_p:
        raise ValueError(f"p must be a writable contiguous float64 array of at least "
                         f"{model.n_p} entries")
    tb, keep = _tableau(ffi, coefficients)
    ys = np.empty((hs.shape[0], y0.shape[0]))
    outs = np.zeros((hs.shape[0], int(n_out)))
    ptr = _ptr(ffi)
    status = lib.mbs_step_states(model, float(t0), ptr(y0), y0.shape[0], ptr(p), ptr(hs),
                                 hs.shape[0], tb, int(n_out), ptr(ys), ptr(outs))
    del keep
    _check_status(status)
    return ys, outs


def integrate(model, y0, p, edges, settings, coefficients):
    """Integrate a model from edges[0] to edges[-1] with the compiled core.

    Parameters
    ----------
    model : cffi pointer to ``mbs_model``
        The model's record (`model_record`).
    y0 : array of float, shape (n,)
        Initial state (the model's units: m, rad, m/s, rad/s, ...).
    p : ndarray of float64, shape (model.n_p,)
        Parameters, memory and constants; the memory entries are updated in place
        (contiguous float64 required).
    edges : array of float, shape (n_windows + 1,)
        Window edges in s: edges[0] the start, edges[-1] the end; the integration lands on
        each, and the monitor's maximum is tracked per window.
    settings : integrator.IntegratorSettings
        From `integrator.make_settings`; ``atol`` needs at least n entries here.
    coefficients : tuple
        ``Tableau.arrays()`` of the method.

    Returns
    -------
    tuple
        (t (m,) in s, y (m, n), memory (m, max(n_mem, 1)) of the recorded steps, the refined
        maximum of the monitor per window and its time in s, counters (int64: nfev,
        naccept, nreject, nevent, nrefine), outputs (m, n_out), status (an
        `integrator.RESULTS` code)), arrays owning their memory.
    """
    ffi, lib = core()
    y0 = _doubles("y0", y0)
    edges = _doubles("edges", edges)
    if not (isinstance(p, np.ndarray) and p.dtype == np.float64 and p.ndim == 1
            and p.flags.c_contiguous and p.flags.writeable):
        raise ValueError("p must be a writable contiguous 1-dimensional float64 array (its "
                         "memory entries are updated in place)")
    n = y0.shape[0]
    n_p = int(model.n_p)
    if p.shape[0] != n_p:
        raise ValueError(f"p must have the model's {n_p} entries; got {p.shape[0]}")
    if n < 1 or edges.shape[0] < 2:
        raise ValueError(f"y0 needs at least 1 entry and edges at least 2; got {n} and "
                         f"{edges.shape[0]}")
    atol = _doubles("atol", settings.atol)
    if atol.shape[0] < n or not 1 <= settings.n_err <= n:
        raise ValueError(f"atol must have at least len(y0) = {n} entries and n_err must be in "
                         f"[1, {n}]; got {atol.shape[0]} and {settings.n_err}")
    if settings.mem_start + settings.n_mem > n_p:
        raise ValueError(f"the memory entries p[{settings.mem_start}:"
                         f"{settings.mem_start + settings.n_mem}] exceed p's {n_p} entries")
    tb, keep = _tableau(ffi, coefficients)
    keep = (keep, y0, edges, atol)   # alive through the call
    ptr = _ptr(ffi)
    st = ffi.new("mbs_settings *")
    st.rtol = settings.rtol
    st.atol, st.n_atol = ptr(atol), atol.shape[0]
    for name in ("n_err", "h0", "h_max", "max_steps", "record", "event_tol", "event_margin",
                 "n_samples", "refine_iters", "n_out", "n_dense", "n_events", "mem_start",
                 "n_mem", "n_crests"):
        setattr(st, name, getattr(settings, name))
    res = ffi.new("mbs_result *")
    status = lib.mbs_integrate(model, ptr(y0), n, ffi.cast("double *", ffi.from_buffer(p)),
                               ptr(edges), edges.shape[0], st, tb, res)
    del keep
    try:
        if status == OUT_OF_MEMORY:
            raise MemoryError("the compiled integrator ran out of memory for its records: "
                              "set record=False or shorten the run")
        if status == BAD_ARGUMENT:
            raise ValueError("the compiled integrator refused its arguments (sizes of y0, "
                             "p, edges, atol or the settings out of range)")
        nrec, n_win = res.n_rec, res.n_win
        n_m = max(settings.n_mem, 1)
        n_out = settings.n_out

        t = _take(ffi, lib, res, "t", nrec, (nrec,))
        y = _take(ffi, lib, res, "y", nrec * n, (nrec, n))
        memory = _take(ffi, lib, res, "mem", nrec * n_m, (nrec, n_m))
        if settings.n_mem == 0:
            memory[:] = 0.0     # no memory: the one column is not written by the core
        outputs = _take(ffi, lib, res, "out", nrec * n_out, (nrec, n_out))
        peaks = _take(ffi, lib, res, "peaks", n_win, (n_win,))
        peak_t = _take(ffi, lib, res, "peak_t", n_win, (n_win,))
        counters = np.array(list(res.counters), dtype=np.int64)
    finally:
        lib.mbs_result_free(res)
    return t, y, memory, peaks, peak_t, counters, outputs, int(status)


def _take(ffi, lib, res, field: str, count: int, shape) -> np.ndarray:
    """The result's array `field` as a numpy array that owns the core's memory (freed when
    the array is; no copy: copying a recorded run's arrays cost a tenth of its time); the
    field is cleared so that `mbs_result_free` leaves it."""
    cptr = getattr(res, field)
    if count == 0 or cptr == ffi.NULL:
        return np.zeros(shape)
    owner = ffi.gc(cptr, lib.mbs_free)        # the buffer keeps it alive, numpy the buffer
    setattr(res, field, ffi.NULL)
    return np.frombuffer(ffi.buffer(owner, 8 * count), dtype=np.float64).reshape(shape)


class RecordKernels:
    """The monitor and the event action of a compiled model (a `generate.c_loader.CModel`)
    called through its record's function pointers from Python, numpy arrays written in
    place (p and the outputs: contiguous float64): what a Python integrator (validation's
    scipy reference) or a test calls besides the model's rhs and event."""

    def __init__(self, model):
        self.ffi, self.rec = model.ffi, model.record

    def _ptr(self, a):
        return self.ffi.from_buffer("double[]", a)

    def monitor(self, t, y, p, dydt, out, g, gd) -> float:
        """The monitored value at (t in s, y); dydt, out (its length: the outputs written),
        g and gd (one entry per switching function) filled."""
        y = np.ascontiguousarray(y, dtype=float)
        return self.rec.monitor(float(t), self._ptr(y), y.shape[0], self._ptr(p),
                                self._ptr(dydt), self._ptr(out), out.shape[0], self._ptr(g),
                                self._ptr(gd))

    def on_event(self, t, y, p, j) -> None:
        """The action of switching function j at (t in s, y): its memory in p updated."""
        y = np.ascontiguousarray(y, dtype=float)
        self.rec.on_event(float(t), self._ptr(y), self._ptr(p), int(j))
