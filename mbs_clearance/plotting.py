"""All figures of mbs-clearance (the only module that imports matplotlib).

Figures are built with the object-oriented API (`matplotlib.figure.Figure`), so no GUI
backend is ever needed; every function returns the Figure and saves it when given a path.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ._checks import check_int
from ._io import PNG_SOFTWARE
from .solve.trajectory import Trajectory
from .units import number

__all__ = ["backend_label", "plot_branch", "plot_trajectory", "plot_overlay", "plot_comparison",
           "plot_sensitivities",
           "plot_work_precision", "plot_fitness_history", "plot_force_comparison",
           "SENSITIVITY_FIGURES", "save", "plot_bifurcation", "plot_regime_map",
           "plot_poincare", "animate_mechanism", "mechanism_frames", "MechanismFrames",
           "magnification", "plot_wear",
           "DRAWN_BEARING", "JOURNAL_GAP"]

COLORS = ["C0", "C3", "C2", "C1", "C4", "C5"]

#: the sensitivity methods in words (figure titles)
METHOD_NAMES = {"ddm": "direct differentiation", "fd": "finite differences"}


def save(fig: Figure, path: str | Path | None, dpi: int = 120) -> Figure:
    """Save `fig` to `path` (format from the suffix) if a path is given; return `fig`."""
    if path is not None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        # the Software field marks the figure as ours (the CLI overwrites only such files)
        metadata = {"Software": PNG_SOFTWARE} if path.suffix.lower() == ".png" else None
        fig.savefig(path, dpi=dpi, bbox_inches="tight", metadata=metadata)
    return fig


def _crank_deg(traj: Trajectory) -> np.ndarray:
    return np.degrees(traj.crank_angle)


#: how a backend is named in legends and titles
BACKEND_NAMES = {"reduced": "reduced model", "exudyn": "Exudyn", "ideal": "ideal joints"}


def backend_label(traj: Trajectory) -> str:
    """The legend name of `traj`'s model: "reduced model", "Exudyn (symbolic contact)", ..."""
    name = BACKEND_NAMES.get(traj.backend, traj.backend)
    contact = traj.stats.get("contact")
    return f"{name} ({contact} contact)" if contact else name


def plot_overlay(trajs: Sequence[Trajectory], labels: Sequence[str] | None = None,
                 revolution: int | None = None, path: str | Path | None = None,
                 title: str | None = None) -> Figure:
    """Four panels like the paper's Fig. 3 for one or more trajectories.

    (a) |F12| and (b) crank moment versus crank angle over `revolution` (default: the last
    full one), (c) slider acceleration versus velocity, (d) journal-centre orbit inside the
    clearance circle (in units of the clearance).
    """
    labels = list(labels) if labels is not None else [backend_label(t) for t in trajs]
    fig = Figure(figsize=(11, 8), layout="constrained")
    axes = fig.subplots(2, 2)
    ax_f, ax_m, ax_ph, ax_orb = axes.ravel()
    for k, (traj, label) in enumerate(zip(trajs, labels)):
        rev = revolution or traj.revolutions
        mask = traj.revolution_mask(rev)
        ang = _crank_deg(traj)[mask] - 360.0 * (rev - 1)
        col = COLORS[k % len(COLORS)]
        lw = 1.2 if k == 0 else 0.9
        ax_f.plot(ang, traj.base_force_magnitude[mask], color=col, lw=lw, label=label)
        ax_m.plot(ang, traj.crank_moment[mask], color=col, lw=lw, label=label)
        ax_ph.plot(traj.slider_velocity[mask], traj.slider_acceleration[mask], color=col,
                   lw=0.7, label=label)
        c = traj.mechanism.clearance
        ecc = traj.eccentricity / c
        ax_orb.plot(ecc[:, 0], ecc[:, 1], color=col, lw=0.6, label=label)
    phi = np.linspace(0, 2 * np.pi, 361)
    ax_orb.plot(np.cos(phi), np.sin(phi), "k--", lw=0.8, label="clearance circle")
    ax_orb.set_aspect("equal")
    ax_f.set(xlabel="crank angle in revolution (deg)", ylabel="|F12| (N)",
             title="(a) base reaction force")
    ax_m.set(xlabel="crank angle in revolution (deg)", ylabel="crank moment M2 (N m)",
             title="(b) crank driving moment")
    ax_ph.set(xlabel="slider velocity (m/s)", ylabel="slider acceleration (m/s$^2$)",
              title="(c) slider phase plot")
    ax_orb.set(xlabel="journal x / clearance (-)", ylabel="journal y / clearance (-)",
               title="(d) journal centre orbit (all revolutions)")
    for ax in axes.ravel():
        ax.grid(alpha=0.3)
    ax_f.legend(loc="upper right", fontsize=8)
    ax_orb.legend(loc="upper right", fontsize=7)
    if title:
        fig.suptitle(title)
    return save(fig, path)


def plot_trajectory(traj: Trajectory, path: str | Path | None = None,
                    revolution: int | None = None) -> Figure:
    """The paper's Fig. 3 panels for one trajectory (see `plot_overlay`)."""
    m = traj.mechanism
    title = (f"{backend_label(traj)}: clearance {m.clearance * 1e3:.3g} mm, "
             f"{m.crank_speed_rpm:.0f} rpm, e = {m.restitution:g}")
    return plot_overlay([traj], [backend_label(traj)], revolution=revolution, path=path,
                        title=title)


#: the paper's grouping of the sensitivity figures
SENSITIVITY_FIGURES = {
    "fig4_kinematic": ("Fig. 4: kinematic properties",
                       ("crank_length", "coupler_length", "coupler_mass", "slider_mass")),
    "fig5_contact": ("Fig. 5: contact properties",
                     ("contact_stiffness", "youngs_modulus", "restitution")),
    "fig6_journal": ("Fig. 6: journal radius (clearance)", ("journal_radius",)),
}


