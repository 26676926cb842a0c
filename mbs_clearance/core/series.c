/* Series of a model library at recorded steps, in one call each (a loop in Python over the
 * steps costs more than the run that recorded them). Compiled once, not per model: a model's
 * function comes as its address. */
#include <math.h>
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

/* linkage_ddm._window_norm_maxima: per window w (rows lo[w] .. hi[w] - 1) and requested
 * direction k, the maximum over its rows i of sum_j weights[k, j] c_j^2 with
 * c_j = sum_e s[i, rows[e], j] vals[e] (e from ptr[k] to ptr[k + 1]), at least 0 (0 where
 * a row is NaN, as Python's max(0.0, nan)); into out[nw, npar]. Row i of s starts at
 * s + i * ld, direction b's n2 entries at b * n2 from there. The operations of the numpy
 * formula, in its order (a product for a direction with one entry; sums from 0 otherwise). */
void mbs_window_norm_maxima(const double *s, int64_t ld, int64_t n2, const int64_t *ptr,
                            int64_t npar, const int64_t *rows, const double *vals,
                            const double *weights, const int64_t *lo, const int64_t *hi,
                            int64_t nw, double *out) {
    for (int64_t w = 0; w < nw; w++) {
        for (int64_t k = 0; k < npar; k++) {
            const int64_t e0 = ptr[k], e1 = ptr[k + 1];
            const double *wk = weights + k * n2;
            double best = -INFINITY;
            int nan = 0;
            for (int64_t i = lo[w]; i < hi[w]; i++) {
                const double *row = s + i * ld;
                double acc = 0.0;
                for (int64_t j = 0; j < n2; j++) {
                    double c;
                    if (e1 - e0 == 1) {
                        c = row[rows[e0] * n2 + j] * vals[e0];
                    } else {
                        c = 0.0;
                        for (int64_t e = e0; e < e1; e++)
                            c += row[rows[e] * n2 + j] * vals[e];
                    }
                    acc += wk[j] * c * c;
                }
                if (acc != acc)
                    nan = 1;
                else if (acc > best)
                    best = acc;
            }
            out[w * npar + k] = (!nan && best > 0.0) ? best : 0.0;
        }
    }
}
