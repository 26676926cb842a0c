"""The frictionless joint (the paper's Eqs. 6-8): Ft = 0."""

from ..base import FrictionLaw


def force(vt, fn):
    """Ft."""
    return 0.0


LAW = FrictionLaw(name="none", force=force, arguments=(), parameters=(),
                  source="the paper's Eqs. 6-8")
