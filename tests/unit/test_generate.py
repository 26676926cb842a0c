"""The generated models: the paper case against its closed form written by hand
(validation/paper_closed_form.py: two independent derivations), energy balance, loop
closure, the specialised models against the general ones, deterministic generation. (Names
of the description never reach the C source: tests/unit/test_c_models.py.)"""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mbs_clearance.core.integrate import RecordKernels
from mbs_clearance.generate import (
    generate_module,
    load_model,
)
from mbs_clearance.generate.energy import mechanical_energy
from mbs_clearance.model.cases import paper_slider_crank
from mbs_clearance.model.linkage import GROUND, Body, ClearanceJoint, Drive, Linkage, Revolute
from mbs_clearance.model.mechanism import SliderCrank
from mbs_clearance.solve import reduced
from mbs_clearance.solve.linkage_model import initial_state, pack_parameters
from validation import paper_closed_form as closed

ROOT = Path(__file__).resolve().parents[2]


def _random_states(mech, rng, n, spread):
    """States near the ideal assembly: the journal off-centre by up to `spread` clearances."""
    out = []
    for _ in range(n):
        t = rng.uniform(0, 3 * mech.period)
        th2 = mech.crank_speed * t + mech.initial_crank_angle
        q = reduced.ideal_kinematics(mech.crank_length, mech.coupler_length,
                                     mech.crank_speed, th2)
        q[0] += rng.uniform(-1, 1) * spread * mech.clearance / mech.coupler_length
        q[1] += rng.uniform(-1, 1) * spread * mech.clearance
        q[2] *= 1 + rng.uniform(-0.2, 0.2)
        q[3] += rng.uniform(-1, 1) * mech.crank_speed * mech.crank_length * 0.1
        out.append((t, np.append(q, rng.uniform(0, 10))))
    return out


@pytest.mark.parametrize("mech", [
    SliderCrank(),
    SliderCrank(crank_length=0.07, coupler_mass=0.4, initial_crank_angle=0.7,
                contact_model="hunt_crossley", restitution=0.6, gravity=3.0,
                journal_radius=0.00995),
], ids=["paper", "varied"])
def test_paper_model_matches_reduced(mech):
    """Accelerations, |F12| (the crank pivot's reaction), drive moment, contact force and
    switching function of the generated model equal the paper's closed form at random
    states in both contact modes (sympy.physics.mechanics + generated code against the
    paper's Eqs. 1-8 written by hand, validation/paper_closed_form.py)."""
    lk = paper_slider_crank(**{f: getattr(mech, f) for f in (
        "crank_length", "coupler_mass", "initial_crank_angle", "contact_model", "restitution",
        "gravity", "journal_radius")})
    model = load_model(lk)
    p = pack_parameters(lk, model)
    col = {c: i for i, c in enumerate(model.OUT_COLUMNS)}
    rng = np.random.default_rng(5)
    n_contact = 0
    for t, y in _random_states(mech, rng, 40, 3.0):
        for mode in (0.0, 1.0):
            dmin = rng.uniform(0.01, 1.0)
            p[model.MEM_START:model.MEM_START + 2] = mode, dmin
            th3dd, x4dd, F, delta, deltadot, ex, ey, M2, F12x, F12y = closed.dynamics(
                mech, t, y, mode, dmin)
            out = np.empty(model.N_OUT)
            dydt = np.empty(model.N_STATE)
            g, gd = np.empty(1), np.empty(1)
            m = RecordKernels(model).monitor(t, y, p, dydt, out, g, gd)
            n_contact += F > 0
            # scales: the largest term of each quantity (inertial ~ m L w^2, contact F)
            acc_scale = (abs(th3dd) + 300.0 / mech.coupler_inertia_value * mech.coupler_length
                         + F * mech.coupler_length / mech.coupler_inertia_value)
            force_scale = abs(F) + 20.0 + np.hypot(F12x, F12y)
            assert out[col["coupler.angle.acc"]] == pytest.approx(th3dd, rel=1e-12,
                                                                 abs=1e-12 * acc_scale)
            assert out[col["slider_guide.s.acc"]] == pytest.approx(
                x4dd, rel=1e-12, abs=1e-12 * (abs(x4dd) + F / mech.slider_mass))
            assert out[col["coupler_slider.contact_force"]] == pytest.approx(F, rel=1e-12,
                                                                             abs=1e-9)
            # the journal's position is a difference of coordinates of size L2 + L3:
            # round-off ~ a few ulps of 0.2 m
            assert out[col["coupler_slider.penetration"]] == pytest.approx(delta, abs=5e-16)
            assert out[col["coupler_slider.ecc_x"]] == pytest.approx(ex, abs=5e-16)
            assert out[col["coupler_slider.ecc_y"]] == pytest.approx(ey, abs=5e-16)
            assert out[col["crank_pivot.reaction_x"]] == pytest.approx(
                F12x, abs=1e-12 * force_scale)
            assert out[col["crank_pivot.reaction_y"]] == pytest.approx(
                F12y, abs=1e-12 * force_scale)
            assert m == pytest.approx(np.hypot(F12x, F12y), rel=1e-12, abs=1e-12 * force_scale)
            assert out[col["drive_moment"]] == pytest.approx(
                M2, abs=1e-12 * force_scale * (mech.crank_length + mech.coupler_length))
            assert dydt[4] == pytest.approx(M2 * mech.crank_speed,
                                            abs=1e-12 * force_scale * 0.2 * mech.crank_speed)
            assert dydt[:2] == pytest.approx(y[2:4], abs=0)
            ge, gde = closed.switching(mech, t, y, mode)
            vel = mech.crank_speed * (mech.crank_length + mech.coupler_length)
            assert model.event(t, y, p, 0) == pytest.approx((ge, gde), abs=1e-13 * vel)
            assert model.event(t, y, p, 0)[0] == pytest.approx(ge, abs=5e-16)
            assert (g[0], gd[0]) == pytest.approx(model.event(t, y, p, 0), rel=1e-12,
                                                  abs=1e-18)
    assert n_contact > 10       # the contact branch was exercised


