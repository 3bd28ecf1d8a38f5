/*
 * The MLP: a trunk of linear layers ([LayerNorm], activation, [dropout], optional residual)
 * and heads over column ranges of its output, forward, backward and the loss, over plain
 * float arrays in the style of llm.c. Parameters live in one array (weights) with their
 * gradients in another of the same layout (grads), so the optimiser sees one vector.
 */
#include <assert.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nn/nn.h"

static void set_err(char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void set_err(char *err, size_t errlen, const char *fmt, ...)
{
    if (!err || !errlen)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
}

/* ---------------------------------------------------------------- parameters ------ */

/* Uniform in [0,1) from (seed, tensor, index): a pure function, independent of order. */
static double uniform_at(uint64_t seed, uint64_t tensor, uint64_t i)
{
    uint64_t z = nn_mix64(seed ^ nn_mix64(tensor * 0x9e3779b97f4a7c15ull + i + 1));
    return (double)(z >> 11) * 0x1p-53;
}

static double normal_at(uint64_t seed, uint64_t tensor, uint64_t i)
{
    // Box-Muller on two draws of this element's own (even, odd) counters
    double u1 = uniform_at(seed, tensor, 2 * i), u2 = uniform_at(seed, tensor, 2 * i + 1);
    return sqrt(-2.0 * log(1.0 - u1)) * cos(2.0 * M_PI * u2);
}

static int add_param(nn_mlp *m, const char *name, int ndim, int64_t d0, int64_t d1)
{
    if (m->n_params >= (int)(sizeof m->params / sizeof m->params[0]))
        return -1;
    nn_param *p = &m->params[m->n_params++];
    snprintf(p->name, sizeof p->name, "%s", name);
    p->ndim = ndim;
    p->shape[0] = d0;
    p->shape[1] = ndim > 1 ? d1 : 1;
    p->offset = m->n_floats;
    p->size = (size_t)d0 * (size_t)p->shape[1];
    m->n_floats += p->size;
    return 0;
}

/* The parameter table: names as torch numbers the modules, shapes, offsets, and where
 * each layer's tensors are (m->linear_param, m->norm_param). */
static void build_params(nn_mlp *m)
{
    const nn_mlp_config *c = &m->cfg;
    char name[64];
    int module = 0;
    m->n_params = 0;
    m->n_floats = 0;
    for (int l = 0; l < c->n_linear; l++) {
        int last = l == c->n_linear - 1, in = c->width[l], out = c->width[l + 1];
        m->norm_param[l] = -1;
        if (c->residual && !last) {
            m->linear_param[l] = m->n_params;
            snprintf(name, sizeof name, "trunk.%d.linear.weight", l);
            add_param(m, name, 2, out, in);
            snprintf(name, sizeof name, "trunk.%d.linear.bias", l);
            add_param(m, name, 1, out, 1);
            if (c->layernorm) {
                m->norm_param[l] = m->n_params;
                snprintf(name, sizeof name, "trunk.%d.norm.weight", l);
                add_param(m, name, 1, out, 1);
                snprintf(name, sizeof name, "trunk.%d.norm.bias", l);
                add_param(m, name, 1, out, 1);
            }
            module++;
            continue;
        }
        m->linear_param[l] = m->n_params;
        snprintf(name, sizeof name, "trunk.%d.weight", module);
        add_param(m, name, 2, out, in);
        snprintf(name, sizeof name, "trunk.%d.bias", module);
        add_param(m, name, 1, out, 1);
        module++;
        if (last)
            break;
        if (c->layernorm) {
            m->norm_param[l] = m->n_params;
            snprintf(name, sizeof name, "trunk.%d.weight", module);
            add_param(m, name, 1, out, 1);
            snprintf(name, sizeof name, "trunk.%d.bias", module);
            add_param(m, name, 1, out, 1);
            module++;
        }
        module++; /* the activation */
        if (c->dropout > 0.0f)
            module++;
    }
}

static void init_params(nn_mlp *m, uint64_t seed)
{
    const nn_mlp_config *c = &m->cfg;
    for (int l = 0; l < c->n_linear; l++) {
        int t = m->linear_param[l];
        nn_param *w = &m->params[t], *b = &m->params[t + 1];
        double fan_in = (double)c->width[l], fan_out = (double)c->width[l + 1];
        float *pw = m->weights + w->offset, *pb = m->weights + b->offset;
        for (size_t i = 0; i < w->size; i++) {
            switch (c->init) {
            case NN_INIT_KAIMING:
                pw[i] = (float)(normal_at(seed, (uint64_t)t, i) * sqrt(2.0 / fan_in));
                break;
            case NN_INIT_XAVIER:
                pw[i] = (float)((2.0 * uniform_at(seed, (uint64_t)t, i) - 1.0) *
                                sqrt(6.0 / (fan_in + fan_out)));
                break;
            case NN_INIT_TORCH:
            default:
                pw[i] = (float)((2.0 * uniform_at(seed, (uint64_t)t, i) - 1.0) / sqrt(fan_in));
                break;
            }
        }
        for (size_t i = 0; i < b->size; i++)
            pb[i] = c->init == NN_INIT_TORCH
                        ? (float)((2.0 * uniform_at(seed, (uint64_t)t + 1, i) - 1.0) /
                                  sqrt(fan_in))
                        : 0.0f;
        if (m->norm_param[l] >= 0) {
            nn_param *g = &m->params[m->norm_param[l]], *be = &m->params[m->norm_param[l] + 1];
            for (size_t i = 0; i < g->size; i++) {
                m->weights[g->offset + i] = 1.0f;
                m->weights[be->offset + i] = 0.0f;
            }
        }
    }
}

int nn_mlp_create(nn_mlp *m, const nn_mlp_config *cfg, const nn_head *heads, int n_heads,
                  uint64_t seed, char *err, size_t errlen)
{
    memset(m, 0, sizeof *m);
    if (cfg->n_linear < 1 || cfg->n_linear > NN_MLP_MAX_LAYERS || n_heads < 1 ||
        n_heads > NN_MAX_HEADS) {
        set_err(err, errlen, "model: %d linear layers and %d heads (need 1..%d and 1..%d)",
                cfg->n_linear, n_heads, NN_MLP_MAX_LAYERS, NN_MAX_HEADS);
        return -1;
    }
    m->cfg = *cfg;
    m->n_heads = n_heads;
    memcpy(m->heads, heads, (size_t)n_heads * sizeof *heads);
    int outputs = 0;
    for (int k = 0; k < n_heads; k++) {
        const nn_head *h = &heads[k];
        int w = h->kind == NN_HEAD_SOFTMAX ? h->classes : h->count;
        if (h->out_first != outputs || w < 1) {
            set_err(err, errlen, "model: head %d does not follow the previous heads' outputs", k);
            return -1;
        }
        if (h->kind == NN_HEAD_LINEAR && h->loss == NN_LOSS_THESIS) {
            set_err(err, errlen,
                    "model: head %d is linear but the thesis loss takes log(p + 1e-7), which "
                    "needs p > 0: use a sigmoid head",
                    k);
            return -1;
        }
        outputs += w;
        if (h->y_first + h->count > m->y_cols)
            m->y_cols = h->y_first + h->count;
    }
    if (outputs != cfg->width[cfg->n_linear]) {
        set_err(err, errlen, "model: heads need %d outputs, the network has %d", outputs,
                cfg->width[cfg->n_linear]);
        return -1;
    }
    build_params(m);
    m->weights = calloc(m->n_floats, sizeof(float));
    m->grads = calloc(m->n_floats, sizeof(float));
    if (!m->weights || !m->grads) {
        nn_mlp_free(m);
        set_err(err, errlen, "model: out of memory for %zu parameters", m->n_floats);
        return -1;
    }
    init_params(m, seed);
    m->threads = 1;
    m->dropout_seed = nn_mix64(seed + 0x243f6a8885a308d3ull);
    return 0;
}

void nn_mlp_free(nn_mlp *m)
{
    free(m->weights);
    free(m->grads);
    free(m->acts);
    m->weights = m->grads = m->acts = NULL;
    m->cap_batch = 0;
}

const nn_param *nn_mlp_find_param(const nn_mlp *m, const char *name)
{
    for (int i = 0; i < m->n_params; i++)
        if (!strcmp(m->params[i].name, name))
            return &m->params[i];
    return NULL;
}

/* ---------------------------------------------------------------- activations ----- */

/* Pointers into m->acts for a batch capacity of cap rows. Per linear layer l: z (its
 * output), and for hidden layers norm/mean/rstd (LayerNorm), act (activation output),
 * keep (dropout), h (the layer's output: the next layer's input). */
typedef struct mlp_acts {
    float *z[NN_MLP_MAX_LAYERS], *norm[NN_MLP_MAX_LAYERS], *mean[NN_MLP_MAX_LAYERS],
        *rstd[NN_MLP_MAX_LAYERS], *act[NN_MLP_MAX_LAYERS], *keep[NN_MLP_MAX_LAYERS],
        *h[NN_MLP_MAX_LAYERS];
    float *probs;              /* (cap, OUT) head outputs */
    float *dlogits;            /* (cap, OUT) */
    float *d[4];               /* (cap, max width) gradient scratch */
    float *gp, *gy, *gm, *gd;  /* (cap, max(OUT, y_cols)) head gathers */
} mlp_acts;

static size_t layout(const nn_mlp *m, size_t cap, float *base, mlp_acts *a)
{
    const nn_mlp_config *c = &m->cfg;
    size_t o = 0;
    int maxw = 0;
    for (int l = 0; l <= c->n_linear; l++)
        maxw = c->width[l] > maxw ? c->width[l] : maxw;
    int out = c->width[c->n_linear];
    int gw = out > m->y_cols ? out : m->y_cols;
#define TAKE(ptr, count)                                                                       \
    do {                                                                                       \
        (ptr) = base ? base + o : NULL;                                                        \
        o += (count);                                                                          \
    } while (0)
    memset(a, 0, sizeof *a);
    for (int l = 0; l < c->n_linear; l++) {
        size_t w = (size_t)c->width[l + 1];
        TAKE(a->z[l], cap * w);
        if (l == c->n_linear - 1)
            break;
        if (c->layernorm) {
            TAKE(a->norm[l], cap * w);
            TAKE(a->mean[l], cap);
            TAKE(a->rstd[l], cap);
        }
        TAKE(a->act[l], cap * w);
        if (c->dropout > 0.0f)
            TAKE(a->keep[l], cap * w);
        TAKE(a->h[l], cap * w);
    }
    TAKE(a->probs, cap * (size_t)out);
    TAKE(a->dlogits, cap * (size_t)out);
    for (int k = 0; k < 4; k++)
        TAKE(a->d[k], cap * (size_t)maxw);
    TAKE(a->gp, cap * (size_t)gw);
    TAKE(a->gy, cap * (size_t)gw);
    TAKE(a->gm, cap * (size_t)gw);
    TAKE(a->gd, cap * (size_t)gw);
#undef TAKE
    return o;
}

static int ensure_acts(nn_mlp *m, int B, mlp_acts *a)
{
    if (B > m->cap_batch) {
        mlp_acts tmp;
        size_t n = layout(m, (size_t)B, NULL, &tmp);
        float *p = malloc(n * sizeof(float));
        if (!p)
            return -1;
        free(m->acts);
        m->acts = p;
        m->acts_floats = n;
        m->cap_batch = B;
    }
    layout(m, (size_t)m->cap_batch, m->acts, a);
    return 0;
}

/* ---------------------------------------------------------------- forward -------- */

static const float *param(const nn_mlp *m, const float *base, int index)
{
    return base + m->params[index].offset;
}

/* Trunk forward; dropout only when training. Leaves logits in a->z[last]. */
static void trunk_forward(nn_mlp *m, const mlp_acts *a, const float *x, int B, int training,
                          long long step)
{
    const nn_mlp_config *c = &m->cfg;
    const float *in = x;
    for (int l = 0; l < c->n_linear; l++) {
        int Ci = c->width[l], Co = c->width[l + 1];
        size_t n = (size_t)B * Co;
        // z (B,Co) = in (B,Ci) . W^T + b
        linear_forward(a->z[l], in, param(m, m->weights, m->linear_param[l]),
                       param(m, m->weights, m->linear_param[l] + 1), B, Ci, Co, m->threads);
        if (l == c->n_linear - 1)
            break;
        const float *pre = a->z[l];
        if (c->layernorm) {
            // norm (B,Co) = LayerNorm(z)
            layernorm_forward(a->norm[l], a->mean[l], a->rstd[l], a->z[l],
                              param(m, m->weights, m->norm_param[l]),
                              param(m, m->weights, m->norm_param[l] + 1), B, Co);
            pre = a->norm[l];
        }
        // act (B,Co) = f(pre)
        if (c->act == NN_ACT_GELU)
            gelu_forward(a->act[l], pre, n);
        else if (c->act == NN_ACT_LEAKY_RELU)
            leaky_relu_forward(a->act[l], pre, n, c->leaky_slope);
        else {
            memcpy(a->act[l], pre, n * sizeof(float));
            relu_forward(a->act[l], n);
        }
        // h (B,Co) = dropout(act) [+ in when residual and Ci == Co]
        if (training && c->dropout > 0.0f)
            dropout_forward(a->h[l], a->keep[l], a->act[l], n, c->dropout,
                            m->dropout_seed ^ nn_mix64((uint64_t)step * 64 + (uint64_t)l));
        else
            memcpy(a->h[l], a->act[l], n * sizeof(float));
        if (c->residual && Ci == Co)
            for (size_t i = 0; i < n; i++)
                a->h[l][i] += in[i];
        in = a->h[l];
    }
}

/* probs (B,OUT) = the heads' activations of the logits. */
static void heads_forward(const nn_mlp *m, const mlp_acts *a, int B)
{
    int out = m->cfg.width[m->cfg.n_linear];
    const float *z = a->z[m->cfg.n_linear - 1];
    for (int k = 0; k < m->n_heads; k++) {
        const nn_head *h = &m->heads[k];
        for (int i = 0; i < B; i++) {
            const float *zi = z + (size_t)i * out + h->out_first;
            float *pi = a->probs + (size_t)i * out + h->out_first;
            if (h->kind == NN_HEAD_SOFTMAX)
                softmax_forward(pi, zi, 1, h->classes);
            else if (h->kind == NN_HEAD_SIGMOID)
                sigmoid_forward(pi, zi, (size_t)h->count);
            else
                memcpy(pi, zi, (size_t)h->count * sizeof(float));
        }
    }
}

/* The eval-mode forward pass into m's activations (a->probs the outputs). */
static int eval_forward(nn_mlp *m, const float *x, int B, mlp_acts *a)
{
    if (ensure_acts(m, B, a))
        return -1;
    trunk_forward(m, a, x, B, 0, 0);
    heads_forward(m, a, B);
    return 0;
}

int nn_mlp_forward(nn_mlp *m, const float *x, int B, float *out)
{
    mlp_acts a;
    if (eval_forward(m, x, B, &a))
        return -1;
    memcpy(out, a.probs, (size_t)B * m->cfg.width[m->cfg.n_linear] * sizeof(float));
    return 0;
}

int nn_mlp_forward_mean(nn_mlp *nets, int n, const float *x, int B, float *out)
{
    size_t count = (size_t)B * (size_t)nets[0].cfg.width[nets[0].cfg.n_linear];
    if (nn_mlp_forward(&nets[0], x, B, out))
        return -1;
    for (int k = 1; k < n; k++) {
        mlp_acts a; /* member k's own activations: no scratch of ours */
        if (eval_forward(&nets[k], x, B, &a))
            return -1;
        for (size_t j = 0; j < count; j++)
            out[j] += a.probs[j];
    }
    for (size_t j = 0; n > 1 && j < count; j++)
        out[j] /= (float)n;
    return 0;
}

/* The class a softmax head's Y value v means. */
static int target_class(const nn_head *h, float v)
{
    return h->unit_selector ? (int)lrintf(v * (float)(h->classes - 1)) : (int)v;
}

void nn_mlp_decode(const nn_mlp *m, const float *probs, int B, float *y)
{
    int out = m->cfg.width[m->cfg.n_linear];
    memset(y, 0, (size_t)B * m->y_cols * sizeof(float));
    for (int k = 0; k < m->n_heads; k++) {
        const nn_head *h = &m->heads[k];
        for (int i = 0; i < B; i++) {
            const float *p = probs + (size_t)i * out + h->out_first;
            float *yi = y + (size_t)i * m->y_cols + h->y_first;
            if (h->kind != NN_HEAD_SOFTMAX) {
                memcpy(yi, p, (size_t)h->count * sizeof(float));
                continue;
            }
            int best = 0; /* first maximum, as torch.argmax */
            for (int c = 1; c < h->classes; c++)
                best = p[c] > p[best] ? c : best;
            yi[0] = h->unit_selector ? (float)best / (float)(h->classes - 1) : (float)best;
        }
    }
}

int nn_mlp_predict(nn_mlp *m, const float *x, int B, float *y)
{
    mlp_acts a;
    if (eval_forward(m, x, B, &a))
        return -1;
    nn_mlp_decode(m, a.probs, B, y);
    return 0;
}

/* ---------------------------------------------------------------- loss, backward -- */

/* loss = sum_k weight_k loss_k; dlogits (B,OUT) = dloss/dlogits. */
static double heads_loss_backward(const nn_mlp *m, const mlp_acts *a, const float *y,
                                  const float *mask, int B)
{
    int out = m->cfg.width[m->cfg.n_linear], yc = m->y_cols;
    const float *z = a->z[m->cfg.n_linear - 1];
    memset(a->dlogits, 0, (size_t)B * out * sizeof(float));
    double total = 0.0;
    for (int k = 0; k < m->n_heads; k++) {
        const nn_head *h = &m->heads[k];
        int w = h->kind == NN_HEAD_SOFTMAX ? h->classes : h->count;
        // gather this head's columns: gp (B,w) outputs or logits, gy/gm (B,count)
        for (int i = 0; i < B; i++) {
            const float *src = (h->kind == NN_HEAD_SOFTMAX ? z : a->probs) + (size_t)i * out +
                               h->out_first;
            memcpy(a->gp + (size_t)i * w, src, (size_t)w * sizeof(float));
            for (int j = 0; j < h->count; j++) {
                float v = y[(size_t)i * yc + h->y_first + j];
                float mk = mask ? mask[(size_t)i * yc + h->y_first + j] : 1.0f;
                if (h->kind == NN_HEAD_SOFTMAX)
                    v = mk != 0.0f ? (float)target_class(h, v) : 0.0f;
                a->gy[(size_t)i * h->count + j] = v;
                a->gm[(size_t)i * h->count + j] = mk;
            }
        }
        memset(a->gd, 0, (size_t)B * w * sizeof(float));
        double loss;
        if (h->kind == NN_HEAD_SOFTMAX) {
            // the softmax probabilities go to d[0] (scratch); gd = dloss/dlogits
            float cw = m->column_weights ? m->column_weights[h->y_first] : 1.0f;
            loss = cw * cross_entropy_forward_backward(a->gd, a->d[0], a->gp, a->gy,
                                                       mask ? a->gm : NULL, B, h->classes,
                                                       (double)h->weight * cw);
        } else {
            // gd = dloss/dp; for a sigmoid head then dloss/dz = dp p (1 - p)
            loss = regression_loss_forward_backward(h->loss, a->gd, a->gp, a->gy,
                                                    mask ? a->gm : NULL,
                                                    m->column_weights
                                                        ? m->column_weights + h->y_first
                                                        : NULL,
                                                    B, h->count,
                                                    h->weight);
            if (h->kind == NN_HEAD_SIGMOID)
                sigmoid_backward(a->gd, a->gd, a->gp, (size_t)B * h->count);
        }
        total += (double)h->weight * loss;
        for (int i = 0; i < B; i++)
            memcpy(a->dlogits + (size_t)i * out + h->out_first, a->gd + (size_t)i * w,
                   (size_t)w * sizeof(float));
    }
    return total;
}

static void trunk_backward(nn_mlp *m, const mlp_acts *a, const float *x, int B)
{
    const nn_mlp_config *c = &m->cfg;
    // dh: gradient of the current layer's output; starts as dloss/dlogits
    const float *dh = a->dlogits;
    float *d_in = a->d[0], *d_other = a->d[1], *t1 = a->d[2], *t2 = a->d[3];
    for (int l = c->n_linear - 1; l >= 0; l--) {
        int Ci = c->width[l], Co = c->width[l + 1];
        size_t n = (size_t)B * Co;
        const float *in = l ? a->h[l - 1] : x;
        const float *dz = dh;
        if (l < c->n_linear - 1) {
            // backward of h = dropout(act) [+ in]: t1 = dact
            if (a->keep[l] && c->dropout > 0.0f)
                dropout_backward(t1, dh, a->keep[l], n);
            else
                memcpy(t1, dh, n * sizeof(float));
            // backward of act = f(pre): t2 = dpre
            const float *pre = c->layernorm ? a->norm[l] : a->z[l];
            if (c->act == NN_ACT_GELU)
                gelu_backward(t2, t1, pre, n);
            else if (c->act == NN_ACT_LEAKY_RELU)
                leaky_relu_backward(t2, t1, pre, n, c->leaky_slope);
            else
                relu_backward(t2, t1, pre, n);
            dz = t2;
            if (c->layernorm) {
                // backward of norm = LayerNorm(z): t1 = dz
                int g = m->norm_param[l];
                layernorm_backward(t1, m->grads + m->params[g].offset,
                                   m->grads + m->params[g + 1].offset, t2, a->z[l],
                                   param(m, m->weights, g), a->mean[l], a->rstd[l], B, Co);
                dz = t1;
            }
        }
        // backward of z = in . W^T + b: dW, db += ...; d_in (B,Ci) = dz . W
        int li = m->linear_param[l];
        linear_backward(l ? d_in : NULL, m->grads + m->params[li].offset,
                        m->grads + m->params[li + 1].offset, dz, in, param(m, m->weights, li), B,
                        Ci, Co, m->threads);
        if (!l)
            break;
        // the previous layer's output fed both this layer and, through the residual, this
        // layer's output: its gradient adds dh
        if (c->residual && Ci == Co && l < c->n_linear - 1)
            for (size_t i = 0; i < n; i++)
                d_in[i] += dh[i];
        dh = d_in;
        float *t = d_in;
        d_in = d_other;
        d_other = t;
    }
}

int nn_mlp_forward_backward(nn_mlp *m, const float *x, const float *y, const float *mask,
                            int B, long long step, double *loss)
{
    mlp_acts a;
    if (ensure_acts(m, B, &a))
        return -1;
    trunk_forward(m, &a, x, B, 1, step);
    heads_forward(m, &a, B);
    memset(m->grads, 0, m->n_floats * sizeof(float));
    *loss = heads_loss_backward(m, &a, y, mask, B);
    trunk_backward(m, &a, x, B);
    return 0;
}

int nn_mlp_evaluate(nn_mlp *m, const float *x, const float *y, const float *mask, int B,
                    double *loss)
{
    mlp_acts a;
    if (eval_forward(m, x, B, &a))
        return -1;
    *loss = heads_loss_backward(m, &a, y, mask, B); /* dlogits is scratch here */
    return 0;
}

int nn_mlp_train_step(nn_mlp *m, nn_optimizer *opt, const float *x, const float *y,
                      const float *mask, int B, double *loss)
{
    assert(opt->n == m->n_floats);
    if (nn_mlp_forward_backward(m, x, y, mask, B, opt->step, loss))
        return -1;
    nn_optimizer_step(opt, m->weights, m->grads);
    return 0;
}

int nn_mlp_check_data(const nn_mlp *m, const float *x, const float *y, const float *mask,
                      size_t N, char *err, size_t errlen)
{
    int in = m->cfg.width[0], yc = m->y_cols;
    for (size_t i = 0; i < N; i++)
        for (int j = 0; j < in; j++)
            if (!isfinite(x[i * in + j])) {
                set_err(err, errlen, "X row %zu column %d is %g (must be finite)", i, j,
                        x[i * in + j]);
                return -1;
            }
    for (size_t i = 0; i < N; i++)
        for (int k = 0; k < m->n_heads; k++) {
            const nn_head *h = &m->heads[k];
            for (int j = h->y_first; j < h->y_first + h->count; j++) {
                float mk = mask ? mask[i * yc + j] : 1.0f;
                float v = y[i * yc + j];
                if (mk != 0.0f && mk != 1.0f) {
                    set_err(err, errlen, "mask row %zu column %d is %g (must be 0 or 1)", i, j,
                            mk);
                    return -1;
                }
                if (mk == 0.0f)
                    continue;
                if (!isfinite(v)) {
                    set_err(err, errlen, "Y row %zu column %d is %g (must be finite)", i, j, v);
                    return -1;
                }
                if (h->kind == NN_HEAD_SOFTMAX) {
                    int ok = h->unit_selector
                                 ? v >= 0.0f && v <= 1.0f
                                 : v >= 0.0f && v < (float)h->classes && floorf(v) == v;
                    if (!ok) {
                        set_err(err, errlen,
                                "Y row %zu column %d is %g: the softmax head needs %s", i, j, v,
                                h->unit_selector ? "a selector value in [0, 1]"
                                                 : "a class index 0..K-1");
                        return -1;
                    }
                }
                if (h->kind == NN_HEAD_SIGMOID && h->loss == NN_LOSS_THESIS && v < 0.0f) {
                    set_err(err, errlen,
                            "Y row %zu column %d is %g: the thesis loss takes log(y + 1e-7)", i,
                            j, v);
                    return -1;
                }
            }
        }
    return 0;
}
