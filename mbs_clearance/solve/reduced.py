"""The paper's slider-crank (`SliderCrank`) on the reduced model: its runs and `Trajectory`.

A `SliderCrank` runs on the model generated from its description (`cases.from_slider_crank`,
the checked-in module `MODEL` = mbs_clearance._generated.paper_slider_crank): one place of
the physics for every linkage. Generalized coordinates theta3 (coupler angle) and x4
(slider position); the crank angle is prescribed, theta2 = omega2 t + theta20. State y =
[theta3, x4, theta3dot, x4dot, W] where W is the work done by the crank drive (a quadrature,
kept out of error control). The clearance joint's memory (contact mode, impact velocity
deltadot_minus, set exactly at the located onset) is p[MEM_START:MEM_START + 2] of the
model's parameter vector (`model_parameters`).

This module keeps the orchestration of a SliderCrank's runs: tolerances from its scales,
revolution windows, the pilot and memory estimate, accuracy flags and the Trajectory. Its
sensitivities (sensitivity.py, objective.py) run on the same model's generated Jacobians
(linkage_ddm).
"""

from __future__ import annotations

import functools
import math
import sys
import warnings
from typing import Any, NamedTuple

import numba as nb
import numpy as np

from .._checks import (
    REVOLUTION_BYTES,
    MemoryLimitError,
    check_bool,
    check_choice,
    check_int,
    check_max_memory,
    check_real,
    check_revolutions_memory,
    format_bytes,
    revolution_bytes,
)
from .._generated import paper_slider_crank as MODEL
from .._warnings import AccuracyWarning
from ..laws.forces import CONTACT_MODELS, hysteresis_factor
from ..model.mechanism import SliderCrank
from ..numerics.integrator import (
    COUNTERS,
    METHODS,
    RESULTS,
    make_settings,
)
from .diagnostics import (  # noqa: F401 - the contact diagnostics, public here too
    GRAZING_ONSET,
    LOOSE_RTOL,
    RATTLING,
    SETTLING_ONSETS,
    START_SWITCHES,
    contact_flags,
    floored_impacts,
    grazing_onsets_of,
    rattles,
)
from .linkage_model import (  # the settings shared with every linkage's runs
    DEFAULT_MAX_STEPS,
    DEFAULT_RTOL,
    EVENT_ATOL,
    REFINE_ITERS,
    event_margin,
    landed_indices,
    landing_edges,
    window_peaks,
)
from .trajectory import annotate

# ---- the generated model's layout (every SliderCrank maps to its structure)
#: the clearance joint's memory (mode, impact velocity) in the generated model's p
MEM_START = MODEL.MEM_START
#: columns of the outputs that a plain run records (the generated model's)
MODEL_COLUMNS = MODEL.OUT_COLUMNS
#: index of the clearance in the generated model's p
P_CLEARANCE = MODEL.PARAMETERS.index(f"{MODEL.JOINTS[0]}.clearance")

_THIS = sys.modules[__name__]
N_MEM = 2          # the joint's mode and impact velocity
N_STATE = 5        # theta3, x4, theta3dot, x4dot, W
N_ERR = 4          # W is a quadrature, not under error control
N_EVENT = 4        # the event function reads theta3, x4 and their rates only (rhs needs
                   # no more: the integrator's continuous extension is formed for these)


@functools.lru_cache(maxsize=256)
def _model_parameters(mech: SliderCrank) -> np.ndarray:
    from ..model.cases import from_slider_crank
    from .linkage_model import pack_parameters as pack

    p = pack(from_slider_crank(mech), MODEL)
    p.flags.writeable = False
    return p


def model_parameters(mech: SliderCrank) -> np.ndarray:
    """The generated model's parameter vector p (MODEL.N_P,) for `mech`: its description's
    values (`cases.from_slider_crank`) and constants, the memory in free flight (a new
    array; the values are cached per mechanism)."""
    return _model_parameters(mech).copy()


def ideal_kinematics(L2, L3, w, th2):
    """[theta3, x4, theta3dot, x4dot] of the ideal mechanism at crank angle th2.

    Written with numpy functions so that it also takes complex arguments (complex-step
    derivatives of the initial state in `sensitivity`).
    """
    s3 = -L2 * np.sin(th2) / L3
    th3 = np.arcsin(s3)
    c3 = np.cos(th3)
    th3d = -L2 * w * np.cos(th2) / (L3 * c3)
    x4 = L2 * np.cos(th2) + L3 * c3
    x4d = -L2 * w * np.sin(th2) - L3 * th3d * s3
    return np.array([th3, x4, th3d, x4d])