def test_on_event_matches_the_closed_form():
    mech = SliderCrank()
    lk = paper_slider_crank()
    model = load_model(lk)
    p = pack_parameters(lk, model)
    rng = np.random.default_rng(2)
    for t, y in _random_states(mech, rng, 5, 1.5):
        for mode in (0.0, 1.0):
            p[model.MEM_START] = mode
            RecordKernels(model).on_event(t, y, p, 0)
            assert p[model.MEM_START] == 1.0 - mode
            if mode == 0.0:     # an onset stores the impact velocity
                assert p[model.MEM_START + 1] == pytest.approx(
                    closed.impact_velocity(mech, t, y), rel=1e-12, abs=1e-15)


def _energy_rate_check(lk, mode, rng, n=5):
    """d(mechanical energy)/dt along rhs (central differences at two step sizes, where
    truncation ~h^2 and round-off ~1/h are both below 1e-7 of the power or at most one of
    them is) against the drive power; returns the relative errors. A missing or wrong term
    of the equations gives errors of order one."""
    model = load_model(lk)
    p = pack_parameters(lk, model)
    energy_of = mechanical_energy(lk)
    y0 = initial_state(lk, model, p)
    errs = []
    for _ in range(n):
        t = rng.uniform(0, lk.period)
        y = initial_state(lk, model, p, t0=t)
        y[:model.N_Q] += rng.uniform(-1, 1, model.N_Q) * 2 * lk.min_clearance / max(
            lk.length_scale, 1e-3) * np.where(
            [c.endswith(".angle") for c in model.COORDINATES], 1.0, lk.length_scale)
        p[model.MEM_START::2][:model.N_EVENTS] = mode
        f = np.empty(model.N_STATE)
        model.rhs(t, y, p, f)
        power = f[-1]
        rates = []
        for h in (1e-6 * lk.period, 0.5e-6 * lk.period):
            fwd = energy_of(t + h, y + h * f, p)
            bwd = energy_of(t - h, y - h * f, p)
            # the state moves along the tangent, not the solution: second-order terms cancel
            # in the central difference up to O(h^2)
            rates.append((fwd - bwd) / (2 * h))
        scale = abs(power) + 1e-3 * abs(energy_of(t, y, p)) / lk.period
        errs.append((abs(rates[0] - power) / scale, abs(rates[1] - power) / scale))
    del y0
    return errs


