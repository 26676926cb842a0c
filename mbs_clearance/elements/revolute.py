"""The revolute clearance joint (`model.linkage.ClearanceJoint`) as an element: a journal in
a bearing with radial clearance, one contact per joint, with its variants per joint:

- dry contact: the normal force of the contact law (`laws.forces.CONTACT_MODELS`) along the
  line of centres at the penetration |e| - c (the stages ``contact_stage`` of
  core/runtime.h, ``contact_jacobian`` / ``contact_tangent`` of core/jac_runtime.h);
- friction (``friction_law``): the tangential force Ft at the contact point from the slip
  velocity, its moments R_J Ft and -R_B Ft about the centres (``friction_stage``,
  ``friction_jacobian`` / ``friction_tangent``);
- oil film (``lubrication``): the film's force and its torques on the two bodies, faded out
  near the wall where the dry contact takes over (``lubricated_stage``, ``film_jacobian`` /
  ``film_tangent``). The film is a variant of this element, not an element of its own: it
  replaces the joint's contact stage in place (its contact, memory and event stay the
  joint's), so that a linkage whose joints are lubricated one by one keeps every joint's
  contact at its place in the layout;
- bearing profile (``bearing_profile``, a worn or shaped bearing): the profiled contact
  stages of core/profile_runtime.h in place of the circular ones.

Its Exudyn element (`exudyn_build`, one of three variants by the backend's option
``contact``): ``"symbolic"`` (default) an ``ObjectConnectorCartesianSpringDamper`` between
``MarkerBodyRigid`` markers at the bearing and journal points with an Exudyn symbolic
(C++-evaluated) spring force: with d the journal centre relative to the bearing centre,
delta = |d| - c, deltadot = d.d'/|d|, F = max(K delta^1.5 (1 + xi(e) deltadot /
deltadot_minus), 0) for delta > 0, returned as F d/|d| (Exudyn applies it to the bearing and
its opposite to the journal; `_symbolic_force`); ``"python"`` the same connector with a
Python force calling `laws.forces.contact_force`; ``"sphere"`` Exudyn's native
``ObjectContactSphereSphere``, the bearing as hollow sphere, restitution e' = 1 - xi(e)/1.5
(`sphere_restitution`), only for laws it represents. Beside the connector:

- friction (law not "none", mu > 0): an ``ObjectGenericODE2`` on the two bodies' nodes whose
  (symbolic, or Python) force returns the generalized forces of the tangential force Ft t at
  the joint's points and the moments R_J Ft / -R_B Ft, Ft = friction_force(vt, Fn, ...) with
  vt = de/dt . t + omega_J R_J - omega_B R_B (`_friction_loads`; a connector would apply
  equal and opposite moments);
- the oil film: an ``ObjectGenericODE2`` whose Python force is the compiled film law
  (`_film_loads`);
- a bearing profile: one ``ObjectGenericODE2`` in place of the connector (any ``contact``
  but "sphere") whose Python force is the normal force at the profiled penetration
  |e| - (R_B(theta_e) - R_J) with Eq. 9's stiffness at R_B(theta_e), and the friction with
  R_B(theta_e) (`_profile_loads`; a symbolic spline lookup ran 30 times slower). A profiled,
  rubbing or lubricated joint to the ground is not built (its reaction would miss that
  force).

Each joint but a "sphere" one has its impact-velocity memory, read by the backend's pre-step
function from the joint's gap function (`_connector_gap`, a profiled joint's own). After the
run (`exudyn_series`) the eccentricity, penetration and force come from the connector's
recorded displacement and force (a profiled joint's from the stored body states), the
contact angle, slip velocity and friction power from the stored body states
(`_clearance_series`).

Its contacts come first in every layout (the registry's first element): per joint its
contact fields, then the friction fields of the joints with a law, then the film's fields of
the lubricated joints; the load symbols FX, FY (the force on the bearing, moved to its
centre), TQ (friction) and TJ, TB (the film's torques).
"""

from __future__ import annotations

import math

import numpy as np

from ..laws._dispatch import friction_force_slots
from ..laws.forces import (
    CONTACT_MODELS,
    FRICTION_LAWS,
    contact_force,
    hysteresis_factor,
    stiffness_eq9_partials,
)
from ..laws.lubrication import MODELS as LUBRICATION_MODELS
from ..laws.lubrication import lubricated_force
from ..laws.registry import FRICTION, FRICTION_PARAMETER_SPECS, FRICTION_SLOTS
from ..model.linkage import GROUND, LUBRICATION_PARAMETERS, ClearanceJoint
from .base import CONTACT_FIELDS, Element, friction_arguments

__all__ = ["ELEMENT", "FRICTION_FIELDS", "LUBRICATION_FIELDS", "friction_of",
           "sphere_restitution", "symbolic_friction_force", "symbolic_friction_factor"]

#: per clearance joint with friction, the entries of p read by the friction law and the
#: tangential slip (the radii put the contact point on each body's surface)
FRICTION_FIELDS = ("friction_law", *FRICTION_SLOTS, "journal_radius", "bearing_radius")

#: per lubricated clearance joint, the entries of p read by the film (`laws.lubrication`)
LUBRICATION_FIELDS = ("lubrication", "viscosity", "bearing_length", "journal_radius",
                      "film_fade_start", "film_fade_end")

#: the description's values that reach the stiffness (Eq. 9) or the clearance
_STIFFNESS_FIELDS = ("bearing_radius", "journal_radius", "youngs_modulus", "poisson_ratio",
                     "contact_stiffness")

#: the output columns of a joint's friction and of its film
_FRICTION_COLUMNS = ("friction_force", "slip_velocity", "friction_power")
_FILM_COLUMNS = ("film_force_x", "film_force_y", "film_torque", "film_power")


def _moments(ctx, moments) -> None:
    """Each (body, moment about its centre) of `moments` into the derivation's loads."""
    for body, tau in moments:
        ctx.torque_loads.append((body, tau))
        if body != GROUND:
            ctx.loads.append((ctx.frames[body], tau * ctx.N.z))


