"""Design sensitivities of any `Linkage` by direct differentiation (DDM) on its generated
model, or by central finite differences.

The sensitivity equations use the generated model's exact Jacobian (the module's
`jacobian`, generate/jacobians.py): for each parameter b_k (a dotted name of
`Linkage.parameter_names`) the state sensitivity s_k = d(q, qdot)/db_k obeys

    d/dt s_k = [s_k's rates; dA/dy s_k + dA/dp D_k + sum_j dA/dv_j sigma_jk],

where p are the generated model's parameters, D_k = dp/db_k the chain of the description's
values into them (`chain`: radii into clearance and Eq. 9 stiffness, ...) and sigma_jk the
sensitivity of joint j's impact-velocity memory v_j, set at each contact onset with the
event-time term (core/sens_runtime.h). The state sensitivities do not jump at the
events: each contact force is zero at zero penetration in both modes. The initial
sensitivities are exact: the derivative of the assembly (journals centred: the closure
e(t0, q, p) = 0 and its rate) by the implicit function theorem with the generated Jacobian's
rows of the eccentricities and their rates.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from ..elements.registry import ELEMENTS
from ..generate.sens_runtime import fill_seed_work, work_size
from ..model.linkage import Linkage
from .linkage_model import (
    default_atol,
    integrator_settings,
    prepare,
    solve,
    specialisable,
    trajectory_from_run,
)
from .problem import Problem
from .settings import RunSettings

__all__ = ["chain", "combine", "initial_sensitivities", "independent_directions", "setup",
           "ddm_run", "DdmRun", "linkage_sensitivities", "Directions", "SensitivityProblem",
           "prepare_sensitivity", "fd_step", "central_differences", "finite_differences",
           "DDM_INTEGRATOR"]

_THIS = sys.modules[__name__]

#: method of the compiled integrator for the sensitivity equations (as the paper case's)
DDM_INTEGRATOR = "dop853"


def chain(linkage: Linkage, model, names) -> list[dict[int, float]]:
    """Per parameter name, the nonzero entries {z column: d p / d b} of the chain from the
    description's value b into the generated model's parameters p (z column of p[i]:
    1 + 2 N_Q + i); the impact-velocity floor also starts each joint's memory (see
    `initial_sensitivities`)."""
    pidx = {name: i for i, name in enumerate(model.PARAMETERS)}
    off = 1 + 2 * model.N_Q
    out = []
    for name in names:
        head, _, field = name.rpartition(".")
        entries: dict[int, float] = {}
        if name in pidx:
            # a p entry of its own (with friction the radii are too: the contact points)
            entries[off + pidx[name]] = 1.0
        if via := {n: v for el in ELEMENTS for n, v in el.chain(linkage, head, field).items()}:
            # a field of an element's joint that reaches p under another name (a clearance
            # joint's radii: its clearance and the Eq. 9 stiffness)
            entries.update({off + pidx[n]: v for n, v in via.items()})
        elif name not in pidx:
            raise AssertionError(f"no chain for parameter {name!r}")
        out.append({c: v for c, v in entries.items() if v != 0.0})
    return out


def floor_names(linkage: Linkage) -> list[str]:
    """Per contact of the generated model (the elements' contacts, in the registry's
    order) the name of its impact-velocity floor (a contact's is its joint's)."""
    return [f for el in ELEMENTS for f in el.floor_names(linkage)]


def _memory_sensitivities(linkage: Linkage, model, names) -> np.ndarray:
    """(nb, J): d(initial impact-velocity memory of contact j)/db_k (the memory starts at
    the floor)."""
    sig = np.zeros((len(names), model.N_EVENTS))
    floors = floor_names(linkage)
    for k, name in enumerate(names):
        for j, floor in enumerate(floors):
            if name == floor:
                sig[k, j] = 1.0
    return sig


def combine(linkage: Linkage, model, directions):
    """The chains (`chain`) and initial memory sensitivities (nb, J) of `directions`, each a
    mapping {description parameter name: coefficient} (a design variable that moves several
    of the description's values at once: d value / d variable)."""
    names = sorted({n for d in directions for n in d})
    per_name = dict(zip(names, chain(linkage, model, names)))
    sig_name = dict(zip(names, _memory_sensitivities(linkage, model, names)))
    entries, sigma = [], np.zeros((len(directions), model.N_EVENTS))
    for k, d in enumerate(directions):
        ent: dict[int, float] = {}
        for name, coef in d.items():
            for c, v in per_name[name].items():
                ent[c] = ent.get(c, 0.0) + coef * v
            sigma[k] += coef * sig_name[name]
        entries.append({c: v for c, v in ent.items() if v != 0.0})
    return entries, sigma


def initial_sensitivities(linkage: Linkage, model, p, y0, entries, t0: float = 0.0, *,
                          free: bool = False):
    """(nb, 2 N_Q): exact derivatives of the centred start (`linkage_model.initial_state`)
    along the chains `entries`: the closure e(t0, q, p) = 0 and its rate edot(t0, q, qdot, p)
    = 0 differentiated (least squares where the closure is not square, as the assembly).
    A free linkage's run (`free`: its span has no revolutions) holds the coordinates and
    rates its `Initial` gives: theirs are zero.
    Each joint closes through its element's rows (`Element.closure_rows`: a clearance
    joint's journal centred, a translational joint's slider offset and tilt)."""
    n = model.N_Q
    jac = model.jacobian_matrix(t0, y0, p, False)
    out, extra = model.OUT_COLUMNS.index, model.JAC_EXTRA_ROWS
    pos, rate = [], []              # closure rows: {Jacobian row: weight}
    for el in ELEMENTS:
        el_pos, el_rate = el.closure_rows(linkage, out, extra)
        pos += el_pos
        rate += el_rate

    def rows(spec):
        m = np.zeros((len(spec), jac.shape[1]))
        for i, r in enumerate(spec):
            for row, wgt in r.items():
                m[i] += wgt * jac[row]
        return m
    e, ed = rows(pos), rows(rate)
    d = np.zeros((jac.shape[1], len(entries)))
    for k, ent in enumerate(entries):
        for c, v in ent.items():
            d[c, k] += v
    held_q = held_u = np.zeros(n, dtype=bool)
    if free:
        held_q = np.array([c in linkage.start.coordinates for c in model.COORDINATES])
        held_u = np.array([c in linkage.start.rates for c in model.COORDINATES])
    dq = np.zeros((n, len(entries)))
    du = np.zeros((n, len(entries)))
    if e.shape[0] and not held_q.all():
        dq[~held_q] = -np.linalg.lstsq(e[:, 1:1 + n][:, ~held_q], e @ d, rcond=None)[0]
    if ed.shape[0] and not held_u.all():
        dq_full = ed[:, 1:1 + n] @ dq + ed @ d
        du[~held_u] = -np.linalg.lstsq(ed[:, 1 + n:1 + 2 * n][:, ~held_u], dq_full,
                                       rcond=None)[0]
    return np.hstack([dq.T, du.T])


#: relative tolerance of `independent_directions` on the dimensionless directions
DIRECTION_TOL = 1e-12


def independent_directions(M: np.ndarray, tol: float = DIRECTION_TOL):
    """A basis of the columns of M (the parameters' directions) and the coefficients C with
    M = M[:, basis] @ C.

    The sensitivity equations are linear in the direction of a parameter (its initial
    sensitivity, its chain into the model's parameters and its memory term), so parameters
    whose directions are linearly dependent need not be integrated separately: a Young's
    modulus, Poisson ratio and contact stiffness all enter through the stiffness alone, and
    a parameter with no effect has a zero direction. M must be dimensionless (rows and
    columns scaled by their reference values, see `setup`); a column joins the basis when
    its least-squares residual on the basis so far exceeds tol times its norm. Greedy in
    the given order, so the first of two proportional parameters is the one integrated. At
    least one column is kept.
    """
    M = np.asarray(M, dtype=float)
    npar = M.shape[1]
    basis: list[int] = []
    q = np.zeros((M.shape[0], npar))   # orthonormal basis of the columns kept so far
    nq = 0
    for k in range(npar):
        col = M[:, k]
        qk = q[:, :nq]
        r = col - qk @ (qk.T @ col)
        r = r - qk @ (qk.T @ r)         # Gram-Schmidt twice (re-orthogonalized)
        rn = math.sqrt(r @ r)
        if rn > tol * math.sqrt(col @ col) or (not basis and k == npar - 1):
            basis.append(k)
            if rn > 0.0:
                q[:, nq] = r / rn
                nq += 1
    coeffs = np.linalg.lstsq(M[:, basis], M, rcond=None)[0]
    return np.array(basis), coeffs


def pack_sensitivity_parameters(model, p, entries, event_time_term: bool = True,
                                record_columns=()):
    """The parameter vector of a sensitivity run (layout: generate/sens_runtime.py, read by
    core/sens_runtime.h); after the work space N_OUT slots of which the first hold
    `record_columns`, the outputs whose derivatives a run with a longer record stores
    (core/sens_runtime.h)."""
    nb = len(entries)
    m = max([1] + [len(e) for e in entries])
    cols = np.ones((nb, m))          # padding: column 1 (the first coordinate), value 0
    vals = np.zeros((nb, m))
    for k, ent in enumerate(entries):
        for e, (c, v) in enumerate(sorted(ent.items())):
            cols[k, e] = c
            vals[k, e] = v
    work = np.zeros(work_size(nb, model.N_Z, model.N_JROWS, model.N_Q, model.N_EVENTS))
    fill_seed_work(work, entries, model.N_Z, model.N_JROWS, model.N_Q,
                   1 + 2 * model.N_Q + model.MEM_START + 1, model.N_EVENTS)
    rec = np.zeros(model.N_OUT)
    rec[:len(record_columns)] = record_columns
    return np.concatenate([p, [nb, 1.0 if event_time_term else 0.0, m], cols.ravel(),
                           vals.ravel(), work, rec])


def sensitivity_state(y_state, s0, sigma0) -> np.ndarray:
    """The initial state [q, qdot, s_1 .. s_nb, W, sigma] of a sensitivity run."""
    n2 = s0.shape[1]
    return np.concatenate([y_state[:n2], s0.ravel(), [0.0], sigma0.ravel()])


def sensitivity_atol(model, atol_plain, scale) -> np.ndarray:
    """Absolute tolerances of a sensitivity run: the state's (atol_plain[:2 N_Q]), each
    direction's the state's / its parameter's scale, the work none (1 J), the memories'
    sensitivities none (not under error control), then the switching functions'
    (atol_plain[N_STATE:])."""
    n2 = 2 * model.N_Q
    a_state = atol_plain[:n2]
    return np.concatenate([a_state] + [a_state / s for s in scale] + [[1.0]]
                          + [np.full(len(scale) * model.N_EVENTS, np.inf)]
                          + [atol_plain[model.N_STATE:]])


def tangent_work(model, p) -> dict:
    """The column work of one sensitivity right-hand side (sensitivity run's p): the
    integrated directions (each one pass of the contact and the solve stages), the state
    columns contracted for every direction (t, q, qdot), and the (direction, parameter
    column) pairs evaluated (`sens_runtime.seed_index`; the memories' columns included),
    against the N_Z columns of the full Jacobian."""
    from ..generate.sens_runtime import ddm_layout, work_offsets

    nb, _, _, _, w0 = ddm_layout(p, model.N_P)
    _, use0, _, _, _ = work_offsets(nb, w0, model.N_Z, model.N_JROWS, model.N_EVENTS)
    n2 = 2 * model.N_Q
    use = p[use0:use0 + model.N_Z + 1]
    return dict(directions=int(nb), state_columns=1 + n2,
                parameter_pairs=int(use[model.N_Z] - use[1 + n2]),
                jacobian_columns=int(model.N_Z))


class DdmRun(NamedTuple):
    """A recorded DDM run: the model, its plain parameters p0 and the sensitivity run's p,
    the records (times, sensitivity states, memories, outputs of the monitor), the peaks,
    the counters, the coefficients (nb, npar) that combine the integrated directions
    into the requested ones (`independent_directions`), the directions' scales, and (a run
    with `derivatives`) the outputs' derivatives along the integrated directions at the
    recorded steps (n, len(out_columns), nb) of the outputs out_columns (indices of
    OUT_COLUMNS), else None."""

    model: Any
    p0: np.ndarray
    p: np.ndarray
    ts: np.ndarray
    ys: np.ndarray
    ms: np.ndarray
    peaks: np.ndarray
    peak_t: np.ndarray
    outs: np.ndarray
    stats: dict
    coeffs: np.ndarray
    scale: np.ndarray
    out_ders: np.ndarray | None = None
    out_columns: tuple[int, ...] = ()

    @property
    def nb(self) -> int:
        return self.coeffs.shape[0]

    def plain_states(self, ys=None) -> np.ndarray:
        """[q, qdot, W] (n, N_STATE) of the records (or of sensitivity states ys)."""
        ys = self.ys if ys is None else ys
        n2 = 2 * self.model.N_Q
        return np.column_stack([ys[:, :n2], ys[:, n2 * (1 + self.nb)]])

    def state_sensitivities(self, ys=None) -> np.ndarray:
        """(n, npar, 2 N_Q): d(q, qdot)/db_k of the requested directions."""
        ys = self.ys if ys is None else ys
        n2 = 2 * self.model.N_Q
        s = ys[:, n2:n2 * (1 + self.nb)].reshape(len(ys), self.nb, n2)
        return _combine_directions(s.transpose(0, 2, 1), self.coeffs).transpose(0, 2, 1)

    def recorded_output_sensitivities(self, rows=None):
        """Values (n, N_OUT) and derivatives (n, len(out_columns), npar) of the outputs
        along the requested directions at the recorded steps (all, or the indices `rows`),
        from the run's records (a run with `derivatives`: the monitor computed them with
        each step, as `output_sensitivities` would from the recorded states)."""
        if self.out_ders is None:
            raise ValueError("this DDM run recorded no output derivatives: run it with "
                             "derivatives=True, or use output_sensitivities")
        vals, ders = self.outs, self.out_ders
        if rows is not None:
            vals, ders = vals[rows], ders[rows]
        return vals, _combine_directions(ders, self.coeffs)

    def growth(self, unit, period, revolutions, windows=None) -> np.ndarray:
        """`growth_maxima` of the requested directions over all recorded steps, without
        forming their state sensitivities (`_window_norm_maxima`); per window of the edges
        `windows` (a free linkage's) instead of per revolution if given."""
        n2 = 2 * self.model.N_Q
        s = self.ys[:, n2:n2 * (1 + self.nb)].reshape(len(self.ys), self.nb, n2)
        weights = (self.scale[:, None] / np.asarray(unit)[None, :]) ** 2
        lo, hi = (_revolution_rows(self.ts, period, revolutions) if windows is None
                  else _window_rows(self.ts, windows))
        return np.sqrt(_window_norm_maxima(s, *_sparse_columns(self.coeffs), weights, lo, hi))

    def output_sensitivities(self, ts, ys, ms):
        """Values (n, N_OUT) and derivatives (n, N_OUT, npar) of the model's outputs along
        the requested directions at times ts, sensitivity states ys and memories ms (a
        second pass of the tangent: for states between the recorded steps; at the recorded
        steps `recorded_output_sensitivities` has them)."""
        vals, ders = self.model.output_sensitivities(
            np.ascontiguousarray(ts), np.ascontiguousarray(ys),
            np.ascontiguousarray(ms[:, :self.model.N_MEM]), self.p)
        return vals, _combine_directions(ders, self.coeffs)


def _combine_directions(a: np.ndarray, coeffs: np.ndarray) -> np.ndarray:
    """a (n, m, nb) @ coeffs (nb, npar): (n, m, npar), one matrix product (the coefficients
    are mostly an identity: the same numbers as summing each column's nonzero terms in
    order, to the last bit on the paper case, and 4 times faster than that loop)."""
    return np.matmul(a, np.asarray(coeffs, dtype=float))


def _sparse_columns(coeffs):
    """coeffs (nb, npar) by columns, its nonzero entries only: (ptr (npar + 1), rows,
    values); column k's entries are ptr[k]:ptr[k + 1]. The coefficients of independent
    directions are mostly an identity (one entry per requested direction that is
    integrated)."""
    ptr, rows, vals = [0], [], []
    for k in range(coeffs.shape[1]):
        nz = np.flatnonzero(coeffs[:, k])
        rows += nz.tolist()
        vals += coeffs[nz, k].tolist()
        ptr.append(len(rows))
    return np.array(ptr, dtype=np.int64), np.array(rows, dtype=np.int64), np.array(vals)


def _window_norm_maxima(s, ptr, rows, vals, weights, lo, hi):
    """Per window w (rows lo[w]:hi[w]) the maximum over its rows i of
    sum_j weights[k, j] (sum_b s[i, b, j] coeffs[b, k])^2 (nw, npar), at least 0: the
    squared weighted norms of the combined state sensitivities (coeffs by
    `_sparse_columns`), from those of the integrated directions s (n, nb, 2 N_Q). One pass
    in C over the rows (`c_loader.window_norm_maxima`, the numpy formula's operations)."""
    from ..generate.c_loader import window_norm_maxima

    return window_norm_maxima(s, ptr, rows, vals, weights, lo, hi)


def magnitude_derivative(vals, col, ders, row):
    """d|F|/db (n, npar) of the force F = (vals[:, col], vals[:, col + 1]) from its
    components' derivatives ders[:, row], ders[:, row + 1] (n, ., npar): (F . dF) / |F|
    (|F| floored at 1e-300)."""
    fx, fy = vals[:, col], vals[:, col + 1]
    inv = 1.0 / np.maximum(np.hypot(fx, fy), 1e-300)
    return (fx[:, None] * ders[:, row, :] + fy[:, None] * ders[:, row + 1, :]) * inv[:, None]


def setup(problem: Problem, directions, scale, event_time_term: bool = True,
          fixed_start: bool = False, record_columns=()):
    """The sensitivity system of `directions` (see `combine`) about the plain run
    `problem`: one integrated direction per independent one (`independent_directions` on
    the directions made dimensionless: the initial sensitivities by the state's tolerance
    scales, the chains by the parameters' values, the memories by the floors, and each
    direction by its `scale`). Returns (y0, p, atol, coefficients (nb, npar)). With
    `fixed_start` the initial state and memories do not move with the parameters (a
    `linkage_model.Start`): the sensitivities start at zero. record_columns: see
    `pack_sensitivity_parameters`."""
    linkage, model, p0 = problem.linkage, problem.model, problem.p
    entries, sigma = combine(linkage, model, directions)
    if fixed_start:
        s0 = np.zeros((len(entries), 2 * model.N_Q))
        sigma = np.zeros_like(sigma)
    else:
        s0 = initial_sensitivities(linkage, model, p0, problem.y0, entries,
                                   free=problem.span.revolutions is None)
    n2, off = 2 * model.N_Q, 1 + 2 * model.N_Q
    cols = sorted({c for e in entries for c in e})
    pcol = np.abs(p0[[c - off for c in cols]])
    dense = np.zeros((len(cols), len(entries)))
    for k, ent in enumerate(entries):
        for i, c in enumerate(cols):
            dense[i, k] = ent.get(c, 0.0)
    floors = np.array([p0[model.PARAMETERS.index(f)] for f in floor_names(linkage)])
    state_scale = default_atol(linkage, model, 1.0)[:n2]
    M = np.vstack([s0.T / state_scale[:, None],
                   dense / np.where(pcol > 0.0, pcol, 1.0)[:, None],
                   sigma.T / floors[:, None]]) * np.asarray(scale)[None, :]
    basis, coeffs = _THIS.independent_directions(M)
    coeffs = coeffs * np.asarray(scale)[basis, None] / np.asarray(scale)[None, :]
    coeffs[:, basis] = np.eye(len(basis))     # exactly (no least-squares round-off)
    p = pack_sensitivity_parameters(model, p0, [entries[b] for b in basis], event_time_term,
                                    record_columns)
    y0 = sensitivity_state(problem.y0, s0[basis], sigma[basis])
    atol = sensitivity_atol(model, problem.integrator.atol, np.asarray(scale)[basis])
    return y0, p, atol, coeffs


@dataclass(frozen=True)
class Directions:
    """Design names that are not the description's parameters (the paper's fields,
    `mechanism.field_directions`): each name's direction in the parameters ({dotted path:
    coefficient}), its value (`reference`), the scale of its sensitivities' tolerances and
    the units of the state in the growth diagnostic (None: the description's)."""

    directions: list
    reference: np.ndarray
    scale: np.ndarray
    unit: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class SensitivityProblem:
    """A DDM run (or finite differences) prepared: the plain run's `Problem` (the model,
    specialised unless a direction moves one of its zero-valued geometric parameters; the
    span, tolerances, parameter vector and start) and the design `names` with their
    `Directions`; `start`: the `linkage_model.Start` it runs from (held fixed), if any."""

    problem: Problem
    names: tuple[str, ...]
    directions: Directions
    start: object = None

    @property
    def fixed_start(self) -> bool:
        """Whether the run starts from a `Start`: its sensitivities start at zero."""
        return self.start is not None


def prepare_sensitivity(linkage: Linkage, names, revolutions: int | None = None,
                        settings: RunSettings | None = None, *,
                        directions: Directions | None = None, duration: float | None = None,
                        window: float | None = None, t_eval=None, start=None,
                        whole: bool | None = None, record: bool = True,
                        specialise: bool | None = None, **options) -> SensitivityProblem:
    """The one door of a DDM run (and of finite differences): the plain run's `Problem`
    (`linkage_model.prepare`: every argument checked, the span of `revolutions`, or of a
    free linkage's `duration` s in windows of `window` s, the tolerances, the parameter
    vector and the centred start or `start`) and the directions of the design names
    `names`: the description's parameters themselves, each direction's tolerance scaled
    by its parameter's natural scale (as the finite differences' steps: a radius enters
    through the clearance), or `directions` (names that are not the description's
    parameters). With `t_eval` the run lands on those times and (`whole` False; None: unless
    `directions` are given) ends at the last of them. `specialise` (None: as the directions
    allow, `specialisable`) picks the model. A profiled bearing is refused."""
    from ..generate.profiles import refuse_sensitivity_runs

    refuse_sensitivity_runs(linkage)
    names = tuple(names)
    paths = names if directions is None else sorted(
        {k for d in directions.directions for k in d})
    if specialise is None:
        specialise = specialisable(linkage, paths)
    problem = prepare(linkage, revolutions, settings, duration=duration, window=window,
                      t_eval=t_eval, whole=directions is not None if whole is None else whole,
                      start=start,
                      record=record, specialise=specialise, **options)
    if directions is None:
        directions = Directions([{n: 1.0} for n in names],
                                np.array([linkage.parameter_value(n) for n in names]),
                                np.array([fd_step(linkage, n, 1.0) for n in names]))
    return SensitivityProblem(problem, names, directions, start)


def ddm_run(sp: SensitivityProblem, *, event_time_term: bool = True, derivatives=False
            ) -> DdmRun:
    """Integrate the sensitivity equations of the prepared `sp` (see `setup`) over its span
    (landing on its t_eval if given, without peak refinement); returns the `DdmRun`. With
    `derivatives` (True: every output; or a sequence of names in OUT_COLUMNS) and a
    recording problem the derivatives of those outputs are computed with every step and
    recorded (`DdmRun.recorded_output_sensitivities`)."""
    problem = sp.problem
    linkage, model = problem.linkage, problem.model
    record = problem.integrator.record
    for el in ELEMENTS:
        el.sensitivity_check(linkage)
    zeros = set(getattr(model, "ZERO_PARAMETERS", ()))
    along = sorted({n for d in sp.directions.directions for n, v in d.items()
                    if v != 0.0 and n in zeros})
    if along:
        raise ValueError(f"directions along {along}: the model of linkage {linkage.name!r} "
                         "is specialised on them being zero (no derivatives along them); use "
                         "mbs_clearance.generate.load_model(linkage, specialise=False)")
    if derivatives is True:
        derivatives = model.OUT_COLUMNS
    unknown = [c for c in derivatives or () if c not in model.OUT_COLUMNS]
    if unknown:
        raise ValueError(f"derivatives: unknown output(s) {unknown}; the outputs of linkage "
                         f"{linkage.name!r} are {list(model.OUT_COLUMNS)}")
    columns = tuple(model.OUT_COLUMNS.index(c) for c in derivatives) \
        if derivatives and record else ()
    scale = np.asarray(sp.directions.scale, dtype=float)
    y0, p, atol, coeffs = setup(problem, sp.directions.directions, scale, event_time_term,
                                sp.fixed_start, columns)
    nb = coeffs.shape[0]
    t0 = time.perf_counter()
    n_out = model.N_OUT + len(columns) * nb if columns else None
    ts, ys, ms, peaks, peak_t, outs, stats = _run(problem, y0, p, 2 * model.N_Q * (1 + nb),
                                                  atol, n_out=n_out)
    stats.update(wall_time=time.perf_counter() - t0, event_time_term=event_time_term,
                 directions=nb)
    out_ders = None
    if columns:
        out_ders = outs[:, model.N_OUT:].reshape(len(ts), len(columns), nb)
        outs = outs[:, :model.N_OUT]
    return DdmRun(model, problem.p.copy(), p, ts, ys, ms, peaks, peak_t, outs, stats, coeffs,
                  scale, out_ders, columns)


def _run(problem: Problem, y0, p, n_err, atol, kernel="integrate_sens", n_out=None):
    """The compiled integrator's run of the sensitivity state y0 with p over `problem`'s
    span, with its settings (tolerances `atol` on the leading `n_err` components, recording
    `n_out` outputs per step, default N_OUT): (ts, ys, ms, peaks, peak_t, outs, stats)."""
    from .._checks import MemoryLimitError, format_bytes
    from ..numerics.integrator import COUNTERS, METHODS, RESULTS

    linkage, model, edges = problem.linkage, problem.model, problem.span.edges
    plain = problem.integrator
    max_steps, max_memory, record = problem.max_steps, problem.max_memory, plain.record
    # the record never outgrows the memory limit: a run that would stops there
    n_out = (model.N_OUT if n_out is None else n_out) if record else 0
    row = 8 * (1 + len(y0) + model.N_MEM + n_out)
    limit = min(max_steps, max(1, (max_memory - 24 * len(edges)) // row)) if record \
        else max_steps
    settings = integrator_settings(
        linkage, model, problem.rtol, atol, h_max=plain.h_max, max_steps=limit,
        record=record, event_tol=plain.event_tol, n_samples=plain.n_samples,
        refine_iters=plain.refine_iters, n_out=n_out, n_err=n_err)
    ts, ys, ms, peaks, peak_t, counters, outs, status = getattr(model, kernel)(
        y0, p, edges, settings, METHODS[problem.method].arrays())
    status = RESULTS(int(status))
    if status == RESULTS.max_steps and limit < max_steps:
        raise MemoryLimitError(
            f"the record of linkage {linkage.name!r} reached {format_bytes(max_memory)} (the "
            f"memory limit, max_memory) at t = {ts[-1]:.6g} s, after {limit} steps; run fewer "
            "revolutions")
    if status != RESULTS.success:
        raise RuntimeError(f"integration of linkage {linkage.name!r} failed at about t = "
                           f"{ts[-1] if len(ts) else float('nan'):.6g} s: {status.message}")
    stats = {k: int(v) for k, v in zip(COUNTERS, counters)}
    stats.update(method=problem.method, rtol=problem.rtol)
    return ts, ys, ms, peaks, peak_t, outs, stats


def landed(ts, t_eval):
    """Indices of the recorded steps at the times t_eval (the integrator lands on each
    window edge; the last record at that time holds the memory the next step uses)."""
    idx = np.searchsorted(ts, t_eval, side="right") - 1
    if np.any(np.abs(ts[idx] - t_eval) > 1e-12 * max(1.0, float(np.max(np.abs(t_eval))))):
        raise RuntimeError("the run did not land on every requested time")
    return idx


def _unit(sp: SensitivityProblem) -> np.ndarray:
    """The state's units in the growth diagnostic: the directions' own, else angles 1 rad
    and lengths the smallest clearance, rates those at the drive speed (a free linkage:
    over its `time_scale`)."""
    if sp.directions.unit is not None:
        return sp.directions.unit
    linkage, model = sp.problem.linkage, sp.problem.model
    w = 1.0 / linkage.time_scale if sp.problem.span.revolutions is None \
        else linkage.drive.speed
    unit = np.array([1.0 if name.endswith(".angle") else linkage.min_clearance
                     for name in model.COORDINATES])
    return np.concatenate([unit, unit * w])


def linkage_sensitivities(sp: SensitivityProblem, event_time_term: bool = True):
    """DDM of the prepared `sp` (see the module docstring): (Sensitivities fields as a
    dict). From a `start` the start is held fixed: the sensitivities start at zero. A free
    linkage runs over its span's time windows instead of revolutions (its growth per
    window, its crank_moment None: it has no drive)."""
    run = ddm_run(sp, event_time_term=event_time_term, derivatives=True)
    problem = sp.problem
    linkage, model, p0, span = problem.linkage, run.model, run.p0, problem.span
    ts, ys, ms = run.ts, run.ys, run.ms
    growth = (run.growth(_unit(sp), None, None, span.windows) if span.revolutions is None
              else run.growth(_unit(sp), linkage.period, span.revolutions))
    peaks, keep = run.peaks, None
    if span.t_eval is not None:
        keep = landed(ts, span.t_eval)
        ts, ys, ms = ts[keep], ys[keep], ms[keep]
        peaks = None
    vals, ders = run.recorded_output_sensitivities(keep)
    traj = trajectory_from_run(linkage, model, ts, run.plain_states(ys), ms, p0, run.stats,
                               peaks, vals)
    fields = _fields(model, ts, sp.names, sp.directions.reference, ders, traj, growth,
                     run.stats)
    sens = run.state_sensitivities(ys)
    for i, cname in enumerate(model.COORDINATES):
        fields["outputs"][cname] = sens[:, :, i]
    return fields


def growth_maxima(ts, sens, scale, unit, period, revolutions):
    """Per revolution and parameter, the maximum of the normalized state-sensitivity norm
    |s_k scale_k / unit| (sens (n, npar, 2 N_Q) at the recorded times ts)."""
    weights = (np.asarray(scale)[:, None] / unit[None, :]) ** 2
    norm2 = np.einsum("nkj,kj->nk", sens * sens, weights, optimize=False)
    return _revolution_maxima(ts, norm2, period, revolutions)


def _window_rows(ts, edges):
    """Per window between the edges (as far as the times ts reach) the rows lo:hi of the
    times ts in it (a step on an edge counts for both sides)."""
    edges = np.minimum(np.asarray(edges, dtype=float), ts[-1])
    edges = edges[:max(2, int(np.searchsorted(edges, ts[-1], side="left")) + 1)]
    lo = np.searchsorted(ts, edges[:-1], side="left")
    hi = np.searchsorted(ts, edges[1:], side="right")
    return lo.astype(np.int64), hi.astype(np.int64)


def _revolution_rows(ts, period, revolutions):
    """Per revolution (a step on an edge counts for both sides; at most as many as the
    times ts reach) the rows lo:hi of the times ts in it."""
    revolutions = min(revolutions, int(np.ceil(ts[-1] / period - 1e-9)))
    edges = np.minimum(np.arange(revolutions + 1) * period, ts[-1])
    lo = np.searchsorted(ts, edges[:-1], side="left")
    hi = np.searchsorted(ts, edges[1:], side="right")
    return lo.astype(np.int64), hi.astype(np.int64)


def _revolution_maxima(ts, norm2, period, revolutions):
    """Per revolution (`_revolution_rows`) the maxima of the squared norms norm2 (n, npar)
    at the times ts, square-rooted."""
    lo, hi = _revolution_rows(ts, period, revolutions)
    out = np.zeros((len(lo), norm2.shape[1]))
    for r in range(len(lo)):
        if hi[r] > lo[r]:
            out[r] = norm2[lo[r]:hi[r]].max(axis=0)
    return np.sqrt(out)


def _fields(model, ts, names, ref, ders, traj, growth, stats):
    col = {c: i for i, c in enumerate(model.OUT_COLUMNS)}
    mon = model.MONITOR_COLUMN
    force = ders[:, mon:mon + 2, :]
    d_mag = magnitude_derivative(np.ascontiguousarray(traj.base_force), 0, ders, mon)
    contact = np.stack([ders[:, col[f"{j}.contact_force"], :] for j in model.JOINTS], axis=1)
    if model.N_EVENTS == 1:
        contact = contact[:, 0, :]
    # views of ders, not copies (a strided copy per output cost a tenth of a paper DDM run)
    outputs = {c: ders[:, i, :] for c, i in col.items()}
    return dict(t=ts, parameters=tuple(names), reference=ref, base_force=force.copy(),
                base_force_magnitude=d_mag,
                crank_moment=outputs.get("drive_moment"),
                contact_force=contact, trajectory=traj, method="ddm", backend="reduced",
                growth=growth, stats=stats, outputs=outputs)


def fd_step(linkage: Linkage, name: str, relative: float) -> float:
    """Central-difference step of the design name `name` (`model.design`; the one step
    rule of every finite difference): `relative` times its value; a clearance relative to
    itself, the radii relative to the clearance, a case's override relative to its value
    (1 of its unit where zero), zero-valued coordinates relative to the length scale, a
    zero angle relative to 1 rad, zero gravity relative to 9.81 m/s^2. On the paper's case
    a field of its table (`mechanism.FIELD_PATHS`) is valued as the field (its derived
    value where None), a radius of its one clearance joint."""
    from ..model import design
    from ..model.mechanism import FIELD_PATHS, PAPER_JOINT, reference_value

    if name.endswith("clearance"):
        return relative * design.design_value(linkage, name)
    paper = design.slider_crank_of(linkage) if name in FIELD_PATHS else None
    if paper is None and name in design._case_table(linkage):
        value = abs(design.design_value(linkage, name))
        return relative * (value if value != 0.0 else 1.0)
    name = design._dotted(name)
    head, _, field = name.rpartition(".")
    for el in ELEMENTS:
        # a bare field: the paper's one clearance joint's
        scale = el.fd_scale(linkage, head or PAPER_JOINT, field)
        if scale is not None:
            return relative * scale
    value = abs(reference_value(paper, name) if paper is not None
                else linkage.parameter_value(name))
    if value != 0.0:
        return relative * value
    if field in ("x", "y"):
        return relative * linkage.length_scale
    return relative * (9.81 if name == "gravity" else 1.0)


def central_differences(linkage: Linkage, names, relative: float, evaluate, args=(), *,
                        executor=None, processes: int | None = None):
    """The perturbed runs of central differences along the design names `names`
    (`model.design`): the steps h_k (`fd_step`) and evaluate((design, *args)) of `linkage`
    with each value at b0 + h_k and b0 - h_k (`design.linkage_with`), through
    `executor.map`, else in `processes` worker processes, else here (`evaluate` module
    level: picklable). Returns (steps (p,), plus (p), minus (p)). ValueError where a step
    leaves a value's valid range, before any run."""
    from concurrent.futures import ProcessPoolExecutor

    from ..model import design

    steps = np.array([fd_step(linkage, n, relative) for n in names])
    jobs = []
    for name, h in zip(names, steps):
        b0 = design.design_value(linkage, name)
        for sign in (1.0, -1.0):
            try:
                jobs.append((design.linkage_with(linkage, {name: b0 + sign * h}), *args))
            except ValueError as exc:
                raise ValueError(f"the finite-difference step of {name} ({h:.3g}) leaves its "
                                 f"valid range: {exc}; pass a smaller fd_relative_step"
                                 ) from exc
    if executor is not None:
        values = list(executor.map(evaluate, jobs))
    elif processes:
        with ProcessPoolExecutor(max_workers=processes) as pool:
            values = list(pool.map(evaluate, jobs))
    else:
        values = [evaluate(j) for j in jobs]
    return steps, values[0::2], values[1::2]


def _reduced_at(job):
    """One run of the finite differences on the reduced model (module level: picklable):
    the plain run of the design landing on t_eval (`linkage_model.run`, ending at the last
    of them, from `start` if given), its outputs (n, N_OUT) and coordinates (n, N_Q)."""
    from .linkage_model import run

    design, revolutions, t_eval, settings, start, specialise = job
    out = run(design, revolutions, settings, edges=np.array([0.0, t_eval[-1]]),
              t_eval=t_eval, start=start, specialise=specialise)
    return out.outs[:, :out.model.N_OUT], out.ys[:, :out.model.N_Q]


def _backend_at(job):
    """One run of the finite differences through another backend (module level:
    picklable): the design's `simulate` (as the paper's `SliderCrank` where it was given
    so) over `revolutions`; its Trajectory."""
    from ..model.cases import slider_crank_of
    from .simulate import simulate

    design, as_paper, revolutions, backend, options = job
    return simulate(slider_crank_of(design) if as_paper else design, revolutions,
                    backend=backend, **options)


def finite_differences(sp: SensitivityProblem, relative: float, *, backend: str = "reduced",
                       as_paper: bool = False, executor=None, n_jobs: int | None = None,
                       options=None) -> dict:
    """Central finite differences (`central_differences`, steps `relative` by `fd_step`)
    of the prepared `sp`: (Sensitivities fields as a dict). The reduced model: every run
    lands on sp's t_eval (from its start if it has one, on its model: the general one if a
    zero-valued geometric parameter is among the names), the derivatives of every output
    and coordinate. Another `backend`: its `simulate` runs over sp's revolutions (with
    `options`; the paper's `SliderCrank` where `as_paper`), in `n_jobs` processes (default
    2) or through `executor`: the monitored force, drive moment and contact force."""
    problem = sp.problem
    linkage, model, span, names = problem.linkage, problem.model, problem.span, sp.names
    t0 = time.perf_counter()
    if backend == "reduced":
        nominal = solve(problem)
        args = (span.revolutions, span.t_eval, problem.settings, sp.start, problem.specialise)
        steps, plus, minus = central_differences(linkage, names, relative, _reduced_at, args,
                                                 executor=executor)
        ders = np.stack([(a[0] - b[0]) / (2 * h) for a, b, h in zip(plus, minus, steps)], -1)
        coords = np.stack([(a[1] - b[1]) / (2 * h) for a, b, h in zip(plus, minus, steps)],
                          -1)
        stats = nominal.stats
        stats.update(fd_steps=steps.tolist(), runs=2 * len(names) + 1,
                     wall_time=time.perf_counter() - t0)
        traj = trajectory_from_run(linkage, model, nominal.ts, nominal.ys, nominal.ms,
                                   nominal.p, stats, None, nominal.outs)
        fields = _fields(model, nominal.ts, names, sp.directions.reference, ders, traj,
                         None, stats)
        for i, c in enumerate(model.COORDINATES):
            fields["outputs"][c] = coords[:, i, :]
        fields["method"] = "fd"
        return fields
    args = (as_paper, span.revolutions, backend, dict(options or {}))
    steps, plus, minus = central_differences(
        linkage, names, relative, _backend_at, args, executor=executor,
        processes=None if executor is not None or n_jobs == 1 else (n_jobs or 2))
    nominal = _backend_at((linkage, *args))
    n = len(nominal.t)
    for run in (*plus, *minus):
        if len(run.t) != n or not np.allclose(run.t, nominal.t, rtol=0, atol=1e-12):
            raise RuntimeError("perturbed runs returned different time grids")

    def diff(series):
        return np.stack([(series(a) - series(b)) / (2 * h)
                         for a, b, h in zip(plus, minus, steps)], -1)
    stats = {"fd_steps": steps.tolist(), "runs": 2 * len(names) + 1,
             "wall_time": time.perf_counter() - t0}
    return dict(t=nominal.t, parameters=names, reference=sp.directions.reference,
                base_force=diff(lambda r: r.base_force),
                base_force_magnitude=diff(lambda r: np.hypot(*r.base_force.T)),
                crank_moment=diff(lambda r: r.crank_moment),
                contact_force=diff(lambda r: r.contact_force), trajectory=nominal,
                method="fd", backend=backend, stats=stats)
