"""`Trajectory`: the one result type of every backend, with derived outputs and save/load."""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._checks import check_int
from .._warnings import PhysicsWarning
from ..model.mechanism import SliderCrank

__all__ = ["Trajectory", "load_trajectory", "annotate", "periodicity", "PENETRATION_LIMIT",
           "PERIODIC_TOL", "PAPER_SERIES"]

#: largest physically meaningful penetration, as a fraction of the journal radius. The
#: contact laws (K delta^1.5, Hertz-type) assume a contact zone small against the radii; a
#: journal that sinks by 5 % of its own radius into the bearing overlaps it grossly and the
#: result is meaningless. Measured maxima (all revolutions, docs/user_guide.md): the paper
#: case 9e-4 R_J (0.89 c), every case of validation/stress.py at most 0.013 R_J (c = 1 mm;
#: 11.6 c with the stiffness divided by 100), 1e5 rpm 0.027 R_J; 3e5 rpm 0.10 R_J and
#: omega2 = 1e6 rad/s 7.6 R_J (7567 c) are flagged. Not a fraction of the clearance: a
#: 1 um clearance legitimately sees 3 c.
PENETRATION_LIMIT = 0.05

#: the state at the revolution boundaries repeats within this distance (units: clearance
#: for the eccentricity, omega2 * clearance for the velocities) for the motion to count as
#: periodic; at the default rtol the paper case's return distance falls by about 5 times
#: per revolution, to 3e-3 at revolution 4 and 1e-9 at revolution 12, while c = 0.1 mm,
#: c = 0.5 mm and 100 rpm stay at 1 to 80 (docs/user_guide.md)
PERIODIC_TOL = 1e-2

#: periods (in revolutions) the return map checks
MAX_PERIOD = 4

#: above this tolerance (clearance units) the integration noise hides the return map: the
#: periodicity is then undetermined (rtol above about 3e-6 in the paper case)
NOISE_LIMIT = 0.5

#: the paper slider-crank's coordinates by their description's names
#: (`cases.from_slider_crank`): the coupler's angle, the slider's position s along its guide
COUPLER_ANGLE = "coupler.angle"
SLIDER_S = "slider_guide.s"

#: the paper's names of the slider-crank's series -> (unit, the generic series, coordinate):
#: the one table the read-only `Trajectory` properties (slider_position, ...) and the
#: columns of a saved SliderCrank trajectory are read from; any linkage whose description
#: has these coordinates has these series
PAPER_SERIES: dict[str, tuple[str, str, str]] = {
    "coupler_angle": ("rad", "coordinates", COUPLER_ANGLE),
    "coupler_rate": ("rad/s", "rates", COUPLER_ANGLE),
    "slider_position": ("m", "coordinates", SLIDER_S),
    "slider_velocity": ("m/s", "rates", SLIDER_S),
    "slider_acceleration": ("m/s^2", "accelerations", SLIDER_S),
}

#: name -> (unit, number of columns); the columns of a saved SliderCrank trajectory (the
#: paper's series among them, `PAPER_SERIES`)
SERIES: dict[str, tuple[str, int]] = {
    "t": ("s", 1),
    "base_force": ("N", 2),
    "crank_moment": ("N m", 1),
    "contact_force": ("N", 1),
    "penetration": ("m", 1),
    "eccentricity": ("m", 2),
    "slider_position": ("m", 1),
    "slider_velocity": ("m/s", 1),
    "slider_acceleration": ("m/s^2", 1),
    "coupler_angle": ("rad", 1),
    "coupler_rate": ("rad/s", 1),
    "contact_phase": ("-", 1),
    "crank_work": ("J", 1),
}


def _paper_property(name: str) -> property:
    """The read-only `Trajectory` property of the paper's name `name` (`PAPER_SERIES`)."""
    unit, kind, coordinate = PAPER_SERIES[name]
    return property(lambda self: self._by_paper_name(name),
                    doc=f"(n,) {unit}, ``{kind}[{coordinate!r}]`` (`PAPER_SERIES`); "
                        "AttributeError where the description has no such coordinate.")


