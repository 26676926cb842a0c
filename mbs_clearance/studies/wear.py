"""The wear life of a clearance joint: Archard wear (`laws.wear.archard`) coupled with the
dynamics over many cycles (`wear_life` -> `WearResult`).

A cycle is one drive revolution. The evolution alternates the dynamics and the wear:

1. on the current (frozen) bearing profile, run `settle` revolutions so that the motion
   forgets its start, then `record` more; the wear of the recorded revolutions, per cycle,
   is the wear rate dh/dN at each grid angle (with the peak of the monitored output, the
   drive moment's RMS and whether the motion is periodic);
2. extrapolate that rate over an interval of dN cycles, update the profile, repeat.

The interval is chosen by step doubling: one step of dN (profile R1) against two of dN / 2
(R2, the second from the rate at the half-way profile). Their largest difference estimates
the error of R2; the step is accepted when it is within ``tolerance * c0`` (c0 the joint's
initial radial clearance) and the next interval scaled by ``0.9 sqrt(tol / error)`` (the
local error of the one-rate step grows as dN^2). The profile kept is the extrapolation
2 R2 - R1 = R + dN * rate(R + dN/2 * rate(R)), the midpoint rule (second order), so the
estimate is conservative (measured on a closed form, tests/unit/test_wear_law.py: the true
error 0.06-0.2 of it). Each accepted interval costs two evaluations of the dynamics. The
sum of the accepted estimates is the result's `error_estimate` (m).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .._checks import check_int, check_real
from .._warnings import AccuracyWarning, PhysicsWarning
from ..laws.wear.archard import wear_increment
from ..model.linkage import Linkage
from ..model.profile import BearingProfile

__all__ = ["CycleWear", "WearResult", "WearLife", "WearOptimum", "wear_life", "cycle_wear",
           "load_wear", "optimize_wear_life", "DEFAULT_POINTS"]

#: grid angles of the profile when the joint has none yet (1 degree)
DEFAULT_POINTS = 360
#: the longest life (cycles) a run takes
MAX_CYCLES = 1e12
#: the largest wear depth, as a fraction of the bearing radius, at which a life stops: the
#: small-wear approximation (radial normal) stops holding well before the journal could
#: leave a groove this deep
MAX_DEPTH_FRACTION = 0.1


@dataclass(frozen=True)
class CycleWear:
    """The dynamics on one frozen profile, per cycle: wear depth at each grid angle (m), the
    worn volume (m^3), the sliding distance in contact (m), the monitored output's peak over
    the recorded cycles (N), the drive moment's RMS (N m), and whether the motion is
    periodic (None: undetermined)."""

    depth: np.ndarray
    volume: float
    sliding: float
    peak: float
    drive_rms: float
    periodic: bool | None


@dataclass
class WearResult:
    """A wear life: the state after each accepted interval (index 0: the start).

    Attributes
    ----------
    joint : str
        The worn clearance joint.
    coefficient : float
        k/H (m^2/N).
    cycles : (K+1,) cycles done
    profiles : (K+1, N) m, the bearing radii on the grid (`BearingProfile`)
    wear_volume : (K+1,) m^3, worn volume so far
    peaks : (K+1,) N, the monitored output's peak on each profile
    drive_rms : (K+1,) N m, the drive moment's RMS on each profile
    periodic : list of bool or None, the motion's regime on each profile
    intervals : (K,) cycles of each accepted interval
    errors : (K,) m, the step-doubling estimate of each interval's profile error
    tolerance : float
        m, the accepted error per interval.
    evaluations : int
        Dynamics runs made (each `settle + record` revolutions).
    initial_clearance : float
        m, c0 = R_B - R_J of the circular start (the smallest clearance of a given start).
    output : str
        The name of the monitored output whose peaks are recorded.
    """

    joint: str
    coefficient: float
    cycles: np.ndarray
    profiles: np.ndarray
    wear_volume: np.ndarray
    peaks: np.ndarray
    drive_rms: np.ndarray
    periodic: list
    intervals: np.ndarray
    errors: np.ndarray
    tolerance: float
    evaluations: int
    initial_clearance: float
    output: str = "base force"
    stats: dict = field(default_factory=dict)

    @property
    def depth(self) -> np.ndarray:
        """(K+1, N) m, wear depth at each grid angle (profile minus the start)."""
        return self.profiles - self.profiles[0]

    @property
    def max_depth(self) -> np.ndarray:
        """(K+1,) m, the largest wear depth so far."""
        return self.depth.max(axis=1)

    @property
    def angles(self) -> np.ndarray:
        """The profile's grid angles (rad, the bearing body's frame)."""
        return BearingProfile(self.profiles[0]).angles

    @property
    def error_estimate(self) -> float:
        """m, the sum of the accepted intervals' error estimates (how far the final profile
        may move when the intervals are refined)."""
        return float(np.sum(self.errors))

    def _first_crossing(self, series: np.ndarray, level: float) -> float | None:
        above = np.nonzero(series >= level)[0]
        if len(above) == 0:
            return None
        k = int(above[0])
        if k == 0:
            return 0.0
        # linear between the two accepted states that bracket the crossing
        s0, s1 = series[k - 1], series[k]
        n0, n1 = self.cycles[k - 1], self.cycles[k]
        return float(n0 + (level - s0) / (s1 - s0) * (n1 - n0))

    def cycles_to_limit(self, force: float) -> float | None:
        """The cycle at which the monitored output's peak first reaches `force` (N), linear
        between accepted states; None if it does not within the life."""
        return self._first_crossing(self.peaks, force)

    def cycles_to_clearance(self, factor: float = 2.0) -> float | None:
        """The cycle at which the largest clearance reaches `factor` times the initial one
        (the wear depth reaches (factor - 1) c0); None if not within the life."""
        return self._first_crossing(self.max_depth, (factor - 1.0) * self.initial_clearance)

    def to_dict(self) -> dict:
        """The life as plain data (lists of floats; regimes as True/False/None)."""
        from .._io import RUN_KEY, run_stamp

        return {RUN_KEY: run_stamp("wear"), "kind": "wear life",
                "joint": self.joint, "wear_coefficient_m2_per_N": self.coefficient,
                "initial_clearance_m": self.initial_clearance, "output": self.output,
                "tolerance_m": self.tolerance, "error_estimate_m": self.error_estimate,
                "evaluations": self.evaluations, "settings": dict(self.stats),
                "angles_rad": self.angles.tolist(), "cycles": self.cycles.tolist(),
                "profiles_m": self.profiles.tolist(), "wear_volume_m3": self.wear_volume.tolist(),
                "max_depth_m": self.max_depth.tolist(), "peaks_N": self.peaks.tolist(),
                "drive_rms_Nm": self.drive_rms.tolist(), "periodic": list(self.periodic),
                "intervals": self.intervals.tolist(), "errors_m": self.errors.tolist()}

    def save(self, path) -> None:
        """Write `to_dict` as JSON to `path`."""
        import json
        from pathlib import Path

        Path(path).write_text(json.dumps(self.to_dict(), indent=1) + "\n")

    def table(self) -> list[dict]:
        """One row per accepted state: cycles, max depth (um), volume (mm^3), peak (N),
        drive RMS (N m), regime."""
        regime = {True: "periodic", False: "not periodic", None: "undetermined"}
        return [{"cycles": float(n), "max_depth_um": 1e6 * float(d),
                 "volume_mm3": 1e9 * float(v), "peak_N": float(p), "drive_rms_Nm": float(r),
                 "regime": regime[g]}
                for n, d, v, p, r, g in zip(self.cycles, self.max_depth, self.wear_volume,
                                            self.peaks, self.drive_rms, self.periodic)]


def _joint_index(linkage: Linkage, joint: str | None) -> int:
    worn = [k for k, j in enumerate(linkage.clearance_joints) if j.wear_coefficient > 0.0]
    names = [j.name for j in linkage.clearance_joints]
    if joint is None:
        if len(worn) == 1:
            return worn[0]
        if len(linkage.clearance_joints) == 1:
            return 0
        raise ValueError(f"joint must name the worn clearance joint, one of {names}"
                         + ("" if not worn else f" ({len(worn)} have a wear_coefficient)"))
    if joint not in names:
        raise ValueError(f"joint must be one of the clearance joints {names}; got {joint!r}")
    return names.index(joint)


def cycle_wear(linkage: Linkage, joint: int, coefficient: float, *, settle: int = 3,
               record: int = 1, samples: int = 2048, rtol: float = 1e-8,
               backend: str = "reduced") -> CycleWear:
    """Run `settle` + `record` revolutions of `linkage` and return the wear of clearance
    joint number `joint` per recorded cycle (`CycleWear`): the dynamics' contact force,
    penetration, contact angle and slip velocity sampled `samples` times per revolution
    into Archard's law (`wear_increment`)."""
    from ..solve.simulate import simulate

    revs = settle + record
    period = 2.0 * math.pi / abs(linkage.drive.speed)
    # Exudyn's series are its steps' (its default step samples a revolution thousands of
    # times); the reduced model's, `samples` per revolution from its dense output
    options = ({"rtol": rtol, "t_eval": np.linspace(0.0, revs * period, revs * samples + 1)}
               if backend == "reduced" else {})
    tr = simulate(linkage, revs, backend=backend, **options)
    if tr.contact_angle is None or tr.slip_velocity is None:
        raise ValueError(f"the {backend!r} backend does not record the contact angle and "
                         "slip velocity that the wear law needs")
    keep = tr.t >= settle * period * (1.0 - 1e-9)
    cj = linkage.clearance_joints[joint]
    profile = cj.profile or BearingProfile.circular(cj.bearing_radius, DEFAULT_POINTS)
    depth, volume = wear_increment(
        profile, cj.journal_radius, cj.bearing_length, coefficient, tr.t[keep],
        tr.contact_force[keep, joint], tr.penetration[keep, joint],
        tr.contact_angle[keep, joint], tr.slip_velocity[keep, joint])
    contact = np.where(tr.contact_force[keep, joint] > 0.0,
                       np.abs(tr.slip_velocity[keep, joint]), 0.0)
    sliding = float(_trapezoid(contact, tr.t[keep]))
    peaks = np.asarray(tr.peaks, dtype=float)[settle:]
    moment = tr.crank_moment[keep]
    rms = float(np.sqrt(_trapezoid(moment * moment, tr.t[keep]) / (record * period)))
    return CycleWear(depth=depth / record, volume=volume / record, sliding=sliding / record,
                     peak=float(np.max(peaks)), drive_rms=rms,
                     periodic=tr.stats.get("periodic"))


