"""A profiled bearing (`ClearanceJoint.bearing_profile`) in the reduced model's compiled C
core: limit cases against the circular joint, the gap against its definition recomputed from
the recorded motion, the contact angle and slip velocity against the friction law's own slip,
the profile as data (no recompilation), and the runs that refuse it."""

import dataclasses
import warnings

import numpy as np
import pytest

from mbs_clearance._warnings import AccuracyWarning
from mbs_clearance.core import build
from mbs_clearance.generate.key import model_structure, structure_digest
from mbs_clearance.model import cases
from mbs_clearance.model.linkage import ClearanceJoint
from mbs_clearance.model.profile import BearingProfile
from mbs_clearance.solve import linkage_model as lm

N = 72
THETA = 2.0 * np.pi * np.arange(N) / N


def profiled(linkage, radii, joint: int = 0, **fields):
    """`linkage` with clearance joint `joint` given the bearing radii `radii` (and
    `fields`)."""
    joints = list(linkage.clearance_joints)
    joints[joint] = dataclasses.replace(joints[joint], bearing_profile=tuple(radii), **fields)
    return linkage.replace(clearance_joints=tuple(joints))


def peaks(linkage, revolutions=2):
    return lm.run(linkage, revolutions, record=False).peaks


def test_a_circular_profile_reproduces_the_circular_joint_and_is_another_model():
    lk = cases.paper_slider_crank()
    cj = lk.clearance_joints[0]
    lp = profiled(lk, [cj.bearing_radius] * N)
    # the spline of equal radii is the constant: the gap, its rate and Eq. 9 are evaluated
    # on the same numbers in the same order, so the runs agree to round-off (in fact bitwise
    # on this machine; 1e-12 leaves room for a compiler's other contraction of the added
    # bearing-angle terms)
    np.testing.assert_allclose(peaks(lp), peaks(lk), rtol=1e-12, atol=0)
    plain, prof = lm.load_model(lk), lm.load_model(lp)
    assert prof is not plain
    assert structure_digest(model_structure(lp)) != structure_digest(model_structure(lk))
    assert prof.PROFILE_POINTS == (N,) and prof.N_P > plain.N_P
    # the circular joint's model prints as it did: no profile in it
    assert not getattr(plain.meta, "PROFILE_JOINTS", ())
    assert "profile_runtime.h" not in plain.source


@pytest.mark.parametrize("stiffness", [None, 4.0e9])
def test_a_uniform_profile_is_the_larger_circular_bearing(stiffness):
    # radii all R_B + w: the circular bearing of radius R_B + w, its Eq. 9 stiffness from
    # R_B + w too (or the explicit stiffness, unchanged)
    lk = cases.paper_slider_crank()
    cj = lk.clearance_joints[0]
    w = 2e-6
    base = lk.replace(clearance_joints=(dataclasses.replace(cj, contact_stiffness=stiffness),))
    lp = profiled(base, [cj.bearing_radius + w] * N)
    wider = base.replace(clearance_joints=(dataclasses.replace(
        base.clearance_joints[0], bearing_radius=cj.bearing_radius + w),))
    got, want = peaks(lp), peaks(wider)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
    # and not the circular bearing of R_B (the profile counts)
    assert abs(got[-1] - peaks(base)[-1]) > 1e-4 * want[-1]


def _swapped(lk):
    """The two-clearance slider-crank with the crank-coupler joint's bearing on the driven
    crank (its journal on the coupler)."""
    cj = lk.clearance_joints[0]
    swapped = dataclasses.replace(cj, journal_body=cj.bearing_body,
                                  journal_point=cj.bearing_point,
                                  bearing_body=cj.journal_body, bearing_point=cj.journal_point)
    return lk.replace(clearance_joints=(swapped, lk.clearance_joints[1]))


def _bearing_angle(traj, linkage, joint):
    """The bearing body's angle (rad) along `traj`, from the recorded coordinates or the
    drive's law (independent of the library's own bookkeeping)."""
    body = linkage.clearance_joints[joint].bearing_body
    if body == "slider":
        return np.zeros_like(traj.t)
    if body == "crank":
        return linkage.drive.speed * traj.t + linkage.drive.initial_angle
    return traj.coordinates[f"{body}.angle"]


