"""Regime maps and bifurcation diagrams: sweeps of long runs on any executor.

`regime_map(mech, sweep, revolutions=100, keep=50, ...)` runs a grid over one or two fields
of a description (`parse_sweep`: "clearance=1e-6:1e-3:log:60", "crank_speed=500rpm:10000rpm:40",
"crank_length=0.04,0.05,0.06"); each point is a `poincare.poincare_section` run (the last
`keep` revolutions' section samples, the regime, optionally the largest Lyapunov exponent)
and keeps what the map needs only: O(keep) numbers per point.

The points are evaluated by `executor.evaluate` (a local thread pool by default, a process
pool, or dask.distributed: `scheduler="tcp://host:port"` or a Client), in chunks; each
chunk's results are written into the dataset as it arrives (`out`: a netCDF file, written
whole to a temporary file and renamed, so a killed run leaves the last complete file). A
re-run with the same settings and `out` skips the points already done (`done` = 1), so a
killed sweep resumed gives the same dataset as an uninterrupted one: every point is a
deterministic function of its design.

Fields: a SliderCrank's field names (`mechanism.SliderCrank`), plus "clearance" (the
journal radius is set to bearing_radius - clearance); a Linkage's dotted parameter names
(`Linkage.parameter_names`), plus "clearance" (every clearance joint's journal radius),
"<joint>.clearance" and "crank_speed" (the drive's speed); for a named case (`case=`), its
overrides (`cases.CASE_PARAMETERS`), plus "clearance" for every clearance of the case.
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._checks import (
    DESIGN_BYTES,
    check_bool,
    check_int,
    check_memory,
    check_real,
    revolution_bytes,
)
from .._io import recover
from ..analysis.poincare import (
    MAX_PERIOD,
    RECURRENCE_TOL,
    REGIME_CODES,
    REGIMES,
    SECTION_COMPONENTS,
    clearances_of,
    drive_of,
    joints_of,
    poincare_section,
)
from ..model.design import design_at
from ..units import number, parse_quantity

__all__ = ["SweepAxis", "parse_sweep", "design_at", "regime_map", "MapResult", "load_map",
           "map_memory"]

RPM = 2.0 * math.pi / 60.0

#: the dataset format's version (a resumed run must match it)
FORMAT = "mbs-clearance regime map 5"


@dataclass(frozen=True)
class SweepAxis:
    """One swept field: its name, values (SI) and spacing ("log", "lin" or "list")."""

    name: str
    values: tuple[float, ...]
    spacing: str = "list"

    def __post_init__(self):
        if not self.values:
            raise ValueError(f"sweep {self.name}: no values")


#: bytes of one swept value held while parsed (a float64 and a Python float in a tuple)
_VALUE_BYTES = 40

def _value(name: str, text: str, unit: str | None) -> float:
    """A number in SI, or with a unit suffix of `unit` (`units.parse_quantity`)."""
    return parse_quantity(text.strip(), unit, f"sweep {name}")


def parse_sweep(spec, unit_of=None) -> SweepAxis:
    """A sweep from "NAME=LO:HI:N" (linear), "NAME=LO:HI:lin:N", "NAME=LO:HI:log:N" or
    "NAME=V1,V2,..." (numbers, SI or with a unit suffix: "500rpm", "0.02mm",
    `units.UNIT_SUFFIXES`; `unit_of(NAME)` gives the field's SI unit, whose suffixes only
    are accepted, None: any suffix converts by itself); a `SweepAxis` or (name, values) is
    taken as is. ValueError naming the problem otherwise."""
    if isinstance(spec, SweepAxis):
        return spec
    if isinstance(spec, tuple) and len(spec) == 2:
        values = tuple(float(v) for v in np.atleast_1d(np.asarray(spec[1], dtype=float)))
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"sweep {spec[0]}: values must be finite")
        return SweepAxis(str(spec[0]), values)
    if not isinstance(spec, str) or "=" not in spec:
        raise ValueError(f"a sweep must be 'NAME=LO:HI:[lin|log:]N' or 'NAME=V1,V2,...'; "
                         f"got {spec!r}")
    name, rhs = (s.strip() for s in spec.split("=", 1))
    if not name:
        raise ValueError(f"sweep {spec!r}: no field name before '='")
    unit = unit_of(name) if unit_of is not None else None
    if ":" in rhs:
        parts = [s.strip() for s in rhs.split(":")]
        if len(parts) == 3:
            parts.insert(2, "lin")
        if len(parts) != 4 or parts[2] not in ("lin", "log"):
            raise ValueError(f"sweep {name}: range must be LO:HI:N, LO:HI:lin:N or "
                             f"LO:HI:log:N; got {rhs!r}")
        lo, hi = _value(name, parts[0], unit), _value(name, parts[1], unit)
        try:
            n = int(parts[3])
        except ValueError:
            raise ValueError(f"sweep {name}: the number of points must be an integer >= 1; "
                             f"got {parts[3]!r}") from None
        if n < 1:
            raise ValueError(f"sweep {name}: the number of points must be >= 1; got {n}")
        check_memory(f"sweep {name} with {n} points: its values need", n * _VALUE_BYTES,
                     advice="use fewer points")
        if parts[2] == "log":
            if not (lo > 0 and hi > 0):
                raise ValueError(f"sweep {name}: a log range needs LO, HI > 0; got {rhs!r}")
            values = np.geomspace(lo, hi, n)
        else:
            values = np.linspace(lo, hi, n)
        return SweepAxis(name, tuple(float(v) for v in values), parts[2])
    values = tuple(_value(name, v, unit) for v in rhs.split(",") if v.strip())
    return SweepAxis(name, values)


# ------------------------------------------------------------------------------ designs

# ------------------------------------------------------------------------------- points

def _map_point(item, settings: dict) -> dict:
    """Worker: one sweep point (flat index, design) -> what the map keeps of its run."""
    index, mech = item
    keep = settings["keep"]
    J = len(joints_of(mech))
    out = {"index": index, "status": 1, "message": "", "tangent_failed": 0}
    t0 = time.perf_counter()
    run = dict(angle=settings["angle"], tol=settings["tol"],
               max_period=settings["max_period"], rtol=settings["rtol"])
    early = dict(early_stop=settings.get("early_stop", False) and not settings["lyapunov"])
    try:
        try:
            sec = poincare_section(mech, settings["revolutions"], keep,
                                   lyapunov=settings["lyapunov"], **run, **early)
        except RuntimeError:
            if not settings["lyapunov"]:
                raise
            # the tangent run failed (e.g. events chattering at a grazing contact under the
            # tangent's error control): the plain run still gives the section and regime
            out["tangent_failed"] = 1
            sec = poincare_section(mech, settings["revolutions"], keep, lyapunov=False,
                                   **run)
    except (RuntimeError, ValueError, NotImplementedError) as exc:
        out.update(status=2, message=str(exc).splitlines()[0][:200],
                   section=np.full((keep, J, 4), np.nan), peak=np.full(keep, np.nan),
                   regime=REGIME_CODES["failed"], period=0, lyapunov=np.nan,
                   lyapunov_uncertainty=np.nan,
                   distance=np.full(settings["max_period"], np.nan), nfev=0, rtol=np.nan,
                   stopped=0)
    else:
        out.update(section=sec.samples, peak=sec.peaks[-keep:],
                   regime=REGIME_CODES[sec.regime], period=sec.period,
                   lyapunov=sec.lyapunov, lyapunov_uncertainty=sec.lyapunov_uncertainty,
                   distance=sec.distance, nfev=sec.counters["nfev"],
                   rtol=sec.rtol, stopped=sec.stopped)
    out["seconds"] = time.perf_counter() - t0
    return out


# ------------------------------------------------------------------------------ dataset

def _empty_dataset(axes, J, joints, keep, revolutions, max_period, attrs):
    import xarray as xr

    shape = tuple(len(a.values) for a in axes)
    dims = tuple(a.name for a in axes)
    coords = {a.name: (a.name, np.array(a.values), {"spacing": a.spacing}) for a in axes}
    coords.update(joint=("joint", np.array(joints)),
                  component=("component", np.array(SECTION_COMPONENTS)),
                  revolution=("revolution", np.arange(revolutions - keep + 1,
                                                      revolutions + 1, dtype=np.int32)),
                  lag=("lag", np.arange(1, max_period + 1, dtype=np.int32)))
    nan = np.nan
    regime_attrs = {"flag_values": np.array(sorted(REGIMES), dtype=np.int8),
                    "flag_meanings": " ".join(REGIMES[k] for k in sorted(REGIMES)),
                    "long_name": "regime of the motion (poincare.classify)"}
    data = {
        "section": (dims + ("revolution", "joint", "component"),
                    np.full(shape + (keep, J, 4), nan),
                    {"long_name": "Poincare section: journal minus bearing centre (x, y, m) "
                                  "and its rate (m/s)"}),
        "peak": (dims + ("revolution",), np.full(shape + (keep,), nan),
                 {"long_name": "monitored force's maximum per section interval", "units": "N"}),
        "peak_mean": (dims, np.full(shape, nan), {"units": "N"}),
        "peak_max": (dims, np.full(shape, nan), {"units": "N"}),
        "regime": (dims, np.zeros(shape, dtype=np.int8), regime_attrs),
        "period": (dims, np.zeros(shape, dtype=np.int16),
                   {"long_name": "period in revolutions (0: not periodic)"}),
        "lyapunov": (dims, np.full(shape, nan),
                     {"long_name": "largest Lyapunov exponent per revolution (NaN: not "
                                   "computed)"}),
        "lyapunov_uncertainty": (dims, np.full(shape, nan),
                                 {"long_name": "half-width of the exponent's interval per "
                                               "revolution (lyapunov.exponent_interval)"}),
        "lyapunov_per_second": (dims, np.full(shape, nan), {"units": "1/s"}),
        "recurrence": (dims + ("lag",), np.full(shape + (max_period,), nan),
                       {"long_name": "max |X_{i+k} - X_i| of the scaled section samples"}),
        "joint_clearance": (dims + ("joint",), np.full(shape + (J,), nan),
                            {"long_name": "radial clearance of each joint at the point",
                             "units": "m"}),
        "nfev": (dims, np.zeros(shape, dtype=np.int32),
                 {"long_name": "right-hand side evaluations of the point's run"}),
        "rtol": (dims, np.full(shape, nan),
                 {"long_name": "relative tolerance of the run that gave the section (below "
                               "the map's when its classification was re-checked: "
                               "poincare.RESOLVE_BAND)"}),
        "stopped": (dims, np.zeros(shape, dtype=np.int16),
                    {"long_name": "revolutions run before an early stop on a confirmed "
                                  "periodic orbit (0: all; poincare.py)"}),
        "done": (dims, np.zeros(shape, dtype=np.int8),
                 {"long_name": "1: computed (ok or failed), 0: to do"}),
        "failed": (dims, np.zeros(shape, dtype=np.int8),
                   {"long_name": "1: the point's run failed (regime 'failed')"}),
        "tangent_failed": (dims, np.zeros(shape, dtype=np.int8),
                           {"long_name": "1: the tangent run failed, the section is the "
                                         "plain run's and the exponent NaN"}),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _store(ds, shape, res, omega_of) -> None:
    """Write one point's result into the dataset (in place)."""
    idx = np.unravel_index(res["index"], shape)
    ds["section"].values[idx] = res["section"]
    ds["peak"].values[idx] = res["peak"]
    ok = res["status"] == 1
    ds["peak_mean"].values[idx] = np.mean(res["peak"]) if ok else np.nan
    ds["peak_max"].values[idx] = np.max(res["peak"]) if ok else np.nan
    ds["regime"].values[idx] = res["regime"]
    ds["period"].values[idx] = res["period"]
    ds["lyapunov"].values[idx] = res["lyapunov"]
    ds["lyapunov_uncertainty"].values[idx] = res["lyapunov_uncertainty"]
    ds["lyapunov_per_second"].values[idx] = res["lyapunov"] * omega_of(res["index"]) / (
        2.0 * math.pi)
    ds["recurrence"].values[idx] = res["distance"]
    ds["nfev"].values[idx] = min(res["nfev"], 2**31 - 1)
    ds["rtol"].values[idx] = res["rtol"]
    ds["stopped"].values[idx] = res["stopped"]
    ds["done"].values[idx] = 1
    ds["failed"].values[idx] = 0 if ok else 1
    ds["tangent_failed"].values[idx] = res["tangent_failed"]


