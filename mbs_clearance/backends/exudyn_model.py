"""The slider-crank with a clearance joint in the multibody engine Exudyn (backend "exudyn").

An independent implementation of the same mechanism as `reduced`: three planar rigid bodies
with absolute coordinates, ideal joints as algebraic constraints, solved by Exudyn's implicit
generalized-alpha integrator with a fixed step size. Only the clearance-joint contact law is
ours; everything else (kinematics, mass matrix, constraint forces) is Exudyn's.

The system is built by `exudyn_linkage.build` from the mechanism's description
(`cases.from_slider_crank`): one builder for every linkage. This module maps a
`SliderCrank` to it and the result back to the slider-crank's series. What follows describes
the slider-crank as that builder makes it.

Model
-----
- Crank (body 2): `ObjectRigidBody2D`, node at its centre of mass (L2/2 from the pivot),
  mass m2, inertia J2 about the CG; `RevoluteJoint2D` to the ground at the origin. Constant
  speed by a velocity-level `CoordinateConstraint` on the crank rotation coordinate
  (d(phi2)/dt - omega2 = 0); its Lagrange multiplier lambda is the drive: the moment applied
  to the crank is -lambda (Exudyn adds C_q^T lambda on the left-hand side).
- Coupler (body 3): `ObjectRigidBody2D`, node at the CG (mid-length), mass m3, inertia J3;
  `RevoluteJoint2D` to the crank end.
- Slider (body 4): `ObjectRigidBody2D` of mass m4 on an `ObjectJointPrismatic2D` along the
  x axis with its rotation constrained (a rigid body rather than a point mass because the
  prismatic joint and the native sphere contact ask for markers with an orientation).
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

from .._checks import check_int
from ..elements import revolute
from ..model.mechanism import SliderCrank
from ..solve.trajectory import Trajectory, annotate
from . import exudyn_linkage as xl
from .exudyn_linkage import CONTACT_VARIANTS, ONSET_MODES, ExudynSettings

__all__ = [
    "simulate_exudyn", "peak_exudyn", "build_model", "ExudynSettings", "make_settings",
    "CONTACT_VARIANTS", "DEFAULT_STEP_SIZE", "OPTION_NAMES", "ONSET_MODES",
    "sphere_restitution",
]

#: the default fixed step in s at the paper's design (`ExudynSettings.step` of its
#: description; other designs take the same rule); chosen with
#: benchmarks/exudyn_speed.py: at 2e-6 s (6000 steps per revolution at 5000 rpm,
#: `exudyn_linkage.DEFAULT_STEPS_PER_REVOLUTION`) the paper case's 4th-revolution peak |F12|
#: is within 0.03 % of the tight reduced reference; 5e-6 s gives 0.07 %.
DEFAULT_STEP_SIZE = 2.0e-6

#: option names accepted by simulate_exudyn / peak_exudyn (as the linkage backend's)
OPTION_NAMES: tuple[str, ...] = tuple(n for n in xl.OPTION_NAMES if n != "start")


def make_settings(options: dict) -> ExudynSettings:
    """Validate backend options and return them as `ExudynSettings` (ValueError naming the
    option and its range if bad); without step_size, accuracy or steps_per_revolution the
    step follows the description's rule (`ExudynSettings.step`), as for every linkage."""
    return xl.make_settings(options)


def sphere_restitution(mech: SliderCrank) -> float:
    """Restitution e' for Exudyn's Hunt-Crossley sphere contact that reproduces our law
    (`elements.revolute.sphere_restitution` of the mechanism's clearance joint)."""
    return revolute.sphere_restitution(_linkage(mech).clearance_joints[0])


def _linkage(mech: SliderCrank):
    from ..model.cases import from_slider_crank

    return from_slider_crank(mech)      # ValueError for anything but a SliderCrank


def build_model(mech: SliderCrank, settings: ExudynSettings | None = None,
                outputs: tuple[str, ...] = ("all",)) -> xl.ExudynModel:
    """The Exudyn system of `mech` (not yet solved), by `exudyn_linkage.build`."""
    settings = make_settings({}) if settings is None else settings
    return xl.build(_linkage(mech), settings, outputs)


def _options(mech, revolutions, options, name):
    from ..solve.linkage_model import prepare_span

    max_memory = options.pop("max_memory", None)
    settings = make_settings(options)
    linkage = _linkage(mech)
    span = prepare_span(linkage, check_int(name, revolutions, 1), max_memory=max_memory)
    return linkage, settings, span, max_memory


def simulate_exudyn(mech: SliderCrank, revolutions: int = 4, **options) -> Trajectory:
    """Simulate `revolutions` crank revolutions with Exudyn; returns a `Trajectory`.

    Parameters
    ----------
    mech : SliderCrank
    revolutions : int
        Full crank revolutions from t = 0 (>= 1).
    **options
        `ExudynSettings` fields: ``step_size`` (s, default `ExudynSettings.step` of the
        description: 2e-6 s at the paper's design) or
        ``accuracy`` or ``steps_per_revolution``, ``contact`` ("symbolic", "python",
        "sphere"), ``spectral_radius``, ``modified_newton``, ``onset``,
        ``newton_tolerance``, and ``max_memory`` (bytes; a run whose records are estimated
        above it is refused). Unknown names or bad values raise ValueError before anything
        is computed.

    Returns
    -------
    Trajectory
        Every time step, t = 0, h, 2h, ...; ``peaks``: max |F12| per revolution refined
        between the steps (`exudyn_linkage.refined_peaks`).
        ``contact_phase`` is 1 where the penetration is positive. ``contact_force`` is
        the signed normal force (only the native sphere contact can make it negative, see
        the module docstring). ``stats`` holds the settings, the step actually used
        (``step_size_used`` = end time / number of steps), whether every step kept that
        size (``uniform_steps``), Newton counters and the wall time in s.
    """
    linkage, settings, span, max_memory = _options(mech, revolutions, options, "revolutions")
    lt = xl.run_linkage(linkage, span, settings, max_memory)
    return annotate(Trajectory(
        t=lt.t, base_force=lt.base_force, crank_moment=lt.crank_moment,
        contact_force=lt.contact_force[:, 0].copy(), penetration=lt.penetration[:, 0].copy(),
        eccentricity=lt.eccentricity[:, 0].copy(),
        contact_phase=lt.contact_phase[:, 0].copy(), crank_work=lt.crank_work,
        mechanism=mech, backend="exudyn", stats=lt.stats, peaks=lt.peaks, joints=lt.joints,
        reactions=lt.reactions, shaking_force=lt.shaking_force, coordinates=lt.coordinates,
        rates=lt.rates, accelerations=lt.accelerations))


def peak_exudyn(mech: SliderCrank, revolution: int = 4, **options) -> float:
    """Max |F12| in N over crank revolution `revolution` (1-based), refined between the
    time steps (`exudyn_linkage.refined_peaks`).

    Integrates only up to the end of that revolution and records only the base force.
    Options as `simulate_exudyn`.
    """
    linkage, settings, span, max_memory = _options(mech, revolution, options, "revolution")
    return xl.peak_run(linkage, span, settings, max_memory)
