"""Profiled bearings (`ClearanceJoint.bearing_profile`) in a compiled C model.

A profiled joint's model reads its bearing's shape as data: per profiled joint a block of
the parameter vector after the constants, ``[R_J, eq9, E, nu, R_ref, rho0, rho1, c_0 ..
c_(4N-1)]`` (journal radius in m; 1.0 when the stiffness is Eq. 9's from the radius at the
contact, else 0.0 and the joint's constant stiffness parameter is used; Young's modulus in
Pa, Poisson's ratio; the circle (the smallest radius, m) the profile fades into near the
centre between |e| = rho0 and rho1 (m, `FADE` of the smallest clearance: no contact reaches
there); the periodic cubic spline's N pieces, `BearingProfile.coefficients`, row by row).
The number of grid points N is part of the model's structure (a new N compiles a new model);
the radii are not (a new profile of the same N reuses the compiled model). The C side is
core/profile_runtime.h.
"""

from __future__ import annotations

import numpy as np

from ..model.linkage import GROUND, Linkage, Prismatic, Revolute

__all__ = ["HEAD", "FADE", "fade", "effective_radius", "block_size", "profiled",
           "refuse_profiles", "refuse_sensitivity_runs", "bearing_kinematics",
           "body_angle_series", "fill_profiles"]

#: entries of a profile's block before its spline pieces (R_J, eq9, E, nu, R_ref, rho0, rho1)
HEAD = 7
#: where the profile fades into its mean circle near the centre: from rho0 to rho1, these
#: fractions of the smallest clearance (core/profile_runtime.h, mbs_profile_gap)
FADE = (0.25, 0.5)


def fade(radii, journal_radius: float) -> tuple[float, float, float]:
    """(R_ref, rho0, rho1) in m of a profile of `radii` (`FADE`)."""
    r_min = float(np.min(radii))
    c_min = r_min - journal_radius
    return r_min, FADE[0] * c_min, FADE[1] * c_min


def effective_radius(radii, journal_radius: float, theta, r) -> np.ndarray:
    """The bearing radius (m) the compiled model takes at contact angle `theta` (rad) and
    eccentricity magnitude `r` (m): the profile's where |e| >= rho1 (every contact), faded
    into R_ref below (`fade`; the quintic step of core/profile_runtime.h)."""
    from ..model.profile import BearingProfile

    r_ref, rho0, rho1 = fade(radii, journal_radius)
    s = np.clip((np.asarray(r) - rho0) / (rho1 - rho0), 0.0, 1.0)
    w = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
    R = BearingProfile(radii).radius(theta)
    return np.where(s >= 1.0, R, r_ref + w * (R - r_ref))


def block_size(points: int) -> int:
    """Entries of p of one profiled joint's block with `points` grid angles."""
    return HEAD + 4 * points


def profiled(linkage: Linkage) -> list[tuple[int, object]]:
    """(index among the clearance joints, joint) of `linkage`'s profiled clearance joints."""
    return [(j, cj) for j, cj in enumerate(linkage.clearance_joints)
            if cj.bearing_profile is not None]


def refuse_profiles(linkage: Linkage, runs: str, hint: str) -> None:
    """ValueError naming the first profiled clearance joint of `linkage`, which `runs` do
    not support (`hint`: what to do instead)."""
    found = profiled(linkage)
    if found:
        raise ValueError(f"clearance joint {found[0][1].name!r} has a bearing_profile, which "
                         f"is not supported by {runs}; {hint}")


#: what runs that need the contact Jacobian say of a profiled joint
SENSITIVITY_RUNS = ("sensitivity runs (DDM, tangent flows: periodic orbits, Lyapunov "
                    "exponents, peak gradients), whose contact Jacobian rows take a circular "
                    "bearing")
SENSITIVITY_HINT = ("use finite differences (method 'fd', --method fd) or plain runs, or a "
                    "circular bearing (bearing_profile=None)")


