"""Any `Linkage` description built in the multibody engine Exudyn (backend "exudyn").

An independent implementation of the same description as the generated reduced model:
planar rigid bodies in absolute coordinates, ideal joints as algebraic constraints, solved
by Exudyn's implicit generalized-alpha integrator with a fixed step. Only the clearance
joints' contact law is ours; kinematics, mass matrices, constraint and reaction forces are
Exudyn's.

Model (`build`)
---------------
- every body: `NodeRigidBody2D` at its centre of mass + `ObjectRigidBody2D` (mass, inertia
  about the centre of mass); the ground is `ObjectGround`; gravity g along -y on every body
  (`LoadMassProportional`);
- `Revolute`: `RevoluteJoint2D` between `MarkerBodyPosition` markers at the two named
  points (a joint to the ground has the ground's marker first);
- `Prismatic`: `ObjectJointPrismatic2D` between `MarkerBodyRigid` markers at point_a of
  body_a (marker 0, axis (cos angle, sin angle) in body_a's frame) and point_b of body_b,
  with the relative rotation constrained (body_b keeps body_a's orientation);
- the `Drive`: a velocity-level `CoordinateConstraint` on the driven body's rotation
  coordinate (dphi/dt = speed); its Lagrange multiplier lambda gives the drive moment
  -lambda (Exudyn adds C_q^T lambda on the left-hand side);
- each joint of an element kind (`elements.registry`: the revolute clearance joint, the
  translational clearance joint): what its element module builds (`Element.exudyn_build`:
  a revolute clearance joint's contact connector with our contact law, its friction and
  oil film as generic elements, see `elements.revolute`; a translational joint's corners
  as one generic element, see `elements.translational`), in the registry's order. The
  generic elements are `ObjectGenericODE2`s on the bodies' nodes (`_generic_element`,
  `_Side`) whose force function is the element's, symbolic (`_symbolic_vector_function`)
  or Python;
- every contact with a user force has its own impact-velocity memory (`ImpactMemory`): a
  pre-step function (one Python call per time step for all contacts, never inside Newton)
  reads each contact's penetration and rate from its element's gap function, registers
  the onsets (penetration crossing zero upward) and sets the contact's named symbolic
  variable deltadot_minus where it has one, second-order accurate (`_pre_step`, option
  ``onset``).

Outputs from Exudyn's own sensors (stored in memory every step): the force of each ground
joint's constraint or contact (the reaction on the ground), the drive constraint's
multiplier, the displacement and force of the contacts an element asks for, and every body
node's coordinates, velocities and accelerations (the minimal coordinates of the
description are computed from those, and the elements' series and remaining ground
reactions, `Element.exudyn_series`).

The initial state is the reduced model's (`linkage_model.initial_state`: journals centred),
carried to the bodies by the forest's kinematics (`body_states`).

Step size (`ExudynSettings`): a fixed step ``step_size`` in s; if None, the step of
``steps_per_revolution`` (default `DEFAULT_STEPS_PER_REVOLUTION`) or, with ``accuracy``, the
step that gives that relative error of the monitored peak by the method's second order
(`step_for_accuracy`), at most a `STEPS_PER_CONTACT_PERIOD`-th of the contacts' linearised
period. Newton's tolerance: `NEWTON_TOLERANCE`, or `ROUNDOFF_MARGIN` times the contact
force's roundoff floor where that is higher (`contact_scales`; docs/exudyn.md).
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import time
from dataclasses import asdict, dataclass, field, replace
from types import SimpleNamespace

import numpy as np

from .._checks import (
    MemoryLimitError,
    check_bool,
    check_choice,
    check_int,
    check_max_memory,
    check_real,
    format_bytes,
)
from ..elements.registry import elements_with
from ..model.linkage import GROUND, Linkage, Prismatic, Revolute
from ..solve.problem import Span

__all__ = ["ExudynSettings", "make_settings", "build", "solve", "simulate_exudyn_linkage",
           "peak_exudyn_linkage", "run_linkage", "peak_run", "body_states",
           "step_for_accuracy", "refined_peaks", "refine_peak", "CONTACT_VARIANTS",
           "ONSET_MODES", "OPTION_NAMES", "DEFAULT_STEPS_PER_REVOLUTION",
           "ACCURACY_AT_DEFAULT", "ExudynModel", "contact_scales", "NEWTON_TOLERANCE",
           "ROUNDOFF_MARGIN", "STEPS_PER_CONTACT_PERIOD"]

#: the elements whose Exudyn element this backend builds (`elements.registry`)
_ELEMENTS = elements_with("Exudyn element")

#: clearance-joint implementations (option ``contact``)
CONTACT_VARIANTS: tuple[str, ...] = ("symbolic", "python", "sphere")

ONSET_MODES: tuple[str, ...] = ("predict", "detect")

#: default fixed steps per drive revolution: 2e-6 s in the paper case (5000 rpm), where the
#: 4th-revolution peak is within 3e-4 of the tight reduced reference (docs/exudyn.md lists
#: the error of this default for every named case, measured)
DEFAULT_STEPS_PER_REVOLUTION = 6000

#: relative error of the monitored 4th-revolution peak at DEFAULT_STEPS_PER_REVOLUTION,
#: the reference point of `step_for_accuracy`'s second-order law (the paper case's,
#: measured; other cases are checked against it in tests/integration/test_exudyn_linkage.py)
ACCURACY_AT_DEFAULT = 3e-4


@dataclass(frozen=True)
class ExudynSettings:
    """Integrator and model settings of the Exudyn backend (its options).

    Parameters
    ----------
    step_size : float or None
        Fixed time step in s (> 0); None: from ``accuracy`` or ``steps_per_revolution``.
    steps_per_revolution : int
        Steps per drive revolution when neither step_size nor accuracy is given.
    accuracy : float or None
        Target relative error of the monitored peak (1e-8 ... 0.1): the step is
        `step_for_accuracy` (second order from the default's measured error).
    contact : str
        Clearance-joint variant, one of `CONTACT_VARIANTS` (a joint with a bearing profile
        has a Python force function under "symbolic" and "python"; "sphere" takes none).
    spectral_radius : float
        Generalized-alpha spectral radius at infinity rho_inf in [0, 1]; 0.9 damps the
        spurious high-frequency oscillation of index-3 constraint forces.
    modified_newton : bool
        Reuse the Newton Jacobian between iterations and steps (Exudyn's default).
    onset : str
        "predict" or "detect": when the impact velocity is registered (`_pre_step`).
    newton_tolerance : float or None
        Relative tolerance of Newton's method (> 0); None: `NEWTON_TOLERANCE`, raised to
        the contact's roundoff floor where that is higher (`contact_scales`).
    """

    step_size: float | None = None
    steps_per_revolution: int = DEFAULT_STEPS_PER_REVOLUTION
    accuracy: float | None = None
    contact: str = "symbolic"
    spectral_radius: float = 0.9
    modified_newton: bool = True
    onset: str = "predict"
    newton_tolerance: float | None = None

    def step(self, linkage) -> float:
        """The fixed step in s for a `Linkage` (or a drive period in s): `step_size`; else
        the step of `accuracy` or `steps_per_revolution`, for a Linkage at most a
        `STEPS_PER_CONTACT_PERIOD`-th of its contacts' linearised period."""
        if self.step_size is not None:
            return self.step_size
        # a free linkage: its time scale (a turn at its largest initial rate) for a revolution
        period = ((linkage.period if linkage.drive is not None else linkage.time_scale)
                  if isinstance(linkage, Linkage) else float(linkage))
        if self.accuracy is not None:
            h = step_for_accuracy(period, self.accuracy)
        else:
            h = period / self.steps_per_revolution
        if isinstance(linkage, Linkage):
            h = min(h, contact_scales(linkage)[0] / STEPS_PER_CONTACT_PERIOD)
        return h

    def tolerance(self, linkage: Linkage) -> float:
        """Newton's relative tolerance for `linkage`: `newton_tolerance` if given, else
        `NEWTON_TOLERANCE` or, if higher, ROUNDOFF_MARGIN times the contact force's roundoff
        floor (`contact_scales`): below it Newton stalls without converging."""
        if self.newton_tolerance is not None:
            return self.newton_tolerance
        return max(NEWTON_TOLERANCE, ROUNDOFF_MARGIN * contact_scales(linkage)[1])


#: Newton's relative tolerance where the residual's roundoff allows it (Exudyn's default)
NEWTON_TOLERANCE = 1e-8

#: the automatic Newton tolerance stays this factor above the estimated roundoff floor
ROUNDOFF_MARGIN = 3.0

#: the default step resolves a contact's linearised oscillation by at least this many steps
#: (docs/exudyn.md, "Four-bar": coarser steps let the persistent contact blow up)
STEPS_PER_CONTACT_PERIOD = 12


def contact_scales(linkage: Linkage) -> tuple[float, float]:
    """(shortest linearised contact period in s, largest relative roundoff floor of a
    contact force) of `linkage`, estimated at a load scale F = m (g + omega^2 L) (m: total
    mass, omega: drive speed, L: the ground points' largest distance from the origin plus
    every body's largest point distance, a bound on any position's size).

    At that load a joint penetrates delta = (F / K)^(2/3) with the linearised stiffness
    k = 1.5 K delta^(1/2); its oscillation period is 2 pi sqrt(m_j / k) (m_j the lighter of
    its bodies). Exudyn holds absolute positions of size L, rounded to eps L; the contact
    force in the Newton residual then carries an error k eps L, relative to F:
    1.5 eps L / delta. A light mechanism of metres with a stiff, lightly loaded contact (the
    four-bar: delta ~ 7e-8 m, L ~ 7 m) has a floor above Exudyn's default 1e-8."""
    masses = {b.name: b.mass for b in linkage.bodies}
    size = max((math.hypot(*p) for p in linkage.ground_points.values()), default=0.0)
    size += sum(max((math.hypot(*p) for p in b.points.values()), default=0.0)
                for b in linkage.bodies)
    load = sum(masses.values()) * (linkage.gravity + linkage.rate_scale ** 2 * size)
    period, floor = math.inf, 0.0
    for el in _ELEMENTS:
        el_period, el_floor = el.exudyn_contact_scale(linkage, load, masses, size)
        period, floor = min(period, el_period), max(floor, el_floor)
    return period, floor


#: option names of simulate(linkage, backend="exudyn"): the settings, ``max_memory`` and
#: ``start`` (a `linkage_model.Start`)
OPTION_NAMES: tuple[str, ...] = (*ExudynSettings.__dataclass_fields__, "max_memory", "start",
                                 "duration", "window")


def step_for_accuracy(period: float, accuracy: float) -> float:
    """Fixed step (s) for a target relative peak error `accuracy`: generalized-alpha is
    second order, so h = (period / DEFAULT_STEPS_PER_REVOLUTION) sqrt(accuracy /
    ACCURACY_AT_DEFAULT), the error constant measured at the default step."""
    return (period / DEFAULT_STEPS_PER_REVOLUTION) * math.sqrt(accuracy / ACCURACY_AT_DEFAULT)


def make_settings(options: dict) -> ExudynSettings:
    """Validate backend options and return them as `ExudynSettings` (ValueError naming the
    option and its range if bad); ``max_memory`` is accepted and checked by the runs."""
    unknown = sorted(set(options) - set(OPTION_NAMES))
    if unknown:
        raise ValueError(f"unknown option(s) {unknown} for backend 'exudyn'; "
                         f"allowed: {list(OPTION_NAMES)}")
    s = ExudynSettings(**{k: v for k, v in options.items()
                          if k not in ("max_memory", "start", "duration", "window")})
    if s.step_size is not None and s.accuracy is not None:
        raise ValueError("give step_size or accuracy, not both (accuracy chooses the step)")
    return ExudynSettings(
        step_size=None if s.step_size is None else check_real(
            "step_size", s.step_size, 0.0, low_open=True, unit="s"),
        steps_per_revolution=check_int("steps_per_revolution", s.steps_per_revolution, 10),
        accuracy=None if s.accuracy is None else check_real(
            "accuracy (relative peak error)", s.accuracy, 1e-8, 0.1),
        contact=check_choice("contact", s.contact, CONTACT_VARIANTS),
        spectral_radius=check_real("spectral_radius", s.spectral_radius, 0.0, 1.0),
        modified_newton=check_bool("modified_newton", s.modified_newton),
        onset=check_choice("onset", s.onset, ONSET_MODES),
        newton_tolerance=None if s.newton_tolerance is None else check_real(
            "newton_tolerance", s.newton_tolerance, 0.0, low_open=True))


# ---------------------------------------------------------------------------- kinematics

def _rot(phi: float, xy) -> np.ndarray:
    c, s = math.cos(phi), math.sin(phi)
    return np.array([c * xy[0] - s * xy[1], s * xy[0] + c * xy[1]])


def _perp(v) -> np.ndarray:
    return np.array([-v[1], v[0]])


def _points(linkage: Linkage) -> dict:
    pts = {b.name: b.points for b in linkage.bodies}
    pts[GROUND] = linkage.ground_points
    return pts


def body_states(linkage: Linkage, t: float, q, qd) -> dict[str, tuple]:
    """Per body (x, y, phi, vx, vy, omega) of its centre of mass at time t for the minimal
    coordinates q and rates qd (`Linkage.coordinates` order), by the forest's kinematics
    (as the generated model's: the driven body's angle is speed t + initial angle, other
    revolute bodies' angles and floating bodies' x, y, angle are coordinates, a prismatic
    child keeps its parent's angle)."""
    index = {c: i for i, c in enumerate(linkage.coordinates())}
    pts = _points(linkage)
    state = {GROUND: (np.zeros(2), 0.0, np.zeros(2), 0.0)}    # r, phi, v, omega
    for body, parent, joint in linkage.tree():
        if body == GROUND:
            continue
        if parent is None:                                      # floating
            i = [index[f"{body}.{k}"] for k in ("x", "y", "angle")]
            state[body] = (np.array([q[i[0]], q[i[1]]]), q[i[2]],
                           np.array([qd[i[0]], qd[i[1]]]), qd[i[2]])
            continue
        rp, php, vp, wp = state[parent]
        if isinstance(joint, Revolute):
            if linkage.drive is not None and joint.name == linkage.drive.joint:
                phi = linkage.drive.speed * t + linkage.drive.initial_angle
                w = linkage.drive.speed
            else:
                i = index[f"{body}.angle"]
                phi, w = q[i], qd[i]
            pp, pc = ((joint.point_a, joint.point_b) if joint.body_a == parent
                      else (joint.point_b, joint.point_a))
            arm_p = _rot(php, pts[parent][pp])
            arm_c = _rot(phi, pts[body][pc])
            r = rp + arm_p - arm_c
            v = vp + wp * _perp(arm_p) - w * _perp(arm_c)
        else:
            i = index[f"{joint.name}.s"]
            s, sd = q[i], qd[i]
            phi, w = php, wp
            u = _rot(php, (math.cos(joint.angle), math.sin(joint.angle)))
            if joint.body_a == parent:          # point_b = point_a + s u
                arm_p = _rot(php, pts[parent][joint.point_a])
                arm_c = _rot(phi, pts[body][joint.point_b])
                rel = arm_p + s * u - arm_c
                r = rp + rel
                v = vp + wp * _perp(rel) + sd * u
            else:                               # point_a = point_b - s u
                arm_p = _rot(php, pts[parent][joint.point_b])
                arm_c = _rot(phi, pts[body][joint.point_a])
                rel = arm_p - s * u - arm_c
                r = rp + rel
                v = vp + wp * _perp(rel) - sd * u
        state[body] = (r, phi, v, w)
    return {b: (r[0], r[1], phi, v[0], v[1], w) for b, (r, phi, v, w) in state.items()
            if b != GROUND}


# ---------------------------------------------------------------------------- memory

class ImpactMemory:
    """Impact velocity deltadot_minus and contact mode of one contact (`name`, e.g. a
    clearance joint or a corner of a translational one), updated once per step by the
    pre-step function."""

    def __init__(self, name: str, floor: float):
        self.name = name
        self.floor = floor
        self.dmin = floor          # as the reduced model: the floor until the first onset
        self.mode = 0              # 1 from a registered onset until separation
        self.onsets = 0
        self.first_onset = None    # time of the first registered onset, s
        self.symbol = None         # named symbolic Real mirrored for the compiled force
        self.previous = None       # (t, delta, deltadot) of the previous step's state
        self.history = None        # [(t, deltadot_minus)] per step if recorded
        self.log = None            # [[t, deltadot_minus]] per onset if captured
        self.shift = None          # added to the registered impact velocity, per onset

    def set(self, value: float, t: float, new_onset: bool = True) -> None:
        if new_onset:
            self.onsets += 1
            if self.first_onset is None:
                self.first_onset = t
        if self.shift is not None and 0 < self.onsets <= len(self.shift):
            value += self.shift[self.onsets - 1]
        self.dmin = max(value, self.floor)
        if self.log is not None and self.onsets:
            if new_onset or not self.log:
                self.log.append([t, self.dmin])
            else:                  # the same onset registered again (a refined prediction)
                self.log[-1] = [t, self.dmin]
        if self.symbol is not None:
            self.symbol.SetValue(self.dmin)


class OnsetCapture:
    """The impact velocities the runs inside `capturing_onsets` register: ``registered``,
    per contact (its index in the layout) the list of [t in s, deltadot_minus in m/s] per
    onset (the last build's, after a Newton retry); ``shift``: per contact what to add to
    the impact velocities of its first onsets (m/s, every registration of the onset: a
    prediction and its refinement; later onsets keep their own)."""

    def __init__(self, shift: dict | None = None):
        self.shift = dict(shift or {})
        self.registered: dict[int, list] = {}

    def attach(self, index: int, memory: ImpactMemory) -> None:
        memory.log = self.registered[index] = []
        memory.shift = self.shift.get(index)


_CAPTURE: contextvars.ContextVar = contextvars.ContextVar("onset_capture", default=None)


@contextlib.contextmanager
def capturing_onsets(shift: dict | None = None):
    """Capture the impact velocities registered by the Exudyn runs made inside (an
    `OnsetCapture`), optionally shifted by `shift` (a step sequence's estimate of its
    onsets' error, `exudyn_convergence.onset_term`)."""
    capture = OnsetCapture(shift)
    token = _CAPTURE.set(capture)
    try:
        yield capture
    finally:
        _CAPTURE.reset(token)


def _update_memory(memory: ImpactMemory, t: float, h: float, delta: float, rate: float,
                   predict: bool) -> None:
    """Register an onset of one contact from the converged state at the step's start (see
    `_pre_step`: called at t_n+1 = `t` with the state of t_n = t - h)."""
    ts = t - h                 # the time of the state (delta, rate)
    prev = memory.previous
    if prev is not None and ts <= prev[0]:
        prev = None        # step repeated after a failed Newton: no new information
    if delta <= 0.0:
        if predict and delta + h * rate > 0.0:
            accel = (rate - prev[2]) / (ts - prev[0]) if prev is not None else 0.0
            s = -delta / rate                      # time to the crossing, then one
            qv = rate + accel * s                  # Newton step on the quadratic
            if qv > 0.0:
                s -= (delta + rate * s + 0.5 * accel * s * s) / qv
            s = min(max(s, 0.0), h)
            memory.set(rate + accel * s, ts + s, new_onset=memory.mode == 0)
            memory.mode = 1
        else:
            memory.mode = 0
    elif prev is not None and prev[1] <= 0.0:
        # crossed during the last step: interpolate deltadot at delta = 0
        theta = prev[1] / (prev[1] - delta)
        memory.set(prev[2] + theta * (rate - prev[2]), prev[0] + theta * (ts - prev[0]),
                   new_onset=memory.mode == 0)
        memory.mode = 1
    elif memory.mode == 0:
        memory.set(rate, ts)   # in contact without a registered onset (e.g. the first step)
        memory.mode = 1
    memory.previous = (ts, delta, rate)


def _pre_step(contacts: list, h: float, predict: bool):
    """Pre-step function: register contact onsets and impact velocities of every contact
    (`contacts`: (gap function of mbs -> (delta, deltadot), its `ImpactMemory`), from the
    elements' `exudyn_build`).

    Exudyn calls it at the start of each step with the new time t_n+1 and the converged
    state of t_n. With two consecutive states the penetration acceleration is known by a
    difference quotient, which makes both impact-velocity estimates second order in h:
    a predicted onset (``onset="predict"``, delta_n <= 0 < delta_n + h deltadot_n) uses
    deltadot extrapolated to the predicted crossing from the crossing step on; an onset
    found after the crossing step (delta_n-1 <= 0 < delta_n) interpolates deltadot
    linearly in delta between the bracketing states (this also refines a prediction).
    """
    def pre_step(mbs, t):
        for gap, memory in contacts:
            delta, rate = gap(mbs)
            _update_memory(memory, t, h, delta, rate, predict)
            if memory.history is not None:
                memory.history.append((t, memory.dmin))
        return True

    return pre_step


# ---------------------------------------------------------------------- generic elements

class _Side:
    """One body of a generic element (`_generic_element`): its node's slice of the
    element's coordinates (None for the ground), reference pose and the joint's point."""

    def __init__(self, slot, reference, point, fixed):
        self.slot, self.reference, self.point, self.fixed = slot, reference, point, fixed

    def angle(self, q):
        """The body's angle (0 for the ground)."""
        return 0.0 if self.slot is None else self.reference[2] + q[self.slot + 2]

    def kinematics(self, q, qt, cos, sin):
        """(position, velocity of the point, arm from the centre of mass, omega)."""
        px, py = self.point
        if self.slot is None:                           # ground: a fixed point
            return self.fixed, (0.0, 0.0), (0.0, 0.0), 0.0
        i = self.slot
        x0, y0, phi0 = self.reference
        phi = phi0 + q[i + 2]
        co, si = cos(phi), sin(phi)
        ax, ay = co * px - si * py, si * px + co * py
        w = qt[i + 2]
        return ((x0 + q[i] + ax, y0 + q[i + 1] + ay),
                (qt[i] - w * ay, qt[i + 1] + w * ax), (ax, ay), w)


def _generic_element(mbs, ends, nodes: dict, pts: dict):
    """(sides, element, node list): an `ObjectGenericODE2` on the nodes of the bodies of
    `ends` ((body, point) pairs; the ground has no node) and their `_Side`s, in that order,
    for a force user function of both."""
    import exudyn.itemInterface as ii

    sides, node_list = [], []
    for body, point in ends:
        if body == GROUND:
            sides.append(_Side(None, None, pts[GROUND][point], pts[GROUND][point]))
            continue
        ref = list(mbs.GetNodeParameter(nodes[body], "referenceCoordinates"))
        sides.append(_Side(3 * len(node_list), ref, pts[body][point], None))
        node_list.append(nodes[body])
    obj = mbs.AddObject(ii.ObjectGenericODE2(nodeNumbers=node_list,
                                             forceVector=[0.0] * (3 * len(node_list))))
    return sides, obj, node_list


def _symbolic_vector_function(mbs, function, obj, n: int):
    """Exudyn symbolic user function of an `ObjectGenericODE2` force (mbs, t, itemNumber,
    q, q_t) -> vector of n: as exudyn.advancedUtilities.CreateSymbolicUserFunction, whose
    recording gives the vector arguments length 0 (we give them the element's n)."""
    import exudyn as exu

    esym = exu.symbolic
    recording = esym.GetRecording()
    esym.SetRecording(True)
    try:
        args = dict(mbs=mbs, t=esym.Real("t", 0.0), itemNumber=esym.Real("itemNumber", 0),
                    q=esym.Vector("q", [0.0] * n), q_t=esym.Vector("q_t", [0.0] * n))
        value = esym.Vector(function(**args))
    finally:
        esym.SetRecording(recording)
    spec = {"functionName": function.__name__, "argList": list(args.values()),
            "argTypeList": ["MainSystem", "Real", "Index", "StdVector", "StdVector"],
            "returnValue": value, "returnType": "StdVector"}
    uf = esym.UserFunction()
    uf.SetUserFunctionFromDict(mbs, spec, "forceUserFunction", obj, "None")
    return uf


def _node_state(node_list):
    """Function of mbs: the coordinates and rates of the nodes of `node_list`, in order
    (as a generic element on them sees its q, q_t)."""
    import exudyn as exu

    def state(mbs):
        q, qt = [], []
        for node in node_list:
            q += list(mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates))
            qt += list(mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates_t))
        return q, qt

    return state


