"""The documentation describes the product as it is: no development history (work sessions,
tracker numbers, commit hashes, internal work branches, processor brands, build-machine
paths) in the README, the docs, the examples or, once the code is scrubbed, the sources and
tests. The history lives in CHANGELOG.md and in git.

The patterns are assembled from parts so that this file does not match them itself.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

_S, _I, _C = "sess" + "ion", "iss" + "ue", "com" + "mit"
_HEX = r"[0-9a-f]{7,40}"
PATTERNS = {
    "work session range": rf"\b{_S}s? \d+\s*-\s*\d+",
    "work session number": rf"\b{_S}s? \d+",
    "tracker number": rf"\b{_I}s? #?\d+",
    "commit hash": rf"\b{_C}s?\b\W{{0,3}}(?:\w+\W+){{0,2}}{_HEX}\b|\b{_HEX}\^?\W{{0,3}}{_C}",
    "processor brand": r"\b(?:" + "|".join(["Xe" + "on", "EP" + "YC", "Ry" + "zen",
                                             "Co" + r"re i\d"]) + r")\b",
    "work branch": r"\bs\d{1,2}-[a-z]+\b",
    "build-machine path": "(?:" + "|".join([r"/wo" + r"rk/", r"/ro" + r"ot/",
                                            r"/ho" + r"me/[a-z_][\w.-]*/"]) + ")",
}
_REGEX = re.compile("|".join(f"(?P<p{i}>{p})" for i, p in enumerate(PATTERNS.values())),
                    re.IGNORECASE)
_NAMES = list(PATTERNS)


def history_references(text: str) -> list[str]:
    """'line N: kind: match' for every history reference in `text`."""
    out = []
    for no, line in enumerate(text.splitlines(), 1):
        for m in _REGEX.finditer(line):
            kind = _NAMES[int(m.lastgroup[1:])]
            out.append(f"line {no}: {kind}: {m.group(0)!r}")
    return out


def _files(*parts: str, suffixes=(".md", ".py", ".yml", ".toml", ".txt", ".jinja")) -> list:
    found = []
    for part in parts:
        p = ROOT / part
        if p.is_file():
            found.append(p)
        elif p.is_dir():
            found += sorted(f for f in p.rglob("*") if f.is_file() and f.suffix in suffixes
                            and "__pycache__" not in f.parts)
    return found


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


PRODUCT_DOCS = [_rel(p) for p in _files("README.md", "mkdocs.yml", "docs", "examples")]
CODE_FOLDERS = ["mbs_clearance", "validation", "tools", "tests"]


@pytest.mark.parametrize("kind,text", [
    ("work session number", f"measured in {_S} 17"),
    ("work session range", f"{_S}s 3-5"),
    ("tracker number", f"{_I} 16's target"),
    ("tracker number", f"({_I} #38)"),
    ("commit hash", f"a fresh clone of 315781e ({_C})"),
    ("commit hash", f"the {_C} f2c990d^"),
    ("processor brand", "a quiet Intel " + "Xe" + "on"),
    ("processor brand", "AMD " + "EP" + "YC"),
    ("processor brand", "Co" + "re i7"),
    ("work branch", "built by helper s" + "7-gen"),
    ("build-machine path", "in `/wo" + "rk/shared/paper`"),
    ("build-machine path", "/ho" + "me/alice/src"),
])
def test_the_patterns_find_history(kind, text):
    found = history_references(text)
    assert found and kind in found[0], (text, found)


@pytest.mark.parametrize("text", [
    "2 cores, 24 GiB, Python 3.11", "see the CHANGELOG", "a core of the model",
    "the sessions of a user", "commit your design file", "ISO 286 H7/g6, 0.0100 mm",
    "a dask scheduler at tcp://host:8786", "~/.cache/numba", "issues with the contact law",
])
def test_the_patterns_leave_ordinary_prose(text):
    assert history_references(text) == []


def test_this_file_does_not_match_its_own_patterns():
    assert history_references(Path(__file__).read_text()) == []


def test_the_documentation_is_found():
    assert "README.md" in PRODUCT_DOCS and "mkdocs.yml" in PRODUCT_DOCS
    assert any(p.startswith("docs/") for p in PRODUCT_DOCS)
    assert any(p.startswith("examples/") for p in PRODUCT_DOCS)
    assert "CHANGELOG.md" not in PRODUCT_DOCS


@pytest.mark.parametrize("path", PRODUCT_DOCS)
def test_no_history_in_the_documentation(path):
    found = history_references((ROOT / path).read_text(encoding="utf-8"))
    assert not found, f"{path}:\n" + "\n".join(found)


@pytest.mark.parametrize("folder", CODE_FOLDERS)
def test_no_history_in_the_code(folder):
    found = []
    for path in _files(folder, suffixes=(".py", ".jinja")):
        if path == Path(__file__).resolve():
            continue
        found += [f"{_rel(path)}: {ref}" for ref in history_references(path.read_text())]
    assert not found, f"{len(found)} history references:\n" + "\n".join(found)


def test_readme_is_short_and_its_test_command_is_what_ci_runs():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 125
    ci = (ROOT / ".ci" / "run").read_text()
    command = 'pip install -e ".[test,dask]" && python -m pytest -m "not slow" -n auto'
    assert command in readme
    assert 'python -m pytest -m "not slow" -n auto' in ci and '".[test,dask' in ci


def test_every_example_is_in_the_site_and_run_by_a_test():
    examples = sorted(p.stem for p in (ROOT / "examples").glob("*.py"))
    assert examples
    site = (ROOT / "mkdocs.yml").read_text()
    runner = (ROOT / "tests" / "integration" / "test_examples.py").read_text()
    for name in examples:
        assert (ROOT / "docs" / "examples" / f"{name}.md").is_file(), name
        assert f"examples/{name}.md" in site, name
        assert f'"{name}"' in runner, name
