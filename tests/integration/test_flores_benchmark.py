"""The translational-clearance benchmark (Flores, Leine & Glocker 2010) against references
that share nothing with the generated model: the nonsmooth Moreau scheme of
validation.moreau (rigid contacts), the energy balance written from the mechanism's own
kinematics (validation.moreau's mass matrix, itself checked against differences of the
bodies' velocities), and Exudyn. The comparisons with the
non-smooth reference, Exudyn and the report compute for 10 s to a minute: slow."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mbs_clearance.model.cases import flores_translational_slider_crank as flg
from mbs_clearance.solve import linkage_model as lm
from validation import moreau as mo

pytestmark = [
              # the rattling corners draw the accuracy note (its advice is about peaks)
              pytest.mark.filterwarnings("ignore::mbs_clearance.AccuracyWarning")]

DATA = mo.FLGData()
T = 0.05        # s: before the slider's tilt separates runs of different tolerance


def _end(run):
    return run.ys[-1, :3], run.ys[-1, 3:6]


@pytest.mark.slow
def test_the_compliant_model_agrees_with_the_nonsmooth_reference():
    """At 0.05 s (after the first flat impacts on both surfaces) the crank's angle and the
    energy of the compliant model (K = 1e10 N/m^1.5) lie within the Moreau scheme's own
    error bar: its result extrapolated from steps of 10 and 5 us (first order), the bar
    the distance of the 5 us result from that. Measured: angle 4.79327 against 4.79357
    (bar 1.6e-3 rad), energy 7.3572 against 7.3588 J (bar 7.9e-3 J)."""
    q, u = _end(lm.run(flg(), duration=T, rtol=1e-10))
    coarse, fine = (mo.run(DATA, t_end=T, h=h, every=1000) for h in (1e-5, 5e-6))
    angle = 2 * fine.q[-1, 0] - coarse.q[-1, 0]
    energy_c, energy_f = (mo.energy(DATA, r.q[-1], r.u[-1]) for r in (coarse, fine))
    energy = 2 * energy_f - energy_c
    assert abs(q[0] - angle) < abs(fine.q[-1, 0] - angle)
    assert abs(mo.energy(DATA, q, u) - energy) < abs(energy_f - energy)
    # both lost energy in the impacts (restitution 0.4): about 2 % by 0.05 s
    e0 = mo.energy(DATA, DATA.q0, DATA.u0)
    assert 0.01 < 1 - mo.energy(DATA, q, u) / e0 < 0.03


def test_compliant_results_converge_as_the_stiffness_grows():
    """The crank's angle at 0.05 s against the stiffest run (1e12 N/m^1.5): moving from
    1e9 to 1e10 and 1e11 closes most of the gap. Measured differences from 1e12: 9.1e-5,
    2.3e-5, 1.3e-5 rad."""
    angle = {K: _end(lm.run(flg(contact_stiffness=K), duration=T, rtol=1e-10))[0][0]
             for K in (1e9, 1e10, 1e11, 1e12)}
    gap = {K: abs(angle[K] - angle[1e12]) for K in (1e9, 1e10, 1e11)}
    assert gap[1e10] < gap[1e9] / 2 and gap[1e11] < gap[1e9] / 2
    assert gap[1e9] < 2e-4                  # all within 0.004 % of the angle


def test_energy_is_conserved_at_restitution_one_without_friction():
    """Flores' law has no damping at e = 1 (xi = 8 (1 - e) / (5 e)); without friction the
    kinetic, gravitational and corners' spring energy (K delta^2.5 / 2.5, delta from
    validation.moreau's corner gaps) stays constant over the benchmark's 0.2 s through
    every impact; its drift falls with rtol. Measured largest drift relative to the
    energy: 4.2e-5 at rtol 1e-7, 1.1e-6 at 1e-9."""
    from mbs_clearance.laws.forces import CONTACT_MODELS, hysteresis_factor

    lk = flg(restitution=1.0, friction_law="none")
    joint = lk.translational_joints[0]
    assert hysteresis_factor(1.0, CONTACT_MODELS[joint.contact_model])[0] == 0.0
    data = dataclasses.replace(DATA, e_n=1.0, mu=0.0)
    drift = {}
    for rtol in (1e-7, 1e-9):
        run = lm.run(lk, duration=0.2, rtol=rtol)
        assert run.stats["nevent"] > 20         # the energy passes through the contacts
        energy = []
        for y in run.ys:
            gaps = mo.corner_gaps(data, y[:3])[0]
            spring = np.sum(joint.stiffness * np.maximum(-gaps, 0.0) ** 2.5 / 2.5)
            energy.append(mo.energy(data, y[:3], y[3:6]) + spring)
        energy = np.asarray(energy)
        drift[rtol] = float(np.max(np.abs(energy - energy[0])) / energy[0])
    assert drift[1e-9] < drift[1e-7] / 5
    assert drift[1e-9] < 3e-6


@pytest.mark.slow
@pytest.mark.exudyn
def test_reduced_against_exudyn_on_the_benchmark():
    """The same description in Exudyn (absolute coordinates, ideal joints as constraints,
    the corners a generic element, fixed steps) through the first flat impact on the upper
    surface and the flight down (0 to 20 ms): the crank's angle and rate agree, the
    closer the finer Exudyn's step (second order)."""
    from mbs_clearance import simulate

    lk = flg()
    red = simulate(lk, duration=0.02, rtol=1e-10)
    touch = red.t[np.argmax(red.contact_phase[:, :2].any(axis=1))]     # about 2.69 ms
    errors, rate_errors = [], []
    for h in (4e-6, 1e-6):
        ex = simulate(lk, backend="exudyn", duration=0.02, step_size=h)
        # Exudyn's fine steps interpolated at the reduced model's samples (the other way
        # round, the reduced samples' spacing would set the difference)
        angle = np.interp(red.t, ex.t, ex.coordinates["crank.angle"])
        errors.append(float(np.max(np.abs(angle - red.coordinates["crank.angle"]))))
        rate = np.interp(red.t, ex.t, ex.rates["crank.angle"])
        rate_errors.append(float(np.max(np.abs(rate - red.rates["crank.angle"]))))
        # the top corners touch first, at the same time within Exudyn's step
        first = ex.t[np.argmax(ex.contact_phase[:, :2].any(axis=1))]
        assert first == pytest.approx(touch, abs=2 * h)
    # measured: angle 2.0e-6, 2.3e-7 rad; rate 3.6e-2, 4.0e-3 rad/s (of 150)
    assert errors[1] < errors[0] / 4 and errors[1] < 1e-6
    assert rate_errors[1] < rate_errors[0] / 4 and rate_errors[1] < 1e-2


