/*
 * forest: multi-output random forests of CART regression trees, as scikit-learn's
 * RandomForestRegressor fits them with a 2-D y (criterion "squared_error"), to rank
 * descriptor features by importance.
 *
 * Data are plain arrays: X is n x d floats (row-major), Y is n x k floats, and an optional
 * mask M (n x k bytes, 1 = the target is active, 0 = ignore it). Nothing here knows about
 * files other than the forest's own save/load.
 *
 * Split semantics (exact mode, FOREST_SPLIT_EXACT) are scikit-learn's: a node's samples
 * are sorted by a feature, candidate thresholds lie halfway between consecutive values
 * that differ by more than 1e-7, a sample goes left if x <= threshold, both children keep
 * at least min_samples_leaf samples, and the split maximising the weighted variance
 * reduction summed over outputs wins (the first found on equality). Binned mode
 * (FOREST_SPLIT_BINNED) first maps each feature to at most n_bins quantile bins (uint8)
 * and then only tries thresholds at bin edges; when a feature has no more distinct values
 * than bins, its bins are exactly its distinct values and the two modes split alike.
 * Candidate splits are scored from float sums of centred targets (twice the vector width
 * of double); impurities, importances and predictions are computed in double. On
 * scikit-learn's fixture (tests/reference/forest) exact trees predict within 1e-5.
 *
 * Masked targets (mask given): in FOREST_MASK_EXCLUDE mode each output's sums and weights
 * run over its active rows only (a node's impurity is the mean over outputs of the
 * variance of its active rows; a leaf predicts the mean of its active rows, or its nearest
 * ancestor's value if it has none); in FOREST_MASK_IMPUTE mode masked targets are replaced
 * by their output's mean over active rows before fitting. With no mask both are the plain
 * criterion. BENCHMARKS.md measures the two.
 *
 * Memory beyond the caller's arrays: binned mode keeps one byte per value of X (plus
 * 255 float edges per feature), exact mode a column-major float copy of X; each fitting
 * thread needs O(n * k) more.
 *
 * Results do not depend on the thread count: tree t draws from a generator seeded by
 * (seed, t) alone and is written to its own slot.
 */
#ifndef IMSYNTH_FOREST_H
#define IMSYNTH_FOREST_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum forest_max_features {
    FOREST_MAXF_ALL = 0,  /* every feature (scikit-learn 1.2's default, 1.0) */
    FOREST_MAXF_SQRT,     /* max(1, floor(sqrt(d))) */
    FOREST_MAXF_LOG2,     /* max(1, floor(log2(d))) */
    FOREST_MAXF_FRACTION, /* max(1, floor(value * d)), 0 < value <= 1 */
    FOREST_MAXF_COUNT,    /* min(value, d) */
} forest_max_features;

typedef enum forest_split { FOREST_SPLIT_EXACT = 0, FOREST_SPLIT_BINNED } forest_split;
typedef enum forest_mask_mode { FOREST_MASK_EXCLUDE = 0, FOREST_MASK_IMPUTE } forest_mask_mode;

/* Called after each fitted tree (from a worker thread, serialised by the forest). */
typedef void (*forest_progress_fn)(void *ctx, int trees_done, int trees_total);

typedef struct forest_params {
    int n_estimators;          /* trees (>= 1) */
    forest_max_features max_features;
    double max_features_value; /* for FRACTION and COUNT */
    int max_depth;             /* 0: unlimited */
    int min_samples_split;     /* >= 2 */
    int min_samples_leaf;      /* >= 1 */
    int bootstrap;             /* 1: each tree sees n rows drawn with replacement */
    uint64_t seed;
    int n_threads;             /* >= 1 */
    forest_split split;
    int n_bins;                /* binned mode: 2..256 */
    forest_mask_mode mask_mode;
    forest_progress_fn progress; /* may be NULL */
    void *progress_ctx;
} forest_params;

/* scikit-learn's defaults (100 trees, all features, unlimited depth, split 2, leaf 1,
 * bootstrap), seed 0, 1 thread, binned with 256 bins, masked targets excluded. */
forest_params forest_default_params(void);

typedef struct forest forest;

/* Fit a forest to X (n x d), Y (n x k) and the optional mask M (n x k, NULL: all active).
 * X and the active entries of Y must be finite. Returns 0 and *out, or -1 with a message. */
int forest_fit(const float *X, size_t n, size_t d, const float *Y, size_t k,
               const uint8_t *M, const forest_params *p, forest **out, char *err,
               size_t errlen);

/* Y_out (n x k) = the mean of the trees' predictions for X (n x d). Returns 0, or -1 out
 * of memory. */
int forest_predict(const forest *f, const float *X, size_t n, float *Y_out, int n_threads);

size_t forest_n_features(const forest *f);
size_t forest_n_outputs(const forest *f);
int forest_n_trees(const forest *f);
/* Total nodes over all trees (for reports). */
size_t forest_n_nodes(const forest *f);

/* Impurity-based importances (d doubles), scikit-learn's feature_importances_: per tree
 * the weighted impurity decrease of every split credited to its feature, normalised to
 * sum 1; averaged over trees with at least one split; normalised again. 0, or -1 out of
 * memory. */
int forest_feature_importances(const forest *f, double *importance);

/* Mean over outputs of R^2 of the forest's predictions on (X, Y), each output over its
 * active rows (M may be NULL); outputs with no variance are skipped. NaN out of memory. */
double forest_score(const forest *f, const float *X, const float *Y, const uint8_t *M,
                    size_t n, int n_threads);

/* Permutation importance on held-out rows: for each of the n_eval features in `features`
 * (NULL: all d, in order), the mean and standard deviation over n_repeats shuffles of that
 * column of the drop in forest_score. Results depend on (seed, feature) only. */
int forest_permutation_importance(const forest *f, const float *X, const float *Y,
                                  const uint8_t *M, size_t n, const size_t *features,
                                  size_t n_eval, int n_repeats, uint64_t seed, int n_threads,
                                  double *mean, double *std, char *err, size_t errlen);

/* The indices of the k largest values of score (d of them), largest first, ties broken by
 * the lower index (NaN ranks last). 0, or -1 out of memory. */
int forest_top_k(const double *score, size_t d, size_t k, size_t *indices);

/* Save through a temporary file renamed into place; load checks the version, every size
 * against the file's length before allocating, every node index and a checksum. Both
 * return 0, or -1 with a message naming the file and the place. */
int forest_save(const forest *f, const char *path, char *err, size_t errlen);
int forest_load(const char *path, forest **out, char *err, size_t errlen);

void forest_free(forest *f);

#ifdef __cplusplus
}
#endif
#endif
