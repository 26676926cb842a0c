"""The nonsmooth reference of the translational-clearance benchmark (validation.moreau):
its equations against differences and energy, its contact laws against their definitions,
and its first-order convergence against the exact free flight."""

import math

import numpy as np
import pytest

from validation import moreau as mo

D = mo.FLGData()


def _centres(q):
    """Centres of mass of crank, coupler, slider at q, written out for the test."""
    e = [np.array([math.cos(p), math.sin(p)]) for p in q]
    return [D.l1 / 2 * e[0], D.l1 * e[0] + D.l2 / 2 * e[1], D.l1 * e[0] + D.l2 * e[1]]


def test_mass_matrix_is_the_kinetic_energy_of_the_bodies_velocities():
    rng = np.random.default_rng(1)
    for _ in range(3):
        q, u = rng.uniform(-3, 3, 3), rng.uniform(-100, 100, 3)
        eps = 1e-6
        vel = [(a - b) / (2 * eps) for a, b in zip(_centres(q + eps * u), _centres(q - eps * u))]
        kinetic = sum(0.5 * m * v @ v for m, v in zip(D.m, vel)) + 0.5 * sum(
            i * w * w for i, w in zip(D.inertia, u))
        assert 0.5 * u @ mo.mass_matrix(D, q) @ u == pytest.approx(kinetic, rel=1e-8)


def test_free_motion_conserves_its_energy():
    t = np.linspace(0.0, 0.0025, 6)
    q, u = mo.free_flight_reference(D, t)
    energies = [mo.energy(D, qi, ui) for qi, ui in zip(q, u)]
    assert np.ptp(energies) < 1e-9 * energies[0]


def test_corner_gaps_and_their_gradients():
    q = np.array([0.3, -0.1, 0.02])
    gaps, wn, wt = mo.corner_gaps(D, q)
    y3 = D.l1 * math.sin(0.3) + D.l2 * math.sin(-0.1)
    # corner (+a, +b) by hand: its y, against the upper surface
    y = y3 + D.a * math.sin(0.02) + D.b * math.cos(0.02)
    assert gaps[0] == pytest.approx(D.b + D.c - y, abs=1e-15)
    # corner (-a, -b) against the lower surface
    y = y3 - D.a * math.sin(0.02) - D.b * math.cos(0.02)
    assert gaps[2] == pytest.approx(y + D.b + D.c, abs=1e-15)
    eps = 1e-7
    for k in range(3):
        dq = np.zeros(3)
        dq[k] = eps
        dg = (mo.corner_gaps(D, q + dq)[0] - mo.corner_gaps(D, q - dq)[0]) / (2 * eps)
        assert np.allclose(wn[k], dg, rtol=1e-6, atol=1e-9)
    # the sliding direction: the corners' x against differences
    x3 = lambda q: D.l1 * math.cos(q[0]) + D.l2 * math.cos(q[1])     # noqa: E731
    for c, (sx, sy) in enumerate(mo.CORNERS):
        x = lambda q: x3(q) + math.cos(q[2]) * sx * D.a - math.sin(q[2]) * sy * D.b  # noqa
        for k in range(3):
            dq = np.zeros(3)
            dq[k] = eps
            assert wt[k, c] == pytest.approx((x(q + dq) - x(q - dq)) / (2 * eps), abs=1e-8)


def test_the_scheme_is_first_order_before_the_first_impact():
    """Against the exact free flight (DOP853 at rtol 1e-12) up to 2.4 ms, before the
    first corner reaches the guide (at about 2.7 ms): halving the step halves the error."""
    e1 = mo.free_flight_error(D, 2e-5, 0.0024)
    e2 = mo.free_flight_error(D, 1e-5, 0.0024)
    assert math.log2(e1 / e2) == pytest.approx(1.0, abs=0.05)


def test_impulses_satisfy_newtons_impact_law_and_coulombs_cone():
    """One contact, frictionless and with friction: the impulse makes the corner leave at
    -e times its approach velocity, and the friction impulse stays in the cone (sliding:
    on its edge, against the sliding direction)."""
    q = np.array([0.0, 0.0, 0.0])
    M = mo.mass_matrix(D, q)
    _, wn, wt = mo.corner_gaps(D, q)
    u = np.array([0.0, 0.0, 50.0])      # the slider turns counter-clockwise: (+a, +b) rises
    for mu in (0.0, 0.3):
        W = np.column_stack([wn[:, 0], wt[:, 0]])
        MW = np.linalg.solve(M, W)
        G = W.T @ MW
        gamma_a = wn[:, 0] @ u
        assert gamma_a < 0                  # approaching: its gap closes
        P, _ = mo._solve_impulses(G, W.T @ u, np.array([gamma_a]), 0.4, mu, 1)
        after = u + MW @ P
        assert wn[:, 0] @ after == pytest.approx(-0.4 * gamma_a, rel=1e-9)
        assert abs(P[1]) <= mu * P[0] * (1 + 1e-12)
        slip = wt[:, 0] @ after
        if mu > 0 and abs(slip) > 1e-9:
            assert P[1] == pytest.approx(-math.copysign(mu * P[0], slip), rel=1e-9)


def test_bad_step_is_refused():
    with pytest.raises(ValueError, match="h and t_end must be > 0"):
        mo.run(D, t_end=0.1, h=0.0)
