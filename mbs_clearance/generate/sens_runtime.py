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

import numba as nb
import numpy as np

from ..laws._dispatch import friction_force_partials_slots
from ..laws.forces import contact_force, contact_force_partials
from ..laws.lubrication.partials import film_direction, film_values
from ..numerics.integrator import KERNEL, _golden_max, _step_monitor, step_workspace
from .runtime import corner_state, gap_state

__all__ = ["contact_jacobian", "friction_jacobian", "contact_tangent", "friction_tangent",
           "film_jacobian", "film_tangent", "corner_jacobian", "corner_tangent",
           "corner_friction_jacobian", "corner_friction_tangent", "sens_on_event_at",
           "sens_rhs", "seed_directions", "seed_index", "work_size", "fill_seed_work", "tangent_at",
           "step_peaks", "step_value", "step_states", "sens_on_event", "sens_monitor",
           "sens_outputs", "ddm_layout"]


@nb.njit(**KERNEL, inline="always")
def _contact_values(ex, ey, exd, eyd, clearance, mode, dmin, stiffness, restitution, model):
    """The gap (delta, deltadot, n), 1 / |e|, the contact force F of the law (zero in free
    flight, mode 0) and its partial derivatives (d delta, d deltadot, d impact velocity, d
    stiffness, d restitution)."""
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
    return delta, deltadot, nx, ny, rinv, f, f_d, f_dd, f_dm, f_k, f_e


@nb.njit(**KERNEL, inline="always")
def _contact_direction(dex, dey, dexd, deyd, dcl, dk, de, ddm, exd, eyd, nx, ny, rinv, f,
                       f_d, f_dd, f_dm, f_k, f_e):
    """Derivatives of (delta, deltadot, F, F n_x, F n_y) along one direction, from those of
    the offset (dex, dey), its rate (dexd, deyd) and the law's parameters (clearance,
    stiffness, restitution, impact velocity): delta = |e| - c, deltadot = n . edot."""
    d_delta = nx * dex + ny * dey - dcl
    dnx = (ny * ny * dex - nx * ny * dey) * rinv
    dny = (nx * nx * dey - nx * ny * dex) * rinv
    d_rate = exd * dnx + eyd * dny + nx * dexd + ny * deyd
    d_f = f_d * d_delta + f_dd * d_rate + f_dm * ddm + f_k * dk + f_e * de
    return d_delta, d_rate, d_f, nx * d_f + f * dnx, ny * d_f + f * dny


@nb.njit(**KERNEL, inline="always")
def _contact_write(jac, stride, vc, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, r_fx, r_fy,
                   ex, ey, exd, eyd, delta, deltadot, f, nx, ny):
    """The values (column vc) of one clearance joint's rows; returns (fx, fy) = F n."""
    fx = f * nx
    fy = f * ny
    jac[r_f * stride + vc] = f
    jac[r_pen * stride + vc] = delta
    jac[r_rate * stride + vc] = deltadot
    jac[r_ex * stride + vc] = ex
    jac[r_ey * stride + vc] = ey
    jac[r_exd * stride + vc] = exd
    jac[r_eyd * stride + vc] = eyd
    jac[r_fx * stride + vc] = fx
    jac[r_fy * stride + vc] = fy
    return fx, fy


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
    delta, deltadot, nx, ny, rinv, f, f_d, f_dd, f_dm, f_k, f_e = _contact_values(
        ex, ey, exd, eyd, clearance, mode, dmin, stiffness, restitution, model)
    for col in range(nz):
        d_delta, d_rate, d_f, d_fx, d_fy = _contact_direction(
            jac[r_ex * stride + col], jac[r_ey * stride + col], jac[r_exd * stride + col],
            jac[r_eyd * stride + col], 1.0 if col == c_clear else 0.0,
            1.0 if col == c_stiff else 0.0, 1.0 if col == c_rest else 0.0,
            1.0 if col == c_dmin else 0.0, exd, eyd, nx, ny, rinv, f, f_d, f_dd, f_dm, f_k,
            f_e)
        jac[r_pen * stride + col] = d_delta
        jac[r_rate * stride + col] = d_rate
        jac[r_f * stride + col] = d_f
        jac[r_fx * stride + col] = d_fx
        jac[r_fy * stride + col] = d_fy
    return _contact_write(jac, stride, nz, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, r_fx,
                          r_fy, ex, ey, exd, eyd, delta, deltadot, f, nx, ny)


