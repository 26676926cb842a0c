"""Archard's wear law on a clearance joint's bearing: the wear depth rate at a surface point
is ``dh/dt = (k/H) p v``, with p the contact pressure there and v the sliding speed of the
journal's surface against the bearing's (Archard, J. Appl. Phys. 24 (1953) 981-988; as in
Flores, Mech. Mach. Theory 44 (2009) 1211-1222, and Mukras et al., Wear 268 (2010) 643-652).

The pressure around the joint: an elastic foundation (Winkler) on the worn profile. Where the
journal's circle overlaps the bearing's profile, the pressure is proportional to the local
overlap ``e cos(psi) - c(theta_c + psi)`` (e the eccentricity, c(theta) = R_B(theta) - R_J,
psi the angle from the contact direction theta_c); its magnitude is set by the contact
force of the dynamics, so that the pressure integrated over the contact arc and the
bearing's length is the contact force. Hence the worn volume is exactly
``(k/H) * integral of F |v| dt`` (Archard's volume law), and the shape follows the profile:
a worn groove that conforms to the journal spreads the load over a wider arc.

Only the bearing wears here (the journal's wear, spread around its circumference by its
rotation against the load, is not modelled). The sliding speed is the one at the contact
direction, taken for the whole arc (it differs across the arc by the centre's motion only).
"""

from __future__ import annotations

import math

import numpy as np

from ..base import Parameter

__all__ = ["WEAR_COEFFICIENT", "pressure_weights", "wear_increment"]

#: the dimensional wear coefficient k/H of a clearance joint (0: the joint does not wear)
WEAR_COEFFICIENT = Parameter(
    "wear_coefficient", "k/H", "m^2/N", 0.0, 0.0, 1e-9, low_open=False, high_open=False,
    source="Archard's k over the softer surface's hardness H; published values for dry "
           "steel pairs span 1e-16 to 1e-13 m^2/N and scatter by tens of per cent; 0: no wear")

#: arc points per grid cell at which the overlap is evaluated (the pressure's resolution:
#: a linear deposit of points this dense onto the grid leaves a ripple below 1e-3)
ARC_POINTS_PER_CELL = 8


def pressure_weights(profile, journal_radius: float, angle, penetration):
    """Where the pressure of each contact sample sits, on the bearing's `profile` (a
    `model.profile.BearingProfile`): indices (M, P) into the fine grid of
    `ARC_POINTS_PER_CELL` points per cell of the profile (angle 2 pi m / (N *
    ARC_POINTS_PER_CELL)) and weights (M, P) that sum to 1 per sample, proportional to the
    overlap of the journal's circle with the bearing's profile (the elastic foundation).

    `angle` (M,) is the contact direction theta_c in the bearing's frame and `penetration`
    (M,) the penetration delta > 0 at it, so that the eccentricity is
    e = delta + R_B(theta_c) - R_J. The arc searched is +- acos(c_min / e) (c_min the
    profile's smallest clearance, which bounds where an overlap can be) plus two grid cells,
    at most +- pi / 2."""
    angle = np.asarray(angle, dtype=float)
    delta = np.asarray(penetration, dtype=float)
    fine = ARC_POINTS_PER_CELL * profile.points
    step = 2.0 * np.pi / fine
    c_fine = profile.radius(step * np.arange(fine)) - journal_radius
    c_at = profile.radius(angle) - journal_radius
    e = delta + c_at
    c_min = float(np.min(c_fine))
    half = np.arccos(np.clip(np.minimum(c_min, c_at) / e, -1.0, 1.0))
    half = np.minimum(half + 2.0 * ARC_POINTS_PER_CELL * step, 0.5 * np.pi)
    width = int(math.ceil(float(np.max(half, initial=0.0)) / step))
    centre = np.rint(angle / step).astype(np.int64)
    offsets = np.arange(-width, width + 1)
    index = (centre[:, None] + offsets[None, :]) % fine
    psi = (centre[:, None] + offsets[None, :]) * step - angle[:, None]
    overlap = e[:, None] * np.cos(psi) - c_fine[index]
    w = np.maximum(overlap, 0.0)
    total = w.sum(axis=1)
    # an overlap narrower than the fine grid's spacing: the load at the contact direction
    point = total <= 0.0
    w[point, width] = 1.0
    total[point] = 1.0
    return index, w / total[:, None]


def wear_increment(profile, journal_radius: float, bearing_length: float,
                   coefficient: float, t, force, penetration, angle, slip):
    """The wear depth (m) at the profile's grid angles accumulated over the samples, and the
    worn volume (m^3).

    Parameters
    ----------
    profile : BearingProfile
        The bearing's current shape (radii on its grid).
    journal_radius, bearing_length : float
        R_J (m) and the bearing's axial length L (m): the depth is volume / (L R_B dtheta).
    coefficient : float
        k/H (m^2/N).
    t, force, penetration, angle, slip : (M,) arrays
        Sample times (s, increasing), the contact force (N), the penetration (m), the
        contact direction in the bearing's frame (rad) and the sliding speed (m/s) of one
        joint; samples out of contact (force <= 0) wear nothing. The time integral is the
        trapezoidal rule over the samples.

    Returns
    -------
    depth : (N,) m
        Wear depth per grid cell (the cell of angle theta_i spans theta_i +- pi / N).
    volume : float
        m^3, ``coefficient * integral of F |v| dt`` (the trapezoidal rule), which equals the
        depth summed over the cells times L R_B(theta_i) 2 pi / N.
    """
    t = np.asarray(t, dtype=float)
    force = np.asarray(force, dtype=float)
    rate = coefficient * np.where(force > 0.0, force, 0.0) * np.abs(np.asarray(slip, float))
    dt = np.diff(t)
    weight = np.zeros_like(t)
    weight[:-1] += 0.5 * dt
    weight[1:] += 0.5 * dt
    volume_k = rate * weight                        # m^3 worn at each sample
    n = profile.points
    cell = 2.0 * np.pi / n
    on = np.nonzero(volume_k > 0.0)[0]
    angle = np.asarray(angle, dtype=float)
    delta = np.maximum(np.asarray(penetration, dtype=float), 0.0)
    fine = np.zeros(ARC_POINTS_PER_CELL * n)
    for chunk in np.array_split(on, max(1, len(on) // 256)):
        if len(chunk) == 0:
            continue
        index, w = pressure_weights(profile, journal_radius, angle[chunk], delta[chunk])
        fine += np.bincount(index.ravel(), (volume_k[chunk][:, None] * w).ravel(),
                            minlength=len(fine))
    # the fine points onto the grid, linearly: point m lies a fraction f of a cell past
    # grid angle i0
    m = np.arange(len(fine))
    i0 = m // ARC_POINTS_PER_CELL
    f = (m % ARC_POINTS_PER_CELL) / ARC_POINTS_PER_CELL
    depth = (np.bincount(i0, fine * (1.0 - f), minlength=n)
             + np.bincount((i0 + 1) % n, fine * f, minlength=n))
    depth /= bearing_length * profile.radii * cell
    return depth, float(volume_k.sum())
