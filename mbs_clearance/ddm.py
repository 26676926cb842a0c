"""Direct differentiation (paper Eqs. 16-17) of the reduced model: compiled kernels.

The state y = [theta3, x4, theta3dot, x4dot] is augmented with its sensitivities
s_k = dy/db_k for each requested design parameter b_k, integrated together with the state by
the same compiled integrator (error control on state and sensitivities):

    d/dt s_k = (df/dy) s_k + (df/dbeta) D[:, k] + (df/ddeltadot_minus) sigma_k,

where beta are the kernel parameters (L2, L3, m2, m3, m4, J3, omega2, theta20, c, K, e, g,
v_min), D = dbeta/db the chain-rule matrix of derived values (E and R_J into K and c, m3 and
L3 into the uniform-rod J3, ...) and sigma_k = d(deltadot_minus)/db_k the sensitivity of the
impact-velocity memory. The partial derivatives are exact: generated once with sympy
(tools/generate_jacobians.py -> _jacobians.py).

The state sensitivities do not jump at contact onset or separation because the force is zero
at delta = 0 on both sides. The memory does: at an onset at time t_e, deltadot_minus =
deltadot(t_e), so

    sigma_k = d(deltadot)/db_k + deltadotdot * dt_e/db_k,   dt_e/db_k = -(d delta/db_k) / deltadot,

the event-time term (switchable, to show that it matters). See docs/sensitivity.md.

Layout of p (built by `pack`): the reduced model's 17 entries (reduced.P_*), then P_NPAR,
P_EVTERM, P_NC (1: no parameter needs the Jacobian's crank-angle columns, so the
right-hand side uses the generated *_accel_nc functions), the memory sensitivities sigma
(npar), the chain matrix D (13 x npar, row-major), its nonzero entries by parameter
(`sparse_chain`: entries per parameter, then Jacobian columns and values, each in a slot of
13 npar entries) and N_WORK entries of work space (z with the
parameter-only temporaries of the *_accel functions, filled once by `pack`).
The recorded memory is p[P_MODE : P_SIGMA + npar].
y = [4 states, 4 npar sensitivities, W].
"""

from __future__ import annotations

import math
import sys

import numba as nb
import numpy as np

from . import reduced
from ._jacobians import (
    CRANK_COLUMNS,
    N_Z,
    N_ZO,
    N_ZW,
    accel_constants,
    contact_accel,
    contact_accel_nc,
    contact_branch,
    contact_outputs,
    contact_outputs_nc,
    free_accel,
    free_accel_nc,
    free_branch,
    free_outputs,
    free_outputs_nc,
)
from .contact import contact_force, hysteresis_factor
from .integrator import (
    ACTION_SIG,
    KERNEL,
    MONITOR_SIG,
    RHS_SIG,
    _step_monitor,
    integrate,
    step_workspace,
)
from .reduced import (
    P_C,
    P_DMIN,
    P_E,
    P_G,
    P_J3,
    P_K,
    P_L2,
    P_L3,
    P_M2,
    P_M3,
    P_M4,
    P_MODE,
    P_MODEL,
    P_TH0,
    P_VFLOOR,
    P_W,
    geometry,
)

_THIS = sys.modules[__name__]
P_NPAR = 17
P_EVTERM = 18
P_NC = 19
P_SIGMA = 20
N_BETA = 13
#: kernel parameters beta, in the row order of the chain matrix D
BETA_NAMES = ("L2", "L3", "m2", "m3", "m4", "J3", "omega2", "theta20", "c", "K", "e", "g",
              "v_min")
B_L2, B_L3, B_M2, B_M3, B_M4, B_J3, B_W, B_TH0, B_C, B_K, B_E, B_G, B_VMIN = range(N_BETA)
#: slots of beta in the reduced model's parameter vector (reduced.pack_parameters)
BETA_SLOTS = np.array([P_L2, P_L3, P_M2, P_M3, P_M4, P_J3, P_W, P_TH0, P_C, P_K, P_E, P_G,
                       P_VFLOOR])
