"""The peak refinement between fixed steps (exudyn_linkage.refine_peak) on closed-form
signals: its error falls at least at fifth order in the step, whatever the phase of the
peak between the samples, so that Exudyn's refined peaks converge at generalized-alpha's
second order."""

import numpy as np
import pytest

from mbs_clearance.backends import exudyn_linkage as xl


def _signal(t):
    # an asymmetric impact-like pulse on a slow background; its maximum is not at a sample
    u = (t - 0.3) / 0.05
    return 3.0 * np.exp(-u * u) * (1.0 + 0.2 * u) + 0.1 * np.cos(7.0 * t)


def _worst_error(h, true):
    """Largest error of the refined peak over 36 phases of the grid against the peak."""
    worst = 0.0
    for phase in np.arange(36) / 36.0:
        t = 0.3 + (np.arange(-200, 200) + phase) * h
        y = _signal(t)
        worst = max(worst, abs(xl.refine_peak(t, y, int(np.argmax(y))) - true))
    return worst


def test_refined_peak_converges_at_fifth_order_or_better():
    fine = np.linspace(0.28, 0.33, 2_000_001)
    true = float(_signal(fine).max())       # the reference: a 2.5e-8 grid, quadratic error
    steps = [0.01, 0.005, 0.0025]           # 10, 20, 40 steps per pulse width
    errors = [_worst_error(h, true) for h in steps]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders >= 5.0), (errors, orders)
    # the parabola through three samples, for contrast: an order lower at best
    t = 0.3 + (np.arange(-200, 200) + 0.37) * steps[0]
    y = _signal(t)
    i = int(np.argmax(y))
    assert abs(xl._parabola(y, i) - true) > abs(xl.refine_peak(t, y, i) - true)


def test_refined_peak_edges_and_non_maxima():
    t = np.linspace(0.0, 1.0, 11)
    y = 2.0 - (t - 0.52) ** 2
    # a quadratic is reproduced exactly by the quartic (and by the parabola near the ends)
    assert xl.refine_peak(t, y, 5) == pytest.approx(2.0, rel=1e-12)
    assert xl.refine_peak(t, t, 10) == 1.0           # the end of the record: the sample
    y = 1.0 - (t - 0.05) ** 2                        # largest at sample 1: parabola there
    assert xl.refine_peak(t, y, 1) == pytest.approx(1.0, rel=1e-12)


def test_ringing_samples_fall_back_to_the_parabola():
    """Samples that do not rise then fall over the five (a start-up's ringing: these are
    Exudyn's first samples of the lubricated case at 6000 steps a revolution) are no
    resolved smooth peak: the quartic through them overshoots every sample by 110 N, the
    parabola through the largest sample and its neighbours stays within the ringing's
    amplitude."""
    y = np.array([5534.51892426, 8265.19304866, 8277.74782606, 8257.72898981,
                  8271.91385905, 8261.18325298])
    t = np.arange(len(y)) * 2e-6
    quartic = np.polyfit(np.arange(-2, 3), y[0:5], 4)
    overshoot = max(np.polyval(quartic, s) for s in np.linspace(-1, 1, 201))
    assert overshoot > y.max() + 100.0                # what the guard keeps out
    refined = xl.refine_peak(t, y, 2)
    assert refined == xl._parabola(y, 2)
    assert y[2] <= refined <= y[2] + (y[2] - y[3])
