"""The verdict of a cross-check of two models: do they agree within their error bars?

Each model gives a value of a quantity with its own error estimate (its "bar"): the
reduced model at its requested accuracy (`simulate(..., accuracy=)`, ``stats
["error_estimate"]``), Exudyn converged by step halving and extrapolation
(`exudyn_convergence`). The verdict (`Verdict.kind`) is one of

- ``"agree"``: every compared quantity's difference is within the two bars together;
- ``"differ"``: at least one difference exceeds them (`Verdict.worst` says which quantity and
  by how much);
- ``"not decided: no error bar"``: a difference beyond the bars where a model has no error
  estimate (a run at a fixed step or tolerance, its bar 0): part of the difference may be
  that model's own error, so it decides nothing (`validation.compare.step_bars` gives an
  Exudyn run at a fixed step its bar: two more runs at h/2 and h/4);
- ``"not comparable peak by peak"``: the motion is chaotic or has not settled (a Lyapunov
  exponent that is positive or undecided, or the return map of the revolution boundaries
  finds no period: ``stats["periodic"]`` False or None; a run too short for the return
  map, fewer than 3 revolutions, is judged on a reduced run of `JUDGE_REVOLUTIONS`). Two
  correct models then separate after a few impacts, and their peaks in a given revolution
  mean nothing against each other. The comparison moves to statistics over the
  revolutions after the first: the mean of the per-revolution peaks, of the
  per-revolution RMS and of the per-revolution time average of the monitored force, each
  with a 95 % Student-t confidence interval over the revolutions (`mean_interval`) as its
  bar; `Verdict.statistics` ("agree", "differ", or "undecided" with fewer than
  `MIN_STATISTICS_REVOLUTIONS` revolutions) is taken on those.

The bars of two models add: two values whose true values are equal differ by at most the
sum of their errors, so a difference beyond the sum is a model difference whenever each bar
covers its model's error.

`compare` and `cross_check` (``mbs-clearance compare``), the validation report and the
Python API (`verdict_of_peaks`, `verdict_of_trajectories`) build the same `Verdict`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

__all__ = ["AGREE", "DIFFER", "NO_BAR", "NOT_COMPARABLE", "UNDECIDED", "Item", "Verdict",
           "comparable", "judge_periodicity", "periodic_flag", "mean_interval",
           "revolution_statistics", "verdict_of_peaks", "verdict_of_trajectories",
           "format_verdict", "with_missing_bars", "has_bars", "MIN_STATISTICS_REVOLUTIONS",
           "JUDGE_REVOLUTIONS"]

AGREE = "agree"
DIFFER = "differ"
NO_BAR = "not decided: no error bar"
NOT_COMPARABLE = "not comparable peak by peak"
UNDECIDED = "undecided"

#: fewest revolutions (after the first) over which statistics give a verdict: a t-interval
#: from two values has 1 degree of freedom (t = 12.7) and says almost nothing
MIN_STATISTICS_REVOLUTIONS = 3

#: revolutions of the reduced run that judges the periodicity of a motion whose compared run
#: is too short for the return map (fewer than 3 revolution boundaries): the paper case's
#: return distance falls about 5-fold per revolution, below the tolerance by revolution 4
JUDGE_REVOLUTIONS = 8

#: Student-t 97.5 % quantiles for 1..30 degrees of freedom (two-sided 95 % interval)
_T975 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201,
         2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069,
         2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042)


def _t975(dof: int) -> float:
    if dof < 1:
        return math.inf
    return _T975[dof - 1] if dof <= len(_T975) else 1.96 + 2.4 / dof


@dataclass(frozen=True)
class Item:
    """One compared quantity: each model's value and bar (same unit, e.g. N), a the
    reference."""

    quantity: str
    a: float
    a_error: float
    b: float
    b_error: float

    @property
    def difference(self) -> float:
        """b - a."""
        return self.b - self.a

    @property
    def relative_difference(self) -> float:
        """b / a - 1."""
        return self.b / self.a - 1.0 if self.a != 0.0 else math.inf

    @property
    def bars(self) -> float:
        """The two bars together."""
        return self.a_error + self.b_error

    @property
    def agree(self) -> bool:
        """The difference is within the two bars together (NaN anywhere: False)."""
        return bool(abs(self.difference) <= self.bars)

    @property
    def excess(self) -> float:
        """|difference| / bars: how many times the bars the difference is (inf: zero
        bars)."""
        d = abs(self.difference)
        return d / self.bars if self.bars > 0.0 else (0.0 if d == 0.0 else math.inf)


@dataclass(frozen=True)
class Verdict:
    """The verdict of a comparison of models a (reference) and b (module docstring)."""

    #: "agree", "differ", "not decided: no error bar" or "not comparable peak by peak"
    kind: str
    model_a: str
    model_b: str
    #: the peak-by-peak items (per revolution); compared also where not comparable, for
    #: the record
    items: tuple
    #: why the motion is (not) comparable peak by peak
    reason: str = ""
    #: where not comparable: the verdict on the statistics ("agree", "differ",
    #: "undecided"); "" otherwise
    statistics: str = ""
    #: where not comparable: the statistics items (mean over revolutions, 95 % interval)
    statistics_items: tuple = ()

    @property
    def decisive_items(self) -> tuple:
        """The items the verdict is taken on: the statistics where not comparable peak by
        peak, else the peaks."""
        return self.statistics_items if self.kind == NOT_COMPARABLE else self.items

    @property
    def worst(self) -> Item | None:
        """The decisive item whose difference is the most bars (None: no items)."""
        items = self.decisive_items
        return max(items, key=lambda i: i.excess) if items else None

    @property
    def agree(self) -> bool:
        """The models agree: peak by peak, or on the statistics where not comparable."""
        return self.kind == AGREE or (self.kind == NOT_COMPARABLE and self.statistics == AGREE)

    def summary(self) -> str:
        """One sentence: the verdict and, for a difference, by how much and where."""
        return _summary(self)

    def to_dict(self) -> dict:
        return asdict(self)


def mean_interval(values) -> tuple[float, float]:
    """(mean, half-width of its 95 % Student-t confidence interval) of `values` (the
    per-revolution values of a quantity); half-width inf with fewer than 2 values."""
    x = np.asarray(values, dtype=float)
    if x.size == 0:
        return math.nan, math.inf
    if x.size < 2:
        return float(x[0]), math.inf
    return float(x.mean()), float(_t975(x.size - 1) * x.std(ddof=1) / math.sqrt(x.size))


def comparable(periodic=None, lyapunov=None, transient: bool = False) -> tuple[bool, str]:
    """Is the motion comparable peak by peak? From the periodicity flags (True, False or
    None, `trajectory.periodicity`; one per model, or one) and an optional Lyapunov
    result (its ``verdict``: "negative" or "zero" comparable, "positive" or "undecided"
    not). The Lyapunov verdict decides where given; otherwise every flag must be True.
    `transient`: a free linkage's motion from one initial state over a set span, always
    comparable: each model's bar comes from refining its own steps over that span, so it
    holds whatever the span amplifies. Returns (comparable, the reason)."""
    if transient:
        return True, ("a transient from one initial state: each peak against the bars of "
                      "its own refinement")
    if lyapunov is not None:
        v = getattr(lyapunov, "verdict", lyapunov)
        ok = v in ("negative", "zero")
        return ok, (f"Lyapunov exponent {v}"
                    + ("" if ok else ": the motion is chaotic or not settled"))
    flags = periodic if isinstance(periodic, (tuple, list)) else (periodic,)
    if all(f is True for f in flags):
        return True, "periodic (the state at the revolution boundaries repeats)"
    if any(f is False for f in flags):
        return False, ("not periodic: the state at the revolution boundaries does not repeat "
                       "(chaotic, quasi-periodic or a long transient)")
    return False, ("periodicity undetermined (too few revolutions or a transient that has "
                   "not settled)")


def judge_periodicity(mech, revolutions: int = JUDGE_REVOLUTIONS) -> tuple:
    """(periodic flag, note) of `mech`'s motion from a reduced run of `revolutions` drive
    revolutions at the default accuracy (`trajectory.periodicity`); (None, why) for a free
    linkage, which has no revolutions to compare."""
    import warnings

    from .._warnings import AccuracyWarning
    from ..solve.simulate import simulate

    drive = getattr(mech, "drive", True)
    if drive is None:
        return None, "undetermined: a free linkage has no drive revolutions to compare"
    with warnings.catch_warnings():
        # a rattling run warns of its accuracy; here only its periodicity flag counts
        warnings.simplefilter("ignore", AccuracyWarning)
        tr = simulate(mech, revolutions, rtol=1e-9)
    return tr.stats.get("periodic"), tr.stats.get("periodicity_note", "")


def periodic_flag(traj) -> bool | None:
    """A run's periodicity flag, judged on a longer reduced run (`judge_periodicity`) where
    the run is too short for its return map (``stats["periodic"]`` None)."""
    flag = traj.stats.get("periodic")
    if flag is None and traj.revolutions < JUDGE_REVOLUTIONS:
        flag = judge_periodicity(traj.mechanism)[0]
    return flag


def revolution_statistics(traj, revolutions=None) -> dict[str, np.ndarray]:
    """Per-revolution values of the monitored force |F| (N) of a Trajectory: ``peak``
    (its refined per-revolution peak), ``rms`` and ``mean`` (time averages, trapezoidal
    rule on the samples over each revolution); `revolutions` (1-based) default 2..n (the
    first holds the start's transient)."""
    from ..solve.accuracy import revolution_peaks

    n = traj.revolutions
    revs = tuple(range(2, n + 1)) if revolutions is None else tuple(revolutions)
    peaks = revolution_peaks(traj)
    f = traj.base_force_magnitude
    rms, mean = [], []
    for k in revs:
        m = traj.revolution_mask(k)
        t, y = traj.t[m], f[m]
        span = t[-1] - t[0]
        mean.append(float(np.trapezoid(y, t) / span))
        rms.append(float(np.sqrt(np.trapezoid(y * y, t) / span)))
    return {"revolutions": np.array(revs, dtype=int),
            "peak": np.array([peaks[k - 1] for k in revs]),
            "rms": np.array(rms), "mean": np.array(mean)}


def _statistics_items(sa: dict, sb: dict) -> tuple:
    items = []
    for key, label in (("peak", "mean of the per-revolution peaks"),
                       ("rms", "mean of the per-revolution RMS"),
                       ("mean", "time average")):
        ma, ha = mean_interval(sa[key])
        mb, hb = mean_interval(sb[key])
        # no numerical error added: in a motion that is not settled a run's error in one
        # revolution is another sample of the same distribution, which the interval over
        # the revolutions already covers
        items.append(Item(f"{label} of |F|, revolutions {_span(sa['revolutions'])}",
                          ma, ha, mb, hb))
    return tuple(items)


def _span(revs) -> str:
    revs = list(revs)
    return f"{revs[0]}-{revs[-1]}" if len(revs) > 1 else (str(revs[0]) if revs else "none")


def verdict_of_peaks(a, a_error, b, b_error, *, model_a: str = "reduced",
                     model_b: str = "exudyn", revolutions=None, periodic=None,
                     lyapunov=None, statistics_a: dict | None = None,
                     statistics_b: dict | None = None, span: str = "revolution",
                     transient: bool = False) -> Verdict:
    """The verdict on per-revolution peaks a, b (N) with their bars a_error, b_error (N,
    scalars or per revolution).

    Parameters
    ----------
    a, a_error, b, b_error : array_like
        Each model's per-revolution peaks and error bars, N (a the reference).
    model_a : str, default "reduced"
        Name of the first model, for the record.
    model_b : str, default "exudyn"
        Name of the second model, for the record.
    revolutions : sequence of int or None
        The revolutions (1-based) of the peaks; None: 1..len(a).
    periodic, lyapunov
        The motion's periodicity flags and an optional Lyapunov result (`comparable`).
    statistics_a, statistics_b : dict or None
        Per-revolution statistics of each model (`revolution_statistics`); needed where the
        motion is not comparable peak by peak (else the statistics verdict is "undecided").
    span : str, default "revolution"
        What a peak is taken over, in the quantities' names ("window" for a free linkage's
        time windows).
    transient : bool
        A free linkage's motion over a set span (`comparable`).

    Returns
    -------
    Verdict
    """
    a, b = np.atleast_1d(np.asarray(a, dtype=float)), np.atleast_1d(np.asarray(b, dtype=float))
    if a.shape != b.shape:
        raise ValueError(f"the two models' peaks must have the same length; got {a.size} "
                         f"and {b.size}")
    ea = np.broadcast_to(np.asarray(a_error, dtype=float), a.shape)
    eb = np.broadcast_to(np.asarray(b_error, dtype=float), b.shape)
    if np.any(ea < 0) or np.any(eb < 0):
        raise ValueError("error bars must be >= 0")
    revs = range(1, a.size + 1) if revolutions is None else revolutions
    items = tuple(Item(f"peak of |F| in {span} {k}", float(x), float(ex), float(y),
                       float(ey)) for k, x, ex, y, ey in zip(revs, a, ea, b, eb))
    ok, reason = comparable(periodic, lyapunov, transient)
    if ok:
        kind = AGREE if all(i.agree for i in items) else DIFFER
        return Verdict(kind, model_a, model_b, items, reason)
    stats, sitems = UNDECIDED, ()
    if statistics_a is not None and statistics_b is not None:
        n = min(len(statistics_a["peak"]), len(statistics_b["peak"]))
        sitems = _statistics_items(statistics_a, statistics_b) if n else ()
        if n >= MIN_STATISTICS_REVOLUTIONS:
            stats = AGREE if all(i.agree for i in sitems) else DIFFER
        else:
            reason += (f"; statistics over {n} revolution(s) after the first decide nothing "
                       f"(at least {MIN_STATISTICS_REVOLUTIONS}: run at least "
                       f"{MIN_STATISTICS_REVOLUTIONS + 1} revolutions)")
    else:
        reason += "; no per-revolution statistics given"
    return Verdict(NOT_COMPARABLE, model_a, model_b, items, reason, stats, sitems)


def _flags(a, b) -> tuple:
    """The two runs' periodicity flags, judged once on a longer run where either is too
    short."""
    flags = [tr.stats.get("periodic") for tr in (a, b)]
    if None in flags and min(a.revolutions, b.revolutions) < JUDGE_REVOLUTIONS:
        judged = judge_periodicity(a.mechanism)[0]
        flags = [judged if f is None else f for f in flags]
    return tuple(flags)


def _relative_error(traj) -> float:
    e = traj.stats.get("error_estimate")
    return float(e) if isinstance(e, (int, float)) and math.isfinite(e) else 0.0


def _bars(traj, peaks: np.ndarray) -> np.ndarray:
    """Each revolution's bar (N): its own (``stats["peak_errors"]``, Exudyn's step
    sequence per revolution) where the run has them, else the run's relative estimate x
    the peak (one erratic revolution's bar would otherwise widen every other's)."""
    own = traj.stats.get("peak_errors")
    if own is not None and len(own) == len(peaks):
        return np.abs(np.asarray(own, dtype=float))
    return _relative_error(traj) * np.abs(peaks)


def verdict_of_trajectories(a, b, revolutions=None, *, lyapunov=None,
                            bars=None) -> Verdict:
    """The verdict on two Trajectories of the same mechanism (a the reference).

    Their per-revolution peaks, each with its own bar (`_bars`: a run's per-revolution
    ``stats["peak_errors"]``, else ``stats["error_estimate"]`` x peak; 0 where a run has
    no estimate: a run at a fixed tolerance or step, whose error is unknown), comparable
    peak by peak where both runs are periodic (``stats["periodic"]``) or the given
    Lyapunov result says so; else on the statistics of revolutions 2..n.

    Parameters
    ----------
    a, b : Trajectory
        The two runs, a the reference.
    revolutions : sequence of int or None
        The revolutions (1-based) compared; None: every one both cover.
    lyapunov
        An optional Lyapunov result (`comparable`).
    bars : callable or None
        Trajectory -> Trajectory: gives a run without an estimate its bars first (e.g.
        `validation.compare.step_bars`: an Exudyn run at a fixed step, from two more runs at
        h/2 and h/4), called on each run only where the motion is comparable peak by peak
        (elsewhere the statistics' intervals are the bars and it would change nothing).

    Returns
    -------
    Verdict
        A difference beyond the bars where a model still has no estimate is
        "not decided: no error bar" (`NO_BAR`), not "differ".
    """
    from ..solve.accuracy import revolution_peaks

    n = min(a.revolutions, b.revolutions)
    revs = tuple(range(1, n + 1)) if revolutions is None else tuple(revolutions)
    flags = _flags(a, b)
    if bars is not None and comparable(flags, lyapunov)[0]:
        a, b = bars(a), bars(b)
    pa, pb = revolution_peaks(a), revolution_peaks(b)
    ea, eb = _bars(a, pa), _bars(b, pb)
    x = np.array([pa[k - 1] for k in revs])
    y = np.array([pb[k - 1] for k in revs])
    later = tuple(range(2, n + 1))
    v = verdict_of_peaks(x, np.array([ea[k - 1] for k in revs]), y,
                         np.array([eb[k - 1] for k in revs]), model_a=a.backend,
                         model_b=b.backend, revolutions=revs,
                         periodic=flags,
                         lyapunov=lyapunov,
                         statistics_a=revolution_statistics(a, later),
                         statistics_b=revolution_statistics(b, later))
    v = with_missing_bars(v, [tr.backend for tr in (a, b) if not has_bars(tr)])
    return _with_step_note(v, [tr for tr in (a, b) if "step_bars_seconds" in tr.stats])


def has_bars(traj) -> bool:
    """The run carries an error estimate (``stats["error_estimate"]`` or per-revolution
    ``stats["peak_errors"]``)."""
    return "error_estimate" in traj.stats or "peak_errors" in traj.stats


def _with_step_note(v: Verdict, barred) -> Verdict:
    """`v` with the note of the step-halving runs that gave a run its bars."""
    if not barred:
        return v
    tr = barred[0]
    h = tr.stats["accuracy_steps"][0]
    note = (f"; {tr.backend}'s bars from runs at its step {h:.3g} s halved twice, "
            f"{tr.stats['step_bars_seconds']:.3g} s")
    return replace(v, reason=v.reason + note)


def with_missing_bars(v: Verdict, missing) -> Verdict:
    """`v` with the note that the models `missing` have no error estimate (bar 0); a
    difference beyond the bars then decides nothing (part of it may be that model's error):
    a differing `v` becomes "not decided: no error bar" (`NO_BAR`). `v` itself where none
    is missing."""
    if not missing:
        return v
    note = (f"; no error estimate for {' and '.join(missing)} (bar 0: give it one with "
            f"accuracy=, compare's step bars or compare --accuracy X)")
    kind = NO_BAR if v.kind == DIFFER else v.kind
    return Verdict(kind, v.model_a, v.model_b, v.items, v.reason + note, v.statistics,
                   v.statistics_items)


def _summary(v: Verdict) -> str:
    if v.kind == AGREE:
        return (f"verdict: {v.model_a} and {v.model_b} agree within their error bars "
                f"({len(v.items)} quantities; {v.reason})")
    if v.kind in (DIFFER, NO_BAR):
        w = v.worst
        where = (f"{w.quantity}: {w.a:.6g} N +- {w.a_error:.2g} N vs {w.b:.6g} N +- "
                 f"{w.b_error:.2g} N ({100 * w.relative_difference:+.3g} %, {w.excess:.3g} "
                 f"times the bars); {sum(not i.agree for i in v.items)} of {len(v.items)} "
                 f"quantities beyond the bars")
        if v.kind == DIFFER:
            return (f"verdict: {v.model_a} and {v.model_b} differ beyond their error bars: "
                    f"{where}")
        k = v.reason.find("no error estimate for")
        return (f"verdict: not decided, a model has no error bar: {where}; "
                f"{v.reason[k:]}, so part of the difference may be its own error")
    if v.statistics == UNDECIDED:
        tail = "the statistics decide nothing"
    elif v.statistics == AGREE:
        tail = "the statistics over revolutions agree within their confidence intervals"
    else:
        w = v.worst
        tail = (f"the statistics differ beyond their confidence intervals: {w.quantity}: "
                f"{w.a:.6g} N +- {w.a_error:.2g} N vs {w.b:.6g} N +- {w.b_error:.2g} N "
                f"({100 * w.relative_difference:+.3g} %)")
    return f"verdict: not comparable peak by peak ({v.reason}); {tail}"


def _bar(error: float) -> str:
    """An error bar in the table: two digits, "-" where there is none (one revolution's
    statistics)."""
    return f"{error:.2g}" if math.isfinite(error) else "-"


def format_verdict(v: Verdict) -> str:
    """Plain-text table of a `Verdict`: every decisive quantity with both models' values
    and bars, then the summary sentence."""
    rows = [("peak by peak" if v.kind != NOT_COMPARABLE else
             "peak by peak (for the record: not comparable)", v.items)]
    if v.kind == NOT_COMPARABLE:
        rows.append(("statistics over revolutions (+-: 95 % interval over the revolutions)",
                     v.statistics_items))
    lines = []
    for title, items in rows:
        if not items:
            continue
        width = max(len(i.quantity) for i in items)
        lines += [f"{title}:",
                  f"  {'quantity':<{width}}  {v.model_a + ' (N)':>14}  {'+-':>9}  "
                  f"{v.model_b + ' (N)':>14}  {'+-':>9}  {'b/a - 1':>10}  {'|d|/bars':>8}"]
        for i in items:
            rel = 100 * i.relative_difference
            rel = 0.0 if abs(rel) < 5e-4 else rel       # no signed zero ("-0.000 %")
            lines.append(f"  {i.quantity:<{width}}  {i.a:>14.6g}  {_bar(i.a_error):>9}  "
                         f"{i.b:>14.6g}  {_bar(i.b_error):>9}  "
                         f"{rel:>+8.3f} %  {i.excess:>8.3g}")
    lines.append(v.summary())
    return "\n".join(lines)
