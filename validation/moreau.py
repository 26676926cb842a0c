"""The nonsmooth reference of the translational-clearance slider-crank: Moreau's midpoint
time stepping with set-valued contact laws, the method of Flores, Leine and Glocker
(Multibody Syst. Dyn. 23 (2010) 165-190), written here independently of the package.

It shares nothing with the package's compliant model but the data (`FLGData`): rigid
contacts (a corner's normal impulse is whatever keeps it out of the guide), Newton's impact
law (normal restitution e_N), Coulomb's friction (mu), and a first-order scheme at a fixed
step, so its error is set by the step alone (`free_flight_error` measures it where the
exact motion is known).

The mechanism: crank O-A (length l1) pinned to the ground at O, coupler A-B (l2), and a
slider whose centre B is pinned to the coupler. The guide is the ground: the strip
|y| <= b + c around the x axis. The slider (length 2a, height 2b) turns freely (angle
phi3); its corners are (+-a, +-b) in its frame; the top corners (+b) touch the upper
surface y = b + c, the bottom ones the lower surface y = -(b + c). The centres of mass are
at the crank's and coupler's midpoints and at the slider's centre. Coordinates
q = (phi1, phi2, phi3): the absolute angles of crank, coupler and slider.

One step from (t, q_A, u_A) to (t + h, q_E, u_E):

    q_M = q_A + h/2 u_A
    M(q_M) (u_E - u_A) = h f(q_M, u_A) + W_N P_N + W_T P_T       (contacts with g_N(q_M) <= 0)
    P_N = prox_{R+}(P_N - r xi_N),    xi_N = gamma_N(u_E) + e_N gamma_N(u_A)
    P_T = prox_{[-mu P_N, mu P_N]}(P_T - r xi_T),    xi_T = gamma_T(u_E)
    q_E = q_M + h/2 u_E

with gamma = W^T u the contact velocities; the impulses are found by a projected
Gauss-Seidel iteration on the Delassus matrix W^T M^-1 W.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["FLGData", "MoreauResult", "corner_gaps", "mass_matrix", "forces", "run",
           "free_flight_reference", "free_flight_error", "energy", "CORNERS"]

#: the corners (sx, sy): their position (sx a, sy b) in the slider's frame; sy = +1 touch
#: the upper surface, sy = -1 the lower one
CORNERS = ((1, 1), (-1, 1), (-1, -1), (1, -1))


@dataclass(frozen=True)
class FLGData:
    """Flores, Leine and Glocker (2010), Table 1 (SI units) and the initial state."""

    l1: float = 0.153
    l2: float = 0.306
    a: float = 0.05
    b: float = 0.025
    c: float = 0.001
    m: tuple[float, float, float] = (0.038, 0.038, 0.076)
    inertia: tuple[float, float, float] = (7.4e-5, 5.9e-4, 2.7e-6)
    g: float = 9.81
    e_n: float = 0.4
    mu: float = 0.01
    q0: tuple[float, float, float] = (0.0, 0.0, 0.0)
    u0: tuple[float, float, float] = (150.0, -75.0, 0.0)


def _e(phi):
    return np.array([math.cos(phi), math.sin(phi)])


def _e_perp(phi):
    return np.array([-math.sin(phi), math.cos(phi)])


def _arms(d: FLGData):
    """Each body's centre of mass as sum_k L[k] e(phi_k)."""
    return (np.array([d.l1 / 2, 0.0, 0.0]), np.array([d.l1, d.l2 / 2, 0.0]),
            np.array([d.l1, d.l2, 0.0]))


def mass_matrix(d: FLGData, q) -> np.ndarray:
    """M(q) = sum_i m_i J_i^T J_i + diag(inertias)."""
    M = np.diag(np.asarray(d.inertia, dtype=float))
    ep = [_e_perp(p) for p in q]
    for mi, L in zip(d.m, _arms(d)):
        J = np.column_stack([L[k] * ep[k] for k in range(3)])
        M += mi * J.T @ J
    return M


