"""The package keeps its layers (docs/architecture.md): each imports only the layers its
row of tools/architecture.py allows, no modules import each other in a circle, and the
library never imports the validation package. Read from the sources; nothing is run."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import architecture as arch  # noqa: E402


@pytest.fixture(scope="module")
def graph():
    return arch.imports()


def test_every_module_is_in_a_layer(graph):
    for module in graph:
        if module != arch.PACKAGE:
            assert arch.layer_of(module) in arch.LAYERS


def test_layers_import_only_what_they_may(graph):
    assert arch.breaches(graph) == []


def test_no_import_circles(graph):
    assert arch.circles(arch.module_edges(graph)) == []


def test_the_checks_can_fail():
    """The reader and the checks see a breach, an import of validation and a circle."""
    fake = {"mbs_clearance.numerics.integrator": {"mbs_clearance.solve.reduced.run"},
            "mbs_clearance.solve.reduced": {"mbs_clearance.numerics.integrator",
                                            "validation.report"}}
    bad = arch.breaches(fake)
    assert any("numerics" in b and "solve" in b for b in bad)
    assert any("never imports validation" in b for b in bad)
    assert arch.circles(arch.module_edges(fake)) == [["mbs_clearance.numerics.integrator",
                                                      "mbs_clearance.solve.reduced"]]


def test_function_level_imports_are_read(tmp_path):
    """An import inside a function counts (it ties the modules as much as one at the top)."""
    pkg = tmp_path / arch.PACKAGE / "model"
    pkg.mkdir(parents=True)
    (tmp_path / arch.PACKAGE / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "cases.py").write_text("def f():\n    from ..solve.reduced import run\n")
    g = arch.imports(tmp_path)
    assert "mbs_clearance.solve.reduced.run" in g["mbs_clearance.model.cases"]


def test_the_result_type_does_not_import_the_generator(graph):
    """A saved trajectory loads without the generator (nothing to compile to read a file)."""
    names = graph["mbs_clearance.solve.trajectory"]
    assert not [n for n in names if n.startswith("mbs_clearance.generate")]
