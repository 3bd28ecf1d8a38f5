/*
 * SGD with momentum, Adam and AdamW in torch 1.13's order of operations (its documented
 * algorithms), gradient clipping by global norm, learning-rate schedules.
 *
 * Scalars that torch computes in Python (bias corrections, 1 - lr wd) are computed here in
 * double and rounded to float once, as torch rounds a Python scalar when it meets a float
 * tensor, so that 100 steps stay within float rounding of torch's.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "nn/nn.h"

nn_optimizer_config nn_optimizer_defaults(nn_optimizer_kind kind)
{
    nn_optimizer_config c = {.kind = kind, .lr = 1e-3f, .beta1 = 0.9f, .beta2 = 0.999f,
                             .eps = 1e-8f, .schedule = NN_SCHEDULE_CONSTANT, .gamma = 0.1f};
    if (kind == NN_OPT_SGD)
        c.lr = 1e-2f;
    if (kind == NN_OPT_ADAMW)
        c.weight_decay = 1e-2f;
    return c;
}

int nn_optimizer_parse(const char *s)
{
    if (!strcmp(s, "sgd"))
        return NN_OPT_SGD;
    if (!strcmp(s, "adam"))
        return NN_OPT_ADAM;
    if (!strcmp(s, "adamw"))
        return NN_OPT_ADAMW;
    return -1;
}

float nn_schedule_lr(const nn_optimizer_config *cfg, long long t)
{
    switch (cfg->schedule) {
    case NN_SCHEDULE_STEP:
        if (cfg->step_size <= 0)
            return cfg->lr;
        return (float)(cfg->lr * pow(cfg->gamma, (double)(t / cfg->step_size)));
    case NN_SCHEDULE_COSINE: {
        if (t < cfg->warmup_steps)
            return (float)((double)cfg->lr * (double)(t + 1) / (double)cfg->warmup_steps);
        long long span = cfg->total_steps - cfg->warmup_steps;
        double s = span > 0 ? (double)(t - cfg->warmup_steps) / (double)span : 1.0;
        s = s < 0.0 ? 0.0 : s > 1.0 ? 1.0 : s;
        return (float)((double)cfg->lr * 0.5 * (1.0 + cos(M_PI * s)));
    }
    case NN_SCHEDULE_CONSTANT:
    default:
        return cfg->lr;
    }
}

int nn_optimizer_init(nn_optimizer *opt, const nn_optimizer_config *cfg, size_t n)
{
    memset(opt, 0, sizeof *opt);
    opt->cfg = *cfg;
    opt->n = n;
    size_t bytes = (n ? n : 1) * sizeof(float);
    int need_m = cfg->kind != NN_OPT_SGD || cfg->momentum != 0.0f;
    int need_v = cfg->kind != NN_OPT_SGD;
    if (need_m && !(opt->m = calloc(1, bytes)))
        return -1;
    if (need_v && !(opt->v = calloc(1, bytes))) {
        nn_optimizer_free(opt);
        return -1;
    }
    return 0;
}

void nn_optimizer_free(nn_optimizer *opt)
{
    free(opt->m);
    free(opt->v);
    opt->m = opt->v = NULL;
    opt->n = 0;
}

double nn_grad_norm(const float *g, size_t n)
{
    double s = 0.0;
    for (size_t i = 0; i < n; i++)
        s += (double)g[i] * g[i];
    return sqrt(s);
}

float nn_optimizer_step(nn_optimizer *opt, float *params, float *grads)
{
    const nn_optimizer_config *c = &opt->cfg;
    size_t n = opt->n;
    double lr = nn_schedule_lr(c, opt->step);
    if (c->clip_norm > 0.0f) {
        // torch.nn.utils.clip_grad_norm_: g *= min(1, clip / (|g| + 1e-6))
        double norm = nn_grad_norm(grads, n);
        double coef = c->clip_norm / (norm + 1e-6);
        if (coef < 1.0) {
            float f = (float)coef;
            for (size_t i = 0; i < n; i++)
                grads[i] *= f;
        }
    }
    opt->step++;
    float wd = c->weight_decay;
    if (c->kind == NN_OPT_SGD) {
        float lrf = (float)lr, mom = c->momentum;
        for (size_t i = 0; i < n; i++) {
            float g = grads[i] + wd * params[i];
            if (opt->m) {
                // buf = g on the first step, else momentum buf + g
                opt->m[i] = opt->step == 1 ? g : mom * opt->m[i] + g;
                g = opt->m[i];
            }
            params[i] -= lrf * g;
        }
        return (float)lr;
    }
    double bc1 = 1.0 - pow(c->beta1, (double)opt->step);
    double bc2 = 1.0 - pow(c->beta2, (double)opt->step);
    float step_size = (float)(lr / bc1), bc2_sqrt = (float)sqrt(bc2);
    float b1 = c->beta1, b2 = c->beta2, one_b1 = (float)(1.0 - c->beta1),
          one_b2 = (float)(1.0 - c->beta2), eps = c->eps;
    float decay = (float)(1.0 - lr * wd);
    int decoupled = c->kind == NN_OPT_ADAMW;
    float *m = opt->m, *v = opt->v;
    for (size_t i = 0; i < n; i++) {
        float g = grads[i];
        if (decoupled)
            params[i] *= decay; // p *= 1 - lr wd
        else
            g += wd * params[i]; // L2 penalty in the gradient (Adam)
        m[i] = m[i] * b1 + one_b1 * g;      // m = b1 m + (1 - b1) g
        v[i] = v[i] * b2 + one_b2 * g * g;  // v = b2 v + (1 - b2) g^2
        float denom = sqrtf(v[i]) / bc2_sqrt + eps;
        params[i] += -step_size * m[i] / denom; // p -= lr / bc1 * m / denom
    }
    return (float)lr;
}
