"""Joint kinds as elements: each kind in one module that brings its gap function, loads,
Jacobian rows, tangent terms, what the C printer needs, its reduced model's parameters, its
ideal joint and its Exudyn element (`base.Element`); the generator, the reduced model and
the backends iterate over the registry (`registry.ELEMENTS`, `registry.elements_with`)."""

from .base import PIECES, Element
from .registry import ELEMENTS, KINDS, element

__all__ = ["Element", "PIECES", "ELEMENTS", "KINDS", "element"]
