/* The seam between a model and the compiled core (plain C99).
 *
 * A model is a record of sizes and function pointers; the core (integrator.c) integrates
 * any model through it. Arrays are contiguous doubles; matrices are row-major. The memory
 * of the clearance joints (mode, impact velocity, ...) lives in p[mem_start:mem_start+n_mem]
 * and is written by on_event only.
 */
#ifndef MBS_CORE_H
#define MBS_CORE_H

#include <stdint.h>

/* state derivative dydt[:n] at (t, y[:n]); n may be the model's n_dense (a truncated state:
 * the model then gives those derivatives only) */
typedef void (*mbs_rhs_fn)(double t, const double *y, int64_t n, const double *p,
                           double *dydt);
/* switching function of joint j and its rate into g_gd[0], g_gd[1] (negative in the
 * current mode; a crossing to positive is an event) */
typedef void (*mbs_event_fn)(double t, const double *y, const double *p, int64_t j,
                             double *g_gd);
/* applied exactly at a located event of joint j: updates joint j's memory in p */
typedef void (*mbs_action_fn)(double t, const double *y, double *p, int64_t j);
/* the last stage of a step: dydt (as rhs), outputs into out (when n_out >= the model's
 * n_out, else none), every joint's g, gd, and the monitored scalar (returned) */
typedef double (*mbs_monitor_fn)(double t, const double *y, int64_t n, const double *p,
                                 double *dydt, double *out, int64_t n_out, double *g,
                                 double *gd);
/* the parameter-only constants into p[const_start:]; returns 0, or 1 when a parameter the
 * model is specialised on (zero) is not zero */
typedef int (*mbs_prepare_fn)(double *p);

typedef struct mbs_model {
    int64_t n_state;     /* length of y */
    int64_t n_q;         /* coordinates */
    int64_t n_events;    /* switching functions (clearance joints, corners) */
    int64_t mem_start;   /* memory entries of p */
    int64_t n_mem;
    int64_t n_out;       /* outputs written by monitor */
    int64_t const_start; /* parameter-only constants from here */
    int64_t n_p;         /* length of p (parameters, memory, constants) */
    mbs_rhs_fn rhs;
    mbs_event_fn event;
    mbs_action_fn on_event;
    mbs_monitor_fn monitor;
    mbs_prepare_fn prepare;
} mbs_model;

/* every model library exports this: its record (static storage) */
const mbs_model *mbs_model_record(void);
/* and its loop closure at coordinates y[:n_q] (mbs_closure_size() values; the Jacobian
 * d/dq row-major, the rate d/dt at fixed q) */
int64_t mbs_closure_size(void);
void mbs_closure(double t, const double *y, const double *p, double *res);
void mbs_closure_jacobian(double t, const double *y, const double *p, double *res);
void mbs_closure_rate(double t, const double *y, const double *p, double *res);

/* coefficients of an embedded pair or a Rosenbrock method (integrator.Tableau.arrays()) */
typedef struct mbs_tableau {
    const double *A; int64_t a_rows, a_cols;
    const double *B; int64_t n_b;
    const double *C; int64_t n_c;
    const double *E; int64_t n_e;
    const double *E2; int64_t n_e2;          /* n_e2 = 0: one error estimator */
    const double *P; int64_t p_rows, p_cols; /* dense output */
    const double *A_extra; int64_t x_rows, x_cols;
    const double *C_extra; int64_t n_c_extra;
    double error_order, pi_alpha, pi_beta;
} mbs_tableau;

/* integrator.IntegratorSettings, field by field */
typedef struct mbs_settings {
    double rtol;
    const double *atol; int64_t n_atol;
    int64_t n_err;
    double h0, h_max;
    int64_t max_steps;
    int64_t record;
    double event_tol, event_margin;
    int64_t n_samples, refine_iters, n_out, n_dense, n_events, mem_start, n_mem, n_crests;
} mbs_settings;

/* what integrate returns; the arrays are malloc'ed by the core (free with mbs_result_free) */
typedef struct mbs_result {
    int64_t n_rec;                 /* recorded steps */
    double *t;                     /* (n_rec,) */
    double *y;                     /* (n_rec, n) */
    double *mem;                   /* (n_rec, max(n_mem, 1)) */
    double *out;                   /* (n_rec, n_out) */
    int64_t n_win;
    double *peaks, *peak_t;        /* (n_win,) */
    int64_t counters[5];           /* nfev, naccept, nreject, nevent, nrefine */
    int64_t status;                /* integrator.RESULTS; negative: out of memory */
} mbs_result;

int64_t mbs_integrate(const mbs_model *m, const double *y0, int64_t n, double *p,
                      const double *edges, int64_t n_edges, const mbs_settings *s,
                      const mbs_tableau *tb, mbs_result *res);
void mbs_result_free(mbs_result *res);

/* the step maps of recorded steps (a run's records refined afterwards), each returning 0 or
 * a negative status: the maximum of the monitored value over the step of size hs[k] from
 * (t0s[k], y0s[k] (n_steps, n), memories mems[k] (n_steps, n_mem)) by golden section, as the
 * integrator's peak refinement (values, times); the monitored value at t0 + h of one step
 * (into *value); the states (n_h, n) and outputs (n_h, n_out) at t0 + hs[k] of steps from
 * (t0, y0) with the memories in p (p's work entries are written) */
int64_t mbs_step_peaks(const mbs_model *m, const double *t0s, const double *y0s,
                       int64_t n_steps, int64_t n, const double *mems, int64_t n_mem,
                       const double *p, const double *hs, const mbs_tableau *tb, int64_t iters,
                       double *vals, double *times);
int64_t mbs_step_value(const mbs_model *m, double t0, const double *y0, int64_t n,
                       const double *mem, int64_t n_mem, const double *p, double h,
                       const mbs_tableau *tb, double *value);
int64_t mbs_step_states(const mbs_model *m, double t0, const double *y0, int64_t n, double *p,
                        const double *hs, int64_t n_h, const mbs_tableau *tb, int64_t n_out,
                        double *ys, double *outs);

#endif
