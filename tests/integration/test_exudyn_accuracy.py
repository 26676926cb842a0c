"""Exudyn's accuracy checked, not assumed: `simulate(..., backend="exudyn", accuracy=a)`
runs the step sequence h, h/2, h/4 (halved further while a bar exceeds a), returns the
extrapolated peaks with their error estimate, and warns when the request is not met."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mbs_clearance import AccuracyWarning, SliderCrank, peak_base_force, simulate
from mbs_clearance.backends import exudyn_convergence as xc
from mbs_clearance.backends import exudyn_linkage as xl
from mbs_clearance.model.cases import as_linkage
from mbs_clearance.solve.linkage_model import prepare_span

pytestmark = pytest.mark.exudyn


def test_the_step_sequence_and_its_record():
    """One revolution of the paper case at 3e-3: three runs at h, h/2, h/4 (the request is
    met by the first bar, 1.8e-3), the returned run is the h/4 one with the extrapolated
    peak; the peak-only entry point gives the same number."""
    mech = SliderCrank()
    tr = simulate(mech, 1, backend="exudyn", accuracy=3e-3)
    s = tr.stats
    h = s["accuracy_steps"]
    assert len(h) == 3 and h[1] == pytest.approx(h[0] / 2) and h[2] == pytest.approx(h[0] / 4)
    # (Exudyn fits a whole number of steps into the run: the step used is within 1e-5)
    assert s["step_size_used"] == pytest.approx(h[2], rel=1e-5)
    assert s["accuracy_ok"] and s["error_estimate"] <= 3e-3
    value, error, order = xc.richardson(*np.array(s["accuracy_peaks"]))
    # the bar: the step differences' plus the onsets' share (`onset_term`), a small part
    assert tr.peaks[0] == value[0]
    assert s["peak_errors"][0] == error[0] + s["onset_errors"][0]
    assert 0.0 < s["onset_errors"][0] < error[0]
    assert s["error_estimate"] == pytest.approx(s["peak_errors"][0] / value[0])
    assert peak_base_force(mech, 1, backend="exudyn", accuracy=3e-3) == tr.peaks[0]


def test_the_cli_prints_the_sequence_and_its_estimate(capsys):
    """`simulate --backend exudyn --accuracy` prints the extrapolated peak and the
    sequence's own estimate, the same as the Python call's."""
    from mbs_clearance.cli import main

    tr = simulate(SliderCrank(), 1, backend="exudyn", accuracy=3e-3)
    assert main(["simulate", "--backend", "exudyn", "--accuracy", "3e-3",
                 "--revolutions", "1"]) == 0
    out, err = capsys.readouterr()
    assert f"{tr.peaks[0]:.6g} N" in out
    s = tr.stats
    assert (f"estimated relative error of the peaks: {s['error_estimate']:.2g} (requested "
            f"0.003, met; step halving, 3 runs down to {s['accuracy_steps'][-1]:.3g} s, "
            f"the onsets' registration {s['onset_errors'][0] / tr.peaks[0]:.2g} of it)") in err


def test_unmet_accuracy_warns_and_is_flagged(monkeypatch):
    """1e-3 needs a fourth run (the bar of the first three is 1.8e-3); with no further
    halving allowed the run says so."""
    monkeypatch.setattr(xc, "MAX_HALVINGS", 0)
    with pytest.warns(AccuracyWarning, match="misses the requested accuracy 0.001"):
        tr = simulate(SliderCrank(), 1, backend="exudyn", accuracy=1e-3)
    assert tr.stats["accuracy_ok"] is False and tr.stats["error_estimate"] > 1e-3
    assert len(tr.stats["accuracy_steps"]) == 3


def test_bad_requests_fail_before_any_run(monkeypatch):
    def fail(*args, **kwargs):
        raise AssertionError("a run started despite a bad request")

    monkeypatch.setattr(xc, "_all_peaks", fail)
    monkeypatch.setattr(xl, "monitored_force", fail)
    with pytest.raises(ValueError, match="not both"):
        simulate(SliderCrank(), 1, backend="exudyn", accuracy=1e-4, step_size=1e-6)
    with pytest.raises(ValueError, match="accuracy"):
        simulate(SliderCrank(), 1, backend="exudyn", accuracy=0.5)
    with pytest.raises(ValueError, match="accuracy or rtol, not both"):
        simulate(SliderCrank(), 1, backend="exudyn", accuracy=1e-4, rtol=1e-8)
    with pytest.raises(ValueError, match="unknown option"):
        simulate(SliderCrank(), 1, backend="exudyn", accuracy=1e-4, atol=1e-8)


@pytest.mark.slow      # seven Exudyn runs down to h = 0.17 us: about a minute on a loaded machine
def test_exudyn_at_1e_4_meets_it_at_2000_rpm():
    """Off the point where the step law was calibrated (2000 rpm): the extrapolated peaks
    are within 1e-4 of the reduced model at rtol 1e-12 (the independent reference) and each
    revolution's bar covers its true error. Revolution 2's peak barely changes with the
    step (+2.75e-5, +2.31e-5, +1.98e-5 from 0.7 to 0.17 us): the last onset's registered
    impact velocity, whose error is not smooth in the step, cancels Exudyn's smooth step
    error between the runs, so the step differences alone (9e-6) miss the 2.0e-5; the
    onsets' share (`onset_term`) holds it."""
    mech = SliderCrank(crank_speed=2000 * 2 * math.pi / 60)
    tr = simulate(mech, 2, backend="exudyn", accuracy=1e-4)
    ref = simulate(mech, 2, rtol=1e-12).peaks
    err = np.abs(tr.peaks - ref)
    assert tr.stats["accuracy_ok"]
    assert np.all(err / ref < 1e-4), err / ref
    bars = np.asarray(tr.stats["peak_errors"])
    assert np.all(err <= bars), (err, bars)
    share = np.asarray(tr.stats["onset_errors"])
    # without the onsets' share revolution 2's bar would not cover its error
    assert err[1] > bars[1] - share[1], (err, bars, share)


