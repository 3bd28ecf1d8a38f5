/*
 * imsynth search: the materials nearest an image, as a labelled contact sheet (pipeline.h,
 * "search"; the thesis's "material database").
 *
 * Two sources. A model's catalogue (predictor_nearest, by default Euclidean over the
 * model's PCA scores, as `evaluate`'s nearest rows); its samples keep no renders, so
 * each hit is rendered at the search preset. Or a dataset (every row, any size): the Gram
 * distance (evaluate_gram_distance) between the input's descriptor and each stored one,
 * streamed so memory stays one row, and the stored renders go on the sheet.
 * Either way a hit is a dataset id, and `imsynth export --seed ID` exports it (datagen's
 * parameters of id N are frame N's).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "pipeline/pipeline_internal.h"

#include <cblas.h> /* after our headers: its <complex.h> defines I */

typedef struct hit {
    long long id;
    int view;
    double distance;
    float *params;
    image img;
} hit;

static void hits_free(hit *h, int n)
{
    for (int i = 0; h && i < n; i++) {
        free(h[i].params);
        image_free(&h[i].img);
    }
    free(h);
}

/* The descriptor kind of a dataset's config, or DATAGEN_DESC_NONE when it is not a whole
 * MobileNetV2 or VGG19 descriptor (a masked one cannot be compared with a fresh one). */
static datagen_descriptor dataset_kind(const dataset_info *info)
{
    cJSON *c = cJSON_Parse(info->config_json ? info->config_json : "");
    const cJSON *d = cJSON_GetObjectItemCaseSensitive(c, "descriptor");
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(d, "features");
    int masked = cJSON_GetObjectItemCaseSensitive(d, "mask_sha256") != NULL;
    datagen_descriptor k = DATAGEN_DESC_NONE;
    if (cJSON_IsString(f) && !masked)
        k = pipeline_descriptor_kind_named(f->valuestring);
    cJSON_Delete(c);
    return k;
}

/* Inserts (id, view, distance) into the k best so far (ascending; ties keep the earlier). */
static void keep_best(hit *best, int *n, int k, long long id, int view, double d)
{
    if (*n == k && !(d < best[k - 1].distance))
        return;
    int at = *n < k ? (*n)++ : k - 1;
    while (at > 0 && best[at - 1].distance > d) {
        best[at] = best[at - 1];
        at--;
    }
    best[at] = (hit){.id = id, .view = view, .distance = d};
}

static int search_dataset(const search_options *o, const image *input, hit **out, int *n_out,
                          const char *const **names, int *n_params, dataset **dsp, char *err,
                          size_t errlen)
{
    dataset *ds = dataset_open(o->dataset_path, err, errlen);
    if (!ds)
        return -1;
    *dsp = ds;
    dataset_info info;
    if (dataset_get_info(ds, &info, err, errlen))
        return -1;
    datagen_descriptor kind = dataset_kind(&info);
    size_t dsize = info.descriptor_size;
    *n_params = info.n_params;
    dataset_info_free(&info);
    if (kind == DATAGEN_DESC_NONE || !dsize)
        return pipeline_error(err, errlen,
                              "%s: stores no whole MobileNetV2 or VGG19 descriptor to search by",
                              o->dataset_path);
    *names = dataset_param_names(ds);
    pipeline_descriptor *pd = pipeline_descriptor_create(kind, err, errlen);
    if (!pd)
        return -1;
    size_t offsets[65];
    int n_layers = pipeline_descriptor_layers(pd, offsets);
    float *q = malloc(dsize * sizeof *q);
    hit *best = calloc((size_t)o->k, sizeof *best);
    int rc = -1, n = 0;
    if (!q || !best) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    if (pipeline_descriptor_size(pd) != dsize) {
        pipeline_error(err, errlen, "%s: descriptors of %zu values; this build's has %zu",
                       o->dataset_path, dsize, pipeline_descriptor_size(pd));
        goto done;
    }
    if (pipeline_descriptor_compute(pd, input, q, err, errlen))
        goto done;
    /* Pass 1: distances, streamed. Pass 2: the hits' parameters and renders. */
    dataset_iter *it = dataset_iter_new(ds, 1, 0, err, errlen);
    if (!it)
        goto done;
    dataset_row row;
    int got;
    while ((got = dataset_iter_next(it, &row, err, errlen)) == 1)
        keep_best(best, &n, o->k, row.id, row.view,
                  evaluate_gram_distance(q, row.descriptor, offsets, n_layers));
    dataset_iter_free(it);
    if (got < 0)
        goto done;
    if (!(it = dataset_iter_new(ds, 0, 1, err, errlen)))
        goto done;
    int found = 0;
    while (found < n && (got = dataset_iter_next(it, &row, err, errlen)) == 1)
        for (int i = 0; i < n; i++)
            if (best[i].id == row.id && best[i].view == row.view && !best[i].params) {
                best[i].params = malloc((size_t)*n_params * sizeof(float));
                if (!best[i].params ||
                    (row.img.pixels && image_alloc(&best[i].img, row.img.width, row.img.height,
                                                   row.img.channels))) {
                    dataset_iter_free(it);
                    pipeline_error(err, errlen, "out of memory");
                    goto done;
                }
                if (row.img.pixels)
                    memcpy(best[i].img.pixels, row.img.pixels,
                           (size_t)row.img.width * (size_t)row.img.height *
                               (size_t)row.img.channels * sizeof(float));
                memcpy(best[i].params, row.params, (size_t)*n_params * sizeof(float));
                found++;
            }
    dataset_iter_free(it);
    if (got < 0)
        goto done;
    rc = 0;
done:
    free(q);
    pipeline_descriptor_free(pd);
    if (rc) {
        hits_free(best, n);
        return -1;
    }
    *out = best;
    *n_out = n;
    return 0;
}

