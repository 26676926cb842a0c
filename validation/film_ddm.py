"""DDM along the oil film against central differences of plain runs: the measurements of
docs/lubrication.md ("Sensitivities along the film") on which
tests/integration/test_lubricated_case.py asserts its bounds.

    python -m validation.film_ddm [--film short long]

The lubricated paper case (SAE 30), the coordinates at 12 times of the first fifth of a
revolution: DDM at rtol 1e-10 against central differences of plain runs at rtol 1e-12,
relative step 1e-5, along the short film's viscosity, bearing length, journal radius and
the slider's mass, the long film's viscosity and bearing length. Per film: the largest
difference of a series (one coordinate along one parameter) over its largest magnitude,
and the same between the differences at steps 1e-5 and 1e-4 (their own spread).
"""

from __future__ import annotations

import argparse

import numpy as np

#: per film law: the parameters of the comparison (the tests')
NAMES = {
    "short": ("coupler_slider.viscosity", "coupler_slider.bearing_length",
              "coupler_slider.journal_radius", "slider.mass"),
    "long": ("coupler_slider.viscosity", "coupler_slider.bearing_length"),
}


def _largest(a: dict, b: dict, coordinates) -> float:
    """max over coordinates and parameters of max_t |a - b| / max_t |b|."""
    return max(float(np.max(np.max(np.abs(a[c] - b[c]), axis=0)
                            / np.max(np.abs(b[c]), axis=0))) for c in coordinates)


def film_sensitivities(film: str, steps=(1e-5,)):
    """The lubricated paper case with film law `film`, its DDM sensitivities (rtol 1e-10)
    along NAMES[film] at 12 times of the first fifth of a revolution, and central
    differences of plain runs (rtol 1e-12) at each relative step of `steps`:
    (linkage, ddm, {step: differences})."""
    from mbs_clearance import sensitivities
    from mbs_clearance.model import cases

    lk = cases.paper_slider_crank_lubricated(lubrication=film)
    names = NAMES[film]
    t_eval = np.linspace(0.0, 0.2 * lk.period, 13)[1:]
    ddm = sensitivities(lk, names, revolutions=1, t_eval=t_eval, rtol=1e-10)
    fd = {step: sensitivities(lk, names, revolutions=1, method="fd", t_eval=t_eval,
                              rtol=1e-12, fd_relative_step=step) for step in steps}
    return lk, ddm, fd


def film_errors(film: str) -> tuple[float, float]:
    """(DDM against central differences at step 1e-5, the differences at steps 1e-5
    against 1e-4), each the largest over the series, for film law `film`."""
    lk, ddm, fd = film_sensitivities(film, (1e-5, 1e-4))
    coordinates = lk.coordinates()
    return (_largest(ddm.outputs, fd[1e-5].outputs, coordinates),
            _largest(fd[1e-4].outputs, fd[1e-5].outputs, coordinates))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--film", nargs="+", choices=sorted(NAMES), default=["short", "long"])
    args = ap.parse_args(argv)
    for film in args.film:
        error, spread = film_errors(film)
        print(f"{film} film, {len(NAMES[film])} parameters: DDM within {error:.1e} of each "
              f"series' largest magnitude; central differences at steps 1e-5 and 1e-4 "
              f"differ by up to {spread:.1e}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