# ---------------------------------------------------------------------------- build

@dataclass
class ExudynModel:
    """A built Exudyn system of a linkage: container, system, items, sensors, memories."""

    SC: object
    mbs: object
    linkage: Linkage
    settings: ExudynSettings
    step: float
    nodes: dict            # body -> node index
    sensors: dict          # name -> sensor index
    ground_signs: dict     # ground joint -> sign turning the sensor force into the reaction
    memories: list         # ImpactMemory per contact, layout order (None: no memory)
    keep_alive: list = field(default_factory=list)
    #: per element kind (`elements.registry`) what its `exudyn_build` returned (per joint
    #: what its `exudyn_series` reads after the run)
    elements: dict = field(default_factory=dict)
    keep: np.ndarray | None = None   # rows of the stored data kept (`solve`: sliver steps)
    #: allocations per step by design: the outputs the pre-step function reads from Exudyn
    #: (each read allocates one vector) and the Python force user functions
    #: (`PYTHON_FORCE_ALLOCATIONS` each); `solve` tells Exudyn's allocation notice so
    pre_step_reads: int = 0


#: allocations per step of a force user function of a generic element (a friction's, an oil
#: film's, a profiled contact's, a translational joint's corners'): its force vector is made
#: on every call, each Newton iteration (41 per step measured on the lubricated case, 24 on
#: the translational benchmark), by design, so counted with the pre-step reads for Exudyn's
#: allocation notice
PYTHON_FORCE_ALLOCATIONS = 100

