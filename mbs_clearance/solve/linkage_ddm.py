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
    DEFAULT_MAX_STEPS,
    REFINE_ITERS,
    _tolerances,
    check_start,
    default_atol,
    event_tolerance,
    initial_state,
    integrator_settings,
    load_model,
    pack_parameters,
    specialisable,
    trajectory_from_run,
)
from .settings import RunSettings

__all__ = ["chain", "combine", "initial_sensitivities", "independent_directions", "setup",
           "ddm_run", "DdmRun", "linkage_sensitivities", "design_run", "Directions", "fd_step",
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


def initial_sensitivities(linkage: Linkage, model, p, y0, entries, t0: float = 0.0):
    """(nb, 2 N_Q): exact derivatives of the centred start (`linkage_model.initial_state`)
    along the chains `entries`: the closure e(t0, q, p) = 0 and its rate edot(t0, q, qdot, p)
    = 0 differentiated (least squares where the closure is not square, as the assembly).
    A free linkage holds the coordinates and rates its `Initial` gives: theirs are zero.
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
    if linkage.drive is None:
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


def setup(linkage: Linkage, model, p0, y_state, directions, scale, atol_plain,
          event_time_term: bool = True, fixed_start: bool = False, record_columns=()):
    """The sensitivity system of `directions` (see `combine`): one integrated direction per
    independent one (`independent_directions` on the directions made dimensionless: the
    initial sensitivities by the state's tolerance scales, the chains by the parameters'
    values, the memories by the floors, and each direction by its `scale`). Returns (y0, p,
    atol, coefficients (nb, npar)). With `fixed_start` the initial state and memories do not
    move with the parameters (a `linkage_model.Start`): the sensitivities start at zero.
    record_columns: see `pack_sensitivity_parameters`."""
    entries, sigma = combine(linkage, model, directions)
    if fixed_start:
        s0 = np.zeros((len(entries), 2 * model.N_Q))
        sigma = np.zeros_like(sigma)
    else:
        s0 = initial_sensitivities(linkage, model, p0, y_state, entries)
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
    y0 = sensitivity_state(y_state, s0[basis], sigma[basis])
    atol = sensitivity_atol(model, atol_plain, np.asarray(scale)[basis])
    return y0, p, atol, coeffs


def ddm_run(linkage: Linkage, model, p0, y_state, directions, *, scale, rtol, atol_plain,
            revolutions: int, t_eval=None, event_time_term: bool = True,
            method: str = DDM_INTEGRATOR, record: bool = True, whole: bool = False,
            fixed_start: bool = False, derivatives=False, windows=None) -> DdmRun:
    """Integrate the sensitivity equations of `directions` (see `setup`) over `revolutions`
    drive revolutions (landing on the times t_eval if given, without peak refinement, and
    ending at the last unless `whole`); returns the `DdmRun`. With `derivatives` (True:
    every output; or a sequence of names in OUT_COLUMNS) and `record` the derivatives of
    those outputs are computed with every step and recorded
    (`DdmRun.recorded_output_sensitivities`). A free linkage runs over the window edges
    `windows` (s, from 0; `linkage_model.time_edges`) instead of revolutions."""
    from ..generate.profiles import refuse_sensitivity_runs

    refuse_sensitivity_runs(linkage)
    for el in ELEMENTS:
        el.sensitivity_check(linkage)
    zeros = set(getattr(model, "ZERO_PARAMETERS", ()))
    along = sorted({n for d in directions for n, v in d.items() if v != 0.0 and n in zeros})
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
    y0, p, atol, coeffs = setup(linkage, model, p0, y_state, directions, scale,
                                atol_plain, event_time_term, fixed_start, columns)
    nb = coeffs.shape[0]
    edges = _edges(linkage, revolutions, t_eval, whole, windows)
    t0 = time.perf_counter()
    n_out = model.N_OUT + len(columns) * nb if columns else None
    ts, ys, ms, peaks, peak_t, outs, stats = _run(
        linkage, model, y0, p, edges, rtol, method, 2 * model.N_Q * (1 + nb), atol,
        record=record, refine=REFINE_ITERS if t_eval is None else 0, n_out=n_out)
    stats.update(wall_time=time.perf_counter() - t0, event_time_term=event_time_term,
                 directions=nb)
    out_ders = None
    if columns:
        out_ders = outs[:, model.N_OUT:].reshape(len(ts), len(columns), nb)
        outs = outs[:, :model.N_OUT]
    return DdmRun(model, p0, p, ts, ys, ms, peaks, peak_t, outs, stats, coeffs,
                  np.asarray(scale, dtype=float), out_ders, columns)


def _run(linkage, model, y0, p, edges, rtol, method, n_err, atol, record=True,
         max_steps=DEFAULT_MAX_STEPS, kernel="integrate_sens", refine=REFINE_ITERS,
         n_out=None):
    from .._checks import MemoryLimitError, default_max_memory, format_bytes
    from ..numerics.integrator import COUNTERS, METHODS, RESULTS

    event_tol = event_tolerance(linkage)
    # the record never outgrows the default memory limit: a run that would stops there
    max_memory = default_max_memory()
    n_out = (model.N_OUT if n_out is None else n_out) if record else 0
    row = 8 * (1 + len(y0) + model.N_MEM + n_out)
    limit = min(max_steps, max(1, (max_memory - 24 * len(edges)) // row)) if record \
        else max_steps
    settings = integrator_settings(
        linkage, model, rtol, atol, h_max=_h_max(linkage), max_steps=limit, record=record,
        event_tol=event_tol, refine_iters=refine, n_out=n_out, n_err=n_err)
    ts, ys, ms, peaks, peak_t, counters, outs, status = getattr(model, kernel)(
        y0, p, edges, settings, METHODS[method].arrays())
    status = RESULTS(int(status))
    if status == RESULTS.max_steps and limit < max_steps:
        raise MemoryLimitError(
            f"the record of linkage {linkage.name!r} reached {format_bytes(max_memory)} (the "
            f"default memory limit) at t = {ts[-1]:.6g} s, after {limit} steps; run fewer "
            "revolutions")
    if status != RESULTS.success:
        raise RuntimeError(f"integration of linkage {linkage.name!r} failed at about t = "
                           f"{ts[-1] if len(ts) else float('nan'):.6g} s: {status.message}")
    stats = {k: int(v) for k, v in zip(COUNTERS, counters)}
    stats.update(method=method, rtol=float(rtol))
    return ts, ys, ms, peaks, peak_t, outs, stats


def _h_max(linkage) -> float:
    """The largest step, as the plain run's: an eighth of a revolution (a free linkage: of
    its `time_scale`)."""
    return (linkage.time_scale if linkage.drive is None else linkage.period) / 8


def _edges(linkage, revolutions, t_eval, whole: bool = False, windows=None):
    """Window edges of a run: the revolutions (a free linkage: the edges `windows`), or
    (t_eval given) 0 and the times t_eval: the run lands on each and ends at the last; with
    `whole` it runs the revolutions too (as a SliderCrank's runs do)."""
    edges = np.asarray(windows, dtype=float) if windows is not None else \
        np.arange(revolutions + 1) * linkage.period
    if t_eval is None:
        return edges
    edges = np.union1d(edges if whole else [0.0], t_eval)
    return edges[np.concatenate([[True], np.diff(edges) > 1e-12 * edges[-1]])]


def landed(ts, t_eval):
    """Indices of the recorded steps at the times t_eval (the integrator lands on each
    window edge; the last record at that time holds the memory the next step uses)."""
    idx = np.searchsorted(ts, t_eval, side="right") - 1
    if np.any(np.abs(ts[idx] - t_eval) > 1e-12 * max(1.0, float(np.max(np.abs(t_eval))))):
        raise RuntimeError("the run did not land on every requested time")
    return idx


def plain_setup(linkage: Linkage, rtol: float | None, start=None, specialise: bool = True):
    """What a DDM run of `linkage` starts from, as its plain run: the generated model
    (`specialise`: the one specialised on its zero-valued geometric parameters), the
    parameter vector, the centred initial state (or `start`'s, a `linkage_model.Start`,
    with its memories in p0) and the plain run's tolerances (rtol, atol with the switching
    functions'). Returns (model, p0, y_state, rtol, atol). A free linkage starts from its
    `Initial` (no `start`). The model is the compiled C model. A profiled bearing is
    refused."""
    from ..generate.profiles import refuse_sensitivity_runs

    refuse_sensitivity_runs(linkage)
    if linkage.drive is None and start is not None:
        raise ValueError("start is for a driven linkage; a free linkage starts from its "
                         "initial (Linkage.initial, an Initial)")
    model = load_model(linkage, specialise)
    rtol, atol = _tolerances(linkage, model, rtol, None)
    p0 = pack_parameters(linkage, model)
    if start is None:
        return model, p0, initial_state(linkage, model, p0), rtol, atol
    return model, p0, check_start(linkage, model, p0, start, event_tolerance(linkage)), \
        rtol, atol


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


def design_run(linkage: Linkage, names: tuple[str, ...], rtol: float | None, *,
               revolutions: int | None, t_eval=None, event_time_term: bool = True,
               method: str = DDM_INTEGRATOR, start=None, windows=None, record: bool = True,
               derivatives=True, directions: Directions | None = None) -> DdmRun:
    """The DDM run of `linkage` along the design names `names` from its plain run's start
    (or `start`, held fixed) with its plain run's tolerances (`plain_setup`): the
    description's parameters themselves, or `directions` (their names' directions, then
    the run covers the revolutions too, `ddm_run`'s ``whole``). Each direction's
    tolerance is scaled by its parameter's natural scale (as the finite differences'
    steps: a radius enters through the clearance; `directions`' own scale)."""
    paths = names if directions is None else sorted(
        {k for d in directions.directions for k in d})
    model, p0, y_state, rtol, atol_plain = plain_setup(linkage, rtol, start,
                                                       specialisable(linkage, paths))
    if directions is None:
        scale = np.array([fd_step(linkage, n, 1.0) for n in names])
        along = [{n: 1.0} for n in names]
    else:
        scale, along = directions.scale, directions.directions
    return ddm_run(linkage, model, p0, y_state, along, scale=scale, rtol=rtol,
                   atol_plain=atol_plain, revolutions=revolutions, t_eval=t_eval,
                   event_time_term=event_time_term, method=method,
                   fixed_start=start is not None, record=record,
                   whole=directions is not None, derivatives=derivatives, windows=windows)


def linkage_sensitivities(linkage: Linkage, names: tuple[str, ...], revolutions: int | None,
                          rtol: float | None, t_eval, event_time_term: bool, method: str,
                          start=None, windows=None, directions: Directions | None = None):
    """DDM of `linkage` (see the module docstring): (Sensitivities fields as a dict). From
    `start` (a `linkage_model.Start`) the start is held fixed: the sensitivities start at
    zero. A free linkage runs over the window edges `windows` (s) instead of revolutions
    (its growth per window, its crank_moment None: it has no drive). `directions`: names
    that are not parameters of the description (`design_run`)."""
    run = design_run(linkage, names, rtol, revolutions=revolutions, t_eval=t_eval,
                     event_time_term=event_time_term, method=method, start=start,
                     windows=windows, directions=directions)
    model, p0 = run.model, run.p0
    free = linkage.drive is None
    w, c = (1.0 / linkage.time_scale if free else linkage.drive.speed), linkage.min_clearance
    if directions is not None and directions.unit is not None:
        unit = directions.unit
    else:
        unit = np.array([1.0 if name.endswith(".angle") else c
                         for name in model.COORDINATES])
        unit = np.concatenate([unit, unit * w])
    ts, ys, ms = run.ts, run.ys, run.ms
    growth = run.growth(unit, None if free else linkage.period, revolutions, windows)
    peaks, keep = run.peaks, None
    if t_eval is not None:
        keep = landed(ts, t_eval)
        ts, ys, ms = ts[keep], ys[keep], ms[keep]
        peaks = None
    vals, ders = run.recorded_output_sensitivities(keep)
    traj = trajectory_from_run(linkage, model, ts, run.plain_states(ys), ms, p0, run.stats,
                               peaks, vals)
    ref = (np.array([linkage.parameter_value(n) for n in names]) if directions is None
           else directions.reference)
    fields = _fields(model, ts, names, ref, ders, traj, growth, run.stats)
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
    """Central-difference step of parameter `name`: `relative` times its value; the radii
    relative to the clearance, zero-valued coordinates relative to the length scale, a zero
    angle relative to 1 rad, zero gravity relative to 9.81 m/s^2. On the paper's case a
    field of its table (`mechanism.FIELD_PATHS`) is valued as the field (its derived value
    where None), a radius of its one clearance joint."""
    from ..model.design import slider_crank_of
    from ..model.mechanism import FIELD_PATHS, PAPER_JOINT, reference_value

    head, _, field = name.rpartition(".")
    paper = slider_crank_of(linkage) if name in FIELD_PATHS else None
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


def _plain_at(linkage, revolutions, t_eval, rtol, method, start=None, specialise=True):
    """Outputs (len(t_eval), N_OUT) and states of a plain run (`linkage_model.run`) landing
    on t_eval (from the centred start or `start`; `specialise`: as `plain_setup`)."""
    from .linkage_model import run

    if linkage.drive is None:
        revolutions = None
    out = run(linkage, revolutions, RunSettings(rtol=rtol, method=method),
              edges=np.array([0.0, t_eval[-1]]), t_eval=t_eval, start=start,
              specialise=specialise)
    return out.ts, out.ys, out.ms, out.outs, out.p, out.stats


def linkage_fd(linkage: Linkage, names: tuple[str, ...], revolutions: int | None, rtol,
               t_eval, relative: float, method: str, start=None, windows=None):
    """Central finite differences of the outputs (and coordinates) at the times t_eval
    (default: 720 per revolution), each run landing on them (from `start` if given). Every
    run takes one model: the general one if a zero-valued geometric parameter is among
    `names` (its steps leave zero), else the one specialised on them."""
    spec = specialisable(linkage, names)
    model = load_model(linkage, spec)
    if t_eval is None and windows is not None:      # a free linkage: 720 per window
        t_eval = np.unique(np.concatenate([np.linspace(a, b, 721) for a, b in
                                           zip(windows[:-1], windows[1:])]))
    elif t_eval is None:
        t_eval = np.linspace(0.0, revolutions * linkage.period, 720 * revolutions + 1)
    rtol = 1e-11 if rtol is None else rtol
    t0 = time.perf_counter()
    ts, ys, ms, outs, p, stats = _plain_at(linkage, revolutions, t_eval, rtol, method, start,
                                           spec)
    steps = [fd_step(linkage, n, relative) for n in names]
    ders = np.empty((len(ts), model.N_OUT, len(names)))
    coords = np.empty((len(ts), model.N_Q, len(names)))
    for k, (name, h) in enumerate(zip(names, steps)):
        b0 = linkage.parameter_value(name)
        runs = []
        for sign in (1.0, -1.0):
            try:
                lk = linkage.with_parameter(name, b0 + sign * h)
            except ValueError as exc:
                raise ValueError(f"the finite-difference step of {name} ({h:.3g}) leaves its "
                                 f"valid range: {exc}; pass a smaller fd_relative_step"
                                 ) from exc
            runs.append(_plain_at(lk, revolutions, t_eval, rtol, method, start, spec))
        ders[:, :, k] = (runs[0][3][:, :model.N_OUT] - runs[1][3][:, :model.N_OUT]) / (2 * h)
        coords[:, :, k] = (runs[0][1][:, :model.N_Q] - runs[1][1][:, :model.N_Q]) / (2 * h)
    stats.update(fd_steps=steps, runs=2 * len(names) + 1,
                 wall_time=time.perf_counter() - t0)
    traj = trajectory_from_run(linkage, model, ts, ys, ms, p, stats, None, outs)
    ref = np.array([linkage.parameter_value(n) for n in names])
    fields = _fields(model, ts, names, ref, ders, traj, None, stats)
    for i, c in enumerate(model.COORDINATES):
        fields["outputs"][c] = coords[:, i, :]
    fields["method"] = "fd"
    return fields
