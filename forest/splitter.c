/*
 * Splitters: for one node (rows idx[0..n)) and one feature, group the rows by feature
 * value in increasing order and hand the groups' statistics to the criterion.
 *
 * Exact: sort the node's values; consecutive values closer than FO_FEATURE_THRESHOLD
 * chain into one group (scikit-learn's rule), and a split between two groups has the
 * threshold halfway between them. Binned: a group per non-empty bin, found without
 * sorting, and the threshold is the bin's upper edge.
 */
#include <assert.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "forest/forest_impl.h"

int fo_splitter_init(fo_splitter *s, const fo_data *data, int masked, int min_leaf)
{
    memset(s, 0, sizeof *s);
    s->data = data;
    s->masked = masked;
    s->min_leaf = min_leaf;
    size_t n = data->n, k = fo_padded(data->k);
    size_t max_groups = data->bins ? 256 : (n ? n : 1);
    s->g.k = k;
    s->g.masked = masked;
    s->g.sum = malloc(max_groups * sizeof *s->g.sum);
    s->g.wk = malloc(max_groups * sizeof *s->g.wk);
    s->g.w = malloc(max_groups * sizeof *s->g.w);
    s->g.count = malloc(max_groups * sizeof *s->g.count);
    s->g.buf_sum = malloc(max_groups * k * sizeof *s->g.buf_sum);
    s->g.buf_w = masked ? malloc(max_groups * k * sizeof *s->g.buf_w) : NULL;
    s->first_row = malloc(max_groups * sizeof *s->first_row);
    s->scratch = malloc(2 * k * sizeof *s->scratch);
    if (data->bins)
        s->gathered_codes = malloc(FO_GATHER_BATCH * (n ? n : 1));
    else
        s->gathered_vals = malloc(FO_GATHER_BATCH * (n ? n : 1) * sizeof *s->gathered_vals);
    if (!data->bins) {
        s->xs = malloc(n * sizeof *s->xs);
        s->rows = malloc(n * sizeof *s->rows);
        s->lo = malloc(n * sizeof *s->lo);
        s->hi = malloc(n * sizeof *s->hi);
    }
    if (!s->g.sum || !s->g.wk || !s->g.w || !s->g.count || !s->g.buf_sum ||
        (masked && !s->g.buf_w) || !s->first_row || !s->scratch ||
        (!s->gathered_codes && !s->gathered_vals) ||
        (!data->bins && (!s->xs || !s->rows || !s->lo || !s->hi))) {
        fo_splitter_free(s);
        return -1;
    }
    return 0;
}

void fo_splitter_free(fo_splitter *s)
{
    free(s->g.sum);
    free(s->g.wk);
    free(s->g.w);
    free(s->g.count);
    free(s->g.buf_sum);
    free(s->g.buf_w);
    free(s->first_row);
    free(s->scratch);
    free(s->xs);
    free(s->rows);
    free(s->lo);
    free(s->hi);
    free(s->gathered_codes);
    free(s->gathered_vals);
    memset(s, 0, sizeof *s);
}

/* ------------------------------------------- sorting (value, row) pairs: introsort -- */

static void swap_pair(float *x, int32_t *r, size_t a, size_t b)
{
    float t = x[a];
    x[a] = x[b];
    x[b] = t;
    int32_t u = r[a];
    r[a] = r[b];
    r[b] = u;
}

static void sift_down(float *x, int32_t *r, size_t root, size_t n)
{
    for (;;) {
        size_t c = 2 * root + 1;
        if (c >= n)
            return;
        if (c + 1 < n && x[c + 1] > x[c])
            c++;
        if (!(x[c] > x[root]))
            return;
        swap_pair(x, r, root, c);
        root = c;
    }
}

static void heap_sort(float *x, int32_t *r, size_t n)
{
    for (size_t i = n / 2; i-- > 0;)
        sift_down(x, r, i, n);
    for (size_t end = n; end-- > 1;) {
        swap_pair(x, r, 0, end);
        sift_down(x, r, 0, end);
    }
}

static void intro_sort(float *x, int32_t *r, size_t n, int depth)
{
    while (n > 16) {
        if (depth-- == 0) {
            heap_sort(x, r, n);
            return;
        }
        /* Median of three as pivot; three-way partition so runs of ties cost nothing. */
        float a = x[0], b = x[n / 2], c = x[n - 1];
        float pivot = a < b ? (b < c ? b : (a < c ? c : a)) : (a < c ? a : (b < c ? c : b));
        size_t lt = 0, i = 0, gt = n;
        while (i < gt) {
            if (x[i] < pivot)
                swap_pair(x, r, lt++, i++);
            else if (x[i] > pivot)
                swap_pair(x, r, i, --gt);
            else
                i++;
        }
        /* Recurse into the smaller side, loop on the larger. */
        if (lt < n - gt) {
            intro_sort(x, r, lt, depth);
            x += gt;
            r += gt;
            n -= gt;
        } else {
            intro_sort(x + gt, r + gt, n - gt, depth);
            n = lt;
        }
    }
    for (size_t i = 1; i < n; i++) {
        float v = x[i];
        int32_t w = r[i];
        size_t j = i;
        for (; j > 0 && x[j - 1] > v; j--) {
            x[j] = x[j - 1];
            r[j] = r[j - 1];
        }
        x[j] = v;
        r[j] = w;
    }
}

