"""Exact Jacobians of a `Derivation` for direct differentiation (DDM), and their code.

The generated kernel `jacobian(t, y, p, jac, full)` gives the total derivatives of the
model's quantities with respect to z = [t, q, qdot, p[:CONST_START]] (every entry of the
parameter vector, the clearance joints' impact-velocity memory included), in the contact
modes of p, at fixed t and state (column 0 is the partial derivative in t). With the
accelerations A as symbols, the equations of motion are R(z, A, F) = M A - f = 0, so

    dA/dz = -M^{-1} (dR/dz + dR/dFX dFX/dz + dR/dFY dFY/dz),

solved in the kernel with the Cholesky factors of M, as the plain model solves for A. The
contact forces' derivatives come from the contact law (`contact_jacobian` of
core/jac_runtime.h, one place with `forces.contact_force_partials`); everything else is
differentiated symbolically
(sympy, through the sines and cosines of the base angles by the chain rule) and written with
parameter-only constants, as the plain kernels are.

Rows of jac (flat, stride N_Z + 1; column N_Z holds the value): OUT_COLUMNS, then per
clearance joint the journal centre's velocity relative to the bearing (x, y) and the contact
force components (x, y) on the bearing's side, then per joint with friction the rotation
part of the slip velocity (omega_J R_J - omega_B R_B); the friction force's derivatives come
from `friction_jacobian` of core/jac_runtime.h (the friction law's partials), its moments enter the
equations of motion through the symbol TQ. `full=False` fills the rows of the clearance
joints and the accelerations only (what the sensitivity equations need).

The plan (`jacobian_plan`) is printed in C for the compiled core (`cjacobians`).
"""

from __future__ import annotations

from types import SimpleNamespace

import sympy as sp

from ..elements.registry import ELEMENTS
from .derive import Derivation

__all__ = ["jacobian_plan", "emit_body", "z_columns"]


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


