"""Compiled adaptive explicit Runge-Kutta integration with event location (numba kernels).

The model is passed as four compiled functions with fixed signatures (numba specialises the
integrator for them, so the calls are direct and can be inlined):

- ``rhs(t, y, p, dydt)``: right-hand side; ``p`` holds parameters and the model's memory
  variables (contact mode, impact velocity, ...), ``p[mem_start:mem_start + n_mem]``, which
  are recorded with every step;
- ``event(t, y, p) -> (g, gdot)``: switching function, negative in the current mode, and its
  time derivative along the motion (used to look for excursions between samples); a crossing to
  positive inside a step is an event;
- ``on_event(t, y, p)``: applied exactly at a located event (updates the memory in ``p``);
- ``monitor(t, y, p, dydt, out) -> (m, g, gdot)``: the right-hand side (into ``dydt``, as
  ``rhs``), a scalar m whose maximum is tracked per time window (the peak) and the event
  function (the same values as ``event(t, y, p)``); it may also write model outputs into
  ``out`` (n_out entries), which are recorded with every step. It is called for the last
  (FSAL) stage of every step, at the step's end, so that a model evaluates itself once
  there for the derivative, the peak, the event search and the outputs.

Error control: the scaled RMS of the embedded error estimate over the first n_err state
components, and optionally (two more entries in ``atol``) the change of the switching
function g and of its rate between the step's solution and the embedded one: a model whose
events hinge on a small difference of large state components (a penetration of
micrometres in coordinates of decimetres) gets its error controlled at the scale of the
difference.

Events are searched on the step's dense output (`_search_event`: interior samples, a closer
look wherever the cubic Hermite interpolant of g and its rate comes within `event_margin` of
the surface, and steps limited while approaching it), so that a crossing and return inside one
step is not missed. The first crossing is located on the dense output, then the step is redone
with the located size and refined by Illinois iterations on the real step map, inside the
search's bracket, until |g| <= event_tol: the memory is set at the landed state, never at the
first state found inside the wall. The integration also lands exactly on the window edges, and
the maximum of ``monitor`` in each window is refined by golden-section search on re-taken
steps: inside the steps on both sides of each of the window's best `N_CRESTS` crests (local
maxima of the sampled monitor: two crests within the integration accuracy of each other are
both refined) and inside the window's first and last steps.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numba import types

__all__ = [
    "KERNEL", "RHS_SIG", "SCALAR_SIG", "MONITOR_SIG", "EVENT_SIG", "ACTION_SIG", "METHODS",
    "Tableau", "integrate", "N_CRESTS",
    "STATUS_MESSAGES",
]

#: numba options of the kernels (model functions and the integrator's helpers, everything
#: that runs per stage or per step and allocates nothing): error_model="numpy" drops the
#: zero-division checks of every float division (the kernels guard their divisors), and
#: without numba's runtime (_nrt=False) passing arrays to a compiled function costs no
#: atomic reference counting (it was 22 % of a simulation, measured with perf). Such
#: functions cannot allocate arrays; `integrate` itself allocates and keeps the runtime.
KERNEL = {"cache": True, "error_model": "numpy", "_nrt": False}

_vec = types.float64[::1]
RHS_SIG = types.void(types.float64, _vec, _vec, _vec)
SCALAR_SIG = types.float64(types.float64, _vec, _vec)
MONITOR_SIG = types.UniTuple(types.float64, 3)(types.float64, _vec, _vec, _vec, _vec)
EVENT_SIG = types.UniTuple(types.float64, 2)(types.float64, _vec, _vec)
ACTION_SIG = types.void(types.float64, _vec, _vec)


class Tableau:
    """Coefficients of an embedded explicit RK pair in the layout of scipy's ``rk_step``.

    A (s, s), B (s,), C (s,), E (s+1,) = b - b_hat (the last entry weights the FSAL stage),
    P (s+1+x, k) dense-output polynomial coefficients (y(t + theta h) = y + h sum_j K_j
    sum_m P[j, m] theta^(m+1)), order = order of the error estimator + 1.
    Two-estimator pairs (DOP853) give a second error vector E2 (empty otherwise); the
    continuous extension may need x extra stages, A_extra (x, s+1+x) and C_extra (x,),
    evaluated only for accepted steps.
    """

    def __init__(self, name, A, B, C, E, P, order, error_order, E2=(), A_extra=None,
                 C_extra=(), pi_beta=0.0, pi_gain=0.75):
        self.name = name
        self.A = np.ascontiguousarray(A, dtype=float)
        self.B = np.ascontiguousarray(B, dtype=float)
        self.C = np.ascontiguousarray(C, dtype=float)
        self.E = np.ascontiguousarray(E, dtype=float)
        self.P = np.ascontiguousarray(P, dtype=float)
        self.order = order
        self.error_order = error_order
        self.E2 = np.ascontiguousarray(E2, dtype=float)
        self.C_extra = np.ascontiguousarray(C_extra, dtype=float)
        if A_extra is None:
            A_extra = np.zeros((0, len(self.B) + 1))
        self.A_extra = np.ascontiguousarray(A_extra, dtype=float)
        # step-size controller: h_new = h 0.9 err^-alpha err_prev^beta, alpha = 1/(q+1) -
        # pi_gain beta (Hairer's DOPRI5 and DOP853 codes: gain 0.75 and 0.2)
        self.pi_beta = float(pi_beta)
        self.pi_alpha = 1.0 / (error_order + 1) - pi_gain * self.pi_beta

    def arrays(self):
        """The coefficient and controller arguments of `integrate`, in its order."""
        return (self.A, self.B, self.C, self.E, self.E2, self.P, self.A_extra, self.C_extra,
                self.error_order, self.pi_alpha, self.pi_beta)


# Dormand & Prince (1980) 5(4) pair with Shampine's 4th-order continuous extension.
_DP_A = [
    [0, 0, 0, 0, 0, 0],
    [1 / 5, 0, 0, 0, 0, 0],
    [3 / 40, 9 / 40, 0, 0, 0, 0],
    [44 / 45, -56 / 15, 32 / 9, 0, 0, 0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0],
]
_DP_B = [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84]
_DP_C = [0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1]
_DP_E = [-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40]
_DP_P = [
    [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0, 0, 0, 0],
    [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0, 127303824393 / 49829197408, -318862633887 / 49829197408,
     701980252875 / 199316789632],
    [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
]

# Bogacki & Shampine (1989) 3(2) pair with its cubic Hermite continuous extension.
_BS_A = [[0, 0, 0], [1 / 2, 0, 0], [0, 3 / 4, 0]]
_BS_B = [2 / 9, 1 / 3, 4 / 9]
_BS_C = [0, 1 / 2, 3 / 4]
_BS_E = [5 / 72, -1 / 12, -1 / 9, 1 / 8]
_BS_P = [[1, -4 / 3, 5 / 9], [0, 1, -2 / 3], [0, 4 / 3, -8 / 9], [0, -1, 1]]



def _dop853() -> Tableau:
    """Dormand & Prince's 8(5,3) pair (Hairer, Norsett & Wanner, Solving ODEs I, Sec. II.10),
    coefficients taken from scipy's DOP853 class, with Hairer's 7th-order continuous
    extension (3 extra stages) rewritten as polynomials in theta for `dense_eval`.

    The extension is y(theta) = y0 + theta (F0 + (1 - theta) (F1 + theta (F2 + (1 - theta)
    (F3 + ...)))), F0 = dy, F1 = h f0 - dy, F2 = 2 dy - h (f0 + f1), F3..F6 = h D K: term i
    carries the weight theta^(i//2 + 1) (1 - theta)^((i + 1)//2).
    """
    from numpy.polynomial import polynomial as npoly
    from scipy.integrate import DOP853 as ref

    s = ref.n_stages
    n_all = s + 1 + len(ref.C_EXTRA)
    b = np.zeros(n_all)
    b[:s] = ref.B
    F = np.zeros((7, n_all))
    F[0] = b
    F[1] = -b
    F[1, 0] += 1.0
    F[2] = 2.0 * b
    F[2, 0] -= 1.0
    F[2, s] -= 1.0
    F[3:] = ref.D
    P = np.zeros((n_all, 7))
    for i in range(7):
        w = npoly.polymul(npoly.polypow([0.0, 1.0], i // 2 + 1),
                          npoly.polypow([1.0, -1.0], (i + 1) // 2))
        w = np.pad(w, (0, 8 - len(w)))
        P += np.outer(F[i], w[1:])
    # beta = 0.06: where stability limits the step (the stiff contact) the I controller
    # rejects ~30 % of the steps; measured on the sensitivity equations (docs/performance.md)
    return Tableau("dop853", ref.A, ref.B, ref.C, ref.E5, P, 8, 7, E2=ref.E3,
                   A_extra=ref.A_EXTRA, C_extra=ref.C_EXTRA, pi_beta=0.06, pi_gain=0.2)


#: name -> Tableau; the registry of integration methods of the compiled integrator
METHODS: dict[str, Tableau] = {
    "dop853": _dop853(),
    "dopri5": Tableau("dopri5", _DP_A, _DP_B, _DP_C, _DP_E, _DP_P, 5, 4),
    "bs3": Tableau("bs3", _BS_A, _BS_B, _BS_C, _BS_E, _BS_P, 3, 2),
}

STATUS_MESSAGES = {
    0: "success",
    1: "maximum number of steps reached: raise max_steps or loosen rtol/atol",
    2: "step size underflow: the problem is too stiff for this tolerance; loosen rtol/atol "
       "or reduce the contact stiffness",
    3: "events chatter (repeated zero-length events): the contact is grazing at machine "
       "precision; raise impact_velocity_floor or change the initial state",
}


#: state length up to which `_combine` runs scalar code (unrolled loops with guards)
SMALL = 8


@nb.njit(**KERNEL, inline="always")
def _combine(y, h, K, coef, n_terms, out):
    """out = y + h * sum_{j < n_terms} coef[j] K[j] (rows of K outer: contiguous inner loop).

    A short state (n <= SMALL, the plain model) takes loops of constant length with a guard
    per component, which the compiler unrolls instead of vectorising: a vector load of the
    row that the model has just written component by component cannot take the values from
    the pending stores and waits until they are written to the cache, at every stage
    (measured: 3 % of a simulation). The same operations in the same order either way; the
    same scalar form for `_copy` and `_weighted_rows` measured 1 and 4 % slower."""
    n = y.shape[0]
    if n <= SMALL:
        for k in range(SMALL):
            if k < n:
                out[k] = y[k]
        for j in range(n_terms):
            c = h * coef[j]
            if c != 0.0:
                for k in range(SMALL):
                    if k < n:
                        out[k] += c * K[j, k]
        return
    for k in range(n):
        out[k] = y[k]
    for j in range(n_terms):
        c = h * coef[j]
        if c != 0.0:
            for k in range(n):
                out[k] += c * K[j, k]


@nb.njit(**KERNEL)
def _copy(src, dst):
    """dst[:] = src without the temporary that a slice assignment may allocate."""
    for k in range(src.shape[0]):
        dst[k] = src[k]


@nb.njit(**KERNEL, inline="always")
def rk_stages(rhs, t, y, f, h, A, B, C, K, p, y_new, ytmp):
    """The stages of one explicit RK step of size h but the last: fills K[:s] and y_new."""
    s = B.shape[0]
    n = y.shape[0]
    for k in range(n):
        K[0, k] = f[k]
    for i in range(1, s):
        _combine(y, h, K, A[i], i, ytmp)
        rhs(t + C[i] * h, ytmp, p, K[i])
    _combine(y, h, K, B, s, y_new)


@nb.njit(**KERNEL)
def rk_step(rhs, t, y, f, h, A, B, C, K, p, y_new, f_new, ytmp):
    """One explicit RK step of size h; fills K (stages, last row FSAL), y_new and f_new."""
    rk_stages(rhs, t, y, f, h, A, B, C, K, p, y_new, ytmp)
    rhs(t + h, y_new, p, f_new)
    _copy(f_new, K[B.shape[0]])


@nb.njit(**KERNEL, inline="always")
def step_workspace(coefficients, n):
    """Work arrays of one step of `n` states with the method's `coefficients`: the stage
    derivatives K and the vectors y_new, f_new, ytmp, f0 (for `_step_monitor` callers
    outside the integrator)."""
    B, A_extra = coefficients[1], coefficients[6]
    return (np.zeros((B.shape[0] + 1 + A_extra.shape[0], n)), np.empty(n), np.empty(n),
            np.empty(n), np.empty(n))


@nb.njit(**KERNEL, inline="always")
def _step_monitor(rhs, monitor, t, y, f, h, A, B, C, K, p, y_new, f_new, ytmp, out):
    """`rk_step` with the monitor as its last stage: returns the monitor and the event
    function at the step's end (its outputs into out)."""
    rk_stages(rhs, t, y, f, h, A, B, C, K, p, y_new, ytmp)
    res = monitor(t + h, y_new, p, f_new, out)
    _copy(f_new, K[B.shape[0]])
    return res


@nb.njit(**KERNEL, inline="always")
def _event_error_sq(event, t, h, y_new, p, work, g, gd, rtol, atol_g, atol_gd, n_err, yhat):
    """Squared scaled differences, summed, of the switching function and its rate between
    the step's solution y_new (where they are g, gd) and the embedded solution
    y_new - h work (work: the error combination of the stages, first n_err components)."""
    n = y_new.shape[0]
    for k in range(n):
        yhat[k] = y_new[k] - h * work[k] if k < n_err else y_new[k]
    gh, gdh = event(t, yhat, p)
    eg = (g - gh) / (atol_g + rtol * abs(g))
    egd = (gd - gdh) / (atol_gd + rtol * abs(gd))
    return eg * eg + egd * egd


@nb.njit(**KERNEL)
def _attempt(rhs, event, monitor, t, y, f, h, A, B, C, E, E2, K, p, y_new, f_new, ytmp, work,
             work2, out, rtol, atol, n_err, yhat):
    """An attempted step of `integrate`: its stages, the monitor at its end (outputs into
    out), the event function there and its scaled error; returns (monitor, g, gdot,
    error). One call of a function without numba's runtime, into which the helpers are
    inlined (inlined into `integrate` they would reference-count their arrays).

    With two more entries in atol than states, the switching function g and its rate are
    under error control too, with those absolute tolerances (`integrate`)."""
    m, g, gd = _step_monitor(rhs, monitor, t, y, f, h, A, B, C, K, p, y_new, f_new, ytmp, out)
    err = error_norm(K, E, E2, h, y, y_new, rtol, atol, n_err, work, work2)
    n = y.shape[0]
    if atol.shape[0] < n + 2:
        return m, g, gd, err
    # error_norm left E.K in work (and E2.K in work2): the embedded solutions' g, gdot
    e1 = _event_error_sq(event, t + h, h, y_new, p, work, g, gd, rtol, atol[n], atol[n + 1],
                         n_err, yhat)
    if E2.shape[0] == 0:
        err_ev = math.sqrt(0.5 * e1)
    else:
        e2 = _event_error_sq(event, t + h, h, y_new, p, work2, g, gd, rtol, atol[n],
                             atol[n + 1], n_err, yhat)
        err_ev = 0.0 if e1 == 0.0 else e1 / math.sqrt((e1 + 0.01 * e2) * 2.0)
    return m, g, gd, max(err, err_ev)


@nb.njit(**KERNEL)
def extra_stages(rhs, t, y, h, K, A_extra, C_extra, p, ytmp):
    """Stages s+1.. of a continuous extension that needs more than the step's stages."""
    first = K.shape[0] - A_extra.shape[0]
    for r in range(A_extra.shape[0]):
        _combine(y, h, K, A_extra[r], first + r, ytmp)
        rhs(t + C_extra[r] * h, ytmp, p, K[first + r])


@nb.njit(**KERNEL, inline="always")
def _weighted_rows(K, E, n, out):
    """out[:n] = sum_j E[j] K[j, :n] (rows of K outer: contiguous inner loop)."""
    for k in range(n):
        out[k] = 0.0
    for j in range(E.shape[0]):
        c = E[j]
        if c != 0.0:
            for k in range(n):
                out[k] += c * K[j, k]


@nb.njit(**KERNEL, inline="always")
def error_norm(K, E, E2, h, y, y_new, rtol, atol, n_err, work, work2):
    """Scaled error estimate over the first n_err components: the RMS of E.K, or with a
    second estimator E2 (DOP853) Hairer's combination |E.K|^2 / sqrt(|E.K|^2 + 0.01
    |E2.K|^2), which is smaller than either when the higher-order one is. work, work2:
    work arrays of n_err entries."""
    two = E2.shape[0] > 0
    _weighted_rows(K, E, n_err, work)
    if two:
        _weighted_rows(K, E2, n_err, work2)
    acc = 0.0
    acc2 = 0.0
    for k in range(n_err):
        scale = atol[k] + rtol * max(abs(y[k]), abs(y_new[k]))
        acc += (work[k] / scale) ** 2
        if two:
            acc2 += (work2[k] / scale) ** 2
    if not two:
        return abs(h) * math.sqrt(acc / n_err)
    if acc == 0.0:
        return 0.0
    return abs(h) * acc / math.sqrt((acc + 0.01 * acc2) * n_err)


@nb.njit(**KERNEL, inline="always")
def _dense_poly(P, j, theta):
    """sum_m P[j, m] theta^(m+1): the weight of stage j at theta, per unit step size."""
    poly = 0.0
    tp = theta
    for m in range(P.shape[1]):
        poly += P[j, m] * tp
        tp *= theta
    return poly


@nb.njit(**KERNEL, inline="always")
def _dense_combine(y, h, K, polys, out, wts):
    """State at theta of the continuous extension from the weights polys[j] =
    _dense_poly(P, j, theta) (wts: work array)."""
    ns = polys.shape[0]
    for j in range(ns):
        wts[j] = h * polys[j]
    _combine(y, 1.0, K, wts, ns, out)


@nb.njit(**KERNEL, inline="always")
def dense_eval(y, h, K, P, theta, out, wts):
    """State at t + theta*h from the step's continuous extension (wts: work array)."""
    ns = P.shape[0]
    for j in range(ns):
        wts[j] = h * _dense_poly(P, j, theta)
    _combine(y, 1.0, K, wts, ns, out)


@nb.njit(**KERNEL)
def initial_step(rhs, t, y, f, p, rtol, atol, order, direction_span, ytmp, ftmp):
    """Hairer-Norsett-Wanner starting step size."""
    n = y.shape[0]
    d0 = 0.0
    d1 = 0.0
    for k in range(n):
        sc = atol[k] + rtol * abs(y[k])
        d0 += (y[k] / sc) ** 2
        d1 += (f[k] / sc) ** 2
    d0 = math.sqrt(d0 / n)
    d1 = math.sqrt(d1 / n)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, direction_span)
    for k in range(n):
        ytmp[k] = y[k] + h0 * f[k]
    rhs(t + h0, ytmp, p, ftmp)
    d2 = 0.0
    for k in range(n):
        sc = atol[k] + rtol * abs(y[k])
        d2 += ((ftmp[k] - f[k]) / sc) ** 2
    d2 = math.sqrt(d2 / n) / h0
    if max(d1, d2) <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / order)
    return min(100.0 * h0, h1, direction_span)