@pytest.mark.parametrize("case", ["ground", "coordinate", "drive"])
def test_the_penetration_of_a_non_circular_profile_is_its_definition(case):
    # R_B(theta) = R_B + a cos(2 theta) + b sin(3 theta) (a, b a few micrometres); the bearing
    # on the ground (through the slider's guide), on a body whose angle is a coordinate, or
    # on the driven crank
    lk = (cases.paper_slider_crank() if case == "ground"
          else cases.slider_crank_two_clearances())
    if case == "drive":
        lk = _swapped(lk)
    cj = lk.clearance_joints[0]
    radii = cj.bearing_radius + 3e-6 * np.cos(2 * THETA) + 1.5e-6 * np.sin(3 * THETA)
    lp = profiled(lk, radii)
    with warnings.catch_warnings():
        # the journal on the coupler rattles in the crank's bearing (flagged): the identity
        # checked here holds at every step all the same
        warnings.simplefilter("ignore", AccuracyWarning)
        traj = lm.simulate_linkage(lp, 2)
    e = traj.eccentricity[:, 0, :]
    r = np.hypot(e[:, 0], e[:, 1])
    theta = np.arctan2(e[:, 1], e[:, 0]) - _bearing_angle(traj, lp, 0)
    want = r - (BearingProfile(radii).radius(theta) - cj.journal_radius)
    # beyond half the smallest clearance (every contact): the definition, to the round-off
    # of the spline's evaluation (m, against a clearance of 1e-5 m); nearer the centre the
    # profile fades into a circle (no contact reaches there)
    c_min = np.min(radii) - cj.journal_radius
    outer = r >= 0.5 * c_min
    assert outer.mean() > 0.9
    np.testing.assert_allclose(traj.penetration[outer, 0], want[outer], rtol=0, atol=1e-15)
    assert np.all(traj.penetration[~outer, 0] < -0.4 * c_min)
    # (away from the wrap at 0 = 2 pi, where either side is right)
    turned = np.mod(theta, 2 * np.pi)
    inside = (turned > 1e-9) & (turned < 2 * np.pi - 1e-9)
    np.testing.assert_allclose(traj.contact_angle[inside, 0], turned[inside], rtol=0,
                               atol=1e-12)
    assert np.all((traj.contact_angle >= 0) & (traj.contact_angle < 2 * np.pi))
    assert traj.contact_phase[:, 0].any()          # the contacts were on the profile


@pytest.mark.parametrize("profile", [False, True])
def test_the_slip_velocity_is_the_friction_laws(profile):
    # the friction stage's v_t (the derivation's symbolic spin, in C) against the series
    # computed from the recorded states (the closure's rates and the bodies' angle rates)
    lk = cases.slider_crank_two_clearances(friction_law="coulomb", friction_coefficient=0.05)
    if profile:
        cj = lk.clearance_joints[0]
        lk = profiled(lk, cj.bearing_radius + 4e-6 * np.cos(THETA) + 2e-6 * np.cos(2 * THETA))
    run = lm.run(lk, 1)
    traj = lm.trajectory_from_run(lk, run.model, run.ts, run.ys, run.ms, run.p, run.stats,
                                  run.peaks, run.outs)
    col = {c: i for i, c in enumerate(run.model.OUT_COLUMNS)}
    for j, cj in enumerate(lk.clearance_joints):
        vt = run.outs[:, col[f"{cj.name}.slip_velocity"]]
        scale = np.max(np.abs(vt))
        np.testing.assert_allclose(traj.slip_velocity[:, j], vt, rtol=0, atol=1e-12 * scale)


def test_a_journal_turning_with_its_crank_slides_at_its_surface_speed():
    # closed form: centred journal (e = 0, before any contact) on the driven crank, bearing
    # on the coupler: slip = omega_J R_J - omega_B R_B with the rates at the start
    lk = cases.slider_crank_two_clearances()
    traj = lm.simulate_linkage(lk, 1)
    cj = lk.clearance_joints[0]
    w_b = traj.rates["coupler.angle"][0]
    want = lk.drive.speed * cj.journal_radius - w_b * cj.bearing_radius
    assert traj.slip_velocity[0, 0] == pytest.approx(want, rel=1e-12)


