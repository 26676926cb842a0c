"""Genetic-algorithm optimisation of design fields (the paper's Section 4, Eq. 18).

`optimize_link_lengths` minimises the peak base reaction force max |F12| over one crank
revolution (the 4th by default) over a box of `SliderCrank` fields (by default the paper's
crank length L2 in [4, 6] cm and coupler length L3 in [10, 14] cm) with pygad's GA, then
polishes the GA's best point with a bounded local search (scipy Nelder-Mead) on the same objective.

Parallelism: each generation's new designs are evaluated as one batch by
`executor.evaluate` (the one evaluator of designs, shared with the tolerance study and the
regime maps) on an executor: by
default a local pool of `workers` threads (the compiled reduced model releases the GIL, so the
threads run in parallel with no pickling and no start method: the call works from a script
without a main guard, a notebook, ``python -`` and ``python -c``), a local process pool for
the Exudyn backend (not thread-safe), any `concurrent.futures`-style executor, or a
`dask.distributed.Client` for scale-out. The executor and the progress bar live in a
module-level registry for the duration of the run, never inside the `pygad.GA` object, which
therefore stays picklable. Each evaluation is a deterministic simulation, so the result for a
given seed does not depend on the executor. Ctrl-C and SIGTERM stop the workers of a pool the
call created within about one design's simulation time and leave no process behind.

The GA works on genes normalised to [0, 1] (u = (x - lo) / (hi - lo)), so that its operators
(tournament selection, simulated binary crossover, polynomial mutation, all bounded) behave
the same whatever the units and widths of the design variables.
"""

from __future__ import annotations

import itertools
import logging
import math
import multiprocessing
import numbers
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._checks import DESIGN_BYTES, check_memory
from .._io import read_json_object, write_json_object
from .._warnings import AccuracyWarning
from ..model.cases import door
from ..model.linkage import Linkage
from ..model.mechanism import CONTINUOUS_FIELDS, SliderCrank
from ..solve.simulate import BACKENDS, peak_base_force, simulate
from .executor import (  # noqa: F401 - the executors live in executor.py (shared)
    _THREAD_SAFE_BACKENDS,
    DASK_CONNECT_TIMEOUT,
    DASK_WORKER_TIMEOUT,
    LOCAL_EXECUTORS,
    _check_timeout,
    _describe_executor,
    _Dispatcher,
    _is_dask_client,
    _peak_chunk,
    _sigterm_raises,
    _stop_pool,
    _wait_for_dask_workers,
    connect_dask,
    evaluate,
    local_process_pool,
    peak_or_inf,
)

__all__ = ["optimize_link_lengths", "OptimizationResult", "MASS_SCALINGS", "PAPER_TABLE3",
           "design_mechanism", "connect_dask", "LOCAL_EXECUTORS", "SATURATION_RTOL",
           "DASK_CONNECT_TIMEOUT", "DASK_WORKER_TIMEOUT"]

#: saturation: the best value counts as unchanged over the last N generations when it moved
#: by at most this fraction of its value
SATURATION_RTOL = 1e-9

#: what to do when worker processes re-import a script without a main guard
_MAIN_GUARD_ADVICE = (
    "worker processes (backend='exudyn' or executor='processes') re-import the main script: "
    "a script that calls optimize_link_lengths at its top level needs the call under "
    "`if __name__ == '__main__':`, or pass executor='serial'")

#: how link masses follow the link lengths: "fixed" (the paper's wording: only the lengths
#: change) or "uniform" (uniform-density links: mass proportional to length)
MASS_SCALINGS = ("fixed", "uniform")

#: the paper's Table 3 and Section 5 (Ebrahimi, Salahshoor & Nouri 2018); lengths in m, N
PAPER_TABLE3: dict[str, Any] = {
    "original": {"crank_length": 0.05, "coupler_length": 0.12, "peak_force": 8311.0},
    "optimum": {"crank_length": 0.040733, "coupler_length": 0.137468, "peak_force": 4667.0},
    "reduction_percent": 43.85,
}

#: fields scaled with the lengths under mass_scaling="uniform" (they cannot also be genes)
_SCALED_FIELDS = ("crank_mass", "coupler_mass", "crank_inertia", "coupler_inertia")

_FORMAT = "mbs_clearance.studies.optimize/1"

#: GA operators and their settings (recorded in `OptimizationResult.settings`)
_GA_OPERATORS: dict[str, Any] = {
    "parent_selection_type": "tournament",
    "K_tournament": 3,
    "crossover_type": "sbx",
    "crossover_probability": 0.9,
    "sbx_crossover_eta": 15,
    "mutation_type": "polynomial",
    "polynomial_mutation_eta": 20,
}


# ----------------------------------------------------------------------------- the problem

def design_mechanism(base: SliderCrank, values: dict[str, float],
                     mass_scaling: str = "fixed") -> SliderCrank:
    """`base` with the design `values` applied (SI units) under the mass assumption.

    With ``mass_scaling="uniform"`` the crank and coupler masses scale with their lengths
    relative to `base` (uniform density, fixed cross-section); explicit inertias scale with
    the cube of the length (m L^2), and inertias left as None follow as uniform rods.
    """
    changes = {k: float(v) for k, v in values.items()}
    if mass_scaling == "uniform":
        s2 = changes.get("crank_length", base.crank_length) / base.crank_length
        s3 = changes.get("coupler_length", base.coupler_length) / base.coupler_length
        changes["crank_mass"] = base.crank_mass * s2
        changes["coupler_mass"] = base.coupler_mass * s3
        if base.crank_inertia is not None:
            changes["crank_inertia"] = base.crank_inertia * s2**3
        if base.coupler_inertia is not None:
            changes["coupler_inertia"] = base.coupler_inertia * s3**3
    elif mass_scaling != "fixed":
        raise ValueError(f"mass_scaling must be one of {list(MASS_SCALINGS)}; "
                         f"got {mass_scaling!r}")
    return base.replace(**changes)


