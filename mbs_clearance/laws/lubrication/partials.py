"""Exact partial derivatives of the faded oil film (`hybrid.lubricated_force`) for the
sensitivity equations (DDM): of its force on the journal (x, y), its torque on the journal,
its torque on the bearing about the bearing's centre and its total power, along the
journal's offset and its rate, the two bodies' angular velocities, the journal radius, the
clearance, the bearing length, the viscosity and the two ends of the fade.

The short film's positive region ends where its pressure is zero, so moving the ends does
not change the integrals (Leibniz: the integrand vanishes there); its derivatives are those
of the closed form with the ends (in Sommerfeld's variable) held fixed, taken by the complex
step (Squire & Trapp 1998: f'(x) = Im f(x + ih) / h, no cancellation, exact to round-off)
through `_short_core`, written in arithmetic that takes complex numbers. The long film's
closed form is integrated by parts (its integrand does not vanish at the ends), so its
ends' motion enters: each end z of a positive lobe is a zero of the full pressure g(psi;
x), which moves by dz = -(dg/dx) / (dg/dpsi) (the implicit function theorem), and
`_long_core` takes the complex step with the ends moved so, z - i Im g(z; x + ih) /
g_psi(z; x)."""

from __future__ import annotations

import cmath
import math

import numpy as np

from .hybrid import fade, lubricated_force
from .journal_bearing import MODELS, _long_pressure, long_lobes, sommerfeld_angle

__all__ = ["N_INPUTS", "N_OUTPUTS", "film_values", "film_direction", "film_partials",
           "check_partials", "DIFFERENTIABLE"]

#: inputs: ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, fade start, fade end
N_INPUTS = 12
#: outputs: Fx, Fy (on the journal), T_J, T_B (the bearing's, about its centre), power
N_OUTPUTS = 5
#: the film laws with partial derivatives
DIFFERENTIABLE = ("short", "long")

#: the complex step (relative to the input's size): far below round-off, no cancellation
_H = 1e-20
#: the offset (in clearances) below which the derivatives are taken at this offset
_CENTRE = 1e-8


def _short_core(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, p1, p2):
    """(Fx, Fy, T, eps) of the short film over the fixed Sommerfeld angles (p1, p2), in
    arithmetic that takes complex inputs (`journal_bearing.short_bearing` otherwise)."""
    # |e| to first order in the complex step, without the complex square root (whose
    # rounding near the imaginary axis would swamp the step)
    er = math.sqrt(ex.real * ex.real + ey.real * ey.real)
    if er == 0.0:
        # centred: the frame of the law's own fallback, u = (1, 0)
        e = 0.0 * ex
        ux = 1.0 + 0.0 * ex
        uy = 0.0 * ex
    else:
        e = er + (ex.real * (ex - ex.real) + ey.real * (ey - ey.real)) / er
        ux = ex / e
        uy = ey / e
    eps = e / c
    eps_dot = (ux * vx + uy * vy) / c
    rate_t = (-uy * vx + ux * vy) / c
    a = (omega_j + omega_b) * eps - 2.0 * rate_t
    b = 2.0 * eps_dot
    sp1, cp1, sp2, cp2 = math.sin(p1), math.cos(p1), math.sin(p2), math.cos(p2)
    s1 = 0.5 * (sp2 * sp2 - sp1 * sp1) + eps * (cp2 - cp1)
    s2 = ((0.5 + eps * eps) * (p2 - p1) + 0.25 * (math.sin(2.0 * p2) - math.sin(2.0 * p1))
          - 2.0 * eps * (sp2 - sp1))
    s3 = 0.5 * (p2 - p1) - 0.25 * (math.sin(2.0 * p2) - math.sin(2.0 * p1))
    q = 1.0 - eps * eps
    s = q ** 0.5
    k = R * mu * L * L * L / (2.0 * c * c)
    fr = k * (a * s1 / (q * q) - b * s2 / (q * q * s))
    ft = k * (a * s3 / (q * s) - b * s1 / (q * q))
    couette = -2.0 * math.pi * mu * R * R * R * L * (omega_j - omega_b) / (c * s)
    return fr * ux - ft * uy, fr * uy + ft * ux, couette - 0.5 * e * ft, eps


