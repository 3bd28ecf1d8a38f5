/* forest's parts on their own: the criterion against brute-force squared errors, node
 * statistics, quantile bin edges and codes, the exact splitter's grouping and thresholds. */
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "forest/forest_impl.h"

enum { KP = FO_LANES }; /* two outputs, padded */

/* Sum of squared deviations of rows [a, b) of y (n x 2), summed over outputs. */
static double sse(const double *y, int a, int b)
{
    double total = 0.0;
    for (int j = 0; j < 2; j++) {
        double m = 0.0;
        for (int i = a; i < b; i++)
            m += y[i * 2 + j];
        m /= b - a;
        for (int i = a; i < b; i++)
            total += (y[i * 2 + j] - m) * (y[i * 2 + j] - m);
    }
    return total;
}

/* Groups of one row each: the chosen split minimises left + right squared error, and
 * min_leaf rules out splits with a small side. */
static void test_criterion_matches_brute_force(void **state)
{
    (void)state;
    enum { N = 9 };
    const double y[N * 2] = {0.3, 1, -0.2, 2, 1.5, 0, 1.7, 0.5, 1.6, -1, 3.0, 4, 2.9, 3.5,
                             0.1, 0, 3.2, 3.9};
    fo_acc sum[N * KP] = {0}, w[N], tsum[KP] = {0}, tw = N, scratch[2 * KP];
    int32_t count[N];
    for (int i = 0; i < N; i++) {
        for (int j = 0; j < 2; j++) {
            sum[i * KP + j] = (fo_acc)y[i * 2 + j];
            tsum[j] += (fo_acc)y[i * 2 + j];
        }
        w[i] = 1;
        count[i] = 1;
    }
    const fo_acc *rows[N];
    for (int i = 0; i < N; i++)
        rows[i] = sum + i * KP;
    fo_groups g = {.n_groups = N, .k = KP, .masked = 0, .sum = rows, .w = w, .count = count};
    for (int min_leaf = 1; min_leaf <= 4; min_leaf++) {
        double proxy;
        long s = fo_criterion_best_split(&g, tsum, &tw, N, min_leaf, &proxy, scratch);
        int best = -1;
        double best_sse = DBL_MAX;
        for (int cut = min_leaf; cut <= N - min_leaf; cut++) {
            double e = sse(y, 0, cut) + sse(y, cut, N);
            if (e < best_sse - 1e-9) {
                best_sse = e;
                best = cut - 1;
            }
        }
        assert_int_equal(s, best);
        /* proxy = total sum of squares - remaining squared error */
        double sq = 0.0;
        for (int i = 0; i < N * 2; i++)
            sq += y[i] * y[i];
        assert_true(fabs((sq - proxy) - best_sse) < 1e-4);
    }
    /* min_leaf larger than half the rows: no valid split */
    double proxy;
    assert_int_equal(fo_criterion_best_split(&g, tsum, &tw, N, 5, &proxy, scratch), -1);
}

/* With a mask of ones the masked criterion picks the same split; with output 1 masked on
 * the rows that decide it, the split follows output 0 alone. */
static void test_masked_criterion(void **state)
{
    (void)state;
    enum { N = 6 };
    /* output 0 wants a cut after row 2, output 1 (strongly) after row 0 */
    const float y0[N] = {0, 0, 0, 1, 1, 1}, y1[N] = {10, 0, 0, 0, 0, 0};
    fo_acc sum[N * KP] = {0}, wm[N * KP] = {0}, tsum[KP] = {0}, tw[KP] = {0};
    fo_acc scratch[2 * KP];
    int32_t count[N];
    for (int i = 0; i < N; i++) {
        sum[i * KP] = y0[i];
        sum[i * KP + 1] = y1[i];
        wm[i * KP] = wm[i * KP + 1] = 1;
        tsum[0] += y0[i];
        tsum[1] += y1[i];
        count[i] = 1;
    }
    tw[0] = tw[1] = N;
    const fo_acc *rows[N], *wrows[N];
    for (int i = 0; i < N; i++) {
        rows[i] = sum + i * KP;
        wrows[i] = wm + i * KP;
    }
    fo_groups g = {.n_groups = N, .k = KP, .masked = 1, .sum = rows, .wk = wrows, .count = count};
    double proxy;
    assert_int_equal(fo_criterion_best_split(&g, tsum, tw, N, 1, &proxy, scratch), 0);
    /* mask output 1 on row 0: it no longer pulls the cut */
    tsum[1] -= sum[1];
    sum[1] = 0;
    wm[1] = 0;
    tw[1] -= 1;
    assert_int_equal(fo_criterion_best_split(&g, tsum, tw, N, 1, &proxy, scratch), 2);
}

