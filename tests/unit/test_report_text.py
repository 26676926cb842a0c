"""The report's machinery: numbers without signed zeros, section numbers and
cross-references generated from the section list, runs thinned for data/."""

from __future__ import annotations

import re

import numpy as np
import pytest
from mbs_clearance_validation import report
from mbs_clearance_validation.report import (
    SECTIONS,
    TITLES,
    fixed,
    numbered_titles,
    section_paper,
    section_ref,
)

from mbs_clearance.studies.tolerance import _index


@pytest.mark.parametrize("value, digits, sign, text", [
    (-0.0004, 3, False, "0.000"), (-0.0006, 3, False, "-0.001"), (-1e-12, 2, True, "0.00"),
    (1e-12, 2, True, "0.00"), (1.25, 1, True, "+1.2"), (-2.0, 0, False, "-2"),
    (float("nan"), 3, False, "-"), (None, 3, False, "-")])
def test_fixed_never_writes_a_signed_zero(value, digits, sign, text):
    assert fixed(value, digits, sign) == text


def test_sobol_index_rounding_to_zero_is_unsigned():
    assert _index(-0.0003).strip() == "0.000"
    assert _index(-0.0123).strip() == "-0.012"
    assert len(_index(-0.0003)) == len(_index(0.5)) == 7


def test_titles_are_numbered_in_the_order_of_the_sections():
    body = [k for k in SECTIONS if not TITLES[k].startswith("Appendix")]
    assert [TITLES[k].split(".")[0] for k in body] == [str(i) for i in
                                                       range(1, len(body) + 1)]
    appendices = [k for k in SECTIONS if k not in body]
    assert [TITLES[k].split(".")[0] for k in appendices] == [
        f"Appendix {chr(65 + i)}" for i in range(len(appendices))]
    for key in body:
        assert section_ref(key) == f"section {TITLES[key].split('.')[0]}"
    # a single appendix has no letter; a new section renumbers everything after it
    titles = numbered_titles(("a", "b", "env"), {"a": "A", "b": "B", "env": "E"}, ("env",))
    assert titles == {"a": "1. A", "b": "2. B", "env": "Appendix. E"}
    assert numbered_titles(("x", "a", "b"), {"x": "X", "a": "A", "b": "B"})["b"] == "3. B"


def test_the_paper_table_refers_to_the_optimisation_section_by_its_number():
    """The comparison table's explanations point at the section that explains the 4667 N,
    whatever its number (it once said "section 5" for section 4)."""
    peaks = {"peak_base_force": [1.0, 2.0, 3.0, 8000.0]}
    numbers = {
        "response": {"reduced": peaks, "exudyn": peaks, "ideal": peaks},
        "optimization": {
            "paper_optimum_in_our_models": {"fixed": {"reduced": 6000.0, "exudyn": 6001.0,
                                                      "ideal": 5900.0}},
            "results": {"fixed": {"best_peak_force": 5000.0, "reduction_percent": 30.0,
                                  "crank_length": 0.04, "coupler_length": 0.14}}}}
    rows = section_paper(None, {"exudyn_step": 4e-6}, numbers)["rows"]
    refs = [m for r in rows for m in re.findall(r"section \d+", r["explanation"])]
    number = TITLES["optimization"].split(".")[0]
    assert refs and set(refs) == {f"section {number}"}
    assert "optimization" in report.HEADINGS and TITLES["optimization"].endswith(
        report.HEADINGS["optimization"])


def test_thinned_run_keeps_each_revolution_s_peak_and_loads(tmp_path):
    """data/ keeps a run thinned: about the asked samples per revolution, each
    revolution's largest |F12| sample kept (the stored refined peaks still bound the
    series, the loader's check), and every series cut at the same samples."""
    from mbs_clearance import SliderCrank, load_trajectory, simulate

    traj = simulate(SliderCrank(), 2)
    small = report.thinned(traj, per_revolution=200)
    assert len(traj.t) > 1000 and len(small.t) <= 2 * 200 + 4
    for k in (1, 2):
        assert small.base_force_magnitude[small.revolution_mask(k)].max() == (
            traj.base_force_magnitude[traj.revolution_mask(k)].max())
    kept = np.searchsorted(traj.t, small.t)
    assert np.array_equal(traj.t[kept], small.t)
    assert np.array_equal(small.eccentricity, traj.eccentricity[kept])
    assert np.array_equal(small.contact_phase, traj.contact_phase[kept])
    back = load_trajectory(small.save(tmp_path / "run.npz"))
    assert np.array_equal(back.peaks, traj.peaks) and len(back.t) == len(small.t)
    assert report.thinned(small, per_revolution=250) is small       # nothing more to cut


def test_full_data_keeps_every_sample(tmp_path):
    """--full-data (the setting full_data) saves the run whole; the default thins it."""
    from mbs_clearance import SliderCrank, load_trajectory, simulate

    traj = simulate(SliderCrank(), 1)
    whole = load_trajectory(report.save_run(traj, tmp_path / "a.npz", {"full_data": True}))
    thin = load_trajectory(report.save_run(traj, tmp_path / "b.npz", {}))
    assert len(traj.t) > report.SAVED_SAMPLES_PER_REVOLUTION + 2
    assert np.array_equal(whole.t, traj.t)
    assert len(thin.t) <= report.SAVED_SAMPLES_PER_REVOLUTION + 3 < len(traj.t)
