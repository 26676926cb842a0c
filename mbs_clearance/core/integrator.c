/* The compiled integrator (plain C99): adaptive embedded Runge-Kutta pairs (dopri5, dop853,
 * bs3) and a linearly implicit Rosenbrock method (rodas4), with dense output, event location
 * and landing, and the refinement of each window's peak of the monitored scalar.
 *
 * The floating-point operations keep one fixed order (the integrator was ported from a
 * Python implementation and checked bitwise against it; the functions keep its names), so
 * that a run's numbers do not depend on the compiler's choices. Built without -ffast-math: the event search and the error
 * control rely on IEEE semantics (NaN tests, no reassociation, no contraction to FMA).
 *
 * min and max are Python's builtins: max(a, b) is b if b > a else a, so a NaN
 * in the second place is dropped and in the first place kept (`nb_max`, `nb_min`).
 *
 * Arrays: K is (K_rows, n) row-major with row stride ldk = n (the full state); a function
 * working on the leading n_dense components takes that length as `n` and the stride apart.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include "mbs_core.h"

#define SMALL 8
#define STATUS_MAX_STEPS 1
#define STATUS_STEP_UNDERFLOW 2
#define STATUS_EVENT_CHATTER 3
#define STATUS_OUT_OF_MEMORY (-1)
#define STATUS_BAD_ARGUMENT (-2)

/* the stages of a long state (a sensitivity run's) in AVX2 where the processor has it (one
 * copy per instruction set, chosen when the library loads): the same operations in the same
 * order (no contraction to FMA, no reassociation), wider registers; a DDM run of the paper's
 * case spends a sixth of its time here */
#if defined(__x86_64__) && defined(__ELF__) && defined(__GNUC__) && __GNUC__ >= 6 \
    && !defined(__clang__)
#define MBS_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define MBS_VECTOR_CLONES
#endif

static inline double nb_max(double a, double b) { return b > a ? b : a; }
static inline double nb_min(double a, double b) { return b < a ? b : a; }

/* float ** int (exponentiation by squaring, 1 / r for a negative exponent) */
static double int_power(double a, int64_t b)
{
    double r = 1.0;
    int invert = b < 0;
    int64_t e = invert ? -b : b;
    while (e != 0) {
        if (e & 1)
            r *= a;
        e >>= 1;
        a *= a;
    }
    return invert ? 1.0 / r : r;
}

/* ---- the method's coefficients ---- */

typedef struct {
    const mbs_model *m;
    const mbs_tableau *tb;
    int64_t ldk;     /* row stride of K (the full state length) */
    int64_t k_rows;  /* rows of K */
    int64_t s;       /* B's length */
    int rosenbrock;
    int64_t n_out;   /* outputs the monitor writes (settings) */
} run_ctx;

static inline double A_at(const mbs_tableau *tb, int64_t i, int64_t j)
{
    return tb->A[i * tb->a_cols + j];
}

/* _combine: out = y + h * sum_{j < n_terms} coef[j] K[j] */
static void combine(const double *y, int64_t n, double h, const double *K, int64_t ldk,
                    const double *coef, int64_t n_terms, double *out)
{
    for (int64_t k = 0; k < n; k++)
        out[k] = y[k];
    for (int64_t j = 0; j < n_terms; j++) {
        double c = h * coef[j];
        if (c != 0.0) {
            const double *Kj = K + j * ldk;
            for (int64_t k = 0; k < n; k++)
                out[k] += c * Kj[k];
        }
    }
}

/* _lu: LU factors (partial pivoting) of the n x n matrix in rows r0.. of M, in place */
static void lu(double *M, int64_t ldk, int64_t r0, int64_t n, double *piv)
{
    for (int64_t k = 0; k < n; k++) {
        double big = fabs(M[(r0 + k) * ldk + k]);
        int64_t q = k;
        for (int64_t i = k + 1; i < n; i++) {
            if (fabs(M[(r0 + i) * ldk + k]) > big) {
                big = fabs(M[(r0 + i) * ldk + k]);
                q = i;
            }
        }
        piv[k] = (double)q;
        if (q != k) {
            for (int64_t c = 0; c < n; c++) {
                double tmp = M[(r0 + k) * ldk + c];
                M[(r0 + k) * ldk + c] = M[(r0 + q) * ldk + c];
                M[(r0 + q) * ldk + c] = tmp;
            }
        }
        double d = M[(r0 + k) * ldk + k];
        if (d != 0.0) {
            for (int64_t i = k + 1; i < n; i++) {
                M[(r0 + i) * ldk + k] /= d;
                double li = M[(r0 + i) * ldk + k];
                if (li != 0.0) {
                    for (int64_t c = k + 1; c < n; c++)
                        M[(r0 + i) * ldk + c] -= li * M[(r0 + k) * ldk + c];
                }
            }
        }
    }
}

/* _lu_solve: x = (LU)^-1 x, in place */
static void lu_solve(const double *M, int64_t ldk, int64_t r0, int64_t n, const double *piv,
                     double *x)
{
    for (int64_t k = 0; k < n; k++) {
        int64_t q = (int64_t)piv[k];
        if (q != k) {
            double tmp = x[k];
            x[k] = x[q];
            x[q] = tmp;
        }
    }
    for (int64_t i = 1; i < n; i++) {
        double acc = x[i];
        for (int64_t c = 0; c < i; c++)
            acc -= M[(r0 + i) * ldk + c] * x[c];
        x[i] = acc;
    }
    for (int64_t i = n - 1; i >= 0; i--) {
        double acc = x[i];
        for (int64_t c = i + 1; c < n; c++)
            acc -= M[(r0 + i) * ldk + c] * x[c];
        x[i] = acc / M[(r0 + i) * ldk + i];
    }
}

/* sqrt(eps): the relative step of the central differences of J and df/dt */
#define FD_STEP 1.4901161193847656e-08

/* _ros_stages: the stages of one Rosenbrock step */
static void ros_stages(const run_ctx *cx, double t, const double *y, int64_t n, const double *f,
                       double h, double *K, double *p, double *y_new, double *ytmp)
{
    const mbs_tableau *tb = cx->tb;
    const mbs_rhs_fn rhs_fn = cx->m->rhs;
    const int64_t ldk = cx->ldk;
    const int64_t s1 = tb->n_b;
    const int64_t w0 = s1 + 1;
    const int64_t r_ft = w0 + n;
    const int64_t r_piv = r_ft + 1;
    const int64_t r_tmp = r_piv + 1;
    const int64_t ncol = tb->a_cols;
    const double gamma = A_at(tb, 0, ncol - 1);
    double *Kft = K + r_ft * ldk, *Ktmp = K + r_tmp * ldk, *Kpiv = K + r_piv * ldk;
    for (int64_t k = 0; k < n; k++) {
        K[k] = f[k];
        ytmp[k] = y[k];
    }
    for (int64_t c = 0; c < n; c++) {
        double d = FD_STEP * nb_max(1e-5, fabs(y[c]));
        ytmp[c] = y[c] + d;
        d = ytmp[c] - y[c];
        rhs_fn(t, ytmp, n, p, Ktmp);
        ytmp[c] = y[c] - d;
        rhs_fn(t, ytmp, n, p, Kft);
        ytmp[c] = y[c];
        for (int64_t r = 0; r < n; r++)
            K[(w0 + r) * ldk + c] = -(Ktmp[r] - Kft[r]) / (2.0 * d);
    }
    double diag = 1.0 / (h * gamma);
    for (int64_t r = 0; r < n; r++)
        K[(w0 + r) * ldk + r] += diag;
    double dt = FD_STEP * nb_max(1e-5, fabs(t));
    dt = (t + dt) - t;
    rhs_fn(t + dt, y, n, p, Kft);
    rhs_fn(t - dt, y, n, p, Ktmp);
    for (int64_t r = 0; r < n; r++)
        Kft[r] = (Kft[r] - Ktmp[r]) / (2.0 * dt);
    lu(K, ldk, w0, n, Kpiv);
    const int64_t cc = s1;
    for (int64_t i = 1; i < s1; i++) {
        double *Ki = K + i * ldk;
        if (i == 1) {
            for (int64_t k = 0; k < n; k++)
                Ki[k] = f[k];
        } else {
            combine(y, n, h, K, ldk, tb->A + i * ncol, i, ytmp);
            rhs_fn(t + tb->C[i] * h, ytmp, n, p, Ki);
        }
        double hg = h * A_at(tb, i, ncol - 2);
        for (int64_t k = 0; k < n; k++) {
            double acc = Ki[k] + hg * Kft[k];
            for (int64_t j = 1; j < i; j++)
                acc += A_at(tb, i, cc + j) * K[j * ldk + k];
            Ktmp[k] = acc;
        }
        lu_solve(K, ldk, w0, n, Kpiv, Ktmp);
        for (int64_t k = 0; k < n; k++)
            Ki[k] = Ktmp[k] / h;
    }
    combine(y, n, h, K, ldk, tb->B, s1, y_new);
}