#: sensor groups `build` can record
OUTPUT_GROUPS: tuple[str, ...] = ("reactions", "drive", "contact", "bodies")


def _check_linkage(linkage, settings: ExudynSettings) -> None:
    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    for el in _ELEMENTS:
        el.exudyn_check(linkage, settings)


def build(linkage: Linkage, settings: ExudynSettings | None = None,
          outputs: tuple[str, ...] = ("all",), y0=None, start=None) -> ExudynModel:
    """Create the Exudyn system of `linkage` (not yet solved), started from the reduced
    model's centred state (or `y0`, a state [q, qdot, W] of the generated model, or
    `start`, a `linkage_model.Start`: its state and each contact's mode and impact velocity).

    `outputs` selects the sensors: "reactions", "drive", "contact", "bodies" or "all".
    The symbolic user functions are built here, in the calling process.
    """
    import exudyn as exu
    import exudyn.itemInterface as ii

    settings = ExudynSettings() if settings is None else settings
    _check_linkage(linkage, settings)
    want = set(outputs)
    unknown = want - {"all", *OUTPUT_GROUPS}
    if unknown:
        raise ValueError(f"unknown output group(s) {sorted(unknown)}; "
                         f"allowed: {['all', *OUTPUT_GROUPS]}")
    if "all" in want:
        want = set(OUTPUT_GROUPS)
    step = settings.step(linkage)
    start_memory = None
    if start is not None:
        from ..solve.linkage_model import check_start, event_tolerance, load_model, pack_parameters

        if settings.contact == "sphere":
            raise ValueError("start needs a contact with its own impact-velocity memory "
                             "(contact='symbolic' or 'python'), not 'sphere'")
        gen = load_model(linkage)
        p = pack_parameters(linkage, gen)
        y0 = check_start(linkage, gen, p, start, event_tolerance(linkage))
        start_memory = list(zip(start.modes, start.impact_velocities))
    elif y0 is None:
        from ..solve.linkage_model import initial_state
        y0 = initial_state(linkage)
    n = len(linkage.coordinates())
    states = body_states(linkage, 0.0, y0[:n], y0[n:2 * n])

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    objects = {GROUND: mbs.AddObject(ii.ObjectGround())}
    n_ground = mbs.AddNode(ii.NodePointGround())
    nodes = {}
    for b in linkage.bodies:
        x, y, phi, vx, vy, w = states[b.name]
        nodes[b.name] = mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=[x, y, phi],
                                                       initialVelocities=[vx, vy, w]))
        objects[b.name] = mbs.AddObject(ii.ObjectRigidBody2D(
            nodeNumber=nodes[b.name], mass=b.mass, inertia=b.inertia))
        m = mbs.AddMarker(ii.MarkerBodyMass(bodyNumber=objects[b.name]))
        mbs.AddLoad(ii.LoadMassProportional(markerNumber=m, loadVector=[0, -linkage.gravity, 0]))
    pts = _points(linkage)

    def marker(body, point, rigid=False):
        x, y = pts[body][point]
        make = ii.MarkerBodyRigid if rigid else ii.MarkerBodyPosition
        return mbs.AddMarker(make(bodyNumber=objects[body], localPosition=[x, y, 0.0]))

    ground_items, ground_signs = {}, {}
    for jt in linkage.joints:
        if isinstance(jt, Revolute):
            ends = [(jt.body_a, jt.point_a), (jt.body_b, jt.point_b)]
            if jt.body_b == GROUND:
                ends.reverse()
            obj = mbs.AddObject(ii.RevoluteJoint2D(markerNumbers=[marker(*e) for e in ends]))
            sign = 1.0
        else:
            ma = marker(jt.body_a, jt.point_a, rigid=True)
            mb = marker(jt.body_b, jt.point_b, rigid=True)
            ca, sa = math.cos(jt.angle), math.sin(jt.angle)
            obj = mbs.AddObject(ii.ObjectJointPrismatic2D(
                markerNumbers=[ma, mb], axisMarker0=[ca, sa, 0.0],
                normalMarker1=[-sa, ca, 0.0], constrainRotation=True))
            sign = 1.0 if jt.body_a == GROUND else -1.0
        if GROUND in (jt.body_a, jt.body_b):
            ground_items[jt.name], ground_signs[jt.name] = obj, sign

    drive = None        # a free linkage: no drive constraint, it moves from its start
    if linkage.drive is not None:
        drive_joint = next(j for j in linkage.joints if j.name == linkage.drive.joint)
        m_gc = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=n_ground, coordinate=0))
        m_phi = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=nodes[drive_joint.body_b],
                                                      coordinate=2))
        drive = mbs.AddObject(ii.CoordinateConstraint(markerNumbers=[m_gc, m_phi],
                                                      offset=linkage.drive.speed,
                                                      velocityLevel=True))

    memories: list = []

    def new_memory(name, floor):
        # the next contact's memory, at its place in the layout (the start's modes)
        memory = ImpactMemory(name, floor)
        if start_memory is not None:
            memory.mode = int(start_memory[len(memories)][0])
            memory.dmin = float(start_memory[len(memories)][1])
        capture = _CAPTURE.get()
        if capture is not None:
            capture.attach(len(memories), memory)
        memories.append(memory)
        return memory

    ctx = SimpleNamespace(mbs=mbs, settings=settings, nodes=nodes, pts=pts, marker=marker,
                          generic_element=_generic_element, node_state=_node_state,
                          symbolic_vector_function=_symbolic_vector_function,
                          new_memory=new_memory, python_force=PYTHON_FORCE_ALLOCATIONS,
                          memories=memories, contacts=[], keep_alive=[], pre_step_reads=0,
                          ground_items=ground_items, ground_signs=ground_signs,
                          contact_sensors=[])
    element_items = {el.kind: el.exudyn_build(linkage, ctx) for el in _ELEMENTS}
    if ctx.contacts:
        mbs.SetPreStepUserFunction(_pre_step(ctx.contacts, step, settings.onset == "predict"))

    OVT = exu.OutputVariableType

    def sensor(kind, number, var):
        make = ii.SensorObject if kind == "object" else ii.SensorNode
        key = "objectNumber" if kind == "object" else "nodeNumber"
        return mbs.AddSensor(make(**{key: number}, outputVariableType=var, storeInternal=True,
                                  writeToFile=False))

    sensors: dict = {}
    if "reactions" in want:
        prismatic = {j.name: j for j in linkage.joints if isinstance(j, Prismatic)}
        after = {n for el in _ELEMENTS for n in el.exudyn_ground_joints(linkage)}
        for name in linkage.ground_joints():
            if name in after:           # from an element's series after the run
                continue
            # a prismatic joint outputs its force in marker 0's (body_a's) frame
            var = OVT.ForceLocal if name in prismatic else OVT.Force
            sensors[f"{name}.force"] = sensor("object", ground_items[name], var)
            if name in prismatic and prismatic[name].body_a != GROUND:
                sensors[f"{name}.frame"] = sensor("node", nodes[prismatic[name].body_a],
                                                  OVT.Coordinates)
    if "drive" in want and drive is not None:
        sensors["drive"] = sensor("object", drive, OVT.Force)
    if "contact" in want:
        for name, obj in ctx.contact_sensors:
            sensors[f"{name}.displacement"] = sensor("object", obj, OVT.Displacement)
            sensors[f"{name}.force"] = sensor("object", obj, OVT.Force)
    if "bodies" in want:
        for b in linkage.bodies:
            for var, suffix in ((OVT.Coordinates, "q"), (OVT.Coordinates_t, "v"),
                                (OVT.Coordinates_tt, "a")):
                sensors[f"{b.name}.{suffix}"] = sensor("node", nodes[b.name], var)
    mbs.Assemble()
    return ExudynModel(SC=SC, mbs=mbs, linkage=linkage, settings=settings, step=step,
                       nodes=nodes, sensors=sensors, ground_signs=ground_signs,
                       memories=memories, keep_alive=ctx.keep_alive, elements=element_items,
                       pre_step_reads=ctx.pre_step_reads)


