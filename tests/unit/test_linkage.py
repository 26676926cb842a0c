"""The linkage description: validation, graph checks, parameters, files, the paper case."""

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from mbs_clearance.model.cases import from_slider_crank, paper_slider_crank
from mbs_clearance.model.linkage import (
    GROUND,
    Body,
    ClearanceJoint,
    Drive,
    Initial,
    Linkage,
    Prismatic,
    Revolute,
)
from mbs_clearance.model.mechanism import SliderCrank


def four_bar_like(**changes):
    """A crank-rocker four-bar with the coupler-rocker joint cut by a clearance joint."""
    kw = dict(
        name="fb",
        bodies=(Body("crank", 0.1, 1e-4, {"o": (-0.01, 0), "a": (0.01, 0)}),
                Body("coupler", 0.2, 1e-3, {"a": (-0.05, 0), "b": (0.05, 0)}),
                Body("rocker", 0.2, 1e-3, {"o": (-0.04, 0), "b": (0.04, 0)})),
        joints=(Revolute("j_o2", GROUND, "o2", "crank", "o"),
                Revolute("j_a", "crank", "a", "coupler", "a"),
                Revolute("j_o4", GROUND, "o4", "rocker", "o")),
        clearance_joints=(ClearanceJoint("j_b", "coupler", "b", "rocker", "b", 0.005,
                                         0.0049),),
        drive=Drive("j_o2", 10.0),
        ground_points={"o2": (0, 0), "o4": (0.08, 0)},
    )
    kw.update(changes)
    return Linkage(**kw)


def test_four_bar_structure():
    fb = four_bar_like()
    assert fb.coordinates() == ("coupler.angle", "rocker.angle")
    assert fb.ground_joints() == ("j_o2", "j_o4")
    tree = {b: (parent, j.name if j else None) for b, parent, j in fb.tree()}
    assert tree["crank"] == (GROUND, "j_o2") and tree["coupler"] == ("crank", "j_a")
    assert tree["rocker"] == (GROUND, "j_o4")


def test_closed_ideal_loop_names_its_joints():
    fb = four_bar_like()
    with pytest.raises(ValueError, match=r"\['j_o2', 'j_a', 'j_b_ideal'\]|closed loop") as e:
        four_bar_like(joints=(*fb.joints, Revolute("j_b_ideal", "coupler", "b", "rocker",
                                                   "b")))
    msg = str(e.value)
    for name in ("j_a", "j_o2", "j_o4", "j_b_ideal"):
        assert name in msg


def test_unknown_body_and_point():
    fb = four_bar_like()
    with pytest.raises(ValueError, match="unknown body 'cranck'"):
        four_bar_like(joints=(Revolute("j_o2", GROUND, "o2", "cranck", "o"), *fb.joints[1:]))
    with pytest.raises(ValueError, match="unknown point 'zz' of body 'rocker'"):
        four_bar_like(clearance_joints=(ClearanceJoint("j_b", "coupler", "b", "rocker", "zz",
                                                       0.005, 0.0049),))
    with pytest.raises(ValueError, match="unknown point 'o9' of body 'ground'"):
        four_bar_like(joints=(*fb.joints[:2], Revolute("j_o4", GROUND, "o9", "rocker", "o")))


def test_journal_not_smaller_than_bearing():
    with pytest.raises(ValueError, match="clearance joint 'j_b' journal_radius must be smaller"):
        ClearanceJoint("j_b", "coupler", "b", "rocker", "b", 0.005, 0.005)


def test_negative_mass_and_inertia():
    with pytest.raises(ValueError, match=r"body 'crank' mass must be a finite number > 0"):
        Body("crank", -0.1, 1e-4)
    with pytest.raises(ValueError, match=r"body 'crank' inertia must be a finite number > 0"):
        Body("crank", 0.1, math.nan)


def test_drive_must_be_a_ground_revolute():
    with pytest.raises(ValueError, match="drive joint 'j_a' must be a Revolute with body_a"):
        four_bar_like(drive=Drive("j_a", 10.0))
    with pytest.raises(ValueError, match="drive joint 'nope'.*no ideal joint"):
        four_bar_like(drive=Drive("nope", 10.0))
    fb = four_bar_like()
    with pytest.raises(ValueError, match="drive joint 'j_o2'.*Prismatic"):
        four_bar_like(joints=(Prismatic("j_o2", GROUND, "o2", "crank", "o"), *fb.joints[1:]))
    with pytest.raises(ValueError, match="drive speed must be a finite number > 0"):
        Drive("j_o2", 0.0)


