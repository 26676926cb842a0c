"""The plan of a `Derivation`'s compiled model, which the C printer (`cwriter`) writes out:
expressions split into parameter-only constants and state polynomials, the stages of a
model evaluation, the mass matrix solved in the kernel, the output columns.

Every expression of the model is a polynomial in the state-dependent symbols (sines and
cosines of the angles, coordinates, rates, accelerations, contact force components) whose
coefficients depend on the parameters only. Each coefficient that is more than a number or
one parameter becomes a *constant*, computed once per run by the generated `prepare(p)`
into p[CONST_START:] and read by the kernels: the per-step code multiplies constants and
monomials, as a hand-written model with its lengths and masses combined would.
"""

from __future__ import annotations

from types import SimpleNamespace

import sympy as sp

from ..elements.registry import ELEMENTS
from .derive import Derivation

__all__ = ["Derivation"]


class _Numbers:
    """How the model printers write powers and numbers, alike so that the C model and the
    plan's literal lines evaluate the same operations in the same order: integer powers as
    products, square roots through `SQRT`, rationals and integers as round-trip float
    literals."""

    SQRT = "math.sqrt"

    def _power(self, expr) -> str | None:
        """`expr` (a Pow) as code, or None for a power of no such form."""
        base, exp = expr.as_base_exp()
        b = self._print(base)
        if exp.is_Integer and 1 < abs(int(exp)) <= 4:
            prod = " * ".join([f"{b}" if base.is_Symbol else f"({b})"] * abs(int(exp)))
            return f"({prod})" if exp > 0 else f"(1.0 / ({prod}))"
        if exp == -1:
            return f"(1.0 / {b})" if base.is_Symbol else f"(1.0 / ({b}))"
        if exp == sp.Rational(1, 2):
            return f"{self.SQRT}({b})"
        return None

    def _print_Rational(self, expr):
        return repr(float(expr))

    def _print_Integer(self, expr):
        return f"{int(expr)}.0" if abs(int(expr)) < 2**53 else repr(float(expr))


class _Writer:
    """Splits expressions into constants and state polynomials."""

    def __init__(self, d: Derivation):
        self.d = d
        self.pindex = {sym: i for i, sym in enumerate(d.psyms[n] for n in d.parameters)}
        self.pname = {d.psyms[n]: n for n in d.parameters}
        # state-dependent symbols: sin/cos of angles that move, Q, U, A, contact forces
        self.moving = []           # (angle expr, S, C) of the angles depending on t or Q
        self.fixed = []            # of the parameter-only angles (prismatic axes)
        for a, S, C in d.angles:
            (self.moving if a.free_symbols - set(self.pindex) else self.fixed).append(
                (a, S, C))
        self.vars = [s for _, S, C in self.moving for s in (S, C)]
        self.vars += [*d.Q, *d.U, *d.A, *d.load_symbols]
        self.constants: dict[sp.Expr, sp.Symbol] = {}

    # ---- constants
    def _constant(self, coeff: sp.Expr) -> sp.Expr:
        if coeff.is_Number or coeff in self.pindex or (
                coeff.is_Mul and len(coeff.args) == 2 and coeff.args[0] == -1
                and coeff.args[1] in self.pindex):
            return coeff
        if coeff in self.constants:
            return self.constants[coeff]
        if -coeff in self.constants:
            return -self.constants[-coeff]
        sym = sp.Symbol(f"k{len(self.constants)}", real=True)
        self.constants[coeff] = sym
        return sym

    def split(self, expr: sp.Expr) -> sp.Expr:
        """`expr` with its parameter-only coefficients replaced by constants."""
        expr = sp.expand(expr)
        if not expr.free_symbols & set(self.vars):
            return self._constant(expr)
        poly = sp.Poly(expr, *self.vars)
        out = sp.S(0)
        for monom, coeff in poly.terms():
            term = sp.Mul(*[v**k for v, k in zip(self.vars, monom) if k])
            out += self._constant(sp.factor_terms(coeff)) * term
        return out

    # ---- function bodies
def _solve_lines(M, f, out, indent="    ") -> list[str]:
    """Lines solving M x = f (M symmetric positive definite, entries given as code strings,
    f as names) into the names `out`: by division for a diagonal M, else by an unrolled
    Cholesky factorisation L L^T."""
    n = len(f)
    lines = []
    if all(M[i][j] == "0" for i in range(n) for j in range(n) if i != j):
        for i in range(n):
            lines.append(f"{out[i]} = {f[i]} / {M[i][i]}")
        return [indent + line for line in lines]
    for i in range(n):
        for j in range(i + 1):
            lines.append(f"m_{i}_{j} = {M[i][j]}")
    for j in range(n):
        s = " - ".join([f"m_{j}_{j}"] + [f"l_{j}_{k} * l_{j}_{k}" for k in range(j)])
        lines.append(f"l_{j}_{j} = math.sqrt({s})")
        lines.append(f"il_{j} = 1.0 / l_{j}_{j}")
        for i in range(j + 1, n):
            s = " - ".join([f"m_{i}_{j}"] + [f"l_{i}_{k} * l_{j}_{k}" for k in range(j)])
            lines.append(f"l_{i}_{j} = ({s}) * il_{j}")
    for i in range(n):
        s = " - ".join([f[i]] + [f"l_{i}_{k} * z_{k}" for k in range(i)])
        lines.append(f"z_{i} = ({s}) * il_{i}")
    for i in reversed(range(n)):
        s = " - ".join([f"z_{i}"] + [f"l_{k}_{i} * {out[k]}" for k in range(i + 1, n)])
        lines.append(f"{out[i]} = ({s}) * il_{i}")
    return [indent + line for line in lines]