/* rk_stages: the stages of one step but the last; fills K[:s] and y_new */
MBS_VECTOR_CLONES
static void rk_stages(const run_ctx *cx, double t, const double *y, int64_t n, const double *f,
                      double h, double *K, double *p, double *y_new, double *ytmp)
{
    if (cx->rosenbrock) {
        ros_stages(cx, t, y, n, f, h, K, p, y_new, ytmp);
        return;
    }
    const mbs_tableau *tb = cx->tb;
    const int64_t s = tb->n_b, ldk = cx->ldk;
    for (int64_t k = 0; k < n; k++)
        K[k] = f[k];
    for (int64_t i = 1; i < s; i++) {
        combine(y, n, h, K, ldk, tb->A + i * tb->a_cols, i, ytmp);
        cx->m->rhs(t + tb->C[i] * h, ytmp, n, p, K + i * ldk);
    }
    combine(y, n, h, K, ldk, tb->B, s, y_new);
}

/* rk_step: one step; fills K (stages, FSAL row), y_new and f_new */
static void rk_step(const run_ctx *cx, double t, const double *y, int64_t n, const double *f,
                    double h, double *K, double *p, double *y_new, double *f_new,
                    double *ytmp)
{
    rk_stages(cx, t, y, n, f, h, K, p, y_new, ytmp);
    cx->m->rhs(t + h, y_new, n, p, f_new);
    memcpy(K + cx->s * cx->ldk, f_new, (size_t)n * sizeof(double));
}

/* _step_monitor: rk_step with the monitor as its last stage. f_new has the full length
 * (ldk) in every caller, and all of it is copied into the FSAL row. */
static double step_monitor(const run_ctx *cx, double t, const double *y, int64_t n,
                           const double *f, double h, double *K, double *p, double *y_new,
                           double *f_new, double *ytmp, double *out, double *g, double *gd)
{
    rk_stages(cx, t, y, n, f, h, K, p, y_new, ytmp);
    double mval = cx->m->monitor(t + h, y_new, n, p, f_new, out, cx->n_out, g, gd);
    memcpy(K + cx->s * cx->ldk, f_new, (size_t)cx->ldk * sizeof(double));
    return mval;
}

/* dopri5's coefficients as constants (the same floats as the Python table: each a correctly
 * rounded quotient of two integers) */
static const double A21 = 1.0 / 5.0;
static const double A31 = 3.0 / 40.0, A32 = 9.0 / 40.0;
static const double A41 = 44.0 / 45.0, A42 = -56.0 / 15.0, A43 = 32.0 / 9.0;
static const double A51 = 19372.0 / 6561.0, A52 = -25360.0 / 2187.0, A53 = 64448.0 / 6561.0,
                    A54 = -212.0 / 729.0;
static const double A61 = 9017.0 / 3168.0, A62 = -355.0 / 33.0, A63 = 46732.0 / 5247.0,
                    A64 = 49.0 / 176.0, A65 = -5103.0 / 18656.0;
static const double B1 = 35.0 / 384.0, B2 = 0.0, B3 = 500.0 / 1113.0, B4 = 125.0 / 192.0,
                    B5 = -2187.0 / 6784.0, B6 = 11.0 / 84.0;
static const double C2 = 1.0 / 5.0, C3 = 3.0 / 10.0, C4 = 4.0 / 5.0, C5 = 8.0 / 9.0, C6 = 1.0;
static const double E1 = -71.0 / 57600.0, E2 = 0.0, E3 = 71.0 / 16695.0, E4 = -71.0 / 1920.0,
                    E5 = 17253.0 / 339200.0, E6 = -22.0 / 525.0, E7 = 1.0 / 40.0;

/* _is_dopri5 */
static int is_dopri5(const mbs_tableau *tb)
{
    if (tb->a_rows != 6 || tb->a_cols < 5 || tb->n_b != 6 || tb->n_c != 6 || tb->n_e != 7
        || tb->n_e2 != 0 || tb->x_rows != 0)
        return 0;
    const double *B = tb->B, *C = tb->C, *E = tb->E;
    int lower = (A_at(tb, 1, 0) == A21 && A_at(tb, 2, 0) == A31 && A_at(tb, 2, 1) == A32
                 && A_at(tb, 3, 0) == A41 && A_at(tb, 3, 1) == A42 && A_at(tb, 3, 2) == A43
                 && A_at(tb, 4, 0) == A51 && A_at(tb, 4, 1) == A52 && A_at(tb, 4, 2) == A53
                 && A_at(tb, 4, 3) == A54 && A_at(tb, 5, 0) == A61 && A_at(tb, 5, 1) == A62
                 && A_at(tb, 5, 2) == A63 && A_at(tb, 5, 3) == A64 && A_at(tb, 5, 4) == A65);
    int weights = (B[0] == B1 && B[1] == B2 && B[2] == B3 && B[3] == B4 && B[4] == B5
                   && B[5] == B6 && C[1] == C2 && C[2] == C3 && C[3] == C4 && C[4] == C5
                   && C[5] == C6);
    int errors = (E[0] == E1 && E[1] == E2 && E[2] == E3 && E[3] == E4 && E[4] == E5
                  && E[5] == E6 && E[6] == E7);
    return lower && weights && errors && B2 == 0.0 && E2 == 0.0;
}

/* _dp5_step_monitor: dopri5's step written out (coefficients as constants, each component
 * summed in one expression, in the order and with the products h a_ij of `combine`) */
static double dp5_step_monitor(const run_ctx *cx, double t, const double *y, int64_t n,
                               const double *f, double h, double *K, double *p, double *y_new,
                               double *f_new, double *ytmp, double *out, double *g, double *gd)
{
    const mbs_rhs_fn rhs_fn = cx->m->rhs;
    const int64_t ldk = cx->ldk;
    double *K0 = K, *K1 = K + ldk, *K2 = K + 2 * ldk, *K3 = K + 3 * ldk, *K4 = K + 4 * ldk,
           *K5 = K + 5 * ldk, *K6 = K + 6 * ldk;
    for (int64_t k = 0; k < n; k++)
        K0[k] = f[k];
    double c1 = h * A21;
    for (int64_t k = 0; k < n; k++)
        ytmp[k] = y[k] + c1 * K0[k];
    rhs_fn(t + C2 * h, ytmp, n, p, K1);
    c1 = h * A31;
    double c2 = h * A32;
    for (int64_t k = 0; k < n; k++)
        ytmp[k] = y[k] + c1 * K0[k] + c2 * K1[k];
    rhs_fn(t + C3 * h, ytmp, n, p, K2);
    c1 = h * A41;
    c2 = h * A42;
    double c3 = h * A43;
    for (int64_t k = 0; k < n; k++)
        ytmp[k] = y[k] + c1 * K0[k] + c2 * K1[k] + c3 * K2[k];
    rhs_fn(t + C4 * h, ytmp, n, p, K3);
    c1 = h * A51;
    c2 = h * A52;
    c3 = h * A53;
    double c4 = h * A54;
    for (int64_t k = 0; k < n; k++)
        ytmp[k] = y[k] + c1 * K0[k] + c2 * K1[k] + c3 * K2[k] + c4 * K3[k];
    rhs_fn(t + C5 * h, ytmp, n, p, K4);
    c1 = h * A61;
    c2 = h * A62;
    c3 = h * A63;
    c4 = h * A64;
    double c5 = h * A65;
    for (int64_t k = 0; k < n; k++)
        ytmp[k] = y[k] + c1 * K0[k] + c2 * K1[k] + c3 * K2[k] + c4 * K3[k] + c5 * K4[k];
    rhs_fn(t + C6 * h, ytmp, n, p, K5);
    c1 = h * B1;
    c3 = h * B3; /* b2 = 0: skipped, as `combine` skips it */
    c4 = h * B4;
    c5 = h * B5;
    double c6 = h * B6;
    for (int64_t k = 0; k < n; k++)
        y_new[k] = y[k] + c1 * K0[k] + c3 * K2[k] + c4 * K3[k] + c5 * K4[k] + c6 * K5[k];
    double mval = cx->m->monitor(t + h, y_new, n, p, f_new, out, cx->n_out, g, gd);
    for (int64_t k = 0; k < n; k++)
        K6[k] = f_new[k];
    return mval;
}

