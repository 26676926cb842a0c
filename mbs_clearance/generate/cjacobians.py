"""C code of the Jacobian and tangent kernels of a `Derivation`: the one plan of
`jacobians.jacobian_plan`, its expressions printed by the C model's
printer (`cwriter._C`) and its literal lines (python syntax: assignments, `for` and `if`
blocks by indentation, calls of the elements' rows with tuple results and tuple arguments)
translated statement by statement (`translate`). The elements' rows are core/jac_runtime.h.

The kernels' arguments:
``jacobian(t, y, p, jac, full)`` and ``tangent(t, y, p, dz, nd, use, out, full)``, exported
as ``mbs_jacobian`` and ``mbs_tangent``.
"""

from __future__ import annotations

import re

from ..elements.registry import ELEMENTS
from .jacobians import emit_body, jacobian_plan

__all__ = ["jacobian_functions", "translate"]

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_FOR = re.compile(r"^for ([a-z_]+) in range\((.+)\):$")
_IF = re.compile(r"^if (.+):$")
_CALL = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*(?:, [A-Za-z_][A-Za-z0-9_]*)*) = "
                   r"([a-z_]+)\((.*)\)$")
_ASSIGN = re.compile(r"^(.+?) (\+?=) (.+)$")
#: the integer locals of the plan's lines (indices); every other local is a double
_INTS = ("d", "e", "col", "yo")


def _split_args(text: str) -> list[str]:
    """The top-level comma-separated items of `text` (brackets and parentheses kept)."""
    items, depth, cur = [], 0, ""
    for ch in text:
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
        if ch == "," and depth == 0:
            items.append(cur.strip())
            cur = ""
        else:
            cur += ch
    if cur.strip():
        items.append(cur.strip())
    return items


def _expr(text: str) -> str:
    """A python expression of the plan as C: int(x) a cast, math.sqrt sqrt (the rest,
    arithmetic on names, indices and float literals, reads alike)."""
    return text.replace("math.sqrt(", "sqrt(").replace("int(", "(int64_t)(")


def _argument(text: str) -> str:
    """One argument of an element's call: a tuple (the friction law's columns or values) as
    a C99 compound literal, anything else as an expression."""
    if text.startswith("(") and text.endswith(")") and "," in text:
        items = _split_args(text[1:-1])
        kind = "double" if any("[" in it or "." in it for it in items) else "int64_t"
        return f"(const {kind}[]){{{', '.join(_expr(it) for it in items)}}}"
    return _expr(text)


def _range(args: str) -> tuple[str, str]:
    parts = [_expr(a) for a in _split_args(args)]
    return ("0", parts[0]) if len(parts) == 1 else (parts[0], parts[1])


def translate(lines: list[str]) -> tuple[list[str], list[str]]:
    """(C statements, the double locals they assign) of the plan's lines: `for x in
    range(...)` and `if ...:` blocks by indentation, `a, b = f(...)` calls (results through
    pointers after the arguments), assignments; lines ending in ';' are C already (printed
    stages), their local assigned names collected alike. The locals are declared by the
    caller (python's function scope: a name may be assigned in a block and read after it)."""
    out, names, stack = [], [], []

    def local(name):
        if _NAME.match(name) and name not in _INTS and name not in names:
            names.append(name)

    for raw in lines:
        if not raw.strip():
            continue
        indent = len(raw) - len(raw.lstrip(" "))
        line = raw.strip()
        while stack and indent <= stack[-1]:
            stack.pop()
            out.append(" " * (4 * len(stack)) + "}")
        pad = " " * (4 * len(stack))
        if line.endswith(";"):
            local(line.split(" = ", 1)[0])
            out.append(pad + line)
            continue
        m = _FOR.match(line)
        if m:
            var, (lo, hi) = m.group(1), _range(m.group(2))
            out.append(f"{pad}for (int64_t {var} = {lo}; {var} < {hi}; {var}++) {{")
            stack.append(indent)
            continue
        m = _IF.match(line)
        if m:
            out.append(f"{pad}if ({_expr(m.group(1))}) {{")
            stack.append(indent)
            continue
        m = _CALL.match(line)
        if m and not m.group(2).startswith("int"):
            results = m.group(1).split(", ")
            for r in results:
                local(r)
            args = [_argument(a) for a in _split_args(m.group(3))]
            out.append(f"{pad}{m.group(2)}({', '.join(args + [f'&{r}' for r in results])});")
            continue
        m = _ASSIGN.match(line)
        if m is None:
            raise ValueError(f"no C form for the generated line {line!r}")
        lhs, op, rhs = m.groups()
        if lhs in _INTS:
            if op != "=":
                raise ValueError(f"no C form for the generated line {line!r}")
            out.append(f"{pad}const int64_t {lhs} = {_expr(rhs)};")
            continue
        local(lhs)
        out.append(f"{pad}{lhs} {op} {_expr(rhs)};")
    while stack:
        stack.pop()
        out.append(" " * (4 * len(stack)) + "}")
    return out, names