@dataclass(frozen=True)
class Trajectory:
    """Time series of one simulation of a `SliderCrank` or a `Linkage`.

    For a `Linkage` (``traj.linkage`` is not None) the per-joint series have a joint axis
    in the order of ``joints`` (the clearance joints): contact_force, penetration and
    contact_phase (n, J), eccentricity (n, J, 2); base_force is the monitored ground joint's
    reaction (the shaking force when the description monitors none), crank_moment the drive
    moment, crank_work the drive's work; ``reactions`` holds every ground joint's force on
    the ground by joint name, ``shaking_force`` their sum, ``coordinates``, ``rates`` and
    ``accelerations`` the minimal coordinates by name.

    A `SliderCrank`'s run (the paper's parameter set of one linkage) has the per-joint
    series of its one clearance joint as (n,) arrays and the same generic series as its
    description's: ``joints`` ("coupler_slider",), ``coordinates`` ("coupler.angle",
    "slider_guide.s"), ``rates``, ``accelerations`` and, from the reduced model and Exudyn,
    ``reactions`` ("crank_pivot" is base_force, F12; "slider_guide") and ``shaking_force``.

    The paper's names of the slider-crank's series are read-only properties looked up in
    the generic series (`PAPER_SERIES`), on any trajectory whose description has the
    coordinates "slider_guide.s" (slider_position, slider_velocity, slider_acceleration)
    and "coupler.angle" (coupler_angle, coupler_rate); elsewhere they raise AttributeError
    naming the linkage and its coordinates. A saved SliderCrank trajectory keeps them as
    columns of the file.

    Attributes
    ----------
    t : (n,) s
    base_force : (n, 2) N, force exerted on the ground by the crank at the pivot (F12)
    crank_moment : (n,) N m, driving moment that keeps the crank speed constant (Eq. 8)
    contact_force : (n,) N, normal force in the clearance joint
    penetration : (n,) m, delta = |eccentricity| - clearance (negative in free flight)
    eccentricity : (n, 2) m, journal centre relative to bearing centre
    contact_phase : (n,) int, 1 while in contact, 0 in free flight
    crank_work : (n,) J, work done by the crank drive since t = 0 (NaN-free; zeros if the
        backend does not integrate it)
    mechanism : the simulated SliderCrank
    backend : name of the backend
    stats : counters of the solver (nfev, naccept, nreject, nevent, ...) and settings
    peaks : (revolutions,) N, max |F12| per revolution refined between samples, or None
    """

    t: np.ndarray
    base_force: np.ndarray
    crank_moment: np.ndarray
    contact_force: np.ndarray
    penetration: np.ndarray
    eccentricity: np.ndarray
    contact_phase: np.ndarray
    crank_work: np.ndarray
    mechanism: Any
    backend: str
    stats: dict[str, Any] = field(default_factory=dict)
    peaks: np.ndarray | None = None
    joints: tuple[str, ...] | None = None
    reactions: dict[str, np.ndarray] | None = None
    shaking_force: np.ndarray | None = None
    coordinates: dict[str, np.ndarray] | None = None
    rates: dict[str, np.ndarray] | None = None
    accelerations: dict[str, np.ndarray] | None = None
    #: J, work dissipated by friction in the clearance joints since t = 0 (a linkage with
    #: friction; None otherwise)
    friction_work: np.ndarray | None = None
    #: rad, per clearance joint (n, J; the first J of ``joints``, which the translational
    #: joints' corners follow): the eccentricity's direction in the bearing body's
    #: frame, in [0, 2 pi) (where a contact presses the bearing); None if not provided
    contact_angle: np.ndarray | None = None
    #: m/s, per clearance joint (n, J): the journal surface's tangential speed against the
    #: bearing's at the contact (the friction law's v_t); None if not provided
    slip_velocity: np.ndarray | None = None

    # the paper's names, read from the generic series
    coupler_angle = _paper_property("coupler_angle")
    coupler_rate = _paper_property("coupler_rate")
    slider_position = _paper_property("slider_position")
    slider_velocity = _paper_property("slider_velocity")
    slider_acceleration = _paper_property("slider_acceleration")

    def _by_paper_name(self, name: str) -> np.ndarray:
        """The generic series that the paper's name `name` (`PAPER_SERIES`) stands for (no
        copy); AttributeError naming the linkage and its coordinates where its description
        has no such coordinate."""
        _, kind, coordinate = PAPER_SERIES[name]
        series = getattr(self, kind)
        if series is not None and coordinate in series:
            return series[coordinate]
        from ..model.cases import as_linkage

        has = ", ".join(repr(c) for c in series or ()) or "none"
        raise AttributeError(
            f"{name} is the series of the paper slider-crank's coordinate {coordinate!r}, "
            f"which linkage {as_linkage(self.mechanism).name!r} does not have (its {kind}: "
            f"{has}); read its series in traj.{kind}")

    @property
    def linkage(self):
        """The simulated `Linkage`, or None for a `SliderCrank`."""
        from ..model.cases import door

        return None if door(self.mechanism).given_as_paper else self.mechanism

    @property
    def output(self) -> str:
        """The name of the output whose peaks are ``peaks`` and `max_base_force`: the
        mechanism's `default_output` ("pivot_force:crank_pivot" for the paper's |F12|,
        "shaking_force" for a linkage without a monitored joint)."""
        return self.mechanism.default_output

    def _drive(self) -> tuple[float, float]:
        from ..model.cases import as_linkage

        m = as_linkage(self.mechanism)     # the paper's crank: its description's drive
        if m.drive is None:
            raise ValueError(f"linkage {m.name!r} is free (drive=None): it has no crank angle; "
                             "its angles are in coordinates")
        return m.drive.speed, m.drive.initial_angle

    # ------------------------------------------------------------------ derived outputs
    @property
    def base_force_magnitude(self) -> np.ndarray:
        """|F12| in N, shape (n,)."""
        return np.hypot(self.base_force[:, 0], self.base_force[:, 1])

    @property
    def crank_angle(self) -> np.ndarray:
        """theta2 = omega2 t + theta20 in rad, shape (n,)."""
        speed, angle = self._drive()
        return speed * self.t + angle

    @property
    def revolutions(self) -> int:
        """Number of full crank revolutions covered (0 for a free linkage: no drive)."""
        if self.linkage is not None and self.mechanism.drive is None:
            return 0
        return int(np.floor(self.t[-1] / self.mechanism.period + 1e-9))

    def revolution_window(self, revolution: int) -> tuple[float, float]:
        """Time interval [t_a, t_b] of crank revolution `revolution` (1-based) in s."""
        revolution = check_int("revolution", revolution, 1)
        if revolution > self.revolutions:
            raise ValueError(
                f"revolution must be between 1 and {self.revolutions} (the trajectory covers"
                f" {self.revolutions} full revolutions); got {revolution}"
            )
        period = self.mechanism.period
        return (revolution - 1) * period, revolution * period

    def revolution_mask(self, revolution: int) -> np.ndarray:
        """Boolean mask of the samples inside revolution `revolution` (1-based)."""
        t_a, t_b = self.revolution_window(revolution)
        tol = 1e-12 * max(1.0, t_b)
        return (self.t >= t_a - tol) & (self.t <= t_b + tol)

    def max_base_force(self, revolution: int = 4) -> float:
        """Maximum of the monitored output (`output`: |F12| of the paper's case) in N over
        revolution `revolution` (1-based).

        Uses the peak refined between samples where the backend provides it (reduced model),
        otherwise the maximum over the samples.
        """
        revolution = check_int("revolution", revolution, 1)
        mask = self.revolution_mask(revolution)
        if self.peaks is not None and len(self.peaks) >= revolution:
            return float(self.peaks[revolution - 1])
        if not np.any(mask):
            raise ValueError(f"revolution {revolution} has no samples (the run's output times "
                             f"t_eval cover {self.t[0]:.6g} to {self.t[-1]:.6g} s)")
        return float(self.base_force_magnitude[mask].max())

    # ------------------------------------------------------------------ save / load
    def save(self, path: str | Path) -> Path:
        """Write to ``.npz`` (all data) or ``.csv`` (series, metadata in a comment line)."""
        path = Path(path)
        meta = self._meta()
        if self.linkage is not None:
            return _save_linkage(self, path, meta)
        generic = generic_columns(self)
        if path.suffix == ".npz":
            arrays = {name: getattr(self, name) for name in SERIES}
            if self.peaks is not None:
                arrays["peaks"] = self.peaks
            np.savez_compressed(path, meta=np.array(json.dumps(meta)), **arrays, **generic)
        elif path.suffix == ".csv":
            columns, header = self._columns()
            columns = np.column_stack([columns, *generic.values()])
            np.savetxt(path, columns, delimiter=",", header="# " + json.dumps(meta) + "\n"
                       + ",".join([*header, *generic]), comments="", fmt="%.17g")
        else:
            raise ValueError(f"trajectory file must end in .npz or .csv; got {str(path)!r}")
        return path

    def _meta(self) -> dict[str, Any]:
        stats = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in self.stats.items()}
        key = "mechanism" if self.linkage is None else "linkage"
        meta = {key: self.mechanism.to_dict(), "backend": self.backend, "stats": stats}
        if self.peaks is not None:
            meta["peaks"] = [float(p) for p in self.peaks]
        return meta

    def _columns(self) -> tuple[np.ndarray, list[str]]:
        cols, header = [], []
        for name, (unit, ncol) in SERIES.items():
            data = np.asarray(getattr(self, name), dtype=float)
            if ncol == 1:
                cols.append(data)
                header.append(f"{name}[{unit}]")
            else:
                for j, axis in enumerate("xy"):
                    cols.append(data[:, j])
                    header.append(f"{name}_{axis}[{unit}]")
        return np.column_stack(cols), header


