"""A mechanism's state advanced window by window on the compiled integrator: `Flow` (the
plain model) and `TangentFlow` (the state with one tangent vector of the variational
equations), the runs under Poincare sections (poincare.py) and Lyapunov exponents
(lyapunov.py). Any Linkage has one, and a SliderCrank on the paper's generated model."""

from __future__ import annotations

import numpy as np

from .._checks import check_real
from ..model.linkage import Linkage
from ..model.mechanism import SliderCrank
from ..numerics.integrator import METHODS, RESULTS
from .linkage_model import DEFAULT_RTOL

__all__ = ["Flow", "TangentFlow", "drive_of", "clearances_of", "joints_of"]


def _is_linkage(mech) -> bool:
    return isinstance(mech, Linkage)


def _check_mech(mech) -> None:
    if not isinstance(mech, (SliderCrank, Linkage)):
        raise ValueError(f"mech must be a SliderCrank or a Linkage; got {type(mech).__name__}")


def drive_of(mech) -> tuple[float, float]:
    """(omega, theta0): the constant drive speed (rad/s) and initial crank angle (rad)."""
    if _is_linkage(mech):
        return mech.drive.speed, mech.drive.initial_angle
    return mech.crank_speed, mech.initial_crank_angle


def clearances_of(mech) -> np.ndarray:
    """Radial clearance of each clearance joint (m)."""
    if _is_linkage(mech):
        return np.array([j.clearance for j in mech.clearance_joints])
    return np.array([mech.clearance])


def joints_of(mech) -> tuple[str, ...]:
    """Names of the clearance joints (the paper's one joint: "coupler_slider")."""
    if _is_linkage(mech):
        return tuple(j.name for j in mech.clearance_joints)
    return ("coupler_slider",)


class Flow:
    """A mechanism's state advanced window by window on the compiled integrator (the plain
    model: `reduced` for a SliderCrank, the generated model for a Linkage), holding one
    window's record at a time. `t`, `y`, `p` are the current time, state and parameters
    (with the contact memory). `advance(t1)` returns the window's refined maximum of the
    monitored force (|F12|, or the linkage's monitored reaction)."""

    def __init__(self, mech, *, rtol: float | None = None, method: str = "dopri5",
                 max_steps: int = 5_000_000):
        _check_mech(mech)
        self.mech = mech
        rtol = DEFAULT_RTOL if rtol is None else check_real("rtol", rtol, 1e-14, 1e-4)
        if method not in METHODS:
            raise ValueError(f"method must be one of {sorted(METHODS)}; got {method!r}")
        self.omega, self.theta0 = drive_of(mech)
        self.clearance = clearances_of(mech)
        self.joints = joints_of(mech)
        from . import linkage_model as lm
        from . import reduced

        linkage = mech if _is_linkage(mech) else reduced.linkage_of(mech)
        model = self.model = (lm.load_model(linkage) if _is_linkage(mech)
                              else reduced.model_of(mech))
        p = lm.pack_parameters(linkage, model)
        rtol, atol = lm._tolerances(linkage, model, rtol, None)
        event_tol = lm.event_tolerance(linkage)
        if _is_linkage(mech):
            y0 = lm.initial_state(linkage, model, p)
        else:                       # the paper's closed-form start, as its runs
            y0 = lm.check_start(linkage, model, p, reduced.centred_start(mech), event_tol)
        self.kernel = model.integrate_model
        self.settings = lm.integrator_settings(
            linkage, model, rtol, atol, h_max=linkage.period / 8, max_steps=max_steps,
            record=True, event_tol=event_tol)
        self._gaps = [getattr(model, f"_gap_{j}") for j in range(model.N_EVENTS)]
        self.rtol = rtol
        self.coefficients = METHODS[method].arrays()
        self.t = 0.0
        self.y = np.ascontiguousarray(y0, dtype=float)
        self.p = p
        self.counters = np.zeros(5, dtype=np.int64)
        #: the most steps recorded in one window (the run's record never holds more)
        self.max_recorded = 0

    def _run(self, kernel, y, p, t1, settings):
        """One window [t, t1] of `kernel` from (y, p): the end state (landed on t1), the
        window's peak; the next window starts with the last full step's size."""
        edges = np.array([self.t, t1])
        ts, ys, ms, peaks, _, counters, _, status = kernel(y, p, edges, settings,
                                                            self.coefficients)
        status = RESULTS(int(status))
        if status is not RESULTS.success:
            name = getattr(self.mech, "name", "slider-crank")
            raise RuntimeError(f"{name}: integration failed at about t = "
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
    (`cases.from_slider_crank`)."""

    def __init__(self, mech, *, rtol: float | None = None, method: str = "dop853",
                 direction=None, memory: str = "reset", max_steps: int = 5_000_000):
        if memory not in ("reset", "carry"):
            raise ValueError(f"memory must be 'reset' or 'carry'; got {memory!r}")
        self.reset_memory = memory == "reset"
        super().__init__(mech, rtol=rtol, method=method, max_steps=max_steps)
        from .linkage_ddm import pack_sensitivity_parameters, sensitivity_atol

        model = self.model
        n2 = 2 * model.N_Q
        #: scales of the tangent's components: the journal moves within the clearance
        self.scale = _tangent_scale(mech, model)
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


def _tangent_scale(mech, model) -> np.ndarray:
    """Scales of the tangent's components: lengths the (smallest) clearance c, angles c
    over the coupler's length (the paper's case) or over the linkage's length scale, rates
    those times the drive speed."""
    if isinstance(mech, SliderCrank):
        c, length, w = mech.clearance, mech.coupler_length, mech.crank_speed
    else:
        c, length, w = mech.min_clearance, mech.length_scale, mech.drive.speed
    pos = np.array([c / length if n.endswith(".angle") else c for n in model.COORDINATES])
    return np.concatenate([pos, w * pos])
