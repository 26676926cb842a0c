"""The glue between a `Linkage` and its generated model: parameters, initial state, run.

`pack_parameters(linkage)` fills the generated module's parameter vector from the
description (by the module's PARAMETERS names, no index arithmetic) and computes its
constants; `initial_state(linkage)` solves the loop closure of the clearance joints (journals
centred) by Newton from the description's assembly guesses and the velocities from the
velocity constraints.
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from .._warnings import AccuracyWarning
from ..elements.registry import ELEMENTS
from ..laws.forces import CONTACT_MODELS
from ..model.linkage import GROUND, Linkage
from .diagnostics import contact_flags, floored_impacts
from .problem import ModelLayout, Problem, Span
from .settings import DEFAULT_MAX_STEPS, DEFAULT_RTOL, MAX_SAMPLES, RunSettings  # noqa: F401

__all__ = ["parameter_values", "pack_parameters", "initial_state", "Start", "settled_start"]


def load_model(linkage: Linkage, specialise: bool = True):
    """The model of a run of `linkage` (plain, DDM or tangent), specialised on its
    zero-valued geometric parameters (or, `specialise=False`, the general one): the
    compiled C model (`generate.c_loader.CModel`)."""
    from .kernels import c_model

    return c_model(linkage, specialise)


def specialisable(linkage: Linkage, names) -> bool:
    """Whether runs differentiated along the parameters `names` (dotted) may use the model
    specialised on `linkage`'s zero-valued geometric parameters: none of them is one."""
    from ..generate.key import geometric_zeros

    return not set(names) & set(geometric_zeros(linkage))


def parameter_values(linkage: Linkage) -> dict[str, float]:
    """Values of the generated model's parameters (its PARAMETERS names) for `linkage`; the
    memory of each clearance joint starts in free flight with the impact-velocity floor."""
    values: dict[str, float] = {}
    for b in linkage.bodies:
        values[f"{b.name}.mass"] = b.mass
        values[f"{b.name}.inertia"] = b.inertia
        for pt, (x, y) in b.points.items():
            values[f"{b.name}.{pt}.x"] = x
            values[f"{b.name}.{pt}.y"] = y
    for pt, (x, y) in linkage.ground_points.items():
        values[f"{GROUND}.{pt}.x"] = x
        values[f"{GROUND}.{pt}.y"] = y
    for j in linkage.joints:
        if hasattr(j, "angle"):
            values[f"{j.name}.angle"] = j.angle
    for el in ELEMENTS:
        values.update(el.parameter_values(linkage))
    if linkage.drive is not None:
        values["drive.speed"] = linkage.drive.speed
        values["drive.initial_angle"] = linkage.drive.initial_angle
    values["gravity"] = linkage.gravity
    return values


def pack_parameters(linkage: Linkage, model=None) -> np.ndarray:
    """The parameter vector p (N_P,) of `linkage`'s generated model, constants computed."""
    model = load_model(linkage) if model is None else model
    values = parameter_values(linkage)
    p = np.zeros(model.N_P)
    for i, name in enumerate(model.PARAMETERS):
        p[i] = values[name]
    for name in getattr(model, "ZERO_PARAMETERS", ()):
        if values[name] != 0.0:
            raise ValueError(f"{name} = {values[name]!r}: the model "
                             f"{getattr(model, '__name__', 'of ' + repr(linkage.name))} "
                             "is specialised on it being 0; load the general one "
                             "(mbs_clearance.generate.load_model(linkage, specialise=False))")
    if getattr(model, "PROFILE_OFFSETS", ()):
        from ..generate.profiles import fill_profiles

        fill_profiles(linkage, model, p)
    model.prepare(p)
    return p


def initial_state(linkage: Linkage, model=None, p=None, t0: float = 0.0, tol: float = 1e-14,
                  max_iter: int = 50) -> np.ndarray:
    """State y0 (N_STATE,) with every journal centred in its bearing: the coordinates solve
    the loop closure (closure(t0, q, p) = 0) by Newton's method from the description's
    assembly guesses (0 for coordinates without one; least squares if the closure is not
    square), the rates the velocity constraints closure_jacobian qdot = -closure_rate;
    W = 0 (and the friction work). A free linkage holds the coordinates and rates its
    `Initial` gives and solves only the others (the given coordinates first, over the
    assembly guesses). Raises ValueError if Newton does not converge (no assembly near the
    guesses)."""
    model = load_model(linkage) if model is None else model
    p = pack_parameters(linkage, model) if p is None else p
    coords = list(model.COORDINATES)
    given_q, given_u = ({}, {}) if linkage.drive is not None else (
        linkage.start.coordinates, linkage.start.rates)
    q = np.array([given_q.get(c, linkage.assembly.get(c, 0.0)) for c in coords])
    solve_q = np.array([c not in given_q for c in coords])
    scale = max(linkage.length_scale, 1e-300)
    every = bool(solve_q.all())
    for _ in range(max_iter):
        res = model.closure(t0, q, p)
        if not solve_q.any():
            break
        jac = model.closure_jacobian(t0, q, p)
        if every:
            q = q + np.linalg.lstsq(jac, -res, rcond=None)[0]
        else:
            q[solve_q] += np.linalg.lstsq(jac[:, solve_q], -res, rcond=None)[0]
        if np.max(np.abs(model.closure(t0, q, p))) <= tol * scale:
            break
    else:
        raise ValueError(
            f"the loop closure of linkage {linkage.name!r} did not converge from the assembly "
            f"guesses {dict(linkage.assembly)} (residual "
            f"{np.max(np.abs(model.closure(t0, q, p))):.3g} m): give guesses (Linkage."
            f"assembly, by coordinate name {list(model.COORDINATES)}) near an assembly")
    if given_q and np.max(np.abs(model.closure(t0, q, p))) > 1e-9 * scale:
        raise ValueError(
            f"the initial coordinates {dict(given_q)} of linkage {linkage.name!r} leave a "
            f"journal off its bearing's centre by {np.max(np.abs(model.closure(t0, q, p))):.3g}"
            f" m (the start is centred): give fewer coordinates, or ones of an assembly")
    jac = model.closure_jacobian(t0, q, p)
    if linkage.drive is not None:
        qd = np.linalg.lstsq(jac, -model.closure_rate(t0, q, p), rcond=None)[0]
        return np.concatenate([q, qd, np.zeros(model.N_STATE - 2 * len(q))])
    qd = np.array([given_u.get(c, 0.0) for c in coords])
    solve_u = np.array([c not in given_u for c in coords])
    rhs = -model.closure_rate(t0, q, p) - jac[:, ~solve_u] @ qd[~solve_u]
    if solve_u.any():
        qd[solve_u] = np.linalg.lstsq(jac[:, solve_u], rhs, rcond=None)[0]
    return np.concatenate([q, qd, np.zeros(model.N_STATE - 2 * len(q))])