def plot_sensitivities(sens, parameters: Sequence[str], title: str = "",
                       revolution: int | None = None,
                       zooms: Sequence[tuple[float, float]] = ((50, 70), (170, 190),
                                                                (290, 310)),
                       path: str | Path | None = None) -> Figure:
    """Normalized sensitivity of |F12| (Eq. 15) over one crank revolution and zoomed windows,
    like the paper's Figs. 4-6. `sens` is a `Sensitivities`; `zooms` are crank-angle windows
    in degrees. A free linkage (no revolutions): over the whole run, against time."""
    rev = revolution or sens.trajectory.revolutions
    if not rev:
        return _plot_free_sensitivities(sens, parameters, title, path)
    mask = sens.revolution_mask(rev)
    ang = np.degrees(sens.trajectory.crank_angle[mask]) - 360.0 * (rev - 1)
    fig = Figure(figsize=(11, 7), layout="constrained")
    grid = fig.add_gridspec(2, len(zooms))
    main = fig.add_subplot(grid[0, :])
    zoom_axes = [fig.add_subplot(grid[1, i]) for i in range(len(zooms))]
    for i, name in enumerate(parameters):
        k = sens.column(name)
        y = sens.normalized[mask, k]
        col = COLORS[i % len(COLORS)]
        main.plot(ang, y, color=col, lw=1.0, label=name)
        for ax, (a, b) in zip(zoom_axes, zooms):
            sel = (ang >= a) & (ang <= b)
            ax.plot(ang[sel], y[sel], color=col, lw=1.0)
    for a, b in zooms:
        main.axvspan(a, b, color="0.85", zorder=0)
    main.set(xlabel="crank angle in revolution (deg)",
             ylabel="normalized sensitivity of |F12| (-)",
             title=f"{title} ({METHOD_NAMES.get(sens.method, sens.method)}, revolution {rev})")
    main.legend(fontsize=8, ncol=len(parameters), loc="upper right")
    for ax, (a, b) in zip(zoom_axes, zooms):
        ax.set(xlabel="crank angle (deg)", ylabel="normalized sensitivity (-)",
               title=f"zoom {a:g}-{b:g} deg")
    for ax in [main, *zoom_axes]:
        ax.grid(alpha=0.3)
    return save(fig, path)


def _plot_free_sensitivities(sens, parameters, title, path) -> Figure:
    """Normalized sensitivity of the monitored force over a free linkage's whole run."""
    fig = Figure(figsize=(11, 4.5), layout="constrained")
    ax = fig.add_subplot()
    t_ms = 1e3 * np.asarray(sens.t)
    for i, name in enumerate(parameters):
        ax.plot(t_ms, sens.normalized[:, sens.column(name)], color=COLORS[i % len(COLORS)],
                lw=1.0, label=name)
    ax.set(xlabel="time (ms)", ylabel="normalized sensitivity of the monitored force (-)",
           title=f"{title} ({METHOD_NAMES.get(sens.method, sens.method)}, free linkage)")
    ax.legend(fontsize=8, ncol=len(parameters), loc="upper right")
    ax.grid(alpha=0.3)
    return save(fig, path)


def plot_comparison(a: Trajectory, b: Trajectory, path: str | Path | None = None,
                    revolution: int | None = None) -> Figure:
    """Overlay |F12|, the crank moment and the journal orbit of two trajectories.

    Parameters
    ----------
    a, b : Trajectory
        Same mechanism, e.g. the reduced and the Exudyn model.
    path : str or Path or None
        File to write; None returns the figure without saving.
    revolution : int or None
        Revolution shown in the time plots (default: the last one both cover); the orbit
        shows the whole common time span.
    """
    mech = a.mechanism
    n = min(a.revolutions, b.revolutions)
    k = n if revolution is None else revolution
    if not isinstance(k, (int, np.integer)) or not 1 <= k <= n:
        raise ValueError(f"revolution must be between 1 and {n}; got {revolution!r}")
    c = mech.clearance
    fig = Figure(figsize=(15, 4.5), layout="constrained")
    axes = fig.subplots(1, 3)
    for tr, style in ((a, dict(color="C0", lw=1.6)), (b, dict(color="C3", lw=1.0, ls="--"))):
        m = tr.revolution_mask(k)
        angle = np.degrees(tr.crank_angle[m] - 2 * np.pi * (k - 1))
        label = backend_label(tr)
        axes[0].plot(angle, tr.base_force_magnitude[m], label=label, **style)
        axes[1].plot(angle, tr.crank_moment[m], label=label, **style)
        mo = tr.t <= n * mech.period * (1 + 1e-12)
        axes[2].plot(tr.eccentricity[mo, 0] / c, tr.eccentricity[mo, 1] / c, label=label,
                     **{**style, "lw": 0.6})
    axes[0].set(xlabel=f"crank angle in revolution {k} (deg)", ylabel="|F12| (N)",
                title="base force magnitude")
    axes[1].set(xlabel=f"crank angle in revolution {k} (deg)", ylabel="M2 (N m)",
                title="crank driving moment")
    phi = np.linspace(0.0, 2 * np.pi, 361)
    axes[2].plot(np.cos(phi), np.sin(phi), color="0.5", lw=0.8, label="clearance circle")
    axes[2].set(xlabel="journal x / clearance (-)", ylabel="journal y / clearance (-)",
                title="journal centre orbit", aspect="equal")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    fig.suptitle(f"{backend_label(a)} vs {backend_label(b)}: c = {c * 1e3:.4g} mm, "
                 f"{mech.crank_speed_rpm:.0f} rpm")
    return save(fig, path)


