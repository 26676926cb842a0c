"""Poincare sections, Lyapunov exponents and regime maps: each checked against an
independent reference (closed form, the generated model's sympy kinematics, two nearby runs
of the plain model, recurrence of the section)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mbs_clearance import SliderCrank, lyapunov_exponent, poincare_section, regime_map
from mbs_clearance.analysis.lyapunov import TangentFlow, textbook_exponent
from mbs_clearance.analysis.poincare import (
    REGIMES,
    Flow,
    classify,
    near_tolerance,
    section_times,
)
from mbs_clearance.studies import sweep as sweep_mod
from mbs_clearance.studies.sweep import design_at, parse_sweep

PAPER = SliderCrank()                               # 0.01 mm, 5000 rpm
LOOSE = SliderCrank(journal_radius=0.0095)          # 0.5 mm


def test_linear_system_exponent_is_the_largest_real_part_of_its_eigenvalues():
    # x' = A x: a spiral with real part 0.3 and a decaying mode; the exponent is 0.3 exactly
    A = np.array([[0.3, 2.0, 0.0], [-2.0, 0.3, 0.0], [0.0, 0.0, -1.0]])
    res = textbook_exponent("linear", 40.0, window=1.0, transient=10.0, matrix=A,
                            x0=(1.0, 0.0, 1.0), v0=(0.3, 1.0, 1.0))
    assert res.per_second == pytest.approx(max(np.linalg.eigvals(A).real), abs=1e-6)
    # the growth of each window is e^(0.3) once the decaying mode is gone
    np.testing.assert_allclose(res.log_growth[10:], 0.3, atol=1e-6)


def test_lorenz_exponent_through_the_same_integrator_and_renormalisation():
    # Lorenz (sigma 10, rho 28, beta 8/3): largest exponent 0.9056 (Sprott, Chaos and
    # Time-Series Analysis, 2003); 2000 time units give it within 2 % (measured 0.4 %)
    res = textbook_exponent("lorenz", 2000.0, window=1.0, transient=100.0)
    assert res.per_second == pytest.approx(0.9056, rel=0.02)


def test_section_times_land_on_the_crank_angle():
    mech = PAPER.replace(initial_crank_angle=0.4)
    t = section_times(mech, 5, angle=1.0)
    theta = mech.crank_speed * t + mech.initial_crank_angle
    np.testing.assert_allclose(np.mod(theta - 1.0 + 1e-9, 2 * math.pi) - 1e-9, 0.0,
                               atol=1e-9)
    assert np.all((t > np.arange(5) * mech.period) & (t <= np.arange(1, 6) * mech.period))
    # the default angle: the ends of the revolutions
    np.testing.assert_allclose(section_times(mech, 3), np.arange(1, 4) * mech.period)


def _paper_gap(mech, t, y):
    """Journal centre minus bearing centre of the paper's joint and its rate, in closed form
    from the ideal crank-coupler kinematics (docs/derivations.md, Eqs. 1-3)."""
    L2, L3, w = mech.crank_length, mech.coupler_length, mech.crank_speed
    th2 = w * t + mech.initial_crank_angle
    s2, c2 = math.sin(th2), math.cos(th2)
    s3, c3 = math.sin(y[0]), math.cos(y[0])
    return (L2 * c2 + L3 * c3 - y[1], L2 * s2 + L3 * s3,
            -L2 * w * s2 - L3 * y[2] * s3 - y[3], L2 * w * c2 + L3 * y[2] * c3)


def test_section_kinematics_match_the_generated_model():
    # the section's eccentricity and rate: the sympy-generated paper linkage against the
    # closed form
    from mbs_clearance.solve import reduced

    model, p = reduced.MODEL, reduced.model_parameters(PAPER)
    rng = np.random.default_rng(3)
    for _ in range(5):
        t = rng.uniform(0, PAPER.period)
        y = reduced.initial_state(PAPER)[:4] + rng.normal(0, 1e-4, 4) * [1, 1e-2, 1e3, 10]
        y = np.append(y, 0.0)
        np.testing.assert_allclose(_paper_gap(PAPER, t, y), model.gap(t, y, p, 0),
                                   rtol=1e-9, atol=1e-12)


def test_paper_design_is_period_one_and_the_loose_joint_is_not():
    sec = poincare_section(PAPER, revolutions=24, keep=9, max_period=4)
    assert sec.regime == "period_1" and sec.period == 1
    assert sec.distance[0] < 1e-4        # recurrence far inside the tolerance 1e-3
    assert sec.samples.shape == (9, 1, 4) and sec.peaks.shape == (24,)
    # in permanent contact: the journal beyond the wall (penetration of micrometres)
    r = np.hypot(sec.samples[:, 0, 0], sec.samples[:, 0, 1])
    assert np.all((r > PAPER.clearance) & (r < 2 * PAPER.clearance))
    loose = poincare_section(LOOSE, revolutions=24, keep=9, max_period=4)
    assert loose.regime == "aperiodic" and loose.period == 0
    assert np.min(loose.distance) > 0.1    # no recurrence within a tenth of the clearance


def test_classify_criterion():
    rng = np.random.default_rng(0)
    two = np.tile(rng.normal(size=(2, 1, 4)), (6, 1, 1))      # period 2 exactly
    assert classify(two, max_period=3)[:2] == ("period_k", 2)
    noise = rng.normal(size=(12, 1, 4))
    assert classify(noise, max_period=3, lyapunov=0.5)[0] == "chaotic"
    assert classify(noise, max_period=3, lyapunov=0.0)[0] == "quasi_periodic"
    assert classify(noise, max_period=3, lyapunov=-0.5)[0] == "unsettled"
    assert classify(noise, max_period=3)[0] == "aperiodic"
    with pytest.raises(ValueError, match="keep must be >= 2 max_period"):
        classify(noise[:4], max_period=3)
    # with its interval: the exponent's verdict decides, as `lyapunov` prints it
    assert classify(noise, max_period=3, lyapunov=0.5, uncertainty=0.4)[0] == "chaotic"
    assert classify(noise, max_period=3, lyapunov=0.5, uncertainty=0.6)[0] == "undecided"
    assert classify(noise, max_period=3, lyapunov=-0.05, uncertainty=0.1)[0] == "undecided"
    assert classify(noise, max_period=3, lyapunov=0.01, uncertainty=0.005)[0] == \
        "quasi_periodic"


def test_a_period_k_pattern_of_growths_is_averaged_over_whole_periods():
    """A motion that repeats every 4 revolutions has growths that repeat every 4: averaged
    over whole periods their mean is the exponent and the interval closes; blocks of 5
    revolutions cut across the pattern and leave it open (the mean -0.053 reads as
    undecided). The reference: the exact mean of one period."""
    from mbs_clearance.analysis.poincare import classify_run, exponent_estimate

    pattern = np.array([0.397, -0.236, 0.252, -0.625])
    logs = np.tile(pattern, 5)
    lam, half = exponent_estimate(logs, 4)
    assert lam == pytest.approx(pattern.mean(), rel=1e-12) and half < 1e-12
    lam1, half1 = exponent_estimate(logs, 1)
    assert half1 > abs(lam1)
    rng = np.random.default_rng(1)
    four = np.tile(rng.normal(size=(4, 1, 4)), (5, 1, 1))      # period 4 exactly
    regime, period, _, lam, half = classify_run(four, logs, max_period=8)
    assert (regime, period) == ("period_k", 4) and half < 1e-12
    # with no recurrence the same growths leave the regime undecided
    noise = rng.normal(size=(20, 1, 4))
    assert classify_run(noise, logs, max_period=8)[0] == "undecided"


def test_near_tolerance_flags_verdicts_decided_at_the_tolerance():
    d = np.array([2.5e-3, 2.2e-3, 2.9e-3])                      # flat, just above tol
    assert near_tolerance("aperiodic", 0, d, 1e-3)
    assert not near_tolerance("aperiodic", 0, 20 * d, 1e-3)     # clearly no recurrence
    assert near_tolerance("period_k", 2, np.array([1.1e-3, 7e-4, 9e-4]), 1e-3)
    assert not near_tolerance("period_k", 2, np.array([27.0, 8.7e-5, 27.0]), 1e-3)
    assert not near_tolerance("period_1", 1, np.array([9e-4, 9e-4]), 1e-3)


def test_micrometre_clearance_is_rechecked_at_a_tighter_tolerance():
    """At c = 1 um the rtol 1e-7 run's section noise (~3e-3 c) exceeds the recurrence
    tolerance (1e-3 c) and reads 'aperiodic'; the re-check at rtol 1e-9 finds period 1,
    as an independent run at rtol 1e-10 does (recurrence of the same size)."""
    ref = SliderCrank(crank_speed=511.5)
    mech = SliderCrank(crank_speed=511.5, journal_radius=ref.bearing_radius - 1e-6)
    one = poincare_section(mech, 40, 17, rtol=1e-7, recheck=False)
    assert one.regime == "aperiodic" and not one.rechecked
    assert 1e-3 < one.distance.min() < 1e-2
    sec = poincare_section(mech, 40, 17, rtol=1e-7)
    assert sec.rechecked and sec.rtol == pytest.approx(1e-9)
    assert sec.regime == "period_1"
    tight = poincare_section(mech, 40, 17, rtol=1e-10, recheck=False)
    assert tight.regime == "period_1"
    assert sec.distance[0] < 10 * max(tight.distance[0], 1e-5)
    assert sec.counters["nfev"] > one.counters["nfev"]       # both runs counted


def test_tangent_matches_two_nearby_runs_of_the_plain_model():
    # the variational equations against the divergence of two runs eps apart, over a short
    # horizon in the chaotic regime (growth ~1e8 in 2 revolutions): the same finite-time
    # exponent within 2 % (measured: 0.5 %); rtol 1e-11 so that integration noise stays
    # below the eps-sized separation
    eps, rtol = 1e-8, 1e-11
    tf = TangentFlow(LOOSE, rtol=rtol)
    v0 = tf.tangent().copy()
    a, b = Flow(LOOSE, rtol=rtol), Flow(LOOSE, rtol=rtol)
    b.y[:4] += eps * v0
    horizon = 2 * LOOSE.period
    for f in (tf, a, b):
        f.advance(horizon)
    growth_tangent = np.linalg.norm(tf.tangent() / tf.scale)
    growth_runs = np.linalg.norm((b.y[:4] - a.y[:4]) / eps / tf.scale)
    assert growth_tangent > 1e6 and growth_runs > 1e6
    assert math.log(growth_tangent) == pytest.approx(math.log(growth_runs), rel=0.02)


def test_paper_design_negative_exponent_and_the_neutral_memory():
    res = lyapunov_exponent(PAPER, revolutions=16, transient=8)
    assert res.per_revolution < -0.1 and res.per_second < 0
    assert res.per_second == pytest.approx(res.per_revolution / PAPER.period)
    # carrying the impact-velocity memory's tangent: the persistent contact never forgets
    # it (multiplier 1, exponent 0), and the plain model's nearby runs agree: a run started
    # eps away settles at a constant distance, not back onto the same motion
    carry = lyapunov_exponent(PAPER, revolutions=16, transient=8, memory="carry")
    assert abs(carry.per_revolution) < 1e-3
    eps = 1e-6
    a, b = Flow(PAPER, rtol=1e-10), Flow(PAPER, rtol=1e-10)
    b.y[:4] += eps * TangentFlow(PAPER).tangent()
    d = []
    for t in section_times(PAPER, 8):
        a.advance(t)
        b.advance(t)
        d.append(np.linalg.norm(b.y[:4] - a.y[:4]))
    assert d[-1] == pytest.approx(d[-2], rel=0.02) and d[-1] > eps * 1e-3


def test_loose_joint_positive_exponent_and_chaotic_regime():
    sec = poincare_section(LOOSE, revolutions=24, keep=9, max_period=4, lyapunov=True)
    assert sec.lyapunov > 1.0 and sec.regime == "chaotic"


def test_parse_sweep_and_designs():
    ax = parse_sweep("clearance=1e-6:1e-3:log:4")
    np.testing.assert_allclose(ax.values, [1e-6, 1e-5, 1e-4, 1e-3])
    ax = parse_sweep("crank_speed=500rpm:1000rpm:3")
    np.testing.assert_allclose(np.array(ax.values) * 60 / (2 * math.pi), [500, 750, 1000])
    assert parse_sweep("crank_length=0.04, 0.05").values == (0.04, 0.05)
    for bad, match in (("clearance", "NAME="), ("clearance=1:2:x:3", "range must be"),
                       ("clearance=0:1e-3:log:3", "log range"), ("c=1:2:0", ">= 1"),
                       ("c=abc", "not a number")):
        with pytest.raises(ValueError, match=match):
            parse_sweep(bad)
    assert design_at(PAPER, {"clearance": 2e-5}).clearance == pytest.approx(2e-5)
    with pytest.raises(ValueError, match="unknown sweep field 'foo'"):
        design_at(PAPER, {"foo": 1.0})
    with pytest.raises(ValueError, match="clearance must be in"):
        design_at(PAPER, {"clearance": 0.02})
    link = design_at(None, {"clearance": 3e-4, "crank_speed": 2.0}, case="four_bar")
    assert link.clearance_joints[0].clearance == pytest.approx(3e-4)
    assert link.drive.speed == 2.0


SMALL = dict(revolutions=10, keep=5, max_period=2, scheduler="serial")


def test_map_killed_midway_and_resumed_equals_uninterrupted(tmp_path, monkeypatch):
    sweep = ["clearance=1e-5:5e-4:log:3", "crank_speed=4000rpm:5000rpm:2"]
    whole = regime_map(PAPER, sweep, out=tmp_path / "whole.nc", **SMALL)
    assert whole.computed == 6 and int(whole.dataset["done"].sum()) == 6
    ds = whole.dataset
    assert ds["regime"].values[0, 1] == 2          # the paper's design: period-1
    np.testing.assert_allclose(ds["joint_clearance"].values[:, 1, 0],
                               np.geomspace(1e-5, 5e-4, 3))
    r = np.hypot(*ds["section"].values[0, 1, :, 0, :2].T)   # on the wall there
    assert np.all((r > 1e-5) & (r < 2e-5))
    real = sweep_mod._map_point

    def dies_at_the_fourth(item, settings):
        if item[0] == 3:
            raise KeyboardInterrupt
        return real(item, settings)

    path = tmp_path / "part.nc"      # (written at the end: the default write_interval)
    monkeypatch.setattr(sweep_mod, "_map_point", dies_at_the_fourth)
    with pytest.raises(KeyboardInterrupt):
        regime_map(PAPER, sweep, out=path, **SMALL)
    monkeypatch.setattr(sweep_mod, "_map_point", real)
    part = sweep_mod.load_map(path)
    assert int(part["done"].sum()) == 3                       # written on the interrupt
    resumed = regime_map(PAPER, sweep, out=path, **SMALL)
    assert resumed.computed == 3 and resumed.skipped == 3
    on_disk = sweep_mod.load_map(path)
    for ds in (resumed.dataset, on_disk):
        for name in whole.dataset.data_vars:
            np.testing.assert_array_equal(ds[name].values, whole.dataset[name].values,
                                          err_msg=name)
    with pytest.raises(ValueError, match="different regime map"):
        regime_map(PAPER, sweep, out=path, **{**SMALL, "keep": 6})


def test_early_stop_gives_the_same_regimes_as_the_full_runs():
    """A small map with early stop on and off: the same regime and period at every point
    (period-1, period-2 and aperiodic ones). A stopped point ran fewer revolutions and
    right-hand side evaluations, and its kept sections (the repeated last period) lie
    within the recurrence tolerance of those the full run reaches (measured: 2.6e-6 of the
    scales for the paper's design, 4e-4 for the period-2 point; 1e-3 is the tolerance)."""
    sweep = ["clearance=1e-5,4e-5,5e-4", "crank_speed=4722rpm,5000rpm"]
    on = regime_map(PAPER, sweep, workers=1).dataset
    off = regime_map(PAPER, sweep, workers=1, early_stop=False).dataset
    np.testing.assert_array_equal(on["regime"].values, off["regime"].values)
    np.testing.assert_array_equal(on["period"].values, off["period"].values)
    assert set(on["regime"].values.ravel()) >= {2, 3, 6}    # period-1, period-k, aperiodic
    stopped = on["stopped"].values > 0
    assert stopped[0, 1] and on["stopped"].values[0, 1] < 20     # the paper's design
    assert not stopped[2].any() and not off["stopped"].values.any()
    assert np.all(on["nfev"].values[stopped] < off["nfev"].values[stopped])
    for i, j in zip(*np.nonzero(stopped)):
        c = float(on["joint_clearance"].values[i, j, 0])
        w = float(on["crank_speed"].values[j])
        unit = c * np.array([1.0, 1.0, w, w])
        diff = (on["section"].values[i, j] - off["section"].values[i, j]) / unit
        assert np.max(np.abs(diff)) < 1e-3, (i, j)


def test_memory_per_point_is_the_samples_not_the_steps():
    # a point's result holds keep samples whatever the run's length, and the flow holds one
    # window (revolution) of steps at a time
    settings = dict(revolutions=8, keep=5, angle=None, tol=1e-3, max_period=2,
                    lyapunov=False, rtol=None)
    short = sweep_mod._map_point((0, LOOSE), settings)
    long = sweep_mod._map_point((0, LOOSE), {**settings, "revolutions": 16})
    size = {k: np.asarray(v).nbytes for k, v in short.items() if k != "message"}
    assert size == {k: np.asarray(v).nbytes for k, v in long.items() if k != "message"}
    assert long["nfev"] > 1.5 * short["nfev"]
    flow = Flow(LOOSE)
    for t in section_times(LOOSE, 8):
        flow.advance(t)
    assert flow.max_recorded < 0.4 * flow.counters[1]     # the largest window's steps


def test_cli_map_writes_dataset_and_figures_and_resumes(tmp_path, capsys):
    from mbs_clearance.cli import main

    argv = ["map", "--sweep", "clearance=1e-5,5e-4", "--revolutions", "10", "--keep", "5",
            "--max-period", "2", "--workers", "1", "--no-progress", "--out", str(tmp_path)]
    assert main(argv) == 0
    out = capsys.readouterr()
    assert "2 of 2 points done" in out.out and "period_1: 1" in out.out
    for name in ("map.nc", "bifurcation.png", "poincare.png"):
        assert (tmp_path / name).stat().st_size > 0 and name in out.err
    assert main(argv) == 0                       # everything done: nothing recomputed
    assert "0 points computed, 2 resumed" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["map", "--out", str(tmp_path)])    # --sweep is required
    with pytest.raises(SystemExit):
        main(["map", "--sweep", "foo=1,2", "--out", str(tmp_path / "x")])
    assert "unknown sweep field 'foo'" in capsys.readouterr().err