# ---------------------------------------------------------------------------- starts

class Start(NamedTuple):
    """A state of a linkage to start a run from instead of the centred assembly, e.g. on
    its periodic orbit (`settled_start`), so that a run, its sensitivities and an Exudyn
    run of the same description skip the start's settling impacts.

    A start is taken a whole number of drive revolutions after the centred start: there the
    drive is back at its initial angle, and the equations repeat with the drive, so a run
    from it at t = 0 continues the run it was taken from. A run from a start holds the
    start fixed: its sensitivities start at zero (the state and the memories do not move
    with the parameters), as do finite differences of runs from the same start.
    """

    #: the generated model's coordinates and their rates (2 N_Q,), in SI units and rad
    y: np.ndarray
    #: per clearance joint: 1.0 in contact, 0.0 in free flight
    modes: np.ndarray
    #: per clearance joint: the stored impact velocity in m/s (the contact law's memory)
    impact_velocities: np.ndarray
    #: drive revolutions after the centred start at which the state was taken
    revolutions: int
    #: the linkage's name (a start is refused by a linkage of another structure)
    linkage: str


def settled_start(linkage: Linkage, revolutions: int, *, rtol: float | None = None,
                  method: str = "dopri5", progress=None) -> Start:
    """The `Start` after `revolutions` drive revolutions from the centred start, when the
    start's impacts and the weakly damped sliding mode of a frictionless joint have settled
    (the four-bar's default needs about 100, docs/cases.md). The revolutions run one at a
    time, each from the previous one's end, so the memory holds one revolution's record.
    `progress`: a callable called with the number of revolutions done. The paper's
    `SliderCrank` settles as its description (`cases.door`)."""
    from .._checks import check_int
    from ..model.cases import as_linkage

    linkage = as_linkage(linkage)
    revolutions = check_int("revolutions", revolutions, 1)
    start = None
    for k in range(revolutions):
        model, ts, ys, ms = run(linkage, 1, rtol=rtol, method=method, start=start)[:4]
        n2, nj = 2 * model.N_Q, model.N_EVENTS
        start = Start(y=ys[-1, :n2].copy(), modes=ms[-1, 0:2 * nj:2].copy(),
                      impact_velocities=ms[-1, 1:2 * nj:2].copy(), revolutions=k + 1,
                      linkage=linkage.name)
        if progress is not None:
            progress(k + 1)
    return start


def check_start(linkage: Linkage, model, p, start, event_tol: float) -> np.ndarray:
    """Validate `start` for `linkage` (ValueError naming what is wrong), store its memories
    in p and return the state y0 (N_STATE,) it gives (works zero)."""
    if not isinstance(start, Start):
        raise ValueError(f"start must be a Start (from linkage_model.settled_start); "
                         f"got {type(start).__name__}")
    if start.linkage != linkage.name:
        raise ValueError(f"start was taken of linkage {start.linkage!r}, not of "
                         f"{linkage.name!r}")
    y = np.asarray(start.y, dtype=float)
    modes = np.asarray(start.modes, dtype=float)
    dmin = np.asarray(start.impact_velocities, dtype=float)
    n2, nj = 2 * model.N_Q, model.N_EVENTS
    if y.shape != (n2,) or modes.shape != (nj,) or dmin.shape != (nj,):
        raise ValueError(f"start of linkage {linkage.name!r} must hold {n2} coordinates and "
                         f"rates ({list(model.COORDINATES)}) and {nj} modes and impact "
                         f"velocities; got {y.shape}, {modes.shape}, {dmin.shape}")
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(dmin))):
        raise ValueError("start holds a value that is not finite")
    # an element's contact's floor is its joint's (contacts in the model's event order)
    owners = [joint.name for _, joint in linkage.contacts()]
    for j, name in enumerate(model.JOINTS):
        floor = p[model.PARAMETERS.index(f"{owners[j]}.impact_velocity_floor")]
        if modes[j] not in (0.0, 1.0):
            raise ValueError(f"start: the mode of joint {name!r} must be 0 (free) or 1 "
                             f"(contact); got {modes[j]!r}")
        if dmin[j] < floor:
            raise ValueError(f"start: the impact velocity of joint {name!r} must be >= its "
                             f"impact_velocity_floor {floor:g} m/s; got {dmin[j]!r}")
        p[model.MEM_START + 2 * j] = modes[j]
        p[model.MEM_START + 2 * j + 1] = dmin[j]
    y0 = np.concatenate([y, np.zeros(model.N_STATE - n2)])
    for j, name in enumerate(model.JOINTS):
        g = model.event(0.0, y0, p, j)[0]
        if g > event_tol:
            side = "in contact" if modes[j] else "in free flight"
            raise ValueError(f"start: joint {name!r} is marked {side} but its journal is "
                             f"{g:.3g} m on the other side of the bearing wall")
    return y0


# ---------------------------------------------------------------------------- tolerances

