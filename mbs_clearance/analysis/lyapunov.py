"""The largest Lyapunov exponent from the variational equations.

The DDM kernels of a generated model (linkage_ddm; core/sens_runtime.h in the compiled C
model) integrate the
state with sensitivities s' = (df/dy) s + (df/dp) D + (df/d deltadot_minus) sigma. With no
parameter (D = 0) and an initial sensitivity v0 (a direction in state space) the
sensitivity is the tangent vector v(t) = Phi(t) v0 of the flow, and each clearance joint's
impact-velocity memory sensitivity sigma_j carries the tangent of that hidden state, set at
each of its contact onsets with the event-time term (core/sens_runtime.h) exactly as for
parameters: the state's tangent does not jump at the switches (the contact force is zero on
both sides of delta = 0), the memory's does.

Benettin's method: the tangent is integrated over one window (a crank revolution), its
growth measured in the scaled norm |v / S| (S: clearance-sized positions and clearance x
speed rates, so that every component counts), then renormalised to 1. The exponent is the
mean log-growth over the windows after a transient: lambda = sum log(growth_k) / (windows
kept), per window, and / window time in 1/s.

The memory's tangent at a renormalisation (`memory`): "reset" (the default) sets it to 0,
"carry" divides it by the growth as v. The stored impact velocity is constant while a
contact lasts, so in a motion that stays in contact (the paper's design: five contact
switches in all, then permanent contact) a perturbation of it is never forgotten: nearby
runs settle on nearby periodic motions with different stored impact velocities (checked
against two runs of the plain model), and the full hybrid system's largest exponent is
exactly 0 there, whatever the motion's own stability. "reset" measures the separation of
the mechanical states for a given contact-law memory within each window (the memory's
tangent is still set at each onset from v, with the event-time term): negative on a stable
periodic motion, and the same as "carry" where contacts start again and again (chaos).

The contacts are the clearance joints and the corners of the translational clearance
joints alike: each corner is a contact with its own memory, its onsets set its memory's
tangent with the event-time term, and the state's tangent does not jump there either.

A free linkage (no drive) has no revolutions: its exponent is the finite-time one over
`duration` s from its `Initial` start, the tangent renormalised at the end of each window of
`window` s (default one window, the whole duration), in 1/s and per window.

The interface a flow offers (`TangentFlow`, `TextbookFlow`): `advance(t1)` integrates
state and tangent from its time to t1 and returns the window's peak; `renormalise()` scales
the tangent back to unit norm and returns the growth; `section()` the Poincare section
of the state. Any Linkage (and a SliderCrank, on the paper's generated model) has one.

`TextbookFlow` runs a reference system through the same integrator and the same
renormalisation code: a linear system x' = A x (the exponent is the largest real part of
A's eigenvalues) and the Lorenz system (sigma 10, rho 28, beta 8/3: 0.9056).

Uncertainty (`exponent_interval`): a finite mean of correlated log-growths. Its half-width
is the larger of (a) the 95 % batch-means interval from `BLOCKS` blocks of the averaged
windows (Student t with BLOCKS - 1 degrees of freedom) and (b) the spread of the running
estimate over the last half of the averaged windows. The verdict (`exponent_verdict`) is
"undecided" where the interval contains zero and does not lie within the zero band
(poincare.LYAPUNOV_ZERO); "positive", "negative" or "zero" otherwise.
"""

from __future__ import annotations

import functools
import math
import sys
from dataclasses import dataclass, field

import numpy as np

from .._checks import check_int, check_real, check_revolutions_memory
from ..core.integrate import no_events_source
from ..model.cases import as_linkage
from ..numerics.integrator import METHODS, make_settings
from ..solve.flows import Flow, TangentFlow, drive_of
from ..solve.settings import RunSettings
from .poincare import (  # noqa: F401 - the exponent statistics, public here too
    BLOCKS,
    DEFAULT_RTOL,
    MAX_PERIOD,
    RECURRENCE_TOL,
    T_QUANTILE,
    classify_run,
    exponent_estimate,
    exponent_interval,
    exponent_verdict,
    scale_samples,
    section_times,
)

__all__ = ["LyapunovResult", "TangentFlow", "TextbookFlow", "lyapunov_exponent",
           "textbook_exponent", "LORENZ", "exponent_of_flow", "exponent_interval",
           "exponent_verdict"]

