"""Speed of the compiled integrator on the paper case, for A/B comparisons of two versions
of the code (e.g. main and a branch that changes the integrator), run one after the other on
the same quiet machine.

Only the public API is used (`simulate`, `peak_base_force`, `sensitivities`), so the same
script runs against either version. Timed, after one untimed warm-up call each (JIT
compilation or cache load): `simulate` (4 revolutions, recorded, default settings), the
peak only (`peak_base_force`, 4 revolutions) and DDM sensitivities (1 revolution), median
and quartiles over repeats taken in rotation (simulate, peak, ddm, simulate, ...) so that a
change of the machine's load hits all three alike. The function evaluations are printed
too: equal nfev in both versions means equal work, and then the time ratio is the
per-evaluation overhead of the integrator.

    python -m validation.benchmarks.integrator_ab [--repeats 41] [--json]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from mbs_clearance import SliderCrank, peak_base_force, sensitivities, simulate

from .common import machine_summary


def _cases(mech):
    """name -> (call, nfev of a call's result or None)."""
    return {
        "simulate": (lambda: simulate(mech, 4), lambda r: r.stats.get("nfev")),
        "peak_base_force": (lambda: peak_base_force(mech, 4), lambda r: None),
        "ddm_1rev": (lambda: sensitivities(mech, revolutions=1), lambda r: r.stats.get("nfev")),
    }


def measure(repeats: int) -> dict:
    """Median and quartiles (s) of each case over `repeats` rotations, and nfev."""
    mech = SliderCrank()
    cases = _cases(mech)
    nfev = {}
    for name, (call, count) in cases.items():
        nfev[name] = count(call())                  # warm-up (compile or load the cache)
    times = {name: [] for name in cases}
    for _ in range(repeats):
        for name, (call, _) in cases.items():
            t0 = time.perf_counter()
            call()
            times[name].append(time.perf_counter() - t0)
    out = {}
    for name, ts in times.items():
        q1, med, q3 = np.percentile(ts, [25, 50, 75])
        out[name] = {"median_s": float(med), "q1_s": float(q1), "q3_s": float(q3),
                     "repeats": repeats, "nfev": nfev[name]}
    return out


def _main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=41)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error("--repeats must be >= 1")
    res = measure(args.repeats)
    if args.json:
        print(json.dumps({"machine": machine_summary(), "cases": res}))
        return 0
    print(machine_summary())
    print("| case | median (ms) | quartiles (ms) | nfev |\n|---|---|---|---|")
    for name, r in res.items():
        print(f"| {name} | {1e3 * r['median_s']:.3f} | {1e3 * r['q1_s']:.3f} - "
              f"{1e3 * r['q3_s']:.3f} | {r['nfev']} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(_main())
