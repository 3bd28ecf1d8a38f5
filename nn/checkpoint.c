/*
 * MLP checkpoints in safetensors: the weights under torch's state_dict names (so a torch
 * module with the same structure loads them as they are), what is needed to rebuild the
 * model in "__metadata__", and optionally the optimiser's state beside them:
 *
 *   imsynth.format     "imsynth-mlp-1"
 *   imsynth.arch       nn_mlp_format_arch()        imsynth.heads   nn_heads_format()
 *   imsynth.losses     one per head: mse|l1|thesis (regression) or ce (softmax)
 *   imsynth.y_cols     Y columns
 *   imsynth.dropout_seed  dropout's draws (with optimizer.step: a resumed run draws as
 *                      the uninterrupted one would)
 *   optimizer.kind     sgd|adam|adamw, optimizer.step (steps taken), optimizer.<field>
 *                      for every nn_optimizer_config field
 *   tensors optimizer.exp_avg.<name>, optimizer.exp_avg_sq.<name> (Adam, AdamW) or
 *           optimizer.momentum_buffer.<name> (SGD with momentum): torch's state names
 */
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nn/nn.h"

#define CHECKPOINT_FORMAT "imsynth-mlp-1"

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

static const char *const loss_names[] = {"mse", "l1", "thesis"};
static const char *const optimizer_names[] = {"sgd", "adam", "adamw"};
static const char *const schedule_names[] = {"constant", "step", "cosine"};

enum { META_MAX = 32, META_VALUE = 512 };

typedef struct meta_list {
    const char *kv[2 * META_MAX];
    char values[META_MAX][META_VALUE];
    int n;
} meta_list;

