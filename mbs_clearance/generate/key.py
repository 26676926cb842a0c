"""What a generated module is keyed by, without the generator (no sympy): a linkage's
structure, the geometric parameters it is specialised on, and the generator's version.
Finding a checked-in or cached module needs only this."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from ..model.linkage import GROUND, Linkage, Prismatic

__all__ = ["GENERATOR_VERSION", "structure_digest", "geometric_zeros", "model_structure"]

_HERE = Path(__file__).parent
#: the generator's sources: any edit of them (or of an element module, which brings its
#: joint kind's share of the derivation and the plan) changes the key of every generated
#: module
_SOURCES = ("derive.py", "writer.py", "jacobians.py", "key.py")


def _generator_version() -> str:
    h = hashlib.sha256()
    elements = sorted((_HERE.parent / "elements").glob("*.py"))
    for path in [*(_HERE / name for name in _SOURCES), *elements]:
        h.update(path.read_bytes().replace(b"\r\n", b"\n") + b"\0")
    return h.hexdigest()[:16]


#: part of the cache key: the generated code changes with the generator's sources
GENERATOR_VERSION = _generator_version()


def structure_digest(structure: dict) -> str:
    """SHA-256 of a linkage structure and the generator version: the cache key."""
    text = json.dumps(structure, sort_keys=True) + "\0" + GENERATOR_VERSION
    return hashlib.sha256(text.encode()).hexdigest()


def geometric_zeros(linkage: Linkage) -> tuple[str, ...]:
    """Dotted names (p order) of `linkage`'s geometric parameters whose value is exactly 0:
    body and ground point coordinates, prismatic axis angles. The generated model of a
    linkage is specialised on them (`derive.specialise`): a point on a body's axis or a
    guide through the origin adds no terms to the equations."""
    zeros = []
    for b in linkage.bodies:
        for pt, xy in b.points.items():
            zeros += [f"{b.name}.{pt}.{c}" for c, v in zip("xy", xy) if v == 0.0]
    for pt, xy in linkage.ground_points.items():
        zeros += [f"{GROUND}.{pt}.{c}" for c, v in zip("xy", xy) if v == 0.0]
    zeros += [f"{j.name}.angle" for j in linkage.joints
              if isinstance(j, Prismatic) and j.angle == 0.0]
    return tuple(zeros)


def model_structure(linkage: Linkage, specialise: bool = True) -> dict:
    """What `linkage`'s generated module depends on: its structure (`Linkage.structure`)
    and, when specialised, the geometric parameters that are exactly zero in it."""
    structure = linkage.structure()
    zeros = geometric_zeros(linkage) if specialise else ()
    if zeros:
        structure["zero_parameters"] = list(zeros)
    return structure
