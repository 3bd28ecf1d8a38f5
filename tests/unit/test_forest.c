/* forest: exact trees against scikit-learn's (tests/reference/forest/make_fixture.py),
 * random-forest accuracy against scikit-learn's, binned against exact, thread-count
 * independence, masked targets, permutation importance, save/load and bad files. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "forest/forest.h"
#include "nn/nn.h"

#define REF IMSYNTH_SOURCE_DIR "/tests/reference/forest/"

static float *load(const char *name, size_t *rows, size_t *cols)
{
    char err[512];
    float *a = NULL;
    if (nn_npy_read_f32(name, &a, rows, cols, err, sizeof err))
        fail_msg("%s", err);
    return a;
}

static int quick(void) { return getenv("IMSYNTH_TEST_QUICK") != NULL; }

static forest *fit_or_fail(const float *X, size_t n, size_t d, const float *Y, size_t k,
                           const uint8_t *M, const forest_params *p)
{
    char err[512];
    forest *f = NULL;
    if (forest_fit(X, n, d, Y, k, M, p, &f, err, sizeof err))
        fail_msg("forest_fit: %s", err);
    return f;
}

static forest_params deterministic(void)
{
    forest_params p = forest_default_params();
    p.n_estimators = 1;
    p.bootstrap = 0;
    p.split = FOREST_SPLIT_EXACT;
    return p;
}

/* Exact trees predict what scikit-learn's predict, and credit the same importances. */
static void check_exact_case(const char *name, int max_depth, int mss, int msl)
{
    size_t n, d, nt, dt, k, r, c;
    float *X = load(REF "exact_X_train.npy", &n, &d);
    float *Y = load(REF "exact_Y_train.npy", &r, &k);
    float *Xt = load(REF "exact_X_test.npy", &nt, &dt);
    char path[512];
    snprintf(path, sizeof path, REF "exact_%s_pred.npy", name);
    float *want = load(path, &r, &c);
    assert_int_equal(r, nt);
    assert_int_equal(c, k);
    snprintf(path, sizeof path, REF "exact_%s_importance.npy", name);
    float *want_imp = load(path, &r, &c);
    assert_int_equal(c, d);

    forest_params p = deterministic();
    p.max_depth = max_depth;
    p.min_samples_split = mss;
    p.min_samples_leaf = msl;
    forest *f = fit_or_fail(X, n, d, Y, k, NULL, &p);
    float *got = malloc(nt * k * sizeof *got);
    assert_int_equal(forest_predict(f, Xt, nt, got, 1), 0);
    for (size_t i = 0; i < nt * k; i++)
        if (fabsf(got[i] - want[i]) > 1e-5f * (1.0f + fabsf(want[i])))
            fail_msg("%s: prediction [%zu, %zu] = %.7g, scikit-learn %.7g", name, i / k,
                     i % k, got[i], want[i]);
    double imp[16];
    assert_int_equal(forest_feature_importances(f, imp), 0);
    for (size_t j = 0; j < d; j++)
        if (fabs(imp[j] - want_imp[j]) > 1e-5)
            fail_msg("%s: importance %zu = %.7g, scikit-learn %.7g", name, j, imp[j],
                     (double)want_imp[j]);
    forest_free(f);
    free(X);
    free(Y);
    free(Xt);
    free(want);
    free(want_imp);
    free(got);
}

static void test_exact_matches_sklearn_leaf4(void **state)
{
    (void)state;
    check_exact_case("leaf4", 0, 2, 4);
}
static void test_exact_matches_sklearn_depth5(void **state)
{
    (void)state;
    check_exact_case("depth5", 5, 20, 1);
}

/* Random-forest mode (bootstrap, sqrt features): held-out R^2, averaged over seeds, within
 * 0.02 of scikit-learn's average for the same hyper-parameters, in both split modes. */
