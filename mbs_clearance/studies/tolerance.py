"""Manufacturing tolerances and wear: global sensitivity and the probability of exceeding a
load over a production batch.

`tolerance_study(inputs, ...)` takes an uncertainty description (each input a distribution:
`Uniform` over a tolerance band, `Normal` with a sigma, or `FitClearance`, the radial
clearance of an ISO 286 fit, `mbs_clearance.model.fits`) and an output (the rev-k peak of |F12|,
the RMS drive moment, the max contact force, or any function of the inputs), and computes

- Sobol first- and total-order indices with bootstrap confidence intervals (SALib; Saltelli
  sampling on a scrambled Sobol sequence), and Morris' mu* (SALib);
- DGSM (derivative-based global sensitivity measures) nu_i = E[(dY/dx_i)^2] from the exact
  gradients of the peak (`peak_gradient`, DDM), with the bound of the total Sobol index
  S_T,i <= C_i nu_i / V (Sobol & Kucherenko 2009; Lamboni et al. 2013), C_i the Poincare
  constant of input i: (b - a)^2 / pi^2 for a uniform or any log-concave density on [a, b]
  (Payne & Weinberger 1960), sigma^2 for a normal;
- Monte Carlo of the output distribution and P(Y > allowable) with its Clopper-Pearson
  interval; a wear study: the same statistics as the radial clearance grows by given
  amounts.

Inputs are sampled in the unit cube (SALib, seeded) and mapped through each distribution's
quantile function, so that the same seed gives the same designs and, every run being
deterministic, the same indices on any executor (`executor.evaluate`: threads, processes,
dask). Runs whose motion is not periodic (a rattling contact, `reduced.RATTLING`; or
``stats["periodic"] is False``) are counted; their output is a statistic over revolutions
2..k (the max of the per-revolution peaks, the RMS over those revolutions) instead of
revolution k alone. Runs flagged by the accuracy or physics checks (``accuracy_ok`` False,
``penetration_meaningless``) are counted and reported.

The study is four steps, as in SALib, each a function of its own: `describe` (the inputs,
the nominal design, the output: a `ToleranceProblem`, checked before any run), `sample` (a
`ToleranceSample` of one method: "sobol", "morris" or "monte_carlo"), `evaluate` (the runs:
an `Evaluation`) and `analyse` (the indices or statistics of that method).
`tolerance_study` does the four for every method asked, plus DGSM and wear, in one call.

Design fields are read and written through `field_value` / `with_values` only (name -> value,
replace), so that a general mechanism description can take the place of `SliderCrank`.
"""

from __future__ import annotations

import math
import numbers
import threading
import time
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._checks import DESIGN_BYTES, check_memory, check_revolutions_memory
from .._warnings import AccuracyWarning, PhysicsWarning
from ..model.cases import door
from ..model.design import value_at
from ..model.fits import iso_fit
from ..model.linkage import Linkage
from ..model.mechanism import CONTINUOUS_FIELDS, SliderCrank
from .executor import _THREAD_SAFE_BACKENDS
from .executor import evaluate as _evaluate_all

__all__ = ["tolerance_study", "ToleranceResult", "Uniform", "Normal", "FitClearance",
           "OUTPUTS", "field_value", "with_values", "band", "read_inputs",
           "ToleranceProblem", "ToleranceSample", "Evaluation", "describe", "sample",
           "evaluate", "analyse", "SAMPLERS"]

#: built-in outputs of a run: the rev-k peak of the mechanism's default output
#: (`Linkage.default_output`, the paper's |F12|; peak-only run), the RMS of the drive
#: moment over revolution k, the max contact force over revolution k (recorded runs)
OUTPUTS = ("peak", "rms_drive_moment", "max_contact_force")
#: what each named output is, and its unit
OUTPUT_LABELS = {"peak": ("max |F12|", "N"), "rms_drive_moment": ("RMS drive moment", "N m"),
                 "max_contact_force": ("max contact force", "N")}

#: derived input: the radial clearance R_B - R_J (set by moving the journal radius)
CLEARANCE = "radial_clearance"

_FORMAT = "mbs_clearance.studies.tolerance/1"

#: quantiles are taken at u clipped to [EPS, 1 - EPS] (the normal's tails are infinite)
_U_EPS = 1e-12


# ----------------------------------------------------------------------- distributions

def _real(name: str, value, positive: bool = False) -> float:
    if not isinstance(value, numbers.Real) or isinstance(value, bool) \
            or not math.isfinite(value) or (positive and value <= 0):
        raise ValueError(f"{name} must be a finite number{' > 0' if positive else ''}; "
                         f"got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Uniform:
    """Uniform over [low, high] (a tolerance band)."""

    low: float
    high: float

    def __post_init__(self):
        _real("Uniform.low", self.low)
        _real("Uniform.high", self.high)
        if not self.low < self.high:
            raise ValueError(f"Uniform needs low < high; got ({self.low!r}, {self.high!r})")

    def ppf(self, u: np.ndarray) -> np.ndarray:
        return self.low * (1.0 - u) + self.high * u

    @property
    def poincare(self) -> float:
        """Poincare constant C: Var f <= C E[f'^2] for every smooth f."""
        return (self.high - self.low) ** 2 / math.pi**2

    def describe(self) -> dict:
        return {"kind": "uniform", "low": self.low, "high": self.high}


def band(nominal: float, tolerance: float) -> Uniform:
    """Uniform over the tolerance band nominal +- tolerance."""
    _real("nominal", nominal)
    tolerance = _real("tolerance", tolerance, positive=True)
    return Uniform(nominal - tolerance, nominal + tolerance)


@dataclass(frozen=True)
class Normal:
    """Normal with mean and standard deviation sigma (> 0)."""

    mean: float
    sigma: float

    def __post_init__(self):
        _real("Normal.mean", self.mean)
        _real("Normal.sigma", self.sigma, positive=True)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        from scipy.special import ndtri

        return self.mean + self.sigma * ndtri(np.clip(u, _U_EPS, 1.0 - _U_EPS))

    @property
    def poincare(self) -> float:
        return self.sigma**2

    def describe(self) -> dict:
        return {"kind": "normal", "mean": self.mean, "sigma": self.sigma}


@dataclass(frozen=True)
class FitClearance:
    """The radial clearance of an ISO 286 fit at a nominal diameter (m).

    shape "trapezoid" (default): hole and shaft diameters independent and uniform over their
    tolerance zones, the clearance their half difference (a trapezoidal density); "uniform":
    uniform between the minimum and maximum clearance (the worst-case band).
    """

    fit: str
    diameter: float
    shape: str = "trapezoid"

    def __post_init__(self):
        if self.shape not in ("trapezoid", "uniform"):
            raise ValueError(f"FitClearance.shape must be 'trapezoid' or 'uniform'; "
                             f"got {self.shape!r}")
        lo, _ = self.limits
        if lo <= 0:
            raise ValueError(f"fit {self.fit!r} has a minimum clearance of 0; the model needs "
                             "a clearance > 0 (use a fit with a clearance, e.g. H7/g6)")

    @property
    def iso(self):
        return iso_fit(self.fit, self.diameter)

    @property
    def limits(self) -> tuple[float, float]:
        """(min, max) radial clearance, m."""
        return self.iso.radial_clearance

    def ppf(self, u: np.ndarray) -> np.ndarray:
        lo, hi = self.limits
        if self.shape == "uniform":
            return lo * (1.0 - u) + hi * u
        f = self.iso
        # radial clearance = lo + (A + B) / 2, A ~ U(0, hole IT), B ~ U(0, shaft IT)
        a = (f.hole[1] - f.hole[0]) / 2.0
        b = (f.shaft[1] - f.shaft[0]) / 2.0
        w1, w2 = min(a, b), max(a, b)
        u = np.asarray(u, dtype=float)
        t = np.where(u <= w1 / (2 * w2), np.sqrt(2 * a * b * u),
                     np.where(u <= 1 - w1 / (2 * w2), u * w2 + w1 / 2,
                              w1 + w2 - np.sqrt(2 * a * b * np.clip(1 - u, 0.0, 1.0))))
        return lo + t

    @property
    def poincare(self) -> float:
        # log-concave on [lo, hi] (a convolution of uniforms): C <= (hi - lo)^2 / pi^2
        lo, hi = self.limits
        return (hi - lo) ** 2 / math.pi**2

    def describe(self) -> dict:
        lo, hi = self.limits
        return {"kind": "fit", "fit": self.fit, "diameter": self.diameter,
                "shape": self.shape, "low": lo, "high": hi}


_DISTRIBUTIONS = (Uniform, Normal, FitClearance)


def read_inputs(path: str | Path) -> dict[str, Any]:
    """Input distributions from a file: a JSON object {name: {"uniform": [lo, hi]} |
    {"band": [nominal, tol]} | {"normal": [mean, sigma]} | {"fit": "H7/g6", "diameter": d,
    "shape": "trapezoid"}}, or a SALib parameter file (lines NAME LOW HIGH: uniform;
    blank lines and lines starting with # ignored)."""
    from .._io import parse_json, read_text

    path = Path(path)
    text = read_text(path, "the inputs file")       # at most _io.MAX_INPUT_BYTES
    if text.lstrip().startswith("{"):
        data = parse_json(text, path, "the inputs file")
        return {str(k): _from_spec(str(k), v) for k, v in data.items()}
    out = {}
    for no, line in enumerate(text.splitlines(), 1):
        parts = line.split()
        if not parts or parts[0].startswith("#"):
            continue
        try:
            out[parts[0]] = Uniform(float(parts[1]), float(parts[2]))
        except (IndexError, ValueError) as exc:
            raise ValueError(f"{str(path)!r} line {no}: expected NAME LOW HIGH with LOW < "
                             f"HIGH; got {line.strip()!r} ({exc})") from None
    if not out:
        raise ValueError(f"{str(path)!r} holds no inputs")
    return out


def _from_spec(name: str, spec) -> Any:
    kinds = ("uniform", "band", "normal", "fit")
    if not isinstance(spec, dict) or not any(k in spec for k in kinds):
        raise ValueError(f"input {name!r}: expected an object with one of {list(kinds)}; "
                         f"got {spec!r}")
    try:
        if "fit" in spec:
            return FitClearance(spec["fit"], spec["diameter"], spec.get("shape", "trapezoid"))
        kind = next(k for k in kinds if k in spec)
        if not isinstance(spec[kind], list) or len(spec[kind]) != 2:
            raise ValueError(f"{kind!r} needs a list of two numbers")
        a, b = spec[kind]
        return {"uniform": Uniform, "band": band, "normal": Normal}[kind](a, b)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"input {name!r}: bad specification {spec!r} ({exc})") from None


