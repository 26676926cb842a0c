"""Design sensitivities of the base reaction force (paper Section 3, Figs. 4-6).

`sensitivities(mech, parameters, method="ddm")` integrates the direct-differentiation
equations of the reduced model, generated with its exact Jacobians (`linkage_ddm`; a
SliderCrank's fields are directions in its description's parameters,
`mechanism.field_directions`); ``method="fd"`` takes central finite
differences through any backend, with the runs in parallel.
"""

from __future__ import annotations

import json
import logging
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._checks import (
    check_bool,
    check_choice,
    check_int,
    check_real,
    check_revolutions_memory,
    check_times,
)
from ..model.mechanism import (  # noqa: F401 - reference_value public here too
    CONTINUOUS_FIELDS,
    PAPER_JOINT,
    SliderCrank,
    check_field_names,
    field_directions,
    reference_value,
)
from ..numerics.integrator import METHODS
from ..solve import reduced
from ..solve.linkage_ddm import (
    fd_step,  # noqa: F401  (public here too)
    independent_directions,  # noqa: F401  (public here too)
)
from ..solve.settings import RunSettings
from ..solve.trajectory import Trajectory, annotate, load_trajectory

__all__ = ["Sensitivities", "sensitivities", "load_sensitivities", "DEFAULT_PARAMETERS",
           "reference_value", "fd_step", "summary_sensitivities",
           "summary_times", "time_average", "SUMMARY_RTOL", "SUMMARY_SAMPLES_PER_REVOLUTION"]

#: the sensitivity summary (mean |S| over the last revolution: `Sensitivities.summary`) is
#: one number wherever it is reported (``mbs-clearance sensitivity``, the validation report,
#: docs/sensitivity.md): DDM at this rtol, sampled on a uniform grid of
#: SUMMARY_SAMPLES_PER_REVOLUTION intervals per revolution (`summary_sensitivities`)
SUMMARY_RTOL = 1e-9
SUMMARY_SAMPLES_PER_REVOLUTION = 1440