def refuse_sensitivity_runs(linkage: Linkage) -> None:
    """ValueError if `linkage` has a profiled clearance joint: no run with the contact
    Jacobian takes it (`SENSITIVITY_RUNS`)."""
    refuse_profiles(linkage, SENSITIVITY_RUNS, SENSITIVITY_HINT)


def _body_angles(linkage: Linkage) -> dict:
    """Per body, where its absolute angle comes from: ("ground",), ("coordinate", name),
    ("drive",) or ("same", parent body) (a prismatic joint keeps the parent's angle)."""
    source: dict = {GROUND: ("ground",)}
    drive = None if linkage.drive is None else linkage.drive.joint
    for body, parent, joint in linkage.tree():
        if body == GROUND:
            continue
        if parent is None or (isinstance(joint, Revolute) and joint.name != drive):
            source[body] = ("coordinate", f"{body}.angle")
        elif isinstance(joint, Revolute):
            source[body] = ("drive",)
        elif isinstance(joint, Prismatic):
            source[body] = ("same", parent)
    for body in list(source):
        while source[body][0] == "same":
            source[body] = source[source[body][1]]
    return source


def bearing_kinematics(linkage: Linkage, d) -> dict:
    """Per profiled clearance joint (by its index among the clearance joints): the bearing
    body's absolute angle (rad) and its rate (rad/s) as expressions of the derivation `d`'s
    symbols (coordinates Q, rates U, time t, parameters)."""
    source = _body_angles(linkage)
    index = {c: i for i, c in enumerate(d.coordinates)}
    out = {}
    for j, cj in profiled(linkage):
        kind = source[cj.bearing_body]
        if kind[0] == "ground":
            angle, rate = 0.0, 0.0
        elif kind[0] == "coordinate":
            angle, rate = d.Q[index[kind[1]]], d.U[index[kind[1]]]
        else:
            speed = d.psyms["drive.speed"]
            angle, rate = speed * d.t + d.psyms["drive.initial_angle"], speed
        out[j] = (angle, rate)
    return out


def body_angle_series(linkage: Linkage, coordinates: tuple, ts, ys) -> dict:
    """Per body of `linkage` (and the ground), its absolute angle (rad) and rate (rad/s) at
    the recorded times `ts` (n,) from the recorded states `ys` (n, >= 2 N_Q) of a model with
    `coordinates`."""
    n = len(coordinates)
    index = {c: i for i, c in enumerate(coordinates)}
    zero = np.zeros(len(ts))
    out = {}
    for body, kind in _body_angles(linkage).items():
        if kind[0] == "ground":
            out[body] = (zero, zero)
        elif kind[0] == "coordinate":
            out[body] = (ys[:, index[kind[1]]], ys[:, n + index[kind[1]]])
        else:
            w = linkage.drive.speed
            out[body] = (w * np.asarray(ts) + linkage.drive.initial_angle, zero + w)
    return out


def fill_profiles(linkage: Linkage, model, p: np.ndarray) -> None:
    """Write the blocks of `linkage`'s profiled joints into p (the model's PROFILE_OFFSETS),
    ValueError if the model's grid sizes are not the profiles' (a model of another
    structure)."""
    offsets = getattr(model, "PROFILE_OFFSETS", ())
    found = profiled(linkage)
    if len(found) != len(offsets):
        raise ValueError(f"the model has {len(offsets)} profiled bearings, linkage "
                         f"{linkage.name!r} {len(found)}: a model of another structure")
    for (_, cj), off, points in zip(found, offsets, model.PROFILE_POINTS):
        if len(cj.bearing_profile) != points:
            raise ValueError(f"clearance joint {cj.name!r} bearing_profile has "
                             f"{len(cj.bearing_profile)} radii; the model was compiled for "
                             f"{points}")
        eq9 = cj.contact_stiffness is None
        p[off:off + HEAD] = (cj.journal_radius, 1.0 if eq9 else 0.0, cj.youngs_modulus,
                             cj.poisson_ratio, *fade(cj.bearing_profile, cj.journal_radius))
        p[off + HEAD:off + block_size(points)] = cj.profile.coefficients().ravel()
