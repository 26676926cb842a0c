"""The description of a planar linkage with revolute clearance joints (`Linkage`).

A linkage is rigid bodies (mass, inertia about the centre of mass, named points in the body
frame), ideal revolute and prismatic joints, one constant-speed drive of a revolute joint to
the ground, gravity along -y, any number of revolute clearance joints and of translational
(prismatic) clearance joints (`TranslationalClearance`: a rectangular slider in a guide,
its four corners each a contact). Every value is SI.
The clearance joints cut the kinematic loops: the ideal joints must form a forest rooted at
the ground, so that the equations of motion are ODEs in minimal coordinates (no DAE). Bodies
with no ideal path to the ground float (x, y, angle).

Coordinates (`Linkage.coordinates`), in the order of the joints, then of the floating bodies:

- a Revolute other than the drive's: "<body>.angle", the ABSOLUTE angle of the body on the
  joint's far side from the ground (its x axis against the ground's x axis). An angle
  relative to a body that turns with the crank grows by 2 pi per revolution, and with it the
  integrator's relative error scale; the absolute angle of a coupler or a rocker stays
  bounded;
- a Prismatic: "<joint>.s", the distance of point_b from point_a along the axis;
- a floating body: "<body>.x", "<body>.y" (its centre of mass), "<body>.angle".

The drive's angle (body_b's angle) is prescribed, speed t + initial_angle, not a coordinate.
A free linkage (``drive=None``) has no prescribed motion: every joint's angle is a
coordinate, and the run starts from `Initial` coordinates and rates (the equations are
autonomous; a run covers a duration in s instead of drive revolutions).

Every description is validated on construction: a bad value raises ValueError naming the
item and its allowed range, a graph error (unknown body or point, a closed loop of ideal
joints, a drive not on a ground revolute, two clearance joints on one pin, ...) names the
joints involved. Every name is an identifier (`NAME_RULE`: names reach the generated
model's source and its cache), and the sizes are bounded (`MAX_BODIES`, `MAX_POINTS`,
`MAX_JOINTS`, `MAX_CLEARANCE_JOINTS`), so that a description is refused before any work.
`Linkage.from_file` also checks that the loops close with the journals centred (`assemble`).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import numbers
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..laws.forces import CONTACT_MODELS, FRICTION_LAWS, stiffness_eq9
from ..laws.lubrication import BEARING_LENGTH, FADE_END, FADE_START, VISCOSITY, check_fade
from ..laws.lubrication import MODELS as LUBRICATION_MODELS
from ..laws.registry import FRICTION_PARAMETER_SPECS, FRICTION_SLOTS, friction_law
from ..laws.wear.archard import WEAR_COEFFICIENT
from .profile import BearingProfile, check_profile

__all__ = ["Point", "GROUND", "RESERVED_NAMES", "Body", "Revolute", "Prismatic", "ClearanceJoint",
           "TranslationalClearance", "CORNERS", "Drive", "Initial", "Linkage",
           "FRICTION_DEFAULTS", "check_friction", "check_lubrication"]

Point = tuple[float, float]
#: reserved body name of the ground; its points are `Linkage.ground_points`
GROUND = "ground"
#: names no body or joint may take: the keys a dotted path (`Linkage.with_parameter`, the
#: command line's --set) resolves before the items' names ("gravity", "drive.speed",
#: "ground.<point>.x") and the description's sections accepted in front of a path
#: ("bodies.coupler.mass"); an item of such a name would be shadowed by the key
RESERVED_NAMES = (GROUND, "gravity", "drive", "bodies", "joints", "clearance_joints",
                  "translational_joints", "ground_points")


def _check_reserved(kind: str, name: str) -> None:
    """ValueError where an item's `name` is one of `RESERVED_NAMES`, with the reason."""
    if name in RESERVED_NAMES:
        raise ValueError(
            f"{kind} name {name!r} is reserved: {name!r} is a key of the description, so a "
            f"dotted path such as {name + '.mass'!r} (--set, Linkage.with_parameter) would "
            f"mean the key, not the {kind}; rename the {kind} (reserved: "
            f"{', '.join(RESERVED_NAMES)})")


def _is_real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _real(item: str, value: Any, allowed: str = "a finite number", ok=lambda v: True,
          ) -> float:
    """`value` as a float, or ValueError naming `item` and the allowed range."""
    good = _is_real(value)
    if good:
        try:
            value = float(value)
        except OverflowError:
            good = False
        good = good and math.isfinite(value) and ok(value)
    if not good:
        raise ValueError(f"{item} must be {allowed}; got {_short(value)}")
    return value


#: the rule every name of a description follows (names reach generated code and files)
NAME_RULE = "an identifier [A-Za-z_][A-Za-z0-9_]* of at most 64 characters"
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")


def _short(value: Any, limit: int = 60) -> str:
    """repr of `value`, cut to `limit` characters (a message stays one short line)."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _name(item: str, value: Any) -> str:
    """`value` if it is a valid name (NAME_RULE), else ValueError naming `item`."""
    if not isinstance(value, str) or _IDENTIFIER.fullmatch(value) is None:
        raise ValueError(f"{item} must be {NAME_RULE}; got {_short(value)}")
    return value


#: the most bodies, points per body (and of the ground), ideal joints and clearance joints
#: a description may hold: the derivation's cost grows fast with them, so a larger one is
#: refused at once instead of after minutes of work
MAX_BODIES = 64
MAX_POINTS = 64
MAX_JOINTS = 128
MAX_CLEARANCE_JOINTS = 32


def _points(item: str, points: Any) -> dict[str, Point]:
    if not isinstance(points, Mapping):
        raise ValueError(f"{item} must be a mapping of point name to (x, y) in m; "
                         f"got {_short(points)}")
    if len(points) > MAX_POINTS:
        raise ValueError(f"{item} holds {len(points)} points; at most {MAX_POINTS} are "
                         f"allowed")
    out = {}
    for key, xy in points.items():
        _name(f"{item} key", key)
        if isinstance(xy, (str, bytes)) or not hasattr(xy, "__len__") or len(xy) != 2:
            raise ValueError(f"{item}[{key!r}] must be a pair (x, y) of finite numbers in m; "
                             f"got {_short(xy)}")
        out[key] = (_real(f"{item}[{key!r}] x", xy[0], "a finite number (m)"),
                    _real(f"{item}[{key!r}] y", xy[1], "a finite number (m)"))
    return out


@dataclass(frozen=True)
class Body:
    """A rigid body: mass in kg, inertia about the centre of mass in kg m^2, and named points
    (x, y) in m in the body frame, whose origin is the centre of mass and whose x axis is the
    body's reference line (the body's angle is that axis's angle)."""

    name: str
    mass: float
    inertia: float
    points: Mapping[str, Point] = field(default_factory=dict)

    def __post_init__(self) -> None:
        _name("body name", self.name)
        if self.name == GROUND:
            raise ValueError(f"body name {GROUND!r} is reserved for the ground (its points are "
                             "Linkage.ground_points)")
        what = f"body {self.name!r}"
        object.__setattr__(self, "mass", _real(f"{what} mass", self.mass,
                                               "a finite number > 0 (kg)", lambda v: v > 0))
        object.__setattr__(self, "inertia", _real(f"{what} inertia", self.inertia,
                                                  "a finite number > 0 (kg m^2)",
                                                  lambda v: v > 0))
        object.__setattr__(self, "points", _points(f"{what} points", self.points))


@dataclass(frozen=True)
class Revolute:
    """Ideal pin: point_a of body_a coincides with point_b of body_b."""

    name: str
    body_a: str
    point_a: str
    body_b: str
    point_b: str

    def __post_init__(self) -> None:
        _joint_names(self)


