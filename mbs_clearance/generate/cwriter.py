"""C code of a `Derivation`: the plan of `writer._plan` (the split expressions, their common
subexpressions, the constants in a fixed order) printed with sympy's C99 printer, its powers
and numbers written as the python printer writes them, so that every kernel evaluates its
expressions in one fixed order of operations.

The model is a C99 translation unit that includes the seam (mbs_core.h) and the runtime
(core/runtime.h: sincos, the contact stages, the laws) and exports `mbs_model_record()`.
Nothing of the description enters it as code: parameters are read as ``p[i]`` into locals
named ``P<i>``, every other name is the generator's own; the description's names appear
nowhere in it (the structure's digest names it).
"""

from __future__ import annotations

import re

import sympy as sp
from sympy.printing.c import C99CodePrinter

from ..elements.registry import ELEMENTS
from .cjacobians import jacobian_functions
from .derive import Derivation
from .key import structure_digest
from .profiles import block_size
from .writer import _Numbers, _out_columns, _plan

__all__ = ["render_c", "metadata"]


class _CPrinter(_Numbers, C99CodePrinter):
    """C code, powers and numbers as the python printer writes them (same operations, same
    order), parameters renamed through `names`."""

    SQRT = "sqrt"

    def __init__(self, names: dict):
        super().__init__()
        self._names = names

    def _print_Symbol(self, expr):
        return self._names.get(expr, expr.name)

    def _print_Pow(self, expr, rational=False):
        code = self._power(expr)
        if code is None:
            raise ValueError(f"no C form for the power {expr} in a generated model")
        return code

    def _print_Float(self, expr):
        return repr(float(expr))


_ASSIGN = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*) = (.*)$")
_SLOTS = re.compile(r", \((p\[\d+\](?:, p\[\d+\])*),?\)")
_CALL = re.compile(r"^([A-Za-z_][A-Za-z0-9_, ]*) = ([a-z_]+)\((.*)\)$")


class _C:
    """Prints the plan's stages as C statements."""

    def __init__(self, w):
        self.w = w
        self.pr = _CPrinter({sym: f"P{i}" for sym, i in w.pindex.items()})

    def code(self, expr) -> str:
        return self.pr.doprint(expr)

    def stage(self, exprs, names, temps):
        reps, reduced = sp.cse(exprs, symbols=temps, optimizations="basic", order="none")
        used = set()
        for e in [*(e for _, e in reps), *reduced]:
            used |= e.free_symbols
        lines = [f"const double {sym} = {self.code(e)};" for sym, e in reps]
        lines += [f"const double {name} = {self.code(e)};" for name, e in zip(names, reduced)]
        return used, lines

    def loads(self, need) -> list[str]:
        w, d = self.w, self.w.d
        lines = [f"const double P{w.pindex[s]} = p[{w.pindex[s]}];"
                 for s in sorted(need & set(w.pindex), key=lambda s: w.pindex[s])]
        consts = {v: k for k, v in w.constants.items()}
        lines += [f"const double {s} = p[CONST_START + {s.name[1:]}];"
                  for s in sorted((s for s in need if s in consts), key=lambda s: int(s.name[1:]))]
        n = len(d.Q)
        lines += [f"const double {d.Q[i]} = y[{i}];" for i in range(n) if d.Q[i] in need]
        lines += [f"const double {d.U[i]} = y[{n + i}];" for i in range(n) if d.U[i] in need]
        return lines

    def function(self, stages) -> list[str]:
        """Statements: the loads, one sincos per moving angle used, then the stages (each
        (exprs, names), or a list of python lines of the plan, translated)."""
        temps = sp.numbered_symbols("x")
        used, lines = set(), []
        for st in stages:
            if isinstance(st, tuple):
                u, ls = self.stage(*st, temps)
                used |= u
                lines += ls
            else:
                lines += [_statement(line) for line in st]
        angles = [(a, S, C) for a, S, C in self.w.moving if S in used or C in used]
        need = set(used)
        for a, _, _ in angles:
            need |= a.free_symbols
        pre = self.loads(need)
        pre += [f"double {S}, {C}; mbs_sincos({self.code(a)}, &{S}, &{C});"
                for a, S, C in angles]
        return ["    " + line for line in pre + lines]

    def constants(self) -> list[str]:
        """The statements of `prepare`: every constant into p[CONST_START + k]."""
        w = self.w
        items = list(w.constants.items())
        reps, reduced = sp.cse([e for e, _ in items], symbols=sp.numbered_symbols("x"),
                               optimizations="basic", order="none")
        used = set()
        for e in [*(e for _, e in reps), *reduced]:
            used |= e.free_symbols
        fixed = [(a, S, C) for a, S, C in w.fixed if S in used or C in used]
        need = set(used)
        for a, _, _ in fixed:
            need |= a.free_symbols
        lines = self.loads(need)
        for a, S, C in fixed:
            lines += [f"const double {S} = sin({self.code(a)});",
                      f"const double {C} = cos({self.code(a)});"]
        lines += [f"const double {sym} = {self.code(e)};" for sym, e in reps]
        lines += [f"p[CONST_START + {sym.name[1:]}] = {self.code(e)};"
                  for (_, sym), e in zip(items, reduced)]
        return ["    " + line for line in lines]


