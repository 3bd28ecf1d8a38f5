/*
 * Sub-shader extraction must never change the material: the extracted graph's four
 * BSDF maps equal the original's at every point (compared as floats with ==, NaN equal
 * to NaN, so +0 and -0 count as equal; see extract.c). And it must actually simplify.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "shadergraph/shadergraph.h"
#include "test_assets.h"

static const sg_socket_ref maps[4] = {{"Principled BSDF", "Base Color"},
                                      {"Principled BSDF", "Metallic"},
                                      {"Principled BSDF", "Roughness"},
                                      {"Principled BSDF", "Normal"}};

enum { RES = 64, N = RES * RES };

/* Evaluates the four maps over a RES x RES view of the plane: out[k] has 3*N floats.
 * unfolded: compiled without constant folding (the reference). */
static void eval_maps(const sg_graph *g, sg_blender_mode mode, bool unfolded, float *out[4])
{
    char err[SG_ERROR_MAX] = "";
    sg_compile_options opt = {.blender = mode, .unfolded = unfolded};
    sg_program *p = sg_compile(g, maps, 4, &opt, err, sizeof err);
    if (!p)
        fail_msg("compile: %s", err);
    enum { B = 256 };
    sg_evaluator *e = sg_evaluator_new(p, B);
    static float geom[48 * B], tmp[4][3 * B];
    for (int first = 0; first < N; first += B) {
        sg_geometry_batch gb;
        sg_plane_geometry(RES, RES, first, B, geom, &gb);
        float *o[4] = {tmp[0], tmp[1], tmp[2], tmp[3]};
        sg_evaluate(e, &gb, o);
        for (int k = 0; k < 4; k++) {
            int w = sg_socket_type_width(sg_program_output_type(p, k));
            for (int c = 0; c < 3; c++)
                for (int i = 0; i < B; i++)
                    out[k][(size_t)c * N + (size_t)(first + i)] = tmp[k][(w == 1 ? 0 : c) * B + i];
        }
    }
    sg_evaluator_free(e);
    sg_program_free(p);
}

static bool same_value(float a, float b) { return a == b || (isnan(a) && isnan(b)); }

/* Extracts g and checks the maps agree in both Blender modes; returns the node count. */
static int check_extraction(const sg_graph *g)
{
    static float a[4][3 * N], b[4][3 * N];
    float *pa[4] = {a[0], a[1], a[2], a[3]}, *pb[4] = {b[0], b[1], b[2], b[3]};
    char err[SG_ERROR_MAX] = "";
    int count = -1;
    for (int mode = 3; mode <= 4; mode++) {
        sg_extract_options opt = {.blender = (sg_blender_mode)mode};
        sg_graph *x = sg_extract(g, &opt, err, sizeof err);
        if (!x)
            fail_msg("extract: %s", err);
        /* Against the original evaluated node by node, not folded by the same pass that
         * made x (that would prove folding idempotent, not faithful). */
        eval_maps(g, (sg_blender_mode)mode, true, pa);
        eval_maps(x, (sg_blender_mode)mode, false, pb);
        for (int k = 0; k < 4; k++)
            for (int i = 0; i < 3 * N; i++)
                if (!same_value(a[k][i], b[k][i]))
                    fail_msg("map %s differs at %d (Blender %d): %.9g vs %.9g", maps[k].socket,
                             i % N, mode, (double)a[k][i], (double)b[k][i]);
        /* The result is a valid graph that survives a JSON round trip. */
        char *text = sg_graph_to_json(x);
        sg_graph *y = sg_graph_load_json(text, strlen(text), "extracted", err, sizeof err);
        if (!y)
            fail_msg("extracted graph does not reload: %s", err);
        count = sg_graph_node_count(x);
        free(text);
        sg_graph_free(y);
        sg_graph_free(x);
    }
    return count;
}

static void test_marble_unchanged(void **state)
{
    (void)state;
    sg_graph *g = load_asset("assets/examples/marble.json");
    int before = sg_graph_node_count(g);
    int after = check_extraction(g);
    /* Nothing in the marble is constant-foldable except Map Range's constant chain: it
     * may not grow. */
    assert_true(after <= before);
    sg_graph_free(g);
}

