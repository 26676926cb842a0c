"""The studies on the lubricated paper case (`cases.paper_slider_crank_lubricated`, a named
case): a tolerance study with the oil's viscosity uncertain, the GA over the link lengths
and a regime map over clearance and crank speed beside the dry joint's, each against
direct `simulate` runs of the same designs, from the API and the command line. Slow: the
lubricated model's runs are stiff for the explicit integrator (about a second a
revolution) and its kernels compile first."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mbs_clearance.analysis.objective import peak_output
from mbs_clearance.cli import main
from mbs_clearance.model import cases
from mbs_clearance.model.design import design_names, design_value, linkage_with
from mbs_clearance.solve.simulate import simulate
from mbs_clearance.studies.optimize import optimize_link_lengths
from mbs_clearance.studies.tolerance import Uniform, tolerance_study

RPM = 2.0 * np.pi / 60.0


def test_film_fields_are_design_names_of_the_case():
    """The case's overrides (SliderCrank fields and the film's) are design names; a study's
    viscosity, by override or by dotted path, moves the joint's viscosity; "clearance"
    moves the journal radius at the case's bearing radius."""
    lk = cases.paper_slider_crank_lubricated()
    names = design_names(lk)
    assert {"viscosity", "bearing_length", "crank_length", "clearance"} <= set(names)
    assert "coupler_slider.viscosity" in names
    assert design_value(lk, "viscosity") == lk.clearance_joints[0].viscosity == 9e-3
    for name in ("viscosity", "coupler_slider.viscosity"):
        moved = linkage_with(lk, {name: 2e-2})
        assert moved.clearance_joints[0].viscosity == 2e-2
        assert moved.clearance_joints[0].has_lubrication
    wide = linkage_with(lk, {"clearance": 4e-5})
    joint = wide.clearance_joints[0]
    assert joint.bearing_radius - joint.journal_radius == pytest.approx(4e-5, rel=1e-9)
    assert joint.viscosity == 9e-3
    assert linkage_with(lk, {"crank_length": 0.045}) == \
        cases.paper_slider_crank_lubricated(crank_length=0.045)


def test_tolerance_study_with_the_viscosity_uncertain_against_direct_runs(tmp_path):
    """Monte Carlo of the revolution-2 peak base force over the viscosity (uniform 4.5-18
    mPa s: SAE 30 between about 80 and 120 C) and the clearance: every sample's value is a
    direct `simulate` run of the same design (the samples redrawn from the same seed); the
    command line (the viscosity by its dotted path) saves the same values."""
    lk = cases.paper_slider_crank_lubricated()
    inputs = {"viscosity": Uniform(4.5e-3, 18e-3), "clearance": Uniform(0.8e-5, 1.2e-5)}
    n, seed = 4, 5
    res = tolerance_study(inputs, lk, revolution=2, sobol=0, monte_carlo=n, seed=seed,
                          progress=False, executor="serial", rtol=1e-8)
    U = np.random.default_rng(seed).random((n, 2))
    direct = []
    for u in U:
        mu = 4.5e-3 * (1 - u[0]) + 18e-3 * u[0]
        c = 0.8e-5 * (1 - u[1]) + 1.2e-5 * u[1]
        design = cases.paper_slider_crank_lubricated(viscosity=mu, journal_radius=0.010 - c)
        direct.append(simulate(design, 2, rtol=1e-8).peaks[1])
    np.testing.assert_allclose(res.monte_carlo["values"], direct, rtol=1e-10)
    assert res.counts["failed"] == 0

    spec = tmp_path / "inputs.json"
    spec.write_text(json.dumps({"coupler_slider.viscosity": {"uniform": [4.5e-3, 18e-3]},
                                "clearance": {"uniform": [0.8e-5, 1.2e-5]}}))
    out = tmp_path / "tol"
    assert main(["tolerance", str(spec), "--case", "paper_slider_crank_lubricated",
                 "--revolution", "2", "--sobol", "0", "--monte-carlo", str(n), "--seed",
                 str(seed), "--rtol", "1e-8", "--workers", "1", "--no-progress",
                 "--out", str(out)]) == 0
    saved = json.loads((out / "result.json").read_text())
    np.testing.assert_allclose(saved["monte_carlo"]["values"], direct, rtol=1e-10)


