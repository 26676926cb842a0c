"""Figures checked by what they draw: data in the axis units the labels state, markers at
the design's coordinates, outlines around the cells they name."""

from __future__ import annotations

import re

import numpy as np
import pytest
import xarray as xr
from matplotlib.collections import QuadMesh

from mbs_clearance import SliderCrank
from mbs_clearance.analysis.poincare import REGIME_CODES
from mbs_clearance.plotting import plot_poincare, plot_regime_map

RPM = 2.0 * np.pi / 60.0        # rad/s per rpm


def _map(clearance, speed, regime) -> xr.Dataset:
    return xr.Dataset(
        {"regime": (("clearance", "crank_speed"), np.asarray(regime, dtype=np.int8))},
        coords={"clearance": ("clearance", np.asarray(clearance), {"spacing": "log"}),
                "crank_speed": ("crank_speed", np.asarray(speed), {"spacing": "lin"})})


@pytest.fixture
def paper_map():
    clearance = np.geomspace(1e-6, 1e-3, 4)              # m
    speed = np.array([500.0, 5000.0, 10000.0]) * RPM     # rad/s
    regime = np.full((4, 3), REGIME_CODES["chaotic"])
    regime[0:2, 1:3] = REGIME_CODES["period_1"]          # the 1e-6 and 1e-5 m rows, 5000+ rpm
    return _map(clearance, speed, regime)


def test_regime_map_cells_in_mm_and_rpm(paper_map):
    fig = plot_regime_map(paper_map)
    ax = fig.axes[0]
    mesh = next(c for c in ax.collections if isinstance(c, QuadMesh))
    xy = mesh.get_coordinates()                          # (ny + 1, nx + 1, 2) cell corners
    x, y = xy[..., 0], xy[..., 1]
    # the cells span the sweep in the labels' units: 1e-3 .. 1 mm, 500 .. 10000 rpm
    assert x.min() < 1e-3 < x[0, 1] and x[0, -2] < 1.0 < x.max()
    assert y.min() < 500.0 < y[1, 0] and y[-2, 0] < 10000.0 < y.max() < 15000.0
    assert "mm" in ax.get_xlabel() and "rpm" in ax.get_ylabel()
    assert ax.get_xscale() == "log"
    # the view shows the cells, not an empty area
    lo, hi = ax.get_xlim()
    assert lo <= x.min() * 1.0001 and hi >= x.max() * 0.9999


def test_regime_map_marks_the_design_and_outlines_period_1(paper_map):
    mech = SliderCrank()
    fig = plot_regime_map(paper_map, mark={"clearance": mech.clearance,
                                           "crank_speed": mech.crank_speed},
                          outline="period_1", mark_label="paper's design")
    ax = fig.axes[0]
    stars = [ln for ln in ax.lines if ln.get_marker() == "*"]
    assert len(stars) == 1
    assert stars[0].get_xdata()[0] == pytest.approx(0.01)       # mm
    assert stars[0].get_ydata()[0] == pytest.approx(5000.0)     # rpm
    outline = [ln for ln in ax.lines if ln.get_marker() != "*"]
    xs = np.concatenate([ln.get_xdata() for ln in outline])
    ys = np.concatenate([ln.get_ydata() for ln in outline])
    mesh = next(c for c in ax.collections if isinstance(c, QuadMesh)).get_coordinates()
    ex, ey = mesh[0, :, 0], mesh[:, 0, 1]
    # the period-1 block spans clearance cells 0-1 and speed cells 1-2: its outline runs
    # along exactly those cells' outer edges
    assert np.all(np.isclose(xs[:, None], ex[None, :3]).any(axis=1))
    assert xs.min() == pytest.approx(ex[0]) and xs.max() == pytest.approx(ex[2])
    assert ys.min() == pytest.approx(ey[1]) and ys.max() == pytest.approx(ey[3])
    # the design lies inside the outlined block
    assert ex[0] < 0.01 < ex[2] and ey[1] < 5000.0 < ey[3]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "period-1 region" in labels and "paper's design" in labels


def _report_regime_axes(ds, tmp_path, monkeypatch, branches=()):
    """The Axes of the report's regime figure (`plot_regimes`) of map `ds`."""
    from mbs_clearance_validation.report import plot_regimes

    from mbs_clearance import plotting

    figures = []

    def recorded(*args, **kwargs):
        figures.append(plot_regime_map(*args, **kwargs))
        return figures[-1]

    monkeypatch.setattr(plotting, "plot_regime_map", recorded)
    nc = tmp_path / "map.nc"
    ds.to_netcdf(nc)
    assert plot_regimes(nc, tmp_path / "regime_map.png", branches).stat().st_size > 0
    return figures[0].axes[0]


