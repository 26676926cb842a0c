/* The integrator compiled into a model's library (included at the end of the model's C, with
 * MBS_MODEL_CORE defined before it; generate/c_loader.py writes integrator.c beside it as
 * integrator_core.h): a copy of integrator.c that calls this model's rhs, event, action
 * and monitor directly instead of through its record's pointers, so that the compiler keeps
 * the integrator's values in registers across them and inlines where it chooses. The same
 * operations in the same order as the core's: a run gives the same numbers bit for bit, in
 * 2-3 % less time on the paper's and the lubricated case (as fast on the four-bar), for a
 * compile twice as long as the model's kernels alone. The core (compiled once) still runs
 * every other record: the sensitivity runs and hand-written models. */
#ifndef MBS_MODEL_CORE_H
#define MBS_MODEL_CORE_H

#define MBS_RHS(m) rhs
#define MBS_EVENT(m) event
#define MBS_ON_EVENT(m) on_event
#define MBS_MONITOR(m) monitor
#define MBS_CORE_API static __attribute__((unused))
#include "integrator_core.h"

/* mbs_integrate of this library's plain record (mbs_model_record()); a record with other
 * functions is refused (STATUS_BAD_ARGUMENT) */
int64_t mbs_model_integrate(const mbs_model *m, const double *y0, int64_t n, double *p,
                            const double *edges, int64_t n_edges, const mbs_settings *st,
                            const mbs_tableau *tb, mbs_result *res)
{
    if (m->rhs != rhs || m->event != event || m->on_event != on_event
        || m->monitor != monitor) {
        memset(res, 0, sizeof(*res));
        res->status = STATUS_BAD_ARGUMENT;
        return res->status;
    }
    return mbs_integrate(m, y0, n, p, edges, n_edges, st, tb, res);
}

#endif
