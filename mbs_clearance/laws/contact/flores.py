"""Flores et al.'s hysteresis damping: xi = 8 (1 - e) / (5 e) (Flores, Machado, Silva &
Martins 2011, "On the continuous contact force models for soft materials in multibody
dynamics", Multibody Syst. Dyn. 25:357). Valid over the whole range of e."""

from ..base import ContactLaw
from ._restitution import restitution


def hysteresis(e):
    """xi(e)."""
    return 1.6 * (1.0 - e) / e


LAW = ContactLaw(name="flores", hysteresis=hysteresis, restitution=restitution(low_open=True),
                 source="Flores, Machado, Silva & Martins 2011, Multibody Syst. Dyn. 25:357")
