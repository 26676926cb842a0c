"""Small versions of the work-precision benchmark and the stress sweep, with invariants."""

import pytest

from validation.stress import (
    backend_differences,
    run_case,
    step_excursions,
    stress_cases,
    summary,
)
from validation.work_precision import run, speed_ratios, target_table


@pytest.mark.slow
def test_work_precision_quick_invariants():
    rows, refs = run(quick=True, repeats=1, exudyn=False)
    for ref in refs.values():
        assert ref["scipy_dop853_rel_diff"] < 1e-8  # the reference agrees with scipy
    for case in refs:
        ours = {r["setting"]: r for r in rows
                if r["case"] == case and r["backend"] == "reduced (ours)"}
        # error falls with the tolerance, and reaches what was asked for
        assert ours["rtol 1e-09"]["peak_error"] < ours["rtol 1e-06"]["peak_error"]
        assert ours["rtol 1e-09"]["peak_error"] < 1e-6
        assert all(r["time"] > 0 for r in rows)
    ratios = speed_ratios(rows, "paper (c = 0.01 mm)", 1e-3)
    assert ratios[0]["backend"] == "reduced (ours)"  # fastest at equal accuracy
    # the docs' target table: one row per target, ours in ms, scipy DOP853 as a ratio > 1
    table = target_table(rows, "paper (c = 0.01 mm)").splitlines()
    assert len(table) == 2 + 3
    row = dict(zip(table[0].split("|")[1:-1], table[3].split("|")[1:-1]))
    assert row[" ours (dopri5) "].strip().split()[1] == "ms"
    assert float(row[" scipy DOP853 "].split()[0]) > 1.0


@pytest.mark.slow   # a minute of stress runs; the CLI's stress command is tested quickly
def test_stress_quick_all_pass():
    rows = [run_case(c) for c in stress_cases(quick=True)]
    s = summary(rows)
    assert s["fail"] == 0, s["failures"]
    assert s["cases"] == len(rows) >= 7
    energy = [r["energy_error"] for r in rows if "energy_error" in r]
    assert energy and max(energy) < 1e-6  # e = 1 case closes the energy balance


@pytest.mark.slow      # re-takes every step of a run: about 50 s on a CI machine
def test_step_checks_measure_distances_inside_steps():
    """The missed-contact and missed-separation checks re-take free-flight and contact steps
    at interior times: in the paper case the journal stays outside the wall in free flight
    (by a margin) and inside it in contact (by about 7e-4 c at its closest), so both checks
    measure real distances and are not trivially zero."""
    case = stress_cases(quick=True)[0]
    inside, outside = step_excursions(case)
    assert -0.1 < inside < 0.0
    assert -0.01 < outside < 0.0


@pytest.mark.exudyn
def test_stress_case_on_both_backends():
    case = stress_cases(quick=True)[0]
    rows = [run_case(case, "reduced"), run_case(case, "exudyn")]
    assert [r["status"] for r in rows] == ["pass", "pass"]
    (diff,) = backend_differences(rows)
    assert abs(diff["difference_percent"]) < 0.1  # same periodic peak (2 revolutions)


def test_equal_error_time_interpolates_in_log_log():
    from benchmarks.speed_reduced import equal_error_time

    # time ~ error^(-1/2) between the rows: at error 1e-6 (geometric midpoint of 1e-5 and
    # 1e-7) the interpolated time is the geometric midpoint of 1 and 100
    rows = [(1e-5, 1e-3, 0.5, 0), (1e-6, 1e-5, 1.0, 0), (1e-7, 1e-7, 100.0, 0)]
    assert equal_error_time(rows, 1e-6) == pytest.approx(10.0)
    assert equal_error_time(rows, 1e-7) == pytest.approx(100.0)
    assert equal_error_time(rows, 1e-9) is None           # never reached
    assert equal_error_time(rows[1:], 1e-2) == 1.0        # the first row is already better


