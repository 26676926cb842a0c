"""Compare two trajectories of the same mechanism on a common time grid.

`compare(a, b)` returns per-revolution metrics with `a` as the reference, for the paper's
`SliderCrank` and for any `Linkage` (a named case: per clearance joint):

- peak of the monitored force (|F12| of the slider-crank, the monitored ground joint's
  |reaction| or the |shaking force| of a linkage) of each model (each its own, refined where
  the backend refines it) and their relative difference peak_b / peak_a - 1;
- the RMS over the revolution of the |shaking force| (sum of the ground reactions; the
  slider-crank's |F12|) and of the drive moment of each model, and their relative
  differences;
- relative RMS differences rms(a - b) / rms(a) of the base force (vector) and the crank
  moment over the revolution;
- the orbit distance |e_a - e_b| of the eccentricity curves, max and RMS, in m and relative
  to the radial clearance (the largest over the clearance joints);

plus the first impact of every clearance joint (time of its first contact onset and peak
contact force of that contact) and time-averaged statistics over revolutions 2..n (mean
and RMS of the monitored force and of the |shaking force|, RMS of the drive moment,
contact time fraction), which are the meaningful comparison when the
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

from mbs_clearance.analysis.verdict import Verdict, format_verdict, verdict_of_trajectories
from mbs_clearance.solve.trajectory import Trajectory

__all__ = ["RevolutionMetrics", "FirstImpact", "Statistics", "Comparison", "compare", "step_bars",
           "common_grid", "first_impact", "statistics", "format_table", "compare_command",
           "plot_linkage_comparison", "shaking_magnitude", "eccentricities", "clearances",
           "joints_of", "CrossCheck", "cross_check", "format_cross_check"]

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
    shaking_rms_a: float = float("nan")   # N, rms |shaking force| over the revolution
    shaking_rms_b: float = float("nan")
    moment_rms_a: float = float("nan")    # N m, rms drive moment over the revolution
    moment_rms_b: float = float("nan")

    @property
    def shaking_rms_rel_diff(self) -> float:
        """rms |shaking force| b / a - 1."""
        return self.shaking_rms_b / self.shaking_rms_a - 1.0

    @property
    def moment_rms_rel_diff(self) -> float:
        """rms drive moment b / a - 1."""
        return self.moment_rms_b / self.moment_rms_a - 1.0


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
    contact_fraction: float       # share of time in contact (any joint)
    rms_shaking_force: float = float("nan")   # N, rms |shaking force|


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
    joints: tuple[str, ...] = ()
    first_impacts_a: dict = field(default_factory=dict)   # joint -> FirstImpact or None
    first_impacts_b: dict = field(default_factory=dict)
    #: the verdict on the two runs' peaks with their own error bars
    #: (`mbs_clearance.analysis.verdict.verdict_of_trajectories`)
    verdict: Verdict | None = None

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


def joints_of(tr: Trajectory) -> tuple[str, ...]:
    """Names of the clearance joints of a trajectory (the slider-crank's: "coupler_slider")."""
    return tr.joints if tr.joints is not None else ("coupler_slider",)


def clearances(mech) -> np.ndarray:
    """Radial clearance of each clearance joint in m."""
    if hasattr(mech, "clearance_joints"):
        return np.array([j.clearance for j in mech.clearance_joints])
    return np.array([mech.clearance])


def eccentricities(tr: Trajectory) -> np.ndarray:
    """Eccentricity (n, J, 2) in m."""
    e = np.asarray(tr.eccentricity)
    return e[:, None, :] if e.ndim == 2 else e


def shaking_magnitude(tr: Trajectory) -> np.ndarray:
    """|shaking force| (n,) in N: |sum of the ground reactions|; a run without them (the
    paper's closed form with ideal joints records only F12): its |F12|."""
    f = tr.shaking_force if tr.shaking_force is not None else tr.base_force
    return np.hypot(f[:, 0], f[:, 1])


def first_impact(tr: Trajectory, joint: int = 0) -> FirstImpact | None:
    """First onset (penetration crossing zero upward) of clearance joint `joint` (index)
    and the peak force of that contact."""
    pen = tr.penetration if tr.penetration.ndim == 1 else tr.penetration[:, joint]
    force = tr.contact_force if tr.contact_force.ndim == 1 else tr.contact_force[:, joint]
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
    return FirstImpact(time=t_on, peak_contact_force=float(force[i:j].max()))


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
    phase = tr.contact_phase[mask]
    phase = phase if phase.ndim == 1 else phase.max(axis=1)
    return Statistics(
        revolutions=tuple(revolutions),
        mean_base_force=mean(f),
        rms_base_force=float(np.sqrt(mean(f * f))),
        rms_crank_moment=float(np.sqrt(mean(tr.crank_moment[mask] ** 2))),
        contact_fraction=mean(phase.astype(float)),
        rms_shaking_force=float(np.sqrt(mean(shaking_magnitude(tr)[mask] ** 2))),
    )


def compare(a: Trajectory, b: Trajectory, revolutions=None, *, step_bars: bool = True,
            start=None) -> Comparison:
    """Compare trajectory `b` against the reference `a` revolution by revolution.

    Parameters
    ----------
    a, b : Trajectory
        Simulations of the same mechanism (only the clearance is used from a's mechanism).
    revolutions : int, sequence of int or None
        Revolutions (1-based) to compare; an int n means 1..n; None: every full revolution
        both trajectories cover.
    step_bars : bool, default True
        For the verdict, give an Exudyn run at a fixed step its error bars from two more
        runs at h/2 and h/4 (`step_bars`; about 6 times that run's time, only where the
        motion is comparable peak by peak). False: no further runs, and a difference
        beyond the bars where a run has none is "not decided: no error bar".
    start
        The runs' start (`simulate(..., start=)`), for those further runs.

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
    c = clearances(mech)
    t = common_grid(a, b, max(revs) * mech.period)
    Fa, Fb = _interp(t, a, "base_force"), _interp(t, b, "base_force")
    Ma, Mb = _interp(t, a, "crank_moment"), _interp(t, b, "crank_moment")
    Sa, Sb = (np.interp(t, tr.t, shaking_magnitude(tr)) for tr in (a, b))
    ea, eb = eccentricities(a), eccentricities(b)
    # orbit distance per joint, in m and in that joint's clearances
    dE = np.column_stack([
        np.hypot(np.interp(t, a.t, ea[:, j, 0]) - np.interp(t, b.t, eb[:, j, 0]),
                 np.interp(t, a.t, ea[:, j, 1]) - np.interp(t, b.t, eb[:, j, 1]))
        for j in range(len(c))])
    dF = np.hypot(*(Fa - Fb).T)
    magF = np.hypot(*Fa.T)
    metrics = []
    for k in revs:
        t0, t1 = (k - 1) * mech.period, k * mech.period
        m = (t >= t0 - 1e-12 * t1) & (t <= t1 * (1 + 1e-12))
        pa, pb = a.max_base_force(k), b.max_base_force(k)
        d = dE[m]
        rms_j = np.sqrt(np.mean(d * d, axis=0))
        metrics.append(RevolutionMetrics(
            revolution=k, peak_a=pa, peak_b=pb, peak_rel_diff=pb / pa - 1.0,
            base_force_rel_rms=_rms(dF[m]) / _rms(magF[m]),
            crank_moment_rel_rms=_rms(Ma[m] - Mb[m]) / _rms(Ma[m]),
            orbit_max=float(d.max()), orbit_rms=float(rms_j.max()),
            orbit_max_rel=float((d.max(axis=0) / c).max()),
            orbit_rms_rel=float((rms_j / c).max()),
            shaking_rms_a=_rms(Sa[m]), shaking_rms_b=_rms(Sb[m]),
            moment_rms_a=_rms(Ma[m]), moment_rms_b=_rms(Mb[m]),
        ))
    later = tuple(k for k in range(2, n_common + 1)) or (1,)
    joints = joints_of(a)
    fa = {name: first_impact(a, j) for j, name in enumerate(joints)}
    fb = {name: first_impact(b, j) for j, name in enumerate(joints)}
    return Comparison(
        backend_a=a.backend, backend_b=b.backend, clearance=float(c.min()),
        grid_step=float(t[1] - t[0]), revolutions=tuple(metrics),
        first_impact_a=_earliest(fa), first_impact_b=_earliest(fb),
        statistics_a=statistics(a, later), statistics_b=statistics(b, later),
        meta={"stats_a": dict(a.stats), "stats_b": dict(b.stats)},
        joints=joints, first_impacts_a=fa, first_impacts_b=fb,
        verdict=verdict_of_trajectories(a, b, revs,
                                        bars=_step_bars_from(start) if step_bars else None),
    )


def step_bars(traj, start=None):
    """An Exudyn run at a fixed step h without an error estimate, with a bar on each of its
    per-revolution peaks from two more runs at h/2 and h/4 (the reactions only).

    The three runs are read as the step sequences read theirs (`exudyn_convergence.
    _sequence_peaks`, `_run_peaks`: the peaks of the monitored force smoothed against the
    step-alternating roundoff oscillation of Exudyn's reactions, `smoothed`), and
    `exudyn_convergence.richardson` on those three readings gives the extrapolated value y*
    and its bar |y_h/2 - y_h/4|. The value shown stays the run's own peak y_h (its
    ``peaks``, read from the raw force like every fixed-step run's); its bar is
    |y_h - y*| + |y_h/2 - y_h/4|, with y_h that raw peak: it bounds y_h's error wherever
    the extrapolated value's bar holds, and it holds the run's own oscillation too, as
    |y_h - y*| measures it (docs/exudyn.md measures the bars against the reduced model at
    rtol 1e-12). Any other run (another backend, a free linkage, or a run with an estimate
    already) is returned as it is.

    Parameters
    ----------
    traj : Trajectory
        An Exudyn run of a driven mechanism (``stats["step_size"]``, its settings).
    start
        The run's start (`simulate(..., start=)`), None: the default.

    Returns
    -------
    Trajectory
        `traj` with ``stats["peak_errors"]`` (N per revolution), ``error_estimate``
        (largest relative bar), ``error_estimate_method`` ("step halving at the run's
        step"), ``observed_order``, ``accuracy_steps``, ``accuracy_peaks`` (N, the smoothed
        readings of the three runs that the extrapolation used; the first row is the run's
        own smoothed, not its ``peaks``) and ``step_bars_seconds`` (s, the two runs' wall
        time).
    """
    from dataclasses import fields, replace

    from mbs_clearance._checks import MemoryLimitError
    from mbs_clearance.analysis.verdict import has_bars
    from mbs_clearance.backends import exudyn_linkage as xl
    from mbs_clearance.backends.exudyn_convergence import (
        _run_peaks,
        _sequence_peaks,
        richardson,
    )
    from mbs_clearance.model.cases import as_linkage
    from mbs_clearance.solve.linkage_model import prepare_span

    if (traj.backend != "exudyn" or has_bars(traj) or traj.peaks is None
            or "step_size" not in traj.stats or getattr(traj.mechanism, "drive", True) is None):
        return traj
    linkage = as_linkage(traj.mechanism)
    # (the finer runs choose their own Newton tolerance: its roundoff floor rises as the
    # step shrinks, `exudyn_linkage.build_and_solve`)
    names = {f.name for f in fields(xl.ExudynSettings)} - {"step_size", "accuracy",
                                                          "newton_tolerance"}
    options = {k: v for k, v in traj.stats.items() if k in names}
    h = float(traj.stats["step_size"])
    y_h = np.asarray(traj.peaks, dtype=float)
    n = len(y_h)
    own = _sequence_peaks(traj.t, traj.base_force, linkage.period, n)[0]
    t0 = time.perf_counter()
    try:
        span = prepare_span(linkage, n)
        finer = [_run_peaks(linkage, span, xl.make_settings({**options, "step_size": step}),
                            None, start)[0] for step in (h / 2.0, h / 4.0)]
    except MemoryLimitError:
        return traj     # even the reactions at h/4 exceed max_memory: no bar (it says so)
    seconds = time.perf_counter() - t0
    value, error, order = richardson(own, *finer)
    bars = np.abs(y_h - value) + error
    stats = dict(traj.stats)
    stats.update(peak_errors=[float(e) for e in bars],
                 error_estimate=float(np.max(bars / np.abs(y_h))),
                 error_estimate_method="step halving at the run's step (h, h/2, h/4)",
                 observed_order=[float(p) for p in order],
                 accuracy_steps=[h, h / 2.0, h / 4.0],
                 accuracy_peaks=[list(map(float, p)) for p in (own, *finer)],
                 step_bars_seconds=seconds)
    return replace(traj, stats=stats)


def _step_bars_from(start):
    # `compare`'s flag of the same name hides the function there
    return lambda traj: step_bars(traj, start)


def _earliest(impacts: dict) -> FirstImpact | None:
    found = [f for f in impacts.values() if f is not None]
    return min(found, key=lambda f: f.time) if found else None


def _pct(x: float) -> str:
    if not np.isfinite(x):
        return "n/a"
    text = f"{100.0 * x:+.3f} %"
    return "0.000 %" if text in ("+0.000 %", "-0.000 %") else text   # no signed zero


def _impact_time(impact: FirstImpact | None) -> str:
    from mbs_clearance.units import quantity

    return "no impact" if impact is None else f"at {quantity(impact.time, 's', 6)}"


def _pct_of(b: float, a: float) -> str:
    """b against a as a relative difference; n/a where a is zero (e.g. no dry contact in a
    lubricated joint) unless b is too."""
    if a == 0.0:
        return _pct(0.0) if b == 0.0 else "n/a"
    return _pct(b / a - 1.0)


def format_table(result: Comparison) -> str:
    """Plain-text table of a `Comparison` (returned as a string)."""
    a, b = result.backend_a, result.backend_b
    from mbs_clearance.units import number, quantity

    lines = [f"comparison: a = {a} (reference), b = {b}; smallest clearance c = "
             f"{quantity(result.clearance, 'm')}; common grid step "
             f"{quantity(result.grid_step, 's', 3)}", ""]
    head = (f"{'rev':>3}  {'peak a (N)':>12}  {'peak b (N)':>12}  "
            f"{'b/a - 1':>10}  {'rms dF/rms':>10}  {'rms dM/rms':>10}  "
            f"{'rms |S| b/a-1':>13}  {'rms M b/a-1':>11}  {'orbit max/c':>11}  "
            f"{'orbit rms/c':>11}")
    lines += [head, "-" * len(head)]
    for r in result.revolutions:
        lines.append(
            f"{r.revolution:>3}  {number(r.peak_a, 6):>12}  {number(r.peak_b, 6):>12}  "
            f"{_pct(r.peak_rel_diff):>10}  {100 * r.base_force_rel_rms:>8.3f} %  "
            f"{100 * r.crank_moment_rel_rms:>8.3f} %  {_pct(r.shaking_rms_rel_diff):>13}  "
            f"{_pct(r.moment_rms_rel_diff):>11}  {r.orbit_max_rel:>11.4f}  "
            f"{r.orbit_rms_rel:>11.4f}")
    lines += ["", "peak: the monitored force (|F12|, a ground joint's |reaction| or the |shaking "
              "force|); S: shaking force; M: drive moment; orbit: journal centre distance "
              "(largest over the joints) in clearances", ""]
    for name in result.joints or ("",):
        fa = result.first_impacts_a.get(name, result.first_impact_a)
        fb = result.first_impacts_b.get(name, result.first_impact_b)
        label = f"first impact {name}".rstrip()
        if fa is not None and fb is not None:
            lines.append(f"{label}: t_a = {quantity(fa.time, 's', 6)}, t_b = "
                         f"{quantity(fb.time, 's', 6)}; peak contact force a = "
                         f"{quantity(fa.peak_contact_force, 'N', 6)}, b = "
                         f"{quantity(fb.peak_contact_force, 'N', 6)} "
                         f"({_pct_of(fb.peak_contact_force, fa.peak_contact_force)})")
        else:
            lines.append(f"{label}: a {_impact_time(fa)}, b {_impact_time(fb)}")
    sa, sb = result.statistics_a, result.statistics_b
    if sa is not None and sb is not None:
        revs = f"{min(sa.revolutions)}-{max(sa.revolutions)}"
        lines.append(f"statistics over revolutions {revs}:")
        for label, x, y, unit in (
                ("mean |F|", sa.mean_base_force, sb.mean_base_force, "N"),
                ("rms |F|", sa.rms_base_force, sb.rms_base_force, "N"),
                ("rms |S|", sa.rms_shaking_force, sb.rms_shaking_force, "N"),
                ("rms M", sa.rms_crank_moment, sb.rms_crank_moment, "N m"),
                ("contact fraction", 100 * sa.contact_fraction, 100 * sb.contact_fraction,
                 "%")):
            lines.append(f"  {label:<18} a = {quantity(x, unit):>12}   b = "
                         f"{quantity(y, unit):>12}   ({_pct_of(y, x)})")
    if result.verdict is not None:
        lines += ["", format_verdict(result.verdict)]
    return "\n".join(lines)


#: width (in) of the comparison figures: the report's page width at 110 dpi
COMPARISON_WIDTH = 11.0


def plot_linkage_comparison(a: Trajectory, b: Trajectory, path=None,
                            revolution: int | None = None):
    """Overlay two trajectories of a linkage: the monitored force, the |shaking force| and
    the drive moment over one revolution (default: the last both cover) against the drive
    angle, and the journal orbit of every clearance joint (in its clearances) over the whole
    common span. Returns the matplotlib Figure (written to `path` if given)."""
    from matplotlib.figure import Figure

    from mbs_clearance.plotting import backend_label, save

    mech = a.mechanism
    n = min(a.revolutions, b.revolutions)
    k = n if revolution is None else revolution
    if not isinstance(k, (int, np.integer)) or not 1 <= k <= n:
        raise ValueError(f"revolution must be between 1 and {n}; got {revolution!r}")
    joints, c = joints_of(a), clearances(mech)
    # two panels a row: each keeps about half the page width (readable ticks and labels)
    panels = 3 + len(joints)
    rows = (panels + 1) // 2
    fig = Figure(figsize=(COMPARISON_WIDTH, 3.6 * rows), layout="constrained")
    grid = fig.subplots(rows, 2, squeeze=False).ravel()
    for ax in grid[panels:]:
        ax.set_axis_off()
    axes = grid[:panels]
    for tr, style in ((a, dict(color="C0", lw=1.6)), (b, dict(color="C3", lw=1.0, ls="--"))):
        m = tr.revolution_mask(k)
        angle = np.degrees(tr.crank_angle[m] - tr.crank_angle[0] - 2 * np.pi * (k - 1))
        label = backend_label(tr)
        axes[0].plot(angle, tr.base_force_magnitude[m], label=label, **style)
        axes[1].plot(angle, shaking_magnitude(tr)[m], label=label, **style)
        axes[2].plot(angle, tr.crank_moment[m], label=label, **style)
        mo = tr.t <= n * mech.period * (1 + 1e-12)
        e = eccentricities(tr)
        for j in range(len(joints)):
            axes[3 + j].plot(e[mo, j, 0] / c[j], e[mo, j, 1] / c[j], label=label,
                             **{**style, "lw": 0.6})
    xlabel = f"drive angle in revolution {k} (deg)"
    axes[0].set(xlabel=xlabel, ylabel="monitored force (N)", title="monitored force")
    axes[1].set(xlabel=xlabel, ylabel="|shaking force| (N)", title="|shaking force|")
    axes[2].set(xlabel=xlabel, ylabel="drive moment (N m)", title="drive moment")
    phi = np.linspace(0.0, 2 * np.pi, 361)
    for j, name in enumerate(joints):
        ax = axes[3 + j]
        ax.plot(np.cos(phi), np.sin(phi), color="0.5", lw=0.8, label="clearance circle")
        ax.set(xlabel="journal x / clearance (-)", ylabel="journal y / clearance (-)",
               title=f"journal orbit in {name}", aspect="equal")
    for ax in axes:
        ax.grid(alpha=0.3)
    for ax in (axes[0], *axes[3:]):
        ax.legend(fontsize=8, loc="upper right")
    fig.suptitle(f"{getattr(mech, 'name', 'slider-crank').replace('_', ' ')}: "
                 f"{backend_label(a)} vs {backend_label(b)}")
    return save(fig, path)


# ------------------------------------------------------------------------------ CLI
@dataclass(frozen=True)
class CrossCheck:
    """The two models' converged per-revolution peaks of the monitored force with their
    error bars (N): the reduced model run to a requested accuracy (its own estimate), Exudyn
    extrapolated from the steps h, h/2, h/4 (`exudyn_convergence`); the time each needed
    (s); and the `Verdict` on them (statistics over revolutions where the motion is not
    comparable peak by peak)."""

    reduced: np.ndarray
    reduced_error: np.ndarray
    exudyn: np.ndarray
    exudyn_error: np.ndarray
    exudyn_order: np.ndarray
    exudyn_steps: tuple
    reduced_seconds: float
    exudyn_seconds: float
    accuracy: float
    verdict: Verdict | None = None

    @property
    def difference(self) -> np.ndarray:
        """exudyn - reduced, N."""
        return self.exudyn - self.reduced

    @property
    def bars(self) -> np.ndarray:
        """Sum of the two error bars, N."""
        return self.reduced_error + self.exudyn_error

    @property
    def model_difference(self) -> np.ndarray:
        """Per revolution: the difference exceeds the two error bars together."""
        return np.abs(self.difference) > self.bars


def cross_check(mech, revolutions: int = 4, *, accuracy: float = 1e-6,
                step_size: float | None = None, exudyn_accuracy: float | None = None,
                lyapunov=None, **exudyn_options) -> CrossCheck:
    """Converged peaks of both models (`CrossCheck`) and the verdict on them.

    The reduced model runs at `accuracy` (its error bar: its estimate x peak), Exudyn from
    `step_size` h (default its default step), h/2, h/4, Richardson-extrapolated (its bar:
    `exudyn_convergence.richardson` and the onsets' share, `onset_term`), halved further
    while a bar exceeds `exudyn_accuracy` (relative; None: three runs). The verdict
    (`mbs_clearance.analysis.verdict`) is taken peak by peak where the reduced run is
    periodic (``stats["periodic"]``, judged on a reduced run of 8 revolutions where the run
    is too short: `periodic_flag`) or the given `lyapunov` result (`lyapunov_exponent`) is
    negative or zero; otherwise on statistics over revolutions 2..n, for which Exudyn runs
    once more at its finest step, recorded.
    """
    from mbs_clearance import simulate
    from mbs_clearance.analysis.verdict import revolution_statistics, verdict_of_peaks
    from mbs_clearance.backends.exudyn_convergence import converged_peaks
    from mbs_clearance.solve.accuracy import revolution_peaks

    t0 = time.perf_counter()
    red = simulate(mech, revolutions, accuracy=accuracy)
    reduced_seconds = time.perf_counter() - t0
    peaks = revolution_peaks(red)
    conv = converged_peaks(mech, revolutions, step_size=step_size, accuracy=exudyn_accuracy,
                           **exudyn_options)
    reduced_error = red.stats["error_estimate"] * np.abs(peaks)
    later = tuple(range(2, revolutions + 1))
    kw = {}
    from mbs_clearance.analysis.verdict import comparable, periodic_flag

    periodic = periodic_flag(red) if lyapunov is None else None
    if not comparable(periodic, lyapunov)[0] and not later:
        # one revolution: no statistics over revolutions 2..n, which the verdict says
        kw = dict(statistics_a=revolution_statistics(red, later),
                  statistics_b=revolution_statistics(red, later))
    elif not comparable(periodic, lyapunov)[0]:
        t1 = time.perf_counter()
        fine = simulate(mech, revolutions, backend="exudyn", step_size=conv.steps[-1],
                        **exudyn_options)
        conv = _with_seconds(conv, time.perf_counter() - t1)
        kw = dict(statistics_a=revolution_statistics(red, later),
                  statistics_b=revolution_statistics(fine, later))
    verdict = verdict_of_peaks(peaks, reduced_error, conv.value, conv.error,
                               periodic=periodic, lyapunov=lyapunov, **kw)
    return CrossCheck(reduced=peaks, reduced_error=reduced_error,
                      exudyn=conv.value, exudyn_error=conv.error, exudyn_order=conv.order,
                      exudyn_steps=conv.steps[-3:], reduced_seconds=reduced_seconds,
                      exudyn_seconds=float(sum(conv.seconds) + conv.onset_seconds),
                      accuracy=accuracy,
                      verdict=verdict)


def _with_seconds(conv, seconds: float):
    from dataclasses import replace

    return replace(conv, seconds=tuple(conv.seconds) + (seconds,))


def format_cross_check(cc: CrossCheck) -> str:
    """Plain-text table of a `CrossCheck` and its verdict."""
    h = cc.exudyn_steps
    lines = [f"converged peaks: reduced at accuracy {cc.accuracy:g} ({cc.reduced_seconds:.3g} "
             f"s); exudyn at steps {h[0]:.3g}, {h[1]:.3g}, {h[2]:.3g} s, extrapolated "
             f"({cc.exudyn_seconds:.3g} s)", ""]
    head = (f"{'rev':>3}  {'reduced (N)':>12}  {'+-':>9}  {'exudyn (N)':>12}  {'+-':>9}  "
            f"{'order':>5}  {'difference':>10}  {'bars':>9}  within bars")
    lines += [head, "-" * len(head)]
    for k in range(len(cc.reduced)):
        order = "-" if not np.isfinite(cc.exudyn_order[k]) else f"{cc.exudyn_order[k]:.2f}"
        lines.append(f"{k + 1:>3}  {cc.reduced[k]:>12.3f}  {cc.reduced_error[k]:>9.3g}  "
                     f"{cc.exudyn[k]:>12.3f}  {cc.exudyn_error[k]:>9.3g}  {order:>5}  "
                     f"{_pct(cc.exudyn[k] / cc.reduced[k] - 1):>10}  "
                     f"{_pct(cc.bars[k] / cc.reduced[k]):>9}  "
                     f"{'no' if cc.model_difference[k] else 'yes'}")
    lines += ["", "+-: each model's error estimate (reduced: its own, from a second run; "
              "exudyn: the difference of its h/2 and h/4 peaks, or the larger step difference "
              "where the observed order is outside [1, 4] and nothing is extrapolated); "
              "difference: exudyn / reduced - 1; bars: the two error bars together, "
              "relative to the reduced peak"]
    if cc.verdict is not None:
        if cc.verdict.kind == "not comparable peak by peak":
            lines += ["", format_verdict(cc.verdict)]
        else:
            lines += ["", cc.verdict.summary()]
    return "\n".join(lines)


def _backend_options(backend: str, other: str, args, mech) -> dict:
    options = {}
    if backend == "reduced":
        if args.rtol is not None:
            options["rtol"] = args.rtol
        h_max = args.h_max
        if h_max is None and other == "exudyn":
            # sample the adaptive model at least as densely as the fixed-step one: linear
            # interpolation between its long free-flight steps would otherwise cut the
            # curved orbit and show up as a spurious orbit distance
            h_max = _exudyn_step(args, mech)
        if h_max is not None:
            options["h_max"] = h_max
    if backend == "exudyn":
        for name in ("step_size", "accuracy", "contact"):
            if getattr(args, name, None) is not None:
                options[name] = getattr(args, name)
        _exudyn_settings(options, mech)        # bad values fail before any simulation runs
    return options


def _exudyn_settings(options: dict, mech):
    from mbs_clearance.backends.exudyn_linkage import make_settings

    return make_settings(dict(options))


def _exudyn_step(args, mech) -> float:
    """The Exudyn run's fixed step in s (its default for `mech` unless given; with
    --accuracy the step the second-order law gives for it: the reduced run's sampling
    bound)."""
    options = {k: getattr(args, k) for k in ("step_size", "accuracy")
               if getattr(args, k, None) is not None}
    from mbs_clearance.model.cases import as_linkage

    return _exudyn_settings(options, mech).step(as_linkage(mech))


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    """Arguments of ``mbs-clearance compare`` (added to `parser` if given)."""
    from mbs_clearance.cli import (
        Parser,
        add_force_option,
        add_linkage_options,
        add_mechanism_options,
        add_window_options,
        int_at_least,
        positive_float,
        positive_time,
    )
    from mbs_clearance.solve.simulate import BACKENDS

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
    parser.add_argument("--revolutions", type=int_at_least(1),
                        help="crank revolutions (default: 4)")
    parser.add_argument("--rtol", type=positive_float,
                        help="relative tolerance (reduced backend)")
    parser.add_argument("--h-max", type=positive_time,
                        help="largest step in s (reduced backend); default: the Exudyn step "
                             "size when compared with exudyn")
    parser.add_argument("--step-size", type=positive_time,
                        help="time step in s (exudyn backend; default: its default step)")
    parser.add_argument("--accuracy", type=positive_float,
                        help="target relative peak error (exudyn backend): runs at steps h, "
                             "h/2, h/4, ... until the extrapolated peaks' error estimate "
                             "meets it (the verdict's bar for exudyn; instead of "
                             "--step-size)")
    parser.add_argument("--no-step-bars", action="store_true",
                        help="without --accuracy, Exudyn's run at its step gets its error "
                             "bars from two more runs at half and a quarter of that step "
                             "(about 6 times its time; only where the motion is comparable "
                             "peak by peak); this skips them, and a difference beyond the "
                             "bars is then 'not decided: no error bar'")
    parser.add_argument("--contact", help="contact variant (exudyn backend): symbolic, "
                                          "python or sphere")
    parser.add_argument("--converged", action="store_true",
                        help="also the converged cross-check: the reduced model at a "
                             "requested accuracy (--converged-accuracy) and Exudyn at the "
                             "steps h, h/2, h/4 (h: --step-size or its default), "
                             "extrapolated, each with its error bar and the time it needed; "
                             "'model difference' where the difference exceeds the bars")
    parser.add_argument("--converged-accuracy", type=positive_float, default=1e-6,
                        help="requested accuracy of the reduced model in the converged "
                             "cross-check")
    parser.add_argument("--out", type=Path, default=Path("compare_overlay.png"),
                        help="overlay figure (PNG); default compare_overlay.png")
    parser.add_argument("--no-plot", action="store_true", help="do not write the figure")
    add_window_options(parser, "its peaks are compared per --window",
                       "the time windows in s whose peaks are compared, a whole number of "
                       "them in --duration (default: one window, the whole run)")
    add_force_option(parser)
    add_linkage_options(parser)
    add_mechanism_options(parser)
    return parser


def compare_free(linkage, duration: float, window: float | None = None, *,
                 accuracy: float = 1e-6, exudyn_accuracy: float | None = 1e-4,
                 **exudyn_options):
    """A free linkage (no drive) in both models over `duration` s, its peaks per time
    `window`: (reduced Trajectory, Exudyn Trajectory, Verdict). The reduced model at
    `accuracy`, Exudyn converged by step halving to `exudyn_accuracy` (None: one run at its
    step, no bar), each peak with its own bar (Exudyn's per window, N); comparable peak by
    peak (`verdict.comparable`: a transient from one initial state)."""
    from mbs_clearance.analysis.verdict import verdict_of_peaks, with_missing_bars
    from mbs_clearance.solve.simulate import simulate

    span = {"duration": duration, "window": window}
    a = simulate(linkage, accuracy=accuracy, **span)
    b = simulate(linkage, backend="exudyn", accuracy=exudyn_accuracy, **span,
                 **exudyn_options)
    pa, pb = np.asarray(a.peaks, dtype=float), np.asarray(b.peaks, dtype=float)
    ea = float(a.stats.get("error_estimate", 0.0)) * np.abs(pa)
    eb = np.asarray(b.stats.get("peak_errors", np.zeros_like(pb)), dtype=float)
    v = verdict_of_peaks(pa, ea, pb, eb, model_a="reduced", model_b="exudyn",
                         span="window", transient=True)
    return a, b, with_missing_bars(v, [] if "peak_errors" in b.stats else ["exudyn"])


def paper_peak_line(mech, result: Comparison) -> str | None:
    """The paper's peak of |F12| over revolution 4 (its Table 3) beside both models' peaks,
    for the paper's case at its original design or at its published optimum (the lengths
    changed, the masses fixed); None for any other mechanism or fewer than 4 revolutions."""
    from mbs_clearance.model.mechanism import SliderCrank
    from mbs_clearance.studies.optimize import PAPER_TABLE3

    rev4 = [r for r in result.revolutions if r.revolution == 4]
    for design in ("original", "optimum"):
        row = PAPER_TABLE3[design]
        if rev4 and mech == SliderCrank(crank_length=row["crank_length"],
                                        coupler_length=row["coupler_length"]):
            paper = row["peak_force"]
            return (f"the paper's peak in revolution 4 ({design} design): {paper:g} N; "
                    f"a against it {_pct_of(rev4[0].peak_a, paper)}, b against it "
                    f"{_pct_of(rev4[0].peak_b, paper)}")
    return None


def run_compare(args: argparse.Namespace) -> int:
    """Body of ``mbs-clearance compare`` for parsed arguments; returns the exit code."""
    from mbs_clearance._io import atomic_file, check_output_file
    from mbs_clearance.cli import (
        check_run_size,
        figure_suffixes,
        linkage_from_args,
        mechanism_from_args,
        refuse_window_options,
    )
    from mbs_clearance.solve.simulate import simulate

    mech = linkage_from_args(args) or mechanism_from_args(args)
    if getattr(mech, "drive", True) is None:
        return _run_compare_free(mech, args)
    refuse_window_options(args, "--revolutions")
    if args.revolutions is None:
        args.revolutions = 4
    if args.revolutions < 1:
        raise ValueError(f"--revolutions must be >= 1; got {args.revolutions}")
    # the sizes before any work, each backend's run by its own step
    for backend in {args.backend_a, args.backend_b}:
        check_run_size(mech, "--revolutions", args.revolutions, backend=backend,
                       step_size=args.step_size, accuracy=args.accuracy)
    if args.h_max is not None:
        check_run_size(mech, "--revolutions", args.revolutions, step_size=args.h_max,
                       backend="exudyn", step_option="--h-max")
    if not args.no_plot:
        check_output_file(args.out, "--out", args.force, suffixes=figure_suffixes())
    pair = (args.backend_a, args.backend_b)
    all_options = [_backend_options(be, other, args, mech)
                   for be, other in (pair, pair[::-1])]
    trajectories = []
    for backend, options in zip(pair, all_options):
        t0 = time.perf_counter()
        trajectories.append(simulate(mech, args.revolutions, backend=backend, **options))
        print(f"{backend}: {time.perf_counter() - t0:.3g} s", file=sys.stderr, flush=True)
    result = compare(*trajectories, step_bars=not args.no_step_bars)
    print(format_table(result))
    paper = paper_peak_line(mech, result)
    if paper:
        print(paper)
    if args.converged:
        if set(pair) != {"reduced", "exudyn"}:
            raise ValueError("--converged compares the reduced and exudyn backends")
        options = {"contact": args.contact} if args.contact is not None else {}
        cc = cross_check(mech, args.revolutions, accuracy=args.converged_accuracy,
                         step_size=args.step_size, **options)
        print()
        print(format_cross_check(cc))
    if not args.no_plot:
        with atomic_file(args.out) as tmp:
            if hasattr(mech, "clearance_joints"):
                plot_linkage_comparison(*trajectories, path=tmp)
            else:
                from mbs_clearance.plotting import plot_comparison

                plot_comparison(*trajectories, path=tmp)
        print(f"figure written to {args.out}", file=sys.stderr)
    return 0


def _run_compare_free(linkage, args: argparse.Namespace) -> int:
    """`run_compare` for a free linkage: `compare_free` over --duration in --window's, the
    verdict table (a figure is not drawn: the overlay figures follow drive revolutions)."""
    from mbs_clearance.cli import check_run_size, free_window

    free_window(linkage, args, "revolutions")     # --duration, a whole number of --window
    for backend in ("reduced", "exudyn"):
        check_run_size(linkage, "--duration", args.duration, unit="s", backend=backend,
                       step_size=args.step_size)
    options = {"contact": args.contact} if args.contact is not None else {}
    if args.step_size is not None:
        options["step_size"] = args.step_size
    accuracy = None if args.step_size is not None else (args.accuracy or 1e-4)
    t0 = time.perf_counter()
    a, b, verdict = compare_free(linkage, args.duration, args.window,
                                 accuracy=args.converged_accuracy, exudyn_accuracy=accuracy,
                                 **options)
    print(f"compared in {time.perf_counter() - t0:.3g} s", file=sys.stderr, flush=True)
    print(format_verdict(verdict))
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
