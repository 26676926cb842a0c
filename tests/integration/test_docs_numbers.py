"""Every number of README.md and docs/ listed in tests/docs_numbers.toml is what the command
beside it prints: the page holds the number and the command within `REACH` lines, and the
command, run as a user runs it (from a fresh folder), prints the same number to half a unit
of its last documented digit (or the entry's stated tolerance). Each command runs once.

Kinds: ``number`` (one number, group 1 of the first printed line matching ``printed``);
``lines`` (printed lines of the same words); ``numbers`` (several numbers of one table
cell or row, in the page's text in that order: the groups of the first printed lines
matching ``printed``, line after line (groups that match nothing skipped), e.g. one line
per revolution; a documented "-" is printed as "-"); ``table`` (the body rows of the table whose
line holds ``header``, row k against the k-th printed line matching ``printed``: the numbers
of the cells ``columns`` (1-based), in order, against its groups). A table is one block: the
command may stand within REACH lines of any of its rows.

Every number that stands beside a command (tools/docs_numbers.py says which) is checked by
an entry here or exempt, with its reason, in tests/docs_exempt.toml."""

from __future__ import annotations

import ast
import functools
import math
import re
import sys
from decimal import Decimal
from pathlib import Path

import pytest

# the registry is TOML (readable patterns); Python 3.10 has no reader in its library
tomllib = pytest.importorskip("tomllib", reason="the registry needs tomllib (Python >= 3.11)")

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "unit"))
sys.path.insert(0, str(ROOT / "tools"))
import docs_numbers  # noqa: E402  (the scan of the pages, one way)
from test_documented_outputs import NUMBER, _run  # noqa: E402  (its runner, one way)

del sys.path[:2]

REGISTRY = ROOT / "tests" / "docs_numbers.toml"
REACH = docs_numbers.REACH


def _entries():
    data = tomllib.loads(REGISTRY.read_text())
    out = []
    for kind in ("number", "lines", "numbers", "table"):
        for k, e in enumerate(data.get(kind, [])):
            e = {**e, "kind": kind}
            marks = [pytest.mark.slow] if e.get("slow") else []
            label = (e["number"] if kind == "number" else f"{len(e['lines'])} lines"
                     if kind == "lines" else ",".join(e["numbers"]) if kind == "numbers"
                     else f"table {e['header'][:30]}")
            out.append(pytest.param(e, marks=marks, id=f"{e['page']}:{label}:{k}"))
    return out


ENTRIES = _entries()


def half_unit(documented: str) -> float:
    """Half a unit of the last digit of a documented number ("8290.32": 0.005)."""
    return 0.5 * 10.0 ** Decimal(documented.lstrip("+-")).as_tuple().exponent


def _tolerance(entry: dict, documented: str) -> float:
    if "rtol" in entry:
        assert entry.get("reason"), f"{entry}: a stated tolerance needs its reason"
        return float(entry["rtol"]) * abs(float(documented))
    return half_unit(documented)


def _where(lines: list[str], text: str) -> list[int]:
    return [i for i, ln in enumerate(lines) if text in ln]


def _beside(page: str, entry: dict) -> None:
    """The page holds the documented text and the command within REACH lines of it (of
    its table, for a table row)."""
    doc = docs_numbers.Page.read(page, ROOT)
    cmd = entry["command"]
    near = doc.commands(cmd)
    assert near, f"{page} does not show the command `{cmd}`"
    texts = (entry["lines"] if entry["kind"] == "lines" else [entry["header"]]
             if entry["kind"] == "table" else [entry["text"]])
    for text in texts:
        at = _where(doc.lines, text)
        assert at, f"{page} does not hold the documented text\n  {text}"
        assert any(doc.near(i, j) for i in at for j in near), (
            f"{page}: `{cmd}` is not within {REACH} lines of\n  {text}")


_OUTPUT: dict[str, list[str]] = {}


def _output(cmd: str, tmp_path_factory) -> list[str]:
    if cmd not in _OUTPUT:
        _OUTPUT[cmd] = _run(cmd, tmp_path_factory.mktemp("docs-number"))
    return _OUTPUT[cmd]