@pytest.mark.slow   # two GAs and direct runs, 8 s
def test_ga_on_the_lubricated_case_against_direct_runs(tmp_path, capsys):
    """The GA over the crank and coupler lengths on the lubricated case (revolution-2 peak
    base force): its best design is lubricated and in the box, its reported value is a
    direct run's at that design and no worse than the original design's; the command line
    prints the same best value."""
    lk = cases.paper_slider_crank_lubricated()
    genes = {"crank_length": (0.04, 0.06), "coupler_length": (0.10, 0.14)}
    settings = dict(genes=genes, revolution=2, seed=2, population=4, generations=2,
                    saturation=None, refine=False, progress=False, executor="serial",
                    rtol=1e-8)
    res = optimize_link_lengths(lk, **settings)
    assert res.best.clearance_joints[0].has_lubrication
    for name, (lo, hi) in genes.items():
        assert lo <= res.best_genes[name] <= hi
    output = "pivot_force:crank_pivot"
    assert res.best_peak_force == peak_output(res.best, output, 2, rtol=1e-8)
    assert res.original_peak_force == pytest.approx(simulate(lk, 2, rtol=1e-8).peaks[1],
                                                    rel=1e-9)
    assert res.best_peak_force <= res.original_peak_force

    argv = ["optimize", "--case", "paper_slider_crank_lubricated", "--revolution", "2",
            "--seed", "2", "--population", "4", "--generations", "2", "--saturation", "0",
            "--no-refine", "--no-progress", "--workers", "1", "--rtol", "1e-8",
            "--out", str(tmp_path / "opt")]
    for name, (lo, hi) in genes.items():
        argv += ["--gene", f"{name}={lo}:{hi}"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert f"best: {res.best_peak_force:.2f} N of pivot_force:crank_pivot (" in printed
    saved = json.loads((tmp_path / "opt" / "result.json").read_text())
    assert saved["best_peak_force"] == res.best_peak_force


@pytest.mark.slow   # two maps and a CLI map, 6 s
def test_regime_maps_over_clearance_and_speed_beside_the_dry_joint(tmp_path):
    """Regime maps of the lubricated and the dry case over clearance (10, 40 um) and crank
    speed (3000, 5000 rpm), 4 revolutions, 3 kept: each lubricated point's peaks are a direct
    run's
    of the case rebuilt there (at the point's tolerance, to 1e-5: the map's run stops at
    each section), and at every point the film lowers the largest peak of the kept
    revolutions below the dry joint's (measured, film against dry: 2971.2 / 3019.9 N and
    3218.1 / 3330.7 N at 3000 rpm, 8253.3 / 8292.3 N and 8773.1 / 8805.3 N at 5000 rpm, for
    10 and 40 um). The command line writes the same map."""
    from mbs_clearance.studies.sweep import load_map, regime_map

    clearances, speeds = (1e-5, 4e-5), (3000 * RPM, 5000 * RPM)
    sweep = [("clearance", clearances), ("crank_speed", speeds)]
    kw = dict(revolutions=4, keep=3, max_period=1, rtol=1e-9, scheduler="serial",
              progress=False)
    lube = regime_map(None, sweep, case="paper_slider_crank_lubricated", **kw).dataset
    dry = regime_map(None, sweep, case="paper_slider_crank", **kw).dataset
    for i, c in enumerate(clearances):
        for k, w in enumerate(speeds):
            rtol = float(lube["rtol"].values[i, k])
            run = simulate(cases.paper_slider_crank_lubricated(
                journal_radius=0.010 - c, crank_speed=w), 4, rtol=rtol)
            np.testing.assert_allclose(lube["peak"].values[i, k], run.peaks[-3:], rtol=1e-5)
            film, metal = lube["peak_max"].values[i, k], dry["peak_max"].values[i, k]
            print(f"clearance {c:g} m, {w / RPM:.0f} rpm: film {film:.6g} N, dry {metal:.6g} N")
            assert film < metal
    out = tmp_path / "map"
    assert main(["map", "--case", "paper_slider_crank_lubricated", "--sweep",
                 "clearance=1e-5,4e-5", "--sweep", f"crank_speed={speeds[0]},{speeds[1]}",
                 "--revolutions", "4", "--keep", "3", "--max-period", "1", "--workers",
                 "1", "--rtol", "1e-9", "--out", str(out), "--no-progress"]) == 0
    np.testing.assert_array_equal(load_map(out / "map.nc")["peak"].values,
                                  lube["peak"].values)


def test_sensitivities_along_the_film_from_the_command_line(capsys):
    """`mbs-clearance sensitivity --case paper_slider_crank_lubricated` along the film's
    dotted parameters (DDM, one revolution) prints the API's sensitivities
    (`sensitivities` on the case, whose DDM is checked against differences in
    test_lubricated_case.py): per parameter its value and the mean of |S| (Eq. 15) to the
    printed digits; the viscosity and the bearing length move the base force."""
    from mbs_clearance.analysis.sensitivity import summary_sensitivities

    lk = cases.paper_slider_crank_lubricated()
    names = ("coupler_slider.viscosity", "coupler_slider.bearing_length")
    # the command prints the reported summary (its sampling and accuracy), as the report does
    ref = summary_sensitivities(lk, names, revolutions=1, rtol=1e-8)
    capsys.readouterr()
    assert main(["sensitivity", "--case", "paper_slider_crank_lubricated", "--parameters",
                 ",".join(names), "--revolutions", "1", "--rtol", "1e-8"]) == 0
    out = capsys.readouterr().out.splitlines()
    rows = [line.split() for line in out if line.split()[:1] and line.split()[0] in names]
    assert [r[0] for r in rows] == list(names)
    for row, r, b0 in zip(rows, ref.summary(), (9e-3, 0.01)):
        assert float(row[1]) == b0
        assert float(row[2]) == pytest.approx(r["mean_abs_normalized"], rel=1e-3)
        assert r["mean_abs_normalized"] > 0.0
