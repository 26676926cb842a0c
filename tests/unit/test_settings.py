"""One plain run and one settings record: `linkage_model.run` with `RunSettings`."""

import numpy as np
import pytest

from mbs_clearance import RunSettings, SliderCrank, simulate
from mbs_clearance._checks import MemoryLimitError
from mbs_clearance.laws.forces import CONTACT_MODELS, hysteresis_factor
from mbs_clearance.model import cases
from mbs_clearance.solve import linkage_model as lm
from mbs_clearance.solve import reduced


@pytest.mark.parametrize("field, value, message", [
    ("rtol", 0.5, r"rtol must be a finite number in \[1e-14, 0.01\]"),
    ("method", "rk4", r"method must be one of"),
    ("max_steps", 0, r"max_steps must be"),
    ("h_max", -1.0, r"h_max \(largest step\)"),
    ("n_samples", 5000, r"n_samples \(interior event samples per step\)"),
    ("event_tol", 0.0, r"event_tol"),
    ("atol", -1e-9, r"atol must be a finite number > 0"),
    ("atol", [[1e-9]], r"atol must be a finite number > 0"),
    ("event_control", "yes", r"event_control must be True or False"),
])
def test_a_bad_setting_is_refused_when_the_record_is_made(field, value, message):
    with pytest.raises(ValueError, match=message):
        RunSettings(**{field: value})


def test_a_bad_setting_is_refused_before_any_integration(monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("the integrator ran before the settings were checked")

    monkeypatch.setattr(lm, "integrate", forbidden)
    with pytest.raises(ValueError, match="unknown run setting"):
        lm.run(reduced.linkage_of(SliderCrank()), 1, rtol_typo=1e-8)
    with pytest.raises(ValueError, match="settings must be a RunSettings"):
        simulate(SliderCrank(), 1, settings={"rtol": 1e-8})


def test_the_record_and_the_keywords_give_the_same_run():
    """The record is the keywords' one form: equal runs bit for bit; its non-default fields
    rebuild it."""
    s = RunSettings(rtol=1e-9, method="dop853", n_samples=2)
    assert RunSettings(**s.options()) == s
    assert s.options() == {"rtol": 1e-9, "method": "dop853", "n_samples": 2}
    a = simulate(SliderCrank(), 2, settings=s)
    b = simulate(SliderCrank(), 2, rtol=1e-9, method="dop853", n_samples=2)
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.base_force, b.base_force)
    # a keyword beside the record wins
    c = simulate(SliderCrank(), 2, settings=s, method="dopri5")
    d = simulate(SliderCrank(), 2, rtol=1e-9, n_samples=2)
    np.testing.assert_array_equal(c.base_force, d.base_force)


@pytest.mark.parametrize("mech", [
    SliderCrank(),
    SliderCrank(friction_law="coulomb", friction_coefficient=0.1),
], ids=["dry", "coulomb"])
def test_a_slider_crank_is_its_description_run_from_its_closed_form_start(mech):
    """The paper's parameter set runs as its description: the peaks and counts of
    `reduced.run` are those of `linkage_model.run` of `cases.from_slider_crank` from the
    closed-form centred start, with or without friction (one path); the closed-form start
    and the description's Newton assembly agree to round-off."""
    lk = cases.from_slider_crank(mech)
    start = reduced.centred_start(mech)
    a = reduced.run(mech, 2)
    b = lm.run(lk, 2, start=start)
    np.testing.assert_array_equal(a.peaks, b.peaks)
    assert reduced.counters_dict(a.counters) == {k: b.stats[k] for k in reduced.COUNTERS}
    newton = lm.initial_state(lk)[:4]
    np.testing.assert_allclose(start.y, newton, rtol=1e-12, atol=1e-12)
    # the module named without the generator's lookup is the one the lookup finds
    assert reduced.model_of(mech) is lm.load_model(lk)


