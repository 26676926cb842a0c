"""tools/docs_numbers.py finds the numbers that stand beside a command on a page and tells
which an entry checks or exempts: on small hand-written pages whose answer is read off."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

pytest.importorskip("tomllib", reason="the registry needs tomllib (Python >= 3.11)")
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import docs_numbers as dn  # noqa: E402

sys.path.pop(0)

PAGE = """# Results 8311

The paper's case peaks at 8291.96 N in revolution 4 (paper: 8311 N).

    mbs-clearance simulate --rpm 5000

It runs 5000 rpm for 12 revolutions; `mbs-clearance compare` prints 8290.32 too.
Once more: 8291.96 N.

| rpm | peak | paper |
|---|---|---|
| 2000 | 1234.5 N | 1300 |
| 3000 | 2345.6 N | 2400 |
""" + "\n" * 30 + """Far from any command: 777.7 N.

```text
inside a fence 999.9
```
"""


def _root(tmp_path: Path, registry: str = "", exempt: str = "") -> Path:
    (tmp_path / "docs").mkdir()
    (tmp_path / "README.md").write_text(PAGE)
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "docs_numbers.toml").write_text(registry)
    (tmp_path / "tests" / "docs_exempt.toml").write_text(exempt)
    return tmp_path


def test_numbers_skip_names_versions_and_read_a_range_dash_as_a_dash():
    assert dn.numbers("DOP853 F12 Python 3.11.7 0.3-0.9 -0.23 % +2.2e-4 of 30.") == [
        "0.3", "0.9", "-0.23", "+2.2e-4", "30"]
    assert dn.numbers("ISO 286, PEP 562 and SHA-256 of RMS 0.16 at 5000 rpm") == ["0.16", "5000"]


def test_what_stands_beside_a_command(tmp_path):
    page = dn.Page.read("README.md", _root(tmp_path))
    found = {page.lines[i]: n for i, n in dn.beside(page).items()}
    # a heading, the commands' own inputs (5000), integers below 100, inline code, a fence
    # and a line further than REACH are not counted; the table's rows all are (one block)
    assert found == {
        "It runs 5000 rpm for 12 revolutions; `mbs-clearance compare` prints 8290.32 too.":
            ["8290.32"],
        "Once more: 8291.96 N.": ["8291.96"],
        "The paper's case peaks at 8291.96 N in revolution 4 (paper: 8311 N).":
            ["8291.96", "8311"],
        "| 2000 | 1234.5 N | 1300 |": ["2000", "1234.5", "1300"],
        "| 3000 | 2345.6 N | 2400 |": ["3000", "2345.6", "2400"],
    }


def test_a_table_is_one_block_for_the_reach(tmp_path):
    rows = [f"| {k} | 1.5 |" for k in range(30)]
    lines = ["mbs-clearance simulate", *[""] * (dn.REACH - 1), "| a | b |", "|---|---|",
             *rows, "", "prose 2.5"]
    (tmp_path / "p.md").write_text("\n".join(lines))
    page = dn.Page.read("p.md", tmp_path)
    last_row = lines.index(rows[-1])
    assert page.block(last_row) == (dn.REACH, last_row)
    assert page.near(last_row, 0)              # 42 lines away, but its table starts at 12
    assert not page.near(len(lines) - 1, 0)    # prose after the table is not
    assert page.body(last_row)[0] == dn.REACH + 2   # header and rule are not body rows


def test_an_entry_checks_and_an_exemption_covers_only_what_it_names(tmp_path):
    registry = '''
[[number]]
page = "README.md"
text = "peaks at 8291.96 N"
number = "8291.96"
command = "mbs-clearance simulate --rpm 5000"
printed = 'x'

[[table]]
page = "README.md"
header = "| rpm | peak | paper |"
columns = [2]
command = "mbs-clearance simulate --rpm 5000"
printed = 'x'
'''
    exempt = '''
[[exempt]]
page = "README.md"
text = "| rpm | peak | paper |"
table = true
columns = [1]
why = "input"

[[exempt]]
page = "README.md"
text = "(paper: 8311 N)"
numbers = ["8311"]
why = "paper"
'''
    root = _root(tmp_path, registry, exempt)
    # the paper column (3) and the number beside the inline command are neither checked
    # nor exempt; "Once more: 8291.96" repeats a checked number within REACH of its line
    assert [(n, t[:12]) for _, _, n, t in dn.unchecked(root)] == [
        (["8290.32"], "It runs 5000"), (["1300"], "| 2000 | 123"), (["2400"], "| 3000 | 234")]
    # an exemption "unchecked" counts as not covering when the residual is asked for
    root2 = tmp_path / "two"
    root2.mkdir()
    _root(root2, registry, exempt.replace('"paper"', '"unchecked"'))
    assert ["8311"] in [n for _, _, n, _ in dn.unchecked(root2, keep=("unchecked",))]
    assert ["8311"] not in [n for _, _, n, _ in dn.unchecked(root2)]


def test_cells_of_a_row_with_empty_and_escaped_cells(tmp_path):
    (tmp_path / "p.md").write_text("| a | b | c |\n|---|---|---|\n| | | 0.5 |\n| \\|F\\| | 2 | |\n")
    page = dn.Page.read("p.md", tmp_path)
    assert page.cells(2) == ["", "", "0.5"]
    assert page.cells(3) == ["\\|F\\|", "2", ""]
