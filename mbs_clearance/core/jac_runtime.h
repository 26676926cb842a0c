/* What the generated Jacobian and tangent kernels call (generate/cjacobians.py): each element's
 * rows (a clearance joint's contact, its friction, a translational joint's corner and its
 * friction, a lubricated joint's oil film), the C twins of generate/sens_runtime.py's
 * functions of the same names, in the same order of operations. A row r of the Jacobian
 * jac (flat) holds jac[r * stride + col], the value in column nz; a row of the tangent out
 * holds out[r * ts + d] along seed d of dz (nd x nz, flat), the value in column nd. Tuples
 * are returned through pointers after the arguments. */
#ifndef MBS_JAC_RUNTIME_H
#define MBS_JAC_RUNTIME_H

#include <complex.h>
#include <math.h>
#include <stdint.h>

#include "laws_generated.h"
#include "runtime.h"

/* the contact law's force F (zero in free flight, mode 0) and its partials law[5] (d delta,
 * d deltadot, d impact velocity, d stiffness, d restitution; zero where F is) */
static inline void jac_law(double delta, double deltadot, double mode, double dmin,
                           double stiffness, double restitution, double model, double *f,
                           double *law) {
    *f = 0.0;
    for (int k = 0; k < 5; k++) law[k] = 0.0;
    if (mode > 0.5) {
        *f = mbs_contact_force(delta, deltadot, dmin, stiffness, restitution, (int64_t)model);
        if (*f > 0.0) {
            double d[6];
            mbs_contact_force_partials(delta, deltadot, dmin, stiffness, restitution,
                                       (int64_t)model, d);
            for (int k = 0; k < 5; k++) law[k] = d[k + 1];
        }
    }
}

/* ---- a clearance joint's contact */

/* the gap (delta, deltadot, n), 1 / |e|, the law's force F (zero in free flight, mode 0) and
 * its partials law[5] (d delta, d deltadot, d impact velocity, d stiffness, d restitution) */
static inline void jac_contact_values(double ex, double ey, double exd, double eyd,
                                      double clearance, double mode, double dmin,
                                      double stiffness, double restitution, double model,
                                      double *delta, double *deltadot, double *nx, double *ny,
                                      double *rinv, double *f, double *law) {
    gap_state(ex, ey, exd, eyd, clearance, delta, deltadot, nx, ny);
    double r = *delta + clearance;
    *rinv = r > 1e-300 ? 1.0 / r : 0.0;
    jac_law(*delta, *deltadot, mode, dmin, stiffness, restitution, model, f, law);
}

/* derivatives (delta, deltadot, F, F n_x, F n_y) along one direction into dv[5] */
static inline void jac_contact_direction(double dex, double dey, double dexd, double deyd,
                                         double dcl, double dk, double de, double ddm,
                                         double exd, double eyd, double nx, double ny,
                                         double rinv, double f, const double *law,
                                         double *dv) {
    double d_delta = nx * dex + ny * dey - dcl;
    double dnx = (ny * ny * dex - nx * ny * dey) * rinv;
    double dny = (nx * nx * dey - nx * ny * dex) * rinv;
    double d_rate = exd * dnx + eyd * dny + nx * dexd + ny * deyd;
    double d_f = law[0] * d_delta + law[1] * d_rate + law[2] * ddm + law[3] * dk + law[4] * de;
    dv[0] = d_delta;
    dv[1] = d_rate;
    dv[2] = d_f;
    dv[3] = nx * d_f + f * dnx;
    dv[4] = ny * d_f + f * dny;
}

/* the values (column vc) of a contact's rows: force, penetration and rate, the offset
 * and its rate */
static inline void jac_gap_values(double *jac, int64_t stride, int64_t vc, int64_t r_f,
                                  int64_t r_pen, int64_t r_rate, int64_t r_ex, int64_t r_ey,
                                  int64_t r_exd, int64_t r_eyd, double f, double delta,
                                  double deltadot, double ex, double ey, double exd,
                                  double eyd) {
    jac[r_f * stride + vc] = f;
    jac[r_pen * stride + vc] = delta;
    jac[r_rate * stride + vc] = deltadot;
    jac[r_ex * stride + vc] = ex;
    jac[r_ey * stride + vc] = ey;
    jac[r_exd * stride + vc] = exd;
    jac[r_eyd * stride + vc] = eyd;
}

/* one column of a joint's derivative rows (delta, deltadot, F, F n_x, F n_y) from dv */
static inline void jac_contact_rows(double *jac, int64_t stride, int64_t col, int64_t r_pen,
                                    int64_t r_rate, int64_t r_f, int64_t r_fx, int64_t r_fy,
                                    const double *dv) {
    jac[r_pen * stride + col] = dv[0];
    jac[r_rate * stride + col] = dv[1];
    jac[r_f * stride + col] = dv[2];
    jac[r_fx * stride + col] = dv[3];
    jac[r_fy * stride + col] = dv[4];
}

static inline void jac_contact_write(double *jac, int64_t stride, int64_t vc, int64_t r_f,
                                     int64_t r_pen, int64_t r_rate, int64_t r_ex, int64_t r_ey,
                                     int64_t r_exd, int64_t r_eyd, int64_t r_fx, int64_t r_fy,
                                     double ex, double ey, double exd, double eyd,
                                     double delta, double deltadot, double f, double nx,
                                     double ny, double *fx, double *fy) {
    *fx = f * nx;
    *fy = f * ny;
    jac_gap_values(jac, stride, vc, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, f, delta,
                   deltadot, ex, ey, exd, eyd);
    jac[r_fx * stride + vc] = *fx;
    jac[r_fy * stride + vc] = *fy;
}

