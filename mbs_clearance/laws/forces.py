"""The clearance joint's contact and friction laws in Python (the compiled models print the same
formulas in C: core/laws_generated.h, core/runtime.h): the Hertzian
normal force with hysteresis damping,

    F = K * delta**n * (1 + xi(e) * deltadot / deltadot_minus),     n = 3/2,

clamped at zero (a contact cannot pull: at low restitution the damping term can exceed the
spring term late in the restitution phase), where delta is the penetration, deltadot its
rate and deltadot_minus the penetration rate at contact onset (the impact velocity); the
friction force Ft at the contact point, opposing the relative tangential velocity v_t of the
journal's surface with respect to the bearing's; and the paper's stiffness (Eq. 9).

Each law (its hysteresis factor xi(e), or its friction force) is declared once in its own
module of `mbs_clearance.laws` (with its parameters, their ranges and its source); this
module dispatches on the law's integer id (`laws.registry`) through the generated
`laws._dispatch`.
"""

from __future__ import annotations

import math

from ._dispatch import friction_force, friction_force_partials, hysteresis_factor
from .registry import CONTACT_MODELS, FRICTION_LAWS

__all__ = [
    "CONTACT_MODELS", "hysteresis_factor", "contact_force", "contact_force_partials",
    "stiffness_eq9", "stiffness_eq9_partials",
    "FRICTION_LAWS", "friction_factor", "friction_force", "friction_force_partials",
]

#: the Hertzian exponent of every contact law (the kernels write delta^1.5 as delta sqrt(delta))
EXPONENT = 1.5


def contact_force(delta, deltadot, deltadot_minus, K, e, model):
    """Normal contact force in N (>= 0; zero for delta <= 0)."""
    if delta <= 0.0:
        return 0.0
    xi, _ = hysteresis_factor(e, model)
    # xi / deltadot_minus does not depend on the state: off the critical path
    f = K * delta * math.sqrt(delta) * (1.0 + deltadot * (xi / deltadot_minus))
    return f if f > 0.0 else 0.0


def contact_force_partials(delta, deltadot, deltadot_minus, K, e, model):
    """Force and its partial derivatives.

    Returns (F, dF/ddelta, dF/ddeltadot, dF/ddeltadot_minus, dF/dK, dF/de); all zero where
    the force is zero (free flight or clamped).
    """
    if delta <= 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    xi, dxi = hysteresis_factor(e, model)
    # delta^1.5 and delta^0.5 from one square root, as in `contact_force` (two calls of libm's
    # pow were several per cent of a DDM run)
    root = math.sqrt(delta)
    spring = K * delta * root
    damp = 1.0 + xi * deltadot / deltadot_minus
    f = spring * damp
    if f <= 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    d_delta = EXPONENT * K * root * damp
    d_rate = spring * xi / deltadot_minus
    d_rate_minus = -spring * xi * deltadot / deltadot_minus**2
    d_k = delta * root * damp
    d_e = spring * dxi * deltadot / deltadot_minus
    return f, d_delta, d_rate, d_rate_minus, d_k, d_e


def stiffness_eq9(journal_radius, bearing_radius, youngs_modulus, poisson_ratio):
    """Generalized contact stiffness K of the paper's Eq. 9 in N/m^1.5.

    K = 4 / (3 pi (h_J + h_B)) * sqrt(R_J R_B / (R_B - R_J)), h = (1 - nu^2) / (pi E),
    journal and bearing of the same material.
    """
    h = (1.0 - poisson_ratio**2) / (math.pi * youngs_modulus)
    return 4.0 / (3.0 * math.pi * 2.0 * h) * math.sqrt(
        journal_radius * bearing_radius / (bearing_radius - journal_radius))


def stiffness_eq9_partials(journal_radius, bearing_radius, youngs_modulus, poisson_ratio):
    """Return (K, dK/dR_J, dK/dR_B, dK/dE, dK/dnu) of Eq. 9."""
    k = stiffness_eq9(journal_radius, bearing_radius, youngs_modulus, poisson_ratio)
    rj, rb = journal_radius, bearing_radius
    c = rb - rj
    # ln K = const + ln E - ln(1 - nu^2) + 0.5 (ln R_J + ln R_B - ln(R_B - R_J))
    d_rj = 0.5 * k * (1.0 / rj + 1.0 / c)
    d_rb = 0.5 * k * (1.0 / rb - 1.0 / c)
    d_e = k / youngs_modulus
    d_nu = k * 2.0 * poisson_ratio / (1.0 - poisson_ratio**2)
    return k, d_rj, d_rb, d_e, d_nu


def friction_factor(vt, v0, v1, law):
    """Return (phi, dphi/dvt, dphi/dv0, dphi/dv1) of friction law id `law` at the relative
    tangential velocity `vt` (m/s) with the law's velocity parameters v0, v1 (m/s), for the
    laws whose force is -mu Fn phi(vt) (phi is Ft at mu = 1, Fn = -1)."""
    ft, d_vt, _, _, d_v0, d_v1 = friction_force_partials(vt, -1.0, 1.0, v0, v1, law)
    return ft, d_vt, d_v0, d_v1