def initial_state(mech: SliderCrank, offset: float = 0.0) -> np.ndarray:
    """Ideal-joint positions and velocities (state y0), journal centred in the bearing.

    `offset` in [-1, 1] moves the slider so that the journal centre starts at
    offset * clearance along x from the bearing centre (+-1: touching the wall, a grazing
    start), used by the stress tests.
    """
    q = ideal_kinematics(mech.crank_length, mech.coupler_length, mech.crank_speed,
                         mech.initial_crank_angle)
    q[1] -= offset * mech.clearance
    return np.append(q, 0.0)


# ---------------------------------------------------------------------------- driver

#: hysteresis factor xi (contact.py) above which the contact law counts as damping-dominated
#: (the damping term exceeds the spring term xi-fold at the impact speed) and the
#: penetration rate is put under error control too: Flores' law at e = 0.05 (xi = 30) and
#: 0.1 (xi = 14) missed 1e-5 on the first impact's peak without it; the laws with xi <= 1.5
#: (every restitution of the other two) met it (docs/performance.md, the accuracy map)
DAMPED_XI = 4.0

#: absolute tolerance of the penetration rate of a damping-dominated law, in clearance x
#: crank speed x rtol, divided by xi (the force's relative error goes as xi times the rate's)
DAMPED_RATE_ATOL = 1e4

def default_atol(mech: SliderCrank, rtol: float) -> np.ndarray:
    """Absolute tolerances per state component from the mechanism's natural scales."""
    L = mech.crank_length + mech.coupler_length
    w = mech.crank_speed
    return rtol * np.array([1.0, L, w, w * mech.crank_length, 1.0])


def window_edges(mech: SliderCrank, revolutions: int, max_memory: int | None = None
                 ) -> np.ndarray:
    """Times of the crank revolution boundaries 0, T, ..., revolutions*T (refused with
    `MemoryLimitError` if the per-revolution arrays alone exceed `max_memory` bytes)."""
    if max_memory is not None:
        check_revolutions_memory(revolutions, max_memory)
    return np.arange(revolutions + 1) * mech.period


#: bytes per revolution window held during a run: its edge, refined peak and peak time
WINDOW_BYTES = REVOLUTION_BYTES

#: largest `n_samples` (interior event samples per step) accepted
MAX_SAMPLES = 1000

#: runs of at least this many revolutions are preceded by a one-revolution pilot (no
#: record) whose step count estimates the run's steps and memory; it costs at most 1/16
#: of the run and turns a run that would stop at max_steps or max_memory into an
#: immediate refusal
PILOT_MIN_REVOLUTIONS = 16

#: the sensitivity system's steps per plain step at the same tolerance (measured on the
#: paper case, 4 revolutions, eight parameters, dop853: 5823 / 2534 = 2.3, rounded up; used
#: only by the pilot's estimate)
SYSTEM_STEP_FACTOR = 2.5


def _record_row(system) -> int:
    """Floats recorded per step: time, state, memory and outputs."""
    if system is None:
        return 1 + N_STATE + N_MEM + MODEL.N_OUT
    return 1 + len(system.y0) + max(system.n_mem, 1) + system.n_out


def bytes_per_step(row: int) -> int:
    """Peak bytes per recorded step: the record (row floats) grows by doubling, so up to
    3 rows are alive while it is copied; the Trajectory's 15 columns and the times' copy
    (16 floats) are built while the record is alive."""
    return 8 * (3 * row + 16)