def test_report_regime_figure_draws_in_mm_and_rpm(paper_map, tmp_path, monkeypatch):
    """The report's figure is the library's, not converted a second time."""
    ax = _report_regime_axes(paper_map, tmp_path, monkeypatch)
    star = next(ln for ln in ax.lines if ln.get_marker() == "*")
    assert (star.get_xdata()[0], star.get_ydata()[0]) == (pytest.approx(0.01),
                                                          pytest.approx(5000.0))
    assert ax.get_xlim()[1] < 10.0 and ax.get_ylim()[1] < 15000.0
    # tick labels read in rpm (not converted again), and do not overprint each other
    labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
    values = [float(t.replace("\N{MINUS SIGN}", "-").replace(",", "")) for t in labels]
    assert max(values) <= 15000.0 and len(labels) <= 12


def test_outline_names_a_regime(paper_map):
    with pytest.raises(ValueError, match="outline must be one of"):
        plot_regime_map(paper_map, outline="period-1")


def test_poincare_titles_in_the_units_of_the_other_figures(paper_map):
    rng = np.random.default_rng(0)
    ds = paper_map.assign(
        section=(("clearance", "crank_speed", "sample", "joint", "component"),
                 rng.uniform(-1e-6, 1e-6, (4, 3, 5, 1, 4))),
        joint_clearance=(("clearance", "crank_speed", "joint"),
                         np.broadcast_to(paper_map["clearance"].values[:, None, None],
                                         (4, 3, 1)).copy()))
    fig = plot_poincare(ds, [{"clearance": 1e-5, "crank_speed": 5000 * RPM}])
    title = fig.axes[0].get_title()
    assert "clearance = 0.01 mm" in title and "crank speed = 5000 rpm" in title


def test_fig3_panels_draw_the_trajectory_in_stated_units():
    from mbs_clearance import simulate
    from mbs_clearance.plotting import plot_trajectory

    traj = simulate(SliderCrank(), 2)
    ax_f, ax_m, ax_ph, ax_orb = plot_trajectory(traj).axes
    angle, force = ax_f.lines[0].get_xdata(), ax_f.lines[0].get_ydata()
    # revolution 2 in degrees within the revolution, the force in N: its sampled maximum
    # within the sampling's reach of the located peak
    assert angle.min() >= -1e-6 and 359.0 < angle.max() <= 360.0 + 1e-6
    assert force.max() == pytest.approx(traj.max_base_force(2), rel=2e-3)
    assert force.max() <= traj.max_base_force(2) * (1 + 1e-9)
    assert "(N)" in ax_f.get_ylabel() and "(N m)" in ax_m.get_ylabel()
    mask = traj.revolution_mask(2)
    assert np.array_equal(ax_m.lines[0].get_ydata(), traj.crank_moment[mask])
    # the orbit in clearances: beyond the unit circle by the deepest penetration, which the
    # Hertz law gives from the largest contact force, delta = (F / K)^(2/3) (at the deepest
    # point the damping term vanishes, so F there is at most the largest force)
    mech = traj.mechanism
    x, y = ax_orb.lines[0].get_xdata(), ax_orb.lines[0].get_ydata()
    depth = np.hypot(x, y).max() - 1.0
    hertz = (traj.contact_force.max() / mech.stiffness) ** (2 / 3) / mech.clearance
    assert 0.9 * hertz < depth <= hertz * (1 + 1e-9)
    circle = ax_orb.lines[-1]
    assert np.allclose(np.hypot(circle.get_xdata(), circle.get_ydata()), 1.0)


def test_regime_map_speed_axis_stays_in_the_physical_domain():
    """The quick report's coarse speed sweep (500, 5250, 10000 rpm): the first cell ends at
    0 rpm, not at 2 x 500 - 2875 = -1875 rpm, and the view shows no negative speed."""
    clearance = np.geomspace(1e-6, 1e-3, 4)
    speed = np.linspace(500.0, 10000.0, 3) * RPM
    fig = plot_regime_map(_map(clearance, speed, np.full((4, 3), REGIME_CODES["period_1"])))
    ax = fig.axes[0]
    y = next(c for c in ax.collections if isinstance(c, QuadMesh)).get_coordinates()[..., 1]
    assert y.min() == pytest.approx(0.0, abs=1e-9)
    assert ax.get_ylim()[0] >= 0.0
    # the top cell still reaches half a spacing beyond the last sample
    assert y.max() == pytest.approx(10000.0 + 0.5 * 4750.0)


def _branches():
    """Two synthetic branches as the report's bifurcation section stores them: over crank
    speed (SI, rad/s) from 5000 rpm down, stable until a period doubling at 3790 rpm, and
    over clearance (m) from 0.01 mm up, stable throughout with a fold at 0.012 mm."""
    speed = np.linspace(5000.0, 3700.0, 30) * RPM
    clearance = np.linspace(1.0e-5, 1.3e-5, 20)
    return [
        {"field": "crank_speed", "values": list(speed), "section_x": list(np.sin(speed)),
         "stable": [bool(v > 3790.0 * RPM) for v in speed], "orbits": 30,
         "points": [{"kind": "period_doubling", "words": "period doubling",
                     "value": 3790.0 * RPM}]},
        {"field": "clearance", "values": list(clearance),
         "section_x": list(1e4 * clearance), "stable": [True] * 20, "orbits": 20,
         "points": [{"kind": "fold", "words": "fold", "value": 1.2e-5}]}]


