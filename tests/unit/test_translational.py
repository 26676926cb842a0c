"""The translational clearance joint: a rectangular slider in a guide, each corner its own
contact (Flores, Ambrosio, Claro and Lankarani 2008). References: the ideal slider-crank's
closed form (backends.ideal) as the clearance vanishes, the corners' penetrations and
forces by hand (plane geometry, the contact law at rest), the energy balance of an elastic
contact, and the description's refusals."""

import json
import math

import numpy as np
import pytest

from mbs_clearance.generate.energy import mechanical_energy
from mbs_clearance.model import cases
from mbs_clearance.model.linkage import (
    GROUND,
    Body,
    Drive,
    Linkage,
    Prismatic,
    Revolute,
    TranslationalClearance,
)
from mbs_clearance.model.mechanism import SliderCrank

A, B = 0.025, 0.01          # the slider's half-length and half-height (m)


def guided(c=1e-4, stiffness=1e10, rpm=500.0, restitution=0.4, model="flores", **joint):
    """The paper's slider-crank (SliderCrank defaults at `rpm`) with ideal pins and its
    slider (2a x 2b, centre at the coupler's pin) in a guide of clearance c along the x axis
    instead of the ideal prismatic joint; (SliderCrank, Linkage)."""
    mech = SliderCrank().replace(crank_speed=rpm * 2 * math.pi / 60)
    L2, L3 = mech.crank_length, mech.coupler_length
    guide = TranslationalClearance(
        "guide", GROUND, "axis", "slider", "pin", half_length=A, half_height=B, clearance=c,
        contact_stiffness=stiffness, restitution=restitution, contact_model=model, **joint)
    return mech, Linkage(
        name="guided_slider_crank",
        bodies=(Body("crank", mech.crank_mass, mech.crank_inertia_value,
                     {"pivot": (-L2 / 2, 0.0), "pin": (L2 / 2, 0.0)}),
                Body("coupler", mech.coupler_mass, mech.coupler_inertia_value,
                     {"crank_end": (-L3 / 2, 0.0), "slider_end": (L3 / 2, 0.0)}),
                Body("slider", mech.slider_mass, mech.slider_mass * (A * A + B * B) / 3,
                     {"pin": (0.0, 0.0)})),
        joints=(Revolute("crank_pivot", GROUND, "crank_pivot", "crank", "pivot"),
                Revolute("crank_coupler", "crank", "pin", "coupler", "crank_end"),
                Revolute("coupler_slider", "coupler", "slider_end", "slider", "pin")),
        clearance_joints=(),
        translational_joints=(guide,),
        drive=Drive("crank_pivot", mech.crank_speed, 0.0),
        ground_points={"crank_pivot": (0.0, 0.0), "axis": (0.0, 0.0)},
        gravity=mech.gravity, monitor_joint="crank_pivot")


# ---------------------------------------------------------------- description (fast)

def test_description_round_trip_and_centred_assembly(tmp_path):
    """to_dict/from_file round trip, the dotted parameters, and the assembly with the slider
    centred: the coupler angle of the closed form, the slider level (theta3 = asin(-L2 sin
    theta2 / L3), the slider's angle 0)."""
    mech, lk = guided()
    path = tmp_path / "guided.json"
    path.write_text(json.dumps(lk.to_dict()))
    assert Linkage.from_file(path) == lk
    assert lk.coordinates() == ("coupler.angle", "slider.angle")
    assert [n for n, _ in lk.contacts()] == ["guide.front_top", "guide.rear_top",
                                             "guide.front_bottom", "guide.rear_bottom"]
    assert lk.ground_joints() == ("crank_pivot", "guide")
    assert "guide.clearance" in lk.parameter_names()
    assert "guide.friction_coefficient" not in lk.parameter_names()
    wider = lk.with_parameter("guide.clearance", 2e-4)
    assert wider.translational_joints[0].clearance == 2e-4 and wider.min_clearance == 2e-4
    assert wider.structure() == lk.structure()
    # a study's names: the guide's clearance, and "clearance" moving every joint's
    from mbs_clearance.model.design import design_value, direction, linkage_with

    assert design_value(lk, "guide.clearance") == 1e-4
    assert linkage_with(lk, {"clearance": 3e-4}).translational_joints[0].clearance == 3e-4
    assert direction(lk, "clearance") == {"guide.clearance": 1.0}
    rubbing = guided(friction_law="coulomb", friction_coefficient=0.1)[1]
    assert rubbing.structure() != lk.structure()
    assert "guide.friction_coefficient" in rubbing.parameter_names()
    th2 = 1.0
    q = lk.replace(drive=Drive("crank_pivot", mech.crank_speed, th2)).assemble()
    assert q["coupler.angle"] == pytest.approx(
        math.asin(-mech.crank_length * math.sin(th2) / mech.coupler_length), abs=1e-9)
    assert q["slider.angle"] == pytest.approx(0.0, abs=1e-9)


