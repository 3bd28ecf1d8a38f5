/*
 * Super-shader parameters: the sampling convention (3 decimals, Mult bin centres), the
 * generator against SplitMix64's published outputs, determinism, parameter files
 * (every kind of bad entry is an error naming file and parameter), atomic writes, and
 * binding into a graph.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <unistd.h>

#include <cmocka.h>

#include "shadergraph/shadergraph.h"

/* A material reading three parameters, "A", "Mult 3 B" and "C", from RandomValues.
 * Base Color = (A, B, C) so that evaluation shows what is bound. */
static const char *const small_graph =
    "{\"format\": \"imsynth-graph/1\", \"name\": \"small\",\n"
    " \"nodes\": [\n"
    "  {\"name\": \"RV\", \"type\": \"ShaderNodeGroup\", \"group\": \"RandomValues\"},\n"
    "  {\"name\": \"RGB\", \"type\": \"ShaderNodeCombineColor\"},\n"
    "  {\"name\": \"Principled BSDF\", \"type\": \"ShaderNodeBsdfPrincipled\"},\n"
    "  {\"name\": \"Material Output\", \"type\": \"ShaderNodeOutputMaterial\"}],\n"
    " \"links\": [\n"
    "  {\"from_node\": \"RV\", \"from_socket\": \"A\", \"to_node\": \"RGB\", \"to_socket\": \"Red\"},\n"
    "  {\"from_node\": \"RV\", \"from_socket\": \"Mult 3 B\", \"to_node\": \"RGB\", \"to_socket\": \"Green\"},\n"
    "  {\"from_node\": \"RV\", \"from_socket\": \"C\", \"to_node\": \"RGB\", \"to_socket\": \"Blue\"},\n"
    "  {\"from_node\": \"RGB\", \"from_socket\": \"Color\", \"to_node\": \"Principled BSDF\", \"to_socket\": \"Base Color\"},\n"
    "  {\"from_node\": \"Principled BSDF\", \"from_socket\": \"BSDF\", \"to_node\": \"Material Output\", \"to_socket\": \"Surface\"}],\n"
    " \"groups\": {\"RandomValues\": {\n"
    "   \"inputs\": [],\n"
    "   \"outputs\": [{\"name\": \"A\", \"type\": \"FLOAT\", \"default\": 0.25},\n"
    "               {\"name\": \"Mult 3 B\", \"type\": \"FLOAT\", \"default\": 0.5},\n"
    "               {\"name\": \"C\", \"type\": \"FLOAT\", \"default\": 0.75}],\n"
    "   \"nodes\": [{\"name\": \"A\", \"type\": \"ShaderNodeValue\", \"outputs\": {\"Value\": 0.25}},\n"
    "             {\"name\": \"B\", \"type\": \"ShaderNodeValue\", \"outputs\": {\"Value\": 0.5}},\n"
    "             {\"name\": \"C\", \"type\": \"ShaderNodeValue\", \"outputs\": {\"Value\": 0.75}},\n"
    "             {\"name\": \"Out\", \"type\": \"NodeGroupOutput\"}],\n"
    "   \"links\": [{\"from_node\": \"A\", \"from_socket\": \"Value\", \"to_node\": \"Out\", \"to_socket\": \"A\"},\n"
    "             {\"from_node\": \"B\", \"from_socket\": \"Value\", \"to_node\": \"Out\", \"to_socket\": \"Mult 3 B\"},\n"
    "             {\"from_node\": \"C\", \"from_socket\": \"Value\", \"to_node\": \"Out\", \"to_socket\": \"C\"}]}}}\n";