/* rows of one clearance joint in the Jacobian (sens_runtime.contact_jacobian); (fx, fy) */
static inline void contact_jacobian(double *jac, int64_t stride, int64_t nz, double ex,
                                    double ey, double exd, double eyd, int64_t r_f,
                                    int64_t r_pen, int64_t r_rate, int64_t r_ex, int64_t r_ey,
                                    int64_t r_exd, int64_t r_eyd, int64_t r_fx, int64_t r_fy,
                                    int64_t c_clear, int64_t c_stiff, int64_t c_rest,
                                    int64_t c_dmin, double clearance, double mode, double dmin,
                                    double stiffness, double restitution, double model,
                                    double *fx, double *fy) {
    double delta, deltadot, nx, ny, rinv, f, law[5], dv[5];
    jac_contact_values(ex, ey, exd, eyd, clearance, mode, dmin, stiffness, restitution, model,
                       &delta, &deltadot, &nx, &ny, &rinv, &f, law);
    for (int64_t col = 0; col < nz; col++) {
        jac_contact_direction(jac[r_ex * stride + col], jac[r_ey * stride + col],
                              jac[r_exd * stride + col], jac[r_eyd * stride + col],
                              col == c_clear ? 1.0 : 0.0, col == c_stiff ? 1.0 : 0.0,
                              col == c_rest ? 1.0 : 0.0, col == c_dmin ? 1.0 : 0.0, exd, eyd,
                              nx, ny, rinv, f, law, dv);
        jac_contact_rows(jac, stride, col, r_pen, r_rate, r_f, r_fx, r_fy, dv);
    }
    jac_contact_write(jac, stride, nz, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, r_fx, r_fy,
                      ex, ey, exd, eyd, delta, deltadot, f, nx, ny, fx, fy);
}

/* contact_jacobian along nd seeds dz (sens_runtime.contact_tangent); (fx, fy) */
static inline void contact_tangent(double *out, int64_t ts, int64_t nd, const double *dz,
                                   int64_t nz, double ex, double ey, double exd, double eyd,
                                   int64_t r_f, int64_t r_pen, int64_t r_rate, int64_t r_ex,
                                   int64_t r_ey, int64_t r_exd, int64_t r_eyd, int64_t r_fx,
                                   int64_t r_fy, int64_t c_clear, int64_t c_stiff,
                                   int64_t c_rest, int64_t c_dmin, double clearance,
                                   double mode, double dmin, double stiffness,
                                   double restitution, double model, double *fx, double *fy) {
    double delta, deltadot, nx, ny, rinv, f, law[5], dv[5];
    jac_contact_values(ex, ey, exd, eyd, clearance, mode, dmin, stiffness, restitution, model,
                       &delta, &deltadot, &nx, &ny, &rinv, &f, law);
    for (int64_t d = 0; d < nd; d++) {
        int64_t o = d * nz;
        jac_contact_direction(out[r_ex * ts + d], out[r_ey * ts + d], out[r_exd * ts + d],
                              out[r_eyd * ts + d], dz[o + c_clear], dz[o + c_stiff],
                              dz[o + c_rest], dz[o + c_dmin], exd, eyd, nx, ny, rinv, f, law,
                              dv);
        jac_contact_rows(out, ts, d, r_pen, r_rate, r_f, r_fx, r_fy, dv);
    }
    jac_contact_write(out, ts, nd, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, r_fx, r_fy,
                      ex, ey, exd, eyd, delta, deltadot, f, nx, ny, fx, fy);
}

/* ---- a clearance joint's friction */

/* from the values (column vc): exd, eyd, n, 1 / |e|, vt = edot . t + spin, and the law's
 * d[3 + MBS_N_FRICTION_SLOTS] (Ft, dFt/dvt, dFt/dfn, dFt/dslots) */
static inline void jac_friction_values(const double *jac, int64_t stride, int64_t vc,
                                       double spin, int64_t r_ex, int64_t r_ey, int64_t r_exd,
                                       int64_t r_eyd, int64_t r_f, double law,
                                       const double *slots, double *exd, double *eyd,
                                       double *nx, double *ny, double *rinv, double *vt,
                                       double *d) {
    double ex = jac[r_ex * stride + vc];
    double ey = jac[r_ey * stride + vc];
    *exd = jac[r_exd * stride + vc];
    *eyd = jac[r_eyd * stride + vc];
    double f = jac[r_f * stride + vc];
    double r, rd;
    gap_state(ex, ey, *exd, *eyd, 0.0, &r, &rd, nx, ny);
    *rinv = r > 1e-300 ? 1.0 / r : 0.0;
    *vt = *eyd * *nx - *exd * *ny + spin;
    mbs_friction_force_partials_slots(*vt, f, slots, (int64_t)law, d);
}

/* (vt, Ft, power, the additions to the force on the bearing x, y) along one direction */
static inline void jac_friction_direction(double dex, double dey, double dexd, double deyd,
                                          double dspin, double dfn, double dlaw, double exd,
                                          double eyd, double nx, double ny, double rinv,
                                          double vt, double ft, double ft_vt, double ft_fn,
                                          double *dv) {
    double dnx = (ny * ny * dex - nx * ny * dey) * rinv;
    double dny = (nx * nx * dey - nx * ny * dex) * rinv;
    double d_vt = dexd * (-ny) - exd * dny + deyd * nx + eyd * dnx + dspin;
    double d_ft = ft_vt * d_vt + ft_fn * dfn + dlaw;
    dv[0] = d_vt;
    dv[1] = d_ft;
    dv[2] = -(d_ft * vt + ft * d_vt);
    dv[3] = d_ft * ny + ft * dny;
    dv[4] = -(d_ft * nx + ft * dnx);
}

