"""The studies (peak gradient, GA, tolerance study, regime map) on a `Linkage` of a named
case, each against an independent reference: direct `simulate` runs, finite differences
computed here, a grid of the same objective; and the same studies from the CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from mbs_clearance.analysis.objective import parse_output, peak_gradient, peak_output
from mbs_clearance.cli import main
from mbs_clearance.model.cases import four_bar, slider_crank_two_clearances
from mbs_clearance.model.design import design_value, direction, linkage_with
from mbs_clearance.solve.simulate import simulate
from mbs_clearance.studies.optimize import optimize_link_lengths
from mbs_clearance.studies.tolerance import Uniform, tolerance_study

#: tolerance of the four-bar's runs here: its peaks agree between rtol 1e-10 and 1e-11 to
#: 3e-6 (cases.four_bar), and 1e-10 keeps each two-revolution run near a second
RTOL = 1e-10

#: the four-bar of the gradient and GA tests: the case with restitution 0.3. The default's
#: frictionless sliding mode is weakly damped (cases.four_bar), so its revolution-2 peak is
#: the largest of near-tied oscillation maxima: measured, it moves by ~1e-3 N (3e-5 of the
#: value) back and forth over coupler-length changes of 1e-4, no derivative there. The
#: contact's damping grows with 1 - e^2: at e = 0.3 the peak is smooth (central
#: differences over 2e-4 to 2e-3 of the coupler length agree to 3e-4)
DAMPED = {"restitution": 0.3}

#: central differences of the damped four-bar's revolution-2 peaks over relative steps
#: 6e-5 to 2e-3 spread by up to 2 % (rocker length, shaking force: the peaks' integration
#: error at rtol 1e-10, ~1e-5 N, over the step), under 0.3 % for the coupler length; the
#: gradients here are compared to this
GRADIENT_RTOL = 2e-2


# ------------------------------------------------------------------ bad input (no runs)

def test_unknown_names_and_outputs_are_refused_in_one_line():
    fb = four_bar()
    with pytest.raises(ValueError, match=r"unknown parameter 'coupler_lenght' of linkage "
                                         r"'four_bar'; allowed: the overrides of case") as e:
        linkage_with(fb, {"coupler_lenght": 4.0})
    assert "\n" not in str(e.value) and "coupler.mass" in str(e.value)
    with pytest.raises(ValueError, match=r"unknown parameter 'bodies\.coupler\.colour'"):
        linkage_with(fb, {"bodies.coupler.colour": 1.0})
    with pytest.raises(ValueError, match=r"unknown output 'shaking' of linkage 'four_bar'; "
                                         r"allowed: \['pivot_force:crank_pivot'"):
        parse_output(fb, "shaking")
    with pytest.raises(ValueError, match=r"unknown output 'contact_force:crank_pivot'"):
        peak_output(fb, "contact_force:crank_pivot")
    with pytest.raises(ValueError, match=r"unknown gene 'mass' of linkage 'four_bar'"):
        optimize_link_lengths(fb, genes={"mass": (1.0, 2.0)}, progress=False)
    # a box whose corner is no Grashof crank-rocker: refused before any run, naming it
    with pytest.raises(ValueError, match=r"the gene bounds .* contain an invalid mechanism at "
                                         r"\{'coupler_length': 4\.4, 'rocker_length': 2\.2\}.*"
                                         r"not a Grashof crank-rocker"):
        optimize_link_lengths(fb, genes={"coupler_length": (3.6, 4.4),
                                         "rocker_length": (2.2, 2.8)}, progress=False)
    with pytest.raises(ValueError, match=r"unknown input 'radius' of linkage"):
        tolerance_study({"radius": Uniform(1.0, 2.0)}, slider_crank_two_clearances(),
                        monte_carlo=2, sobol=0)
    with pytest.raises(ValueError, match=r"unknown parameter 'clearence' of linkage"):
        peak_gradient(fb, ["clearance", "clearence"], method="ddm")
    with pytest.raises(ValueError, match=r"parameters must name what to differentiate"):
        peak_gradient(fb, output="drive_moment")


@pytest.mark.parametrize("argv, message", [
    (["optimize", "--case", "four_bar", "--gene", "rocker_length=2.2:10"],
     "not a Grashof crank-rocker"),
    (["optimize", "--case", "four_bar", "--gene", "coupler_length=3.8:4.2", "--output",
      "torque"], "unknown output 'torque'"),
    (["optimize", "--case", "four_bar", "--gene", "length=1:2"], "unknown gene 'length'"),
])
def test_cli_bad_input_is_one_line(argv, message, capsys, tmp_path):
    with pytest.raises(SystemExit) as e:
        main(argv + ["--out", str(tmp_path / "o")])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_case_memory_and_design_names():
    """A case rebuilt with an override moves every value that follows from it; a changed
    copy forgets its case; a case override's direction is the derivative of the rebuilt
    description (the coupler's points -+L/2, its inertia m L / 6)."""
    fb = four_bar(clearance=2e-5)
    assert fb.case == "four_bar" and fb.overrides == {"clearance": 2e-5}
    longer = linkage_with(fb, {"coupler_length": 4.2})
    assert longer.overrides == {"clearance": 2e-5, "coupler_length": 4.2}
    assert longer == four_bar(clearance=2e-5, coupler_length=4.2)
    assert design_value(longer, "coupler_inertia") == pytest.approx(4.2 ** 2 / 12, rel=1e-15)
    assert design_value(fb, "clearance") == pytest.approx(2e-5, rel=1e-9)
    assert fb.with_parameter("coupler.mass", 2.0).case is None
    both = linkage_with(fb, {"rocker_length": 2.6, "bodies.coupler.mass": 1.5})
    assert both.parameter_value("coupler.mass") == 1.5 and both.case is None
    assert both.parameter_value("rocker.pin.x") == pytest.approx(1.3, rel=1e-15)
    # a description (no case): its dotted paths only
    from mbs_clearance.model.linkage import Linkage

    desc = Linkage.from_dict(four_bar().to_dict())
    assert desc.case is None and desc == four_bar()
    assert linkage_with(desc, {"bodies.coupler.mass": 2.0}).parameter_value("coupler.mass") \
        == 2.0
    with pytest.raises(ValueError, match=r"unknown parameter 'coupler_length' of linkage "
                                         r"'four_bar'; allowed: 'clearance'"):
        linkage_with(desc, {"coupler_length": 4.2})
    d = direction(fb, "coupler_length")
    assert set(d) == {"coupler.crank_end.x", "coupler.rocker_end.x", "coupler.inertia"}
    assert d["coupler.rocker_end.x"] == pytest.approx(0.5, rel=1e-9)
    assert d["coupler.inertia"] == pytest.approx(1.0 * 4.0 / 6.0, rel=1e-9)


# ------------------------------------------------------------------ objective and gradient

LENGTHS = (("coupler_length", 4.0), ("rocker_length", 2.5))


@pytest.mark.slow
def test_peak_gradient_of_the_four_bars_shaking_force_against_central_differences(tmp_path):
    """d(peak shaking force over revolution 2)/d(coupler length, rocker length) by the
    library (central differences of the refined peak over 1e-3 of each value, the design
    rebuilt by the case's overrides) against central differences computed here from
    `simulate` runs of the case built with other steps (5e-4 of the value), within
    GRADIENT_RTOL."""
    fb = four_bar(**DAMPED)
    g = peak_gradient(fb, [n for n, _ in LENGTHS], revolution=2, output="shaking_force",
                      rtol=RTOL, fd_relative_step=1e-3)
    base = simulate(fb, 2, rtol=RTOL)
    assert g.peak == pytest.approx(base.peaks[1], rel=1e-12)
    for k, (name, value) in enumerate(LENGTHS):
        h = 5e-4 * value
        up = simulate(four_bar(**{name: value + h}, **DAMPED), 2, rtol=RTOL).peaks[1]
        down = simulate(four_bar(**{name: value - h}, **DAMPED), 2, rtol=RTOL).peaks[1]
        assert g.gradient[k] == pytest.approx((up - down) / (2 * h), rel=GRADIENT_RTOL), name
    # the command line: the same gradient (central differences at the library's default
    # step) within the spread of central differences over steps (GRADIENT_RTOL)
    assert main(["sensitivity", "--case", "four_bar", "--set", "restitution=0.3",
                 "--output", "shaking_force", "--parameters", "coupler_length,rocker_length",
                 "--revolutions", "2", "--method", "fd", "--rtol", str(RTOL),
                 "--out", str(tmp_path / "s")]) == 0
    saved = json.loads((tmp_path / "s" / "peak_gradient.json").read_text())["gradient"]
    for k, (name, _) in enumerate(LENGTHS):
        assert saved[name] == pytest.approx(g.gradient[k], rel=GRADIENT_RTOL), name


@pytest.mark.slow
@pytest.mark.parametrize("output", ["pivot_force:crank_pivot", "drive_moment"])
def test_ddm_peak_gradient_along_case_overrides_against_central_differences(output, capsys,
                                                                          tmp_path):
    """The DDM gradient of the paper slider-crank's revolution-4 peak, built as a Linkage by
    its case and differentiated along the case's overrides (coupler and crank length: the
    directions of the description's values they move), for the monitored output (the crank
    pivot's force, refined by the integrator) and another one (the drive moment, refined
    between the recorded steps), against central differences of the peak computed here
    (steps 3e-4 of the value, rtol 1e-11) to 3e-4 (measured: they agree to 2e-5; the
    differences' own spread between steps of 3e-5 and 3e-4 is 7e-5), and for the monitored
    force against the SliderCrank's DDM gradient (its own directions and run) to 1e-4. The
    CLI prints and saves the same gradient."""
    from mbs_clearance.model.cases import paper_slider_crank
    from mbs_clearance.model.mechanism import SliderCrank

    names = ["coupler_length", "crank_length"]
    g = peak_gradient(paper_slider_crank(), names, 4, output=output, method="ddm")
    for k, (name, value) in enumerate((("coupler_length", 0.12), ("crank_length", 0.05))):
        h = 3e-4 * value
        up = peak_output(paper_slider_crank(**{name: value + h}), output, 4, rtol=1e-11)
        down = peak_output(paper_slider_crank(**{name: value - h}), output, 4, rtol=1e-11)
        assert g.gradient[k] == pytest.approx((up - down) / (2 * h), rel=3e-4), name
    assert g.peak == pytest.approx(peak_output(paper_slider_crank(), output, 4, rtol=1e-11),
                                   rel=1e-6)
    if output == "pivot_force:crank_pivot":
        np.testing.assert_allclose(g.gradient, peak_gradient(SliderCrank(), names).gradient,
                                   rtol=1e-4)
    assert main(["sensitivity", "--case", "paper_slider_crank", "--output", output,
                 "--parameters", ",".join(names), "--revolutions", "4",
                 "--out", str(tmp_path / "s")]) == 0
    printed = capsys.readouterr().out
    rows = {line.split()[0]: line.split() for line in printed.splitlines()
            if line.split() and line.split()[0] in names}
    for name, d in zip(names, g.gradient):                 # 6 significant digits printed
        assert float(rows[name][2]) == pytest.approx(d, rel=5e-6, abs=1e-12)
    saved = json.loads((tmp_path / "s" / "peak_gradient.json").read_text())
    assert saved["gradient"] == g.as_dict()


@pytest.mark.slow
def test_peaks_of_other_outputs_are_refined_between_the_recorded_steps():
    """The refined peak of an output that the integrator does not monitor: applied to the
    monitored force it gives the integrator's own refined peak (to 1e-7; on the damped
    four-bar, whose peak is one maximum: on the default's near-tied maxima it finds a
    higher one than the integrator, which refines around the largest sample only), and
    for the
    other outputs it is at least the recorded samples' maximum and above it by less than
    1e-4 (the samples are steps of a run at rtol 1e-10)."""
    from mbs_clearance.analysis.objective import _refined_peak
    from mbs_clearance.solve import linkage_model as lm

    fb = four_bar(**DAMPED)
    model, ts, ys, ms, peaks, _, stats, outs, p = lm.run(fb, 2, record=True, rtol=RTOL)
    v, _ = _refined_peak(model, ts, ys, ms, p, outs, parse_output(fb, "shaking_force"),
                         fb.period, 2 * fb.period, stats["method"])
    assert v == pytest.approx(peaks[1], rel=1e-7)
    traj = simulate(fb, 2, rtol=RTOL)
    rev2 = traj.t >= fb.period
    samples = {"pivot_force:crank_pivot": np.hypot(*traj.reactions["crank_pivot"][rev2].T),
               "drive_moment": np.abs(traj.crank_moment[rev2]),
               "contact_force:coupler_rocker": traj.contact_force[rev2, 0]}
    for name, s in samples.items():
        peak = peak_output(fb, name, 2, rtol=RTOL)
        assert s.max() <= peak <= s.max() * (1 + 1e-4), name


# ------------------------------------------------------------------ GA against a grid

GENES = {"coupler_length": (3.6, 4.2), "rocker_length": (2.4, 2.8)}


@pytest.mark.slow
def test_ga_on_the_four_bars_lengths_against_a_grid(tmp_path, capsys):
    """The GA over the four-bar's coupler and rocker lengths (peak shaking force of
    revolution 2) against a 5 x 5 grid of the same objective: the GA's best is no worse
    than the grid's best by more than the largest change of the objective between the
    grid's best point and its grid neighbours (the grid's own resolution: its best is
    only known to that accuracy). The reported best value is the objective at the
    reported design. The CLI's run with the same settings prints and saves the same
    numbers."""
    fb = four_bar(**DAMPED)
    settings = dict(genes=GENES, output="shaking_force", revolution=2, seed=3, population=8,
                    generations=5, saturation=None, refine=False, progress=False,
                    executor="serial", rtol=RTOL)
    res = optimize_link_lengths(fb, **settings)
    best = res.best_genes
    for name, (lo, hi) in GENES.items():
        assert lo <= best[name] <= hi
    assert res.best_peak_force == peak_output(res.best, "shaking_force", 2, rtol=RTOL)
    assert res.best_peak_force <= res.original_peak_force
    cs = np.linspace(*GENES["coupler_length"], 5)
    rs = np.linspace(*GENES["rocker_length"], 5)
    grid = np.array([[peak_output(four_bar(coupler_length=c, rocker_length=r, **DAMPED),
                                  "shaking_force", 2, rtol=RTOL) for r in rs] for c in cs])
    i, j = np.unravel_index(np.argmin(grid), grid.shape)
    neighbours = [grid[a, b] for a, b in ((i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1))
                  if 0 <= a < 5 and 0 <= b < 5]
    margin = max(abs(n - grid[i, j]) for n in neighbours)
    assert res.best_peak_force <= grid[i, j] + margin

    out = tmp_path / "opt"
    argv = ["optimize", "--case", "four_bar", "--set", "restitution=0.3", "--output",
            "shaking_force", "--revolution", "2",
            "--seed", "3", "--population", "8", "--generations", "5", "--saturation", "0",
            "--no-refine", "--no-progress", "--workers", "1", "--rtol", str(RTOL),
            "--out", str(out)]
    for name, (lo, hi) in GENES.items():
        argv += ["--gene", f"{name}={lo}:{hi}"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert f"best: {res.best_peak_force:.2f} N of shaking_force (" in printed
    saved = json.loads((out / "result.json").read_text())
    assert saved["best_peak_force"] == res.best_peak_force
    assert saved["best_genes"] == best


# ------------------------------------------------------------------ tolerance study

@pytest.mark.slow
def test_tolerance_study_of_the_two_clearance_slider_crank_against_direct_runs(tmp_path):
    """Monte Carlo of the two-clearance slider-crank's peak crank-pivot force over its two
    clearances (uniform bands): every sample's value equals a direct `simulate` run of the
    same design (the samples redrawn here from the same seed), so the study's mean and
    standard deviation are those of the direct runs; the CLI saves the same values."""
    link = slider_crank_two_clearances()
    inputs = {"crank_coupler_clearance": Uniform(0.8e-5, 1.2e-5),
              "coupler_slider_clearance": Uniform(0.8e-5, 1.2e-5)}
    n, seed = 6, 4
    res = tolerance_study(inputs, link, revolution=2, sobol=0, monte_carlo=n, seed=seed,
                          progress=False, executor="serial", rtol=1e-8)
    U = np.random.default_rng(seed).random((n, 2))
    direct = []
    for u in U:
        c1 = 0.8e-5 * (1 - u[0]) + 1.2e-5 * u[0]
        c2 = 0.8e-5 * (1 - u[1]) + 1.2e-5 * u[1]
        lk = slider_crank_two_clearances(crank_coupler_clearance=c1,
                                         coupler_slider_clearance=c2)
        direct.append(simulate(lk, 2, rtol=1e-8).peaks[1])
    direct = np.array(direct)
    np.testing.assert_allclose(res.monte_carlo["values"], direct, rtol=1e-10)
    assert res.monte_carlo["mean"] == pytest.approx(direct.mean(), rel=1e-10)
    assert res.monte_carlo["std"] == pytest.approx(direct.std(ddof=1), rel=1e-8)
    assert res.counts["failed"] == 0

    spec = tmp_path / "inputs.json"
    spec.write_text(json.dumps({k: {"uniform": [d.low, d.high]} for k, d in inputs.items()}))
    out = tmp_path / "tol"
    assert main(["tolerance", str(spec), "--case", "slider_crank_two_clearances",
                 "--revolution", "2", "--sobol", "0", "--monte-carlo", str(n), "--seed",
                 str(seed), "--rtol", "1e-8", "--workers", "1", "--no-progress",
                 "--out", str(out)]) == 0
    saved = json.loads((out / "result.json").read_text())
    np.testing.assert_array_equal(saved["monte_carlo"]["values"], res.monte_carlo["values"])


# ------------------------------------------------------------------ regime map

@pytest.mark.slow
def test_regime_map_of_the_four_bar_over_its_clearance_against_direct_runs(tmp_path):
    """A regime map of the (damped) four-bar over its clearance (a Linkage and its case's
    override): each point's clearance is the one asked for, and its per-revolution peaks
    are those of a direct `simulate` run of the case rebuilt with that clearance at the
    point's tolerance (1e-9), to 1e-5 (the two integrate the same model with their own
    steps: the map's run is stopped at each section, the direct one is not; measured at
    rtol 1e-9, the direct run's revolution-2 peak is 3.2e-6 and the map's 1.1e-6 from
    the value at rtol 1e-10; at the map's default rtol both were 4e-5 off)."""
    from mbs_clearance.studies.sweep import regime_map

    values = (1e-5, 3e-5)
    res = regime_map(four_bar(**DAMPED), ("clearance", values), revolutions=4, keep=3,
                     max_period=1, rtol=1e-9, scheduler="serial", progress=False)
    ds = res.dataset
    np.testing.assert_allclose(ds["joint_clearance"].values[:, 0], values, rtol=1e-9)
    for k, c in enumerate(values):
        rtol = float(ds["rtol"].values[k])
        traj = simulate(four_bar(clearance=c, **DAMPED), 4, rtol=rtol)
        np.testing.assert_allclose(ds["peak"].values[k], traj.peaks[-3:], rtol=1e-5)
    out = tmp_path / "map"
    assert main(["map", "--case", "four_bar", "--set", "restitution=0.3", "--sweep",
                 "clearance=1e-5,3e-5",
                 "--revolutions", "4", "--keep", "3", "--max-period", "1", "--workers", "1",
                 "--rtol", "1e-9",
                 "--out", str(out), "--no-progress"]) == 0
    from mbs_clearance.studies.sweep import load_map

    np.testing.assert_array_equal(load_map(out / "map.nc")["peak"].values, ds["peak"].values)
    assert math.isfinite(float(ds["peak_max"].max()))


def test_ga_result_of_a_case_reads_back_with_its_case(tmp_path):
    """A GA result of a named case, written and read back, keeps the case and overrides of
    its original and best designs (rebuilt by the case: the same descriptions), so that a
    study can go on from it by name; a description edited by hand reads back as written."""
    import numpy as np

    from mbs_clearance.studies.optimize import OptimizationResult

    genes = {"coupler_length": (3.6, 4.4), "rocker_length": (2.2, 2.8)}
    original = four_bar(**DAMPED)
    best = four_bar(**DAMPED, coupler_length=4.1, rocker_length=2.4)
    res = OptimizationResult(
        best=best, best_peak_force=1.0, original=original, original_peak_force=2.0,
        history=np.array([2.0, 1.0]), genes=genes,
        settings={"case": "four_bar", "overrides": dict(DAMPED), "output": "peak"},
        n_evaluations=4, ga_best=best, ga_best_peak_force=1.0, generations_completed=1)
    back = OptimizationResult.from_json(res.to_json(tmp_path / "r.json"))
    assert back.original.case == "four_bar" and back.original.overrides == DAMPED
    assert back.best.case == "four_bar"
    assert back.best.overrides == {**DAMPED, "coupler_length": 4.1, "rocker_length": 2.4}
    assert back.best.to_dict() == best.to_dict()
    data = json.loads((tmp_path / "r.json").read_text())
    data["best"]["bodies"][1]["mass"] = 1.5          # no longer what the case builds
    (tmp_path / "edited.json").write_text(json.dumps(data))
    edited = OptimizationResult.from_json(tmp_path / "edited.json")
    assert edited.best.case is None and edited.best.bodies[1].mass == 1.5