/* _dp5_error: dopri5's error norm; leaves E.K in work */
static double dp5_error(const double *K, int64_t ldk, double h, const double *y,
                        const double *y_new, double rtol, const double *atol, int64_t n_err,
                        double *work)
{
    const double *K0 = K, *K2 = K + 2 * ldk, *K3 = K + 3 * ldk, *K4 = K + 4 * ldk,
                 *K5 = K + 5 * ldk, *K6 = K + 6 * ldk;
    double acc = 0.0;
    for (int64_t k = 0; k < n_err; k++) {
        double w = (0.0 + E1 * K0[k] + E3 * K2[k] + E4 * K3[k] + E5 * K4[k] + E6 * K5[k]
                    + E7 * K6[k]);
        work[k] = w;
        double scale = atol[k] + rtol * nb_max(fabs(y[k]), fabs(y_new[k]));
        double q = w / scale;
        acc += q * q;
    }
    return fabs(h) * sqrt(acc / (double)n_err);
}

/* _event_error_sq */
static double event_error_sq(const run_ctx *cx, double t, double h, const double *y_new,
                             int64_t n, double *p, const double *work, const double *g,
                             const double *gd, int64_t n_ev, double rtol, const double *atol,
                             int64_t n_err, double *yhat)
{
    for (int64_t k = 0; k < n; k++)
        yhat[k] = k < n_err ? y_new[k] - h * work[k] : y_new[k];
    double acc = 0.0;
    double ggd[2];
    for (int64_t j = 0; j < n_ev; j++) {
        cx->m->event(t, yhat, p, j, ggd);
        double eg = (g[j] - ggd[0]) / (atol[n + 2 * j] + rtol * fabs(g[j]));
        double egd = (gd[j] - ggd[1]) / (atol[n + 2 * j + 1] + rtol * fabs(gd[j]));
        acc += eg * eg + egd * egd;
    }
    return acc;
}

/* _weighted_rows: out[:n] = sum_j E[j] K[j, :n] */
static void weighted_rows(const double *K, int64_t ldk, const double *E, int64_t n_e,
                          int64_t n, double *out)
{
    for (int64_t k = 0; k < n; k++)
        out[k] = 0.0;
    for (int64_t j = 0; j < n_e; j++) {
        double c = E[j];
        if (c != 0.0) {
            const double *Kj = K + j * ldk;
            for (int64_t k = 0; k < n; k++)
                out[k] += c * Kj[k];
        }
    }
}

/* error_norm */
static double error_norm(const run_ctx *cx, const double *K, double h, const double *y,
                         const double *y_new, double rtol, const double *atol, int64_t n_err,
                         double *work, double *work2)
{
    const mbs_tableau *tb = cx->tb;
    int two = tb->n_e2 > 0;
    weighted_rows(K, cx->ldk, tb->E, tb->n_e, n_err, work);
    if (two)
        weighted_rows(K, cx->ldk, tb->E2, tb->n_e2, n_err, work2);
    double acc = 0.0, acc2 = 0.0;
    for (int64_t k = 0; k < n_err; k++) {
        double scale = atol[k] + rtol * nb_max(fabs(y[k]), fabs(y_new[k]));
        double q = work[k] / scale;
        acc += q * q;
        if (two) {
            double q2 = work2[k] / scale;
            acc2 += q2 * q2;
        }
    }
    if (!two)
        return fabs(h) * sqrt(acc / (double)n_err);
    if (acc == 0.0)
        return 0.0;
    return fabs(h) * acc / sqrt((acc + 0.01 * acc2) * (double)n_err);
}

/* _attempt: stages, monitor, error; returns the monitor, the error into *err */
static double attempt(const run_ctx *cx, double t, const double *y, int64_t n, const double *f,
                      double h, double *K, double *p, double *y_new, double *f_new,
                      double *ytmp, double *work, double *work2, double *out, double rtol,
                      const double *atol, int64_t n_atol, int64_t n_err, double *yhat,
                      double *g, double *gd, int64_t n_ev, int dp5, double *err)
{
    double mval, e;
    if (dp5) {
        mval = dp5_step_monitor(cx, t, y, n, f, h, K, p, y_new, f_new, ytmp, out, g, gd);
        e = dp5_error(K, cx->ldk, h, y, y_new, rtol, atol, n_err, work);
    } else {
        mval = step_monitor(cx, t, y, n, f, h, K, p, y_new, f_new, ytmp, out, g, gd);
        e = error_norm(cx, K, h, y, y_new, rtol, atol, n_err, work, work2);
    }
    double n_g = 2.0 * (double)n_ev;
    if (n_atol < n + 2 * n_ev) {
        *err = e;
        return mval;
    }
    double e1 = event_error_sq(cx, t + h, h, y_new, n, p, work, g, gd, n_ev, rtol, atol, n_err,
                               yhat);
    double err_ev;
    if (cx->tb->n_e2 == 0) {
        err_ev = sqrt(e1 / n_g);
    } else {
        double e2 = event_error_sq(cx, t + h, h, y_new, n, p, work2, g, gd, n_ev, rtol, atol,
                                   n_err, yhat);
        err_ev = e1 == 0.0 ? 0.0 : e1 / sqrt((e1 + 0.01 * e2) * n_g);
    }
    *err = nb_max(e, err_ev);
    return mval;
}

/* extra_stages: stages s+1.. of a continuous extension that needs them */
static void extra_stages(const run_ctx *cx, double t, const double *y, int64_t n, double h,
                         double *K, double *p, double *ytmp)
{
    const mbs_tableau *tb = cx->tb;
    const int64_t first = cx->k_rows - tb->x_rows;
    for (int64_t r = 0; r < tb->x_rows; r++) {
        combine(y, n, h, K, cx->ldk, tb->A_extra + r * tb->x_cols, first + r, ytmp);
        cx->m->rhs(t + tb->C_extra[r] * h, ytmp, n, p, K + (first + r) * cx->ldk);
    }
}

/* _dense_poly: sum_m P[j, m] theta^(m+1) */
static inline double dense_poly(const mbs_tableau *tb, int64_t j, double theta)
{
    double poly = 0.0, tp = theta;
    const double *Pj = tb->P + j * tb->p_cols;
    for (int64_t m = 0; m < tb->p_cols; m++) {
        poly += Pj[m] * tp;
        tp *= theta;
    }
    return poly;
}

/* _dense_combine: the state at theta from the weights polys[j] */
static void dense_combine(const run_ctx *cx, const double *y, int64_t n, double h,
                          const double *K, const double *polys, double *out, double *wts)
{
    const int64_t ns = cx->tb->p_rows;
    for (int64_t j = 0; j < ns; j++)
        wts[j] = h * polys[j];
    combine(y, n, 1.0, K, cx->ldk, wts, ns, out);
}

/* dense_eval: the state at t + theta h from the continuous extension */
static void dense_eval(const run_ctx *cx, const double *y, int64_t n, double h, const double *K,
                       double theta, double *out, double *wts)
{
    const int64_t ns = cx->tb->p_rows;
    for (int64_t j = 0; j < ns; j++)
        wts[j] = h * dense_poly(cx->tb, j, theta);
    combine(y, n, 1.0, K, cx->ldk, wts, ns, out);
}

/* initial_step: Hairer-Norsett-Wanner starting step size */
static double initial_step(const run_ctx *cx, double t, const double *y, int64_t n,
                           const double *f, double *p, double rtol, const double *atol,
                           int64_t order, double direction_span, double *ytmp, double *ftmp)
{
    double d0 = 0.0, d1 = 0.0;
    for (int64_t k = 0; k < n; k++) {
        double sc = atol[k] + rtol * fabs(y[k]);
        double a = y[k] / sc, b = f[k] / sc;
        d0 += a * a;
        d1 += b * b;
    }
    d0 = sqrt(d0 / (double)n);
    d1 = sqrt(d1 / (double)n);
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h0 = nb_min(h0, direction_span);
    for (int64_t k = 0; k < n; k++)
        ytmp[k] = y[k] + h0 * f[k];
    cx->m->rhs(t + h0, ytmp, n, p, ftmp);
    double d2 = 0.0;
    for (int64_t k = 0; k < n; k++) {
        double sc = atol[k] + rtol * fabs(y[k]);
        double a = (ftmp[k] - f[k]) / sc;
        d2 += a * a;
    }
    d2 = sqrt(d2 / (double)n) / h0;
    double h1;
    if (nb_max(d1, d2) <= 1e-15)
        h1 = nb_max(1e-6, h0 * 1e-3);
    else
        h1 = pow(0.01 / nb_max(d1, d2), 1.0 / (double)order);
    return nb_min(nb_min(100.0 * h0, h1), direction_span);
}

