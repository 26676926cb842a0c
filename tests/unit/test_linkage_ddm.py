"""DDM sensitivities of any Linkage (linkage_ddm, on the generated Jacobians) against central
finite differences of plain runs, per named case, on short runs with contact events; and a
SliderCrank's fields as directions in its description's parameters."""

import numpy as np
import pytest

from mbs_clearance.analysis.sensitivity import sensitivities
from mbs_clearance.model import cases
from mbs_clearance.model.mechanism import SliderCrank


def _paper_ddm(mech, names, *, revolutions, derivatives=False):
    """The DDM run of the paper's fields `names` through the one path: the case's door, the
    fields' directions, the prepared sensitivity problem."""
    from mbs_clearance.analysis.sensitivity import field_directions_of
    from mbs_clearance.solve import linkage_ddm
    from mbs_clearance.solve.settings import RunSettings

    entry = cases.door(mech)
    settings = RunSettings(method=linkage_ddm.DDM_INTEGRATOR)
    sp = linkage_ddm.prepare_sensitivity(entry.linkage, names, revolutions, settings,
                                         directions=field_directions_of(entry.paper, names))
    return linkage_ddm.ddm_run(sp, derivatives=derivatives)

#: per case: parameters (at least 4, of bodies, joints and the drive) and the end of the run
#: as a fraction of a revolution (the four-bar: its first impacts, the journal falling
#: through its clearance under gravity at 10 rpm; the run ends between two impacts)
CASES = {
    "paper_slider_crank": (("coupler.mass", "coupler_slider.bearing_radius", "drive.speed",
                            "coupler_slider.restitution", "crank.pin.x"), 0.25),
    "slider_crank_two_clearances": (("slider.mass", "crank_coupler.journal_radius",
                                     "coupler_slider.youngs_modulus", "coupler.inertia",
                                     "crank_coupler.restitution"), 0.25),
    "four_bar": (("rocker.inertia", "coupler_rocker.bearing_radius", "coupler.mass",
                  "coupler_rocker.restitution", "drive.initial_angle"), 0.0035),
}


def _compare(a, b, what, rel):
    """|a - b| within rel of b's largest magnitude over time, per parameter."""
    scale = np.max(np.abs(b), axis=0, keepdims=True)
    err = np.abs(a - b) / np.maximum(scale, 1e-300)
    assert np.all(err <= rel), (what, err.max(axis=0))


@pytest.mark.parametrize("case", [
    "paper_slider_crank",
    "slider_crank_two_clearances",
    "four_bar",
])
def test_ddm_matches_finite_differences(case):
    """d(coordinates)/db and d(monitored reaction)/db of DDM (rtol 1e-10) equal central
    differences of plain runs (rtol 1e-12) at 12 times of a run with contact events, for
    every parameter; the run has at least two contact onsets."""
    # (the four-bar at the 0.1 mm clearance where the tolerances below were measured; its
    # default became 0.01 mm in the same session, where DOPRI5 meets chattering events)
    linkage = getattr(cases, case)(**({"clearance": 1e-4} if case == "four_bar" else {}))
    names, frac = CASES[case]
    t_eval = np.linspace(0.0, frac * linkage.period, 13)[1:]
    # (the four-bar's journal grazes after its first impacts: DOP853 at rtol 1e-10 lands on
    # repeated zero-length events there, DOPRI5 does not)
    ddm = sensitivities(linkage, names, revolutions=1, t_eval=t_eval, rtol=1e-10,
                        integrator="dopri5" if case == "four_bar" else None)
    # (the four-bar's parameters move it little in 21 ms: at a relative step of 1e-5 the
    # differences are at the integration's noise (rocker.inertia 1.6 % off, measured), at
    # 1e-4 they agree with DDM at rtol 1e-9 ... 1e-11 to 1e-4)
    fd = sensitivities(linkage, names, revolutions=1, method="fd", t_eval=t_eval,
                       rtol=1e-12, fd_relative_step=1e-4 if case == "four_bar" else 1e-5)
    assert ddm.stats["nevent"] >= 2, ddm.stats
    assert ddm.outputs is not None and ddm.base_force.shape == (12, 2, len(names))
    # (the four-bar's finite differences are the limit: between the relative steps 1e-4 and
    # 1e-5 they differ by up to 1.6 % at the end, while DDM at rtol 1e-9, 1e-10, 1e-11
    # agrees with itself to 1e-4; measured DDM - FD(1e-4): 3.9e-4 of the largest magnitude)
    rel = 1e-3 if case == "four_bar" else 2e-4
    for c in linkage.coordinates():
        _compare(ddm.outputs[c], fd.outputs[c], c, rel)
    _compare(ddm.base_force[:, 0], fd.base_force[:, 0], "reaction x", 2e-3)
    _compare(ddm.base_force[:, 1], fd.base_force[:, 1], "reaction y", 2e-3)