#: absolute tolerance of each switching function (the penetration), in clearances times
#: rtol: the event functions and their rates are under error control beside the state
#: (`integrator._attempt`). The state's own scales (positions ~ the length scale, speeds
#: ~ omega times it) are 1e4 times coarser than the penetration that sets the contact force
#: and the stored impact velocity; see docs/performance.md (the accuracy map)
EVENT_ATOL = 1.5


def drive_extent(linkage: Linkage) -> float:
    """The driven body's largest distance between two of its points (and its centre of
    mass) in m: its tip speed / drive speed, the scale of length rates."""
    import math

    drive = next(j for j in linkage.joints if j.name == linkage.drive.joint)
    body = next(b for b in linkage.bodies if b.name == drive.body_b)
    pts = [(0.0, 0.0), *body.points.values()]
    return max(math.dist(a, b) for a in pts for b in pts)


#: hysteresis factor xi (laws.forces) above which a contact law counts as damping-dominated
#: (the damping term exceeds the spring term xi-fold at the impact speed) and the
#: penetration rate is put under error control too: Flores' law at e = 0.05 (xi = 30) and
#: 0.1 (xi = 14) missed 1e-5 on the paper case's first impact's peak without it; the laws
#: with xi <= 1.5 (every restitution of the other laws) met it (docs/performance.md, the
#: accuracy map)
DAMPED_XI = 4.0

#: absolute tolerance of the penetration rate of a damping-dominated law, in clearance x
#: drive speed x rtol, divided by xi (the force's relative error goes as xi times the rate's)
DAMPED_RATE_ATOL = 1e4


def event_atol(joint, speed: float, rtol: float) -> np.ndarray:
    """Absolute tolerances of one clearance joint's switching function (penetration, m)
    and its rate (m/s): the penetration's error is controlled at the clearance's scale;
    its rate only through the state (a tolerance on it at the clearance's scale cost more
    than it gained, docs/performance.md), except for a damping-dominated contact law
    (hysteresis factor xi > DAMPED_XI), whose force follows the rate with weight xi: there
    the rate's atol is rtol x DAMPED_RATE_ATOL / xi x clearance x drive speed."""
    from ..laws.registry import CONTACT

    # the law's python source: a compiled kernel called from here would compile on first use
    xi = CONTACT[CONTACT_MODELS[joint.contact_model]].hysteresis(joint.restitution)
    rate = (rtol * DAMPED_RATE_ATOL / xi * joint.clearance * speed
            if xi > DAMPED_XI else np.inf)
    return np.array([rtol * EVENT_ATOL * joint.clearance, rate])


def default_atol(linkage: Linkage, model, rtol: float) -> np.ndarray:
    """Absolute tolerances: per state component from the linkage's natural scales (angles
    1 rad, lengths the length scale, angle rates the drive speed, length rates the driven
    body's tip speed, the drive's (and friction's) work 1 J, not under error control), then
    per clearance joint of its switching function and its rate (`event_atol`)."""
    w = linkage.rate_scale
    length = linkage.length_scale
    # a free linkage: its whole reach as the extent
    tip = w * (drive_extent(linkage) if linkage.drive is not None else length)
    pos = [1.0 if c.endswith(".angle") else length for c in model.COORDINATES]
    vel = [w if c.endswith(".angle") else tip for c in model.COORDINATES]
    events = [event_atol(j, w, rtol) for _, j in linkage.contacts()]
    works = [1.0] * (model.N_STATE - 2 * model.N_Q)
    return np.concatenate([rtol * np.array(pos + vel + works), *events])


# ---------------------------------------------------------------------------- trajectory

def trajectory_from_run(linkage: Linkage, model, ts, ys, ms, p, stats, peaks, outs=None):
    """The `Trajectory` of a linkage run: recorded times, states, memories (n, N_MEM) and,
    if recorded, outputs (OUT_COLUMNS; else evaluated here)."""
    from .trajectory import Trajectory

    ys = np.ascontiguousarray(ys)
    ms = np.ascontiguousarray(ms[:, :model.N_MEM])
    if outs is None or outs.shape[1] < model.N_OUT:
        outs = model.outputs(np.ascontiguousarray(ts), ys, ms, p)
    col = {c: i for i, c in enumerate(model.OUT_COLUMNS)}
    joints = model.JOINTS
    J, n = len(joints), model.N_Q

    def take(*names):
        return _take_columns(outs, [col[c] for c in names])

    def per_joint(field):
        return take(*(f"{j}.{field}" for j in joints))

    named = named_series(model, ys, outs, model.OUT_COLUMNS)
    monitored = (named["shaking_force"] if model.MONITOR_JOINT is None
                 else named["reactions"][model.MONITOR_JOINT])
    # (n, J, 2): per joint its x and y side by side
    ecc = take(*(f"{j}.ecc_{a}" for j in joints for a in "xy")).reshape(-1, J, 2)
    series = {}
    for el in ELEMENTS:
        series.update(el.trajectory_series(linkage, ecc, _SeriesContext(linkage, model, ts,
                                                                        ys, p)))
    contact_angle, slip_velocity = series["contact_angle"], series["slip_velocity"]
    # a free linkage has no drive: no drive moment, no drive work
    free = "drive_moment" not in col
    return Trajectory(
        t=np.asarray(ts), base_force=monitored,
        crank_moment=None if free else outs[:, col["drive_moment"]].copy(),
        contact_force=per_joint("contact_force"), penetration=per_joint("penetration"),
        eccentricity=ecc,
        contact_phase=(ms[:, 0:2 * J:2] > 0.5).astype(np.int8),
        crank_work=None if free else ys[:, 2 * n].copy(), mechanism=linkage,
        backend="reduced", stats=stats,
        peaks=peaks, **named,
        friction_work=(ys[:, model.FRICTION_WORK].copy() if getattr(model, "FRICTION_WORK", -1)
                       > 0 and ys.shape[1] > model.FRICTION_WORK else None),
        contact_angle=contact_angle, slip_velocity=slip_velocity,
    )


