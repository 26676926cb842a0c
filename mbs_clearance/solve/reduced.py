"""The paper's slider-crank (`SliderCrank`) on the reduced model: its named parameter set
run as its description, and its `Trajectory` as the paper's case (`paper_series`).

A `SliderCrank` is the paper's parameter set of one linkage: its runs integrate its
description (`cases.from_slider_crank`, whose compiled model is `MODEL` for the paper's
parameter set, or the one with the tangential force for a joint with friction) through
`linkage_model.run`, the one plain run of every linkage.
This module adds only what is the paper's own: the closed-form centred start (and the
stress tests' offset start), and the Trajectory's series of its one clearance joint as
(n,) arrays (F12 is `base_force`; the slider position and coupler angle are the
description's coordinates, read by their paper names through `trajectory.PAPER_SERIES`).
Generalized coordinates theta3 (coupler angle) and x4
(slider position); the crank angle is prescribed, theta2 = omega2 t + theta20. State y =
[theta3, x4, theta3dot, x4dot, W] where W is the work done by the crank drive (a quadrature,
kept out of error control). The clearance joint's memory (contact mode, impact velocity
deltadot_minus, set exactly at the located onset) is p[MEM_START:MEM_START + 2] of the
model's parameter vector (`model_parameters`).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from .._checks import check_real, check_revolutions_memory
from ..model.mechanism import SliderCrank
from ..numerics.integrator import COUNTERS
from . import linkage_model as lm
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
from .linkage_model import (  # noqa: F401 - the settings shared with every linkage's runs
    DAMPED_RATE_ATOL,
    DAMPED_XI,
    DEFAULT_MAX_STEPS,
    DEFAULT_RTOL,
    EVENT_ATOL,
    MAX_SAMPLES,
    REFINE_ITERS,
    Start,
    event_margin,
)


# ---- the compiled model's layout (every SliderCrank without friction maps to its
# structure): MODEL (the compiled model of the paper's description), MEM_START (the clearance
# joint's memory, mode and impact velocity, in its p), MODEL_COLUMNS (the outputs a plain run
# records) and P_CLEARANCE (the clearance's index in p), read on first use (the model is
# built or found in the compiled-code cache then)
def __getattr__(name: str):
    if name not in ("MODEL", "MEM_START", "MODEL_COLUMNS", "P_CLEARANCE"):
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    model = _paper_model()
    return {"MODEL": model, "MEM_START": model.MEM_START, "MODEL_COLUMNS": model.OUT_COLUMNS,
            "P_CLEARANCE": model.PARAMETERS.index(f"{model.JOINTS[0]}.clearance")}[name]


@functools.lru_cache(maxsize=1)
def _paper_model():
    # one look-up per process: building the description to find its model costs ~0.2 ms
    return lm.load_model(linkage_of(SliderCrank()))


N_MEM = 2          # the joint's mode and impact velocity
N_STATE = 5        # theta3, x4, theta3dot, x4dot, W
N_ERR = 4          # W is a quadrature, not under error control
N_EVENT = 4        # the event function reads theta3, x4 and their rates only (rhs needs
                   # no more: the integrator's continuous extension is formed for these)


@functools.lru_cache(maxsize=256)
def _model_parameters(mech: SliderCrank) -> np.ndarray:
    from ..model.cases import from_slider_crank
    from .linkage_model import pack_parameters as pack

    p = pack(from_slider_crank(mech), _paper_model())
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


# ---------------------------------------------------------------------------- runs

@functools.lru_cache(maxsize=256)
def linkage_of(mech: SliderCrank):
    """The description of `mech` (`cases.from_slider_crank`, cached per mechanism): what
    its runs integrate, with `linkage_model.run`."""
    from ..model.cases import from_slider_crank

    return from_slider_crank(mech)


def model_of(mech: SliderCrank):
    """The compiled model of `mech`'s description for a plain run (`linkage_model.load_model`):
    the paper's model, or its variant with the tangential force for a joint with friction
    (any law: a parameter)."""
    return lm.load_model(linkage_of(mech))


def centred_start(mech: SliderCrank, offset: float = 0.0) -> Start:
    """The run's start: the ideal joints' closed-form state (`initial_state`), the joint in
    free flight with its floor as impact velocity (the centred start, offset 0)."""
    return Start(y=initial_state(mech, offset)[:4], modes=np.zeros(1),
                 impact_velocities=np.array([mech.impact_velocity_floor]), revolutions=0,
                 linkage=linkage_of(mech).name)


def default_atol(mech: SliderCrank, rtol: float) -> np.ndarray:
    """Absolute tolerances per state component from the mechanism's natural scales (those
    of its description, `linkage_model.default_atol`)."""
    lk = linkage_of(mech)
    return lm.default_atol(lk, model_of(mech), rtol)[:N_STATE]


def event_atol(mech: SliderCrank, rtol: float) -> np.ndarray:
    """Absolute tolerances of the switching function (penetration, m) and its rate (m/s)
    (`linkage_model.event_atol`)."""
    return lm.event_atol(linkage_of(mech).clearance_joints[0], mech.crank_speed, rtol)


def window_edges(mech: SliderCrank, revolutions: int, max_memory: int | None = None
                 ) -> np.ndarray:
    """Times of the crank revolution boundaries 0, T, ..., revolutions*T (refused with
    `MemoryLimitError` if the per-revolution arrays alone exceed `max_memory` bytes)."""
    if max_memory is not None:
        check_revolutions_memory(revolutions, max_memory)
    return np.arange(revolutions + 1) * mech.period


class RunOutput(NamedTuple):
    """What `run` returns: the recorded times, states, memories (mode and impact velocity)
    and outputs (the model's OUT_COLUMNS) per step, the refined peak of |F12| and its time
    per window, the integrator's counters (`COUNTERS`) and the parameter vector."""

    ts: np.ndarray
    ys: np.ndarray
    ms: np.ndarray
    peaks: np.ndarray
    peak_times: np.ndarray
    counters: np.ndarray
    outs: np.ndarray
    p: np.ndarray


def run(mech: SliderCrank, revolutions: int = 4, *, initial_offset: float = 0.0,
        **options) -> RunOutput:
    """Integrate the paper's mechanism `mech`: `linkage_model.run` of its description
    (`options`: that function's), from the closed-form centred start or, with
    `initial_offset` in [-1, 1], with the slider moved so that the journal centre starts at
    initial_offset x clearance along x from the bearing centre (+-1: on the wall, a grazing
    start). Returns a `RunOutput` (ts, ys, ms, peaks, peak_times, counters, outs, p)."""
    from ..model.cases import door

    if not door(mech).given_as_paper:
        raise ValueError(f"mech must be a SliderCrank; got {type(mech).__name__}")
    if "start" in options:
        raise ValueError("start is not an option of a SliderCrank's run; use its "
                         "description (reduced.linkage_of) with linkage_model.run")
    initial_offset = check_real("initial_offset (fraction of the clearance)",
                                initial_offset, -1.0, 1.0)
    out = lm.run(linkage_of(mech), revolutions, start=centred_start(mech, initial_offset),
                 model=model_of(mech), **options)
    counters = np.array([out.stats[k] for k in COUNTERS], dtype=np.int64)
    return RunOutput(out.ts, out.ys, out.ms, out.peaks, out.peak_times, counters, out.outs,
                     out.p)


def counters_dict(counters) -> dict:
    """Solver counters (`integrator.COUNTERS`) as a dict."""
    return {k: int(v) for k, v in zip(COUNTERS, counters)}


def grazing_onsets(mech: SliderCrank, ms: np.ndarray) -> int:
    """Contact onsets among the recorded memories whose impact velocity is below
    GRAZING_ONSET x clearance x crank speed (where the accuracy map found the 1e-5 target
    missed at the default tolerance). A contact present at the start (the journal placed
    on the wall) counts as an onset at the floor velocity: its damping follows the
    penetration rate with weight xi / floor (measured: journal on the far wall, 3.4e-5)."""
    return grazing_onsets_of(ms, mech.clearance * mech.crank_speed)


#: the output columns of a Trajectory's series (base force x, y, eccentricity x, y, crank
#: moment, contact force, penetration), by name in the generated model's outputs
_SERIES = ("crank_pivot.reaction_x", "crank_pivot.reaction_y", "coupler_slider.ecc_x",
           "coupler_slider.ecc_y", "drive_moment", "coupler_slider.contact_force",
           "coupler_slider.penetration")


def _series_columns(columns) -> np.ndarray:
    """Indices of the `_SERIES` columns in the output layout `columns`."""
    names = tuple(columns)
    return np.array([names.index(a) for a in _SERIES], dtype=np.int64)


def _columns(ys, ms, out, col, work):
    """The paper's clearance joint's and drive's series of a `Trajectory` from states,
    memories and outputs (the `_SERIES` columns col of out): base_force, crank_moment,
    contact_force, penetration, eccentricity, contact_phase, crank_work, each a contiguous
    copy (the coordinates are the generic series, `linkage_model.named_series`)."""
    def column(a, k):
        return np.ascontiguousarray(a[:, k])

    return (np.ascontiguousarray(out[:, col[:2]]), column(out, col[4]), column(out, col[5]),
            column(out, col[6]), np.ascontiguousarray(out[:, col[2:4]]),
            (ms[:, 0] > 0.5).astype(np.int8), column(ys, work))


def trajectory_from_states(mech, ts, ys, ms, p, stats, peaks, outs=None,
                           columns=None, model=None):
    """Build a `Trajectory` of the paper's case (its clearance joint's series as (n,)
    arrays, the coordinates and reactions by the description's names,
    `linkage_model.named_series`) from recorded states [theta3, x4, theta3dot,
    x4dot, W (, friction work)], memories [mode, dmin, ...] and, if recorded by the integrator, the
    outputs of `model` named `columns` (read in place, with any strides: a DDM run's are
    columns of its record); without outputs they are evaluated here from the model's
    parameters p."""
    from .trajectory import Trajectory

    model = _paper_model() if model is None else model
    columns = model.OUT_COLUMNS if columns is None else columns
    ys = np.ascontiguousarray(ys)
    ms = np.ascontiguousarray(ms)
    if outs is None or outs.shape[1] == 0:
        out = model.outputs(np.ascontiguousarray(ts), ys, np.ascontiguousarray(ms[:, :N_MEM]),
                            p)
        columns = model.OUT_COLUMNS
    else:
        out = outs
    (base_force, crank_moment, contact_force, penetration, eccentricity, contact_phase,
     crank_work) = _columns(ys, ms, out, _series_columns(columns), 2 * model.N_Q)
    friction = getattr(model, "FRICTION_WORK", -1)
    generic = lm.named_series(model, ys, out, columns)
    return Trajectory(
        t=ts,
        base_force=base_force,
        crank_moment=crank_moment,
        contact_force=contact_force,
        penetration=penetration,
        eccentricity=eccentricity,
        contact_phase=contact_phase,
        crank_work=crank_work,
        mechanism=mech,
        backend="reduced",
        stats=stats,
        peaks=peaks,
        friction_work=(ys[:, friction].copy() if 0 < friction < ys.shape[1] else None),
        **generic,
    )


def paper_series(traj, mech: SliderCrank, sampled: bool = False):
    """`traj`, a run of `mech`'s description (`cases.door`), as a run of `mech`: its
    clearance joint's series as (n,) arrays, `mech` as its mechanism (its closed-form
    start: no `start_revolutions`; `sampled`, a run on given output times: no peaks). The
    description's generic series (`joints`, `reactions`, `coordinates`, ...) stay: the
    paper's names (slider_position, ...) are read from them (`trajectory.PAPER_SERIES`)."""
    import dataclasses

    def first(a):
        return None if a is None else np.ascontiguousarray(a[:, 0]) if a.ndim > 1 else a

    series = dict(
        contact_force=first(traj.contact_force), penetration=first(traj.penetration),
        eccentricity=(np.ascontiguousarray(traj.eccentricity[:, 0])
                      if traj.eccentricity.ndim == 3 else traj.eccentricity),
        contact_phase=first(traj.contact_phase),
        friction_work=first(traj.friction_work) if traj.backend == "reduced" else None,
        contact_angle=None, slip_velocity=None, mechanism=mech,
        peaks=None if sampled else traj.peaks,
        stats={k: v for k, v in traj.stats.items()
               if not (k == "start_revolutions" and v == 0)})
    return dataclasses.replace(traj, **series)
