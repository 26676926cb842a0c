"""Command line: `mbs-clearance SUBCOMMAND ...`; each subcommand calls a public function."""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

from .integrator import METHODS
from .mechanism import PARAMETER_INFO, SliderCrank
from .optimize import (
    MASS_SCALINGS,
    PAPER_TABLE3,
    connect_dask,
    design_mechanism,
    optimize_link_lengths,
)
from .simulate import BACKENDS, peak_base_force, simulate

__all__ = ["main", "build_parser", "mechanism_from_args", "add_mechanism_options",
           "format_table3"]


def _optional_float(text: str) -> float | None:
    if text.lower() == "none":
        return None
    return float(text)


def add_mechanism_options(parser: argparse.ArgumentParser) -> None:
    """One option per SliderCrank field (--crank-length ...) plus --config FILE.json."""
    group = parser.add_argument_group("mechanism (SI units; defaults: the paper's case)")
    group.add_argument("--config", metavar="FILE.json",
                       help="JSON object of SliderCrank fields; options below override it")
    defaults = SliderCrank()
    for f in dataclasses.fields(SliderCrank):
        symbol, unit, _ = PARAMETER_INFO[f.name]
        default = getattr(defaults, f.name)
        kind = str if f.name == "contact_model" else (
            _optional_float if default is None or f.name.endswith("inertia") else float)
        group.add_argument("--" + f.name.replace("_", "-"), dest=f.name, type=kind,
                           default=None, metavar="X",
                           help=f"{symbol} [{unit}] (default {default})")


def mechanism_from_args(args: argparse.Namespace) -> SliderCrank:
    """SliderCrank from --config and the per-field options (ValueError on bad values)."""
    base = SliderCrank.from_json(args.config) if args.config else SliderCrank()
    changes = {f.name: getattr(args, f.name) for f in dataclasses.fields(SliderCrank)
               if getattr(args, f.name) is not None}
    return base.replace(**changes)