def _joint(**changes):
    fields = dict(name="g", guide_body=GROUND, guide_point="axis", slider_body="slider",
                  slider_point="pin", half_length=A, half_height=B, clearance=1e-4,
                  contact_stiffness=1e10)
    fields.update(changes)
    return TranslationalClearance(**fields)


#: (changed fields, the refusal's message)
BAD_FIELDS = [
    ({"half_length": 0.0}, "half_length must be a finite number > 0 (m)"),
    ({"half_height": -1.0}, "half_height must be a finite number > 0 (m)"),
    ({"clearance": float("nan")}, "clearance must be a finite number > 0 (m)"),
    ({"contact_stiffness": None}, "contact_stiffness must be a finite number > 0 (N/m^1.5)"),
    ({"impact_velocity_floor": 0.0}, "impact_velocity_floor must be a finite number > 0"),
    ({"angle": float("inf")}, "angle must be a finite number (rad)"),
    ({"slider_angle": "0"}, "slider_angle must be a finite number (rad)"),
    ({"restitution": 0.0}, "restitution must be in the interval (0, 1]"),
    ({"contact_model": "spring"}, "contact_model must be one of"),
    ({"friction_law": "glue"}, "friction_law must be one of"),
    ({"friction_law": "coulomb", "friction_coefficient": -0.1},
     "friction_coefficient must be a finite number >= 0"),
    ({"slider_body": GROUND, "guide_body": "coupler"}, "slider_body must be a moving body"),
    ({"guide_body": "slider"}, "guide and slider on the same body"),
    ({"name": "a.b"}, "translational clearance joint name must be an identifier"),
]


def _re(text):
    import re

    return re.escape(text)


def test_bad_linkages_are_refused():
    """Every field's refusal (naming the joint, the field and its range); the graph's
    refusals: unknown bodies and points, a second guide of one slider, an
    ideal prismatic joint beside the guide, a name used twice, no clearance at all; the
    exudyn backend's native sphere contact refuses the joint before any work."""
    for changes, message in BAD_FIELDS:
        with pytest.raises(ValueError, match=_re(message)) as info:
            _joint(**changes)
        assert str(info.value).startswith("translational clearance joint")
    _, lk = guided()
    bad = [
        ({"translational_joints": (_joint(guide_body="frame"),)},
         "joint 'g' guide_body names an unknown body 'frame'"),
        ({"translational_joints": (_joint(slider_point="tip"),)},
         "joint 'g' slider_point names an unknown point 'tip' of body 'slider'"),
        ({"translational_joints": (_joint(), _joint(name="h"))},
         "'g' and 'h' guide the same slider 'slider'"),
        ({"translational_joints": (_joint(name="crank_pivot"),)},
         "joint name 'crank_pivot' is used twice"),
        ({"translational_joints": ()}, "clearance_joints must hold at least one"),
        ({"translational_joints": ("g",)}, "must hold TranslationalClearance objects"),
        ({"joints": lk.joints[:2] + (Prismatic("rail", GROUND, "axis", "slider", "pin"),),
          "translational_joints": (_joint(),)},
         "'g' and the ideal prismatic joint 'rail' both guide 'slider'"),
    ]
    for changes, message in bad:
        with pytest.raises(ValueError, match=_re(message)):
            lk.replace(**changes)
    data = lk.to_dict()
    data["translational_joints"][0]["width"] = 1.0
    with pytest.raises(ValueError, match=r"unknown translational clearance joint key 'width' "
                                         r"in translational_joints\[0\] \('guide'\)"):
        Linkage.from_dict(data)
    from mbs_clearance.backends.exudyn_linkage import _check_linkage, make_settings

    with pytest.raises(ValueError, match="contact='sphere' has no translational clearance"):
        _check_linkage(lk, make_settings({"contact": "sphere"}))


# ---------------------------------------------------------------- the generated model (slow)

