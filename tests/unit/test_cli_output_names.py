"""Every command prints the name of the output beside the numbers it measures, and the
number is the library's peak of that output (the four-bar: its default output is the
shaking force, not a pivot's reaction)."""

import json

import pytest

from mbs_clearance import peak_base_force
from mbs_clearance.analysis.objective import peak_output
from mbs_clearance.cli import main
from mbs_clearance.model import cases

#: one fixed tolerance for the commands and their references: the same runs
RTOL = "1e-7"
FOUR_BAR = ["--case", "four_bar"]


def _out(capsys, *argv) -> list[str]:
    assert main(list(argv)) == 0
    return capsys.readouterr().out.splitlines()


def _column(lines, head: str) -> list[str]:
    """The cells under the heading `head` of a table whose cells are 'number unit'."""
    header = next(line for line in lines if head in line)
    end = header.index(head) + len(head)
    rows = lines[lines.index(header) + 1:]
    return [row[:end].split()[-2] for row in rows if len(row) >= end]


# the four-bar's slow drive rattles in its joint: the recorded run says so (its peak is
# still the one the peak-only run at the same rtol finds)
@pytest.mark.filterwarnings("ignore::mbs_clearance.AccuracyWarning")
def test_simulate_heads_each_column_with_its_output(capsys):
    lines = _out(capsys, "simulate", *FOUR_BAR, "--revolutions", "1", "--rtol", RTOL)
    assert lines[0].split() == ["revolution", "max", "shaking_force", "max", "drive_moment",
                                "max", "contact_force:coupler_rocker"]
    ref = peak_base_force(cases.four_bar(), 1, rtol=float(RTOL))
    assert float(_column(lines, "max shaking_force")[0]) == pytest.approx(ref, rel=1e-5)


def test_peak_gradient_names_its_output(capsys):
    lines = _out(capsys, "sensitivity", *FOUR_BAR, "--output", "shaking_force", "--method",
                 "fd", "--parameters", "crank_length", "--revolutions", "1", "--rtol", RTOL)
    head = "peak of shaking_force over revolution 1: "
    assert lines[0].startswith(head)
    ref = peak_output(cases.four_bar(), "shaking_force", 1, rtol=float(RTOL))
    assert float(lines[0][len(head):].split()[0]) == pytest.approx(ref, rel=1e-5)
    assert "d(peak of shaking_force)/db (N per unit of b)" in lines[1]


def test_sensitivities_name_their_output(capsys):
    lines = _out(capsys, "sensitivity", "--case", "slider_crank_two_clearances",
                 "--parameters", "slider.mass", "--revolutions", "1")
    assert lines[0].startswith("sensitivities of pivot_force:crank_pivot ")


def test_optimize_names_the_output_of_every_peak(capsys, tmp_path):
    lines = _out(capsys, "optimize", *FOUR_BAR, "--gene", "crank_length=0.99:1.01",
                 "--revolution", "1", "--population", "4", "--generations", "1",
                 "--no-refine", "--no-progress", "--workers", "1", "--rtol", RTOL,
                 "--out", str(tmp_path / "opt"))
    assert lines[0] == "linkage 'four_bar': peak of shaking_force over revolution 1"
    ref = peak_output(cases.four_bar(), None, 1, rtol=float(RTOL))
    assert lines[1] == f"original: {ref:.2f} N of shaking_force"
    assert lines[2].startswith("best: ") and " N of shaking_force (" in lines[2]
    ga = next(line for line in lines if "GA best before refinement" in line)
    assert ga.endswith(" N of shaking_force")


def test_tolerance_names_its_output(capsys, tmp_path):
    spec = tmp_path / "inputs.json"
    spec.write_text(json.dumps({"crank_length": {"uniform": [0.99, 1.01]}}))
    lines = _out(capsys, "tolerance", str(spec), *FOUR_BAR, "--revolution", "1", "--sobol",
                 "0", "--monte-carlo", "2", "--workers", "1", "--no-progress", "--rtol", RTOL,
                 "--out", str(tmp_path / "tol"))
    assert lines[0].startswith("output: peak of shaking_force over revolution 1 (N)")


def test_map_summary_names_its_peaks_output(capsys, tmp_path):
    lines = _out(capsys, "map", "--case", "slider_crank_two_clearances", "--sweep",
                 "clearance=0.01mm", "--revolutions", "4", "--keep", "3", "--max-period",
                 "1", "--workers", "1", "--no-progress", "--out", str(tmp_path / "map"))
    line = next(line for line in lines if line.startswith("peak of "))
    assert line.startswith("peak of pivot_force:crank_pivot over the kept revolutions: ")