def _cmd_simulate(args: argparse.Namespace) -> int:
    mech = mechanism_from_args(args)
    if args.out and args.out.suffix not in (".csv", ".npz"):
        raise ValueError(f"--out must end in .npz or .csv; got {str(args.out)!r}")
    options = {}
    if args.rtol is not None:
        options["rtol"] = args.rtol
    if args.step_size is not None:
        options["step_size"] = args.step_size
    if args.contact is not None:
        options["contact"] = args.contact
    if args.integrator is not None:
        options["method"] = args.integrator
    print(f"simulating {args.revolutions} revolutions with backend {args.backend!r} ...",
          file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    traj = simulate(mech, args.revolutions, backend=args.backend, **options)
    elapsed = time.perf_counter() - t0
    print(f"done in {elapsed:.3g} s ({len(traj.t)} samples)", file=sys.stderr)
    print(f"{'revolution':>10}  {'max |F12| (N)':>14}  {'max |M2| (N m)':>14}  "
          f"{'max contact force (N)':>22}")
    for k in range(1, traj.revolutions + 1):
        mask = traj.revolution_mask(k)
        print(f"{k:>10}  {traj.max_base_force(k):>14.2f}  "
              f"{abs(traj.crank_moment[mask]).max():>14.3f}  "
              f"{traj.contact_force[mask].max():>22.2f}")
    floored = traj.stats.get("floored_impacts") if traj.stats else None
    if floored:
        print(f"note: {floored} contact onset(s) at the impact-velocity floor (grazing); the "
              f"damping they set is sensitive to the tolerance: compare with a tighter --rtol",
              file=sys.stderr)
    if args.out:
        print(f"trajectory written to {traj.save(args.out)}", file=sys.stderr)
    if args.plot:
        from .plotting import plot_trajectory

        plot_trajectory(traj, path=args.plot)
        print(f"figure written to {args.plot}", file=sys.stderr)
    return 0


def _cmd_sensitivity(args: argparse.Namespace) -> int:
    from .sensitivity import DEFAULT_PARAMETERS, sensitivities

    mech = mechanism_from_args(args)
    names = tuple(args.parameters.split(",")) if args.parameters else DEFAULT_PARAMETERS
    options = {}
    if args.step_size is not None:
        options["step_size"] = args.step_size
    print(f"sensitivities of |F12| to {len(names)} parameters by {args.method} "
          f"({args.backend}), {args.revolutions} revolutions ...", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    sens = sensitivities(mech, names, args.revolutions, method=args.method,
                         backend=args.backend, rtol=args.rtol, integrator=args.integrator,
                         **options)
    print(f"done in {time.perf_counter() - t0:.3g} s", file=sys.stderr)
    print(f"{'parameter':<22} {'b0':>12} {'mean |S|':>10} {'max |S|':>10} {'growth/rev':>10}")
    for row in sens.summary():
        print(f"{row['parameter']:<22} {row['reference']:>12.5g} "
              f"{row['mean_abs_normalized']:>10.4g} {row['max_abs_normalized']:>10.4g} "
              f"{row['growth_per_revolution']:>10.3g}")
    if sens.chaotic:
        print("WARNING: the sensitivities grow from revolution to revolution: the motion is "
              "not periodic (chaotic or transient) and these derivatives are not meaningful; "
              "reduce the clearance or the speed.", file=sys.stderr)
    if args.out:
        from .plotting import SENSITIVITY_FIGURES, plot_sensitivities

        args.out.mkdir(parents=True, exist_ok=True)
        sens.save(args.out / "sensitivities.npz")
        for stem, (title, group) in SENSITIVITY_FIGURES.items():
            group = [g for g in group if g in sens.parameters]
            if group:
                plot_sensitivities(sens, group, title, path=args.out / f"{stem}.png")
        print(f"sensitivities.npz and figures written to {args.out}", file=sys.stderr)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mbs-clearance",
        description="Slider-crank mechanism with a revolute clearance joint: simulate, "
                    "compare models, sensitivities, optimisation, validation report.")
    parser.add_argument("--version", action="version", version="%(prog)s 0.1.0")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("simulate", help="simulate and write the trajectory and a figure",
                       description="Simulate the slider-crank; print the peak per revolution, "
                                   "write the trajectory (csv/npz) and a Fig. 3-like PNG.")
    p.add_argument("--revolutions", type=int, default=4)
    p.add_argument("--backend", choices=sorted(BACKENDS), default="reduced")
    p.add_argument("--rtol", type=float, help="relative tolerance (reduced backend)")
    p.add_argument("--step-size", type=float, help="time step in s (exudyn backend)")
    p.add_argument("--contact", help="contact variant (exudyn backend)")
    p.add_argument("--integrator", choices=sorted(METHODS),
                   help="method of the compiled integrator (reduced backend; default dopri5)")
    p.add_argument("--out", type=Path, help="trajectory file, .csv or .npz")
    p.add_argument("--plot", type=Path, help="figure file, e.g. simulate.png")
    add_mechanism_options(p)
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser("sensitivity", help="design sensitivities of the base force (Figs. 4-6)",
                       description="Sensitivities of |F12| by direct differentiation (reduced "
                                   "model) or finite differences (any backend); prints mean "
                                   "and max normalized sensitivity (Eq. 15) over the last "
                                   "revolution and writes Fig. 4-6-like plots.")
    p.add_argument("--parameters", help="comma-separated SliderCrank fields "
                                        "(default: the paper's eight)")
    p.add_argument("--method", choices=("ddm", "fd"), default="ddm")
    p.add_argument("--backend", choices=sorted(BACKENDS), default="reduced")
    p.add_argument("--revolutions", type=int, default=4)
    p.add_argument("--rtol", type=float, help="relative tolerance (reduced backend)")
    p.add_argument("--step-size", type=float, help="time step in s (exudyn backend)")
    p.add_argument("--integrator", choices=sorted(METHODS),
                   help="method of the compiled integrator (reduced backend; default dop853 "
                        "for DDM, dopri5 for FD)")
    p.add_argument("--out", type=Path, help="folder for sensitivities.npz and figures")
    add_mechanism_options(p)
    p.set_defaults(func=_cmd_sensitivity)

    _add_optimize_parser(sub)
    _add_plugins(sub)
    return parser


def _add_optimize_parser(subparsers) -> argparse.ArgumentParser:
    """The ``optimize`` subcommand: GA over the link lengths (paper Section 4, Table 3)."""
    p = subparsers.add_parser(
        "optimize", help="GA optimisation of the link lengths (paper Table 3)",
        description="Minimise the peak base force max |F12| over a crank revolution by "
                    "choosing L2 and L3 with a genetic algorithm (pygad), refine the GA's "
                    "best point locally, print a Table 3-like comparison with the paper and "
                    "write result.json and two figures into --out.")
    p.add_argument("--seed", type=int, default=1, help="GA seed (default 1)")
    p.add_argument("--population", type=int, default=20, help="population size (default 20)")
    p.add_argument("--generations", type=int, default=30,
                   help="maximum number of generations (default 30)")
    p.add_argument("--saturation", type=int, default=10,
                   help="stop after this many generations without improvement (default 10;"
                        " 0 disables)")
    p.add_argument("--mass-scaling", choices=MASS_SCALINGS, default="fixed",
                   help="fixed: link masses fixed (paper); uniform: crank and coupler masses "
                        "proportional to their lengths")
    p.add_argument("--crank-bounds", type=float, nargs=2, metavar=("LO", "HI"),
                   default=(0.04, 0.06), help="bounds of L2 in m (default 0.04 0.06)")
    p.add_argument("--coupler-bounds", type=float, nargs=2, metavar=("LO", "HI"),
                   default=(0.10, 0.14), help="bounds of L3 in m (default 0.10 0.14)")
    p.add_argument("--revolution", type=int, default=4,
                   help="crank revolution whose peak is minimised (default 4)")
    p.add_argument("--rtol", type=float, help="relative tolerance of the reduced model")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="evaluate on this dask.distributed scheduler")
    p.add_argument("--workers", type=int, default=2,
                   help="local worker processes when no --scheduler (1 = this process)")
    p.add_argument("--out", type=Path, default=Path("optimize"),
                   help="output directory (default ./optimize)")
    p.add_argument("--no-refine", action="store_true", help="skip the local refinement")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_mechanism_options(p)
    p.set_defaults(func=_cmd_optimize)
    return p


