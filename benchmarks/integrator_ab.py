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

    python -m benchmarks.integrator_ab [--repeats 41] [--json]

Times are CPU time of the calling thread (`time.thread_time`: on a loaded machine wall time
also counts the other processes) and wall time. A/B against another checkout of the
repository (e.g. main's, compiled there once) in ALTERNATING processes, this checkout's and
the other's, each timing `--repeats` rotations; the ratio (other / this) of each pair of
processes, and their median:

    python -m benchmarks.integrator_ab --other /path/to/main --rounds 5

``--other-rtol R`` runs the other side's plain runs at rtol R (an A/B at equal accuracy, e.g.
against a version without the penetration's error control); each side's per-revolution
peak error against its own rtol 1e-12 run is printed after the table.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from mbs_clearance import SliderCrank, peak_base_force, sensitivities, simulate
from validation.timing import machine_summary


def _cases(mech, rtol=None):
    """name -> (call, nfev of a call's result or None); rtol: the plain runs' tolerance
    (None: the default; the DDM keeps its own)."""
    kw = {} if rtol is None else {"rtol": rtol}
    return {
        "simulate": (lambda: simulate(mech, 4, **kw), lambda r: r.stats.get("nfev")),
        "peak_base_force": (lambda: peak_base_force(mech, 4, **kw), lambda r: None),
        "ddm_1rev": (lambda: sensitivities(mech, revolutions=1), lambda r: r.stats.get("nfev")),
    }


def peak_errors(rtol=None, reference_rtol: float = 1e-12) -> list[float]:
    """Relative error of each revolution's peak |F12| (`simulate(mech, 4)` at rtol, the
    default if None) against the same code at `reference_rtol`: what the run's time buys."""
    mech = SliderCrank()
    kw = {} if rtol is None else {"rtol": rtol}
    got = np.asarray(simulate(mech, 4, **kw).peaks, dtype=float)
    ref = np.asarray(simulate(mech, 4, rtol=reference_rtol).peaks, dtype=float)
    return [float(v) for v in np.abs(got / ref - 1.0)]


def measure(repeats: int, rtol=None) -> dict:
    """Median and quartiles (s) of each case over `repeats` rotations, and nfev."""
    mech = SliderCrank()
    cases = _cases(mech, rtol)
    nfev = {}
    for name, (call, count) in cases.items():
        nfev[name] = count(call())                  # warm-up (compile or load the cache)
    times = {name: [] for name in cases}
    cpu = {name: [] for name in cases}
    for _ in range(repeats):
        for name, (call, _) in cases.items():
            c0 = time.thread_time()
            t0 = time.perf_counter()
            call()
            times[name].append(time.perf_counter() - t0)
            cpu[name].append(time.thread_time() - c0)
    out = {}
    for name, ts in times.items():
        q1, med, q3 = np.percentile(ts, [25, 50, 75])
        out[name] = {"median_s": float(med), "q1_s": float(q1), "q3_s": float(q3),
                     "cpu_median_s": float(np.median(cpu[name])),
                     "repeats": repeats, "nfev": nfev[name]}
    return out


def _process(checkout: Path, repeats: int, rtol=None, what: str = "measure") -> dict | list:
    """`measure` (or `peak_errors`) of this script in a new process that imports the
    package `mbs_clearance` from `checkout` (the same measurement code on either side)."""
    here = Path(__file__).resolve().parents[1]
    code = ("import json, sys; sys.path.insert(0, sys.argv[1]); import mbs_clearance; "
            "sys.path.insert(0, sys.argv[2]); "
            "from benchmarks.integrator_ab import measure, peak_errors; "
            "import validation; "
            "assert mbs_clearance.__file__.startswith(sys.argv[1]), mbs_clearance.__file__; "
            "assert validation.__file__.startswith(sys.argv[2]), validation.__file__; "
            "rtol = None if sys.argv[4] == 'None' else float(sys.argv[4]); "
            "print(json.dumps(measure(int(sys.argv[3]), rtol) if sys.argv[5] == 'measure' "
            "else peak_errors(rtol)))")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    res = subprocess.run([sys.executable, "-c", code, str(checkout), str(here), str(repeats),
                          str(rtol), what],
                         cwd=checkout, env=env, capture_output=True, text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def compare(other: Path, rounds: int, repeats: int, other_rtol=None) -> dict:
    """Alternating processes of this checkout and `other` (this, other, this, ...): per
    case the median over rounds of the ratio other / this of the CPU medians (and of the
    wall medians), and each side's nfev; `other_rtol`: the other side's plain runs at this
    tolerance (for an A/B at equal accuracy: `peak_errors` of each side are printed)."""
    here = Path(__file__).resolve().parents[1]
    _process(here, 1)                     # warm-up: compile or load both caches
    _process(other, 1, other_rtol)
    ratios = {}
    last = {}
    for _ in range(rounds):
        a = _process(here, repeats)
        b = _process(other, repeats, other_rtol)
        for name in a:
            r = ratios.setdefault(name, {"cpu": [], "wall": []})
            r["cpu"].append(b[name]["cpu_median_s"] / a[name]["cpu_median_s"])
            r["wall"].append(b[name]["median_s"] / a[name]["median_s"])
        last = {"this": a, "other": b}
    return {name: {"cpu_ratio": float(np.median(r["cpu"])),
                   "wall_ratio": float(np.median(r["wall"])),
                   "cpu_ratios": r["cpu"],
                   "this_cpu_ms": 1e3 * last["this"][name]["cpu_median_s"],
                   "other_cpu_ms": 1e3 * last["other"][name]["cpu_median_s"],
                   "nfev_this": last["this"][name]["nfev"],
                   "nfev_other": last["other"][name]["nfev"]} for name, r in ratios.items()}


def _main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=41)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--other", type=Path,
                    help="another checkout of the repository: A/B in alternating processes")
    ap.add_argument("--rounds", type=int, default=5, help="process pairs with --other")
    ap.add_argument("--other-rtol", type=float, default=None,
                    help="the other checkout's plain runs at this rtol (default: its own "
                         "default); each side's per-revolution peak errors are printed")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error("--repeats must be >= 1")
    if args.other is not None:
        if args.rounds < 1:
            ap.error("--rounds must be >= 1")
        if args.other_rtol is not None and not args.other_rtol > 0.0:
            ap.error("--other-rtol must be > 0")
        res = compare(args.other.resolve(), args.rounds, args.repeats, args.other_rtol)
        print(machine_summary())
        print(f"other = {args.other}; {args.rounds} alternating process pairs, "
              f"{args.repeats} repeats each; ratio = other / this (> 1: this is faster)")
        print("| case | CPU ratio (median of pairs) | wall ratio | CPU ms this / other "
              "(last pair) | nfev this / other |\n|---|---|---|---|---|")
        for name, r in res.items():
            print(f"| {name} | {r['cpu_ratio']:.3f} | {r['wall_ratio']:.3f} | "
                  f"{r['this_cpu_ms']:.3f} / {r['other_cpu_ms']:.3f} | "
                  f"{r['nfev_this']} / {r['nfev_other']} |")
        here = Path(__file__).resolve().parents[1]
        mine = _process(here, 1, None, "errors")
        theirs = _process(args.other.resolve(), 1, args.other_rtol, "errors")
        print("per-revolution peak |F12| error against the same code at rtol 1e-12 "
              f"(this, default rtol): {', '.join(f'{e:.1e}' for e in mine)}; other (rtol "
              f"{args.other_rtol or 'default'}): {', '.join(f'{e:.1e}' for e in theirs)}")
        return 0
    res = measure(args.repeats)
    if args.json:
        print(json.dumps({"machine": machine_summary(), "cases": res}))
        return 0
    print(machine_summary())
    print("| case | median (ms) | quartiles (ms) | CPU median (ms) | nfev |\n"
          "|---|---|---|---|---|")
    for name, r in res.items():
        print(f"| {name} | {1e3 * r['median_s']:.3f} | {1e3 * r['q1_s']:.3f} - "
              f"{1e3 * r['q3_s']:.3f} | {1e3 * r['cpu_median_s']:.3f} | {r['nfev']} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(_main())