static void test_random_forest_r2_matches_sklearn(void **state)
{
    (void)state;
    size_t n, d, nt, k, r, c;
    float *X = load(REF "rf_X_train.npy", &n, &d);
    float *Y = load(REF "rf_Y_train.npy", &r, &k);
    float *Xt = load(REF "rf_X_test.npy", &nt, &c);
    float *Yt = load(REF "rf_Y_test.npy", &r, &c);
    float *sk = load(REF "rf_sklearn_r2.npy", &r, &c);
    double sk_mean = 0.0;
    for (size_t i = 0; i < r; i++)
        sk_mean += sk[i] / (double)r;
    int seeds = quick() ? 2 : 5;
    for (int mode = 0; mode < 2; mode++) {
        forest_params p = forest_default_params();
        p.n_estimators = 60;
        p.max_features = FOREST_MAXF_SQRT;
        p.min_samples_leaf = 2;
        p.n_threads = 2;
        p.split = mode ? FOREST_SPLIT_BINNED : FOREST_SPLIT_EXACT;
        double mean = 0.0;
        for (int s = 0; s < seeds; s++) {
            p.seed = (uint64_t)s;
            forest *f = fit_or_fail(X, n, d, Y, k, NULL, &p);
            mean += forest_score(f, Xt, Yt, NULL, nt, 2) / seeds;
            forest_free(f);
        }
        print_message("%s: held-out R^2 %.4f, scikit-learn %.4f\n", mode ? "binned" : "exact",
                      mean, sk_mean);
        assert_true(fabs(mean - sk_mean) < 0.02);
    }
    free(X);
    free(Y);
    free(Xt);
    free(Yt);
    free(sk);
}

/* Features with fewer distinct values than bins: binned trees are the exact trees (same
 * node count and statistics, same predictions on the training rows). Integer targets keep
 * every sum exact, so equal splits tie identically in both modes. No bootstrap: a row out
 * of a tree's bag may fall between a node's values, where exact thresholds (halfway
 * between the node's values) and bin edges (halfway between the feature's) differ. */
static void test_binned_equals_exact_on_few_values(void **state)
{
    (void)state;
    enum { N = 300, D = 5, K = 2 };
    static float X[N * D], Y[N * K];
    uint64_t s = 99;
    for (int i = 0; i < N * D; i++) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        X[i] = (float)((s >> 33) % 17) * 0.25f - 2.0f;
    }
    for (int i = 0; i < N; i++) {
        Y[i * K] = (float)((int)(X[i * D] * 4) % 5 + (X[i * D + 1] > 0.5f ? 3 : 0));
        Y[i * K + 1] = (float)((int)(X[i * D + 2] * 4) % 3) * (X[i * D + 3] > 0 ? 1.0f : -2.0f);
    }
    forest_params p = forest_default_params();
    p.n_estimators = 4;
    p.max_features = FOREST_MAXF_COUNT;
    p.max_features_value = 2;
    p.seed = 5;
    p.bootstrap = 0;
    p.split = FOREST_SPLIT_EXACT;
    forest *fe = fit_or_fail(X, N, D, Y, K, NULL, &p);
    p.split = FOREST_SPLIT_BINNED;
    forest *fb = fit_or_fail(X, N, D, Y, K, NULL, &p);
    assert_int_equal(forest_n_nodes(fe), forest_n_nodes(fb));
    static float Pe[N * K], Pb[N * K];
    assert_int_equal(forest_predict(fe, X, N, Pe, 1), 0);
    assert_int_equal(forest_predict(fb, X, N, Pb, 1), 0);
    assert_memory_equal(Pe, Pb, sizeof Pe);
    double ie[D], ib[D];
    forest_feature_importances(fe, ie);
    forest_feature_importances(fb, ib);
    for (int j = 0; j < D; j++)
        assert_true(fabs(ie[j] - ib[j]) < 1e-12);
    forest_free(fe);
    forest_free(fb);
}

/* A synthetic problem: y0 depends on features 0 and 1, y1 on feature 2, the rest noise. */
static void synthetic(size_t n, size_t d, uint64_t seed, float *X, float *Y)
{
    for (size_t i = 0; i < n * d; i++) {
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        X[i] = (float)((double)(seed >> 11) / 9007199254740992.0 * 2.0 - 1.0);
    }
    for (size_t i = 0; i < n; i++) {
        const float *x = X + i * d;
        Y[i * 2] = sinf(3.0f * x[0]) + x[1] * x[1];
        Y[i * 2 + 1] = x[2] > 0.0f ? 1.0f + x[2] : -1.0f;
    }
}

