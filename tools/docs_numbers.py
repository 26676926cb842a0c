"""The numbers of README.md and docs/ that stand beside a command, and which of them are
checked.

A number stands beside a command when it is in a prose line or table row within `REACH`
lines of a command line (``mbs-clearance ...``, ``python -m benchmarks...``,
``python -m validation...``, ``python examples/...``); a table counts as one block, so
every row of a table that starts or ends near a command stands beside it. Not counted:
fenced blocks (output blocks are checked by tests/unit/test_documented_outputs.py), inline
code, headings, integers below 100, requests written as a power of ten (1e-4), and numbers
that the nearby command itself holds (its inputs).

Each counted number must be checked by an entry of tests/docs_numbers.toml (the command
prints it) or be repeated within REACH lines of the line an entry checks, be quoted from an
output block within REACH lines that a test runs and compares
(tests/unit/test_documented_outputs.py), or be exempt in tests/docs_exempt.toml with one of
the reasons of `REASONS`.
tests/integration/test_docs_numbers.py asserts that; this script lists what is neither::

    python tools/docs_numbers.py                 # counts per page
    python tools/docs_numbers.py --page docs/exudyn.md --list
"""

from __future__ import annotations

import argparse
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    tomllib = None

ROOT = Path(__file__).resolve().parents[1]
REGISTRY = ROOT / "tests" / "docs_numbers.toml"
EXEMPT = ROOT / "tests" / "docs_exempt.toml"
#: lines between a number and its command on the page (a table counts as one block)
REACH = 12
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
#: the number of a standard or a method (ISO 286, PEP 562, SHA-256) is a name
NAMED = re.compile(r"\b[A-Z]{2,}[- ]$")
#: a version (Python 3.11.7) is not a number
VERSION = re.compile(r"\b\d+\.\d+\.\d+\b")
COMMAND = re.compile(r"mbs-clearance [a-z]|python -m (?:benchmarks|validation)\.|"
                     r"python examples/")
#: why a number beside a command is not compared with the command's output
REASONS = {
    "paper": "a published figure, quoted for comparison",
    "input": "a parameter, design or setting the user or the case chooses",
    "wall time": "a time on the machine the page names; it depends on the machine and its load",
    "time ratio": "a ratio of times (a speed-up); it depends on the machine and its load",
    "test": "a bound a test asserts; the entry names the test (`test`)",
    "chaotic": "one sample of a chaotic run, whose digits move with any change of the integrator",
    "unchecked": "not yet compared with a command's output",
}


@dataclass
class Page:
    """A page's lines, which of them are in fenced blocks, and its tables' extents."""

    path: str
    lines: list[str]
    fenced: list[bool] = field(default_factory=list)
    table: list[tuple[int, int] | None] = field(default_factory=list)

    @classmethod
    def read(cls, path: str, root: Path = ROOT) -> Page:
        lines = (root / path).read_text().splitlines()
        fenced, inside = [], False
        for ln in lines:
            if ln.strip().startswith("```"):
                inside = not inside
                fenced.append(True)
                continue
            fenced.append(inside)
        table: list[tuple[int, int] | None] = [None] * len(lines)
        i = 0
        while i < len(lines):
            if _is_row(lines[i]) and not fenced[i]:
                j = i
                while j + 1 < len(lines) and _is_row(lines[j + 1]) and not fenced[j + 1]:
                    j += 1
                for k in range(i, j + 1):
                    table[k] = (i, j)
                i = j + 1
            else:
                i += 1
        return cls(path, lines, fenced, table)

    def block(self, i: int) -> tuple[int, int]:
        """The lines (first, last) of the block holding line i: its table, or the line."""
        return self.table[i] or (i, i)

    def commands(self, cmd: str | None = None) -> list[int]:
        """Lines holding a command (or the command `cmd`, spaces and backticks ignored)."""
        if cmd is None:
            return [i for i, ln in enumerate(self.lines)
                    if COMMAND.search(ln) and "pytest" not in ln]
        return [i for i, ln in enumerate(self.lines)
                if cmd in " ".join(ln.replace("`", " ").split())]

    def near(self, i: int, j: int) -> bool:
        """Line i's block lies within REACH lines of line j's block."""
        return self.within(i, *self.block(j))

    def within(self, i: int, first: int, last: int) -> bool:
        """Line i's block lies within REACH lines of the lines first ... last."""
        a, b = self.block(i)
        return max(a - last, first - b, 0) <= REACH

    def cell_numbers(self, i: int, columns: list[int]) -> list[str]:
        """The numbers of table row i's cells `columns` (1-based), in order."""
        cells = self.cells(i)
        return [n for c in columns if c <= len(cells) for n in numbers(cells[c - 1])]

    def cells(self, i: int) -> list[str]:
        """The cells of table row i (1-based: cells(i)[0] is the first cell)."""
        row = self.lines[i].strip()[1:-1]           # the outer pipes
        return [c.strip() for c in re.split(r"(?<!\\)\|", row)]   # not an escaped \|

    def body(self, i: int) -> list[int]:
        """The body rows (after the header and its rule) of the table holding line i."""
        a, b = self.block(i)
        return [k for k in range(a, b + 1)
                if k > a and not re.fullmatch(r"\|[-:| ]+\|", self.lines[k].strip())]


