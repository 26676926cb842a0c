"""Exudyn's peaks converged in the step: runs at h, h/2, h/4 and Richardson extrapolation.

Exudyn's generalized-alpha runs at a fixed step h; its peaks (refined between the samples,
`exudyn_linkage.refined_peaks`: the vertex of the parabola through the largest sample and
its neighbours) converge as h is halved. From three runs at h, h/2, h/4, per value y:

- observed order p = log2(|y_h - y_h/2| / |y_h/2 - y_h/4|);
- extrapolated value y_h/4 + (y_h/4 - y_h/2) / (2^p - 1);
- error estimate (the bar of the extrapolated value): the last difference |y_h/4 - y_h/2|.
  With an order p >= 1 and the values converging monotonically, the limit lies between
  y_h/4 and y_h/4 + (y_h/4 - y_h/2) / (2^p - 1), within |y_h/4 - y_h/2| of y_h/4, and so does
  the extrapolated value: their distance is at most that difference whatever the true
  order. (The correction itself, |y_h/4 - y_h/2| / (2^p - 1), was too small a bar: at 2000
  rpm, paper case, revolution 2, observed order 3.2, it was 2.8e-5 of the peak where the
  extrapolated value was 4.2e-5 from the reduced model at rtol 1e-12.)

Where the two differences do not shrink in the same direction at an order within
[`MIN_ORDER`, `MAX_ORDER`] (not yet in the asymptotic range), nothing is extrapolated: the
value is y_h/4 and its bar the larger of the two differences.

MIN_ORDER is 1 so that the bar's argument holds.

The bar also holds the onsets' share (`onset_term`): Exudyn registers each contact's impact
velocity from the steps around its onset, with an error that is not smooth in the step and
that the differences above can cancel; one more run at the last step but one, its impact
velocities shifted onto the last run's, measures it.

The step sequences of `simulate_to_accuracy`, `peak_to_accuracy` and `converged_peaks` read
each run of a driven linkage (`_run_peaks`) from the monitored force smoothed against the
step-alternating roundoff oscillation of Exudyn's reactions (`SMOOTHING`), and run the
halvings beyond h/4 only to shortly after the last value near each revolution's peak where
that saves at least half of a run (`_stop_time`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .._checks import check_int
from ..model.cases import as_linkage
from ..solve.linkage_model import prepare_span

__all__ = ["Convergence", "richardson", "converged_peaks", "MIN_ORDER", "MAX_ORDER",
           "simulate_to_accuracy", "peak_to_accuracy", "first_step", "MAX_HALVINGS"]

#: further halvings beyond h/4 while a bar exceeds the requested accuracy (each doubles the
#: cost of the last run: at most 2^MAX_HALVINGS times the h/4 run, a small fraction of it
#: where the finer runs stop early, `_stop_time`)
MAX_HALVINGS = 4

#: weights of the smoothing of the monitored force's components before a step sequence
#: reads its peaks (`smoothed`): a zero of second order at the step-alternating frequency
#: 1/(2h), exact on cubics (a smooth signal changes by -h^4 f^(4) / 16, beyond
#: generalized-alpha's O(h^2)). Exudyn's reactions (index-3 multipliers) carry a
#: step-alternating oscillation from the positions' roundoff, growing as 1 / h^2 and
#: independent of Newton's tolerance: read raw, it breaks the sequences' order below ~1 us
#: in the four-bar (docs/exudyn.md, "Roundoff in the reactions at small steps").
SMOOTHING = np.array([-1.0, 4.0, 10.0, 4.0, -1.0]) / 16.0


def _end_weights() -> np.ndarray:
    """(2, 5) weights of the last sample and the one before it on the last five, last first
    (`END_SMOOTHING`)."""
    k = np.arange(5.0)                  # samples counted back from the last
    basis = np.column_stack([k**0, k, k**2, k**3, (-1.0) ** k])   # a cubic + c (-1)^k
    cubic_at = np.column_stack([basis[:2, :4], np.zeros(2)])       # its cubic part at 0, 1
    # w_j . y = the cubic part at j of the fit through y: w_j = basis^-T cubic_at[j]
    return np.linalg.solve(basis.T, cubic_at.T).T


#: weights of the last two samples of a run (rows: the last, the one before) on the last
#: five, last first (`smoothed`): the cubic part there of the fit of a cubic plus
#: c (-1)^k through the five end samples, so again exact on cubics with a zero response to
#: the step-alternating component: (15, 4, -6, 4, -1) / 16 and (1, 12, 6, -4, 1) / 16 (the
#: same fit at the centre sample gives `SMOOTHING`); noise gains (root sum of squares) 1.07
#: and 0.88, against 0.72 inside. The first two samples stay raw: the first is the initial
#: state's force, exact at every step, and generalized-alpha's start-up ringing decays
#: rather than alternating at a constant amplitude (with these weights at the start too,
#: the translational benchmark's first window, whose peak is the force at t = 0, read
#: +2.6e-6, +1.2e-6, +1.6e-7 off at 2.5, 1.3 and 0.64 us instead of exact).
END_SMOOTHING = _end_weights()

#: the finer runs of a sequence (beyond h/4) stop STOP_WINDOW periods after the last sample
#: of the h/4 run within PEAK_MARGIN of its revolution's peak, where that saves at least
#: STOP_FRACTION of the run (`_stop_time`): nothing later in the revolution can become its
#: peak unless the finer steps move a value by PEAK_MARGIN, ten times and more the h/4
#: run's step error at the accuracies the sequence is for
PEAK_MARGIN = 0.05
STOP_WINDOW = 0.01
STOP_FRACTION = 0.5

#: observed orders accepted for extrapolation (generalized-alpha is second order)
MIN_ORDER = 1.0
MAX_ORDER = 4.0


def richardson(y_h, y_h2, y_h4):
    """(value, error, order) arrays from values at steps h, h/2, h/4 (module docstring); the
    order is NaN where nothing was extrapolated."""
    y1, y2, y4 = (np.asarray(v, dtype=float) for v in (y_h, y_h2, y_h4))
    d1, d2 = y1 - y2, y2 - y4
    with np.errstate(divide="ignore", invalid="ignore"):
        p = np.log2(np.abs(d1) / np.abs(d2))
    ok = (np.sign(d1) == np.sign(d2)) & (d2 != 0.0) & (p >= MIN_ORDER) & (p <= MAX_ORDER)
    p = np.where(ok, p, np.nan)
    with np.errstate(invalid="ignore"):
        correction = np.where(ok, (y4 - y2) / (2.0 ** p - 1.0), 0.0)
    value = y4 + correction
    error = np.where(ok, np.abs(d2), np.maximum(np.abs(d1), np.abs(d2)))
    return value, error, p


def extrapolate(peaks):
    """`richardson` on the last three rows of `peaks` (one row per step, halved each time),
    its bar widened where an earlier row shows the sequence is not yet converging: with
    four or more rows, where the last three differences do not share their sign, the
    largest of them (a sequence that turned before its last three values is not in the
    asymptotic range, whatever order those three suggest: a revolution-2 peak of a slider-
    crank with its crank-coupler joint loose went 2005, 2111, 1920, 1903 N, an observed
    order 3.5 and a bar of 17 N, against 2033 N converged)."""
    peaks = np.asarray(peaks, dtype=float)
    value, error, order = richardson(*peaks[-3:])
    if len(peaks) >= 4:
        d = np.diff(peaks[-4:], axis=0)
        turned = (np.sign(d[0]) != np.sign(d[1])) | (np.sign(d[1]) != np.sign(d[2]))
        error = np.where(turned, np.maximum(error, np.max(np.abs(d), axis=0)), error)
        order = np.where(turned, np.nan, order)
    return value, error, order


@dataclass(frozen=True)
class Convergence:
    """Exudyn's per-revolution peaks (N) at the steps h, h/2, h/4 and their extrapolation."""

    #: the steps in s (h, h/2, h/4 and any further halvings)
    steps: tuple
    #: (len(steps), revolutions) refined peaks at each step
    peaks: np.ndarray
    #: (revolutions,) extrapolated peaks (or the h/4 peak where nothing was extrapolated)
    value: np.ndarray
    #: (revolutions,) error estimate of `value`, N
    error: np.ndarray
    #: (revolutions,) observed order (NaN: not extrapolated)
    order: np.ndarray
    #: wall time of each run in s
    seconds: tuple
    #: why the halving stopped short of the request ("": met, or MAX_HALVINGS reached)
    stopped: str = ""
    #: (revolutions,) the onsets' share of `error`, N (`onset_term` times `_onset_weight`);
    #: None: not estimated
    onset: np.ndarray | None = None
    #: why the onsets' share was not estimated ("": it was, or the runs register no onset)
    onset_note: str = ""
    #: wall time of the runs that estimated the onsets' share, s
    onset_seconds: float = 0.0

    @property
    def relative_error(self) -> np.ndarray:
        """error / |value| per revolution."""
        return self.error / np.abs(self.value)


