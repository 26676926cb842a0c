"""The verdict of a comparison from error bars (mbs_clearance.analysis.verdict)."""

import math

import numpy as np
import pytest
from scipy import stats

from mbs_clearance.analysis.verdict import (
    AGREE,
    DIFFER,
    NO_BAR,
    NOT_COMPARABLE,
    UNDECIDED,
    Item,
    comparable,
    format_verdict,
    mean_interval,
    verdict_of_peaks,
)


def test_item_agrees_exactly_within_the_summed_bars():
    # |b - a| = 3, bars 1 + 2 = 3: within; bars 1 + 1.9: beyond by 3 / 2.9
    assert Item("q", 10.0, 1.0, 13.0, 2.0).agree
    beyond = Item("q", 10.0, 1.0, 13.0, 1.9)
    assert not beyond.agree
    assert beyond.excess == pytest.approx(3.0 / 2.9)
    assert beyond.relative_difference == pytest.approx(0.3)
    assert not Item("q", 10.0, math.nan, 10.0, 0.0).agree


@pytest.mark.parametrize("n", [2, 3, 7, 30, 45])
def test_mean_interval_is_the_student_t_interval(n):
    x = np.random.default_rng(n).normal(5.0, 2.0, n)
    mean, half = mean_interval(x)
    lo, hi = stats.t.interval(0.95, n - 1, loc=x.mean(), scale=stats.sem(x))
    assert mean == pytest.approx(x.mean())
    # tabulated quantiles to 3 decimals, beyond 30 degrees of freedom an expansion in 1/dof
    assert half == pytest.approx((hi - lo) / 2, rel=2e-3)
    assert mean_interval([3.0]) == (3.0, math.inf)


def test_the_interval_covers_the_true_mean_about_95_percent_of_the_time():
    rng = np.random.default_rng(1)
    hits = 0
    for _ in range(2000):
        m, h = mean_interval(rng.exponential(1.0, 8))
        hits += abs(m - 1.0) <= h
    # skewed data make a t-interval somewhat optimistic; it still covers most draws
    assert 0.85 < hits / 2000 < 0.97


def test_comparability_from_flags_and_lyapunov():
    assert comparable(True)[0]
    assert comparable((True, True))[0]
    assert not comparable((True, None))[0]
    assert not comparable(False)[0]
    assert "undetermined" in comparable(None)[1]
    assert not comparable(True, lyapunov="positive")[0]
    assert not comparable(True, lyapunov="undecided")[0]
    assert comparable(False, lyapunov="negative")[0]


def test_peak_verdicts_agree_and_differ():
    a = np.array([100.0, 200.0, 300.0])
    v = verdict_of_peaks(a, 0.1, a + [0.05, -0.1, 0.15], 0.05, periodic=True)
    assert v.kind == AGREE and v.agree
    v = verdict_of_peaks(a, 0.1, a + [0.05, -0.6, 0.15], 0.05, periodic=True)
    assert v.kind == DIFFER and not v.agree
    assert v.worst.quantity == "peak of |F| in revolution 2"
    assert v.worst.excess == pytest.approx(0.6 / 0.15)
    assert "revolution 2" in v.summary() and "differ beyond" in v.summary()
    with pytest.raises(ValueError, match="same length"):
        verdict_of_peaks(a, 0.1, a[:2], 0.1)
    with pytest.raises(ValueError, match=">= 0"):
        verdict_of_peaks(a, -0.1, a, 0.1)


def _stats(x):
    return {"revolutions": np.arange(2, len(x) + 2), "peak": np.asarray(x),
            "rms": 0.5 * np.asarray(x), "mean": 0.3 * np.asarray(x)}


