"""The symbolic model of a `Linkage`'s structure, derived with sympy.physics.mechanics.

Every number of the description stays a symbol (a parameter of the vector p), so that one
derivation serves every linkage of the same structure (`Linkage.structure`). The kinematics
follow the forest of ideal joints from the ground (`Linkage.tree`); the equations of motion
come from Kane's method (`KanesMethod`, one `RigidBody` per body, gravity and the loads of
the joint kinds' elements as point forces and moments); the outputs (ground reactions by
Newton on the subtree below each ground joint, the drive moment as the generalized force of
the prescribed drive angle, the mechanical energy, the elements' loop-closure residuals)
from the same kinematics.

Trigonometry: every rotation is written with the sine and cosine of a *base angle* (an angle
coordinate, the drive angle speed t + initial_angle, a prismatic axis angle); after the
derivation they become symbols (S_k, C_k), computed once per evaluation by the kernels
(`_trig.sincos`), and products are reduced modulo S_k^2 + C_k^2 = 1.
"""

from __future__ import annotations

import keyword
import re
from dataclasses import dataclass, field
from types import SimpleNamespace

import sympy as sp
import sympy.physics.mechanics as me

from ..elements.registry import ELEMENTS
from ..model.linkage import GROUND, Linkage, Prismatic, Revolute

__all__ = ["Derivation", "derive", "parameter_layout", "identifier", "specialise"]


def identifier(name: str, taken: set[str]) -> str:
    """A Python identifier for a dotted name (unique among `taken`, which it joins): ASCII
    letters, digits and underscores only, whatever `name` holds, never a keyword."""
    base = re.sub(r"[^A-Za-z0-9_]", "_", name.replace(".", "__"))
    if not base or base[0].isdigit() or base in ("t", "y", "p") or keyword.iskeyword(base):
        base = "p_" + base
    ident, k = base, 1
    while ident in taken:
        ident, k = f"{base}_{k}", k + 1
    taken.add(ident)
    return ident


def parameter_layout(linkage: Linkage) -> tuple[str, ...]:
    """Dotted names of the entries of the kernels' parameter vector p, in order: bodies
    (mass, inertia, points), ground points, prismatic axis angles, then each element's
    (`elements.registry`, in its order: the revolute clearance joints' contact, friction and
    film fields, a translational clearance joint's contact fields and geometry), the drive,
    gravity, then the memory (mode, impact velocity) of each element's contacts."""
    names = []
    for b in linkage.bodies:
        names += [f"{b.name}.mass", f"{b.name}.inertia"]
        for pt in b.points:
            names += [f"{b.name}.{pt}.x", f"{b.name}.{pt}.y"]
    for pt in linkage.ground_points:
        names += [f"{GROUND}.{pt}.x", f"{GROUND}.{pt}.y"]
    names += [f"{j.name}.angle" for j in linkage.joints if isinstance(j, Prismatic)]
    for el in ELEMENTS:
        names += el.parameter_names(linkage)
    if linkage.drive is not None:       # a free linkage has no drive parameters
        names += ["drive.speed", "drive.initial_angle"]
    names += ["gravity"]
    for el in ELEMENTS:
        names += el.memory_names(linkage)
    return tuple(names)