def annotate(traj: Trajectory) -> Trajectory:
    """Add the physics diagnostics to `traj.stats` (in place) and return `traj`.

    - ``max_penetration_clearance``, ``max_penetration_radius``: the largest penetration over
      the run divided by the clearance and by the journal radius;
    - ``penetration_meaningless``: True when it exceeds `PENETRATION_LIMIT` times the journal
      radius; a `PhysicsWarning` then says so;
    - ``periodic`` (True, False or None) and ``periodicity_note``: see `periodicity`.
    """
    m = traj.mechanism
    if traj.linkage is not None:
        # the joint with the largest penetration relative to its journal radius
        # (a translational joint's corners: the slider's half-height in the radius's place)
        radii = np.array([getattr(j, "journal_radius", None) or j.half_height
                          for _, j in m.contacts()])
        clear = np.array([j.clearance for _, j in m.contacts()])
        pens = np.maximum(np.max(traj.penetration, axis=0, initial=0.0), 0.0)
        k = int(np.argmax(pens / radii))
        pen, radius, clearance = float(pens[k]), radii[k], clear[k]
    else:
        pen = float(np.max(traj.penetration, initial=-np.inf)) if len(traj.t) else -np.inf
        pen = max(pen, 0.0)
        radius, clearance = m.journal_radius, m.clearance
    ratio = pen / radius
    traj.stats["max_penetration_clearance"] = pen / clearance
    traj.stats["max_penetration_radius"] = ratio
    traj.stats["penetration_meaningless"] = bool(ratio > PENETRATION_LIMIT)
    if ratio > PENETRATION_LIMIT:
        warnings.warn(
            f"the journal penetrates the bearing by {pen:.3g} m = {ratio:.3g} journal radii "
            f"({pen / clearance:.4g} clearances), more than {PENETRATION_LIMIT:g} R_J: the "
            "contact law does not hold there and the result is physically meaningless "
            "(lower the crank speed or raise the contact stiffness)", PhysicsWarning,
            stacklevel=3)
    periodic, note = periodicity(traj)
    traj.stats["periodic"] = periodic
    traj.stats["periodicity_note"] = note
    return traj


