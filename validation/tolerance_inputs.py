"""The tolerances of the paper's case that the report and the tolerance benchmark study."""

from __future__ import annotations

from mbs_clearance import SliderCrank
from mbs_clearance.studies.tolerance import FitClearance, band

#: the 8 fields of the target: lengths to +-0.05 mm, masses to +-2 %, crank inertia to
#: +-5 %, the clearance of an H7/g6 fit on the 20 mm pin, restitution 0.85-0.95
_M = SliderCrank()
INPUTS = {
    "crank_length": band(_M.crank_length, 5e-5),
    "coupler_length": band(_M.coupler_length, 5e-5),
    "crank_mass": band(_M.crank_mass, 0.02 * _M.crank_mass),
    "coupler_mass": band(_M.coupler_mass, 0.02 * _M.coupler_mass),
    "slider_mass": band(_M.slider_mass, 0.02 * _M.slider_mass),
    "crank_inertia": band(_M.crank_inertia, 0.05 * _M.crank_inertia),
    "radial_clearance": FitClearance("H7/g6", 2 * _M.bearing_radius),
    "restitution": band(0.9, 0.05),
}

#: each input's tolerance in words (the report lists those its study varies)
DESCRIPTIONS = {
    "crank_length": "crank length to \u00b10.05 mm",
    "coupler_length": "coupler length to \u00b10.05 mm",
    "crank_mass": "crank mass to \u00b12 %",
    "coupler_mass": "coupler mass to \u00b12 %",
    "slider_mass": "slider mass to \u00b12 %",
    "crank_inertia": "crank inertia to \u00b15 %",
    "radial_clearance": "the radial clearance of an H7/g6 fit on the 20 mm pin (ISO 286)",
    "restitution": "restitution 0.85-0.95",
}