def plot_work_precision(rows: Sequence[dict], path: str | Path | None = None,
                        error: str = "peak_error") -> Figure:
    """Run time against error (log-log), one panel per case, one line per backend/method.

    `rows` are dicts with keys case, backend, method, time (s) and `error`.
    """
    cases = list(dict.fromkeys(r["case"] for r in rows))
    fig = Figure(figsize=(6.5 * len(cases), 5), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(cases)))
    markers = {"reduced (ours)": "o", "scipy": "s", "exudyn": "^"}
    for ax, case in zip(axes, cases):
        groups = dict.fromkeys((r["backend"], r["method"]) for r in rows if r["case"] == case)
        for i, key in enumerate(groups):
            pts = sorted((r[error], r["time"]) for r in rows
                         if r["case"] == case and (r["backend"], r["method"]) == key
                         and np.isfinite(r[error]) and r[error] > 0)
            if pts:
                e, t = np.array(pts).T
                ax.loglog(e, t, marker=markers.get(key[0], "x"), color=COLORS[i % 6] if i < 6
                          else f"C{i}", label=f"{key[0]}: {key[1]}")
        ax.set(xlabel="relative error of the peak |F12| (-)" if error == "peak_error"
               else "max base-force error / peak (-)", ylabel="median run time (s)",
               title=case)
        ax.invert_xaxis()
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7, loc="upper left")
    return save(fig, path)


def plot_fitness_history(result, path: str | Path | None = None) -> Figure:
    """Best max |F12| of the population versus generation (paper Fig. 7a).

    Parameters
    ----------
    result : OptimizationResult
        ``result.history`` (generations_completed + 1,) N is plotted; the original design's
        peak and the refined optimum are drawn as horizontal lines.
    path : str or Path, optional
        Where to save the figure (format from the suffix).
    """
    history = np.asarray(result.history, dtype=float)
    fig = Figure(figsize=(6.5, 4.2), layout="constrained")
    ax = fig.subplots()
    ax.plot(np.arange(len(history)), history, "o-", color="C0", ms=3, lw=1.2,
            label="GA: best of population")
    ax.axhline(result.original_peak_force, color="C3", ls="--", lw=1.0,
               label=f"original design ({result.original_peak_force:.0f} N)")
    ax.axhline(result.best_peak_force, color="C2", ls=":", lw=1.2,
               label=f"after refinement ({result.best_peak_force:.1f} N)")
    settings = result.settings
    ax.set(xlabel="generation", ylabel="max |F12| over revolution "
           f"{settings.get('revolution', 4)} (N)",
           title=f"GA fitness history (population {settings.get('population')}, seed "
                 f"{settings.get('seed')}, masses {settings.get('mass_scaling')})")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    return save(fig, path)


def plot_force_comparison(trajectories: Mapping[str, Trajectory],
                          path: str | Path | None = None, revolution: int = 4) -> Figure:
    """|F12| versus crank angle over revolution `revolution` for several designs (paper
    Fig. 7b). `trajectories` maps a label ("original", "optimum", ...) to its Trajectory; the
    first two are drawn solid, the others dashed."""
    fig = Figure(figsize=(7.5, 4.5), layout="constrained")
    ax = fig.subplots()
    colors = ["C3", "C0", "C2", "C1", "C4"]
    backends = set()
    for k, (label, traj) in enumerate(trajectories.items()):
        mech = traj.mechanism
        backends.add(traj.backend)
        mask = traj.revolution_mask(revolution)
        angle = np.degrees(traj.crank_angle[mask]) - 360.0 * (revolution - 1)
        peak = traj.max_base_force(revolution)
        ax.plot(angle, traj.base_force_magnitude[mask], color=colors[k % len(colors)],
                lw=1.2 if k < 2 else 1.0, ls="-" if k < 2 else "--",
                label=f"{label}: L2 = {mech.crank_length * 100:.4g} cm, "
                      f"L3 = {mech.coupler_length * 100:.4g} cm, max {peak:.0f} N")
    ax.set(xlabel="crank angle in revolution (deg)", ylabel="|F12| (N)",
           title=f"base reaction force, revolution {revolution} "
                 f"({', '.join(sorted(backends))} model)", xlim=(0.0, 360.0))
    ax.set_xticks(np.arange(0, 361, 45))
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    return save(fig, path)


# ---------------------------------------------------------------- regime maps

#: colour of each regime code (poincare.REGIMES)
REGIME_COLORS = {0: "#ffffff", 1: "#000000", 2: "#4c9be8", 3: "#8fd175", 4: "#f2c14e",
                 5: "#d9534f", 6: "#b07cc6", 7: "#9e9e9e", 8: "#e0e0e0"}


#: swept field -> (axis label, factor from SI to the plotted unit)
_AXIS_UNITS = {"clearance": ("clearance (mm)", 1e3),
               "crank_speed": ("crank speed (rpm)", 60.0 / (2.0 * np.pi))}


def _axis_label(ds, name: str) -> str:
    return _AXIS_UNITS.get(name, (name, 1.0))[0]


def _axis_factor(name: str) -> float:
    """Factor from a swept field's SI value to its plotted unit (mm, rpm; else 1)."""
    return _AXIS_UNITS.get(name, (name, 1.0))[1]


def _field_text(name: str, value: float) -> str:
    """``clearance = 0.0158 mm``: a swept field's value in its plotted unit."""
    label, factor = _AXIS_UNITS.get(name, (name, 1.0))
    unit = label[label.index("(") + 1:-1] if label.endswith(")") else ""
    base = label[:label.index(" (")] if unit else label
    return f"{base} = {number(value * factor, 3)}" + (f" {unit}" if unit else "")