@nb.njit(**KERNEL, inline="always")
def contact_tangent(out, ts, nd, dz, nz, ex, ey, exd, eyd, r_f, r_pen, r_rate, r_ex, r_ey,
                    r_exd, r_eyd, r_fx, r_fy, c_clear, c_stiff, c_rest, c_dmin, clearance, mode,
                    dmin, stiffness, restitution, model):
    """`contact_jacobian` along nd seed directions dz (nd x nz, flat) instead of every
    column: the rows of out (ts = nd + 1 per row, column nd the value) hold the offset's
    and its rate's derivatives along each direction; the law's parameters enter through
    their seeds dz[d, c_*]. Returns (fx, fy)."""
    delta, deltadot, nx, ny, rinv, f, f_d, f_dd, f_dm, f_k, f_e = _contact_values(
        ex, ey, exd, eyd, clearance, mode, dmin, stiffness, restitution, model)
    for d in range(nd):
        o = d * nz
        d_delta, d_rate, d_f, d_fx, d_fy = _contact_direction(
            out[r_ex * ts + d], out[r_ey * ts + d], out[r_exd * ts + d], out[r_eyd * ts + d],
            dz[o + c_clear], dz[o + c_stiff], dz[o + c_rest], dz[o + c_dmin], exd, eyd, nx,
            ny, rinv, f, f_d, f_dd, f_dm, f_k, f_e)
        out[r_pen * ts + d] = d_delta
        out[r_rate * ts + d] = d_rate
        out[r_f * ts + d] = d_f
        out[r_fx * ts + d] = d_fx
        out[r_fy * ts + d] = d_fy
    return _contact_write(out, ts, nd, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, r_fx,
                          r_fy, ex, ey, exd, eyd, delta, deltadot, f, nx, ny)


@nb.njit(**KERNEL, inline="always")
def _friction_values(jac, stride, vc, spin, r_ex, r_ey, r_exd, r_eyd, r_f, law, slots):
    """From the values (column vc) of the offset, its rate and the normal force: n, 1 / |e|,
    the slip velocity vt = edot . t + spin (t = (-n_y, n_x)), the friction force Ft of the
    law and its partials (in vt, the normal force and each of the law's `slots`)."""
    ex = jac[r_ex * stride + vc]
    ey = jac[r_ey * stride + vc]
    exd = jac[r_exd * stride + vc]
    eyd = jac[r_eyd * stride + vc]
    f = jac[r_f * stride + vc]
    r, _, nx, ny = gap_state(ex, ey, exd, eyd, 0.0)
    rinv = 1.0 / r if r > 1e-300 else 0.0
    vt = eyd * nx - exd * ny + spin
    ft, ft_vt, ft_fn, ft_slots = friction_force_partials_slots(vt, f, slots, int(law))
    return exd, eyd, nx, ny, rinv, vt, ft, ft_vt, ft_fn, ft_slots


@nb.njit(**KERNEL, inline="always")
def _friction_direction(dex, dey, dexd, deyd, dspin, dfn, dlaw, exd, eyd, nx, ny, rinv, vt,
                        ft, ft_vt, ft_fn):
    """Derivatives of (vt, Ft, the power -Ft vt, and the additions -Ft t to the force on the
    bearing (x, y)) along one direction; dlaw: the derivative of Ft through the law's
    parameters along it."""
    dnx = (ny * ny * dex - nx * ny * dey) * rinv
    dny = (nx * nx * dey - nx * ny * dex) * rinv
    d_vt = dexd * (-ny) - exd * dny + deyd * nx + eyd * dnx + dspin
    d_ft = ft_vt * d_vt + ft_fn * dfn + dlaw
    return d_vt, d_ft, -(d_ft * vt + ft * d_vt), d_ft * ny + ft * dny, -(d_ft * nx + ft * dnx)


@nb.njit(**KERNEL, inline="always")
def _friction_write(jac, stride, vc, spin, r_spin, r_fx, r_fy, r_ft, r_vt, r_pw, nx, ny, vt,
                    ft):
    """The values (column vc) of one joint's friction rows; returns (fx, fy, Ft)."""
    fx = jac[r_fx * stride + vc] + ft * ny
    fy = jac[r_fy * stride + vc] - ft * nx
    jac[r_fx * stride + vc] = fx
    jac[r_fy * stride + vc] = fy
    jac[r_spin * stride + vc] = spin
    jac[r_vt * stride + vc] = vt
    jac[r_ft * stride + vc] = ft
    jac[r_pw * stride + vc] = -ft * vt
    return fx, fy, ft


@nb.njit(**KERNEL, inline="always")
def friction_jacobian(jac, stride, nz, spin, r_ex, r_ey, r_exd, r_eyd, r_spin, r_f, r_fx,
                      r_fy, r_ft, r_vt, r_pw, cols, law, slots):
    """Rows of one clearance joint's friction in the Jacobian, after `contact_jacobian` has
    filled its rows (values and total derivatives of the offset, its rate and the normal
    force F): the slip velocity vt = edot . t + spin (t = (-n_y, n_x); the spin's row holds
    the derivatives of omega_J R_J - omega_B R_B), the friction force Ft of the law
    (its partials; `cols` the columns of the law's `slots`), the friction power
    -Ft vt, and -Ft t added to the force on the bearing (rows fx, fy), as
    `runtime.friction_stage`. Returns (fx, fy, Ft)."""
    exd, eyd, nx, ny, rinv, vt, ft, ft_vt, ft_fn, ft_slots = _friction_values(
        jac, stride, nz, spin, r_ex, r_ey, r_exd, r_eyd, r_f, law, slots)
    for col in range(nz):
        dlaw = 0.0
        for k in range(len(cols)):
            if col == cols[k]:
                dlaw += ft_slots[k]
        d_vt, d_ft, d_pw, d_fx, d_fy = _friction_direction(
            jac[r_ex * stride + col], jac[r_ey * stride + col], jac[r_exd * stride + col],
            jac[r_eyd * stride + col], jac[r_spin * stride + col], jac[r_f * stride + col],
            dlaw, exd, eyd, nx, ny, rinv, vt, ft, ft_vt, ft_fn)
        jac[r_vt * stride + col] = d_vt
        jac[r_ft * stride + col] = d_ft
        jac[r_pw * stride + col] = d_pw
        jac[r_fx * stride + col] += d_fx
        jac[r_fy * stride + col] += d_fy
    return _friction_write(jac, stride, nz, spin, r_spin, r_fx, r_fy, r_ft, r_vt, r_pw, nx, ny,
                           vt, ft)


