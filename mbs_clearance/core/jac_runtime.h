/* What the generated Jacobian and tangent kernels call (generate/cjacobians.py): each element's
 * rows (a clearance joint's contact, its friction, a translational joint's corner and its
 * friction, a lubricated joint's oil film), the C twins of generate/sens_runtime.py's
 * functions of the same names, in the same order of operations. A row r of the Jacobian
 * jac (flat) holds jac[r * stride + col], the value in column nz; a row of the tangent out
 * holds out[r * ts + d] along seed d of dz (nd x nz, flat), the value in column nd. Tuples
 * are returned through pointers after the arguments. Included after runtime.h. */
#ifndef MBS_JAC_RUNTIME_H
#define MBS_JAC_RUNTIME_H

#include <complex.h>
#include <math.h>
#include <stdint.h>

#include "laws_generated.h"

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
    *f = 0.0;
    for (int k = 0; k < 5; k++) law[k] = 0.0;
    if (mode > 0.5) {
        *f = mbs_contact_force(*delta, *deltadot, dmin, stiffness, restitution, (int64_t)model);
        if (*f > 0.0) {
            double d[6];
            mbs_contact_force_partials(*delta, *deltadot, dmin, stiffness, restitution,
                                       (int64_t)model, d);
            for (int k = 0; k < 5; k++) law[k] = d[k + 1];
        }
    }
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

static inline void jac_contact_write(double *jac, int64_t stride, int64_t vc, int64_t r_f,
                                     int64_t r_pen, int64_t r_rate, int64_t r_ex, int64_t r_ey,
                                     int64_t r_exd, int64_t r_eyd, int64_t r_fx, int64_t r_fy,
                                     double ex, double ey, double exd, double eyd,
                                     double delta, double deltadot, double f, double nx,
                                     double ny, double *fx, double *fy) {
    *fx = f * nx;
    *fy = f * ny;
    jac[r_f * stride + vc] = f;
    jac[r_pen * stride + vc] = delta;
    jac[r_rate * stride + vc] = deltadot;
    jac[r_ex * stride + vc] = ex;
    jac[r_ey * stride + vc] = ey;
    jac[r_exd * stride + vc] = exd;
    jac[r_eyd * stride + vc] = eyd;
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
        jac[r_pen * stride + col] = dv[0];
        jac[r_rate * stride + col] = dv[1];
        jac[r_f * stride + col] = dv[2];
        jac[r_fx * stride + col] = dv[3];
        jac[r_fy * stride + col] = dv[4];
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
        out[r_pen * ts + d] = dv[0];
        out[r_rate * ts + d] = dv[1];
        out[r_f * ts + d] = dv[2];
        out[r_fx * ts + d] = dv[3];
        out[r_fy * ts + d] = dv[4];
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
        jac[r_vt * stride + col] = dv[0];
        jac[r_ft * stride + col] = dv[1];
        jac[r_pw * stride + col] = dv[2];
        jac[r_fx * stride + col] += dv[3];
        jac[r_fy * stride + col] += dv[4];
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
        out[r_vt * ts + dd] = dv[0];
        out[r_ft * ts + dd] = dv[1];
        out[r_pw * ts + dd] = dv[2];
        out[r_fx * ts + dd] += dv[3];
        out[r_fy * ts + dd] += dv[4];
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
    *f = 0.0;
    for (int k = 0; k < 5; k++) law[k] = 0.0;
    if (mode > 0.5) {
        *f = mbs_contact_force(*delta, *deltadot, dmin, stiffness, restitution, (int64_t)model);
        if (*f > 0.0) {
            double d[6];
            mbs_contact_force_partials(*delta, *deltadot, dmin, stiffness, restitution,
                                       (int64_t)model, d);
            for (int k = 0; k < 5; k++) law[k] = d[k + 1];
        }
    }
}

static inline double jac_corner_write(double *jac, int64_t stride, int64_t vc, int64_t r_f,
                                      int64_t r_pen, int64_t r_rate, int64_t r_ex,
                                      int64_t r_ey, int64_t r_exd, int64_t r_eyd, int64_t r_fn,
                                      double ex, double h, double exd, double hd, double delta,
                                      double deltadot, double f, double side) {
    jac[r_f * stride + vc] = f;
    jac[r_pen * stride + vc] = delta;
    jac[r_rate * stride + vc] = deltadot;
    jac[r_ex * stride + vc] = ex;
    jac[r_ey * stride + vc] = h;
    jac[r_exd * stride + vc] = exd;
    jac[r_eyd * stride + vc] = hd;
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

#endif
