"""Per named case: the compiled integrator against scipy's DOP853 on the same compiled model.

For each case of `mbs_clearance.model.cases` (or `--case NAME`), 4 drive revolutions from the
centred start:

- reference: the 4th revolution's refined peak of the monitored force by our integrator at
  rtol 1e-12 (and, with --check-reference, by scipy DOP853 at rtol 1e-12: their relative
  difference is printed);
- ours: `simulate` (every step recorded) and the peak-only run at the default settings
  (the accuracy request 1e-5: dopri5 at rtol 1e-7 with its error check, tighter runs where
  the diagnostics flag the run), or at the method and rtol given by ``--ours METHOD:RTOL`` (e.g.
  ``--ours dop853:1e-4``: the same DOP853 pair as scipy's), and the peak's relative error
  against the reference;
- scipy: `solve_ivp(method="DOP853")` on the generated model's compiled right-hand side,
  one terminal event per clearance joint, the mode switched by the generated `on_event`
  between restarts (validation.scipy_reference.solve_scipy_linkage), at rtol 1e-5, 1e-6,
  ... until its error is not worse than ours;
- each scipy row timed against ours in ALTERNATING pairs in one process (ours, scipy, ours,
  scipy, ...; `common.paired`), the median of the per-pair ratios; the headline ratio is
  interpolated to our error in log(ratio) against log(error) between the last two rows
  (as speed_reduced.py does for the paper case);
- why: the ratio of function evaluations (scipy / ours at the rows bracketing our error)
  and the time per function evaluation of each (per-call overhead: scipy calls the
  compiled right-hand side from Python at every stage);
- the ceiling: one call of the compiled right-hand side alone (`rhs_call_ns`: a C loop
  over the recorded states of our run, in their contact modes, median of 5), and
  scipy's time per evaluation over it: the speed-up an integrator that cost nothing but
  its right-hand side would reach at scipy's number of evaluations.

    python -m benchmarks.case_speed [--case four_bar] [--repeats 3] [--ours dop853:1e-4]

Run it on a quiet machine: the ratios are the point of the script.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from mbs_clearance import peak_base_force, simulate
from mbs_clearance.model.cases import CASES
from mbs_clearance.solve.accuracy import DEFAULT_ACCURACY
from mbs_clearance.solve.linkage_model import DEFAULT_RTOL
from validation.scipy_reference import solve_scipy_linkage
from validation.timing import machine_summary, ns_per_call, paired

from .speed_reduced import equal_error_ratio

SCIPY_RTOLS = (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
REVOLUTION = 4


#: compiled loops over a model's kernels (through its record, mbs_core.h): reps passes over
#: the states ys (n rows of n_y) at the times ts with the memories ms (n rows of n_m) copied
#: into p before each call
_LOOPS_C = r"""
#include "mbs_core.h"

static void set_memory(double *p, const double *ms, int64_t i, int64_t n_m,
                       int64_t mem_start) {
    for (int64_t k = 0; k < n_m; k++)
        p[mem_start + k] = ms[i * n_m + k];
}

double rhs_loop(const mbs_model *m, const double *ts, const double *ys, int64_t n,
                int64_t n_y, const double *ms, int64_t n_m, double *p, int64_t mem_start,
                double *d, int64_t reps) {
    double acc = 0.0;
    for (int64_t r = 0; r < reps; r++)
        for (int64_t i = 0; i < n; i++) {
            set_memory(p, ms, i, n_m, mem_start);
            m->rhs(ts[i], ys + i * n_y, n_y, p, d);
            acc += d[0];
        }
    return acc;
}

double monitor_loop(const mbs_model *m, const double *ts, const double *ys, int64_t n,
                    int64_t n_y, const double *ms, int64_t n_m, double *p, int64_t mem_start,
                    double *d, double *out, int64_t n_out, double *g, double *gd,
                    int64_t reps) {
    double acc = 0.0;
    for (int64_t r = 0; r < reps; r++)
        for (int64_t i = 0; i < n; i++) {
            set_memory(p, ms, i, n_m, mem_start);
            acc += m->monitor(ts[i], ys + i * n_y, n_y, p, d, out, n_out, g, gd);
        }
    return acc;
}

double event_loop(const mbs_model *m, const double *ts, const double *ys, int64_t n,
                  int64_t n_y, const double *ms, int64_t n_m, double *p, int64_t mem_start,
                  int64_t reps) {
    double acc = 0.0, g_gd[2];
    for (int64_t r = 0; r < reps; r++)
        for (int64_t i = 0; i < n; i++) {
            set_memory(p, ms, i, n_m, mem_start);
            m->event(ts[i], ys + i * n_y, p, 0, g_gd);
            acc += g_gd[0];
        }
    return acc;
}
"""
_LOOPS_CDEF = """
double rhs_loop(const mbs_model *m, const double *ts, const double *ys, int64_t n,
                int64_t n_y, const double *ms, int64_t n_m, double *p, int64_t mem_start,
                double *d, int64_t reps);
