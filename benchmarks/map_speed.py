"""Speed of regime maps: points per second per core for 100-revolution runs of the
paper's case, the time of a 60 x 40 map (clearance 1 um - 1 mm, log x 500 - 10000 rpm)
extrapolated from a measured subset, and the efficiency of a dask LocalCluster with 1 and
2 workers with an estimate for 64 workers from the measured per-task cost and overhead.

Measured in one run:
- per point: `sweep._map_point` (the windowed section run) on a subset of the grid spread
  over both axes (every --stride-th clearance and speed), serially; and, interleaved with
  it on the same designs, one continuous peak-only run of the same revolutions
  (`peak_base_force`): the ratio is the cost of the section windows;
- the subset as a map on the local pool (threads) and on LocalClusters of 1 and 2 worker
  processes: efficiency = serial time / (workers x map time);
- dask's overhead per task: the round trip of no-op tasks on the 2-worker cluster.
The 64-worker estimate: T(W) = work / W + tasks x (scheduler overhead per task), work =
the grid's serial time, tasks = the grid's chunks (8 per worker, `executor.evaluate`).

    python -m benchmarks.map_speed [--stride 10] [--repeats 3] [--revolutions 100]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mbs_clearance import SliderCrank, peak_base_force, regime_map
from mbs_clearance.studies.sweep import _map_point, design_at, parse_sweep
from validation.timing import machine_summary

CLEARANCE = "clearance=1e-6:1e-3:log:60"
SPEED = "crank_speed=500rpm:10000rpm:40"


def _noop(x):
    return x


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stride", type=int, default=10,
                    help="every stride-th point of each axis is measured (default 10)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--revolutions", type=int, default=100)
    ap.add_argument("--keep", type=int, default=50)
    ap.add_argument("--no-dask", action="store_true")
    args = ap.parse_args(argv)
    print(machine_summary())
    cl, sp = parse_sweep(CLEARANCE), parse_sweep(SPEED)
    c_sub = cl.values[args.stride // 2::args.stride]
    s_sub = sp.values[args.stride // 2::args.stride]
    paper = SliderCrank()
    designs = [design_at(paper, {"clearance": c, "crank_speed": s})
               for c in c_sub for s in s_sub]
    settings = dict(revolutions=args.revolutions, keep=args.keep, angle=None, tol=1e-3,
                    max_period=8, lyapunov=False, rtol=None, early_stop=False)
    _map_point((0, paper), {**settings, "revolutions": 20, "keep": 17})   # compile
    peak_base_force(paper, 2)
    t_map, t_peak = [], []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        for i, m in enumerate(designs):
            _map_point((i, m), settings)
        t_map.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for m in designs:
            try:
                peak_base_force(m, args.revolutions)
            except RuntimeError:
                pass
        t_peak.append(time.perf_counter() - t0)
    per_point = float(np.median(t_map)) / len(designs)
    ratio = float(np.median(t_map)) / float(np.median(t_peak))
    n_grid = len(cl.values) * len(sp.values)
    print(f"\n{len(designs)} points ({len(c_sub)} clearances x {len(s_sub)} speeds), "
          f"{args.revolutions} revolutions, keep {args.keep}")
    print(f"| quantity | value |\n|---|---|\n"
          f"| time per point, one core (median of {args.repeats}) | {per_point:.3f} s |\n"
          f"| points per second per core | {1 / per_point:.2f} |\n"
          f"| section run / one continuous peak-only run, same designs | {ratio:.3f} |\n"
          f"| 60 x 40 map extrapolated, 1 core | {n_grid * per_point / 60:.1f} min |\n"
          f"| 60 x 40 map extrapolated, 2 cores (ideal) | {n_grid * per_point / 120:.1f} min |")
    sweep = [("clearance", c_sub), ("crank_speed", s_sub)]
    kw = dict(revolutions=args.revolutions, keep=args.keep)
    regime_map(paper, [("clearance", c_sub[:1])], scheduler="serial",
               **{**kw, "revolutions": 20, "keep": 17})          # imports (xarray) warm
    t0 = time.perf_counter()
    regime_map(paper, sweep, scheduler="serial", **kw)
    t_serial = time.perf_counter() - t0
    t0 = time.perf_counter()
    regime_map(paper, sweep, workers=2, **kw)
    t_threads = time.perf_counter() - t0
    print(f"| subset map, serial | {t_serial:.2f} s |\n| subset map, 2 threads | "
          f"{t_threads:.2f} s (efficiency {t_serial / (2 * t_threads):.2f}) |")
    if args.no_dask:
        return 0
    from dask.distributed import Client, LocalCluster

    for workers in (1, 2):
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            regime_map(paper, [("clearance", c_sub[:1]), ("crank_speed", s_sub[:workers])],
                       scheduler=client, **{**kw, "revolutions": 20, "keep": 17})  # warm
            t0 = time.perf_counter()
            res = regime_map(paper, sweep, scheduler=client, **kw)
            t = time.perf_counter() - t0
            n_tasks = int(np.ceil(res.computed / max(1, np.ceil(res.computed / (8 * workers)))))
            print(f"| subset map, LocalCluster {workers} worker(s) | {t:.2f} s (efficiency "
                  f"{t_serial / (workers * t):.2f}, {n_tasks} tasks) |")
            if workers == 2:
                client.gather(client.map(_noop, range(200), pure=False))     # warm
                futures = client.map(_noop, range(200, 600), pure=False)
                t0 = time.perf_counter()
                client.gather(futures)
                overhead = (time.perf_counter() - t0) / 400
    work = n_grid * per_point
    tasks = 8 * 64
    t64 = work / 64 + tasks * overhead
    print(f"| dask overhead per task (no-op round trip, 2 workers) | {1e3 * overhead:.2f} ms |\n"
          f"| 60 x 40 map on 64 workers, estimated (work / 64 + {tasks} tasks x overhead) | "
          f"{t64:.1f} s (efficiency {work / (64 * t64):.2f}) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
