/*
 * Graph JSON loading, validation, saving; compiling and evaluating through groups,
 * reroutes and type conversions.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "shadergraph/shadergraph.h"

/* A small valid material: a Math node feeding Base Color, and a group. */
static const char *const valid_graph =
    "{\"format\": \"imsynth-graph/1\", \"name\": \"t\",\n"
    " \"nodes\": [\n"
    "  {\"name\": \"V\", \"type\": \"ShaderNodeValue\", \"outputs\": {\"Value\": 0.25}},\n"
    "  {\"name\": \"M\", \"type\": \"ShaderNodeMath\", \"properties\": {\"operation\": \"MULTIPLY\"},"
    "   \"inputs\": {\"Value_001\": 3.0}, \"location\": [10, 20], \"label\": \"times three\"},\n"
    "  {\"name\": \"G\", \"type\": \"ShaderNodeGroup\", \"group\": \"Add\", \"inputs\": {\"B\": 0.5}},\n"
    "  {\"name\": \"R\", \"type\": \"NodeReroute\"},\n"
    "  {\"name\": \"Principled BSDF\", \"type\": \"ShaderNodeBsdfPrincipled\"},\n"
    "  {\"name\": \"Material Output\", \"type\": \"ShaderNodeOutputMaterial\"}],\n"
    " \"links\": [\n"
    "  {\"from_node\": \"V\", \"from_socket\": \"Value\", \"to_node\": \"M\", \"to_socket\": \"Value\"},\n"
    "  {\"from_node\": \"M\", \"from_socket\": \"Value\", \"to_node\": \"G\", \"to_socket\": \"A\"},\n"
    "  {\"from_node\": \"G\", \"from_socket\": \"Sum\", \"to_node\": \"R\", \"to_socket\": \"Input\"},\n"
    "  {\"from_node\": \"R\", \"from_socket\": \"Output\", \"to_node\": \"Principled BSDF\", \"to_socket\": \"Base Color\"},\n"
    "  {\"from_node\": \"Principled BSDF\", \"from_socket\": \"BSDF\", \"to_node\": \"Material Output\", \"to_socket\": \"Surface\"}],\n"
    " \"groups\": {\"Add\": {\n"
    "   \"inputs\": [{\"name\": \"A\", \"type\": \"FLOAT\"}, {\"name\": \"B\", \"type\": \"FLOAT\", \"default\": 1.0}],\n"
    "   \"outputs\": [{\"name\": \"Sum\", \"type\": \"FLOAT\"}],\n"
    "   \"nodes\": [{\"name\": \"In\", \"type\": \"NodeGroupInput\"},\n"
    "             {\"name\": \"Add\", \"type\": \"ShaderNodeMath\"},\n"
    "             {\"name\": \"Out\", \"type\": \"NodeGroupOutput\"}],\n"
    "   \"links\": [{\"from_node\": \"In\", \"from_socket\": \"A\", \"to_node\": \"Add\", \"to_socket\": \"Value\"},\n"
    "             {\"from_node\": \"In\", \"from_socket\": \"B\", \"to_node\": \"Add\", \"to_socket\": \"Value_001\"},\n"
    "             {\"from_node\": \"Add\", \"from_socket\": \"Value\", \"to_node\": \"Out\", \"to_socket\": \"Sum\"}]}}}\n";

/* Replaces the first occurrence of `from` in valid_graph by `to`. */
static char *mutate(const char *from, const char *to)
{
    const char *at = strstr(valid_graph, from);
    assert_non_null(at);
    size_t n = strlen(valid_graph) - strlen(from) + strlen(to) + 1;
    char *s = malloc(n);
    assert_non_null(s);
    size_t pre = (size_t)(at - valid_graph);
    memcpy(s, valid_graph, pre);
    strcpy(s + pre, to);
    strcat(s, at + strlen(from));
    return s;
}