# ----------------------------------------------------------------------- field access

def _linkage_name(name: str) -> str:
    """A Linkage's design name of an input ("radial_clearance": every clearance)."""
    return "clearance" if name == CLEARANCE else name


def field_value(mech: SliderCrank | Linkage, name: str) -> float:
    """The value of design field `name` (SI; "radial_clearance" = R_B - R_J; a Linkage's
    names: `design`, "radial_clearance" its smallest clearance)."""
    return value_at(mech, _linkage_name(name))


def with_values(mech: SliderCrank, values: Mapping[str, float]) -> SliderCrank:
    """`mech` with the fields `values` replaced ("radial_clearance" moves the journal
    radius, after any new bearing radius); a Linkage through `design.linkage_with`
    ("radial_clearance" sets every clearance)."""
    if isinstance(mech, Linkage):
        from ..model.design import linkage_with

        return linkage_with(mech, {_linkage_name(k): v for k, v in values.items()})
    changes = {k: float(v) for k, v in values.items() if k != CLEARANCE}
    if CLEARANCE in values:
        rb = changes.get("bearing_radius", mech.bearing_radius)
        changes["journal_radius"] = rb - float(values[CLEARANCE])
    return mech.replace(**changes)


def _gradient_names(names: tuple[str, ...], mech) -> tuple[tuple[str, ...], np.ndarray]:
    """Fields to differentiate and the chain-rule matrix: d/d(input) = J @ d/d(field) (a
    Linkage's inputs are its design names)."""
    if isinstance(mech, Linkage):
        return tuple(_linkage_name(n) for n in names), np.eye(len(names))
    fields = []
    for n in names:
        f = "journal_radius" if n == CLEARANCE else n
        if f not in fields:
            fields.append(f)
    J = np.zeros((len(names), len(fields)))
    for i, n in enumerate(names):
        if n == CLEARANCE:
            J[i, fields.index("journal_radius")] = -1.0       # R_J = R_B - c
        else:
            J[i, fields.index(n)] = 1.0
            if n == "bearing_radius" and CLEARANCE in names:
                J[i, fields.index("journal_radius")] = 1.0    # R_J follows R_B at fixed c
    return tuple(fields), J


# ----------------------------------------------------------------------- one run

@dataclass(frozen=True)
class _Task:
    """Picklable description of the output of one design."""

    output: str | Callable
    revolution: int
    backend: str
    options: dict
    window: float | None = None


def _quiet(fn, *args):
    """Call `fn` with the library's accuracy/physics warnings silenced where that is safe
    (the main thread of a worker process; in threads the caller has silenced them): their
    content is in the stats, which are counted."""
    if threading.current_thread() is threading.main_thread():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AccuracyWarning)
            warnings.simplefilter("ignore", PhysicsWarning)
            return fn(*args)
    return fn(*args)


def _run_one(item, task: _Task) -> tuple[float, bool | None, bool, bool]:
    """(value, chaotic, flagged, failed) of one design: a SliderCrank, or a dict of input
    values for a function output."""
    if callable(task.output):
        try:
            return float(task.output(item)), None, False, False
        except (ValueError, ArithmeticError):
            return math.nan, None, False, True
    try:
        return _quiet(_mechanism_output, item, task)
    except (RuntimeError, ValueError):
        return math.nan, None, False, True


def _span(k: int) -> range:
    """Revolutions (0-based) over which a chaotic run's statistic is taken: 2..k."""
    return range(min(1, k - 1), k)


def _mechanism_output(mech: SliderCrank | Linkage, task: _Task):
    k = task.revolution
    if isinstance(mech, Linkage) and task.output not in OUTPUTS[1:]:
        from ..analysis.objective import _linkage_peak, parse_output

        out = parse_output(mech, None if task.output == "peak" else task.output)
        return _linkage_peak(mech, out, k, task.options, task.window)[0], None, False, False
    if task.output == "peak" and task.options.get("accuracy") is None:
        if task.backend == "reduced":
            from ..solve.reduced import RATTLING, run

            out = run(mech, k, record=False, **task.options)
            peaks, counters = out.peaks, out.counters
            chaotic = bool(counters[3] > RATTLING * k)
            value = max(peaks[j] for j in _span(k)) if chaotic else peaks[k - 1]
            return float(value), chaotic, chaotic, False
        from ..solve.simulate import peak_base_force

        return float(peak_base_force(mech, k, task.backend, **task.options)), None, False, \
            False
    from ..solve.simulate import simulate

    traj = simulate(mech, k, task.backend, **task.options)
    st = traj.stats
    chaotic = None if st.get("periodic") is None else not st["periodic"]
    flagged = (st.get("accuracy_ok") is False) or bool(st.get("penetration_meaningless"))
    revs = list(_span(k)) if chaotic else [k - 1]
    mask = np.zeros(len(traj.t), dtype=bool)
    for j in revs:
        mask |= traj.revolution_mask(j + 1)
    t = traj.t[mask]
    if task.output == "peak":
        from ..solve.accuracy import revolution_peaks

        value = float(max(revolution_peaks(traj)[j] for j in revs))
    elif task.output == "rms_drive_moment":
        m2 = traj.crank_moment[mask] ** 2
        value = math.sqrt(np.sum(0.5 * (m2[1:] + m2[:-1]) * np.diff(t)) / (t[-1] - t[0]))
    else:
        value = float(np.max(traj.contact_force[mask]))
    return value, chaotic, flagged, False


