"""The comparison harness (validation.compare) and its command line."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mbs_clearance import AccuracyWarning, SliderCrank, simulate
from validation.compare import (
    common_grid,
    compare,
    compare_command,
    first_impact,
    format_table,
    paper_peak_line,
)


@pytest.fixture(scope="module")
def reduced_paper():
    return simulate(SliderCrank(), 2, backend="reduced", rtol=1e-10)


def test_identical_trajectories_have_zero_differences(reduced_paper):
    res = compare(reduced_paper, reduced_paper)
    for r in res.revolutions:
        assert r.peak_rel_diff == 0 and r.base_force_rel_rms == 0
        assert r.crank_moment_rel_rms == 0 and r.orbit_max == 0
    assert res.first_impact_a == res.first_impact_b


def test_known_differences_are_measured(reduced_paper):
    """A scaled copy: relative RMS and peak differences equal the scale error exactly."""
    scaled = dataclasses.replace(reduced_paper, base_force=1.01 * reduced_paper.base_force,
                                 crank_moment=0.98 * reduced_paper.crank_moment, peaks=None)
    r = compare(reduced_paper, scaled).revolution(2)
    assert r.base_force_rel_rms == pytest.approx(0.01, rel=1e-9)
    assert r.crank_moment_rel_rms == pytest.approx(0.02, rel=1e-9)
    # b's peak is over its samples, a's is refined between samples: equal to ~1e-6
    assert r.peak_rel_diff == pytest.approx(0.01, abs=1e-5)


def test_the_verdict_is_the_python_apis(reduced_paper):
    """`compare` carries the record `verdict_of_trajectories` returns: identical runs agree;
    a copy with its force 1 % higher differs by 1 % in each revolution, which decides
    nothing: neither run has an error estimate at a fixed rtol (bars 0), so the difference
    may be their own errors, which the verdict says; with a bar on each it differs; the paper's
    motion is periodic (judged on 8 revolutions: 2 are too few), so peak by peak."""
    from mbs_clearance.analysis.verdict import AGREE, DIFFER, NO_BAR, verdict_of_trajectories

    same = compare(reduced_paper, reduced_paper)
    assert same.verdict == verdict_of_trajectories(reduced_paper, reduced_paper)
    assert same.verdict.kind == AGREE and "periodic" in same.verdict.reason
    assert "no error estimate for reduced and reduced" in same.verdict.reason
    scaled = dataclasses.replace(reduced_paper, base_force=1.01 * reduced_paper.base_force,
                                 peaks=1.01 * reduced_paper.peaks)
    res = compare(reduced_paper, scaled)
    assert res.verdict.kind == NO_BAR
    assert [i.relative_difference for i in res.verdict.items] == pytest.approx([0.01, 0.01])
    assert "verdict: not decided, a model has no error bar" in format_table(res)
    barred = [dataclasses.replace(tr, stats={**tr.stats, "error_estimate": 1e-6})
              for tr in (reduced_paper, scaled)]
    res = compare(*barred)
    assert res.verdict.kind == DIFFER
    assert "verdict: reduced and reduced differ beyond their error bars" in format_table(res)


def test_orbit_distance_of_a_shifted_orbit(reduced_paper):
    shift = 0.1 * reduced_paper.mechanism.clearance
    moved = dataclasses.replace(reduced_paper,
                                eccentricity=reduced_paper.eccentricity + [shift, 0.0])
    r = compare(reduced_paper, moved).revolution(1)
    assert r.orbit_max_rel == pytest.approx(0.1, rel=1e-9)
    assert r.orbit_rms_rel == pytest.approx(0.1, rel=1e-9)


def test_common_grid_reproduces_a_uniform_trajectory():
    mech = SliderCrank()
    ideal = simulate(mech, 1, backend="ideal", samples_per_revolution=600)
    t = common_grid(ideal, ideal, mech.period)
    assert np.allclose(t, ideal.t, rtol=0, atol=1e-15)


def test_first_impact_is_interpolated_between_samples(reduced_paper):
    fi = first_impact(reduced_paper)
    # the reduced model locates the onset event exactly: 32.093 us in the paper case
    on = reduced_paper.t[np.argmax(reduced_paper.contact_phase == 1)]
    assert fi.time == pytest.approx(on, abs=1e-9)


def test_bad_inputs(reduced_paper):
    # c = 0.1 mm: not periodic, flagged at a fixed rtol (at a requested accuracy its first
    # revolution's peak meets the request and is not)
    with pytest.warns(AccuracyWarning, match="rattles"):
        other = simulate(SliderCrank(journal_radius=0.0099), 1, backend="reduced", rtol=1e-7)
    with pytest.raises(ValueError, match="different mechanisms"):
        compare(reduced_paper, other)
    with pytest.raises(ValueError, match="revolutions"):
        compare(reduced_paper, reduced_paper, revolutions=(3,))


def test_command_prints_table_and_writes_figure(tmp_path, capsys):
    out = tmp_path / "overlay.png"
    code = compare_command(["--backend-a", "reduced", "--backend-b", "ideal",
                            "--revolutions", "2", "--out", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    assert "peak a (N)" in text and "statistics over revolutions 2-2" in text
    assert out.stat().st_size > 10_000


def test_the_paper_s_peak_beside_both_models_only_for_its_two_designs():
    """The paper's revolution-4 peak (Table 3: 8311 N at 5 / 12 cm, 4667 N at its optimum)
    beside each model's, as b/a - 1 of the printed peaks; nothing for another mechanism or
    a run shorter than 4 revolutions."""
    original = simulate(SliderCrank(), 4, backend="reduced")
    ideal = simulate(SliderCrank(), 4, backend="ideal")
    line = paper_peak_line(SliderCrank(), compare(original, ideal))
    a, b = original.max_base_force(4), ideal.max_base_force(4)
    assert line == (f"the paper's peak in revolution 4 (original design): 8311 N; a against it "
                    f"{100 * (a / 8311 - 1):+.3f} %, b against it {100 * (b / 8311 - 1):+.3f} %")
    optimum = SliderCrank(crank_length=0.040733, coupler_length=0.137468)
    line = paper_peak_line(optimum, compare(*(simulate(optimum, 4, backend=be)
                                              for be in ("reduced", "ideal"))))
    assert line.startswith("the paper's peak in revolution 4 (optimum design): 4667 N; a ")
    assert paper_peak_line(SliderCrank(restitution=0.5), compare(original, ideal)) is None
    short = simulate(SliderCrank(), 2, backend="ideal")
    assert paper_peak_line(SliderCrank(), compare(short, short)) is None


def test_command_rejects_bad_values_before_simulating(capsys):
    with pytest.raises(SystemExit) as exc:
        compare_command(["--step-size", "-1", "--no-plot"])
    assert exc.value.code == 2
    err = capsys.readouterr()
    assert "--step-size: must be a finite number > 0" in err.err and "reduced:" not in err.err


def test_format_table_lists_every_revolution(reduced_paper):
    text = format_table(compare(reduced_paper, reduced_paper))
    assert text.count("\n  1 ") + text.count("\n  2 ") == 2


@pytest.mark.slow   # a minute of Exudyn runs of both slider-cranks
def test_linkage_comparison_per_joint(tmp_path):
    """A linkage against a copy with one joint's orbit shifted by 0.1 of its clearance and
    the drive moment scaled by 1.02: the per-joint orbit distance and the RMS differences
    are measured exactly; the other joint's first impact is unchanged."""
    from mbs_clearance.model.cases import slider_crank_two_clearances
    from validation.compare import plot_linkage_comparison

    lk = slider_crank_two_clearances()
    a = simulate(lk, 1, backend="reduced")
    c = lk.clearance_joints[1].clearance
    ecc = a.eccentricity.copy()
    ecc[:, 1, 0] += 0.1 * c
    b = dataclasses.replace(a, eccentricity=ecc, crank_moment=1.02 * a.crank_moment)
    res = compare(a, b)
    r = res.revolution(1)
    assert r.orbit_max_rel == pytest.approx(0.1, rel=1e-9)
    assert r.moment_rms_rel_diff == pytest.approx(0.02, rel=1e-9)
    assert r.shaking_rms_rel_diff == 0.0 and r.peak_rel_diff == 0.0
    assert res.joints == ("crank_coupler", "coupler_slider")
    assert res.first_impacts_a == res.first_impacts_b
    assert all(f is not None for f in res.first_impacts_a.values())
    assert "first impact crank_coupler" in format_table(res)
    fig = plot_linkage_comparison(a, b, path=tmp_path / "o.png")
    # five panels drawn on a 3 x 2 grid (its sixth switched off)
    assert sum(ax.axison for ax in fig.axes) == 5
    assert (tmp_path / "o.png").stat().st_size > 10_000


