/* The direct-differentiation (DDM) equations of a generated model in C: the sensitivity
 * right-hand side, the memories' sensitivities at a contact onset, the monitor with the
 * outputs' derivatives, the outputs' derivatives at recorded steps (plain C99), as
 * generate/sens_runtime.py (sens_rhs, sens_on_event_at, sens_monitor, sens_outputs), the
 * same operations in the same order.
 *
 * Included by a model's C file after its kernels: it calls them by name (`jacobian`,
 * `tangent`, `rhs`, `on_event`, `monitor`, `observe`) and reads its defines (N_Q, N_P,
 * N_Z, N_JROWS, N_EVENTS, N_OUT, MEM_START, MEM_COL0, ACC_COLUMN, PEN_ROW, RATE_ROW,
 * JOINT_ROWS, FLOORS, DDM_MOMENT_ROW and DDM_SPEED_INDEX: -1 without a drive).
 *
 * Sensitivity state: y = [q, qdot (2 N_Q), s_1 ... s_nb (2 N_Q each), W, sigma (nb N_EVENTS)];
 * p = the model's p (N_P entries), the header [nb, event-time term flag, m], the sparse
 * chain (nb m columns of z, nb m values), then the work space (`ddm_work`). The work space
 * lives in p, so these functions write p's work entries (and the memories' sensitivities
 * in y at an onset) through the seam's const pointers: every p
 * and y the integrator passes is writable.
 */
#ifndef MBS_SENS_RUNTIME_H
#define MBS_SENS_RUNTIME_H

#include <stdlib.h>
#include <string.h>

/* the layout of a sensitivity run's p (ddm_layout) and of its work space (work_offsets):
 * the Jacobian (N_JROWS (N_Z + 1)), the seeds (nb N_Z), which seeds use each column
 * (N_Z + 1 + nb N_Z), the chain's part of the seeds at the memories' columns (nb J), the
 * tangents (N_JROWS (nb + 1)), the plain monitor's derivative (2 N_Q), the recorded columns */
typedef struct {
    int64_t nb, m, c0, v0, w0;
    int64_t dz0, use0, mb0, t0, ws;
} ddm_work;

static inline ddm_work ddm_layout(const double *p)
{
    ddm_work w;
    w.nb = (int64_t)p[N_P];
    w.m = (int64_t)p[N_P + 2];
    w.c0 = N_P + 3;
    w.v0 = w.c0 + w.nb * w.m;
    w.w0 = w.v0 + w.nb * w.m;
    w.dz0 = w.w0 + (int64_t)N_JROWS * (N_Z + 1);
    w.use0 = w.dz0 + w.nb * N_Z;
    w.mb0 = w.use0 + N_Z + 1 + w.nb * N_Z;
    w.t0 = w.mb0 + w.nb * N_EVENTS;
    w.ws = w.t0 + (int64_t)N_JROWS * (w.nb + 1);
    return w;
}

/* _directional: the total derivative of Jacobian row `row` along direction k (the state
 * part s_k at y[base:], the parameters' part by the sparse chain, the memories' sigma_k at
 * y[sig:]) */
static inline double ddm_directional(const double *jac, int64_t row, const double *y,
                                     int64_t base, const double *p, const ddm_work *w,
                                     int64_t k, int64_t sig)
{
    const int64_t stride = N_Z + 1;
    const int64_t r0 = row * stride;
    double acc = 0.0;
    for (int64_t c = 0; c < 2 * N_Q; c++)
        acc += jac[r0 + 1 + c] * y[base + c];
    for (int64_t e = k * w->m; e < (k + 1) * w->m; e++)
        acc += jac[r0 + (int64_t)p[w->c0 + e]] * p[w->v0 + e];
    for (int64_t j = 0; j < N_EVENTS; j++)
        acc += jac[r0 + MEM_COL0 + 2 * j] * y[sig + j];
    return acc;
}

/* seed_directions: the seeds' memories' columns, the chain's part plus sigma_k */
static inline void ddm_seed_directions(double *dz, const double *membase, const double *y,
                                       int64_t nb)
{
    const int64_t wpos = 2 * N_Q * (1 + nb);
    for (int64_t k = 0; k < nb; k++) {
        const int64_t o = k * N_Z;
        const int64_t sig = wpos + 1 + k * N_EVENTS;
        for (int64_t j = 0; j < N_EVENTS; j++)
            dz[o + MEM_COL0 + 2 * j] = membase[k * N_EVENTS + j] + y[sig + j];
    }
}

