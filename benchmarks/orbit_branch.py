"""Continuation against the brute-force line: the paper's case (5000 rpm) along clearance
from --start up to the first detected bifurcation by `continue_orbits`, and the regime
map's line over the same clearances with as many points as the branch has orbits
(100 revolutions each, 50 kept), one worker, serially.

Prints both wall times, the branch's detected point and the brute-force regimes along
the line. Run it on a quiet machine (timings on a shared machine vary).

    python -m benchmarks.orbit_branch [--start 1e-6] [--stop 1e-4]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mbs_clearance import SliderCrank, continue_orbits, regime_map
from mbs_clearance.analysis.poincare import REGIMES
from validation.timing import machine_summary


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--start", type=float, default=1e-6, help="first clearance (m)")
    parser.add_argument("--stop", type=float, default=1e-4, help="last clearance (m)")
    parser.add_argument("--max-points", type=int, default=400)
    args = parser.parse_args(argv)
    paper = SliderCrank()
    mech = paper.replace(journal_radius=paper.bearing_radius - args.start)
    # warm the kernels (compiled once per source digest) outside the timings
    continue_orbits(mech, "clearance", args.start, args.start * 1.001, max_points=2)
    regime_map(paper, [f"clearance={args.start},{args.start * 1.001}"], revolutions=4,
               keep=3, max_period=1, workers=1)
    t0 = time.perf_counter()
    branch = continue_orbits(mech, "clearance", args.start, args.stop, step=0.1,
                             max_step=3.0, max_points=args.max_points, stop_at_first=True)
    t_branch = time.perf_counter() - t0
    n = len(branch.values)
    hi = float(np.max(branch.values))
    t0 = time.perf_counter()
    res = regime_map(paper, [f"clearance={args.start}:{hi}:log:{n}"], workers=1)
    t_map = time.perf_counter() - t0
    print(machine_summary())
    print(branch.summary())
    print(f"continuation: {n} orbits, {branch.counters['shooting_runs']} shooting runs, "
          f"{t_branch:.3g} s")
    print(f"continuation from {args.start * 1e3:.3g} mm to {hi * 1e3:.3g} mm")
    codes, counts = np.unique(res.dataset["regime"].values, return_counts=True)
    regimes = ", ".join(f"{REGIMES[int(c)]} {k}" for c, k in zip(codes, counts))
    print(f"brute-force line: {n} points over {args.start:.3g} - {hi:.3g} m, {t_map:.3g} s "
          f"({regimes})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