def _is_row(line: str) -> bool:
    s = line.strip()
    return s.startswith("|") and s.endswith("|") and len(s) > 1


def numbers(text: str) -> list[str]:
    """The numbers of a text: not the digits of a name (DOP853, F12, ISO 286) or of a version, the
    "-" of a range (0.3-0.9) is not a sign, and a full stop is not a decimal point."""
    text = VERSION.sub(" ", text)
    out = []
    for m in NUMBER.finditer(text):
        before = text[m.start() - 1] if m.start() else " "
        n = m.group()
        if n[0] not in "+-" and (before.isalnum() or before in "_."):
            continue
        if re.fullmatch(r"-?\d+", n) and NAMED.search(text, 0, m.start() + (n[0] == "-")):
            continue
        if n[0] in "+-" and (before.isalnum() or before in ")_"):
            n = n[1:]
        out.append(n[:-1] if n.endswith(".") else n)   # "30." ends a sentence
    return out


def pages(root: Path = ROOT) -> list[str]:
    return ["README.md", *sorted(str(p.relative_to(root)) for p in (root / "docs").rglob("*.md"))]


def _counted(number: str) -> bool:
    bare = number.lstrip("+-")
    if re.fullmatch(r"1(?:[eE][-+]?\d+)?", bare):
        return False
    return not re.fullmatch(r"\d{1,2}", bare)


def _command_text(line: str) -> str:
    """The commands of a command line: its code spans that hold one, or the whole line
    (an indented or fenced command)."""
    spans = [c for c in re.findall(r"`([^`]*)`", line) if COMMAND.search(c)]
    return " ".join(spans) if spans else line


def _plain(line: str) -> str:
    return re.sub(r"`[^`]*`", " ", line)


def beside(page: Page) -> dict[int, list[str]]:
    """{line: counted numbers} of the prose lines and table rows beside a command."""
    cmds = page.commands()
    found: dict[int, list[str]] = {}
    for i, ln in enumerate(page.lines):
        if page.fenced[i] or ln.lstrip().startswith("#"):
            continue
        near = [j for j in cmds if page.near(i, j)]
        if not near:
            continue
        inputs = {n.lstrip("+") for j in near for n in numbers(_command_text(page.lines[j]))}
        nums = [n for n in numbers(_plain(ln))
                if _counted(n) and n.lstrip("+") not in inputs]
        if nums:
            found[i] = nums
    return found


def _load(path: Path) -> dict:
    if tomllib is None:
        raise SystemExit("reading the registry needs Python >= 3.11 (tomllib)")
    return tomllib.loads(path.read_text()) if path.exists() else {}


def checked(page: Page, registry: dict) -> dict[int, set[str]]:
    """{line: numbers} an entry of the registry compares with its command's output."""
    out: dict[int, set[str]] = {}
    for kind in ("number", "numbers", "lines"):
        for e in registry.get(kind, []):
            if e["page"] != page.path:
                continue
            texts = e["lines"] if kind == "lines" else [e["text"]]
            for text in texts:
                nums = ({e["number"]} if kind == "number" else set(e["numbers"])
                        if kind == "numbers" else set(numbers(text)))
                for i, ln in enumerate(page.lines):
                    if text in ln:
                        out.setdefault(i, set()).update(nums)
    for e in registry.get("table", []):
        if e["page"] != page.path:
            continue
        for i in table_rows(page, e):
            out.setdefault(i, set()).update(page.cell_numbers(i, e["columns"]))
    return out