def _grad_one(mech: SliderCrank | Linkage, fields: tuple[str, ...], revolution: int,
              window: float | None = None):
    """(peak, gradient over `fields`, kink) of one design; NaNs where it fails."""
    from functools import partial

    from ..analysis.objective import peak_gradient

    try:
        g = _quiet(partial(peak_gradient, window=window), mech, fields, revolution)
    except (RuntimeError, ValueError):
        return math.nan, np.full(len(fields), math.nan), False
    return float(g.peak), np.asarray(g.gradient, dtype=float), bool(g.kink)


# ----------------------------------------------------------------------- the result

@dataclass(frozen=True, eq=False)
class ToleranceResult:
    """Outcome of `tolerance_study`.

    Attributes
    ----------
    names : input names (design fields, "radial_clearance", or a function's arguments)
    distributions : name -> description of its distribution
    output : the output's name
    sobol : {"S1", "S1_conf", "ST", "ST_conf", "S2", "S2_conf", "N", "runs", ...} or {}
    morris : {"mu_star", "mu_star_conf", "sigma", "trajectories", "runs", ...} or {}
    dgsm : {"nu", "bound", "poincare", "variance", "runs", "kinks", ...} or {}
    monte_carlo : {"values", "mean", "std", "quantiles", "p_exceed", "p_exceed_ci", ...}
    wear : one dict per wear level (radial clearance added, m) with the same statistics
    counts : runs, failed, chaotic (not periodic), flagged (accuracy/physics) over the study
    notes : sentences on what the counts mean for the result
    settings : everything needed to repeat the study (seed, sizes, model, executor)
    elapsed : wall time, s
    """

    names: tuple[str, ...]
    distributions: dict[str, dict]
    output: str
    sobol: dict[str, Any] = field(default_factory=dict)
    morris: dict[str, Any] = field(default_factory=dict)
    dgsm: dict[str, Any] = field(default_factory=dict)
    monte_carlo: dict[str, Any] = field(default_factory=dict)
    wear: list[dict[str, Any]] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    settings: dict[str, Any] = field(default_factory=dict)
    elapsed: float = 0.0

    def ranking(self, method: str = "sobol") -> list[str]:
        """Inputs from the most to the least influential: by S_T ("sobol"), mu* ("morris")
        or the DGSM bound ("dgsm")."""
        key = {"sobol": ("sobol", "ST"), "morris": ("morris", "mu_star"),
               "dgsm": ("dgsm", "bound")}
        if method not in key:
            raise ValueError(f"method must be one of {list(key)}; got {method!r}")
        block, name = key[method]
        values = getattr(self, block).get(name)
        if values is None:
            raise ValueError(f"the study did not compute {method!r}")
        order = np.argsort(-np.asarray(values, dtype=float), kind="stable")
        return [self.names[i] for i in order]

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-serialisable dict."""
        return _jsonable({
            "format": _FORMAT, "names": list(self.names), "distributions": self.distributions,
            "output": self.output, "sobol": self.sobol, "morris": self.morris,
            "dgsm": self.dgsm, "monte_carlo": self.monte_carlo, "wear": self.wear,
            "counts": self.counts, "notes": self.notes, "settings": self.settings,
            "elapsed": self.elapsed})

    def to_json(self, path: str | Path) -> Path:
        """Write the result to `path` (JSON); returns the path."""
        from .._io import write_json_object

        return write_json_object(path, self.to_dict())

    @classmethod
    def from_json(cls, path: str | Path) -> ToleranceResult:
        """Read a result written by `to_json` (arrays as lists)."""
        from .._io import read_json_object

        data = read_json_object(path, "tolerance study")
        if data.get("format") != _FORMAT:
            raise ValueError(f"{str(path)!r} is not a tolerance study ({_FORMAT})")
        return cls(names=tuple(data["names"]), distributions=data["distributions"],
                   output=data["output"], sobol=data["sobol"], morris=data["morris"],
                   dgsm=data["dgsm"], monte_carlo=data["monte_carlo"], wear=data["wear"],
                   counts=data["counts"], notes=data["notes"], settings=data["settings"],
                   elapsed=float(data["elapsed"]))

    @property
    def output_unit(self) -> str:
        """The output's unit ("" for a user's function)."""
        return OUTPUT_LABELS.get(self.output, ("", _linkage_unit(self.output)))[1]

    @property
    def output_label(self) -> str:
        """``peak of pivot_force:crank_pivot over revolution 4 (N)``: what the output is,
        by name (the built-in "peak": the mechanism's default output), with its unit."""
        what, unit = OUTPUT_LABELS.get(self.output, (f"peak of {self.output}",
                                                     _linkage_unit(self.output)))
        if self.output == "peak" and self.settings.get("default_output"):
            what = f"peak of {self.settings['default_output']}"
        rev, win = self.settings.get("revolution"), self.settings.get("window")
        span = (f" over time window {rev} of {win:g} s" if win is not None
                else f" over revolution {rev}" if rev is not None else "")
        return (what + span
                + (f" ({unit})" if unit else ""))

    def summary(self) -> str:
        """A few lines of text: indices, probabilities, counts and notes."""
        from ..units import number

        def val(v, digits=5):
            return number(v, digits) + (f" {self.output_unit}" if self.output_unit else "")

        lines = [f"output: {self.output_label}; inputs: {', '.join(self.names)}"]
        w = max(len(n) for n in self.names)
        if self.sobol:
            lines.append(f"Sobol (N = {self.sobol['N']}, {self.sobol['runs']} runs)")
            if "S1" not in self.sobol:
                lines.append(f"  indices not computed: {self.sobol.get('failed', 0)} runs "
                             "failed")
            else:
                lines.append(f"  {'':<{w}}  {'S1 +- conf':>16}  {'ST +- conf':>16}")
            for i, n in enumerate(self.names if "S1" in self.sobol else ()):
                lines.append(f"  {n:<{w}}  {_index(self.sobol['S1'][i])} +- "
                             f"{self.sobol['S1_conf'][i]:.3f}  {_index(self.sobol['ST'][i])} +- "
                             f"{self.sobol['ST_conf'][i]:.3f}")
        if self.morris:
            lines.append(f"Morris ({self.morris['runs']} runs): mu*, the mean change of the "
                         "output over each input's full range")
            if "mu_star" not in self.morris:
                lines.append(f"  indices not computed: {self.morris.get('failed', 0)} runs "
                             "failed")
            for i, n in enumerate(self.names if "mu_star" in self.morris else ()):
                lines.append(f"  {n:<{w}}  {val(self.morris['mu_star'][i], 4)} +- "
                             f"{val(self.morris['mu_star_conf'][i], 2)}")
        if self.dgsm:
            lines.append(f"DGSM ({self.dgsm['runs']} gradient runs): bound on S_T")
            for i, n in enumerate(self.names):
                lines.append(f"  {n:<{w}}  {number(self.dgsm['bound'][i], 4)}")
        for label, mc in [("Monte Carlo", self.monte_carlo)] + [
                (f"wear +{lv['wear'] * 1e6:.3g} \N{MICRO SIGN}m", lv) for lv in self.wear]:
            if not mc:
                continue
            line = (f"{label} ({mc['runs']} runs): mean {val(mc['mean'])}, std "
                    f"{val(mc['std'], 3)}, 5-95 % [{val(mc['quantiles']['0.05'])}, "
                    f"{val(mc['quantiles']['0.95'])}]")
            if mc.get("p_exceed") is not None:
                lo, hi = mc["p_exceed_ci"]
                line += (f", P(> {val(mc['allowable'], 6)}) = {mc['p_exceed']:.4f} "
                         f"[{lo:.4f}, {hi:.4f}]")
            lines.append(line)
        c = self.counts
        lines.append(f"runs {c.get('runs', 0)}, failed {c.get('failed', 0)}, not periodic "
                     f"{c.get('chaotic', 0)}, flagged {c.get('flagged', 0)}")
        lines.extend(f"NOTE: {n}" for n in self.notes)
        return "\n".join(lines)


def _linkage_unit(output: str) -> str:
    """The unit of a Linkage output name ("" for anything else)."""
    from ..analysis.objective import OUTPUT_KINDS

    kind = output.partition(":")[0] if isinstance(output, str) else ""
    return OUTPUT_KINDS[kind][1] if kind in OUTPUT_KINDS else ""


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return None if not math.isfinite(obj) else float(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


# ----------------------------------------------------------------------- the driver

class _Study:
    """Inputs, output and executor of one study; maps unit-cube rows to output values."""

    def __init__(self, names, dists, base, task, executor, workers, progress):
        self.names, self.dists, self.base, self.task = names, dists, base, task
        self.executor, self.workers, self.progress = executor, workers, progress
        self.counts = {"runs": 0, "failed": 0, "chaotic": 0, "flagged": 0}

    def physical(self, U: np.ndarray) -> np.ndarray:
        U = np.atleast_2d(np.asarray(U, dtype=float))
        return np.column_stack([self.dists[n].ppf(U[:, j]) for j, n in enumerate(self.names)])

    def items(self, X: np.ndarray, extra: Mapping[str, float] | None = None) -> list:
        rows = [dict(zip(self.names, map(float, x))) for x in X]
        if extra:
            rows = [{**r, **{k: r.get(k, field_value(self.base, k)) + v
                             for k, v in extra.items()}} for r in rows]
        if callable(self.task.output):
            return rows
        out = []
        for r in rows:
            try:
                out.append(with_values(self.base, r))
            except ValueError:
                out.append(None)        # an invalid design (e.g. a normal's tail): failed
        return out

    def values(self, X: np.ndarray, desc: str, extra=None) -> tuple[np.ndarray, np.ndarray]:
        """Output of each row of physical inputs `X`; and whether each run was chaotic."""
        items = self.items(X, extra)
        ok = [i for i, it in enumerate(items) if it is not None]
        thread_safe = self.task.backend in _THREAD_SAFE_BACKENDS
        with warnings.catch_warnings():
            # the worker threads share this process's filters: the warnings' content is in
            # the stats, which are counted
            warnings.simplefilter("ignore", AccuracyWarning)
            warnings.simplefilter("ignore", PhysicsWarning)
            res = _evaluate_all(_run_one, [items[i] for i in ok], (self.task,),
                           executor=self.executor, workers=self.workers,
                           thread_safe=thread_safe, progress=self.progress, desc=desc)
        y = np.full(len(items), math.nan)
        chaotic = np.zeros(len(items), dtype=bool)
        self.counts["runs"] += len(items)
        self.counts["failed"] += len(items) - len(ok)
        for i, (v, c, f, failed) in zip(ok, res):
            y[i] = v
            chaotic[i] = bool(c)
            self.counts["chaotic"] += bool(c)
            self.counts["flagged"] += bool(f)
            self.counts["failed"] += bool(failed)
        return y, chaotic


def _check_inputs(inputs, output, mech=None) -> tuple[tuple[str, ...], dict]:
    if not isinstance(inputs, Mapping) or not inputs:
        raise ValueError("inputs must be a non-empty dict {name: distribution}; "
                         f"got {inputs!r}")
    allowed = (*CONTINUOUS_FIELDS, CLEARANCE)
    if isinstance(mech, Linkage) and not callable(output):
        from ..model.design import check_names

        check_names(mech, [_linkage_name(n) for n in inputs], "input")
    for name, dist in inputs.items():
        if not callable(output) and name not in allowed and not isinstance(mech, Linkage):
            raise ValueError(f"unknown input {name!r}; allowed: {list(allowed)}")
        if not isinstance(dist, _DISTRIBUTIONS):
            raise ValueError(f"input {name!r} must be a Uniform, Normal or FitClearance; "
                             f"got {dist!r}")
        if isinstance(dist, FitClearance) and name != CLEARANCE and not callable(output):
            raise ValueError(f"a FitClearance describes {CLEARANCE!r}; got it for {name!r}")
    if not callable(output) and CLEARANCE in inputs and "journal_radius" in inputs:
        raise ValueError(f"give either {CLEARANCE!r} or 'journal_radius', not both")
    return tuple(inputs), dict(inputs)


#: a Normal input is checked over mean +- NORMAL_CHECK_SIGMAS sigma (all but 5.7e-7 of its
#: draws); rarer draws outside the field's range make invalid designs, counted as failed runs
NORMAL_CHECK_SIGMAS = 5.0


def _support(dist) -> tuple[float, float]:
    """The range of values a distribution is checked over (see NORMAL_CHECK_SIGMAS)."""
    if isinstance(dist, Normal):
        return (dist.mean - NORMAL_CHECK_SIGMAS * dist.sigma,
                dist.mean + NORMAL_CHECK_SIGMAS * dist.sigma)
    if isinstance(dist, FitClearance):
        return dist.limits
    return dist.low, dist.high


def _describe(dist) -> str:
    if isinstance(dist, Normal):
        return (f"normal({dist.mean:g}, {dist.sigma:g}) over mean +- "
                f"{NORMAL_CHECK_SIGMAS:g} sigma")
    if isinstance(dist, FitClearance):
        return f"fit {dist.fit} on {dist.diameter:g} m"
    return f"uniform [{dist.low:g}, {dist.high:g}]"


def _corners(names, dists):
    """The corners of the inputs' box (at most 2**12; beyond, its two extreme corners)."""
    import itertools

    ranges = {n: _support(dists[n]) for n in names}
    if len(names) <= 12:
        return ranges, itertools.product(*(ranges[n] for n in names))
    return ranges, [tuple(r[0] for r in ranges.values()), tuple(r[1] for r in ranges.values())]


def _check_ranges(mech: SliderCrank | Linkage, names, dists) -> None:
    """ValueError, before any sample is drawn, if an input's distribution leaves the valid
    range of a design field: every input at both ends of its range with the others nominal,
    then every corner of the inputs' box (SliderCrank's constraints are linear in the
    fields, so the box is valid when its corners are)."""
    ranges, corners = _corners(names, dists)
    for n in names:
        for v in ranges[n]:
            try:
                with_values(mech, {n: v})
            except ValueError as exc:
                raise ValueError(f"input {n!r}: {_describe(dists[n])} reaches {v:.6g}, "
                                 f"outside the design's valid range ({exc})") from None
    for corner in corners:
        row = dict(zip(names, corner))
        try:
            with_values(mech, row)
        except ValueError as exc:
            raise ValueError(f"inputs {list(names)} together reach an invalid design at "
                             f"{_short(row)} ({exc}); narrow their ranges") from None


def _check_wear(mech: SliderCrank | Linkage, names, dists, worst: float) -> None:
    """ValueError, before any sample is drawn, if the largest wear `worst` added to the
    radial clearance at a corner of the inputs' box (`describe` checked the box itself)
    leaves the design's valid range."""
    for corner in _corners(names, dists)[1]:
        row = dict(zip(names, corner))
        worn = {**row, CLEARANCE: row.get(CLEARANCE, field_value(with_values(mech, row),
                                                                CLEARANCE)) + worst}
        try:
            with_values(mech, worn)
        except ValueError as exc:
            raise ValueError(f"wear {worst:g} m leaves the design's valid range: radial "
                             f"clearance {worn[CLEARANCE]:.6g} m at {_short(row)} "
                             f"({exc})") from None


def _short(row: Mapping[str, float]) -> str:
    return "{" + ", ".join(f"{k}: {v:.6g}" for k, v in row.items()) + "}"


def _run_bytes(d: int) -> int:
    """Bytes per run of a study held at once: its inputs (unit and physical, two float64
    per input), its design (`_checks.DESIGN_BYTES`), its row dict and its result tuple."""
    return 16 * d + DESIGN_BYTES + 100 * d + 250


def study_memory(d: int, *, sobol: int = 0, second_order: bool = True, morris: int = 0,
                 dgsm: int = 0, monte_carlo: int = 0, wear_levels: int = 0,
                 max_memory: int | None = None) -> int:
    """Estimated peak memory (bytes) of a tolerance study over `d` inputs: the largest
    sample held at once (Sobol N (2 d + 2) or N (d + 2) runs, Morris r (d + 1), DGSM n,
    Monte Carlo n) at `_run_bytes` each, plus the kept outputs of every run;
    `MemoryLimitError` naming the sample size above `max_memory` (None: the default)."""
    sizes = {"sobol": sobol, "morris": morris, "dgsm": dgsm, "monte_carlo": monte_carlo}
    runs = {"sobol": sobol * ((2 * d + 2) if second_order else (d + 2)),
            "morris": morris * (d + 1), "dgsm": dgsm, "monte_carlo": monte_carlo}
    outputs = 8 * (sum(runs.values()) + monte_carlo * wear_levels)
    name, largest = max(runs.items(), key=lambda kv: kv[1])
    need = largest * _run_bytes(d) + outputs
    check_memory(f"{name}={sizes[name]} ({largest} runs over {d} inputs): the study needs",
                 need, max_memory, f"use a smaller {name} sample")
    return need


def _count(name: str, value, minimum: int) -> int:
    if not isinstance(value, numbers.Integral) or isinstance(value, bool) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def _stats(y: np.ndarray, chaotic: np.ndarray, allowable: float | None,
           confidence: float) -> dict[str, Any]:
    from scipy.stats import binomtest

    good = y[np.isfinite(y)]
    out: dict[str, Any] = {"runs": len(y), "failed": int(len(y) - len(good)),
                           "chaotic_fraction": float(np.mean(chaotic)) if len(y) else 0.0,
                           "values": y}
    if not len(good):
        return {**out, "mean": math.nan, "std": math.nan,
                "quantiles": {q: math.nan for q in ("0.05", "0.5", "0.95")}}
    out.update(mean=float(np.mean(good)), std=float(np.std(good, ddof=1)) if len(good) > 1
               else 0.0, quantiles={str(q): float(np.quantile(good, q))
                                    for q in (0.05, 0.5, 0.95)})
    out["allowable"] = allowable
    if allowable is not None:
        k = int(np.count_nonzero(good > allowable))
        ci = binomtest(k, len(good)).proportion_ci(confidence, method="exact")
        out.update(p_exceed=k / len(good), p_exceed_ci=[float(ci.low), float(ci.high)],
                   exceed_count=k)
    else:
        out["p_exceed"] = None
    return out


# ------------------------------------------------------- describe, sample, evaluate, analyse

#: the sampling methods of `sample`, each with what `analyse` computes from its runs
SAMPLERS = {"sobol": "Sobol first-, total- (and second-) order indices (SALib, Saltelli)",
            "morris": "Morris' elementary effects mu*, sigma (SALib)",
            "monte_carlo": "the output's distribution and P(Y > allowable)"}


@dataclass(frozen=True)
class ToleranceProblem:
    """What a tolerance study varies and what it measures (`describe`): the input names and
    their distributions, the nominal design, the output and the runs' settings."""

    names: tuple[str, ...]
    distributions: dict[str, Any]
    mech: SliderCrank | Linkage
    output: str | Callable
    revolution: int = 4
    backend: str = "reduced"
    options: dict[str, Any] = field(default_factory=dict)
    window: float | None = None

    @property
    def unit_problem(self) -> dict[str, Any]:
        """SALib's problem over the unit cube (every input is sampled there and mapped
        through its distribution's quantile function)."""
        d = len(self.names)
        return {"num_vars": d, "names": list(self.names), "bounds": [[0.0, 1.0]] * d}

    def physical(self, unit: np.ndarray) -> np.ndarray:
        """Rows of the unit cube -> rows of input values (SI)."""
        U = np.atleast_2d(np.asarray(unit, dtype=float))
        return np.column_stack([self.distributions[n].ppf(U[:, j])
                                for j, n in enumerate(self.names)])


@dataclass
class ToleranceSample:
    """Designs of one method (`sample`): `unit` rows in the unit cube, `values` the inputs
    (SI), `settings` the method's sizes and seed."""

    method: str
    unit: np.ndarray
    values: np.ndarray
    settings: dict[str, Any] = field(default_factory=dict)


@dataclass
class Evaluation:
    """The runs of a sample (`evaluate`): the output of each design (nan: failed), whether
    its motion was not periodic, and the counts of runs, failed, chaotic and flagged runs."""

    y: np.ndarray
    chaotic: np.ndarray
    counts: dict[str, int]
    wear: float = 0.0


def describe(inputs: Mapping[str, Any], mech: SliderCrank | Linkage | None = None,
             output: str | Callable = "peak", revolution: int = 4, *,
             backend: str = "reduced", window: float | None = None,
             **options) -> ToleranceProblem:
    """The problem of a tolerance study, checked before any run: `inputs` (name ->
    `Uniform`, `Normal` or `FitClearance`), the nominal `mech` (default: the paper's
    case), the `output` over `revolution` (a free linkage's: over time window `revolution`
    of `window` s), the `backend` and its options (see `tolerance_study` for each).
    ValueError naming the item on bad input."""
    from ..solve.simulate import BACKENDS

    mech = _studied(mech, inputs, output, window)
    if isinstance(mech, Linkage) and not callable(output) and output not in OUTPUTS:
        from ..analysis.objective import parse_output

        parse_output(mech, output)      # ValueError naming the allowed outputs
        if backend != "reduced":
            raise ValueError(f"output {output!r} of a Linkage needs backend='reduced' (its "
                             f"generated model); got {backend!r}")
    elif not callable(output) and output not in OUTPUTS:
        raise ValueError(f"output must be one of {list(OUTPUTS)} or a function; "
                         f"got {output!r}")
    names, dists = _check_inputs(inputs, output, mech)
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {sorted(BACKENDS)}; got {backend!r}")
    if isinstance(mech, Linkage) and not callable(output) and output == "peak" \
            and backend != "reduced":
        raise ValueError(f"output 'peak' of a Linkage needs backend='reduced'; got {backend!r}")
    revolution = _count("revolution", revolution, 1)
    check_revolutions_memory(revolution, options.get("max_memory"), name="revolution")
    _check_window(mech, output, revolution, window)
    if not callable(output):
        with_values(mech, {n: field_value(mech, n) for n in names})   # checks the nominal
        _check_ranges(mech, names, dists)
    return ToleranceProblem(names=names, distributions=dists, mech=mech, output=output,
                            revolution=revolution, backend=backend, options=dict(options),
                            window=window)


def _studied(mech, inputs, output, window) -> SliderCrank | Linkage:
    """What a study varies (`cases.door`; None: the paper's case): the paper's case, given
    as its parameter set or as its named case, as that set (its fields the inputs, its
    outputs `OUTPUTS`), unless an input is not one of its fields or the output or a window
    is a description's; any other linkage as it is."""
    entry = door(SliderCrank() if mech is None else mech)
    fields = callable(output) or not isinstance(inputs, Mapping) or all(
        n in (*CONTINUOUS_FIELDS, CLEARANCE) for n in inputs)
    if entry.paper is None or not fields or window is not None:
        return entry.linkage
    if callable(output) or output in OUTPUTS:
        return entry.paper
    from ..analysis.objective import parse_output

    try:
        parse_output(entry.linkage, output)
    except ValueError:
        return entry.paper              # the paper's message: OUTPUTS
    return entry.linkage


def _check_window(mech, output, revolution: int, window) -> None:
    """A free linkage's study needs `window` and an output that is a peak over a window
    (`objective.peak_output`); a driven one refuses `window`."""
    if callable(output):
        if window is not None:
            raise ValueError("window applies to a free linkage's peak output; not to a "
                             "function output")
        return
    if not isinstance(mech, Linkage):
        if window is not None:
            raise ValueError("window (s) is for a free linkage (drive=None); the paper's "
                             "slider-crank is driven: its output is over a revolution")
        return
    from ..analysis.objective import objective_window

    objective_window(mech, revolution, window)
    if mech.drive is None and output in OUTPUTS[1:]:
        raise ValueError(f"output {output!r} is taken over a drive revolution; a free "
                         f"linkage (drive=None) takes 'peak' or an output of "
                         f"objective.parse_output, its peak over a time window")


def sample(problem: ToleranceProblem, method: str, n: int, *, seed: int = 0,
           second_order: bool = True, levels: int = 4) -> ToleranceSample:
    """Designs of one `method` of `SAMPLERS`: "sobol" (Saltelli's scheme on a scrambled
    Sobol sequence, base size `n` a power of 2: n (2 d + 2) designs with `second_order`,
    else n (d + 2)), "morris" (`n` trajectories on a grid of `levels`: n (d + 1)) or
    "monte_carlo" (`n` independent uniform rows). The same seed gives the same designs."""
    if method not in SAMPLERS:
        raise ValueError(f"method must be one of {list(SAMPLERS)}; got {method!r}")
    n = _count("n", n, 1)
    seed = _count("seed", seed, 0)
    unit = problem.unit_problem
    if method == "sobol":
        if n & (n - 1):
            raise ValueError(f"n must be a power of 2 for method 'sobol'; got {n}")
        from SALib.sample import sobol as sobol_sample

        U = sobol_sample.sample(unit, n, calc_second_order=second_order, seed=seed)
        settings = {"N": n, "second_order": bool(second_order), "seed": seed}
    elif method == "morris":
        levels = _count("levels", levels, 2)
        if levels % 2:
            raise ValueError(f"levels must be even; got {levels}")
        from SALib.sample import morris as morris_sample

        U = morris_sample.sample(unit, n, num_levels=levels, seed=seed)
        settings = {"trajectories": n, "levels": levels, "seed": seed}
    else:
        U = np.random.default_rng(seed).random((n, len(problem.names)))
        settings = {"n": n, "seed": seed}
    return ToleranceSample(method=method, unit=U, values=problem.physical(U),
                           settings=settings)


def _nominal_accuracy_note(problem: ToleranceProblem) -> list[str]:
    """The cheaper default's error at the nominal design, checked: the sample's evaluation
    (one run at rtol 1e-7, no estimate of its own) against `simulate`'s default accuracy;
    a sentence and an `AccuracyWarning` where it misses that accuracy."""
    if (problem.output != "peak" or problem.backend != "reduced"
            or {"rtol", "atol", "accuracy"} & set(problem.options)):
        return []
    from ..solve.accuracy import DEFAULT_ACCURACY
    from ..solve.simulate import peak_base_force

    task = _task(problem)
    options = {k: v for k, v in problem.options.items() if k != "max_memory"}
    try:
        cheap = _mechanism_output(problem.mech, task)[0]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AccuracyWarning)
            if isinstance(problem.mech, Linkage):
                from ..analysis.objective import peak_output

                accurate = peak_output(problem.mech, None, problem.revolution,
                                       window=problem.window, **options)
            else:
                accurate = peak_base_force(problem.mech, problem.revolution, **options)
    except RuntimeError:        # the nominal design's run fails: the counts say so
        return []
    error = abs(cheap / accurate - 1.0)
    if error <= DEFAULT_ACCURACY:
        return []
    note = (f"each sample was one run at rtol 1e-7 without an error estimate; at the nominal "
            f"design that is {error:.1e} off the peak at accuracy {DEFAULT_ACCURACY:g}: pass "
            f"accuracy={DEFAULT_ACCURACY:g} for error-controlled samples")
    warnings.warn(note, AccuracyWarning, stacklevel=3)
    return [note]


def _task(problem: ToleranceProblem) -> _Task:
    return _Task(output=problem.output, revolution=problem.revolution,
                 backend=problem.backend, options=dict(problem.options),
                 window=problem.window)


def evaluate(problem: ToleranceProblem, samples: ToleranceSample, *, wear: float = 0.0,
             executor=None, workers: int = 2, progress: bool = True) -> Evaluation:
    """Run every design of `samples` (`executor.evaluate`: threads, processes or dask;
    None: a local pool of `workers`), with `wear` (m) added to the radial clearance. An
    invalid design (a normal's far tail) or a failed run gives nan."""
    wear = _real("wear", wear)
    if wear < 0:
        raise ValueError(f"wear must be >= 0 m; got {wear!r}")
    if wear and callable(problem.output):
        raise ValueError("wear applies to the mechanism's radial clearance; not to a "
                         "function output")
    study = _Study(problem.names, problem.distributions, problem.mech, _task(problem),
                   executor, workers, progress)
    desc = {"sobol": "Sobol", "morris": "Morris", "monte_carlo": "Monte Carlo"}[samples.method]
    if wear:
        desc = f"wear +{wear * 1e6:.3g} um"
    y, chaotic = study.values(samples.values, desc, extra={CLEARANCE: wear} if wear else None)
    return Evaluation(y=y, chaotic=chaotic, counts=dict(study.counts), wear=wear)


def _analysis_settings(bootstrap, confidence, seed, allowable):
    bootstrap = _count("bootstrap", bootstrap, 10)
    seed = _count("seed", seed, 0)
    confidence = _real("confidence", confidence)
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1); got {confidence!r}")
    if allowable is not None:
        allowable = _real("allowable", allowable)
    return bootstrap, confidence, seed, allowable