def _trapezoid(y: np.ndarray, t: np.ndarray) -> float:
    """The trapezoidal rule of y over t."""
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(t)))


def wear_life(mech, cycles: float, *, joint: str | None = None,
              wear_coefficient: float | None = None, tolerance: float = 0.01,
              points: int = DEFAULT_POINTS, settle: int = 3, record: int = 1,
              samples: int = 2048, rtol: float = 1e-8, backend: str = "reduced",
              min_interval: float = 1.0, max_interval: float | None = None,
              max_evaluations: int = 1000, stop_at_depth: float | None = None,
              progress: bool = False,
              evaluate: Callable[[Linkage, int, float], CycleWear] | None = None
              ) -> WearResult:
    """The wear life of a clearance joint over `cycles` drive revolutions.

    Parameters
    ----------
    mech : Linkage or SliderCrank
        A driven linkage with at least one clearance joint (a named case, e.g.
        ``cases.CASES["paper_slider_crank_wear"]()``).
    cycles : float
        Length of the life (drive revolutions, > 0).
    joint : str or None
        The worn clearance joint; None: the one with a wear_coefficient (or the only one).
    wear_coefficient : float or None
        k/H (m^2/N); None: the joint's `wear_coefficient` (which must then be > 0).
    tolerance : float
        The profile error accepted per interval, as a fraction of the initial clearance
        (default 0.01: 1 %). Smaller is more accurate and costs more intervals.
    points : int
        Grid angles of the profile when the joint starts circular (default 360).
    settle, record : int
        Revolutions run on each profile before the wear is recorded (default 3: the paper
        case's motion is periodic from the fourth revolution), and recorded (the rate is
        their mean).
    samples : int
        Samples per revolution of the recorded series (the wear integral's resolution).
    rtol : float
        The reduced model's relative tolerance for each run.
    backend : str
        "reduced" (default) or "exudyn".
    min_interval : float
        The shortest interval (cycles); an interval at it is accepted even when its error
        estimate exceeds the tolerance (with an `AccuracyWarning`).
    max_interval : float or None
        The longest interval (cycles); None: a twentieth of the life, so that the peaks and
        the depth are drawn at 20 points at least.
    max_evaluations : int
        Stop after this many dynamics runs (default 1000, a minute or two for the paper
        case): the life so far is returned with ``stats["stopped"]`` saying why and an
        `AccuracyWarning`. A motion that is not periodic wears a scattering amount per cycle,
        which the step doubling reads as an error: record more revolutions there.
    stop_at_depth : float or None
        Stop the life at the first state whose largest wear depth reaches this (m), e.g.
        the initial clearance to find when the clearance has doubled.
    progress : bool
        Show a tqdm bar over the cycles.
    evaluate : callable or None
        ``evaluate(linkage, joint_index, coefficient) -> CycleWear`` in place of the
        dynamics (`cycle_wear` with the settings above); for tests and other models.

    Returns
    -------
    WearResult
    """
    from ..model.cases import as_linkage

    linkage = as_linkage(mech)
    if linkage.drive is None:
        raise ValueError("wear_life needs a driven linkage (a cycle is one drive revolution); "
                         f"{linkage.name!r} is free (no drive)")
    cycles = check_real("cycles", cycles, 0.0, low_open=True)
    if cycles > MAX_CYCLES:
        raise ValueError(f"cycles must be at most {MAX_CYCLES:g} (a machine's life); got "
                         f"{cycles:g}")
    tolerance = check_real("tolerance", tolerance, 0.0, low_open=True)
    points = check_int("points", points, 1)
    settle = check_int("settle", settle, 0)
    record = check_int("record", record, 1)
    samples = check_int("samples", samples, 1)
    min_interval = check_real("min_interval", min_interval, 0.0, low_open=True)
    max_interval = (max(min_interval, cycles / 20.0) if max_interval is None
                    else check_real("max_interval", max_interval, 0.0, low_open=True))
    if max_interval < min_interval:
        raise ValueError(f"max_interval ({max_interval:g}) must be at least min_interval "
                         f"({min_interval:g}) cycles")
    max_evaluations = check_int("max_evaluations", max_evaluations, 1)
    if samples < 64:
        raise ValueError(f"samples must be at least 64 per revolution; got {samples}")
    if points < 8:
        raise ValueError(f"points must be at least 8; got {points}")
    index = _joint_index(linkage, joint)
    cj = linkage.clearance_joints[index]
    k = cj.wear_coefficient if wear_coefficient is None else wear_coefficient
    if not (isinstance(k, (int, float)) and math.isfinite(k) and 0.0 < k <= 1e-9):
        raise ValueError(f"wear_coefficient must be in (0, 1e-09] m^2/N (the joint "
                         f"{cj.name!r} has {cj.wear_coefficient!r}); got {k!r}")
    if cj.has_lubrication:
        raise ValueError(f"clearance joint {cj.name!r} is lubricated: the wear law takes a "
                         "dry joint (lubrication 'none')")
    radii0 = (np.asarray(cj.bearing_profile, float) if cj.bearing_profile is not None
              else np.full(points, cj.bearing_radius))
    c0 = float(np.min(radii0)) - cj.journal_radius
    tol = tolerance * c0
    if evaluate is None:
        def evaluate(lk, j, coefficient):
            return cycle_wear(lk, j, coefficient, settle=settle, record=record,
                              samples=samples, rtol=rtol, backend=backend)

    def with_profile(radii):
        worn = dataclasses.replace(cj, bearing_profile=tuple(float(r) for r in radii))
        joints = list(linkage.clearance_joints)
        joints[index] = worn
        return linkage.replace(clearance_joints=tuple(joints))

    count = 0
    flagged = 0          # runs whose own accuracy check warned (e.g. a rattling contact)
    stopped = None

    class _Budget(Exception):
        pass

    def run(radii) -> CycleWear:
        nonlocal count, flagged
        if count >= max_evaluations:
            raise _Budget
        count += 1
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            out = evaluate(with_profile(radii), index, k)
        flagged += any(issubclass(w.category, AccuracyWarning) for w in caught)
        return out

    done = 0.0
    radii = radii0.copy()
    rate = run(radii)
    states = [(0.0, radii.copy(), 0.0, rate)]
    intervals, errors = [], []
    top = float(np.max(rate.depth))
    # the first guess: the interval that wears 10 tolerances at the deepest point
    dn = cycles if top <= 0.0 else min(cycles, max(min_interval, 10.0 * tol / top))
    volume = 0.0
    bar = None
    if progress:
        from tqdm.auto import tqdm
        bar = tqdm(total=float(cycles), desc=f"wear of {cj.name}", unit="cycle")
    try:
        while done < cycles * (1.0 - 1e-12):
            dn = min(dn, max_interval, cycles - done)
            full = radii + dn * rate.depth
            half_radii = radii + 0.5 * dn * rate.depth
            half = run(half_radii)
            two = half_radii + 0.5 * dn * half.depth
            err = float(np.max(np.abs(two - full)))
            if err > tol and dn > min_interval:
                dn = max(min_interval, dn * max(0.2, 0.9 * math.sqrt(tol / err)))
                continue
            if err > tol:
                warnings.warn(f"wear_life: the interval at cycle {done:.6g} is at min_interval "
                              f"({min_interval:g}) and its error estimate {err:.3g} m exceeds "
                              f"the tolerance {tol:.3g} m", AccuracyWarning, stacklevel=2)
            volume += dn * half.volume
            done += dn
            radii = 2.0 * two - full      # local extrapolation: the midpoint rule
            intervals.append(dn)
            errors.append(err)
            if bar is not None:
                bar.update(dn)
            rate = run(radii)
            states.append((done, radii.copy(), volume, rate))
            deepest = float(np.max(radii - radii0))
            if stop_at_depth is not None and deepest >= stop_at_depth:
                stopped = (f"stopped at cycle {done:.6g}: the wear depth {deepest:.3g} m "
                           f"reached stop_at_depth ({stop_at_depth:.3g} m)")
                break
            if deepest > MAX_DEPTH_FRACTION * cj.bearing_radius:
                stopped = (f"stopped at cycle {done:.6g}: the wear depth {deepest:.3g} m "
                           f"exceeds {MAX_DEPTH_FRACTION:g} of the bearing radius, where the "
                           "small-wear approximation no longer holds")
                warnings.warn(f"wear_life: {stopped}", PhysicsWarning, stacklevel=2)
                break
            dn = dn * min(2.0, max(0.3, 0.9 * math.sqrt(tol / max(err, 1e-300))))
    except _Budget:
        stopped = (f"stopped at cycle {done:.6g} of {cycles:.6g}: max_evaluations "
                   f"({max_evaluations}) reached (intervals of {dn:.3g} cycles at the end; "
                   f"{flagged} runs flagged by their own accuracy check)")
        warnings.warn(f"wear_life: {stopped}", AccuracyWarning, stacklevel=2)
    finally:
        if bar is not None:
            bar.close()
    return WearResult(
        joint=cj.name, coefficient=float(k),
        cycles=np.array([s[0] for s in states]),
        profiles=np.array([s[1] for s in states]),
        wear_volume=np.array([s[2] for s in states]),
        peaks=np.array([s[3].peak for s in states]),
        drive_rms=np.array([s[3].drive_rms for s in states]),
        periodic=[s[3].periodic for s in states],
        intervals=np.array(intervals), errors=np.array(errors), tolerance=tol,
        evaluations=count, initial_clearance=c0,
        output=f"{linkage.monitor_joint or 'shaking'} force",
        stats={"settle": settle, "record": record, "samples": samples, "rtol": rtol,
               "backend": backend, "stopped": stopped, "flagged_runs": flagged})