def _between(lk, step_a, step_b, outputs=("all",)) -> int:
    """A max_memory between what one revolution of `lk` needs at two steps."""
    return (xl.estimate_memory(lk, 1, step_a, outputs)[1]
            + xl.estimate_memory(lk, 1, step_b, outputs)[1]) // 2


def test_a_finer_record_beyond_max_memory_records_its_peaks_only(tmp_path, monkeypatch):
    """1e-3 takes a fourth run (as above); with max_memory between the h/4 and h/8 records
    the fourth run records its peaks only: the series are the h/4 run's, the peaks the
    same extrapolated ones as without the limit, and the saved run loads back (its peaks
    within their stated offset of its samples). (The finer runs run full revolutions
    here: without that, the fourth would stop early after the peak and record its peaks
    only anyway, `_stop_time`.)"""
    monkeypatch.setattr(xc, "STOP_FRACTION", 0.0)
    from mbs_clearance import load_trajectory
    from mbs_clearance.model.cases import as_linkage

    mech = SliderCrank()
    free = simulate(mech, 1, backend="exudyn", accuracy=1e-3)
    h = free.stats["accuracy_steps"]
    assert len(h) == 4
    lk = as_linkage(mech)
    limit = _between(lk, h[2], h[3])
    tr = simulate(mech, 1, backend="exudyn", accuracy=1e-3, max_memory=limit)
    assert tr.stats["series_step"] == h[2] and tr.stats["step_size_used"] > 1.5 * h[3]
    assert tr.stats["accuracy_steps"] == h
    np.testing.assert_array_equal(tr.peaks, free.peaks)
    assert tr.stats["series_peak_offset"] > free.stats["series_peak_offset"]
    back = load_trajectory(tr.save(tmp_path / "run.npz"))
    np.testing.assert_array_equal(back.peaks, tr.peaks)


def test_an_h4_record_beyond_max_memory_records_the_h2_run():
    """With max_memory between the h/2 and h/4 records the series come from the h/2 run
    (recorded before h/4 is run), every finer run records its peaks only, and the peaks are
    the same extrapolated ones as without the limit (1e-3: four runs, as above)."""
    from mbs_clearance.model.cases import as_linkage

    mech = SliderCrank()
    free = simulate(mech, 1, backend="exudyn", accuracy=1e-3)
    h = free.stats["accuracy_steps"]
    lk = as_linkage(mech)
    limit = _between(lk, h[1], h[2])
    tr = simulate(mech, 1, backend="exudyn", accuracy=1e-3, max_memory=limit)
    assert tr.stats["series_step"] == h[1]
    assert tr.stats["accuracy_steps"] == h
    np.testing.assert_array_equal(tr.peaks, free.peaks)
    # the series' own peaks are the h/2 run's: farther from the extrapolated ones
    assert tr.stats["series_peak_offset"] > free.stats["series_peak_offset"]


