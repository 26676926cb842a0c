"""Friction in the Exudyn model of a description (the Exudyn side).

The friction of a clearance joint is an `ObjectGenericODE2` on the two bodies' nodes whose
(symbolic) force function returns the tangential force at the joint's points and the
moments R_J Ft / -R_B Ft; the law is contact.friction_force's. Checked here against
independent references: the law itself point by point (contact.friction_factor), the
power of the generalized forces (= Ft vt, the friction power, for any state), the Python
variant that calls contact.friction_force, the frictionless model (mu = 0 exactly), and the
generated reduced model with friction (slow, cross-model).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mbs_clearance import simulate
from mbs_clearance.backends import exudyn_linkage as xl
from mbs_clearance.elements import revolute
from mbs_clearance.laws.forces import FRICTION_LAWS, friction_factor, friction_force
from mbs_clearance.model import cases

pytestmark = pytest.mark.exudyn


#: the normal force of the power check, N
FN = 123.0


def _paper(**friction):
    return cases.paper_slider_crank(**friction)


@pytest.mark.parametrize("law", ["coulomb", "ambrosio"])
def test_symbolic_friction_factor_is_the_contact_law(law):
    """The symbolic phi(vt) evaluates to contact.friction_factor's at velocities on both
    sides of both thresholds, at them, and at zero (to the last bit but rounding)."""
    import exudyn as exu

    esym = exu.symbolic
    v0, v1 = 1e-4, 1e-2
    recording = esym.GetRecording()
    esym.SetRecording(True)
    try:
        vt = esym.Real("vt", 0.0)
        expr = revolute.symbolic_friction_factor(vt, v0, v1, FRICTION_LAWS[law])
        for v in (-0.5, -v1, -3e-3, -v0, -5e-5, 0.0, 2e-5, v0, 1.5e-4, 5e-3, v1, 0.2):
            vt.SetValue(v)
            assert expr.Evaluate() == pytest.approx(friction_factor(v, v0, v1,
                                                                   FRICTION_LAWS[law])[0],
                                                    rel=1e-15, abs=1e-300)
    finally:
        esym.SetRecording(recording)


def test_friction_loads_dissipate_the_friction_power():
    """The generalized forces of the friction element on the two bodies' (x, y, phi) do
    the power Ft vt for any state (forces at the joint points and the moments R_J Ft,
    -R_B Ft): vt computed independently from the surfaces' velocities at the contact
    point, Ft from contact.friction_force. Random states in contact, paper case."""
    lk = _paper(friction_law="coulomb", friction_coefficient=0.1)
    cj = lk.clearance_joints[0]
    bodies = {b.name: b for b in lk.bodies}
    rng = np.random.default_rng(3)
    pj, pb = bodies[cj.journal_body].points[cj.journal_point], \
        bodies[cj.bearing_body].points[cj.bearing_point]
    for _ in range(20):
        ref_j, ref_b = rng.normal(size=3), rng.normal(size=3)
        sides = [xl._Side(0, list(ref_j), pj, None), xl._Side(3, list(ref_b), pb, None)]
        q = np.zeros(6)
        qt = rng.normal(size=6)
        # place the journal point at penetration 1e-7 along a random direction
        th = rng.uniform(0, 2 * math.pi)
        rj = sides[0].kinematics(q, qt, math.cos, math.sin)[0]
        rb = sides[1].kinematics(q, qt, math.cos, math.sin)[0]
        n = np.array([math.cos(th), math.sin(th)])
        q[:2] = np.array(rb) + (cj.clearance + 1e-7) * n - np.array(rj)
        out = revolute._friction_loads(
            cj, sides, q, qt, lambda dx, dy, vx, vy: (math.hypot(dx, dy), FN),
            lambda vt, f: friction_force(vt, f, 0.1, cj.friction_v0, cj.friction_v1, 1),
            math.cos, math.sin, lambda d, v: v if d > 0 else 0.0)
        (xj, yj), vj, _, wj = sides[0].kinematics(q, qt, math.cos, math.sin)
        (xb, yb), vb, _, wb = sides[1].kinematics(q, qt, math.cos, math.sin)
        e = np.array([xj - xb, yj - yb])
        n = e / np.linalg.norm(e)
        t = np.array([-n[1], n[0]])
        # velocities of the two surfaces' points at the contact
        sj = np.array(vj) + wj * cj.journal_radius * np.array([-n[1], n[0]])
        sb = np.array(vb) + wb * cj.bearing_radius * np.array([-n[1], n[0]])
        vt = float((sj - sb) @ t)
        ft = friction_force(vt, FN, 0.1, cj.friction_v0, cj.friction_v1, 1)
        assert float(np.dot(out, qt)) == pytest.approx(ft * vt, rel=1e-10)
        assert ft * vt < 0.0


def _window(lk, **options):
    return simulate(lk, 1, backend="exudyn", step_size=8e-6, **options)


def test_zero_coefficient_is_the_frictionless_model():
    """mu = 0 (law "ambrosio") reproduces the frictionless Exudyn run bit for bit; mu = 0.1
    changes it (the element acts)."""
    free = _window(_paper())
    zero = _window(_paper(friction_law="ambrosio", friction_coefficient=0.0))
    on = _window(_paper(friction_law="ambrosio", friction_coefficient=0.1))
    np.testing.assert_array_equal(zero.base_force, free.base_force)
    np.testing.assert_array_equal(zero.crank_moment, free.crank_moment)
    assert np.max(np.abs(on.crank_moment - free.crank_moment)) > 1e-3 * np.max(
        np.abs(free.crank_moment))


@pytest.mark.parametrize("law", ["coulomb", "ambrosio"])
def test_symbolic_and_python_friction_agree(law):
    """The symbolic friction element and the Python one (contact.contact_force and
    contact.friction_force called per evaluation) give the same revolution (paper case,
    mu = 0.1, 8 us): base force and drive moment within 2e-6 of their maxima (measured
    4.2e-7 / 1.5e-6 with Ambrosio's law, 2e-8 / 1e-7 with Coulomb's: Newton's tolerance on
    a law with a kink)."""
    lk = _paper(friction_law=law, friction_coefficient=0.1)
    a, b = _window(lk), _window(lk, contact="python")
    for x, y in ((a.base_force, b.base_force), (a.crank_moment, b.crank_moment)):
        assert np.max(np.abs(x - y)) < 2e-6 * np.max(np.abs(x))


def test_friction_refused_where_not_built():
    """Friction with the native sphere contact is refused, naming the option."""
    lk = _paper(friction_law="ambrosio", friction_coefficient=0.1)
    with pytest.raises(ValueError, match="contact='sphere'"):
        simulate(lk, 1, backend="exudyn", contact="sphere")


@pytest.mark.slow
@pytest.mark.parametrize("mu", [0.01, 0.1])
def test_reduced_and_exudyn_agree_with_friction(mu):
    """Cross-model with friction on: the paper case, Ambrosio's law, between the
    generated reduced model (rtol 1e-10) and Exudyn at its default step (2 us): the rev-4
    peak of the monitored force within 0.5 % (measured -1.6e-5 at mu = 0.1), the RMS of
    the |shaking force| and of the drive moment within 2 % (-6.9e-6, -3.8e-5), and the
    friction work over four revolutions (Exudyn's from its body states and the law, the
    reduced model's a quadrature in its state) within 1e-3 (measured 9.7e-5)."""
    from validation.compare import compare

    lk = _paper(friction_law="ambrosio", friction_coefficient=mu)
    ref = simulate(lk, 4, rtol=1e-10, h_max=2e-6)
    ex = simulate(lk, 4, backend="exudyn")
    rev = compare(ref, ex, step_bars=False).revolution(4)
    assert abs(rev.peak_rel_diff) < 5e-3
    assert abs(rev.shaking_rms_rel_diff) < 2e-2 and abs(rev.moment_rms_rel_diff) < 2e-2
    end = 4 * lk.period
    wf_ref = np.interp(end, ref.t, ref.friction_work)
    wf_ex = np.interp(end, ex.t, ex.friction_work)
    assert wf_ref > 0 and abs(wf_ex / wf_ref - 1) < 1e-3