/* A graph built to be simplified: constant chains, identities, a group used twice
 * with constant inputs, a hard switch with a constant selector, duplicate nodes. */
static const char *const foldable =
    "{\"format\": \"imsynth-graph/1\", \"nodes\": [\n"
    " {\"name\": \"Sel\", \"type\": \"ShaderNodeValue\", \"outputs\": {\"Value\": 0.6}},\n"
    " {\"name\": \"Noise\", \"type\": \"ShaderNodeTexNoise\", \"inputs\": {\"Detail\": 3.0}},\n"
    " {\"name\": \"Noise2\", \"type\": \"ShaderNodeTexNoise\", \"inputs\": {\"Detail\": 3.0}},\n"
    " {\"name\": \"Vor\", \"type\": \"ShaderNodeTexVoronoi\"},\n"
    " {\"name\": \"G1\", \"type\": \"ShaderNodeGroup\", \"group\": \"Switch\"},\n"
    " {\"name\": \"Scale\", \"type\": \"ShaderNodeMath\", \"properties\": {\"operation\": \"MULTIPLY\"},"
    "  \"inputs\": {\"Value\": 2.0, \"Value_001\": 0.5}},\n"
    " {\"name\": \"Times\", \"type\": \"ShaderNodeMath\", \"properties\": {\"operation\": \"MULTIPLY\"}},\n"
    " {\"name\": \"Plus0\", \"type\": \"ShaderNodeMath\", \"inputs\": {\"Value_001\": 0.0}},\n"
    " {\"name\": \"Mix\", \"type\": \"ShaderNodeMix\", \"properties\": {\"data_type\": \"RGBA\"},"
    "  \"inputs\": {\"Factor_Float\": 0.0, \"B_Color\": [1, 0, 0, 1]}},\n"
    " {\"name\": \"Bump\", \"type\": \"ShaderNodeBump\", \"inputs\": {\"Distance\": 0.1}},\n"
    " {\"name\": \"Principled BSDF\", \"type\": \"ShaderNodeBsdfPrincipled\"},\n"
    " {\"name\": \"Material Output\", \"type\": \"ShaderNodeOutputMaterial\"}],\n"
    " \"links\": [\n"
    "  {\"from_node\": \"Sel\", \"from_socket\": \"Value\", \"to_node\": \"G1\", \"to_socket\": \"Selector\"},\n"
    "  {\"from_node\": \"Noise\", \"from_socket\": \"Fac\", \"to_node\": \"G1\", \"to_socket\": \"A\"},\n"
    "  {\"from_node\": \"Vor\", \"from_socket\": \"Distance\", \"to_node\": \"G1\", \"to_socket\": \"B\"},\n"
    "  {\"from_node\": \"G1\", \"from_socket\": \"Out\", \"to_node\": \"Times\", \"to_socket\": \"Value\"},\n"
    "  {\"from_node\": \"Scale\", \"from_socket\": \"Value\", \"to_node\": \"Times\", \"to_socket\": \"Value_001\"},\n"
    "  {\"from_node\": \"Times\", \"from_socket\": \"Value\", \"to_node\": \"Plus0\", \"to_socket\": \"Value\"},\n"
    "  {\"from_node\": \"Plus0\", \"from_socket\": \"Value\", \"to_node\": \"Principled BSDF\", \"to_socket\": \"Roughness\"},\n"
    "  {\"from_node\": \"Noise2\", \"from_socket\": \"Color\", \"to_node\": \"Mix\", \"to_socket\": \"A_Color\"},\n"
    "  {\"from_node\": \"Mix\", \"from_socket\": \"Result_Color\", \"to_node\": \"Principled BSDF\", \"to_socket\": \"Base Color\"},\n"
    "  {\"from_node\": \"Noise\", \"from_socket\": \"Fac\", \"to_node\": \"Principled BSDF\", \"to_socket\": \"Metallic\"},\n"
    "  {\"from_node\": \"Noise2\", \"from_socket\": \"Fac\", \"to_node\": \"Bump\", \"to_socket\": \"Height\"},\n"
    "  {\"from_node\": \"Bump\", \"from_socket\": \"Normal\", \"to_node\": \"Principled BSDF\", \"to_socket\": \"Normal\"},\n"
    "  {\"from_node\": \"Principled BSDF\", \"from_socket\": \"BSDF\", \"to_node\": \"Material Output\", \"to_socket\": \"Surface\"}],\n"
    " \"groups\": {\"Switch\": {\n"
    "   \"inputs\": [{\"name\": \"Selector\", \"type\": \"FLOAT\"}, {\"name\": \"A\", \"type\": \"FLOAT\"},"
    "              {\"name\": \"B\", \"type\": \"FLOAT\"}],\n"
    "   \"outputs\": [{\"name\": \"Out\", \"type\": \"FLOAT\"}],\n"
    "   \"nodes\": [{\"name\": \"In\", \"type\": \"NodeGroupInput\"},\n"
    "     {\"name\": \"IsB\", \"type\": \"ShaderNodeMath\", \"properties\": {\"operation\": \"GREATER_THAN\"}},\n"
    "     {\"name\": \"IsA\", \"type\": \"ShaderNodeMath\", \"properties\": {\"operation\": \"SUBTRACT\"}, \"inputs\": {\"Value\": 1.0}},\n"
    "     {\"name\": \"TA\", \"type\": \"ShaderNodeMath\", \"properties\": {\"operation\": \"MULTIPLY\"}},\n"
    "     {\"name\": \"TB\", \"type\": \"ShaderNodeMath\", \"properties\": {\"operation\": \"MULTIPLY\"}},\n"
    "     {\"name\": \"Sum\", \"type\": \"ShaderNodeMath\"},\n"
    "     {\"name\": \"Out\", \"type\": \"NodeGroupOutput\"}],\n"
    "   \"links\": [\n"
    "     {\"from_node\": \"In\", \"from_socket\": \"Selector\", \"to_node\": \"IsB\", \"to_socket\": \"Value\"},\n"
    "     {\"from_node\": \"IsB\", \"from_socket\": \"Value\", \"to_node\": \"IsA\", \"to_socket\": \"Value_001\"},\n"
    "     {\"from_node\": \"In\", \"from_socket\": \"A\", \"to_node\": \"TA\", \"to_socket\": \"Value\"},\n"
    "     {\"from_node\": \"IsA\", \"from_socket\": \"Value\", \"to_node\": \"TA\", \"to_socket\": \"Value_001\"},\n"
    "     {\"from_node\": \"In\", \"from_socket\": \"B\", \"to_node\": \"TB\", \"to_socket\": \"Value\"},\n"
    "     {\"from_node\": \"IsB\", \"from_socket\": \"Value\", \"to_node\": \"TB\", \"to_socket\": \"Value_001\"},\n"
    "     {\"from_node\": \"TA\", \"from_socket\": \"Value\", \"to_node\": \"Sum\", \"to_socket\": \"Value\"},\n"
    "     {\"from_node\": \"TB\", \"from_socket\": \"Value\", \"to_node\": \"Sum\", \"to_socket\": \"Value_001\"},\n"
    "     {\"from_node\": \"Sum\", \"from_socket\": \"Value\", \"to_node\": \"Out\", \"to_socket\": \"Out\"}]}}}\n";

