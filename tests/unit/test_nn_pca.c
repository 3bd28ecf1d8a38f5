/*
 * nn_pca_fit against an independent double-precision reference: data with a known
 * decaying spectrum, whose covariance's leading eigenvectors are found here by power
 * iteration with deflation; then orthonormality, the variances, thread invariance and
 * the argument checks.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nn/nn.h"

enum { N = 600, D = 400, K = 6 };

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static double urand(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return ((double)(rng_state >> 11) + 0.5) * 0x1p-53;
}
static double nrand(void) { return sqrt(-2 * log(urand())) * cos(6.283185307179586 * urand()); }

/* X (N, D) = G diag(sigma) V^T + small noise, centred; sigma = 10, 7, 5, 3.5, 2.5, 1.8, then
 * noise of 0.05: the gaps make the leading six directions well defined. */
static float *make_data(void)
{
    static const double sigma[K] = {10, 7, 5, 3.5, 2.5, 1.8};
    double *V = malloc(sizeof(double) * K * D);
    for (int c = 0; c < K; c++) { /* random orthonormal directions (Gram-Schmidt) */
        double *v = V + (size_t)c * D;
        for (int t = 0; t < D; t++)
            v[t] = nrand();
        for (int j = 0; j < c; j++) {
            double r = 0;
            for (int t = 0; t < D; t++)
                r += v[t] * V[(size_t)j * D + t];
            for (int t = 0; t < D; t++)
                v[t] -= r * V[(size_t)j * D + t];
        }
        double s = 0;
        for (int t = 0; t < D; t++)
            s += v[t] * v[t];
        for (int t = 0; t < D; t++)
            v[t] /= sqrt(s);
    }
    float *X = malloc(sizeof(float) * N * D);
    for (int i = 0; i < N; i++) {
        double g[K];
        for (int c = 0; c < K; c++)
            g[c] = nrand() * sigma[c];
        for (int t = 0; t < D; t++) {
            double x = 0.05 * nrand();
            for (int c = 0; c < K; c++)
                x += g[c] * V[(size_t)c * D + t];
            X[(size_t)i * D + t] = (float)x;
        }
    }
    for (int t = 0; t < D; t++) {
        double m = 0;
        for (int i = 0; i < N; i++)
            m += X[(size_t)i * D + t];
        for (int i = 0; i < N; i++)
            X[(size_t)i * D + t] -= (float)(m / N);
    }
    free(V);
    return X;
}

/* Leading eigenvectors of the covariance X^T X / (N - 1), in double, by power iteration
 * with deflation (independent of the randomized method under test). */
static void reference_components(const float *X, double *vec, double *val)
{
    double *C = calloc((size_t)D * D, sizeof *C);
    for (int i = 0; i < N; i++)
        for (int a = 0; a < D; a++) {
            double xa = X[(size_t)i * D + a];
            for (int b = 0; b < D; b++)
                C[(size_t)a * D + b] += xa * X[(size_t)i * D + b] / (N - 1);
        }
    double *y = malloc(sizeof(double) * D);
    for (int c = 0; c < K; c++) {
        double *v = vec + (size_t)c * D;
        for (int t = 0; t < D; t++)
            v[t] = nrand();
        double lambda = 0;
        for (int it = 0; it < 400; it++) {
            for (int a = 0; a < D; a++) {
                double s = 0;
                for (int b = 0; b < D; b++)
                    s += C[(size_t)a * D + b] * v[b];
                y[a] = s;
            }
            double s = 0;
            for (int a = 0; a < D; a++)
                s += y[a] * y[a];
            lambda = sqrt(s);
            for (int a = 0; a < D; a++)
                v[a] = y[a] / lambda;
        }
        val[c] = lambda;
        for (int a = 0; a < D; a++) /* deflate */
            for (int b = 0; b < D; b++)
                C[(size_t)a * D + b] -= lambda * v[a] * v[b];
    }
    free(C);
    free(y);
}

static void test_pca_matches_reference(void **state)
{
    (void)state;
    float *X = make_data();
    float *comp = malloc(sizeof(float) * K * D), var[K];
    char err[256];
    assert_int_equal(nn_pca_fit(X, N, D, K, 2, 7, 1, comp, var, err, sizeof err), 0);
    double *ref = malloc(sizeof(double) * K * D), rval[K];
    reference_components(X, ref, rval);
    for (int c = 0; c < K; c++) {
        double dot = 0, norm = 0;
        for (int t = 0; t < D; t++) {
            dot += comp[(size_t)c * D + t] * ref[(size_t)c * D + t];
            norm += (double)comp[(size_t)c * D + t] * comp[(size_t)c * D + t];
        }
        assert_true(fabs(norm - 1) < 1e-5);
        assert_true(fabs(fabs(dot) - 1) < 1e-5); /* same direction up to sign */
        assert_true(fabs(var[c] - rval[c]) < 1e-4 * rval[c]);
        for (int j = 0; j < c; j++) {
            double o = 0;
            for (int t = 0; t < D; t++)
                o += (double)comp[(size_t)c * D + t] * comp[(size_t)j * D + t];
            assert_true(fabs(o) < 1e-5);
        }
        /* sign convention: the largest |entry| is positive */
        int big = 0;
        for (int t = 1; t < D; t++)
            if (fabsf(comp[(size_t)c * D + t]) > fabsf(comp[(size_t)c * D + big]))
                big = t;
        assert_true(comp[(size_t)c * D + big] > 0);
    }
    /* the projection's variance is the reported one; whitening makes it 1 */
    float *Z = malloc(sizeof(float) * N * K);
    nn_pca_transform(Z, X, comp, var, N, D, K, 1, 1);
    for (int c = 0; c < K; c++) {
        double s = 0;
        for (int i = 0; i < N; i++)
            s += (double)Z[(size_t)i * K + c] * Z[(size_t)i * K + c];
        assert_true(fabs(s / (N - 1) - 1) < 1e-4);
    }
    free(Z);
    free(ref);
    free(comp);
    free(X);
}

static void test_pca_threads_bit_identical(void **state)
{
    (void)state;
    float *X = make_data();
    float *c1 = malloc(sizeof(float) * K * D), *c3 = malloc(sizeof(float) * K * D);
    float v1[K], v3[K];
    char err[256];
    assert_int_equal(nn_pca_fit(X, N, D, K, 2, 3, 1, c1, v1, err, sizeof err), 0);
    assert_int_equal(nn_pca_fit(X, N, D, K, 2, 3, 3, c3, v3, err, sizeof err), 0);
    assert_memory_equal(c1, c3, sizeof(float) * K * D);
    assert_memory_equal(v1, v3, sizeof v1);
    free(c1);
    free(c3);
    free(X);
}

static void test_pca_refuses_impossible_k(void **state)
{
    (void)state;
    float X[12] = {0}, comp[16], var[4];
    char err[256] = "";
    assert_int_equal(nn_pca_fit(X, 3, 4, 4, 1, 1, 1, comp, var, err, sizeof err), -1);
    assert_non_null(strstr(err, "cannot take 4 components"));
    assert_int_equal(nn_pca_fit(X, 1, 4, 1, 1, 1, 1, comp, var, err, sizeof err), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pca_matches_reference),
        cmocka_unit_test(test_pca_threads_bit_identical),
        cmocka_unit_test(test_pca_refuses_impossible_k),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
