"""The normal output of tiny runs of tolerance, map, lyapunov, animate and compare, scanned
for what a user should not see: Python reprs and code values, numbers with more than six
significant digits, numbers without a unit (internals go to --verbose)."""

import json
import re

import pytest

from mbs_clearance.cli import main

#: what only code prints: None/True/False, object and array reprs, complex numbers,
#: container reprs, numpy scalars, executors
REPRS = re.compile(r"\bNone\b|\bTrue\b|\bFalse\b|<[\w.]+ object|\barray\(|np\.\w+\(|"
                   r"\d[jJ]\b|[{\[]'|\bnan\b|\binf\b|Executor|\w+\(\w+=")
NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?(?![\w.])")
#: a unit (or a count's noun, or a percentage) right after a number
UNIT_AFTER = re.compile(r"\s?(N m|kN|N|mm|um|µm|\N{MICRO SIGN}m|m|ms|us|s|rpm|rad/s|rad|deg|"
                        r"1/s|%|J|W|kg|GPa|MPa|kPa|Pa|per revolution|per window|"
                        r"revolutions?|clearances|times|runs|points|values|samples)(?![\w])")


PLUS_MINUS = re.compile(r"\s*\+-\s*" + NUMBER.pattern)


def _decimal(text: str) -> bool:
    return "." in text or "e" in text.lower()


def _significant(text: str) -> int:
    mantissa = re.split(r"[eE]", text.lstrip("+-"))[0].replace(".", "").lstrip("0")
    return len(mantissa)


def problems(text: str) -> list[str]:
    """What the output shows that it should not: reprs, more than 6 significant digits,
    decimal numbers without a unit outside tables (a table's header names its units) and
    probabilities (P(...) = p [lo, hi])."""
    found = [f"repr {m.group(0)!r} in: {line}" for line in text.splitlines()
             for m in REPRS.finditer(line)]
    for line in text.splitlines():
        numbers = list(NUMBER.finditer(line))
        table_row = sum(1 for cell in line.split() if NUMBER.fullmatch(cell.rstrip("%"))) >= 3
        probability = line.find("P(")
        for m in numbers:
            if _decimal(m.group(0)) and _significant(m.group(0)) > 6:
                found.append(f"{m.group(0)} has more than 6 significant digits in: {line}")
            if table_row or not _decimal(m.group(0)) or 0 <= probability < m.start():
                continue
            end = m.end()
            spread = PLUS_MINUS.match(line, end)        # "a +- b unit": the unit after b
            if not UNIT_AFTER.match(line, spread.end() if spread else end):
                found.append(f"{m.group(0)} without a unit in: {line}")
    return found


def test_the_scanner_finds_what_it_should():
    assert problems("peak 8253.23 N at t = 1.2 ms, 3 runs") == []
    assert problems("P(> 1e4 N) = 0.5000 [0.1, 0.9]") == []
    assert len(problems("KKT: True; mu 1.08e-14+6.34e-15j")) >= 2
    assert len(problems("peak 8253.229173 N")) == 1
    assert len(problems("orbit 0.004531")) == 1
    assert problems("lambda 0.6645 +- 0.02 per revolution") == []
    assert len(problems("lambda 0.6645 +- inf per revolution")) == 2


def _run(capsys, *argv) -> str:
    assert main(list(argv)) == 0
    out, err = capsys.readouterr()
    return out + err


@pytest.fixture
def inputs(tmp_path):
    path = tmp_path / "inputs.json"
    path.write_text(json.dumps({"radial_clearance": {"uniform": [1e-5, 2e-5]},
                                "crank_length": {"band": [0.05, 1e-4]}}))
    return path


def test_tolerance_output_has_units_and_no_internals(tmp_path, inputs, capsys):
    text = _run(capsys, "tolerance", str(inputs), "--sobol", "0", "--morris", "2",
                "--monte-carlo", "4", "--wear", "1um", "--allowable", "10kN", "--revolution",
                "1", "--rtol", "1e-6", "--workers", "1", "--no-progress", "--out",
                str(tmp_path / "tol"))
    assert "Morris" in text and "Monte Carlo" in text and "wear" in text
    assert problems(text) == []


def test_map_output_has_units_and_no_internals(tmp_path, capsys):
    text = _run(capsys, "map", "--sweep", "clearance=0.01mm", "--revolutions", "4", "--keep",
                "3", "--max-period", "1", "--workers", "1", "--no-progress", "--out",
                str(tmp_path / "map"))
    assert "clearance: 0.01 mm to 0.01 mm, 1 values" in text
    assert problems(text) == []


@pytest.mark.parametrize("revolutions, transient", [("2", "0"), ("10", "2")])
def test_lyapunov_output_has_units_and_no_internals(revolutions, transient, capsys):
    # 2 revolutions: too few for a spread (said so); 10: the exponent +- its spread
    text = _run(capsys, "lyapunov", "--revolutions", revolutions, "--transient", transient)
    assert "per revolution" in text and "1/s" in text
    assert ("+-" in text) == (revolutions == "10")
    assert problems(text) == []


def test_animate_output_has_units_and_no_internals(tmp_path, capsys):
    text = _run(capsys, "animate", "--case", "four_bar", "--revolutions", "1", "--frames",
                "2", "--out", str(tmp_path / "anim"))
    assert "journal offsets drawn" in text
    assert problems(text) == []


def test_compare_output_has_units_and_no_internals(tmp_path, capsys):
    text = _run(capsys, "compare", "--backend-b", "ideal", "--revolutions", "1", "--no-plot")
    assert "smallest clearance c = 0.01 mm" in text and "no impact" in text
    assert problems(text) == []