def output_blocks(root: Path = ROOT) -> dict[str, list[tuple[int, int, set[str]]]]:
    """{page: [(first line, last line, numbers)]} of the output blocks that
    tests/unit/test_documented_outputs.py (or the test it names) runs and compares."""
    sys.path.insert(0, str(root / "tests" / "unit"))
    try:
        import test_documented_outputs as tdo
    finally:
        sys.path.pop(0)
    out: dict[str, list[tuple[int, int, set[str]]]] = {}
    for page, line, cmd, body in tdo.output_blocks():
        first = line - 1                        # the fence (or the snippet) opening it
        last = first + cmd.count("\n") + len(body) + 4
        out.setdefault(page, []).append(
            (first, last, {n for ln in body for n in numbers(ln)}))
    return out


def quoted(page: Page, blocks: dict) -> dict[int, set[str]]:
    """{line: numbers} a line quotes from a checked output block within REACH of it."""
    out: dict[int, set[str]] = {}
    for first, last, nums in blocks.get(page.path, []):
        for i in range(len(page.lines)):
            if page.within(i, first, last):
                out.setdefault(i, set()).update(nums)
    return out


def table_rows(page: Page, entry: dict) -> list[int]:
    """The body rows of the table whose line holds entry['header']."""
    at = [i for i, ln in enumerate(page.lines) if entry["header"] in ln and page.table[i]]
    return page.body(at[0]) if at else []


def exempt(page: Page, exemptions: dict) -> dict[int, dict[str, str]]:
    """{line: {number: reason}} of the exempt numbers ("*" for all of a line)."""
    out: dict[int, dict[str, str]] = {}
    for e in exemptions.get("exempt", []):
        if e["page"] != page.path:
            continue
        hits = [i for i, ln in enumerate(page.lines) if e["text"] in ln]
        if e.get("table"):
            hits = sorted({k for i in hits if page.table[i] for k in page.body(i)})
        for i in hits:
            if "columns" in e:
                nums = page.cell_numbers(i, e["columns"])
            else:
                nums = e.get("numbers", ["*"])
            out.setdefault(i, {}).update({n: e["why"] for n in nums})
    return out


def uncovered(page: Page, registry: dict, blocks: dict) -> dict[int, list[str]]:
    """{line: numbers} beside a command that no registry entry checks and that are not
    quoted from a checked output block: what an exemption may cover."""
    ok = checked(page, registry)
    # a number repeated within REACH of the line (or table) that checks it is checked too
    near = {i: {n for j, nums in ok.items() if page.near(i, j) for n in nums}
            for i in range(len(page.lines))}
    for i, nums in near.items():
        ok.setdefault(i, set()).update(nums)
    for i, nums in quoted(page, blocks).items():
        ok.setdefault(i, set()).update(nums)
    out = {i: [n for n in nums if n not in ok.get(i, set())]
           for i, nums in beside(page).items()}
    return {i: nums for i, nums in out.items() if nums}


def unchecked(root: Path = ROOT, only: str | None = None,
              keep: tuple[str, ...] = ()) -> list[tuple[str, int, list[str], str]]:
    """(page, line number, numbers, line) of the numbers beside a command that no entry
    checks and no exemption covers; exemptions whose reason is in `keep` count as not
    covering (e.g. keep=("unchecked",) lists the residual)."""
    registry, exemptions = _load(root / "tests" / "docs_numbers.toml"), _load(
        root / "tests" / "docs_exempt.toml")
    blocks = output_blocks(root) if root == ROOT else {}
    out = []
    for path in pages(root):
        if only and path != only:
            continue
        page = Page.read(path, root)
        free = exempt(page, exemptions)
        for i, nums in uncovered(page, registry, blocks).items():
            why = free.get(i, {})
            left = [n for n in nums if why.get(n, why.get("*")) in (None, *keep)]
            if left:
                out.append((path, i + 1, left, page.lines[i]))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--page", help="one page, e.g. docs/exudyn.md")
    ap.add_argument("--list", action="store_true", help="list the lines, not only counts")
    ap.add_argument("--residual", action="store_true",
                    help="count the numbers exempt as 'unchecked' as well")
    args = ap.parse_args(argv)
    left = unchecked(only=args.page, keep=("unchecked",) if args.residual else ())
    per: dict[str, int] = {}
    for path, line, nums, text in left:
        per[path] = per.get(path, 0) + len(nums)
        if args.list:
            print(f"{path}:{line}: {' '.join(nums)}    | {text.strip()[:100]}")
    for path, n in per.items():
        print(f"{n:5d}  {path}")
    print(f"{sum(per.values()):5d}  numbers beside a command, neither checked nor exempt"
          + (" (counting 'unchecked' exemptions)" if args.residual else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