def test_map_counts_read_the_cost_the_rechecks_and_the_boundary_from_the_dataset():
    # a hand-made 3 x 2 dataset: what the map command prints after the regimes, against the
    # values written into it
    import xarray as xr

    from mbs_clearance.cli import _map_counts, field_unit

    rpm = np.pi / 30
    code = {name: c for c, name in REGIMES.items()}
    dims = ("clearance", "crank_speed")
    regime = np.array([[code["period_1"], code["period_1"]],
                       [code["period_1"], code["period_k"]],
                       [code["chaotic"], code["failed"]]], dtype=np.int8)
    ds = xr.Dataset(
        {"regime": (dims, regime),
         "nfev": (dims, np.array([[100, 20], [300, 40], [500, 0]], dtype=np.int32)),
         "rtol": (dims, np.array([[1e-7, 1e-9], [1e-7, 1e-9], [1e-7, np.nan]])),
         "done": (dims, np.ones((3, 2), dtype=np.int8)),
         "failed": (dims, np.array([[0, 0], [0, 0], [0, 1]], dtype=np.int8))},
        coords={"clearance": [1e-6, 1e-5, 1e-4], "crank_speed": [500 * rpm, 5000 * rpm]})
    lines = _map_counts(ds, field_unit(None), None, {"clearance": 1e-5,
                                                     "crank_speed": 4000 * rpm})
    assert lines == [
        "right-hand side evaluations: 9.6e2 in all, 2e1 to 5e2 per point",
        "  at clearance 0.001 mm: 2e1 to 1e2 per point",
        "  at clearance 0.1 mm: 5e2 to 5e2 per point",          # its failed run left out
        "  at crank_speed 500 rpm: 1e2 to 5e2 per point",
        "  at crank_speed 5000 rpm: 2e1 to 4e1 per point",
        "re-checked near the recurrence tolerance at rtol 1e-9: 2 points, clearance 0.001 mm "
        "to 0.01 mm, crank_speed 5000 rpm to 5000 rpm; regimes: period_1: 1, period_k: 1",
        "row nearest the marked design's crank_speed (5000 rpm): first clearance that is "
        "not period-1: 0.01 mm (period_k)"]
    # a run at rtol 1e-9 throughout re-checks nothing at 1e-9
    assert _map_counts(ds, field_unit(None), 1e-9, None)[-1] == (
        "re-checked near the recurrence tolerance: no point")