def _corners_by_hand(mech, lk, t, q, positions=False):
    """(penetration, rate 0) of the four corners in `CORNERS` order at coordinates q (coupler
    angle, slider angle) and time t, from plane geometry: the slider centre at the coupler's
    end, each corner at centre + R(phi) (+-a, +-b); penetration y - (b + c) at the top,
    -y - (b + c) at the bottom; with `positions` also the corners' x (along the guide)."""
    th2 = mech.crank_speed * t
    x = mech.crank_length * math.cos(th2) + mech.coupler_length * math.cos(q[0])
    y = mech.crank_length * math.sin(th2) + mech.coupler_length * math.sin(q[0])
    c = lk.translational_joints[0].clearance
    pen, xs = [], []
    for sa, sb in ((1, 1), (-1, 1), (1, -1), (-1, -1)):
        cy = y + math.sin(q[1]) * sa * A + math.cos(q[1]) * sb * B
        xs.append(x + math.cos(q[1]) * sa * A - math.sin(q[1]) * sb * B)
        pen.append(sb * cy - (B + c))
    return (np.array(pen), np.array(xs)) if positions else np.array(pen)


@pytest.mark.slow
def test_corner_penetrations_and_jammed_forces_by_hand():
    """The corners' penetrations at poses by hand (plane geometry); with the slider tilted
    across the guide (jammed), only the two opposite corners touch, and at rest each
    carries the contact law's static force K delta^1.5, its direction the surface's normal:
    the guide's force on the ground is (0, F_top - F_bottom), and with Coulomb friction
    at sliding speed v (regularised, v0) -mu (F_top + F_bottom) v / sqrt(v^2 + v0^2) along
    the axis is added on the slider (its opposite on the ground)."""
    from mbs_clearance.generate import load_model
    from mbs_clearance.solve.linkage_model import pack_parameters

    mech, lk = guided(c=1e-4)
    model = load_model(lk)
    p = pack_parameters(lk, model)
    col = {c: i for i, c in enumerate(model.OUT_COLUMNS)}
    names = [n for n, _ in lk.contacts()]
    rng = np.random.default_rng(5)
    ts = rng.uniform(0, mech.period, 6)
    qs = rng.uniform(-0.3, 0.3, (6, 2)) * [1.0, 0.01]
    ys = np.column_stack([qs, np.zeros((6, model.N_STATE - 2))])
    out = model.outputs(ts, ys, np.zeros((6, model.N_MEM)), p)
    for i in range(6):
        pen, xs = _corners_by_hand(mech, lk, ts[i], qs[i], positions=True)
        assert [out[i, col[f"{n}.penetration"]] for n in names] == pytest.approx(pen,
                                                                                abs=1e-15)
        assert [out[i, col[f"{n}.ecc_x"]] for n in names] == pytest.approx(xs, abs=1e-15)
    # jammed: the slider turned by 1.2 c / a about its centre on the mid-line (two
    # opposite corners about 0.2 c deep)
    tilt = 1.2 * 1e-4 / A
    pen = _corners_by_hand(mech, lk, 0.0, np.array([0.0, tilt]))
    assert pen[0] > 0 and pen[3] > 0 and pen[1] < 0 and pen[2] < 0   # front_top, rear_bottom
    stiff = lk.translational_joints[0].stiffness
    for v, law in ((False, {}), (True, {"friction_law": "coulomb", "friction_coefficient": 0.2,
                                     "friction_v0": 1e-3})):
        _, lk_v = guided(c=1e-4, **law)
        model_v = load_model(lk_v)
        p_v = pack_parameters(lk_v, model_v)
        col_v = {c: i for i, c in enumerate(model_v.OUT_COLUMNS)}
        # at crank angle 0 the slider stands still; at pi / 2 it slides at -L2 w along x
        # (the slider centre on the axis, the coupler's rate keeping it there)
        th2 = math.pi / 2 if v else 0.0
        tt = th2 / mech.crank_speed
        q0 = math.asin(-mech.crank_length * math.sin(th2) / mech.coupler_length)
        qq = np.array([q0, tilt])
        y = np.zeros(model_v.N_STATE)
        y[:2] = qq
        # the coupler's rate that keeps its end level: theta3dot = -L2 w cos th2 / (L3 cos q0)
        y[2] = -mech.crank_length * mech.crank_speed * math.cos(th2) / (
            mech.coupler_length * math.cos(q0))
        pen = _corners_by_hand(mech, lk_v, tt, qq)
        ms = np.zeros((1, model_v.N_MEM))
        ms[0, 0::2] = 1.0
        ms[0, 1::2] = 1.0                     # any impact velocity: the rates are zero
        res = model_v.outputs(np.array([tt]), y[None, :], ms, p_v)[0]
        forces = np.array([res[col_v[f"{n}.contact_force"]] for n in names])
        expected = np.where(pen > 0, stiff * np.maximum(pen, 0.0) ** 1.5, 0.0)
        assert forces == pytest.approx(expected, rel=1e-9, abs=1e-9)
        assert forces[1] == 0.0 and forces[2] == 0.0 and forces[0] > 0 and forces[3] > 0
        rx, ry = res[col_v["guide.reaction_x"]], res[col_v["guide.reaction_y"]]
        assert ry == pytest.approx(forces[0] - forces[3], rel=1e-12)
        # the corners' sliding velocity: the pin's, -L2 w sin th2 (the slider does not turn)
        vx = -mech.crank_length * mech.crank_speed * math.sin(th2)
        mu, v0 = (0.2, 1e-3) if v else (0.0, 1.0)
        friction = -mu * (forces[0] + forces[3]) * vx / math.sqrt(vx * vx + v0 * v0)
        assert rx == pytest.approx(-friction, rel=1e-9, abs=1e-12)


