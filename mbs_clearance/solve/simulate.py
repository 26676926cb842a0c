"""`simulate(mech, backend=...)`: one entry point for every model, one `Trajectory` result."""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from ..model.cases import door
from ..model.linkage import Linkage
from ..model.mechanism import SliderCrank
from .accuracy import DEFAULT_ACCURACY, check_accuracy_or_rtol
from .settings import expand
from .trajectory import Trajectory

__all__ = ["simulate", "peak_base_force", "BACKENDS", "Backend", "Model"]


@dataclass(frozen=True)
class Model:
    """Where a backend's functions for one kind of input live: the module (imported when
    first asked for) and the names of its simulate and peak-only functions."""

    module: str
    simulate: str
    peak: str

    def load(self, attr: str):
        return getattr(importlib.import_module(self.module), getattr(self, attr))


@dataclass(frozen=True)
class Backend:
    """A model of a mechanism: what it is, and its functions for a `Linkage` (a
    `SliderCrank` runs as its description, `cases.door`)."""

    description: str
    model: Model
    #: its runs to a requested accuracy (a step sequence, extrapolated), if it has its own
    to_accuracy: Model | None = None


#: name -> Backend: the one registry of models (each module imported when first asked for,
#: Exudyn only then)
BACKENDS: dict[str, Backend] = {
    "reduced": Backend(
        "the model generated from the description, compiled in C",
        Model("mbs_clearance.solve.linkage_model", "simulate_linkage", "peak_linkage")),
    "exudyn": Backend(
        "the same mechanism built in the multibody engine Exudyn",
        Model("mbs_clearance.backends.exudyn_linkage", "simulate_exudyn_linkage",
              "peak_exudyn_linkage"),
        to_accuracy=Model("mbs_clearance.backends.exudyn_convergence",
                          "simulate_to_accuracy", "peak_to_accuracy")),
    "ideal": Backend(
        "the same mechanism with ideal joints (no clearance): the paper's closed form, any "
        "description's constraints solved",
        Model("mbs_clearance.backends.ideal_linkage", "simulate_ideal_linkage",
              "peak_ideal_linkage")),
}


def _backend(name: str) -> Backend:
    if name not in BACKENDS:
        raise ValueError(f"backend must be one of {sorted(BACKENDS)}; got {name!r}")
    return BACKENDS[name]


def _check(mech: Linkage, revolutions, name="revolutions") -> int | None:
    """The revolutions (default 4) of a driven linkage; None for a free linkage (it runs
    for the option ``duration``), which refuses revolutions (`linkage_model.check_span`)."""
    from .linkage_model import check_span

    return check_span(mech, revolutions, None, None, name)