@nb.njit(**KERNEL)
def _golden_max(rhs, monitor, t0, y0, p, h_max, A, B, C, K, y_new, f_new, ytmp, f0, iters,
                out):
    """Maximise monitor(t0 + h, step(y0, h)) over h in [0, h_max]; return (value, t).
    f0 and out (the monitor's outputs) are work arrays."""
    rhs(t0, y0, p, f0)
    invphi = 0.6180339887498949
    a = 0.0
    b = h_max
    c = b - invphi * (b - a)
    d = a + invphi * (b - a)
    fc = _step_monitor(rhs, monitor, t0, y0, f0, c, A, B, C, K, p, y_new, f_new, ytmp,
                       out)[0]
    fd = _step_monitor(rhs, monitor, t0, y0, f0, d, A, B, C, K, p, y_new, f_new, ytmp,
                       out)[0]
    for _ in range(iters):
        if fc > fd:
            b = d
            d = c
            fd = fc
            c = b - invphi * (b - a)
            fc = _step_monitor(rhs, monitor, t0, y0, f0, c, A, B, C, K, p, y_new, f_new, ytmp,
                               out)[0]
        else:
            a = c
            c = d
            fc = fd
            d = a + invphi * (b - a)
            fd = _step_monitor(rhs, monitor, t0, y0, f0, d, A, B, C, K, p, y_new, f_new, ytmp,
                               out)[0]
    if fc > fd:
        return fc, t0 + c
    return fd, t0 + d