/* _golden_max: maximise monitor(t0 + h, step(y0, h)) over h in [0, h_max]; the value is
 * returned, its time into *t_at */
static double golden_max(const run_ctx *cx, double t0, const double *y0, int64_t n, double *p,
                         double h_max, double *K, double *y_new, double *f_new, double *ytmp,
                         double *f0, int64_t iters, double *out, double *g, double *gd,
                         double *t_at)
{
    cx->m->rhs(t0, y0, n, p, f0);
    const double invphi = 0.6180339887498949;
    double a = 0.0, b = h_max;
    double c = b - invphi * (b - a);
    double d = a + invphi * (b - a);
    double fc = step_monitor(cx, t0, y0, n, f0, c, K, p, y_new, f_new, ytmp, out, g, gd);
    double fd = step_monitor(cx, t0, y0, n, f0, d, K, p, y_new, f_new, ytmp, out, g, gd);
    for (int64_t it = 0; it < iters; it++) {
        if (fc > fd) {
            b = d;
            d = c;
            fd = fc;
            c = b - invphi * (b - a);
            fc = step_monitor(cx, t0, y0, n, f0, c, K, p, y_new, f_new, ytmp, out, g, gd);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + invphi * (b - a);
            fd = step_monitor(cx, t0, y0, n, f0, d, K, p, y_new, f_new, ytmp, out, g, gd);
        }
    }
    if (fc > fd) {
        *t_at = t0 + c;
        return fc;
    }
    *t_at = t0 + d;
    return fd;
}

/* ---- the window's crests ---- */

typedef struct {
    int64_t n_top;     /* crests kept */
    int64_t n;         /* state length */
    int64_t n_p;       /* parameter length */
    double *cr_y;      /* (n_top + 1, 2, n) */
    double *cr_p;      /* (n_top + 1, 2, n_p) */
    double *cr_sc;     /* (n_top + 1, 5) */
    int64_t *rows;     /* crest_rows (n_top + 1) */
} crests;

static inline double *cr_y_at(const crests *c, int64_t row, int64_t side)
{
    return c->cr_y + (row * 2 + side) * c->n;
}

static inline double *cr_p_at(const crests *c, int64_t row, int64_t side)
{
    return c->cr_p + (row * 2 + side) * c->n_p;
}

static inline double *cr_sc_at(const crests *c, int64_t row)
{
    return c->cr_sc + row * 5;
}

/* _crest_put / _crest_store */
static void crest_put(const crests *c, int64_t row, const double *y_prev, const double *p_prev,
                      double t_prev, double h_prev, const double *y, const double *p, double t,
                      double m)
{
    if (h_prev > 0.0) {
        memcpy(cr_y_at(c, row, 0), y_prev, (size_t)c->n * sizeof(double));
        memcpy(cr_p_at(c, row, 0), p_prev, (size_t)c->n_p * sizeof(double));
    }
    memcpy(cr_y_at(c, row, 1), y, (size_t)c->n * sizeof(double));
    memcpy(cr_p_at(c, row, 1), p, (size_t)c->n_p * sizeof(double));
    double *sc = cr_sc_at(c, row);
    sc[0] = t_prev;
    sc[1] = h_prev;
    sc[2] = t;
    sc[3] = 0.0;
    sc[4] = m;
}

/* _crest_confirm: returns the new count, the threshold into *thresh */
static int64_t crest_confirm(const crests *c, int64_t n_cr, double next_h, double *thresh)
{
    const int64_t n_top = c->n_top;
    int64_t *rows = c->rows;
    int64_t row = rows[n_cr];
    cr_sc_at(c, row)[3] = next_h;
    if (n_cr < n_top) {
        n_cr += 1;
    } else {
        int64_t i_min = 0;
        for (int64_t i = 1; i < n_top; i++)
            if (cr_sc_at(c, rows[i])[4] < cr_sc_at(c, rows[i_min])[4])
                i_min = i;
        if (cr_sc_at(c, row)[4] > cr_sc_at(c, rows[i_min])[4]) {
            rows[n_top] = rows[i_min];
            rows[i_min] = row;
        }
    }
    if (n_cr < n_top) {
        *thresh = -INFINITY;
        return n_cr;
    }
    double low = INFINITY;
    for (int64_t i = 0; i < n_top; i++)
        low = nb_min(low, cr_sc_at(c, rows[i])[4]);
    *thresh = low;
    return n_cr;
}

/* _track_crests: returns n_cr; *thresh and *pend updated */
static int64_t track_crests(const crests *c, double m, double m_last, int *pend, int64_t n_cr,
                            double *thresh, const double *y_prev, const double *p_step,
                            double t_prev, double h_step, const double *y, const double *p,
                            double t)
{
    if (*pend) {
        if (!(m > cr_sc_at(c, c->rows[n_cr])[4]))
            n_cr = crest_confirm(c, n_cr, h_step, thresh);
        *pend = 0;
    }
    if (m > m_last && m > *thresh) {
        crest_put(c, c->rows[n_cr], y_prev, p_step, t_prev, h_step, y, p, t, m);
        *pend = 1;
    }
    return n_cr;
}

/* _seen */
static int seen(const double *done_t, int64_t n_done, double t0)
{
    for (int64_t i = 0; i < n_done; i++)
        if (done_t[i] == t0)
            return 1;
    return 0;
}

/* _refine_window: returns the number of steps refined; *peak, *peak_t updated */
static int64_t refine_window(const run_ctx *cx, double *peak, double *peak_t,
                             const crests *cr, int64_t n_cr, double ws_t, const double *ws_y,
                             int64_t n_d, double *ws_p, double ws_h, double t_last,
                             const double *y_last, double *p_last, double h_last, double *K,
                             double *y_new, double *f_new, double *ytmp, double *f_ref,
                             int64_t refine_iters, double *oscr, double *g, double *gd,
                             double *done_t)
{
    int64_t n_done = 0;
    for (int64_t i = 0; i < n_cr + 2; i++) {
        int64_t row, sides;
        if (i < n_cr) {
            row = cr->rows[i];
            sides = 2;
        } else {
            row = -1;
            sides = 1;
        }
        for (int64_t side = 0; side < sides; side++) {
            double t0, hh;
            if (row >= 0) {
                t0 = cr_sc_at(cr, row)[2 * side];
                hh = cr_sc_at(cr, row)[2 * side + 1];
            } else if (i == n_cr) {
                t0 = ws_t;
                hh = ws_h;
            } else {
                t0 = t_last;
                hh = h_last;
            }
            if (hh <= 0.0 || seen(done_t, n_done, t0))
                continue;
            double v, tv;
            if (row >= 0)
                v = golden_max(cx, t0, cr_y_at(cr, row, side), n_d, cr_p_at(cr, row, side), hh,
                               K, y_new, f_new, ytmp, f_ref, refine_iters, oscr, g, gd, &tv);
            else if (i == n_cr)
                v = golden_max(cx, t0, ws_y, n_d, ws_p, hh, K, y_new, f_new, ytmp, f_ref,
                               refine_iters, oscr, g, gd, &tv);
            else
                v = golden_max(cx, t0, y_last, n_d, p_last, hh, K, y_new, f_new, ytmp, f_ref,
                               refine_iters, oscr, g, gd, &tv);
            done_t[n_done] = t0;
            n_done += 1;
            if (v > *peak) {
                *peak = v;
                *peak_t = tv;
            }
        }
    }
    return n_done;
}

/* ---- events ---- */

/* _illinois_update: shrink the bracket [a, b] to the new point x */
static inline void illinois_update(double x, double gx, double *a, double *ga, double *b,
                                   double *gb, int *side)
{
    if (gx > 0.0) {
        if (*side == -1)
            *ga *= 0.5;
        *b = x;
        *gb = gx;
        *side = -1;
        return;
    }
    if (*side == 1)
        *gb *= 0.5;
    *a = x;
    *ga = gx;
    *side = 1;
}

/* _hermite_weights */
static inline void hermite_weights(double u, double *w00, double *w10, double *w01,
                                   double *w11)
{
    double u2 = u * u;
    double u3 = u2 * u;
    *w00 = 2.0 * u3 - 3.0 * u2 + 1.0;
    *w10 = u3 - 2.0 * u2 + u;
    *w01 = -2.0 * u3 + 3.0 * u2;
    *w11 = u3 - u2;
}

