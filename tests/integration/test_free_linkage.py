"""Free (undriven) linkages against independent references.

The mechanism: the slider-crank of Flores, Leine and Glocker's free benchmark (Multibody
Syst Dyn 23 (2010) 165-190: crank 0.153 m, coupler 0.306 m, masses 0.038, 0.038, 0.076 kg,
inertias 7.4e-5, 5.9e-4, 2.7e-6 kg m^2, gravity 9.81, the crank started at 150 rad/s and the
coupler at -75 rad/s with every angle zero), with a revolute clearance joint at the
coupler-slider pin. References: the energy balance (written here from the closed-form
kinematics, not from the generated model), the ideal slider-crank's one-degree-of-freedom
Lagrange equation integrated by scipy, and Exudyn.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mbs_clearance import simulate
from mbs_clearance.model.linkage import (
    GROUND,
    Body,
    ClearanceJoint,
    Initial,
    Linkage,
    Prismatic,
    Revolute,
)
from mbs_clearance.solve import linkage_model as lm

L1, L2 = 0.153, 0.306
M1, M2, M3 = 0.038, 0.038, 0.076
J1, J2, J3 = 7.4e-5, 5.9e-4, 2.7e-6
G = 9.81


def free_slider_crank(clearance=1e-4, restitution=1.0, stiffness=None) -> Linkage:
    """The free slider-crank with a clearance joint of radial `clearance` (m) at the pin."""
    rb = 0.01
    return Linkage(
        name="free_slider_crank",
        bodies=(Body("crank", M1, J1, {"pivot": (-L1 / 2, 0.0), "pin": (L1 / 2, 0.0)}),
                Body("coupler", M2, J2, {"crank_end": (-L2 / 2, 0.0),
                                         "slider_end": (L2 / 2, 0.0)}),
                Body("slider", M3, J3, {"pin": (0.0, 0.0)})),
        joints=(Revolute("crank_pivot", GROUND, "crank_pivot", "crank", "pivot"),
                Revolute("crank_coupler", "crank", "pin", "coupler", "crank_end"),
                Prismatic("slider_guide", GROUND, "slider_axis", "slider", "pin")),
        clearance_joints=(ClearanceJoint(
            "coupler_slider", "coupler", "slider_end", "slider", "pin", bearing_radius=rb,
            journal_radius=rb - clearance, restitution=restitution,
            contact_stiffness=stiffness),),
        drive=None,
        ground_points={"crank_pivot": (0.0, 0.0), "slider_axis": (0.0, 0.0)},
        gravity=G, monitor_joint="crank_pivot",
        assembly={"slider_guide.s": L1 + L2},
        initial=Initial(coordinates={"crank.angle": 0.0, "coupler.angle": 0.0},
                        rates={"crank.angle": 150.0, "coupler.angle": -75.0}))


def closed_form_energy(ys: np.ndarray, joint: ClearanceJoint) -> np.ndarray:
    """Kinetic + gravitational + contact spring energy (K delta^2.5 / 2.5) in J of the
    states [crank angle, coupler angle, s, their rates], from the slider-crank's kinematics
    written out (crank pivot at the origin, slider on the x axis, centres at midpoints)."""
    th1, th2, s, w1, w2, sd = ys[:, :6].T
    c1, s1, c2, s2 = np.cos(th1), np.sin(th1), np.cos(th2), np.sin(th2)
    vx2 = -L1 * s1 * w1 - L2 / 2 * s2 * w2
    vy2 = L1 * c1 * w1 + L2 / 2 * c2 * w2
    kinetic = 0.5 * (M1 * (L1 / 2 * w1) ** 2 + J1 * w1 ** 2 + M2 * (vx2 ** 2 + vy2 ** 2)
                     + J2 * w2 ** 2 + M3 * sd ** 2)
    potential = G * (M1 * L1 / 2 * s1 + M2 * (L1 * s1 + L2 / 2 * s2))
    ex, ey = L1 * c1 + L2 * c2 - s, L1 * s1 + L2 * s2
    delta = np.maximum(np.hypot(ex, ey) - joint.clearance, 0.0)
    return kinetic + potential + joint.stiffness * delta ** 2.5 / 2.5


# (the short run's contact onsets draw the settling note, whose advice is about peaks)
@pytest.mark.filterwarnings("ignore::mbs_clearance.AccuracyWarning")
def test_initial_state_holds_the_given_start_and_solves_the_rest():
    # the slider's position from the closure (journal centred), its rate from the velocity
    # constraint: at zero angles the pin moves vertically only, so ds/dt = 0
    lk = free_slider_crank()
    y0 = lm.initial_state(lk)
    assert y0[:6] == pytest.approx([0.0, 0.0, L1 + L2, 150.0, -75.0, 0.0], abs=1e-12)
    traj = simulate(lk, duration=2e-3, rtol=1e-8)
    assert traj.crank_moment is None and traj.crank_work is None
    assert "drive_moment" not in lm.load_model(lk).OUT_COLUMNS
    assert traj.coordinates["crank.angle"][0] == 0.0
    assert traj.rates["crank.angle"][0] == 150.0


def test_energy_is_conserved_at_restitution_one_and_its_error_falls_with_rtol():
    # Lankarani-Nikravesh at e = 1 has no hysteresis damping (xi = 3 (1 - e^2) / 4 = 0),
    # no friction: kinetic + potential + contact energy is constant. Measured largest
    # relative drift over 0.05 s (about 430 contact switches): 7.0e-5 at rtol 1e-6,
    # 8.8e-6 at 1e-7, 1.9e-6 at 1e-8, 3.7e-7 at 1e-9
    from mbs_clearance.laws.forces import CONTACT_MODELS, hysteresis_factor

    lk = free_slider_crank(clearance=1e-4, restitution=1.0)
    joint = lk.clearance_joints[0]
    assert hysteresis_factor(1.0, CONTACT_MODELS[joint.contact_model])[0] == 0.0
    drift = {}
    for rtol in (1e-6, 1e-7, 1e-9):
        run = lm.run(lk, duration=0.05, rtol=rtol)
        assert run.stats["nevent"] > 100          # the energy passes through the contact
        energy = closed_form_energy(run.ys, joint)
        drift[rtol] = float(np.max(np.abs(energy - energy[0])) / energy[0])
    assert drift[1e-6] < 3e-4
    assert drift[1e-7] < drift[1e-6] / 3
    assert drift[1e-9] < drift[1e-7] / 5
    assert drift[1e-9] < 2e-6


def _ideal_crank_angle(duration: float):
    """The ideal slider-crank's crank angle (dense, a function of t): Lagrange's equation
    of its one degree of freedom, M(th) th'' + M'(th) th'^2 / 2 + V'(th) = 0, with the
    generalized mass M and potential V written out, integrated by scipy at rtol 1e-12."""
    from scipy.integrate import solve_ivp

    def mass_potential(th):
        s, c = math.sin(th), math.cos(th)
        th2 = math.asin(-L1 * s / L2)
        d2 = -L1 * c / (L2 * math.cos(th2))                 # d th2 / d th
        vx2 = -L1 * s - L2 / 2 * math.sin(th2) * d2         # coupler centre / th'
        vy2 = L1 * c + L2 / 2 * math.cos(th2) * d2
        dx = -L1 * s - L2 * math.sin(th2) * d2              # slider / th'
        mass = M1 * L1 ** 2 / 4 + J1 + M2 * (vx2 ** 2 + vy2 ** 2) + J2 * d2 ** 2 + M3 * dx ** 2
        return mass, G * (M1 * L1 / 2 * s + M2 * (L1 * s + L2 / 2 * math.sin(th2)))

    def rhs(t, y):
        th, w = y
        h = 1e-6
        dm = (mass_potential(th + h)[0] - mass_potential(th - h)[0]) / (2 * h)
        dv = (mass_potential(th + h)[1] - mass_potential(th - h)[1]) / (2 * h)
        return [w, -(0.5 * dm * w * w + dv) / mass_potential(th)[0]]

    sol = solve_ivp(rhs, (0.0, duration), [0.0, 150.0], rtol=1e-12, atol=1e-12,
                    dense_output=True)
    return lambda t: sol.sol(t)[0]


def test_tiny_clearance_approaches_the_ideal_slider_crank():
    # measured largest crank-angle difference over 0.05 s (1.2 turns, rtol 1e-8,
    # restitution 0.9): 1.5e-3 rad at clearance 1e-5 m (K 1e12), 2.0e-4 at 1e-6 m
    # (1e12), 2.6e-5 at 1e-7 m (1e13): linear in the clearance
    duration = 0.05
    ideal = _ideal_crank_angle(duration)
    errors = []
    for clearance, stiffness in ((1e-5, 1e12), (1e-6, 1e12), (1e-7, 1e13)):
        run = lm.run(free_slider_crank(clearance, 0.9, stiffness), duration=duration,
                     rtol=1e-8)
        errors.append(float(np.max(np.abs(run.ys[:, 0] - ideal(run.ts)))))
    assert errors[2] < 6e-5
    assert errors[1] < errors[0] / 4 and errors[2] < errors[1] / 4


@pytest.mark.exudyn
def test_reduced_against_exudyn_on_a_free_linkage():
    # measured over 0.02 s (restitution 0.9, about 60 contact switches; Exudyn's default
    # step 5.2e-6 s, reduced rtol 1e-9): coordinates within 3.7e-4 rad (crank), 4.3e-4 rad
    # (coupler), 3.9e-5 m (slider) against ranges of 1.6 rad, 0.52 rad and 0.2 m
    pytest.importorskip("exudyn")
    lk = free_slider_crank(restitution=0.9)
    ex = simulate(lk, backend="exudyn", duration=0.02, window=0.01)
    rd = simulate(lk, duration=0.02, window=0.01, rtol=1e-9)
    assert ex.crank_moment is None and len(ex.peaks) == len(rd.peaks) == 2
    limits = {"crank.angle": 1e-3, "coupler.angle": 1e-3, "slider_guide.s": 1e-4}
    for name, limit in limits.items():
        assert ex.coordinates[name][0] == pytest.approx(rd.coordinates[name][0], abs=1e-12)
        diff = np.interp(ex.t, rd.t, rd.coordinates[name]) - ex.coordinates[name]
        assert np.max(np.abs(diff)) < limit, name