def converged_peaks(mech, revolutions: int = 4, *, step_size: float | None = None,
                    accuracy: float | None = None, max_halvings: int = 3,
                    **options) -> Convergence:
    """Per-revolution peaks of the monitored force from Exudyn runs at step_size h (default:
    the backend's default step for `mech`'s description, `ExudynSettings.step`), h/2 and h/4,
    extrapolated (`richardson`). With `accuracy` (relative): while a revolution's bar
    exceeds it, one more run at half the last step (at most `max_halvings` more), the
    extrapolation from the last three. Other `options`: the backend's (`ExudynSettings`
    fields but step_size and accuracy, ``max_memory``, ``start``); `steps` and `peaks` of
    the result hold every run, `value`, `error`, `order` come from the last three.
    A driven linkage's runs are read as the step sequences of `simulate_to_accuracy` read
    them (`_run_peaks`: the smoothed monitored force, the runs beyond h/4 stopped shortly
    after the peaks where `_stop_time` allows); a free linkage's windows from the smoothed
    monitored force as well (`_all_peaks`).
    The bars hold the onsets' share too (`_OnsetBars`: one more run at the last step but
    one, made once the step differences meet `accuracy`, and for the last pair)."""
    from . import exudyn_linkage as xl

    revolutions = check_int("revolutions", revolutions, 1)
    if "accuracy" in options:
        raise ValueError("converged_peaks chooses its steps from step_size; leave accuracy "
                         "out")
    linkage = as_linkage(mech)
    max_memory = options.pop("max_memory", None)
    start = options.pop("start", None)
    span = prepare_span(linkage, revolutions, max_memory=max_memory)
    if step_size is None:
        step_size = xl.make_settings(dict(options)).step(linkage)
    if accuracy is not None:
        from .._checks import check_real

        accuracy = check_real("accuracy (relative error of the peaks)", accuracy, 1e-10, 0.1)
    max_halvings = check_int("max_halvings", max_halvings, 0)
    free = span.revolutions is None
    steps, peaks, seconds, onsets = [], [], [], []
    series, stop = None, None

    def run(h):
        nonlocal series
        settings = xl.make_settings({**options, "step_size": h})
        t0 = time.perf_counter()
        with xl.capturing_onsets() as capture:
            if free:
                peaks.append(_all_peaks(linkage, span, settings, max_memory, start))
                end = float(span.edges[-1])
            else:
                # a run stopped at a fraction f of the span stores as much as a full one at
                # h / f
                if stop is not None and not _fits(linkage, span,
                                                  h * float(span.edges[-1]) / stop,
                                                  max_memory, ("reactions",)):
                    from .._checks import MemoryLimitError, check_max_memory

                    raise MemoryLimitError(
                        f"the Exudyn run at step {h:g} s to {stop:.3g} s needs more than "
                        f"max_memory={check_max_memory(max_memory)} bytes for its "
                        "reactions; raise step_size, max_memory or accuracy")
                row, t, mag = _run_peaks(linkage, span, settings, max_memory, start, stop)
                peaks.append(row)
                series = (t, mag)
                end = float(t[-1])
        onsets.append((end, capture.registered))
        seconds.append(time.perf_counter() - t0)
        steps.append(h)

    for h in (step_size, step_size / 2.0, step_size / 4.0):
        run(h)
    value, error, order = richardson(*peaks[-3:])
    if not free:
        stop = _stop_time(*series, linkage.period, revolutions)
    onset = _OnsetBars(linkage, span, options, max_memory, start, steps, peaks, onsets)
    total = onset.bars(value, error, stop, accuracy)
    for _ in range(max_halvings if accuracy is not None else 0):
        if np.all(total <= accuracy * np.abs(value)):
            break
        run(steps[-1] / 2.0)
        value, error, order = extrapolate(peaks)
        total = onset.bars(value, error, stop, accuracy)
    total = onset.bars(value, error, stop)
    return Convergence(steps=tuple(steps), peaks=np.array(peaks), value=value, error=total,
                       order=order, seconds=tuple(seconds), onset=onset.share,
                       onset_note=onset.note, onset_seconds=onset.seconds)


