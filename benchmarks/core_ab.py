"""Run time of this checkout's runs against another build's, in alternating pairs.

    python -m benchmarks.core_ab --reference PYTHON [--reference-env NAME=VALUE ...]
                                 [--pairs 15] [--run NAME ...] [--clock wall|cpu]

`PYTHON` is the interpreter of another installation of mbs-clearance (for instance a venv
of an earlier release, which ran on numba: ``--reference-env MBS_CLEARANCE_CORE=numba``).
Each side runs in a long-lived worker process of its own (`benchmarks/ab_worker.py`, run
by each interpreter: each imports its own package) that loads every run's model and runs
it once before timing; the parent then asks the two workers for the same run in
alternating order (this, reference; then reference, this) so that each pair shares the
machine's load. Printed per run: each side's median time, the median of the per-pair
ratios this / reference and their range, and the relative difference of the two sides'
results (the last peak, or a DDM run's largest derivative), which shows that the runs
are the same computation. ``--clock cpu`` times each run by its thread's CPU time instead of
the wall clock: on a shared machine the other users' load then falls out of the times
(though not their use of the caches).

Runs: the paper's slider-crank (recorded and peak only, 4 revolutions), its DDM along 8
parameters, the four-bar (1 revolution), the lubricated case (rodas4, 1 revolution) and
the translational-clearance benchmark (a free run of 0.05 s).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

WORKER = Path(__file__).with_name("ab_worker.py")


class _Worker:
    """A worker process: one line in (a run's name), one line out (wall and CPU seconds,
    value)."""

    def __init__(self, python: str, env: dict):
        self.proc = subprocess.Popen([python, str(WORKER)], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, text=True, env=env,
                                     cwd=str(WORKER.parent))

    def ask(self, name: str) -> tuple[float, float, float]:
        self.proc.stdin.write(name + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the worker of {self.proc.args[0]} ended (run {name!r})")
        seconds, cpu, value = line.split()
        return float(seconds), float(cpu), float(value)

    def close(self):
        self.proc.stdin.close()
        self.proc.wait(timeout=60)


def measure(names, pairs: int, reference: str, reference_env: dict,
            clock: str = "wall") -> dict:
    """Per run: each side's median time (s; wall or CPU, `clock`), the per-pair ratios'
    median and range, and the relative difference of the two sides' results."""
    column = {"wall": 0, "cpu": 1}[clock]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    this, other = _Worker(sys.executable, env), _Worker(reference, {**env, **reference_env})
    rows = {}
    try:
        for name in names:
            values = [w.ask(name)[2] for w in (this, other)]     # warm: loaded, run once
            times = {"this": [], "other": []}
            for k in range(pairs):
                order = (("this", this), ("other", other))
                for side, worker in (order if k % 2 == 0 else order[::-1]):
                    times[side].append(worker.ask(name)[column])
            ratio = np.asarray(times["this"]) / np.asarray(times["other"])
            rows[name] = {"this_s": float(np.median(times["this"])),
                          "other_s": float(np.median(times["other"])),
                          "ratio": float(np.median(ratio)), "low": float(ratio.min()),
                          "high": float(ratio.max()),
                          "difference": abs(values[0] - values[1]) / abs(values[1])}
    finally:
        this.close()
        other.close()
    return rows


def main(argv=None) -> int:
    sys.path.insert(0, str(WORKER.parent))
    from ab_worker import RUNS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", required=True,
                        help="the Python interpreter of the build to compare with")
    parser.add_argument("--reference-env", action="append", default=[], metavar="NAME=VALUE",
                        help="an environment variable for the reference's worker")
    parser.add_argument("--pairs", type=int, default=15, help="alternating pairs per run")
    parser.add_argument("--run", nargs="+", choices=list(RUNS), default=list(RUNS),
                        help="which runs (default: all)")
    parser.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                        help="time each run by the wall clock (default) or by its thread's "
                             "CPU time")
    args = parser.parse_args(argv)
    if args.pairs < 1:
        parser.error("--pairs must be >= 1")
    ref_env = {}
    for item in args.reference_env:
        name, sep, value = item.partition("=")
        if not sep or not name:
            parser.error(f"--reference-env must be NAME=VALUE; got {item!r}")
        ref_env[name] = value
    from validation.timing import machine_summary

    rows = measure(args.run, args.pairs, args.reference, ref_env, args.clock)
    print(f"this build / reference, {args.pairs} alternating pairs, {args.clock} time "
          f"({machine_summary()})")
    print(f"{'run':<26} {'reference (ms)':>14} {'this (ms)':>10} {'ratio':>7} {'range':>13}"
          f" {'result diff':>11}")
    for name, r in rows.items():
        print(f"{name:<26} {1e3 * r['other_s']:>14.2f} {1e3 * r['this_s']:>10.2f} "
              f"{r['ratio']:>7.3f} {r['low']:>6.3f}-{r['high']:.3f} {r['difference']:>11.1e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
