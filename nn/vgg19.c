/*
 * VGG19's convolutional part and its Gram descriptor.
 *
 * torchvision's `features` numbering, which the weight files use:
 *   block 1: convs 0, 2            pool 4      Gram after conv1_2 (features.2)
 *   block 2: convs 5, 7            pool 9      Gram after conv2_2 (features.7)
 *   block 3: convs 10, 12, 14, 16  pool 18     Gram after conv3_4 (features.16)
 *   block 4: convs 19, 21, 23, 25  pool 27     Gram after conv4_4 (features.25)
 *   block 5: convs 28, 30, 32, 34              Gram after conv5_4 (features.34)
 * Every conv is 3x3, stride 1, padding 1, followed by a ReLU. The last pool is skipped:
 * nothing after conv5_4 is used.
 */
#include <cblas.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nn/conv3x3.h"
#include "nn/nn.h"

const int vgg19_standard_width[5] = {64, 128, 256, 512, 512};

static const int convs_per_block[5] = {2, 2, 4, 4, 4};
static const int torch_index[VGG_CONV_LAYERS] = {0,  2,  5,  7,  10, 12, 14, 16,
                                                 19, 21, 23, 25, 28, 30, 32, 34};
/* The convs whose output a Gram is taken of, and after which a pool follows (but 15). */
static const int block_last_conv[5] = {1, 3, 7, 11, 15};

/* Cache budget per worker for one chunk's buffers: about half an L2 (2 MB here) so the
 * transformed inputs, the products and a slice of the weights stay resident. */
#define CONV_CHUNK_BUDGET ((size_t)1 << 20)

static void set_err(char *err, size_t errlen, const char *fmt, ...)
{
    if (!err || !errlen)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
}

int vgg_pool_parse(const char *s)
{
    if (!strcmp(s, "avg3"))
        return VGG_POOL_AVG3;
    if (!strcmp(s, "avg2"))
        return VGG_POOL_AVG2;
    if (!strcmp(s, "max2"))
        return VGG_POOL_MAX2;
    return -1;
}

int vgg_precision_parse(const char *s)
{
    if (!strcmp(s, "fp32"))
        return VGG_PRECISION_FP32;
    if (!strcmp(s, "fast"))
        return VGG_PRECISION_FAST;
    return -1;
}

/* ------------------------------------------------------------ weights ------------- */

static void set_widths(vgg19 *net, const int width[5])
{
    int l = 0, cin = 3;
    for (int b = 0; b < 5; b++) {
        net->width[b] = width[b];
        for (int i = 0; i < convs_per_block[b]; i++, l++) {
            net->cin[l] = cin;
            net->cout[l] = width[b];
            cin = width[b];
        }
    }
}

static int alloc_weights(vgg19 *net)
{
    for (int l = 0; l < VGG_CONV_LAYERS; l++) {
        net->weight[l] = malloc((size_t)net->cout[l] * net->cin[l] * 9 * sizeof(float));
        net->bias[l] = malloc((size_t)net->cout[l] * sizeof(float));
        if (!net->weight[l] || !net->bias[l])
            return -1;
    }
    return 0;
}

void vgg19_free(vgg19 *net)
{
    for (int l = 0; l < VGG_CONV_LAYERS; l++) {
        free(net->weight[l]);
        free(net->bias[l]);
        net->weight[l] = net->bias[l] = NULL;
    }
}

/* splitmix64's finaliser: a bijective 64-bit mix, so (seed, layer, index) -> bits is a
 * pure function and the weights do not depend on the order they are drawn in. */
static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* Two standard normals from a counter: Box-Muller on two 53-bit uniforms in (0,1]. */
static void normal_pair_at(uint64_t seed, uint64_t layer, uint64_t pair, double out[2])
{
    uint64_t a = mix64(seed ^ mix64(layer * 0x9e3779b97f4a7c15ull + 2 * pair + 1));
    uint64_t b = mix64(seed ^ mix64(layer * 0x9e3779b97f4a7c15ull + 2 * pair + 2));
    double u1 = ((a >> 11) + 1) * 0x1p-53, u2 = (b >> 11) * 0x1p-53;
    double r = sqrt(-2.0 * log(u1));
    out[0] = r * cos(6.283185307179586 * u2);
    out[1] = r * sin(6.283185307179586 * u2);
}

