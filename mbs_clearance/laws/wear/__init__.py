"""Wear laws of the clearance joints' surfaces (`archard`)."""

from .archard import WEAR_COEFFICIENT, pressure_weights, wear_increment

__all__ = ["WEAR_COEFFICIENT", "pressure_weights", "wear_increment"]
