"""The walk-through "Describe your own mechanism" (docs/own_mechanism.md) is true: its
description file is the four-bar the page describes, and each command it shows prints what
the page shows.

The file's four-bar is not a named case; it has the bodies, points and joints of the named
four-bar with other lengths, masses, clearance and speed, so it runs on that case's
generated model (no derivation or compile of its own).
"""

from __future__ import annotations

import math
import re
import shlex
from pathlib import Path

import pytest

from mbs_clearance.cli import main
from mbs_clearance.model.linkage import Linkage

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "own_mechanism.md"
FILE = ROOT / "examples" / "my_four_bar.json"


def _console_blocks(text: str) -> list[tuple[str, list[str]]]:
    """(command, printed lines) of every ```console block: its first line is the command
    after "$ ", the rest what it prints on standard output."""
    blocks = []
    for body in re.findall(r"```console\n(.*?)```", text, re.DOTALL):
        lines = body.rstrip("\n").splitlines()
        assert lines[0].startswith("$ mbs-clearance "), lines[0]
        blocks.append((lines[0][2:], lines[1:]))
    return blocks


BLOCKS = _console_blocks(PAGE.read_text())
_NUMBER = re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?$")


def test_the_page_is_reachable_and_names_the_file():
    site = (ROOT / "mkdocs.yml").read_text()
    assert "own_mechanism.md" in site
    assert "(own_mechanism.md)" in (ROOT / "docs" / "index.md").read_text()
    assert "(docs/own_mechanism.md)" in (ROOT / "README.md").read_text()
    assert FILE.is_file() and "examples/my_four_bar.json" in PAGE.read_text()
    assert len(BLOCKS) >= 2
    assert all("--description examples/my_four_bar.json" in cmd for cmd, _ in BLOCKS)


def test_the_file_is_the_four_bar_the_page_describes():
    """Not a named case; lengths from its points; the assembly at the start (crank at its
    initial angle, journal centred) equals the closed-form position analysis of the
    four-bar (loop of crank a, coupler b, rocker c, ground d)."""
    from mbs_clearance.model.cases import CASES

    lk = Linkage.from_file(FILE)
    assert lk.name not in CASES
    length = {b.name: math.dist(*b.points.values()) for b in lk.bodies}
    a, b, c = length["crank"], length["coupler"], length["rocker"]
    d = math.dist(*lk.ground_points.values())
    assert (a, b, c, d) == pytest.approx((0.08, 0.32, 0.22, 0.30))
    assert a + b <= c + d and a == min(a, b, c, d)            # Grashof crank-rocker
    joint = lk.clearance_joints[0]
    assert joint.bearing_radius - joint.journal_radius == pytest.approx(1e-4)
    assert lk.drive.speed == pytest.approx(120 * math.pi / 30)
    theta = lk.drive.initial_angle
    pin = (a * math.cos(theta), a * math.sin(theta))           # the crank's pin
    # the rocker's pin on the circle of radius c about (d, 0) at distance b from `pin`:
    # the intersection of two circles, on the branch of the assembly guesses
    dx, dy = d - pin[0], -pin[1]
    r = math.hypot(dx, dy)
    along = (b * b - c * c + r * r) / (2 * r)
    h = math.sqrt(b * b - along * along)
    base = (pin[0] + along * dx / r, pin[1] + along * dy / r)
    tips = [(base[0] - s * h * dy / r, base[1] + s * h * dx / r) for s in (1, -1)]
    solved = lk.assemble()
    for tip in tips:
        rocker = math.atan2(tip[1], tip[0] - d)
        coupler = math.atan2(tip[1] - pin[1], tip[0] - pin[0])
        if abs(rocker - solved["rocker.angle"]) < 0.5:
            assert solved["rocker.angle"] == pytest.approx(rocker, abs=1e-8)
            assert solved["coupler.angle"] == pytest.approx(coupler, abs=1e-8)
            break
    else:
        raise AssertionError(f"the assembly {solved} is on neither branch")


def _same(printed: str, shown: str, rtol: float) -> bool:
    a, b = printed.split(), shown.split()
    if len(a) != len(b):
        return False
    for x, y in zip(a, b):
        if _NUMBER.match(x) and _NUMBER.match(y):
            if not math.isclose(float(x), float(y), rel_tol=rtol, abs_tol=1e-12):
                return False
        elif x != y:
            return False
    return True


# the page's runs request a relative accuracy of 1e-3 of the peaks (--accuracy) or run at
# rtol 1e-10 (the gradient); two runs within 1e-3 of the exact peak agree within 2e-3
RTOL = 2e-3


@pytest.mark.parametrize("command, shown", BLOCKS, ids=[c.split()[1] + str(i) for i, (c, _)
                                                         in enumerate(BLOCKS)])
def test_each_command_prints_what_the_page_shows(command, shown, capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    assert main(shlex.split(command)[1:]) == 0
    printed = capsys.readouterr().out.rstrip("\n").splitlines()
    assert len(printed) == len(shown), (printed, shown)
    for p, s in zip(printed, shown):
        assert _same(p, s, RTOL), f"printed {p!r}\n   page {s!r}"
