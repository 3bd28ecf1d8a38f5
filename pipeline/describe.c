/* The dataset's descriptor: VGG19 Gram values (random weights, seed 1, avg3, fp32) or
 * MobileNetV2's (default taps, one scale, [0,1] input), optionally restricted to a feature
 * mask, stored as float16. One definition for datagen and `dataset describe`, so that both
 * store the same bytes for the same image. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline/store.h"

int descriptor_config_init(descriptor_config *dc, int kind, const char *mask_path, char *err,
                           size_t errlen)
{
    memset(dc, 0, sizeof *dc);
    dc->mobilenet = kind == DATAGEN_DESC_MOBILENETV2_F16;
    if (dc->mobilenet) {
        char path[1024], msg[768];
        if (pipeline_find_data("assets/mobilenetv2/mobilenetv2_block10.safetensors", path,
                               sizeof path, err, errlen))
            return -1;
        size_t len;
        char *bytes = pipeline_read_file(path, &len, err, errlen);
        if (!bytes)
            return -1;
        pipeline_sha256_hex(bytes, len, dc->weights_hash);
        free(bytes);
        if (mnv2_load(&dc->mnv2, path, msg, sizeof msg))
            return pipeline_error(err, errlen, "%s", msg);
        dc->mnv2_opt.ntaps = mnv2_taps_parse(mnv2_default_taps, dc->mnv2_opt.taps, msg, sizeof msg);
        dc->mnv2_opt.scales = 1;
        dc->mnv2_opt.threads = 1;
        size_t off[2 * MNV2_MAX_TAPS + 1];
        dc->full_size = mnv2_descriptor_offsets(&dc->mnv2, &dc->mnv2_opt, off);
    } else {
        if (vgg19_init_random(&dc->net, vgg19_standard_width, 1))
            return pipeline_error(err, errlen, "out of memory for VGG19");
        dc->vgg = (vgg_options){.pool = VGG_POOL_AVG3, .precision = VGG_PRECISION_FP32,
                                .threads = 1};
        dc->full_size = vgg19_descriptor_size(&dc->net);
    }
    dc->n_stored = dc->full_size;
    if (!mask_path)
        return 0;
    float *m = NULL;
    size_t r, c;
    char msg[768];
    if (nn_npy_read_f32(mask_path, &m, &r, &c, msg, sizeof msg)) {
        descriptor_config_free(dc);
        return pipeline_error(err, errlen, "--descriptor-mask: %s", msg);
    }
    size_t n = r * c;
    dc->index = malloc((n ? n : 1) * sizeof *dc->index);
    int bad = !dc->index;
    size_t k = 0;
    if (!bad && n == dc->full_size) { /* a 0/1 mask over every feature */
        for (size_t i = 0; i < n && !bad; i++) {
            if (m[i] != 0.0f && m[i] != 1.0f)
                bad = pipeline_error(err, errlen, "%s: mask value %g at %zu is not 0 or 1",
                                     mask_path, (double)m[i], i);
            else if (m[i] == 1.0f)
                dc->index[k++] = (uint32_t)i;
        }
    } else if (!bad) { /* a list of feature indices, ascending */
        for (size_t i = 0; i < n && !bad; i++) {
            float v = m[i];
            if (!(v >= 0.0f) || v >= (float)dc->full_size || v != floorf(v) ||
                (k && (uint32_t)v <= dc->index[k - 1]))
                bad = pipeline_error(err, errlen,
                                     "%s: entry %zu (%g) is not a feature index below %zu in "
                                     "ascending order",
                                     mask_path, i, (double)v, dc->full_size);
            else
                dc->index[k++] = (uint32_t)v;
        }
    }
    if (!bad && k == 0)
        bad = pipeline_error(err, errlen, "%s: selects no feature", mask_path);
    free(m);
    if (bad) {
        descriptor_config_free(dc);
        return -1;
    }
    dc->n_stored = k;
    /* The selection's identity for the config: a hash of the indices. */
    pipeline_sha256_hex(dc->index, k * sizeof *dc->index, dc->mask_hash);
    return 0;
}

