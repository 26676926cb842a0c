"""Validation of user input shared by every entry point: one message format, one place.

Each check returns the value normalised to a plain Python type (numpy scalars and Fractions
are accepted where a number is meant) or raises ValueError naming the item and its allowed
range, before any computation. Booleans are never numbers here (``True`` is not 1).
"""

from __future__ import annotations

import math
import numbers
import os
from typing import Any

import numpy as np

__all__ = ["check_int", "check_real", "check_bool", "check_choice", "check_times",
           "check_max_memory", "default_max_memory", "format_bytes", "MemoryLimitError",
           "check_memory", "check_revolutions_memory", "revolution_bytes", "REVOLUTION_BYTES",
           "DESIGN_BYTES", "check_steps"]


class MemoryLimitError(ValueError):
    """A run would need more memory (or steps) than allowed; raised before it starts."""


def _is_int(value: Any) -> bool:
    return isinstance(value, (numbers.Integral, np.integer)) and not isinstance(
        value, (bool, np.bool_))


def _is_real(value: Any) -> bool:
    return isinstance(value, (numbers.Real, np.floating, np.integer)) and not isinstance(
        value, (bool, np.bool_))


def check_int(name: str, value: Any, low: int | None = None, high: int | None = None) -> int:
    """`value` as a Python int in [low, high] (None: unbounded); ValueError otherwise."""
    if not _is_int(value) or (low is not None and value < low) or (
            high is not None and value > high):
        raise ValueError(f"{name} must be an integer {_range(low, high, False, False)}; "
                         f"got {value!r}")
    return int(value)


def check_real(name: str, value: Any, low: float | None = None, high: float | None = None, *,
               low_open: bool = False, high_open: bool = False, unit: str = "") -> float:
    """`value` as a finite Python float in the interval given by low/high (open or closed
    ends; None: unbounded); ValueError naming `name` and the interval otherwise."""
    ok = _is_real(value)
    if ok:
        v = float(value)
        ok = (math.isfinite(v)
              and (low is None or (v > low if low_open else v >= low))
              and (high is None or (v < high if high_open else v <= high)))
    if not ok:
        where = _range(low, high, low_open, high_open)
        raise ValueError(f"{name} must be a finite number {where}{' ' + unit if unit else ''};"
                         f" got {value!r}")
    return v


def check_bool(name: str, value: Any) -> bool:
    """`value` if it is True or False (numpy booleans too); ValueError otherwise."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False; got {value!r}")
    return bool(value)


def check_choice(name: str, value: Any, choices) -> Any:
    """`value` if it is one of `choices`; ValueError listing them otherwise."""
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"{name} must be one of {sorted(choices)}; got {value!r}")
    return value


def check_times(name: str, value: Any, t_end: float) -> np.ndarray:
    """A non-empty, finite, strictly increasing 1-D array of times within [0, t_end] s."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if (arr is None or arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr))
            or np.any(np.diff(arr) <= 0) or arr[0] < 0 or arr[-1] > t_end * (1 + 1e-12)):
        raise ValueError(f"{name} must be a non-empty array of finite, strictly increasing "
                         f"times within [0, {t_end:.6g}] s; got {_short(value)}")
    return arr


def _range(low, high, low_open, high_open) -> str:
    if low is None and high is None:
        return ""
    if high is None:
        return f"{'>' if low_open else '>='} {low:g}"
    if low is None:
        return f"{'<' if high_open else '<='} {high:g}"
    return f"in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


# ---------------------------------------------------------------------------- memory

#: upper end of the default memory limit (bytes); the default is the smaller of this and
#: half of the machine's physical memory (`default_max_memory`)
MAX_MEMORY_CAP = 4 * 1024**3


def default_max_memory() -> int:
    """Default limit of a run's estimated memory in bytes: min(4 GiB, half the physical RAM)
    (4 GiB when the RAM size cannot be read)."""
    try:
        ram = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return MAX_MEMORY_CAP
    return int(min(MAX_MEMORY_CAP, ram // 2)) if ram > 0 else MAX_MEMORY_CAP


def check_max_memory(value: Any) -> int:
    """The option ``max_memory`` (bytes, an integer >= 1, or None for the default)."""
    if value is None:
        return default_max_memory()
    return check_int("max_memory (bytes)", value, 1)


def format_bytes(n: float) -> str:
    """n bytes as a short human-readable string (MiB / GiB / TiB)."""
    for unit, size in (("TiB", 1024**4), ("GiB", 1024**3), ("MiB", 1024**2)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 1024:.3g} KiB"


#: bytes per crank revolution that every run holds whatever it records: the revolution's
#: edge time, its refined peak and the peak's time (three float64)
REVOLUTION_BYTES = 24

#: bytes of one design held in a list (a SliderCrank takes about 300, a named case's
#: Linkage about 3000, measured with tracemalloc): the estimate of sweeps, GA generations
#: and tolerance samples
DESIGN_BYTES = 4096


def revolution_bytes(revolutions: int) -> int:
    """Bytes of the per-revolution arrays of a run of `revolutions` revolutions."""
    return REVOLUTION_BYTES * (int(revolutions) + 1)


def check_memory(what: str, need: float, max_memory: Any = None, advice: str = "") -> int:
    """Refuse work whose estimated peak memory `need` (bytes) exceeds `max_memory` (bytes;
    None: `default_max_memory`), before anything is built or allocated: `MemoryLimitError`
    with one line ``WHAT need(s) about N GiB, more than max_memory=B bytes (L GiB); ADVICE``
    (`what` names the options that set the size, with their values). Returns the limit."""
    limit = check_max_memory(max_memory)
    if need > limit:
        raise MemoryLimitError(
            f"{what} about {format_bytes(need)}, more than max_memory={limit} bytes "
            f"({format_bytes(limit)})" + (f"; {advice}" if advice else ""))
    return limit


def check_revolutions_memory(revolutions: int, max_memory: Any = None, per_revolution: int = 0,
                             name: str = "revolutions") -> int:
    """Refuse a run whose per-revolution arrays alone (`REVOLUTION_BYTES`, plus
    `per_revolution` more bytes each, e.g. a sensitivity's growth per parameter) exceed
    `max_memory` (None: the default limit), with `check_memory`'s one line naming `name`.
    Returns `revolutions`."""
    check_memory(f"{name}={revolutions}: the per-revolution arrays alone need",
                 (REVOLUTION_BYTES + per_revolution) * (int(revolutions) + 1), max_memory,
                 "run fewer revolutions or raise max_memory")
    return revolutions


def check_steps(what: str, steps: float, max_steps: int, advice: str = "") -> int:
    """Refuse work of at least `steps` integrator steps (an estimate made before the run)
    above `max_steps`: `MemoryLimitError` with one line ``WHAT takes at least N steps, more
    than max_steps=M; ADVICE`` (`what` names the options that set the size, with their
    values). Returns the estimate as an int."""
    if not steps <= max_steps:         # NaN or inf: refused too
        raise MemoryLimitError(f"{what} takes at least {steps:.3g} steps, more than "
                               f"max_steps={max_steps}" + (f"; {advice}" if advice else ""))
    return int(steps)