/* -------------------------------------------------------------- grouping ---------- */

/* A group of one row points at that row's statistics (no copy: most groups of deep nodes
 * are single rows); a group of several rows gets a buffer row and their sums. */
static inline void point_at_row(fo_groups *g, size_t gi, size_t r, const fo_acc *wy,
                                const fo_acc *wm, const double *w)
{
    g->sum[gi] = wy + r * g->k;
    if (wm)
        g->wk[gi] = wm + r * g->k;
    else
        g->w[gi] = (fo_acc)w[r];
}

/* Makes group gi the (empty) multi-row group number mi. */
static inline void open_buffer(fo_groups *g, size_t gi, size_t mi)
{
    fo_acc *sum = g->buf_sum + mi * g->k;
    memset(sum, 0, g->k * sizeof *sum);
    g->sum[gi] = sum;
    if (g->masked) {
        fo_acc *wk = g->buf_w + mi * g->k;
        memset(wk, 0, g->k * sizeof *wk);
        g->wk[gi] = wk;
    } else
        g->w[gi] = 0.0f;
}

/* Adds row r to group gi, which has a buffer (open_buffer). */
static inline void add_row(fo_groups *g, size_t gi, size_t r, const fo_acc *wy,
                           const fo_acc *wm, const double *w)
{
    const size_t k = g->k;
    fo_acc *restrict sum = (fo_acc *)g->sum[gi];
    const fo_acc *restrict a = wy + r * k;
    for (size_t j = 0; j < k; j++)
        sum[j] += a[j];
    if (wm) {
        fo_acc *restrict gw = (fo_acc *)g->wk[gi];
        const fo_acc *restrict b = wm + r * k;
        for (size_t j = 0; j < k; j++)
            gw[j] += b[j];
    } else
        g->w[gi] += (fo_acc)w[r];
}

/* vals[i]: the feature's value for row idx[i]. */
static size_t groups_exact(fo_splitter *s, const float *vals, const int32_t *idx, size_t n,
                           const fo_acc *wy, const fo_acc *wm, const double *w)
{
    for (size_t i = 0; i < n; i++) {
        s->rows[i] = idx[i];
        s->xs[i] = vals[i];
    }
    if (n < 2)
        return n;
    int depth = 2;
    for (size_t m = n; m > 1; m >>= 1)
        depth += 2;
    intro_sort(s->xs, s->rows, n, depth);
    if (s->xs[n - 1] <= s->xs[0] + FO_FEATURE_THRESHOLD)
        return 1; /* constant in this node */
    /* Groups are runs of the sorted rows: [start, i) closes when the value jumps. */
    fo_groups *g = &s->g;
    size_t ng = 0, mi = 0, start = 0;
    s->lo[0] = s->xs[0];
    for (size_t i = 1; i <= n; i++) {
        if (i < n && !(s->xs[i] > s->xs[i - 1] + FO_FEATURE_THRESHOLD))
            continue;
        s->hi[ng] = s->xs[i - 1];
        g->count[ng] = (int32_t)(i - start);
        if (i - start == 1)
            point_at_row(g, ng, (size_t)s->rows[start], wy, wm, w);
        else {
            open_buffer(g, ng, mi++);
            for (size_t q = start; q < i; q++)
                add_row(g, ng, (size_t)s->rows[q], wy, wm, w);
        }
        ng++;
        if (i < n)
            s->lo[ng] = s->xs[i];
        start = i;
    }
    g->n_groups = ng;
    return ng;
}

/* codes[i]: the feature's bin for row idx[i]. */
static size_t groups_binned(fo_splitter *s, const uint8_t *codes, const int32_t *idx,
                            size_t n, const fo_acc *wy, const fo_acc *wm, const double *w)
{
    /* Which bins occur, as a 256-bit set; numbering its members in order is then a few
     * count-trailing-zeros, with no sort and no sweep over empty bins. */
    uint64_t present[4] = {0, 0, 0, 0};
    for (size_t i = 0; i < n; i++) {
        uint8_t b = codes[i];
        present[b >> 6] |= 1ull << (b & 63);
    }
    size_t ng = 0;
    for (int word = 0; word < 4; word++)
        for (uint64_t bits = present[word]; bits; bits &= bits - 1) {
            int b = word * 64 + __builtin_ctzll(bits);
            s->slot_of[b] = (int32_t)ng;
            s->slot_bin[ng++] = b;
        }
    fo_groups *g = &s->g;
    g->n_groups = ng;
    if (ng <= 1)
        return ng;
    /* Count each group's rows (remembering one), then point or accumulate. */
    memset(g->count, 0, ng * sizeof *g->count);
    for (size_t i = 0; i < n; i++) {
        int32_t gi = s->slot_of[codes[i]];
        g->count[gi]++;
        s->first_row[gi] = idx[i];
    }
    size_t mi = 0;
    for (size_t gi = 0; gi < ng; gi++)
        if (g->count[gi] == 1)
            point_at_row(g, gi, (size_t)s->first_row[gi], wy, wm, w);
        else
            open_buffer(g, gi, mi++);
    if (mi > 0)
        for (size_t i = 0; i < n; i++) {
            int32_t gi = s->slot_of[codes[i]];
            if (g->count[gi] > 1)
                add_row(g, (size_t)gi, (size_t)idx[i], wy, wm, w);
        }
    return ng;
}

