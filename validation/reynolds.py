"""A finite-difference solver of Reynolds' equation for the finite journal bearing: the
independent reference of the film laws (`mbs_clearance.laws.lubrication`), written apart
from their closed forms. Not used by the library.

The film is solved in the world frame: theta is the absolute angle (counterclockwise from
the x axis), z the axial coordinate in [-L/2, L/2]; the film thickness is
h = c - ex cos theta - ey sin theta, its rate dh/dt = -(vx cos theta + vy sin theta), the
surfaces slide at R omega_J and R omega_B; Reynolds' equation for an incompressible,
isoviscous film,

    (1/R^2) d/dtheta(h^3 dp/dtheta) + d/dz(h^3 dp/dz)
        = 6 mu (omega_J + omega_B) dh/dtheta + 12 mu dh/dt,

periodic in theta, p = 0 at both ends z = +-L/2, is discretised by conservative central
differences (h^3 at the half nodes) on n_theta x n_z nodes and solved as one sparse linear
system (full film). Cavitation: "full" keeps the whole solution; "half_sommerfeld" keeps
its positive part (Gumbel: the closed forms' condition).

The film's force on the journal is F = -int int p n R dtheta dz, n = (cos theta, sin theta);
its torque on the journal is the shear of the film on the journal surface,
R^2 int int (-(h / (2 R)) dp/dtheta - mu R (omega_J - omega_B) / h) dtheta dz, from the
computed pressure's own gradient (differences)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

__all__ = ["FilmSolution", "solve"]

CAVITATION = ("full", "half_sommerfeld")


@dataclass(frozen=True)
class FilmSolution:
    """The solved film: its force (fx, fy) on the journal centre (N), torque on the journal
    (N m), the pressure p[i_theta, i_z] (Pa) on the nodes theta, z (ends included)."""

    fx: float
    fy: float
    torque: float
    theta: np.ndarray
    z: np.ndarray
    p: np.ndarray


def _operator(h_half, h_node, dth, dz, R, n_theta, n_z):
    """The sparse Reynolds operator on the interior nodes (row i_theta * n_z + i_z)."""
    n = n_theta * n_z
    idx = np.arange(n).reshape(n_theta, n_z)
    a_e = h_half[1:] ** 3 / (R * R * dth * dth)    # between i and i+1
    a_w = h_half[:-1] ** 3 / (R * R * dth * dth)   # between i-1 and i
    a_z = h_node ** 3 / (dz * dz)
    rows, cols, vals = [], [], []
    diag = -(a_e + a_w)[:, None] - 2.0 * a_z[:, None] * np.ones((1, n_z))
    rows.append(idx.ravel())
    cols.append(idx.ravel())
    vals.append(diag.ravel())
    for shift, coef in ((1, a_e), (-1, a_w)):
        rows.append(idx.ravel())
        cols.append(np.roll(idx, -shift, axis=0).ravel())
        vals.append(np.repeat(coef, n_z))
    for shift in (1, -1):
        inside = idx[:, 1:] if shift == -1 else idx[:, :-1]
        rows.append(inside.ravel())
        cols.append((inside + shift).ravel())
        vals.append(np.repeat(a_z, n_z - 1))
    return sps.csr_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                  np.concatenate(cols))), shape=(n, n))


def solve(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, n_theta=240, n_z=40,
          cavitation="half_sommerfeld") -> FilmSolution:
    """The film of a journal (radius R, centre at e = (ex, ey) from the bearing centre,
    moving at (vx, vy), spinning at omega_j) in a bearing spinning at omega_b, radial
    clearance c, length L, viscosity mu; n_theta nodes around, n_z interior nodes along
    (`cavitation`: "full" or "half_sommerfeld")."""
    if cavitation not in CAVITATION:
        raise ValueError(f"cavitation must be one of {CAVITATION}; got {cavitation!r}")
    if not (n_theta >= 8 and n_z >= 2):
        raise ValueError(f"n_theta must be >= 8 and n_z >= 2; got {n_theta}, {n_z}")
    if not math.hypot(ex, ey) < c:
        raise ValueError(f"the journal centre must be inside the clearance circle "
                         f"(|e| < c = {c!r} m); got |e| = {math.hypot(ex, ey)!r} m")
    dth = 2.0 * math.pi / n_theta
    theta = dth * np.arange(n_theta)
    dz = L / (n_z + 1)
    z = -0.5 * L + dz * np.arange(n_z + 2)

    def h(th):
        return c - ex * np.cos(th) - ey * np.sin(th)

    h_node = h(theta)
    h_half = h(theta[0] - 0.5 * dth + dth * np.arange(n_theta + 1))
    dhdt = -(vx * np.cos(theta) + vy * np.sin(theta))
    rhs_node = (6.0 * mu * (omega_j + omega_b) * (h_half[1:] - h_half[:-1]) / dth
                + 12.0 * mu * dhdt)
    A = _operator(h_half, h_node, dth, dz, R, n_theta, n_z)
    b = np.repeat(rhs_node, n_z)
    x = spla.spsolve(A.tocsc(), b)
    if cavitation == "half_sommerfeld":
        x = np.maximum(x, 0.0)
    p = np.zeros((n_theta, n_z + 2))
    p[:, 1:-1] = x.reshape(n_theta, n_z)
    # force: periodic trapezoid in theta, trapezoid in z (p = 0 at the ends)
    P = p.sum(axis=1) * dz
    fx = -R * dth * float(np.sum(P * np.cos(theta)))
    fy = -R * dth * float(np.sum(P * np.sin(theta)))
    dpdth = (np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)) / (2.0 * dth)
    shear = -(h_node[:, None] / (2.0 * R)) * dpdth - mu * R * (omega_j - omega_b) / h_node[:, None]
    torque = R * R * dth * dz * float(np.sum(shear[:, 1:-1])
                                      + 0.5 * np.sum(shear[:, [0, -1]]))
    return FilmSolution(fx, fy, torque, theta, z, p)