class RevoluteClearance(Element):
    """The revolute clearance joint: a journal in a bearing, one contact each, with its
    friction, oil film and bearing-profile variants."""

    kind = "revolute"
    description = ClearanceJoint
    attribute = "clearance_joints"

    # ---- description
    def contact_names(self, linkage) -> list[str]:
        """The joints themselves (one contact each)."""
        return [j.name for j in self.joints(linkage)]

    # ---- gap function and loads (generate.derive)
    def parameter_names(self, linkage) -> list[str]:
        """Per joint its contact fields, then per joint with friction `FRICTION_FIELDS`,
        then per lubricated joint `LUBRICATION_FIELDS`."""
        joints = self.joints(linkage)
        names = [f"{j.name}.{f}" for j in joints for f in CONTACT_FIELDS]
        names += [f"{j.name}.{f}" for j in joints if j.has_friction for f in FRICTION_FIELDS]
        names += [f"{j.name}.{f}" for j in joints if j.has_lubrication
                  for f in LUBRICATION_FIELDS]
        return names

    def memory_names(self, linkage) -> list[str]:
        """Per joint its contact mode and impact velocity."""
        return [f"{j.name}.{f}" for j in self.joints(linkage)
                for f in ("mode", "impact_velocity")]

    def base_angles(self, linkage, psyms) -> list:
        """None: the joint's kinematics use the bodies' angles only."""
        return []

    def add_loads(self, linkage, ctx):
        """The force (FX, FY) on the bearing at its centre, the opposite on the journal at
        its centre; with friction the moments R_J Ft and -R_B Ft about the centres (Ft on the
        journal along the tangent at the contact point, moved to the centres); with a film
        its torques TJ, TB on the two bodies (its force is in FX, FY). `ctx`: the
        derivation's kinematics (psyms, world, local, angle, frames, mech_point, N) and its
        load lists (loads, contact_loads, torque_loads), appended to. Returns the state
        `finish` reads."""
        # the generator's only: a run imports no sympy
        import sympy as sp

        psyms, world, local, angle = ctx.psyms, ctx.world, ctx.local, ctx.angle
        joints = self.joints(linkage)
        J = len(joints)
        FX = [sp.Symbol(f"FX{j}", real=True) for j in range(J)]
        FY = [sp.Symbol(f"FY{j}", real=True) for j in range(J)]
        gaps_t = []
        for j, cj in enumerate(joints):
            jr = world(cj.journal_body, local(cj.journal_body, cj.journal_point))
            br = world(cj.bearing_body, local(cj.bearing_body, cj.bearing_point))
            gaps_t.append((jr[0] - br[0], jr[1] - br[1]))
            for body, xy, sign in ((cj.journal_body, jr, -1), (cj.bearing_body, br, 1)):
                ctx.contact_loads.append((body, xy, sign * FX[j], sign * FY[j]))
                if body != GROUND:
                    ctx.loads.append((ctx.mech_point(f"C_{j}_{body}", xy),
                                      sign * (FX[j] * ctx.N.x + FY[j] * ctx.N.y)))
        # friction: Ft t on the journal at its contact point, -Ft t on the bearing at its;
        # with the forces (FX, FY = Fn n - Ft t on the bearing) moved to the centres, the
        # moments R_J Ft on the journal and -R_B Ft on the bearing about their centres remain
        TQ, spin_t = [], []
        for j, cj in enumerate(joints):
            if not cj.has_friction:
                TQ.append(None)
                spin_t.append(None)
                continue
            TQ.append(sp.Symbol(f"TQ{j}", real=True))
            rj, rb = psyms[f"{cj.name}.journal_radius"], psyms[f"{cj.name}.bearing_radius"]
            spin_t.append(angle[cj.journal_body] * rj - angle[cj.bearing_body] * rb)
            _moments(ctx, ((cj.journal_body, rj * TQ[j]), (cj.bearing_body, -rb * TQ[j])))
        # lubrication: the film's force on the journal is in FX, FY (moved to the bearing's
        # centre on the bearing's side); its torques on the two bodies, the bearing's
        # including that move, are TJ and TB
        TL, omega_t = [], []
        for j, cj in enumerate(joints):
            if not cj.has_lubrication:
                TL.append(None)
                omega_t.append(None)
                continue
            TL.append((sp.Symbol(f"TJ{j}", real=True), sp.Symbol(f"TB{j}", real=True)))
            omega_t.append((angle[cj.journal_body], angle[cj.bearing_body]))
            _moments(ctx, ((cj.journal_body, TL[j][0]), (cj.bearing_body, TL[j][1])))
        return self.part(joints=joints, FX=FX, FY=FY, gaps_t=gaps_t, TQ=TQ, spin_t=spin_t,
                         TL=TL, omega_t=omega_t)

    def ground_reaction(self, state, name: str, finish):
        """The force on the ground of a joint whose journal or bearing is the ground (the
        force on the bearing, reversed on the journal's side), or None when `name` is no
        such joint."""
        for j, cj in enumerate(state.joints):
            if cj.name == name:
                sign = -1 if cj.journal_body == GROUND else 1
                return (sign * state.FX[j], sign * state.FY[j])
        return None

    def finish(self, state, finish, dt):
        """The element's share of the `Derivation`: the contacts (the joints), per joint its
        gap (journal centre minus bearing centre and its rate, ``gaps``), the loop closure's
        rates (the gaps' rates), the load symbols (FX, FY, TQ, TJ and TB, ``symbols``) and
        per joint ``FX``, ``FY``, ``TQ`` (None: no friction), ``spins`` (the slip velocity's
        rotation part omega_J R_J - omega_B R_B; None: no friction), ``TL`` ((TJ, TB); None:
        not lubricated) and ``omegas`` ((omega_J, omega_B); None: not lubricated)."""
        gaps = [tuple(finish(v) for v in (ex, ey, dt(ex), dt(ey))) for ex, ey in state.gaps_t]
        return self._part(
            [cj.name for cj in state.joints], gaps, state.FX, state.FY, state.TQ,
            [None if e is None else finish(dt(e)) for e in state.spin_t], state.TL,
            [None if e is None else tuple(finish(dt(a)) for a in e) for e in state.omega_t])

    def _part(self, contacts, gaps, FX, FY, TQ, spins, TL, omegas):
        return self.part(
            contacts=contacts, gaps=gaps, FX=FX, FY=FY, TQ=TQ, spins=spins, TL=TL,
            omegas=omegas, closure_rates=[v for gap in gaps for v in gap[2:]],
            symbols=[*FX, *FY, *(s for s in TQ if s is not None),
                     *(s for pair in TL if pair is not None for s in pair)])

    def specialise(self, part, sub):
        """`part` with `sub` applied to its expressions."""
        return self._part(
            part.contacts, [tuple(sub(e) for e in g) for g in part.gaps], part.FX, part.FY,
            part.TQ, [sub(e) for e in part.spins], part.TL,
            [None if e is None else tuple(sub(a) for a in e) for e in part.omegas])

    # ---- C printer (generate.writer, generate.cwriter)
    def plan(self, part, params: list, mem_start: int, first: int):
        """The joints' stages of the model evaluation (`first`: the event index of the first
        joint): the contact stage, the friction stage in its place for a joint with a law
        (the slip's rotation part ``sp<j>`` beside the gaps), the lubricated stage (dry
        contact plus the faded film, the bodies' angular velocities ``wj<j>``, ``wb<j>``
        beside the gaps) for a joint in oil. Returns ``lines``, ``contact`` (per joint its
        contact fields' p indices), ``fric``, ``fpar``, ``lub`` (the events with friction,
        their friction fields' p indices, the lubricated events), ``gap_extras`` ((name in
        the model, name in the Jacobians, its extra row's key, expression) computed beside
        the gaps), ``results`` (the friction's and the films' output values), ``floors``,
        ``friction`` and ``lubricated`` (the contacts with a law, in oil)."""
        contact = [{f: params.index(f"{name}.{f}") for f in CONTACT_FIELDS}
                   for name in part.contacts]
        events = range(first, first + len(part.contacts))
        fric = [e for e, k in zip(events, part.TQ) if k is not None]
        lub = [e for e, k in zip(events, part.TL) if k is not None]
        fpar = {e: {f: params.index(f"{part.contacts[e - first]}.{f}") for f in FRICTION_FIELDS}
                for e in fric}
        lpar = {e: {f: params.index(f"{part.contacts[e - first]}.{f}")
                    for f in LUBRICATION_FIELDS} for e in lub}
        gap_extras = [(f"sp{e}", f"gv{e}_4", ("spin", e), part.spins[e - first]) for e in fric]
        for e in lub:
            for m, what in enumerate(("wj", "wb")):
                gap_extras.append((f"{what}{e}", f"gv{e}_{5 + m}", (what, e),
                                   part.omegas[e - first][m]))
        lines = []
        for e, c in zip(events, contact):
            k = e - first
            FX, FY = part.FX[k], part.FY[k]
            law = (f"p[{c['clearance']}], p[{mem_start + 2 * e}], p[{mem_start + 2 * e + 1}], "
                   f"p[{c['stiffness']}], p[{c['restitution']}], p[{c['contact_model']}]")
            if e in lpar:
                TJ, TB = part.TL[k]
                lines.append(
                    f"F{e}, d{e}, dd{e}, {FX}, {FY}, {TJ}, {TB}, ffx{e}, ffy{e}, fpw{e} = "
                    f"lubricated_stage(ex{e}, ey{e}, exd{e}, eyd{e}, wj{e}, wb{e}, {law}, "
                    + ", ".join(f"p[{lpar[e][f]}]" for f in LUBRICATION_FIELDS) + ")")
            elif e in fpar:
                lines.append(
                    f"F{e}, d{e}, dd{e}, {FX}, {FY}, {part.TQ[k]}, vt{e} = friction_stage("
                    f"ex{e}, ey{e}, exd{e}, eyd{e}, sp{e}, {law}, p[{fpar[e]['friction_law']}], "
                    "(" + friction_arguments([f"p[{fpar[e][f]}]" for f in FRICTION_SLOTS])
                    + "))")
            else:
                lines.append(f"F{e}, d{e}, dd{e}, {FX}, {FY} = contact_stage("
                             f"ex{e}, ey{e}, exd{e}, eyd{e}, {law})")
        results = []
        for e in fric:
            tq = part.TQ[e - first]
            results += [str(tq), f"vt{e}", f"-{tq} * vt{e}"]
        for e in lub:
            results += [f"ffx{e}", f"ffy{e}", str(part.TL[e - first][0]), f"fpw{e}"]
        return self.part(
            lines=lines, contact=contact, fric=fric, fpar=fpar, lub=lub, first=first,
            mem_start=mem_start, gap_extras=gap_extras, results=results,
            floors=[(e, c["impact_velocity_floor"]) for e, c in zip(events, contact)],
            friction=[part.contacts[e - first] for e in fric],
            lubricated=[part.contacts[e - first] for e in lub], profiles={}, offsets={})

    def out_columns(self, part, plan) -> list[str]:
        """The friction columns of the joints with a law, then the film's of the lubricated
        ones."""
        return ([f"{name}.{f}" for name in plan.friction for f in _FRICTION_COLUMNS]
                + [f"{name}.{f}" for name in plan.lubricated for f in _FILM_COLUMNS])

    def friction_contacts(self, part, plan) -> list[str]:
        """The joints with a friction law (their friction power enters the work)."""
        return list(plan.friction)

    def profiled_stages(self, part, plan, profiles: dict, gaps_stage, block_size) -> dict:
        """The profiled joints' contact stages (core/profile_runtime.h) in place of the
        circular ones in `plan`'s lines, the bearing body's angle and rate (pa<j>, pw<j>)
        computed beside the gaps (appended to `gaps_stage`); `profiles`: per profiled event
        (bearing angle, its rate, grid size); returns per profiled event the offset of its
        block (`block_size`(points) entries each) from PROFILE_START."""
        import sympy as sp

        offsets, at = {}, 0
        for e in sorted(profiles):
            angle, rate, points = profiles[e]
            offsets[e] = at
            at += block_size(points)
            gaps_stage[0].extend([sp.sympify(angle), sp.sympify(rate)])
            gaps_stage[1].extend([f"pa{e}", f"pw{e}"])
            k = e - plan.first
            c, mem = plan.contact[k], plan.mem_start + 2 * e
            FX, FY = part.FX[k], part.FY[k]
            law = (f"p[{mem}], p[{mem + 1}], p[{c['stiffness']}], p[{c['restitution']}], "
                   f"p[{c['contact_model']}]")
            block = f"p + PROFILE_START + {offsets[e]}, {points}"
            if e in plan.fpar:
                fp = plan.fpar[e]
                plan.lines[k] = (
                    f"F{e}, d{e}, dd{e}, {FX}, {FY}, {part.TQ[k]}, vt{e} = "
                    f"profile_friction_stage(ex{e}, ey{e}, exd{e}, eyd{e}, sp{e}, pa{e}, "
                    f"pw{e}, p[{fp['bearing_radius']}], {law}, p[{fp['friction_law']}], ("
                    + friction_arguments([f"p[{fp[f]}]" for f in FRICTION_SLOTS])
                    + f"), {block})")
            else:
                plan.lines[k] = (
                    f"F{e}, d{e}, dd{e}, {FX}, {FY} = profile_contact_stage(ex{e}, "
                    f"ey{e}, exd{e}, eyd{e}, pa{e}, pw{e}, {law}, {block})")
        plan.profiles, plan.offsets = dict(profiles), offsets
        return offsets

    def penetration_lines(self, plan) -> list[str]:
        """The C lines of `penetration` for the joints: (delta, deltadot) of the journal in
        its bearing (core/runtime.h's ``gap_state``; a profiled bearing's
        ``mbs_profile_gap``)."""
        out = []
        for k, ci in enumerate(plan.contact):
            e = plan.first + k
            if e in plan.profiles:
                out.append(
                    f"    if (j == {e}) {{ gap_{e}(t, y, p, g); bearing_{e}(t, y, p, b); "
                    "mbs_profile_gap(g[0], g[1], g[2], g[3], b[0], b[1], "
                    f"p + PROFILE_START + {plan.offsets[e]}, {plan.profiles[e][2]}, &dd[0], "
                    "&dd[1], &nx, &ny, &rb, &slope); return; }")
            else:
                out.append(f"    if (j == {e}) {{ gap_{e}(t, y, p, g); gap_state(g[0], g[1], "
                           f"g[2], g[3], p[{ci['clearance']}], &dd[0], &dd[1], &nx, &ny); "
                           "return; }")
        return out

    def closure(self, part) -> list:
        """The loop closure: each journal centred in its bearing (the gaps' offsets)."""
        return [e for g in part.gaps for e in g[:2]]

    # ---- Jacobian rows and tangent terms (generate.jacobians)
    @staticmethod
    def _variants(part, first: int) -> tuple[list[int], list[int]]:
        """(the events with friction, the lubricated events)."""
        return ([first + k for k, s in enumerate(part.TQ) if s is not None],
                [first + k for k, s in enumerate(part.TL) if s is not None])

    def jacobian_rows(self, part, first: int, start: int) -> dict:
        """{(what, event): row} of the joints' extra rows from row `start`: per joint the
        rates of its offsets and its force (exd, eyd, fx, fy), then per joint with friction
        its slip's rotation part (spin), then per lubricated joint its bodies' angular
        velocities and the film's torque on the bearing (wj, wb, tb)."""
        J = len(part.contacts)
        fric, lub = self._variants(part, first)
        rows = {}
        for k in range(J):
            for m, what in enumerate(("exd", "eyd", "fx", "fy")):
                rows[(what, first + k)] = start + 4 * k + m
        for k, e in enumerate(fric):
            rows[("spin", e)] = start + 4 * J + k
        for k, e in enumerate(lub):
            for m, what in enumerate(("wj", "wb", "tb")):
                rows[(what, e)] = start + 4 * J + len(fric) + 3 * k + m
        return rows

    def jacobian_lines(self, part, first: int, ctx) -> tuple[list[str], list[str]]:
        """(the `jacobian` lines, the `tangent` lines) of the joints' forces: per joint the
        contact law's rows (``contact_jacobian``), the friction law's (``friction_jacobian``)
        and the film's (``film_jacobian``) of core/jac_runtime.h, and their tangents. `ctx`:
        the plan's row (output rows), extra (extra rows), pcol (z columns of p), n (N_Q),
        stride, nz."""
        row, extra, pcol, n = ctx.row, ctx.extra, ctx.pcol, ctx.n
        stride, nz = ctx.stride, ctx.nz
        fric, lub = self._variants(part, first)
        jlines, tlines = [], []
        for k, name in enumerate(part.contacts):
            j = first + k
            FX, FY = part.FX[k], part.FY[k]
            rows = [row[f"{name}.{f}"] for f in ("contact_force", "penetration",
                                                 "penetration_rate", "ecc_x", "ecc_y")]
            rows += [extra[(what, j)] for what in ("exd", "eyd", "fx", "fy")]
            zc = [pcol[f"{name}.{f}"] for f in ("clearance", "stiffness", "restitution",
                                                "impact_velocity")]
            pv = [f"p[{pcol[f'{name}.{f}'] - 1 - 2 * n}]" for f in (
                "clearance", "mode", "impact_velocity", "stiffness", "restitution",
                "contact_model")]
            args = (f"gv{j}_0, gv{j}_1, gv{j}_2, gv{j}_3, "
                    + ", ".join(str(v) for v in rows + zc) + ", " + ", ".join(pv) + ")")
            jlines.append(f"{FX}, {FY} = contact_jacobian(jac, {stride}, {nz}, " + args)
            tlines.append(f"{FX}, {FY} = contact_tangent(out, ts, nd, dz, {nz}, " + args)
            if j in fric:
                frows = [row[f"{name}.{f}"] for f in ("ecc_x", "ecc_y")] + [
                    extra[(what, j)] for what in ("exd", "eyd", "spin")] + [
                    row[f"{name}.contact_force"], extra[("fx", j)], extra[("fy", j)]] + [
                    row[f"{name}.{f}"] for f in _FRICTION_COLUMNS]
                fc = friction_arguments([f"{pcol[f'{name}.{f}']}" for f in FRICTION_SLOTS])
                fv = friction_arguments([f"p[{pcol[f'{name}.{f}'] - 1 - 2 * n}]"
                                         for f in FRICTION_SLOTS])
                law = f"p[{pcol[f'{name}.friction_law'] - 1 - 2 * n}]"
                args = (f"gv{j}_4, " + ", ".join(str(v) for v in frows)
                        + f", ({fc}), {law}, ({fv}))")
                TQ = part.TQ[k]
                jlines.append(f"{FX}, {FY}, {TQ} = friction_jacobian(jac, {stride}, {nz}, "
                              + args)
                tlines.append(f"{FX}, {FY}, {TQ} = friction_tangent(out, ts, nd, dz, {nz}, "
                              + args)
            if j in lub:
                lrows = [row[f"{name}.{f}"] for f in ("ecc_x", "ecc_y")] + [
                    extra[(what, j)] for what in ("exd", "eyd", "wj", "wb", "fx", "fy")] + [
                    row[f"{name}.{f}"] for f in _FILM_COLUMNS[:3]] + [
                    extra[("tb", j)], row[f"{name}.film_power"]]
                fields = ("journal_radius", "clearance", "bearing_length", "viscosity",
                          "film_fade_start", "film_fade_end")
                lcols = [pcol[f"{name}.{f}"] for f in fields]
                lvals = [f"p[{pcol[f'{name}.{f}'] - 1 - 2 * n}]" for f in (
                    *fields[:4], "lubrication", *fields[4:])]
                args = ", ".join([f"gv{j}_5", f"gv{j}_6"] + [str(v) for v in lrows + lcols
                                                                + lvals]) + ")"
                TJ, TB = part.TL[k]
                jlines.append(f"{FX}, {FY}, {TJ}, {TB} = film_jacobian(jac, {stride}, "
                              f"{nz}, " + args)
                tlines.append(f"{FX}, {FY}, {TJ}, {TB} = film_tangent(out, ts, nd, dz, "
                              f"{nz}, " + args)
        return jlines, tlines

    def force_loads(self, part, first: int, row: dict, extra: dict) -> list[tuple]:
        """The joints' load symbols in the equations of motion: (symbol, its row,
        coefficient name stem, event)."""
        return [(F, frow, "r" + stem, j) for j, lds in self.output_loads(part, first, row, extra)
                for stem, F, frow in lds]

    def output_loads(self, part, first: int, row: dict, extra: dict) -> list[tuple]:
        """Per joint (event, [(stem, load symbol, its row)]) for the outputs' chain rule
        through the joints' loads: FX, FY, with friction TQ, in oil TJ and TB."""
        out = []
        for k, name in enumerate(part.contacts):
            j = first + k
            lds = [("fx", part.FX[k], extra[("fx", j)]), ("fy", part.FY[k], extra[("fy", j)])]
            if part.TQ[k] is not None:
                lds.append(("tq", part.TQ[k], row[f"{name}.friction_force"]))
            if part.TL[k] is not None:
                lds.append(("tj", part.TL[k][0], row[f"{name}.film_torque"]))
                lds.append(("tb", part.TL[k][1], extra[("tb", j)]))
            out.append((j, lds))
        return out

    # ---- energy (generate.energy)
    def contact_energy(self, part, params: list, first: int, offsets: tuple):
        """A function (a, p, mem_start) -> the joints' contact potential in J, where `a` are
        the arguments of the derivation's numeric functions and `offsets` the numeric
        offsets (x, y lists) of the contacts: K delta^2.5 / 2.5 of each joint in contact,
        delta = |e| - c (a film stores no energy)."""
        offset_x, offset_y = offsets
        joints = [(params.index(f"{name}.clearance"), params.index(f"{name}.stiffness"))
                  for name in part.contacts]

        def energy(a, p, mem_start):
            e = 0.0
            for k, (ic, ik) in enumerate(joints):
                j = first + k
                if p[mem_start + 2 * j] > 0.5:
                    delta = math.hypot(offset_x[j](*a), offset_y[j](*a)) - p[ic]
                    if delta > 0.0:
                        e += p[ik] * delta * delta * math.sqrt(delta) / 2.5
            return e

        return energy

    # ---- the reduced model's parameters and sensitivities (solve.linkage_model,
    # solve.linkage_ddm)
    def parameter_values(self, linkage) -> dict[str, float]:
        """The values of the kind's entries of p (`parameter_names`, `memory_names`): the
        joints' fields (the stiffness `ClearanceJoint.stiffness`), the laws' ids, each
        joint's memory started free at the floor."""
        values = {}
        for j in self.joints(linkage):
            values[f"{j.name}.clearance"] = j.clearance
            values[f"{j.name}.stiffness"] = j.stiffness
            values[f"{j.name}.restitution"] = j.restitution
            values[f"{j.name}.contact_model"] = float(CONTACT_MODELS[j.contact_model])
            values[f"{j.name}.impact_velocity_floor"] = j.impact_velocity_floor
            values[f"{j.name}.mode"] = 0.0
            values[f"{j.name}.impact_velocity"] = j.impact_velocity_floor
            values[f"{j.name}.friction_law"] = float(FRICTION_LAWS[j.friction_law])
            for f in FRICTION_SLOTS:
                values[f"{j.name}.{f}"] = getattr(j, f)
            values[f"{j.name}.journal_radius"] = j.journal_radius
            values[f"{j.name}.bearing_radius"] = j.bearing_radius
            # the film's model id (-1: dry, never read: a dry joint's model has no film)
            values[f"{j.name}.lubrication"] = float(LUBRICATION_MODELS.get(j.lubrication, -1))
            for f in LUBRICATION_PARAMETERS:
                values[f"{j.name}.{f}"] = getattr(j, f)
        return values

    def floor_names(self, linkage) -> list[str]:
        """Per contact (joint) the name of its impact-velocity floor."""
        return [f"{j.name}.impact_velocity_floor" for j in self.joints(linkage)]

    def chain(self, linkage, head: str, field: str) -> dict[str, float]:
        """{entry of p: d entry / d value} of the description's value `field` of joint
        `head` when it reaches p under another name (empty otherwise): the radii reach the
        clearance, and with the paper's Eq. 9 (no contact_stiffness given) the radii, the
        Young's modulus and the Poisson ratio reach the stiffness (d 0 when it is given);
        contact_stiffness is the stiffness."""
        joint = next((j for j in self.joints(linkage) if j.name == head), None)
        if joint is None or field not in _STIFFNESS_FIELDS:
            return {}
        _, d_rj, d_rb, d_e, d_nu = stiffness_eq9_partials(
            joint.journal_radius, joint.bearing_radius, joint.youngs_modulus,
            joint.poisson_ratio)
        derived = joint.contact_stiffness is None
        k, c = f"{head}.stiffness", f"{head}.clearance"
        if field == "contact_stiffness":
            return {k: 1.0}
        if field == "bearing_radius":
            return {c: 1.0, k: d_rb if derived else 0.0}
        if field == "journal_radius":
            return {c: -1.0, k: d_rj if derived else 0.0}
        return {k: (d_e if field == "youngs_modulus" else d_nu) if derived else 0.0}

    def closure_rows(self, linkage, out, extra) -> tuple[list[dict], list[dict]]:
        """The loop closure of the joints at the start as rows of the model's Jacobian
        ({row: weight}: `out`(column name) an output row, `extra`[name] an extra row), and
        their rates: each journal centred (its offsets x, y)."""
        pos, rate = [], []
        for j in self.joints(linkage):
            for xy in "xy":
                pos.append({out(f"{j.name}.ecc_{xy}"): 1.0})
                rate.append({extra[f"e{xy}d:{j.name}"]: 1.0})
        return pos, rate

    def sensitivity_check(self, linkage) -> None:
        """ValueError unless the sensitivity runs have the partial derivatives of every
        joint's laws (a film model without them is refused by name)."""
        from ..laws.lubrication.partials import check_partials

        for j in self.joints(linkage):
            if j.has_lubrication:
                check_partials(f"clearance joint {j.name!r}", j.lubrication)

    def fd_scale(self, linkage, head: str, field: str) -> float | None:
        """The scale of a central-difference step of the value `field` of joint `head`:
        the clearance for its radii (None otherwise: the value's own)."""
        if field in ("bearing_radius", "journal_radius"):
            for j in self.joints(linkage):
                if j.name == head:
                    return j.clearance
        return None

    def trajectory_series(self, linkage, ecc, ctx) -> dict:
        """The run's series of the joints: ``contact_angle`` and ``slip_velocity``, each
        (n, J) over the J joints at the recorded steps (the contacts' eccentricities ecc
        (n, >= J, 2)): the direction of the eccentricity e in the bearing body's frame in
        [0, 2 pi) rad, and the journal surface's tangential speed against the bearing's at
        the contact in m/s, e_dot . t + omega_J R_J - omega_B R_B with t = (-n_y, n_x),
        n = e / |e| (as the friction law's; R_B at the contact angle for a profiled bearing,
        as the compiled model takes it). `ctx`: ``edot``(J) the rates (n, J, 2) of the first
        J contacts' eccentricities, ``bodies`` {body: (angle, rate)} series,
        ``effective_radius`` (`generate.profiles.effective_radius`). Both None for a linkage
        without these joints."""
        joints = self.joints(linkage)
        if not joints:
            return {"contact_angle": None, "slip_velocity": None}
        # the joints' contacts are the first (the registry's first element)
        edot, bodies = ctx.edot(len(joints)), ctx.bodies
        angle, slip = np.empty((len(ecc), len(joints))), np.empty((len(ecc), len(joints)))
        for j, cj in enumerate(joints):
            ex, ey = ecc[:, j, 0], ecc[:, j, 1]
            phi_b, w_b = bodies[cj.bearing_body]
            w_j = bodies[cj.journal_body][1]
            theta = np.mod(np.arctan2(ey, ex) - phi_b, 2.0 * np.pi)
            theta[theta >= 2.0 * np.pi] = 0.0          # a round-off below 0 wraps to 2 pi
            r = np.hypot(ex, ey)
            centred = r <= 1e-300                      # the model's normal there: (-1, 0)
            safe = np.where(centred, 1.0, r)
            nx = np.where(centred, -1.0, ex / safe)
            ny = np.where(centred, 0.0, ey / safe)
            rb = (cj.bearing_radius if cj.bearing_profile is None else
                  ctx.effective_radius(cj.bearing_profile, cj.journal_radius, theta, r))
            angle[:, j] = theta
            slip[:, j] = (edot[:, j, 1] * nx - edot[:, j, 0] * ny + w_j * cj.journal_radius
                          - w_b * rb)
        return {"contact_angle": angle, "slip_velocity": slip}

    # ---- the ideal-joint backend (backends.ideal_linkage)
    def ideal_joints(self, linkage, angles: dict) -> list[tuple]:
        """Each joint closed as an ideal pin: ("pin", (name, journal body, journal point,
        bearing body, bearing point))."""
        return [("pin", (j.name, j.journal_body, j.journal_point, j.bearing_body,
                         j.bearing_point)) for j in self.joints(linkage)]

    def ideal_contact_forces(self, linkage, multipliers) -> list:
        """Per joint the magnitude of the force its ideal pin transmits (N, (s,)): its two
        multipliers' (`multipliers`(name) -> (s, 2))."""
        out = []
        for j in self.joints(linkage):
            lam = multipliers(j.name)
            out.append(np.hypot(lam[:, 0], lam[:, 1]))
        return out

    # ---- Exudyn element (backends.exudyn_linkage)
    def exudyn_check(self, linkage, settings) -> None:
        """ValueError unless the Exudyn backend's `settings` build the joints: the friction,
        the film and a profiled contact are generic elements on the two bodies' nodes (no
        "sphere" contact, no ground joint: its reaction would miss that force); a "sphere"
        contact needs Exudyn's restitution 1 - xi/1.5 > 0."""
        joints = self.joints(linkage)
        for j in joints:
            for what, on in (("friction law of ours", friction_of(j) is not None),
                             ("oil film", j.has_lubrication),
                             ("bearing profile", j.profile is not None)):
                if not on:
                    continue
                if settings.contact == "sphere":
                    raise ValueError(f"contact='sphere' has no {what} (joint {j.name!r} has "
                                     "it); use contact='symbolic' or 'python'")
                if GROUND in (j.journal_body, j.bearing_body):
                    raise ValueError(f"the {what.split(' of')[0]} of clearance joint "
                                     f"{j.name!r}, which is a ground joint, is not built in the "
                                     "exudyn backend (its reaction would miss that force); use "
                                     "the reduced backend")
        if settings.contact == "sphere":
            for j in joints:
                if sphere_restitution(j) <= 0.0:
                    raise ValueError(
                        f"contact='sphere' cannot represent joint {j.name!r}'s contact_model="
                        f"{j.contact_model!r} with restitution {j.restitution!r}: Exudyn's "
                        f"restitution 1 - xi/1.5 = {sphere_restitution(j):.3g} must be > 0; "
                        "use contact='symbolic'")

    def exudyn_contact_scale(self, linkage, load: float, masses: dict, size: float):
        """(shortest linearised contact period in s, largest relative roundoff floor) of the
        joints at the load scale `load` (N): a joint penetrates delta = (F / K)^(2/3) with the
        linearised stiffness 1.5 K delta^(1/2) against the lighter of its bodies."""
        period, floor = math.inf, 0.0
        for cj in self.joints(linkage):
            delta = (load / cj.stiffness) ** (2.0 / 3.0)
            k = 1.5 * cj.stiffness * math.sqrt(delta)
            m = min(masses.get(cj.journal_body, math.inf), masses.get(cj.bearing_body, math.inf))
            period = min(period, 2.0 * math.pi * math.sqrt(m / k))
            floor = max(floor, 1.5 * float(np.finfo(float).eps) * size / delta)
        return period, floor

    def exudyn_build(self, linkage, ctx) -> list:
        """Add each joint's contact (option ``contact`` of ``ctx.settings``): a
        ``CartesianSpringDamper`` with the symbolic or Python contact force, or Exudyn's
        ``ObjectContactSphereSphere``; a profiled joint's `ObjectGenericODE2`; with friction
        and in oil their `ObjectGenericODE2`s. Every joint but a "sphere" one has its
        impact-velocity memory and gap function for the pre-step function. `ctx`: the system
        (mbs), settings, nodes, points (pts), the backend's helpers (marker, generic_element,
        node_state, symbolic_vector_function, new_memory(name, floor)), the Python force's
        allocation count (python_force), and what it fills: memories, contacts ((gap
        function, memory)), keep_alive, pre_step_reads, ground_items and ground_signs (a
        ground joint's item whose Force sensor, times the sign, is the reaction on the
        ground), contact_sensors ((joint, item) whose Displacement and Force Exudyn
        records). Returns per joint (joint, memory or None, the sign turning the recorded
        Displacement into journal minus bearing)."""
        import exudyn.itemInterface as ii

        mbs, variant, items = ctx.mbs, ctx.settings.contact, []
        for k, cj in enumerate(self.joints(linkage)):
            memory = None
            if variant == "sphere":
                m_journal = ctx.marker(cj.journal_body, cj.journal_point, rigid=True)
                m_bearing = ctx.marker(cj.bearing_body, cj.bearing_point, rigid=True)
                n_data = mbs.AddNode(ii.NodeGenericData(
                    numberOfDataCoordinates=4, initialCoordinates=[cj.clearance, 0, 0, 0]))
                obj = mbs.AddObject(ii.ObjectContactSphereSphere(
                    markerNumbers=[m_journal, m_bearing], nodeNumber=n_data,
                    spheresRadii=[cj.journal_radius, cj.bearing_radius], isHollowSphere1=True,
                    contactStiffness=cj.stiffness, contactStiffnessExponent=1.5,
                    contactDamping=0.0, dynamicFriction=0.0,
                    restitutionCoefficient=sphere_restitution(cj),
                    minimumImpactVelocity=cj.impact_velocity_floor, impactModel=1))
                ctx.memories.append(None)
            elif cj.profile is not None:
                memory = ctx.new_memory(cj.name, cj.impact_velocity_floor)
                obj, gap = _profile_element(ctx, cj, memory)
                memory.history = []         # the contact force after the run needs it
                ctx.contacts.append((gap, memory))
                # the gap reads each node's coordinates and rates
                ctx.pre_step_reads += (2 * sum(b != GROUND for b in (cj.journal_body,
                                                                     cj.bearing_body))
                                       + ctx.python_force)
            else:
                m_journal = ctx.marker(cj.journal_body, cj.journal_point, rigid=True)
                m_bearing = ctx.marker(cj.bearing_body, cj.bearing_point, rigid=True)
                memory = ctx.new_memory(cj.name, cj.impact_velocity_floor)
                obj = mbs.AddObject(ii.CartesianSpringDamper(markerNumbers=[m_bearing,
                                                                            m_journal]))
                if variant == "symbolic":
                    uf = _symbolic_force(mbs, obj, cj, memory, k)
                    ctx.keep_alive += [uf, memory.symbol]   # the tree must outlive the run
                else:
                    uf = _python_force(cj, memory)
                mbs.SetObjectParameter(obj, "springForceUserFunction", uf)
                ctx.contacts.append((_connector_gap(obj, cj.clearance), memory))
                ctx.pre_step_reads += 2          # the joint's displacement and velocity
                if friction_of(cj) is not None:
                    _friction_element(ctx, cj, memory)
                    memory.history = []
                    # its force function (symbolic vector or Python) makes its vector each call
                    ctx.pre_step_reads += ctx.python_force
                if cj.has_lubrication:
                    _film_element(ctx, cj)
                    ctx.pre_step_reads += ctx.python_force
            if cj.profile is None:              # a profiled one's from the bodies' states
                ctx.contact_sensors.append((cj.name, obj))
            if GROUND in (cj.journal_body, cj.bearing_body):
                # the force on the bearing is +f (user force) / -f (sphere: markers swapped)
                on_bearing = 1.0 if variant != "sphere" else -1.0
                ctx.ground_items[cj.name] = obj
                ctx.ground_signs[cj.name] = on_bearing * (1.0 if cj.bearing_body == GROUND
                                                          else -1.0)
            items.append((cj, memory, -1.0 if variant == "sphere" else 1.0))
        return items

    def exudyn_ground_joints(self, linkage) -> set[str]:
        """None: a joint to the ground has its reaction from the Force sensor of its contact
        (`exudyn_build`'s ground_items)."""
        return set()

    def exudyn_series(self, items, ctx):
        """The joints' series of a run (`items`: per joint (joint, memory, sign) of
        `exudyn_build`): per contact ``eccentricity`` (n, 2), ``penetration`` and
        ``force`` (from the recorded Displacement and Force of its contact, a profiled
        one's from the bodies' states, `_clearance_series`), the ``friction_power`` of the
        joints with friction and the ``columns`` contact_angle and slip_velocity per joint.
        `ctx`: the samples t, stored(sensor name), motion(body) -> (coordinates (n, 3),
        rates (n, 3)), the points, impact_velocity(memory) -> (n,) at the samples. No
        ground reaction (a ground joint's is a sensor's)."""
        ecc, pen, force, power, angle, slip = [], [], [], [], [], []
        for cj, memory, sign in items:
            series = _clearance_series(ctx, cj, memory)
            angle.append(series["contact_angle"])
            slip.append(series["slip_velocity"])
            if "friction_power" in series:
                power.append(series["friction_power"])
            if cj.profile is not None:
                ecc.append(series["eccentricity"])
                pen.append(series["penetration"])
                force.append(series["force"])
                continue
            e = sign * ctx.stored(f"{cj.name}.displacement")[:, 1:3]
            r = np.hypot(e[:, 0], e[:, 1])
            f = ctx.stored(f"{cj.name}.force")[:, 1:3]
            with np.errstate(invalid="ignore", divide="ignore"):
                fn = sign * (f[:, 0] * e[:, 0] + f[:, 1] * e[:, 1]) / r
            ecc.append(e)
            pen.append(r - cj.clearance)
            force.append(np.where(r > 0.0, fn, 0.0))
        return self.part(reactions={}, eccentricity=ecc, penetration=pen, force=force,
                         friction_power=power,
                         columns={"contact_angle": angle, "slip_velocity": slip})


