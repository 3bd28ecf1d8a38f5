/*
 * MobileNetV2 (Keras' layout, width 1.0) from Conv1 to block_10, and its Gram descriptor.
 * See nn.h for the architecture, the taps and the input scaling.
 *
 * Activations are CHW planes of one image (channel after channel, rows top first). The
 * 1x1 convolutions are sgemms: out (K, HW) = W (K, C) . in (C, HW). The depthwise 3x3
 * and Conv1 are written out here (depthwise.c). Every image is computed by one worker
 * thread from start to end with OpenBLAS single-threaded (nn.h), so a descriptor does not depend
 * on how many threads there are or which one took it.
 */
#include <assert.h>
#include <cblas.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nn/depthwise.h"
#include "nn/nn.h"

const char mnv2_default_taps[] =
    "conv1,block_1_expand,block_3_expand,block_6_expand,block_10_project";

/* Keras MobileNetV2 alpha 1.0, blocks 0..10: expansion, output channels, stride. */
static const int block_expansion[MNV2_BLOCKS] = {1, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6};
static const int block_cout[MNV2_BLOCKS] = {16, 24, 24, 32, 32, 32, 64, 64, 64, 64, 96};
static const int block_stride[MNV2_BLOCKS] = {1, 2, 1, 2, 1, 1, 2, 1, 1, 1, 1};
enum { CONV1_CHANNELS = 32, MAX_THREADS = 256 };

static void set_err(char *err, size_t errlen, const char *fmt, ...)
{
    if (!err || !errlen)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
}

static int has_residual(const mobilenetv2 *net, int b)
{
    return net->stride[b] == 1 && net->cin[b] == net->cout[b];
}

/* ------------------------------------------------------------ weights ------------- */

void mnv2_free(mobilenetv2 *net)
{
    free(net->conv1_w);
    free(net->conv1_b);
    for (int b = 0; b < MNV2_BLOCKS; b++) {
        free(net->expand_w[b]);
        free(net->expand_b[b]);
        free(net->dw_w[b]);
        free(net->dw_b[b]);
        free(net->project_w[b]);
        free(net->project_b[b]);
    }
    memset(net, 0, sizeof *net);
}

static const char *block_name(int b, char *buf, size_t len)
{
    if (b == 0)
        snprintf(buf, len, "expanded_conv");
    else
        snprintf(buf, len, "block_%d", b);
    return buf;
}

/* Read tensor `<layer>.weight` of shape (dims) and `<layer>.bias` (dims[0]) into fresh
 * arrays, rejecting non-finite values. */
static int read_layer(const nn_safetensors *st, const char *layer, int ndim,
                      const int64_t *dims, float **w, float **bias, char *err, size_t errlen)
{
    char name[96];
    size_t n = 1;
    for (int i = 0; i < ndim; i++)
        n *= (size_t)dims[i];
    *w = malloc(n * sizeof(float));
    *bias = malloc((size_t)dims[0] * sizeof(float));
    if (!*w || !*bias) {
        set_err(err, errlen, "%s: out of memory", st->path);
        return -1;
    }
    snprintf(name, sizeof name, "%s.weight", layer);
    if (nn_safetensors_read_f32(st, name, ndim, dims, *w, err, errlen))
        return -1;
    for (size_t i = 0; i < n; i++)
        if (!isfinite((*w)[i])) {
            set_err(err, errlen, "%s: tensor \"%s\" has a non-finite value at flat index %zu",
                    st->path, name, i);
            return -1;
        }
    snprintf(name, sizeof name, "%s.bias", layer);
    if (nn_safetensors_read_f32(st, name, 1, dims, *bias, err, errlen))
        return -1;
    for (int64_t i = 0; i < dims[0]; i++)
        if (!isfinite((*bias)[i])) {
            set_err(err, errlen, "%s: tensor \"%s\" has a non-finite value at index %lld",
                    st->path, name, (long long)i);
            return -1;
        }
    return 0;
}

