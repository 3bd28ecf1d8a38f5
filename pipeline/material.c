/* Load -> bind -> extract -> compile: the sequence every command that renders shares. */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline/pipeline_internal.h"

sg_graph *pipeline_load_graph(const char *graph_path, const char *params_path, long long seed,
                              char *err, size_t errlen)
{
    char e[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(graph_path, e, sizeof e);
    if (!g) {
        pipeline_error(err, errlen, "%s", e);
        return NULL;
    }
    if (!params_path && seed < 0)
        return g;
    sg_params p;
    if (sg_params_from_graph(g, &p, e, sizeof e) < 0) {
        pipeline_error(err, errlen, "%s: %s", graph_path, e);
        sg_graph_free(g);
        return NULL;
    }
    int rc = 0;
    if (params_path)
        rc = sg_params_read_file(params_path, &p, e, sizeof e);
    else
        sg_params_sample(&p, (unsigned long long)seed);
    if (rc == 0)
        rc = sg_graph_bind_params(g, &p, e, sizeof e);
    sg_params_free(&p);
    if (rc < 0) {
        pipeline_error(err, errlen, "%s", e);
        sg_graph_free(g);
        return NULL;
    }
    return g;
}

render_material *pipeline_render_material(const sg_graph *g, const char *graph_path,
                                          sg_blender_mode blender, char *err, size_t errlen)
{
    char msg[1024];
    render_material *m = render_material_new(g, blender, msg, sizeof msg);
    if (!m)
        pipeline_error(err, errlen, "%s: %s", graph_path, msg);
    return m;
}

/* The extracted sub-shader of g as JSON text (what "unchanged" is judged by). */
static char *subshader_json(const sg_graph *g, sg_blender_mode blender, int *nodes, char *err,
                            size_t errlen)
{
    sg_extract_options opt = {.blender = blender == SG_BLENDER_3 ? SG_BLENDER_3 : SG_BLENDER_4};
    char e[SG_ERROR_MAX] = "";
    sg_graph *x = sg_extract(g, &opt, e, sizeof e);
    if (!x) {
        pipeline_error(err, errlen, "extracting the sub-shader: %s", e);
        return NULL;
    }
    if (nodes)
        *nodes = sg_graph_node_count(x);
    char *json = sg_graph_to_json(x);
    sg_graph_free(x);
    if (!json)
        pipeline_error(err, errlen, "out of memory");
    return json;
}

/* Binds p with parameter k set to v, extracts, and says whether the sub-shader differs
 * from `base`: 1 differs, 0 same, -1 error. */
static int differs_with(sg_graph *g, sg_params *p, int k, float v, const char *base,
                        sg_blender_mode blender, char *err, size_t errlen)
{
    float keep = p->values[k];
    p->values[k] = v;
    char e[SG_ERROR_MAX] = "";
    int rc = sg_graph_bind_params(g, p, e, sizeof e);
    p->values[k] = keep;
    if (rc < 0)
        return pipeline_error(err, errlen, "%s", e);
    char *json = subshader_json(g, blender, NULL, err, errlen);
    if (!json)
        return -1;
    int d = strcmp(json, base) != 0;
    free(json);
    return d;
}

/* Whether parameter k of the bound graph g is active (pipeline_active_params): 1, 0, or
 * -1 with a message. p holds g's parameters; p->values[k] is put back. */
static int param_active(sg_graph *g, sg_params *p, int k, const char *base,
                        sg_blender_mode blender, char *err, size_t errlen)
{
    int choices = sg_param_mult_choices(p->names[k]);
    int d = 0;
    if (choices >= 2) {
        int mine = (int)floorf(p->values[k] * (float)choices);
        if (mine > choices - 1)
            mine = choices - 1;
        for (int c = 0; c < choices && d == 0; c++)
            if (c != mine)
                d = differs_with(g, p, k, ((float)c + 0.5f) / (float)choices, base, blender,
                                 err, errlen);
    } else {
        /* A value parameter may act only past a threshold (a clamped Map Range): try
         * values spread over (0, 1), stopping at the first change. Not 0 or 1 exactly:
         * there folds like x * 0 reshape the sub-shader without changing what an
         * unused branch computes (a false "active"). */
        static const float offsets[] = {0.5f, 0.25f, 0.75f, 0.125f, 0.375f, 0.625f, 0.875f};
        for (size_t j = 0; j < sizeof offsets / sizeof offsets[0] && d == 0; j++) {
            float v = p->values[k] + offsets[j];
            v = roundf((v >= 1.0f ? v - 1.0f : v) * 1000.0f) / 1000.0f;
            if (v > 0.0f && v < 1.0f && v != p->values[k])
                d = differs_with(g, p, k, v, base, blender, err, errlen);
        }
    }
    return d;
}

/* One thread's share of pipeline_active_params_on: parameters first, first + stride, ...
 * on its own copy of the graph, bound to `values` first and restored to its own after. */
typedef struct active_share {
    sg_graph *g;
    sg_blender_mode blender;
    const char *base;
    const float *values; /* the parameters being tested (the first graph's) */
    int first, stride;
    uint8_t *active;
    int rc;
    char err[512];
} active_share;

static void *active_share_run(void *arg)
{
    active_share *a = arg;
    sg_params p, own;
    char e[SG_ERROR_MAX] = "";
    a->rc = -1;
    if (sg_params_from_graph(a->g, &own, e, sizeof e) < 0) {
        pipeline_error(a->err, sizeof a->err, "%s", e);
        return NULL;
    }
    if (sg_params_copy(&own, &p) < 0) {
        pipeline_error(a->err, sizeof a->err, "out of memory");
        sg_params_free(&own);
        return NULL;
    }
    memcpy(p.values, a->values, (size_t)p.n * sizeof *p.values);
    int rc = 0;
    for (int k = a->first; rc == 0 && k < p.n; k += a->stride) {
        int d = param_active(a->g, &p, k, a->base, a->blender, a->err, sizeof a->err);
        if (d < 0)
            rc = -1;
        else
            a->active[k] = (uint8_t)d;
    }
    if (sg_graph_bind_params(a->g, &own, e, sizeof e) < 0 && rc == 0)
        rc = pipeline_error(a->err, sizeof a->err, "%s", e);
    sg_params_free(&p);
    sg_params_free(&own);
    a->rc = rc;
    return NULL;
}

int pipeline_active_params_on(sg_graph *const *g, int n_graphs, sg_blender_mode blender,
                              uint8_t *active, int *subshader_nodes, char *err, size_t errlen)
{
    enum { MAX_SHARES = 8 };
    sg_params p;
    char e[SG_ERROR_MAX] = "";
    if (sg_params_from_graph(g[0], &p, e, sizeof e) < 0)
        return pipeline_error(err, errlen, "%s", e);
    char *base = subshader_json(g[0], blender, subshader_nodes, err, errlen);
    if (!base) {
        sg_params_free(&p);
        return -1;
    }
    int n = n_graphs < 1 ? 1 : n_graphs > MAX_SHARES ? MAX_SHARES : n_graphs;
    active_share share[MAX_SHARES];
    pthread_t tid[MAX_SHARES];
    int started[MAX_SHARES] = {0};
    for (int t = 0; t < n; t++) {
        share[t] = (active_share){.g = g[t], .blender = blender, .base = base,
                                  .values = p.values, .first = t, .stride = n,
                                  .active = active};
        if (t > 0)
            started[t] = pthread_create(&tid[t], NULL, active_share_run, &share[t]) == 0;
    }
    /* Shares whose thread did not start run here, after the first. */
    active_share_run(&share[0]);
    for (int t = 1; t < n; t++) {
        if (started[t])
            pthread_join(tid[t], NULL);
        else {
            share[t].g = g[0];
            active_share_run(&share[t]);
        }
    }
    int rc = 0;
    for (int t = 0; t < n && rc == 0; t++)
        if (share[t].rc < 0)
            rc = pipeline_error(err, errlen, "%s", share[t].err);
    free(base);
    sg_params_free(&p);
    return rc;
}

int pipeline_active_params(sg_graph *g, sg_blender_mode blender, uint8_t *active, int *subshader_nodes,
                           char *err, size_t errlen)
{
    return pipeline_active_params_on(&g, 1, blender, active, subshader_nodes, err, errlen);
}

int pipeline_distinct_subshaders(sg_graph *g, sg_blender_mode blender, const float *params, int n, int keep,
                                 int *index, char *err, size_t errlen)
{
    sg_params p, saved;
    char e[SG_ERROR_MAX] = "";
    if (sg_params_from_graph(g, &p, e, sizeof e) < 0)
        return pipeline_error(err, errlen, "%s", e);
    if (sg_params_copy(&p, &saved) < 0) {
        sg_params_free(&p);
        return pipeline_error(err, errlen, "out of memory");
    }
    char **kept = calloc((size_t)(keep > 0 ? keep : 1), sizeof *kept);
    int got = 0, rc = kept ? 0 : pipeline_error(err, errlen, "out of memory");
    for (int i = 0; rc == 0 && i < n && got < keep; i++) {
        memcpy(p.values, params + (size_t)i * (size_t)p.n, (size_t)p.n * sizeof(float));
        if (sg_graph_bind_params(g, &p, e, sizeof e) < 0) {
            rc = pipeline_error(err, errlen, "parameter set %d: %s", i, e);
            break;
        }
        char *json = subshader_json(g, blender, NULL, err, errlen);
        if (!json) {
            rc = -1;
            break;
        }
        int seen = 0;
        for (int j = 0; j < got && !seen; j++)
            seen = !strcmp(kept[j], json);
        if (seen)
            free(json);
        else {
            kept[got] = json;
            index[got++] = i;
        }
    }
    if (sg_graph_bind_params(g, &saved, e, sizeof e) < 0 && rc == 0)
        rc = pipeline_error(err, errlen, "%s", e);
    for (int j = 0; j < got; j++)
        free(kept[j]);
    free(kept);
    sg_params_free(&p);
    sg_params_free(&saved);
    return rc < 0 ? -1 : got;
}
