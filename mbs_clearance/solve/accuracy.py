"""Runs of the reduced model to a requested accuracy: `simulate(mech, accuracy=1e-5)`.

An adaptive method's error follows its tolerance, so two runs at different tolerances
estimate the error of the less accurate one; the run tightens until the estimate is within
the requested relative accuracy on its per-revolution peaks (the reported peaks).

1. The first run (recorded) is at rtol = accuracy x `RTOL_PER_ACCURACY` (1e-7 for 1e-5: the
   default that the accuracy map found within 1e-5 on every design whose diagnostics raise
   no flag).
2. If its diagnostics do not flag it (`reduced.contact_flags`, per clearance joint: grazing
   onsets, a slowly settling contact, rattling; the check failed on the four-bar, whose
   peaks' error does not fall with rtol between 1e-5 and 1e-7, and which its hundreds of
   contact onsets per revolution flag), a cheap check: the peaks alone (nothing recorded) at
   `CHECK_LOOSER` x that rtol. The peaks' error falls at least `MIN_REDUCTION`-fold per
   decade of rtol (measured on the paper case: 7.4, 3.9 and 4.7-fold from 1e-4 to 1e-7), R =
   MIN_REDUCTION ** log10(CHECK_LOOSER)-fold between the two runs, so their difference d
   bounds the first run's error by d / (R - 1).
3. If the first run is flagged, or the check's estimate misses the request: runs at rtol / 10,
   / 100, ... (recorded): the difference of two successive runs bounds the coarser one's
   error, hence the finer one's; the finer run is returned as soon as the difference is
   within the request, or at `MIN_RTOL`. A rattling run (not periodic: its late peaks depend
   on every digit, and no tolerance makes them accurate) takes one tighter run for the
   estimate and is returned itself, flagged in its stats (``accuracy_ok`` False, the
   ``accuracy_note``) and with an `AccuracyWarning`, as a run at a fixed rtol.

The returned run's stats hold ``accuracy`` (requested), ``error_estimate`` (the estimate's
relative error of the per-revolution peaks), ``error_estimate_method`` ("looser run" or
"tighter run"), ``accuracy_runs`` (the rtols run, in order, with "peaks" for a run that
recorded nothing), ``accuracy_nfev`` (the function evaluations of all of them) and
``accuracy_ok`` (the estimate is within the request). The series between the peaks are not
estimated separately: the tighter run that sets the peaks' accuracy sets theirs.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .._checks import check_real
from .._warnings import AccuracyWarning

__all__ = ["DEFAULT_ACCURACY", "simulate_to_accuracy", "peak_difference", "value_to_accuracy"]

#: the accuracy a run meets by default (relative, on the per-revolution peaks)
DEFAULT_ACCURACY = 1e-5

#: the first run's rtol per unit of requested accuracy (1e-7 at 1e-5: the accuracy map's
#: default, docs/performance.md)
RTOL_PER_ACCURACY = 1e-2

#: the cheap check's rtol over the first run's (peaks only): the check cost 0.61 of the
#: recorded run at 10 x, 0.57 at 30 x and 0.41 at 100 x (paper case, medians of 15
#: alternating rounds, loaded machine); 100 x keeps the whole run within 1.5 x a run at the
#: fixed rtol. The assumed error reduction over the 2 decades, 16-fold, is just inside the
#: measured 17-fold (paper case, 1e-5 -> 1e-7)
CHECK_LOOSER = 100.0

#: least reduction of the peaks' error per decade of rtol (measured 3.9-7.4 on the paper
#: case, `test_error_falls_monotonically_with_rtol_in_the_paper_case`)
MIN_REDUCTION = 4.0

#: rtol divisor of each tighter run
TIGHTEN = 10.0

#: the tightest rtol run (the accuracy map's reference)
MIN_RTOL = 1e-12

#: loosest rtol of a check run (the reduced model warns above it)
MAX_RTOL = 1e-4

#: least growth of the function evaluations from a run to one at a tenfold tighter rtol for
#: their agreement to count as an estimate (dopri5 takes 10^(1/5) = 1.6 times the steps,
#: DOP853 1.3 times): where a step bound (``h_max``) and not the tolerance sets the steps,
#: runs at every rtol take the same steps and agree while sharing their error (a slider-
#: crank with its crank-coupler joint loose, 0.05 mm, 3000 rpm, h_max 1.9 us: rtol 1e-7 and
#: 1e-8 agreed within 8e-7, both 1.0e-3 off the peak at rtol 1e-12; nfev 125293 and 125299)
MIN_WORK_GROWTH = 1.1


def peak_difference(a, b) -> float:
    """Largest relative difference max |a - b| / |b| of two runs' per-revolution peaks (a
    window without samples, peak 0 in both, counts as equal; a revolution that a run on
    output times does not sample, NaN, is left out)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = np.maximum(np.abs(b), np.finfo(float).tiny)
    d = np.where((a == 0.0) & (b == 0.0), 0.0, np.abs(a - b) / scale)
    d = d[~np.isnan(d)]
    return float(np.max(d)) if d.size else 0.0