/* Fitting with 1 or 3 threads gives the same bytes on disk. */
static void test_threads_do_not_change_the_forest(void **state)
{
    (void)state;
    enum { N = 400, D = 12 };
    static float X[N * D], Y[N * 2];
    synthetic(N, D, 3, X, Y);
    char path1[] = "/tmp/test_forest_t1_XXXXXX", path3[] = "/tmp/test_forest_t3_XXXXXX";
    int fd1 = mkstemp(path1), fd3 = mkstemp(path3);
    assert_true(fd1 >= 0 && fd3 >= 0);
    close(fd1);
    close(fd3);
    char err[512];
    for (int mode = 0; mode < 2; mode++) {
        forest_params p = forest_default_params();
        p.n_estimators = 7;
        p.max_features = FOREST_MAXF_SQRT;
        p.seed = 42;
        p.split = mode ? FOREST_SPLIT_BINNED : FOREST_SPLIT_EXACT;
        p.n_threads = 1;
        forest *a = fit_or_fail(X, N, D, Y, 2, NULL, &p);
        p.n_threads = 3;
        forest *b = fit_or_fail(X, N, D, Y, 2, NULL, &p);
        assert_int_equal(forest_save(a, path1, err, sizeof err), 0);
        assert_int_equal(forest_save(b, path3, err, sizeof err), 0);
        size_t r1, r3;
        FILE *f1 = fopen(path1, "rb"), *f3 = fopen(path3, "rb");
        static unsigned char b1[1 << 20], b3[1 << 20];
        r1 = fread(b1, 1, sizeof b1, f1);
        r3 = fread(b3, 1, sizeof b3, f3);
        fclose(f1);
        fclose(f3);
        assert_true(r1 > 100 && r1 < sizeof b1);
        assert_int_equal(r1, r3);
        assert_memory_equal(b1, b3, r1);
        forest_free(a);
        forest_free(b);
    }
    unlink(path1);
    unlink(path3);
}

/* Save, load: the same predictions, bit for bit. Truncated, lying and corrupted files are
 * errors that name the file and the place. */
static void test_save_load_and_bad_files(void **state)
{
    (void)state;
    enum { N = 200, D = 6 };
    static float X[N * D], Y[N * 2], P1[N * 2], P2[N * 2];
    synthetic(N, D, 8, X, Y);
    forest_params p = forest_default_params();
    p.n_estimators = 5;
    forest *f = fit_or_fail(X, N, D, Y, 2, NULL, &p);
    char path[] = "/tmp/test_forest_io_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    char err[512];
    assert_int_equal(forest_save(f, path, err, sizeof err), 0);
    forest *g = NULL;
    assert_int_equal(forest_load(path, &g, err, sizeof err), 0);
    assert_int_equal(forest_n_trees(g), 5);
    assert_int_equal(forest_n_features(g), D);
    assert_int_equal(forest_n_outputs(g), 2);
    assert_int_equal(forest_predict(f, X, N, P1, 1), 0);
    assert_int_equal(forest_predict(g, X, N, P2, 2), 0);
    assert_memory_equal(P1, P2, sizeof P1);
    forest_free(g);

    FILE *fp = fopen(path, "rb");
    static unsigned char buf[1 << 20];
    size_t size = fread(buf, 1, sizeof buf, fp);
    fclose(fp);
    char bad[] = "/tmp/test_forest_bad_XXXXXX";
    fd = mkstemp(bad);
    assert_true(fd >= 0);
    close(fd);
    struct {
        size_t cut;       /* bytes kept */
        long poke_at;     /* -1: none */
        unsigned char poke_byte;
        const char *says;
    } cases[] = {
        {10, -1, 0, "truncated"},
        {size / 2, -1, 0, "truncated"},
        {size - 1, -1, 0, "truncated"}, /* the hash's last byte gone: the trees run over */
        {size, 0, 'X', "bad magic"},
        {size, 8, 2, "version 2"},
        {size, 44, 0x7f, "claims"},           /* tree 0's node count made huge */
        {size, 36, 0x7f, "claims"},           /* the tree count made huge */
        {size, 48 + 8, 0x7f, "invalid"},      /* root's feature index out of range */
        {size, (long)size - 20, 0x5a, "checksum"}, /* a value changed */
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        static unsigned char mod[1 << 20];
        memcpy(mod, buf, size);
        if (cases[c].poke_at >= 0)
            mod[cases[c].poke_at] = cases[c].poke_byte;
        fp = fopen(bad, "wb");
        fwrite(mod, 1, cases[c].cut, fp);
        fclose(fp);
        err[0] = 0;
        assert_int_equal(forest_load(bad, &g, err, sizeof err), -1);
        assert_null(g);
        if (!strstr(err, cases[c].says) || !strstr(err, bad))
            fail_msg("case %zu: \"%s\" lacks \"%s\" or the file name", c, err, cases[c].says);
    }
    assert_int_equal(forest_load("/nonexistent/f.bin", &g, err, sizeof err), -1);
    unlink(bad);
    unlink(path);
    forest_free(f);
}