def simulate(mech: SliderCrank, revolutions: int | None = None, backend: str = "reduced",
             accuracy: float | None = None, **options) -> Trajectory:
    """Simulate `revolutions` crank revolutions from t = 0.

    Parameters
    ----------
    mech : SliderCrank or Linkage
        A `Linkage` (e.g. from `mbs_clearance.model.cases`) runs the model generated from its
        description (backend "reduced") or the description built in Exudyn (backend
        "exudyn", `exudyn_linkage`); its Trajectory has per-joint series.
    revolutions : int or None
        Number of full crank (drive) revolutions (>= 1; None: 4). A free `Linkage`
        (``drive=None``) takes none: it runs for ``duration`` (an option, s) from its
        `Initial` start, its peaks per window of ``window`` s (default the whole run).
    backend : str
        A key of `BACKENDS`: "reduced" (default), "exudyn" or "ideal".
    accuracy : float or None
        Requested relative accuracy of the per-revolution peaks. Backend "reduced": for a
        `SliderCrank` or a `Linkage` default `accuracy.DEFAULT_ACCURACY` (1e-5) unless
        ``rtol`` or ``atol`` is given (an expert's fixed tolerance, run once as given); the
        run estimates its own error from a second run and tightens until the estimate is
        within the request
        (`mbs_clearance.solve.accuracy`; ``stats["error_estimate"]``,
        ``stats["accuracy_ok"]``: the estimate is within the request). Backend "exudyn"
        (a driven mechanism): checked, not assumed: runs at the steps h, h/2, h/4, halved
        further while a revolution's bar exceeds the request (at most
        `exudyn_convergence.MAX_HALVINGS` more); the last run is returned with the
        Richardson-extrapolated peaks as ``peaks`` and ``stats["error_estimate"]``
        (largest relative bar), ``stats["accuracy_ok"]``, ``stats["peak_errors"]`` (N),
        ``stats["accuracy_steps"]``; an `AccuracyWarning` where the request is not met
        (`exudyn_convergence.simulate_to_accuracy`). Without it Exudyn runs once at its
        default step, its error unestimated. A free linkage on Exudyn: the step of the
        second-order law for the request (`exudyn_linkage.step_for_accuracy`).
    **options
        Backend settings, e.g. ``rtol``, ``atol``, ``method`` for "reduced" (or all of them
        as one record, ``settings=RunSettings(...)``); ``step_size``, ``contact`` for
        "exudyn". Unknown options or values out of range raise ValueError
        before any computation. Every backend takes ``max_memory`` (bytes; default
        min(4 GiB, half the RAM)): a run estimated to need more is refused with
        `MemoryLimitError` (a ValueError) before it allocates. A `Linkage` on either
        backend takes ``start`` (a `linkage_model.Start`, e.g. `settled_start(linkage,
        100)`): the run starts from that state instead of the centred assembly.

    Returns
    -------
    Trajectory
        ``stats`` holds, besides the solver counters, ``max_penetration_clearance``,
        ``max_penetration_radius``, ``penetration_meaningless`` (a `PhysicsWarning` is
        emitted when True) and ``periodic`` (True, False or None) with
        ``periodicity_note``; see `trajectory.annotate`.
    """
    entry = door(mech)
    if entry.given_as_paper and "start" in options:
        raise ValueError("start is not an option of a SliderCrank's run; use its description "
                         "(cases.paper_slider_crank, the same case) with start=")
    if backend == "reduced":
        options = _paper_start(entry, expand(options))
    return paper_view(_simulate(entry.linkage, revolutions, backend, accuracy, options,
                                rattling=entry.paper is not None), entry,
                      sampled=options.get("t_eval") is not None)


def _simulate(mech: Linkage, revolutions, backend, accuracy, options, rattling):
    check_accuracy_or_rtol(accuracy, options)
    if accuracy is not None and _backend(backend).to_accuracy is not None:
        simulate_to_accuracy = _backend(backend).to_accuracy.load("simulate")
        revolutions = _check(mech, revolutions)
        _call_check(backend, mech, options)

        def record(h):
            return _call(backend, "simulate", mech, revolutions, {**options, "step_size": h})

        return simulate_to_accuracy(mech, revolutions, accuracy, record, **options)
    if backend != "reduced":
        if accuracy is not None:
            options["accuracy"] = accuracy
        return _call(backend, "simulate", mech, revolutions, options)
    if accuracy is None and ("rtol" in options or "atol" in options):
        return _call(backend, "simulate", mech, revolutions, options)
    return _to_accuracy(mech, revolutions, DEFAULT_ACCURACY if accuracy is None else accuracy,
                        options, rattling)


def _to_accuracy(mech: Linkage, revolutions, accuracy, options: dict,
                 rattling: bool = False) -> Trajectory:
    """The reduced model's run within `accuracy` (`accuracy.simulate_to_accuracy`): recorded
    runs through `_call`, the peaks-only check through `linkage_model.run`. `rattling`: a
    rattling run stops tightening (the paper's case, whose rattling peaks no tolerance
    makes accurate); elsewhere not: the four-bar's slow drive switches its contact hundreds
    of times per revolution, yet its peaks converge as rtol falls (docs/performance.md)."""
    from . import linkage_model as lm
    from .accuracy import simulate_to_accuracy

    def record(rtol):
        return _call("reduced", "simulate", mech, revolutions, {**options, "rtol": rtol})

    def peaks(rtol):
        out = lm.run(mech, revolutions, record=False, rtol=rtol, **options)
        return out.peaks, out.stats["nfev"]

    def rattles(traj):
        return bool(traj.stats.get("rattling"))

    return simulate_to_accuracy(record, peaks, accuracy, rattling=rattles if rattling else None)


