"""Figures checked by what they draw: data in the axis units the labels state, markers at
the design's coordinates, outlines around the cells they name."""

from __future__ import annotations

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


def test_report_regime_figure_draws_in_mm_and_rpm(paper_map, tmp_path, monkeypatch):
    """The report's figure is the library's, not converted a second time."""
    from mbs_clearance_validation.report import plot_regimes

    from mbs_clearance import plotting

    figures = []

    def recorded(*args, **kwargs):
        figures.append(plot_regime_map(*args, **kwargs))
        return figures[-1]

    monkeypatch.setattr(plotting, "plot_regime_map", recorded)
    nc = tmp_path / "map.nc"
    paper_map.to_netcdf(nc)
    assert plot_regimes(nc, tmp_path / "regime_map.png").stat().st_size > 0
    ax = figures[0].axes[0]
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
