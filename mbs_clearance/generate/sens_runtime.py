"""What the generated Jacobian and sensitivity kernels import: the contact law's part of the
Jacobian (`contact_jacobian`) and the direct-differentiation equations of any generated
model (`sens_rhs`, `sens_on_event`, `sens_monitor`, `sens_outputs`), written once and bound
to a module's kernels by its template (jacobians.py.jinja).

Sensitivity state (DDM): y = [q, qdot (2 N_Q), s_1 ... s_nb (2 N_Q each), W, sigma], where
s_k = d(q, qdot)/db_k for the integrated directions k and sigma[k J + j] = d(impact velocity
of joint j)/db_k (constant between events: its derivative is zero, `sens_on_event` sets it).
The parameter vector of a sensitivity run is the model's p (N_P entries), then a header at
N_P: [nb, event-time term flag, m], the sparse chain D (per direction k, m columns of z and
m values: dp/db_k), then work space (the Jacobian, N_JROWS (N_Z + 1); the plain monitor's
derivative, 2 N_Q + 1).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..contact import contact_force, contact_force_partials, friction_force_partials
from ..integrator import KERNEL
from .runtime import gap_state

__all__ = ["contact_jacobian", "friction_jacobian", "sens_rhs", "sens_on_event",
           "sens_monitor", "sens_outputs", "ddm_layout"]


@nb.njit(**KERNEL, inline="always")
def contact_jacobian(jac, stride, nz, ex, ey, exd, eyd, r_f, r_pen, r_rate, r_ex, r_ey, r_exd,
                     r_eyd, r_fx, r_fy, c_clear, c_stiff, c_rest, c_dmin, clearance, mode, dmin,
                     stiffness, restitution, model):
    """Rows of one clearance joint in the Jacobian jac (flat, `stride` per row, column nz
    the value): from the rows of the journal centre's offset (ex, ey) and velocity (exd, eyd)
    against the bearing centre, the penetration delta = |e| - c, its rate n . edot, the
    contact force F of the law (zero in free flight, mode 0) and F n (the force of the
    bearing's side on ... the journal: fx, fy as `runtime.contact_stage`), with the
    parameters that enter the law directly (columns of the clearance, stiffness,
    restitution and the impact velocity). Returns (fx, fy)."""
    delta, deltadot, nx, ny = gap_state(ex, ey, exd, eyd, clearance)
    r = delta + clearance
    rinv = 1.0 / r if r > 1e-300 else 0.0
    f = 0.0
    f_d = 0.0
    f_dd = 0.0
    f_dm = 0.0
    f_k = 0.0
    f_e = 0.0
    if mode > 0.5:
        f = contact_force(delta, deltadot, dmin, stiffness, restitution, int(model))
        if f > 0.0:
            _, f_d, f_dd, f_dm, f_k, f_e = contact_force_partials(
                delta, deltadot, dmin, stiffness, restitution, int(model))
    fx = f * nx
    fy = f * ny
    for col in range(nz):
        dex = jac[r_ex * stride + col]
        dey = jac[r_ey * stride + col]
        dexd = jac[r_exd * stride + col]
        deyd = jac[r_eyd * stride + col]
        d_delta = nx * dex + ny * dey
        dnx = (ny * ny * dex - nx * ny * dey) * rinv
        dny = (nx * nx * dey - nx * ny * dex) * rinv
        d_rate = exd * dnx + eyd * dny + nx * dexd + ny * deyd
        d_f = f_d * d_delta + f_dd * d_rate
        jac[r_pen * stride + col] = d_delta
        jac[r_rate * stride + col] = d_rate
        jac[r_f * stride + col] = d_f
        jac[r_fx * stride + col] = nx * d_f + f * dnx
        jac[r_fy * stride + col] = ny * d_f + f * dny
    # the parameters of the law: delta = |e| - c
    jac[r_pen * stride + c_clear] -= 1.0
    for k in range(4):
        if k == 0:
            col, d_f = c_clear, -f_d
        elif k == 1:
            col, d_f = c_stiff, f_k
        elif k == 2:
            col, d_f = c_rest, f_e
        else:
            col, d_f = c_dmin, f_dm
        jac[r_f * stride + col] += d_f
        jac[r_fx * stride + col] += nx * d_f
        jac[r_fy * stride + col] += ny * d_f
    jac[r_f * stride + nz] = f
    jac[r_pen * stride + nz] = delta
    jac[r_rate * stride + nz] = deltadot
    jac[r_ex * stride + nz] = ex
    jac[r_ey * stride + nz] = ey
    jac[r_exd * stride + nz] = exd
    jac[r_eyd * stride + nz] = eyd
    jac[r_fx * stride + nz] = fx
    jac[r_fy * stride + nz] = fy
    return fx, fy


@nb.njit(**KERNEL, inline="always")
def friction_jacobian(jac, stride, nz, spin, r_ex, r_ey, r_exd, r_eyd, r_spin, r_f, r_fx,
                      r_fy, r_ft, r_vt, r_pw, c_mu, c_v0, c_v1, law, mu, v0, v1):
    """Rows of one clearance joint's friction in the Jacobian, after `contact_jacobian` has
    filled its rows (values and total derivatives of the offset, its rate and the normal
    force F): the slip velocity vt = edot . t + spin (t = (-n_y, n_x); the spin's row holds
    the derivatives of omega_J R_J - omega_B R_B), the friction force Ft of the law
    (`contact.friction_force_partials`, with the columns of mu, v0, v1), the friction power
    -Ft vt, and -Ft t added to the force on the bearing (rows fx, fy), as
    `runtime.friction_stage`. Returns (fx, fy, Ft)."""
    ex = jac[r_ex * stride + nz]
    ey = jac[r_ey * stride + nz]
    exd = jac[r_exd * stride + nz]
    eyd = jac[r_eyd * stride + nz]
    f = jac[r_f * stride + nz]
    r = math.sqrt(ex * ex + ey * ey)
    if r > 1e-300:
        rinv = 1.0 / r
        nx = ex * rinv
        ny = ey * rinv
    else:
        rinv = 0.0
        nx = -1.0
        ny = 0.0
    vt = eyd * nx - exd * ny + spin
    ft, ft_vt, ft_fn, ft_mu, ft_v0, ft_v1 = friction_force_partials(vt, f, mu, v0, v1,
                                                                    int(law))
    for col in range(nz):
        dex = jac[r_ex * stride + col]
        dey = jac[r_ey * stride + col]
        dnx = (ny * ny * dex - nx * ny * dey) * rinv
        dny = (nx * nx * dey - nx * ny * dex) * rinv
        d_vt = (jac[r_eyd * stride + col] * nx + eyd * dnx - jac[r_exd * stride + col] * ny
                - exd * dny + jac[r_spin * stride + col])
        d_ft = ft_vt * d_vt + ft_fn * jac[r_f * stride + col]
        jac[r_vt * stride + col] = d_vt
        jac[r_ft * stride + col] = d_ft
        jac[r_pw * stride + col] = -(d_ft * vt + ft * d_vt)
        jac[r_fx * stride + col] += d_ft * ny + ft * dny
        jac[r_fy * stride + col] -= d_ft * nx + ft * dnx
    for k in range(3):
        if k == 0:
            col, d_ft = c_mu, ft_mu
        elif k == 1:
            col, d_ft = c_v0, ft_v0
        else:
            col, d_ft = c_v1, ft_v1
        jac[r_ft * stride + col] += d_ft
        jac[r_pw * stride + col] -= d_ft * vt
        jac[r_fx * stride + col] += d_ft * ny
        jac[r_fy * stride + col] -= d_ft * nx
    fx = jac[r_fx * stride + nz] + ft * ny
    fy = jac[r_fy * stride + nz] - ft * nx
    jac[r_fx * stride + nz] = fx
    jac[r_fy * stride + nz] = fy
    jac[r_spin * stride + nz] = spin
    jac[r_vt * stride + nz] = vt
    jac[r_ft * stride + nz] = ft
    jac[r_pw * stride + nz] = -ft * vt
    return fx, fy, ft


@nb.njit(**KERNEL, inline="always")
def ddm_layout(p, n_p):
    """(nb, m, first column entry, first value entry, work start) of a sensitivity run's p."""
    nb_ = int(p[n_p])
    m = int(p[n_p + 2])
    c0 = n_p + 3
    v0 = c0 + nb_ * m
    return nb_, m, c0, v0, v0 + nb_ * m


@nb.njit(**KERNEL, inline="always")
def _directional(jac, row, stride, y, n2, base, p, c0, v0, m, k, mem_col0, n_joints, sig):
    """Total derivative of Jacobian row `row` along direction k: the state part (s_k at
    y[base:base + n2]), the parameters' part (the sparse chain) and the memory's (sigma_k
    at y[sig:sig + J])."""
    r0 = row * stride
    acc = 0.0
    for c in range(n2):
        acc += jac[r0 + 1 + c] * y[base + c]
    for e in range(k * m, (k + 1) * m):
        acc += jac[r0 + int(p[c0 + e])] * p[v0 + e]
    for j in range(n_joints):
        acc += jac[r0 + mem_col0 + 2 * j] * y[sig + j]
    return acc


@nb.njit(**KERNEL, inline="always")
def sens_rhs(jacobian, rhs, t, y, p, dydt, n_q, n_p, nz, n_jrows, acc_row, mom_row, speed,
             mem_col0, n_joints):
    """The state, sensitivity and work derivatives; for the truncated state y[:2 N_Q] (the
    integrator's continuous extension) the plain model's."""
    n2 = 2 * n_q
    nb_, m, c0, v0, w0 = ddm_layout(p, n_p)
    if y.shape[0] < n2 * (1 + nb_) + 1 + nb_ * n_joints:
        rhs(t, y, p, dydt)
        return
    stride = nz + 1
    jac = p[w0:w0 + n_jrows * stride]
    jacobian(t, y, p, jac, False)
    for i in range(n_q):
        dydt[i] = y[n_q + i]
        dydt[n_q + i] = jac[(acc_row + i) * stride + nz]
    wpos = n2 * (1 + nb_)
    dydt[wpos] = jac[mom_row * stride + nz] * p[speed]
    for k in range(nb_):
        base = n2 * (1 + k)
        sig = wpos + 1 + k * n_joints
        for i in range(n_q):
            dydt[base + i] = y[base + n_q + i]
            dydt[base + n_q + i] = _directional(jac, acc_row + i, stride, y, n2, base, p, c0,
                                                v0, m, k, mem_col0, n_joints, sig)
        for j in range(n_joints):
            dydt[sig + j] = 0.0


@nb.njit(**KERNEL, inline="always")
def sens_on_event(jacobian, on_event, t, y, p, j, n_q, n_p, nz, n_jrows, mem_start, pen_row,
                  rate_row, joint_rows, acc_row, floor0, contact_stride, mem_col0, n_joints):
    """Switch joint j's mode (the plain model's `on_event`); at a contact onset also the
    sensitivity of its impact-velocity memory, with the event-time term:
    sigma_k = d(deltadot)/db_k + deltadotdot dt_e/db_k, dt_e/db_k = -(d delta/db_k) / deltadot
    (or d(floor)/db_k when the floor applies). The state sensitivities do not jump: the
    contact force is zero at delta = 0 in both modes."""
    if p[mem_start + 2 * j] > 0.5:
        on_event(t, y, p, j)
        return
    n2 = 2 * n_q
    nb_, m, c0, v0, w0 = ddm_layout(p, n_p)
    stride = nz + 1
    jac = p[w0:w0 + n_jrows * stride]
    jacobian(t, y, p, jac, False)           # free flight: F = 0 at the onset
    on_event(t, y, p, j)
    r_rate = rate_row + joint_rows * j
    r_pen = pen_row + joint_rows * j
    rate = jac[r_rate * stride + nz]
    floor = p[floor0 + contact_stride * j]
    wpos = n2 * (1 + nb_)
    evterm = p[n_p + 1] > 0.5
    if rate > floor:
        # d(deltadot)/dt along the motion
        r0 = r_rate * stride
        accel = jac[r0]
        for i in range(n_q):
            accel += (jac[r0 + 1 + i] * y[n_q + i]
                      + jac[r0 + 1 + n_q + i] * jac[(acc_row + i) * stride + nz])
        for k in range(nb_):
            base = n2 * (1 + k)
            sig = wpos + 1 + k * n_joints
            d_rate = _directional(jac, r_rate, stride, y, n2, base, p, c0, v0, m, k, mem_col0,
                                  n_joints, sig)
            if evterm:
                d_pen = _directional(jac, r_pen, stride, y, n2, base, p, c0, v0, m, k,
                                     mem_col0, n_joints, sig)
                d_rate -= accel * d_pen / rate
            y[sig + j] = d_rate
    else:
        col = 1 + n2 + floor0 + contact_stride * j
        for k in range(nb_):
            v = 0.0
            for e in range(k * m, (k + 1) * m):
                if int(p[c0 + e]) == col:
                    v += p[v0 + e]
            y[wpos + 1 + k * n_joints + j] = v


@nb.njit(**KERNEL, inline="always")
def sens_monitor(rhs_sens, monitor, t, y, p, dydt, out, g, gd, n_q, n_p, nz, n_jrows):
    """`rhs_sens`, then the plain model's monitor on the state (outputs, switching functions,
    the monitored value), its derivative into work space."""
    rhs_sens(t, y, p, dydt)
    n2 = 2 * n_q
    _, _, _, _, w0 = ddm_layout(p, n_p)
    ws = w0 + n_jrows * (nz + 1)
    return monitor(t, y[:n2], p, p[ws:ws + n2], out, g, gd)


@nb.njit(error_model="numpy")
def sens_outputs(jacobian, ts, ys, ms, p, n_q, n_p, nz, n_jrows, n_out, mem_start, mem_col0,
                 n_joints):
    """Values (n, n_out) and total derivatives (n, n_out, nb) of the outputs (the first
    n_out rows of the Jacobian) along the integrated directions at recorded steps (times
    ts, sensitivity states ys, memories ms)."""
    n2 = 2 * n_q
    q = p.copy()
    nb_, m, c0, v0, w0 = ddm_layout(q, n_p)
    stride = nz + 1
    jac = np.zeros(n_jrows * stride)
    n = ts.shape[0]
    vals = np.empty((n, n_out))
    ders = np.empty((n, n_out, nb_))
    wpos = n2 * (1 + nb_)
    for i in range(n):
        for k in range(ms.shape[1]):
            q[mem_start + k] = ms[i, k]
        y = ys[i]
        jacobian(ts[i], y, q, jac, True)
        for r in range(n_out):
            vals[i, r] = jac[r * stride + nz]
            for k in range(nb_):
                ders[i, r, k] = _directional(jac, r, stride, y, n2, n2 * (1 + k), q, c0, v0, m,
                                             k, mem_col0, n_joints, wpos + 1 + k * n_joints)
    return vals, ders


@nb.njit(error_model="numpy")
def jacobian_at(jacobian, t, y, p, n_jrows, nz, full):
    """The Jacobian (n_jrows, nz + 1) at (t, y) (tests, initial sensitivities)."""
    jac = np.zeros(n_jrows * (nz + 1))
    jacobian(t, y, p, jac, full)
    return jac.reshape((n_jrows, nz + 1))
