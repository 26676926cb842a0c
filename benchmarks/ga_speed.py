"""Wall time of a GA run (population x generations) on different executors, in one run.

Paper case, reduced model, GA only (no refinement, no saturation stop, so every run does the
same generations and simulates the same designs). Executors: this process (serial), the
default pool of 2 threads (the compiled model releases the GIL), a local process pool of 2
workers created by the run itself (start-up included) and one started beforehand (warm), and
a dask LocalCluster of 2 single-threaded worker processes (started and warmed beforehand;
cluster start-up reported separately). Times are medians over repeats. Every run must find
the same optimum (same seed); the script checks it.

Then the issue-15 target: the default call `optimize_link_lengths(seed=...)` (20 x 30, 2
threads, saturation 10, gradient refinement), median wall time against 10 s, with the
refinement's objective calls; and the thread capacity of the machine (the same simulations in
one thread and split over two).

    python -m benchmarks.ga_speed [--population 20] [--generations 30] [--repeats 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mbs_clearance import SliderCrank, peak_base_force
from mbs_clearance.studies.optimize import local_process_pool, optimize_link_lengths
from validation.timing import machine_summary, timed


def warm(executor, n=4):
    """Load the compiled model in every worker before timing."""
    futures = [executor.submit(peak_base_force, SliderCrank(), 1) for _ in range(n)]
    for f in futures:
        f.result()


def evaluate(n):
    """n simulations of the paper case (peak only); module-level for the process pool."""
    for _ in range(n):
        peak_base_force(SliderCrank(), 4)
    return n


def parallel_capacity(pool, n=40, repeats=3):
    """Time of n simulations here / time of the same n split over the pool's 2 workers.

    About 2 on two independent cores; about 1 when the two cores share one core's throughput
    (hyper-threads, a CPU quota), in which case no executor can speed the GA up.
    """
    t_serial, _ = timed(lambda: evaluate(n), repeats)
    t_pool, _ = timed(lambda: list(pool.map(evaluate, [n // 2, n - n // 2])), repeats)
    return t_serial / t_pool, t_serial, t_pool


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--population", type=int, default=20)
    ap.add_argument("--generations", type=int, default=30)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-dask", action="store_true", help="skip the dask LocalCluster")
    args = ap.parse_args(argv)
    mech = SliderCrank()
    kw = dict(seed=args.seed, population=args.population, generations=args.generations,
              saturation=None, refine=False, progress=False)
    peak_base_force(mech, 4)  # compile / load the cache in this process
    rows = []

    def run(label, executor, note, setup=None):
        t, res = timed(lambda: optimize_link_lengths(mech, executor=executor, **kw),
                       args.repeats)
        rows.append(dict(label=label, time=t, res=res, note=note, setup=setup))
        print(f"  {label:40s} {t:7.2f} s  best {res.best_peak_force:.4f} N", flush=True)

    run("serial (this process)", "serial", "")
    run("2 threads (default), pool started by the run", None, "includes pool start-up")
    run("2 local processes, pool started by the run", "processes", "includes pool start-up")
    with local_process_pool(2) as pool:
        t0 = time.perf_counter()
        warm(pool)
        setup = time.perf_counter() - t0
        run("2 local processes, warm pool", pool, "pool started beforehand", setup)
        capacity = parallel_capacity(pool)
    if not args.no_dask:
        from dask.distributed import Client, LocalCluster

        t0 = time.perf_counter()
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            warm(client)
            setup = time.perf_counter() - t0
            run("dask LocalCluster, 2 workers x 1 thread", client,
                "cluster started beforehand", setup)

    t_full, full = timed(lambda: optimize_link_lengths(mech, seed=args.seed, progress=False),
                         args.repeats)
    thread_ratio = thread_capacity()
    ref = rows[0]["res"]
    same = all(np.array_equal(r["res"].history, ref.history) and r["res"].best == ref.best
               for r in rows)
    n = ref.n_evaluations - 1
    print()
    print(f"Machine: {machine_summary()}")
    print()
    print(f"GA {args.population} x {args.generations} (population x generations), seed "
          f"{args.seed}, paper case, reduced model; {n} distinct designs simulated per run; "
          f"median of {args.repeats} runs")
    print()
    print("| executor | median wall time (s) | per design (ms) | speed-up vs serial "
          "| start-up beforehand (s) |")
    print("|---|---|---|---|---|")
    for r in rows:
        setup = "-" if r["setup"] is None else f"{r['setup']:.2f}"
        label = r["label"] + (f" ({r['note']})" if r["note"] else "")
        print(f"| {label} | {r['time']:.2f} | {1e3 * r['time'] / n:.1f} | "
              f"{rows[0]['time'] / r['time']:.2f} | {setup} |")
    print()
    print(f"parallel capacity of the machine: 40 simulations take {capacity[1]:.3f} s in one "
          f"process and {capacity[2]:.3f} s split over 2 worker processes, ratio "
          f"{capacity[0]:.2f} (2 = two independent cores)")
    print(f"same result on every executor: {'yes' if same else 'NO'} "
          f"(best max|F12| {ref.best_peak_force:.4f} N at L2 = "
          f"{ref.best.crank_length * 100:.4f} cm, L3 = {ref.best.coupler_length * 100:.4f} cm)")
    print(f"thread capacity: {thread_ratio[0]:.2f} (time of 40 simulations in one thread / "
          f"split over 2 threads; 2 = the GIL is released and two cores are free)")
    print()
    print(f"default call, 20 x 30 GA with gradient refinement (2 threads, saturation 10): "
          f"median {t_full:.2f} s (target < 10 s on 2 cores); {full.generations_completed} "
          f"generations ({full.stop_reason}), {full.n_evaluations} designs, refinement "
          f"{full.refinement.get('method')} with {full.refinement.get('objective_calls')} "
          f"objective calls, KKT {full.refinement.get('kkt')}, best "
          f"{full.best_peak_force:.4f} N")
    return 0 if same else 1


def thread_capacity(n=40, repeats=3):
    """Time of n simulations in this thread / time of the same n split over 2 threads."""
    from concurrent.futures import ThreadPoolExecutor

    t_one, _ = timed(lambda: evaluate(n), repeats)
    with ThreadPoolExecutor(2) as pool:
        t_two, _ = timed(lambda: list(pool.map(evaluate, [n // 2, n - n // 2])), repeats)
    return t_one / t_two, t_one, t_two


if __name__ == "__main__":
    raise SystemExit(main())