/* one column of a joint's friction rows (vt, Ft, power) from dv, its force added to the
 * force on the bearing's (x, y) */
static inline void jac_friction_rows(double *jac, int64_t stride, int64_t col, int64_t r_vt,
                                     int64_t r_ft, int64_t r_pw, int64_t r_fx, int64_t r_fy,
                                     const double *dv) {
    jac[r_vt * stride + col] = dv[0];
    jac[r_ft * stride + col] = dv[1];
    jac[r_pw * stride + col] = dv[2];
    jac[r_fx * stride + col] += dv[3];
    jac[r_fy * stride + col] += dv[4];
}

static inline void jac_friction_write(double *jac, int64_t stride, int64_t vc, double spin,
                                      int64_t r_spin, int64_t r_fx, int64_t r_fy, int64_t r_ft,
                                      int64_t r_vt, int64_t r_pw, double nx, double ny,
                                      double vt, double ft, double *fx, double *fy,
                                      double *ft_out) {
    *fx = jac[r_fx * stride + vc] + ft * ny;
    *fy = jac[r_fy * stride + vc] - ft * nx;
    jac[r_fx * stride + vc] = *fx;
    jac[r_fy * stride + vc] = *fy;
    jac[r_spin * stride + vc] = spin;
    jac[r_vt * stride + vc] = vt;
    jac[r_ft * stride + vc] = ft;
    jac[r_pw * stride + vc] = -ft * vt;
    *ft_out = ft;
}

/* rows of one clearance joint's friction (sens_runtime.friction_jacobian); (fx, fy, Ft) */
static inline void friction_jacobian(double *jac, int64_t stride, int64_t nz, double spin,
                                     int64_t r_ex, int64_t r_ey, int64_t r_exd, int64_t r_eyd,
                                     int64_t r_spin, int64_t r_f, int64_t r_fx, int64_t r_fy,
                                     int64_t r_ft, int64_t r_vt, int64_t r_pw,
                                     const int64_t *cols, double law, const double *slots,
                                     double *fx, double *fy, double *ft) {
    double exd, eyd, nx, ny, rinv, vt, d[3 + MBS_N_FRICTION_SLOTS], dv[5];
    jac_friction_values(jac, stride, nz, spin, r_ex, r_ey, r_exd, r_eyd, r_f, law, slots, &exd,
                        &eyd, &nx, &ny, &rinv, &vt, d);
    for (int64_t col = 0; col < nz; col++) {
        double dlaw = 0.0;
        for (int k = 0; k < MBS_N_FRICTION_SLOTS; k++)
            if (col == cols[k]) dlaw += d[3 + k];
        jac_friction_direction(jac[r_ex * stride + col], jac[r_ey * stride + col],
                               jac[r_exd * stride + col], jac[r_eyd * stride + col],
                               jac[r_spin * stride + col], jac[r_f * stride + col], dlaw, exd,
                               eyd, nx, ny, rinv, vt, d[0], d[1], d[2], dv);
        jac_friction_rows(jac, stride, col, r_vt, r_ft, r_pw, r_fx, r_fy, dv);
    }
    jac_friction_write(jac, stride, nz, spin, r_spin, r_fx, r_fy, r_ft, r_vt, r_pw, nx, ny, vt,
                       d[0], fx, fy, ft);
}

/* friction_jacobian along nd seeds dz (sens_runtime.friction_tangent); (fx, fy, Ft) */
static inline void friction_tangent(double *out, int64_t ts, int64_t nd, const double *dz,
                                    int64_t nz, double spin, int64_t r_ex, int64_t r_ey,
                                    int64_t r_exd, int64_t r_eyd, int64_t r_spin, int64_t r_f,
                                    int64_t r_fx, int64_t r_fy, int64_t r_ft, int64_t r_vt,
                                    int64_t r_pw, const int64_t *cols, double law,
                                    const double *slots, double *fx, double *fy, double *ft) {
    double exd, eyd, nx, ny, rinv, vt, d[3 + MBS_N_FRICTION_SLOTS], dv[5];
    jac_friction_values(out, ts, nd, spin, r_ex, r_ey, r_exd, r_eyd, r_f, law, slots, &exd,
                        &eyd, &nx, &ny, &rinv, &vt, d);
    for (int64_t dd = 0; dd < nd; dd++) {
        int64_t o = dd * nz;
        double dlaw = 0.0;
        for (int k = 0; k < MBS_N_FRICTION_SLOTS; k++) dlaw += d[3 + k] * dz[o + cols[k]];
        jac_friction_direction(out[r_ex * ts + dd], out[r_ey * ts + dd], out[r_exd * ts + dd],
                               out[r_eyd * ts + dd], out[r_spin * ts + dd], out[r_f * ts + dd],
                               dlaw, exd, eyd, nx, ny, rinv, vt, d[0], d[1], d[2], dv);
        jac_friction_rows(out, ts, dd, r_vt, r_ft, r_pw, r_fx, r_fy, dv);
    }
    jac_friction_write(out, ts, nd, spin, r_spin, r_fx, r_fy, r_ft, r_vt, r_pw, nx, ny, vt,
                       d[0], fx, fy, ft);
}

/* ---- a corner of a translational clearance joint */

static inline void jac_corner_values(double h, double hd, double side, double clearance,
                                     double half_height, double mode, double dmin,
                                     double stiffness, double restitution, double model,
                                     double *delta, double *deltadot, double *f, double *law) {
    corner_state(h, hd, side, clearance, half_height, delta, deltadot);
    jac_law(*delta, *deltadot, mode, dmin, stiffness, restitution, model, f, law);
}

