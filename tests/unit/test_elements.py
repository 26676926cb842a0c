"""The joint kinds as elements (`mbs_clearance.elements`): every registered kind brings every
piece the generator and the Exudyn backend ask for, an unknown kind is refused in one line
naming the allowed kinds, and the translational element's pieces agree with the description
and with closed forms. Nothing is compiled or integrated."""

from __future__ import annotations

import dataclasses

import pytest

from mbs_clearance.backends.exudyn_linkage import _Side
from mbs_clearance.elements import ELEMENTS, KINDS, PIECES, Element, element
from mbs_clearance.elements.translational import corner_loads
from mbs_clearance.generate.derive import parameter_layout
from mbs_clearance.model.cases import CASES
from mbs_clearance.model.linkage import CORNERS, GROUND, Linkage


@pytest.mark.parametrize("el", ELEMENTS, ids=lambda el: el.kind)
def test_every_registered_kind_brings_every_piece(el):
    assert isinstance(el, Element) and KINDS[el.kind] is el and element(el.kind) is el
    assert dataclasses.is_dataclass(el.description)
    assert el.attribute in {f.name for f in dataclasses.fields(Linkage)}
    missing = [hook for hooks in PIECES.values() for hook in hooks
               if getattr(type(el), hook, None) is getattr(Element, hook, None)
               or not callable(getattr(el, hook, None))]
    assert missing == [], f"element {el.kind!r} lacks {missing}"


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


def test_a_linkage_without_the_kind_gets_nothing_from_its_element():
    link = CASES["paper_slider_crank"]()
    for el in ELEMENTS:
        assert el.joints(link) == () and el.contact_names(link) == []
        assert el.parameter_names(link) == [] and el.memory_names(link) == []


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


#: the modules that iterate over the registry instead of naming a kind
ITERATING = ("generate/derive.py", "generate/writer.py", "generate/cwriter.py",
             "generate/jacobians.py", "generate/cjacobians.py", "generate/energy.py",
             "solve/linkage_model.py", "solve/linkage_ddm.py",
             "backends/exudyn_linkage.py", "backends/ideal_linkage.py")


@pytest.mark.parametrize("module", ITERATING)
def test_the_generator_and_the_backends_name_no_element_kind(module):
    """Read from the sources: no module that iterates over the registry reaches for an
    element's joints, corners or description class itself."""
    from pathlib import Path

    import mbs_clearance

    text = (Path(mbs_clearance.__file__).parent / module).read_text()
    names = [n for el in ELEMENTS for n in (el.attribute, el.description.__name__)]
    names += ["corner_names", "CORNERS"]        # the translational joint's corners
    assert [n for n in names if n in text] == []