def eccentricity_rates(model, ts, ys, p, joints: int) -> np.ndarray:
    """(n, joints, 2) m/s: the rate of the journal centre minus the bearing centre of the
    first `joints` clearance joints at the recorded steps (times ts, states ys): the loop
    closure's Jacobian times the rates plus its explicit time rate (the gaps' rates are
    linear in the rates); a compiled C model evaluates the gaps' rates directly."""
    if hasattr(model, "gap_series"):
        return model.gap_series(ts, ys, p, joints)[:, :, 2:]
    n_q = model.N_Q
    out = np.empty((len(ts), joints, 2))
    rows = slice(0, 2 * joints)
    for i in range(len(ts)):
        q, qd = ys[i, :n_q], ys[i, n_q:2 * n_q]
        rate = model.closure_jacobian(ts[i], q, p)[rows] @ qd + model.closure_rate(
            ts[i], q, p)[rows]
        out[i] = rate.reshape(joints, 2)
    return out


class _SeriesContext:
    """What an element's run series read (`Element.trajectory_series`), computed when first
    asked: ``edot``(J) the first J contacts' eccentricity rates (n, J, 2), ``bodies`` the
    bodies' angle and rate series, ``effective_radius`` of a profiled bearing."""

    def __init__(self, linkage: Linkage, model, ts, ys, p):
        self._args = (linkage, model, np.asarray(ts), ys, p)

    def edot(self, joints: int) -> np.ndarray:
        _, model, ts, ys, p = self._args
        return eccentricity_rates(model, ts, ys, p, joints)

    @property
    def bodies(self) -> dict:
        from ..generate.profiles import body_angle_series

        linkage, model, ts, ys, _ = self._args
        return body_angle_series(linkage, model.COORDINATES, ts, ys)

    @staticmethod
    def effective_radius(*args):
        from ..generate.profiles import effective_radius

        return effective_radius(*args)


def named_series(model, ys, outs, columns) -> dict:
    """The series of a run by the description's names (the Trajectory fields joints,
    reactions, shaking_force, coordinates, rates, accelerations): the clearance joints,
    every ground joint's reaction, the shaking force, the coordinates, their rates and
    accelerations, from the recorded states and the outputs named `columns`."""
    col = {c: i for i, c in enumerate(columns)}
    n = model.N_Q

    def take(*names):
        return _take_columns(outs, [col[c] for c in names])

    return {
        "joints": tuple(model.JOINTS),
        "reactions": {g: take(f"{g}.reaction_x", f"{g}.reaction_y")
                      for g in model.GROUND_JOINTS},
        "shaking_force": take("shaking_x", "shaking_y"),
        "coordinates": {c: ys[:, i].copy() for i, c in enumerate(model.COORDINATES)},
        "rates": {c: ys[:, n + i].copy() for i, c in enumerate(model.COORDINATES)},
        "accelerations": {c: outs[:, col[f"{c}.acc"]].copy() for c in model.COORDINATES},
    }


def _take_columns(a: np.ndarray, columns) -> np.ndarray:
    """a[:, columns] as a new C-contiguous (n, len(columns)) array, copied column by column
    (for a long record several times faster than numpy's fancy indexing of columns)."""
    out = np.empty((a.shape[0], len(columns)))
    for k, c in enumerate(columns):
        out[:, k] = a[:, c]
    return out


# ---------------------------------------------------------------------------- runs

#: options of `simulate(linkage, backend="reduced")` (keywords of `run` meant for users)
#: (the run settings, `RunSettings`, but the comparisons' event_control)
OPTION_NAMES = (*(n for n in RunSettings.names() if n != "event_control"), "t_eval", "start",
                "duration", "window")

#: the event search looks closer (7 more samples and the interpolant's maximum) between two
#: samples of a step where the cubic Hermite interpolant of a penetration comes within
#: `event_margin` of the wall (see integrator._search_event): this fraction of the smallest
#: clearance, or MARGIN_PER_RTOL x rtol of it where that is larger
EVENT_MARGIN = 0.001
#: the margin stays at least this many times the switching function's error tolerance
#: (rtol (1.5 c + |delta|), `EVENT_ATOL`): 67 x at rtol 1e-5 and looser
MARGIN_PER_RTOL = 100.0

#: golden-section iterations per refined peak candidate: the bracket shrinks to 0.618^24 =
#: 1e-5 of a step, where the peak's quadratic error is ~1e-12 of its value
REFINE_ITERS = 24


def event_margin(clearance: float, rtol: float) -> float:
    """Distance from a wall (m) within which the event search looks closer between samples:
    EVENT_MARGIN of the (smallest) clearance, at least MARGIN_PER_RTOL rtol of it. It guards
    against the interpolants' error, which the switching function's error control keeps
    below rtol (1.5 c + |delta|); a fixed 0.05 c would put every step of a
    light lasting contact (penetration ~0.005 c, the four-bar's) under the closer look and
    the approach step limit, at 1.7 times the run time with the same steps
    (docs/performance.md)."""
    return clearance * max(EVENT_MARGIN, MARGIN_PER_RTOL * rtol)


def event_tolerance(linkage: Linkage) -> float:
    """Default penetration tolerance of the events in m: 1e-12 of the smallest clearance,
    but not below the round-off of the journal positions."""
    return max(1e-12 * linkage.min_clearance, 8 * np.finfo(float).eps * linkage.length_scale)