def _agree(doc: str, printed: str, tol: float) -> bool:
    return math.isclose(float(doc), float(printed), rel_tol=0.0, abs_tol=tol * (1 + 1e-9))


def test_half_unit_and_the_registry_are_read():
    assert half_unit("8290.32") == pytest.approx(0.005)
    assert half_unit("548") == 0.5 and half_unit("-0.23") == pytest.approx(0.005)
    assert len(ENTRIES) >= 20


@pytest.mark.parametrize("entry", ENTRIES)
def test_the_documented_number_is_what_its_command_prints(entry, tmp_path_factory):
    _beside(entry["page"], entry)
    printed = _output(entry["command"], tmp_path_factory)
    if entry["kind"] == "table":
        _check_table(entry, printed)
        return
    if entry["kind"] == "numbers":
        _check_cell(entry, printed)
        return
    if entry["kind"] == "number":
        assert entry["number"] in entry["text"]
        pattern = re.compile(entry["printed"])
        found = [m.group(1) for ln in printed if (m := pattern.search(ln))]
        assert found, (f"`{entry['command']}` prints nothing matching {entry['printed']}:\n  "
                       + "\n  ".join(printed))
        tol = _tolerance(entry, entry["number"])
        assert _agree(entry["number"], found[0], tol), (
            f"{entry['page']} says {entry['number']}; `{entry['command']}` prints "
            f"{found[0]} (tolerance {tol:g})")
        return
    for doc in entry["lines"]:
        words = NUMBER.sub("#", doc).split()
        match = [ln for ln in printed if NUMBER.sub("#", ln).split() == words]
        assert match, f"`{entry['command']}` prints no line like\n  {doc}"
        nums = NUMBER.findall(doc)
        ok = [ln for ln in match
              if all(_agree(a, b, _tolerance(entry, a))
                     for a, b in zip(nums, NUMBER.findall(ln)))]
        assert ok, f"{entry['page']} says\n  {doc}\n`{entry['command']}` prints\n  {match[0]}"


def _check_cell(entry: dict, printed: list[str]) -> None:
    """A ``numbers`` entry: its numbers, in the page's text in that order, against the
    groups of the first printed lines that match ``printed``, line after line."""
    docs = entry["numbers"]
    at = 0
    for doc in docs:
        at = entry["text"].find(doc, at)
        assert at >= 0, f"{entry['text']} does not hold {docs} in that order"
        at += len(doc)
    pattern = re.compile(entry["printed"])
    found = [g for ln in printed if (m := pattern.search(ln))
             for g in m.groups() if g is not None][:len(docs)]
    assert len(found) == len(docs), (f"`{entry['command']}` prints {len(found)} values "
                                     f"matching {entry['printed']}, not {len(docs)}")
    for doc, got in zip(docs, found):
        if doc == "-" or got == "-":
            assert doc == got, f"{entry['page']} says {docs}; `{entry['command']}` prints {found}"
            continue
        assert _agree(doc, got, _tolerance(entry, doc)), (
            f"{entry['page']} says {docs}; `{entry['command']}` prints {found}")


def _check_table(entry: dict, printed: list[str]) -> None:
    """A ``table`` entry: body row k's cells ``columns`` against the groups of the k-th
    printed line matching ``printed``."""
    doc = docs_numbers.Page.read(entry["page"], ROOT)
    rows = docs_numbers.table_rows(doc, entry)
    assert rows, f"{entry['page']} has no table with a line holding {entry['header']}"
    pattern = re.compile(entry["printed"])
    found = [[g for g in m.groups() if g is not None]
             for ln in printed if (m := pattern.search(ln))]
    assert len(found) >= len(rows), (f"`{entry['command']}` prints {len(found)} lines "
                                     f"matching {entry['printed']}, the table has {len(rows)}")
    for row, got in zip(rows, found):
        cells = doc.cells(row)
        docs = [n for c in entry["columns"] for n in
                (["-"] if cells[c - 1] == "-" else docs_numbers.numbers(cells[c - 1]))]
        assert len(docs) == len(got), (f"{entry['page']}: row {cells} holds {docs}; "
                                       f"`{entry['command']}` prints {got}")
        for d, g in zip(docs, got):
            ok = d == g if "-" in (d, g) else _agree(d, g, _tolerance(entry, d))
            assert ok, (f"{entry['page']}: row {cells} says {docs}; "
                        f"`{entry['command']}` prints {got}")


