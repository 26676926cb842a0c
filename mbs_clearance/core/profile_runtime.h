/* The contact stages of a clearance joint with a profiled bearing (model/profile.py): the
 * bearing's radius R_B(theta) is a periodic cubic spline on N equal pieces, read from a block
 * of the parameter vector (generate/profiles.py: R_J, eq9, E, nu, R_ref, rho0, rho1, then the
 * pieces c0..c3 of each). Small-wear approximation: the contact lies along the eccentricity's
 * direction theta_e (in the bearing body's frame), the penetration is
 * |e| - (R_B(theta_e) - R_J) and the normal stays radial. Included by the models of profiled joints only, after runtime.h. */
#ifndef MBS_PROFILE_RUNTIME_H
#define MBS_PROFILE_RUNTIME_H

#include <math.h>
#include <stdint.h>

#define MBS_PROFILE_HEAD 7

/* the paper's Eq. 9 (laws/forces.py stiffness_eq9, same order of operations) */
static inline double mbs_stiffness_eq9(double rj, double rb, double e, double nu) {
    double h = (1.0 - nu * nu) / (MBS_PI * e);
    return 4.0 / (3.0 * MBS_PI * 2.0 * h) * sqrt(rj * rb / (rb - rj));
}

/* R_B (m) and dR_B/dtheta (m/rad) of the spline pieces c[4 n] at theta (rad, any value) */
static inline void mbs_profile_radius(const double *c, int64_t n, double theta, double *r,
                                      double *dr) {
    const double two_pi = 2.0 * MBS_PI;
    double th = fmod(theta, two_pi);
    if (th < 0.0) th += two_pi;
    int64_t i = (int64_t)floor(th * (double)n / two_pi);
    /* at the wrap: th within round-off of 2 pi belongs to the last piece */
    if (i < 0) i = 0;
    if (i >= n) i = n - 1;
    double u = th - two_pi * (double)i / (double)n;
    const double *ci = c + 4 * i;
    *r = ci[0] + u * (ci[1] + u * (ci[2] + u * ci[3]));
    *dr = ci[1] + u * (2.0 * ci[2] + 3.0 * u * ci[3]);
}

/* (delta, deltadot, nx, ny, R_B, slope) of a profiled joint: e and its rate, the bearing body's
 * angle phi and rate omega, the profile's block prof with n pieces. Near the centre, where
 * theta_e turns fast and no contact can be (|e| below half the smallest clearance), the
 * profile fades into the circle of radius R_ref (a quintic step in |e| between rho0 and
 * rho1): the gap stays smooth there, so the error control of the penetration does not
 * shrink the steps of a journal passing the centre. slope = R_B'(theta_e) / |e| (1/rad): the
 * gap's gradient in e is n - slope t, t = (-ny, nx) */
static inline void mbs_profile_gap(double ex, double ey, double exd, double eyd, double phi,
                                   double omega, const double *prof, int64_t n, double *delta,
                                   double *deltadot, double *nx, double *ny, double *rb,
                                   double *slope) {
    const double r_ref = prof[4], rho0 = prof[5], rho1 = prof[6];
    double r = sqrt(ex * ex + ey * ey);
    if (r > 1e-300) {
        double inv_r = 1.0 / r;
        *nx = ex * inv_r;
        *ny = ey * inv_r;
    } else {
        *nx = -1.0;
        *ny = 0.0;
    }
    double rdot = *nx * exd + *ny * eyd;
    *slope = 0.0;
    if (r <= rho0) {
        *rb = r_ref;
        *delta = r - (r_ref - prof[0]);
        *deltadot = rdot;
        return;
    }
    double turn = (ex * eyd - ey * exd) / (r * r) - omega;     /* d theta_e / dt */
    double R, dR;
    mbs_profile_radius(prof + MBS_PROFILE_HEAD, n, atan2(ey, ex) - phi, &R, &dR);
    if (r >= rho1) {
        *rb = R;
        *slope = dR / r;
        *delta = r - (R - prof[0]);
        *deltadot = rdot - dR * turn;
        return;
    }
    double width = rho1 - rho0;
    double s = (r - rho0) / width;
    double w = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
    double dw = 30.0 * s * s * (1.0 - s) * (1.0 - s) / width;
    *rb = r_ref + w * (R - r_ref);
    *slope = w * dR / r;
    *delta = r - (*rb - prof[0]);
    *deltadot = rdot - (dw * rdot * (R - r_ref) + w * dR * turn);
}

