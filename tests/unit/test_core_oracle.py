"""The C core against numba's integrator, the reference it replaces: the same plain run of a
generated model through both gives the same steps, events and peaks (the same floating-point
operations in the same order: equal to round-off, asserted to 1e-12 relative)."""

from __future__ import annotations

import numpy as np
import pytest

from mbs_clearance.generate.c_loader import CModel
from mbs_clearance.model import cases
from mbs_clearance.solve import kernels
from mbs_clearance.solve import linkage_model as lm


def _both(monkeypatch, linkage, revolutions=None, **options):
    runs = {}
    for core in ("numba", "c"):
        monkeypatch.setenv(kernels.ENV, core)
        runs[core] = lm.run(linkage, revolutions, **options)
    assert isinstance(runs["c"].model, CModel)
    assert not isinstance(runs["numba"].model, CModel)
    return runs["numba"], runs["c"]


def _same(a, b, rel=1e-12):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    scale = np.maximum(np.abs(a), np.abs(b)).max(initial=0.0)
    assert np.max(np.abs(a - b), initial=0.0) <= rel * max(scale, 1e-300)


def _check(ref, new):
    for key in ("nfev", "naccept", "nreject", "nevent", "nrefine"):
        assert new.stats[key] == ref.stats[key], key
    _same(ref.peaks, new.peaks)
    _same(ref.peak_times, new.peak_times)
    _same(ref.ts, new.ts)
    _same(ref.ys, new.ys)
    _same(ref.ms, new.ms)
    if ref.outs.size:
        _same(ref.outs, new.outs)


def test_paper_case_recorded_and_peak_only(monkeypatch):
    linkage = cases.paper_slider_crank()
    _check(*_both(monkeypatch, linkage, 2))
    _check(*_both(monkeypatch, linkage, 2, record=False))


# Each numba reference specialises the integrator for its model (a minute of CPU per case on
# two cores); the paper case above keeps the comparison in the fast set.
@pytest.mark.slow
@pytest.mark.parametrize("case, revolutions, options", [
    ("four_bar", 1, {}),
    ("slider_crank_two_clearances", 2, {}),
    ("paper_slider_crank", 2, {"method": "dop853"}),
    ("paper_slider_crank", 2, {"method": "bs3"}),
    ("paper_slider_crank_lubricated", 1, {"method": "rodas4"}),
])
def test_named_cases(monkeypatch, case, revolutions, options):
    _check(*_both(monkeypatch, cases.CASES[case](), revolutions, **options))


@pytest.mark.slow
def test_free_translational_benchmark(monkeypatch):
    linkage = cases.flores_translational_slider_crank()
    _check(*_both(monkeypatch, linkage, duration=0.02, window=0.01))
