"""The joint kinds as elements (`mbs_clearance.elements`): every registered kind brings every
piece it declares (the layers that ask for a piece iterate over the elements that bring it),
an unknown kind is refused in one line naming the allowed kinds, and the revolute and
translational elements' pieces agree with the description and with closed forms. Only the
revolute contact's check evaluates a (shipped, compiled) model; nothing is integrated."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from mbs_clearance.backends.exudyn_linkage import _Side
from mbs_clearance.elements import ELEMENTS, KINDS, PIECES, Element, element
from mbs_clearance.elements.registry import elements_with
from mbs_clearance.elements.translational import corner_loads
from mbs_clearance.generate.derive import parameter_layout
from mbs_clearance.model.cases import CASES
from mbs_clearance.model.linkage import CORNERS, GROUND, Linkage
from mbs_clearance.solve.linkage_model import initial_state, load_model, pack_parameters


@pytest.mark.parametrize("el", ELEMENTS, ids=lambda el: el.kind)
def test_every_registered_kind_brings_every_piece(el):
    assert isinstance(el, Element) and KINDS[el.kind] is el and element(el.kind) is el
    assert dataclasses.is_dataclass(el.description)
    assert el.attribute in {f.name for f in dataclasses.fields(Linkage)}
    assert el.pieces and set(el.pieces) <= set(PIECES)
    missing = [hook for piece in el.pieces for hook in PIECES[piece]
               if getattr(type(el), hook, None) is getattr(Element, hook, None)
               or not callable(getattr(el, hook, None))]
    assert missing == [], f"element {el.kind!r} lacks {missing}"
    for piece in PIECES:
        assert (el in elements_with(piece)) == (piece in el.pieces)


def test_the_revolute_element_comes_first_and_every_element_brings_every_piece():
    """The clearance joints' contacts come first in every layout; every registered
    clearance element brings every piece, its Exudyn element included (the backend builds
    no kind itself)."""
    assert ELEMENTS[0] is element("revolute")
    for el in ELEMENTS:
        assert el.pieces == tuple(PIECES)
    assert elements_with("Exudyn element") == ELEMENTS
    with pytest.raises(ValueError, match="unknown piece 'gap'; allowed: "):
        elements_with("gap")


@pytest.mark.parametrize("kind", ["helical", "", None, 3])
def test_an_unknown_kind_is_refused_in_one_line_naming_the_allowed(kind):
    with pytest.raises(ValueError) as err:
        element(kind)
    text = str(err.value)
    assert "\n" not in text and repr(kind) in text
    assert all(repr(k) in text for k in KINDS)


def test_the_base_refuses_a_missing_piece_by_name():
    class Half(Element):
        kind = "half"

    with pytest.raises(NotImplementedError, match="'half' has no 'contact_names'"):
        Half().contact_names(CASES["flores_translational_slider_crank"]())


def test_contacts_and_layout_of_the_translational_element_match_the_description():
    """The element's contacts are the description's contacts after the clearance joints',
    its parameters one block of the model's parameter vector and its memory the last
    entries (`parameter_layout`)."""
    link = CASES["flores_translational_slider_crank"]()
    el = element("translational")
    names = [n for n, _ in link.contacts()][len(link.clearance_joints):]
    assert el.contact_names(link) == names and len(names) == 4 * len(link.translational_joints)
    layout = list(parameter_layout(link))
    block = el.parameter_names(link)
    start = layout.index(block[0])
    assert layout[start:start + len(block)] == block
    memory = el.memory_names(link)
    assert layout[-len(memory):] == memory
    assert memory == [f"{c}.{f}" for c in names for f in ("mode", "impact_velocity")]


def _second_joint_lubricated():
    link = CASES["slider_crank_two_clearances"]()
    first, second = link.clearance_joints
    return link.replace(clearance_joints=(first, dataclasses.replace(
        second, lubrication="short", friction_law="none")))


@pytest.mark.parametrize("make", [CASES["paper_slider_crank_lubricated"],
                                  CASES["slider_crank_two_clearances"],
                                  _second_joint_lubricated],
                         ids=["lubricated", "two_clearances", "second_lubricated"])
def test_contacts_and_layout_of_the_revolute_element_match_the_description(make):
    """The revolute element's contacts are the clearance joints, first among the contacts
    and in their order whichever is lubricated (the film is a variant of the joint's
    contact); its parameters one block of the parameter vector after the bodies', ground
    points' and prismatic axes' (contact fields, then the friction's, then the film's), its
    memory the first memory entries."""
    link = make()
    el = element("revolute")
    names = [j.name for j in link.clearance_joints]
    assert el.contact_names(link) == names == [n for n, _ in link.contacts()][:len(names)]
    layout = list(parameter_layout(link))
    block = el.parameter_names(link)
    start = layout.index(block[0])
    assert layout[start:start + len(block)] == block
    assert layout[start - 1].endswith((".x", ".y", ".angle"))
    assert block[:5 * len(names)] == [f"{n}.{f}" for n in names for f in (
        "clearance", "stiffness", "restitution", "contact_model", "impact_velocity_floor")]
    lubricated = [j.name for j in link.clearance_joints if j.has_lubrication]
    assert [b.partition(".")[0] for b in block if b.endswith(".viscosity")] == lubricated
    memory = el.memory_names(link)
    first = layout.index(f"{names[0]}.mode")
    assert layout[first:first + len(memory)] == memory
    assert memory == [f"{n}.{f}" for n in names for f in ("mode", "impact_velocity")]
    assert el.floor_names(link) == [f"{n}.impact_velocity_floor" for n in names]
    values = el.parameter_values(link)
    assert set(block + memory) <= set(values)
    for j in link.clearance_joints:
        assert values[f"{j.name}.clearance"] == j.bearing_radius - j.journal_radius
        assert values[f"{j.name}.impact_velocity"] == j.impact_velocity_floor


def test_the_revolute_chain_of_a_radius_is_the_clearance_and_eq9():
    """The bearing radius reaches the clearance (d 1) and the Eq. 9 stiffness: its chain
    against a central difference of `ClearanceJoint.stiffness`; a given stiffness has none."""
    link = CASES["paper_slider_crank"]()
    el, cj = element("revolute"), link.clearance_joints[0]
    via = el.chain(link, cj.name, "bearing_radius")
    h = 1e-6 * cj.clearance
    up = dataclasses.replace(cj, bearing_radius=cj.bearing_radius + h).stiffness
    down = dataclasses.replace(cj, bearing_radius=cj.bearing_radius - h).stiffness
    assert via[f"{cj.name}.clearance"] == 1.0
    assert via[f"{cj.name}.stiffness"] == pytest.approx((up - down) / (2 * h), rel=1e-6)
    given = dataclasses.replace(cj, contact_stiffness=1e9)
    link = link.replace(clearance_joints=(given,))
    assert el.chain(link, cj.name, "youngs_modulus") == {f"{cj.name}.stiffness": 0.0}
    assert el.chain(link, cj.name, "contact_stiffness") == {f"{cj.name}.stiffness": 1.0}
    assert el.chain(link, "nobody", "bearing_radius") == {}
    assert el.fd_scale(link, cj.name, "journal_radius") == cj.clearance
    assert el.fd_scale(link, cj.name, "restitution") is None


@pytest.mark.parametrize("restitution", [1.0, 0.9], ids=["hertz", "lankarani_nikravesh"])
def test_the_revolute_contact_force_at_a_given_penetration_is_the_closed_form(restitution):
    """The paper case's compiled model with its slider moved by c + delta from the centred
    start: the journal penetrates delta = |e| - c (from the offsets, not the contact stage)
    at the rate e . e_dot / |e| (from the gap function), and in contact since an impact at
    v0 the joint's force is Lankarani-Nikravesh's K delta^1.5 (1 + 3 (1 - e^2) / 4 *
    deltadot / v0), Hertz's K delta^1.5 at restitution 1."""
    link = CASES["paper_slider_crank"]()
    model = load_model(link)
    p = pack_parameters(link, model)
    p[model.PARAMETERS.index("coupler_slider.restitution")] = restitution
    model.prepare(p)
    y = initial_state(link, model, p).copy()
    cj = link.clearance_joints[0]
    c, K, delta, v0 = cj.clearance, cj.stiffness, 0.3 * cj.clearance, 0.5
    y[model.COORDINATES.index("slider_guide.s")] += c + delta
    out = model.outputs([0.0], y[None, :], np.array([[1.0, v0]]), p)[0]
    col = {name: k for k, name in enumerate(model.OUT_COLUMNS)}
    ex, ey, exd, eyd = model.gap(0.0, y, p, 0)
    r = math.hypot(ex, ey)
    assert out[col["coupler_slider.ecc_x"]] == ex and out[col["coupler_slider.ecc_y"]] == ey
    pen, rate = out[col["coupler_slider.penetration"]], out[col["coupler_slider.penetration_rate"]]
    assert pen == pytest.approx(r - c, rel=1e-9) and pen == pytest.approx(delta, rel=1e-6)
    assert rate == pytest.approx((ex * exd + ey * eyd) / r, rel=1e-9)
    expected = K * pen ** 1.5 * (1.0 + 0.75 * (1.0 - restitution ** 2) * rate / v0)
    assert out[col["coupler_slider.contact_force"]] == pytest.approx(expected, rel=1e-9)
    if restitution == 1.0:
        assert out[col["coupler_slider.contact_force"]] == pytest.approx(K * delta ** 1.5,
                                                                          rel=1e-5)