def test_linkage_section_matches_the_hand_written_model():
    # the same mechanism as a Linkage (generated model) and as a SliderCrank (reduced
    # model): the same regime and the same section samples within the tolerance
    from mbs_clearance.model.cases import from_slider_crank

    link = poincare_section(from_slider_crank(PAPER), revolutions=12, keep=5, max_period=2)
    red = poincare_section(PAPER, revolutions=12, keep=5, max_period=2)
    assert link.joints == ("coupler_slider",) and link.regime == red.regime == "period_1"
    np.testing.assert_allclose(link.scaled(), red.scaled(), atol=1e-3)
    np.testing.assert_allclose(link.peaks, red.peaks, rtol=1e-4)
    # the exponent of the same mechanism as a Linkage: negative as the SliderCrank's (its
    # tangent's angle scale is the clearance over the linkage's length scale, not over the
    # coupler's: another norm, the same sign)
    res = lyapunov_exponent(from_slider_crank(PAPER), revolutions=16, transient=8)
    assert res.per_revolution < -0.1


def test_a_failed_tangent_run_falls_back_to_the_plain_section(monkeypatch):
    real = sweep_mod.poincare_section

    def tangent_fails(mech, *args, lyapunov=False, **kw):
        if lyapunov:
            raise RuntimeError("events chatter")
        return real(mech, *args, lyapunov=False, **kw)

    monkeypatch.setattr(sweep_mod, "poincare_section", tangent_fails)
    settings = dict(revolutions=8, keep=5, angle=None, tol=1e-3, max_period=2,
                    lyapunov=True, rtol=None)
    res = sweep_mod._map_point((0, PAPER), settings)
    plain = sweep_mod._map_point((0, PAPER), {**settings, "lyapunov": False})
    assert res["tangent_failed"] == 1 and res["status"] == 1 and math.isnan(res["lyapunov"])
    np.testing.assert_array_equal(res["section"], plain["section"])
    assert res["regime"] == plain["regime"] == 2


