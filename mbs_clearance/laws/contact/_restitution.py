"""The restitution parameter shared by the contact laws' declarations."""

from ..base import Parameter


def restitution(low_open: bool) -> Parameter:
    """The coefficient of restitution e in [0, 1] ((0, 1] where xi(e) divides by e)."""
    return Parameter("restitution", "e", "-", 0.9, 0.0, 1.0, low_open=low_open,
                     high_open=False, source="paper: e = 0.9")