@dataclass
class Derivation:
    """The symbolic model (expressions in t, Q, U, A, the parameter symbols and the elements'
    load symbols; the sines and cosines of the base angles as symbols S, C)."""

    parameters: tuple[str, ...]             # dotted names, p order
    psyms: dict[str, sp.Symbol]             # dotted name -> symbol
    coordinates: tuple[str, ...]
    t: sp.Symbol
    Q: list[sp.Symbol]
    U: list[sp.Symbol]
    A: list[sp.Symbol]
    #: base angles: (expression of the angle, S symbol, C symbol)
    angles: list[tuple[sp.Expr, sp.Symbol, sp.Symbol]]
    ground_joints: tuple[str, ...]
    #: per contact (`events`): its offsets and their rates (`Element.finish`)
    gaps: list[tuple[sp.Expr, sp.Expr, sp.Expr, sp.Expr]]
    mass_matrix: sp.Matrix
    forcing: sp.Matrix
    #: per ground joint: the force on the ground (x, y)
    reactions: list[tuple[sp.Expr, sp.Expr]]
    drive_moment: sp.Expr
    kinetic: sp.Expr
    potential: sp.Expr
    #: the loop closure's rates (the elements' `closure_rates`): d / dQ and d / dt at
    #: fixed Q
    closure_jacobian: sp.Matrix
    closure_rate: sp.Matrix
    monitor: str | None
    extra: dict = field(default_factory=dict)
    #: per element kind (`elements.registry`, in its order) the element's share
    #: (`Element.finish`): its contacts (the model's events, in the registry's order),
    #: their gaps (in `gaps`), its loop closure and load symbols
    parts: dict = field(default_factory=dict)

    @property
    def events(self) -> list[str]:
        """The contacts with a memory: every element's, in the registry's order."""
        return [c for part in self.parts.values() for c in part.contacts]

    @property
    def load_symbols(self) -> list:
        """The elements' load symbols (state-dependent, each a force or a moment)."""
        return [s for part in self.parts.values() for s in part.symbols]


def _rot(c, s, x, y):
    return c * x - s * y, s * x + c * y