@nb.njit(**KERNEL, inline="always")
def friction_tangent(out, ts, nd, dz, nz, spin, r_ex, r_ey, r_exd, r_eyd, r_spin, r_f, r_fx,
                     r_fy, r_ft, r_vt, r_pw, cols, law, slots):
    """`friction_jacobian` along nd seed directions dz (nd x nz, flat), after
    `contact_tangent` (rows of out: ts = nd + 1 per row, column nd the value). Returns
    (fx, fy, Ft)."""
    exd, eyd, nx, ny, rinv, vt, ft, ft_vt, ft_fn, ft_slots = _friction_values(
        out, ts, nd, spin, r_ex, r_ey, r_exd, r_eyd, r_f, law, slots)
    for d in range(nd):
        o = d * nz
        dlaw = 0.0
        for k in range(len(cols)):
            dlaw += ft_slots[k] * dz[o + cols[k]]
        d_vt, d_ft, d_pw, d_fx, d_fy = _friction_direction(
            out[r_ex * ts + d], out[r_ey * ts + d], out[r_exd * ts + d], out[r_eyd * ts + d],
            out[r_spin * ts + d], out[r_f * ts + d], dlaw, exd, eyd, nx, ny, rinv, vt, ft,
            ft_vt, ft_fn)
        out[r_vt * ts + d] = d_vt
        out[r_ft * ts + d] = d_ft
        out[r_pw * ts + d] = d_pw
        out[r_fx * ts + d] += d_fx
        out[r_fy * ts + d] += d_fy
    return _friction_write(out, ts, nd, spin, r_spin, r_fx, r_fy, r_ft, r_vt, r_pw, nx, ny, vt,
                           ft)


@nb.njit(**KERNEL, inline="always")
def _corner_values(h, hd, side, clearance, half_height, mode, dmin, stiffness, restitution,
                   model):
    """A corner's penetration and rate (`runtime.corner_state`), the contact force F of the
    law (zero in free flight, mode 0) and its partials (d delta, d deltadot, d impact
    velocity, d stiffness, d restitution)."""
    delta, deltadot = corner_state(h, hd, side, clearance, half_height)
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
    return delta, deltadot, f, f_d, f_dd, f_dm, f_k, f_e


@nb.njit(**KERNEL, inline="always")
def _corner_write(jac, stride, vc, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, r_fn, ex, h,
                  exd, hd, delta, deltadot, f, side):
    """The values (column vc) of one corner's rows; returns fn = -side F."""
    jac[r_f * stride + vc] = f
    jac[r_pen * stride + vc] = delta
    jac[r_rate * stride + vc] = deltadot
    jac[r_ex * stride + vc] = ex
    jac[r_ey * stride + vc] = h
    jac[r_exd * stride + vc] = exd
    jac[r_eyd * stride + vc] = hd
    jac[r_fn * stride + vc] = -side * f
    return -side * f


@nb.njit(**KERNEL, inline="always")
def corner_jacobian(jac, stride, nz, ex, h, exd, hd, r_f, r_pen, r_rate, r_ex, r_ey, r_exd,
                    r_eyd, r_fn, c_clear, c_half, c_stiff, c_rest, c_dmin, side, clearance,
                    half_height, mode, dmin, stiffness, restitution, model):
    """Rows of one corner of a translational clearance joint in the Jacobian, after the
    gap stage has filled the derivatives of its position along the guide's axis (ex), its
    normal offset h (ey) and their rates: the penetration delta = side h - (b + c), its rate
    side hdot, the contact force F of the law and the normal force on the slider
    fn = -side F (row r_fn), as `runtime.corner_stage`, with the parameters that enter
    directly (columns of the clearance, half-height, stiffness, restitution and the impact
    velocity). Returns fn."""
    delta, deltadot, f, f_d, f_dd, f_dm, f_k, f_e = _corner_values(
        h, hd, side, clearance, half_height, mode, dmin, stiffness, restitution, model)
    for col in range(nz):
        d_delta = side * jac[r_ey * stride + col]
        if col == c_clear or col == c_half:
            d_delta -= 1.0
        d_rate = side * jac[r_eyd * stride + col]
        d_f = f_d * d_delta + f_dd * d_rate
        if col == c_dmin:
            d_f += f_dm
        if col == c_stiff:
            d_f += f_k
        if col == c_rest:
            d_f += f_e
        jac[r_pen * stride + col] = d_delta
        jac[r_rate * stride + col] = d_rate
        jac[r_f * stride + col] = d_f
        jac[r_fn * stride + col] = -side * d_f
    return _corner_write(jac, stride, nz, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, r_fn,
                         ex, h, exd, hd, delta, deltadot, f, side)


