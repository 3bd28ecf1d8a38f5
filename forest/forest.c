/*
 * The forest: checks the inputs, prepares the features once (column-major floats for
 * exact splits, uint8 bins otherwise), fits the trees on a thread pool, and predicts.
 *
 * Determinism: tree t is grown from (seed, t) alone into trees[t]; the pool only decides
 * who grows it. Predictions sum trees in index order.
 */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "forest/forest_impl.h"

forest_params forest_default_params(void)
{
    return (forest_params){
        .n_estimators = 100,
        .max_features = FOREST_MAXF_ALL,
        .max_features_value = 1.0,
        .max_depth = 0,
        .min_samples_split = 2,
        .min_samples_leaf = 1,
        .bootstrap = 1,
        .seed = 0,
        .n_threads = 1,
        .split = FOREST_SPLIT_BINNED,
        .n_bins = 256,
        .mask_mode = FOREST_MASK_EXCLUDE,
    };
}

size_t forest_n_features(const forest *f) { return f->d; }
size_t forest_n_outputs(const forest *f) { return f->k; }
int forest_n_trees(const forest *f) { return f->n_trees; }

size_t forest_n_nodes(const forest *f)
{
    size_t total = 0;
    for (int t = 0; t < f->n_trees; t++)
        total += (size_t)f->trees[t].n_nodes;
    return total;
}

void forest_free(forest *f)
{
    if (!f)
        return;
    for (int t = 0; t < f->n_trees; t++)
        fo_tree_free(&f->trees[t]);
    free(f->trees);
    free(f);
}

/* scikit-learn's resolution of max_features against d features. */
static long resolve_max_features(const forest_params *p, size_t d, char *err, size_t errlen)
{
    double v = p->max_features_value;
    long m;
    switch (p->max_features) {
    case FOREST_MAXF_ALL: m = (long)d; break;
    case FOREST_MAXF_SQRT: m = (long)floor(sqrt((double)d)); break;
    case FOREST_MAXF_LOG2: m = (long)floor(log2((double)d)); break;
    case FOREST_MAXF_FRACTION:
        if (!(v > 0.0 && v <= 1.0)) {
            snprintf(err, errlen, "max_features fraction %g is not in (0, 1]", v);
            return -1;
        }
        m = (long)floor(v * (double)d);
        break;
    case FOREST_MAXF_COUNT:
        if (!(v >= 1.0 && v == floor(v))) {
            snprintf(err, errlen, "max_features count %g is not a positive integer", v);
            return -1;
        }
        m = v > (double)d ? (long)d : (long)v;
        break;
    default: snprintf(err, errlen, "unknown max_features kind %d", (int)p->max_features); return -1;
    }
    return m < 1 ? 1 : m;
}

typedef struct fit_pool {
    const fo_data *data;
    const uint8_t *M;
    fo_tree_options opt;
    uint64_t seed;
    int n_trees;
    fo_tree *trees;
    atomic_int next;
    atomic_int failed;
    pthread_mutex_t lock;
    int done;
    forest_progress_fn progress;
    void *progress_ctx;
} fit_pool;

static void *fit_worker(void *arg)
{
    fit_pool *p = arg;
    for (;;) {
        int t = atomic_fetch_add(&p->next, 1);
        if (t >= p->n_trees || atomic_load(&p->failed))
            return NULL;
        if (fo_build_tree(p->data, p->M, &p->opt, p->seed, (uint64_t)t, &p->trees[t])) {
            atomic_store(&p->failed, 1);
            return NULL;
        }
        pthread_mutex_lock(&p->lock);
        int done = ++p->done;
        if (p->progress)
            p->progress(p->progress_ctx, done, p->n_trees);
        pthread_mutex_unlock(&p->lock);
    }
}