def _statement(line: str) -> str:
    """A python line of the plan (a stage call with tuple results, or an assignment of the
    mass matrix solve) as a C statement."""
    call = _CALL.match(line)
    if call and call.group(2).endswith("_stage"):
        outs = call.group(1).split(", ")
        # a tuple of the friction slots: a C99 compound literal
        args = _SLOTS.sub(r", (const double[]){\1}", call.group(3))
        return (f"double {', '.join(outs)}; {call.group(2)}({args}, "
                + ", ".join(f"&{o}" for o in outs) + ");")
    assign = _ASSIGN.match(line.strip())
    if assign is None:
        raise ValueError(f"no C form for the generated line {line!r}")
    return (f"const double {assign.group(1)} = "
            f"{assign.group(2).replace('math.sqrt(', 'sqrt(')};")


def metadata(d: Derivation, linkage_name: str, structure: dict, zeros: tuple, pl,
             n_constants: int) -> dict:
    """What a model exposes beside its kernels, for the C model's callers."""
    params = pl.params
    out_columns, mon = _out_columns(d, pl.parts, pl.driven)
    friction = [c for el in ELEMENTS
                for c in el.friction_contacts(d.parts[el.kind], pl.parts[el.kind])]
    n = pl.n
    return dict(
        LINKAGE=linkage_name, STRUCTURE_DIGEST=structure_digest(structure),
        PARAMETERS=tuple(params), ZERO_PARAMETERS=tuple(zeros),
        ZERO_INDEX=tuple(params.index(z) for z in zeros), COORDINATES=tuple(d.coordinates),
        N_Q=n, FRICTION_JOINTS=tuple(friction),
        N_STATE=2 * n + 1 + (1 if friction else 0),
        FRICTION_WORK=2 * n + 1 if friction else -1, JOINTS=tuple(pl.events),
        N_EVENTS=pl.E, MEM_START=pl.mem_start, N_MEM=2 * pl.E,
        GROUND_JOINTS=tuple(d.ground_joints), MONITOR_JOINT=d.monitor,
        CONST_START=len(params), N_CONSTANTS=n_constants, N_P=len(params) + n_constants,
        OUT_COLUMNS=tuple(out_columns), N_OUT=len(out_columns), MONITOR_COLUMN=mon,
        MOMENT_COLUMN=out_columns.index("drive_moment") if pl.driven else -1,
        ACC_COLUMN=out_columns.index(f"{d.coordinates[0]}.acc"),
        LUBRICATED_JOINTS=tuple(c for el in ELEMENTS for c in pl.parts[el.kind].lubricated),
        SPEED_INDEX=params.index("drive.speed") if pl.driven else -1,
        POWER_COLUMNS=tuple(out_columns.index(f"{j}.friction_power") for j in friction))


