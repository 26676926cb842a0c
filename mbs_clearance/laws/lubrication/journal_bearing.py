"""The oil film of a journal bearing in closed form: its force on the journal centre and
its torque on the journal, from Reynolds' equation for an incompressible isoviscous film,

    (1/R^2) d/dtheta(h^3 dp/dtheta) + d/dz(h^3 dp/dz)
        = 6 mu (omega_J + omega_B) dh/dtheta + 12 mu dh/dt,

in the short-bearing limit (Ocvirk: the circumferential term dropped, L/D -> 0) and the
long-bearing limit (Sommerfeld: the axial term dropped, L/D -> infinity), with the
half-Sommerfeld (Gumbel) condition: the film carries only its positive pressure (Pinkus &
Sternlicht 1961, "Theory of Hydrodynamic Lubrication", ch. 3-4; Frene et al. 1997,
"Hydrodynamic Lubrication"; used for planar mechanisms by Flores, Ambrosio, Claro,
Lankarani & Koshy 2006, Mech. Mach. Theory 41:247).

Conventions. e = (ex, ey): the journal centre relative to the bearing centre, e = |e|,
epsilon = e / c (c: radial clearance). theta is measured from the thickest film (opposite
e), counterclockwise, so h = c (1 + epsilon cos theta); u_r = e / |e|, u_t = u_r turned
+90 degrees. With phi the angle of e, omega_bar = omega_J + omega_B - 2 phi_dot.

Short bearing. The pressure integrated over the length is
    P(theta) = mu L^3 / (2 c^2) (A sin theta - B cos theta) / (1 + epsilon cos theta)^3,
A = omega_bar epsilon (wedge), B = 2 epsilon_dot (squeeze). It is positive on exactly the
half circle theta in (alpha, alpha + pi), alpha = atan2(B, A): the Gumbel boundaries move
with the squeeze rate (Daniel, Machado & Cavalca 2016, Mech. Mach. Theory 99:19). The
classical forms (Flores et al. 2006 Eqs. for the short bearing) integrate both terms over
(0, pi), the wedge's own positive half; that is exact for pure rotation only (for pure
squeeze they give a tangential force where the film has none: see docs/lubrication.md).

Long bearing. The full-film pressure is the Sommerfeld wedge solution (zero at the
thickest film) plus the squeeze solution whose constant makes int h^3 p dtheta = 0, the
limit of a finite bearing with ambient pressure at its ends as L/D -> infinity. Its
positive region is not a half circle once the journal both turns and squeezes: its ends
are located as the zeros of the pressure (a trigonometric polynomial of degree 2 in psi,
sampled, then Newton steps inside the bracket), and the forces are integrated over it in
closed form. (Integrating the wedge and squeeze terms each over its own positive half,
as the classical superposed forms do, misses the combined film by up to its sign: see
docs/lubrication.md.)

The integrals are evaluated in Sommerfeld's variable psi, cos psi = (epsilon + cos theta) /
(1 + epsilon cos theta), in which every integrand is a trigonometric polynomial (exact,
and free of 1/epsilon cancellations near the centre); the long-bearing ones after one
integration by parts (the pressure vanishes at the ends of its positive region).

Torque on the journal (about its centre): the Couette shear of the full film,
-2 pi mu R^3 L (omega_J - omega_B) / (c sqrt(1 - epsilon^2)) (Petroff, eccentric), plus the
pressure-gradient (Poiseuille) shear, (R/2) int int p dh/dtheta = -(e/2) F_t. With these,
the film's total power F . (de/dt - omega_B k x e) + T (omega_J - omega_B) is never
positive (equal to minus an integral of squares).

The functions use only `math`; core/runtime.h holds their C twins, in the same order of
operations."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..base import Parameter

__all__ = ["LubricationLaw", "VISCOSITY", "BEARING_LENGTH", "LAWS", "MODELS",
           "short_bearing", "long_bearing", "film_force", "sommerfeld_angle", "long_lobes"]

VISCOSITY = Parameter(
    "viscosity", "mu", "Pa s", 9.0e-3, 0.0, low_open=True,
    source="SAE 30 engine oil at 100 C: kinematic viscosity 9.3-12.5 mm^2/s (SAE J300); "
           "the midpoint, 10.9 mm^2/s, times a density of about 0.83 kg/L at 100 C")
BEARING_LENGTH = Parameter(
    "bearing_length", "L", "m", 0.01, 0.0, low_open=True,
    source="assumed: half the journal diameter of the paper case's joint (L/D = 0.5); the "
           "paper gives no length; give the joint's")


@dataclass(frozen=True)
class LubricationLaw:
    """A film law: `force`(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu) returns
    (Fx, Fy, T): the film's force on the journal centre and torque on the journal (the
    bearing receives the opposite force at the same point and the opposite torque);
    `parameters` declare viscosity and bearing length; `limit` where it applies."""

    name: str
    force: object
    parameters: tuple[Parameter, ...]
    limit: str
    source: str


def sommerfeld_angle(theta, eps):
    """psi(theta): the continuous, increasing Sommerfeld variable, cos psi =
    (eps + cos theta) / (1 + eps cos theta), psi(theta + 2 pi) = psi(theta) + 2 pi, psi = 0
    and pi at theta = 0 and pi (its derivative is sqrt(1 - eps^2) / (1 + eps cos theta))."""
    beta = eps / (1.0 + math.sqrt(1.0 - eps * eps))
    return theta - 2.0 * math.atan2(beta * math.sin(theta), 1.0 + beta * math.cos(theta))


def _frame(ex, ey, vx, vy, c):
    """(e, eps, ur_x, ur_y, eps_dot, the tangential rate v . u_t / c)."""
    e = math.sqrt(ex * ex + ey * ey)
    if e > 0.0:
        ux, uy = ex / e, ey / e
    else:
        ux, uy = 1.0, 0.0
    return e, e / c, ux, uy, (ux * vx + uy * vy) / c, (-uy * vx + ux * vy) / c


def _torque(e, eps, ft, omega_j, omega_b, R, c, L, mu):
    """Couette shear of the full film plus the pressure-gradient shear, -(e/2) F_t."""
    couette = -2.0 * math.pi * mu * R * R * R * L * (omega_j - omega_b) / (
        c * math.sqrt(1.0 - eps * eps))
    return couette - 0.5 * e * ft


def short_bearing(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu):
    """(Fx, Fy, T) of the short (Ocvirk) film with the half-Sommerfeld condition at its
    exact boundaries (valid for eps < 1)."""
    e, eps, ux, uy, eps_dot, rate_t = _frame(ex, ey, vx, vy, c)
    # A = omega_bar eps without dividing by e: phi_dot e = v . u_t
    a = (omega_j + omega_b) * eps - 2.0 * rate_t
    b = 2.0 * eps_dot
    if a == 0.0 and b == 0.0:
        return 0.0, 0.0, _torque(e, eps, 0.0, omega_j, omega_b, R, c, L, mu)
    alpha = math.atan2(b, a)
    p1 = sommerfeld_angle(alpha, eps)
    p2 = sommerfeld_angle(alpha + math.pi, eps)
    s1 = (0.5 * (math.sin(p2) ** 2 - math.sin(p1) ** 2)
          + eps * (math.cos(p2) - math.cos(p1)))                  # int sin psi (cos psi - eps)
    s2 = ((0.5 + eps * eps) * (p2 - p1) + 0.25 * (math.sin(2.0 * p2) - math.sin(2.0 * p1))
          - 2.0 * eps * (math.sin(p2) - math.sin(p1)))            # int (cos psi - eps)^2
    s3 = 0.5 * (p2 - p1) - 0.25 * (math.sin(2.0 * p2) - math.sin(2.0 * p1))  # int sin^2 psi
    q = 1.0 - eps * eps
    s = math.sqrt(q)
    k = R * mu * L * L * L / (2.0 * c * c)
    fr = k * (a * s1 / (q * q) - b * s2 / (q * q * s))
    ft = k * (a * s3 / (q * s) - b * s1 / (q * q))
    return (fr * ux - ft * uy, fr * uy + ft * ux,
            _torque(e, eps, ft, omega_j, omega_b, R, c, L, mu))


def _long_pressure(psi, eps, a1, b1):
    """The long film's full pressure (over 6 mu R^2 / c^2) at Sommerfeld angle psi, and its
    derivative in psi: the wedge a1 sin psi (2 - eps^2 - eps cos psi) plus the squeeze
    b1 ((7 eps - 2 eps^3) - (4 + 6 eps^2) cos psi + eps (2 + 3 eps^2) cos^2 psi)."""
    sp, cp = math.sin(psi), math.cos(psi)
    g = (a1 * sp * (2.0 - eps * eps - eps * cp)
         + b1 * ((7.0 - 2.0 * eps * eps) * eps - (4.0 + 6.0 * eps * eps) * cp
                 + eps * (2.0 + 3.0 * eps * eps) * cp * cp))
    dg = (a1 * (cp * (2.0 - eps * eps - eps * cp) + eps * sp * sp)
          + b1 * sp * ((4.0 + 6.0 * eps * eps) - 2.0 * eps * (2.0 + 3.0 * eps * eps) * cp))
    return g, dg


def _zero(lo, hi, eps, a1, b1):
    """The zero of the long film's pressure between lo and hi (a sign change): Newton
    steps kept inside the bracket, bisection where they leave it."""
    glo = _long_pressure(lo, eps, a1, b1)[0]
    x = 0.5 * (lo + hi)
    for _ in range(80):
        g, dg = _long_pressure(x, eps, a1, b1)
        if g == 0.0:
            return x
        if (g > 0.0) == (glo > 0.0):
            lo = x
        else:
            hi = x
        step = x - g / dg if dg != 0.0 else 0.5 * (lo + hi)
        if not lo < step < hi:
            step = 0.5 * (lo + hi)
        if abs(step - x) <= 4e-16 * (1.0 + abs(x)) or hi - lo <= 4e-16 * (1.0 + abs(x)):
            return step
        x = step
    return x


#: samples of the long film's pressure around the circle when locating its zeros (a
#: trigonometric polynomial of degree 2: at most four zeros)
_SAMPLES = 96


def _long_integrals(p1, p2, eps):
    """(int sin psi (eps + 2 cos psi), int sin^2 psi, int (cos psi - eps)(eps + 2 cos psi),
    int sin psi (cos psi - eps)) over (p1, p2)."""
    s1, c1, s2, c2 = math.sin(p1), math.cos(p1), math.sin(p2), math.cos(p2)
    i1 = (s2 * s2 - eps * c2) - (s1 * s1 - eps * c1)
    i2 = 0.5 * (p2 - p1) - 0.5 * (s2 * c2 - s1 * c1)
    i3 = ((1.0 - eps * eps) * (p2 - p1) + (s2 * c2 - s1 * c1) - eps * (s2 - s1))
    i4 = 0.5 * (s2 * s2 - s1 * s1) + eps * (c2 - c1)
    return i1, i2, i3, i4


def long_lobes(eps, a1, b1):
    """The positive region of the long film's full pressure (`_long_pressure`) as its
    lobes in Sommerfeld's variable: (n, u1, d1, u2, d2), n lobes (u_k, d_k) from an
    up-crossing to the next down-crossing (a trigonometric polynomial of degree 2: at most
    two), in the order the sum over them takes (the one wrapping through psi = 0 last, its
    end past 2 pi); n = -1: positive all around (0, 2 pi), n = 0: nowhere."""
    n = 0
    u1 = d1 = u2 = d2 = 0.0
    step = 2.0 * math.pi / _SAMPLES
    g0 = _long_pressure(0.0, eps, a1, b1)[0]
    prev = g0
    up = -1.0
    first_down = -1.0
    crossed = False
    for k in range(1, _SAMPLES + 1):
        x = k * step
        g = _long_pressure(x, eps, a1, b1)[0] if k < _SAMPLES else g0
        if (prev > 0.0) != (g > 0.0):
            z = _zero(x - step, x, eps, a1, b1)
            crossed = True
            if g > 0.0:
                up = z
            elif up >= 0.0:
                if n == 0:
                    u1, d1 = up, z
                else:
                    u2, d2 = up, z
                n += 1
                up = -1.0
            else:
                first_down = z
        prev = g
    if crossed and up >= 0.0 and first_down >= 0.0:
        # the last positive lobe wraps through psi = 0
        if n == 0:
            u1, d1 = up, first_down + 2.0 * math.pi
        else:
            u2, d2 = up, first_down + 2.0 * math.pi
        n += 1
    elif not crossed and g0 > 0.0:
        return -1, 0.0, 2.0 * math.pi, 0.0, 0.0
    return n, u1, d1, u2, d2


def long_bearing(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu):
    """(Fx, Fy, T) of the long (Sommerfeld) film with the half-Sommerfeld condition over
    the exact positive region of the full-film pressure (valid for eps < 1)."""
    e, eps, ux, uy, eps_dot, rate_t = _frame(ex, ey, vx, vy, c)
    a = (omega_j + omega_b) * eps - 2.0 * rate_t
    q = 1.0 - eps * eps
    s = math.sqrt(q)
    a1 = a / ((2.0 + eps * eps) * q * s)
    b1 = eps_dot / ((2.0 + 3.0 * eps * eps) * q * q)
    n, u1, d1, u2, d2 = long_lobes(eps, a1, b1)
    j1 = j2 = j3 = j4 = 0.0
    if n == -1:
        j1, j2, j3, j4 = _long_integrals(u1, d1, eps)
    if n >= 1:
        i1, i2, i3, i4 = _long_integrals(u1, d1, eps)
        j1, j2, j3, j4 = j1 + i1, j2 + i2, j3 + i3, j4 + i4
    if n >= 2:
        i1, i2, i3, i4 = _long_integrals(u2, d2, eps)
        j1, j2, j3, j4 = j1 + i1, j2 + i2, j3 + i3, j4 + i4
    k6 = 6.0 * mu * R * R * R * L / (c * c)
    fr = -k6 * (a * j1 / ((2.0 + eps * eps) * q) + 2.0 * eps_dot * j2 / (q * s))
    ft = k6 * (a * j3 / ((2.0 + eps * eps) * q * s) + 2.0 * eps_dot * j4 / (q * q))
    return (fr * ux - ft * uy, fr * uy + ft * ux,
            _torque(e, eps, ft, omega_j, omega_b, R, c, L, mu))


SHORT = LubricationLaw(
    name="short", force=short_bearing, parameters=(VISCOSITY, BEARING_LENGTH),
    limit="L/D -> 0 (Ocvirk; within about 10 % of the finite bearing for L/D <= 0.25 at "
          "moderate eccentricity)",
    source="Ocvirk 1952 NACA TN 2808; Flores et al. 2006, Mech. Mach. Theory 41:247; "
           "boundaries: Daniel, Machado & Cavalca 2016, Mech. Mach. Theory 99:19")
LONG = LubricationLaw(
    name="long", force=long_bearing, parameters=(VISCOSITY, BEARING_LENGTH),
    limit="L/D -> infinity (Sommerfeld)",
    source="Sommerfeld 1904; Pinkus & Sternlicht 1961 ch. 3; Flores et al. 2006, "
           "Mech. Mach. Theory 41:247")

#: the film laws; the position is the kernel id
LAWS: tuple[LubricationLaw, ...] = (SHORT, LONG)

#: law name -> integer id
MODELS: dict[str, int] = {law.name: i for i, law in enumerate(LAWS)}


def film_force(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, model):
    """(Fx, Fy, T) of film law id `model` (0 short, 1 long)."""
    if model == 1:
        return long_bearing(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu)
    return short_bearing(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu)