# column of beta in the generated Jacobian's input vector z (-1: not an input)
_Z_COL = np.array([6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, -1])
Z_DMIN = 5
# rows of the generated outputs
O_TH3DD, O_X4DD, O_F12X, O_F12Y, O_M2, O_F, O_DELTA, O_DELTADOT = range(8)
# the *_accel functions' fourth output: M2 (value only)
O_M2_ACCEL = 3
#: outputs recorded at every step by `monitor_sens`: the plain model's (reduced.OUT_COLUMNS),
#: then d(theta3dd)/db per integrated direction
N_OUT_PLAIN = len(reduced.OUT_COLUMNS)


#: work space at the end of p for the right-hand side: z (N_ZW: the Jacobian's inputs, then
#: the parameter-only temporaries of the generated *_accel functions), outputs (8), Jacobian
#: (8 x N_Z, flat row-major)
N_WORK = N_ZW + 8 + 8 * N_Z


def sparse_chain(D: np.ndarray, dxi: float) -> np.ndarray:
    """The nonzero entries of the chain matrix D (13 x npar) by parameter, as the kernels
    read them: [m, Jacobian columns (m per parameter, in a slot of 13 npar), values (m per
    parameter, slot)], m the largest number of entries of a parameter (at
    least 1; shorter lists are padded with value 0 on column 1). Grouped by parameter, the
    right-hand side sums each parameter's few terms in registers and stores once.
    The value of the restitution row is multiplied by dxi = d(xi)/de, constant in a run, as
    the generated Jacobian is with respect to the hysteresis factor xi; v_min (the
    impact-velocity floor) is not a Jacobian input and is left out."""
    npar = D.shape[1]
    slot = N_BETA * npar
    entries = [[(_Z_COL[b], D[b, k] * (dxi if b == B_E else 1.0)) for b in range(N_BETA)
                if _Z_COL[b] >= 0 and D[b, k] != 0.0] for k in range(npar)]
    m = max([1] + [len(e) for e in entries])
    block = np.zeros(1 + 2 * slot)
    block[0] = m
    block[1:1 + npar * m] = 1.0       # padding: column 1 (theta3), value 0
    for k, ek in enumerate(entries):
        for e, (col, value) in enumerate(ek):
            block[1 + k * m + e] = col
            block[1 + slot + k * m + e] = value
    return block


def pack(base: np.ndarray, D: np.ndarray, sigma0: np.ndarray,
         event_time_term: bool) -> np.ndarray:
    """Parameter vector of the sensitivity kernels (layout in the module docstring) from the
    reduced model's `base` = reduced.pack_parameters(mech)."""
    npar = D.shape[1]
    xi, dxi = hysteresis_factor(base[P_E], int(base[P_MODEL]))
    chain = sparse_chain(D, dxi)
    no_crank = not np.isin(chain[1:1 + npar * int(chain[0])], CRANK_COLUMNS).any()
    p = np.concatenate([base, [npar, 1.0 if event_time_term else 0.0, float(no_crank)],
                        sigma0, D.ravel(), chain, np.zeros(N_WORK)])
    # the parameter entries of the Jacobian's inputs z (constant during a run; the kernels
    # refresh only time, state and impact velocity)
    z = p[len(p) - N_WORK:len(p) - N_WORK + N_ZW]
    z[6:16] = base[[P_L2, P_L3, P_M2, P_M3, P_M4, P_J3, P_W, P_TH0, P_C, P_K]]
    z[16] = xi
    z[17] = base[P_G]
    accel_constants(z)
    return p


@nb.njit(**KERNEL, inline="always")
def _work(p, npar):
    """Views of the work space of p (no allocation in the right-hand side)."""
    w0 = P_SIGMA + (1 + N_BETA) * npar + 1 + 2 * N_BETA * npar
    return p[w0:w0 + N_ZW], p[w0 + N_ZW:w0 + N_ZW + 8], p[w0 + N_ZW + 8:w0 + N_WORK]


