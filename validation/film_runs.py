"""The lubricated paper case's runs of docs/lubrication.md, as the page's two tables.

    python -m validation.film_runs

1. What the film changes: the paper case, 4 revolutions at 5000 rpm, the default accuracy,
   dry and with the coupler-slider joint in films of five viscosities: the base force's
   peak per revolution, the largest eccentricity ratio and the contact onsets; the ideal
   joint's revolution-4 peak below them. Then the oils' revolution-4 peaks against the
   ideal joint's and the thinnest film's peaks against the dry joint's.
2. The linearly implicit method: the lubricated case (SAE 30) at fixed tolerances, dopri5
   against rodas4: accepted steps, right-hand side evaluations, the run's time (one run,
   machine-dependent) and the largest relative error of the revolution 2-4 peaks against
   dopri5 at rtol 1e-11.
3. The film in Exudyn: the lubricated case at 6000, 12000 and 24000 steps a revolution
   against the reduced model at rtol 1e-10, two revolutions (the peaks, the RMS of the
   eccentricity ratio over revolution 2) and the largest relative difference of either
   between successive steps.
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


def film_table(peaks: dict | None = None) -> list[str]:
    """The rows of table 1 (markdown); `peaks` (if given) receives each row's peaks (N),
    contact onsets and thinnest film (m) by label, the ideal joint's revolution-4 peak under
    "ideal"."""
    peaks = {} if peaks is None else peaks
    rows = ["| joint | rev 1 | rev 2 | rev 3 | rev 4 | largest eccentricity ratio | contacts |",
            "|---|---|---|---|---|---|---|"]
    for label, viscosity in FILMS:
        lk = (cases.paper_slider_crank() if viscosity is None
              else cases.paper_slider_crank_lubricated(viscosity=viscosity))
        run = simulate(lk, 4)
        e = run.eccentricity.reshape(len(run.t), 2)
        ratio = np.max(np.hypot(e[:, 0], e[:, 1])) / lk.clearance_joints[0].clearance
        phase = run.contact_phase[:, 0].astype(int)
        onsets = int(phase[0] + np.sum(np.diff(phase) > 0))
        c = lk.clearance_joints[0].clearance
        peaks[label] = (np.asarray(run.peaks), onsets, c * (1.0 - ratio))
        cells = " | ".join(f"{p:.1f} N" for p in run.peaks)
        rows.append(f"| {label} | {cells} | {ratio:.2f} | {onsets} |")
    ideal = simulate(cases.paper_slider_crank(), 4, backend="ideal").peaks[-1]
    peaks["ideal"] = ideal
    rows.append(f"| ideal joint (closed form) | | | | {ideal:.1f} N | | |")
    return rows


def film_summary(peaks: dict) -> list[str]:
    """What table 1 shows, as relative differences of the peaks: the oils' revolution-4
    peak against the ideal joint's and their thinnest film, the thinnest film's peaks against
    the dry joint's."""
    ideal = peaks["ideal"]
    oils = [label for label, _ in FILMS[-2:]]
    thin, dry = peaks[FILMS[1][0]], peaks[FILMS[0][0]]
    rel = np.abs(thin[0] / dry[0] - 1.0)
    return ["oils against the ideal joint, revolution 4: "
            + ", ".join(f"{label} {abs(peaks[label][0][-1] / ideal - 1.0):.1e}"
                        for label in oils),
            "oils' thinnest film: " + ", ".join(f"{label} {peaks[label][2] * 1e6:.1f} um"
                                                for label in oils),
            f"{FILMS[1][0]} against the dry joint: revolution 1 {rel[0]:.1e}, revolutions "
            f"2-4 within {np.max(rel[1:]):.1e}; contact onsets {thin[1]} and {dry[1]}"]


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


def _orbit_rms(run, t0, t1, clearance) -> float:
    """RMS of the eccentricity ratio |e| / c over [t0, t1] (trapezoids on the samples)."""
    keep = (run.t >= t0) & (run.t <= t1)
    e = run.eccentricity.reshape(len(run.t), 2)[keep]
    r2 = (e[:, 0] ** 2 + e[:, 1] ** 2) / clearance**2
    return float(np.sqrt(np.trapezoid(r2, run.t[keep]) / (run.t[keep][-1] - run.t[keep][0])))


def exudyn_film() -> list[str]:
    """The lubricated case (SAE 30) in Exudyn at 6000, 12000 and 24000 steps a revolution
    against the reduced model at rtol 1e-10, two revolutions: the peaks and the orbit's RMS
    eccentricity ratio over revolution 2."""
    from mbs_clearance.backends.exudyn_linkage import simulate_exudyn_linkage

    lk = cases.paper_slider_crank_lubricated()
    c, T = lk.clearance_joints[0].clearance, lk.period
    ref = simulate(lk, 2, rtol=1e-10)
    runs = [simulate_exudyn_linkage(lk, 2, steps_per_revolution=n) for n in (6000, 12000, 24000)]
    peak2 = [r.peaks[1] for r in runs]
    rms2 = [_orbit_rms(r, T, 2 * T, c) for r in runs]

    def step_to_step(v):
        return max(abs(b - a) for a, b in zip(v, v[1:])) / abs(v[-1])

    return [f"exudyn film, peak rev 1: {', '.join(f'{r.peaks[0]:.1f}' for r in runs)} N; "
            f"reduced {ref.peaks[0]:.2f} N",
            f"exudyn film, peak rev 2: {', '.join(f'{r.peaks[1]:.3f}' for r in runs)} N; "
            f"reduced {ref.peaks[1]:.2f} N",
            f"exudyn film, RMS eccentricity ratio rev 2: "
            f"{', '.join(f'{v:.6f}' for v in rms2)}; "
            f"reduced {_orbit_rms(ref, T, 2 * T, c):.6f}",
            f"exudyn film, rev 2, largest difference between successive steps: peak "
            f"{step_to_step(peak2):.0e}, RMS eccentricity ratio {step_to_step(rms2):.0e} of "
            f"the value"]


def main() -> None:
    peaks: dict = {}
    print("\n".join(film_table(peaks)))
    print()
    print("\n".join(film_summary(peaks)))
    print()
    print("\n".join(fixed_tolerance_table()))
    print()
    print("\n".join(exudyn_film()))


if __name__ == "__main__":
    main()