void descriptor_config_free(descriptor_config *dc)
{
    if (dc->full_size && dc->mobilenet)
        mnv2_free(&dc->mnv2);
    else if (dc->full_size)
        vgg19_free(&dc->net);
    free(dc->index);
    memset(dc, 0, sizeof *dc);
}

void descriptor_config_json(const descriptor_config *dc, cJSON *d)
{
    if (dc->mobilenet) {
        cJSON_AddStringToObject(d, "features", "mobilenetv2");
        cJSON_AddStringToObject(d, "weights_sha256", dc->weights_hash);
        cJSON_AddStringToObject(d, "taps", mnv2_default_taps);
        cJSON_AddNumberToObject(d, "scales", 1);
        cJSON_AddStringToObject(d, "input", "srgb [0,1]");
        cJSON_AddStringToObject(d, "storage", "float16");
        cJSON_AddNumberToObject(d, "size", (double)dc->n_stored);
        if (dc->index)
            cJSON_AddStringToObject(d, "mask_sha256", dc->mask_hash);
        return;
    }
    cJSON_AddStringToObject(d, "features", "vgg19");
    cJSON_AddStringToObject(d, "weights", "random he-normal, seed 1");
    cJSON_AddStringToObject(d, "pool", "avg3");
    cJSON_AddStringToObject(d, "precision", "fp32");
    cJSON_AddStringToObject(d, "storage", "float16");
    cJSON_AddNumberToObject(d, "size", (double)dc->n_stored);
    if (dc->index)
        cJSON_AddStringToObject(d, "mask_sha256", dc->mask_hash);
}

int descriptor_worker_init(descriptor_worker *dw, const descriptor_config *dc)
{
    memset(dw, 0, sizeof *dw);
    if (dc->mobilenet)
        dw->mws = mnv2_workspace_create(&dc->mnv2, &dc->mnv2_opt, MNV2_INPUT_SIZE, 1);
    else
        dw->ws = vgg_workspace_create(&dc->net, &dc->vgg, 1);
    dw->in = malloc(3 * VGG_INPUT_SIZE * VGG_INPUT_SIZE * sizeof(float));
    dw->full = malloc(dc->full_size * sizeof(float));
    return (dw->ws || dw->mws) && dw->in && dw->full ? 0 : -1;
}

void descriptor_worker_free(descriptor_worker *dw)
{
    vgg_workspace_free(dw->ws);
    mnv2_workspace_free(dw->mws);
    free(dw->in);
    free(dw->full);
    memset(dw, 0, sizeof *dw);
}

uint16_t *descriptor_compute_f16(const descriptor_config *dc, descriptor_worker *dw,
                                 const image *img)
{
    if (dc->mobilenet) {
        if (mnv2_preprocess(dw->in, img->pixels, img->width, img->height, img->channels))
            return NULL;
        mnv2_describe(dw->mws, dw->in, 1, dw->full);
    } else {
        if (vgg_preprocess(dw->in, img->pixels, img->width, img->height, img->channels))
            return NULL;
        vgg_describe(dw->ws, dw->in, 1, dw->full);
    }
    uint16_t *out = malloc(dc->n_stored * sizeof *out);
    if (!out)
        return NULL;
    for (size_t i = 0; i < dc->n_stored; i++)
        out[i] = nn_float_to_half(dw->full[dc->index ? dc->index[i] : i]);
    return out;
}

/* ---------------------------------------------------------------- public handle ---- */

struct pipeline_descriptor {
    descriptor_config dc;
    descriptor_worker dw;
};

datagen_descriptor pipeline_descriptor_kind_named(const char *features)
{
    return !features                         ? DATAGEN_DESC_NONE
           : !strcmp(features, "mobilenetv2") ? DATAGEN_DESC_MOBILENETV2_F16
           : !strcmp(features, "vgg19")       ? DATAGEN_DESC_VGG19_F16
                                              : DATAGEN_DESC_NONE;
}

