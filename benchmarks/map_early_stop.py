"""The regime map with and without early stop: the 60 x 40 map of the paper's case
(clearance 1 um - 1 mm log x 500 - 10000 rpm, 100 revolutions, 50 kept, docs/regimes.md)
or every --stride-th point of each axis, on --workers threads, old (early_stop=False) and
new alternating in --pairs pairs (the machine's load drifts between runs).

Prints each run's wall time, the median ratio old / new, the right-hand side evaluations
of both, the points stopped early and every point whose regime or period differs.

    python -m benchmarks.map_early_stop [--stride 1] [--pairs 2] [--workers 2]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from mbs_clearance import SliderCrank, regime_map
from mbs_clearance.analysis.poincare import REGIMES
from mbs_clearance.studies.sweep import parse_sweep
from validation.timing import machine_summary

CLEARANCE = "clearance=1e-6:1e-3:log:60"
SPEED = "crank_speed=500rpm:10000rpm:40"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stride", type=int, default=1,
                    help="every stride-th value of each axis (default 1: the full grid)")
    ap.add_argument("--pairs", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    print(machine_summary())
    axes = [parse_sweep(CLEARANCE), parse_sweep(SPEED)]
    sweep = [(a.name, a.values[args.stride // 2::args.stride] if args.stride > 1
              else a.values) for a in axes]
    paper = SliderCrank()
    # warm the kernels (the plain run and the Newton check's variational run)
    regime_map(paper, ["clearance=1e-5"], revolutions=20, keep=17, workers=1)
    times = {False: [], True: []}
    maps = {}
    for _ in range(args.pairs):
        for early in (False, True):
            t0 = time.perf_counter()
            maps[early] = regime_map(paper, sweep, workers=args.workers,
                                     early_stop=early).dataset
            times[early].append(time.perf_counter() - t0)
            print(f"early_stop={early}: {times[early][-1]:.1f} s", flush=True)
    old, new = maps[False], maps[True]
    n = old["regime"].size
    ratios = [a / b for a, b in zip(times[False], times[True])]
    print(f"grid {' x '.join(str(len(v)) for _, v in sweep)} = {n} points, "
          f"{args.workers} workers, {args.pairs} pairs")
    print(f"wall time old {statistics.median(times[False]):.1f} s, new "
          f"{statistics.median(times[True]):.1f} s; ratio old / new per pair "
          f"{', '.join(f'{r:.2f}' for r in ratios)}")
    print(f"right-hand side evaluations old {int(old['nfev'].sum()):.4g}, new "
          f"{int(new['nfev'].sum()):.4g} "
          f"({int(old['nfev'].sum()) / int(new['nfev'].sum()):.2g} x fewer)")
    stopped = new["stopped"].values > 0
    print(f"stopped early: {int(stopped.sum())} points, after "
          f"{np.median(new['stopped'].values[stopped]) if stopped.any() else 0:.0f} "
          "revolutions (median)")
    codes, counts = np.unique(new["regime"].values, return_counts=True)
    print("regimes (new): " + ", ".join(f"{REGIMES[int(c)]} {k}" for c, k in
                                        zip(codes, counts)))
    differ = np.nonzero((old["regime"].values != new["regime"].values)
                        | (old["period"].values != new["period"].values))
    print(f"points whose regime or period differs: {len(differ[0])} of {n}")
    for i, j in zip(*differ):
        print(f"  clearance {float(old['clearance'][i]):.4g} m, "
              f"{float(old['crank_speed'][j]) * 30 / np.pi:.0f} rpm: old "
              f"{REGIMES[int(old['regime'].values[i, j])]}/{int(old['period'].values[i, j])}"
              f", new {REGIMES[int(new['regime'].values[i, j])]}/"
              f"{int(new['period'].values[i, j])} (stopped at "
              f"{int(new['stopped'].values[i, j])})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