/* sens_rhs: the state, sensitivity and work derivatives from the tangent along the
 * integrated directions (`full`: every row of the tangent); a truncated state (the
 * integrator's dense components) takes the plain model's */
static void sens_rhs(double t, const double *y, int64_t n, double *p, double *dydt,
                     int64_t full)
{
    const int64_t n2 = 2 * N_Q;
    const ddm_work w = ddm_layout(p);
    const int64_t nb = w.nb;
    if (n < n2 * (1 + nb) + 1 + nb * N_EVENTS) {
        rhs(t, y, n, p, dydt);
        return;
    }
    const int64_t ts = nb + 1;
    double *dz = p + w.dz0, *out = p + w.t0;
    ddm_seed_directions(dz, p + w.mb0, y, nb);
    tangent(t, y, p, dz, nb, p + w.use0, out, full);
    for (int64_t i = 0; i < N_Q; i++) {
        dydt[i] = y[N_Q + i];
        dydt[N_Q + i] = out[(ACC_COLUMN + i) * ts + nb];
    }
    const int64_t wpos = n2 * (1 + nb);
    /* the drive's work rate (a free linkage: no drive, no work) */
    dydt[wpos] = DDM_MOMENT_ROW >= 0 ? out[DDM_MOMENT_ROW * ts + nb] * p[DDM_SPEED_INDEX]
                                     : 0.0;
    for (int64_t k = 0; k < nb; k++) {
        const int64_t base = n2 * (1 + k);
        const int64_t sig = wpos + 1 + k * N_EVENTS;
        for (int64_t i = 0; i < N_Q; i++) {
            dydt[base + i] = y[base + N_Q + i];
            dydt[base + N_Q + i] = out[(ACC_COLUMN + i) * ts + k];
        }
        for (int64_t j = 0; j < N_EVENTS; j++)
            dydt[sig + j] = 0.0;
    }
}

/* sens_on_event_at: switch contact j's mode (the plain on_event); at an onset also the
 * sensitivity of its impact-velocity memory with the event-time term
 * (sigma_k = d(deltadot)/db_k + deltadotdot dt_e/db_k, dt_e/db_k = -(d delta/db_k)/deltadot),
 * or d(floor)/db_k where the floor p[floor_index] applies */
static void sens_on_event_at(double t, double *y, double *p, int64_t j, int64_t floor_index)
{
    if (p[MEM_START + 2 * j] > 0.5) {
        on_event(t, y, p, j);
        return;
    }
    const int64_t n2 = 2 * N_Q;
    const ddm_work w = ddm_layout(p);
    const int64_t nb = w.nb;
    const int64_t stride = N_Z + 1;
    double *jac = p + w.w0;
    jacobian(t, y, p, jac, 0);             /* free flight: F = 0 at the onset */
    on_event(t, y, p, j);
    const int64_t r_rate = RATE_ROW + JOINT_ROWS * j;
    const int64_t r_pen = PEN_ROW + JOINT_ROWS * j;
    const double rate = jac[r_rate * stride + N_Z];
    const double floor_ = p[floor_index];
    const int64_t wpos = n2 * (1 + nb);
    const int evterm = p[N_P + 1] > 0.5;
    if (rate > floor_) {
        /* d(deltadot)/dt along the motion */
        const int64_t r0 = r_rate * stride;
        double accel = jac[r0];
        for (int64_t i = 0; i < N_Q; i++)
            accel += (jac[r0 + 1 + i] * y[N_Q + i]
                      + jac[r0 + 1 + N_Q + i] * jac[(ACC_COLUMN + i) * stride + N_Z]);
        for (int64_t k = 0; k < nb; k++) {
            const int64_t base = n2 * (1 + k);
            const int64_t sig = wpos + 1 + k * N_EVENTS;
            double d_rate = ddm_directional(jac, r_rate, y, base, p, &w, k, sig);
            if (evterm) {
                const double d_pen = ddm_directional(jac, r_pen, y, base, p, &w, k, sig);
                d_rate -= accel * d_pen / rate;
            }
            y[sig + j] = d_rate;
        }
    } else {
        const int64_t col = 1 + n2 + floor_index;
        for (int64_t k = 0; k < nb; k++) {
            double v = 0.0;
            for (int64_t e = k * w.m; e < (k + 1) * w.m; e++)
                if ((int64_t)p[w.c0 + e] == col)
                    v += p[w.v0 + e];
            y[wpos + 1 + k * N_EVENTS + j] = v;
        }
    }
}

