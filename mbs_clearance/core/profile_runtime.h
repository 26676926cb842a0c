/* The contact stages of a clearance joint with a profiled bearing (model/profile.py): the
 * bearing's radius R_B(theta) is a periodic cubic spline on N equal pieces, read from a block
 * of the parameter vector (generate/profiles.py: R_J, eq9, E, nu, then the pieces c0..c3 of
 * each). Small-wear approximation: the contact lies along the eccentricity's direction
 * theta_e (in the bearing body's frame), the penetration is |e| - (R_B(theta_e) - R_J) and the
 * normal stays radial. Included by the models of profiled joints only, after runtime.h. */
#ifndef MBS_PROFILE_RUNTIME_H
#define MBS_PROFILE_RUNTIME_H

#include <math.h>
#include <stdint.h>

#define MBS_PROFILE_HEAD 4

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

/* (delta, deltadot, nx, ny, R_B(theta_e)) of a profiled joint: e and its rate, the bearing
 * body's angle phi and rate omega, the profile's block prof with n pieces */
static inline void mbs_profile_gap(double ex, double ey, double exd, double eyd, double phi,
                                   double omega, const double *prof, int64_t n, double *delta,
                                   double *deltadot, double *nx, double *ny, double *rb) {
    double r = sqrt(ex * ex + ey * ey);
    double turn = 0.0;          /* d theta_e / dt */
    if (r > 1e-300) {
        double inv_r = 1.0 / r;
        *nx = ex * inv_r;
        *ny = ey * inv_r;
        turn = (ex * eyd - ey * exd) * inv_r * inv_r - omega;
    } else {
        *nx = -1.0;
        *ny = 0.0;
    }
    double dr;
    mbs_profile_radius(prof + MBS_PROFILE_HEAD, n, atan2(ey, ex) - phi, rb, &dr);
    *delta = r - (*rb - prof[0]);
    *deltadot = *nx * exd + *ny * eyd - dr * turn;
}

/* the contact stiffness at the contact: Eq. 9 with R_B(theta_e) when the block says so (not
 * the local radius of curvature: a worn groove conforming to the journal sends Eq. 9 to
 * infinity), else the joint's constant stiffness */
static inline double mbs_profile_stiffness(const double *prof, double rb, double stiffness) {
    return prof[1] > 0.5 ? mbs_stiffness_eq9(prof[0], rb, prof[2], prof[3]) : stiffness;
}

/* contact_stage of a profiled joint: (F, delta, deltadot, fx, fy) */
static inline void profile_contact_stage(double ex, double ey, double exd, double eyd,
                                         double phi, double omega, double mode,
                                         double deltadot_minus, double stiffness,
                                         double restitution, double model, const double *prof,
                                         int64_t n, double *F, double *delta, double *deltadot,
                                         double *fx, double *fy) {
    double nx, ny, rb;
    mbs_profile_gap(ex, ey, exd, eyd, phi, omega, prof, n, delta, deltadot, &nx, &ny, &rb);
    double f = 0.0;
    if (mode > 0.5)
        f = mbs_contact_force(*delta, *deltadot, deltadot_minus,
                              mbs_profile_stiffness(prof, rb, stiffness), restitution,
                              (int64_t)model);
    *F = f;
    *fx = f * nx;
    *fy = f * ny;
}

/* friction_stage of a profiled joint: (F, delta, deltadot, fx, fy, ft, vt); spin is
 * omega_J R_J - omega_B bearing_radius, corrected here to the radius at the contact (the
 * moment of friction on the bearing keeps the arm bearing_radius: a difference of the wear
 * depth) */
static inline void profile_friction_stage(double ex, double ey, double exd, double eyd,
                                          double spin, double phi, double omega,
                                          double bearing_radius, double mode,
                                          double deltadot_minus, double stiffness,
                                          double restitution, double model, double law,
                                          const double *slots, const double *prof, int64_t n,
                                          double *F, double *delta, double *deltadot,
                                          double *fx, double *fy, double *ft, double *vt) {
    double nx, ny, rb;
    mbs_profile_gap(ex, ey, exd, eyd, phi, omega, prof, n, delta, deltadot, &nx, &ny, &rb);
    double fn = 0.0;
    if (mode > 0.5)
        fn = mbs_contact_force(*delta, *deltadot, deltadot_minus,
                               mbs_profile_stiffness(prof, rb, stiffness), restitution,
                               (int64_t)model);
    double v = eyd * nx - exd * ny + spin + omega * (bearing_radius - rb);
    double f = mbs_friction_force_slots(v, fn, slots, (int64_t)law);
    *F = fn;
    *fx = fn * nx + f * ny;
    *fy = fn * ny - f * nx;
    *ft = f;
    *vt = v;
}

#endif