_THIS = sys.modules[__name__]


@dataclass
class LyapunovResult:
    """The largest Lyapunov exponent: per_second (1/s) and per_revolution (per window),
    from the log-growths (windows,) of the tangent, the first `transient` not counted."""

    per_second: float
    per_revolution: float
    log_growth: np.ndarray
    transient: int
    window: float
    counters: dict = field(default_factory=dict)
    #: half-width of the exponent's interval per revolution (per window; `exponent_interval`;
    #: inf with fewer than BLOCKS averaged windows)
    uncertainty: float = math.inf
    #: "positive", "negative", "zero" or "undecided" (`exponent_verdict`)
    verdict: str = "undecided"
    #: the regime of the averaged windows by the regime map's rule (`poincare.classify_run`;
    #: "" where no section was taken)
    regime: str = ""
    #: the period in windows found by recurrence of the section (0: none)
    period: int = 0

    @property
    def interval(self) -> tuple[float, float]:
        """(low, high) of the exponent per revolution (per window)."""
        return (self.per_revolution - self.uncertainty, self.per_revolution + self.uncertainty)

    @property
    def interval_per_second(self) -> tuple[float, float]:
        """(low, high) of the exponent in 1/s."""
        return (self.interval[0] / self.window, self.interval[1] / self.window)


# ------------------------------------------------------------------ reference systems

#: the reference systems of `TextbookFlow`: kind code in p[0]
LINEAR, LORENZ = 0, 1


#: the reference systems in C, through the compiled core's seam (mbs_core.h): state (3)
#: and, for the full state, tangent (3) derivatives of the system p[0]: LINEAR (x' = A x, A
#: row-major in p[1:10]) or LORENZ (sigma, rho, beta in p[1:4]); no switching (the one
#: switching function stays negative); the monitored value is |x|
_TEXTBOOK_C = no_events_source("""
    int tangent = n >= 6;
    if (p[0] < 0.5) {
        for (int i = 0; i < 3; i++) {
            double a = 0.0, b = 0.0;
            for (int j = 0; j < 3; j++) {
                a += p[1 + 3 * i + j] * y[j];
                if (tangent)
                    b += p[1 + 3 * i + j] * y[3 + j];
            }
            dydt[i] = a;
            if (tangent)
                dydt[3 + i] = b;
        }
        return;
    }
    double s = p[1], r = p[2], b = p[3], x = y[0], yy = y[1], z = y[2];
    dydt[0] = s * (yy - x);
    dydt[1] = x * (r - z) - yy;
    dydt[2] = x * yy - b * z;
    if (tangent) {
        double u = y[3], v = y[4], w = y[5];
        dydt[3] = s * (v - u);
        dydt[4] = (r - z) * u - v - x * w;
        dydt[5] = yy * u + x * v - b * w;
    }""", "sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2])", 6, 3, 10)


@functools.lru_cache(maxsize=1)
def _textbook_record():
    from ..core import build
    from ..core.integrate import model_record

    return model_record(*build.load("textbook", [("textbook.c", _TEXTBOOK_C)]))


def integrate_textbook(y0, p, edges, settings, coefficients):
    """The compiled core's run of the reference systems (`_TEXTBOOK_C`, built once and
    cached), with the arguments and returns of a model's ``integrate_model``."""
    from ..core.integrate import integrate

    return integrate(_textbook_record(), y0, p, edges, settings, coefficients)


class TextbookFlow(Flow):
    """A reference system (3 states + 3 tangent components) on the compiled integrator,
    with the members of `TangentFlow`: `advance`, `renormalise`."""

    def __init__(self, kind: int, params, x0, v0, *, rtol: float = 1e-10,
                 method: str = "dop853"):
        # no mechanism: the Flow's integration members only
        self.mech = None
        self.rtol = check_real("rtol", rtol, 1e-14, 1e-4)
        self.p = np.zeros(10)
        self.p[0] = kind
        self.p[1:1 + len(params)] = params
        self.y = np.concatenate([np.asarray(x0, float), np.asarray(v0, float)])
        self.y[3:] /= np.linalg.norm(self.y[3:])
        atol = np.full(6, rtol)
        self.settings = make_settings(rtol, atol, 6, h_max=np.inf, max_steps=10**7,
                                      record=True, refine_iters=0, n_out=0, n_dense=3,
                                      n_events=1, mem_start=10, n_mem=0)
        self.kernel = integrate_textbook
        self.coefficients = METHODS[method].arrays()
        self.t = 0.0
        self.counters = np.zeros(5, dtype=np.int64)
        self.max_recorded = 0
        self.joints = ()

    def renormalise(self) -> float:
        n = float(np.linalg.norm(self.y[3:]))
        self.y[3:] /= n
        return n