#: the reduced model's tolerance for each design of the GA unless rtol, atol or accuracy is
#: given: one run per design instead of the error-controlled run of `peak_base_force`'s
#: default (within 1e-5 on the paper's GA box, the accuracy map in docs/performance.md);
#: the best design is simulated again at the default accuracy, and its estimate's note
#: kept in ``best_accuracy_note``
GA_RTOL = 1e-7


@dataclass(frozen=True)
class _Problem:
    """Picklable description of the objective: design box, mapping, model settings."""

    base: SliderCrank | Linkage
    names: tuple[str, ...]
    lo: tuple[float, ...]
    hi: tuple[float, ...]
    mass_scaling: str
    revolution: int
    backend: str
    options: dict
    output: str | None = None
    window: float | None = None

    @property
    def eval_options(self) -> dict:
        """Options of a design's evaluation (`executor.peak_or_inf`): the backend's, and a
        Linkage's output (and a free linkage's window)."""
        if isinstance(self.base, Linkage):
            return {**self.options, "output": self.output,
                    **({"window": self.window} if self.window is not None else {})}
        if self.backend == "reduced" and not {"rtol", "atol", "accuracy", "settings"} \
                & set(self.options):
            # the GA's cheaper default: one run at GA_RTOL per design, no error estimate
            return {"rtol": GA_RTOL, **self.options}
        return self.options

    def physical(self, u) -> np.ndarray:
        """Genes in [0, 1] -> field values in SI units."""
        lo, hi = np.asarray(self.lo), np.asarray(self.hi)
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        return lo * (1.0 - u) + hi * u      # exact at both bounds (lo + u (hi - lo) is not)

    def unit(self, x) -> np.ndarray:
        lo, hi = np.asarray(self.lo), np.asarray(self.hi)
        return (np.asarray(x, dtype=float) - lo) / (hi - lo)

    def mechanism(self, u) -> SliderCrank | Linkage:
        values = dict(zip(self.names, self.physical(u)))
        if isinstance(self.base, Linkage):
            from ..model.design import linkage_with

            return linkage_with(self.base, values)
        return design_mechanism(self.base, values, self.mass_scaling)


#: run id -> (dispatcher, progress bar) while a run is active; kept out of the GA object
_ACTIVE: dict[int, tuple[_Dispatcher, Any]] = {}
_RUN_IDS = itertools.count()


