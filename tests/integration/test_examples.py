"""Every script of examples/ runs as a user runs it (a fresh Python process, from the
repository root, warnings as errors) and prints what its documentation page shows.

Each runs in two to three seconds, except the Exudyn cross-check (a minute of Exudyn runs,
``-m slow``).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
TIMEOUT = 600  # s: a loaded machine, first builds included

#: name -> (marks, lines its output must contain)
CASES = {
    "paper_slider_crank": ((), [
        "clearance 0.010 mm, crank speed 523.6 rad/s",
        "revolution 4: 8292.0 N, the paper reports 8311 N (-0.23 %)",
        "motion periodic: True",
    ]),
    "custom_linkage": ((), [
        "coordinates: coupler.angle, rocker.angle",
        "revolution 3: peak shaking force",
    ]),
    "optimize_link_lengths": ((), [
        "original design: 8292.0 N",
        "best design: L2 = 4.000 cm, L3 = 14.000 cm, 6254.4 N",
    ]),
    "tolerance_study": ((), [
        "P(peak > 8300 N) =",
        "Morris mu* of radial_clearance:",
    ]),
    "regime_map": ((), [
        "4 of 4 points done",
        "clearance 0.010 mm, 5000 rpm: period_1",
    ]),
    "exudyn_cross_check": ((pytest.mark.exudyn, pytest.mark.slow), [
        "max |F12|, revolution 4: reduced 8292.0 N, Exudyn 8290.3 N",
    ]),
}


def test_every_example_has_a_case():
    assert sorted(p.stem for p in EXAMPLES.glob("*.py")) == sorted(CASES)


@pytest.mark.parametrize("name", [pytest.param(n, marks=m) for n, (m, _) in CASES.items()])
def test_example_runs_and_prints_its_result(name):
    env = {**os.environ, "PYTHONWARNINGS": "error"}
    res = subprocess.run([sys.executable, str(EXAMPLES / f"{name}.py")], cwd=ROOT, env=env,
                         capture_output=True, text=True, timeout=TIMEOUT)
    assert res.returncode == 0, res.stderr[-3000:]
    for line in CASES[name][1]:
        assert line in res.stdout, (line, res.stdout)
    if name in PAGE_CHECKED:
        printed = res.stdout.splitlines()
        for line in page_output(name):
            assert line in printed, (f"docs/examples/{name}.md shows a line the example "
                                     f"does not print", line, res.stdout)


#: examples whose page's "It prints:" block is checked line by line against the output
PAGE_CHECKED = ("paper_slider_crank", "custom_linkage")


def page_output(name: str) -> list[str]:
    """The lines of the first ```text block after "It prints" on the example's page."""
    lines = (ROOT / "docs" / "examples" / f"{name}.md").read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("It prints"))
    first = next(i for i in range(start, len(lines)) if lines[i].startswith("```text"))
    end = next(i for i in range(first + 1, len(lines)) if lines[i].startswith("```"))
    return lines[first + 1:end]


@pytest.mark.parametrize("name", PAGE_CHECKED)
def test_page_shows_a_block_of_output(name):
    assert len(page_output(name)) >= 3
