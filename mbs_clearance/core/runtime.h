/* What every generated C model includes: sin and cos of one angle together, the clearance
 * joints' contact stages (penetration, its rate, the force of the law, friction, the oil
 * film) and the switching function. The film's functions keep the order of operations of
 * their Python twins (laws/lubrication), so that both round alike; the laws themselves come
 * from laws_generated.h, printed from their one definition. Tuples are returned through
 * pointers. */
#ifndef MBS_RUNTIME_H
#define MBS_RUNTIME_H

#include <math.h>
#include <stdint.h>

#include "laws_generated.h"

/* a model's dynamics, inlined into its rhs and monitor whatever the optimisation level: the
 * integrator then calls one function per stage (the paper's case: 8 % less time than with
 * the call left at -O2) */
#if defined(__GNUC__)
#define MBS_ALWAYS_INLINE static inline __attribute__((always_inline))
#else
#define MBS_ALWAYS_INLINE static inline
#endif

/* ---- sin and cos (numerics/_trig.py): reduction by pi/2 in two parts (Cody & Waite), the
 * Taylor series on |r| <= pi/4 by Estrin's scheme; about 1e-16 absolute for |x| < 1e5 */
#define MBS_PIO2_HI 0x1.921fb54400000p+0
#define MBS_PIO2_LO 0x1.0b4611a626331p-34
#define MBS_TWO_OVER_PI 0x1.45f306dc9c883p-1
#define MBS_TWO63 0x1.0000000000000p+63
#define MBS_S3 -0x1.5555555555555p-3
#define MBS_S5 0x1.1111111111111p-7
#define MBS_S7 -0x1.a01a01a01a01ap-13
#define MBS_S9 0x1.71de3a556c734p-19
#define MBS_S11 -0x1.ae64567f544e4p-26
#define MBS_S13 0x1.6124613a86d09p-33
#define MBS_S15 -0x1.ae7f3e733b81fp-41
#define MBS_S17 0x1.952c77030ad4ap-49
#define MBS_C2 -0x1.0000000000000p-1
#define MBS_C4 0x1.5555555555555p-5
#define MBS_C6 -0x1.6c16c16c16c17p-10
#define MBS_C8 0x1.a01a01a01a01ap-16
#define MBS_C10 -0x1.27e4fb7789f5cp-22
#define MBS_C12 0x1.1eed8eff8d898p-29
#define MBS_C14 -0x1.93974a8c07c9dp-37
#define MBS_C16 0x1.ae7f3e733b81fp-45
#define MBS_C18 -0x1.6827863b97d97p-53

static inline void mbs_sincos(double x, double *s_out, double *c_out) {
    double k = rint(x * MBS_TWO_OVER_PI);
    /* beyond the int64 range (a diverging trial step): what x86's conversion gives */
    if (!(fabs(k) < MBS_TWO63)) k = -MBS_TWO63;
    double r = (x - k * MBS_PIO2_HI) - k * MBS_PIO2_LO;
    double r2 = r * r;
    double r4 = r2 * r2;
    double r8 = r4 * r4;
    double ps = ((MBS_S3 + MBS_S5 * r2) + (MBS_S7 + MBS_S9 * r2) * r4
                 + ((MBS_S11 + MBS_S13 * r2) + (MBS_S15 + MBS_S17 * r2) * r4) * r8);
    double pc = ((MBS_C4 + MBS_C6 * r2) + (MBS_C8 + MBS_C10 * r2) * r4
                 + ((MBS_C12 + MBS_C14 * r2) + (MBS_C16 + MBS_C18 * r2) * r4) * r8);
    double s = r + r * r2 * ps;
    double c = 1.0 + r2 * (MBS_C2 + r2 * pc);
    int64_t q = (int64_t)k & 3;
    if (q == 0) { *s_out = s; *c_out = c; }
    else if (q == 1) { *s_out = c; *c_out = -s; }
    else if (q == 2) { *s_out = -s; *c_out = -c; }
    else { *s_out = -c; *c_out = s; }
}

/* ---- the contact stages (generate/runtime.py) */

/* (delta, deltadot, nx, ny) of a clearance joint from the journal centre's offset and
 * velocity relative to the bearing centre; n = (-1, 0) when exactly centred */
