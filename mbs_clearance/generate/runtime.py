"""What every generated model module imports: the kernel signatures of protocol v2 (from the
integrator) and the clearance joints' contact stage (one place for the penetration, its rate
and the force)."""

from __future__ import annotations

import math

import numba as nb

from ..laws._dispatch import friction_force_slots
from ..laws.forces import contact_force
from ..laws.lubrication import lubricated_force
from ..numerics.integrator import ACTION_SIG, EVENT_SIG, KERNEL, MONITOR_SIG, RHS_SIG

__all__ = ["KERNEL", "RHS_SIG", "EVENT_SIG", "ACTION_SIG", "MONITOR_SIG", "gap_state",
           "contact_stage", "friction_stage", "lubricated_stage", "switching",
           "corner_state", "corner_stage", "corner_friction_stage"]


@nb.njit(**KERNEL, inline="always")
def gap_state(ex, ey, exd, eyd, clearance):
    """(delta, deltadot, nx, ny) of a clearance joint from the journal centre's position
    (ex, ey) and velocity relative to the bearing centre: penetration |e| - c, its rate and
    the unit vector n = e / |e| (n = (-1, 0) when the journal is exactly centred, as the
    hand-written model has it)."""
    r = math.sqrt(ex * ex + ey * ey)
    if r > 1e-300:
        inv_r = 1.0 / r
        nx = ex * inv_r
        ny = ey * inv_r
    else:
        nx = -1.0
        ny = 0.0
    return r - clearance, nx * exd + ny * eyd, nx, ny


@nb.njit(**KERNEL, inline="always")
def contact_stage(ex, ey, exd, eyd, clearance, mode, deltadot_minus, stiffness, restitution,
                  model):
    """(F, delta, deltadot, fx, fy): the contact force magnitude of the law
    (`contact.contact_force`, zero in free flight, mode 0), the penetration and its rate, and
    the force F n that the bearing exerts on the journal is -F n (n from the bearing centre to
    the journal centre): fx, fy = F n."""
    delta, deltadot, nx, ny = gap_state(ex, ey, exd, eyd, clearance)
    f = 0.0
    if mode > 0.5:
        f = contact_force(delta, deltadot, deltadot_minus, stiffness, restitution, int(model))
    return f, delta, deltadot, f * nx, f * ny


@nb.njit(**KERNEL, inline="always")
def friction_stage(ex, ey, exd, eyd, spin, clearance, mode, deltadot_minus, stiffness,
                   restitution, model, law, slots):
    """`contact_stage` with friction: (F, delta, deltadot, fx, fy, ft, vt) where ft is the
    friction force on the journal along the tangent t = (-n_y, n_x) (the law's force, its
    parameters `slots` the values of `laws.FRICTION_SLOTS`, of the slip velocity
    vt = edot . t + spin, spin = omega_J R_J - omega_B R_B, and the normal force F) and
    fx, fy = F n - ft t the force on the bearing."""
    f, delta, deltadot, fx, fy = contact_stage(ex, ey, exd, eyd, clearance, mode,
                                               deltadot_minus, stiffness, restitution, model)
    _, _, nx, ny = gap_state(ex, ey, exd, eyd, clearance)
    vt = eyd * nx - exd * ny + spin
    ft = friction_force_slots(vt, f, slots, int(law))
    return f, delta, deltadot, fx + ft * ny, fy - ft * nx, ft, vt


@nb.njit(**KERNEL, inline="always")
def lubricated_stage(ex, ey, exd, eyd, omega_j, omega_b, clearance, mode, deltadot_minus,
                     stiffness, restitution, model, lubrication, viscosity, length,
                     journal_radius, fade_start, fade_end):
    """`contact_stage` of a joint in an oil film: (F, delta, deltadot, fx, fy, tj, tb, ffx,
    ffy, power) with fx, fy the dry contact's force on the bearing minus the film's force
    (ffx, ffy) on the journal (`laws.lubrication.lubricated_force`, faded out near the
    wall), tj the film's torque on the journal, tb its torque on the bearing about the
    bearing's centre (-tj minus the moment of the film's force moved there), and the film's
    total power (never positive)."""
    f, delta, deltadot, fx, fy = contact_stage(ex, ey, exd, eyd, clearance, mode,
                                               deltadot_minus, stiffness, restitution, model)
    ffx, ffy, tj, _ = lubricated_force(ex, ey, exd, eyd, omega_j, omega_b, journal_radius,
                                       clearance, length, viscosity, int(lubrication),
                                       fade_start, fade_end)
    tb = -tj - (ex * ffy - ey * ffx)
    power = (ffx * (exd + omega_b * ey) + ffy * (eyd - omega_b * ex)
             + tj * (omega_j - omega_b))
    return f, delta, deltadot, fx - ffx, fy - ffy, tj, tb, ffx, ffy, power


@nb.njit(**KERNEL, inline="always")
def corner_state(h, hd, side, clearance, half_height):
    """(delta, deltadot) of a corner of a translational clearance joint's slider from its
    normal offset h from the guide's mid-line and its rate: the penetration side h - (b + c)
    into the surface on its side (side +1 the upper, -1 the lower) and its rate."""
    return side * h - (half_height + clearance), side * hd


@nb.njit(**KERNEL, inline="always")
def corner_stage(h, hd, side, clearance, half_height, mode, deltadot_minus, stiffness,
                 restitution, model):
    """(F, delta, deltadot, fn): the contact force magnitude of the law at a corner (zero in
    free flight, mode 0), its penetration and rate (`corner_state`), and the normal force on
    the slider along the guide's normal, fn = -side F (the surface pushes the corner back)."""
    delta, deltadot = corner_state(h, hd, side, clearance, half_height)
    f = 0.0
    if mode > 0.5:
        f = contact_force(delta, deltadot, deltadot_minus, stiffness, restitution, int(model))
    return f, delta, deltadot, -side * f


@nb.njit(**KERNEL, inline="always")
def corner_friction_stage(h, hd, vt, side, clearance, half_height, mode, deltadot_minus,
                          stiffness, restitution, model, law, slots):
    """`corner_stage` with friction: (F, delta, deltadot, fn, ft), ft the friction force on
    the slider along the guide's axis (the law's force at the corner's sliding velocity vt
    along the axis relative to the guide, and the normal force F)."""
    f, delta, deltadot, fn = corner_stage(h, hd, side, clearance, half_height, mode,
                                          deltadot_minus, stiffness, restitution, model)
    return f, delta, deltadot, fn, friction_force_slots(vt, f, slots, int(law))


@nb.njit(**KERNEL, inline="always")
def switching(mode, delta, deltadot):
    """The switching function of a clearance joint and its rate: penetration (and rate) in
    free flight, minus them in contact."""
    if mode > 0.5:
        return -delta, -deltadot
    return delta, deltadot
