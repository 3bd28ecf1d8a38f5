/*
 * The textual specs of a model: --arch ("mlp:IN-H-...-OUT[,options]") and --heads
 * ("sigmoid:A-B,softmax:C/K[:unit][@W],..."), parsed into nn_mlp_config / nn_head and
 * formatted back (checkpoints store the canonical form).
 */
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

static const char *const act_names[] = {"relu", "gelu", "leaky"};
static const char *const init_names[] = {"torch", "kaiming", "xavier"};

/* A whole-token decimal: strtol/strtof that must consume [s, end). */
static int parse_long_token(const char *s, const char *end, long lo, long hi, long *v)
{
    char buf[32];
    size_t n = (size_t)(end - s);
    if (!n || n >= sizeof buf)
        return -1;
    memcpy(buf, s, n);
    buf[n] = 0;
    char *e;
    *v = strtol(buf, &e, 10);
    return *e || *v < lo || *v > hi ? -1 : 0;
}

static int parse_float_token(const char *s, const char *end, float *v)
{
    char buf[32];
    size_t n = (size_t)(end - s);
    if (!n || n >= sizeof buf)
        return -1;
    memcpy(buf, s, n);
    buf[n] = 0;
    char *e;
    *v = strtof(buf, &e);
    return *e || !isfinite(*v) ? -1 : 0;
}

int nn_mlp_parse_arch(const char *spec, nn_mlp_config *cfg, char *err, size_t errlen)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->act = NN_ACT_RELU;
    cfg->leaky_slope = 0.01f;
    cfg->init = NN_INIT_TORCH;
    if (strncmp(spec, "mlp:", 4)) {
        set_err(err, errlen, "--arch \"%s\": expected \"mlp:IN-H1-...-OUT[,options]\"", spec);
        return -1;
    }
    const char *s = spec + 4;
    const char *widths_end = strchr(s, ',');
    if (!widths_end)
        widths_end = s + strlen(s);
    int n = 0;
    while (s < widths_end) {
        const char *e = memchr(s, '-', (size_t)(widths_end - s));
        if (!e)
            e = widths_end;
        long w;
        if (parse_long_token(s, e, 1, 1 << 24, &w)) {
            set_err(err, errlen, "--arch \"%s\": width %d (\"%.*s\") is not an integer >= 1",
                    spec, n, (int)(e - s), s);
            return -1;
        }
        if (n > NN_MLP_MAX_LAYERS) {
            set_err(err, errlen, "--arch \"%s\": more than %d layers", spec, NN_MLP_MAX_LAYERS);
            return -1;
        }
        cfg->width[n++] = (int)w;
        s = e < widths_end ? e + 1 : e;
    }
    if (n < 2) {
        set_err(err, errlen, "--arch \"%s\": need at least IN-OUT", spec);
        return -1;
    }
    cfg->n_linear = n - 1;
    while (*s == ',') {
        s++;
        const char *e = strchr(s, ',');
        if (!e)
            e = s + strlen(s);
        const char *eq = memchr(s, '=', (size_t)(e - s));
        size_t key = (size_t)((eq ? eq : e) - s);
        int ok = 0;
        if (key == 4 && !strncmp(s, "relu", 4) && !eq) {
            cfg->act = NN_ACT_RELU;
            ok = 1;
        } else if (key == 4 && !strncmp(s, "gelu", 4) && !eq) {
            cfg->act = NN_ACT_GELU;
            ok = 1;
        } else if (key == 5 && !strncmp(s, "leaky", 5)) {
            cfg->act = NN_ACT_LEAKY_RELU;
            ok = !eq || !parse_float_token(eq + 1, e, &cfg->leaky_slope);
        } else if (key == 2 && !strncmp(s, "ln", 2) && !eq) {
            cfg->layernorm = ok = 1;
        } else if (key == 3 && !strncmp(s, "res", 3) && !eq) {
            cfg->residual = ok = 1;
        } else if (key == 7 && !strncmp(s, "dropout", 7) && eq) {
            ok = !parse_float_token(eq + 1, e, &cfg->dropout) && cfg->dropout >= 0.0f &&
                 cfg->dropout < 1.0f;
        } else if (key == 4 && !strncmp(s, "init", 4) && eq) {
            for (int k = 0; k < 3; k++)
                if ((size_t)(e - eq - 1) == strlen(init_names[k]) &&
                    !strncmp(eq + 1, init_names[k], (size_t)(e - eq - 1))) {
                    cfg->init = (nn_init)k;
                    ok = 1;
                }
        }
        if (!ok) {
            set_err(err, errlen,
                    "--arch \"%s\": option \"%.*s\" is not one of relu, gelu, leaky[=SLOPE], ln, "
                    "res, dropout=P (0 <= P < 1), init=torch|kaiming|xavier",
                    spec, (int)(e - s), s);
            return -1;
        }
        s = e;
    }
    return 0;
}

void nn_mlp_format_arch(const nn_mlp_config *cfg, char *buf, size_t len)
{
    size_t o = (size_t)snprintf(buf, len, "mlp:");
    for (int l = 0; l <= cfg->n_linear && o < len; l++)
        o += (size_t)snprintf(buf + o, len - o, "%s%d", l ? "-" : "", cfg->width[l]);
    if (o < len && cfg->act == NN_ACT_LEAKY_RELU)
        o += (size_t)snprintf(buf + o, len - o, ",leaky=%.9g", cfg->leaky_slope);
    else if (o < len)
        o += (size_t)snprintf(buf + o, len - o, ",%s", act_names[cfg->act]);
    if (o < len && cfg->layernorm)
        o += (size_t)snprintf(buf + o, len - o, ",ln");
    if (o < len && cfg->residual)
        o += (size_t)snprintf(buf + o, len - o, ",res");
    if (o < len && cfg->dropout > 0.0f)
        o += (size_t)snprintf(buf + o, len - o, ",dropout=%.9g", cfg->dropout);
    if (o < len)
        snprintf(buf + o, len - o, ",init=%s", init_names[cfg->init]);
}

