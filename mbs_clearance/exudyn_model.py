"""The slider-crank with a clearance joint in the multibody engine Exudyn (backend "exudyn").

An independent implementation of the same mechanism as `reduced`: three planar rigid bodies
with absolute coordinates, ideal joints as algebraic constraints, solved by Exudyn's implicit
generalized-alpha integrator with a fixed step size. Only the clearance-joint contact law is
ours; everything else (kinematics, mass matrix, constraint forces) is Exudyn's.

Model
-----
- Crank (body 2): `ObjectRigidBody2D`, node at its centre of mass (L2/2 from the pivot),
  mass m2, inertia J2 about the CG; `RevoluteJoint2D` to the ground at the origin. Constant
  speed by a velocity-level `CoordinateConstraint` on the crank rotation coordinate
  (d(phi2)/dt - omega2 = 0); its Lagrange multiplier lambda is the drive: the moment applied
  to the crank is -lambda (Exudyn adds C_q^T lambda on the left-hand side).
- Coupler (body 3): `ObjectRigidBody2D`, node at the CG (mid-length), mass m3, inertia J3;
  `RevoluteJoint2D` to the crank end.
- Slider (body 4): `ObjectRigidBody2D` of mass m4 with its y and rotation coordinates fixed
  by `CoordinateConstraint`s (a rigid body rather than a point mass because the native sphere
  contact asks for markers with an orientation).
- Gravity g along -y on all bodies (`LoadMassProportional`).
- Clearance joint between the coupler end (journal centre) and the slider (bearing centre),
  one of three variants (option ``contact``):

  ``"symbolic"`` (default)
      `ObjectConnectorCartesianSpringDamper` (markers [bearing, journal]) whose force is an
      Exudyn symbolic user function, evaluated in C++: with d the journal centre relative to
      the bearing centre, delta = |d| - c and deltadot = d.d'/|d|,
      F = max(K delta^1.5 (1 + xi(e) deltadot / deltadot_minus), 0) for delta > 0, else 0,
      returned as F d/|d| (Exudyn applies -f to the journal: a push back toward the bearing
      centre). xi(e) from `contact.hysteresis_factor` for the mechanism's contact model.
  ``"python"``
      The same connector with a plain Python user function calling `contact.contact_force`,
      the reduced model's own compiled law (about 25 % slower; for debugging).
  ``"sphere"``
      Exudyn's native `ObjectContactSphereSphere` with the bearing as hollow sphere
      (``isHollowSphere1=True``, radii R_J and R_B), ``contactStiffnessExponent=1.5``,
      ``impactModel=1``. Its force is K delta^n (1 + 1.5 (1 - e') deltadot/v_imp), so the
      restitution passed is e' = 1 - xi(e)/1.5 (= (1 + e^2)/2 for Lankarani-Nikravesh).
      Differences to our law, documented not hidden: Exudyn does not clamp the force at zero
      (late in the restitution phase it can pull slightly), stores the impact velocity at
      the end of the first step in contact rather than at the onset, and switches the
      contact on and off through its discontinuous iteration.

Impact velocity (memory variable)
---------------------------------
For the two user-function variants deltadot_minus is never computed inside the force: a
pre-step function, called at the start of every time step with the converged state of the
previous one, updates it (`_pre_step`, `_ImpactMemory`; for the symbolic force it sets a
named symbolic variable). Onset means, as in the reduced model, the penetration crossing
zero upward; the impact velocity is floored at `impact_velocity_floor`. With
``onset="predict"`` (default) the crossing is anticipated one step ahead (delta <= 0 now and
delta + h deltadot > 0), so the step in which contact begins already uses the new impact
velocity, extrapolated to the predicted crossing time; after that step it is refined by
interpolating between the two states that bracket the crossing. Both estimates are second
order in h, which keeps the whole scheme second order (see the convergence test).
``onset="detect"`` only reacts after the crossing step, so that step runs with the previous
impact's value: in the paper case the first impact then sees the 1 mm/s floor instead of
0.62 m/s, and its peak |F12| comes out at 36.2 kN instead of 18.6 kN (kept to show why).

Numerics
--------
Generalized-alpha (index-3 constraints, spectral radius 0.9) with a fixed step;
``useRecommendedStepSize`` is off so that the contact cannot change the step; no solution
files, no graphics, no console output. Outputs are sensors stored in memory, every step:
joint force of the ground revolute joint (= F12, the force on the ground), Lagrange
multiplier of the drive (-M2), connector displacement (eccentricity) and force (contact
force), slider node position/velocity/acceleration, coupler node angle and rate.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from ._checks import (
    MemoryLimitError,
    check_bool,
    check_choice,
    check_int,
    check_max_memory,
    check_real,
    format_bytes,
)
from .contact import CONTACT_MODELS, contact_force, hysteresis_factor
from .mechanism import SliderCrank
from .reduced import initial_state
from .trajectory import Trajectory, annotate

__all__ = [
    "simulate_exudyn", "peak_exudyn", "build_model", "ExudynSettings", "ExudynModel",
    "CONTACT_VARIANTS", "DEFAULT_STEP_SIZE", "OPTION_NAMES",
]

#: clearance-joint implementations (option ``contact``)
CONTACT_VARIANTS: tuple[str, ...] = ("symbolic", "python", "sphere")

#: default fixed step size in s; chosen with validation/benchmarks/exudyn_speed.py: at
#: 2e-6 s (about 6000 steps per revolution at 5000 rpm) the paper case's 4th-revolution
#: peak |F12| is within 0.02 % of the tight reduced reference and the 4th-revolution relative
#: RMS differences of F12 and the crank moment are below 0.5 %; 5e-6 s gives 0.7 % / 1.8 %.
DEFAULT_STEP_SIZE = 2.0e-6

ONSET_MODES: tuple[str, ...] = ("predict", "detect")

#: sensor groups `build_model` can record
OUTPUT_GROUPS: tuple[str, ...] = ("base_force", "crank_moment", "contact", "slider", "coupler")


@dataclass(frozen=True)
class ExudynSettings:
    """Integrator and model settings of the Exudyn backend (the backend's options).

    Parameters
    ----------
    step_size : float
        Fixed time step in s (> 0).
    contact : str
        Clearance-joint variant, one of `CONTACT_VARIANTS`.
    spectral_radius : float
        Generalized-alpha spectral radius at infinity rho_inf in [0, 1]; 0.9 (Exudyn's
        default) damps the spurious high-frequency oscillation of the constraint forces that
        rho_inf = 1 shows with the index-3 formulation.
    modified_newton : bool
        Reuse the Newton Jacobian between iterations and steps (Exudyn's default, faster).
    onset : str
        "predict" or "detect", see the module docstring.
    newton_tolerance : float
        Relative tolerance of Newton's method (> 0).
    """

    step_size: float = DEFAULT_STEP_SIZE
    contact: str = "symbolic"
    spectral_radius: float = 0.9
    modified_newton: bool = True
    onset: str = "predict"
    newton_tolerance: float = 1e-8


#: option names accepted by simulate_exudyn / peak_exudyn: the settings and ``max_memory``
OPTION_NAMES: tuple[str, ...] = (*ExudynSettings.__dataclass_fields__, "max_memory")

#: floats Exudyn stores per time step for each output group (the time and the components of
#: each sensor: forces, displacements, positions, velocities, accelerations and
#: coordinates are 3-vectors, the drive's multiplier a scalar)
SENSOR_FLOATS: dict[str, int] = {"base_force": 4, "crank_moment": 2, "contact": 8,
                                 "slider": 12, "coupler": 8}


def make_settings(options: dict) -> ExudynSettings:
    """Validate backend options and return them as `ExudynSettings` (ValueError naming the
    option and its range if bad); ``max_memory`` is accepted and checked by the runs."""
    unknown = sorted(set(options) - set(OPTION_NAMES))
    if unknown:
        raise ValueError(f"unknown option(s) {unknown} for backend 'exudyn'; "
                         f"allowed: {list(OPTION_NAMES)}")
    s = ExudynSettings(**{k: v for k, v in options.items() if k != "max_memory"})
    return ExudynSettings(
        step_size=check_real("step_size", s.step_size, 0.0, low_open=True, unit="s"),
        contact=check_choice("contact", s.contact, CONTACT_VARIANTS),
        spectral_radius=check_real("spectral_radius", s.spectral_radius, 0.0, 1.0),
        modified_newton=check_bool("modified_newton", s.modified_newton),
        onset=check_choice("onset", s.onset, ONSET_MODES),
        newton_tolerance=check_real("newton_tolerance", s.newton_tolerance, 0.0,
                                    low_open=True))


def estimate_memory(mech: SliderCrank, revolutions: int, settings: ExudynSettings,
                    outputs: tuple[str, ...] = ("all",)) -> tuple[int, int]:
    """(time steps, peak bytes) of a run: Exudyn stores every step of every sensor
    (SENSOR_FLOATS), the arrays are copied out of it, and a Trajectory holds 16 floats
    per step; so 2 copies of the sensors plus 16 floats (peak-only: the base force only)."""
    groups = OUTPUT_GROUPS if "all" in outputs else outputs
    floats = sum(SENSOR_FLOATS[g] for g in groups)
    steps = max(1, int(round(revolutions * mech.period / settings.step_size)))
    per_step = 8 * (2 * floats + (16 if "all" in outputs else 0))
    return steps, (steps + 1) * per_step


def _check_memory(mech, revolutions, settings, outputs, max_memory) -> None:
    max_memory = check_max_memory(max_memory)
    steps, need = estimate_memory(mech, revolutions, settings, outputs)
    if need > max_memory:
        raise MemoryLimitError(
            f"the Exudyn run of {revolutions} revolutions takes {steps:.3g} fixed steps of "
            f"{settings.step_size:g} s and needs about {format_bytes(need)} for its records, "
            f"more than max_memory={max_memory} bytes ({format_bytes(max_memory)}); raise "
            "step_size or max_memory, or run fewer revolutions")


def _check_run(mech, revolutions, settings: ExudynSettings, name="revolutions") -> int:
    if not isinstance(mech, SliderCrank):
        raise ValueError(f"mech must be a SliderCrank; got {type(mech).__name__}")
    revolutions = check_int(name, revolutions, 1)
    if settings.contact == "sphere" and sphere_restitution(mech) <= 0.0:
        raise ValueError(
            f"contact='sphere' cannot represent contact_model={mech.contact_model!r} with "
            f"restitution {mech.restitution!r}: Exudyn's restitution 1 - xi/1.5 = "
            f"{sphere_restitution(mech):.3g} must be > 0; use contact='symbolic'")
    return revolutions


def sphere_restitution(mech: SliderCrank) -> float:
    """Restitution e' for Exudyn's Hunt-Crossley sphere contact that reproduces our law.

    Exudyn's impactModel 1 damps with 1.5 (1 - e'); matching xi(e) gives e' = 1 - xi/1.5,
    i.e. (1 + e^2)/2 for Lankarani-Nikravesh and e for Hunt-Crossley.
    """
    xi, _ = hysteresis_factor(mech.restitution, CONTACT_MODELS[mech.contact_model])
    return 1.0 - xi / 1.5


class _ImpactMemory:
    """Impact velocity deltadot_minus and contact mode, updated once per step (pre-step)."""

    def __init__(self, floor: float):
        self.floor = floor
        self.dmin = floor          # as the reduced model: the floor until the first onset
        self.mode = 0              # 1 from a registered onset until separation
        self.onsets = 0
        self.symbol = None         # named symbolic Real mirrored for the compiled force
        self.previous = None       # (t, delta, deltadot) of the previous step's state

    def set(self, value: float, new_onset: bool = True) -> None:
        self.dmin = max(value, self.floor)
        self.onsets += int(new_onset)
        if self.symbol is not None:
            self.symbol.SetValue(self.dmin)


@dataclass
class ExudynModel:
    """A built Exudyn system: container, system, item indices and sensors."""

    SC: object
    mbs: object
    mech: SliderCrank
    settings: ExudynSettings
    items: dict
    sensors: dict
    memory: _ImpactMemory | None
    keep_alive: list


def build_model(mech: SliderCrank, settings: ExudynSettings | None = None,
                outputs: tuple[str, ...] = ("all",)) -> ExudynModel:
    """Create the Exudyn system for `mech` (not yet solved).

    `outputs` selects the sensors: "base_force", "crank_moment", "contact", "slider",
    "coupler" or "all". The symbolic user function is built here, in the calling process.
    """
    import exudyn as exu
    import exudyn.itemInterface as ii

    settings = ExudynSettings() if settings is None else settings
    want = set(outputs)
    unknown = want - {"all", *OUTPUT_GROUPS}
    if unknown:
        raise ValueError(f"unknown output group(s) {sorted(unknown)}; "
                         f"allowed: {['all', *OUTPUT_GROUPS]}")
    if "all" in want:
        want = set(OUTPUT_GROUPS)

    L2, L3 = mech.crank_length, mech.coupler_length
    w = mech.crank_speed
    th2 = mech.initial_crank_angle
    c = mech.clearance
    th3, x4, th3d, x4d, _ = initial_state(mech)

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ii.ObjectGround())
    n_ground = mbs.AddNode(ii.NodePointGround())

    # initial state: ideal-joint positions and velocities (journal centred, as reduced)
    e2 = np.array([math.cos(th2), math.sin(th2)])
    t2 = np.array([-e2[1], e2[0]])
    e3 = np.array([math.cos(th3), math.sin(th3)])
    t3 = np.array([-e3[1], e3[0]])
    g2, v2 = 0.5 * L2 * e2, 0.5 * L2 * w * t2
    g3 = L2 * e2 + 0.5 * L3 * e3
    v3 = L2 * w * t2 + 0.5 * L3 * th3d * t3

    n2 = mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=[g2[0], g2[1], th2],
                                        initialVelocities=[v2[0], v2[1], w]))
    crank = mbs.AddObject(ii.ObjectRigidBody2D(nodeNumber=n2, mass=mech.crank_mass,
                                               inertia=mech.crank_inertia_value))
    n3 = mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=[g3[0], g3[1], th3],
                                        initialVelocities=[v3[0], v3[1], th3d]))
    coupler = mbs.AddObject(ii.ObjectRigidBody2D(nodeNumber=n3, mass=mech.coupler_mass,
                                                 inertia=mech.coupler_inertia_value))
    # the slider's rotational inertia never acts (rotation locked); a disc of radius R_B
    n4 = mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=[x4, 0.0, 0.0],
                                        initialVelocities=[x4d, 0.0, 0.0]))
    slider = mbs.AddObject(ii.ObjectRigidBody2D(
        nodeNumber=n4, mass=mech.slider_mass,
        inertia=0.5 * mech.slider_mass * mech.bearing_radius**2))

    m_ground = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=ground, localPosition=[0, 0, 0]))
    m_crank0 = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=crank,
                                                   localPosition=[-0.5 * L2, 0, 0]))
    m_crank1 = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=crank,
                                                   localPosition=[0.5 * L2, 0, 0]))
    m_coupler0 = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=coupler,
                                                     localPosition=[-0.5 * L3, 0, 0]))
    m_journal = mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=coupler,
                                                 localPosition=[0.5 * L3, 0, 0]))
    m_bearing = mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=slider, localPosition=[0, 0, 0]))

    base_joint = mbs.AddObject(ii.RevoluteJoint2D(markerNumbers=[m_ground, m_crank0]))
    mbs.AddObject(ii.RevoluteJoint2D(markerNumbers=[m_crank1, m_coupler0]))

    m_gc = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=n_ground, coordinate=0))
    m_phi2 = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=n2, coordinate=2))
    drive = mbs.AddObject(ii.CoordinateConstraint(markerNumbers=[m_gc, m_phi2], offset=w,
                                                  velocityLevel=True))
    for coord in (1, 2):       # slider: y = 0 and no rotation (prismatic guide along x)
        m = mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=n4, coordinate=coord))
        mbs.AddObject(ii.CoordinateConstraint(markerNumbers=[m_gc, m]))

    for body in (crank, coupler, slider):
        m = mbs.AddMarker(ii.MarkerBodyMass(bodyNumber=body))
        mbs.AddLoad(ii.LoadMassProportional(markerNumber=m, loadVector=[0, -mech.gravity, 0]))

    keep_alive: list = []
    memory = None
    if settings.contact == "sphere":
        gap0 = c           # journal centred: gap = c > 0, no contact (Exudyn's data[0])
        n_data = mbs.AddNode(ii.NodeGenericData(numberOfDataCoordinates=4,
                                                initialCoordinates=[gap0, 0.0, 0.0, 0.0]))
        joint = mbs.AddObject(ii.ObjectContactSphereSphere(
            markerNumbers=[m_journal, m_bearing], nodeNumber=n_data,
            spheresRadii=[mech.journal_radius, mech.bearing_radius], isHollowSphere1=True,
            contactStiffness=mech.stiffness, contactStiffnessExponent=1.5,
            contactDamping=0.0, dynamicFriction=0.0,
            restitutionCoefficient=sphere_restitution(mech),
            minimumImpactVelocity=mech.impact_velocity_floor, impactModel=1))
        ecc_sign = -1.0    # Displacement = bearing - journal
    else:
        memory = _ImpactMemory(mech.impact_velocity_floor)
        joint = mbs.AddObject(ii.CartesianSpringDamper(markerNumbers=[m_bearing, m_journal]))
        if settings.contact == "symbolic":
            uf = _symbolic_force(mbs, joint, mech, memory)
            keep_alive += [uf, memory.symbol]     # the expression tree must outlive the run
        else:
            uf = _python_force(mech, memory)
        mbs.SetObjectParameter(joint, "springForceUserFunction", uf)
        mbs.SetPreStepUserFunction(_pre_step(joint, mech, settings, memory))
        ecc_sign = 1.0     # Displacement = journal - bearing

    def sensor(kind, number, var):
        make = ii.SensorObject if kind == "object" else ii.SensorNode
        key = "objectNumber" if kind == "object" else "nodeNumber"
        return mbs.AddSensor(make(**{key: number}, outputVariableType=var, storeInternal=True,
                                  writeToFile=False))

    OVT = exu.OutputVariableType
    sensors: dict = {}
    if "base_force" in want:
        sensors["base_force"] = sensor("object", base_joint, OVT.Force)
    if "crank_moment" in want:
        sensors["drive"] = sensor("object", drive, OVT.Force)
    if "contact" in want:
        sensors["displacement"] = sensor("object", joint, OVT.Displacement)
        sensors["joint_force"] = sensor("object", joint, OVT.Force)
    if "slider" in want:
        sensors["slider_position"] = sensor("node", n4, OVT.Position)
        sensors["slider_velocity"] = sensor("node", n4, OVT.Velocity)
        sensors["slider_acceleration"] = sensor("node", n4, OVT.Acceleration)
    if "coupler" in want:
        sensors["coupler_angle"] = sensor("node", n3, OVT.Coordinates)
        sensors["coupler_rate"] = sensor("node", n3, OVT.Coordinates_t)

    mbs.Assemble()
    items = dict(crank=crank, coupler=coupler, slider=slider, base_joint=base_joint,
                 drive=drive, joint=joint, n_crank=n2, n_coupler=n3, n_slider=n4,
                 ecc_sign=ecc_sign, coupler_reference_angle=th3)
    return ExudynModel(SC=SC, mbs=mbs, mech=mech, settings=settings, items=items,
                       sensors=sensors, memory=memory, keep_alive=keep_alive)


def _law_constants(mech: SliderCrank):
    model = CONTACT_MODELS[mech.contact_model]
    xi, _ = hysteresis_factor(mech.restitution, model)
    return mech.stiffness, mech.clearance, float(xi), model


def _python_force(mech: SliderCrank, memory: _ImpactMemory):
    """Plain Python user function: the reduced model's compiled contact law."""
    K, c, _, model = _law_constants(mech)
    e = mech.restitution

    def force(mbs, t, itemNumber, displacement, velocity, stiffness, damping, offset):
        dx, dy = displacement[0], displacement[1]
        r = math.sqrt(dx * dx + dy * dy)
        delta = r - c
        if delta <= 0.0:
            return [0.0, 0.0, 0.0]
        rate = (dx * velocity[0] + dy * velocity[1]) / r
        f = contact_force(delta, rate, memory.dmin, K, e, model) / r
        return [f * dx, f * dy, 0.0]

    return force


def _symbolic_force(mbs, joint, mech: SliderCrank, memory: _ImpactMemory):
    """Compiled (symbolic) user function; the impact velocity is a named symbolic variable."""
    import exudyn as exu
    from exudyn.advancedUtilities import CreateSymbolicUserFunction

    esym = exu.symbolic
    K, c, xi, _ = _law_constants(mech)
    dmin = esym.Real("deltadot_minus", memory.dmin)
    memory.symbol = dmin
    zero = esym.Real(0.0)

    def force(mbs, t, itemNumber, displacement, velocity, stiffness, damping, offset):
        dx, dy = displacement[0], displacement[1]
        r = esym.sqrt(dx * dx + dy * dy)
        delta = r - c
        rate = (dx * velocity[0] + dy * velocity[1]) / r
        magnitude = esym.max(K * delta**1.5 * (1.0 + xi * rate / dmin), zero)
        # lazy: r > c > 0 inside the true branch, so no division by zero when centred
        factor = esym.IfThenElse(delta > 0.0, magnitude / r, zero)
        return [factor * dx, factor * dy, zero]

    return CreateSymbolicUserFunction(mbs, force, "springForceUserFunction", joint)


def _pre_step(joint, mech: SliderCrank, settings: ExudynSettings, memory: _ImpactMemory):
    """Pre-step function: register contact onsets and their impact velocity.

    Exudyn calls it at the start of each step with the new time t_n+1 and the converged state
    of t_n. With two consecutive states the penetration acceleration is known by a difference
    quotient, which makes both impact-velocity estimates second-order accurate in h:

    - predicted onset (``onset="predict"``, delta_n <= 0 < delta_n + h deltadot_n): deltadot
      extrapolated to the predicted crossing time, used from the crossing step on;
    - onset found after the crossing step (delta_n-1 <= 0 < delta_n): deltadot interpolated
      linearly in delta between the two bracketing states; this also refines a prediction.
    """
    import exudyn as exu

    c = mech.clearance
    h = settings.step_size
    predict = settings.onset == "predict"
    disp = exu.OutputVariableType.Displacement
    vel = exu.OutputVariableType.Velocity

    def pre_step(mbs, t):
        d = mbs.GetObjectOutput(joint, disp)
        v = mbs.GetObjectOutput(joint, vel)
        r = math.sqrt(d[0] * d[0] + d[1] * d[1])
        delta = r - c
        rate = (d[0] * v[0] + d[1] * v[1]) / r if r > 0.0 else 0.0
        prev = memory.previous
        if prev is not None and t <= prev[0]:
            prev = None        # step repeated after a failed Newton: no new information
        if delta <= 0.0:
            if predict and delta + h * rate > 0.0:
                accel = (rate - prev[2]) / (t - prev[0]) if prev is not None else 0.0
                s = -delta / rate                      # time to the crossing, then one
                q = rate + accel * s                   # Newton step on the quadratic
                if q > 0.0:
                    s -= (delta + rate * s + 0.5 * accel * s * s) / q
                memory.set(rate + accel * min(max(s, 0.0), h), new_onset=memory.mode == 0)
                memory.mode = 1
            else:
                memory.mode = 0
        elif prev is not None and prev[1] <= 0.0:
            # crossed during the last step: interpolate deltadot at delta = 0
            theta = prev[1] / (prev[1] - delta)
            memory.set(prev[2] + theta * (rate - prev[2]), new_onset=memory.mode == 0)
            memory.mode = 1
        elif memory.mode == 0:
            memory.set(rate)   # in contact without a registered onset (e.g. the first step)
            memory.mode = 1
        memory.previous = (t, delta, rate)
        return True

    return pre_step


def _simulation_settings(settings: ExudynSettings, end_time: float):
    import exudyn as exu

    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    n_steps = max(1, int(round(end_time / settings.step_size)))
    ti.numberOfSteps = n_steps
    ti.endTime = end_time
    ti.verboseMode = 0
    ti.discontinuous.useRecommendedStepSize = False
    ti.generalizedAlpha.spectralRadius = float(settings.spectral_radius)
    ti.newton.useModifiedNewton = settings.modified_newton
    ti.newton.relativeTolerance = float(settings.newton_tolerance)
    ss.show.statistics = False
    ss.show.computationTime = False
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = 0.0      # every step
    return ss, n_steps


def solve(model: ExudynModel, end_time: float) -> dict:
    """Run the time integration to `end_time` (s); returns solver statistics.

    Raises RuntimeError with advice if Exudyn's solver fails.
    """
    import exudyn as exu

    ss, n_steps = _simulation_settings(model.settings, end_time)
    wall = time.perf_counter()
    try:
        ok = exu.SolveDynamic(model.mbs, ss, storeSolver=True)
    except Exception as exc:  # Exudyn raises its own error types from C++
        if "USER FUNCTION" in str(exc):      # a bug in our pre-step or force function
            raise RuntimeError(f"Exudyn user function failed: {exc}") from exc
        raise RuntimeError(_failure_message(model, f"{type(exc).__name__}: {exc}")) from exc
    wall = time.perf_counter() - wall
    solver = model.mbs.sys.get("dynamicSolver")
    if not ok:
        raise RuntimeError(_failure_message(model, "the solver reported failure"))
    stats = dict(step_size=model.settings.step_size, step_size_used=end_time / n_steps,
                 n_steps=n_steps, wall_time=wall,
                 **{k: v for k, v in asdict(model.settings).items() if k != "step_size"})
    if solver is not None:
        it = solver.it
        stats.update(newton_steps=int(it.newtonStepsCount), jacobians=int(it.newtonJacobiCount),
                     discontinuous_iterations=int(it.discontinuousIterationsCount))
    if model.memory is not None:
        stats["onsets"] = model.memory.onsets
    return stats


def _failure_message(model: ExudynModel, reason: str) -> str:
    s = model.settings
    return (f"Exudyn time integration failed ({reason}) with step_size={s.step_size:g} s, "
            f"contact={s.contact!r}; try a smaller step_size (e.g. {s.step_size / 2:g}) or "
            "modified_newton=False")


def _stored(model: ExudynModel, name: str) -> np.ndarray:
    return np.asarray(model.mbs.GetSensorStoredData(model.sensors[name]))


def simulate_exudyn(mech: SliderCrank, revolutions: int = 4, **options) -> Trajectory:
    """Simulate `revolutions` crank revolutions with Exudyn; returns a `Trajectory`.

    Parameters
    ----------
    mech : SliderCrank
    revolutions : int
        Full crank revolutions from t = 0 (>= 1).
    **options
        `ExudynSettings` fields: ``step_size`` (s, default `DEFAULT_STEP_SIZE`),
        ``contact`` ("symbolic", "python", "sphere"), ``spectral_radius``,
        ``modified_newton``, ``onset``, ``newton_tolerance``, and ``max_memory`` (bytes;
        a run whose records `estimate_memory` puts above it is refused). Unknown names or
        bad values raise ValueError before anything is computed.

    Returns
    -------
    Trajectory
        Every time step, t = 0, h, 2h, ...; ``peaks`` is None (maxima are over the steps).
        ``contact_phase`` is 1 where the penetration is positive. ``contact_force`` is
        the signed normal force (only the native sphere contact can make it negative, see
        the module docstring). ``stats`` holds the settings, the step actually used
        (``step_size_used`` = end time / number of steps), whether every step kept that
        size (``uniform_steps``; False if Exudyn had to cut a step after a Newton failure),
        Newton counters and the wall time in s.
    """
    max_memory = options.pop("max_memory", None)
    settings = make_settings(options)
    revolutions = _check_run(mech, revolutions, settings)
    _check_memory(mech, revolutions, settings, ("all",), max_memory)
    model = build_model(mech, settings)
    stats = solve(model, revolutions * mech.period)

    F = _stored(model, "base_force")
    t = F[:, 0].copy()
    base_force = np.ascontiguousarray(F[:, 1:3])
    moment = -_stored(model, "drive")[:, 1]          # drive moment on the crank = -lambda
    ecc = model.items["ecc_sign"] * _stored(model, "displacement")[:, 1:3]
    r = np.hypot(ecc[:, 0], ecc[:, 1])
    penetration = r - mech.clearance
    fj = _stored(model, "joint_force")[:, 1:3]
    # CartesianSpringDamper: f = F e/|e|; sphere contact: f = -F e/|e| (see module doc)
    with np.errstate(invalid="ignore", divide="ignore"):
        F_n = model.items["ecc_sign"] * (fj[:, 0] * ecc[:, 0] + fj[:, 1] * ecc[:, 1]) / r
    contact = np.where(r > 0.0, F_n, 0.0)
    power = moment * mech.crank_speed
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    stats["uniform_steps"] = bool(len(t) == stats["n_steps"] + 1 and np.allclose(
        np.diff(t), stats["step_size_used"], rtol=1e-6, atol=0.0))
    theta3 = _stored(model, "coupler_angle")[:, 3] + model.items["coupler_reference_angle"]
    return annotate(Trajectory(
        t=t,
        base_force=base_force,
        crank_moment=moment,
        contact_force=contact,
        penetration=penetration,
        eccentricity=np.ascontiguousarray(ecc),
        slider_position=_stored(model, "slider_position")[:, 1].copy(),
        slider_velocity=_stored(model, "slider_velocity")[:, 1].copy(),
        slider_acceleration=_stored(model, "slider_acceleration")[:, 1].copy(),
        coupler_angle=theta3,
        coupler_rate=_stored(model, "coupler_rate")[:, 3].copy(),
        contact_phase=(penetration > 0.0).astype(np.int8),
        crank_work=work,
        mechanism=mech,
        backend="exudyn",
        stats=stats,
        peaks=None,
    ))


def peak_exudyn(mech: SliderCrank, revolution: int = 4, **options) -> float:
    """Max |F12| in N over crank revolution `revolution` (1-based), over the time steps.

    Integrates only up to the end of that revolution and records only the base force.
    Options as `simulate_exudyn`.
    """
    max_memory = options.pop("max_memory", None)
    settings = make_settings(options)
    revolution = _check_run(mech, revolution, settings, "revolution")
    _check_memory(mech, revolution, settings, ("base_force",), max_memory)
    model = build_model(mech, settings, outputs=("base_force",))
    solve(model, revolution * mech.period)
    F = _stored(model, "base_force")
    t = F[:, 0]
    t_a, t_b = (revolution - 1) * mech.period, revolution * mech.period
    tol = 1e-12 * max(1.0, t_b)
    mask = (t >= t_a - tol) & (t <= t_b + tol)
    return float(np.hypot(F[mask, 1], F[mask, 2]).max())