static int search_catalogue(const search_options *o, const image *input, hit **out, int *n_out,
                            predictor **predp, char *err, size_t errlen)
{
    predictor *p = predictor_load(o->model_dir, err, errlen);
    if (!p)
        return -1;
    *predp = p;
    predictor_nearest_metric(p, o->nearest_metric);
    pipeline_descriptor *pd = pipeline_descriptor_create(predictor_descriptor_kind(p), err, errlen);
    if (!pd)
        return -1;
    float *q = malloc(predictor_descriptor_size(p) * sizeof *q);
    size_t *index = malloc((size_t)o->k * sizeof *index);
    double *dist = malloc((size_t)o->k * sizeof *dist);
    hit *best = calloc((size_t)o->k, sizeof *best);
    int rc = -1, n = 0, np = predictor_n_params(p);
    if (!q || !index || !dist || !best) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    if (pipeline_descriptor_compute(pd, input, q, err, errlen) ||
        (n = predictor_nearest(p, q, o->k, index, dist, err, errlen)) < 0) {
        n = 0;
        goto done;
    }
    for (int i = 0; i < n; i++) {
        const float *cp = predictor_catalogue_params(p, index[i], &best[i].id);
        best[i].distance = dist[i];
        if (!(best[i].params = malloc((size_t)np * sizeof(float)))) {
            pipeline_error(err, errlen, "out of memory");
            goto done;
        }
        memcpy(best[i].params, cp, (size_t)np * sizeof(float));
    }
    rc = 0;
done:
    free(q);
    free(index);
    free(dist);
    pipeline_descriptor_free(pd);
    if (rc) {
        hits_free(best, n);
        return -1;
    }
    *out = best;
    *n_out = n;
    return 0;
}

/* Renders the hits that have no image (catalogue hits) at the preset in the plain scene. */
static int render_hits(const search_options *o, hit *h, int n, int n_params, char *err,
                       size_t errlen)
{
    char graph_buf[4096], scene_buf[4096];
    const char *gp = o->graph_path, *sp = o->scene_path;
    if ((!gp && pipeline_find_data("assets/supershader.json", graph_buf, sizeof graph_buf, err,
                                   errlen)) ||
        (!sp && pipeline_find_data("assets/scene.json", scene_buf, sizeof scene_buf, err, errlen)))
        return -1;
    gp = gp ? gp : graph_buf;
    sp = sp ? sp : scene_buf;
    sg_graph *g = pipeline_load_graph(gp, NULL, -1, err, errlen);
    render_scene *scene = g ? render_scene_load(sp, err, errlen) : NULL;
    sg_params params = {0};
    char e[SG_ERROR_MAX] = "";
    int rc = -1;
    if (!scene)
        goto done;
    if (sg_params_from_graph(g, &params, e, sizeof e) < 0 || params.n != n_params) {
        pipeline_error(err, errlen, "%s: %s", gp,
                       params.n != n_params ? "not the model's parameters" : e);
        goto done;
    }
    for (int i = 0; i < n; i++) {
        if (h[i].img.pixels)
            continue;
        memcpy(params.values, h[i].params, (size_t)n_params * sizeof(float));
        if (sg_graph_bind_params(g, &params, e, sizeof e) < 0) {
            pipeline_error(err, errlen, "%s: %s", gp, e);
            goto done;
        }
        render_material *m = pipeline_render_material(g, gp, o->blender, err, errlen);
        if (!m)
            goto done;
        render_options ro;
        datagen_preset_render_options(o->preset, o->blender, &ro);
        ro.threads = o->threads;
        ro.seed = (uint64_t)h[i].id << 4; /* as datagen renders id's plain view */
        char msg[768];
        int r = render_image(scene, m, &ro, &h[i].img, NULL, msg, sizeof msg);
        render_material_free(m);
        if (r < 0) {
            pipeline_error(err, errlen, "render: %s", msg);
            goto done;
        }
    }
    rc = 0;
done:
    sg_params_free(&params);
    render_scene_free(scene);
    sg_graph_free(g);
    return rc;
}