def _tolerances(linkage, model, rtol, atol):
    from .._checks import check_real

    rtol = DEFAULT_RTOL if rtol is None else check_real("rtol", rtol, 1e-14, 1e-2)
    full = default_atol(linkage, model, rtol)
    if atol is None:
        return rtol, full
    arr = None
    if not isinstance(atol, (bool, np.bool_)):
        try:
            arr = np.asarray(atol, dtype=float)
            if arr.ndim == 1 and arr.shape[0] == full.shape[0]:
                arr = arr.copy()            # the state's and the switching functions'
            else:
                arr = np.broadcast_to(arr, (model.N_STATE,)).copy()
        except (TypeError, ValueError):
            arr = None
    n = model.N_STATE
    if (arr is None or not np.all(np.isfinite(arr[:n])) or np.any(arr <= 0)
            or np.any(np.isnan(arr))):
        raise ValueError(f"atol must be a finite number > 0 or {n} of them (one per state "
                         f"component {list(model.COORDINATES)}, their rates, the drive's "
                         f"work), or {full.shape[0]} (then per clearance joint its "
                         f"penetration's and penetration rate's, inf allowed); got {atol!r}")
    full[:arr.shape[0]] = arr
    return rtol, full


def landing_edges(edges: np.ndarray, t_eval) -> tuple[np.ndarray, np.ndarray]:
    """Output times `t_eval` (checked: increasing, within [0, edges[-1]]) and the edges the
    integrator lands on: the window edges united with them, a time within 1e-12 of the span
    of the previous one dropped. Returns (t_eval, edges)."""
    from .._checks import check_times

    t_eval = check_times("t_eval", t_eval, float(edges[-1]))
    merged = np.union1d(edges, t_eval)
    merged = merged[np.concatenate([[True], np.diff(merged) > 1e-12 * merged[-1]])]
    return t_eval, merged


def landed_indices(ts: np.ndarray, t_eval: np.ndarray) -> np.ndarray:
    """Indices of the recorded steps that landed on the times `t_eval`."""
    return np.minimum(np.searchsorted(ts, t_eval), len(ts) - 1)


def window_peaks(ts: np.ndarray, outs: np.ndarray, column: int,
                 win_edges: np.ndarray) -> np.ndarray:
    """Per window [win_edges[i], win_edges[i + 1]] the largest magnitude of the outputs'
    columns (column, column + 1) at the samples ts (0 for a window without samples)."""
    mags = np.hypot(outs[:, column], outs[:, column + 1])
    return np.array([mags[(ts >= a) & (ts <= b)].max(initial=0.0)
                     for a, b in zip(win_edges[:-1], win_edges[1:])])


class LinkageRun(NamedTuple):
    """What `run` returns: the compiled model, the recorded times, states, memories (per
    joint its mode and impact velocity) and outputs (model.OUT_COLUMNS) per step, the
    refined peak of the monitored force and its time per revolution, the run's stats
    (counters, tolerances) and the parameter vector."""

    model: object
    ts: np.ndarray
    ys: np.ndarray
    ms: np.ndarray
    peaks: np.ndarray
    peak_times: np.ndarray
    stats: dict
    outs: np.ndarray
    p: np.ndarray


#: runs of at least this many revolutions are preceded by a one-revolution pilot (no
#: record) whose step count estimates the run's steps and memory; it costs at most 1/16
#: of the run and turns a run that would stop at max_steps or max_memory into an
#: immediate refusal
PILOT_MIN_REVOLUTIONS = 16


def record_row(model, record: bool = True) -> int:
    """Floats recorded per step: time, state, memory and (if recorded) outputs."""
    return 1 + model.N_STATE + model.N_MEM + (model.N_OUT if record else 0)


def trajectory_floats(model) -> int:
    """Floats per step of a `Trajectory`'s series (`trajectory_from_run`) and the times'
    copy: monitored force 2, drive moment 1, per joint contact force, penetration,
    eccentricity 2, phase, contact angle and slip velocity, per ground joint its reaction 2,
    shaking force 2, works 2, coordinates, rates and accelerations."""
    return 1 + 2 + 1 + 7 * model.N_EVENTS + 2 * len(model.GROUND_JOINTS) + 2 + 2 \
        + 3 * model.N_Q


def bytes_per_step(model) -> int:
    """Peak bytes per recorded step: the record grows by doubling, so up to 3 rows are
    alive while it is copied; the Trajectory's series are built while the record is
    alive."""
    return 8 * (3 * record_row(model) + trajectory_floats(model))


def _estimate_steps(linkage, revolutions: float, free: bool, *, max_steps: int, h_max: float,
                    pilot: dict) -> int | None:
    if free:                        # a free linkage: `revolutions` are seconds, no pilot
        return _estimate_free(revolutions, max_steps, h_max)
    return _estimate_driven(linkage, revolutions, max_steps=max_steps, h_max=h_max,
                            pilot=pilot)


def _estimate_free(duration: float, max_steps: int, h_max: float) -> None:
    """A free linkage's run of `duration` s: refused where h_max alone forces more than
    max_steps (no pilot: a free motion's first part need not be like the rest)."""
    import math

    from .._checks import check_steps

    check_steps(f"a run of {duration:.6g} s with h_max = {h_max:.3g} s",
                math.ceil(duration / h_max), max_steps,
                "raise h_max or max_steps, or run a shorter duration")
    return None


def _estimate_driven(linkage, revolutions: float, *, max_steps: int, h_max: float,
                     pilot: dict) -> int | None:
    """Steps of a run of `revolutions` revolutions, estimated before it; refused with
    `MemoryLimitError` where h_max alone forces more than max_steps, or (runs of
    `PILOT_MIN_REVOLUTIONS` or more) where a one-revolution pilot without record (`pilot`:
    its run options) predicts more. None: not estimated (a short run)."""
    import math

    from .._checks import MemoryLimitError, check_steps

    check_steps(f"a run of {revolutions:.6g} revolutions with h_max = {h_max:.3g} s",
                math.ceil(revolutions * linkage.period / h_max), max_steps,
                "raise h_max or max_steps, or run fewer revolutions")
    if revolutions < PILOT_MIN_REVOLUTIONS:
        return None
    try:
        stats = run(linkage, 1, record=False, **pilot).stats
        per_rev = float(stats["naccept"] + stats["nreject"])
    except RuntimeError:
        per_rev = float(max_steps)
    steps = int(math.ceil(per_rev * revolutions))
    if steps > max_steps:
        raise MemoryLimitError(
            f"a run of {revolutions:.6g} revolutions needs about {steps:.3g} steps "
            f"({per_rev:.4g} in the first revolution), more than max_steps={max_steps}; "
            "raise max_steps or run fewer revolutions")
    return steps


