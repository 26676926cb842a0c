"""Numbers as an engineer reads them: 0.01 mm, 5000 rpm, 207 GPa, 8311 N.

One place for quantities as text: their display in the report, the CLI's tables and --help
(`quantity`, `number`), and the one reader of a value with a unit suffix that every command
uses (`parse_quantity`: "5000rpm", "0.01 mm", "90deg"). Values stay SI everywhere else.

    >>> quantity(9.999999999999593e-06, "m")
    '0.01 mm'
    >>> quantity(523.5987755982989, "rad/s")
    '5000 rpm'
    >>> quantity(207e9, "Pa")
    '207 GPa'
    >>> derived(0.000252, "kg m^2", "uniform rod")
    'computed: 0.000252 kg m^2 (uniform rod)'
    >>> parse_quantity("5000rpm", "rad/s")
    523.5987755982989
    >>> parse_quantity("0.01 mm", "m")
    1e-05
"""

from __future__ import annotations

import math
import re

__all__ = ["number", "quantity", "derived", "percent", "duration", "DISPLAY_UNITS",
           "UNIT_SUFFIXES", "parse_quantity", "unit_of_path", "suffixes_of"]

_RPM = 2.0 * math.pi / 60.0

#: SI unit -> (display unit, factor SI -> display) chosen by magnitude in `quantity`
DISPLAY_UNITS = {
    "m": (("m", 1.0), ("mm", 1e3), ("um", 1e6)),
    "Pa": (("GPa", 1e-9), ("MPa", 1e-6), ("kPa", 1e-3), ("Pa", 1.0)),
    "s": (("s", 1.0), ("ms", 1e3), ("us", 1e6)),
}


def number(value: float, digits: int = 4) -> str:
    """`value` with `digits` significant digits, no trailing zeros, no exponent between
    1e-4 and 1e6 (0.000252, 8311, 43.85; 3.2e+10 beyond)."""
    if value is None:
        return "-"
    value = float(value)
    if not math.isfinite(value):
        return str(value)
    if value == 0.0:
        return "0"
    exponent = math.floor(math.log10(abs(value)))
    if -4 <= exponent < 6:
        decimals = max(digits - 1 - exponent, 0)
        text = f"{round(value, decimals):.{decimals}f}"
        if "." in text:
            text = text.rstrip("0").rstrip(".")
        return text
    mantissa, power = f"{value:.{digits - 1}e}".split("e")
    if "." in mantissa:
        mantissa = mantissa.rstrip("0").rstrip(".")
    return f"{mantissa}e{int(power)}"


def quantity(value: float, unit: str, digits: int = 4) -> str:
    """`value` (SI, in `unit`) in the display unit an engineer expects: lengths below 1 m
    in mm (below 0.001 mm in um), pressures in GPa/MPa, speeds in rad/s as rpm, times in
    s/ms/us; other units as given. ``quantity(1e-5, "m") == "0.01 mm"``."""
    if value is None:
        return "-"
    if unit in ("-", ""):
        return number(value, digits)
    if unit == "rad/s":
        return f"{number(value / _RPM, digits)} rpm"
    if unit in DISPLAY_UNITS:
        options = DISPLAY_UNITS[unit]
        a = abs(float(value))
        if unit == "m":
            name, factor = options[0] if a >= 1.0 else options[1] if a >= 1e-6 else options[2]
        elif unit == "s":
            name, factor = options[0] if a >= 1.0 else options[1] if a >= 1e-3 else options[2]
        else:
            name, factor = next(((n, f) for n, f in options if a * f >= 1.0), options[-1])
        return f"{number(value * factor, digits)} {name}"
    return f"{number(value, digits)} {unit}"


def derived(value: float, unit: str, how: str, digits: int = 4) -> str:
    """A value the model computes from others: ``computed: 0.000252 kg m^2 (uniform rod)``."""
    return f"computed: {quantity(value, unit, digits)} ({how})"


def percent(value: float, digits: int = 4, sign: bool = False) -> str:
    """A percentage: ``percent(43.851) == '43.85 %'``; `sign` adds + to positive values."""
    text = number(value, digits)
    if sign and value is not None and value > 0:
        text = "+" + text
    return f"{text} %"


def duration(seconds: float) -> str:
    """A run time: ``duration(0.0123) == '12.3 ms'``, ``duration(95) == '1 min 35 s'``."""
    if seconds is None:
        return "-"
    if seconds >= 60.0:
        minutes, rest = divmod(round(seconds), 60)
        return f"{minutes} min {rest} s"
    return quantity(seconds, "s", 3)