@pytest.mark.parametrize("case, kind", [("paper_slider_crank", "translational"),
                                        ("flores_translational_slider_crank", "revolute")])
def test_a_linkage_without_the_kind_gets_nothing_from_its_element(case, kind):
    link = CASES[case]()
    el = element(kind)
    assert el.joints(link) == () and el.contact_names(link) == []
    assert el.parameter_names(link) == [] and el.memory_names(link) == []
    assert el.parameter_values(link) == {} and el.floor_names(link) == []
    assert el.closure_rows(link, None, None) == ([], [])


def test_corner_loads_of_a_slider_pressed_into_the_top_surface_are_hertz():
    """A level slider (axis along x, guide on the ground along x) lifted by c + delta: both
    top corners penetrate delta, the bottom ones are free; at rest each top corner pushes
    with K delta^1.5 (the hysteresis term vanishes at zero rate), so the slider gets
    -2 K delta^1.5 along y and no moment (the corners are symmetric about its centre)."""
    link = CASES["flores_translational_slider_crank"]()
    joint = link.translational_joints[0]
    assert joint.guide_body == GROUND
    c, K = joint.clearance, joint.stiffness
    delta = 0.2 * c
    slider = _Side(0, [0.0, c + delta, -joint.slider_angle], (0.0, 0.0), None)
    guide = _Side(None, None, (0.0, 0.0), (0.0, 0.0))
    joint = dataclasses.replace(joint, angle=0.0)
    out, series = corner_loads(joint, (slider, guide), [0.0] * 3, [0.0] * 3,
                               [joint.impact_velocity_floor] * 4)
    tops = [k for k, (_, side) in enumerate(CORNERS.values()) if side > 0]
    for k, row in enumerate(series):
        if k in tops:
            assert row[1] == pytest.approx(delta, rel=1e-9)
            assert row[0] == pytest.approx(K * delta ** 1.5, rel=1e-9)
        else:
            assert row[1] == pytest.approx(-(2 * c + delta), rel=1e-9) and row[0] == 0.0
    assert out[0] == pytest.approx(0.0, abs=1e-9 * K * delta ** 1.5)
    assert out[1] == pytest.approx(-2 * K * delta ** 1.5, rel=1e-9)
    assert out[2] == pytest.approx(0.0, abs=1e-9 * K * delta ** 1.5 * joint.half_length)


