"""The design evaluator shared by the GA, the sweeps and the tolerance study.

Designs are evaluated as batches on an executor: a local pool of `workers` threads (the
compiled reduced model releases the GIL, so threads run in parallel with no pickling and no
start method), a local process pool (`local_process_pool`; the Exudyn backend is not
thread-safe), any `concurrent.futures`-style executor, or a `dask.distributed.Client`
(`connect_dask`) for scale-out. `_Dispatcher` gives them one `map`; `evaluate` runs any
picklable function over a list of items on any of them with a progress bar, shutting a pool
it created down on Ctrl-C or SIGTERM within about one design's simulation time. Every
evaluation is deterministic, so results do not depend on the executor.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import numbers
import os
import signal
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from ..model.mechanism import SliderCrank
from ..solve.simulate import peak_base_force

__all__ = ["LOCAL_EXECUTORS", "DASK_CONNECT_TIMEOUT", "DASK_WORKER_TIMEOUT", "connect_dask",
           "local_process_pool", "evaluate"]

#: the executors the call can create itself: "serial" (this process), "threads" (a pool of
#: `workers` threads; the default for the compiled backends), "processes" (a pool of
#: `workers` processes; the default for backend="exudyn", whose engine is not thread-safe)
LOCAL_EXECUTORS = ("serial", "threads", "processes")

#: backends evaluated in threads by default (their kernels release the GIL or are numpy)
_THREAD_SAFE_BACKENDS = ("reduced", "ideal")


#: seconds to wait for a dask scheduler to answer, and for its first worker to join
DASK_CONNECT_TIMEOUT = 10.0
DASK_WORKER_TIMEOUT = 60.0


def _peak_chunk(mechs: list[SliderCrank], revolution: int, backend: str,
                options: dict, stop: threading.Event | None = None) -> list[float]:
    """Worker: peak |F12| of each mechanism (inf where the integration fails).

    `stop` (thread pools only) is checked between designs: once set, the chunk returns
    at once (its result is then discarded).
    """
    out = []
    options = dict(options)
    # a Linkage study's output (objective.peak_output); none: the monitored force
    output = options.pop("output", None)
    for mech in mechs:
        if stop is not None and stop.is_set():
            break
        try:
            if output is not None:
                from ..analysis.objective import peak_output

                out.append(float(peak_output(mech, output, revolution, **options)))
                continue
            out.append(float(peak_base_force(mech, revolution, backend, **options)))
        except RuntimeError:
            out.append(math.inf)
    return out


def peak_or_inf(mech: SliderCrank, revolution: int, backend: str, options: dict) -> float:
    """Worker of the GA's `evaluate` calls: peak |F12| of one design (inf where the
    integration fails)."""
    return _peak_chunk([mech], revolution, backend, options)[0]


def _peak_chunk_packed(args: tuple) -> list[float]:
    """`_peak_chunk` with its arguments in one tuple (for map-only executors)."""
    return _peak_chunk(*args)


def _init_worker() -> None:
    """Process-pool initializer: one thread per worker process, SIGINT left to the parent.

    The compiled core is serial; these variables keep any OpenMP/BLAS library loaded later
    from starting one thread per core in each of the worker processes. Ctrl-C at a terminal
    reaches the whole process group: the workers ignore it and the parent, which gets it
    too, terminates them (a KeyboardInterrupt inside a worker would break the pool while it
    shuts down).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(name, "1")


# ----------------------------------------------------------------------------- executors