def boundary_states(traj: Trajectory) -> np.ndarray | None:
    """The dimensionless state at the revolution boundaries t = T, 2T, ... (Poincare
    section, t = 0 excluded: the journal starts centred): rows [e_x / c, e_y / c,
    x4dot / (omega2 c), theta3dot L3 / (omega2 c)], interpolated linearly between samples.
    None when a boundary is not resolved (no sample within 1e-3 T)."""
    m = traj.mechanism
    k = traj.revolutions
    if k < 1:
        return np.zeros((0, 4))
    times = np.arange(1, k + 1) * m.period
    t = traj.t
    hi = np.clip(np.searchsorted(t, times), 0, len(t) - 1)
    lo = np.clip(hi - 1, 0, len(t) - 1)
    near = np.minimum(np.abs(t[hi] - times), np.abs(t[lo] - times))
    if np.any(near > 1e-3 * m.period):
        return None
    # only the samples around the boundaries (np.interp on them takes the same brackets
    # as on the whole series: the same values, without scaling every sample)
    rows = np.unique(np.concatenate([lo, hi]))
    t_rows = t[rows]
    if traj.linkage is not None:
        # every joint's eccentricity in its clearances, every rate in drive speed x the
        # smallest clearance (angle rates times the linkage's length scale)
        c, w = m.min_clearance, m.drive.speed
        # (a corner of a translational joint: its normal offset only; its position along
        # the guide is no small quantity)
        cols = [traj.eccentricity[rows, k, i] / j.clearance
                for k, (name, j) in enumerate(m.contacts()) for i in range(2)
                if i == 1 or name == j.name]
        cols += [v[rows] * (m.length_scale if name.endswith(".angle") else 1.0) / (w * c)
                 for name, v in traj.rates.items()]
        return np.column_stack([np.interp(times, t_rows, col) for col in cols])
    c, w = m.clearance, m.crank_speed
    cols = (traj.eccentricity[rows, 0] / c, traj.eccentricity[rows, 1] / c,
            traj.slider_velocity[rows] / (w * c),
            traj.coupler_rate[rows] * m.coupler_length / (w * c))
    return np.column_stack([np.interp(times, t_rows, col) for col in cols])