def _sweep_dims(ds) -> list[str]:
    return [d for d in ds["regime"].dims]


def plot_bifurcation(ds, path: str | Path | None = None, joint: int = 0,
                     component: str = "x", fixed: Mapping | None = None) -> Figure:
    """Bifurcation diagram of a regime map (`sweep.regime_map`'s dataset): the kept
    section samples of `component` of clearance joint `joint` (in clearances, or
    clearance x speed for rates) against the first swept field, coloured by regime; a
    two-field map is cut at `fixed` ({other field: value}, nearest; default its first
    value)."""
    from .analysis.poincare import REGIMES

    dims = _sweep_dims(ds)
    sel = ds
    if len(dims) == 2:
        other = dims[1]
        value = (fixed or {}).get(other, float(ds[other].values[0]))
        sel = ds.sel({other: value}, method="nearest")
    x = sel[dims[0]].values * _axis_factor(dims[0])
    c = sel["joint_clearance"].values[:, joint]
    comp = list(ds["component"].values).index(component)
    y = sel["section"].values[:, :, joint, comp] / c[:, None]
    if component.endswith("dot"):
        y = y / _speed_of(sel, len(x))
    fig = Figure(figsize=(7.5, 4.2))
    ax = fig.subplots()
    regime = sel["regime"].values
    for code in np.unique(regime):
        rows = regime == code
        xs = np.repeat(x[rows], y.shape[1])
        ax.plot(xs, y[rows].ravel(), ".", ms=2.0, color=REGIME_COLORS.get(int(code), "k"),
                label=REGIMES[int(code)].replace("_", " "))
    if ds[dims[0]].attrs.get("spacing") == "log":
        ax.set_xscale("log")
    ax.set_xlabel(_axis_label(ds, dims[0]))
    unit = "clearance x crank speed" if component.endswith("dot") else "clearance"
    ax.set_ylabel(f"section {component} of {ds['joint'].values[joint]} ({unit})")
    title = "bifurcation diagram"
    if len(dims) == 2:
        from .units import quantity

        si_unit = {"clearance": "m", "crank_speed": "rad/s"}.get(dims[1], "-")
        value = quantity(float(sel[dims[1]].values), si_unit)
        title += f" at {dims[1].replace('_', ' ')} = {value}"
    ax.set_title(title)
    ax.legend(fontsize=8, markerscale=4, loc="upper left")
    return save(fig, path)


def _speed_of(sel, n: int) -> np.ndarray:
    """The crank speed (rad/s) of each point of a 1-D cut: swept, or the base design's."""
    import json

    if "crank_speed" in sel.coords:
        return np.broadcast_to(np.asarray(sel["crank_speed"].values, float), (n,))[:, None]
    base = json.loads(sel.attrs["base_design"])
    speed = base.get("crank_speed", base.get("drive", {}).get("speed", 1.0))
    return np.full((n, 1), float(speed))


def plot_regime_map(ds, path: str | Path | None = None, mark: Mapping | None = None,
                    outline: str | None = None, mark_label: str = "design",
                    title: str = "regime map") -> Figure:
    """2-D regime map of a two-field regime map dataset: each point's regime as a coloured
    cell (log axes for log sweeps), clearance in mm and crank speed in rpm.

    Parameters
    ----------
    ds : xarray.Dataset
        A map made by `regime_map` over two fields.
    path : str or Path, optional
        Where to save the figure (format from the suffix).
    mark : mapping, optional
        ``{field: value}`` in SI units: a design to mark with a star, e.g. the paper's.
    outline : str, optional
        A regime name (`poincare.REGIMES`, e.g. ``"period_1"``) whose cells are outlined.
    mark_label, title : str
        The star's legend entry and the axes' title.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from .analysis.poincare import REGIME_CODES, REGIMES

    dims = _sweep_dims(ds)
    if len(dims) != 2:
        raise ValueError(f"plot_regime_map needs a map over two fields; got {dims}")
    if outline is not None and outline not in REGIME_CODES:
        raise ValueError(f"outline must be one of {sorted(REGIME_CODES)}; got {outline!r}")
    ex, ey = (_edges(ds[d].values * _axis_factor(d), ds[d].attrs.get("spacing"))
              for d in dims)
    codes = sorted(REGIMES)
    rgb = np.array([[int(REGIME_COLORS[k][i:i + 2], 16) / 255 for i in (1, 3, 5)]
                    for k in codes])
    regime = ds["regime"].values.astype(int)
    img = rgb[regime]                                   # (nx, ny, 3)
    fig = Figure(figsize=(7.5, 5.0))
    ax = fig.subplots()
    ax.pcolormesh(ex, ey, np.transpose(img, (1, 0, 2)), shading="flat")
    for name, axis in ((dims[0], "x"), (dims[1], "y")):
        if ds[name].attrs.get("spacing") == "log":
            getattr(ax, f"set_{axis}scale")("log")
    handles = [Patch(color=REGIME_COLORS[k], label=REGIMES[k].replace("_", " "))
               for k in codes if np.any(regime == k)]
    if outline is not None:
        for xs, ys in _region_outline(regime == REGIME_CODES[outline], ex, ey):
            ax.plot(xs, ys, color="k", lw=2.0, solid_capstyle="projecting")
        handles.append(Line2D([], [], color="k", lw=2,
                              label=f"{outline.replace('_', '-')} region"))
    if mark:
        ax.plot([mark[dims[0]] * _axis_factor(dims[0])],
                [mark[dims[1]] * _axis_factor(dims[1])], marker="*", ms=14, color="k",
                mfc="yellow", ls="none", label=mark_label)
        handles.append(Line2D([], [], marker="*", ms=12, color="k", mfc="yellow", ls="none",
                              label=mark_label))
    ax.legend(handles=handles, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_xlabel(_axis_label(ds, dims[0]))
    ax.set_ylabel(_axis_label(ds, dims[1]))
    ax.set_title(title)
    return save(fig, path)


def _region_outline(inside: np.ndarray, ex: np.ndarray, ey: np.ndarray
                    ) -> list[tuple[list[float], list[float]]]:
    """The cell edges between the cells where `inside` (nx, ny) holds and the others (or
    the map's border), as ([x0, x1], [y0, y1]) segments on the cell edges `ex`, `ey`."""
    nx, ny = inside.shape

    def within(i, j):
        return 0 <= i < nx and 0 <= j < ny and inside[i, j]

    segments = []
    for i, j in zip(*np.nonzero(inside)):
        for di, dj, xs, ys in ((-1, 0, [ex[i]] * 2, ey[j:j + 2]),
                               (1, 0, [ex[i + 1]] * 2, ey[j:j + 2]),
                               (0, -1, ex[i:i + 2], [ey[j]] * 2),
                               (0, 1, ex[i:i + 2], [ey[j + 1]] * 2)):
            if not within(i + di, j + dj):
                segments.append((list(xs), list(ys)))
    return segments


def _edges(v: np.ndarray, spacing: str | None) -> np.ndarray:
    """Cell edges around the sample values (geometric midpoints on log axes)."""
    v = np.asarray(v, dtype=float)
    if len(v) == 1:
        return np.array([v[0] * 0.9, v[0] * 1.1]) if v[0] != 0 else np.array([-0.5, 0.5])
    if spacing == "log" and np.all(v > 0):
        lv = np.log(v)
        mid = 0.5 * (lv[1:] + lv[:-1])
        return np.exp(np.concatenate([[2 * lv[0] - mid[0]], mid, [2 * lv[-1] - mid[-1]]]))
    mid = 0.5 * (v[1:] + v[:-1])
    edges = np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])
    # a field whose samples are all positive (a speed, a clearance) has its outer cells
    # end at zero, not below it
    if np.all(v > 0):
        edges[0] = max(edges[0], 0.0)
    elif np.all(v < 0):
        edges[-1] = min(edges[-1], 0.0)
    return edges


