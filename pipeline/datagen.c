/*
 * datagen: sample -> extract (active mask) -> render -> describe -> store, for every id of a
 * range and shard that the dataset lacks.
 *
 * A sample is a pure function of (id, config). Workers each make whole samples (their own
 * graph copy, evaluator and descriptor workspace, one render thread each), so the thread
 * count decides only which worker makes an id, never its bytes. The main thread stores a
 * batch of finished samples in one transaction, in id order.
 */
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "nn/nn.h"
#include "pipeline/store.h"
/* Last: OpenBLAS's config defines a macro I (complex.h), which would rename
 * sg_geometry_batch's field I in shadergraph.h. */
#include <cblas.h>

const char *const datagen_stage_names[5] = {"sample", "extract", "render", "describe", "store"};

/* ---------------------------------------------------------------- presets ---------- */

/* Chosen by measurement (BENCHMARKS.md, "Datagen preset"): the descriptor of a "datagen"
 * render is as close to the converged Cycles reference as Cycles' own 252-sample render's. */
static const datagen_preset presets[] = {
    {"draft", 1, 0, 4, 0.03f},
    {"datagen", 4, 0, 4, 0.03f},
    {"converged", 4, 256, 4, 0.03f},
};

const datagen_preset *datagen_preset_find(const char *name)
{
    for (size_t i = 0; i < sizeof presets / sizeof presets[0]; i++)
        if (!strcmp(presets[i].name, name))
            return &presets[i];
    return NULL;
}

const char *datagen_preset_names(void) { return "draft, datagen, converged"; }

void datagen_preset_render_options(const datagen_preset *p, sg_blender_mode blender, render_options *ro)
{
    render_options_default(ro);
    ro->mode = RENDER_FAST;
    ro->spp = p->spp;
    ro->max_spp = p->max_spp;
    ro->light_samples = p->light_samples;
    ro->noise_target = p->noise_target;
    ro->blender = blender;
}

void pipeline_render_crop_only(render_options *ro, const render_scene *s)
{
    int w, h;
    render_scene_resolution(s, &w, &h);
    if (ro->width > 0 && ro->height > 0)
        w = ro->width, h = ro->height;
    if ((ro->mode == RENDER_FAST && ro->max_spp > ro->spp) || w < PIPELINE_CROP ||
        h < PIPELINE_CROP)
        return;
    ro->window_x = (w - PIPELINE_CROP) / 2, ro->window_y = (h - PIPELINE_CROP) / 2;
    ro->window_w = ro->window_h = PIPELINE_CROP;
}

/* ---------------------------------------------------------------- augmentation ----- */

int datagen_augment_parse(const char *spec, datagen_augment *a, char *err, size_t errlen)
{
    memset(a, 0, sizeof *a);
    if (!spec || !*spec)
        return 0;
    char *copy = strdup(spec), *save = NULL;
    if (!copy)
        return pipeline_error(err, errlen, "out of memory");
    int rc = 0;
    for (char *tok = strtok_r(copy, ",", &save); tok && !rc; tok = strtok_r(NULL, ",", &save)) {
        char *eq = strchr(tok, '=');
        char *end = NULL;
        double v = eq ? strtod(eq + 1, &end) : 0.0;
        if (!eq || end == eq + 1 || *end || !isfinite(v) || v < 0) {
            rc = pipeline_error(err, errlen,
                                "--augment: \"%s\": expected KEY=NUMBER >= 0 (keys: views, "
                                "light, flash, exposure, wb, rotate, shift)",
                                tok);
            break;
        }
        *eq = 0;
        if (!strcmp(tok, "views") && v == floor(v) && v <= 15)
            a->views = (int)v;
        else if (!strcmp(tok, "light") && v <= 1)
            a->light = (float)v;
        else if (!strcmp(tok, "flash") && v <= 1)
            a->flash = (float)v;
        else if (!strcmp(tok, "exposure") && v <= 4)
            a->exposure = (float)v;
        else if (!strcmp(tok, "wb") && v <= 1)
            a->wb = (float)v;
        else if (!strcmp(tok, "rotate") && v <= 180)
            a->rotate = (float)v;
        else if (!strcmp(tok, "shift") && v <= 10)
            a->shift = (float)v;
        else
            rc = pipeline_error(err, errlen,
                                "--augment: %s=%g: unknown key or out of range (views 0-15 "
                                "integer, light 0-1 m, flash 0-1, exposure 0-4 stops, wb 0-1, rotate 0-180 "
                                "degrees, shift 0-10 m)",
                                tok, v);
    }
    free(copy);
    return rc;
}

