"""How the reduced model integrates a run, as one record: `RunSettings`.

Tolerances and step control, the event search and the memory limit travel together from
the entry points (`simulate(mech, rtol=...)`, `peak_base_force`, the studies) to the one
plain run (`linkage_model.run`), instead of a dozen keywords repeated through every layer.
The record checks its fields when it is made (ValueError naming the field and its allowed
range), so a bad setting is refused before any model is loaded; the checks that need the
linkage (the length of a per-component `atol`) are made by the run.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["RunSettings", "DEFAULT_RTOL", "DEFAULT_MAX_STEPS", "MAX_SAMPLES"]

#: default relative tolerance of the compiled integrator (chosen by the work-precision
#: benchmark, see docs/performance.md)
DEFAULT_RTOL = 1e-7

#: default `max_steps` (step attempts) of a run
DEFAULT_MAX_STEPS = 5_000_000

#: largest `n_samples` (interior event samples per step) accepted
MAX_SAMPLES = 1000


@dataclass(frozen=True)
class RunSettings:
    """The integration settings of a reduced-model run.

    Attributes
    ----------
    rtol : relative tolerance (1e-14 .. 1e-2; None: `DEFAULT_RTOL`)
    atol : absolute tolerance: one number, one per state component, or the state's and then
        per clearance joint its penetration's and penetration rate's (np.inf: not under
        error control); None: from the linkage's scales (`linkage_model.default_atol`)
    method : the integrator's method ("dopri5", "dop853", "bs3", "rodas4": linearly
        implicit, for a stiff oil film at a fixed rtol, docs/lubrication.md)
    max_steps : step attempts allowed (>= 1)
    h_max : largest step in s (> 0; None: an eighth of a drive revolution)
    h0 : first step in s (0: automatic)
    n_samples : interior event samples per step (0 .. `MAX_SAMPLES`)
    event_tol : penetration in m within which a contact event is located (> 0; None: 1e-12
        of the smallest clearance, not below the journal positions' round-off)
    max_memory : bytes a run may hold (>= 1; None: the default limit, min(4 GiB, half the
        RAM))
    event_control : put each joint's penetration under error control beside the state
        (False only for comparisons with the error control without it)
    """

    rtol: float | None = None
    atol: Any = None
    method: str = "dopri5"
    max_steps: int = DEFAULT_MAX_STEPS
    h_max: float | None = None
    h0: float = 0.0
    n_samples: int = 1
    event_tol: float | None = None
    max_memory: int | None = None
    event_control: bool = True

    def __post_init__(self):
        from .._checks import check_bool, check_choice, check_int, check_max_memory, check_real
        from ..numerics.integrator import METHODS

        checked = {
            "rtol": None if self.rtol is None else check_real("rtol", self.rtol, 1e-14, 1e-2),
            "method": check_choice("method", self.method, METHODS),
            "max_steps": check_int("max_steps", self.max_steps, 1),
            "h_max": None if self.h_max is None else check_real(
                "h_max (largest step)", self.h_max, 0.0, low_open=True, unit="s"),
            "h0": check_real("h0 (initial step; 0: automatic)", self.h0, 0.0, unit="s"),
            "n_samples": check_int("n_samples (interior event samples per step)",
                                   self.n_samples, 0, MAX_SAMPLES),
            "event_tol": None if self.event_tol is None else check_real(
                "event_tol (penetration tolerance of events)", self.event_tol, 0.0,
                low_open=True, unit="m"),
            "max_memory": None if self.max_memory is None else check_max_memory(
                self.max_memory),
            "event_control": check_bool("event_control", self.event_control),
        }
        if self.atol is not None:
            _check_atol_values(self.atol)
        for name, value in checked.items():
            object.__setattr__(self, name, value)

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The fields' names: the run options a user may pass as keywords."""
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def split(cls, options: dict) -> tuple[RunSettings, dict]:
        """(the settings among `options`, the other options)."""
        mine = {k: v for k, v in options.items() if k in cls.names()}
        return cls(**mine), {k: v for k, v in options.items() if k not in mine}

    def replace(self, **changes) -> RunSettings:
        """A copy with `changes`; ValueError for a name that is no setting."""
        unknown = sorted(set(changes) - set(self.names()))
        if unknown:
            raise ValueError(f"unknown run setting(s) {unknown}; the settings are "
                             f"{list(self.names())}")
        return dataclasses.replace(self, **changes)

    def options(self) -> dict:
        """The fields that differ from the defaults, as keyword options."""
        default = RunSettings()
        return {n: getattr(self, n) for n in self.names()
                if not _same(getattr(self, n), getattr(default, n))}

    def with_options(self, options: dict) -> RunSettings:
        """This record with the keyword options `options` (run settings only) applied."""
        return self.replace(**options) if options else self


def _same(a, b) -> bool:
    if a is None or b is None:
        return a is b
    return bool(np.array_equal(np.asarray(a), np.asarray(b)))


def expand(options: dict) -> dict:
    """`options` with a ``settings`` entry (a `RunSettings`) replaced by its non-default
    fields; a field also given as a keyword wins. ValueError for another type."""
    if "settings" not in options:
        return options
    options = dict(options)
    settings = options.pop("settings")
    if not isinstance(settings, RunSettings):
        raise ValueError(f"settings must be a RunSettings; got {type(settings).__name__}")
    return {**settings.options(), **options}


def _check_atol_values(atol) -> None:
    """Refuse an atol that is no positive number or array of them (its length is checked by
    the run, which knows the state)."""
    bad = isinstance(atol, (bool, np.bool_))
    if not bad:
        try:
            arr = np.asarray(atol, dtype=float)
            bad = arr.ndim > 1 or arr.size == 0 or bool(np.any(np.isnan(arr))) \
                or bool(np.any(arr <= 0))
        except (TypeError, ValueError):
            bad = True
    if bad:
        raise ValueError(f"atol must be a finite number > 0 or an array of them (one per state "
                         f"component, then optionally per clearance joint its penetration's "
                         f"and its rate's, inf allowed there); got {atol!r}")
