"""Where the time of the paper case's plain run goes (the cost per function evaluation).

Three measurements, all in CPU time of this thread (`time.thread_time`, medians: on a
loaded machine wall time counts the other processes too):

1. the cost of one call of each generated kernel (`rhs`, `monitor` with and without
   outputs, `event`), in a compiled loop over states of the paper case's trajectory (each
   with its recorded contact memory, so branches go as in a run);
2. how often a run calls each of them (``--counts``: the integrator specialised for
   counting wrappers of the kernels, a compile of several minutes the first time): the
   calls of the main loop, and those of the peak refinement (golden-section steps, whose
   kernels run on copies of p);
3. the run with one part switched off through its settings (no recompilation): the peak
   refinement (refine_iters = 0), the switching function's error control (atol without its
   2 J entries), the interior event sample (n_samples = 0), and a recorded run (record with
   the outputs, as `simulate`) against the peak-only run.

Prints a table of the kernel costs times their counts against the run's time; the rest is
the integrator's own work (stage combinations, error norm, step control, event search
arithmetic, crest tracking, recording).

    python -m benchmarks.cost_breakdown [--repeats 51] [--counts]
"""

from __future__ import annotations

import argparse
import time

import numba as nb
import numpy as np

from mbs_clearance import SliderCrank, simulate
from mbs_clearance.numerics import integrator as _int
from mbs_clearance.numerics.integrator import (
    ACTION_SIG,
    EVENT_SIG,
    KERNEL,
    METHODS,
    MONITOR_SIG,
    RHS_SIG,
    integrate,
    make_settings,
)
from mbs_clearance.solve import reduced
from validation.timing import machine_summary

MODEL = reduced.MODEL


@nb.njit(cache=False, inline="always")
def _load(i, ys, ms, y, p, link):
    """State i into y (plus 0.0 times `link`: with the previous call's result there, the
    call depends on it, as an RK step's stages do; with a constant, it does not) and its
    contact memory into p (copies: a view of a row would be reference-counted)."""
    for k in range(y.shape[0]):
        y[k] = ys[i, k] + 0.0 * link
    for k in range(ms.shape[1]):
        p[MODEL.MEM_START + k] = ms[i, k]


@nb.njit(cache=False)
def _loop_rhs(ts, ys, ms, p, reps, chain):
    y = np.empty(ys.shape[1])
    dydt = np.zeros(ys.shape[1])
    acc = 0.0
    for _ in range(reps):
        for i in range(ts.shape[0]):
            _load(i, ys, ms, y, p, dydt[3] if chain else 0.0)
            MODEL.rhs(ts[i], y, p, dydt)
            acc += dydt[3]
    return acc


@nb.njit(cache=False)
def _loop_monitor(ts, ys, ms, p, reps, chain, n_out):
    y = np.empty(ys.shape[1])
    dydt = np.zeros(ys.shape[1])
    out = np.empty(n_out)
    g = np.empty(MODEL.N_EVENTS)
    gd = np.empty(MODEL.N_EVENTS)
    m = 0.0
    acc = 0.0
    for _ in range(reps):
        for i in range(ts.shape[0]):
            _load(i, ys, ms, y, p, m if chain else 0.0)
            m = MODEL.monitor(ts[i], y, p, dydt, out, g, gd)
            acc += m
    return acc


@nb.njit(cache=False)
def _loop_event(ts, ys, ms, p, reps, chain):
    y = np.empty(ys.shape[1])
    g = 0.0
    acc = 0.0
    for _ in range(reps):
        for i in range(ts.shape[0]):
            _load(i, ys, ms, y, p, g if chain else 0.0)
            g, gd = MODEL.event(ts[i], y, p, 0)
            acc += g
    return acc


@nb.njit(cache=False)
def _loop_load(ts, ys, ms, p, reps, chain):
    """The loops' own cost (loading the states), subtracted from theirs."""
    y = np.empty(ys.shape[1])
    acc = 0.0
    for _ in range(reps):
        for i in range(ts.shape[0]):
            _load(i, ys, ms, y, p, acc if chain else 0.0)
            acc += y[3]
    return acc