def _write(ds, path: Path) -> None:
    """The whole dataset to `path` (netCDF, scipy engine), through a temporary file of this
    process renamed over it, so that the file on disk is always a complete dataset (a
    failed write, e.g. a full disk, removes its temporary file and leaves the last one)."""
    tmp = path.with_name(f".{path.name}.partial-{os.getpid()}")
    try:
        ds.to_netcdf(tmp, engine="scipy")
        os.replace(tmp, path)
    except OSError as exc:
        if exc.filename is None and exc.strerror:     # a failed write: name the map
            raise OSError(exc.errno, exc.strerror, str(path)) from exc
        raise
    finally:
        if tmp.exists():
            tmp.unlink()


def load_map(path: str | Path):
    """The regime map (xarray.Dataset) in the netCDF file `path`, loaded into memory;
    ValueError naming the file if it cannot be read or is not a map of this program."""
    import xarray as xr

    path = Path(path)
    try:
        with xr.open_dataset(path, engine="scipy", mask_and_scale=False, mmap=False) as ds:
            ds = ds.load()
    except FileNotFoundError:
        raise ValueError(f"regime map {str(path)!r} does not exist") from None
    except MemoryError:
        raise
    except Exception as exc:  # noqa: BLE001 - a damaged file fails anywhere in the reader
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        # the reader names the file by its absolute path: name it as the user did
        reason = reason.replace(str(path.resolve()), str(path))
        raise ValueError(f"cannot read the regime map {str(path)!r}: it is not a complete "
                         f"netCDF file ({reason})") from None
    if not str(ds.attrs.get("format", "")).startswith("mbs-clearance regime map"):
        raise ValueError(f"{str(path)!r} is a netCDF file but not a regime map of "
                         "mbs-clearance (no 'format' attribute naming one)")
    return ds


