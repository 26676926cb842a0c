"""Closed-form slider-crank with ideal joints: the zero-clearance limit of the models.

The paper's `SliderCrank` parameter set only; any `Linkage` with its clearance joints closed
is `ideal_linkage` (the same backend, "ideal").

With the crank at constant speed the ideal mechanism has no degree of freedom left, so every
output is an explicit function of time (kinematics differentiated twice, then Newton-Euler
for the joint forces). Used as the reference of the ideal-joint limit tests and as the
"ideal joint" curves of the report.
"""

from __future__ import annotations

import numpy as np

from .._checks import MemoryLimitError, check_int, check_max_memory, format_bytes
from ..model.mechanism import PAPER_JOINT, SliderCrank
from ..solve.trajectory import COUPLER_ANGLE, SLIDER_S, Trajectory, annotate

__all__ = ["ideal_outputs", "simulate_ideal", "peak_ideal"]

#: options of `simulate(..., backend="ideal")`
OPTION_NAMES = ("samples_per_revolution", "max_memory")

#: peak bytes per sample of `simulate_ideal`: the closed form's temporaries and the
#: Trajectory (measured with tracemalloc: 232 bytes per sample), with a margin
BYTES_PER_SAMPLE = 8 * 40


def ideal_outputs(mech: SliderCrank, t: np.ndarray) -> dict[str, np.ndarray]:
    """All outputs of the ideal mechanism at times `t` (s), as a dict of arrays.

    Keys: theta3, theta3d, theta3dd, x4, x4d, x4dd, joint_force (n, 2) (force of the slider
    on the coupler's journal), base_force (n, 2), crank_moment.
    """
    t = np.asarray(t, dtype=float)
    L2, L3 = mech.crank_length, mech.coupler_length
    m2, m3, m4 = mech.crank_mass, mech.coupler_mass, mech.slider_mass
    w, g = mech.crank_speed, mech.gravity
    J3 = mech.coupler_inertia_value
    th2 = w * t + mech.initial_crank_angle
    c2, s2 = np.cos(th2), np.sin(th2)
    s3 = -L2 * s2 / L3
    th3 = np.arcsin(s3)
    c3 = np.cos(th3)
    th3d = -L2 * w * c2 / (L3 * c3)
    th3dd = (L2 * w**2 * s2 + L3 * th3d**2 * s3) / (L3 * c3)
    x4 = L2 * c2 + L3 * c3
    x4d = -L2 * w * s2 - L3 * th3d * s3
    x4dd = -L2 * w**2 * c2 - L3 * (th3dd * s3 + th3d**2 * c3)
    sin32 = s3 * c2 - c3 * s2
    cos23 = c2 * c3 + s2 * s3
    fjx = -m4 * x4dd
    inertia = J3 + 0.25 * m3 * L3**2
    fjy = (inertia * th3dd + 0.5 * m3 * L2 * L3 * w**2 * sin32 + 0.5 * m3 * g * L3 * c3
           + L3 * fjx * s3) / (L3 * c3)
    ag2 = -0.5 * L2 * w**2 * np.stack([c2, s2], axis=1)
    ag3 = (-L2 * w**2 * np.stack([c2, s2], axis=1)
           + 0.5 * L3 * (th3dd[:, None] * np.stack([-s3, c3], axis=1)
                         - (th3d**2)[:, None] * np.stack([c3, s3], axis=1)))
    fj = np.stack([fjx, fjy], axis=1)
    weight = np.zeros_like(fj)
    weight[:, 1] = (m2 + m3) * g
    base = -(m2 * ag2 + m3 * ag3 + weight - fj)
    moment = (0.5 * m3 * L2 * L3 * (th3dd * cos23 - th3d**2 * sin32)
              + (m3 + 0.5 * m2) * g * L2 * c2 - L2 * (-fjx * s2 + fjy * c2))
    return dict(theta3=th3, theta3d=th3d, theta3dd=th3dd, x4=x4, x4d=x4d, x4dd=x4dd,
                joint_force=fj, base_force=base, crank_moment=moment)


def simulate_ideal(mech: SliderCrank, revolutions: int = 4, *,
                   samples_per_revolution: int = 3600, max_memory: int | None = None
                   ) -> Trajectory:
    """Ideal-joint trajectory sampled uniformly (closed form, no integration).

    A run whose samples would need more than ``max_memory`` bytes (default
    `_checks.default_max_memory`; BYTES_PER_SAMPLE per sample) is refused before it starts.
    """
    revolutions = check_int("revolutions", revolutions, 1)
    samples_per_revolution = check_int("samples_per_revolution", samples_per_revolution, 8)
    max_memory = check_max_memory(max_memory)
    n = revolutions * samples_per_revolution + 1
    if n * BYTES_PER_SAMPLE > max_memory:
        raise MemoryLimitError(
            f"{revolutions} revolutions of {samples_per_revolution} samples need about "
            f"{format_bytes(n * BYTES_PER_SAMPLE)}, more than max_memory={max_memory} bytes "
            f"({format_bytes(max_memory)}); use fewer samples or revolutions, or raise "
            "max_memory")
    t = np.linspace(0.0, revolutions * mech.period, n)
    o = ideal_outputs(mech, t)
    zeros = np.zeros(n)
    power = o["crank_moment"] * mech.crank_speed
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    # the ideal mechanism is periodic in the crank revolution: one refined peak serves all
    peaks = np.full(revolutions, _refined_peak(mech, 1))
    return annotate(Trajectory(
        t=t, base_force=o["base_force"], crank_moment=o["crank_moment"],
        contact_force=np.hypot(o["joint_force"][:, 0], o["joint_force"][:, 1]),
        penetration=zeros.copy(), eccentricity=np.zeros((n, 2)),
        contact_phase=np.ones(n, dtype=np.int8), crank_work=work,
        mechanism=mech, backend="ideal",
        stats={"samples_per_revolution": samples_per_revolution}, peaks=peaks,
        joints=(PAPER_JOINT,),
        # by the description's names (`trajectory.PAPER_SERIES` reads the paper's from them)
        coordinates={COUPLER_ANGLE: o["theta3"], SLIDER_S: o["x4"]},
        rates={COUPLER_ANGLE: o["theta3d"], SLIDER_S: o["x4d"]},
        accelerations={COUPLER_ANGLE: o["theta3dd"], SLIDER_S: o["x4dd"]},
    ))


def _refined_peak(mech: SliderCrank, revolution: int) -> float:
    from scipy.optimize import minimize_scalar

    t_a = (revolution - 1) * mech.period
    t = np.linspace(t_a, t_a + mech.period, 3601)
    mag = np.hypot(*ideal_outputs(mech, t)["base_force"].T)
    i = int(np.argmax(mag))
    lo, hi = t[max(i - 1, 0)], t[min(i + 1, len(t) - 1)]

    def neg(tt):
        return -float(np.hypot(*ideal_outputs(mech, np.array([tt]))["base_force"][0]))

    res = minimize_scalar(neg, bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-14 * mech.period})
    return max(-res.fun, float(mag[i]))


def peak_ideal(mech: SliderCrank, revolution: int = 4, *, max_memory: int | None = None
               ) -> float:
    """Max |F12| in N over a revolution of the ideal mechanism (periodic: the same for every
    revolution, computed over the first; O(1) memory, `max_memory` is only checked)."""
    check_int("revolution", revolution, 1)
    check_max_memory(max_memory)
    return _refined_peak(mech, 1)