def plot_poincare(ds, points: Sequence[Mapping], path: str | Path | None = None,
                  joint: int = 0) -> Figure:
    """Poincare portraits: the section samples (x, y in clearances) of the given sweep
    points ({field: value}, nearest), one panel each, the clearance circle drawn."""
    from .analysis.poincare import REGIMES

    n = len(points)
    fig = Figure(figsize=(3.2 * n, 3.4))
    axes = np.atleast_1d(fig.subplots(1, n))
    circle = np.linspace(0, 2 * np.pi, 200)
    for ax, point in zip(axes, points):
        sel = ds.sel(dict(point), method="nearest")
        xy = sel["section"].values[:, joint, :2] / float(sel["joint_clearance"].values[joint])
        ax.plot(np.cos(circle), np.sin(circle), color="0.7", lw=0.8)
        ax.plot(xy[:, 0], xy[:, 1], ".", ms=4)
        ax.set_aspect("equal")
        label = ", ".join(_field_text(k, float(sel[k].values)) for k in point)
        ax.set_title(f"{label}\n{REGIMES[int(sel['regime'].values)].replace('_', ' ')}",
                     fontsize=8)
        ax.set_xlabel("x / clearance")
    axes[0].set_ylabel("y / clearance")
    return save(fig, path)


def animate_mechanism(traj: Trajectory, path: str | Path, revolution: int | None = None,
                      frames: int = 72, fps: int = 12, magnify: float | None = None) -> Path:
    """Animation of the mechanism over one crank revolution (default: the last): GIF
    (Pillow) or, for a .mp4 `path`, MP4 when ffmpeg is installed. Returns the path.

    Any trajectory is drawn from its mechanism's description (`mechanism_frames`; the
    paper's `SliderCrank` from its case's `Linkage`): bodies as polylines through their
    named points, ground pivots, sliders' guides (the paper's slider a block on its guide),
    each clearance joint's bearing circle and its journal with the journal's offset
    magnified `magnify` times (default: the bearing's drawn clearance, `JOURNAL_GAP` of the
    drawn bearing radius, shows the largest clearance), the orbit of the revolution beside
    it in units of the clearance.
    """
    path = Path(path)
    if path.suffix.lower() not in (".gif", ".mp4"):
        raise ValueError(f"animation file must end in .gif or .mp4; got {str(path)!r}")
    frames = _check_frames(frames, fps)
    return _animate(traj, path, revolution, frames, fps, magnify)


def _check_frames(frames, fps) -> int:
    from ._checks import check_int

    check_int("fps (frames per second)", fps, 1)
    return check_int("frames (frames per revolution)", frames, 2)


def _writer(path: Path, fps: int):
    from matplotlib.animation import FFMpegWriter, PillowWriter

    if path.suffix.lower() == ".mp4":
        if not FFMpegWriter.isAvailable():
            raise ValueError("an .mp4 needs ffmpeg on the PATH; write a .gif instead")
        return FFMpegWriter(fps=fps)
    return PillowWriter(fps=fps)


#: drawn bearing radius as a fraction of the linkage's length scale (`Linkage.length_scale`)
DRAWN_BEARING = 0.035
#: the drawn journal's gap to its bearing (drawn bearing radius minus drawn journal radius)
#: at the largest clearance, as a fraction of the drawn bearing radius (default magnification)
JOURNAL_GAP = 0.4


