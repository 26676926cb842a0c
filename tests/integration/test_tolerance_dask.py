"""The tolerance study on a dask LocalCluster gives the same indices as the local thread
pool for the same seed (every run is deterministic and the samples are drawn in the caller)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("SALib")


def test_same_seed_same_indices_locally_and_on_a_dask_local_cluster():
    distributed = pytest.importorskip("dask.distributed")
    from mbs_clearance.studies.tolerance import FitClearance, band, tolerance_study

    inputs = {"crank_length": band(0.05, 2e-4),
              "radial_clearance": FitClearance("H7/g6", 0.020)}
    kw = dict(sobol=4, second_order=False, monte_carlo=4, allowable=8000.0, revolution=2,
              seed=17, progress=False)
    local = tolerance_study(inputs, **kw)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        remote = tolerance_study(inputs, executor=client, **kw)
    assert remote.settings["executor"].startswith("dask.distributed.Client(")
    assert local.counts == remote.counts and local.counts["runs"] == 4 * 4 + 4
    for key in ("S1", "S1_conf", "ST", "ST_conf"):
        np.testing.assert_array_equal(remote.sobol[key], local.sobol[key])
    np.testing.assert_array_equal(remote.monte_carlo["values"], local.monte_carlo["values"])
    assert remote.monte_carlo["p_exceed_ci"] == local.monte_carlo["p_exceed_ci"]
