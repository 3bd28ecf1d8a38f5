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
    const size_t n = data->n, d = data->d, k = data->k;
    const int masked = o->masked && M;
    memset(out, 0, sizeof *out);
    fo_rng rng;
    fo_rng_seed(&rng, seed, index);

    double *w = calloc(n, sizeof *w);
    double *wy = malloc(n * k * sizeof *wy);
    double *wm = masked ? malloc(n * k * sizeof *wm) : NULL;
    int32_t *idx = malloc(n * sizeof *idx);
    int32_t *feat = malloc(d * sizeof *feat);
    double *stats = malloc(3 * k * sizeof *stats);
    pending *stack = malloc((n + 2) * sizeof *stack);
    fo_splitter sp;
    int sp_ok = 0, rc = -1;
    if (!w || !wy || (masked && !wm) || !idx || !feat || !stats || !stack)
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
            wy[i * k + j] = w[i] * m * (double)data->Y[i * k + j];
            if (masked)
                wm[i * k + j] = w[i] * m;
        }
    }
    for (size_t f = 0; f < d; f++)
        feat[f] = (int32_t)f;

    double *sum = stats, *sumsq = stats + k, *wsum = stats + 2 * k;
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
                value[j] = (float)(sum[j] / wj);
            else
                value[j] = p.parent >= 0 ? out->values[(size_t)p.parent * k + j] : 0.0f;
        }
        int is_leaf = (o->max_depth > 0 && p.depth >= o->max_depth) ||
                      nn < (size_t)o->min_samples_split ||
                      nn < 2 * (size_t)o->min_samples_leaf || impurity <= DBL_EPSILON;
        if (is_leaf)
            continue;
        fo_split best = {-1, 0.0, -1, -DBL_MAX};
        size_t visited = 0, constant = 0;
        for (size_t i = 0; i < d && (visited < o->max_features || visited <= constant); i++) {
            size_t j = i + (size_t)fo_rng_below(&rng, d - i);
            int32_t f = feat[j];
            feat[j] = feat[i];
            feat[i] = f;
            visited++;
            constant += (size_t)fo_splitter_try_feature(&sp, rows, nn, (size_t)f, wy, wm, w,
                                                        sum, wsum, &best);
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
    free(idx);
    free(feat);
    free(stats);
    free(stack);
    return rc;
}