/*
 * Which random initialisation, and why it gives usable texture statistics:
 * He (Kaiming) normal, w ~ N(0, 2 / fan_in) with fan_in = 9 cin, and zero bias. With that
 * variance a ReLU layer keeps the second moment of its input (He et al. 2015), so for a
 * unit-variance image every one of the 16 layers sees activations of order 1 and the
 * five Gram matrices have comparable, non-degenerate scales, instead of shrinking or
 * growing geometrically with depth as a fixed-variance init would. Random filters of a
 * deep network with this scaling are known to carry enough texture statistics for Gatys'
 * texture synthesis (Ustyuzhaninov et al. 2017, "What does it take to generate natural
 * textures?"; He, Wang & Hopcroft 2016): Gram matrices of random multi-scale features
 * still separate textures by their local structure at each receptive-field size.
 */
int vgg19_init_random(vgg19 *net, const int width[5], uint64_t seed)
{
    memset(net, 0, sizeof *net);
    set_widths(net, width);
    if (alloc_weights(net)) {
        vgg19_free(net);
        return -1;
    }
    for (int l = 0; l < VGG_CONV_LAYERS; l++) {
        size_t n = (size_t)net->cout[l] * net->cin[l] * 9;
        double std = sqrt(2.0 / (9.0 * net->cin[l]));
        for (size_t i = 0; i < n; i += 2) { /* n = 9 cin cout is even: cout is */
            double z[2];
            normal_pair_at(seed, (uint64_t)l, i / 2, z);
            net->weight[l][i] = (float)(std * z[0]);
            if (i + 1 < n)
                net->weight[l][i + 1] = (float)(std * z[1]);
        }
        memset(net->bias[l], 0, (size_t)net->cout[l] * sizeof(float));
    }
    return 0;
}

int vgg19_load(vgg19 *net, const char *path, char *err, size_t errlen)
{
    memset(net, 0, sizeof *net);
    nn_safetensors st;
    if (nn_safetensors_open(path, &st, err, errlen))
        return -1;
    /* Widths from the last conv of each block's weight shape (cout, cin, 3, 3). */
    int width[5];
    for (int b = 0; b < 5; b++) {
        char name[64];
        snprintf(name, sizeof name, "features.%d.weight", torch_index[block_last_conv[b]]);
        int i = nn_safetensors_find(&st, name);
        if (i < 0) {
            set_err(err, errlen, "%s: no tensor \"%s\" (torchvision VGG19 key names expected)",
                    path, name);
            nn_safetensors_close(&st);
            return -1;
        }
        if (st.tensors[i].ndim != 4 || st.tensors[i].shape[0] < 1 ||
            st.tensors[i].shape[0] > 4096) {
            set_err(err, errlen, "%s: tensor \"%s\" is not a (cout, cin, 3, 3) conv weight",
                    path, name);
            nn_safetensors_close(&st);
            return -1;
        }
        width[b] = (int)st.tensors[i].shape[0];
    }
    set_widths(net, width);
    if (alloc_weights(net)) {
        set_err(err, errlen, "%s: out of memory", path);
        goto fail;
    }
    for (int l = 0; l < VGG_CONV_LAYERS; l++) {
        char name[64];
        int64_t wshape[4] = {net->cout[l], net->cin[l], 3, 3}, bshape[1] = {net->cout[l]};
        snprintf(name, sizeof name, "features.%d.weight", torch_index[l]);
        if (nn_safetensors_read_f32(&st, name, 4, wshape, net->weight[l], err, errlen))
            goto fail;
        snprintf(name, sizeof name, "features.%d.bias", torch_index[l]);
        if (nn_safetensors_read_f32(&st, name, 1, bshape, net->bias[l], err, errlen))
            goto fail;
        size_t n = (size_t)net->cout[l] * net->cin[l] * 9;
        for (size_t i = 0; i < n; i++)
            if (!isfinite(net->weight[l][i])) {
                set_err(err, errlen, "%s: tensor \"features.%d.weight\" has a non-finite value "
                        "at flat index %zu", path, torch_index[l], i);
                goto fail;
            }
    }
    nn_safetensors_close(&st);
    return 0;
fail:
    nn_safetensors_close(&st);
    vgg19_free(net);
    return -1;
}

