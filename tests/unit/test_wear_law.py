"""Archard's law on a bearing profile (`laws.wear.archard`) and the wear life's interval
control (`studies.wear.wear_life`) against closed forms."""

import dataclasses
import math

import numpy as np
import pytest

from mbs_clearance.laws.wear.archard import ARC_POINTS_PER_CELL, pressure_weights, wear_increment
from mbs_clearance.model.cases import paper_slider_crank
from mbs_clearance.model.profile import BearingProfile
from mbs_clearance.studies.wear import CycleWear, wear_life

RB, RJ, LENGTH, K = 0.010, 0.00999, 0.01, 1e-14


def _steady(force, speed, angle, duration, n=2001, delta=2e-6):
    t = np.linspace(0.0, duration, n)
    one = np.ones(n)
    return t, force * one, delta * one, angle * one if np.isscalar(angle) else angle, speed * one


def test_a_constant_load_sliding_at_constant_speed_wears_archards_volume():
    # volume = k/H F s (Archard), s = v T; the depth in cells sums to the same volume
    profile = BearingProfile.circular(RB, 360)
    t, f, d, a, v = _steady(500.0, 0.3, 1.0, 2.0)
    depth, volume = wear_increment(profile, RJ, LENGTH, K, t, f, d, a, v)
    assert volume == pytest.approx(K * 500.0 * 0.3 * 2.0, rel=1e-12)
    cell = 2 * np.pi / 360
    assert np.sum(depth * LENGTH * profile.radii * cell) == pytest.approx(volume, rel=1e-12)
    # the elastic foundation on a circle: the load sits within acos(c / e) of the contact
    c = RB - RJ
    half = math.acos(c / (c + 2e-6))
    off = np.abs(np.angle(np.exp(1j * (profile.angles - 1.0))))
    assert np.all(depth[off > half + 1.5 * cell] == 0.0)
    assert depth[np.argmin(off)] == depth.max()
    # symmetric about the contact direction (to the grid's offset from it)
    moment = np.sum(depth * np.sin(profile.angles - 1.0))
    assert moment == pytest.approx(0.0, abs=0.02 * depth.sum())


def test_a_load_turning_round_the_joint_wears_it_uniformly():
    # the contact direction sweeps the circle at constant speed: depth = k F v T / (L R 2 pi)
    profile = BearingProfile.circular(RB, 72)
    n = 72 * 400 + 1
    t = np.linspace(0.0, 1.0, n)
    angle = 2 * np.pi * t
    depth, volume = wear_increment(profile, RJ, LENGTH, K, t, 200.0 * np.ones(n),
                                   1e-6 * np.ones(n), angle, 0.5 * np.ones(n))
    expect = K * 200.0 * 0.5 * 1.0 / (LENGTH * RB * 2 * np.pi)
    assert np.allclose(depth, expect, rtol=2e-3)


def test_free_flight_and_the_slip_sign_count_as_archard_says():
    profile = BearingProfile.circular(RB, 90)
    t, f, d, a, v = _steady(300.0, -0.2, 0.5, 1.0)
    f[:1000] = 0.0                     # the first half in free flight: no wear
    depth, volume = wear_increment(profile, RJ, LENGTH, K, t, f, d, a, v)
    assert volume == pytest.approx(K * 300.0 * 0.2 * 0.5, rel=2e-3)


def test_a_worn_groove_conforming_to_the_journal_spreads_the_load():
    # a bearing worn locally into the journal's shape carries the same load on a wider arc
    circle = BearingProfile.circular(RB, 360)
    theta = circle.angles
    groove = BearingProfile(RB + 3e-6 * np.exp(-0.5 * (np.angle(np.exp(1j * theta)) / 0.3) ** 2))
    i_c, w_c = pressure_weights(circle, RJ, np.array([0.0]), np.array([1e-6]))
    i_g, w_g = pressure_weights(groove, RJ, np.array([0.0]), np.array([1e-6]))
    step = 2 * np.pi / (ARC_POINTS_PER_CELL * 360)
    th_c, th_g = (np.angle(np.exp(1j * step * i)) for i in (i_c, i_g))

    def spread(th, w):
        return math.sqrt(float(np.sum(w * th ** 2)))

    assert spread(th_g, w_g) > 1.3 * spread(th_c, w_c)