int forest_fit(const float *X, size_t n, size_t d, const float *Y, size_t k,
               const uint8_t *M, const forest_params *p, forest **out, char *err,
               size_t errlen)
{
    *out = NULL;
    if (n < 1 || d < 1 || k < 1 || n > INT32_MAX - 2 || d > INT32_MAX) {
        snprintf(err, errlen, "need at least one row, feature and output (got %zu x %zu -> %zu)",
                 n, d, k);
        return -1;
    }
    if (p->n_estimators < 1 || p->min_samples_split < 2 || p->min_samples_leaf < 1 ||
        p->max_depth < 0 || p->n_threads < 1 || p->n_bins < 2 || p->n_bins > 256) {
        snprintf(err, errlen,
                 "bad parameters: trees %d (>= 1), min_samples_split %d (>= 2), "
                 "min_samples_leaf %d (>= 1), max_depth %d (>= 0), threads %d (>= 1), "
                 "bins %d (2..256)",
                 p->n_estimators, p->min_samples_split, p->min_samples_leaf, p->max_depth,
                 p->n_threads, p->n_bins);
        return -1;
    }
    long max_features = resolve_max_features(p, d, err, errlen);
    if (max_features < 0)
        return -1;
    for (size_t i = 0; i < n * d; i++)
        if (!isfinite(X[i])) {
            snprintf(err, errlen, "X[%zu, %zu] is not finite (%g)", i / d, i % d, (double)X[i]);
            return -1;
        }
    /* Our copy of Y: masked targets are zeroed (exclude) or set to their output's mean
     * over active rows (impute), so they may be anything, even NaN, in the caller's Y. */
    float *Yc = malloc(n * k * sizeof *Yc);
    if (!Yc) {
        snprintf(err, errlen, "out of memory copying Y (%zu x %zu)", n, k);
        return -1;
    }
    for (size_t i = 0; i < n * k; i++) {
        int active = !M || M[i];
        if (active && !isfinite(Y[i])) {
            snprintf(err, errlen, "Y[%zu, %zu] is not finite (%g)", i / k, i % k, (double)Y[i]);
            free(Yc);
            return -1;
        }
        Yc[i] = active ? Y[i] : 0.0f;
    }
    /* Centre each output on its active rows' mean (impute: masked entries get exactly
     * that mean, i.e. zero after centring). Variances, hence trees, do not change; float
     * split sums stay relative to the spread. */
    double *y_mean = calloc(k, sizeof *y_mean);
    if (!y_mean) {
        snprintf(err, errlen, "out of memory");
        free(Yc);
        return -1;
    }
    for (size_t j = 0; j < k; j++) {
        size_t c;
        y_mean[j] = fo_active_mean(Yc, M, n, k, j, &c);
        for (size_t i = 0; i < n; i++)
            Yc[i * k + j] = !M || M[i * k + j] ? (float)(Yc[i * k + j] - y_mean[j]) : 0.0f;
    }
    const uint8_t *Mfit = M && p->mask_mode == FOREST_MASK_EXCLUDE ? M : NULL;

    fo_data data = {n, d, k, NULL, NULL, Yc, y_mean};
    fo_bins bins;
    float *Xc = NULL;
    int have_bins = 0, rc = -1;
    forest *f = calloc(1, sizeof *f);
    fo_tree *trees = calloc((size_t)p->n_estimators, sizeof *trees);
    if (!f || !trees) {
        snprintf(err, errlen, "out of memory");
        goto done;
    }
    if (p->split == FOREST_SPLIT_BINNED) {
        if (fo_bins_build(X, n, d, p->n_bins, p->n_threads, &bins, err, errlen))
            goto done;
        have_bins = 1;
        data.bins = &bins;
    } else {
        Xc = malloc(n * d * sizeof *Xc);
        if (!Xc) {
            snprintf(err, errlen, "out of memory transposing X (%zu x %zu)", n, d);
            goto done;
        }
        for (size_t i = 0; i < n; i++)
            for (size_t j = 0; j < d; j++)
                Xc[j * n + i] = X[i * d + j];
        data.Xc = Xc;
    }

    fit_pool pool = {
        .data = &data,
        .M = Mfit,
        .opt = {(size_t)max_features, p->max_depth, p->min_samples_split, p->min_samples_leaf,
                p->bootstrap, Mfit != NULL},
        .seed = p->seed,
        .n_trees = p->n_estimators,
        .trees = trees,
        .progress = p->progress,
        .progress_ctx = p->progress_ctx,
    };
    atomic_init(&pool.next, 0);
    atomic_init(&pool.failed, 0);
    pthread_mutex_init(&pool.lock, NULL);
    int n_workers = p->n_threads < p->n_estimators ? p->n_threads : p->n_estimators;
    pthread_t *tids = calloc((size_t)n_workers, sizeof *tids);
    int started = 0;
    if (tids)
        for (; started + 1 < n_workers; started++)
            if (pthread_create(&tids[started], NULL, fit_worker, &pool))
                break;
    fit_worker(&pool); /* this thread works too */
    for (int i = 0; i < started; i++)
        pthread_join(tids[i], NULL);
    free(tids);
    pthread_mutex_destroy(&pool.lock);
    if (atomic_load(&pool.failed)) {
        snprintf(err, errlen, "out of memory growing trees");
        goto done;
    }
    f->d = d;
    f->k = k;
    f->n_trees = p->n_estimators;
    f->trees = trees;
    trees = NULL;
    *out = f;
    f = NULL;
    rc = 0;
done:
    if (trees)
        for (int t = 0; t < p->n_estimators; t++)
            fo_tree_free(&trees[t]);
    free(trees);
    free(f);
    free(Xc);
    if (have_bins)
        fo_bins_free(&bins);
    free(Yc);
    free(y_mean);
    return rc;
}