def test_other_checks():
    with pytest.raises(ValueError, match="same body"):
        ClearanceJoint("c", "coupler", "b", "coupler", "a", 0.005, 0.004)
    with pytest.raises(ValueError, match="joint name 'j_a' is used twice"):
        fb = four_bar_like()
        four_bar_like(clearance_joints=(dataclasses.replace(fb.clearance_joints[0],
                                                            name="j_a"),))
    with pytest.raises(ValueError, match="at least one ClearanceJoint"):
        four_bar_like(clearance_joints=())
    with pytest.raises(ValueError, match="unknown coordinate 'crank.angle'"):
        four_bar_like(assembly={"crank.angle": 0.0})
    with pytest.raises(ValueError, match="monitor_joint"):
        four_bar_like(monitor_joint="j_a")
    with pytest.raises(ValueError, match="reserved for the ground"):
        Body(GROUND, 1.0, 1.0)
    with pytest.raises(ValueError, match="restitution must be in the interval"):
        ClearanceJoint("c", "a", "b", "c", "d", 0.005, 0.004, restitution=0.0)


def test_floating_body_coordinates():
    """Both coupler joints cut: the coupler floats (x, y, angle)."""
    lk = paper_slider_crank()
    cj = lk.clearance_joints[0]
    two = lk.replace(
        joints=(lk.joints[0], lk.joints[2]),
        clearance_joints=(cj, dataclasses.replace(cj, name="crank_coupler", journal_body="crank",
                                                  journal_point="pin", bearing_body="coupler",
                                                  bearing_point="crank_end")),
        assembly={})
    assert two.coordinates() == ("slider_guide.s", "coupler.x", "coupler.y", "coupler.angle")


def test_parameters_roundtrip():
    lk = paper_slider_crank()
    names = lk.parameter_names()
    assert "coupler.slider_end.x" in names and "coupler_slider.bearing_radius" in names
    for name in names:
        v = lk.parameter_value(name)
        new = lk.with_parameter(name, v * 1.0001 if v else 0.001)
        assert new.parameter_value(name) == pytest.approx(v * 1.0001 if v else 0.001)
        others = [n for n in names if n != name and not (
            name.endswith(("radius", "modulus", "poisson_ratio")) and n.endswith("stiffness"))]
        assert all(new.parameter_value(n) == lk.parameter_value(n) for n in others), name
    with pytest.raises(ValueError, match="unknown parameter 'crank.length'"):
        lk.with_parameter("crank.length", 1.0)
    with pytest.raises(ValueError, match="body 'crank' mass must be"):
        lk.with_parameter("crank.mass", -1.0)


@pytest.mark.parametrize("suffix", [".json", ".toml"])
def test_file_roundtrip(tmp_path, suffix):
    lk = paper_slider_crank(contact_stiffness=1e10)
    # guesses off the collinear start (there the closure's Jacobian is singular)
    four = four_bar_like(assembly={"coupler.angle": 0.5, "rocker.angle": 1.5})
    # a free linkage: no drive table, its start instead
    free = lk.replace(name="free", drive=None, initial=Initial(
        coordinates={"crank.angle": 0.3}, rates={"crank.angle": 10.0}))
    for desc in (lk, four, free):
        path = tmp_path / f"d{suffix}"
        if suffix == ".json":
            path.write_text(json.dumps(desc.to_dict()))
        else:
            path.write_text(_toml(desc.to_dict()))
        assert Linkage.from_file(path) == desc
    # a description that cannot start (no assembly from its guesses) is refused on loading
    path.write_text(json.dumps(four_bar_like().to_dict()))
    path = path.rename(path.with_suffix(".json"))
    with pytest.raises(ValueError, match="loop closure of linkage 'fb' cannot be solved from "
                                         "the assembly guesses {}"):
        Linkage.from_file(path)
    with pytest.raises(ValueError, match="unknown body key"):
        d = lk.to_dict()
        d["bodies"][0]["colour"] = "red"
        Linkage.from_dict(d)


def _toml(d):
    """A small TOML writer for the description's plain data (tests only)."""
    def val(v):
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{json.dumps(k)} = {val(x)}" for k, x in v.items()) + "}"
        return repr(float(v)) if isinstance(v, float) else str(v)

    lines = [f"{k} = {val(v)}" for k, v in d.items() if not isinstance(v, (list, dict))]
    for k, v in d.items():
        if isinstance(v, dict):
            lines.append(f"{k} = {val(v)}")
    for k, v in d.items():
        if isinstance(v, list):
            for item in v:
                lines.append(f"[[{k}]]")
                lines += [f"{kk} = {val(vv)}" for kk, vv in item.items()]
    return "\n".join(lines) + "\n"


