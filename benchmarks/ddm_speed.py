"""Cost of direct differentiation against plain simulation and central differences.

Paper case, the 8 default parameters, 4 revolutions, reported on revolution 4 (721 points,
`t_eval`), with the default integrator of the sensitivity equations (dop853) and with dopri5.
Accuracy = max over parameters of max|S - S_ref| / max|S_ref| of d|F12|/db, with S_ref the
DDM (dopri5) at rtol 1e-11. The plain simulation is `simulate(mech, 4)` (every step
recorded), and also with the same 721 output times as the DDM run (`t_eval`: both land on
them); the default call `sensitivities(mech)` (every step, no t_eval) is timed too. Medians
over repeats after warm-up, in one run.

The headline (the target: DDM of the 8 default parameters at most 4 plain
simulations) comes first: `sensitivities(mech)` against `simulate(mech, 4)`, the median of
the per-pair ratios over alternating pairs in this process (`common.paired`), with the
function evaluations of both and the column work of one sensitivity right-hand side
(`linkage_ddm.tangent_work`). `--headline` prints only that.

At equal accuracy (also in the headline): the plain default run's own error of |F12| over
revolution 4 (max difference from the run at rtol 1e-11 on 721 points, of the max) and the
loosest DDM rtol (dop853; 1e-5, 3e-6, 1e-6, 1e-7) whose error of d|F12|/db (against DDM at
rtol 1e-11, of the max) is not larger; that DDM call against `simulate(mech, 4)`, again
as the median of alternating pairs.

    python -m benchmarks.ddm_speed [--repeats 5] [--pairs 11] [--headline]
"""

from __future__ import annotations

import argparse

import numpy as np

from mbs_clearance import SliderCrank, simulate
from mbs_clearance.analysis.sensitivity import sensitivities
from mbs_clearance.solve.reduced import DEFAULT_RTOL
from validation.timing import machine_summary, paired, timed


def error(s, ref):
    return max(np.max(np.abs(s.base_force_magnitude[:, k] - ref.base_force_magnitude[:, k]))
               / np.max(np.abs(ref.base_force_magnitude[:, k]))
               for k in range(len(ref.parameters)))


def headline(mech, pairs):
    """DDM of the default parameters / plain simulation: paired time ratio, nfev, work."""
    from mbs_clearance.analysis.sensitivity import DEFAULT_PARAMETERS, field_directions_of
    from mbs_clearance.model.cases import door
    from mbs_clearance.solve import linkage_ddm
    from mbs_clearance.solve.linkage_ddm import tangent_work
    from mbs_clearance.solve.settings import RunSettings

    plain = simulate(mech, 4)
    ddm = sensitivities(mech)
    res = paired(lambda: simulate(mech, 4), lambda: sensitivities(mech), pairs)
    entry = door(mech)
    run = linkage_ddm.ddm_run(linkage_ddm.prepare_sensitivity(
        entry.linkage, DEFAULT_PARAMETERS, 1, RunSettings(method=linkage_ddm.DDM_INTEGRATOR),
        directions=field_directions_of(entry.paper, DEFAULT_PARAMETERS)))
    work = tangent_work(run.model, run.p)
    print(f"Machine: {machine_summary()}\n")
    print(f"DDM of the {len(DEFAULT_PARAMETERS)} default parameters "
          f"({work['directions']} integrated directions) / simulate(mech, 4): "
          f"{res['ratio']:.2f} (median of {pairs} alternating pairs; target <= 4); "
          f"nfev {ddm.stats['nfev']} / {plain.stats['nfev']} = "
          f"{ddm.stats['nfev'] / plain.stats['nfev']:.2f}; per right-hand side: "
          f"{work['directions']} directions x {work['state_columns']} state columns + "
          f"{work['parameter_pairs']} (direction, parameter column) pairs "
          f"(the full Jacobian: {work['jacobian_columns']} columns)")
    rtol, err, plain_err = equal_accuracy_rtol(mech)
    if rtol is None:
        print(f"At the plain run's accuracy ({plain_err:.1e}): no DDM rtol tried is as "
              f"accurate\n")
        return
    eq = paired(lambda: simulate(mech, 4), lambda: sensitivities(mech, rtol=rtol), pairs)
    print(f"At the plain default run's accuracy (its |F12| over revolution 4: {plain_err:.1e} "
          f"of the max): DDM at rtol {rtol:g} ({err:.1e}) / simulate(mech, 4): "
          f"{eq['ratio']:.2f} (median of {pairs} alternating pairs)\n")


