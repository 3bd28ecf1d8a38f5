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

void gelu_forward(float *out, const float *in, size_t n)
{
    // out = x Phi(x) = 0.5 x (1 + erf(x / sqrt 2))
    for (size_t i = 0; i < n; i++) {
        float x = in[i];
        out[i] = 0.5f * x * (1.0f + erff(x * (float)M_SQRT1_2));
    }
}

void gelu_backward(float *din, const float *dout, const float *in, size_t n)
{
    // backward of out = x Phi(x): d/dx = Phi(x) + x phi(x), phi the normal density
    const float inv_sqrt_2pi = 0.3989422804014327f;
    for (size_t i = 0; i < n; i++) {
        float x = in[i];
        float cdf = 0.5f * (1.0f + erff(x * (float)M_SQRT1_2));
        float pdf = inv_sqrt_2pi * expf(-0.5f * x * x);
        din[i] = dout[i] * (cdf + x * pdf);
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
