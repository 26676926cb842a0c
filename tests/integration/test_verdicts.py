"""Every kind of verdict of the reduced model against Exudyn, each from real runs: agreeing
models (the paper case), a contact stiffness changed in one model (a model difference), a
chaotic point (routed to statistics over revolutions), a run at a fixed step given its bars
by step halving."""

from __future__ import annotations

import numpy as np
import pytest

from mbs_clearance import SliderCrank, simulate
from mbs_clearance.analysis.verdict import (
    AGREE,
    DIFFER,
    NOT_COMPARABLE,
    judge_periodicity,
    verdict_of_peaks,
)
from mbs_clearance.solve.accuracy import revolution_peaks

pytestmark = pytest.mark.exudyn


@pytest.fixture(scope="module")
def exudyn_paper():
    """Exudyn's converged peaks of the paper case over 2 revolutions (h = 2, 1, 0.5 us)."""
    from mbs_clearance.backends.exudyn_convergence import converged_peaks

    return converged_peaks(SliderCrank(), 2)


def _reduced(mech):
    tr = simulate(mech, 2, accuracy=1e-6)
    peaks = revolution_peaks(tr)
    return peaks, tr.stats["error_estimate"] * np.abs(peaks)


@pytest.mark.slow      # three Exudyn runs of 2 revolutions (84 000 steps)
def test_paper_case_agrees_and_a_stiffer_contact_in_one_model_differs(exudyn_paper):
    """The paper case is periodic (judged on 8 revolutions: 2 are too few for the return
    map), so its peaks are compared one by one: the converged models agree within their
    bars. The reduced model with the contact stiffness raised by 5 % (Young's modulus x 1.05:
    K is proportional to the effective modulus) against unchanged Exudyn: a model
    difference, the first revolution's impact peak 0.9 % higher."""
    paper = SliderCrank()
    flag, note = judge_periodicity(paper)
    assert flag is True, note
    peaks, bars = _reduced(paper)
    v = verdict_of_peaks(peaks, bars, exudyn_paper.value, exudyn_paper.error, periodic=flag)
    assert v.kind == AGREE, v.summary()
    stiff = paper.replace(youngs_modulus=1.05 * paper.youngs_modulus)
    peaks, bars = _reduced(stiff)
    v = verdict_of_peaks(peaks, bars, exudyn_paper.value, exudyn_paper.error, periodic=flag)
    assert v.kind == DIFFER, v.summary()
    # the stiffer model's impact peak is 0.9 % higher than Exudyn's, 22 times the bars
    assert not v.items[0].agree and v.items[0].relative_difference < -0.005
    assert "differ beyond their error bars" in v.summary() and v.worst.quantity in v.summary()


def test_chaotic_point_is_compared_on_statistics():
    """c = 0.5 mm (chaotic: positive Lyapunov exponent, docs/regimes.md): the runs separate
    after a few impacts (peak differences of tens of per cent), so the comparison is
    routed to statistics over revolutions 2-8, where both models' means lie within the
    95 % intervals. Runs at a fixed rtol and a fixed step are given no bar; the verdict
    says so."""
    from validation.compare import compare, format_table

    loose = SliderCrank(journal_radius=0.0095)
    a = simulate(loose, 8, rtol=1e-9)
    b = simulate(loose, 8, backend="exudyn")
    res = compare(a, b)
    v = res.verdict
    assert v.kind == NOT_COMPARABLE, v.summary()
    assert "not periodic" in v.reason
    assert "no error estimate for reduced and exudyn" in v.reason     # fixed rtol and step
    assert max(abs(i.relative_difference) for i in v.items) > 0.2
    assert len(v.statistics_items) == 3
    assert all(np.isfinite(i.a_error) and np.isfinite(i.b_error) for i in v.statistics_items)
    assert v.statistics == AGREE, v.summary()
    assert "not comparable peak by peak" in format_table(res)


def test_a_run_at_a_fixed_step_gets_bars_that_hold_the_reference():
    """Exudyn at a fixed step (4 us, 2 revolutions) has no error estimate; `step_bars` gives
    each of its peaks a bar from runs at 2 and 1 us. Each bar covers the run's distance
    from the reduced model at rtol 1e-12 (an independent reference, converged far beyond
    these bars) without being vacuous (at most 3 times that distance). The three runs are
    read as the step sequences read theirs (the smoothed monitored force, `smoothed`, not
    the raw one) and the bar is the run's own (raw) peak's distance from their
    extrapolation plus its bar. With the bars the comparison agrees; without them the same
    difference decides nothing."""
    from mbs_clearance.analysis.verdict import NO_BAR
    from mbs_clearance.backends import exudyn_convergence as xc
    from mbs_clearance.backends import exudyn_linkage as xl
    from mbs_clearance.model.cases import as_linkage
    from mbs_clearance.solve.linkage_model import prepare_span
    from validation.compare import compare, step_bars

    paper = SliderCrank()
    ref = simulate(paper, 2, rtol=1e-12)
    run = simulate(paper, 2, backend="exudyn", step_size=4e-6)
    barred = step_bars(run)
    bars = np.asarray(barred.stats["peak_errors"])
    distance = np.abs(revolution_peaks(run) - revolution_peaks(ref))
    assert np.all(distance <= bars) and np.all(bars <= 3.0 * distance), (distance, bars)
    assert barred.stats["accuracy_steps"] == [4e-6, 2e-6, 1e-6]
    # extrapolated in both revolutions (measured orders 1.8 and 3.3: generalized-alpha is
    # second order, not yet exactly so at these steps)
    assert np.all(np.isfinite(barred.stats["observed_order"]))
    assert step_bars(barred) is barred and step_bars(ref) is ref     # nothing to add
    lk = as_linkage(paper)
    rows = np.asarray(barred.stats["accuracy_peaks"])
    for row, traj in ((0, run), (2, None)):
        if traj is None:
            settings = xl.make_settings({"step_size": 1e-6})
            t, force = xl.monitored_force(lk, prepare_span(lk, 2), settings)
        else:
            t, force = traj.t, traj.base_force
        f = xc.smoothed(force)
        smooth = xl.refined_peaks(t, np.hypot(f[:, 0], f[:, 1]), lk.period, 2)
        raw = xl.refined_peaks(t, np.hypot(force[:, 0], force[:, 1]), lk.period, 2)
        np.testing.assert_allclose(rows[row], smooth, rtol=1e-12)
        assert np.all(np.abs(raw - smooth) > 1e-12 * smooth)
    value, error, _ = xc.richardson(*rows)
    np.testing.assert_allclose(bars, np.abs(revolution_peaks(run) - value) + error, rtol=1e-12)
    assert compare(ref, run, step_bars=False).verdict.kind == NO_BAR
    v = compare(ref, run).verdict
    assert v.kind == AGREE, v.summary()
    assert [i.b_error for i in v.items] == pytest.approx(bars)
    assert "bars from runs at its step 4e-06 s halved twice" in v.summary()