def estimate_run(mech: SliderCrank, windows: int, *, window_time: float, record: bool,
                 row: int, max_steps: int, h_max: float, max_memory: int,
                 pilot: dict | None = None) -> dict:
    """Estimated steps and peak memory (bytes) of a run over `windows` windows up to
    `window_time` s; raises `MemoryLimitError` before the run if it cannot fit.

    Checks, cheapest first: the per-window arrays; the steps that h_max alone forces
    (window_time / h_max) against max_steps; then, for runs of `PILOT_MIN_REVOLUTIONS` or
    more, a one-revolution pilot without record (`pilot`: its rtol, atol, method; the
    sensitivity system's steps are taken as SYSTEM_STEP_FACTOR plain steps) gives the
    steps per revolution, and the estimated steps and memory are checked against max_steps
    and max_memory. Returns dict(steps=estimate or None, bytes=estimate, step_cap=the
    largest number of recorded steps that fits in max_memory, or None without record).
    """
    window_bytes = revolution_bytes(windows)
    if window_bytes > max_memory:
        window_edges(mech, windows, max_memory)       # raises with the message
    revolutions = window_time / mech.period
    forced = math.ceil(window_time / h_max)
    if forced > max_steps:
        raise MemoryLimitError(
            f"a run of {revolutions:.6g} revolutions with h_max = {h_max:.3g} s takes at least "
            f"{forced:.3g} steps, more than max_steps={max_steps}; raise h_max or max_steps, "
            "or run fewer revolutions")
    per_step = bytes_per_step(row) if record else 0
    steps = None
    if pilot is not None and revolutions >= PILOT_MIN_REVOLUTIONS:
        factor = 1.0 if row == _record_row(None) else SYSTEM_STEP_FACTOR
        try:
            counters = run(mech, 1, record=False, max_steps=max_steps, h_max=h_max,
                           **pilot).counters
            per_rev = factor * (int(counters[1]) + int(counters[2]))
        except RuntimeError:
            per_rev = float(max_steps)
        steps = int(math.ceil(per_rev * revolutions))
        if steps > max_steps:
            raise MemoryLimitError(
                f"a run of {revolutions:.6g} revolutions needs about {steps:.3g} steps "
                f"({per_rev:.4g} in the first revolution), more than max_steps={max_steps}; "
                "raise max_steps or run fewer revolutions")
    need = window_bytes + per_step * (steps if steps is not None else 0)
    if need > max_memory:
        raise MemoryLimitError(
            f"a run of {revolutions:.6g} revolutions needs about {format_bytes(need)} "
            f"({steps:.3g} recorded steps of {per_step} bytes), more than max_memory="
            f"{max_memory} bytes ({format_bytes(max_memory)}); raise max_memory, run fewer "
            "revolutions, or use peak_base_force (records nothing)")
    cap = (max_memory - window_bytes) // per_step if record else None
    return {"steps": steps, "bytes": need, "step_cap": cap}


class System(NamedTuple):
    """An ODE system for the integrator: the plain model or one augmented with more states
    (the sensitivity equations). `kernel` is `integrator.integrate` bound to the system's
    right-hand side and event action (a cached wrapper such as `integrate_plain`)."""

    kernel: Any
    y0: np.ndarray
    p: np.ndarray
    mem_start: int
    n_mem: int
    n_err: int
    atol: np.ndarray
    #: outputs its monitor writes at each step, recorded (0: none)
    n_out: int = 0
    #: names of those outputs (the generated model's OUT_COLUMNS)
    columns: tuple | None = None


#: `integrate` bound to the generated model's kernels (compiled once, cached): the plain run
integrate_plain = MODEL.integrate_model


def plain_system(mech: SliderCrank, atol: np.ndarray, initial_offset: float = 0.0
                 ) -> System:
    """The plain model of `mech` as a `System`: the generated model's kernels, the centred
    start (`initial_state`), its parameters (`model_parameters`) and `atol` (N_STATE entries,
    plus optionally the switching function's and its rate's)."""
    return System(_THIS.integrate_plain, initial_state(mech, initial_offset),
                  model_parameters(mech), MEM_START, N_MEM, N_ERR, atol, MODEL.N_OUT,
                  MODEL.OUT_COLUMNS)


class RunOutput(NamedTuple):
    """What `run` returns: the recorded times, states, memories (mode and impact velocity)
    and outputs (MODEL.OUT_COLUMNS) per step, the refined peak of |F12| and its time per
    window, the integrator's counters (`COUNTERS`) and the parameter vector."""

    ts: np.ndarray
    ys: np.ndarray
    ms: np.ndarray
    peaks: np.ndarray
    peak_times: np.ndarray
    counters: np.ndarray
    outs: np.ndarray
    p: np.ndarray


