"""Every registered contact and friction law, checked the same way (parametrised over
`mbs_clearance.laws.registry`): the generated partial derivatives against central finite
differences of the compiled force at states on both sides of each threshold; the work of a
contact over a closed compression-restitution cycle (a point mass on a rigid wall, scipy's
DOP853: energy lost for e < 1, none for e = 1); the friction power Ft vt <= 0; no pull, no
force without penetration or normal force; the compiled value against the law's own
formula evaluated as an Exudyn symbolic expression; and the parameters the laws declare
(defaults in range, ranges enforced at load). A new law gets all of these by being in the
registry."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mbs_clearance.laws import codegen
from mbs_clearance.laws._dispatch import friction_force_partials_slots, friction_force_slots
from mbs_clearance.laws.forces import contact_force, contact_force_partials, hysteresis_factor
from mbs_clearance.laws.registry import (
    CONTACT,
    CONTACT_MODELS,
    FRICTION,
    FRICTION_LAWS,
    FRICTION_PARAMETER_SPECS,
    FRICTION_SLOTS,
)
from mbs_clearance.model import cases

CONTACT_NAMES = list(CONTACT_MODELS)
FRICTION_NAMES = list(FRICTION_LAWS)

#: the friction slots' values of the checks: the declared defaults, mu = 0.1 (a dry pair)
#: and any further coefficient (a static one) 0.15
SLOTS = tuple(0.1 if p.name == "friction_coefficient" else
              0.15 if p.name.endswith("coefficient") else p.default
              for p in FRICTION_PARAMETER_SPECS)
V0, V1 = SLOTS[FRICTION_SLOTS.index("friction_v0")], SLOTS[FRICTION_SLOTS.index("friction_v1")]

#: slip velocities (m/s) on both sides of the velocity scales v0 = 1e-4, v1 = 1e-2 and of 0,
#: none within the finite-difference step of a kink
SLIPS = (-0.7, -2e-2, -4e-3, -3e-4, -5e-5, -1e-6, 1e-6, 5e-5, 3e-4, 4e-3, 2e-2, 0.7)


#: xi(e) of each contact law as published (written out here, independently of its module)
PUBLISHED_XI = {
    "lankarani_nikravesh": lambda e: 3.0 * (1.0 - e**2) / 4.0,    # Lankarani & Nikravesh 1990
    "hunt_crossley": lambda e: 3.0 * (1.0 - e) / 2.0,             # Hunt & Crossley 1975
    "flores": lambda e: 8.0 * (1.0 - e) / (5.0 * e),              # Flores et al. 2011
    "hu_guo": lambda e: 3.0 * (1.0 - e) / (2.0 * e),              # Hu & Guo 2015
}

#: the paper case with a law, run by both models (slow): law -> the case's overrides
CROSS_MODEL: dict[str, dict] = {
    "hu_guo": {"contact_model": "hu_guo"},
    "stribeck": {"friction_law": "stribeck", "friction_coefficient": 0.1,
                 "friction_static_coefficient": 0.15},
}


def test_dispatch_is_generated_from_the_registry():
    """The checked-in `laws._dispatch` is what `python -m mbs_clearance.laws.codegen`
    writes from the registry now (a law added without regenerating fails here)."""
    assert codegen.PATH.read_text() == codegen.render()


def test_c_laws_are_generated_from_the_registry():
    """The checked-in C header of the laws (`core/laws_generated.h`) is what the codegen
    writes from the registry now, and `--check` says so."""
    assert codegen.C_PATH.read_text() == codegen.render_c()
    assert codegen.main(["--check"]) == 0


# ------------------------------------------------------------------------------- contact

@pytest.mark.parametrize("name", CONTACT_NAMES)
@pytest.mark.parametrize("e", [0.15, 0.5, 0.8, 0.99, 1.0])
def test_hysteresis_partial_matches_central_differences(name, e):
    """dxi/de (sympy's, generated) against central differences of the compiled xi(e)
    (at e = 1, the end of the range, centred on 1 - h)."""
    model = CONTACT_MODELS[name]
    h = 1e-6
    hi = e + h if e < 1.0 else e
    lo = e - h if e < 1.0 else e - 2 * h
    fd = (hysteresis_factor(hi, model)[0] - hysteresis_factor(lo, model)[0]) / (hi - lo)
    mid = 0.5 * (hi + lo)
    assert hysteresis_factor(mid, model)[1] == pytest.approx(fd, rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("name", CONTACT_NAMES)
def test_hysteresis_is_the_published_formula(name):
    """Every registered contact law has its published xi(e) here, and the compiled one
    matches it over the whole range of e."""
    model = CONTACT_MODELS[name]
    for e in np.linspace(0.02, 1.0, 50):
        assert hysteresis_factor(e, model)[0] == pytest.approx(PUBLISHED_XI[name](e),
                                                               rel=1e-14, abs=1e-15)


@pytest.mark.parametrize("name", CONTACT_NAMES)
@pytest.mark.parametrize("state", [(2e-6, 0.2, 0.3), (2e-6, -0.2, 0.3), (5e-7, 0.0, 1.0)])
@pytest.mark.parametrize("k", range(5))
def test_contact_partials_match_central_differences(name, state, k):
    """(dF/ddelta, dF/ddeltadot, dF/ddeltadot_minus, dF/dK, dF/de) in compression and in
    restitution, against central differences of the compiled force."""
    model = CONTACT_MODELS[name]
    x = [*state, 4.8e11, 0.7]
    h = max(abs(x[k]), 1e-3) * 1e-6
    up, dn = list(x), list(x)
    up[k] += h
    dn[k] -= h
    fd = (contact_force(*up, model) - contact_force(*dn, model)) / (2 * h)
    scale = contact_force(*x, model) / max(abs(x[k]), 1e-3)
    assert contact_force_partials(*x, model)[1 + k] == pytest.approx(fd, rel=1e-6,
                                                                     abs=1e-9 * scale)


@pytest.mark.parametrize("name", CONTACT_NAMES)
def test_contact_never_pulls(name):
    """No force without penetration; at the lowest restitution and a fast separation the
    damping term exceeds the spring term and the force is clamped to 0, not negative."""
    model = CONTACT_MODELS[name]
    assert contact_force(-1e-9, -1.0, 0.3, 1e10, 0.9, model) == 0.0
    assert contact_force(0.0, 1.0, 0.3, 1e10, 0.9, model) == 0.0
    for e in (0.05, 0.3, 0.9):
        for rate in (-100.0, -3.0, -0.3, 0.0, 0.3):
            assert contact_force(1e-6, rate, 0.3, 1e10, e, model) >= 0.0
    xi = hysteresis_factor(0.05, model)[0]
    assert contact_force(1e-6, -2.0 * 0.3 / xi, 0.3, 1e10, 0.05, model) == 0.0
    assert contact_force_partials(1e-6, -2.0 * 0.3 / xi, 0.3, 1e10, 0.05, model) == (
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def _impact(model, e, m=0.14, K=4.8e11, v_in=0.5):
    """A point mass on a rigid wall through the law: (exit speed, the work of the contact
    force over the cycle integrated along the path, int F ddelta)."""

    def f(t, y):
        force = contact_force(y[0], y[1], v_in, K, e, model)
        return [y[1], -force / m, force * y[1]]

    def leave(t, y):
        return y[0]

    leave.terminal, leave.direction = True, -1
    sol = solve_ivp(f, (0, 1e-3), [1e-15, v_in, 0.0], rtol=1e-11, atol=1e-16,
                    events=leave, method="DOP853")
    y = sol.y_events[0][0]
    return -y[1], y[2]


@pytest.mark.parametrize("name", CONTACT_NAMES)
@pytest.mark.parametrize("e", [0.3, 0.7, 0.95, 1.0])
def test_contact_cycle_dissipates_unless_e_is_one(name, e):
    """Over a closed compression-restitution cycle the contact force does work
    W = int F ddelta = 1/2 m (v_in^2 - v_out^2) >= 0 on the wall (energy the mass loses):
    positive for e < 1, zero for e = 1 for the laws declared lossless (xi(1) = 0). The
    work, integrated along the path, checks the energy balance of the integration."""
    law = CONTACT[CONTACT_MODELS[name]]
    m, v_in = 0.14, 0.5
    v_out, work = _impact(CONTACT_MODELS[name], e, m=m, v_in=v_in)
    lost = 0.5 * m * (v_in**2 - v_out**2)
    assert work == pytest.approx(lost, rel=1e-6, abs=1e-12)
    if e < 1.0:
        assert lost > 1e-3 * 0.5 * m * v_in**2
        assert 0.0 < v_out < v_in
    elif law.lossless:
        assert v_out == pytest.approx(v_in, rel=1e-7)


@pytest.mark.exudyn
@pytest.mark.parametrize("name", CONTACT_NAMES)
def test_contact_symbolic_is_the_compiled_law(name):
    """The law's xi(e) evaluated as an Exudyn symbolic expression and the Exudyn model's
    symbolic normal force (with that xi) equal the compiled ones (to rounding)."""
    exu = pytest.importorskip("exudyn")
    from mbs_clearance.elements import revolute

    esym = exu.symbolic
    model = CONTACT_MODELS[name]
    recording = esym.GetRecording()
    esym.SetRecording(True)
    try:
        e_sym = esym.Real("e", 0.5)
        expr = CONTACT[model].hysteresis(e_sym)
        for e in (0.1, 0.5, 0.8, 1.0):
            e_sym.SetValue(e)
            assert expr.Evaluate() == pytest.approx(hysteresis_factor(e, model)[0],
                                                    rel=1e-15, abs=1e-300)
        K, c, dmin, e = 4.8e11, 1e-4, 0.3, 0.7
        xi = hysteresis_factor(e, model)[0]
        dx, dy, vx, vy = (esym.Real(s, 0.0) for s in ("dx", "dy", "vx", "vy"))
        _, force = revolute._symbolic_normal(K, c, xi, dmin, dx, dy, vx, vy)
        for th, pen, rate in ((0.3, 2e-6, 0.2), (2.0, 2e-6, -0.2), (-1.0, 1e-6, -50.0),
                              (1.0, -1e-7, 0.1)):
            r = c + pen
            for var, value in ((dx, r * math.cos(th)), (dy, r * math.sin(th)),
                               (vx, rate * math.cos(th)), (vy, rate * math.sin(th))):
                var.SetValue(value)
            ref = contact_force(pen, rate, dmin, K, e, model)
            assert force.Evaluate() == pytest.approx(ref, rel=1e-9, abs=1e-9)
    finally:
        esym.SetRecording(recording)


# ------------------------------------------------------------------------------ friction

@pytest.mark.parametrize("name", FRICTION_NAMES)
@pytest.mark.parametrize("vt", SLIPS)
def test_friction_partials_match_central_differences(name, vt):
    """dFt/dvt, dFt/dFn and dFt/d(each slot) against central differences of the compiled
    force, at slip velocities on both sides of 0 and of each velocity scale."""
    law, fn = FRICTION_LAWS[name], 123.0
    ft, d_vt, d_fn, d_slots = friction_force_partials_slots(vt, fn, SLOTS, law)
    assert ft == friction_force_slots(vt, fn, SLOTS, law)
    h = abs(vt) * 1e-6
    fd = (friction_force_slots(vt + h, fn, SLOTS, law)
          - friction_force_slots(vt - h, fn, SLOTS, law)) / (2 * h)
    scale = 0.1 * fn / V0
    assert d_vt == pytest.approx(fd, rel=1e-5, abs=1e-9 * scale)
    fd = (friction_force_slots(vt, fn * 1.001, SLOTS, law)
          - friction_force_slots(vt, fn * 0.999, SLOTS, law)) / (0.002 * fn)
    assert d_fn == pytest.approx(fd, rel=1e-9, abs=1e-15)
    for k, value in enumerate(SLOTS):
        h = value * 1e-6
        up, dn = list(SLOTS), list(SLOTS)
        up[k] += h
        dn[k] -= h
        fd = (friction_force_slots(vt, fn, tuple(up), law)
              - friction_force_slots(vt, fn, tuple(dn), law)) / (2 * h)
        assert d_slots[k] == pytest.approx(fd, rel=1e-5, abs=1e-9 * fn / value), \
            FRICTION_SLOTS[k]


@pytest.mark.parametrize("name", FRICTION_NAMES)
def test_friction_dissipates_and_is_odd(name):
    """Ft vt <= 0 (friction never drives the sliding), Ft(-vt) = -Ft(vt), no force without
    normal force, |Ft| <= the largest coefficient the law can reach times Fn."""
    law, fn = FRICTION_LAWS[name], 50.0
    mu_max = max(SLOTS[k] for k, f in enumerate(FRICTION_SLOTS)
                 if f.endswith("coefficient"))
    for vt in np.concatenate([SLIPS, np.linspace(-0.05, 0.05, 401)]):
        ft = friction_force_slots(vt, fn, SLOTS, law)
        assert ft * vt <= 0.0
        assert friction_force_slots(-vt, fn, SLOTS, law) == pytest.approx(-ft, abs=1e-15)
        assert friction_force_slots(vt, 0.0, SLOTS, law) == 0.0
        assert abs(ft) <= mu_max * fn * (1 + 1e-12)


@pytest.mark.exudyn
@pytest.mark.parametrize("name", FRICTION_NAMES)
def test_friction_symbolic_is_the_compiled_law(name):
    """The law's force evaluated as an Exudyn symbolic expression (what the Exudyn model's
    friction element computes) equals the compiled force at slip velocities on both sides
    of every threshold, at them, and at zero."""
    exu = pytest.importorskip("exudyn")
    from mbs_clearance.elements import revolute

    esym = exu.symbolic
    law, fn = FRICTION_LAWS[name], 77.0
    recording = esym.GetRecording()
    esym.SetRecording(True)
    try:
        vt = esym.Real("vt", 0.0)
        expr = revolute.symbolic_friction_force(vt, fn, law, SLOTS)
        for v in (*SLIPS, 0.0, V0, -V0, V1, -V1):
            vt.SetValue(v)
            assert expr.Evaluate() == pytest.approx(friction_force_slots(v, fn, SLOTS, law),
                                                    rel=1e-14, abs=1e-300)
    finally:
        esym.SetRecording(recording)


@pytest.mark.slow
@pytest.mark.exudyn
@pytest.mark.parametrize("name", sorted(CROSS_MODEL))
def test_reduced_and_exudyn_agree_with_the_law(name):
    """Cross-model with a law: the paper case, two revolutions, the generated reduced model
    (rtol 1e-10) against Exudyn at its default step (2 us), compared as the friction
    cross-model test does (same bounds): the rev-2 peak of the monitored force within
    0.5 %, the RMS of the |shaking force| and of the drive moment within 2 %."""
    from mbs_clearance import simulate
    from validation.compare import compare

    lk = cases.paper_slider_crank(**CROSS_MODEL[name])
    ref = simulate(lk, 2, rtol=1e-10, h_max=2e-6)
    ex = simulate(lk, 2, backend="exudyn")
    rev = compare(ref, ex, step_bars=False).revolution(2)
    assert abs(rev.peak_rel_diff) < 5e-3
    assert abs(rev.shaking_rms_rel_diff) < 2e-2 and abs(rev.moment_rms_rel_diff) < 2e-2


# ---------------------------------------------------------------------------- parameters

def test_declared_parameters_are_consistent():
    """Every declared default lies in its range; contact laws declare the restitution;
    each friction law's arguments are slots with a declaration."""
    for law in CONTACT:
        p = law.restitution
        assert p.name == "restitution" and p.contains(p.default) and law.source
    declared = {p.name for p in FRICTION_PARAMETER_SPECS}
    assert set(FRICTION_SLOTS) == declared
    for law in FRICTION:
        assert set(law.arguments) <= set(FRICTION_SLOTS) and law.source
        for p in law.parameters:
            assert p.contains(p.default) or (p.name == "friction_coefficient"
                                             and p.default == 0.0)
            assert not p.contains(math.inf)
            if p.low is not None:
                assert not p.contains(p.low - 1.0)


