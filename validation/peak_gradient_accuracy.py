"""Accuracy of `peak_gradient` (DDM at the refined peak) against central differences of the
refined peak at rtol 1e-12, on designs of the GA's box, at one or more DDM tolerances.

Per design: the peak (N) and its time in revolution 4 from the reference; per rtol the
kink / at-edge flags, the gap to the rival maximum, the largest error of the normalized
gradient |S_ddm - S_fd| / max(|S_fd|, 0.1) (the measure of tests/unit/test_objective.py:
a parameter whose normalized value is ~3e-4 has no relative accuracy) and its parameter
(and, over the designs, the largest of every parameter but the journal radius), the peak's
relative error, and the DDM run's function evaluations against the peak-only run's
(`peak_base_force` at its default settings).

    python -m validation.peak_gradient_accuracy [--rtol 1e-7 --rtol 1e-6] [--design L2,L3 ...]
"""

from __future__ import annotations

import argparse

import numpy as np

from mbs_clearance import SliderCrank, peak_gradient
from mbs_clearance.cli import positive_float
from mbs_clearance.solve import reduced

from .timing import machine_summary

#: (L2, L3) in m: the paper's design, the designs of tests/unit/test_objective.py and four
#: more of the GA's box (L2 in [0.04, 0.06], L3 in [0.10, 0.14])
DESIGNS = ((0.05, 0.12), (0.045, 0.11), (0.055, 0.13), (0.045, 0.13), (0.055, 0.11),
           (0.05, 0.13), (0.042, 0.137), (0.04, 0.14), (0.06, 0.10))
#: central differences: relative step 1e-5 of each field at rtol 1e-12 (the tests' reference)
FD_RTOL = 1e-12
FD_STEP = 1e-5


def normalized_error(ddm, fd) -> np.ndarray:
    """|S_ddm - S_fd| / max(|S_fd|, 0.1) per parameter (S: the normalized gradient)."""
    return np.abs(ddm.normalized - fd.normalized) / np.maximum(np.abs(fd.normalized), 0.1)


def design_rows(mech: SliderCrank, rtols) -> tuple[object, list[dict]]:
    """The central-difference reference of `mech` and one row per DDM tolerance."""
    fd = peak_gradient(mech, method="fd", rtol=FD_RTOL, fd_relative_step=FD_STEP)
    nfev_peak = int(reduced.run(mech, 4, record=False).counters[0])
    rows = []
    for rtol in rtols:
        ddm = peak_gradient(mech, rtol=rtol)
        err = normalized_error(ddm, fd)
        k = int(np.argmax(err))
        rows.append(dict(rtol=ddm.stats["rtol"], kink=ddm.kink, at_edge=ddm.at_edge,
                         gap=ddm.gap, error=float(err[k]), worst=ddm.parameters[k],
                         others=max(float(e) for e, n in zip(err, ddm.parameters)
                                    if n != "journal_radius"),
                         peak_error=abs(ddm.peak / fd.peak - 1.0),
                         nfev_ratio=ddm.stats["nfev"] / nfev_peak))
    return fd, rows


def _design(text: str) -> tuple[float, float]:
    try:
        a, b = (positive_float(v) for v in text.split(","))
    except (ValueError, argparse.ArgumentTypeError) as exc:
        raise argparse.ArgumentTypeError(
            f"a design is L2,L3 in m (e.g. 0.05,0.12); got {text!r}: {exc}") from None
    return a, b


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rtol", type=positive_float, action="append",
                    help="DDM tolerance (repeatable; default: peak_gradient's default)")
    ap.add_argument("--design", type=_design, action="append",
                    help="L2,L3 in m (repeatable; default: the nine designs of DESIGNS)")
    args = ap.parse_args(argv)
    rtols = args.rtol or [None]
    designs = args.design or DESIGNS
    print(f"Machine: {machine_summary()}\n")
    print("| L2 (m) | L3 (m) | peak (N) | t* - start of rev. 4 (s) | rtol | kink / at edge "
          "| gap | max error | worst parameter | peak error | nfev / peak-only run's |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    worst = {}
    for L2, L3 in designs:
        mech = SliderCrank().replace(crank_length=L2, coupler_length=L3)
        fd, rows = design_rows(mech, rtols)
        for r in rows:
            print(f"| {L2:g} | {L3:g} | {fd.peak:.1f} | {fd.time - 3 * mech.period:.3e} "
                  f"| {r['rtol']:g} | {r['kink']} / {r['at_edge']} | {r['gap']:.1e} "
                  f"| {r['error']:.1e} | {r['worst']} | {r['peak_error']:.1e} "
                  f"| {r['nfev_ratio']:.2f} |", flush=True)
            w = worst.setdefault(r["rtol"], [0.0, 0.0, 0.0, []])
            w[0] = max(w[0], r["error"])
            w[1] = max(w[1], r["peak_error"])
            w[2] = max(w[2], r["others"])
            w[3].append(r["nfev_ratio"])
    print()
    for rtol, (err, perr, others, nfev) in worst.items():
        print(f"rtol {rtol:g}: worst normalized error {err:.1e}, worst peak error {perr:.1e} "
              f"over {len(designs)} designs")
        print(f"rtol {rtol:g}: every parameter but journal_radius within {others:.1e}; "
              f"nfev / peak-only run's {min(nfev):.2f} to {max(nfev):.2f}")


if __name__ == "__main__":
    main()