def _plan(d: Derivation) -> SimpleNamespace:
    """The stages of the model evaluation of `d` (its expressions split: the kernels'
    constants numbered first, in this order, by every printer), and the indices into p
    they read: the one plan the python and the C printers write out."""
    w = _Writer(d)
    n, G = len(d.Q), len(d.ground_joints)
    # the events: every element's contacts, in the registry's order
    events = d.events
    E = len(events)
    params = list(d.parameters)
    mem_start = params.index(f"{events[0]}.mode")

    # ---- the stages of the model evaluation
    gap_names = [[f"ex{j}", f"ey{j}", f"exd{j}", f"eyd{j}"] for j in range(E)]
    gap_exprs = [[w.split(e) for e in gap] for gap in d.gaps]
    gaps_stage = ([e for g in gap_exprs for e in g], [nm for g in gap_names for nm in g])
    # the elements' contact stages, each element's contacts numbered from `first`, and what
    # they compute beside the gaps (a revolute joint's slip and angular velocities)
    parts, first, contact_lines = {}, 0, []
    for el in ELEMENTS:
        parts[el.kind] = el.plan(d.parts[el.kind], params, mem_start, first)
        contact_lines += parts[el.kind].lines
        first += len(d.parts[el.kind].contacts)
    for el in ELEMENTS:
        for name, _, _, e in parts[el.kind].gap_extras:
            gaps_stage[0].append(w.split(e))
            gaps_stage[1].append(name)
    M = [[w.split(d.mass_matrix[i, k]) for k in range(n)] for i in range(n)]
    f = [w.split(d.forcing[i]) for i in range(n)]
    fsyms = [sp.Symbol(f"f{i}", real=True) for i in range(n)]
    diagonal = all(M[i][k] == 0 for i in range(n) for k in range(n) if i != k)
    if diagonal and not any(M[i][i].free_symbols & set(w.vars) for i in range(n)):
        # a constant diagonal mass matrix: its inverse is a constant, no division per call
        eom = [(f, [str(s) for s in fsyms]),
               ([fsyms[i] * w._constant(1 / sp.expand(d.mass_matrix[i, i]))
                 for i in range(n)], [f"A{i}" for i in range(n)])]
    else:
        lower = [(i, k) for i in range(n) for k in range(i + 1) if M[i][k] != 0]
        code = [[("0" if M[max(i, k)][min(i, k)] == 0 else f"mm_{max(i, k)}_{min(i, k)}")
                 for k in range(n)] for i in range(n)]
        eom = [(f + [M[i][k] for i, k in lower],
                [str(s) for s in fsyms] + [f"mm_{i}_{k}" for i, k in lower]),
               _solve_lines(code, [str(s) for s in fsyms], [f"A{i}" for i in range(n)], "")]
    reaction_names = [f"r{g}{xy}" for g in range(G) for xy in "xy"]
    # a free linkage (no drive parameters) has no drive moment
    driven = "drive.speed" in params
    moment = ["moment"] if driven else []
    outputs_stage = ([w.split(e) for r in d.reactions for e in r]
                     + [w.split(d.drive_moment)] * driven, reaction_names + moment)
    results = []
    for j in range(E):
        results += [f"F{j}", f"d{j}", f"dd{j}", f"ex{j}", f"ey{j}"]
    results += reaction_names
    results += [" + ".join(f"r{g}x" for g in range(G)) or "0.0",
                " + ".join(f"r{g}y" for g in range(G)) or "0.0", *moment]
    results += [f"A{i}" for i in range(n)]
    for el in ELEMENTS:
        results += parts[el.kind].results
    return SimpleNamespace(**locals())


def _out_columns(d: Derivation, parts: dict, driven: bool) -> tuple[list[str], int]:
    """(the columns of the outputs, the column of the monitored value's x); `parts`: the
    elements' plans."""
    out_columns = []
    for j in d.events:
        out_columns += [f"{j}.contact_force", f"{j}.penetration", f"{j}.penetration_rate",
                        f"{j}.ecc_x", f"{j}.ecc_y"]
    for gname in d.ground_joints:
        out_columns += [f"{gname}.reaction_x", f"{gname}.reaction_y"]
    out_columns += ["shaking_x", "shaking_y", *(["drive_moment"] if driven else [])]
    out_columns += [f"{c}.acc" for c in d.coordinates]
    for el in ELEMENTS:
        out_columns += el.out_columns(d.parts[el.kind], parts[el.kind])
    if d.monitor is None:
        mon = out_columns.index("shaking_x")
    else:
        mon = out_columns.index(f"{d.monitor}.reaction_x")
    return out_columns, mon