@nb.njit(**KERNEL, inline="always")
def corner_tangent(out, ts, nd, dz, nz, ex, h, exd, hd, r_f, r_pen, r_rate, r_ex, r_ey, r_exd,
                   r_eyd, r_fn, c_clear, c_half, c_stiff, c_rest, c_dmin, side, clearance,
                   half_height, mode, dmin, stiffness, restitution, model):
    """`corner_jacobian` along nd seed directions dz (nd x nz, flat): rows of out (ts =
    nd + 1 per row, column nd the value). Returns fn."""
    delta, deltadot, f, f_d, f_dd, f_dm, f_k, f_e = _corner_values(
        h, hd, side, clearance, half_height, mode, dmin, stiffness, restitution, model)
    for d in range(nd):
        o = d * nz
        d_delta = side * out[r_ey * ts + d] - dz[o + c_clear] - dz[o + c_half]
        d_rate = side * out[r_eyd * ts + d]
        d_f = (f_d * d_delta + f_dd * d_rate + f_dm * dz[o + c_dmin] + f_k * dz[o + c_stiff]
               + f_e * dz[o + c_rest])
        out[r_pen * ts + d] = d_delta
        out[r_rate * ts + d] = d_rate
        out[r_f * ts + d] = d_f
        out[r_fn * ts + d] = -side * d_f
    return _corner_write(out, ts, nd, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, r_fn, ex,
                         h, exd, hd, delta, deltadot, f, side)


@nb.njit(**KERNEL, inline="always")
def _corner_friction_write(jac, stride, vc, r_ft, r_vt, r_pw, vt, ft):
    """The values (column vc) of one corner's friction rows; returns Ft."""
    jac[r_ft * stride + vc] = ft
    jac[r_vt * stride + vc] = vt
    jac[r_pw * stride + vc] = -ft * vt
    return ft


@nb.njit(**KERNEL, inline="always")
def corner_friction_jacobian(jac, stride, nz, r_exd, r_f, r_ft, r_vt, r_pw, cols, law, slots):
    """Rows of one corner's friction in the Jacobian, after `corner_jacobian`: the friction
    force Ft of the law on the slider along the guide's axis at the sliding velocity vt
    (the rate of the corner's axial position, row r_exd) and the normal force F (row r_f),
    its partials (`cols` the columns of the law's `slots`), the slip velocity and the power
    -Ft vt, as `runtime.corner_friction_stage`. Returns Ft."""
    vt = jac[r_exd * stride + nz]
    ft, ft_vt, ft_fn, ft_slots = friction_force_partials_slots(
        vt, jac[r_f * stride + nz], slots, int(law))
    for col in range(nz):
        d_vt = jac[r_exd * stride + col]
        d_ft = ft_vt * d_vt + ft_fn * jac[r_f * stride + col]
        for k in range(len(cols)):
            if col == cols[k]:
                d_ft += ft_slots[k]
        jac[r_vt * stride + col] = d_vt
        jac[r_ft * stride + col] = d_ft
        jac[r_pw * stride + col] = -(d_ft * vt + ft * d_vt)
    return _corner_friction_write(jac, stride, nz, r_ft, r_vt, r_pw, vt, ft)


@nb.njit(**KERNEL, inline="always")
def corner_friction_tangent(out, ts, nd, dz, nz, r_exd, r_f, r_ft, r_vt, r_pw, cols, law,
                            slots):
    """`corner_friction_jacobian` along nd seed directions dz (nd x nz, flat), after
    `corner_tangent`. Returns Ft."""
    vt = out[r_exd * ts + nd]
    ft, ft_vt, ft_fn, ft_slots = friction_force_partials_slots(
        vt, out[r_f * ts + nd], slots, int(law))
    for d in range(nd):
        o = d * nz
        d_vt = out[r_exd * ts + d]
        d_ft = ft_vt * d_vt + ft_fn * out[r_f * ts + d]
        for k in range(len(cols)):
            d_ft += ft_slots[k] * dz[o + cols[k]]
        out[r_vt * ts + d] = d_vt
        out[r_ft * ts + d] = d_ft
        out[r_pw * ts + d] = -(d_ft * vt + ft * d_vt)
    return _corner_friction_write(out, ts, nd, r_ft, r_vt, r_pw, vt, ft)


@nb.njit(**KERNEL)
def _film_rows(jac, stride, col, r_fx, r_fy, r_ffx, r_ffy, r_tj, r_tb, r_pw, d):
    """One column of the film's rows from d (Fx, Fy, T_J, T_B, power), d's force taken off
    the force on the bearing's column."""
    jac[r_ffx * stride + col] = d[0]
    jac[r_ffy * stride + col] = d[1]
    jac[r_tj * stride + col] = d[2]
    jac[r_tb * stride + col] = d[3]
    jac[r_pw * stride + col] = d[4]
    jac[r_fx * stride + col] -= d[0]
    jac[r_fy * stride + col] -= d[1]