size_t vgg19_descriptor_size(const vgg19 *net)
{
    size_t off[VGG_GRAM_LAYERS + 1];
    vgg19_descriptor_offsets(net, off);
    return off[VGG_GRAM_LAYERS];
}

void vgg19_descriptor_offsets(const vgg19 *net, size_t offsets[VGG_GRAM_LAYERS + 1])
{
    offsets[0] = 0;
    for (int b = 0; b < 5; b++)
        offsets[b + 1] = offsets[b] + (size_t)net->width[b] * (net->width[b] + 1) / 2;
}

/* ------------------------------------------------------------ preprocessing ------- */

int vgg_preprocess(float *out, const float *pixels, int width, int height, int channels)
{
    static const float mean[3] = {0.485f, 0.456f, 0.406f}, std[3] = {0.229f, 0.224f, 0.225f};
    if (width < VGG_INPUT_SIZE || height < VGG_INPUT_SIZE || channels < 1 || channels > 4)
        return -1;
    int y0 = (height - VGG_INPUT_SIZE) / 2, x0 = (width - VGG_INPUT_SIZE) / 2;
    for (int c = 0; c < 3; c++) {
        /* Grey (1) and grey+alpha (2) replicate their first channel; alpha is dropped. */
        int src_c = channels >= 3 ? c : 0;
        for (int y = 0; y < VGG_INPUT_SIZE; y++)
            for (int x = 0; x < VGG_INPUT_SIZE; x++) {
                float v = pixels[((size_t)(y0 + y) * width + x0 + x) * channels + src_c];
                v = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; /* also maps NaN to 0 */
                out[((size_t)c * VGG_INPUT_SIZE + y) * VGG_INPUT_SIZE + x] =
                    (v - mean[c]) / std[c];
            }
    }
    return 0;
}

/* ------------------------------------------------------------ workspace ----------- */

/* Work is handed to the pool as a job: a function over chunk indices 0..count-1. A chunk
 * always computes the same thing in the same order, whichever worker takes it, so the
 * results do not depend on the thread count. */
typedef void (*job_fn)(const void *ctx, size_t chunk, float *scratch);

struct vgg_workspace {
    const vgg19 *net;
    vgg_options opt;
    int max_batch;
    float *act[2];                  /* ping-pong activations, max_batch * largest layer */
    float *U[VGG_CONV_LAYERS];      /* Winograd weights, or NULL for im2col layers */
    uint32_t *Ub[VGG_CONV_LAYERS];  /* fast path: U as bf16 pairs, or NULL */
    int amx;                        /* fast path on AMX tiles */
    int winograd[VGG_CONV_LAYERS];
    int chunk[VGG_CONV_LAYERS];
    float *gram_partial;            /* per-slice partial Grams of the largest tap */
    int threads;
    float **scratch;                /* per thread */
    size_t bytes;
    /* worker pool: the caller is worker 0 */
    pthread_t *tid;
    pthread_barrier_t start, done;
    job_fn job;
    const void *job_ctx;
    atomic_size_t next_chunk;
    size_t job_chunks;
    int quit;
};

/* Spatial size of conv layer l's input for the pooling mode. */
static int layer_size(vgg_pool pool, int l)
{
    int s = VGG_INPUT_SIZE;
    for (int b = 0; b < 5; b++) {
        if (l <= block_last_conv[b])
            return s;
        s = pool == VGG_POOL_AVG3 ? (s - 3) / 3 + 1 : (s - 2) / 2 + 1;
    }
    return s;
}

static void run_chunks(vgg_workspace *ws, int worker)
{
    for (;;) {
        size_t c = atomic_fetch_add(&ws->next_chunk, 1);
        if (c >= ws->job_chunks)
            break;
        ws->job(ws->job_ctx, c, ws->scratch[worker]);
    }
}

static void run_job(vgg_workspace *ws, job_fn fn, const void *ctx, size_t chunks)
{
    ws->job = fn;
    ws->job_ctx = ctx;
    ws->job_chunks = chunks;
    atomic_store(&ws->next_chunk, 0);
    if (ws->threads > 1) {
        pthread_barrier_wait(&ws->start);
        run_chunks(ws, 0);
        pthread_barrier_wait(&ws->done);
    } else {
        run_chunks(ws, 0);
    }
}

