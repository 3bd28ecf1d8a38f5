/*
 * The multi-output squared-error criterion (scikit-learn's MSE with a 2-D y).
 *
 * A split's quality is the weighted sum of squared deviations it removes, summed over
 * outputs. Since the node's total is fixed, ranking splits only needs the proxy
 *     sum_j  L_j^2 / wL_j + R_j^2 / wR_j
 * (L_j, R_j: weighted target sums of output j left and right; wL_j, wR_j: their weights,
 * the same for every output unless masked), which is what scikit-learn compares too.
 */
#include <assert.h>
#include <float.h>

#include "forest/forest_impl.h"

long fo_criterion_best_split(const fo_groups *g, const double *total_sum,
                             const double *total_w, int32_t total_count, int min_leaf,
                             double *proxy, double *scratch)
{
    const size_t k = g->k;
    double *L = scratch;     /* k: left sums */
    double *wl = scratch + k; /* k (masked) or 1: left weights */
    long best = -1;
    double best_proxy = -DBL_MAX;
    for (size_t j = 0; j < k; j++)
        L[j] = 0.0;
    for (size_t j = 0; j < (g->masked ? k : 1); j++)
        wl[j] = 0.0;
    int32_t nl = 0;
    /* The last group can only be left of nothing. */
    for (size_t s = 0; s + 1 < g->n_groups; s++) {
        const double *gs = g->sum + s * k;
        for (size_t j = 0; j < k; j++)
            L[j] += gs[j];
        nl += g->count[s];
        if (g->masked)
            for (size_t j = 0; j < k; j++)
                wl[j] += g->w[s * k + j];
        else
            wl[0] += g->w[s];
        if (nl < min_leaf)
            continue;
        if (total_count - nl < min_leaf)
            break; /* the right side only shrinks from here */
        double p = 0.0;
        if (g->masked) {
            for (size_t j = 0; j < k; j++) {
                double wr = total_w[j] - wl[j], R = total_sum[j] - L[j];
                if (wl[j] > 0.0)
                    p += L[j] * L[j] / wl[j];
                if (wr > 0.0)
                    p += R * R / wr;
            }
        } else {
            double sl = 0.0, sr = 0.0;
            for (size_t j = 0; j < k; j++) {
                double R = total_sum[j] - L[j];
                sl += L[j] * L[j];
                sr += R * R;
            }
            p = sl / wl[0] + sr / (total_w[0] - wl[0]);
        }
        if (p > best_proxy) {
            best_proxy = p;
            best = (long)s;
        }
    }
    *proxy = best_proxy;
    return best;
}

void fo_criterion_node_stats(const int32_t *idx, size_t n, size_t k, const double *wy,
                             const double *wm, const double *w, const float *Y,
                             double *sum, double *sumsq, double *wsum, double *impurity,
                             double *wimpurity)
{
    const size_t nw = wm ? k : 1;
    for (size_t j = 0; j < k; j++)
        sum[j] = sumsq[j] = 0.0;
    for (size_t j = 0; j < nw; j++)
        wsum[j] = 0.0;
    for (size_t i = 0; i < n; i++) {
        size_t r = (size_t)idx[i];
        const double *a = wy + r * k;
        const float *y = Y + r * k;
        for (size_t j = 0; j < k; j++) {
            sum[j] += a[j];
            sumsq[j] += a[j] * (double)y[j];
        }
        if (wm)
            for (size_t j = 0; j < k; j++)
                wsum[j] += wm[r * k + j];
        else
            wsum[0] += w[r];
    }
    /* scikit-learn: impurity = mean_j (sumsq_j / w - mean_j^2). */
    double imp = 0.0, wimp = 0.0;
    for (size_t j = 0; j < k; j++) {
        double wj = wsum[wm ? j : 0];
        if (wj <= 0.0)
            continue;
        double mean = sum[j] / wj;
        double v = sumsq[j] / wj - mean * mean;
        imp += v;
        wimp += v * wj;
    }
    *impurity = imp / (double)k;
    *wimpurity = wimp / (double)k;
}
