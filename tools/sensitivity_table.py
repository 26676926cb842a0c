"""Regenerate the table of docs/sensitivity.md from the command shown beside it.

    python tools/sensitivity_table.py            # runs `mbs-clearance sensitivity`, rewrites
                                                 # the table in docs/sensitivity.md
    python tools/sensitivity_table.py --check    # exit status 1 if the table is not current

The table is the command's output as printed (the shared summary,
`mbs_clearance.analysis.sensitivity.summary_sensitivities`, which the validation report uses
too), one markdown row per printed row; tests/integration/test_sensitivity_docs.py checks
that it is current.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "sensitivity.md"
#: the command beside the table (after "mbs-clearance")
COMMAND = ["sensitivity"]
#: the line that introduces the table in the docs
ANCHOR = "    mbs-clearance sensitivity"
HEAD = ("| parameter | b0 | mean \\|S\\| | max \\|S\\| | growth per revolution |\n"
        "|---|---|---|---|---|")


def command_output() -> str:
    """stdout of ``mbs-clearance sensitivity`` run in this process."""
    from mbs_clearance.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = main(COMMAND)
    if code not in (0, None):
        raise RuntimeError(f"mbs-clearance {' '.join(COMMAND)} failed with status {code}")
    return out.getvalue()


def table_of(output: str) -> str:
    """The markdown table of the command's printed rows: parameter, b0 (with its unit, as
    printed), mean |S|, max |S|, growth per revolution."""
    lines = output.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("parameter "))
    rows = []
    for line in lines[start + 1:]:
        if not line.strip() or line.startswith(" "):
            break
        parts = line.split()
        name, rest = parts[0], parts[1:]
        mean, peak, growth = rest[-3:]
        b0 = " ".join(rest[:-3])
        rows.append(f"| {name} | {b0} | {mean} | {peak} | {growth} |")
    return "\n".join([HEAD, *rows])


def documented_table(text: str) -> tuple[int, int]:
    """(first, end) line indices of the table after `ANCHOR` in the docs' text."""
    lines = text.splitlines()
    i = lines.index(ANCHOR)
    first = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("|"))
    end = first
    while end < len(lines) and lines[end].startswith("|"):
        end += 1
    return first, end


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true",
                    help="only compare; exit status 1 if the table is not current")
    args = ap.parse_args(argv)
    text = DOC.read_text()
    lines = text.splitlines()
    first, end = documented_table(text)
    table = table_of(command_output())
    current = "\n".join(lines[first:end])
    if args.check:
        print("current" if current == table else f"not current; the command prints:\n{table}")
        return 0 if current == table else 1
    DOC.write_text("\n".join(lines[:first] + table.splitlines() + lines[end:]) + "\n")
    print(f"wrote the table of {DOC.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
