"""ISO 286 clearance fits: a fit class (e.g. "H7/g6") and a nominal diameter -> the limits of
the hole and the shaft and the clearance range.

Values are those of ISO 286-1:2010, "Geometrical product specifications (GPS) - ISO code
system for tolerances on linear sizes - Part 1: Basis of tolerances, deviations and fits":
Table 1 (standard tolerance grades IT5-IT11) and Table 2 (fundamental deviations es of the
shafts d, e, f, g, h; for the holes D, E, F, G, H the standard's rule EI = -es of the same
letter applies, Table 3), for nominal sizes up to 500 mm, in micrometres. The tables are the
rounded values of the formulas of the standard's basis (ISO 286-1, Annex A; reproduced in
`FORMULAS` and checked against the tables in tests/unit/test_tolerance.py):
i = 0.45 D^(1/3) + 0.001 D um (D the geometric mean of the size range in mm), IT5..IT11 =
7, 10, 16, 25, 40, 64, 100 i; es(d) = -16 D^0.44, es(e) = -11 D^0.41, es(f) = -5.5 D^0.41,
es(g) = -2.5 D^0.34 um.

Only clearance fits are covered (hole letters D-H with shaft letters d-h), the only ones
that leave the journal free in its bearing.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

__all__ = ["Fit", "iso_fit", "SIZE_RANGES", "IT_GRADES", "SHAFT_DEVIATIONS", "FORMULAS"]

#: nominal size ranges (over, up to and including), mm (ISO 286-1 Tables 1 and 2)
SIZE_RANGES: tuple[tuple[float, float], ...] = (
    (0, 3), (3, 6), (6, 10), (10, 18), (18, 30), (30, 50), (50, 80), (80, 120), (120, 180),
    (180, 250), (250, 315), (315, 400), (400, 500))

#: standard tolerance grades, um, per size range (ISO 286-1:2010 Table 1)
IT_GRADES: dict[int, tuple[int, ...]] = {
    5: (4, 5, 6, 8, 9, 11, 13, 15, 18, 20, 23, 25, 27),
    6: (6, 8, 9, 11, 13, 16, 19, 22, 25, 29, 32, 36, 40),
    7: (10, 12, 15, 18, 21, 25, 30, 35, 40, 46, 52, 57, 63),
    8: (14, 18, 22, 27, 33, 39, 46, 54, 63, 72, 81, 89, 97),
    9: (25, 30, 36, 43, 52, 62, 74, 87, 100, 115, 130, 140, 155),
    10: (40, 48, 58, 70, 84, 100, 120, 140, 160, 185, 210, 230, 250),
    11: (60, 75, 90, 110, 130, 160, 190, 220, 250, 290, 320, 360, 400),
}

#: upper deviation es of the shafts, um, per size range (ISO 286-1:2010 Table 2)
SHAFT_DEVIATIONS: dict[str, tuple[int, ...]] = {
    "d": (-20, -30, -40, -50, -65, -80, -100, -120, -145, -170, -190, -210, -230),
    "e": (-14, -20, -25, -32, -40, -50, -60, -72, -85, -100, -110, -125, -135),
    "f": (-6, -10, -13, -16, -20, -25, -30, -36, -43, -50, -56, -62, -68),
    "g": (-2, -4, -5, -6, -7, -9, -10, -12, -14, -15, -17, -18, -20),
    "h": (0,) * 13,
}

#: the formulas behind the tables (ISO 286-1 Annex A), D in mm -> um, for checking
FORMULAS = {
    "i": lambda D: 0.45 * D ** (1.0 / 3.0) + 0.001 * D,
    "IT": {5: 7, 6: 10, 7: 16, 8: 25, 9: 40, 10: 64, 11: 100},
    "es": {"d": lambda D: -16.0 * D**0.44, "e": lambda D: -11.0 * D**0.41,
           "f": lambda D: -5.5 * D**0.41, "g": lambda D: -2.5 * D**0.34, "h": lambda D: 0.0},
}

_FIT = re.compile(r"^\s*([A-Z])(\d{1,2})\s*/\s*([a-z])(\d{1,2})\s*$")


@dataclass(frozen=True)
class Fit:
    """A clearance fit at a nominal diameter; limits in m (diametral).

    Attributes
    ----------
    name : the fit class, e.g. "H7/g6"
    diameter : nominal diameter, m
    hole : (lower, upper) deviation of the hole from the nominal diameter, m
    shaft : (lower, upper) deviation of the shaft, m
    """

    name: str
    diameter: float
    hole: tuple[float, float]
    shaft: tuple[float, float]

    @property
    def clearance(self) -> tuple[float, float]:
        """(minimum, maximum) diametral clearance, m."""
        return self.hole[0] - self.shaft[1], self.hole[1] - self.shaft[0]

    @property
    def radial_clearance(self) -> tuple[float, float]:
        """(minimum, maximum) radial clearance R_B - R_J, m (half the diametral)."""
        lo, hi = self.clearance
        return lo / 2.0, hi / 2.0


def _range_index(diameter_mm: float) -> int:
    for k, (a, b) in enumerate(SIZE_RANGES):
        if a < diameter_mm <= b:
            return k
    raise ValueError(f"diameter must be in (0, 0.5] m (ISO 286 sizes up to 500 mm are "
                     f"tabulated here); got {diameter_mm / 1000.0!r} m")


def iso_fit(fit: str, diameter: float) -> Fit:
    """The limits of an ISO 286 clearance fit ("H7/g6", "G7/h6", ...) at a nominal
    `diameter` in m (0 < diameter <= 0.5 m).

    Hole letters D, E, F, G, H and shaft letters d, e, f, g, h with grades 5-11; a fit
    whose minimum clearance is zero (H/h) is accepted here (the tolerance study rejects
    it, the model needs a clearance > 0).
    """
    if not isinstance(fit, str) or not _FIT.match(fit):
        raise ValueError(f"fit must be a string like 'H7/g6' (hole letter, grade / shaft "
                         f"letter, grade); got {fit!r}")
    if isinstance(diameter, bool) or not isinstance(diameter, (int, float)) \
            or not math.isfinite(diameter) or diameter <= 0:
        raise ValueError(f"diameter must be a finite number > 0 in m; got {diameter!r}")
    hl, hg, sl, sg = _FIT.match(fit).groups()
    hg, sg = int(hg), int(sg)
    letters = sorted(SHAFT_DEVIATIONS)
    if hl.lower() not in SHAFT_DEVIATIONS or sl not in SHAFT_DEVIATIONS:
        raise ValueError(f"fit {fit!r}: only clearance fits are tabulated, hole letters "
                         f"{[x.upper() for x in letters]} and shaft letters {letters}")
    for grade in (hg, sg):
        if grade not in IT_GRADES:
            raise ValueError(f"fit {fit!r}: grade {grade} not tabulated; allowed grades "
                             f"{min(IT_GRADES)}-{max(IT_GRADES)}")
    k = _range_index(diameter * 1000.0)
    um = 1e-6
    ei_hole = -SHAFT_DEVIATIONS[hl.lower()][k]          # EI = -es (ISO 286-1 Table 3)
    es_shaft = SHAFT_DEVIATIONS[sl][k]
    hole = (ei_hole * um, (ei_hole + IT_GRADES[hg][k]) * um)
    shaft = ((es_shaft - IT_GRADES[sg][k]) * um, es_shaft * um)
    return Fit(name=f"{hl}{hg}/{sl}{sg}", diameter=float(diameter), hole=hole, shaft=shaft)