def test_ddm_along_zero_valued_geometry_runs_on_the_general_model():
    """Along parameters that are exactly zero in the description (a pin on the coupler's
    axis, the guide raised or turned), on which the checked-in module is
    specialised, DDM and the finite differences run on the general module and agree as in
    the test above (same tolerances); a run along other parameters keeps the specialised
    one."""
    from mbs_clearance.solve.linkage_ddm import prepare_sensitivity
    from mbs_clearance.solve.linkage_model import specialisable

    linkage = cases.paper_slider_crank()
    names = ("coupler.slider_end.y", "ground.slider_axis.y", "slider_guide.angle", "crank.pin.x")
    assert not specialisable(linkage, names) and specialisable(linkage, names[3:])
    assert prepare_sensitivity(linkage, names[3:], 1).problem.model.ZERO_PARAMETERS
    assert not getattr(prepare_sensitivity(linkage, names, 1).problem.model,
                       "ZERO_PARAMETERS", ())
    t_eval = np.linspace(0.0, 0.25 * linkage.period, 13)[1:]
    ddm = sensitivities(linkage, names, revolutions=1, t_eval=t_eval, rtol=1e-10)
    fd = sensitivities(linkage, names, revolutions=1, method="fd", t_eval=t_eval,
                       rtol=1e-12, fd_relative_step=1e-5)
    assert ddm.stats["nevent"] >= 2, ddm.stats
    assert np.all(np.max(np.abs(fd.base_force), axis=0) > 0)
    for c in linkage.coordinates():
        _compare(ddm.outputs[c], fd.outputs[c], c, 2e-4)
    _compare(ddm.base_force[:, 0], fd.base_force[:, 0], "reaction x", 2e-3)
    _compare(ddm.base_force[:, 1], fd.base_force[:, 1], "reaction y", 2e-3)


@pytest.mark.parametrize("mech", [SliderCrank(), SliderCrank(crank_inertia=None,
                                                             contact_stiffness=3e11),
                                  SliderCrank(friction_law="ambrosio",
                                              friction_coefficient=0.05)],
                         ids=["paper", "derived_inertias", "friction"])
def test_field_directions_are_the_derivatives_of_its_description(mech):
    """A SliderCrank's DDM runs on its description's parameters: the direction of each
    field (`mechanism.field_directions`, exact) equals central differences of the mapping
    `cases.from_slider_crank` for every parameter of the description (the mapping is at most
    quadratic in a field: central differences are exact to round-off), the description's
    own chain (radii and material into the stiffness) excepted: a derived stiffness is the
    description's, not the field map's."""
    from mbs_clearance.model.cases import from_slider_crank
    from mbs_clearance.model.mechanism import (
        CONTINUOUS_FIELDS,
        field_directions,
        reference_value,
    )

    base = from_slider_crank(mech)
    names = base.parameter_names()
    dirs = field_directions(mech, CONTINUOUS_FIELDS)
    for field, direction in zip(CONTINUOUS_FIELDS, dirs):
        b0 = reference_value(mech, field)
        h = 1e-4 * (b0 if b0 != 0.0 else 1.0)
        if field in ("journal_radius", "bearing_radius"):
            h = 1e-3 * mech.clearance
        # one-sided at a friction coefficient's lower bound (mu = 0 or mu_s = 0: the
        # mapping is linear there, exact)
        steps = (0, 1) if field.endswith("_coefficient") and b0 == 0.0 else (-1, 1)
        lo, hi = (from_slider_crank(mech.replace(**{field: b0 + s * h})) for s in steps)
        for name in names:
            if name.endswith(".contact_stiffness") and mech.contact_stiffness is None:
                continue        # Eq. 9 of the radii and material: the description's chain
            fd = (hi.parameter_value(name) - lo.parameter_value(name)) / ((steps[1] - steps[0]) * h)
            scale = max(abs(base.parameter_value(name)) / max(abs(b0), 1e-300), 1e-12)
            assert direction.get(name, 0.0) == pytest.approx(fd, rel=1e-7, abs=1e-9 * scale), \
                (field, name)