static inline double jac_corner_write(double *jac, int64_t stride, int64_t vc, int64_t r_f,
                                      int64_t r_pen, int64_t r_rate, int64_t r_ex,
                                      int64_t r_ey, int64_t r_exd, int64_t r_eyd, int64_t r_fn,
                                      double ex, double h, double exd, double hd, double delta,
                                      double deltadot, double f, double side) {
    jac_gap_values(jac, stride, vc, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, f, delta,
                   deltadot, ex, h, exd, hd);
    jac[r_fn * stride + vc] = -side * f;
    return -side * f;
}

/* rows of one corner (sens_runtime.corner_jacobian); fn */
static inline void corner_jacobian(double *jac, int64_t stride, int64_t nz, double ex,
                                   double h, double exd, double hd, int64_t r_f, int64_t r_pen,
                                   int64_t r_rate, int64_t r_ex, int64_t r_ey, int64_t r_exd,
                                   int64_t r_eyd, int64_t r_fn, int64_t c_clear,
                                   int64_t c_half, int64_t c_stiff, int64_t c_rest,
                                   int64_t c_dmin, double side, double clearance,
                                   double half_height, double mode, double dmin,
                                   double stiffness, double restitution, double model,
                                   double *fn) {
    double delta, deltadot, f, law[5];
    jac_corner_values(h, hd, side, clearance, half_height, mode, dmin, stiffness, restitution,
                      model, &delta, &deltadot, &f, law);
    for (int64_t col = 0; col < nz; col++) {
        double d_delta = side * jac[r_ey * stride + col];
        if (col == c_clear || col == c_half) d_delta -= 1.0;
        double d_rate = side * jac[r_eyd * stride + col];
        double d_f = law[0] * d_delta + law[1] * d_rate;
        if (col == c_dmin) d_f += law[2];
        if (col == c_stiff) d_f += law[3];
        if (col == c_rest) d_f += law[4];
        jac[r_pen * stride + col] = d_delta;
        jac[r_rate * stride + col] = d_rate;
        jac[r_f * stride + col] = d_f;
        jac[r_fn * stride + col] = -side * d_f;
    }
    *fn = jac_corner_write(jac, stride, nz, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, r_fn,
                           ex, h, exd, hd, delta, deltadot, f, side);
}

/* corner_jacobian along nd seeds dz (sens_runtime.corner_tangent); fn */
static inline void corner_tangent(double *out, int64_t ts, int64_t nd, const double *dz,
                                  int64_t nz, double ex, double h, double exd, double hd,
                                  int64_t r_f, int64_t r_pen, int64_t r_rate, int64_t r_ex,
                                  int64_t r_ey, int64_t r_exd, int64_t r_eyd, int64_t r_fn,
                                  int64_t c_clear, int64_t c_half, int64_t c_stiff,
                                  int64_t c_rest, int64_t c_dmin, double side,
                                  double clearance, double half_height, double mode,
                                  double dmin, double stiffness, double restitution,
                                  double model, double *fn) {
    double delta, deltadot, f, law[5];
    jac_corner_values(h, hd, side, clearance, half_height, mode, dmin, stiffness, restitution,
                      model, &delta, &deltadot, &f, law);
    for (int64_t d = 0; d < nd; d++) {
        int64_t o = d * nz;
        double d_delta = side * out[r_ey * ts + d] - dz[o + c_clear] - dz[o + c_half];
        double d_rate = side * out[r_eyd * ts + d];
        double d_f = (law[0] * d_delta + law[1] * d_rate + law[2] * dz[o + c_dmin]
                      + law[3] * dz[o + c_stiff] + law[4] * dz[o + c_rest]);
        out[r_pen * ts + d] = d_delta;
        out[r_rate * ts + d] = d_rate;
        out[r_f * ts + d] = d_f;
        out[r_fn * ts + d] = -side * d_f;
    }
    *fn = jac_corner_write(out, ts, nd, r_f, r_pen, r_rate, r_ex, r_ey, r_exd, r_eyd, r_fn, ex,
                           h, exd, hd, delta, deltadot, f, side);
}

static inline double jac_corner_friction_write(double *jac, int64_t stride, int64_t vc,
                                               int64_t r_ft, int64_t r_vt, int64_t r_pw,
                                               double vt, double ft) {
    jac[r_ft * stride + vc] = ft;
    jac[r_vt * stride + vc] = vt;
    jac[r_pw * stride + vc] = -ft * vt;
    return ft;
}

/* rows of one corner's friction (sens_runtime.corner_friction_jacobian); Ft */
static inline void corner_friction_jacobian(double *jac, int64_t stride, int64_t nz,
                                            int64_t r_exd, int64_t r_f, int64_t r_ft,
                                            int64_t r_vt, int64_t r_pw, const int64_t *cols,
                                            double law, const double *slots, double *ft) {
    double vt = jac[r_exd * stride + nz];
    double d[3 + MBS_N_FRICTION_SLOTS];
    mbs_friction_force_partials_slots(vt, jac[r_f * stride + nz], slots, (int64_t)law, d);
    for (int64_t col = 0; col < nz; col++) {
        double d_vt = jac[r_exd * stride + col];
        double d_ft = d[1] * d_vt + d[2] * jac[r_f * stride + col];
        for (int k = 0; k < MBS_N_FRICTION_SLOTS; k++)
            if (col == cols[k]) d_ft += d[3 + k];
        jac[r_vt * stride + col] = d_vt;
        jac[r_ft * stride + col] = d_ft;
        jac[r_pw * stride + col] = -(d_ft * vt + d[0] * d_vt);
    }
    *ft = jac_corner_friction_write(jac, stride, nz, r_ft, r_vt, r_pw, vt, d[0]);
}