int mnv2_load(mobilenetv2 *net, const char *path, char *err, size_t errlen)
{
    memset(net, 0, sizeof *net);
    nn_safetensors st;
    if (nn_safetensors_open(path, &st, err, errlen))
        return -1;
    int64_t conv1_dims[4] = {CONV1_CHANNELS, 3, 3, 3};
    if (read_layer(&st, "Conv1", 4, conv1_dims, &net->conv1_w, &net->conv1_b, err, errlen))
        goto fail;
    int cin = CONV1_CHANNELS;
    for (int b = 0; b < MNV2_BLOCKS; b++) {
        char prefix[32], layer[64];
        block_name(b, prefix, sizeof prefix);
        net->cin[b] = cin;
        net->cexp[b] = cin * block_expansion[b];
        net->cout[b] = block_cout[b];
        net->stride[b] = block_stride[b];
        if (block_expansion[b] != 1) {
            int64_t dims[2] = {net->cexp[b], cin};
            snprintf(layer, sizeof layer, "%s_expand", prefix);
            if (read_layer(&st, layer, 2, dims, &net->expand_w[b], &net->expand_b[b], err,
                           errlen))
                goto fail;
        }
        int64_t dw_dims[3] = {net->cexp[b], 3, 3};
        snprintf(layer, sizeof layer, "%s_depthwise", prefix);
        if (read_layer(&st, layer, 3, dw_dims, &net->dw_w[b], &net->dw_b[b], err, errlen))
            goto fail;
        int64_t pdims[2] = {net->cout[b], net->cexp[b]};
        snprintf(layer, sizeof layer, "%s_project", prefix);
        if (read_layer(&st, layer, 2, pdims, &net->project_w[b], &net->project_b[b], err,
                       errlen))
            goto fail;
        cin = net->cout[b];
    }
    nn_safetensors_close(&st);
    return 0;
fail:
    nn_safetensors_close(&st);
    mnv2_free(net);
    return -1;
}

/* ------------------------------------------------------------ taps ---------------- */

void mnv2_tap_name(mnv2_tap tap, char *buf, size_t len)
{
    static const char *const point[] = {"", "expand", "depthwise", "project"};
    if (tap.point == MNV2_CONV1)
        snprintf(buf, len, "conv1");
    else
        snprintf(buf, len, "block_%d_%s", tap.block, point[tap.point]);
}

int mnv2_tap_channels(const mobilenetv2 *net, mnv2_tap tap)
{
    switch (tap.point) {
    case MNV2_CONV1:
        return CONV1_CHANNELS;
    case MNV2_EXPAND:
    case MNV2_DEPTHWISE:
        return net->cexp[tap.block];
    case MNV2_PROJECT:
        return net->cout[tap.block];
    }
    return 0;
}

static int parse_one_tap(const char *s, size_t len, mnv2_tap *tap)
{
    char name[64];
    if (len == 0 || len >= sizeof name)
        return -1;
    memcpy(name, s, len);
    name[len] = 0;
    if (!strcmp(name, "conv1")) {
        *tap = (mnv2_tap){0, MNV2_CONV1};
        return 0;
    }
    if (!strcmp(name, "expanded_conv_depthwise")) {
        *tap = (mnv2_tap){0, MNV2_DEPTHWISE};
        return 0;
    }
    if (!strcmp(name, "expanded_conv_project")) {
        *tap = (mnv2_tap){0, MNV2_PROJECT};
        return 0;
    }
    if (strncmp(name, "block_", 6))
        return -1;
    char *end;
    long b = strtol(name + 6, &end, 10);
    if (end == name + 6 || *end != '_' || b < 0 || b >= MNV2_BLOCKS)
        return -1;
    const char *point = end + 1;
    if (!strcmp(point, "expand") && b > 0)
        *tap = (mnv2_tap){(int)b, MNV2_EXPAND};
    else if (!strcmp(point, "depthwise"))
        *tap = (mnv2_tap){(int)b, MNV2_DEPTHWISE};
    else if (!strcmp(point, "project"))
        *tap = (mnv2_tap){(int)b, MNV2_PROJECT};
    else
        return -1;
    return 0;
}

int mnv2_taps_parse(const char *list, mnv2_tap *taps, char *err, size_t errlen)
{
    int n = 0;
    const char *s = list;
    for (;;) {
        const char *comma = strchr(s, ',');
        size_t len = comma ? (size_t)(comma - s) : strlen(s);
        mnv2_tap t;
        if (parse_one_tap(s, len, &t)) {
            set_err(err, errlen,
                    "unknown tap \"%.*s\" (expected conv1 or block_N_expand (N 1..10), "
                    "block_N_depthwise or block_N_project (N 0..10))",
                    (int)len, s);
            return -1;
        }
        for (int i = 0; i < n; i++)
            if (taps[i].point == t.point && (t.point == MNV2_CONV1 || taps[i].block == t.block)) {
                set_err(err, errlen, "tap \"%.*s\" given twice", (int)len, s);
                return -1;
            }
        /* Every distinct tap fits: there are exactly MNV2_MAX_TAPS of them. */
        taps[n++] = t;
        if (!comma)
            break;
        s = comma + 1;
    }
    return n;
}