# ---------------------------------------------------------------------------- Exudyn

def sphere_restitution(joint: ClearanceJoint) -> float:
    """Restitution e' for Exudyn's Hunt-Crossley sphere contact that reproduces our law:
    Exudyn's impactModel 1 damps with 1.5 (1 - e'), so e' = 1 - xi(e)/1.5 ((1 + e^2)/2 for
    Lankarani-Nikravesh, e for Hunt-Crossley)."""
    xi, _ = hysteresis_factor(joint.restitution, CONTACT_MODELS[joint.contact_model])
    return 1.0 - xi / 1.5


def _law_constants(joint: ClearanceJoint):
    model = CONTACT_MODELS[joint.contact_model]
    xi, _ = hysteresis_factor(joint.restitution, model)
    return joint.stiffness, joint.clearance, float(xi), model


def _python_force(joint: ClearanceJoint, memory):
    """Plain Python user function: the reduced model's compiled contact law."""
    K, c, _, model = _law_constants(joint)
    e = joint.restitution

    def force(mbs, t, itemNumber, displacement, velocity, stiffness, damping, offset):
        dx, dy = displacement[0], displacement[1]
        r = math.sqrt(dx * dx + dy * dy)
        delta = r - c
        if delta <= 0.0:
            return [0.0, 0.0, 0.0]
        rate = (dx * velocity[0] + dy * velocity[1]) / r
        f = contact_force(delta, rate, memory.dmin, K, e, model) / r
        return [f * dx, f * dy, 0.0]

    return force


