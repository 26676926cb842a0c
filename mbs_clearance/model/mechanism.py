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

__all__ = ["SliderCrank", "PARAMETER_INFO", "CONTINUOUS_FIELDS", "FIELD_PATHS",
           "FieldPath", "description_values", "field_directions", "PAPER_JOINT"]

RPM = 2.0 * math.pi / 60.0

#: the clearance joint of the paper's description (`cases.from_slider_crank`)
PAPER_JOINT = "coupler_slider"

#: the slider's inertia per unit mass (m^2): it does not turn (prismatic joint), so the
#: value never enters the motion; the paper gives none. A 1 cm uniform square block
#: (a^2 / 6, a = 0.01 m) makes the description complete
SLIDER_INERTIA_PER_MASS = 0.01**2 / 6.0


@dataclass(frozen=True)
class FieldPath:
    """One `SliderCrank` field: its paper symbol, unit, the source of its default, and the
    description's parameters it sets (``{dotted path: d value / d field}``; a text field,
    e.g. the contact model, sets its path to its value)."""

    symbol: str
    unit: str
    source: str
    paths: dict[str, float]


def _joint_field(symbol: str, unit: str, source: str, name: str) -> FieldPath:
    return FieldPath(symbol, unit, source, {f"{PAPER_JOINT}.{name}": 1.0})


_TABLE_1 = "paper Table 1"
_TABLE_2 = "paper Table 2"
_FLORES = "Flores & Ambrosio 2004 (Computers & Structures 82)"

#: the one table of the paper's fields: field -> `FieldPath` (symbol, unit, source, and the
#: dotted paths of its description `cases.from_slider_crank` with their coefficients). The
#: description, the fields' directions in it (`field_directions`, the sensitivities' and
#: the gradient's) and the way back from a case's overrides (`design.slider_crank_of`) are
#: all read from it. The inertias None (uniform rods) are derived: `field_directions`
#: adds their dependence on the lengths and masses
FIELD_PATHS: dict[str, FieldPath] = {
    "crank_length": FieldPath("L2", "m", _TABLE_1, {"crank.pivot.x": -0.5, "crank.pin.x": 0.5}),
    "coupler_length": FieldPath("L3", "m", _TABLE_1, {"coupler.crank_end.x": -0.5,
                                                      "coupler.slider_end.x": 0.5}),
    "crank_mass": FieldPath("m2", "kg", _TABLE_1, {"crank.mass": 1.0}),
    "coupler_mass": FieldPath("m3", "kg", _TABLE_1, {"coupler.mass": 1.0}),
    "slider_mass": FieldPath("m4", "kg", _TABLE_1, {"slider.mass": 1.0,
                                                    "slider.inertia": SLIDER_INERTIA_PER_MASS}),
    "crank_inertia": FieldPath("J2", "kg m^2", _FLORES, {"crank.inertia": 1.0}),
    "coupler_inertia": FieldPath("J3", "kg m^2", "uniform thin rod m3 L3^2/12 (paper)",
                                 {"coupler.inertia": 1.0}),
    "crank_speed": FieldPath("omega2", "rad/s", f"{_FLORES}, 5000 rpm", {"drive.speed": 1.0}),
    "initial_crank_angle": FieldPath("theta20", "rad", _FLORES, {"drive.initial_angle": 1.0}),
    "bearing_radius": _joint_field("R_B", "m", _TABLE_2, "bearing_radius"),
    "journal_radius": _joint_field("R_J", "m", f"{_TABLE_2} (clearance 0.01 mm)",
                                   "journal_radius"),
    "youngs_modulus": _joint_field("E", "Pa", _TABLE_2, "youngs_modulus"),
    "poisson_ratio": _joint_field("nu", "-", _TABLE_2, "poisson_ratio"),
    "restitution": _joint_field("e_r", "-", _TABLE_2, "restitution"),
    "contact_stiffness": _joint_field("K", "N/m^1.5", "paper Eq. 9 from radii and materials",
                                      "contact_stiffness"),
    "gravity": FieldPath("g", "m/s^2", "standard gravity along -y", {"gravity": 1.0}),
    "contact_model": _joint_field("-", "-", "paper: Lankarani-Nikravesh", "contact_model"),
    "impact_velocity_floor": _joint_field(
        "v_min", "m/s", "assumed: a numerical floor for grazing onsets, about a thousandth "
                        "of the impact velocities (docs/derivations.md)",
        "impact_velocity_floor"),
    # friction in the clearance joint (docs/friction.md)
    **{k: _joint_field(sym, unit, source, k)
       for k, (sym, unit, _, source) in FRICTION_DEFAULTS.items()},
}

#: field -> (paper symbol, unit, source of the default value), read from `FIELD_PATHS`
PARAMETER_INFO: dict[str, tuple[str, str, str]] = {
    k: (v.symbol, v.unit, v.source) for k, v in FIELD_PATHS.items()}

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


def description_values(mech: SliderCrank) -> dict[str, Any]:
    """The values of `mech`'s description (`cases.from_slider_crank`) by dotted path, read
    through `FIELD_PATHS`: each path its coefficient times its field's value in use (an
    inertia None: the uniform rod's; the contact stiffness None stays None: Eq. 9 in the
    description)."""
    out: dict[str, Any] = {}
    for name, spec in FIELD_PATHS.items():
        value = getattr(mech, name)
        if name in ("crank_inertia", "coupler_inertia"):
            value = getattr(mech, f"{name}_value")
        for path, coef in spec.paths.items():
            out[path] = value if coef == 1.0 else coef * value
    # m a^2 / 6 in this order, the description's value to the last bit
    out["slider.inertia"] = mech.slider_mass * 0.01**2 / 6.0
    return out


def field_directions(mech: SliderCrank, names) -> list[dict[str, float]]:
    """Per field of `names`, its direction in the description's parameters ({dotted path:
    d value / d field}, exact: the description is linear in every field (`FIELD_PATHS`)
    but the derived uniform-rod inertias m L^2 / 12, differentiated here). A friction field
    is a parameter only where the joint has a friction law (else no direction). The
    description's own chain takes the radii and the material into the clearance and the
    Eq. 9 stiffness."""
    out = []
    for name in names:
        if name in FRICTION_SLOTS:
            out.append(dict(FIELD_PATHS[name].paths) if mech.friction_law != "none" else {})
        else:
            out.append({**FIELD_PATHS[name].paths, **_derived_inertia(mech, name)})
    return out


def _derived_inertia(mech: SliderCrank, name: str) -> dict[str, float]:
    """d(inertia)/d(field) of the uniform-rod inertias m L^2 / 12 where they are derived."""
    out = {}
    if mech.crank_inertia is None:
        m, L = mech.crank_mass, mech.crank_length
        out.update({"crank_length": ("crank.inertia", m * L / 6.0),
                    "crank_mass": ("crank.inertia", L * L / 12.0)})
    if mech.coupler_inertia is None:
        m, L = mech.coupler_mass, mech.coupler_length
        out.update({"coupler_length": ("coupler.inertia", m * L / 6.0),
                    "coupler_mass": ("coupler.inertia", L * L / 12.0)})
    return dict([out[name]]) if name in out else {}
