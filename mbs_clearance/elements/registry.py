"""The registry of the joint kinds that are elements: which element modules exist, in the
order of their joints' contacts in every layout of the compiled model (parameters, events,
rows, outputs): the revolute clearance joints' first. Adding a joint kind: its element
module (`base.Element`: every hook of the pieces of `base.PIECES` it brings), one line here,
and its tests."""

from __future__ import annotations

from .base import PIECES, Element
from .revolute import ELEMENT as REVOLUTE
from .translational import ELEMENT as TRANSLATIONAL

__all__ = ["ELEMENTS", "KINDS", "element", "elements_with"]

#: the elements, in layout order
ELEMENTS: tuple[Element, ...] = (
    REVOLUTE,
    TRANSLATIONAL,
)

#: kind name -> element
KINDS: dict[str, Element] = {el.kind: el for el in ELEMENTS}


def element(kind: str) -> Element:
    """The element of joint kind `kind`; ValueError naming the allowed kinds otherwise."""
    try:
        return KINDS[kind]
    except (KeyError, TypeError):
        raise ValueError(f"unknown joint kind {kind!r}; allowed: {sorted(KINDS)}") from None


def elements_with(piece: str) -> tuple[Element, ...]:
    """The elements that bring `piece` (a key of `base.PIECES`), in layout order."""
    if piece not in PIECES:
        raise ValueError(f"unknown piece {piece!r}; allowed: {sorted(PIECES)}")
    return tuple(el for el in ELEMENTS if piece in el.pieces)
