"""Friction in the clearance joints: description fields and their validation."""

from __future__ import annotations

import numpy as np
import pytest

from mbs_clearance import SliderCrank
from mbs_clearance.laws.forces import FRICTION_LAWS
from mbs_clearance.model import cases
from mbs_clearance.model.linkage import ClearanceJoint


def _joint(**kw):
    return ClearanceJoint("j", "a", "p", "b", "q", bearing_radius=0.01,
                          journal_radius=0.0099, **kw)


def test_friction_fields_default_to_frictionless():
    cj = _joint()
    assert cj.friction_law == "none" and cj.friction_coefficient == 0.0
    assert not cj.has_friction
    assert SliderCrank().friction_law == "none"
    lk = cases.paper_slider_crank()
    assert not any(n.endswith(("friction_coefficient", "friction_v0", "friction_v1"))
                   for n in lk.parameter_names())
    lk = cases.paper_slider_crank(friction_law="ambrosio", friction_coefficient=0.1)
    assert lk.clearance_joints[0].friction_coefficient == 0.1
    assert lk.parameter_value("coupler_slider.friction_v1") == 1e-2


@pytest.mark.parametrize("kw, match", [
    (dict(friction_coefficient=-0.1), "friction_coefficient must be a finite number >= 0"),
    (dict(friction_coefficient=float("nan")), "friction_coefficient must be"),
    (dict(friction_v0=0.0), "friction_v0 must be a finite number > 0"),
    (dict(friction_v0=0.01, friction_v1=0.01), "friction_v1 must be a finite number > "
                                               "friction_v0"),
    (dict(friction_law="dahl"), r"friction_law must be one of \['ambrosio', 'coulomb', "
                                r"'none', 'stribeck'\]"),
])
def test_friction_fields_are_validated(kw, match):
    with pytest.raises(ValueError, match=match):
        _joint(**kw)
    with pytest.raises(ValueError, match=match):
        SliderCrank(**kw)
    with pytest.raises(ValueError, match=match):
        cases.slider_crank_two_clearances(**kw)
    assert sorted(FRICTION_LAWS) == ["ambrosio", "coulomb", "none", "stribeck"]


def test_friction_overrides_reach_every_joint():
    lk = cases.slider_crank_two_clearances(friction_law="coulomb", friction_coefficient=0.05)
    assert all(j.friction_law == "coulomb" and j.friction_coefficient == 0.05
               for j in lk.clearance_joints)
    lk = cases.four_bar(friction_law="ambrosio", friction_v0=1e-3, friction_v1=1e-1)
    assert lk.clearance_joints[0].friction_v1 == 1e-1


@pytest.mark.parametrize("law, phi", [("coulomb", 0.2 / np.hypot(0.2, 0.05)),
                                      ("ambrosio", 1.0), ("none", 0.0)])
def test_friction_stage_of_a_journal_on_a_turning_bearing(law, phi):
    """The compiled models' friction stage (core/runtime.h) at a journal pressed on the
    bottom of a bearing that turns at omega (n = (0, -1), t = (1, 0), slip velocity
    edot . t - omega R_B = -0.2 m/s): the friction force on the journal mu Fn phi along t
    (dragged along by the wall), and the force on the bearing Fn n - Ft t."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from core_models import runtime_stages

    from mbs_clearance.laws import FRICTION_PARAMETER_SPECS
    from mbs_clearance.laws.forces import CONTACT_MODELS, contact_force

    c, pen, k, mu, v0, v1 = 1e-5, 1e-7, 1e10, 0.2, 0.05, 0.1
    spin = -20.0 * 0.01                 # omega_J R_J - omega_B R_B, the journal not turning
    ey, eyd = -(c + pen), -1e-4         # at the bottom, still sinking; sliding sideways:
    exd = 0.0                           # (none: the slip is the wall's)
    model = CONTACT_MODELS["lankarani_nikravesh"]
    # the law's parameters (the registry's slots; further ones at their defaults)
    given = {"friction_coefficient": mu, "friction_v0": v0, "friction_v1": v1}
    slots = tuple(given.get(p.name, p.default) for p in FRICTION_PARAMETER_SPECS)
    friction_stage = runtime_stages()[1]
    f, delta, _, fx, fy, ft, vt = friction_stage(0.0, ey, exd, eyd, spin, c, 1.0, 0.01, k,
                                                 0.9, model, FRICTION_LAWS[law], slots)
    fn = contact_force(pen, 1e-4, 0.01, k, 0.9, model)
    assert f == pytest.approx(fn, rel=1e-12) and delta == pytest.approx(pen, rel=1e-6)
    assert vt == pytest.approx(spin, rel=1e-12)
    assert ft == pytest.approx(mu * fn * phi, rel=1e-12)
    # force on the bearing: Fn n - Ft t with n = (0, -1), t = (1, 0)
    assert fx == pytest.approx(-ft, rel=1e-12, abs=1e-12 * fn)
    assert fy == pytest.approx(-fn, rel=1e-12)


def test_slider_crank_ddm_of_a_friction_field_without_a_law_is_zero():
    """A SliderCrank's DDM runs on its friction model when it has a law (checked against
    central differences in test_sensitivity.py, slow); without a law the friction fields do
    not act: their derivative is exactly zero, beside a nonzero one."""
    import numpy as np

    from mbs_clearance.analysis.sensitivity import sensitivities

    d = sensitivities(SliderCrank(), ["friction_coefficient", "crank_mass"], revolutions=1)
    assert np.all(d.base_force_magnitude[:, 0] == 0.0)
    assert np.abs(d.base_force_magnitude[:, 1]).max() > 0.0


@pytest.mark.slow
@pytest.mark.parametrize("mu, names", [(0.1, ["journal_radius", "restitution"]),
                                       (0.01, ["restitution"])])
def test_ddm_of_figs_5_6_fields_with_friction_matches_central_differences(mu, names):
    """The sensitivities of Figs. 4-6 with friction (docs/friction.md): DDM of |F12| for the
    journal radius (Fig. 6) and the restitution (Fig. 5; at mu = 0.01 its sensitivity is
    about 5 times the frictionless one) agrees with central differences of plain runs at
    rtol 1e-10 over two revolutions, Ambrosio's law (the mu = 0.05 check of mu and the
    crank length is in test_sensitivity.py)."""
    from mbs_clearance.analysis.sensitivity import sensitivities

    mech = SliderCrank(friction_law="ambrosio", friction_coefficient=mu)
    te = np.linspace(0.0, 2 * mech.period, 801)[1:]
    d = sensitivities(mech, names, revolutions=2, method="ddm", t_eval=te)
    f = sensitivities(mech, names, revolutions=2, method="fd", t_eval=te, rtol=1e-10)
    np.testing.assert_array_equal(d.t, f.t)
    for k, name in enumerate(names):
        a, b = d.base_force_magnitude[:, k], f.base_force_magnitude[:, k]
        assert np.sqrt(np.mean((a - b) ** 2)) < 5e-3 * np.sqrt(np.mean(b ** 2)), name