def _symbolic_normal(K, c, xi, dmin, dx, dy, vx, vy):
    """Symbolic normal force of the contact law from the journal centre's position (dx, dy)
    and velocity (vx, vy) relative to the bearing centre: (r, magnitude or 0 when free);
    the same formula as contact.contact_force (clamped at zero, zero for delta <= 0)."""
    import exudyn as exu

    esym = exu.symbolic
    zero = esym.Real(0.0)
    r = esym.sqrt(dx * dx + dy * dy)
    delta = r - c
    rate = (dx * vx + dy * vy) / r
    magnitude = esym.max(K * delta**1.5 * (1.0 + xi * rate / dmin), zero)
    # lazy: r > c > 0 inside the true branch, so no division by zero when centred
    return r, esym.IfThenElse(delta > 0.0, magnitude, zero)


def _symbolic_force(mbs, obj, joint: ClearanceJoint, memory, k: int):
    """Compiled (symbolic) user function; the impact velocity is a named symbolic variable
    (one per joint)."""
    import exudyn as exu
    from exudyn.advancedUtilities import CreateSymbolicUserFunction

    esym = exu.symbolic
    K, c, xi, _ = _law_constants(joint)
    dmin = esym.Real(f"deltadot_minus_{k}", memory.dmin)
    memory.symbol = dmin
    zero = esym.Real(0.0)

    def force(mbs, t, itemNumber, displacement, velocity, stiffness, damping, offset):
        dx, dy = displacement[0], displacement[1]
        r, magnitude = _symbolic_normal(K, c, xi, dmin, dx, dy, velocity[0], velocity[1])
        factor = esym.IfThenElse(r - c > 0.0, magnitude / r, zero)
        return [factor * dx, factor * dy, zero]

    return CreateSymbolicUserFunction(mbs, force, "springForceUserFunction", obj)


