"""SliderCrank: defaults from the paper, derived values, validation of bad input."""

import json
import math

import numpy as np
import pytest

from mbs_clearance import SliderCrank
from mbs_clearance.laws.forces import stiffness_eq9, stiffness_eq9_partials


def test_defaults_are_the_paper_case(paper):
    assert (paper.crank_length, paper.coupler_length) == (0.05, 0.12)
    assert (paper.crank_mass, paper.coupler_mass, paper.slider_mass) == (0.30, 0.21, 0.14)
    assert paper.clearance == pytest.approx(1e-5, rel=1e-9)
    assert paper.crank_speed_rpm == pytest.approx(5000.0)
    # uniform thin rod coupler agrees with Flores' 0.00025 kg m^2 to 1 %
    assert paper.coupler_inertia_value == pytest.approx(0.00025, rel=0.01)


def test_stiffness_eq9_closed_form(paper):
    # Eq. 9 with equal materials reduces to K = 2E / (3 (1 - nu^2)) sqrt(R_J R_B / c)
    E, nu, rj, rb = 207e9, 0.3, 0.00999, 0.01
    expected = 2 * E / (3 * (1 - nu**2)) * math.sqrt(rj * rb / (rb - rj))
    assert paper.stiffness == pytest.approx(expected, rel=1e-12)
    assert SliderCrank(contact_stiffness=1e10).stiffness == 1e10


@pytest.mark.parametrize("index,arg", [(1, 0.00999), (2, 0.01), (3, 207e9), (4, 0.3)])
def test_stiffness_partials_match_central_differences(index, arg):
    base = [0.00999, 0.01, 207e9, 0.3]
    h = arg * 1e-6
    up, dn = list(base), list(base)
    up[index - 1] += h
    dn[index - 1] -= h
    fd = (stiffness_eq9(*up) - stiffness_eq9(*dn)) / (2 * h)
    assert stiffness_eq9_partials(*base)[index] == pytest.approx(fd, rel=1e-6)


def test_replace_validates_and_rejects_unknown_names(paper):
    assert paper.replace(crank_length=0.04).crank_length == 0.04
    with pytest.raises(ValueError, match="unknown parameter name.*crank_lenght"):
        paper.replace(crank_lenght=0.04)


BAD = [
    ("crank_length", -0.05, "crank_length must be a finite number > 0"),
    ("crank_length", 0.0, "crank_length must be a finite number > 0"),
    ("coupler_mass", -1.0, "coupler_mass must be a finite number > 0"),
    ("slider_mass", float("nan"), "slider_mass must be a finite number > 0"),
    ("crank_mass", float("inf"), "crank_mass must be a finite number > 0"),
    ("crank_speed", 0.0, "crank_speed must be a finite number > 0"),
    ("journal_radius", 0.011, r"journal_radius must be smaller than bearing_radius"),
    ("journal_radius", 0.01, r"journal_radius must be smaller than bearing_radius"),
    ("restitution", 0.0, r"restitution must be in the interval \(0, 1\]"),
    ("restitution", 1.2, r"restitution must be in the interval \(0, 1\]"),
    ("poisson_ratio", 0.5, r"poisson_ratio must be in the open interval \(-1, 0.5\)"),
    ("poisson_ratio", -1.0, r"poisson_ratio must be in the open interval \(-1, 0.5\)"),
    ("youngs_modulus", -1.0, "youngs_modulus must be a finite number > 0"),
    ("contact_stiffness", 0.0, "contact_stiffness must be None or a finite number > 0"),
    ("coupler_inertia", -1e-4, "coupler_inertia must be None or a finite number > 0"),
    ("gravity", float("nan"), "gravity must be a finite number"),
    ("initial_crank_angle", float("inf"), "initial_crank_angle must be a finite number"),
    ("contact_model", "hertz", "contact_model must be one of"),
    ("coupler_length", 0.04, "coupler_length must be greater than crank_length"),
    ("crank_length", "0.05", "crank_length must be a finite number > 0"),
    ("restitution", True, r"restitution must be in the interval"),
]


@pytest.mark.parametrize("field,value,message", BAD)
def test_bad_values_raise_value_error_naming_field_and_range(field, value, message):
    with pytest.raises(ValueError, match=message):
        SliderCrank(**{field: value})


def test_numpy_scalars_are_accepted():
    m = SliderCrank(crank_length=np.float64(0.05), slider_mass=np.float32(0.14))
    assert m.crank_length == 0.05


def test_json_roundtrip_and_unreadable_file(tmp_path, paper):
    path = tmp_path / "m.json"
    path.write_text(json.dumps(paper.replace(restitution=0.5).to_dict()))
    assert SliderCrank.from_json(path).restitution == 0.5
    with pytest.raises(ValueError, match="cannot read mechanism file"):
        SliderCrank.from_json(tmp_path / "missing.json")
    path.write_text("{not json")
    with pytest.raises(ValueError, match="cannot read mechanism file"):
        SliderCrank.from_json(path)
    path.write_text(json.dumps({"crank_lenght": 1}))
    with pytest.raises(ValueError, match="unknown parameter name"):
        SliderCrank.from_json(path)