/* the contact stiffness at the contact: Eq. 9 with R_B(theta_e) when the block says so (not
 * the local radius of curvature: a worn groove conforming to the journal sends Eq. 9 to
 * infinity), else the joint's constant stiffness */
static inline double mbs_profile_stiffness(const double *prof, double rb, double stiffness) {
    return prof[1] > 0.5 ? mbs_stiffness_eq9(prof[0], rb, prof[2], prof[3]) : stiffness;
}

/* the normal force of a profiled joint: (F, delta, deltadot, nx, ny, gx, gy, R_B) with
 * (gx, gy) = n - slope t, the direction of the force F on the bearing (F n + F slope
 * (ny, -nx)), not n: the journal centre's boundary |e| = R_B(theta) - R_J leans from the
 * circle by R_B' / |e|, comparable to 1 when the profile's slope (m/rad) is comparable to the
 * clearance, and a radial force on it does work around a closed path (a journal orbiting in
 * a non-round bearing gains energy without bound). Its moment about the bearing centre,
 * -F R_B' (the profile's torque on the bearing), a turning bearing body misses (the model
 * applies the forces at the centres) */
static inline void mbs_profile_normal(double ex, double ey, double exd, double eyd,
                                      double phi, double omega, double mode,
                                      double deltadot_minus, double stiffness,
                                      double restitution, double model, const double *prof,
                                      int64_t n, double *F, double *delta, double *deltadot,
                                      double *nx, double *ny, double *gx, double *gy,
                                      double *rb) {
    double k;
    mbs_profile_gap(ex, ey, exd, eyd, phi, omega, prof, n, delta, deltadot, nx, ny, rb, &k);
    *F = 0.0;
    if (mode > 0.5)
        *F = mbs_contact_force(*delta, *deltadot, deltadot_minus,
                               mbs_profile_stiffness(prof, *rb, stiffness), restitution,
                               (int64_t)model);
    *gx = *nx + k * *ny;
    *gy = *ny - k * *nx;
}

/* contact_stage of a profiled joint: (F, delta, deltadot, fx, fy) */
static inline void profile_contact_stage(double ex, double ey, double exd, double eyd,
                                         double phi, double omega, double mode,
                                         double deltadot_minus, double stiffness,
                                         double restitution, double model, const double *prof,
                                         int64_t n, double *F, double *delta, double *deltadot,
                                         double *fx, double *fy) {
    double nx, ny, gx, gy, rb;
    mbs_profile_normal(ex, ey, exd, eyd, phi, omega, mode, deltadot_minus, stiffness,
                       restitution, model, prof, n, F, delta, deltadot, &nx, &ny, &gx, &gy,
                       &rb);
    *fx = *F * gx;
    *fy = *F * gy;
}

/* friction_stage of a profiled joint: (F, delta, deltadot, fx, fy, ft, vt); spin is
 * omega_J R_J - omega_B bearing_radius, corrected here to the radius at the contact (the
 * moment of friction on the bearing keeps the arm bearing_radius: a difference of the wear
 * depth); the friction acts along t */
static inline void profile_friction_stage(double ex, double ey, double exd, double eyd,
                                          double spin, double phi, double omega,
                                          double bearing_radius, double mode,
                                          double deltadot_minus, double stiffness,
                                          double restitution, double model, double law,
                                          const double *slots, const double *prof, int64_t n,
                                          double *F, double *delta, double *deltadot,
                                          double *fx, double *fy, double *ft, double *vt) {
    double nx, ny, gx, gy, rb;
    mbs_profile_normal(ex, ey, exd, eyd, phi, omega, mode, deltadot_minus, stiffness,
                       restitution, model, prof, n, F, delta, deltadot, &nx, &ny, &gx, &gy,
                       &rb);
    double v = eyd * nx - exd * ny + spin + omega * (bearing_radius - rb);
    double f = mbs_friction_force_slots(v, *F, slots, (int64_t)law);
    *fx = *F * gx + f * ny;
    *fy = *F * gy - f * nx;
    *ft = f;
    *vt = v;
}

#endif