def _evaluator(rate_of):
    """A stand-in for the dynamics: the per-cycle depth `rate_of(depth)` on the profile."""
    def evaluate(linkage, j, coefficient):
        cj = linkage.clearance_joints[j]
        radii = np.asarray(cj.bearing_profile)
        depth = rate_of(radii - cj.bearing_radius)
        return CycleWear(depth=depth, volume=float(np.sum(depth)), sliding=1.0,
                         peak=1000.0 + 1e9 * float(np.max(radii - cj.bearing_radius)),
                         drive_rms=1.0, periodic=True)
    return evaluate


def _case():
    link = paper_slider_crank()
    cj = dataclasses.replace(link.clearance_joints[0], wear_coefficient=K)
    return link.replace(clearance_joints=(cj,))


def test_a_constant_wear_rate_grows_the_depth_linearly_in_few_intervals():
    shape = 1e-11 * (1.0 + np.cos(BearingProfile.circular(RB, 36).angles)) ** 2
    res = wear_life(_case(), 1e6, points=36, max_interval=1e6,
                    evaluate=_evaluator(lambda h: shape))
    assert res.cycles[-1] == pytest.approx(1e6)
    # the depth is a difference of radii (0.01 m): a few ulps of the radius absolute
    assert np.allclose(res.depth[-1], 1e6 * shape, rtol=1e-12, atol=1e-17)
    assert np.allclose(res.max_depth, res.cycles * shape.max(), rtol=1e-9, atol=1e-17)
    assert res.error_estimate < 1e-15        # round-off of the radii only
    assert len(res.intervals) < 15                  # doubling intervals when error-free
    # the limit crossings, linear between states
    assert res.cycles_to_clearance(1.5) == pytest.approx(0.5 * res.initial_clearance
                                                         / shape.max(), rel=1e-9)
    assert res.cycles_to_limit(1000.0 + 1e9 * 2e-6) == pytest.approx(2e-6 / shape.max(),
                                                                      rel=1e-9)


def test_a_slowing_wear_rate_meets_its_closed_form_within_the_error_estimate():
    # dh/dN = a / (1 + h / b): h(N) = b (sqrt(1 + 2 a N / b) - 1)
    a, b, n = 2e-11, 1e-6, 1e6
    errs = []
    for tolerance in (0.02, 0.005):
        res = wear_life(_case(), n, points=16, tolerance=tolerance,
                        evaluate=_evaluator(lambda h: a / (1.0 + h / b)))
        exact = b * (np.sqrt(1.0 + 2.0 * a * res.cycles / b) - 1.0)
        err = np.max(np.abs(res.depth[:, 0] - exact))
        assert 0.0 < err <= res.error_estimate
        assert np.all(res.errors <= res.tolerance * (1 + 1e-12))
        errs.append(err)
    assert errs[1] < 0.5 * errs[0]          # a quarter of the tolerance: a third of the error


def test_wear_life_refuses_bad_input_before_running():
    link = _case()
    calls = []

    def never(*args):
        calls.append(args)
        raise AssertionError("ran")

    for kw, msg in [({"cycles": 0}, "cycles must be a finite number > 0"),
                    ({"cycles": 10, "tolerance": -1}, "tolerance must be"),
                    ({"cycles": 10, "joint": "nope"}, "joint must be one of"),
                    ({"cycles": 10, "samples": 10}, "samples must be at least 64"),
                    ({"cycles": 10, "wear_coefficient": 1.0}, r"wear_coefficient must be in")]:
        with pytest.raises(ValueError, match=msg):
            wear_life(link, evaluate=never, **kw)
    with pytest.raises(ValueError, match="wear_coefficient must be in"):
        wear_life(paper_slider_crank(), 10, evaluate=never)
    assert not calls