def _all_peaks(linkage, span, settings, max_memory, start) -> np.ndarray:
    """A free linkage's refined peaks per window of `span` (N) of one Exudyn run recording
    the reactions only, read as the step sequences read their recorded runs (the smoothed
    monitored force)."""
    from . import exudyn_linkage as xl

    return _window_peaks(*xl.monitored_force(linkage, span, settings, max_memory, start),
                         span)


def _window_peaks(t, force, span) -> np.ndarray:
    """Refined peaks per window of `span` (N) of a free linkage's monitored force (n, 2) at
    times t, smoothed as the step sequences read it."""
    from . import exudyn_linkage as xl

    force = smoothed(force)
    return xl.window_peaks(t, np.hypot(force[:, 0], force[:, 1]), span.windows)


def _run_peaks(linkage, span, settings, max_memory, start, stop=None):
    """The peaks of one driven linkage's Exudyn run at the settings' step as the step
    sequences read them: (per-revolution refined peaks of the smoothed monitored force in N,
    t in s, that force's magnitude in N) of a run recording the reactions only, to its end
    or stopped at `stop` s (`_stop_time`; run in full where its largest value moved to the
    cut, `_moved_to_the_cut`; the caller checked the stopped run's memory)."""
    from . import exudyn_linkage as xl

    revolutions = span.revolutions
    t, force = xl.monitored_force(linkage, span, settings, max_memory, start, stop)
    row, mag = _sequence_peaks(t, force, linkage.period, revolutions)
    if stop is not None and _moved_to_the_cut(t, mag, linkage.period, revolutions, stop):
        t, force = xl.monitored_force(linkage, span, settings, max_memory, start)
        row, mag = _sequence_peaks(t, force, linkage.period, revolutions)
    return row, t, mag