def derive(linkage: Linkage) -> Derivation:
    """Derive the symbolic model of `linkage`'s structure (its numbers are not used)."""
    names = parameter_layout(linkage)
    taken: set[str] = {"t"}
    psyms = {n: sp.Symbol(identifier(n, taken), real=True) for n in names}
    coords = linkage.coordinates()
    n = len(coords)
    t = me.dynamicsymbols._t
    q = [me.dynamicsymbols(f"q{i}") for i in range(n)]
    u = [me.dynamicsymbols(f"u{i}") for i in range(n)]
    index = {c: i for i, c in enumerate(coords)}
    g = psyms["gravity"]

    # the drive angle: a plain symbol THETA in the positions (for the partial derivatives
    # of the drive moment), speed t + initial_angle wherever time enters (`timed`)
    # (a free linkage has neither: its equations are autonomous, its drive moment is 0)
    driven = linkage.drive is not None
    drive_angle = psyms["drive.speed"] * t + psyms["drive.initial_angle"] if driven else None
    THETA = sp.Symbol("THETA", real=True)

    def timed(expr):
        return expr.xreplace({THETA: drive_angle}) if driven else expr

    def point(body, pt):
        return psyms[f"{body}.{pt}.x"], psyms[f"{body}.{pt}.y"]

    # ---- kinematics along the forest: per body the angle, (cos, sin) of it, centre of mass
    angle = {GROUND: sp.S(0)}
    rot = {GROUND: (sp.S(1), sp.S(0))}
    pos = {GROUND: (sp.S(0), sp.S(0))}

    def world(body, xy):
        """World position of the body-frame point xy of `body`."""
        c, s = rot[body]
        dx, dy = _rot(c, s, *xy)
        return pos[body][0] + dx, pos[body][1] + dy

    local = point

    children: dict[str, list[str]] = {}
    for body, parent, joint in linkage.tree():
        if body == GROUND:
            continue
        children.setdefault(parent, []).append(body)
        if parent is None:                                  # floating root
            i = index[f"{body}.angle"]
            angle[body] = q[i]
            rot[body] = (sp.cos(q[i]), sp.sin(q[i]))
            pos[body] = (q[index[f"{body}.x"]], q[index[f"{body}.y"]])
            continue
        if isinstance(joint, Revolute):
            if driven and joint.name == linkage.drive.joint:
                angle[body] = THETA
                rot[body] = (sp.cos(THETA), sp.sin(THETA))
            else:
                i = index[f"{body}.angle"]
                angle[body] = q[i]
                rot[body] = (sp.cos(q[i]), sp.sin(q[i]))
            pp, pc = ((joint.point_a, joint.point_b) if joint.body_a == parent
                      else (joint.point_b, joint.point_a))
            px, py = world(parent, local(parent, pp))
            c, s = rot[body]
            dx, dy = _rot(c, s, *local(body, pc))
            pos[body] = (px - dx, py - dy)
        else:                                               # Prismatic
            s_q = q[index[f"{joint.name}.s"]]
            alpha = psyms[f"{joint.name}.angle"]
            angle[body] = angle[parent]
            rot[body] = rot[parent]
            c, s = rot[parent]
            ux, uy = _rot(c, s, sp.cos(alpha), sp.sin(alpha))    # the axis in the world
            if joint.body_a == parent:      # point_b = point_a + s axis
                ax, ay = world(parent, local(parent, joint.point_a))
                dx, dy = _rot(c, s, *local(body, joint.point_b))
                pos[body] = (ax + s_q * ux - dx, ay + s_q * uy - dy)
            else:                           # point_a = point_b - s axis
                bx, by = world(parent, local(parent, joint.point_b))
                dx, dy = _rot(c, s, *local(body, joint.point_a))
                pos[body] = (bx - s_q * ux - dx, by - s_q * uy - dy)

    def subtree(body):
        out, stack = [], [body]
        while stack:
            b = stack.pop()
            out.append(b)
            stack += children.get(b, [])
        return out

    # ---- sympy.physics.mechanics: frames, points, rigid bodies, loads
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)

    def mech_point(label, xy):
        xy = (timed(xy[0]), timed(xy[1]))
        P = me.Point(label)
        P.set_pos(O, xy[0] * N.x + xy[1] * N.y)
        P.set_vel(N, sp.diff(xy[0], t) * N.x + sp.diff(xy[1], t) * N.y)
        return P

    bodies, loads, com_point, frames = [], [], {}, {}
    mass = {b.name: psyms[f"{b.name}.mass"] for b in linkage.bodies}
    inertia = {b.name: psyms[f"{b.name}.inertia"] for b in linkage.bodies}
    for b in linkage.bodies:
        frame = me.ReferenceFrame(f"B_{len(bodies)}")
        frame.orient_axis(N, N.z, timed(angle[b.name]))
        P = mech_point(f"G_{len(bodies)}", pos[b.name])
        com_point[b.name] = P
        frames[b.name] = frame
        bodies.append(me.RigidBody(f"body_{len(bodies)}", P, frame, mass[b.name],
                                   (me.inertia(frame, 0, 0, inertia[b.name]), P)))
        loads.append((P, -mass[b.name] * g * N.y))
    contact_loads = []       # (body, world position of the point, fx, fy)
    torque_loads = []        # (body, moment about its centre)
    # the elements' loads (and their gaps, kept in their states)
    ctx = SimpleNamespace(psyms=psyms, world=world, local=local, rot=rot, angle=angle,
                          frames=frames, mech_point=mech_point, N=N, loads=loads,
                          contact_loads=contact_loads, torque_loads=torque_loads)
    states = {el.kind: el.add_loads(linkage, ctx) for el in ELEMENTS}
    kane = me.KanesMethod(N, q_ind=q, u_ind=u,
                          kd_eqs=[q[i].diff(t) - u[i] for i in range(n)])
    kane.kanes_equations(bodies, loads)
    mass_matrix = kane.mass_matrix
    forcing = kane.forcing

    # ---- plain symbols for q(t) and its derivatives
    Q = [sp.Symbol(f"Q{i}", real=True) for i in range(n)]
    U = [sp.Symbol(f"U{i}", real=True) for i in range(n)]
    A = [sp.Symbol(f"A{i}", real=True) for i in range(n)]
    plain = {}
    for i in range(n):
        plain[q[i].diff(t, 2)] = A[i]
        plain[u[i].diff(t)] = A[i]
    for i in range(n):
        plain[q[i].diff(t)] = U[i]
    for i in range(n):
        plain[q[i]] = Q[i]
        plain[u[i]] = U[i]

    def flat(expr):
        return me.msubs(expr, plain)

    # ---- base angles -> symbols
    base = [flat(drive_angle)] if driven else []
    for c in coords:
        if c.endswith(".angle"):
            base.append(Q[index[c]])
    for jt in linkage.joints:
        if isinstance(jt, Prismatic):
            base.append(psyms[f"{jt.name}.angle"])
    for el in ELEMENTS:
        base += el.base_angles(linkage, psyms)
    angles = [(a, sp.Symbol(f"S{k}", real=True), sp.Symbol(f"C{k}", real=True))
              for k, a in enumerate(base)]
    trig = {}
    for a, S, C in angles:
        trig[sp.sin(a)] = S
        trig[sp.cos(a)] = C
    ideal = [S**2 + C**2 - 1 for _, S, C in angles]
    gens = [g_ for _, S, C in angles for g_ in (S, C)]

    def finish(expr):
        """Plain symbols, trig symbols, reduced modulo S^2 + C^2 = 1."""
        e = flat(timed(expr)).xreplace(trig)
        bad = [f for f in e.atoms(sp.Function) if isinstance(f, (sp.sin, sp.cos))]
        if bad:
            raise AssertionError(f"trigonometric terms of no base angle: {bad}")
        e = sp.expand(e)
        if e.has(*[S for _, S, _ in angles]):
            e = _reduce_trig(e, ideal, gens)
        return e

    def dt(expr):
        return sp.diff(timed(expr), t)

    parts = {el.kind: el.finish(states[el.kind], finish, dt) for el in ELEMENTS}
    gaps = [gap for part in parts.values() for gap in part.gaps]

    # ---- outputs: Newton on the subtree below each ground joint
    acc = {}
    for b in linkage.bodies:
        x, y = pos[b.name]
        acc[b.name] = (dt(dt(x)), dt(dt(y)))
    ground_joints = linkage.ground_joints()
    ideal_by_name = {jt.name: jt for jt in linkage.joints}
    reactions = []
    for name in ground_joints:
        if name in ideal_by_name:
            jt = ideal_by_name[name]
            child = jt.body_b if jt.body_a == GROUND else jt.body_a
            sub = set(subtree(child))
            rx, ry = sp.S(0), sp.S(0)
            for b in sub:
                rx += mass[b] * acc[b][0]
                ry += mass[b] * acc[b][1] + mass[b] * g
            for body, _, fx, fy in contact_loads:
                if body in sub:
                    rx -= fx
                    ry -= fy
            reactions.append((finish(-rx), finish(-ry)))
        else:                                   # an element's joint to the ground
            reactions.append(next(r for r in (el.ground_reaction(states[el.kind], name, finish)
                                              for el in ELEMENTS) if r is not None))
    # the drive moment: the generalized force of the prescribed drive angle (Kane's form
    # of the paper's Eq. 8; with the other equations of motion it equals the moment balance
    # of the driven subtree about its pivot): sum over bodies of (m a + m g ey) . dr/dtheta
    # + J alpha dphi/dtheta, minus the contact forces' F . dr/dtheta
    moment = sp.S(0)
    for b in linkage.bodies:
        x, y = pos[b.name]
        dx, dy = sp.diff(x, THETA), sp.diff(y, THETA)
        dphi = sp.diff(angle[b.name], THETA)
        moment += (mass[b.name] * (acc[b.name][0] * dx + (acc[b.name][1] + g) * dy)
                   + inertia[b.name] * dt(dt(angle[b.name])) * dphi)
    for _, (x, y), fx, fy in contact_loads:
        moment -= fx * sp.diff(x, THETA) + fy * sp.diff(y, THETA)
    for body, tau in torque_loads:
        moment -= tau * sp.diff(angle[body], THETA)
    moment = timed(moment)
    kinetic = sp.S(0)
    potential = sp.S(0)
    for b in linkage.bodies:
        x, y = pos[b.name]
        kinetic += (mass[b.name] * (dt(x) ** 2 + dt(y) ** 2) + inertia[b.name]
                    * dt(angle[b.name]) ** 2) / 2
        potential += mass[b.name] * g * y
    # the gaps' rates are linear in U: d gap / dQ are their coefficients, d gap / dt at
    # fixed q the rest
    rates = sp.Matrix([v for part in parts.values() for v in part.closure_rates])
    jac = rates.jacobian(U)
    rate = rates.xreplace({Ui: 0 for Ui in U})
    return Derivation(
        parameters=names, psyms=psyms, coordinates=coords, t=t, Q=Q, U=U, A=A,
        angles=angles, ground_joints=ground_joints, gaps=gaps,
        mass_matrix=mass_matrix.applyfunc(finish), forcing=forcing.applyfunc(finish),
        reactions=reactions, drive_moment=finish(moment), kinetic=finish(kinetic),
        potential=finish(potential), closure_jacobian=jac, closure_rate=rate,
        monitor=linkage.monitor_joint, parts=parts)


