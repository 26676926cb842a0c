"""validation.regime_scan's summaries: contact switches per revolution counted from a
recorded run, the summary of a span of revolutions, and its command-line input."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from validation import regime_scan
from validation.regime_scan import settled_summary, switches_per_revolution


def test_switches_per_revolution_counts_mode_changes_by_revolution():
    # two joints (mode, impact velocity per joint); period 1 s, 3 revolutions
    ts = np.array([0.0, 0.2, 0.5, 0.9, 1.1, 1.5, 2.0, 2.5, 3.0])
    modes_a = [0, 1, 1, 0, 0, 0, 1, 1, 1]        # switches at 0.2, 0.9 | 2.0
    modes_b = [0, 0, 0, 0, 1, 1, 1, 1, 0]        # switches at 1.1 | 3.0 (the last instant)
    ms = np.column_stack([modes_a, np.full(9, 0.3), modes_b, np.full(9, 0.1)])
    got = switches_per_revolution(ts, ms, 1.0, 3)
    # revolution 1: 0.2, 0.9; revolution 2: 1.1; revolution 3: 2.0 and 3.0 (the end)
    assert got.tolist() == [2, 1, 2]


def test_switches_of_a_recorded_run_are_the_integrators_events():
    """The count from the recorded modes equals the integrator's own event counter, and
    the recording run has the unrecorded run's peaks (the same steps)."""
    from mbs_clearance.model.cases import CASES

    lk = CASES["four_bar"](crank_speed=math.pi, clearance=1e-4)   # 30 rpm: impacts
    rec = regime_scan.adaptive_peaks(lk, 2, 1e-8, per_revolution=True)
    plain = regime_scan.adaptive_peaks(lk, 2, 1e-8)
    assert rec["per_revolution"].sum() == rec["events"] > 0
    assert rec["per_revolution"][0] == rec["events_first"]
    np.testing.assert_array_equal(rec["peaks"], plain["peaks"])


def _run(rtol, peaks, per_revolution=None):
    r = {"rtol": rtol, "peaks": np.asarray(peaks, float), "events": 0, "events_first": 0}
    if per_revolution is not None:
        r["per_revolution"] = np.asarray(per_revolution)
    return r


def test_settled_summary_of_a_span():
    loose = _run(1e-9, [10.0, 4.0, 2.0, 2.2, 2.0], [9, 0, 3, 1, 2])
    tight = _run(1e-10, [10.0, 4.0, 2.0, 2.1, 2.0])
    s = settled_summary([loose, tight], 3)
    # revolutions 3-5 at the tighter rtol: 2.0, 2.1, 2.0
    assert s["peak"] == pytest.approx((2.0, 2.0, 2.1))
    # changes between consecutive revolutions of the span: 4 -> 5 and 3 -> 4 only
    changes = sorted([0.1 / 2.1, 0.1 / 2.0])
    assert s["change"] == pytest.approx((changes[0], np.median(changes), changes[1]))
    # between the rtols, relative to the tighter: 0, 0.1 / 2.1, 0
    assert s["between"] == pytest.approx((0.0, 0.0, 0.1 / 2.1))
    assert s["events"] == [(1, 3, 6), None]
    assert settled_summary([tight], 2)["between"] is None


def test_override_input():
    assert regime_scan._override("crank_speed=20rpm") == ("crank_speed",
                                                          pytest.approx(20 * 2 * math.pi / 60))
    assert regime_scan._override("clearance=1e-4") == ("clearance", 1e-4)
    with pytest.raises(ValueError, match="NAME=VALUE"):
        regime_scan._override("clearance")
    with pytest.raises(ValueError, match="override clearance: the value must be a number"):
        regime_scan._override("clearance=0.1mm")


@pytest.mark.parametrize("argv, message", [
    (["four_bar", "8", "adaptive", "1e-9", "--from", "8"], r"--from must be in \[2, 7\]; got 8"),
    (["four_bar", "8", "adaptive"], "'adaptive' needs the rtols"),
    (["four_bar", "8", "adaptive", "2"], r"the rtols must be in \(0, 1\)"),
    (["four_bar", "8", "adaptive", "1e-9", "foo=1"], r"unknown override\(s\) \['foo'\]"),
    (["four_bar", "8", "100", "--events"], "--events go with 'adaptive'"),
    (["flores_translational_slider_crank", "8", "adaptive", "1e-9"], "is free"),
])
def test_bad_input_is_refused_in_one_line_before_running(argv, message, capsys):
    with pytest.raises(SystemExit) as stop:
        regime_scan.main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("python -m validation.regime_scan: error: ")
    assert re.search(message, err), err


def test_the_approach_to_the_orbit_is_what_the_revolutions_print(capsys):
    """The summary of how a run approaches its orbit, from the per-revolution lines it
    prints: the ratio of consecutive changes from revolution 4 on, and each revolution's
    peak against the last one's."""
    regime_scan.main_adaptive("paper_slider_crank", 6, [1e-10], {})
    out = capsys.readouterr().out
    peaks = [float(m) for m in re.findall(r"^revolution \d: peaks (\S+) N", out, re.M)]
    changes = [float(m) for m in re.findall(r"previous revolution (\S+)$", out, re.M)][2:]
    ratios = np.array(changes[1:]) / np.array(changes[:-1])
    m = re.search(r"^revolutions 2-6: ratio of consecutive changes median (\S+) \((\S+) to "
                  r"(\S+)\) from revolution 4 on$", out, re.M)
    # the printed changes carry 3 digits: their ratios to 1e-2
    assert [float(g) for g in m.groups()] == pytest.approx(
        [np.median(ratios), ratios.min(), ratios.max()], abs=1e-2)
    against = re.search(r"^against revolution 6's peak at rtol 1e-10: (.*)$", out, re.M)[1]
    got = [float(x.split()[-1]) for x in against.split(", ")]
    assert got == pytest.approx([p / peaks[-1] - 1 for p in peaks[:-1]], rel=0.05, abs=1e-12)