def order_of(a: float, b: float, c: float) -> float:
    """Observed order log2(|a - b| / |b - c|) of three values at halved steps (NaN if
    undefined)."""
    d1, d2 = abs(a - b), abs(b - c)
    return math.log2(d1 / d2) if d1 > 0.0 and d2 > 0.0 else math.nan


def first_step(linkage, accuracy: float, options: dict) -> float:
    """The first step h of the sequence for a requested relative `accuracy`: the step that
    the second-order law (`exudyn_linkage.step_for_accuracy`) gives for 4 x accuracy, so
    that the bar of the h/2, h/4 pair (3/16 of the error at h) meets the request where the
    law holds; at most the description's contact-period limit."""
    from . import exudyn_linkage as xl

    return xl.make_settings({**options, "accuracy": min(4.0 * accuracy, 0.1)}).step(linkage)


def _sequence(linkage, span, accuracy: float, options: dict, record=None,
              max_halvings: int | None = None, only: int | None = None):
    """Runs over `span` (a `Span`, `linkage_model.prepare_span`) at h, h/2, h/4
    (`first_step`), halved further while a revolution's bar exceeds `accuracy` (at most
    `max_halvings` more): (Convergence, the last recorded run or None).
    The runs from h/4 on are recorded by `record(h)` (a Trajectory with per-revolution
    ``peaks``) where given, else peaks only; where `_stop_time` allows, the runs beyond h/4
    stop early and record peaks only. Every run's peaks (a driven linkage's per revolution, a
    free one's per window) are read from the smoothed monitored force (`smoothed`).
    `only`: the index of the one revolution whose bar counts (None: all)."""
    from .._checks import check_real
    from . import exudyn_linkage as xl

    accuracy = check_real("accuracy (relative error of the peaks)", accuracy, 1e-8, 0.1)
    max_halvings = MAX_HALVINGS if max_halvings is None else max_halvings
    if options.get("step_size") is not None:
        raise ValueError("give step_size or accuracy, not both (accuracy chooses the steps)")
    options = dict(options)
    max_memory = options.pop("max_memory", None)
    start = options.pop("start", None)
    for name in ("duration", "window"):     # a free linkage's span: its record's
        options.pop(name, None)
    xl.make_settings(dict(options))         # bad values fail before any run
    h = first_step(linkage, accuracy, options)
    steps, peaks, seconds, last = [], [], [], None
    revolutions = span.revolutions
    free = revolutions is None              # a free linkage: every run recorded (windows)

    series = None        # (t, smoothed |monitored force|) of the last full-length run
    stop = None          # the finer runs' end time in s (`_stop_time`), None: full runs
    onsets = []          # per run (its end in s, its registered onsets, `capturing_onsets`)

    def run(step, recorded):
        nonlocal last, series
        t0 = time.perf_counter()
        settings = xl.make_settings({**options, "step_size": step})
        with xl.capturing_onsets() as capture:
            if free:
                last = record(step)
                last.stats["series_step"] = step
                t = last.t
                peaks.append(_window_peaks(t, last.base_force, span))
            elif stop is not None:
                row, t, _ = _run_peaks(linkage, span, settings, max_memory, start, stop)
                peaks.append(row)
            else:
                if recorded and (last is None or _fits(linkage, span, step, max_memory)):
                    last = record(step)
                    last.stats["series_step"] = step
                    t = last.t
                    row, mag = _sequence_peaks(t, last.base_force, linkage.period,
                                               revolutions)
                else:
                    # a record beyond max_memory: this run's peaks only; the series stay
                    # those of the last recorded run
                    row, t, mag = _run_peaks(linkage, span, settings, max_memory, start)
                peaks.append(row)
                series = (t, mag)
        onsets.append((float(t[-1]), capture.registered))
        seconds.append(time.perf_counter() - t0)
        steps.append(step)

    # the series are recorded at h/4, or at the finest of h/2, h whose record fits within
    # max_memory (a long run: the four-bar's 4 revolutions need 6 GiB at h/4)
    at = 2
    while record is not None and not free and at > 0 and not _fits(
            linkage, span, h / 2.0 ** at, max_memory):
        at -= 1
    for k, step in enumerate((h, h / 2.0, h / 4.0)):
        run(step, record is not None and k == at)
    if not free:
        stop = _stop_time(*series, linkage.period, revolutions)
    fraction = 1.0 if stop is None else stop / (revolutions * linkage.period)
    value, error, order = richardson(*peaks[-3:])
    pick = slice(None) if only is None else slice(only, only + 1)
    stopped = ""
    onset = _OnsetBars(linkage, span, options, max_memory, start, steps, peaks, onsets)
    total = onset.bars(value, error, stop, accuracy, pick)
    for _ in range(max_halvings):
        if np.all(total[pick] <= accuracy * np.abs(value[pick])):
            break
        # a run of a fraction f of the span at step s stores as much as a full one at s / f
        if not free and not _fits(linkage, span, steps[-1] / 2.0 / fraction,
                                  max_memory, ("reactions",)):
            # even its peaks (the reactions at every step) exceed max_memory: stop here,
            # unmet (e.g. a motion that does not repeat, whose later peaks never converge)
            stopped = (f"; the next run (step {steps[-1] / 2.0:.3g} s) would exceed "
                       "max_memory even for its peaks")
            break
        run(steps[-1] / 2.0, record is not None and stop is None)
        value, error, order = extrapolate(peaks)
        total = onset.bars(value, error, stop, accuracy, pick)
    total = onset.bars(value, error, stop)      # unmet too: the share belongs in the bars
    conv = Convergence(steps=tuple(steps), peaks=np.array(peaks), value=value, error=total,
                       order=order, seconds=tuple(seconds), stopped=stopped,
                       onset=onset.share, onset_note=onset.note,
                       onset_seconds=onset.seconds)
    return conv, last