/* Node statistics: impurity is the mean over outputs of the weighted variance (as
 * scikit-learn's), wimpurity that times the weight; masked outputs use their own rows. */
static void test_node_stats(void **state)
{
    (void)state;
    const float Y[4 * 2] = {1, 5, 2, 7, 4, 100, 9, 9};
    const int32_t idx[3] = {0, 1, 3};
    const double w[4] = {1, 2, 0, 1}; /* row 1 drawn twice, row 2 not at all */
    double sum[KP], sumsq[KP], wsum[KP], imp, wimp;
    fo_criterion_node_stats(idx, 3, 2, NULL, NULL, w, Y, sum, sumsq, wsum, &imp, &wimp);
    /* output 0: values 1,2,2,9 -> mean 3.5, var 10.25; output 1: 5,7,7,9 -> mean 7, var 2 */
    assert_true(fabs(imp - (10.25 + 2.0) / 2) < 1e-12);
    assert_true(fabs(wimp - 4 * imp) < 1e-12);
    assert_true(fabs(wsum[0] - 4) < 1e-12);
    /* masked: output 1 inactive on row 3 -> values 5,7,7 -> var 8/9 */
    fo_acc wm[4 * KP] = {0};
    for (int i = 0; i < 4; i++)
        wm[i * KP] = wm[i * KP + 1] = (fo_acc)w[i];
    wm[3 * KP + 1] = 0;
    fo_criterion_node_stats(idx, 3, 2, NULL, wm, w, Y, sum, sumsq, wsum, &imp, &wimp);
    assert_true(fabs(imp - (10.25 + 8.0 / 9.0) / 2) < 1e-12);
    assert_true(fabs(wimp - (4 * 10.25 + 3 * 8.0 / 9.0) / 2) < 1e-12);
}

/* Few distinct values: one bin each, edges halfway. Many: at most max_bins - 1 edges,
 * increasing, never inside a run of equal values, splitting the rows evenly. */
static void test_bin_edges(void **state)
{
    (void)state;
    const float few[7] = {0, 0, 1, 2, 2, 2, 3};
    float edges[255];
    assert_int_equal(fo_bins_edges(few, 7, 256, edges), 3);
    assert_true(edges[0] == 0.5f && edges[1] == 1.5f && edges[2] == 2.5f);
    /* values closer than 1e-7 count as one */
    const float close[3] = {0.001f, 0.00100005f, 2.0f};
    assert_true(close[1] != close[0]);
    assert_int_equal(fo_bins_edges(close, 3, 256, edges), 1);

    enum { N = 1000 };
    static float v[N];
    for (int i = 0; i < N; i++)
        v[i] = i < 400 ? 7.0f : (float)i; /* a run of 400 ties, then distinct values */
    int ne = fo_bins_edges(v, N, 8, edges);
    assert_true(ne >= 2 && ne <= 7);
    for (int e = 0; e < ne; e++) {
        if (e)
            assert_true(edges[e] > edges[e - 1]);
        int below = 0;
        for (int i = 0; i < N; i++)
            below += v[i] <= edges[e];
        assert_true(below >= 400); /* the run stays on one side */
    }
    for (int i = 0; i < N; i++)
        v[i] = (float)i * 0.5f;
    ne = fo_bins_edges(v, N, 4, edges);
    assert_int_equal(ne, 3);
    for (int e = 0; e < 3; e++) {
        int below = 0;
        for (int i = 0; i < N; i++)
            below += v[i] <= edges[e];
        assert_true(abs(below - 250 * (e + 1)) <= 1);
    }
}

/* Codes agree with the edges: code(x) <= b exactly when x <= edges[b], for every feature
 * and thread count. */