# ---------------------------------------------------------------------------- solve

def _simulation_settings(settings: ExudynSettings, step: float, end_time: float,
                         tolerance: float):
    import exudyn as exu

    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    n_steps = max(1, int(round(end_time / step)))
    ti.numberOfSteps = n_steps
    ti.endTime = end_time
    ti.verboseMode = 0
    ti.discontinuous.useRecommendedStepSize = False
    ti.generalizedAlpha.spectralRadius = float(settings.spectral_radius)
    ti.newton.useModifiedNewton = settings.modified_newton
    ti.newton.relativeTolerance = float(tolerance)
    ss.show.statistics = False
    ss.show.computationTime = False
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = 0.0      # every step
    return ss, n_steps


class SolverFailure(RuntimeError):
    """Exudyn's time integration stopped (its Newton iteration did not converge)."""


#: a run whose Newton iteration fails at the automatic tolerance runs again with the
#: tolerance this factor looser, at most `NEWTON_RETRIES` times: a step's initial residual
#: shrinks with the step while the contact force's roundoff does not, so the relative
#: floor that `ExudynSettings.tolerance` estimates rises at small steps (the four-bar at
#: 30 rpm: 3.6e-8 fails at a step of 3.0e-6 s and 5e-8 converges)
NEWTON_RETRY_FACTOR = 4.0
NEWTON_RETRIES = 2