def load_wear(path) -> WearResult:
    """Read a wear life written by `WearResult.save` (JSON data; ValueError naming the file
    and the key when it is not one)."""
    import json
    from pathlib import Path

    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"wear life file {str(path)!r}: not readable JSON ({exc})") from None
    if not isinstance(data, dict) or data.get("kind") != "wear life":
        raise ValueError(f"wear life file {str(path)!r}: not a wear life written by "
                         "mbs-clearance (no 'kind': 'wear life')")
    try:
        arrays = {k: np.asarray(data[k], dtype=float) for k in (
            "cycles", "profiles_m", "wear_volume_m3", "peaks_N", "drive_rms_Nm", "intervals",
            "errors_m")}
        res = WearResult(
            joint=str(data["joint"]), coefficient=float(data["wear_coefficient_m2_per_N"]),
            cycles=arrays["cycles"], profiles=arrays["profiles_m"],
            wear_volume=arrays["wear_volume_m3"], peaks=arrays["peaks_N"],
            drive_rms=arrays["drive_rms_Nm"],
            periodic=[None if g is None else bool(g) for g in data["periodic"]],
            intervals=arrays["intervals"], errors=arrays["errors_m"],
            tolerance=float(data["tolerance_m"]), evaluations=int(data["evaluations"]),
            initial_clearance=float(data["initial_clearance_m"]), output=str(data["output"]),
            stats=dict(data.get("settings", {})))
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"wear life file {str(path)!r}: bad or missing key ({exc})") from None
    n = len(res.cycles)
    if res.profiles.ndim != 2 or res.profiles.shape[0] != n or len(res.peaks) != n:
        raise ValueError(f"wear life file {str(path)!r}: its series have different lengths")
    return res