/* The augmentation's random numbers: SplitMix64, a pure function of (id, view, draw). */
static double uniform01(uint64_t *state)
{
    return (double)(pipeline_splitmix64(state) >> 11) * 0x1p-53;
}

static void view_settings_make(const datagen_augment *a, const double base_light[3],
                               const double flash_light[3], long long id, int view,
                               pipeline_view *vs)
{
    memset(vs, 0, sizeof *vs);
    vs->wb[0] = vs->wb[1] = vs->wb[2] = 1.0;
    memcpy(vs->light, base_light, sizeof vs->light);
    if (view == 0)
        return; /* view 0 is the plain scene, whatever the augmentation */
    uint64_t state = (uint64_t)id * 0x100000001b3ull ^ ((uint64_t)view << 56);
    vs->flash = uniform01(&state) < a->flash;
    if (vs->flash)
        memcpy(vs->light, flash_light, sizeof vs->light);
    for (int k = 0; k < 3; k++) {
        double u = uniform01(&state) * 2.0 - 1.0;
        vs->light[k] += vs->flash ? 0.0 : u * a->light;
    }
    if (vs->light[2] < 0.05)
        vs->light[2] = 0.05; /* keep the light above the plane */
    vs->exposure = (uniform01(&state) * 2.0 - 1.0) * a->exposure;
    vs->wb[0] = exp2((uniform01(&state) * 2.0 - 1.0) * a->wb);
    vs->wb[2] = exp2((uniform01(&state) * 2.0 - 1.0) * a->wb);
    /* Drawn last, so that adding rotate/shift to a spec keeps the other draws. */
    vs->rotate = (uniform01(&state) * 2.0 - 1.0) * a->rotate * M_PI / 180.0;
    for (int k = 0; k < 2; k++)
        vs->shift[k] = (uniform01(&state) * 2.0 - 1.0) * a->shift;
}

static int view_moves_texture(const pipeline_view *vs)
{
    return vs->rotate != 0.0 || vs->shift[0] != 0.0 || vs->shift[1] != 0.0;
}

static char *view_settings_json(const pipeline_view *vs)
{
    char *s = malloc(256);
    if (s)
        snprintf(s, 256,
                 "{\"scene\":\"%s\",\"light\":[%.6g,%.6g,%.6g],\"exposure\":%.6g,"
                 "\"wb\":[%.6g,%.6g,%.6g],\"rotation_z\":%.6g,\"shift\":[%.6g,%.6g]}",
                 vs->flash ? "flash" : "plain", vs->light[0], vs->light[1], vs->light[2],
                 vs->exposure, vs->wb[0], vs->wb[1], vs->wb[2], vs->rotate, vs->shift[0],
                 vs->shift[1]);
    return s;
}

/* The inverse of view_settings_json, for a stored row (an evaluation renders candidates in
 * the row's own view). Fields written since ("rotation_z", "shift") may be absent: 0. */
int pipeline_view_parse(const char *view_json, pipeline_view *vs, char *err, size_t errlen)
{
    memset(vs, 0, sizeof *vs);
    vs->wb[0] = vs->wb[1] = vs->wb[2] = 1.0;
    cJSON *root = cJSON_Parse(view_json ? view_json : "");
    const char *scene = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(root, "scene"));
    const cJSON *light = cJSON_GetObjectItemCaseSensitive(root, "light");
    const cJSON *exposure = cJSON_GetObjectItemCaseSensitive(root, "exposure");
    const cJSON *wb = cJSON_GetObjectItemCaseSensitive(root, "wb");
    const cJSON *rot = cJSON_GetObjectItemCaseSensitive(root, "rotation_z");
    const cJSON *shift = cJSON_GetObjectItemCaseSensitive(root, "shift");
    int ok = scene && (!strcmp(scene, "plain") || !strcmp(scene, "flash")) &&
             cJSON_GetArraySize(light) == 3 && cJSON_IsNumber(exposure) &&
             cJSON_GetArraySize(wb) == 3 && (!rot || cJSON_IsNumber(rot)) &&
             (!shift || cJSON_GetArraySize(shift) == 2);
    if (ok) {
        vs->flash = !strcmp(scene, "flash");
        vs->exposure = exposure->valuedouble;
        vs->rotate = rot ? rot->valuedouble : 0.0;
        for (int k = 0; k < 3; k++) {
            const cJSON *l = cJSON_GetArrayItem(light, k), *w = cJSON_GetArrayItem(wb, k);
            ok = ok && cJSON_IsNumber(l) && cJSON_IsNumber(w);
            vs->light[k] = ok ? l->valuedouble : 0.0;
            vs->wb[k] = ok ? w->valuedouble : 1.0;
        }
        for (int k = 0; k < 2 && shift; k++) {
            const cJSON *v = cJSON_GetArrayItem(shift, k);
            ok = ok && cJSON_IsNumber(v);
            vs->shift[k] = ok ? v->valuedouble : 0.0;
        }
    }
    cJSON_Delete(root);
    if (!ok)
        return pipeline_error(err, errlen, "view settings \"%.200s\": expected scene plain|flash, "
                                           "light[3], exposure, wb[3] (rotation_z, shift[2])",
                              view_json ? view_json : "(null)");
    return 0;
}

