/*
 * imsynth evaluate: every test input against every method, in parameter space and in image
 * space (docs/evaluation.md).
 *
 * Inputs: a synthetic test dataset's rows (each rendered in its own view: plain or flash
 * scene, light, exposure, white balance, texture transform, from view_json) and hand-made
 * Cycles materials (<dir>/<name>/render.exr in assets/scene.json, flash.exr in
 * assets/scene-flash.json). Methods (the table `methods`): parameter sets drawn from a
 * source (the training mean, a random catalogue sample, retrieval, the predictor); a
 * "-topk" method renders --top-k of its source's candidates and keeps the one whose render
 * is nearest the input under the TRAINING descriptor (never the judge's).
 *
 * Each input's renders share one seed, a function of (--seed, the input) only: candidates
 * of all methods are compared under the same noise (common random numbers), a candidate
 * two methods share is rendered once, and the bytes do not depend on --threads. Workers
 * take whole inputs; the predictor, not shareable, is called under a lock (a prediction
 * costs a millisecond against a second of rendering).
 *
 * Invariant: the report folder is written as OUT.tmp.PID and renamed whole; an error
 * removes what was written.
 */
#include <assert.h>
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "pipeline/pipeline_internal.h"
/* Last: OpenBLAS's config defines a macro I (complex.h). */
#include <cblas.h>

/* ---------------------------------------------------------------- what is measured - */

/* Distances: the two Gram descriptors and the two colour terms. "colour" is the box-by-box
 * term (issue 15's "L1 of 32x32-pooled images"), "colour-sorted" the same boxes compared as
 * distributions, which is what predict's loss has used by default since session 29: the
 * -refine rows minimise one of them (--colour-term), and both are reported so that a row is
 * judged by the term it did not minimise too. */
enum { DIST_MOBILENET, DIST_VGG, DIST_COLOUR, DIST_COLOUR_SORTED, N_DIST };
static const char *const dist_names[N_DIST] = {"mobilenetv2", "vgg19", "colour", "colour-sorted"};
static const datagen_descriptor gram_kinds[2] = {DATAGEN_DESC_MOBILENETV2_F16,
                                                 DATAGEN_DESC_VGG19_F16};

typedef enum input_set { SET_SYNTHETIC, SET_AUGMENTED, SET_HANDMADE, SET_FLASH, N_SETS } input_set;
static const char *const set_names[N_SETS] = {"synthetic", "synthetic-augmented", "handmade",
                                              "handmade-flash"};

/* Where a method's candidate parameter sets come from. */
typedef enum source { SOURCE_MEAN, SOURCE_RANDOM, SOURCE_NEAREST, SOURCE_PREDICTOR } source;

typedef struct method {
    const char *name;
    source src;
    int topk; /* 0: the source's first candidate; 1: the best of --top-k by rendering */
    const char *what;
    const char *refines; /* NULL, or the method whose pick this one refines (--refine renders
                            of refine_search with predict's loss), listed before it */
} method;

/* A new method is one entry here and, if it needs one, one source. */
static const method methods[] = {
    {"mean", SOURCE_MEAN, 0, "the training set's mean parameters (the thesis's result)"},
    {"random", SOURCE_RANDOM, 0, "a catalogue sample drawn per input (seeded)"},
    {"nearest", SOURCE_NEAREST, 0, "the catalogue sample nearest the input's descriptor"},
    {"nearest-topk", SOURCE_NEAREST, 1,
     "the k nearest catalogue samples, rendered; the best by the training descriptor"},
    {"predictor", SOURCE_PREDICTOR, 0, "the predictor's most probable hypothesis"},
    {"predictor-topk", SOURCE_PREDICTOR, 1,
     "the predictor's k hypotheses, rendered; the best by the training descriptor"},
    {"nearest-refine", SOURCE_NEAREST, 1, "nearest-topk's pick, refined as imsynth predict does",
     "nearest-topk"},
    {"predictor-refine", SOURCE_PREDICTOR, 1,
     "predictor-topk's pick, refined as imsynth predict does", "predictor-topk"},
};
enum { N_METHODS = sizeof methods / sizeof methods[0], METHOD_MEAN = 0, METHOD_NEAREST = 2 };

/* The index of the method named `name` (a name in the table). */
static int method_index(const char *name)
{
    for (int m = 0; m < N_METHODS; m++)
        if (!strcmp(methods[m].name, name))
            return m;
    assert(!"a method's `refines` names a method of the table");
    return 0;
}

/* ---------------------------------------------------------------- inputs, results -- */

typedef struct input {
    input_set set;
    char name[200];
    long long id; /* synthetic: the row's id and view */
    int view;
    char *view_json;
    float *params; /* synthetic: the target (n_params), NULL otherwise */
    uint8_t *active;
    float *stored_desc; /* the row's descriptor when the model reads it as stored */
    image img;          /* the input image */
    image floor_img;    /* hand-made: the shifted render the floor compares against... */
    image floor_ref;    /* ...and what with, when not the input itself (a flash input
                           without its own shifted render takes its plain pair's floor) */
    char floor_source[64];
    int sheet_row; /* row on its contact sheet, or -1 */
} input;

typedef struct result {
    int failed;
    char err[768];
    float *chosen;                      /* N_METHODS x n_params */
    int chosen_index[N_METHODS];        /* which candidate */
    int start_index[N_METHODS];         /* -topk and -refine rows: the -topk candidate the
                                         * refinement starts from (predict's choice) */
    int n_candidates[N_METHODS];
    long long chosen_id[N_METHODS];     /* the catalogue id (random, nearest), else -1 */
    double dist[N_METHODS][N_DIST], norm[N_METHODS][N_DIST];
    double floor[N_DIST];
    int renders;
    double seconds;
    image tiles[N_METHODS + 2]; /* sheet rows only: input, methods, floor */
} result;

static void input_clear(input *in)
{
    free(in->view_json);
    free(in->params);
    free(in->active);
    free(in->stored_desc);
    image_free(&in->img);
    image_free(&in->floor_img);
    image_free(&in->floor_ref);
    memset(in, 0, sizeof *in);
}

static void result_clear(result *r)
{
    free(r->chosen);
    for (int t = 0; t < N_METHODS + 2; t++)
        image_free(&r->tiles[t]);
    memset(r, 0, sizeof *r);
}

/* ---------------------------------------------------------------- shared state ----- */

typedef struct shared {
    const evaluate_options *o;
    predictor *pred;
    pthread_mutex_t lock; /* the predictor, the progress count */
    long long done, todo;
    double t_start;
    int n_params, offset_param; /* "Pattern Offset"'s index, or -1 */
    const char *const *names;
    const float *mean;
    size_t catalogue_size;
    int train; /* DIST_MOBILENET or DIST_VGG: the descriptor the model reads */
    char graph_path[1024];
    char *scene_text, *flash_text;
    render_scene *scene, *flash_scene;
    int width, height; /* the scene's resolution */
    int tile;
    refine_space space; /* the -refine methods' */
    refine_kind *kind;
    int *choices;
} shared;

typedef struct worker {
    shared *sh;
    sg_graph *graph;
    sg_params params;
    pipeline_descriptor *desc[2];
    size_t offsets[2][65];
    int n_layers[2];
    size_t desc_size[2];
    /* per batch */
    input *inputs;
    result *results;
    int n, *next;
} worker;

/* A rendered candidate of one input, with its descriptors computed when first needed. */
typedef struct candidate {
    float *params;
    image img;
    float *desc[2];
} candidate;

typedef struct input_work {
    worker *w;
    const input *in;
    result *r;
    const render_scene *scene;
    pipeline_view view;
    int has_view;
    uint64_t seed;
    float *in_desc[2];
    candidate *cands;
    int n_cands, cap_cands;
} input_work;

/* An input's seed: a function of (--seed, the input's identity) only. Synthetic rows by
 * (id, view); hand-made ones by their set and name. Never datagen's id * 16 + view: a
 * candidate's render must not share the input's noise. */
static uint64_t input_seed(uint64_t seed, const input *in)
{
    uint64_t h = seed ^ 0x6576616c75617465ull; /* "evaluate" */
    if (in->set == SET_SYNTHETIC || in->set == SET_AUGMENTED)
        h ^= (uint64_t)in->id << 4 | (uint64_t)in->view;
    else {
        h ^= (uint64_t)in->set << 60;
        for (const char *p = in->name; *p; p++)
            h = (h ^ (unsigned char)*p) * 0x100000001b3ull; /* FNV-1a */
    }
    uint64_t s = h;
    return pipeline_splitmix64(&s);
}

/* ---------------------------------------------------------------- rendering -------- */

/* The refinement's preset: --refine-preset, else the evaluation's. */
static const datagen_preset *refine_preset(const evaluate_options *o)
{
    return o->refine_preset ? o->refine_preset : o->preset;
}

/* crop_only: only the centre crop the distances read (pipeline_render_crop_only), for a
 * render that is measured and dropped (the refinement's proposals). */
static int render_params(input_work *iw, const datagen_preset *preset, const float *params,
                         int crop_only, image *out, char *err, size_t errlen)
{
    worker *w = iw->w;
    const shared *sh = w->sh;
    memcpy(w->params.values, params, (size_t)sh->n_params * sizeof(float));
    char e[SG_ERROR_MAX] = "";
    if (sg_graph_bind_params(w->graph, &w->params, e, sizeof e) < 0)
        return pipeline_error(err, errlen, "%s: %s", sh->graph_path, e);
    render_material *m =
        pipeline_render_material(w->graph, sh->graph_path, sh->o->blender, err, errlen);
    if (!m)
        return -1;
    render_options ro;
    datagen_preset_render_options(preset, sh->o->blender, &ro);
    ro.threads = 1;
    ro.seed = iw->seed;
    if (crop_only)
        pipeline_render_crop_only(&ro, iw->scene);
    char msg[768];
    int rc = render_image(iw->scene, m, &ro, out, NULL, msg, sizeof msg);
    render_material_free(m);
    if (rc < 0)
        return pipeline_error(err, errlen, "render: %s", msg);
    if (iw->has_view)
        pipeline_view_apply_gain(&iw->view, out);
    iw->r->renders++;
    return 0;
}

/* The candidate with these parameters, rendered on first use. NULL with a message. */
static candidate *candidate_get(input_work *iw, const float *params, char *err, size_t errlen)
{
    size_t bytes = (size_t)iw->w->sh->n_params * sizeof(float);
    for (int i = 0; i < iw->n_cands; i++)
        if (!memcmp(iw->cands[i].params, params, bytes))
            return &iw->cands[i];
    if (iw->n_cands == iw->cap_cands) {
        int cap = iw->cap_cands ? 2 * iw->cap_cands : 16;
        candidate *c = realloc(iw->cands, (size_t)cap * sizeof *c);
        if (!c) {
            pipeline_error(err, errlen, "out of memory");
            return NULL;
        }
        iw->cands = c;
        iw->cap_cands = cap;
    }
    candidate *c = &iw->cands[iw->n_cands];
    memset(c, 0, sizeof *c);
    if (!(c->params = malloc(bytes))) {
        pipeline_error(err, errlen, "out of memory");
        return NULL;
    }
    memcpy(c->params, params, bytes);
    iw->n_cands++;
    if (render_params(iw, iw->w->sh->o->preset, params, 0, &c->img, err, errlen))
        return NULL;
    return c;
}

/* The descriptor `k` (0 MobileNetV2, 1 VGG19) of an image, into *slot (malloc'd once). */
static int describe(worker *w, int k, const image *img, float **slot, char *err, size_t errlen)
{
    if (*slot)
        return 0;
    if (!(*slot = malloc(w->desc_size[k] * sizeof(float))))
        return pipeline_error(err, errlen, "out of memory");
    return pipeline_descriptor_compute(w->desc[k], img, *slot, err, errlen);
}

/* The distances between images a and b, their descriptors computed into the slots when
 * missing. */
