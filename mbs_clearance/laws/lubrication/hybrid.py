"""The lubricated clearance joint's transition from oil film to metal contact (the hybrid
model of Flores, Ambrosio, Claro, Lankarani & Koshy 2006, Mech. Mach. Theory 41:247): the
film carries the journal up to an eccentricity ratio `film_fade_start`, fades out smoothly
(a quintic step: its value, slope and curvature continuous) until `film_fade_end` < 1, and
dry contact (the joint's contact law) takes over where the journal reaches the wall
(eps = 1, the contact onset the integrator locates as an event). The film force is
multiplied by the weight, so its power keeps its sign (never positive).

The ends of the fade are stated as film thicknesses over the clearance: h_min = c (1 - eps).
Defaults: the film fades from h_min = 10 % of the clearance to 3 % (about 0.3 um for the
paper case's 10 um clearance: the order of the combined roughness of ground pins and
bores, Ra 0.1-0.4 um, at which a film stops separating the surfaces) - an assumption to be
set per joint."""

from __future__ import annotations

from ..base import Parameter
from .journal_bearing import film_force

__all__ = ["FADE_START", "FADE_END", "fade", "lubricated_force", "check_fade"]

FADE_START = Parameter(
    "film_fade_start", "eps_1", "-", 0.90, 0.0, 1.0, low_open=True, high_open=True,
    source="assumed: film thickness 10 % of the clearance (Flores et al. 2006 fade the "
           "film into contact between two stated eccentricities)")
FADE_END = Parameter(
    "film_fade_end", "eps_2", "-", 0.97, 0.0, 1.0, low_open=True, high_open=True,
    source="assumed: film thickness 3 % of the clearance, about 0.3 um for 10 um, the "
           "order of ground surfaces' combined roughness")


def fade(eps, start, end):
    """(w, dw/deps): the film's weight, 1 for eps <= start, 0 for eps >= end, the quintic
    smooth step 1 - (10 s^3 - 15 s^4 + 6 s^5), s = (eps - start) / (end - start), between."""
    if eps <= start:
        return 1.0, 0.0
    if eps >= end:
        return 0.0, 0.0
    width = end - start
    s = (eps - start) / width
    return (1.0 - s * s * s * (10.0 - 15.0 * s + 6.0 * s * s),
            -30.0 * s * s * (1.0 - s) * (1.0 - s) / width)


def lubricated_force(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, model, start, end):
    """(Fx, Fy, T, w): the faded film's force on the journal centre and torque on the
    journal, and the weight w (the dry contact is the joint's own, added by the caller)."""
    eps = (ex * ex + ey * ey) ** 0.5 / c
    w = fade(eps, start, end)[0]
    if w == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    fx, fy, torque = film_force(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, model)
    return w * fx, w * fy, w * torque, w


def check_fade(what, start, end):
    """ValueError unless 0 < start < end < 1 (each a finite number), naming the fields."""
    for p, v in ((FADE_START, start), (FADE_END, end)):
        if not isinstance(v, (int, float)) or not p.contains(float(v)):
            raise ValueError(f"{what} {p.name} must be a number in {p.interval} "
                             f"(eccentricity ratio); got {v!r}")
    if not start < end:
        raise ValueError(f"{what} film_fade_start must be smaller than film_fade_end = "
                         f"{end!r}; got {start!r}")