def test_two_joint_slider_crank_exponent_agrees_with_two_nearby_runs():
    """A non-paper case (the two-joint slider-crank, its own generated sensitivity
    kernels): at 0.2 mm in both joints the exponent is positive and two plain runs 1e-9
    apart (scaled units, along the tangent's start) separate e-fold more than 10 times in
    the first revolution (measured: exponent 6.8 per revolution, separation 1e-9 -> 2.9);
    at the default 0.01 mm it is negative and the runs do not separate after the start's
    transient: they stay at the distance the persistent contacts' memories and the
    integration's own error set, 4e-8 to 4e-7 over revolutions 2-6 (measured at rtol 1e-11
    and 1e-12, with an event margin of 0.001 c and of 0.05 c: not constant to a factor
    1.5), far from the chaotic case's
    separation, asserted below 1e-6."""
    from mbs_clearance.model.cases import slider_crank_two_clearances

    for c, chaotic in ((2e-4, True), (1e-5, False)):
        lk = slider_crank_two_clearances(crank_coupler_clearance=c, coupler_slider_clearance=c)
        res = lyapunov_exponent(lk, revolutions=12, transient=4)
        tf = TangentFlow(lk)
        n2 = len(tf.scale)
        eps = 1e-9
        a, b = Flow(lk, rtol=1e-11), Flow(lk, rtol=1e-11)
        b.y[:n2] += eps * tf.tangent()
        d = []
        for t in section_times(lk, 6):
            a.advance(t)
            b.advance(t)
            d.append(np.linalg.norm((b.y[:n2] - a.y[:n2]) / tf.scale))
        if chaotic:
            assert res.per_revolution > 1.0
            assert math.log(d[0] / eps) > 10.0
        else:
            assert res.per_revolution < -1.0
            assert max(d[1:]) < 1e-6, d