@dataclass
class MapResult:
    """A regime map: the dataset (xarray.Dataset), where it was written, and counts of the
    points computed in this call and skipped (done before)."""

    dataset: object
    path: Path | None
    computed: int
    skipped: int
    seconds: float

    def summary(self) -> str:
        ds = self.dataset
        codes, counts = np.unique(ds["regime"].values, return_counts=True)
        parts = ", ".join(f"{REGIMES[int(c)]}: {n}" for c, n in zip(codes, counts))
        text = (f"{int(ds['done'].sum())} of {ds['done'].size} points done ({self.computed} "
                f"computed now, {self.skipped} before); regimes: {parts}")
        peak = ds["peak_max"].values
        if np.isfinite(peak).any():
            output = ds["peak"].attrs.get("output", "the monitored force")
            text += (f"\npeak of {output} over the kept revolutions: "
                     f"{number(float(np.nanmin(peak)), 6)} N to "
                     f"{number(float(np.nanmax(peak)), 6)} N over the points")
        return text


def _check_driven(mech) -> None:
    """ValueError for a free linkage (drive=None): a regime is a property of the
    stroboscopic map of the drive period (a section once per revolution, its recurrence, a
    periodic orbit of that map); a free linkage has no period to sample at, and without a
    drive feeding energy in its motion decays instead of settling on an attractor."""
    from ..model.cases import as_linkage

    linkage = as_linkage(mech)
    if linkage.drive is None:
        raise ValueError(
            f"linkage {linkage.name!r} is free (drive=None): a regime map classifies the "
            "Poincare section taken once per drive period (its recurrence, a periodic orbit "
            "of that map), which a free linkage has not, and without a drive its motion "
            "decays rather than settling on an attractor; study its peaks per time window "
            "instead (simulate(..., duration=, window=), the studies with window=)")


