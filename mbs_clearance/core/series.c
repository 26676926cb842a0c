/* Series of a model library at recorded steps, in one call each (a loop in Python over the
 * steps costs more than the run that recorded them). Compiled once, not per model: a model's
 * function comes as its address. */
#include <stdint.h>

typedef void (*mbs_gap_fn)(double t, const double *y, const double *p, int64_t j, double *g);

/* the model's mbs_gap (ex, ey, exd, eyd) of switching functions 0 .. joints - 1 at the steps
 * (ts[n], ys[n, width]) into out[n, joints, 4] */
void mbs_gap_series(uintptr_t gap, const double *ts, const double *ys, int64_t n,
                    int64_t width, const double *p, int64_t joints, double *out) {
    mbs_gap_fn f = (mbs_gap_fn)gap;
    for (int64_t i = 0; i < n; i++)
        for (int64_t j = 0; j < joints; j++)
            f(ts[i], ys + i * width, p, j, out + 4 * (i * joints + j));
}