@dataclass(frozen=True)
class WearLife:
    """The wear life of a named case's design as a study's output: ``WearLife(...)(values)``
    builds ``CASES[case](**overrides, **values)`` and returns the cycles until its largest
    clearance reaches `factor` times the initial one, within a life of `cycles` (a design
    that does not get there returns `cycles`: a lower bound, counted by `censored`).

    Pass it as a tolerance study's ``output`` (`tolerance.tolerance_study(inputs,
    output=WearLife(...))`; the inputs are the case's override names, e.g.
    ``wear_coefficient``, ``crank_speed``, ``journal_radius``). It is plain data, so process
    pools and dask workers take it."""

    case: str = "paper_slider_crank_wear"
    overrides: tuple = ()
    cycles: float = 1e7
    factor: float = 2.0
    tolerance: float = 0.02

    def design(self, values: dict) -> Linkage:
        """The case's linkage at `values` (its override names)."""
        from ..model.cases import CASES

        if self.case not in CASES:
            raise ValueError(f"case must be one of {sorted(CASES)}; got {self.case!r}")
        return CASES[self.case](**dict(self.overrides), **values)

    def __call__(self, values: dict) -> float:
        design = self.design(values)
        c0 = min(j.clearance for j in design.clearance_joints if j.wear_coefficient > 0.0)
        res = wear_life(design, self.cycles, tolerance=self.tolerance,
                        stop_at_depth=(self.factor - 1.0) * c0)
        hit = res.cycles_to_clearance(self.factor)
        return float(self.cycles if hit is None else hit)

    def censored(self, y) -> int:
        """How many outputs `y` are the life's length (the clearance did not reach the
        factor): their true life is longer."""
        return int(np.sum(np.asarray(y, dtype=float) >= self.cycles))