@nb.njit(**KERNEL, inline="always")
def _evaluate(t, y, p, z, o, jac, full):
    """Outputs and Jacobian at (t, y) in the branch of the current contact mode (z: the
    Jacobian's input vector in the work space, its parameter entries filled by `pack`).

    full=False computes only the rows theta3dd and x4dd (all the right-hand side needs).
    """
    z[0] = t
    z[1] = y[0]
    z[2] = y[1]
    z[3] = y[2]
    z[4] = y[3]
    z[5] = p[P_DMIN]
    if not full:
        # accelerations only (the right-hand side): the contact branch's unclamped force
        # (third output) tells whether it applies; F > 0 exactly when contact_force > 0
        # (without the crank-angle columns where no parameter needs them: P_NC)
        nc = p[P_NC] > 0.5
        if p[P_MODE] > 0.5:
            if nc:
                contact_accel_nc(z, o, jac)
            else:
                contact_accel(z, o, jac)
            if o[2] > 0.0:
                return
        if nc:
            free_accel_nc(z, o, jac)
        else:
            free_accel(z, o, jac)
        return
    in_contact = False
    if p[P_MODE] > 0.5:
        # the contact branch is only valid (real) for delta > 0 and F > 0 (else clamped:
        # force and derivatives are zero)
        _, _, _, delta, rate, _, _ = geometry(t, y, p)
        in_contact = contact_force(delta, rate, p[P_DMIN], p[P_K], p[P_E],
                                   int(p[P_MODEL])) > 0.0
    if in_contact:
        contact_branch(z, o, jac)
    else:
        free_branch(z, o, jac)


@nb.njit(**KERNEL, inline="always")
def _directional(jac, row, y, p, npar, out, first, stride):
    """Total derivative of output `row` along each parameter k at fixed time, into
    out[first + stride * k]: the state part and the parameter part over the nonzero
    entries of D[:, k] (one or two: each parameter enters one or two kernel parameters)."""
    r0 = row * N_Z      # the row's first entry in the flat Jacobian
    s0 = P_SIGMA + (1 + N_BETA) * npar
    slot = N_BETA * npar
    m = int(p[s0])
    for k in range(npar):
        base = 4 + 4 * k
        acc = (jac[r0 + 1] * y[base] + jac[r0 + 2] * y[base + 1]
               + jac[r0 + 3] * y[base + 2] + jac[r0 + 4] * y[base + 3]
               + jac[r0 + Z_DMIN] * p[P_SIGMA + k])
        for e in range(s0 + 1 + k * m, s0 + 1 + (k + 1) * m):
            acc += jac[r0 + int(p[e])] * p[e + slot]
        out[first + stride * k] = acc


@nb.njit(RHS_SIG, **KERNEL)
def rhs_sens(t, y, p, dydt):
    """State, sensitivity and work derivatives; for the truncated state y[:N_EVENT] (the
    integrator's continuous extension) only the state derivatives, by the plain model."""
    if y.shape[0] < 4 + 4 * int(p[P_NPAR]):
        reduced.rhs(t, y, p, dydt)
        return
    npar = int(p[P_NPAR])
    z, o, jac = _work(p, npar)
    _evaluate(t, y, p, z, o, jac, False)
    dydt[0] = y[2]
    dydt[1] = y[3]
    dydt[2] = o[O_TH3DD]
    dydt[3] = o[O_X4DD]
    # `_directional` for both acceleration rows, fused into one pass over the parameters
    # (two calls of it measured 15 % slower here); each parameter's terms of D are summed
    # in registers and stored once (a pass over all entries of D after the state part,
    # adding into dydt, waited on converted indices and on its own stores: 14 % of a
    # sensitivity run). The indices are unsigned: numba wraps negative signed indices
    # around (a compare and a conditional add per load), which the chain terms' loads
    # waited on (unsigned: a sensitivity run 3.5 % faster, A/B)
    a0 = O_TH3DD * N_Z
    b0 = O_X4DD * N_Z
    ja1, ja2, ja3, ja4, ja5 = jac[a0 + 1], jac[a0 + 2], jac[a0 + 3], jac[a0 + 4], jac[a0 + 5]
    jb1, jb2, jb3, jb4, jb5 = jac[b0 + 1], jac[b0 + 2], jac[b0 + 3], jac[b0 + 4], jac[b0 + 5]
    u = np.uint64
    s0 = P_SIGMA + (1 + N_BETA) * npar
    slot = u(N_BETA * npar)
    m = u(int(p[s0]))
    e0 = u(s0 + 1)
    for k in range(u(npar)):
        base = u(4) + u(4) * k
        s1 = y[base]
        s2 = y[base + u(1)]
        s3 = y[base + u(2)]
        s4 = y[base + u(3)]
        sg = p[u(P_SIGMA) + k]
        pa = 0.0
        pb = 0.0
        for e in range(e0 + k * m, e0 + (k + u(1)) * m):
            col = u(int(p[e]))
            v = p[e + slot]
            pa += jac[col] * v
            pb += jac[col + u(N_Z)] * v
        dydt[base] = s3
        dydt[base + u(1)] = s4
        dydt[base + u(2)] = ja1 * s1 + ja2 * s2 + ja3 * s3 + ja4 * s4 + ja5 * sg + pa
        dydt[base + u(3)] = jb1 * s1 + jb2 * s2 + jb3 * s3 + jb4 * s4 + jb5 * sg + pb
    # the crank's work (the trajectory's crank_work; not under error control)
    dydt[4 + 4 * npar] = o[O_M2_ACCEL] * p[P_W]