int search_run(const search_options *o, char *err, size_t errlen)
{
    if (!o->image_path || !o->sheet_path || o->k < 1 || o->k > 1024 || !o->preset)
        return pipeline_error(err, errlen, "search: need an image, a sheet path and 1 <= k <= 1024");
    image raw = {0}, input = {0}, sheet = {0};
    hit *hits = NULL;
    int n = 0, n_params = 0, rc = -1;
    predictor *pred = NULL;
    dataset *ds = NULL;
    openblas_set_num_threads(1); /* as predict_run: descriptors independent of --threads */
    const char *const *names = NULL;
    cJSON *list = NULL;
    if (pipeline_read_user_image(o->image_path, &raw, err, errlen))
        return -1;
    if (pipeline_prepare_input(&raw, 256, &input, err, errlen))
        goto done;
    if (o->dataset_path) {
        if (search_dataset(o, &input, &hits, &n, &names, &n_params, &ds, err, errlen))
            goto done;
    } else {
        if (search_catalogue(o, &input, &hits, &n, &pred, err, errlen))
            goto done;
        names = predictor_param_names(pred);
        n_params = predictor_n_params(pred);
    }
    if (render_hits(o, hits, n, n_params, err, errlen))
        goto done;

    /* The sheet: the input, then the hits, nearest first, each labelled with its id and
     * distance. */
    int tile = o->tile > 0 ? o->tile : 160, cols = o->cols > 0 ? o->cols : 5;
    int cells = n + 1, rows = (cells + cols - 1) / cols;
    if (image_alloc(&sheet, cols * tile, rows * tile, 3)) {
        pipeline_error(err, errlen, "out of memory for the sheet");
        goto done;
    }
    memset(sheet.pixels, 0, (size_t)sheet.width * (size_t)sheet.height * 3 * sizeof(float));
    for (int c = 0; c < cells; c++) {
        int ox = (c % cols) * tile, oy = (c / cols) * tile;
        if (pipeline_sheet_paste(&sheet, c ? &hits[c - 1].img : &input, ox, oy, tile)) {
            pipeline_error(err, errlen, "out of memory");
            goto done;
        }
        char label[64];
        if (c)
            snprintf(label, sizeof label, "%lld d %.3f", hits[c - 1].id, hits[c - 1].distance);
        else
            snprintf(label, sizeof label, "input");
        pipeline_sheet_label(&sheet, ox + 2, oy + tile - 14, label, 2);
    }
    char tmp[4200], msg[768];
    snprintf(tmp, sizeof tmp, "%s.tmp.png", o->sheet_path);
    if (image_write_png(tmp, &sheet, msg, sizeof msg) || rename(tmp, o->sheet_path)) {
        pipeline_error(err, errlen, "%s: %s", o->sheet_path, msg[0] ? msg : "cannot rename");
        remove(tmp);
        goto done;
    }

    list = cJSON_CreateObject();
    cJSON_AddStringToObject(list, "image", o->image_path);
    cJSON_AddStringToObject(list, "source", o->dataset_path ? o->dataset_path : "catalogue");
    cJSON_AddStringToObject(list, "distance", o->dataset_path
                                                  ? "Gram distance of the dataset's descriptor"
                                                  : o->nearest_metric == PREDICTOR_METRIC_PCA
                                                        ? "Euclidean over the model's PCA scores"
                                                        : "Euclidean in the model's whitened PCA space");
    cJSON *a = cJSON_AddArrayToObject(list, "hits");
    for (int i = 0; i < n; i++) {
        cJSON *h = cJSON_CreateObject();
        cJSON_AddNumberToObject(h, "id", (double)hits[i].id);
        cJSON_AddNumberToObject(h, "view", hits[i].view);
        cJSON_AddNumberToObject(h, "distance", hits[i].distance);
        char cmd[128];
        snprintf(cmd, sizeof cmd, "imsynth export assets/supershader.json --seed %lld -o m.json",
                 hits[i].id);
        cJSON_AddStringToObject(h, "export", cmd);
        cJSON_AddItemToObject(h, "params", pipeline_params_json(names, hits[i].params, n_params));
        cJSON_AddItemToArray(a, h);
    }
    if (o->json_path && pipeline_write_json_atomic(o->json_path, list, err, errlen))
        goto done;
    for (int i = 0; i < n && o->print; i++)
        printf("%lld\t%d\t%.6f\n", hits[i].id, hits[i].view, hits[i].distance);
    rc = 0;
done:
    cJSON_Delete(list);
    hits_free(hits, n);
    image_free(&raw);
    image_free(&input);
    image_free(&sheet);
    predictor_free(pred);
    if (ds)
        dataset_close(ds);
    return rc;
}
