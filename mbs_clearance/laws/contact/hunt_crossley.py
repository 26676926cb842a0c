"""Hunt & Crossley's hysteresis damping: xi = 3 (1 - e) / 2 (Hunt & Crossley 1975,
"Coefficient of restitution interpreted as damping in vibroimpact", J. Appl. Mech. 42:440,
in the form of Flores et al. 2011)."""

from ..base import ContactLaw
from ._restitution import restitution


def hysteresis(e):
    """xi(e)."""
    return 1.5 * (1.0 - e)


LAW = ContactLaw(name="hunt_crossley", hysteresis=hysteresis,
                 restitution=restitution(low_open=True),
                 source="Hunt & Crossley 1975, J. Appl. Mech. 42:440")