class _OnsetBars:
    """A step sequence's bars with the onsets' share (`onset_term` times `_onset_weight`),
    estimated once per last pair of runs, where the step differences alone meet the
    request (an unmet pair is halved anyway) or, without a request, when asked for."""

    def __init__(self, linkage, span, options, max_memory, start, steps, peaks, onsets):
        self.args = (linkage, span, options)
        self.memory = (max_memory, start)
        self.steps, self.peaks, self.onsets = steps, peaks, onsets
        self.share, self.note, self.seconds = None, "", 0.0
        self.pair = None        # len(steps) when the share was estimated

    def bars(self, value, error, stop, accuracy=None, pick=slice(None)):
        """`error` plus the share of the current last pair (N per revolution), estimated
        now where `accuracy` is None or `error` meets it; `error` alone otherwise."""
        if self.pair != len(self.steps):
            if accuracy is not None and not np.all(
                    error[pick] <= accuracy * np.abs(value[pick])):
                return error
            t0 = time.perf_counter()
            term, self.note = onset_term(*self.args, self.steps, self.peaks, self.onsets,
                                         stop, *self.memory)
            self.seconds += time.perf_counter() - t0
            self.share = None if term is None else _onset_weight(value, self.peaks) * term
            self.pair = len(self.steps)
        return error if self.share is None else error + self.share


