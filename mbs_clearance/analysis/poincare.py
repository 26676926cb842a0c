"""Poincare sections of a run and the classification of its motion.

A run is integrated one section interval at a time on the compiled event-exact integrator
(`Flow`): the integrator lands exactly on each window's end, and for a constant-speed drive
the crank angle `angle` is reached at t_k = (2 pi (k - 1) + ((angle - theta0) mod 2 pi)) /
omega (with 2 pi in place of 0: sample k lies in revolution k, at its end when angle =
theta0). Only one window's steps are held at a time; what a run keeps is the section
samples and one peak per window, so its memory is O(samples), independent of its length.

The section of each clearance joint is its eccentricity (journal centre minus bearing
centre, x and y, m) and the eccentricity's rate (m/s): `SECTION_COMPONENTS`.

Classification (`classify`), on the kept samples X_1..X_N made dimensionless (positions
divided by the joint's clearance c, rates by c omega):

- period-k: the smallest k <= max_period with max_i |X_{i+k} - X_i|_inf <= tol over all the
  kept samples (the recurrence holds N - k times; N >= 2 max_period + 1 is required);
- otherwise, by the largest Lyapunov exponent lambda per revolution (`lyapunov.py`), if it
  was computed, through its interval [lambda - u, lambda + u] and the verdict of
  `exponent_verdict` (the rule `lyapunov_exponent` prints, so a map's point and the
  exponent of the same run agree): chaotic if "positive", quasi-periodic if "zero" (the
  interval within |lambda| <= LYAPUNOV_ZERO), unsettled if "negative" (contracting, but not
  yet on its periodic orbit after the transient: run longer), undecided if the interval
  contains zero and reaches out of the band (run longer to decide);
- aperiodic when no exponent was computed.

The section samples carry the integration's error, of the order of rtol times the
mechanism's size (about 2.5 nm at rtol 1e-7 in the paper's slider-crank, measured), which at
micrometre clearances is the tolerance itself (1e-3 c = 1 nm at c = 1 um). A classification
decided by a distance within a factor RESOLVE_BAND of the tolerance (no period found but
some d_k <= RESOLVE_BAND tol, or a period k > 1 with d_k > tol / RESOLVE_BAND) is therefore
re-checked: the run is repeated at rtol / RESOLVE_FACTOR and classified again, and that run's
samples are kept (`PoincareSection.rtol`, `rechecked`).

Early stop (`early_stop=True`, plain runs only). A run whose section repeats with some
lag k <= EARLY_STOP_MAX_LAG to tol / RESOLVE_BAND at two consecutive revolutions, with at
least EARLY_STOP_MIN_LEFT revolutions left, is checked by
one Newton step on the k-revolution map from its state (`periodic.newton_check`, at
rtol / RESOLVE_FACTOR): where the step lands on a stable orbit near the state, the motion
contracts onto it, and the run stops. Its remaining revolutions repeat its last k
section samples and peaks: the run's own recurrence, which the integration's error at the
run's rtol sets, not the orbit's (the two differ by that error, up to a few 1e-3 of the
clearance at rtol 1e-7). A check that fails (unstable, too far, no convergence, or an orbit
repeating after fewer revolutions than the lag: the run's own section does not repeat to
tol / RESOLVE_BAND at its period) lets the run go on and is tried again later, at most
EARLY_STOP_ATTEMPTS times.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._checks import check_int, check_real, check_revolutions_memory
from ..solve.flows import Flow, TangentFlow, _check_mech, clearances_of, drive_of, joints_of  # noqa: F401
from ..solve.linkage_model import DEFAULT_RTOL as LM_DEFAULT_RTOL
from ..solve.settings import RunSettings

__all__ = ["SECTION_COMPONENTS", "REGIMES", "Flow", "PoincareSection", "poincare_section",
           "classify", "classify_run", "exponent_interval", "exponent_verdict",
           "exponent_estimate", "section_times", "RECURRENCE_TOL", "MAX_PERIOD", "LYAPUNOV_ZERO"]

#: the section's components per clearance joint
SECTION_COMPONENTS = ("x", "y", "xdot", "ydot")

#: regime codes (the dataset's `regime` variable; CF flag_values / flag_meanings)
REGIMES = {0: "not_computed", 1: "failed", 2: "period_1", 3: "period_k",
           4: "quasi_periodic", 5: "chaotic", 6: "aperiodic", 7: "unsettled", 8: "undecided"}

#: the exponent's verdict (`exponent_verdict`) -> the regime of a motion with no
#: period found
VERDICT_REGIMES = {"positive": "chaotic", "zero": "quasi_periodic", "negative": "unsettled",
                   "undecided": "undecided"}
REGIME_CODES = {v: k for k, v in REGIMES.items()}

#: default recurrence tolerance of the dimensionless section samples (fraction of the
#: clearance for positions, of clearance x crank speed for rates)
RECURRENCE_TOL = 1e-3

#: default largest period looked for
MAX_PERIOD = 8

#: |largest Lyapunov exponent| per revolution below which the motion counts as neither
#: contracting nor chaotic: separations change less than e-fold in 50 revolutions
LYAPUNOV_ZERO = 0.02

#: default relative tolerance of section runs (as the plain runs)
DEFAULT_RTOL = LM_DEFAULT_RTOL

#: a classification decided within this factor of the recurrence tolerance is re-checked
RESOLVE_BAND = 10.0

#: ... at the run's rtol divided by this factor (not below MIN_RTOL)
RESOLVE_FACTOR = 100.0
MIN_RTOL = 1e-12

#: Newton checks of an early stop per run (each costs a few revolutions' work)
EARLY_STOP_ATTEMPTS = 2
#: revolutions before another check after one failed (times the checks so far)
EARLY_STOP_BACKOFF = 10
#: the longest lag checked: a check's plain run costs its lag in revolutions at a
#: tighter rtol, and period-k motions are few in a map
EARLY_STOP_MAX_LAG = 2
#: a check only where at least this many revolutions are left to save
EARLY_STOP_MIN_LEFT = 10


def section_times(mech, samples, angle: float | None = None, first: int = 1) -> np.ndarray:
    """Times of section samples first..first+samples-1 at crank angle `angle` (rad; None:
    the initial crank angle, i.e. the ends of the revolutions): sample k in revolution k."""
    omega, theta0 = drive_of(mech)
    rel = 2.0 * math.pi if angle is None else (angle - theta0) % (2.0 * math.pi)
    if rel <= 1e-12:
        rel = 2.0 * math.pi
    k = np.arange(first, first + samples)
    return (2.0 * math.pi * (k - 1) + rel) / omega


# --------------------------------------------------------------------------------- flows

# ------------------------------------------------------------------------------ sections

@dataclass
class PoincareSection:
    """Section samples of a run and its classification.

    samples (N, J, 4): eccentricity x, y (m) and rates (m/s) of each joint at the kept
    section times `t` (N,); peaks (revolutions,): the monitored force's maximum (N) over
    each section interval (the crank revolutions when the section angle is the initial
    crank angle); regime / period: `classify`'s result; lyapunov: the exponent per
    revolution when computed (else NaN), lyapunov_uncertainty its half-width
    (`exponent_interval`); distance: the recurrence distances d_k
    (k = 1..max_period)."""

    t: np.ndarray
    samples: np.ndarray
    peaks: np.ndarray
    joints: tuple[str, ...]
    clearance: np.ndarray
    omega: float
    regime: str
    period: int
    distance: np.ndarray
    lyapunov: float = math.nan
    lyapunov_uncertainty: float = math.nan
    counters: dict = field(default_factory=dict)
    #: relative tolerance of the run that gave the samples
    rtol: float = DEFAULT_RTOL
    #: True when the classification was re-checked at a tighter rtol (module docstring)
    rechecked: bool = False
    #: revolutions run before an early stop (0: all of them; the module docstring)
    stopped: int = 0
    #: the confirmed orbit's multipliers at an early stop (else empty)
    multipliers: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=complex))

    def scaled(self) -> np.ndarray:
        """The samples made dimensionless (positions / c, rates / (c omega))."""
        return scale_samples(self.samples, self.clearance, self.omega)


def scale_samples(samples, clearance, omega) -> np.ndarray:
    """Section samples (N, J, 4) divided by (c, c, c omega, c omega) per joint."""
    c = np.asarray(clearance, dtype=float)[None, :, None]
    unit = np.array([1.0, 1.0, omega, omega])[None, None, :]
    return np.asarray(samples) / (c * unit)


def recurrence_distances(scaled: np.ndarray, max_period: int) -> np.ndarray:
    """d_k = max_i |X_{i+k} - X_i|_inf over the samples (N, ...), k = 1..max_period."""
    n = scaled.shape[0]
    flat = scaled.reshape(n, -1)
    return np.array([np.max(np.abs(flat[k:] - flat[:-k])) if n > k else np.inf
                     for k in range(1, max_period + 1)])


#: blocks of the batch-means interval of the exponent (`exponent_interval`)
BLOCKS = 4

#: two-sided 95 % quantile of Student's t with BLOCKS - 1 = 3 degrees of freedom
T_QUANTILE = 3.182


def exponent_interval(kept: np.ndarray) -> float:
    """Half-width of the interval of the mean of the averaged log-growths `kept` (per
    window): the larger of the 95 % batch-means half-width (`BLOCKS` consecutive blocks of
    equal length, the first windows left over dropped; t quantile `T_QUANTILE`) and the
    spread (max - min) of the running mean over the last half of the windows. inf with
    fewer than BLOCKS windows. The running mean's spread catches a slow trend or a
    periodic pattern of the growths that blocks of the wrong length would miss or average
    out; the batch means, the scatter of a chaotic motion's growths."""
    kept = np.asarray(kept, dtype=float)
    n = len(kept)
    if n < BLOCKS:
        return math.inf
    size = n // BLOCKS
    means = kept[n - BLOCKS * size:].reshape(BLOCKS, size).mean(axis=1)
    batch = T_QUANTILE * float(np.std(means, ddof=1)) / math.sqrt(BLOCKS)
    running = np.cumsum(kept) / np.arange(1, n + 1)
    tail = running[n // 2:]
    return max(batch, float(tail.max() - tail.min()))


def exponent_verdict(low: float, high: float) -> str:
    """The sign of an exponent known to lie in [low, high] (per revolution): "zero" if the
    interval lies within the band |lambda| <= LYAPUNOV_ZERO, "positive" if it lies
    above 0, "negative" if below, "undecided" if it contains 0 and reaches out of the band
    (run longer, or with a longer transient, to decide)."""
    if not (math.isfinite(low) and math.isfinite(high)):
        return "undecided"
    if -LYAPUNOV_ZERO <= low and high <= LYAPUNOV_ZERO:
        return "zero"
    if low > 0.0:
        return "positive"
    if high < 0.0:
        return "negative"
    return "undecided"


def exponent_estimate(kept: np.ndarray, period: int = 1) -> tuple[float, float]:
    """(mean, half-width) per window of the log-growths `kept`, over whole periods of a
    motion of `period` windows (the first windows left over dropped): on a period-k orbit
    the growths repeat every k windows, and blocks or a running mean that cut across the
    pattern would read its swing as uncertainty."""
    kept = np.asarray(kept, dtype=float)
    period = max(int(period), 1)
    whole = (len(kept) // period) * period
    if whole == 0:
        return (float(np.mean(kept)) if len(kept) else math.nan), math.inf
    per = kept[len(kept) - whole:].reshape(-1, period).mean(axis=1)
    return float(np.mean(per)), exponent_interval(per)


def classify(scaled: np.ndarray, *, tol: float = RECURRENCE_TOL, max_period: int = MAX_PERIOD,
             lyapunov: float | None = None,
             uncertainty: float = 0.0) -> tuple[str, int, np.ndarray]:
    """(regime, period, distances) of dimensionless section samples (N, ...) by the
    criterion of the module docstring; `lyapunov` is the exponent per revolution (None or
    NaN: not computed), `uncertainty` its half-width (0: the point value decides)."""

    tol = check_real("tol (recurrence tolerance)", tol, 0.0, low_open=True)
    max_period = check_int("max_period", max_period, 1)
    if scaled.shape[0] < 2 * max_period + 1:
        raise ValueError(f"keep must be >= 2 max_period + 1 = {2 * max_period + 1} samples "
                         f"to detect periods up to {max_period}; got {scaled.shape[0]}")
    d = recurrence_distances(scaled, max_period)
    for k in range(1, max_period + 1):
        if d[k - 1] <= tol:
            return ("period_1" if k == 1 else "period_k"), k, d
    if lyapunov is None or not math.isfinite(lyapunov):
        return "aperiodic", 0, d
    verdict = exponent_verdict(lyapunov - uncertainty, lyapunov + uncertainty)
    return VERDICT_REGIMES[verdict], 0, d


def classify_run(scaled: np.ndarray, logs: np.ndarray | None, *, tol: float = RECURRENCE_TOL,
                 max_period: int = MAX_PERIOD) -> tuple[str, int, np.ndarray, float, float]:
    """(regime, period, distances, exponent, half-width) of one run: its dimensionless
    section samples (N, ...) and the log-growths of its tangent over the same N windows
    (None: no exponent). The one rule of the regime map and of `lyapunov_exponent`: a
    period found by recurrence decides; the exponent is averaged over whole periods
    (`exponent_estimate`) and, without a period, its verdict decides (`classify`)."""
    regime, period, d = classify(scaled, tol=tol, max_period=max_period)
    if logs is None:
        return regime, period, d, math.nan, math.nan
    lam, half = exponent_estimate(logs, period or 1)
    if not period:
        regime = VERDICT_REGIMES[exponent_verdict(lam - half, lam + half)]
    return regime, period, d, lam, half


def near_tolerance(regime: str, period: int, distances: np.ndarray, tol: float) -> bool:
    """True when `classify`'s verdict was decided by a recurrence distance within a factor
    RESOLVE_BAND of `tol`: no period found but some d_k <= RESOLVE_BAND tol, or a period
    k > 1 accepted with d_k > tol / RESOLVE_BAND (the integration's error may have decided
    it; the module docstring)."""
    d = np.asarray(distances, dtype=float)
    if regime == "period_1":
        return False
    if regime == "period_k":
        return bool(d[period - 1] > tol / RESOLVE_BAND)
    finite = d[np.isfinite(d)]
    return bool(finite.size and finite.min() <= RESOLVE_BAND * tol)


def _check_run(mech, revolutions, keep, angle):
    _check_mech(mech)
    revolutions = check_int("revolutions", revolutions, 1)
    keep = check_int("keep (revolutions kept after the transient)", keep, 1, revolutions)
    check_revolutions_memory(revolutions, per_revolution=8 * 4 * len(joints_of(mech)))
    if angle is not None:
        angle = check_real("angle (section crank angle)", angle, unit="rad")
    return revolutions, keep, angle


def poincare_section(mech, revolutions: int = 100, keep: int = 50, *,
                     angle: float | None = None, tol: float = RECURRENCE_TOL,
                     max_period: int = MAX_PERIOD, lyapunov: bool = False,
                     rtol: float | None = None, method: str | None = None,
                     recheck: bool = True, early_stop: bool = False) -> PoincareSection:
    """The Poincare section of a run of `mech` (a SliderCrank or a Linkage).

    Parameters
    ----------
    revolutions : int
        Crank revolutions run; the last `keep` give one section sample each (the first
        revolutions - keep are the transient).
    angle : float, optional
        Crank angle of the section (rad); default the initial crank angle (revolution ends).
    tol : float, default 1e-3
        Relative tolerance of the recurrence criterion (`classify`).
    max_period : int, default 8
        Longest period in crank revolutions that the recurrence criterion looks for.
    lyapunov : bool
        Also integrate one tangent vector (`lyapunov.lyapunov_exponent`'s flow) and
        classify non-periodic motion by the exponent's sign; the state is then
        integrated with the tangent under error control too.
    rtol, method :
        Integrator settings (defaults: 1e-7; dopri5, or dop853 with the tangent).
    recheck : bool
        Repeat the run at rtol / RESOLVE_FACTOR when the classification was decided within
        a factor RESOLVE_BAND of `tol` (the module docstring); False: one run only.
    early_stop : bool
        Stop a run whose section repeats, once one Newton step confirms a stable periodic
        orbit there (the module docstring); not with `lyapunov`.
    """
    revolutions, keep, angle = _check_run(mech, revolutions, keep, angle)
    if rtol is not None:
        rtol = check_real("rtol", rtol, 1e-14, 1e-4)
    tol = check_real("tol (recurrence tolerance)", tol, 0.0, low_open=True)
    max_period = check_int("max_period", max_period, 1)
    if not isinstance(early_stop, bool):
        raise ValueError(f"early_stop must be True or False; got {early_stop!r}")
    if early_stop and lyapunov:
        raise ValueError("early_stop needs lyapunov=False (the exponent averages the kept "
                         "revolutions' growths: they must be run)")
    times = section_times(mech, revolutions, angle)
    sec = _section_run(mech, times, keep, tol, max_period, lyapunov, rtol, method, early_stop)
    tighter = max(sec.rtol / RESOLVE_FACTOR, MIN_RTOL)
    if recheck and tighter < sec.rtol and near_tolerance(sec.regime, sec.period, sec.distance, tol):
        first = sec.counters
        sec = _section_run(mech, times, keep, tol, max_period, lyapunov, tighter, method,
                           early_stop)
        sec.counters = {k: first.get(k, 0) + v for k, v in sec.counters.items()}
        sec.rechecked = True
    return sec


def _section_run(mech, times, keep, tol, max_period, lyapunov, rtol, method,
                 early_stop=False):
    """One run of `poincare_section` at `rtol`, classified."""
    revolutions = len(times)
    kind = TangentFlow if lyapunov else Flow
    flow = kind(mech, RunSettings(rtol=rtol, method=method or kind.METHOD))
    samples = np.empty((keep, len(flow.joints), 4))
    peaks = np.empty(revolutions)
    logs = np.empty(keep)
    first = revolutions - keep
    stop = _EarlyStop(flow, tol, max_period, revolutions) if early_stop else None
    stopped, extra = 0, 0
    for k, t1 in enumerate(times):
        peaks[k] = flow.advance(t1)
        if lyapunov:
            growth = flow.renormalise()
            if k >= first:
                logs[k - first] = math.log(growth)
        sample = flow.section()
        if k >= first:
            samples[k - first] = sample
        if stop is not None and k + 1 < revolutions and stop.confirmed(k, t1, sample,
                                                                         peaks[k]):
            # the rest repeats the run's last `period` revolutions
            for m in range(k + 1, revolutions):
                sample, peaks[m] = stop.recent[len(stop.recent) - stop.period
                                               + (m - k - 1) % stop.period][1:]
                if m >= first:
                    samples[m - first] = sample
            stopped = k + 1
            break
    if stop is not None:
        extra = stop.nfev
    scaled = scale_samples(samples, flow.clearance, flow.omega)
    regime, period, d, lam, half = classify_run(scaled, logs if lyapunov else None, tol=tol,
                                                max_period=max_period)
    from ..solve.reduced import counters_dict

    counters = counters_dict(flow.counters)
    counters["nfev"] += extra
    return PoincareSection(t=times[first:], samples=samples, peaks=peaks, joints=flow.joints,
                           clearance=flow.clearance, omega=flow.omega, regime=regime,
                           period=period, distance=d, lyapunov=lam,
                           lyapunov_uncertainty=half, counters=counters,
                           rtol=float(flow.rtol), stopped=stopped,
                           multipliers=stop.multipliers if stopped else
                           np.zeros(0, dtype=complex))


class _EarlyStop:
    """The early stop of a plain run (module docstring): the recent section samples and
    peaks, and the Newton checks."""

    def __init__(self, flow, tol, max_period, revolutions):
        self.flow, self.tol, self.max_period = flow, tol, max_period
        self.revolutions = revolutions
        self.unit = (flow.clearance[:, None]
                     * np.array([1.0, 1.0, flow.omega, flow.omega])[None, :])
        self.recent = []        # (scaled sample, sample, peak), the last max_period + 2
        self.attempts, self.next, self.nfev, self.period = 0, 0, 0, 0
        self.multipliers = np.zeros(0, dtype=complex)

    def _lag(self) -> int:
        """The smallest lag with the section repeating to tol / RESOLVE_BAND at the last
        two revolutions (one alone can be a chance near-return), else 0."""
        r = self.recent
        for lag in range(1, min(self.max_period, EARLY_STOP_MAX_LAG, len(r) - 2) + 1):
            if all(np.max(np.abs(r[-1 - i][0] - r[-1 - i - lag][0]))
                   <= self.tol / RESOLVE_BAND for i in (0, 1)):
                return lag
        return 0

    def confirmed(self, k, t, sample, peak) -> bool:
        from .periodic import newton_check

        self.recent.append((sample / self.unit, sample, peak))
        if len(self.recent) > self.max_period + 2:
            self.recent.pop(0)
        if k < self.next or self.attempts >= EARLY_STOP_ATTEMPTS or \
                k + EARLY_STOP_MIN_LEFT >= self.revolutions:
            return False
        lag = self._lag()
        if not lag:
            return False
        self.attempts += 1
        flow = self.flow
        model = flow.model
        n2, mem, J = 2 * model.N_Q, model.MEM_START, model.N_EVENTS
        try:
            check = newton_check(flow.mech, t, flow.y[:n2], flow.p[mem:mem + 2 * J:2],
                                 flow.p[mem + 1:mem + 2 * J:2], lag,
                                 rtol=max(flow.rtol / RESOLVE_FACTOR, MIN_RTOL),
                                 tol=self.tol / RESOLVE_BAND)
        except ValueError:      # a state the shooting does not take: run on
            self.next = k + EARLY_STOP_BACKOFF * self.attempts
            return False
        self.nfev += check.nfev
        # an orbit of fewer revolutions than the lag: the run's own section does not repeat
        # to tol / RESOLVE_BAND at the orbit's period (its integration error), so its
        # remaining revolutions must be run, as without early stop
        if not check.confirmed or check.least_period != lag:
            self.next = k + EARLY_STOP_BACKOFF * self.attempts
            return False
        self.period, self.multipliers = lag, check.multipliers
        return True
