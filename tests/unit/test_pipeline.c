/*
 * pipeline/: SHA-256 against FIPS 180-2's examples, half-float conversion both ways,
 * finding data files, and the active-parameter mask's promise: changing an inactive
 * parameter alone changes no value of the material anywhere.
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

#include "nn/nn.h"
#include "pipeline/pipeline.h"

static void test_sha256(void **state)
{
    (void)state;
    char h[65];
    pipeline_sha256_hex("", 0, h);
    assert_string_equal(h, "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
    pipeline_sha256_hex("abc", 3, h);
    assert_string_equal(h, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    const char *two = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"; /* 56 bytes */
    pipeline_sha256_hex(two, strlen(two), h);
    assert_string_equal(h, "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
    char *million = malloc(1000000);
    memset(million, 'a', 1000000);
    pipeline_sha256_hex(million, 1000000, h);
    assert_string_equal(h, "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
    free(million);
}

static void test_half_float(void **state)
{
    (void)state;
    /* Every non-NaN half survives half -> float -> half. */
    for (uint32_t u = 0; u < 65536; u++) {
        uint16_t hv = (uint16_t)u;
        float f = nn_half_to_float(hv);
        if (isnan(f))
            continue;
        assert_int_equal(nn_float_to_half(f), hv);
    }
    /* Round to nearest, ties to even; overflow to infinity; NaN stays NaN. */
    assert_int_equal(nn_float_to_half(1.0f + 0x1p-11f), 0x3c00);             /* tie, down */
    assert_int_equal(nn_float_to_half(1.0f + 3 * 0x1p-11f), 0x3c02);         /* tie, up */
    assert_int_equal(nn_float_to_half(1.0f + 0x1p-11f + 0x1p-20f), 0x3c01);  /* above tie */
    assert_int_equal(nn_float_to_half(65504.0f), 0x7bff);
    assert_int_equal(nn_float_to_half(65520.0f), 0x7c00);
    assert_int_equal(nn_float_to_half(-1e9f), 0xfc00);
    assert_int_equal(nn_float_to_half(0x1p-25f), 0x0000);                    /* tie to 0 */
    assert_int_equal(nn_float_to_half(0x1p-25f + 0x1p-30f), 0x0001);
    assert_true(isnan(nn_half_to_float(nn_float_to_half(NAN))));
}

static void test_find_data(void **state)
{
    (void)state;
    char out[1024], err[1024];
    assert_int_equal(pipeline_find_data("/etc/hostname-not-checked", out, sizeof out, err, sizeof err), 0);
    assert_string_equal(out, "/etc/hostname-not-checked");
    setenv("IMSYNTH_DATA", IMSYNTH_SOURCE_DIR, 1);
    assert_int_equal(pipeline_find_data("assets/scene.json", out, sizeof out, err, sizeof err), 0);
    assert_string_equal(out, IMSYNTH_SOURCE_DIR "/assets/scene.json");
    assert_int_equal(pipeline_find_data("assets/no-such-file.json", out, sizeof out, err, sizeof err), -1);
    assert_non_null(strstr(err, "assets/no-such-file.json: not found"));
    assert_non_null(strstr(err, "IMSYNTH_DATA"));
    unsetenv("IMSYNTH_DATA");
}

static const sg_socket_ref maps[4] = {{"Principled BSDF", "Base Color"},
                                      {"Principled BSDF", "Metallic"},
                                      {"Principled BSDF", "Roughness"},
                                      {"Principled BSDF", "Normal"}};
enum { RES = 24, N = RES * RES };

/* The four maps of g over a RES x RES view of the plane, 3 N floats each, into out. */
static void eval_maps(const sg_graph *g, float *out)
{
    char err[SG_ERROR_MAX] = "";
    sg_compile_options opt = {.blender = SG_BLENDER_4};
    sg_program *p = sg_compile(g, maps, 4, &opt, err, sizeof err);
    if (!p)
        fail_msg("compile: %s", err);
    sg_evaluator *e = sg_evaluator_new(p, N);
    memset(out, 0, 12 * N * sizeof(float)); /* float maps fill N of their 3N */
    float *geom = malloc(48 * N * sizeof(float));
    sg_geometry_batch gb;
    sg_plane_geometry(RES, RES, 0, N, geom, &gb);
    float *o[4] = {out, out + 3 * N, out + 6 * N, out + 9 * N};
    sg_evaluate(e, &gb, o);
    free(geom);
    sg_evaluator_free(e);
    sg_program_free(p);
}

static int same_maps(const float *a, const float *b)
{
    for (int i = 0; i < 12 * N; i++)
        if (!(a[i] == b[i] || (isnan(a[i]) && isnan(b[i])))) {
            if (getenv("DEBUG_MAPS"))
                fprintf(stderr, "map %d point %d: %.9g vs %.9g\n", i / (3 * N), i % N, (double)a[i], (double)b[i]);
            return 0;
        }
    return 1;
}

/* Binds p's values with parameter k at v and evaluates the maps. */
static void eval_with(sg_graph *g, sg_params *p, int k, float v, float *out)
{
    float keep = p->values[k];
    p->values[k] = v;
    char err[SG_ERROR_MAX] = "";
    assert_int_equal(sg_graph_bind_params(g, p, err, sizeof err), 0);
    eval_maps(g, out);
    p->values[k] = keep;
    assert_int_equal(sg_graph_bind_params(g, p, err, sizeof err), 0);
}

static void test_inactive_params_change_nothing(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(IMSYNTH_SOURCE_DIR "/assets/supershader.json", err, sizeof err);
    assert_non_null(g);
    sg_params p;
    assert_int_equal(sg_params_from_graph(g, &p, err, sizeof err), 0);
    float *base = malloc(12 * N * sizeof(float)), *other = malloc(12 * N * sizeof(float));
    int seeds = getenv("IMSYNTH_TEST_QUICK") ? 2 : 6, inactive_total = 0, active_total = 0;
    int active_changed = 0;
    for (int s = 0; s < seeds; s++) {
        sg_params_sample(&p, (unsigned long long)(1000 + s));
        assert_int_equal(sg_graph_bind_params(g, &p, err, sizeof err), 0);
        uint8_t active[64];
        int nodes = 0;
        char msg[512];
        assert_int_equal(pipeline_active_params(g, 4, active, &nodes, msg, sizeof msg), 0);
        assert_true(nodes > 5 && nodes < 200);
        eval_maps(g, base);
        for (int k = 0; k < p.n; k++) {
            int choices = sg_param_mult_choices(p.names[k]);
            if (!active[k]) {
                inactive_total++;
                /* Every other choice of a selector; for a value, values the mask did not
                 * try (it tries v + j/8 and the ends). */
                int n = choices >= 2 ? choices : 4;
                for (int c = 0; c < n; c++) {
                    float v = choices >= 2 ? ((float)c + 0.5f) / (float)choices
                                           : fmodf(p.values[k] + 0.1f + 0.2f * (float)c, 1.0f);
                    eval_with(g, &p, k, v, other);
                    if (!same_maps(base, other))
                        fail_msg("seed %d: inactive \"%s\" at %g changes the material", 1000 + s,
                                 p.names[k], (double)v);
                }
            } else {
                active_total++;
                /* Active by the sub-shader; most of them visibly so. */
                float v = choices >= 2 ? fmodf(p.values[k] + 1.0f / (float)choices, 1.0f)
                                       : fmodf(p.values[k] + 0.5f, 1.0f);
                eval_with(g, &p, k, v, other);
                active_changed += !same_maps(base, other);
            }
        }
        /* The mask left g's parameters as they were. */
        eval_maps(g, other);
        assert_true(same_maps(base, other));
    }
    printf("%d active (%d of them changed the maps by one move), %d inactive over %d seeds\n",
           active_total, active_changed, inactive_total, seeds);
    assert_true(inactive_total > 0);
    assert_true(active_total > 0);
    assert_true(active_changed > active_total / 2);
    free(base);
    free(other);
    sg_params_free(&p);
    sg_graph_free(g);
}

/* Shared among threads, each on its own copy of the graph (the copies bound to other
 * parameters), the test gives the one-thread answer, and every graph keeps its own
 * parameters. */
static void test_active_params_shared(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g[3];
    for (int i = 0; i < 3; i++) {
        g[i] = sg_graph_load_file(IMSYNTH_SOURCE_DIR "/assets/supershader.json", err, sizeof err);
        assert_non_null(g[i]);
    }
    sg_params p, q;
    assert_int_equal(sg_params_from_graph(g[0], &p, err, sizeof err), 0);
    assert_int_equal(sg_params_from_graph(g[0], &q, err, sizeof err), 0);
    for (int i = 1; i < 3; i++) {
        sg_params_sample(&q, (unsigned long long)(500 + i));
        assert_int_equal(sg_graph_bind_params(g[i], &q, err, sizeof err), 0);
    }
    int seeds = getenv("IMSYNTH_TEST_QUICK") ? 2 : 4, differ = 0;
    uint8_t first[64];
    for (int s = 0; s < seeds; s++) {
        sg_params_sample(&p, (unsigned long long)(3000 + s));
        assert_int_equal(sg_graph_bind_params(g[0], &p, err, sizeof err), 0);
        uint8_t one[64], two[64], three[64];
        int n1 = 0, n3 = 0;
        char msg[512];
        assert_int_equal(pipeline_active_params(g[0], 4, one, &n1, msg, sizeof msg), 0);
        assert_int_equal(pipeline_active_params_on(g, 2, 4, two, NULL, msg, sizeof msg), 0);
        assert_int_equal(pipeline_active_params_on(g, 3, 4, three, &n3, msg, sizeof msg), 0);
        assert_memory_equal(one, two, (size_t)p.n);
        assert_memory_equal(one, three, (size_t)p.n);
        assert_int_equal(n1, n3);
        if (s == 0)
            memcpy(first, one, (size_t)p.n);
        else
            differ += memcmp(first, one, (size_t)p.n) != 0;
        for (int i = 0; i < 3; i++) {
            sg_params now;
            assert_int_equal(sg_params_from_graph(g[i], &now, err, sizeof err), 0);
            if (i > 0)
                sg_params_sample(&q, (unsigned long long)(500 + i));
            assert_memory_equal(now.values, i ? q.values : p.values, sizeof(float) * (size_t)p.n);
            sg_params_free(&now);
        }
    }
    assert_true(differ > 0); /* the sets differ: the comparison could fail */
    sg_params_free(&p);
    sg_params_free(&q);
    for (int i = 0; i < 3; i++)
        sg_graph_free(g[i]);
}

/* Hypotheses that differ only in an inactive parameter extract alike and are kept once;
 * a different material is kept; g's parameters come back unchanged. */
static void test_distinct_subshaders(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(IMSYNTH_SOURCE_DIR "/assets/supershader.json", err, sizeof err);
    assert_non_null(g);
    sg_params p;
    assert_int_equal(sg_params_from_graph(g, &p, err, sizeof err), 0);
    int n = p.n, found = 0;
    float *sets = malloc(sizeof(float) * 4 * (size_t)n);
    for (int s = 0; s < 20 && !found; s++) {
        sg_params_sample(&p, (unsigned long long)(2000 + s));
        assert_int_equal(sg_graph_bind_params(g, &p, err, sizeof err), 0);
        uint8_t active[64];
        char msg[512];
        assert_int_equal(pipeline_active_params(g, 4, active, NULL, msg, sizeof msg), 0);
        for (int k = 0; k < n && !found; k++)
            if (!active[k] && sg_param_mult_choices(p.names[k]) == 0) {
                memcpy(sets, p.values, sizeof(float) * (size_t)n);                 /* A */
                memcpy(sets + n, p.values, sizeof(float) * (size_t)n);             /* A, k moved */
                sets[n + k] = fmodf(p.values[k] + 0.3f, 1.0f);
                sg_params_sample(&p, (unsigned long long)(9000 + s));              /* B */
                memcpy(sets + 2 * n, p.values, sizeof(float) * (size_t)n);
                memcpy(sets + 3 * n, sets, sizeof(float) * (size_t)n);             /* A again */
                found = 1;
            }
    }
    assert_true(found);
    sg_params_sample(&p, 77);
    assert_int_equal(sg_graph_bind_params(g, &p, err, sizeof err), 0);
    int index[4];
    char msg[512];
    assert_int_equal(pipeline_distinct_subshaders(g, 4, sets, 4, 4, index, msg, sizeof msg), 2);
    assert_int_equal(index[0], 0);
    assert_int_equal(index[1], 2);
    assert_int_equal(pipeline_distinct_subshaders(g, 4, sets, 4, 1, index, msg, sizeof msg), 1);
    sg_params now;
    assert_int_equal(sg_params_from_graph(g, &now, err, sizeof err), 0);
    assert_memory_equal(now.values, p.values, sizeof(float) * (size_t)n);
    sg_params_free(&now);
    free(sets);
    sg_params_free(&p);
    sg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sha256),
        cmocka_unit_test(test_half_float),
        cmocka_unit_test(test_find_data),
        cmocka_unit_test(test_inactive_params_change_nothing),
        cmocka_unit_test(test_active_params_shared),
        cmocka_unit_test(test_distinct_subshaders),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