def friction_of(joint: ClearanceJoint):
    """(law id, the values of the friction slots `laws.FRICTION_SLOTS`) of a clearance joint
    whose friction is on (law not "none" and mu > 0), else None: a joint without friction
    gets no friction element, so its results are the frictionless ones bit for bit."""
    if not joint.has_friction or joint.friction_coefficient == 0.0:
        return None
    return (FRICTION_LAWS[joint.friction_law],
            tuple(getattr(joint, f) for f in FRICTION_SLOTS))


def symbolic_friction_force(vt, fn, law: int, slots: tuple):
    """Ft(vt, Fn) of friction law id `law` as an Exudyn symbolic expression: the law
    module's own formula (`laws.friction.<name>.force`) evaluated on symbolic Reals, with
    the law's parameters from `slots` (the values of `laws.FRICTION_SLOTS`)."""
    spec = FRICTION[law]
    values = dict(zip(FRICTION_SLOTS, slots))
    ft = spec.force(vt, fn, *(values[a] for a in spec.arguments))
    return ft if hasattr(ft, "Evaluate") else 0.0 * vt + ft


def symbolic_friction_factor(vt, v0: float, v1: float, law: int):
    """phi(vt) of `contact.friction_factor` as an Exudyn symbolic expression (Ft at mu = 1,
    Fn = -1, `symbolic_friction_force`); tested against contact.friction_factor point by
    point; further slots at their defaults."""
    given = {"friction_coefficient": 1.0, "friction_v0": v0, "friction_v1": v1}
    return symbolic_friction_force(vt, -1.0, law, tuple(
        given.get(p.name, p.default) for p in FRICTION_PARAMETER_SPECS))


