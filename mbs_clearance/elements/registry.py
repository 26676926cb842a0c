"""The registry of the joint kinds that are elements: which element modules exist, in the
order their joints' contacts follow the revolute clearance joints' in every layout of the
compiled model (parameters, events, rows, outputs). Adding a joint kind: its element module
(`base.Element`: every hook of `base.PIECES`), one line here, and its tests."""

from __future__ import annotations

from .base import Element
from .translational import ELEMENT as TRANSLATIONAL

__all__ = ["ELEMENTS", "KINDS", "element"]

#: the elements, in layout order
ELEMENTS: tuple[Element, ...] = (
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