/* corner_friction_jacobian along nd seeds dz (sens_runtime.corner_friction_tangent); Ft */
static inline void corner_friction_tangent(double *out, int64_t ts, int64_t nd,
                                           const double *dz, int64_t nz, int64_t r_exd,
                                           int64_t r_f, int64_t r_ft, int64_t r_vt,
                                           int64_t r_pw, const int64_t *cols, double law,
                                           const double *slots, double *ft) {
    double vt = out[r_exd * ts + nd];
    double d[3 + MBS_N_FRICTION_SLOTS];
    mbs_friction_force_partials_slots(vt, out[r_f * ts + nd], slots, (int64_t)law, d);
    for (int64_t dd = 0; dd < nd; dd++) {
        int64_t o = dd * nz;
        double d_vt = out[r_exd * ts + dd];
        double d_ft = d[1] * d_vt + d[2] * out[r_f * ts + dd];
        for (int k = 0; k < MBS_N_FRICTION_SLOTS; k++) d_ft += d[3 + k] * dz[o + cols[k]];
        out[r_vt * ts + dd] = d_vt;
        out[r_ft * ts + dd] = d_ft;
        out[r_pw * ts + dd] = -(d_ft * vt + d[0] * d_vt);
    }
    *ft = jac_corner_friction_write(out, ts, nd, r_ft, r_vt, r_pw, vt, d[0]);
}

/* ---- a lubricated joint's oil film: its partials by the complex step
 * (laws/lubrication/partials.py: the same cores, steps and fallbacks) */

/* the complex step (relative to the input's size) and the offset (in clearances) below
 * which the derivatives are taken at this offset */
#define JAC_FILM_H 1e-20
#define JAC_FILM_CENTRE 1e-8

/* the ends of the film's positive region in Sommerfeld's variable: n lobes (u1, d1),
 * (u2, d2) (-1: all around; -2: a law without partials) */
typedef struct { int64_t n; double u1, d1, u2, d2; } jac_film_ends;

/* |e| to first order in the complex step (no complex square root) and the frame u */
static inline void jac_film_frame_c(double complex ex, double complex ey, double complex *e,
                                    double complex *ux, double complex *uy) {
    double er = sqrt(creal(ex) * creal(ex) + creal(ey) * creal(ey));
    if (er == 0.0) {
        *e = 0.0 * ex;
        *ux = 1.0 + 0.0 * ex;
        *uy = 0.0 * ex;
    } else {
        *e = er + (creal(ex) * (ex - creal(ex)) + creal(ey) * (ey - creal(ey))) / er;
        *ux = ex / *e;
        *uy = ey / *e;
    }
}

/* (Fx, Fy, T, eps) of the short film over the fixed Sommerfeld angles (p1, p2)
 * (partials._short_core) */
static void jac_short_core(double complex ex, double complex ey, double complex vx,
                           double complex vy, double complex omega_j, double complex omega_b,
                           double complex R, double complex c, double complex L,
                           double complex mu, double p1, double p2, double complex *res) {
    double complex e, ux, uy;
    jac_film_frame_c(ex, ey, &e, &ux, &uy);
    double complex eps = e / c;
    double complex eps_dot = (ux * vx + uy * vy) / c;
    double complex rate_t = (-uy * vx + ux * vy) / c;
    double complex a = (omega_j + omega_b) * eps - 2.0 * rate_t;
    double complex b = 2.0 * eps_dot;
    double sp1 = sin(p1), cp1 = cos(p1), sp2 = sin(p2), cp2 = cos(p2);
    double complex s1 = 0.5 * (sp2 * sp2 - sp1 * sp1) + eps * (cp2 - cp1);
    double complex s2 = ((0.5 + eps * eps) * (p2 - p1) + 0.25 * (sin(2.0 * p2) - sin(2.0 * p1))
                         - 2.0 * eps * (sp2 - sp1));
    double s3 = 0.5 * (p2 - p1) - 0.25 * (sin(2.0 * p2) - sin(2.0 * p1));
    double complex q = 1.0 - eps * eps;
    double complex s = csqrt(q);
    double complex k = R * mu * L * L * L / (2.0 * c * c);
    double complex fr = k * (a * s1 / (q * q) - b * s2 / (q * q * s));
    double complex ft = k * (a * s3 / (q * s) - b * s1 / (q * q));
    double complex couette = -2.0 * MBS_PI * mu * R * R * R * L * (omega_j - omega_b) / (c * s);
    res[0] = fr * ux - ft * uy;
    res[1] = fr * uy + ft * ux;
    res[2] = couette - 0.5 * e * ft;
    res[3] = eps;
}

/* the short film's ends (partials._short_ends) */
static inline jac_film_ends jac_short_ends(double ex, double ey, double vx, double vy,
                                           double omega_j, double omega_b, double c) {
    double e = sqrt(ex * ex + ey * ey);
    double ux = 1.0, uy = 0.0;
    if (e > 0.0) { ux = ex / e; uy = ey / e; }
    double eps = e / c;
    double a = (omega_j + omega_b) * eps - 2.0 * (-uy * vx + ux * vy) / c;
    double b = 2.0 * (ux * vx + uy * vy) / c;
    double alpha = atan2(b, a);
    jac_film_ends out = {1, mbs_sommerfeld_angle(alpha, eps),
                         mbs_sommerfeld_angle(alpha + MBS_PI, eps), 0.0, 0.0};
    return out;
}

