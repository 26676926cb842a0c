"""Shared by the benchmark scripts: the machine description and median timing."""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable
from typing import Any

import numpy as np


def machine_summary() -> str:
    """A one-line description of the machine a benchmark ran on."""
    cpu = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as fh:
            kb = int(fh.readline().split()[1])
            mem = f", {kb / 2**20:.0f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    return (f"{cpu}, {os.cpu_count()} cores{mem}, {platform.system()} "
            f"{platform.machine()}, Python {platform.python_version()}")


def timed(fn: Callable[[], Any], repeats: int, warmup: bool = False) -> tuple[float, Any]:
    """Median wall time in s of `repeats` calls of fn (after one untimed call if `warmup`),
    and the result of the last call."""
    result = fn() if warmup else None
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), result


def ns_per_call(loop: Callable[[int], Any], n_calls: int, repeats: int = 5) -> float:
    """ns per call of a compiled loop: `loop(reps)` makes reps x `n_calls` calls. One pass
    first (compile, warm), then the median of `repeats` timings of about 2 million calls."""
    loop(1)
    reps = max(1, int(2e6 // n_calls))
    return 1e9 * timed(lambda: loop(reps), repeats)[0] / (reps * n_calls)


def paired(fn_a: Callable[[], Any], fn_b: Callable[[], Any], pairs: int) -> dict[str, float]:
    """Time a and b in alternating pairs (a, b, a, b, ...) in this process; returns the
    median of the per-pair ratios t_b / t_a ("ratio") and the two medians ("a", "b").

    The ratio of each pair is taken under the same machine load, so a noisy machine moves
    its spread, not its median; two separate medians are not compared that way."""
    ta, tb = [], []
    for _ in range(pairs):
        t0 = time.perf_counter()
        fn_a()
        t1 = time.perf_counter()
        fn_b()
        t2 = time.perf_counter()
        ta.append(t1 - t0)
        tb.append(t2 - t1)
    ta_, tb_ = np.asarray(ta), np.asarray(tb)
    return {"ratio": float(np.median(tb_ / ta_)), "a": float(np.median(ta_)),
            "b": float(np.median(tb_))}
