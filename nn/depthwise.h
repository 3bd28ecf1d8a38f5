/* Internal to nn: MobileNetV2's spatial kernels (depthwise.c), used by mobilenetv2.c. */
#ifndef IMSYNTH_NN_DEPTHWISE_H
#define IMSYNTH_NN_DEPTHWISE_H

/* One channel's 3x3 depthwise convolution plus bias, then ReLU6. in (H,H), out (H,H) at
 * stride 1 (zero padding 1 all round, Keras' 'same') or (H/2,H/2) at stride 2 (H even;
 * zero padding only after the last row and column: Keras' ZeroPadding2D ((0,1),(0,1))
 * then 'valid'). w (3,3) row-major. zero: H + 1 zero floats. Each output is
 * relu6(b + sum over dy, dx in row-major order of w[dy][dx] * in[..]). */
void depthwise3x3_relu6_forward(float *out, const float *in, const float *w, float b, int H,
                                int stride, const float *zero);

/* Conv1's im2col at stride 2 with Keras' ((0,1),(0,1)) padding: in (3,S,S), S even ->
 * out (27, (S/2)^2), row c*9 + dy*3 + dx holding in[c][2y+dy][2x+dx] (0 past the last
 * row or column), matching a (32,3,3,3) weight read as (32,27). zero: S + 1 zeros. */
void conv1_im2col(float *out, const float *in, int S, const float *zero);

#endif
