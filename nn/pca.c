/*
 * Principal components by randomized SVD (Halko, Martinsson and Tropp, "Finding structure
 * with randomness", 2011: range finder with power iterations, Algorithms 4.3/4.4 and 5.1).
 *
 * A descriptor has tens of thousands of features and a dataset tens of thousands of rows:
 * the d x d covariance (38,808^2 floats = 6 GB) is out of the question, but X only ever
 * needs to be multiplied by thin matrices of l = k + oversampling columns. Every product
 * goes through linear_forward / linear_backward, whose blocking makes the results
 * bit-identical for any thread count; the small dense algebra (orthonormalisation, the
 * l x l eigenproblem) is in double, in a fixed order.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nn/nn.h"

enum { PCA_OVERSAMPLE = 16 };

/* Standard normal draw number i of a stream: Box-Muller over two counter-based uniforms. */
static float gaussian(uint64_t seed, uint64_t i)
{
    uint64_t a = nn_mix64(seed ^ nn_mix64(2 * i + 1)), b = nn_mix64(seed ^ nn_mix64(2 * i + 2));
    double u1 = ((double)(a >> 11) + 0.5) * 0x1p-53, u2 = (double)(b >> 11) * 0x1p-53;
    return (float)(sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2));
}

/* Orthonormalises the l rows of A (l, n) in place: modified Gram-Schmidt, twice ("twice is
 * enough", Giraud et al. 2005), sums in double. A row that vanishes (rank deficiency)
 * becomes zero and stays out of later projections. */
static void orthonormalise_rows(float *A, int l, size_t n)
{
    for (int pass = 0; pass < 2; pass++)
        for (int j = 0; j < l; j++) {
            float *a = A + (size_t)j * n;
            for (int i = 0; i < j; i++) {
                const float *q = A + (size_t)i * n;
                double r = 0;
                for (size_t t = 0; t < n; t++)
                    r += (double)a[t] * q[t];
                for (size_t t = 0; t < n; t++)
                    a[t] -= (float)(r * q[t]);
            }
            double s = 0;
            for (size_t t = 0; t < n; t++)
                s += (double)a[t] * a[t];
            float inv = s > 1e-30 ? (float)(1.0 / sqrt(s)) : 0.0f;
            for (size_t t = 0; t < n; t++)
                a[t] *= inv;
        }
}

static void transpose(float *dst, const float *src, size_t rows, size_t cols)
{
    for (size_t i = 0; i < rows; i++)
        for (size_t j = 0; j < cols; j++)
            dst[j * rows + i] = src[i * cols + j];
}

/* Eigen-decomposition of the symmetric l x l matrix S (destroyed): cyclic Jacobi
 * rotations until the off-diagonal mass is negligible. U (l, l) receives the eigenvectors
 * as columns, w the eigenvalues, both in descending order of w. */
static void symmetric_eigen(double *S, int l, double *U, double *w)
{
    for (int i = 0; i < l; i++)
        for (int j = 0; j < l; j++)
            U[i * l + j] = i == j;
    for (int sweep = 0; sweep < 60; sweep++) {
        double off = 0, diag = 0;
        for (int i = 0; i < l; i++)
            for (int j = 0; j < l; j++)
                if (i != j)
                    off += S[i * l + j] * S[i * l + j];
                else
                    diag += S[i * l + j] * S[i * l + j];
        if (off <= 1e-24 * diag)
            break;
        for (int p = 0; p < l - 1; p++)
            for (int q = p + 1; q < l; q++) {
                double spq = S[p * l + q];
                if (fabs(spq) < 1e-300)
                    continue;
                // the rotation that zeroes S[p][q] (Golub & Van Loan, 8.5.2)
                double theta = (S[q * l + q] - S[p * l + p]) / (2 * spq);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1));
                double c = 1 / sqrt(t * t + 1), s = t * c;
                for (int k = 0; k < l; k++) { /* columns p, q */
                    double a = S[k * l + p], b = S[k * l + q];
                    S[k * l + p] = c * a - s * b;
                    S[k * l + q] = s * a + c * b;
                }
                for (int k = 0; k < l; k++) { /* rows p, q */
                    double a = S[p * l + k], b = S[q * l + k];
                    S[p * l + k] = c * a - s * b;
                    S[q * l + k] = s * a + c * b;
                }
                for (int k = 0; k < l; k++) {
                    double a = U[k * l + p], b = U[k * l + q];
                    U[k * l + p] = c * a - s * b;
                    U[k * l + q] = s * a + c * b;
                }
            }
    }
    for (int i = 0; i < l; i++)
        w[i] = S[i * l + i];
    // selection sort, descending (l is a few hundred)
    for (int i = 0; i < l; i++) {
        int best = i;
        for (int j = i + 1; j < l; j++)
            if (w[j] > w[best])
                best = j;
        if (best != i) {
            double t = w[i];
            w[i] = w[best];
            w[best] = t;
            for (int k = 0; k < l; k++) {
                t = U[k * l + i];
                U[k * l + i] = U[k * l + best];
                U[k * l + best] = t;
            }
        }
    }
}