def build_and_solve(linkage: Linkage, settings: ExudynSettings, end_time: float,
                    **build_options) -> tuple[ExudynModel, dict]:
    """`build` and `solve` to `end_time` (s): (model, stats). Where the Newton tolerance is
    automatic (``newton_tolerance=None``) and the solver fails, the model is built again
    and run with the tolerance `NEWTON_RETRY_FACTOR` times looser, at most `NEWTON_RETRIES`
    times (``stats["newton_retries"]``; ``stats["newton_tolerance"]`` is the one used)."""
    tolerance = settings.tolerance(linkage)
    for attempt in range(NEWTON_RETRIES + 1):
        run_settings = (settings if attempt == 0
                        else replace(settings, newton_tolerance=tolerance))
        model = build(linkage, run_settings, **build_options)
        try:
            stats = solve(model, end_time)
        except SolverFailure as exc:
            if settings.newton_tolerance is not None or attempt == NEWTON_RETRIES:
                if attempt:
                    raise SolverFailure(f"{exc} (also with Newton's tolerance loosened "
                                        f"to {tolerance:.3g})") from exc
                raise
            tolerance *= NEWTON_RETRY_FACTOR
            continue
        stats["newton_retries"] = attempt
        return model, stats
    raise AssertionError("unreachable")


