"""The runs of the paper's slider-crank that flag themselves at the default rtol (1e-7),
measured: the error of the worst per-revolution peak |F12| against rtol 1e-12 (as
`validation.accuracy_map`) and what the flag reads (docs/performance.md, "Runs that flag
themselves").

- grazing re-contacts: the two designs of the GA box's 9 x 9 grid that miss 1e-5, the last
  contact onset's impact velocity in units of c omega2 (`reduced.GRAZING_ONSET`), the
  slowest onset of the designs within 1e-5, and the error at rtol 1e-10;
- the journal placed on the far wall (initial offset -1 c) and started 0.1 % of c off it;
- slow settling: clearance 0.05 mm, 2000 rpm, 1000 rpm, and 2000 rpm at rtol 1e-10;
- loose tolerances: the paper case's contact events and 4th revolution's peak (that of
  `peak_base_force`) at rtol 1e-2 and 1e-3, and its error at rtol 1e-4 ... 1e-7.

    python -m validation.accuracy_flags
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from mbs_clearance import SliderCrank
from mbs_clearance._warnings import AccuracyWarning
from mbs_clearance.solve import reduced
from mbs_clearance.solve.diagnostics import onset_velocities

from .accuracy_map import TARGET, grid_designs, grid_mechanism, peak_errors, reference_peaks

RPM = 2.0 * np.pi / 60.0
#: the grazing designs of the 9 x 9 grid (L2, L3 in m)
GRAZING = ((0.045, 0.125), (0.0425, 0.135))


def onset_speeds(mech: SliderCrank, revolutions: int = 4, **options) -> np.ndarray:
    """Impact velocities (m/s) of the contact onsets of the default run, in order (a
    contact present at the start counts as an onset)."""
    return onset_velocities(reduced.run(mech, revolutions, **options).ms)


def worst(mech: SliderCrank, revolutions: int = 4, **settings) -> float:
    """The worst per-revolution peak error of a run with `settings` against rtol 1e-12."""
    options = tuple(sorted((k, v) for k, v in settings.items() if k == "initial_offset"))
    rest = {k: v for k, v in settings.items() if k != "initial_offset"}
    return float(peak_errors(mech, revolutions, options, **rest)[0].max())


def _grazing() -> None:
    for L2, L3 in GRAZING:
        mech = grid_mechanism(L2, L3)
        scale = mech.clearance * mech.crank_speed
        print(f"grazing re-contact, L2 = {100 * L2:g} cm, L3 = {100 * L3:g} cm: error "
              f"{worst(mech):.1e}, last onset {onset_speeds(mech)[-1] / scale:.1f} c omega2; "
              f"at rtol 1e-10 {worst(mech, rtol=1e-10):.1e}")
    slowest = np.inf
    for L2, L3 in grid_designs(9):
        mech = grid_mechanism(L2, L3)
        if worst(mech) <= TARGET:
            slowest = min(slowest, onset_speeds(mech).min()
                          / (mech.clearance * mech.crank_speed))
    print(f"slowest onset of a design within {TARGET:g}: {slowest:.1f} c omega2 "
          f"(flagged below {reduced.GRAZING_ONSET:g})")


def _far_wall() -> None:
    mech = SliderCrank()
    near = -0.999
    print(f"journal on the far wall (-1 c): error {worst(mech, initial_offset=-1.0):.1e}; "
          f"started 0.1 % of c off it: lands at {onset_speeds(mech, initial_offset=near)[0]:.2f}"
          f" m/s, error {worst(mech, initial_offset=near):.1e}")


def _settling() -> None:
    cases = {"clearance 0.05 mm": SliderCrank(journal_radius=0.01 - 5e-5),
             "2000 rpm": SliderCrank(crank_speed=2000 * RPM),
             "1000 rpm": SliderCrank(crank_speed=1000 * RPM)}
    print("slow settling: " + ", ".join(f"{name} {worst(mech):.1e}"
                                        for name, mech in cases.items())
          + f"; 2000 rpm at rtol 1e-10 {worst(cases['2000 rpm'], rtol=1e-10):.1e}")


def _loose() -> None:
    mech = SliderCrank()
    ref = reference_peaks(mech)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)       # what is measured here
        out = {rtol: reduced.run(mech, 4, rtol=rtol, record=False) for rtol in (1e-2, 1e-3)}
        default = reduced.run(mech, 4, record=False)
        errs = [worst(mech, rtol=r) for r in (1e-4, 1e-5, 3e-6, 1e-6, 1e-7)]

    def events(o):
        return reduced.counters_dict(o.counters)["nevent"]

    print(f"rtol 1e-2: {events(out[1e-2])} contact events ({events(default)} at the default), "
          f"the 4th revolution's peak {out[1e-2].peaks[3] / ref[3]:.0f} times the reference; "
          f"rtol 1e-3: {100 * abs(out[1e-3].peaks[3] / ref[3] - 1):.0f} % off")
    print("error at rtol 1e-4, 1e-5, 3e-6, 1e-6, 1e-7: " + ", ".join(f"{e:.1e}" for e in errs))


def main(argv=None) -> int:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args(argv)
    _grazing()
    _far_wall()
    _settling()
    _loose()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