/* _hermite_bound */
static inline double hermite_bound(double g_a, double d_a, double g_b, double d_b)
{
    return nb_max(g_a, g_b) + 0.097 * fabs(g_a - g_b) + 0.149 * (fabs(d_a) + fabs(d_b));
}

/* _hermite_max: the maximum over [0, 1] of the cubic Hermite interpolant; where into *where */
static double hermite_max(double g_a, double d_a, double g_b, double d_b, double *where)
{
    double best = g_a;
    *where = 0.0;
    if (g_b > best) {
        best = g_b;
        *where = 1.0;
    }
    double qa = 6.0 * g_a + 3.0 * d_a - 6.0 * g_b + 3.0 * d_b;
    double qb = -6.0 * g_a - 4.0 * d_a + 6.0 * g_b - 2.0 * d_b;
    double qc = d_a;
    double disc = qb * qb - 4.0 * qa * qc;
    if (disc < 0.0)
        return best;
    double q = -0.5 * (qb + copysign(sqrt(disc), qb));
    for (int k = 0; k < 2; k++) {
        double u;
        if (k == 0) {
            if (q == 0.0)
                continue;
            u = qc / q;
        } else {
            if (qa == 0.0)
                continue;
            u = q / qa;
        }
        if (0.0 < u && u < 1.0) {
            double w00, w10, w01, w11;
            hermite_weights(u, &w00, &w10, &w01, &w11);
            double val = g_a * w00 + d_a * w10 + g_b * w01 + d_b * w11;
            if (val > best) {
                best = val;
                *where = u;
            }
        }
    }
    return best;
}

/* _clear_of_surface (y, ytmp: the leading n components) */
static int clear_of_surface(const run_ctx *cx, double t, const double *y, int64_t n,
                            const double *y_new, const double *f0, const double *f1, double h,
                            double *p, const double *g_start, const double *gd_start,
                            const double *g_end, const double *gd_end, int64_t n_ev,
                            int64_t n_samples, double event_tol, double event_margin,
                            double *ytmp, double *g_a, double *gd_a)
{
    for (int64_t j = 0; j < n_ev; j++) {
        if (g_start[j] > -100.0 * event_tol)
            return 0;
        g_a[j] = g_start[j];
        gd_a[j] = gd_start[j];
    }
    double margin = 2.0 * event_margin;
    double theta_a = 0.0;
    double ggd[2];
    for (int64_t i = 1; i < n_samples + 2; i++) {
        double theta_b = nb_min((double)i / ((double)n_samples + 1.0), 1.0);
        double span = (theta_b - theta_a) * h;
        int last = i == n_samples + 1;
        double h00 = 0.0, h10 = 0.0, h01 = 0.0, h11 = 0.0;
        if (!last) {
            double w10, w11;
            hermite_weights(theta_b, &h00, &w10, &h01, &w11);
            h10 = w10 * h;
            h11 = w11 * h;
            for (int64_t k = 0; k < n; k++)
                ytmp[k] = h00 * y[k] + h10 * f0[k] + h01 * y_new[k] + h11 * f1[k];
        }
        for (int64_t j = 0; j < n_ev; j++) {
            double g_b, gd_b;
            if (last) {
                g_b = g_end[j];
                gd_b = gd_end[j];
            } else {
                cx->m->event(t + theta_b * h, ytmp, p, j, ggd);
                g_b = ggd[0];
                gd_b = ggd[1];
                double g_h = (h00 * g_start[j] + h10 * gd_start[j] + h01 * g_end[j]
                              + h11 * gd_end[j]);
                if (fabs(g_b - g_h) > 0.1 * event_margin)
                    return 0;
            }
            double bound = hermite_bound(g_a[j], gd_a[j] * span, g_b, gd_b * span);
            if (g_b > -margin || bound > -margin)
                return 0;
            g_a[j] = g_b;
            gd_a[j] = gd_b;
        }
        theta_a = theta_b;
    }
    return 1;
}

static inline void set_bracket(double *out, double lo, double g_lo, double hi, double g_hi)
{
    out[0] = lo;
    out[1] = g_lo;
    out[2] = hi;
    out[3] = g_hi;
}

/* _search_event: the first sign change of joint j's g inside the step; the bracket into
 * out[0..3] = (theta_lo, g_lo, theta_hi, g_hi), theta_hi = -1: none */
static void search_event(const run_ctx *cx, int64_t j, double t, const double *y, int64_t n,
                         double h, const double *K, double *p, double g_start, double gd_start,
                         double g_end, double gd_end, int64_t n_samples, double event_tol,
                         double event_margin, double *ytmp, double *wts, double *fine,
                         const double *sample_polys, double *out)
{
    const int64_t prows = cx->tb->p_rows;
    double theta_a = 0.0, g_a = g_start, gd_a = gd_start;
    double ggd[2];
    int64_t n_near = g_start > -100.0 * event_tol ? 3 : 0;
    for (int64_t i = 1 - n_near; i < n_samples + 2; i++) {
        double theta_b, g_b, gd_b;
        if (i <= 0)
            theta_b = int_power(10.0, i - 1) / ((double)n_samples + 1.0);
        else
            theta_b = nb_min((double)i / ((double)n_samples + 1.0), 1.0);
        if (i == n_samples + 1) {
            g_b = g_end;
            gd_b = gd_end;
        } else {
            if (i <= 0)
                dense_eval(cx, y, n, h, K, theta_b, ytmp, wts);
            else
                dense_combine(cx, y, n, h, K, sample_polys + (i - 1) * prows, ytmp, wts);
            cx->m->event(t + theta_b * h, ytmp, p, j, ggd);
            g_b = ggd[0];
            gd_b = ggd[1];
        }
        double span = (theta_b - theta_a) * h;
        double d_a = gd_a * span;
        double d_b = gd_b * span;
        double bound = hermite_bound(g_a, d_a, g_b, d_b);
        double peak = bound;
        double where = -1.0;
        if (g_b <= 0.0 && bound > -event_margin)
            peak = hermite_max(g_a, d_a, g_b, d_b, &where);
        if (g_b <= 0.0 && peak > -event_margin) {
            int64_t n_fine = 7;
            for (int q = 0; q < 7; q++)
                fine[q] = (double)(q + 1) / 8.0;
            if (0.0 < where && where < 1.0) {
                int q = 7;
                while (q > 0 && fine[q - 1] > where) {
                    fine[q] = fine[q - 1];
                    q -= 1;
                }
                fine[q] = where;
                n_fine = 8;
            }
            double span_theta = theta_b - theta_a;
            double base = theta_a;
            for (int64_t q = 0; q < n_fine; q++) {
                double theta_f = base + fine[q] * span_theta;
                dense_eval(cx, y, n, h, K, theta_f, ytmp, wts);
                cx->m->event(t + theta_f * h, ytmp, p, j, ggd);
                double g_f = ggd[0];
                if (g_f > 0.0) {
                    set_bracket(out, theta_a, g_a, theta_f, g_f);
                    return;
                }
                theta_a = theta_f;
                g_a = g_f;
            }
        }
        if (g_b > 0.0) {
            set_bracket(out, theta_a, g_a, theta_b, g_b);
            return;
        }
        theta_a = theta_b;
        g_a = g_b;
        gd_a = gd_b;
    }
    set_bracket(out, theta_a, g_a, -1.0, 0.0);
}

/* _dense_root: Illinois root of joint j's g on the dense output in [a, b] */
static double dense_root(const run_ctx *cx, int64_t j, double t, const double *y, int64_t n,
                         double h, const double *K, double *p, double a, double ga, double b,
                         double gb, double event_tol, double *ytmp, double *wts)
{
    int side = 0;
    double theta = b;
    double ggd[2];
    for (int it = 0; it < 60; it++) {
        double c = (a * gb - b * ga) / (gb - ga);
        dense_eval(cx, y, n, h, K, c, ytmp, wts);
        cx->m->event(t + c * h, ytmp, p, j, ggd);
        double gc = ggd[0];
        theta = c;
        if (fabs(gc) <= event_tol || (b - a) < 1e-15)
            break;
        illinois_update(c, gc, &a, &ga, &b, &gb, &side);
    }
    return theta;
}

typedef struct {
    int64_t j;
    double theta_lo, g_lo, theta_hi, g_hi, theta;
    int64_t nfev;
} event_found;

