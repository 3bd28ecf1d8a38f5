/*
 * The tree builder: grows one tree depth-first, as scikit-learn's DepthFirstTreeBuilder.
 *
 * A node becomes a leaf if it is at max_depth, has fewer than min_samples_split rows or
 * fewer than 2 * min_samples_leaf, is pure (impurity <= DBL_EPSILON), or no sampled
 * feature offers a valid split. Features are sampled without replacement until
 * max_features have been looked at, and beyond that while every one looked at was
 * constant in the node (scikit-learn's rule).
 */
#include <assert.h>
#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "forest/forest_impl.h"

typedef struct pending {
    int32_t start, end, depth, parent;
    int is_left;
} pending;

typedef struct tree_growth {
    fo_tree *t;
    size_t k;
    int32_t cap;
} tree_growth;

static int32_t add_node(tree_growth *g)
{
    if (g->t->n_nodes == g->cap) {
        int32_t cap = g->cap ? g->cap * 2 : 64;
        fo_node *nodes = realloc(g->t->nodes, (size_t)cap * sizeof *nodes);
        if (!nodes)
            return -1;
        g->t->nodes = nodes;
        float *values = realloc(g->t->values, (size_t)cap * g->k * sizeof *values);
        if (!values)
            return -1;
        g->t->values = values;
        g->cap = cap;
    }
    return g->t->n_nodes++;
}

void fo_tree_free(fo_tree *t)
{
    free(t->nodes);
    free(t->values);
    memset(t, 0, sizeof *t);
}