@dataclass(frozen=True)
class Prismatic:
    """Ideal slider: body_b keeps body_a's orientation; point_b moves along the axis through
    point_a at `angle` (rad, in body_a's frame); the coordinate s is point_b's distance from
    point_a along the axis."""

    name: str
    body_a: str
    point_a: str
    body_b: str
    point_b: str
    angle: float = 0.0

    def __post_init__(self) -> None:
        _joint_names(self)
        object.__setattr__(self, "angle", _real(f"joint {self.name!r} angle", self.angle,
                                                "a finite number (rad)"))


def _joint_names(joint) -> None:
    _name("joint name", joint.name)
    for f in ("body_a", "point_a", "body_b", "point_b"):
        _name(f"joint {joint.name!r} {f}", getattr(joint, f))
    if joint.body_a == joint.body_b:
        raise ValueError(f"joint {joint.name!r} joins body {joint.body_a!r} to itself; "
                         "body_a and body_b must differ")


@dataclass(frozen=True)
class ClearanceJoint:
    """A revolute joint with radial clearance: a journal (radius journal_radius, centred on
    journal_point of journal_body) inside a bearing (bearing_radius, centred on bearing_point
    of bearing_body). Contact: a Hertzian spring with hysteresis damping
    (`contact.CONTACT_MODELS`); stiffness from the paper's Eq. 9 unless given. With
    `lubrication` "short" or "long" the joint runs in an oil film (`laws.lubrication`:
    viscosity, bearing_length; the film fades out between the eccentricity ratios
    film_fade_start and film_fade_end, the dry contact taking over at the wall)."""

    name: str
    journal_body: str
    journal_point: str
    bearing_body: str
    bearing_point: str
    bearing_radius: float
    journal_radius: float
    youngs_modulus: float = 207e9
    poisson_ratio: float = 0.3
    restitution: float = 0.9
    contact_stiffness: float | None = None
    contact_model: str = "lankarani_nikravesh"
    impact_velocity_floor: float = 1e-3
    friction_law: str = "none"
    friction_coefficient: float = 0.0
    friction_v0: float = 1e-4
    friction_v1: float = 1e-2
    friction_static_coefficient: float = 0.0
    friction_stribeck_velocity: float = 1e-3
    lubrication: str = "none"
    viscosity: float = VISCOSITY.default
    bearing_length: float = BEARING_LENGTH.default
    film_fade_start: float = FADE_START.default
    film_fade_end: float = FADE_END.default
    #: a worn (or shaped) bearing: its radii (m) at N equally spaced angles in the bearing
    #: body's frame (`profile.BearingProfile`); None is the circle of bearing_radius
    bearing_profile: tuple[float, ...] | None = None
    #: Archard's dimensional wear coefficient k/H of the bearing (m^2/N; 0: it does not
    #: wear), read by the wear life (`studies.wear`), not by a single run
    wear_coefficient: float = 0.0

    def __post_init__(self) -> None:
        _name("clearance joint name", self.name)
        what = f"clearance joint {self.name!r}"
        for f in ("journal_body", "journal_point", "bearing_body", "bearing_point"):
            _name(f"{what} {f}", getattr(self, f))
        if self.journal_body == self.bearing_body:
            raise ValueError(f"{what} has journal and bearing on the same body "
                             f"{self.journal_body!r}; they must be on different bodies")
        positive = lambda v: v > 0          # noqa: E731
        for f, unit in (("bearing_radius", "m"), ("journal_radius", "m"),
                        ("youngs_modulus", "Pa"), ("impact_velocity_floor", "m/s")):
            object.__setattr__(self, f, _real(f"{what} {f}", getattr(self, f),
                                              f"a finite number > 0 ({unit})", positive))
        if self.journal_radius >= self.bearing_radius:
            raise ValueError(f"{what} journal_radius must be smaller than its bearing_radius "
                             f"({self.bearing_radius!r} m); got {self.journal_radius!r} m "
                             "(allowed range: 0 < journal_radius < bearing_radius)")
        object.__setattr__(self, "poisson_ratio", _real(
            f"{what} poisson_ratio", self.poisson_ratio, "in the open interval (-1, 0.5)",
            lambda v: -1.0 < v < 0.5))
        object.__setattr__(self, "restitution", _real(
            f"{what} restitution", self.restitution, "in the interval (0, 1]",
            lambda v: 0.0 < v <= 1.0))
        if self.contact_stiffness is not None:
            object.__setattr__(self, "contact_stiffness", _real(
                f"{what} contact_stiffness", self.contact_stiffness,
                "None or a finite number > 0 (N/m^1.5)", positive))
        if self.contact_model not in CONTACT_MODELS:
            raise ValueError(f"{what} contact_model must be one of {sorted(CONTACT_MODELS)}; "
                             f"got {_short(self.contact_model)}")
        check_friction(what, self.friction_law, *(getattr(self, f) for f in FRICTION_SLOTS))
        for f in FRICTION_SLOTS:
            object.__setattr__(self, f, float(getattr(self, f)))
        check_lubrication(what, self.lubrication, self.viscosity, self.bearing_length,
                          self.film_fade_start, self.film_fade_end)
        if self.lubrication != "none" and self.friction_law != "none":
            raise ValueError(f"{what} has lubrication {self.lubrication!r} and friction_law "
                             f"{self.friction_law!r}: a lubricated joint takes no friction "
                             "law (friction_law must be 'none')")
        for f in LUBRICATION_PARAMETERS:
            object.__setattr__(self, f, float(getattr(self, f)))
        object.__setattr__(self, "wear_coefficient", _real(
            f"{what} wear_coefficient", self.wear_coefficient,
            f"in {WEAR_COEFFICIENT.interval} (m^2/N)", WEAR_COEFFICIENT.contains))
        if self.bearing_profile is not None:
            object.__setattr__(self, "bearing_profile", check_profile(
                f"{what} bearing_profile", self.bearing_profile, self.journal_radius))
            if self.has_lubrication:
                raise ValueError(f"{what} has a bearing_profile and lubrication "
                                 f"{self.lubrication!r}: the oil film takes a circular bearing "
                                 "(bearing_profile must be None)")

    @property
    def profile(self) -> BearingProfile | None:
        """The bearing's shape (`profile.BearingProfile`), None for a circular bearing."""
        return None if self.bearing_profile is None else BearingProfile(self.bearing_profile)

    @property
    def has_lubrication(self) -> bool:
        """Whether the joint runs in an oil film (`laws.lubrication`): the film's force and
        torque, faded out near the wall, besides the dry contact."""
        return self.lubrication != "none"

    @property
    def has_friction(self) -> bool:
        """Whether the joint carries a friction law (its generated model has the tangential
        force; a zero coefficient still runs that model)."""
        return self.friction_law != "none"

    @property
    def clearance(self) -> float:
        """Radial clearance R_B - R_J in m; of a profiled bearing the smallest over its grid
        (the scale of the gap's tolerances, which grows with wear)."""
        if self.bearing_profile is not None:
            return min(self.bearing_profile) - self.journal_radius
        return self.bearing_radius - self.journal_radius

    @property
    def stiffness(self) -> float:
        """Contact stiffness K in N/m^1.5: `contact_stiffness` or the paper's Eq. 9."""
        if self.contact_stiffness is not None:
            return float(self.contact_stiffness)
        # the law's python source: the compiled kernel would compile on first use
        return stiffness_eq9(self.journal_radius, self.bearing_radius,
                                     self.youngs_modulus, self.poisson_ratio)


