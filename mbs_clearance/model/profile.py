"""A clearance joint's bearing profile: the bearing's radius as a smooth periodic function of
the angle around the joint, as a worn bearing has it.

The radii are given at N equally spaced angles theta_i = 2 pi i / N (rad), measured in the
bearing body's frame from its x axis, counter-clockwise; between them the radius is the
periodic cubic spline through them (continuous second derivative, so the gap, its rate and
the contact force stay smooth for the integrator). A profile whose radii are all equal is
the circular bearing of that radius.

Small-wear approximation: the contact is located along the eccentricity direction theta_e
(journal centre minus bearing centre, in the bearing's frame) and the penetration is
``|e| - (R_B(theta_e) - R_J)``. What sets its error is the profile's slope against the
clearance, not against the radius: the journal centre's boundary ``|e| = R_B(theta) - R_J``
leans from a circle by ``R_B'(theta) / |e|`` (|e| about the clearance), and the true
boundary differs from it at second order in that lean. The contact force therefore acts
along that gap's gradient, ``n - (R_B' / |e|) t`` (n = e / |e|, t = (-n_y, n_x)), not along
n: a radial force on a leaning boundary does work around a closed path.
"""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np

__all__ = ["BearingProfile", "MIN_POINTS", "MAX_POINTS", "check_profile"]

#: fewest and most grid points of a profile (a cubic spline needs a few; the most bounds the
#: parameter vector of a generated model)
MIN_POINTS = 8
MAX_POINTS = 4096


def check_profile(what: str, radii, journal_radius: float) -> tuple[float, ...]:
    """The radii of a bearing profile as a tuple of floats, or ValueError naming `what` and
    the allowed range (MIN_POINTS..MAX_POINTS finite radii, each larger than the journal's
    radius)."""
    if isinstance(radii, (str, bytes)) or not hasattr(radii, "__len__"):
        raise ValueError(f"{what} must be a list of bearing radii (m) on an equally spaced "
                         f"angle grid; got {type(radii).__name__}")
    n = len(radii)
    if not MIN_POINTS <= n <= MAX_POINTS:
        raise ValueError(f"{what} must hold {MIN_POINTS} to {MAX_POINTS} radii (an equally "
                         f"spaced angle grid); got {n}")
    out = []
    for k, r in enumerate(radii):
        if isinstance(r, bool) or not isinstance(r, (int, float, np.floating, np.integer)):
            raise ValueError(f"{what}[{k}] must be a number (m); got {type(r).__name__}")
        r = float(r)
        if not math.isfinite(r) or r <= journal_radius:
            raise ValueError(f"{what}[{k}] must be a finite radius larger than the journal "
                             f"radius {journal_radius!r} m; got {r!r} m")
        out.append(r)
    return tuple(out)


class BearingProfile:
    """The bearing radius R_B(theta) through `radii` (m) at theta_i = 2 pi i / N: a periodic
    cubic spline. Angles in rad, in the bearing body's frame."""

    def __init__(self, radii) -> None:
        self.radii = np.asarray(radii, dtype=float)
        if self.radii.ndim != 1 or len(self.radii) < MIN_POINTS:
            raise ValueError(f"a bearing profile needs at least {MIN_POINTS} radii; "
                             f"got {self.radii.shape}")

    @classmethod
    def circular(cls, radius: float, points: int = 360) -> BearingProfile:
        """The circular bearing of `radius` (m) on a grid of `points` angles."""
        return cls(np.full(points, float(radius)))

    @property
    def points(self) -> int:
        """Number of grid angles N."""
        return len(self.radii)

    @property
    def angles(self) -> np.ndarray:
        """The grid angles theta_i = 2 pi i / N (rad)."""
        return 2.0 * np.pi * np.arange(self.points) / self.points

    @cached_property
    def spline(self):
        """The periodic cubic spline through the radii (closed at 2 pi)."""
        theta = 2.0 * np.pi * np.arange(self.points + 1) / self.points
        # imported here: scipy.interpolate costs ~0.3 s at import, and only a profile needs it
        from scipy.interpolate import CubicSpline

        return CubicSpline(theta, np.append(self.radii, self.radii[0]), bc_type="periodic")

    def radius(self, theta, derivative: int = 0) -> np.ndarray:
        """R_B (m) or its `derivative`-th derivative in theta (m/rad^k) at `theta` (rad, any
        value: reduced to [0, 2 pi))."""
        return self.spline(np.mod(theta, 2.0 * np.pi), derivative)

    def curvature_radius(self, theta) -> np.ndarray:
        """The radius of curvature of the bearing's surface at `theta` (m): for a polar
        curve, (r^2 + r'^2)^(3/2) / (r^2 + 2 r'^2 - r r''); R for a circle."""
        r, r1, r2 = (self.radius(theta, k) for k in range(3))
        return (r * r + r1 * r1) ** 1.5 / (r * r + 2.0 * r1 * r1 - r * r2)

    def coefficients(self) -> np.ndarray:
        """The spline's pieces, shape (N, 4): on [theta_i, theta_i+1) the radius is
        c0 + c1 u + c2 u^2 + c3 u^3 with u = theta - theta_i (how a compiled model
        evaluates it)."""
        return np.ascontiguousarray(self.spline.c[::-1].T)

    def area(self) -> float:
        """The area enclosed by the profile (m^2): integral of R_B^2 / 2 over the angle,
        exact for the spline (Gauss-Legendre on each piece)."""
        x, w = np.polynomial.legendre.leggauss(4)
        h = 2.0 * np.pi / self.points
        theta = (self.angles[:, None] + 0.5 * h * (x[None, :] + 1.0)).ravel()
        r = self.radius(theta)
        return float(0.25 * h * np.sum(np.tile(w, self.points) * r * r))
