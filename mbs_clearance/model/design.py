"""Designs of a study on any `Linkage`: the linkage with some values changed, by name.

Every study of a linkage (`objective.peak_gradient`, `optimize.optimize_link_lengths`,
`tolerance.tolerance_study`) names what it varies the same way (`design_names`):

- an override of the named case that built the linkage (`Linkage.case`; for example
  ``coupler_length``, ``rocker_length``, ``clearance``, ``crank_speed``: the keys of
  `cases.CASE_PARAMETERS`, for "paper_slider_crank" the continuous `SliderCrank` fields).
  The case is rebuilt with the new overrides, so every value that follows from them moves
  too (a coupler length moves both of the coupler's joint points and its uniform-rod
  inertia, and the assembly guesses);
- "clearance": every radial clearance of the linkage (a case's clearance overrides, or
  every clearance joint's journal radius at fixed bearing radius);
  "<clearance joint>.clearance": that joint's clearance;
- a numeric field of the description by a dotted path, the names of the description's
  items and then its JSON keys (`Linkage.parameter_names`): "<body>.mass",
  "<body>.inertia", "<body>.<point>.x" / ".y", "<prismatic joint>.angle",
  "<clearance joint>.<field>" (bearing_radius, journal_radius, youngs_modulus, ...),
  "drive.speed", "drive.initial_angle", "gravity", "ground.<point>.x" / ".y"; the same
  with the description's section in front is accepted too: "bodies.coupler.mass",
  "clearance_joints.coupler_rocker.bearing_radius", "joints.slider_guide.angle",
  "ground_points.rocker_pivot.x".

Case overrides are applied first (the case rebuilt), then the dotted paths on top. A name
that is none of these raises ValueError naming it and listing the allowed names.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping

from .cases import SLIDER_CRANK_CASES as _SLIDER_CRANK_CASES
from .cases import slider_crank_of
from .linkage import GROUND, Linkage
from .mechanism import SliderCrank, reference_value

__all__ = ["design_names", "check_names", "design_value", "linkage_with", "direction", "design_at",
           "value_at", "slider_crank_of"]

#: the description's sections accepted in front of a dotted path, and what they become
_SECTIONS = {"bodies": "", "joints": "", "clearance_joints": "", "ground_points": f"{GROUND}."}


def _case_table(linkage: Linkage) -> dict[str, object]:
    """The numeric overrides of the linkage's case: name -> default (None: derived)."""
    if linkage.case is None:
        return {}
    if linkage.case in _SLIDER_CRANK_CASES:
        from .cases import LUBRICATED_DEFAULTS, WEAR_DEFAULTS
        from .mechanism import CONTINUOUS_FIELDS

        extra = {"paper_slider_crank_lubricated": LUBRICATED_DEFAULTS,
                 "paper_slider_crank_wear": WEAR_DEFAULTS}.get(linkage.case, {})
        return {**dict.fromkeys(CONTINUOUS_FIELDS),
                **{k: v[0] for k, v in extra.items() if not isinstance(v[0], str)}}
    from .cases import CASE_PARAMETERS

    return {k: v[0] for k, v in CASE_PARAMETERS[linkage.case].items()
            if v[0] is None or (isinstance(v[0], numbers.Real) and not isinstance(v[0], bool))}


def _dotted(name: str) -> str:
    head, _, rest = name.partition(".")
    if head in _SECTIONS and rest:
        return _SECTIONS[head] + rest
    return name


def design_names(linkage: Linkage) -> list[str]:
    """Every name a study may vary on `linkage` (see the module docstring): the case's
    overrides, "clearance", "<joint>.clearance", then the dotted paths."""
    if not isinstance(linkage, Linkage):
        raise ValueError(f"linkage must be a Linkage; got {type(linkage).__name__}")
    names = list(_case_table(linkage))
    if "clearance" not in names:
        names.append("clearance")
    names += [f"{j.name}.clearance" for j in linkage.clearance_joints]
    return names + list(linkage.parameter_names())


def check_names(linkage: Linkage, names: Iterable[str], what: str = "parameter") -> tuple:
    """`names` as a tuple; ValueError naming the first unknown one and the allowed names."""
    allowed = design_names(linkage)
    out = []
    for name in names:
        if not isinstance(name, str) or (name not in allowed and _dotted(name) not in allowed):
            case = (f"the overrides of case {linkage.case!r} {list(_case_table(linkage))}, "
                    if linkage.case is not None else "")
            raise ValueError(
                f"unknown {what} {name!r} of linkage {linkage.name!r}; allowed: {case}"
                f"'clearance', '<clearance joint>.clearance' or a dotted path of the "
                f"description {list(linkage.parameter_names())} (also with its section in "
                f"front, e.g. 'bodies.<body>.mass')")
        out.append(name)
    if len(set(out)) != len(out):
        raise ValueError(f"{what}s must not repeat a name; got {out}")
    return tuple(out)