void pipeline_view_apply_gain(const pipeline_view *vs, image *img)
{
    /* Exposure and white balance act on the linear image, as a camera's would. */
    if (vs->exposure == 0.0 && vs->wb[0] == 1.0 && vs->wb[1] == 1.0 && vs->wb[2] == 1.0)
        return;
    float gain[3];
    for (int k = 0; k < 3; k++)
        gain[k] = (float)(exp2(vs->exposure) * vs->wb[k]);
    size_t n = (size_t)img->width * (size_t)img->height;
    int nc = img->channels < 3 ? img->channels : 3;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < nc; k++)
            img->pixels[i * (size_t)img->channels + (size_t)k] *= gain[k];
}

char *pipeline_scene_for_view(const char *scene_text, const pipeline_view *vs)
{
    cJSON *root = cJSON_Parse(scene_text);
    cJSON *lights = root ? cJSON_GetObjectItemCaseSensitive(root, "lights") : NULL;
    cJSON *light = lights ? cJSON_GetArrayItem(lights, 0) : NULL;
    cJSON *objects = root ? cJSON_GetObjectItemCaseSensitive(root, "objects") : NULL;
    cJSON *plane = objects ? cJSON_GetArrayItem(objects, 0) : NULL;
    char *out = NULL;
    if (light && plane) {
        cJSON_ReplaceItemInObjectCaseSensitive(light, "location",
                                               cJSON_CreateDoubleArray(vs->light, 3));
        if (view_moves_texture(vs)) {
            cJSON *t = cJSON_CreateObject();
            double loc[3] = {vs->shift[0], vs->shift[1], 0.0}, rot[3] = {0.0, 0.0, vs->rotate};
            cJSON_AddItemToObject(t, "location", cJSON_CreateDoubleArray(loc, 3));
            cJSON_AddItemToObject(t, "rotation_euler", cJSON_CreateDoubleArray(rot, 3));
            cJSON_DeleteItemFromObjectCaseSensitive(plane, "transform");
            cJSON_AddItemToObject(plane, "transform", t);
        }
        out = cJSON_PrintUnformatted(root);
    }
    cJSON_Delete(root);
    return out;
}

/* The first light's location in a scene's JSON text; -1 if it has none. */
static int scene_light(const char *scene_text, double out[3])
{
    cJSON *root = cJSON_Parse(scene_text);
    cJSON *lights = root ? cJSON_GetObjectItemCaseSensitive(root, "lights") : NULL;
    cJSON *loc = cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(lights, 0), "location");
    int rc = -1;
    if (cJSON_GetArraySize(loc) == 3) {
        for (int k = 0; k < 3; k++)
            out[k] = cJSON_GetNumberValue(cJSON_GetArrayItem(loc, k));
        rc = 0;
    }
    cJSON_Delete(root);
    return rc;
}

/* ---------------------------------------------------------------- one sample ------- */

enum { MAX_VIEWS = 16, MAX_PARAMS = 256 };

typedef struct view_result {
    char *view_json;
    unsigned char *image; /* encoded file bytes */
    size_t image_len;
    uint16_t *descriptor; /* float16 */
} view_result;

typedef struct sample_result {
    long long id;
    int failed;
    char err[768];
    float params[MAX_PARAMS];
    uint8_t active[MAX_PARAMS];
    int subshader_nodes;
    view_result views[MAX_VIEWS];
} sample_result;