def test_a_slider_crank_run_does_not_load_the_generator():
    """The paper's run knows its checked-in module, or its compiled C model from the cache:
    no derivation, so neither the generator nor sympy is imported (about 0.3 s of every
    command's start)."""
    import subprocess
    import sys

    for mech in (SliderCrank(), SliderCrank(friction_law="coulomb", friction_coefficient=0.1)):
        simulate(mech, 1)       # the models built into the cache, as by any earlier run

    code = ("import sys; from mbs_clearance import SliderCrank, simulate; "
            "simulate(SliderCrank(), 1); "
            "simulate(SliderCrank(friction_law='coulomb', friction_coefficient=0.1), 1); "
            "print('sympy' in sys.modules, 'mbs_clearance.generate.derive' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["False", "False"]


def test_damped_law_rate_tolerance_holds_for_every_linkage():
    """A damping-dominated law (xi > DAMPED_XI) puts the penetration rate under error
    control with atol rtol DAMPED_RATE_ATOL / xi c omega, joint by joint; a law with
    small xi leaves it out (inf). Checked on the two-clearance slider-crank with one joint
    changed to Flores' law at e = 0.1."""
    import dataclasses

    lk = cases.CASES["slider_crank_two_clearances"]()
    j0, j1 = lk.clearance_joints
    lk = dataclasses.replace(lk, clearance_joints=(
        dataclasses.replace(j0, contact_model="flores", restitution=0.1), j1))
    model = lm.load_model(lk)
    rtol = 1e-7
    atol = lm.default_atol(lk, model, rtol)
    xi = hysteresis_factor(0.1, CONTACT_MODELS["flores"])[0]
    assert xi > lm.DAMPED_XI
    n = model.N_STATE
    w = lk.drive.speed
    c0 = lk.clearance_joints[0].clearance
    assert atol[n + 1] == pytest.approx(rtol * lm.DAMPED_RATE_ATOL / xi * c0 * w, rel=1e-14)
    assert atol[n] == pytest.approx(rtol * lm.EVENT_ATOL * c0, rel=1e-14)
    assert np.isinf(atol[n + 3])


def test_a_long_linkage_run_is_refused_by_its_pilot(monkeypatch):
    """A run of 16 revolutions or more is estimated by a one-revolution pilot: one that
    cannot fit in max_steps is refused after the pilot alone (one kernel call)."""
    lk = cases.CASES["four_bar"]()
    calls = []
    kernel = lm.integrate

    def counted(*args):
        calls.append(1)
        return kernel(*args)

    monkeypatch.setattr(lm, "integrate", counted)
    with pytest.raises(MemoryLimitError, match="needs about .* steps .* max_steps=20000"):
        lm.run(lk, 40, record=False, max_steps=20_000)
    assert len(calls) == 1


def test_a_slider_crank_trajectory_has_its_description_s_names():
    """The paper's names are aliases on its case: a SliderCrank's Trajectory carries the
    generic series of its description's run (built by the linkage's own code), equal to
    them; base_force is the crank pivot's reaction, slider_position the guide's
    coordinate."""
    mech = SliderCrank()
    a = simulate(mech, 2, rtol=1e-7)
    b = simulate(reduced.linkage_of(mech), 2, rtol=1e-7, start=reduced.centred_start(mech))
    assert a.joints == b.joints == ("coupler_slider",)
    np.testing.assert_array_equal(a.t, b.t)
    for name in ("reactions", "coordinates", "rates", "accelerations"):
        mine, theirs = getattr(a, name), getattr(b, name)
        assert mine.keys() == theirs.keys()
        for k in theirs:
            np.testing.assert_array_equal(mine[k], theirs[k])
    np.testing.assert_array_equal(a.shaking_force, b.shaking_force)
    np.testing.assert_array_equal(a.base_force, b.reactions["crank_pivot"])
    np.testing.assert_array_equal(a.slider_position, b.coordinates["slider_guide.s"])
    np.testing.assert_array_equal(a.contact_force, b.contact_force[:, 0])