@nb.njit(cache=False)
def _loop_attempt(ts, hs, ys, ms, p, reps, which, settings, coefficients):
    """which = 0: `integrator._attempt` (a step's stages, monitor, error norm and the
    switching function's error) from each state with the step size that the run took
    there; 1: the same kernel calls on the state alone (5 rhs, monitor, event); 2: the
    loop's own cost (one rhs for the start derivative). The difference 0 - 1 is the
    attempt's own work."""
    A, B, C, E, E2, P, A_extra, C_extra, eo, pa, pb = coefficients
    n = ys.shape[1]
    y = np.empty(n)
    f = np.empty(n)
    y_new = np.empty(n)
    f_new = np.empty(n)
    ytmp = np.empty(n)
    ftmp = np.empty(n)
    yhat = np.empty(n)
    obuf = np.empty(0)
    g = np.empty(MODEL.N_EVENTS)
    gd = np.empty(MODEL.N_EVENTS)
    K = np.zeros((B.shape[0] + 1, n))
    acc = 0.0
    for _ in range(reps):
        for i in range(ts.shape[0]):
            _load(i, ys, ms, y, p, 0.0)
            MODEL.rhs(ts[i], y, p, f)
            if which == 0:
                m, err = _int._attempt(MODEL.rhs, MODEL.event, MODEL.monitor, ts[i], y, f, hs[i],
                                       A, B, C, E, E2, K, p, y_new, f_new, ytmp, ytmp, ftmp,
                                       obuf, settings.rtol, settings.atol, settings.n_err,
                                       yhat, g, gd)
                acc += err
            elif which == 1:
                for _r in range(B.shape[0] - 1):
                    MODEL.rhs(ts[i], y, p, f_new)
                acc += MODEL.monitor(ts[i], y, p, f_new, obuf, g, gd)
                acc += MODEL.event(ts[i], y, p, 0)[0]
    return acc


def attempt_cost(repeats: int) -> dict:
    """CPU ns of one attempted dopri5 step (`integrator._attempt`) against the kernel calls
    it makes, over 1000 steps of the paper case's run."""
    mech = SliderCrank()
    traj_ts, ys, ms, *_, p = reduced.run(mech, 4, record=True)
    idx = np.linspace(0, len(traj_ts) - 2, 1000).astype(int)
    ts = np.ascontiguousarray(traj_ts[idx])
    hs = np.ascontiguousarray(traj_ts[idx + 1] - traj_ts[idx])
    ys = np.ascontiguousarray(ys[idx])
    ms = np.ascontiguousarray(ms[idx, :MODEL.N_MEM])
    p = p.copy()
    _, _, _, settings, coef = _plain_args(mech)
    reps = 20
    n = reps * len(idx)
    t = [_median_call_ns(lambda w=w: _loop_attempt(ts, hs, ys, ms, p, reps, w, settings, coef),
                         n, repeats) for w in (0, 1, 2)]
    return {"attempt": t[0] - t[2], "its kernel calls": t[1] - t[2],
            "its own work": t[0] - t[1]}


def _median_call_ns(fn, n_calls, repeats):
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.thread_time()
        fn()
        times.append(time.thread_time() - t0)
    return 1e9 * float(np.median(times)) / n_calls


def kernel_costs(repeats: int) -> dict:
    """CPU ns per call of each kernel over 1000 states of the paper case's trajectory
    (each with its contact memory), the loop's own cost subtracted: calls independent of
    each other (throughput), and each depending on the previous one's result (latency, as
    in the stages of a step)."""
    mech = SliderCrank()
    traj_ts, ys, ms, *_, p = reduced.run(mech, 4, record=True)
    idx = np.linspace(0, len(traj_ts) - 1, 1000).astype(int)
    ts = np.ascontiguousarray(traj_ts[idx])
    ys = np.ascontiguousarray(ys[idx])
    ms = np.ascontiguousarray(ms[idx, :MODEL.N_MEM])
    p = p.copy()
    reps = 20
    n = reps * len(idx)
    res = {}
    for chain, label in ((False, ""), (True, ", dependent")):
        base = _median_call_ns(lambda c=chain: _loop_load(ts, ys, ms, p, reps, c), n, repeats)
        for name, fn in (
                ("rhs", lambda c=chain: _loop_rhs(ts, ys, ms, p, reps, c)),
                ("monitor (no outputs)",
                 lambda c=chain: _loop_monitor(ts, ys, ms, p, reps, c, 0)),
                ("monitor (outputs)",
                 lambda c=chain: _loop_monitor(ts, ys, ms, p, reps, c, MODEL.N_OUT)),
                ("event", lambda c=chain: _loop_event(ts, ys, ms, p, reps, c))):
            res[name + label] = _median_call_ns(fn, n, repeats) - base
    return res


