"""Exact Jacobians of a `Derivation` for direct differentiation (DDM), and their code.

The generated kernel `jacobian(t, y, p, jac, full)` gives the total derivatives of the
model's quantities with respect to z = [t, q, qdot, p[:CONST_START]] (every entry of the
parameter vector, the clearance joints' impact-velocity memory included), in the contact
modes of p, at fixed t and state (column 0 is the partial derivative in t). With the
accelerations A as symbols, the equations of motion are R(z, A, F) = M A - f = 0, so

    dA/dz = -M^{-1} (dR/dz + dR/dFX dFX/dz + dR/dFY dFY/dz),

solved in the kernel with the Cholesky factors of M, as the plain model solves for A. The
contact forces' derivatives come from the contact law (`runtime.contact_jacobian`, one place
with `contact.contact_force_partials`); everything else is differentiated symbolically
(sympy, through the sines and cosines of the base angles by the chain rule) and written with
parameter-only constants, as the plain kernels are.

Rows of jac (flat, stride N_Z + 1; column N_Z holds the value): OUT_COLUMNS, then per
clearance joint the journal centre's velocity relative to the bearing (x, y) and the contact
force components (x, y) on the bearing's side, then per joint with friction the rotation
part of the slip velocity (omega_J R_J - omega_B R_B); the friction force's derivatives come
from `runtime.friction_jacobian` (`contact.friction_force_partials`), its moments enter the
equations of motion through the symbol TQ. `full=False` fills the rows of the clearance
joints and the accelerations only (what the sensitivity equations need).
"""

from __future__ import annotations

import sympy as sp

from .derive import Derivation

__all__ = ["jacobian_context", "z_columns"]


def z_columns(d: Derivation) -> list:
    """The symbols of z in column order: t, Q, U, then the parameters (p order)."""
    return [d.t, *d.Q, *d.U, *(d.psyms[n] for n in d.parameters)]


def _diff(d: Derivation, expr: sp.Expr, var) -> sp.Expr:
    """d expr / d var with the chain rule through the trig symbols S_k, C_k of the base
    angles a_k (dS = C da, dC = -S da)."""
    out = sp.diff(expr, var)
    for a, S, C in d.angles:
        da = sp.diff(a, var)
        if da != 0 and (expr.has(S) or expr.has(C)):
            out += (sp.diff(expr, S) * C - sp.diff(expr, C) * S) * da
    return sp.expand(out)


def _gradient(d: Derivation, expr: sp.Expr, cols: list) -> dict[int, sp.Expr]:
    """The nonzero partial derivatives of expr along the z columns {col: derivative}."""
    out = {}
    free = expr.free_symbols
    angle_syms = {s for _, S, C in d.angles for s in (S, C)}
    for k, var in enumerate(cols):
        if var not in free and not (free & angle_syms):
            continue
        der = _diff(d, expr, var)
        if der != 0:
            out[k] = der
    return out


