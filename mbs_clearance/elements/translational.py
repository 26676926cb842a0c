"""The translational clearance joint (`model.linkage.TranslationalClearance`, Flores et al.
2008) as an element: a rectangular slider in a guide of width 2 (b + c), its four corners
(`CORNERS`) each its own contact with the surface on its side.

What it brings:

- gap function: per corner the position along the guide's axis and the normal offset of
  the corner from the guide's mid-line (and their rates); penetration = side * offset -
  (b + c); the loop closure beside the clearance joints' gaps: the slider centre's normal
  offset and half_length times the sine of its tilt;
- loads: per corner the normal force FN along the guide's normal and the friction FT along
  its axis on the slider at the corner, the opposite force on the guide moved to the guide
  point with its moment; the guide's reaction when the guide is the ground;
- C printer: the corner stages of core/runtime.h (``corner_stage``,
  ``corner_friction_stage``, ``corner_state``), the corners' output columns;
- Jacobian rows and tangent terms: per corner the rates of its two offsets and its normal
  force (rows after the clearance joints'), the stages ``corner_jacobian`` /
  ``corner_tangent`` and ``corner_friction_jacobian`` / ``corner_friction_tangent`` of
  core/jac_runtime.h;
- energy: each corner's Hertzian contact potential K delta^2.5 / 2.5;
- Exudyn element: an ``ObjectGenericODE2`` on the slider's node (and the guide's) whose
  Python force function returns the corners' generalized forces (`corner_loads`), each
  corner with its own impact-velocity memory; the corners' series and the guide's reaction
  computed after the run from the stored body states (`corner_series`).
"""

from __future__ import annotations

import math

import numpy as np

from ..laws._dispatch import friction_force_slots
from ..laws.forces import CONTACT_MODELS, FRICTION_LAWS, contact_force
from ..laws.registry import FRICTION_SLOTS
from ..model.linkage import CORNERS, GROUND, TranslationalClearance
from .base import CONTACT_FIELDS, Element, friction_arguments

__all__ = ["ELEMENT", "TRANSLATIONAL_FIELDS", "corner_loads"]

#: per translational clearance joint, the entries of p read by its corners' contacts
#: (the contact fields first, as a clearance joint's) and its geometry
TRANSLATIONAL_FIELDS = (*CONTACT_FIELDS, "half_length", "half_height", "angle",
                        "slider_angle")

#: per corner, the columns of its friction (joints with a friction law)
_FRICTION_COLUMNS = ("friction_force", "slip_velocity", "friction_power")


def _rot(c, s, x, y):
    return c * x - s * y, s * x + c * y