/* What every worker shares (read-only while workers run). */
typedef struct shared {
    const datagen_options *o;
    const char *graph_path;
    const char *scene_text, *flash_text;
    const render_scene *scene, *flash_scene;
    double base_light[3], flash_light[3];
    descriptor_config desc;
    size_t desc_size; /* stored floats a view (0: no descriptor) */
    int n_params, n_views;
    char tmpdir[512];
} shared;

typedef struct worker {
    const shared *sh;
    int index;
    sg_graph *graph;
    sg_params params;
    descriptor_worker dw;
    double stage_seconds[5];
    /* per batch */
    sample_result *results;
    const long long *ids;
    int n;
    pthread_mutex_t *lock;
    int *next;
} worker;

static void result_clear(sample_result *r)
{
    for (int v = 0; v < MAX_VIEWS; v++) {
        free(r->views[v].view_json);
        free(r->views[v].image);
        free(r->views[v].descriptor);
    }
    memset(r, 0, sizeof *r);
}

/* Encodes img as the dataset's image format, through a temporary file (imageio writes
 * files; the bytes are what the file holds), and replaces img by what that file decodes
 * to: the descriptor is then computed from exactly the image stored, so `dataset
 * describe` reproduces it bit for bit. */
static int encode_image(worker *w, image *img, view_result *vr, char *err, size_t errlen)
{
    const datagen_options *o = w->sh->o;
    if (o->images == DATAGEN_IMAGES_NONE)
        return 0;
    char path[700];
    snprintf(path, sizeof path, "%s/imsynth-datagen-%ld-%d.%s", w->sh->tmpdir, (long)getpid(),
             w->index, o->images == DATAGEN_IMAGES_EXR ? "exr" : "png");
    char msg[768];
    int rc = o->images == DATAGEN_IMAGES_EXR
                 ? image_write_exr(path, img, IMAGE_EXR_HALF, msg, sizeof msg)
                 : image_write_png16_linear(path, img, msg, sizeof msg);
    if (rc < 0)
        return pipeline_error(err, errlen, "%s", msg);
    size_t len;
    char *bytes = pipeline_read_file(path, &len, err, errlen);
    image stored;
    if (bytes && image_read(path, &stored, msg, sizeof msg) < 0) {
        free(bytes);
        bytes = NULL;
        pipeline_error(err, errlen, "%s", msg);
    }
    unlink(path);
    if (!bytes)
        return -1;
    image_free(img);
    *img = stored;
    vr->image = (unsigned char *)bytes;
    vr->image_len = len;
    return 0;
}

static int make_view(worker *w, const render_material *m, long long id, int view,
                     sample_result *r, char *err, size_t errlen)
{
    const shared *sh = w->sh;
    const datagen_options *o = sh->o;
    pipeline_view vs;
    view_settings_make(&o->augment, sh->base_light, sh->flash_light, id, view, &vs);
    view_result *vr = &r->views[view];
    if (!(vr->view_json = view_settings_json(&vs)))
        return pipeline_error(err, errlen, "out of memory");

    double t0 = pipeline_now();
    /* The scene: the shared one unless this view moved the light. */
    const render_scene *scene = vs.flash ? sh->flash_scene : sh->scene;
    render_scene *own = NULL;
    const double *unmoved = vs.flash ? sh->flash_light : sh->base_light;
    if (memcmp(vs.light, unmoved, sizeof vs.light) || view_moves_texture(&vs)) {
        char *text = pipeline_scene_for_view(vs.flash ? sh->flash_text : sh->scene_text, &vs);
        char msg[512] = "out of memory";
        own = text ? render_scene_load_json(text, strlen(text), "augmented scene", msg, sizeof msg)
                   : NULL;
        free(text);
        if (!own)
            return pipeline_error(err, errlen, "id %lld view %d: scene: %s", id, view, msg);
        scene = own;
    }
    render_options ro;
    datagen_preset_render_options(o->preset, o->blender, &ro);
    ro.threads = 1;
    ro.seed = (uint64_t)id << 4 | (uint64_t)view;
    image img;
    char msg[768];
    int rc = render_image(scene, m, &ro, &img, NULL, msg, sizeof msg);
    render_scene_free(own);
    if (rc < 0)
        return pipeline_error(err, errlen, "id %lld view %d: render: %s", id, view, msg);
    pipeline_view_apply_gain(&vs, &img);
    double t1 = pipeline_now();
    w->stage_seconds[2] += t1 - t0;

    rc = encode_image(w, &img, vr, err, errlen);
    double t2 = pipeline_now();
    w->stage_seconds[4] += t2 - t1;
    if (rc == 0 && sh->desc_size &&
        !(vr->descriptor = descriptor_compute_f16(&sh->desc, &w->dw, &img)))
        rc = pipeline_error(err, errlen, "id %lld: render too small for the descriptor, or out "
                                         "of memory", id);
    image_free(&img);
    w->stage_seconds[3] += pipeline_now() - t2;
    return rc;
}

