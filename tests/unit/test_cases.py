"""The named cases (mbs_clearance.model.cases): each builds, its overrides work and bad ones fail
with a clear ValueError, the four-bar is a Grashof crank-rocker, and the assembly guesses
at t = 0 are the closed loop of the hand-written ideal reference (validation.ideal_linkage)."""

import math

import numpy as np
import pytest

from mbs_clearance import Linkage, SliderCrank
from mbs_clearance.backends.ideal import ideal_outputs as paper_ideal
from mbs_clearance.model.cases import (
    CASE_PARAMETERS,
    CASES,
    four_bar,
    paper_slider_crank,
    slider_crank_two_clearances,
)
from validation.ideal_linkage import from_linkage, grashof_type, ideal_outputs


def world(o, loop_names, body, point, linkage):
    """World position at sample 0 of a body-frame point, from the reference's body pose."""
    if body == "ground":
        return np.asarray(linkage.ground_points[point], float)
    i = loop_names.index(body)
    phi = o["angles"][0, i]
    p = dict(linkage.bodies[[b.name for b in linkage.bodies].index(body)].points)[point]
    c, s = math.cos(phi), math.sin(phi)
    return o["centres"][0, i] + np.array([c * p[0] - s * p[1], s * p[0] + c * p[1]])


def body_order(linkage):
    loop = from_linkage(linkage)
    pins = {j.name: j for j in (*linkage.joints, *linkage.clearance_joints)}
    drive = pins[loop.joints[0]]
    crank = drive.body_b
    b = pins[loop.joints[1]]
    ends = {getattr(b, k) for k in ("body_a", "body_b", "journal_body", "bearing_body")
            if hasattr(b, k)}
    coupler = (ends - {crank}).pop()
    c = pins[loop.joints[2]]
    ends = {getattr(c, k) for k in ("body_a", "body_b", "journal_body", "bearing_body")
            if hasattr(c, k)}
    return loop, (crank, coupler, (ends - {coupler}).pop())


@pytest.mark.parametrize("name", sorted(CASES))
def test_each_case_builds_with_its_documented_defaults(name):
    linkage = CASES[name]()
    assert isinstance(linkage, Linkage)
    assert linkage.name == name
    n_q = {"paper_slider_crank": 2, "paper_slider_crank_lubricated": 2,
           "paper_slider_crank_wear": 2,
           "slider_crank_two_clearances": 4, "four_bar": 2,
           "flores_translational_slider_crank": 3}[name]
    assert len(linkage.coordinates()) == n_q
    if name in CASE_PARAMETERS:
        table = CASE_PARAMETERS[name]
        if linkage.drive is None:           # a free case starts at its table's rates
            assert linkage.initial.rates["crank.angle"] == table["crank_rate"][0]
        else:
            assert linkage.drive.speed == table["crank_speed"][0]
        assert linkage.gravity == table["gravity"][0]
        for cj in linkage.clearance_joints:
            assert cj.bearing_radius == table["bearing_radius"][0]
        masses = {b.name: b.mass for b in linkage.bodies}
        assert masses["crank"] == table["crank_mass"][0]
        assert masses["coupler"] == table["coupler_mass"][0]


def test_two_clearance_case_has_both_coupler_joints_loose():
    linkage = slider_crank_two_clearances()
    loose = {frozenset((j.journal_body, j.bearing_body)): j for j in linkage.clearance_joints}
    assert set(loose) == {frozenset(("crank", "coupler")), frozenset(("coupler", "slider"))}
    # the coupler has no ideal joint: it floats
    assert not [j for j in linkage.joints if "coupler" in (j.body_a, j.body_b)]
    assert {"coupler.x", "coupler.y", "coupler.angle"} <= set(linkage.coordinates())
    # same mechanism as the paper's (Table 1, Flores & Ambrosio's crank)
    paper = SliderCrank()
    pts = {b.name: b for b in linkage.bodies}
    assert pts["crank"].mass == paper.crank_mass and pts["slider"].mass == paper.slider_mass
    assert pts["coupler"].inertia == pytest.approx(paper.coupler_inertia_value, rel=1e-15)