@dataclass(frozen=True)
class MechanismFrames:
    """What `animate_mechanism` draws of a Linkage, per frame (F frames), in m.

    t (F,) s: the frames' times (recorded steps nearest to uniform times in the revolution);
    index (F,): their rows in the trajectory; bodies: name -> (F, k, 2) polyline through the
    body's k named points; pivots: ground point name -> (2,) of every ground revolute joint;
    guides: prismatic joint name -> (F, 2, 2) the ends of its guide (its axis over the
    slider's travel); bearings: clearance joint name -> (F, 2) the bearing centre; journals:
    -> (F, 2) the drawn journal centre, bearing + magnify x (journal - bearing) from the
    description's kinematics; bearing_radius: the drawn bearing radius; journal_radius:
    joint -> its drawn radius (the drawn gap is magnify x the joint's clearance); magnify:
    the magnification of the journals' offsets.
    """

    t: np.ndarray
    index: np.ndarray
    bodies: dict
    pivots: dict
    guides: dict
    bearings: dict
    journals: dict
    bearing_radius: float
    journal_radius: dict
    magnify: float
    revolution: int


def magnification(linkage, magnify: float | None = None) -> float:
    """The magnification of the journals' offsets that `mechanism_frames` draws `linkage`
    with: `magnify` checked (ValueError unless > 0 and <= 0.9 drawn bearing radius /
    largest clearance: a drawn journal keeps a tenth of its bearing's drawn radius), or by
    default the one that draws the largest clearance as `JOURNAL_GAP` of the drawn bearing
    radius."""
    from ._checks import check_real

    rb = DRAWN_BEARING * linkage.length_scale
    c_max = max((j.clearance for j in linkage.clearance_joints), default=linkage.min_clearance)
    if magnify is None:
        return JOURNAL_GAP * rb / c_max
    return check_real("magnify (magnification of the journals' offsets)", magnify, 0.0,
                      0.9 * rb / c_max, low_open=True)


def drawn_linkage(traj: Trajectory):
    """The `Linkage` a trajectory is drawn from: its own, or the paper's `SliderCrank`'s
    case (`cases.as_linkage`: the same coordinates and clearance joint)."""
    if traj.linkage is not None:
        return traj.linkage
    from .model.cases import as_linkage

    return as_linkage(traj.mechanism)


def _eccentricity(traj: Trajectory) -> np.ndarray:
    """(n, J, 2) journal offsets in m (the paper's SliderCrank's one joint is (n, 2))."""
    e = np.asarray(traj.eccentricity)
    return e[:, None, :] if e.ndim == 2 else e


def _world(pose, xy) -> np.ndarray:
    x, y, phi = pose[:3]
    c, s = np.cos(phi), np.sin(phi)
    return np.array([x + c * xy[0] - s * xy[1], y + s * xy[0] + c * xy[1]])


def mechanism_frames(traj: Trajectory, revolution: int | None = None, frames: int = 72,
                     magnify: float | None = None) -> MechanismFrames:
    """The drawn geometry of a trajectory (`drawn_linkage`) at `frames` times of revolution
    `revolution` (default: the last): the bodies' poses from the description's forest
    kinematics (`exudyn_linkage.body_states`, the generated model's kinematics written once
    for the description) at the recorded coordinates. ValueError for a trajectory without
    coordinates, a revolution outside the trajectory, or a `magnify` that
    would draw a journal larger than its bearing allows (> 0 and <= 0.9 drawn bearing
    radius / largest clearance)."""
    from .backends.exudyn_linkage import body_states
    from .model.linkage import GROUND, Prismatic

    linkage = drawn_linkage(traj)
    if traj.coordinates is None:
        raise ValueError(f"mechanism_frames draws a trajectory with its minimal coordinates "
                         f"(backend 'reduced' or 'exudyn'); this one of backend "
                         f"{traj.backend!r} has none")
    frames = _check_frames(frames, 1)
    rev = traj.revolutions if revolution is None else revolution
    t_a, t_b = traj.revolution_window(rev)       # ValueError for a revolution not covered
    rb = DRAWN_BEARING * linkage.length_scale
    magnify = magnification(linkage, magnify)
    times = np.linspace(t_a, t_b, frames)
    index = np.clip(np.searchsorted(traj.t, times), 0, len(traj.t) - 1)
    before = np.clip(index - 1, 0, len(traj.t) - 1)
    index = np.where(np.abs(traj.t[before] - times) < np.abs(traj.t[index] - times),
                     before, index)
    names = linkage.coordinates()
    q = np.column_stack([traj.coordinates[c] for c in names]) if names else \
        np.zeros((len(traj.t), 0))
    qd = (np.column_stack([traj.rates[c] for c in names])
          if names and traj.rates is not None else np.zeros_like(q))
    poses = [body_states(linkage, float(traj.t[i]), q[i], qd[i]) for i in index]
    points = {b.name: b.points for b in linkage.bodies}

    def world(body, point, k):
        if body == GROUND:
            return np.asarray(linkage.ground_points[point], dtype=float)
        return _world(poses[k][body], points[body][point])

    bodies = {b.name: np.array([[world(b.name, pt, k) for pt in b.points]
                                for k in range(frames)]) for b in linkage.bodies}
    pivots = {}
    guides = {}
    for j in linkage.joints:
        if isinstance(j, Prismatic):
            origin = np.array([world(j.body_a, j.point_a, k) for k in range(frames)])
            slider = np.array([world(j.body_b, j.point_b, k) for k in range(frames)])
            phi = np.array([0.0 if j.body_a == GROUND else poses[k][j.body_a][2]
                            for k in range(frames)]) + j.angle
            u = np.column_stack([np.cos(phi), np.sin(phi)])
            s = np.einsum("ij,ij->i", slider - origin, u)
            lo, hi = min(0.0, s.min()) - 2 * rb, max(0.0, s.max()) + 2 * rb
            guides[j.name] = np.stack([origin + lo * u, origin + hi * u], axis=1)
        elif GROUND in (j.body_a, j.body_b):
            point = j.point_a if j.body_a == GROUND else j.point_b
            pivots[point] = np.asarray(linkage.ground_points[point], dtype=float)
    bearings, journals, radii = {}, {}, {}
    for cj in linkage.clearance_joints:
        b = np.array([world(cj.bearing_body, cj.bearing_point, k) for k in range(frames)])
        jn = np.array([world(cj.journal_body, cj.journal_point, k) for k in range(frames)])
        bearings[cj.name] = b
        journals[cj.name] = b + magnify * (jn - b)
        radii[cj.name] = rb - magnify * cj.clearance
    return MechanismFrames(t=traj.t[index], index=index, bodies=bodies, pivots=pivots,
                           guides=guides, bearings=bearings, journals=journals,
                           bearing_radius=rb, journal_radius=radii, magnify=float(magnify),
                           revolution=rev)