static int make_sample(worker *w, long long id, sample_result *r)
{
    const shared *sh = w->sh;
    r->id = id;
    double t0 = pipeline_now();
    sg_params_sample(&w->params, (unsigned long long)id);
    char e[SG_ERROR_MAX] = "";
    if (sg_graph_bind_params(w->graph, &w->params, e, sizeof e) < 0)
        return pipeline_error(r->err, sizeof r->err, "id %lld: %s", id, e);
    memcpy(r->params, w->params.values, (size_t)sh->n_params * sizeof(float));
    double t1 = pipeline_now();
    w->stage_seconds[0] += t1 - t0;
    if (pipeline_active_params(w->graph, sh->o->blender, r->active, &r->subshader_nodes, r->err,
                               sizeof r->err) < 0)
        return -1;
    w->stage_seconds[1] += pipeline_now() - t1;
    render_material *m =
        pipeline_render_material(w->graph, sh->graph_path, sh->o->blender, r->err, sizeof r->err);
    if (!m)
        return -1;
    int rc = 0;
    for (int v = 0; v < sh->n_views && rc == 0; v++)
        rc = make_view(w, m, id, v, r, r->err, sizeof r->err);
    render_material_free(m);
    return rc;
}

static void *worker_main(void *arg)
{
    worker *w = arg;
    for (;;) {
        pthread_mutex_lock(w->lock);
        int i = (*w->next)++;
        pthread_mutex_unlock(w->lock);
        if (i >= w->n)
            break;
        if (make_sample(w, w->ids[i], &w->results[i]) < 0)
            w->results[i].failed = 1;
    }
    return NULL;
}

/* ---------------------------------------------------------------- config ----------- */

static char *config_json(const datagen_options *o, const shared *sh, const char *graph_hash,
                         const char *scene_hash, const char *flash_hash)
{
    cJSON *c = cJSON_CreateObject();
    cJSON_AddStringToObject(c, "format", STORE_SCHEMA);
    cJSON_AddStringToObject(c, "supershader_sha256", graph_hash);
    cJSON_AddStringToObject(c, "scene_sha256", scene_hash);
    if (flash_hash)
        cJSON_AddStringToObject(c, "flash_scene_sha256", flash_hash);
    cJSON_AddNumberToObject(c, "blender", o->blender);
    /* How the active mask is decided (docs/datasets.md): 2 since extraction lists links in
     * one order (36bf3b2). Before, a selector the sub-shader does not use could count as
     * active (an unused Detail Operation in ~18% of samples), and those configs have no
     * such key, so a dataset begun under the old rule is not resumed or merged under the
     * new one. */
    cJSON_AddNumberToObject(c, "active_rule", 2);
    cJSON *p = cJSON_AddObjectToObject(c, "preset");
    cJSON_AddStringToObject(p, "name", o->preset->name);
    cJSON_AddNumberToObject(p, "spp", o->preset->spp);
    cJSON_AddNumberToObject(p, "max_spp", o->preset->max_spp);
    cJSON_AddNumberToObject(p, "light_samples", o->preset->light_samples);
    cJSON_AddNumberToObject(p, "noise_target", o->preset->noise_target);
    cJSON_AddStringToObject(p, "seed", "id * 16 + view");
    cJSON *a = cJSON_AddObjectToObject(c, "augment");
    cJSON_AddNumberToObject(a, "views", o->augment.views);
    cJSON_AddNumberToObject(a, "light", o->augment.light);
    cJSON_AddNumberToObject(a, "flash", o->augment.flash);
    cJSON_AddNumberToObject(a, "exposure", o->augment.exposure);
    cJSON_AddNumberToObject(a, "wb", o->augment.wb);
    if (o->augment.rotate > 0 || o->augment.shift > 0) {
        /* Only when used: configs made before these existed keep their hash. */
        cJSON_AddNumberToObject(a, "rotate", o->augment.rotate);
        cJSON_AddNumberToObject(a, "shift", o->augment.shift);
    }
    cJSON_AddStringToObject(c, "images",
                            o->images == DATAGEN_IMAGES_NONE    ? "none"
                            : o->images == DATAGEN_IMAGES_PNG16 ? "png16-linear"
                                                                : "exr-half");
    cJSON *d = cJSON_AddObjectToObject(c, "descriptor");
    if (sh->desc_size)
        descriptor_config_json(&sh->desc, d);
    else
        cJSON_AddStringToObject(d, "features", "none");
    char *s = cJSON_PrintUnformatted(c);
    cJSON_Delete(c);
    return s;
}