static inline void gap_state(double ex, double ey, double exd, double eyd, double clearance,
                             double *delta, double *deltadot, double *nx, double *ny) {
    double r = sqrt(ex * ex + ey * ey);
    if (r > 1e-300) {
        double inv_r = 1.0 / r;
        *nx = ex * inv_r;
        *ny = ey * inv_r;
    } else {
        *nx = -1.0;
        *ny = 0.0;
    }
    *delta = r - clearance;
    *deltadot = *nx * exd + *ny * eyd;
}

/* (F, delta, deltadot, fx, fy): the law's force (zero in free flight, mode 0), the
 * penetration and its rate, fx, fy = F n */
static inline void contact_stage(double ex, double ey, double exd, double eyd,
                                 double clearance, double mode, double deltadot_minus,
                                 double stiffness, double restitution, double model,
                                 double *F, double *delta, double *deltadot, double *fx,
                                 double *fy) {
    double nx, ny;
    gap_state(ex, ey, exd, eyd, clearance, delta, deltadot, &nx, &ny);
    double f = 0.0;
    if (mode > 0.5)
        f = mbs_contact_force(*delta, *deltadot, deltadot_minus, stiffness, restitution,
                              (int64_t)model);
    *F = f;
    *fx = f * nx;
    *fy = f * ny;
}

/* contact_stage with friction: (F, delta, deltadot, fx, fy, ft, vt), slots the values of
 * the friction slots */
static inline void friction_stage(double ex, double ey, double exd, double eyd, double spin,
                                  double clearance, double mode, double deltadot_minus,
                                  double stiffness, double restitution, double model,
                                  double law, const double *slots, double *F, double *delta,
                                  double *deltadot, double *fx, double *fy, double *ft,
                                  double *vt) {
    double cfx, cfy, d_, dd_, nx, ny;
    contact_stage(ex, ey, exd, eyd, clearance, mode, deltadot_minus, stiffness, restitution,
                  model, F, delta, deltadot, &cfx, &cfy);
    gap_state(ex, ey, exd, eyd, clearance, &d_, &dd_, &nx, &ny);
    double v = eyd * nx - exd * ny + spin;
    double f = mbs_friction_force_slots(v, *F, slots, (int64_t)law);
    *fx = cfx + f * ny;
    *fy = cfy - f * nx;
    *ft = f;
    *vt = v;
}

/* (delta, deltadot) of a corner of a translational joint's slider */
static inline void corner_state(double h, double hd, double side, double clearance,
                                double half_height, double *delta, double *deltadot) {
    *delta = side * h - (half_height + clearance);
    *deltadot = side * hd;
}

/* (F, delta, deltadot, fn) of a corner: fn = -side F */
static inline void corner_stage(double h, double hd, double side, double clearance,
                                double half_height, double mode, double deltadot_minus,
                                double stiffness, double restitution, double model, double *F,
                                double *delta, double *deltadot, double *fn) {
    corner_state(h, hd, side, clearance, half_height, delta, deltadot);
    double f = 0.0;
    if (mode > 0.5)
        f = mbs_contact_force(*delta, *deltadot, deltadot_minus, stiffness, restitution,
                              (int64_t)model);
    *F = f;
    *fn = -side * f;
}

/* corner_stage with friction: (F, delta, deltadot, fn, ft) */
static inline void corner_friction_stage(double h, double hd, double vt, double side,
                                         double clearance, double half_height, double mode,
                                         double deltadot_minus, double stiffness,
                                         double restitution, double model, double law,
                                         const double *slots, double *F, double *delta,
                                         double *deltadot, double *fn, double *ft) {
    corner_stage(h, hd, side, clearance, half_height, mode, deltadot_minus, stiffness,
                 restitution, model, F, delta, deltadot, fn);
    *ft = mbs_friction_force_slots(vt, *F, slots, (int64_t)law);
}

/* the switching function and its rate: penetration in free flight, minus it in contact */
static inline void switching(double mode, double delta, double deltadot, double *g,
                             double *gd) {
    if (mode > 0.5) {
        *g = -delta;
        *gd = -deltadot;
    } else {
        *g = delta;
        *gd = deltadot;
    }
}