@nb.njit(**KERNEL)
def _film_write(jac, stride, vc, r_fx, r_fy, r_ffx, r_ffy, r_tj, r_tb, r_pw, values):
    """The values (column vc) of one lubricated joint's film rows (Fx, Fy, T_J, T_B,
    power), the film's force taken off the force on the bearing (rows fx, fy); returns
    (fx, fy, T_J, T_B)."""
    _film_rows(jac, stride, vc, r_fx, r_fy, r_ffx, r_ffy, r_tj, r_tb, r_pw, values)
    return jac[r_fx * stride + vc], jac[r_fy * stride + vc], values[2], values[3]


@nb.njit(**KERNEL)
def _film_state(jac, stride, vc, wj, wb, r_ex, r_ey, r_exd, r_eyd, r_wj, r_wb, radius,
                clearance, length, viscosity, model, start, end):
    """The film's inputs (the offset and its rate from their rows' values, column vc; the
    angular velocities wj, wb, written there) and `film_values` of them."""
    ex, ey = jac[r_ex * stride + vc], jac[r_ey * stride + vc]
    exd, eyd = jac[r_exd * stride + vc], jac[r_eyd * stride + vc]
    jac[r_wj * stride + vc] = wj
    jac[r_wb * stride + vc] = wb
    active, ends, w, dw, fx, fy, tj, tb, pw = film_values(
        ex, ey, exd, eyd, wj, wb, radius, clearance, length, viscosity, int(model), start,
        end)
    return ex, ey, exd, eyd, wj, wb, active, ends, w, dw, fx, fy, tj, tb, pw


@nb.njit(**KERNEL)
def film_jacobian(jac, stride, nz, wj, wb, r_ex, r_ey, r_exd, r_eyd, r_wj, r_wb, r_fx, r_fy, r_ffx,
                  r_ffy, r_tj, r_tb, r_pw, c_r, c_c, c_l, c_mu, c_s, c_e, radius, clearance,
                  length, viscosity, model, start, end):
    """Rows of one lubricated joint's oil film in the Jacobian, after `contact_jacobian`
    has filled the joint's rows: from the rows of the offset, its rate and the bodies'
    angular velocities (values wj, wb; their rows hold their derivatives) and the film's
    parameters (columns of the journal radius,
    clearance, bearing length, viscosity and the fade's ends), the film's force on the
    journal (rows ffx, ffy, taken off the force on the bearing, rows fx, fy), its torques
    on the journal and on the bearing and its power (`laws.lubrication.partials`), as
    `runtime.lubricated_stage` (film law id `model`; derivatives NaN for a law without
    partials, `laws.lubrication.partials.DIFFERENTIABLE`). Returns (fx, fy, T_J, T_B)."""
    vc = nz
    ex, ey, exd, eyd, wj, wb, active, ends, w, dw, fx, fy, tj, tb, pw = _film_state(
        jac, stride, vc, wj, wb, r_ex, r_ey, r_exd, r_eyd, r_wj, r_wb, radius, clearance,
        length, viscosity, model, start, end)
    if active:
        for col in range(nz):
            dr = 1.0 if col == c_r else 0.0
            dc = 1.0 if col == c_c else 0.0
            dl = 1.0 if col == c_l else 0.0
            dmu = 1.0 if col == c_mu else 0.0
            ds = 1.0 if col == c_s else 0.0
            de = 1.0 if col == c_e else 0.0
            d = film_direction(
                ex, ey, exd, eyd, wj, wb, radius, clearance, length, viscosity, int(model),
                start, end, ends, w, dw, fx, fy, tj, jac[r_ex * stride + col],
                jac[r_ey * stride + col],
                jac[r_exd * stride + col], jac[r_eyd * stride + col],
                jac[r_wj * stride + col], jac[r_wb * stride + col], dr, dc, dl, dmu, ds, de)
            _film_rows(jac, stride, col, r_fx, r_fy, r_ffx, r_ffy, r_tj, r_tb, r_pw, d)
    return _film_write(jac, stride, vc, r_fx, r_fy, r_ffx, r_ffy, r_tj, r_tb, r_pw,
                       (fx, fy, tj, tb, pw))


