"""Command line: `mbs-clearance SUBCOMMAND ...`; each subcommand calls a public function."""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

from .mechanism import PARAMETER_INFO, SliderCrank
from .simulate import BACKENDS

__all__ = ["main", "build_parser", "mechanism_from_args"]


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
    from .simulate import simulate

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
                         backend=args.backend, rtol=args.rtol, **options)
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
    p.add_argument("--out", type=Path, help="folder for sensitivities.npz and figures")
    add_mechanism_options(p)
    p.set_defaults(func=_cmd_sensitivity)
    _add_plugins(sub)
    return parser


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
