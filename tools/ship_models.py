"""Write the named cases' generated C sources into the package (mbs_clearance/generate/
shipped/), so that a first run of a named case compiles without deriving its model.

    python tools/ship_models.py

Each named case's model, specialised on its zero-valued parameters (plain runs) and general
(sensitivities, the GA), is derived and printed as a first use would; files of sources no
case has any more are removed. tests/unit/test_shipped_models.py checks that every case has
its current source here (run this after a change of the printer, the loader or a case)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mbs_clearance.generate.c_loader import SHIPPED, _render, source_key  # noqa: E402
from mbs_clearance.generate.key import model_structure, structure_digest  # noqa: E402
from mbs_clearance.model.cases import CASES  # noqa: E402


def shipped_keys() -> dict[str, tuple[str, bool]]:
    """{source key: (case, specialise)} of every named case's two models."""
    out = {}
    for name in sorted(CASES):
        linkage = CASES[name]()
        for specialise in (True, False):
            key = source_key(structure_digest(model_structure(linkage, specialise)))
            out.setdefault(key, (name, specialise))
    return out


def main() -> int:
    SHIPPED.mkdir(exist_ok=True)
    keys = shipped_keys()
    for key, (name, specialise) in keys.items():
        path = SHIPPED / f"model-source-{key}.json"
        if path.is_file():
            continue
        source, meta = _render(CASES[name](), specialise)
        path.write_text(json.dumps({"case": name, "specialise": specialise, "source": source,
                                    "meta": meta}, sort_keys=True) + "\n")
        print(f"wrote {path.name} ({name}, {'specialised' if specialise else 'general'})")
    for path in SHIPPED.glob("model-source-*.json"):
        if path.name[len("model-source-"):-len(".json")] not in keys:
            path.unlink()
            print(f"removed {path.name} (no case has it)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
