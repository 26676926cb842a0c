"""Named linkages (`Linkage` descriptions), each citing its source, units beside values.

- `paper_slider_crank(**overrides)`: the paper's slider-crank (Ebrahimi, Salahshoor & Nouri
  2018, Tables 1-2, completed with Flores & Ambrosio's benchmark: see
  `mechanism.PARAMETER_INFO`), clearance in the coupler-slider joint; the overrides are
  `SliderCrank` fields. `from_slider_crank(mech)` maps any `SliderCrank`.
- `slider_crank_two_clearances(**overrides)`: the same slider-crank with clearance in BOTH
  coupler joints (Flores' multiple-clearance study).
- `four_bar(**overrides)`: a Grashof crank-rocker with a clearance in the coupler-rocker
  joint (the four-bar of the Siconos clearance example, Akhadkar, Acary & Brogliato).
- `CASES`: name -> function; `CASE_PARAMETERS`: each case's overrides with default, unit and
  source. docs/cases.md tells each case, its sources and what is measured.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
from typing import Any

from ..laws.registry import FRICTION_SLOTS
from .linkage import (
    FRICTION_DEFAULTS,
    GROUND,
    Body,
    ClearanceJoint,
    Drive,
    Initial,
    Linkage,
    Prismatic,
    Revolute,
    TranslationalClearance,
    check_friction,
)
from .mechanism import PAPER_JOINT, SliderCrank, description_values

__all__ = ["as_linkage", "door", "Door", "slider_crank_of", "SLIDER_CRANK_CASES",
           "paper_slider_crank", "from_slider_crank",
           "slider_crank_two_clearances",
           "four_bar", "paper_slider_crank_lubricated", "LUBRICATED_DEFAULTS",
           "paper_slider_crank_wear", "WEAR_DEFAULTS", "CASES",
           "CASE_PARAMETERS", "CASE_SUMMARY", "flores_translational_slider_crank",
           "FLORES_DURATION"]


def from_slider_crank(mech: SliderCrank) -> Linkage:
    """The `Linkage` of a `SliderCrank`, every field mapped, as the paper's Eqs. 1-8 have it:
    the crank pivot at the origin, the slider on the x axis through the origin, the crank's
    and coupler's centres of mass at their midpoints, the slider's at its pin. The clearance
    joint "coupler_slider" has its journal on the coupler's slider end and its bearing on the
    slider. The drive turns the crank pivot; the monitored joint is the crank pivot (its
    reaction is the paper's base force F12). Assembly guesses: the ideal joints' closed-form
    positions at the initial crank angle (the branch with the slider at x > 0)."""
    if not _is_paper_set(mech):
        raise ValueError(f"mech must be a SliderCrank; got {type(mech).__name__}")
    import numpy as np

    v = description_values(mech)        # every value through the one table, FIELD_PATHS
    L2, L3 = mech.crank_length, mech.coupler_length
    th2 = mech.initial_crank_angle
    th3 = float(np.arcsin(-L2 * np.sin(th2) / L3))
    x4 = float(L2 * np.cos(th2) + L3 * np.cos(th3))

    def point(path):
        return (v[f"{path}.x"], 0.0)

    joint = {path.partition(".")[2]: value for path, value in v.items()
             if path.startswith(f"{PAPER_JOINT}.")}
    return Linkage(
        name="paper_slider_crank",
        bodies=(
            Body("crank", v["crank.mass"], v["crank.inertia"],
                 {"pivot": point("crank.pivot"), "pin": point("crank.pin")}),
            Body("coupler", v["coupler.mass"], v["coupler.inertia"],
                 {"crank_end": point("coupler.crank_end"),
                  "slider_end": point("coupler.slider_end")}),
            Body("slider", v["slider.mass"], v["slider.inertia"], {"pin": (0.0, 0.0)}),
        ),
        joints=(
            Revolute("crank_pivot", GROUND, "crank_pivot", "crank", "pivot"),
            Revolute("crank_coupler", "crank", "pin", "coupler", "crank_end"),
            Prismatic("slider_guide", GROUND, "slider_axis", "slider", "pin", angle=0.0),
        ),
        clearance_joints=(
            ClearanceJoint(PAPER_JOINT, journal_body="coupler", journal_point="slider_end",
                           bearing_body="slider", bearing_point="pin", **joint),
        ),
        drive=Drive("crank_pivot", v["drive.speed"], v["drive.initial_angle"]),
        ground_points={"crank_pivot": (0.0, 0.0), "slider_axis": (0.0, 0.0)},
        gravity=v["gravity"],
        monitor_joint="crank_pivot",
        assembly={"coupler.angle": th3, "slider_guide.s": x4},
    )


@functools.lru_cache(maxsize=256)
def _paper_case_of(mech: SliderCrank) -> Linkage:
    changed = {f.name: getattr(mech, f.name) for f in dataclasses.fields(SliderCrank)
               if getattr(mech, f.name) != getattr(_PAPER_DEFAULTS, f.name)}
    return paper_slider_crank(**changed)


_PAPER_DEFAULTS = SliderCrank()


#: the cases whose overrides are SliderCrank fields (the lubricated and wearing ones: and
#: their joint's)
SLIDER_CRANK_CASES = ("paper_slider_crank", "paper_slider_crank_lubricated",
                      "paper_slider_crank_wear")


def slider_crank_of(linkage: Linkage) -> SliderCrank | None:
    """The `SliderCrank` of a linkage built by a case whose overrides are its fields (its
    overrides that are fields of the one table, `mechanism.FIELD_PATHS`), else None."""
    if linkage.case not in SLIDER_CRANK_CASES:
        return None
    from .mechanism import FIELD_PATHS

    return SliderCrank().replace(**{k: v for k, v in linkage.overrides.items()
                                    if k in FIELD_PATHS})


@dataclasses.dataclass(frozen=True)
class Door:
    """A mechanism as the studies take it (`door`): `linkage` the description every layer
    runs; `paper` the paper's parameter set where the description is its case
    "paper_slider_crank" (its overrides the fields of `mechanism.FIELD_PATHS`), else None;
    `given_as_paper` whether the user gave that set (`SliderCrank`), so that a result
    names its designs as given (`back`)."""

    linkage: Linkage
    paper: SliderCrank | None
    given_as_paper: bool

    def back(self, design: SliderCrank | Linkage) -> SliderCrank | Linkage:
        """A design of the study (the paper's set or a description of the same case) as
        the user gave the mechanism: the paper's `SliderCrank`, or the description."""
        entry = door(design)
        return entry.paper if self.given_as_paper else entry.linkage


def _is_paper_set(mech) -> bool:
    # the package's one type test of the paper's parameter set: `door` and its converter
    return isinstance(mech, SliderCrank)


def door(mech: SliderCrank | Linkage) -> Door:
    """The one door of every study: the mechanism as its description (`Door`). A `Linkage`
    as it is; the paper's `SliderCrank` (a named parameter set) as the case
    "paper_slider_crank" with its changed fields as the case's overrides, so that its field
    names are design names of every study (`design`). The only place that tells the two
    apart. ValueError for anything else."""
    if _is_paper_set(mech):
        return Door(_paper_case_of(mech), mech, True)
    if isinstance(mech, Linkage):
        # the paper's case itself (a lubricated or wearing joint is more than its fields)
        return Door(mech, slider_crank_of(mech) if mech.case == "paper_slider_crank" else None,
                    False)
    raise ValueError(f"mech must be a SliderCrank or a Linkage (the paper's parameter set "
                     f"or any description); got {type(mech).__name__}")


def as_linkage(mech: SliderCrank | Linkage) -> Linkage:
    """The description a study runs (`door`): a `Linkage` as it is, the paper's
    `SliderCrank` as its case. ValueError for anything else."""
    return door(mech).linkage


def paper_slider_crank(**overrides: Any) -> Linkage:
    """The paper's slider-crank (`SliderCrank()` defaults: L2 = 0.05 m, L3 = 0.12 m,
    m2 = 0.30 kg, m3 = 0.21 kg, m4 = 0.14 kg, J2 = 1e-4 kg m^2, J3 = m3 L3^2/12, 5000 rpm,
    R_B = 10 mm, R_J = 9.99 mm (clearance 0.01 mm), E = 207 GPa, nu = 0.3, e = 0.9, g =
    9.81 m/s^2; Ebrahimi, Salahshoor & Nouri 2018 Tables 1-2 and Flores & Ambrosio's
    benchmark, `mechanism.PARAMETER_INFO`), with `overrides` of SliderCrank fields (e.g.
    ``journal_radius=0.00995``), as a `Linkage` (`from_slider_crank`)."""
    import dataclasses

    linkage = from_slider_crank(SliderCrank().replace(**overrides))
    return dataclasses.replace(linkage, case="paper_slider_crank", overrides=dict(overrides))


#: the lubrication overrides of `paper_slider_crank_lubricated`: name -> (default, unit,
#: source)
LUBRICATED_DEFAULTS: dict[str, tuple[Any, str, str]] = {
    "lubrication": ("short", "-", "the short-bearing film (Ocvirk; L/D = 0.5 here), as "
                                  "Flores et al. 2006 for the slider-crank's joints"),
    "viscosity": (9.0e-3, "Pa s", "SAE 30 engine oil at 100 C: 9.3-12.5 mm^2/s (SAE J300), "
                                  "the midpoint times about 0.83 kg/L"),
    "bearing_length": (0.01, "m", "assumed: half the journal diameter (L/D = 0.5); the "
                                  "paper gives no length"),
    "film_fade_start": (0.90, "-", "assumed: film 10 % of the clearance"),
    "film_fade_end": (0.97, "-", "assumed: film 3 % of the clearance (0.3 um), ground "
                                 "surfaces' combined roughness"),
}


def paper_slider_crank_lubricated(**overrides: Any) -> Linkage:
    """The paper's slider-crank (`paper_slider_crank`) with its coupler-slider joint in an
    oil film (`laws.lubrication`): the overrides are SliderCrank fields and the lubrication
    fields of `LUBRICATED_DEFAULTS` (film model, viscosity, bearing length, the fade's
    ends), each a design name of the studies (``viscosity``, ``crank_speed``, ...)."""
    return _paper_joint_case("paper_slider_crank_lubricated", LUBRICATED_DEFAULTS, overrides)


def _paper_joint_case(name: str, defaults: dict, overrides: dict) -> Linkage:
    """The paper's slider-crank whose coupler-slider joint takes the fields of `defaults`
    ({field: (default, unit, source)}), each overridden by `overrides`, the rest of which
    are SliderCrank fields; named and cased `name`."""
    import dataclasses

    joint_values = {k: overrides.get(k, d[0]) for k, d in defaults.items()}
    linkage = paper_slider_crank(**{k: v for k, v in overrides.items() if k not in defaults})
    joint = dataclasses.replace(linkage.clearance_joints[0], **joint_values)
    return dataclasses.replace(linkage.replace(clearance_joints=(joint,)), name=name,
                               case=name, overrides=dict(overrides))


#: the overrides of `paper_slider_crank_wear` beyond the SliderCrank fields: name ->
#: (default, unit, source)
WEAR_DEFAULTS: dict[str, tuple[Any, str, str]] = {
    "friction_law": ("coulomb", "-", "Coulomb's law, regularised (friction_v0, friction_v1)"),
    "friction_coefficient": (0.1, "-", "assumed: steel on steel, boundary-lubricated "
                                       "(dry steel pairs run 0.3-0.6)"),
    "wear_coefficient": (2.0e-17, "m^2/N", "assumed: Archard's K = 1e-7 over a hardened "
                                           "steel's H = 5 GPa, inside the mild-wear range of "
                                           "K (1e-8 to 1e-4; severe adhesive wear of dry mild "
                                           "steel reaches 7e-3, Archard 1953); published "
                                           "coefficients scatter widely: study per decade"),
    "bearing_length": (0.01, "m", "assumed: half the journal diameter (L/D = 0.5), as the "
                                  "lubricated case; the paper gives no length"),
}


def paper_slider_crank_wear(**overrides: Any) -> Linkage:
    """The paper's slider-crank (`paper_slider_crank`) whose coupler-slider joint wears:
    Coulomb friction in the joint and Archard's wear coefficient k/H (`WEAR_DEFAULTS`, each
    with its source); the overrides are SliderCrank fields and the fields of
    `WEAR_DEFAULTS`. Its wear life: `studies.wear.wear_life` (CLI ``mbs-clearance wear``)."""
    return _paper_joint_case("paper_slider_crank_wear", WEAR_DEFAULTS, overrides)


# ---------------------------------------------------------------------------------------
# slider-crank with clearance in both coupler joints; crank-rocker four-bar
# ---------------------------------------------------------------------------------------

RPM = 2.0 * math.pi / 60.0

#: the friction overrides of every case (ClearanceJoint's friction fields, every clearance
#: joint of the case): name -> (default, unit, source)
_FRICTION = {k: (default, unit, source)
             for k, (_, unit, default, source) in FRICTION_DEFAULTS.items()}

#: case -> {override name: (default, unit, source)}; docs/cases.md lists the same table
CASE_PARAMETERS: dict[str, dict[str, tuple[Any, str, str]]] = {
    "slider_crank_two_clearances": {
        "crank_length": (0.05, "m", "Ebrahimi et al. 2018 Table 1 (Flores' slider-crank)"),
        "coupler_length": (0.12, "m", "Ebrahimi et al. 2018 Table 1"),
        "crank_mass": (0.30, "kg", "Ebrahimi et al. 2018 Table 1"),
        "coupler_mass": (0.21, "kg", "Ebrahimi et al. 2018 Table 1"),
        "slider_mass": (0.14, "kg", "Ebrahimi et al. 2018 Table 1"),
        "crank_inertia": (1.0e-4, "kg m^2", "Flores & Ambrosio benchmark (as SliderCrank)"),
        "coupler_inertia": (None, "kg m^2", "None: uniform thin rod m L^2/12 (paper)"),
        "crank_speed": (5000.0 * RPM, "rad/s", "5000 rpm, Flores & Ambrosio benchmark"),
        "initial_crank_angle": (0.0, "rad", "as SliderCrank"),
        "bearing_radius": (0.010, "m", "Ebrahimi et al. 2018 Table 2, both joints"),
        "crank_coupler_clearance": (1.0e-5, "m", "assumed: the paper's 0.01 mm"),
        "coupler_slider_clearance": (1.0e-5, "m", "Ebrahimi et al. 2018 Table 2"),
        "youngs_modulus": (207.0e9, "Pa", "Ebrahimi et al. 2018 Table 2"),
        "poisson_ratio": (0.3, "-", "Ebrahimi et al. 2018 Table 2"),
        "restitution": (0.9, "-", "Ebrahimi et al. 2018 Table 2"),
        "contact_model": ("lankarani_nikravesh", "-", "paper Eq. 9"),
        "gravity": (9.81, "m/s^2", "standard gravity along -y"),
        **_FRICTION,
    },
    "four_bar": {
        "ground_length": (3.0, "m", "Siconos FourBarLinkageWith3clearance, Table 1 (l0)"),
        "crank_length": (1.0, "m", "same source (l1)"),
        "coupler_length": (4.0, "m", "same source (l2)"),
        "rocker_length": (2.5, "m", "same source (l3)"),
        "crank_mass": (1.0, "kg", "same source (m1)"),
        "coupler_mass": (1.0, "kg", "same source (m2)"),
        "rocker_mass": (1.0, "kg", "same source (m3)"),
        "crank_inertia": (None, "kg m^2", "None: uniform rod m L^2/12 (same source, J1)"),
        "coupler_inertia": (None, "kg m^2", "None: uniform rod m L^2/12 (J2)"),
        "rocker_inertia": (None, "kg m^2", "None: uniform rod m L^2/12 (J3)"),
        "crank_speed": (10.0 * RPM, "rad/s", "assumed: 10 rpm (the source tracks a "
                        "sinusoidal crank angle, no constant speed)"),
        "initial_crank_angle": (math.pi / 2, "rad", "the source's initial crank angle"),
        "bearing_radius": (0.06, "m", "same source (r2, r4, r6)"),
        "clearance": (1.0e-5, "m", "assumed: 0.01 mm, the paper's (the source has 5 mm: "
                      "0.06 - 0.055); chosen for its regime (docs/cases.md)"),
        "youngs_modulus": (207.0e9, "Pa", "assumed: steel, as the paper"),
        "poisson_ratio": (0.3, "-", "assumed: steel, as the paper"),
        "restitution": (0.9, "-", "assumed: as the paper"),
        "contact_model": ("lankarani_nikravesh", "-", "paper Eq. 9"),
        "gravity": (9.81, "m/s^2", "same source"),
        **_FRICTION,
    },
    "flores_translational_slider_crank": {
        "crank_length": (0.153, "m", "Flores, Leine & Glocker 2010, Table 1 (l1)"),
        "coupler_length": (0.306, "m", "same source (l2)"),
        "half_length": (0.05, "m", "same source (slider a)"),
        "half_height": (0.025, "m", "same source (slider b)"),
        "clearance": (0.001, "m", "same source (c)"),
        "crank_mass": (0.038, "kg", "same source (m1)"),
        "coupler_mass": (0.038, "kg", "same source (m2)"),
        "slider_mass": (0.076, "kg", "same source (m3)"),
        "crank_inertia": (7.4e-5, "kg m^2", "same source (J1)"),
        "coupler_inertia": (5.9e-4, "kg m^2", "same source (J2)"),
        "slider_inertia": (2.7e-6, "kg m^2", "same source (J3)"),
        "gravity": (9.81, "m/s^2", "same source"),
        "restitution": (0.4, "-", "same source (normal restitution e_N)"),
        "friction_coefficient": (0.01, "-", "same source (mu)"),
        "crank_rate": (150.0, "rad/s", "same source (initial crank angular velocity)"),
        "coupler_rate": (-75.0, "rad/s", "same source (initial coupler angular velocity)"),
        "contact_stiffness": (1.0e10, "N/m^1.5", "assumed: stands in for the source's rigid "
                              "contact; results converge as it grows (docs/cases/"
                              "flores_translational_slider_crank.md)"),
        "contact_model": ("flores", "-", "assumed: Flores' law, valid at low restitution"),
        "friction_law": ("coulomb", "-", "the source's Coulomb friction (regularised by "
                         "friction_v0, friction_v1)"),
        **{k: v for k, v in _FRICTION.items()
           if k not in ("friction_law", "friction_coefficient")},
    },
}

#: the duration in s of the benchmark's run (Flores, Leine & Glocker 2010)
FLORES_DURATION = 0.2


def _case_values(case: str, overrides: dict[str, Any]) -> dict[str, Any]:
    """The case's defaults with `overrides` applied; unknown names raise ValueError."""
    table = CASE_PARAMETERS[case]
    unknown = sorted(set(overrides) - set(table))
    if unknown:
        raise ValueError(f"{case}: unknown override(s) {unknown}; allowed: {sorted(table)}")
    values = {k: v[0] for k, v in table.items()}
    values.update(overrides)
    check_friction(case, values["friction_law"], *(values[f] for f in FRICTION_SLOTS))
    for key, value in values.items():
        if key in ("contact_model", "friction_law"):
            continue
        if value is None and table[key][0] is None:     # None: the uniform-rod inertia
            continue
        if (not isinstance(value, numbers.Real) or isinstance(value, bool)
                or not math.isfinite(float(value))):
            raise ValueError(f"{case}: {key} must be a finite number in "
                             f"{table[key][1]}; got {value!r}")
        values[key] = float(value)
    positive = [k for k in values if k.endswith(("_length", "_mass", "_inertia", "_speed",
                                                 "_radius", "clearance"))]
    for key in positive:
        if values[key] is not None and not values[key] > 0.0:
            raise ValueError(f"{case}: {key} must be > 0 {table[key][1]}; "
                             f"got {values[key]!r}")
    for key in [k for k in values if k.endswith("clearance") and "bearing_radius" in values]:
        if not values[key] < values["bearing_radius"]:
            raise ValueError(f"{case}: {key} must be smaller than bearing_radius = "
                             f"{values['bearing_radius']!r} m; got {values[key]!r}")
    return values


def _rod_inertia(values: dict[str, Any], body: str) -> float:
    J = values[f"{body}_inertia"]
    return values[f"{body}_mass"] * values[f"{body}_length"] ** 2 / 12.0 if J is None else J


def _clearance_joint(name, journal_body, journal_point, bearing_body, bearing_point,
                     values, clearance):
    return ClearanceJoint(
        name, journal_body=journal_body, journal_point=journal_point,
        bearing_body=bearing_body, bearing_point=bearing_point,
        bearing_radius=values["bearing_radius"],
        journal_radius=values["bearing_radius"] - clearance,
        youngs_modulus=values["youngs_modulus"], poisson_ratio=values["poisson_ratio"],
        restitution=values["restitution"], contact_model=values["contact_model"],
        friction_law=values["friction_law"], **{f: values[f] for f in FRICTION_SLOTS})


def slider_crank_two_clearances(**overrides: Any) -> Linkage:
    """Slider-crank with radial clearance in BOTH coupler joints (crank-coupler and
    coupler-slider), the mechanism of Flores' parametric study of multiple clearance joints
    (P. Flores, "A parametric study on the dynamic response of planar multibody systems with
    multiple clearance joints", Nonlinear Dyn 61 (2010) 633-653) and of Erkaya & Uzmay's
    slider-crank studies.

    Values (SI; `CASE_PARAMETERS["slider_crank_two_clearances"]` lists each with its
    source): L2 = 0.05 m, L3 = 0.12 m, m2 = 0.30 kg, m3 = 0.21 kg, m4 = 0.14 kg
    (Ebrahimi, Salahshoor & Nouri 2018, Table 1, the paper's slider-crank, the same
    mechanism as Flores'), J2 = 1e-4 kg m^2, J3 = m3 L3^2 / 12, crank 5000 rpm (Flores &
    Ambrosio's benchmark, as `SliderCrank`), both bearings R_B = 10 mm with clearance
    0.01 mm (the paper's; Flores' own clearance values could not be read in the sources
    available here: docs/cases.md), E = 207 GPa, nu = 0.3, e = 0.9.

    Overrides: any key of that table, e.g. ``crank_coupler_clearance=5e-5`` (m). The coupler
    floats (its x, y, angle are coordinates); the drive turns the crank pivot; the monitored
    joint is the crank pivot (the paper's base force).
    """
    v = _case_values("slider_crank_two_clearances", overrides)
    L2, L3 = v["crank_length"], v["coupler_length"]
    if not L3 > L2:
        raise ValueError(f"slider_crank_two_clearances: coupler_length must exceed "
                         f"crank_length = {L2!r} m for the crank to turn fully; got {L3!r}")
    J3 = v["coupler_inertia"] if v["coupler_inertia"] is not None else (
        v["coupler_mass"] * L3 ** 2 / 12.0)
    th2 = v["initial_crank_angle"]
    # assembly guesses (ideal joints, centred journals): the closed-form slider-crank
    s3 = -L2 * math.sin(th2) / L3
    th3 = math.asin(s3)
    x4 = L2 * math.cos(th2) + L3 * math.cos(th3)
    bx, by = L2 * math.cos(th2), L2 * math.sin(th2)
    return Linkage(
        name="slider_crank_two_clearances",
        bodies=(
            Body("crank", v["crank_mass"], v["crank_inertia"],
                 {"pivot": (-L2 / 2, 0.0), "pin": (L2 / 2, 0.0)}),
            Body("coupler", v["coupler_mass"], J3,
                 {"crank_end": (-L3 / 2, 0.0), "slider_end": (L3 / 2, 0.0)}),
            # the slider does not turn: its inertia never enters the motion (as the paper case)
            Body("slider", v["slider_mass"], v["slider_mass"] * 0.01 ** 2 / 6.0,
                 {"pin": (0.0, 0.0)}),
        ),
        joints=(
            Revolute("crank_pivot", GROUND, "crank_pivot", "crank", "pivot"),
            Prismatic("slider_guide", GROUND, "slider_axis", "slider", "pin", angle=0.0),
        ),
        clearance_joints=(
            _clearance_joint("crank_coupler", "crank", "pin", "coupler", "crank_end", v,
                             v["crank_coupler_clearance"]),
            _clearance_joint("coupler_slider", "coupler", "slider_end", "slider", "pin", v,
                             v["coupler_slider_clearance"]),
        ),
        drive=Drive("crank_pivot", v["crank_speed"], th2),
        ground_points={"crank_pivot": (0.0, 0.0), "slider_axis": (0.0, 0.0)},
        gravity=v["gravity"],
        monitor_joint="crank_pivot",
        case="slider_crank_two_clearances", overrides=dict(overrides),
        assembly={"slider_guide.s": x4, "coupler.angle": th3,
                  "coupler.x": bx + 0.5 * L3 * math.cos(th3),
                  "coupler.y": by + 0.5 * L3 * math.sin(th3)},
    )


def _grashof_crank_rocker(lengths: dict[str, float]) -> None:
    s, l_ = min(lengths.values()), max(lengths.values())
    p_q = sum(lengths.values()) - s - l_
    if not (s + l_ < p_q and lengths["crank_length"] == s):
        raise ValueError(
            "four_bar: the link lengths " + ", ".join(f"{k} = {v!r} m" for k, v in
                                                       lengths.items())
            + " are not a Grashof crank-rocker (needs shortest + longest < sum of the other "
            "two, strictly, and the crank the shortest link)")


def four_bar(**overrides: Any) -> Linkage:
    """Crank-rocker four-bar with one revolute clearance joint (coupler-rocker).

    Geometry and inertia from the four-bar with joint clearances of the Siconos tutorials
    (siconos/siconos-tutorials, examples/mechanics/FourBarLinkageWith3clearance,
    "parameters according to Table 1", the four-bar of Akhadkar, Acary & Brogliato's studies
    of four-bar mechanisms with joint clearances, e.g. Multibody Syst Dyn 38 (2016)
    101-136): ground l0 = 3 m, crank l1 = 1 m, coupler l2 = 4 m, rocker l3 = 2.5 m, masses
    1 kg each, uniform rods (J = m l^2 / 12), bearing radius 0.06 m, initial crank angle
    pi/2, gravity 9.81 m/s^2. Grashof: 1 + 4 < 3 + 2.5 with the crank shortest: a
    crank-rocker. Assumed here (the source drives the crank along a sinusoid, has 5 mm
    clearances in three joints, and no material): constant crank speed 10 rpm, one
    clearance joint (coupler-rocker, journal on the rocker) of 0.01 mm (the paper's
    clearance), steel E = 207 GPa, nu = 0.3, restitution 0.9 (docs/cases.md says why).

    Regime of the defaults (measured with ``python -m validation.regime_scan four_bar 8
    adaptive 1e-10,1e-11 clearance=1e-5``): the centred start's impacts settle in the first
    revolution, then the joint stays in contact (no event in revolutions 2-8); the peaks
    per revolution agree between rtol 1e-10 and 1e-11 to 3e-6 (not tolerance-sensitive),
    but approach their periodic value slowly (change from the previous revolution 1.2e-2
    at revolution 3, 1.0e-3 at revolution 8): the frictionless joint's sliding mode,
    excited by the start, is only weakly damped. Compare window averages of the forces
    (the sliding mode averages out over a window), not a revolution's peak (docs/cases.md
    "Regime of the defaults"); with 0.1 mm the start's
    impacts make the peaks tolerance-sensitive (2e-4 between those rtols), at 20 rpm and
    more the joint force passes near zero and impacts recur irregularly.

    Overrides: any key of `CASE_PARAMETERS["four_bar"]` (SI), e.g. ``clearance=1e-7``.
    The monitored output is the shaking force (sum of the ground reactions).
    """
    v = _case_values("four_bar", overrides)
    lengths = {k: v[k] for k in ("ground_length", "crank_length", "coupler_length",
                                 "rocker_length")}
    _grashof_crank_rocker(lengths)
    L1, L2, L3, L4 = (lengths[k] for k in ("ground_length", "crank_length",
                                           "coupler_length", "rocker_length"))
    th2 = v["initial_crank_angle"]
    # assembly guesses (open branch, C above the line from B to O4): circle intersection
    bx, by = L2 * math.cos(th2), L2 * math.sin(th2)
    dx, dy = L1 - bx, -by
    D = math.hypot(dx, dy)
    along = (L3 ** 2 - L4 ** 2 + D ** 2) / (2.0 * D)
    h = math.sqrt(max(L3 ** 2 - along ** 2, 0.0))
    cx = bx + (along * dx - h * dy) / D
    cy = by + (along * dy + h * dx) / D
    th3 = math.atan2(cy - by, cx - bx)
    th4 = math.atan2(cy, cx - L1)
    return Linkage(
        name="four_bar",
        bodies=(
            Body("crank", v["crank_mass"], _rod_inertia(v, "crank"),
                 {"pivot": (-L2 / 2, 0.0), "pin": (L2 / 2, 0.0)}),
            Body("coupler", v["coupler_mass"], _rod_inertia(v, "coupler"),
                 {"crank_end": (-L3 / 2, 0.0), "rocker_end": (L3 / 2, 0.0)}),
            Body("rocker", v["rocker_mass"], _rod_inertia(v, "rocker"),
                 {"pivot": (-L4 / 2, 0.0), "pin": (L4 / 2, 0.0)}),
        ),
        joints=(
            Revolute("crank_pivot", GROUND, "crank_pivot", "crank", "pivot"),
            Revolute("crank_coupler", "crank", "pin", "coupler", "crank_end"),
            Revolute("rocker_pivot", GROUND, "rocker_pivot", "rocker", "pivot"),
        ),
        clearance_joints=(
            _clearance_joint("coupler_rocker", "rocker", "pin", "coupler", "rocker_end", v,
                             v["clearance"]),
        ),
        drive=Drive("crank_pivot", v["crank_speed"], th2),
        ground_points={"crank_pivot": (0.0, 0.0), "rocker_pivot": (L1, 0.0)},
        gravity=v["gravity"],
        monitor_joint=None,
        assembly={"coupler.angle": th3, "rocker.angle": th4},
        case="four_bar", overrides=dict(overrides),
    )


def flores_translational_slider_crank(**overrides: Any) -> Linkage:
    """The free slider-crank with a translational clearance joint of Flores, Leine and
    Glocker, "Modeling and analysis of planar rigid multibody systems with translational
    clearance joints based on the non-smooth dynamics approach", Multibody Syst. Dyn. 23
    (2010) 165-190, Table 1: crank l1 = 0.153 m, coupler l2 = 0.306 m, slider 2a = 0.1 m by
    2b = 0.05 m in a guide of width 2(b + c), c = 1 mm; masses 0.038, 0.038, 0.076 kg,
    moments of inertia 7.4e-5, 5.9e-4, 2.7e-6 kg m^2; gravity 9.81 m/s^2; normal restitution
    0.4, friction coefficient 0.01. No drive: all angles zero, the crank starting at
    150 rad/s and the coupler at -75 rad/s (the slider's centre then moves along the
    guide), run for `FLORES_DURATION` = 0.2 s.

    The source's contacts are rigid (Moreau's time stepping, Newton's impact law); here each
    corner is a compliant contact of Flores' law with stiffness ``contact_stiffness``
    (1e10 N/m^1.5 by default, an assumption: the results converge as it grows, measured in
    docs/cases/flores_translational_slider_crank.md) and Coulomb friction regularised below
    ``friction_v1``. The centres of mass are at the crank's and coupler's midpoints and the
    slider's centre, where the coupler's pin is. The monitored joint is the crank pivot.

    Overrides: any key of `CASE_PARAMETERS["flores_translational_slider_crank"]` (SI).
    """
    v = _case_values("flores_translational_slider_crank", overrides)
    L1, L2 = v["crank_length"], v["coupler_length"]
    return Linkage(
        name="flores_translational_slider_crank",
        bodies=(
            Body("crank", v["crank_mass"], v["crank_inertia"],
                 {"pivot": (-L1 / 2, 0.0), "pin": (L1 / 2, 0.0)}),
            Body("coupler", v["coupler_mass"], v["coupler_inertia"],
                 {"crank_end": (-L2 / 2, 0.0), "slider_end": (L2 / 2, 0.0)}),
            Body("slider", v["slider_mass"], v["slider_inertia"], {"centre": (0.0, 0.0)}),
        ),
        joints=(
            Revolute("crank_pivot", GROUND, "crank_pivot", "crank", "pivot"),
            Revolute("crank_coupler", "crank", "pin", "coupler", "crank_end"),
            Revolute("coupler_slider", "coupler", "slider_end", "slider", "centre"),
        ),
        clearance_joints=(),
        translational_joints=(
            TranslationalClearance(
                "guide", guide_body=GROUND, guide_point="guide_axis", slider_body="slider",
                slider_point="centre", half_length=v["half_length"],
                half_height=v["half_height"], clearance=v["clearance"],
                contact_stiffness=v["contact_stiffness"], restitution=v["restitution"],
                contact_model=v["contact_model"], friction_law=v["friction_law"],
                friction_coefficient=v["friction_coefficient"],
                **{f: v[f] for f in FRICTION_SLOTS if f != "friction_coefficient"}),
        ),
        drive=None,
        initial=Initial(coordinates={"crank.angle": 0.0, "coupler.angle": 0.0,
                                     "slider.angle": 0.0},
                        rates={"crank.angle": v["crank_rate"],
                               "coupler.angle": v["coupler_rate"], "slider.angle": 0.0}),
        ground_points={"crank_pivot": (0.0, 0.0), "guide_axis": (0.0, 0.0)},
        gravity=v["gravity"],
        monitor_joint="crank_pivot",
        case="flores_translational_slider_crank", overrides=dict(overrides),
    )


#: one line per case: what it is and where its values come from (CLI `simulate --help`)
CASE_SUMMARY = {
    "paper_slider_crank": "slider-crank, clearance in the coupler-slider joint (Ebrahimi et "
                          "al. 2018; overrides: SliderCrank fields)",
    "paper_slider_crank_wear": "the paper's slider-crank whose coupler-slider joint wears "
                               "(Coulomb friction, Archard's k/H; overrides: SliderCrank "
                               "fields, friction_coefficient, wear_coefficient, "
                               "bearing_length)",
    "paper_slider_crank_lubricated": "the paper's slider-crank, its coupler-slider joint in "
                                     "SAE 30 oil (overrides: SliderCrank fields, viscosity, "
                                     "bearing_length, lubrication, film_fade_start/end)",
    "slider_crank_two_clearances": "the paper's slider-crank with clearance in both coupler "
                                   "joints (Flores 2010's multiple-clearance study)",
    "four_bar": "Grashof crank-rocker, clearance in the coupler-rocker joint (Siconos "
                "four-bar example, Akhadkar et al. 2016)",
    "flores_translational_slider_crank": "free slider-crank, its slider in a guide with "
                                         "1 mm clearance (Flores, Leine & Glocker 2010); "
                                         "run it for 0.2 s",
}

#: the named cases, by name (CLI `simulate --case NAME`)
CASES = {
    "paper_slider_crank": paper_slider_crank,
    "paper_slider_crank_lubricated": paper_slider_crank_lubricated,
    "paper_slider_crank_wear": paper_slider_crank_wear,
    "slider_crank_two_clearances": slider_crank_two_clearances,
    "four_bar": four_bar,
    "flores_translational_slider_crank": flores_translational_slider_crank,
}
