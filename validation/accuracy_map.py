"""The accuracy map: relative error of every per-revolution peak |F12| of the default
`peak_base_force` / `simulate` against rtol 1e-12 runs, over an n x n grid of the GA's design
box (L2 in [0.04, 0.06] m, L3 in [0.10, 0.14] m) and over the stress cases of
`validation/stress.py` that are in a periodic regime.

    python -m validation.accuracy_map [--n 9] [--no-stress] [--before]
"""

from __future__ import annotations

import argparse
from functools import cache

import numpy as np

from mbs_clearance import SliderCrank
from mbs_clearance.solve import reduced
from mbs_clearance.studies.optimize import design_mechanism

#: the GA's default box (optimize.py)
BOX = {"crank_length": (0.04, 0.06), "coupler_length": (0.10, 0.14)}
#: the accuracy target on every per-revolution peak at the default settings
TARGET = 1e-5
REFERENCE_RTOL = 1e-12
REVOLUTIONS = 4
#: stress cases (validation/stress.py) in a periodic regime: their late peaks are well
#: defined (the others are chaotic, and a tolerance change moves them by any amount)
PERIODIC_STRESS = ("paper case", "clearance 0.001 mm", "speed 10000 rpm", "restitution 0.05",
                   "restitution 0.3", "stiffness x0.01", "initial crank angle 90 deg",
                   "initial crank angle 180 deg", "initial crank angle 270 deg",
                   "zero gravity", "journal starts against the wall (+1 c)",
                   "journal starts against the wall (-1 c)", "hunt_crossley law, restitution 0.05",
                   "flores law, restitution 0.05")


def grid_designs(n: int) -> list[tuple[float, float]]:
    """(L2, L3) of the n x n grid of the box, row by row (L2 outer)."""
    return [(float(a), float(b)) for a in np.linspace(*BOX["crank_length"], n)
            for b in np.linspace(*BOX["coupler_length"], n)]


def grid_mechanism(L2: float, L3: float) -> SliderCrank:
    """The paper's mechanism with link lengths L2, L3 (masses fixed, as the GA's default)."""
    return design_mechanism(SliderCrank(), {"crank_length": L2, "coupler_length": L3})


@cache
def reference_peaks(mech: SliderCrank, revolutions: int = REVOLUTIONS,
                    options: tuple = ()) -> np.ndarray:
    """Per-revolution peaks at rtol 1e-12 (cached per process: the references dominate the
    cost of the map)."""
    return reduced.run(mech, revolutions, rtol=REFERENCE_RTOL, record=False,
                       **dict(options)).peaks


def state_error_only() -> dict:
    """The run options of the error control before the penetration was put under it: the
    state's atol only (for before/after comparisons)."""
    return {"event_control": False}


def peak_errors(mech: SliderCrank, revolutions: int = REVOLUTIONS, options: tuple = (),
                before: bool = False, **settings) -> tuple[np.ndarray, dict]:
    """Relative errors of the per-revolution peaks of a run with `settings` (default: the
    defaults of `peak_base_force`; `before`: without the error control of the
    penetration), and the run's counters."""
    ref = reference_peaks(mech, revolutions, options)
    if before:
        settings.update(state_error_only())
    out = reduced.run(mech, revolutions, record=False, **dict(options), **settings)
    return np.abs(out.peaks / ref - 1.0), reduced.counters_dict(out.counters)


def grid_map(n: int = 9, **settings) -> list[dict]:
    """One row per grid design: L2, L3, the per-revolution errors, nfev."""
    rows = []
    for L2, L3 in grid_designs(n):
        err, counters = peak_errors(grid_mechanism(L2, L3), **settings)
        rows.append({"L2": L2, "L3": L3, "errors": err, "nfev": counters["nfev"]})
    return rows


def stress_map(**settings) -> list[dict]:
    """One row per periodic stress case: name, the per-revolution errors, nfev."""
    from .stress import stress_cases

    rows = []
    for case in stress_cases():
        if case.name not in PERIODIC_STRESS:
            continue
        options = tuple(sorted(case.options.items()))
        err, counters = peak_errors(case.mech, case.revolutions, options, **settings)
        rows.append({"case": case.name, "errors": err, "nfev": counters["nfev"]})
    return rows


def markdown_grid(rows: list[dict], n: int) -> str:
    """The grid as a table: worst per-revolution error per design (L3 across, L2 down)."""
    L3s = sorted({r["L3"] for r in rows})
    lines = ["| L2 \\ L3 (cm) | " + " | ".join(f"{100 * b:.1f}" for b in L3s) + " |",
             "|---" * (len(L3s) + 1) + "|"]
    for L2 in sorted({r["L2"] for r in rows}):
        cells = [f"{max(r['errors']):.1e}" for r in rows if r["L2"] == L2]
        lines.append(f"| {100 * L2:.2f} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=9, help="grid points per axis")
    ap.add_argument("--no-stress", action="store_true", help="skip the stress cases")
    ap.add_argument("--rtol", type=float, default=None, help="rtol of the runs measured")
    ap.add_argument("--method", default="dopri5")
    ap.add_argument("--before", action="store_true",
                    help="without the error control of the penetration (state only)")
    args = ap.parse_args(argv)
    settings = {"method": args.method, "before": args.before}
    if args.rtol is not None:
        settings["rtol"] = args.rtol
    rows = grid_map(args.n, **settings)
    worst = max(rows, key=lambda r: max(r["errors"]))
    print(markdown_grid(rows, args.n))
    print(f"\ngrid {args.n} x {args.n}: worst {max(worst['errors']):.2e} at L2 = "
          f"{worst['L2']:.4f}, L3 = {worst['L3']:.4f}; "
          f"{sum(max(r['errors']) > TARGET for r in rows)} designs above {TARGET:g}; "
          f"nfev total {sum(r['nfev'] for r in rows)}")
    if not args.no_stress:
        print("\n| stress case | rev 1 | rev 2 | rev 3 | rev 4 | nfev |\n|---|---|---|---|---|---|")
        for r in stress_map(**settings):
            cells = " | ".join(f"{e:.1e}" for e in r["errors"])
            print(f"| {r['case']} | {cells} | {r['nfev']} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(_main())
