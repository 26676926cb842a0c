"""Exudyn's step error split into its smooth part and its onsets' impact-velocity part: the
paper case at 2000 rpm, 2 revolutions, at fixed steps, once as is and once with each
registered impact velocity replaced by the reduced model's exact one (the n-th onset gets
the reduced model's n-th; a test run, not a backend option).

Per step: the last onset's registered impact velocity against the reduced model's, and
revolution 2's peak (smoothed reactions, as the accuracy runs read it) against the reduced
model's at rtol 1e-12, as is and with the exact impact velocities; the difference of the
two (the registrations' effect) and that per relative impact-velocity error. Then the
exact-velocity peaks' successive differences' factors and their extrapolation.

    python -m benchmarks.exudyn_onset_error [--steps 0.7 0.35 0.175]   (us)
"""

from __future__ import annotations

import argparse
import math
from unittest import mock

import numpy as np

from mbs_clearance import simulate
from mbs_clearance.backends import exudyn_linkage
from mbs_clearance.backends.exudyn_convergence import smoothed
from mbs_clearance.backends.exudyn_linkage import refined_peaks
from mbs_clearance.model import cases
from mbs_clearance.solve import linkage_model

RPM = 2.0 * math.pi / 60.0


def reference_onsets(linkage) -> tuple[np.ndarray, float]:
    """(the reduced model's impact velocities at its onsets in m/s, revolution 2's peak N)."""
    run = linkage_model.run(linkage, 2, rtol=1e-12, max_steps=50_000_000)
    ms, peaks = run[3], run[4]
    mode, dmin = ms[:, 0], ms[:, 1]
    onsets = np.nonzero(np.diff(mode) > 0)[0] + 1
    return dmin[onsets], float(peaks[1])


def exudyn_run(linkage, step: float, exact=None) -> tuple[float, float]:
    """(the last onset's registered impact velocity m/s, revolution 2's peak N) of Exudyn
    at `step` s; with `exact`, the n-th onset registers exact[n - 1]."""
    registered, count = [], [0]
    original = exudyn_linkage.ImpactMemory.set

    def register(memory, value, t, new_onset=True):
        count[0] += bool(new_onset)
        if exact is not None:
            value = exact[count[0] - 1]
        registered.append(value)
        return original(memory, value, t, new_onset)

    with mock.patch.object(exudyn_linkage.ImpactMemory, "set", register):
        tr = simulate(linkage, 2, backend="exudyn", step_size=step)
    force = smoothed(tr.base_force)
    peaks = refined_peaks(tr.t, np.hypot(force[:, 0], force[:, 1]), linkage.period, 2)
    return float(registered[-1]), float(peaks[1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=float, nargs="*", default=[0.7, 0.35, 0.175],
                    help="Exudyn's fixed steps in us")
    args = ap.parse_args(argv)
    linkage = cases.paper_slider_crank(crank_speed=2000 * RPM)
    exact, ref = reference_onsets(linkage)
    print(f"reduced model: {len(exact)} onsets, the last's impact velocity {exact[-1]:.7g} "
          f"m/s; revolution 2's peak {ref:.4f} N")
    print("| step (us) | last impact velocity | peak 2, as is | peak 2, exact impact "
          "velocities | the onsets' effect | per impact-velocity error |")
    exact_peaks = []
    for h in args.steps:
        v, peak = exudyn_run(linkage, h * 1e-6)
        _, peak_exact = exudyn_run(linkage, h * 1e-6, exact)
        dv, dp, dx = v / exact[-1] - 1, peak / ref - 1, peak_exact / ref - 1
        # the registrations' effect on the peak, and per relative impact-velocity error
        print(f"| {h:g} | {dv:+.2e} | {dp:+.2e} | {dx:+.2e} | {dp - dx:+.2e} | "
              f"{(dp - dx) / dv:.3f} |", flush=True)
        exact_peaks.append(dx)
    print(convergence(exact_peaks))
    return 0


def convergence(peaks) -> str:
    """The exact-velocity peaks' successive differences' factors (second order: 4 per
    halving) and the Richardson extrapolation from the last three (relative errors)."""
    d = -np.diff(np.asarray(peaks, dtype=float))
    if len(d) < 2:
        return "exact impact velocities: too few steps for the differences' factors"
    factors = d[:-1] / d[1:]
    text = ("exact impact velocities: successive differences falling by "
            + ", ".join(f"{f:.2f}" for f in factors))
    if not factors[-1] > 1.0:          # not converging monotonically: no extrapolation
        return text + "; not extrapolated"
    limit = peaks[-1] - d[-1] / (factors[-1] - 1.0)     # 2^p = the last factor
    return text + f"; extrapolated from the last three {limit:+.1e}"


if __name__ == "__main__":
    raise SystemExit(main())