def run(mech: SliderCrank, revolutions: int = 4, *, rtol: float | None = None,
        atol: float | np.ndarray | None = None, method: str = "dopri5", record: bool = True,
        max_steps: int = DEFAULT_MAX_STEPS, n_samples: int = 1, h_max: float | None = None,
        h0: float = 0.0, event_tol: float | None = None, edges: np.ndarray | None = None,
        t_eval: np.ndarray | None = None, system=None, select: bool = True,
        initial_offset: float = 0.0, max_memory: int | None = None):
    """Integrate the reduced model; returns a `RunOutput` (ts, ys, ms, peaks, peak_times,
    counters, outs, p) with outs the generated model's outputs (MODEL.OUT_COLUMNS) at the
    recorded steps.

    The integration runs over the crank revolutions 1..`revolutions`, or over the windows
    given by `edges` (times, increasing, from 0); `peaks` holds max |F12| per window, refined
    between steps. With `t_eval` the integrator also lands exactly on those times and only
    they are returned (peaks are then maxima over the returned samples, not refined;
    ``select=False`` returns all steps, which include the times `t_eval`).
    `system` (a `System`) replaces the plain model (`plain_system`; another system: the
    sensitivity equations), whose parameters `p` are returned.
    Every option is checked first (ValueError naming it and its range); then the run's
    memory and steps are estimated (`estimate_run`) and a run above ``max_memory`` bytes
    (default `_checks.default_max_memory`) or ``max_steps`` is refused with
    `_checks.MemoryLimitError` (a ValueError) before anything is allocated.
    Raises RuntimeError with advice when it cannot finish.
    """
    revolutions = check_int("revolutions", revolutions, 1)
    rtol, atol_arr = _tolerances(mech, rtol, atol)
    check_choice("method", method, METHODS)
    record = check_bool("record", record)
    max_steps = check_int("max_steps", max_steps, 1)
    n_samples = check_int("n_samples (interior event samples per step)", n_samples, 0,
                          MAX_SAMPLES)
    h0 = check_real("h0 (initial step; 0: automatic)", h0, 0.0, unit="s")
    max_memory = check_max_memory(max_memory)
    if rtol > LOOSE_RTOL:
        warnings.warn(f"rtol {rtol:g} is too loose to resolve the contacts (looser than "
                      f"{LOOSE_RTOL:g}: spurious contact events and peak forces wrong by any "
                      f"amount); use rtol <= {LOOSE_RTOL:g}, the default is {DEFAULT_RTOL:g}",
                      AccuracyWarning, stacklevel=3)
    tab = METHODS[method]
    if edges is None:
        edges = window_edges(mech, revolutions, max_memory)
    else:
        edges = np.ascontiguousarray(edges, dtype=float)
        if (edges.ndim != 1 or len(edges) < 2 or edges[0] != 0.0
                or not np.all(np.isfinite(edges)) or np.any(np.diff(edges) <= 0)):
            raise ValueError("edges must be increasing finite times starting at 0.0")
    h_max = mech.period / 8 if h_max is None else check_real(
        "h_max (largest step)", h_max, 0.0, low_open=True, unit="s")
    if event_tol is None:
        # 1e-12 of the clearance, but not below the round-off of the journal position
        # (delta is a difference of coordinates of size L2 + L3)
        event_tol = max(1e-12 * mech.clearance,
                        8 * np.finfo(float).eps * (mech.crank_length + mech.coupler_length))
    else:
        event_tol = check_real("event_tol (penetration tolerance of events)", event_tol, 0.0,
                               low_open=True, unit="m")
    if system is None:
        initial_offset = check_real("initial_offset (fraction of the clearance)",
                                    initial_offset, -1.0, 1.0)
    win_edges = edges
    refine = REFINE_ITERS
    if t_eval is not None:
        t_eval, edges = landing_edges(edges, t_eval)
        record = True
        refine = 0
    est = estimate_run(mech, len(edges) - 1, window_time=float(edges[-1]), record=record,
                 row=_record_row(system), max_steps=max_steps, h_max=h_max,
                 max_memory=max_memory,
                 pilot=dict(rtol=rtol, atol=None if system is not None else atol_arr,
                            method=method))
    # the record never outgrows max_memory: a run that would stops there (and says so)
    step_limit = max_steps if est["step_cap"] is None else min(max_steps, est["step_cap"])
    if system is None:
        system = plain_system(mech, np.append(atol_arr, event_atol(mech, rtol)),
                              initial_offset)
    kernel, y0, p, mem_start, n_mem, n_err, atol_arr, n_out, _ = system
    if not record:
        n_out = 0
    settings = make_settings(rtol, atol_arr, n_err, h0=h0, h_max=h_max, max_steps=step_limit,
                             record=record, event_tol=event_tol,
                             event_margin=event_margin(mech.clearance, rtol), n_samples=n_samples,
                             refine_iters=refine, n_out=n_out, n_dense=N_EVENT, n_events=1,
                             mem_start=mem_start, n_mem=n_mem)
    ts, ys, ms, peaks, peak_t, counters, outs, status = kernel(y0, p, edges, settings,
                                                               tab.arrays())
    status = RESULTS(status)
    if status is RESULTS.max_steps and step_limit < max_steps:
        raise MemoryLimitError(
            f"the reduced model's record reached max_memory={max_memory} bytes "
            f"({format_bytes(max_memory)}) at t = {ts[-1]:.6g} s, after {step_limit} steps; "
            "raise max_memory, run fewer revolutions, or use peak_base_force")
    if status is not RESULTS.success:
        raise RuntimeError(f"reduced model integration failed at about t = "
                           f"{ts[-1] if len(ts) else float('nan'):.6g} s: "
                           f"{status.message}")
    if t_eval is not None and select:
        keep = landed_indices(ts, t_eval)
        ts, ys, ms, outs = ts[keep], ys[keep], ms[keep], outs[keep]
        if outs.shape[1] < MODEL.N_OUT:          # no outputs recorded: evaluated here
            outs = MODEL.outputs(np.ascontiguousarray(ts), np.ascontiguousarray(ys),
                                 np.ascontiguousarray(ms[:, :N_MEM]), p)
        peaks = window_peaks(ts, outs, MODEL.MONITOR_COLUMN, win_edges)
    return RunOutput(ts, ys, ms, peaks, peak_t, counters, outs, p)


