"""A run prepared once and handed down: `Problem`, with its `Span` and `ModelLayout`.

`linkage_model.prepare(linkage, revolutions, settings, ...)` checks every argument, loads
the generated model and builds the span, the tolerances, the parameter vector and the start;
`linkage_model.solve(problem)` integrates it. The layout (sizes of the state, events,
memory, outputs and parameters) is what a compiled core needs to know of a model besides its
kernels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .settings import RunSettings

__all__ = ["ModelLayout", "Span", "Problem"]


@dataclass(frozen=True)
class ModelLayout:
    """Sizes of a generated model: state, coordinates, switching functions (events),
    memory entries of p (from mem_start), recorded outputs, parameter-only constants (from
    const_start) and the whole parameter vector."""

    n_state: int
    n_q: int
    n_events: int
    mem_start: int
    n_mem: int
    n_out: int
    const_start: int
    n_p: int

    @classmethod
    def of(cls, model) -> ModelLayout:
        """The layout of a generated model module."""
        return cls(n_state=int(model.N_STATE), n_q=int(model.N_Q),
                   n_events=int(model.N_EVENTS), mem_start=int(model.MEM_START),
                   n_mem=int(model.N_MEM), n_out=int(model.N_OUT),
                   const_start=int(model.CONST_START), n_p=int(model.N_P))


@dataclass(frozen=True, eq=False)
class Span:
    """The stretch of time a run covers: the window edges the integrator lands on (s), the
    windows its peaks are reported over (the same, unless it lands on `t_eval` too), the
    drive revolutions (None for a free linkage, which runs over time windows), and whether
    only the `t_eval` samples are returned (`select`)."""

    edges: np.ndarray
    windows: np.ndarray
    revolutions: int | None
    t_eval: np.ndarray | None = None
    select: bool = True

    @property
    def duration(self) -> float:
        """The run's length in s."""
        return float(self.edges[-1] - self.edges[0])


@dataclass(frozen=True, eq=False)
class Problem:
    """One plain run, prepared: the description, its generated model and layout, the span,
    the settings (as given and as the integrator's record), the parameter vector (with the
    joints' memory and the model's constants) and the start."""

    linkage: object
    model: object
    layout: ModelLayout
    span: Span
    settings: RunSettings
    specialise: bool
    p: np.ndarray
    y0: np.ndarray
    #: the integrator's settings record (`integrator.IntegratorSettings`)
    integrator: object
    method: str
    rtol: float
    #: the step attempts the user allowed (the record's memory limit may lower the
    #: integrator's own)
    max_steps: int
    max_memory: int
    #: right-hand-side evaluations spent before the integrator (the start step's)
    extra_fev: int = 0