pipeline_descriptor *pipeline_descriptor_create(datagen_descriptor kind, char *err,
                                                size_t errlen)
{
    if (kind != DATAGEN_DESC_VGG19_F16 && kind != DATAGEN_DESC_MOBILENETV2_F16) {
        pipeline_error(err, errlen, "no such descriptor (%d)", (int)kind);
        return NULL;
    }
    pipeline_descriptor *d = calloc(1, sizeof *d);
    if (!d) {
        pipeline_error(err, errlen, "out of memory");
        return NULL;
    }
    if (descriptor_config_init(&d->dc, kind, NULL, err, errlen)) {
        free(d);
        return NULL;
    }
    if (descriptor_worker_init(&d->dw, &d->dc)) {
        pipeline_descriptor_free(d);
        pipeline_error(err, errlen, "out of memory for the descriptor's workspace");
        return NULL;
    }
    return d;
}

void pipeline_descriptor_free(pipeline_descriptor *d)
{
    if (!d)
        return;
    descriptor_worker_free(&d->dw);
    descriptor_config_free(&d->dc);
    free(d);
}

size_t pipeline_descriptor_size(const pipeline_descriptor *d) { return d->dc.full_size; }

int pipeline_descriptor_layers(const pipeline_descriptor *d, size_t offsets[64])
{
    if (d->dc.mobilenet) {
        size_t off[2 * MNV2_MAX_TAPS + 1];
        mnv2_descriptor_offsets(&d->dc.mnv2, &d->dc.mnv2_opt, off);
        int n = d->dc.mnv2_opt.scales * d->dc.mnv2_opt.ntaps;
        for (int i = 0; i <= n; i++)
            offsets[i] = off[i];
        return n;
    }
    vgg19_descriptor_offsets(&d->dc.net, offsets);
    return VGG_GRAM_LAYERS;
}

int pipeline_descriptor_compute(pipeline_descriptor *d, const image *img, float *out,
                                char *err, size_t errlen)
{
    uint16_t *h = descriptor_compute_f16(&d->dc, &d->dw, img);
    if (!h)
        return pipeline_error(err, errlen, "image of %d x %d: the descriptor needs at least "
                                           "224 x 224 (or out of memory)",
                              img->width, img->height);
    for (size_t i = 0; i < d->dc.n_stored; i++)
        out[i] = nn_half_to_float(h[i]);
    free(h);
    return 0;
}

_Static_assert(PIPELINE_TEXSTATS_N == TEXSTATS_N, "pipeline.h's count of texture statistics");

int pipeline_texstats(const image *img, float *out, char *err, size_t errlen)
{
    const int side = PIPELINE_CROP; /* the descriptors' crop (mnv2_preprocess, vgg_preprocess) */
    size_t n = (size_t)side * side;
    float *chw = malloc(3 * n * sizeof *chw), *hwc = malloc(3 * n * sizeof *hwc);
    int rc = -1;
    if (!chw || !hwc)
        pipeline_error(err, errlen, "out of memory");
    else if (mnv2_preprocess(chw, img->pixels, img->width, img->height, img->channels))
        pipeline_error(err, errlen, "image of %d x %d: texture statistics need at least "
                                    "224 x 224",
                       img->width, img->height);
    else {
        // the crop, clamped to [0, 1], sRGB-encoded: a perceptual scale, so that the
        // statistics of dark materials are not crowded near 0
        for (size_t p = 0; p < n; p++)
            for (int c = 0; c < 3; c++)
                hwc[3 * p + (size_t)c] = linear_to_srgb(chw[(size_t)c * n + p]);
        if (texstats_forward(out, hwc, side, side))
            pipeline_error(err, errlen, "out of memory");
        else
            rc = 0;
    }
    free(chw);
    free(hwc);
    return rc;
}