def test_exponent_interval_covers_the_textbook_values_and_decides_their_sign():
    """The interval of the exponent against known exponents: x' = A x with eigenvalues
    0.3 +- 2i, -1 (exactly 0.3: a narrow interval around it, positive); a pure rotation
    (+-2i, -1: exactly 0, "zero"); Lorenz (0.9056, Sprott 2003: inside the interval, which
    is wider than the linear one's since its growths scatter)."""
    from mbs_clearance.analysis.lyapunov import exponent_verdict

    spiral = np.array([[0.3, 2.0, 0.0], [-2.0, 0.3, 0.0], [0.0, 0.0, -1.0]])
    res = textbook_exponent("linear", 40.0, window=1.0, transient=10.0, matrix=spiral,
                            x0=(1.0, 0.0, 1.0), v0=(0.3, 1.0, 1.0))
    # 1e-6: the integration's error at rtol 1e-10 (as the closed-form test above)
    assert abs(res.per_second - 0.3) <= res.uncertainty + 1e-6 and res.uncertainty < 1e-5
    assert res.verdict == "positive"
    rotation = spiral - np.diag([0.3, 0.3, 0.0])
    res = textbook_exponent("linear", 40.0, window=1.0, transient=10.0, matrix=rotation,
                            x0=(1.0, 0.0, 1.0), v0=(0.3, 1.0, 1.0))
    assert abs(res.per_second) < 1e-6 and res.verdict == "zero"
    lorenz = textbook_exponent("lorenz", 400.0, window=1.0, transient=20.0)
    assert lorenz.interval[0] <= 0.9056 <= lorenz.interval[1], lorenz.interval
    assert 0.01 < lorenz.uncertainty < 0.3 and lorenz.verdict == "positive"
    # the verdict from an interval
    assert exponent_verdict(-0.19, 0.08) == "undecided"
    assert exponent_verdict(-0.01, 0.015) == "zero"
    assert exponent_verdict(-0.5, -0.01) == "negative"


