"""The gradient of the design objective: the peak of an output over one drive revolution.

`peak_gradient(linkage, parameters)` returns d(peak)/db for named design values of any
linkage (`design`; the paper's SliderCrank is its case, its fields the names). The peak is
max_t F(t, b) of the output F (by default the linkage's monitored output,
`Linkage.default_output`: the paper's |F12|, the four-bar's shaking force)
over the revolution's window; where its maximum is an interior, isolated local maximum,
dF/dt = 0 there and the envelope theorem gives

    d(peak)/db = (partial dF/db)(t*, b),

the DDM sensitivity of F at the refined peak time t*. One DDM run gives both: its
integrator refines the window's maximum of the monitored force by golden section on
re-taken steps (the step map; another output is refined on the same step maps
afterwards), and the state and its sensitivities at t* are that step map's value at t*,
taken again from the recorded step that contains it (the model's `step_sens`). Reading the
sensitivities at the largest *recorded* sample instead is wrong by tens of percent: they
oscillate with the contact vibration (~13 kHz) between samples.

Where a second local maximum of the window comes within the integration accuracy of the
peak, the objective is the maximum of two smooth branches and has a kink: the result says so
(`kink`), with the rival's time, value and gradient (the two one-sided values). A peak at the
window's edge is flagged too. See docs/sensitivity.md, "Gradient of the design objective".
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._checks import check_choice, check_int, check_real, check_revolutions_memory
from ..model.linkage import Linkage
from ..model.mechanism import SliderCrank
from ..numerics.integrator import METHODS
from .sensitivity import DDM_INTEGRATOR, DEFAULT_PARAMETERS, FD_RELATIVE_STEP

__all__ = ["PeakGradient", "peak_gradient", "objective_window", "KINK_RTOL",
           "PEAK_GRADIENT_RTOL", "RIVAL_CANDIDATES",
           "OUTPUT_KINDS", "Output", "parse_output", "ground_joints", "peak_output"]

_THIS = sys.modules[__name__]

#: relative gap (peak - rival) / peak below which two local maxima of the window count as
#: tied within the integration accuracy (the kink tolerance is max(KINK_RTOL, KINK_PER_RTOL
#: rtol)): the accuracy target of the default settings on every per-revolution peak
KINK_RTOL = 1e-5

#: the DDM run's rtol when none is given. Its peak and gradient do not need the plain run's
#: 1e-7: against central differences at rtol 1e-12 the gradient is as accurate at 1e-6 as at
#: 1e-7 (its error is set by the peak time's location, not by the tolerance) and the peak is
#: within 1.5e-8, at about three quarters of the cost (`python -m
#: validation.peak_gradient_accuracy`, docs/sensitivity.md)
PEAK_GRADIENT_RTOL = 1e-6

#: the kink tolerance's floor per unit of the DDM run's rtol: the run's peak error measured
#: below rtol / 3 from rtol 1e-3 to 1e-7 (validation.peak_gradient_accuracy), and a gap is the
#: difference of two peaks
KINK_PER_RTOL = 10.0

#: local maxima of the recorded samples (largest first) refined as rivals of the peak
RIVAL_CANDIDATES = 8

#: golden-section iterations per rival's step: the bracket shrinks to 0.618^18 = 1.7e-4 of a
#: step, where the value's error is below 1e-7 of the peak even at the contact vibration's
#: ~2 rad per step (the kink tolerance is 1e-5)
_REFINE_ITERS = 18


@dataclass(frozen=True)
class PeakGradient:
    """The peak of an output (``stats["output"]``; by default the linkage's
    `default_output`, the paper's |F12|) over a crank revolution and its gradient.

    Attributes
    ----------
    peak : float
        Its maximum over the revolution, N (N m for the drive moment).
    time : float
        Where it is, s (NaN for backends that do not report it).
    parameters : tuple of str
        The SliderCrank fields b.
    reference : (p,) their values b0 (derived values where the field is None).
    gradient : (p,) d(peak)/db, N per SI unit of each parameter.
    kink : bool
        The objective is not differentiable here: a second local maximum (the rival) comes
        within `kink_tol` of the peak, or the peak sits at the window's edge. `gradient`
        and `rival_gradient` are then the two one-sided values (the objective is the
        maximum of the two smooth branches).
    rival_time, rival_peak : float
        The largest other local maximum of the output in the window (s, N); NaN if none.
    rival_gradient : (p,) its gradient (N per unit), NaN if none.
    at_edge : bool
        The peak sits at the window's edge.
    message : str
        What the flags mean for this result ("" when differentiable).
    method, backend : how it was computed.
    revolution : the crank revolution (1-based); a free linkage's: the time window.
    window : a free linkage's window width in s (None for a driven one).
    stats : solver counters (nfev, naccept, ...) and settings.
    """

    peak: float
    time: float
    parameters: tuple[str, ...]
    reference: np.ndarray
    gradient: np.ndarray
    kink: bool = False
    rival_time: float = math.nan
    rival_peak: float = math.nan
    rival_gradient: np.ndarray | None = None
    at_edge: bool = False
    message: str = ""
    method: str = "ddm"
    backend: str = "reduced"
    revolution: int = 4
    kink_tol: float = KINK_RTOL
    stats: dict[str, Any] = field(default_factory=dict)
    window: float | None = None

    @property
    def normalized(self) -> np.ndarray:
        """Eq. 15 at the peak: gradient * b0 / peak, shape (p,) (0 where b0 = 0)."""
        return self.gradient * self.reference / self.peak

    @property
    def rival_normalized(self) -> np.ndarray:
        """Eq. 15 of the rival's branch: rival_gradient * b0 / peak."""
        if self.rival_gradient is None:
            return np.full(len(self.parameters), np.nan)
        return self.rival_gradient * self.reference / self.peak

    @property
    def gap(self) -> float:
        """(peak - rival_peak) / peak: how far the rival is below the peak (NaN if none)."""
        return (self.peak - self.rival_peak) / self.peak

    def as_dict(self) -> dict[str, float]:
        """The gradient as {parameter: d(peak)/db}."""
        return {n: float(g) for n, g in zip(self.parameters, self.gradient)}


# ------------------------------------------------------------------ outputs of a linkage

#: the outputs whose peak a study of a `Linkage` takes (`parse_output`): kind -> (argument,
#: unit, what); a force's peak is that of its magnitude, the drive moment's that of |M|
OUTPUT_KINDS = {
    "pivot_force": ("ground joint", "N", "|reaction| of a joint to the ground (the paper's "
                    "base force F12 is the crank pivot's)"),
    "shaking_force": (None, "N", "|sum of the ground joints' reactions|"),
    "drive_moment": (None, "N m", "|drive moment|"),
    "contact_force": ("clearance joint", "N", "normal contact force of a clearance joint"),
}


def ground_joints(linkage: Linkage) -> list[str]:
    """Names of the joints (ideal, clearance, then translational clearance) that join a
    body to the ground: each has a reaction output, and each may be the monitored joint."""
    return list(linkage.ground_joints())


@dataclass(frozen=True)
class Output:
    """A study's output of a linkage: its name ("pivot_force:crank_pivot", ...), the model
    columns it is made of (two: the magnitude of a force; one: the absolute value) and
    its unit."""

    name: str
    columns: tuple[str, ...]
    unit: str

    def monitored(self, linkage: Linkage) -> bool:
        """Whether this is the linkage's monitored force (its peak is refined between steps
        by the integrator itself, and its DDM gradient is available): its default output."""
        return self.name == linkage.default_output

    def values(self, outs: np.ndarray, columns: dict[str, int]) -> np.ndarray:
        """The output at the rows of a model's outputs `outs` (columns by name)."""
        if len(self.columns) == 2:
            return np.hypot(outs[:, columns[self.columns[0]]], outs[:, columns[self.columns[1]]])
        return np.abs(outs[:, columns[self.columns[0]]])


def default_output(linkage: Linkage) -> str:
    """The default output: the linkage's monitored output (`Linkage.default_output`: the
    |reaction| of its `monitor_joint`, else the shaking force), whose peaks `simulate`
    reports."""
    return linkage.default_output


def parse_output(linkage: Linkage, output: str | None = None) -> Output:
    """The `Output` named by `output` ("pivot_force:<ground joint>", "shaking_force",
    "drive_moment", "contact_force:<clearance joint or translational joint's corner>"; None:
    `default_output`);
    ValueError naming it and the allowed names otherwise."""
    if output is None:
        output = default_output(linkage)
    from ..elements.registry import ELEMENTS

    grounds = ground_joints(linkage)
    # every contact's force, the elements' contacts in registry order (the revolute
    # clearance joints, a translational joint's corners): the trajectory's contact_force
    clearance = [name for el in ELEMENTS for name in el.contact_names(linkage)]
    # a free linkage has no drive, no drive moment
    allowed = ([f"pivot_force:{g}" for g in grounds] + ["shaking_force"]
               + (["drive_moment"] if linkage.drive is not None else [])
               + [f"contact_force:{c}" for c in clearance])
    if not isinstance(output, str) or output not in allowed:
        raise ValueError(f"unknown output {output!r} of linkage {linkage.name!r}; allowed: "
                         f"{allowed}")
    kind, _, arg = output.partition(":")
    if kind == "pivot_force":
        columns = (f"{arg}.reaction_x", f"{arg}.reaction_y")
    elif kind == "shaking_force":
        columns = ("shaking_x", "shaking_y")
    elif kind == "drive_moment":
        columns = ("drive_moment",)
    else:
        columns = (f"{arg}.contact_force",)
    return Output(output, columns, OUTPUT_KINDS[kind][1])


def _rk_state(model, t0, y0, q, h, A, B, C):
    """The state after one explicit Runge-Kutta step of size h (the integrator's step map,
    in Python: the step re-taken from a recorded step's start)."""
    n = len(y0)
    K = np.empty((len(B), n))
    f = np.empty(n)
    model.rhs(t0, y0, q, f)
    K[0] = f
    for i in range(1, len(B)):
        y = y0 + h * (A[i, :i] @ K[:i])
        model.rhs(t0 + C[i] * h, np.ascontiguousarray(y), q, f)
        K[i] = f
    return y0 + h * (B @ K)


#: recorded local maxima of an output (largest first) refined between steps
_OUTPUT_CANDIDATES = 4


def _refined_peak(model, ts, ys, ms, p, outs, out: Output, t_lo, t_hi, method):
    """The maximum of `out` over [t_lo, t_hi] refined between the recorded steps: the
    largest local maxima of the samples, each refined by golden section on the step maps of
    the steps on both sides (as the integrator refines its monitored force). Returns
    (peak, time)."""
    from ..numerics.integrator import METHODS

    A, B, C = METHODS[method].arrays()[:3]
    col = {c: i for i, c in enumerate(model.OUT_COLUMNS)}
    lo = int(np.searchsorted(ts, t_lo, side="left"))
    hi = int(np.searchsorted(ts, t_hi, side="right"))
    vals = out.values(outs[lo:hi], col)
    m = len(vals)
    is_max = np.zeros(m, dtype=bool)
    is_max[0] = is_max[-1] = True
    if m >= 3:
        is_max[1:-1] = (vals[1:-1] >= vals[:-2]) & (vals[1:-1] >= vals[2:])
    cand = np.flatnonzero(is_max)
    cand = cand[np.argsort(-vals[cand], kind="stable")][:_OUTPUT_CANDIDATES]
    k = int(np.argmax(vals))
    best_v, best_t = float(vals[k]), float(ts[lo + k])
    n_mem, m0 = model.N_MEM, model.MEM_START
    q = p.copy()
    for j in cand:
        for s in (lo + j - 1, lo + j):
            if not lo <= s < hi - 1:
                continue
            q[m0:m0 + n_mem] = ms[s, :n_mem]
            y0 = np.ascontiguousarray(ys[s])
            t0, span = float(ts[s]), float(ts[s + 1] - ts[s])
            if span <= 0.0:
                continue

            def value(h, t0=t0, y0=y0, mem=ms[s:s + 1, :n_mem]):
                y = _rk_state(model, t0, y0, q, h, A, B, C)
                o = model.outputs(np.array([t0 + h]), y[None, :], mem, q)
                return float(out.values(o, col)[0])

            a, b = 0.0, span
            g = 0.6180339887498949
            x1, x2 = b - g * (b - a), a + g * (b - a)
            f1, f2 = value(x1), value(x2)
            for _ in range(REFINE_OUTPUT_ITERS):
                if f1 >= f2:
                    b, x2, f2 = x2, x1, f1
                    x1 = b - g * (b - a)
                    f1 = value(x1)
                else:
                    a, x1, f1 = x1, x2, f2
                    x2 = a + g * (b - a)
                    f2 = value(x2)
            v, x = (f1, x1) if f1 >= f2 else (f2, x2)
            if v > best_v and t_lo <= t0 + x <= t_hi:
                best_v, best_t = v, t0 + x
    return best_v, best_t


#: golden-section iterations per step refined (`_refined_peak`): the bracket shrinks to
#: 0.618^30 = 5e-7 of a step, the value's quadratic error to ~1e-13 of the step's variation
REFINE_OUTPUT_ITERS = 30


def _linkage_peak(linkage: Linkage, out: Output, revolution: int, options: dict,
                  window: float | None = None):
    """(peak, time) of output `out` over drive revolution `revolution` (a free linkage:
    time window `revolution` of `window` s, `objective_window`) of the generated model's
    run with `options` (`linkage_model.run`'s): the monitored force's peak from a run that
    records nothing (the integrator refines it), any other output's from a recorded run
    (`_refined_peak`)."""
    from ..solve import linkage_model as lm

    if options.get("accuracy") is not None:
        from ..solve.accuracy import check_accuracy_or_rtol, value_to_accuracy

        rest = {k: v for k, v in options.items() if k != "accuracy"}
        check_accuracy_or_rtol(options["accuracy"], rest)
        return value_to_accuracy(
            lambda rtol: _linkage_peak(linkage, out, revolution, {**rest, "rtol": rtol},
                                       window),
            options["accuracy"])[0]
    options = {k: v for k, v in options.items() if k != "accuracy"}
    span, t_lo, t_hi = objective_window(linkage, revolution, window)
    if out.monitored(linkage):
        res = lm.run(linkage, record=False, **span, **options)
        return float(res.peaks[revolution - 1]), float(res.peak_times[revolution - 1])
    model, ts, ys, ms, _, _, stats, outs, p = lm.run(linkage, record=True, **span, **options)
    return _refined_peak(model, ts, ys, ms, p, outs, out, t_lo, t_hi, stats["method"])


def objective_window(linkage: Linkage, revolution: int, window: float | None = None):
    """The run and the window of the objective's peak: (keywords of `linkage_model.run`,
    t_lo, t_hi). A driven linkage: drive revolution `revolution`, [(k - 1) T, k T] (no
    `window`: ValueError). A free linkage: time window k of `window` s, [(k - 1) w, k w],
    of a run of k w s in windows of w (`linkage_model.time_edges`, the windows `simulate`
    takes); `window` is required: a free linkage has no period, and a window fixed in
    seconds does not move with the design (its initial rates included), so the peak's
    gradient has no term from moving window edges."""
    if linkage.drive is not None:
        if window is not None:
            raise ValueError(f"linkage {linkage.name!r} is driven: its objective is the peak "
                             f"over drive revolution {revolution}; window= (s) is for a free "
                             f"linkage (drive=None); got window={window!r}")
        return ({"revolutions": revolution}, (revolution - 1) * linkage.period,
                revolution * linkage.period)
    if window is None:
        raise ValueError(f"linkage {linkage.name!r} is free (drive=None): its objective is "
                         f"the peak over time window {revolution} (1-based) of window= s, "
                         f"[(k - 1) w, k w]; give window= in s (e.g. its time scale "
                         f"{linkage.time_scale:.3g} s, one turn at its largest initial rate)")
    window = check_real("window", window, 0.0, None, low_open=True, unit="s")
    return ({"duration": revolution * window, "window": window}, (revolution - 1) * window,
            revolution * window)


def peak_output(linkage: Linkage, output: str | None = None, revolution: int = 4, *,
                window: float | None = None, **options) -> float:
    """The peak of `output` (`parse_output`; default `Linkage.default_output`) over drive
    revolution `revolution` (1-based) of `linkage`'s generated model: the objective of the
    studies of any linkage. A free linkage (drive None): over time window `revolution` of
    `window` s, [(k - 1) w, k w] (`objective_window`; `window` required, and refused for a
    driven linkage). The monitored force (the description's `monitor_joint`, or the
    shaking force) is refined between steps by the integrator (`simulate.peak_base_force`);
    any other output is the largest of the recorded steps' local maxima refined by golden
    section on the steps' map. `options`: those of `simulate` for the reduced backend
    (e.g. ``rtol``), or ``accuracy``: the peak within that relative accuracy by runs at
    tightening rtol until two agree (`accuracy.value_to_accuracy`, an `AccuracyWarning`
    where they do not). Neither given: `simulate`'s default accuracy, 1e-5 (one run at
    the generated model's default rtol, 1e-7, was 1.2e-3 off at 2000 rpm on the paper's
    case)."""
    from ..solve import linkage_model as lm

    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    out = parse_output(linkage, output)
    revolution = check_int("revolution", revolution, 1)
    objective_window(linkage, revolution, window)
    allowed = set(lm.OPTION_NAMES) - {"t_eval", "start", "duration", "window"} | {"accuracy"}
    unknown = sorted(set(options) - allowed)
    if unknown:
        raise ValueError(f"unknown option(s) {unknown} of peak_output; allowed: "
                         f"{sorted(allowed)}")
    if not {"rtol", "atol", "accuracy", "settings"} & set(options):
        from ..solve.accuracy import DEFAULT_ACCURACY

        options = {**options, "accuracy": DEFAULT_ACCURACY}
    return _linkage_peak(linkage, out, revolution, options, window)[0]


# ------------------------------------------------------------------ any linkage

# ------------------------------------------------------------------ DDM at the peak

class _Run:
    """A recorded DDM run of `linkage` along the directions of the design names `names`
    (`design.direction`: a case override moves every description value that follows from
    it), on the model its plain runs use, with the plain run's tolerances (each direction's
    over the value it differentiates, 1 where that is zero), and what is needed to
    evaluate the step map inside it for the output `out`."""

    def __init__(self, linkage, names, out: Output, revolution, rtol, integrator,
                 window=None):
        from ..model import design
        from ..solve import linkage_ddm
        from ..solve.settings import RunSettings

        self.directions = [design.direction(linkage, n) for n in names]
        # CVODES-style error weights, the state's tolerances over |b_k|: the radius's
        # direction sets the step and with it the accuracy of every direction's
        # sensitivity (docs/sensitivity.md, "The error weights of the sensitivities")
        values = np.abs([design.design_value(linkage, n) for n in names])
        scale = np.where(values != 0.0, values, 1.0)
        sp = linkage_ddm.prepare_sensitivity(
            linkage, names, revolution if window is None else None,
            RunSettings(rtol=rtol, method=integrator),
            directions=linkage_ddm.Directions(self.directions, values, scale),
            duration=None if window is None else revolution * window, window=window)
        self.run = linkage_ddm.ddm_run(sp)
        model, rtol = sp.problem.model, sp.problem.rtol
        self.out = out
        self.rtol = float(rtol)
        self.coefficients = METHODS[integrator].arrays()
        self.ts, self.ys, self.ms = self.run.ts, self.run.ys, self.run.ms
        self.peaks, self.peak_t, self.outs = self.run.peaks, self.run.peak_t, self.run.outs
        self.counters = {k: v for k, v in self.run.stats.items()
                         if k not in ("rtol", "method", "wall_time", "event_time_term",
                                      "directions")}
        self.model = model
        self.columns = {c: i for i, c in enumerate(model.OUT_COLUMNS)}
        self.plain_p = self.run.p0
        self.stages = self.coefficients[1].shape[0]
        # function evaluations after the run: plain (rival refinement), augmented (steps
        # to the peak and the rival)
        self.post_plain = 0
        self.post_sens = 0
        self.post_steps = 0

    def magnitudes(self, lo, hi):
        return self.out.values(self.outs[lo:hi], self.columns)

    def step_start(self, t):
        """Index of the recorded step whose end or interior holds t: i with ts[i] < t <=
        ts[i + 1] (or t == ts[0])."""
        return max(int(np.searchsorted(self.ts, t, side="left")) - 1, 0)

    def gradient_at(self, t, newton=True):
        """The output at time t and its derivatives along the directions at the maximum next
        to t, from the step map of the recorded step that holds t (or the recorded sample at
        t). Returns (value at t, gradient, time of the gradient).

        The golden-section refinement places t within ~1e-5 of a step of the maximum t**;
        the sensitivities of parameters that carry the contact vibration at full weight
        (the journal radius) change by percent over that (d/dt of S_k is large where
        d out/dt = 0). With ``newton``, the output and its derivatives are evaluated at
        t - delta, t, t + delta (delta = 1e-4 of the step), t** = t - f'/f'' from their
        parabola (one Newton step for d out/dt = 0) and the gradient interpolated to t**."""
        i = self.step_start(t)
        if self.ts[i + 1] == t:
            i += 1
        if self.ts[i] == t:
            ys, mems = self.ys[i:i + 1], self.ms[i:i + 1]
            hs = np.zeros(1)
        else:
            q = self.run.p.copy()
            n_mem, m0 = self.model.N_MEM, self.model.MEM_START
            q[m0:m0 + n_mem] = self.ms[i, :n_mem]
            h = t - self.ts[i]
            delta = 1e-4 * (self.ts[i + 1] - self.ts[i])
            hs = np.array([h, h - delta, h + delta]) if newton else np.array([h])
            ys, _ = self.model.step_sens(self.ts[i], np.ascontiguousarray(self.ys[i]), q, hs,
                                         self.coefficients)
            self.post_sens += 1 + len(hs) * self.stages
            mems = np.repeat(self.ms[i:i + 1], len(hs), axis=0)
        vals, ders = self.run.output_sensitivities(self.ts[i] + hs, ys, mems)
        cols = [self.columns[c] for c in self.out.columns]
        if len(cols) == 2:
            fx, fy = vals[:, cols[0]], vals[:, cols[1]]
            f = np.hypot(fx, fy)
            d_out = (fx[:, None] * ders[:, cols[0]] + fy[:, None] * ders[:, cols[1]]) \
                / np.maximum(f, 1e-300)[:, None]
        else:
            f = np.abs(vals[:, cols[0]])
            d_out = np.sign(vals[:, cols[0]])[:, None] * ders[:, cols[0]]
        if len(hs) == 1:
            return float(f[0]), d_out[0], float(t)
        d = hs[2] - hs[0]
        curv = (f[2] - 2.0 * f[0] + f[1]) / (0.25 * d * d)      # f''
        slope = (f[2] - f[1]) / d                                # f'
        s = -slope / curv if curv < 0.0 else 0.0
        s = min(max(s, -0.5 * d), 0.5 * d)
        g = (d_out[0] + s * (d_out[2] - d_out[1]) / d
             + 0.5 * s * s * (d_out[2] - 2.0 * d_out[0] + d_out[1]) / (0.25 * d * d))
        return float(f[0]), g, float(t + s)

    def plain_rows(self, idx):
        """States (plain model: the coordinates, rates and the work) and memories of
        recorded rows."""
        return (np.ascontiguousarray(self.run.plain_states(self.ys[idx])),
                np.ascontiguousarray(self.ms[idx, :self.model.N_MEM]))

    def value_at(self, t):
        """The output at time t from the plain step map of the recorded step that holds t."""
        i = self.step_start(t)
        y0s, mems = self.plain_rows(np.array([i]))
        q = self.plain_p.copy()
        n_mem, m0 = self.model.N_MEM, self.model.MEM_START
        q[m0:m0 + n_mem] = mems[0]
        A, B, C = self.coefficients[:3]
        y = _rk_state(self.model, float(self.ts[i]), y0s[0], q, t - self.ts[i], A, B, C)
        o = self.model.outputs(np.array([t]), y[None, :], mems, q)
        self.post_plain += self.stages
        return float(self.out.values(o, self.columns)[0])


def _local_maxima(run, lo, hi, period):
    """The window's local maxima of the monitored force (value, time), largest first.

    Candidates: the RIVAL_CANDIDATES largest local maxima of the recorded samples, each
    refined over the steps on both sides (golden section on the step map, as the
    integrator's refinement), and the window's first and last steps. A refined maximum is a
    local maximum of the window where it lies inside its step, at a sample that both steps
    beside it converge to, or at the window's edge (a boundary maximum: the force falls
    into the window); a refinement that runs into the far end of its step is not (it rises
    beyond it, to a maximum found from the other side). Maxima closer than 1e-6 of a period
    are one."""
    mags = run.magnitudes(lo, hi)
    m = len(mags)
    is_max = np.zeros(m, dtype=bool)
    if m >= 3:
        is_max[1:-1] = (mags[1:-1] >= mags[:-2]) & (mags[1:-1] >= mags[2:])
    cand = np.flatnonzero(is_max)
    cand = cand[np.argsort(-mags[cand], kind="stable")][:RIVAL_CANDIDATES]
    # steps (by their start row, absolute) to refine: both sides of each candidate sample,
    # and the window's first and last steps
    starts = {lo, hi - 2}
    for j in cand:
        starts.update((lo + j - 1, lo + j))
    starts = np.array(sorted(s for s in starts if lo <= s < hi - 1), dtype=np.int64)
    y0s, mems = run.plain_rows(starts)
    t0s = run.ts[starts]
    hs = run.ts[starts + 1] - t0s
    vals, times = run.model.refine_steps(t0s, y0s, mems, run.plain_p, hs, run.coefficients,
                                         _REFINE_ITERS)
    run.post_steps += len(starts)
    run.post_plain += len(starts) * (1 + (_REFINE_ITERS + 2) * run.stages)
    # where each refinement ended: inside its step, or at its start or end sample
    end_tol = 2.0 * 0.6180339887498949 ** _REFINE_ITERS * hs
    at_start = times - t0s <= end_tol
    at_end = t0s + hs - times <= end_tol
    ends_at = {int(s) + 1 for s, e in zip(starts, at_end) if e}
    starts_at = {int(s) for s, b in zip(starts, at_start) if b}
    maxima = []
    for s, v, t, b, e in zip(starts, vals, times, at_start, at_end):
        s = int(s)
        if not (b or e) or (b and s == lo) or (e and s + 1 == hi - 1) \
                or (e and s + 1 in starts_at) or (b and s in ends_at):
            maxima.append((float(v), float(t)))
    # merge: largest first, a maximum closer than `eps` to a kept one is the same
    eps = 1e-6 * period
    maxima.sort(key=lambda vt: -vt[0])
    kept: list[tuple[float, float]] = []
    for v, t in maxima:
        if all(abs(t - tk) > eps for _, tk in kept):
            kept.append((v, t))
    return kept, eps


def _edge_slope(run, t):
    """d out/dt at t from the plain step map of the step that holds t: a central difference
    over +-1e-3 of the step (the map is smooth past the step's end; much shorter
    differences are dominated by the rounding of the penetration, a difference of
    coordinates of the linkage's size)."""
    i = run.step_start(t)
    d = 1e-3 * (run.ts[i + 1] - run.ts[i])
    return (run.value_at(t + d) - run.value_at(t - d)) / (2.0 * d)


def _ddm_gradient(linkage, names, out: Output, revolution, rtol, integrator, kink_tol,
                  window=None):
    """The peak of `out` over drive revolution `revolution` and its DDM gradient along the
    design names `names`: one run of the sensitivity equations, the peak refined between
    its steps (the integrator's refinement for the monitored force, `_refined_peak` for
    another output), the gradient the output's sensitivity at the refined peak time
    (envelope theorem); for the monitored force the window's other local maxima too (a
    rival within the kink tolerance: a kink, with both one-sided gradients)."""
    from ..model import design

    t_wall = time.perf_counter()
    run = _Run(linkage, names, out, revolution, rtol, integrator, window)
    _, t_lo, t_hi = objective_window(linkage, revolution, window)
    monitored = out.monitored(linkage)
    if monitored:
        peak_int, t_int = float(run.peaks[revolution - 1]), float(run.peak_t[revolution - 1])
        lo = int(np.searchsorted(run.ts, t_lo, side="left"))
        hi = int(np.searchsorted(run.ts, t_hi, side="right"))
        kept, eps = _local_maxima(run, lo, hi, t_hi - t_lo)
        # the integrator's peak among them (it replaces a candidate at the same time)
        kept = [(v, t) for v, t in kept if abs(t - t_int) > eps] + [(peak_int, t_int)]
        kept.sort(key=lambda vt: -vt[0])
    else:
        peak_int, t_int = _refined_peak(run.model, run.ts, run.run.plain_states(), run.ms,
                                        run.plain_p, run.outs, out, t_lo, t_hi, integrator)
        kept, eps = [(peak_int, t_int)], 1e-6 * (t_hi - t_lo)
    t_peak = kept[0][1]
    tol = max(kink_tol, KINK_PER_RTOL * run.rtol)
    at_edge = min(t_peak - t_lo, t_hi - t_peak) <= eps
    peak, grad, _ = run.gradient_at(t_peak, newton=not at_edge)
    rival_t = rival_v = math.nan
    rival_g = np.full(len(names), np.nan)
    if len(kept) > 1:
        rival_t = kept[1][1]
        rival_v, rival_g, _ = run.gradient_at(
            rival_t, newton=min(rival_t - t_lo, t_hi - rival_t) > eps)
    speed = np.array([d.get("drive.speed", 0.0) for d in run.directions])
    if at_edge and np.any(speed != 0.0):
        # the window's edges move with the drive speed: d(edge)/d omega = -edge / omega
        t_edge = t_lo if t_peak - t_lo <= eps else t_hi
        grad = grad + _edge_slope(run, t_peak) * (-t_edge / linkage.drive.speed) * speed
    near = np.isfinite(rival_v) and (peak - rival_v) <= tol * peak
    kink = bool(near or at_edge)
    messages = []
    if near:
        messages.append(
            f"kink: a second local maximum of {out.name} at t = {rival_t:.9g} s "
            f"({rival_v:.9g} {out.unit}) is within {tol:.1e} of the peak at t = "
            f"{t_peak:.9g} s ({peak:.9g} {out.unit}); the objective is the larger of two "
            f"smooth branches: gradient and rival_gradient are its one-sided derivatives")
    if not monitored:
        messages.append(f"no rival detection for {out.name} (not the monitored force): a "
                        f"second local maximum within the accuracy of the peak is not looked "
                        f"for (compare with method='fd')")
    if at_edge:
        messages.append(
            f"the peak sits at the window's edge (t = {t_peak:.9g} s in [{t_lo:.9g}, "
            f"{t_hi:.9g}] s): gradient is the derivative of the output at the edge, valid "
            f"while the maximum stays there")
    stats = dict(run.counters, rtol=run.rtol, method=integrator, output=out.name,
                 directions=int(run.run.nb), integrator_peak=peak_int,
                 integrator_peak_time=t_int, local_maxima=len(kept),
                 post_fev_plain=run.post_plain, post_fev_sens=run.post_sens,
                 post_refined_steps=run.post_steps,
                 wall_time=time.perf_counter() - t_wall)
    return PeakGradient(
        peak=peak, time=t_peak, parameters=names,
        reference=np.array([design.design_value(linkage, n) for n in names]), gradient=grad,
        kink=kink, rival_time=rival_t, rival_peak=rival_v, rival_gradient=rival_g,
        at_edge=bool(at_edge), message="; ".join(messages), method="ddm",
        backend="reduced", revolution=revolution, kink_tol=tol, stats=stats, window=window)


# ------------------------------------------------------------------ finite differences

def _fd_peak(args):
    """One perturbed peak (module level: picklable for process pools): (peak, time); the
    reduced model's refined peak of any output, another backend's peak of the monitored
    force (time NaN)."""
    linkage, out, revolution, backend, options, window = args
    if backend == "reduced":
        return _linkage_peak(linkage, out, revolution, options, window)
    from ..solve.simulate import peak_base_force

    return float(peak_base_force(linkage, revolution, backend, **options)), math.nan


def _fd_gradient(linkage, names, out: Output, revolution, backend, fd_relative_step,
                 executor, options, window=None):
    from ..model import design
    from ..solve.linkage_ddm import central_differences

    t_wall = time.perf_counter()
    options = dict(options)
    if backend == "reduced":
        options.setdefault("rtol", 1e-11)
    ref = np.array([design.design_value(linkage, n) for n in names])
    args = (out, revolution, backend, options, window)
    h, plus, minus = central_differences(linkage, names, fd_relative_step, _fd_peak, args,
                                         executor=executor)
    peak, t_peak = _fd_peak((linkage, *args))
    plus = np.array([v[0] for v in plus])
    minus = np.array([v[0] for v in minus])
    stats = {"fd_steps": h.tolist(), "runs": 2 * len(names) + 1, "forward": (plus - peak) / h,
             "backward": (peak - minus) / h, "wall_time": time.perf_counter() - t_wall,
             "output": out.name, **{k: v for k, v in options.items()
                                    if k in ("rtol", "method")}}
    return PeakGradient(
        peak=peak, time=t_peak, parameters=names, reference=ref,
        gradient=(plus - minus) / (2.0 * h), method="fd", backend=backend,
        revolution=revolution, window=window,
        message="central differences: no kink detection (stats['forward'] and "
                "stats['backward'] hold the one-sided differences)", stats=stats)


# ------------------------------------------------------------------ entry point

def peak_gradient(mech: Linkage | SliderCrank, parameters=None, revolution: int = 4,
                  backend: str = "reduced", method: str | None = None, *,
                  output: str | None = None, rtol: float | None = None,
                  integrator: str | None = None, kink_tol: float = KINK_RTOL,
                  fd_relative_step: float = FD_RELATIVE_STEP, executor=None,
                  window: float | None = None, **options) -> PeakGradient:
    """The peak of an output over drive revolution `revolution` (the GA's objective) and
    its gradient with respect to named design values.

    Parameters
    ----------
    mech : Linkage or SliderCrank
        Any description (a named case's, a file's); the paper's `SliderCrank` is its
        case "paper_slider_crank" (`cases.as_linkage`), its fields the design names.
    parameters : sequence of str, optional
        Design names (`design`): the case's overrides ("coupler_length", "clearance",
        ...; the paper's case: continuous SliderCrank fields) or dotted paths of the
        description ("coupler.mass", "drive.speed"). Default on the paper's case
        `sensitivity.DEFAULT_PARAMETERS`; required otherwise.
    output : str, optional
        "pivot_force:<ground joint>", "shaking_force", "drive_moment" or
        "contact_force:<clearance joint>" (`parse_output`); default the linkage's
        monitored output (`Linkage.default_output`: the paper's base force F12, the
        four-bar's shaking force), the one `simulate`'s peaks are.
    revolution : int
        Drive revolution (1-based) whose peak is the objective (paper: 4); a free linkage
        (drive None): the time window [(k - 1) w, k w] of width `window`.
    window : float, optional
        A free linkage's window width w in s (required there, refused for a driven
        linkage; `objective_window`).
    backend : str
        "reduced" for DDM; any backend of `simulate` for ``method="fd"`` (another
        backend's peak is that of the monitored force).
    method : {None, "ddm", "fd"}
        "ddm": one run of the sensitivity equations along the directions of the named values
        (`design.direction`), the output's sensitivity at the refined peak time (envelope
        theorem), on the model `simulate` runs (with friction: the model generated with the
        tangential force). For the monitored force the window's other local maxima are
        refined too, and a rival within `kink_tol` is reported as a kink with both
        one-sided gradients. "fd": central differences of the refined peak, 2 p + 1 runs.
        None: "ddm" on the paper's case (measured against central differences to 1e-3
        on the GA's box, docs/sensitivity.md); "fd" on other linkages (on the four-bar's
        lightly damped sliding contact the DDM does not converge with rtol,
        docs/studies_linkage.md).
    rtol : float, optional
        Relative tolerance of the reduced model (DDM: default `PEAK_GRADIENT_RTOL`, 1e-6;
        FD: default 1e-11). The cheaper default: one run at that tolerance, without an
        error estimate of the peak (`peak` is not the error-controlled value of
        `peak_base_force`, whose default meets 1e-5; measured against rtol 1e-12, the DDM
        default's peak is within 5e-6 at the paper's point, 2000 rpm, c = 0.05 mm and
        L2 = 4.5 cm / L3 = 12.5 cm; the gradient's accuracy is measured in
        docs/performance.md).
    integrator : str, optional
        Method of the compiled integrator (DDM default "dop853"; FD: the plain default).
    kink_tol : float, default 1e-5
        Relative gap below which a second local maximum ties with the peak (the tolerance
        used is max(kink_tol, KINK_PER_RTOL * rtol) = max(kink_tol, 10 rtol)).
    fd_relative_step : float, default 3e-5
        FD only: relative step, see `linkage_ddm.fd_step`.
    executor :
        FD only: a concurrent.futures-style executor for the 2 p + 1 runs.
    **options :
        FD only: backend options passed to the peak runs (e.g. ``step_size`` for Exudyn).

    Returns
    -------
    PeakGradient
    """
    from ..model import design
    from ..model.cases import as_linkage
    from ..solve import linkage_model as lm
    from ..solve.simulate import BACKENDS

    linkage = as_linkage(mech)
    revolution = check_int("revolution", revolution, 1)
    objective_window(linkage, revolution, window)
    check_revolutions_memory(revolution, name="revolution")
    check_choice("backend", backend, BACKENDS)
    paper = design.slider_crank_of(linkage) is not None
    if method is None:
        method = "ddm" if paper else "fd"
    check_choice("method", method, ("ddm", "fd"))
    if integrator is not None:
        check_choice("integrator", integrator, METHODS)
    if rtol is not None:
        rtol = check_real("rtol", rtol, 1e-14, 1e-2)
    kink_tol = check_real("kink_tol", kink_tol, 0.0, 1.0, high_open=True)
    fd_relative_step = check_real("fd_relative_step", fd_relative_step, 0.0, 0.1,
                                  low_open=True, high_open=True)
    if parameters is None and paper:
        parameters = DEFAULT_PARAMETERS
    if parameters is None:
        raise ValueError(f"parameters must name what to differentiate for a Linkage: "
                         f"{design.design_names(linkage)}")
    names = design.check_names(linkage, [parameters] if isinstance(parameters, str)
                               else list(parameters))
    if not names:
        raise ValueError("parameters must name at least one parameter")
    out = parse_output(linkage, output)
    if method == "ddm":
        if backend != "reduced":
            raise ValueError("method='ddm' needs backend='reduced' (the direct "
                             "differentiation equations are those of the reduced model); use "
                             "method='fd' for other backends")
        if options or executor is not None:
            extra = sorted(options) + (["executor"] if executor is not None else [])
            raise ValueError(f"unknown option(s) for method='ddm': {extra}")
        return _ddm_gradient(linkage, names, out, revolution,
                             PEAK_GRADIENT_RTOL if rtol is None else rtol,
                             integrator or DDM_INTEGRATOR, kink_tol, window)
    if backend == "reduced":
        allowed = set(lm.OPTION_NAMES) - {"t_eval", "start", "duration", "window"}
        unknown = sorted(set(options) - allowed)
        if unknown:
            raise ValueError(f"unknown option(s) {unknown} for the reduced model's peak; "
                             f"allowed: {sorted(allowed)}")
    else:
        if not out.monitored(linkage):
            raise ValueError(f"output {out.name!r} is the reduced model's only (backend "
                             f"{backend!r} gives the monitored force's peak); use "
                             f"backend='reduced'")
        for name, value in (("rtol", rtol), ("integrator", integrator)):
            if value is not None:
                raise ValueError(f"{name} applies to the reduced backend only; got "
                                 f"backend={backend!r}")
    if rtol is not None:
        options["rtol"] = rtol
    if integrator is not None:
        options["method"] = integrator
    return _fd_gradient(linkage, names, out, revolution, backend, fd_relative_step, executor,
                        options, window)
