"""Hu & Guo's hysteresis damping: xi = 3 (1 - e) / (2 e) (Hu & Guo 2015, a dissipative
contact force model for impact analysis in multibody dynamics, Multibody Syst. Dyn.
35:131), derived from the energy balance of the whole impact for the whole range of e (like
Flores et al.'s, it grows without bound as e goes to 0)."""

from ..base import ContactLaw
from ._restitution import restitution


def hysteresis(e):
    """xi(e)."""
    return 1.5 * (1.0 - e) / e


LAW = ContactLaw(name="hu_guo", hysteresis=hysteresis, restitution=restitution(low_open=True),
                 source="Hu & Guo 2015, Multibody Syst. Dyn. 35:131")