def forces(d: FLGData, q, u) -> np.ndarray:
    """f(q, u): gravity and the velocity-product terms, M udot = f + contact forces."""
    f = np.zeros(3)
    ep = [_e_perp(p) for p in q]
    ee = [_e(p) for p in q]
    for mi, L in zip(d.m, _arms(d)):
        J = np.column_stack([L[k] * ep[k] for k in range(3)])
        quad = -sum(L[k] * ee[k] * u[k] ** 2 for k in range(3))
        f -= mi * J.T @ (quad + np.array([0.0, d.g]))
    return f


def corner_gaps(d: FLGData, q):
    """(g_N, W_N, W_T) of the four corners: the gaps to their guide surface (> 0 apart),
    and the gradients of the gaps and of the corners' x (the sliding direction) in q."""
    p1, p2, p3 = q
    y3 = d.l1 * math.sin(p1) + d.l2 * math.sin(p2)
    gaps, wn, wt = np.zeros(4), np.zeros((3, 4)), np.zeros((3, 4))
    for k, (sx, sy) in enumerate(CORNERS):
        yc = y3 + math.sin(p3) * sx * d.a + math.cos(p3) * sy * d.b
        dy = np.array([d.l1 * math.cos(p1), d.l2 * math.cos(p2),
                       math.cos(p3) * sx * d.a - math.sin(p3) * sy * d.b])
        dx = np.array([-d.l1 * math.sin(p1), -d.l2 * math.sin(p2),
                       -math.sin(p3) * sx * d.a - math.cos(p3) * sy * d.b])
        gaps[k] = (d.b + d.c) - sy * yc
        wn[:, k] = -sy * dy
        wt[:, k] = dx
    return gaps, wn, wt


def energy(d: FLGData, q, u) -> float:
    """Kinetic plus gravitational energy in J."""
    u = np.asarray(u, dtype=float)
    pot = 0.0
    for mi, L in zip(d.m, _arms(d)):
        pot += mi * d.g * sum(L[k] * math.sin(q[k]) for k in range(3))
    return 0.5 * u @ mass_matrix(d, q) @ u + pot


def _solve_impulses(G, gamma_free, gamma_a, e_n, mu, n, tol=1e-12, max_sweeps=100000):
    """Projected Gauss-Seidel on (P_N, P_T) of n active contacts: G is the Delassus matrix
    over [normals, tangents], gamma = gamma_free + G P. It stops when a sweep changes the
    contact velocities gamma by at most tol times their scale: two corners on one surface
    have the same sliding direction (G is singular there), and only the sum of their
    tangential impulses is defined."""
    P = np.zeros(2 * n)
    diag = np.diag(G).copy()
    scale = max(1e-300, float(np.max(np.abs(gamma_free))), float(np.max(np.abs(gamma_a))))
    gamma = gamma_free.copy()
    for sweep in range(max_sweeps):
        for i in range(n):
            xi = gamma_free[i] + G[i] @ P + e_n * gamma_a[i]
            P[i] = max(0.0, P[i] - xi / diag[i])
            j = n + i
            xi = gamma_free[j] + G[j] @ P
            bound = mu * P[i]
            P[j] = min(bound, max(-bound, P[j] - xi / diag[j]))
        new = gamma_free + G @ P
        if np.max(np.abs(new - gamma)) <= tol * scale:
            return P, sweep + 1
        gamma = new
    raise RuntimeError(f"the contact impulses did not converge in {max_sweeps} sweeps")


