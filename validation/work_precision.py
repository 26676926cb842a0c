"""Work-precision: run time against error for every backend and integrator, in one run.

Cases: the paper's (c = 0.01 mm, periodic; errors over revolution 4) and c = 0.1 mm (not
periodic: trajectories at different tolerances diverge after the first revolution, so its
errors are measured over revolution 1, the first impacts).

Reference: the reduced model at rtol 1e-12, checked against scipy DOP853 at rtol 1e-12.
Error measures: relative error of the peak |F12| of the measured revolution, and the max
error of the base force vector over that revolution on a 721-point grid divided by the peak.
Timing: median over repeats after warm-up (full trajectory runs, `simulate`).

    python -m validation.work_precision [--quick] [--out results/]
    mbs-clearance bench [--quick] [--out results/]
"""

from __future__ import annotations

import json
import math
import time
import warnings
from functools import partial
from pathlib import Path

import numpy as np

from mbs_clearance import SliderCrank, simulate
from mbs_clearance._warnings import AccuracyWarning
from mbs_clearance.solve import reduced

from .scipy_reference import solve_scipy
from .timing import machine_summary, timed

CASES = {
    "paper (c = 0.01 mm)": (SliderCrank(), 4),
    "c = 0.1 mm": (SliderCrank(journal_radius=0.0099), 1),
}


def _grid(mech, rev, n=721):
    return np.linspace((rev - 1) * mech.period, rev * mech.period, n)


def _reference(mech, rev):
    grid = _grid(mech, rev)
    traj = simulate(mech, rev, rtol=1e-12, t_eval=grid)
    peak = simulate(mech, rev, rtol=1e-12).max_base_force(rev)
    scipy_peak = solve_scipy(mech, revolutions=rev, rtol=1e-12).peaks[rev - 1]
    return grid, traj.base_force, peak, abs(scipy_peak / peak - 1)


def _errors(force, peak, ref_force, ref_peak):
    return (abs(peak / ref_peak - 1),
            float(np.max(np.hypot(*(force - ref_force).T)) / ref_peak))


def _scipy_force(res, grid):
    model = reduced.MODEL
    out = np.empty((len(grid), 2))
    for i, t in enumerate(grid):
        y, p = res.state(t)
        o = model.outputs(np.array([t]), np.ascontiguousarray(y)[None, :],
                          np.ascontiguousarray(p[model.MEM_START:model.MEM_START + 2])[None, :],
                          p)[0]
        out[i] = o[model.MONITOR_COLUMN], o[model.MONITOR_COLUMN + 1]
    return out


