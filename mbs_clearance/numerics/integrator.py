"""Compiled adaptive Runge-Kutta integration with event location (numba kernels): explicit
pairs (dopri5, dop853, bs3) and a linearly implicit Rosenbrock method for stiff models
(rodas4, `rosenbrock`: its step is not limited by stability, its Jacobian a central
difference of the right-hand side).

Protocol v2. The model is passed as four compiled functions with fixed signatures (numba
specialises the integrator for them, so the calls are direct and can be inlined); it has
J >= 1 switching functions (``IntegratorSettings.n_events``), one per clearance joint:

- ``rhs(t, y, p, dydt)`` (`RHS_SIG`): right-hand side; ``p`` holds parameters and the
  model's memory variables, ``p[mem_start:mem_start + n_mem]`` (by convention two per joint
  j: ``p[mem_start + 2 j]`` its mode, ``p[mem_start + 2 j + 1]`` its impact velocity), which
  are recorded with every step;
- ``event(t, y, p, j) -> (g, gdot)`` (`EVENT_SIG`): switching function of joint j, negative
  in its current mode, and its time derivative along the motion (used to look for
  excursions between samples); a crossing to positive inside a step is an event;
- ``on_event(t, y, p, j)`` (`ACTION_SIG`): applied exactly at a located event of joint j
  (updates joint j's memory in ``p``);
- ``monitor(t, y, p, dydt, out, g, gd) -> m`` (`MONITOR_SIG`): the right-hand side (into
  ``dydt``, as ``rhs``), every joint's switching function and rate into ``g[:J]``,
  ``gd[:J]`` (the values of ``event(t, y, p, j)``) and a scalar m whose maximum is tracked
  per time window (the peak); it may also write model outputs into ``out`` (n_out
  entries), which are recorded with every step. It is called for the last (FSAL) stage of
  every step, at the step's end, so that a model evaluates itself once there for the
  derivative, the peak, the event search and the outputs.

The settings are one record (`IntegratorSettings`, built with `make_settings`), the outcome a
named result (`RESULTS`, each with an actionable message).

Error control: the scaled RMS of the embedded error estimate over the first n_err state
components, and optionally (2 J more entries in ``atol``) the change of each switching
function g_j and of its rate between the step's solution and the embedded one: a model whose
events hinge on a small difference of large state components (a penetration of
micrometres in coordinates of decimetres) gets its error controlled at the scale of the
difference.

A step is taken in named stages: `_attempt` (stages, monitor, error), then `_find_event`
(every joint's switching function searched on the step's dense output: interior samples, a
closer look wherever the cubic Hermite interpolant of g and its rate comes within
`event_margin` of the surface, and steps limited while approaching it, so that a crossing
and return inside one step is not missed; the earliest crossing among the joints is located
on the dense output), `_land` (the step redone with the located size and refined by Illinois
iterations on the real step map, inside the search's bracket, until |g| <= event_tol: the
memory is set at the landed state, never at the first state found inside the wall),
`_switch` (on_event for that joint and for every other joint on its surface there: two
events in one step are two steps), `_track_crests` and, at a window's close,
`_refine_window`. The integration also lands exactly on the window edges, and the maximum
of ``monitor`` in each window is refined by golden-section search on re-taken steps (of the
state the monitor reads, y[:n_dense]): inside
the steps on both sides of each of the window's best ``n_crests`` crests (local maxima of
the sampled monitor: two crests within the integration accuracy of each other are both
refined) and inside the window's first and last steps.
"""

from __future__ import annotations

import enum
import math
from typing import NamedTuple

import numba as nb
import numpy as np
from numba import types

__all__ = [
    "KERNEL", "RHS_SIG", "SCALAR_SIG", "MONITOR_SIG", "EVENT_SIG", "ACTION_SIG", "METHODS",
    "Tableau", "rosenbrock", "STIFF_METHODS", "integrate", "N_CRESTS", "RESULTS",
    "IntegratorSettings", "make_settings", "COUNTERS",
]

#: numba options of the kernels, shared with the contact laws (`_kernel`)
from ._kernel import KERNEL  # noqa: E402

_vec = types.float64[::1]
RHS_SIG = types.void(types.float64, _vec, _vec, _vec)
SCALAR_SIG = types.float64(types.float64, _vec, _vec)
EVENT_SIG = types.UniTuple(types.float64, 2)(types.float64, _vec, _vec, types.int64)
ACTION_SIG = types.void(types.float64, _vec, _vec, types.int64)
MONITOR_SIG = types.float64(types.float64, _vec, _vec, _vec, _vec, _vec, _vec)

class Tableau:
    """Coefficients of an embedded explicit RK pair in the layout of scipy's ``rk_step``.

    A (s, s), B (s,), C (s,), E (s+1,) = b - b_hat (the last entry weights the FSAL stage),
    P (s+1+x, k) dense-output polynomial coefficients (y(t + theta h) = y + h sum_j K_j
    sum_m P[j, m] theta^(m+1)), order = order of the error estimator + 1.
    Two-estimator pairs (DOP853) give a second error vector E2 (empty otherwise); the
    continuous extension may need x extra stages, A_extra (x, s+1+x) and C_extra (x,),
    evaluated only for accepted steps. A Rosenbrock method (`rosenbrock`) is written in the
    same arrays, A with more columns than rows.
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



# dopri5's coefficients as compile-time constants of `_dp5_step_monitor` and `_dp5_error`
# (the same floats as _DP_A, _DP_B, _DP_C, _DP_E: the same arithmetic, bit for bit)
_A21 = _DP_A[1][0]
_A31, _A32 = _DP_A[2][:2]
_A41, _A42, _A43 = _DP_A[3][:3]
_A51, _A52, _A53, _A54 = _DP_A[4][:4]
_A61, _A62, _A63, _A64, _A65 = _DP_A[5][:5]
_B1, _B2, _B3, _B4, _B5, _B6 = _DP_B
_C2, _C3, _C4, _C5, _C6 = _DP_C[1:]
_E1, _E2, _E3, _E4, _E5, _E6, _E7 = _DP_E


def _dop853_coefficients():
    """scipy's table of DOP853 coefficients (scipy/integrate/_ivp/dop853_coefficients.py, plain
    numpy arrays) read from its file: importing it as a module would import all of
    scipy.integrate, a large part of the start-up time of every command."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.find_spec("scipy")
    path = Path(spec.origin).parent / "integrate" / "_ivp" / "dop853_coefficients.py"
    if path.is_file():
        module_spec = importlib.util.spec_from_file_location("_mbs_dop853_coefficients", path)
        module = importlib.util.module_from_spec(module_spec)
        module_spec.loader.exec_module(module)
        return module
    from scipy.integrate._ivp import dop853_coefficients  # another layout: the usual way

    return dop853_coefficients