/* the long film's lobes (partials._long_ends) */
static inline jac_film_ends jac_long_ends(double ex, double ey, double vx, double vy,
                                          double omega_j, double omega_b, double c) {
    double e = sqrt(ex * ex + ey * ey);
    double ux = 1.0, uy = 0.0;
    if (e > 0.0) { ux = ex / e; uy = ey / e; }
    double eps = e / c;
    double a = (omega_j + omega_b) * eps - 2.0 * (-uy * vx + ux * vy) / c;
    double q = 1.0 - eps * eps;
    double a1 = a / ((2.0 + eps * eps) * q * sqrt(q));
    double b1 = (ux * vx + uy * vy) / c / ((2.0 + 3.0 * eps * eps) * q * q);
    jac_film_ends out;
    out.n = mbs_long_lobes(eps, a1, b1, &out.u1, &out.d1, &out.u2, &out.d2);
    return out;
}

/* the end z moved with the complex step of the pressure's parameters (partials._moved) */
static inline double complex jac_moved(double z, double complex eps, double complex a1,
                                       double complex b1) {
    double sp = sin(z), cp = cos(z);
    double complex g = (a1 * sp * (2.0 - eps * eps - eps * cp)
                        + b1 * ((7.0 - 2.0 * eps * eps) * eps - (4.0 + 6.0 * eps * eps) * cp
                                + eps * (2.0 + 3.0 * eps * eps) * cp * cp));
    double g0, dg;
    mbs_long_pressure(z, creal(eps), creal(a1), creal(b1), &g0, &dg);
    return z - I * (cimag(g) / dg);
}

/* journal_bearing._long_integrals of complex ends, added to j[4] */
static inline void jac_long_integrals_c(double complex p1, double complex p2,
                                        double complex eps, double complex *j) {
    double complex s1 = csin(p1), c1 = ccos(p1), s2 = csin(p2), c2 = ccos(p2);
    j[0] = j[0] + ((s2 * s2 - eps * c2) - (s1 * s1 - eps * c1));
    j[1] = j[1] + (0.5 * (p2 - p1) - 0.5 * (s2 * c2 - s1 * c1));
    j[2] = j[2] + ((1.0 - eps * eps) * (p2 - p1) + (s2 * c2 - s1 * c1) - eps * (s2 - s1));
    j[3] = j[3] + (0.5 * (s2 * s2 - s1 * s1) + eps * (c2 - c1));
}

/* (Fx, Fy, T, eps) of the long film over its lobes, each end moved (partials._long_core) */
static void jac_long_core(double complex ex, double complex ey, double complex vx,
                          double complex vy, double complex omega_j, double complex omega_b,
                          double complex R, double complex c, double complex L,
                          double complex mu, jac_film_ends ends, double complex *res) {
    double complex e, ux, uy;
    jac_film_frame_c(ex, ey, &e, &ux, &uy);
    double complex eps = e / c;
    double complex eps_dot = (ux * vx + uy * vy) / c;
    double complex rate_t = (-uy * vx + ux * vy) / c;
    double complex a = (omega_j + omega_b) * eps - 2.0 * rate_t;
    double complex q = 1.0 - eps * eps;
    double complex s = csqrt(q);
    double complex a1 = a / ((2.0 + eps * eps) * q * s);
    double complex b1 = eps_dot / ((2.0 + 3.0 * eps * eps) * q * q);
    double complex j[4] = {0.0 * eps, 0.0 * eps, 0.0 * eps, 0.0 * eps};
    if (ends.n == -1)      /* positive all around: the ends are fixed */
        jac_long_integrals_c(0.0, 2.0 * MBS_PI, eps, j);
    for (int64_t k = 0; k < ends.n; k++) {
        double u = k == 0 ? ends.u1 : ends.u2, d = k == 0 ? ends.d1 : ends.d2;
        jac_long_integrals_c(jac_moved(u, eps, a1, b1), jac_moved(d, eps, a1, b1), eps, j);
    }
    double complex k6 = 6.0 * mu * R * R * R * L / (c * c);
    double complex fr = -k6 * (a * j[0] / ((2.0 + eps * eps) * q) + 2.0 * eps_dot * j[1] / (q * s));
    double complex ft = k6 * (a * j[2] / ((2.0 + eps * eps) * q * s) + 2.0 * eps_dot * j[3] / (q * q));
    double complex couette = -2.0 * MBS_PI * mu * R * R * R * L * (omega_j - omega_b) / (c * s);
    res[0] = fr * ux - ft * uy;
    res[1] = fr * uy + ft * ux;
    res[2] = couette - 0.5 * e * ft;
    res[3] = eps;
}

/* the faded film of law id `model` (partials.film_values): returns active (0: faded out, all
 * zero); its ends, w, dw/deps, and v[5] = (Fx, Fy, T_J, T_B, power) */
static int jac_film_values(double ex, double ey, double vx, double vy, double omega_j,
                           double omega_b, double R, double c, double L, double mu,
                           int64_t model, double start, double end, jac_film_ends *ends,
                           double *w, double *dw, double *v) {
    jac_film_ends none = {0, 0.0, 0.0, 0.0, 0.0};
    *ends = none;
    for (int k = 0; k < 5; k++) v[k] = 0.0;
    mbs_film_fade(sqrt(ex * ex + ey * ey) / c, start, end, w, dw);
    if (*w == 0.0) {
        *w = 0.0;
        *dw = 0.0;
        return 0;
    }
    double fx, fy, tj;
    if (model == 0) {
        *ends = jac_short_ends(ex, ey, vx, vy, omega_j, omega_b, c);
        double complex r[4];
        jac_short_core(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, ends->u1, ends->d1, r);
        fx = *w * creal(r[0]);
        fy = *w * creal(r[1]);
        tj = *w * creal(r[2]);
    } else {
        if (model == 1) {
            *ends = jac_long_ends(ex, ey, vx, vy, omega_j, omega_b, c);
        } else {
            jac_film_ends nod = {-2, 0.0, 0.0, 0.0, 0.0};
            *ends = nod;
        }
        double w2;
        mbs_lubricated_force(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, model, start, end,
                             &fx, &fy, &tj, &w2);
    }
    v[0] = fx;
    v[1] = fy;
    v[2] = tj;
    v[3] = -tj - (ex * fy - ey * fx);
    v[4] = fx * (vx + omega_b * ey) + fy * (vy - omega_b * ex) + tj * (omega_j - omega_b);
    return 1;
}