/* _find_event (y, ytmp: the leading n = n_dense components; y_new, f rows: full) */
static event_found find_event(const run_ctx *cx, double t, const double *y, int64_t n,
                              const double *y_new, double h, double *K, double *p,
                              const double *g_start, const double *gd_start,
                              const double *g_end, const double *gd_end, int64_t n_ev,
                              int64_t n_samples, double event_tol, double event_margin,
                              double *ytmp, double *wts, double *fine,
                              const double *sample_polys, double *g_a, double *gd_a)
{
    const int64_t n_extra = cx->tb->x_rows;
    const int64_t s = cx->k_rows - n_extra - 1;
    event_found r = {-1, 1.0, 0.0, -1.0, 0.0, 1.0, 0};
    if (n_extra > 0) {
        if (clear_of_surface(cx, t, y, n, y_new, K, K + s * cx->ldk, h, p, g_start, gd_start,
                             g_end, gd_end, n_ev, n_samples, event_tol, event_margin, ytmp,
                             g_a, gd_a))
            return r;
        extra_stages(cx, t, y, n, h, K, p, ytmp);
        r.nfev = n_extra;
    }
    double br[4];
    for (int64_t j = 0; j < n_ev; j++) {
        double g0 = g_start[j];
        int on_surface = fabs(g0) <= event_tol && gd_start[j] < 0.0;
        if (on_surface && g0 > 0.0)
            g0 = 0.0;
        search_event(cx, j, t, y, n, h, K, p, g0, gd_start[j], g_end[j], gd_end[j], n_samples,
                     event_tol, event_margin, ytmp, wts, fine, sample_polys, br);
        double lo = br[0], g_lo = br[1], hi = br[2], g_hi = br[3];
        if (hi < 0.0 || (on_surface && g_hi <= event_tol))
            continue;
        double theta;
        if (g_lo > 0.0)
            theta = 0.0;
        else
            theta = dense_root(cx, j, t, y, n, h, K, p, lo, g_lo, hi, g_hi, event_tol, ytmp,
                               wts);
        if (r.j < 0 || theta < r.theta) {
            r.j = j;
            r.theta_lo = lo;
            r.g_lo = g_lo;
            r.theta_hi = hi;
            r.g_hi = g_hi;
            r.theta = theta;
        }
    }
    return r;
}

/* _land: the step redone with the located size and refined by Illinois iterations; returns
 * the landed size, the evaluations into *nfev */
static double land_event(const run_ctx *cx, int64_t j, double t, const double *y, int64_t n,
                         const double *f, double h_ev, double h_a, double g_a, double h_b,
                         double g_b, double *K, double *p, double *y_new, double *f_new,
                         double *ytmp, double event_tol, int64_t evals, int64_t *nfev)
{
    double ggd[2];
    rk_step(cx, t, y, n, f, h_ev, K, p, y_new, f_new, ytmp);
    *nfev = evals;
    cx->m->event(t + h_ev, y_new, p, j, ggd);
    double g_ev = ggd[0];
    int side = 0;
    for (int it = 0; it < 16; it++) {
        if (fabs(g_ev) <= event_tol || h_b - h_a <= 1e-15 * nb_max(1.0, fabs(t)))
            break;
        illinois_update(h_ev, g_ev, &h_a, &g_a, &h_b, &g_b, &side);
        double h_c = (h_a * g_b - h_b * g_a) / (g_b - g_a);
        if (!(h_a < h_c && h_c < h_b))
            h_c = 0.5 * (h_a + h_b);
        h_ev = h_c;
        rk_step(cx, t, y, n, f, h_ev, K, p, y_new, f_new, ytmp);
        *nfev += evals;
        cx->m->event(t + h_ev, y_new, p, j, ggd);
        g_ev = ggd[0];
    }
    return h_ev;
}

/* _switch: on_event for joint j and every other joint on its surface; the joints switched */
static int64_t switch_events(const run_ctx *cx, double t, const double *y, double *p, int64_t j,
                             int64_t n_ev, double event_tol)
{
    int64_t n_sw = 1;
    double ggd[2];
    for (int64_t k = 0; k < n_ev; k++) {
        if (k == j)
            continue;
        cx->m->event(t, y, p, k, ggd);
        if (fabs(ggd[0]) <= event_tol) {
            cx->m->on_event(t, y, p, k);
            n_sw += 1;
        }
    }
    cx->m->on_event(t, y, p, j);
    return n_sw;
}

/* ---- integrate ---- */

/* glibc's allocator: blocks below mmap_threshold bytes from the heap, and the heap kept
 * mapped up to trim_threshold bytes of free memory (1: set; 0: not glibc or refused). Its
 * defaults hand each run's records fresh pages that the kernel zeroes: a quarter of a DDM
 * run of the paper case went into those page faults. */
int64_t mbs_tune_allocator(int64_t mmap_threshold, int64_t trim_threshold)
{
#ifdef __GLIBC__
    return mallopt(M_MMAP_THRESHOLD, (int)mmap_threshold) == 1
        && mallopt(M_TRIM_THRESHOLD, (int)trim_threshold) == 1;
#else
    (void)mmap_threshold;
    (void)trim_threshold;
    return 0;
#endif
}

/* free one of a result's arrays handed to Python (numpy arrays own them then) */
void mbs_free(void *data)
{
    free(data);
}

void mbs_result_free(mbs_result *res)
{
    if (res == NULL)
        return;
    free(res->t);
    free(res->y);
    free(res->mem);
    free(res->out);
    free(res->peaks);
    free(res->peak_t);
    res->t = res->y = res->mem = res->out = res->peaks = res->peak_t = NULL;
    res->n_rec = 0;
    res->n_win = 0;
}

/* malloc of count doubles (at least one, so that NULL means out of memory) */
static double *alloc_d(int64_t count)
{
    return (double *)malloc((size_t)(count > 0 ? count : 1) * sizeof(double));
}

static double *calloc_d(int64_t count)
{
    return (double *)calloc((size_t)(count > 0 ? count : 1), sizeof(double));
}

/* the records grown to cap rows (their first rows kept); 0 when out of memory (the records
 * stay valid) */
static int grow_records(mbs_result *res, int64_t cap, int64_t n, int64_t n_m, int64_t n_out)
{
    double *q;
    if (!(q = realloc(res->t, (size_t)(cap > 0 ? cap : 1) * sizeof(double))))
        return 0;
    res->t = q;
    if (!(q = realloc(res->y, (size_t)(cap * n > 0 ? cap * n : 1) * sizeof(double))))
        return 0;
    res->y = q;
    if (!(q = realloc(res->mem, (size_t)(cap * n_m > 0 ? cap * n_m : 1) * sizeof(double))))
        return 0;
    res->mem = q;
    if (!(q = realloc(res->out, (size_t)(cap * n_out > 0 ? cap * n_out : 1) * sizeof(double))))
        return 0;
    res->out = q;
    return 1;
}