@nb.njit(ACTION_SIG, cache=True, error_model="numpy")
def on_event_sens(t, y, p, j):
    """Contact switch (the one joint, j = 0) with the impact-velocity memory and its
    sensitivity (event-time term)."""
    if p[P_MODE] > 0.5:
        p[P_MODE] = 0.0
        return
    npar = int(p[P_NPAR])
    z, o, jac = _work(p, npar)
    _evaluate(t, y, p, z, o, jac, True)    # free branch: F = 0 at the onset
    rate = o[O_DELTADOT]
    p[P_MODE] = 1.0
    if rate > p[P_VFLOOR]:
        p[P_DMIN] = rate
        # d(deltadot)/dt along the motion
        r0 = O_DELTADOT * N_Z
        accel = (jac[r0] + jac[r0 + 1] * y[2] + jac[r0 + 2] * y[3]
                 + jac[r0 + 3] * o[O_TH3DD] + jac[r0 + 4] * o[O_X4DD])
        d_rate = np.empty(npar)
        d_pen = np.empty(npar)
        _directional(jac, O_DELTADOT, y, p, npar, d_rate, 0, 1)
        _directional(jac, O_DELTA, y, p, npar, d_pen, 0, 1)
        for k in range(npar):
            if p[P_EVTERM] > 0.5:
                d_rate[k] += accel * (-d_pen[k] / rate)
            p[P_SIGMA + k] = d_rate[k]
    else:
        p[P_DMIN] = p[P_VFLOOR]
        d0 = P_SIGMA + npar
        for k in range(npar):
            p[P_SIGMA + k] = p[d0 + B_VMIN * npar + k]


@nb.njit(cache=True, error_model="numpy")
def _nonzero_by_parameter(coeffs):
    """The nonzero coefficients (nb, npar) per parameter k: their number cnt[k], the
    directions dirs[k, :cnt[k]] and the values vals[k, :cnt[k]] (most parameters are one
    direction)."""
    nb_, npar = coeffs.shape
    cnt = np.zeros(npar, dtype=np.int64)
    dirs = np.zeros((npar, nb_), dtype=np.int64)
    vals = np.zeros((npar, nb_))
    for k in range(npar):
        for b in range(nb_):
            if coeffs[b, k] != 0.0:
                dirs[k, cnt[k]] = b
                vals[k, cnt[k]] = coeffs[b, k]
                cnt[k] += 1
    return cnt, dirs, vals