static inline double jac_max(double a, double b) { return b > a ? b : a; }

/* derivatives of the faded film's (Fx, Fy, T_J, T_B, power) along one direction of the
 * inputs (the d-arguments) into dv[5] (partials.film_direction); fx, fy, tj: the faded
 * values */
static void jac_film_direction(double ex, double ey, double vx, double vy, double omega_j,
                               double omega_b, double R, double c, double L, double mu,
                               int64_t model, double start, double end, jac_film_ends ends,
                               double w, double dw, double fx, double fy, double tj,
                               double dex, double dey, double dvx, double dvy, double dwj,
                               double dwb, double dR, double dc, double dL, double dmu,
                               double dstart, double dend, double *dv) {
    if (ends.n == -2) {
        for (int k = 0; k < 5; k++) dv[k] = NAN;
        return;
    }
    /* the step: JAC_FILM_H of each input's natural size along the direction */
    double sv = c * jac_max(jac_max(fabs(omega_j), fabs(omega_b)), 1.0);
    double big = fabs(dex) / c;
    big = jac_max(big, fabs(dey) / c);
    big = jac_max(big, fabs(dvx) / jac_max(fabs(vx), sv));
    big = jac_max(big, fabs(dvy) / jac_max(fabs(vy), sv));
    big = jac_max(big, fabs(dwj) / jac_max(fabs(omega_j), 1.0));
    big = jac_max(big, fabs(dwb) / jac_max(fabs(omega_b), 1.0));
    big = jac_max(big, fabs(dR) / R);
    big = jac_max(big, fabs(dc) / c);
    big = jac_max(big, fabs(dL) / L);
    big = jac_max(big, fabs(dmu) / mu);
    double gfx = 0.0, gfy = 0.0, gtj = 0.0, deps = 0.0;
    double e = sqrt(ex * ex + ey * ey);
    double xs = ex, ys = ey;
    if (e < JAC_FILM_CENTRE * c) {
        /* near the centre: the derivatives at |e| = JAC_FILM_CENTRE c */
        double ux = 1.0, uy = 0.0;
        if (e > 0.0) { ux = ex / e; uy = ey / e; }
        xs = JAC_FILM_CENTRE * c * ux;
        ys = JAC_FILM_CENTRE * c * uy;
        ends = model == 0 ? jac_short_ends(xs, ys, vx, vy, omega_j, omega_b, c)
                          : jac_long_ends(xs, ys, vx, vy, omega_j, omega_b, c);
    }
    if (big > 0.0) {
        double h = JAC_FILM_H / big;
        double complex r[4];
        double complex a[10] = {xs + I * (h * dex), ys + I * (h * dey), vx + I * (h * dvx),
                                vy + I * (h * dvy), omega_j + I * (h * dwj),
                                omega_b + I * (h * dwb), R + I * (h * dR), c + I * (h * dc),
                                L + I * (h * dL), mu + I * (h * dmu)};
        if (model == 0)
            jac_short_core(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], ends.u1,
                           ends.d1, r);
        else
            jac_long_core(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], ends, r);
        gfx = cimag(r[0]) / h;
        gfy = cimag(r[1]) / h;
        gtj = cimag(r[2]) / h;
        deps = cimag(r[3]) / h;
    }
    /* the faded film w F: d(w F) = w dF + F dw, dw = w'(eps) deps + the fade's ends' part */
    double dwt = dw * deps;
    double eps = e / c;
    if (start < eps && eps < end && (dstart != 0.0 || dend != 0.0)) {
        double width = end - start;
        double s = (eps - start) / width;
        double slope = 30.0 * s * s * (1.0 - s) * (1.0 - s);
        dwt += slope * ((1.0 - s) * dstart + s * dend) / width;
    }
    double r = dwt / w;
    double dfx = w * gfx + fx * r;
    double dfy = w * gfy + fy * r;
    double dtj = w * gtj + tj * r;
    dv[0] = dfx;
    dv[1] = dfy;
    dv[2] = dtj;
    dv[3] = -dtj - (dex * fy + ex * dfy - dey * fx - ey * dfx);
    dv[4] = (dfx * (vx + omega_b * ey) + fx * (dvx + dwb * ey + omega_b * dey)
             + dfy * (vy - omega_b * ex) + fy * (dvy - dwb * ex - omega_b * dex)
             + dtj * (omega_j - omega_b) + tj * (dwj - dwb));
}

/* one column of the film's rows from d (Fx, Fy, T_J, T_B, power), d's force taken off the
 * force on the bearing's column */
static inline void jac_film_rows(double *jac, int64_t stride, int64_t col, int64_t r_fx,
                                 int64_t r_fy, int64_t r_ffx, int64_t r_ffy, int64_t r_tj,
                                 int64_t r_tb, int64_t r_pw, const double *d) {
    jac[r_ffx * stride + col] = d[0];
    jac[r_ffy * stride + col] = d[1];
    jac[r_tj * stride + col] = d[2];
    jac[r_tb * stride + col] = d[3];
    jac[r_pw * stride + col] = d[4];
    jac[r_fx * stride + col] -= d[0];
    jac[r_fy * stride + col] -= d[1];
}

/* the film's inputs from their rows' values (column vc; wj, wb written there) and
 * jac_film_values of them; in[4] = (ex, ey, exd, eyd) */