/* ------------------------------------------------------------------ predict ------- */

/* The leaf of tree t reached by row x, with x[swap_feature] read as swap_value instead
 * (swap_feature = SIZE_MAX: none). */
static const float *leaf_value(const forest *f, int t, const float *x, size_t swap_feature,
                               float swap_value)
{
    const fo_tree *tr = &f->trees[t];
    int32_t i = 0;
    while (tr->nodes[i].left >= 0) {
        const fo_node *nd = &tr->nodes[i];
        float v = (size_t)nd->feature == swap_feature ? swap_value : x[nd->feature];
        i = (double)v <= nd->threshold ? nd->left : nd->right;
    }
    return tr->values + (size_t)i * f->k;
}

void fo_predict_rows(const forest *f, const float *X, size_t r0, size_t r1,
                         size_t swap_feature, const float *swap, float *Y_out, double *acc)
{
    const size_t k = f->k, d = f->d;
    for (size_t r = r0; r < r1; r++) {
        for (size_t j = 0; j < k; j++)
            acc[j] = 0.0;
        const float *x = X + r * d;
        float sv = swap ? swap[r] : 0.0f;
        for (int t = 0; t < f->n_trees; t++) {
            const float *v = leaf_value(f, t, x, swap_feature, sv);
            for (size_t j = 0; j < k; j++)
                acc[j] += v[j];
        }
        for (size_t j = 0; j < k; j++)
            Y_out[r * k + j] = (float)(acc[j] / f->n_trees);
    }
}

typedef struct predict_job {
    const forest *f;
    const float *X;
    size_t r0, r1;
    float *Y;
    int failed;
} predict_job;

static void *predict_worker(void *arg)
{
    predict_job *j = arg;
    double *acc = malloc(j->f->k * sizeof *acc);
    if (!acc) {
        j->failed = 1;
        return NULL;
    }
    fo_predict_rows(j->f, j->X, j->r0, j->r1, SIZE_MAX, NULL, j->Y, acc);
    free(acc);
    return NULL;
}

int forest_predict(const forest *f, const float *X, size_t n, float *Y_out, int n_threads)
{
    enum { MAX_PREDICT_THREADS = 64 };
    if (n_threads < 1)
        n_threads = 1;
    if (n_threads > MAX_PREDICT_THREADS)
        n_threads = MAX_PREDICT_THREADS;
    if ((size_t)n_threads > n)
        n_threads = n ? (int)n : 1;
    predict_job jobs[MAX_PREDICT_THREADS];
    pthread_t tids[MAX_PREDICT_THREADS];
    int started[MAX_PREDICT_THREADS] = {0};
    for (int t = 0; t < n_threads; t++)
        jobs[t] = (predict_job){f, X, n * (size_t)t / (size_t)n_threads,
                                n * (size_t)(t + 1) / (size_t)n_threads, Y_out, 0};
    for (int t = 0; t + 1 < n_threads; t++)
        started[t] = !pthread_create(&tids[t], NULL, predict_worker, &jobs[t]);
    for (int t = 0; t < n_threads; t++)
        if (t + 1 == n_threads || !started[t])
            predict_worker(&jobs[t]);
    for (int t = 0; t < n_threads; t++)
        if (started[t])
            pthread_join(tids[t], NULL);
    int failed = 0;
    for (int t = 0; t < n_threads; t++)
        failed |= jobs[t].failed;
    return failed ? -1 : 0;
}
