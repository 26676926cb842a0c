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

Friction (tangential force at the contact point, opposing the relative tangential velocity
v_t of the journal's surface with respect to the bearing's), Ft = -mu * Fn * phi(v_t):

- ``none``: phi = 0 (the frictionless joint).
- ``coulomb``: regularised Coulomb, phi = v_t / sqrt(v_t^2 + v0^2): the sign of v_t, smoothed
  over the velocity scale v0 (a smooth stand-in for the set-valued sign; |phi| > 0.995 for
  |v_t| > 10 v0).
- ``ambrosio``: Ambrosio's modified Coulomb law with the dynamic correction coefficient
  c_d between two tangential-velocity thresholds, phi = c_d(|v_t|) sign(v_t) with
  c_d = 0 for |v_t| <= v0, (|v_t| - v0) / (v1 - v0) between, 1 for |v_t| >= v1
  (Ambrosio 2002, "Impact of rigid and flexible multibody systems: deformation description
  and contact models", in Virtual Nonlinear Multibody Systems, NATO Sci. Ser. II 103;
  used for clearance joints by Flores, Ambrosio, Claro & Lankarani, "Kinematics and
  Dynamics of Multibody Systems with Imperfect Joints", Springer 2008). It has no stiction:
  below v0 the joint is frictionless.
"""

from __future__ import annotations

import math

import numba as nb

from .integrator import KERNEL

__all__ = [
    "CONTACT_MODELS", "hysteresis_factor", "contact_force", "contact_force_partials",
    "stiffness_eq9", "stiffness_eq9_partials",
    "FRICTION_LAWS", "friction_factor", "friction_force", "friction_force_partials",
]

#: name -> integer id used inside compiled kernels
CONTACT_MODELS: dict[str, int] = {"lankarani_nikravesh": 0, "hunt_crossley": 1, "flores": 2}

#: the Hertzian exponent of every contact law (the kernels write delta^1.5 as delta sqrt(delta))
EXPONENT = 1.5

#: friction law name -> integer id used inside compiled kernels
FRICTION_LAWS: dict[str, int] = {"none": 0, "coulomb": 1, "ambrosio": 2}


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


@nb.njit(**KERNEL, inline="always")
def friction_factor(vt, v0, v1, law):
    """Return (phi, dphi/dvt, dphi/dv0, dphi/dv1) of friction law id `law` at the relative
    tangential velocity `vt` (m/s), thresholds v0 < v1 (m/s); Ft = -mu Fn phi."""
    if law == 1:
        r = vt * vt + v0 * v0
        root = math.sqrt(r)
        return vt / root, v0 * v0 / (r * root), -vt * v0 / (r * root), 0.0
    if law == 2:
        speed = abs(vt)
        if speed <= v0:
            return 0.0, 0.0, 0.0, 0.0
        sign = 1.0 if vt > 0.0 else -1.0
        if speed >= v1:
            return sign, 0.0, 0.0, 0.0
        width = v1 - v0
        return (sign * (speed - v0) / width, 1.0 / width,
                sign * (speed - v1) / (width * width), -sign * (speed - v0) / (width * width))
    return 0.0, 0.0, 0.0, 0.0


@nb.njit(**KERNEL, inline="always")
def friction_force(vt, fn, mu, v0, v1, law):
    """Tangential friction force in N on the journal, along the tangent that defines `vt`
    (negative where vt > 0: friction opposes the sliding)."""
    phi, _, _, _ = friction_factor(vt, v0, v1, law)
    return -mu * fn * phi


@nb.njit(**KERNEL)
def friction_force_partials(vt, fn, mu, v0, v1, law):
    """Return (Ft, dFt/dvt, dFt/dFn, dFt/dmu, dFt/dv0, dFt/dv1) of `friction_force`."""
    phi, d_vt, d_v0, d_v1 = friction_factor(vt, v0, v1, law)
    scale = -mu * fn
    return scale * phi, scale * d_vt, -mu * phi, -fn * phi, scale * d_v0, scale * d_v1