def _onset_weight(value, peaks) -> np.ndarray:
    """How much of the last run's onset error the value carries, per revolution: 1 + c
    where value = y_last + c (y_last - y_prev) (c = 1 / (2^p - 1) where extrapolated at
    order p, 0 where the value is the last run's)."""
    y_prev, y_last = (np.asarray(r, dtype=float) for r in peaks[-2:])
    d = np.abs(y_last - y_prev)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.where(d > 0.0, np.abs(np.asarray(value, dtype=float) - y_last) / d, 0.0)
    return 1.0 + c


def onset_term(linkage, span, options: dict, steps, peaks, onsets, stop, max_memory, start):
    """The onsets' share of a step sequence's bar: (per revolution, N; or None and why).

    Exudyn registers each contact's impact velocity at its onset from the states of the
    steps around the crossing (`exudyn_linkage._pre_step`); the registration's error
    depends on where the crossing falls within the step and is not a smooth function of
    the step, so the differences between the runs, where the smooth step error is read,
    can cancel it (docs/exudyn.md, "The 2000 rpm difference in revolution 2"). The run at
    the last step but one is made again with each contact's first n impact velocities
    shifted onto the last run's (n: the onsets the last run registered; the same number
    must lie within the same time in the run being redone): the change of its peaks is
    the effect of the registrations' change between the two steps, R_last - R_prev.
    Taking |R_last| to be at most that change (the registrations' error falls with the
    step; measured at 2000 rpm: 1.7e-3, 3.7e-4, 1.9e-5, 1.5e-5 of the impact velocity from
    0.7 us to 0.0875 us), the value's share is at most (1 + 1 / (2^p - 1)) times it
    (`_onset_weight`). A free linkage's run is redone over its whole span, recording the
    reactions only (`_all_peaks`)."""
    from . import exudyn_linkage as xl

    (end, fine), (_, coarse) = onsets[-1], onsets[-2]
    shift = {}
    for index, log in fine.items():
        before = [v for t, v in coarse.get(index, []) if t <= end]
        if len(before) != len(log):
            return None, (f"not estimated: the last two runs register {len(before)} and "
                          f"{len(log)} onsets of contact {index + 1} (a grazing contact "
                          "one step finds and the other does not)")
        shift[index] = [v - u for (_, v), u in zip(log, before)]
    if not any(shift.values()):
        return np.zeros_like(np.asarray(peaks[-1], dtype=float)), ""
    settings = xl.make_settings({**options, "step_size": steps[-2]})
    with xl.capturing_onsets(shift):
        if span.revolutions is None:
            row = _all_peaks(linkage, span, settings, max_memory, start)
        else:
            row = _run_peaks(linkage, span, settings, max_memory, start, stop)[0]
    return np.abs(np.asarray(row) - np.asarray(peaks[-2])), ""