class _Objective:
    """Batch fitness for pygad (fitness = -peak) with a cache of every evaluated design.

    Holds only picklable data; the executor is looked up by run id in `_ACTIVE`, and a copy
    unpickled elsewhere (no entry) evaluates in its own process.
    """

    def __init__(self, problem: _Problem, run_id: int):
        self.problem = problem
        self.run_id = run_id
        self.cache: dict[tuple[float, ...], float] = {}

    def peaks(self, U, serial: bool = False) -> np.ndarray:
        """Peak |F12| in N for each row of genes `U` (k, n), evaluating only new designs."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        keys = [tuple(float(v) for v in row) for row in U]
        new = list(dict.fromkeys(k for k in keys if k not in self.cache))
        if new:
            mechs = [self.problem.mechanism(k) for k in new]
            active = _ACTIVE.get(self.run_id)
            executor, chunk = "serial", None
            if active is not None and not serial and active[0].executor is not None:
                # the run's pool or Client, one chunk per worker
                executor = active[0].executor
                if active[0].n_workers:
                    chunk = math.ceil(len(mechs) / active[0].n_workers)
            problem = self.problem
            peaks = evaluate(peak_or_inf, mechs,
                             (problem.revolution, problem.backend, problem.eval_options),
                             executor=executor, chunk_size=chunk, desc="GA designs")
            for k, p in zip(new, peaks):
                self.cache[k] = p
        return np.array([self.cache[k] for k in keys])

    def __call__(self, ga, solutions, indices):
        return [-p for p in self.peaks(solutions)]


class _OnGeneration:
    """pygad callback: advance the progress bar (looked up by run id) with the best so far,
    and stop the run ("stop") once the best value has moved by at most `rtol` of its value
    over the last `saturation` generations."""

    def __init__(self, run_id: int, saturation: int | None, rtol: float):
        self.run_id = run_id
        self.saturation = saturation
        self.rtol = rtol
        self.bests: list[float] = []    # best peak after each generation, N

    def __call__(self, ga):
        best = float(-np.max(ga.last_generation_fitness))
        if not self.bests:   # the initial population's best
            self.bests.append(float(-np.max(ga.best_solutions_fitness[0])))
        self.bests.append(best)
        active = _ACTIVE.get(self.run_id)
        if active is not None and active[1] is not None:
            bar = active[1]
            bar.set_postfix_str(f"best max|F12| = {best:.2f} N", refresh=False)
            bar.update(1)
        if self.saturated():
            return "stop"
        return None

    def saturated(self) -> bool:
        n = self.saturation
        if n is None or len(self.bests) <= n:
            return False
        old, new = self.bests[-1 - n], self.bests[-1]
        return abs(old - new) <= self.rtol * abs(old)


# ----------------------------------------------------------------------------- the result

@dataclass(frozen=True, eq=False)
class OptimizationResult:
    """Outcome of `optimize_link_lengths`; forces in N, mechanisms in SI units.

    Attributes
    ----------
    best : SliderCrank
        Optimal design (GA, then local refinement where that improved it or moved it onto
        a bound within the objective's accuracy, see `refinement`).
    best_peak_force : float
        Its max |F12| over the chosen revolution, N.
    original : SliderCrank
        The design the optimisation started from (`mech`).
    original_peak_force : float
        max |F12| of `original`, N.
    history : (generations_completed + 1,) array
        Best max |F12| in the population, N: initial population, then after each generation.
    genes : dict
        Design field -> (lower, upper) bound in SI units.
    settings : dict
        Everything needed to repeat the run (seed, sizes, operators, model, mass scaling).
    n_evaluations : int
        Distinct designs simulated (GA, refinement and the original).
    ga_best, ga_best_peak_force : SliderCrank, float
        The GA's best design before refinement and its peak force.
    generations_completed : int
        Generations run before a stopping criterion (limit or saturation) held.
    n_failed : int
        Designs whose integration failed (ranked last, peak = inf).
    elapsed : float
        Wall time of the call, s.
    best_periodic : bool or None
        ``simulate(best).stats["periodic"]``: whether the best design's motion settled into a
        periodic regime (None where the model does not judge it).
    best_periodicity_note : str or None
        ``simulate(best).stats["periodicity_note"]``: why periodicity could not be judged or
        was not found (None when the model gives none).
    best_accuracy_note : str or None
        ``simulate(best).stats["accuracy_note"]``: where the best design's run may miss the
        stated accuracy (grazing onsets, slow settling; docs/performance.md), else None.
    stop_reason : str
        "generations" (the limit) or "saturation" (the best value moved by at most
        ``settings["saturation_rtol"]`` of its value over ``settings["saturation"]``
        generations).
    refinement : dict
        The local refinement's record (empty without one): method, objective calls, whether
        it improved the GA's point, whether it moved a start within 1e-6 of the box from a
        bound onto that bound (`projected`: the gradient points out of the box there and
        the two values agree within the objective's accuracy, 1e-5), the bounds it ended on
        and the KKT check there.
    """

    best: SliderCrank
    best_peak_force: float
    original: SliderCrank
    original_peak_force: float
    history: np.ndarray
    genes: dict[str, tuple[float, float]]
    settings: dict[str, Any]
    n_evaluations: int
    ga_best: SliderCrank
    ga_best_peak_force: float
    generations_completed: int
    n_failed: int = 0
    elapsed: float = field(default=0.0)
    best_periodic: bool | None = None
    best_periodicity_note: str | None = None
    best_accuracy_note: str | None = None
    stop_reason: str = "generations"
    refinement: dict[str, Any] = field(default_factory=dict)

    @property
    def reduction_percent(self) -> float:
        """Reduction of the peak force from the original design, %."""
        return 100.0 * (self.original_peak_force - self.best_peak_force) \
            / self.original_peak_force

    @property
    def best_genes(self) -> dict[str, float]:
        """Design field -> optimal value (SI units)."""
        if isinstance(self.best, Linkage):
            from ..model.design import design_value

            return {name: design_value(self.best, name) for name in self.genes}
        return {name: getattr(self.best, name) for name in self.genes}

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-serialisable dict (mechanisms as field dicts)."""
        return {
            "format": _FORMAT,
            "best": self.best.to_dict(),
            "best_genes": self.best_genes,
            "best_peak_force": self.best_peak_force,
            "original": self.original.to_dict(),
            "original_peak_force": self.original_peak_force,
            "reduction_percent": self.reduction_percent,
            "history": [float(v) for v in self.history],
            "genes": {k: [float(a), float(b)] for k, (a, b) in self.genes.items()},
            "settings": self.settings,
            "n_evaluations": self.n_evaluations,
            "ga_best": self.ga_best.to_dict(),
            "ga_best_peak_force": self.ga_best_peak_force,
            "generations_completed": self.generations_completed,
            "n_failed": self.n_failed,
            "elapsed": self.elapsed,
            "best_periodic": self.best_periodic,
            "best_periodicity_note": self.best_periodicity_note,
            "best_accuracy_note": self.best_accuracy_note,
            "stop_reason": self.stop_reason,
            "refinement": self.refinement,
        }

    def to_json(self, path: str | Path) -> Path:
        """Write the result with the settings used to `path` (JSON); returns the path."""
        return write_json_object(path, self.to_dict())

    @classmethod
    def from_json(cls, path: str | Path) -> OptimizationResult:
        """Read a result written by `to_json`."""
        data = read_json_object(path, "optimisation result")
        if data.get("format") != _FORMAT:
            raise ValueError(f"{str(path)!r} is not an optimisation result ({_FORMAT})")
        settings = data["settings"]
        case, overrides = settings.get("case"), settings.get("overrides") or {}

        def design(d, genes=None):
            # a Linkage's description (it has bodies) or a SliderCrank's fields; a linkage
            # of a named case is rebuilt by the case (with the genes' values) where that
            # gives the stored description, so that it keeps its case and overrides
            if "bodies" not in d:
                return SliderCrank.from_dict(d)
            return _rebuilt(Linkage.from_dict(d), case, overrides, genes)

        return cls(
            best=design(data["best"], data.get("best_genes")),
            best_peak_force=float(data["best_peak_force"]),
            original=design(data["original"]),
            original_peak_force=float(data["original_peak_force"]),
            history=np.asarray(data["history"], dtype=float),
            genes={k: (float(a), float(b)) for k, (a, b) in data["genes"].items()},
            settings=data["settings"],
            n_evaluations=int(data["n_evaluations"]),
            ga_best=design(data["ga_best"]),
            ga_best_peak_force=float(data["ga_best_peak_force"]),
            generations_completed=int(data["generations_completed"]),
            n_failed=int(data.get("n_failed", 0)),
            elapsed=float(data.get("elapsed", 0.0)),
            best_periodic=_optional_bool(data.get("best_periodic")),
            best_periodicity_note=data.get("best_periodicity_note"),
            best_accuracy_note=data.get("best_accuracy_note"),
            stop_reason=str(data.get("stop_reason", "generations")),
            refinement=dict(data.get("refinement") or {}),
        )


def _rebuilt(description: Linkage, case: str | None, overrides: dict,
             genes: dict | None) -> Linkage:
    """`description` as its named case built with `overrides` and the `genes`' values
    (`design.linkage_with`), where that gives the same description; else as read."""
    if case is None:
        return description
    from ..model.cases import CASES
    from ..model.design import linkage_with

    try:
        linkage = CASES[case](**overrides)
        if genes:
            linkage = linkage_with(linkage, {k: float(v) for k, v in genes.items()})
    except (KeyError, TypeError, ValueError):
        return description
    return linkage if linkage.to_dict() == description.to_dict() else description


def _optional_bool(value) -> bool | None:
    return None if value is None else bool(value)


def _pygad_logger() -> logging.Logger:
    """pygad's messages: its warnings on stderr; its ERROR records (it logs the traceback
    of every exception before re-raising it) dropped, the exception itself propagates."""
    logger = logging.getLogger("mbs_clearance.studies.optimize.pygad")
    if not logger.handlers:
        handler = logging.StreamHandler()
        handler.addFilter(lambda record: record.levelno < logging.ERROR)
        logger.addHandler(handler)
        logger.setLevel(logging.WARNING)
        logger.propagate = False
    return logger


# ----------------------------------------------------------------------------- validation

def _is_int(value) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _check_int(name: str, value, minimum: int) -> int:
    if not _is_int(value) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def _check_genes(base: SliderCrank | Linkage, genes: dict, mass_scaling: str) -> dict:
    if not isinstance(genes, dict) or not genes:
        raise ValueError("genes must be a non-empty dict {field: (lower, upper)}; "
                         f"got {genes!r}")
    if isinstance(base, Linkage):
        from ..model.design import check_names

        check_names(base, genes, "gene")
    else:
        unknown = [n for n in genes if n not in CONTINUOUS_FIELDS]
        if unknown:
            raise ValueError(f"unknown gene name(s) {unknown}; allowed: "
                             f"{list(CONTINUOUS_FIELDS)}")
    if mass_scaling == "uniform":
        clash = [n for n in genes if n in _SCALED_FIELDS]
        if clash:
            raise ValueError(f"gene(s) {clash} cannot be optimised with mass_scaling='uniform'"
                             " (they follow the lengths); use mass_scaling='fixed'")
    out = {}
    for name, bounds in genes.items():
        try:
            lo, hi = bounds
            ok = all(isinstance(v, numbers.Real) and not isinstance(v, bool)
                     and math.isfinite(v) for v in (lo, hi))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ValueError(f"bounds of gene {name!r} must be two finite numbers "
                             f"(lower, upper); got {bounds!r}")
        if not lo < hi:
            raise ValueError(f"bounds of gene {name!r} must satisfy lower < upper; "
                             f"got ({lo!r}, {hi!r})")
        out[name] = (float(lo), float(hi))
    # every constraint of SliderCrank is linear in the fields (L3 > L2, R_J < R_B, ranges),
    # so the box is feasible when all its corners are; a case's are convex in its overrides
    # (positive values, clearance < bearing radius, the four-bar's Grashof crank-rocker:
    # crank + longest - the other two < 0 with the crank shortest), so its box is too
    names = list(out)
    for corner in itertools.product(*(out[n] for n in names)):
        try:
            if isinstance(base, Linkage):
                from ..model.design import linkage_with

                linkage_with(base, dict(zip(names, corner))).assemble()
            else:
                design_mechanism(base, dict(zip(names, corner)), mass_scaling)
        except ValueError as exc:
            raise ValueError(
                f"the gene bounds {out} contain an invalid mechanism at "
                f"{dict(zip(names, corner))}: {exc}") from exc
    return out


# ----------------------------------------------------------------------------- the driver

_DEFAULT_CRANK = (0.04, 0.06)
_DEFAULT_COUPLER = (0.10, 0.14)


def ga_memory(population: int, generations: int, n_genes: int,
              max_memory: int | None = None) -> int:
    """Estimated peak memory (bytes) of a GA run: pygad's arrays of the population (eight
    copies of population x genes), one generation's designs, and the cache of every design
    evaluated (population x generations entries, about 120 + 32 genes bytes each, measured);
    `MemoryLimitError` naming population and generations above `max_memory`."""
    need = (population * (64 * n_genes + 32 + DESIGN_BYTES)
            + population * generations * (120 + 32 * n_genes))
    check_memory(f"population={population} x generations={generations}: the GA needs", need,
                 max_memory, "use a smaller population or fewer generations")
    return need


def optimize_link_lengths(mech: SliderCrank | None = None,
                          crank_length: tuple[float, float] = _DEFAULT_CRANK,
                          coupler_length: tuple[float, float] = _DEFAULT_COUPLER,
                          revolution: int = 4, backend: str = "reduced",
                          seed: int | None = None, executor=None, population: int = 20,
                          generations: int = 30, saturation: int | None = 10,
                          genes: dict[str, tuple[float, float]] | None = None,
                          mass_scaling: str = "fixed", refine: bool | str = True,
                          progress: bool = True, workers: int = 2,
                          saturation_rtol: float = SATURATION_RTOL,
                          dask_timeout: float = DASK_WORKER_TIMEOUT,
                          output: str | None = None, window: float | None = None,
                          **backend_options) -> OptimizationResult:
    """Minimise max |F12| over crank revolution `revolution` with a GA (paper Eq. 18).

    Parameters
    ----------
    mech : SliderCrank or Linkage, optional
        Starting design; every field that is not a gene keeps its value (default: the paper's
        case). A Linkage (a named case's or a description's) needs `genes` named by its
        case's overrides or dotted paths of its description (`design`, e.g.
        ``{"coupler_length": (3.6, 4.4), "rocker_length": (2.2, 2.8)}`` for the four-bar);
        its objective is the peak of `output` (`objective.peak_output`), its refinement
        (``refine=True``) Nelder-Mead, its backend the generated model ("reduced").
    crank_length : (float, float), default (0.04, 0.06)
        Bounds in m of L2, a default gene (the paper's).
    coupler_length : (float, float), default (0.1, 0.14)
        Bounds in m of L3, a default gene (the paper's).
    revolution : int
        Crank revolution (1-based) whose peak |F12| is minimised (paper: 4); a free
        Linkage's (drive None): the time window [(k - 1) w, k w] of width `window`.
    window : float, optional
        A free Linkage's window width w in s (required there, refused for a driven
        linkage; `objective.objective_window`).
    backend : str
        Model, a key of `BACKENDS` ("reduced" default; "ideal" for rigid joints).
    seed : int, optional
        Seed of the GA in [0, 2**32 - 1]; the same seed gives the same result on every
        executor. None draws one, which is recorded in ``settings["seed"]``.
    executor : optional
        Where the designs of a generation are simulated: None (the default local pool of
        `workers`: threads for "reduced" and "ideal", processes for "exudyn"), "serial"
        (this process), "threads" or "processes" (a local pool of `workers`, created and
        shut down here), any `concurrent.futures`-style executor (``submit`` or ``map``),
        or a `dask.distributed.Client` (see `connect_dask`).
    population : int
        Population size (>= 4).
    generations : int
        Maximum number of generations (>= 1).
    saturation : int or None
        Stop when the best value has moved by at most `saturation_rtol` of its value over
        the last `saturation` generations; None disables it.
    genes : dict, optional
        ``{field: (lower, upper)}`` of any continuous `SliderCrank` fields (SI units);
        replaces the two default genes.
    mass_scaling : {"fixed", "uniform"}
        "fixed": link masses stay as in `mech` (the paper's wording); "uniform": crank and
        coupler masses scale with their lengths (uniform density), see `design_mechanism`.
    refine : bool or str
        Polish the GA's best point with a bounded local search on the same objective:
        True or "l-bfgs-b" (bounded quasi-Newton with the exact gradient of the peak, see
        `REFINE_METHODS`), "nelder-mead" (bounded, derivative-free); False for none. The
        result's `refinement` says whether it ended on a bound and whether the KKT
        conditions hold there.
    progress : bool
        Show a tqdm progress bar with the best value so far.
    workers : int
        Size of the local pool (threads or processes) when `executor` is None, "threads" or
        "processes"; 1 evaluates in this process.
    saturation_rtol : float, default 1e-9
        Relative tolerance of the saturation test, in [0, 1).
    dask_timeout : float, default 60.0
        Seconds to wait for the first worker of a dask Client before giving up (> 0).
    output : str, optional
        Linkage only: the output whose peak is minimised (`objective.parse_output`:
        "pivot_force:<ground joint>", "shaking_force", "drive_moment",
        "contact_force:<clearance joint>"; default `Linkage.default_output`, the peak
        `simulate` reports).
    **backend_options
        Passed to `peak_base_force` (e.g. ``rtol``, ``accuracy``). The GA's cheaper
        default on the reduced backend: each design of a `SliderCrank` at rtol `GA_RTOL`
        (1e-7), one run without an error estimate (measured against rtol 1e-12: within
        1e-5 at 80 of the 81 points of a 9 x 9 grid of the paper's box, 2.9e-5 at L2 = 4.5
        cm, L3 = 12.5 cm; 1.2e-3 at 2000 rpm); a `Linkage`'s designs at the default
        accuracy (`peak_output`); the best design
        is simulated again at the default accuracy (``best_accuracy_note`` where its own
        estimate misses it). Give ``accuracy=1e-5`` for error-controlled evaluations
        (about 1.2 times the cost). ``max_memory`` (bytes) is also the
        limit of the GA's own estimated memory (`ga_memory`; default
        `_checks.default_max_memory`), checked before any design is simulated.

    Returns
    -------
    OptimizationResult

    Notes
    -----
    Ctrl-C (KeyboardInterrupt) and SIGTERM stop a pool the call created within about one
    design's simulation and leave no worker behind (SIGTERM then exits with code 143).
    """
    import pygad
    from tqdm.auto import tqdm

    if getattr(multiprocessing.current_process(), "_inheriting", False):
        # a forkserver/spawn worker re-importing a script without a main guard: stop it
        # with one line (the parent reports the same advice) instead of a recursive GA
        raise SystemExit(_MAIN_GUARD_ADVICE)
    t_start = time.perf_counter()
    given = SliderCrank() if mech is None else mech
    entry = door(given)
    # the paper's case (given as its parameter set or as its named case) runs as that set:
    # its fields the genes, its mass scaling, every backend; a named case asked for another
    # output, and any other linkage, on its description
    fields = genes is None or (isinstance(genes, dict)
                               and all(n in CONTINUOUS_FIELDS for n in genes))
    mech = entry.paper if entry.paper is not None and output is None \
        and (fields or entry.given_as_paper) else entry.linkage
    is_linkage = mech is entry.linkage
    if is_linkage:
        from ..analysis.objective import parse_output

        output = parse_output(mech, output).name
        if genes is None:
            from ..model.design import design_names

            raise ValueError(f"genes must be given for a Linkage ({{name: (lower, upper)}} "
                             f"of {design_names(mech)})")
        if backend != "reduced":
            raise ValueError(f"backend must be 'reduced' for a Linkage (its generated "
                             f"model); got {backend!r}")
        if mass_scaling != "fixed":
            raise ValueError("mass_scaling applies to a SliderCrank; a Linkage's masses are "
                             "genes or follow its case (mass_scaling='fixed')")
    elif output is not None:
        raise ValueError("output applies to a Linkage; a SliderCrank's objective is the "
                         "peak of |F12|")
    elif window is not None:
        raise ValueError("window (s) is for a free Linkage (drive=None); a SliderCrank's "
                         "objective is the peak over a crank revolution")
    if mass_scaling not in MASS_SCALINGS:
        raise ValueError(f"mass_scaling must be one of {list(MASS_SCALINGS)}; "
                         f"got {mass_scaling!r}")
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {sorted(BACKENDS)}; got {backend!r}")
    revolution = _check_int("revolution", revolution, 1)
    if is_linkage:
        from ..analysis.objective import objective_window

        objective_window(mech, revolution, window)
    population = _check_int("population", population, 4)
    generations = _check_int("generations", generations, 1)
    if saturation is not None:
        saturation = _check_int("saturation", saturation, 1)
    if not isinstance(saturation_rtol, numbers.Real) or isinstance(saturation_rtol, bool) \
            or not 0.0 <= saturation_rtol < 1.0:
        raise ValueError(f"saturation_rtol must be a number in [0, 1); got {saturation_rtol!r}")
    dask_timeout = _check_timeout("dask_timeout", dask_timeout)
    refine_method = _check_refine(refine)
    if is_linkage and refine is True:
        # a Linkage's gradient is central differences (2 p + 1 runs a call): the
        # derivative-free search costs fewer runs
        refine_method = "nelder-mead"
    if seed is None:
        seed = int(np.random.SeedSequence().generate_state(1)[0])
    elif not _is_int(seed) or not 0 <= seed < 2**32:
        raise ValueError(f"seed must be None or an integer in [0, 2**32 - 1]; got {seed!r}")
    if genes is None:
        genes = {"crank_length": crank_length, "coupler_length": coupler_length}
    elif crank_length != _DEFAULT_CRANK or coupler_length != _DEFAULT_COUPLER:
        raise ValueError("pass either genes=... or crank_length/coupler_length bounds, "
                         "not both (put all bounds in genes)")
    genes = _check_genes(mech, genes, mass_scaling)
    ga_memory(population, generations, len(genes), backend_options.get("max_memory"))
    if isinstance(executor, str) and executor not in LOCAL_EXECUTORS:
        raise ValueError(f"executor must be None, one of {list(LOCAL_EXECUTORS)}, a "
                         f"concurrent.futures executor or a dask.distributed.Client; "
                         f"got {executor!r}")
    if executor is None or executor in ("threads", "processes"):
        _check_int("workers", workers, 1)
    if executor is None:
        executor = "threads" if backend in _THREAD_SAFE_BACKENDS else "processes"

    names = tuple(genes)
    problem = _Problem(base=mech, names=names, lo=tuple(genes[n][0] for n in names),
                       hi=tuple(genes[n][1] for n in names), mass_scaling=mass_scaling,
                       revolution=revolution, backend=backend, options=dict(backend_options),
                       output=output, window=window)
    # the original design, in this process: checks the options and warms the compiled model
    if is_linkage:
        from ..analysis.objective import peak_output

        original_peak = float(peak_output(mech, output, revolution, window=window,
                                          **backend_options))
    else:
        original_peak = float(peak_base_force(mech, revolution, backend,
                                              **problem.eval_options))

    run_id = next(_RUN_IDS)
    objective = _Objective(problem, run_id)
    n_genes = len(names)
    n_elite = max(1, population // 10)
    ga_settings = dict(_GA_OPERATORS, num_parents_mating=max(2, population // 2),
                       keep_elitism=n_elite, mutation_probability=1.0 / n_genes)
    settings = {
        "revolution": revolution, "backend": backend, "backend_options": dict(backend_options),
        "seed": seed, "population": population, "generations": generations,
        "saturation": saturation, "saturation_rtol": float(saturation_rtol),
        "mass_scaling": mass_scaling, "refine": refine_method or False,
        # the output the peaks are of (the paper's set: its default, |F12|)
        "output": output if is_linkage else entry.linkage.default_output,
        **({"case": entry.linkage.case, "overrides": dict(entry.linkage.overrides)}
           if not entry.given_as_paper else {}),
        **({"window": window} if window is not None else {}),
        "ga": ga_settings, "pygad_version": pygad.__version__,
    }
    on_generation = _OnGeneration(run_id, saturation, float(saturation_rtol))
    ga = pygad.GA(
        num_generations=generations, fitness_func=objective, fitness_batch_size=population,
        sol_per_pop=population, num_genes=n_genes, gene_type=float,
        init_range_low=0.0, init_range_high=1.0,
        gene_space=[{"low": 0.0, "high": 1.0}] * n_genes,
        on_generation=on_generation, random_seed=seed, logger=_pygad_logger(),
        **ga_settings)

    own_pool = None
    if executor == "threads" and workers > 1:
        own_pool = ThreadPoolExecutor(workers, thread_name_prefix="mbs-ga")
    elif executor == "processes" and workers > 1:
        own_pool = local_process_pool(workers)
    executor = own_pool if isinstance(executor, str) else executor
    dispatcher = _Dispatcher(executor, workers if own_pool is not None else None)
    settings["executor"] = _describe_executor(executor, dispatcher.n_workers)
    interrupted = True
    with _sigterm_raises():
        try:
            if dispatcher.is_dask:
                _wait_for_dask_workers(executor, dask_timeout)
            bar = tqdm(total=generations, desc="GA", unit="gen", disable=not progress,
                       leave=True)
            _ACTIVE[run_id] = (dispatcher, bar)
            try:
                ga.run()
            finally:
                _ACTIVE.pop(run_id, None)
                bar.close()
            interrupted = False
        except BrokenProcessPool as exc:
            raise RuntimeError(f"the GA's worker processes stopped ({exc}); "
                               f"{_MAIN_GUARD_ADVICE}") from None
        finally:
            if own_pool is not None:
                _stop_pool(own_pool, dispatcher, interrupted)

        history = -np.asarray(ga.best_solutions_fitness, dtype=float)
        u_ga, fit_ga, _ = ga.best_solution(pop_fitness=ga.last_generation_fitness)
        ga_peak = float(-fit_ga)
        u_best, best_peak = np.asarray(u_ga, dtype=float), ga_peak
        refinement: dict[str, Any] = {}
        if refine_method:
            u_best, best_peak, refinement = _refine(objective, u_best, best_peak, progress,
                                                    refine_method)
        best = problem.mechanism(u_best)
        periodic, note, accuracy_note = _periodicity(best, problem)
    n_failed = sum(1 for p in objective.cache.values() if not math.isfinite(p))
    return OptimizationResult(
        best=entry.back(best), best_peak_force=float(best_peak), original=given,
        original_peak_force=original_peak, history=history, genes=genes, settings=settings,
        n_evaluations=len(objective.cache) + 1, ga_best=entry.back(problem.mechanism(u_ga)),
        ga_best_peak_force=ga_peak, generations_completed=int(ga.generations_completed),
        n_failed=n_failed, elapsed=time.perf_counter() - t_start,
        best_periodic=periodic, best_periodicity_note=note,
        best_accuracy_note=accuracy_note,
        stop_reason="saturation" if on_generation.saturated() else "generations",
        refinement=refinement)


def _periodicity(best: SliderCrank, problem: _Problem):
    """Simulate the best design once; its periodicity flag and note from the stats (None
    where the backend does not report them or the integration fails), and the accuracy note
    of that run (its AccuracyWarning's text, kept in the result instead of warned). A
    free linkage has none: its motion is not periodic in a drive period."""
    if problem.window is not None:
        return None, ("a free linkage (drive=None): no drive period, no periodicity "
                      "check"), None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AccuracyWarning)
            traj = simulate(best, problem.revolution, problem.backend, **problem.options)
    except RuntimeError as exc:
        return None, f"the best design could not be simulated again: {exc}", None
    periodic = traj.stats.get("periodic")
    note = traj.stats.get("periodicity_note")
    accuracy = traj.stats.get("accuracy_note") or None
    return (None if periodic is None else bool(periodic)), \
        (None if note is None else str(note)), accuracy


#: refinement methods (`refine=`); True selects the first: "l-bfgs-b" (scipy's bounded
#: quasi-Newton method with the exact gradient of the peak, `objective.peak_gradient`: DDM
#: for the reduced model, central differences for the other backends) or "nelder-mead"
REFINE_METHODS = ("l-bfgs-b", "nelder-mead")

#: L-BFGS-B settings: at most this many objective (value and gradient) calls; stop when the
#: peak changes by less than `ftol` relative (the default integration accuracy is ~1e-6) or
#: the projected gradient of the peak relative to the start's, in the unit box, is below
#: `gtol_rel` (a gene whose gradient points out of the box: within gtol_rel of its bound)
_LBFGSB = {"maxfun": 60, "ftol": 1e-10, "gtol_rel": 1e-7}

#: KKT check at the refined point, gradient in the unit box (N per box width): at a lower
#: bound dF/du >= -tol, at an upper bound <= tol, inside |dF/du| <= tol, tol = this * peak
KKT_RTOL = 1e-4


def _check_refine(refine) -> str | None:
    if refine is False or refine is None:
        return None
    if refine is True:
        return REFINE_METHODS[0]
    if isinstance(refine, str) and refine in REFINE_METHODS:
        return refine
    raise ValueError(f"refine must be True, False or one of {list(REFINE_METHODS)}; "
                     f"got {refine!r}")


#: local refinement: Nelder-Mead with bounds (scipy clips to the box, so it lands exactly on
#: a bound where the optimum is one, which Powell's bounded line search does not), started
#: from a simplex spanning 5 % of the box; the peak is accurate to about 1e-6 relative at
#: the default rtol, so a tighter fatol buys nothing
_REFINE_STEP = 0.05
_REFINE_OPTIONS = {"xatol": 1e-6, "fatol_rel": 1e-6, "maxfev": 400}


def _refine(objective: _Objective, u0: np.ndarray, f0: float, progress: bool, method: str):
    """Bounded local search from the GA's best point; returns the better of (start, refined)
    and the refinement's record (see `OptimizationResult.refinement`)."""
    from tqdm.auto import tqdm

    calls = [0]
    with tqdm(desc="refine", unit="eval", disable=not progress, leave=True) as bar:
        if method == "l-bfgs-b":
            def fun_grad(u):
                calls[0] += 1
                bar.update(1)
                peak, grad, _ = _peak_and_gradient(objective.problem, np.clip(u, 0.0, 1.0))
                return peak, grad

            u, record = _lbfgsb(fun_grad, u0, f0)
        else:
            def fun(u):
                calls[0] += 1
                bar.update(1)
                return float(objective.peaks(np.clip(u, 0.0, 1.0), serial=True)[0])

            u, record = _nelder_mead(fun, u0, f0)
        f = float(objective.peaks(u, serial=True)[0])
        bar.set_postfix_str(f"best max|F12| = {min(f, f0):.2f} N", refresh=True)
    improved = f < f0
    # a start within _SNAP of a bound, with the gradient pointing out of the box, moved onto
    # the bound: the first-order change is far below the objective's integration accuracy,
    # so the two values differ by integration noise alone (either sign); the bound's design
    # is kept (the result then says truthfully that it sits on the bound) when its value is
    # within that accuracy of the start's
    projected = (method == "l-bfgs-b" and not improved and np.any(u != u0)
                 and bool(np.all(np.abs(u - u0) <= _SNAP))
                 and f <= f0 * (1.0 + _accuracy(objective.problem)))
    u_out, f_out = (u, f) if improved or projected else (u0, f0)
    record.update(method=method, objective_calls=calls[0], improved=bool(improved),
                  projected=bool(projected),
                  start_peak_force=float(f0), end_peak_force=float(f_out),
                  **_bounds_record(objective.problem, u_out))
    if method == "l-bfgs-b":
        record.update(_kkt_record(objective.problem, u_out, record["on_bounds"]))
    return u_out, f_out, record


def _gradient_parameters(problem: _Problem) -> list[str]:
    """Fields whose derivatives the genes' gradient needs: the genes and, with uniform mass
    scaling, the masses and explicit inertias that follow the lengths."""
    params = list(problem.names)
    if problem.mass_scaling == "uniform":
        for length, mass, inertia in _SCALED_LINKS:
            if length in params:
                params.append(mass)
                if getattr(problem.base, inertia) is not None:
                    params.append(inertia)
    return params


#: (length, mass, inertia) of the links whose mass follows the length (uniform scaling)
_SCALED_LINKS = (("crank_length", "crank_mass", "crank_inertia"),
                 ("coupler_length", "coupler_mass", "coupler_inertia"))


def _peak_and_gradient(problem: _Problem, u: np.ndarray):
    """Peak |F12| (N) at genes `u` and its gradient in the unit box (N per box width):
    `objective.peak_gradient` (DDM for the reduced model, central differences otherwise),
    chained through the mass scaling: with uniform density m = m0 L / L0 and an explicit
    J = J0 (L / L0)^3, so d/dL = dF/dL + (m/L) dF/dm + 3 (J/L) dF/dJ; then times (hi - lo)."""
    from ..analysis.objective import peak_gradient

    mech = problem.mechanism(u)
    params = _gradient_parameters(problem)
    options = dict(problem.options)
    if isinstance(mech, Linkage):
        kwargs = {"method": "fd", "output": problem.output, "window": problem.window,
                  **options}
    elif problem.backend == "reduced":
        kwargs = {"method": "ddm", "rtol": options.get("rtol")}
    else:
        kwargs = {"method": "fd", **options}
    pg = peak_gradient(mech, parameters=params, revolution=problem.revolution,
                       backend=problem.backend, **kwargs)
    g = dict(zip(params, np.asarray(pg.gradient, dtype=float)))
    grad = []
    for name in problem.names:
        d = g[name]
        for length, mass, inertia in _SCALED_LINKS:
            if name == length and mass in g:
                L = getattr(mech, length)
                d += getattr(mech, mass) / L * g[mass]
                if inertia in g:
                    d += 3.0 * getattr(mech, inertia) / L * g[inertia]
        grad.append(d)
    width = np.asarray(problem.hi) - np.asarray(problem.lo)
    return float(pg.peak), np.asarray(grad) * width, pg


def _lbfgsb(fun_grad, u0: np.ndarray, f0: float):
    """scipy L-BFGS-B on the unit box with the exact gradient."""
    from scipy.optimize import minimize

    n = len(u0)
    scale = 1.0 / abs(f0) if f0 else 1.0

    def scaled(u):
        # the peak relative to the start's: L-BFGS-B's projected gradient mixes the
        # gradient (inside) with the distance to the bound (a gene whose gradient points
        # out of the box), so gtol must be relative for both to be small together (with
        # gtol in N a gene 1e-4 of the box off its bound counted as converged)
        peak, grad = fun_grad(u)
        return peak * scale, np.asarray(grad) * scale

    opts = {"maxfun": _LBFGSB["maxfun"], "ftol": _LBFGSB["ftol"],
            "gtol": _LBFGSB["gtol_rel"]}
    res = minimize(scaled, np.asarray(u0, dtype=float), jac=True, method="L-BFGS-B",
                   bounds=[(0.0, 1.0)] * n, options=opts)
    u = np.clip(res.x, 0.0, 1.0)
    # L-BFGS-B stops once the projected gradient is small, which a gene within gtol of a
    # bound with the gradient pointing out of the box already satisfies: put such genes on
    # the bound (the caller keeps the better of the two points, or the bound's within the
    # objective's accuracy)
    g = np.asarray(res.jac, dtype=float)
    u = np.where((u <= _SNAP) & (g > 0), 0.0, np.where((u >= 1.0 - _SNAP) & (g < 0), 1.0, u))
    return u, {"message": str(res.message)}


#: genes within this fraction of the box from a bound, with the gradient pointing out of
#: the box, are put on the bound after L-BFGS-B
_SNAP = 1e-6


def _accuracy(problem: _Problem) -> float:
    """Relative accuracy of the objective at the problem's settings: the stated target on
    every per-revolution peak (objective.KINK_RTOL, 1e-5, docs/performance.md) or 100 rtol
    for a looser reduced rtol."""
    from ..analysis.objective import KINK_RTOL

    rtol = problem.options.get("rtol") if problem.backend == "reduced" else None
    return max(KINK_RTOL, 100.0 * rtol) if rtol else KINK_RTOL


def _kkt_record(problem: _Problem, u: np.ndarray, on_bounds: dict) -> dict[str, Any]:
    """Gradient at the final point and the KKT check: at a lower bound dF/du >= -tol, at an
    upper bound <= tol, inside |dF/du| <= tol (tol = KKT_RTOL * peak, unit box)."""
    peak, grad, pg = _peak_and_gradient(problem, u)
    tol = KKT_RTOL * abs(peak)
    ok = []
    for name, g in zip(problem.names, grad):
        side = on_bounds.get(name)
        ok.append(g >= -tol if side == "lower" else g <= tol if side == "upper"
                  else abs(g) <= tol)
    return {"gradient": {n: float(g) for n, g in zip(problem.names, grad)},
            "kkt": bool(all(ok)), "kkt_tol": float(tol), "kink": bool(pg.kink)}


def _nelder_mead(fun, u0: np.ndarray, f0: float):
    """Bounded Nelder-Mead from a simplex spanning `_REFINE_STEP` of the box."""
    from scipy.optimize import minimize

    n = len(u0)
    simplex = [u0]
    for i in range(n):
        step = np.zeros(n)
        step[i] = _REFINE_STEP if u0[i] + _REFINE_STEP <= 1.0 else -_REFINE_STEP
        simplex.append(u0 + step)
    opts = {"xatol": _REFINE_OPTIONS["xatol"], "maxfev": _REFINE_OPTIONS["maxfev"],
            "fatol": _REFINE_OPTIONS["fatol_rel"] * abs(f0), "initial_simplex": simplex}
    res = minimize(fun, u0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * n, options=opts)
    return np.clip(res.x, 0.0, 1.0), {"message": str(res.message)}


def _bounds_record(problem: _Problem, u: np.ndarray) -> dict[str, Any]:
    """The genes of `u` that sit on a bound: {name: "lower" | "upper"}."""
    on = {}
    for name, ui in zip(problem.names, np.asarray(u, dtype=float)):
        if ui <= 0.0:
            on[name] = "lower"
        elif ui >= 1.0:
            on[name] = "upper"
    return {"on_bounds": on}
