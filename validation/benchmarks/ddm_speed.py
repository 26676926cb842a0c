"""Cost of direct differentiation against plain simulation and central differences.

Paper case, the 8 default parameters, 4 revolutions, reported on revolution 4 (721 points).
Accuracy = max over parameters of max|S - S_ref| / max|S_ref| of d|F12|/db, with S_ref the
DDM at rtol 1e-11. Medians over repeats after warm-up, in one run.

    python -m validation.benchmarks.ddm_speed [--repeats 5]
"""

from __future__ import annotations

import argparse

import numpy as np

from mbs_clearance import SliderCrank, simulate
from mbs_clearance.sensitivity import sensitivities
from validation.benchmarks.common import machine_summary, timed


def error(s, ref):
    return max(np.max(np.abs(s.base_force_magnitude[:, k] - ref.base_force_magnitude[:, k]))
               / np.max(np.abs(ref.base_force_magnitude[:, k]))
               for k in range(len(ref.parameters)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    mech = SliderCrank()
    T = mech.period
    t_eval = np.linspace(3 * T, 4 * T, 721)
    ref = sensitivities(mech, t_eval=t_eval, rtol=1e-11)
    rows = []
    for rtol in (1e-7, 1e-8, 1e-9):
        sensitivities(mech, t_eval=t_eval, rtol=rtol)
        simulate(mech, 4, rtol=rtol)
        t_ddm, s = timed(lambda r=rtol: sensitivities(mech, t_eval=t_eval, rtol=r),
                               args.repeats)
        t_sim, _ = timed(lambda r=rtol: simulate(mech, 4, rtol=r), args.repeats)
        rows.append(("DDM", rtol, error(s, ref), t_ddm, t_ddm / t_sim, s.stats["naccept"]))
    fd_rows = []
    for rtol in (1e-9, 1e-11):
        t_fd, s = timed(
            lambda r=rtol: sensitivities(mech, method="fd", t_eval=t_eval, rtol=r),
            max(1, args.repeats // 2))
        t_sim, _ = timed(lambda r=rtol: simulate(mech, 4, rtol=r), args.repeats)
        fd_rows.append(("FD (17 runs)", rtol, error(s, ref), t_fd, t_fd / t_sim, None))
    print(f"Machine: {machine_summary()}\n")
    print("| method | rtol | max rel. error of d\\|F12\\|/db | median time (s) "
          "| x plain simulation at same rtol | steps |")
    print("|---|---|---|---|---|---|")
    for name, rtol, err, t, ratio, steps in rows + fd_rows:
        print(f"| {name} | {rtol:g} | {err:.1e} | {t:.3f} | {ratio:.1f} | {steps or '-'} |")
    best_fd = min(fd_rows, key=lambda r: r[2])
    for _, rtol, err, t, *_ in rows:
        if err <= best_fd[2] * 1.5:
            print(f"\nDDM at rtol {rtol:g} ({err:.1e}) vs FD at rtol {best_fd[1]:g} "
                  f"({best_fd[2]:.1e}): DDM is {best_fd[3] / t:.1f} x faster")
            break


if __name__ == "__main__":
    main()