def test_energy_rate_equals_drive_power_free_flight():
    rng = np.random.default_rng(3)
    for e1, e2 in _energy_rate_check(paper_slider_crank(), 0.0, rng):
        assert min(e1, e2) < 1e-7


def test_energy_rate_in_elastic_contact():
    """Restitution 1: the contact is conservative (spring energy counted in contact mode)."""
    rng = np.random.default_rng(4)
    for e1, e2 in _energy_rate_check(paper_slider_crank(restitution=1.0), 1.0, rng):
        assert min(e1, e2) < 1e-7


def _pendulum_pair():
    """A driven crank carrying a floating disc through a clearance joint, and a pendulum
    hung from the ground through a second one: a floating body and a ground clearance
    joint, two switching functions."""
    return Linkage(
        name="pendulum_pair",
        bodies=(Body("crank", 0.2, 2e-4, {"o": (-0.02, 0.0), "a": (0.02, 0.0)}),
                Body("disc", 0.1, 3e-5, {"c": (0.0, 0.0)}),
                Body("pendulum", 0.3, 1e-3, {"top": (0.0, 0.05), "tip": (0.0, -0.05)})),
        joints=(Revolute("drive_pin", GROUND, "o", "crank", "o"),),
        clearance_joints=(
            ClearanceJoint("disc_pin", "crank", "a", "disc", "c", 0.004, 0.0039,
                           restitution=1.0),
            ClearanceJoint("hanger", "pendulum", "top", GROUND, "h", 0.004, 0.0039,
                           restitution=1.0)),
        drive=Drive("drive_pin", 20.0, 0.3),
        ground_points={"o": (0.0, 0.0), "h": (0.2, 0.0)},
        assembly={"disc.x": 0.02, "pendulum.x": 0.2, "pendulum.y": -0.05},
    )


def test_floating_bodies_and_ground_clearance():
    """Coordinates of floating bodies, closure at the centred start, its Jacobian against
    central differences, energy balance in free flight and elastic contact."""
    lk = _pendulum_pair()
    model = load_model(lk)
    assert model.COORDINATES == ("disc.x", "disc.y", "disc.angle", "pendulum.x",
                                 "pendulum.y", "pendulum.angle")
    assert model.GROUND_JOINTS == ("drive_pin", "hanger")
    p = pack_parameters(lk, model)
    y0 = initial_state(lk, model, p)
    assert np.abs(model.closure(0.0, y0[:6], p)).max() < 1e-15
    # crank pin at 0.04 (cos 0.3, sin 0.3); the disc's centre there; the pendulum hangs
    assert y0[:2] == pytest.approx(0.04 * np.array([np.cos(0.3), np.sin(0.3)]), abs=1e-15)
    assert y0[3:5] == pytest.approx([0.2, -0.05], abs=1e-15)
    q = y0[:6] + np.random.default_rng(1).uniform(-0.1, 0.1, 6)
    jac = model.closure_jacobian(0.1, q, p)
    for k in range(6):
        dq = np.zeros(6)
        dq[k] = 1e-6
        fd = (model.closure(0.1, q + dq, p) - model.closure(0.1, q - dq, p)) / 2e-6
        assert jac[:, k] == pytest.approx(fd, abs=1e-8)
    rate = model.closure_rate(0.1, q, p)
    fd = (model.closure(0.1 + 1e-7, q, p) - model.closure(0.1 - 1e-7, q, p)) / 2e-7
    assert rate == pytest.approx(fd, abs=1e-7)
    rng = np.random.default_rng(6)
    for mode in (0.0, 1.0):
        for e1, e2 in _energy_rate_check(lk, mode, rng):
            assert min(e1, e2) < 1e-7