def test_step_limit_jacobian_matches_the_generated_one():
    """step_limit's state Jacobian (central differences of the compiled rhs) against the
    generated exact Jacobian's state columns, at states of the two-joint case's run in
    their contact modes; its dominant eigenvalue along the run is a lightly damped contact
    vibration resolved with several steps per period (h |lambda| below dopri5's stability
    bound in that direction)."""
    import numpy as np

    from benchmarks.step_limit import (
        model_call_cost,
        spectrum_along_run,
        stability_radius,
        state_jacobian,
    )
    from mbs_clearance.model import cases
    from mbs_clearance.solve.linkage_model import run

    lk = cases.slider_crank_two_clearances()
    model, ts, ys, ms, *_, p = run(lk, 1)
    n = 2 * model.N_Q
    q = p.copy()
    for i in np.linspace(10, len(ts) - 10, 7).astype(int):
        q[model.MEM_START:model.MEM_START + model.N_MEM] = ms[i]
        fd = state_jacobian(model, ts[i], ys[i].copy(), q)
        jac = model.jacobian_matrix(ts[i], ys[i], q, False).ravel()
        exact = np.zeros((n, n))
        exact[:model.N_Q, model.N_Q:] = np.eye(model.N_Q)
        for r in range(model.N_Q):
            row = (model.ACC_COLUMN + r) * model.JAC_STRIDE
            exact[model.N_Q + r] = jac[row + 1:row + 1 + n]
        # central differences with steps of 1e-7 |y|: round-off and truncation up to about
        # 1e-6 of the largest entry (measured: 8.4e-7 at worst of these states)
        assert np.max(np.abs(fd - exact)) <= 3e-6 * np.max(np.abs(exact)), i
    default = run(lk, 4)
    s = spectrum_along_run(lk, 50, default)
    assert s["contact_fraction"] > 0.9
    assert abs(s["re_median"]) < 0.2 * s["im_median"]       # lightly damped
    assert 0.1 < s["h_lambda"][1] < stability_radius("dopri5", s["angle_median"])
    # the kernel costs (no timing is compared here: benchmarks, not tests, judge speed);
    # the calls they are multiplied by: every attempted dopri5 step is 6 evaluations (5
    # stages and the monitor), plus the starting step's and the landings' few
    c = model_call_cost(lk, default)
    assert c["rhs_ns"] > 0 and c["monitor_ns"] > 0 and c["event_ns"] > 0
    attempts = c["naccept"] + c["nreject"]
    assert 0 <= c["nfev"] - 6 * attempts <= 0.01 * c["nfev"]


def test_stability_radius_closed_forms():
    """Runge-Kutta stability bounds against closed forms: bs3's stability function is
    1 + z + z^2/2 + z^3/6 (three stages, order 3): on the imaginary axis |R(iy)|^2 = 1 -
    y^4/12 + y^6/36, stable up to sqrt(3); on the negative real axis up to the real root of
    R(-x) = -1; dopri5's R is the degree-6 polynomial with z^6/600, whose real bound is where
    it comes back to +1."""
    import numpy as np

    from benchmarks.step_limit import stability_radius

    assert stability_radius("bs3", np.pi / 2) == pytest.approx(np.sqrt(3.0), rel=1e-9)
    real_root = [r.real for r in np.roots([1 / 6, -1 / 2, 1.0, -2.0]) if abs(r.imag) < 1e-12]
    assert stability_radius("bs3", np.pi) == pytest.approx(real_root[0], rel=1e-9)
    # 1 - x + x^2/2 - x^3/6 + x^4/24 - x^5/120 + x^6/600 = 1, divided by x
    coeffs = [1 / 600, -1 / 120, 1 / 24, -1 / 6, 1 / 2, -1.0]
    roots = sorted(r.real for r in np.roots(coeffs) if abs(r.imag) < 1e-9 and r.real > 0)
    assert stability_radius("dopri5", np.pi) == pytest.approx(roots[0], rel=1e-9)


# slow: central differences at rtol 1e-12 on nine designs, a minute or more
@pytest.mark.slow
def test_peak_gradient_accuracy_script(capsys):
    """validation.peak_gradient_accuracy on the paper's design at two DDM tolerances: one
    row each, the error measure against central differences below the tests' 1e-3 (the
    reference: tests/unit/test_objective.py), and the looser rtol's run cheaper in
    evaluations; a malformed design is refused before any run."""
    from validation.peak_gradient_accuracy import main

    main(["--design", "0.05,0.12", "--rtol", "1e-7", "--rtol", "1e-6"])
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("| 0.05 ")]
    assert len(lines) == 2
    cells = [[c.strip() for c in ln.strip("|").split("|")] for ln in lines]
    assert [c[4] for c in cells] == ["1e-07", "1e-06"]
    assert all(float(c[7]) < 1e-3 and float(c[9]) < 1e-7 for c in cells)
    assert float(cells[1][10]) < float(cells[0][10])      # nfev / peak-only run's
    with pytest.raises(SystemExit):
        main(["--design", "0.05"])
    assert "L2,L3" in capsys.readouterr().err