#: crests (distinct local maxima of the sampled monitor) per window whose neighbouring steps
#: are refined at the window's close: two crests within the integration accuracy of each
#: other are both refined, and the best refined value is the window's peak
N_CRESTS = 3


@nb.njit(**KERNEL)
def _crest_store(row, cr_prev_y, cr_prev_p, cr_y, cr_p, cr_sc, y_prev, p_prev, t_prev, h_prev,
                 y, p, t, m):
    """Store a (pending) crest in `row`: the step before it (state y_prev at t_prev, size
    h_prev, memory p_prev; h_prev = 0: none) and the sample itself (y, memory p, t, m)."""
    if h_prev > 0.0:
        for k in range(y.shape[0]):
            cr_prev_y[row, k] = y_prev[k]
        for k in range(p.shape[0]):
            cr_prev_p[row, k] = p_prev[k]
    for k in range(y.shape[0]):
        cr_y[row, k] = y[k]
    for k in range(p.shape[0]):
        cr_p[row, k] = p[k]
    cr_sc[row, 0] = t_prev
    cr_sc[row, 1] = h_prev
    cr_sc[row, 2] = t
    cr_sc[row, 3] = 0.0
    cr_sc[row, 4] = m


@nb.njit(**KERNEL)
def _crest_confirm(crest_rows, n_cr, cr_sc, next_h):
    """Confirm the pending crest (row crest_rows[n_cr]; the step after it has size next_h,
    0: none) among the window's best ones, crest_rows[:n_cr]: kept while fewer than
    len(crest_rows) - 1 are, else in place of the smallest if larger. Returns the new count
    and the value a sample must exceed to become a crest (-inf until the rows are full)."""
    n_top = crest_rows.shape[0] - 1
    row = crest_rows[n_cr]
    cr_sc[row, 3] = next_h
    if n_cr < n_top:
        n_cr += 1
    else:
        i_min = 0
        for i in range(1, n_top):
            if cr_sc[crest_rows[i], 4] < cr_sc[crest_rows[i_min], 4]:
                i_min = i
        if cr_sc[row, 4] > cr_sc[crest_rows[i_min], 4]:
            crest_rows[n_top] = crest_rows[i_min]
            crest_rows[i_min] = row
    if n_cr < n_top:
        return n_cr, -np.inf
    low = np.inf
    for i in range(n_top):
        low = min(low, cr_sc[crest_rows[i], 4])
    return n_cr, low