def jacobian_context(w, d: Derivation, out_columns: list[str]) -> dict:
    """Template variables of jacobians.py.jinja: the body of `jacobian` and the layout."""
    n, J = len(d.Q), len(d.joints)
    if d.t not in w.vars:
        # time enters the derivatives explicitly (d angle / d speed = t): not a constant
        w.vars.append(d.t)
    cols = z_columns(d)
    nz = len(cols)
    stride = nz + 1
    n_out = len(out_columns)
    row = {c: i for i, c in enumerate(out_columns)}
    extra = {}
    for j in range(J):
        for k, what in enumerate(("exd", "eyd", "fx", "fy")):
            extra[(what, j)] = n_out + 4 * j + k
    fric = [j for j in range(J) if d.TQ[j] is not None]
    for k, j in enumerate(fric):
        extra[("spin", j)] = n_out + 4 * J + k
    n_rows = n_out + 4 * J + len(fric)
    params = list(d.parameters)
    pcol = {name: 1 + 2 * n + i for i, name in enumerate(params)}

    def at(r, c):
        return f"jac[{r * stride + c}]"

    # ---- the gaps of the clearance joints: values and partials
    gap_rows = []
    for j, name in enumerate(d.joints):
        gap_rows.append([row[f"{name}.ecc_x"], row[f"{name}.ecc_y"], extra[("exd", j)],
                         extra[("eyd", j)]])
    gexprs, gnames = [], []
    for j, gap in enumerate(d.gaps):
        for c, e in enumerate(gap):
            r = gap_rows[j][c]
            gexprs.append(w.split(e))
            gnames.append(f"gv{j}_{c}")
            for k, der in _gradient(d, e, cols).items():
                gexprs.append(w.split(der))
                gnames.append(at(r, k))
    for j in fric:
        gexprs.append(w.split(d.spins[j]))
        gnames.append(f"gv{j}_4")
        for k, der in _gradient(d, d.spins[j], cols).items():
            gexprs.append(w.split(der))
            gnames.append(at(extra[("spin", j)], k))
    stages = [(gexprs, gnames)]
    clines = []
    for j, name in enumerate(d.joints):
        rows = [row[f"{name}.{f}"] for f in ("contact_force", "penetration",
                                             "penetration_rate", "ecc_x", "ecc_y")]
        rows += [extra[(what, j)] for what in ("exd", "eyd", "fx", "fy")]
        zc = [pcol[f"{name}.{f}"] for f in ("clearance", "stiffness", "restitution",
                                            "impact_velocity")]
        pv = [f"p[{pcol[f'{name}.{f}'] - 1 - 2 * n}]" for f in (
            "clearance", "mode", "impact_velocity", "stiffness", "restitution",
            "contact_model")]
        clines.append(f"{d.FX[j]}, {d.FY[j]} = contact_jacobian(jac, {stride}, {nz}, "
                      f"gv{j}_0, gv{j}_1, gv{j}_2, gv{j}_3, "
                      + ", ".join(str(v) for v in rows + zc) + ", " + ", ".join(pv) + ")")
        if j in fric:
            frows = [row[f"{name}.{f}"] for f in ("ecc_x", "ecc_y")] + [
                extra[(what, j)] for what in ("exd", "eyd", "spin")] + [
                row[f"{name}.contact_force"], extra[("fx", j)], extra[("fy", j)]] + [
                row[f"{name}.{f}"] for f in ("friction_force", "slip_velocity",
                                             "friction_power")]
            fc = [pcol[f"{name}.{f}"] for f in ("friction_coefficient", "friction_v0",
                                                "friction_v1")]
            fv = [f"p[{pcol[f'{name}.{f}'] - 1 - 2 * n}]" for f in (
                "friction_law", "friction_coefficient", "friction_v0", "friction_v1")]
            clines.append(f"{d.FX[j]}, {d.FY[j]}, {d.TQ[j]} = friction_jacobian(jac, {stride}, "
                          f"{nz}, gv{j}_4, " + ", ".join(str(v) for v in frows + fc) + ", "
                          + ", ".join(fv) + ")")
    stages.append(clines)

    # ---- the equations of motion: values (Cholesky of M), then dA/dz
    A = d.A
    R = [sum((d.mass_matrix[i, k] * A[k] for k in range(n)), sp.S(0)) - d.forcing[i]
         for i in range(n)]
    mexprs, mnames = [], []
    for i in range(n):
        for k in range(i + 1):
            mexprs.append(w.split(d.mass_matrix[i, k]))
            mnames.append(f"m_{i}_{k}")
    for i in range(n):
        mexprs.append(w.split(d.forcing[i]))
        mnames.append(f"f_{i}")
    stages.append((mexprs, mnames))
    stages.append(_cholesky_lines(n))
    stages.append(_solve(n, [f"f_{i}" for i in range(n)], [str(a) for a in A], ""))
    acc_rows = [row[f"{c}.acc"] for c in d.coordinates]
    rexprs, rnames = [], []
    for i in range(n):
        for k, der in _gradient(d, R[i], cols).items():
            rexprs.append(w.split(der))
            rnames.append(at(acc_rows[i], k))
        for j in range(J):
            rexprs.append(w.split(sp.expand(sp.diff(R[i], d.FX[j]))))
            rnames.append(f"rfx_{i}_{j}")
            rexprs.append(w.split(sp.expand(sp.diff(R[i], d.FY[j]))))
            rnames.append(f"rfy_{i}_{j}")
            if j in fric:
                rexprs.append(w.split(sp.expand(sp.diff(R[i], d.TQ[j]))))
                rnames.append(f"rtq_{i}_{j}")
    stages.append((rexprs, rnames))
    loop = [f"for col in range({nz}):"]
    for i in range(n):
        terms = [f"jac[{acc_rows[i] * stride} + col]"]
        for j in range(J):
            terms.append(f"rfx_{i}_{j} * jac[{extra[('fx', j)] * stride} + col]")
            terms.append(f"rfy_{i}_{j} * jac[{extra[('fy', j)] * stride} + col]")
            if j in fric:
                ft_row = row[f"{d.joints[j]}.friction_force"]
                terms.append(f"rtq_{i}_{j} * jac[{ft_row * stride} + col]")
        loop.append(f"    b_{i} = -(" + " + ".join(terms) + ")")
    loop += _solve(n, [f"b_{i}" for i in range(n)], [f"x_{i}" for i in range(n)], "    ")
    for i in range(n):
        loop.append(f"    jac[{acc_rows[i] * stride} + col] = x_{i}")
    for i in range(n):
        loop.append(f"{at(acc_rows[i], nz)} = {A[i]}")
    stages.append(loop)

    # ---- the drive moment's value (the work's rate) in every call
    mom = row["drive_moment"]
    stages.append(([w.split(d.drive_moment)], [at(mom, nz)]))

    # ---- full: the reactions and the drive moment with their derivatives
    outs = [(row[f"{g}.reaction_{xy}"], d.reactions[gi][k])
            for gi, g in enumerate(d.ground_joints) for k, xy in enumerate("xy")]
    outs.append((mom, d.drive_moment))
    oexprs, onames, oloop = [], [], []
    for m, (r, e) in enumerate(outs):
        e = sp.expand(e)
        if r != mom:
            oexprs.append(w.split(e))
            onames.append(at(r, nz))
        for k, der in _gradient(d, e, cols).items():
            oexprs.append(w.split(der))
            onames.append(at(r, k))
        terms = []
        for i in range(n):
            c = sp.expand(sp.diff(e, A[i]))
            if c != 0:
                oexprs.append(w.split(c))
                onames.append(f"oa_{m}_{i}")
                terms.append(f"oa_{m}_{i} * jac[{acc_rows[i] * stride} + col]")
        for j in range(J):
            loads = [("fx", d.FX[j], extra[("fx", j)]), ("fy", d.FY[j], extra[("fy", j)])]
            if j in fric:
                loads.append(("tq", d.TQ[j], row[f"{d.joints[j]}.friction_force"]))
            for what, F, frow in loads:
                c = sp.expand(sp.diff(e, F))
                if c != 0:
                    oexprs.append(w.split(c))
                    onames.append(f"o{what}_{m}_{j}")
                    terms.append(f"o{what}_{m}_{j} * jac[{frow * stride} + col]")
        if terms:
            oloop.append(f"    jac[{r * stride} + col] += " + " + ".join(terms))
    full_stage = (oexprs, onames)
    shake = []
    for xy in "xy":
        rs = [row[f"{g}.reaction_{xy}"] for g in d.ground_joints]
        tgt = row[f"shaking_{xy}"]
        shake.append(f"for col in range({stride}):")
        shake.append(f"    jac[{tgt * stride} + col] = "
                     + (" + ".join(f"jac[{r * stride} + col]" for r in rs) or "0.0"))

    temps = sp.numbered_symbols("x")
    used, body = set(), []
    for st in stages:
        if isinstance(st, tuple):
            u, ls = w.stage(*st, temps)
            used |= u
            body += ls
        else:
            body += st
    fu, fl = w.stage(*full_stage, temps)
    used |= fu
    extra_syms = {*d.A, *d.FX, *d.FY, *(d.TQ[j] for j in fric)}
    used -= extra_syms
    if oloop:
        full_body = fl + [f"for col in range({nz}):"] + oloop + shake
    else:
        full_body = fl + shake
    pre = w.preamble(used)
    code = ["    " + ln for ln in pre + body]
    code.append("    if full:")
    code += ["        " + ln for ln in full_body]
    return dict(jac_body=code, n_z=nz, jac_stride=stride, n_jrows=n_rows,
                z_names=["t", *(f"{c}" for c in d.coordinates),
                         *(f"{c}.rate" for c in d.coordinates), *params],
                jac_extra={f"{what}:{d.joints[j]}": r for (what, j), r in extra.items()})


