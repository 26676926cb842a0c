"""Regularised Coulomb friction: Ft = -mu Fn vt / sqrt(vt^2 + v0^2), the sign of vt smoothed
over the velocity scale v0 (a smooth stand-in for the set-valued sign; |phi| > 0.995 for
|vt| > 10 v0)."""

from ..base import FrictionLaw
from ..ops import sqrt
from ._common import MU, V0


def force(vt, fn, mu, v0):
    """Ft."""
    return -mu * fn * (vt / sqrt(vt * vt + v0 * v0))


LAW = FrictionLaw(name="coulomb", force=force, arguments=("friction_coefficient",
                                                          "friction_v0"),
                  parameters=(MU, V0), source="Coulomb's law, regularised (e.g. Pennestri "
                  "et al. 2016, Nonlinear Dyn. 83:1785)")
