"""The wear rate of a worn joint from both models: the reduced model's series and Exudyn's
give the same Archard wear per cycle."""

import dataclasses

import numpy as np
import pytest

from mbs_clearance.model.cases import paper_slider_crank_wear
from mbs_clearance.studies.wear import cycle_wear, wear_life

pytestmark = [pytest.mark.exudyn, pytest.mark.slow]       # 4 Exudyn revolutions: ~30 s


def test_both_models_wear_a_worn_joint_alike():
    case = paper_slider_crank_wear()
    life = wear_life(case, 5e5, tolerance=0.02)
    worn = dataclasses.replace(case.clearance_joints[0],
                               bearing_profile=tuple(life.profiles[-1]))
    case = case.replace(clearance_joints=(worn,))
    k = worn.wear_coefficient
    reduced = cycle_wear(case, 0, k)
    exudyn = cycle_wear(case, 0, k, backend="exudyn")
    # measured: volume 2e-4 apart, depth 7e-4 of its largest value on the circular start;
    # Exudyn's default step is its error (second order, h = 2 us)
    assert exudyn.volume == pytest.approx(reduced.volume, rel=2e-3)
    assert np.max(np.abs(exudyn.depth - reduced.depth)) < 3e-3 * reduced.depth.max()
    # the peaks at Exudyn's default step differ by its step error (0.15 % here); converged,
    # they agree within their bars (test_exudyn_profile.py, the worn bearing's cross-check)