def test_chaotic_motion_is_judged_on_statistics():
    rng = np.random.default_rng(3)
    pa, pb = rng.normal(1000.0, 100.0, 40), rng.normal(1000.0, 100.0, 40)
    # peak by peak these differ by far more than their bars; the distributions are the same
    v = verdict_of_peaks(pa, 0.01, pb, 0.01, periodic=False, statistics_a=_stats(pa),
                         statistics_b=_stats(pb))
    assert v.kind == NOT_COMPARABLE and v.statistics == AGREE and v.agree
    assert any(not i.agree for i in v.items)
    assert "not comparable peak by peak" in v.summary()
    # a shift of 20 % of the mean: the 95 % intervals (about +-32 N each) separate
    pc = rng.normal(1200.0, 100.0, 40)
    v = verdict_of_peaks(pa, 0.01, pc, 0.01, periodic=False, statistics_a=_stats(pa),
                         statistics_b=_stats(pc))
    assert v.kind == NOT_COMPARABLE and v.statistics == DIFFER and not v.agree
    assert "statistics differ" in v.summary()
    assert "statistics over revolutions" in format_verdict(v)
    # two revolutions decide nothing
    v = verdict_of_peaks(pa[:2], 0.01, pc[:2], 0.01, periodic=False,
                         statistics_a=_stats(pa[:2]), statistics_b=_stats(pc[:2]))
    assert v.statistics == UNDECIDED and "run at least 4 revolutions" in v.reason


def test_a_difference_without_a_bar_is_not_decided():
    """A model without an error estimate (a fixed step) has the bar 0: a difference beyond
    the bars then decides nothing (part of it may be that model's error), a verdict of its
    own kind that says why, not "differ"."""
    import dataclasses

    from mbs_clearance import SliderCrank, simulate
    from mbs_clearance.analysis.verdict import verdict_of_trajectories

    a = simulate(SliderCrank(), 2)
    stats = {k: v for k, v in a.stats.items() if k != "error_estimate"}
    b = dataclasses.replace(a, backend="exudyn", peaks=1.01 * np.asarray(a.peaks), stats=stats)
    v = verdict_of_trajectories(a, b)
    assert v.kind == NO_BAR and not v.agree, v.summary()
    assert "no error estimate for exudyn" in v.summary()
    assert "not decided" in v.summary() and "differ beyond" not in v.summary()
    assert "may be its own error" in v.summary()
    # with a bar on b the same difference is a difference
    barred = dataclasses.replace(b, stats={**stats, "error_estimate": 1e-6})
    assert verdict_of_trajectories(a, barred).kind == DIFFER
    assert "no error estimate" not in verdict_of_trajectories(a, a).summary()


def test_one_revolution_of_a_motion_that_does_not_repeat_says_to_run_more():
    """One revolution has no revolutions after the first to take statistics on: the
    verdict is undecided and says how many revolutions would decide."""
    a = np.array([100.0])
    empty = _stats(np.array([]))
    v = verdict_of_peaks(a, 0.1, a + 5.0, 0.1, periodic=False, statistics_a=empty,
                         statistics_b=empty)
    assert v.kind == NOT_COMPARABLE and v.statistics == UNDECIDED
    assert v.statistics_items == ()
    assert "over 0 revolution(s)" in v.reason and "run at least 4 revolutions" in v.reason
    assert "statistics over revolutions" not in format_verdict(v)


def test_bars_are_asked_for_only_where_peaks_are_compared():
    """`verdict_of_trajectories(..., bars=f)` gives the runs their bars (e.g. Exudyn's by
    step halving, further runs) only where the motion is comparable peak by peak: where it
    is not, the statistics' intervals are the bars and the runs would change nothing."""
    import dataclasses

    from mbs_clearance import SliderCrank, simulate
    from mbs_clearance.analysis.verdict import verdict_of_trajectories

    a = simulate(SliderCrank(), 2)
    asked = []

    def bars(tr):
        asked.append(tr.backend)
        return dataclasses.replace(tr, stats={**tr.stats, "error_estimate": 0.02})

    b = dataclasses.replace(a, backend="exudyn", peaks=1.01 * np.asarray(a.peaks),
                            stats={k: v for k, v in a.stats.items() if k != "error_estimate"})
    # periodic (judged on 8 revolutions): both runs asked; the 1 % lies within 2 % bars
    assert verdict_of_trajectories(a, b, bars=bars).kind == AGREE
    assert asked == ["reduced", "exudyn"]
    asked.clear()
    flagged = [dataclasses.replace(tr, stats={**tr.stats, "periodic": False}) for tr in (a, b)]
    assert verdict_of_trajectories(*flagged, bars=bars).kind == NOT_COMPARABLE
    assert asked == []