def analyse(problem: ToleranceProblem, samples: ToleranceSample, evaluation: Evaluation, *,
            bootstrap: int = 200, confidence: float = 0.95, seed: int = 0,
            allowable: float | None = None) -> dict[str, Any]:
    """What the runs of `samples` say, by its method: Sobol indices (S1, ST, S2 with their
    bootstrap intervals at `confidence`) or Morris' mu*, sigma (SALib), or the Monte Carlo
    statistics (mean, std, quantiles, P(Y > allowable) with its Clopper-Pearson interval).
    Indices are computed only when every run gave a value."""
    bootstrap, confidence, seed, allowable = _analysis_settings(bootstrap, confidence, seed,
                                                                allowable)
    y, ch = evaluation.y, evaluation.chaotic
    if len(y) != len(samples.unit):
        raise ValueError(f"evaluation has {len(y)} outputs for {len(samples.unit)} designs")
    unit = problem.unit_problem
    failed = int(np.count_nonzero(~np.isfinite(y)))
    if samples.method == "monte_carlo":
        return _stats(y, ch, allowable, confidence)
    if samples.method == "sobol":
        from SALib.analyze import sobol as sobol_analyze

        d = len(problem.names)
        second_order = samples.settings["second_order"]
        out = {"N": samples.settings["N"], "runs": len(y), "failed": failed,
               "chaotic_fraction": float(np.mean(ch)),
               "values_A": y[::(2 * d + 2) if second_order else d + 2]}
        if np.all(np.isfinite(y)):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                Si = sobol_analyze.analyze(unit, y, calc_second_order=second_order,
                                           num_resamples=bootstrap, conf_level=confidence,
                                           seed=seed, print_to_console=False)
            out.update({k: np.asarray(Si[k]) for k in ("S1", "S1_conf", "ST", "ST_conf")})
            if second_order:
                out.update(S2=np.asarray(Si["S2"]), S2_conf=np.asarray(Si["S2_conf"]))
            out["variance"] = float(np.var(y, ddof=1))
        return out
    from SALib.analyze import morris as morris_analyze

    out = {"trajectories": samples.settings["trajectories"],
           "levels": samples.settings["levels"], "runs": len(y), "failed": failed}
    if np.all(np.isfinite(y)):
        Mi = morris_analyze.analyze(unit, samples.unit, y, num_resamples=bootstrap,
                                    conf_level=confidence,
                                    num_levels=samples.settings["levels"], seed=seed,
                                    print_to_console=False)
        out.update({k: np.asarray(Mi[k], dtype=float)
                    for k in ("mu_star", "mu_star_conf", "sigma", "mu")})
    return out


