/*
 * Properties of the Voronoi Texture kernel (kernels/voronoi.c) that hold without Blender:
 * F1 never exceeds F2, lattice points at Randomness 0, Normalize's divisor, the 3.x mode
 * ignoring 4.x's octave sockets, 3.x's search starting at 8, smooth F1 at smoothness 0,
 * and which sockets exist for which settings. Agreement with Blender itself is tested by
 * test_blender_nodes on the rendered references (tests/reference/nodes/voronoi_*).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "shadergraph/node_type.h"

#define NPTS 64

enum { IN_VECTOR, IN_W, IN_SCALE, IN_DETAIL, IN_ROUGHNESS, IN_LACUNARITY, IN_SMOOTHNESS,
       IN_EXPONENT, IN_RANDOMNESS, N_IN };
enum { OUT_DISTANCE, OUT_COLOR, OUT_POSITION, OUT_W, OUT_RADIUS, N_OUT };
enum { P_DIMS, P_METRIC, P_FEATURE, P_NORMALIZE };

typedef struct call {
    const sg_node_type *type;
    int prop[4];
    sg_blender_mode blender;
    float in[N_IN][3 * NPTS];
    float out[N_OUT][3 * NPTS];
} call;

/* Default inputs at NPTS scattered points (a fixed, irregular pattern). */
static void call_init(call *c)
{
    memset(c, 0, sizeof *c);
    c->type = sg_node_type_find("ShaderNodeTexVoronoi");
    assert_non_null(c->type);
    assert_int_equal(c->type->n_inputs, N_IN);
    assert_int_equal(c->type->n_outputs, N_OUT);
    c->blender = SG_BLENDER_4;
    for (int p = 0; p < c->type->n_props; p++)
        c->prop[p] = c->type->props[p].default_value;
    for (int k = IN_SCALE; k < N_IN; k++)
        for (int i = 0; i < NPTS; i++)
            c->in[k][i] = c->type->inputs[k].default_value[0];
    for (int i = 0; i < NPTS; i++) {
        c->in[IN_VECTOR][i] = -1.3f + 0.173f * (float)i;
        c->in[IN_VECTOR][NPTS + i] = 0.9f - 0.061f * (float)((i * 7) % 31);
        c->in[IN_VECTOR][2 * NPTS + i] = 0.25f + 0.037f * (float)((i * 13) % 17);
        c->in[IN_W][i] = 0.5f - 0.091f * (float)i;
    }
}

static void set_all(call *c, int input, float v)
{
    for (int i = 0; i < NPTS; i++)
        c->in[input][i] = v;
}

static void run(call *c)
{
    const float *in[N_IN];
    float *out[N_OUT];
    for (int k = 0; k < N_IN; k++)
        in[k] = c->in[k];
    for (int k = 0; k < N_OUT; k++)
        out[k] = c->out[k];
    sg_kernel_args a = {.n = NPTS, .blender = c->blender, .prop = c->prop, .in = in, .out = out};
    c->type->kernel(&a);
}

static void test_f1_not_above_f2(void **state)
{
    (void)state;
    for (int mode = 0; mode < 2; mode++)
        for (int dims = 0; dims < 4; dims++)
            for (int metric = 0; metric < 4; metric++) {
                call f1, f2;
                call_init(&f1);
                f1.blender = mode ? SG_BLENDER_3 : SG_BLENDER_4;
                f1.prop[P_DIMS] = dims;
                f1.prop[P_METRIC] = metric;
                set_all(&f1, IN_EXPONENT, 1.7f);
                f2 = f1;
                f2.prop[P_FEATURE] = 1; /* F2 */
                run(&f1);
                run(&f2);
                for (int i = 0; i < NPTS; i++)
                    assert_true(f1.out[OUT_DISTANCE][i] <= f2.out[OUT_DISTANCE][i]);
            }
}

/* Randomness 0 puts every point on a lattice corner: at a lattice point the F1 distance
 * is 0 and the position is the point itself. */
static void test_lattice_at_randomness_0(void **state)
{
    (void)state;
    call c;
    call_init(&c);
    set_all(&c, IN_RANDOMNESS, 0.0f);
    set_all(&c, IN_SCALE, 2.0f);
    for (int i = 0; i < NPTS; i++)
        for (int d = 0; d < 3; d++)
            c.in[IN_VECTOR][d * NPTS + i] = 0.5f * (float)((i * (d + 3)) % 11 - 5);
    run(&c);
    for (int i = 0; i < NPTS; i++) {
        assert_float_equal(c.out[OUT_DISTANCE][i], 0.0f, 0.0f);
        for (int d = 0; d < 3; d++)
            assert_float_equal(c.out[OUT_POSITION][d * NPTS + i], c.in[IN_VECTOR][d * NPTS + i],
                               0.0f);
    }
}

/* Normalize divides one octave's F1 by the largest F1 distance in a cell: the distance
 * from a cell's centre to its corner in the metric, sqrt(3) / 2 * (1 + randomness) for
 * Euclidean; F2's by twice that. */
static void test_normalize_divisor(void **state)
{
    (void)state;
    for (int feature = 0; feature < 2; feature++) {
        call plain, norm;
        call_init(&plain);
        plain.prop[P_FEATURE] = feature;
        set_all(&plain, IN_RANDOMNESS, 0.6f);
        norm = plain;
        norm.prop[P_NORMALIZE] = 1;
        run(&plain);
        run(&norm);
        const float max_distance = sqrtf(3.0f) * 0.8f * (feature ? 2.0f : 1.0f);
        for (int i = 0; i < NPTS; i++)
            assert_float_equal(norm.out[OUT_DISTANCE][i] * max_distance,
                               plain.out[OUT_DISTANCE][i], 1e-6);
    }
}