/* ---- the oil film (laws/lubrication/journal_bearing.py, hybrid.py) */
#define MBS_PI 3.141592653589793
/* samples of the long film's pressure around the circle when locating its zeros */
#define MBS_LONG_SAMPLES 96

static inline double mbs_sommerfeld_angle(double theta, double eps) {
    double beta = eps / (1.0 + sqrt(1.0 - eps * eps));
    return theta - 2.0 * atan2(beta * sin(theta), 1.0 + beta * cos(theta));
}

/* (e, eps, ur_x, ur_y, eps_dot, the tangential rate v . u_t / c) */
static inline void mbs_film_frame(double ex, double ey, double vx, double vy, double c,
                                  double *e, double *eps, double *ux, double *uy,
                                  double *eps_dot, double *rate_t) {
    *e = sqrt(ex * ex + ey * ey);
    if (*e > 0.0) {
        *ux = ex / *e;
        *uy = ey / *e;
    } else {
        *ux = 1.0;
        *uy = 0.0;
    }
    *eps = *e / c;
    *eps_dot = (*ux * vx + *uy * vy) / c;
    *rate_t = (-*uy * vx + *ux * vy) / c;
}

static inline double mbs_film_torque(double e, double eps, double ft, double omega_j,
                                     double omega_b, double R, double c, double L, double mu) {
    double couette = -2.0 * MBS_PI * mu * R * R * R * L * (omega_j - omega_b) / (
        c * sqrt(1.0 - eps * eps));
    return couette - 0.5 * e * ft;
}

static inline void mbs_short_bearing(double ex, double ey, double vx, double vy,
                                     double omega_j, double omega_b, double R, double c,
                                     double L, double mu, double *fx, double *fy,
                                     double *torque) {
    double e, eps, ux, uy, eps_dot, rate_t;
    mbs_film_frame(ex, ey, vx, vy, c, &e, &eps, &ux, &uy, &eps_dot, &rate_t);
    double a = (omega_j + omega_b) * eps - 2.0 * rate_t;
    double b = 2.0 * eps_dot;
    if (a == 0.0 && b == 0.0) {
        *fx = 0.0;
        *fy = 0.0;
        *torque = mbs_film_torque(e, eps, 0.0, omega_j, omega_b, R, c, L, mu);
        return;
    }
    double alpha = atan2(b, a);
    double p1 = mbs_sommerfeld_angle(alpha, eps);
    double p2 = mbs_sommerfeld_angle(alpha + MBS_PI, eps);
    double sp2 = sin(p2), sp1 = sin(p1);
    double s1 = (0.5 * (sp2 * sp2 - sp1 * sp1) + eps * (cos(p2) - cos(p1)));
    double s2 = ((0.5 + eps * eps) * (p2 - p1) + 0.25 * (sin(2.0 * p2) - sin(2.0 * p1))
                 - 2.0 * eps * (sin(p2) - sin(p1)));
    double s3 = 0.5 * (p2 - p1) - 0.25 * (sin(2.0 * p2) - sin(2.0 * p1));
    double q = 1.0 - eps * eps;
    double s = sqrt(q);
    double k = R * mu * L * L * L / (2.0 * c * c);
    double fr = k * (a * s1 / (q * q) - b * s2 / (q * q * s));
    double ft = k * (a * s3 / (q * s) - b * s1 / (q * q));
    *fx = fr * ux - ft * uy;
    *fy = fr * uy + ft * ux;
    *torque = mbs_film_torque(e, eps, ft, omega_j, omega_b, R, c, L, mu);
}

static inline void mbs_long_pressure(double psi, double eps, double a1, double b1, double *g,
                                     double *dg) {
    double sp = sin(psi), cp = cos(psi);
    *g = (a1 * sp * (2.0 - eps * eps - eps * cp)
          + b1 * ((7.0 - 2.0 * eps * eps) * eps - (4.0 + 6.0 * eps * eps) * cp
                  + eps * (2.0 + 3.0 * eps * eps) * cp * cp));
    *dg = (a1 * (cp * (2.0 - eps * eps - eps * cp) + eps * sp * sp)
           + b1 * sp * ((4.0 + 6.0 * eps * eps) - 2.0 * eps * (2.0 + 3.0 * eps * eps) * cp));
}

