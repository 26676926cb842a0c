"""Tolerance study: ISO 286 fits, distributions, Sobol indices of a closed-form function
(Ishigami) through the study's pipeline, exceedance probabilities, DGSM's bound on the
mechanism, and bad input."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

pytest.importorskip("SALib")

from mbs_clearance import SliderCrank  # noqa: E402
from mbs_clearance.model.fits import FORMULAS, IT_GRADES, SHAFT_DEVIATIONS, SIZE_RANGES, iso_fit  # noqa: E402
from mbs_clearance.studies.tolerance import (  # noqa: E402
    FitClearance,
    Normal,
    Uniform,
    band,
    field_value,
    tolerance_study,
    with_values,
)

# ------------------------------------------------------------------ ISO 286


def test_iso_fit_h7_g6_20mm_matches_the_standard_limits():
    """H7/g6 at 20 mm (ISO 286-2 tables: hole 0/+21 um, shaft -7/-20 um): diametral
    clearance 7..41 um, radial 3.5..20.5 um."""
    f = iso_fit("H7/g6", 0.020)
    assert f.hole == pytest.approx((0.0, 21e-6), abs=1e-12)
    assert f.shaft == pytest.approx((-20e-6, -7e-6), abs=1e-12)
    assert f.clearance == pytest.approx((7e-6, 41e-6), abs=1e-12)
    assert f.radial_clearance == pytest.approx((3.5e-6, 20.5e-6), abs=1e-12)
    # shaft basis: G7/h6 at 20 mm, hole +7/+28 um, shaft -13/0
    g = iso_fit("G7/h6", 0.020)
    assert g.clearance == pytest.approx((7e-6, 41e-6), abs=1e-12)


def test_iso_286_tables_agree_with_the_standards_formulas():
    """Every tabulated value (sizes over 3 mm) is the standard's formula evaluated at the
    geometric mean of its size range, to within the standard's rounding (the tables round
    to 1-2 significant steps, the largest departure is IT6 at 3-6 mm: 8 um for 7.3 um,
    9 %); a typo (a transposed or dropped digit) would be off by far more."""
    for k, (a, b) in enumerate(SIZE_RANGES):
        if a == 0:
            continue
        D = math.sqrt(a * b)
        i = FORMULAS["i"](D)
        for grade, mult in FORMULAS["IT"].items():
            assert IT_GRADES[grade][k] == pytest.approx(mult * i, rel=0.10), (grade, a, b)
        for letter, fn in FORMULAS["es"].items():
            if letter == "h":
                assert SHAFT_DEVIATIONS[letter][k] == 0
            else:
                assert SHAFT_DEVIATIONS[letter][k] == pytest.approx(fn(D), rel=0.06), \
                    (letter, a, b)


@pytest.mark.parametrize("fit,diameter,message", [
    ("H7/p6", 0.02, "only clearance fits"),
    ("H7g6", 0.02, "fit must be a string like 'H7/g6'"),
    ("H4/g6", 0.02, "grade 4 not tabulated"),
    ("H7/g6", 0.6, "diameter must be in (0, 0.5] m"),
    ("H7/g6", -1.0, "diameter must be a finite number > 0"),
])
def test_iso_fit_bad_input(fit, diameter, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")
                       .replace("[", r"\[").replace("]", r"\]")):
        iso_fit(fit, diameter)


def test_fit_clearance_trapezoid_is_the_half_difference_of_uniform_diameters():
    """The quantile function of FitClearance (trapezoid) against the empirical quantiles of
    (hole - shaft) / 2 with hole and shaft diameters drawn uniformly in their zones."""
    dist = FitClearance("H7/g6", 0.020)
    f = iso_fit("H7/g6", 0.020)
    rng = np.random.default_rng(1)
    n = 400_000
    hole = rng.uniform(*f.hole, n)
    shaft = rng.uniform(*f.shaft, n)
    c = (hole - shaft) / 2.0
    q = np.linspace(0.01, 0.99, 25)
    width = f.radial_clearance[1] - f.radial_clearance[0]
    # quantile standard error ~ sqrt(q(1-q)/n) / density, < 1e-3 of the width here
    np.testing.assert_allclose(dist.ppf(q), np.quantile(c, q), atol=3e-3 * width)
    assert dist.ppf(np.array([0.0, 1.0])) == pytest.approx(f.radial_clearance, abs=1e-15)
    with pytest.raises(ValueError, match="minimum clearance of 0"):
        FitClearance("H7/h6", 0.020)


# ------------------------------------------------------------------ field access

def test_field_access_radial_clearance_moves_the_journal():
    m = SliderCrank()
    assert field_value(m, "radial_clearance") == pytest.approx(1e-5, rel=1e-9)
    m2 = with_values(m, {"radial_clearance": 2e-5, "crank_length": 0.051})
    assert m2.bearing_radius == m.bearing_radius
    assert m2.journal_radius == pytest.approx(m.bearing_radius - 2e-5, rel=1e-15)
    assert m2.crank_length == 0.051
    m3 = with_values(m, {"bearing_radius": 0.0101, "radial_clearance": 2e-5})
    assert m3.clearance == pytest.approx(2e-5, rel=1e-9)


# ------------------------------------------------------------------ Ishigami

A_ISH, B_ISH = 7.0, 0.1


def ishigami(x: dict) -> float:
    """Ishigami & Homma (1990): sin x1 + a sin^2 x2 + b x3^4 sin x1."""
    return (math.sin(x["x1"]) + A_ISH * math.sin(x["x2"]) ** 2
            + B_ISH * x["x3"] ** 4 * math.sin(x["x1"]))


def ishigami_indices():
    """Closed-form first- and total-order indices for x_i ~ U(-pi, pi)."""
    a, b, pi = A_ISH, B_ISH, math.pi
    V1 = 0.5 * (1 + b * pi**4 / 5) ** 2
    V2 = a**2 / 8
    V13 = 8 * b**2 * pi**8 / 225
    V = V1 + V2 + V13
    return np.array([V1, V2, 0.0]) / V, np.array([V1 + V13, V2, V13]) / V


def test_ishigami_sobol_indices_within_salibs_confidence_intervals():
    """Sobol indices of the Ishigami function through the study's pipeline (unit-cube
    sample, quantile transform, the shared evaluator on a thread pool, SALib's analysis)
    are within SALib's 95 % intervals of the closed-form values, and so is Morris' ranking
    (x1 > x2 > x3 by mu*, as the total indices)."""
    pi = math.pi
    inputs = {n: Uniform(-pi, pi) for n in ("x1", "x2", "x3")}
    r = tolerance_study(inputs, output=ishigami, sobol=1024, morris=40, seed=3,
                        progress=False, workers=2)
    S1, ST = ishigami_indices()
    s = r.sobol
    assert s["runs"] == 1024 * (2 * 3 + 2)
    assert np.all(np.abs(s["S1"] - S1) <= s["S1_conf"]), (s["S1"], S1, s["S1_conf"])
    assert np.all(np.abs(s["ST"] - ST) <= s["ST_conf"]), (s["ST"], ST, s["ST_conf"])
    assert r.ranking("sobol") == ["x1", "x2", "x3"]
    assert r.morris["runs"] == 40 * 4
    assert r.counts == {"runs": 1024 * 8 + 160, "failed": 0, "chaotic": 0, "flagged": 0}


def test_same_seed_same_indices_serial_and_threads():
    inputs = {n: Uniform(-math.pi, math.pi) for n in ("x1", "x2", "x3")}
    kw = dict(output=ishigami, sobol=64, seed=11, progress=False)
    a = tolerance_study(inputs, executor="serial", **kw)
    b = tolerance_study(inputs, executor="threads", workers=2, **kw)
    np.testing.assert_array_equal(a.sobol["ST"], b.sobol["ST"])
    np.testing.assert_array_equal(a.sobol["S1_conf"], b.sobol["S1_conf"])


def linear_u(x: dict) -> float:
    return x["u"]


def test_exceedance_probability_and_its_interval_cover_the_exact_value():
    """Y = u, u ~ U(0, 1): P(Y > 0.9) = 0.1 exactly; the Clopper-Pearson 95 % interval of
    the Monte Carlo estimate covers it, and the quantiles match the uniform's."""
    r = tolerance_study({"u": Uniform(0.0, 1.0)}, output=linear_u, sobol=0,
                        monte_carlo=2000, allowable=0.9, seed=5, progress=False)
    mc = r.monte_carlo
    lo, hi = mc["p_exceed_ci"]
    assert lo < 0.1 < hi and hi - lo < 0.06
    assert mc["quantiles"]["0.5"] == pytest.approx(0.5, abs=0.03)
    assert mc["mean"] == pytest.approx(0.5, abs=3 * math.sqrt(1 / 12 / 2000))


