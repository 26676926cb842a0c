"""Ideal-joint reference models of the named linkages (four-bar, slider-crank), written by hand.

Every joint is ideal (clearance closed) and the crank turns at constant speed, so the
mechanism has no degree of freedom left: every output is an explicit function of time.

- Positions: the loop closure is solved analytically (intersection of two circles for the
  four-bar, of a circle and a line for the slider-crank); velocities and accelerations by
  differentiating the closure (a 2 x 2 linear solve at each instant, no numerical
  differentiation).
- Forces: Newton-Euler inverse dynamics, one 9 x 9 linear solve per instant for the joint
  reactions and the drive moment (3 moving bodies x 3 equations; unknowns: 2 per revolute
  joint, normal force and moment of the prismatic guide, the drive moment).

This module is the reference of the ideal-joint limit tests of the generated models: it uses
nothing of the generator (mbs_clearance.generate, linkage_model) and nothing of the reduced
model. `from_linkage` only reads the numbers of a description (points, masses, inertias,
drive) into the plain records below, treating clearance joints as pins.

Conventions (those of mbs_clearance.Linkage): SI units; a body's points are given in its
body frame, whose origin is the centre of mass; the body angle is the angle of that frame's
x axis; gravity acts along -y; the drive prescribes the crank's body angle
theta = speed t + initial_angle. Reactions are reported as the force ON THE GROUND; the
shaking force is their sum; the drive moment is the moment the drive applies to the crank
(positive counter-clockwise), so that its power is drive_moment * speed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Link", "FourBarLoop", "SliderCrankLoop", "ideal_outputs", "from_linkage",
           "grashof_type"]

Point = tuple[float, float]


@dataclass(frozen=True)
class Link:
    """A moving body of the loop: mass (kg), inertia about the centre of mass (kg m^2), and
    its two joint points in the body frame (m): `p` the one nearer the crank along the loop,
    `q` the other one."""

    mass: float
    inertia: float
    p: Point
    q: Point


@dataclass(frozen=True)
class FourBarLoop:
    """Ground pivot O2 - crank (p = O2, q = B) - coupler (p = B, q = C) - rocker (p = C,
    q = O4) - ground pivot O4. `joints` names the four joints in that order (O2, B, C, O4);
    `branch` = +1 puts C on the left of the line from B to O4, -1 on the right."""

    crank: Link
    coupler: Link
    rocker: Link
    ground_crank: Point
    ground_rocker: Point
    speed: float
    initial_angle: float = 0.0
    gravity: float = 9.81
    branch: int = 1
    joints: tuple[str, str, str, str] = ("O2", "B", "C", "O4")


@dataclass(frozen=True)
class SliderCrankLoop:
    """Ground pivot O2 - crank (p = O2, q = B) - coupler (p = B, q = C) - slider (p = C,
    q = guide point) on a prismatic guide through the ground point `guide_origin` along
    direction `guide_angle` (rad); the slider keeps the ground's orientation (angle 0).
    `joints` names the joints (O2, B, C, guide); `branch` = +1 takes the slider position
    further along the guide direction, -1 the nearer one."""

    crank: Link
    coupler: Link
    slider: Link
    ground_crank: Point
    guide_origin: Point
    guide_angle: float
    speed: float
    initial_angle: float = 0.0
    gravity: float = 9.81
    branch: int = 1
    joints: tuple[str, str, str, str] = ("O2", "B", "C", "guide")


# ---------------------------------------------------------------------------------------
# planar helpers, vectorised over time: vectors are (n, 2) arrays
# ---------------------------------------------------------------------------------------

def _rot(phi: np.ndarray, p: Point) -> np.ndarray:
    """R(phi) p for every phi."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([c * p[0] - s * p[1], s * p[0] + c * p[1]], axis=1)


