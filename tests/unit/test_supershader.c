/*
 * The super-shader asset (assets/supershader.json): it loads, has 400-700 nodes (the
 * design's ~550, and the bricks and grain patterns built from Math nodes) and
 * exactly 50 parameters in [0, 1] read from RandomValues, every choice of every
 * multiplexer changes the material for some frame, and the four maps are finite and in
 * their ranges over the plane for random frames.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>
#include <cmocka.h>

#include "shadergraph/shadergraph.h"

#define ASSET IMSYNTH_SOURCE_DIR "/assets/supershader.json"

enum { N_MAPS = 4 };
static const sg_socket_ref maps[N_MAPS] = {
    {"Principled BSDF", "Base Color"},
    {"Principled BSDF", "Metallic"},
    {"Principled BSDF", "Roughness"},
    {"Principled BSDF", "Normal"},
};
static const int map_width[N_MAPS] = {3, 1, 1, 3};

static char *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *s = malloc((size_t)n + 1);
    assert_non_null(s);
    assert_int_equal(fread(s, 1, (size_t)n, f), (size_t)n);
    s[n] = '\0';
    fclose(f);
    *len = (size_t)n;
    return s;
}

/* Nodes with every group expanded in place, once per group instance (the definition
 * assets/generate_supershader.py prints and sg_graph_node_count uses): the tree's
 * nodes, a group node replaced by its group's count. Read from the JSON directly, so
 * the count does not depend on the loader. */
static int count_nodes(const cJSON *tree, const cJSON *groups, int depth)
{
    assert_true(depth < 16);
    int n = 0;
    const cJSON *node;
    cJSON_ArrayForEach(node, cJSON_GetObjectItemCaseSensitive(tree, "nodes"))
    {
        const cJSON *type = cJSON_GetObjectItemCaseSensitive(node, "type");
        if (!strcmp(type->valuestring, "ShaderNodeGroup")) {
            const cJSON *name = cJSON_GetObjectItemCaseSensitive(node, "group");
            const cJSON *g = cJSON_GetObjectItemCaseSensitive(groups, name->valuestring);
            assert_non_null(g);
            n += count_nodes(g, groups, depth + 1);
        } else
            n++;
    }
    return n;
}

