"""Every output block of the README and the docs that follows the command printing it is
that command's output: the command is run and each number of the page is compared with
the number printed at the same place.

A block is an output block when it is a ``console`` block (``$ command`` lines, then what
they print) or a ``text`` block whose nearest command within the lines above it (an
indented or fenced code line, or inline code) is an ``mbs-clearance`` or
``python examples/`` command. A Python snippet (a plain fenced block holding
``python - <<'EOF'`` ... ``EOF`` or ``python -c "..."``) followed at once by a plain
fenced block: the snippet is run and the second block is its output. The examples' pages
and the walk-through "Describe your own mechanism" are run by their own tests
(tests/integration/test_examples.py, tests/unit/test_own_mechanism.py); every other output
block is run here.
"""

from __future__ import annotations

import math
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
#: pages whose output blocks another test runs
RUN_ELSEWHERE = {"docs/own_mechanism.md": "tests/unit/test_own_mechanism.py",
                 **{f"docs/examples/{p.name}": "tests/integration/test_examples.py"
                    for p in (ROOT / "docs" / "examples").glob("*.md")}}
#: lines whose numbers depend on the machine (wall time)
TIMING = re.compile(r"^(done in|took) ")
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
COMMAND = re.compile(r"(mbs-clearance [^`]+|python examples/\S+)")
#: the first line of a Python snippet: a script on standard input or after -c
SNIPPET = re.compile(r"""^python (- <<'EOF'$|-c ")""")
#: numbers printed with 6 significant digits agree to half a unit of the last one
RTOL = 1e-5


def output_blocks():
    """(page, line, command, documented output lines) of every output block."""
    found = []
    for page in PAGES:
        lines = page.read_text().splitlines()
        rel = str(page.relative_to(ROOT))
        i = 0
        while i < len(lines):
            fence = lines[i].strip()
            if not fence.startswith("```"):
                i += 1
                continue
            end = _closing(lines, i)
            body = lines[i + 1:end]
            if fence == "```console":
                found.append((rel, i + 1, *_console(body)))
            elif fence == "```text":
                cmd = _command_above(lines, i)
                if cmd is not None:
                    found.append((rel, i + 1, cmd, body))
            elif fence == "```" and body and SNIPPET.match(body[0]) \
                    and end + 1 < len(lines) and lines[end + 1].strip() == "```":
                # a Python snippet and, in the plain block right below it, its output
                out_end = _closing(lines, end + 1)
                found.append((rel, i + 1, "\n".join(body), lines[end + 2:out_end]))
                end = out_end
            i = end + 1
    return found


def _closing(lines, i):
    """The line closing the fenced block that opens at line i."""
    return next(k for k in range(i + 1, len(lines)) if lines[k].strip() == "```")


def _console(body):
    cmd, out, cont = [], [], False
    for ln in body:
        if ln.startswith("$ ") or cont:
            cmd.append(ln[2:] if ln.startswith("$ ") else ln)
            cont = ln.endswith("\\")
        else:
            out.append(ln)
    return " ".join(c.rstrip("\\").strip() for c in cmd), out


def _command_above(lines, i, reach=8):
    """The command nearest above line i (an indented or fenced code line, or inline code),
    its continuation lines joined; None when there is none within `reach` lines or prose
    with no command comes between."""
    k = i - 1
    while k >= max(0, i - reach):
        ln = lines[k]
        if ln.strip().startswith("```") and k < i - 1:
            # the closing fence of a code block: its first line is the command
            start = next(j for j in range(k - 1, -1, -1) if lines[j].strip().startswith("```"))
            text = " ".join(x.strip().rstrip("\\") for x in lines[start + 1:k])
            m = COMMAND.search(text)
            return " ".join(m.group(1).split()) if m else None
        m = COMMAND.search(ln)
        if m:
            return " ".join(m.group(1).split()).rstrip("`,;:")
        k -= 1
    return None


def _numbers(line):
    return [float(x) for x in NUMBER.findall(line)]


def _agree(a, b):
    return math.isclose(a, b, rel_tol=RTOL, abs_tol=0.0) or a == b


def _run(cmd, folder):
    """The command's printed lines (standard output and error), run as a user runs it from
    the repository root, in `folder` (files it writes land there) with the repository's
    examples beside it."""
    (folder / "examples").symlink_to(ROOT / "examples")
    script = None
    if cmd.startswith("python - <<'EOF'\n"):      # a snippet: the script on standard input
        script = cmd.split("\n", 1)[1].rsplit("\nEOF", 1)[0] + "\n"
        cmd = "python -"
    argv = shlex.split(cmd)
    if argv[0] == "mbs-clearance":
        argv = [str(Path(sys.executable).with_name("mbs-clearance")), *argv[1:]]
    elif argv[0] == "python":
        argv = [sys.executable, *argv[1:]]
    # `python -m benchmarks.X` / `validation.X` as from the repository root
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.run(argv, cwd=folder, capture_output=True, text=True, timeout=1800,
                          env=env, input=script)
    assert proc.returncode == 0, f"{cmd} failed:\n{proc.stderr[-2000:]}"
    text = proc.stdout + proc.stderr
    return [ln for ln in text.splitlines()
            if ln.strip() and not ln.startswith(("compiling ", "building "))]


def check_block(printed, documented, cmd):
    """Each documented line with numbers is a printed line (standard output and error are
    two streams: in any order) with the same words and numbers that agree (`RTOL`);
    timing lines need only their words."""
    left = list(printed)
    for doc in documented:
        if not doc.strip():
            continue
        words = NUMBER.sub("#", doc).split()
        nums = _numbers(doc)
        for k, line in enumerate(left):
            if NUMBER.sub("#", line).split() != words:
                continue
            if TIMING.match(doc.strip()) or all(_agree(a, b) for a, b in zip(nums,
                                                                             _numbers(line))):
                del left[k]
                break
        else:
            raise AssertionError(f"`{cmd}` does not print the documented line\n  {doc}\n"
                                 "it printed:\n  " + "\n  ".join(printed))


def test_output_blocks_are_found():
    """The scan finds the blocks it is meant for (the start page's first command) and
    leaves an error message without a command alone."""
    blocks = {(p, c) for p, _, c, _ in output_blocks()}
    assert ("docs/getting_started.md", "mbs-clearance simulate") in blocks
    assert ("README.md", "mbs-clearance simulate") in blocks
    assert not any(c.startswith("ValueError") for _, c in blocks)
    # the optimisation page's Python snippets, on standard input and after -c
    snippets = [c for p, c in blocks if p == "docs/optimization.md"]
    assert any(c.startswith("python - <<'EOF'\n") and c.endswith("\nEOF") for c in snippets)
    assert any(c.startswith('python -c "') for c in snippets)


def test_check_block_detects_a_changed_digit():
    printed = ["revolution     max |F12|", "        2     8290.05 N"]
    check_block(printed, ["        2     8290.05 N"], "x")
    with pytest.raises(AssertionError, match="documented line"):
        check_block(printed, ["        2     8290.15 N"], "x")
    with pytest.raises(AssertionError, match="documented line"):
        check_block(printed, ["        2     8290.05 N m"], "x")


BLOCKS = [b for b in output_blocks() if b[0] not in RUN_ELSEWHERE]


@pytest.mark.parametrize("page, line, cmd, documented", BLOCKS,
                         ids=[f"{p}:{n}" for p, n, _, _ in BLOCKS])
def test_documented_output_is_what_the_command_prints(page, line, cmd, documented, tmp_path):
    check_block(_run(cmd, tmp_path), documented, cmd)