#: the modules that iterate over the registry instead of naming a kind, with the piece
#: they ask of it (a module names no kind that brings its piece)
ITERATING = {
    "generate/derive.py": "gap function and loads", "generate/writer.py": "C printer",
    "generate/cwriter.py": "C printer", "generate/jacobians.py":
    "Jacobian rows and tangent terms", "generate/cjacobians.py": "C printer",
    "generate/energy.py": "energy",
    "solve/linkage_model.py": "reduced model's parameters and sensitivities",
    "solve/linkage_ddm.py": "reduced model's parameters and sensitivities",
    "backends/exudyn_linkage.py": "Exudyn element",
    "backends/ideal_linkage.py": "ideal joint"}


@pytest.mark.parametrize("module", ITERATING)
def test_the_generator_and_the_backends_name_no_element_kind(module):
    """Read from the sources: no module that iterates over the registry reaches for the
    joints, corners or description class of an element that brings its piece."""
    from pathlib import Path

    import mbs_clearance

    text = (Path(mbs_clearance.__file__).parent / module).read_text()
    names = [n for el in elements_with(ITERATING[module])
             for n in (el.attribute, el.description.__name__)]
    names += ["corner_names", "CORNERS"]        # the translational joint's corners
    # the revolute joint's bodies and variants
    names += ["journal_body", "bearing_body", "has_lubrication", "profile is"]
    assert [n for n in names if n in text] == []