size_t mnv2_descriptor_offsets(const mobilenetv2 *net, const mnv2_options *opt,
                               size_t offsets[2 * MNV2_MAX_TAPS + 1])
{
    size_t k = 0;
    offsets[0] = 0;
    for (int s = 0; s < opt->scales; s++)
        for (int t = 0; t < opt->ntaps; t++, k++) {
            size_t C = (size_t)mnv2_tap_channels(net, opt->taps[t]);
            offsets[k + 1] = offsets[k] + C * (C + 1) / 2;
        }
    return offsets[k];
}

/* ------------------------------------------------------------ preprocessing ------- */

/* The sRGB transfer function (IEC 61966-2-1), linear [0,1] -> encoded [0,1]. */
static float srgb_encode(float v)
{
    return v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
}

int mnv2_preprocess(float *out, const float *pixels, int width, int height, int channels)
{
    if (width < MNV2_INPUT_SIZE || height < MNV2_INPUT_SIZE || channels < 1 || channels > 4)
        return -1;
    int y0 = (height - MNV2_INPUT_SIZE) / 2, x0 = (width - MNV2_INPUT_SIZE) / 2;
    for (int c = 0; c < 3; c++) {
        int src_c = channels >= 3 ? c : 0; /* grey (+alpha) replicates channel 0 */
        for (int y = 0; y < MNV2_INPUT_SIZE; y++)
            for (int x = 0; x < MNV2_INPUT_SIZE; x++) {
                float v = pixels[((size_t)(y0 + y) * width + x0 + x) * channels + src_c];
                v = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; /* also maps NaN to 0 */
                out[((size_t)c * MNV2_INPUT_SIZE + y) * MNV2_INPUT_SIZE + x] = srgb_encode(v);
            }
    }
    return 0;
}

/* ------------------------------------------------------------ workspace ----------- */

/* One worker's buffers, sized for the input side ws->size:
 *   x, y   a block's input and output (the residual stream), ping-pong
 *   e      the expanded activation (also Conv1's im2col matrix)
 *   d      the depthwise output
 *   input  the image at the scale being computed
 *   gram   C x C scratch of gram_upper_forward
 *   zero   a zero row for the depthwise borders */
typedef struct worker {
    float *x, *y, *e, *d, *input, *gram, *zero;
} worker;

struct mnv2_workspace {
    const mobilenetv2 *net;
    mnv2_options opt;
    int size, max_batch, threads;
    size_t row; /* descriptor floats per image */
    size_t offsets[2 * MNV2_MAX_TAPS + 1];
    worker *workers;
    /* the job of one mnv2_describe call */
    const float *job_in;
    float *job_out;
    int job_n;
    atomic_int next_image;
};

static size_t max_size(size_t a, size_t b)
{
    return a > b ? a : b;
}