static char *params_names_json(const sg_params *p)
{
    cJSON *a = cJSON_CreateArray();
    for (int k = 0; k < p->n; k++)
        cJSON_AddItemToArray(a, cJSON_CreateString(p->names[k]));
    char *s = cJSON_PrintUnformatted(a);
    cJSON_Delete(a);
    return s;
}

/* ---------------------------------------------------------------- storing ---------- */

static int store_batch(sqlite3 *db, const char *path, sample_result *res, int n,
                       const shared *sh, char *err, size_t errlen)
{
    if (store_exec(db, path, "BEGIN IMMEDIATE", err, errlen))
        return -1;
    sqlite3_stmt *st = NULL;
    int rc = sqlite3_prepare_v2(db,
                                "INSERT INTO samples(id, view, params, active, subshader_nodes, "
                                "view_json, image, descriptor) VALUES(?,?,?,?,?,?,?,?)",
                                -1, &st, NULL);
    for (int i = 0; i < n && rc == SQLITE_OK; i++) {
        sample_result *r = &res[i];
        for (int v = 0; v < sh->n_views && rc == SQLITE_OK; v++) {
            view_result *vr = &r->views[v];
            sqlite3_reset(st);
            sqlite3_bind_int64(st, 1, r->id);
            sqlite3_bind_int(st, 2, v);
            sqlite3_bind_blob(st, 3, r->params, sh->n_params * (int)sizeof(float), SQLITE_STATIC);
            sqlite3_bind_blob(st, 4, r->active, sh->n_params, SQLITE_STATIC);
            sqlite3_bind_int(st, 5, r->subshader_nodes);
            sqlite3_bind_text(st, 6, vr->view_json, -1, SQLITE_STATIC);
            if (vr->image)
                sqlite3_bind_blob(st, 7, vr->image, (int)vr->image_len, SQLITE_STATIC);
            else
                sqlite3_bind_null(st, 7);
            if (vr->descriptor)
                sqlite3_bind_blob(st, 8, vr->descriptor, (int)(sh->desc_size * 2), SQLITE_STATIC);
            else
                sqlite3_bind_null(st, 8);
            rc = sqlite3_step(st);
            if (rc == SQLITE_DONE)
                rc = SQLITE_OK;
        }
    }
    if (rc != SQLITE_OK) {
        pipeline_error(err, errlen, "%s: storing samples: %s%s", path, sqlite3_errmsg(db),
                       (rc & 0xff) == SQLITE_FULL ? " (disk full; nothing of this batch was "
                                                    "stored, rerun to resume)"
                                                  : "");
        sqlite3_finalize(st);
        sqlite3_exec(db, "ROLLBACK", NULL, NULL, NULL);
        return -1;
    }
    sqlite3_finalize(st);
    if (store_exec(db, path, "COMMIT", err, errlen)) {
        sqlite3_exec(db, "ROLLBACK", NULL, NULL, NULL);
        return -1;
    }
    return 0;
}

/* The ids of [first, first + count) in the shard that the dataset lacks, ascending. */
static long long *missing_ids(sqlite3 *db, const datagen_options *o, long long *n_out,
                              char *err, size_t errlen)
{
    long long first = o->first_id, count = o->count;
    uint8_t *have = calloc((size_t)count, 1);
    long long *ids = malloc((size_t)(count > 0 ? count : 1) * sizeof *ids);
    if (!have || !ids) {
        free(have);
        free(ids);
        pipeline_error(err, errlen, "out of memory for %lld ids", count);
        return NULL;
    }
    sqlite3_stmt *st = NULL;
    sqlite3_prepare_v2(db, "SELECT DISTINCT id FROM samples WHERE id >= ? AND id < ?", -1, &st,
                       NULL);
    sqlite3_bind_int64(st, 1, first);
    sqlite3_bind_int64(st, 2, first + count);
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW)
        have[sqlite3_column_int64(st, 0) - first] = 1;
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE) {
        pipeline_error(err, errlen, "%s: reading ids: %s", o->out_path, sqlite3_errmsg(db));
        free(have);
        free(ids);
        return NULL;
    }
    long long n = 0;
    for (long long i = 0; i < count; i++) {
        long long id = first + i;
        if (!have[i] && id % o->shard_count == o->shard_index)
            ids[n++] = id;
    }
    free(have);
    *n_out = n;
    return ids;
}

