"""Contact laws: partial derivatives, clamping, and the restitution they produce."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mbs_clearance.contact import CONTACT_MODELS, contact_force, contact_force_partials

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