def test_shaking_force_is_newton_on_the_whole_mechanism():
    """The sum of the forces on the ground equals -(sum of m a) - gravity of all bodies
    (Newton on the whole mechanism), with the accelerations from finite differences of the
    centres of mass (pendulum pair: a ground clearance joint's force counts too)."""
    lk = _pendulum_pair()
    model = load_model(lk)
    p = pack_parameters(lk, model)
    y = initial_state(lk, model, p, t0=0.05)
    y[:6] += np.random.default_rng(9).uniform(-2e-4, 2e-4, 6)
    y[6:12] += np.random.default_rng(8).uniform(-0.05, 0.05, 6)
    col = {c: i for i, c in enumerate(model.OUT_COLUMNS)}
    for mode in (0.0, 1.0):
        p[model.MEM_START::2][:2] = mode
        out = np.empty(model.N_OUT)
        f = np.empty(model.N_STATE)
        RecordKernels(model).monitor(0.05, y, p, f, out, np.empty(2), np.empty(2))
        # crank: rotation about the origin at the drive speed, centre of mass at its middle
        th = 20.0 * 0.05 + 0.3
        a_crank = -0.02 * 20.0**2 * np.array([np.cos(th), np.sin(th)])
        total = (0.2 * a_crank + 0.1 * f[6:8] + 0.3 * f[9:11]
                 + np.array([0.0, (0.2 + 0.1 + 0.3) * 9.81]))
        shaking = out[[col["shaking_x"], col["shaking_y"]]]
        assert shaking == pytest.approx(-total, rel=1e-12, abs=1e-12 * np.abs(total).max())


def test_generation_is_deterministic_across_processes():
    """Another hash seed gives the same text (sympy's set orders do not leak into it)."""
    code = ("import sys; from mbs_clearance.model.cases import paper_slider_crank; "
            "from mbs_clearance.generate import generate_module; "
            "sys.stdout.write(generate_module(paper_slider_crank()))")
    texts = []
    for seed in ("1", "2"):
        env = dict(os.environ, PYTHONHASHSEED=seed)
        texts.append(subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env,
                                    capture_output=True, text=True, check=True).stdout)
    assert texts[0] == texts[1]


def test_models_specialised_on_zero_geometry_equal_the_general_one():
    """The paper case's model is specialised on its zero-valued geometric parameters (points
    on the links' axes, the guide through the origin): its right-hand side and outputs
    equal the general model's at the states of a run, to round-off; a nonzero offset takes
    another model; the specialised model refuses a
    nonzero entry in its zero set (pack_parameters naming it; integrate_model; a DDM
    direction along it). (Sensitivities along such parameters: test_linkage_ddm.)"""
    from mbs_clearance.generate.key import geometric_zeros
    from mbs_clearance.model import cases
    from mbs_clearance.numerics.integrator import METHODS, make_settings
    from mbs_clearance.solve import linkage_ddm

    lk = cases.paper_slider_crank()
    spec, gen = load_model(lk), load_model(lk, specialise=False)
    assert spec.ZERO_PARAMETERS == geometric_zeros(lk) and "slider.pin.y" in spec.ZERO_PARAMETERS
    assert gen.ZERO_PARAMETERS == () and gen is not spec
    assert spec.PARAMETERS == gen.PARAMETERS
    p, pg = pack_parameters(lk, spec), pack_parameters(lk, gen)
    assert np.array_equal(p[:spec.CONST_START], pg[:gen.CONST_START])
    from mbs_clearance.solve.linkage_model import run

    _, ts, ys, ms, *_ = run(lk, 1)
    rng = np.random.default_rng(3)
    for i in rng.choice(len(ts), 300, replace=False):
        for q, m in ((p, spec), (pg, gen)):
            q[m.MEM_START:m.MEM_START + m.N_MEM] = ms[i]
        a, b = np.empty(spec.N_STATE), np.empty(gen.N_STATE)
        spec.rhs(ts[i], ys[i], p, a)
        gen.rhs(ts[i], ys[i], pg, b)
        a = np.r_[a, spec.outputs(ts[i:i + 1], ys[i:i + 1], ms[i:i + 1], p)[0]]
        b = np.r_[b, gen.outputs(ts[i:i + 1], ys[i:i + 1], ms[i:i + 1], pg)[0]]
        scale = np.maximum(np.abs(b), 1e-9 * np.max(np.abs(b)))
        assert np.max(np.abs(a - b) / scale) < 1e-9, i
    # an offset of the slider's pin: no longer in the zero set, another module
    off = lk.with_parameter("slider.pin.y", 1e-3)
    assert "slider.pin.y" not in load_model(off).ZERO_PARAMETERS
    with pytest.raises(ValueError, match=r"slider\.pin\.y = 0\.001.*specialise=False"):
        pack_parameters(off, spec)
    q = pack_parameters(lk, spec)
    q[spec.PARAMETERS.index("slider.pin.y")] = 1e-3
    settings = make_settings(1e-7, np.full(5, 1e-9), 4, h_max=1e-3, max_steps=10,
                             n_dense=4, n_events=1, mem_start=spec.MEM_START, n_mem=2)
    with pytest.raises(ValueError, match="ZERO_PARAMETERS"):
        spec.integrate_model(initial_state(lk, spec, p), q, np.array([0.0, 1e-3]), settings,
                             METHODS["dopri5"].arrays())
    with pytest.raises(ValueError, match=r"directions along \['slider\.pin\.y'\]"):
        linkage_ddm.ddm_run(linkage_ddm.prepare_sensitivity(lk, ("slider.pin.y",), 1,
                                                            specialise=True))


