"""The four-bar's periodic orbit against its independent references: the measurements of
docs/orbits.md ("The four-bar", the table "Checked" and the paragraph below it).

    python -m validation.four_bar_orbit_checks

The orbit is `periodic_orbit(cases.four_bar(), tol=5e-4)` from its default guess (20
settling revolutions, smoothed), as in tests/unit/test_periodic.py, which asserts bounds on
the same quantities. The references: the regime map's flow (dopri5, rtol 1e-10, from the
centred start), its sections over revolutions 101-150 and 161-200; central differences of
the plain return map at steps 3e-4, 1e-3 and 1e-2 of the scales. Differences are in the
orbit's scaled units (fractions of the clearance; of clearance x speed for rates). Takes
several minutes (the orbit's Newton runs, 200 revolutions of the flow, 24 map runs).
"""

from __future__ import annotations

import math
import time

import numpy as np

from mbs_clearance import periodic_orbit
from mbs_clearance.analysis.periodic import return_map
from mbs_clearance.analysis.poincare import Flow
from mbs_clearance.model import cases

#: Newton's tolerance, above the map's own error (about 1e-4 of the scales)
TOL = 5e-4
#: central-difference steps (fractions of the scales)
STEPS = (3e-4, 1e-3, 1e-2)


def _g(x: float, digits: int = 2) -> str:
    """x to `digits` significant digits, small values as 3e-5 (the page's style)."""
    if x != 0.0 and abs(x) < 0.1:
        m, e = f"{x:.{digits - 1}e}".split("e")
        return f"{m}e{int(e)}"
    return f"{x:.{digits}g}"


def _pair(mu) -> str:
    """The complex pair of largest modulus as "a +- bi"."""
    z = mu[np.argmax(np.abs(mu))]
    return f"{z.real:.3g} +- {abs(z.imag):.2g}i"


def flow_sections(mech, revolutions: int, n2: int, rtol: float = 1e-10) -> np.ndarray:
    """The flow's section state (coordinates and rates) after each of `revolutions`."""
    flow = Flow(mech, rtol=rtol)
    period = 2.0 * math.pi / flow.omega
    out = []
    for k in range(revolutions):
        flow.advance((k + 1) * period)
        out.append(flow.y[:n2].copy())
    return np.array(out)


def central_differences(orbit, h: float) -> np.ndarray:
    """The return map's derivative in the state by central differences of its plain runs
    at steps h of the scales, in the scaled variables of the monodromy matrix."""
    n2 = len(orbit.state)
    S = orbit.scale[:n2]
    F = np.empty((n2, n2))
    for k in range(n2):
        ends = []
        for sign in (1.0, -1.0):
            x = orbit.state.copy()
            x[k] += sign * h * S[k]
            xe, _, _, _ = return_map(orbit.mech, x, orbit.modes, orbit.impact_velocities)
            ends.append(xe / S)
        F[:, k] = (ends[0] - ends[1]) / (2 * h)
    return F


def main() -> None:
    t0 = time.perf_counter()
    mech = cases.four_bar()
    orbit = periodic_orbit(mech, tol=TOL, trajectory=False)
    n2 = len(orbit.state)
    q = n2 // 2
    print(f"orbit: {orbit.stability}, residual {_g(orbit.residual)} after "
          f"{orbit.iterations} iterations, multipliers {_pair(orbit.multipliers)} "
          f"(|mu| {np.max(np.abs(orbit.multipliers)):.3f})", flush=True)

    sections = flow_sections(mech, 200, n2)
    S = orbit.scale[:n2]
    for first, last in ((101, 150), (161, 200)):
        kept = sections[first - 1:last]
        diff = np.abs(np.mean(kept, axis=0) - orbit.state) / S
        std = np.std(kept, axis=0) / S
        print(f"flow, revolutions {first}-{last}: mean within {_g(np.max(diff[:q]), 1)} "
              f"(positions) and {_g(np.max(diff[q:]))} (rates) of the orbit; std "
              f"{_g(np.min(std[:q]), 1)} - {_g(np.max(std[:q]), 1)} (positions) and "
              f"{_g(np.min(std[q:]))} - {_g(np.max(std[q:]))} (rates)", flush=True)

    A = orbit.monodromy
    largest = np.max(np.abs(A))
    ratio = np.sum(A[q:] * A[:q]) / np.sum(A[:q] ** 2)
    print(f"monodromy: largest entry {largest:.3g}, rate rows {ratio:.3g} times the "
          f"position rows (least squares)", flush=True)
    for h in STEPS:
        F = central_differences(orbit, h)
        err = np.max(np.abs(F - A)) / largest
        print(f"central differences, steps {_g(h, 1)}: within {_g(err)} of the largest "
              f"entry, eigenvalues {_pair(np.linalg.eigvals(F))}", flush=True)
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