def tolerance_study(inputs: Mapping[str, Any], mech: SliderCrank | None = None,
                    output: str | Callable = "peak", revolution: int = 4, *,
                    sobol: int = 256, second_order: bool = True, morris: int = 0,
                    morris_levels: int = 4, dgsm: int = 0, monte_carlo: int = 0,
                    allowable: float | None = None, wear: Any = None,
                    confidence: float = 0.95, bootstrap: int = 200, seed: int = 0,
                    executor=None, workers: int = 2, progress: bool = True,
                    backend: str = "reduced", window: float | None = None,
                    **options) -> ToleranceResult:
    """Global sensitivity and exceedance probability of a run's output over tolerances.

    Parameters
    ----------
    inputs : dict
        name -> `Uniform`, `Normal` or `FitClearance`. Names are continuous SliderCrank
        fields or "radial_clearance" (R_B - R_J, set by moving the journal radius); with a
        function `output`, any names (its arguments). For a Linkage: its case's overrides
        or dotted paths of its description (`design`; e.g. "coupler_length",
        "crank_coupler_clearance", "coupler.mass"), "radial_clearance" every clearance.
    mech : SliderCrank or Linkage, optional
        Nominal design; the inputs replace its fields (default: the paper's case).
    output : str or callable
        "peak" (max |F12|, the mechanism's default output, over revolution `revolution`,
        peak-only run), "rms_drive_moment"
        (N m) or "max_contact_force" (N) over that revolution (recorded runs); or a
        module-level function of a dict {name: value} returning a float. For a Linkage
        also any output of `objective.parse_output` ("shaking_force",
        "contact_force:<joint>", ...; "peak" is its default output,
        `Linkage.default_output`: the four-bar's shaking force),
        its peak over the revolution (`objective.peak_output`).
    revolution : int
        Crank revolution k (1-based) of the output (revolutions 1..k are simulated); a
        free linkage's (drive None): time window k, [(k - 1) w, k w].
    window : float, optional
        A free linkage's window width w in s (required there, refused for a driven one;
        `objective.objective_window`); its output is a peak (`objective.peak_output`).
    sobol : int
        Base sample size N of Sobol indices (a power of 2; 0: none). Runs: N (2 d + 2)
        with `second_order`, else N (d + 2).
    morris : int
        Morris trajectories r (0: none); runs r (d + 1).
    morris_levels : int
        Grid levels of Morris' design (even, >= 2).
    dgsm : int
        Gradient samples for DGSM (0: none; output "peak" with the reduced backend only;
        the gradients of `objective.peak_gradient`: DDM on the paper's case, central
        differences on other linkages, 2 d + 1 runs per sample).
    monte_carlo : int
        Monte Carlo samples of the output distribution (0: none).
    allowable : float, optional
        Load whose exceedance probability P(Y > allowable) is estimated (with its
        Clopper-Pearson interval at `confidence`).
    wear : sequence of float, optional
        Radial wear amounts in m added to the clearance; each level repeats the Monte Carlo
        (the same `monte_carlo` samples, common random numbers).
    confidence : float
        Level of every confidence interval, in (0, 1).
    bootstrap : int
        Bootstrap resamples of SALib's intervals and of the DGSM means.
    seed : int
        Seed of every sample and bootstrap (>= 0): the same seed gives the same result on
        every executor.
    executor : optional
        As in `executor.evaluate` (None: a local pool of `workers` threads).
    workers : int
        Size of the local pool.
    progress : bool
        tqdm bars of the runs.
    backend : str
        Model of the mechanism outputs ("reduced" default).
    **options
        Passed to the backend (e.g. ``rtol``, ``accuracy``). The cheaper default of output
        "peak" on the reduced backend: each sample one run at rtol 1e-7 recording only
        running maxima, without an error estimate of its own (measured against rtol 1e-12:
        within 1e-5 at 80 of the 81 points of a 9 x 9 grid of the paper's GA box, 2.9e-5 at
        L2 = 4.5 cm, L3 = 12.5 cm; 3.4e-5 at c = 0.05 mm; 1.2e-3 at 2000 rpm). The nominal
        design is checked: where its evaluation misses the default accuracy an
        `AccuracyWarning` says by how much and the result's notes keep it. With ``accuracy``
        each sample is a run that estimates its own error (`simulate`), and samples whose
        estimate misses it are counted as flagged. The other outputs: `simulate`'s default
        accuracy (1e-5 on the peaks, estimated).

    Returns
    -------
    ToleranceResult
    """
    t_start = time.perf_counter()
    given = SliderCrank() if mech is None else mech
    problem = describe(inputs, given, output, revolution, backend=backend, window=window,
                       **options)
    mech, names, dists = problem.mech, problem.names, problem.distributions
    shown = door(given).back(mech)      # in the result's settings as the user gave it
    revolution = problem.revolution
    sobol = _count("sobol", sobol, 0)
    if sobol and sobol & (sobol - 1):
        raise ValueError(f"sobol must be 0 or a power of 2 (Sobol sequences); got {sobol}")
    morris = _count("morris", morris, 0)
    morris_levels = _count("morris_levels", morris_levels, 2)
    if morris_levels % 2:
        raise ValueError(f"morris_levels must be even; got {morris_levels}")
    dgsm = _count("dgsm", dgsm, 0)
    monte_carlo = _count("monte_carlo", monte_carlo, 0)
    bootstrap, confidence, seed, allowable = _analysis_settings(bootstrap, confidence, seed,
                                                                allowable)
    if dgsm and (callable(output) or output != "peak" or backend != "reduced"):
        raise ValueError("dgsm needs output='peak' and backend='reduced' (the exact "
                         "gradients of the peak, peak_gradient)")
    wear_levels = []
    if wear is not None:
        if callable(output):
            raise ValueError("wear applies to the mechanism's radial clearance; not to a "
                             "function output")
        try:
            wear_levels = [_real("wear", w) for w in wear]
        except TypeError:
            raise ValueError(f"wear must be a sequence of radial wear amounts in m; "
                             f"got {wear!r}") from None
        if not wear_levels or min(wear_levels) < 0:
            raise ValueError(f"wear must be a non-empty sequence of amounts >= 0 m; "
                             f"got {wear!r}")
        if not monte_carlo:
            raise ValueError("wear needs monte_carlo > 0 (the samples of each level)")
    if not (sobol or morris or dgsm or monte_carlo):
        raise ValueError("nothing to do: set sobol, morris, dgsm or monte_carlo > 0")
    if wear_levels and not callable(output):
        _check_wear(mech, names, dists, max(wear_levels))
    study_memory(len(names), sobol=sobol, second_order=second_order, morris=morris,
                 dgsm=dgsm, monte_carlo=monte_carlo, wear_levels=len(wear_levels),
                 max_memory=options.get("max_memory"))

    run = {"executor": executor, "workers": workers, "progress": progress}
    stats = {"bootstrap": bootstrap, "confidence": confidence, "seed": seed,
             "allowable": allowable}
    counts = {"runs": 0, "failed": 0, "chaotic": 0, "flagged": 0}
    res: dict[str, Any] = {}

    def step(method, n, **kw):
        samples = sample(problem, method, n, seed=seed, **kw)
        ev = evaluate(problem, samples, **run)
        for k in counts:
            counts[k] += ev.counts[k]
        return samples, ev

    if sobol:
        samples, ev = step("sobol", sobol, second_order=second_order)
        res["sobol"] = analyse(problem, samples, ev, **stats)
    if morris:
        samples, ev = step("morris", morris, levels=morris_levels)
        res["morris"] = analyse(problem, samples, ev, **stats)
    if dgsm:
        study = _Study(names, dists, mech, _task(problem), executor, workers, progress)
        res["dgsm"] = _dgsm(study, dgsm, seed, bootstrap, confidence)
        for k in counts:
            counts[k] += study.counts[k]
    if monte_carlo:
        samples, ev = step("monte_carlo", monte_carlo)
        res["monte_carlo"] = analyse(problem, samples, ev, **stats)
        res["wear"] = []
        for w in wear_levels:
            ew = evaluate(problem, samples, wear=w, **run)
            for k in counts:
                counts[k] += ew.counts[k]
            res["wear"].append({"wear": w, **analyse(problem, samples, ew, **stats)})

    notes = _notes(counts, res, names, output) + _nominal_accuracy_note(problem)
    return ToleranceResult(
        names=names, distributions={n: dists[n].describe() for n in names},
        output=output if isinstance(output, str) else getattr(output, "__name__", "function"),
        sobol=res.get("sobol", {}), morris=res.get("morris", {}), dgsm=res.get("dgsm", {}),
        monte_carlo=res.get("monte_carlo", {}), wear=res.get("wear", []),
        counts=dict(counts), notes=notes,
        settings={"revolution": revolution, "backend": backend, "options": dict(options),
                  **({"default_output": mech.default_output} if output == "peak" else {}),
                  **({"window": window} if window is not None else {}),
                  "sobol": sobol, "second_order": second_order, "morris": morris,
                  "morris_levels": morris_levels, "dgsm": dgsm, "monte_carlo": monte_carlo,
                  "allowable": allowable, "wear": wear_levels, "confidence": confidence,
                  "bootstrap": bootstrap, "seed": seed, "mechanism": shown.to_dict(),
                  **({"case": shown.case, "overrides": dict(shown.overrides)}
                     if isinstance(shown, Linkage) and shown.case is not None else {}),
                  "executor": _executor_name(executor, workers)},
        elapsed=time.perf_counter() - t_start)