def test_coupled_mass_matrix_chain():
    """A chain (crank - link - link, the last link's tip in a ground bearing): a full,
    state-dependent mass matrix, solved by the unrolled Cholesky factorisation; energy
    balance in free flight and elastic contact, closure at the start."""
    lk = Linkage(
        name="chain",
        bodies=(Body("crank", 0.2, 2e-4, {"o": (-0.02, 0.0), "a": (0.02, 0.0)}),
                Body("l1", 0.3, 4e-4, {"a": (-0.06, 0.0), "b": (0.06, 0.01)}),
                Body("l2", 0.25, 3e-4, {"b": (-0.05, 0.0), "c": (0.05, 0.0)})),
        joints=(Revolute("drive_pin", GROUND, "o", "crank", "o"),
                Revolute("ab", "crank", "a", "l1", "a"),
                Revolute("bc", "l1", "b", "l2", "b")),
        clearance_joints=(ClearanceJoint("tip", "l2", "c", GROUND, "t", 0.004, 0.0039,
                                         restitution=1.0),),
        drive=Drive("drive_pin", 15.0),
        ground_points={"o": (0.0, 0.0), "t": (0.12, 0.08)},
        assembly={"l1.angle": 0.8, "l2.angle": -0.5},
    )
    source = generate_module(lk)
    assert "sqrt(m_0_0" in source      # the Cholesky path
    model = load_model(lk)
    p = pack_parameters(lk, model)
    y0 = initial_state(lk, model, p)
    assert np.abs(model.closure(0.0, y0[:2], p)).max() < 1e-15
    rng = np.random.default_rng(11)
    for mode in (0.0, 1.0):
        for e1, e2 in _energy_rate_check(lk, mode, rng):
            assert min(e1, e2) < 1e-7


def test_trajectory_along_reduced_run(tmp_path):
    """The Linkage glue's Trajectory from the SliderCrank path's recorded run (same state
    layout: coupler angle, slider position, their rates, the drive's work): both glues read
    the same series along a real trajectory with impacts; save/load round trip."""
    from mbs_clearance.solve.linkage_model import trajectory_from_run
    from mbs_clearance.solve.trajectory import annotate, load_trajectory

    mech = SliderCrank()
    lk = paper_slider_crank()
    model = load_model(lk)
    ts, ys, ms, peaks, _, counters, outs, pr = reduced.run(mech, 2)
    ref = reduced.trajectory_from_states(mech, ts, ys, ms, pr, {}, peaks, outs,
                                         reduced.MODEL.OUT_COLUMNS)
    p = pack_parameters(lk, model)
    assert initial_state(lk, model, p) == pytest.approx(ys[0], abs=1e-15)
    traj = annotate(trajectory_from_run(lk, model, ts, ys, ms, p, {"rtol": 1e-7}, peaks))
    assert traj.contact_force.shape == (len(ts), 1)
    assert traj.eccentricity.shape == (len(ts), 1, 2)
    scale = np.abs(ref.base_force).max()
    assert np.abs(traj.base_force - ref.base_force).max() < 1e-12 * scale
    assert np.abs(traj.reactions["crank_pivot"] - ref.base_force).max() < 1e-12 * scale
    assert np.abs(traj.crank_moment - ref.crank_moment).max() < 1e-12 * scale * 0.17
    assert np.abs(traj.contact_force[:, 0] - ref.contact_force).max() < 1e-12 * scale
    assert np.abs(traj.eccentricity[:, 0] - ref.eccentricity).max() < 5e-16
    assert np.array_equal(traj.contact_phase[:, 0], ref.contact_phase)
    assert np.array_equal(traj.crank_work, ref.crank_work)
    assert np.abs(traj.accelerations["slider_guide.s"] - ref.slider_acceleration).max() < (
        1e-12 * np.abs(ref.slider_acceleration).max())
    assert traj.stats["max_penetration_clearance"] == pytest.approx(
        ref.stats.get("max_penetration_clearance", annotate(ref).stats[
            "max_penetration_clearance"]), rel=1e-9)
    assert traj.max_base_force(2) == ref.max_base_force(2)
    for suffix in (".npz", ".csv"):
        back = load_trajectory(traj.save(tmp_path / f"t{suffix}"))
        assert back.mechanism == lk and back.joints == traj.joints
        assert np.array_equal(back.contact_force, traj.contact_force)
        assert np.array_equal(back.reactions["slider_guide"], traj.reactions["slider_guide"])
        assert np.array_equal(back.coordinates["coupler.angle"], traj.coordinates[
            "coupler.angle"])
        assert np.array_equal(back.peaks, traj.peaks)