int64_t mbs_integrate(const mbs_model *m, const double *y0, int64_t n, double *p,
                      const double *edges, int64_t n_edges, const mbs_settings *st,
                      const mbs_tableau *tb, mbs_result *res)
{
    memset(res, 0, sizeof(*res));
    if (n < 1 || n_edges < 2 || st->n_events < 1 || st->n_crests < 1 || st->n_err < 1
        || st->n_err > n || st->n_atol < n || st->n_samples < 0 || st->n_out < 0
        || st->n_mem < 0 || st->mem_start < 0 || st->mem_start + st->n_mem > m->n_p) {
        res->status = STATUS_BAD_ARGUMENT;
        return res->status;
    }
    const double rtol = st->rtol;
    const double *atol = st->atol;
    const int64_t n_atol = st->n_atol;
    const int64_t n_err = st->n_err;
    const double h_max = st->h_max;
    const int64_t max_steps = st->max_steps;
    const int record = st->record != 0;
    const double event_tol = st->event_tol;
    const double event_margin = st->event_margin;
    const int64_t n_samples = st->n_samples;
    const int64_t refine_iters = st->refine_iters;
    const int64_t n_out = st->n_out;
    const int64_t n_ev = st->n_events;
    const int64_t mem_start = st->mem_start;
    const int64_t n_mem = st->n_mem;
    const int64_t n_top = st->n_crests;
    const int64_t n_p = m->n_p;
    const int64_t n_dense = st->n_dense < n ? st->n_dense : n;
    const int64_t s = tb->n_b;
    const int rosen = tb->a_cols > tb->a_rows;

    run_ctx cx;
    cx.m = m;
    cx.tb = tb;
    cx.ldk = n;
    cx.k_rows = s + 1 + tb->x_rows + (rosen ? n + 3 : 0);
    cx.s = s;
    cx.rosenbrock = rosen;
    cx.n_out = n_out;

    const int dp5 = n <= SMALL && n_err <= SMALL && is_dopri5(tb);
    const int64_t evals = rosen ? s + 2 * n + 1 : s;
    const int64_t n_win = n_edges - 1;
    const int64_t n_m = n_mem > 1 ? n_mem : 1;
    const int64_t prows = tb->p_rows;

    /* the work arrays, in one block */
    int64_t sizes[] = {
        cx.k_rows * n,                      /* K (zeros) */
        n, n, n, n, n, n, n, n, n,          /* y f y_new f_new ytmp ftmp yhat f_ref ws_y */
        n_p, n_p,                           /* p_prev ws_p */
        prows, n_samples * prows, 8,        /* wts sample_polys fine */
        n_ev, n_ev, n_ev, n_ev, n_ev, n_ev, /* g_start gd_start g_end gd_end g_work gd_work */
        (n_top + 1) * 2 * n, (n_top + 1) * 2 * n_p, (n_top + 1) * 5, /* crests */
        2 * n_top + 2,                      /* done_t */
        n_out, n_out,                       /* obuf oscr (zeros) */
    };
    enum { N_WORK = sizeof(sizes) / sizeof(sizes[0]) };
    int64_t total = 0;
    for (int i = 0; i < N_WORK; i++)
        total += sizes[i];
    double *block = calloc_d(total);
    int64_t *crest_rows = (int64_t *)malloc((size_t)(n_top + 1) * sizeof(int64_t));
    res->peaks = alloc_d(n_win);
    res->peak_t = calloc_d(n_win);
    const int64_t cap0 = record ? 16384 : 1;
    if (!block || !crest_rows || !res->peaks || !res->peak_t
        || !grow_records(res, cap0, n, n_m, n_out)) {
        free(block);
        free(crest_rows);
        mbs_result_free(res);
        res->status = STATUS_OUT_OF_MEMORY;
        return res->status;
    }
    int64_t cap = cap0;
    double *w[N_WORK];
    {
        double *q = block;
        for (int i = 0; i < N_WORK; i++) {
            w[i] = q;
            q += sizes[i];
        }
    }
    double *K = w[0];
    double *y = w[1], *f = w[2], *y_new = w[3], *f_new = w[4], *ytmp = w[5], *ftmp = w[6];
    double *yhat = w[7], *f_ref = w[8], *ws_y = w[9];
    double *p_prev = w[10], *ws_p = w[11];
    double *wts = w[12], *sample_polys = w[13], *fine = w[14];
    double *g_start = w[15], *gd_start = w[16], *g_end = w[17], *gd_end = w[18];
    double *g_work = w[19], *gd_work = w[20];
    crests cr = {n_top, n, n_p, w[21], w[22], w[23], crest_rows};
    double *done_t = w[24];
    double *obuf = w[25], *oscr = w[26];
    double *peaks = res->peaks, *peak_t = res->peak_t;
    int64_t *counters = res->counters;

    memcpy(y, y0, (size_t)n * sizeof(double));
    memcpy(p_prev, p, (size_t)n_p * sizeof(double));
    for (int64_t i = 1; i < n_samples + 1; i++)
        for (int64_t j = 0; j < prows; j++)
            sample_polys[(i - 1) * prows + j] = dense_poly(
                tb, j, nb_min((double)i / ((double)n_samples + 1.0), 1.0));
    for (int64_t i = 0; i < n_win; i++)
        peaks[i] = -INFINITY;
    int64_t status = 0;
    for (int64_t i = 0; i < n_top + 1; i++)
        crest_rows[i] = i;
    int64_t n_cr = 0;
    double thresh = -INFINITY;
    memcpy(ws_y, y, (size_t)n * sizeof(double));
    double ws_t = edges[0];
    memcpy(ws_p, p, (size_t)n_p * sizeof(double));
    double ws_h = 0.0;
    int64_t nrec = 0;

    double t = edges[0];
    const double t_end = edges[n_edges - 1];
    double m0 = m->monitor(t, y, n, p, f, obuf, n_out, g_start, gd_start);
    counters[0] += 1;
    double h;
    if (st->h0 <= 0.0) {
        h = initial_step(&cx, t, y, n, f, p, rtol, atol, (int64_t)tb->error_order + 1,
                         nb_min(h_max, t_end - t), ytmp, ftmp);
        counters[0] += 1;
    } else {
        h = nb_min(st->h0, h_max);
    }
    int64_t win = 0;
    peaks[0] = m0;
    peak_t[0] = t;
    crest_put(&cr, crest_rows[0], y, p, t, 0.0, y, p, t, m0);
    int pend = 1;
    double m_last = m0;
    if (record) {
        res->t[0] = t;
        memcpy(res->y, y, (size_t)n * sizeof(double));
        for (int64_t k = 0; k < n_mem; k++)
            res->mem[k] = p[mem_start + k];
        for (int64_t k = 0; k < n_out; k++)
            res->out[k] = obuf[k];
        nrec = 1;
    }
    int64_t zero_events = 0;
    const double inv_order = 1.0 / (tb->error_order + 1.0);
    const double pi_alpha = tb->pi_alpha, pi_beta = tb->pi_beta;
    int last_rejected = 0;
    double err_prev = 1e-4;
    int64_t nstep = 0;
    while (win < n_win) {
        if (record && nrec == cap) {
            if (!grow_records(res, 2 * nrec, n, n_m, n_out)) {
                status = STATUS_OUT_OF_MEMORY;
                break;
            }
            cap = 2 * nrec;
        }
        if (nstep >= max_steps) {
            status = STATUS_MAX_STEPS;
            break;
        }
        nstep += 1;
        double t_target = edges[win + 1];
        int land = 0;
        double h_try = h;
        /* approaching a surface: not far past the linear prediction of the crossing */
        for (int64_t j = 0; j < n_ev; j++) {
            if (gd_start[j] > 0.0)
                h_try = nb_min(h_try, (2.0 * fabs(g_start[j])
                                       + (double)(n_samples + 1) * event_margin) / gd_start[j]);
        }
        if (t + h_try >= t_target - 1e-13 * nb_max(1.0, fabs(t_target))) {
            h_try = t_target - t;
            land = 1;
        }
        if (h_try <= 1e-15 * nb_max(1.0, fabs(t))) {
            if (land) {
                h_try = t_target - t;
            } else {
                status = STATUS_STEP_UNDERFLOW;
                break;
            }
        }
        double err;
        double m_new = attempt(&cx, t, y, n, f, h_try, K, p, y_new, f_new, ytmp, ytmp, ftmp,
                               obuf, rtol, atol, n_atol, n_err, yhat, g_end, gd_end, n_ev, dp5,
                               &err);
        counters[0] += evals;
        if (!(err <= 1.0)) {
            counters[2] += 1;
            if (err != err)
                h = 0.1 * h_try;
            else
                h = h_try * nb_max(0.2, 0.9 * pow(err, -inv_order));
            last_rejected = 1;
            continue;
        }
        /* PI step-size control */
        double err_c = nb_max(err, 1e-10);
        double factor = 0.9 * pow(err_c, -pi_alpha);
        if (pi_beta != 0.0)
            factor *= pow(err_prev, pi_beta);
        factor = nb_min(10.0, factor);
        err_prev = nb_max(err_c, 1e-4);
        if (last_rejected) {
            factor = nb_min(factor, 1.0);
            last_rejected = 0;
        }
        double h_next = nb_min(h_try * factor, h_max);
        if (land)
            h_next = nb_max(h_next, h);

        event_found ev = find_event(&cx, t, y, n_dense, y_new, h_try, K, p, g_start, gd_start,
                                    g_end, gd_end, n_ev, n_samples, event_tol, event_margin,
                                    ytmp, wts, fine, sample_polys, g_work, gd_work);
        counters[0] += ev.nfev;
        int ev_step = ev.j >= 0;
        double t_old, h_step, mval;
        if (ev_step) {
            memcpy(p_prev, p, (size_t)n_p * sizeof(double));
            counters[3] += 1;
            double h_ev = ev.theta * h_try;
            if (h_ev <= 1e-14 * nb_max(1.0, fabs(t))) {
                zero_events += 1;
                if (zero_events > 20) {
                    status = STATUS_EVENT_CHATTER;
                    break;
                }
                m->on_event(t, y, p, ev.j);
                m->monitor(t, y, n, p, f, obuf, n_out, g_start, gd_start);
                counters[0] += 1;
                if (record && nrec > 0 && res->t[nrec - 1] == t) {
                    for (int64_t k = 0; k < n_mem; k++)
                        res->mem[(nrec - 1) * n_m + k] = p[mem_start + k];
                    for (int64_t k = 0; k < n_out; k++)
                        res->out[(nrec - 1) * n_out + k] = obuf[k];
                }
                continue;
            }
            zero_events = 0;
            int64_t nfev;
            h_ev = land_event(&cx, ev.j, t, y, n, f, h_ev, ev.theta_lo * h_try,
                              nb_min(ev.g_lo, 0.0), ev.theta_hi * h_try,
                              nb_max(ev.g_hi, 1e-300), K, p, y_new, f_new, ytmp, event_tol,
                              evals, &nfev);
            counters[0] += nfev;
            t_old = t;
            t = t + h_ev;
            land = 0;
            h_step = h_ev;
            memcpy(ftmp, y, (size_t)n * sizeof(double));
            memcpy(y, y_new, (size_t)n * sizeof(double));
            counters[3] += switch_events(&cx, t, y, p, ev.j, n_ev, event_tol) - 1;
            mval = m->monitor(t, y, n, p, f, obuf, n_out, g_start, gd_start);
            counters[0] += 1;
            h = h_next;
        } else {
            zero_events = 0;
            for (int64_t j = 0; j < n_ev; j++) {
                g_start[j] = g_end[j];
                gd_start[j] = gd_end[j];
            }
            t_old = t;
            h_step = h_try;
            memcpy(ftmp, y, (size_t)n * sizeof(double));
            t = land ? t_target : t + h_try;
            memcpy(y, y_new, (size_t)n * sizeof(double));
            memcpy(f, f_new, (size_t)n * sizeof(double));
            mval = m_new;
            h = h_next;
        }
        counters[1] += 1;

        /* the window's peak: the best sample, and the best crests with their steps */
        if (ws_h == 0.0)
            ws_h = h_step;
        if (mval > peaks[win]) {
            peaks[win] = mval;
            peak_t[win] = t;
        }
        if (!(pend || (mval > m_last && mval > thresh))) {
            /* a falling sample, no crest pending */
        } else if (ev_step) {
            n_cr = track_crests(&cr, mval, m_last, &pend, n_cr, &thresh, ftmp, p_prev, t_old,
                                h_step, y, p, t);
        } else {
            n_cr = track_crests(&cr, mval, m_last, &pend, n_cr, &thresh, ftmp, p, t_old,
                                h_step, y, p, t);
        }
        m_last = mval;

        if (record) {
            res->t[nrec] = t;
            memcpy(res->y + nrec * n, y, (size_t)n * sizeof(double));
            for (int64_t k = 0; k < n_mem; k++)
                res->mem[nrec * n_m + k] = p[mem_start + k];
            for (int64_t k = 0; k < n_out; k++)
                res->out[nrec * n_out + k] = obuf[k];
            nrec += 1;
        }

        if (land) {
            /* window closed: refine its maximum */
            if (refine_iters > 0) {
                if (pend)
                    n_cr = crest_confirm(&cr, n_cr, 0.0, &thresh);
                counters[4] += refine_window(&cx, &peaks[win], &peak_t[win], &cr, n_cr, ws_t,
                                             ws_y, n_dense, ws_p, ws_h, t_old, ftmp, p, h_step,
                                             K, y_new, f_new, ytmp, f_ref, refine_iters, oscr,
                                             g_work, gd_work, done_t);
            }
            win += 1;
            if (win < n_win) {
                peaks[win] = mval;
                peak_t[win] = t;
                n_cr = 0;
                thresh = -INFINITY;
                crest_put(&cr, crest_rows[0], y, p, t, 0.0, y, p, t, mval);
                pend = 1;
                memcpy(ws_y, y, (size_t)n * sizeof(double));
                ws_t = t;
                memcpy(ws_p, p, (size_t)n_p * sizeof(double));
                ws_h = 0.0;
            }
        }
    }
    free(block);
    free(crest_rows);
    res->n_rec = nrec;
    res->n_win = n_win;
    res->status = status;
    return status;
}