#: SI unit -> {suffix: factor to SI}: the units a value may be given in, on the command line
#: and in sweeps. No suffix belongs to two units, so a suffix alone says what it converts;
#: a number without a suffix is SI.
UNIT_SUFFIXES: dict[str, dict[str, float]] = {
    "m": {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6},
    "rad": {"rad": 1.0, "deg": math.pi / 180.0},
    "rad/s": {"rad/s": 1.0, "rpm": _RPM, "deg/s": math.pi / 180.0},
    "s": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "min": 60.0},
    "kg": {"kg": 1.0, "g": 1e-3},
    "kg m^2": {"kg m^2": 1.0, "kg*m^2": 1.0, "g cm^2": 1e-7},
    "N": {"N": 1.0, "kN": 1e3},
    "N m": {"N m": 1.0, "Nm": 1.0, "N*m": 1.0},
    "Pa": {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "GPa": 1e9},
    "Pa s": {"Pa s": 1.0, "mPa s": 1e-3},
    "m/s": {"m/s": 1.0, "mm/s": 1e-3},
    "m/s^2": {"m/s^2": 1.0},
}
_SUFFIX_UNIT = {suffix: unit for unit, table in UNIT_SUFFIXES.items() for suffix in table}
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_VALUE = re.compile(rf"\s*({_NUMBER})\s*(.*?)\s*")


def suffixes_of(unit: str) -> tuple[str, ...]:
    """The suffixes a value of `unit` (SI) may carry (empty for a unit without any)."""
    return tuple(UNIT_SUFFIXES.get(unit, {}))


def parse_quantity(text, unit: str | None = None, item: str = "value") -> float:
    """A number with an optional unit suffix, in SI.

    Parameters
    ----------
    text : str or float
        "5000rpm", "0.02 mm", "90deg", "1e-5" (no suffix: SI); a number is taken as is.
    unit : str or None
        The SI unit the value must have ("m", "rad/s", ..., `UNIT_SUFFIXES`); "-" for a
        dimensionless value (no suffix allowed); None when not known: the suffix alone
        converts the value.
    item : str
        The option or field named in the error.

    Returns
    -------
    float
        The value in SI units.

    Raises
    ------
    ValueError
        One line naming `item`, the text and the allowed suffixes: not a number, an unknown
        suffix, or a suffix of another unit.
    """
    if not isinstance(text, str):
        return float(text)
    try:                # a plain number (also inf and nan: the caller checks the range)
        return float(text)
    except ValueError:
        pass
    match = _VALUE.fullmatch(text)
    allowed = suffixes_of(unit) if unit is not None else ()
    hint = (f" (a number in {unit}, or with one of {', '.join(allowed)})" if allowed
            else " (a number)" if unit in ("-", "") else f" (a number in {unit})"
            if unit else "")
    if not match:
        raise ValueError(f"{item}: {text!r} is not a number{hint}")
    value, suffix = float(match.group(1)), match.group(2)
    if not suffix:
        return value
    own = _SUFFIX_UNIT.get(suffix)
    if own is None or (unit is not None and own != unit):
        what = "an unknown unit" if own is None else f"a unit of {own}"
        raise ValueError(f"{item}: {text!r} has {what}{hint}")
    return value * UNIT_SUFFIXES[own][suffix]


#: the SI unit of a description's dotted parameter path by its last part
#: (`Linkage.parameter_names`: "coupler.mass", "drive.speed", "journal.bearing_radius", ...)
PATH_UNITS = {
    "mass": "kg", "inertia": "kg m^2", "x": "m", "y": "m", "angle": "rad",
    "slider_angle": "rad", "initial_angle": "rad", "speed": "rad/s", "crank_speed": "rad/s",
    "gravity": "m/s^2",
    "clearance": "m", "bearing_radius": "m", "journal_radius": "m", "half_length": "m",
    "half_height": "m", "bearing_length": "m", "youngs_modulus": "Pa", "viscosity": "Pa s",
    "impact_velocity_floor": "m/s", "restitution": "-", "poisson_ratio": "-",
    "contact_stiffness": "N/m^1.5", "film_fade_start": "-", "film_fade_end": "-",
    "friction_coefficient": "-", "friction_static_coefficient": "-", "friction_v0": "m/s",
    "friction_v1": "m/s", "friction_stribeck_velocity": "m/s",
}


def unit_of_path(name: str) -> str | None:
    """The SI unit of a dotted parameter path of a description by its last part
    (`PATH_UNITS`); None when the part is not one of them."""
    return PATH_UNITS.get(name.rsplit(".", 1)[-1])