def _executor_name(executor, workers) -> str:
    if executor is None or isinstance(executor, str):
        return f"{executor or 'threads'}({workers} workers)"
    from .executor import _describe_executor

    return _describe_executor(executor, None)


def _dgsm(study: _Study, n: int, seed: int, bootstrap: int, confidence: float) -> dict:
    """DGSM nu_i = E[(dY/dx_i)^2] over `n` quasi-random designs (scrambled Sobol), and the
    bound C_i nu_i / V on S_T,i with V the variance of the same sample's peaks."""
    from scipy.stats import qmc

    names = study.names
    fields, J = _gradient_names(names, study.base)
    U = qmc.Sobol(len(names), scramble=True, seed=seed).random(n)
    mechs = study.items(study.physical(U))
    if any(m is None for m in mechs):
        raise ValueError("a DGSM sample point is not a valid mechanism; narrow the inputs")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        warnings.simplefilter("ignore", PhysicsWarning)
        res = _evaluate_all(_grad_one, mechs, (fields, study.task.revolution,
                                               study.task.window),
                       executor=study.executor, workers=study.workers, progress=study.progress,
                       desc="DGSM")
    peaks = np.array([r[0] for r in res])
    grads = np.array([J @ r[1] for r in res])         # (n, d) d(peak)/d(input)
    kinks = int(sum(r[2] for r in res))
    ok = np.isfinite(peaks) & np.all(np.isfinite(grads), axis=1)
    study.counts["runs"] += n
    study.counts["failed"] += int(np.count_nonzero(~ok))
    g2 = grads[ok] ** 2
    nu = g2.mean(axis=0)
    V = float(np.var(peaks[ok], ddof=1))
    C = np.array([study.dists[nm].poincare for nm in names])
    rng = np.random.default_rng(seed)
    boot = np.array([g2[rng.integers(0, len(g2), len(g2))].mean(axis=0)
                     for _ in range(bootstrap)])
    alpha = (1.0 - confidence) / 2.0
    return {"nu": nu, "nu_ci": np.quantile(boot, [alpha, 1 - alpha], axis=0),
            "poincare": C, "variance": V, "bound": C * nu / V, "runs": n,
            "failed": int(np.count_nonzero(~ok)), "kinks": kinks,
            "gradient_fields": list(fields)}