def run(quick: bool = False, repeats: int = 5, exudyn: bool = True):
    """All rows: case, backend, method, setting, time (s), peak error, series error."""
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"repeats must be an integer >= 1; got {repeats!r}")
    rows = []
    refs = {}
    for case, (mech, rev) in CASES.items():
        grid, ref_force, ref_peak, scipy_check = _reference(mech, rev)
        refs[case] = {"peak": ref_peak, "scipy_dop853_rel_diff": scipy_check}
        ours = {"dopri5": (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11),
                "dop853": (1e-6, 1e-7, 1e-8, 1e-9, 1e-10),
                "bs3": (1e-4, 1e-5, 1e-6, 1e-7, 1e-8)}
        scipy_methods = {"DOP853": (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11),
                         "LSODA": (1e-6, 1e-7, 1e-8, 1e-9, 1e-10),
                         "Radau": (1e-5, 1e-6, 1e-7)}
        steps = [mech.period / (720 * k) for k in (2, 4, 8, 16)]
        if quick:
            ours = {"dopri5": (1e-6, 1e-9)}
            scipy_methods = {"DOP853": (1e-9,)}
            steps = steps[1:2]
        for method, rtols in ours.items():
            for rtol in rtols:
                # the errors are measured here against the reference: the runs' own accuracy
                # flags (loose tolerances, the start-up's contacts) are not needed
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", AccuracyWarning)
                    t = timed(partial(simulate, mech, rev, rtol=rtol, method=method), repeats,
                              True)[0]
                    peak = simulate(mech, rev, rtol=rtol, method=method).max_base_force(rev)
                    force = simulate(mech, rev, rtol=rtol, method=method,
                                     t_eval=grid).base_force
                rows.append(dict(case=case, backend="reduced (ours)", method=method,
                                 setting=f"rtol {rtol:g}", time=t,
                                 **dict(zip(("peak_error", "series_error"),
                                            _errors(force, peak, ref_force, ref_peak)))))
        for method, rtols in scipy_methods.items():
            for rtol in rtols:
                t0 = time.perf_counter()
                try:
                    res = solve_scipy(mech, revolutions=rev, method=method, rtol=rtol)
                except RuntimeError as exc:
                    rows.append(dict(case=case, backend="scipy", method=method,
                                     setting=f"rtol {rtol:g}", time=float("nan"),
                                     peak_error=float("nan"), series_error=float("nan"),
                                     note=str(exc)[:80]))
                    continue
                first = time.perf_counter() - t0
                t = first if method != "DOP853" or quick else timed(
                    partial(solve_scipy, mech, revolutions=rev, method=method, rtol=rtol),
                    max(1, repeats // 2), True)[0]
                rows.append(dict(case=case, backend="scipy", method=method,
                                 setting=f"rtol {rtol:g}", time=t,
                                 **dict(zip(("peak_error", "series_error"),
                                            _errors(_scipy_force(res, grid),
                                                    res.peaks[rev - 1], ref_force,
                                                    ref_peak)))))
        if not exudyn:
            continue
        # the Python user force computes the same force as the symbolic one (it differs only
        # in speed), so it gets the two middle step sizes
        variants = {"symbolic": steps, "sphere": steps, "python": steps[1:3]}
        if quick:
            variants = {"symbolic": steps}
        for variant, variant_steps in variants.items():
            for h in variant_steps:
                t = timed(partial(simulate, mech, rev, backend="exudyn", step_size=h,
                                  contact=variant), max(1, repeats // 2), True)[0]
                traj = simulate(mech, rev, backend="exudyn", step_size=h, contact=variant)
                force = np.column_stack([np.interp(grid, traj.t, traj.base_force[:, j])
                                         for j in range(2)])
                rows.append(dict(case=case, backend="exudyn", method=variant,
                                 setting=f"h {h:.3g} s", time=t,
                                 **dict(zip(("peak_error", "series_error"),
                                            _errors(force, traj.max_base_force(rev),
                                                    ref_force, ref_peak)))))
    return rows, refs


def speed_ratios(rows, case, target=1e-6):
    """Time of each (backend, method) at its fastest setting whose peak error AND series
    error are <= target, and its ratio to ours (dopri5). Both measures, because a run can hit
    the peak and still miss contacts elsewhere (scipy at loose tolerances does)."""
    best = {}
    for r in rows:
        if r["case"] != case or not (max(r["peak_error"], r["series_error"]) <= target):
            continue
        key = (r["backend"], r["method"])
        if key not in best or r["time"] < best[key]["time"]:
            best[key] = r
    ours = best.get(("reduced (ours)", "dopri5"))
    out = []
    for key, r in best.items():
        out.append(dict(backend=key[0], method=key[1], setting=r["setting"], time=r["time"],
                        ratio=(r["time"] / ours["time"]) if ours else float("nan")))
    return sorted(out, key=lambda d: d["time"])


#: the columns of `target_table` after ours (dopri5): (backend, method, heading)
TARGET_COLUMNS = (("reduced (ours)", "dop853", "ours (dop853)"), ("scipy", "LSODA", "scipy LSODA"),
                  ("scipy", "DOP853", "scipy DOP853"), ("scipy", "Radau", "scipy Radau"),
                  ("exudyn", "sphere", "Exudyn sphere"),
                  ("exudyn", "symbolic", "Exudyn symbolic"), ("exudyn", "python", "Exudyn python"))
TARGETS = (1e-2, 1e-3, 1e-5)


def target_table(rows, case) -> str:
    """Markdown table: per target, our time (dopri5) and each method's time relative to it,
    at each one's fastest setting within the target (`speed_ratios`)."""
    out = ["| target | ours (dopri5) | " + " | ".join(c[2] for c in TARGET_COLUMNS) + " |",
           "|---" * (len(TARGET_COLUMNS) + 2) + "|"]
    for target in TARGETS:
        best = {(s["backend"], s["method"]): s for s in speed_ratios(rows, case, target)}
        ours = best.get(("reduced (ours)", "dopri5"))
        # without a run of ours within the target there is no ratio: the others' times
        cells = [f"{ours['time'] * 1e3:.1f} ms ({ours['setting']})" if ours else "not reached"]
        for backend, method, _ in TARGET_COLUMNS:
            s = best.get((backend, method))
            cells.append("-" if not s else f"{s['ratio']:.1f} x" if ours
                         else f"{s['time'] * 1e3:.1f} ms")
        out.append(f"| {target:g} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def markdown(rows, refs) -> str:
    lines = []
    for case in CASES:
        lines.append(f"\n### {case}: reference peak {refs[case]['peak']:.6f} N "
                     f"(scipy DOP853 at 1e-12 differs by "
                     f"{refs[case]['scipy_dop853_rel_diff']:.1e})\n")
        lines.append("| backend | method | setting | median time (ms) | peak rel. error "
                     "| max series error / peak |")
        lines.append("|---|---|---|---|---|---|")
        for r in rows:
            if r["case"] == case:
                lines.append(f"| {r['backend']} | {r['method']} | {r['setting']} | "
                             f"{r['time'] * 1e3:.1f} | {r['peak_error']:.1e} | "
                             f"{r['series_error']:.1e} |")
        for target in TARGETS:
            lines.append(f"\nAt peak and series errors <= {target:g}:")
            for s in speed_ratios(rows, case, target):
                ratio = ("; ours (dopri5): not reached" if math.isnan(s["ratio"])
                         else f" = {s['ratio']:.1f} x ours")
                lines.append(f"- {s['backend']} {s['method']} ({s['setting']}): "
                             f"{s['time'] * 1e3:.1f} ms{ratio}")
        lines.append("\nFastest setting of each method within each target, relative to ours:\n")
        lines.append(target_table(rows, case))
    return "\n".join(lines)


def check_repeats(repeats: int, quick: bool) -> int:
    """Refuse, before any run, --repeats whose timed runs of the reduced model alone (each
    setting `repeats` times, at least 8 steps per revolution) exceed the work of one
    command, `cli.MAX_COMMAND_STEPS` steps; returns that lower bound of the steps."""
    from mbs_clearance._checks import check_steps
    from mbs_clearance.cli import MAX_COMMAND_STEPS

    settings = 2 if quick else 17             # the reduced model's rtols in `run`
    revolutions = sum(rev for _, rev in CASES.values())
    return check_steps(f"--repeats {repeats}: {repeats} timed runs of each of {settings} "
                       f"settings over {revolutions} revolutions", 8 * repeats * settings
                       * revolutions, MAX_COMMAND_STEPS, "give fewer --repeats")


def main(args) -> int:
    from mbs_clearance._io import OutputDir, check_output_dir

    if args.out:
        check_output_dir(args.out, "--out", args.force)
    check_repeats(args.repeats, args.quick)
    rows, refs = run(quick=args.quick, repeats=args.repeats, exudyn=not args.no_exudyn)
    text = f"Machine: {machine_summary()}\n" + markdown(rows, refs)
    print(text)
    if args.out:
        from mbs_clearance.plotting import plot_work_precision

        with OutputDir(args.out, "bench") as staged:
            out = staged.path
            (out / "work_precision.json").write_text(json.dumps(
                {"rows": rows, "references": refs, "machine": machine_summary()}, indent=1))
            (out / "work_precision.md").write_text(text)
            plot_work_precision(rows, path=out / "work_precision.png")
            staged.commit()
        print(f"\nwritten to {args.out}/work_precision.(json|md|png)")
    return 0


def add_arguments(p):
    from mbs_clearance.cli import add_force_option, int_at_least

    p.add_argument("--quick", action="store_true", help="a few settings only")
    p.add_argument("--repeats", type=int_at_least(1), default=5,
                   help="timed runs per setting (median; >= 1, default 5)")
    p.add_argument("--no-exudyn", action="store_true",
                   help="leave out the Exudyn backend's rows (the reduced model's and scipy's "
                        "integrators only)")
    p.add_argument("--out", type=Path, help="folder for work_precision.json/.md/.png")
    add_force_option(p)


if __name__ == "__main__":
    from .commands import bench

    bench.run_script()
