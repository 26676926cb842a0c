"""The kernels' sincos against the C library's sin and cos."""

import math

import numpy as np
import pytest

from mbs_clearance.numerics._trig import PIO2_HI, PIO2_LO, sincos


def test_the_split_of_pi_over_2():
    # the high part has 33 significant bits (k * hi exact for |k| < 2^20) and the two parts
    # add up to pi/2 beyond double precision
    mantissa = PIO2_HI.hex().split(".")[1].split("p")[0]
    assert mantissa.rstrip("0") and len(mantissa.rstrip("0")) <= 8
    assert PIO2_HI + PIO2_LO == math.pi / 2
    assert abs(PIO2_LO) < 1e-10


@pytest.mark.parametrize("span", [1.0, 30.0, 1e3, 1e5])
def test_sincos_equals_libm_to_an_ulp_of_one(span):
    x = np.random.default_rng(7).uniform(-span, span, 20000)
    # near the quadrant boundaries, where the reduction matters most
    k = np.arange(-2000, 2000)
    x = np.concatenate([x, k * (math.pi / 2), k * (math.pi / 2) + 1e-9,
                        k * (math.pi / 2) + math.pi / 4])
    x = x[np.abs(x) <= span]
    got = np.array([sincos(v) for v in x])
    ref = np.column_stack([np.sin(x), np.cos(x)])
    # absolute error of the order of one ulp of 1 (the model adds these to O(1) terms)
    assert np.max(np.abs(got - ref)) <= 2.3e-16