static void test_foldable_graph_simplifies_and_is_unchanged(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_json(foldable, strlen(foldable), "foldable", err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    int before = sg_graph_node_count(g);
    int after = check_extraction(g);
    /* Selector 0.6 > 0.5 picks B (Voronoi); Noise feeds only Metallic; Scale folds to
     * 1 and Times bypasses; Plus0 bypasses; Mix with factor 0 bypasses; Noise2 and
     * Noise are duplicates and merge. What remains: Noise, Voronoi, Bump, Principled
     * BSDF, Material Output. */
    assert_int_equal(before, 18);
    if (after != 5) {
        sg_extract_options opt = {0};
        sg_graph *x = sg_extract(g, &opt, err, sizeof err);
        char *t = sg_graph_to_json(x);
        fail_msg("expected 5 nodes, got %d:\n%s", after, t);
    }
    sg_graph_free(g);
}

/* Geometry for `n` random points of the plane (uniform over the 2 m square), as a
 * 4096 x 4096 view sees its pixel centres: storage as sg_plane_geometry wants it. */
static void random_plane_points(unsigned seed, int n, float *storage, sg_geometry_batch *gb)
{
    float one[48];
    sg_geometry_batch p1;
    uint64_t state = 0x9E3779B97F4A7C15ull * (seed + 1);
    sg_plane_geometry(1, 1, 0, n, storage, gb); /* lays out gb's pointers for n points */
    for (int i = 0; i < n; i++) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        int pixel = (int)((state >> 33) % (4096u * 4096u));
        sg_plane_geometry(4096, 4096, pixel, 1, one, &p1);
        /* Field k of point i lives at storage[k*3n + c*n + i]; of p1 at one[k*3 + c]. */
        for (int k = 0; k < 16; k++)
            for (int c = 0; c < 3; c++)
                storage[(size_t)k * 3 * n + (size_t)c * n + i] = one[k * 3 + c];
    }
}