#: the corners of a translational clearance joint's slider: name -> (sign along the axis,
#: sign across it) in the slider's frame; the "top" corners touch the guide's upper surface
#: (+ normal side), the "bottom" ones its lower surface
CORNERS = {"front_top": (1.0, 1.0), "rear_top": (-1.0, 1.0),
           "front_bottom": (1.0, -1.0), "rear_bottom": (-1.0, -1.0)}


@dataclass(frozen=True)
class TranslationalClearance:
    """A prismatic joint with clearance (Flores, Ambrosio, Claro and Lankarani, J. Comput.
    Nonlinear Dyn. 3 (2008) 011007): a rectangular slider (half-length `half_length` a along
    its axis, half-height `half_height` b across it) whose centre is `slider_point` of
    `slider_body`, in a guide of width 2 (b + c) whose mid-line passes through `guide_point`
    of `guide_body` (the ground allowed) at `angle` (rad, in the guide body's frame). The
    slider's axis is at `slider_angle` (rad) in the slider body's frame. Each of the four
    corners (`CORNERS`) is its own contact with the surface on its side: penetration = the
    corner's normal offset beyond b + c, normal force of the contact law (`contact_model`,
    `restitution`, `contact_stiffness` in N/m^1.5, required: a corner on a flat surface has
    no Eq. 9), friction along the guide axis (`friction_law` and its parameters) from the
    corner's sliding velocity. The joint is the slider's guide: no ideal prismatic joint may
    join the two bodies too."""

    name: str
    guide_body: str
    guide_point: str
    slider_body: str
    slider_point: str
    half_length: float
    half_height: float
    clearance: float
    contact_stiffness: float
    angle: float = 0.0
    slider_angle: float = 0.0
    restitution: float = 0.4
    contact_model: str = "flores"
    impact_velocity_floor: float = 1e-3
    friction_law: str = "none"
    friction_coefficient: float = 0.0
    friction_v0: float = 1e-4
    friction_v1: float = 1e-2
    friction_static_coefficient: float = 0.0
    friction_stribeck_velocity: float = 1e-3

    def __post_init__(self) -> None:
        _name("translational clearance joint name", self.name)
        what = f"translational clearance joint {self.name!r}"
        for f in ("guide_body", "guide_point", "slider_body", "slider_point"):
            _name(f"{what} {f}", getattr(self, f))
        if self.guide_body == self.slider_body:
            raise ValueError(f"{what} has guide and slider on the same body "
                             f"{self.guide_body!r}; they must be on different bodies")
        if self.slider_body == GROUND:
            raise ValueError(f"{what} slider_body must be a moving body, not {GROUND!r} "
                             "(the ground may carry the guide)")
        positive = lambda v: v > 0          # noqa: E731
        for f, unit in (("half_length", "m"), ("half_height", "m"), ("clearance", "m"),
                        ("contact_stiffness", "N/m^1.5"), ("impact_velocity_floor", "m/s")):
            object.__setattr__(self, f, _real(f"{what} {f}", getattr(self, f),
                                              f"a finite number > 0 ({unit})", positive))
        for f in ("angle", "slider_angle"):
            object.__setattr__(self, f, _real(f"{what} {f}", getattr(self, f),
                                              "a finite number (rad)"))
        object.__setattr__(self, "restitution", _real(
            f"{what} restitution", self.restitution, "in the interval (0, 1]",
            lambda v: 0.0 < v <= 1.0))
        if self.contact_model not in CONTACT_MODELS:
            raise ValueError(f"{what} contact_model must be one of {sorted(CONTACT_MODELS)}; "
                             f"got {_short(self.contact_model)}")
        check_friction(what, self.friction_law, *(getattr(self, f) for f in FRICTION_SLOTS))
        for f in FRICTION_SLOTS:
            object.__setattr__(self, f, float(getattr(self, f)))

    @property
    def has_friction(self) -> bool:
        """Whether the corners carry a friction law."""
        return self.friction_law != "none"

    @property
    def stiffness(self) -> float:
        """Contact stiffness K of each corner in N/m^1.5."""
        return float(self.contact_stiffness)

    def corner_names(self) -> tuple[str, ...]:
        """The dotted names of the four corner contacts ("<joint>.<corner>", `CORNERS`)."""
        return tuple(f"{self.name}.{c}" for c in CORNERS)


@dataclass(frozen=True)
class Drive:
    """Constant-speed drive of a revolute joint to the ground: body_b's angle is
    speed t + initial_angle (speed in rad/s > 0, angle in rad)."""

    joint: str
    speed: float
    initial_angle: float = 0.0

    def __post_init__(self) -> None:
        _name("drive joint", self.joint)
        object.__setattr__(self, "speed", _real("drive speed", self.speed,
                                                "a finite number > 0 (rad/s)", lambda v: v > 0))
        object.__setattr__(self, "initial_angle", _real(
            "drive initial_angle", self.initial_angle, "a finite number (rad)"))

    @property
    def period(self) -> float:
        """Duration of one revolution of the drive in s."""
        return 2.0 * math.pi / self.speed


def _values(item: str, values: Any) -> dict[str, float]:
    """`values` (a mapping of coordinate name to a finite number) as a dict of floats."""
    if not isinstance(values, Mapping):
        raise ValueError(f"{item} must be a mapping of coordinate name to a finite number; "
                         f"got {_short(values)}")
    out = {}
    for key, value in values.items():
        if not isinstance(key, str):
            raise ValueError(f"{item} key must be a coordinate name; got {_short(key)}")
        out[key] = _real(f"{item}[{key!r}]", value, "a finite number (SI units, rad)")
    return out


@dataclass(frozen=True)
class Initial:
    """The start of a free linkage (``Linkage(drive=None)``): coordinates (by name,
    `Linkage.coordinates`; m or rad) and their rates (m/s or rad/s). A coordinate not given
    solves the loop closure of the clearance joints (journals centred) with the given ones
    held, from the linkage's assembly guesses; a rate not given solves the velocity
    constraints with the given ones held (least squares, minimum norm: a rate no constraint
    fixes starts at 0)."""

    coordinates: Mapping[str, float] = field(default_factory=dict)
    rates: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "coordinates",
                           _values("initial coordinates", self.coordinates))
        object.__setattr__(self, "rates", _values("initial rates", self.rates))


#: field -> (symbol, unit, default, source) of the friction fields of `ClearanceJoint`: the
#: law's name and the parameters the friction laws declare (`laws.friction`)
FRICTION_DEFAULTS: dict[str, tuple[str, str, Any, str]] = {
    "friction_law": ("-", "-", "none", "frictionless, the paper's Eqs. 6-8"),
    **{p.name: (p.symbol, p.unit, p.default, p.source) for p in FRICTION_PARAMETER_SPECS},
}


def check_friction(what: str, law: Any, mu: Any, v0: Any, v1: Any, *more: Any) -> None:
    """ValueError naming `what` and the item unless the friction fields are valid: law one
    of contact.FRICTION_LAWS, mu a finite number >= 0, 0 < v0 < v1 finite (m/s), and the
    further slots (`more`, in the order of `laws.FRICTION_SLOTS`) in the ranges their laws
    declare."""
    if not isinstance(law, str) or law not in FRICTION_LAWS:
        raise ValueError(f"{what} friction_law must be one of {sorted(FRICTION_LAWS)}; "
                         f"got {_short(law)}")
    _real(f"{what} friction_coefficient", mu, "a finite number >= 0", lambda v: v >= 0)
    v0 = _real(f"{what} friction_v0", v0, "a finite number > 0 (m/s)", lambda v: v > 0)
    _real(f"{what} friction_v1", v1, f"a finite number > friction_v0 = {v0!r} (m/s)",
          lambda v: v > v0)
    specs = {p.name: p for p in FRICTION_PARAMETER_SPECS}
    for name, value in zip(FRICTION_SLOTS[3:], more, strict=True):
        spec = specs[name]
        _real(f"{what} {name}", value, f"a finite number in {spec.interval} ({spec.unit})",
              spec.contains)
    spec = friction_law(law)
    if spec.check is not None:
        spec.check(what, dict(zip(FRICTION_SLOTS, (mu, v0, v1, *more), strict=True)))


