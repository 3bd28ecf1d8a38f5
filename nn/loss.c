/* Regression losses and cross-entropy, masked and weighted, forward and backward at once. */
#include <math.h>
#include <string.h>

#include "nn/nn.h"

/* The thesis's log term: log(p + 1e-7), in float as torch computes it. */
#define THESIS_LOG_EPS 1e-7f
#define THESIS_LOG_WEIGHT 20.0f

int nn_loss_parse(const char *s)
{
    if (!strcmp(s, "mse"))
        return NN_LOSS_MSE;
    if (!strcmp(s, "l1"))
        return NN_LOSS_L1;
    if (!strcmp(s, "thesis"))
        return NN_LOSS_THESIS;
    return -1;
}

double regression_loss_forward_backward(nn_loss kind, float *dp, const float *p, const float *y,
                                        const float *mask, const float *wcol, int B, int C,
                                        double scale)
{
    // loss = sum_ij m_ij w_j e(p_ij, y_ij) / max(1, sum_ij m_ij)
    double active = 0.0;
    for (size_t i = 0; i < (size_t)B * C; i++)
        active += mask ? mask[i] : 1.0f;
    double denom = active > 1.0 ? active : 1.0;
    float g_scale = (float)(scale / denom);
    double total = 0.0;
    for (int i = 0; i < B; i++)
        for (int j = 0; j < C; j++) {
            size_t k = (size_t)i * C + j;
            float m = mask ? mask[k] : 1.0f;
            if (m == 0.0f)
                continue; /* masked: neither loss nor gradient (y may be anything here) */
            float w = (wcol ? wcol[j] : 1.0f) * m;
            float diff = p[k] - y[k], e, de;
            switch (kind) {
            case NN_LOSS_L1:
                // e = |p - y|, de/dp = sign(p - y)
                e = fabsf(diff);
                de = diff > 0.0f ? 1.0f : diff < 0.0f ? -1.0f : 0.0f;
                break;
            case NN_LOSS_THESIS: {
                // e = (p - y)^2 + 20 (log(p + eps) - log(y + eps))^2
                // de/dp = 2 (p - y) + 40 (lp - ly) / (p + eps)
                float lp = logf(p[k] + THESIS_LOG_EPS), ly = logf(y[k] + THESIS_LOG_EPS);
                float dl = lp - ly;
                e = diff * diff + THESIS_LOG_WEIGHT * dl * dl;
                de = 2.0f * diff + 2.0f * THESIS_LOG_WEIGHT * dl / (p[k] + THESIS_LOG_EPS);
                break;
            }
            case NN_LOSS_MSE:
            default:
                // e = (p - y)^2, de/dp = 2 (p - y)
                e = diff * diff;
                de = 2.0f * diff;
                break;
            }
            total += (double)w * e;
            if (dp)
                dp[k] += g_scale * w * de;
        }
    return total / denom;
}

double cross_entropy_forward_backward(float *dlogits, float *probs, const float *logits,
                                      const float *cls, const float *mask, int B, int K,
                                      double scale)
{
    // CE_i = -log softmax(logits_i)[cls_i]; loss = sum_i m_i CE_i / max(1, sum_i m_i)
    softmax_forward(probs, logits, B, K);
    double active = 0.0;
    for (int i = 0; i < B; i++)
        active += mask ? mask[i] : 1.0f;
    double denom = active > 1.0 ? active : 1.0;
    float g_scale = (float)(scale / denom);
    double total = 0.0;
    for (int i = 0; i < B; i++) {
        float m = mask ? mask[i] : 1.0f;
        if (m == 0.0f)
            continue;
        const float *z = logits + (size_t)i * K;
        const float *q = probs + (size_t)i * K;
        int c = (int)cls[i];
        // log softmax from the logits (not log of the rounded probability):
        // CE = log sum_k exp(z_k - max) - (z_c - max)
        float mx = z[0];
        for (int k = 1; k < K; k++)
            mx = z[k] > mx ? z[k] : mx;
        double s = 0.0;
        for (int k = 0; k < K; k++)
            s += exp((double)z[k] - mx);
        total += (double)m * (log(s) - ((double)z[c] - mx));
        // d CE / d z_k = softmax_k - [k == c]
        if (dlogits) {
            float *d = dlogits + (size_t)i * K;
            for (int k = 0; k < K; k++)
                d[k] += g_scale * m * (q[k] - (k == c ? 1.0f : 0.0f));
        }
    }
    return total / denom;
}