def test_paper_case_maps_every_slider_crank_field():
    """Every SliderCrank field changes the Linkage (no field is dropped), and the geometry is
    the paper's: at crank angle th2 the pin sits at L2 (cos, sin) and the slider's pin on the
    x axis at the closed-form x4."""
    base = SliderCrank()
    lk0 = from_slider_crank(base)
    changed = {"crank_length": 0.06, "coupler_length": 0.13, "crank_mass": 0.4,
               "coupler_mass": 0.3, "slider_mass": 0.2, "crank_inertia": 2e-4,
               "coupler_inertia": 4e-4, "crank_speed": 300.0, "initial_crank_angle": 0.3,
               "bearing_radius": 0.0101, "journal_radius": 0.00995, "youngs_modulus": 100e9,
               "poisson_ratio": 0.25, "restitution": 0.5, "contact_stiffness": 1e9,
               "gravity": 0.0, "contact_model": "flores", "impact_velocity_floor": 1e-2,
               "friction_law": "ambrosio", "friction_coefficient": 0.05, "friction_v0": 2e-4,
               "friction_v1": 2e-2, "friction_static_coefficient": 0.08,
               "friction_stribeck_velocity": 2e-3}
    assert set(changed) == {f.name for f in dataclasses.fields(SliderCrank)}
    for f, v in changed.items():
        assert from_slider_crank(base.replace(**{f: v})) != lk0, f
    mech = base.replace(**changed)
    lk = from_slider_crank(mech)
    cj = lk.clearance_joints[0]
    assert (cj.clearance, cj.stiffness, cj.restitution, cj.contact_model) == pytest.approx(
        (mech.clearance, mech.stiffness, mech.restitution, mech.contact_model))
    assert lk.drive.speed == mech.crank_speed and lk.period == mech.period
    crank, coupler, slider = lk.bodies
    assert (crank.mass, crank.inertia, coupler.inertia) == (0.4, 2e-4, 4e-4)
    # crank length = distance pivot-pin, coupler length = crank_end-slider_end
    assert math.dist(*crank.points.values()) == pytest.approx(0.06)
    assert math.dist(*coupler.points.values()) == pytest.approx(0.13)
    # the centre of mass of crank and coupler at their midpoints (the paper's aG2, aG3)
    assert np.sum(list(crank.points.values()), axis=0) == pytest.approx([0, 0])
    th2 = mech.initial_crank_angle
    th3, x4 = lk.assembly["coupler.angle"], lk.assembly["slider_guide.s"]
    pin = 0.06 * np.array([np.cos(th2), np.sin(th2)])
    journal = pin + 0.13 * np.array([np.cos(th3), np.sin(th3)])
    assert journal == pytest.approx([x4, 0.0], abs=1e-15)
    assert lk.monitor_joint == "crank_pivot"
    assert lk.length_scale == pytest.approx(0.06 + 0.13)


def test_paper_case_overrides_and_defaults():
    lk = paper_slider_crank(journal_radius=0.00995)
    assert lk.clearance_joints[0].clearance == pytest.approx(5e-5)
    assert paper_slider_crank() == from_slider_crank(SliderCrank())
    with pytest.raises(ValueError, match="unknown parameter name"):
        paper_slider_crank(crank_lenght=0.1)


def test_simulate_refuses_other_backends_and_options_for_a_linkage():
    from mbs_clearance import simulate
    from mbs_clearance.model.cases import four_bar

    with pytest.raises(ValueError,
                       match=r"backend must be one of \['exudyn', 'ideal', 'reduced'\]"):
        simulate(four_bar(), 2, backend="rigid")
    with pytest.raises(ValueError, match=r"unknown option\(s\) \['step_size'\] for "
                                         r"backend 'ideal'"):
        simulate(four_bar(), 2, backend="ideal", step_size=1e-6)
    with pytest.raises(ValueError, match=r"unknown option\(s\) \['step_size'\]"):
        simulate(paper_slider_crank(), 4, step_size=1e-6)
    with pytest.raises(ValueError, match="mech must be a SliderCrank or a Linkage"):
        simulate({"name": "x"}, 4)


