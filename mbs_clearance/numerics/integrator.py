"""The integration methods of the compiled integrator (core/integrator.c) and the records
around a run: the embedded Runge-Kutta pairs (dopri5, dop853, bs3) and a linearly implicit
Rosenbrock method for stiff models (rodas4, `rosenbrock`: its step is not limited by
stability, its Jacobian a central difference of the right-hand side) as coefficient arrays
(`METHODS`), the settings of a run (`IntegratorSettings`, built with `make_settings`), its
outcome (`RESULTS`, each with an actionable message) and its counters (`COUNTERS`).

The model seam, the error control, the event location and the peak refinement are
described in core/mbs_core.h and core/integrator.c.
"""

from __future__ import annotations

import enum
import math
from typing import NamedTuple

import numpy as np

__all__ = [
    "METHODS", "Tableau", "rosenbrock", "STIFF_METHODS", "N_CRESTS", "RESULTS",
    "IntegratorSettings", "make_settings", "COUNTERS", "initial_step",
]

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
        """The coefficient and controller arguments of a run (`core.integrate.integrate`),
        in its order."""
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
    """Outcome of a run of the compiled integrator (its last return value, as an int;
    ``RESULTS(status)``)."""

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
#: the entries of the counters array returned by a run
COUNTERS = ("nfev", "naccept", "nreject", "nevent", "nrefine")

#: crests (distinct local maxima of the sampled monitor) per window whose neighbouring steps
#: are refined at the window's close (the default of ``IntegratorSettings.n_crests``): two
#: crests within the integration accuracy of each other are both refined, and the best
#: refined value is the window's peak
N_CRESTS = 3


class IntegratorSettings(NamedTuple):
    """The settings of a run of the compiled integrator, one record (build it with
    `make_settings`, which fixes the field types)."""

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
    """`IntegratorSettings` with its fields converted to the types the core reads (n_mem
    default: 2 n_events, two memory entries per joint). Raises ValueError for a
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


def initial_step(rhs, t, y, f, p, rtol, atol, order, direction_span, ytmp, ftmp):
    """Hairer-Norsett-Wanner starting step size in s (the compiled integrator's rule):
    `rhs(t, y, p, dydt)` a Python callable, `f` its value at (t, y), `ytmp` and `ftmp`
    work arrays of the length of y."""
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