void fo_splitter_gather(fo_splitter *s, const int32_t *idx, size_t n, const int32_t *features,
                        size_t count)
{
    const fo_data *D = s->data;
    assert(count <= FO_GATHER_BATCH);
    /* One tight loop of independent loads per feature: the cache misses of the columns
     * (a node's rows are scattered over them) overlap instead of stalling the sums. */
    for (size_t q = 0; q < count; q++) {
        size_t f = (size_t)features[q];
        if (D->bins) {
            const uint8_t *col = D->bins->codes + f * D->n;
            uint8_t *out = s->gathered_codes + q * D->n;
            for (size_t i = 0; i < n; i++)
                out[i] = col[idx[i]];
        } else {
            const float *col = D->Xc + f * D->n;
            float *out = s->gathered_vals + q * D->n;
            for (size_t i = 0; i < n; i++)
                out[i] = col[idx[i]];
        }
    }
}

static size_t groups_gathered(fo_splitter *s, size_t q, const int32_t *idx, size_t n,
                              const fo_acc *wy, const fo_acc *wm, const double *w)
{
    size_t stride = s->data->n;
    return s->data->bins ? groups_binned(s, s->gathered_codes + q * stride, idx, n, wy, wm, w)
                         : groups_exact(s, s->gathered_vals + q * stride, idx, n, wy, wm, w);
}

size_t fo_splitter_groups(fo_splitter *s, const int32_t *idx, size_t n, size_t f,
                          const fo_acc *wy, const fo_acc *wm, const double *w)
{
    int32_t feature = (int32_t)f;
    fo_splitter_gather(s, idx, n, &feature, 1);
    return groups_gathered(s, 0, idx, n, wy, wm, w);
}

int fo_splitter_try_gathered(fo_splitter *s, size_t q, const int32_t *idx, size_t n,
                             size_t f, const fo_acc *wy, const fo_acc *wm, const double *w,
                             const fo_acc *total_sum, const fo_acc *total_w, fo_split *best)
{
    size_t ng = groups_gathered(s, q, idx, n, wy, wm, w);
    if (ng <= 1)
        return 1;
    double proxy;
    long last_left = fo_criterion_best_split(&s->g, total_sum, total_w, (int32_t)n,
                                             s->min_leaf, &proxy, s->scratch);
    if (last_left < 0 || !(proxy > best->proxy))
        return 0;
    best->feature = (long)f;
    best->proxy = proxy;
    if (s->data->bins) {
        int b = s->slot_bin[last_left];
        best->bin = b;
        best->threshold = s->data->bins->edges[f * (size_t)(s->data->bins->max_bins - 1) + b];
    } else {
        /* scikit-learn: halfway in double; if that rounds onto the right value (or
         * overflows), the left value itself. */
        double a = s->hi[last_left], b = s->lo[last_left + 1];
        double t = a / 2.0 + b / 2.0;
        if (t == b || isinf(t))
            t = a;
        best->threshold = t;
        best->bin = -1;
    }
    return 0;
}

int fo_splitter_try_feature(fo_splitter *s, const int32_t *idx, size_t n, size_t f,
                            const fo_acc *wy, const fo_acc *wm, const double *w,
                            const fo_acc *total_sum, const fo_acc *total_w, fo_split *best)
{
    int32_t feature = (int32_t)f;
    fo_splitter_gather(s, idx, n, &feature, 1);
    return fo_splitter_try_gathered(s, 0, idx, n, f, wy, wm, w, total_sum, total_w, best);
}

size_t fo_splitter_partition(const fo_splitter *s, int32_t *idx, size_t n,
                             const fo_split *split)
{
    const fo_data *D = s->data;
    size_t f = (size_t)split->feature, i = 0, j = n;
    if (D->bins) {
        const uint8_t *codes = D->bins->codes + f * D->n;
        const int b = split->bin;
        while (i < j) {
            if (codes[idx[i]] <= b)
                i++;
            else {
                int32_t t = idx[i];
                idx[i] = idx[--j];
                idx[j] = t;
            }
        }
    } else {
        const float *col = D->Xc + f * D->n;
        const double t = split->threshold;
        while (i < j) {
            if ((double)col[idx[i]] <= t)
                i++;
            else {
                int32_t u = idx[i];
                idx[i] = idx[--j];
                idx[j] = u;
            }
        }
    }
    return i;
}