def render_c(d: Derivation, linkage_name: str, structure: dict,
             zeros: tuple = (), profiles: dict | None = None) -> tuple[str, dict]:
    """(the C source of the model of derivation `d`, its metadata (`metadata`));
    deterministic. `zeros`: the parameters `d` is specialised on, checked to be zero.
    `profiles`: per profiled clearance joint (its index), the bearing body's angle, its rate
    (expressions of `d`) and the profile's grid size (`profiles.bearing_kinematics`); a
    model without them prints as it always has."""
    pl = _plan(d)
    c = _C(pl.w)
    E, n = pl.E, pl.n
    profiles = profiles or {}
    offsets = {}
    for el in ELEMENTS:
        offsets.update(el.profiled_stages(d.parts[el.kind], pl.parts[el.kind], profiles,
                                          pl.gaps_stage, block_size))
    pl.contact_lines = [ln for el in ELEMENTS for ln in pl.parts[el.kind].lines]
    dynamics = c.function([pl.gaps_stage, pl.contact_lines, *pl.eom, pl.outputs_stage])
    gap_fns = [c.function([(pl.gap_exprs[j], pl.gap_names[j])]) for j in range(E)]
    bearing_fns = {j: c.function([([sp.sympify(e) for e in profiles[j][:2]],
                                   [f"pa{j}", f"pw{j}"])]) for j in profiles}
    # the kernels' constants are numbered first; the closure's
    # (used at the start only) after them
    n_kernel_constants = len(pl.w.constants)
    # the energy's constants (unused here), so that the Jacobians' keep their numbers and
    # their sums' order
    pl.w.split(d.kinetic + d.potential)
    closure = _closure_functions(c, d, pl)
    jac_lines, jac_meta = jacobian_functions(c, d, pl)   # constants before prepare's
    prepare = c.constants()      # after the plan: every constant of the kernels known
    meta = metadata(d, linkage_name, structure, zeros, pl, len(pl.w.constants))
    meta["N_KERNEL_CONSTANTS"] = n_kernel_constants
    meta.update(jac_meta)
    if profiles:
        # the profiles' blocks after the constants (generate/profiles.py)
        start = meta["N_P"]
        meta.update(PROFILE_JOINTS=tuple(pl.events[j] for j in sorted(profiles)),
                    PROFILE_POINTS=tuple(profiles[j][2] for j in sorted(profiles)),
                    PROFILE_OFFSETS=tuple(start + offsets[j] for j in sorted(profiles)),
                    N_P=start + sum(block_size(profiles[j][2]) for j in profiles))
    N_OUT = meta["N_OUT"]

    out = ["/* GENERATED by mbs_clearance.generate (C printer) from a linkage's structure, "
           "digest",
           f" * {meta['STRUCTURE_DIGEST']}: do not edit. Kernels of the seam mbs_core.h. */",
           '#include "mbs_core.h"', '#include "runtime.h"', '#include "jac_runtime.h"',
           *(['#include "profile_runtime.h"'] if profiles else []), "",
           f"#define N_Q {n}", f"#define N_STATE {meta['N_STATE']}", f"#define N_EVENTS {E}",
           f"#define MEM_START {pl.mem_start}", f"#define N_MEM {2 * E}",
           f"#define N_OUT {N_OUT}", f"#define CONST_START {meta['CONST_START']}",
           f"#define N_P {meta['N_P']}", f"#define ACC_COLUMN {meta['ACC_COLUMN']}",
           f"#define MONITOR_COLUMN {meta['MONITOR_COLUMN']}",
           *([f"#define PROFILE_START {meta['PROFILE_OFFSETS'][0]}"] if profiles else []), ""]
    zi = meta["ZERO_INDEX"]
    out += ["static int zeros_hold(const double *p) {"]
    if zi:
        out += [f"    static const int64_t index[{len(zi)}] = {{{', '.join(map(str, zi))}}};",
                f"    for (int i = 0; i < {len(zi)}; i++)",
                "        if (p[index[i]] != 0.0) return 0;"]
    else:
        out += ["    (void)p;"]
    out += ["    return 1;", "}", "",
            "/* the parameter-only constants into p[CONST_START:]; 1 when a parameter the model "
            "is", " * specialised on is not zero */",
            "static int prepare(double *p) {", "    if (!zeros_hold(p)) return 1;",
            *prepare, "    return 0;", "}", "",
            "/* every output (in the OUT_COLUMNS order) into res[N_OUT] */",
            "MBS_ALWAYS_INLINE void dynamics(double t, const double *y, const double *p, "
            "double *res) {", "    (void)t;", *dynamics]
    out += [f"    res[{k}] = {r};" for k, r in enumerate(pl.results)]
    out += ["}", "",
            "static inline void derivative(const double *y, int64_t n, const double *p, "
            "const double *res,", "                              double *dydt) {",
            "    (void)p;",
            "    for (int i = 0; i < N_Q; i++) {", "        dydt[i] = y[N_Q + i];",
            "        dydt[N_Q + i] = res[ACC_COLUMN + i];", "    }",
            "    if (n > 2 * N_Q)",
            (f"        dydt[2 * N_Q] = res[{meta['MOMENT_COLUMN']}] * p[{meta['SPEED_INDEX']}];"
             if pl.driven else "        dydt[2 * N_Q] = 0.0;")]
    if meta["POWER_COLUMNS"]:
        out += ["    if (n > 2 * N_Q + 1)",
                "        dydt[2 * N_Q + 1] = "
                + " + ".join(f"res[{k}]" for k in meta["POWER_COLUMNS"]) + ";"]
    out += ["}", "",
            "static void rhs(double t, const double *y, int64_t n, const double *p, "
            "double *dydt) {",
            "    double res[N_OUT];", "    dynamics(t, y, p, res);",
            "    derivative(y, n, p, res, dydt);", "}", ""]
    for j, lines in enumerate(gap_fns):
        out += [f"static inline void gap_{j}(double t, const double *y, const double *p, "
                "double *g) {", "    (void)t;", *lines,
                f"    g[0] = ex{j}; g[1] = ey{j}; g[2] = exd{j}; g[3] = eyd{j};", "}", ""]
    for j, lines in bearing_fns.items():
        out += [f"/* the angle and rate of joint {j}'s bearing body */",
                f"static inline void bearing_{j}(double t, const double *y, const double *p, "
                "double *b) {", "    (void)t; (void)y; (void)p;", *lines,
                f"    b[0] = pa{j}; b[1] = pw{j};", "}", ""]
    out += ["/* (delta, deltadot) of contact j */",
            "static inline void penetration(double t, const double *y, const double *p, "
            "int64_t j, double *dd) {", "    double g[4], nx, ny;",
            "    dd[0] = 0.0; dd[1] = 0.0;"]
    if profiles:
        out += ["    double b[2], rb, slope;"]
    for el in ELEMENTS:
        out += el.penetration_lines(pl.parts[el.kind])
    out += ["    (void)nx; (void)ny;", *(["    (void)rb; (void)slope;"] if profiles else []),
            "}", "",
            "static void event(double t, const double *y, const double *p, int64_t j, "
            "double *g_gd) {", "    double dd[2];", "    penetration(t, y, p, j, dd);",
            "    switching(p[MEM_START + 2 * j], dd[0], dd[1], &g_gd[0], &g_gd[1]);", "}", "",
            "/* switch joint j's contact mode; at onset store the impact velocity (floored) */",
            "static void on_event(double t, const double *y, double *p, int64_t j) {",
            "    int64_t k = MEM_START + 2 * j;",
            "    if (p[k] > 0.5) { p[k] = 0.0; return; }",
            "    double dd[2];", "    penetration(t, y, p, j, dd);", "    p[k] = 1.0;",
            "    double floor_ = 0.0;"]
    floors = [f for el in ELEMENTS for f in pl.parts[el.kind].floors]
    out += [f"    if (j == {j}) floor_ = p[{fl}];" for j, fl in floors]
    out += ["    if (j >= 0 && j < N_EVENTS)",
            "        p[k + 1] = floor_ > dd[1] ? floor_ : dd[1];   /* python's max */",
            "}", "",
            "static double monitor(double t, const double *y, int64_t n, const double *p, "
            "double *dydt,", "                      double *out, int64_t n_out, double *g, "
            "double *gd) {",
            "    double res[N_OUT];", "    dynamics(t, y, p, res);",
            "    derivative(y, n, p, res, dydt);",
            "    if (n_out >= N_OUT)", "        for (int k = 0; k < N_OUT; k++) out[k] = res[k];"]
    out += [f"    switching(p[MEM_START + {2 * j}], res[{5 * j + 1}], res[{5 * j + 2}], "
            f"&g[{j}], &gd[{j}]);" for j in range(E)]
    out += ["    double x = res[MONITOR_COLUMN];", "    double y_ = res[MONITOR_COLUMN + 1];",
            "    return sqrt(x * x + y_ * y_);", "}", "",
            "static const mbs_model MODEL = {N_STATE, N_Q, N_EVENTS, MEM_START, N_MEM, N_OUT, "
            "CONST_START, N_P,", "                              rhs, event, on_event, monitor, "
            "prepare};", "",
            "const mbs_model *mbs_model_record(void) { return &MODEL; }", ""]
    out += closure
    out += jac_lines
    out += _sens_functions(meta)
    return "\n".join(out), meta