double monitor_loop(const mbs_model *m, const double *ts, const double *ys, int64_t n,
                    int64_t n_y, const double *ms, int64_t n_m, double *p, int64_t mem_start,
                    double *d, double *out, int64_t n_out, double *g, double *gd,
                    int64_t reps);
double event_loop(const mbs_model *m, const double *ts, const double *ys, int64_t n,
                  int64_t n_y, const double *ms, int64_t n_m, double *p, int64_t mem_start,
                  int64_t reps);
"""


def _loops(model, ts, ys, ms, p):
    """The three loops bound to `model` and the states: callables of reps."""
    from mbs_clearance.core import build

    ffi, lib = build.load("kernel-loops", [("loops.c", _LOOPS_C)], cdef=_LOOPS_CDEF)
    ts = np.ascontiguousarray(ts, dtype=float)
    ys = np.ascontiguousarray(ys, dtype=float)
    ms = np.ascontiguousarray(ms[:, :model.N_MEM], dtype=float)
    p = np.ascontiguousarray(p, dtype=float).copy()
    n, n_y, n_m, J = ys.shape[0], ys.shape[1], ms.shape[1], model.N_EVENTS
    d, out = np.empty(n_y), np.empty(max(model.N_OUT, 1))
    g, gd = np.empty(J), np.empty(J)
    rec = ffi.cast("const mbs_model *", int(model.ffi.cast("uintptr_t", model.record)))

    def ptr(a):
        return ffi.cast("double *", ffi.from_buffer(a))

    common = (rec, ptr(ts), ptr(ys), n, n_y, ptr(ms), n_m, ptr(p), model.MEM_START)
    return {"rhs": lambda reps: lib.rhs_loop(*common, ptr(d), reps),
            "monitor": lambda reps: lib.monitor_loop(*common, ptr(d), ptr(out), model.N_OUT,
                                                     ptr(g), ptr(gd), reps),
            "event": lambda reps: lib.event_loop(*common, reps)}


def rhs_call_ns(linkage, **options) -> float:
    """ns per call of `linkage`'s compiled right-hand side over the recorded states of its
    run (revolution 1 to REVOLUTION, `options` as simulate's), median of 5 timings."""
    from mbs_clearance.solve.linkage_model import run

    model, ts, ys, ms, *_, p = run(linkage, REVOLUTION, **options)
    return model_rhs_ns(model, ts, ys, ms, p)


def model_rhs_ns(model, ts, ys, ms, p) -> float:
    """ns per call of `model`'s compiled rhs over the states ys (memories ms) at the times
    ts, with the parameters p (not changed), median of 5 timings."""
    return ns_per_call(_loops(model, ts, ys, ms, p)["rhs"], len(ts))


def model_kernel_ns(model, ts, ys, ms, p) -> dict[str, float]:
    """ns per call of `model`'s rhs, monitor (with its outputs) and event (joint 0) over the
    states ys (memories ms) at the times ts, medians of 5 timings each."""
    loops = _loops(model, ts, ys, ms, p)
    return {name: ns_per_call(loop, len(ts)) for name, loop in loops.items()}


def case_speed(name: str, repeats: int, check_reference: bool = False,
               ours: dict | None = None) -> dict:
    """The measurements of one case (see the module docstring) as a dict; `ours`: the
    options of our runs (method, rtol), the defaults if None."""
    ours = dict(ours or {})
    lk = CASES[name]()
    ref = peak_base_force(lk, REVOLUTION, rtol=1e-12)
    result = {"case": name, "reference": ref, "ours": ours}
    if check_reference:
        sref = solve_scipy_linkage(lk, REVOLUTION, rtol=1e-12).peaks[REVOLUTION - 1]
        result["scipy_reference_difference"] = abs(sref / ref - 1.0)
    traj = simulate(lk, REVOLUTION, **ours)              # compile / load, then measure
    ours_peak = peak_base_force(lk, REVOLUTION, **ours)
    ours_err = abs(ours_peak / ref - 1.0)
    result.update(ours_error=ours_err, ours_nfev=traj.stats["nfev"],
                  ours_events=traj.stats["nevent"])
    rows, ratios = [], []
    for rtol in SCIPY_RTOLS:
        res = solve_scipy_linkage(lk, REVOLUTION, rtol=rtol)
        err = abs(res.peaks[REVOLUTION - 1] / ref - 1.0)

        def run_scipy(r=rtol):
            return solve_scipy_linkage(lk, REVOLUTION, rtol=r)

        sim = paired(lambda: simulate(lk, REVOLUTION, **ours), run_scipy, repeats)
        peak = paired(lambda: peak_base_force(lk, REVOLUTION, **ours), run_scipy, repeats)
        rows.append((rtol, err, sim["b"], res.nfev))
        ratios.append((sim["ratio"], peak["ratio"], sim["a"], peak["a"], len(res.event_times)))
        print(f"  {name}: scipy rtol {rtol:g}: peak error {err:.2e} (ours {ours_err:.2e}), "
              f"nfev {res.nfev}, events {len(res.event_times)}, {sim['b']:.3g} s; paired "
              f"ratio {sim['ratio']:.0f} (simulate), {peak['ratio']:.0f} (peak only)",
              flush=True)
        if err <= ours_err:
            break
    result.update(rows=rows, paired=ratios)
    result["ratio_simulate"] = equal_error_ratio(rows, [r[0] for r in ratios], ours_err)
    result["ratio_peak"] = equal_error_ratio(rows, [r[1] for r in ratios], ours_err)
    last = rows[-1]
    t_ours = ratios[-1][2]
    result["nfev_ratio"] = last[3] / traj.stats["nfev"]
    result["us_per_nfev_scipy"] = 1e6 * last[2] / last[3]
    result["us_per_nfev_ours"] = 1e6 * t_ours / traj.stats["nfev"]
    result["rhs_ns"] = rhs_call_ns(lk, **ours)
    result["ceiling"] = 1e3 * result["us_per_nfev_scipy"] / result["rhs_ns"]
    return result


def ours_setting(text: str) -> dict:
    """``METHOD:RTOL`` (--ours) as simulate's options."""
    from mbs_clearance.numerics.integrator import METHODS

    method, _, rtol = text.partition(":")
    try:
        value = float(rtol)
    except ValueError:
        value = -1.0
    if method not in METHODS or not 0 < value < 1:
        raise argparse.ArgumentTypeError(
            f"--ours must be METHOD:RTOL with METHOD one of {sorted(METHODS)} and 0 < RTOL < 1;"
            f" got {text!r}")
    return {"method": method, "rtol": value}


def _fmt(x, spec):
    return "n/a" if x is None else format(x, spec)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=sorted(CASES), action="append",
                    help="a case (repeatable; default: every case)")
    ap.add_argument("--repeats", type=int, default=3, help="alternating pairs per scipy row")
    ap.add_argument("--check-reference", action="store_true",
                    help="also compare the reference peak with scipy DOP853 at rtol 1e-12")
    ap.add_argument("--ours", type=ours_setting, metavar="METHOD:RTOL",
                    help="our integrator and rtol (default: the accuracy request 1e-5, dopri5 at "
                         "rtol 1e-7 checked)")
    ap.add_argument("--json", help="also write the results to this JSON file")
    args = ap.parse_args(argv)
    names = args.case or list(CASES)
    results = []
    for name in names:
        results.append(case_speed(name, args.repeats, args.check_reference, args.ours))
    print()
    print(f"Machine: {machine_summary()}")
    setting = (f"{args.ours['method']} at rtol {args.ours['rtol']:g}" if args.ours
               else f"the defaults (accuracy {DEFAULT_ACCURACY:g}: dopri5 at rtol "
                    f"{DEFAULT_RTOL:g}, checked, tightened if flagged)")
    print(f"ours: {setting}; revolution {REVOLUTION}'s peak; "
          f"{args.repeats} alternating pairs per scipy row")
    print()
    print("| case | ours: peak error | scipy rtol at/below it (error) | speed-up simulate | "
          "speed-up peak only | nfev scipy / ours | us per nfev: scipy / ours | rhs call "
          "alone | ceiling (scipy per nfev / rhs call) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in results:
        rtol, err = r["rows"][-1][0], r["rows"][-1][1]
        print(f"| {r['case']} | {r['ours_error']:.1e} | {rtol:g} ({err:.1e}) | "
              f"{_fmt(r['ratio_simulate'], '.0f')} x | {_fmt(r['ratio_peak'], '.0f')} x | "
              f"{r['nfev_ratio']:.2f} | {r['us_per_nfev_scipy']:.1f} / "
              f"{r['us_per_nfev_ours']:.3f} | {r['rhs_ns']:.0f} ns | "
              f"{r['ceiling']:.0f} x |")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(results, fh, indent=1, default=float)


if __name__ == "__main__":
    main()