def periodicity(traj: Trajectory) -> tuple[bool | None, str]:
    """Is the motion periodic? (True, False or None: cannot be judged) and a sentence why.

    The return map of the state at the revolution boundaries (`boundary_states`): periodic
    with period n (n <= MAX_PERIOD revolutions) when the last state is within
    `PERIODIC_TOL` (or 10 times the integration noise rtol (L2 + L3) / c if larger) of the
    state n revolutions before. Otherwise undetermined (None) when
    fewer than 3 boundaries are available, the integration tolerance is too loose for the
    distance to mean anything (`NOISE_LIMIT`), or the return distance is still falling fast
    (by more than half per revolution over the last two: a transient that has not
    settled), else not periodic (False: chaotic, quasi-periodic or a transient longer than
    the run).
    """
    if traj.linkage is not None and traj.mechanism.drive is None:
        return None, "undetermined: a free linkage has no drive revolutions to compare"
    x = boundary_states(traj)
    if x is None:
        return None, ("undetermined: the samples do not resolve the revolution boundaries "
                      "(t_eval without them)")
    if len(x) < 3:
        return None, (f"undetermined: {len(x)} revolution(s); the return map needs at least "
                      "3 revolutions")
    # the integration noise of the positions in clearance units (atol = rtol (L2 + L3)),
    # with a margin of 10: the return distance cannot be judged below it
    m = traj.mechanism
    rtol = traj.stats.get("rtol") if traj.backend != "exudyn" else None
    rtol = rtol if isinstance(rtol, float) else 0.0
    if traj.linkage is not None:
        reach, clearance = m.length_scale, m.min_clearance
    else:
        reach, clearance = m.crank_length + m.coupler_length, m.clearance
    tol = max(PERIODIC_TOL, 10 * rtol * reach / clearance)
    if tol > NOISE_LIMIT:
        return None, (f"undetermined: at rtol {rtol:g} the integration noise of the journal "
                      f"position ({tol / 10:.2g} clearances) is too large to tell a periodic "
                      "motion; use a smaller rtol")
    last = [float(np.linalg.norm(x[-1] - x[-1 - n])) for n in range(1, min(MAX_PERIOD,
                                                                         len(x) - 1) + 1)]
    for n, d in enumerate(last, start=1):
        if d <= tol:
            return True, (f"periodic (period-{n}): the state at the last revolution boundary "
                          f"repeats within {d:.2g} clearance units (tolerance {tol:.2g})")
    d1 = np.linalg.norm(np.diff(x, axis=0), axis=1)
    if len(d1) >= 2 and d1[-1] < 0.5 * d1[-2] and (len(d1) < 3 or d1[-2] < 0.5 * d1[-3]):
        return None, (f"undetermined: the return distance is still falling ({d1[-2]:.2g} -> "
                      f"{d1[-1]:.2g} clearance units per revolution); run more revolutions")
    return False, (f"not periodic: the state at the revolution boundaries does not repeat "
                   f"with a period of up to {min(MAX_PERIOD, len(x) - 1)} revolutions "
                   f"(smallest return distance {min(last):.2g} clearance units, tolerance "
                   f"{tol:.2g}): chaotic, quasi-periodic or a long transient")


def _fail(path: Path, problem: str) -> ValueError:
    return ValueError(f"inconsistent trajectory file {str(path)!r}: {problem}")


def check_consistency(path: Path, series: dict[str, np.ndarray], meta: Any,
                      peaks: np.ndarray | None) -> None:
    """Check a loaded trajectory: metadata types, equal lengths, column counts, finite
    values, increasing times, and stored peaks against the stored series (ValueError naming
    the file and the problem)."""
    if not isinstance(meta, dict) or not isinstance(meta.get("mechanism"), dict):
        raise _fail(path, "metadata must be an object with a 'mechanism' object")
    if not isinstance(meta.get("backend"), str):
        raise _fail(path, "metadata 'backend' must be a string")
    if not isinstance(meta.get("stats", {}), dict):
        raise _fail(path, "metadata 'stats' must be an object")
    n = None
    for name, (_, ncol) in SERIES.items():
        a = series[name]
        shape = (a.shape[0],) if ncol == 1 else (a.shape[0], ncol)
        if a.ndim != len(shape) or a.shape != shape or a.shape[0] < 1:
            raise _fail(path, f"series {name!r} has shape {a.shape}, expected (n,)"
                        f"{'' if ncol == 1 else f' x {ncol}'} with n >= 1")
        if n is None:
            n = a.shape[0]
        elif a.shape[0] != n:
            raise _fail(path, f"series {name!r} has {a.shape[0]} samples, 't' has {n}")
        if not np.issubdtype(a.dtype, np.number) or not np.all(np.isfinite(a)):
            raise _fail(path, f"series {name!r} holds non-finite or non-numeric values")
    if np.any(np.diff(series["t"]) <= 0):
        raise _fail(path, "times 't' are not strictly increasing")
    if not np.all(np.isin(series["contact_phase"], (0, 1))):
        raise _fail(path, "contact_phase must hold 0 or 1 only")
    if peaks is not None:
        if peaks.ndim != 1 or not np.all(np.isfinite(peaks)) or np.any(peaks < 0):
            raise _fail(path, "peaks must be a list of finite numbers >= 0")