def _reduce_trig(expr, ideal, gens):
    """`expr` (a polynomial in the S_k, C_k) reduced modulo S_k^2 + C_k^2 - 1: no S_k^2."""
    if not ideal:
        return expr
    num, den = sp.fraction(sp.together(expr)) if expr.is_Add is False and any(
        a.is_Pow and a.exp.is_negative for a in expr.atoms(sp.Pow)) else (expr, sp.S(1))
    try:
        _, rem = sp.reduced(num, ideal, *gens, order="lex")
    except sp.PolynomialError:
        return expr
    return rem / den


def specialise(d: Derivation, zeros) -> Derivation:
    """`d` with the parameters named in `zeros` (dotted names) set to zero in every
    expression: the model of the linkages whose those entries are exactly 0. A zero prismatic
    axis angle drops its sine and cosine (0 and 1). The parameter layout is `d`'s (the
    entries stay in p, unread); derivatives along them are lost (zero)."""
    zeros = tuple(zeros)
    unknown = [z for z in zeros if z not in d.psyms]
    if unknown:
        raise ValueError(f"specialise: unknown parameters {unknown}")
    subs = {d.psyms[z]: sp.S(0) for z in zeros}
    angles = []
    for a, S, C in d.angles:
        if a in subs:
            subs[S], subs[C] = sp.S(0), sp.S(1)
        else:
            angles.append((a, S, C))

    def sub(e):
        return e if e is None else sp.expand(sp.sympify(e).xreplace(subs))

    return Derivation(
        parameters=d.parameters, psyms=d.psyms, coordinates=d.coordinates, t=d.t, Q=d.Q,
        U=d.U, A=d.A, angles=[(sub(a), S, C) for a, S, C in angles],
        ground_joints=d.ground_joints,
        gaps=[tuple(sub(e) for e in g) for g in d.gaps],
        mass_matrix=d.mass_matrix.applyfunc(sub), forcing=d.forcing.applyfunc(sub),
        reactions=[tuple(sub(e) for e in r) for r in d.reactions],
        drive_moment=sub(d.drive_moment), kinetic=sub(d.kinetic), potential=sub(d.potential),
        closure_jacobian=d.closure_jacobian.applyfunc(sub),
        closure_rate=d.closure_rate.applyfunc(sub), monitor=d.monitor, extra=dict(d.extra),
        parts={el.kind: el.specialise(d.parts[el.kind], sub) for el in ELEMENTS
               if el.kind in d.parts})
