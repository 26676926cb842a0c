"""The paper's slider-crank in closed form (Eqs. 1-8 of Ebrahimi, Salahshoor & Nouri 2018,
docs/derivations.md), written by hand in plain Python: the independent reference against
which the tests check the model generated from its description (sympy.physics.mechanics).
Not used by the library (its one model of the physics is the generated one).

State y = [theta3, x4, theta3dot, x4dot, ...]; the crank angle theta2 = omega2 t + theta20
is prescribed. `dynamics` returns (theta3dd, x4dd, F, delta, deltadot, ex, ey, M2, F12x,
F12y): accelerations, contact force, penetration and its rate, the journal centre minus the
bearing centre, the crank moment and the base force F12 (the crank pivot's reaction on the
ground).
"""

from __future__ import annotations

import math

from mbs_clearance.laws.forces import CONTACT_MODELS, contact_force
from mbs_clearance.model.mechanism import SliderCrank
from mbs_clearance.numerics._trig import sincos

__all__ = ["gap", "dynamics", "switching", "impact_velocity"]


def gap(mech: SliderCrank, t: float, y) -> tuple[float, ...]:
    """(ex, ey, r, delta, deltadot, nx, ny): the vector from the journal centre to the
    bearing centre, its length, the penetration r - c, its rate and n = e / r (Eqs. 1-3,
    10-11)."""
    L2, L3, w = mech.crank_length, mech.coupler_length, mech.crank_speed
    s2, c2 = sincos(w * t + mech.initial_crank_angle)
    s3, c3 = sincos(y[0])
    ex = y[1] - L2 * c2 - L3 * c3
    ey = -L2 * s2 - L3 * s3
    exd = y[3] + L2 * w * s2 + L3 * y[2] * s3
    eyd = -L2 * w * c2 - L3 * y[2] * c3
    r = math.sqrt(ex * ex + ey * ey)
    nx, ny = (ex * (1.0 / r), ey * (1.0 / r)) if r > 1e-300 else (1.0, 0.0)
    return ex, ey, r, r - mech.clearance, nx * exd + ny * eyd, nx, ny


def dynamics(mech: SliderCrank, t: float, y, mode: float, dmin: float) -> tuple[float, ...]:
    """Accelerations (Eqs. 6-7), contact force (in contact mode, impact velocity dmin), the
    gap, crank moment (Eq. 8) and base force F12 (Newton for crank and coupler)."""
    L2, L3, w, g = mech.crank_length, mech.coupler_length, mech.crank_speed, mech.gravity
    m2, m3, m4 = mech.crank_mass, mech.coupler_mass, mech.slider_mass
    s2, c2 = sincos(w * t + mech.initial_crank_angle)
    s3, c3 = sincos(y[0])
    ex, ey, r, delta, deltadot, nx, ny = gap(mech, t, y)
    F = 0.0
    if mode > 0.5:
        F = contact_force(delta, deltadot, dmin, mech.stiffness, mech.restitution,
                          CONTACT_MODELS[mech.contact_model])
    sin32 = s3 * c2 - c3 * s2
    cos23 = c2 * c3 + s2 * s3
    inv_inertia = 1.0 / (mech.coupler_inertia_value + 0.25 * m3 * L3 * L3)
    th3d = y[2]
    th3dd = -(0.5 * m3 * L2 * L3 * w * w * sin32 + 0.5 * m3 * g * L3 * c3
              + L3 * F * (s3 * nx - c3 * ny)) * inv_inertia
    x4dd = -F * nx * (1.0 / m4)
    M2 = (0.5 * m3 * L2 * L3 * (th3dd * cos23 - th3d * th3d * sin32)
          + (m3 + 0.5 * m2) * g * L2 * c2 + L2 * F * (s2 * nx - c2 * ny))
    w2 = w * w
    ag2x, ag2y = -0.5 * L2 * w2 * c2, -0.5 * L2 * w2 * s2
    ag3x = -L2 * w2 * c2 + 0.5 * L3 * (-th3dd * s3 - th3d * th3d * c3)
    ag3y = -L2 * w2 * s2 + 0.5 * L3 * (th3dd * c3 - th3d * th3d * s3)
    F12x = -(m2 * ag2x + m3 * ag3x - F * nx)
    F12y = -(m2 * ag2y + m3 * ag3y + (m2 + m3) * g - F * ny)
    return th3dd, x4dd, F, delta, deltadot, -ex, -ey, M2, F12x, F12y


def switching(mech: SliderCrank, t: float, y, mode: float) -> tuple[float, float]:
    """The switching function and its rate: the penetration and its rate in free flight,
    minus them in contact."""
    _, _, _, delta, deltadot, _, _ = gap(mech, t, y)
    return (-delta, -deltadot) if mode > 0.5 else (delta, deltadot)


def impact_velocity(mech: SliderCrank, t: float, y) -> float:
    """The impact velocity stored at a contact onset: the penetration rate, floored."""
    return max(gap(mech, t, y)[4], mech.impact_velocity_floor)
