"""Speed of the compiled C core against the numba integrator on the same model (the test
ball of the core's tests: floor and ceiling impacts, drag, a state wider than the dense one),
run in alternating pairs (numba, C, numba, C, ...) so that a change of the machine's load
hits both alike. Both return the same numbers (checked here, bit for bit); the ratio of
their times is the per-evaluation cost of the two integrators.

    python -m benchmarks.core_speed [--pairs 21] [--duration 20] [--methods dopri5,rodas4]

Times are CPU time of the calling thread (`time.thread_time`), after one untimed warm-up
call of each (numba's compilation or cache load, the core's build).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "unit"))

from core_models import BALL_C, ball_numba, ball_parameters, ball_settings  # noqa: E402

from mbs_clearance.core import build  # noqa: E402
from mbs_clearance.core.integrate import integrate, model_record  # noqa: E402
from mbs_clearance.numerics.integrator import METHODS  # noqa: E402


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=21)
    parser.add_argument("--duration", type=float, default=20.0, help="simulated time in s")
    parser.add_argument("--methods", default="dopri5,dop853,bs3,rodas4")
    args = parser.parse_args(argv)
    model = model_record(*build.load("bench_ball", [("ball.c", BALL_C)]))
    y0 = np.array([0.5, 3.0, 0.0])
    edges = np.linspace(0.0, args.duration, int(2 * args.duration) + 1)
    settings = ball_settings(1e-8)
    print(f"{'method':8} {'nfev':>8} {'numba ms':>9} {'C ms':>8} {'C/numba':>8}")
    for method in args.methods.split(","):
        tab = METHODS[method].arrays()

        def run(kind, tab=tab):
            p = ball_parameters(e=1.0, drag=0.05, ceiling=0.8)
            started = time.thread_time()
            if kind == "numba":
                out = ball_numba(y0, p, edges, settings, tab)
            else:
                out = integrate(model, y0, p, edges, settings, tab)
            return time.thread_time() - started, out

        _, want = run("numba")
        _, got = run("C")
        if not all(np.array_equal(a, b) for a, b in zip(got[:7], want[:7])):
            raise SystemExit(f"{method}: the C core and numba differ")
        ratios, t_numba, t_c = [], [], []
        for _ in range(args.pairs):
            tn, _ = run("numba")
            tc, _ = run("C")
            t_numba.append(tn)
            t_c.append(tc)
            ratios.append(tc / tn)
        print(f"{method:8} {got[5][0]:8d} {1e3 * statistics.median(t_numba):9.2f} "
              f"{1e3 * statistics.median(t_c):8.2f} {statistics.median(ratios):8.3f}")


if __name__ == "__main__":
    main()
