/*
 * MobileNetV2's spatial kernels: the depthwise 3x3 convolution (stride 1 and 2) and
 * Conv1's im2col. Written as plain loops over contiguous rows so the compiler vectorises
 * the interior of each row (AVX-512 with -march=native); the borders are the same sum
 * with the out-of-image terms left out, and rows outside the image read a zero row, so
 * there is no branch in the hot loop.
 */
#include <stddef.h>

#include "nn/depthwise.h"

static inline float relu6(float v)
{
    v = v > 0.0f ? v : 0.0f;
    return v < 6.0f ? v : 6.0f;
}

/* relu6(b + w . the 3x3 window) with window column j at in[x + j - 1] of rows r0..r2,
 * columns outside [0, W) counting as 0. The order of the sum is that of the interior. */
static inline float window_s1(const float *r0, const float *r1, const float *r2,
                              const float *w, float b, int x, int W)
{
    float l0 = x > 0 ? r0[x - 1] : 0.0f, l1 = x > 0 ? r1[x - 1] : 0.0f,
          l2 = x > 0 ? r2[x - 1] : 0.0f;
    float q0 = x + 1 < W ? r0[x + 1] : 0.0f, q1 = x + 1 < W ? r1[x + 1] : 0.0f,
          q2 = x + 1 < W ? r2[x + 1] : 0.0f;
    float s = b + w[0] * l0 + w[1] * r0[x] + w[2] * q0;
    s = s + w[3] * l1 + w[4] * r1[x] + w[5] * q1;
    s = s + w[6] * l2 + w[7] * r2[x] + w[8] * q2;
    return relu6(s);
}

static void depthwise_s1(float *restrict out, const float *restrict in, const float *w,
                         float b, int H, const float *zero)
{
    // in (H,H) -> out (H,H), pad 1. The interior rows 1..H-2 as ONE run of the plane,
    // each point p reading p-H-1 .. p+H+1: long contiguous loops whatever H is (14 wide
    // rows would leave most of a 16-float vector idle). Columns 0 and H-1 of those rows
    // read across the row boundary there and are recomputed with the border sum after;
    // rows 0 and H-1 are done with the border sum too. Every output is the same
    // expression as window_s1's, so the values do not depend on which path made them.
    const float w0 = w[0], w1 = w[1], w2 = w[2], w3 = w[3], w4 = w[4], w5 = w[5], w6 = w[6],
                w7 = w[7], w8 = w[8];
    if (H >= 3) {
        size_t n = (size_t)(H - 2) * H;
        const float *restrict r0 = in, *restrict r1 = in + H, *restrict r2 = in + 2 * (size_t)H;
        float *restrict o = out + H;
        for (size_t p = 1; p + 1 < n; p++) {
            float s = b + w0 * r0[p - 1] + w1 * r0[p] + w2 * r0[p + 1];
            s = s + w3 * r1[p - 1] + w4 * r1[p] + w5 * r1[p + 1];
            s = s + w6 * r2[p - 1] + w7 * r2[p] + w8 * r2[p + 1];
            s = s > 0.0f ? s : 0.0f;
            o[p] = s < 6.0f ? s : 6.0f;
        }
    }
    for (int y = 0; y < H; y++) {
        const float *r0 = y > 0 ? in + (size_t)(y - 1) * H : zero;
        const float *r1 = in + (size_t)y * H;
        const float *r2 = y + 1 < H ? in + (size_t)(y + 1) * H : zero;
        float *o = out + (size_t)y * H;
        if (y == 0 || y == H - 1) {
            for (int x = 0; x < H; x++)
                o[x] = window_s1(r0, r1, r2, w, b, x, H);
        } else {
            o[0] = window_s1(r0, r1, r2, w, b, 0, H);
            o[H - 1] = window_s1(r0, r1, r2, w, b, H - 1, H);
        }
    }
}

static void depthwise_s2(float *restrict out, const float *restrict in, const float *w,
                         float b, int H, const float *zero)
{
    // in (H,H), H even -> out (H/2,H/2); window rows 2y..2y+2, columns 2x..2x+2, the
    // row and column H being the zero padding
    const float w0 = w[0], w1 = w[1], w2 = w[2], w3 = w[3], w4 = w[4], w5 = w[5], w6 = w[6],
                w7 = w[7], w8 = w[8];
    int OH = H / 2;
    for (int y = 0; y < OH; y++) {
        const float *restrict r0 = in + (size_t)(2 * y) * H;
        const float *restrict r1 = r0 + H;
        const float *restrict r2 = 2 * y + 2 < H ? r1 + H : zero;
        float *restrict o = out + (size_t)y * OH;
        for (int x = 0; x < OH - 1; x++) {
            int c = 2 * x;
            float s = b + w0 * r0[c] + w1 * r0[c + 1] + w2 * r0[c + 2];
            s = s + w3 * r1[c] + w4 * r1[c + 1] + w5 * r1[c + 2];
            s = s + w6 * r2[c] + w7 * r2[c + 1] + w8 * r2[c + 2];
            s = s > 0.0f ? s : 0.0f;
            o[x] = s < 6.0f ? s : 6.0f;
        }
        int c = H - 2; /* the last window: its third column is the padding */
        float s = b + w0 * r0[c] + w1 * r0[c + 1] + w2 * 0.0f;
        s = s + w3 * r1[c] + w4 * r1[c + 1] + w5 * 0.0f;
        s = s + w6 * r2[c] + w7 * r2[c + 1] + w8 * 0.0f;
        o[OH - 1] = relu6(s);
    }
}

void depthwise3x3_relu6_forward(float *out, const float *in, const float *w, float b, int H,
                                int stride, const float *zero)
{
    if (stride == 1)
        depthwise_s1(out, in, w, b, H, zero);
    else
        depthwise_s2(out, in, w, b, H, zero);
}

void conv1_im2col(float *out, const float *in, int S, const float *zero)
{
    // in (3,S,S) -> out (27, OH*OH), OH = S/2
    int OH = S / 2;
    size_t plane = (size_t)OH * OH;
    for (int c = 0; c < 3; c++)
        for (int dy = 0; dy < 3; dy++)
            for (int dx = 0; dx < 3; dx++) {
                float *o = out + (size_t)(c * 9 + dy * 3 + dx) * plane;
                for (int y = 0; y < OH; y++) {
                    int sy = 2 * y + dy;
                    const float *r = sy < S ? in + ((size_t)c * S + sy) * S : zero;
                    for (int x = 0; x < OH; x++) {
                        int sx = 2 * x + dx;
                        o[(size_t)y * OH + x] = sx < S ? r[sx] : 0.0f;
                    }
                }
            }
}