/* ---------------------------------------------------------------- the run ---------- */

static int load_shared(shared *sh, const datagen_options *o, char *paths[3], char *err,
                       size_t errlen)
{
    sh->o = o;
    sh->graph_path = paths[0];
    char msg[768];
    size_t len;
    if (!(sh->scene_text = pipeline_read_file(paths[1], &len, err, errlen)))
        return -1;
    if (!(sh->scene = render_scene_load_json(sh->scene_text, len, paths[1], msg, sizeof msg)))
        return pipeline_error(err, errlen, "%s", msg);
    if (scene_light(sh->scene_text, sh->base_light) < 0)
        return pipeline_error(err, errlen, "%s: the scene has no light to augment", paths[1]);
    if (o->augment.flash > 0) {
        if (!(sh->flash_text = pipeline_read_file(paths[2], &len, err, errlen)))
            return -1;
        if (!(sh->flash_scene =
                  render_scene_load_json(sh->flash_text, len, paths[2], msg, sizeof msg)))
            return pipeline_error(err, errlen, "%s", msg);
        if (scene_light(sh->flash_text, sh->flash_light) < 0)
            return pipeline_error(err, errlen, "%s: the flash scene has no light", paths[2]);
    }
    sh->n_views = 1 + o->augment.views;
    if (o->descriptor != DATAGEN_DESC_NONE) {
        if (descriptor_config_init(&sh->desc, o->descriptor, o->descriptor_mask_path, err, errlen))
            return -1;
        sh->desc_size = sh->desc.n_stored;
    }
    const char *t = getenv("TMPDIR");
    snprintf(sh->tmpdir, sizeof sh->tmpdir, "%s", t && *t ? t : "/tmp");
    return 0;
}

static void free_shared(shared *sh)
{
    free((void *)sh->scene_text);
    free((void *)sh->flash_text);
    render_scene_free((render_scene *)sh->scene);
    render_scene_free((render_scene *)sh->flash_scene);
    if (sh->desc_size)
        descriptor_config_free(&sh->desc);
}

static int worker_init(worker *w, const shared *sh, int index, char *err, size_t errlen)
{
    memset(w, 0, sizeof *w);
    w->sh = sh;
    w->index = index;
    char e[SG_ERROR_MAX] = "";
    if (!(w->graph = sg_graph_load_file(sh->graph_path, e, sizeof e)))
        return pipeline_error(err, errlen, "%s", e);
    if (sg_params_from_graph(w->graph, &w->params, e, sizeof e) < 0)
        return pipeline_error(err, errlen, "%s: %s", sh->graph_path, e);
    if (sh->desc_size && descriptor_worker_init(&w->dw, &sh->desc))
        return pipeline_error(err, errlen, "out of memory for the descriptor workspace");
    return 0;
}

static void worker_free(worker *w)
{
    sg_graph_free(w->graph);
    if (w->params.names)
        sg_params_free(&w->params);
    descriptor_worker_free(&w->dw);
}