int nn_pca_fit(const float *X, int n, int d, int k, int power_iters, uint64_t seed, int threads,
               float *components, float *variance, char *err, size_t errlen)
{
    if (n < 2 || d < 1 || k < 1 || k > d || k > n) {
        snprintf(err, errlen, "PCA of %d rows x %d features: cannot take %d components", n, d,
                 k);
        return -1;
    }
    int l = k + PCA_OVERSAMPLE;
    if (l > d)
        l = d;
    if (l > n)
        l = n;
    float *W = malloc((size_t)l * d * sizeof *W);  /* (l, d): a basis of X's row space */
    float *Y = malloc((size_t)n * l * sizeof *Y);  /* (n, l) = X W^T */
    float *Qt = malloc((size_t)l * n * sizeof *Qt); /* (l, n): Y's columns, orthonormal */
    double *S = malloc((size_t)l * l * sizeof *S), *U = malloc((size_t)l * l * sizeof *U);
    double *w = malloc((size_t)l * sizeof *w);
    int rc = -1;
    if (!W || !Y || !Qt || !S || !U || !w) {
        snprintf(err, errlen, "PCA of %d x %d: out of memory", n, d);
        goto done;
    }
    // W = a Gaussian test matrix; then alternately Q = orth(X W^T), W = orth(Q^T X): each
    // round multiplies the spectrum's decay, so the range found is the top one
    for (size_t i = 0; i < (size_t)l * d; i++)
        W[i] = gaussian(seed, i);
    for (int it = 0;; it++) {
        linear_forward(Y, X, W, NULL, n, d, l, threads); // Y (n,l) = X (n,d) . W^T (d,l)
        transpose(Qt, Y, (size_t)n, (size_t)l);
        orthonormalise_rows(Qt, l, (size_t)n);
        transpose(Y, Qt, (size_t)l, (size_t)n);
        memset(W, 0, (size_t)l * d * sizeof *W);
        linear_backward(NULL, W, NULL, Y, X, NULL, n, d, l, threads); // W (l,d) = Q^T X
        if (it == power_iters)
            break;
        orthonormalise_rows(W, l, (size_t)d);
    }
    // now W = B = Q^T X (l, d), and X ~ Q B. B B^T = U diag(w) U^T gives X's right singular
    // vectors v_i = B^T u_i / sqrt(w_i) and variances w_i / (n - 1)
    for (int i = 0; i < l; i++)
        for (int j = 0; j <= i; j++) {
            double s = 0;
            const float *a = W + (size_t)i * d, *b = W + (size_t)j * d;
            for (int t = 0; t < d; t++)
                s += (double)a[t] * b[t];
            S[i * l + j] = S[j * l + i] = s;
        }
    symmetric_eigen(S, l, U, w);
    double *acc = malloc((size_t)d * sizeof *acc);
    if (!acc) {
        snprintf(err, errlen, "PCA of %d x %d: out of memory", n, d);
        goto done;
    }
    for (int c = 0; c < k; c++) {
        memset(acc, 0, (size_t)d * sizeof *acc);
        for (int j = 0; j < l; j++) {
            double u = U[j * l + c];
            const float *b = W + (size_t)j * d;
            for (int t = 0; t < d; t++)
                acc[t] += u * b[t];
        }
        double norm = w[c] > 0 ? sqrt(w[c]) : 0;
        // the sign is arbitrary: fix it so the largest |entry| is positive (as
        // scikit-learn's svd_flip does), which makes components comparable across runs
        size_t big = 0;
        for (int t = 1; t < d; t++)
            if (fabs(acc[t]) > fabs(acc[big]))
                big = (size_t)t;
        double sgn = acc[big] < 0 ? -1.0 : 1.0;
        for (int t = 0; t < d; t++)
            components[(size_t)c * d + t] = norm > 0 ? (float)(sgn * acc[t] / norm) : 0.0f;
        variance[c] = (float)(w[c] > 0 ? w[c] / (n - 1) : 0.0);
    }
    free(acc);
    rc = 0;
done:
    free(W);
    free(Y);
    free(Qt);
    free(S);
    free(U);
    free(w);
    return rc;
}

void nn_pca_transform(float *out, const float *X, const float *components,
                      const float *variance, int n, int d, int k, int whiten, int threads)
{
    // out (n,k) = X (n,d) . components^T (d,k)
    linear_forward(out, X, components, NULL, n, d, k, threads);
    if (!whiten)
        return;
    for (int i = 0; i < n; i++)
        for (int c = 0; c < k; c++) {
            float v = variance[c];
            out[(size_t)i * k + c] = v > 0 ? out[(size_t)i * k + c] / sqrtf(v) : 0.0f;
        }
}