/* Frame `seed`'s parameters bound to g (params: g's) and its sub-shader. */
static sg_graph *extract_frame(sg_graph *g, sg_params *params, unsigned seed)
{
    char err[SG_ERROR_MAX] = "";
    sg_params_sample(params, seed);
    if (sg_graph_bind_params(g, params, err, sizeof err) < 0)
        fail_msg("%s", err);
    sg_graph *x = sg_extract(g, NULL, err, sizeof err);
    if (!x)
        fail_msg("seed %u: %s", seed, err);
    return x;
}

/* The contract of issue 3 on the real super-shader: for 100 parametrizations, the
 * sub-shader's four maps equal the super-shader's at 4,096 random points each.
 * IMSYNTH_TEST_QUICK (set for the sanitizer run of scripts/test) checks 10. */
static void test_supershader_100_seeds(void **state)
{
    (void)state;
    sg_params params;
    sg_graph *g = load_supershader(&params);
    char err[SG_ERROR_MAX] = "";
    enum { B = 256, BATCHES = 16 }; /* 4,096 points */
    static float storage[48 * B], a[4][3 * B], b[4][3 * B];
    float *pa[4] = {a[0], a[1], a[2], a[3]}, *pb[4] = {b[0], b[1], b[2], b[3]};
    unsigned seeds = getenv("IMSYNTH_TEST_QUICK") ? 10 : 100;
    long total_nodes = 0;
    for (unsigned seed = 0; seed < seeds; seed++) {
        sg_graph *x = extract_frame(g, &params, seed);
        sg_program *pg = sg_compile(g, maps, 4, NULL, err, sizeof err), *px = sg_compile(x, maps, 4, NULL, err, sizeof err);
        if (!pg || !px)
            fail_msg("seed %u: compile: %s", seed, err);
        sg_evaluator *eg = sg_evaluator_new(pg, B), *ex = sg_evaluator_new(px, B);
        for (int batch = 0; batch < BATCHES; batch++) {
            sg_geometry_batch gb;
            random_plane_points(seed * BATCHES + (unsigned)batch, B, storage, &gb);
            sg_evaluate(eg, &gb, pa);
            sg_evaluate(ex, &gb, pb);
            for (int k = 0; k < 4; k++) {
                int w = sg_socket_type_width(sg_program_output_type(pg, k));
                assert_int_equal(w, sg_socket_type_width(sg_program_output_type(px, k)));
                for (int i = 0; i < w * B; i++)
                    if (!same_value(a[k][i], b[k][i]))
                        fail_msg("seed %u: %s differs at point %d: %.9g vs %.9g", seed,
                                 maps[k].socket, i % B, (double)a[k][i], (double)b[k][i]);
            }
        }
        total_nodes += sg_graph_node_count(x);
        sg_evaluator_free(eg);
        sg_evaluator_free(ex);
        sg_program_free(pg);
        sg_program_free(px);
        sg_graph_free(x);
    }
    /* It must simplify: the thesis went from 507 nodes to about 30. */
    double mean = (double)total_nodes / seeds;
    print_message("super-shader: %d nodes, sub-shaders %.1f nodes on average\n",
                  sg_graph_node_count(g), mean);
    assert_true(mean < 0.5 * sg_graph_node_count(g));
    sg_params_free(&params);
    sg_graph_free(g);
}