static sg_graph *load_small(void)
{
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_json(small_graph, strlen(small_graph), "small.json", err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    return g;
}

/* Base Color of g at one point of the plane. */
static void base_color(const sg_graph *g, float rgb[3])
{
    char err[SG_ERROR_MAX] = "";
    sg_socket_ref ref = {"Principled BSDF", "Base Color"};
    sg_program *p = sg_compile(g, &ref, 1, NULL, err, sizeof err);
    assert_non_null(p);
    sg_evaluator *e = sg_evaluator_new(p, 1);
    float storage[48];
    sg_geometry_batch geom;
    sg_plane_geometry(4, 4, 5, 1, storage, &geom);
    float *out[1] = {rgb};
    sg_evaluate(e, &geom, out);
    sg_evaluator_free(e);
    sg_program_free(p);
}

/* A params set with these names (values 0). */
static void make_params(sg_params *p, const char *const *names, int n)
{
    p->n = n;
    p->names = calloc((size_t)n, sizeof *p->names);
    p->values = calloc((size_t)n, sizeof *p->values);
    assert_non_null(p->names);
    assert_non_null(p->values);
    for (int i = 0; i < n; i++)
        p->names[i] = strdup(names[i]);
}

static void test_mult_choices(void **state)
{
    (void)state;
    assert_int_equal(sg_param_mult_choices("Mult 9 Noise A Pattern"), 9);
    assert_int_equal(sg_param_mult_choices("Mult 2 Bump Invert"), 2);
    assert_int_equal(sg_param_mult_choices("Mult 12"), 12);
    assert_int_equal(sg_param_mult_choices("Mult 1 Lonely"), 0);  /* not a choice */
    assert_int_equal(sg_param_mult_choices("Mult 0 X"), 0);
    assert_int_equal(sg_param_mult_choices("Mult X"), 0);
    assert_int_equal(sg_param_mult_choices("Mult 9x"), 0);
    assert_int_equal(sg_param_mult_choices("Multiplier 3"), 0);
    assert_int_equal(sg_param_mult_choices("mult 3 x"), 0); /* the convention is "Mult" */
    assert_int_equal(sg_param_mult_choices("Noise A Scale"), 0);
}

/* The generator is SplitMix64 seeded with the frame: frame 1234567's first draws are
 * the published SplitMix64 outputs for seed 1234567 (e.g. Rosetta Code, "Pseudo-random
 * numbers/Splitmix64"), taken through our documented conversion and rounding. */
static void test_sample_matches_splitmix64(void **state)
{
    (void)state;
    static const uint64_t published[5] = {
        UINT64_C(6457827717110365317), UINT64_C(3203168211198807973),
        UINT64_C(9817491932198370423), UINT64_C(4593380528125082431),
        UINT64_C(16408922859458223821)};
    const char *names[5] = {"p0", "p1", "p2", "p3", "p4"};
    sg_params p;
    make_params(&p, names, 5);
    sg_params_sample(&p, 1234567);
    for (int i = 0; i < 5; i++) {
        double u = (double)(published[i] >> 11) * 0x1.0p-53;
        float want = (float)(rint(u * 1000.0) / 1000.0);
        assert_true(p.values[i] == want);
    }
    sg_params_free(&p);
}

/* Every value is in [0, 1]; plain ones are multiples of 0.001; "Mult N" ones are a bin
 * centre (k + 0.5) / N or 1; the same frame gives the same set; values are uniform. */
static void test_sample_convention(void **state)
{
    (void)state;
    const char *names[6] = {"Plain", "Mult 9 Nine", "Mult 2 Two", "Other", "Mult 6 Six",
                            "Mult 4 Four"};
    sg_params p, q;
    make_params(&p, names, 6);
    make_params(&q, names, 6);
    enum { FRAMES = 20000 };
    double sum_plain = 0.0;
    int bins[6][10] = {{0}};
    for (int f = 0; f < FRAMES; f++) {
        sg_params_sample(&p, (unsigned long long)f);
        sg_params_sample(&q, (unsigned long long)f);
        assert_memory_equal(p.values, q.values, sizeof(float) * 6);
        for (int i = 0; i < 6; i++) {
            float v = p.values[i];
            assert_true(v >= 0.0f && v <= 1.0f);
            int n = sg_param_mult_choices(names[i]);
            if (!n) {
                double m = (double)v * 1000.0;
                assert_true(fabs(m - rint(m)) < 1e-3);
                sum_plain += v;
                continue;
            }
            int k = (int)floor((double)v * n);
            if (k >= n)
                k = n - 1;
            float centre = (float)((k + 0.5) / n);
            assert_true(v == centre || v == 1.0f);
            bins[i][k]++;
        }
    }
    /* Uniform: mean 0.5 (standard error 0.29/sqrt(20000) = 0.002; 5 sigma), each bin
     * 1/N of the frames (binomial standard error under 0.0036; 5 sigma). */
    assert_true(fabs(sum_plain / (2.0 * FRAMES) - 0.5) < 0.01);
    for (int i = 0; i < 6; i++) {
        int n = sg_param_mult_choices(names[i]);
        for (int k = 0; k < n; k++)
            assert_true(fabs((double)bins[i][k] / FRAMES - 1.0 / n) < 0.018);
    }
    /* Different frames give different sets. */
    sg_params_sample(&p, 1);
    sg_params_sample(&q, 2);
    assert_true(memcmp(p.values, q.values, sizeof(float) * 6) != 0);
    sg_params_free(&p);
    sg_params_free(&q);
}

/* u = 1.0 (possible after rounding) maps to 1, not past it. Found by searching frames
 * for a draw that rounds to 1.000 on a Mult parameter. */
static void test_sample_top_of_range(void **state)
{
    (void)state;
    const char *names[1] = {"Mult 3 Top"};
    const char *plain[1] = {"Top"};
    sg_params p, q;
    make_params(&p, names, 1);
    make_params(&q, plain, 1);
    int found = 0;
    for (unsigned long long f = 0; f < 100000 && !found; f++) {
        sg_params_sample(&q, f);
        if (q.values[0] == 1.0f) {
            sg_params_sample(&p, f);
            assert_true(p.values[0] == 1.0f);
            found = 1;
        }
    }
    assert_true(found); /* P(u >= 0.9995) = 1/2000 a frame */
    sg_params_free(&p);
    sg_params_free(&q);
}

static void test_from_graph_and_bind(void **state)
{
    (void)state;
    sg_graph *g = load_small();
    sg_params p;
    char err[SG_ERROR_MAX] = "";
    assert_int_equal(sg_params_from_graph(g, &p, err, sizeof err), 0);
    assert_int_equal(p.n, 3);
    assert_string_equal(p.names[0], "A");
    assert_string_equal(p.names[1], "Mult 3 B");
    assert_string_equal(p.names[2], "C");
    assert_true(p.values[0] == 0.25f && p.values[1] == 0.5f && p.values[2] == 0.75f);
    assert_int_equal(sg_params_index(&p, "C"), 2);
    assert_int_equal(sg_params_index(&p, "D"), -1);

    /* Bound values reach the evaluator. */
    p.values[0] = 0.125f;
    p.values[1] = 0.875f;
    p.values[2] = 0.0625f;
    assert_int_equal(sg_graph_bind_params(g, &p, err, sizeof err), 0);
    float rgb[3];
    base_color(g, rgb);
    assert_true(rgb[0] == 0.125f && rgb[1] == 0.875f && rgb[2] == 0.0625f);

    /* They survive saving and loading (Value nodes and interface defaults agree). */
    char *text = sg_graph_to_json(g);
    assert_non_null(text);
    sg_graph *g2 = sg_graph_load_json(text, strlen(text), "saved.json", err, sizeof err);
    assert_non_null(g2);
    sg_params q;
    assert_int_equal(sg_params_from_graph(g2, &q, err, sizeof err), 0);
    assert_memory_equal(p.values, q.values, sizeof(float) * 3);
    sg_params_free(&q);
    sg_graph_free(g2);
    free(text);

    /* A bad set is refused and leaves the graph as it was. */
    sg_params bad;
    assert_int_equal(sg_params_copy(&p, &bad), 0);
    bad.values[1] = 1.5f;
    assert_int_equal(sg_graph_bind_params(g, &bad, err, sizeof err), -1);
    assert_non_null(strstr(err, "Mult 3 B"));
    bad.values[1] = NAN;
    assert_int_equal(sg_graph_bind_params(g, &bad, err, sizeof err), -1);
    assert_non_null(strstr(err, "Mult 3 B"));
    base_color(g, rgb);
    assert_true(rgb[1] == 0.875f);
    sg_params_free(&bad);

    const char *two[2] = {"A", "C"};
    make_params(&bad, two, 2);
    assert_int_equal(sg_graph_bind_params(g, &bad, err, sizeof err), -1);
    assert_non_null(strstr(err, "\"Mult 3 B\": missing"));
    sg_params_free(&bad);
    const char *four[4] = {"A", "Mult 3 B", "C", "D"};
    make_params(&bad, four, 4);
    assert_int_equal(sg_graph_bind_params(g, &bad, err, sizeof err), -1);
    assert_non_null(strstr(err, "\"D\""));
    sg_params_free(&bad);

    sg_params_free(&p);
    sg_graph_free(g);
}

static void test_graph_without_parameters(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_params p;
    /* Rename the group: the graph still loads but has no parameter group. */
    char *text = strdup(small_graph);
    for (char *at; (at = strstr(text, "RandomValues"));)
        memcpy(at, "RandomVALUES", 12);
    sg_graph *g = sg_graph_load_json(text, strlen(text), "renamed.json", err, sizeof err);
    assert_non_null(g);
    assert_int_equal(sg_params_from_graph(g, &p, err, sizeof err), -1);
    assert_non_null(strstr(err, "RandomValues"));
    sg_graph_free(g);
    free(text);

    /* An output not fed by a Value node. */
    text = strdup(small_graph);
    char *link = strstr(text, "{\"from_node\": \"C\", \"from_socket\": \"Value\"");
    assert_non_null(link);
    char *end = strstr(link, "}");
    memset(link, ' ', (size_t)(end - link + 1));
    char *comma = link;
    while (*comma != ',')
        comma--;
    *comma = ' '; /* the comma before it: C's link was the last */
    g = sg_graph_load_json(text, strlen(text), "unfed.json", err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    assert_int_equal(sg_params_from_graph(g, &p, err, sizeof err), -1);
    assert_non_null(strstr(err, "\"C\" is not fed by a Value node"));
    sg_graph_free(g);
    free(text);
}

/* ---- files ---------------------------------------------------------------------- */

static char tmpdir[256];

static int setup_dir(void **state)
{
    (void)state;
    snprintf(tmpdir, sizeof tmpdir, "/tmp/imsynth_test_params_XXXXXX");
    return mkdtemp(tmpdir) ? 0 : -1;
}

static int remove_dir(void **state)
{
    (void)state;
    DIR *d = opendir(tmpdir);
    if (d) {
        struct dirent *e;
        char path[600];
        while ((e = readdir(d)))
            if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) {
                snprintf(path, sizeof path, "%s/%s", tmpdir, e->d_name);
                unlink(path);
            }
        closedir(d);
    }
    rmdir(tmpdir);
    return 0;
}

static int count_files(void)
{
    DIR *d = opendir(tmpdir);
    assert_non_null(d);
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        n += e->d_name[0] != '.';
    closedir(d);
    return n;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* Reading `text` as a parameter file for names A, "Mult 3 B", C fails, and the message
 * names the file and contains `expect`. */
static void expect_read_error(const char *text, const char *expect)
{
    const char *names[3] = {"A", "Mult 3 B", "C"};
    sg_params p;
    make_params(&p, names, 3);
    p.values[0] = 0.5f;
    char path[600];
    snprintf(path, sizeof path, "%s/bad.json", tmpdir);
    write_text(path, text);
    char err[SG_ERROR_MAX] = "";
    assert_int_equal(sg_params_read_file(path, &p, err, sizeof err), -1);
    if (!strstr(err, path) || !strstr(err, expect))
        fail_msg("message \"%s\" lacks \"%s\" or the path", err, expect);
    assert_true(p.values[0] == 0.5f); /* unchanged on error */
    sg_params_free(&p);
}

static void test_file_errors(void **state)
{
    (void)state;
    expect_read_error("{\"A\": 0.1, \"Mult 3 B\": 0.5}", "\"C\": missing");
    expect_read_error("{\"A\": 0.1, \"Mult 3 B\": 0.5, \"C\": 0.2, \"D\": 0.3}",
                      "\"D\": not a parameter");
    expect_read_error("{\"A\": 1.5, \"Mult 3 B\": 0.5, \"C\": 0.2}", "\"A\": 1.5 is outside [0, 1]");
    expect_read_error("{\"A\": 0.1, \"Mult 3 B\": -0.001, \"C\": 0.2}", "\"Mult 3 B\"");
    expect_read_error("{\"A\": 0.1, \"Mult 3 B\": 0.5, \"C\": \"0.2\"}", "\"C\": expected a number");
    expect_read_error("{\"A\": 0.1, \"Mult 3 B\": 0.5, \"C\": null}", "\"C\": expected a number");
    expect_read_error("{\"A\": 1e999, \"Mult 3 B\": 0.5, \"C\": 0.2}", "\"A\": value is not finite");
    expect_read_error("{\"A\": NaN, \"Mult 3 B\": 0.5, \"C\": 0.2}", "invalid JSON");
    expect_read_error("{\"A\": 0.1, \"A\": 0.2, \"Mult 3 B\": 0.5, \"C\": 0.2}", "\"A\": given twice");
    expect_read_error("{\"A\": 0.1,\n \"Mult 3 B\": 0.5,\n \"C\": }", ":3:");
    expect_read_error("[0.1, 0.5, 0.2]", "expected a JSON object");

    sg_params p;
    const char *names[1] = {"A"};
    make_params(&p, names, 1);
    char err[SG_ERROR_MAX] = "";
    assert_int_equal(sg_params_read_file("/nonexistent/params.json", &p, err, sizeof err), -1);
    assert_non_null(strstr(err, "/nonexistent/params.json"));
    assert_int_equal(sg_params_write_file("/nonexistent/dir/params.json", &p, err, sizeof err), -1);
    assert_non_null(strstr(err, "/nonexistent/dir/params.json"));
    sg_params_free(&p);
}

/* Sampled sets write and read back bit for bit, leave no temporary file behind, and an
 * existing file is replaced whole. */
static void test_file_round_trip(void **state)
{
    (void)state;
    sg_graph *g = load_small();
    sg_params p, q;
    char err[SG_ERROR_MAX] = "";
    assert_int_equal(sg_params_from_graph(g, &p, err, sizeof err), 0);
    assert_int_equal(sg_params_copy(&p, &q), 0);
    char path[600];
    snprintf(path, sizeof path, "%s/p.json", tmpdir);
    int before = count_files();
    for (unsigned long long f = 0; f < 200; f++) {
        sg_params_sample(&p, f);
        if (f == 7) /* values that need all 9 digits */
            p.values[2] = 0.1f + 1e-7f;
        assert_int_equal(sg_params_write_file(path, &p, err, sizeof err), 0);
        memset(q.values, 0, sizeof(float) * 3);
        assert_int_equal(sg_params_read_file(path, &q, err, sizeof err), 0);
        assert_memory_equal(p.values, q.values, sizeof(float) * 3);
    }
    assert_int_equal(count_files(), before + 1);
    /* In-memory text round trip too, and keys in the graph's order. */
    char *text = sg_params_to_json(&p);
    assert_non_null(text);
    assert_true(strstr(text, "\"A\"") < strstr(text, "\"Mult 3 B\""));
    assert_true(strstr(text, "\"Mult 3 B\"") < strstr(text, "\"C\""));
    assert_int_equal(sg_params_read_json(text, strlen(text), "mem", &q, err, sizeof err), 0);
    assert_memory_equal(p.values, q.values, sizeof(float) * 3);
    free(text);
    sg_params_free(&p);
    sg_params_free(&q);
    sg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mult_choices),
        cmocka_unit_test(test_sample_matches_splitmix64),
        cmocka_unit_test(test_sample_convention),
        cmocka_unit_test(test_sample_top_of_range),
        cmocka_unit_test(test_from_graph_and_bind),
        cmocka_unit_test(test_graph_without_parameters),
        cmocka_unit_test(test_file_errors),
        cmocka_unit_test(test_file_round_trip),
    };
    return cmocka_run_group_tests(tests, setup_dir, remove_dir);
}