@nb.njit(**KERNEL, inline="always")
def _seen(done_t, n_done, t0):
    """Whether a step starting at t0 is among done_t[:n_done]."""
    for i in range(n_done):
        if done_t[i] == t0:
            return True
    return False


@nb.njit(**KERNEL, inline="always")
def _illinois_update(x, gx, a, ga, b, gb, side):
    """Shrink the bracket [a, b] (g(a) <= 0 < g(b)) to the new point x; the Illinois rule
    halves the value kept at the end that stays, when that end stays twice in a row."""
    if gx > 0.0:
        if side == -1:
            ga *= 0.5
        return a, ga, x, gx, -1
    if side == 1:
        gb *= 0.5
    return x, gx, b, gb, 1


@nb.njit(**KERNEL, inline="always")
def _hermite_weights(u):
    """The cubic Hermite basis at u in [0, 1]: weights of the start value, start slope, end
    value and end slope (slopes times the interval length)."""
    u2 = u * u
    u3 = u2 * u
    return 2.0 * u3 - 3.0 * u2 + 1.0, u3 - 2.0 * u2 + u, -2.0 * u3 + 3.0 * u2, u3 - u2


@nb.njit(**KERNEL, inline="always")
def _hermite_bound(g_a, d_a, g_b, d_b):
    """A cheap upper bound of the cubic Hermite interpolant over [0, 1] (|h00 - (1 - u)| <=
    0.097, |h10|, |h11| <= 4/27), checked before its exact maximum."""
    return max(g_a, g_b) + 0.097 * abs(g_a - g_b) + 0.149 * (abs(d_a) + abs(d_b))


