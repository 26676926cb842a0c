"""The studies of a free linkage (no drive), their objective the peak over a time window:
the translational-clearance benchmark of Flores, Leine and Glocker (the slider-crank run
from its initial rates, `cases.flores_translational_slider_crank`), over windows of
W = 0.01 s up to 0.03 s, well before 0.07 s where the slider's tilt under friction
separates runs of different tolerances (its case page). Each against an independent
reference: `simulate`'s peaks per window, central differences computed here, a grid of the
same objective, the linear model of a narrow box; and the same from the CLI.

The tolerance study computes for several seconds: slow; the others are quick."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from mbs_clearance.analysis.objective import peak_gradient, peak_output
from mbs_clearance.cli import main
from mbs_clearance.model.cases import flores_translational_slider_crank
from mbs_clearance.model.design import design_value, linkage_with
from mbs_clearance.solve.simulate import simulate
from mbs_clearance.studies.optimize import optimize_link_lengths
from mbs_clearance.studies.tolerance import Uniform, tolerance_study

#: the objective's window width, s
W = 0.01

#: the plain runs' tolerance: the window peaks at rtol 1e-10 and 1e-11 agree to 3.3e-9
RTOL = 1e-10

NAMES = ("clearance", "friction_coefficient")


def _central(lk, name, k, relative, output=None):
    """d(peak of window k)/d(name) by central differences of `peak_output` (rtol 1e-11)."""
    b0 = design_value(lk, name)
    h = relative * b0
    up = peak_output(linkage_with(lk, {name: b0 + h}), output, k, window=W, rtol=1e-11)
    down = peak_output(linkage_with(lk, {name: b0 - h}), output, k, window=W, rtol=1e-11)
    return (up - down) / (2.0 * h)


def test_peak_of_a_window_is_simulates_peak_of_that_window():
    """peak_output over window k is `simulate`'s peak of window k (the same run, k windows
    of W), and the larger of its two halves' peaks from a run in windows of W / 2 (other
    window edges, so other steps: to 1e-8, the runs' error at this tolerance)."""
    lk = flores_translational_slider_crank()
    whole = simulate(lk, duration=3 * W, window=W, rtol=RTOL)
    halves = simulate(lk, duration=3 * W, window=W / 2, rtol=RTOL)
    assert len(whole.peaks) == 3 and len(halves.peaks) == 6
    for k in (1, 2, 3):
        peak = peak_output(lk, None, k, window=W, rtol=RTOL)
        assert peak == pytest.approx(whole.peaks[k - 1], rel=1e-12)
        assert peak == pytest.approx(max(halves.peaks[2 * k - 2:2 * k]), rel=1e-8)


def test_peak_gradient_over_windows_against_central_differences():
    """d(peak of window k)/d(clearance, friction coefficient), k = 1, 2, 3, by DDM (the
    envelope theorem at the refined peak time, its default rtol 1e-6) and by the library's
    central differences (relative step 3e-5, rtol 1e-11), against central differences of
    `peak_output` computed here (rtol 1e-11, relative steps 1e-4 and 3e-4): within three
    times the references' own error (their change between the two steps). The library's
    differences at their smaller step carry the peaks' integration error too, e / h with e
    the change of the peak between rtol 1e-10 and 1e-11 (measured: their friction column
    in window 3 is 7e-4 off, the DDM's 2.4e-5). Window 1's peak is the crank pivot's
    reaction at t = 0, before any contact (its gradient along both is zero), window 2's at
    its end (the force rises into window 3): both at the window's edge, flagged; window 3
    holds an impact inside it."""
    lk = flores_translational_slider_crank()
    steps = np.array([3e-5 * design_value(lk, n) for n in NAMES])
    for k in (1, 2, 3):
        ref = np.array([_central(lk, n, k, 1e-4) for n in NAMES])
        other = np.array([_central(lk, n, k, 3e-4) for n in NAMES])
        tol = 3.0 * np.abs(ref - other)
        noise = abs(peak_output(lk, None, k, window=W, rtol=1e-10)
                    - peak_output(lk, None, k, window=W, rtol=1e-11))
        ddm = peak_gradient(lk, NAMES, k, method="ddm", window=W)
        fd = peak_gradient(lk, NAMES, k, method="fd", window=W)
        assert ddm.window == W and ddm.revolution == k and fd.window == W
        assert (k - 1) * W <= ddm.time <= k * W
        assert ddm.at_edge == (k in (1, 2))
        assert ddm.peak == pytest.approx(peak_output(lk, None, k, window=W, rtol=1e-11),
                                         rel=1e-6)
        assert np.all(np.abs(ddm.gradient - ref) <= tol), (k, ddm.gradient, ref, tol)
        assert np.all(np.abs(fd.gradient - ref) <= tol + noise / steps), \
            (k, fd.gradient, ref, tol + noise / steps)
    # window 3's gradient is far from zero: the checks above are not vacuous
    assert abs(ref[0]) > 1e5 and abs(ref[1]) > 1e2