def test_a_new_profile_of_the_same_size_is_data_not_a_new_model():
    lk = cases.paper_slider_crank()
    cj = lk.clearance_joints[0]
    first = peaks(profiled(lk, cj.bearing_radius + 2e-6 * np.cos(THETA)), 1)
    before = build.compile_count()
    second = peaks(profiled(lk, cj.bearing_radius + 4e-6 * np.sin(2 * THETA)), 1)
    assert build.compile_count() == before
    assert abs(second[0] - first[0]) > 1e-6 * first[0]      # the new radii took effect
    # another grid size is another structure
    assert structure_digest(model_structure(profiled(lk, [cj.bearing_radius] * 36))) != \
        structure_digest(model_structure(profiled(lk, [cj.bearing_radius] * N)))


def test_sensitivity_runs_refuse_a_profiled_bearing():
    from mbs_clearance.analysis.lyapunov import lyapunov_exponent
    from mbs_clearance.analysis.periodic import periodic_orbit
    from mbs_clearance.analysis.sensitivity import sensitivities

    lk = cases.paper_slider_crank()
    lp = profiled(lk, [lk.clearance_joints[0].bearing_radius] * N)
    message = r"'coupler_slider' has a bearing_profile, which is not supported by sensitivity"
    for call in (lambda: sensitivities(lp, parameters=["crank.mass"], method="ddm"),
                 lambda: lyapunov_exponent(lp, 2, 1),
                 lambda: periodic_orbit(lp)):
        with pytest.raises(ValueError, match=message):
            call()
    model = lm.load_model(lp)
    with pytest.raises(ValueError, match=message):
        model.jacobian_matrix(0.0, np.zeros(model.N_STATE), lm.pack_parameters(lp, model),
                              False)


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_contact_angle_and_slip_velocity_are_saved_and_loaded(tmp_path, suffix):
    from mbs_clearance.solve.trajectory import load_trajectory

    lk = cases.slider_crank_two_clearances()
    traj = lm.simulate_linkage(profiled(lk, lk.clearance_joints[1].bearing_radius
                                        + 2e-6 * np.cos(THETA), joint=1), 1)
    assert traj.contact_angle.shape == traj.slip_velocity.shape == (len(traj.t), 2)
    back = load_trajectory(traj.save(tmp_path / f"t{suffix}"))
    np.testing.assert_array_equal(back.contact_angle, traj.contact_angle)
    np.testing.assert_array_equal(back.slip_velocity, traj.slip_velocity)
    assert isinstance(back.linkage.clearance_joints[1], ClearanceJoint)
    assert back.linkage.clearance_joints[1].bearing_profile == \
        traj.linkage.clearance_joints[1].bearing_profile


