"""Numbers as an engineer reads them: 0.01 mm, 5000 rpm, 207 GPa, 8311 N.

One place for the display of quantities in the report, the CLI's tables and --help. Values
stay SI everywhere else; these functions only turn them into text.

    >>> quantity(9.999999999999593e-06, "m")
    '0.01 mm'
    >>> quantity(523.5987755982989, "rad/s")
    '5000 rpm'
    >>> quantity(207e9, "Pa")
    '207 GPa'
    >>> derived(0.000252, "kg m^2", "uniform rod")
    'computed: 0.000252 kg m^2 (uniform rod)'
"""

from __future__ import annotations

import math

__all__ = ["number", "quantity", "derived", "percent", "duration", "DISPLAY_UNITS"]

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
