"""The API reference shows what the code does: every default in its parameter tables is the
code's default, and every row is a parameter of the function or class.

The reference is rendered by mkdocstrings from the numpydoc docstrings of the objects that
docs/api.md lists; its tables come from griffe's numpy parser, run here with the options of
mkdocs.yml. The reference values come from the code itself: `inspect.signature` of the
imported object (a dataclass's generated ``__init__`` holds its field defaults).
"""

from __future__ import annotations

import ast
import importlib
import inspect
import operator
import re
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

griffe = pytest.importorskip("griffe")

ROOT = Path(__file__).resolve().parents[2]
_EMPTY = inspect.Parameter.empty
_EXPRESSION = 4.0


def _docstring_options() -> dict:
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    for plugin in config["plugins"]:
        if isinstance(plugin, dict) and "mkdocstrings" in plugin:
            options = plugin["mkdocstrings"]["handlers"]["python"]["options"]
            assert options["docstring_style"] == "numpy"
            return dict(options.get("docstring_options", {}))
    raise AssertionError("mkdocs.yml has no mkdocstrings plugin")


API_PATHS = re.findall(r"^::: (\S+)", (ROOT / "docs" / "api.md").read_text(), re.MULTILINE)
# the package is visited once (a load per object would visit it again each time)
_PACKAGE = griffe.GriffeLoader(search_paths=[str(ROOT)], extensions=griffe.load_extensions()
                               ).load("mbs_clearance")


def _rendered(path: str):
    """The griffe object of `path` and its public members that the page renders."""
    obj = _PACKAGE[path.removeprefix("mbs_clearance.")]
    stack = [obj]
    while stack:
        o = stack.pop()
        yield o
        if o.is_class:
            stack += [m for m in o.members.values() if not m.name.startswith("_")
                      and not m.is_alias and (m.is_function or m.is_class)]


def _imported(path: str):
    """The live object at dotted `path` and the module that defines it."""
    parts = path.split(".")
    for i in range(len(parts), 0, -1):
        try:
            module = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        obj = module
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj, module
    raise ImportError(path)


def _parameter_tables():
    """(object path, griffe parameter, live signature, defining module) of every row."""
    options = _docstring_options()
    for path in API_PATHS:
        for o in _rendered(path):
            if o.docstring is None:
                continue
            sections = [s for s in o.docstring.parse("numpy", **options)
                        if s.kind.value in ("parameters", "other parameters")]
            if not sections:
                continue
            live, module = _imported(o.path)
            signature = inspect.signature(live)
            for section in sections:
                for row in section.value:
                    yield o.path, row, signature, module


ROWS = list(_parameter_tables())


def _plain(name: str) -> str:
    return name.lstrip("*")


def test_the_reference_is_found():
    # the page lists the mechanism and the entry points; their tables are read
    assert "mbs_clearance.model.mechanism.SliderCrank" in API_PATHS
    assert "mbs_clearance.solve.simulate.simulate" in API_PATHS
    names = {(p, r.name) for p, r, _, _ in ROWS}
    assert ("mbs_clearance.model.mechanism.SliderCrank", "poisson_ratio") in names
    assert len(ROWS) > 100


def test_every_row_is_a_parameter():
    # prose after a parameter list at the left margin would render as rows named "A", "its"
    wrong = [f"{p}: {r.name!r}" for p, r, sig, _ in ROWS if _plain(r.name) not in sig.parameters]
    assert not wrong, "rows that are not parameters:\n" + "\n".join(wrong)


_OPERATORS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
              ast.Div: operator.truediv, ast.Pow: operator.pow, ast.USub: operator.neg}


def _value_of(text: str, module):
    """The value of a default as the page shows it: a literal, or arithmetic on public names
    of the defining module (a reader can look those up; a private name they cannot)."""

    def value(node):
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, (ast.Tuple, ast.List)):
            items = [value(e) for e in node.elts]
            return tuple(items) if isinstance(node, ast.Tuple) else items
        if isinstance(node, ast.Name):
            if node.id.startswith("_") or module is None or not hasattr(module, node.id):
                raise ValueError(f"{node.id} is not a public name of the module")
            return getattr(module, node.id)
        if isinstance(node, ast.BinOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](value(node.left), value(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](value(node.operand))
        raise ValueError("not a value")

    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError:
        raise ValueError("not a value") from None
    return value(tree.body)


def _wrong_defaults(rows) -> list[str]:
    """'object.name: ...' for every row whose shown default is not the code's."""
    wrong = []
    for path, row, signature, module in rows:
        param = signature.parameters.get(_plain(row.name))
        if param is None or param.kind in (param.VAR_POSITIONAL, param.VAR_KEYWORD):
            continue
        shown = row.default
        if shown is None:  # rendered as required
            if param.default is not _EMPTY:
                wrong.append(f"{path}.{row.name}: shown as required, code {param.default!r}")
            continue
        text = str(shown)
        try:
            value = _value_of(text, module)
        except ValueError as err:
            wrong.append(f"{path}.{row.name}: shown as {text!r}: {err}")
            continue
        if param.default is _EMPTY or not (value is param.default or value == param.default):
            wrong.append(f"{path}.{row.name}: shown {text}, code {param.default!r}")
    return wrong


def test_every_default_shown_is_the_codes_default():
    wrong = _wrong_defaults(ROWS)
    assert not wrong, "defaults in the API reference:\n" + "\n".join(wrong)


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def _wrong_text_defaults(rows) -> list[str]:
    """Rows whose description says "default <number>" where the code's default is another
    number."""
    wrong = []
    for path, row, signature, _ in rows:
        param = signature.parameters.get(_plain(row.name))
        if param is None or isinstance(param.default, bool) \
                or not isinstance(param.default, (int, float)):
            continue
        for m in re.finditer(rf"\bdefault:?\s+({_NUMBER})(?![\w.])", row.description):
            if float(m.group(1)) != param.default:
                wrong.append(f"{path}.{row.name}: text says {m.group(0)!r}, code "
                             f"{param.default!r}")
    return wrong


def test_every_default_stated_in_the_text_is_the_codes_default():
    wrong = _wrong_text_defaults(ROWS)
    assert not wrong, "\n".join(wrong)


@dataclass
class _Pair:
    """Two lengths.

    Parameters
    ----------
    first : float
        In m (default 1.0).
    second : float, default 3.0
        In m.
    third : float
        In m (default 2).
    fourth : float
        In m.
    """

    first: float = 1.0
    second: float = 2.0
    third: float = 2.0 * 3
    fourth: float = _EXPRESSION


def test_the_check_finds_a_wrong_default():
    # a stated default that the code does not have, and one shown as a private name that a
    # reader cannot look up; arithmetic on literals is a value
    source = "from dataclasses import dataclass\n_EXPRESSION = 4.0\n" + inspect.getsource(_Pair)
    with griffe.temporary_visited_package("pairs", {"__init__.py": source},
                                          extensions=griffe.load_extensions()) as package:
        sections = package["_Pair"].docstring.parse("numpy", **_docstring_options())
    rows = [("_Pair", row, inspect.signature(_Pair), package) for row in sections[1].value]
    assert [r.name for _, r, _, _ in rows] == ["first", "second", "third", "fourth"]
    wrong = _wrong_defaults(rows)
    assert [w.split(":")[0] for w in wrong] == ["_Pair.second", "_Pair.fourth"]
    wrong = _wrong_text_defaults(rows)
    assert [w.split(":")[0] for w in wrong] == ["_Pair.third"]