def test_linkage_parameters_checked():
    """Unknown or repeated parameter names of a Linkage are a ValueError naming them."""
    linkage = cases.four_bar()
    with pytest.raises(ValueError, match="unknown parameter 'rocker.length'"):
        sensitivities(linkage, ["rocker.length"])
    with pytest.raises(ValueError, match="must not repeat"):
        sensitivities(linkage, ["rocker.mass", "rocker.mass"])


def test_ddm_cost_pinned():
    """The paper case's DDM for 8 parameters (4 revolutions, DOP853) takes at most 1.4 times
    the right-hand side evaluations of the plain run (DOPRI5) at the same rtol (measured
    75706 against 59959: 1.26); the cost per evaluation is measured by
    benchmarks/linkage_ddm_speed.py."""
    from mbs_clearance.solve.linkage_model import run

    linkage = cases.paper_slider_crank()
    names = ("crank.pin.x", "coupler.slider_end.x", "coupler.mass", "slider.mass",
             "coupler_slider.contact_stiffness", "coupler_slider.youngs_modulus",
             "coupler_slider.journal_radius", "coupler_slider.restitution")
    plain = run(linkage, 4, record=False)[6]
    ddm = sensitivities(linkage, names, revolutions=4)
    assert ddm.stats["nfev"] <= 1.4 * plain["nfev"], (ddm.stats["nfev"], plain["nfev"])
    assert ddm.stats["nevent"] == plain["nevent"]