mnv2_workspace *mnv2_workspace_create(const mobilenetv2 *net, const mnv2_options *opt,
                                      int size, int max_batch)
{
    if (size < 16 || size % 16 || max_batch < 1 || opt->ntaps < 1 || opt->ntaps > MNV2_MAX_TAPS ||
        opt->scales < 1 || opt->scales > 2 || (opt->scales == 2 && size % 32))
        return NULL;
    mnv2_workspace *ws = calloc(1, sizeof *ws);
    if (!ws)
        return NULL;
    ws->net = net;
    ws->opt = *opt;
    ws->size = size;
    ws->max_batch = max_batch;
    ws->threads = opt->threads < 1 ? 1 : opt->threads > MAX_THREADS ? MAX_THREADS : opt->threads;
    ws->row = mnv2_descriptor_offsets(net, opt, ws->offsets);
    /* Largest activation of each kind over the blocks, at the first (largest) scale. */
    size_t h = (size_t)size / 2; /* after Conv1 */
    size_t xy = CONV1_CHANNELS * h * h, e = 27 * h * h, d = 0;
    int widest = CONV1_CHANNELS;
    for (int b = 0; b < MNV2_BLOCKS; b++) {
        size_t oh = h / (size_t)net->stride[b];
        xy = max_size(xy, (size_t)net->cout[b] * oh * oh);
        e = max_size(e, (size_t)net->cexp[b] * h * h);
        d = max_size(d, (size_t)net->cexp[b] * oh * oh);
        widest = net->cexp[b] > widest ? net->cexp[b] : widest;
        h = oh;
    }
    ws->workers = calloc((size_t)ws->threads, sizeof *ws->workers);
    if (!ws->workers) {
        free(ws);
        return NULL;
    }
    for (int t = 0; t < ws->threads; t++) {
        worker *w = &ws->workers[t];
        w->x = malloc(xy * sizeof(float));
        w->y = malloc(xy * sizeof(float));
        w->e = malloc(e * sizeof(float));
        w->d = malloc(d * sizeof(float));
        w->input = malloc(3 * (size_t)size * size * sizeof(float));
        w->gram = malloc((size_t)widest * widest * sizeof(float));
        w->zero = calloc((size_t)size + 16, sizeof(float));
        if (!w->x || !w->y || !w->e || !w->d || !w->input || !w->gram || !w->zero) {
            mnv2_workspace_free(ws);
            return NULL;
        }
    }
    return ws;
}

void mnv2_workspace_free(mnv2_workspace *ws)
{
    if (!ws)
        return;
    for (int t = 0; ws->workers && t < ws->threads; t++) {
        worker *w = &ws->workers[t];
        free(w->x);
        free(w->y);
        free(w->e);
        free(w->d);
        free(w->input);
        free(w->gram);
        free(w->zero);
    }
    free(ws->workers);
    free(ws);
}

/* ------------------------------------------------------------ forward ------------- */

/* out (K, HW) = w (K, C) . in (C, HW) + b, then ReLU6 (relu6) or + residual (K, HW)
 * when not NULL: one single-threaded sgemm and one pass over the output. */
static void pointwise_forward(float *out, const float *in, const float *w, const float *b,
                              int K, int C, int HW, int relu6, const float *residual)
{
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, K, HW, C, 1.0f, w, C, in, HW, 0.0f,
                out, HW);
    for (int k = 0; k < K; k++) {
        float *restrict o = out + (size_t)k * HW;
        const float bk = b[k];
        if (relu6)
            for (int p = 0; p < HW; p++) {
                float v = o[p] + bk;
                v = v > 0.0f ? v : 0.0f;
                o[p] = v < 6.0f ? v : 6.0f;
            }
        else if (residual) {
            const float *restrict r = residual + (size_t)k * HW;
            for (int p = 0; p < HW; p++)
                o[p] = (o[p] + bk) + r[p];
        } else
            for (int p = 0; p < HW; p++)
                o[p] += bk;
    }
}

/* The Gram of tap `point` of block b (if it is one) at scale s into the descriptor row. */
static void maybe_tap(const mnv2_workspace *ws, worker *w, int scale, int block,
                      mnv2_point point, const float *f, int C, int HW, float *row)
{
    for (int t = 0; t < ws->opt.ntaps; t++) {
        mnv2_tap tap = ws->opt.taps[t];
        if (tap.point != point || (point != MNV2_CONV1 && tap.block != block))
            continue;
        gram_upper_forward(row + ws->offsets[scale * ws->opt.ntaps + t], f, C, HW, w->gram);
    }
}

/* One image of side S already in w->input (3,S,S) through Conv1 .. block_10, writing the
 * Grams of scale `scale` into row. */