def _pair(sides, q, qt, cos, sin):
    """(e, de/dt (x, y each), omega_J, omega_B, the two points' arms from their centres of
    mass) of a journal-bearing pair of `_Side`s."""
    (xj, yj), (vxj, vyj), arm_j, wj = sides[0].kinematics(q, qt, cos, sin)
    (xb, yb), (vxb, vyb), arm_b, wb = sides[1].kinematics(q, qt, cos, sin)
    return xj - xb, yj - yb, vxj - vxb, vyj - vyb, wj, wb, arm_j, arm_b


def _film_loads(joint, sides, q, qt):
    """Generalized forces of the oil film of one lubricated joint on its bodies'
    coordinates: the film's force F on the journal centre and its torque T_J on the
    journal (`laws.lubrication.lubricated_force`, faded out near the wall), -F at the
    bearing's point and the bearing's torque -T_J - e x F (as the reduced model's
    `lubricated_stage`)."""
    dx, dy, vx, vy, wj, wb, (axj, ayj), (axb, ayb) = _pair(sides, q, qt, math.cos, math.sin)
    fx, fy, tj, _ = lubricated_force(
        dx, dy, vx, vy, wj, wb, joint.journal_radius, joint.clearance,
        joint.bearing_length, joint.viscosity, LUBRICATION_MODELS[joint.lubrication],
        joint.film_fade_start, joint.film_fade_end)
    tb = -tj - (dx * fy - dy * fx)
    out = [0.0] * (3 * sum(s.slot is not None for s in sides))
    for side, sign, (ax, ay), torque in ((sides[0], 1.0, (axj, ayj), tj),
                                         (sides[1], -1.0, (axb, ayb), tb)):
        if side.slot is not None:
            i = side.slot
            out[i], out[i + 1] = sign * fx, sign * fy
            out[i + 2] = sign * (ax * fy - ay * fx) + torque
    return out