@nb.njit(**KERNEL)
def film_tangent(out, ts, nd, dz, nz, wj, wb, r_ex, r_ey, r_exd, r_eyd, r_wj, r_wb, r_fx, r_fy,
                 r_ffx, r_ffy, r_tj, r_tb, r_pw, c_r, c_c, c_l, c_mu, c_s, c_e, radius,
                 clearance, length, viscosity, model, start, end):
    """`film_jacobian` along nd seed directions dz (nd x nz, flat), after `contact_tangent`
    (rows of out: ts = nd + 1 per row, column nd the value). Returns (fx, fy, T_J, T_B)."""
    ex, ey, exd, eyd, wj, wb, active, ends, w, dw, fx, fy, tj, tb, pw = _film_state(
        out, ts, nd, wj, wb, r_ex, r_ey, r_exd, r_eyd, r_wj, r_wb, radius, clearance,
        length, viscosity, model, start, end)
    for d in range(nd):
        o = d * nz
        if active:
            der = film_direction(
                ex, ey, exd, eyd, wj, wb, radius, clearance, length, viscosity, int(model),
                start, end, ends, w, dw, fx, fy, tj, out[r_ex * ts + d], out[r_ey * ts + d],
                out[r_exd * ts + d], out[r_eyd * ts + d], out[r_wj * ts + d],
                out[r_wb * ts + d], dz[o + c_r], dz[o + c_c], dz[o + c_l], dz[o + c_mu],
                dz[o + c_s], dz[o + c_e])
        else:
            der = (0.0, 0.0, 0.0, 0.0, 0.0)
        _film_rows(out, ts, d, r_fx, r_fy, r_ffx, r_ffy, r_tj, r_tb, r_pw, der)
    return _film_write(out, ts, nd, r_fx, r_fy, r_ffx, r_ffy, r_tj, r_tb, r_pw,
                       (fx, fy, tj, tb, pw))


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
def work_offsets(nb_, w0, nz, n_jrows, n_joints):
    """Starts of the work space's parts: the Jacobian (n_jrows (nz + 1)), the seeds
    (nb nz), which seeds use each column (`seed_index`: nz + 1 + nb nz), the chain's part
    of the seeds at the memories' columns (nb J), the tangents (n_jrows (nb + 1)), the
    plain monitor's derivative."""
    dz0 = w0 + n_jrows * (nz + 1)
    use0 = dz0 + nb_ * nz
    mb0 = use0 + nz + 1 + nb_ * nz
    t0 = mb0 + nb_ * n_joints
    return dz0, use0, mb0, t0, t0 + n_jrows * (nb_ + 1)


def work_size(nb_: int, nz: int, n_jrows: int, n_q: int, n_joints: int) -> int:
    """Entries of a sensitivity run's work space (see `work_offsets`)."""
    return (n_jrows * (nz + 1) + nb_ * nz + nz + 1 + nb_ * nz + nb_ * n_joints
            + n_jrows * (nb_ + 1) + 2 * n_q + 1)


@nb.njit(error_model="numpy")
def seed_index(nonzero, use):
    """Which seeds use each column of z, as the generated `tangent` reads it: for column k
    the seeds use[nz + 1 + e], e in [use[k], use[k + 1]) (nonzero: (nd, nz) booleans)."""
    nd, nz = nonzero.shape
    e = 0
    for k in range(nz):
        use[k] = e
        for d in range(nd):
            if nonzero[d, k]:
                use[nz + 1 + e] = d
                e += 1
    use[nz] = e


def fill_seed_work(work, entries, nz: int, n_jrows: int, n_q: int, mem_col0: int,
                   n_joints: int):
    """The constant part of the seeds in a sensitivity run's work space (laid out as
    `work_offsets` with w0 = 0): the chains D_k (entries[k]: {column of z: value}) into the
    seeds' parameter columns, the columns used, and the chains' values at the memories'
    columns (`seed_directions` adds sigma_k there in each call)."""
    nb_ = len(entries)
    dz0, use0, mb0, _, _ = work_offsets(nb_, 0, nz, n_jrows, n_joints)
    nonzero = np.zeros((nb_, nz), dtype=np.bool_)
    nonzero[:, 1:1 + 2 * n_q] = True
    mem_cols = [mem_col0 + 2 * j for j in range(n_joints)]
    nonzero[:, mem_cols] = True
    for k, ent in enumerate(entries):
        for c, v in ent.items():
            work[dz0 + k * nz + c] += v
            nonzero[k, c] = True
        for j, c in enumerate(mem_cols):
            work[mb0 + k * n_joints + j] = work[dz0 + k * nz + c]
    seed_index(nonzero, work[use0:mb0])


@nb.njit(**KERNEL, inline="always")
def seed_directions(dz, membase, y, nb_, n2, nz, mem_col0, n_joints):
    """The seeds dz_k = [0, s_k, D_k + sigma_k] (nb x nz, flat) of the integrated directions
    for this call, at the memories' columns: the chain's part (membase) plus sigma_k. The
    chain's other columns are constant (`fill_seed_work`); the generated `tangent` reads
    the state part s_k from y[n2 (1 + k):] itself."""
    wpos = n2 * (1 + nb_)
    for k in range(nb_):
        o = k * nz
        sig = wpos + 1 + k * n_joints
        for j in range(n_joints):
            dz[o + mem_col0 + 2 * j] = membase[k * n_joints + j] + y[sig + j]


