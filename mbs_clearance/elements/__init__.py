"""Joint kinds as elements: each kind in one module that brings its gap function, loads,
Jacobian rows, tangent terms, what the C printer needs and its Exudyn element
(`base.Element`); the generator and the Exudyn backend iterate over the registry
(`registry.ELEMENTS`)."""

from .base import PIECES, Element
from .registry import ELEMENTS, KINDS, element

__all__ = ["Element", "PIECES", "ELEMENTS", "KINDS", "element"]
