"""Periodic orbits of a constant-speed mechanism and their stability: Newton shooting on
the state at a crank-angle section, with the monodromy matrix from the variational run.

The return map. A constant-speed drive repeats the equations every revolution, so the
state after `period` revolutions from t = 0 is a map P of the state at t = 0; a periodic
orbit is a fixed point of P. The hybrid state is the mechanical state x = (q, qdot)
(2 N_Q: the generated model's coordinates and rates) and, per clearance joint, its contact
mode and the stored impact velocity v_j (the contact law's memory). The mode is discrete:
it is carried through the shooting and must be the same at both ends. The memory enters
the map by what it does in one period:

- a joint with a contact onset within the period: its memory at the end is set at that
  onset, a function of the state (the event-time term, `sens_runtime.sens_on_event`), and
  the memory at the start acts on the motion until then (where the joint is in contact at
  the section). Its v_j is an unknown of the shooting and a row and column of the
  monodromy matrix: the multipliers are those of the full hybrid map.
- a joint with no onset within the period (in permanent contact, the paper's design, or
  in free flight throughout): its memory is never overwritten, P leaves it unchanged, so
  the hybrid map has the multiplier exactly 1 along it whatever the motion's stability:
  nearby memories give nearby periodic orbits, a family (lyapunov.py's module docstring).
  Its v_j is held at the guess's value (a parameter of the orbit, not an unknown), and its
  row and column are left out: the multipliers are those of the mechanical state for that
  memory, as the Lyapunov exponent's memory "reset". With them in, Newton's matrix
  P' - I would be singular and the verdict could never be "stable".

The monodromy matrix comes from one run of the sensitivity equations (linkage_ddm,
generate/sens_runtime.py) with no parameter and 2 N_Q + J directions: the scaled unit
vectors of the state (positions in clearances, angles in clearance / length, rates times
the drive speed: `lyapunov._tangent_scale`) and of each memory (clearance x drive
speed). The tangent of the state does not jump at contact switches, the memory's is set at
each onset with the event-time term: the matrix is that of the non-smooth map (checked
against central finite differences of the map, tests/unit/test_periodic.py).

The contacts are the clearance joints and the corners of the translational clearance joints
alike (`Linkage.contacts`): a corner's memory is a joint's as above.

A free linkage (no drive) has no drive period, so no return map: it is refused
(`check_driven`).

Stability: "stable" where every multiplier lies inside the unit circle, else "unstable".

The guess. A settled run can still carry a weakly damped fast vibration of the contact
(the four-bar at 10 rpm: the joint's contact mode, thousands of oscillations per
revolution, decays over about 100 revolutions), and a Newton step on it leaves the region
where the map is near linear (the oscillation's frequency depends on its amplitude, so its
phase after a revolution does too). The default guess is therefore the better, by the map's
residual, of the settled section state and its smoothed value one revolution later: a
polynomial fitted to the run's states over a short window around the section (a slow
orbit's state is smooth there, the vibration averages out of the fit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._checks import check_int, check_real
from ..model.cases import as_linkage
from ..model.design import design_at, value_at
from ..numerics.integrator import RESULTS
from ..solve.flows import Flow, _tangent_scale, clearances_of, drive_of, joints_of

__all__ = ["PeriodicOrbit", "periodic_orbit", "return_map", "Branch", "BranchPoint",
           "continue_orbits", "switch_branch", "field_value", "with_field", "newton_check",
           "OrbitCheck",
           "SHOOTING_RTOL", "NEWTON_TOL", "POINT_KINDS"]

#: default relative tolerance of the shooting runs (the map's error must stay well below
#: the Newton tolerance)
SHOOTING_RTOL = 1e-10

#: default Newton tolerance: the largest scaled component of P(z) - z (fractions of the
#: clearance, of clearance x speed for rates)
NEWTON_TOL = 1e-6

#: largest Newton step, scaled (clearances; clearance x speed for rates)
MAX_STEP = 0.5

#: default settling revolutions of the guess (a plain run from the centred start)
SETTLE = 20

#: the smoothed guess: a window of this fraction of a revolution around the section, and
#: the degree of the polynomial fitted there (module docstring, "The guess")
SMOOTH_WINDOW = 0.02
SMOOTH_DEGREE = 6
SMOOTH_SAMPLES = 401


@dataclass
class PeriodicOrbit:
    """A periodic orbit of `period` drive revolutions found by shooting.

    `state` (2 N_Q,) is the generated model's coordinates and rates at the section
    (t = 0, the drive at its initial angle), `modes` and `impact_velocities` (J,) each
    clearance joint's contact mode and stored impact velocity there; `multipliers` the
    Floquet multipliers (complex, largest modulus first) of the return map over the
    unknowns `unknowns` (coordinate names, then "<joint>.impact_velocity" of the joints
    with a contact onset per period; the module docstring), `monodromy` its matrix in
    scaled variables (`scale`); `stability` "stable" or "unstable"; `iterations` the
    Newton iterations, `residual` the final max |P(z) - z| in scaled units; `onsets`
    the contact onsets per joint over one period; `trajectory` the orbit over `period`
    revolutions (None where not asked for)."""

    mech: object
    period: int
    state: np.ndarray
    modes: np.ndarray
    impact_velocities: np.ndarray
    multipliers: np.ndarray
    monodromy: np.ndarray
    unknowns: tuple
    scale: np.ndarray
    stability: str
    iterations: int
    residual: float
    onsets: np.ndarray
    rtol: float
    trajectory: object = None
    history: list = field(default_factory=list)

    @property
    def spectral_radius(self) -> float:
        """Largest modulus of the multipliers."""
        return float(np.max(np.abs(self.multipliers))) if len(self.multipliers) else 0.0

    @property
    def contact_phases(self) -> int:
        """Contact onsets per period, all joints."""
        return int(np.sum(self.onsets))

    def start(self):
        """The section state as a `linkage_model.Start` (of the mechanism's linkage: a
        SliderCrank's `cases.from_slider_crank`), to run from the orbit."""
        from ..solve.linkage_model import Start

        return Start(y=self.state.copy(), modes=self.modes.copy(),
                     impact_velocities=self.impact_velocities.copy(), revolutions=0,
                     linkage=as_linkage(self.mech).name)


def check_driven(mech) -> None:
    """ValueError for a free linkage (drive None): a periodic orbit here is a fixed point of
    the map over whole drive revolutions, and a free linkage has no drive period."""
    linkage = as_linkage(mech)
    if linkage.drive is None:
        raise ValueError(f"linkage {linkage.name!r} is free (drive=None): periodic orbits "
                         "are fixed points of the map over whole drive revolutions, and a "
                         "free linkage has no drive period; its finite-time Lyapunov "
                         "exponent: lyapunov_exponent(linkage, duration=..., window=...)")


class _Shooter:
    """The return map of `mech` over `period` revolutions: plain (`value`) and with the
    monodromy matrix (`jacobian`), from a state x and memory (modes, impact velocities)."""

    def __init__(self, mech, period: int, rtol: float, method: str, t0: float = 0.0):
        from ..generate.profiles import refuse_sensitivity_runs
        from ..solve.linkage_ddm import pack_sensitivity_parameters, sensitivity_atol

        check_driven(mech)
        refuse_sensitivity_runs(as_linkage(mech))
        flow = Flow(mech, rtol=rtol, method=method)
        self.mech = mech
        self.model = model = flow.model
        self.n2 = n2 = 2 * model.N_Q
        self.J = J = model.N_EVENTS
        self.p0 = flow.p.copy()
        self.y0 = flow.y.copy()
        self.n_state = len(self.y0)
        self.mem0 = model.MEM_START
        self.plain_kernel = flow.kernel
        self.plain_settings = flow.settings
        self.coefficients = flow.coefficients
        self.omega, _ = drive_of(mech)
        # the drive repeats every revolution: a map from any section time t0
        self.edges = t0 + np.arange(period + 1) * 2.0 * math.pi / self.omega
        self.counters = np.zeros(5, dtype=np.int64)
        self.scale = np.concatenate([_tangent_scale(flow.problem),
                                     clearances_of(mech) * self.omega])
        self.joints = joints_of(mech)
        nb = n2 + J
        self.nb = nb
        self.sp = pack_sensitivity_parameters(model, self.p0, [{}] * nb, True)
        # each column a perturbation of the size of the state's scales: the state's atol
        atol = sensitivity_atol(model, flow.settings.atol, [1.0] * nb)
        self.sens_settings = flow.settings._replace(atol=atol, n_err=n2 * (1 + nb))
        self.sens_kernel = model.integrate_sens
        self.rtol = flow.rtol
        self.method = method
        self.guess_flow = flow

    def memory(self, p) -> tuple[np.ndarray, np.ndarray]:
        m = p[self.mem0:self.mem0 + 2 * self.J]
        return m[0::2].copy(), m[1::2].copy()

    def _set_memory(self, p, modes, vel):
        p[self.mem0:self.mem0 + 2 * self.J:2] = modes
        p[self.mem0 + 1:self.mem0 + 2 * self.J:2] = vel

    def _call(self, kernel, y, p, settings):
        ts, ys, ms, peaks, _, counters, _, status = kernel(y, p, self.edges, settings,
                                                           self.coefficients)
        status = RESULTS(int(status))
        self.counters += counters
        if status is not RESULTS.success:
            raise RuntimeError(f"integration of the return map failed at about t = "
                               f"{ts[-1] if len(ts) else 0.0:.6g} s: {status.message}")
        return ys[-1], ms, peaks

    def onsets(self, modes0, ms) -> np.ndarray:
        """Contact onsets per joint in a run's record (modes from modes0 at the start)."""
        out = np.zeros(self.J, dtype=int)
        for j in range(self.J):
            m = np.concatenate([[modes0[j]], ms[:, 2 * j]])
            out[j] = int(np.sum((m[1:] > 0.5) & (m[:-1] < 0.5)))
        return out

    def value(self, x, modes, vel):
        """P: (end state, end modes, end impact velocities, onsets per joint, peaks)."""
        p = self.p0.copy()
        self._set_memory(p, modes, vel)
        y = np.concatenate([x, np.zeros(self.n_state - self.n2)])
        ye, ms, peaks = self._call(self.plain_kernel, y, p, self.plain_settings)
        m, v = self.memory(p)
        return ye[:self.n2].copy(), m, v, self.onsets(modes, ms), peaks

    def jacobian(self, x, modes, vel):
        """As `value`, with the monodromy matrix (n2 + J, n2 + J) in scaled variables."""
        n2, nb, J = self.n2, self.nb, self.J
        p = self.sp.copy()
        self._set_memory(p, modes, vel)
        s0 = np.zeros((nb, n2))
        s0[np.arange(n2), np.arange(n2)] = self.scale[:n2]
        sig0 = np.zeros((nb, J))
        for j in range(J):
            sig0[n2 + j, j] = self.scale[n2 + j]
        y = np.concatenate([x, s0.ravel(), [0.0], sig0.ravel()])
        ye, ms, peaks = self._call(self.sens_kernel, y, p, self.sens_settings)
        s = ye[n2:n2 * (1 + nb)].reshape(nb, n2)
        sig = ye[n2 * (1 + nb) + 1:].reshape(nb, J)
        M = np.empty((n2 + J, nb))
        M[:n2] = s.T / self.scale[:n2, None]
        M[n2:] = sig.T / self.scale[n2:, None]
        m, v = self.memory(p)
        return ye[:n2].copy(), m, v, self.onsets(modes, ms), peaks, M


def return_map(mech, state, modes, impact_velocities, period: int = 1, *,
               rtol: float | None = None, method: str = "dop853", jacobian: bool = False):
    """The state after `period` drive revolutions from (state, modes, impact_velocities)
    at t = 0: (end state, end modes, end impact velocities, onsets per joint), and with
    `jacobian` the monodromy matrix in scaled variables (module docstring) last."""
    sh = _Shooter(mech, check_int("period", period, 1),
                  SHOOTING_RTOL if rtol is None else rtol, method)
    x, modes, vel = _check_state(sh, state, modes, impact_velocities)
    out = (sh.jacobian if jacobian else sh.value)(x, modes, vel)
    return out[:4] + ((out[5],) if jacobian else ())


def _check_state(sh, state, modes, vel):
    x = np.asarray(state, dtype=float)
    modes = np.asarray(modes, dtype=float).reshape(-1)
    vel = np.asarray(vel, dtype=float).reshape(-1)
    if x.shape != (sh.n2,) or not np.all(np.isfinite(x)):
        raise ValueError(f"state must be {sh.n2} finite numbers (the coordinates "
                         f"{list(sh.model.COORDINATES)} and their rates); got {state!r}")
    if modes.shape != (sh.J,) or not np.all((modes == 0.0) | (modes == 1.0)):
        raise ValueError(f"modes must be {sh.J} values 0 (free) or 1 (contact), one per "
                         f"clearance joint {list(sh.joints)}; got {modes!r}")
    if vel.shape != (sh.J,) or not np.all(np.isfinite(vel)) or np.any(vel < 0.0):
        raise ValueError(f"impact_velocities must be {sh.J} finite numbers >= 0 (m/s), one "
                         f"per clearance joint {list(sh.joints)}; got {vel!r}")
    return x, modes, vel


def _guess_of(sh, guess, settle: int):
    """(x, modes, impact velocities) to start Newton from."""
    from ..solve.linkage_model import Start

    if guess is None:
        flow = sh.guess_flow
        for k in range(settle):
            flow.advance((k + 1) * 2.0 * math.pi / sh.omega)
        m, v = sh.memory(flow.p)
        raw = flow.y[:sh.n2].copy(), m, v
        if settle == 0:
            return raw
        smooth = _smoothed_section(sh, flow, settle + 1)
        if smooth is None:
            return raw
        res = []
        for x, m_, v_ in (raw, smooth):
            try:
                xe, me, ve, ons, _ = sh.value(x, m_, v_)
            except RuntimeError:
                res.append(math.inf)
                continue
            res.append(float(np.max(np.abs((xe - x) / sh.scale[:sh.n2])))
                       if np.all(me == m_) else math.inf)
        return smooth if res[1] < res[0] else raw
    if isinstance(guess, PeriodicOrbit):
        return guess.state.copy(), guess.modes.copy(), guess.impact_velocities.copy()
    if isinstance(guess, Start):
        return _check_state(sh, guess.y, guess.modes, guess.impact_velocities)
    if isinstance(guess, (tuple, list)) and len(guess) == 3:
        return _check_state(sh, *guess)
    raise ValueError("guess must be None (a settled run), a PeriodicOrbit, a "
                     "linkage_model.Start or a tuple (state, modes, impact_velocities); got "
                     f"{type(guess).__name__}")


def _map_error(sh, x, modes, vel, idx) -> float:
    """Largest scaled difference of the map at (x, modes, vel) between its runs at the
    shooting's rtol and at rtol / 10 (an estimate of the map's integration error: the
    residual Newton can reach); nan where a run fails."""
    ends = []
    for rtol in (sh.rtol, sh.rtol / 10.0):
        one = _Shooter(sh.mech, len(sh.edges) - 1, rtol, sh.method, sh.edges[0])
        try:
            xe, _, ve, _, _ = one.value(x, modes, vel)
        except RuntimeError:
            return math.nan
        ends.append(np.concatenate([xe, ve])[idx] / sh.scale[idx])
    return float(np.max(np.abs(ends[0] - ends[1])))


def _smoothed_section(sh, flow, revolution: int):
    """The section state of the plain run `flow` at the end of `revolution`, smoothed: the
    value at the section of a polynomial (SMOOTH_DEGREE, Hann-weighted least squares)
    fitted per coordinate and rate to the run's states over SMOOTH_WINDOW of a revolution
    centred there; with the memory at the section. None where a contact mode or memory
    changes within the window (the state is not smooth there)."""
    T = 2.0 * math.pi / sh.omega
    t_c = revolution * T
    w = SMOOTH_WINDOW * T
    ts = np.linspace(t_c - 0.5 * w, t_c + 0.5 * w, SMOOTH_SAMPLES)
    try:
        flow.advance(ts[0])
        mem0 = sh.memory(flow.p)
        ys = []
        for t in ts:
            if t > flow.t:
                flow.advance(t)
            ys.append(flow.y[:sh.n2].copy())
    except RuntimeError:
        return None
    m, v = sh.memory(flow.p)
    if np.any(m != mem0[0]) or np.any(v != mem0[1]):
        return None
    tau = (ts - t_c) / w
    weight = np.sqrt(np.sin(math.pi * (tau + 0.5)) ** 2 + 1e-3)
    ys = np.array(ys) / sh.scale[:sh.n2]
    fit = np.polynomial.polynomial.polyfit(tau, ys, SMOOTH_DEGREE, w=weight)
    return fit[0] * sh.scale[:sh.n2], m, v


def periodic_orbit(mech, period: int = 1, guess=None, *, rtol: float | None = None,
                   tol: float = NEWTON_TOL, max_iterations: int = 12, settle: int = SETTLE,
                   method: str = "dop853", trajectory: bool = True) -> PeriodicOrbit:
    """The periodic orbit of `mech` (a SliderCrank or a Linkage) of `period` drive
    revolutions by Newton shooting on the state at the section t = 0 (the drive at its
    initial angle), its Jacobian the monodromy matrix of the variational run (module
    docstring); with the Floquet multipliers and the stability verdict.

    guess: None (the state after `settle` revolutions of a plain run from the centred
    start, or its smoothed value a revolution later where the map's residual is smaller
    there: the module docstring), a PeriodicOrbit (e.g. of a nearby design), a
    `linkage_model.Start`, or a tuple (state, modes, impact_velocities). rtol: of the
    shooting runs (default SHOOTING_RTOL); tol: Newton's tolerance on max |P(z) - z| in
    scaled units (fractions of the clearance; of clearance x speed for rates), to be above
    the map's integration error (the four-bar's: about 1e-4 at rtol 1e-10). trajectory:
    also run the orbit through `simulate` from the converged state
    (`PeriodicOrbit.trajectory`).

    Raises ValueError for bad input before any computation, RuntimeError where Newton does
    not converge within `max_iterations` (with what to try).
    """
    as_linkage(mech)                    # ValueError for anything else
    check_driven(mech)
    period = check_int("period (drive revolutions)", period, 1, 64)
    rtol = SHOOTING_RTOL if rtol is None else check_real("rtol", rtol, 1e-14, 1e-4)
    tol = check_real("tol (Newton tolerance, scaled)", tol, 0.0, 1e-1, low_open=True)
    max_iterations = check_int("max_iterations", max_iterations, 1, 200)
    settle = check_int("settle (revolutions of the default guess)", settle, 0, 100_000)
    sh = _Shooter(mech, period, rtol, method)
    x, modes, vel = _guess_of(sh, guess, settle)
    return _newton(sh, x, modes, vel, period, tol, max_iterations, trajectory)


def _newton(sh, x, modes, vel, period, tol, max_iterations, trajectory):
    n2, J = sh.n2, sh.J
    S = sh.scale
    history = []
    res = math.inf
    for it in range(1, max_iterations + 1):
        try:
            xe, me, ve, ons, _, M = sh.jacobian(x, modes, vel)
        except RuntimeError as exc:
            raise RuntimeError(f"periodic_orbit: {exc} (Newton iteration {it}); try a guess "
                               "from a settled run or a tighter rtol") from exc
        active = [j for j in range(J) if ons[j] > 0]
        idx = list(range(n2)) + [n2 + j for j in active]
        z = np.concatenate([x, vel[active]]) / S[idx]
        ze = np.concatenate([xe, ve[active]]) / S[idx]
        g = ze - z
        res = float(np.max(np.abs(g)))
        mode_change = bool(np.any(me != modes))
        A = M[np.ix_(idx, idx)]
        history.append(dict(residual=res, active=tuple(active), mode_change=mode_change,
                            multipliers=np.linalg.eigvals(A)))
        if res <= tol and not mode_change:
            break
        if mode_change:
            # the end's contact mode differs: restart from the end of the period
            x, modes, vel = xe, me, ve
            continue
        try:
            dz = np.linalg.solve(A - np.eye(len(idx)), -g)
        except np.linalg.LinAlgError as exc:
            raise RuntimeError("periodic_orbit: a multiplier is 1 (Newton's matrix is "
                               "singular): a fold of the orbit; try a nearby design or "
                               "continue_orbits") from exc
        # a step is at most MAX_STEP clearances (the orbit moves within the clearance)
        big = float(np.max(np.abs(dz)))
        if big > MAX_STEP:
            dz *= MAX_STEP / big
        # damped: halve a step whose map residual does not fall (the map is only piecewise
        # smooth, and strongly nonlinear where contact forces switch); the smallest step
        # is taken where none falls (an unstable orbit's neighbourhood can need it)
        lam = 1.0
        for _ in range(5):
            zn = z + lam * dz
            xn = zn[:n2] * S[:n2]
            vn = vel.copy()
            vn[active] = zn[n2:] * S[[n2 + j for j in active]]
            if not np.any(vn < 0.0):
                try:
                    xe2, me2, ve2, _, _ = sh.value(xn, modes, vn)
                except RuntimeError:
                    xe2 = None
                if xe2 is not None and not np.any(me2 != modes):
                    ze2 = np.concatenate([xe2, ve2[active]]) / S[idx]
                    if float(np.max(np.abs(ze2 - zn))) < res:
                        break
            if lam < 0.1:
                break
            lam *= 0.5
        if np.any(vn < 0.0):
            vn = np.maximum(vn, 0.0)
        history[-1]["damping"] = lam
        x, vel = xn, vn
    else:
        err = _map_error(sh, x, modes, vel, idx)
        floor = (f"; the map's own error there (its runs at rtol and rtol / 10 differ by "
                 f"{err:.2g}, scaled) is above tol: a larger tol or a tighter rtol"
                 if err > tol else "")
        raise RuntimeError(
            f"periodic_orbit: Newton did not converge in {max_iterations} iterations "
            f"(residual {res:.3g} > tol {tol:g}, scaled){floor}; try a guess from a settled "
            "run (settle=... more revolutions, or a Start / PeriodicOrbit of a nearby "
            "design), a different period, or a tighter rtol")
    mult = np.linalg.eigvals(A)
    mult = mult[np.argsort(-np.abs(mult), kind="stable")]
    names = tuple(sh.model.COORDINATES) + tuple(f"{c}_rate" for c in sh.model.COORDINATES)
    unknowns = names + tuple(f"{sh.joints[j]}.impact_velocity" for j in active)
    orbit = PeriodicOrbit(
        mech=sh.mech, period=period, state=x.copy(), modes=modes.copy(),
        impact_velocities=vel.copy(), multipliers=mult, monodromy=A, unknowns=unknowns,
        scale=S[idx].copy(), stability="stable" if np.max(np.abs(mult)) < 1.0 else "unstable",
        iterations=it, residual=res, onsets=ons, rtol=sh.rtol, history=history)
    if trajectory:
        from ..solve.simulate import simulate

        orbit.trajectory = simulate(as_linkage(sh.mech), period, rtol=sh.rtol,
                                    start=orbit.start())
    return orbit


# ------------------------------------------------------------- one step, from a run

#: a Newton step longer than this (scaled) does not confirm an orbit: the multipliers
#: describe the map only near the orbit
CHECK_MAX_STEP = 0.05


@dataclass
class OrbitCheck:
    """One Newton step of the `period`-revolution map from a run's state (`newton_check`):
    `confirmed` where it lands on a stable orbit; `reason` otherwise ("integration",
    "mode change", "unstable", "far", "residual"); the multipliers at the state, the
    step's length and the map's residual before and after it (scaled), and the runs'
    right-hand side evaluations."""

    confirmed: bool
    reason: str
    multipliers: np.ndarray
    step: float
    residual: float
    residual_after: float
    nfev: int
    #: the orbit's least period: the first revolution count dividing `period` after which
    #: the plain run from the step's end is back within `tol` (0: not checked)
    least_period: int = 0

    @property
    def spectral_radius(self) -> float:
        """Largest modulus of the multipliers (inf where none was computed)."""
        return float(np.max(np.abs(self.multipliers))) if len(self.multipliers) else math.inf


def newton_check(mech, t0: float, state, modes, impact_velocities, period: int = 1, *,
                 rtol: float = SHOOTING_RTOL, tol: float = 1e-4,
                 method: str = "dop853") -> OrbitCheck:
    """Is the state of a run at time `t0` (a section time: any, the drive repeats every
    revolution) near a stable periodic orbit of `period` revolutions? One Newton step
    with the monodromy matrix (the shooting's variational run from the state), then one
    plain run from the step's end: confirmed where every multiplier lies inside the
    unit circle, the step is at most CHECK_MAX_STEP (scaled) and the map's residual after
    it is at most `tol` and at most half the residual before it (or below NEWTON_TOL);
    `least_period` says whether the orbit repeats after fewer revolutions."""
    sh = _Shooter(mech, period, rtol, method, t0)
    x, modes, vel = _check_state(sh, state, modes, impact_velocities)
    n2, J = sh.n2, sh.J
    none = np.zeros(0, dtype=complex)

    def out(ok, reason, mu=none, step=math.nan, res=math.nan, res2=math.nan, least=0):
        return OrbitCheck(ok, reason, mu, step, res, res2, int(sh.counters[0]), least)

    try:
        xe, me, ve, ons, _, M = sh.jacobian(x, modes, vel)
    except RuntimeError:
        return out(False, "integration")
    if np.any(me != modes):
        return out(False, "mode change")
    active = [j for j in range(J) if ons[j] > 0]
    idx = list(range(n2)) + [n2 + j for j in active]
    S = sh.scale[idx]
    z = np.concatenate([x, vel[active]]) / S
    g = np.concatenate([xe, ve[active]]) / S - z
    A = M[np.ix_(idx, idx)]
    mu = np.linalg.eigvals(A)
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    res = float(np.max(np.abs(g)))
    if np.max(np.abs(mu)) >= 1.0:
        return out(False, "unstable", mu, res=res)
    dz = np.linalg.solve(A - np.eye(len(idx)), -g)
    step = float(np.max(np.abs(dz)))
    if step > CHECK_MAX_STEP:
        return out(False, "far", mu, step, res)
    zs = z + dz
    vs = vel.copy()
    vs[active] = zs[n2:] * S[n2:]
    if np.any(vs < 0.0):
        return out(False, "far", mu, step, res)
    # the plain run one revolution at a time: an orbit of `period` revolutions may repeat
    # sooner (a period-1 orbit is a fixed point of every iterate of the map)
    xe2, me2, ve2 = zs[:n2] * S[:n2], modes, vs
    least = period
    for r in range(period):
        one = _Shooter(mech, 1, rtol, method, t0 + r * 2.0 * math.pi / sh.omega)
        try:
            xe2, me2, ve2, _, _ = one.value(xe2, me2, ve2)
        except RuntimeError:
            return out(False, "integration", mu, step, res)
        finally:
            sh.counters += one.counters
        back = float(np.max(np.abs(np.concatenate([xe2, ve2[active]]) / S - zs)))
        if r + 1 < least and period % (r + 1) == 0 and back <= tol and \
                np.all(me2 == modes):
            least = r + 1
    res2 = back
    if np.any(me2 != modes) or res2 > tol or res2 > max(0.5 * res, NEWTON_TOL):
        return out(False, "residual", mu, step, res, res2)
    return out(True, "", mu, step, res, res2, least)


# ------------------------------------------------------------------------ continuation

#: kinds of the detected points of a branch
POINT_KINDS = ("fold", "period_doubling", "neimark_sacker", "grazing")

#: a located fold with no multiplier within this distance of +1 is marked non-smooth
FOLD_MU_TOL = 0.05


@dataclass
class BranchPoint:
    """A detected point of a branch: `kind` (POINT_KINDS), the field's value located to
    +- `tolerance` (bisection on the arclength), the multipliers there, a note, and `index`:
    the branch's orbit after which it lies."""

    kind: str
    value: float
    tolerance: float
    multipliers: np.ndarray
    note: str = ""
    index: int = -1
    #: the located orbit's scaled unknowns (state, memories, field) and, at a period
    #: doubling, the eigenvector of the multiplier -1 in them: `switch_branch` starts there
    w: np.ndarray | None = field(default=None, repr=False)
    eigenvector: np.ndarray | None = field(default=None, repr=False)
    tangent: np.ndarray | None = field(default=None, repr=False)


@dataclass
class Branch:
    """A branch of periodic orbits over `field`: per computed point the field's `values`,
    the section `states` (n, 2 N_Q), the impact velocities (n, J), the `multipliers` (n,
    padded with NaN where the memory unknowns differ), `stable` (n,), the contact onsets
    per period (n, J), the section of each clearance joint (n, J, 4: eccentricity x, y in
    m and its rates in m/s, as `poincare.Flow.section`), and the detected `points`;
    `stopped` says why it ended."""

    field: str
    values: np.ndarray
    states: np.ndarray
    impact_velocities: np.ndarray
    multipliers: np.ndarray
    stable: np.ndarray
    onsets: np.ndarray
    points: list
    stopped: str
    period: int = 1
    sections: np.ndarray | None = None
    clearances: np.ndarray | None = None
    counters: dict = field(default_factory=dict)
    #: what `switch_branch` needs to go on from a point of this branch
    setup: dict = field(default_factory=dict, repr=False)

    def summary(self) -> str:
        """The branch in words: its range, stable points and detected points."""
        lines = [f"branch over {self.field}: {len(self.values)} orbits of period "
                 f"{self.period}, {self.values[0]:.6g} to {self.values[-1]:.6g} "
                 f"({int(np.sum(self.stable))} stable); stopped: {self.stopped}"]
        for p in self.points:
            lines.append(f"  {p.kind} at {self.field} = {p.value:.8g} +- {p.tolerance:.2g}"
                         f" (largest multipliers {_format_mu(p.multipliers[:2])})"
                         + (f"; {p.note}" if p.note else ""))
        return "\n".join(lines)


def _format_mu(mu) -> str:
    return ", ".join(f"{m.real:.4g}{m.imag:+.3g}j" if abs(m.imag) > 1e-12 else f"{m.real:.4g}"
                     for m in np.asarray(mu))


def field_value(mech, name: str) -> float:
    """The value of sweep field `name` on `mech` (`design.design_at`'s names)."""
    return value_at(mech, name)


def with_field(mech, name: str, value: float):
    """`mech` with field `name` set to `value` (`design.design_at`)."""
    return design_at(mech, {name: float(value)})


class _Continuation:
    """The extended system of pseudo-arclength continuation in u (the field, or its
    logarithm), scaled: unknowns w = (z, u) with z the state and every joint's impact
    velocity over the start's scales S0, u over `span`."""

    def __init__(self, mech, name, period, rtol, method, log, span, u0):
        self.mech0, self.name, self.period = mech, name, period
        self.rtol, self.method, self.log = rtol, method, log
        self.span, self.u0 = span, u0
        self.sh0 = _Shooter(mech, period, rtol, method)
        self.S0 = self.sh0.scale
        self.n2, self.J = self.sh0.n2, self.sh0.J
        self.cache = {}
        self.runs = 0
        self.plain_runs = 0
        #: fold candidates bisection did not confirm (field value, half width)
        self.unconfirmed = []

    def value_of(self, uu):
        u = self.u0 + uu * self.span
        return math.exp(u) if self.log else u

    def shooter(self, uu):
        key = float(uu)
        if key not in self.cache:
            if len(self.cache) > 8:
                self.cache.clear()
            try:
                mech = with_field(self.mech0, self.name, self.value_of(uu))
            except (ValueError, OverflowError) as exc:
                # a corrector's iterate that left the field's range: a failed step (the
                # corrector halves it), not a failed continuation
                raise RuntimeError(f"iterate outside the range of {self.name}: {exc}") from exc
            self.cache[key] = _Shooter(mech, self.period, self.rtol, self.method)
        return self.cache[key]

    def residual(self, w, modes, held, jac=True):
        """G(w) (n,), its Jacobian (n, n + 1) and the point's (A, active, onsets, end
        modes); `held`: the memories of the joints with no onset."""
        n2, J, S0 = self.n2, self.J, self.S0
        z, uu = w[:-1], w[-1]
        x, vel = z[:n2] * S0[:n2], z[n2:] * S0[n2:]
        sh = self.shooter(uu)
        xe, me, ve, ons, _, M = sh.jacobian(x, modes, vel)
        self.runs += 1
        ze = np.concatenate([xe, ve]) / S0
        g = ze - z
        active = [j for j in range(J) if ons[j] > 0]
        D = sh.scale / S0
        Mf = D[:, None] * M / D[None, :]
        jz = Mf - np.eye(n2 + J)
        for j in range(J):
            if j not in active:
                # a memory no onset overwrites: held at its value (a parameter of the branch)
                g[n2 + j] = z[n2 + j] - held[j] / S0[n2 + j]
                jz[n2 + j] = 0.0
                jz[n2 + j, n2 + j] = 1.0
        gu = None
        if jac:
            # the field's derivative: central differences of the map (two plain runs)
            h = 1e-4
            outs = []
            for sgn in (1.0, -1.0):
                shp = self.shooter(uu + sgn * h)
                xe2, _, ve2, _, _ = shp.value(x, modes, vel)
                outs.append(np.concatenate([xe2, ve2]) / S0)
            gu = (outs[0] - outs[1]) / (2 * h)
            for j in range(J):
                if j not in active:
                    gu[n2 + j] = 0.0
        idx = list(range(n2)) + [n2 + j for j in active]
        A = Mf[np.ix_(idx, idx)]
        return g, (np.hstack([jz, gu[:, None]]) if jac else jz), A, active, ons, me

    def value(self, w, modes, held):
        """G(w) from one plain run (no Jacobian), the onsets and end modes."""
        n2, J, S0 = self.n2, self.J, self.S0
        z, uu = w[:-1], w[-1]
        sh = self.shooter(uu)
        xe, me, ve, ons, _ = sh.value(z[:n2] * S0[:n2], modes, z[n2:] * S0[n2:])
        self.plain_runs += 1
        g = np.concatenate([xe, ve]) / S0 - z
        for j in range(J):
            if ons[j] == 0:
                g[n2 + j] = z[n2 + j] - held[j] / S0[n2 + j]
        return g, ons, me

    def correct(self, w_pred, w_base, tangent, ds, modes, held, tol, max_it=8, Jg=None):
        """Newton on G = 0 and tangent . (w - w_base) = ds from w_pred; returns (w, info)
        or None where it does not converge. With `Jg`, the Jacobian of a nearby point, a
        chord method: `Jg` is held (plain runs only) while the residual falls by half per
        iteration and recomputed at the iterate where it does not, and one run with the
        monodromy matrix at the converged point gives its multipliers; info["jacobians"]
        counts the recomputations."""
        hold = Jg is not None
        w = w_pred.copy()
        last = math.inf
        fresh = 0
        for it in range(1, max_it + 1):
            try:
                if hold:
                    g, ons, me = self.value(w, modes, held)
                else:
                    g, Jg, A, active, ons, me = self.residual(w, modes, held)
            except RuntimeError:
                return None
            if np.any(me != modes):
                return None
            res = float(np.max(np.abs(g)))
            arc = float(tangent @ (w - w_base) - ds)
            try:
                if res <= tol and abs(arc) <= tol:
                    if hold:
                        _, Jg, A, active, ons, me = self.residual(w, modes, held)
                    return w, dict(A=A, active=active, onsets=ons, J=Jg, iterations=it,
                                   residual=res, jacobians=fresh)
                if hold and max(res, abs(arc)) > 0.5 * last:
                    # the held Jacobian no longer contracts: Newton's own at this iterate
                    g, Jg, *_ = self.residual(w, modes, held)
                    fresh += 1
                    if fresh > 3:
                        return None
            except RuntimeError:
                return None
            last = max(res, abs(arc))
            try:
                dw = np.linalg.solve(np.vstack([Jg, tangent[None, :]]),
                                     -np.concatenate([g, [arc]]))
            except np.linalg.LinAlgError:
                return None
            w = w + dw
            if not np.all(np.isfinite(w)) or np.any(w[self.n2:-1] < 0.0):
                return None
        return None


def _tangent_of(Jg, previous, orientation=None):
    """The unit null vector of the Jacobian Jg (n, n + 1), oriented along `previous`, or,
    with `orientation` (+-1), so that det([Jg; t]) has that sign: that sign is the sign
    of det(M - I) t_u, so the field's component t_u changes sign exactly where det(M - I)
    does (a fold), not where the branch turns by more than a right angle in the state
    over one step (where orienting along `previous` flips it)."""
    n = Jg.shape[0]
    rhs = np.zeros(n + 1)
    rhs[-1] = 1.0
    try:
        t = np.linalg.solve(np.vstack([Jg, previous[None, :]]), rhs)
    except np.linalg.LinAlgError:
        t = np.linalg.svd(Jg)[2][-1]
    t /= np.linalg.norm(t)
    if orientation is not None:
        return t if _orientation(Jg, t) == orientation else -t
    return t if t @ previous >= 0 else -t


def _orientation(Jg, t) -> float:
    """The sign of det([Jg; t]) (the branch's orientation, constant along it)."""
    return 1.0 if np.linalg.det(np.vstack([Jg, t[None, :]])) >= 0.0 else -1.0


def _tests(A):
    """Test functions of a point: det(A - I) (fold), det(A + I) (period doubling), the
    product of mu_i mu_j - 1 over pairs (Neimark-Sacker)."""
    mu = np.linalg.eigvals(A)
    ns = 1.0 + 0j
    for i in range(len(mu)):
        for j in range(i + 1, len(mu)):
            ns *= mu[i] * mu[j] - 1.0
    n = len(mu)
    return (float(np.real(np.linalg.det(A - np.eye(n)))),
            float(np.real(np.linalg.det(A + np.eye(n)))), float(np.real(ns)), mu)


def continue_orbits(mech, field_name: str, start: float, stop: float, *, period: int = 1,
                    guess=None, step: float = 0.1, min_step: float = 1e-5,
                    max_step: float = 3.0, max_points: int = 200, log: bool | None = None,
                    rtol: float | None = None, tol: float = NEWTON_TOL,
                    locate_tol: float = 1e-4, settle: int = SETTLE, method: str = "dop853",
                    stop_at_first: bool = False, progress=None) -> Branch:
    """Pseudo-arclength continuation of a periodic orbit of `mech` in `field_name` (a sweep
    field: "clearance", "crank_speed", a SliderCrank field, a case override or a dotted
    field of a Linkage; `design.design_at`) from `start` to `stop`.

    The orbit at `start` is found by `periodic_orbit` (from `guess`, or a settled run).
    Steps are in the arclength of (scaled state, u) with u the field (log: its logarithm;
    default for clearances and for ranges over a factor 10 or more) over |u(stop) -
    u(start)|; `step` the first, adapted between `min_step` and `max_step`. The memory of a
    joint with no contact onset per period is held at the start orbit's value along the
    branch (module docstring). Detected between consecutive points and located by
    bisection on the arclength to `locate_tol` of the scaled field: folds (det(M - I)
    changes sign), period doublings (det(M + I)), Neimark-Sacker points (a complex pair
    crosses the unit circle) and grazing (the contact onsets per period change). Stops at
    `stop`, after `max_points`, where the step falls below `min_step`, or (with
    `stop_at_first`) at the first detected point.
    """
    as_linkage(mech)                    # ValueError for anything else
    check_driven(mech)
    if not isinstance(field_name, str):
        raise ValueError(f"field must be a field name (str); got {field_name!r}")
    start = check_real("start", start)
    stop = check_real("stop", stop)
    if start == stop:
        raise ValueError(f"start and stop must differ; got {start!r} twice")
    field_value(mech, field_name)           # ValueError for an unknown name
    m0 = with_field(mech, field_name, start)
    with_field(mech, field_name, stop)      # ValueError for a value out of range
    period = check_int("period (drive revolutions)", period, 1, 64)
    step = check_real("step", step, 0.0, 100.0, low_open=True)
    min_step = check_real("min_step", min_step, 0.0, step, low_open=True)
    max_step = check_real("max_step", max_step, step, 100.0)
    max_points = check_int("max_points", max_points, 2, 100_000)
    locate_tol = check_real("locate_tol", locate_tol, 0.0, 0.1, low_open=True)
    tol = check_real("tol (Newton tolerance, scaled)", tol, 0.0, 1e-1, low_open=True)
    rtol = SHOOTING_RTOL if rtol is None else check_real("rtol", rtol, 1e-14, 1e-4)
    if log is None:
        log = (field_name.endswith("clearance") or max(abs(start), abs(stop))
               >= 10 * min(abs(start), abs(stop)) > 0.0) and start > 0.0 and stop > 0.0
    if log and (start <= 0.0 or stop <= 0.0):
        raise ValueError(f"log continuation needs start and stop > 0; got {start!r}, "
                         f"{stop!r}")
    u0 = math.log(start) if log else start
    span = (math.log(stop) if log else stop) - u0
    orbit = periodic_orbit(m0, period, guess, rtol=rtol, tol=tol, settle=settle,
                           method=method, trajectory=False)
    con = _Continuation(mech, field_name, period, rtol, method, log, span, u0)
    held = orbit.impact_velocities.copy()
    modes = orbit.modes.copy()
    w = np.concatenate([np.concatenate([orbit.state, held]) / con.S0, [0.0]])
    g, Jg, A, active, ons, _ = con.residual(w, modes, held)
    t = _tangent_of(Jg, np.concatenate([np.zeros(len(w) - 1), [1.0]]))
    pts = [dict(w=w, A=A, active=active, onsets=ons, t=t, tests=_tests(A), J=Jg,
                o=_orientation(Jg, t))]
    steps = dict(step=step, min_step=min_step, max_step=max_step, max_points=max_points,
                 tol=tol, locate_tol=locate_tol, stop_at_first=stop_at_first)
    found, stopped = _follow(con, pts, modes, held, progress=progress, **steps)
    setup = dict(mech=mech, log=log, span=span, u0=u0, rtol=rtol, method=method,
                 modes=modes, held=held, steps=steps)
    return _branch_of(con, pts, found, stopped, setup)


def _follow(con, pts, modes, held, *, step, min_step, max_step, max_points, tol,
            locate_tol, stop_at_first, progress=None):
    """Pseudo-arclength steps from the last of `pts` (appended to it): (the detected
    points, why it stopped). A step's corrector holds the last point's Jacobian (chord),
    and takes Newton's with the Jacobian recomputed where that does not converge."""
    found: list[BranchPoint] = []
    ds = step
    stopped = "max_points"
    while len(pts) < max_points:
        cur = pts[-1]
        pred = cur["w"] + ds * cur["t"]
        new = con.correct(pred, cur["w"], cur["t"], ds, modes, held, tol, max_it=10,
                          Jg=cur["J"])
        if new is None:
            ds /= 2.0
            if ds < min_step:
                stopped = "step below min_step (no convergence: a fold of the map's " \
                          "smoothness, a grazing contact or a mode change)"
                break
            continue
        wn, info = new
        tn = _tangent_of(info["J"], cur["t"], cur["o"])
        pt = dict(w=wn, A=info["A"], active=info["active"], onsets=info["onsets"], t=tn,
                  tests=_tests(info["A"]), ds=ds, J=info["J"], o=cur["o"])
        kinds = _crossings(cur, pt)
        pts.append(pt)
        for kind in list(kinds):
            point = _locate(con, cur, pt, kind, modes, held, tol, locate_tol)
            if point is None:
                kinds.remove(kind)
                continue
            point.index = len(pts) - 2
            found.append(point)
        if progress is not None:
            progress(len(pts), con.value_of(wn[-1]))
        # converged in few plain runs on the last point's Jacobian: the branch is nearly
        # straight over the step, so a longer one will do
        if info["iterations"] <= 6 and info["jacobians"] == 0:
            ds = min(ds * 1.5, max_step)
        elif info["jacobians"] >= 2:
            ds = max(ds / 2.0, min_step)
        if wn[-1] >= 1.0:
            stopped = "reached stop"
            break
        if wn[-1] < -0.5:
            stopped = "turned back past start"
            break
        if stop_at_first and kinds:
            stopped = f"first detected point ({kinds[0]})"
            break
    return found, stopped


def _branch_of(con, pts, found, stopped, setup) -> Branch:
    """The Branch of the computed points `pts` of continuation `con`."""
    n2 = con.n2
    nmu = max(len(p["tests"][3]) for p in pts)
    mults = np.full((len(pts), nmu), np.nan + 0j)
    for i, p in enumerate(pts):
        mu = p["tests"][3]
        mults[i, :len(mu)] = mu[np.argsort(-np.abs(mu), kind="stable")]
    W = np.array([p["w"] for p in pts])
    states = W[:, :n2] * con.S0[:n2]
    sections, clear = [], []
    for w_, x in zip(W, states):
        sh = con.shooter(w_[-1])
        sections.append([g(0.0, np.concatenate([x, np.zeros(sh.n_state - n2)]), sh.p0)
                         for g in sh.guess_flow._gaps])
        clear.append(clearances_of(sh.mech))
    return Branch(field=con.name, values=np.array([con.value_of(u) for u in W[:, -1]]),
                  states=states, impact_velocities=W[:, n2:-1] * con.S0[n2:],
                  multipliers=mults,
                  stable=np.array([np.max(np.abs(p["tests"][3])) < 1.0 for p in pts]),
                  onsets=np.array([p["onsets"] for p in pts]), points=found, stopped=stopped,
                  period=con.period, sections=np.array(sections, dtype=float),
                  clearances=np.array(clear),
                  counters=dict(shooting_runs=con.runs, plain_runs=con.plain_runs,
                                speed=con.sh0.omega,
                                unconfirmed_folds=len(con.unconfirmed)),
                  setup=setup)


def switch_branch(branch: Branch, point: BranchPoint, *, step: float = 0.01,
                  max_points: int = 50, stop_at_first: bool = False,
                  progress=None) -> Branch:
    """The branch of period 2 x `branch.period` born at the period doubling `point` of
    `branch` (`continue_orbits`), followed by pseudo-arclength continuation in the same
    field and scaled units, up to the same stop.

    Its first orbit is found on the doubled map from the located orbit moved by `step`
    (scaled) along the eigenvector of the multiplier -1, the arclength condition taken
    across the old branch (the old branch is a fixed point of the doubled map too); then
    as `continue_orbits`, with `max_points` orbits at most. ValueError if `point` is not
    a period doubling of `branch`."""
    if not isinstance(branch, Branch) or not branch.setup:
        raise ValueError("branch must be a Branch returned by continue_orbits")
    if not isinstance(point, BranchPoint) or point.kind != "period_doubling" or \
            point.eigenvector is None or all(point is not q for q in branch.points):
        raise ValueError("point must be one of the branch's period doublings "
                         "(branch.points, kind 'period_doubling')")
    step = check_real("step", step, 0.0, 1.0, low_open=True)
    max_points = check_int("max_points", max_points, 2, 100_000)
    st = branch.setup
    steps = dict(st["steps"], max_points=max_points, stop_at_first=stop_at_first)
    con = _Continuation(st["mech"], branch.field, 2 * branch.period, st["rtol"],
                        st["method"], st["log"], st["span"], st["u0"])
    modes, held, tol = st["modes"], st["held"], steps["tol"]
    w0, v = point.w, point.eigenvector
    # across the old branch (a branch of fixed points of the doubled map too): the
    # arclength condition then meets it only far away
    t0 = v - (v @ point.tangent) * point.tangent
    t0 = t0 / np.linalg.norm(t0)
    new = None
    ds = step
    while new is None and ds >= steps["min_step"]:
        new = con.correct(w0 + ds * t0, w0, t0, ds, modes, held, tol, max_it=12)
        # where the old branch bends fast the corrector can slide back onto it: the two
        # halves of a doubled orbit lie about 2 ds apart, an old orbit's coincide
        if new is not None and _half_apart(con, new[0], modes, branch.period) < ds / 2:
            new = None
        if new is None:
            ds /= 2.0
    if new is None:
        raise RuntimeError("switch_branch: no orbit of the doubled period found near the "
                           "period doubling; try a smaller step or a tighter locate_tol")
    w1, info = new
    t1 = _tangent_of(info["J"], t0)
    pts = [dict(w=w1, A=info["A"], active=info["active"], onsets=info["onsets"], t=t1,
                tests=_tests(info["A"]), J=info["J"], o=_orientation(info["J"], t1))]
    found, stopped = _follow(con, pts, modes, held, progress=progress,
                             **dict(steps, step=max(ds, steps["min_step"])))
    return _branch_of(con, pts, found, stopped, dict(st, steps=steps))


def _half_apart(con, w, modes, period) -> float:
    """Scaled distance between the orbit w of the doubled map and its image under the
    map of `period` revolutions (0 for an orbit of that period)."""
    n2, S0 = con.n2, con.S0
    sh = _Shooter(with_field(con.mech0, con.name, con.value_of(w[-1])), period, con.rtol,
                  con.method)
    z = w[:-1]
    try:
        xe, _, _, _, _ = sh.value(z[:n2] * S0[:n2], modes, z[n2:] * S0[n2:])
    except RuntimeError:
        return 0.0
    con.plain_runs += 1
    return float(np.max(np.abs(xe / S0[:n2] - z[:n2])))


def _crossings(a, b) -> list:
    """The kinds of points between two consecutive points a, b of a branch."""
    kinds = []
    if not np.array_equal(a["onsets"], b["onsets"]):
        kinds.append("grazing")
        return kinds       # the smooth test functions jump with the active memories
    fa, pa, na, mua = a["tests"]
    fb, pb, nb_, mub = b["tests"]
    # with the tangent oriented by det([Jg; t]) its field component turns exactly where
    # det(M - I) changes sign: one test
    if fa * fb < 0.0:
        kinds.append("fold")
    if pa * pb < 0.0:
        kinds.append("period_doubling")

    def outside_pairs(mu):
        return int(np.sum((np.abs(mu) > 1.0) & (np.abs(mu.imag) > 1e-12)))

    if na * nb_ < 0.0 and outside_pairs(mua) != outside_pairs(mub):
        kinds.append("neimark_sacker")
    return kinds


def _test_value(kind, pt):
    if kind == "grazing":
        return None
    f, p, n, _ = pt["tests"]
    return {"fold": f, "period_doubling": p, "neimark_sacker": n}[kind]


def _locate(con, a, b, kind, modes, held, tol, locate_tol) -> BranchPoint:
    """Bisection on the arclength between points a and b for a sign change of `kind`'s
    test function (grazing: a change of the onsets per period) to `locate_tol` of the
    scaled field."""
    lo, hi = 0.0, float(b["ds"])
    side_a = _test_value(kind, a)
    ua, ub = a["w"][-1], b["w"][-1]
    last = a
    for _ in range(40):
        if abs(ub - ua) <= locate_tol:
            break
        mid = 0.5 * (lo + hi)
        new = con.correct(a["w"] + mid * a["t"], a["w"], a["t"], mid, modes, held, tol)
        if new is None:
            break
        wm, info = new
        pm = dict(w=wm, onsets=info["onsets"], tests=_tests(info["A"]),
                  t=_tangent_of(info["J"], a["t"], a["o"]), A=info["A"],
                  active=info["active"])
        if kind == "grazing":
            same = np.array_equal(pm["onsets"], a["onsets"])
        else:
            same = _test_value(kind, pm) * side_a > 0.0
        if same:
            lo, ua, last = mid, wm[-1], pm
        else:
            hi, ub = mid, wm[-1]
    value = 0.5 * (con.value_of(ua) + con.value_of(ub))
    half = 0.5 * abs(con.value_of(ub) - con.value_of(ua))
    mu = last["tests"][3]
    note = ""
    if kind == "grazing":
        note = f"onsets per period {list(a['onsets'])} -> {list(b['onsets'])}"
    if kind == "fold" and np.min(np.abs(mu - 1.0)) > FOLD_MU_TOL:
        note = ("no multiplier at +1: the map's smoothness changes at this fold (e.g. a "
                "contact force reaching zero within a contact phase)")
    if hi - lo > 0.0 and abs(ub - ua) > locate_tol:
        if kind == "fold":
            # unconfirmed: det(M - I) changed sign over a step the corrector cannot
            # bisect, no evidence of a multiplier through +1
            con.unconfirmed.append((value, half))
            return None
        note += ("; " if note else "") + "bisection stopped (corrector did not converge)"
    vec = None
    if kind == "period_doubling":
        w_, V = np.linalg.eig(last["A"])
        k = int(np.argmin(np.abs(w_ + 1.0)))
        idx = list(range(con.n2)) + [con.n2 + j for j in last["active"]]
        vec = np.zeros(len(a["w"]))
        vec[idx] = np.real(V[:, k])
        vec /= np.linalg.norm(vec)
    return BranchPoint(kind=kind, value=value, tolerance=half,
                       multipliers=mu[np.argsort(-np.abs(mu), kind="stable")], note=note,
                       w=last["w"].copy(), eigenvector=vec, tangent=last["t"].copy())