@pytest.mark.slow
def test_elastic_corners_conserve_energy():
    """Restitution 1 (Flores' law: no hysteresis), no friction: d(mechanical energy)/dt
    equals the drive's power at states off the centred assembly, in free flight and with
    every corner in contact (springs' energy counted), and over a run with impacts the
    drive's work equals the change of mechanical energy."""
    from mbs_clearance import simulate
    from mbs_clearance.generate import load_model
    from mbs_clearance.solve.linkage_model import initial_state, pack_parameters

    mech, lk = guided(c=1e-4, restitution=1.0)
    model = load_model(lk)
    energy_of = mechanical_energy(lk)
    p = pack_parameters(lk, model)
    rng = np.random.default_rng(9)
    for mode in (0.0, 1.0):
        for _ in range(4):
            t = rng.uniform(0, lk.period)
            y = initial_state(lk, model, p, t0=t)
            # off the centre by up to 1.5 clearances (corners 0.5 c into the surfaces)
            y[:2] += rng.uniform(-1, 1, 2) * 1.5e-4 / np.array([mech.coupler_length, A])
            p[model.MEM_START::2][:model.N_EVENTS] = mode
            f = np.empty(model.N_STATE)
            model.rhs(t, y, p, f)
            power = f[-1]
            h = 1e-6 * lk.period
            rate = (energy_of(t + h, y + h * f, p)
                    - energy_of(t - h, y - h * f, p)) / (2 * h)
            scale = abs(power) + 1e-3 * abs(energy_of(t, y, p)) / lk.period
            assert abs(rate - power) / scale < 1e-6
    p[model.MEM_START::2][:model.N_EVENTS] = 0.0
    traj = simulate(lk, 1, rtol=1e-10)
    assert traj.stats["nevent"] >= 4
    ys = np.column_stack([traj.coordinates[c] for c in model.COORDINATES]
                         + [traj.rates[c] for c in model.COORDINATES] + [traj.crank_work])
    energy = np.empty(len(traj.t))
    for i, t in enumerate(traj.t):
        p[model.MEM_START::2][:model.N_EVENTS] = traj.contact_phase[i]
        energy[i] = energy_of(t, ys[i], p)
    change = energy - energy[0]
    scale = np.abs(traj.crank_work).max() + np.abs(change).max()
    assert np.abs(traj.crank_work - change).max() / scale < 1e-6
    # with Coulomb friction at the corners: the drive's work minus the change of energy is
    # the work the friction dissipated (its own quadrature), which grows
    _, rubbing = guided(c=1e-4, restitution=1.0, friction_law="coulomb",
                        friction_coefficient=0.2)
    model = load_model(rubbing)
    energy_of = mechanical_energy(rubbing)
    p = pack_parameters(rubbing, model)
    traj = simulate(rubbing, 1, rtol=1e-10)
    ys = np.column_stack([traj.coordinates[c] for c in model.COORDINATES]
                         + [traj.rates[c] for c in model.COORDINATES] + [traj.crank_work])
    energy = np.array([energy_of(t, ys[i], _memories(model, p, traj, i))
                       for i, t in enumerate(traj.t)])
    lost = traj.crank_work - (energy - energy[0])
    assert traj.friction_work[-1] > 1e-3 * np.abs(traj.crank_work).max()
    assert np.all(np.diff(traj.friction_work) >= -1e-12)
    assert np.abs(lost - traj.friction_work).max() < 1e-6 * np.abs(traj.crank_work).max()