def integrator_settings(linkage: Linkage, model, rtol: float, atol: np.ndarray, *,
                        h_max: float, max_steps: int, record: bool, event_tol: float,
                        h0: float = 0.0, n_samples: int = 1,
                        refine_iters: int = REFINE_ITERS, n_out: int = 0,
                        n_err: int | None = None):
    """The integrator's settings record (`integrator.IntegratorSettings`) of a run of
    `linkage`'s generated `model`: the leading `n_err` state components under error control
    (default the plain state's 2 N_Q; the works are quadratures; a sensitivity run adds its
    own), the event search's margin from the smallest clearance (`event_margin`), the
    memories of every clearance joint recorded."""
    from ..numerics.integrator import make_settings

    return make_settings(
        rtol, atol, 2 * model.N_Q if n_err is None else n_err, h0=h0, h_max=h_max,
        max_steps=max_steps, record=record,
        event_tol=event_tol, event_margin=event_margin(linkage.min_clearance, rtol),
        n_samples=n_samples, refine_iters=refine_iters, n_out=n_out, n_dense=2 * model.N_Q,
        n_events=model.N_EVENTS, mem_start=model.MEM_START, n_mem=model.N_MEM)


def time_edges(duration, window=None) -> np.ndarray:
    """The window edges of a free linkage's run of `duration` s: windows of `window` s
    from t = 0 (None: one window, the whole run; the last window ends at `duration`, a
    remainder shorter than 1e-9 of it joined to the window before)."""
    from .._checks import check_real

    duration = check_real("duration", duration, 0.0, None, low_open=True, unit="s")
    if window is None:
        return np.array([0.0, duration])
    window = check_real("window", window, 0.0, duration, low_open=True, unit="s")
    edges = np.arange(0.0, duration, window)
    if duration - edges[-1] < 1e-9 * duration and len(edges) > 1:
        edges = edges[:-1]
    if len(edges) > MAX_WINDOWS:
        raise ValueError(f"window must be at least duration / {MAX_WINDOWS} = "
                         f"{duration / MAX_WINDOWS:.3g} s (at most {MAX_WINDOWS} windows); "
                         f"got {window!r}")
    return np.append(edges, duration)


#: the most time windows of a free linkage's run
MAX_WINDOWS = 1_000_000


def check_span(linkage: Linkage, revolutions, duration, window,
               name: str = "revolutions") -> int | None:
    """The revolutions of a driven linkage's run (None: 4), or None for a free linkage
    (which takes `duration` in s and `window`, not revolutions); ValueError naming the
    allowed choice otherwise."""
    from .._checks import check_int

    if linkage.drive is None:
        if revolutions is not None:
            raise ValueError(f"linkage {linkage.name!r} is free (drive=None): it has no drive "
                             f"revolutions; give duration= (s) and optionally window= (s) "
                             f"instead of {name}={revolutions!r}")
        return None
    if duration is not None or window is not None:
        raise ValueError(f"linkage {linkage.name!r} is driven: its runs cover revolutions= "
                         f"(whole drive revolutions, windows of one revolution); duration= "
                         f"and window= are for a free linkage (drive=None)")
    return check_int(name, 4 if revolutions is None else revolutions, 1)


def prepare_span(linkage: Linkage, revolutions=None, *, duration=None, window=None,
                 edges=None, max_memory=None, name: str = "revolutions") -> Span:
    """The span of a run of `linkage`, checked (ValueError naming the option and its
    range, before any work): a driven linkage's `revolutions` (None: 4; `name`: the option
    as its errors say it), windows of one revolution; a free linkage's `duration` in s,
    windows of `window` s (`time_edges`), and no revolutions. `edges` (increasing times in
    s from 0) replaces the windows (a free linkage: then without a duration). The
    per-window arrays are refused with `MemoryLimitError` above `max_memory` bytes (None:
    the default) before they are allocated. Every run takes its span from here: the plain
    and peak-only runs (`prepare`), the Exudyn and the ideal backends."""
    from .._checks import check_max_memory, check_revolutions_memory

    free = linkage.drive is None        # the runs below read the span, not the drive
    if free and edges is not None and revolutions is None and duration is None:
        pass            # the caller's windows
    elif free:
        check_span(linkage, revolutions, duration, window, name)
        if duration is None:
            raise ValueError(f"linkage {linkage.name!r} is free (drive=None): give its run's "
                             "duration= in s")
        edges = time_edges(duration, window)
    else:
        revolutions = check_span(linkage, revolutions, duration, window, name)
    max_memory = check_max_memory(max_memory)
    if edges is None:
        check_revolutions_memory(revolutions, max_memory)
        edges = np.arange(revolutions + 1) * linkage.period
    else:
        edges = np.ascontiguousarray(edges, dtype=float)
        if (edges.ndim != 1 or len(edges) < 2 or edges[0] != 0.0
                or not np.all(np.isfinite(edges)) or np.any(np.diff(edges) <= 0)):
            raise ValueError("edges must be increasing finite times starting at 0.0")
        check_revolutions_memory(len(edges) - 1, max_memory, name="windows")
    return Span(edges=edges, windows=edges, revolutions=revolutions)


def check_span_start(span: Span, start) -> None:
    """ValueError for a `start` (a `Start`) of a free linkage's run (`span` without
    revolutions), which starts from its description's `Initial`."""
    if span.revolutions is None and start is not None:
        raise ValueError("start is for a driven linkage; a free linkage starts from its "
                         "initial (Linkage.initial, an Initial)")


def run(linkage: Linkage, revolutions: int | None = None,
        settings: RunSettings | None = None, **options):
    """`solve(prepare(linkage, revolutions, settings, **options))`: integrate `linkage`'s
    generated model (see `prepare` for the arguments); a `LinkageRun`."""
    return solve(prepare(linkage, revolutions, settings, **options))