def _friction_loads(joint, sides, q, qt, normal, friction, cos, sin, gate):
    """Generalized forces of the friction of one joint on its bodies' coordinates (the
    friction element's force vector): the tangential force Ft t on the journal at its
    point plus the moment R_J Ft, the opposite force on the bearing plus -R_B Ft, with
    vt = de/dt . t + omega_J R_J - omega_B R_B and Ft = friction_force(vt, Fn, ...)
    (`normal` gives |e| and Fn from e, de/dt; `friction` Ft from vt, Fn; `gate`(delta,
    value) is the value in contact and zero in free flight, where t is undefined when
    the journal is centred)."""
    journal, bearing = sides
    dx, dy, vx, vy, wj, wb, (axj, ayj), (axb, ayb) = _pair(sides, q, qt, cos, sin)
    r, fn = normal(dx, dy, vx, vy)
    tx, ty = -dy / r, dx / r
    vt = vx * tx + vy * ty + wj * joint.journal_radius - wb * joint.bearing_radius
    ft = friction(vt, fn)
    fx, fy = ft * tx, ft * ty
    out = [None] * (3 * sum(s.slot is not None for s in sides))
    delta = r - joint.clearance
    for side, sign, radius, (ax, ay) in ((journal, 1.0, joint.journal_radius, (axj, ayj)),
                                         (bearing, -1.0, joint.bearing_radius, (axb, ayb))):
        if side.slot is not None:
            i = side.slot
            out[i] = gate(delta, sign * fx)
            out[i + 1] = gate(delta, sign * fy)
            out[i + 2] = gate(delta, sign * (ax * fy - ay * fx + radius * ft))
    return out


def _pair_element(ctx, joint: ClearanceJoint):
    """(sides, element, n): the backend's generic element (``ctx.generic_element``) on the
    joint's bodies (journal first), n its number of coordinates."""
    sides, obj, node_list = ctx.generic_element(
        ctx.mbs, ((joint.journal_body, joint.journal_point),
                  (joint.bearing_body, joint.bearing_point)), ctx.nodes, ctx.pts)
    return sides, obj, 3 * len(node_list)


def _film_element(ctx, joint: ClearanceJoint):
    """Add the oil film of the lubricated `joint` as an `ObjectGenericODE2` on its bodies'
    nodes whose force is `_film_loads`, a Python user function calling the compiled law
    (not a symbolic one: the law's one formula is the compiled kernel, whose film ends are
    found by `atan2` (short) or by a search for the pressure's zeros (long), and an Exudyn
    expression of it would be a second formula of the same law)."""
    sides, obj, _ = _pair_element(ctx, joint)

    def force(mbs, t, itemNumber, q, q_t):
        return _film_loads(joint, sides, q, q_t)

    ctx.mbs.SetObjectParameter(obj, "forceUserFunction", force)
    ctx.keep_alive.append(force)
    return obj


def _friction_element(ctx, joint: ClearanceJoint, memory):
    """Add the friction of `joint` (friction on) as an `ObjectGenericODE2` on the two
    bodies' nodes whose force user function returns the generalized forces of
    `_friction_loads` (symbolic, or Python with contact.contact_force/friction_force)."""
    import exudyn as exu

    law, slots = friction_of(joint)
    K, c, xi, model = _law_constants(joint)
    sides, obj, n = _pair_element(ctx, joint)
    if ctx.settings.contact == "python":
        def normal(dx, dy, vx, vy):
            r = math.sqrt(dx * dx + dy * dy)
            if r <= c:
                return max(r, 1e-300), 0.0     # free flight (gated to 0); finite at centre
            rate = (dx * vx + dy * vy) / r
            return r, contact_force(r - c, rate, memory.dmin, K, joint.restitution, model)

        def force(mbs, t, itemNumber, q, q_t):
            return _friction_loads(joint, sides, q, q_t, normal,
                                   lambda vt, fn: friction_force_slots(vt, fn, slots, law),
                                   math.cos, math.sin,
                                   lambda delta, v: v if delta > 0.0 else 0.0)

        ctx.mbs.SetObjectParameter(obj, "forceUserFunction", force)
        ctx.keep_alive.append(force)
        return obj
    esym = exu.symbolic
    dmin = memory.symbol

    def normal(dx, dy, vx, vy):
        return _symbolic_normal(K, c, xi, dmin, dx, dy, vx, vy)

    def friction(vt, fn):
        return symbolic_friction_force(vt, fn, law, slots)

    zero = esym.Real(0.0)

    def force(mbs, t, itemNumber, q, q_t):
        # lazy gates: r > c > 0 inside the true branch (t = perp(e) / |e| is defined)
        return _friction_loads(joint, sides, q, q_t, normal, friction, esym.cos, esym.sin,
                               lambda delta, v: esym.IfThenElse(delta > 0.0, v, zero))

    uf = ctx.symbolic_vector_function(ctx.mbs, force, obj, n)
    ctx.mbs.SetObjectParameter(obj, "forceUserFunction", uf)
    ctx.keep_alive.append(uf)
    return obj


class _ProfileLookup:
    """A profiled joint's bearing radius R_B(theta) and slope, the spline's piece found by
    index (as `BearingProfile.radius`, without its per-call overhead)."""

    def __init__(self, joint: ClearanceJoint):
        profile = joint.profile
        self.pieces = profile.coefficients().tolist()
        self.h = 2.0 * math.pi / profile.points

    def __call__(self, theta: float) -> tuple[float, float]:
        """(R_B in m, dR_B/dtheta in m/rad) at theta in [0, 2 pi]."""
        i = min(int(theta / self.h), len(self.pieces) - 1)
        u = theta - i * self.h
        c0, c1, c2, c3 = self.pieces[i]
        return c0 + u * (c1 + u * (c2 + u * c3)), c1 + u * (2.0 * c2 + 3.0 * u * c3)


def _profile_stiffness(joint: ClearanceJoint):
    """K(R_B) in N/m^1.5 of a profiled joint: its explicit contact_stiffness, or the
    paper's Eq. 9 at the local bearing radius (the radius enters only through
    sqrt(R_J R_B / (R_B - R_J)))."""
    if joint.contact_stiffness is not None:
        K = float(joint.contact_stiffness)
        return lambda R: K
    rj, rb = joint.journal_radius, joint.bearing_radius
    factor = joint.stiffness / math.sqrt(rj * rb / (rb - rj))
    return lambda R: factor * math.sqrt(rj * R / (R - rj))


def _profile_geometry(joint: ClearanceJoint, lookup, dx, dy, vx, vy, phib, wb):
    """(r = |e|, theta_e, R_B(theta_e), delta, deltadot) of a profiled joint from the
    eccentricity e = (dx, dy) (m), its rate (m/s), the bearing body's angle phib (rad) and
    rate wb (rad/s): theta_e is e's direction in the bearing's frame in [0, 2 pi), delta =
    |e| - (R_B(theta_e) - R_J), deltadot = d|e|/dt - R_B'(theta_e) dtheta_e/dt with
    dtheta_e/dt = (ex eyd - ey exd) / |e|^2 - wb (0 for a centred journal)."""
    theta = _profile_geometry_angle(dx, dy, phib)
    R, slope = lookup(theta)
    r = math.sqrt(dx * dx + dy * dy)
    delta = r - (R - joint.journal_radius)
    if r == 0.0:
        return r, theta, R, delta, 0.0
    rate = (dx * vx + dy * vy) / r - slope * ((dx * vy - dy * vx) / (r * r) - wb)
    return r, theta, R, delta, rate


def _profile_geometry_angle(dx: float, dy: float, phib: float) -> float:
    """theta_e of the eccentricity (dx, dy) in the frame of a bearing body at angle phib,
    in [0, 2 pi)."""
    co, si = math.cos(phib), math.sin(phib)
    theta = math.atan2(co * dy - si * dx, co * dx + si * dy)
    return theta + 2.0 * math.pi if theta < 0.0 else theta