class _Dispatcher:
    """Uniform `map` over a thread or process pool, a concurrent.futures executor or a dask
    Client. `stop` (set on an interrupt) makes thread-pool chunks return between designs."""

    def __init__(self, executor, n_workers: int | None):
        self.executor = executor
        self.is_dask = _is_dask_client(executor)
        self.stop = threading.Event() if isinstance(executor, ThreadPoolExecutor) else None
        if n_workers is None and executor is not None:
            if self.is_dask:
                n_workers = max(1, sum(executor.nthreads().values()))
            else:
                n_workers = getattr(executor, "_max_workers", None)
        self.n_workers = n_workers

    def map(self, mechs: list[SliderCrank], problem) -> list[float]:
        args = (problem.revolution, problem.backend, problem.options)
        if self.executor is None or len(mechs) <= 1:
            return _peak_chunk(mechs, *args)
        n_chunks = len(mechs) if self.n_workers is None else min(len(mechs), self.n_workers)
        bounds = np.linspace(0, len(mechs), n_chunks + 1).round().astype(int)
        chunks = [mechs[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
        if self.is_dask:
            futures = [self.executor.submit(_peak_chunk, c, *args, pure=False) for c in chunks]
            results = self.executor.gather(futures)
        elif hasattr(self.executor, "submit"):
            extra = () if self.stop is None else (self.stop,)
            futures = [self.executor.submit(_peak_chunk, c, *args, *extra) for c in chunks]
            try:
                results = [f.result() for f in futures]
            except BaseException:
                for f in futures:
                    f.cancel()
                if self.stop is not None:
                    self.stop.set()
                raise
        else:  # map-only executors, e.g. multiprocessing.Pool: one iterable of tuples
            results = list(self.executor.map(_peak_chunk_packed, [(c, *args) for c in chunks]))
        return [p for chunk in results for p in chunk]


    def map_tasks(self, fn: Callable, items: Sequence, args: tuple = (),
                  chunk_size: int | None = None, on_chunk: Callable | None = None,
                  on_result: Callable | None = None, retries: int = 0) -> list:
        """``[fn(item, *args) for item in items]`` on the executor, in order.

        Items go out in chunks of `chunk_size` (default: one chunk per worker); `on_chunk`
        is called with the number of items of each chunk as it completes, e.g. a progress
        bar's ``update``; `on_result(start, results)` with each chunk's results as it
        completes (in completion order: the chunk holds items[start:start + len(results)]),
        e.g. to write them at once. A dask chunk that raised is retried `retries` times (a
        lost worker's chunks are rescheduled by the dask scheduler itself). `fn` must be
        picklable for process pools and dask (a module-level function) and handle its own
        failures.
        """
        items = list(items)
        if self.executor is None or len(items) <= 1:
            out = []
            for i, item in enumerate(items):
                out.append(fn(item, *args))
                if on_chunk is not None:
                    on_chunk(1)
                if on_result is not None:
                    on_result(i, out[-1:])
            return out
        if chunk_size is None:
            n_chunks = len(items) if self.n_workers is None \
                else min(len(items), self.n_workers)
        else:
            n_chunks = max(1, math.ceil(len(items) / chunk_size))
        bounds = np.linspace(0, len(items), n_chunks + 1).round().astype(int)
        chunks = [items[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
        results: list = [None] * len(chunks)

        def done(i, r):
            results[i] = r
            if on_chunk is not None:
                on_chunk(len(chunks[i]))
            if on_result is not None:
                on_result(int(bounds[i]), r)

        if self.is_dask:
            from dask.distributed import as_completed as dask_completed

            futures = [self.executor.submit(_task_chunk, fn, c, args, pure=False,
                                            retries=retries) for c in chunks]
            index = {f.key: i for i, f in enumerate(futures)}
            try:
                if on_result is None:
                    for i, f in enumerate(futures):
                        done(i, f.result())
                else:
                    for f in dask_completed(futures):
                        done(index[f.key], f.result())
            except BaseException:
                self.executor.cancel(futures)
                raise
        elif hasattr(self.executor, "submit"):
            extra = () if self.stop is None else (self.stop,)
            futures = [self.executor.submit(_task_chunk, fn, c, args, *extra) for c in chunks]
            index = {f: i for i, f in enumerate(futures)}
            try:
                if on_result is None:
                    for i, f in enumerate(futures):
                        done(i, f.result())
                else:
                    for f in as_completed(futures):
                        done(index[f], f.result())
            except BaseException:
                for f in futures:
                    f.cancel()
                if self.stop is not None:
                    self.stop.set()
                raise
        else:  # map-only executors, e.g. multiprocessing.Pool: one iterable of tuples
            for i, r in enumerate(self.executor.map(_task_chunk_packed,
                                                    [(fn, c, args) for c in chunks])):
                done(i, r)
        return [r for chunk in results for r in chunk]


def _task_chunk(fn: Callable, items: list, args: tuple,
                stop: threading.Event | None = None) -> list:
    """Worker: `fn(item, *args)` for each item; `stop` (thread pools only) is checked
    between items, and once set the chunk returns at once (its result is discarded)."""
    out = []
    for item in items:
        if stop is not None and stop.is_set():
            break
        out.append(fn(item, *args))
    return out


def _task_chunk_packed(packed: tuple) -> list:
    """`_task_chunk` with its arguments in one tuple (for map-only executors)."""
    return _task_chunk(*packed)


def _mechanism_of(item):
    """The mechanism of an evaluated item: the item itself or a tuple's (index, design)."""
    from ..model.cases import door

    def mechanism(x) -> bool:
        try:
            door(x)
        except (ValueError, TypeError):
            return False
        return True

    if isinstance(item, tuple):
        item = next((x for x in item if mechanism(x)), None)
    return item if item is not None and mechanism(item) else None


def ship_compiled(client, mech=None) -> int:
    """Hand a dask Client's workers the compiled core and models this process has built
    (`core.build.used_files`), after building `mech`'s models here if needed (its plain
    model, specialised and general), so that no worker compiles (a worker plugin installs
    them into each worker's cache, also on workers that join later). Returns the number of
    files handed over."""
    from ..core import build
    from ..model.cases import as_linkage
    from ..solve.kernels import c_model

    if mech is not None:
        try:
            linkage = as_linkage(mech)
        except (TypeError, ValueError):
            linkage = None
        if linkage is not None:
            c_model(linkage)
            c_model(linkage, specialise=False)
    files = build.used_files()
    if files:
        from ._dask_plugin import CompiledFiles

        client.register_plugin(CompiledFiles(files), name=CompiledFiles.name)
    return len(files)


def _is_dask_client(executor) -> bool:
    return (type(executor).__module__.startswith("distributed")
            and hasattr(executor, "gather") and hasattr(executor, "nthreads"))


def _describe_executor(executor, workers) -> str:
    if executor is None:
        return "serial (this process)"
    if _is_dask_client(executor):
        return f"dask.distributed.Client({executor.scheduler.address}, {workers} threads)"
    return f"{type(executor).__name__}({workers} workers)"


def local_process_pool(workers: int = 2) -> ProcessPoolExecutor:
    """A process pool suited to the GA: forkserver (spawn where unavailable), one thread
    each, SIGINT ignored in the workers (the parent stops them, see `_stop_pool`).

    Forkserver/spawn rather than fork because the parent may run threads (progress bar,
    dask client) that fork would copy mid-operation. Both re-import the main script in each
    worker: a script that calls the GA at its top level needs a main guard (the call then
    fails with that advice in one line); thread pools have no such requirement.
    """
    method = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() \
        else "spawn"
    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context(method),
                               initializer=_init_worker)


def _stop_pool(pool, dispatcher: _Dispatcher, interrupted: bool) -> None:
    """Shut a pool the call created down; after an interrupt, without waiting for queued
    designs: threads stop between designs, processes are terminated and reaped."""
    if not interrupted:
        pool.shutdown(wait=True)
        return
    if dispatcher.stop is not None:
        dispatcher.stop.set()
    if isinstance(pool, ProcessPoolExecutor):
        processes = list((getattr(pool, "_processes", None) or {}).values())
        for proc in processes:
            with contextlib.suppress(Exception):
                proc.terminate()
        pool.shutdown(wait=False, cancel_futures=True)
        for proc in processes:
            with contextlib.suppress(Exception):
                proc.join(5.0)
                if proc.is_alive():
                    proc.kill()
                    proc.join(1.0)
    else:
        pool.shutdown(wait=True, cancel_futures=True)


class _Terminated(SystemExit):
    """Raised in the main thread by SIGTERM during a run, so that the pool is cleaned up."""


@contextlib.contextmanager
def _sigterm_raises():
    """For the duration of a run in the main thread, turn SIGTERM (whose default action
    would kill this process at once and orphan pool workers) into `_Terminated` (exit code
    143); a handler installed by the caller is left alone."""
    if threading.current_thread() is not threading.main_thread() \
            or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        yield
        return

    def handler(signum, frame):
        raise _Terminated(128 + signum)

    signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def connect_dask(address: str, timeout: float = DASK_CONNECT_TIMEOUT):
    """A `dask.distributed.Client` connected to the scheduler at `address`, or TimeoutError
    with one line (how long it waited, what to check) after `timeout` seconds."""
    from dask.distributed import Client

    timeout = _check_timeout("timeout", timeout)
    try:
        _probe_scheduler(address, timeout)
        return Client(address, timeout=timeout)
    except (MemoryError, ValueError, TypeError, EOFError) as exc:
        # something answered that is not a dask scheduler (a web server or proxy): dask
        # reads its first bytes as a message length (e.g. "HTTP/1.1" as exbibytes)
        raise ConnectionError(
            f"could not connect to the dask scheduler at {address!r}: the server there does "
            f"not speak dask's protocol ({type(exc).__name__} while reading its answer); "
            "check the address and port of the scheduler (dask scheduler prints them)"
        ) from None
    except (OSError, TimeoutError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise TimeoutError(
            f"could not connect to the dask scheduler at {address!r} within {timeout:g} s "
            f"({reason}); check that the scheduler runs (dask scheduler) and that the "
            "address and port are reachable from here") from None


def _probe_scheduler(address: str, timeout: float) -> None:
    """Ask the scheduler at `address` who it is, all within `timeout` seconds (raises
    TimeoutError, OSError, or what a server that is not a scheduler makes dask raise).
    dask's Client waits without a bound on a server that accepts the connection and then
    stays silent; this bounds that wait (in a thread of its own, so that a caller's running
    event loop is not disturbed)."""
    import asyncio

    from distributed.comm import connect

    async def probe():
        comm = await connect(address, timeout=timeout)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    outcome: dict = {}

    def target():
        try:
            outcome["reply"] = asyncio.run(asyncio.wait_for(probe(), timeout))
        except BaseException as exc:  # noqa: BLE001 - handed to the caller's thread
            outcome["error"] = exc

    thread = threading.Thread(target=target, name="mbs-dask-probe", daemon=True)
    thread.start()
    thread.join(timeout + 5.0)
    if thread.is_alive():
        raise TimeoutError(f"no answer within {timeout:g} s")
    if "error" in outcome:
        raise outcome["error"]
    if not isinstance(outcome.get("reply"), dict):
        raise ValueError("its answer is not a scheduler's identity")


def _wait_for_dask_workers(client, timeout: float) -> None:
    """Wait up to `timeout` seconds for the first worker of a dask cluster (submitted tasks
    would otherwise wait forever); TimeoutError with one line."""
    try:
        client.wait_for_workers(1, timeout=timeout)
    except (OSError, TimeoutError) as exc:
        address = getattr(client.scheduler, "address", "?")
        raise TimeoutError(
            f"no dask worker joined the scheduler at {address} within {timeout:g} s; start "
            f"workers (dask worker {address}) or check that they can reach the scheduler "
            "and import mbs_clearance") from exc


def _check_timeout(name: str, value) -> float:
    if not isinstance(value, numbers.Real) or isinstance(value, bool) \
            or not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a finite number of seconds > 0; got {value!r}")
    return float(value)




def evaluate(fn: Callable, items: Sequence, args: tuple = (), *, executor=None,
             workers: int = 2, thread_safe: bool = True, progress: bool = False,
             desc: str = "designs", chunk_size: int | None = None,
             dask_timeout: float = DASK_WORKER_TIMEOUT, on_result: Callable | None = None,
             retries: int = 2) -> list:
    """``[fn(item, *args) for item in items]`` on an executor, with a progress bar.

    Parameters
    ----------
    fn : callable
        A module-level function (picklable), deterministic, that handles its own failures.
    items : sequence
        What to evaluate (picklable), e.g. mechanisms.
    executor : optional
        None (a local pool of `workers`: threads when `thread_safe`, else processes),
        "serial", "threads", "processes", any `concurrent.futures`-style executor, or a
        `dask.distributed.Client`. A pool created here is shut down at the end, and at
        once on Ctrl-C or SIGTERM.
    workers : int
        Size of a local pool (>= 1; 1 evaluates in this process).
    progress : bool
        Show a tqdm bar of the items done.
    chunk_size : int, optional
        Items per task (default: about 8 tasks per worker, so that the bar moves).
    dask_timeout : float
        Seconds to wait for the first worker of a dask Client (> 0).
    on_result : callable, optional
        Called as ``on_result(start, results)`` with each chunk's results as the chunk
        completes (completion order; items[start:start + len(results)]), in this process:
        results stream back and can be written as they arrive.
    retries : int
        Times a dask chunk that raised is resubmitted (>= 0); the chunks of a worker that
        is lost are rescheduled by the dask scheduler itself.
    """
    from tqdm.auto import tqdm

    if isinstance(executor, str) and executor not in LOCAL_EXECUTORS:
        raise ValueError(f"executor must be None, one of {list(LOCAL_EXECUTORS)}, a "
                         f"concurrent.futures executor or a dask.distributed.Client; "
                         f"got {executor!r}")
    if executor is None or executor in ("threads", "processes"):
        if not isinstance(workers, numbers.Integral) or isinstance(workers, bool) \
                or workers < 1:
            raise ValueError(f"workers must be an integer >= 1; got {workers!r}")
    if chunk_size is not None and (not isinstance(chunk_size, numbers.Integral)
                                   or isinstance(chunk_size, bool) or chunk_size < 1):
        raise ValueError(f"chunk_size must be None or an integer >= 1; got {chunk_size!r}")
    dask_timeout = _check_timeout("dask_timeout", dask_timeout)
    if not isinstance(retries, numbers.Integral) or isinstance(retries, bool) or retries < 0:
        raise ValueError(f"retries must be an integer >= 0; got {retries!r}")
    items = list(items)
    if executor is None:
        executor = "threads" if thread_safe else "processes"
    own_pool = None
    if executor == "threads" and workers > 1:
        own_pool = ThreadPoolExecutor(workers, thread_name_prefix="mbs-eval")
    elif executor == "processes" and workers > 1:
        own_pool = local_process_pool(workers)
    pool = own_pool if isinstance(executor, str) else executor
    dispatcher = _Dispatcher(pool, workers if own_pool is not None else None)
    if chunk_size is None and dispatcher.n_workers is not None:
        chunk_size = max(1, math.ceil(len(items) / (8 * dispatcher.n_workers)))
    interrupted = True
    with _sigterm_raises():
        try:
            if dispatcher.is_dask:
                _wait_for_dask_workers(pool, dask_timeout)
                if items:
                    ship_compiled(pool, _mechanism_of(items[0]))
            with tqdm(total=len(items), desc=desc, unit="run", disable=not progress,
                      leave=True) as bar:
                out = dispatcher.map_tasks(fn, items, args, chunk_size, bar.update, on_result,
                                            int(retries))
            interrupted = False
        except BrokenProcessPool as exc:
            if own_pool is None:    # the caller's pool: the caller says what to do
                raise
            raise RuntimeError(f"the worker processes stopped ({exc}); a script that starts "
                               "a process pool at its top level needs the call under "
                               "`if __name__ == '__main__':`, or pass executor='threads'"
                               ) from None
        finally:
            if own_pool is not None:
                _stop_pool(own_pool, dispatcher, interrupted)
    return out


def describe(executor, workers: int | None = None) -> str:
    """One line naming an executor (for settings records)."""
    return _describe_executor(executor, workers)