# counting wrappers: the counts go to four entries appended to p (the kernels read p by
# fixed indices below them); the refinement's kernels run on copies of p and count there
_C = MODEL.N_P


@nb.njit(RHS_SIG, **KERNEL)
def _count_rhs(t, y, p, dydt):
    p[_C] += 1.0
    MODEL.rhs(t, y, p, dydt)


@nb.njit(EVENT_SIG, **KERNEL)
def _count_event(t, y, p, j):
    p[_C + 1] += 1.0
    return MODEL.event(t, y, p, j)


@nb.njit(ACTION_SIG, **KERNEL)
def _count_on_event(t, y, p, j):
    p[_C + 2] += 1.0
    MODEL.on_event(t, y, p, j)


@nb.njit(MONITOR_SIG, **KERNEL)
def _count_monitor(t, y, p, dydt, out, g, gd):
    p[_C + 3] += 1.0
    return MODEL.monitor(t, y, p, dydt, out, g, gd)


def _plain_args(mech, **changes):
    """(y0, p, edges, settings, coefficients) of the default peak-only run, as reduced.run
    builds them, with the settings' fields in `changes` replaced."""
    from mbs_clearance.solve import linkage_model as lm

    linkage = reduced.linkage_of(mech)
    rtol = reduced.DEFAULT_RTOL
    atol = np.append(reduced.default_atol(mech, rtol), reduced.event_atol(mech, rtol))
    edges = reduced.window_edges(mech, 4)
    event_tol = lm.event_tolerance(linkage)
    p = reduced.model_parameters(mech)
    y0 = lm.check_start(linkage, MODEL, p, reduced.centred_start(mech), event_tol)
    fields = dict(h_max=mech.period / 8, max_steps=reduced.DEFAULT_MAX_STEPS, record=False,
                  event_tol=event_tol, event_margin=reduced.event_margin(mech.clearance, rtol),
                  n_samples=1, refine_iters=reduced.REFINE_ITERS, n_out=0,
                  n_dense=reduced.N_EVENT, n_events=1, mem_start=MODEL.MEM_START,
                  n_mem=MODEL.N_MEM)
    atol_arr = changes.pop("atol", atol)
    fields.update(changes)
    settings = make_settings(rtol, atol_arr, reduced.N_ERR, **fields)
    return y0, p, edges, settings, METHODS["dopri5"].arrays()


def counts() -> dict:
    """Kernel calls of the default peak-only run (main loop) and of its refinement."""
    mech = SliderCrank()
    y0, p, edges, settings, coef = _plain_args(mech)
    pc = np.concatenate([p, np.zeros(4)])
    out = integrate(_count_rhs, _count_event, _count_on_event, _count_monitor, y0, pc, edges,
                    settings, coef)
    counters = out[5]
    main = dict(zip(("rhs", "event", "on_event", "monitor"), pc[_C:_C + 4].astype(int)))
    # the refinement alone: each refined step is one rhs at its start and
    # (refine_iters + 2) golden-section steps (s - 1 rhs and a monitor each)
    s = METHODS["dopri5"].B.shape[0]
    n_golden = int(counters[4]) * (reduced.REFINE_ITERS + 2)
    refine = {"rhs": int(counters[4]) + n_golden * (s - 1), "monitor": n_golden}
    return {"main": main, "refine": refine, "nfev": int(counters[0]),
            "naccept": int(counters[1]), "nreject": int(counters[2])}