class Translational(Element):
    """The translational clearance joint: a slider with four corner contacts in a guide."""

    kind = "translational"
    description = TranslationalClearance
    attribute = "translational_joints"

    # ---- description
    def contact_names(self, linkage) -> list[str]:
        """The corners of every joint ("<joint>.<corner>", `CORNERS` order)."""
        return [c for j in self.joints(linkage) for c in j.corner_names()]

    # ---- gap function and loads (generate.derive)
    def parameter_names(self, linkage) -> list[str]:
        """Per joint its contact fields and geometry (`TRANSLATIONAL_FIELDS`), then with
        friction the law's id and slots."""
        names = []
        for j in self.joints(linkage):
            names += [f"{j.name}.{f}" for f in TRANSLATIONAL_FIELDS]
            if j.has_friction:
                names += [f"{j.name}.{f}" for f in ("friction_law", *FRICTION_SLOTS)]
        return names

    def memory_names(self, linkage) -> list[str]:
        """Per corner its contact mode and impact velocity (the compiled model's memory)."""
        return [f"{c}.{f}" for c in self.contact_names(linkage)
                for f in ("mode", "impact_velocity")]

    def base_angles(self, linkage, psyms) -> list:
        """The guide's and the slider's axis angles (parameters) of every joint."""
        return [psyms[f"{j.name}.{f}"] for j in self.joints(linkage)
                for f in ("angle", "slider_angle")]

    def add_loads(self, linkage, ctx):
        """Each corner's normal force FN (along the guide's normal n) and friction FT
        (along its axis u) act on the slider at the corner; on the guide the opposite force
        acts at the same place: moved to the guide point, with its moment about it (a load
        at the corner's expression would move with the slider). `ctx`: the derivation's
        kinematics (psyms, world, local, rot, frames, mech_point) and its load lists
        (loads, contact_loads, torque_loads), appended to. Returns the state `finish`
        reads."""
        # the generator's only: a run imports no sympy
        import sympy as sp

        psyms, world, local, rot = ctx.psyms, ctx.world, ctx.local, ctx.rot
        corners, gaps_t, closure_t, guide_forces = [], [], [], {}
        for tj in self.joints(linkage):
            gx, gy = world(tj.guide_body, local(tj.guide_body, tj.guide_point))
            sx, sy = world(tj.slider_body, local(tj.slider_body, tj.slider_point))
            alpha = psyms[f"{tj.name}.angle"]
            beta = psyms[f"{tj.name}.slider_angle"]
            ux, uy = _rot(*rot[tj.guide_body], sp.cos(alpha), sp.sin(alpha))
            nx, ny = -uy, ux
            ax, ay = _rot(*rot[tj.slider_body], sp.cos(beta), sp.sin(beta))
            a, b = psyms[f"{tj.name}.half_length"], psyms[f"{tj.name}.half_height"]
            closure_t.append((nx * (sx - gx) + ny * (sy - gy), a * (nx * ax + ny * ay)))
            for cname, (sa, sb) in zip(tj.corner_names(), CORNERS.values()):
                k = len(corners)
                FN = sp.Symbol(f"FN{k}", real=True)
                FT = sp.Symbol(f"FT{k}", real=True) if tj.has_friction else None
                corners.append((cname, tj.name, sb, FN, FT))
                cx = sx + sa * a * ax - sb * b * ay
                cy = sy + sa * a * ay + sb * b * ax
                rx, ry = cx - gx, cy - gy
                gaps_t.append((ux * rx + uy * ry, nx * rx + ny * ry))
                fx, fy = FN * nx, FN * ny
                if FT is not None:
                    fx, fy = fx + FT * ux, fy + FT * uy
                ctx.contact_loads.append((tj.slider_body, (cx, cy), fx, fy))
                ctx.contact_loads.append((tj.guide_body, (gx, gy), -fx, -fy))
                guide_forces.setdefault(tj.name, []).append((-fx, -fy))
                tau = -(rx * fy - ry * fx)
                ctx.torque_loads.append((tj.guide_body, tau))
                if tj.slider_body != GROUND:
                    ctx.loads.append((ctx.mech_point(f"K_{k}_{tj.slider_body}", (cx, cy)),
                                      fx * ctx.N.x + fy * ctx.N.y))
                if tj.guide_body != GROUND:
                    ctx.loads.append((ctx.mech_point(f"KG_{k}_{tj.guide_body}", (gx, gy)),
                                      -fx * ctx.N.x - fy * ctx.N.y))
                    ctx.loads.append((ctx.frames[tj.guide_body], tau * ctx.N.z))
        return self.part(corners=corners, gaps_t=gaps_t, closure_t=closure_t,
                         guide_forces=guide_forces)

    def ground_reaction(self, state, name: str, finish):
        """The force on the ground of a joint whose guide is the ground (the sum of its
        corners' forces on the guide), or None when `name` is no such joint."""
        forces = state.guide_forces.get(name)
        if forces is None:
            return None
        return (finish(sum(f[0] for f in forces)), finish(sum(f[1] for f in forces)))

    def finish(self, state, finish, dt):
        """The element's share of the `Derivation`: per corner (name, joint, side, FN, FT)
        (``corners``), its gap (along, offset and their rates, ``gaps``), the loop closure
        (``closure``: per joint the slider centre's normal offset and half_length times the
        sine of its tilt) and its rates (``closure_rates``), the load symbols
        (``symbols``), the contacts' names (``contacts``)."""
        gaps = [tuple(finish(v) for v in (s, h, dt(s), dt(h))) for s, h in state.gaps_t]
        return self.part(
            corners=state.corners, contacts=[c[0] for c in state.corners], gaps=gaps,
            closure=[tuple(finish(v) for v in pair) for pair in state.closure_t],
            closure_rates=[finish(dt(v)) for pair in state.closure_t for v in pair],
            symbols=[s for c in state.corners for s in c[3:] if s is not None])

    def specialise(self, part, sub):
        """`part` with `sub` applied to its expressions."""
        return self.part(
            corners=part.corners, contacts=part.contacts,
            gaps=[tuple(sub(e) for e in g) for g in part.gaps],
            closure=[tuple(sub(e) for e in c) for c in part.closure],
            closure_rates=[sub(e) for e in part.closure_rates], symbols=part.symbols)

    # ---- C printer (generate.writer, generate.cwriter)
    def plan(self, part, params: list, mem_start: int, first: int):
        """The corners' stages of the model evaluation (`first`: the event index of the
        first corner): per corner its normal offset (ey) and rate against the surface on
        its side, the sliding velocity along the axis (exd) for the friction law. Returns
        (``lines`` of the contact stage, ``indices`` per corner: its p indices, event and
        side; ``friction``: the corners with a law; ``results``: their output values;
        ``floors``: (event, p index of its impact-velocity floor); ``gap_extras`` and
        ``lubricated``: none, computed beside the gaps or in oil))."""
        lines, indices, friction, results = [], [], [], []
        for k, (_, tname, side, FN, FT) in enumerate(part.corners):
            e = first + k
            c = {f: params.index(f"{tname}.{f}") for f in
                 ("clearance", "stiffness", "restitution", "contact_model",
                  "impact_velocity_floor", "half_height")}
            c.update(event=e, side=repr(float(side)))
            indices.append(c)
            law = (f"p[{c['clearance']}], p[{c['half_height']}], p[{mem_start + 2 * e}], "
                   f"p[{mem_start + 2 * e + 1}], p[{c['stiffness']}], "
                   f"p[{c['restitution']}], p[{c['contact_model']}]")
            if FT is None:
                lines.append(f"F{e}, d{e}, dd{e}, {FN} = corner_stage(ey{e}, eyd{e}, "
                             f"{c['side']}, {law})")
            else:
                friction.append(k)
                fl = params.index(f"{tname}.friction_law")
                lines.append(
                    f"F{e}, d{e}, dd{e}, {FN}, {FT} = corner_friction_stage(ey{e}, eyd{e}, "
                    f"exd{e}, {c['side']}, {law}, p[{fl}], ("
                    + friction_arguments([f"p[{params.index(f'{tname}.{f}')}]"
                                          for f in FRICTION_SLOTS]) + "))")
        for k in friction:
            ft = part.corners[k][4]
            results += [str(ft), f"exd{first + k}", f"-{ft} * exd{first + k}"]
        return self.part(lines=lines, indices=indices, friction=friction, results=results,
                         floors=[(c["event"], c["impact_velocity_floor"]) for c in indices],
                         gap_extras=[], lubricated=[])

    def out_columns(self, part, plan) -> list[str]:
        """The friction columns of the corners with a law (after the clearance joints')."""
        return [f"{part.corners[k][0]}.{f}" for k in plan.friction for f in _FRICTION_COLUMNS]

    def friction_contacts(self, part, plan) -> list[str]:
        """The corners with a friction law (their friction power enters the work)."""
        return [part.corners[k][0] for k in plan.friction]

    def profiled_stages(self, part, plan, profiles: dict, gaps_stage, block_size) -> dict:
        """None: a guide has no bearing profile (`profiles` holds no corner)."""
        return {}

    def penetration_lines(self, plan) -> list[str]:
        """The C lines of `penetration` for the corners: (delta, deltadot) of the corner
        against the surface on its side (core/runtime.h's ``corner_state``)."""
        return [f"    if (j == {ci['event']}) {{ gap_{ci['event']}(t, y, p, g); corner_state("
                f"g[1], g[3], {ci['side']}, p[{ci['clearance']}], p[{ci['half_height']}], "
                "&dd[0], &dd[1]); return; }" for ci in plan.indices]

    def closure(self, part) -> list:
        """The loop-closure expressions after the clearance joints' gaps."""
        return [e for pair in part.closure for e in pair]

    # ---- Jacobian rows and tangent terms (generate.jacobians)
    def jacobian_rows(self, part, first: int, start: int) -> dict:
        """{(what, event): row} of the corners' extra rows from row `start`: the rates of
        the two offsets and the normal force of each corner."""
        return {(what, first + k): start + 3 * k + m for k in range(len(part.corners))
                for m, what in enumerate(("exd", "eyd", "fn"))}

    def jacobian_lines(self, part, first: int, ctx) -> tuple[list[str], list[str]]:
        """(the `jacobian` lines, the `tangent` lines) of the corners' forces: the contact
        law's (``corner_jacobian``) and the friction law's rows (core/jac_runtime.h).
        `ctx`: the plan's row (output rows), extra (extra rows), pcol (z columns of p),
        n (N_Q), stride, nz."""
        row, extra, pcol, n = ctx.row, ctx.extra, ctx.pcol, ctx.n
        stride, nz = ctx.stride, ctx.nz
        jlines, tlines = [], []
        for k, (cname, tname, side, FN, FT) in enumerate(part.corners):
            e = first + k
            rows = [row[f"{cname}.{f}"] for f in ("contact_force", "penetration",
                                                  "penetration_rate", "ecc_x", "ecc_y")]
            rows += [extra[(what, e)] for what in ("exd", "eyd", "fn")]
            zc = [pcol[f"{tname}.{f}"] for f in ("clearance", "half_height", "stiffness",
                                                 "restitution")]
            zc += [pcol[f"{cname}.impact_velocity"]]
            pv = [repr(float(side))] + [f"p[{pcol[nm] - 1 - 2 * n}]" for nm in (
                f"{tname}.clearance", f"{tname}.half_height", f"{cname}.mode",
                f"{cname}.impact_velocity", f"{tname}.stiffness", f"{tname}.restitution",
                f"{tname}.contact_model")]
            args = (f"gv{e}_0, gv{e}_1, gv{e}_2, gv{e}_3, "
                    + ", ".join(str(v) for v in rows + zc + pv) + ")")
            jlines.append(f"{FN} = corner_jacobian(jac, {stride}, {nz}, " + args)
            tlines.append(f"{FN} = corner_tangent(out, ts, nd, dz, {nz}, " + args)
            if FT is not None:
                frows = [extra[("exd", e)], row[f"{cname}.contact_force"]] + [
                    row[f"{cname}.{f}"] for f in _FRICTION_COLUMNS]
                fc = friction_arguments([f"{pcol[f'{tname}.{f}']}" for f in FRICTION_SLOTS])
                fv = friction_arguments([f"p[{pcol[f'{tname}.{f}'] - 1 - 2 * n}]"
                                         for f in FRICTION_SLOTS])
                law = f"p[{pcol[f'{tname}.friction_law'] - 1 - 2 * n}]"
                args = ", ".join(str(v) for v in frows) + f", ({fc}), {law}, ({fv}))"
                jlines.append(f"{FT} = corner_friction_jacobian(jac, {stride}, {nz}, " + args)
                tlines.append(f"{FT} = corner_friction_tangent(out, ts, nd, dz, {nz}, "
                              + args)
        return jlines, tlines

    def force_loads(self, part, first: int, row: dict, extra: dict) -> list[tuple]:
        """The corners' force symbols in the equations of motion: (symbol, its row,
        coefficient name stem, event)."""
        out = []
        for k, (cname, _, _, FN, FT) in enumerate(part.corners):
            out.append((FN, extra[("fn", first + k)], "rfn", first + k))
            if FT is not None:
                out.append((FT, row[f"{cname}.friction_force"], "rft", first + k))
        return out

    def output_loads(self, part, first: int, row: dict, extra: dict) -> list[tuple]:
        """Per corner (event, [(stem, force symbol, its row)]) for the outputs' chain rule
        through the corners' forces."""
        out = []
        for k, (cname, _, _, FN, FT) in enumerate(part.corners):
            lds = [("fn", FN, extra[("fn", first + k)])]
            if FT is not None:
                lds.append(("ft", FT, row[f"{cname}.friction_force"]))
            out.append((first + k, lds))
        return out

    # ---- the reduced model's parameters and sensitivities (solve.linkage_model,
    # solve.linkage_ddm)
    def parameter_values(self, linkage) -> dict[str, float]:
        """The values of the kind's entries of p (`parameter_names`, `memory_names`): the
        joints' fields, the laws' ids, each corner's memory started free at the floor."""
        values = {}
        for j in self.joints(linkage):
            values[f"{j.name}.stiffness"] = j.stiffness
            values[f"{j.name}.contact_model"] = float(CONTACT_MODELS[j.contact_model])
            values[f"{j.name}.friction_law"] = float(FRICTION_LAWS[j.friction_law])
            for f in ("clearance", "restitution", "impact_velocity_floor", "half_length",
                      "half_height", "angle", "slider_angle", *FRICTION_SLOTS):
                values[f"{j.name}.{f}"] = getattr(j, f)
            for c in j.corner_names():
                values[f"{c}.mode"] = 0.0
                values[f"{c}.impact_velocity"] = j.impact_velocity_floor
        return values

    def floor_names(self, linkage) -> list[str]:
        """Per contact the name of its impact-velocity floor (a corner's is its joint's)."""
        return [f"{j.name}.impact_velocity_floor" for j in self.joints(linkage)
                for _ in j.corner_names()]

    def chain(self, linkage, head: str, field: str) -> dict[str, float]:
        """{entry of p: d entry / d value} of the description's value `field` of joint
        `head` when it reaches p under another name (empty otherwise): a joint's
        contact_stiffness is its stiffness (no Eq. 9 from radii)."""
        if field == "contact_stiffness" and head in {j.name for j in self.joints(linkage)}:
            return {f"{head}.stiffness": 1.0}
        return {}

    def closure_rows(self, linkage, out, extra) -> tuple[list[dict], list[dict]]:
        """The loop closure of the joints at the start as rows of the model's Jacobian
        ({row: weight}: `out`(column name) an output row, `extra`[name] an extra row), and
        their rates: the slider's offset and tilt, the mean of its corners' normal offsets
        and of their signed ones (`CORNERS`)."""
        pos, rate = [], []
        for tj in self.joints(linkage):
            for signed in (False, True):
                pos.append({out(f"{c}.ecc_y"): 0.25 * (CORNERS[c.rpartition(".")[2]][0]
                                                        if signed else 1.0)
                            for c in tj.corner_names()})
                rate.append({extra[f"eyd:{c}"]: 0.25 * (CORNERS[c.rpartition(".")[2]][0]
                                                         if signed else 1.0)
                             for c in tj.corner_names()})
        return pos, rate

    def sensitivity_check(self, linkage) -> None:
        """None: the corners' contact and friction laws have their partial derivatives."""

    def fd_scale(self, linkage, head: str, field: str) -> None:
        """None: a joint's values step by their own size."""
        return None

    def trajectory_series(self, linkage, ecc, ctx) -> dict:
        """None beside the outputs: the corners' series are output columns."""
        return {}

    # ---- the ideal-joint backend (backends.ideal_linkage)
    def ideal_joints(self, linkage, angles: dict) -> list[tuple]:
        """Each joint closed as an ideal prismatic joint: ("slide", (name, guide body, guide
        point, axis angle in rad, slider body, slider point, the bodies' angle difference to
        keep in rad)) from the bodies' assembled `angles`."""
        return [("slide", (tj.name, tj.guide_body, tj.guide_point, tj.angle, tj.slider_body,
                           tj.slider_point,
                           angles.get(tj.slider_body, 0.0) - angles.get(tj.guide_body, 0.0)))
                for tj in self.joints(linkage)]

    def ideal_contact_forces(self, linkage, multipliers) -> list:
        """The corners' normal forces (N, (s,) each, `CORNERS` order per joint) of the
        ideal joints whose multipliers are lambda (offset) and mu (angle)
        (`multipliers`(name) -> (s, 2)): the slider receives -lambda along the guide's
        normal at its centre and the moment -mu, so its end e (+-1, at e a along the axis)
        is pushed by F_e = -(lambda + e mu / a) / 2 along the normal, by the corner on the
        side opposite to F_e's direction; the other corner carries nothing."""
        out = []
        for tj in self.joints(linkage):
            lam = multipliers(tj.name)
            lam_n, mu = lam[:, 0], lam[:, 1]
            for along, side in CORNERS.values():
                push = -0.5 * (lam_n + along * mu / tj.half_length)
                out.append(np.where(np.sign(push) == -side, np.abs(push), 0.0))
        return out

    # ---- energy (generate.energy)
    def contact_energy(self, part, params: list, first: int, offsets: tuple):
        """A function (a, p, mem_start) -> the corners' contact potential in J, where `a`
        are the arguments of the derivation's numeric functions and `offsets` the numeric
        offsets of the contacts (x, y lists; a corner's y is its normal offset): K
        delta^2.5 / 2.5 of each corner in contact."""
        offset_y = offsets[1]
        corners = [(float(side), params.index(f"{tname}.clearance"),
                    params.index(f"{tname}.half_height"), params.index(f"{tname}.stiffness"))
                   for _, tname, side, _, _ in part.corners]

        def energy(a, p, mem_start):
            e = 0.0
            for k, (side, ic, ih, ik) in enumerate(corners):
                ev = first + k
                if p[mem_start + 2 * ev] > 0.5:
                    delta = side * offset_y[ev](*a) - (p[ih] + p[ic])
                    if delta > 0.0:
                        e += p[ik] * delta * delta * math.sqrt(delta) / 2.5
            return e

        return energy

    # ---- Exudyn element (backends.exudyn_linkage)
    def exudyn_check(self, linkage, settings) -> None:
        """ValueError unless the Exudyn backend's `settings` build the kind's joints."""
        joints = self.joints(linkage)
        if joints and settings.contact == "sphere":
            raise ValueError(f"contact='sphere' has no translational clearance joint (linkage "
                             f"{linkage.name!r} has {[j.name for j in joints]}); use "
                             "contact='symbolic' or 'python'")

    def exudyn_contact_scale(self, linkage, load: float, masses: dict, size: float):
        """(shortest linearised contact period in s, largest relative roundoff floor) of the
        corners at the load scale `load` (N): a corner penetrates delta = (F / K)^(2/3) with
        the linearised stiffness 1.5 K delta^(1/2) against the slider's mass."""
        period, floor = math.inf, 0.0
        for tj in self.joints(linkage):
            delta = (load / tj.stiffness) ** (2.0 / 3.0)
            k = 1.5 * tj.stiffness * math.sqrt(delta)
            period = min(period, 2.0 * math.pi * math.sqrt(masses[tj.slider_body] / k))
            floor = max(floor, 1.5 * float(np.finfo(float).eps) * size / delta)
        return period, floor

    def exudyn_build(self, linkage, ctx) -> list:
        """Add each joint's `ObjectGenericODE2` (the slider's node first, then the guide's
        unless it is the ground) with the corners' force function, every corner with its
        own impact-velocity memory. `ctx`: the system (mbs), nodes, points (pts), the
        backend's helpers (generic_element, node_state, new_memory(name, floor): the next
        contact's memory, appended to ctx.memories), the Python force's allocation count
        (python_force), and the lists it appends to (contacts: (gap function, memory),
        keep_alive); returns per joint (joint, sides, memories) and adds the pre-step reads
        to ctx.pre_step_reads."""
        items = []
        for tj in self.joints(linkage):
            sides, obj, node_list = ctx.generic_element(
                ctx.mbs, ((tj.slider_body, tj.slider_point), (tj.guide_body, tj.guide_point)),
                ctx.nodes, ctx.pts)
            mems = []
            for name in tj.corner_names():
                memory = ctx.new_memory(name, tj.impact_velocity_floor)
                memory.history = []
                mems.append(memory)
            items.append((tj, sides, mems))

            def force(mbs, t, itemNumber, q, q_t, tj=tj, sides=sides, mems=mems):
                return corner_loads(tj, sides, q, q_t, [m.dmin for m in mems])[0]

            # each corner's gap reads the coordinates and rates of every node of the joint;
            # the corners' force is a Python user function
            ctx.pre_step_reads += len(CORNERS) * 2 * len(node_list) + ctx.python_force

            state = ctx.node_state(node_list)

            for k in range(len(CORNERS)):
                def gap(mbs, k=k, tj=tj, sides=sides, mems=mems, state=state):
                    # the corner's penetration and its rate
                    row = corner_loads(tj, sides, *state(mbs), [m.dmin for m in mems])[1][k]
                    return row[1], row[6]

                ctx.contacts.append((gap, mems[k]))
            ctx.mbs.SetObjectParameter(obj, "forceUserFunction", force)
            ctx.keep_alive.append(force)
        return items

    def exudyn_ground_joints(self, linkage) -> set[str]:
        """The ground joints whose reaction `exudyn_series` gives (no Exudyn sensor)."""
        return {j.name for j in self.joints(linkage) if j.guide_body == GROUND}

    def exudyn_series(self, items, ctx):
        """The corners' series of a run: per joint of `items` (joint, sides, memories) its
        corners' (n, 4) arrays "force", "penetration", "along", "offset", "friction", "slip"
        (`corner_loads`) at the samples ``ctx.t``, from ``ctx.states``(bodies) -> (q, qt)
        of the stored body states and each corner's impact velocity in force
        (``ctx.impact_velocity``(memory) -> (n,) array). Returns the record the backend
        merges: ``reactions`` of the ground guides, per contact ``eccentricity`` (n, 2),
        ``penetration``, ``force``, the ``friction_power`` of the joints with a law, no
        further ``columns``."""
        t, reactions, ecc, pen, force, power = ctx.t, {}, [], [], [], []
        for joint, sides, memories in items:
            bodies = [b for b in (joint.slider_body, joint.guide_body) if b != GROUND]
            q, qt = ctx.states(bodies)
            dmins = [ctx.impact_velocity(m) for m in memories]
            rows = np.empty((len(t), 4, 7))
            ground = np.zeros((len(t), 2))
            for i in range(len(t)):
                loads, series = corner_loads(joint, sides, q[i], qt[i],
                                             [d[i] for d in dmins])
                rows[i] = series
                if joint.guide_body == GROUND:     # the slider's loads, reversed
                    ground[i] = -np.asarray(loads[:2])
            if joint.guide_body == GROUND:
                reactions[joint.name] = ground
            for k in range(len(CORNERS)):
                ecc.append(np.column_stack([rows[:, k, 2], rows[:, k, 3]]))
                pen.append(rows[:, k, 1].copy())
                force.append(rows[:, k, 0].copy())
            if joint.has_friction:
                power.append(np.sum(rows[:, :, 4] * rows[:, :, 5], axis=1))
        return self.part(reactions=reactions, eccentricity=ecc, penetration=pen, force=force,
                         friction_power=power, columns={})