/* 3.4 has no Detail / Roughness / Lacunarity / Normalize: setting them changes nothing
 * in 3.x mode, and changes the 4.x result. */
static void test_3x_ignores_octaves(void **state)
{
    (void)state;
    for (int feature = 0; feature < 4; feature++) {
        call base, oct, oct4;
        call_init(&base);
        base.blender = SG_BLENDER_3;
        base.prop[P_FEATURE] = feature;
        oct = base;
        set_all(&oct, IN_DETAIL, 3.5f);
        set_all(&oct, IN_ROUGHNESS, 0.8f);
        set_all(&oct, IN_LACUNARITY, 2.5f);
        oct.prop[P_NORMALIZE] = 1;
        oct4 = oct;
        oct4.blender = SG_BLENDER_4;
        run(&base);
        run(&oct);
        run(&oct4);
        assert_memory_equal(base.out, oct.out, sizeof base.out);
        assert_memory_not_equal(base.out[OUT_DISTANCE], oct4.out[OUT_DISTANCE],
                                sizeof base.out[OUT_DISTANCE]);
    }
}

/* A Minkowski exponent of 0.05 makes distances of thousands. 3.x's search starts at 8
 * and finds nothing, 4.x's starts at FLT_MAX. */
static void test_search_start(void **state)
{
    (void)state;
    call c3, c4;
    call_init(&c3);
    c3.prop[P_METRIC] = 3;
    set_all(&c3, IN_EXPONENT, 0.05f);
    c3.blender = SG_BLENDER_3;
    c4 = c3;
    c4.blender = SG_BLENDER_4;
    run(&c3);
    run(&c4);
    for (int i = 0; i < NPTS; i++) {
        assert_float_equal(c3.out[OUT_DISTANCE][i], 8.0f, 0.0f);
        assert_true(c4.out[OUT_DISTANCE][i] > 8.0f);
    }
}

/* Smoothness 0: 4.x evaluates plain F1, bit for bit. */
static void test_smoothness_0_is_f1(void **state)
{
    (void)state;
    call f1, smooth;
    call_init(&f1);
    smooth = f1;
    smooth.prop[P_FEATURE] = 2;
    set_all(&smooth, IN_SMOOTHNESS, 0.0f);
    run(&f1);
    run(&smooth);
    assert_memory_equal(f1.out, smooth.out, sizeof f1.out);
}

/* Unused outputs are NULL: only the requested one is written. */
static void test_null_outputs(void **state)
{
    (void)state;
    call c;
    call_init(&c);
    c.prop[P_FEATURE] = 4; /* n-sphere radius */
    const float *in[N_IN];
    float *out[N_OUT] = {NULL, NULL, NULL, NULL, c.out[OUT_RADIUS]};
    for (int k = 0; k < N_IN; k++)
        in[k] = c.in[k];
    sg_kernel_args a = {.n = NPTS, .blender = SG_BLENDER_4, .prop = c.prop, .in = in, .out = out};
    c.type->kernel(&a);
    for (int i = 0; i < NPTS; i++)
        assert_true(c.out[OUT_RADIUS][i] > 0.0f && c.out[OUT_RADIUS][i] < 1.0f);
}

static bool available(const sg_node_type *t, const sg_socket_def *s, int dims, int metric,
                      int feature)
{
    int prop[4] = {dims, metric, feature, 0};
    (void)t;
    return sg_socket_available(s, prop);
}

/* Socket availability as Blender 4.3 shows it (bpy: socket.enabled). */
static void test_availability(void **state)
{
    (void)state;
    const sg_node_type *t = sg_node_type_find("ShaderNodeTexVoronoi");
    assert_non_null(t);
    const sg_socket_def *in = t->inputs, *out = t->outputs;
    assert_false(available(t, &in[IN_VECTOR], 0, 0, 0));
    assert_true(available(t, &in[IN_W], 0, 0, 0));
    assert_false(available(t, &in[IN_W], 2, 0, 0));
    assert_true(available(t, &in[IN_W], 3, 0, 0));
    assert_true(available(t, &in[IN_EXPONENT], 2, 3, 2));
    assert_false(available(t, &in[IN_EXPONENT], 2, 0, 0));
    assert_false(available(t, &in[IN_EXPONENT], 2, 3, 3));
    assert_false(available(t, &in[IN_DETAIL], 2, 0, 4));
    assert_true(available(t, &in[IN_DETAIL], 2, 0, 3));
    assert_true(available(t, &in[IN_SMOOTHNESS], 0, 0, 2));
    assert_false(available(t, &out[OUT_POSITION], 0, 0, 0));
    assert_true(available(t, &out[OUT_W], 0, 0, 1));
    assert_false(available(t, &out[OUT_W], 2, 0, 1));
    assert_false(available(t, &out[OUT_COLOR], 2, 0, 3));
    assert_true(available(t, &out[OUT_RADIUS], 2, 0, 4));
    assert_false(available(t, &out[OUT_DISTANCE], 2, 0, 4));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_f1_not_above_f2),
        cmocka_unit_test(test_lattice_at_randomness_0),
        cmocka_unit_test(test_normalize_divisor),
        cmocka_unit_test(test_3x_ignores_octaves),
        cmocka_unit_test(test_search_start),
        cmocka_unit_test(test_smoothness_0_is_f1),
        cmocka_unit_test(test_null_outputs),
        cmocka_unit_test(test_availability),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