@nb.njit(cache=True, error_model="numpy")
def sens_outputs(ts, ys, ms, outs, p, coeffs):
    """Sensitivities of the outputs (F12x, F12y, M2, F) at recorded steps.

    ms are the recorded memories p[P_MODE : P_SIGMA + nb], outs the outputs recorded by
    `monitor_sens` (the plain model's, then d(theta3dd)/db per integrated direction), coeffs
    (nb, npar) the parameters' sensitivities as combinations of the integrated directions
    (`sensitivity.independent_directions`). theta3dd is an input of the generated
    *_outputs functions, and its total derivatives are the recorded ones, so each step
    needs the Jacobian of the outputs at given accelerations only.
    Returns dF12/db (n, 2, npar), d|F12|/db, dM2/db and dF/db (n, npar) each.
    """
    nb_ = int(p[P_NPAR])
    npar = coeffs.shape[1]
    n = ts.shape[0]
    q = p.copy()
    zw, _, _ = _work(q, nb_)
    z = np.empty(N_ZO)
    o = np.empty(4)
    jac = np.zeros(4 * N_ZO)
    # the chain terms per direction (`sparse_chain`) with integer columns, and the nonzero
    # coefficients, once
    s0 = P_SIGMA + (1 + N_BETA) * nb_
    slot = N_BETA * nb_
    m = int(q[s0])
    cols = np.empty((nb_, m), dtype=np.int64)
    vals = np.empty((nb_, m))
    for b in range(nb_):
        for e in range(m):
            cols[b, e] = int(q[s0 + 1 + b * m + e])
            vals[b, e] = q[s0 + 1 + b * m + e + slot]
    cnt, dirs, cvals = _nonzero_by_parameter(coeffs)
    d = np.empty((nb_, 4))
    d_force = np.empty((n, 2, npar))
    d_mag = np.empty((n, npar))
    d_moment = np.empty((n, npar))
    d_contact = np.empty((n, npar))
    for j in range(6, N_Z):
        z[j] = zw[j]
    nc = q[P_NC] > 0.5
    for i in range(n):
        z[0] = ts[i]
        for j in range(4):
            z[1 + j] = ys[i, j]
        z[5] = ms[i, 1]                 # the impact-velocity memory (P_DMIN)
        z[N_Z] = outs[i, 0]             # theta3dd
        # the branch as in the right-hand side: contact while the law's force is positive
        # (without the crank-angle columns where no parameter needs them, as there)
        in_contact = False
        if ms[i, 0] > 0.5:              # the contact mode (P_MODE)
            if nc:
                contact_outputs_nc(z, o, jac)
            else:
                contact_outputs(z, o, jac)
            in_contact = o[3] > 0.0
        if not in_contact:
            if nc:
                free_outputs_nc(z, o, jac)
            else:
                free_outputs(z, o, jac)
        for b in range(nb_):
            base = 4 + 4 * b
            s1 = ys[i, base]
            s2 = ys[i, base + 1]
            s3 = ys[i, base + 2]
            s4 = ys[i, base + 3]
            sg = ms[i, P_SIGMA - P_MODE + b]
            a3 = outs[i, N_OUT_PLAIN + b]
            for r in range(4):
                r0 = r * N_ZO
                acc = (jac[r0 + 1] * s1 + jac[r0 + 2] * s2 + jac[r0 + 3] * s3
                       + jac[r0 + 4] * s4 + jac[r0 + Z_DMIN] * sg + jac[r0 + N_Z] * a3)
                for e in range(m):
                    acc += jac[r0 + cols[b, e]] * vals[b, e]
                d[b, r] = acc
        fx = o[0]
        fy = o[1]
        inv = 1.0 / max(math.sqrt(fx * fx + fy * fy), 1e-300)
        for k in range(npar):
            dfx = 0.0
            dfy = 0.0
            dm2 = 0.0
            dfc = 0.0
            for e in range(cnt[k]):
                b = dirs[k, e]
                c = cvals[k, e]
                dfx += c * d[b, 0]
                dfy += c * d[b, 1]
                dm2 += c * d[b, 2]
                dfc += c * d[b, 3]
            d_force[i, 0, k] = dfx
            d_force[i, 1, k] = dfy
            d_moment[i, k] = dm2
            d_contact[i, k] = dfc
            d_mag[i, k] = (fx * dfx + fy * dfy) * inv
    return d_force, d_mag, d_moment, d_contact