def _energy(linkage, ys, model, spring):
    """Kinetic + gravitational energy (J) of `linkage`'s bodies at the states ys, from the
    revolute and prismatic joints' kinematics walked here (body positions and velocities
    from the coordinates and rates), plus `spring` (n,)."""
    from mbs_clearance.model.linkage import GROUND, Prismatic

    n = model.N_Q
    col = {c: i for i, c in enumerate(model.COORDINATES)}
    zero = np.zeros(len(ys))
    pts = {b.name: b.points for b in linkage.bodies}
    pts[GROUND] = linkage.ground_points
    frame = {GROUND: (zero, zero, zero, zero, zero)}      # x, y, vx, vy, angle rate; angle
    angle = {GROUND: zero}

    def world(body, point):
        """World position and velocity of a body point."""
        x, y, vx, vy, w = frame[body]
        px, py = pts[body][point] if point in pts[body] else (0.0, 0.0)
        c, s = np.cos(angle[body]), np.sin(angle[body])
        rx, ry = c * px - s * py, s * px + c * py
        return x + rx, y + ry, vx - w * ry, vy + w * rx

    energy = spring.copy()
    for body, parent, joint in linkage.tree():
        if body == GROUND:
            continue
        if isinstance(joint, Prismatic):            # the guide's axis from the ground here
            gx, gy, _, _ = world(parent, joint.point_a)
            s, sd = ys[:, col[f"{joint.name}.s"]], ys[:, n + col[f"{joint.name}.s"]]
            angle[body] = angle[parent]
            frame[body] = (gx + s * np.cos(joint.angle), gy + s * np.sin(joint.angle),
                           sd * np.cos(joint.angle), sd * np.sin(joint.angle), zero)
            own = pts[body][joint.point_b]
            assert own == (0.0, 0.0)                # the slider's pin is its centre
        else:
            mine, theirs = ((joint.point_b, joint.point_a) if joint.body_b == body
                            else (joint.point_a, joint.point_b))
            ax, ay, avx, avy = world(parent, theirs)
            th, w = ys[:, col[f"{body}.angle"]], ys[:, n + col[f"{body}.angle"]]
            angle[body] = th
            px, py = pts[body][mine]
            rx, ry = np.cos(th) * px - np.sin(th) * py, np.sin(th) * px + np.cos(th) * py
            frame[body] = (ax - rx, ay - ry, avx + w * ry, avy - w * rx, w)
        b = next(b for b in linkage.bodies if b.name == body)
        x, y, vx, vy, w = frame[body]
        energy += 0.5 * (b.mass * (vx * vx + vy * vy) + b.inertia * w * w) \
            + b.mass * linkage.gravity * y
    return energy


@pytest.mark.parametrize("amplitude", [0.0, 30e-6])
def test_a_free_linkage_keeps_its_energy_on_a_profiled_bearing(amplitude):
    # restitution 1 (no hysteresis damping), no friction, a constant stiffness: the contact
    # force along the gap's gradient is conservative (the bearing is on the slider, which
    # does not turn), so kinetic + potential + K delta^2.5 / 2.5 keeps its value to the
    # integration error. A profile leaning by up to 0.9 (R_B' / c: 90 um/rad against a
    # clearance of 100 um) keeps it as well as the circle: measured largest relative drift
    # over 0.05 s (about 250 contact switches) at rtol 1e-8, 3.6e-7 circular and 2.4e-7
    # profiled (1.1e-5 both at rtol 1e-6); a radial force on the same profile gained 530 %
    from mbs_clearance.model.linkage import Initial

    lk = cases.paper_slider_crank(journal_radius=0.0099, restitution=1.0,
                                  contact_stiffness=1e10)
    lk = lk.replace(name="free_profiled", drive=None, initial=Initial(rates={
        "crank.angle": 300.0}))
    cj = lk.clearance_joints[0]
    radii = cj.bearing_radius + amplitude * (np.cos(2 * THETA) + np.sin(3 * THETA)) / 2
    lp = profiled(lk, radii)
    run = lm.run(lp, duration=0.05, rtol=1e-8)
    assert run.stats["nevent"] > 20                # through the contact, many times
    col = {c: i for i, c in enumerate(run.model.OUT_COLUMNS)}
    delta = np.maximum(run.outs[:, col[f"{cj.name}.penetration"]], 0.0)
    energy = _energy(lp, run.ys, run.model, 1e10 * delta ** 2.5 / 2.5)
    drift = np.max(np.abs(energy - energy[0])) / energy[0]
    assert drift < 2e-6, drift


def test_the_closure_gives_the_eccentricity_rates_the_gaps_give():
    # the loop closure's Jacobian and explicit time rate against the compiled model's gap
    # series, on its recorded steps
    lk = cases.slider_crank_two_clearances()
    run = lm.run(lk, 1)

    class ClosureOnly:
        N_Q = run.model.N_Q

        def closure_jacobian(self, t, q, p):
            return run.model.closure_jacobian(t, q, p)

        def closure_rate(self, t, q, p):
            return run.model.closure_rate(t, q, p)

    rows = slice(0, len(run.ts), 50)
    ts, ys = run.ts[rows], np.ascontiguousarray(run.ys[rows])
    got = lm.eccentricity_rates(ClosureOnly(), ts, ys, run.p, 2)
    want = lm.eccentricity_rates(run.model, ts, ys, run.p, 2)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.max(np.abs(want)))