static int pair_distances(worker *w, const image *a, float *desc_a[2], const image *b,
                          float *desc_b[2], double out[N_DIST], char *err, size_t errlen)
{
    for (int k = 0; k < 2; k++) {
        if (describe(w, k, a, &desc_a[k], err, errlen) ||
            describe(w, k, b, &desc_b[k], err, errlen))
            return -1;
        out[k] = evaluate_gram_distance(desc_a[k], desc_b[k], w->offsets[k], w->n_layers[k]);
    }
    if (evaluate_colour_distance(a, b, &out[DIST_COLOUR], err, errlen))
        return -1;
    return evaluate_colour_sorted_distance(a, b, &out[DIST_COLOUR_SORTED], err, errlen);
}

/* The distances between the input and an image whose descriptors are desc[]. */
static int distances(input_work *iw, const image *img, float *desc[2], double out[N_DIST],
                     char *err, size_t errlen)
{
    return pair_distances(iw->w, &iw->in->img, iw->in_desc, img, desc, out, err, errlen);
}

/* ---------------------------------------------------------------- methods ---------- */

/* Up to k candidates of a source into params (k x n_params); ids (k) the catalogue ids
 * (-1 when not from the catalogue). Returns the count, or -1 with a message. */
static int source_candidates(input_work *iw, source src, int k, const float *desc,
                             float *params, long long *ids, char *err, size_t errlen)
{
    shared *sh = iw->w->sh;
    size_t np = (size_t)sh->n_params;
    int n = -1;
    switch (src) {
    case SOURCE_MEAN:
        memcpy(params, sh->mean, np * sizeof(float));
        ids[0] = -1;
        return 1;
    case SOURCE_RANDOM: {
        uint64_t s = iw->seed ^ 0x72616e646f6d2121ull; /* "random!!" */
        size_t i = (size_t)(pipeline_splitmix64(&s) % sh->catalogue_size);
        memcpy(params, predictor_catalogue_params(sh->pred, i, &ids[0]), np * sizeof(float));
        return 1;
    }
    case SOURCE_NEAREST: {
        size_t index[256];
        pthread_mutex_lock(&sh->lock);
        n = predictor_nearest(sh->pred, desc, k, index, NULL, err, errlen);
        for (int j = 0; j < n; j++)
            memcpy(params + (size_t)j * np, predictor_catalogue_params(sh->pred, index[j], &ids[j]),
                   np * sizeof(float));
        pthread_mutex_unlock(&sh->lock);
        break;
    }
    case SOURCE_PREDICTOR: {
        float stats[TEXSTATS_N];
        int use_stats = predictor_uses_texstats(sh->pred);
        if (use_stats && pipeline_texstats(&iw->in->img, stats, err, errlen))
            return -1;
        pthread_mutex_lock(&sh->lock);
        n = predictor_predict(sh->pred, desc, use_stats ? stats : NULL, k, params, NULL, err,
                              errlen);
        pthread_mutex_unlock(&sh->lock);
        for (int j = 0; j < n; j++)
            ids[j] = -1;
        break;
    }
    }
    if (n == 0)
        return pipeline_error(err, errlen, "no candidate");
    return n;
}

/* ---------------------------------------------------------------- refinement ------ */

/* The refinement's loss, predict's (pipeline_refine_loss): the training descriptor's Gram
 * distance and the colour term of a render at the refine preset and the input's seed.
 * Proposals are not kept as candidates (a search renders tens of them); the result is
 * rendered again at the evaluation's preset to be measured like every other method. */
static int refine_loss_cb(void *ctx, const float *params, double *g, double *c, char *err,
                          size_t errlen)
{
    input_work *iw = ctx;
    worker *w = iw->w;
    int k = w->sh->train;
    image img = {0};
    float *desc = NULL;
    int rc = render_params(iw, refine_preset(w->sh->o), params, 1, &img, err, errlen);
    if (rc == 0)
        rc = describe(w, k, &img, &desc, err, errlen);
    if (rc == 0)
        rc = evaluate_colour_term(w->sh->o->refine.colour_term, &img, &iw->in->img, c, err,
                                  errlen);
    if (rc == 0)
        *g = evaluate_gram_distance(iw->in_desc[k], desc, w->offsets[k], w->n_layers[k]);
    free(desc);
    image_free(&img);
    return rc;
}

static int refine_active_cb(void *ctx, const float *params, uint8_t *active, char *err,
                            size_t errlen)
{
    input_work *iw = ctx;
    worker *w = iw->w;
    memcpy(w->params.values, params, (size_t)w->sh->n_params * sizeof(float));
    char e[SG_ERROR_MAX] = "";
    if (sg_graph_bind_params(w->graph, &w->params, e, sizeof e) < 0)
        return pipeline_error(err, errlen, "%s: %s", w->sh->graph_path, e);
    return pipeline_active_params(w->graph, w->sh->o->blender, active, NULL, err, errlen);
}

/* The input's tile for its sheet row. */
static int tile_of(const shared *sh, const image *img, image *tile)
{
    image_free(tile);
    return image_resize(img, sh->tile, sh->tile, tile);
}

static int evaluate_input(worker *w, const input *in, result *r)
{
    shared *sh = w->sh;
    const evaluate_options *o = sh->o;
    size_t np = (size_t)sh->n_params;
    char *err = r->err;
    size_t errlen = sizeof r->err;
    double t0 = pipeline_now();
    input_work iw = {.w = w, .in = in, .r = r, .seed = input_seed(o->seed, in)};
    render_scene *own = NULL;
    int top_k = o->top_k > 256 ? 256 : o->top_k;
    /* A -topk method asks its source for up to 4 k candidates and renders the first k whose
     * sub-shaders differ (pipeline_distinct_subshaders): sets that differ only in what the
     * sub-shader ignores render alike and would waste the budget. */
    int ask = 4 * top_k > 256 ? 256 : 4 * top_k;
    float *buf = malloc((size_t)ask * np * sizeof(float));
    long long ids[256];
    r->chosen = malloc(N_METHODS * np * sizeof(float));
    /* A -topk method's best o->refine.starts picks, nearest first: its -refine row races
     * them as predict does (refine_race). */
    int n_starts = o->refine.starts < 1 ? 1 : o->refine.starts > top_k ? top_k : o->refine.starts;
    float *ranked = malloc(N_METHODS * (size_t)n_starts * np * sizeof(float));
    int n_ranked[N_METHODS] = {0};
    int rc = buf && r->chosen && ranked ? 0 : pipeline_error(err, errlen, "out of memory");

    /* The scene: a synthetic row's own view; a hand-made input's plain or flash scene. */
    if (rc == 0 && (in->set == SET_SYNTHETIC || in->set == SET_AUGMENTED)) {
        rc = pipeline_view_parse(in->view_json, &iw.view, err, errlen);
        if (rc == 0 && iw.view.flash && !sh->flash_text)
            rc = pipeline_error(err, errlen, "a flash view, but no flash scene was loaded");
        char *text = rc ? NULL : pipeline_scene_for_view(iw.view.flash ? sh->flash_text
                                                                       : sh->scene_text,
                                                         &iw.view);
        char msg[512] = "out of memory, or the scene has no light or plane";
        if (rc == 0 && !(text && (own = render_scene_load_json(text, strlen(text), "view scene",
                                                               msg, sizeof msg))))
            rc = pipeline_error(err, errlen, "%s", msg);
        free(text);
        iw.scene = own;
        iw.has_view = 1;
    } else
        iw.scene = in->set == SET_FLASH ? sh->flash_scene : sh->scene;

    /* The input's descriptors: both networks (distances); the model reads the training
     * one, or the row's stored one when it is the model's. */
    for (int k = 0; k < 2 && rc == 0; k++)
        rc = describe(w, k, &in->img, &iw.in_desc[k], err, errlen);
    const float *model_in = in->stored_desc ? in->stored_desc : iw.in_desc[sh->train];

    for (int m = 0; m < N_METHODS && rc == 0; m++) {
        if (methods[m].refines) {
            int from = method_index(methods[m].refines);
            assert(n_ranked[from] >= 1);
            refine_options ro = o->refine;
            ro.seed = iw.seed;
            refine_result rr;
            if (refine_race(&sh->space, &ro, refine_loss_cb, refine_active_cb, &iw,
                            ranked + (size_t)from * n_starts * np, n_ranked[from], buf, &rr,
                            err, errlen)) {
                rc = -1;
                break;
            }
            refine_result_free(&rr);
            candidate *c = candidate_get(&iw, buf, err, errlen);
            if (!c || distances(&iw, &c->img, c->desc, r->dist[m], err, errlen)) {
                rc = -1;
                break;
            }
            memcpy(r->chosen + (size_t)m * np, c->params, np * sizeof(float));
            r->chosen_index[m] = rr.accepted;
            r->start_index[m] = r->start_index[from];
            r->n_candidates[m] = rr.evals;
            r->chosen_id[m] = -1;
            if (in->sheet_row >= 0 && tile_of(sh, &c->img, &r->tiles[1 + m]))
                rc = pipeline_error(err, errlen, "out of memory");
            continue;
        }
        int n = source_candidates(&iw, methods[m].src, methods[m].topk ? ask : 1, model_in, buf,
                                  ids, err, errlen);
        if (n < 0) {
            rc = -1;
            break;
        }
        if (methods[m].topk && n > 1) {
            int keep[256];
            n = pipeline_distinct_subshaders(w->graph, o->blender, buf, n, top_k, keep, err, errlen);
            if (n < 1) {
                rc = n < 0 ? -1 : pipeline_error(err, errlen, "no distinct candidate");
                break;
            }
            for (int j = 0; j < n; j++) { /* keep[] ascends: keep[j] >= j, compaction in place */
                assert(keep[j] >= j && (j == 0 || keep[j] > keep[j - 1]));
                memmove(buf + (size_t)j * np, buf + (size_t)keep[j] * np, np * sizeof(float));
                ids[j] = ids[keep[j]];
            }
        }
        /* The pick: the first, or the candidate whose render is nearest the input under the
         * training descriptor (issue 15's -topk row; ties: the earlier, i.e. the likelier or
         * nearer). The refinement starts where predict's would: from the candidates best by
         * G + start_colour_weight C (predict.c, the starts), which is the pick when that
         * weight is 0. */
        int order[256] = {0}, by_loss[256] = {0};
        double dist[256], loss[256];
        for (int j = 0; j < n && methods[m].topk; j++) {
            candidate *c = candidate_get(&iw, buf + (size_t)j * np, err, errlen);
            double colour = NAN;
            if (!c || describe(w, sh->train, &c->img, &c->desc[sh->train], err, errlen) ||
                evaluate_colour_term(o->refine.colour_term, &c->img, &in->img, &colour, err,
                                     errlen)) {
                rc = -1;
                break;
            }
            dist[j] = evaluate_gram_distance(iw.in_desc[sh->train], c->desc[sh->train],
                                             w->offsets[sh->train], w->n_layers[sh->train]);
            loss[j] = pipeline_refine_loss(dist[j], colour, o->refine.start_colour_weight);
            pipeline_insert_by_key(order, j, dist);
            pipeline_insert_by_key(by_loss, j, loss);
        }
        if (rc)
            break;
        int best = order[0];
        r->start_index[m] = by_loss[0];
        n_ranked[m] = !methods[m].topk ? 1 : n < n_starts ? n : n_starts;
        for (int j = 0; j < n_ranked[m]; j++)
            memcpy(ranked + ((size_t)m * n_starts + j) * np, buf + (size_t)by_loss[j] * np,
                   np * sizeof(float));
        candidate *c = candidate_get(&iw, buf + (size_t)best * np, err, errlen);
        if (!c || distances(&iw, &c->img, c->desc, r->dist[m], err, errlen)) {
            rc = -1;
            break;
        }
        memcpy(r->chosen + (size_t)m * np, c->params, np * sizeof(float));
        r->chosen_index[m] = best;
        r->n_candidates[m] = n;
        r->chosen_id[m] = ids[best];
        if (in->sheet_row >= 0 && tile_of(sh, &c->img, &r->tiles[1 + m]))
            rc = pipeline_error(err, errlen, "out of memory");
    }

    /* The floor: the target's own parameters with the pattern moved (Pattern Offset + 0.5,
     * mod 1), or the hand-made material's render with shifted texture coordinates. */
    const image *floor_img = NULL;
    float *floor_desc[2] = {NULL, NULL};
    image floor_render = {0};
    if (rc == 0 && in->params) {
        memcpy(buf, in->params, np * sizeof(float));
        if (sh->offset_param >= 0)
            buf[sh->offset_param] = (float)fmod((double)buf[sh->offset_param] + 0.5, 1.0);
        rc = render_params(&iw, o->preset, buf, 0, &floor_render, err, errlen);
        floor_img = &floor_render;
    } else if (rc == 0)
        floor_img = &in->floor_img;
    float *ref_desc[2] = {NULL, NULL};
    if (rc == 0 && in->floor_ref.pixels)
        rc = pair_distances(w, &in->floor_ref, ref_desc, floor_img, floor_desc, r->floor, err,
                            errlen);
    else if (rc == 0)
        rc = distances(&iw, floor_img, floor_desc, r->floor, err, errlen);
    if (rc == 0 && in->sheet_row >= 0 &&
        (tile_of(sh, &in->img, &r->tiles[0]) || tile_of(sh, floor_img, &r->tiles[N_METHODS + 1])))
        rc = pipeline_error(err, errlen, "out of memory");
    for (int m = 0; m < N_METHODS && rc == 0; m++)
        for (int d = 0; d < N_DIST; d++)
            r->norm[m][d] = evaluate_normalise(r->dist[m][d], r->floor[d]);

    image_free(&floor_render);
    for (int k = 0; k < 2; k++) {
        free(floor_desc[k]);
        free(ref_desc[k]);
        free(iw.in_desc[k]);
    }
    for (int i = 0; i < iw.n_cands; i++) {
        free(iw.cands[i].params);
        image_free(&iw.cands[i].img);
        free(iw.cands[i].desc[0]);
        free(iw.cands[i].desc[1]);
    }
    free(iw.cands);
    render_scene_free(own);
    free(buf);
    free(ranked);
    r->seconds = pipeline_now() - t0;
    if (rc) {
        /* Prefixed with the input's name, the message cut to fit. */
        size_t pre = strlen(in->name) + 2, len = strlen(err);
        if (pre + len >= errlen)
            len = errlen - pre - 1;
        memmove(err + pre, err, len);
        err[pre + len] = 0;
        memcpy(err, in->name, pre - 2);
        err[pre - 2] = ':';
        err[pre - 1] = ' ';
    }
    return rc;
}