@pytest.mark.parametrize("name", ["paper_slider_crank", "slider_crank_two_clearances",
                                  "four_bar"])
def test_bad_descriptions_of_each_named_case(name):
    """Four bad descriptions, made from each named case: a clearance joint
    replaced by an ideal pin (every loop then closed by ideal joints), an ideal joint on an
    unknown body, a journal larger than its bearing, a negative mass; each a ValueError
    naming the item."""
    from mbs_clearance.model.cases import CASES

    lk = CASES[name]()
    # every clearance joint an ideal pin (a spare clearance joint kept, so that the refusal
    # is the loop's): the loop through the pins is closed
    pins = tuple(Revolute(c.name + "_pin", c.bearing_body, c.bearing_point, c.journal_body,
                          c.journal_point) for c in lk.clearance_joints)
    spare = dataclasses.replace(lk.clearance_joints[0], name="spare")
    with pytest.raises(ValueError, match="closed loop") as err:
        lk.replace(joints=(*lk.joints, *pins), clearance_joints=(spare,))
    assert all(p.name in str(err.value) for p in pins), str(err.value)
    cj = lk.clearance_joints[-1]
    joint = lk.joints[-1]
    with pytest.raises(ValueError, match="unknown body 'nobody'"):
        lk.replace(joints=(*lk.joints[:-1], dataclasses.replace(joint, body_b="nobody")))
    with pytest.raises(ValueError, match=f"clearance joint '{cj.name}' journal_radius must "
                                         "be smaller"):
        dataclasses.replace(cj, journal_radius=cj.bearing_radius * 1.01)
    with pytest.raises(ValueError, match="body 'coupler' mass must be a finite number > 0"):
        lk.with_parameter("coupler.mass", -0.2)


def test_linkage_run_lands_on_t_eval():
    """simulate(linkage, t_eval=...) lands exactly on the requested times and returns only
    them; their states are those of the run without t_eval to the integration tolerance
    (the extra step ends change the steps, not the solution)."""
    import numpy as np

    from mbs_clearance import simulate
    from mbs_clearance.model import cases

    lk = cases.paper_slider_crank()
    te = np.linspace(0.0, lk.period, 41)[1:]
    a = simulate(lk, 1, t_eval=te)
    np.testing.assert_array_equal(a.t, te)
    b = simulate(lk, 1)
    ref = np.interp(te, b.t, b.coordinates["slider_guide.s"])
    assert np.max(np.abs(a.coordinates["slider_guide.s"] - ref)) < 1e-6 * lk.length_scale


# ---------------------------------------------------------------- hostile and careless input

#: a name that, pasted into a generated module's docstring, would run its Python on import
#: (it writes the file named by MARK)
PAYLOAD = 'x"""\nimport pathlib; pathlib.Path(MARK).write_text("pwned")\n"""'


def _description(tmp_path, change) -> Path:
    d = paper_slider_crank().to_dict()
    change(d)
    path = tmp_path / "d.json"
    path.write_text(json.dumps(d))
    return path


@pytest.mark.parametrize("where", ["linkage", "body", "point", "joint", "joint body",
                                   "clearance joint", "clearance point", "drive", "ground"])
def test_a_name_holding_python_is_refused_and_runs_nothing(tmp_path, where):
    """Every name of a description must be an identifier: a name holding triple quotes and
    Python (the payload writes a file when pasted into a docstring, shown by the control)
    is refused on loading, with a one-line error naming the item and the rule, and the file
    is never written."""
    mark = tmp_path / "pwned"
    payload = PAYLOAD.replace("MARK", repr(str(mark)))
    exec(f'"""linkage {payload}: do not edit."""', {})      # noqa: S102 - the control
    assert mark.read_text() == "pwned"
    mark.unlink()

    def change(d):
        if where == "linkage":
            d["name"] = payload
        elif where == "body":
            d["bodies"][0]["name"] = payload
        elif where == "point":
            d["bodies"][2]["points"][payload] = [0.0, 0.0]
        elif where == "joint":
            d["joints"][1]["name"] = payload
        elif where == "joint body":
            d["joints"][1]["body_b"] = payload
        elif where == "clearance joint":
            d["clearance_joints"][0]["name"] = payload
        elif where == "clearance point":
            d["clearance_joints"][0]["bearing_point"] = payload
        elif where == "drive":
            d["drive"]["joint"] = payload
        else:
            d["ground_points"][payload] = [0.0, 0.0]

    path = _description(tmp_path, change)
    with pytest.raises(ValueError) as err:
        Linkage.from_file(path)
    message = str(err.value)
    assert "\n" not in message and "[A-Za-z_][A-Za-z0-9_]*" in message
    assert not mark.exists()