def variants(repeats: int) -> dict:
    """CPU ms (median) of the peak-only kernel run with parts switched off, and recorded."""
    mech = SliderCrank()
    kernel = reduced.MODEL.integrate_model
    runs = {
        "peak only (default)": _plain_args(mech),
        "no peak refinement": _plain_args(mech, refine_iters=0),
        "no error control of g": _plain_args(
            mech, atol=reduced._tolerances(mech, None, None)[1]),
        "no interior event sample": _plain_args(mech, n_samples=0),
        "recorded with outputs (simulate's run)": _plain_args(
            mech, record=True, n_out=MODEL.N_OUT),
    }
    nfev = {}
    for name, (y0, p, edges, settings, coef) in runs.items():
        nfev[name] = int(kernel(y0, p.copy(), edges, settings, coef)[5][0])
    times = {name: [] for name in runs}
    for _ in range(repeats):            # in rotation: a load change hits all alike
        for name, (y0, p, edges, settings, coef) in runs.items():
            q = p.copy()
            t0 = time.thread_time()
            kernel(y0, q, edges, settings, coef)
            times[name].append(time.thread_time() - t0)
    t_sim = []
    for _ in range(max(5, repeats // 5)):
        t0 = time.thread_time()
        simulate(mech, 4)
        t_sim.append(time.thread_time() - t0)
    res = {name: (1e3 * float(np.median(ts)), nfev[name]) for name, ts in times.items()}
    res["simulate (public call)"] = (1e3 * float(np.median(t_sim)), None)
    return res


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=51)
    ap.add_argument("--counts", action="store_true",
                    help="count the kernel calls (compiles the integrator for counting "
                         "wrappers: minutes the first time)")
    args = ap.parse_args(argv)
    print(machine_summary())
    cost = kernel_costs(args.repeats)
    print("\n| kernel | CPU ns per call |\n|---|---|")
    for name, ns in cost.items():
        print(f"| {name} | {ns:.1f} |")
    att = attempt_cost(args.repeats)
    print("\n| one attempted step (dopri5) | CPU ns |\n|---|---|")
    for name, ns in att.items():
        print(f"| {name} | {ns:.1f} |")
    runs = variants(args.repeats)
    base = runs["peak only (default)"][0]
    print("\n| run (paper case, 4 revolutions) | CPU ms | / peak only | nfev |\n|---|---|---|---|")
    for name, (ms, nfev) in runs.items():
        print(f"| {name} | {ms:.3f} | {ms / base:.3f} | {nfev if nfev is not None else ''} |")
    if args.counts:
        c = counts()
        print(f"\ncounts: {c}")
        main_ns = (c["main"]["rhs"] * cost["rhs"] + c["main"]["monitor"]
                   * cost["monitor (no outputs)"] + c["main"]["event"] * cost["event"])
        ref_ns = c["refine"]["rhs"] * cost["rhs"] + c["refine"]["monitor"] * cost[
            "monitor (no outputs)"]
        print("\n| part of the peak-only run | calls | CPU ms (calls x cost) | share |")
        print("|---|---|---|---|")
        rows = [
            ("rhs, main loop", c["main"]["rhs"], c["main"]["rhs"] * cost["rhs"]),
            ("monitor, main loop", c["main"]["monitor"],
             c["main"]["monitor"] * cost["monitor (no outputs)"]),
            ("event, main loop", c["main"]["event"], c["main"]["event"] * cost["event"]),
            ("rhs + monitor, peak refinement", c["refine"]["rhs"] + c["refine"]["monitor"],
             ref_ns),
        ]
        for name, calls, ns in rows:
            print(f"| {name} | {calls} | {ns * 1e-6:.3f} | {ns * 1e-6 / base:.2f} |")
        rest = base - (main_ns + ref_ns) * 1e-6
        print(f"| the integrator's own work (the rest) | | {rest:.3f} | {rest / base:.2f} |")


if __name__ == "__main__":
    main()