@pytest.mark.slow      # three Exudyn runs of a named case: about 90 s on a CI machine
def test_command_takes_a_named_case(tmp_path, capsys):
    """`compare --case NAME`: the linkage's table (first impact per clearance joint) and
    the per-joint overlay; --set changes the case; slider-crank options are refused. At a
    fixed --rtol the linkage's own diagnostics speak: the 20 um joint's contact settles
    after several onsets, which the run flags."""
    out = tmp_path / "case.png"
    with pytest.warns(AccuracyWarning, match="contact onsets before the contact settles"):
        code = compare_command(["--case", "slider_crank_two_clearances", "--backend-a",
                                "reduced", "--backend-b", "reduced", "--rtol", "1e-8",
                                "--revolutions", "1", "--set", "crank_coupler_clearance=2e-5",
                                "--out", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    assert "first impact crank_coupler" in text and "first impact coupler_slider" in text
    assert out.stat().st_size > 10_000
    with pytest.raises(SystemExit) as exc:
        compare_command(["--case", "four_bar", "--journal-radius", "0.05", "--no-plot"])
    assert exc.value.code == 2
    assert "four_bar: unknown override(s) ['journal_radius']" in capsys.readouterr().err


@pytest.mark.slow
def test_converged_cross_check_agrees_within_the_error_bars_and_within_1e_4():
    """The paper case, 2 revolutions: Exudyn at 2, 1 and 0.5 us, extrapolated, against the
    reduced model at rtol 1e-12 (the independent reference): within 1e-4 and within its own
    error bar in each revolution; the observed order of the first revolution's peak near
    generalized-alpha's 2; the cross-check (reduced at accuracy 1e-6) says "agree" and
    reports both times (2 revolutions are too few for the return map: the periodicity is
    judged on 8 revolutions of the reduced model). Slow: three Exudyn runs (84 000 steps)."""
    from validation.compare import cross_check, format_cross_check

    mech = SliderCrank()
    cc = cross_check(mech, 2, accuracy=1e-6)
    ref = simulate(mech, 2, rtol=1e-12).peaks
    assert np.all(np.abs(cc.exudyn / ref - 1.0) < 1e-4), cc.exudyn / ref - 1.0
    assert np.all(np.abs(cc.exudyn - ref) <= cc.exudyn_error), (cc.exudyn - ref, cc.exudyn_error)
    assert np.all(np.abs(cc.reduced - ref) <= cc.reduced_error)
    assert 1.5 < cc.exudyn_order[0] < 2.6, cc.exudyn_order
    assert not cc.model_difference.any()
    assert cc.verdict.kind == "agree", cc.verdict.summary()
    text = format_cross_check(cc)
    assert "agree within their error bars" in text
    assert cc.exudyn_seconds > 0.0 and cc.reduced_seconds > 0.0


@pytest.mark.slow      # Exudyn's step sequence over 20 ms (four runs, about 50 s)
def test_a_free_linkage_is_compared_per_window_with_both_bars():
    """The translational benchmark (free): both models over two 10 ms windows, Exudyn
    converged by step halving (its own bars per window, a record every run), each peak
    with its bars, and a verdict that says the models agree there."""
    from mbs_clearance.model.cases import CASES
    from validation.compare import compare_free

    a, b, v = compare_free(CASES["flores_translational_slider_crank"](), 0.02, 0.01)
    assert len(a.peaks) == len(b.peaks) == 2
    assert b.stats["accuracy_ok"] and len(b.stats["peak_errors"]) == 2
    assert len(b.stats["accuracy_steps"]) >= 3
    assert [i.quantity for i in v.items] == ["peak of |F| in window 1",
                                            "peak of |F| in window 2"]
    assert v.kind == "agree", v.summary()
    assert all(i.b_error > 0 for i in v.items[1:])


@pytest.mark.parametrize("argv, needs", [
    ([], "--duration"), (["--duration", "0.03", "--window", "0.007"], "whole number"),
    (["--duration", "0.02", "--revolutions", "2"], "--duration")])
def test_a_free_linkage_needs_its_span(argv, needs, capsys):
    """compare on a free linkage: --duration (not --revolutions), a whole number of
    --window's; refused in one line before any run."""
    with pytest.raises(SystemExit) as exit_:
        compare_command(["--case", "flores_translational_slider_crank", *argv])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert needs in err and len(err.strip().splitlines()) == 1
