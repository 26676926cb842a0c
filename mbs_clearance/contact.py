"""Continuous contact force laws for the clearance joint, as pure numba functions.

All laws share the form of a Hertzian spring with hysteresis damping,

    F = K * delta**n * (1 + xi(e) * deltadot / deltadot_minus),     n = 3/2,

where delta is the penetration, deltadot its rate and deltadot_minus the penetration rate
at contact onset (the impact velocity). They differ in the hysteresis factor xi(e):

- ``lankarani_nikravesh``: xi = 3 (1 - e^2) / 4
  (Lankarani & Nikravesh 1990, J. Mech. Des. 112:369; the paper's Eq. 9).
- ``hunt_crossley``: xi = 3 (1 - e) / 2
  (Hunt & Crossley 1975, J. Appl. Mech. 42:440, in the form of Flores et al. 2011).
- ``flores``: xi = 8 (1 - e) / (5 e)
  (Flores, Machado, Silva & Martins 2011, Multibody Syst. Dyn. 25:357).

The force is clamped at zero: a contact cannot pull (at low restitution the damping term
can exceed the spring term late in the restitution phase).
"""

from __future__ import annotations

import math

import numba as nb

from .integrator import KERNEL

__all__ = [
    "CONTACT_MODELS", "hysteresis_factor", "contact_force", "contact_force_partials",
    "stiffness_eq9", "stiffness_eq9_partials",
]

#: name -> integer id used inside compiled kernels
CONTACT_MODELS: dict[str, int] = {"lankarani_nikravesh": 0, "hunt_crossley": 1, "flores": 2}

EXPONENT = 1.5


@nb.njit(**KERNEL, inline="always")
def hysteresis_factor(e, model):
    """Return (xi, dxi/de) for restitution `e` and contact model id `model`."""
    if model == 0:
        return 0.75 * (1.0 - e * e), -1.5 * e
    if model == 1:
        return 1.5 * (1.0 - e), -1.5
    return 1.6 * (1.0 - e) / e, -1.6 / (e * e)


@nb.njit(**KERNEL, inline="always")
def contact_force(delta, deltadot, deltadot_minus, K, e, model):
    """Normal contact force in N (>= 0; zero for delta <= 0)."""
    if delta <= 0.0:
        return 0.0
    xi, _ = hysteresis_factor(e, model)
    # xi / deltadot_minus does not depend on the state: off the critical path
    f = K * delta * math.sqrt(delta) * (1.0 + deltadot * (xi / deltadot_minus))
    return f if f > 0.0 else 0.0


@nb.njit(**KERNEL)
def contact_force_partials(delta, deltadot, deltadot_minus, K, e, model):
    """Force and its partial derivatives.

    Returns (F, dF/ddelta, dF/ddeltadot, dF/ddeltadot_minus, dF/dK, dF/de); all zero where
    the force is zero (free flight or clamped).
    """
    if delta <= 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    xi, dxi = hysteresis_factor(e, model)
    spring = K * delta**EXPONENT
    damp = 1.0 + xi * deltadot / deltadot_minus
    f = spring * damp
    if f <= 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    d_delta = EXPONENT * K * delta ** (EXPONENT - 1.0) * damp
    d_rate = spring * xi / deltadot_minus
    d_rate_minus = -spring * xi * deltadot / deltadot_minus**2
    d_k = delta**EXPONENT * damp
    d_e = spring * dxi * deltadot / deltadot_minus
    return f, d_delta, d_rate, d_rate_minus, d_k, d_e


@nb.njit(**KERNEL)
def stiffness_eq9(journal_radius, bearing_radius, youngs_modulus, poisson_ratio):
    """Generalized contact stiffness K of the paper's Eq. 9 in N/m^1.5.

    K = 4 / (3 pi (h_J + h_B)) * sqrt(R_J R_B / (R_B - R_J)), h = (1 - nu^2) / (pi E),
    journal and bearing of the same material.
    """
    h = (1.0 - poisson_ratio**2) / (math.pi * youngs_modulus)
    return 4.0 / (3.0 * math.pi * 2.0 * h) * math.sqrt(
        journal_radius * bearing_radius / (bearing_radius - journal_radius))


@nb.njit(**KERNEL)
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
