"""Cost of a run to a requested accuracy: `simulate(mech)` (accuracy 1e-5: the run at rtol
1e-7 and its error estimate) against a run at the fixed rtol 1e-7 (`simulate(mech,
rtol=1e-7)`, the same run without an estimate), on designs where the fixed run already
meets 1e-5 (the paper case and the named cases' defaults, 4 revolutions). Every run has
its contact diagnostics; an unflagged one takes the cheap check (a peaks-only run at
100 x the rtol).

Timed in alternating pairs (fixed, requested, fixed, ...) so that a change of the machine's
load hits both; medians over the repeats and the ratio of the medians. Target: ratio <= 1.5.

    python -m benchmarks.accuracy_request_cost [--repeats 21]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from mbs_clearance import SliderCrank, simulate
from mbs_clearance.model import cases
from validation.timing import machine_summary


def designs() -> dict:
    """label -> mechanism: designs whose default run meets 1e-5 without a flag."""
    return {"paper case (SliderCrank)": SliderCrank(),
            "paper_slider_crank (Linkage)": cases.paper_slider_crank(),
            "slider_crank_two_clearances": cases.slider_crank_two_clearances()}


def pair(mech, repeats: int) -> tuple[float, float, dict]:
    """Medians (s) of the fixed-rtol and requested-accuracy runs, alternating; the latter's
    stats."""
    fixed, requested = [], []
    stats = {}
    for _ in range(repeats):
        t0 = time.perf_counter()
        simulate(mech, rtol=1e-7)
        fixed.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        stats = simulate(mech).stats
        requested.append(time.perf_counter() - t0)
    return float(np.median(fixed)), float(np.median(requested)), stats


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=21)
    args = ap.parse_args(argv)
    print(machine_summary())
    warnings.simplefilter("ignore")
    print("| design | rtol 1e-7 (ms) | accuracy 1e-5 (ms) | ratio | runs | estimate |\n"
          "|---|---|---|---|---|---|")
    worst = 0.0
    for label, mech in designs().items():
        simulate(mech)                       # compile and warm up
        tf, ta, st = pair(mech, args.repeats)
        worst = max(worst, ta / tf)
        print(f"| {label} | {1e3 * tf:.1f} | {1e3 * ta:.1f} | {ta / tf:.2f} | "
              f"{len(st['accuracy_runs'])} | {st['error_estimate']:.2g} |", flush=True)
    print(f"\nworst ratio {worst:.2f} (target <= 1.5)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