static void test_bin_codes(void **state)
{
    (void)state;
    enum { N = 500, D = 70 }; /* more features than a block of 64 */
    static float X[N * D];
    uint64_t s = 3;
    for (int i = 0; i < N * D; i++) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        X[i] = (i % D) % 3 == 0 ? (float)((s >> 40) % 5) : (float)((s >> 11) % 100000) * 1e-3f - 50;
    }
    fo_bins a, b;
    char err[256];
    assert_int_equal(fo_bins_build(X, N, D, 256, 1, &a, err, sizeof err), 0);
    assert_int_equal(fo_bins_build(X, N, D, 256, 3, &b, err, sizeof err), 0);
    assert_memory_equal(a.codes, b.codes, (size_t)N * D);
    for (int f = 0; f < D; f++) {
        const float *edges = a.edges + (size_t)f * 255;
        int ne = a.n_edges[f];
        if (f % 3 == 0)
            assert_int_equal(ne, 4); /* 5 distinct values */
        else
            assert_true(ne > 200);
        for (int i = 0; i < N; i++) {
            int c = a.codes[(size_t)f * N + i];
            float x = X[i * D + f];
            assert_true(c <= ne);
            assert_true(c == ne || x <= edges[c]);
            assert_true(c == 0 || x > edges[c - 1]);
        }
    }
    fo_bins_free(&a);
    fo_bins_free(&b);
}

/* The exact splitter groups values within 1e-7, puts thresholds halfway between groups
 * and partitions rows by them. */
static void test_exact_splitter(void **state)
{
    (void)state;
    enum { N = 6 };
    /* 0.002 and 0.00200005 are closer than 1e-7: one group */
    const float x[N] = {0.003f, 0.001f, 0.002f, 0.00200005f, 0.005f, 0.001f};
    const float y[N] = {10, 0, 10, 10, 10, 0}; /* the cut belongs between 0.001 and 0.002 */
    const double half = (double)0.001f / 2.0 + (double)0.002f / 2.0;
    fo_data data = {N, 1, 1, x, NULL, y, NULL};
    fo_splitter sp;
    assert_int_equal(fo_splitter_init(&sp, &data, 0, 1), 0);
    int32_t idx[N] = {0, 1, 2, 3, 4, 5};
    double w[N];
    fo_acc wy[N * KP] = {0}, tsum[KP] = {0}, tw = N;
    for (int i = 0; i < N; i++) {
        w[i] = 1;
        wy[i * KP] = y[i];
        tsum[0] += y[i];
    }
    assert_int_equal(fo_splitter_groups(&sp, idx, N, 0, wy, NULL, w), 4);
    fo_split best = {-1, 0, -1, -DBL_MAX};
    assert_int_equal(fo_splitter_try_feature(&sp, idx, N, 0, wy, NULL, w, tsum, &tw, &best), 0);
    assert_int_equal(best.feature, 0);
    assert_true(best.threshold == half);
    size_t nl = fo_splitter_partition(&sp, idx, N, &best);
    assert_int_equal(nl, 2);
    for (size_t i = 0; i < N; i++)
        assert_true(((double)x[idx[i]] <= half) == (i < nl));
    /* min_leaf 3: groups of 2, 2, 1, 1 rows leave no cut with 3 on each side */
    fo_splitter_free(&sp);
    assert_int_equal(fo_splitter_init(&sp, &data, 0, 3), 0);
    best = (fo_split){-1, 0, -1, -DBL_MAX};
    assert_int_equal(fo_splitter_try_feature(&sp, idx, N, 0, wy, NULL, w, tsum, &tw, &best), 0);
    assert_int_equal(best.feature, -1);
    /* a constant feature reports itself */
    const float c[N] = {4, 4, 4, 4, 4, 4};
    data.Xc = c;
    best = (fo_split){-1, 0, -1, -DBL_MAX};
    assert_int_equal(fo_splitter_try_feature(&sp, idx, N, 0, wy, NULL, w, tsum, &tw, &best), 1);
    assert_int_equal(best.feature, -1);
    fo_splitter_free(&sp);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_criterion_matches_brute_force),
        cmocka_unit_test(test_masked_criterion),
        cmocka_unit_test(test_node_stats),
        cmocka_unit_test(test_bin_edges),
        cmocka_unit_test(test_bin_codes),
        cmocka_unit_test(test_exact_splitter),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
