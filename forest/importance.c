/*
 * Feature importances and scores: scikit-learn's impurity-based feature_importances_,
 * R^2 over active targets, permutation importance on held-out rows, top-k selection.
 */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "forest/forest_impl.h"

/* ---------------------------------------------------------------- importance ------ */

int forest_feature_importances(const forest *f, double *importance)
{
    const size_t d = f->d;
    double *tree_imp = calloc(d, sizeof *tree_imp);
    for (size_t j = 0; j < d; j++)
        importance[j] = 0.0;
    if (!tree_imp)
        return -1;
    for (int t = 0; t < f->n_trees; t++) {
        const fo_tree *tr = &f->trees[t];
        if (tr->n_nodes <= 1)
            continue; /* scikit-learn skips trees that are a single leaf */
        memset(tree_imp, 0, d * sizeof *tree_imp);
        double total = 0.0;
        for (int32_t i = 0; i < tr->n_nodes; i++) {
            const fo_node *nd = &tr->nodes[i];
            if (nd->left < 0)
                continue;
            double dec = nd->wimpurity - tr->nodes[nd->left].wimpurity -
                         tr->nodes[nd->right].wimpurity;
            tree_imp[nd->feature] += dec;
        }
        for (size_t j = 0; j < d; j++)
            total += tree_imp[j];
        if (total > 0.0)
            for (size_t j = 0; j < d; j++)
                importance[j] += tree_imp[j] / total;
    }
    double total = 0.0;
    for (size_t j = 0; j < d; j++)
        total += importance[j];
    if (total > 0.0)
        for (size_t j = 0; j < d; j++)
            importance[j] /= total;
    free(tree_imp);
    return 0;
}

/* Mean over outputs of R^2 of P against Y on active rows (outputs without variance are
 * skipped; none left: 0). */
static double r2_mean(const float *P, const float *Y, const uint8_t *M, size_t n, size_t k)
{
    double total = 0.0;
    size_t used = 0;
    for (size_t j = 0; j < k; j++) {
        size_t c;
        double mean = fo_active_mean(Y, M, n, k, j, &c), sse = 0.0, sst = 0.0;
        if (c == 0)
            continue;
        for (size_t i = 0; i < n; i++)
            if (!M || M[i * k + j]) {
                double e = (double)Y[i * k + j] - P[i * k + j], v = Y[i * k + j] - mean;
                sse += e * e;
                sst += v * v;
            }
        if (sst <= 0.0)
            continue;
        total += 1.0 - sse / sst;
        used++;
    }
    return used ? total / (double)used : 0.0;
}

double forest_score(const forest *f, const float *X, const float *Y, const uint8_t *M,
                    size_t n, int n_threads)
{
    float *P = malloc(n * f->k * sizeof *P);
    if (!P)
        return NAN;
    if (forest_predict(f, X, n, P, n_threads)) {
        free(P);
        return NAN;
    }
    double r2 = r2_mean(P, Y, M, n, f->k);
    free(P);
    return r2;
}

typedef struct perm_pool {
    const forest *f;
    const float *X, *Y;
    const uint8_t *M;
    size_t n;
    const size_t *features;
    size_t n_eval;
    int n_repeats;
    uint64_t seed;
    double baseline;
    double *mean, *std;
    atomic_size_t next;
    atomic_int failed;
} perm_pool;