def test_overrides_change_only_what_they_name():
    base = slider_crank_two_clearances()
    one = slider_crank_two_clearances(crank_coupler_clearance=5e-5)
    by = {j.name: j for j in one.clearance_joints}
    assert by["crank_coupler"].clearance == pytest.approx(5e-5, rel=1e-9)
    assert by["coupler_slider"].clearance == pytest.approx(1e-5, rel=1e-9)
    assert one.replace(clearance_joints=base.clearance_joints) == base
    fast = four_bar(crank_speed=20.0, clearance=1e-7, coupler_mass=2.0)
    assert fast.drive.speed == 20.0
    assert fast.clearance_joints[0].clearance == pytest.approx(1e-7, rel=1e-8)
    coupler = {b.name: b for b in fast.bodies}["coupler"]
    assert coupler.mass == 2.0
    assert coupler.inertia == pytest.approx(2.0 * 4.0 ** 2 / 12, rel=1e-15)   # m L^2 / 12
    assert four_bar(coupler_inertia=0.5).bodies[1].inertia == 0.5
    assert paper_slider_crank(journal_radius=0.00995).clearance_joints[0].clearance == \
        pytest.approx(5e-5, rel=1e-9)


@pytest.mark.parametrize("case, kwargs, match", [
    (four_bar, {"clerance": 1e-4}, r"unknown override\(s\) \['clerance'\]; allowed: .*clearance"),
    (four_bar, {"crank_mass": -1.0}, r"crank_mass must be > 0 kg"),
    (four_bar, {"clearance": 0.0}, r"clearance must be > 0 m"),
    (four_bar, {"clearance": 0.07}, r"clearance must be smaller than bearing_radius"),
    (four_bar, {"crank_speed": float("nan")}, r"crank_speed must be a finite number in rad/s"),
    (four_bar, {"gravity": "9.81"}, r"gravity must be a finite number"),
    (four_bar, {"crank_length": 2.8}, r"not a Grashof crank-rocker"),
    (four_bar, {"ground_length": 0.9}, r"not a Grashof crank-rocker"),
    (four_bar, {"restitution": 1.5}, r"restitution"),
    (four_bar, {"contact_model": "nope"}, r"contact_model must be one of"),
    (slider_crank_two_clearances, {"coupler_length": 0.04},
     r"coupler_length must exceed crank_length"),
    (slider_crank_two_clearances, {"coupler_slider_clearance": 0.02},
     r"coupler_slider_clearance must be smaller than bearing_radius"),
    (slider_crank_two_clearances, {"slider_mass": 0}, r"slider_mass must be > 0 kg"),
    (slider_crank_two_clearances, {"crank_inertia": None},
     r"crank_inertia must be a finite number"),
])
def test_bad_overrides_fail_with_clear_errors(case, kwargs, match):
    with pytest.raises(ValueError, match=match):
        case(**kwargs)


def test_four_bar_is_a_grashof_crank_rocker_driven_at_the_crank():
    """Link lengths measured from the description's points (not from the case's table)."""
    linkage = four_bar()
    loop, names = body_order(linkage)
    o = ideal_outputs(loop, np.array([0.0]))

    def dist(p, q):
        return float(np.hypot(*(np.subtract(q, p))))

    lengths = dict(ground=dist(loop.ground_crank, loop.ground_rocker),
                   crank=dist(loop.crank.p, loop.crank.q),
                   coupler=dist(loop.coupler.p, loop.coupler.q),
                   rocker=dist(loop.rocker.p, loop.rocker.q))
    assert grashof_type(lengths) == "crank-rocker"
    assert names[0] == {j.name: j for j in linkage.joints}[linkage.drive.joint].body_b
    # the crank turns fully: the loop closes at every crank angle (reference raises if not),
    # and the rocker swings between two extremes without turning over
    t = np.linspace(0.0, linkage.period, 3601)
    rocker = ideal_outputs(loop, t)["angles"][:, 2]
    assert np.ptp(rocker) < math.pi
    assert o["angles"][0, 0] == pytest.approx(math.pi / 2)