def solve(model: ExudynModel, end_time: float) -> dict:
    """Run the time integration to `end_time` (s); returns solver statistics.

    Raises `SolverFailure` (a RuntimeError) with advice if Exudyn's solver fails, and a
    RuntimeError if a user function does.
    """
    import exudyn as exu
    import exudyn.solver as exs

    tolerance = model.settings.tolerance(model.linkage)
    ss, n_steps = _simulation_settings(model.settings, model.step, end_time, tolerance)
    wall = time.perf_counter()
    # Exudyn prints a notice when a run allocates about once per Newton step or more,
    # meant for allocations nobody asked for; the pre-step function's reads of the joints'
    # outputs allocate by design (one vector each): the notice's threshold is raised by
    # exactly those, so it still reports anything beyond them
    threshold = exs.solverCheckMemoryAllocationsThreshold
    exs.solverCheckMemoryAllocationsThreshold = threshold + n_steps * model.pre_step_reads
    try:
        ok = exu.SolveDynamic(model.mbs, ss, storeSolver=True)
    except Exception as exc:  # Exudyn raises its own error types from C++
        if "USER FUNCTION" in str(exc):      # a bug in our pre-step or force function
            raise RuntimeError(f"Exudyn user function failed: {exc}") from exc
        raise SolverFailure(_failure_message(model, f"{type(exc).__name__}: {exc}")) from exc
    finally:
        exs.solverCheckMemoryAllocationsThreshold = threshold
    wall = time.perf_counter() - wall
    if not ok:
        raise SolverFailure(_failure_message(model, "the solver reported failure"))
    stats = dict(step_size=model.step, step_size_used=end_time / n_steps, n_steps=n_steps,
                 wall_time=wall,
                 **{k: v for k, v in asdict(model.settings).items() if k != "step_size"})
    stats["newton_tolerance"] = tolerance
    solver = model.mbs.sys.get("dynamicSolver")
    if solver is not None:
        it = solver.it
        stats.update(newton_steps=int(it.newtonStepsCount), jacobians=int(it.newtonJacobiCount),
                     discontinuous_iterations=int(it.discontinuousIterationsCount))
    if model.sensors:
        t = np.asarray(model.mbs.GetSensorStoredData(next(iter(model.sensors.values()))))[:, 0]
        model.keep = _sliver_rows(t, model.step)
        stats["sliver_steps"] = int(len(t) - model.keep.sum())
    mems = [m for m in model.memories if m is not None]
    if mems:
        stats["onsets"] = sum(m.onsets for m in mems)
        stats["first_onsets"] = {m.name: m.first_onset for m in mems}
    return stats


def _failure_message(model: ExudynModel, reason: str) -> str:
    s = model.settings
    return (f"Exudyn time integration of linkage {model.linkage.name!r} failed ({reason}) "
            f"with step_size={model.step:g} s, contact={s.contact!r}; try a smaller "
            f"step_size (e.g. {model.step / 2:g}) or modified_newton=False")


def stored(model: ExudynModel, name: str) -> np.ndarray:
    """The stored data (n, 1 + components) of sensor `name`: time, then the values (the
    rows `solve` keeps)."""
    data = np.asarray(model.mbs.GetSensorStoredData(model.sensors[name]))
    return data if model.keep is None else data[model.keep]


#: a step shorter than this fraction of the fixed step is a sliver (`_sliver_rows`)
SLIVER = 1e-2


def _sliver_rows(t: np.ndarray, step: float) -> np.ndarray:
    """Rows to keep: all but those ending a sliver step. When Exudyn has halved steps after
    a failed Newton iteration, its time grid no longer divides the end time and the run
    ends with a sliver (e.g. 3e-10 s after 7.8e-6 s steps); the constraint multipliers of
    a step of length s carry Newton's residual times ~1/s^2 (index-3 constraints), so the
    reactions and the drive moment of that sample are noise (8.7 kN against 30 N in the
    four-bar, measured). Such samples are dropped; the state is continuous across them."""
    keep = np.ones(len(t), dtype=bool)
    keep[1:] = np.diff(t) >= SLIVER * step
    return keep


#: floats Exudyn stores per step: per ground joint 4, drive 2, per contact 8, per body 12
#: (time + 3 components per sensor)
def estimate_memory(linkage: Linkage, revolutions: int | None, step: float,
                    outputs: tuple[str, ...] = ("all",), *,
                    duration: float | None = None) -> tuple[int, int]:
    """(time steps, peak bytes) of a run of `revolutions` drive revolutions, or of
    `duration` s (a free linkage's run, or any span's length: then `revolutions` is not
    read): every step of every sensor stored by Exudyn, copied once, and the Trajectory's
    per-step arrays."""
    J = sum(len(el.contact_names(linkage)) for el in _ELEMENTS)
    B = len(linkage.bodies)
    G = len(linkage.ground_joints())
    full = "all" in outputs
    floats = 4 * G + (2 + 8 * J + 12 * B if full else 0)
    length = revolutions * linkage.period if duration is None else duration
    steps = max(1, int(round(length / step)))
    per_step = 8 * (2 * floats + ((6 + 6 * J + 2 * G + 3 * len(linkage.coordinates()))
                                  if full else 0))
    return steps, (steps + 1) * per_step


def _check_run(linkage, span: Span, settings, outputs, max_memory) -> None:
    """Refuse a run over `span` (a `Span`, `linkage_model.prepare_span`) whose records of
    `outputs` at the settings' step exceed `max_memory` (`MemoryLimitError`), or whose
    linkage the settings cannot build (ValueError)."""
    _check_linkage(linkage, settings)
    size, unit = ((span.duration, "s") if span.revolutions is None
                  else (span.revolutions, "revolutions"))
    max_memory = check_max_memory(max_memory)
    step = settings.step(linkage)
    steps, need = estimate_memory(linkage, span.revolutions, step, outputs,
                                  duration=span.duration)
    if need > max_memory:
        raise MemoryLimitError(
            f"the Exudyn run of {size} {unit} takes {steps:.3g} fixed steps of "
            f"{step:g} s and needs about {format_bytes(need)} for its records, more than "
            f"max_memory={max_memory} bytes ({format_bytes(max_memory)}); raise step_size "
            "or max_memory, or run fewer revolutions")


# ---------------------------------------------------------------------------- results