def design_value(linkage: Linkage, name: str) -> float:
    """The value of `name` on `linkage` (SI; a derived override, e.g. a uniform-rod
    inertia, its value in use; "clearance": the smallest clearance)."""
    check_names(linkage, [name])
    table = _case_table(linkage)
    if name in table:
        mech = slider_crank_of(linkage)
        if mech is not None and table[name] is None:
            return reference_value(mech, name)
        value = linkage.overrides.get(name, table[name])
        if value is None and name.endswith("_inertia"):
            return linkage.parameter_value(f"{name[:-len('_inertia')]}.inertia")
        return float(value)
    if name == "clearance":
        return linkage.min_clearance
    if _revolute_clearance(linkage, name):
        joint = name[:-len(".clearance")]
        return next(j.clearance for j in linkage.clearance_joints if j.name == joint)
    return linkage.parameter_value(_dotted(name))


def _revolute_clearance(linkage: Linkage, name: str) -> bool:
    """Whether `name` is "<clearance joint>.clearance" of a revolute clearance joint (a
    translational joint's clearance is a parameter of its own)."""
    return name.endswith(".clearance") and any(
        j.name == name[:-len(".clearance")] for j in linkage.clearance_joints)


def linkage_with(linkage: Linkage, values: Mapping[str, float]) -> Linkage:
    """`linkage` with the named values set (see the module docstring): a case's overrides
    rebuild the case, then the dotted paths, "clearance" and "<joint>.clearance" change the
    description (`design_at`). ValueError for an unknown name, a value that is not
    a finite number, or a design out of the case's or the description's valid range."""

    if not isinstance(values, Mapping):
        raise ValueError(f"values must be a mapping {{name: value}}; got {values!r}")
    check_names(linkage, values)
    table = _case_table(linkage)
    overrides, dotted, clearance = {}, {}, None
    for name, value in values.items():
        if (not isinstance(value, numbers.Real) or isinstance(value, bool)
                or not math.isfinite(float(value))):
            raise ValueError(f"{name} must be a finite number; got {value!r}")
        value = float(value)
        if name in table:
            overrides[name] = value
        elif name == "clearance" and linkage.case is not None:
            clearance = value
        else:
            dotted[_dotted(name)] = value
    if clearance is not None:
        if linkage.case in _SLIDER_CRANK_CASES:
            rb = overrides.get("bearing_radius", slider_crank_of(linkage).bearing_radius)
            if not 0.0 < clearance < rb:
                raise ValueError(f"clearance must be in (0, bearing_radius {rb!r} m); "
                                 f"got {clearance!r}")
            overrides["journal_radius"] = rb - clearance
        else:
            for key in [k for k in table if k.endswith("clearance")]:
                overrides[key] = clearance
    if overrides:
        from .cases import CASES

        linkage = CASES[linkage.case](**{**linkage.overrides, **overrides})
    if dotted:
        linkage = design_at(linkage, dotted)
    return linkage


#: relative steps of the central differences that give a case override's direction (the
#: second where the first leaves the case's valid range): exact for values at most
#: quadratic in the override, so the step is as large as the rounding of the values asks
#: (a journal radius 0.06 m - 1e-5 m is rounded to 1e-17 m)
_DIRECTION_STEPS = (1e-3, 1e-6)


def direction(linkage: Linkage, name: str) -> dict[str, float]:
    """d(description parameter)/d(name) for every description parameter that `name`
    moves ({dotted path: coefficient}): the direction of a DDM design variable
    (`linkage_ddm.combine`). A dotted path is itself; a clearance moves the journal
    radii (-1); a case override's coefficients are central differences of the rebuilt
    case's values over +-1e-6 of the override (exact for the cases' values, which are at
    most quadratic in an override: the uniform-rod inertia m L^2 / 12). A contact
    stiffness still derived from the radii (Eq. 9) in the rebuilt case is left to the
    DDM's own chain; an override of the stiffness itself moves it."""
    check_names(linkage, [name])
    if name == "clearance" and linkage.case is None:
        return {**{f"{j.name}.journal_radius": -1.0 for j in linkage.clearance_joints},
                **{f"{j.name}.clearance": 1.0 for j in linkage.translational_joints}}
    if _revolute_clearance(linkage, name) and name not in _case_table(linkage):
        return {f"{name[:-len('.clearance')]}.journal_radius": -1.0}
    if name not in _case_table(linkage) and name != "clearance":
        return {_dotted(name): 1.0}
    value = design_value(linkage, name)
    for step in _DIRECTION_STEPS:
        h = step * (abs(value) if value != 0.0 else 1.0)
        try:
            plus = linkage_with(linkage, {name: value + h})
            minus = linkage_with(linkage, {name: value - h})
            break
        except ValueError:
            if step == _DIRECTION_STEPS[-1]:
                raise
    derived = {f"{j.name}.contact_stiffness" for j in plus.clearance_joints
               if j.contact_stiffness is None}
    out = {}
    for p in linkage.parameter_names():
        if p in derived:
            continue
        d = plus.parameter_value(p) - minus.parameter_value(p)
        if d != 0.0:
            out[p] = d / (2.0 * h)
    return out


