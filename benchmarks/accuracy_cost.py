"""Cost of the accuracy fix: the penetration under error control at the clearance's scale
(`reduced.EVENT_ATOL`), against the same integrator without it (the state's error control
alone, as before the fix), in one run.

Timed: the paper case (peak only and `simulate`, 4 revolutions) and the 9 x 9 grid of the
GA's box in total (peak only), medians over repeats, interleaved (before, after, before, ...)
so that a change of the machine's load hits both. Also the function evaluations and the
worst per-revolution peak error against rtol 1e-12 (validation/accuracy_map.py). Target:
after / before <= 1.5 on the paper case and on the grid.

    python -m benchmarks.accuracy_cost [--repeats 7] [--n 9]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mbs_clearance import SliderCrank
from mbs_clearance.solve import reduced
from validation import accuracy_map as am
from validation.timing import machine_summary


def _run(mech, fixed: bool, record: bool):
    options = {} if fixed else am.state_error_only()
    return reduced.run(mech, 4, record=record, **options)


def _peaks(mech, fixed, record=False):
    out = _run(mech, fixed, record)
    return out.peaks, int(out.counters[0])


def _interleaved(fn_before, fn_after, repeats):
    tb, ta = [], []
    for _ in range(repeats):
        for fn, acc in ((fn_before, tb), (fn_after, ta)):
            t0 = time.perf_counter()
            fn()
            acc.append(time.perf_counter() - t0)
    return float(np.median(tb)), float(np.median(ta))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--n", type=int, default=9, help="grid points per axis")
    args = ap.parse_args(argv)
    print(machine_summary())
    paper = SliderCrank()
    grid = [am.grid_mechanism(a, b) for a, b in am.grid_designs(args.n)]
    for m in [paper] + grid:            # JIT warm-up and the references (cached)
        am.reference_peaks(m)
    print("| run | before (ms) | after (ms) | ratio | nfev before | nfev after | "
          "worst peak error before | after | nfev after / before |\n"
          "|---|---|---|---|---|---|---|---|---|")
    for label, mechs, record in (("paper case, peak only", [paper], False),
                                 ("paper case, simulate", [paper], True),
                                 (f"{args.n} x {args.n} grid, peak only, total", grid, False)):
        res = {}
        for fixed in (False, True):
            peaks = [_peaks(m, fixed, record) for m in mechs]
            err = max(float(np.max(np.abs(p / am.reference_peaks(m) - 1)))
                      for (p, _), m in zip(peaks, mechs))
            res[fixed] = (sum(n for _, n in peaks), err)
        tb, ta = _interleaved(lambda ms=mechs, r=record: [_run(m, False, r) for m in ms],
                              lambda ms=mechs, r=record: [_run(m, True, r) for m in ms],
                              args.repeats)
        print(f"| {label} | {1e3 * tb:.1f} | {1e3 * ta:.1f} | {ta / tb:.2f} | "
              f"{res[False][0]} | {res[True][0]} | {res[False][1]:.1e} | {res[True][1]:.1e} | "
              f"{res[True][0] / res[False][0]:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
