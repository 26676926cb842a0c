"""One accuracy contract: the entry points' defaults against converged values (the reduced
model at rtol 1e-12) at the paper's point and off it."""

from __future__ import annotations

import math
import warnings

import pytest

from mbs_clearance import SliderCrank, peak_base_force, simulate
from mbs_clearance.solve.accuracy import DEFAULT_ACCURACY

RPM = 2 * math.pi / 60


@pytest.mark.slow      # the rtol 1e-12 references: minutes per design on a loaded machine
@pytest.mark.parametrize("design", [
    {}, {"crank_speed": 2000 * RPM}, {"journal_radius": 0.01 - 5e-5},
    {"crank_length": 0.045, "coupler_length": 0.125}],
    ids=["paper", "2000rpm", "c0.05mm", "L2_4.5cm_L3_12.5cm"])
def test_peak_base_force_default_meets_the_default_accuracy(design):
    """`peak_base_force`'s default is `simulate`'s (the same number), within 1e-5 of the
    converged value at the paper's point and three off it; the single run at rtol 1e-7
    (the GA's cheaper default) is what missed it at 2000 rpm (measured: default 9.2e-7 and
    7.7e-7 off at the paper's point and 2000 rpm, rtol 1e-7 9.2e-7 and 1.24e-3)."""
    mech = SliderCrank(**design)
    ref = simulate(mech, 4, rtol=1e-12).peaks[3]
    peak = peak_base_force(mech, 4)
    assert abs(peak / ref - 1.0) <= DEFAULT_ACCURACY, peak / ref - 1.0
    assert peak == simulate(mech, 4).peaks[3]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fixed = peak_base_force(mech, 4, rtol=1e-7)
    print(f"{design}: default {peak / ref - 1:.2e}, rtol 1e-7 {fixed / ref - 1:.2e}")
