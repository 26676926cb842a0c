"""Friction in the clearance joints on the generated reduced model: a zero
coefficient reproduces the frictionless run bit for bit, the energy balance closes with the
friction work, a closed-form case of the tangential law (a journal pressed by its weight on
a rotating bearing), friction changes the paper case's peak by more than the integration
error at a pinned cost, and the DDM sensitivities to the friction parameters equal central
finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mbs_clearance import peak_base_force, simulate
from mbs_clearance.analysis.sensitivity import sensitivities
from mbs_clearance.generate.energy import mechanical_energy
from mbs_clearance.model import cases
from mbs_clearance.model.linkage import (
    GROUND,
    Body,
    ClearanceJoint,
    Drive,
    Linkage,
    Prismatic,
    Revolute,
)

FRICTION = {"friction_law": "ambrosio", "friction_coefficient": 0.1}


def test_zero_coefficient_reproduces_the_frictionless_run():
    """mu = 0 with a law on runs the friction model (its own generated module, with the
    friction work in the state) and gives the frictionless run's steps and peaks bit for
    bit; the friction work stays 0."""
    plain = simulate(cases.paper_slider_crank(), 2)
    zero = simulate(cases.paper_slider_crank(friction_law="ambrosio",
                                             friction_coefficient=0.0), 2)
    assert zero.friction_work is not None and plain.friction_work is None
    assert zero.stats["nfev"] == plain.stats["nfev"]
    assert np.array_equal(zero.peaks, plain.peaks)
    assert np.array_equal(zero.t, plain.t)
    assert np.array_equal(zero.base_force, plain.base_force)
    assert np.all(zero.friction_work == 0.0)


def test_friction_changes_the_peak_at_pinned_cost():
    """mu = 0.1 (Ambrosio's law) moves the paper case's rev-4 peak of the monitored force by
    more than 10 times its integration error (rtol 1e-7 against 1e-9; measured: 0.44 % moved,
    an error of about 1e-6), and costs at most 1.1 times the frictionless run's evaluations
    (measured 1.01; the issue's budget is 1.3 times the time)."""
    base = cases.paper_slider_crank()
    fric = cases.paper_slider_crank(**FRICTION)
    plain = simulate(base, 4)
    run = simulate(fric, 4)
    fine = peak_base_force(fric, 4, rtol=1e-9)
    error = abs(run.peaks[3] - fine)
    change = abs(run.peaks[3] - plain.peaks[3])
    assert change > 10 * error, (change, error)
    assert change > 1e-3 * plain.peaks[3]
    assert run.stats["nfev"] <= 1.1 * plain.stats["nfev"], (run.stats["nfev"],
                                                            plain.stats["nfev"])
    # friction dissipates: its work grows monotonically (power -Ft vt >= 0)
    assert np.all(np.diff(run.friction_work) >= -1e-12 * run.friction_work[-1])
    assert run.friction_work[-1] > 0.0


def _energy(lk, traj):
    """Kinetic + gravity + contact-spring energy at the recorded states, from the generated
    model's energy kernel (contact mode from the recorded phase)."""
    from mbs_clearance.generate import load_model
    from mbs_clearance.solve.linkage_model import pack_parameters

    model = load_model(lk)
    energy_of = mechanical_energy(lk)
    p = pack_parameters(lk, model)
    q = np.stack([traj.coordinates[c] for c in model.COORDINATES], axis=1)
    qd = np.stack([traj.rates[c] for c in model.COORDINATES], axis=1)
    y = np.ascontiguousarray(np.concatenate([q, qd], axis=1))
    out = np.empty(len(traj.t))
    for i in range(len(traj.t)):
        for j in range(model.N_EVENTS):
            p[model.MEM_START + 2 * j] = float(traj.contact_phase[i, j])
        out[i] = energy_of(traj.t[i], y[i], p)
    return out


@pytest.mark.slow   # two energy balances at tight rtol, 5 s
@pytest.mark.parametrize("case, revolutions", [
    (lambda: cases.paper_slider_crank(restitution=1.0, **FRICTION), 2),
    (lambda: cases.slider_crank_two_clearances(restitution=1.0, **FRICTION), 2),
], ids=["paper_slider_crank", "slider_crank_two_clearances"])
def test_energy_balance_with_friction(case, revolutions):
    """With restitution 1 the contact law is conservative: the drive's work W equals the
    change of mechanical energy plus the friction work Wf (both quadratures in the state),
    to 1e-8 of max |W|; friction takes a sizeable part of it."""
    lk = case()
    traj = simulate(lk, revolutions, rtol=1e-11)
    energy = _energy(lk, traj)
    W, Wf = traj.crank_work, traj.friction_work
    scale = np.max(np.abs(W))
    err = np.max(np.abs(W - (energy - energy[0]) - Wf))
    assert err < 1e-8 * scale, f"energy balance off by {err / scale:.2e} of max |W|"
    assert Wf[-1] > 1e-3 * scale            # the balance needs the friction term
    assert traj.contact_phase.any()


def _rotating_bearing(law, mu, v0=1e-4, v1=1e-2, speed=20.0):
    """A wheel (the bearing, radius 10 mm, 0.01 mm clearance) turned at `speed` about its
    centre, and a 1 kg pin (the journal) on a vertical guide through the same centre: the
    pin falls on the bearing's bottom and rests there, pressed by its weight."""
    return Linkage(
        name="rotating_bearing",
        # (a rim point and a pin end give the bodies their length scales: tolerances)
        bodies=(Body("wheel", 2.0, 1e-3, {"c": (0.0, 0.0), "rim": (0.05, 0.0)}),
                Body("pin", 1.0, 1e-4, {"c": (0.0, 0.0), "end": (0.0, 0.05)})),
        joints=(Revolute("spin", GROUND, "o", "wheel", "c"),
                Prismatic("guide", GROUND, "o", "pin", "c", angle=math.pi / 2)),
        clearance_joints=(ClearanceJoint(
            "bearing", "pin", "c", "wheel", "c", bearing_radius=0.01, journal_radius=0.00999,
            restitution=0.1, contact_model="flores", friction_law=law,
            friction_coefficient=mu, friction_v0=v0, friction_v1=v1),),
        drive=Drive("spin", speed), ground_points={"o": (0.0, 0.0)}, gravity=9.81,
        monitor_joint="spin")


@pytest.mark.parametrize("law", ["ambrosio", "coulomb"])
def test_journal_on_a_rotating_bearing(law):
    """Closed form of the tangential law: the journal rests on the bottom of a bearing that
    turns at omega (n = (0, -1), slip velocity -omega R_B); the friction force mu Fn phi
    drags it along and the drive must supply the moment R_B mu Fn |phi| at every instant
    (the wheel turns at constant speed, its centre of mass on its axis): |phi| = 1 beyond
    Ambrosio's v1, omega R_B / sqrt((omega R_B)^2 + v0^2) for the regularised Coulomb law.
    Once the journal has settled, Fn = m g, the moment mu m g R_B, and the friction work
    is all of the drive's."""
    mu, speed, rb, v0 = 0.2, 20.0, 0.01, 0.05
    lk = _rotating_bearing(law, mu, v0=v0, v1=0.1, speed=speed)
    traj = simulate(lk, 2, rtol=1e-9)
    slip = speed * rb
    phi = 1.0 if law == "ambrosio" else slip / math.hypot(slip, v0)
    fn = traj.contact_force[:, 0]
    expected = mu * rb * phi * fn
    scale = mu * rb * 9.81
    assert np.max(np.abs(traj.crank_moment - expected)) < 1e-9 * scale
    late = traj.t > 0.5 * traj.t[-1]
    assert np.all(traj.contact_phase[late, 0] == 1)           # settled on the wall
    assert np.mean(fn[late]) == pytest.approx(9.81, rel=1e-3)
    assert np.mean(traj.crank_moment[late]) == pytest.approx(mu * 9.81 * rb * phi, rel=1e-3)
    # the drive's work all goes into friction (the wheel keeps its energy; the pin's fall
    # through the clearance and its settling are vertical, the drive does no work on them)
    assert traj.friction_work[-1] == pytest.approx(traj.crank_work[-1], rel=1e-8)


def _compare(a, b, what, rel):
    scale = np.max(np.abs(b), axis=0, keepdims=True)
    err = np.abs(a - b) / np.maximum(scale, 1e-300)
    assert np.all(err <= rel), (what, err.max(axis=0))


@pytest.mark.parametrize("overrides, names", [
    ({"friction_law": "coulomb", "friction_coefficient": 0.1, "friction_v0": 0.2,
      "friction_v1": 1.0},
     ("coupler_slider.friction_coefficient", "coupler_slider.journal_radius",
      "coupler_slider.friction_v0")),
    ({"friction_law": "ambrosio", "friction_coefficient": 0.1, "friction_v0": 0.02,
      "friction_v1": 3.0},
     ("coupler.mass", "coupler_slider.friction_v0", "coupler_slider.friction_v1")),
], ids=["coulomb", "ambrosio"])
def test_friction_ddm_matches_finite_differences(overrides, names):
    """DDM on the generated Jacobians with friction (rtol 1e-10) against central differences
    (rtol 1e-12) at 12 times of a quarter revolution with contact events, for the friction
    coefficient, the thresholds (set at the slip velocity's scale, ~1 m/s, where they act),
    a radius (the contact point's lever) and a mass."""
    linkage = cases.paper_slider_crank(**overrides)
    t_eval = np.linspace(0.0, 0.25 * linkage.period, 13)[1:]
    ddm = sensitivities(linkage, names, revolutions=1, t_eval=t_eval, rtol=1e-10)
    assert ddm.stats["nevent"] >= 2, ddm.stats
    for k, name in enumerate(names):
        assert np.max(np.abs(ddm.base_force[:, :, k])) > 0.0, name
    # (the thresholds act weakly: at a relative step of 1e-5 their differences are at the
    # plain runs' noise, measured against DDM 5.8e-4 (Coulomb v0) and 4.4e-2 (Ambrosio v0)
    # off, at 1e-4 7.6e-5 and 5.9e-3, at 1e-3 4.9e-6 and 7.5e-5 (1.2e-4 and 2.5e-4 for
    # Ambrosio's v0 and v1 beside other directions): converging to DDM, the differences are
    # the limit there; the other parameters at 1e-5, where 1e-3 has truncation error).
    # The weak ones are compared within 1e-3 (not 5e-4): with the event
    # search's margin of 0.001 c the difference quotient of Ambrosio's v0 at 1e-3 is off
    # DDM by 5.5e-4 on coupler.angle (8.1e-5 with 0.05 c), while at 3e-3 it agrees within
    # 2.2e-5 (1.0e-4 with 0.05 c), measured: the noise is the
    # differences', the DDM's derivative is the same to 1e-4 either way
    strong = [k for k, n in enumerate(names) if "friction_v" not in n]
    weak = [k for k, n in enumerate(names) if "friction_v" in n]
    for idx, step, rel in ((strong, 1e-5, 2e-4), (weak, 1e-3, 1e-3)):
        fd = sensitivities(linkage, [names[k] for k in idx], revolutions=1, method="fd",
                           t_eval=t_eval, rtol=1e-12, fd_relative_step=step)
        for c in linkage.coordinates():
            _compare(ddm.outputs[c][:, idx], fd.outputs[c], c, rel)
        _compare(ddm.base_force[:, 0][:, idx], fd.base_force[:, 0], "reaction x", 10 * rel)
        _compare(ddm.base_force[:, 1][:, idx], fd.base_force[:, 1], "reaction y", 10 * rel)
        if idx is strong:        # (the thresholds' differences of it: 6.6e-3 off, noise)
            col = "coupler_slider.friction_force"
            _compare(ddm.outputs[col][:, idx], fd.outputs[col], col, 10 * rel)