static void meta_add(meta_list *l, const char *key, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void meta_add(meta_list *l, const char *key, const char *fmt, ...)
{
    if (l->n >= META_MAX)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(l->values[l->n], META_VALUE, fmt, ap);
    va_end(ap);
    l->kv[2 * l->n] = key;
    l->kv[2 * l->n + 1] = l->values[l->n];
    l->n++;
}

/* The one writer of both entry points below: opt's state is written only in F32 (a resumed
 * run must continue exactly), so a caller asks F16 only for weights alone. */
static int save_checkpoint(const nn_mlp *m, const nn_optimizer *opt, nn_dtype dtype,
                           const char *path, char *err, size_t errlen)
{
    meta_list meta = {.n = 0};
    char arch[META_VALUE], heads[META_VALUE], losses[META_VALUE] = "";
    nn_mlp_format_arch(&m->cfg, arch, sizeof arch);
    nn_heads_format(m->heads, m->n_heads, heads, sizeof heads);
    for (int k = 0; k < m->n_heads; k++)
        snprintf(losses + strlen(losses), sizeof losses - strlen(losses), "%s%s", k ? "," : "",
                 m->heads[k].kind == NN_HEAD_SOFTMAX ? "ce" : loss_names[m->heads[k].loss]);
    meta_add(&meta, "imsynth.format", "%s", CHECKPOINT_FORMAT);
    meta_add(&meta, "imsynth.arch", "%s", arch);
    meta_add(&meta, "imsynth.heads", "%s", heads);
    meta_add(&meta, "imsynth.losses", "%s", losses);
    meta_add(&meta, "imsynth.y_cols", "%d", m->y_cols);
    meta_add(&meta, "imsynth.dropout_seed", "%llu", (unsigned long long)m->dropout_seed);
    int with_opt = opt && opt->n;
    if (with_opt) {
        const nn_optimizer_config *c = &opt->cfg;
        meta_add(&meta, "optimizer.kind", "%s", optimizer_names[c->kind]);
        meta_add(&meta, "optimizer.step", "%lld", opt->step);
        meta_add(&meta, "optimizer.lr", "%.9g", c->lr);
        meta_add(&meta, "optimizer.weight_decay", "%.9g", c->weight_decay);
        meta_add(&meta, "optimizer.beta1", "%.9g", c->beta1);
        meta_add(&meta, "optimizer.beta2", "%.9g", c->beta2);
        meta_add(&meta, "optimizer.eps", "%.9g", c->eps);
        meta_add(&meta, "optimizer.momentum", "%.9g", c->momentum);
        meta_add(&meta, "optimizer.clip_norm", "%.9g", c->clip_norm);
        meta_add(&meta, "optimizer.schedule", "%s", schedule_names[c->schedule]);
        meta_add(&meta, "optimizer.warmup_steps", "%lld", c->warmup_steps);
        meta_add(&meta, "optimizer.total_steps", "%lld", c->total_steps);
        meta_add(&meta, "optimizer.step_size", "%lld", c->step_size);
        meta_add(&meta, "optimizer.gamma", "%.9g", c->gamma);
    }
    int cap = m->n_params * 3;
    nn_tensor_out *t = calloc((size_t)cap, sizeof *t);
    char(*names)[128] = calloc((size_t)cap, sizeof *names);
    if (!t || !names) {
        free(t);
        free(names);
        set_err(err, errlen, "%s: out of memory", path);
        return -1;
    }
    int n = 0;
    for (int i = 0; i < m->n_params; i++) {
        const nn_param *p = &m->params[i];
        t[n++] = (nn_tensor_out){p->name, p->ndim, {p->shape[0], p->shape[1]},
                                 m->weights + p->offset, dtype};
    }
    if (with_opt) {
        const char *first = opt->v ? "optimizer.exp_avg." : "optimizer.momentum_buffer.";
        for (int s = 0; s < 2; s++) {
            const float *buf = s ? opt->v : opt->m;
            if (!buf)
                continue;
            for (int i = 0; i < m->n_params; i++) {
                const nn_param *p = &m->params[i];
                snprintf(names[n], sizeof names[n], "%s%s", s ? "optimizer.exp_avg_sq." : first,
                         p->name);
                t[n] = (nn_tensor_out){names[n], p->ndim, {p->shape[0], p->shape[1]},
                                       buf + p->offset};
                n++;
            }
        }
    }
    int rc = nn_safetensors_write(path, t, n, meta.kv, meta.n, err, errlen);
    free(t);
    free(names);
    return rc;
}

int nn_mlp_save(const nn_mlp *m, const nn_optimizer *opt, const char *path, char *err,
                size_t errlen)
{
    return save_checkpoint(m, opt, NN_F32, path, err, errlen);
}

int nn_mlp_save_weights(const nn_mlp *m, nn_dtype dtype, const char *path, char *err,
                        size_t errlen)
{
    if (dtype != NN_F32 && dtype != NN_F16) {
        set_err(err, errlen, "%s: weights are written as F32 or F16 only", path);
        return -1;
    }
    // a weight past the half range would load as infinity: refuse rather than ship it
    for (int i = 0; dtype == NN_F16 && i < m->n_params; i++) {
        const nn_param *p = &m->params[i];
        for (size_t k = 0; k < p->size; k++) {
            float w = m->weights[p->offset + k];
            if (!(fabsf(w) <= 65504.0f)) {
                set_err(err, errlen, "%s: %s[%zu] = %g cannot be stored as F16", path, p->name,
                        k, (double)w);
                return -1;
            }
        }
    }
    return save_checkpoint(m, NULL, dtype, path, err, errlen);
}

/* Reads tensor prefix+name for every parameter into dst (the model's layout). */
static int read_all(const nn_mlp *m, const nn_safetensors *st, const char *prefix, float *dst,
                    char *err, size_t errlen)
{
    for (int i = 0; i < m->n_params; i++) {
        const nn_param *p = &m->params[i];
        char name[160];
        snprintf(name, sizeof name, "%s%s", prefix, p->name);
        if (nn_safetensors_read_f32(st, name, p->ndim, p->shape, dst + p->offset, err, errlen))
            return -1;
    }
    return 0;
}

static int load_weights_from(nn_mlp *m, const nn_safetensors *st, char *err, size_t errlen)
{
    // strict, as torch's load_state_dict: every parameter present with its shape, and no
    // model tensor the model does not have (optimiser state is not the model's)
    for (int i = 0; i < st->count; i++) {
        const char *name = st->tensors[i].name;
        if (strncmp(name, "optimizer.", 10) && !nn_mlp_find_param(m, name)) {
            char arch[256];
            nn_mlp_format_arch(&m->cfg, arch, sizeof arch);
            set_err(err, errlen, "%s: tensor \"%s\" is not a parameter of %s", st->path, name,
                    arch);
            return -1;
        }
    }
    return read_all(m, st, "", m->weights, err, errlen);
}

int nn_mlp_load_weights(nn_mlp *m, const char *path, char *err, size_t errlen)
{
    nn_safetensors st;
    if (nn_safetensors_open(path, &st, err, errlen))
        return -1;
    int rc = load_weights_from(m, &st, err, errlen);
    nn_safetensors_close(&st);
    return rc;
}

static int meta_string(const nn_safetensors *st, const char *key, char *v, size_t len, char *err,
                       size_t errlen)
{
    if (nn_safetensors_metadata(st, key, v, len)) {
        set_err(err, errlen, "%s: metadata \"%s\" is missing (not an imsynth checkpoint?)",
                st->path, key);
        return -1;
    }
    return 0;
}

static int meta_number(const nn_safetensors *st, const char *key, double *v, char *err,
                       size_t errlen)
{
    char s[64], *end;
    if (meta_string(st, key, s, sizeof s, err, errlen))
        return -1;
    *v = strtod(s, &end);
    if (!*s || *end) {
        set_err(err, errlen, "%s: metadata \"%s\" = \"%s\" is not a number", st->path, key, s);
        return -1;
    }
    return 0;
}

static int name_index(const char *const *names, int n, const char *s)
{
    for (int k = 0; k < n; k++)
        if (!strcmp(names[k], s))
            return k;
    return -1;
}

static int load_optimizer(const nn_mlp *m, nn_optimizer *opt, const nn_safetensors *st,
                          char *err, size_t errlen)
{
    char kind[32], sched[32];
    memset(opt, 0, sizeof *opt);
    if (nn_safetensors_metadata(st, "optimizer.kind", kind, sizeof kind))
        return 0; /* weights only */
    int k = name_index(optimizer_names, 3, kind);
    if (k < 0 || meta_string(st, "optimizer.schedule", sched, sizeof sched, err, errlen)) {
        if (k < 0)
            set_err(err, errlen, "%s: metadata optimizer.kind \"%s\" is not sgd, adam or adamw",
                    st->path, kind);
        return -1;
    }
    int s = name_index(schedule_names, 3, sched);
    if (s < 0) {
        set_err(err, errlen, "%s: metadata optimizer.schedule \"%s\" is unknown", st->path,
                sched);
        return -1;
    }
    nn_optimizer_config c = nn_optimizer_defaults((nn_optimizer_kind)k);
    c.schedule = (nn_schedule_kind)s;
    struct {
        const char *key;
        float *f;
        long long *i;
    } fields[] = {
        {"optimizer.lr", &c.lr, NULL},           {"optimizer.weight_decay", &c.weight_decay, NULL},
        {"optimizer.beta1", &c.beta1, NULL},     {"optimizer.beta2", &c.beta2, NULL},
        {"optimizer.eps", &c.eps, NULL},         {"optimizer.momentum", &c.momentum, NULL},
        {"optimizer.clip_norm", &c.clip_norm, NULL}, {"optimizer.gamma", &c.gamma, NULL},
        {"optimizer.warmup_steps", NULL, &c.warmup_steps},
        {"optimizer.total_steps", NULL, &c.total_steps},
        {"optimizer.step_size", NULL, &c.step_size},
    };
    for (size_t f = 0; f < sizeof fields / sizeof fields[0]; f++) {
        double v;
        if (meta_number(st, fields[f].key, &v, err, errlen))
            return -1;
        // in range before any conversion (an out-of-range cast is undefined)
        int ok = fields[f].f ? fabs(v) <= FLT_MAX : v >= 0 && v <= 0x1p53 && v == floor(v);
        if (!ok) {
            set_err(err, errlen, "%s: metadata \"%s\" = %g is out of range", st->path,
                    fields[f].key, v);
            return -1;
        }
        if (fields[f].f)
            *fields[f].f = (float)v;
        else
            *fields[f].i = (long long)v;
    }
    double step;
    if (meta_number(st, "optimizer.step", &step, err, errlen))
        return -1;
    if (!(step >= 0 && step <= 0x1p53) || step != floor(step)) {
        set_err(err, errlen, "%s: metadata optimizer.step = %g is not a step count", st->path,
                step);
        return -1;
    }
    if (nn_optimizer_init(opt, &c, m->n_floats)) {
        set_err(err, errlen, "%s: out of memory for the optimiser state", st->path);
        return -1;
    }
    opt->step = (long long)step;
    int rc = 0;
    if (opt->v)
        rc = read_all(m, st, "optimizer.exp_avg.", opt->m, err, errlen) ||
             read_all(m, st, "optimizer.exp_avg_sq.", opt->v, err, errlen);
    else if (opt->m)
        rc = read_all(m, st, "optimizer.momentum_buffer.", opt->m, err, errlen);
    if (rc) {
        nn_optimizer_free(opt);
        return -1;
    }
    return 0;
}

int nn_mlp_load(nn_mlp *m, nn_optimizer *opt, const char *path, char *err, size_t errlen)
{
    memset(m, 0, sizeof *m);
    if (opt)
        memset(opt, 0, sizeof *opt);
    nn_safetensors st;
    if (nn_safetensors_open(path, &st, err, errlen))
        return -1;
    char format[64], arch[META_VALUE], heads_spec[META_VALUE], losses[META_VALUE];
    double y_cols;
    nn_mlp_config cfg;
    nn_head heads[NN_MAX_HEADS];
    int n_heads = -1;
    char sub[512];
    if (meta_string(&st, "imsynth.format", format, sizeof format, err, errlen) ||
        meta_string(&st, "imsynth.arch", arch, sizeof arch, err, errlen) ||
        meta_string(&st, "imsynth.heads", heads_spec, sizeof heads_spec, err, errlen) ||
        meta_string(&st, "imsynth.losses", losses, sizeof losses, err, errlen) ||
        meta_number(&st, "imsynth.y_cols", &y_cols, err, errlen))
        goto fail;
    if (strcmp(format, CHECKPOINT_FORMAT)) {
        set_err(err, errlen, "%s: imsynth.format \"%s\" is not \"%s\"", path, format,
                CHECKPOINT_FORMAT);
        goto fail;
    }
    if (y_cols < 1 || y_cols > 1 << 24 || y_cols != (int)y_cols) {
        set_err(err, errlen, "%s: imsynth.y_cols = %g is not a column count", path, y_cols);
        goto fail;
    }
    if (nn_mlp_parse_arch(arch, &cfg, sub, sizeof sub)) {
        set_err(err, errlen, "%s: metadata imsynth.arch: %s", path, sub);
        goto fail;
    }
    n_heads = nn_heads_parse(heads_spec, (int)y_cols, cfg.width[cfg.n_linear], NN_LOSS_MSE,
                             heads, NN_MAX_HEADS, sub, sizeof sub);
    if (n_heads < 0) {
        set_err(err, errlen, "%s: metadata imsynth.heads: %s", path, sub);
        goto fail;
    }
    const char *s = losses;
    for (int k = 0; k < n_heads; k++) {
        size_t len = strcspn(s, ",");
        char name[16] = "";
        if (len < sizeof name)
            memcpy(name, s, len);
        int l = name_index(loss_names, 3, name);
        int ok = heads[k].kind == NN_HEAD_SOFTMAX ? !strcmp(name, "ce") : l >= 0;
        if (!ok) {
            set_err(err, errlen, "%s: metadata imsynth.losses \"%s\": head %d has no valid loss",
                    path, losses, k);
            goto fail;
        }
        if (l >= 0)
            heads[k].loss = (nn_loss)l;
        s += len + (s[len] == ',');
    }
    if (nn_mlp_create(m, &cfg, heads, n_heads, 0, sub, sizeof sub)) {
        set_err(err, errlen, "%s: %s", path, sub);
        goto fail;
    }
    if ((int)y_cols > m->y_cols)
        m->y_cols = (int)y_cols;
    char seed[32], *end;
    if (!nn_safetensors_metadata(&st, "imsynth.dropout_seed", seed, sizeof seed)) {
        m->dropout_seed = strtoull(seed, &end, 10);
        if (!*seed || *end) {
            set_err(err, errlen, "%s: metadata imsynth.dropout_seed = \"%s\" is not a number",
                    path, seed);
            goto fail;
        }
    }
    if (load_weights_from(m, &st, err, errlen))
        goto fail;
    if (opt && load_optimizer(m, opt, &st, err, errlen))
        goto fail;
    nn_safetensors_close(&st);
    return 0;
fail:
    nn_mlp_free(m);
    nn_safetensors_close(&st);
    return -1;
}