def _short_ends(ex, ey, vx, vy, omega_j, omega_b, c):
    """The Sommerfeld angles of the ends of the short film's positive region."""
    e = math.sqrt(ex * ex + ey * ey)
    ux, uy = (ex / e, ey / e) if e > 0.0 else (1.0, 0.0)
    eps = e / c
    a = (omega_j + omega_b) * eps - 2.0 * (-uy * vx + ux * vy) / c
    b = 2.0 * (ux * vx + uy * vy) / c
    alpha = math.atan2(b, a)
    return sommerfeld_angle(alpha, eps), sommerfeld_angle(alpha + math.pi, eps)


def _long_state(ex, ey, vx, vy, omega_j, omega_b, c):
    """(eps, a1, b1) of the long film's full pressure (`journal_bearing.long_bearing`)."""
    e = math.sqrt(ex * ex + ey * ey)
    ux, uy = (ex / e, ey / e) if e > 0.0 else (1.0, 0.0)
    eps = e / c
    a = (omega_j + omega_b) * eps - 2.0 * (-uy * vx + ux * vy) / c
    q = 1.0 - eps * eps
    return (eps, a / ((2.0 + eps * eps) * q * math.sqrt(q)),
            (ux * vx + uy * vy) / c / ((2.0 + 3.0 * eps * eps) * q * q))


def _long_ends(ex, ey, vx, vy, omega_j, omega_b, c):
    """The long film's positive lobes (`journal_bearing.long_lobes`)."""
    return long_lobes(*_long_state(ex, ey, vx, vy, omega_j, omega_b, c))


def _moved(z, eps, a1, b1):
    """The end z of a lobe moved with the complex step of the pressure's parameters: the
    zero of g(psi) = _long_pressure to first order, z - i Im g(z) / g_psi(z)."""
    g = _long_pressure(z, eps, a1, b1)[0]
    dg = _long_pressure(z, eps.real, a1.real, b1.real)[1]
    return z - 1j * g.imag / dg


def _long_integrals_c(p1, p2, eps):
    """`journal_bearing._long_integrals` of complex ends."""
    s1, c1, s2, c2 = cmath.sin(p1), cmath.cos(p1), cmath.sin(p2), cmath.cos(p2)
    i1 = (s2 * s2 - eps * c2) - (s1 * s1 - eps * c1)
    i2 = 0.5 * (p2 - p1) - 0.5 * (s2 * c2 - s1 * c1)
    i3 = ((1.0 - eps * eps) * (p2 - p1) + (s2 * c2 - s1 * c1) - eps * (s2 - s1))
    i4 = 0.5 * (s2 * s2 - s1 * s1) + eps * (c2 - c1)
    return i1, i2, i3, i4


def _long_core(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, n, u1, d1, u2, d2):
    """(Fx, Fy, T, eps) of the long film over its n lobes (u_k, d_k) (`long_lobes`), each
    end moved as a zero of the pressure (`_moved`), in arithmetic that takes complex
    inputs (`journal_bearing.long_bearing` otherwise)."""
    er = math.sqrt(ex.real * ex.real + ey.real * ey.real)
    if er == 0.0:
        e = 0.0 * ex
        ux = 1.0 + 0.0 * ex
        uy = 0.0 * ex
    else:
        e = er + (ex.real * (ex - ex.real) + ey.real * (ey - ey.real)) / er
        ux = ex / e
        uy = ey / e
    eps = e / c
    eps_dot = (ux * vx + uy * vy) / c
    rate_t = (-uy * vx + ux * vy) / c
    a = (omega_j + omega_b) * eps - 2.0 * rate_t
    q = 1.0 - eps * eps
    s = q ** 0.5
    a1 = a / ((2.0 + eps * eps) * q * s)
    b1 = eps_dot / ((2.0 + 3.0 * eps * eps) * q * q)
    j1 = j2 = j3 = j4 = 0.0 * eps
    if n == -1:
        # positive all around: the ends are fixed
        j1, j2, j3, j4 = _long_integrals_c(0.0 + 0.0j, 2.0 * math.pi + 0.0j, eps)
    for k in range(max(n, 0)):
        u, d = (u1, d1) if k == 0 else (u2, d2)
        i1, i2, i3, i4 = _long_integrals_c(_moved(u, eps, a1, b1), _moved(d, eps, a1, b1),
                                           eps)
        j1, j2, j3, j4 = j1 + i1, j2 + i2, j3 + i3, j4 + i4
    k6 = 6.0 * mu * R * R * R * L / (c * c)
    fr = -k6 * (a * j1 / ((2.0 + eps * eps) * q) + 2.0 * eps_dot * j2 / (q * s))
    ft = k6 * (a * j3 / ((2.0 + eps * eps) * q * s) + 2.0 * eps_dot * j4 / (q * q))
    couette = -2.0 * math.pi * mu * R * R * R * L * (omega_j - omega_b) / (c * s)
    return fr * ux - ft * uy, fr * uy + ft * ux, couette - 0.5 * e * ft, eps


