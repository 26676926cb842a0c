"""A linkage's state advanced window by window on the compiled integrator: `Flow` (the
plain model) and `TangentFlow` (the state with one tangent vector of the variational
equations), the runs under Poincare sections (poincare.py), Lyapunov exponents
(lyapunov.py) and periodic orbits (periodic.py). Any Linkage has one (the paper's
SliderCrank as its case, `cases.as_linkage`)."""

from __future__ import annotations

from functools import partial

import numpy as np

from .._checks import check_real
from ..model.cases import as_linkage
from ..numerics.integrator import METHODS, RESULTS
from .kernels import plain_kernel
from .problem import Problem
from .settings import RunSettings

#: times a window is run again, each with a first step 0.3 times smaller, when its events
#: chattered (a grazing contact at machine precision: the step sequence, not the motion)
CHATTER_RETRIES = 3

__all__ = ["Flow", "TangentFlow", "prepare_flow", "drive_of", "clearances_of", "joints_of"]


def _check_mech(mech) -> None:
    as_linkage(mech)


def drive_of(mech) -> tuple[float, float]:
    """(omega, theta0): the constant drive speed (rad/s) and initial crank angle (rad)."""
    drive = as_linkage(mech).drive
    return drive.speed, drive.initial_angle


def clearances_of(mech) -> np.ndarray:
    """Radial clearance of each clearance joint (m)."""
    return np.array([j.clearance for _, j in as_linkage(mech).contacts()])


def joints_of(mech) -> tuple[str, ...]:
    """Names of the clearance joints (the paper's one joint: "coupler_slider")."""
    return tuple(name for name, _ in as_linkage(mech).contacts())


def prepare_flow(mech, settings: RunSettings | None = None, *, free: bool = False,
                 default_method: str = "dopri5", **options) -> Problem:
    """The `Problem` of a flow of `mech` (`linkage_model.prepare`): its span one window, a
    drive revolution (a free linkage, refused unless `free`: its `time_scale`), the state,
    parameters and tolerances the flow starts from. `settings` (a `RunSettings`; keywords
    change single fields; `default_method` where neither names one): its rtol at most 1e-4
    (default `DEFAULT_RTOL`)."""
    from .linkage_model import prepare

    linkage = as_linkage(mech)
    free_linkage = linkage.drive is None
    if free_linkage and not free:
        raise ValueError(f"linkage {linkage.name!r} is free (drive=None): a flow maps "
                         "drive revolutions; run a free linkage with simulate(..., "
                         "duration=)")
    if settings is None:
        settings = RunSettings(method=options.pop("method", None) or default_method)
    if not isinstance(settings, RunSettings):
        raise ValueError(f"settings must be a RunSettings; got {type(settings).__name__}")
    settings = settings.with_options(options)
    if settings.rtol is not None:
        check_real("rtol", settings.rtol, 1e-14, 1e-4)
    return prepare(linkage, None if free_linkage else 1, settings,
                   duration=linkage.time_scale if free_linkage else None)


class Flow:
    """A linkage's state advanced window by window on its generated model's integrator,
    holding one window's record at a time. `t`, `y`, `p` are the current time, state and
    parameters (with the contact memory). `advance(t1)` returns the window's refined
    maximum of the monitored force (the linkage's monitored reaction, or the shaking
    force).

    `mech` is a mechanism (its `Problem` prepared here, `prepare_flow`) or a prepared
    `Problem`. `settings` (a `RunSettings`; keywords change single fields): its rtol (at
    most 1e-4; default `DEFAULT_RTOL`), atol, method, max_steps, h_max (default an eighth
    of a drive revolution) and event_tol are the runs'.

    A free linkage (drive None) has no drive revolutions to map: it is refused unless
    `free` is True (its windows are then any times, h_max an eighth of its `time_scale`,
    and `omega`, `theta0` are None)."""

    #: the method when the settings name none
    METHOD = "dopri5"

    def __init__(self, mech, settings: RunSettings | None = None, *, free: bool = False,
                 **options):
        from . import linkage_model as lm

        if isinstance(mech, Problem):
            if settings is not None or options:
                raise ValueError("a prepared Problem carries its settings: give them to "
                                 "prepare_flow (or linkage_model.prepare), not to the flow")
            problem = mech
        else:
            problem = prepare_flow(mech, settings, free=free, default_method=self.METHOD,
                                   **options)
        self.problem = problem
        linkage = self.linkage = problem.linkage
        self.mech = problem.linkage if isinstance(mech, Problem) else mech
        self.omega, self.theta0 = ((None, None) if problem.span.revolutions is None else
                                   (linkage.drive.speed, linkage.drive.initial_angle))
        self.clearance = clearances_of(linkage)
        self.joints = joints_of(linkage)
        model = self.model = problem.model
        plain = problem.integrator
        self.kernel = plain_kernel(linkage, model, problem.specialise)
        # the flow's own record: every step of one window, no outputs
        self.settings = lm.integrator_settings(
            linkage, model, problem.rtol, plain.atol, h_max=plain.h_max,
            max_steps=problem.max_steps, record=True, event_tol=plain.event_tol)
        self._gaps = [_gap_function(model, j) for j in range(model.N_EVENTS)]
        self.rtol = problem.rtol
        self.coefficients = METHODS[problem.method].arrays()
        self.t = 0.0
        self.y = np.ascontiguousarray(problem.y0, dtype=float).copy()
        self.p = problem.p.copy()
        self.counters = np.zeros(5, dtype=np.int64)
        #: the most steps recorded in one window (the run's record never holds more)
        self.max_recorded = 0
        #: windows run again after events chattered at a grazing contact (`CHATTER_RETRIES`)
        self.chatter_retries = 0

    def _run(self, kernel, y, p, t1, settings):
        """One window [t, t1] of `kernel` from (y, p): the end state (landed on t1), the
        window's peak; the next window starts with the last full step's size."""
        edges = np.array([self.t, t1])
        p_start = p.copy()
        for retry in range(CHATTER_RETRIES + 1):
            ts, ys, ms, peaks, _, counters, _, status = kernel(y, p, edges, settings,
                                                                self.coefficients)
            status = RESULTS(int(status))
            if status is not RESULTS.event_chatter or retry == CHATTER_RETRIES:
                break
            # a grazing contact met at machine precision by this step sequence: the window
            # again from its start (state and memories) with a smaller first step, which
            # changes the sequence; the run stays within its tolerances
            self.counters += counters          # the failed attempt's work counts
            p[:] = p_start
            h0 = settings.h0 if settings.h0 > 0.0 else 1e-4 * (t1 - self.t)   # 0: automatic
            settings = settings._replace(h0=0.3 * h0)
            self.chatter_retries += 1
        if status is not RESULTS.success:
            raise RuntimeError(f"{self.linkage.name}: integration failed at about t = "
                               f"{ts[-1] if len(ts) else self.t:.6g} s: {status.message}")
        self.counters += counters
        self.max_recorded = max(self.max_recorded, len(ts))
        if len(ts) >= 3:
            self.settings = self.settings._replace(h0=float(ts[-2] - ts[-3]))
        self.t = float(t1)
        return np.ascontiguousarray(ys[-1]).copy(), float(peaks[0])

    def advance(self, t1: float) -> float:
        """Integrate to t1 (> t); returns the window's peak of the monitored force (N)."""
        self.y, peak = self._run(self.kernel, self.y, self.p, t1, self.settings)
        return peak

    def section(self) -> np.ndarray:
        """(J, 4) eccentricity x, y (m) and its rates (m/s) of each joint, now."""
        return np.array([g(self.t, self.y, self.p) for g in self._gaps], dtype=float)


