"""The paper's case is one mechanism: `SliderCrank(...)` (its named parameter set) and its
description (the named case `paper_slider_crank`, built by `cases.from_slider_crank`
through the one table `mechanism.FIELD_PATHS`) give the same numbers, to the last bit, in
every study. Each study turns a SliderCrank into its description at the door
(`cases.as_linkage`); the reference here is the description run directly."""

import ast
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mbs_clearance import (
    SliderCrank,
    Uniform,
    lyapunov_exponent,
    optimize_link_lengths,
    peak_base_force,
    peak_gradient,
    periodic_orbit,
    poincare_section,
    regime_map,
    sensitivities,
    settled_start,
    simulate,
    tolerance_study,
)
from mbs_clearance.model.cases import as_linkage, from_slider_crank, paper_slider_crank

#: a design off the defaults (so that the overrides carry it) and the paper's
DESIGNS = {"paper": {}, "shorter crank": {"crank_length": 0.045, "slider_mass": 0.2}}


@pytest.fixture(params=list(DESIGNS), scope="module")
def pair(request):
    """(SliderCrank, its named case with the same fields as overrides)."""
    fields = DESIGNS[request.param]
    return SliderCrank(**fields), paper_slider_crank(**fields)


def _arrays_equal(a, b):
    """Every array field that both hold is equal (==); a one-contact series may be
    (n,) on one and (n, 1) on the other."""
    compared = 0
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray) and isinstance(y, np.ndarray):
            assert np.array_equal(x.reshape(len(x), -1), y.reshape(len(y), -1)), f.name
            compared += 1
    return compared


def test_the_description_is_the_cases_and_the_door_gives_it(pair):
    mech, case = pair
    assert as_linkage(mech) == case
    assert from_slider_crank(mech).replace() == dataclasses.replace(case, case=None,
                                                                   overrides={})


@pytest.mark.parametrize("backend", ["reduced", "ideal"])
def test_simulate(pair, backend):
    mech, case = pair
    a, b = simulate(mech, 2, backend=backend), simulate(case, 2, backend=backend)
    assert _arrays_equal(a, b) >= 4
    np.testing.assert_array_equal(a.peaks, b.peaks)
    assert len(a.peaks) == 2


def test_simulate_exudyn_one_revolution():
    pytest.importorskip("exudyn")
    mech = SliderCrank(crank_length=0.045)
    a = simulate(mech, 1, backend="exudyn", steps_per_revolution=2000)
    b = simulate(paper_slider_crank(crank_length=0.045), 1, backend="exudyn",
                 steps_per_revolution=2000)
    assert _arrays_equal(a, b) >= 4
    np.testing.assert_array_equal(a.peaks, b.peaks)


def test_peak_base_force(pair):
    mech, case = pair
    assert peak_base_force(mech, 1) == peak_base_force(case, 1)
    assert peak_base_force(mech, 1, rtol=1e-7) == peak_base_force(case, 1, rtol=1e-7)
    assert peak_base_force(mech, 1, backend="ideal") == peak_base_force(case, 1,
                                                                       backend="ideal")


@pytest.mark.parametrize("method", ["ddm", "fd"])
def test_sensitivities(pair, method):
    mech, case = pair
    names = ["crank_length", "slider_mass"]
    a = sensitivities(mech, names, 1, method=method)
    b = sensitivities(case, names, 1, method=method)
    assert a.parameters == b.parameters == tuple(names)
    assert _arrays_equal(a, b) >= 6
    assert _arrays_equal(a.trajectory, b.trajectory) >= 4
    # the SliderCrank's trajectory in the paper's names, the case's in the description's
    np.testing.assert_array_equal(a.trajectory.slider_position,
                                  b.trajectory.coordinates["slider_guide.s"])
    # the derivatives are not zero (the comparison tests something)
    assert np.max(np.abs(a.base_force_magnitude)) > 0.0


def test_peak_gradient(pair):
    mech, case = pair
    a = peak_gradient(mech, ["crank_length", "coupler_length"], 1)
    b = peak_gradient(case, ["crank_length", "coupler_length"], 1)
    assert a.peak == b.peak and a.time == b.time
    np.testing.assert_array_equal(a.gradient, b.gradient)