def film_values(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, model, start, end):
    """(active, ends, w, dw/deps, Fx, Fy, T_J, T_B, power) of the faded film of law id
    `model`: the ends of its positive region, (n, u1, d1, u2, d2) in Sommerfeld's variable
    (the short film: one lobe; the long one: `journal_bearing.long_lobes`; n = -2 for a law
    without partials, whose derivatives `film_direction` then gives as NaN), the fade's
    weight and slope, the faded force on the journal, torque on the journal, torque on the
    bearing about its centre (-T_J - e x F) and total power F . (edot - omega_B k x e) +
    T_J (omega_J - omega_B); active False where the film has faded out (all zero)."""
    w, dw = fade(math.sqrt(ex * ex + ey * ey) / c, start, end)
    if w == 0.0:
        return False, (0, 0.0, 0.0, 0.0, 0.0), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if model == 0:
        p1, p2 = _short_ends(ex, ey, vx, vy, omega_j, omega_b, c)
        ends = (1, p1, p2, 0.0, 0.0)
        fx, fy, tj, _ = _short_core(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, p1, p2)
        fx, fy, tj = w * fx, w * fy, w * tj
    else:
        ends = (_long_ends(ex, ey, vx, vy, omega_j, omega_b, c) if model == 1
                else (-2, 0.0, 0.0, 0.0, 0.0))
        fx, fy, tj, _ = lubricated_force(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu,
                                         model, start, end)
    tb = -tj - (ex * fy - ey * fx)
    power = fx * (vx + omega_b * ey) + fy * (vy - omega_b * ex) + tj * (omega_j - omega_b)
    return True, ends, w, dw, fx, fy, tj, tb, power


