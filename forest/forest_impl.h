/*
 * forest internals shared by the folder's files (and by its unit tests); not a public
 * interface. The layout follows scikit-learn's tree module: a criterion scores candidate
 * splits from sufficient statistics, a splitter turns one node's samples and one feature
 * into those statistics, a builder grows one tree depth-first, and forest.c runs the
 * builders over a thread pool.
 */
#ifndef IMSYNTH_FOREST_IMPL_H
#define IMSYNTH_FOREST_IMPL_H

#include <stddef.h>
#include <stdint.h>

#include "forest/forest.h"

/* scikit-learn's FEATURE_THRESHOLD: values closer than this are one value when splitting. */
#define FO_FEATURE_THRESHOLD 1e-7f

/* ------------------------------------------------------------ random numbers ------ */

/* xoshiro256** seeded through splitmix64 from (seed, stream): tree t uses stream t, so a
 * tree's draws never depend on which thread fits it. */
typedef struct fo_rng {
    uint64_t s[4];
} fo_rng;

static inline uint64_t fo_splitmix64(uint64_t *x)
{
    uint64_t z = (*x += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static inline void fo_rng_seed(fo_rng *r, uint64_t seed, uint64_t stream)
{
    uint64_t x = seed ^ (stream * 0xd1342543de82ef95ull + 0x2545f4914f6cdd1dull);
    for (int i = 0; i < 4; i++)
        r->s[i] = fo_splitmix64(&x);
}

static inline uint64_t fo_rng_next(fo_rng *r)
{
    uint64_t *s = r->s;
    uint64_t x = s[1] * 5;
    uint64_t out = ((x << 7) | (x >> 57)) * 9;
    uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = (s[3] << 45) | (s[3] >> 19);
    return out;
}

/* Uniform in [0, n), n >= 1 (rejection sampling: no modulo bias). */
static inline uint64_t fo_rng_below(fo_rng *r, uint64_t n)
{
    uint64_t limit = UINT64_MAX - UINT64_MAX % n;
    uint64_t x;
    do
        x = fo_rng_next(r);
    while (x >= limit);
    return x % n;
}

/* The mean of output j of Y (n x k) over the rows M marks active (M NULL: all of them);
 * *count gets how many there are (the mean is 0 if none). */
static inline double fo_active_mean(const float *Y, const uint8_t *M, size_t n, size_t k,
                                    size_t j, size_t *count)
{
    double s = 0.0;
    size_t c = 0;
    for (size_t i = 0; i < n; i++)
        if (!M || M[i * k + j]) {
            s += Y[i * k + j];
            c++;
        }
    *count = c;
    return c ? s / (double)c : 0.0;
}

/* ------------------------------------------------------------------- trees -------- */

/* One node. A leaf has left == right == -1 and feature == -1. Children always have larger
 * indices than their parent (so prediction terminates on any validated tree). */
typedef struct fo_node {
    int32_t left, right;
    int32_t feature;
    int32_t n_samples;  /* distinct training rows that reached the node */
    double threshold;   /* a row goes left if x[feature] <= threshold */
    double weighted_n;  /* rows counted with their bootstrap multiplicity */
    double impurity;    /* mean over outputs of the rows' variance */
    double wimpurity;   /* mean over outputs of the rows' weighted sum of squared deviations
                           (= weighted_n * impurity without a mask) */
} fo_node;

typedef struct fo_tree {
    int32_t n_nodes;
    fo_node *nodes;
    float *values; /* n_nodes x k: the node's prediction */
} fo_tree;

struct forest {
    size_t d, k;
    int n_trees;
    fo_tree *trees;
};

/* ---------------------------------------------------------------- criterion ------- */

/* Split search accumulates targets in float: twice the vector lanes and half the memory
 * traffic of double. Targets are centred on their mean first (forest.c), so a proxy's
 * rounding is relative to the spread, not the offset, of the targets. Node statistics
 * (impurities, predictions) are summed in double. */
typedef float fo_acc;

/* Sufficient statistics of the candidate groups of one node along one feature, in
 * increasing feature order: group g holds count[g] distinct rows, weight w[g] (or, with a
 * mask, wk[g][j] per output), and the weighted target sums sum[g][j]. A group of one row
 * points into the tree's per-row arrays; larger ones into buf_sum / buf_w. A split puts
 * groups [0, s] left and (s, n_groups) right. */
typedef struct fo_groups {
    size_t n_groups, k;
    int masked;
    const fo_acc **sum; /* n_groups rows of k */
    const fo_acc **wk;  /* masked: n_groups rows of k */
    fo_acc *w;          /* unmasked: n_groups */
    int32_t *count;     /* n_groups */
    fo_acc *buf_sum, *buf_w; /* storage of the groups of several rows */
} fo_groups;

/* The best split of g (largest proxy improvement, the first on equality) keeping at least
 * min_leaf rows on each side, given the node's totals (total_w: 1 or k values). Returns the
 * last left group, or -1 if no split is valid; *proxy gets its score. scratch: 2k doubles.
 * k is a multiple of FO_LANES here (padded outputs are zero). */
long fo_criterion_best_split(const fo_groups *g, const fo_acc *total_sum,
                             const fo_acc *total_w, int32_t total_count, int min_leaf,
                             double *proxy, fo_acc *scratch);

/* Statistics of rows idx[0..n), in double from Y (rows of k): per output the weighted sum,
 * the weighted sum of squares and the weight (wm = w*m per row and output in rows of
 * kp = fo_padded(k); wm NULL: unmasked, row weights w). sum, sumsq and (masked) wsum get kp
 * values, the padding zero. wy is unused (kept for symmetry with the splitter). Writes
 * impurity and weighted impurity as fo_node defines them. */
void fo_criterion_node_stats(const int32_t *idx, size_t n, size_t k, const fo_acc *wy,
                             const fo_acc *wm, const double *w, const float *Y,
                             double *sum, double *sumsq, double *wsum, double *impurity,
                             double *wimpurity);

/* ----------------------------------------------------------------- binning -------- */

/* Quantile bins of every feature: bin(x) = the first b with x <= edges[b], or n_edges if
 * none, so bin(x) <= b exactly when x <= edges[b]. codes is column-major (d x n). */
typedef struct fo_bins {
    int max_bins;
    float *edges;     /* d x (max_bins - 1) */
    uint16_t *n_edges; /* d */
    uint8_t *codes;   /* d x n */
} fo_bins;

int fo_bins_build(const float *X, size_t n, size_t d, int max_bins, int n_threads,
                  fo_bins *b, char *err, size_t errlen);
void fo_bins_free(fo_bins *b);
/* Edges of one sorted column (n values): at most max_bins - 1; returns their number. */
int fo_bins_edges(const float *sorted, size_t n, int max_bins, float *edges);

/* ---------------------------------------------------------------- splitter -------- */

/* Rows of per-output statistics are padded with zeros to a multiple of FO_LANES doubles
 * so that their loops vectorise without remainders; zero outputs add nothing to any sum. */
#define FO_LANES 16
static inline size_t fo_padded(size_t k) { return (k + FO_LANES - 1) / FO_LANES * FO_LANES; }

/* What a splitter reads: features column-major, as floats (exact) or bin codes. */
typedef struct fo_data {
    size_t n, d, k;
    const float *Xc;     /* exact: d x n */
    const fo_bins *bins; /* binned */
    const float *Y;      /* n x k, centred (masked entries zero in exclude mode) */
    const double *y_mean; /* k: what centring took off, added back to predictions */
} fo_data;

/* Features whose node values are gathered at once (see fo_splitter_gather). */
enum { FO_GATHER_BATCH = 64 };

typedef struct fo_splitter {
    const fo_data *data;
    int masked;
    int min_leaf;
    fo_groups g;
    /* exact mode: sorted (value, row) pairs and each group's first and last value */
    float *xs;
    int32_t *rows;
    float *lo, *hi;
    /* gathered node values: FO_GATHER_BATCH x n codes (binned) or floats (exact) */
    uint8_t *gathered_codes;
    float *gathered_vals;
    int32_t *first_row; /* binned mode: a row of each group */
    /* binned mode: a bin's group (valid for the bins present in the last call) */
    int32_t slot_of[256];
    int32_t slot_bin[256];
    fo_acc *scratch;
} fo_splitter;

typedef struct fo_split {
    long feature; /* -1: none */
    double threshold;
    int bin;      /* binned mode: left if code <= bin */
    double proxy;
} fo_split;

int fo_splitter_init(fo_splitter *s, const fo_data *data, int masked, int min_leaf);
void fo_splitter_free(fo_splitter *s);
/* Groups of rows idx[0..n) along feature f; returns the number of groups (1: constant). */
size_t fo_splitter_groups(fo_splitter *s, const int32_t *idx, size_t n, size_t f,
                          const fo_acc *wy, const fo_acc *wm, const double *w);
/* Copies the values of rows idx[0..n) for count <= FO_GATHER_BATCH features into the
 * splitter, for fo_splitter_try_gathered(q = 0..count-1). */
void fo_splitter_gather(fo_splitter *s, const int32_t *idx, size_t n, const int32_t *features,
                        size_t count);
/* Best split of rows idx[0..n) along the q-th gathered feature f (updates *best if
 * better; returns 1 if f is constant in the node). */
int fo_splitter_try_gathered(fo_splitter *s, size_t q, const int32_t *idx, size_t n,
                             size_t f, const fo_acc *wy, const fo_acc *wm, const double *w,
                             const fo_acc *total_sum, const fo_acc *total_w, fo_split *best);
/* The same for one feature, gathering it first. */
int fo_splitter_try_feature(fo_splitter *s, const int32_t *idx, size_t n, size_t f,
                            const fo_acc *wy, const fo_acc *wm, const double *w,
                            const fo_acc *total_sum, const fo_acc *total_w, fo_split *best);
/* Reorders idx[0..n) so rows going left come first; returns how many go left. */
size_t fo_splitter_partition(const fo_splitter *s, int32_t *idx, size_t n,
                             const fo_split *split);

/* ----------------------------------------------------------------- builder -------- */

typedef struct fo_tree_options {
    size_t max_features;
    int max_depth; /* 0: unlimited */
    int min_samples_split, min_samples_leaf;
    int bootstrap;
    int masked;
} fo_tree_options;

/* Rows [r0, r1) of X (n x d) into Y_out (n x k), with column swap_feature read from
 * swap[r] instead (SIZE_MAX: none); acc: k doubles of scratch. */
void fo_predict_rows(const forest *f, const float *X, size_t r0, size_t r1,
                     size_t swap_feature, const float *swap, float *Y_out, double *acc);

/* Grow tree `index` of a forest seeded with `seed`. M: n x k mask or NULL. */
int fo_build_tree(const fo_data *data, const uint8_t *M, const fo_tree_options *o,
                  uint64_t seed, uint64_t index, fo_tree *out);
void fo_tree_free(fo_tree *t);

#endif