static void forward_one(const mnv2_workspace *ws, worker *w, int S, int scale, float *row)
{
    const mobilenetv2 *net = ws->net;
    // Conv1: input (3,S,S) -> x (32,S/2,S/2), ReLU6
    int H = S / 2;
    size_t HW = (size_t)H * H;
    conv1_im2col(w->e, w->input, S, w->zero);
    pointwise_forward(w->x, w->e, net->conv1_w, net->conv1_b, CONV1_CHANNELS, 27, (int)HW, 1,
                      NULL);
    maybe_tap(ws, w, scale, 0, MNV2_CONV1, w->x, CONV1_CHANNELS, (int)HW, row);
    float *x = w->x, *y = w->y;
    for (int b = 0; b < MNV2_BLOCKS; b++) {
        int cin = net->cin[b], cexp = net->cexp[b], cout = net->cout[b];
        int OH = H / net->stride[b];
        size_t OHW = (size_t)OH * OH;
        // expand: x (cin, HW) -> e (cexp, HW), ReLU6; block 0 depthwise-convolves x itself
        const float *e = x;
        if (net->expand_w[b]) {
            pointwise_forward(w->e, x, net->expand_w[b], net->expand_b[b], cexp, cin, (int)HW,
                              1, NULL);
            maybe_tap(ws, w, scale, b, MNV2_EXPAND, w->e, cexp, (int)HW, row);
            e = w->e;
        }
        // depthwise: e (cexp, H, H) -> d (cexp, OH, OH), ReLU6 (fused in the kernel)
        for (int c = 0; c < cexp; c++)
            depthwise3x3_relu6_forward(w->d + (size_t)c * OHW, e + (size_t)c * HW,
                                       net->dw_w[b] + 9 * (size_t)c, net->dw_b[b][c], H,
                                       net->stride[b], w->zero);
        maybe_tap(ws, w, scale, b, MNV2_DEPTHWISE, w->d, cexp, (int)OHW, row);
        // project: d (cexp, OHW) -> y (cout, OHW), + x when the block is residual
        pointwise_forward(y, w->d, net->project_w[b], net->project_b[b], cout, cexp, (int)OHW,
                          0, has_residual(net, b) ? x : NULL);
        maybe_tap(ws, w, scale, b, MNV2_PROJECT, y, cout, (int)OHW, row);
        float *t = x;
        x = y;
        y = t;
        H = OH;
        HW = OHW;
    }
}

/* Image k: both scales. */
static void describe_image(const mnv2_workspace *ws, worker *w, int k)
{
    int S = ws->size;
    size_t plane = (size_t)S * S;
    const float *src = ws->job_in + (size_t)k * 3 * plane;
    float *row = ws->job_out + (size_t)k * ws->row;
    for (size_t i = 0; i < 3 * plane; i++)
        w->input[i] = ws->opt.signed_input ? 2.0f * src[i] - 1.0f : src[i];
    forward_one(ws, w, S, 0, row);
    if (ws->opt.scales == 2) {
        // 2x2 box average of the (possibly signed) input: (3,S,S) -> (3,S/2,S/2), in place
        // (row y of the result only reads rows 2y, 2y+1 >= y, already-read ones never)
        int h = S / 2;
        for (int c = 0; c < 3; c++) {
            const float *in = w->input + (size_t)c * plane;
            float *o = w->input + (size_t)c * h * h;
            for (int yy = 0; yy < h; yy++)
                for (int xx = 0; xx < h; xx++) {
                    const float *p = in + (size_t)2 * yy * S + 2 * xx;
                    o[(size_t)yy * h + xx] = 0.25f * ((p[0] + p[1]) + (p[S] + p[S + 1]));
                }
        }
        forward_one(ws, w, h, 1, row);
    }
}

typedef struct worker_arg {
    mnv2_workspace *ws;
    int index;
} worker_arg;

static void *worker_main(void *p)
{
    worker_arg *a = p;
    for (;;) {
        int k = atomic_fetch_add(&a->ws->next_image, 1);
        if (k >= a->ws->job_n)
            break;
        describe_image(a->ws, &a->ws->workers[a->index], k);
    }
    return NULL;
}

void mnv2_describe(mnv2_workspace *ws, const float *in, int n, float *out)
{
    ws->job_in = in;
    ws->job_out = out;
    assert(n >= 0 && n <= ws->max_batch);
    ws->job_n = n;
    atomic_store(&ws->next_image, 0);
    int threads = ws->threads < ws->job_n ? ws->threads : ws->job_n;
    pthread_t tid[MAX_THREADS];
    worker_arg args[MAX_THREADS];
    int started = 0;
    for (int t = 1; t < threads; t++) {
        args[t] = (worker_arg){ws, t};
        if (pthread_create(&tid[t], NULL, worker_main, &args[t]))
            break; /* fewer workers: the same results, only slower */
        started = t;
    }
    args[0] = (worker_arg){ws, 0};
    worker_main(&args[0]);
    for (int t = 1; t <= started; t++)
        pthread_join(tid[t], NULL);
}
