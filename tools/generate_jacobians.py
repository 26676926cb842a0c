"""Derive the reduced model's outputs and their exact Jacobian with sympy; write numba code.

    python tools/generate_jacobians.py   # rewrites mbs_clearance/_jacobians.py

Inputs z (in this order): t, theta3, x4, theta3dot, x4dot, deltadot_minus, L2, L3, m2, m3,
m4, J3, omega2, theta20, c, K, xi, g. The hysteresis factor xi of the contact law is an input
so that one derivation serves all contact models (d/de = d/dxi * dxi/de in the kernel).

Outputs o: theta3dd, x4dd, F12x, F12y, M2, F, delta, deltadot. Two branches: "contact" (the
law's force, delta > 0 and F > 0) and "free" (F = 0). The equations are the paper's Eqs. 1-8
and the base force of docs/derivations.md, written here independently of reduced.py.
"""

import re
from pathlib import Path

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

NAMES = ["t", "th3", "x4", "th3d", "x4d", "dmin", "L2", "L3", "m2", "m3", "m4", "J3", "w",
         "th0", "c", "K", "xi", "g"]
OUTPUTS = ["th3dd", "x4dd", "F12x", "F12y", "M2", "F", "delta", "deltadot"]
#: the Jacobian's columns of the crank angle's inputs t, omega2, theta20
CRANK_COLUMNS = (0, 12, 13)


def derive(contact: bool, accel_input: bool = False):
    """Inputs z, outputs and their Jacobian of one branch. With accel_input, theta3dd is an
    input (the last of z) and the outputs are F12x, F12y, M2 and F only."""
    z = sp.symbols(NAMES, real=True)
    t, th3, x4, th3d, x4d, dmin, L2, L3, m2, m3, m4, J3, w, th0, c, K, xi, g = z
    th2 = w * t + th0
    c2, s2, c3, s3 = sp.cos(th2), sp.sin(th2), sp.cos(th3), sp.sin(th3)
    ex = x4 - L2 * c2 - L3 * c3
    ey = -L2 * s2 - L3 * s3
    exd = x4d + L2 * w * s2 + L3 * th3d * s3
    eyd = -L2 * w * c2 - L3 * th3d * c3
    r = sp.sqrt(ex**2 + ey**2)
    nx, ny = ex / r, ey / r
    delta = r - c
    deltadot = nx * exd + ny * eyd
    F = K * delta ** sp.Rational(3, 2) * (1 + xi * deltadot / dmin) if contact else sp.S(0)
    inertia = J3 + m3 * L3**2 / 4
    # angle differences written out (sin(theta3 - theta2) = s3 c2 - c3 s2, ...): the code
    # then needs sin and cos of theta2 and theta3 only
    sin32 = s3 * c2 - c3 * s2
    cos23 = c2 * c3 + s2 * s3
    th3dd = -(m3 * L2 * L3 * w**2 * sin32 / 2 + m3 * g * L3 * c3 / 2
              + L3 * F * (s3 * nx - c3 * ny)) / inertia
    x4dd = -F * nx / m4
    if accel_input:
        z = z + [sp.Symbol("th3dd", real=True)]
        th3dd = z[-1]
    M2 = (m3 * L2 * L3 * (th3dd * cos23 - th3d**2 * sin32) / 2
          + (m3 + m2 / 2) * g * L2 * c2 + L2 * F * (s2 * nx - c2 * ny))
    ag2 = sp.Matrix([-L2 * w**2 * c2 / 2, -L2 * w**2 * s2 / 2])
    ag3 = (sp.Matrix([-L2 * w**2 * c2, -L2 * w**2 * s2])
           + L3 / 2 * (th3dd * sp.Matrix([-s3, c3]) - th3d**2 * sp.Matrix([c3, s3])))
    R = m2 * ag2 + m3 * ag3 + sp.Matrix([0, (m2 + m3) * g]) - F * sp.Matrix([nx, ny])
    if accel_input:
        out = sp.Matrix([-R[0], -R[1], M2, F])
    else:
        out = sp.Matrix([th3dd, x4dd, -R[0], -R[1], M2, F, delta, deltadot])
    return z, out, out.jacobian(sp.Matrix(z))