/* the zero of the long film's pressure between lo and hi (a sign change) */
static inline double mbs_long_zero(double lo, double hi, double eps, double a1, double b1) {
    double glo, g, dg;
    mbs_long_pressure(lo, eps, a1, b1, &glo, &dg);
    double x = 0.5 * (lo + hi);
    for (int it = 0; it < 80; it++) {
        mbs_long_pressure(x, eps, a1, b1, &g, &dg);
        if (g == 0.0) return x;
        if ((g > 0.0) == (glo > 0.0)) lo = x;
        else hi = x;
        double step = dg != 0.0 ? x - g / dg : 0.5 * (lo + hi);
        if (!(lo < step && step < hi)) step = 0.5 * (lo + hi);
        if (fabs(step - x) <= 4e-16 * (1.0 + fabs(x)) || hi - lo <= 4e-16 * (1.0 + fabs(x)))
            return step;
        x = step;
    }
    return x;
}

static inline void mbs_long_integrals(double p1, double p2, double eps, double *i1,
                                      double *i2, double *i3, double *i4) {
    double s1 = sin(p1), c1 = cos(p1), s2 = sin(p2), c2 = cos(p2);
    *i1 = (s2 * s2 - eps * c2) - (s1 * s1 - eps * c1);
    *i2 = 0.5 * (p2 - p1) - 0.5 * (s2 * c2 - s1 * c1);
    *i3 = ((1.0 - eps * eps) * (p2 - p1) + (s2 * c2 - s1 * c1) - eps * (s2 - s1));
    *i4 = 0.5 * (s2 * s2 - s1 * s1) + eps * (c2 - c1);
}

/* the positive lobes of the long film's pressure: returns n (-1: all around, 0: none) */
static inline int64_t mbs_long_lobes(double eps, double a1, double b1, double *u1, double *d1,
                                     double *u2, double *d2) {
    int64_t n = 0;
    double dg;
    *u1 = *d1 = *u2 = *d2 = 0.0;
    double step = 2.0 * MBS_PI / MBS_LONG_SAMPLES;
    double g0;
    mbs_long_pressure(0.0, eps, a1, b1, &g0, &dg);
    double prev = g0;
    double up = -1.0;
    double first_down = -1.0;
    int crossed = 0;
    for (int64_t k = 1; k < MBS_LONG_SAMPLES + 1; k++) {
        double x = (double)k * step;
        double g = g0;
        if (k < MBS_LONG_SAMPLES) mbs_long_pressure(x, eps, a1, b1, &g, &dg);
        if ((prev > 0.0) != (g > 0.0)) {
            double z = mbs_long_zero(x - step, x, eps, a1, b1);
            crossed = 1;
            if (g > 0.0) {
                up = z;
            } else if (up >= 0.0) {
                if (n == 0) { *u1 = up; *d1 = z; }
                else { *u2 = up; *d2 = z; }
                n += 1;
                up = -1.0;
            } else {
                first_down = z;
            }
        }
        prev = g;
    }
    if (crossed && up >= 0.0 && first_down >= 0.0) {
        if (n == 0) { *u1 = up; *d1 = first_down + 2.0 * MBS_PI; }
        else { *u2 = up; *d2 = first_down + 2.0 * MBS_PI; }
        n += 1;
    } else if (!crossed && g0 > 0.0) {
        *u1 = 0.0; *d1 = 2.0 * MBS_PI; *u2 = 0.0; *d2 = 0.0;
        return -1;
    }
    return n;
}