def _animate(traj: Trajectory, path: Path, revolution, frames: int, fps: int,
             magnify) -> Path:
    from matplotlib.animation import FuncAnimation
    from matplotlib.patches import Circle

    fr = mechanism_frames(traj, revolution, frames, magnify)
    writer = _writer(path, fps)
    linkage = drawn_linkage(traj)
    ecc = _eccentricity(traj)
    rb = fr.bearing_radius
    every = np.concatenate([v.reshape(-1, 2) for v in
                            (*fr.bodies.values(), *fr.guides.values(),
                             *fr.bearings.values())]
                           + [np.array(list(fr.pivots.values())).reshape(-1, 2)])
    lo = every.min(axis=0) - 2.5 * rb
    hi = every.max(axis=0) + 2.5 * rb
    fig = Figure(figsize=(10, 4.2), layout="constrained")
    m_ax, o_ax = fig.subplots(1, 2, width_ratios=(2.2, 1))
    m_ax.set_xlim(lo[0], hi[0])
    m_ax.set_ylim(lo[1], hi[1])
    m_ax.set_aspect("equal")
    m_ax.set_title(f"{linkage.name}, revolution {fr.revolution}; journal offsets drawn "
                   f"{number(fr.magnify, 3)} times their size", fontsize=9)
    m_ax.set_xlabel("x (m)")
    m_ax.set_ylabel("y (m)")
    m_ax.grid(alpha=0.2)
    for xy in fr.pivots.values():
        m_ax.plot([xy[0]], [xy[1]], "^", ms=10, color="0.3", zorder=1)
    guide_lines = {n: m_ax.plot([], [], "-", lw=1.0, color="0.6", zorder=1)[0]
                   for n in fr.guides}
    body_lines = {}
    for k, (name, poly) in enumerate(fr.bodies.items()):
        col = COLORS[k % len(COLORS)]
        if poly.shape[1] == 1:       # a body with one point: a block
            body_lines[name] = m_ax.plot([], [], "s", ms=14, color=col, alpha=0.7,
                                         zorder=2)[0]
        else:
            body_lines[name] = m_ax.plot([], [], "-o", lw=3, ms=3, color=col, alpha=0.8,
                                         zorder=2, label=name)[0]
    bearing_patches = {}
    journal_patches = {}
    orbit_lines = {}
    for name in fr.bearings:
        bearing_patches[name] = m_ax.add_patch(Circle((0, 0), rb, fill=False, lw=1.2,
                                                      color="k", zorder=3))
        journal_patches[name] = m_ax.add_patch(Circle((0, 0), fr.journal_radius[name],
                                                      color="C3", alpha=0.6, zorder=3))
        orbit_lines[name] = m_ax.plot([], [], "-", lw=0.6, color="C3", zorder=3)[0]
    m_ax.legend(fontsize=7, loc="upper right")
    # the journals' orbits over the revolution, in units of their clearance
    theta = np.linspace(0, 2 * np.pi, 100)
    o_ax.plot(np.cos(theta), np.sin(theta), "k-", lw=1, label="wall (e = c)")
    mask = traj.revolution_mask(fr.revolution)
    dots = {}
    lim = 1.2
    for j, cj in enumerate(linkage.clearance_joints):
        e = ecc[:, j] / cj.clearance
        col = COLORS[(j + 1) % len(COLORS)]
        o_ax.plot(e[mask, 0], e[mask, 1], color=col, lw=0.7, alpha=0.6,
                  label=f"{cj.name} (c = {cj.clearance * 1e3:.3g} mm)")
        dots[cj.name] = o_ax.plot([], [], "o", color=col)[0]
        lim = max(lim, float(np.abs(e[mask]).max()) * 1.1)
    o_ax.set(xlim=(-lim, lim), ylim=(-lim, lim), aspect="equal",
             title="journal centre / clearance")
    o_ax.legend(fontsize=6, loc="lower right")
    rows = {cj.name: j for j, cj in enumerate(linkage.clearance_joints)}
    offsets = {name: fr.journals[name] - fr.bearings[name] for name in fr.bearings}

    def draw(k):
        for name, line in body_lines.items():
            line.set_data(fr.bodies[name][k, :, 0], fr.bodies[name][k, :, 1])
        for name, line in guide_lines.items():
            line.set_data(fr.guides[name][k, :, 0], fr.guides[name][k, :, 1])
        for name in fr.bearings:
            centre = fr.bearings[name][k]
            bearing_patches[name].center = tuple(centre)
            journal_patches[name].center = tuple(fr.journals[name][k])
            trail = centre + offsets[name]
            orbit_lines[name].set_data(trail[:, 0], trail[:, 1])
            i = fr.index[k]
            c = linkage.clearance_joints[rows[name]].clearance
            dots[name].set_data([ecc[i, rows[name], 0] / c], [ecc[i, rows[name], 1] / c])
        return ()

    anim = FuncAnimation(fig, draw, frames=frames, blit=False)
    anim.save(str(path), writer=writer, dpi=80)
    return path