/* The text's lines, sorted: two texts with the same lines in another order (a graph's
 * links listed in another order) give the same string. */
static char *sorted_lines(const char *text)
{
    size_t n = 1, len = strlen(text);
    for (size_t i = 0; i < len; i++)
        n += text[i] == '\n';
    char *copy = strdup(text), **line = malloc(n * sizeof *line), *out = malloc(len + 2);
    assert_non_null(copy);
    assert_non_null(line);
    assert_non_null(out);
    size_t k = 0;
    for (char *save = NULL, *t = strtok_r(copy, "\n", &save); t; t = strtok_r(NULL, "\n", &save))
        line[k++] = t;
    for (size_t a = 1; a < k; a++) /* insertion sort: a few hundred lines */
        for (size_t b = a; b > 0 && strcmp(line[b], line[b - 1]) < 0; b--) {
            char *t = line[b];
            line[b] = line[b - 1];
            line[b - 1] = t;
        }
    out[0] = 0;
    for (size_t a = 0, at = 0; a < k; a++) {
        size_t l = strlen(line[a]);
        memcpy(out + at, line[a], l);
        out[at + l] = '\n';
        out[at += l + 1] = 0;
    }
    free(copy);
    free(line);
    return out;
}

/* One sub-shader, one text: a selector whose choice the sub-shader does not use (an unused
 * pattern's) leaves the extracted JSON byte for byte as it was, not the same graph with its
 * links in another order (the folds add and remove links in an order that depends on what
 * they folded). The active-parameter test and the loss cache compare this text. */
static void test_same_subshader_same_text(void **state)
{
    (void)state;
    sg_params params;
    sg_graph *g = load_supershader(&params);
    char err[SG_ERROR_MAX] = "";
    unsigned seeds = getenv("IMSYNTH_TEST_QUICK") ? 8 : 40;
    int same_graph = 0;
    for (unsigned seed = 0; seed < seeds; seed++) {
        sg_graph *x = extract_frame(g, &params, seed);
        char *base = sg_graph_to_json(x), *base_sorted = sorted_lines(base);
        sg_graph_free(x);
        for (int k = 0; k < params.n; k++) {
            int choices = sg_param_mult_choices(params.names[k]);
            float kept = params.values[k];
            for (int c = 0; c < choices; c++) {
                float v = (float)((c + 0.5) / choices);
                if (v == kept)
                    continue;
                params.values[k] = v;
                if (sg_graph_bind_params(g, &params, err, sizeof err) < 0 ||
                    !(x = sg_extract(g, NULL, err, sizeof err)))
                    fail_msg("seed %u, %s: %s", seed, params.names[k], err);
                char *text = sg_graph_to_json(x), *text_sorted = sorted_lines(text);
                if (!strcmp(text_sorted, base_sorted)) {
                    same_graph++;
                    if (strcmp(text, base))
                        fail_msg("seed %u: %s = %g gives the same sub-shader in another order",
                                 seed, params.names[k], (double)v);
                }
                free(text);
                free(text_sorted);
                sg_graph_free(x);
            }
            params.values[k] = kept;
        }
        free(base);
        free(base_sorted);
    }
    print_message("%d selector changes left the sub-shader as it was\n", same_graph);
    assert_true(same_graph > 0);
    sg_params_free(&params);
    sg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_marble_unchanged),
        cmocka_unit_test(test_foldable_graph_simplifies_and_is_unchanged),
        cmocka_unit_test(test_supershader_100_seeds),
        cmocka_unit_test(test_same_subshader_same_text),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