static void *worker_main(void *arg)
{
    worker *w = arg;
    shared *sh = w->sh;
    for (;;) {
        pthread_mutex_lock(&sh->lock);
        int i = (*w->next)++;
        pthread_mutex_unlock(&sh->lock);
        if (i >= w->n)
            break;
        if (evaluate_input(w, &w->inputs[i], &w->results[i]) < 0)
            w->results[i].failed = 1;
        pthread_mutex_lock(&sh->lock);
        sh->done++;
        if (sh->o->progress)
            sh->o->progress(sh->o->progress_ctx, sh->done, sh->todo, pipeline_now() - sh->t_start);
        pthread_mutex_unlock(&sh->lock);
    }
    return NULL;
}

static int worker_init(worker *w, shared *sh, char *err, size_t errlen)
{
    memset(w, 0, sizeof *w);
    w->sh = sh;
    char e[SG_ERROR_MAX] = "";
    if (!(w->graph = sg_graph_load_file(sh->graph_path, e, sizeof e)))
        return pipeline_error(err, errlen, "%s", e);
    if (sg_params_from_graph(w->graph, &w->params, e, sizeof e) < 0)
        return pipeline_error(err, errlen, "%s: %s", sh->graph_path, e);
    for (int k = 0; k < 2; k++) {
        if (!(w->desc[k] = pipeline_descriptor_create(gram_kinds[k], err, errlen)))
            return -1;
        w->n_layers[k] = pipeline_descriptor_layers(w->desc[k], w->offsets[k]);
        w->desc_size[k] = pipeline_descriptor_size(w->desc[k]);
    }
    return 0;
}

typedef struct worker_init_job {
    worker *w;
    shared *sh;
    int rc;
    char err[768];
} worker_init_job;

static void *worker_init_main(void *arg)
{
    worker_init_job *j = arg;
    j->rc = worker_init(j->w, j->sh, j->err, sizeof j->err);
    return NULL;
}

/* Every worker's graph and networks, made in parallel: VGG19's random weights take seconds
 * each (He-normal draws). On error every worker is still safe to free. */
static int workers_init(worker *workers, int n, shared *sh, char *err, size_t errlen)
{
    worker_init_job *jobs = calloc((size_t)n, sizeof *jobs);
    pthread_t *tid = calloc((size_t)n, sizeof *tid);
    int *started = calloc((size_t)n, sizeof *started);
    if (!jobs || !tid || !started) {
        free(jobs);
        free(tid);
        free(started);
        return pipeline_error(err, errlen, "out of memory");
    }
    for (int t = 0; t < n; t++) {
        jobs[t] = (worker_init_job){.w = &workers[t], .sh = sh};
        started[t] = t > 0 && pthread_create(&tid[t], NULL, worker_init_main, &jobs[t]) == 0;
    }
    for (int t = 0; t < n; t++)
        if (!started[t])
            worker_init_main(&jobs[t]); /* the caller's share, or a thread that did not start */
    int rc = 0;
    for (int t = 0; t < n; t++) {
        if (started[t])
            pthread_join(tid[t], NULL);
        if (jobs[t].rc && !rc)
            rc = pipeline_error(err, errlen, "%s", jobs[t].err);
    }
    free(jobs);
    free(tid);
    free(started);
    return rc;
}

static void worker_free(worker *w)
{
    sg_graph_free(w->graph);
    if (w->params.names)
        sg_params_free(&w->params);
    for (int k = 0; k < 2; k++)
        pipeline_descriptor_free(w->desc[k]);
}

/* Runs a batch of inputs over the workers (the calling thread is worker 0). */
static void run_batch(worker *workers, int n_workers, input *inputs, result *results, int n)
{
    int next = 0;
    pthread_t tid[256];
    int started = 1;
    for (int t = 0; t < n_workers && t < n; t++) {
        workers[t].inputs = inputs;
        workers[t].results = results;
        workers[t].n = n;
        workers[t].next = &next;
        if (t > 0) {
            if (pthread_create(&tid[t], NULL, worker_main, &workers[t]) != 0)
                break; /* fewer threads: the same work, the same bytes */
            started = t + 1;
        }
    }
    worker_main(&workers[0]);
    for (int t = 1; t < started; t++)
        pthread_join(tid[t], NULL);
}

/* ---------------------------------------------------------------- kept results ----- */

/* What the report needs of an input once its images are gone. */
typedef struct record {
    input_set set;
    char name[200];
    long long id;
    int view;
    char floor_source[64];
    float *target;   /* synthetic: n_params, else NULL */
    uint8_t *active;
    result r;        /* chosen, distances, tiles (sheet rows) */
} record;

typedef struct records {
    record *v;
    size_t n, cap;
} records;

static int records_add(records *rs, input *in, result *r)
{
    if (rs->n == rs->cap) {
        size_t cap = rs->cap ? 2 * rs->cap : 64;
        record *v = realloc(rs->v, cap * sizeof *v);
        if (!v)
            return -1;
        rs->v = v;
        rs->cap = cap;
    }
    record *rec = &rs->v[rs->n++];
    memset(rec, 0, sizeof *rec);
    rec->set = in->set;
    memcpy(rec->name, in->name, sizeof rec->name);
    memcpy(rec->floor_source, in->floor_source, sizeof rec->floor_source);
    rec->id = in->id;
    rec->view = in->view;
    rec->target = in->params; /* moved, not copied */
    rec->active = in->active;
    in->params = NULL;
    in->active = NULL;
    rec->r = *r;
    memset(r, 0, sizeof *r);
    return 0;
}

static void records_free(records *rs)
{
    for (size_t i = 0; i < rs->n; i++) {
        free(rs->v[i].target);
        free(rs->v[i].active);
        result_clear(&rs->v[i].r);
    }
    free(rs->v);
}

/* ---------------------------------------------------------------- summaries -------- */

typedef struct dist_summary {
    size_t n;
    double median, p10, p90, beats_mean, beats_nearest; /* shares in [0, 1] */
    double beats_mean_ci[2], beats_nearest_ci[2];       /* their 95% intervals */
} dist_summary;

static dist_summary summarise(const records *rs, input_set set, int m, int d)
{
    dist_summary s = {0};
    double *v = calloc(rs->n ? rs->n : 1, sizeof *v);
    if (!v) {
        s.median = s.p10 = s.p90 = s.beats_mean = s.beats_nearest = NAN;
        s.beats_mean_ci[0] = s.beats_mean_ci[1] = s.beats_nearest_ci[0] = NAN;
        s.beats_nearest_ci[1] = NAN;
        return s;
    }
    size_t beats_mean = 0, beats_nearest = 0;
    for (size_t i = 0; i < rs->n; i++) {
        const record *rec = &rs->v[i];
        if (rec->set != set)
            continue;
        v[s.n++] = rec->r.norm[m][d];
        beats_mean += rec->r.norm[m][d] < rec->r.norm[METHOD_MEAN][d];
        beats_nearest += rec->r.norm[m][d] < rec->r.norm[METHOD_NEAREST][d];
    }
    s.median = evaluate_quantile(v, s.n, 0.5);
    s.p10 = evaluate_quantile(v, s.n, 0.1);
    s.p90 = evaluate_quantile(v, s.n, 0.9);
    s.beats_mean = s.n ? (double)beats_mean / (double)s.n : NAN;
    s.beats_nearest = s.n ? (double)beats_nearest / (double)s.n : NAN;
    evaluate_share_interval(beats_mean, s.n, &s.beats_mean_ci[0], &s.beats_mean_ci[1]);
    evaluate_share_interval(beats_nearest, s.n, &s.beats_nearest_ci[0], &s.beats_nearest_ci[1]);
    free(v);
    return s;
}

/* A parameter's role, as the predictor's (pipeline_internal.h): ROLE_SELECTOR, ROLE_SEED
 * ("Pattern Offset") or ROLE_VALUE. */
static int role_of(const char *name)
{
    if (sg_param_mult_choices(name) >= 2)
        return ROLE_SELECTOR;
    return strcmp(name, "Pattern Offset") ? ROLE_VALUE : ROLE_SEED;
}

static int bin_of(float v, int choices)
{
    int b = (int)floorf(v * (float)choices);
    return b < 0 ? 0 : b >= choices ? choices - 1 : b;
}

/* One parameter's figures for one method over the rows of a set where it is active. */
typedef struct param_figures {
    size_t rows;
    double accuracy, majority; /* selectors: share right, share of the majority class */
    double r2, spread, corr;   /* values */
} param_figures;

/* majority_bin: per selector, the catalogue's most frequent class. */
static param_figures param_summary(const records *rs, input_set set, int m, int k, int choices,
                                   int majority_bin, double train_mean, size_t np)
{
    param_figures f = {0};
    f.accuracy = f.majority = f.r2 = f.spread = f.corr = NAN;
    double *pred = malloc((rs->n ? rs->n : 1) * sizeof *pred);
    double *truth = malloc((rs->n ? rs->n : 1) * sizeof *truth);
    if (!pred || !truth) {
        free(pred);
        free(truth);
        return f;
    }
    size_t right = 0, major = 0;
    for (size_t i = 0; i < rs->n; i++) {
        const record *rec = &rs->v[i];
        if (rec->set != set || !rec->target || !rec->active[k])
            continue;
        pred[f.rows] = rec->r.chosen[(size_t)m * np + (size_t)k];
        truth[f.rows] = rec->target[k];
        if (choices) {
            int t = bin_of((float)truth[f.rows], choices);
            right += bin_of((float)pred[f.rows], choices) == t;
            major += t == majority_bin;
        }
        f.rows++;
    }
    if (f.rows && choices) {
        f.accuracy = (double)right / (double)f.rows;
        f.majority = (double)major / (double)f.rows;
    } else if (f.rows) {
        f.r2 = evaluate_r2(pred, truth, f.rows, train_mean);
        f.spread = evaluate_spread(pred, truth, f.rows);
        f.corr = evaluate_correlation(pred, truth, f.rows);
    }
    free(pred);
    free(truth);
    return f;
}

/* ---------------------------------------------------------------- the report ------- */