@nb.njit(**KERNEL, inline="always")
def sens_rhs(tangent, rhs, t, y, p, dydt, n_q, n_p, nz, n_jrows, acc_row, mom_row, speed,
             mem_col0, n_joints, full):
    """The state, sensitivity and work derivatives, from the model's `tangent` along the
    integrated directions (`seed_directions`; with `full` every row of the tangent, the
    outputs' too, in the work space); for the truncated state y[:2 N_Q] (the integrator's
    continuous extension) the plain model's."""
    n2 = 2 * n_q
    nb_, m, c0, v0, w0 = ddm_layout(p, n_p)
    if y.shape[0] < n2 * (1 + nb_) + 1 + nb_ * n_joints:
        rhs(t, y, p, dydt)
        return
    dz0, use0, mb0, t0, ws = work_offsets(nb_, w0, nz, n_jrows, n_joints)
    ts = nb_ + 1
    dz = p[dz0:use0]
    out = p[t0:ws]
    seed_directions(dz, p[mb0:t0], y, nb_, n2, nz, mem_col0, n_joints)
    tangent(t, y, p, dz, nb_, p[use0:mb0], out, full)
    for i in range(n_q):
        dydt[i] = y[n_q + i]
        dydt[n_q + i] = out[(acc_row + i) * ts + nb_]
    wpos = n2 * (1 + nb_)
    # the drive's work rate (a free linkage, mom_row < 0: no drive, no work)
    dydt[wpos] = out[mom_row * ts + nb_] * p[speed] if mom_row >= 0 else 0.0
    for k in range(nb_):
        base = n2 * (1 + k)
        sig = wpos + 1 + k * n_joints
        for i in range(n_q):
            dydt[base + i] = y[base + n_q + i]
            dydt[base + n_q + i] = out[(acc_row + i) * ts + k]
        for j in range(n_joints):
            dydt[sig + j] = 0.0


@nb.njit(**KERNEL, inline="always")
def sens_on_event(jacobian, on_event, t, y, p, j, n_q, n_p, nz, n_jrows, mem_start, pen_row,
                  rate_row, joint_rows, acc_row, floor0, contact_stride, mem_col0, n_joints):
    """`sens_on_event_at` with joint j's impact-velocity floor at p[floor0 + contact_stride
    j] (the clearance joints' contact fields, one block each)."""
    sens_on_event_at(jacobian, on_event, t, y, p, j, n_q, n_p, nz, n_jrows, mem_start,
                     pen_row, rate_row, joint_rows, acc_row, floor0 + contact_stride * j,
                     mem_col0, n_joints)


@nb.njit(**KERNEL, inline="always")
def sens_on_event_at(jacobian, on_event, t, y, p, j, n_q, n_p, nz, n_jrows, mem_start,
                     pen_row, rate_row, joint_rows, acc_row, floor_index, mem_col0, n_joints):
    """Switch contact j's mode (the plain model's `on_event`); at a contact onset also the
    sensitivity of its impact-velocity memory, with the event-time term:
    sigma_k = d(deltadot)/db_k + deltadotdot dt_e/db_k, dt_e/db_k = -(d delta/db_k) / deltadot
    (or d(floor)/db_k when the floor, p[floor_index], applies). The state sensitivities do
    not jump: the contact force is zero at delta = 0 in both modes."""
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
    floor = p[floor_index]
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
        col = 1 + n2 + floor_index
        for k in range(nb_):
            v = 0.0
            for e in range(k * m, (k + 1) * m):
                if int(p[c0 + e]) == col:
                    v += p[v0 + e]
            y[wpos + 1 + k * n_joints + j] = v