# ------------------------------------------------------------------ periodic orbits

def plot_branch(branch, path=None, regime_map=None, joint: int = 0,
                component: str = "x"):
    """Bifurcation diagram of a branch: the section `component` of clearance joint `joint`
    (in clearances; rates in clearance x drive speed) against the field, stable orbits
    solid, unstable dashed, detected points marked; over the brute-force samples of a
    `regime_map` dataset (`plotting.plot_bifurcation`, a two-field map cut at the branch's
    other values) where given. Saved to `path` if given; returns the Figure."""
    from matplotlib.figure import Figure

    from .analysis.poincare import SECTION_COMPONENTS

    if component not in SECTION_COMPONENTS:
        raise ValueError(f"component must be one of {SECTION_COMPONENTS}; got {component!r}")
    J = branch.sections.shape[1]
    joint = check_int("joint", joint, 0, J - 1)
    comp = SECTION_COMPONENTS.index(component)
    y = branch.sections[:, joint, comp] / branch.clearances[:, joint]
    if component.endswith("dot"):
        y = y / _branch_speed(branch)
    x = branch.values * _axis_factor(branch.field)
    if regime_map is not None:
        fig = plot_bifurcation(regime_map, joint=joint, component=component)
        ax = fig.axes[0]
    else:
        fig = Figure(figsize=(7.5, 4.2))
        ax = fig.subplots()
        ax.set_xlabel(branch.field)
        ax.set_ylabel(f"section {component} of joint {joint} (clearance)")
        if branch.field.endswith("clearance"):
            ax.set_xscale("log")
    first = {True: True, False: True}
    start = 0
    for i in range(1, len(x) + 1):
        if i == len(x) or branch.stable[i] != branch.stable[start]:
            st = bool(branch.stable[start])
            seg = slice(start, min(i + 1, len(x)))
            ax.plot(x[seg], y[seg], "-" if st else "--", color="k", lw=1.2,
                    label=("stable period-%d orbit" if st else "unstable period-%d orbit")
                    % branch.period if first[st] else None)
            first[st] = False
            start = i
    marks = {"fold": "o", "period_doubling": "s", "neimark_sacker": "D", "grazing": "^"}
    for kind, marker in marks.items():
        pts = [p for p in branch.points if p.kind == kind]
        if pts:
            xv = np.array([p.value for p in pts])
            yv = np.interp(xv, *_monotone(branch.values, y))
            ax.plot(xv * _axis_factor(branch.field), yv, marker, mfc="none", color="C3",
                    label=kind.replace("_", " "))
    ax.legend(fontsize=7, loc="upper left")
    return save(fig, path)


def _branch_speed(branch) -> np.ndarray:
    if branch.field == "crank_speed":
        return branch.values
    return np.full(len(branch.values), float(branch.counters.get("speed", 1.0)))


def _monotone(xv, yv):
    order = np.argsort(xv, kind="stable")
    return np.asarray(xv)[order], np.asarray(yv)[order]


def plot_wear(result, path: str | Path | None = None, lives: int = 5) -> Figure:
    """A wear life (`studies.wear.WearResult`) in three panels: the worn bearing drawn over
    the joint (its wear depth magnified against the initial clearance), the wear depth
    against the angle around the joint at `lives` points of the life, and the monitored
    output's peak and the largest depth against the cycles.

    Parameters
    ----------
    result : WearResult
    path : str or Path, optional
        Where to save the figure (format from the suffix).
    lives : int
        How many states of the life to draw (evenly spread over the accepted ones).
    """
    theta = result.angles
    depth = result.depth
    c0 = result.initial_clearance
    picks = sorted(set(np.linspace(0, len(result.cycles) - 1, max(2, lives)).round().astype(int)))
    fig = Figure(figsize=(13.0, 4.2), layout="constrained")
    ax0 = fig.add_subplot(1, 3, 1, projection="polar")
    ax1 = fig.add_subplot(1, 3, 2)
    ax2 = fig.add_subplot(1, 3, 3)
    closed = np.append(theta, theta[0] + 2 * np.pi)
    for k, i in enumerate(picks):
        d = np.append(depth[i], depth[i][0])
        label = f"{number(result.cycles[i], 3)} cycles"
        # radius drawn: the clearance plus the wear, in micrometres, around the joint
        ax0.plot(closed, 1e6 * (c0 + d), color=f"C{k}", lw=1.2, label=label)
        ax1.plot(np.degrees(closed), 1e6 * d, color=f"C{k}", lw=1.2, label=label)
    ax0.set_title("bearing clearance around the joint (um)\n(bearing frame, 0 deg = its x axis)",
                  fontsize=9)
    ax0.set_rlim(0, 1e6 * (c0 + depth.max()) * 1.05)
    ax1.set(xlabel="angle around the joint, bearing frame (deg)", ylabel="wear depth (um)",
            title=f"wear of joint {result.joint!r}, k/H = {result.coefficient:.3g} m^2/N",
            xlim=(0, 360))
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=8)
    ax2.plot(result.cycles, result.peaks, "o-", color="C0", ms=3, lw=1.2)
    ax2.set(xlabel="cycles", ylabel=f"peak {result.output} (N)",
            title="peaks and largest wear depth over the life")
    ax2.grid(alpha=0.3)
    twin = ax2.twinx()
    twin.plot(result.cycles, 1e6 * result.max_depth, "s--", color="C3", ms=3, lw=1.0)
    twin.set_ylabel("largest wear depth (um)", color="C3")
    return save(fig, path)
