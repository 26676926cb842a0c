"""Run time of plain and DDM runs on the C core against numba's, in alternating pairs.

    python -m benchmarks.core_ab [--pairs 15] [--case NAME ...]

For each case the same run (the same model, tolerances and steps: the two cores give the
same numbers, tests/unit/test_core_oracle.py) is timed on both cores, warm (each compiled
and loaded before timing), in alternating pairs within one process; printed: the median of
the per-pair ratios C / numba of the wall time, and their spread. Cases: the paper's
slider-crank (recorded and peak only), the four-bar, the lubricated case (rodas4), the
translational-clearance benchmark (a free run of 0.05 s) and the paper case's DDM
sensitivities along 8 parameters (4 revolutions, DOP853, the output derivatives recorded).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from mbs_clearance.model import cases
from mbs_clearance.solve import kernels
from mbs_clearance.solve import linkage_model as lm

#: name -> (case, run keywords)
RUNS = {
    "paper, recorded": ("paper_slider_crank", dict(revolutions=4)),
    "paper, peak only": ("paper_slider_crank", dict(revolutions=4, record=False)),
    "four_bar": ("four_bar", dict(revolutions=1)),
    "lubricated (rodas4)": ("paper_slider_crank_lubricated",
                            dict(revolutions=1, method="rodas4")),
    "translational benchmark": ("flores_translational_slider_crank",
                                dict(duration=0.05, window=0.01)),
    "paper DDM, 8 parameters": ("paper_slider_crank", dict(revolutions=4, ddm=(
        "crank.pin.x", "coupler.slider_end.x", "coupler.mass", "slider.mass",
        "coupler_slider.contact_stiffness", "coupler_slider.youngs_modulus",
        "coupler_slider.journal_radius", "coupler_slider.restitution"))),
}


def _timed(core: str, linkage, options: dict) -> tuple[float, float]:
    """(wall time in s, a result to compare: the last peak, or a DDM run's largest
    derivative of the monitored force) of one run on `core`."""
    from mbs_clearance.analysis.sensitivity import sensitivities

    os.environ[kernels.ENV] = core
    options = dict(options)
    names = options.pop("ddm", None)
    t0 = time.perf_counter()
    if names is None:
        value = float(lm.run(linkage, **options).peaks[-1])
    else:
        value = float(np.max(np.abs(sensitivities(linkage, names, **options).base_force)))
    return time.perf_counter() - t0, value


def measure(names, pairs: int) -> dict:
    """Per run: median and range of the per-pair ratios C / numba and each core's median
    time (s)."""
    rows = {}
    for name in names:
        case, options = RUNS[name]
        linkage = cases.CASES[case]()
        peaks = {core: _timed(core, linkage, options)[1] for core in ("numba", "c")}
        if peaks["numba"] != peaks["c"]:
            raise RuntimeError(f"{name}: the cores disagree ({peaks})")
        times = {"numba": [], "c": []}
        for k in range(pairs):
            for core in (("numba", "c") if k % 2 == 0 else ("c", "numba")):
                times[core].append(_timed(core, linkage, options)[0])
        ratio = np.asarray(times["c"]) / np.asarray(times["numba"])
        rows[name] = {"ratio_median": float(np.median(ratio)), "ratio_min": float(ratio.min()),
                      "ratio_max": float(ratio.max()),
                      "numba_s": float(np.median(times["numba"])),
                      "c_s": float(np.median(times["c"]))}
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=15, help="alternating pairs per run")
    parser.add_argument("--run", nargs="+", choices=list(RUNS), default=list(RUNS),
                        help="which runs (default: all)")
    args = parser.parse_args(argv)
    if args.pairs < 1:
        parser.error("--pairs must be >= 1")
    from validation.timing import machine_summary

    rows = measure(args.run, args.pairs)
    print(f"C core / numba, {args.pairs} alternating pairs ({machine_summary()})")
    print(f"{'run':<26} {'numba (ms)':>10} {'C (ms)':>8} {'C / numba':>10} {'range':>13}")
    for name, r in rows.items():
        print(f"{name:<26} {1e3 * r['numba_s']:>10.2f} {1e3 * r['c_s']:>8.2f} "
              f"{r['ratio_median']:>10.3f} {r['ratio_min']:>6.3f}-{r['ratio_max']:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