def test_fewer_averaged_windows_than_blocks_leave_the_verdict_undecided():
    from mbs_clearance.analysis.lyapunov import BLOCKS, exponent_interval

    assert exponent_interval(np.full(BLOCKS - 1, -1.0)) == math.inf
    # a periodic pattern of growths (period 4, mean -0.054 per window, as the 0.1 mm joint's
    # revolutions 21-40) averaged over 20 windows in blocks of 5: the blocks see the pattern
    assert exponent_interval(np.tile([0.397, -0.236, 0.252, -0.625], 5)) > 0.054


def test_map_point_and_exponent_agree_on_the_same_run():
    """The regime map's point (`poincare_section` with the exponent) and
    `lyapunov_exponent` run the same tangent flow over the same revolutions: the same
    exponent to round-off, the same interval, the same regime and period."""
    from mbs_clearance.analysis.lyapunov import lyapunov_exponent as exponent

    for mech in (PAPER, LOOSE):
        sec = poincare_section(mech, revolutions=24, keep=12, max_period=5, lyapunov=True,
                               recheck=False)
        res = exponent(mech, revolutions=24, transient=12)
        assert res.per_revolution == pytest.approx(sec.lyapunov, rel=1e-12, abs=1e-14)
        assert res.uncertainty == pytest.approx(sec.lyapunov_uncertainty, rel=1e-12)
        assert (res.regime, res.period) == (sec.regime, sec.period)
    assert sec.regime == "chaotic" and res.verdict == "positive"


