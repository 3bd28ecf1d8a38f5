/* Elementwise activations, softmax and dropout, forward and backward. */
#include <math.h>

#include "nn/nn.h"

void relu_backward(float *din, const float *dout, const float *in, size_t n)
{
    // backward of out = max(in, 0): the gradient passes where in > 0 (0 at 0, as torch)
    for (size_t i = 0; i < n; i++)
        din[i] = in[i] > 0.0f ? dout[i] : 0.0f;
}

void leaky_relu_forward(float *out, const float *in, size_t n, float slope)
{
    for (size_t i = 0; i < n; i++)
        out[i] = in[i] > 0.0f ? in[i] : in[i] * slope;
}

void leaky_relu_backward(float *din, const float *dout, const float *in, size_t n, float slope)
{
    // backward of out = in > 0 ? in : slope * in
    for (size_t i = 0; i < n; i++)
        din[i] = in[i] > 0.0f ? dout[i] : dout[i] * slope;
}

/*
 * erf and exp for GELU, GELU_LANES at a time. With AVX-512 and glibc's libmvec (its
 * 16-lane erff/expf, a few ulp like the scalar ones) the GELU of a (128, 512) layer costs
 * a tenth of the scalar calls, which were 7% of a training step. Every element goes
 * through the same function (a short tail is padded into a full vector), so a value's
 * GELU does not depend on its position or on n.
 */
#if defined(__AVX512F__) && defined(IMSYNTH_HAVE_LIBMVEC)
#include <immintrin.h>
__m512 _ZGVeN16v_erff(__m512 x);
__m512 _ZGVeN16v_expf(__m512 x);
enum { GELU_LANES = 16 };
static void erf_lanes(float *v)
{
    _mm512_storeu_ps(v, _ZGVeN16v_erff(_mm512_loadu_ps(v)));
}
static void exp_lanes(float *v)
{
    _mm512_storeu_ps(v, _ZGVeN16v_expf(_mm512_loadu_ps(v)));
}
#else
enum { GELU_LANES = 16 };
static void erf_lanes(float *v)
{
    for (int k = 0; k < GELU_LANES; k++)
        v[k] = erff(v[k]);
}
static void exp_lanes(float *v)
{
    for (int k = 0; k < GELU_LANES; k++)
        v[k] = expf(v[k]);
}
#endif

void gelu_forward(float *out, const float *in, size_t n)
{
    // out = x Phi(x) = 0.5 x (1 + erf(x / sqrt 2))
    for (size_t i = 0; i < n; i += GELU_LANES) {
        float e[GELU_LANES] = {0};
        size_t m = n - i < GELU_LANES ? n - i : GELU_LANES;
        for (size_t k = 0; k < m; k++)
            e[k] = in[i + k] * (float)M_SQRT1_2;
        erf_lanes(e);
        for (size_t k = 0; k < m; k++)
            out[i + k] = 0.5f * in[i + k] * (1.0f + e[k]);
    }
}

void gelu_backward(float *din, const float *dout, const float *in, size_t n)
{
    // backward of out = x Phi(x): d/dx = Phi(x) + x phi(x), phi the normal density
    const float inv_sqrt_2pi = 0.3989422804014327f;
    for (size_t i = 0; i < n; i += GELU_LANES) {
        float e[GELU_LANES] = {0}, g[GELU_LANES] = {0};
        size_t m = n - i < GELU_LANES ? n - i : GELU_LANES;
        for (size_t k = 0; k < m; k++) {
            float x = in[i + k];
            e[k] = x * (float)M_SQRT1_2;
            g[k] = -0.5f * x * x;
        }
        erf_lanes(e);
        exp_lanes(g);
        for (size_t k = 0; k < m; k++) {
            float x = in[i + k];
            float cdf = 0.5f * (1.0f + e[k]), pdf = inv_sqrt_2pi * g[k];
            din[i + k] = dout[i + k] * (cdf + x * pdf);
        }
    }
}

void sigmoid_forward(float *out, const float *in, size_t n)
{
    // out = 1 / (1 + exp(-x)), written so that neither branch overflows
    for (size_t i = 0; i < n; i++) {
        float x = in[i];
        if (x >= 0.0f) {
            out[i] = 1.0f / (1.0f + expf(-x));
        } else {
            float e = expf(x);
            out[i] = e / (1.0f + e);
        }
    }
}

void sigmoid_backward(float *din, const float *dout, const float *out, size_t n)
{
    // backward of out = sigmoid(x): d/dx = out (1 - out)
    for (size_t i = 0; i < n; i++)
        din[i] = dout[i] * out[i] * (1.0f - out[i]);
}

void softmax_forward(float *out, const float *in, int B, int K)
{
    // out[i, k] = exp(in[i, k] - max_k in[i]) / sum_k exp(...)
    for (int i = 0; i < B; i++) {
        const float *x = in + (size_t)i * K;
        float *o = out + (size_t)i * K;
        float mx = x[0];
        for (int k = 1; k < K; k++)
            mx = x[k] > mx ? x[k] : mx;
        double sum = 0.0;
        for (int k = 0; k < K; k++) {
            o[k] = expf(x[k] - mx);
            sum += o[k];
        }
        float inv = (float)(1.0 / sum);
        for (int k = 0; k < K; k++)
            o[k] *= inv;
    }
}


void dropout_forward(float *out, float *keep, const float *in, size_t n, float p, uint64_t seed)
{
    // keep[i] = (u_i >= p) / (1 - p), u_i uniform in [0,1) from (seed, i); out = in * keep
    float scale = p < 1.0f ? 1.0f / (1.0f - p) : 0.0f;
    uint64_t s = nn_mix64(seed ^ 0x6a09e667f3bcc909ull);
    for (size_t i = 0; i < n; i++) {
        double u = (double)(nn_mix64(s + i) >> 11) * 0x1p-53;
        keep[i] = u >= p ? scale : 0.0f;
        out[i] = in[i] * keep[i];
    }
}

void dropout_backward(float *din, const float *dout, const float *keep, size_t n)
{
    // backward of out = in * keep
    for (size_t i = 0; i < n; i++)
        din[i] = dout[i] * keep[i];
}