def equal_accuracy_rtol(mech, rtols=(1e-5, 3e-6, 1e-6, 1e-7)):
    """(the loosest DDM rtol whose d|F12|/db error is at most the plain default run's |F12|
    error, that error, the plain error) over revolution 4; rtol None if none is."""
    T = mech.period
    t_eval = np.linspace(3 * T, 4 * T, 721)
    fine = simulate(mech, 4, t_eval=t_eval, rtol=1e-11).base_force_magnitude
    plain_err = (np.max(np.abs(simulate(mech, 4, t_eval=t_eval).base_force_magnitude - fine))
                 / np.max(fine))
    ref = sensitivities(mech, t_eval=t_eval, rtol=1e-11)
    for rtol in rtols:
        err = error(sensitivities(mech, t_eval=t_eval, rtol=rtol), ref)
        if err <= plain_err:
            return rtol, err, plain_err
    return None, None, plain_err


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--pairs", type=int, default=11)
    ap.add_argument("--headline", action="store_true")
    args = ap.parse_args(argv)
    mech = SliderCrank()
    headline(mech, args.pairs)
    if args.headline:
        return
    T = mech.period
    t_eval = np.linspace(3 * T, 4 * T, 721)
    ref = sensitivities(mech, t_eval=t_eval, rtol=1e-11, integrator="dopri5")
    rows = []
    simulate(mech, 4)
    simulate(mech, 4, t_eval=t_eval)
    t_default = timed(lambda: simulate(mech, 4), 4 * args.repeats)[0]
    t_default_te = timed(lambda: simulate(mech, 4, t_eval=t_eval), 4 * args.repeats)[0]
    for method in ("dop853", "dopri5"):
        for rtol in (1e-5, 3e-6, 1e-6, 1e-7, 1e-8, 1e-9):
            sensitivities(mech, t_eval=t_eval, rtol=rtol, integrator=method)
            simulate(mech, 4, rtol=rtol)
            t_ddm, s = timed(
                lambda r=rtol, m=method: sensitivities(mech, t_eval=t_eval, rtol=r,
                                                       integrator=m), args.repeats)
            t_sim, _ = timed(lambda r=rtol: simulate(mech, 4, rtol=r), args.repeats)
            rows.append((f"DDM {method}", rtol, error(s, ref), t_ddm, t_ddm / t_sim,
                         s.stats["naccept"], t_ddm / t_default, t_ddm / t_default_te))
    # the default call: every step recorded (no t_eval), against simulate(mech, 4)
    sensitivities(mech)
    t_all, s_all = timed(lambda: sensitivities(mech), args.repeats)
    all_row = ("DDM dop853, every step (default call)", DEFAULT_RTOL, None, t_all,
               t_all / t_default, s_all.stats["naccept"], t_all / t_default, None)
    fd_rows = []
    for rtol in (1e-9, 1e-11):
        t_fd, s = timed(
            lambda r=rtol: sensitivities(mech, method="fd", t_eval=t_eval, rtol=r),
            max(1, args.repeats // 2))
        t_sim, _ = timed(lambda r=rtol: simulate(mech, 4, rtol=r), args.repeats)
        fd_rows.append(("FD (17 runs)", rtol, error(s, ref), t_fd, t_fd / t_sim, None,
                        t_fd / t_default, t_fd / t_default_te))
    print(f"Machine: {machine_summary()}\n")
    print(f"One plain simulation at the default rtol {DEFAULT_RTOL:g}: {t_default * 1e3:.2f} ms "
          f"(every step), {t_default_te * 1e3:.2f} ms (landing on the 721 output times)\n")
    print("| method | rtol | max rel. error of d\\|F12\\|/db | median time (ms) "
          "| x plain simulation at same rtol | x plain simulation at default rtol "
          "| x plain simulation at default rtol, same output times | steps |")
    print("|---|---|---|---|---|---|---|---|")
    for name, rtol, err, t, ratio, steps, ratio_default, ratio_te in rows + [all_row] + fd_rows:
        err_s = "-" if err is None else f"{err:.1e}"
        te_s = "-" if ratio_te is None else f"{ratio_te:.1f}"
        print(f"| {name} | {rtol:g} | {err_s} | {t * 1e3:.1f} | {ratio:.1f} "
              f"| {ratio_default:.1f} | {te_s} | {steps or '-'} |")
    print()
    for _, f_rtol, f_err, f_t, *_ in fd_rows:
        # the cheapest default-method DDM run at least as accurate as this FD run
        ok = [r for r in rows if r[0] == "DDM dop853" and r[2] <= f_err]
        if ok:
            best = min(ok, key=lambda r: r[3])
            print(f"FD at rtol {f_rtol:g} ({f_err:.1e}) vs DDM at rtol {best[1]:g} "
                  f"({best[2]:.1e}): DDM is {f_t / best[3]:.1f} x faster")


if __name__ == "__main__":
    main()