def test_loose_joint_at_0_1_mm_over_40_revolutions_is_not_found_stable():
    """c = 0.1 mm, 5000 rpm, 40 revolutions (20 averaged). The motion starts chaotic, and
    how long that lasts depends on the integration's error and the start's last digits: at
    the default rtol the same revolutions 21-40 gave -0.054 +- 0.137 (undecided) from the
    closed form's start and +2.34 +- 1.02 (positive) from the description's assembly, a
    start within 1.5e-14 of it; at rtol 1e-10, +2.65 +- 2.0 and +2.50 +- 0.34. What holds
    for every such run is what the verdict may say: not a stable motion (neither
    "negative" nor "zero"), and chaotic where the integration is tight. (At rtol 1e-10 one
    window's step sequence meets a grazing contact at machine precision: it runs again,
    `flows.CHATTER_RETRIES`.)"""
    mech = SliderCrank(journal_radius=SliderCrank().bearing_radius - 1e-4)
    res = lyapunov_exponent(mech, revolutions=40, transient=20)
    assert res.verdict in ("undecided", "positive"), (res.per_revolution, res.uncertainty)
    assert res.interval[1] > 0.0
    tight = lyapunov_exponent(mech, revolutions=40, transient=20, rtol=1e-10)
    assert tight.verdict == "positive", (tight.per_revolution, tight.uncertainty)


