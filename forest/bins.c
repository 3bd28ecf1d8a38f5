/*
 * Quantile binning of the features, done once before any tree is grown: each feature is
 * mapped to at most 256 bins so that histograms replace sorting and the data shrink to one
 * byte per value (5,000 x 305,888 descriptors are 1.5 GB).
 *
 * Edges sit halfway between consecutive distinct values, like exact thresholds: a feature
 * with at most max_bins distinct values gets one bin per value, and then every exact split
 * on the training rows is also a bin split.
 */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "forest/forest_impl.h"

/* An unsigned key ordering floats as their values (negative ones with every bit flipped,
 * positive ones with the sign bit set); -0 sorts just before +0, which no caller minds. */
static uint32_t float_key(float x)
{
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    return u & 0x80000000u ? ~u : u | 0x80000000u;
}

/* LSD radix sort of n (key, row) pairs, a byte a pass (four passes: the result ends where
 * it started); tmp_* hold n entries each. */
static void radix_sort(uint32_t *key, uint32_t *row, uint32_t *tmp_key, uint32_t *tmp_row,
                       size_t n)
{
    enum { BITS = 8, RADIX = 1 << BITS };
    size_t count[RADIX];
    for (int shift = 0; shift < 32; shift += BITS) {
        memset(count, 0, sizeof count);
        for (size_t i = 0; i < n; i++)
            count[(key[i] >> shift) & (RADIX - 1)]++;
        size_t at = 0;
        for (int b = 0; b < RADIX; b++) {
            size_t c = count[b];
            count[b] = at;
            at += c;
        }
        for (size_t i = 0; i < n; i++) {
            size_t to = count[(key[i] >> shift) & (RADIX - 1)]++;
            tmp_key[to] = key[i];
            tmp_row[to] = row[i];
        }
        uint32_t *t = key;
        key = tmp_key;
        tmp_key = t;
        t = row;
        row = tmp_row;
        tmp_row = t;
    }
}

/* Halfway between a < b, rounded so that a <= edge < b (x <= edge sends a left, b right). */
static float midpoint(float a, float b)
{
    float m = (float)((double)a / 2.0 + (double)b / 2.0);
    if (m >= b || !isfinite(m))
        m = a;
    return m;
}

int fo_bins_edges(const float *sorted, size_t n, int max_bins, float *edges)
{
    /* Distinct values, counted with scikit-learn's closeness rule. */
    size_t distinct = n ? 1 : 0;
    for (size_t i = 1; i < n; i++)
        distinct += sorted[i] > sorted[i - 1] + FO_FEATURE_THRESHOLD;
    int ne = 0;
    if (distinct <= (size_t)max_bins) {
        for (size_t i = 1; i < n; i++)
            if (sorted[i] > sorted[i - 1] + FO_FEATURE_THRESHOLD)
                edges[ne++] = midpoint(sorted[i - 1], sorted[i]);
        return ne;
    }
    /* Quantiles: the b-th edge just below the value at rank b*n/max_bins; inside a run of
     * ties it moves to the run's end so no edge splits equal values. */
    for (int b = 1; b < max_bins; b++) {
        size_t pos = (size_t)((double)b * (double)n / max_bins);
        if (pos == 0)
            pos = 1;
        while (pos < n && !(sorted[pos] > sorted[pos - 1] + FO_FEATURE_THRESHOLD))
            pos++;
        if (pos >= n)
            break;
        float e = midpoint(sorted[pos - 1], sorted[pos]);
        if (ne == 0 || e > edges[ne - 1])
            edges[ne++] = e;
    }
    return ne;
}

typedef struct bin_job {
    const float *X;
    size_t n, d;
    fo_bins *b;
    size_t first, last; /* features [first, last) */
    int failed;
} bin_job;

/* Features are processed in blocks so that reading rows stays sequential. */
enum { BIN_BLOCK = 64 };

