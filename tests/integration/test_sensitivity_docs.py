"""One definition per reported quantity: the sensitivity summary of the paper's case is one
function (`summary_sensitivities` + `Sensitivities.summary`) for the command line, the
validation report and docs/sensitivity.md, and the docs' table is what the command prints
(tools/sensitivity_table.py regenerates it)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from mbs_clearance import SliderCrank
from mbs_clearance.analysis.sensitivity import (
    SUMMARY_RTOL,
    summary_sensitivities,
    summary_times,
    time_average,
)

ROOT = Path(__file__).resolve().parents[2]


def _tool():
    name = "sensitivity_table"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, ROOT / "tools" / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


def test_time_average_is_the_integral_mean():
    t = np.concatenate([np.linspace(0.0, 1.0, 11), np.linspace(1.001, 2.0, 1000)])
    y = np.where(t <= 1.0, 1.0, 3.0)
    # a sample mean would weight the dense second half 100 times more; the time average
    # is (1 + 3) / 2 up to the one interval across the step
    assert time_average(t, y) == pytest.approx(2.0, abs=2e-3)
    assert np.mean(y) > 2.9


@pytest.mark.slow      # DDM of eight parameters over 4 revolutions at rtol 1e-9
def test_docs_table_is_what_the_command_prints_and_the_summary_is_one_function():
    tool = _tool()
    output = tool.command_output()
    text = tool.DOC.read_text()
    first, end = tool.documented_table(text)
    assert "\n".join(text.splitlines()[first:end]) == tool.table_of(output), (
        "docs/sensitivity.md's table is not current: run python tools/sensitivity_table.py")
    # the command's numbers are the shared function's, which the report calls
    sens = summary_sensitivities(SliderCrank())
    assert sens.stats.get("rtol", SUMMARY_RTOL) == SUMMARY_RTOL
    np.testing.assert_array_equal(sens.t, summary_times(SliderCrank(), 4))
    rows = {r["parameter"]: r for r in sens.summary()}
    for line in tool.table_of(output).splitlines()[2:]:
        name, _, mean, _, _ = (c.strip() for c in line.strip("|").split("|"))
        assert float(mean) == pytest.approx(rows[name]["mean_abs_normalized"], rel=5e-4)