def jacobian_plan(w, d: Derivation, out_columns: list[str], parts: dict) -> SimpleNamespace:
    """The stages of the kernels `jacobian` (every column of z) and `tangent` (the
    directional derivatives along given seeds dz, from the same derivative expressions),
    one plan printed in python (`jacobian_context`) and in C (`cjacobians`): each stage
    (exprs, names[, post]) or a list of lines in python's syntax (assignments, `for` and
    `if` blocks, calls of the elements' rows), and the layout. `parts`: the elements' plans
    of the model evaluation (`Element.plan`)."""
    n = len(d.Q)
    if d.t not in w.vars:
        # time enters the derivatives explicitly (d angle / d speed = t): not a constant
        w.vars.append(d.t)
    cols = z_columns(d)
    nz = len(cols)
    stride = nz + 1
    n_out = len(out_columns)
    row = {c: i for i, c in enumerate(out_columns)}
    extra = {}
    n_rows = n_out
    # the elements' rows after the outputs (each element's contacts numbered from `first`)
    first = {}
    for el in ELEMENTS:
        first[el.kind] = sum(len(d.parts[k].contacts) for k in first)
        rows = el.jacobian_rows(d.parts[el.kind], first[el.kind], n_rows)
        extra.update(rows)
        n_rows += len(rows)
    params = list(d.parameters)
    pcol = {name: 1 + 2 * n + i for i, name in enumerate(params)}

    def grad(e):
        return {k: w.split(der) for k, der in _gradient(d, e, cols).items()}

    # Each stage is built twice from the same (split) expressions: for `jacobian` (J: the
    # derivative of row r along column k into jac[r * stride + k]) and for `tangent` (T:
    # the derivatives as locals, contracted with the seeds in a loop over the directions d:
    # out[r * ts + d] = sum_k der_k dz[d * N_Z + k], ts = nd + 1, the value in column nd;
    # the seeds' state part, direction d's state sensitivity, read from y[2 N_Q (d + 1):]).
    def at(r, c):
        return f"jac[{r * stride + c}]"

    def contract(terms):
        """sum over the state columns k (1 .. 2 N_Q) of der_k times the seed's, y[yo + k - 1]."""
        return " + ".join(f"{v} * y[yo + {k - 1}]" for k, v in terms) or "0.0"

    n2 = 2 * n
    masked_cols: set[int] = set()

    def masked(rows_terms, head=None, tail=None):
        """The post-processing of a tangent stage: rows_terms is a list of (target, {k:
        local name}, extra terms). The state columns (q, qdot: every direction uses them)
        are contracted in one loop over the directions; the derivatives along each other
        column (time: no DDM direction moves it; the parameters) are computed and added
        only to the directions whose seed uses that column (the lists in `use`, see
        sens_runtime.seed_index)."""
        by_name = {}
        for _, terms, _ in rows_terms:
            for k, v in terms.items():
                if k > n2 or k == 0:
                    by_name[v] = k
                    masked_cols.add(k)

        def post(lines):
            keep, blocks = [], {}
            for ln in lines:
                lhs = ln.split(" = ", 1)[0]
                if lhs in by_name:
                    blocks.setdefault(by_name[lhs], []).append(ln)
                else:
                    keep.append(ln)
            loop = ["for d in range(nd):", f"    yo = {n2} * (d + 1)"]
            for tgt, terms, extra_terms in rows_terms:
                dense = [contract([(k, v) for k, v in terms.items() if 0 < k <= n2])]
                loop.append(f"    {tgt} = " + " + ".join(dense + extra_terms))
            out = keep + (head or []) + loop
            for k in sorted(blocks):
                out.append(f"if use[{k + 1}] > use[{k}]:")
                out += ["    " + ln for ln in blocks[k]]
                out += [f"    for e in range(int(use[{k}]), int(use[{k + 1}])):",
                        f"        d = int(use[{nz + 1} + e])",
                        f"        dk = dz[d * {nz} + {k}]"]
                for tgt, terms, _ in rows_terms:
                    if k in terms:
                        out.append(f"        {tgt} += {terms[k]} * dk")
            return out + (tail or [])
        return post

    # ---- the contacts' gaps (and what the elements compute beside them): values and
    # partials
    gap_items = []          # (value name or None, row, expression, gradient)
    events = d.events
    for j, gap in enumerate(d.gaps):
        rows4 = [row[f"{events[j]}.ecc_x"], row[f"{events[j]}.ecc_y"],
                 extra[("exd", j)], extra[("eyd", j)]]
        for c, e in enumerate(gap):
            gap_items.append((f"gv{j}_{c}", rows4[c], w.split(e), grad(e)))
    for el in ELEMENTS:
        for _, name, key, e in parts[el.kind].gap_extras:
            gap_items.append((name, extra[key], w.split(e), grad(e)))
    J_stages, T_stages = [], []
    gx, gn, tx, tn, trows = [], [], [], [], []
    for name, r, e, g in gap_items:
        gx.append(e)
        gn.append(name)
        tx.append(e)
        tn.append(name)
        for k, der in g.items():
            gx.append(der)
            gn.append(at(r, k))
            tx.append(der)
            tn.append(f"g{r}_{k}")
        trows.append((f"out[{r} * ts + d]", {k: f"g{r}_{k}" for k in g}, []))
    J_stages.append((gx, gn))
    T_stages.append((tx, tn, masked(trows)))

    # ---- the contact (and friction) forces: one place each, sens_runtime
    jlines, tlines = [], []
    ctx = SimpleNamespace(row=row, extra=extra, pcol=pcol, n=n, stride=stride, nz=nz)
    for el in ELEMENTS:
        jl, tl = el.jacobian_lines(d.parts[el.kind], first[el.kind], ctx)
        jlines += jl
        tlines += tl
    J_stages.append(jlines)
    T_stages.append(tlines)

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
    values = [(mexprs, mnames), _cholesky_lines(n),
              _solve(n, [f"f_{i}" for i in range(n)], [str(a) for a in A], "")]
    J_stages += values
    T_stages += values
    acc_rows = [row[f"{c}.acc"] for c in d.coordinates]
    rx, rn, trn = [], [], []
    rgrad = []
    loads = []              # (symbol, its row, coefficient name stem, contact)
    for el in ELEMENTS:
        loads += el.force_loads(d.parts[el.kind], first[el.kind], row, extra)
    for i in range(n):
        g = grad(R[i])
        rgrad.append(g)
        for k, der in g.items():
            rx.append(der)
            rn.append(at(acc_rows[i], k))
            trn.append(f"r{i}_{k}")
        for F, _, stem, jj in loads:
            rx.append(w.split(sp.expand(sp.diff(R[i], F))))
            rn.append(f"{stem}_{i}_{jj}")
            trn.append(f"{stem}_{i}_{jj}")
    J_stages.append((rx, rn))

    def load_terms(i, col, tab, st):
        out = []
        for _, frow, stem, jj in loads:
            out.append(f"{stem}_{i}_{jj} * {tab}[{frow} * {st} + {col}]")
        return out

    loop = [f"for col in range({nz}):"]
    for i in range(n):
        terms = [f"jac[{acc_rows[i] * stride} + col]"] + load_terms(i, "col", "jac",
                                                                     stride)
        loop.append(f"    b_{i} = -(" + " + ".join(terms) + ")")
    loop += _solve(n, [f"b_{i}" for i in range(n)], [f"x_{i}" for i in range(n)], "    ")
    for i in range(n):
        loop.append(f"    jac[{acc_rows[i] * stride} + col] = x_{i}")
    for i in range(n):
        loop.append(f"{at(acc_rows[i], nz)} = {A[i]}")
    J_stages.append(loop)
    # (the tangent: dR/dz dz into the accelerations' rows, then the solve in place)
    tloop = ["for d in range(nd):"]
    for i in range(n):
        terms = [f"out[{acc_rows[i]} * ts + d]"] + load_terms(i, "d", "out", "ts")
        tloop.append(f"    b_{i} = -(" + " + ".join(terms) + ")")
    tloop += _solve(n, [f"b_{i}" for i in range(n)], [f"x_{i}" for i in range(n)], "    ")
    for i in range(n):
        tloop.append(f"    out[{acc_rows[i]} * ts + d] = x_{i}")
    for i in range(n):
        tloop.append(f"out[{acc_rows[i]} * ts + nd] = {A[i]}")
    T_stages.append((rx, trn, masked(
        [(f"out[{acc_rows[i]} * ts + d]", {k: f"r{i}_{k}" for k in rgrad[i]}, [])
         for i in range(n)], tail=tloop)))

    # ---- the drive moment's value (the work's rate) in every call (a free linkage: none)
    mom = row.get("drive_moment", -1)
    if mom >= 0:
        mom_e = w.split(d.drive_moment)
        J_stages.append(([mom_e], [at(mom, nz)]))
        T_stages.append(([mom_e], [f"out[{mom} * ts + nd]"]))

    # ---- full: the reactions and the drive moment with their derivatives
    outs = [(row[f"{g}.reaction_{xy}"], d.reactions[gi][k])
            for gi, g in enumerate(d.ground_joints) for k, xy in enumerate("xy")]
    if mom >= 0:
        outs.append((mom, d.drive_moment))
    oexprs, onames, tonames, oloop, trows_full = [], [], [], [], []
    for m, (r, e) in enumerate(outs):
        e = sp.expand(e)
        if r != mom:
            oexprs.append(w.split(e))
            onames.append(at(r, nz))
            tonames.append(f"out[{r} * ts + nd]")
        g = grad(e)
        for k, der in g.items():
            oexprs.append(der)
            onames.append(at(r, k))
            tonames.append(f"o{r}_{k}")
        terms, tterms = [], []
        for i in range(n):
            c = sp.expand(sp.diff(e, A[i]))
            if c != 0:
                oexprs.append(w.split(c))
                onames.append(f"oa_{m}_{i}")
                tonames.append(f"oa_{m}_{i}")
                terms.append(f"oa_{m}_{i} * jac[{acc_rows[i] * stride} + col]")
                tterms.append(f"oa_{m}_{i} * out[{acc_rows[i]} * ts + d]")
        for j, lds in (item for el in ELEMENTS for item in el.output_loads(
                d.parts[el.kind], first[el.kind], row, extra)):
            for what, F, frow in lds:
                c = sp.expand(sp.diff(e, F))
                if c != 0:
                    oexprs.append(w.split(c))
                    onames.append(f"o{what}_{m}_{j}")
                    tonames.append(f"o{what}_{m}_{j}")
                    terms.append(f"o{what}_{m}_{j} * jac[{frow * stride} + col]")
                    tterms.append(f"o{what}_{m}_{j} * out[{frow} * ts + d]")
        if terms:
            oloop.append(f"    jac[{r * stride} + col] += " + " + ".join(terms))
        trows_full.append((f"out[{r} * ts + d]", {k: f"o{r}_{k}" for k in g}, tterms))
    shake, tshake = [], []
    for xy in "xy":
        rs = [row[f"{g}.reaction_{xy}"] for g in d.ground_joints]
        tgt = row[f"shaking_{xy}"]
        shake.append(f"for col in range({stride}):")
        shake.append(f"    jac[{tgt * stride} + col] = "
                     + (" + ".join(f"jac[{r * stride} + col]" for r in rs) or "0.0"))
        tshake.append("for col in range(ts):")
        tshake.append(f"    out[{tgt} * ts + col] = "
                      + (" + ".join(f"out[{r} * ts + col]" for r in rs) or "0.0"))

    extra_syms = {*d.A, *d.load_symbols}

    oloop = ([f"for col in range({nz}):"] + oloop) if oloop else []
    return SimpleNamespace(
        jac_stages=J_stages, tan_stages=T_stages, extra_syms=extra_syms,
        jac_full=(oexprs, onames, lambda ls: ls + oloop + shake),
        tan_full=(oexprs, tonames, masked(trows_full, tail=tshake)),
        n_z=nz, jac_stride=stride, n_jrows=n_rows,
        z_names=["t", *(f"{c}" for c in d.coordinates),
                 *(f"{c}.rate" for c in d.coordinates), *params],
        jac_extra={f"{what}:{events[j]}": r for (what, j), r in extra.items()})


def emit_body(stages: list, full_stage: tuple, stage, preamble) -> tuple[list, list, list]:
    """(preamble, body, full-only body) of a kernel from the plan's stages: each stage
    (exprs, names[, post]) printed by `stage(exprs, names, temps)` (post: a function of its
    lines), or a list of lines taken as they are; `preamble(used)` loads what the printed
    expressions use (the accelerations and forces are the kernel's own)."""
    temps = sp.numbered_symbols("x")
    used, body = set(), []
    for st in [*stages, full_stage]:
        if isinstance(st, tuple):
            u, ls = stage(*st[:2], temps)
            used |= u
            body.append(st[2](ls) if len(st) > 2 else ls)
        else:
            body.append(st)
    return preamble(used), [ln for b in body[:-1] for ln in b], body[-1]


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