/* "A-B" or "A" as an inclusive column range. */
static int parse_range(const char *s, const char *e, int *first, int *count)
{
    const char *dash = memchr(s, '-', (size_t)(e - s));
    long a, b;
    if (parse_long_token(s, dash ? dash : e, 0, 1 << 24, &a))
        return -1;
    b = a;
    if (dash && parse_long_token(dash + 1, e, 0, 1 << 24, &b))
        return -1;
    if (b < a)
        return -1;
    *first = (int)a;
    *count = (int)(b - a + 1);
    return 0;
}

int nn_heads_parse(const char *spec, int y_cols, int out_width, nn_loss default_loss,
                   nn_head *heads, int max_heads, char *err, size_t errlen)
{
    int n = 0, out = 0;
    if (!spec || !*spec) {
        heads[0] = (nn_head){.kind = NN_HEAD_LINEAR, .y_first = 0, .count = y_cols,
                             .weight = 1.0f, .loss = default_loss};
        n = 1;
        out = y_cols;
    }
    const char *s = spec && *spec ? spec : NULL;
    while (s && *s) {
        const char *e = strchr(s, ',');
        if (!e)
            e = s + strlen(s);
        if (n >= max_heads) {
            set_err(err, errlen, "--heads: more than %d heads", max_heads);
            return -1;
        }
        nn_head h = {.weight = 1.0f, .loss = default_loss, .count = 1};
        const char *at = memchr(s, '@', (size_t)(e - s));
        const char *body_end = at ? at : e;
        const char *colon = memchr(s, ':', (size_t)(body_end - s));
        int bad = !colon;
        if (!bad && at && (parse_float_token(at + 1, e, &h.weight) || h.weight < 0.0f))
            bad = 1;
        if (!bad) {
            size_t kl = (size_t)(colon - s);
            const char *a = colon + 1;
            if ((kl == 7 && !strncmp(s, "sigmoid", 7)) || (kl == 6 && !strncmp(s, "linear", 6))) {
                h.kind = s[0] == 's' ? NN_HEAD_SIGMOID : NN_HEAD_LINEAR;
                bad = parse_range(a, body_end, &h.y_first, &h.count);
            } else if (kl == 7 && !strncmp(s, "softmax", 7)) {
                h.kind = NN_HEAD_SOFTMAX;
                const char *slash = memchr(a, '/', (size_t)(body_end - a));
                const char *unit = slash ? memchr(slash, ':', (size_t)(body_end - slash)) : NULL;
                long c, k;
                bad = !slash || parse_long_token(a, slash, 0, 1 << 24, &c) ||
                      parse_long_token(slash + 1, unit ? unit : body_end, 2, 1 << 20, &k);
                if (!bad && unit)
                    bad = (size_t)(body_end - unit - 1) != 4 || strncmp(unit + 1, "unit", 4);
                if (!bad) {
                    h.loss = NN_LOSS_MSE; /* unused: cross-entropy; one value for equality */
                    h.y_first = (int)c;
                    h.classes = (int)k;
                    h.unit_selector = unit != NULL;
                }
            } else {
                bad = 1;
            }
        }
        if (bad) {
            set_err(err, errlen,
                    "--heads: \"%.*s\" is not sigmoid:A-B, linear:A-B, softmax:C/K or "
                    "softmax:C/K:unit (each optionally @WEIGHT)",
                    (int)(e - s), s);
            return -1;
        }
        if (h.y_first + h.count > y_cols) {
            set_err(err, errlen, "--heads: \"%.*s\" reads Y column %d but Y has %d columns",
                    (int)(e - s), s, h.y_first + h.count - 1, y_cols);
            return -1;
        }
        for (int k = 0; k < n; k++)
            if (h.y_first < heads[k].y_first + heads[k].count &&
                heads[k].y_first < h.y_first + h.count) {
                set_err(err, errlen, "--heads: \"%.*s\" overlaps the Y columns of head %d",
                        (int)(e - s), s, k);
                return -1;
            }
        h.out_first = out;
        out += h.kind == NN_HEAD_SOFTMAX ? h.classes : h.count;
        heads[n++] = h;
        s = *e ? e + 1 : e;
    }
    if (out != out_width) {
        set_err(err, errlen, "--heads need %d network outputs but the network has %d", out,
                out_width);
        return -1;
    }
    return n;
}

void nn_heads_format(const nn_head *heads, int n, char *buf, size_t len)
{
    size_t o = 0;
    buf[0] = 0;
    for (int k = 0; k < n && o < len; k++) {
        const nn_head *h = &heads[k];
        const char *sep = k ? "," : "";
        if (h->kind == NN_HEAD_SOFTMAX)
            o += (size_t)snprintf(buf + o, len - o, "%ssoftmax:%d/%d%s", sep, h->y_first,
                                  h->classes, h->unit_selector ? ":unit" : "");
        else
            o += (size_t)snprintf(buf + o, len - o, "%s%s:%d-%d", sep,
                                  h->kind == NN_HEAD_SIGMOID ? "sigmoid" : "linear", h->y_first,
                                  h->y_first + h->count - 1);
        if (o < len && h->weight != 1.0f)
            o += (size_t)snprintf(buf + o, len - o, "@%.9g", h->weight);
    }
}