def _profile_loads(joint, sides, q, qt, lookup, normal, friction):
    """Generalized forces of a profiled joint's contact (and friction) on its bodies'
    coordinates: the normal force Fn g (g = n - (R_B'(theta_e) / |e|) t, the gap's gradient,
    n = e/|e|, Fn = `normal`(delta, deltadot, R_B)) on the bearing at its point and -Fn g on
    the journal at its; with `friction` (Ft from v_t, Fn; None without) Ft t on the journal
    plus the moment R_J Ft, the opposite force on the bearing plus -bearing_radius Ft,
    v_t = de/dt . t + omega_J R_J - omega_B R_B(theta_e), t = (-n_y, n_x). Zero in free
    flight."""
    out = [0.0] * (3 * sum(s.slot is not None for s in sides))
    dx, dy, vx, vy, wj, wb, (axj, ayj), (axb, ayb) = _pair(sides, q, qt, math.cos, math.sin)
    r, theta, R, delta, rate = _profile_geometry(joint, lookup, dx, dy, vx, vy,
                                                 sides[1].angle(q), wb)
    if delta <= 0.0:
        return out
    nx, ny = dx / r, dy / r
    fn = normal(delta, rate, R)
    # along the gap's gradient n - (R_B' / |e|) t, as the reduced model
    # (core/profile_runtime.h): a radial force on a non-round boundary does work round a
    # closed path
    k = lookup(theta)[1] / r
    fx, fy, ft = -fn * (nx + k * ny), -fn * (ny - k * nx), 0.0      # on the journal
    if friction is not None:
        vt = (vy * nx - vx * ny) + (wj * joint.journal_radius - wb * R)
        ft = friction(vt, fn)
        fx, fy = fx - ft * ny, fy + ft * nx
    # friction's moment on the bearing with the arm bearing_radius, as the reduced model
    for side, sign, radius, (ax, ay) in ((sides[0], 1.0, joint.journal_radius, (axj, ayj)),
                                         (sides[1], -1.0, joint.bearing_radius, (axb, ayb))):
        if side.slot is not None:
            i = side.slot
            out[i], out[i + 1] = sign * fx, sign * fy
            out[i + 2] = sign * (ax * fy - ay * fx + radius * ft)
    return out


def _profile_element(ctx, joint: ClearanceJoint, memory):
    """Add a profiled joint's contact and friction as one `ObjectGenericODE2` on its bodies'
    nodes whose force is `_profile_loads`, a Python user function with
    contact.contact_force and friction_force (the force needs the bearing body's angle,
    which a connector's user function does not see; Exudyn's symbolic layer can express the
    spline's lookup, as a tree of IfThenElse on the piece index, but its generic-element
    function ran 30 times slower than this one, docs/exudyn.md). Returns (element, the
    joint's (delta, deltadot) function of mbs for the pre-step function)."""
    sides, obj, _ = _pair_element(ctx, joint)
    _, _, _, model = _law_constants(joint)
    fric = friction_of(joint)
    lookup = _ProfileLookup(joint)
    stiffness = _profile_stiffness(joint)

    def normal(delta, rate, R):
        return contact_force(delta, rate, memory.dmin, stiffness(R), joint.restitution, model)

    friction = (None if fric is None else
                lambda vt, fn: friction_force_slots(vt, fn, fric[1], fric[0]))

    def force(mbs, t, itemNumber, q, q_t):
        return _profile_loads(joint, sides, q, q_t, lookup, normal, friction)

    ctx.mbs.SetObjectParameter(obj, "forceUserFunction", force)
    ctx.keep_alive.append(force)
    state = ctx.node_state([ctx.nodes[b] for b in (joint.journal_body, joint.bearing_body)
                            if b != GROUND])

    def gap(mbs):
        q, qt = state(mbs)
        dx, dy, vx, vy, _, wb, _, _ = _pair(sides, q, qt, math.cos, math.sin)
        return _profile_geometry(joint, lookup, dx, dy, vx, vy, sides[1].angle(q), wb)[3:]

    return obj, gap


def _pair_series(ctx, joint: ClearanceJoint):
    """(e, de/dt, omega_J, phi_B, omega_B) of a clearance joint at every sample ``ctx.t``
    from the stored body states (``ctx.motion``): e the journal centre minus the bearing
    centre (m), the bodies' rates in rad/s, the bearing body's angle in rad (0 for the
    ground)."""
    pts, t = ctx.points, ctx.t

    def point(body, name):
        if body == GROUND:
            p = np.asarray(pts[GROUND][name], dtype=float)
            zero = np.zeros(len(t))
            return np.tile(p, (len(t), 1)), np.zeros((len(t), 2)), zero, zero
        q, v = ctx.motion(body)
        x, y = pts[body][name]
        co, si = np.cos(q[:, 2]), np.sin(q[:, 2])
        arm = np.column_stack([co * x - si * y, si * x + co * y])
        return (q[:, :2] + arm, v[:, :2] + v[:, 2:3] * np.column_stack([-arm[:, 1], arm[:, 0]]),
                q[:, 2], v[:, 2])

    rj, vj, _, wj = point(joint.journal_body, joint.journal_point)
    rb, vb, phib, wb = point(joint.bearing_body, joint.bearing_point)
    return rj - rb, vj - vb, wj, phib, wb


def _clearance_series(ctx, joint: ClearanceJoint, memory) -> dict:
    """The series of a clearance joint at every kept sample, from the stored body states:
    "contact_angle" theta_e (rad, e's direction in the bearing body's frame, in
    [0, 2 pi)) and "slip_velocity" v_t = de/dt . t + omega_J R_J - omega_B R_B(theta_e)
    (m/s; t = (-n_y, n_x), n = e/|e|, or the direction theta_e when the journal is
    centred). A profiled joint's also "eccentricity" e (n, 2), "penetration" |e| -
    (R_B(theta_e) - R_J) and "force" Fn (N; `_profile_geometry`); a joint with friction
    "friction_power" Ft v_t (W, <= 0). The forces are contact.contact_force /
    friction_force (the Python variant's law) with the impact velocity in force at each
    step (``ctx.impact_velocity``)."""
    t = ctx.t
    e, ed, wj, phib, wb = _pair_series(ctx, joint)
    r = np.hypot(e[:, 0], e[:, 1])
    co, si = np.cos(phib), np.sin(phib)
    theta = np.mod(np.arctan2(co * e[:, 1] - si * e[:, 0], co * e[:, 0] + si * e[:, 1]),
                   2.0 * np.pi)
    profile = joint.profile
    R = (np.full(len(t), joint.bearing_radius) if profile is None
         else np.asarray(profile.radius(theta)))
    with np.errstate(invalid="ignore", divide="ignore"):
        n = np.where(r[:, None] > 0.0, e / r[:, None],
                     np.column_stack([np.cos(theta + phib), np.sin(theta + phib)]))
    vt = (ed[:, 1] * n[:, 0] - ed[:, 0] * n[:, 1]) + (wj * joint.journal_radius - wb * R)
    out = {"contact_angle": theta, "slip_velocity": vt}
    fric = friction_of(joint)
    if profile is None and fric is None:
        return out
    _, _, _, cmodel = _law_constants(joint)
    stiffness = _profile_stiffness(joint) if profile is not None else None
    dmin = ctx.impact_velocity(memory)
    delta = r - (R - joint.journal_radius) if profile is not None else r - joint.clearance
    force = np.zeros(len(t))
    power = np.zeros(len(t))
    slope = None if profile is None else np.asarray(profile.radius(theta, 1))
    for i in np.nonzero(delta > 0.0)[0]:
        rate = float(ed[i] @ n[i])
        K = joint.stiffness
        if profile is not None:
            rate -= slope[i] * ((e[i, 0] * ed[i, 1] - e[i, 1] * ed[i, 0]) / (r[i] * r[i])
                                - wb[i])
            K = stiffness(R[i])
        force[i] = contact_force(delta[i], rate, float(dmin[i]), K, joint.restitution, cmodel)
        if fric is not None:
            power[i] = friction_force_slots(vt[i], force[i], fric[1], fric[0]) * vt[i]
    if fric is not None:
        out["friction_power"] = power
    if profile is not None:
        out.update(eccentricity=e, penetration=delta, force=force)
    return out


def _connector_gap(obj, clearance: float):
    """Function of mbs: (delta, deltadot) of a joint's contact connector `obj` from its
    Displacement d and Velocity v (journal relative to bearing): |d| - c, d.v/|d| (0 when
    centred)."""
    import exudyn as exu

    disp = exu.OutputVariableType.Displacement
    vel = exu.OutputVariableType.Velocity

    def gap(mbs):
        d = mbs.GetObjectOutput(obj, disp)
        v = mbs.GetObjectOutput(obj, vel)
        r = math.sqrt(d[0] * d[0] + d[1] * d[1])
        return r - clearance, ((d[0] * v[0] + d[1] * v[1]) / r if r > 0.0 else 0.0)

    return gap


#: the element of the registry
ELEMENT = RevoluteClearance()
