/* The dataset's descriptor: VGG19 Gram values (random weights, seed 1, avg3, fp32),
 * optionally restricted to a feature mask, stored as float16. One definition for datagen
 * and `dataset describe`, so that both store the same bytes for the same image. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline/store.h"

int descriptor_config_init(descriptor_config *dc, const char *mask_path, char *err,
                           size_t errlen)
{
    memset(dc, 0, sizeof *dc);
    if (vgg19_init_random(&dc->net, vgg19_standard_width, 1))
        return pipeline_error(err, errlen, "out of memory for VGG19");
    dc->vgg = (vgg_options){.pool = VGG_POOL_AVG3, .precision = VGG_PRECISION_FP32, .threads = 1};
    dc->full_size = vgg19_descriptor_size(&dc->net);
    dc->n_stored = dc->full_size;
    if (!mask_path)
        return 0;
    float *m = NULL;
    size_t r, c;
    char msg[768];
    if (nn_npy_read_f32(mask_path, &m, &r, &c, msg, sizeof msg)) {
        vgg19_free(&dc->net);
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
    if (dc->full_size)
        vgg19_free(&dc->net);
    free(dc->index);
    memset(dc, 0, sizeof *dc);
}

void descriptor_config_json(const descriptor_config *dc, cJSON *d)
{
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
    dw->ws = vgg_workspace_create(&dc->net, &dc->vgg, 1);
    dw->in = malloc(3 * VGG_INPUT_SIZE * VGG_INPUT_SIZE * sizeof(float));
    dw->full = malloc(dc->full_size * sizeof(float));
    return dw->ws && dw->in && dw->full ? 0 : -1;
}

void descriptor_worker_free(descriptor_worker *dw)
{
    vgg_workspace_free(dw->ws);
    free(dw->in);
    free(dw->full);
    memset(dw, 0, sizeof *dw);
}

uint16_t *descriptor_compute_f16(const descriptor_config *dc, descriptor_worker *dw,
                                 const image *img)
{
    if (vgg_preprocess(dw->in, img->pixels, img->width, img->height, img->channels))
        return NULL;
    vgg_describe(dw->ws, dw->in, 1, dw->full);
    uint16_t *out = malloc(dc->n_stored * sizeof *out);
    if (!out)
        return NULL;
    for (size_t i = 0; i < dc->n_stored; i++)
        out[i] = nn_float_to_half(dw->full[dc->index ? dc->index[i] : i]);
    return out;
}