@dataclass
class MoreauResult:
    """Samples of a Moreau run every `every` steps: t, q (n, 3), u (n, 3), the corners'
    gaps (n, 4) and their normal impulses (n, 4, the sum over the samples' steps)."""

    t: np.ndarray
    q: np.ndarray
    u: np.ndarray
    gaps: np.ndarray
    impulses: np.ndarray
    step: float
    stats: dict = field(default_factory=dict)

    def corner_offsets(self, d: FLGData) -> np.ndarray:
        """Each corner's y offset from its place with the slider centred, over c: +1 on the
        upper surface, -1 on the lower one."""
        sy = np.array([s for _, s in CORNERS], dtype=float)
        return sy * (d.c - self.gaps) / d.c


def run(d: FLGData = FLGData(), t_end: float = 0.2, h: float = 1e-5, every: int = 1,
        stop_at_first_contact: bool = False) -> MoreauResult:
    """Moreau's midpoint scheme at the fixed step h from the data's initial state to t_end
    (or to the first step whose midpoint has a closed contact)."""
    if not (h > 0 and t_end > 0):
        raise ValueError(f"h and t_end must be > 0; got h={h!r}, t_end={t_end!r}")
    n_steps = int(round(t_end / h))
    q = np.array(d.q0, dtype=float)
    u = np.array(d.u0, dtype=float)
    ts, qs, us, gs, ps = [0.0], [q.copy()], [u.copy()], [corner_gaps(d, q)[0]], [np.zeros(4)]
    acc = np.zeros(4)
    sweeps = contact_steps = 0
    for i in range(1, n_steps + 1):
        qm = q + 0.5 * h * u
        M = mass_matrix(d, qm)
        f = forces(d, qm, u)
        gaps, wn, wt = corner_gaps(d, qm)
        active = np.flatnonzero(gaps <= 0.0)
        u_free = u + np.linalg.solve(M, h * f)
        if active.size:
            if stop_at_first_contact:
                break
            n = active.size
            W = np.hstack([wn[:, active], wt[:, active]])
            MW = np.linalg.solve(M, W)
            G = W.T @ MW
            P, k = _solve_impulses(G, W.T @ u_free, wn[:, active].T @ u, d.e_n, d.mu, n)
            sweeps += k
            contact_steps += 1
            u = u_free + MW @ P
            acc[active] += P[:n]
        else:
            u = u_free
        q = qm + 0.5 * h * u
        if i % every == 0:
            ts.append(i * h)
            qs.append(q.copy())
            us.append(u.copy())
            gs.append(corner_gaps(d, q)[0])
            ps.append(acc.copy())
            acc[:] = 0.0
    return MoreauResult(t=np.array(ts), q=np.array(qs), u=np.array(us), gaps=np.array(gs),
                        impulses=np.array(ps), step=h,
                        stats={"steps": i, "contact_steps": contact_steps,
                               "gauss_seidel_sweeps": sweeps})


def free_flight_reference(d: FLGData, t_eval, rtol: float = 1e-12):
    """The exact motion before any contact (scipy's DOP853 at rtol), (q, u) at t_eval."""
    from scipy.integrate import solve_ivp

    def rhs(t, y):
        q, u = y[:3], y[3:]
        return np.concatenate([u, np.linalg.solve(mass_matrix(d, q), forces(d, q, u))])

    t_eval = np.atleast_1d(np.asarray(t_eval, dtype=float))
    sol = solve_ivp(rhs, (0.0, float(t_eval[-1])), np.concatenate([d.q0, d.u0]),
                    method="DOP853", rtol=rtol, atol=rtol * 1e-3, t_eval=t_eval)
    return sol.y[:3].T, sol.y[3:].T


def free_flight_error(d: FLGData, h: float, t_end: float) -> float:
    """The scheme's largest angle error (rad) against the exact motion over [0, t_end],
    which must end before the first contact."""
    res = run(d, t_end=t_end, h=h)
    if np.any(res.gaps <= 0.0):
        raise ValueError(f"a corner touches before t_end={t_end!r} s; choose an earlier end")
    q_ref, _ = free_flight_reference(d, res.t)
    return float(np.max(np.abs(res.q - q_ref)))
