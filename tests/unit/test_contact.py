"""Contact laws: partial derivatives, clamping, and the restitution they produce."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mbs_clearance.laws.forces import (
    CONTACT_MODELS,
    FRICTION_LAWS,
    contact_force,
    contact_force_partials,
    friction_force,
    friction_force_partials,
)

ARGS = (2e-6, 0.05, 0.3, 4.8e11, 0.8)  # delta, deltadot, deltadot_minus, K, e


@pytest.mark.parametrize("model", CONTACT_MODELS.values())
@pytest.mark.parametrize("k", range(5))
def test_partials_match_central_differences(model, k):
    x = list(ARGS)
    h = abs(x[k]) * 1e-6
    up, dn = list(x), list(x)
    up[k] += h
    dn[k] -= h
    fd = (contact_force(*up, model) - contact_force(*dn, model)) / (2 * h)
    order = [1, 2, 3, 4, 5]  # F, dF/ddelta, dF/ddeltadot, dF/ddeltadot_minus, dF/dK, dF/de
    assert contact_force_partials(*x, model)[order[k]] == pytest.approx(fd, rel=1e-6)


def test_no_force_without_penetration_and_never_pulling():
    assert contact_force(-1e-9, 1.0, 0.3, 1e10, 0.9, 0) == 0.0
    # strongly separating at low restitution: the damping term would pull; clamped to zero
    assert contact_force(1e-6, -10.0, 0.1, 1e10, 0.1, 0) == 0.0


def point_impact_restitution(name, e):
    """Effective restitution of a mass hitting a rigid wall through the law (scipy DOP853)."""
    model = CONTACT_MODELS[name]
    m, K, v0 = 0.14, 4.8e11, 0.5

    def f(t, y):
        return [y[1], -contact_force(y[0], y[1], v0, K, e, model) / m]

    def leave(t, y):
        return y[0]

    leave.terminal, leave.direction = True, -1
    sol = solve_ivp(f, (0, 1e-3), [1e-15, v0], rtol=1e-11, atol=1e-16, events=leave,
                    method="DOP853")
    return -sol.y_events[0][0][1] / v0


def test_restitution_is_exact_without_damping():
    for name in CONTACT_MODELS:
        assert point_impact_restitution(name, 1.0) == pytest.approx(1.0, abs=1e-7)


def test_lankarani_nikravesh_is_a_high_restitution_law():
    """Lankarani-Nikravesh linearises the energy loss about e = 1: the effective restitution
    matches e to 2 % for e >= 0.9 and drifts away as e falls (known limit of the law, see
    Flores et al. 2011, Fig. 6); Flores' law stays within 0.05 over the whole range."""
    dev_ln = [abs(point_impact_restitution("lankarani_nikravesh", e) - e)
              for e in (0.99, 0.9, 0.8, 0.5)]
    assert dev_ln[0] < 0.002 and dev_ln[1] < 0.02
    assert np.all(np.diff(dev_ln) > 0)
    assert dev_ln[3] > 0.2
    for e in (0.3, 0.5, 0.8, 0.9):
        dev_fl = abs(point_impact_restitution("flores", e) - e)
        assert dev_fl < 0.05
        if e <= 0.8:
            assert dev_fl < abs(point_impact_restitution("lankarani_nikravesh", e) - e)


# ---------------------------------------------------------------------------- friction laws

V0, V1 = 1e-4, 1e-2


@pytest.mark.parametrize("law", ["coulomb", "ambrosio"])
@pytest.mark.parametrize("vt", [-0.3, -5e-3, -3e-5, 2e-5, 4e-3, 0.7])
def test_friction_partials_match_central_differences(law, vt):
    lid = FRICTION_LAWS[law]
    args = [vt, 120.0, 0.1, V0, V1]
    got = friction_force_partials(*args, lid)
    assert got[0] == pytest.approx(friction_force(*args, lid), rel=1e-15, abs=0)
    for k in range(5):
        h = 1e-5 * max(abs(args[k]), V0)
        up, dn = list(args), list(args)
        up[k] += h
        dn[k] -= h
        fd = (friction_force(*up, lid) - friction_force(*dn, lid)) / (2 * h)
        # round-off of the difference quotient: ~1e-15 |Ft| / h
        assert got[k + 1] == pytest.approx(fd, rel=1e-6, abs=1e-14 * abs(got[0]) / h), k


def test_friction_opposes_sliding_and_reaches_coulomb():
    for law in ("coulomb", "ambrosio"):
        lid = FRICTION_LAWS[law]
        for vt in (-1.0, -0.05, 0.05, 1.0):
            f = friction_force(vt, 200.0, 0.05, V0, V1, lid)
            # well above both thresholds: |Ft| = mu Fn to the regularisation's 1e-5
            assert f * vt < 0
            assert abs(f) == pytest.approx(0.05 * 200.0, rel=1e-5)
    assert friction_force(0.5, 200.0, 0.05, V0, V1, FRICTION_LAWS["none"]) == 0.0


def test_ambrosio_dynamic_correction_is_piecewise_linear():
    lid = FRICTION_LAWS["ambrosio"]
    mu, fn = 0.1, 50.0
    # Ambrosio's c_d: 0 up to v0, linear between the thresholds, 1 from v1
    for speed, cd in ((0.5 * V0, 0.0), (V0, 0.0), (0.5 * (V0 + V1), 0.5),
                      (V0 + 0.25 * (V1 - V0), 0.25), (V1, 1.0), (3 * V1, 1.0)):
        for sign in (1.0, -1.0):
            assert friction_force(sign * speed, fn, mu, V0, V1, lid) == pytest.approx(
                -sign * mu * fn * cd, rel=1e-12, abs=1e-15)


def test_regularised_coulomb_is_odd_and_smooth_through_zero():
    lid = FRICTION_LAWS["coulomb"]
    assert friction_force(0.0, 10.0, 0.2, V0, V1, lid) == 0.0
    f, dvt = friction_force_partials(0.0, 10.0, 0.2, V0, V1, lid)[:2]
    assert dvt == pytest.approx(-0.2 * 10.0 / V0, rel=1e-14)   # slope mu Fn / v0 at rest
    for vt in (1e-5, 3e-4, 0.1):
        assert friction_force(-vt, 10.0, 0.2, V0, V1, lid) == -friction_force(
            vt, 10.0, 0.2, V0, V1, lid)
