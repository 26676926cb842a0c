"""The output-time landing shared by reduced.run and linkage_model.run (one helper)."""

from __future__ import annotations

import numpy as np
import pytest

from mbs_clearance.solve.linkage_model import landed_indices, landing_edges, window_peaks


def test_landing_edges_unite_edges_and_times_without_near_duplicates():
    t_eval, edges = landing_edges(np.array([0.0, 1.0, 2.0]), [0.5, 1.0 + 1e-14, 1.5, 2.0])
    np.testing.assert_array_equal(t_eval, [0.5, 1.0 + 1e-14, 1.5, 2.0])
    # 1 + 1e-14 lies within 1e-12 of the span (2 s) of the edge 1.0: landed there once
    np.testing.assert_array_equal(edges, [0.0, 0.5, 1.0, 1.5, 2.0])
    with pytest.raises(ValueError, match="t_eval"):
        landing_edges(np.array([0.0, 1.0]), [0.5, 3.0])


def test_landed_indices_and_window_peaks_against_a_direct_search():
    rng = np.random.default_rng(3)
    ts = np.sort(np.concatenate([[0.0, 1.0, 2.0], rng.uniform(0.0, 2.0, 40)]))
    t_eval = ts[::5].copy()
    keep = landed_indices(ts, t_eval)
    np.testing.assert_array_equal(ts[keep], t_eval)
    outs = rng.normal(size=(len(ts), 4))
    peaks = window_peaks(ts, outs, 1, np.array([0.0, 1.0, 2.0]))
    for i, (a, b) in enumerate([(0.0, 1.0), (1.0, 2.0)]):
        best = max(np.hypot(outs[k, 1], outs[k, 2]) for k in range(len(ts)) if a <= ts[k] <= b)
        assert peaks[i] == best
