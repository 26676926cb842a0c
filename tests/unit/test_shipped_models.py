"""The named cases' C sources shipped with the package (`c_loader.SHIPPED`, written by
tools/ship_models.py): every case's two models are there under their current key, nothing
else is, a shipped source is what a derivation prints, and a first run uses it."""

import json
import sys
from pathlib import Path

import pytest

from mbs_clearance.generate import c_loader
from mbs_clearance.generate.key import model_structure, structure_digest
from mbs_clearance.model.cases import CASES

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import ship_models  # noqa: E402


def test_every_named_case_ships_its_current_sources_and_nothing_else():
    keys = ship_models.shipped_keys()
    files = {p.name[len("model-source-"):-len(".json")]
             for p in c_loader.SHIPPED.glob("model-source-*.json")}
    missing = sorted(set(keys) - files)
    assert not missing, (f"{[keys[k] for k in missing]} have no shipped source under their "
                         "current key: run `python tools/ship_models.py`")
    assert files == set(keys), "stale shipped sources: run `python tools/ship_models.py`"


def test_a_shipped_source_is_what_a_derivation_prints():
    link = CASES["paper_slider_crank"]()
    key = c_loader.source_key(structure_digest(model_structure(link, True)))
    data = json.loads((c_loader.SHIPPED / f"model-source-{key}.json").read_text())
    source, meta = c_loader._render(link, True)
    assert data["source"] == source
    assert json.loads(json.dumps(meta)) == data["meta"]


def test_a_first_run_of_a_named_case_derives_nothing(monkeypatch):
    def refuse(*args):
        raise AssertionError("derived a shipped model")

    monkeypatch.setattr(c_loader, "_render", refuse)
    link = CASES["four_bar"]()
    digest = structure_digest(model_structure(link, True))
    source, meta = c_loader._cached_render(link, True, digest)
    assert "mbs_model_record" in source and meta["N_STATE"] > 0


@pytest.mark.parametrize("name", sorted(CASES))
def test_shipped_metadata_reads_as_the_cache_reads_it(name):
    link = CASES[name]()
    digest = structure_digest(model_structure(link, False))
    source, meta = c_loader._cached_render(link, False, digest)
    assert all(not isinstance(v, list) for v in meta.values())