def _sens_functions(meta: dict) -> list[str]:
    """After the Jacobian and tangent kernels: the monitor's values from a column of the
    model's quantities (`observe`: the value column of a full tangent), every switching
    function's gap (`mbs_gap`), and the DDM equations of core/sens_runtime.h (the
    sensitivity run's record and its outputs' derivatives)."""
    E = meta["N_EVENTS"]
    out = [f"#define DDM_MOMENT_ROW {meta['MOMENT_COLUMN']}",
           f"#define DDM_SPEED_INDEX {meta['SPEED_INDEX']}", "",
           "/* the monitor's outputs, switching functions and monitored value from the model's "
           "quantities",
           " * res[k stride] (OUT_COLUMNS first), as monitor has them from dynamics */",
           "static double observe(const double *p, const double *res, int64_t stride, "
           "double *out,", "                      int64_t n_out, double *g, double *gd) {",
           "    if (n_out >= N_OUT)",
           "        for (int64_t k = 0; k < N_OUT; k++) out[k] = res[k * stride];"]
    out += [f"    switching(p[MEM_START + {2 * j}], res[{5 * j + 1} * stride], "
            f"res[{5 * j + 2} * stride], &g[{j}], &gd[{j}]);" for j in range(E)]
    out += ["    double x = res[MONITOR_COLUMN * stride];",
            "    double y_ = res[(MONITOR_COLUMN + 1) * stride];",
            "    return sqrt(x * x + y_ * y_);", "}", "",
            "/* the offset of switching function j's contact point (ex, ey) and its rate into "
            "g[4] */",
            "void mbs_gap(double t, const double *y, const double *p, int64_t j, double *g) {"]
    out += [f"    if (j == {j}) gap_{j}(t, y, p, g);" for j in range(E)]
    out += ["}", ""]
    if "N_Z" in meta:           # the Jacobian and tangent kernels are there
        out += ['#include "sens_runtime.h"', ""]
    return out