def test_a_window_whose_events_chatter_runs_again_from_its_start():
    """A window that ends in chattering events (a grazing contact met at machine precision
    by one step sequence) runs again from its start: the same state and memories (the
    failed attempt's writes to p undone) and a smaller first step; the retry's result is
    the window's. After `CHATTER_RETRIES` retries the failure is raised."""
    from mbs_clearance.numerics.integrator import RESULTS
    from mbs_clearance.solve import flows

    flow = Flow(SliderCrank())
    real, calls = flow.kernel, []

    def kernel(y, p, edges, settings, coefficients):
        calls.append((p.copy(), settings.h0))
        if len(calls) == 1:                 # a failed attempt that wrote to p
            p[:] = -1.0
            return (np.array([edges[0]]), y[None, :], np.zeros((1, 1)), np.zeros(1),
                    np.zeros(1), np.zeros(5, dtype=np.int64), np.zeros((1, 0)),
                    int(RESULTS.event_chatter.value))
        return real(y, p, edges, settings, coefficients)

    p0 = flow.p.copy()
    flow.kernel = kernel
    peak = flow.advance(flow.linkage.period)
    assert len(calls) == 2 and flow.chatter_retries == 1
    assert np.array_equal(calls[1][0], p0)                      # memories as at the start
    h_first = calls[0][1] if calls[0][1] > 0 else 1e-4 * flow.linkage.period
    assert calls[1][1] == pytest.approx(0.3 * h_first)
    reference = Flow(SliderCrank())
    assert peak == pytest.approx(reference.advance(reference.linkage.period), rel=1e-6)

    failing = Flow(SliderCrank())
    failing.kernel = lambda y, p, edges, settings, coefficients: (
        np.array([edges[0]]), y[None, :], np.zeros((1, 1)), np.zeros(1), np.zeros(1),
        np.zeros(5, dtype=np.int64), np.zeros((1, 0)), int(RESULTS.event_chatter.value))
    with pytest.raises(RuntimeError, match="events chatter"):
        failing.advance(failing.linkage.period)
    assert failing.chatter_retries == flows.CHATTER_RETRIES