def test_description_fields_default_to_the_declarations():
    """The friction fields of `ClearanceJoint` and `SliderCrank` default to what the laws
    declare."""
    import dataclasses

    from mbs_clearance.model.linkage import ClearanceJoint
    from mbs_clearance.model.mechanism import SliderCrank

    for cls in (ClearanceJoint, SliderCrank):
        defaults = {f.name: f.default for f in dataclasses.fields(cls)}
        for p in FRICTION_PARAMETER_SPECS:
            assert defaults[p.name] == p.default, (cls.__name__, p.name)


@pytest.mark.parametrize("spec", FRICTION_PARAMETER_SPECS[3:], ids=lambda p: p.name)
def test_further_slots_are_checked_at_load(spec):
    """A friction slot beyond mu, v0, v1 outside its declared range (or not finite) fails
    when the description is built, naming the field and the allowed range."""
    bad = [math.nan, math.inf] + ([spec.low - 1.0] if spec.low is not None else [])
    if spec.low is not None and spec.low_open:
        bad.append(spec.low)
    for value in bad:
        with pytest.raises(ValueError, match=f"{spec.name}.*{spec.interval[1:4]}"):
            cases.paper_slider_crank(**{spec.name: value})


@pytest.mark.parametrize("name", FRICTION_NAMES)
def test_friction_law_reaches_the_case_description(name):
    """A friction law and its slots given as case overrides reach every clearance joint
    of the description."""
    values = dict(zip(FRICTION_SLOTS, SLOTS))
    lk = cases.slider_crank_two_clearances(friction_law=name, **values)
    for j in lk.clearance_joints:
        assert j.friction_law == name
        assert all(getattr(j, f) == v for f, v in values.items())