int datagen_run(const datagen_options *o, long long *made, char *err, size_t errlen)
{
    if (made)
        *made = 0;
    if (o->count < 0 || o->first_id < 0 || o->shard_count < 1 || o->shard_index < 0 ||
        o->shard_index >= o->shard_count)
        return pipeline_error(err, errlen, "bad id range or shard");
    char graph_path[1024], scene_path[1024], flash_path[1024];
    if (pipeline_find_data(o->graph_path ? o->graph_path : "assets/supershader.json", graph_path,
                           sizeof graph_path, err, errlen) ||
        pipeline_find_data(o->scene_path ? o->scene_path : "assets/scene.json", scene_path,
                           sizeof scene_path, err, errlen))
        return -1;
    flash_path[0] = 0;
    if (o->augment.flash > 0 &&
        pipeline_find_data(o->flash_scene_path ? o->flash_scene_path : "assets/scene-flash.json",
                           flash_path, sizeof flash_path, err, errlen))
        return -1;
    char *paths[3] = {graph_path, scene_path, flash_path};

    shared sh;
    memset(&sh, 0, sizeof sh);
    int threads = pipeline_thread_count(o->threads);
    worker *workers = NULL;
    sample_result *res = NULL;
    long long *ids = NULL;
    sqlite3 *db = NULL;
    char *cfg = NULL, *names = NULL;
    int rc = -1, n_workers = 0;
    if (load_shared(&sh, o, paths, err, errlen))
        goto done;

    /* Hashes of the inputs that define a sample, for the config. */
    char hg[65], hs[65], hf[65];
    if (pipeline_file_sha256(graph_path, hg, err, errlen))
        goto done;
    pipeline_sha256_hex(sh.scene_text, strlen(sh.scene_text), hs);
    if (sh.flash_text)
        pipeline_sha256_hex(sh.flash_text, strlen(sh.flash_text), hf);

    workers = calloc((size_t)threads, sizeof *workers);
    if (!workers) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    for (; n_workers < threads; n_workers++)
        if (worker_init(&workers[n_workers], &sh, n_workers, err, errlen)) {
            n_workers++;
            goto done;
        }
    sh.n_params = workers[0].params.n;
    if (sh.n_params > MAX_PARAMS) {
        pipeline_error(err, errlen, "%s: %d parameters, at most %d", graph_path, sh.n_params,
                       MAX_PARAMS);
        goto done;
    }
    cfg = config_json(o, &sh, hg, hs, sh.flash_text ? hf : NULL);
    names = params_names_json(&workers[0].params);
    if (!cfg || !names) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    if (!(db = store_open_for_writing(o->out_path, cfg, names, err, errlen)))
        goto done;
    long long n_todo;
    if (!(ids = missing_ids(db, o, &n_todo, err, errlen)))
        goto done;
    /* Our workers each run single-threaded sgemms. */
    openblas_set_num_threads(1);
    int batch = o->batch > 0 ? o->batch : 4 * threads;
    if (!(res = calloc((size_t)batch, sizeof *res))) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    double store_seconds = 0;
    long long done_count = 0;
    rc = 0;
    for (long long first = 0; first < n_todo; first += batch) {
        if (o->stop && *o->stop) {
            rc = 1;
            break;
        }
        int n = n_todo - first < batch ? (int)(n_todo - first) : batch;
        pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
        int next = 0;
        pthread_t tid[256];
        int started = 0;
        for (int t = 0; t < n_workers && t < n; t++) {
            worker *w = &workers[t];
            w->results = res;
            w->ids = ids + first;
            w->n = n;
            w->lock = &lock;
            w->next = &next;
            if (t == 0 || pthread_create(&tid[t], NULL, worker_main, w) == 0)
                started = t + 1;
            else
                break;
        }
        worker_main(&workers[0]); /* the calling thread is worker 0 */
        for (int t = 1; t < started; t++)
            pthread_join(tid[t], NULL);
        for (int i = 0; i < n && rc == 0; i++)
            if (res[i].failed)
                rc = pipeline_error(err, errlen, "%s", res[i].err);
        double t0 = pipeline_now();
        if (rc == 0 && store_batch(db, o->out_path, res, n, &sh, err, errlen))
            rc = -1;
        store_seconds += pipeline_now() - t0;
        for (int i = 0; i < n; i++)
            result_clear(&res[i]);
        if (rc)
            break;
        done_count += n;
        if (made)
            *made = done_count;
        if (o->progress) {
            double stage[5] = {0, 0, 0, 0, store_seconds};
            for (int t = 0; t < n_workers; t++)
                for (int k = 0; k < 5; k++)
                    stage[k] += workers[t].stage_seconds[k];
            o->progress(o->progress_ctx, done_count, n_todo, stage);
        }
    }
done:
    if (db && sqlite3_close(db) != SQLITE_OK && rc == 0)
        rc = pipeline_error(err, errlen, "%s: close failed", o->out_path);
    for (int t = 0; t < n_workers; t++)
        worker_free(&workers[t]);
    free(workers);
    free(res);
    free(ids);
    free(cfg);
    free(names);
    free_shared(&sh);
    return rc;
}