def test_paper_case_through_the_linkage_path():
    """simulate(paper_slider_crank()) (generated model, protocol v2, glue) against
    simulate(SliderCrank()) (hand-written model) at the same fixed rtol (the default
    accuracy request would check the two differently): the refined peak of |F12| of every
    revolution within 1e-9 relative, and the same contact events."""
    from mbs_clearance import simulate

    ref = simulate(SliderCrank(), 4, rtol=1e-7)
    traj = simulate(paper_slider_crank(), 4, rtol=1e-7)
    for rev in range(1, 5):
        assert traj.max_base_force(rev) == pytest.approx(ref.max_base_force(rev), rel=1e-9)
    assert traj.stats["nevent"] == ref.stats["nevent"]
    assert traj.contact_force.shape == (len(traj.t), 1)
    assert traj.eccentricity.shape == (len(traj.t), 1, 2)
    assert set(traj.reactions) == {"crank_pivot", "slider_guide"}
    # the drive's work over the run against the hand-written model's
    assert traj.crank_work[-1] == pytest.approx(ref.crank_work[-1], rel=1e-7)


@pytest.mark.slow
def test_two_joints_energy_balance_over_a_run():
    """Two clearance joints (a floating disc on the crank pin and a pendulum rattling in a
    ground bearing, ~470 impacts in 2 revolutions), restitution 1: the drive's work equals
    the change of mechanical energy along the whole run, to the integration error, which
    shrinks with rtol (each contact onset costs the step into it a few 1e-11 J at rtol 1e-10:
    the force law K delta^1.5 is not smooth at delta = 0), so that a model inconsistency
    (a wrong force, a mode switched off the wall) would stand out."""
    from mbs_clearance import simulate

    lk = _pendulum_pair()
    model = load_model(lk)
    p = pack_parameters(lk, model)
    energy_of = mechanical_energy(lk)
    errors = []
    for rtol in (1e-10, 1e-11):
        traj = simulate(lk, 2, rtol=rtol)
        assert traj.stats["nevent"] >= 100
        assert traj.contact_force.shape[1] == 2
        assert np.any(traj.contact_phase[:, 0]) and np.any(traj.contact_phase[:, 1])
        ys = np.column_stack([traj.coordinates[c] for c in model.COORDINATES]
                             + [traj.rates[c] for c in model.COORDINATES] + [traj.crank_work])
        energy = np.empty(len(traj.t))
        for i, t in enumerate(traj.t):
            p[model.MEM_START::2][:2] = traj.contact_phase[i]
            energy[i] = energy_of(t, ys[i], p)
        change = energy - energy[0]
        scale = np.abs(traj.crank_work).max() + np.abs(change).max()
        errors.append(np.abs(traj.crank_work - change).max() / scale)
    # measured: 2.3e-8 and 2.5e-9
    assert errors[1] < 1e-8 and errors[1] < errors[0] / 3


# ---------------------------------------------------------------- hostile names, cached modules