@nb.njit(**KERNEL, inline="always")
def _hermite_max(g_a, d_a, g_b, d_b):
    """Maximum over [0, 1] of the cubic Hermite interpolant with values g_a, g_b and
    end slopes d_a, d_b (derivatives times the interval length), and where it is."""
    best = g_a
    where = 0.0
    if g_b > best:
        best = g_b
        where = 1.0
    qa = 6.0 * g_a + 3.0 * d_a - 6.0 * g_b + 3.0 * d_b
    qb = -6.0 * g_a - 4.0 * d_a + 6.0 * g_b - 2.0 * d_b
    qc = d_a
    # roots of qa u^2 + qb u + qc, in the cancellation-free form (qa may be ~0: the
    # interpolant of a quadratic is quadratic)
    disc = qb * qb - 4.0 * qa * qc
    if disc < 0.0:
        return best, where
    q = -0.5 * (qb + math.copysign(math.sqrt(disc), qb))
    for k in range(2):
        if k == 0:
            if q == 0.0:
                continue
            u = qc / q
        else:
            if qa == 0.0:
                continue
            u = q / qa
        if 0.0 < u < 1.0:
            w00, w10, w01, w11 = _hermite_weights(u)
            val = g_a * w00 + d_a * w10 + g_b * w01 + d_b * w11
            if val > best:
                best = val
                where = u
    return best, where


@nb.njit(**KERNEL)
def _clear_of_surface(event, t, y, y_new, f0, f1, h, p, g_start, gd_start, g_end, gd_end,
                      n_samples, event_tol, event_margin, ytmp):
    """Whether a step is certainly clear of the switching surface, from the cubic Hermite
    interpolant of the state (its values and derivatives at both ends, no extra stages):
    the test of `_search_event` at the same interior samples, with twice the margin, and
    the interpolant's g checked against the Hermite interpolant of g itself (two cubic
    approximations of different functions; where they differ by more than a tenth of the
    margin, the interpolation error is not small against it). False sends the step to
    `_search_event` on the continuous extension.

    Where the steps resolve the motion the cubic's error is far below the margin: in the
    paper's case at most 1.3e-9 m at mid-step against the margin of 5e-7 m (0.05 c)."""
    if g_start > -100.0 * event_tol:
        return False               # starts on the surface: `_search_event` looks closer
    margin = 2.0 * event_margin
    n = y.shape[0]
    theta_a = 0.0
    g_a = g_start
    gd_a = gd_start
    for i in range(1, n_samples + 2):
        theta_b = min(i / (n_samples + 1.0), 1.0)
        if i == n_samples + 1:
            g_b = g_end
            gd_b = gd_end
        else:
            h00, w10, h01, w11 = _hermite_weights(theta_b)
            h10 = w10 * h
            h11 = w11 * h
            for k in range(n):
                ytmp[k] = h00 * y[k] + h10 * f0[k] + h01 * y_new[k] + h11 * f1[k]
            g_b, gd_b = event(t + theta_b * h, ytmp, p)
            # the Hermite interpolant of g over the whole step, at the same point
            g_h = (h00 * g_start + h10 * gd_start + h01 * g_end + h11 * gd_end)
            if abs(g_b - g_h) > 0.1 * event_margin:
                return False
        span = (theta_b - theta_a) * h
        bound = _hermite_bound(g_a, gd_a * span, g_b, gd_b * span)
        if g_b > -margin or bound > -margin:
            return False
        theta_a = theta_b
        g_a = g_b
        gd_a = gd_b
    return True


@nb.njit(**KERNEL)
def _search_event(event, t, y, h, K, P, p, g_start, gd_start, g_end, gd_end, n_samples,
                  event_tol, event_margin, ytmp, wts, fine, sample_polys):
    """First sign change of g (from <= 0 to > 0) inside a step of size h.

    g and its rate are sampled at n_samples interior points of the dense output; at the
    end (the real step) they are g_end, gd_end (from the monitor); a step that starts on
    the surface is also sampled close to its start. Between two samples where the cubic
    Hermite interpolant of g (values and rates) comes within `event_margin` of the surface,
    7 more points are sampled: an excursion through the surface shorter than the sample
    spacing would hide there.
    Returns (theta_lo, g_lo, theta_hi, g_hi); theta_hi = -1: no crossing.
    `fine` is a work array of 8 entries; sample_polys[i - 1] the weights `_dense_poly` of
    the interior sample i (the same every step: computed once per run).
    """
    theta_a = 0.0
    g_a = g_start
    gd_a = gd_start
    n_near = 3 if g_start > -100.0 * event_tol else 0
    for i in range(1 - n_near, n_samples + 2):
        if i <= 0:
            theta_b = 10.0 ** (i - 1) / (n_samples + 1.0)
        else:
            theta_b = min(i / (n_samples + 1.0), 1.0)
        if i == n_samples + 1:
            g_b = g_end
            gd_b = gd_end
        else:
            if i <= 0:
                dense_eval(y, h, K, P, theta_b, ytmp, wts)
            else:
                _dense_combine(y, h, K, sample_polys[i - 1], ytmp, wts)
            g_b, gd_b = event(t + theta_b * h, ytmp, p)
        span = (theta_b - theta_a) * h
        d_a = gd_a * span
        d_b = gd_b * span
        bound = _hermite_bound(g_a, d_a, g_b, d_b)
        peak = bound
        where = -1.0
        if g_b <= 0.0 and bound > -event_margin:
            peak, where = _hermite_max(g_a, d_a, g_b, d_b)
        if g_b <= 0.0 and peak > -event_margin:
            # 7 equally spaced points and the interpolant's maximum, in time order
            n_fine = 7
            for j in range(7):
                fine[j] = (j + 1) / 8.0
            if 0.0 < where < 1.0:
                # insert the interpolant's maximum in order (the 7 points are sorted)
                j = 7
                while j > 0 and fine[j - 1] > where:
                    fine[j] = fine[j - 1]
                    j -= 1
                fine[j] = where
                n_fine = 8
            span_theta = theta_b - theta_a
            base = theta_a
            for j in range(n_fine):
                theta_f = base + fine[j] * span_theta
                dense_eval(y, h, K, P, theta_f, ytmp, wts)
                g_f, gd_f = event(t + theta_f * h, ytmp, p)
                if g_f > 0.0:
                    return theta_a, g_a, theta_f, g_f
                theta_a = theta_f
                g_a = g_f
        if g_b > 0.0:
            return theta_a, g_a, theta_b, g_b
        theta_a = theta_b
        g_a = g_b
        gd_a = gd_b
    return theta_a, g_a, -1.0, 0.0