/* sens_monitor: sens_rhs, then the plain monitor on the state (outputs, switching
 * functions, the monitored value); with n_out > N_OUT also the derivatives of the recorded
 * columns (listed after the work space) along each direction, out[N_OUT + i nb + k], and the
 * monitor's values from the full tangent's value column (`observe`) */
static double sens_monitor(double t, const double *y, int64_t n, double *p, double *dydt,
                           double *out, int64_t n_out, double *g, double *gd)
{
    const int64_t full = n_out > N_OUT;
    sens_rhs(t, y, n, p, dydt, full);
    const int64_t n2 = 2 * N_Q;
    const ddm_work w = ddm_layout(p);
    const int64_t nb = w.nb;
    if (!full || n <= n2)
        return monitor(t, y, n2, p, p + w.ws, out, n_out, g, gd);
    const int64_t st = nb + 1;
    const double m = observe(p, p + w.t0 + nb, st, out, n_out, g, gd);
    const int64_t rec0 = w.ws + n2 + 1;
    const int64_t n_rec = (n_out - N_OUT) / nb;
    for (int64_t i = 0; i < n_rec; i++) {
        const int64_t r = (int64_t)p[rec0 + i];
        for (int64_t k = 0; k < nb; k++)
            out[N_OUT + i * nb + k] = p[w.t0 + r * st + k];
    }
    return m;
}

/* the seam's callbacks of a sensitivity run */
static void rhs_sens(double t, const double *y, int64_t n, const double *p, double *dydt)
{
    sens_rhs(t, y, n, (double *)p, dydt, 0);
}

static void on_event_sens(double t, const double *y, double *p, int64_t j)
{
    sens_on_event_at(t, (double *)y, p, j, FLOORS[j]);
}

static double monitor_sens(double t, const double *y, int64_t n, const double *p,
                           double *dydt, double *out, int64_t n_out, double *g, double *gd)
{
    return sens_monitor(t, y, n, (double *)p, dydt, out, n_out, g, gd);
}

/* the record of a sensitivity run: its n_state and n_p are those of the plain model (a
 * run's own are longer: the caller sets them in a copy) */
static const mbs_model SENS_MODEL = {N_STATE, N_Q, N_EVENTS, MEM_START, N_MEM, N_OUT,
                                     CONST_START, N_P, rhs_sens, event, on_event_sens,
                                     monitor_sens, prepare};

const mbs_model *mbs_sens_model_record(void) { return &SENS_MODEL; }

/* sens_outputs: values (n, N_OUT) and derivatives (n, N_OUT, nb) of the outputs along the
 * integrated directions at recorded steps (times ts, sensitivity states ys (n, n_y),
 * memories ms (n, n_m)) from the full tangent along each step's seeds, on a copy of p
 * (n_p entries); returns 0, or -1 when out of memory */
int64_t mbs_output_sensitivities(const double *ts, const double *ys, int64_t n, int64_t n_y,
                                 const double *ms, int64_t n_m, const double *p, int64_t n_p,
                                 double *vals, double *ders)
{
    double *q = (double *)malloc((size_t)(n_p > 0 ? n_p : 1) * sizeof(double));
    if (q == NULL)
        return -1;
    memcpy(q, p, (size_t)n_p * sizeof(double));
    const ddm_work w = ddm_layout(q);
    const int64_t nb = w.nb, st = nb + 1;
    for (int64_t i = 0; i < n; i++) {
        for (int64_t k = 0; k < n_m; k++)
            q[MEM_START + k] = ms[i * n_m + k];
        const double *y = ys + i * n_y;
        ddm_seed_directions(q + w.dz0, q + w.mb0, y, nb);
        double *out = q + w.t0;
        tangent(ts[i], y, q, q + w.dz0, nb, q + w.use0, out, 1);
        for (int64_t r = 0; r < N_OUT; r++) {
            vals[i * N_OUT + r] = out[r * st + nb];
            for (int64_t k = 0; k < nb; k++)
                ders[(i * N_OUT + r) * nb + k] = out[r * st + k];
        }
    }
    free(q);
    return 0;
}

#endif