def _paper_start(entry, options: dict) -> dict:
    """The reduced model's options for the paper's case (`cases.door`): unless a start is
    given, its closed-form centred start (`reduced.centred_start`), offset by the option
    ``initial_offset`` (a fraction of the clearance in [-1, 1], the stress tests'); other
    linkages as given."""
    if entry.paper is None or "start" in options:
        return options
    from .._checks import check_real
    from .reduced import centred_start

    options = dict(options)
    offset = check_real("initial_offset (fraction of the clearance)",
                        options.pop("initial_offset", 0.0), -1.0, 1.0)
    options["start"] = centred_start(entry.paper, offset)
    return options


def paper_view(traj: Trajectory, entry, sampled: bool = False) -> Trajectory:
    """The trajectory as the user gave the mechanism (`cases.door`): a `SliderCrank`'s in
    the paper's names (`reduced.paper_series`; `sampled`: on given output times, where
    it has no peaks), a `Linkage`'s as it is."""
    if not entry.given_as_paper or traj.linkage is None:
        return traj
    from .reduced import paper_series

    return paper_series(traj, entry.paper, sampled)


def peak_base_force(mech: SliderCrank, revolution: int | None = None, backend: str = "reduced",
                    accuracy: float | None = None, **options) -> float:
    """The peak in N of the mechanism's default output (`Linkage.default_output`: its
    monitored joint's |reaction|, the paper's |F12|, or the shaking force without one) over
    crank revolution `revolution` (1-based): the peak of the same output that `simulate`'s
    peaks, `objective.peak_output`, `peak_gradient`, the GA and the tolerance study take
    by default. A free linkage: over its last time window (``duration``, ``window``).

    Backend "reduced": by default within `accuracy.DEFAULT_ACCURACY` (1e-5), as `simulate`:
    the peak of `simulate(mech, revolution, accuracy=accuracy)`, a run that estimates its
    own error and tightens until the estimate is within the request (a recorded run and a
    check, about 1.2 times a fixed run) and warns (`AccuracyWarning`) where it cannot. With
    ``rtol`` or ``atol`` (and no `accuracy`): one run at that fixed tolerance recording
    only running maxima, without an error estimate (rtol 1e-7 is within 1e-5 on the
    paper's GA box, the accuracy map in docs/performance.md, but 1.2e-3 off at 2000 rpm).
    Backend "exudyn" with `accuracy`: the peak converged in the step
    (`exudyn_convergence.peak_to_accuracy`: runs at h, h/2, h/4, ... recording the
    reactions only, extrapolated; an `AccuracyWarning` where the estimate misses the
    request); without it, one run at the backend's step (its error unestimated,
    docs/exudyn.md).
    """
    entry = door(mech)
    mech = entry.linkage
    if backend == "reduced":
        options = _paper_start(entry, expand(options))
        if accuracy is None and "rtol" not in options and "atol" not in options:
            accuracy = DEFAULT_ACCURACY
    if accuracy is not None and backend == "reduced":
        from .accuracy import revolution_peaks

        revolution = _check(mech, revolution, "revolution")
        traj = simulate(mech, revolution, accuracy=accuracy, **options)
        if revolution is None:      # a free linkage: its last window's peak
            return float(traj.peaks[-1])
        return float(revolution_peaks(traj)[revolution - 1])
    if accuracy is not None and _backend(backend).to_accuracy is not None:
        peak_to_accuracy = _backend(backend).to_accuracy.load("peak")
        revolution = _check(mech, revolution, "revolution")
        _call_check(backend, mech, options)
        return peak_to_accuracy(mech, revolution, accuracy, **options)
    if accuracy is not None:
        options["accuracy"] = accuracy
    return _call(backend, "peak", mech, revolution, options, "revolution")


def _call_check(backend: str, mech, options: dict) -> Model:
    """`backend`'s Model for `mech` after checking the option names (ValueError before any
    run)."""
    model = _backend(backend).model
    allowed = getattr(importlib.import_module(model.module), "OPTION_NAMES", None)
    unknown = sorted(set(options) - set(allowed)) if allowed is not None else []
    if unknown:
        raise ValueError(f"unknown option(s) {unknown} for backend {backend!r}; "
                         f"allowed: {sorted(allowed)}")
    return model


def _call(backend: str, attr: str, mech, revolutions, options: dict,
          name: str = "revolutions"):
    """Validate backend, mechanism, count and option names, then call the backend (which
    validates the options' values)."""
    revolutions = _check(mech, revolutions, name)
    model = _call_check(backend, mech, options)
    return model.load(attr)(mech, revolutions, **options)
