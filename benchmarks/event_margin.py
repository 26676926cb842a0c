"""The event search's margin (`linkage_model.EVENT_MARGIN`): run time and accuracy per case.

Within the margin of a wall the event search looks closer between its samples (7 more
samples and the interpolant's maximum) and limits the step while approaching; it guards
against the interpolation error of the switching function. For each named case, 4
revolutions at the default rtol: the run time with the margin at `--old` against the
current default (`simulate`, alternating pairs in one process, the median of the per-pair
ratios, `common.paired`), the function evaluations and events, and each revolution's peak
error against the same case at rtol 1e-11 (computed once, with the current margin).

    python -m benchmarks.event_margin [--case NAME ...] [--old 0.05] [--pairs 9]
"""

from __future__ import annotations

import argparse

import numpy as np

from mbs_clearance import simulate
from mbs_clearance.model import cases
from mbs_clearance.solve import linkage_model as lm
from validation.timing import machine_summary, paired

CASES = ("paper_slider_crank", "slider_crank_two_clearances", "four_bar")


def _with_margin(margin: float, fn):
    """fn() with lm.EVENT_MARGIN = margin (restored after)."""
    keep = lm.EVENT_MARGIN
    lm.EVENT_MARGIN = margin
    try:
        return fn()
    finally:
        lm.EVENT_MARGIN = keep


def measure(name: str, old: float, pairs: int) -> dict:
    case = getattr(cases, name)()
    new = lm.EVENT_MARGIN
    ref = np.asarray(simulate(case, 4, rtol=1e-11).peaks, dtype=float)
    row = {"case": name}
    for label, margin in (("old", old), ("new", new)):
        traj = _with_margin(margin, lambda: simulate(case, 4))
        row[label] = {"margin": margin, "nfev": traj.stats["nfev"],
                      "nevent": traj.stats["nevent"],
                      "errors": np.abs(np.asarray(traj.peaks) / ref - 1.0).tolist()}

    def run():
        simulate(case, 4)

    res = paired(lambda: _with_margin(new, run), lambda: _with_margin(old, run), pairs)
    row["ratio_old_over_new"] = res["ratio"]
    row["ms"] = (1e3 * res["b"], 1e3 * res["a"])
    row["pairs"] = pairs
    return row


def _main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", action="append", choices=CASES,
                    help="named case (repeatable; default: all three)")
    ap.add_argument("--old", type=float, default=0.05,
                    help="the margin compared, in clearances (default 0.05: the earlier margin)")
    ap.add_argument("--pairs", type=int, default=9)
    args = ap.parse_args(argv)
    if not args.old > 0.0:
        ap.error("--old must be > 0")
    if args.pairs < 1:
        ap.error("--pairs must be >= 1")
    print(machine_summary())
    print(f"margin now {lm.EVENT_MARGIN:g} c (at least {lm.MARGIN_PER_RTOL:g} rtol c), against "
          f"{args.old:g} c; {args.pairs} alternating pairs per case\n")
    print("| case | time, old / new margin | nfev old / new | events old / new | peak error "
          "per revolution, old margin | new margin |\n|---|---|---|---|---|---|")
    for name in args.case or CASES:
        r = measure(name, args.old, args.pairs)
        fmt = ", ".join
        print(f"| {name} | {r['ratio_old_over_new']:.2f} ({r['ms'][0]:.1f} / {r['ms'][1]:.1f} ms) "
              f"| {r['old']['nfev']} / "
              f"{r['new']['nfev']} | {r['old']['nevent']} / {r['new']['nevent']} | "
              f"{fmt(f'{e:.1e}' for e in r['old']['errors'])} | "
              f"{fmt(f'{e:.1e}' for e in r['new']['errors'])} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(_main())