def test_normal_input_quantiles():
    """Normal's quantile transform against scipy.stats.norm."""
    from scipy.stats import norm

    u = np.array([0.01, 0.3, 0.5, 0.9])
    np.testing.assert_allclose(Normal(2.0, 0.5).ppf(u), norm.ppf(u, 2.0, 0.5), rtol=1e-14)


# ------------------------------------------------------------------ bad input

@pytest.mark.parametrize("kwargs,message", [
    (dict(inputs={"crank_lenght": band(0.05, 1e-4)}), "unknown input 'crank_lenght'"),
    (dict(inputs={}), "inputs must be a non-empty dict"),
    (dict(inputs={"crank_length": (0.04, 0.06)}), "must be a Uniform, Normal or FitClearance"),
    (dict(output="peek"), "output must be one of"),
    (dict(sobol=100), "sobol must be 0 or a power of 2"),
    (dict(revolution=0), "revolution must be an integer >= 1"),
    (dict(morris_levels=3), "morris_levels must be even"),
    (dict(confidence=1.5), r"confidence must be in \(0, 1\)"),
    (dict(dgsm=4, output="rms_drive_moment"), "dgsm needs output='peak'"),
    (dict(wear=[1e-6]), "wear needs monte_carlo > 0"),
    (dict(wear=[-1e-6], monte_carlo=4), "wear must be a non-empty sequence"),
    (dict(sobol=0), "nothing to do"),
    (dict(inputs={"crank_length": FitClearance("H7/g6", 0.02)}), "a FitClearance describes"),
    (dict(inputs={"radial_clearance": band(1e-5, 1e-6), "journal_radius": band(0.00999, 1e-6)}),
     "either 'radial_clearance' or 'journal_radius'"),
])
def test_bad_input_fails_before_any_run(kwargs, message):
    args = dict(inputs={"crank_length": band(0.05, 1e-4)}, progress=False)
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        tolerance_study(**args)
    with pytest.raises(ValueError, match="Uniform needs low < high"):
        Uniform(1.0, 1.0)
    with pytest.raises(ValueError, match="Normal.sigma must be a finite number > 0"):
        Normal(1.0, 0.0)


