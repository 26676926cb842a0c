"""What a law module declares: its parameters and its formula (`ContactLaw`,
`FrictionLaw`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["Parameter", "ContactLaw", "FrictionLaw"]


@dataclass(frozen=True)
class Parameter:
    """A parameter of a law: its field name in the description, symbol, unit, default, the
    allowed interval (low, high; each end open or closed; None for unbounded) and the
    source of the default."""

    name: str
    symbol: str
    unit: str
    default: float
    low: float | None
    high: float | None = None
    low_open: bool = False
    high_open: bool = True
    source: str = ""

    @property
    def interval(self) -> str:
        """The allowed interval as text, e.g. "(0, 1]"."""
        lo = "-inf" if self.low is None else f"{self.low:g}"
        hi = "inf" if self.high is None else f"{self.high:g}"
        return (("(" if self.low_open or self.low is None else "[") + f"{lo}, {hi}"
                + (")" if self.high_open or self.high is None else "]"))

    def contains(self, value: float) -> bool:
        """Whether `value` is a finite number in the allowed interval."""
        if not math.isfinite(value):
            return False
        if self.low is not None and (value < self.low or (self.low_open and value == self.low)):
            return False
        return not (self.high is not None
                    and (value > self.high or (self.high_open and value == self.high)))


@dataclass(frozen=True)
class ContactLaw:
    """A Hertzian contact law F = K delta^1.5 (1 + xi(e) deltadot / deltadot_minus), clamped
    at zero. `hysteresis` is xi(e), plain arithmetic (see `ops`): evaluated in Python,
    printed in C for the compiled models, differentiated by sympy for the partials,
    evaluated on Exudyn symbolic Reals for the Exudyn model. `restitution` gives the allowed
    e of the law; `lossless` whether xi(1) = 0 (the law conserves energy at e = 1)."""

    name: str
    hysteresis: Callable
    restitution: Parameter
    source: str
    lossless: bool = True


@dataclass(frozen=True)
class FrictionLaw:
    """A friction law: `force`(vt, fn, *arguments) is the tangential force Ft on the journal
    (opposing the slip velocity vt) for the normal force fn, plain arithmetic (see `ops`);
    `arguments` name the description fields its further parameters come from, `parameters`
    declare the ones the law reads (with their ranges); `check`(what, values), if given,
    raises ValueError on the law's own conditions between its parameters (values: field ->
    value), after each has been checked against its range."""

    name: str
    force: Callable
    arguments: tuple[str, ...]
    parameters: tuple[Parameter, ...]
    source: str
    check: Callable | None = None