def revolution_peaks(traj) -> np.ndarray:
    """A Trajectory's per-revolution peaks: its refined `peaks`, or (a run on output times)
    the maxima over its samples (NaN for a revolution it has no sample in)."""
    if traj.peaks is not None:
        return np.asarray(traj.peaks, dtype=float)
    return np.array([traj.max_base_force(k) if np.any(traj.revolution_mask(k)) else np.nan
                     for k in range(1, traj.revolutions + 1)])


def _round(rtol: float) -> float:
    """rtol to 12 digits (1e-5 x 1e-2 is 1e-7 exactly, the default's run bit for bit)."""
    return float(f"{rtol:.12g}")


def _quiet(fn, *args, **kwargs):
    """fn(...) with its AccuracyWarnings held back (the estimate replaces the flags)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        return fn(*args, **kwargs)


def simulate_to_accuracy(record, peaks, accuracy: float, *, rattling=None):
    """The Trajectory of `record(rtol)` within `accuracy` on its peaks (module docstring).

    record(rtol) -> Trajectory (its ``peaks`` per revolution and ``stats`` with
    ``accuracy_ok`` from the diagnostics, ``nfev``); peaks(rtol) -> (peaks, nfev) without a
    record; rattling(traj) -> bool (no tightening beyond one tighter run)."""
    accuracy = check_real("accuracy (relative error of the peaks)", accuracy, 1e-10, 1e-3)
    rtol = _round(min(max(accuracy * RTOL_PER_ACCURACY, MIN_RTOL), MAX_RTOL))
    traj = _quiet(record, rtol)
    runs, nfev = [rtol], int(traj.stats.get("nfev", 0))
    # a run without diagnostics counts as flagged: the looser check failed on the four-bar
    # (1 revolution at 10 rpm: its peaks at rtol 1e-5 and 1e-7 agree within 7e-5 while both
    # are 7.7e-5 off; the check estimated 4.6e-6), which its contact onsets flag
    flagged = traj.stats.get("accuracy_ok") is not True
    estimate, how = math.inf, "tighter run"
    loose = _round(min(CHECK_LOOSER * rtol, MAX_RTOL))
    if not flagged and loose >= 2.0 * rtol:
        check, n = _quiet(peaks, loose)
        runs.append((loose, "peaks"))
        nfev += n
        reduction = MIN_REDUCTION ** math.log10(loose / rtol)
        if _tolerance_sets_steps(n, int(traj.stats.get("nfev", 0)), loose / rtol):
            estimate = peak_difference(revolution_peaks(traj), check) / (reduction - 1.0)
        how = "looser run"
    rattles = False
    if estimate > accuracy and rattling is not None and rattling(traj):
        # not periodic: no tolerance makes its late peaks accurate; one tighter run gives
        # the estimate of this run's error, and this run is returned (as at a fixed rtol)
        rattles = True
        fine = _quiet(record, _round(rtol / TIGHTEN))
        runs.append(_round(rtol / TIGHTEN))
        nfev += int(fine.stats.get("nfev", 0))
        estimate = peak_difference(revolution_peaks(traj), revolution_peaks(fine))
        how = "tighter run"
    elif estimate > accuracy:
        fines = []

        def recorded(r):
            fines.append(record(r))
            return fines[-1]

        finer, tighter, rtol, rtols = _tighten(
            recorded, lambda a, b: peak_difference(revolution_peaks(a), revolution_peaks(b)),
            traj, rtol, accuracy, work=lambda tr: int(tr.stats.get("nfev", 0)))
        if rtols:
            traj, estimate, how = finer, tighter, "tighter run"
            runs += rtols
            nfev += sum(int(f.stats.get("nfev", 0)) for f in fines)
    ok = bool(estimate <= accuracy)
    note = "" if ok else (
        f"the estimated error of the peaks, {estimate:.2g} (from a {how} at rtol "
        f"{runs[-1] if how == 'tighter run' else loose:g}), misses the requested accuracy "
        f"{accuracy:g}"
        + (" (the motion rattles, not periodic: its late peaks depend on every digit; the "
           f"run at rtol {rtol:g} is returned)" if rattles
           else f" at the tightest rtol tried, {rtol:g}")
        + " (the run is flagged: accuracy not met)")
    traj.stats.update(accuracy=accuracy, error_estimate=estimate, error_estimate_method=how,
                      accuracy_runs=runs, accuracy_nfev=nfev, accuracy_ok=ok,
                      accuracy_note=note)
    if note:
        warnings.warn(note, AccuracyWarning, stacklevel=3)
    return traj


def _tolerance_sets_steps(n_coarse: int, n_fine: int, ratio: float) -> bool:
    """Whether a run at a `ratio` times tighter rtol did the more work that a tolerance-set
    step sequence does (`MIN_WORK_GROWTH` per decade; unknown counts, 0, pass)."""
    if n_coarse <= 0 or n_fine <= 0:
        return True
    return n_fine >= n_coarse * MIN_WORK_GROWTH ** math.log10(ratio)


def _tighten(run, difference, coarse, rtol: float, accuracy: float, work=None):
    """Runs ``run(rtol)`` at rtol / 10, / 100, ... after `coarse` (the run at `rtol`) until
    two successive runs differ by at most `accuracy` (``difference(coarser, finer)``) or
    `MIN_RTOL`: (the finest run, the last difference, its rtol, the rtols run). The
    difference of two runs bounds the coarser one's error, hence the finer one's, where the
    tolerance sets their steps: with `work` (a run's function evaluations) two runs whose
    work did not grow (`_tolerance_sets_steps`) do not end the tightening."""
    estimate, rtols = math.inf, []
    while rtol / TIGHTEN >= MIN_RTOL * (1 - 1e-9):
        rtol = _round(rtol / TIGHTEN)
        fine = _quiet(run, rtol)
        rtols.append(rtol)
        estimate = difference(coarse, fine)
        evidence = work is None or _tolerance_sets_steps(work(coarse), work(fine), TIGHTEN)
        coarse = fine
        if estimate <= accuracy and evidence:
            break
    return coarse, estimate, rtol, rtols


def check_accuracy_or_rtol(accuracy, options) -> None:
    """ValueError when both a requested `accuracy` and a fixed ``rtol`` in `options` are
    given (the accuracy chooses the tolerances)."""
    if accuracy is not None and "rtol" in options:
        raise ValueError("give accuracy or rtol, not both (accuracy chooses the tolerances)")


def value_to_accuracy(value, accuracy: float):
    """(result, estimate, rtol, rtols) of ``value(rtol)`` within `accuracy`: ``value(rtol)``
    returns (number, ...) for one run at `rtol`; runs at rtol = accuracy x
    `RTOL_PER_ACCURACY`, then / 10, / 100, ... until two successive numbers differ by at
    most `accuracy` relative (the difference bounds the coarser run's error, hence the
    finer one's), or `MIN_RTOL`; the finer run's result is returned. For study outputs that
    have no diagnostics of their own (any output of a linkage); an `AccuracyWarning` says
    when the request was not reached."""
    accuracy = check_real("accuracy (relative error of the peaks)", accuracy, 1e-10, 1e-3)
    rtol = _round(min(max(accuracy * RTOL_PER_ACCURACY, MIN_RTOL), MAX_RTOL))
    start = rtol
    coarse, estimate, rtol, tighter = _tighten(
        value, lambda a, b: peak_difference(a[0], b[0]), _quiet(value, rtol), rtol, accuracy)
    rtols = [start] + tighter
    if estimate > accuracy:
        warnings.warn(f"the estimated error of the output, {estimate:.2g} (from a tighter run "
                      f"at rtol {rtol:g}), misses the requested accuracy {accuracy:g} at the "
                      f"tightest rtol tried", AccuracyWarning, stacklevel=3)
    return coarse, estimate, rtol, rtols