def format_table3(result, paper_in_model: float, ideal: dict[str, float]) -> str:
    """Markdown table: the paper's Table 3 beside our optimum and the paper's optimum.

    `paper_in_model` is max |F12| of the paper's published optimum in our model, `ideal` the
    ideal-joint (closed form) peaks keyed "original", "optimum", "paper optimum".
    """
    po, pp = PAPER_TABLE3["original"], PAPER_TABLE3["optimum"]
    orig, best = result.original, result.best
    f0 = result.original_peak_force

    def red(f):
        return f"{100.0 * (f0 - f) / f0:.2f}"

    rows = [
        ("original (paper)", po["crank_length"], po["coupler_length"], po["peak_force"], "-",
         "-"),
        ("original (ours)", orig.crank_length, orig.coupler_length, f0, ideal["original"], "-"),
        ("optimum (paper)", pp["crank_length"], pp["coupler_length"], pp["peak_force"], "-",
         f"{PAPER_TABLE3['reduction_percent']:.2f}"),
        ("optimum (ours)", best.crank_length, best.coupler_length, result.best_peak_force,
         ideal["optimum"], red(result.best_peak_force)),
        ("paper's optimum in our model", pp["crank_length"], pp["coupler_length"],
         paper_in_model, ideal["paper optimum"], red(paper_in_model)),
    ]
    lines = ["| design | L2 (cm) | L3 (cm) | max abs(F12) (N) | ideal joints (N) "
             "| reduction (%) |", "|---|---|---|---|---|---|"]
    for name, l2, l3, f, fi, r in rows:
        fi = fi if isinstance(fi, str) else f"{fi:.2f}"
        lines.append(f"| {name} | {l2 * 100:.4f} | {l3 * 100:.4f} | {f:.2f} | {fi} | {r} |")
    return "\n".join(lines)