class TangentFlow(Flow):
    """A mechanism's generated model with one tangent vector: the DDM sensitivity equations
    (`linkage_ddm`) with one direction and no parameter. y = [state (2 N_Q), tangent
    (2 N_Q), W, the memories' tangents (J)]; a SliderCrank runs on the paper's model
    (`cases.from_slider_crank`). The contacts are the clearance joints and the corners of
    the translational clearance joints alike: each corner's onset sets its memory's
    tangent with the event-time term, as a joint's. `free`: as `Flow`."""

    #: the variational equations are accuracy-limited: the 8th-order pair
    METHOD = "dop853"

    def __init__(self, mech, settings: RunSettings | None = None, *, direction=None,
                 memory: str = "reset", free: bool = False, **options):
        from ..generate.profiles import refuse_sensitivity_runs

        refuse_sensitivity_runs(mech.linkage if isinstance(mech, Problem) else as_linkage(mech))
        if memory not in ("reset", "carry"):
            raise ValueError(f"memory must be 'reset' or 'carry'; got {memory!r}")
        self.reset_memory = memory == "reset"
        super().__init__(mech, settings, free=free, **options)
        from .linkage_ddm import pack_sensitivity_parameters, sensitivity_atol

        model = self.model
        n2 = 2 * model.N_Q
        #: scales of the tangent's components: the journal moves within the clearance
        self.scale = _tangent_scale(self.problem)
        v = np.full(n2, 0.5) if direction is None else np.asarray(direction, dtype=float)
        if v.shape != (n2,) or not np.all(np.isfinite(v)) or not np.any(v != 0.0):
            raise ValueError(f"direction must be {n2} finite numbers, not all zero (scaled "
                             f"components of {', '.join(model.COORDINATES)} and their rates); "
                             f"got {direction!r}")
        v = v / np.linalg.norm(v) * self.scale
        self.p = pack_sensitivity_parameters(model, self.p, [{}], True)
        self.y = np.concatenate([self.y[:n2], v, [self.y[n2]], np.zeros(model.N_EVENTS)])
        atol_plain = self.settings.atol
        atol = sensitivity_atol(model, atol_plain, [1.0])
        atol[n2:2 * n2] = self.rtol * self.scale
        self.settings = self.settings._replace(atol=atol, n_err=2 * n2)
        self.kernel = model.integrate_sens
        self._n2 = n2

    def tangent(self) -> np.ndarray:
        """The tangent vector (2 N_Q,) in units of the state."""
        return self.y[self._n2:2 * self._n2]

    def renormalise(self) -> float:
        """Scale the tangent to unit scaled norm (the memories' tangents: reset to 0 or
        scaled alike, `memory`); returns the growth."""
        n2 = self._n2
        n = float(np.linalg.norm(self.y[n2:2 * n2] / self.scale))
        self.y[n2:2 * n2] /= n
        sig = slice(2 * n2 + 1, None)
        self.y[sig] = 0.0 if self.reset_memory else self.y[sig] / n
        return n


def _gap_function(model, j: int):
    """(t, y, p) -> (ex, ey, exd, eyd) of switching function j's contact point, of a C
    model."""
    return partial(model.gap, j=j)


def _tangent_scale(problem: Problem) -> np.ndarray:
    """Scales of the tangent's components of a flow's `problem`: lengths the smallest
    clearance c, angles c over the linkage's length scale, rates those times the drive
    speed (a free linkage's span, without revolutions: over its `time_scale`)."""
    linkage, model = problem.linkage, problem.model
    c, length = linkage.min_clearance, linkage.length_scale
    w = 1.0 / linkage.time_scale if problem.span.revolutions is None else linkage.drive.speed
    pos = np.array([c / length if n.endswith(".angle") else c for n in model.COORDINATES])
    return np.concatenate([pos, w * pos])