def check_lubrication(what: str, model: Any, viscosity: Any, length: Any, start: Any,
                      end: Any) -> None:
    """ValueError naming `what` and the item unless the lubrication fields are valid: model
    "none" or one of `laws.lubrication.MODELS`, viscosity (Pa s) and bearing length (m)
    finite and > 0, 0 < film_fade_start < film_fade_end < 1."""
    allowed = ["none", *LUBRICATION_MODELS]
    if not isinstance(model, str) or model not in allowed:
        raise ValueError(f"{what} lubrication must be one of {allowed}; got {_short(model)}")
    for spec, value in ((VISCOSITY, viscosity), (BEARING_LENGTH, length)):
        _real(f"{what} {spec.name}", value, f"a finite number in {spec.interval} "
              f"({spec.unit})", spec.contains)
    check_fade(what, start, end)


#: the JSON/TOML "type" of each joint class
_JOINT_TYPES = {"revolute": Revolute, "prismatic": Prismatic}

#: parameter fields of the clearance joints (`Linkage.parameter_names`)
CLEARANCE_PARAMETERS = ("bearing_radius", "journal_radius", "youngs_modulus", "poisson_ratio",
                        "restitution", "contact_stiffness", "impact_velocity_floor")
#: parameter fields of the clearance joints with a friction law (not "none")
FRICTION_PARAMETERS = FRICTION_SLOTS
#: parameter fields of the lubricated clearance joints
LUBRICATION_PARAMETERS = ("viscosity", "bearing_length", "film_fade_start", "film_fade_end")
#: parameter fields of the translational clearance joints
TRANSLATIONAL_PARAMETERS = ("half_length", "half_height", "clearance", "angle",
                            "slider_angle", "restitution", "contact_stiffness",
                            "impact_velocity_floor")