@nb.njit(**KERNEL, inline="always")
def sens_monitor(tangent, rhs, monitor, observe, t, y, p, dydt, out, g, gd, n_q, n_p, nz,
                 n_jrows, acc_row, mom_row, speed, mem_col0, n_joints, n_out):
    """`sens_rhs`, then the plain model's monitor on the state (outputs into out[:n_out],
    switching functions, the monitored value), its derivative into work space. An `out`
    longer than n_out records derivatives of outputs too, those of the first
    (len(out) - n_out) / nb columns listed after the work space (`pack_sensitivity_
    parameters`'s record columns): out[n_out + i nb + k] that of the i-th along direction
    k; the tangent then computes every row (full), and the monitor's values come from its
    value column (the model's `observe`) instead of another evaluation of the model."""
    full = out.shape[0] > n_out
    sens_rhs(tangent, rhs, t, y, p, dydt, n_q, n_p, nz, n_jrows, acc_row, mom_row, speed,
             mem_col0, n_joints, full)
    n2 = 2 * n_q
    nb_, _, _, _, w0 = ddm_layout(p, n_p)
    _, _, _, t0, ws = work_offsets(nb_, w0, nz, n_jrows, n_joints)
    if not full or y.shape[0] <= n2:
        return monitor(t, y[:n2], p, p[ws:ws + n2], out, g, gd)
    st = nb_ + 1
    m = observe(p, p[t0 + nb_:ws:st], out, g, gd)
    rec0 = ws + n2 + 1
    for i in range((out.shape[0] - n_out) // nb_):
        r = int(p[rec0 + i])
        for k in range(nb_):
            out[n_out + i * nb_ + k] = p[t0 + r * st + k]
    return m


@nb.njit(error_model="numpy")
def sens_outputs(tangent, ts, ys, ms, p, n_q, n_p, nz, n_jrows, n_out, mem_start, mem_col0,
                 n_joints):
    """Values (n, n_out) and total derivatives (n, n_out, nb) of the outputs (the first
    n_out rows of the Jacobian) along the integrated directions at recorded steps (times
    ts, sensitivity states ys, memories ms): the model's `tangent` (full) along each
    step's seeds."""
    n2 = 2 * n_q
    q = p.copy()
    nb_, _, _, _, w0 = ddm_layout(q, n_p)
    dz0, use0, mb0, t0, ws = work_offsets(nb_, w0, nz, n_jrows, n_joints)
    st = nb_ + 1
    n = ts.shape[0]
    vals = np.empty((n, n_out))
    ders = np.empty((n, n_out, nb_))
    for i in range(n):
        for k in range(ms.shape[1]):
            q[mem_start + k] = ms[i, k]
        y = ys[i]
        seed_directions(q[dz0:use0], q[mb0:t0], y, nb_, n2, nz, mem_col0, n_joints)
        out = q[t0:ws]
        tangent(ts[i], y, q, q[dz0:use0], nb_, q[use0:mb0], out, True)
        for r in range(n_out):
            vals[i, r] = out[r * st + nb_]
            for k in range(nb_):
                ders[i, r, k] = out[r * st + k]
    return vals, ders


@nb.njit(error_model="numpy")
def jacobian_at(jacobian, t, y, p, n_jrows, nz, full):
    """The Jacobian (n_jrows, nz + 1) at (t, y) (tests, initial sensitivities)."""
    jac = np.zeros(n_jrows * (nz + 1))
    jacobian(t, y, p, jac, full)
    return jac.reshape((n_jrows, nz + 1))


@nb.njit(error_model="numpy")
def tangent_at(tangent, t, y, p, dz, n_jrows, n_q, full):
    """The tangents (n_jrows, nd + 1) at (t, y) along the seeds dz (nd, nz) (tests): the
    seeds' state columns (1 .. 2 N_Q) passed as state sensitivities after y[:2 N_Q], where
    the generated `tangent` reads them."""
    nd = dz.shape[0]
    n2 = 2 * n_q
    out = np.zeros(n_jrows * (nd + 1))
    use = np.zeros(dz.shape[1] + 1 + dz.size)
    seed_index(dz != 0.0, use)
    ys = np.empty(n2 * (1 + nd))
    ys[:n2] = y[:n2]
    for d in range(nd):
        ys[n2 * (1 + d):n2 * (2 + d)] = dz[d, 1:1 + n2]
    tangent(t, ys, p, np.ascontiguousarray(dz).ravel(), nd, use, out, full)
    return out.reshape((n_jrows, nd + 1))


# ------------------------------------------------------------- the step map (objective.py)

@nb.njit(error_model="numpy")
def step_peaks(rhs, monitor, t0s, y0s, mems, p, hs, coefficients, iters, mem_start,
               n_events):
    """The maximum of the monitored value over the plain step map of each step k (start
    t0s[k], state y0s[k], memories mems[k] (N_MEM), size hs[k]), by golden section as the
    integrator's peak refinement; returns values and times."""
    A, B, C = coefficients[0], coefficients[1], coefficients[2]
    n = y0s.shape[1]
    K, y_new, f_new, ytmp, f0, g, gd = step_workspace(coefficients, n, n_events)
    y0 = np.empty(n)
    out = np.zeros(0)
    q = p.copy()
    vals = np.empty(t0s.shape[0])
    times = np.empty(t0s.shape[0])
    for k in range(t0s.shape[0]):
        for j in range(n):
            y0[j] = y0s[k, j]
        for j in range(mems.shape[1]):
            q[mem_start + j] = mems[k, j]
        vals[k], times[k] = _golden_max(rhs, monitor, t0s[k], y0, q, hs[k], A, B, C, K, y_new,
                                        f_new, ytmp, f0, iters, out, g, gd)
    return vals, times


@nb.njit(error_model="numpy")
def step_value(rhs, monitor, t0, y0, mem, p, h, coefficients, mem_start, n_events):
    """The monitored value of the plain step map at t0 + h (state y0, memories mem)."""
    A, B, C = coefficients[0], coefficients[1], coefficients[2]
    K, y_new, f_new, ytmp, f0, g, gd = step_workspace(coefficients, y0.shape[0], n_events)
    q = p.copy()
    for j in range(mem.shape[0]):
        q[mem_start + j] = mem[j]
    rhs(t0, y0, q, f0)
    return _step_monitor(rhs, monitor, t0, y0, f0, h, A, B, C, K, q, y_new, f_new, ytmp,
                         np.zeros(0), g, gd)


@nb.njit(error_model="numpy")
def step_states(rhs_sens, monitor_sens, t0, y0, p, hs, coefficients, n_out, n_events):
    """Steps of the sizes hs of the sensitivity equations from (t0, y0), the memories in p:
    the states (sensitivities included) at t0 + hs (len(hs), n) and the monitor's outputs
    there (len(hs), n_out). The integrator's peak refinement maximises the monitored value
    over exactly this step map, so this gives the state at a refined peak time."""
    A, B, C = coefficients[0], coefficients[1], coefficients[2]
    n = y0.shape[0]
    K, _, f_new, ytmp, f0, g, gd = step_workspace(coefficients, n, n_events)
    ys = np.empty((hs.shape[0], n))
    outs = np.zeros((hs.shape[0], n_out))
    rhs_sens(t0, y0, p, f0)
    for k in range(hs.shape[0]):
        _step_monitor(rhs_sens, monitor_sens, t0, y0, f0, hs[k], A, B, C, K, p, ys[k], f_new,
                      ytmp, outs[k], g, gd)
    return ys, outs
