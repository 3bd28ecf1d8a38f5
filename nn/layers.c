/* The simple layers: reference convolution, ReLU, pooling, Gram. */
#include <cblas.h>
#include <float.h>
#include <string.h>

#include "nn/nn.h"

void conv3x3_forward_reference(float *out, const float *in, const float *w, const float *b,
                               int N, int C, int K, int H, int W)
{
    // in (N,C,H,W), w (K,C,3,3), b (K) -> out (N,K,H,W); padding 1
    size_t plane = (size_t)H * W;
    for (int n = 0; n < N; n++) {
        for (int k = 0; k < K; k++) {
            float *o = out + ((size_t)n * K + k) * plane;
            for (size_t p = 0; p < plane; p++)
                o[p] = b[k];
            for (int c = 0; c < C; c++) {
                const float *x = in + ((size_t)n * C + c) * plane;
                const float *wk = w + ((size_t)k * C + c) * 9;
                for (int y = 0; y < H; y++)
                    for (int dy = -1; dy <= 1; dy++) {
                        int sy = y + dy;
                        if (sy < 0 || sy >= H)
                            continue;
                        for (int dx = -1; dx <= 1; dx++) {
                            float wv = wk[(dy + 1) * 3 + dx + 1];
                            int x0 = dx < 0 ? 1 : 0, x1 = dx > 0 ? W - 1 : W;
                            const float *src = x + (size_t)sy * W + dx;
                            float *dst = o + (size_t)y * W;
                            for (int xx = x0; xx < x1; xx++)
                                dst[xx] += wv * src[xx];
                        }
                    }
            }
        }
    }
}

void relu_forward(float *x, size_t n)
{
    for (size_t i = 0; i < n; i++)
        x[i] = x[i] > 0.0f ? x[i] : 0.0f;
}

void avgpool_forward(float *out, const float *in, int N, int C, int H, int W, int kernel,
                     int stride)
{
    // in (N,C,H,W) -> out (N,C,OH,OW), OH = (H - kernel) / stride + 1
    int OH = (H - kernel) / stride + 1, OW = (W - kernel) / stride + 1;
    float inv = 1.0f / (float)(kernel * kernel);
    for (size_t p = 0; p < (size_t)N * C; p++) {
        const float *x = in + p * H * W;
        float *o = out + p * OH * OW;
        for (int oy = 0; oy < OH; oy++)
            for (int ox = 0; ox < OW; ox++) {
                float s = 0.0f;
                for (int dy = 0; dy < kernel; dy++)
                    for (int dx = 0; dx < kernel; dx++)
                        s += x[(size_t)(oy * stride + dy) * W + ox * stride + dx];
                o[oy * OW + ox] = s * inv;
            }
    }
}

void maxpool_forward(float *out, const float *in, int N, int C, int H, int W, int kernel,
                     int stride)
{
    int OH = (H - kernel) / stride + 1, OW = (W - kernel) / stride + 1;
    for (size_t p = 0; p < (size_t)N * C; p++) {
        const float *x = in + p * H * W;
        float *o = out + p * OH * OW;
        for (int oy = 0; oy < OH; oy++)
            for (int ox = 0; ox < OW; ox++) {
                float m = -FLT_MAX;
                for (int dy = 0; dy < kernel; dy++)
                    for (int dx = 0; dx < kernel; dx++) {
                        float v = x[(size_t)(oy * stride + dy) * W + ox * stride + dx];
                        m = v > m ? v : m;
                    }
                o[oy * OW + ox] = m;
            }
    }
}

void gram_upper_forward(float *out, const float *f, int C, int HW, float *scratch)
{
    // f (C, HW) -> scratch (C, C) upper part = f f^T / HW -> out C(C+1)/2
    cblas_ssyrk(CblasRowMajor, CblasUpper, CblasNoTrans, C, HW, 1.0f / (float)HW, f, HW, 0.0f,
                scratch, C);
    size_t k = 0;
    for (int i = 0; i < C; i++) {
        memcpy(out + k, scratch + (size_t)i * C + i, (size_t)(C - i) * sizeof(float));
        k += (size_t)(C - i);
    }
}