/* ---- the step maps of recorded steps (sens_runtime.step_peaks, step_value, step_states) ---- */

/* the run context and work arrays of single steps of n states, as integrator.step_workspace
 * (K zeros, y_new, f_new, ytmp, f0, g, gd) and, with copy_p, a copy q of p (whose n_mem
 * memory entries the caller sets); 0, or a negative status (then nothing to free; else free
 * w->block) */
typedef struct {
    double *block, *K, *y_new, *f_new, *ytmp, *f0, *g, *gd, *q;
} step_work;

static int64_t step_workspace(run_ctx *cx, step_work *w, const mbs_model *m,
                              const mbs_tableau *tb, int64_t n, int64_t n_out, int64_t n_mem,
                              const double *p, int copy_p)
{
    if (n < 1 || n_out < 0 || n_mem < 0 || m->mem_start + n_mem > m->n_p)
        return STATUS_BAD_ARGUMENT;
    const int rosen = tb->a_cols > tb->a_rows;
    cx->m = m;
    cx->tb = tb;
    cx->ldk = n;
    cx->k_rows = tb->n_b + 1 + tb->x_rows + (rosen ? n + 3 : 0);
    cx->s = tb->n_b;
    cx->rosenbrock = rosen;
    cx->n_out = n_out;
    const int64_t ne = m->n_events > 1 ? m->n_events : 1;
    const int64_t n_q = copy_p ? m->n_p : 0;
    w->block = calloc_d(cx->k_rows * n + 4 * n + 2 * ne + n_q);
    if (!w->block)
        return STATUS_OUT_OF_MEMORY;
    w->K = w->block;
    w->y_new = w->K + cx->k_rows * n;
    w->f_new = w->y_new + n;
    w->ytmp = w->f_new + n;
    w->f0 = w->ytmp + n;
    w->g = w->f0 + n;
    w->gd = w->g + ne;
    w->q = w->gd + ne;
    if (copy_p)
        memcpy(w->q, p, (size_t)m->n_p * sizeof(double));
    return 0;
}

int64_t mbs_step_peaks(const mbs_model *m, const double *t0s, const double *y0s,
                       int64_t n_steps, int64_t n, const double *mems, int64_t n_mem,
                       const double *p, const double *hs, const mbs_tableau *tb, int64_t iters,
                       double *vals, double *times)
{
    run_ctx cx;
    step_work w;
    int64_t status = step_workspace(&cx, &w, m, tb, n, 0, n_mem, p, 1);
    if (status)
        return status;
    double out[1];
    for (int64_t k = 0; k < n_steps; k++) {
        for (int64_t j = 0; j < n_mem; j++)
            w.q[m->mem_start + j] = mems[k * n_mem + j];
        vals[k] = golden_max(&cx, t0s[k], y0s + k * n, n, w.q, hs[k], w.K, w.y_new, w.f_new,
                             w.ytmp, w.f0, iters, out, w.g, w.gd, &times[k]);
    }
    free(w.block);
    return 0;
}

int64_t mbs_step_value(const mbs_model *m, double t0, const double *y0, int64_t n,
                       const double *mem, int64_t n_mem, const double *p, double h,
                       const mbs_tableau *tb, double *value)
{
    run_ctx cx;
    step_work w;
    int64_t status = step_workspace(&cx, &w, m, tb, n, 0, n_mem, p, 1);
    if (status)
        return status;
    double out[1];
    for (int64_t j = 0; j < n_mem; j++)
        w.q[m->mem_start + j] = mem[j];
    m->rhs(t0, y0, n, w.q, w.f0);
    *value = step_monitor(&cx, t0, y0, n, w.f0, h, w.K, w.q, w.y_new, w.f_new, w.ytmp, out,
                          w.g, w.gd);
    free(w.block);
    return 0;
}

int64_t mbs_step_states(const mbs_model *m, double t0, const double *y0, int64_t n, double *p,
                        const double *hs, int64_t n_h, const mbs_tableau *tb, int64_t n_out,
                        double *ys, double *outs)
{
    run_ctx cx;
    step_work w;
    int64_t status = step_workspace(&cx, &w, m, tb, n, n_out, 0, p, 0);
    if (status)
        return status;
    m->rhs(t0, y0, n, p, w.f0);
    for (int64_t k = 0; k < n_h; k++)
        step_monitor(&cx, t0, y0, n, w.f0, hs[k], w.K, p, ys + k * n, w.f_new, w.ytmp,
                     outs + k * n_out, w.g, w.gd);
    free(w.block);
    return 0;
}
