"""Named linkages (`Linkage` descriptions), each citing its source, units beside values.

- `paper_slider_crank(**overrides)`: the paper's slider-crank (Ebrahimi, Salahshoor & Nouri
  2018, Tables 1-2, completed with Flores & Ambrosio's benchmark: see
  `mechanism.PARAMETER_INFO`), clearance in the coupler-slider joint; the overrides are
  `SliderCrank` fields. `from_slider_crank(mech)` maps any `SliderCrank`.
"""

from __future__ import annotations

from typing import Any

from .linkage import GROUND, Body, ClearanceJoint, Drive, Linkage, Prismatic, Revolute
from .mechanism import SliderCrank

__all__ = ["paper_slider_crank", "from_slider_crank"]


def from_slider_crank(mech: SliderCrank) -> Linkage:
    """The `Linkage` of a `SliderCrank`, every field mapped, as the paper's Eqs. 1-8 have it:
    the crank pivot at the origin, the slider on the x axis through the origin, the crank's
    and coupler's centres of mass at their midpoints, the slider's at its pin. The clearance
    joint "coupler_slider" has its journal on the coupler's slider end and its bearing on the
    slider. The drive turns the crank pivot; the monitored joint is the crank pivot (its
    reaction is the paper's base force F12). Assembly guesses: the ideal joints' closed-form
    positions at the initial crank angle (the branch with the slider at x > 0)."""
    if not isinstance(mech, SliderCrank):
        raise ValueError(f"mech must be a SliderCrank; got {type(mech).__name__}")
    import numpy as np

    L2, L3 = mech.crank_length, mech.coupler_length
    th2 = mech.initial_crank_angle
    th3 = float(np.arcsin(-L2 * np.sin(th2) / L3))
    x4 = float(L2 * np.cos(th2) + L3 * np.cos(th3))
    return Linkage(
        name="paper_slider_crank",
        bodies=(
            Body("crank", mech.crank_mass, mech.crank_inertia_value,
                 {"pivot": (-L2 / 2, 0.0), "pin": (L2 / 2, 0.0)}),
            Body("coupler", mech.coupler_mass, mech.coupler_inertia_value,
                 {"crank_end": (-L3 / 2, 0.0), "slider_end": (L3 / 2, 0.0)}),
            Body("slider", mech.slider_mass, _slider_inertia(mech), {"pin": (0.0, 0.0)}),
        ),
        joints=(
            Revolute("crank_pivot", GROUND, "crank_pivot", "crank", "pivot"),
            Revolute("crank_coupler", "crank", "pin", "coupler", "crank_end"),
            Prismatic("slider_guide", GROUND, "slider_axis", "slider", "pin", angle=0.0),
        ),
        clearance_joints=(
            ClearanceJoint(
                "coupler_slider", journal_body="coupler", journal_point="slider_end",
                bearing_body="slider", bearing_point="pin",
                bearing_radius=mech.bearing_radius, journal_radius=mech.journal_radius,
                youngs_modulus=mech.youngs_modulus, poisson_ratio=mech.poisson_ratio,
                restitution=mech.restitution, contact_stiffness=mech.contact_stiffness,
                contact_model=mech.contact_model,
                impact_velocity_floor=mech.impact_velocity_floor),
        ),
        drive=Drive("crank_pivot", mech.crank_speed, mech.initial_crank_angle),
        ground_points={"crank_pivot": (0.0, 0.0), "slider_axis": (0.0, 0.0)},
        gravity=mech.gravity,
        monitor_joint="crank_pivot",
        assembly={"coupler.angle": th3, "slider_guide.s": x4},
    )


def _slider_inertia(mech: SliderCrank) -> float:
    """The slider's inertia (kg m^2): it does not turn (prismatic joint), so the value never
    enters the motion; the paper gives none. A 1 cm uniform square block of the slider's
    mass is taken so that the description is complete (m a^2 / 6, a = 0.01 m)."""
    return mech.slider_mass * 0.01**2 / 6.0


def paper_slider_crank(**overrides: Any) -> Linkage:
    """The paper's slider-crank (`SliderCrank()` defaults: L2 = 0.05 m, L3 = 0.12 m,
    m2 = 0.30 kg, m3 = 0.21 kg, m4 = 0.14 kg, J2 = 1e-4 kg m^2, J3 = m3 L3^2/12, 5000 rpm,
    R_B = 10 mm, R_J = 9.99 mm (clearance 0.01 mm), E = 207 GPa, nu = 0.3, e = 0.9, g =
    9.81 m/s^2; Ebrahimi, Salahshoor & Nouri 2018 Tables 1-2 and Flores & Ambrosio's
    benchmark, `mechanism.PARAMETER_INFO`), with `overrides` of SliderCrank fields (e.g.
    ``journal_radius=0.00995``), as a `Linkage` (`from_slider_crank`)."""
    return from_slider_crank(SliderCrank().replace(**overrides))