def _check_peaks(path: Path, traj: Trajectory) -> None:
    """The stored refined peaks must agree with the stored series: each at least the largest
    sample of its revolution (within 1e-9) and at most PEAK_EXCESS above it."""
    if traj.peaks is None or (traj.linkage is not None and traj.mechanism.drive is None):
        return      # (a free linkage's windows are not stored: its peaks are not checked)
    if len(traj.peaks) != traj.revolutions:
        raise _fail(path, f"{len(traj.peaks)} peaks for {traj.revolutions} revolutions")
    mag = traj.base_force_magnitude
    # peaks extrapolated in the step (Exudyn at a requested accuracy) may lie below the
    # stored run's samples, by at most their error estimate
    below = (max(float(traj.stats.get("error_estimate", 0.0)),
                 float(traj.stats.get("series_peak_offset", 0.0)))
             if traj.stats.get("peaks_extrapolated") else 0.0)
    for k in range(1, len(traj.peaks) + 1):
        sampled = float(mag[traj.revolution_mask(k)].max())
        peak = float(traj.peaks[k - 1])
        if not (sampled * (1 - 1e-9 - below) <= peak <= sampled * (1 + PEAK_EXCESS) + 1e-9):
            raise _fail(path, f"stored peak of revolution {k} ({peak:.9g} N) disagrees with "
                        f"the stored series (sampled maximum {sampled:.9g} N; a refined peak "
                        f"lies within {PEAK_EXCESS:g} above it)")


#: the refined peak between samples exceeds the largest sample by at most this fraction in
#: a loaded file (measured over the paper case, c = 0.1 and 0.5 mm, 100 and 10000 rpm and
#: e = 0.05, 4 revolutions: at most 0.007 at the default rtol, 0.17 at rtol 1e-4, where the
#: steps are long); a peak below the largest sample is always refused
PEAK_EXCESS = 0.25


def load_trajectory(path: str | Path) -> Trajectory:
    """Read a trajectory written by `Trajectory.save` (``.npz`` or ``.csv``).

    The file is checked (equal lengths, column counts, finite values, increasing times,
    metadata types, peaks consistent with the stored series); a bad file raises ValueError
    naming it and the problem.
    """
    path = Path(path)
    try:
        if path.suffix == ".npz":
            with np.load(path, allow_pickle=False) as data:
                meta = json.loads(str(data["meta"]))
                if isinstance(meta, dict) and "linkage" in meta:
                    meta["_columns"] = {k: np.asarray(data[k]) for k in data.files
                                        if k not in ("meta", "peaks")}
                    return _load_linkage(path, meta)
                series = {name: np.asarray(data[name]) for name in SERIES}
                rest = {k: np.asarray(data[k]) for k in data.files
                        if k not in SERIES and k not in ("meta", "peaks")}
        elif path.suffix == ".csv":
            with open(path) as fh:
                meta = json.loads(fh.readline()[1:].strip())
                header = fh.readline().strip().split(",")
            table = np.loadtxt(path, delimiter=",", skiprows=2, ndmin=2)
            if isinstance(meta, dict) and "linkage" in meta:
                meta["_columns"] = {name: table[:, k] for k, name in enumerate(header)}
                return _load_linkage(path, meta)
            series = {}
            used = set()
            for name, (_, ncol) in SERIES.items():
                if ncol == 1:
                    used.add(header.index(f"{name}[{SERIES[name][0]}]"))
                    series[name] = table[:, header.index(f"{name}[{SERIES[name][0]}]")]
                else:
                    idx = [header.index(f"{name}_{a}[{SERIES[name][0]}]") for a in "xy"]
                    used.update(idx)
                    series[name] = table[:, idx]
            rest = {name: table[:, k] for k, name in enumerate(header) if k not in used}
        else:
            raise ValueError(f"trajectory file must end in .npz or .csv; got {str(path)!r}")
    except (OSError, KeyError, json.JSONDecodeError, UnicodeDecodeError, EOFError,
            ValueError) as exc:
        if isinstance(exc, ValueError) and "must end in" in str(exc):
            raise
        raise ValueError(f"cannot read trajectory file {str(path)!r}: {exc}") from exc
    if isinstance(meta, dict) and "linkage" in meta:
        return _load_linkage(path, meta)
    peaks = meta.get("peaks") if isinstance(meta, dict) else None
    try:
        peaks = None if peaks is None else np.asarray(peaks, dtype=float)
    except (TypeError, ValueError) as exc:
        raise _fail(path, f"peaks must be a list of numbers: {exc}") from exc
    check_consistency(path, series, meta, peaks)
    series["contact_phase"] = series["contact_phase"].astype(np.int8)
    try:
        mech = SliderCrank.from_dict(meta["mechanism"])
    except (TypeError, ValueError) as exc:
        raise _fail(path, f"bad mechanism: {exc}") from exc
    generic = _generic_series(path, rest, len(series["t"]))
    _add_paper_columns(path, generic, {name: series.pop(name) for name in PAPER_SERIES})
    from ..model.cases import as_linkage

    generic["joints"] = tuple(j.name for j in as_linkage(mech).clearance_joints)
    traj = Trajectory(**series, mechanism=mech, backend=meta["backend"],
                      stats=meta.get("stats", {}), peaks=peaks, **generic)
    _check_peaks(path, traj)
    return traj