# ------------------------------------------------------------------ GA

GENES = {"clearance": (0.5e-3, 1.5e-3), "friction_coefficient": (0.0, 0.05)}


def test_ga_over_a_window_against_a_grid(tmp_path, capsys):
    """The GA over the clearance and the friction coefficient (the peak of window 3) against
    a 5 x 5 grid of the same objective: its best is within the bounds, its reported value
    is the objective at its design, and it is no worse than the grid's best by more than
    the objective's change between the grid's best point and its neighbours (the grid's
    own resolution). The CLI's run with the same settings prints and saves the same."""
    lk = flores_translational_slider_crank()
    settings = dict(genes=GENES, revolution=3, window=W, seed=2, population=6,
                    generations=3, saturation=None, refine=False, progress=False,
                    executor="serial", rtol=RTOL)
    res = optimize_link_lengths(lk, **settings)
    best = res.best_genes
    for name, (lo, hi) in GENES.items():
        assert lo <= best[name] <= hi
    assert res.best_peak_force == peak_output(res.best, None, 3, window=W, rtol=RTOL)
    assert res.best_peak_force < res.original_peak_force
    assert res.settings["window"] == W and res.best_periodic is None
    cs = np.linspace(*GENES["clearance"], 5)
    fs = np.linspace(*GENES["friction_coefficient"], 5)
    grid = np.array([[peak_output(flores_translational_slider_crank(
        clearance=c, friction_coefficient=f), None, 3, window=W, rtol=RTOL) for f in fs]
        for c in cs])
    i, j = np.unravel_index(np.argmin(grid), grid.shape)
    neighbours = [grid[a, b] for a, b in ((i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1))
                  if 0 <= a < 5 and 0 <= b < 5]
    margin = max(abs(n - grid[i, j]) for n in neighbours)
    assert res.best_peak_force <= grid[i, j] + margin

    out = tmp_path / "opt"
    argv = ["optimize", "--case", "flores_translational_slider_crank", "--duration",
            str(3 * W), "--window", str(W), "--seed", "2", "--population", "6",
            "--generations", "3", "--saturation", "0", "--no-refine", "--no-progress",
            "--workers", "1", "--rtol", str(RTOL), "--out", str(out)]
    for name, (lo, hi) in GENES.items():
        argv += ["--gene", f"{name}={lo}:{hi}"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "over time window [0.02, 0.03] s" in printed
    assert f"best: {res.best_peak_force:.2f} N of pivot_force:crank_pivot (" in printed
    saved = json.loads((out / "result.json").read_text())
    assert saved["best_peak_force"] == res.best_peak_force
    assert saved["best_genes"] == best


# ------------------------------------------------------------------ tolerance study

@pytest.mark.slow   # 7 s of runs
def test_tolerance_study_over_a_window_against_the_linear_model(tmp_path):
    """Sobol indices of window 3's peak over narrow uniform bands of the clearance and the
    friction coefficient: over them the peak is nearly linear (the grid above: slopes
    between neighbouring points within 3 %), so each first-order and total index is
    g_i^2 Var(x_i) / sum_j g_j^2 Var(x_j) with the gradients g from central differences
    computed here, within SALib's confidence interval; the DGSM bound is no less than the
    total index less its interval. The CLI saves the same indices."""
    lk = flores_translational_slider_crank()
    inputs = {"clearance": Uniform(0.95e-3, 1.05e-3),
              "friction_coefficient": Uniform(0.005, 0.015)}
    r = tolerance_study(inputs, lk, revolution=3, window=W, sobol=32, second_order=False,
                        dgsm=4, seed=1, progress=False, executor="serial", rtol=RTOL)
    assert r.counts["failed"] == 0
    assert r.settings["window"] == W and "time window 3 of 0.01 s" in r.output_label
    g = np.array([_central(lk, n, 3, 1e-4) for n in NAMES])
    var = np.array([(d.high - d.low) ** 2 / 12.0 for d in inputs.values()])
    linear = g ** 2 * var / np.sum(g ** 2 * var)
    s = r.sobol
    assert np.all(np.abs(s["S1"] - linear) <= s["S1_conf"]), (s["S1"], linear)
    assert np.all(np.abs(s["ST"] - linear) <= s["ST_conf"]), (s["ST"], linear)
    assert abs(np.sum(s["S1"]) - 1.0) <= np.sum(s["S1_conf"])
    assert np.all(s["ST"] - s["ST_conf"] <= r.dgsm["bound"])

    spec = tmp_path / "inputs.json"
    spec.write_text(json.dumps({k: {"uniform": [d.low, d.high]} for k, d in inputs.items()}))
    out = tmp_path / "tol"
    assert main(["tolerance", str(spec), "--case", "flores_translational_slider_crank",
                 "--duration", str(3 * W), "--window", str(W), "--sobol", "32",
                 "--first-order-only", "--seed", "1", "--rtol", str(RTOL), "--workers", "1",
                 "--no-progress", "--out", str(out)]) == 0
    saved = json.loads((out / "result.json").read_text())
    np.testing.assert_array_equal(saved["sobol"]["S1"], s["S1"])


# ------------------------------------------------------------------ CLI

def test_cli_sensitivity_over_windows(tmp_path, capsys):
    """`sensitivity --output` on the free case with --duration and --window: the peak over
    the last window and its DDM gradient, printed and saved as `peak_gradient` gives them;
    without --output, the sensitivities over --duration in windows of --window, saved as
    the library's (their growth per window), with their figure over the run."""
    from mbs_clearance.analysis.sensitivity import load_sensitivities, sensitivities

    lk = flores_translational_slider_crank()
    case = ["--case", "flores_translational_slider_crank", "--duration", str(3 * W),
            "--window", str(W)]
    out = tmp_path / "grad"
    assert main(["sensitivity", *case, "--output", "pivot_force:crank_pivot",
                 "--parameters", ",".join(NAMES), "--out", str(out)]) == 0
    pg = peak_gradient(lk, NAMES, 3, window=W, method="ddm")
    printed = capsys.readouterr().out
    shown = re.search(r"over time window \[0.02, 0.03\] s: (\S+) N ", printed)
    assert float(shown.group(1)) == pytest.approx(pg.peak, rel=5e-6)   # 6 digits printed
    saved = json.loads((out / "peak_gradient.json").read_text())
    assert saved["revolution"] == 3 and saved["window"] == W
    assert saved["peak"] == pg.peak and saved["gradient"] == pg.as_dict()

    names = ("guide.clearance", "guide.friction_coefficient")
    out = tmp_path / "series"
    assert main(["sensitivity", *case, "--parameters", ",".join(names), "--out",
                 str(out)]) == 0
    assert "growth per window of 0.01 s" in capsys.readouterr().out
    assert (out / "sensitivities.png").is_file()
    ref = sensitivities(lk, names, duration=3 * W, window=W)
    cli = load_sensitivities(out / "sensitivities.npz")
    assert cli.growth.shape == (3, 2) and cli.crank_moment is None
    np.testing.assert_array_equal(cli.growth, ref.growth)
    np.testing.assert_array_equal(cli.normalized, ref.normalized)