@dataclass
class WearOptimum:
    """The longest-lived design a GA found (`optimize_wear_life`): the genes' values, their
    life (cycles until the clearance reaches `factor` times the initial one; the life's
    length when not reached, a lower bound), the best life per generation and the number
    of wear lives run."""

    best: dict
    life: float
    censored: bool
    history: list
    evaluations: int
    settings: dict


def optimize_wear_life(genes: dict, *, case: str = "paper_slider_crank_wear",
                       overrides: dict | None = None, cycles: float = 1e7,
                       factor: float = 2.0, tolerance: float = 0.02, population: int = 8,
                       generations: int = 5, seed: int = 0, progress: bool = False
                       ) -> WearOptimum:
    """A genetic algorithm (pygad, the operators of `optimize.optimize_link_lengths`) that
    maximises the wear life of a named case's design: ``genes`` {override name: (low,
    high)} in SI (e.g. ``{"bearing_length": (0.005, 0.02), "crank_speed": (300, 600)}``),
    each design's life a `WearLife` (`cycles`, `factor`, `tolerance`). Runs population x
    (generations + 1) wear lives at most, in this process. Bad input raises ValueError
    before any run."""
    import pygad

    from ..model.cases import CASES
    from .optimize import _GA_OPERATORS, _pygad_logger

    if case not in CASES:
        raise ValueError(f"case must be one of {sorted(CASES)}; got {case!r}")
    if not isinstance(genes, dict) or not genes:
        raise ValueError("genes must be a non-empty {name: (low, high)} of the case's "
                         "overrides")
    for name, bounds in genes.items():
        ok = (isinstance(bounds, (tuple, list)) and len(bounds) == 2
              and all(isinstance(v, (int, float)) and math.isfinite(v) for v in bounds)
              and bounds[0] < bounds[1])
        if not ok:
            raise ValueError(f"genes[{name!r}] must be (low, high) with low < high; got "
                             f"{bounds!r}")
    population = check_int("population", population, 4)
    generations = check_int("generations", generations, 1)
    names = tuple(genes)
    lo = np.array([genes[n][0] for n in names], dtype=float)
    hi = np.array([genes[n][1] for n in names], dtype=float)
    life = WearLife(case=case, overrides=tuple((overrides or {}).items()), cycles=cycles,
                    factor=factor, tolerance=tolerance)
    life.design({n: float(v) for n, v in zip(names, lo)})      # the names, checked now
    seen: dict[tuple, float] = {}

    def fitness(ga, solution, index):
        key = tuple(float(v) for v in lo + np.asarray(solution) * (hi - lo))
        if key not in seen:
            seen[key] = life(dict(zip(names, key)))
        return seen[key]

    history: list[float] = []
    ga = pygad.GA(num_generations=generations, fitness_func=fitness, sol_per_pop=population,
                  num_genes=len(names), gene_type=float, init_range_low=0.0,
                  init_range_high=1.0, gene_space=[{"low": 0.0, "high": 1.0}] * len(names),
                  random_seed=seed, logger=_pygad_logger(),
                  on_generation=lambda g: history.append(float(np.max(g.last_generation_fitness))),
                  num_parents_mating=max(2, population // 2),
                  keep_elitism=max(1, population // 10),
                  mutation_probability=1.0 / len(names), **_GA_OPERATORS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        ga.run()
    key = max(seen, key=seen.get)
    return WearOptimum(best=dict(zip(names, key)), life=seen[key],
                       censored=seen[key] >= cycles, history=history, evaluations=len(seen),
                       settings={"case": case, "overrides": dict(overrides or {}),
                                 "cycles": cycles, "factor": factor, "tolerance": tolerance,
                                 "population": population, "generations": generations,
                                 "seed": seed})