def _closure_functions(c: _C, d: Derivation, pl) -> list[str]:
    """The loop closure at coordinates q (closure, closure_jacobian and closure_rate): the
    elements' closures (`Element.closure`), into res[nc] (the Jacobian row-major,
    res[nc * N_Q])."""
    w, n = pl.w, pl.n
    closing = [e for el in ELEMENTS for e in el.closure(d.parts[el.kind])]
    nc = len(closing)
    value = [f"c{i}" for i in range(nc)]
    jacobian = [f"c{i}_{k}" for i in range(nc) for k in range(n)]
    bodies = (
        ("mbs_closure", value, c.function([([w.split(e) for e in closing], value)])),
        ("mbs_closure_jacobian", jacobian,
         c.function([([w.split(d.closure_jacobian[i, k]) for i in range(nc)
                       for k in range(n)], jacobian)])),
        ("mbs_closure_rate", value, c.function([([w.split(e) for e in d.closure_rate],
                                                 value)])))
    out = [f"int64_t mbs_closure_size(void) {{ return {nc}; }}", ""]
    for name, names, body in bodies:
        out += [f"void {name}(double t, const double *y, const double *p, double *res) {{",
                "    (void)t; (void)p;", *body]
        out += [f"    res[{k}] = {nm};" for k, nm in enumerate(names)]
        out += ["}", ""]
    return out
