"""The converged cross-check at the named cases' points: Exudyn at h, h/2, h/4 extrapolated
(`mbs_clearance.backends.exudyn_convergence`) and the reduced model at accuracy 1e-6, each with its
error bar, against the reduced model at rtol 1e-12; the time each model needed.

    python -m validation.cross_check [--revolutions 4] [--cases NAME ...] [--points LABEL ...]
                                     [--exudyn-accuracy 1e-4]

The points are those of `validation.accuracy_request` (default, a slower drive, a larger
clearance, a lower restitution). Exudyn's steps start at its default step h; with
--exudyn-accuracy they are halved beyond h/4 (at most three times) until every
revolution's bar is within it.
"""

from __future__ import annotations

import argparse

import numpy as np

from mbs_clearance.model import cases

from .accuracy_request import points, reference_peaks
from .compare import cross_check


def rows(case: str, label: str, overrides: dict, revolutions: int,
         exudyn_accuracy: float | None = None) -> list[dict]:
    """One row per revolution at one point."""
    linkage = cases.CASES[case](**overrides)
    ref = reference_peaks(linkage, revolutions)
    cc = cross_check(linkage, revolutions, accuracy=1e-6, exudyn_accuracy=exudyn_accuracy)
    out = []
    for k in range(revolutions):
        out.append({"case": case, "point": label, "revolution": k + 1,
                    "exudyn": cc.exudyn[k] / ref[k] - 1.0,
                    "bar": cc.exudyn_error[k] / ref[k], "order": cc.exudyn_order[k],
                    "reduced": cc.reduced[k] / ref[k] - 1.0,
                    "reduced_bar": cc.reduced_error[k] / ref[k],
                    "verdict": "model difference" if cc.model_difference[k] else "agree",
                    "seconds_exudyn": cc.exudyn_seconds,
                    "seconds_reduced": cc.reduced_seconds})
    return out


def table(rs: list[dict]) -> str:
    lines = [f"{'case':<28} {'point':<16} {'rev':>3} {'exudyn':>10} {'+-':>9} {'order':>5} "
             f"{'in bar':>6} {'reduced':>10} {'+-':>9} {'verdict':<16} {'exudyn s':>8} "
             f"{'reduced s':>9}"]
    for r in rs:
        order = "-" if not np.isfinite(r["order"]) else f"{r['order']:.2f}"
        lines.append(f"{r['case']:<28} {r['point']:<16} {r['revolution']:>3} "
                     f"{r['exudyn']:>10.2e} {r['bar']:>9.2e} {order:>5} "
                     f"{'yes' if abs(r['exudyn']) <= r['bar'] else 'NO':>6} "
                     f"{r['reduced']:>10.2e} {r['reduced_bar']:>9.2e} {r['verdict']:<16} "
                     f"{r['seconds_exudyn']:>8.3g} {r['seconds_reduced']:>9.3g}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--revolutions", type=int, default=4)
    ap.add_argument("--cases", nargs="*", default=["paper_slider_crank",
                                                   "slider_crank_two_clearances"])
    ap.add_argument("--points", nargs="*", help="point labels (default: all four)")
    ap.add_argument("--exudyn-accuracy", type=float,
                    help="halve Exudyn's step beyond h/4 (at most three times) until every "
                         "relative bar is within this (default: three runs)")
    args = ap.parse_args(argv)
    out = []
    for case in args.cases:
        for label, overrides in points()[case]:
            if args.points and label not in args.points:
                continue
            out += rows(case, label, overrides, args.revolutions, args.exudyn_accuracy)
            print(table(out[-args.revolutions:]).split("\n", 1)[1], flush=True)
    print()
    print(table(out))
    print("\nexudyn, reduced: relative difference from the reduced model at rtol 1e-12; +-: "
          "each one's error bar, relative; in bar: |exudyn| <= its bar")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
