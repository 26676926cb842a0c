"""The lubricated paper case's runs of docs/lubrication.md, as the page's two tables.

    python -m validation.film_runs

1. What the film changes: the paper case, 4 revolutions at 5000 rpm, the default accuracy,
   dry and with the coupler-slider joint in films of five viscosities: the base force's
   peak per revolution, the largest eccentricity ratio and the contact onsets; the ideal
   joint's revolution-4 peak below them.
2. The linearly implicit method: the lubricated case (SAE 30) at fixed tolerances, dopri5
   against rodas4: accepted steps, right-hand side evaluations, the run's time (one run,
   machine-dependent) and the largest relative error of the revolution 2-4 peaks against
   dopri5 at rtol 1e-11.
"""

from __future__ import annotations

import time

import numpy as np

from mbs_clearance import simulate
from mbs_clearance.model import cases

#: (label, viscosity in Pa s; None: the dry joint)
FILMS = [("dry (contact law only)", None), ("film, 1e-7 Pa s", 1e-7),
         ("film, 1e-5 Pa s", 1e-5), ("film, 1 mPa s", 1e-3),
         ("film, SAE 30 at 100 C (9 mPa s)", 9e-3), ("film, 45 mPa s", 45e-3)]
#: (method, rtol) of the fixed-tolerance runs
FIXED = [("dopri5", "1e-7"), ("dopri5", "1e-9"), ("dopri5", "1e-10"),
         ("rodas4", "1e-7"), ("rodas4", "1e-8"), ("rodas4", "1e-9")]


def film_table() -> list[str]:
    """The rows of table 1 (markdown)."""
    rows = ["| joint | rev 1 | rev 2 | rev 3 | rev 4 | largest eccentricity ratio | contacts |",
            "|---|---|---|---|---|---|---|"]
    for label, viscosity in FILMS:
        lk = (cases.paper_slider_crank() if viscosity is None
              else cases.paper_slider_crank_lubricated(viscosity=viscosity))
        run = simulate(lk, 4)
        clearance = lk.clearance_joints[0].bearing_radius - lk.clearance_joints[0].journal_radius
        ratio = np.max(np.hypot(*run.eccentricity.reshape(len(run.t), 2).T)) / clearance
        phase = run.contact_phase[:, 0].astype(int)
        onsets = int(phase[0] + np.sum(np.diff(phase) > 0))
        peaks = " | ".join(f"{p:.1f} N" for p in run.peaks)
        rows.append(f"| {label} | {peaks} | {ratio:.2f} | {onsets} |")
    ideal = simulate(cases.paper_slider_crank(), 4, backend="ideal").peaks[-1]
    rows.append(f"| ideal joint (closed form) | | | | {ideal:.1f} N | | |")
    return rows


def fixed_tolerance_table() -> list[str]:
    """The rows of table 2 (markdown)."""
    lk = cases.paper_slider_crank_lubricated()
    ref = simulate(lk, 4, rtol=1e-11).peaks[1:]
    rows = ["| method | rtol | accepted steps | evaluations | time | peak error |",
            "|---|---|---|---|---|---|"]
    for method, rtol in FIXED:
        t0 = time.perf_counter()
        run = simulate(lk, 4, method=method, rtol=float(rtol))
        seconds = time.perf_counter() - t0
        error = np.max(np.abs(run.peaks[1:] - ref) / ref)
        rows.append(f"| {method} | {rtol} | {run.stats['naccept']} | "
                    f"{run.stats['nfev'] / 1e6:.2f} M | {seconds:.2f} s | {error:.1e} |")
    return rows


def main() -> None:
    print("\n".join(film_table()))
    print()
    print("\n".join(fixed_tolerance_table()))


if __name__ == "__main__":
    main()