/* Bad inputs are errors: NaN in X, NaN in an active target (but not in a masked one),
 * impossible parameters. */
static void test_bad_inputs(void **state)
{
    (void)state;
    float X[8] = {0, 1, 2, 3, 4, 5, 6, 7}, Y[4] = {0, 1, 2, 3};
    uint8_t M[4] = {1, 1, 0, 1};
    forest_params p = forest_default_params();
    p.n_estimators = 2;
    char err[512];
    forest *f = NULL;
    X[5] = NAN;
    assert_int_equal(forest_fit(X, 4, 2, Y, 1, NULL, &p, &f, err, sizeof err), -1);
    assert_non_null(strstr(err, "X[2, 1]"));
    X[5] = 5;
    Y[2] = NAN;
    assert_int_equal(forest_fit(X, 4, 2, Y, 1, NULL, &p, &f, err, sizeof err), -1);
    assert_non_null(strstr(err, "Y[2, 0]"));
    assert_int_equal(forest_fit(X, 4, 2, Y, 1, M, &p, &f, err, sizeof err), 0);
    forest_free(f);
    p.min_samples_leaf = 0;
    assert_int_equal(forest_fit(X, 4, 2, Y, 1, NULL, &p, &f, err, sizeof err), -1);
    p = forest_default_params();
    p.max_features = FOREST_MAXF_FRACTION;
    p.max_features_value = 1.5;
    assert_int_equal(forest_fit(X, 4, 2, Y, 1, NULL, &p, &f, err, sizeof err), -1);
    assert_null(f);
}

/* Excluding masked targets: what they hold does not matter (the forest is identical when
 * they are changed), and with an all-active mask the fit is as good as the unmasked fit
 * (not bit-identical: the masked criterion sums per output in another order, so near-ties
 * may fall the other way). */
static void test_masked_targets_are_ignored(void **state)
{
    (void)state;
    enum { N = 300, NT = 200, D = 6 };
    static float X[(N + NT) * D], Y[(N + NT) * 2], Y2[N * 2], P1[N * 2], P2[N * 2];
    static uint8_t M[N * 2], ones[N * 2];
    synthetic(N + NT, D, 21, X, Y);
    memcpy(Y2, Y, sizeof Y2);
    for (int i = 0; i < N * 2; i++) {
        M[i] = (i * 7919) % 5 != 0;
        ones[i] = 1;
        if (!M[i])
            Y2[i] = i % 2 ? NAN : 1e6f;
    }
    forest_params p = forest_default_params();
    p.n_estimators = 6;
    p.max_features = FOREST_MAXF_SQRT;
    forest *a = fit_or_fail(X, N, D, Y, 2, M, &p);
    forest *b = fit_or_fail(X, N, D, Y2, 2, M, &p);
    assert_int_equal(forest_predict(a, X, N, P1, 1), 0);
    assert_int_equal(forest_predict(b, X, N, P2, 1), 0);
    assert_memory_equal(P1, P2, sizeof P1);
    forest_free(a);
    forest_free(b);
    a = fit_or_fail(X, N, D, Y, 2, ones, &p);
    b = fit_or_fail(X, N, D, Y, 2, NULL, &p);
    double ra = forest_score(a, X + N * D, Y + N * 2, NULL, NT, 1);
    double rb = forest_score(b, X + N * D, Y + N * 2, NULL, NT, 1);
    print_message("all-active mask: held-out R^2 %.4f, no mask %.4f\n", ra, rb);
    assert_true(rb > 0.8);
    assert_true(fabs(ra - rb) < 0.01);
    forest_free(a);
    forest_free(b);
}