@functools.cache
def _scan(page: str):
    """The page and its numbers beside a command that only an exemption can cover."""
    doc = docs_numbers.Page.read(page, ROOT)
    return doc, docs_numbers.uncovered(doc, _REGISTRY, _BLOCKS)


EXEMPT = tomllib.loads(docs_numbers.EXEMPT.read_text()) if docs_numbers.EXEMPT.exists() else {}
_REGISTRY = tomllib.loads(REGISTRY.read_text())
_BLOCKS = docs_numbers.output_blocks(ROOT)


def test_every_number_beside_a_command_is_checked_or_exempt():
    left = docs_numbers.unchecked(ROOT)
    assert not left, (f"{sum(len(n) for _, _, n, _ in left)} numbers stand beside a "
                      "command, and no entry of tests/docs_numbers.toml checks them nor "
                      "does tests/docs_exempt.toml exempt them (python tools/docs_numbers.py "
                      "--list):\n" + "\n".join(f"  {p}:{i}: {' '.join(n)}" for p, i, n, _
                                                   in left[:40]))


@pytest.mark.parametrize("entry", EXEMPT.get("exempt", []),
                         ids=lambda e: f"{e['page']}:{e['text'][:30]}")
def test_an_exemption_names_its_reason_and_a_line_it_covers(entry):
    assert entry["why"] in docs_numbers.REASONS, (
        f"why = {entry['why']!r}; allowed: {sorted(docs_numbers.REASONS)}")
    doc, beside = _scan(entry["page"])
    at = _where(doc.lines, entry["text"])
    assert at, f"{entry['page']} no longer holds\n  {entry['text']}"
    lines = sorted({k for i in at for k in (doc.body(i) if entry.get("table") else [i])})
    assert any(k in beside for k in lines), (
        f"{entry['page']}: nothing beside a command to exempt at\n  {entry['text']}")
    counted = {n for k in lines for n in beside.get(k, [])}
    stale = [n for n in entry.get("numbers", []) if n not in counted]
    assert not stale, (f"{entry['page']}: {stale} are checked, or not counted, numbers "
                       f"of\n  {entry['text']}")
    if entry["why"] == "test":
        # the test asserts the number: a literal of its code (not only of its docstring),
        # or it reads the page and compares it with what it computes
        literals, names = _test_code(entry["test"])
        if Path(entry["page"]).name not in names:
            # in the test's units: 0.00185 mm on the page is 1.85e-6 m in the test
            missing = [n for n in entry.get("numbers", sorted(counted)) if not any(
                math.isclose(abs(float(n)), v * 10.0 ** k, rel_tol=1e-9)
                for v in literals for k in (-6, -3, -2, 0, 2, 3, 6))]
            assert not missing, (f"{entry['page']}: {entry['test']} holds no literal "
                                 f"{missing}, so it does not assert them:\n  {entry['text']}")


def _test_code(name: str) -> tuple[list[float], str]:
    """The numeric literals and strings of the test function `name` and its decorators (not
    its docstring)."""
    for path in sorted((ROOT / "tests").rglob("test_*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and node.name == name:
                body = node.body[1:] if ast.get_docstring(node) else node.body
                consts = [c.value for stmt in [*node.decorator_list, *body]    # parametrize
                          for c in ast.walk(stmt) if isinstance(c, ast.Constant)]
                return ([abs(float(v)) for v in consts if type(v) in (int, float)],
                        " ".join(v for v in consts if isinstance(v, str)))
    raise AssertionError(f"no test named {name}")
