"""Hydrodynamic lubrication of the clearance joint: the oil film's force and torque on the
journal (`journal_bearing`: the short- and long-bearing closed forms with the
half-Sommerfeld cavitation condition), its fade into dry contact near the wall (`hybrid`)
and the declared parameters of the film."""

from .hybrid import FADE_END, FADE_START, check_fade, fade, lubricated_force
from .journal_bearing import (
    BEARING_LENGTH,
    LAWS,
    MODELS,
    VISCOSITY,
    LubricationLaw,
    film_force,
    long_bearing,
    short_bearing,
)

__all__ = ["LubricationLaw", "LAWS", "MODELS", "VISCOSITY", "BEARING_LENGTH",
           "film_force", "short_bearing", "long_bearing", "FADE_START", "FADE_END", "fade",
           "lubricated_force", "check_fade"]
