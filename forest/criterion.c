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

/* The reductions below keep LANES partial sums so that they vectorise without
 * -ffast-math (which this project does not use); the result depends only on k, never on
 * the thread or the machine. */
enum { LANES = FO_LANES };

/* L += G, then sl = |L|^2 and sr = |T - L|^2 (k a multiple of LANES). */
static inline void add_and_square(fo_acc *restrict L, const fo_acc *restrict G,
                                  const fo_acc *restrict T, size_t k, double *sl, double *sr)
{
    fo_acc al[LANES] = {0}, ar[LANES] = {0};
    for (size_t j = 0; j < k; j += LANES)
        for (int l = 0; l < LANES; l++) {
            fo_acc a = L[j + l] + G[j + l], r = T[j + l] - a;
            L[j + l] = a;
            al[l] += a * a;
            ar[l] += r * r;
        }
    /* Pairwise, halving, with constant bounds: a few vector shuffles instead of LANES
     * dependent scalar additions (which cost more than the loop above). */
    _Static_assert(LANES == 16, "the reduction below halves 16 lanes");
    for (int l = 0; l < 8; l++) {
        al[l] += al[l + 8];
        ar[l] += ar[l + 8];
    }
    for (int l = 0; l < 4; l++) {
        al[l] += al[l + 4];
        ar[l] += ar[l + 4];
    }
    for (int l = 0; l < 2; l++) {
        al[l] += al[l + 2];
        ar[l] += ar[l + 2];
    }
    *sl = (double)al[0] + al[1];
    *sr = (double)ar[0] + ar[1];
}

/* Masked: L += G, wl += GW, then sum_j L_j^2 / wl_j + R_j^2 / wr_j over the sides that
 * have weight (R = T - L, wr = TW - wl), in lanes like add_and_square. */
static inline double add_and_proxy_masked(fo_acc *restrict L, fo_acc *restrict wl,
                                          const fo_acc *restrict G, const fo_acc *restrict GW,
                                          const fo_acc *restrict T, const fo_acc *restrict TW,
                                          size_t k)
{
    fo_acc acc[LANES] = {0};
    for (size_t j = 0; j < k; j += LANES)
        for (int l = 0; l < LANES; l++) {
            fo_acc a = L[j + l] + G[j + l], wa = wl[j + l] + GW[j + l];
            fo_acc r = T[j + l] - a, wr = TW[j + l] - wa;
            L[j + l] = a;
            wl[j + l] = wa;
            /* the divisor is 1 where the side is empty (then its sum is 0 too) */
            acc[l] += a * a / (wa > 0.0f ? wa : 1.0f) + r * r / (wr > 0.0f ? wr : 1.0f);
        }
    _Static_assert(LANES == 16, "the reduction below halves 16 lanes");
    for (int l = 0; l < 8; l++)
        acc[l] += acc[l + 8];
    for (int l = 0; l < 4; l++)
        acc[l] += acc[l + 4];
    for (int l = 0; l < 2; l++)
        acc[l] += acc[l + 2];
    return (double)acc[0] + acc[1];
}

long fo_criterion_best_split(const fo_groups *g, const fo_acc *total_sum,
                             const fo_acc *total_w, int32_t total_count, int min_leaf,
                             double *proxy, fo_acc *scratch)
{
    const size_t k = g->k;
    assert(k % LANES == 0);
    fo_acc *L = scratch;      /* k: left sums */
    fo_acc *wl = scratch + k; /* k (masked) or 1: left weights */
    long best = -1;
    double best_proxy = -DBL_MAX;
    for (size_t j = 0; j < k; j++)
        L[j] = 0.0;
    for (size_t j = 0; j < (g->masked ? k : 1); j++)
        wl[j] = 0.0;
    int32_t nl = 0;
    /* The last group can only be left of nothing. */
    for (size_t s = 0; s + 1 < g->n_groups; s++) {
        const fo_acc *gs = g->sum[s];
        nl += g->count[s];
        double p;
        if (g->masked) {
            if (nl < min_leaf || total_count - nl < min_leaf) {
                for (size_t j = 0; j < k; j++) {
                    L[j] += gs[j];
                    wl[j] += g->wk[s][j];
                }
                if (total_count - nl < min_leaf)
                    break; /* the right side only shrinks from here */
                continue;
            }
            p = add_and_proxy_masked(L, wl, gs, g->wk[s], total_sum, total_w, k);
        } else {
            wl[0] += g->w[s];
            if (nl < min_leaf || total_count - nl < min_leaf) {
                for (size_t j = 0; j < k; j++)
                    L[j] += gs[j];
                if (total_count - nl < min_leaf)
                    break;
                continue;
            }
            /* L += group, and both sums of squares, in one pass. */
            double sl, sr;
            add_and_square(L, gs, total_sum, k, &sl, &sr);
            p = sl / wl[0] + sr / ((double)total_w[0] - wl[0]);
        }
        if (p > best_proxy) {
            best_proxy = p;
            best = (long)s;
        }
    }
    *proxy = best_proxy;
    return best;
}

void fo_criterion_node_stats(const int32_t *idx, size_t n, size_t k, const fo_acc *wy,
                             const fo_acc *wm, const double *w, const float *Y,
                             double *sum, double *sumsq, double *wsum, double *impurity,
                             double *wimpurity)
{
    (void)wy; /* kept for symmetry with the splitter (forest_impl.h) */
    const size_t kp = fo_padded(k);
    for (size_t j = 0; j < kp; j++)
        sum[j] = sumsq[j] = 0.0;
    for (size_t j = 0; j < (wm ? kp : 1); j++)
        wsum[j] = 0.0;
    /* From Y in double, not from the float wy: impurities are differences of sums. Row
     * weights (bootstrap counts) and wm (counts times 0 or 1) are exact in float. */
    for (size_t i = 0; i < n; i++) {
        size_t r = (size_t)idx[i];
        const float *y = Y + r * k;
        if (wm) {
            const fo_acc *m = wm + r * kp;
            for (size_t j = 0; j < k; j++) {
                double a = (double)m[j] * y[j];
                sum[j] += a;
                sumsq[j] += a * y[j];
                wsum[j] += m[j];
            }
        } else {
            const double wr = w[r];
            for (size_t j = 0; j < k; j++) {
                double a = wr * y[j];
                sum[j] += a;
                sumsq[j] += a * y[j];
            }
            wsum[0] += wr;
        }
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