typedef struct worker_arg {
    vgg_workspace *ws;
    int index;
} worker_arg;

static void *worker_main(void *p)
{
    vgg_workspace *ws = ((worker_arg *)p)->ws;
    int index = ((worker_arg *)p)->index;
    free(p);
    for (;;) {
        pthread_barrier_wait(&ws->start);
        if (ws->quit)
            break;
        run_chunks(ws, index);
        pthread_barrier_wait(&ws->done);
    }
    return NULL;
}

/* ---- jobs ---- */

static void conv_job(const void *ctx, size_t chunk, float *scratch)
{
    conv_run_chunk(ctx, chunk, scratch);
}

/* Gram of each image's (K, HW) features, split along HW into slices of GRAM_SLICE
 * columns: chunk (image, slice) writes the slice's partial F F^T (upper part) into
 * partial[image][slice]; gram_finish_job then adds the slices in slice order. */
#define GRAM_SLICE_FLOATS ((size_t)1 << 18) /* 1 MB of features per slice */

typedef struct gram_ctx {
    const float *y; /* (n, K, HW) */
    int n, K, HW, slice, slices;
    float *partial; /* (n, slices, K, K) */
    float *out;     /* descriptor rows */
    size_t row, offset;
} gram_ctx;

static void gram_slice_job(const void *ctx, size_t chunk, float *scratch)
{
    (void)scratch; /* a job_fn; this job needs no scratch */
    const gram_ctx *g = ctx;
    size_t i = chunk / g->slices, s = chunk % g->slices;
    int c0 = (int)s * g->slice, len = g->HW - c0 < g->slice ? g->HW - c0 : g->slice;
    const float *f = g->y + i * g->K * g->HW + c0;
    cblas_ssyrk(CblasRowMajor, CblasUpper, CblasNoTrans, g->K, len, 1.0f, f, g->HW, 0.0f,
                g->partial + (i * g->slices + s) * g->K * g->K, g->K);
}

/* Chunk = (image, row of G): sum the slices' row in order, scale, write the upper part. */
static void gram_finish_job(const void *ctx, size_t chunk, float *scratch)
{
    (void)scratch; /* a job_fn; this job needs no scratch */
    const gram_ctx *g = ctx;
    size_t i = chunk / g->K;
    int r = (int)(chunk % g->K);
    const size_t kk = (size_t)g->K * g->K;
    const float *p = g->partial + i * g->slices * kk + (size_t)r * g->K;
    /* Row r's upper part starts after rows 0..r-1, which hold K + (K-1) + ... entries. */
    float *o = g->out + i * g->row + g->offset + (size_t)r * g->K - (size_t)r * (r - 1) / 2;
    const float inv = 1.0f / (float)g->HW;
    for (int c = r; c < g->K; c++) {
        float sum = p[c];
        for (int s = 1; s < g->slices; s++)
            sum += p[s * kk + c];
        o[c - r] = sum * inv;
    }
}

typedef struct pool_ctx {
    float *out;
    const float *in;
    int H, W, planes_per_chunk;
    size_t planes;
    vgg_pool pool;
    int relu_input; /* the input still needs its ReLU (the Gram was taken before it) */
} pool_ctx;

static void pool_job(const void *ctx, size_t chunk, float *scratch)
{
    const pool_ctx *p = ctx;
    size_t first = chunk * p->planes_per_chunk;
    int count = (int)(p->planes - first < (size_t)p->planes_per_chunk ? p->planes - first
                                                                       : (size_t)p->planes_per_chunk);
    int k = p->pool == VGG_POOL_AVG3 ? 3 : 2;
    int OH = (p->H - k) / k + 1, OW = (p->W - k) / k + 1;
    const float *in = p->in + first * p->H * p->W;
    float *out = p->out + first * OH * OW;
    /* ReLU commutes with max, not with averaging: for avg, rectify into scratch first. */
    if (p->relu_input && p->pool != VGG_POOL_MAX2) {
        size_t n = (size_t)count * p->H * p->W;
        memcpy(scratch, in, n * sizeof(float));
        relu_forward(scratch, n);
        in = scratch;
    }
    if (p->pool == VGG_POOL_MAX2) {
        maxpool_forward(out, in, 1, count, p->H, p->W, 2, 2);
        if (p->relu_input)
            relu_forward(out, (size_t)count * OH * OW);
    } else {
        avgpool_forward(out, in, 1, count, p->H, p->W, k, k);
    }
}

