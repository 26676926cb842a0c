"""Compare two trajectories of the same mechanism on a common time grid.

`compare(a, b)` returns per-revolution metrics with `a` as the reference:

- peak |F12| of each model (each its own, refined where the backend refines it) and their
  relative difference peak_b / peak_a - 1;
- relative RMS differences rms(a - b) / rms(a) of the base force (vector) and the crank
  moment over the revolution;
- the orbit distance |e_a - e_b| of the eccentricity curves, max and RMS, in m and relative
  to the radial clearance;

plus the first impact (time of the first contact onset and peak contact force of that
contact) and time-averaged statistics over revolutions 2..n (mean and RMS of |F12|, RMS of
the crank moment, contact time fraction), which are the meaningful comparison when the
response is chaotic and trajectories separate after a few impacts.

The common grid is uniform with the finer of the two median sample spacings; both
trajectories are interpolated linearly onto it (exactly reproducing a uniform trajectory
whose samples coincide with the grid, e.g. Exudyn's fixed steps).

Command line (``mbs-clearance compare`` / ``python -m validation.compare``): see
`compare_command`.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from mbs_clearance.trajectory import Trajectory

__all__ = ["RevolutionMetrics", "FirstImpact", "Statistics", "Comparison", "compare",
           "common_grid", "first_impact", "statistics", "format_table", "compare_command"]

#: upper bound on the number of points of the common grid (memory guard)
MAX_GRID_POINTS = 4_000_000


@dataclass(frozen=True)
class RevolutionMetrics:
    """Differences of two trajectories over one crank revolution (a = reference)."""

    revolution: int
    peak_a: float                 # N, max |F12|
    peak_b: float                 # N
    peak_rel_diff: float          # peak_b / peak_a - 1
    base_force_rel_rms: float     # rms(|F12_a - F12_b|) / rms(|F12_a|)
    crank_moment_rel_rms: float   # rms(M_a - M_b) / rms(M_a)
    orbit_max: float              # m, max |e_a - e_b|
    orbit_rms: float              # m, rms |e_a - e_b|
    orbit_max_rel: float          # orbit_max / clearance
    orbit_rms_rel: float          # orbit_rms / clearance


@dataclass(frozen=True)
class FirstImpact:
    """First contact onset of a trajectory: time (s, interpolated) and peak force (N)."""

    time: float
    peak_contact_force: float


@dataclass(frozen=True)
class Statistics:
    """Time averages over a set of revolutions (trapezoidal rule on the samples)."""

    revolutions: tuple[int, ...]
    mean_base_force: float        # N, mean |F12|
    rms_base_force: float         # N, rms |F12|
    rms_crank_moment: float       # N m
    contact_fraction: float       # share of time in contact


@dataclass(frozen=True)
class Comparison:
    """Result of `compare`; ``a`` is the reference."""

    backend_a: str
    backend_b: str
    clearance: float
    grid_step: float
    revolutions: tuple[RevolutionMetrics, ...]
    first_impact_a: FirstImpact | None
    first_impact_b: FirstImpact | None
    statistics_a: Statistics | None
    statistics_b: Statistics | None
    meta: dict = field(default_factory=dict)

    def revolution(self, k: int) -> RevolutionMetrics:
        """Metrics of revolution `k` (1-based)."""
        for r in self.revolutions:
            if r.revolution == k:
                return r
        raise ValueError(f"revolution {k} not compared; compared: "
                         f"{[r.revolution for r in self.revolutions]}")

    def to_dict(self) -> dict:
        return asdict(self)


def common_grid(a: Trajectory, b: Trajectory, t_end: float) -> np.ndarray:
    """Uniform grid on [0, t_end] with the finer median sample spacing of `a` and `b`."""
    steps = [float(np.median(np.diff(tr.t))) for tr in (a, b) if len(tr.t) > 1]
    dt = min(steps) if steps else t_end
    n = int(np.ceil(t_end / dt - 1e-9)) + 1
    if n > MAX_GRID_POINTS:
        n = MAX_GRID_POINTS
    return np.linspace(0.0, t_end, n)


def _interp(t: np.ndarray, tr: Trajectory, name: str) -> np.ndarray:
    y = np.asarray(getattr(tr, name), dtype=float)
    if y.ndim == 1:
        return np.interp(t, tr.t, y)
    return np.column_stack([np.interp(t, tr.t, y[:, j]) for j in range(y.shape[1])])


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else float("nan")


def first_impact(tr: Trajectory) -> FirstImpact | None:
    """First onset (penetration crossing zero upward) and the peak force of that contact."""
    pen = tr.penetration
    inside = np.nonzero(pen > 0.0)[0]
    if inside.size == 0:
        return None
    i = int(inside[0])
    if i > 0 and pen[i - 1] <= 0.0:
        theta = pen[i - 1] / (pen[i - 1] - pen[i])
        t_on = float(tr.t[i - 1] + theta * (tr.t[i] - tr.t[i - 1]))
    else:
        t_on = float(tr.t[i])
    after = np.nonzero(pen[i:] <= 0.0)[0]
    j = i + int(after[0]) if after.size else len(pen)
    return FirstImpact(time=t_on, peak_contact_force=float(tr.contact_force[i:j].max()))


def statistics(tr: Trajectory, revolutions: tuple[int, ...]) -> Statistics:
    """Time-averaged |F12|, crank moment and contact share over `revolutions` (contiguous)."""
    t_a = tr.revolution_window(min(revolutions))[0]
    t_b = tr.revolution_window(max(revolutions))[1]
    tol = 1e-12 * max(1.0, t_b)
    mask = (tr.t >= t_a - tol) & (tr.t <= t_b + tol)
    t = tr.t[mask]
    span = t[-1] - t[0]

    def mean(y):
        return float(np.trapezoid(y, t) / span)

    f = tr.base_force_magnitude[mask]
    return Statistics(
        revolutions=tuple(revolutions),
        mean_base_force=mean(f),
        rms_base_force=float(np.sqrt(mean(f * f))),
        rms_crank_moment=float(np.sqrt(mean(tr.crank_moment[mask] ** 2))),
        contact_fraction=mean(tr.contact_phase[mask].astype(float)),
    )


def compare(a: Trajectory, b: Trajectory, revolutions=None) -> Comparison:
    """Compare trajectory `b` against the reference `a` revolution by revolution.

    Parameters
    ----------
    a, b : Trajectory
        Simulations of the same mechanism (only the clearance is used from a's mechanism).
    revolutions : int, sequence of int or None
        Revolutions (1-based) to compare; an int n means 1..n; None: every full revolution
        both trajectories cover.

    Returns
    -------
    Comparison
    """
    if not isinstance(a, Trajectory) or not isinstance(b, Trajectory):
        raise ValueError("compare expects two Trajectory objects")
    if a.mechanism != b.mechanism:
        raise ValueError("the trajectories simulate different mechanisms: "
                         f"{a.mechanism} vs {b.mechanism}")
    n_common = min(a.revolutions, b.revolutions)
    if n_common < 1:
        raise ValueError("the trajectories must cover at least one full revolution")
    if revolutions is None:
        revs = tuple(range(1, n_common + 1))
    elif isinstance(revolutions, (int, np.integer)) and not isinstance(revolutions, bool):
        revs = tuple(range(1, int(revolutions) + 1))
    else:
        revs = tuple(int(k) for k in revolutions)
    bad = [k for k in revs if not 1 <= k <= n_common]
    if not revs or bad:
        raise ValueError(f"revolutions must lie in 1..{n_common} (covered by both "
                         f"trajectories); got {revolutions!r}")

    mech = a.mechanism
    c = mech.clearance
    t = common_grid(a, b, max(revs) * mech.period)
    Fa, Fb = _interp(t, a, "base_force"), _interp(t, b, "base_force")
    Ma, Mb = _interp(t, a, "crank_moment"), _interp(t, b, "crank_moment")
    ea, eb = _interp(t, a, "eccentricity"), _interp(t, b, "eccentricity")
    dF = np.hypot(*(Fa - Fb).T)
    magF = np.hypot(*Fa.T)
    dE = np.hypot(*(ea - eb).T)
    metrics = []
    for k in revs:
        t0, t1 = (k - 1) * mech.period, k * mech.period
        m = (t >= t0 - 1e-12 * t1) & (t <= t1 * (1 + 1e-12))
        pa, pb = a.max_base_force(k), b.max_base_force(k)
        metrics.append(RevolutionMetrics(
            revolution=k, peak_a=pa, peak_b=pb, peak_rel_diff=pb / pa - 1.0,
            base_force_rel_rms=_rms(dF[m]) / _rms(magF[m]),
            crank_moment_rel_rms=_rms(Ma[m] - Mb[m]) / _rms(Ma[m]),
            orbit_max=float(dE[m].max()), orbit_rms=_rms(dE[m]),
            orbit_max_rel=float(dE[m].max()) / c, orbit_rms_rel=_rms(dE[m]) / c,
        ))
    later = tuple(k for k in range(2, n_common + 1)) or (1,)
    return Comparison(
        backend_a=a.backend, backend_b=b.backend, clearance=c, grid_step=float(t[1] - t[0]),
        revolutions=tuple(metrics),
        first_impact_a=first_impact(a), first_impact_b=first_impact(b),
        statistics_a=statistics(a, later), statistics_b=statistics(b, later),
        meta={"stats_a": dict(a.stats), "stats_b": dict(b.stats)},
    )


def _pct(x: float) -> str:
    return f"{100.0 * x:+.3f} %" if np.isfinite(x) else "n/a"


def format_table(result: Comparison) -> str:
    """Plain-text table of a `Comparison` (returned as a string)."""
    a, b = result.backend_a, result.backend_b
    lines = [f"comparison: a = {a} (reference), b = {b}; clearance c = "
             f"{result.clearance:.4g} m; common grid step {result.grid_step:.3g} s", ""]
    head = (f"{'rev':>3}  {'peak |F12| a (N)':>16}  {'peak |F12| b (N)':>16}  "
            f"{'b/a - 1':>10}  {'rms dF12/rms':>12}  {'rms dM2/rms':>11}  "
            f"{'orbit max/c':>11}  {'orbit rms/c':>11}")
    lines += [head, "-" * len(head)]
    for r in result.revolutions:
        lines.append(
            f"{r.revolution:>3}  {r.peak_a:>16.2f}  {r.peak_b:>16.2f}  "
            f"{_pct(r.peak_rel_diff):>10}  {100 * r.base_force_rel_rms:>10.3f} %  "
            f"{100 * r.crank_moment_rel_rms:>9.3f} %  {r.orbit_max_rel:>11.4f}  "
            f"{r.orbit_rms_rel:>11.4f}")
    lines.append("")
    fa, fb = result.first_impact_a, result.first_impact_b
    if fa is not None and fb is not None:
        lines.append(f"first impact: t_a = {fa.time * 1e6:.3f} us, t_b = {fb.time * 1e6:.3f} us;"
                     f" peak contact force a = {fa.peak_contact_force:.1f} N, b = "
                     f"{fb.peak_contact_force:.1f} N "
                     f"({_pct(fb.peak_contact_force / fa.peak_contact_force - 1)})")
    sa, sb = result.statistics_a, result.statistics_b
    if sa is not None and sb is not None:
        revs = f"{min(sa.revolutions)}-{max(sa.revolutions)}"
        lines.append(f"statistics over revolutions {revs}:")
        for label, x, y in (("mean |F12| (N)", sa.mean_base_force, sb.mean_base_force),
                            ("rms |F12| (N)", sa.rms_base_force, sb.rms_base_force),
                            ("rms M2 (N m)", sa.rms_crank_moment, sb.rms_crank_moment),
                            ("contact fraction", sa.contact_fraction, sb.contact_fraction)):
            lines.append(f"  {label:<18} a = {x:>10.4g}   b = {y:>10.4g}   ({_pct(y / x - 1)})")
    return "\n".join(lines)


# ------------------------------------------------------------------------------ CLI
def _backend_options(backend: str, other: str, args) -> dict:
    options = {}
    if backend == "reduced":
        if args.rtol is not None:
            options["rtol"] = args.rtol
        h_max = args.h_max
        if h_max is None and other == "exudyn":
            # sample the adaptive model at least as densely as the fixed-step one: linear
            # interpolation between its long free-flight steps would otherwise cut the
            # curved orbit and show up as a spurious orbit distance
            h_max = args.step_size if args.step_size is not None else _exudyn_default_step()
        if h_max is not None:
            options["h_max"] = h_max
    if backend == "exudyn":
        if args.step_size is not None:
            options["step_size"] = args.step_size
        if args.contact is not None:
            options["contact"] = args.contact
        from mbs_clearance.exudyn_model import make_settings

        make_settings(options)          # bad values fail before any simulation runs
    return options


def _exudyn_default_step() -> float:
    from mbs_clearance.exudyn_model import DEFAULT_STEP_SIZE

    return DEFAULT_STEP_SIZE


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    """Arguments of ``mbs-clearance compare`` (added to `parser` if given)."""
    from mbs_clearance.cli import (
        Parser,
        add_force_option,
        add_mechanism_options,
        int_at_least,
        positive_float,
    )
    from mbs_clearance.simulate import BACKENDS

    if parser is None:
        parser = Parser(
            prog="mbs-clearance compare",
            description="Simulate one mechanism with two backends, print per-revolution "
                        "differences (peak |F12|, RMS of F12 and M2, orbit distance) and "
                        "write an overlay plot.")
    parser.add_argument("--backend-a", choices=sorted(BACKENDS), default="reduced",
                        help="reference backend (default: reduced)")
    parser.add_argument("--backend-b", choices=sorted(BACKENDS), default="exudyn",
                        help="compared backend (default: exudyn)")
    parser.add_argument("--revolutions", type=int_at_least(1), default=4)
    parser.add_argument("--rtol", type=positive_float,
                        help="relative tolerance (reduced backend)")
    parser.add_argument("--h-max", type=positive_float,
                        help="largest step in s (reduced backend); default: the Exudyn step "
                             "size when compared with exudyn")
    parser.add_argument("--step-size", type=positive_float,
                        help="time step in s (exudyn backend)")
    parser.add_argument("--contact", help="contact variant (exudyn backend): symbolic, "
                                          "python or sphere")
    parser.add_argument("--out", type=Path, default=Path("compare_overlay.png"),
                        help="overlay figure (PNG); default compare_overlay.png")
    parser.add_argument("--no-plot", action="store_true", help="do not write the figure")
    add_force_option(parser)
    add_mechanism_options(parser)
    return parser


def run_compare(args: argparse.Namespace) -> int:
    """Body of ``mbs-clearance compare`` for parsed arguments; returns the exit code."""
    from mbs_clearance._io import atomic_file, check_output_file
    from mbs_clearance.cli import figure_suffixes, mechanism_from_args
    from mbs_clearance.simulate import simulate

    mech = mechanism_from_args(args)
    if args.revolutions < 1:
        raise ValueError(f"--revolutions must be >= 1; got {args.revolutions}")
    if not args.no_plot:
        check_output_file(args.out, "--out", args.force, suffixes=figure_suffixes())
    pair = (args.backend_a, args.backend_b)
    all_options = [_backend_options(be, other, args) for be, other in (pair, pair[::-1])]
    trajectories = []
    for backend, options in zip(pair, all_options):
        t0 = time.perf_counter()
        trajectories.append(simulate(mech, args.revolutions, backend=backend, **options))
        print(f"{backend}: {time.perf_counter() - t0:.3g} s", file=sys.stderr, flush=True)
    result = compare(*trajectories)
    print(format_table(result))
    if not args.no_plot:
        from mbs_clearance.plotting import plot_comparison

        with atomic_file(args.out) as tmp:
            plot_comparison(*trajectories, path=tmp)
        print(f"figure written to {args.out}", file=sys.stderr)
    return 0


def compare_command(argv: list[str] | None = None) -> int:
    """``mbs-clearance compare``: simulate with two backends, print the table, plot.

    Failures end with a one-line message: exit status 2 for bad values (mechanism fields,
    options, output path), 1 for failures while running (`mbs_clearance.cli.run_command`).
    """
    from mbs_clearance.cli import run_command

    parser = build_parser()
    args = parser.parse_args(argv)
    return run_command(parser.prog, run_compare, args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(compare_command())


def register(subparsers) -> None:
    """CLI plugin (entry point group ``mbs_clearance.commands``): `mbs-clearance compare`."""
    p = subparsers.add_parser("compare", help="compare two backends (table + overlay plot)",
                              description="Simulate one mechanism with two backends, print "
                                          "per-revolution differences and write an overlay "
                                          "plot.")
    build_parser(p)
    p.set_defaults(func=run_compare)