@pytest.mark.parametrize("name", ["", "1crank", "crank arm", "crank-arm", "crank.arm",
                                  "kurbel\u00e4", "a" * 65, 3, None])
def test_names_must_be_identifiers(name):
    with pytest.raises(ValueError, match=r"body name must be an identifier"):
        Body(name, 1.0, 1.0)
    with pytest.raises(ValueError, match=r"linkage name must be an identifier"):
        four_bar_like(name=name)
    assert Body("_crank_2", 1.0, 1.0).name == "_crank_2"        # the rule admits these
    assert four_bar_like(name="a" * 64).name == "a" * 64


@pytest.mark.parametrize("section, key, expected", [
    ("bodies", "mass", r"bodies\[0\] \('crank'\) lacks the key 'mass'"),
    ("bodies", "inertia", r"bodies\[0\] \('crank'\) lacks the key 'inertia'"),
    ("bodies", "name", r"bodies\[0\] lacks the key 'name'"),
    ("joints", "point_b", r"joints\[0\] \('crank_pivot'\) lacks the key 'point_b'"),
    ("clearance_joints", "bearing_radius",
     r"clearance_joints\[0\] \('coupler_slider'\) lacks the key 'bearing_radius'"),
    ("drive", "speed", r"drive lacks the key 'speed'"),
    ("linkage", "drive", r"the description lacks the key 'drive'"),
])
def test_a_missing_key_is_named_with_its_place(tmp_path, section, key, expected):
    def change(d):
        if section == "linkage":
            del d[key]
        elif section == "drive":
            del d["drive"][key]
        else:
            del d[section][0][key]

    with pytest.raises(ValueError, match=expected) as err:
        Linkage.from_file(_description(tmp_path, change))
    assert "\n" not in str(err.value) and "d.json" in str(err.value)


@pytest.mark.parametrize("section, expected", [
    ("bodies", r"unknown body key 'colour' in bodies\[1\] \('coupler'\)"),
    ("joints", r"unknown prismatic joint key 'colour' in joints\[2\] \('slider_guide'\)"),
    ("clearance_joints", r"unknown clearance joint key 'colour' in clearance_joints\[0\]"),
    ("drive", r"unknown drive key 'colour' in drive"),
    ("linkage", r"unknown linkage key 'colour' in the description"),
])
def test_an_unknown_key_is_named_with_its_place(tmp_path, section, expected):
    def change(d):
        target = {"linkage": d, "drive": d["drive"]}.get(section) or d[section][
            {"bodies": 1, "joints": 2}.get(section, 0)]
        target["colour"] = "red"

    with pytest.raises(ValueError, match=expected):
        Linkage.from_file(_description(tmp_path, change))


def test_a_second_clearance_joint_on_the_same_pin_is_refused():
    lk = paper_slider_crank()
    cj = lk.clearance_joints[0]
    twin = dataclasses.replace(cj, name="second")
    flipped = dataclasses.replace(cj, name="flipped", journal_body=cj.bearing_body,
                                  journal_point=cj.bearing_point, bearing_body=cj.journal_body,
                                  bearing_point=cj.journal_point)
    for other in (twin, flipped):
        with pytest.raises(ValueError, match=rf"clearance joints 'coupler_slider' and "
                                             rf"'{other.name}' join the same points"):
            lk.replace(clearance_joints=(cj, other))


def test_sizes_are_refused_before_the_work():
    """A body with 1.5 million points, too many bodies, joints or clearance joints: refused
    on construction from their count (the points are never read one by one)."""
    class Points(dict):
        def items(self):
            raise AssertionError("the points were read")

    many = Points({f"p{i}": (0.0, 0.0) for i in range(1_500_000)})
    with pytest.raises(ValueError, match="body 'crank' points holds 1500000 points; at most "
                                         "64 are allowed"):
        Body("crank", 1.0, 1.0, many)
    fb = four_bar_like()
    with pytest.raises(ValueError, match="bodies holds 65 entries; at most 64"):
        four_bar_like(bodies=fb.bodies * 22)
    with pytest.raises(ValueError, match="clearance_joints holds 33 entries; at most 32"):
        four_bar_like(clearance_joints=fb.clearance_joints * 40)
    endless = iter(lambda: fb.joints[0], None)           # never ends
    with pytest.raises(ValueError, match="joints holds 129 entries; at most 128"):
        four_bar_like(joints=endless)