def _tolerances(mech, rtol, atol):
    rtol = DEFAULT_RTOL if rtol is None else check_real("rtol", rtol, 1e-14, 1e-2)
    if atol is None:
        atol_arr = default_atol(mech, rtol)
    else:
        try:
            atol_arr = np.broadcast_to(np.asarray(atol, dtype=float), (N_STATE,)).copy()
        except (TypeError, ValueError):
            atol_arr = None
        if (atol_arr is None or not np.all(np.isfinite(atol_arr)) or np.any(atol_arr <= 0)
                or isinstance(atol, (bool, np.bool_))):
            raise ValueError(f"atol must be a finite number > 0 or {N_STATE} of them (one per "
                             f"state component); got {atol!r}")
    return rtol, atol_arr


def event_atol(mech: SliderCrank, rtol: float) -> np.ndarray:
    """Absolute tolerances of the switching function (penetration, m) and its rate (m/s),
    appended to the state's atol of the plain model: the penetration's error is controlled
    at the clearance's scale; its rate only through the state (a tolerance on it at the
    clearance's scale cost more than it gained, docs/performance.md), except for a
    damping-dominated contact law (hysteresis factor xi > DAMPED_XI), whose force follows
    the rate with weight xi: there the rate's atol is rtol x DAMPED_RATE_ATOL / xi x
    clearance x crank speed."""
    xi = hysteresis_factor(mech.restitution, CONTACT_MODELS[mech.contact_model])[0]
    rate = (rtol * DAMPED_RATE_ATOL / xi * mech.clearance * mech.crank_speed
            if xi > DAMPED_XI else np.inf)
    return np.array([rtol * EVENT_ATOL * mech.clearance, rate])


def counters_dict(counters) -> dict:
    """Solver counters (`integrator.COUNTERS`) as a dict."""
    return {k: int(v) for k, v in zip(COUNTERS, counters)}


#: options of `simulate(..., backend="reduced")` (keywords of `run` meant for users)
OPTION_NAMES = ("rtol", "atol", "method", "max_steps", "n_samples", "h_max", "h0",
                "event_tol", "t_eval", "initial_offset", "max_memory")