# ---------------------------------------------------------------- law-specific references

def _slots(**values):
    spec = dict(zip(FRICTION_SLOTS, SLOTS))
    spec.update(values)
    return tuple(spec[f] for f in FRICTION_SLOTS)


def test_stribeck_falls_from_the_static_to_the_dynamic_coefficient():
    """Stribeck's law against its closed form (Andersson et al. 2007 with the Gaussian
    exponent), its limits (mu_s just above v0, mu_d well above v_s), and the regularised
    Coulomb law where mu_s = mu_d."""
    law, fn = FRICTION_LAWS["stribeck"], 100.0
    mu, mu_s, v0, v_s = 0.1, 0.15, 1e-6, 1e-2
    slots = _slots(friction_coefficient=mu, friction_static_coefficient=mu_s,
                   friction_v0=v0, friction_stribeck_velocity=v_s)
    for vt in (-0.3, -2e-2, -1e-2, -3e-3, -1e-5, 2e-7, 1e-5, 5e-3, 1e-2, 0.05, 1.0):
        ref = -fn * (mu + (mu_s - mu) * math.exp(-(abs(vt) / v_s) ** 2)) * vt / math.hypot(
            vt, v0)
        assert friction_force_slots(vt, fn, slots, law) == pytest.approx(ref, rel=1e-14)
    assert friction_force_slots(1e-4, fn, slots, law) == pytest.approx(-mu_s * fn, rel=1e-3)
    # the regularised sign at 0.1 m/s is 1 - 5e-11
    assert friction_force_slots(-0.1, fn, slots, law) == pytest.approx(mu * fn, rel=1e-9)
    same = _slots(friction_coefficient=mu, friction_static_coefficient=mu, friction_v0=v0)
    for vt in SLIPS:
        assert friction_force_slots(vt, fn, same, law) == pytest.approx(
            friction_force_slots(vt, fn, same, FRICTION_LAWS["coulomb"]), rel=1e-15)


def test_stribeck_needs_the_static_coefficient_at_least_the_dynamic():
    """mu_s < mu_d with the Stribeck law fails when the description is built, naming both;
    other laws ignore the static coefficient."""
    with pytest.raises(ValueError, match="friction_static_coefficient must be >= "
                                         "friction_coefficient = 0.1"):
        cases.paper_slider_crank(friction_law="stribeck", friction_coefficient=0.1)
    cases.paper_slider_crank(friction_law="coulomb", friction_coefficient=0.1)