def _memories(model, p, traj, i):
    """p with the contact modes of sample i."""
    p[model.MEM_START::2][:model.N_EVENTS] = traj.contact_phase[i]
    return p


@pytest.mark.slow
def test_ideal_guide_limit():
    """As the clearance c -> 0 (stiff contact, restitution 0.4), the slider's position and the
    crank pivot's reaction approach the ideal slider-crank's closed form over the second
    revolution: the position's error falls with c (about in proportion), the reaction's
    relative error too (the impacts' peaks shrink with the impact speeds ~ c omega)."""
    from mbs_clearance import simulate
    from mbs_clearance.backends.ideal import ideal_outputs

    x_err, f_err = [], []
    for c in (1e-4, 1e-5, 1e-6):
        mech, lk = guided(c=c)
        traj = simulate(lk, 2)
        t = traj.t
        ref = ideal_outputs(mech, t)
        late = t > lk.period
        x4 = (mech.crank_length * np.cos(mech.crank_speed * t)
              + mech.coupler_length * np.cos(traj.coordinates["coupler.angle"]))
        x_err.append(np.abs(x4 - ref["x4"])[late].max())
        force = np.linalg.norm(traj.reactions["crank_pivot"] - ref["base_force"], axis=1)
        f_err.append(force[late].max() / np.linalg.norm(ref["base_force"], axis=1).max())
        # both surfaces are touched during a revolution (the coupler's force turns)
        phase = traj.contact_phase[late]
        assert phase[:, :2].any() and phase[:, 2:].any()
    # measured: x 4.7e-5, 5.2e-6, 6.6e-7 m; reaction 1.8, 0.30, 0.047
    assert x_err[0] < 1.0 * 1e-4 and x_err[1] < x_err[0] / 5 and x_err[2] < x_err[1] / 5
    assert f_err[1] < f_err[0] / 3 and f_err[2] < f_err[1] / 3 and f_err[2] < 0.1


@pytest.mark.slow
@pytest.mark.exudyn
def test_reduced_against_exudyn():
    """The same description in Exudyn (absolute coordinates, the corners' loads a generic
    element, fixed steps): over the second revolution the crank pivot's peak force, the
    guide's force on the ground and the corners' penetrations in contact agree with the
    reduced model's, the better the finer Exudyn's steps; with friction also the work it
    dissipates."""
    from mbs_clearance import simulate

    _, lk = guided(c=1e-4)
    red = simulate(lk, 2)
    errors = []
    for steps in (2000, 8000):
        ex = simulate(lk, 2, backend="exudyn", steps_per_revolution=steps)
        assert ex.joints == red.joints
        late = ex.t > lk.period
        guide = np.interp(ex.t, red.t, red.reactions["guide"][:, 1])[late]
        rms = np.sqrt(np.mean((ex.reactions["guide"][late, 1] - guide) ** 2))
        errors.append((abs(ex.peaks[1] / red.peaks[1] - 1.0),
                       rms / np.sqrt(np.mean(guide ** 2))))
        # the bottom corners' largest penetration in the revolution (the slider's weight
        # and the coupler's push: about 7e-7 m)
        deepest = red.penetration[red.t > lk.period, 2:].max()
        assert ex.penetration[late, 2:].max() == pytest.approx(deepest, rel=0.05)
    # measured: peak 2.3e-2, 5.6e-3; guide force rms 0.136, 0.053
    assert errors[1][0] < 0.01 and errors[1][1] < 0.08
    assert errors[1][0] < errors[0][0] / 2 and errors[1][1] < errors[0][1] / 2
    # Coulomb friction at the corners: the work it dissipates and the guide's force along
    # the axis (measured: 0.45101 J against 0.45103 J; rms 0.056 of the reduced's)
    _, rubbing = guided(c=1e-4, friction_law="coulomb", friction_coefficient=0.2)
    red = simulate(rubbing, 2)
    ex = simulate(rubbing, 2, backend="exudyn", steps_per_revolution=8000)
    assert ex.friction_work[-1] == pytest.approx(red.friction_work[-1], rel=1e-3)
    late = ex.t > rubbing.period
    along = np.interp(ex.t, red.t, red.reactions["guide"][:, 0])[late]
    rms = np.sqrt(np.mean((ex.reactions["guide"][late, 0] - along) ** 2))
    assert rms < 0.1 * np.sqrt(np.mean(along ** 2))


