"""A bearing profile (`model.profile`): the spline against closed forms, the description's
field validated and kept through a file round trip."""

import dataclasses

import numpy as np
import pytest

from mbs_clearance.model.cases import paper_slider_crank
from mbs_clearance.model.linkage import Linkage
from mbs_clearance.model.profile import MAX_POINTS, MIN_POINTS, BearingProfile


def test_a_circular_profile_is_the_circle():
    p = BearingProfile.circular(0.01, 64)
    theta = np.linspace(-7.0, 7.0, 101)
    assert np.allclose(p.radius(theta), 0.01, rtol=0, atol=1e-18)
    assert np.allclose(p.radius(theta, 1), 0.0, atol=1e-15)
    assert np.allclose(p.curvature_radius(theta), 0.01, rtol=1e-14)
    assert p.area() == pytest.approx(np.pi * 0.01 ** 2, rel=1e-14)


def test_an_ellipse_like_profile_converges_at_fourth_order_and_its_area_is_exact():
    # R(theta) = R0 + a cos(2 theta): area = pi R0^2 + pi a^2 / 2 (closed form)
    r0, a = 0.01, 2e-5
    errs = []
    for n in (16, 32, 64):
        p = BearingProfile(r0 + a * np.cos(2 * BearingProfile.circular(r0, n).angles))
        theta = np.linspace(0, 2 * np.pi, 997)
        errs.append(np.max(np.abs(p.radius(theta) - (r0 + a * np.cos(2 * theta)))))
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(rates > 3.8), rates
    assert p.area() == pytest.approx(np.pi * r0 ** 2 + np.pi * a ** 2 / 2, rel=1e-9)


def test_the_pieces_a_compiled_model_evaluates_are_the_spline():
    rng = np.random.default_rng(1)
    p = BearingProfile(0.01 + 1e-5 * rng.random(40))
    c = p.coefficients()
    h = 2 * np.pi / p.points
    for i in (0, 17, 39):
        for u in (0.0, 0.3 * h, 0.999 * h):
            assert c[i] @ [1, u, u * u, u ** 3] == pytest.approx(
                float(p.radius(p.angles[i] + u)), rel=1e-15)


def test_a_profile_is_checked_and_survives_the_description_file():
    link = paper_slider_crank()
    j = link.clearance_joints[0]
    with pytest.raises(ValueError, match=r"bearing_profile must hold 8 to 4096 radii"):
        dataclasses.replace(j, bearing_profile=[j.bearing_radius] * (MIN_POINTS - 1))
    with pytest.raises(ValueError, match=r"bearing_profile\[3\] must be a finite radius larger"):
        dataclasses.replace(j, bearing_profile=[j.bearing_radius] * 3 + [float("nan")] * 9)
    with pytest.raises(ValueError, match="a list of bearing radii"):
        dataclasses.replace(j, bearing_profile="0.01")
    assert MAX_POINTS >= 720
    worn = dataclasses.replace(j, bearing_profile=[j.bearing_radius + 1e-6] * 36)
    link2 = link.replace(clearance_joints=(worn,))
    back = Linkage.from_dict(link2.to_dict())
    assert back == link2 and back.clearance_joints[0].profile.points == 36
    assert "bearing_profile" not in link.to_dict()["clearance_joints"][0]