@dataclass(frozen=True)
class Linkage:
    """A planar linkage: bodies, ideal joints (a forest rooted at the ground), clearance
    joints, the drive (None: a free linkage, started from `initial`), ground points,
    gravity (m/s^2 along -y), the monitored ground joint (None: the shaking force, the sum
    of the ground reactions) and assembly guesses of coordinates (by coordinate name) that
    pick the assembly branch of the centred start. See the module docstring for the
    coordinates."""

    name: str
    bodies: tuple[Body, ...]
    joints: tuple[Revolute | Prismatic, ...]
    clearance_joints: tuple[ClearanceJoint, ...]
    drive: Drive | None
    ground_points: Mapping[str, Point] = field(default_factory=dict)
    gravity: float = 9.81
    monitor_joint: str | None = None
    assembly: Mapping[str, float] = field(default_factory=dict)
    #: the start of a free linkage (drive None; None: `Initial()`, assembled at rest); a
    #: driven linkage takes none (its start is the centred assembly or a `Start`)
    initial: Initial | None = None
    #: the named case (`cases.CASES`) and overrides that built this linkage (None and {} for
    #: a description from a file or a changed copy): a study rebuilds the case with other
    #: overrides (`design.linkage_with`); not part of the description (`to_dict`) nor of
    #: equality
    case: str | None = field(default=None, compare=False)
    overrides: Mapping[str, Any] = field(default_factory=dict, compare=False)
    #: prismatic joints with clearance (`TranslationalClearance`), each the guide of its
    #: slider; their four corners are contacts beside the revolute clearance joints'
    translational_joints: tuple[TranslationalClearance, ...] = ()

    def __post_init__(self) -> None:
        _name("linkage name", self.name)
        if self.case is not None and not isinstance(self.case, str):
            raise ValueError(f"case must be None or a case name; got {_short(self.case)}")
        if not isinstance(self.overrides, Mapping):
            raise ValueError(f"overrides must be a mapping; got {_short(self.overrides)}")
        object.__setattr__(self, "overrides", dict(self.overrides))
        for f, cls, most in (("bodies", Body, MAX_BODIES),
                             ("joints", (Revolute, Prismatic), MAX_JOINTS),
                             ("clearance_joints", ClearanceJoint, MAX_CLEARANCE_JOINTS),
                             ("translational_joints", TranslationalClearance,
                              MAX_CLEARANCE_JOINTS)):
            value = getattr(self, f)
            if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__iter__"):
                raise ValueError(f"{f} must be a sequence; got {_short(value)}")
            value = tuple(itertools.islice(value, most + 1))
            _at_most(f, value, most)
            for item in value:
                if not isinstance(item, cls):
                    raise ValueError(f"{f} must hold {_cls_names(cls)} objects; "
                                     f"got {_short(item)}")
            object.__setattr__(self, f, value)
        if self.drive is not None and not isinstance(self.drive, Drive):
            raise ValueError(f"drive must be a Drive or None (a free linkage); "
                             f"got {_short(self.drive)}")
        if self.initial is not None and not isinstance(self.initial, Initial):
            raise ValueError(f"initial must be None or an Initial; got {_short(self.initial)}")
        if (self.drive is not None and isinstance(self.initial, Initial)
                and not self.initial.coordinates and not self.initial.rates):
            object.__setattr__(self, "initial", None)   # an empty start: nothing to refuse
        if self.initial is not None and self.drive is not None:
            raise ValueError("initial is for a free linkage (drive=None): a driven linkage "
                             "starts from its centred assembly (assembly guesses) or from a "
                             "Start (linkage_model.settled_start)")
        if self.drive is None and self.initial is None:
            object.__setattr__(self, "initial", Initial())
        object.__setattr__(self, "ground_points", _points("ground_points", self.ground_points))
        object.__setattr__(self, "gravity", _real("gravity", self.gravity,
                                                  "a finite number (m/s^2)"))
        if not self.bodies:
            raise ValueError("bodies must hold at least one Body")
        if not self.clearance_joints and not self.translational_joints:
            raise ValueError("clearance_joints must hold at least one ClearanceJoint, or "
                             "translational_joints a TranslationalClearance (a linkage "
                             "without clearance has no switching function)")
        self._check_graph()
        coords = self.coordinates()
        if not coords:
            raise ValueError("the linkage has no free coordinate: every body is fixed by the "
                             "drive and ideal joints")
        if not isinstance(self.assembly, Mapping):
            raise ValueError(f"assembly must be a mapping of coordinate name to a guess; "
                             f"got {_short(self.assembly)}")
        guesses = {}
        for key, value in self.assembly.items():
            if key not in coords:
                raise ValueError(f"assembly names an unknown coordinate {_short(key)}; the "
                                 f"coordinates are {list(coords)}")
            guesses[key] = _real(f"assembly[{key!r}]", value, "a finite number")
        object.__setattr__(self, "assembly", guesses)
        if self.initial is not None:
            for what, values in (("coordinates", self.initial.coordinates),
                                 ("rates", self.initial.rates)):
                for key in values:
                    if key not in coords:
                        raise ValueError(f"initial {what} names an unknown coordinate "
                                         f"{_short(key)}; the coordinates are {list(coords)}")

    @property
    def is_free(self) -> bool:
        """Whether the linkage has no drive (it moves from `initial`)."""
        return self.drive is None

    @property
    def start(self) -> Initial:
        """The start of a free linkage (`initial`, or `Initial()`); ValueError if driven."""
        if self.drive is not None:
            raise ValueError(f"linkage {self.name!r} is driven: it starts from its centred "
                             "assembly, not from an Initial")
        return self.initial

    @property
    def rate_scale(self) -> float:
        """The scale of angular rates in rad/s: the drive speed; of a free linkage the
        largest initial rate (an angle's, or a length's over the length scale), at least
        sqrt(|gravity| / length scale) (the rate of a swing from rest), at least 1e-3."""
        if self.drive is not None:
            return self.drive.speed
        length = max(self.length_scale, 1e-300)
        rates = [abs(v) if c.endswith(".angle") else abs(v) / length
                 for c, v in self.start.rates.items()]
        return max([1e-3, math.sqrt(abs(self.gravity) / length), *rates])

    @property
    def time_scale(self) -> float:
        """2 pi / `rate_scale` in s: a drive revolution, or a free linkage's time of one
        turn at its largest initial rate."""
        return 2.0 * math.pi / self.rate_scale

    # ------------------------------------------------------------------ graph
    def _check_graph(self) -> None:
        points = {GROUND: self.ground_points}
        for body in self.bodies:
            _check_reserved("body", body.name)
            if body.name in points:
                raise ValueError(f"body name {body.name!r} is used twice")
            points[body.name] = body.points
        names = set()
        for joint in (*self.joints, *self.clearance_joints, *self.translational_joints):
            _check_reserved("joint", joint.name)
            if joint.name in names:
                raise ValueError(f"joint name {joint.name!r} is used twice (joint names must "
                                 "be unique)")
            names.add(joint.name)
        for body in self.bodies:
            if body.name in names:
                raise ValueError(f"name {body.name!r} is both a body and a joint")

        def check_end(joint, body_field, point_field):
            body, point = getattr(joint, body_field), getattr(joint, point_field)
            if body not in points:
                raise ValueError(f"joint {joint.name!r} {body_field} names an unknown body "
                                 f"{body!r}; the bodies are {[GROUND, *points][1:]} and "
                                 f"{GROUND!r}")
            if point not in points[body]:
                raise ValueError(f"joint {joint.name!r} {point_field} names an unknown point "
                                 f"{point!r} of body {body!r}; its points are "
                                 f"{sorted(points[body])}")

        for joint in self.joints:
            check_end(joint, "body_a", "point_a")
            check_end(joint, "body_b", "point_b")
        pins: dict[frozenset, str] = {}
        for joint in self.clearance_joints:
            check_end(joint, "journal_body", "journal_point")
            check_end(joint, "bearing_body", "bearing_point")
            # a second clearance joint on the same pin duplicates the first one's contact
            # (the integrator would chase two identical switching functions)
            ends = frozenset({(joint.journal_body, joint.journal_point),
                              (joint.bearing_body, joint.bearing_point)})
            if ends in pins:
                raise ValueError(f"clearance joints {pins[ends]!r} and {joint.name!r} join the "
                                 f"same points {joint.journal_body}.{joint.journal_point} and "
                                 f"{joint.bearing_body}.{joint.bearing_point}; a pin has at "
                                 "most one clearance joint")
            pins[ends] = joint.name
        guided: dict[str, str] = {}
        for joint in self.translational_joints:
            check_end(joint, "guide_body", "guide_point")
            check_end(joint, "slider_body", "slider_point")
            if joint.slider_body in guided:
                raise ValueError(f"translational clearance joints {guided[joint.slider_body]!r}"
                                 f" and {joint.name!r} guide the same slider "
                                 f"{joint.slider_body!r}; a slider has at most one guide")
            guided[joint.slider_body] = joint.name
            pair = {joint.guide_body, joint.slider_body}
            for ideal in self.joints:
                if isinstance(ideal, Prismatic) and {ideal.body_a, ideal.body_b} == pair:
                    raise ValueError(f"translational clearance joint {joint.name!r} and the "
                                     f"ideal prismatic joint {ideal.name!r} both guide "
                                     f"{joint.slider_body!r} on {joint.guide_body!r}; the "
                                     "clearance joint is the guide: remove the ideal one")
        # the ideal joints must form a forest: a joint between two bodies already connected
        # closes a loop, named by its joints
        parent: dict[str, str] = {}

        def root(b):
            while b in parent:
                b = parent[b]
            return b

        adjacency: dict[str, list] = {}
        for joint in self.joints:
            a, b = joint.body_a, joint.body_b
            if root(a) == root(b):
                loop = _path(adjacency, a, b) + [joint.name]
                raise ValueError(f"the ideal joints {loop} form a closed loop; cut it with a "
                                 "ClearanceJoint (a loop of ideal joints makes the equations "
                                 "a DAE)")
            parent[root(a)] = root(b)
            adjacency.setdefault(a, []).append((b, joint.name))
            adjacency.setdefault(b, []).append((a, joint.name))
        drive = (None if self.drive is None
                 else {j.name: j for j in self.joints}.get(self.drive.joint))
        if self.drive is not None and (not isinstance(drive, Revolute)
                                       or drive.body_a != GROUND):
            found = ("no ideal joint of that name" if drive is None else
                     f"a {type(drive).__name__} from {drive.body_a!r} to {drive.body_b!r}")
            raise ValueError(f"drive joint {self.drive.joint!r} must be a Revolute with body_a "
                             f"{GROUND!r}; found {found}")
        if self.monitor_joint is not None and self.monitor_joint not in self.ground_joints():
            raise ValueError(f"monitor_joint must be None or a joint to the ground "
                             f"{list(self.ground_joints())}; got {_short(self.monitor_joint)}")

    def tree(self) -> list[tuple[str, str | None, Any]]:
        """The forest as (body, parent body or None for a floating root, joint or None), in
        an order where every parent comes before its children (ground first)."""
        adjacency: dict[str, list] = {}
        for joint in self.joints:
            adjacency.setdefault(joint.body_a, []).append((joint.body_b, joint))
            adjacency.setdefault(joint.body_b, []).append((joint.body_a, joint))
        order = [(GROUND, None, None)]
        seen = {GROUND}
        roots = [GROUND] + [b.name for b in self.bodies]
        for start in roots:
            if start not in seen:
                seen.add(start)
                order.append((start, None, None))
            stack = [start]
            while stack:
                body = stack.pop(0)
                for other, joint in adjacency.get(body, []):
                    if other not in seen:
                        seen.add(other)
                        order.append((other, body, joint))
                        stack.append(other)
        return order

    def coordinates(self) -> tuple[str, ...]:
        """Names of the minimal coordinates, in state order (module docstring)."""
        child = {joint.name: body for body, _, joint in self.tree() if joint is not None}
        names = []
        for joint in self.joints:
            if self.drive is not None and joint.name == self.drive.joint:
                continue
            if isinstance(joint, Revolute):
                names.append(f"{child[joint.name]}.angle")
            else:
                names.append(f"{joint.name}.s")
        for body, parent, _ in self.tree():
            if body != GROUND and parent is None:
                names += [f"{body}.x", f"{body}.y", f"{body}.angle"]
        return tuple(names)

    def ground_joints(self) -> tuple[str, ...]:
        """Names of the joints to the ground: ideal ones, then clearance joints."""
        return tuple([j.name for j in self.joints if GROUND in (j.body_a, j.body_b)]
                     + [j.name for j in self.clearance_joints
                        if GROUND in (j.journal_body, j.bearing_body)]
                     + [j.name for j in self.translational_joints if j.guide_body == GROUND])

    @property
    def default_output(self) -> str:
        """The linkage's one default monitored output: the |reaction| of `monitor_joint`
        ("pivot_force:<joint>"; the paper's base force F12 is the crank pivot's), or without
        one the |shaking force| ("shaking_force", the four-bar's). `simulate`'s peaks are
        its peaks, and every study (`peak_base_force`, `peak_output`, `peak_gradient`, the
        GA, the tolerance study, the regime map) measures it unless told otherwise."""
        if self.monitor_joint is not None:
            return f"pivot_force:{self.monitor_joint}"
        return "shaking_force"

    @property
    def period(self) -> float:
        """Duration of one drive revolution in s (ValueError for a free linkage)."""
        if self.drive is None:
            raise ValueError(f"linkage {self.name!r} is free (drive=None): it has no drive "
                             "revolution; run it for a duration in s (duration=)")
        return self.drive.period

    # ------------------------------------------------------------------ assembly
    def poses(self, q: Mapping[str, float], t: float = 0.0) -> dict[str, tuple[float, float,
                                                                             float]]:
        """Body -> (x, y, angle) of its frame (centre of mass in m, angle in rad) at
        coordinates `q` (by name, `coordinates`) and time `t`, the ground's (0, 0, 0)
        included: the ideal joints' kinematics along the forest (`tree`)."""
        drive = self.drive
        theta = 0.0 if drive is None else drive.speed * t + drive.initial_angle
        points = {GROUND: self.ground_points, **{b.name: b.points for b in self.bodies}}
        angle = {GROUND: 0.0}
        pos = {GROUND: (0.0, 0.0)}

        def world(body, name):
            dx, dy = _turned(angle[body], points[body][name])
            return pos[body][0] + dx, pos[body][1] + dy

        for body, parent, joint in self.tree():
            if body == GROUND:
                continue
            if parent is None:                          # floating
                angle[body] = q[f"{body}.angle"]
                pos[body] = (q[f"{body}.x"], q[f"{body}.y"])
            elif isinstance(joint, Revolute):
                angle[body] = (theta if drive is not None and joint.name == drive.joint
                               else q[f"{body}.angle"])
                pp, pc = ((joint.point_a, joint.point_b) if joint.body_a == parent
                          else (joint.point_b, joint.point_a))
                px, py = world(parent, pp)
                dx, dy = _turned(angle[body], points[body][pc])
                pos[body] = (px - dx, py - dy)
            else:                                       # Prismatic: s along the axis
                s_q, sign = q[f"{joint.name}.s"], 1.0 if joint.body_a == parent else -1.0
                pp, pc = ((joint.point_a, joint.point_b) if sign > 0
                          else (joint.point_b, joint.point_a))
                angle[body] = angle[parent]
                ux, uy = _turned(angle[parent] + joint.angle, (1.0, 0.0))
                px, py = world(parent, pp)
                dx, dy = _turned(angle[body], points[body][pc])
                pos[body] = (px + sign * s_q * ux - dx, py + sign * s_q * uy - dy)
        return {b: (*pos[b], angle[b]) for b in pos}

    def gaps(self, q: Mapping[str, float], t: float = 0.0) -> list[float]:
        """Journal centre minus bearing centre (x, y in m) of every clearance joint, in
        order, then per translational clearance joint the slider centre's offset from the
        guide's mid-line and half_length times the sine of its tilt (m), at coordinates `q`
        (by name, `coordinates`) and time `t`: the loop closure, zero when every journal
        and slider is centred. Plain Python, the kinematics of the generated
        model's ``closure`` (no model is generated or compiled)."""
        frames = self.poses(q, t)
        points = {GROUND: self.ground_points, **{b.name: b.points for b in self.bodies}}
        angle = {b: f[2] for b, f in frames.items()}

        def world(body, name):
            dx, dy = _turned(angle[body], points[body][name])
            return frames[body][0] + dx, frames[body][1] + dy

        out = []
        for cj in self.clearance_joints:
            jx, jy = world(cj.journal_body, cj.journal_point)
            bx, by = world(cj.bearing_body, cj.bearing_point)
            out += [jx - bx, jy - by]
        for tj in self.translational_joints:
            # the slider centred: its centre on the guide's mid-line, its axis along it
            # (a times the sine of the tilt: the corners' offset from the centre's, in m)
            gx, gy = world(tj.guide_body, tj.guide_point)
            sx, sy = world(tj.slider_body, tj.slider_point)
            nx, ny = _turned(angle[tj.guide_body] + tj.angle, (0.0, 1.0))
            ax, ay = _turned(angle[tj.slider_body] + tj.slider_angle, (1.0, 0.0))
            out += [nx * (sx - gx) + ny * (sy - gy), tj.half_length * (nx * ax + ny * ay)]
        return out

    def assemble(self, t: float = 0.0, max_iter: int = 50) -> dict[str, float]:
        """The coordinates (by name) with every journal centred at time `t`, by at most
        `max_iter` Newton steps from the `assembly` guesses (Jacobian by central
        differences; least squares where the closure is not square), to 1e-9 of the length
        scale (a free linkage's initial coordinates held); ValueError if there is no assembly
        near the guesses. A check that costs
        milliseconds, made before any model is generated or compiled; the run's start
        (`linkage_model.initial_state`) solves the same closure to round-off with the
        model's exact Jacobian."""
        import numpy as np

        names = self.coordinates()
        # a free linkage holds its given initial coordinates
        held = dict(self.initial.coordinates) if self.drive is None else {}
        q = np.array([held.get(c, self.assembly.get(c, 0.0)) for c in names])
        free = np.array([c not in held for c in names])
        scale = max(self.length_scale, 1e-300)
        steps = np.array([1e-6 if c.endswith(".angle") else 1e-6 * scale for c in names])

        def residual(v):
            return np.array(self.gaps(dict(zip(names, v.tolist())), t))

        r = residual(q)
        for _ in range(max_iter):
            if not np.all(np.isfinite(r)):
                break
            if np.max(np.abs(r)) <= 1e-9 * scale:
                return dict(zip(names, q.tolist()))
            jac = np.zeros((len(r), len(q)))
            for i, h in enumerate(steps):
                if not free[i]:
                    continue
                e = np.zeros(len(q))
                e[i] = h
                jac[:, i] = (residual(q + e) - residual(q - e)) / (2.0 * h)
            q = q + np.linalg.lstsq(jac, -r, rcond=None)[0]
            r = residual(q)
        raise ValueError(
            f"the loop closure of linkage {self.name!r} cannot be solved from the assembly "
            f"guesses {dict(self.assembly)} (residual {np.max(np.abs(r)):.3g} m after "
            f"{max_iter} Newton steps): no assembly with the journals centred near them; "
            f"check the lengths, or give guesses (assembly, by coordinate name "
            f"{list(names)}) near an assembly")

    # ------------------------------------------------------------------ variants and I/O
    def replace(self, **changes: Any) -> Linkage:
        """A validated copy with some fields changed (unknown names raise ValueError). The
        copy remembers the case that built this linkage (`case`, `overrides`) only when the
        change is its name alone (or names the case itself): any other change makes a
        description the case's overrides cannot rebuild."""
        allowed = [f.name for f in dataclasses.fields(self)]
        unknown = [k for k in changes if k not in allowed]
        if unknown:
            raise ValueError(f"unknown Linkage field(s) {unknown}; allowed: {allowed}")
        if not set(changes) <= {"name", "case", "overrides"}:
            changes.setdefault("case", None)
            changes.setdefault("overrides", {})
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The description as plain data (JSON/TOML-serialisable; joints carry a "type")."""
        def joint(j):
            d = dataclasses.asdict(j)
            return {"type": "prismatic" if isinstance(j, Prismatic) else "revolute", **d}

        def points(m):
            return {k: [x, y] for k, (x, y) in m.items()}

        out = {
            "name": self.name,
            "bodies": [{"name": b.name, "mass": b.mass, "inertia": b.inertia,
                        "points": points(b.points)} for b in self.bodies],
            "joints": [joint(j) for j in self.joints],
            "clearance_joints": [dataclasses.asdict(j) for j in self.clearance_joints],
            **({} if self.drive is None else {"drive": dataclasses.asdict(self.drive)}),
            "ground_points": points(self.ground_points),
            "gravity": self.gravity,
            "assembly": dict(self.assembly),
        }
        if self.monitor_joint is not None:
            out["monitor_joint"] = self.monitor_joint
        if self.drive is None:      # a free linkage: its start (TOML has no null drive)
            start = self.start
            out["initial"] = {"coordinates": dict(start.coordinates),
                              "rates": dict(start.rates)}
        if self.translational_joints:
            out["translational_joints"] = [dataclasses.asdict(j)
                                           for j in self.translational_joints]
        for j in out["clearance_joints"]:
            if j["contact_stiffness"] is None:      # TOML has no null
                del j["contact_stiffness"]
            if j["wear_coefficient"] == 0.0:
                del j["wear_coefficient"]
            if j["bearing_profile"] is None:
                del j["bearing_profile"]
            else:
                j["bearing_profile"] = list(j["bearing_profile"])
            if j["lubrication"] == "none":          # dry joints: the keys of old
                for f in ("lubrication", *LUBRICATION_PARAMETERS):
                    del j[f]
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Linkage:
        """Build from `to_dict`'s form; a missing or unknown key raises ValueError naming it
        and the item that holds it (``bodies[1] ('coupler')``)."""
        if not isinstance(data, Mapping):
            raise ValueError(f"a linkage description must be a mapping; got {_short(data)}")
        if "drive" not in data and "initial" in data:      # a free linkage
            data = {**data, "drive": None}
        # case and overrides: the provenance of a built case, not keys of a description
        data = dict(_fields_of(cls, "linkage", "the description", data,
                               exclude=("case", "overrides")))

        def items(key, most):
            value = data.get(key, [])
            if not isinstance(value, (list, tuple)):
                raise ValueError(f"{key} must be a list of tables/objects; got {_short(value)}")
            _at_most(key, value, most)
            for k, v in enumerate(value):
                if not isinstance(v, Mapping):
                    raise ValueError(f"{key}[{k}] must be a table/object; got {_short(v)}")
            return [(f"{key}[{k}]{_named(v)}", dict(v)) for k, v in enumerate(value)]

        bodies = tuple(Body(**_fields_of(Body, "body", where, b))
                       for where, b in items("bodies", MAX_BODIES))
        joints = []
        for where, j in items("joints", MAX_JOINTS):
            kind = j.pop("type", "revolute")
            if kind not in _JOINT_TYPES:
                raise ValueError(f"{where} type must be one of {sorted(_JOINT_TYPES)}; "
                                 f"got {_short(kind)}")
            jc = _JOINT_TYPES[kind]
            joints.append(jc(**_fields_of(jc, f"{kind} joint", where, j)))
        clearance = tuple(ClearanceJoint(**_fields_of(ClearanceJoint, "clearance joint", where, j))
                          for where, j in items("clearance_joints", MAX_CLEARANCE_JOINTS))
        translational = tuple(
            TranslationalClearance(**_fields_of(TranslationalClearance,
                                                "translational clearance joint", where, j))
            for where, j in items("translational_joints", MAX_CLEARANCE_JOINTS))
        if translational:
            data["translational_joints"] = translational
        drive = data["drive"]
        if drive is not None:
            if not isinstance(drive, Mapping):
                raise ValueError(f"drive must be a table/object (or absent, with initial, for "
                                 f"a free linkage); got {_short(drive)}")
            drive = Drive(**_fields_of(Drive, "drive", "drive", drive))
        initial = data.get("initial")
        if initial is not None:
            if not isinstance(initial, Mapping):
                raise ValueError(f"initial must be a table/object; got {_short(initial)}")
            initial = Initial(**_fields_of(Initial, "initial", "initial", initial))
        data.update(bodies=bodies, joints=tuple(joints), clearance_joints=clearance,
                    drive=drive, initial=initial)
        return cls(**data)

    @classmethod
    def from_file(cls, path: str | Path) -> Linkage:
        """Read a description from a JSON (.json) or TOML (.toml) file in `to_dict`'s form
        (at most `_io.MAX_INPUT_BYTES`); ValueError naming the file and the item, also when
        the linkage cannot be assembled with its journals centred (`assemble`)."""
        from .._io import parse_json, read_text

        path = Path(path)
        what = "linkage file"
        text = read_text(path, what)
        if path.suffix.lower() == ".toml":
            try:
                import tomllib
            except ImportError:     # Python 3.10
                raise ValueError("reading TOML needs Python >= 3.11 (tomllib); use JSON") from None
            try:
                data = tomllib.loads(text)
            except (tomllib.TOMLDecodeError, RecursionError) as exc:
                raise ValueError(f"cannot read {what} {str(path)!r}: "
                                 f"{exc or 'nested too deeply'}") from None
        else:
            data = parse_json(text, path, what)
        try:
            linkage = cls.from_dict(data)
            linkage.assemble()
        except ValueError as exc:
            raise ValueError(f"{what} {str(path)!r}: {exc}") from None
        return linkage

    # ------------------------------------------------------------------ parameters
    def parameter_names(self) -> tuple[str, ...]:
        """Dotted names of the real-valued parameters ("<body>.mass", "<body>.inertia",
        "<body>.<point>.x"/".y", "<prismatic>.angle", "<clearance joint>.<field>" for
        CLEARANCE_PARAMETERS (and FRICTION_PARAMETERS if its friction_law is not "none"),
        "<translational joint>.<field>" for TRANSLATIONAL_PARAMETERS (and FRICTION_PARAMETERS
        likewise), "drive.speed", "drive.initial_angle", "gravity",
        "ground.<point>.x"/".y")."""
        names = []
        for b in self.bodies:
            names += [f"{b.name}.mass", f"{b.name}.inertia"]
            for pt in b.points:
                names += [f"{b.name}.{pt}.x", f"{b.name}.{pt}.y"]
        for pt in self.ground_points:
            names += [f"{GROUND}.{pt}.x", f"{GROUND}.{pt}.y"]
        names += [f"{j.name}.angle" for j in self.joints if isinstance(j, Prismatic)]
        for j in self.clearance_joints:
            names += [f"{j.name}.{f}" for f in CLEARANCE_PARAMETERS]
            if j.has_friction:
                names += [f"{j.name}.{f}" for f in FRICTION_PARAMETERS]
            if j.has_lubrication:
                names += [f"{j.name}.{f}" for f in LUBRICATION_PARAMETERS]
        for j in self.translational_joints:
            names += [f"{j.name}.{f}" for f in TRANSLATIONAL_PARAMETERS]
            if j.has_friction:
                names += [f"{j.name}.{f}" for f in FRICTION_PARAMETERS]
        drive = [] if self.drive is None else ["drive.speed", "drive.initial_angle"]
        return tuple(names + drive + ["gravity"])

    def _locate(self, name: str):
        """(kind, object, field, point index) of a parameter name, or ValueError."""
        if not isinstance(name, str) or name not in self.parameter_names():
            raise ValueError(f"unknown parameter {name!r} of linkage {self.name!r}; the "
                             f"parameters are {list(self.parameter_names())}")
        parts = name.split(".")
        if parts[0] == "gravity":
            return "linkage", None, "gravity", None
        if parts[0] == "drive":
            return "drive", self.drive, parts[1], None
        if parts[0] == GROUND:
            return "ground", None, parts[1], "xy".index(parts[2])
        for b in self.bodies:
            if b.name == parts[0]:
                if len(parts) == 2:
                    return "body", b, parts[1], None
                return "point", b, parts[1], "xy".index(parts[2])
        for j in (*self.joints, *self.clearance_joints, *self.translational_joints):
            if j.name == parts[0]:
                return "joint", j, parts[1], None
        raise AssertionError(name)      # parameter_names and _locate disagree

    def parameter_value(self, name: str) -> float:
        """The value of parameter `name` (a clearance joint's contact_stiffness: the
        stiffness in use, Eq. 9 when not given)."""
        kind, obj, f, k = self._locate(name)
        if kind == "linkage":
            return self.gravity
        if kind == "ground":
            return self.ground_points[f][k]
        if kind == "point":
            return obj.points[f][k]
        if isinstance(obj, ClearanceJoint) and f == "contact_stiffness":
            return obj.stiffness
        return float(getattr(obj, f))

    def with_parameter(self, name: str, value: float) -> Linkage:
        """A validated copy with parameter `name` (see `parameter_names`) set to `value`."""
        kind, obj, f, k = self._locate(name)
        if kind == "linkage":
            return self.replace(gravity=value)
        if kind == "drive":
            return self.replace(drive=dataclasses.replace(obj, **{f: value}))
        if kind == "ground":
            pts = dict(self.ground_points)
            pts[f] = (value, pts[f][1]) if k == 0 else (pts[f][0], value)
            return self.replace(ground_points=pts)
        if kind == "point":
            pts = dict(obj.points)
            pts[f] = (value, pts[f][1]) if k == 0 else (pts[f][0], value)
            new = dataclasses.replace(obj, points=pts)
        else:
            new = dataclasses.replace(obj, **{f: value})
        if kind in ("body", "point"):
            return self.replace(bodies=tuple(new if b is obj else b for b in self.bodies))
        if isinstance(obj, ClearanceJoint):
            return self.replace(clearance_joints=tuple(
                new if j is obj else j for j in self.clearance_joints))
        if isinstance(obj, TranslationalClearance):
            return self.replace(translational_joints=tuple(
                new if j is obj else j for j in self.translational_joints))
        return self.replace(joints=tuple(new if j is obj else j for j in self.joints))

    # ------------------------------------------------------------------ structure
    def structure(self) -> dict[str, Any]:
        """What the generated model depends on (names and topology, no numbers): two
        linkages with equal structures share one generated module."""
        out = {
            "bodies": [[b.name, sorted(b.points)] for b in self.bodies],
            "ground_points": sorted(self.ground_points),
            "joints": [["prismatic" if isinstance(j, Prismatic) else "revolute", j.name,
                        j.body_a, j.point_a, j.body_b, j.point_b] for j in self.joints],
            # a joint with friction adds the tangential force to the model (its law and
            # values are parameters); frictionless joints keep the structure of old
            "clearance_joints": [[j.name, j.journal_body, j.journal_point, j.bearing_body,
                                  j.bearing_point] + (["friction"] if j.has_friction else [])
                                 + (["lubrication"] if j.has_lubrication else [])
                                 # a profiled bearing: its grid's size is compiled, its
                                 # radii are data of the parameter vector
                                 + ([["profile", len(j.bearing_profile)]]
                                    if j.bearing_profile is not None else [])
                                 for j in self.clearance_joints],
            "drive": None if self.drive is None else self.drive.joint,
            "monitor_joint": self.monitor_joint,
        }
        if self.translational_joints:       # linkages without keep the structure of old
            out["translational_joints"] = [
                [j.name, j.guide_body, j.guide_point, j.slider_body, j.slider_point]
                + (["friction"] if j.has_friction else []) for j in self.translational_joints]
        return out

    @property
    def length_scale(self) -> float:
        """The sum over bodies of the largest distance between two of its points (and its
        centre of mass) in m: the linkage's reach, the scale of position tolerances."""
        total = 0.0
        for b in self.bodies:
            pts = [(0.0, 0.0), *b.points.values()]
            total += max(math.dist(p, q) for p in pts for q in pts)
        return total

    @property
    def min_clearance(self) -> float:
        """The smallest clearance in m: the clearance joints' radial ones and the
        translational joints' (guide half-width minus slider half-height)."""
        return min(j.clearance for j in (*self.clearance_joints, *self.translational_joints))

    def contacts(self) -> tuple[tuple[str, ClearanceJoint | TranslationalClearance], ...]:
        """The contacts of the generated model, in its event order, as (name, joint): each
        clearance joint (its name), then the four corners of each translational clearance
        joint ("<joint>.<corner>", `CORNERS`)."""
        return (tuple((j.name, j) for j in self.clearance_joints)
                + tuple((c, j) for j in self.translational_joints for c in j.corner_names()))