static inline void mbs_long_bearing(double ex, double ey, double vx, double vy,
                                    double omega_j, double omega_b, double R, double c,
                                    double L, double mu, double *fx, double *fy,
                                    double *torque) {
    double e, eps, ux, uy, eps_dot, rate_t;
    mbs_film_frame(ex, ey, vx, vy, c, &e, &eps, &ux, &uy, &eps_dot, &rate_t);
    double a = (omega_j + omega_b) * eps - 2.0 * rate_t;
    double q = 1.0 - eps * eps;
    double s = sqrt(q);
    double a1 = a / ((2.0 + eps * eps) * q * s);
    double b1 = eps_dot / ((2.0 + 3.0 * eps * eps) * q * q);
    double u1, d1, u2, d2, i1, i2, i3, i4;
    int64_t n = mbs_long_lobes(eps, a1, b1, &u1, &d1, &u2, &d2);
    double j1 = 0.0, j2 = 0.0, j3 = 0.0, j4 = 0.0;
    if (n == -1) mbs_long_integrals(u1, d1, eps, &j1, &j2, &j3, &j4);
    if (n >= 1) {
        mbs_long_integrals(u1, d1, eps, &i1, &i2, &i3, &i4);
        j1 = j1 + i1; j2 = j2 + i2; j3 = j3 + i3; j4 = j4 + i4;
    }
    if (n >= 2) {
        mbs_long_integrals(u2, d2, eps, &i1, &i2, &i3, &i4);
        j1 = j1 + i1; j2 = j2 + i2; j3 = j3 + i3; j4 = j4 + i4;
    }
    double k6 = 6.0 * mu * R * R * R * L / (c * c);
    double fr = -k6 * (a * j1 / ((2.0 + eps * eps) * q) + 2.0 * eps_dot * j2 / (q * s));
    double ft = k6 * (a * j3 / ((2.0 + eps * eps) * q * s) + 2.0 * eps_dot * j4 / (q * q));
    *fx = fr * ux - ft * uy;
    *fy = fr * uy + ft * ux;
    *torque = mbs_film_torque(e, eps, ft, omega_j, omega_b, R, c, L, mu);
}

/* (w, dw/deps): the film's weight, the quintic smooth step between start and end */
static inline void mbs_film_fade(double eps, double start, double end, double *w,
                                 double *dw) {
    if (eps <= start) { *w = 1.0; *dw = 0.0; return; }
    if (eps >= end) { *w = 0.0; *dw = 0.0; return; }
    double width = end - start;
    double s = (eps - start) / width;
    *w = 1.0 - s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
    *dw = -30.0 * s * s * (1.0 - s) * (1.0 - s) / width;
}

/* (Fx, Fy, T, w): the faded film's force on the journal centre, torque on the journal and
 * the weight, of film law id `model` (0 short, 1 long) */
static inline void mbs_lubricated_force(double ex, double ey, double vx, double vy,
                                        double omega_j, double omega_b, double R, double c,
                                        double L, double mu, int64_t model, double start,
                                        double end, double *fx, double *fy, double *torque,
                                        double *w) {
    double eps = pow(ex * ex + ey * ey, 0.5) / c;
    double dw;
    mbs_film_fade(eps, start, end, w, &dw);
    if (*w == 0.0) {
        *fx = 0.0; *fy = 0.0; *torque = 0.0; *w = 0.0;
        return;
    }
    double gx, gy, gt;
    if (model == 1) mbs_long_bearing(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, &gx, &gy, &gt);
    else mbs_short_bearing(ex, ey, vx, vy, omega_j, omega_b, R, c, L, mu, &gx, &gy, &gt);
    *fx = *w * gx;
    *fy = *w * gy;
    *torque = *w * gt;
}

/* contact_stage of a joint in an oil film: (F, delta, deltadot, fx, fy, tj, tb, ffx, ffy,
 * power), see generate/runtime.py */
static inline void lubricated_stage(double ex, double ey, double exd, double eyd,
                                    double omega_j, double omega_b, double clearance,
                                    double mode, double deltadot_minus, double stiffness,
                                    double restitution, double model, double lubrication,
                                    double viscosity, double length, double journal_radius,
                                    double fade_start, double fade_end, double *F,
                                    double *delta, double *deltadot, double *fx, double *fy,
                                    double *tj, double *tb, double *ffx, double *ffy,
                                    double *power) {
    double cfx, cfy, w;
    contact_stage(ex, ey, exd, eyd, clearance, mode, deltadot_minus, stiffness, restitution,
                  model, F, delta, deltadot, &cfx, &cfy);
    mbs_lubricated_force(ex, ey, exd, eyd, omega_j, omega_b, journal_radius, clearance,
                         length, viscosity, (int64_t)lubrication, fade_start, fade_end, ffx,
                         ffy, tj, &w);
    *tb = -*tj - (ex * *ffy - ey * *ffx);
    *power = (*ffx * (exd + omega_b * ey) + *ffy * (eyd - omega_b * ex)
              + *tj * (omega_j - omega_b));
    *fx = cfx - *ffx;
    *fy = cfy - *ffy;
}

#endif
