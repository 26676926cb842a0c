"""The impact velocities a run registers, captured and replaced (`exudyn_linkage.
capturing_onsets`), and the share of the onsets' error an extrapolated value carries
(`exudyn_convergence._onset_weight`): pure Python, no Exudyn run."""

from __future__ import annotations

import math

import numpy as np

from mbs_clearance.backends.exudyn_convergence import _onset_weight, richardson
from mbs_clearance.backends.exudyn_linkage import ImpactMemory, OnsetCapture, _update_memory

H = 1e-6


def _approach(memory, rate, t0, steps=4, delta0=-2.5e-6):
    """A contact closing at a constant `rate` (m/s) from `delta0` (m) at t0 (s), one
    pre-step call per step h (at t_n+1 with the state of t_n): (the crossing time, s)."""
    for k in range(steps):
        t = t0 + k * H
        _update_memory(memory, t + H, H, delta0 + rate * (t - t0), rate, predict=False)
    return t0 - delta0 / rate


def test_a_capture_logs_each_onset_once_with_its_last_registration():
    capture = OnsetCapture()
    memory = ImpactMemory("journal", floor=1e-4)
    capture.attach(0, memory)
    crossing = _approach(memory, 1.0, 0.0)
    # a constant rate: the interpolation in delta is exact at the crossing
    [(t, v)] = capture.registered[0]
    assert math.isclose(t, crossing, rel_tol=1e-12) and v == 1.0
    # leave the contact, then a second onset at a slower rate, below the floor
    _update_memory(memory, 1e-5, H, -1e-7, -1.0, predict=False)
    _approach(memory, 5e-5, 2e-5, delta0=-1e-10)
    assert [v for _, v in capture.registered[0]] == [1.0, 1e-4]
    assert memory.onsets == 2


def test_a_shift_moves_the_first_onsets_only():
    capture = OnsetCapture(shift={0: [-0.25]})
    memory = ImpactMemory("journal", floor=1e-4)
    capture.attach(0, memory)
    _approach(memory, 1.0, 0.0)
    assert memory.dmin == 0.75                   # the first onset, shifted
    _update_memory(memory, 1e-5, H, -1e-7, -1.0, predict=False)
    _approach(memory, 0.5, 2e-5, delta0=-1e-6)
    assert memory.dmin == 0.5                    # the second keeps its own
    assert [v for _, v in capture.registered[0]] == [0.75, 0.5]


def test_a_refined_prediction_is_the_same_onset_and_both_registrations_are_shifted():
    """A predicted onset (registered a step early, from the rate extrapolated to the
    predicted crossing) refined at the crossing is one onset; the shift moves both."""
    plain, shifted = ImpactMemory("journal", 1e-4), ImpactMemory("journal", 1e-4)
    capture = OnsetCapture(shift={0: [0.125]})
    capture.attach(0, shifted)
    rates = [1.0, 1.2, 1.4, 1.6]                 # a closing contact, accelerating
    for memory, seen in ((plain, []), (shifted, [])):
        delta = -2.5e-6
        for k, rate in enumerate(rates):
            _update_memory(memory, (k + 1) * H, H, delta, rate, predict=True)
            seen.append(memory.dmin)
            delta += rate * H
        memory.seen = seen
    assert shifted.onsets == plain.onsets == 1 and len(capture.registered[0]) == 1
    assert plain.seen[1] == 1e-4                # the floor: no onset yet
    assert plain.seen[2] != plain.seen[3]       # predicted, then refined
    np.testing.assert_allclose(np.array(shifted.seen[2:]) - plain.seen[2:], 0.125,
                               rtol=1e-12)
    assert shifted.seen[1] == plain.seen[1]


def test_without_a_capture_nothing_is_logged_or_replaced():
    memory = ImpactMemory("journal", floor=1e-4)
    _approach(memory, 1.0, 0.0)
    assert memory.log is None and memory.dmin == 1.0


def test_the_onset_weight_is_the_extrapolations_share_of_the_last_difference():
    """Value y4 + (y4 - y2) / (2^p - 1) with registration errors R4, R2 carries
    R4 + (R4 - R2) / (2^p - 1): at most (1 + 1 / (2^p - 1)) |R4 - R2| where |R4| <= |R4 - R2|;
    unextrapolated, the value is y4 and carries R4. The weight is read from the value
    `richardson` returns (second order: 4/3; first: 2; not extrapolated: 1)."""
    # per revolution (column): differences 12, 3 (order 2); 2, 1 (order 1); -2, 1 (turned)
    rows = np.array([[16.0, 4.0, 1.0], [4.0, 2.0, 3.0], [1.0, 1.0, 2.0]]) + 100.0
    value, _, order = richardson(*rows)
    np.testing.assert_allclose(order[:2], [2.0, 1.0], rtol=1e-14)
    assert np.isnan(order[2])
    np.testing.assert_allclose(_onset_weight(value, rows), [4.0 / 3.0, 2.0, 1.0],
                               rtol=1e-12)
    rng = np.random.default_rng(1)
    for _ in range(100):
        p = rng.uniform(1.0, 4.0)
        r2, r4 = rng.normal(size=2)
        if abs(r4) > abs(r4 - r2):
            continue
        y = np.array([[2.0 + 2.0 ** p], [2.0], [1.0]])        # differences falling at p
        w = _onset_weight(richardson(*y)[0], y)[0]
        carried = r4 + (r4 - r2) / (2.0 ** p - 1.0)
        assert abs(carried) <= w * abs(r4 - r2) * (1 + 1e-12)