class _Printer(PythonCodePrinter):
    # sin and cos through the kernels' inlined sincos (mbs_clearance/_trig.py): the two
    # calls of one angle compile to one evaluation
    def _print_sin(self, expr):
        return f"sincos({self._print(expr.args[0])})[0]"

    def _print_cos(self, expr):
        return f"sincos({self._print(expr.args[0])})[1]"

    def _print_Pow(self, expr, rational=False):
        base, exp = expr.as_base_exp()
        # max(., 0): the branch is chosen with the same penetration computed elsewhere, and
        # rounding may leave delta a few ulps below zero here; the force is then ~0, not NaN
        if exp == sp.Rational(1, 2):
            return f"math.sqrt(max({self._print(base)}, 0.0))"
        if exp == sp.Rational(-1, 2):
            return f"(1.0 / math.sqrt({self._print(base)}))"
        if exp == sp.Rational(3, 2):
            b = f"max({self._print(base)}, 0.0)"
            return f"({b} * math.sqrt({b}))"
        if exp == sp.Rational(-3, 2):     # (no pow call in the right-hand side)
            b = self._print(base)
            return f"(1.0 / (({b}) * math.sqrt({b})))"
        if exp.is_Integer and 1 < abs(int(exp)) <= 4:
            b = self._print(base)
            prod = " * ".join([f"({b})"] * abs(int(exp)))
            return f"({prod})" if exp > 0 else f"(1.0 / ({prod}))"
        return super()._print_Pow(expr, rational=rational)


def _one_sincos_per_angle(lines):
    """Evaluate sincos once per angle: before the first line that uses an angle, a line
    `sN, cN = sincos(angle)`, and the uses replaced by sN, cN."""
    names = {}
    out = []
    for line in lines:
        for arg in re.findall(r"sincos\(([^()]*)\)\[[01]\]", line):
            if arg not in names:
                names[arg] = len(names)
                out.append(f"    s{names[arg]}, c{names[arg]} = sincos({arg})")
            k = names[arg]
            line = line.replace(f"sincos({arg})[0]", f"s{k}").replace(f"sincos({arg})[1]",
                                                                      f"c{k}")
        out.append(line)
    return out


def emit(name, z, out, jac, doc, omit=(), hoist=None):
    """Numba code of o = out and the flat Jacobian jac.

    omit: Jacobian columns not written. hoist: with an offset, the temporaries that depend on
    the kernel parameters only (z[6:], constant during a run) are read from z[hoist + i]
    instead of computed at every call, and a second function `{name}_constants(z)` that
    stores them there is returned too: (code, constants code, number of constants).
    """
    printer = _Printer({"fully_qualified_modules": True})
    exprs = list(out) + [jac[i, j] for i in range(jac.rows) for j in range(jac.cols)]
    reps, reduced_exprs = sp.cse(exprs, symbols=sp.numbered_symbols("x"), optimizations="basic")
    hoisted = []
    if hoist is not None:
        constant = set(z[6:])
        for sym, expr in reps:
            if expr.free_symbols <= constant:
                hoisted.append(sym)
                constant.add(sym)
    # error_model="numpy": at r = 0 (journal centred) the penetration-rate rows divide by
    # zero; they are only used at contact onsets (r = c), the other rows stay finite
    lines = [
        '@nb.njit(cache=True, error_model="numpy", _nrt=False)',
        f"def {name}(z, o, jac):",
        f'    """{doc}"""',
    ]
    for i, s in enumerate(z):
        lines.append(f"    {s} = z[{i}]")
    for sym, expr in reps:
        if sym in hoisted:
            lines.append(f"    {sym} = z[{hoist + hoisted.index(sym)}]")
        else:
            lines.append(f"    {sym} = {printer.doprint(expr)}")
    n_out = len(out)
    for i in range(n_out):
        lines.append(f"    o[{i}] = {printer.doprint(reduced_exprs[i])}")
    for k, e in enumerate(reduced_exprs[n_out:]):
        # flat row-major (jac[i * N_Z + j]): a 2-D view of the caller's work space would
        # need a reshape per call; columns in `omit` are not written (nor computed: the
        # compiler drops what only they used)
        if k % jac.cols not in omit:
            lines.append(f"    jac[{k}] = {printer.doprint(e)}")
    code = "\n".join(_one_sincos_per_angle(lines)).replace("math.math.", "math.")
    if hoist is None:
        return code
    const = [
        '@nb.njit(cache=True, error_model="numpy", _nrt=False)',
        f"def {name}_constants(z):",
        f'    """The parameter-only temporaries of `{name}` into '
        f'z[{hoist}:{hoist + len(hoisted)}]."""',
    ]
    for i, s in enumerate(z[6:], start=6):
        const.append(f"    {s} = z[{i}]")
    for sym, expr in reps:
        if sym in hoisted:
            const.append(f"    {sym} = {printer.doprint(expr)}")
            const.append(f"    z[{hoist + hoisted.index(sym)}] = {sym}")
    return code, "\n".join(const).replace("math.math.", "math."), len(hoisted)