def _turned(a: float, xy) -> tuple[float, float]:
    """`xy` turned by the angle `a` (rad)."""
    c, s = math.cos(a), math.sin(a)
    return c * xy[0] - s * xy[1], s * xy[0] + c * xy[1]


def _cls_names(cls) -> str:
    if isinstance(cls, tuple):
        return " or ".join(c.__name__ for c in cls)
    return cls.__name__


def _at_most(item: str, value: Any, most: int) -> None:
    if len(value) > most:
        raise ValueError(f"{item} holds {len(value)} entries; at most {most} are allowed")


def _named(item: Any) -> str:
    """" ('NAME')" for a table with a string name (how a message points at it), else ""."""
    name = item.get("name") if isinstance(item, Mapping) else None
    return f" ({_short(name, 40)})" if isinstance(name, str) else ""


def _fields_of(cls, what: str, where: str, data: Mapping, exclude=()) -> dict:
    """`data` as keyword arguments of dataclass `cls` (a `what`, at `where` in the
    description): ValueError naming the key and `where` when a key is unknown or a required
    one (a field without a default) is missing. Fields in `exclude` are not description
    keys."""
    fields = [f for f in dataclasses.fields(cls) if f.name not in exclude]
    allowed = [f.name for f in fields]
    unknown = [k for k in data if k not in allowed]
    if unknown:
        raise ValueError(f"unknown {what} key {_short(unknown[0], 40)} in {where}; allowed: "
                         f"{allowed}")
    required = [f.name for f in fields if f.default is dataclasses.MISSING
                and f.default_factory is dataclasses.MISSING]
    missing = [k for k in required if k not in data]
    if missing:
        raise ValueError(f"{where} lacks the key {missing[0]!r}; required: {required}")
    return dict(data)


def _path(adjacency: dict, start: str, goal: str) -> list[str]:
    """Joint names on the path from `start` to `goal` in the forest so far."""
    prev = {start: None}
    queue = [start]
    while queue:
        node = queue.pop(0)
        if node == goal:
            break
        for other, name in adjacency.get(node, []):
            if other not in prev:
                prev[other] = (node, name)
                queue.append(other)
    names = []
    node = goal
    while prev.get(node) is not None:
        node, name = prev[node]
        names.append(name)
    return names[::-1]