def _cmd_optimize(args: argparse.Namespace) -> int:
    mech = mechanism_from_args(args)
    options = {} if args.rtol is None else {"rtol": args.rtol}
    common = dict(crank_length=tuple(args.crank_bounds), coupler_length=tuple(args.coupler_bounds),
                  revolution=args.revolution, seed=args.seed, population=args.population,
                  generations=args.generations, saturation=args.saturation or None,
                  mass_scaling=args.mass_scaling, refine=not args.no_refine,
                  progress=not args.no_progress, **options)
    if args.scheduler:
        try:
            import dask.distributed  # noqa: F401
        except ImportError as exc:
            raise ValueError("--scheduler needs dask.distributed: "
                             "pip install 'mbs-clearance[dask]'") from exc
        with connect_dask(args.scheduler) as client:
            print(f"evaluating on the dask cluster at {args.scheduler}", file=sys.stderr)
            result = optimize_link_lengths(mech, executor=client, **common)
    elif args.workers == 1:
        result = optimize_link_lengths(mech, executor="serial", **common)
    else:
        result = optimize_link_lengths(mech, workers=args.workers, **common)

    pp = PAPER_TABLE3["optimum"]
    paper_mech = design_mechanism(mech, {"crank_length": pp["crank_length"],
                                         "coupler_length": pp["coupler_length"]},
                                  args.mass_scaling)
    paper_in_model = peak_base_force(paper_mech, args.revolution, **options)
    ideal = {k: peak_base_force(m, args.revolution, backend="ideal")
             for k, m in (("original", mech), ("optimum", result.best),
                          ("paper optimum", paper_mech))}
    table = format_table3(result, paper_in_model, ideal)
    print(table)
    print(f"\nmasses: {args.mass_scaling}; seed {result.settings['seed']}; "
          f"{result.generations_completed} generations, {result.n_evaluations} designs "
          f"simulated in {result.elapsed:.1f} s on {result.settings['executor']}; "
          f"GA best before refinement {result.ga_best_peak_force:.2f} N")
    if mech != type(mech)() or args.mass_scaling != "fixed" or args.revolution != 4:
        print("note: the paper's rows refer to its own case (paper mechanism, fixed masses, "
              "4th revolution)")

    from .plotting import plot_fitness_history, plot_force_comparison

    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    result.to_json(out / "result.json")
    (out / "table3.md").write_text(table + "\n")
    plot_fitness_history(result, out / "fitness_history.png")
    designs = {"original": mech, "optimum": result.best, "paper's optimum": paper_mech}
    plot_force_comparison({k: simulate(m, args.revolution, **options)
                           for k, m in designs.items()},
                          out / "force_comparison.png", revolution=args.revolution)
    print(f"result.json, table3.md, fitness_history.png and force_comparison.png written to "
          f"{out}", file=sys.stderr)
    return 0


#: entry-point group through which other packages (this project's `validation`) add
#: subcommands: each entry is a function register(subparsers). The library itself never
#: imports `validation`.
PLUGIN_GROUP = "mbs_clearance.commands"


def _add_plugins(sub) -> None:
    from importlib.metadata import entry_points

    for ep in sorted(entry_points(group=PLUGIN_GROUP), key=lambda e: e.name):
        try:
            register = ep.load()
        except ImportError:  # a plugin whose dependencies are missing is left out
            continue
        register(sub)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the `mbs-clearance` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as exc:
        parser.exit(2, f"mbs-clearance {args.command}: error: {exc}\n")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