typedef struct report_ctx {
    const evaluate_options *o;
    shared *sh;
    const records *rs;
    size_t set_count[N_SETS];
    int floors_small[N_SETS][N_DIST];
    int *majority_bin;      /* n_params (selectors only): the catalogue's most frequent class */
    double *majority_share; /* its share of the catalogue: the rate of always answering it */
    const char *model_config, *test_config;
    long long test_rows, test_samples, test_min_id, test_max_id;
    int stored_used, handmade_materials;
    const char *dir; /* the temporary folder */
} report_ctx;

/* The pattern selectors, whatever their choice count: "Mult N Noise X Pattern". */
static int is_pattern_selector(const char *name)
{
    size_t len = strlen(name), tail = strlen(" Pattern");
    return sg_param_mult_choices(name) > 0 && strstr(name, " Noise ") && len > tail &&
           !strcmp(name + len - tail, " Pattern");
}

static cJSON *number_or_null(double v) { return isfinite(v) ? cJSON_CreateNumber(v) : cJSON_CreateNull(); }

/* [lo, hi], or null when there were no inputs. */
static cJSON *interval_json(const double ci[2])
{
    if (isnan(ci[0]))
        return cJSON_CreateNull();
    cJSON *a = cJSON_CreateArray();
    cJSON_AddItemToArray(a, cJSON_CreateNumber(ci[0]));
    cJSON_AddItemToArray(a, cJSON_CreateNumber(ci[1]));
    return a;
}

static cJSON *distances_json(const double d[N_DIST])
{
    cJSON *o = cJSON_CreateObject();
    for (int k = 0; k < N_DIST; k++)
        cJSON_AddItemToObject(o, dist_names[k], number_or_null(d[k]));
    return o;
}

/* The targets of issue 15, each with its figure and whether it is met. A share of inputs
 * also has its 95% interval (evaluate_share_interval; NAN for the other figures): a share
 * met by its figure but not by its interval's lower end could be luck of the inputs. */
typedef struct target {
    char what[200];
    double figure, threshold, lo, hi;
    int met, known;
} target;

static int make_targets(const report_ctx *c, target *t, int max)
{
    int n = 0;
    const int pred = 4, topk = 5;
    for (int i = 0; i < max; i++)
        t[i].lo = t[i].hi = NAN;
    for (int s = SET_SYNTHETIC; s <= SET_HANDMADE && n + 2 <= max; s += SET_HANDMADE) {
        double need = s == SET_SYNTHETIC ? 0.95 : 0.80;
        for (int d = DIST_MOBILENET; d <= DIST_VGG; d++) {
            dist_summary ds = summarise(c->rs, (input_set)s, pred, d);
            snprintf(t[n].what, sizeof t[n].what,
                     "predictor beats the mean on %s inputs (%s distance)", set_names[s],
                     dist_names[d]);
            t[n].figure = ds.beats_mean;
            t[n].lo = ds.beats_mean_ci[0];
            t[n].hi = ds.beats_mean_ci[1];
            t[n].threshold = need;
            t[n].known = ds.n > 0;
            t[n].met = t[n].known && ds.beats_mean >= need;
            n++;
        }
    }
    size_t np = (size_t)c->sh->n_params;
    for (int k = 0; k < c->sh->n_params && n < max; k++) {
        if (!is_pattern_selector(c->sh->names[k]))
            continue;
        param_figures f = param_summary(c->rs, SET_SYNTHETIC, pred, k,
                                        sg_param_mult_choices(c->sh->names[k]), c->majority_bin[k],
                                        c->sh->mean[k], np);
        snprintf(t[n].what, sizeof t[n].what,
                 "%s: accuracy / majority-class rate (the catalogue's)", c->sh->names[k]);
        t[n].figure = c->majority_share[k] > 0 ? f.accuracy / c->majority_share[k] : NAN;
        t[n].threshold = 2.0;
        t[n].known = isfinite(t[n].figure);
        t[n].met = t[n].known && t[n].figure >= 2.0;
        n++;
    }
    /* Median R^2 and spread over the value parameters. */
    double *r2 = malloc(np * sizeof *r2), *sp = malloc(np * sizeof *sp);
    double *co = malloc(np * sizeof *co);
    size_t nv = 0;
    for (size_t k = 0; r2 && sp && co && k < np; k++) {
        if (role_of(c->sh->names[k]) != ROLE_VALUE)
            continue;
        param_figures f = param_summary(c->rs, SET_SYNTHETIC, pred, (int)k, 0, 0, c->sh->mean[k], np);
        r2[nv] = f.r2;
        co[nv] = f.corr;
        sp[nv++] = f.spread;
    }
    if (n + 4 <= max) {
        snprintf(t[n].what, sizeof t[n].what, "predictor: median R^2 over active value parameters");
        t[n].figure = r2 ? evaluate_quantile(r2, nv, 0.5) : NAN;
        t[n].threshold = 0.3;
        t[n].known = isfinite(t[n].figure);
        t[n].met = t[n].known && t[n].figure >= 0.3;
        n++;
        snprintf(t[n].what, sizeof t[n].what, "predictor: median spread (std pred / std target)");
        t[n].figure = sp ? evaluate_quantile(sp, nv, 0.5) : NAN;
        t[n].threshold = 0.7;
        t[n].known = isfinite(t[n].figure);
        t[n].met = t[n].known && t[n].figure >= 0.7;
        n++;
        /* Not a target of its own: what the two above need together (evaluate_correlation).
         * It tells a predictor that shrinks to the mean because it knows little (spread
         * near its correlation) from one that could be rescaled. */
        snprintf(t[n].what, sizeof t[n].what,
                 "predictor: median correlation with the target (R^2 0.3 with spread 0.7 "
                 "needs 0.564)");
        t[n].figure = co ? evaluate_quantile(co, nv, 0.5) : NAN;
        t[n].threshold = 0.564;
        t[n].known = isfinite(t[n].figure);
        t[n].met = t[n].known && t[n].figure >= 0.564;
        n++;
        dist_summary ds = summarise(c->rs, SET_SYNTHETIC, topk, c->sh->train);
        snprintf(t[n].what, sizeof t[n].what,
                 "predictor-topk beats nearest on synthetic inputs (%s, the training distance)",
                 dist_names[c->sh->train]);
        t[n].figure = ds.beats_nearest;
        t[n].lo = ds.beats_nearest_ci[0];
        t[n].hi = ds.beats_nearest_ci[1];
        t[n].threshold = 0.6;
        t[n].known = ds.n > 0;
        t[n].met = t[n].known && ds.beats_nearest >= 0.6;
        n++;
    }
    free(r2);
    free(sp);
    free(co);
    return n;
}

static int write_text(const char *dir, const char *name, const char *text, char *err,
                      size_t errlen)
{
    char path[1400];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    if (!f)
        return pipeline_error(err, errlen, "%s: cannot create: %s", path, strerror(errno));
    size_t len = strlen(text);
    errno = 0;
    int ok = fwrite(text, 1, len, f) == len;
    ok = fclose(f) == 0 && ok;
    return ok ? 0 : pipeline_error(err, errlen, "%s: write failed: %s", path,
                                   strerror(errno ? errno : EIO));
}

/* A growing string (the CSV, markdown and HTML are built in memory: they are small). */
typedef struct strbuf {
    char *s;
    size_t len, cap;
    int failed;
} strbuf;

static void sb_printf(strbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void sb_printf(strbuf *b, const char *fmt, ...)
{
    if (b->failed)
        return;
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        int n = vsnprintf(b->s ? b->s + b->len : NULL, b->s ? b->cap - b->len : 0, fmt, ap);
        va_end(ap);
        if (n < 0) {
            b->failed = 1;
            return;
        }
        if (b->s && b->len + (size_t)n < b->cap) {
            b->len += (size_t)n;
            return;
        }
        size_t cap = b->cap ? b->cap : 4096;
        while (cap <= b->len + (size_t)n)
            cap *= 2;
        char *s = realloc(b->s, cap);
        if (!s) {
            b->failed = 1;
            return;
        }
        b->s = s;
        b->cap = cap;
    }
}

static const char *fmt_num(char buf[32], double v, const char *spec)
{
    if (!isfinite(v))
        return "-";
    snprintf(buf, 32, spec, v);
    return buf;
}