int fo_build_tree(const fo_data *data, const uint8_t *M, const fo_tree_options *o,
                  uint64_t seed, uint64_t index, fo_tree *out)
{
    const size_t n = data->n, d = data->d, k = data->k, kp = fo_padded(k);
    const int masked = o->masked && M;
    memset(out, 0, sizeof *out);
    fo_rng rng;
    fo_rng_seed(&rng, seed, index);

    double *w = calloc(n, sizeof *w);
    fo_acc *wy = calloc(n * kp, sizeof *wy);
    fo_acc *wm = masked ? calloc(n * kp, sizeof *wm) : NULL;
    fo_acc *totals = calloc(2 * kp, sizeof *totals); /* the node's sums and weights */
    int32_t *idx = malloc(n * sizeof *idx);
    int32_t *feat = malloc(d * sizeof *feat);
    double *stats = malloc(3 * kp * sizeof *stats);
    pending *stack = malloc((n + 2) * sizeof *stack);
    fo_splitter sp;
    int sp_ok = 0, rc = -1;
    if (!w || !wy || (masked && !wm) || !totals || !idx || !feat || !stats || !stack)
        goto done;
    if (fo_splitter_init(&sp, data, masked, o->min_samples_leaf))
        goto done;
    sp_ok = 1;

    /* Bootstrap: n draws with replacement become row weights (a row drawn c times counts
     * c times in every sum, and once in n_samples, as in scikit-learn). */
    if (o->bootstrap)
        for (size_t i = 0; i < n; i++)
            w[fo_rng_below(&rng, n)] += 1.0;
    else
        for (size_t i = 0; i < n; i++)
            w[i] = 1.0;
    size_t n_in = 0;
    for (size_t i = 0; i < n; i++) {
        if (w[i] > 0.0)
            idx[n_in++] = (int32_t)i;
        for (size_t j = 0; j < k; j++) {
            double m = masked ? (double)M[i * k + j] : 1.0;
            wy[i * kp + j] = (fo_acc)(w[i] * m * (double)data->Y[i * k + j]);
            if (masked)
                wm[i * kp + j] = (fo_acc)(w[i] * m);
        }
    }
    for (size_t f = 0; f < d; f++)
        feat[f] = (int32_t)f;

    double *sum = stats, *sumsq = stats + kp, *wsum = stats + 2 * kp;
    tree_growth g = {out, k, 0};
    size_t top = 0;
    stack[top++] = (pending){0, (int32_t)n_in, 0, -1, 0};
    while (top > 0) {
        pending p = stack[--top];
        const int32_t *rows = idx + p.start;
        const size_t nn = (size_t)(p.end - p.start);
        double impurity, wimpurity;
        fo_criterion_node_stats(rows, nn, k, wy, wm, w, data->Y, sum, sumsq, wsum, &impurity,
                                &wimpurity);
        int32_t id = add_node(&g);
        if (id < 0)
            goto done;
        fo_node *node = &out->nodes[id];
        double wn = 0.0;
        for (size_t i = 0; i < nn; i++)
            wn += w[rows[i]];
        *node = (fo_node){-1, -1, -1, (int32_t)nn, 0.0, wn, impurity, wimpurity};
        if (p.parent >= 0) {
            if (p.is_left)
                out->nodes[p.parent].left = id;
            else
                out->nodes[p.parent].right = id;
        }
        /* The node's prediction; an output with no active row here keeps the parent's. */
        float *value = out->values + (size_t)id * k;
        for (size_t j = 0; j < k; j++) {
            double wj = wsum[masked ? j : 0];
            if (wj > 0.0)
                value[j] = (float)(sum[j] / wj + data->y_mean[j]);
            else
                value[j] = p.parent >= 0 ? out->values[(size_t)p.parent * k + j]
                                         : (float)data->y_mean[j]; /* no active row at all */
        }
        int is_leaf = (o->max_depth > 0 && p.depth >= o->max_depth) ||
                      nn < (size_t)o->min_samples_split ||
                      nn < 2 * (size_t)o->min_samples_leaf || impurity <= DBL_EPSILON;
        if (is_leaf)
            continue;
        fo_split best = {-1, 0.0, -1, -DBL_MAX};
        fo_acc *tsum = totals, *tw = totals + kp;
        for (size_t j = 0; j < kp; j++)
            tsum[j] = (fo_acc)sum[j];
        for (size_t j = 0; j < (masked ? kp : 1); j++)
            tw[j] = (fo_acc)wsum[j];
        /* Draw the first max_features at once (in batches, so their values are gathered
         * together), then one at a time while all looked at were constant. */
        size_t visited = 0, constant = 0;
        for (size_t i = 0; i < d && (visited < o->max_features || visited <= constant);) {
            size_t want = visited < o->max_features ? o->max_features - visited : 1;
            size_t nb = want < FO_GATHER_BATCH ? want : FO_GATHER_BATCH;
            if (nb > d - i)
                nb = d - i;
            for (size_t q = 0; q < nb; q++) {
                size_t j = i + q + (size_t)fo_rng_below(&rng, d - i - q);
                int32_t f = feat[j];
                feat[j] = feat[i + q];
                feat[i + q] = f;
            }
            fo_splitter_gather(&sp, rows, nn, feat + i, nb);
            for (size_t q = 0; q < nb; q++) {
                visited++;
                constant += (size_t)fo_splitter_try_gathered(&sp, q, rows, nn,
                                                             (size_t)feat[i + q], wy, wm, w,
                                                             tsum, tw, &best);
            }
            i += nb;
        }
        if (best.feature < 0)
            continue;
        node = &out->nodes[id];
        node->feature = (int32_t)best.feature;
        node->threshold = best.threshold;
        size_t nl = fo_splitter_partition(&sp, idx + p.start, nn, &best);
        assert(nl >= (size_t)o->min_samples_leaf && nn - nl >= (size_t)o->min_samples_leaf);
        /* Right first so the left child is grown (and numbered) first. The stack never
         * holds more than depth + 1 entries, and depth < n. */
        stack[top++] = (pending){p.start + (int32_t)nl, p.end, p.depth + 1, id, 0};
        stack[top++] = (pending){p.start, p.start + (int32_t)nl, p.depth + 1, id, 1};
    }
    rc = 0;
done:
    if (rc)
        fo_tree_free(out);
    if (sp_ok)
        fo_splitter_free(&sp);
    free(w);
    free(wy);
    free(wm);
    free(totals);
    free(idx);
    free(feat);
    free(stats);
    free(stack);
    return rc;
}