def regime_map(mech, sweep, revolutions: int = 100, keep: int = 50, scheduler=None, *,
               case: str | None = None, overrides: dict | None = None,
               out: str | Path | None = None, lyapunov: bool = False,
               angle: float | None = None, tol: float = RECURRENCE_TOL,
               max_period: int = MAX_PERIOD, rtol: float | None = None, workers: int = 2,
               chunk_size: int | None = None, progress: bool = False,
               retries: int = 2, write_interval: float = 5.0,
               max_memory: int | None = None, early_stop: bool = True) -> MapResult:
    """A regime map / bifurcation diagram of `mech` over one or two swept fields. A free
    linkage (no drive) is refused: a regime is a property of the section taken once per
    drive period (`_check_driven`).

    Parameters
    ----------
    mech : SliderCrank or Linkage
        The base design (ignored when `case` is given).
    sweep : str, SweepAxis or (name, values), or a list of one or two of them
        The swept fields (`parse_sweep`); the first is the dataset's first dimension.
    revolutions : int
        Crank revolutions per point.
    keep : int
        How many of the last revolutions give section samples (keep >= 2 max_period + 1).
    scheduler : optional
        None (a local pool of `workers` threads), "serial", "threads", "processes", a
        dask scheduler address "tcp://host:port", or a dask.distributed Client.
    case : str, optional
        A named case (`cases.CASES`), instead of `mech`.
    overrides : dict, optional
        The named case's fixed overrides.
    out : path, optional
        netCDF file written as results arrive (at most every `write_interval` seconds, and
        at the end, also after an error or Ctrl-C); an existing one made with the same
        settings is resumed (its done points are skipped), one with other settings is
        refused.
    lyapunov : bool
        Also compute each point's largest Lyapunov exponent (a tangent run instead of the
        plain one; the regimes then tell quasi-periodic from chaotic).
    angle : float, optional
        As in `poincare.poincare_section`.
    tol : float, default 1e-3
        As in `poincare.poincare_section`.
    max_period : int, default 8
        As in `poincare.poincare_section`.
    rtol : float, optional
        As in `poincare.poincare_section`.
    chunk_size : int, optional
        Points per task (default: about 8 tasks per worker).
    retries : int
        Resubmissions of a dask task that raised (a lost worker's tasks are rescheduled by
        the scheduler).
    write_interval : float
        Seconds between writes of `out` while results arrive (0: after every chunk); a run
        killed without warning loses at most the points of this interval.
    early_stop : bool
        Stop a point's run once its section repeats and one Newton step confirms a
        stable periodic orbit there (`poincare.poincare_section`); its remaining
        revolutions repeat its last period. Not with `lyapunov` (its exponent averages the
        kept revolutions).
    max_memory : int, optional
        Limit in bytes of the map's estimated memory (default
        `_checks.default_max_memory`): the dataset and the designs of every point, and each
        running point's per-revolution arrays (`map_memory`). A map above it is refused
        with `MemoryLimitError` (a ValueError) before any design is built.

    Returns
    -------
    MapResult
        The labelled dataset (dims: the swept fields, revolution, joint, component, lag;
        variables section, peak, peak_mean, peak_max, regime, period, lyapunov,
        lyapunov_per_second, recurrence, joint_clearance, nfev, stopped, done, failed,
        tangent_failed).
    """
    from .executor import connect_dask, evaluate

    sweeps = sweep if isinstance(sweep, list) else [sweep]
    axes = [parse_sweep(s) for s in sweeps]
    if not 1 <= len(axes) <= 2:
        raise ValueError(f"sweep must name one or two fields; got {len(axes)}")
    if len(axes) == 2 and axes[0].name == axes[1].name:
        raise ValueError(f"sweep: the field {axes[0].name!r} is given twice")
    revolutions = check_int("revolutions", revolutions, 2)
    keep = check_int("keep (revolutions kept after the transient)", keep, 1, revolutions)
    max_period = check_int("max_period", max_period, 1)
    if keep < 2 * max_period + 1:
        raise ValueError(f"keep must be >= 2 max_period + 1 = {2 * max_period + 1} (max_period="
                         f"{max_period}); got keep={keep}: raise keep or lower max_period")
    tol = check_real("tol (recurrence tolerance)", tol, 0.0, low_open=True)
    lyapunov = check_bool("lyapunov", lyapunov)
    early_stop = check_bool("early_stop", early_stop) and not lyapunov
    if angle is not None:
        angle = check_real("angle (section crank angle)", angle, unit="rad")
    if rtol is not None:
        rtol = check_real("rtol", rtol, 1e-14, 1e-4)
    write_interval = check_real("write_interval", write_interval, 0.0, unit="s")
    shape = tuple(len(a.values) for a in axes)
    # the size first (the designs of a huge grid alone would not fit), from the base design
    base0 = mech if case is None else design_at(None, {}, case, overrides)
    _check_driven(base0)
    joints = len(joints_of(base0))
    local_pool = scheduler is None or (isinstance(scheduler, str)
                                       and scheduler in ("threads", "processes"))
    concurrent = workers if isinstance(workers, int) and workers > 0 and local_pool else 1
    map_memory(shape, revolutions, keep, max_period, joints, concurrent, max_memory)
    # every design next: a bad field or value fails before any run
    designs = []
    for flat in range(int(np.prod(shape))):
        idx = np.unravel_index(flat, shape)
        values = {a.name: a.values[i] for a, i in zip(axes, idx)}
        designs.append(design_at(mech, values, case, overrides))
    base = designs[0]
    J = len(joints_of(base))
    settings = dict(revolutions=revolutions, keep=keep, angle=angle, tol=tol,
                    max_period=max_period, lyapunov=lyapunov, rtol=rtol,
                    early_stop=early_stop)
    description = base.to_dict()
    attrs = {"format": FORMAT, "case": case or "",
             "mechanism": type(base).__name__,
             "base_design": json.dumps(_jsonable(description), sort_keys=True),
             "overrides": json.dumps(_jsonable(overrides or {}), sort_keys=True),
             "settings": json.dumps({k: (v if v is not None else "default")
                                     for k, v in settings.items()}, sort_keys=True),
             "sweep": json.dumps([[a.name, a.spacing] for a in axes]),
             "regime_criterion": "poincare.classify: recurrence within tol (of the "
                                 "clearance) over the kept samples, then the exponent's sign"}
    ds = _empty_dataset(axes, J, joints_of(base), keep, revolutions, max_period, attrs)
    # the peaks are the description's default output's (`Linkage.default_output`)
    ds["peak"].attrs["output"] = base.default_output
    ds["joint_clearance"].values[...] = np.array(
        [clearances_of(d) for d in designs]).reshape(shape + (J,))
    path = None if out is None else Path(out)
    if path is not None:
        recover(path)           # the temporary files of runs that were killed
    if path is not None and path.exists():
        old = load_map(path)
        _check_resumable(old, ds, path)
        ds = old
    todo = [i for i in range(len(designs)) if ds["done"].values.reshape(-1)[i] == 0]
    skipped = len(designs) - len(todo)
    omegas = [drive_of(d)[0] for d in designs]
    executor, own = scheduler, None
    if isinstance(scheduler, str) and scheduler.startswith(("tcp://", "tls://", "ws://")):
        executor = own = connect_dask(scheduler)    # before any file: it may be unreachable
    if path is not None:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            _write(ds, path)
        except BaseException:
            if own is not None:
                own.close()
            raise

    last_write = [time.monotonic()]
    pending = [0]

    def on_result(start, results):
        for res in results:
            _store(ds, shape, res, omegas.__getitem__)
        pending[0] += len(results)
        if path is not None and time.monotonic() - last_write[0] >= write_interval:
            _write(ds, path)
            last_write[0] = time.monotonic()
            pending[0] = 0

    t0 = time.perf_counter()
    try:
        evaluate(_map_point, [(i, designs[i]) for i in todo], (settings,), executor=executor,
                 workers=workers, progress=progress, desc="map points",
                 chunk_size=chunk_size, on_result=on_result, retries=retries)
    finally:
        if own is not None:
            own.close()
        if path is not None and pending[0]:
            _write(ds, path)        # what arrived since the last write (also on Ctrl-C)
    return MapResult(ds, path, len(todo), skipped, time.perf_counter() - t0)