def test_input_files_are_capped(tmp_path):
    """A description larger than the cap (here 5 MB of valid JSON) or an endless device is
    refused after reading at most the cap."""
    from mbs_clearance import _io

    big = tmp_path / "big.json"
    d = paper_slider_crank().to_dict()
    d["gravity_note"] = "x" * (5 * 1024 * 1024)
    big.write_text(json.dumps(d))
    with pytest.raises(ValueError, match=r"big\.json' is larger than 4096 KiB"):
        Linkage.from_file(big)
    with pytest.raises(ValueError, match=r"'/dev/zero' is larger than 4096 KiB"):
        Linkage.from_file("/dev/zero")
    with pytest.raises(ValueError, match=r"mechanism file '/dev/zero' is larger"):
        SliderCrank.from_json("/dev/zero")
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ValueError, match="nested too deeply"):
        Linkage.from_file(deep)
    assert _io.MAX_INPUT_BYTES == 4 * 1024 * 1024


def test_gaps_are_the_generated_closure():
    """`Linkage.gaps` (plain Python) equals the generated model's closure (sympy's
    kinematics) at random coordinates and times, for every driven case; `assemble` finds the
    centred start of `initial_state`."""
    from mbs_clearance.model.cases import CASES
    from mbs_clearance.solve import linkage_model

    rng = np.random.default_rng(5)
    # the free benchmark case has its own checks (tests/integration/test_flores_benchmark.py)
    for make in [m for m in CASES.values() if m().drive is not None]:
        lk = make()
        model = linkage_model.load_model(lk)
        p = linkage_model.pack_parameters(lk, model)
        for _ in range(20):
            q = rng.normal(0.0, 0.3, model.N_Q) * np.where(
                [c.endswith(".angle") for c in model.COORDINATES], 1.0, lk.length_scale)
            t = rng.uniform(0.0, lk.period)
            np.testing.assert_allclose(lk.gaps(dict(zip(model.COORDINATES, q)), t),
                                       model.closure(t, q, p), rtol=1e-12,
                                       atol=1e-14 * lk.length_scale)
        q0 = linkage_model.initial_state(lk, model, p)[:model.N_Q]
        np.testing.assert_allclose([lk.assemble()[c] for c in model.COORDINATES], q0,
                                   atol=1e-8)


def test_a_four_bar_that_cannot_close_is_refused_on_loading(tmp_path):
    """A coupler too short to reach the rocker: refused by `from_file` after at most 50
    Newton steps of plain Python, in a fresh process that generates, imports and compiles
    no model (no generated module, no sympy loaded)."""
    import subprocess
    import sys

    from mbs_clearance.model.cases import four_bar

    d = four_bar().to_dict()
    d["bodies"][1]["points"] = {"crank_end": [-0.1, 0.0], "rocker_end": [0.1, 0.0]}
    path = tmp_path / "short.json"
    path.write_text(json.dumps(d))
    code = ("import sys\nfrom mbs_clearance.model.linkage import Linkage\n"
            f"try:\n    Linkage.from_file({str(path)!r})\nexcept ValueError as e:\n"
            "    print(e)\n"
            "print(sorted(m for m in sys.modules if m.startswith(('sympy', "
            "'mbs_clearance.generate.c_loader', 'mbs_clearance_model'))))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, check=True).stdout.splitlines()
    assert "short.json': the loop closure of linkage 'four_bar' cannot be solved" in out[0]
    assert "after 50 Newton steps" in out[0]
    assert out[1] == "[]"


def test_the_command_line_refuses_a_malicious_description(tmp_path, monkeypatch, capsys):
    """The issue's command, `lyapunov --revolutions 2 --description F` with a clearance joint
    named with the payload: exit status 2, one line naming the item, no file written."""
    from mbs_clearance.cli import main

    mark = tmp_path / "pwned"
    payload = PAYLOAD.replace("MARK", repr(str(mark)))
    path = _description(tmp_path, lambda d: d["clearance_joints"][0].update(name=payload))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_:
        main(["lyapunov", "--revolutions", "2", "--description", str(path)])
    err = capsys.readouterr().err.strip()
    assert exit_.value.code == 2 and len(err.splitlines()) == 1
    assert "clearance joint name must be an identifier" in err
    assert not mark.exists()