static void *bin_worker(void *arg)
{
    bin_job *j = arg;
    const size_t n = j->n, d = j->d;
    const int nb = j->b->max_bins;
    float *col = malloc(n * BIN_BLOCK * sizeof *col);
    float *sorted = malloc(n * sizeof *sorted);
    uint32_t *key = malloc(4 * n * sizeof *key), *row = key + n, *tk = key + 2 * n,
             *tr = key + 3 * n;
    if (!col || !sorted || !key) {
        j->failed = 1;
        free(col);
        free(sorted);
        free(key);
        return NULL;
    }
    for (size_t f0 = j->first; f0 < j->last; f0 += BIN_BLOCK) {
        size_t nf = j->last - f0 < BIN_BLOCK ? j->last - f0 : BIN_BLOCK;
        for (size_t i = 0; i < n; i++) {
            const float *x = j->X + i * d + f0;
            for (size_t f = 0; f < nf; f++)
                col[f * n + i] = x[f];
        }
        for (size_t f = 0; f < nf; f++) {
            const float *c = col + f * n;
            for (size_t i = 0; i < n; i++) {
                key[i] = float_key(c[i]);
                row[i] = (uint32_t)i;
            }
            radix_sort(key, row, tk, tr, n);
            for (size_t i = 0; i < n; i++)
                sorted[i] = c[row[i]];
            float *edges = j->b->edges + (f0 + f) * (size_t)(nb - 1);
            int ne = fo_bins_edges(sorted, n, nb, edges);
            j->b->n_edges[f0 + f] = (uint16_t)ne;
            /* Walking up the sorted values, the bin (first edge >= x) only grows. */
            uint8_t *codes = j->b->codes + (f0 + f) * n;
            int b = 0;
            for (size_t i = 0; i < n; i++) {
                while (b < ne && sorted[i] > edges[b])
                    b++;
                codes[row[i]] = (uint8_t)b;
            }
        }
    }
    free(col);
    free(sorted);
    free(key);
    return NULL;
}

int fo_bins_build(const float *X, size_t n, size_t d, int max_bins, int n_threads,
                  fo_bins *b, char *err, size_t errlen)
{
    memset(b, 0, sizeof *b);
    b->max_bins = max_bins;
    b->edges = malloc(d * (size_t)(max_bins - 1) * sizeof *b->edges);
    b->n_edges = malloc(d * sizeof *b->n_edges);
    b->codes = malloc(d * n);
    if (!b->edges || !b->n_edges || !b->codes) {
        snprintf(err, errlen, "out of memory binning %zu x %zu features", n, d);
        fo_bins_free(b);
        return -1;
    }
    if (n_threads < 1)
        n_threads = 1;
    if ((size_t)n_threads > d)
        n_threads = (int)d;
    enum { MAX_BIN_THREADS = 64 };
    if (n_threads > MAX_BIN_THREADS)
        n_threads = MAX_BIN_THREADS;
    bin_job jobs[MAX_BIN_THREADS];
    pthread_t tids[MAX_BIN_THREADS];
    int started[MAX_BIN_THREADS] = {0}, failed = 0;
    for (int t = 0; t < n_threads; t++)
        jobs[t] = (bin_job){X, n, d, b, d * (size_t)t / (size_t)n_threads,
                            d * (size_t)(t + 1) / (size_t)n_threads, 0};
    /* Workers take all blocks but the last, which this thread does (as it does any block
     * a thread could not be started for). */
    for (int t = 0; t + 1 < n_threads; t++)
        started[t] = !pthread_create(&tids[t], NULL, bin_worker, &jobs[t]);
    for (int t = 0; t < n_threads; t++)
        if (t + 1 == n_threads || !started[t])
            bin_worker(&jobs[t]);
    for (int t = 0; t < n_threads; t++) {
        if (started[t])
            pthread_join(tids[t], NULL);
        failed |= jobs[t].failed;
    }
    if (failed) {
        snprintf(err, errlen, "out of memory binning %zu x %zu features", n, d);
        fo_bins_free(b);
        return -1;
    }
    return 0;
}

void fo_bins_free(fo_bins *b)
{
    free(b->edges);
    free(b->n_edges);
    free(b->codes);
    memset(b, 0, sizeof *b);
}
