"""The slider-crank mechanism with a clearance joint between coupler and slider.

`SliderCrank` holds every physical parameter in SI units. Its defaults are the paper's case
(Ebrahimi, Salahshoor & Nouri 2018, Tables 1-2) completed with Flores & Ambrosio's benchmark
(crank inertia, crank speed, gravity). Values are validated on construction so that bad input
fails early with a message naming the field and its allowed range.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .._io import read_json_object
from ..laws.forces import CONTACT_MODELS, stiffness_eq9
from ..laws.registry import FRICTION_SLOTS
from .linkage import FRICTION_DEFAULTS, check_friction

__all__ = ["SliderCrank", "PARAMETER_INFO", "CONTINUOUS_FIELDS"]

RPM = 2.0 * math.pi / 60.0

#: field -> (paper symbol, unit, source of the default value)
PARAMETER_INFO: dict[str, tuple[str, str, str]] = {
    "crank_length": ("L2", "m", "paper Table 1"),
    "coupler_length": ("L3", "m", "paper Table 1"),
    "crank_mass": ("m2", "kg", "paper Table 1"),
    "coupler_mass": ("m3", "kg", "paper Table 1"),
    "slider_mass": ("m4", "kg", "paper Table 1"),
    "crank_inertia": ("J2", "kg m^2", "Flores & Ambrosio 2004 (Computers & Structures 82)"),
    "coupler_inertia": ("J3", "kg m^2", "uniform thin rod m3 L3^2/12 (paper)"),
    "crank_speed": ("omega2", "rad/s",
                    "Flores & Ambrosio 2004 (Computers & Structures 82), 5000 rpm"),
    "initial_crank_angle": ("theta20", "rad", "Flores & Ambrosio 2004 (Computers & Structures 82)"),
    "bearing_radius": ("R_B", "m", "paper Table 2"),
    "journal_radius": ("R_J", "m", "paper Table 2 (clearance 0.01 mm)"),
    "youngs_modulus": ("E", "Pa", "paper Table 2"),
    "poisson_ratio": ("nu", "-", "paper Table 2"),
    "restitution": ("e_r", "-", "paper Table 2"),
    "contact_stiffness": ("K", "N/m^1.5", "paper Eq. 9 from radii and materials"),
    "gravity": ("g", "m/s^2", "standard gravity along -y"),
    "contact_model": ("-", "-", "paper: Lankarani-Nikravesh"),
    "impact_velocity_floor": ("v_min", "m/s",
                              "assumed: a numerical floor for grazing onsets, about a "
                              "thousandth of the impact velocities (docs/derivations.md)"),
    # friction in the clearance joint (docs/friction.md)
    **{k: (sym, unit, source) for k, (sym, unit, _, source) in FRICTION_DEFAULTS.items()},
}

#: fields that are real numbers and can be design variables (sensitivities, GA genes)
CONTINUOUS_FIELDS: tuple[str, ...] = tuple(
    k for k in PARAMETER_INFO if k not in ("contact_model", "friction_law")
)


def _is_real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


@dataclass(frozen=True)
class SliderCrank:
    """Planar slider-crank with a radial clearance in the coupler-slider revolute joint.

    All values are SI. Bodies: 2 = crank (driven at constant speed), 3 = coupler,
    4 = slider. The crank pivot is the origin, the slider moves along x.

    Parameters
    ----------
    crank_length : float
        L2 in m.
    coupler_length : float
        L3 in m (L3 > L2 so that the crank can turn fully).
    crank_mass : float
        m2 in kg.
    coupler_mass : float
        m3 in kg.
    slider_mass : float
        m4 in kg.
    crank_inertia : float or None
        J2 about the centre of mass in kg m^2; None means a uniform thin rod m2 L2^2/12.
    coupler_inertia : float or None
        J3 about the centre of mass in kg m^2; None means a uniform thin rod m3 L3^2/12.
    crank_speed : float
        Constant crank speed omega2 in rad/s (> 0); the default is 5000 rpm.
    initial_crank_angle : float
        theta20 in rad.
    bearing_radius : float
        R_B in m (> journal_radius).
    journal_radius : float
        R_J in m (0 < R_J < R_B); the radial clearance is R_B - R_J.
    youngs_modulus : float
        E in Pa, the same for journal and bearing.
    poisson_ratio : float
        nu in (-1, 0.5), the same for journal and bearing.
    restitution : float
        Coefficient of restitution e_r in (0, 1].
    contact_stiffness : float or None
        K in N/m^1.5; None computes it from Eq. 9 of the paper.
    gravity : float
        g in m/s^2, acting along -y.
    contact_model : str
        One of ``CONTACT_MODELS`` (`mbs_clearance.laws`): "lankarani_nikravesh" (paper),
        "hunt_crossley", "flores", "hu_guo".
    impact_velocity_floor : float
        Lower bound in m/s on the impact velocity used by the hysteresis damping; it only
        matters for grazing onsets, where the measured impact velocity tends to zero.
    friction_law : str
        Friction in the clearance joint (`contact.FRICTION_LAWS`): "none" (default, the
        paper's frictionless joint), "coulomb" (regularised over friction_v0), "ambrosio"
        (Ambrosio's modified Coulomb law between friction_v0 and friction_v1) or "stribeck"
        (from the static to the dynamic coefficient over the Stribeck velocity).
    friction_coefficient : float
        Coefficient of friction mu >= 0 (the dynamic one of the Stribeck law).
    friction_v0 : float
        Tangential velocity v0 > 0 in m/s: the scale over which the "coulomb" and
        "stribeck" laws smooth the sign of the sliding velocity, the lower threshold of
        "ambrosio" (the assumed defaults and their sources: `linkage.FRICTION_DEFAULTS`).
    friction_v1 : float
        Tangential velocity v1 > v0 in m/s: the upper threshold of "ambrosio".
    friction_static_coefficient : float
        The Stribeck law's static coefficient mu_s (>= friction_coefficient).
    friction_stribeck_velocity : float
        The Stribeck law's Stribeck velocity v_s > 0 in m/s.
    """

    crank_length: float = 0.05
    coupler_length: float = 0.12
    crank_mass: float = 0.30
    coupler_mass: float = 0.21
    slider_mass: float = 0.14
    crank_inertia: float | None = 1.0e-4
    coupler_inertia: float | None = None
    crank_speed: float = 5000.0 * RPM
    initial_crank_angle: float = 0.0
    bearing_radius: float = 0.010
    journal_radius: float = 0.00999
    youngs_modulus: float = 207.0e9
    poisson_ratio: float = 0.3
    restitution: float = 0.9
    contact_stiffness: float | None = None
    gravity: float = 9.81
    contact_model: str = "lankarani_nikravesh"
    impact_velocity_floor: float = 1.0e-3
    friction_law: str = "none"
    friction_coefficient: float = 0.0
    friction_v0: float = 1.0e-4
    friction_v1: float = 1.0e-2
    friction_static_coefficient: float = 0.0
    friction_stribeck_velocity: float = 1.0e-3

    def __post_init__(self) -> None:
        # numbers of any numeric type (numpy scalars, Fraction, int) are stored as Python
        # floats, so that every value is JSON-serialisable and behaves as a float
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name not in ("contact_model", "friction_law") and _is_real(value):
                try:
                    as_float = float(value)
                except OverflowError:
                    raise ValueError(f"{f.name} must be a finite number; got {value!r}") from None
                object.__setattr__(self, f.name, as_float)
        positive = (
            "crank_length", "coupler_length", "crank_mass", "coupler_mass", "slider_mass",
            "crank_speed", "bearing_radius", "journal_radius", "youngs_modulus",
            "impact_velocity_floor",
        )
        for name in positive:
            _check_number(name, getattr(self, name), "a finite number > 0", lambda v: v > 0)
        for name in ("crank_inertia", "coupler_inertia", "contact_stiffness"):
            value = getattr(self, name)
            if value is not None:
                _check_number(name, value, "None or a finite number > 0", lambda v: v > 0)
        _check_number("initial_crank_angle", self.initial_crank_angle, "a finite number (rad)",
                      lambda v: True)
        _check_number("gravity", self.gravity, "a finite number (m/s^2)", lambda v: True)
        _check_number("poisson_ratio", self.poisson_ratio, "in the open interval (-1, 0.5)",
                      lambda v: -1.0 < v < 0.5)
        _check_number("restitution", self.restitution, "in the interval (0, 1]",
                      lambda v: 0.0 < v <= 1.0)
        if self.journal_radius >= self.bearing_radius:
            raise ValueError(
                f"journal_radius must be smaller than bearing_radius ({self.bearing_radius!r} m);"
                f" got {self.journal_radius!r} m (allowed range: 0 < journal_radius <"
                " bearing_radius)"
            )
        if self.coupler_length <= self.crank_length:
            raise ValueError(
                f"coupler_length must be greater than crank_length ({self.crank_length!r} m) for"
                f" the crank to turn fully; got {self.coupler_length!r} m"
            )
        if self.contact_model not in CONTACT_MODELS:
            raise ValueError(
                f"contact_model must be one of {sorted(CONTACT_MODELS)}; "
                f"got {self.contact_model!r}"
            )
        check_friction("SliderCrank", self.friction_law,
                       *(getattr(self, f) for f in FRICTION_SLOTS))

    # ------------------------------------------------------------------ derived values
    @property
    def clearance(self) -> float:
        """Radial clearance c = R_B - R_J in m."""
        return self.bearing_radius - self.journal_radius

    @property
    def stiffness(self) -> float:
        """Contact stiffness K in N/m^1.5: `contact_stiffness` or Eq. 9 of the paper."""
        if self.contact_stiffness is not None:
            return float(self.contact_stiffness)
        # the law's python source: the compiled kernel would compile on first use
        return stiffness_eq9(self.journal_radius, self.bearing_radius,
                                     self.youngs_modulus, self.poisson_ratio)

    @property
    def crank_inertia_value(self) -> float:
        """J2 in kg m^2 (uniform thin rod when `crank_inertia` is None)."""
        if self.crank_inertia is not None:
            return float(self.crank_inertia)
        return self.crank_mass * self.crank_length**2 / 12.0

    @property
    def coupler_inertia_value(self) -> float:
        """J3 in kg m^2 (uniform thin rod when `coupler_inertia` is None)."""
        if self.coupler_inertia is not None:
            return float(self.coupler_inertia)
        return self.coupler_mass * self.coupler_length**2 / 12.0

    @property
    def default_output(self) -> str:
        """The monitored output, "pivot_force:crank_pivot": |F12|, the crank pivot's
        reaction (the paper's base force), as of the case's `Linkage`."""
        return "pivot_force:crank_pivot"

    @property
    def period(self) -> float:
        """Duration of one crank revolution in s."""
        return 2.0 * math.pi / self.crank_speed

    @property
    def crank_speed_rpm(self) -> float:
        """Crank speed in revolutions per minute."""
        return self.crank_speed / RPM

    # ------------------------------------------------------------------ variants and I/O
    def replace(self, **changes: Any) -> SliderCrank:
        """Return a validated copy with some fields changed (unknown names raise ValueError)."""
        check_field_names(changes)
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Field values as a plain dict (JSON-serialisable)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SliderCrank:
        """Build from a dict of field values; unknown keys raise ValueError."""
        check_field_names(data)
        return cls(**data)

    @classmethod
    def from_json(cls, path: str | Path) -> SliderCrank:
        """Read field values from a JSON file (an object of field: value)."""
        return cls.from_dict(read_json_object(path, "mechanism file"))


def field_names() -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(SliderCrank))


def check_field_names(names: Any, allowed: tuple[str, ...] | None = None) -> None:
    """Raise ValueError if any name is not a SliderCrank field (or not in `allowed`)."""
    allowed = field_names() if allowed is None else allowed
    unknown = [n for n in names if n not in allowed]
    if unknown:
        raise ValueError(f"unknown parameter name(s) {unknown}; allowed: {list(allowed)}")


def _check_number(name: str, value: Any, allowed: str, ok) -> None:
    if not _is_real(value) or not math.isfinite(value) or not ok(value):
        raise ValueError(f"{name} must be {allowed}; got {value!r}")


def reference_value(mech: SliderCrank, name: str) -> float:
    """Value b0 of a design parameter (the derived value where the field is None)."""
    derived = {"contact_stiffness": mech.stiffness,
               "crank_inertia": mech.crank_inertia_value,
               "coupler_inertia": mech.coupler_inertia_value}
    if name in derived:
        return float(derived[name])
    return float(getattr(mech, name))