def simulate_reduced(mech: SliderCrank, revolutions: int = 4, **options):
    """Simulate with the reduced model and return a `Trajectory` (all accepted steps, or the
    times `t_eval` if given)."""
    if mech.friction_law != "none":
        return _with_friction(mech, revolutions, options, record=True)
    ts, ys, ms, peaks, peak_t, counters, outs, p = run(mech, revolutions, record=True,
                                                       **options)
    stats = counters_dict(counters)
    rtol = options.get("rtol")
    stats.update(method=options.get("method", "dopri5"),
                 rtol=DEFAULT_RTOL if rtol is None else float(rtol))
    if options.get("t_eval") is None:
        stats["floored_impacts"] = floored_impacts(ms, mech.impact_velocity_floor)
    stats.update(accuracy_flags(mech, revolutions, ms, stats["nevent"], stats["rtol"]))
    if stats["accuracy_note"]:
        warnings.warn(stats["accuracy_note"], AccuracyWarning, stacklevel=3)
    traj = trajectory_from_states(mech, ts, ys, ms, p, stats,
                                  None if options.get("t_eval") is not None else peaks, outs,
                                  MODEL.OUT_COLUMNS)
    return annotate(traj)


def accuracy_flags(mech: SliderCrank, revolutions: int, ms: np.ndarray, nevent: int,
                   rtol: float) -> dict:
    """Whether a run is where the accuracy map (docs/performance.md) found the stated
    accuracy (1e-5 on every per-revolution peak at the default rtol) missed: grazing onsets,
    or a slow settling (SETTLING_ONSETS or more impacts before a lasting contact, whose late
    peaks ride on a lightly damped contact vibration), or a loose rtol. Returns the stats
    entries grazing_onsets, accuracy_ok and accuracy_note (the warning's text, "" for none).

    A rattling run (`rattles`) is not periodic: its late peaks depend on every digit and no
    tolerance makes them accurate; it is flagged (accuracy_ok False) with a note saying so.
    Every run flagged has a note, except one at an rtol looser than LOOSE_RTOL, which `run`
    has warned about already."""
    return contact_flags([mech.clearance], mech.crank_speed, revolutions, ms, nevent, rtol)


def grazing_onsets(mech: SliderCrank, ms: np.ndarray) -> int:
    """Contact onsets among the recorded memories whose impact velocity is below
    GRAZING_ONSET x clearance x crank speed (where the accuracy map found the 1e-5 target
    missed at the default tolerance). A contact present at the start (the journal placed
    on the wall) counts as an onset at the floor velocity: its damping follows the
    penetration rate with weight xi / floor (measured: journal on the far wall, 3.4e-5)."""
    return grazing_onsets_of(ms, mech.clearance * mech.crank_speed)


#: the output columns of a Trajectory's series (base force x, y, eccentricity x, y, crank
#: moment, contact force, penetration, slider acceleration), by name in the generated
#: model's outputs
_SERIES = ("crank_pivot.reaction_x", "crank_pivot.reaction_y", "coupler_slider.ecc_x",
           "coupler_slider.ecc_y", "drive_moment", "coupler_slider.contact_force",
           "coupler_slider.penetration", "slider_guide.s.acc")


def _series_columns(columns) -> np.ndarray:
    """Indices of the `_SERIES` columns in the output layout `columns`."""
    names = tuple(columns)
    return np.array([names.index(a) for a in _SERIES], dtype=np.int64)


@nb.njit(cache=True)
def _columns(ys, ms, out, col):
    """The time series of a `Trajectory` from states, memories and outputs (the `_SERIES`
    columns col of out), in one pass: base_force, crank_moment, contact_force, penetration,
    eccentricity, slider_position, slider_velocity, slider_acceleration, coupler_angle,
    coupler_rate, contact_phase, crank_work (a copy of a strided column each, with numpy,
    took 0.18 ms, 3 % of the paper case's simulation; this takes 0.05 ms)."""
    m = ys.shape[0]
    last = ys.shape[1] - 1
    base_force = np.empty((m, 2))
    eccentricity = np.empty((m, 2))
    crank_moment = np.empty(m)
    contact_force = np.empty(m)
    penetration = np.empty(m)
    slider_position = np.empty(m)
    slider_velocity = np.empty(m)
    slider_acceleration = np.empty(m)
    coupler_angle = np.empty(m)
    coupler_rate = np.empty(m)
    contact_phase = np.empty(m, dtype=np.int8)
    crank_work = np.empty(m)
    for i in range(m):
        base_force[i, 0] = out[i, col[0]]
        base_force[i, 1] = out[i, col[1]]
        eccentricity[i, 0] = out[i, col[2]]
        eccentricity[i, 1] = out[i, col[3]]
        crank_moment[i] = out[i, col[4]]
        contact_force[i] = out[i, col[5]]
        penetration[i] = out[i, col[6]]
        slider_acceleration[i] = out[i, col[7]]
        coupler_angle[i] = ys[i, 0]
        slider_position[i] = ys[i, 1]
        coupler_rate[i] = ys[i, 2]
        slider_velocity[i] = ys[i, 3]
        crank_work[i] = ys[i, last]
        contact_phase[i] = 1 if ms[i, 0] > 0.5 else 0
    return (base_force, crank_moment, contact_force, penetration, eccentricity,
            slider_position, slider_velocity, slider_acceleration, coupler_angle, coupler_rate,
            contact_phase, crank_work)