@pytest.mark.slow
def test_moving_guide_conserves_energy():
    """A guide on a driven arm (its axis at 0.3 rad in the arm's frame) carrying a floating
    block (its long axis at 0.3 rad in its own frame), restitution 1: d(mechanical
    energy)/dt equals the drive's power with the corners free and in contact, so the
    forces on the moving guide (moved to its point, with their moment) and the drive
    moment's share of them are consistent with the corners' springs."""
    from mbs_clearance.generate import load_model
    from mbs_clearance.solve.linkage_model import initial_state, pack_parameters

    lk = Linkage(
        name="arm_guide",
        bodies=(Body("arm", 0.5, 2e-3, {"pivot": (-0.1, 0.0), "mid": (0.05, 0.02)}),
                Body("block", 0.1, 1e-5, {"c": (0.0, 0.0)})),
        joints=(Revolute("drive_pin", GROUND, "o", "arm", "pivot"),),
        clearance_joints=(),
        translational_joints=(TranslationalClearance(
            "guide", "arm", "mid", "block", "c", half_length=0.02, half_height=0.008,
            clearance=2e-4, contact_stiffness=1e9, angle=0.3, slider_angle=0.3,
            restitution=1.0),),
        drive=Drive("drive_pin", 15.0, 0.2),
        ground_points={"o": (0.0, 0.0)},
        assembly={"block.x": 0.15, "block.y": 0.05, "block.angle": 0.2})
    assert lk.ground_joints() == ("drive_pin",)
    model = load_model(lk)
    energy_of = mechanical_energy(lk)
    p = pack_parameters(lk, model)
    rng = np.random.default_rng(11)
    touching = 0
    for mode in (0.0, 1.0):
        for _ in range(4):
            t = rng.uniform(0, lk.period)
            y = initial_state(lk, model, p, t0=t)
            assert np.abs(model.closure(t, y[:3], p)).max() < 1e-12
            # up to 1.5 clearances off the centre and tilted by up to c / a
            y[:3] += rng.uniform(-1, 1, 3) * np.array([3e-4, 3e-4, 2e-4 / 0.02])
            y[3:6] += rng.uniform(-1, 1, 3) * np.array([0.1, 0.1, 3.0])
            p[model.MEM_START::2][:model.N_EVENTS] = mode
            f = np.empty(model.N_STATE)
            model.rhs(t, y, p, f)
            h = 1e-6 * lk.period
            rate = (energy_of(t + h, y + h * f, p)
                    - energy_of(t - h, y - h * f, p)) / (2 * h)
            scale = abs(f[-1]) + 1e-3 * abs(energy_of(t, y, p)) / lk.period
            assert abs(rate - f[-1]) / scale < 1e-6
            if mode:
                out = model.outputs(np.array([t]), y[None, :], p[None, model.MEM_START:
                                                                  model.MEM_START + 8], p)[0]
                touching += sum(out[5 * k] > 0.0 for k in range(4))
    # the corners' springs were loaded at some of the states
    assert touching >= 2


def test_free_linkage_sensitivities_refusals():
    """A free linkage's sensitivities take duration= (s), not revolutions, and no start;
    the peak objective of a free linkage needs its time window's width (window=), which a
    driven linkage refuses; each before any model is generated."""
    from mbs_clearance.analysis.objective import peak_gradient, peak_output
    from mbs_clearance.analysis.sensitivity import sensitivities

    lk = cases.flores_translational_slider_crank()
    names = ["guide.clearance"]
    with pytest.raises(ValueError, match="is free .*give the sensitivities' duration= in s"):
        sensitivities(lk, names)
    with pytest.raises(ValueError, match="no drive revolutions; give duration="):
        sensitivities(lk, names, revolutions=2, duration=0.01)
    with pytest.raises(ValueError, match="window must be a finite number"):
        sensitivities(lk, names, duration=0.01, window=0.02)
    with pytest.raises(ValueError, match="start is for a driven linkage"):
        sensitivities(lk, names, duration=0.01, start=object())
    for call in (peak_gradient, peak_output):
        with pytest.raises(ValueError, match=r"is free .*peak over time window 2 .*give "
                                             r"window= in s \(e\.g\. its time scale 0\.0419 s"):
            call(lk, names, 2) if call is peak_gradient else call(lk, None, 2)
        with pytest.raises(ValueError, match="window must be a finite number > 0 s"):
            call(lk, names, window=-0.01) if call is peak_gradient else call(lk, window=-0.01)
        with pytest.raises(ValueError, match=r"'four_bar' is driven: .*window= \(s\) is for a "
                                             r"free linkage"):
            call(cases.four_bar(), ["clearance"], window=0.01) if call is peak_gradient \
                else call(cases.four_bar(), window=0.01)
    with pytest.raises(ValueError, match=r"unknown output 'drive_moment' .*allowed: "
                                         r"\['pivot_force:crank_pivot', .*'shaking_force', "
                                         r"'contact_force:guide.front_top'"):
        peak_output(lk, "drive_moment", window=0.01)