# ------------------------------------------------------------------------------ exponent

def exponent_of_flow(flow, times, transient: int, window: float,
                     sections: bool = False) -> LyapunovResult:
    """Benettin's estimate on a flow with the `TangentFlow` members: advance to each of
    `times`, renormalise, average the log-growths after the first `transient` windows of
    duration `window` (s); with its interval (`exponent_interval`) and verdict. With
    `sections`, the flow's Poincare section after each averaged window is classified by the
    regime map's rule (`poincare.classify_run`): a period found by recurrence is reported,
    and the exponent is then averaged over whole periods."""
    logs = np.empty(len(times))
    samples = []
    for k, t1 in enumerate(times):
        flow.advance(t1)
        logs[k] = math.log(flow.renormalise())
        if sections and k >= transient:
            samples.append(flow.section())
    kept = logs[transient:]
    regime, period = "", 0
    if sections and len(kept) >= 3:
        scaled = scale_samples(np.array(samples), flow.clearance, flow.omega)
        regime, period, _, per_window, half = classify_run(
            scaled, kept, tol=RECURRENCE_TOL, max_period=min(MAX_PERIOD, (len(kept) - 1) // 2))
    else:
        per_window, half = exponent_estimate(kept)
    from ..solve.reduced import counters_dict

    return LyapunovResult(per_second=per_window / window, per_revolution=per_window,
                          log_growth=logs, transient=transient, window=window,
                          counters=counters_dict(flow.counters), uncertainty=half,
                          verdict=exponent_verdict(per_window - half, per_window + half),
                          regime=regime, period=period)


def lyapunov_exponent(mech, revolutions: int | None = None, transient: int | None = None, *,
                      duration: float | None = None, window: float | None = None,
                      rtol: float | None = None, method: str = "dop853",
                      direction=None, memory: str = "reset") -> LyapunovResult:
    """The largest Lyapunov exponent of `mech`'s motion (any Linkage; the paper's
    SliderCrank as its case), in 1/s (`per_second`) and per drive revolution.

    The state and one tangent vector (initial `direction`: 2 N_Q scaled components of the
    generated model's coordinates and their rates, for the paper's case theta3, x4 and
    their rates; default all equal) are integrated over `revolutions` crank
    revolutions (default 100), the tangent renormalised at the end of each; the
    log-growths of the last revolutions - `transient` are averaged (default None: the first
    half, revolutions // 2, so 50 of the default 100; any `revolutions` works with it).
    rtol (default 1e-7) applies to the state and the unit tangent alike. The result carries
    the exponent's `uncertainty` (half-width per revolution, `exponent_interval`) and its
    `verdict` ("positive", "negative", "zero" or "undecided" where the interval contains
    zero), and the `regime` and `period` of the averaged revolutions by the regime map's
    rule (`poincare.classify_run`: a period found by recurrence of the section decides, the
    exponent is then averaged over whole periods). `memory`: the impact-velocity memory's
    tangent at each renormalisation, "reset" or "carry" (module docstring). The contacts
    are the clearance joints and the corners of the translational clearance joints alike.

    A free linkage (drive None) has no revolutions: give `duration` (s) and optionally
    `window` (s; default the whole duration, a whole number of windows in `duration`). The
    result is the finite-time exponent from the linkage's `Initial` start: the tangent is
    renormalised at the end of each window, `per_second` the mean log-growth of the windows
    after the first `transient` (default 0) per second, `per_revolution` per window (and
    `window` its length); no Poincare section is taken (`regime` ""), and with fewer than
    `BLOCKS` averaged windows the `uncertainty` is inf and the verdict "undecided".
    """
    linkage = as_linkage(mech)
    if linkage.drive is None:
        return _free_exponent(linkage, revolutions, transient, duration, window, rtol, method,
                              direction, memory)
    if duration is not None or window is not None:
        raise ValueError(f"linkage {linkage.name!r} is driven: its exponent is averaged over "
                         "revolutions= (windows of one drive revolution); duration= and "
                         "window= are for a free linkage (drive=None)")
    revolutions = check_int("revolutions", 100 if revolutions is None else revolutions, 2)
    if transient is None:
        transient = revolutions // 2
    transient = check_int("transient (revolutions not averaged)", transient, 0,
                          revolutions - 1)
    check_revolutions_memory(revolutions, per_revolution=8)
    flow = TangentFlow(mech, RunSettings(rtol=DEFAULT_RTOL if rtol is None else rtol,
                                         method=method), direction=direction, memory=memory)
    omega, _ = drive_of(mech)
    return exponent_of_flow(flow, section_times(mech, revolutions), transient,
                            2.0 * math.pi / omega, sections=True)


def _free_exponent(linkage, revolutions, transient, duration, window, rtol, method,
                   direction, memory) -> LyapunovResult:
    """`lyapunov_exponent` of a free linkage: the finite-time exponent over `duration` s in
    windows of `window` s."""
    if revolutions is not None:
        raise ValueError(f"linkage {linkage.name!r} is free (drive=None): it has no drive "
                         f"revolutions; give duration= (s) and optionally window= (s) "
                         f"instead of revolutions={revolutions!r}")
    if duration is None:
        raise ValueError(f"linkage {linkage.name!r} is free (drive=None): give the "
                         "exponent's duration= (s) and optionally window= (s, the "
                         "renormalisation interval; default the whole duration)")
    duration = check_real("duration", duration, 0.0, None, low_open=True, unit="s")
    window = duration if window is None else check_real("window", window, 0.0, duration,
                                                        low_open=True, unit="s")
    n = int(round(duration / window))
    if abs(n * window - duration) > 1e-9 * duration:
        raise ValueError(f"duration ({duration!r} s) must be a whole number of windows "
                         f"(window {window!r} s)")
    if n > MAX_FREE_WINDOWS:
        raise ValueError(f"window must be at least duration / {MAX_FREE_WINDOWS} = "
                         f"{duration / MAX_FREE_WINDOWS:.3g} s; got {window!r}")
    transient = check_int("transient (windows not averaged)", 0 if transient is None
                          else transient, 0, n - 1)
    flow = TangentFlow(linkage, RunSettings(rtol=DEFAULT_RTOL if rtol is None else rtol,
                                            method=method), direction=direction,
                       memory=memory, free=True)
    return exponent_of_flow(flow, window * np.arange(1, n + 1), transient, window)


#: the most renormalisation windows of a free linkage's exponent
MAX_FREE_WINDOWS = 100_000


#: Lorenz's parameters and a point near its attractor
LORENZ_PARAMS = (10.0, 28.0, 8.0 / 3.0)


def textbook_exponent(kind: str, time: float, *, window: float = 1.0, transient: float = 0.0,
                      matrix=None, x0=(1.0, 1.0, 20.0), v0=(1.0, 0.0, 0.0),
                      rtol: float = 1e-10) -> LyapunovResult:
    """The largest exponent of a reference system by `exponent_of_flow` (the same code as
    the mechanism's): kind "lorenz" (sigma 10, rho 28, beta 8/3) or "linear" (x' = A x,
    `matrix` 3 x 3), over `time` units in windows of `window`, the first `transient`
    units not averaged."""
    if kind not in ("lorenz", "linear"):
        raise ValueError(f"kind must be 'lorenz' or 'linear'; got {kind!r}")
    window = check_real("window", window, 0.0, low_open=True)
    n = int(round(check_real("time", time, window) / window))
    skip = int(round(check_real("transient", transient, 0.0, time - window) / window))
    if kind == "linear":
        A = np.asarray(matrix, dtype=float)
        if A.shape != (3, 3) or not np.all(np.isfinite(A)):
            raise ValueError("matrix must be 3 x 3 finite numbers for kind='linear'")
        flow = TextbookFlow(LINEAR, A.ravel(), x0, v0, rtol=rtol)
    else:
        flow = TextbookFlow(LORENZ, LORENZ_PARAMS, x0, v0, rtol=rtol)
    return exponent_of_flow(flow, window * np.arange(1, n + 1), skip, window)