@pytest.mark.parametrize("name", sorted(n for n in CASES if CASES[n]().drive is not None))
def test_assembly_at_t0_closes_every_loop(name):
    """The ideal reference's pose at t = 0 (analytic closure) puts every clearance joint's
    journal point on its bearing point (centred journals), and the case's assembly guesses
    are that pose (same branch)."""
    linkage = CASES[name]()
    loop, names = body_order(linkage)
    o = ideal_outputs(loop, np.array([0.0]))
    for cj in linkage.clearance_joints:
        gap = (world(o, names, cj.journal_body, cj.journal_point, linkage)
               - world(o, names, cj.bearing_body, cj.bearing_point, linkage))
        assert np.hypot(*gap) < 1e-14
    for j in linkage.joints:
        if type(j).__name__ == "Revolute":
            gap = (world(o, names, j.body_a, j.point_a, linkage)
                   - world(o, names, j.body_b, j.point_b, linkage))
            assert np.hypot(*gap) < 1e-14
    for key, guess in linkage.assembly.items():
        body, _, coord = key.rpartition(".")
        if coord == "angle":
            assert guess == pytest.approx(o["angles"][0, names.index(body)], abs=1e-12), key
        elif coord == "s":
            assert guess == pytest.approx(o["slider_position"][0], abs=1e-15), key
        else:                                   # centre of mass of a floating body
            xy = o["centres"][0, names.index(body)]
            assert guess == pytest.approx(xy["xy".index(coord)], abs=1e-15), key


def test_paper_case_reference_through_the_description_matches_the_closed_form(paper):
    """The reference read from the paper case's description (from_linkage) gives the
    paper's closed-form ideal outputs (mbs_clearance.backends.ideal), to rounding."""
    loop = from_linkage(paper_slider_crank())
    t = np.linspace(0.0, paper.period, 721)
    o, p = ideal_outputs(loop, t), paper_ideal(paper, t)
    scale = np.max(np.abs(p["base_force"]))
    assert np.max(np.abs(o["ground_reactions"]["crank_pivot"] - p["base_force"])) < 1e-12 * scale
    assert np.max(np.abs(o["drive_moment"] - p["crank_moment"])) < 1e-11 * np.max(
        np.abs(p["crank_moment"]))


@pytest.mark.parametrize("name", sorted(CASES))
def test_case_description_round_trips_through_json(name, tmp_path):
    import json

    linkage = CASES[name]()
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(linkage.to_dict()))
    assert Linkage.from_file(path) == linkage


def test_cases_start_with_every_journal_centred():
    """The glue's initial state (Newton on the generated closure) is the ideal reference's
    pose at t = 0: coordinates to 1e-12, rates to 1e-9 relative."""
    from mbs_clearance.generate import load_model
    from mbs_clearance.solve.linkage_model import initial_state, pack_parameters
    from validation.ideal_linkage import from_linkage, ideal_outputs

    for lk in (four_bar(), slider_crank_two_clearances()):
        model = load_model(lk)
        p = pack_parameters(lk, model)
        y0 = initial_state(lk, model, p)
        assert np.max(np.abs(model.closure(0.0, y0[:model.N_Q], p))) < 1e-14
        ref = ideal_outputs(from_linkage(lk), np.array([0.0]))
        names = ("crank", "coupler", "rocker" if lk.name == "four_bar" else "slider")
        for k, c in enumerate(model.COORDINATES):
            body, _, coord = c.rpartition(".")
            if coord == "angle":
                i = names.index(body)
                assert y0[k] == pytest.approx(ref["angles"][0, i], abs=1e-12)
                assert y0[model.N_Q + k] == pytest.approx(ref["rates"][0, i], rel=1e-9,
                                                          abs=1e-9 * lk.drive.speed)
            elif coord in ("x", "y"):
                i = names.index(body)
                assert y0[k] == pytest.approx(ref["centres"][0, i, "xy".index(coord)],
                                              abs=1e-14)
            else:
                assert y0[k] == pytest.approx(ref["slider_position"][0], abs=1e-14)
        assert math.isfinite(y0[-1]) and y0[-1] == 0.0