def main():
    body = []
    offset = len(NAMES)      # the constants follow the inputs in z
    const_names = []
    for contact in (True, False):
        z, out, jac = derive(contact)
        branch = "contact" if contact else "free"
        body.append(emit(f"{branch}_branch", z, out, jac,
                         f"{branch.capitalize()} branch: outputs o (8,), Jacobian jac (8 * 18,)."))
        # the right-hand side of the sensitivity equations needs only the accelerations (and
        # the contact force, to tell whether the contact branch applies); their
        # parameter-only temporaries are computed once per run (`accel_constants`)
        # (and M2's value, without its Jacobian: the crank's work quadrature)
        rows = [0, 1, OUTPUTS.index("F"), OUTPUTS.index("M2")]
        doc = (f"{branch.capitalize()} branch, rows theta3dd and x4dd only: o (4,) = (theta3dd, "
               "x4dd, F, M2), jac (2 * 18,); z[N_Z:N_ZW] filled by `accel_constants`.")
        # the full variant, then one without the columns of t, omega2 and theta20 (the crank
        # angle's), which only sensitivities to the crank speed or initial angle need (13 %
        # less time); both have the same subexpressions, so the second reads the first's
        # constants
        code, const, n = emit(f"{branch}_accel", z, out.extract(rows, [0]), jac[:2, :], doc,
                              hoist=offset)
        code_nc, const_nc, _ = emit(
            f"{branch}_accel_nc", z, out.extract(rows, [0]), jac[:2, :],
            doc + f" Without the columns {CRANK_COLUMNS} (t, omega2, theta20), which it leaves "
            "as they were.", omit=CRANK_COLUMNS, hoist=offset)
        assert const_nc == const.replace(f"{branch}_accel", f"{branch}_accel_nc")
        body += [code, const, code_nc]
        const_names.append(f"{branch}_accel_constants")
        offset += n
        # the outputs at recorded steps, with theta3dd an input: its sensitivities are the
        # sensitivity equations' own right-hand side, recorded by the integrator, so the
        # output sensitivities need no second Jacobian of the accelerations
        zo, out_o, jac_o = derive(contact, accel_input=True)
        doc_o = (f"{branch.capitalize()} branch, outputs at a given theta3dd: z (19,) = the "
                 "inputs, then theta3dd; o (4,) = (F12x, F12y, M2, F), jac (4 * 19,).")
        body.append(emit(f"{branch}_outputs", zo, out_o, jac_o, doc_o))
        body.append(emit(f"{branch}_outputs_nc", zo, out_o, jac_o,
                         doc_o + f" Without the columns {CRANK_COLUMNS} (as the _accel_nc "
                         "functions).", omit=CRANK_COLUMNS))
    calls = "\n".join(f"    {c}(z)" for c in const_names)
    body.append(f'''@nb.njit(cache=True, error_model="numpy", _nrt=False)
def accel_constants(z):
    """Fill z[N_Z:N_ZW], the parameter-only temporaries of the *_accel functions, from the
    parameters z[6:N_Z]; once per run (they are constant while the parameters are)."""
{calls}''')
    header = f'''"""GENERATED by tools/generate_jacobians.py from symbolic equations: do not edit.

Outputs {OUTPUTS} and their exact Jacobian with respect to
z = {NAMES}.
"""
# ruff: noqa
import math

import numba as nb

from ._trig import sincos

Z_NAMES = {tuple(NAMES)!r}
O_NAMES = {tuple(OUTPUTS)!r}
#: columns of the Jacobian, stored flat row-major: d o[i] / d z[j] = jac[i * N_Z + j]
N_Z = {len(NAMES)}
#: length of z with the parameter-only temporaries of the *_accel functions after the
#: inputs (`accel_constants`)
N_ZW = {offset}
#: inputs of the *_outputs functions: z[:N_Z], then theta3dd
N_ZO = {len(NAMES) + 1}
#: columns that the *_accel_nc variants leave out (t, omega2, theta20)
CRANK_COLUMNS = {CRANK_COLUMNS!r}

'''
    path = Path(__file__).resolve().parents[1] / "mbs_clearance" / "_jacobians.py"
    path.write_text(header + "\n\n\n".join(body) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
