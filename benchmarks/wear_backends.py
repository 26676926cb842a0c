"""Cost of one wear step (`studies.wear.cycle_wear`: 3 revolutions to settle, 1 recorded) on
each backend, for the wear case with a worn (non-circular) bearing.

    python -m benchmarks.wear_backends [--repeats 3]

The bearing is the case's circle worn by 5 um over a quarter of its circumference (a
smooth bump, 360 radii), the joint the profiled one of both models. One untimed run per
backend first (the model built, Exudyn imported), then `--repeats` alternating runs; the
median wall time of each backend and their ratio are printed.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def worn_case():
    """The wear case with a smooth 5 um wear bump on a quarter of its bearing."""
    from dataclasses import replace

    from mbs_clearance.model.cases import paper_slider_crank_wear

    lk = paper_slider_crank_wear()
    cj = lk.clearance_joints[0]
    theta = 2.0 * np.pi * np.arange(360) / 360
    bump = 5e-6 * np.clip(np.cos(2.0 * (theta - np.pi)), 0.0, None) ** 2
    bump[np.abs(theta - np.pi) > np.pi / 4] = 0.0
    return lk.replace(clearance_joints=(replace(cj, bearing_profile=tuple(
        cj.bearing_radius + bump)),))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per backend")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be >= 1")
    from mbs_clearance.studies.wear import cycle_wear
    from validation.timing import machine_summary

    lk = worn_case()
    k = lk.clearance_joints[0].wear_coefficient
    times = {"reduced": [], "exudyn": []}
    for backend in times:
        cycle_wear(lk, 0, k, backend=backend)
    for r in range(args.repeats):
        for backend in (("reduced", "exudyn") if r % 2 == 0 else ("exudyn", "reduced")):
            t0 = time.perf_counter()
            cycle_wear(lk, 0, k, backend=backend)
            times[backend].append(time.perf_counter() - t0)
    red, exu = (float(np.median(times[b])) for b in ("reduced", "exudyn"))
    print(f"one wear step (4 revolutions) of the worn wear case, median of {args.repeats} "
          f"({machine_summary()})")
    print(f"reduced {red:.2f} s, exudyn {exu:.1f} s, exudyn / reduced {exu / red:.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