def film_direction(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, model, start, end, ends, w,
                   dw, fx, fy, tj, dex, dey, dvx, dvy, dwj, dwb, dR, dc, dL, dmu, dstart,
                   dend):
    """Derivatives of the faded film's (Fx, Fy, T_J, T_B, power) (`film_values`, whose
    ends, w, dw and faded fx, fy, tj it takes) along one direction of the inputs (the
    d-arguments): one complex step of `_short_core` (law id `model` 0) or `_long_core` (1)
    along it."""
    n = ends[0]
    if n == -2:
        return math.nan, math.nan, math.nan, math.nan, math.nan
    # the step: _H of each input's natural size along the direction (c for the offset,
    # c |omega| for its rate), so that the step's square is far below round-off
    sv = c * max(abs(omega_j), abs(omega_b), 1.0)
    big = max(abs(dex) / c, abs(dey) / c, abs(dvx) / max(abs(vx), sv),
              abs(dvy) / max(abs(vy), sv), abs(dwj) / max(abs(omega_j), 1.0),
              abs(dwb) / max(abs(omega_b), 1.0), abs(dR) / R, abs(dc) / c, abs(dL) / L,
              abs(dmu) / mu)
    gfx = gfy = gtj = deps = 0.0
    e = math.sqrt(ex * ex + ey * ey)
    if e < _CENTRE * c:
        # near the centre the frame's derivatives (1 / |e|) cancel to round-off: take the
        # derivatives at |e| = _CENTRE c (the force is smooth there: a relative error of
        # about _CENTRE), where they lose as many digits
        ux, uy = (ex / e, ey / e) if e > 0.0 else (1.0, 0.0)
        xs, ys = _CENTRE * c * ux, _CENTRE * c * uy
        if model == 0:
            p1, p2 = _short_ends(xs, ys, vx, vy, omega_j, omega_b, c)
            ends = (1, p1, p2, 0.0, 0.0)
        else:
            ends = _long_ends(xs, ys, vx, vy, omega_j, omega_b, c)
    else:
        xs, ys = ex, ey
    if big > 0.0:
        h = _H / big
        args = (xs + 1j * h * dex, ys + 1j * h * dey, vx + 1j * h * dvx, vy + 1j * h * dvy,
                omega_j + 1j * h * dwj, omega_b + 1j * h * dwb, R + 1j * h * dR,
                c + 1j * h * dc, L + 1j * h * dL, mu + 1j * h * dmu)
        if model == 0:
            gx, gy, gt, ge = _short_core(*args, ends[1], ends[2])
        else:
            gx, gy, gt, ge = _long_core(*args, ends[0], ends[1], ends[2], ends[3], ends[4])
        gfx, gfy, gtj, deps = gx.imag / h, gy.imag / h, gt.imag / h, ge.imag / h
    # the faded film w F: d(w F) = w dF + F dw, dw = w'(eps) deps + the fade's ends' part
    dwt = dw * deps
    eps = e / c
    if start < eps < end and (dstart != 0.0 or dend != 0.0):
        width = end - start
        s = (eps - start) / width
        slope = 30.0 * s * s * (1.0 - s) * (1.0 - s)
        dwt += slope * ((1.0 - s) * dstart + s * dend) / width
    r = dwt / w
    dfx = w * gfx + fx * r
    dfy = w * gfy + fy * r
    dtj = w * gtj + tj * r
    dtb = -dtj - (dex * fy + ex * dfy - dey * fx - ey * dfx)
    dpw = (dfx * (vx + omega_b * ey) + fx * (dvx + dwb * ey + omega_b * dey)
           + dfy * (vy - omega_b * ex) + fy * (dvy - dwb * ex - omega_b * dex)
           + dtj * (omega_j - omega_b) + tj * (dwj - dwb))
    return dfx, dfy, dtj, dtb, dpw


def film_partials(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, start, end, model=0):
    """(N_OUTPUTS, N_INPUTS + 1): the faded film's (Fx, Fy, T_J, T_B, power) (rows)
    and their partial derivatives along each input (columns, in `N_INPUTS` order), the
    values in the last column (tests, and a check of a state)."""
    out = np.zeros((N_OUTPUTS, N_INPUTS + 1))
    active, ends, w, dw, fx, fy, tj, tb, pw = film_values(
        ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, model, start, end)
    if not active:
        return out
    out[:, N_INPUTS] = (fx, fy, tj, tb, pw)
    for k in range(N_INPUTS):
        e = np.zeros(N_INPUTS)
        e[k] = 1.0
        out[:, k] = film_direction(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, model,
                                   start, end, ends, w, dw, fx, fy, tj, e[0], e[1], e[2],
                                   e[3], e[4], e[5], e[6], e[7], e[8], e[9], e[10], e[11])
    return out


def check_partials(what: str, model: str) -> None:
    """ValueError unless the film law `model` has partial derivatives (`DIFFERENTIABLE`)."""
    if model not in MODELS:
        raise ValueError(f"{what}: unknown film law {model!r}; allowed: {list(MODELS)}")
    if model not in DIFFERENTIABLE:
        raise ValueError(
            f"{what}: the {model!r} film has no partial derivatives for DDM sensitivities; "
            f"allowed: lubrication in {list(DIFFERENTIABLE)}, or method='fd'")