#: bytes a worker thread of a local pool reserves (its stack, the platform's default)
THREAD_BYTES = 8 * 1024**2


def map_memory(shape: tuple[int, ...], revolutions: int, keep: int, max_period: int,
               joints: int, concurrent: int = 1, max_memory: int | None = None) -> int:
    """Estimated peak memory (bytes) of a regime map over a grid of `shape` with `joints`
    clearance joints: its dataset (held twice while written), the designs and bookkeeping
    of every point, and the per-revolution arrays of `concurrent` running points;
    `MemoryLimitError` naming the options if either part exceeds `max_memory`."""
    points = math.prod(shape)
    run = revolution_bytes(revolutions) + 8 * 4 * keep * joints
    # a local pool runs at most one point per worker and never more workers than points;
    # each worker thread reserves its stack
    running = min(concurrent, points)
    check_memory(f"revolutions={revolutions}: each point's run needs", run,
                 max_memory, "run fewer revolutions")
    if running > 1:
        check_memory(f"workers={concurrent} ({running} points running at once, revolutions="
                     f"{revolutions} each): they need", running * (run + THREAD_BYTES),
                     max_memory, "use fewer workers or run fewer revolutions")
    concurrent = running
    floats = 4 * keep * joints + keep + max_period + joints + 8
    need = points * (2 * 8 * floats + DESIGN_BYTES + 256) + concurrent * run
    grid = " x ".join(str(n) for n in shape)
    check_memory(f"a map of {grid} = {points} points with keep={keep} needs", need,
                 max_memory, "sweep fewer points or keep fewer revolutions")
    return need


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj


def _check_resumable(old, new, path: Path) -> None:
    """ValueError unless `old` (the file at `path`) is a map with `new`'s settings and
    coordinates."""
    for key in ("format", "case", "mechanism", "base_design", "overrides", "settings",
                "sweep"):
        if str(old.attrs.get(key)) != str(new.attrs.get(key)):
            raise ValueError(f"{path} holds a different regime map ({key} differs); resume "
                             "with the same settings, or write to another file")
    for name in new.coords:
        if name not in old.coords or not np.array_equal(old[name].values, new[name].values):
            raise ValueError(f"{path} holds a different regime map (coordinate {name!r} "
                             "differs); resume with the same sweep, or write to another file")