def jacobian_functions(c, d, pl) -> tuple[list[str], dict]:
    """(the C lines of the model's Jacobian and tangent kernels, their layout's defines and
    exports, the metadata they add: Z_NAMES, N_Z, JAC_STRIDE, N_JROWS, JAC_EXTRA_ROWS,
    FLOORS, MEM_COL0) from the C model's printer `c` (`cwriter._C`) and plan `pl`
    (`writer._plan`). Call before the model's constants are printed: the Jacobians'
    constants are numbered after the kernels'."""
    from .writer import _out_columns

    out_columns, _ = _out_columns(d, pl.parts, pl.driven)
    plan = jacobian_plan(c.w, d, out_columns, pl.parts)

    def stage(exprs, names, temps):
        # assignments only: the locals are declared once per kernel (`translate`), and a
        # name may be an entry of jac or out
        used, lines = c.stage(exprs, names, temps)
        return used, [ln.removeprefix("const double ") for ln in lines]

    def preamble(used):
        used = used - plan.extra_syms
        angles = [(a, S, C) for a, S, C in c.w.moving if S in used or C in used]
        need = set(used)
        for a, _, _ in angles:
            need |= a.free_symbols
        return c.loads(need) + [f"double {S}, {C}; mbs_sincos({c.code(a)}, &{S}, &{C});"
                                for a, S, C in angles]

    def kernel(stages, full_stage, head):
        pre, body, full = emit_body(stages, full_stage, stage, preamble)
        body, names = translate(body)
        full, more = translate(full)
        names += [nm for nm in more if nm not in names]
        decl = [f"double {', '.join(names[k:k + 12])};" for k in range(0, len(names), 12)]
        return (["    (void)t;"] + ["    " + ln for ln in head + pre + decl + body]
                + ["    if (full) {"] + ["        " + ln for ln in full] + ["    }"])

    floors = [f for el in ELEMENTS for _, f in pl.parts[el.kind].floors]
    n_z = plan.n_z
    lines = [
        "/* ---- the Jacobian and tangent kernels (generate/cjacobians.py): rows of jac",
        " * (N_JROWS x JAC_STRIDE), columns z = [t, q, qdot, p[:CONST_START]], then the value */",
        f"#define N_Z {n_z}", f"#define N_JROWS {plan.n_jrows}", "#define JAC_STRIDE (N_Z + 1)",
        "#define MEM_COL0 (1 + 2 * N_Q + MEM_START + 1)", "#define PEN_ROW 1",
        "#define RATE_ROW 2", "#define JOINT_ROWS 5",
        "/* per contact (the clearance joints, then the corners) the p index of its "
        "impact-velocity floor */",
        f"static const int64_t FLOORS[N_EVENTS] = {{{', '.join(map(str, floors))}}};", "",
        "static void jacobian(double t, const double *y, const double *p, double *jac, "
        "int64_t full) {",
        *kernel(plan.jac_stages, plan.jac_full,
                ["for (int64_t k = 0; k < N_JROWS * JAC_STRIDE; k++) jac[k] = 0.0;"]),
        "}", "",
        "static void tangent(double t, const double *y, const double *p, const double *dz, "
        "int64_t nd,", "                    const double *use, double *out, int64_t full) {",
        *kernel(plan.tan_stages, plan.tan_full, ["const int64_t ts = nd + 1;"]),
        "}", "",
        "void mbs_jacobian(double t, const double *y, const double *p, double *jac, "
        "int64_t full) {", "    jacobian(t, y, p, jac, full);", "}", "",
        "void mbs_tangent(double t, const double *y, const double *p, const double *dz, "
        "int64_t nd,", "                 const double *use, double *out, int64_t full) {",
        "    tangent(t, y, p, dz, nd, use, out, full);", "}", ""]
    meta = dict(Z_NAMES=tuple(plan.z_names), N_Z=n_z, JAC_STRIDE=plan.jac_stride,
                N_JROWS=plan.n_jrows, JAC_EXTRA_ROWS=dict(plan.jac_extra),
                FLOORS=tuple(floors), MEM_COL0=1 + 2 * pl.n + pl.mem_start + 1)
    return lines, meta