def _cholesky_lines(n: int) -> list[str]:
    lines = []
    for j in range(n):
        s = " - ".join([f"m_{j}_{j}"] + [f"l_{j}_{k} * l_{j}_{k}" for k in range(j)])
        lines.append(f"l_{j}_{j} = math.sqrt({s})")
        lines.append(f"il_{j} = 1.0 / l_{j}_{j}")
        for i in range(j + 1, n):
            s = " - ".join([f"m_{i}_{j}"] + [f"l_{i}_{k} * l_{j}_{k}" for k in range(j)])
            lines.append(f"l_{i}_{j} = ({s}) * il_{j}")
    return lines


def _solve(n: int, rhs: list[str], out: list[str], indent: str) -> list[str]:
    """Lines solving L L^T x = rhs with the factors l_i_k (il_i = 1 / l_i_i)."""
    lines = []
    for i in range(n):
        s = " - ".join([rhs[i]] + [f"l_{i}_{k} * zz_{k}" for k in range(i)])
        lines.append(f"{indent}zz_{i} = ({s}) * il_{i}")
    for i in reversed(range(n)):
        s = " - ".join([f"zz_{i}"] + [f"l_{k}_{i} * {out[k]}" for k in range(i + 1, n)])
        lines.append(f"{indent}{out[i]} = ({s}) * il_{i}")
    return lines