def test_a_halving_beyond_max_memory_stops_the_sequence_unmet(monkeypatch):
    """1e-3 takes a fourth run (as above); with max_memory below even that run's peaks
    (the reactions at every step of a full revolution: the early stop is off here, as
    above) the sequence stops after three runs with the request unmet, warns and says why,
    instead of refusing the whole run."""
    monkeypatch.setattr(xc, "STOP_FRACTION", 0.0)
    from mbs_clearance.model.cases import as_linkage

    mech = SliderCrank()
    free = simulate(mech, 1, backend="exudyn", accuracy=1e-3)
    h = free.stats["accuracy_steps"]
    assert len(h) == 4
    lk = as_linkage(mech)
    limit = _between(lk, h[2], h[3], ("reactions",))
    with pytest.warns(AccuracyWarning, match="misses the requested accuracy"):
        peak = xc.peak_to_accuracy(mech, 1, 1e-3, max_memory=limit)
    conv, _ = xc._sequence(lk, prepare_span(lk, 1), 1e-3, {"max_memory": limit})
    assert conv.steps == tuple(h[:3]) and "exceed max_memory even for its peaks" in conv.stopped
    assert peak == conv.value[0] and conv.relative_error[0] > 1e-3


def test_a_stopped_run_is_the_beginning_of_the_full_run():
    """`exudyn_linkage.monitored_force` to `until`: the same steps and reactions as the full
    run up to the first step at or after `until` (the finer runs of a sequence stop there,
    `_stop_time`)."""
    from mbs_clearance.model.cases import as_linkage

    lk = as_linkage(SliderCrank())
    settings = xl.make_settings({"step_size": lk.period / 3000})
    t, force = xl.monitored_force(lk, prepare_span(lk, 1), settings, None, None)
    until = 0.3 * lk.period
    ts, fs = xl.monitored_force(lk, prepare_span(lk, 1), settings, None, None, until=until)
    h = t[1] - t[0]
    assert until <= ts[-1] < until + 1.01 * h and len(ts) < 0.31 * len(t)
    np.testing.assert_allclose(ts, t[:len(ts)], rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(fs, force[:len(fs)], rtol=0.0,
                               atol=1e-9 * np.max(np.abs(force)))


@pytest.mark.slow      # three full Exudyn revolutions of the four-bar (about 3 minutes)
def test_the_four_bar_at_restitution_0_5_meets_1e_4():
    """The four-bar at restitution 0.5, one revolution (its peak is the first impact of the
    centred start, at 1.4 ms): the sequence's peaks, read from the smoothed reactions,
    converge at second order, and the extrapolated peak is within 1e-4 of the reduced model
    at rtol 1e-12 (the independent reference), inside its bar."""
    from mbs_clearance.model import cases

    lk = cases.four_bar(restitution=0.5)
    ref = simulate(lk, 1, rtol=1e-12, max_steps=50_000_000).peaks[0]
    tr = simulate(lk, 1, backend="exudyn", accuracy=1e-4)
    s = tr.stats
    err = abs(tr.peaks[0] / ref - 1.0)
    assert s["accuracy_ok"] and err < 1e-4 and err * ref <= s["peak_errors"][0], (err, s)
    assert 1.7 < s["observed_order"][0] < 2.5


def test_a_finer_run_that_stops_early_needs_only_its_part_of_the_memory():
    """The paper case's peak lies early in its revolution, so the fourth run of the 1e-3
    sequence stops after it (`_stop_time`): with max_memory below that run's reactions
    over a whole revolution (the limit of the test above) it still runs and meets the
    request, with the same peaks as without the limit."""
    from mbs_clearance.model.cases import as_linkage

    mech = SliderCrank()
    lk = as_linkage(mech)
    free, _ = xc._sequence(lk, prepare_span(lk, 1), 1e-3, {})
    assert len(free.steps) == 4
    limit = _between(lk, free.steps[2], free.steps[3], ("reactions",))
    conv, _ = xc._sequence(lk, prepare_span(lk, 1), 1e-3, {"max_memory": limit})
    assert conv.steps == free.steps and conv.stopped == ""
    np.testing.assert_array_equal(conv.peaks, free.peaks)
    assert conv.relative_error[0] <= 1e-3


def test_converged_peaks_reads_the_runs_as_the_sequence_does():
    """The cross-check's `converged_peaks` from the sequence's first step: the same steps
    and peaks as `_sequence` at 1e-3 (four runs, the fourth stopped after the peak); each
    run's peaks are those of the smoothed reactions of the full run at that step
    (`smoothed`), not the raw ones."""
    from mbs_clearance.model.cases import as_linkage

    lk = as_linkage(SliderCrank())
    span = prepare_span(lk, 1)
    seq, _ = xc._sequence(lk, span, 1e-3, {})
    assert len(seq.steps) == 4
    conv = xc.converged_peaks(SliderCrank(), 1, step_size=seq.steps[0], accuracy=1e-3)
    assert conv.steps == seq.steps
    np.testing.assert_array_equal(conv.peaks, seq.peaks)
    np.testing.assert_array_equal(conv.value, seq.value)
    for k in (0, 3):        # a full run, and the one stopped after the peak
        settings = xl.make_settings({"step_size": seq.steps[k]})
        t, force = xl.monitored_force(lk, span, settings, None, None)
        f = xc.smoothed(force)
        own = xl.refined_peaks(t, np.hypot(f[:, 0], f[:, 1]), lk.period, 1)
        raw = xl.run_peaks(lk, span, settings)
        np.testing.assert_allclose(conv.peaks[k], own, rtol=1e-12)
        assert abs(raw[0] - own[0]) > 1e-12 * own[0]


def test_converged_peaks_stopped_run_needs_only_its_part_of_the_memory(monkeypatch):
    """With max_memory between the reactions of a full revolution at h/4 and at h/8, the
    cross-check's fourth run (h/8, stopped after the peak) runs and gives the peaks it gives
    without the limit; a stopped run whose part exceeds the limit, or with the early stop
    off the full h/8 run, is refused."""
    from mbs_clearance._checks import MemoryLimitError
    from mbs_clearance.model.cases import as_linkage

    lk = as_linkage(SliderCrank())
    h = xc.first_step(lk, 1e-3, {})
    free = xc.converged_peaks(SliderCrank(), 1, step_size=h, accuracy=1e-3)
    assert len(free.steps) == 4
    need = [xl.estimate_memory(lk, 1, step, ("reactions",))[1] for step in free.steps]
    limit = _between(lk, free.steps[2], free.steps[3], ("reactions",))
    conv = xc.converged_peaks(SliderCrank(), 1, step_size=h, accuracy=1e-3, max_memory=limit)
    np.testing.assert_array_equal(conv.peaks, free.peaks)
    # a stopped run beyond the limit is refused too: stopped at about 0.4 of the revolution,
    # the h/16 run needs 1.6 times the full h/4 run (1e-5 takes six runs without a limit)
    monkeypatch.setattr(xc, "STOP_WINDOW", 0.4)
    with pytest.raises(MemoryLimitError, match=r"at step \S+ s to \S+ s needs more than"):
        xc.converged_peaks(SliderCrank(), 1, step_size=h, accuracy=1e-5, max_memory=need[2])
    monkeypatch.setattr(xc, "STOP_FRACTION", 0.0)
    with pytest.raises(MemoryLimitError, match="max_memory"):
        xc.converged_peaks(SliderCrank(), 1, step_size=h, accuracy=1e-3, max_memory=limit)


def test_a_run_whose_impact_velocities_are_shifted_by_nothing_is_the_same_run():
    """The onsets' share of a bar (`exudyn_convergence.onset_term`) redoes a run with its
    impact velocities shifted: shifted by zero it is the same run to the bit, and shifted by
    1 % the registered values move by exactly that at the same onset times."""
    linkage = as_linkage(SliderCrank())
    span = prepare_span(linkage, 1)
    settings = xl.make_settings({})
    with xl.capturing_onsets() as capture:
        t, force = xl.monitored_force(linkage, span, settings)
    log = capture.registered[0]
    assert len(log) >= 2
    with xl.capturing_onsets({0: [0.0] * len(log)}) as again:
        _, force2 = xl.monitored_force(linkage, span, settings)
    np.testing.assert_array_equal(force2, force)
    assert again.registered == capture.registered
    shift = [0.01 * v for _, v in log[:1]]
    with xl.capturing_onsets({0: shift}) as changed:
        _, force3 = xl.monitored_force(linkage, span, settings)
    (t0, v0), (t1, v1) = log[0], changed.registered[0][0]
    # the crossing step's force took the shifted prediction: the refinement sees a state
    # moved by that, so the onset lands within a step and the shift to 1e-3 of itself
    print(t1 - t0, (v1 - v0) / shift[0] - 1.0)
    assert abs(t1 - t0) < settings.step(linkage)
    assert abs((v1 - v0) / shift[0] - 1.0) < 1e-3
    assert np.max(np.abs(force3 - force)) > 0.0


def test_the_registered_onset_time_is_the_crossing():
    """The pre-step function runs at t_n+1 with the state of t_n: the onset it registers
    lies at the crossing between the two states, not a step later. Against the reduced
    model's located event (rtol 1e-12): the first onset within 1e-3 of Exudyn's step."""
    from mbs_clearance.solve import linkage_model

    linkage = as_linkage(SliderCrank())
    run = linkage_model.run(linkage, 1, rtol=1e-12)
    t, modes = run[1], run[3]
    event = t[np.nonzero(np.diff(modes[:, 0]) > 0)[0][0] + 1]
    ex = simulate(linkage, 1, backend="exudyn")
    (first,) = ex.stats["first_onsets"].values()
    assert abs(first - event) <= 1e-3 * ex.stats["step_size_used"], (first, event)
