"""Another integrator setting against the default (dopri5, rtol 1e-7): time and accuracy.

Whether DOP853 at a loose rtol, which wins the 4th revolution's peak against
scipy (docs/performance.md, "Per named case"), could be the default: it must hold the
accuracy map (every per-revolution peak within 1e-5 over the GA's box and the periodic
stress cases, `validation.accuracy_map`) and be faster. Timed here, as medians of the
per-pair ratios of alternating pairs in one process (`common.paired`): the paper case's
peak-only run and `simulate` (4 revolutions), and the 9 x 9 grid of the GA's box in total
(peak only); with the function evaluations and the worst per-revolution error of the grid
and of the paper case against rtol 1e-12.

    python -m benchmarks.method_cost [--method dop853] [--rtol 3e-6] [--pairs 11]
"""

from __future__ import annotations

import argparse

from mbs_clearance import SliderCrank, peak_base_force, simulate
from mbs_clearance.solve import reduced
from validation import accuracy_map as am
from validation.timing import machine_summary, paired


def _grid(n: int, **settings) -> None:
    for L2, L3 in am.grid_designs(n):
        reduced.run(am.grid_mechanism(L2, L3), 4, record=False, **settings)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="dop853")
    ap.add_argument("--rtol", type=float, default=3e-6)
    ap.add_argument("--pairs", type=int, default=11)
    ap.add_argument("--n", type=int, default=9, help="grid points per axis")
    args = ap.parse_args(argv)
    mech = SliderCrank()
    other = {"method": args.method, "rtol": args.rtol}
    for kw in ({}, other):                      # load or compile the kernels
        peak_base_force(mech, 4, **kw)
        simulate(mech, 4, **kw)
    rows = [("paper case, peak only", paired(lambda: peak_base_force(mech, 4),
                                             lambda: peak_base_force(mech, 4, **other),
                                             args.pairs)),
            ("paper case, simulate", paired(lambda: simulate(mech, 4),
                                            lambda: simulate(mech, 4, **other), args.pairs)),
            (f"{args.n} x {args.n} grid, peak only",
             paired(lambda: _grid(args.n), lambda: _grid(args.n, **other),
                    max(3, args.pairs // 4)))]
    default_rows = am.grid_map(args.n)
    other_rows = am.grid_map(args.n, **other)
    paper_default, paper_default_n = am.peak_errors(mech)
    paper_other, paper_other_n = am.peak_errors(mech, **other)
    print(f"Machine: {machine_summary()}\n")
    print(f"{args.method} at rtol {args.rtol:g} against the default (dopri5, rtol "
          f"{reduced.DEFAULT_RTOL:g}); time ratio = other / default, median of alternating "
          f"pairs\n")
    print("| measure | default | other | ratio |")
    print("|---|---|---|---|")
    for label, r in rows:
        print(f"| {label} | {r['a'] * 1e3:.2f} ms | {r['b'] * 1e3:.2f} ms | {r['ratio']:.2f} |")
    for label, d, o in (("grid nfev", sum(r["nfev"] for r in default_rows),
                         sum(r["nfev"] for r in other_rows)),
                        ("paper case nfev", paper_default_n["nfev"], paper_other_n["nfev"])):
        print(f"| {label} | {d} | {o} | {o / d:.2f} |")
    worst_d = [r["errors"].max() for r in default_rows]
    worst_o = [r["errors"].max() for r in other_rows]
    for label, d, o in (("grid: worst per-revolution peak error", max(worst_d), max(worst_o)),
                        ("grid: designs above 1e-5", sum(w > 1e-5 for w in worst_d),
                         sum(w > 1e-5 for w in worst_o)),
                        ("paper case: worst per-revolution peak error", paper_default.max(),
                         paper_other.max())):
        print(f"| {label} | {d:.2g} | {o:.2g} | - |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