#: DDM against finite differences on the translational-clearance benchmark: the times (s),
#: before the slider's tilt under friction separates runs of different tolerances (0.07 s)
FLORES_TIMES = np.array([0.01, 0.02, 0.03, 0.04, 0.05])


@pytest.mark.slow
def test_ddm_matches_finite_differences_on_the_flores_case():
    """DDM sensitivities of the free translational-clearance slider-crank (Flores, Leine and
    Glocker 2010) along the clearance, the friction coefficient and the contact stiffness
    equal central differences of plain runs (rtol 1e-11) in every coordinate at 0.01 to
    0.05 s, through the corners' impacts and sliding: the difference is within three times
    the finite differences' own error, measured as their change between relative steps
    1e-4 and 3e-4 (or 1e-5 of the column's largest value)."""
    from mbs_clearance.analysis.sensitivity import sensitivities

    lk = cases.flores_translational_slider_crank()
    names = ("guide.clearance", "guide.friction_coefficient", "guide.contact_stiffness")
    ddm = sensitivities(lk, names, method="ddm", duration=0.05, t_eval=FLORES_TIMES,
                        rtol=1e-9)
    assert ddm.stats["nevent"] > 10        # the corners' contacts start and end
    fd = [sensitivities(lk, names, method="fd", duration=0.05, t_eval=FLORES_TIMES,
                        rtol=1e-11, fd_relative_step=h) for h in (1e-4, 3e-4)]
    np.testing.assert_allclose(ddm.trajectory.coordinates["crank.angle"],
                               fd[0].trajectory.coordinates["crank.angle"], rtol=1e-6)
    for c in lk.coordinates():
        ref = fd[0].outputs[c]
        scale = np.abs(ref).max(axis=0)
        assert np.all(scale > 0), c
        err = np.abs(ddm.outputs[c] - ref).max(axis=0)
        fd_err = np.abs(fd[1].outputs[c] - ref).max(axis=0)
        assert np.all(err <= np.maximum(3 * fd_err, 1e-5 * scale)), (c, err / scale,
                                                                     fd_err / scale)
    assert ddm.crank_moment is None


@pytest.mark.slow
def test_ddm_matches_finite_differences_on_a_driven_guide():
    """DDM on the driven slider-crank in a guide with clearance along geometric parameters
    (they move the centred start: the initial sensitivities through the slider's closure,
    its offset and tilt as the corners' mean offsets) and the clearance: within three times
    the central differences' own error (their change between relative steps 1e-4 and
    3e-4), or 1e-6 of the column's largest value, over half a revolution."""
    from mbs_clearance.analysis.sensitivity import sensitivities

    _, lk = guided()
    names = ("guide.clearance", "guide.angle", "coupler.slider_end.x")
    t_eval = np.linspace(0.0, 0.5 * lk.period, 6)[1:]
    ddm = sensitivities(lk, names, method="ddm", revolutions=1, t_eval=t_eval, rtol=1e-10)
    fd = [sensitivities(lk, names, method="fd", revolutions=1, t_eval=t_eval, rtol=1e-11,
                        fd_relative_step=h) for h in (1e-4, 3e-4)]
    for c in lk.coordinates():
        ref = fd[0].outputs[c]
        scale = np.abs(ref).max(axis=0)
        err = np.abs(ddm.outputs[c] - ref).max(axis=0)
        fd_err = np.abs(fd[1].outputs[c] - ref).max(axis=0)
        # (without friction the slider stays flat: its tilt's derivatives vanish, 1e-12
        # rad per unit of the parameter is their round-off)
        assert np.all(err <= np.maximum(3 * fd_err, 1e-6 * scale + 1e-12)), (c, err, fd_err,
                                                                             scale)


