/* LayerNorm over the last dimension, as torch.nn.LayerNorm(C) (eps 1e-5, biased variance). */
#include <math.h>

#include "nn/nn.h"

enum { LAYERNORM_EPS_DENOM = 100000 }; /* eps = 1e-5, torch's default */

void layernorm_forward(float *out, float *mean, float *rstd, const float *in, const float *w,
                       const float *b, int B, int C)
{
    // mean_i = sum_c x / C; var_i = sum_c (x - mean)^2 / C; rstd_i = 1 / sqrt(var + eps)
    // out = (x - mean) rstd w + b. Sums in double: the two-pass variance without
    // cancellation, and within rounding of torch's float sums.
    for (int i = 0; i < B; i++) {
        const float *x = in + (size_t)i * C;
        float *o = out + (size_t)i * C;
        double s = 0.0;
        for (int c = 0; c < C; c++)
            s += x[c];
        double mu = s / C, ss = 0.0;
        for (int c = 0; c < C; c++)
            ss += (x[c] - mu) * (x[c] - mu);
        float m = (float)mu, r = (float)(1.0 / sqrt(ss / C + 1.0 / LAYERNORM_EPS_DENOM));
        for (int c = 0; c < C; c++)
            o[c] = (x[c] - m) * r * w[c] + b[c];
        mean[i] = m;
        rstd[i] = r;
    }
}

void layernorm_backward(float *din, float *dw, float *db, const float *dout, const float *in,
                        const float *w, const float *mean, const float *rstd, int B, int C)
{
    // backward of out = xhat w + b with xhat = (x - mean) rstd:
    //   dw += dout xhat, db += dout, dxhat = dout w,
    //   dx = rstd (dxhat - mean_c(dxhat) - xhat mean_c(dxhat xhat))
    for (int i = 0; i < B; i++) {
        const float *x = in + (size_t)i * C, *d = dout + (size_t)i * C;
        float *dx = din + (size_t)i * C;
        float m = mean[i], r = rstd[i];
        double sum_g = 0.0, sum_gx = 0.0;
        for (int c = 0; c < C; c++) {
            float xhat = (x[c] - m) * r, g = d[c] * w[c];
            dw[c] += d[c] * xhat;
            db[c] += d[c];
            sum_g += g;
            sum_gx += (double)g * xhat;
        }
        float mg = (float)(sum_g / C), mgx = (float)(sum_gx / C);
        for (int c = 0; c < C; c++) {
            float xhat = (x[c] - m) * r, g = d[c] * w[c];
            dx[c] = r * (g - mg - xhat * mgx);
        }
    }
}
