"""The compiled series helpers (core/series.c) against their numpy formulas: the windows'
maxima of the combined state sensitivities' weighted norms (a DDM run's growth), bit for
bit, on strided states, directions combined from several integrated ones, NaN rows and
empty windows."""

import numpy as np
import pytest

from mbs_clearance.generate.c_loader import window_norm_maxima
from mbs_clearance.solve.linkage_ddm import _sparse_columns


def numpy_window_norm_maxima(s, ptr, rows, vals, weights, lo, hi):
    """The formula in numpy, operation by operation (the reference)."""
    n2 = s.shape[2]
    npar = ptr.shape[0] - 1
    out = np.zeros((lo.shape[0], npar))
    for k in range(npar):
        e0, e1 = ptr[k], ptr[k + 1]
        if e1 - e0 == 1:
            comb = s[:, rows[e0], :] * vals[e0]
        else:
            comb = np.zeros((s.shape[0], n2))
            for e in range(e0, e1):
                comb += s[:, rows[e], :] * vals[e]
        acc2 = np.zeros(s.shape[0])
        for j in range(n2):
            acc2 += weights[k, j] * comb[:, j] * comb[:, j]
        for w in range(lo.shape[0]):
            if hi[w] > lo[w]:
                out[w, k] = max(0.0, float(acc2[lo[w]:hi[w]].max()))
    return out


def _case(rng, n=400, nb=5, n2=4, width=40):
    """States as a DDM run keeps them: a (n, width) record whose columns n2 .. n2 (1 + nb)
    are the directions' sensitivities (a strided view), coefficients with identity columns,
    a combined column and a zero column."""
    ys = rng.standard_normal((n, width)) * np.exp(rng.uniform(-20, 20, (n, width)))
    s = ys[:, n2:n2 * (1 + nb)].reshape(n, nb, n2)
    coeffs = np.zeros((nb, 6))
    coeffs[np.arange(4), np.arange(4)] = rng.uniform(0.1, 3.0, 4)
    coeffs[[1, 3, 4], 4] = rng.standard_normal(3)       # a direction made of three
    weights = rng.uniform(0.0, 2.0, (6, n2))
    edges = np.sort(rng.choice(np.arange(1, n), 6, replace=False))
    lo, hi = np.r_[0, edges], np.r_[edges, n]
    return s, coeffs, weights, lo, hi


def test_window_norm_maxima_in_c_is_the_numpy_formula_bit_for_bit():
    rng = np.random.default_rng(7)
    s, coeffs, weights, lo, hi = _case(rng)
    assert not s.flags.c_contiguous
    cols = _sparse_columns(coeffs)
    got = window_norm_maxima(s, *cols, weights, lo, hi)
    want = numpy_window_norm_maxima(s, *cols, weights, lo, hi)
    assert got.shape == (len(lo), coeffs.shape[1]) and np.all(got[:, :5] > 0)
    assert np.array_equal(got, want)
    assert np.all(got[:, 5] == 0.0)                      # the zero column


def test_window_norm_maxima_nan_rows_and_empty_windows():
    """A window with a NaN row gives 0 (Python's max(0.0, nan)), as does an empty one."""
    rng = np.random.default_rng(3)
    s, coeffs, weights, lo, hi = _case(rng)
    s = np.array(s)
    s[lo[2] + 1, 0, 1] = np.nan
    lo, hi = np.r_[lo, 5], np.r_[hi, 5]                  # an empty window last
    cols = _sparse_columns(coeffs)
    got = window_norm_maxima(s, *cols, weights, lo, hi)
    assert np.array_equal(got, numpy_window_norm_maxima(s, *cols, weights, lo, hi))
    assert got[2, 0] == 0.0 and got[1, 0] > 0.0 and np.all(got[-1] == 0.0)


def test_window_norm_maxima_refuses_windows_past_the_rows():
    rng = np.random.default_rng(1)
    s, coeffs, weights, lo, hi = _case(rng, n=50)
    with pytest.raises(ValueError, match="do not fit"):
        window_norm_maxima(s, *_sparse_columns(coeffs), weights, lo, hi + 1)