def test_free_linkage_studies_refusals(tmp_path, capsys):
    """The studies of a free linkage take its objective's window (window= s; the CLI's
    --duration and --window), a driven one refuses it; a regime map refuses a free linkage
    (no drive period to take its section at); each before any model is generated."""
    from mbs_clearance.cli import main
    from mbs_clearance.studies.optimize import optimize_link_lengths
    from mbs_clearance.studies.sweep import regime_map
    from mbs_clearance.studies.tolerance import Uniform, tolerance_study

    lk = cases.flores_translational_slider_crank()
    genes = {"clearance": (0.8e-3, 1.2e-3)}
    with pytest.raises(ValueError, match=r"is free .*give window= in s"):
        optimize_link_lengths(lk, genes=genes, progress=False)
    with pytest.raises(ValueError, match=r"window \(s\) is for a free Linkage"):
        optimize_link_lengths(SliderCrank(), window=0.01, progress=False)
    with pytest.raises(ValueError, match=r"is free .*give window= in s"):
        tolerance_study({"clearance": Uniform(0.8e-3, 1.2e-3)}, lk, sobol=0, monte_carlo=2)
    with pytest.raises(ValueError, match=r"'four_bar' is driven: .*window= \(s\) is for"):
        tolerance_study({"clearance": Uniform(1e-5, 2e-5)}, cases.four_bar(), sobol=0,
                        monte_carlo=2, window=0.01)
    with pytest.raises(ValueError, match=r"output 'rms_drive_moment' is taken over a drive "
                                         r"revolution; a free linkage"):
        tolerance_study({"clearance": Uniform(0.8e-3, 1.2e-3)}, lk, "rms_drive_moment",
                        sobol=0, monte_carlo=2, window=0.01)
    with pytest.raises(ValueError, match=r"is free \(drive=None\): a regime map classifies "
                                         r"the Poincare section taken once per drive period"):
        regime_map(lk, ("clearance", (1e-3, 2e-3)), revolutions=4, keep=3, max_period=1)
    spec = tmp_path / "inputs.json"
    spec.write_text(json.dumps({"clearance": {"uniform": [0.8e-3, 1.2e-3]}}))
    flores = ["--case", "flores_translational_slider_crank"]
    for argv, message in (
            (["sensitivity", *flores, "--revolutions", "2"], "it has no revolutions; give "
                                                              "--duration"),
            (["sensitivity", *flores, "--output", "shaking_force", "--parameters",
              "clearance"], "give --duration (s)"),
            (["sensitivity", "--case", "four_bar", "--duration", "0.1"],
             "--duration and --window are for a free linkage"),
            (["optimize", *flores, "--gene", "clearance=8e-4:1.2e-3", "--duration", "0.03",
              "--window", "0.02"], "--duration (0.03 s) must be a whole number of --window"),
            (["optimize", "--duration", "0.1"], "--duration and --window are for a free"),
            (["tolerance", str(spec), *flores, "--revolution", "2"], "give --duration (s) "
                                                                      "and optionally"),
            (["tolerance", str(spec), *flores, "--duration", "0.02", "--output",
              "drive_moment"], "unknown output 'drive_moment'"),
            (["map", *flores, "--sweep", "clearance=1e-3,2e-3", "--revolutions", "4",
              "--keep", "3", "--max-period", "1"], "a regime map classifies the Poincare"),
    ):
        with pytest.raises(SystemExit) as e:
            main(argv + ["--out", str(tmp_path / "o")])
        assert e.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0], (argv, err)


def test_each_corner_is_an_output_named_as_its_trajectory_column():
    """A translational joint's corners are outputs ("contact_force:<joint>.<corner>", as
    simulate prints them): each one's peak over a window is its refined maximum, at least
    the largest recorded sample of that corner's force and within 1 % of it; a name that is
    not a corner is refused naming the allowed ones."""
    from mbs_clearance.analysis.objective import parse_output, peak_output
    from mbs_clearance.solve.simulate import simulate

    lk = cases.flores_translational_slider_crank()
    w = 0.01
    tr = simulate(lk, duration=3 * w, window=w, rtol=1e-9)
    keep = tr.t >= 2 * w - 1e-12
    touched = 0
    for k, corner in enumerate(lk.translational_joints[0].corner_names()):
        peak = peak_output(lk, f"contact_force:{corner}", 3, window=w, rtol=1e-9)
        sample = float(tr.contact_force[keep, k].max())
        assert sample <= peak <= 1.01 * sample + 1e-9, (corner, peak, sample)
        touched += peak > 0.0
    assert touched >= 1                      # the window has contact: the check has teeth
    with pytest.raises(ValueError, match=r"unknown output 'contact_force:guide.top'.*"
                                         r"contact_force:guide.front_top"):
        parse_output(lk, "contact_force:guide.top")