def window_peaks(t: np.ndarray, magnitude: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """The maximum of `magnitude` over each window [edges[k], edges[k + 1]] (s; a span's
    windows: revolutions, or a free linkage's time windows), refined between the samples
    (`refine_peak`)."""
    peaks = np.empty(len(edges) - 1)
    tol = 1e-12 * max(1.0, float(edges[-1]))
    for k in range(len(peaks)):
        idx = np.nonzero((t >= edges[k] - tol) & (t <= edges[k + 1] + tol))[0]
        peaks[k] = refine_peak(t, magnitude, int(idx[np.argmax(magnitude[idx])]))
    return peaks


def _parabola(magnitude: np.ndarray, i: int) -> float:
    """The vertex of the parabola through sample i and its neighbours where it is a local
    maximum, else the sample."""
    f0 = magnitude[i]
    if 0 < i < len(magnitude) - 1:
        fm, fp = magnitude[i - 1], magnitude[i + 1]
        curvature = fm - 2.0 * f0 + fp
        if curvature < 0.0 and max(fm, fp) <= f0:      # a local maximum: vertex within
            f0 = f0 - 0.125 * (fp - fm) ** 2 / curvature   # h/2 of the sample
    return float(f0)


def refine_peak(t: np.ndarray, magnitude: np.ndarray, i: int) -> float:
    """The maximum of a sampled signal near its largest sample i, between the samples: the
    largest value on [t[i-1], t[i+1]] of the quartic through the five samples i-2 ... i+2
    (interpolation error O(h^5) on a smooth peak, beyond generalized-alpha's O(h^2), so
    that the refined peaks converge at the method's order as h is halved; a parabola
    through three samples leaves an O(h^3) error whose sign follows where the peak falls
    between the samples, which breaks the extrapolation on short impacts). Near the ends
    of the record, or where the five samples do not rise then fall, the parabola through
    three samples (`_parabola`); a sample that is no local maximum (at a revolution's edge)
    is kept."""
    n = len(magnitude)
    f0 = float(magnitude[i])
    if not 0 < i < n - 1 or magnitude[i - 1] > f0 or magnitude[i + 1] > f0:
        return f0
    # the quartic only where the five samples rise then fall (a resolved smooth peak); a
    # zig-zag (generalized-alpha's start-up ringing) makes it overshoot by ~1 %
    if (i < 2 or i > n - 3 or magnitude[i - 2] > magnitude[i - 1]
            or magnitude[i + 2] > magnitude[i + 1]):
        return _parabola(magnitude, i)
    h = t[i + 1] - t[i]
    s = (t[i - 2:i + 3] - t[i]) / h
    coeffs = np.polyfit(s, magnitude[i - 2:i + 3], 4)
    roots = np.roots(np.polyder(coeffs))
    real = roots[np.abs(roots.imag) <= 1e-9 * np.maximum(1.0, np.abs(roots))].real
    inside = real[(real >= -1.0) & (real <= 1.0)]
    best = max([f0] + [float(np.polyval(coeffs, r)) for r in inside])
    return best


def refined_peaks(t: np.ndarray, magnitude: np.ndarray, period: float,
                  revolutions: int) -> np.ndarray:
    """Maximum of `magnitude` over each revolution, refined between the fixed steps
    (`refine_peak`: the quartic through the largest sample and two neighbours on each side;
    the sampled maximum misses a sharp peak by up to its curvature times (h/2)^2 / 2,
    which would not converge at second order as h is halved; the refined value does)."""
    return window_peaks(t, magnitude, np.arange(revolutions + 1) * period)


def _coordinates(model: ExudynModel):
    """Minimal coordinates, rates and accelerations (by `Linkage.coordinates` name) from
    the bodies' node sensors."""
    linkage = model.linkage
    q, v, a = {}, {}, {}
    for b in linkage.bodies:
        q[b.name] = stored(model, f"{b.name}.q")[:, 1:4] + np.asarray(
            model.mbs.GetNodeParameter(model.nodes[b.name], "referenceCoordinates"))
        v[b.name] = stored(model, f"{b.name}.v")[:, 1:4]
        a[b.name] = stored(model, f"{b.name}.a")[:, 1:4]
    from .kinematics import coordinate_series

    return coordinate_series(linkage, q, v, a)


def _element_series(model: ExudynModel) -> list:
    """Every element's series of the run (`Element.exudyn_series`, registry order), from
    the stored sensors and body states and each contact's impact velocity in force at each
    step (`ImpactMemory.history`)."""
    t = stored(model, f"{model.linkage.bodies[0].name}.q")[:, 0]

    def motion(body):
        # the body's absolute coordinates and their rates at the samples
        return (stored(model, f"{body}.q")[:, 1:4] + np.asarray(
            model.mbs.GetNodeParameter(model.nodes[body], "referenceCoordinates")),
            stored(model, f"{body}.v")[:, 1:4])

    def states(bodies):
        return (np.hstack([stored(model, f"{b}.q")[:, 1:4] for b in bodies]),
                np.hstack([stored(model, f"{b}.v")[:, 1:4] for b in bodies]))

    def impact_velocity(memory):
        hist = np.asarray(memory.history).reshape(-1, 2)
        if not len(hist):
            return np.full(len(t), memory.floor)
        at = np.clip(np.searchsorted(hist[:, 0], t, side="right") - 1, 0, len(hist) - 1)
        return np.where(hist[at, 0] <= t, hist[at, 1], memory.floor)

    ctx = SimpleNamespace(t=t, stored=lambda name: stored(model, name), motion=motion,
                          states=states, points=_points(model.linkage),
                          impact_velocity=impact_velocity)
    return [el.exudyn_series(model.elements[el.kind], ctx) for el in _ELEMENTS]


def _reactions(model: ExudynModel) -> tuple[np.ndarray, dict]:
    t = None
    reactions = {}
    for name in model.linkage.ground_joints():
        if f"{name}.force" not in model.sensors:    # an element's (`_element_series`)
            continue
        F = stored(model, f"{name}.force")
        t = F[:, 0].copy() if t is None else t
        f = F[:, 1:3]
        if f"{name}.frame" in model.sensors:          # body_a's frame -> world
            node = model.nodes[next(j.body_a for j in model.linkage.joints if j.name == name)]
            phi = stored(model, f"{name}.frame")[:, 3] + model.mbs.GetNodeParameter(
                node, "referenceCoordinates")[2]
            c, s = np.cos(phi), np.sin(phi)
            f = np.column_stack([c * f[:, 0] - s * f[:, 1], s * f[:, 0] + c * f[:, 1]])
        reactions[name] = np.ascontiguousarray(model.ground_signs[name] * f)
    return t, reactions


def simulate_exudyn_linkage(linkage: Linkage, revolutions: int | None = None, **options):
    """Simulate `revolutions` drive revolutions of `linkage` in Exudyn; a `Trajectory` of
    the same form as the reduced backend's (per-joint series, reactions by ground joint).

    Options: `ExudynSettings` fields (``step_size`` s, or ``accuracy``, or
    ``steps_per_revolution``; ``contact``, ``spectral_radius``, ``modified_newton``,
    ``onset``, ``newton_tolerance``) and ``max_memory`` (bytes). Unknown names or bad
    values raise ValueError before anything is computed.

    Every time step is recorded (t = 0, h, 2h, ...); ``peaks`` holds the monitored force's
    maximum per revolution refined between the steps (`refined_peaks`). ``contact_phase``
    is 1 where the penetration is positive; ``contact_force`` the
    signed normal force; ``crank_work`` the trapezoidal integral of the drive's power;
    ``contact_angle`` (rad) and ``slip_velocity`` (m/s) per clearance joint (its element's
    `exudyn_series`).
    ``stats`` holds the settings, the step, Newton counters, onsets (per contact the first
    registered onset time in ``first_onsets``) and the wall time in s.

    A free linkage (drive None) takes ``duration`` (s) and ``window`` (s) instead of
    revolutions: no drive constraint, started from its `Initial`; no drive moment or
    work (None), ``peaks`` per window.
    """
    from ..solve.trajectory import annotate

    settings, span, max_memory, start = _prepare(linkage, revolutions, options)
    return annotate(run_linkage(linkage, span, settings, max_memory, start))


def _prepare(linkage, revolutions, options: dict, name: str = "revolutions"):
    """(settings, span, max_memory, start) of a run from the public options (ValueError
    naming a bad one before any work): `make_settings`, the span of `revolutions` or of
    the options ``duration`` and ``window`` (`linkage_model.prepare_span`; `name`: the
    count's option, as its errors say it)."""
    from ..solve.linkage_model import prepare_span

    max_memory = options.pop("max_memory", None)
    start = options.pop("start", None)
    duration, window = options.pop("duration", None), options.pop("window", None)
    settings = make_settings(options)
    _check_linkage(linkage, settings)
    span = prepare_span(linkage, revolutions, duration=duration, window=window,
                        max_memory=max_memory, name=name)
    return settings, span, max_memory, start


def run_linkage(linkage: Linkage, span: Span, settings: ExudynSettings, max_memory=None,
                start=None):
    """The (not annotated) `Trajectory` of `simulate_exudyn_linkage` over `span` (a
    `Span`, `linkage_model.prepare_span`: drive revolutions, or a free linkage's time
    windows) for validated `settings` (from `start`, a `linkage_model.Start`, if given);
    the run and the record size are checked first."""
    from ..solve.linkage_model import check_span_start
    from ..solve.trajectory import Trajectory

    _check_run(linkage, span, settings, ("all",), max_memory)
    check_span_start(span, start)
    free = span.revolutions is None
    model, stats = build_and_solve(linkage, settings, float(span.edges[-1]), start=start)

    t, reactions = _reactions(model)
    moment = None if free else -stored(model, "drive")[:, 1]
    ecc, pen, force = [], [], []
    elements = _element_series(model)
    for series in elements:
        reactions.update(series.reactions)
        ecc += series.eccentricity
        pen += series.penetration
        force += series.force
    shaking = sum(reactions[g] for g in reactions)
    monitored = shaking if linkage.monitor_joint is None else reactions[linkage.monitor_joint]
    penetration = np.column_stack(pen)
    work = None
    if not free:
        power = moment * linkage.drive.speed
        work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    stats["uniform_steps"] = bool(len(t) == stats["n_steps"] + 1 and np.allclose(
        np.diff(t), stats["step_size_used"], rtol=1e-6, atol=0.0))
    coords, rates, accs = _coordinates(model)
    friction = [power for series in elements for power in series.friction_power]
    friction_work = None
    if friction:
        power = sum(friction)
        friction_work = -np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1])
                                                           * np.diff(t))])
    return Trajectory(
        t=t, base_force=np.ascontiguousarray(monitored), crank_moment=moment,
        contact_force=np.column_stack(force), penetration=penetration,
        eccentricity=np.stack(ecc, axis=1),
        contact_phase=(penetration > 0.0).astype(np.int8), crank_work=work,
        mechanism=linkage, backend="exudyn", stats=stats,
        peaks=window_peaks(t, np.hypot(monitored[:, 0], monitored[:, 1]), span.windows),
        joints=tuple(name for name, _ in linkage.contacts()), reactions=reactions,
        shaking_force=np.ascontiguousarray(shaking), coordinates=coords, rates=rates,
        accelerations=accs, friction_work=friction_work,
        contact_angle=_element_columns(elements, "contact_angle", len(t)),
        slip_velocity=_element_columns(elements, "slip_velocity", len(t)))