def test_report_branch_figure_draws_each_branch_in_its_unit(tmp_path):
    from matplotlib import pyplot as plt
    from mbs_clearance_validation.report import plot_branches

    figures = []
    original = plt.Figure.savefig

    def keep(self, *args, **kwargs):
        figures.append(self)
        return original(self, *args, **kwargs)

    plt.Figure.savefig = keep
    try:
        plot_branches({"bifurcation": {"branches": _branches()}}, tmp_path / "b.png")
    finally:
        plt.Figure.savefig = original
    speed_ax, clearance_ax = figures[0].axes[:2]
    # over speed: the stable part solid above 3790 rpm, the unstable part dashed below
    solid = next(ln for ln in speed_ax.lines if ln.get_linestyle() == "-")
    dashed = next(ln for ln in speed_ax.lines if ln.get_linestyle() == "--")
    xs, xd = solid.get_xdata(), dashed.get_xdata()
    assert np.nanmin(xs[np.isfinite(solid.get_ydata())]) > 3790.0
    assert np.nanmax(xd[np.isfinite(dashed.get_ydata())]) < 3790.0
    assert speed_ax.get_xlim()[0] > 3000.0 and speed_ax.get_xlim()[1] < 5500.0   # rpm
    marker = next(ln for ln in speed_ax.lines if ln.get_marker() == "s")
    assert marker.get_xdata()[0] == pytest.approx(3790.0)
    assert "rpm" in speed_ax.get_xlabel() and "(-)" in speed_ax.get_ylabel()
    # over clearance, in mm
    fold = next(ln for ln in clearance_ax.lines if ln.get_marker() == "o")
    assert fold.get_xdata()[0] == pytest.approx(0.012)
    assert 0.009 < clearance_ax.get_xlim()[0] < clearance_ax.get_xlim()[1] < 0.014
    assert "mm" in clearance_ax.get_xlabel()
    # two panels a row: each about half the page width
    for ax in (speed_ax, clearance_ax):
        assert ax.get_position().width * figures[0].get_figwidth() > 4.0


def test_report_regime_figure_draws_the_branches_where_they_run(paper_map, tmp_path,
                                                               monkeypatch):
    """The branches lie on the map: the speed branch at the design's clearance (0.01 mm),
    the clearance branch at its speed (5000 rpm), each bifurcation marked there."""
    ax = _report_regime_axes(paper_map, tmp_path, monkeypatch, _branches())
    lines = [ln for ln in ax.lines if ln.get_linewidth() == 2.5]
    assert len(lines) == 2
    over_speed, over_clearance = lines
    assert np.allclose(over_speed.get_xdata(), 0.01)
    assert over_speed.get_ydata()[0] == pytest.approx(5000.0)
    assert np.allclose(over_clearance.get_ydata(), 5000.0)
    assert over_clearance.get_xdata()[-1] == pytest.approx(0.013)
    doubling = next(ln for ln in ax.lines if ln.get_marker() == "s")
    assert (doubling.get_xdata()[0], doubling.get_ydata()[0]) == (pytest.approx(0.01),
                                                                  pytest.approx(3790.0))
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert {"continuation branch", "period doubling", "fold"} <= set(labels)


def test_agreement_figure_keeps_every_panel_readable_at_page_width():
    """Five panels of the two-clearance slider-crank (three curves, two orbits): two a row
    within the report's page width, each about half of it, and the y labels name the
    quantity and its unit."""
    from mbs_clearance_validation.compare import COMPARISON_WIDTH, plot_linkage_comparison

    from mbs_clearance import simulate
    from mbs_clearance.model.cases import CASES

    linkage = CASES["slider_crank_two_clearances"]()
    a = simulate(linkage, 1, rtol=1e-7)
    b = simulate(linkage, 1, rtol=1e-9)
    fig = plot_linkage_comparison(a, b)
    fig.canvas.draw()
    shown = [ax for ax in fig.axes if ax.axison]
    assert len(shown) == 5
    assert fig.get_figwidth() <= COMPARISON_WIDTH <= 11.0
    for ax in shown:
        assert ax.get_position().width * fig.get_figwidth() > 0.3 * COMPARISON_WIDTH
        assert re.search(r"\w.* \((N|N m|-)\)$", ax.get_ylabel()), ax.get_ylabel()
    assert [ax.get_ylabel() for ax in shown[:3]] == [
        "monitored force (N)", "|shaking force| (N)", "drive moment (N m)"]


def test_agreement_figure_names_the_models_in_words():
    """Legends and the title name each model as a reader says it (no backend keys)."""
    import dataclasses

    from mbs_clearance_validation.compare import plot_linkage_comparison

    from mbs_clearance import simulate
    from mbs_clearance.model.cases import CASES

    a = simulate(CASES["slider_crank_two_clearances"](), 1)
    b = dataclasses.replace(a, backend="exudyn", stats={**a.stats, "contact": "symbolic"})
    fig = plot_linkage_comparison(a, b)
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == ["reduced model", "Exudyn (symbolic contact)"]
    assert fig.get_suptitle().endswith("reduced model vs Exudyn (symbolic contact)")