def trajectory_from_states(mech, ts, ys, ms, p, stats, peaks, outs=None,
                           columns=MODEL.OUT_COLUMNS):
    """Build a `Trajectory` from recorded states [theta3, x4, theta3dot, x4dot, ..., W],
    memories [mode, dmin, ...] and, if recorded by the integrator, the generated model's
    outputs named `columns` (read in place, not copied, with any strides: a DDM run's are
    columns of its record); without outputs they are evaluated
    here from the model's parameters p."""
    from .trajectory import Trajectory

    ys = np.ascontiguousarray(ys)
    ms = np.ascontiguousarray(ms)
    if outs is None or outs.shape[1] == 0:
        out = MODEL.outputs(np.ascontiguousarray(ts), ys, np.ascontiguousarray(ms[:, :N_MEM]),
                            p)
        columns = MODEL.OUT_COLUMNS
    else:
        out = outs
    (base_force, crank_moment, contact_force, penetration, eccentricity, slider_position,
     slider_velocity, slider_acceleration, coupler_angle, coupler_rate, contact_phase,
     crank_work) = _columns(ys, ms, out, _series_columns(columns))
    return Trajectory(
        t=ts,
        base_force=base_force,
        crank_moment=crank_moment,
        contact_force=contact_force,
        penetration=penetration,
        eccentricity=eccentricity,
        slider_position=slider_position,
        slider_velocity=slider_velocity,
        slider_acceleration=slider_acceleration,
        coupler_angle=coupler_angle,
        coupler_rate=coupler_rate,
        contact_phase=contact_phase,
        crank_work=crank_work,
        mechanism=mech,
        backend="reduced",
        stats=stats,
        peaks=peaks,
    )


def peak_reduced(mech: SliderCrank, revolution: int = 4, **options) -> float:
    """Max |F12| in N over revolution `revolution`, recording nothing but running maxima."""
    if mech.friction_law != "none":
        return _with_friction(mech, revolution, options, record=False)
    peaks = run(mech, revolution, record=False, **options).peaks
    return float(peaks[revolution - 1])


def _with_friction(mech: SliderCrank, revolutions: int, options: dict, record: bool):
    """A SliderCrank with friction in its joint runs on the model generated for its
    description (`cases.from_slider_crank`, whose structure has the tangential force;
    `linkage_model`): its Trajectory in a SliderCrank's form (with the friction work), or
    (record False) the peak of revolution `revolutions`."""
    import dataclasses

    from ..model.cases import from_slider_crank
    from . import linkage_model as lm

    unknown = sorted(set(options) - set(lm.OPTION_NAMES))
    if unknown:
        raise ValueError(f"option(s) {unknown} are not available for a SliderCrank with "
                         f"friction (friction_law {mech.friction_law!r}); allowed: "
                         f"{list(lm.OPTION_NAMES)}")
    lk = from_slider_crank(mech)
    if not record:
        return lm.peak_linkage(lk, revolutions, **options)
    traj = lm.simulate_linkage(lk, revolutions, **options)
    pos, rate, acc = traj.coordinates, traj.rates, traj.accelerations
    return dataclasses.replace(
        traj, mechanism=mech, contact_force=traj.contact_force[:, 0],
        penetration=traj.penetration[:, 0], eccentricity=traj.eccentricity[:, 0, :],
        contact_phase=traj.contact_phase[:, 0], slider_position=pos["slider_guide.s"],
        slider_velocity=rate["slider_guide.s"], slider_acceleration=acc["slider_guide.s"],
        coupler_angle=pos["coupler.angle"], coupler_rate=rate["coupler.angle"], joints=None,
        reactions=None, shaking_force=None, coordinates=None, rates=None,
        accelerations=None)