static cJSON *report_json(const report_ctx *c)
{
    const shared *sh = c->sh;
    const evaluate_options *o = c->o;
    size_t np = (size_t)sh->n_params;
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "format", "imsynth-evaluation/1");
    cJSON *cmd = cJSON_AddObjectToObject(root, "settings");
    cJSON_AddStringToObject(cmd, "model", o->model_dir);
    cJSON_AddStringToObject(cmd, "test", o->test_path ? o->test_path : "");
    cJSON_AddStringToObject(cmd, "handmade", o->handmade_dir ? o->handmade_dir : "");
    cJSON_AddStringToObject(cmd, "preset", o->preset->name);
    cJSON_AddStringToObject(cmd, "refine_preset", refine_preset(o)->name);
    cJSON_AddNumberToObject(cmd, "top_k", o->top_k);
    cJSON_AddNumberToObject(cmd, "sample_hypotheses", o->sample_hypotheses);
    cJSON_AddStringToObject(cmd, "nearest_metric", predictor_metric_names[o->nearest_metric]);
    cJSON_AddStringToObject(cmd, "refine_method", refine_method_names[o->refine.method]);
    cJSON_AddNumberToObject(cmd, "refine_budget", o->refine.budget);
    cJSON_AddNumberToObject(cmd, "colour_weight", o->refine.colour_weight);
    cJSON_AddStringToObject(cmd, "colour_term", pipeline_colour_term_names[o->refine.colour_term]);
    cJSON_AddNumberToObject(cmd, "start_colour_weight", o->refine.start_colour_weight);
    cJSON_AddNumberToObject(cmd, "colour_phase", o->refine.colour_phase);
    cJSON_AddNumberToObject(cmd, "colour_phase_weight", o->refine.colour_phase_weight);
    cJSON_AddNumberToObject(cmd, "starts", o->refine.starts);
    cJSON_AddNumberToObject(cmd, "limit", (double)o->limit);
    cJSON_AddNumberToObject(cmd, "seed", (double)o->seed);
    cJSON_AddNumberToObject(cmd, "blender", o->blender);
    cJSON *model = cJSON_AddObjectToObject(root, "model");
    cJSON_AddStringToObject(model, "descriptor", dist_names[sh->train]);
    cJSON_AddNumberToObject(model, "catalogue_size", (double)sh->catalogue_size);
    cJSON_AddItemToObject(model, "dataset_config", cJSON_Parse(c->model_config ? c->model_config : "null"));
    /* What the model is (model.json's network, input transform, training settings, figures). */
    char mj_path[1200];
    snprintf(mj_path, sizeof mj_path, "%s/model.json", o->model_dir);
    size_t mj_len;
    char *mj = pipeline_read_file(mj_path, &mj_len, NULL, 0);
    cJSON *mjo = mj ? cJSON_Parse(mj) : NULL;
    free(mj);
    static const char *const model_keys[] = {"format", "network", "transform", "training", "result"};
    for (size_t k = 0; mjo && k < sizeof model_keys / sizeof *model_keys; k++) {
        cJSON *item = cJSON_GetObjectItemCaseSensitive(mjo, model_keys[k]);
        if (item)
            cJSON_AddItemToObject(model, model_keys[k], cJSON_Duplicate(item, 1));
    }
    cJSON_Delete(mjo);
    cJSON *test = cJSON_AddObjectToObject(root, "test");
    cJSON_AddNumberToObject(test, "rows", (double)c->test_rows);
    cJSON_AddNumberToObject(test, "samples", (double)c->test_samples);
    cJSON_AddNumberToObject(test, "min_id", (double)c->test_min_id);
    cJSON_AddNumberToObject(test, "max_id", (double)c->test_max_id);
    cJSON_AddBoolToObject(test, "stored_descriptors_read", c->stored_used);
    cJSON_AddItemToObject(test, "config", c->test_config ? cJSON_Parse(c->test_config) : cJSON_CreateNull());
    cJSON_AddNumberToObject(root, "handmade_materials", c->handmade_materials);

    cJSON *dd = cJSON_AddObjectToObject(root, "distances");
    cJSON_AddStringToObject(dd, "training", dist_names[sh->train]);
    cJSON_AddStringToObject(dd, "judge", dist_names[sh->train == DIST_VGG ? DIST_MOBILENET : DIST_VGG]);
    cJSON_AddStringToObject(dd, "gram", "mean over layers of ||a_l - b_l|| / (||a_l|| + ||b_l|| + 1e-12)");
    cJSON_AddStringToObject(dd, "colour", "mean |a - b| of 32x32 box averages of the centre 224 crops, linear RGB clamped to [0,1]");
    cJSON_AddStringToObject(dd, "colour-sorted",
                            "the same box averages projected on R, G, B, (R-G)/2, (G-B)/2, (B-R)/2, "
                            "each projection's sorted values compared (mean |a - b|), averaged");
    cJSON_AddStringToObject(dd, "normalised", "distance / max(floor, epsilon)");
    cJSON_AddNumberToObject(dd, "floor_epsilon", EVALUATE_FLOOR_EPSILON);

    cJSON *ms = cJSON_AddArrayToObject(root, "methods");
    for (int m = 0; m < N_METHODS; m++) {
        cJSON *e = cJSON_CreateObject();
        cJSON_AddStringToObject(e, "name", methods[m].name);
        cJSON_AddStringToObject(e, "what", methods[m].what);
        cJSON_AddItemToArray(ms, e);
    }

    cJSON *sets = cJSON_AddObjectToObject(root, "sets");
    for (int s = 0; s < N_SETS; s++) {
        if (!c->set_count[s])
            continue;
        cJSON *so = cJSON_AddObjectToObject(sets, set_names[s]);
        cJSON_AddNumberToObject(so, "inputs", (double)c->set_count[s]);
        cJSON *fs = cJSON_AddObjectToObject(so, "floors_below_epsilon");
        for (int d = 0; d < N_DIST; d++)
            cJSON_AddNumberToObject(fs, dist_names[d], c->floors_small[s][d]);
        cJSON *sm = cJSON_AddObjectToObject(so, "image_space");
        for (int m = 0; m < N_METHODS; m++) {
            cJSON *mo = cJSON_AddObjectToObject(sm, methods[m].name);
            for (int d = 0; d < N_DIST; d++) {
                dist_summary ds = summarise(c->rs, (input_set)s, m, d);
                cJSON *x = cJSON_AddObjectToObject(mo, dist_names[d]);
                cJSON_AddItemToObject(x, "median", number_or_null(ds.median));
                cJSON_AddItemToObject(x, "p10", number_or_null(ds.p10));
                cJSON_AddItemToObject(x, "p90", number_or_null(ds.p90));
                cJSON_AddItemToObject(x, "beats_mean", number_or_null(ds.beats_mean));
                cJSON_AddItemToObject(x, "beats_nearest", number_or_null(ds.beats_nearest));
                cJSON_AddItemToObject(x, "beats_mean_interval95", interval_json(ds.beats_mean_ci));
                cJSON_AddItemToObject(x, "beats_nearest_interval95",
                                      interval_json(ds.beats_nearest_ci));
            }
        }
        if (s != SET_SYNTHETIC && s != SET_AUGMENTED)
            continue;
        cJSON *ps = cJSON_AddObjectToObject(so, "parameter_space");
        for (int m = 0; m < N_METHODS; m++) {
            cJSON *mo = cJSON_AddObjectToObject(ps, methods[m].name);
            cJSON *sel = cJSON_AddArrayToObject(mo, "selectors");
            cJSON *val = cJSON_AddArrayToObject(mo, "values");
            for (size_t k = 0; k < np; k++) {
                int role = role_of(sh->names[k]);
                if (role == ROLE_SEED)
                    continue;
                int choices = role == ROLE_SELECTOR ? sg_param_mult_choices(sh->names[k]) : 0;
                param_figures f = param_summary(c->rs, (input_set)s, m, (int)k, choices,
                                                c->majority_bin[k], sh->mean[k], np);
                cJSON *e = cJSON_CreateObject();
                cJSON_AddStringToObject(e, "name", sh->names[k]);
                cJSON_AddNumberToObject(e, "rows", (double)f.rows);
                if (choices) {
                    cJSON_AddItemToObject(e, "accuracy", number_or_null(f.accuracy));
                    cJSON_AddItemToObject(e, "majority_train", number_or_null(c->majority_share[k]));
                    cJSON_AddItemToObject(e, "majority_test", number_or_null(f.majority));
                    cJSON_AddItemToArray(sel, e);
                } else {
                    cJSON_AddItemToObject(e, "r2", number_or_null(f.r2));
                    cJSON_AddItemToObject(e, "spread", number_or_null(f.spread));
                    cJSON_AddItemToObject(e, "correlation", number_or_null(f.corr));
                    cJSON_AddItemToArray(val, e);
                }
            }
        }
    }

    target t[16];
    int nt = make_targets(c, t, 16);
    cJSON *ts = cJSON_AddArrayToObject(root, "targets");
    for (int i = 0; i < nt; i++) {
        cJSON *e = cJSON_CreateObject();
        cJSON_AddStringToObject(e, "what", t[i].what);
        cJSON_AddItemToObject(e, "figure", number_or_null(t[i].figure));
        cJSON_AddNumberToObject(e, "threshold", t[i].threshold);
        if (!isnan(t[i].lo))
            cJSON_AddItemToObject(e, "interval95", interval_json((double[2]){t[i].lo, t[i].hi}));
        cJSON_AddStringToObject(e, "status", !t[i].known ? "no data" : t[i].met ? "met" : "not met");
        cJSON_AddItemToArray(ts, e);
    }

    cJSON *ins = cJSON_AddArrayToObject(root, "inputs");
    for (size_t i = 0; i < c->rs->n; i++) {
        const record *rec = &c->rs->v[i];
        cJSON *e = cJSON_CreateObject();
        cJSON_AddStringToObject(e, "set", set_names[rec->set]);
        cJSON_AddStringToObject(e, "name", rec->name);
        if (rec->target) {
            cJSON_AddNumberToObject(e, "id", (double)rec->id);
            cJSON_AddNumberToObject(e, "view", rec->view);
        }
        cJSON_AddStringToObject(e, "floor_source", rec->floor_source);
        cJSON_AddNumberToObject(e, "renders", rec->r.renders);
        cJSON_AddItemToObject(e, "floor", distances_json(rec->r.floor));
        cJSON *mo = cJSON_AddObjectToObject(e, "methods");
        for (int m = 0; m < N_METHODS; m++) {
            cJSON *x = cJSON_AddObjectToObject(mo, methods[m].name);
            cJSON_AddNumberToObject(x, "candidates", rec->r.n_candidates[m]);
            cJSON_AddNumberToObject(x, "chosen", rec->r.chosen_index[m]);
            if (methods[m].refines)
                cJSON_AddNumberToObject(x, "start", rec->r.start_index[m]);
            if (rec->r.chosen_id[m] >= 0)
                cJSON_AddNumberToObject(x, "catalogue_id", (double)rec->r.chosen_id[m]);
            cJSON_AddItemToObject(x, "raw", distances_json(rec->r.dist[m]));
            cJSON_AddItemToObject(x, "normalised", distances_json(rec->r.norm[m]));
            cJSON_AddItemToObject(x, "params",
                                  cJSON_CreateFloatArray(rec->r.chosen + (size_t)m * np, (int)np));
        }
        cJSON_AddItemToArray(ins, e);
    }
    return root;
}

static void summary_tables(const report_ctx *c, strbuf *csv, strbuf *md)
{
    const shared *sh = c->sh;
    size_t np = (size_t)sh->n_params;
    char a[32], b[32], d3[32], e[32], f[32];
    sb_printf(csv, "set,method,distance,inputs,median,p10,p90,beats_mean,beats_nearest,"
                   "beats_mean_lo95,beats_mean_hi95,beats_nearest_lo95,beats_nearest_hi95\n");
    sb_printf(md, "## Image space\n\nNormalised distances (distance / the target's floor; 1 = as "
                  "close as two renders of the target itself at other pattern offsets). "
                  "Gram distance (mobilenetv2, vgg19): the mean over the descriptor's layers of "
                  "||a_l - b_l|| / (||a_l|| + ||b_l||); colour: mean |a - b| of the 32x32 box "
                  "averages of the centre 224 crops (linear RGB in [0, 1]); colour-sorted: "
                  "the same boxes compared as distributions (each of R, G, B and half of R-G, "
                  "G-B, B-R sorted, mean |a - b|, averaged: blind to where the colours are); "
                  "a floor below %g counts as %g. Training descriptor: %s; judge: %s.\n",
              EVALUATE_FLOOR_EPSILON, EVALUATE_FLOOR_EPSILON,
              dist_names[sh->train], dist_names[sh->train == DIST_VGG ? DIST_MOBILENET : DIST_VGG]);
    for (int s = 0; s < N_SETS; s++) {
        if (!c->set_count[s])
            continue;
        sb_printf(md, "\n### %s (%zu inputs; floors below epsilon:", set_names[s], c->set_count[s]);
        for (int d = 0; d < N_DIST; d++)
            sb_printf(md, "%s %d %s", d ? "," : "", c->floors_small[s][d], dist_names[d]);
        sb_printf(md, ")\n\n");
        sb_printf(md, "| method | distance | median | p10 | p90 | beats mean | beats nearest |\n"
                      "|---|---|---|---|---|---|---|\n");
        for (int m = 0; m < N_METHODS; m++)
            for (int d = 0; d < N_DIST; d++) {
                dist_summary ds = summarise(c->rs, (input_set)s, m, d);
                sb_printf(csv, "%s,%s,%s,%zu,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n",
                          set_names[s], methods[m].name, dist_names[d], ds.n, ds.median, ds.p10,
                          ds.p90, ds.beats_mean, ds.beats_nearest, ds.beats_mean_ci[0],
                          ds.beats_mean_ci[1], ds.beats_nearest_ci[0], ds.beats_nearest_ci[1]);
                sb_printf(md, "| %s | %s%s | %s | %s | %s | %s | %s |\n", methods[m].name,
                          dist_names[d], d == sh->train ? " (train)" : "",
                          fmt_num(a, ds.median, "%.3f"), fmt_num(b, ds.p10, "%.3f"),
                          fmt_num(d3, ds.p90, "%.3f"), fmt_num(e, 100 * ds.beats_mean, "%.0f%%"),
                          fmt_num(f, 100 * ds.beats_nearest, "%.0f%%"));
            }
    }
    sb_printf(csv, "\nset,method,parameter,role,rows,accuracy,majority_train,majority_test,r2,"
                   "spread,correlation\n");
    for (int s = SET_SYNTHETIC; s <= SET_AUGMENTED; s++) {
        if (!c->set_count[s])
            continue;
        sb_printf(md, "\n## Parameter space: %s\n\nSelectors: accuracy, beside the majority "
                      "class's share of the catalogue and of these rows; values: R^2 about the "
                      "training mean (spread = std pred / std target); over the rows where the "
                      "parameter is active.\n\n| parameter | rows | majority train/test |",
                  set_names[s]);
        for (int m = 0; m < N_METHODS; m++)
            sb_printf(md, " %s |", methods[m].name);
        sb_printf(md, "\n|---|---|---|");
        for (int m = 0; m < N_METHODS; m++)
            sb_printf(md, "---|");
        sb_printf(md, "\n");
        double *r2[N_METHODS], *sp[N_METHODS];
        size_t nv = 0;
        for (int m = 0; m < N_METHODS; m++) {
            r2[m] = malloc(np * sizeof(double));
            sp[m] = malloc(np * sizeof(double));
        }
        for (size_t k = 0; k < np; k++) {
            int role = role_of(sh->names[k]);
            if (role == ROLE_SEED)
                continue;
            int choices = role == ROLE_SELECTOR ? sg_param_mult_choices(sh->names[k]) : 0;
            size_t rows = 0;
            double majority_test = NAN;
            strbuf cells = {0};
            for (int m = 0; m < N_METHODS; m++) {
                param_figures pf = param_summary(c->rs, (input_set)s, m, (int)k, choices,
                                                 c->majority_bin[k], sh->mean[k], np);
                rows = pf.rows;
                sb_printf(csv, "%s,%s,%s,%s,%zu,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n", set_names[s],
                          methods[m].name, sh->names[k], choices ? "selector" : "value", pf.rows,
                          pf.accuracy, choices ? c->majority_share[k] : NAN, pf.majority, pf.r2,
                          pf.spread, pf.corr);
                if (choices) {
                    sb_printf(&cells, " %s |", fmt_num(a, pf.accuracy, "%.2f"));
                    majority_test = pf.majority;
                }
                else {
                    sb_printf(&cells, " %s (%s) |", fmt_num(a, pf.r2, "%.2f"),
                              fmt_num(b, pf.spread, "%.2f"));
                    if (r2[m] && sp[m]) {
                        r2[m][nv] = pf.r2;
                        sp[m][nv] = pf.spread;
                    }
                }
            }
            if (!choices)
                nv++;
            char maj[64] = "";
            if (choices)
                snprintf(maj, sizeof maj, "%.2f/%s", c->majority_share[k],
                         fmt_num(a, majority_test, "%.2f"));
            sb_printf(md, "| %s | %zu | %s |%s\n", sh->names[k], rows, maj, cells.s ? cells.s : "");
            free(cells.s);
        }
        sb_printf(md, "| **median R^2 (spread) of values** | | |");
        for (int m = 0; m < N_METHODS; m++) {
            sb_printf(md, " %s (%s) |",
                      fmt_num(a, r2[m] ? evaluate_quantile(r2[m], nv, 0.5) : NAN, "%.2f"),
                      fmt_num(b, sp[m] ? evaluate_quantile(sp[m], nv, 0.5) : NAN, "%.2f"));
            free(r2[m]);
            free(sp[m]);
        }
        sb_printf(md, "\n");
    }
    target t[16];
    int nt = make_targets(c, t, 16);
    sb_printf(md, "\n## Targets (issue 15)\n\nA share of inputs has its 95%% interval (Wilson's): "
                  "the range the share over all inputs like these could have, given how few "
                  "were measured. It does not include the variation between training runs.\n\n"
                  "| target | figure | 95%% interval | needed | status |\n|---|---|---|---|---|\n");
    for (int i = 0; i < nt; i++) {
        char ci[64] = "";
        if (!isnan(t[i].lo))
            snprintf(ci, sizeof ci, "%.3f - %.3f", t[i].lo, t[i].hi);
        sb_printf(md, "| %s | %s | %s | %.2f | %s |\n", t[i].what,
                  fmt_num(a, t[i].figure, "%.3f"), ci, t[i].threshold,
                  !t[i].known ? "no data" : t[i].met ? "met" : "NOT met");
    }
}

