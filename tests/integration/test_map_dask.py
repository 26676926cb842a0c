"""The regime map on a dask LocalCluster gives the same dataset as on the local thread pool
(every point is a deterministic run), and the GA evaluates its designs through the same
evaluator (`executor.evaluate`) with the same result on every executor."""

from __future__ import annotations

import numpy as np
import pytest

from mbs_clearance import SliderCrank, regime_map

SWEEP = ["clearance=1e-5:5e-4:log:3", "crank_speed=4000rpm:5000rpm:2"]
SMALL = dict(revolutions=10, keep=5, max_period=2)


def test_map_local_pool_and_dask_local_cluster_identical(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    local = regime_map(SliderCrank(), SWEEP, workers=2, chunk_size=1,
                       out=tmp_path / "local.nc", **SMALL)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        remote = regime_map(SliderCrank(), SWEEP, scheduler=client, chunk_size=2,
                            out=tmp_path / "dask.nc", **SMALL)
    assert remote.computed == local.computed == 6
    for name in local.dataset.data_vars:
        np.testing.assert_array_equal(remote.dataset[name].values,
                                      local.dataset[name].values, err_msg=name)
    # the paper's design period-1, the 0.5 mm joint not periodic, at 5000 rpm
    assert remote.dataset["regime"].values[0, 1] == 2
    assert remote.dataset["regime"].values[2, 1] == 6


def test_ga_evaluates_through_the_shared_evaluator(monkeypatch):
    from mbs_clearance.studies import executor, optimize

    calls = []
    real = executor.evaluate

    def spy(fn, items, *args, **kw):
        calls.append((fn.__name__, len(items)))
        return real(fn, items, *args, **kw)

    monkeypatch.setattr(optimize, "evaluate", spy)
    kw = dict(population=6, generations=3, progress=False, seed=5, refine=False)
    serial = optimize.optimize_link_lengths(SliderCrank(), executor="serial", **kw)
    assert calls and all(name == "peak_or_inf" for name, _ in calls)
    assert sum(n for _, n in calls) == serial.n_evaluations - 1   # all but the original
    calls.clear()
    threads = optimize.optimize_link_lengths(SliderCrank(), executor="threads", workers=2,
                                             **kw)
    assert calls
    assert threads.best == serial.best and threads.best_peak_force == serial.best_peak_force
    np.testing.assert_array_equal(threads.history, serial.history)


def _exit_worker():
    import os

    os._exit(1)


@pytest.mark.slow
def test_a_lost_worker_chunk_is_rescheduled_and_the_map_is_unchanged(tmp_path):
    # a worker process dies while the map runs (its nanny starts a new one): the chunks it
    # held are rescheduled and the dataset equals the serial one
    import contextlib
    import threading
    import time

    distributed = pytest.importorskip("dask.distributed")
    from mbs_clearance.studies.sweep import load_map as _load

    sweep = "clearance=1e-5:5e-4:log:8"
    kw = dict(revolutions=30, keep=5, max_period=2)
    serial = regime_map(SliderCrank(), sweep, scheduler="serial", **kw).dataset
    path = tmp_path / "lost.nc"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as client:
        result = {}
        run = threading.Thread(target=lambda: result.update(res=regime_map(
            SliderCrank(), sweep, scheduler=client, chunk_size=1, out=path,
            write_interval=0.0, **kw)))
        run.start()
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and run.is_alive():
            time.sleep(0.1)
            if path.exists():
                try:
                    if int(_load(path)["done"].sum()) >= 1:
                        break
                except (OSError, ValueError):
                    continue
        victim = sorted(client.scheduler_info()["workers"])[0]
        with contextlib.suppress(Exception):      # the worker dies before it answers
            client.run(_exit_worker, workers=[victim])
        run.join(600)
    assert "res" in result and result["res"].computed == 8
    for name in serial.data_vars:
        np.testing.assert_array_equal(result["res"].dataset[name].values,
                                      serial[name].values, err_msg=name)


def _worker_state():
    from mbs_clearance.core import build

    return {"compiled": build.compile_count(), "loaded": len(build._LOADED)}


def test_workers_with_empty_caches_compile_nothing(tmp_path):
    """Workers whose caches start empty (a fresh machine) run a regime map on the compiled
    core without compiling: the client hands them its libraries (counted on each worker),
    and the map is the local pool's."""
    distributed = pytest.importorskip("dask.distributed")
    cache = tmp_path / "worker-cache"
    env = {"MBS_CLEARANCE_CACHE_DIR": str(cache), "XDG_CACHE_HOME": str(tmp_path / "xdg")}
    local = regime_map(SliderCrank(), SWEEP, workers=1, out=tmp_path / "local.nc", **SMALL)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0", env=env) as cluster, \
            distributed.Client(cluster) as client:
        assert not cache.exists() or not any(cache.iterdir())
        remote = regime_map(SliderCrank(), SWEEP, scheduler=client, chunk_size=1,
                            out=tmp_path / "dask.nc", **SMALL)
        states = client.run(_worker_state)
    assert remote.computed == 6
    assert len(states) == 2
    for state in states.values():
        assert state == {"compiled": 0, "loaded": state["loaded"]}
        assert state["loaded"] >= 1          # it ran on the compiled core
    assert any(p.suffix == ".so" for p in cache.iterdir())
    np.testing.assert_array_equal(remote.dataset["regime"].values,
                                  local.dataset["regime"].values)