@nb.njit(cache=True, error_model="numpy")
def _record_arrays(cap, n, n_mem, n_out):
    """The records (times, states, memories, outputs) for cap steps, as views of one
    allocation. One block rather than four: glibc raises its trim threshold to twice the
    largest block freed, so with one large block it keeps the heap between runs, where
    four smaller ones, freed together with a sensitivity run's results, were returned to
    the system and faulted back in at every call (1000 page faults, 3.3 ms of a 23 ms
    sensitivity run; no change for plain simulations)."""
    block = np.empty(cap * (1 + n + n_mem + n_out))
    a = cap
    b = a + cap * n
    c = b + cap * n_mem
    return (block[:a], block[a:b].reshape((cap, n)), block[b:c].reshape((cap, n_mem)),
            block[c:].reshape((cap, n_out)))


@nb.njit(cache=True, error_model="numpy")
def integrate(rhs, event, on_event, monitor, y0, p, mem_start, n_mem, edges, rtol, atol, n_err,
              h0, h_max, max_steps, record, event_tol, event_margin, n_samples, refine_iters,
              coefficients, n_out, n_dense):
    """Integrate from edges[0] to edges[-1]; see the module docstring for the protocol.

    Arguments: the four model kernels (compiled functions with the signatures RHS_SIG,
    EVENT_SIG, ACTION_SIG, MONITOR_SIG); y0; p (parameters + memory, modified in place);
    mem_start, n_mem (the memory entries of p, recorded); edges (window edges, edges[0] =
    t0, edges[-1] = t_end); rtol; atol (per component; with len(y0) + 2 entries the last
    two are the absolute tolerances of the switching function g and its rate, which are
    then under error control too, see `_attempt`); n_err (components under error
    control); h0 (<= 0: automatic); h_max; max_steps; record; event_tol; event_margin (look
    closer between samples this near the surface); n_samples (interior event samples per
    step); refine_iters (golden-section iterations per peak candidate); then
    coefficients = `Tableau.arrays()` (one tuple: numba types the kernels of calls with 30 or
    more arguments as experimental first-class functions); n_out (outputs written by
    monitor, recorded); n_dense: the event function reads only y[:n_dense], so the
    continuous extension is formed for those components only, and its extra stages
    (DOP853) call `rhs` with the truncated state y[:n_dense]: the model must then give those
    derivatives (entries beyond are not used), which lets an augmented system skip its
    extra equations there.

    Returns (t (m,), y (m, n), memory (m, n_mem) of the recorded steps, the refined maximum
    of monitor per window and its time, counters [nfev, naccept, nreject, nevent, status,
    nrefine], outputs (m, n_out) of the recorded steps).

    numba compiles one specialisation per set of model kernels. Called from Python with
    the kernels as arguments it is compiled in every new process; bind the kernels in a
    cached wrapper instead (`reduced.integrate_plain`) to load it from the disk cache."""
    A, B, C, E, E2, P, A_extra, C_extra, error_order, pi_alpha, pi_beta = coefficients
    n = y0.shape[0]
    s = B.shape[0]
    n_extra = A_extra.shape[0]
    K = np.zeros((s + 1 + n_extra, n))
    y = y0.copy()
    f = np.empty(n)
    y_new = np.empty(n)
    f_new = np.empty(n)
    ytmp = np.empty(n)
    ftmp = np.empty(n)
    p_prev = p.copy()
    wts = np.empty(P.shape[0])
    # the continuous extension's weights at the interior samples of the event search (the
    # same thetas every step; the same arithmetic as dense_eval, evaluated once)
    sample_polys = np.empty((n_samples, P.shape[0]))
    for i in range(1, n_samples + 1):
        for j in range(P.shape[0]):
            sample_polys[i - 1, j] = _dense_poly(P, j, min(i / (n_samples + 1.0), 1.0))
    fine = np.empty(8)
    n_win = edges.shape[0] - 1
    peaks = np.full(n_win, -np.inf)
    peak_t = np.zeros(n_win)
    counters = np.zeros(6, dtype=np.int64)
    # the window's best crests (distinct local maxima of the sampled monitor), each with the
    # step before it and the step after it: rows of the crest arrays; crest_rows[:n_cr] are
    # the confirmed crests, the pending crest (the last sample, while it rises) takes the
    # free row `_pending_row`
    n_top = N_CRESTS
    n_p = p.shape[0]
    cr_prev_y = np.empty((n_top + 1, n))
    cr_prev_p = np.empty((n_top + 1, n_p))
    cr_y = np.empty((n_top + 1, n))
    cr_p = np.empty((n_top + 1, n_p))
    cr_sc = np.zeros((n_top + 1, 5))    # prev_t, prev_h, t, next_h, value
    crest_rows = np.arange(n_top + 1)
    n_cr = 0
    pend = False
    thresh = -np.inf                    # the smallest confirmed crest once n_top are kept
    # the window's start (its first step is refined too)
    ws_y = y.copy()
    ws_t = edges[0]
    ws_p = p.copy()
    ws_h = 0.0
    last_y = np.empty(n)
    yhat = np.empty(n)       # the embedded solution (error control of g)
    f_ref = np.empty(n)
    # the part of the state the continuous extension is formed for (views, no copies)
    y_d = y[:n_dense]
    ytmp_d = ytmp[:n_dense]
    obuf = np.zeros(n_out)       # outputs at the current step (written by monitor)
    oscr = np.zeros(n_out)       # outputs of the refinement (not recorded)

    # untouched pages of np.empty cost nothing: room for typical runs without regrowing
    cap = 16384 if record else 1
    ts, ys, ms, os_ = _record_arrays(cap, n, max(n_mem, 1), n_out)
    nrec = 0

    t = edges[0]
    t_end = edges[-1]
    m0, g_start, gd_start = monitor(t, y, p, f, obuf)
    counters[0] += 1
    if h0 <= 0.0:
        h = initial_step(rhs, t, y, f, p, rtol, atol, error_order + 1, min(h_max, t_end - t),
                         ytmp, ftmp)
        counters[0] += 1
    else:
        h = min(h0, h_max)
    win = 0
    peaks[0] = m0
    peak_t[0] = t
    # the window's start is its first pending crest (the first step is the one after it)
    _crest_store(crest_rows[0], cr_prev_y, cr_prev_p, cr_y, cr_p, cr_sc, y, p, t, 0.0, y, p,
                 t, m0)
    pend = True
    m_last = m0
    done_t = np.empty(2 * n_top + 2)     # start times of the steps refined at a window's close
    if record:
        ts[0] = t
        ys[0, :] = y
        for k in range(n_mem):
            ms[0, k] = p[mem_start + k]
        for k in range(n_out):
            os_[0, k] = obuf[k]
        nrec = 1
    zero_events = 0
    g_start_valid = True
    inv_order = 1.0 / (error_order + 1)
    last_rejected = False
    err_prev = 1e-4
    nstep = 0
    need_room = False
    while True:
        while win < n_win:
            if record and nrec == ts.shape[0]:
                # the record is full: it grows outside this loop, so that the arrays are
                # rebound there only (rebound inside, numba reference-counts them at every
                # step: 4 % of a simulation)
                need_room = True
                break
            if nstep >= max_steps:
                counters[4] = 1
                break
            nstep += 1
            t_target = edges[win + 1]
            land = False
            h_try = h
            # approaching the surface: do not step far past the linear prediction of the
            # crossing, so that the samples of the event search resolve the approach
            if not g_start_valid:
                g_start, gd_start = event(t, y, p)
                g_start_valid = True
            if gd_start > 0.0:
                h_try = min(h_try, (2.0 * abs(g_start) + (n_samples + 1) * event_margin)
                            / gd_start)
            if t + h_try >= t_target - 1e-13 * max(1.0, abs(t_target)):
                h_try = t_target - t
                land = True
            if h_try <= 1e-15 * max(1.0, abs(t)):
                if land:
                    h_try = t_target - t
                else:
                    counters[4] = 2
                    break
            m_new, g_end, gd_end, err = _attempt(rhs, event, monitor, t, y, f, h_try, A, B, C,
                                                 E, E2, K, p, y_new, f_new, ytmp, ytmp, ftmp,
                                                 obuf, rtol, atol, n_err, yhat)
            counters[0] += s
            if not (err <= 1.0):
                counters[2] += 1
                if err != err:  # NaN from the model: shrink hard
                    h = 0.1 * h_try
                else:
                    h = h_try * max(0.2, 0.9 * err ** (-inv_order))
                last_rejected = True
                continue
            # PI step-size control (Gustafsson): the previous error damps the step-size sequence
            # where stability limits the step (pi_beta = 0: the classical I controller)
            err_c = max(err, 1e-10)
            factor = 0.9 * err_c ** (-pi_alpha)
            if pi_beta != 0.0:       # (a pow less per step for the I controller)
                factor *= err_prev ** pi_beta
            factor = min(10.0, factor)
            err_prev = max(err_c, 1e-4)
            if last_rejected:
                # no growth right after a rejection (Hairer, Norsett & Wanner II.4): where the
                # step size is limited by stability this halves the number of rejections
                factor = min(factor, 1.0)
                last_rejected = False
            h_next = min(h_try * factor, h_max)
            if land:
                h_next = max(h_next, h)  # a short landing step says nothing about the scale

            # ---- event search on the dense output (interior samples), then the end point;
            # a continuous extension with extra stages (DOP853) is formed only where a look
            # with the cubic Hermite interpolant does not show the step clear of the surface
            g_start_valid = False
            if n_extra > 0 and _clear_of_surface(event, t, y_d, y_new, K[0], K[s], h_try, p,
                                                 g_start, gd_start, g_end, gd_end, n_samples,
                                                 event_tol, event_margin, ytmp):
                theta_lo, g_lo, theta_hi, g_hi = 1.0, g_end, -1.0, 0.0
            else:
                if n_extra > 0:
                    extra_stages(rhs, t, y_d, h_try, K, A_extra, C_extra, p, ytmp_d)
                    counters[0] += n_extra
                theta_lo, g_lo, theta_hi, g_hi = _search_event(
                    event, t, y_d, h_try, K, P, p, g_start, gd_start, g_end, gd_end,
                    n_samples, event_tol, event_margin, ytmp, wts, fine, sample_polys)
            if theta_hi < 0.0:
                g_start = g_end       # valid for the next step if no event intervenes
                gd_start = gd_end
                g_start_valid = True
            ev_step = theta_hi > 0.0
            if ev_step:
                _copy(p, p_prev)    # the step before the event ran with this memory
                counters[3] += 1
                if g_lo > 0.0:
                    theta_star = 0.0   # already past the switching surface at the step start
                else:
                    # Illinois root finding of g on the dense output in [theta_lo, theta_hi]
                    a = theta_lo
                    b = theta_hi
                    ga = g_lo
                    gb = g_hi
                    side = 0
                    theta_star = b
                    for _ in range(60):
                        c = (a * gb - b * ga) / (gb - ga)
                        dense_eval(y_d, h_try, K, P, c, ytmp_d, wts)
                        gc = event(t + c * h_try, ytmp, p)[0]
                        theta_star = c
                        if abs(gc) <= event_tol or (b - a) < 1e-15:
                            break
                        a, ga, b, gb, side = _illinois_update(c, gc, a, ga, b, gb, side)
                h_ev = theta_star * h_try
                if h_ev <= 1e-14 * max(1.0, abs(t)):
                    zero_events += 1
                    if zero_events > 20:
                        counters[4] = 3
                        break
                    on_event(t, y, p)
                    _, g_start, gd_start = monitor(t, y, p, f, obuf)
                    g_start_valid = True
                    counters[0] += 1
                    if record and nrec > 0 and ts[nrec - 1] == t:
                        # the memory recorded at t is the one used by the step that follows it
                        for k in range(n_mem):
                            ms[nrec - 1, k] = p[mem_start + k]
                        for k in range(n_out):
                            os_[nrec - 1, k] = obuf[k]
                    continue
                zero_events = 0
                # land on the event with the real step map: Illinois iterations on h inside the
                # bracket of the search, so that the root found is the first crossing (an open
                # secant could jump to a later crossing of a non-monotone g)
                rk_step(rhs, t, y, f, h_ev, A, B, C, K, p, y_new, f_new, ytmp)
                counters[0] += s
                g_ev = event(t + h_ev, y_new, p)[0]
                h_a = theta_lo * h_try
                g_a = min(g_lo, 0.0)
                h_b = theta_hi * h_try
                g_b = max(g_hi, 1e-300)
                side = 0
                for _ in range(16):
                    if abs(g_ev) <= event_tol or h_b - h_a <= 1e-15 * max(1.0, abs(t)):
                        break
                    h_a, g_a, h_b, g_b, side = _illinois_update(h_ev, g_ev, h_a, g_a, h_b, g_b,
                                                                side)
                    h_c = (h_a * g_b - h_b * g_a) / (g_b - g_a)
                    if not (h_a < h_c < h_b):
                        h_c = 0.5 * (h_a + h_b)
                    h_ev = h_c
                    rk_step(rhs, t, y, f, h_ev, A, B, C, K, p, y_new, f_new, ytmp)
                    counters[0] += s
                    g_ev = event(t + h_ev, y_new, p)[0]
                t_old = t
                t = t + h_ev
                land = False
                h_step = h_ev
                _copy(y, ftmp)  # the pre-step state, kept for the peak candidate
                _copy(y_new, y)
                on_event(t, y, p)
                m, g_start, gd_start = monitor(t, y, p, f, obuf)    # with the new memory
                g_start_valid = True
                counters[0] += 1
                h = h_next
            else:
                zero_events = 0
                t_old = t
                h_step = h_try
                _copy(y, ftmp)
                t = t_target if land else t + h_try
                _copy(y_new, y)
                _copy(f_new, f)
                m = m_new
                h = h_next
            counters[1] += 1

            # ---- peak tracking in the current window (m: the monitor at the step's end):
            # the best sample, and the best crests of the samples with their steps
            if ws_h == 0.0:
                ws_h = h_step
            if m > peaks[win]:
                peaks[win] = m
                peak_t[win] = t
            if pend:
                if not (m > cr_sc[crest_rows[n_cr], 4]):
                    n_cr, thresh = _crest_confirm(crest_rows, n_cr, cr_sc, h_step)
                pend = False
            if m > m_last and m > thresh:
                _crest_store(crest_rows[n_cr], cr_prev_y, cr_prev_p, cr_y, cr_p, cr_sc, ftmp,
                             p_prev if ev_step else p, t_old, h_step, y, p, t, m)
                pend = True
            m_last = m

            if record:
                ts[nrec] = t
                for k in range(n):
                    ys[nrec, k] = y[k]
                for k in range(n_mem):
                    ms[nrec, k] = p[mem_start + k]
                for k in range(n_out):
                    os_[nrec, k] = obuf[k]
                nrec += 1

            if land:
                # window closed: refine its maximum inside the steps on both sides of each of
                # its best crests, and inside the window's first and last steps (a maximum just
                # inside an edge is invisible to the samples)
                if refine_iters > 0:
                    if pend:
                        n_cr, thresh = _crest_confirm(crest_rows, n_cr, cr_sc, 0.0)
                    pend = False
                    _copy(ftmp, last_y)
                    n_done = 0
                    for i in range(n_cr):
                        row = crest_rows[i]
                        for side in range(2):
                            t0 = cr_sc[row, 2 * side]
                            hh = cr_sc[row, 2 * side + 1]
                            if hh <= 0.0 or _seen(done_t, n_done, t0):
                                continue
                            if side == 0:
                                v, tv = _golden_max(rhs, monitor, t0, cr_prev_y[row],
                                                    cr_prev_p[row], hh, A, B, C, K, y_new,
                                                    f_new, ytmp, f_ref, refine_iters, oscr)
                            else:
                                v, tv = _golden_max(rhs, monitor, t0, cr_y[row], cr_p[row], hh,
                                                    A, B, C, K, y_new, f_new, ytmp, f_ref,
                                                    refine_iters, oscr)
                            done_t[n_done] = t0
                            n_done += 1
                            if v > peaks[win]:
                                peaks[win] = v
                                peak_t[win] = tv
                    for which in range(2):
                        if which == 0:
                            if ws_h <= 0.0 or _seen(done_t, n_done, ws_t):
                                continue
                            v, tv = _golden_max(rhs, monitor, ws_t, ws_y, ws_p, ws_h, A, B, C, K,
                                                y_new, f_new, ytmp, f_ref, refine_iters, oscr)
                        else:
                            if _seen(done_t, n_done, t_old):
                                continue
                            # (a step that lands on an edge is never an event step: p is its
                            # memory)
                            v, tv = _golden_max(rhs, monitor, t_old, last_y, p, h_step, A,
                                                B, C, K, y_new, f_new, ytmp, f_ref,
                                                refine_iters, oscr)
                        done_t[n_done] = t_old if which else ws_t
                        n_done += 1
                        if v > peaks[win]:
                            peaks[win] = v
                            peak_t[win] = tv
                    counters[5] += n_done
                win += 1
                if win < n_win:
                    # the landed step's end is the next window's start (not an event step: m
                    # and its outputs are for the memory p), its first pending crest
                    peaks[win] = m
                    peak_t[win] = t
                    n_cr = 0
                    thresh = -np.inf
                    _crest_store(crest_rows[0], cr_prev_y, cr_prev_p, cr_y, cr_p, cr_sc, y, p,
                                 t, 0.0, y, p, t, m)
                    pend = True
                    m_last = m
                    _copy(y, ws_y)
                    ws_t = t
                    _copy(p, ws_p)
                    ws_h = 0.0
        if not need_room:
            break
        need_room = False
        ts2, ys2, ms2, os2 = _record_arrays(2 * nrec, n, ms.shape[1], n_out)
        ts2[:nrec] = ts
        ys2[:nrec] = ys
        ms2[:nrec] = ms
        os2[:nrec] = os_
        ts = ts2
        ys = ys2
        ms = ms2
        os_ = os2
    # the times are a copy (they become a Trajectory's t; a view would keep the whole
    # block alive), the other records views (the callers take what they keep from them)
    return ts[:nrec].copy(), ys[:nrec], ms[:nrec], peaks, peak_t, counters, os_[:nrec]