def test_tangent_work_per_call_pinned():
    """Each sensitivity right-hand side evaluates the generated `tangent` along the
    integrated directions only: per call nb passes of the contact and solve stages (not
    the N_Z columns of the full Jacobian) and, of the parameter columns, only the
    (direction, column) pairs of the chains plus each direction's memory column (counted
    here from the chains' sparse form in p, independently of the kernel's index)."""
    from mbs_clearance.analysis.sensitivity import DEFAULT_PARAMETERS
    from mbs_clearance.solve.linkage_ddm import tangent_work

    run = _paper_ddm(SliderCrank(), DEFAULT_PARAMETERS, revolutions=1)
    model, p = run.model, run.p
    work = tangent_work(model, p)
    nb = work["directions"]
    assert nb == 7 and work["jacobian_columns"] == model.N_Z == 36
    # the chains in p: per direction m (column, value) pairs, padding with value 0
    m = int(p[model.N_P + 2])
    cols = p[model.N_P + 3:model.N_P + 3 + nb * m]
    vals = p[model.N_P + 3 + nb * m:model.N_P + 3 + 2 * nb * m]
    pairs = {(k // m, int(c)) for k, (c, v) in enumerate(zip(cols, vals)) if v != 0.0}
    pairs |= {(k, 1 + 2 * model.N_Q + model.MEM_START + 1 + 2 * j) for k in range(nb)
              for j in range(model.N_EVENTS)}
    assert work["parameter_pairs"] == len(pairs)
    # measured 20 pairs (13 of the chains, 7 memories) for 7 directions: with the state
    # columns, 7 x 5 + 20 = 55 column terms per call against 36 x (contact + solve) column
    # passes and 7 x 2 contractions of the full Jacobian
    assert work["parameter_pairs"] <= 3 * nb


def test_recorded_derivatives_equal_a_second_pass_and_the_growth_its_loop():
    """A DDM run that records outputs' derivatives with its steps (the monitor's full
    tangent, only the columns asked for) gives bit for bit the derivatives of a second pass
    of the tangent over the recorded states (`output_sensitivities`), and values within
    round-off of it (the plain monitor's expressions); `DdmRun.growth` equals
    `growth_maxima` of the combined state sensitivities, and those equal an einsum of the
    integrated ones with the coefficients. Paper case, the 8 default fields (7 integrated
    directions: one is combined)."""
    from mbs_clearance.analysis.sensitivity import DEFAULT_PARAMETERS
    from mbs_clearance.solve.linkage_ddm import growth_maxima

    mech = SliderCrank()
    cols = ("crank_pivot.reaction_y", "coupler_slider.contact_force", "drive_moment")
    run = _paper_ddm(mech, DEFAULT_PARAMETERS, revolutions=1,
                              derivatives=cols)
    assert run.nb < len(DEFAULT_PARAMETERS) and run.stats["nevent"] >= 2
    vals, ders = run.recorded_output_sensitivities()
    rows = np.arange(0, len(run.ts), 7)
    v2, d2 = run.recorded_output_sensitivities(rows)
    ref_vals, ref = run.output_sensitivities(run.ts, run.ys, run.ms)
    idx = [run.model.OUT_COLUMNS.index(c) for c in cols]
    assert ders.shape == (len(run.ts), len(cols), len(DEFAULT_PARAMETERS))
    np.testing.assert_array_equal(ders, ref[:, idx, :])
    np.testing.assert_array_equal(d2, ders[rows])
    np.testing.assert_array_equal(v2, vals[rows])
    # (per column; the slider guide's x reaction is zero, at round-off, in both)
    diff = np.max(np.abs(vals - ref_vals), axis=0)
    assert np.all(diff <= 1e-9 * np.max(np.abs(ref_vals), axis=0) + 1e-9), diff
    n2 = 2 * run.model.N_Q
    s = run.ys[:, n2:n2 * (1 + run.nb)].reshape(len(run.ts), run.nb, n2)
    sens = np.einsum("nbj,bk->nkj", s, run.coeffs)
    np.testing.assert_allclose(run.state_sensitivities(), sens, rtol=1e-13,
                               atol=1e-13 * np.max(np.abs(sens)))
    unit = np.array([1.0, mech.clearance, mech.crank_speed,
                     mech.crank_speed * mech.clearance / mech.crank_length])
    np.testing.assert_allclose(run.growth(unit, mech.period, 1),
                               growth_maxima(run.ts, sens, run.scale, unit, mech.period, 1),
                               rtol=1e-12)
    plain = _paper_ddm(mech, DEFAULT_PARAMETERS, revolutions=1)
    with pytest.raises(ValueError, match="derivatives=True"):
        plain.recorded_output_sensitivities()
    with pytest.raises(ValueError, match=r"unknown output\(s\) \['crank_pivot.torque'\]"):
        _paper_ddm(mech, DEFAULT_PARAMETERS, revolutions=1,
                         derivatives=["crank_pivot.torque"])


@pytest.mark.parametrize("case, names", [
    ("slider_crank_two_clearances", ("crank_coupler.restitution", "coupler.mass")),
    ("paper_slider_crank", ("coupler_slider.restitution",)),
])
def test_a_linkage_s_saved_sensitivities_load_back(tmp_path, case, names):
    """A linkage's sensitivities (dotted parameters; per-joint contact forces with two
    joints) read back equal to what was saved; a name that is not the linkage's is refused
    naming it."""
    from mbs_clearance.analysis.sensitivity import load_sensitivities

    sens = sensitivities(cases.CASES[case](), list(names), revolutions=1)
    path = sens.save(tmp_path / "s.npz")
    back = load_sensitivities(path)
    assert back.parameters == names
    for field in ("t", "base_force", "base_force_magnitude", "crank_moment",
                  "contact_force"):
        np.testing.assert_array_equal(getattr(back, field), getattr(sens, field))
    with np.load(path) as d:
        arrays = dict(d)
    arrays["parameters"] = np.array(["nobody.mass"] + list(names[1:]))
    np.savez(tmp_path / "bad.npz", **arrays)
    import shutil

    shutil.copy(tmp_path / "s.trajectory.npz", tmp_path / "bad.trajectory.npz")
    with pytest.raises(ValueError, match="unknown parameter.*nobody.mass"):
        load_sensitivities(tmp_path / "bad.npz")


def test_free_linkage_finite_differences_default_to_720_samples_per_window():
    """A free linkage's finite differences without t_eval sample 720 intervals per window
    (the windows' shared edge once) and agree there with DDM (rtol 1e-10) as the driven
    cases do (the same tolerances; measured 1.7e-4 and 1.4e-3)."""
    from mbs_clearance.model.linkage import Initial

    free = cases.paper_slider_crank().replace(name="free_case", drive=None,
                                              initial=Initial(rates={"crank.angle": 100.0}))
    names = ("coupler.mass", "crank.mass")
    fd = sensitivities(free, names, method="fd", duration=0.01, window=0.005)
    np.testing.assert_allclose(fd.t, np.linspace(0.0, 0.01, 1441), rtol=0, atol=1e-15)
    assert fd.crank_moment is None
    ddm = sensitivities(free, names, duration=0.01, window=0.005, t_eval=fd.t, rtol=1e-10)
    assert ddm.stats["nevent"] >= 2, ddm.stats
    for c in free.coordinates():
        _compare(ddm.outputs[c], fd.outputs[c], c, 2e-4)
    _compare(ddm.base_force[:, 0], fd.base_force[:, 0], "reaction x", 2e-3)
    _compare(ddm.base_force[:, 1], fd.base_force[:, 1], "reaction y", 2e-3)
