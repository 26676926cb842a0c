"""Lankarani & Nikravesh's hysteresis damping: xi = 3 (1 - e^2) / 4 (Lankarani & Nikravesh
1990, "A contact force model with hysteresis damping for impact analysis of multibody
systems", J. Mech. Des. 112:369; the paper's Eq. 9). Derived for e close to 1."""

from ..base import ContactLaw
from ._restitution import restitution


def hysteresis(e):
    """xi(e)."""
    return 0.75 * (1.0 - e * e)


LAW = ContactLaw(name="lankarani_nikravesh", hysteresis=hysteresis,
                 restitution=restitution(low_open=True),
                 source="Lankarani & Nikravesh 1990, J. Mech. Des. 112:369")