/* A contact sheet: a header row of column names, then one row per input: input | each
 * method's render (labelled with its normalised training distance) | the floor's image. */
static int write_sheet(const report_ctx *c, int handmade, const char *path, char *err,
                       size_t errlen)
{
    const shared *sh = c->sh;
    int tile = sh->tile, cols = N_METHODS + 2, header = 20, rows = 0;
    for (size_t i = 0; i < c->rs->n; i++)
        rows += c->rs->v[i].r.tiles[0].pixels &&
                (c->rs->v[i].set >= SET_HANDMADE) == (handmade != 0);
    if (!rows)
        return 0;
    image sheet;
    if (image_alloc(&sheet, cols * tile, header + rows * tile, 3))
        return pipeline_error(err, errlen, "out of memory for a contact sheet");
    for (int col = 0; col < cols; col++) {
        const char *name = col == 0 ? "input" : col <= N_METHODS ? methods[col - 1].name : "floor";
        pipeline_sheet_label(&sheet, col * tile + 2, 2, name, 2);
    }
    int row = 0;
    for (size_t i = 0; i < c->rs->n; i++) {
        const record *rec = &c->rs->v[i];
        if (!rec->r.tiles[0].pixels || (rec->set >= SET_HANDMADE) != (handmade != 0))
            continue;
        int oy = header + row * tile;
        for (int col = 0; col < cols; col++) {
            if (pipeline_sheet_paste(&sheet, &rec->r.tiles[col], col * tile, oy, tile)) {
                image_free(&sheet);
                return pipeline_error(err, errlen, "out of memory");
            }
            char label[64];
            if (col == 0) /* a name cut to what a tile shows */
                snprintf(label, sizeof label, "%.30s", rec->name);
            else if (col <= N_METHODS)
                snprintf(label, sizeof label, "%.2f", rec->r.norm[col - 1][sh->train]);
            else
                snprintf(label, sizeof label, "%.3f", rec->r.floor[sh->train]);
            pipeline_sheet_label(&sheet, col * tile + 2, oy + tile - 16, label, 2);
        }
        row++;
    }
    char msg[768];
    int rc = image_write_png(path, &sheet, msg, sizeof msg);
    image_free(&sheet);
    return rc ? pipeline_error(err, errlen, "%s", msg) : 0;
}

/* Markdown tables to HTML: only what summary_tables writes (headings, paragraphs, pipe
 * tables), escaped. */
static void md_to_html(const char *md, strbuf *h)
{
    const char *p = md;
    int in_table = 0;
    while (*p) {
        const char *eol = strchr(p, '\n');
        size_t n = eol ? (size_t)(eol - p) : strlen(p);
        char line[2048];
        if (n >= sizeof line)
            n = sizeof line - 1;
        memcpy(line, p, n);
        line[n] = 0;
        p += n + (eol ? 1 : 0);
        if (in_table && line[0] != '|') {
            sb_printf(h, "</table>\n");
            in_table = 0;
        }
        if (!line[0])
            continue;
        if (line[0] == '|') {
            if (strstr(line, "|---"))
                continue;
            sb_printf(h, in_table ? "<tr>" : "<table>\n<tr>");
            const char *tag = in_table ? "td" : "th";
            in_table = 1;
            char *save = NULL;
            for (char *cell = strtok_r(line, "|", &save); cell; cell = strtok_r(NULL, "|", &save)) {
                sb_printf(h, "<%s>", tag);
                for (char *q = cell; *q; q++)
                    if (*q == '<')
                        sb_printf(h, "&lt;");
                    else if (*q == '>')
                        sb_printf(h, "&gt;");
                    else if (*q == '&')
                        sb_printf(h, "&amp;");
                    else if (*q != '*')
                        sb_printf(h, "%c", *q);
                sb_printf(h, "</%s>", tag);
            }
            sb_printf(h, "</tr>\n");
            continue;
        }
        int level = 0;
        while (line[level] == '#')
            level++;
        const char *text = line + level + (level ? 1 : 0);
        sb_printf(h, level ? "<h%d>" : "<p>", level + 1);
        for (const char *q = text; *q; q++)
            if (*q == '<')
                sb_printf(h, "&lt;");
            else if (*q == '&')
                sb_printf(h, "&amp;");
            else
                sb_printf(h, "%c", *q);
        sb_printf(h, level ? "</h%d>\n" : "</p>\n", level + 1);
    }
    if (in_table)
        sb_printf(h, "</table>\n");
}

/* A CSV field: as it is, or quoted (quotes doubled) when it holds a comma or a quote. */
static const char *csv_field(const char *s, char *buf, size_t len)
{
    if (!strpbrk(s, ",\"\n"))
        return s;
    size_t k = 0;
    buf[k++] = '"';
    for (; *s && k + 3 < len; s++) {
        if (*s == '"')
            buf[k++] = '"';
        buf[k++] = *s == '\n' ? ' ' : *s;
    }
    buf[k++] = '"';
    buf[k] = 0;
    return buf;
}

static const char *const report_files[] = {"report.json",         "summary.csv",
                                           "summary.md",          "sheet-synthetic.png",
                                           "sheet-handmade.png",  "index.html",
                                           "inputs.csv",          "timings.json"};

static int write_report(const report_ctx *c, char *err, size_t errlen)
{
    cJSON *root = report_json(c);
    char *json = root ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (!json)
        return pipeline_error(err, errlen, "out of memory for report.json");
    int rc = write_text(c->dir, "report.json", json, err, errlen);
    free(json);
    strbuf csv = {0}, md = {0}, html = {0};
    sb_printf(&md, "# imsynth evaluate\n\nModel %s (%s descriptor, catalogue of %zu); ",
              c->o->model_dir, dist_names[c->sh->train], c->sh->catalogue_size);
    if (c->o->test_path)
        sb_printf(&md, "test %s (%lld rows of %lld samples, ids %lld-%lld); ", c->o->test_path,
                  c->test_rows, c->test_samples, c->test_min_id, c->test_max_id);
    if (c->o->handmade_dir)
        sb_printf(&md, "hand-made %s (%d materials); ", c->o->handmade_dir,
                  c->handmade_materials);
    sb_printf(&md, "preset %s (refinement %s), top-k %d, seed %llu.\n\n", c->o->preset->name,
              refine_preset(c->o)->name, c->o->top_k, (unsigned long long)c->o->seed);
    summary_tables(c, &csv, &md);
    if (csv.failed || md.failed)
        rc = rc ? rc : pipeline_error(err, errlen, "out of memory for the summary");
    if (rc == 0)
        rc = write_text(c->dir, "summary.csv", csv.s, err, errlen);
    if (rc == 0)
        rc = write_text(c->dir, "summary.md", md.s, err, errlen);
    if (rc == 0) {
        /* Every input, method and distance in one table, for spreadsheets and scripts. */
        strbuf rows = {0};
        char field[2 * sizeof c->rs->v[0].name + 3];
        sb_printf(&rows, "set,input,method,distance,raw,floor,normalised,candidates,chosen\n");
        for (size_t i = 0; i < c->rs->n; i++) {
            const record *rec = &c->rs->v[i];
            for (int m = 0; m < N_METHODS; m++)
                for (int d = 0; d < N_DIST; d++)
                    sb_printf(&rows, "%s,%s,%s,%s,%.9g,%.9g,%.9g,%d,%d\n", set_names[rec->set],
                              csv_field(rec->name, field, sizeof field), methods[m].name, dist_names[d], rec->r.dist[m][d],
                              rec->r.floor[d], rec->r.norm[m][d], rec->r.n_candidates[m],
                              rec->r.chosen_index[m]);
        }
        rc = rows.failed ? pipeline_error(err, errlen, "out of memory for inputs.csv")
                         : write_text(c->dir, "inputs.csv", rows.s, err, errlen);
        free(rows.s);
    }
    char path[1400];
    int sheets[2] = {0, 0};
    for (int hm = 0; hm < 2 && rc == 0; hm++) {
        snprintf(path, sizeof path, "%s/%s", c->dir, report_files[3 + hm]);
        rc = write_sheet(c, hm, path, err, errlen);
        sheets[hm] = access(path, F_OK) == 0;
    }
    if (rc == 0) {
        sb_printf(&html, "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>imsynth "
                         "evaluate</title><style>body{font-family:sans-serif;margin:2em}table{"
                         "border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;"
                         "padding:2px 6px;text-align:right}td:first-child{text-align:left}"
                         "img{max-width:100%%}</style></head><body>\n");
        md_to_html(md.s, &html);
        for (int hm = 0; hm < 2; hm++)
            if (sheets[hm])
                sb_printf(&html, "<h2>Contact sheet: %s inputs</h2>\n<p>input | each method's "
                                 "render (its normalised %s distance) | the floor's image (its "
                                 "raw distance)</p>\n<img src=\"%s\">\n",
                          hm ? "hand-made" : "synthetic", dist_names[c->sh->train],
                          report_files[3 + hm]);
        sb_printf(&html, "<p>Raw figures: <a href=\"report.json\">report.json</a>, "
                         "<a href=\"summary.csv\">summary.csv</a>, <a href=\"inputs.csv\">"
                         "inputs.csv</a>.</p>\n</body></html>\n");
        rc = html.failed ? pipeline_error(err, errlen, "out of memory for index.html")
                         : write_text(c->dir, "index.html", html.s, err, errlen);
    }
    free(csv.s);
    free(md.s);
    free(html.s);
    return rc;
}

/* ---------------------------------------------------------------- inputs ----------- */