# ---------------------------------------------------------------------------- linkages

def linkage_columns(traj: Trajectory) -> dict[str, np.ndarray]:
    """The series of a linkage trajectory as named 1-D columns (units in brackets): what
    .csv and .npz files of a linkage hold."""
    cols = {"t[s]": traj.t, "base_force_x[N]": traj.base_force[:, 0],
            "base_force_y[N]": traj.base_force[:, 1], "crank_moment[N m]": traj.crank_moment,
            "crank_work[J]": traj.crank_work, "shaking_force_x[N]": traj.shaking_force[:, 0],
            "shaking_force_y[N]": traj.shaking_force[:, 1]}
    # a free linkage has no drive: no drive moment or work columns
    cols = {k: v for k, v in cols.items() if v is not None}
    for k, j in enumerate(traj.joints):
        cols[f"contact_force.{j}[N]"] = traj.contact_force[:, k]
        cols[f"penetration.{j}[m]"] = traj.penetration[:, k]
        cols[f"eccentricity.{j}_x[m]"] = traj.eccentricity[:, k, 0]
        cols[f"eccentricity.{j}_y[m]"] = traj.eccentricity[:, k, 1]
        cols[f"contact_phase.{j}[-]"] = traj.contact_phase[:, k]
    # the clearance joints' (the first of `joints`) contact angle and slip velocity
    for field_, unit in (("contact_angle", "rad"), ("slip_velocity", "m/s")):
        series = getattr(traj, field_)
        for k in range(0 if series is None else series.shape[1]):
            cols[f"{field_}.{traj.joints[k]}[{unit}]"] = series[:, k]
    return {**cols, **generic_columns(traj)}


def generic_columns(traj: Trajectory) -> dict[str, np.ndarray]:
    """The series every linkage's run has besides the per-joint ones (the ground joints'
    reactions, the shaking force, the coordinates, their rates and accelerations, the
    friction work) as named 1-D columns; those a trajectory has (an ideal-joint run of the
    paper's parameter set: the coordinates, their rates and accelerations)."""
    cols: dict[str, np.ndarray] = {}
    if traj.shaking_force is not None and traj.linkage is None:
        cols["shaking_force_x[N]"] = traj.shaking_force[:, 0]
        cols["shaking_force_y[N]"] = traj.shaking_force[:, 1]
    for g, r in (traj.reactions or {}).items():
        cols[f"reaction.{g}_x[N]"] = r[:, 0]
        cols[f"reaction.{g}_y[N]"] = r[:, 1]
    for kind, series in (("coordinate", traj.coordinates), ("rate", traj.rates),
                         ("acceleration", traj.accelerations)):
        for c, v in (series or {}).items():
            cols[f"{kind}.{c}"] = v
    if traj.friction_work is not None:
        cols["friction_work[J]"] = traj.friction_work
    return cols


def _generic_series(path: Path, cols: dict[str, np.ndarray], n: int) -> dict[str, Any]:
    """The Trajectory fields of the generic columns (`generic_columns`) among `cols` (none
    present: none filled)."""
    for name, v in cols.items():
        if v.shape != (n,) or not np.all(np.isfinite(v)):
            raise _fail(path, f"column {name!r} has shape {v.shape} or non-finite values")
    grounds = [k[len("reaction."):-len("_x[N]")] for k in cols
               if k.startswith("reaction.") and k.endswith("_x[N]")]
    out: dict[str, Any] = {}
    try:
        if grounds:
            out["reactions"] = {g: np.column_stack([cols[f"reaction.{g}_x[N]"],
                                                    cols[f"reaction.{g}_y[N]"]])
                                for g in grounds}
        if "shaking_force_x[N]" in cols:
            out["shaking_force"] = np.column_stack([cols["shaking_force_x[N]"],
                                                    cols["shaking_force_y[N]"]])
    except KeyError as exc:
        raise _fail(path, f"missing column {exc}") from exc
    # each kind as stored: a file written again from one of an earlier version (whose
    # ideal-joint or Exudyn run stored no coupler acceleration) lacks that column
    for kind, prefix in (("coordinates", "coordinate."), ("rates", "rate."),
                         ("accelerations", "acceleration.")):
        named = {k[len(prefix):]: v for k, v in cols.items() if k.startswith(prefix)}
        if named:
            out[kind] = named
    if "friction_work[J]" in cols:
        out["friction_work"] = cols["friction_work[J]"]
    return out