def time_average(t: np.ndarray, y: np.ndarray) -> float:
    """The time average of y over [t[0], t[-1]] by the trapezoidal rule (the mean of the
    samples where there is one)."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    if len(t) < 2 or t[-1] <= t[0]:
        return float(np.mean(y))
    return float(np.trapezoid(y, t) / (t[-1] - t[0]))


def summary_times(mech, revolutions: int) -> np.ndarray:
    """The summary's sampling times in s: `SUMMARY_SAMPLES_PER_REVOLUTION` uniform
    intervals per drive revolution over `revolutions` revolutions from t = 0."""
    from ..model.cases import as_linkage

    revolutions = check_int("revolutions", revolutions, 1)
    period = as_linkage(mech).period
    return np.linspace(0.0, revolutions * period,
                       revolutions * SUMMARY_SAMPLES_PER_REVOLUTION + 1)


def summary_sensitivities(mech, parameters=None, revolutions: int | None = None, *,
                          method: str = "ddm", rtol: float | None = None, **options):
    """The sensitivities whose `Sensitivities.summary` is the reported one: for DDM of a
    driven mechanism, at rtol `SUMMARY_RTOL` (unless `rtol` is given) on `summary_times`;
    otherwise (finite differences, a free linkage) `sensitivities` as given. Arguments as
    `sensitivities`."""
    from ..model.linkage import Linkage

    driven = not (isinstance(mech, Linkage) and mech.drive is None)
    if method == "ddm" and driven and "t_eval" not in options:
        n = 4 if revolutions is None else revolutions
        options["t_eval"] = summary_times(mech, n)
        rtol = SUMMARY_RTOL if rtol is None else rtol
    return sensitivities(mech, parameters, revolutions, method=method, rtol=rtol, **options)

#: the paper's set of design parameters (Figs. 4-6)
DEFAULT_PARAMETERS = ("crank_length", "coupler_length", "coupler_mass", "slider_mass",
                      "contact_stiffness", "youngs_modulus", "journal_radius", "restitution")

#: relative floor of the normalization of Eq. 15: |F12| is replaced by
#: max(|F12|, NORMALIZATION_FLOOR * max_t |F12|) so the ratio stays finite near |F12| = 0
NORMALIZATION_FLOOR = 0.01

#: growth of the sensitivity norm per revolution, relative to its value in revolution 2,
#: above which the motion is declared not periodic: the slope of a least-squares line
#: through the per-revolution maxima (`growth`) from revolution 2 on (revolution 1 holds the
#: start's transient), divided by the revolution-2 value. A line, not the ratio of the
#: last two revolutions, so that steady algebraic growth is caught too: 100 rpm grows
#: linearly, by 0.43 of its revolution-2 value per revolution over 4 revolutions (the ratio
#: of the last two only 1.15); the paper case's largest is 0.031 (eight parameters, 4
#: revolutions) and falls with more (bounded);
#: 1000 rpm 22, c = 0.1 mm 263, c = 0.5 mm 1.2e5 (8 and 5 revolutions, docs/sensitivity.md)
GROWTH_TREND_LIMIT = 0.1

#: revolutions the growth diagnostic needs: revolution 1 is the transient, and a trend
#: needs two more
MIN_JUDGED_REVOLUTIONS = 3

#: relative finite-difference step: central differences have error O(h^2) against the
#: integration noise rtol / h; measured against DDM in the paper's case, 3e-5 is the best
#: (DDM - FD: 9e-4 at 3e-4, 1e-4 at 1e-4, 9e-6 at 3e-5, 2e-6..6e-6 at 1e-5; docs/sensitivity.md)
FD_RELATIVE_STEP = 3e-5


@dataclass(frozen=True)
class Sensitivities:
    """Derivatives of the outputs with respect to named SliderCrank fields.

    Attributes
    ----------
    t : (n,) s
    parameters : tuple of p field names
    reference : (p,) the parameter values b0 (derived values where the field is None)
    base_force : (n, 2, p) dF12/db
    base_force_magnitude : (n, p) d|F12|/db
    crank_moment : (n, p) dM2/db (None for a free linkage: no drive)
    contact_force : (n, p) dF/db
    trajectory : the nominal Trajectory on the same time grid
    method, backend : how they were computed
    growth : (revolutions, p) max over each revolution (a free linkage: each window) of the
        normalized state-sensitivity norm; it stays bounded in periodic motion and grows
        without bound in chaotic motion
    stats : solver counters and settings
    outputs : for a `Linkage` (else None): every output column of its generated model
        (OUT_COLUMNS) and every coordinate, name -> (n, p) derivatives; there base_force is
        the monitored reaction (the monitor joint's, or the shaking force), crank_moment
        the drive moment, contact_force (n, p) for one contact, (n, J, p) for J (the
        clearance joints, then the translational joints' corners)
    """

    t: np.ndarray
    parameters: tuple[str, ...]
    reference: np.ndarray
    base_force: np.ndarray
    base_force_magnitude: np.ndarray
    crank_moment: np.ndarray
    contact_force: np.ndarray
    trajectory: Trajectory
    method: str
    backend: str
    growth: np.ndarray | None = None
    stats: dict[str, Any] = field(default_factory=dict)
    outputs: dict[str, np.ndarray] | None = None

    @property
    def normalized(self) -> np.ndarray:
        """Eq. 15 for |F12|: (d|F12|/db) b0 / |F12|, shape (n, p).

        |F12| in the denominator is floored at NORMALIZATION_FLOOR times its maximum over
        the trajectory, so the ratio stays finite where the force passes near zero.
        """
        mag = self.trajectory.base_force_magnitude
        denom = np.maximum(mag, NORMALIZATION_FLOOR * mag.max())
        return self.base_force_magnitude * self.reference[None, :] / denom[:, None]

    def revolution_mask(self, revolution: int) -> np.ndarray:
        """Boolean mask of the samples in crank revolution `revolution` (1-based)."""
        return self.trajectory.revolution_mask(revolution)

    @property
    def growth_rate(self) -> np.ndarray:
        """Per parameter, the factor by which the sensitivity norm grows per revolution over
        the last two revolutions (about 1 for periodic motion, >> 1 for chaotic motion; NaN
        with fewer than 3 revolutions)."""
        if self.growth is None or len(self.growth) < 3:
            return np.full(len(self.parameters), np.nan)
        return np.sqrt(self.growth[-1] / np.maximum(self.growth[-3], 1e-300))

    @property
    def growth_trend(self) -> np.ndarray:
        """Per parameter, the growth of the sensitivity norm per revolution relative to its
        revolution-2 value: the slope of a least-squares line through `growth` from
        revolution 2 on, over the revolution-2 value (about 0 for periodic motion; NaN with
        fewer than MIN_JUDGED_REVOLUTIONS revolutions)."""
        if self.growth is None or len(self.growth) < MIN_JUDGED_REVOLUTIONS:
            return np.full(len(self.parameters), np.nan)
        g = np.asarray(self.growth[1:], dtype=float)
        k = np.arange(len(g), dtype=float)
        slope = np.polyfit(k, g, 1)[0]
        return slope / np.maximum(g[0], 1e-300)

    @property
    def periodic(self) -> bool | None:
        """True when the sensitivities stay bounded (periodic motion), False when they grow
        by more than GROWTH_TREND_LIMIT of their revolution-2 value per revolution (chaotic,
        a slow drift, or a long transient), None when it cannot be judged (fewer than
        MIN_JUDGED_REVOLUTIONS revolutions, or no growth diagnostic: finite differences)."""
        trend = self.growth_trend
        if not np.all(np.isfinite(trend)):
            return None
        return bool(np.all(trend <= GROWTH_TREND_LIMIT))

    @property
    def periodicity_note(self) -> str:
        """A sentence on `periodic`: why it cannot be judged, or the largest growth."""
        if self.growth is None:
            return ("undetermined: finite differences give no growth diagnostic (the "
                    "trajectory's own periodicity check still applies)")
        if len(self.growth) < MIN_JUDGED_REVOLUTIONS:
            return (f"undetermined: {len(self.growth)} revolution(s); the growth diagnostic "
                    f"needs at least {MIN_JUDGED_REVOLUTIONS} (revolution 1 is the start's "
                    "transient): the sensitivities' values cannot be trusted to be bounded")
        trend = self.growth_trend
        k = int(np.argmax(trend))
        if self.periodic:
            return (f"periodic: the sensitivity norms stay bounded (largest growth "
                    f"{trend[k]:.2g} of the revolution-2 value per revolution, "
                    f"{self.parameters[k]}; limit {GROWTH_TREND_LIMIT:g})")
        return (f"not periodic: the sensitivity norm of {self.parameters[k]} grows by "
                f"{trend[k]:.3g} times its revolution-2 value per revolution (limit "
                f"{GROWTH_TREND_LIMIT:g}): the motion is chaotic or drifts, and these "
                "derivatives are not meaningful")

    @property
    def chaotic(self) -> bool:
        """True when `periodic` is False: the sensitivities grow from revolution to
        revolution, the motion is not periodic (chaotic, drifting, or still in its
        transient) and derivatives of the trajectory are meaningless there (docs). False
        also when it cannot be judged: check `periodic` is not None."""
        return self.periodic is False

    def summary(self, revolution: int | None = None) -> list[dict[str, float]]:
        """Per parameter: b0, the time average (`time_average`: trapezoidal rule on the
        samples, so that it does not depend on where the integrator's steps fall) and the
        max of |normalized sensitivity| over `revolution`
        (default: the last; a free linkage, which has no revolutions: the whole run), the
        growth rate per revolution (a free linkage: per window) over the last two and the
        growth trend (`growth_trend`)."""
        rev = revolution or self.trajectory.revolutions
        mask = self.revolution_mask(rev) if rev else np.ones(len(self.t), dtype=bool)
        norm = np.abs(self.normalized[mask])
        rate = self.growth_rate
        trend = self.growth_trend
        return [{"parameter": n, "reference": float(self.reference[k]),
                 "mean_abs_normalized": time_average(self.t[mask], norm[:, k]),
                 "max_abs_normalized": float(norm[:, k].max()),
                 "growth_per_revolution": float(rate[k]),
                 "growth_trend": float(trend[k])}
                for k, n in enumerate(self.parameters)]

    def save(self, path: str | Path) -> Path:
        """Write to `path` (.npz: every array, `normalized` included for other tools) and the
        nominal trajectory beside it (``<stem>.trajectory.npz``); `load_sensitivities` reads
        both back."""
        path = Path(path)
        if path.suffix != ".npz":
            raise ValueError(f"sensitivities file must end in .npz; got {str(path)!r}")
        self.trajectory.save(_trajectory_path(path))
        np.savez_compressed(
            path, t=self.t, parameters=np.array(self.parameters), reference=self.reference,
            base_force=self.base_force, base_force_magnitude=self.base_force_magnitude,
            # a free linkage has no drive moment: an empty array (npz holds no None)
            crank_moment=(self.crank_moment if self.crank_moment is not None
                          else np.zeros((0, len(self.parameters)))),
            contact_force=self.contact_force, normalized=self.normalized,
            growth=self.growth if self.growth is not None else np.zeros((0, 0)),
            method=self.method, backend=self.backend,
            stats=json.dumps(self.stats, default=float))
        return path

    def column(self, name: str) -> int:
        """Index of parameter `name`."""
        if name not in self.parameters:
            raise ValueError(f"parameter {name!r} not computed; have {list(self.parameters)}")
        return self.parameters.index(name)


def _trajectory_path(path: Path) -> Path:
    return path.with_name(path.stem + ".trajectory.npz")


def load_sensitivities(path: str | Path) -> Sensitivities:
    """Read sensitivities written by `Sensitivities.save` (and the trajectory beside them).

    The file is checked against itself and its trajectory (shapes, parameter names, finite
    values, the same time grid); a bad file raises ValueError naming it and the problem.
    The stored `normalized` array is not read: it is recomputed from the rest.
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as d:
            arrays = {k: np.asarray(d[k]) for k in (
                "t", "parameters", "reference", "base_force", "base_force_magnitude",
                "crank_moment", "contact_force", "growth", "method", "backend", "stats")}
        stats = json.loads(str(arrays["stats"]))
    except (OSError, KeyError, ValueError, EOFError, json.JSONDecodeError) as exc:
        raise ValueError(f"cannot read sensitivities file {str(path)!r}: {exc}") from exc
    traj = load_trajectory(_trajectory_path(path))
    _check_loaded(path, arrays, stats, traj)
    growth = arrays["growth"].astype(float)
    return Sensitivities(
        t=arrays["t"].astype(float), parameters=tuple(str(p) for p in arrays["parameters"]),
        reference=arrays["reference"].astype(float), base_force=arrays["base_force"],
        base_force_magnitude=arrays["base_force_magnitude"],
        crank_moment=(None if traj.linkage is not None and traj.linkage.drive is None
                      else arrays["crank_moment"]),
        contact_force=arrays["contact_force"], trajectory=traj,
        method=str(arrays["method"]), backend=str(arrays["backend"]),
        growth=growth if growth.size else None, stats=stats)


def _check_loaded(path: Path, a: dict, stats: Any, traj: Trajectory) -> None:
    def fail(problem):
        return ValueError(f"inconsistent sensitivities file {str(path)!r}: {problem}")

    names = a["parameters"]
    if names.ndim != 1 or names.size == 0 or names.dtype.kind not in "US":
        raise fail("'parameters' must be a non-empty list of names")
    linkage = traj.linkage
    try:
        if linkage is None:             # a SliderCrank's: its fields
            _check_parameters(tuple(str(x) for x in names))
        else:                           # a linkage's: its dotted parameters
            allowed = set(linkage.parameter_names())
            unknown = [str(x) for x in names if str(x) not in allowed]
            if unknown:
                raise ValueError(f"unknown parameter(s) {unknown} of linkage "
                                 f"{linkage.name!r}")
    except ValueError as exc:
        raise fail(str(exc)) from exc
    n, p = a["t"].shape[0] if a["t"].ndim == 1 else -1, names.size
    joints = len(traj.joints) if linkage is not None and traj.joints else 1
    free = linkage is not None and linkage.drive is None
    shapes = {"t": (n,), "reference": (p,), "base_force": (n, 2, p),
              "base_force_magnitude": (n, p), "crank_moment": (0, p) if free else (n, p),
              "contact_force": (n, p) if joints == 1 else (n, joints, p)}
    for key, shape in shapes.items():
        arr = a[key]
        if arr.shape != shape or n < 1:
            raise fail(f"{key!r} has shape {arr.shape}, expected {shape} (n = len(t), "
                       f"p = {p} parameters)")
        if arr.dtype.kind not in "fi" or not np.all(np.isfinite(arr)):
            raise fail(f"{key!r} holds non-finite or non-numeric values")
    g = a["growth"]
    if g.size and (g.ndim != 2 or g.shape[1] != p or g.dtype.kind not in "fi"
                   or not np.all(np.isfinite(g)) or np.any(g < 0)):
        raise fail(f"'growth' must be (revolutions, {p}) finite numbers >= 0; got shape "
                   f"{g.shape}")
    if str(a["method"]) not in ("ddm", "fd"):
        raise fail(f"method must be 'ddm' or 'fd'; got {str(a['method'])!r}")
    if not isinstance(stats, dict):
        raise fail("'stats' must be a JSON object")
    if len(traj.t) != n or not np.array_equal(traj.t, a["t"]):
        raise fail(f"its time grid ({n} samples) differs from the trajectory file's "
                   f"({len(traj.t)} samples)")


def _field_names(parameters) -> bool:
    """Whether `parameters` (None: `DEFAULT_PARAMETERS`) name fields of the paper's table
    rather than dotted paths of a description."""
    names = DEFAULT_PARAMETERS if parameters is None else parameters
    names = (names,) if isinstance(names, str) else tuple(names)
    return not any(isinstance(n, str) and "." in n for n in names)


def _check_parameters(parameters) -> tuple[str, ...]:
    names = tuple(DEFAULT_PARAMETERS if parameters is None else parameters)
    if isinstance(parameters, str):
        names = (parameters,)
    if not names:
        raise ValueError("parameters must name at least one SliderCrank field")
    check_field_names(names, CONTINUOUS_FIELDS)
    if len(set(names)) != len(names):
        raise ValueError(f"parameters must not repeat a name; got {list(names)}")
    return names


#: default method of the compiled integrator for the sensitivity equations
DDM_INTEGRATOR = "dop853"


def field_directions_of(mech: SliderCrank, names):
    """The paper's fields `names` as design directions of its description
    (`linkage_ddm.Directions`): their directions through the one table
    (`mechanism.field_directions`), their values, each direction's tolerance scaled by its
    field's value (1 where zero), and the state's units in the growth diagnostic (coupler
    angle rad, slider position the clearance, rates at the crank speed; the slider's
    over L2)."""
    from ..solve.linkage_ddm import Directions

    ref = np.array([reference_value(mech, n) for n in names])
    w, c = mech.crank_speed, mech.clearance
    return Directions(field_directions(mech, names), ref,
                      np.where(ref != 0.0, np.abs(ref), 1.0),
                      np.array([1.0, c, w, w * c / mech.crank_length]))


def _fd_grid(linkage, revolutions: int | None, windows=None) -> np.ndarray:
    """The finite differences' default output times: 720 per drive revolution of
    `linkage` (a free linkage: per window of the edges `windows`)."""
    if windows is not None:
        return np.unique(np.concatenate([np.linspace(a, b, 721) for a, b in
                                         zip(windows[:-1], windows[1:])]))
    return np.linspace(0.0, revolutions * linkage.period, 720 * revolutions + 1)


def sensitivities(mech: SliderCrank, parameters=None, revolutions: int | None = None,
                  method: str = "ddm", backend: str = "reduced", *,
                  t_eval: np.ndarray | None = None, rtol: float | None = None,
                  event_time_term: bool = True, fd_relative_step: float = FD_RELATIVE_STEP,
                  executor: Executor | None = None, n_jobs: int | None = None,
                  integrator: str | None = None, **options) -> Sensitivities:
    """Sensitivities of the outputs to named SliderCrank fields.

    Parameters
    ----------
    mech : SliderCrank
    parameters : sequence of str, optional
        Continuous SliderCrank fields; default `DEFAULT_PARAMETERS` (the paper's set).
    revolutions : int, optional
        Crank revolutions simulated from t = 0 (None: 4; a free linkage takes
        ``duration=`` in s and optionally ``window=`` in s instead, see below).
    method : {"ddm", "fd"}
        Direct differentiation (reduced model only) or central finite differences (any
        backend; 2 p + 1 runs, in parallel).
    backend : str
        Model for ``method="fd"``: "reduced" or "exudyn".
    t_eval : (m,) array, optional
        Times (s) at which to report (reduced backend; the integrator lands on them).
    rtol : float, optional
        Relative tolerance of the reduced model (DDM: default 1e-7; FD: default 1e-11).
    event_time_term : bool
        DDM only: include the event-time term of the impact-velocity sensitivity. Only for
        demonstrating that it matters; leave it True.
    fd_relative_step : float, default 3e-5
        FD only: relative step, see `fd_step`.
    executor, n_jobs :
        FD only: a concurrent.futures-style executor for the perturbed runs, or the number
        of local worker processes (Exudyn runs default to 2; reduced runs run serially).
    integrator : str, optional
        Method of the compiled integrator for the reduced model ("dop853", "dopri5",
        "bs3"). Default: "dop853" for DDM (the augmented system is accuracy-limited, where
        the 8th-order pair takes 4 times fewer steps; docs/sensitivity.md), the plain
        simulation's "dopri5" for finite differences.
    **options :
        Backend options passed to `simulate` (FD), e.g. ``step_size`` for Exudyn.

    Returns
    -------
    Sensitivities

    Notes
    -----
    A `Linkage` (mbs_clearance.model.cases, any description): parameters are its dotted names
    (`Linkage.parameter_names`, default: every one that is not a point coordinate); DDM on
    its generated model's exact Jacobians (`linkage_ddm`), FD by central differences of
    plain runs that land on t_eval (default 720 per revolution), reduced backend only.
    ``start=`` (a `linkage_model.Start`, e.g. `settled_start`) runs from that state instead
    of the centred start, held fixed: the sensitivities start at zero, as finite
    differences of runs from the same start do. A free linkage (no drive) runs for
    ``duration=`` s from its `Initial` (held: its given coordinates and rates do not move
    with the parameters), its growth per window of ``window=`` s (default: the whole run);
    it has no crank moment (``crank_moment`` None).
    """
    from ..model.cases import door

    entry = door(mech)
    linkage, mech = entry.linkage, entry.paper
    # the paper's case differentiates its fields (the one table, `FIELD_PATHS`); its
    # description's dotted paths are any linkage's
    if mech is None or not _field_names(parameters):
        return _linkage_sensitivities(linkage, parameters, revolutions, method, backend,
                                      t_eval, rtol, event_time_term, fd_relative_step,
                                      integrator, options)
    names = _check_parameters(parameters)
    check_choice("method", method, ("ddm", "fd"))
    revolutions = check_int("revolutions", 4 if revolutions is None else revolutions, 1)
    check_revolutions_memory(revolutions, per_revolution=_per_revolution(method, len(names)))
    fd_relative_step = check_real("fd_relative_step", fd_relative_step, 0.0, 0.1,
                                  low_open=True, high_open=True)
    if rtol is not None:
        rtol = check_real("rtol", rtol, 1e-14, 1e-2)
    if t_eval is not None:
        t_eval = check_times("t_eval", t_eval, revolutions * mech.period)
    event_time_term = check_bool("event_time_term", event_time_term)
    if n_jobs is not None:
        n_jobs = check_int("n_jobs", n_jobs, 1)
    from ..solve.simulate import BACKENDS

    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {sorted(BACKENDS)}; got {backend!r}")
    if integrator is not None and integrator not in METHODS:
        raise ValueError(f"integrator must be one of {sorted(METHODS)}; got {integrator!r}")
    if method == "ddm":
        if backend != "reduced":
            raise ValueError("method='ddm' needs backend='reduced' (the direct "
                             "differentiation equations are those of the reduced model); use "
                             "method='fd' for other backends")
        if options:
            raise ValueError(f"unknown option(s) for method='ddm': {sorted(options)}")
        from ..solve import linkage_ddm

        sp = linkage_ddm.prepare_sensitivity(
            linkage, names, revolutions, RunSettings(rtol=rtol,
                                                     method=integrator or DDM_INTEGRATOR),
            directions=field_directions_of(mech, names), t_eval=t_eval)
        return _as_given(Sensitivities(**linkage_ddm.linkage_sensitivities(
            sp, event_time_term)), entry)
    from ..solve import linkage_ddm

    if integrator is not None and backend != "reduced":
        raise ValueError(f"integrator applies to the reduced backend only; got "
                         f"backend={backend!r}")
    if "start" in options:
        raise ValueError("start is for a description: give the paper's case "
                         "(cases.paper_slider_crank, the same case) with start=")
    along = field_directions_of(mech, names)
    if backend == "reduced":
        sp = linkage_ddm.prepare_sensitivity(
            linkage, names, revolutions, RunSettings(
                rtol=1e-11 if rtol is None else rtol, method=integrator or "dopri5"),
            directions=along, whole=False, t_eval=_fd_grid(linkage, revolutions)
            if t_eval is None else t_eval, **options)
        return _as_given(Sensitivities(**linkage_ddm.finite_differences(
            sp, fd_relative_step, executor=executor)), entry)
    if t_eval is not None:
        raise ValueError("t_eval is only supported by the reduced backend; the exudyn "
                         "backend reports its own fixed time steps")
    if backend == "exudyn" and options.get("step_size", 2e-6) > 7.5e-7:
        # measured: docs/sensitivity.md "DDM against finite differences of the Exudyn model"
        logging.getLogger("mbs_clearance").warning(
            f"finite differences through Exudyn at step {options.get('step_size', 2e-6):g} s "
            "are coarse (the paper's case at the default 2e-6 s: 15-19 % RMS off the DDM "
            "sensitivities); step_size=5e-7 gives about 1 % (4 times the run time)")
    sp = linkage_ddm.prepare_sensitivity(linkage, names, revolutions, directions=along)
    return Sensitivities(**linkage_ddm.finite_differences(
        sp, fd_relative_step, backend=backend, as_paper=True, executor=executor,
        n_jobs=n_jobs, options=options))


def _as_given(sens: Sensitivities, entry) -> Sensitivities:
    """Sensitivities as the user gave the mechanism (`cases.door`): a `SliderCrank`'s
    trajectory in the paper's names (`reduced.paper_series`), without the description's
    per-output derivatives; a linkage's as they are."""
    if not entry.given_as_paper:
        return sens
    import dataclasses

    traj = annotate(reduced.paper_series(sens.trajectory, entry.paper))
    # one record of the run's counters and the trajectory's notes, as the run's own
    return dataclasses.replace(sens, trajectory=traj, outputs=None, stats=traj.stats)


def _per_revolution(method: str, p: int) -> int:
    """Bytes per revolution that a sensitivity run holds beyond any run's: DDM's growth
    diagnostic (p floats), finite differences' default output times (720 floats)."""
    return 8 * p if method == "ddm" else 8 * 720


def _linkage_sensitivities(linkage, parameters, revolutions, method, backend, t_eval, rtol,
                           event_time_term, fd_relative_step, integrator, options):
    """`sensitivities` of a Linkage: arguments checked here, the work in linkage_ddm."""
    from ..solve import linkage_ddm

    allowed = linkage.parameter_names()
    if parameters is None:
        names = tuple(n for n in allowed if not n.endswith((".x", ".y")))
    else:
        names = (parameters,) if isinstance(parameters, str) else tuple(parameters)
    if not names:
        raise ValueError(f"parameters must name at least one of {list(allowed)}")
    for name in names:
        if name not in allowed:
            raise ValueError(f"unknown parameter {name!r} of linkage {linkage.name!r}; the "
                             f"parameters are {list(allowed)}")
    if len(set(names)) != len(names):
        raise ValueError(f"parameters must not repeat a name; got {list(names)}")
    from ..solve.linkage_model import check_span, time_edges

    check_choice("method", method, ("ddm", "fd"))
    duration, window = options.pop("duration", None), options.pop("window", None)
    revolutions = check_span(linkage, revolutions, duration, window)
    windows = None
    if revolutions is None:         # a free linkage: time windows
        if duration is None:
            raise ValueError(f"linkage {linkage.name!r} is free (drive=None): give the "
                             "sensitivities' duration= in s (and optionally window= in s)")
        windows = time_edges(duration, window)
        check_revolutions_memory(len(windows) - 1, name="windows",
                                 per_revolution=_per_revolution(method, len(names)))
    else:
        check_revolutions_memory(revolutions,
                                 per_revolution=_per_revolution(method, len(names)))
    if backend != "reduced":
        raise ValueError(f"a Linkage's sensitivities need backend='reduced'; got {backend!r}")
    start = options.pop("start", None)
    if options:
        raise ValueError(f"unknown option(s) for a Linkage: {sorted(options)} (allowed: "
                         "start; duration, window for a free linkage)")
    if rtol is not None:
        rtol = check_real("rtol", rtol, 1e-14, 1e-2)
    if t_eval is not None:
        t_eval = check_times("t_eval", t_eval, windows[-1] if windows is not None
                             else revolutions * linkage.period)
    event_time_term = check_bool("event_time_term", event_time_term)
    fd_relative_step = check_real("fd_relative_step", fd_relative_step, 0.0, 0.1,
                                  low_open=True, high_open=True)
    if integrator is not None and integrator not in METHODS:
        raise ValueError(f"integrator must be one of {sorted(METHODS)}; got {integrator!r}")
    if method == "ddm":
        settings = RunSettings(rtol=rtol, method=integrator or linkage_ddm.DDM_INTEGRATOR)
    else:
        settings = RunSettings(rtol=1e-11 if rtol is None else rtol,
                               method=integrator or "dopri5")
        if t_eval is None:
            t_eval = _fd_grid(linkage, revolutions, windows)
    sp = linkage_ddm.prepare_sensitivity(linkage, names, revolutions, settings,
                                         duration=duration, window=window, t_eval=t_eval,
                                         start=start)
    if method == "ddm":
        return Sensitivities(**linkage_ddm.linkage_sensitivities(sp, event_time_term))
    return Sensitivities(**linkage_ddm.finite_differences(sp, fd_relative_step))