/* Layers whose input is thin (conv1_1: 3 channels) or whose plane is tiny go through
 * im2col; the rest through Winograd. */
static int use_winograd(int cin, int size)
{
    return cin >= 16 && size >= 4;
}

static int gram_slice(int K, int HW)
{
    size_t s = GRAM_SLICE_FLOATS / (size_t)K;
    return s >= (size_t)HW ? HW : (int)s;
}

vgg_workspace *vgg_workspace_create(const vgg19 *net, const vgg_options *opt, int max_batch)
{
    vgg_workspace *ws = calloc(1, sizeof *ws);
    if (!ws)
        return NULL;
    ws->net = net;
    ws->opt = *opt;
    ws->max_batch = max_batch < 1 ? 1 : max_batch;
    ws->threads = opt->threads < 1 ? 1 : opt->threads;
    ws->amx = opt->precision == VGG_PRECISION_FAST && conv_enable_amx();
    size_t largest = (size_t)3 * VGG_INPUT_SIZE * VGG_INPUT_SIZE, scratch_floats = 0,
           partial = 0;
    for (int l = 0; l < VGG_CONV_LAYERS; l++) {
        int s = layer_size(opt->pool, l), C = net->cin[l], K = net->cout[l];
        size_t a = (size_t)K * s * s;
        largest = a > largest ? a : largest;
        ws->winograd[l] = use_winograd(C, s);
        ws->chunk[l] = conv_chunk_size(ws->winograd[l], C, K, s, CONV_CHUNK_BUDGET);
        size_t sf = conv_scratch_floats(ws->winograd[l], C, K, s, ws->chunk[l]);
        scratch_floats = sf > scratch_floats ? sf : scratch_floats;
        /* A pool chunk rectifies its 8 planes into scratch (see pool_job). */
        sf = (size_t)s * s * 8;
        scratch_floats = sf > scratch_floats ? sf : scratch_floats;
        int slice = gram_slice(K, s * s), slices = (s * s + slice - 1) / slice;
        size_t pf = (size_t)ws->max_batch * slices * K * K;
        partial = pf > partial ? pf : partial;
        if (ws->winograd[l]) {
            ws->U[l] = malloc(16 * (size_t)K * C * sizeof(float));
            if (!ws->U[l])
                goto fail;
            winograd_weights(ws->U[l], net->weight[l], K, C);
            ws->bytes += 16 * (size_t)K * C * sizeof(float);
            if (opt->precision == VGG_PRECISION_FAST && conv_have_bf16() && C % 2 == 0) {
                ws->Ub[l] = malloc(16 * (size_t)K * (C / 2) * sizeof(uint32_t));
                if (!ws->Ub[l])
                    goto fail;
                winograd_weights_bf16(ws->Ub[l], ws->U[l], K, C);
                ws->bytes += 16 * (size_t)K * (C / 2) * sizeof(uint32_t);
            }
        }
    }
    for (int i = 0; i < 2; i++) {
        ws->act[i] = malloc((size_t)ws->max_batch * largest * sizeof(float));
        if (!ws->act[i])
            goto fail;
    }
    ws->gram_partial = malloc(partial * sizeof(float));
    ws->scratch = calloc((size_t)ws->threads, sizeof *ws->scratch);
    if (!ws->gram_partial || !ws->scratch)
        goto fail;
    for (int t = 0; t < ws->threads; t++)
        if (!(ws->scratch[t] = malloc(scratch_floats * sizeof(float))))
            goto fail;
    ws->bytes += 2 * (size_t)ws->max_batch * largest * sizeof(float) + partial * sizeof(float) +
                 (size_t)ws->threads * scratch_floats * sizeof(float);
    if (ws->threads > 1) {
        ws->tid = calloc((size_t)ws->threads, sizeof *ws->tid);
        if (!ws->tid)
            goto fail;
        pthread_barrier_init(&ws->start, NULL, (unsigned)ws->threads);
        pthread_barrier_init(&ws->done, NULL, (unsigned)ws->threads);
        for (int t = 1; t < ws->threads; t++) {
            worker_arg *a = malloc(sizeof *a);
            if (!a)
                abort(); /* a few bytes at setup: nothing sensible to fall back to */
            a->ws = ws;
            a->index = t;
            if (pthread_create(&ws->tid[t], NULL, worker_main, a))
                abort();
        }
    }
    return ws;
fail:
    vgg_workspace_free(ws);
    return NULL;
}