@pytest.mark.slow
def test_report_of_the_benchmark_from_the_command_line(tmp_path, capsys):
    """`mbs-clearance report --case flores_translational_slider_crank --quick`: the free
    linkage's report; its numbers are the library's (the window peaks of `simulate`, the
    Moreau runs of validation.moreau and their first-order extrapolation) and the HTML
    carries the benchmark's section with its three figures."""
    import json

    from mbs_clearance import simulate
    from mbs_clearance.cli import main

    out = tmp_path / "report"
    assert main(["report", "--case", "flores_translational_slider_crank", "--quick",
                 "--out", str(out)]) == 0
    n = json.loads((out / "report.json").read_text())
    T = n["response"]["duration"]
    traj = simulate(flg(), duration=T, window=T / 4, rtol=1e-10)
    assert n["response"]["peaks"] == pytest.approx(list(traj.peaks), rel=1e-12)
    b = n["benchmark"]
    coarse, fine = (b["moreau"][f"{h:g}"]["crank_angle"] for h in b["steps"])
    assert b["moreau_extrapolated"]["crank_angle"] == pytest.approx(2 * fine - coarse,
                                                                    rel=1e-12)
    h = b["steps"][-1]
    assert b["moreau"][f"{h:g}"]["crank_angle"] == pytest.approx(
        mo.run(DATA, t_end=T, h=h, every=round(T / h)).q[-1, 0], rel=1e-12)
    whole = simulate(flg(), duration=T, rtol=1e-10)       # one window, as the benchmark's
    assert b["compliant"]["crank_angle"] == pytest.approx(
        whole.coordinates["crank.angle"][-1], rel=1e-12)
    html = (out / "report.html").read_text()
    assert "Against the nonsmooth reference" in html
    assert html.count("data:image/png;base64") == 4