static sg_graph *load(const char *text, char *err, size_t errlen)
{
    return sg_graph_load_json(text, strlen(text), "t.json", err, errlen);
}

/* Loading `text` must fail with a message containing every given fragment. */
static void expect_error(const char *text, const char *frag1, const char *frag2)
{
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = load(text, err, sizeof err);
    if (g)
        fail_msg("accepted an invalid graph (expected \"%s\")", frag1);
    if (!strstr(err, "t.json") || !strstr(err, frag1) || (frag2 && !strstr(err, frag2)))
        fail_msg("message \"%s\" lacks \"%s\" / \"%s\"", err, frag1, frag2 ? frag2 : "");
}

static void expect_mutation_error(const char *from, const char *to, const char *frag1,
                                  const char *frag2)
{
    char *s = mutate(from, to);
    expect_error(s, frag1, frag2);
    free(s);
}

static void test_valid_graph_loads(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = load(valid_graph, err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    sg_graph_free(g);
}

static void test_rejects_bad_json_with_position(void **state)
{
    (void)state;
    expect_error("{\"format\": \"imsynth-graph/1\",\n \"nodes\": [,]}", "t.json:2:", "invalid JSON");
    expect_error("{\"format\": \"imsynth-graph/1\"} trailing", "unexpected text", NULL);
}

static void test_rejects_wrong_format(void **state)
{
    (void)state;
    expect_mutation_error("imsynth-graph/1", "imsynth-graph/2", "format", "not supported");
    expect_mutation_error("\"format\": \"imsynth-graph/1\",", "", "format", "missing");
}

static void test_rejects_unknown_things(void **state)
{
    (void)state;
    expect_mutation_error("ShaderNodeBsdfPrincipled", "ShaderNodeBsdfPrincipledX", "unknown node type",
                          "ShaderNodeBsdfPrincipledX");
    expect_mutation_error("\"Value_001\": 3.0", "\"Value_009\": 3.0", "Value_009", "no input socket");
    expect_mutation_error("\"operation\": \"MULTIPLY\"", "\"operation\": \"MULTIPLYY\"", "operation",
                          "MULTIPLYY");
    expect_mutation_error("\"operation\": \"MULTIPLY\"", "\"operationz\": \"MULTIPLY\"", "no property",
                          "operationz");
    expect_mutation_error("\"label\": \"times three\"", "\"lable\": \"x\"", "unknown key", "lable");
    expect_mutation_error("\"group\": \"Add\"", "\"group\": \"Nope\"", "unknown group", "Nope");
    expect_mutation_error("\"to_socket\": \"Base Color\"", "\"to_socket\": \"Base Colour\"",
                          "no input socket", "Base Colour");
    expect_mutation_error("\"from_node\": \"V\"", "\"from_node\": \"W\"", "links[0]", "no node named \"W\"");
}

static void test_rejects_bad_values(void **state)
{
    (void)state;
    /* 1e999 parses to infinity: not a finite float. */
    expect_mutation_error("\"Value_001\": 3.0", "\"Value_001\": 1e999", "Value_001", "finite");
    expect_mutation_error("\"Value_001\": 3.0", "\"Value_001\": 1e39", "Value_001", "finite");
    expect_mutation_error("\"Value_001\": 3.0", "\"Value_001\": [1, 2, 3]", "Value_001", "expected a number");
    expect_mutation_error("\"location\": [10, 20]", "\"location\": [10]", "location", NULL);
    expect_mutation_error("\"B\": 0.5", "\"B\": \"half\"", "inputs.B", "expected a number");
}

static void test_rejects_structural_errors(void **state)
{
    (void)state;
    /* Duplicate node name. */
    expect_mutation_error("{\"name\": \"R\",", "{\"name\": \"M\",", "duplicate node name", "\"M\"");
    /* Two links into one input. */
    expect_mutation_error("\"to_node\": \"G\", \"to_socket\": \"A\"", "\"to_node\": \"M\", \"to_socket\": \"Value\"",
                          "already has a link", NULL);
    /* A cycle: M feeds G feeds R ... make G feed M's second input. */
    expect_mutation_error("{\"from_node\": \"G\", \"from_socket\": \"Sum\", \"to_node\": \"R\", \"to_socket\": \"Input\"}",
                          "{\"from_node\": \"G\", \"from_socket\": \"Sum\", \"to_node\": \"M\", \"to_socket\": \"Value_001\"}",
                          "cycle", NULL);
    /* Shader into a colour socket. */
    expect_mutation_error("\"to_node\": \"Material Output\", \"to_socket\": \"Surface\"",
                          "\"to_node\": \"Material Output\", \"to_socket\": \"Displacement\"",
                          "cannot link SHADER", NULL);
    /* Hidden socket: Math's third input for MULTIPLY. */
    expect_mutation_error("\"to_node\": \"M\", \"to_socket\": \"Value\"}",
                          "\"to_node\": \"M\", \"to_socket\": \"Value_002\"}", "hidden", "Value_002");
    /* No Material Output. */
    expect_mutation_error("\"ShaderNodeOutputMaterial\"", "\"ShaderNodeBsdfPrincipled\"", "Material Output", NULL);
    /* A group that contains itself. */
    expect_mutation_error("{\"name\": \"Out\", \"type\": \"NodeGroupOutput\"}",
                          "{\"name\": \"Out\", \"type\": \"NodeGroupOutput\"},"
                          "{\"name\": \"Self\", \"type\": \"ShaderNodeGroup\", \"group\": \"Add\"}",
                          "contains itself", NULL);
    /* Group interface nodes outside a group. */
    expect_mutation_error("{\"name\": \"R\", \"type\": \"NodeReroute\"}",
                          "{\"name\": \"R\", \"type\": \"NodeGroupInput\"}", "only allowed inside a group", NULL);
}

static void test_round_trip_is_lossless(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = load(valid_graph, err, sizeof err);
    assert_non_null(g);
    char *a = sg_graph_to_json(g);
    sg_graph *h = load(a, err, sizeof err);
    if (!h)
        fail_msg("reload failed: %s\n%s", err, a);
    char *b = sg_graph_to_json(h);
    assert_string_equal(a, b);
    /* Values that matter survive: the label, the non-default input, the group default. */
    assert_non_null(strstr(a, "times three"));
    assert_non_null(strstr(a, "\"Value_001\":\t3"));
    assert_non_null(strstr(a, "0.25"));
    free(a);
    free(b);
    sg_graph_free(g);
    sg_graph_free(h);
}

static void test_save_file_is_atomic_and_reloads(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = load(valid_graph, err, sizeof err);
    assert_non_null(g);
    char path[] = IMSYNTH_BINARY_DIR "/test_graph_save.json";
    assert_int_equal(sg_graph_save_file(g, path, err, sizeof err), 0);
    sg_graph *h = sg_graph_load_file(path, err, sizeof err);
    assert_non_null(h);
    /* Saving into a missing directory fails with the path in the message. */
    assert_int_equal(sg_graph_save_file(g, IMSYNTH_BINARY_DIR "/no/such/dir/x.json", err, sizeof err), -1);
    assert_non_null(strstr(err, "no/such/dir/x.json"));
    remove(path);
    sg_graph_free(g);
    sg_graph_free(h);
}

/* Evaluate one float socket at 4 points of the plane. */
static void eval_float(const char *text, const char *node, const char *socket, float out[4])
{
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = load(text, err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    sg_socket_ref ref = {node, socket};
    sg_program *p = sg_compile(g, &ref, 1, NULL, err, sizeof err);
    if (!p)
        fail_msg("%s", err);
    sg_evaluator *e = sg_evaluator_new(p, 4);
    float geom[48 * 4], v[3 * 4];
    sg_geometry_batch gb;
    sg_plane_geometry(2, 2, 0, 4, geom, &gb);
    float *o[1] = {v};
    sg_evaluate(e, &gb, o);
    int w = sg_socket_type_width(sg_program_output_type(p, 0));
    for (int i = 0; i < 4; i++)
        out[i] = v[i]; /* first channel */
    (void)w;
    sg_evaluator_free(e);
    sg_program_free(p);
    sg_graph_free(g);
}

static void test_eval_through_group_and_reroute(void **state)
{
    (void)state;
    float v[4];
    /* 0.25 * 3 + 0.5 (the group node's B overrides the interface default 1.0). */
    eval_float(valid_graph, "Principled BSDF", "Base Color", v);
    for (int i = 0; i < 4; i++)
        assert_float_equal(v[i], 1.25f, 0.0f);
    eval_float(valid_graph, "M", "Value", v);
    assert_float_equal(v[0], 0.75f, 0.0f);
    /* Unlinked input reads its default. */
    eval_float(valid_graph, "Principled BSDF", "Roughness", v);
    assert_float_equal(v[0], 0.5f, 0.0f);
}

static void test_compile_errors(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = load(valid_graph, err, sizeof err);
    assert_non_null(g);
    sg_socket_ref bad[] = {{"Nope", "Value"}, {"M", "Nope"}, {"Principled BSDF", "BSDF"}};
    const char *frag[] = {"Nope", "Nope", "shader"};
    for (int i = 0; i < 3; i++) {
        sg_program *p = sg_compile(g, &bad[i], 1, NULL, err, sizeof err);
        assert_null(p);
        if (!strstr(err, frag[i]))
            fail_msg("\"%s\" lacks \"%s\"", err, frag[i]);
    }
    sg_graph_free(g);
}

static void test_socket_ref_parse(void **state)
{
    (void)state;
    sg_socket_ref r;
    char err[SG_ERROR_MAX] = "";
    char a[] = "Node:With:Colons:Fac";
    assert_int_equal(sg_socket_ref_parse(a, &r, err, sizeof err), 0);
    assert_string_equal(r.node, "Node:With:Colons");
    assert_string_equal(r.socket, "Fac");
    char b[] = "NoColon";
    assert_int_equal(sg_socket_ref_parse(b, &r, err, sizeof err), -1);
    char c[] = "Node:";
    assert_int_equal(sg_socket_ref_parse(c, &r, err, sizeof err), -1);
}

/* A colour into a float socket converts by luminance, a vector by the average, a
 * float into a colour broadcasts. */
static void test_link_conversions(void **state)
{
    (void)state;
    const char *text =
        "{\"format\": \"imsynth-graph/1\", \"nodes\": [\n"
        " {\"name\": \"C\", \"type\": \"ShaderNodeRGB\", \"outputs\": {\"Color\": [0.5, 0.25, 1.0, 1.0]}},\n"
        " {\"name\": \"M\", \"type\": \"ShaderNodeMath\"},\n"
        " {\"name\": \"Out\", \"type\": \"ShaderNodeOutputMaterial\"}],\n"
        " \"links\": [{\"from_node\": \"C\", \"from_socket\": \"Color\", \"to_node\": \"M\", \"to_socket\": \"Value\"},\n"
        "  {\"from_node\": \"M\", \"from_socket\": \"Value\", \"to_node\": \"Out\", \"to_socket\": \"Thickness\"}]}";
    float v[4];
    eval_float(text, "M", "Value", v);
    /* Math ADD with Value_001 default 0.5. */
    assert_float_equal(v[0], 0.5f * 0.2126f + 0.25f * 0.7152f + 1.0f * 0.0722f + 0.5f, 1e-6f);
}

/* Batch and pointwise evaluation run the same instructions: identical results. */
static void test_pointwise_equals_batch(void **state)
{
    (void)state;
    const char *text =
        "{\"format\": \"imsynth-graph/1\", \"nodes\": [\n"
        " {\"name\": \"T\", \"type\": \"ShaderNodeTexCoord\"},\n"
        " {\"name\": \"N\", \"type\": \"ShaderNodeTexNoise\", \"inputs\": {\"Detail\": 4.5}},\n"
        " {\"name\": \"B\", \"type\": \"ShaderNodeBump\"},\n"
        " {\"name\": \"Out\", \"type\": \"ShaderNodeOutputMaterial\"}],\n"
        " \"links\": [{\"from_node\": \"T\", \"from_socket\": \"Object\", \"to_node\": \"N\", \"to_socket\": \"Vector\"},\n"
        "  {\"from_node\": \"N\", \"from_socket\": \"Fac\", \"to_node\": \"B\", \"to_socket\": \"Height\"},\n"
        "  {\"from_node\": \"B\", \"from_socket\": \"Normal\", \"to_node\": \"Out\", \"to_socket\": \"Displacement\"}]}";
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = load(text, err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    sg_socket_ref ref[2] = {{"B", "Normal"}, {"N", "Color"}};
    sg_program *p = sg_compile(g, ref, 2, NULL, err, sizeof err);
    if (!p)
        fail_msg("%s", err);
    enum { N = 100 };
    sg_evaluator *e = sg_evaluator_new(p, N);
    static float geom[48 * N], a0[3 * N], a1[3 * N], b0[3 * N], b1[3 * N];
    sg_geometry_batch gb;
    sg_plane_geometry(64, 64, 1000, N, geom, &gb);
    float *oa[2] = {a0, a1}, *ob[2] = {b0, b1};
    sg_evaluate(e, &gb, oa);
    sg_evaluate_pointwise(e, &gb, ob);
    /* And a batch again, after pointwise changed the constants' layout. */
    sg_evaluate(e, &gb, oa);
    assert_memory_equal(a0, b0, sizeof a0);
    assert_memory_equal(a1, b1, sizeof a1);
    /* The bumped normal is unit length and tilted somewhere. */
    int tilted = 0;
    for (int i = 0; i < N; i++) {
        float x = a0[i], y = a0[N + i], z = a0[2 * N + i];
        assert_float_equal(x * x + y * y + z * z, 1.0f, 1e-5f);
        tilted += z < 0.999f;
    }
    assert_true(tilted > 0);
    /* Texture Coordinate and Noise are emitted for each of Bump's three offsets,
     * the Bump once: 3 * 2 + 1 instructions. */
    assert_int_equal(sg_program_instruction_count(p), 7);
    sg_evaluator_free(e);
    sg_program_free(p);
    sg_graph_free(g);
}

static void test_surface_bsdf(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = load(valid_graph, err, sizeof err);
    assert_non_null(g);
    const char *name = sg_graph_surface_bsdf(g, err, sizeof err);
    assert_non_null(name);
    assert_string_equal(name, "Principled BSDF");
    sg_graph_free(g);
    char *s = mutate("{\"from_node\": \"Principled BSDF\", \"from_socket\": \"BSDF\", \"to_node\": \"Material Output\", \"to_socket\": \"Surface\"}",
                     "{\"from_node\": \"Principled BSDF\", \"from_socket\": \"BSDF\", \"to_node\": \"Material Output\", \"to_socket\": \"Volume\"}");
    g = load(s, err, sizeof err);
    free(s);
    assert_non_null(g);
    assert_null(sg_graph_surface_bsdf(g, err, sizeof err));
    assert_non_null(strstr(err, "Surface"));
    sg_graph_free(g);
}

/* ---- limits (FORMAT.md, "Limits") ------------------------------------------------- */

/* Appends printf-formatted text to a growing buffer. */
typedef struct text_buf {
    char *s;
    size_t len, cap;
} text_buf;

static void put(text_buf *b, const char *fmt, ...)
{
    va_list ap;
    for (;;) {
        va_start(ap, fmt);
        int n = vsnprintf(b->s + b->len, b->cap - b->len, fmt, ap);
        va_end(ap);
        assert_true(n >= 0);
        if (b->len + (size_t)n < b->cap) {
            b->len += (size_t)n;
            return;
        }
        b->cap = 2 * (b->cap + (size_t)n);
        b->s = realloc(b->s, b->cap);
        assert_non_null(b->s);
    }
}

/* A material whose Roughness is fed by a chain of `n` Math nodes. */
static char *math_chain(int n)
{
    text_buf b = {malloc(1024), 0, 1024};
    assert_non_null(b.s);
    put(&b, "{\"format\": \"imsynth-graph/1\", \"nodes\": ["
            "{\"name\": \"O\", \"type\": \"ShaderNodeOutputMaterial\"},"
            "{\"name\": \"P\", \"type\": \"ShaderNodeBsdfPrincipled\"}");
    for (int i = 0; i < n; i++)
        put(&b, ",{\"name\": \"M%d\", \"type\": \"ShaderNodeMath\", \"inputs\": {\"Value_001\": 1e-5}}", i);
    put(&b, "], \"links\": [{\"from_node\": \"P\", \"from_socket\": \"BSDF\", \"to_node\": \"O\", "
            "\"to_socket\": \"Surface\"}");
    for (int i = 1; i < n; i++)
        put(&b, ",{\"from_node\": \"M%d\", \"from_socket\": \"Value\", \"to_node\": \"M%d\", "
                "\"to_socket\": \"Value\"}", i - 1, i);
    put(&b, ",{\"from_node\": \"M%d\", \"from_socket\": \"Value\", \"to_node\": \"P\", "
            "\"to_socket\": \"Roughness\"}]}", n - 1);
    return b.s;
}

/* Groups G0..G(depth-1), each G(k) two G(k-1) in series (G0 passes its input through):
 * a few kilobytes that inline to 2^(depth-1) group instances. */
static char *group_bomb(int depth)
{
    text_buf b = {malloc(1024), 0, 1024};
    assert_non_null(b.s);
    put(&b, "{\"format\": \"imsynth-graph/1\", \"nodes\": ["
            "{\"name\": \"O\", \"type\": \"ShaderNodeOutputMaterial\"},"
            "{\"name\": \"P\", \"type\": \"ShaderNodeBsdfPrincipled\"},"
            "{\"name\": \"T\", \"type\": \"ShaderNodeGroup\", \"group\": \"G%d\"}],"
            "\"links\": [{\"from_node\": \"P\", \"from_socket\": \"BSDF\", \"to_node\": \"O\", \"to_socket\": \"Surface\"},"
            "{\"from_node\": \"T\", \"from_socket\": \"V\", \"to_node\": \"P\", \"to_socket\": \"Roughness\"}],"
            "\"groups\": {", depth - 1);
    const char *io = "\"inputs\": [{\"name\": \"V\", \"type\": \"FLOAT\"}], "
                     "\"outputs\": [{\"name\": \"V\", \"type\": \"FLOAT\"}], ";
    put(&b, "\"G0\": {%s\"nodes\": [{\"name\": \"I\", \"type\": \"NodeGroupInput\"},"
            "{\"name\": \"U\", \"type\": \"NodeGroupOutput\"}], \"links\": [{\"from_node\": \"I\", "
            "\"from_socket\": \"V\", \"to_node\": \"U\", \"to_socket\": \"V\"}]}", io);
    for (int k = 1; k < depth; k++)
        put(&b, ",\"G%d\": {%s\"nodes\": [{\"name\": \"I\", \"type\": \"NodeGroupInput\"},"
                "{\"name\": \"A\", \"type\": \"ShaderNodeGroup\", \"group\": \"G%d\"},"
                "{\"name\": \"B\", \"type\": \"ShaderNodeGroup\", \"group\": \"G%d\"},"
                "{\"name\": \"U\", \"type\": \"NodeGroupOutput\"}], \"links\": ["
                "{\"from_node\": \"I\", \"from_socket\": \"V\", \"to_node\": \"A\", \"to_socket\": \"V\"},"
                "{\"from_node\": \"A\", \"from_socket\": \"V\", \"to_node\": \"B\", \"to_socket\": \"V\"},"
                "{\"from_node\": \"B\", \"from_socket\": \"V\", \"to_node\": \"U\", \"to_socket\": \"V\"}]}",
            k, io, k - 1, k - 1);
    put(&b, "}}");
    return b.s;
}

static void test_limits_refuse_before_work(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    /* At the limit a tree loads and compiles (the super-shader has 531 nodes). */
    char *at = math_chain(SG_MAX_TREE_NODES - 2);
    sg_graph *g = load(at, err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    sg_socket_ref ref = {"P", "Roughness"};
    sg_program *p = sg_compile(g, &ref, 1, NULL, err, sizeof err);
    if (!p)
        fail_msg("%s", err);
    sg_program_free(p);
    sg_graph_free(g);
    free(at);
    /* One past it, refused at load. */
    char *over = math_chain(SG_MAX_TREE_NODES - 1);
    expect_error(over, "nodes: 10001 nodes, more than the 10000", NULL);
    free(over);

    /* Nested groups: refused when inlined (the path through them is 2^39 interfaces
     * long), counted without expanding them. */
    char *bomb = group_bomb(40);
    g = load(bomb, err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    /* G(k) shows 2^(k+2) - 2 nodes: G39 more than INT_MAX. */
    assert_int_equal(sg_graph_node_count(g), INT_MAX);
    p = sg_compile(g, &ref, 1, NULL, err, sizeof err);
    assert_null(p);
    if (!strstr(err, "crosses more than 1000 reroutes and group interfaces"))
        fail_msg("\"%s\"", err);
    sg_graph_free(g);
    free(bomb);
    /* A small bomb counts exactly: G3 shows 2^5 - 2 nodes, next to O and P. */
    bomb = group_bomb(4);
    g = load(bomb, err, sizeof err);
    assert_non_null(g);
    assert_int_equal(sg_graph_node_count(g), 2 + 30);
    sg_graph_free(g);
    free(bomb);

    /* A file one byte over the size limit, refused before it is parsed. */
    char path[] = IMSYNTH_BINARY_DIR "/test_graph_too_large.json";
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs(valid_graph, f);
    for (size_t n = strlen(valid_graph); n <= SG_MAX_GRAPH_FILE_BYTES; n++)
        fputc(' ', f);
    assert_int_equal(fclose(f), 0);
    g = sg_graph_load_file(path, err, sizeof err);
    assert_null(g);
    if (!strstr(err, "test_graph_too_large.json: larger than the 16777216 bytes"))
        fail_msg("\"%s\"", err);
    remove(path);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_valid_graph_loads),
        cmocka_unit_test(test_rejects_bad_json_with_position),
        cmocka_unit_test(test_rejects_wrong_format),
        cmocka_unit_test(test_rejects_unknown_things),
        cmocka_unit_test(test_rejects_bad_values),
        cmocka_unit_test(test_rejects_structural_errors),
        cmocka_unit_test(test_round_trip_is_lossless),
        cmocka_unit_test(test_save_file_is_atomic_and_reloads),
        cmocka_unit_test(test_eval_through_group_and_reroute),
        cmocka_unit_test(test_compile_errors),
        cmocka_unit_test(test_socket_ref_parse),
        cmocka_unit_test(test_link_conversions),
        cmocka_unit_test(test_pointwise_equals_batch),
        cmocka_unit_test(test_surface_bsdf),
        cmocka_unit_test(test_limits_refuse_before_work),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