def prepare(linkage: Linkage, revolutions: int | None = None,
            settings: RunSettings | None = None, *, duration: float | None = None,
            window: float | None = None, record: bool = True, t_eval=None,
            start: Start | None = None, edges=None, select: bool = True,
            whole: bool = True, specialise: bool = True, model=None,
            **options) -> Problem:
    """The one door of a plain run: every argument checked, the model loaded, the span,
    tolerances, parameters and start prepared into a `Problem` that `solve` integrates.

    Integrate `linkage`'s generated model over `revolutions` drive revolutions (default
    4) from the centred start (or from `start`, a `Start`); returns a `LinkageRun` (model,
    ts, ys, ms, peaks, peak_times, stats, outs, p). The one place where a plain run meets
    the integrator (the paper's `SliderCrank` runs here too, as its description).

    A free linkage (drive None) runs for `duration` s from its `Initial` start, its peaks
    taken over windows of `window` s (None: the whole run) instead of revolutions
    (`time_edges`); it takes no revolutions (and a driven one no duration or window).

    `settings` (a `RunSettings`: tolerances, step control, events, memory) says how;
    keyword `options` (its field names, e.g. ``rtol=1e-9``) change single fields.
    `edges` (increasing times from 0) replaces the revolution windows over which the peaks
    are taken. With `t_eval` the integrator also lands exactly on those times and only
    they are returned (the peaks then are the maxima over them per window; ``select=False``
    returns every step, which include them); ``whole=False`` lands on 0 and `t_eval` only
    and ends at the last of them (the windows stay the span's). `specialise`: the model
    specialised on the linkage's zero-valued geometric parameters (False: the general one,
    for differences in one of them). `model`: the generated module, where the caller knows
    it (the paper's checked-in one: the lookup by structure imports the generator). Every
    option is checked first (ValueError naming it and its range); a run of
    `PILOT_MIN_REVOLUTIONS` or more is estimated by a one-revolution pilot and
    refused with `MemoryLimitError` (a ValueError) if it cannot fit in max_steps or
    max_memory bytes; a recording run stops there and says so."""
    from .._checks import (
        MemoryLimitError,
        check_bool,
        check_max_memory,
        format_bytes,
        revolution_bytes,
    )
    from .diagnostics import LOOSE_RTOL

    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    if settings is not None and not isinstance(settings, RunSettings):
        raise ValueError(f"settings must be a RunSettings; got {type(settings).__name__}")
    settings = (settings or RunSettings()).with_options(options)
    span = prepare_span(linkage, revolutions, duration=duration, window=window, edges=edges,
                        max_memory=settings.max_memory)
    check_span_start(span, start)
    free = span.revolutions is None
    record = check_bool("record", record)
    select = check_bool("select", select)
    whole = check_bool("whole", whole)
    method, max_steps, n_samples, h0 = (settings.method, settings.max_steps,
                                        settings.n_samples, settings.h0)
    max_memory = check_max_memory(settings.max_memory)
    h_max = ((linkage.time_scale if free else linkage.period) / 8
             if settings.h_max is None else settings.h_max)
    event_tol = event_tolerance(linkage) if settings.event_tol is None else settings.event_tol
    edges = span.edges
    if model is None:
        model = load_model(linkage, specialise)
    rtol, atol_arr = _tolerances(linkage, model, settings.rtol, settings.atol)
    if rtol > LOOSE_RTOL:
        warnings.warn(f"rtol {rtol:g} is too loose to resolve the contacts (looser than "
                      f"{LOOSE_RTOL:g}: spurious contact events and peak forces wrong by any "
                      f"amount); use rtol <= {LOOSE_RTOL:g}, the default is {DEFAULT_RTOL:g}",
                      AccuracyWarning, stacklevel=3)
    if not settings.event_control:
        atol_arr = atol_arr[:model.N_STATE]
    p = pack_parameters(linkage, model)
    if start is None:
        y0 = initial_state(linkage, model, p)
    else:
        y0 = check_start(linkage, model, p, start, event_tol)
    refine = REFINE_ITERS
    if t_eval is not None:
        t_eval, edges = landing_edges(edges, t_eval)
        if not whole:
            edges = landing_edges(np.array([0.0, t_eval[-1]]), t_eval)[1]
        record, refine = True, 0
    length = float(edges[-1]) if free else float(edges[-1]) / linkage.period
    steps = _estimate_steps(linkage, length, free, max_steps=max_steps,
                            h_max=h_max, pilot=dict(settings=settings, start=start,
                                                    specialise=specialise, model=model))
    window_bytes = revolution_bytes(len(edges) - 1)
    per_step = bytes_per_step(model)
    if record and steps is not None and window_bytes + steps * per_step > max_memory:
        need = window_bytes + steps * per_step
        raise MemoryLimitError(
            f"a run of {length:.6g} {'s' if free else 'revolutions'} needs about "
            f"{format_bytes(need)} ({steps:.3g} recorded steps of {per_step} bytes), more "
            f"than max_memory={max_memory} bytes ({format_bytes(max_memory)}); raise "
            "max_memory, run fewer revolutions, or ask for the peaks only (record=False)")
    extra_fev = 0
    if h0 == 0.0 and model.N_STATE > 2 * model.N_Q + 1:
        h0 = _start_step(model, y0, p, rtol, atol_arr, method, min(h_max, edges[-1]))
        extra_fev = 1
    n_out = model.N_OUT if record else 0
    # the record never outgrows max_memory: a run that would stops there (and says so)
    limit = min(max_steps, max(1, (max_memory - window_bytes) // per_step)) if record \
        else max_steps
    kernel_settings = integrator_settings(
        linkage, model, rtol, atol_arr, h0=h0, h_max=h_max, max_steps=limit, record=record,
        event_tol=event_tol, n_samples=n_samples, refine_iters=refine, n_out=n_out)
    span = replace(span, edges=edges, t_eval=t_eval, select=select)
    return Problem(linkage=linkage, model=model, layout=ModelLayout.of(model),
                   span=span, settings=settings, specialise=specialise, p=p, y0=y0,
                   integrator=kernel_settings, method=method, rtol=float(rtol),
                   max_steps=max_steps, max_memory=max_memory, extra_fev=extra_fev)


def solve(problem: Problem) -> LinkageRun:
    """Integrate a prepared `Problem` (its p is copied: the problem can be solved again);
    RuntimeError naming the failure, `MemoryLimitError` where the record reached
    max_memory."""
    from .._checks import MemoryLimitError, format_bytes
    from ..numerics.integrator import COUNTERS, RESULTS

    linkage, model, span = problem.linkage, problem.model, problem.span
    max_memory, max_steps = problem.max_memory, problem.max_steps
    limit = problem.integrator.max_steps
    p = problem.p.copy()
    ts, ys, ms, peaks, peak_t, counters, outs, status = integrate(problem, p)
    status = RESULTS(int(status))
    if status == RESULTS.max_steps and limit < max_steps:
        raise MemoryLimitError(
            f"linkage {linkage.name!r}: the run's record reached max_memory={max_memory} bytes "
            f"({format_bytes(max_memory)}) at t = {ts[-1]:.6g} s, after {limit} steps; raise "
            "max_memory, run fewer revolutions, or ask for the peaks only (record=False)")
    if status != RESULTS.success:
        raise RuntimeError(f"integration of linkage {linkage.name!r} failed at about t = "
                           f"{ts[-1] if len(ts) else float('nan'):.6g} s: {status.message}")
    if span.t_eval is not None and span.select:
        keep = landed_indices(ts, span.t_eval)
        ts, ys, ms, outs = ts[keep], ys[keep], ms[keep], outs[keep]
        peaks = window_peaks(ts, outs, model.MONITOR_COLUMN, span.windows)
    stats = {k: int(v) for k, v in zip(COUNTERS, counters)}
    stats["nfev"] += problem.extra_fev
    stats.update(method=problem.method, rtol=problem.rtol)
    return LinkageRun(model, ts, ys, ms, peaks, peak_t, stats, outs, p)


def integrate(problem: Problem, p: np.ndarray):
    """The integrator's run of `problem` with parameters and memory `p` (modified in
    place) on the compiled core (`kernels.plain_kernel`): the core's `integrate` returns."""
    from ..numerics.integrator import METHODS
    from .kernels import plain_kernel

    kernel = plain_kernel(problem.linkage, problem.model, problem.specialise)
    return kernel(problem.y0, p, problem.span.edges, problem.integrator,
                  METHODS[problem.method].arrays())


def _start_step(model, y0, p, rtol, atol, method, span):
    """The integrator's automatic starting step (`integrator.initial_step`) of the state
    without the friction work (one evaluation of the model): the step a frictionless model
    takes, so that a zero friction coefficient reproduces its run bit for bit (the friction
    work, a quadrature, would otherwise enter the starting step's norms)."""
    from ..numerics.integrator import METHODS, initial_step

    n = 2 * model.N_Q + 1
    y = np.ascontiguousarray(y0[:n])
    f = np.empty(n)
    model.rhs(0.0, y, p, f)
    return initial_step(model.rhs, 0.0, y, f, p, rtol, np.ascontiguousarray(atol[:n]),
                                METHODS[method].error_order + 1, span, np.empty(n),
                                np.empty(n))


def simulate_linkage(linkage: Linkage, revolutions: int | None = None, **options):
    """Simulate `linkage` with its generated model; a `Trajectory` of every accepted step
    with per-joint series (see `Trajectory`), annotated (penetration, periodicity). A free
    linkage takes ``duration`` (s) and ``window`` (s) instead of revolutions (`run`)."""
    from .trajectory import annotate

    settings, rest = RunSettings.split(options)
    problem = prepare(linkage, revolutions, settings, record=True, **rest)
    model, ts, ys, ms, peaks, _, stats, outs, p = solve(problem)
    # a free linkage (a span without revolutions): its duration in turns at its rate scale
    # stands for revolutions
    free = problem.span.revolutions is None
    turns = (max(1.0, float(ts[-1]) / linkage.time_scale) if free
             else problem.span.revolutions)
    stats.update(contact_flags([j.clearance for _, j in linkage.contacts()],
                               linkage.rate_scale, turns, ms[:, :model.N_MEM],
                               stats.get("nevent", 0), stats["rtol"],
                               linkage.time_scale if free else None))
    if stats["accuracy_note"]:
        warnings.warn(stats["accuracy_note"], AccuracyWarning, stacklevel=3)
    if options.get("t_eval") is None:
        # onsets raised to a contact's impact-velocity floor, each contact's memory (mode,
        # impact velocity) in turn
        stats["floored_impacts"] = sum(
            floored_impacts(ms[:, 2 * k:2 * k + 2], j.impact_velocity_floor)
            for k, (_, j) in enumerate(linkage.contacts()))
    traj = trajectory_from_run(linkage, model, ts, ys, ms, p, stats, peaks, outs)
    start = options.get("start")
    if start is not None:
        traj.stats["start_revolutions"] = start.revolutions
    return annotate(traj)


def peak_linkage(linkage: Linkage, revolution: int | None = None, **options) -> float:
    """The monitored force's maximum in N over drive revolution `revolution` (1-based,
    default 4; the monitored ground joint's |reaction|, or |shaking force|), recording
    nothing. A free linkage: over the last window of a run of ``duration`` s (windows of
    ``window`` s; default the whole run), `revolution` not given."""
    revolution = check_span(linkage, revolution, None, None, "revolution")
    if revolution is None:          # a free linkage: its last window
        return float(run(linkage, record=False, **options).peaks[-1])
    peaks = run(linkage, revolution, record=False, **options).peaks
    return float(peaks[revolution - 1])