static void *perm_worker(void *arg)
{
    perm_pool *p = arg;
    const size_t n = p->n, k = p->f->k, d = p->f->d;
    float *col = malloc(n * sizeof *col);
    float *P = malloc(n * k * sizeof *P);
    double *acc = malloc(k * sizeof *acc);
    double *drops = malloc((size_t)p->n_repeats * sizeof *drops);
    if (!col || !P || !acc || !drops) {
        atomic_store(&p->failed, 1);
        goto done;
    }
    for (;;) {
        size_t e = atomic_fetch_add(&p->next, 1);
        if (e >= p->n_eval)
            break;
        size_t feature = p->features ? p->features[e] : e;
        fo_rng rng;
        fo_rng_seed(&rng, p->seed, (uint64_t)feature);
        for (size_t i = 0; i < n; i++)
            col[i] = p->X[i * d + feature];
        double s = 0.0, ss = 0.0;
        for (int rep = 0; rep < p->n_repeats; rep++) {
            for (size_t i = n; i > 1; i--) { /* Fisher-Yates, continuing from the last */
                size_t j = (size_t)fo_rng_below(&rng, i);
                float t = col[i - 1];
                col[i - 1] = col[j];
                col[j] = t;
            }
            fo_predict_rows(p->f, p->X, 0, n, feature, col, P, acc);
            drops[rep] = p->baseline - r2_mean(P, p->Y, p->M, n, k);
            s += drops[rep];
        }
        double m = s / p->n_repeats;
        for (int rep = 0; rep < p->n_repeats; rep++)
            ss += (drops[rep] - m) * (drops[rep] - m);
        p->mean[e] = m;
        p->std[e] = sqrt(ss / p->n_repeats);
    }
done:
    free(col);
    free(P);
    free(acc);
    free(drops);
    return NULL;
}

int forest_permutation_importance(const forest *f, const float *X, const float *Y,
                                  const uint8_t *M, size_t n, const size_t *features,
                                  size_t n_eval, int n_repeats, uint64_t seed, int n_threads,
                                  double *mean, double *std, char *err, size_t errlen)
{
    if (n < 2 || n_repeats < 1) {
        snprintf(err, errlen, "permutation importance needs >= 2 rows and >= 1 repeat");
        return -1;
    }
    if (!features)
        n_eval = f->d;
    for (size_t e = 0; features && e < n_eval; e++)
        if (features[e] >= f->d) {
            snprintf(err, errlen, "feature %zu is out of range (the forest has %zu)",
                     features[e], f->d);
            return -1;
        }
    double baseline = forest_score(f, X, Y, M, n, n_threads);
    if (isnan(baseline)) {
        snprintf(err, errlen, "out of memory predicting %zu rows", n);
        return -1;
    }
    perm_pool pool = {.f = f, .X = X, .Y = Y, .M = M, .n = n, .features = features,
                      .n_eval = n_eval, .n_repeats = n_repeats, .seed = seed,
                      .baseline = baseline, .mean = mean, .std = std};
    atomic_init(&pool.next, 0);
    atomic_init(&pool.failed, 0);
    enum { MAX_PERM_THREADS = 64 };
    if (n_threads < 1)
        n_threads = 1;
    if (n_threads > MAX_PERM_THREADS)
        n_threads = MAX_PERM_THREADS;
    pthread_t tids[MAX_PERM_THREADS];
    int started = 0;
    for (; started + 1 < n_threads; started++)
        if (pthread_create(&tids[started], NULL, perm_worker, &pool))
            break;
    perm_worker(&pool);
    for (int i = 0; i < started; i++)
        pthread_join(tids[i], NULL);
    if (atomic_load(&pool.failed)) {
        snprintf(err, errlen, "out of memory in permutation importance");
        return -1;
    }
    return 0;
}

/* --------------------------------------------------------------------- top k ------ */

typedef struct scored {
    double score;
    size_t index;
} scored;

static int cmp_scored(const void *a, const void *b)
{
    const scored *x = a, *y = b;
    if (x->score != y->score)
        return x->score > y->score ? -1 : 1;
    return (x->index > y->index) - (x->index < y->index);
}

int forest_top_k(const double *score, size_t d, size_t k, size_t *indices)
{
    if (k > d)
        k = d;
    scored *s = malloc(d * sizeof *s);
    if (!s)
        return -1;
    for (size_t j = 0; j < d; j++)
        s[j] = (scored){isnan(score[j]) ? -INFINITY : score[j], j};
    qsort(s, d, sizeof *s, cmp_scored);
    for (size_t r = 0; r < k; r++)
        indices[r] = s[r].index;
    free(s);
    return 0;
}