def _index(value: float) -> str:
    """A Sobol index to 3 decimals, 7 wide; an estimate that rounds to zero is 0.000 (a
    small negative estimate is sampling noise around zero, not a sign)."""
    text = f"{value:7.3f}"
    return f"{0.0:7.3f}" if float(text) == 0.0 else text


def _notes(counts, res, names, output) -> list[str]:
    notes = []
    if counts["chaotic"]:
        notes.append(
            f"{counts['chaotic']} of {counts['runs']} runs are not periodic (a rattling "
            "contact, or motion that does not repeat every revolution): their output is the "
            "statistic over revolutions 2..k (max of the per-revolution peaks, RMS over those "
            "revolutions), not revolution k alone; the indices mix the two regimes")
    if counts["flagged"]:
        notes.append(
            f"{counts['flagged']} runs are flagged by the accuracy or physics checks "
            "(an error estimate above the requested accuracy, or a penetration too deep for "
            "the contact law; for the output 'peak': a rattling contact): their values may "
            "miss the stated accuracy")
    if counts["failed"]:
        notes.append(f"{counts['failed']} runs failed (invalid design or integration "
                     "failure); indices are not computed for a method with a failed run")
    if res.get("dgsm") and res.get("dgsm", {}).get("kinks"):
        notes.append(f"{res['dgsm']['kinks']} DGSM designs sit at a kink of the peak (two "
                     "maxima tie); their gradient is a one-sided value")
    return notes