/* An output active on only 3 of 300 rows: trees whose bootstrap misses all three (or
 * leaves without any) predict the output's mean over its active rows, never 0. */
static void test_rarely_active_output(void **state)
{
    (void)state;
    enum { N = 300, D = 4 };
    static float X[N * D], Y[N * 2], P[N * 2];
    static uint8_t M[N * 2];
    synthetic(N, D, 5, X, Y);
    for (int i = 0; i < N; i++) {
        M[i * 2] = 1;
        M[i * 2 + 1] = i == 10 || i == 150 || i == 290;
        Y[i * 2 + 1] = M[i * 2 + 1] ? 5.0f : -100.0f;
    }
    forest_params p = forest_default_params();
    p.n_estimators = 40; /* P(a tree misses all three rows) = (1 - 3/300)^300 ~ 5% */
    forest *f = fit_or_fail(X, N, D, Y, 2, M, &p);
    assert_int_equal(forest_predict(f, X, N, P, 1), 0);
    for (int i = 0; i < N; i++)
        assert_true(fabsf(P[i * 2 + 1] - 5.0f) < 1e-5f);
    forest_free(f);
}

/* Permutation importance and impurity importance both find the informative features
 * (0, 1, 2) above every noise feature. */
static void test_importances_find_the_signal(void **state)
{
    (void)state;
    enum { N = 500, NT = 200, D = 10 };
    static float X[(N + NT) * D], Y[(N + NT) * 2];
    synthetic(N + NT, D, 77, X, Y);
    forest_params p = forest_default_params();
    p.n_estimators = quick() ? 10 : 30;
    p.max_features = FOREST_MAXF_SQRT;
    p.n_threads = 2;
    forest *f = fit_or_fail(X, N, D, Y, 2, NULL, &p);
    double imp[D], pm[D], ps[D];
    size_t top[3];
    forest_feature_importances(f, imp);
    double total = 0.0;
    for (int j = 0; j < D; j++)
        total += imp[j];
    assert_true(fabs(total - 1.0) < 1e-9);
    assert_int_equal(forest_top_k(imp, D, 3, top), 0);
    for (int r = 0; r < 3; r++)
        assert_true(top[r] <= 2);
    char err[512];
    assert_int_equal(forest_permutation_importance(f, X + N * D, Y + N * 2, NULL, NT, NULL, 0,
                                                   3, 1, 2, pm, ps, err, sizeof err),
                     0);
    assert_int_equal(forest_top_k(pm, D, 3, top), 0);
    for (int r = 0; r < 3; r++)
        assert_true(top[r] <= 2);
    for (int j = 3; j < D; j++)
        assert_true(fabs(pm[j]) < 0.02);
    /* A subset of features gives the same numbers as the full run. */
    size_t sub[2] = {7, 1};
    double sm[2], ss[2];
    assert_int_equal(forest_permutation_importance(f, X + N * D, Y + N * 2, NULL, NT, sub, 2,
                                                   3, 1, 1, sm, ss, err, sizeof err),
                     0);
    assert_true(sm[0] == pm[7] && sm[1] == pm[1]);
    forest_free(f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_matches_sklearn_leaf4),
        cmocka_unit_test(test_exact_matches_sklearn_depth5),
        cmocka_unit_test(test_random_forest_r2_matches_sklearn),
        cmocka_unit_test(test_binned_equals_exact_on_few_values),
        cmocka_unit_test(test_threads_do_not_change_the_forest),
        cmocka_unit_test(test_save_load_and_bad_files),
        cmocka_unit_test(test_bad_inputs),
        cmocka_unit_test(test_masked_targets_are_ignored),
        cmocka_unit_test(test_rarely_active_output),
        cmocka_unit_test(test_importances_find_the_signal),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