def _dop853() -> Tableau:
    """Dormand & Prince's 8(5,3) pair (Hairer, Norsett & Wanner, Solving ODEs I, Sec. II.10),
    coefficients taken from scipy's DOP853 class, with Hairer's 7th-order continuous
    extension (3 extra stages) rewritten as polynomials in theta for `dense_eval`.

    The extension is y(theta) = y0 + theta (F0 + (1 - theta) (F1 + theta (F2 + (1 - theta)
    (F3 + ...)))), F0 = dy, F1 = h f0 - dy, F2 = 2 dy - h (f0 + f1), F3..F6 = h D K: term i
    carries the weight theta^(i//2 + 1) (1 - theta)^((i + 1)//2).
    """
    from numpy.polynomial import polynomial as npoly

    k = _dop853_coefficients()
    s = k.N_STAGES
    # the slices scipy's DOP853 class takes of the table
    A, C, A_extra, C_extra = k.A[:s, :s], k.C[:s], k.A[s + 1:], k.C[s + 1:]
    n_all = s + 1 + len(C_extra)
    b = np.zeros(n_all)
    b[:s] = k.B
    F = np.zeros((7, n_all))
    F[0] = b
    F[1] = -b
    F[1, 0] += 1.0
    F[2] = 2.0 * b
    F[2, 0] -= 1.0
    F[2, s] -= 1.0
    F[3:] = k.D
    P = np.zeros((n_all, 7))
    for i in range(7):
        w = npoly.polymul(npoly.polypow([0.0, 1.0], i // 2 + 1),
                          npoly.polypow([1.0, -1.0], (i + 1) // 2))
        w = np.pad(w, (0, 8 - len(w)))
        P += np.outer(F[i], w[1:])
    # beta = 0.06: where stability limits the step (the stiff contact) the I controller
    # rejects ~30 % of the steps; measured on the sensitivity equations (docs/performance.md)
    return Tableau("dop853", A, k.B, C, k.E5, P, 8, 7, E2=k.E3,
                   A_extra=A_extra, C_extra=C_extra, pi_beta=0.06, pi_gain=0.2)


def rosenbrock(name, alpha, gammas, a, c, m, e, order, error_order) -> Tableau:
    """A Rosenbrock (linearly implicit) method as a `Tableau` of the compiled integrator.

    The method (Hairer & Wanner, Solving ODEs II, Sec. IV.7, the form of their code RODAS):
    with W = I / (h gamma) - J, J = df/dy at the step's start,

        W U_i = f(t + alpha_i h, y + sum_{j<i} a_ij U_j) + sum_{j<i} (c_ij / h) U_j
                + h gamma_i df/dt,
        y_new = y + sum_i m_i U_i,  error = sum_i e_i U_i,

    gamma = gammas[0] (a, c: (s, s) strictly lower triangular). J and df/dt are central
    differences of the right-hand side (2 (n + 1) evaluations per step; the model's protocol
    stays the four kernels); W is factored once per step (LU, partial pivoting).

    The integrator's layout: K[0] = f(t, y), K[i] = U_i / h (i = 1..s), K[s + 1] = f at the
    step's end (the FSAL row), then n + 3 work rows (W's factors, df/dt, the pivots, a
    work vector). So B = [0, m], E = [0, e, 0], C = [0, alpha], and A (s + 1, 2 s + 4)
    holds a in its first s + 1 columns (K's index), c in the next s + 1, gamma_i in column
    2 s + 2 and gamma in column 2 s + 3: a method is linearly implicit when A has more
    columns than rows (`is_rosenbrock`), so every method has the same compiled types. The
    continuous extension is the cubic Hermite interpolant of (y, f) at both ends (third
    order), written in P's form."""
    s = len(alpha)
    A = np.zeros((s + 1, 2 * s + 4))
    for i in range(s):
        for j in range(i):
            A[i + 1, j + 1] = a[i][j]
            A[i + 1, s + 1 + j + 1] = c[i][j]
        A[i + 1, 2 * s + 2] = gammas[i]
    A[:, 2 * s + 3] = gammas[0]
    B = np.concatenate([[0.0], m])
    C = np.concatenate([[0.0], alpha])
    E = np.concatenate([[0.0], e, [0.0]])
    P = np.zeros((s + 2, 3))
    P[0] = [1.0, -2.0, 1.0]
    for i in range(s):
        P[i + 1] = [0.0, 3.0 * m[i], -2.0 * m[i]]
    P[s + 1] = [0.0, -1.0, 1.0]
    return Tableau(name, A, B, C, E, P, order, error_order)


def _rodas4() -> Tableau:
    """Hairer & Wanner's RODAS (order 4, embedded 3, L-stable, stiffly accurate): the
    coefficients of their code's ROCOE (METH = 1)."""
    a = np.zeros((6, 6))
    c = np.zeros((6, 6))
    a[1, 0] = 1.544
    a[2, :2] = 0.9466785280815826, 0.2557011698983284
    a[3, :3] = 3.314825187068521, 2.896124015972201, 0.9986419139977817
    a[4, :4] = 1.221224509226641, 6.019134481288629, 12.53708332932087, -0.6878860361058950
    a[5, :5] = (*a[4, :4], 1.0)
    c[1, 0] = -5.6688
    c[2, :2] = -2.430093356833875, -0.2063599157091915
    c[3, :3] = -0.1073529058151375, -9.594562251023355, -20.47028614809616
    c[4, :4] = 7.496443313967647, -10.24680431464352, -33.99990352819905, 11.70890893206160
    c[5, :5] = (8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136,
                -6.058818238834054)
    alpha = [0.0, 0.386, 0.21, 0.63, 1.0, 1.0]
    gammas = [0.25, -0.1043, 0.1035, -0.03620000000000023, 0.0, 0.0]
    m = [*a[4, :4], 1.0, 1.0]
    e = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    return rosenbrock("rodas4", alpha, gammas, a, c, m, e, 4, 3)


#: name -> Tableau; the registry of integration methods of the compiled integrator
METHODS: dict[str, Tableau] = {
    "dop853": _dop853(),
    "dopri5": Tableau("dopri5", _DP_A, _DP_B, _DP_C, _DP_E, _DP_P, 5, 4),
    "bs3": Tableau("bs3", _BS_A, _BS_B, _BS_C, _BS_E, _BS_P, 3, 2),
    # stiff problems (the oil film's squeeze): linearly implicit, its step not limited by
    # stability
    "rodas4": _rodas4(),
}

#: the methods whose step is not limited by stability (`rosenbrock`)
STIFF_METHODS = ("rodas4",)

class RESULTS(enum.IntEnum):
    """Outcome of `integrate` (its last return value, as an int; ``RESULTS(status)``)."""

    success = 0
    max_steps = 1
    step_underflow = 2
    event_chatter = 3

    @property
    def message(self) -> str:
        """What happened and what to change."""
        return _RESULT_MESSAGES[self]


_RESULT_MESSAGES = {
    RESULTS.success: "success",
    RESULTS.max_steps: "maximum number of steps reached: raise max_steps or loosen rtol/atol",
    RESULTS.step_underflow: "step size underflow: the problem is too stiff for this "
                            "tolerance; loosen rtol/atol or reduce the contact stiffness",
    RESULTS.event_chatter: "events chatter (repeated zero-length events): the contact is "
                           "grazing at machine precision; raise impact_velocity_floor or "
                           "change the initial state",
}
# the kernel's codes (ints in compiled code)
_MAX_STEPS = int(RESULTS.max_steps)
_STEP_UNDERFLOW = int(RESULTS.step_underflow)
_EVENT_CHATTER = int(RESULTS.event_chatter)

#: the entries of the counters array returned by `integrate`
COUNTERS = ("nfev", "naccept", "nreject", "nevent", "nrefine")

#: crests (distinct local maxima of the sampled monitor) per window whose neighbouring steps
#: are refined at the window's close (the default of ``IntegratorSettings.n_crests``): two
#: crests within the integration accuracy of each other are both refined, and the best
#: refined value is the window's peak
N_CRESTS = 3


class IntegratorSettings(NamedTuple):
    """The settings of `integrate`, one record (build it with `make_settings`, which fixes
    the field types: numba compiles one specialisation per set of types)."""

    rtol: float
    #: absolute tolerances: n_err entries (or len(y0)) for the state, plus optionally 2 J
    #: (those of g_j and gdot_j, joint by joint) that put the switching functions under
    #: error control
    atol: np.ndarray
    #: leading state components under error control
    n_err: int
    #: initial step (<= 0: automatic)
    h0: float
    h_max: float
    max_steps: int
    #: record every accepted step (t, y, memory, outputs)
    record: bool
    #: |g| below which an event is located (and a joint counts as on its surface)
    event_tol: float
    #: look closer between event samples where g comes this near the surface
    event_margin: float
    #: interior event samples per step
    n_samples: int
    #: golden-section iterations per refined step (0: peaks not refined)
    refine_iters: int
    #: outputs written by monitor, recorded
    n_out: int
    #: the event functions and the monitor read only y[:n_dense]: the continuous extension
    #: is formed for those components only, its extra stages (DOP853) and the peak
    #: refinement's steps call `rhs` and `monitor` with the truncated state y[:n_dense] (the
    #: model must give those derivatives then)
    n_dense: int
    #: J, the number of switching functions
    n_events: int
    #: the memory entries of p, recorded with every step
    mem_start: int
    n_mem: int
    #: crests per window refined (see `N_CRESTS`)
    n_crests: int


def make_settings(rtol, atol, n_err, *, h0=0.0, h_max=np.inf, max_steps=10**6, record=True,
                  event_tol=1e-12, event_margin=0.0, n_samples=1, refine_iters=24, n_out=0,
                  n_dense, n_events=1, mem_start, n_mem=None,
                  n_crests=N_CRESTS) -> IntegratorSettings:
    """`IntegratorSettings` with its fields converted to the types the kernel is compiled
    for (n_mem default: 2 n_events, two memory entries per joint). Raises ValueError for a
    field out of its range."""
    n_events = int(n_events)
    n_mem = 2 * n_events if n_mem is None else int(n_mem)
    atol = np.ascontiguousarray(atol, dtype=float).reshape(-1)
    for name, value, low in (("n_err", n_err, 1), ("n_dense", n_dense, 1),
                             ("n_events", n_events, 1), ("n_crests", n_crests, 1),
                             ("max_steps", max_steps, 1), ("n_samples", n_samples, 0),
                             ("refine_iters", refine_iters, 0), ("n_out", n_out, 0),
                             ("mem_start", mem_start, 0), ("n_mem", n_mem, 0)):
        if int(value) != value or value < low:
            raise ValueError(f"{name} must be an integer >= {low}; got {value!r}")
    if atol.shape[0] < n_err:
        raise ValueError(f"atol must have at least n_err = {n_err} entries; got "
                         f"{atol.shape[0]}")
    if not (rtol > 0.0 and h_max > 0.0 and event_tol > 0.0 and event_margin >= 0.0):
        raise ValueError("rtol, h_max and event_tol must be > 0 and event_margin >= 0; got "
                         f"{rtol!r}, {h_max!r}, {event_tol!r}, {event_margin!r}")
    return IntegratorSettings(float(rtol), atol, int(n_err), float(h0), float(h_max),
                              int(max_steps), bool(record), float(event_tol),
                              float(event_margin), int(n_samples), int(refine_iters),
                              int(n_out), int(n_dense), n_events, int(mem_start), n_mem,
                              int(n_crests))


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
def is_rosenbrock(A):
    """Whether the coefficients A are a Rosenbrock method's (`rosenbrock`)."""
    return A.shape[1] > A.shape[0]


@nb.njit(**KERNEL, inline="always")
def work_rows(A, n):
    """K's rows beyond the stages and extra stages: a Rosenbrock method's work (n + 3)."""
    return n + 3 if is_rosenbrock(A) else 0


@nb.njit(**KERNEL, inline="always")
def step_evals(A, B, n):
    """Right-hand side evaluations of one step of n states, its end's (FSAL) included: s
    for an explicit method, s + 2 n + 1 for a Rosenbrock one (s - 2 stages, 2 (n + 1) for
    the central differences of J and df/dt, the end)."""
    return B.shape[0] + 2 * n + 1 if is_rosenbrock(A) else B.shape[0]


@nb.njit(**KERNEL)
def _lu(M, r0, n, piv):
    """LU factors (partial pivoting) of the n x n matrix in the rows r0.. of M, in place;
    the pivot rows into piv (floats)."""
    for k in range(n):
        big = abs(M[r0 + k, k])
        q = k
        for i in range(k + 1, n):
            if abs(M[r0 + i, k]) > big:
                big = abs(M[r0 + i, k])
                q = i
        piv[k] = q
        if q != k:
            for c in range(n):
                tmp = M[r0 + k, c]
                M[r0 + k, c] = M[r0 + q, c]
                M[r0 + q, c] = tmp
        d = M[r0 + k, k]
        if d != 0.0:
            for i in range(k + 1, n):
                M[r0 + i, k] /= d
                li = M[r0 + i, k]
                if li != 0.0:
                    for c in range(k + 1, n):
                        M[r0 + i, c] -= li * M[r0 + k, c]


@nb.njit(**KERNEL, inline="always")
def _lu_solve(M, r0, n, piv, x):
    """x = (LU)^-1 x with the factors of `_lu`, in place."""
    for k in range(n):
        q = int(piv[k])
        if q != k:
            tmp = x[k]
            x[k] = x[q]
            x[q] = tmp
    for i in range(1, n):
        acc = x[i]
        for c in range(i):
            acc -= M[r0 + i, c] * x[c]
        x[i] = acc
    for i in range(n - 1, -1, -1):
        acc = x[i]
        for c in range(i + 1, n):
            acc -= M[r0 + i, c] * x[c]
        x[i] = acc / M[r0 + i, i]


#: relative step of the central differences of J and df/dt, sqrt(eps). Central, not
#: forward: a stiff model's force may vary over lengths far below |y| (the oil film over the
#: clearance times 1 - eccentricity ratio, 1e-6 m, at coordinates of 0.1 m). Measured on the
#: lubricated paper case: forward differences at sqrt(eps) erred up to 1e-3 in J's position
#: columns and 5e-3 in df/dt, and the Rosenbrock steps converged at order 1 with them
#: (order 4 with the generated exact Jacobian); central ones erred 5e-5 at most. Forward
#: differences at eps^(2/3) did as well on the film but lost the order of a stiff linear
#: problem to round-off.
_FD_STEP = math.sqrt(2.220446049250313e-16)


@nb.njit(**KERNEL)
def _ros_stages(rhs, t, y, f, h, A, B, C, K, p, y_new, ytmp):
    """The stages of one Rosenbrock step (`rosenbrock`): J and df/dt by central differences
    (steps `_FD_STEP` max(1e-5, |y_k|), and of t), W factored, the stages solved; fills
    K[:s + 1] and y_new."""
    s1 = B.shape[0]
    n = y.shape[0]
    w0 = s1 + 1             # W's rows
    r_ft = w0 + n
    r_piv = r_ft + 1
    r_tmp = r_piv + 1
    ncol = A.shape[1]
    gamma = A[0, ncol - 1]
    for k in range(n):
        K[0, k] = f[k]
        ytmp[k] = y[k]
    # J by columns (r_ft holds f(y - d) until df/dt is formed): W = I / (h gamma) - J
    for c in range(n):
        d = _FD_STEP * max(1e-5, abs(y[c]))
        ytmp[c] = y[c] + d
        d = ytmp[c] - y[c]
        rhs(t, ytmp, p, K[r_tmp])
        ytmp[c] = y[c] - d
        rhs(t, ytmp, p, K[r_ft])
        ytmp[c] = y[c]
        for r in range(n):
            K[w0 + r, c] = -(K[r_tmp, r] - K[r_ft, r]) / (2.0 * d)
    diag = 1.0 / (h * gamma)
    for r in range(n):
        K[w0 + r, r] += diag
    dt = _FD_STEP * max(1e-5, abs(t))
    dt = (t + dt) - t
    rhs(t + dt, y, p, K[r_ft])
    rhs(t - dt, y, p, K[r_tmp])
    for r in range(n):
        K[r_ft, r] = (K[r_ft, r] - K[r_tmp, r]) / (2.0 * dt)
    _lu(K, w0, n, K[r_piv])
    cc = s1     # first c column
    for i in range(1, s1):
        if i == 1:
            for k in range(n):
                K[1, k] = f[k]
        else:
            _combine(y, h, K, A[i], i, ytmp)
            rhs(t + C[i] * h, ytmp, p, K[i])
        # K[j] = U_j / h: the c terms (c_ij / h) U_j are c_ij K[j]
        hg = h * A[i, ncol - 2]
        for k in range(n):
            acc = K[i, k] + hg * K[r_ft, k]
            for j in range(1, i):
                acc += A[i, cc + j] * K[j, k]
            K[r_tmp, k] = acc
        _lu_solve(K, w0, n, K[r_piv], K[r_tmp])
        for k in range(n):
            K[i, k] = K[r_tmp, k] / h
    _combine(y, h, K, B, s1, y_new)


@nb.njit(**KERNEL, inline="always")
def rk_stages(rhs, t, y, f, h, A, B, C, K, p, y_new, ytmp):
    """The stages of one explicit RK step of size h but the last: fills K[:s] and y_new (a
    Rosenbrock method's: `_ros_stages`)."""
    if is_rosenbrock(A):
        _ros_stages(rhs, t, y, f, h, A, B, C, K, p, y_new, ytmp)
        return
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
def step_workspace(coefficients, n, n_events=1):
    """Work arrays of one step of `n` states with the method's `coefficients`: the stage
    derivatives K, the vectors y_new, f_new, ytmp, f0 and the switching functions and
    rates g, gd of `n_events` joints (for `_step_monitor` callers outside the
    integrator)."""
    A, B, A_extra = coefficients[0], coefficients[1], coefficients[6]
    return (np.zeros((B.shape[0] + 1 + A_extra.shape[0] + work_rows(A, n), n)), np.empty(n),
            np.empty(n),
            np.empty(n), np.empty(n), np.empty(n_events), np.empty(n_events))


@nb.njit(**KERNEL, inline="always")
def _step_monitor(rhs, monitor, t, y, f, h, A, B, C, K, p, y_new, f_new, ytmp, out, g, gd):
    """`rk_step` with the monitor as its last stage: returns the monitor at the step's end
    (the switching functions and rates there into g, gd, its outputs into out)."""
    rk_stages(rhs, t, y, f, h, A, B, C, K, p, y_new, ytmp)
    m = monitor(t + h, y_new, p, f_new, out, g, gd)
    _copy(f_new, K[B.shape[0]])
    return m


@nb.njit(**KERNEL)
def _is_dopri5(A, B, C, E, E2, A_extra):
    """Whether the coefficients that a step uses (A below the diagonal, B, C[1:], E) are
    dopri5's, with one error estimator and no extra stages."""
    if (A.shape[0] != 6 or A.shape[1] < 5 or B.shape[0] != 6 or C.shape[0] != 6
            or E.shape[0] != 7 or E2.shape[0] != 0 or A_extra.shape[0] != 0):
        return False
    lower = (A[1, 0] == _A21 and A[2, 0] == _A31 and A[2, 1] == _A32 and A[3, 0] == _A41
             and A[3, 1] == _A42 and A[3, 2] == _A43 and A[4, 0] == _A51 and A[4, 1] == _A52
             and A[4, 2] == _A53 and A[4, 3] == _A54 and A[5, 0] == _A61 and A[5, 1] == _A62
             and A[5, 2] == _A63 and A[5, 3] == _A64 and A[5, 4] == _A65)
    weights = (B[0] == _B1 and B[1] == _B2 and B[2] == _B3 and B[3] == _B4 and B[4] == _B5
               and B[5] == _B6 and C[1] == _C2 and C[2] == _C3 and C[3] == _C4
               and C[4] == _C5 and C[5] == _C6)
    errors = (E[0] == _E1 and E[1] == _E2 and E[2] == _E3 and E[3] == _E4 and E[4] == _E5
              and E[5] == _E6 and E[6] == _E7)
    return lower and weights and errors and _B2 == 0.0 and _E2 == 0.0


@nb.njit(**KERNEL, inline="always")
def _dp5_step_monitor(rhs, monitor, t, y, f, h, K, p, y_new, f_new, ytmp, out, g, gd):
    """`_step_monitor` for dopri5 with a short state (n <= SMALL): the stage combinations
    written out with the coefficients as constants (no loop over the terms, no test of zero
    coefficients, each component summed in a register and stored once), in the order and
    with the products (h a_ij) of `_combine`: bit-identical to the generic step. The generic
    loops cost about a quarter of a plain run (their trip counts and zero tests are known at
    run time only)."""
    n = y.shape[0]
    for k in range(SMALL):
        if k < n:
            K[0, k] = f[k]
    c1 = h * _A21
    for k in range(SMALL):
        if k < n:
            ytmp[k] = y[k] + c1 * K[0, k]
    rhs(t + _C2 * h, ytmp, p, K[1])
    c1 = h * _A31
    c2 = h * _A32
    for k in range(SMALL):
        if k < n:
            ytmp[k] = y[k] + c1 * K[0, k] + c2 * K[1, k]
    rhs(t + _C3 * h, ytmp, p, K[2])
    c1 = h * _A41
    c2 = h * _A42
    c3 = h * _A43
    for k in range(SMALL):
        if k < n:
            ytmp[k] = y[k] + c1 * K[0, k] + c2 * K[1, k] + c3 * K[2, k]
    rhs(t + _C4 * h, ytmp, p, K[3])
    c1 = h * _A51
    c2 = h * _A52
    c3 = h * _A53
    c4 = h * _A54
    for k in range(SMALL):
        if k < n:
            ytmp[k] = y[k] + c1 * K[0, k] + c2 * K[1, k] + c3 * K[2, k] + c4 * K[3, k]
    rhs(t + _C5 * h, ytmp, p, K[4])
    c1 = h * _A61
    c2 = h * _A62
    c3 = h * _A63
    c4 = h * _A64
    c5 = h * _A65
    for k in range(SMALL):
        if k < n:
            ytmp[k] = (y[k] + c1 * K[0, k] + c2 * K[1, k] + c3 * K[2, k] + c4 * K[3, k]
                       + c5 * K[4, k])
    rhs(t + _C6 * h, ytmp, p, K[5])
    c1 = h * _B1
    c3 = h * _B3          # b2 = 0: skipped, as `_combine` skips it
    c4 = h * _B4
    c5 = h * _B5
    c6 = h * _B6
    for k in range(SMALL):
        if k < n:
            y_new[k] = (y[k] + c1 * K[0, k] + c3 * K[2, k] + c4 * K[3, k] + c5 * K[4, k]
                        + c6 * K[5, k])
    m = monitor(t + h, y_new, p, f_new, out, g, gd)
    for k in range(SMALL):
        if k < n:
            K[6, k] = f_new[k]
    return m


@nb.njit(**KERNEL, inline="always")
def _dp5_error(K, h, y, y_new, rtol, atol, n_err, work):
    """`error_norm` of dopri5 (one estimator, e2 = 0 skipped) for n_err <= SMALL, the
    weights as constants; the same arithmetic in the same order (bit-identical); leaves
    E.K in work as `error_norm` does."""
    acc = 0.0
    for k in range(SMALL):
        if k < n_err:
            w = (0.0 + _E1 * K[0, k] + _E3 * K[2, k] + _E4 * K[3, k] + _E5 * K[4, k]
                 + _E6 * K[5, k] + _E7 * K[6, k])
            work[k] = w
            scale = atol[k] + rtol * max(abs(y[k]), abs(y_new[k]))
            acc += (w / scale) ** 2
    return abs(h) * math.sqrt(acc / n_err)


@nb.njit(**KERNEL, inline="always")
def _event_error_sq(event, t, h, y_new, p, work, g, gd, rtol, atol, n_err, yhat):
    """Squared scaled differences, summed over the joints, of the switching functions and
    their rates between the step's solution y_new (where they are g, gd) and the embedded
    solution y_new - h work (work: the error combination of the stages, first n_err
    components); the absolute tolerances of joint j are atol[n + 2 j], atol[n + 2 j + 1]."""
    n = y_new.shape[0]
    for k in range(n):
        yhat[k] = y_new[k] - h * work[k] if k < n_err else y_new[k]
    acc = 0.0
    for j in range(g.shape[0]):
        gh, gdh = event(t, yhat, p, j)
        eg = (g[j] - gh) / (atol[n + 2 * j] + rtol * abs(g[j]))
        egd = (gd[j] - gdh) / (atol[n + 2 * j + 1] + rtol * abs(gd[j]))
        acc += eg * eg + egd * egd
    return acc


@nb.njit(**KERNEL)
def _attempt(rhs, event, monitor, t, y, f, h, A, B, C, E, E2, K, p, y_new, f_new, ytmp, work,
             work2, out, rtol, atol, n_err, yhat, g, gd, dp5):
    """Stage "attempt a step": its stages, the monitor at its end (outputs into out, the
    switching functions and rates into g, gd) and its scaled error; returns (monitor,
    error). One call of a function without numba's runtime, into which the helpers are
    inlined (inlined into `integrate` they would reference-count their arrays). dp5: the
    coefficients are dopri5's and the state is short (`_dp5_step_monitor`, `_dp5_error`).

    With 2 J more entries in atol than states, the switching functions and their rates are
    under error control too, with those absolute tolerances (`IntegratorSettings.atol`)."""
    if dp5:
        m = _dp5_step_monitor(rhs, monitor, t, y, f, h, K, p, y_new, f_new, ytmp, out, g, gd)
        err = _dp5_error(K, h, y, y_new, rtol, atol, n_err, work)
    else:
        m = _step_monitor(rhs, monitor, t, y, f, h, A, B, C, K, p, y_new, f_new, ytmp, out, g,
                          gd)
        err = error_norm(K, E, E2, h, y, y_new, rtol, atol, n_err, work, work2)
    n = y.shape[0]
    n_g = 2.0 * g.shape[0]
    if atol.shape[0] < n + 2 * g.shape[0]:
        return m, err
    # error_norm left E.K in work (and E2.K in work2): the embedded solutions' g, gdot
    e1 = _event_error_sq(event, t + h, h, y_new, p, work, g, gd, rtol, atol, n_err, yhat)
    if E2.shape[0] == 0:
        err_ev = math.sqrt(e1 / n_g)
    else:
        e2 = _event_error_sq(event, t + h, h, y_new, p, work2, g, gd, rtol, atol, n_err, yhat)
        err_ev = 0.0 if e1 == 0.0 else e1 / math.sqrt((e1 + 0.01 * e2) * n_g)
    return m, max(err, err_ev)


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
                out, g, gd):
    """Maximise monitor(t0 + h, step(y0, h)) over h in [0, h_max]; return (value, t).
    f0, out (the monitor's outputs) and g, gd (its switching functions) are work arrays."""
    rhs(t0, y0, p, f0)
    invphi = 0.6180339887498949
    a = 0.0
    b = h_max
    c = b - invphi * (b - a)
    d = a + invphi * (b - a)
    fc = _step_monitor(rhs, monitor, t0, y0, f0, c, A, B, C, K, p, y_new, f_new, ytmp, out,
                       g, gd)
    fd = _step_monitor(rhs, monitor, t0, y0, f0, d, A, B, C, K, p, y_new, f_new, ytmp, out,
                       g, gd)
    for _ in range(iters):
        if fc > fd:
            b = d
            d = c
            fd = fc
            c = b - invphi * (b - a)
            fc = _step_monitor(rhs, monitor, t0, y0, f0, c, A, B, C, K, p, y_new, f_new, ytmp,
                               out, g, gd)
        else:
            a = c
            c = d
            fc = fd
            d = a + invphi * (b - a)
            fd = _step_monitor(rhs, monitor, t0, y0, f0, d, A, B, C, K, p, y_new, f_new, ytmp,
                               out, g, gd)
    if fc > fd:
        return fc, t0 + c
    return fd, t0 + d


@nb.njit(**KERNEL, inline="always")
def _crest_put(row, cr_y, cr_p, cr_sc, y_prev, p_prev, t_prev, h_prev, y, p, t, m):
    """Store a (pending) crest in `row`: the step before it (state y_prev at t_prev, size
    h_prev, memory p_prev: cr_y[row, 0], cr_p[row, 0]; h_prev = 0: none) and the sample
    itself (y, memory p: cr_y[row, 1], cr_p[row, 1]; t, m)."""
    if h_prev > 0.0:
        for k in range(y.shape[0]):
            cr_y[row, 0, k] = y_prev[k]
        for k in range(p.shape[0]):
            cr_p[row, 0, k] = p_prev[k]
    for k in range(y.shape[0]):
        cr_y[row, 1, k] = y[k]
    for k in range(p.shape[0]):
        cr_p[row, 1, k] = p[k]
    cr_sc[row, 0] = t_prev
    cr_sc[row, 1] = h_prev
    cr_sc[row, 2] = t
    cr_sc[row, 3] = 0.0
    cr_sc[row, 4] = m


@nb.njit(**KERNEL)
def _crest_store(row, cr_y, cr_p, cr_sc, y_prev, p_prev, t_prev, h_prev, y, p, t, m):
    """`_crest_put` as a call (from `integrate`, where an inlined body would
    reference-count its arrays)."""
    _crest_put(row, cr_y, cr_p, cr_sc, y_prev, p_prev, t_prev, h_prev, y, p, t, m)


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
                      n_samples, event_tol, event_margin, ytmp, g_a, gd_a):
    """Whether a step is certainly clear of every joint's switching surface, from the cubic
    Hermite interpolant of the state (its values and derivatives at both ends, no extra
    stages): the test of `_search_event` at the same interior samples, with twice the
    margin, and the interpolant's g checked against the Hermite interpolant of g itself (two
    cubic approximations of different functions; where they differ by more than a tenth of
    the margin, the interpolation error is not small against it). False sends the step to
    `_search_event` on the continuous extension. g_a, gd_a: work arrays of J entries.

    Where the steps resolve the motion the cubic's error is far below the margin: in the
    paper's case at most 1.3e-9 m at mid-step (measured with a margin of 0.05 c = 5e-7 m;
    the margin is 0.001 c = 1e-8 m at the default rtol, `linkage_model.event_margin`, and a
    step whose two cubics differ by more than a tenth of it takes the full search)."""
    n_ev = g_start.shape[0]
    for j in range(n_ev):
        if g_start[j] > -100.0 * event_tol:
            return False           # starts on the surface: `_search_event` looks closer
        g_a[j] = g_start[j]
        gd_a[j] = gd_start[j]
    margin = 2.0 * event_margin
    n = y.shape[0]
    theta_a = 0.0
    for i in range(1, n_samples + 2):
        theta_b = min(i / (n_samples + 1.0), 1.0)
        span = (theta_b - theta_a) * h
        last = i == n_samples + 1
        h00 = h10 = h01 = h11 = 0.0
        if not last:
            h00, w10, h01, w11 = _hermite_weights(theta_b)
            h10 = w10 * h
            h11 = w11 * h
            for k in range(n):
                ytmp[k] = h00 * y[k] + h10 * f0[k] + h01 * y_new[k] + h11 * f1[k]
        for j in range(n_ev):
            if last:
                g_b = g_end[j]
                gd_b = gd_end[j]
            else:
                g_b, gd_b = event(t + theta_b * h, ytmp, p, j)
                # the Hermite interpolant of g over the whole step, at the same point
                g_h = (h00 * g_start[j] + h10 * gd_start[j] + h01 * g_end[j]
                       + h11 * gd_end[j])
                if abs(g_b - g_h) > 0.1 * event_margin:
                    return False
            bound = _hermite_bound(g_a[j], gd_a[j] * span, g_b, gd_b * span)
            if g_b > -margin or bound > -margin:
                return False
            g_a[j] = g_b
            gd_a[j] = gd_b
        theta_a = theta_b
    return True


@nb.njit(**KERNEL, inline="always")
def _search_event(event, j, t, y, h, K, P, p, g_start, gd_start, g_end, gd_end, n_samples,
                  event_tol, event_margin, ytmp, wts, fine, sample_polys):
    """First sign change of joint j's g (from <= 0 to > 0) inside a step of size h.

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
            g_b, gd_b = event(t + theta_b * h, ytmp, p, j)
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
            for q in range(7):
                fine[q] = (q + 1) / 8.0
            if 0.0 < where < 1.0:
                # insert the interpolant's maximum in order (the 7 points are sorted)
                q = 7
                while q > 0 and fine[q - 1] > where:
                    fine[q] = fine[q - 1]
                    q -= 1
                fine[q] = where
                n_fine = 8
            span_theta = theta_b - theta_a
            base = theta_a
            for q in range(n_fine):
                theta_f = base + fine[q] * span_theta
                dense_eval(y, h, K, P, theta_f, ytmp, wts)
                g_f, gd_f = event(t + theta_f * h, ytmp, p, j)
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



@nb.njit(**KERNEL, inline="always")
def _dense_root(event, j, t, y, h, K, P, p, a, ga, b, gb, event_tol, ytmp, ytmp_d, wts):
    """Illinois root of joint j's g on the dense output in the bracket [a, b] of thetas
    (g(a) <= 0 < g(b)); ytmp_d = ytmp[:len(y)] is written."""
    side = 0
    theta = b
    for _ in range(60):
        c = (a * gb - b * ga) / (gb - ga)
        dense_eval(y, h, K, P, c, ytmp_d, wts)
        gc = event(t + c * h, ytmp, p, j)[0]
        theta = c
        if abs(gc) <= event_tol or (b - a) < 1e-15:
            break
        a, ga, b, gb, side = _illinois_update(c, gc, a, ga, b, gb, side)
    return theta


@nb.njit(**KERNEL)
def _find_event(rhs, event, t, y, y_new, h, K, P, A_extra, C_extra, p, g_start, gd_start,
                g_end, gd_end, n_samples, event_tol, event_margin, ytmp, ytmp_d, wts, fine,
                sample_polys, g_a, gd_a):
    """Stage "search and locate an event" of an accepted step of size h from (t, y) (y, ytmp_d:
    the first n_dense components): every joint's switching function searched on the step's
    dense output (`_search_event`; a continuous extension with extra stages, DOP853, is
    formed only where the cubic Hermite look `_clear_of_surface` does not show the step
    clear of every surface), and the earliest crossing among the joints located on it.

    Returns (j, theta_lo, g_lo, theta_hi, g_hi, theta, nfev): j = -1 if no joint crosses,
    else the joint crossing first (the lowest j of equal times), the search's bracket
    [theta_lo, theta_hi] of its crossing with g there, the located theta (0: already past
    the surface at the step's start) and the function evaluations spent."""
    n_extra = A_extra.shape[0]
    s = K.shape[0] - n_extra - 1
    nfev = 0
    if n_extra > 0:
        if _clear_of_surface(event, t, y, y_new, K[0], K[s], h, p, g_start, gd_start, g_end,
                             gd_end, n_samples, event_tol, event_margin, ytmp, g_a, gd_a):
            return -1, 1.0, 0.0, -1.0, 0.0, 1.0, 0
        extra_stages(rhs, t, y, h, K, A_extra, C_extra, p, ytmp_d)
        nfev = n_extra
    best = -1
    b_lo = 1.0
    b_glo = 0.0
    b_hi = -1.0
    b_ghi = 0.0
    b_theta = 1.0
    for j in range(g_start.shape[0]):
        g0 = g_start[j]
        # on the surface (|g| <= event_tol), moving into the mode's side (g' < 0): the point
        # an event was just landed on, or a slow onset's first steps in contact, where g is
        # round-off; a crossing found from there with g <= event_tol is round-off too
        on_surface = abs(g0) <= event_tol and gd_start[j] < 0.0
        if on_surface and g0 > 0.0:
            g0 = 0.0
        lo, g_lo, hi, g_hi = _search_event(event, j, t, y, h, K, P, p, g0, gd_start[j],
                                           g_end[j], gd_end[j], n_samples, event_tol,
                                           event_margin, ytmp, wts, fine, sample_polys)
        if hi < 0.0 or (on_surface and g_hi <= event_tol):
            continue
        if g_lo > 0.0:
            theta = 0.0        # already past the switching surface at the step start
        else:
            theta = _dense_root(event, j, t, y, h, K, P, p, lo, g_lo, hi, g_hi, event_tol,
                                ytmp, ytmp_d, wts)
        if best < 0 or theta < b_theta:
            best = j
            b_lo = lo
            b_glo = g_lo
            b_hi = hi
            b_ghi = g_hi
            b_theta = theta
    return best, b_lo, b_glo, b_hi, b_ghi, b_theta, nfev


@nb.njit(**KERNEL)
def _land(rhs, event, j, t, y, f, h_ev, h_a, g_a, h_b, g_b, A, B, C, K, p, y_new, f_new, ytmp,
          event_tol):
    """Stage "land on an event": the step from (t, y) redone with the located size h_ev and
    refined by Illinois iterations on its size inside the search's bracket [h_a, h_b] (g_a
    <= 0 < g_b) until |g_j| <= event_tol, so that the root found is the first crossing (an
    open secant could jump to a later crossing of a non-monotone g). Leaves the landed step
    in K, y_new, f_new; returns (h_ev, nfev)."""
    s = step_evals(A, B, y.shape[0])
    rk_step(rhs, t, y, f, h_ev, A, B, C, K, p, y_new, f_new, ytmp)
    nfev = s
    g_ev = event(t + h_ev, y_new, p, j)[0]
    side = 0
    for _ in range(16):
        if abs(g_ev) <= event_tol or h_b - h_a <= 1e-15 * max(1.0, abs(t)):
            break
        h_a, g_a, h_b, g_b, side = _illinois_update(h_ev, g_ev, h_a, g_a, h_b, g_b, side)
        h_c = (h_a * g_b - h_b * g_a) / (g_b - g_a)
        if not (h_a < h_c < h_b):
            h_c = 0.5 * (h_a + h_b)
        h_ev = h_c
        rk_step(rhs, t, y, f, h_ev, A, B, C, K, p, y_new, f_new, ytmp)
        nfev += s
        g_ev = event(t + h_ev, y_new, p, j)[0]
    return h_ev, nfev


@nb.njit(**KERNEL)
def _switch(event, on_event, t, y, p, j, n_events, event_tol):
    """Stage "switch": on_event for joint j at (t, y), and for every other joint whose
    switching function is within event_tol of its surface there (simultaneous events);
    returns the number of joints switched."""
    n_sw = 1
    for k in range(n_events):
        if k != j and abs(event(t, y, p, k)[0]) <= event_tol:
            on_event(t, y, p, k)
            n_sw += 1
    on_event(t, y, p, j)
    return n_sw


@nb.njit(**KERNEL)
def _track_crests(m, m_last, pend, n_cr, thresh, crest_rows, cr_y, cr_p, cr_sc, y_prev,
                  p_step, t_prev, h_step, y, p, t):
    """Stage "track the window's peak": the sample m at the end of an accepted step (state
    y, memory p, t; the step from (t_prev, y_prev) of size h_step ran with memory p_step)
    confirms the pending crest if it is not above it, and becomes the pending crest if it
    rises above the last sample (m_last) and above the smallest kept crest (thresh).
    Returns (n_cr, thresh, pend)."""
    if pend:
        if not (m > cr_sc[crest_rows[n_cr], 4]):
            n_cr, thresh = _crest_confirm(crest_rows, n_cr, cr_sc, h_step)
        pend = False
    if m > m_last and m > thresh:
        _crest_put(crest_rows[n_cr], cr_y, cr_p, cr_sc, y_prev, p_step, t_prev, h_step, y,
                     p, t, m)
        pend = True
    return n_cr, thresh, pend


@nb.njit(cache=True, error_model="numpy")
def _refine_window(rhs, monitor, peak, peak_t, n_cr, crest_rows, cr_y, cr_p, cr_sc, ws_t, ws_y,
                   ws_p, ws_h, t_last, y_last, p_last, h_last, A, B, C, K, y_new, f_new, ytmp,
                   f_ref, refine_iters, oscr, g, gd, done_t):
    """Stage "refine the window's peak" at its close: golden-section search of the monitor
    inside the steps on both sides of each kept crest, and inside the window's first step
    (from ws_t, size ws_h) and last step (from t_last, size h_last), each step once (by its
    start time). Returns (peak, peak_t, steps refined) given the best sample (peak,
    peak_t). The steps are taken on the leading len(ws_y) components of the states (the
    crests' too), as long as ws_y, y_last, y_new and ytmp."""
    n_done = 0
    for i in range(n_cr + 2):
        if i < n_cr:
            row = crest_rows[i]
            sides = 2
        else:
            row = -1
            sides = 1
        for side in range(sides):
            if row >= 0:
                t0 = cr_sc[row, 2 * side]
                hh = cr_sc[row, 2 * side + 1]
            elif i == n_cr:
                t0 = ws_t
                hh = ws_h
            else:
                t0 = t_last
                hh = h_last
            if hh <= 0.0 or _seen(done_t, n_done, t0):
                continue
            if row >= 0:
                v, tv = _golden_max(rhs, monitor, t0, cr_y[row, side][:ws_y.shape[0]],
                                    cr_p[row, side], hh, A, B, C, K, y_new, f_new, ytmp, f_ref,
                                    refine_iters, oscr, g, gd)
            elif i == n_cr:
                v, tv = _golden_max(rhs, monitor, t0, ws_y, ws_p, hh, A, B, C, K, y_new, f_new,
                                    ytmp, f_ref, refine_iters, oscr, g, gd)
            else:
                v, tv = _golden_max(rhs, monitor, t0, y_last, p_last, hh, A, B, C, K, y_new,
                                    f_new, ytmp, f_ref, refine_iters, oscr, g, gd)
            done_t[n_done] = t0
            n_done += 1
            if v > peak:
                peak = v
                peak_t = tv
    return peak, peak_t, n_done


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
def integrate(rhs, event, on_event, monitor, y0, p, edges, settings, coefficients):
    """Integrate from edges[0] to edges[-1]; see the module docstring for the protocol.

    Arguments: the four model kernels (compiled functions with the signatures RHS_SIG,
    EVENT_SIG, ACTION_SIG, MONITOR_SIG); y0; p (parameters + memory, modified in place);
    edges (window edges, edges[0] = t0, edges[-1] = t_end; the integration lands on each,
    and the monitor's maximum is tracked per window); settings (`IntegratorSettings`, from
    `make_settings`); coefficients = `Tableau.arrays()`.

    Returns (t (m,), y (m, n), memory (m, n_mem) of the recorded steps, the refined maximum
    of monitor per window and its time, counters (`COUNTERS`: nfev, naccept, nreject,
    nevent, nrefine), outputs (m, n_out) of the recorded steps, status (a `RESULTS` code)).

    numba compiles one specialisation per set of model kernels. Called from Python with
    the kernels as arguments it is compiled in every new process; bind the kernels in a
    cached wrapper instead (a generated model's `integrate_model`) to load it from the
    disk cache."""
    A, B, C, E, E2, P, A_extra, C_extra, error_order, pi_alpha, pi_beta = coefficients
    rtol = settings.rtol
    atol = settings.atol
    n_err = settings.n_err
    h_max = settings.h_max
    max_steps = settings.max_steps
    record = settings.record
    event_tol = settings.event_tol
    event_margin = settings.event_margin
    n_samples = settings.n_samples
    refine_iters = settings.refine_iters
    n_out = settings.n_out
    n_ev = settings.n_events
    mem_start = settings.mem_start
    n_mem = settings.n_mem
    n_top = settings.n_crests
    n = y0.shape[0]
    n_dense = min(settings.n_dense, n)
    s = B.shape[0]
    # dopri5 on a short state: its step written out with constant coefficients
    dp5 = n <= SMALL and n_err <= SMALL and _is_dopri5(A, B, C, E, E2, A_extra)
    K = np.zeros((s + 1 + A_extra.shape[0] + work_rows(A, n), n))
    evals = step_evals(A, B, n)
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
    # every joint's switching function and rate at the step's start and end, and work arrays
    g_start = np.empty(n_ev)
    gd_start = np.empty(n_ev)
    g_end = np.empty(n_ev)
    gd_end = np.empty(n_ev)
    g_work = np.empty(n_ev)
    gd_work = np.empty(n_ev)
    n_win = edges.shape[0] - 1
    peaks = np.full(n_win, -np.inf)
    peak_t = np.zeros(n_win)
    counters = np.zeros(len(COUNTERS), dtype=np.int64)
    status = 0
    # the window's best crests (distinct local maxima of the sampled monitor), each with the
    # step before it and the step after it (state and memory: [row, 0] before, [row, 1] at
    # the crest; cr_sc[row]: prev_t, prev_h, t, next_h, value): crest_rows[:n_cr] are the
    # kept crests, the pending one (the last sample, while it rises) takes the free row
    # crest_rows[n_cr]
    cr_y = np.empty((n_top + 1, 2, n))
    cr_p = np.empty((n_top + 1, 2, p.shape[0]))
    cr_sc = np.zeros((n_top + 1, 5))
    crest_rows = np.arange(n_top + 1)
    n_cr = 0
    thresh = -np.inf                    # the smallest kept crest once n_top are kept
    done_t = np.empty(2 * n_top + 2)    # start times of the steps refined at a window's close
    # the window's start (its first step is refined too)
    ws_y = y.copy()
    ws_t = edges[0]
    ws_p = p.copy()
    ws_h = 0.0
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
    m0 = monitor(t, y, p, f, obuf, g_start, gd_start)
    counters[0] += 1
    if settings.h0 <= 0.0:
        h = initial_step(rhs, t, y, f, p, rtol, atol, error_order + 1, min(h_max, t_end - t),
                         ytmp, ftmp)
        counters[0] += 1
    else:
        h = min(settings.h0, h_max)
    win = 0
    peaks[0] = m0
    peak_t[0] = t
    # the window's start is its first pending crest (the first step is the one after it)
    _crest_store(crest_rows[0], cr_y, cr_p, cr_sc, y, p, t, 0.0, y, p, t, m0)
    pend = True
    m_last = m0
    if record:
        ts[0] = t
        ys[0, :] = y
        for k in range(n_mem):
            ms[0, k] = p[mem_start + k]
        for k in range(n_out):
            os_[0, k] = obuf[k]
        nrec = 1
    zero_events = 0
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
                status = _MAX_STEPS
                break
            nstep += 1
            t_target = edges[win + 1]
            land = False
            h_try = h
            # approaching a surface: do not step far past the linear prediction of the
            # crossing, so that the samples of the event search resolve the approach
            for j in range(n_ev):
                if gd_start[j] > 0.0:
                    h_try = min(h_try, (2.0 * abs(g_start[j]) + (n_samples + 1) * event_margin)
                                / gd_start[j])
            if t + h_try >= t_target - 1e-13 * max(1.0, abs(t_target)):
                h_try = t_target - t
                land = True
            if h_try <= 1e-15 * max(1.0, abs(t)):
                if land:
                    h_try = t_target - t
                else:
                    status = _STEP_UNDERFLOW
                    break
            m_new, err = _attempt(rhs, event, monitor, t, y, f, h_try, A, B, C, E, E2, K, p,
                                  y_new, f_new, ytmp, ytmp, ftmp, obuf, rtol, atol, n_err, yhat,
                                  g_end, gd_end, dp5)
            counters[0] += evals
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

            j_ev, theta_lo, g_lo, theta_hi, g_hi, theta_star, nfev = _find_event(
                rhs, event, t, y_d, y_new, h_try, K, P, A_extra, C_extra, p, g_start, gd_start,
                g_end, gd_end, n_samples, event_tol, event_margin, ytmp, ytmp_d, wts, fine,
                sample_polys, g_work, gd_work)
            counters[0] += nfev
            ev_step = j_ev >= 0
            if ev_step:
                _copy(p, p_prev)    # the step before the event ran with this memory
                counters[3] += 1
                h_ev = theta_star * h_try
                if h_ev <= 1e-14 * max(1.0, abs(t)):
                    zero_events += 1
                    if zero_events > 20:
                        status = _EVENT_CHATTER
                        break
                    on_event(t, y, p, j_ev)
                    monitor(t, y, p, f, obuf, g_start, gd_start)
                    counters[0] += 1
                    if record and nrec > 0 and ts[nrec - 1] == t:
                        # the memory recorded at t is the one used by the step that follows it
                        for k in range(n_mem):
                            ms[nrec - 1, k] = p[mem_start + k]
                        for k in range(n_out):
                            os_[nrec - 1, k] = obuf[k]
                    continue
                zero_events = 0
                h_ev, nfev = _land(rhs, event, j_ev, t, y, f, h_ev, theta_lo * h_try,
                                   min(g_lo, 0.0), theta_hi * h_try, max(g_hi, 1e-300), A, B, C,
                                   K, p, y_new, f_new, ytmp, event_tol)
                counters[0] += nfev
                t_old = t
                t = t + h_ev
                land = False
                h_step = h_ev
                _copy(y, ftmp)  # the pre-step state, kept for the peak's crests
                _copy(y_new, y)
                counters[3] += _switch(event, on_event, t, y, p, j_ev, n_ev, event_tol) - 1
                m = monitor(t, y, p, f, obuf, g_start, gd_start)    # with the new memory
                counters[0] += 1
                h = h_next
            else:
                zero_events = 0
                for j in range(n_ev):  # valid for the next step (no event intervened)
                    g_start[j] = g_end[j]
                    gd_start[j] = gd_end[j]
                t_old = t
                h_step = h_try
                _copy(y, ftmp)
                t = t_target if land else t + h_try
                _copy(y_new, y)
                _copy(f_new, f)
                m = m_new
                h = h_next
            counters[1] += 1

            # ---- the window's peak: the best sample, and the best crests with their steps
            if ws_h == 0.0:
                ws_h = h_step
            if m > peaks[win]:
                peaks[win] = m
                peak_t[win] = t
            if not (pend or (m > m_last and m > thresh)):
                pass    # a falling sample, no crest pending: nothing to confirm or store
            elif ev_step:
                n_cr, thresh, pend = _track_crests(m, m_last, pend, n_cr, thresh, crest_rows,
                                                   cr_y, cr_p, cr_sc, ftmp, p_prev, t_old,
                                                   h_step, y, p, t)
            else:
                n_cr, thresh, pend = _track_crests(m, m_last, pend, n_cr, thresh, crest_rows,
                                                   cr_y, cr_p, cr_sc, ftmp, p, t_old, h_step, y,
                                                   p, t)
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
                # window closed: refine its maximum (a step that lands on an edge is never an
                # event step: p is the memory of its last step)
                if refine_iters > 0:
                    if pend:
                        n_cr, thresh = _crest_confirm(crest_rows, n_cr, cr_sc, 0.0)
                    # on the state the monitor reads (y[:n_dense]; the model's rhs gives its
                    # derivative alone, as for the continuous extension): a sensitivity run
                    # refines its peaks by the plain model's steps
                    peaks[win], peak_t[win], n_done = _refine_window(
                        rhs, monitor, peaks[win], peak_t[win], n_cr, crest_rows,
                        cr_y, cr_p, cr_sc, ws_t, ws_y[:n_dense], ws_p, ws_h,
                        t_old, ftmp[:n_dense], p, h_step, A, B, C, K, y_new[:n_dense], f_new,
                        ytmp_d, f_ref, refine_iters, oscr, g_work, gd_work, done_t)
                    counters[4] += n_done
                win += 1
                if win < n_win:
                    # the landed step's end is the next window's start and its first pending
                    # crest (m and its outputs are for the memory p)
                    peaks[win] = m
                    peak_t[win] = t
                    n_cr = 0
                    thresh = -np.inf
                    _crest_store(crest_rows[0], cr_y, cr_p, cr_sc, y, p, t, 0.0, y, p, t, m)
                    pend = True
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
    return ts[:nrec].copy(), ys[:nrec], ms[:nrec], peaks, peak_t, counters, os_[:nrec], status