def _element_columns(elements: list, name: str, n: int) -> np.ndarray:
    """The (n, J) array of the J columns `name` of the elements' series of n samples
    (``columns``; (n, 0) for none)."""
    series = [c for part in elements for c in part.columns.get(name, [])]
    return np.column_stack(series) if series else np.empty((n, 0))


def peak_exudyn_linkage(linkage: Linkage, revolution: int | None = None,
                        **options) -> float:
    """Max of the monitored force (|reaction| of the monitored ground joint, or |shaking
    force|) in N over drive revolution `revolution` (1-based, default 4), refined between
    the time steps (`refined_peaks`); integrates only to the end of that revolution and
    records only the reactions. A free linkage: over the last window of a run of
    ``duration`` s (windows of ``window`` s)."""
    settings, span, max_memory, start = _prepare(linkage, revolution, options, "revolution")
    return peak_run(linkage, span, settings, max_memory, start)


def monitors_element_reaction(linkage: Linkage) -> bool:
    """Whether the monitored force may hold an element's ground reaction (a ground guide's:
    its corners' loads), which is computed from the bodies' stored states that a
    reactions-only run does not keep (its peaks then come from a full run)."""
    after = {n for el in _ELEMENTS for n in el.exudyn_ground_joints(linkage)}
    return bool(after) and (linkage.monitor_joint is None or linkage.monitor_joint in after)


def peak_run(linkage: Linkage, span: Span, settings: ExudynSettings, max_memory=None,
             start=None) -> float:
    """`peak_exudyn_linkage` over `span` (a `Span`; its last window's peak) for validated
    `settings` (from `start` if given)."""
    return float(run_peaks(linkage, span, settings, max_memory, start)[-1])


def run_peaks(linkage: Linkage, span: Span, settings: ExudynSettings, max_memory=None,
              start=None) -> np.ndarray:
    """The refined peaks of the monitored force (N) over each window of `span` (a `Span`,
    `linkage_model.prepare_span`: drive revolutions, or a free linkage's time windows),
    from one run recording the reactions only (a full run where the monitored force holds
    an element's ground reaction, `monitors_element_reaction`)."""
    if monitors_element_reaction(linkage):
        return np.asarray(run_linkage(linkage, span, settings, max_memory, start).peaks,
                          dtype=float)
    t, F = monitored_force(linkage, span, settings, max_memory, start)
    return window_peaks(t, np.hypot(F[:, 0], F[:, 1]), span.windows)


def monitored_force(linkage: Linkage, span: Span, settings: ExudynSettings, max_memory=None,
                    start=None, until: float | None = None):
    """(t in s, monitored force (n, 2) in N) of one run over `span` recording the reactions
    only (a full run where the monitored force holds an element's ground reaction,
    `monitors_element_reaction`), to its end or to the first step at or after `until` s
    (on the full run's steps; the caller checks such a run's memory)."""
    from ..solve.linkage_model import check_span_start

    if monitors_element_reaction(linkage):
        traj = run_linkage(linkage, span, settings, max_memory, start)
        return traj.t, traj.base_force
    end = float(span.edges[-1])
    if until is None:
        _check_run(linkage, span, settings, ("reactions",), max_memory)
    else:
        h = end / max(1, round(end / settings.step(linkage)))
        end = min(end, math.ceil(until / h) * h)
    check_span_start(span, start)
    model, _ = build_and_solve(linkage, settings, end, outputs=("reactions",), start=start)
    t, reactions = _reactions(model)
    F = (sum(reactions.values()) if linkage.monitor_joint is None
         else reactions[linkage.monitor_joint])
    return t, F