static void test_asset_shape(void **state)
{
    (void)state;
    size_t len;
    char *text = read_all(ASSET, &len);
    cJSON *root = cJSON_ParseWithLength(text, len);
    assert_non_null(root);
    int nodes = count_nodes(root, cJSON_GetObjectItemCaseSensitive(root, "groups"), 0);
    print_message("super-shader: %d nodes (groups expanded, once per instance)\n", nodes);
    assert_true(nodes >= 400 && nodes <= 700);
    cJSON_Delete(root);

    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_json(text, len, ASSET, err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    free(text);
    assert_int_equal(sg_graph_node_count(g), nodes);
    sg_params p;
    assert_int_equal(sg_params_from_graph(g, &p, err, sizeof err), 0);
    assert_int_equal(p.n, 50);
    int mults = 0;
    for (int i = 0; i < p.n; i++) {
        assert_true(p.values[i] >= 0.0f && p.values[i] <= 1.0f);
        for (int j = 0; j < i; j++)
            assert_string_not_equal(p.names[i], p.names[j]);
        mults += sg_param_mult_choices(p.names[i]) > 0;
    }
    print_message("super-shader: %d parameters, %d of them multiplexer selectors\n", p.n, mults);
    assert_true(mults >= 10);
    sg_params_free(&p);
    sg_graph_free(g);
}

/* The four maps of g at `n` points of a size x size view of the plane (evenly spread
 * pixels), into out (width-major per map). */
typedef struct maps_buf {
    int n;
    float *v[N_MAPS];
} maps_buf;

static void eval_maps(const sg_graph *g, int size, int stride, maps_buf *mb)
{
    char err[SG_ERROR_MAX] = "";
    sg_program *prog = sg_compile(g, maps, N_MAPS, NULL, err, sizeof err);
    if (!prog)
        fail_msg("%s", err);
    for (int k = 0; k < N_MAPS; k++)
        assert_int_equal(sg_socket_type_width(sg_program_output_type(prog, k)), map_width[k]);
    enum { BATCH = 256 };
    sg_evaluator *e = sg_evaluator_new(prog, BATCH);
    float *storage = malloc(sizeof(float) * 48 * BATCH);
    float *tmp[N_MAPS];
    for (int k = 0; k < N_MAPS; k++)
        tmp[k] = malloc(sizeof(float) * 3 * BATCH);
    int total = size * size;
    mb->n = 0;
    for (int first = 0; first < total; first += BATCH) {
        int n = total - first < BATCH ? total - first : BATCH;
        sg_geometry_batch geom;
        sg_plane_geometry(size, size, first, n, storage, &geom);
        sg_evaluate(e, &geom, tmp);
        for (int i = 0; i < n; i += stride) {
            for (int k = 0; k < N_MAPS; k++)
                for (int c = 0; c < map_width[k]; c++)
                    mb->v[k][(size_t)mb->n * 3 + (size_t)c] = tmp[k][(size_t)c * (size_t)n + (size_t)i];
            mb->n++;
        }
    }
    for (int k = 0; k < N_MAPS; k++)
        free(tmp[k]);
    free(storage);
    sg_evaluator_free(e);
    sg_program_free(prog);
}

static void maps_alloc(maps_buf *mb, int n)
{
    for (int k = 0; k < N_MAPS; k++) {
        mb->v[k] = calloc((size_t)n * 3, sizeof(float));
        assert_non_null(mb->v[k]);
    }
}

static void maps_free(maps_buf *mb)
{
    for (int k = 0; k < N_MAPS; k++)
        free(mb->v[k]);
}

static bool maps_equal(const maps_buf *a, const maps_buf *b)
{
    for (int k = 0; k < N_MAPS; k++)
        if (memcmp(a->v[k], b->v[k], sizeof(float) * 3 * (size_t)a->n))
            return false;
    return true;
}

/* For every "Mult N" parameter and every pair of its choices (bin centres), some frame
 * among the first few gives a different material with one choice than with the other
 * (the other parameters as sampled): no choice is dead or a duplicate of another. */
static void test_every_choice_matters(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(ASSET, err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    sg_params p;
    assert_int_equal(sg_params_from_graph(g, &p, err, sizeof err), 0);
    enum { SIZE = 32, STRIDE = 4, MAX_CHOICES = 16, FRAMES = 12 };
    const int n_points = SIZE * SIZE / STRIDE;
    maps_buf out[MAX_CHOICES];
    for (int c = 0; c < MAX_CHOICES; c++)
        maps_alloc(&out[c], n_points);
    for (int i = 0; i < p.n; i++) {
        int n = sg_param_mult_choices(p.names[i]);
        if (!n)
            continue;
        assert_true(n <= MAX_CHOICES);
        bool differ[MAX_CHOICES][MAX_CHOICES] = {{false}};
        int open = n * (n - 1) / 2, frame;
        for (frame = 0; frame < FRAMES && open > 0; frame++) {
            sg_params_sample(&p, (unsigned long long)frame);
            for (int c = 0; c < n; c++) {
                p.values[i] = (float)((c + 0.5) / n);
                assert_int_equal(sg_graph_bind_params(g, &p, err, sizeof err), 0);
                eval_maps(g, SIZE, STRIDE, &out[c]);
            }
            for (int a = 0; a < n; a++)
                for (int b = a + 1; b < n; b++)
                    if (!differ[a][b] && !maps_equal(&out[a], &out[b])) {
                        differ[a][b] = true;
                        open--;
                    }
        }
        for (int a = 0; a < n; a++)
            for (int b = a + 1; b < n; b++)
                if (!differ[a][b])
                    fail_msg("\"%s\": choices %d and %d give the same material in frames 0..%d",
                             p.names[i], a, b, FRAMES - 1);
        print_message("%-28s all %d choices distinct by frame %d\n", p.names[i], n, frame - 1);
    }
    for (int c = 0; c < MAX_CHOICES; c++)
        maps_free(&out[c]);
    sg_params_free(&p);
    sg_graph_free(g);
}

/* Random frames: every map finite over a 64 x 64 view of the plane, Base Color,
 * Metallic and Roughness in [0, 1], Normal unit length; and frames differ. */
static void test_plane_is_finite(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(ASSET, err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    sg_params p;
    assert_int_equal(sg_params_from_graph(g, &p, err, sizeof err), 0);
    enum { SIZE = 64, FRAMES = 24 };
    maps_buf mb, first;
    maps_alloc(&mb, SIZE * SIZE);
    maps_alloc(&first, SIZE * SIZE);
    int flat = 0;
    for (int frame = 0; frame < FRAMES; frame++) {
        sg_params_sample(&p, 1000u + (unsigned)frame);
        assert_int_equal(sg_graph_bind_params(g, &p, err, sizeof err), 0);
        eval_maps(g, SIZE, 1, frame ? &mb : &first);
        const maps_buf *m = frame ? &mb : &first;
        double lo = 1e30, hi = -1e30;
        for (int i = 0; i < m->n; i++) {
            for (int k = 0; k < N_MAPS; k++)
                for (int c = 0; c < map_width[k]; c++) {
                    float v = m->v[k][(size_t)i * 3 + (size_t)c];
                    assert_true(isfinite(v));
                    if (k < 3)
                        assert_true(v >= 0.0f && v <= 1.0f);
                }
            const float *nv = &m->v[3][(size_t)i * 3];
            assert_true(fabsf(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2] - 1.0f) < 1e-4f);
            assert_true(nv[2] > 0.0f); /* faces the viewer */
            double lum = 0.2126 * m->v[0][i * 3] + 0.7152 * m->v[0][i * 3 + 1] +
                         0.0722 * m->v[0][i * 3 + 2];
            lo = lum < lo ? lum : lo;
            hi = lum > hi ? lum : hi;
        }
        flat += hi - lo < 0.02;
        if (frame)
            assert_false(maps_equal(&mb, &first));
    }
    /* Random parameters give patterned materials, not flat colour. */
    print_message("%d of %d frames have a flat Base Color\n", flat, FRAMES);
    assert_true(flat <= FRAMES / 8);
    maps_free(&mb);
    maps_free(&first);
    sg_params_free(&p);
    sg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_asset_shape),
        cmocka_unit_test(test_every_choice_matters),
        cmocka_unit_test(test_plane_is_finite),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