def corner_loads(joint: TranslationalClearance, sides, q, qt, dmins):
    """(generalized forces on the Exudyn element's coordinates, per corner (F, delta,
    position along the guide's axis, normal offset, friction force, sliding velocity,
    penetration rate)) of the four corners of a translational clearance joint (`sides`: the
    slider's and the guide's side of the element, each with its angle's reference; `dmins`:
    the corners' impact velocities in m/s): each corner's normal force of the contact law
    at its penetration beyond b + c along the guide's normal (zero in free flight), friction
    along the axis from its velocity relative to the guide's material point there, the
    opposite force on the guide."""
    slider, guide = sides
    (sx, sy), (svx, svy), (sax, say), sw = slider.kinematics(q, qt, math.cos, math.sin)
    (gx, gy), (gvx, gvy), (gax, gay), gw = guide.kinematics(q, qt, math.cos, math.sin)
    ga = guide.angle(q) + joint.angle
    ux, uy = math.cos(ga), math.sin(ga)
    nx, ny = -uy, ux
    sa_ = slider.angle(q) + joint.slider_angle
    ax, ay = math.cos(sa_), math.sin(sa_)
    K, c, b = joint.stiffness, joint.clearance, joint.half_height
    model = CONTACT_MODELS[joint.contact_model]
    law = FRICTION_LAWS[joint.friction_law]
    slots = tuple(getattr(joint, f) for f in FRICTION_SLOTS)
    out = [0.0] * (3 * sum(sd.slot is not None for sd in sides))
    series = []
    for (ka, kb), dmin in zip(CORNERS.values(), dmins):
        # the corner's arm from the slider's point, its position from the guide's point
        cx = ka * joint.half_length * ax - kb * b * ay
        cy = ka * joint.half_length * ay + kb * b * ax
        rx, ry = sx + cx - gx, sy + cy - gy
        vx = svx - sw * cy - (gvx - gw * ry)
        vy = svy + sw * cx - (gvy + gw * rx)
        h, hd = nx * rx + ny * ry, nx * vx + ny * vy
        along, vt = ux * rx + uy * ry, ux * vx + uy * vy
        delta, rate = kb * h - (b + c), kb * hd
        f = contact_force(delta, rate, dmin, K, joint.restitution, model) if delta > 0 else 0.0
        ft = friction_force_slots(vt, f, slots, law) if law else 0.0
        fx, fy = -kb * f * nx + ft * ux, -kb * f * ny + ft * uy
        series.append((f, delta, along, h, ft, vt, rate))
        for side, sign, (px, py) in ((slider, 1.0, (sax + cx, say + cy)),
                                     (guide, -1.0, (gax + rx, gay + ry))):
            if side.slot is not None:
                i = side.slot
                out[i] += sign * fx
                out[i + 1] += sign * fy
                out[i + 2] += sign * (px * fy - py * fx)
    return out, series


#: the element of the registry
ELEMENT = Translational()