def test_gradient_chain_rule_for_the_radial_clearance():
    """R_J = R_B - c: d/dc = -d/dR_J and, at fixed c, d/dR_B = d/dR_B + d/dR_J."""
    from mbs_clearance.studies.tolerance import _gradient_names

    fields, J = _gradient_names(("bearing_radius", "radial_clearance", "crank_length"),
                                SliderCrank())
    assert fields == ("bearing_radius", "journal_radius", "crank_length")
    np.testing.assert_array_equal(J, [[1, 1, 0], [0, -1, 0], [0, 0, 1]])


def test_cli_tolerance_reads_a_salib_parameter_file_and_writes_the_result(tmp_path, capsys):
    """`mbs-clearance tolerance FILE` (SALib's parameter-file format) runs the study and
    writes result.json; its Monte Carlo values are the library call's with the same seed."""
    from mbs_clearance.cli import main
    from mbs_clearance.studies.tolerance import ToleranceResult

    params = tmp_path / "params.txt"
    params.write_text("# name low high\ncrank_length 0.0499 0.0501\n")
    out = tmp_path / "out"
    assert main(["tolerance", str(params), "--sobol", "0", "--monte-carlo", "3",
                 "--revolution", "1", "--allowable", "5000", "--seed", "4", "--workers", "1",
                 "--no-progress", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "Monte Carlo (3 runs)" in printed and "P(> 5000 N)" in printed
    res = ToleranceResult.from_json(out / "result.json")
    ref = tolerance_study({"crank_length": Uniform(0.0499, 0.0501)}, sobol=0, monte_carlo=3,
                          revolution=1, seed=4, executor="serial", progress=False)
    np.testing.assert_allclose(res.monte_carlo["values"], ref.monte_carlo["values"],
                               rtol=0, atol=0)
    assert (out / "summary.txt").read_text().startswith(
        "output: peak of pivot_force:crank_pivot over revolution 1 (N)")
    # --accuracy: each run to the requested accuracy, as the library's `accuracy=`
    acc = tmp_path / "acc"
    assert main(["tolerance", str(params), "--sobol", "0", "--monte-carlo", "3",
                 "--revolution", "1", "--seed", "4", "--workers", "1", "--accuracy", "1e-6",
                 "--no-progress", "--out", str(acc)]) == 0
    res = ToleranceResult.from_json(acc / "result.json")
    ref = tolerance_study({"crank_length": Uniform(0.0499, 0.0501)}, sobol=0, monte_carlo=3,
                          revolution=1, seed=4, executor="serial", progress=False,
                          accuracy=1e-6)
    np.testing.assert_allclose(res.monte_carlo["values"], ref.monte_carlo["values"],
                               rtol=0, atol=0)


@pytest.mark.slow
def test_dgsm_bounds_the_total_sobol_index_on_the_mechanism():
    """Sobol & Kucherenko: S_T,i <= C_i nu_i / V (C_i = (b - a)^2 / pi^2 for the uniform and
    the log-concave fit clearance) with nu_i from the exact gradients of the peak; checked
    against Sobol's S_T (less its interval) for every input of a tolerance batch. (The bound
    is not a ranking: the peak's steep dependence on the clearance near contact-mode changes
    makes its bound far larger than its S_T, docs/tolerance.md.)"""
    m = SliderCrank()
    inputs = {"crank_length": band(m.crank_length, 5e-5),
              "coupler_length": band(m.coupler_length, 5e-5),
              "slider_mass": band(m.slider_mass, 0.02 * m.slider_mass),
              "radial_clearance": FitClearance("H7/g6", 0.020)}
    r = tolerance_study(inputs, sobol=64, second_order=False, dgsm=32, revolution=2, seed=2,
                        progress=False)
    assert r.counts["failed"] == 0
    st, conf, bound = r.sobol["ST"], r.sobol["ST_conf"], r.dgsm["bound"]
    print(r.summary())
    assert np.all(st - conf <= bound), (st, conf, bound)


@pytest.mark.slow
def test_dgsm_of_a_linkage_is_that_of_its_parameter_set():
    """DGSM on any linkage: the paper's case given as a Linkage (its inputs its design names,
    the clearance "radial_clearance") gives the SliderCrank's gradients and bounds (the same
    peak_gradient path; the clearance's direction there is the journal radius's negated, by
    the case's differences, not the field's unit seed: the DDM's own error at its rtol 1e-6,
    measured 8e-5 of a gradient, so nu to 1e-3), and on the
    two-clearance slider-crank (central differences of its peak) each nu_i is the mean
    square of gradients checked against central differences of the peak here."""
    from mbs_clearance.analysis.objective import peak_output
    from mbs_clearance.model.cases import paper_slider_crank, slider_crank_two_clearances
    from mbs_clearance.model.design import linkage_with

    m = SliderCrank()
    inputs = {"crank_length": band(m.crank_length, 5e-5),
              "radial_clearance": band(1e-5, 1e-6)}
    a = tolerance_study(inputs, dgsm=4, revolution=2, seed=3, progress=False)
    b = tolerance_study(inputs, paper_slider_crank(), dgsm=4, revolution=2, seed=3,
                        progress=False)
    np.testing.assert_allclose(b.dgsm["nu"], a.dgsm["nu"], rtol=1e-3)
    np.testing.assert_allclose(b.dgsm["bound"], a.dgsm["bound"], rtol=1e-3)
    lk = slider_crank_two_clearances()
    two = {"coupler_length": band(0.12, 5e-5)}
    r = tolerance_study(two, lk, dgsm=2, revolution=2, seed=4, progress=False)
    from scipy.stats import qmc

    x = two["coupler_length"].ppf(qmc.Sobol(1, scramble=True, seed=4).random(2)[:, 0])
    h = 1e-4 * 0.12
    g = [(peak_output(linkage_with(lk, {"coupler_length": v + h}), None, 2, rtol=1e-11)
          - peak_output(linkage_with(lk, {"coupler_length": v - h}), None, 2, rtol=1e-11))
         / (2 * h) for v in x]
    assert r.dgsm["nu"][0] == pytest.approx(np.mean(np.square(g)), rel=1e-3)


def test_read_inputs_json_and_salib_formats(tmp_path):
    from mbs_clearance.studies.tolerance import read_inputs

    js = tmp_path / "in.json"
    js.write_text('{"crank_length": {"band": [0.05, 1e-4]}, "slider_mass": {"normal": [0.14, '
                  '0.001]}, "radial_clearance": {"fit": "H7/g6", "diameter": 0.02}}')
    got = read_inputs(js)
    assert got["crank_length"] == Uniform(0.05 - 1e-4, 0.05 + 1e-4)
    assert got["slider_mass"] == Normal(0.14, 0.001)
    assert got["radial_clearance"].limits == pytest.approx((3.5e-6, 20.5e-6), abs=1e-12)
    txt = tmp_path / "in.txt"
    txt.write_text("# SALib\nx1 -3.14 3.14\n\nx2 0 1\n")
    assert read_inputs(txt) == {"x1": Uniform(-3.14, 3.14), "x2": Uniform(0.0, 1.0)}
    js.write_text('{"crank_length": {"band": [0.05]}}')
    with pytest.raises(ValueError, match="input 'crank_length': bad specification"):
        read_inputs(js)
    txt.write_text("x1 1.0\n")
    with pytest.raises(ValueError, match="line 1: expected NAME LOW HIGH"):
        read_inputs(txt)


def test_the_four_steps_give_the_closed_form_and_the_one_call():
    """describe -> sample -> evaluate -> analyse, one step at a time: the Ishigami indices
    are within SALib's intervals of the closed form, the Monte Carlo mean within 3 standard
    errors of its exact value (3.5, a / 2), and `tolerance_study` gives the same numbers as
    the steps (it is made of them)."""
    from mbs_clearance.studies import tolerance as tol

    pi = math.pi
    inputs = {n: Uniform(-pi, pi) for n in ("x1", "x2", "x3")}
    problem = tol.describe(inputs, output=ishigami)
    assert problem.names == ("x1", "x2", "x3")
    sob = tol.sample(problem, "sobol", 512, seed=3)
    assert sob.unit.shape == (512 * 8, 3) and np.all((sob.unit >= 0) & (sob.unit <= 1))
    np.testing.assert_allclose(sob.values, -pi + 2 * pi * sob.unit)
    ev = tol.evaluate(problem, sob, executor="serial", progress=False)
    assert ev.counts["runs"] == 512 * 8 and ev.counts["failed"] == 0
    s = tol.analyse(problem, sob, ev, seed=3)
    S1, ST = ishigami_indices()
    assert np.all(np.abs(s["S1"] - S1) <= s["S1_conf"]), (s["S1"], S1, s["S1_conf"])
    assert np.all(np.abs(s["ST"] - ST) <= s["ST_conf"]), (s["ST"], ST, s["ST_conf"])
    mc_sample = tol.sample(problem, "monte_carlo", 4000, seed=4)
    mc = tol.analyse(problem, mc_sample, tol.evaluate(problem, mc_sample, executor="serial",
                                                      progress=False))
    # E[Y] = a E[sin^2 x2] = a / 2; Var[Y] from the closed-form partial variances
    V = sum(ishigami_var_parts())
    assert mc["mean"] == pytest.approx(A_ISH / 2, abs=3 * math.sqrt(V / 4000))
    whole = tolerance_study(inputs, output=ishigami, sobol=512, monte_carlo=4000, seed=3,
                            executor="serial", progress=False)
    np.testing.assert_array_equal(whole.sobol["ST"], s["ST"])
    np.testing.assert_array_equal(whole.sobol["S1_conf"], s["S1_conf"])
    again = tol.analyse(problem, tol.sample(problem, "monte_carlo", 4000, seed=3),
                        tol.evaluate(problem, tol.sample(problem, "monte_carlo", 4000, seed=3),
                                     executor="serial", progress=False), seed=3)
    np.testing.assert_array_equal(whole.monte_carlo["values"], again["values"])


def ishigami_var_parts():
    a, b, pi = A_ISH, B_ISH, math.pi
    return (0.5 * (1 + b * pi**4 / 5) ** 2, a**2 / 8, 8 * b**2 * pi**8 / 225)


@pytest.mark.parametrize("call, message", [
    (lambda t, p: t.sample(p, "latin", 8), "method must be one of ['sobol', 'morris', "
                                            "'monte_carlo']; got 'latin'"),
    (lambda t, p: t.sample(p, "sobol", 12), "n must be a power of 2 for method 'sobol'"),
    (lambda t, p: t.sample(p, "morris", 4, levels=3), "levels must be even; got 3"),
    (lambda t, p: t.evaluate(p, t.sample(p, "monte_carlo", 2), wear=-1e-6),
     "wear must be >= 0 m"),
    (lambda t, p: t.analyse(p, t.sample(p, "monte_carlo", 2),
                            t.Evaluation(np.zeros(3), np.zeros(3, bool), {})),
     "evaluation has 3 outputs for 2 designs"),
])
def test_step_bad_input_names_the_item(call, message):
    from mbs_clearance.studies import tolerance as tol

    problem = tol.describe({"x1": Uniform(0.0, 1.0)}, output=ishigami_x1)
    with pytest.raises(ValueError, match=re.escape(message)):
        call(tol, problem)


def ishigami_x1(x: dict) -> float:
    return x["x1"]