def _perp(v: np.ndarray) -> np.ndarray:
    """k x v."""
    return np.stack([-v[:, 1], v[:, 0]], axis=1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z component of a x b."""
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def _solve2(c1: np.ndarray, c2: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve x1 c1 + x2 c2 = rhs (columns c1, c2) by Cramer's rule at every instant."""
    det = _cross(c1, c2)
    return _cross(rhs, c2) / det, _cross(c1, rhs) / det


def _body_about_point(phi, omega, alpha, point: Point, pos, vel, acc):
    """Centre-of-mass motion of a body whose body-frame point `point` moves with
    (pos, vel, acc): r = P - R p, v = vP - w k x R p, a = aP - alpha k x R p + w^2 R p."""
    rho = _rot(phi, point)
    r = pos - rho
    v = vel - omega[:, None] * _perp(rho)
    a = acc - alpha[:, None] * _perp(rho) + (omega ** 2)[:, None] * rho
    return r, v, a


def _point_of_body(phi, omega, alpha, r, v, a, point: Point):
    """Position, velocity, acceleration of body-frame point `point`."""
    rho = _rot(phi, point)
    return (r + rho, v + omega[:, None] * _perp(rho),
            a + alpha[:, None] * _perp(rho) - (omega ** 2)[:, None] * rho)


def _sub(p: Point, q: Point) -> Point:
    return (q[0] - p[0], q[1] - p[1])


# ---------------------------------------------------------------------------------------
# kinematics
# ---------------------------------------------------------------------------------------

def _crank(loop, t):
    n = t.size
    phi = loop.speed * t + loop.initial_angle
    omega = np.full(n, float(loop.speed))
    alpha = np.zeros(n)
    g = np.broadcast_to(np.asarray(loop.ground_crank, float), (n, 2))
    zero = np.zeros((n, 2))
    r, v, a = _body_about_point(phi, omega, alpha, loop.crank.p, g, zero, zero)
    return phi, omega, alpha, r, v, a


def _four_bar_kinematics(loop: FourBarLoop, t: np.ndarray):
    n = t.size
    crank = _crank(loop, t)
    B, vB, aB = _point_of_body(crank[0], crank[1], crank[2], *crank[3:], loop.crank.q)
    d3 = _sub(loop.coupler.p, loop.coupler.q)          # B -> C in the coupler frame
    d4 = _sub(loop.rocker.q, loop.rocker.p)            # O4 -> C in the rocker frame
    L3, L4 = np.hypot(*d3), np.hypot(*d4)
    O4 = np.broadcast_to(np.asarray(loop.ground_rocker, float), (n, 2))
    # C: intersection of the circle (B, L3) and the circle (O4, L4)
    d = O4 - B
    D = np.hypot(d[:, 0], d[:, 1])
    along = (L3 ** 2 - L4 ** 2 + D ** 2) / (2.0 * D)
    h2 = L3 ** 2 - along ** 2
    if np.any(h2 < 0.0):
        raise ValueError("four-bar does not assemble at some crank angle (the coupler and "
                         "rocker circles do not meet): not a crank-rocker")
    u = d / D[:, None]
    C = B + along[:, None] * u + (loop.branch * np.sqrt(h2))[:, None] * _perp(u)
    rho3, rho4 = C - B, C - O4
    phi3 = np.arctan2(rho3[:, 1], rho3[:, 0]) - np.arctan2(d3[1], d3[0])
    phi4 = np.arctan2(rho4[:, 1], rho4[:, 0]) - np.arctan2(d4[1], d4[0])
    # velocity closure: vB + w3 k x rho3 - w4 k x rho4 = 0
    w3, w4 = _solve2(_perp(rho3), -_perp(rho4), -vB)
    # acceleration closure: aB + a3 k x rho3 - w3^2 rho3 - a4 k x rho4 + w4^2 rho4 = 0
    rhs = -aB + (w3 ** 2)[:, None] * rho3 - (w4 ** 2)[:, None] * rho4
    al3, al4 = _solve2(_perp(rho3), -_perp(rho4), rhs)
    coupler = (phi3, w3, al3, *_body_about_point(phi3, w3, al3, loop.coupler.p, B, vB, aB))
    zero = np.zeros((n, 2))
    rocker = (phi4, w4, al4,
              *_body_about_point(phi4, w4, al4, loop.rocker.q, O4, zero, zero))
    return crank, coupler, rocker, (B, C, O4)


def _slider_crank_kinematics(loop: SliderCrankLoop, t: np.ndarray):
    n = t.size
    crank = _crank(loop, t)
    B, vB, aB = _point_of_body(crank[0], crank[1], crank[2], *crank[3:], loop.crank.q)
    d3 = _sub(loop.coupler.p, loop.coupler.q)
    L3 = np.hypot(*d3)
    u1 = np.array([np.cos(loop.guide_angle), np.sin(loop.guide_angle)])
    u = np.broadcast_to(u1, (n, 2))
    # the slider's pin C moves on the line C0 + s u (slider angle 0): C0 = guide origin +
    # (pin - guide point) of the slider frame
    pin_offset = np.array(_sub(loop.slider.q, loop.slider.p))
    C0 = np.asarray(loop.guide_origin, float) + pin_offset
    w = C0 - B
    uw = w @ u1
    disc = uw ** 2 - (np.einsum("ij,ij->i", w, w) - L3 ** 2)
    if np.any(disc < 0.0):
        raise ValueError("slider-crank does not assemble at some crank angle (coupler too "
                         "short for the crank and guide)")
    s = -uw + loop.branch * np.sqrt(disc)
    C = C0 + s[:, None] * u
    rho3 = C - B
    phi3 = np.arctan2(rho3[:, 1], rho3[:, 0]) - np.arctan2(d3[1], d3[0])
    # vB + w3 k x rho3 = sdot u ;  aB + a3 k x rho3 - w3^2 rho3 = sddot u
    w3, sd = _solve2(_perp(rho3), -u, -vB)
    al3, sdd = _solve2(_perp(rho3), -u, -aB + (w3 ** 2)[:, None] * rho3)
    coupler = (phi3, w3, al3, *_body_about_point(phi3, w3, al3, loop.coupler.p, B, vB, aB))
    zeros = np.zeros(n)
    vC, aC = sd[:, None] * u, sdd[:, None] * u
    # slider centre of mass: r4 = C - p (angle 0, p = the pin's body-frame position)
    slider = (zeros, zeros, zeros, C - np.asarray(loop.slider.p, float)[None, :], vC, aC)
    return crank, coupler, slider, (B, C, u, s, sd, sdd)


# ---------------------------------------------------------------------------------------
# Newton-Euler inverse dynamics
# ---------------------------------------------------------------------------------------

def _inverse_dynamics(links, bodies, joint_points, prismatic_normal, gravity):
    """Solve the 9 x 9 Newton-Euler system at every instant.

    Bodies 0, 1, 2 = crank, coupler, third body (rocker or slider). Unknowns, in order:
    F0 (2, ground on crank at O2), F1 (2, crank on coupler at B), F2 (2, coupler on body 2
    at C), then either F3 (2, ground on rocker at O4) or (N, Mp) of the guide (ground on
    slider: force N n, moment Mp), then the drive moment M (ground on crank).
    """
    n = bodies[0][0].size
    A = np.zeros((n, 9, 9))
    b = np.zeros((n, 9))
    g_vec = np.array([0.0, -gravity])

    def add_force(body, col, P, sign):
        r = bodies[body][3]
        arm = P - r
        rows = slice(3 * body, 3 * body + 2)
        A[:, rows.start, col] += sign
        A[:, rows.start + 1, col + 1] += sign
        # moment of (Fx, Fy) about the centre: arm_x Fy - arm_y Fx
        A[:, 3 * body + 2, col] += -sign * arm[:, 1]
        A[:, 3 * body + 2, col + 1] += sign * arm[:, 0]

    O2, B, C, O4 = joint_points
    add_force(0, 0, O2, +1.0)                      # ground -> crank at O2
    add_force(0, 2, B, -1.0)                       # coupler -> crank at B (reaction)
    add_force(1, 2, B, +1.0)                       # crank -> coupler at B
    add_force(1, 4, C, -1.0)
    add_force(2, 4, C, +1.0)                       # coupler -> body 2 at C
    if prismatic_normal is None:
        add_force(2, 6, O4, +1.0)                  # ground -> rocker at O4
    else:
        nrm = prismatic_normal
        A[:, 6, 6] += nrm[:, 0]
        A[:, 7, 6] += nrm[:, 1]
        # the guide's action on the slider: force N n through its centre of mass plus the
        # moment Mp (any other line of action only shifts Mp)
        A[:, 8, 7] += 1.0
    A[:, 2, 8] += 1.0                              # drive moment on the crank
    for i, (_phi, _omega, alpha, _r, _v, a) in enumerate(bodies):
        m, J = links[i].mass, links[i].inertia
        b[:, 3 * i: 3 * i + 2] = m * (a - g_vec)
        b[:, 3 * i + 2] = J * alpha
    return np.linalg.solve(A, b[..., None])[..., 0]


def ideal_outputs(loop: FourBarLoop | SliderCrankLoop, t) -> dict:
    """All outputs of the ideal linkage at times `t` (s).

    Keys: "angles" (n, 3) body angles (crank, coupler, third body; the slider's is 0),
    "rates", "accelerations" (n, 3); "centres", "velocities", "acc_centres" (n, 3, 2);
    "joint_force": {joint name: (n, 2)} the force on the body further along the loop from
    the one before it (ground -> crank, crank -> coupler, coupler -> third body, ground ->
    third body); "ground_reactions": {ground joint name: (n, 2) force on the ground};
    "guide_moment" (slider-crank: moment of the slider on the guide about the slider's
    centre of mass, N m);
    "shaking" (n, 2); "drive_moment" (n,) N m; "kinetic", "potential" (n,) J;
    "power" (n,) W of the drive; for the slider-crank also "slider_position" (n,) (s along
    the guide of the pin) and its rate and acceleration.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    four_bar = isinstance(loop, FourBarLoop)
    if four_bar:
        crank, coupler, third, pts = _four_bar_kinematics(loop, t)
        links = (loop.crank, loop.coupler, loop.rocker)
        joint_points = (None,) + tuple(pts)
        normal = None
    else:
        crank, coupler, third, extra = _slider_crank_kinematics(loop, t)
        links = (loop.crank, loop.coupler, loop.slider)
        B, C, u, s, sd, sdd = extra
        joint_points = (None, B, C, None)
        normal = _perp(u)
    n = t.size
    O2 = np.broadcast_to(np.asarray(loop.ground_crank, float), (n, 2))
    joint_points = (O2,) + tuple(joint_points[1:])
    bodies = (crank, coupler, third)
    x = _inverse_dynamics(links, bodies, joint_points, normal, loop.gravity)
    names = loop.joints
    forces = {names[0]: x[:, 0:2], names[1]: x[:, 2:4], names[2]: x[:, 4:6]}
    if four_bar:
        forces[names[3]] = x[:, 6:8]
        ground = {names[0]: -x[:, 0:2], names[3]: -x[:, 6:8]}
        guide_moment = None
    else:
        forces[names[3]] = x[:, 6:7] * normal
        ground = {names[0]: -x[:, 0:2], names[3]: -x[:, 6:7] * normal}
        guide_moment = -x[:, 7]
    shaking = ground[names[0]] + ground[names[3]]
    kinetic = sum(0.5 * lk.mass * np.einsum("ij,ij->i", bd[4], bd[4])
                  + 0.5 * lk.inertia * bd[1] ** 2 for lk, bd in zip(links, bodies))
    potential = sum(lk.mass * loop.gravity * bd[3][:, 1] for lk, bd in zip(links, bodies))
    out = dict(
        t=t,
        angles=np.stack([bd[0] for bd in bodies], axis=1),
        rates=np.stack([bd[1] for bd in bodies], axis=1),
        accelerations=np.stack([bd[2] for bd in bodies], axis=1),
        centres=np.stack([bd[3] for bd in bodies], axis=1),
        velocities=np.stack([bd[4] for bd in bodies], axis=1),
        acc_centres=np.stack([bd[5] for bd in bodies], axis=1),
        joint_force=forces, ground_reactions=ground, shaking=shaking,
        drive_moment=x[:, 8], kinetic=kinetic, potential=potential,
        power=x[:, 8] * loop.speed,
        masses=np.array([lk.mass for lk in links]),
    )
    if guide_moment is not None:
        out.update(guide_moment=guide_moment, slider_position=s, slider_rate=sd,
                   slider_acceleration=sdd)
    return out


def grashof_type(lengths: dict[str, float]) -> str:
    """Grashof class of a four-bar from its link lengths {ground, crank, coupler, rocker}
    (m): "crank-rocker" when s + l <= p + q and the crank (input) is the shortest link."""
    s_l = min(lengths.values()) + max(lengths.values())
    p_q = sum(lengths.values()) - s_l
    if s_l > p_q:
        return "non-Grashof (triple rocker)"
    shortest = min(lengths, key=lengths.get)
    return {"crank": "crank-rocker", "ground": "double-crank",
            "coupler": "double-rocker", "rocker": "rocker-crank"}[shortest]


# ---------------------------------------------------------------------------------------
# reading a description
# ---------------------------------------------------------------------------------------

def _pin_points(linkage):
    """Every pin-like joint (ideal revolute or clearance joint) as (name, body_a, point_a
    position, body_b, point_b position), points in their body frames (ground points in the
    world)."""
    bodies = {b.name: b for b in linkage.bodies}

    def where(body, point):
        if body == "ground":
            return tuple(map(float, linkage.ground_points[point]))
        return tuple(map(float, bodies[body].points[point]))

    pins = []
    for j in linkage.joints:
        if type(j).__name__ == "Revolute":
            pins.append((j.name, j.body_a, where(j.body_a, j.point_a),
                         j.body_b, where(j.body_b, j.point_b)))
    for j in linkage.clearance_joints:
        pins.append((j.name, j.journal_body, where(j.journal_body, j.journal_point),
                     j.bearing_body, where(j.bearing_body, j.bearing_point)))
    return pins, bodies, where


def from_linkage(linkage) -> FourBarLoop | SliderCrankLoop:
    """The ideal loop of a four-bar or slider-crank description (any of its joints may be a
    clearance joint: in the ideal limit it is a pin at the bearing's point).

    Reads only numbers of the description (points, masses, inertias, drive, gravity); the
    loop is found by walking from the driven joint. Raises ValueError for other topologies.
    """
    pins, bodies, where = _pin_points(linkage)
    drive = next(p for p in pins if p[0] == linkage.drive.joint)
    crank = drive[3] if drive[1] == "ground" else drive[1]

    def side(pin, body):
        """(this body's point, other body, other body's point) of a pin touching `body`."""
        if pin[1] == body:
            return pin[2], pin[3], pin[4]
        return pin[4], pin[1], pin[2]

    def pins_of(body, exclude):
        return [p for p in pins if body in (p[1], p[3]) and p[0] not in exclude]

    o2_crank, _, o2_ground = side(drive, crank)
    nxt = pins_of(crank, {drive[0]})
    if len(nxt) != 1:
        raise ValueError("from_linkage: the crank must have exactly one joint besides the drive")
    pin_b = nxt[0]
    b_crank, coupler, b_coupler = side(pin_b, crank)
    nxt = pins_of(coupler, {pin_b[0]})
    if len(nxt) != 1:
        raise ValueError("from_linkage: the coupler must have exactly two joints")
    pin_c = nxt[0]
    c_coupler, third, c_third = side(pin_c, coupler)

    def link(name, p, q):
        return Link(float(bodies[name].mass), float(bodies[name].inertia), p, q)

    common = dict(speed=float(linkage.drive.speed),
                  initial_angle=float(linkage.drive.initial_angle),
                  gravity=float(linkage.gravity))
    ground_pins = pins_of(third, {pin_c[0]})
    if ground_pins:
        pin_d = ground_pins[0]
        d_third, other, d_ground = side(pin_d, third)
        if other != "ground":
            raise ValueError("from_linkage: the rocker's second joint must be to the ground")
        loop = FourBarLoop(
            crank=link(crank, o2_crank, b_crank), coupler=link(coupler, b_coupler, c_coupler),
            rocker=link(third, c_third, d_third), ground_crank=o2_ground,
            ground_rocker=d_ground, joints=(drive[0], pin_b[0], pin_c[0], pin_d[0]),
            **common)
        return _pick_branch(loop, linkage, (crank, coupler, third))
    guide = [j for j in linkage.joints if type(j).__name__ == "Prismatic"
             and third in (j.body_a, j.body_b)]
    if len(guide) != 1 or guide[0].body_a != "ground":
        raise ValueError("from_linkage: neither a four-bar nor a slider-crank on a ground guide")
    g = guide[0]
    loop = SliderCrankLoop(
        crank=link(crank, o2_crank, b_crank), coupler=link(coupler, b_coupler, c_coupler),
        slider=link(third, c_third, where(third, g.point_b)), ground_crank=o2_ground,
        guide_origin=where("ground", g.point_a), guide_angle=float(g.angle),
        joints=(drive[0], pin_b[0], pin_c[0], g.name), **common)
    return _pick_branch(loop, linkage, (crank, coupler, third))


def _pick_branch(loop, linkage, names):
    """The assembly branch nearest the description's assembly guesses ("<body>.angle": the
    body's absolute angle, "<joint>.s": the slider coordinate); default +1."""
    from dataclasses import replace

    guesses = dict(getattr(linkage, "assembly", {}) or {})
    best, best_err = loop, np.inf
    for branch in (1, -1):
        cand = replace(loop, branch=branch)
        try:
            o = ideal_outputs(cand, np.array([0.0]))
        except ValueError:
            continue
        err = 0.0
        for key, value in guesses.items():
            body, _, coord = key.rpartition(".")
            if coord == "s" and "slider_position" in o:
                err += abs(o["slider_position"][0] - value)
            elif coord == "angle" and body in names:
                err += abs(np.angle(np.exp(1j * (o["angles"][0, names.index(body)] - value))))
        if err < best_err:
            best, best_err = cand, err
    return best