@nb.njit(MONITOR_SIG, **KERNEL)
def monitor_sens(t, y, p, dydt, out, g, gd):
    """The integrator's last stage of a step: `rhs_sens`, the plain model's |F12| and its
    switching function into g, gd (from one evaluation of the plain model). When the
    integrator records outputs (out of N_OUT_PLAIN + npar entries): the plain model's
    outputs, then the total derivatives of theta3dd along each direction, which
    `sens_outputs` needs at the recorded steps (the right-hand side computed them
    already)."""
    rhs_sens(t, y, p, dydt)
    res = reduced.dynamics(t, y, p)
    if out.shape[0] > N_OUT_PLAIN:
        for k in range(N_OUT_PLAIN):
            out[k] = res[k]
        for k in range(out.shape[0] - N_OUT_PLAIN):
            out[N_OUT_PLAIN + k] = dydt[6 + 4 * k]
    return reduced.peak_and_switching(p, res, g, gd)


@nb.njit(cache=True, error_model="numpy")
def norm_maxima(ys, coeffs, weights, lo, hi):
    """Per window [lo[w], hi[w]) of recorded steps and per parameter k, the maximum over the
    steps of the weighted norm sqrt(sum_j weights[4k + j] s_kj^2) of the state sensitivity
    s_k = sum_b coeffs[b, k] ys[:, 4 + 4b : 8 + 4b] (b over the integrated directions,
    `sensitivity.independent_directions`); returns (windows, npar)."""
    npar = coeffs.shape[1]
    out = np.zeros((lo.shape[0], npar))
    cnt, dirs, val = _nonzero_by_parameter(coeffs)
    for w in range(lo.shape[0]):
        for i in range(lo[w], hi[w]):
            for k in range(npar):
                s0 = 0.0
                s1 = 0.0
                s2 = 0.0
                s3 = 0.0
                for e in range(cnt[k]):
                    c = val[k, e]
                    j = 4 + 4 * dirs[k, e]
                    s0 += c * ys[i, j]
                    s1 += c * ys[i, j + 1]
                    s2 += c * ys[i, j + 2]
                    s3 += c * ys[i, j + 3]
                acc = (weights[4 * k] * s0 * s0 + weights[4 * k + 1] * s1 * s1
                       + weights[4 * k + 2] * s2 * s2 + weights[4 * k + 3] * s3 * s3)
                if acc > out[w, k]:
                    out[w, k] = acc
    return np.sqrt(out)


@nb.njit(cache=True, error_model="numpy", nogil=True)
def integrate_sens(y0, p, edges, settings, coefficients):
    """`integrator.integrate` bound to the sensitivity equations (compiled once, cached);
    events and monitor are the plain model's."""
    # module attributes, not plain globals: see reduced.integrate_plain
    return integrate(_THIS.rhs_sens, reduced.event, _THIS.on_event_sens, _THIS.monitor_sens,
                     y0, p, edges, settings, coefficients)


@nb.njit(cache=True, error_model="numpy")
def step_sens(t0, y0, p, hs, coefficients, n_out):
    """Steps of the sizes hs of the sensitivity equations from (t0, y0), with the memory in
    p and the method's `coefficients` (`Tableau.arrays()`): the states (sensitivities
    included) at t0 + hs (len(hs), n) and the outputs of `monitor_sens` there (len(hs),
    n_out). The integrator's peak refinement maximises |F12| over exactly this step map,
    so this gives the state at a refined peak time."""
    A, B, C = coefficients[0], coefficients[1], coefficients[2]
    n = y0.shape[0]
    K, _, f_new, ytmp, f0, g, gd = step_workspace(coefficients, n)
    ys = np.empty((hs.shape[0], n))
    outs = np.zeros((hs.shape[0], n_out))
    _THIS.rhs_sens(t0, y0, p, f0)
    for k in range(hs.shape[0]):
        _step_monitor(_THIS.rhs_sens, _THIS.monitor_sens, t0, y0, f0, hs[k], A, B, C, K, p,
                      ys[k], f_new, ytmp, outs[k], g, gd)
    return ys, outs