static int check_image(const char *path, const image *img, const shared *sh, char *err,
                       size_t errlen)
{
    if (img->width != sh->width || img->height != sh->height)
        return pipeline_error(err, errlen, "%s: %d x %d, the scene renders %d x %d", path,
                              img->width, img->height, sh->width, sh->height);
    size_t n = (size_t)img->width * (size_t)img->height * (size_t)img->channels;
    for (size_t i = 0; i < n; i++)
        if (!isfinite(img->pixels[i]))
            return pipeline_error(err, errlen, "%s: pixel (%zu, %zu) channel %zu is not finite",
                                  path, i / (size_t)img->channels % (size_t)img->width,
                                  i / (size_t)img->channels / (size_t)img->width,
                                  i % (size_t)img->channels);
    return 0;
}

static int image_copy(image *dst, const image *src)
{
    if (image_alloc(dst, src->width, src->height, src->channels))
        return -1;
    memcpy(dst->pixels, src->pixels,
           (size_t)src->width * (size_t)src->height * (size_t)src->channels * sizeof(float));
    return 0;
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* The hand-made inputs: every <dir>/<name>/ holding render.exr (and shifted.exr, needed for
 * its floor), plus flash.exr as a second input when present, in name order. */
static int load_handmade(const char *dir, const shared *sh, input **out, int *n_out,
                         int *materials, char *err, size_t errlen)
{
    *out = NULL;
    *n_out = *materials = 0;
    DIR *d = opendir(dir);
    if (!d)
        return pipeline_error(err, errlen, "%s: cannot open: %s", dir, strerror(errno));
    char **names = NULL;
    size_t n = 0, cap = 0;
    struct dirent *e;
    int rc = 0;
    while ((e = readdir(d)) && rc == 0) {
        if (e->d_name[0] == '.')
            continue;
        char path[1400];
        snprintf(path, sizeof path, "%s/%s/render.exr", dir, e->d_name);
        if (access(path, F_OK) != 0)
            continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 16;
            char **v = realloc(names, cap * sizeof *v);
            if (!v) {
                rc = pipeline_error(err, errlen, "out of memory");
                break;
            }
            names = v;
        }
        if (!(names[n] = strdup(e->d_name)))
            rc = pipeline_error(err, errlen, "out of memory");
        else
            n++;
    }
    closedir(d);
    if (rc == 0 && n == 0)
        rc = pipeline_error(err, errlen, "%s: no <name>/render.exr in it", dir);
    if (rc == 0)
        qsort(names, n, sizeof *names, cmp_str);
    input *v = rc ? NULL : calloc(2 * n, sizeof *v);
    if (rc == 0 && !v)
        rc = pipeline_error(err, errlen, "out of memory");
    int k = 0;
    for (size_t i = 0; i < n && rc == 0; i++) {
        static const char *const files[3] = {"render.exr", "shifted.exr", "flash.exr"};
        image img[3] = {{0}}, flash_shifted = {0};
        char path[3][1400], fs_path[1400];
        for (int f = 0; f < 3 && rc == 0; f++) {
            snprintf(path[f], sizeof path[f], "%s/%s/%s", dir, names[i], files[f]);
            if (f == 2 && access(path[f], F_OK) != 0)
                break;
            char msg[768];
            if (image_read(path[f], &img[f], msg, sizeof msg))
                rc = pipeline_error(err, errlen, "%s%s", msg,
                                    f == 1 ? " (the floor of a hand-made input needs it)" : "");
            else
                rc = check_image(path[f], &img[f], sh, err, errlen);
        }
        /* The flash input's floor: its own shifted render if there is one, else the plain
         * pair's shift (the same material and shift under the plain light). */
        snprintf(fs_path, sizeof fs_path, "%s/%s/flash-shifted.exr", dir, names[i]);
        int own_flash_floor = rc == 0 && img[2].pixels && access(fs_path, F_OK) == 0;
        if (own_flash_floor) {
            char msg[768];
            if (image_read(fs_path, &flash_shifted, msg, sizeof msg))
                rc = pipeline_error(err, errlen, "%s", msg);
            else
                rc = check_image(fs_path, &flash_shifted, sh, err, errlen);
        }
        if (rc) {
            for (int f = 0; f < 3; f++)
                image_free(&img[f]);
            image_free(&flash_shifted);
            break;
        }
        input *plain = &v[k++];
        plain->set = SET_HANDMADE;
        snprintf(plain->name, sizeof plain->name, "%s", names[i]);
        plain->img = img[0];
        plain->floor_img = img[1];
        snprintf(plain->floor_source, sizeof plain->floor_source, "shifted.exr");
        if (img[2].pixels) {
            input *fl = &v[k++];
            fl->set = SET_FLASH;
            snprintf(fl->name, sizeof fl->name, "%s flash", names[i]);
            fl->img = img[2];
            snprintf(fl->floor_source, sizeof fl->floor_source,
                     own_flash_floor ? "flash-shifted.exr" : "render.exr vs shifted.exr");
            if (own_flash_floor)
                fl->floor_img = flash_shifted;
            else if (image_copy(&fl->floor_ref, &img[0]) || image_copy(&fl->floor_img, &img[1]))
                rc = pipeline_error(err, errlen, "out of memory");
        }
        (*materials)++;
    }
    for (size_t i = 0; i < n; i++)
        free(names[i]);
    free(names);
    if (rc) {
        for (int i = 0; i < k; i++)
            input_clear(&v[i]);
        free(v);
        return -1;
    }
    *out = v;
    *n_out = k;
    return 0;
}

/* ---------------------------------------------------------------- the run ---------- */

static char *config_descriptor(const char *config_json)
{
    cJSON *c = cJSON_Parse(config_json ? config_json : "");
    char *s = cJSON_PrintUnformatted(cJSON_GetObjectItemCaseSensitive(c, "descriptor"));
    cJSON_Delete(c);
    return s;
}

static const char *config_string(cJSON *c, const char *key)
{
    return cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(c, key));
}