def test_a_one_generation_ga():
    genes = {"crank_length": (0.04, 0.06), "coupler_length": (0.10, 0.14)}
    kw = dict(genes=genes, population=4, generations=1, seed=3, revolution=1,
              refine=False, progress=False, executor="serial")
    a = optimize_link_lengths(SliderCrank(), **kw)
    b = optimize_link_lengths(paper_slider_crank(), **kw)
    assert a.best_genes == b.best_genes
    assert a.best_peak_force == b.best_peak_force
    np.testing.assert_array_equal(a.history, b.history)
    # each names its designs as it was given: the parameter set, the named case
    assert isinstance(a.best, SliderCrank) and a.original == SliderCrank()
    assert b.best == as_linkage(a.best) and b.best.case == "paper_slider_crank"


def test_a_small_tolerance_study():
    inputs = {"crank_length": Uniform(0.0499, 0.0501), "slider_mass": Uniform(0.13, 0.15)}
    kw = dict(sobol=0, monte_carlo=4, revolution=1, seed=5, progress=False,
              executor="serial")
    a = tolerance_study(inputs, SliderCrank(), **kw)
    b = tolerance_study(inputs, paper_slider_crank(), **kw)
    np.testing.assert_array_equal(a.monte_carlo["values"], b.monte_carlo["values"])
    assert len(set(np.asarray(a.monte_carlo["values"]).tolist())) == 4


def test_lyapunov():
    a = lyapunov_exponent(SliderCrank(), revolutions=4, transient=2)
    b = lyapunov_exponent(paper_slider_crank(), revolutions=4, transient=2)
    assert a.per_revolution == b.per_revolution and a.per_second == b.per_second
    np.testing.assert_array_equal(a.log_growth, b.log_growth)
    assert len(a.log_growth) == 4


def test_periodic_orbit():
    a = periodic_orbit(SliderCrank(), settle=3, trajectory=False)
    b = periodic_orbit(paper_slider_crank(), settle=3, trajectory=False)
    np.testing.assert_array_equal(a.state, b.state)
    np.testing.assert_array_equal(a.multipliers, b.multipliers)


def test_settled_start_and_poincare_section():
    a, b = settled_start(SliderCrank(), 2), settled_start(paper_slider_crank(), 2)
    np.testing.assert_array_equal(a.y, b.y)
    np.testing.assert_array_equal(a.impact_velocities, b.impact_velocities)
    assert a.revolutions == b.revolutions == 2
    # a settled SliderCrank's start runs its named case
    assert simulate(paper_slider_crank(), 1, start=a, rtol=1e-8).peaks[0] > 0.0
    c = poincare_section(SliderCrank(), 8, keep=5, max_period=2)
    d = poincare_section(paper_slider_crank(), 8, keep=5, max_period=2)
    assert c.regime == d.regime
    np.testing.assert_array_equal(c.samples, d.samples)


def test_a_two_point_regime_map():
    kw = dict(revolutions=8, keep=5, max_period=2, scheduler="serial")
    a = regime_map(SliderCrank(), "clearance=1e-5:2e-5:2", **kw).dataset
    b = regime_map(paper_slider_crank(), "clearance=1e-5:2e-5:2", **kw).dataset
    assert a["regime"].size == 2
    for name in a.data_vars:
        np.testing.assert_array_equal(np.asarray(a[name]), np.asarray(b[name]), name)


def test_the_package_tells_a_slider_crank_apart_only_at_its_door():
    """Below the public entry points every layer takes the description: the only
    isinstance test naming SliderCrank in the package is the door's (`cases.door`)."""
    import mbs_clearance

    found = []
    root = Path(mbs_clearance.__file__).parent
    for path in sorted(q for q in root.rglob("*.py") if "_generated" not in q.parts):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "isinstance"
                    and len(node.args) == 2 and "SliderCrank" in ast.unparse(node.args[1])):
                found.append(f"{path.parent.name}/{path.name}")
    assert found == ["model/cases.py"]
