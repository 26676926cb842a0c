"""Cost of `peak_gradient` (DDM at the refined peak) against the peak-only simulation.

The nine designs of `validation.peak_gradient_accuracy` (the paper's and eight more of the
GA's box), the 8 default parameters, revolution 4, default settings (or the DDM run at
`--rtol`): the ratio of the median time of `peak_gradient(mech)` to the median time of
`peak_base_force(mech)` (the GA's objective, nothing recorded), measured in the same run:
the median of the per-repeat ratios over interleaved repeats after warm-up (each ratio under
the same load). Target: at most 4. Also the ratio of function
evaluations (a DDM evaluation costs more than a plain one) and of `sensitivities(mech)` (the
default call, every step) for context.

    python -m benchmarks.peak_gradient_speed [--repeats 21] [--rtol R]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mbs_clearance import SliderCrank, peak_base_force, peak_gradient
from mbs_clearance.analysis.sensitivity import sensitivities
from mbs_clearance.cli import int_at_least, positive_float
from mbs_clearance.solve.reduced import run
from validation.peak_gradient_accuracy import DESIGNS
from validation.timing import machine_summary


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int_at_least(1), default=21)
    ap.add_argument("--rtol", type=positive_float,
                    help="rtol of peak_gradient's DDM run (default: peak_gradient's)")
    args = ap.parse_args(argv)
    rows = []
    for L2, L3 in DESIGNS:
        mech = SliderCrank().replace(crank_length=L2, coupler_length=L3)
        calls = {"peak": lambda m=mech: peak_base_force(m),
                 "grad": lambda m=mech: peak_gradient(m, rtol=args.rtol),
                 "sens": lambda m=mech: sensitivities(m)}
        for fn in calls.values():       # warm-up (caches, allocator)
            fn()
        # interleaved: a change of the machine's load hits all alike
        times = {k: [] for k in calls}
        for _ in range(args.repeats):
            for k, fn in calls.items():
                t0 = time.perf_counter()
                fn()
                times[k].append(time.perf_counter() - t0)
        t_peak, t_grad, t_sens = (float(np.median(times[k])) for k in calls)
        tp = np.asarray(times["peak"])
        r_grad = float(np.median(np.asarray(times["grad"]) / tp))
        r_sens = float(np.median(np.asarray(times["sens"]) / tp))
        g = calls["grad"]()
        nfev_plain = int(run(mech, 4, record=False)[5][0])
        rows.append((f"L2 = {L2 * 100:g} cm, L3 = {L3 * 100:g} cm", t_peak, t_grad, r_grad,
                     r_sens, g.stats["nfev"] / nfev_plain, g.kink, g.stats["rtol"]))
    print(f"Machine: {machine_summary()}\n")
    print("| design | DDM rtol | peak_base_force (ms) | peak_gradient (ms) | ratio (target <= 4) "
          "| sensitivities() / peak_base_force | nfev ratio | kink |")
    print("|---|---|---|---|---|---|---|---|")
    for name, t_peak, t_grad, r_grad, r_sens, nfev_ratio, kink, rtol in rows:
        print(f"| {name} | {rtol:g} | {t_peak * 1e3:.2f} | {t_grad * 1e3:.2f} | {r_grad:.2f} "
              f"| {r_sens:.2f} | {nfev_ratio:.2f} | {kink} |")
    ratios = [r[3] for r in rows]
    print(f"\nratio over the {len(rows)} designs: {min(ratios):.2f} to {max(ratios):.2f} "
          f"(median {float(np.median(ratios)):.2f})")


if __name__ == "__main__":
    main()