@pytest.mark.exudyn
def test_the_exudyn_backend_builds_both_kinds_through_their_elements():
    """A linkage with a revolute clearance joint (with friction) and a translational one,
    built by the Exudyn backend from a state where the journal penetrates its bearing by
    1e-7 m and the slider's top corners the guide by 1e-6 m: every contact has its own
    impact-velocity memory in the description's contact order, the first step's pre-step
    function registers contact for exactly the penetrating contacts, and the elements'
    series give back the penetrations set up by plane geometry."""
    pytest.importorskip("exudyn")
    from mbs_clearance.backends import exudyn_linkage as xl

    flores = CASES["flores_translational_slider_crank"]()
    cj = dataclasses.replace(CASES["paper_slider_crank"]().clearance_joints[0],
                             name="crank_coupler", journal_body="coupler",
                             journal_point="crank_end", bearing_body="crank",
                             bearing_point="pin", friction_law="coulomb",
                             friction_coefficient=0.1)
    link = flores.replace(joints=tuple(j for j in flores.joints if j.name != "crank_coupler"),
                          clearance_joints=(cj,))
    guide = link.translational_joints[0]
    bodies = {b.name: b for b in link.bodies}
    l1 = 2.0 * bodies["crank"].points["pin"][0]
    l2 = 2.0 * bodies["coupler"].points["slider_end"][0]
    d_joint, d_guide = 1e-7, 1e-6
    # slider centre (on the coupler's end) lifted by c + d_guide, the crank pin below the
    # coupler's end by the joint's clearance + d_joint
    lift = guide.clearance + d_guide
    theta = math.asin((lift - cj.clearance - d_joint) / l1)
    q = {"crank.angle": theta, "slider.angle": 0.0, "coupler.x": l1 * math.cos(theta) + l2 / 2,
         "coupler.y": lift, "coupler.angle": 0.0}
    names = link.coordinates()
    y0 = np.zeros(2 * len(names) + 1)
    y0[:len(names)] = [q[n] for n in names]
    model = xl.build(link, xl.ExudynSettings(step_size=1e-7), y0=y0)
    contacts = [n for n, _ in link.contacts()]
    assert set(model.elements) == {el.kind for el in ELEMENTS}
    assert [m.name for m in model.memories] == contacts
    xl.solve(model, 2e-7)
    touching = {"crank_coupler", "guide.front_top", "guide.rear_top"}
    assert {m.name for m in model.memories if m.mode == 1} == touching
    series = xl._element_series(model)
    penetration = [p[0] for part in series for p in part.penetration]
    expected = [d_joint if n == "crank_coupler" else d_guide if n in touching
                else -(2 * guide.clearance + d_guide) for n in contacts]
    assert penetration == pytest.approx(expected, rel=1e-6, abs=1e-12)