# ------------------------------------------------------------------------ sweep designs

def _linkage_clearance(link: Linkage, joint: str | None, value: float) -> Linkage:
    names = [j.name for j in link.clearance_joints] if joint is None else [joint]
    for j in names:
        rb = link.parameter_value(f"{j}.bearing_radius")
        if not 0.0 < value < rb:
            raise ValueError(f"clearance of {j} must be in (0, bearing radius {rb!r} m); "
                             f"got {value!r}")
        link = link.with_parameter(f"{j}.journal_radius", rb - value)
    if joint is None:           # the translational joints' guides too
        for tj in link.translational_joints:
            link = link.with_parameter(f"{tj.name}.clearance", value)
    return link


def design_at(mech, values: dict, case: str | None = None, overrides: dict | None = None):
    """The design of a sweep point: `mech` with the fields `values` (see the module
    docstring for the names), or the named `case` built with `overrides` and `values`.
    ValueError for an unknown field or a value out of its range."""
    if case is not None:
        from .cases import CASE_PARAMETERS, CASES

        if case not in CASES:
            raise ValueError(f"case must be one of {sorted(CASES)}; got {case!r}")
        if case in ("paper_slider_crank_lubricated", "paper_slider_crank_wear"):
            # SliderCrank fields and the film's, "clearance" and dotted paths
            return linkage_with(CASES[case](**(overrides or {})), values)
        table = CASE_PARAMETERS.get(case)
        if table is None:       # the paper's case: SliderCrank fields
            return design_at(SliderCrank().replace(**(overrides or {})), values)
        changes = dict(overrides or {})
        for name, v in values.items():
            if name == "clearance" and name not in table:
                for key in [k for k in table if k.endswith("clearance")]:
                    changes[key] = v
            elif name not in table:
                raise ValueError(f"{case}: unknown sweep field {name!r}; allowed: "
                                 f"{sorted(table) + ['clearance']}")
            else:
                changes[name] = v
        return CASES[case](**changes)
    from .cases import door
    from .mechanism import field_names

    entry = door(mech)                  # ValueError for anything else
    if entry.paper is not None and (entry.given_as_paper or all(
            n == "clearance" or n in field_names() for n in values)):
        # the paper's case: its fields and "clearance" (R_B - R_J), a design of its case
        # named as the user gave the mechanism
        mech = entry.paper
        changes = {}
        for name, v in values.items():
            if name == "clearance":
                if not 0.0 < v < mech.bearing_radius:
                    raise ValueError(f"clearance must be in (0, bearing_radius "
                                     f"{mech.bearing_radius!r} m); got {v!r}")
                changes["journal_radius"] = mech.bearing_radius - v
            elif name in field_names():
                changes[name] = v
            else:
                raise ValueError(f"unknown sweep field {name!r} of a SliderCrank; allowed: "
                                 f"{sorted(field_names()) + ['clearance']}")
        return entry.back(mech.replace(**changes))
    link = entry.linkage
    for name, v in values.items():
        if name == "clearance":
            link = _linkage_clearance(link, None, v)
        elif _revolute_clearance(link, name):
            link = _linkage_clearance(link, name[:-len(".clearance")], v)
        elif name == "crank_speed":
            link = link.with_parameter("drive.speed", v)
        else:
            if name not in link.parameter_names():
                raise ValueError(f"unknown sweep field {name!r} of linkage {link.name!r}; "
                                 f"allowed: {list(link.parameter_names())} or 'clearance', "
                                 "'<joint>.clearance', 'crank_speed'")
            link = link.with_parameter(name, v)
    return link


def value_at(mech, name: str) -> float:
    """The value (SI) of `design_at`'s field `name` on `mech`: a `SliderCrank` field or
    "clearance" (R_B - R_J); on a `Linkage` its design names (`design_value`) and
    "crank_speed" (the drive's speed). ValueError for an unknown name."""
    from .cases import door

    entry = door(mech)                  # ValueError for anything else
    if entry.given_as_paper:            # the paper's set: its fields by name
        from .mechanism import field_names

        if name == "clearance":
            return float(mech.clearance)
        if name not in field_names():
            raise ValueError(f"unknown field {name!r} of a SliderCrank; allowed: "
                             f"{sorted(field_names()) + ['clearance']}")
        return float(getattr(mech, name))
    mech = entry.linkage
    if name == "crank_speed" and "crank_speed" not in _case_table(mech):
        return float(mech.drive.speed)
    return float(design_value(mech, name))