int evaluate_run(const evaluate_options *o, char *err, size_t errlen)
{
    if (!o->model_dir || !o->out_dir || (!o->test_path && !o->handmade_dir))
        return pipeline_error(err, errlen, "evaluate: needs a model, an output folder and a test "
                                           "dataset or a hand-made folder");
    if (o->top_k < 1 || o->top_k > 256 || !o->preset || (o->blender != SG_BLENDER_3 && o->blender != SG_BLENDER_4) ||
        o->refine.budget < 1)
        return pipeline_error(err, errlen, "evaluate: top-k in 1..256, a preset and Blender 3 "
                                           "or 4 are required");
    /* "report/" names the folder "report": the temporary one is its sibling. */
    char out_dir[1024];
    snprintf(out_dir, sizeof out_dir, "%s", o->out_dir);
    for (size_t n = strlen(out_dir); n > 1 && out_dir[n - 1] == '/'; n--)
        out_dir[n - 1] = 0;
    struct stat st;
    if (stat(out_dir, &st) == 0)
        return pipeline_error(err, errlen, "%s: already exists (remove it or choose another "
                                           "output folder)", out_dir);
    shared sh;
    memset(&sh, 0, sizeof sh);
    sh.o = o;
    sh.tile = 128;
    sh.t_start = pipeline_now();
    pthread_mutex_init(&sh.lock, NULL);
    int threads = pipeline_thread_count(o->threads);
    threads = threads > 256 ? 256 : threads;
    worker *workers = NULL;
    int n_workers = 0, rc = -1, n_hand = 0, made_tmp = 0, bsize = 4 * threads;
    input *hand = NULL, *batch = NULL;
    result *res = NULL;
    records rs = {0};
    dataset *ds = NULL;
    dataset_iter *it = NULL;
    dataset_info info;
    memset(&info, 0, sizeof info);
    int have_info = 0;
    report_ctx rc_ctx;
    memset(&rc_ctx, 0, sizeof rc_ctx);
    char tmp_dir[1200];
    snprintf(tmp_dir, sizeof tmp_dir, "%s.tmp.%ld", out_dir, (long)getpid());
    char scene_path[1024], flash_path[1024];
    char *model_desc = NULL, *test_desc = NULL;
    cJSON *model_cfg = NULL, *test_cfg = NULL;
    sg_params gp = {0};
    sg_graph *g = NULL;

    char msg[1024];
    if (!(sh.pred = predictor_load(o->model_dir, msg, sizeof msg))) {
        pipeline_error(err, errlen, "model %s: %s", o->model_dir, msg);
        goto done;
    }
    predictor_sample_hypotheses(sh.pred, o->sample_hypotheses);
    predictor_nearest_metric(sh.pred, o->nearest_metric);
    sh.n_params = predictor_n_params(sh.pred);
    sh.names = predictor_param_names(sh.pred);
    sh.mean = predictor_mean_params(sh.pred);
    sh.catalogue_size = predictor_catalogue_size(sh.pred);
    sh.train = predictor_descriptor_kind(sh.pred) == DATAGEN_DESC_VGG19_F16 ? DIST_VGG
                                                                             : DIST_MOBILENET;
    if (predictor_descriptor_kind(sh.pred) != DATAGEN_DESC_VGG19_F16 &&
        predictor_descriptor_kind(sh.pred) != DATAGEN_DESC_MOBILENETV2_F16) {
        pipeline_error(err, errlen, "model %s: reads no descriptor the evaluation knows", o->model_dir);
        goto done;
    }
    if (sh.catalogue_size == 0) {
        pipeline_error(err, errlen, "model %s: an empty catalogue", o->model_dir);
        goto done;
    }
    sh.offset_param = -1;
    for (int k = 0; k < sh.n_params; k++)
        if (role_of(sh.names[k]) == ROLE_SEED)
            sh.offset_param = k;
    sh.kind = malloc((size_t)sh.n_params * sizeof *sh.kind);
    sh.choices = malloc((size_t)sh.n_params * sizeof *sh.choices);
    if (!sh.kind || !sh.choices) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    refine_space_for_params(sh.names, sh.n_params, sh.kind, sh.choices);
    sh.space = (refine_space){.n = sh.n_params, .kind = sh.kind, .choices = sh.choices};
    rc_ctx.model_config = predictor_dataset_config(sh.pred);
    model_cfg = cJSON_Parse(rc_ctx.model_config ? rc_ctx.model_config : "");
    model_desc = config_descriptor(rc_ctx.model_config);

    /* The super-shader and scenes: the graph's parameters must be the model's. */
    if (pipeline_find_data(o->graph_path ? o->graph_path : "assets/supershader.json",
                           sh.graph_path, sizeof sh.graph_path, err, errlen) ||
        pipeline_find_data(o->scene_path ? o->scene_path : "assets/scene.json", scene_path,
                           sizeof scene_path, err, errlen) ||
        pipeline_find_data(o->flash_scene_path ? o->flash_scene_path : "assets/scene-flash.json",
                           flash_path, sizeof flash_path, err, errlen))
        goto done;
    char e[SG_ERROR_MAX] = "";
    if (!(g = sg_graph_load_file(sh.graph_path, e, sizeof e)) || sg_params_from_graph(g, &gp, e, sizeof e) < 0) {
        pipeline_error(err, errlen, "%s: %s", sh.graph_path, e);
        goto done;
    }
    if (gp.n != sh.n_params) {
        pipeline_error(err, errlen, "model %s: %d parameters, %s has %d", o->model_dir,
                       sh.n_params, sh.graph_path, gp.n);
        goto done;
    }
    for (int k = 0; k < gp.n; k++)
        if (strcmp(gp.names[k], sh.names[k])) {
            pipeline_error(err, errlen, "model %s: parameter %d is \"%s\", %s has \"%s\"",
                           o->model_dir, k, sh.names[k], sh.graph_path, gp.names[k]);
            goto done;
        }
    size_t len;
    if (!(sh.scene_text = pipeline_read_file(scene_path, &len, err, errlen)))
        goto done;
    if (!(sh.scene = render_scene_load_json(sh.scene_text, len, scene_path, msg, sizeof msg)) ||
        !(sh.flash_text = pipeline_read_file(flash_path, &len, msg, sizeof msg)) ||
        !(sh.flash_scene = render_scene_load_json(sh.flash_text, len, flash_path, msg, sizeof msg))) {
        pipeline_error(err, errlen, "%s", msg);
        goto done;
    }
    render_scene_resolution(sh.scene, &sh.width, &sh.height);

    /* The test dataset: the same super-shader as the model's training set, ids the
     * catalogue does not hold, renders stored. */
    if (o->test_path) {
        if (!(ds = dataset_open(o->test_path, err, errlen)) ||
            dataset_get_info(ds, &info, err, errlen))
            goto done;
        have_info = 1;
        test_cfg = cJSON_Parse(info.config_json);
        const char *a = config_string(model_cfg, "supershader_sha256"),
                   *b = config_string(test_cfg, "supershader_sha256");
        if (!a || !b || strcmp(a, b)) {
            pipeline_error(err, errlen, "%s: made with super-shader %.12s, the model's training "
                                        "set with %.12s",
                           o->test_path, b ? b : "?", a ? a : "?");
            goto done;
        }
        const char *images = config_string(test_cfg, "images");
        if (!images || !strcmp(images, "none")) {
            pipeline_error(err, errlen, "%s: no renders stored (made with --images none)",
                           o->test_path);
            goto done;
        }
        const char *const *tn = dataset_param_names(ds);
        for (int k = 0; k < sh.n_params; k++)
            if (info.n_params != sh.n_params || strcmp(tn[k], sh.names[k])) {
                pipeline_error(err, errlen, "%s: its parameters are not the model's (%d: \"%s\")",
                               o->test_path, k, k < info.n_params ? tn[k] : "(none)");
                goto done;
            }
        long long overlap = 0;
        for (size_t i = 0; i < sh.catalogue_size; i++) {
            long long id;
            predictor_catalogue_params(sh.pred, i, &id);
            overlap += id >= info.min_id && id <= info.max_id;
        }
        if (overlap) {
            pipeline_error(err, errlen, "%s: ids %lld-%lld overlap the model's catalogue (%lld "
                                        "of its samples): a test set must be disjoint (datagen "
                                        "--first-id)",
                           o->test_path, info.min_id, info.max_id, overlap);
            goto done;
        }
        test_desc = config_descriptor(info.config_json);
        rc_ctx.stored_used = model_desc && test_desc && !strcmp(model_desc, test_desc) &&
                             info.descriptor_size == predictor_descriptor_size(sh.pred);
        rc_ctx.test_config = info.config_json;
        rc_ctx.test_samples = info.samples;
        rc_ctx.test_min_id = info.min_id;
        rc_ctx.test_max_id = info.max_id;
        rc_ctx.test_rows = o->limit > 0 && o->limit < info.rows ? o->limit : info.rows;
    }

    if (o->handmade_dir && load_handmade(o->handmade_dir, &sh, &hand, &n_hand,
                                         &rc_ctx.handmade_materials, err, errlen))
        goto done;

    workers = calloc((size_t)threads, sizeof *workers);
    if (!workers) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    if (workers_init(workers, threads, &sh, err, errlen)) {
        n_workers = threads;
        goto done;
    }
    n_workers = threads;
    if (!rc_ctx.stored_used && predictor_descriptor_size(sh.pred) != workers[0].desc_size[sh.train]) {
        pipeline_error(err, errlen, "model %s reads %zu descriptor values, not the whole %s "
                                    "descriptor (%zu): give a test set made with its config",
                       o->model_dir, predictor_descriptor_size(sh.pred), dist_names[sh.train],
                       workers[0].desc_size[sh.train]);
        goto done;
    }
    pipeline_remove_flat_dir(tmp_dir); /* a killed run's, if its PID has come round again */
    pipeline_remove_stale_temps(out_dir);
    if (mkdir(tmp_dir, 0777) != 0) {
        pipeline_error(err, errlen, "%s: cannot create: %s", tmp_dir, strerror(errno));
        goto done;
    }
    made_tmp = 1;
    /* Our workers each run single-threaded sgemms (and MobileNetV2's bits need it). */
    openblas_set_num_threads(1);
    sh.todo = rc_ctx.test_rows + n_hand;

    /* Synthetic rows in batches; the sheet shows sheet_inputs of them spread evenly. */
    batch = calloc((size_t)bsize, sizeof *batch);
    res = calloc((size_t)bsize, sizeof *res);
    if (!batch || !res) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    long long n_rows = rc_ctx.test_rows, row_i = 0;
    int sheet_n = o->sheet_inputs > 0 ? o->sheet_inputs : 16;
    if (ds && !(it = dataset_iter_new(ds, rc_ctx.stored_used, 1, err, errlen)))
        goto done;
    int next_sheet = 0;
    while (row_i < n_rows) {
        int n = 0;
        for (; n < bsize && row_i < n_rows; n++, row_i++) {
            dataset_row row;
            int got = dataset_iter_next(it, &row, err, errlen);
            if (got < 0)
                goto done;
            if (got == 0) {
                n_rows = row_i;
                break;
            }
            input *in = &batch[n];
            in->set = row.view ? SET_AUGMENTED : SET_SYNTHETIC;
            in->id = row.id;
            in->view = row.view;
            if (row.view)
                snprintf(in->name, sizeof in->name, "%lldv%d", row.id, row.view);
            else
                snprintf(in->name, sizeof in->name, "%lld", row.id);
            snprintf(in->floor_source, sizeof in->floor_source, "pattern offset + 0.5");
            size_t np = (size_t)sh.n_params;
            in->view_json = strdup(row.view_json);
            in->params = malloc(np * sizeof(float));
            in->active = malloc(np);
            if (rc_ctx.stored_used)
                in->stored_desc = malloc(info.descriptor_size * sizeof(float));
            if (!in->view_json || !in->params || !in->active ||
                (rc_ctx.stored_used && !in->stored_desc) ||
                image_copy(&in->img, &row.img)) {
                n++;
                pipeline_error(err, errlen, "out of memory");
                goto done;
            }
            memcpy(in->params, row.params, np * sizeof(float));
            memcpy(in->active, row.active, np);
            if (in->stored_desc)
                memcpy(in->stored_desc, row.descriptor, info.descriptor_size * sizeof(float));
            char where[300];
            snprintf(where, sizeof where, "%s: id %lld view %d", o->test_path, row.id, row.view);
            if (check_image(where, &in->img, &sh, err, errlen)) {
                n++;
                goto done;
            }
            /* Even spread: row i is on the sheet when i = floor(j n_rows / sheet_n) for
             * the next j (distinct rows when sheet_n < n_rows), or every row. */
            in->sheet_row = -1;
            if (n_rows <= sheet_n || (next_sheet < sheet_n &&
                                      row_i == (long long)next_sheet * n_rows / sheet_n))
                in->sheet_row = next_sheet++;
        }
        run_batch(workers, n_workers, batch, res, n);
        for (int i = 0; i < n; i++) {
            if (res[i].failed) {
                pipeline_error(err, errlen, "%s", res[i].err);
                goto done;
            }
            if (records_add(&rs, &batch[i], &res[i])) {
                pipeline_error(err, errlen, "out of memory");
                goto done;
            }
            input_clear(&batch[i]);
        }
    }
    if (n_hand) {
        result *hres = calloc((size_t)n_hand, sizeof *hres);
        if (!hres) {
            pipeline_error(err, errlen, "out of memory");
            goto done;
        }
        for (int i = 0; i < n_hand; i++)
            hand[i].sheet_row = i;
        run_batch(workers, n_workers, hand, hres, n_hand);
        int failed = 0;
        for (int i = 0; i < n_hand; i++) {
            if (!failed && hres[i].failed)
                failed = pipeline_error(err, errlen, "%s/%s", o->handmade_dir, hres[i].err);
            if (!failed && records_add(&rs, &hand[i], &hres[i]))
                failed = pipeline_error(err, errlen, "out of memory");
            result_clear(&hres[i]);
        }
        free(hres);
        if (failed)
            goto done;
    }
    rc_ctx.test_rows = n_rows;

    /* The report. */
    rc_ctx.o = o;
    rc_ctx.sh = &sh;
    rc_ctx.rs = &rs;
    rc_ctx.dir = tmp_dir;
    for (size_t i = 0; i < rs.n; i++) {
        rc_ctx.set_count[rs.v[i].set]++;
        for (int d = 0; d < N_DIST; d++)
            rc_ctx.floors_small[rs.v[i].set][d] += !(rs.v[i].r.floor[d] > EVALUATE_FLOOR_EPSILON);
    }
    /* The majority class of each selector, over the catalogue (every sample; ties: the
     * lower class). */
    rc_ctx.majority_bin = calloc((size_t)sh.n_params, sizeof(int));
    rc_ctx.majority_share = calloc((size_t)sh.n_params, sizeof(double));
    if (!rc_ctx.majority_bin || !rc_ctx.majority_share) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    for (int k = 0; k < sh.n_params; k++) {
        int choices = sg_param_mult_choices(sh.names[k]);
        if (choices < 2)
            continue;
        size_t count[64] = {0};
        for (size_t i = 0; i < sh.catalogue_size; i++)
            count[bin_of(predictor_catalogue_params(sh.pred, i, NULL)[k], choices) & 63]++;
        for (int b = 1; b < choices && b < 64; b++)
            if (count[b] > count[rc_ctx.majority_bin[k]])
                rc_ctx.majority_bin[k] = b;
        rc_ctx.majority_share[k] =
            (double)count[rc_ctx.majority_bin[k]] / (double)sh.catalogue_size;
    }
    if (write_report(&rc_ctx, err, errlen))
        goto done;
    /* Wall-clock figures vary from run to run: apart, so that report.json is a pure
     * function of the inputs and settings. */
    {
        double total = pipeline_now() - sh.t_start, *secs = malloc((rs.n ? rs.n : 1) * sizeof *secs);
        long long renders = 0;
        for (size_t i = 0; i < rs.n; i++) {
            if (secs)
                secs[i] = rs.v[i].r.seconds;
            renders += rs.v[i].r.renders;
        }
        double load[3] = {0, 0, 0};
        FILE *f = fopen("/proc/loadavg", "r");
        if (f) {
            if (fscanf(f, "%lf %lf %lf", &load[0], &load[1], &load[2]) != 3)
                load[0] = load[1] = load[2] = 0;
            fclose(f);
        }
        char t[512];
        snprintf(t, sizeof t,
                 "{\n  \"threads\": %d,\n  \"seconds\": %.3f,\n  \"inputs\": %zu,\n  "
                 "\"renders\": %lld,\n  \"input_seconds_median\": %.3f,\n  "
                 "\"input_seconds_p90\": %.3f,\n  \"load_average\": [%.2f, %.2f, %.2f]\n}\n",
                 threads, total, rs.n, renders, secs ? evaluate_quantile(secs, rs.n, 0.5) : 0.0,
                 secs ? evaluate_quantile(secs, rs.n, 0.9) : 0.0, load[0], load[1], load[2]);
        free(secs);
        if (write_text(tmp_dir, "timings.json", t, err, errlen))
            goto done;
    }
    if (rename(tmp_dir, out_dir) != 0) {
        pipeline_error(err, errlen, "%s: cannot rename %s to it: %s", out_dir, tmp_dir,
                       strerror(errno));
        goto done;
    }
    made_tmp = 0;
    rc = 0;
done:
    if (made_tmp)
        pipeline_remove_flat_dir(tmp_dir);
    for (int i = 0; batch && i < bsize; i++) {
        input_clear(&batch[i]);
        result_clear(&res[i]);
    }
    free(batch);
    free(res);
    for (int i = 0; i < n_hand; i++)
        input_clear(&hand[i]);
    free(hand);
    records_free(&rs);
    free(rc_ctx.majority_bin);
    free(rc_ctx.majority_share);
    for (int t = 0; t < n_workers; t++)
        worker_free(&workers[t]);
    free(workers);
    dataset_iter_free(it);
    dataset_close(ds);
    if (have_info)
        dataset_info_free(&info);
    cJSON_Delete(model_cfg);
    cJSON_Delete(test_cfg);
    free(model_desc);
    free(test_desc);
    if (gp.names)
        sg_params_free(&gp);
    sg_graph_free(g);
    free(sh.scene_text);
    free(sh.flash_text);
    free(sh.kind);
    free(sh.choices);
    render_scene_free(sh.scene);
    render_scene_free(sh.flash_scene);
    predictor_free(sh.pred);
    pthread_mutex_destroy(&sh.lock);
    return rc;
}
