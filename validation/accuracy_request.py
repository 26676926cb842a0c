"""Accuracy as a request: `simulate(case, accuracy=a)` against the same model at rtol 1e-12.

For each named case (mbs_clearance.model.cases) at its defaults and at three other points (a
slower drive, a larger clearance, a lower restitution), the per-revolution peaks of the
monitored force of `simulate(..., accuracy=a)` for a = 1e-5 and 1e-6 against the reduced
model's own run at rtol 1e-12: the true error, the run's estimate, the rtols it ran, and
whether the true error is within the request.

    python -m validation.accuracy_request [--revolutions 4] [--cases NAME ...]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from mbs_clearance import simulate
from mbs_clearance.model import cases
from mbs_clearance.solve.accuracy import revolution_peaks

RPM = 2.0 * math.pi / 60.0

#: the reference's rtol
REFERENCE_RTOL = 1e-12

#: the requested accuracies
ACCURACIES = (1e-5, 1e-6)


def points() -> dict[str, list[tuple[str, dict]]]:
    """case -> [(label, overrides)]: the default, a slower drive, a larger clearance and a
    lower restitution."""
    return {
        "paper_slider_crank": [
            ("default", {}),
            ("2000 rpm", {"crank_speed": 2000 * RPM}),
            ("c = 0.05 mm", {"journal_radius": 0.01 - 5e-5}),
            ("restitution 0.5", {"restitution": 0.5}),
        ],
        "slider_crank_two_clearances": [
            ("default", {}),
            ("3000 rpm", {"crank_speed": 3000 * RPM}),
            ("c_A = 0.05 mm", {"crank_coupler_clearance": 5e-5}),
            ("restitution 0.5", {"restitution": 0.5}),
        ],
        "four_bar": [
            ("default", {}),
            ("5 rpm", {"crank_speed": 5 * RPM}),
            ("c = 0.05 mm", {"clearance": 5e-5}),
            ("restitution 0.5", {"restitution": 0.5}),
        ],
    }


#: revolutions per case where not --revolutions: the four-bar's slow drive (6 s per
#: revolution at 10 rpm) with its lasting, weakly damped contact takes millions of steps per
#: revolution at rtol 1e-12
REVOLUTIONS = {"four_bar": 1}

#: step limit of the references (the four-bar's exceed the default 5e6)
REFERENCE_MAX_STEPS = 50_000_000


def reference_peaks(linkage, revolutions: int) -> np.ndarray:
    """Per-revolution peaks at rtol 1e-12."""
    return revolution_peaks(simulate(linkage, revolutions, rtol=REFERENCE_RTOL,
                                     max_steps=REFERENCE_MAX_STEPS))


def row(case: str, label: str, overrides: dict, revolutions: int) -> list[dict]:
    """One line per requested accuracy at one point."""
    linkage = cases.CASES[case](**overrides)
    ref = reference_peaks(linkage, revolutions)
    out = []
    for a in ACCURACIES:
        t0 = time.perf_counter()
        traj = simulate(linkage, revolutions, accuracy=a, max_steps=REFERENCE_MAX_STEPS)
        seconds = time.perf_counter() - t0
        err = float(np.max(np.abs(revolution_peaks(traj) / ref - 1.0)))
        st = traj.stats
        out.append({"case": case, "point": label, "revolutions": revolutions,
                    "accuracy": a, "error": err,
                    "estimate": st["error_estimate"], "method": st["error_estimate_method"],
                    "rtol": st["rtol"], "runs": st["accuracy_runs"],
                    "nfev": st["accuracy_nfev"], "seconds": seconds,
                    "ok": st["accuracy_ok"], "met": err <= a})
    return out


def table(rows: list[dict]) -> str:
    lines = [f"{'case':<28} {'point':<16} {'revs':>4} {'request':>8} {'error':>9} "
             f"{'estimate':>9} "
             f"{'final rtol':>10} {'runs':>4} {'nfev':>8} {'met':>4}  how"]
    for r in rows:
        lines.append(f"{r['case']:<28} {r['point']:<16} {r['revolutions']:>4} "
                     f"{r['accuracy']:>8.0e} {r['error']:>9.2e} {r['estimate']:>9.2e} "
                     f"{r['rtol']:>10.0e} "
                     f"{len(r['runs']):>4} {r['nfev']:>8} {'yes' if r['met'] else 'NO':>4}  "
                     f"{r['method']}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--revolutions", type=int, default=4,
                    help="revolutions per run (the four-bar: 1 unless given)")
    ap.add_argument("--cases", nargs="*", default=sorted(points()))
    args = ap.parse_args(argv)
    rows = []
    for case in args.cases:
        for label, overrides in points()[case]:
            revs = (REVOLUTIONS.get(case, args.revolutions) if args.revolutions == 4
                    else args.revolutions)
            rows += row(case, label, overrides, revs)
            print("\n".join(table(rows[-len(ACCURACIES):]).splitlines()[1:]), flush=True)
    print()
    print(table(rows))
    missed = [r for r in rows if not r["met"]]
    print(f"\n{len(rows) - len(missed)} of {len(rows)} within the request; "
          f"the reference: the same model at rtol {REFERENCE_RTOL:g}")
    return 1 if missed else 0


if __name__ == "__main__":
    raise SystemExit(main())
