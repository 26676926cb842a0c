"""Friction in the clearance joints (issue 18): description fields and their validation."""

from __future__ import annotations

import pytest

from mbs_clearance import SliderCrank, cases
from mbs_clearance.contact import FRICTION_LAWS
from mbs_clearance.linkage import ClearanceJoint


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
    (dict(friction_law="stribeck"), r"friction_law must be one of \['ambrosio', 'coulomb', "
                                    r"'none'\]"),
])
def test_friction_fields_are_validated(kw, match):
    with pytest.raises(ValueError, match=match):
        _joint(**kw)
    with pytest.raises(ValueError, match=match):
        SliderCrank(**kw)
    with pytest.raises(ValueError, match=match):
        cases.slider_crank_two_clearances(**kw)
    assert sorted(FRICTION_LAWS) == ["ambrosio", "coulomb", "none"]


def test_friction_overrides_reach_every_joint():
    lk = cases.slider_crank_two_clearances(friction_law="coulomb", friction_coefficient=0.05)
    assert all(j.friction_law == "coulomb" and j.friction_coefficient == 0.05
               for j in lk.clearance_joints)
    lk = cases.four_bar(friction_law="ambrosio", friction_v0=1e-3, friction_v1=1e-1)
    assert lk.clearance_joints[0].friction_v1 == 1e-1