def smoothed(force) -> np.ndarray:
    """The (n, 2) force components (N) smoothed with `SMOOTHING`, the last two samples with
    the one-sided `END_SMOOTHING` (a peak at a run's last instant is read smoothed too),
    the first two unchanged; fewer than 5 samples are returned unchanged."""
    raw = np.array(force, dtype=float)
    force = raw.copy()
    if len(force) >= len(SMOOTHING):
        for c in range(force.shape[1]):
            force[2:-2, c] = np.convolve(raw[:, c], SMOOTHING, mode="valid")
        force[-2:] = (END_SMOOTHING @ raw[:-6:-1])[::-1]
    return force


def _sequence_peaks(t, force, period: float, revolutions: int):
    """(per-revolution refined peaks of the smoothed force's magnitude in N, that magnitude)
    of a run recorded to its end or stopped early (`_stop_time`: every revolution's peak
    lies before the stop)."""
    from . import exudyn_linkage as xl

    t = np.asarray(t, dtype=float)
    f = smoothed(force)
    mag = np.hypot(f[:, 0], f[:, 1])
    return xl.refined_peaks(t, mag, period, revolutions), mag


def _stop_time(t, mag, period: float, revolutions: int):
    """End time in s of the finer runs (`PEAK_MARGIN`, `STOP_WINDOW`), or None where the
    stop would not save `STOP_FRACTION` of the run: the last sample within PEAK_MARGIN of
    its revolution's peak, over the revolutions, plus STOP_WINDOW periods."""
    tol = 1e-12 * max(1.0, revolutions * period)
    stop = 0.0
    for k in range(revolutions):
        inside = (t >= k * period - tol) & (t <= (k + 1) * period + tol)
        tk, mk = t[inside], mag[inside]
        stop = max(stop, float(tk[mk >= (1.0 - PEAK_MARGIN) * mk.max()][-1]))
    stop += STOP_WINDOW * period
    return stop if stop <= STOP_FRACTION * revolutions * period else None


