"""What if the sensitivities were not under error control? (the DDM's cost)

The DDM run controls its step size on the state and on every sensitivity (n_err = 2 N_Q
(1 + directions)). CVODES offers the other choice (`errconS = false`: the step size
from the state alone, the sensitivities integrated along). This experiment replaces n_err
by 2 N_Q in `linkage_ddm._run` (only in this process) and measures, paper case, 8 default
parameters, revolution 4 (721 output times): the function evaluations, the error of
d|F12|/db against DDM at rtol 1e-11 (max over parameters, of the max), and the cost
`sensitivities(mech)` / `simulate(mech, 4)` as the median of alternating pairs.

    python -m benchmarks.ddm_error_control [--pairs 7]
"""

from __future__ import annotations

import argparse

import numpy as np

from mbs_clearance import SliderCrank, simulate
from mbs_clearance.analysis.sensitivity import sensitivities
from mbs_clearance.solve import linkage_ddm
from validation.timing import machine_summary, paired

from .ddm_speed import error


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=7)
    args = ap.parse_args(argv)
    original = linkage_ddm._run
    state_only = {"on": False}

    def run(problem, y0, p, n_err, atol, **kw):
        if state_only["on"]:
            n_err = 2 * problem.model.N_Q
        return original(problem, y0, p, n_err, atol, **kw)

    linkage_ddm._run = run
    mech = SliderCrank()
    t = np.linspace(3 * mech.period, 4 * mech.period, 721)
    ref = sensitivities(mech, t_eval=t, rtol=1e-11)
    print(f"Machine: {machine_summary()}\n")
    print("| step size controlled on | rtol | nfev | error of d\\|F12\\|/db | DDM / plain |")
    print("|---|---|---|---|---|")
    for on in (False, True):
        state_only["on"] = on
        for rtol in (1e-7, 1e-8, 1e-9):
            s = sensitivities(mech, t_eval=t, rtol=rtol)
            cost = ""
            if rtol == 1e-7:
                res = paired(lambda: simulate(mech, 4), lambda: sensitivities(mech), args.pairs)
                cost = f"{res['ratio']:.2f}"
            print(f"| {'the state' if on else 'state and sensitivities'} | {rtol:g} | "
                  f"{s.stats['nfev']} | {error(s, ref):.1e} | {cost} |", flush=True)
    linkage_ddm._run = original


if __name__ == "__main__":
    main()