static inline int jac_film_state(double *jac, int64_t stride, int64_t vc, double wj,
                                 double wb, int64_t r_ex, int64_t r_ey, int64_t r_exd,
                                 int64_t r_eyd, int64_t r_wj, int64_t r_wb, double radius,
                                 double clearance, double length, double viscosity,
                                 double model, double start, double end, double *in,
                                 jac_film_ends *ends, double *w, double *dw, double *v) {
    in[0] = jac[r_ex * stride + vc];
    in[1] = jac[r_ey * stride + vc];
    in[2] = jac[r_exd * stride + vc];
    in[3] = jac[r_eyd * stride + vc];
    jac[r_wj * stride + vc] = wj;
    jac[r_wb * stride + vc] = wb;
    return jac_film_values(in[0], in[1], in[2], in[3], wj, wb, radius, clearance, length,
                           viscosity, (int64_t)model, start, end, ends, w, dw, v);
}

/* rows of one lubricated joint's oil film (sens_runtime.film_jacobian); (fx, fy, T_J, T_B) */
static void film_jacobian(double *jac, int64_t stride, int64_t nz, double wj, double wb,
                          int64_t r_ex, int64_t r_ey, int64_t r_exd, int64_t r_eyd,
                          int64_t r_wj, int64_t r_wb, int64_t r_fx, int64_t r_fy,
                          int64_t r_ffx, int64_t r_ffy, int64_t r_tj, int64_t r_tb,
                          int64_t r_pw, int64_t c_r, int64_t c_c, int64_t c_l, int64_t c_mu,
                          int64_t c_s, int64_t c_e, double radius, double clearance,
                          double length, double viscosity, double model, double start,
                          double end, double *fx, double *fy, double *tj, double *tb) {
    int64_t vc = nz;
    double in[4], w, dw, v[5], d[5];
    jac_film_ends ends;
    int active = jac_film_state(jac, stride, vc, wj, wb, r_ex, r_ey, r_exd, r_eyd, r_wj, r_wb,
                                radius, clearance, length, viscosity, model, start, end, in,
                                &ends, &w, &dw, v);
    if (active) {
        for (int64_t col = 0; col < nz; col++) {
            jac_film_direction(in[0], in[1], in[2], in[3], wj, wb, radius, clearance, length,
                               viscosity, (int64_t)model, start, end, ends, w, dw, v[0], v[1],
                               v[2], jac[r_ex * stride + col], jac[r_ey * stride + col],
                               jac[r_exd * stride + col], jac[r_eyd * stride + col],
                               jac[r_wj * stride + col], jac[r_wb * stride + col],
                               col == c_r ? 1.0 : 0.0, col == c_c ? 1.0 : 0.0,
                               col == c_l ? 1.0 : 0.0, col == c_mu ? 1.0 : 0.0,
                               col == c_s ? 1.0 : 0.0, col == c_e ? 1.0 : 0.0, d);
            jac_film_rows(jac, stride, col, r_fx, r_fy, r_ffx, r_ffy, r_tj, r_tb, r_pw, d);
        }
    }
    jac_film_rows(jac, stride, vc, r_fx, r_fy, r_ffx, r_ffy, r_tj, r_tb, r_pw, v);
    *fx = jac[r_fx * stride + vc];
    *fy = jac[r_fy * stride + vc];
    *tj = v[2];
    *tb = v[3];
}

/* film_jacobian along nd seeds dz (sens_runtime.film_tangent); (fx, fy, T_J, T_B) */
static void film_tangent(double *out, int64_t ts, int64_t nd, const double *dz, int64_t nz,
                         double wj, double wb, int64_t r_ex, int64_t r_ey, int64_t r_exd,
                         int64_t r_eyd, int64_t r_wj, int64_t r_wb, int64_t r_fx, int64_t r_fy,
                         int64_t r_ffx, int64_t r_ffy, int64_t r_tj, int64_t r_tb,
                         int64_t r_pw, int64_t c_r, int64_t c_c, int64_t c_l, int64_t c_mu,
                         int64_t c_s, int64_t c_e, double radius, double clearance,
                         double length, double viscosity, double model, double start,
                         double end, double *fx, double *fy, double *tj, double *tb) {
    double in[4], w, dw, v[5], der[5];
    jac_film_ends ends;
    int active = jac_film_state(out, ts, nd, wj, wb, r_ex, r_ey, r_exd, r_eyd, r_wj, r_wb,
                                radius, clearance, length, viscosity, model, start, end, in,
                                &ends, &w, &dw, v);
    for (int64_t d = 0; d < nd; d++) {
        int64_t o = d * nz;
        if (active)
            jac_film_direction(in[0], in[1], in[2], in[3], wj, wb, radius, clearance, length,
                               viscosity, (int64_t)model, start, end, ends, w, dw, v[0], v[1],
                               v[2], out[r_ex * ts + d], out[r_ey * ts + d],
                               out[r_exd * ts + d], out[r_eyd * ts + d], out[r_wj * ts + d],
                               out[r_wb * ts + d], dz[o + c_r], dz[o + c_c], dz[o + c_l],
                               dz[o + c_mu], dz[o + c_s], dz[o + c_e], der);
        else
            for (int k = 0; k < 5; k++) der[k] = 0.0;
        jac_film_rows(out, ts, d, r_fx, r_fy, r_ffx, r_ffy, r_tj, r_tb, r_pw, der);
    }
    jac_film_rows(out, ts, nd, r_fx, r_fy, r_ffx, r_ffy, r_tj, r_tb, r_pw, v);
    *fx = out[r_fx * ts + nd];
    *fy = out[r_fy * ts + nd];
    *tj = v[2];
    *tb = v[3];
}

#endif