def _moved_to_the_cut(t, mag, period: float, revolutions: int, stop: float) -> bool:
    """Whether a stopped run's largest value in the last revolution it reaches lies in the
    last half window before the stop (its peak may then lie beyond: run it in full)."""
    k = min(int(stop // period), revolutions - 1)
    inside = t >= k * period
    return bool(t[inside][np.argmax(mag[inside])] > stop - 0.5 * STOP_WINDOW * period)


def _fits(linkage, span, step: float, max_memory, outputs=("all",)) -> bool:
    """A run over `span` at `step` recording `outputs` fits within `max_memory`
    (`exudyn_linkage._check_run`)."""
    from .._checks import MemoryLimitError
    from . import exudyn_linkage as xl

    try:
        xl._check_run(linkage, span, xl.make_settings({"step_size": step}), outputs,
                      max_memory)
    except MemoryLimitError:
        return False
    return True


def _accuracy_stats(conv: Convergence, accuracy: float) -> dict:
    rel = conv.relative_error
    estimate = float(np.max(rel)) if rel.size else 0.0
    ok = bool(estimate <= accuracy)
    note = "" if ok else (
        f"Exudyn's estimated error of the peaks, {estimate:.2g} (step halving down to "
        f"{conv.steps[-1]:.3g} s: the difference of the last two steps' peaks and the "
        f"onsets' share), misses the requested accuracy {accuracy:g} after "
        f"{len(conv.steps)} runs{conv.stopped} (stats['accuracy_ok'] is False; the peaks "
        "are the extrapolated ones)")
    onset = None if conv.onset is None else [float(e) for e in conv.onset]
    return dict(accuracy=accuracy, error_estimate=estimate,
                error_estimate_method="step halving", accuracy_ok=ok, accuracy_note=note,
                onset_errors=onset, onset_note=conv.onset_note,
                onset_seconds=float(conv.onset_seconds),
                accuracy_steps=list(conv.steps),
                accuracy_peaks=[list(map(float, p)) for p in conv.peaks],
                observed_order=[float(p) for p in conv.order],
                peak_errors=[float(e) for e in conv.error],
                accuracy_seconds=float(sum(conv.seconds)),
                accuracy_run_seconds=[float(x) for x in conv.seconds], peaks_extrapolated=True)


def simulate_to_accuracy(mech, revolutions: int | None, accuracy: float, record, **options):
    """Exudyn's run of `mech` with its per-revolution peaks (a free linkage, revolutions None: its
    per-window peaks, every run recorded by ``record(h)`` over its ``duration`` and
    ``window``) converged in the step to `accuracy` (relative): the step sequence h, h/2,
    h/4, ... of `_sequence`, the last run recorded (``record(h)`` -> Trajectory). The
    returned Trajectory holds that run's series and, as ``peaks``, the extrapolated peaks
    (`richardson`); its stats hold ``error_estimate`` (largest relative bar over the
    revolutions), ``accuracy_ok``, ``accuracy_steps``, ``accuracy_peaks`` (each run's),
    ``observed_order`` and ``peak_errors`` (N; they hold the onsets' share, ``onset_errors``
    in N per revolution, `onset_term`, or None with ``onset_note`` saying why it was not
    estimated; ``onset_seconds`` its run's time). An `AccuracyWarning` says when the request
    was not met within `MAX_HALVINGS` further halvings. The series are recorded at h/4, or
    at the finest of h/2 and h whose record fits ``max_memory`` (default min(4 GiB, half the
    RAM)); a finer run whose record would exceed it, or that stops early after the peaks
    (`_stop_time`), records its peaks only and the series are the last recorded run's
    (``stats["series_step"]``;
    ``stats["series_peak_offset"]``: the relative distance of its own refined peaks from
    the extrapolated ones)."""
    import warnings

    from .._warnings import AccuracyWarning

    linkage = as_linkage(mech)
    span = prepare_span(linkage, revolutions, duration=options.get("duration"),
                        window=options.get("window"), max_memory=options.get("max_memory"))
    conv, traj = _sequence(linkage, span, accuracy, options, record)
    stats = _accuracy_stats(conv, accuracy)
    # the series may come from a coarser run than the last (a finer record would exceed
    # max_memory): how far its own refined peaks lie from the extrapolated ones
    own = np.asarray(traj.peaks, dtype=float)
    stats["series_peak_offset"] = float(np.max(np.abs(own - conv.value) / np.abs(conv.value)))
    traj.stats.update(stats)
    traj = _with_peaks(traj, conv.value)
    if stats["accuracy_note"]:
        warnings.warn(stats["accuracy_note"], AccuracyWarning, stacklevel=3)
    return traj


def _with_peaks(traj, peaks):
    from dataclasses import replace

    return replace(traj, peaks=np.asarray(peaks, dtype=float))


def peak_to_accuracy(mech, revolution: int, accuracy: float, **options) -> float:
    """Exudyn's peak of revolution `revolution` (N) converged in the step to `accuracy`
    (`simulate_to_accuracy` without a record: every run records the reactions only); an
    `AccuracyWarning` when not met."""
    import warnings

    from .._warnings import AccuracyWarning

    revolution = check_int("revolution", revolution, 1)
    linkage = as_linkage(mech)
    span = prepare_span(linkage, revolution, max_memory=options.get("max_memory"),
                        name="revolution")
    conv, _ = _sequence(linkage, span, accuracy, options, only=revolution - 1)
    rel = float(conv.relative_error[revolution - 1])
    if rel > accuracy:
        warnings.warn(f"Exudyn's estimated error of the peak, {rel:.2g} (step halving down to "
                      f"{conv.steps[-1]:.3g} s: the difference of the last two steps' peaks "
                      f"and the onsets' share), misses the requested accuracy {accuracy:g}"
                      f"{conv.stopped}", AccuracyWarning, stacklevel=3)
    return float(conv.value[revolution - 1])
