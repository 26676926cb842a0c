"""Regenerate the checked-in model modules of the named cases (mbs_clearance/_generated).

    python tools/generate_models.py

Writes mbs_clearance/_generated/<case>.py for every case of `generate.NAMED_CASES` that
mbs_clearance.model.cases defines, and the registry MODULES (structure digest -> module) in
mbs_clearance/_generated/__init__.py. tests/unit/test_generate.py fails when a checked-in
module differs from what this writes.
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))   # this worktree's package, not an installed one

from mbs_clearance.generate import (  # noqa: E402
    generate_module,
    named_cases,
    registry_source,
)


def main():
    folder = ROOT / "mbs_clearance" / "_generated"
    cases = named_cases()
    for name, linkage in cases.items():
        (folder / f"{name}.py").write_text(generate_module(linkage))
        print(f"wrote {folder / name}.py")
    (folder / "__init__.py").write_text(registry_source(cases))
    print(f"wrote {folder / '__init__.py'}")


if __name__ == "__main__":
    main()