def _add_paper_columns(path: Path, generic: dict[str, Any], paper: dict[str, np.ndarray]
                       ) -> None:
    """Put a SliderCrank file's columns of the paper's names (`PAPER_SERIES`) into the
    generic series `generic` (in place); where the file holds a series under both names
    (the reduced model's files) the two must be equal."""
    for name, (_, kind, coordinate) in PAPER_SERIES.items():
        named = generic.setdefault(kind, {})
        if coordinate not in named:
            named[coordinate] = paper[name]
        elif not np.array_equal(named[coordinate], paper[name]):
            raise _fail(path, f"column {name!r} differs from the {kind} column of "
                              f"{coordinate!r}, the same series")


def _save_linkage(traj: Trajectory, path: Path, meta: dict) -> Path:
    cols = linkage_columns(traj)
    if path.suffix == ".npz":
        extra = {} if traj.peaks is None else {"peaks": traj.peaks}
        np.savez_compressed(path, meta=np.array(json.dumps(meta)), **cols, **extra)
    elif path.suffix == ".csv":
        np.savetxt(path, np.column_stack(list(cols.values())), delimiter=",",
                   header="# " + json.dumps(meta) + "\n" + ",".join(cols), comments="",
                   fmt="%.17g")
    else:
        raise ValueError(f"trajectory file must end in .npz or .csv; got {str(path)!r}")
    return path


def _load_linkage(path: Path, meta: dict) -> Trajectory:
    """A linkage trajectory from its columns (`linkage_columns`) and metadata."""
    from ..model.linkage import Linkage

    try:
        linkage = Linkage.from_dict(meta["linkage"])
    except (TypeError, ValueError) as exc:
        raise _fail(path, f"bad linkage: {exc}") from exc
    cols = meta.pop("_columns")
    joints = tuple(name for name, _ in linkage.contacts())
    clearance = tuple(j.name for j in linkage.clearance_joints)
    # the ground joints' and coordinates' names from the columns, in their stored order
    grounds = [k[len("reaction."):-len("_x[N]")] for k in cols
               if k.startswith("reaction.") and k.endswith("_x[N]")]
    coords = [k[len("coordinate."):] for k in cols if k.startswith("coordinate.")]
    try:
        n = len(cols["t[s]"])
        for name, v in cols.items():
            if v.shape != (n,) or not np.all(np.isfinite(v)):
                raise _fail(path, f"column {name!r} has shape {v.shape} or non-finite values")

        def stack(prefix, names, suffix=""):
            return np.column_stack([cols[f"{prefix}.{x}{suffix}"] for x in names])

        peaks = meta.get("peaks")
        traj = Trajectory(
            t=cols["t[s]"],
            base_force=np.column_stack([cols["base_force_x[N]"], cols["base_force_y[N]"]]),
            crank_moment=cols.get("crank_moment[N m]"),
            contact_force=stack("contact_force", joints, "[N]"),
            penetration=stack("penetration", joints, "[m]"),
            eccentricity=np.stack([stack("eccentricity", joints, "_x[m]"),
                                   stack("eccentricity", joints, "_y[m]")], axis=2),
            contact_phase=stack("contact_phase", joints, "[-]").astype(np.int8),
            crank_work=cols.get("crank_work[J]"), mechanism=linkage, backend=meta["backend"],
            stats=meta.get("stats", {}),
            peaks=None if peaks is None else np.asarray(peaks, dtype=float),
            joints=joints,
            reactions={g: np.column_stack([cols[f"reaction.{g}_x[N]"],
                                           cols[f"reaction.{g}_y[N]"]])
                       for g in grounds},
            shaking_force=np.column_stack([cols["shaking_force_x[N]"],
                                           cols["shaking_force_y[N]"]]),
            coordinates={c: cols[f"coordinate.{c}"] for c in coords},
            rates={c: cols[f"rate.{c}"] for c in coords},
            accelerations={c: cols[f"acceleration.{c}"] for c in coords},
            friction_work=cols.get("friction_work[J]"),
            **{field_: stack(field_, clearance, f"[{unit}]")
               for field_, unit in (("contact_angle", "rad"), ("slip_velocity", "m/s"))
               if clearance and f"{field_}.{clearance[0]}[{unit}]" in cols},
        )
    except KeyError as exc:
        raise _fail(path, f"missing column {exc}") from exc
    if np.any(np.diff(traj.t) <= 0):
        raise _fail(path, "times 't' are not strictly increasing")
    return traj


Trajectory.load = staticmethod(load_trajectory)  # type: ignore[attr-defined]