void vgg_workspace_free(vgg_workspace *ws)
{
    if (!ws)
        return;
    if (ws->tid) {
        ws->quit = 1;
        pthread_barrier_wait(&ws->start);
        for (int t = 1; t < ws->threads; t++)
            pthread_join(ws->tid[t], NULL);
        pthread_barrier_destroy(&ws->start);
        pthread_barrier_destroy(&ws->done);
        free(ws->tid);
    }
    for (int l = 0; l < VGG_CONV_LAYERS; l++) {
        free(ws->U[l]);
        free(ws->Ub[l]);
    }
    free(ws->act[0]);
    free(ws->act[1]);
    free(ws->gram_partial);
    if (ws->scratch)
        for (int t = 0; t < ws->threads; t++)
            free(ws->scratch[t]);
    free(ws->scratch);
    free(ws);
}

size_t vgg_workspace_bytes(const vgg_workspace *ws)
{
    return ws->bytes;
}

/*
 * One pass: conv (+ ReLU fused into its output unless a pre-ReLU Gram must see the raw
 * values), Gram at the taps, pooling (+ the deferred ReLU) between blocks. After conv5_4
 * nothing is needed but its Gram.
 */
void vgg_describe(vgg_workspace *ws, const float *in, int n, float *out)
{
    const vgg19 *net = ws->net;
    const size_t row = vgg19_descriptor_size(net);
    size_t offsets[VGG_GRAM_LAYERS + 1];
    vgg19_descriptor_offsets(net, offsets);
    const float *x = in; /* current activations (n, C, s, s) */
    int cur = 0;         /* which ping-pong buffer the next output goes to */
    int s = VGG_INPUT_SIZE, block = 0;
    for (int l = 0; l < VGG_CONV_LAYERS; l++) {
        const int C = net->cin[l], K = net->cout[l];
        const int tap = l == block_last_conv[block];
        float *y = ws->act[cur];
        conv_layer L = {.in = x, .out = y, .N = n, .C = C, .K = K, .H = s, .W = s,
                        .winograd = ws->winograd[l], .U = ws->U[l], .Ub = ws->Ub[l],
                        .amx = ws->amx,
                        .weight = net->weight[l],
                        .bias = net->bias[l], .relu = !tap || ws->opt.post_relu,
                        .chunk = ws->chunk[l]};
        /* Too few chunks to keep every thread busy (deep layers, small batches): split
         * the output channels too. The results do not change (conv_layer.kblocks). */
        L.kblocks = 1;
        size_t chunks = conv_chunk_count(&L);
        while (ws->threads > 1 && chunks * L.kblocks < 2 * (size_t)ws->threads &&
               K % (64 * L.kblocks) == 0)
            L.kblocks *= 2;
        run_job(ws, conv_job, &L, conv_chunk_count(&L));
        if (!tap) {
            x = y;
            cur ^= 1;
            continue;
        }
        gram_ctx g = {.y = y, .n = n, .K = K, .HW = s * s, .slice = gram_slice(K, s * s),
                      .partial = ws->gram_partial, .out = out, .row = row,
                      .offset = offsets[block]};
        g.slices = (g.HW + g.slice - 1) / g.slice;
        run_job(ws, gram_slice_job, &g, (size_t)n * g.slices);
        run_job(ws, gram_finish_job, &g, (size_t)n * K);
        if (block < 4) {
            float *z = ws->act[cur ^ 1];
            pool_ctx p = {.out = z, .in = y, .H = s, .W = s, .planes_per_chunk = 8,
                          .planes = (size_t)n * K, .pool = ws->opt.pool,
                          .relu_input = !ws->opt.post_relu};
            run_job(ws, pool_job, &p, (p.planes + 7) / 8);
            s = layer_size(ws->opt.pool, l + 1);
            x = z; /* in buffer cur^1; the next conv writes to buffer cur */
        }
        block++;
    }
}
