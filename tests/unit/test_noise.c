/*
 * Properties of the Noise and White Noise Texture kernels (kernels/noise_texture.c,
 * white_noise.c) that hold without Blender: the Blender 3.x mode (3.4's Noise Texture, and 3.4's Musgrave Texture
 * for what blender/compat_noise.py translates to it) agrees with the 4.x mode wherever
 * the two versions' algorithms are the same function, and departs from it only where
 * 4.x wraps large coordinates; normalized fBM stays in [0, 1]; Color's red channel is
 * Fac; huge coordinates are handled without undefined behaviour; unused outputs may be
 * NULL. Agreement with Blender itself is tested by test_blender_nodes on the rendered
 * references (tests/reference/nodes/noise_* and white_noise_*).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "shadergraph/node_type.h"

#define NPTS 96

enum { IN_VECTOR, IN_W, IN_SCALE, IN_DETAIL, IN_ROUGHNESS, IN_LACUNARITY, IN_OFFSET,
       IN_GAIN, IN_DISTORTION, N_IN };
enum { OUT_FAC, OUT_COLOR, N_OUT };
enum { P_DIMS, P_TYPE, P_NORMALIZE };
/* Enum indices in Blender's RNA order. */
enum { DIMS_1D, DIMS_2D, DIMS_3D, DIMS_4D };
enum { T_MULTIFRACTAL, T_RIDGED, T_HYBRID, T_FBM, T_HETERO };

typedef struct call {
    const sg_node_type *type;
    int prop[3];
    sg_blender_mode blender;
    float in[N_IN][3 * NPTS];
    float out[N_OUT][3 * NPTS];
} call;

/* Default inputs at NPTS scattered points of [-1, 2]^3 (a fixed, irregular pattern). */
static void call_init(call *c)
{
    memset(c, 0, sizeof *c);
    c->type = sg_node_type_find("ShaderNodeTexNoise");
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
        c->in[IN_VECTOR][i] = -1.0f + 0.0311f * (float)i;
        c->in[IN_VECTOR][NPTS + i] = 2.0f - 0.0297f * (float)((i * 7) % NPTS);
        c->in[IN_VECTOR][2 * NPTS + i] = 0.25f + 0.0413f * (float)((i * 13) % 41);
        c->in[IN_W][i] = 0.5f - 0.091f * (float)i;
    }
}

static void set_all(call *c, int input, float v)
{
    for (int i = 0; i < NPTS; i++)
        c->in[input][i] = v;
}

static void run(call *c, bool want_fac, bool want_color)
{
    const float *in[N_IN];
    float *out[N_OUT];
    for (int k = 0; k < N_IN; k++)
        in[k] = c->in[k];
    out[OUT_FAC] = want_fac ? c->out[OUT_FAC] : NULL;
    out[OUT_COLOR] = want_color ? c->out[OUT_COLOR] : NULL;
    sg_kernel_args a;
    memset(&a, 0, sizeof a);
    a.n = NPTS;
    a.blender = c->blender;
    a.prop = c->prop;
    a.in = in;
    a.out = out;
    c->type->kernel(&a);
}

/* Fac of the same node in both modes. */
static void run_both(call *c, float *fac4, float *fac3)
{
    c->blender = SG_BLENDER_4;
    run(c, true, false);
    memcpy(fac4, c->out[OUT_FAC], sizeof(float) * NPTS);
    c->blender = SG_BLENDER_3;
    run(c, true, false);
    memcpy(fac3, c->out[OUT_FAC], sizeof(float) * NPTS);
}

static float max_abs_diff(const float *a, const float *b)
{
    float m = 0.0f;
    for (int i = 0; i < NPTS; i++)
        m = fmaxf(m, fabsf(a[i] - b[i]));
    return m;
}

/* 3.4's normalized fBM sums 0.5 * noise + 0.5 per octave, 4.x sums the signed noise and
 * maps once: the same function while coordinates stay below 4.x's wrap at 100000. */
static void test_fbm_versions_agree_below_wrap(void **state)
{
    (void)state;
    call c;
    float f4[NPTS], f3[NPTS];
    for (int dims = DIMS_1D; dims <= DIMS_4D; dims++) {
        call_init(&c);
        c.prop[P_DIMS] = dims;
        set_all(&c, IN_DETAIL, 4.5f);
        set_all(&c, IN_ROUGHNESS, 0.6f);
        set_all(&c, IN_DISTORTION, 0.7f);
        run_both(&c, f4, f3);
        /* Last-bit differences only (3.4's SIMD mix rounds differently). */
        assert_true(max_abs_diff(f4, f3) <= 1e-6f);
    }
}

/* At Detail 15 the top octave runs at 2^15 times the coordinates: past 100000, where 4.x
 * wraps (DESIGN.md: the versions differ by up to 1e-2 there). */
static void test_fbm_versions_differ_past_wrap(void **state)
{
    (void)state;
    call c;
    float f4[NPTS], f3[NPTS];
    call_init(&c);
    set_all(&c, IN_SCALE, 40.0f);
    set_all(&c, IN_DETAIL, 15.0f);
    set_all(&c, IN_ROUGHNESS, 0.8f);
    run_both(&c, f4, f3);
    assert_true(max_abs_diff(f4, f3) > 1e-4f);
}

/* The 3.x mode evaluates the Musgrave Texture compat_noise.py builds: Detail + 1 and
 * Dimension -log(Roughness)/log(Lacunarity). With Lacunarity 2 and Roughness a power of
 * two, Lacunarity^-Dimension is exact, so each type must reproduce 4.x. */
static void test_musgrave_translation_matches_4x(void **state)
{
    (void)state;
    static const int types[] = {T_MULTIFRACTAL, T_RIDGED, T_HYBRID, T_HETERO, T_FBM};
    static const float details[] = {0.0f, 1.0f, 3.5f, 14.0f};
    call c;
    float f4[NPTS], f3[NPTS];
    for (size_t t = 0; t < sizeof types / sizeof types[0]; t++)
        for (size_t d = 0; d < sizeof details / sizeof details[0]; d++) {
            call_init(&c);
            c.prop[P_TYPE] = types[t];
            c.prop[P_NORMALIZE] = 0; /* fBM: the unnormalized one is a Musgrave fBM */
            set_all(&c, IN_SCALE, 1.5f);
            set_all(&c, IN_DETAIL, details[d]);
            set_all(&c, IN_ROUGHNESS, 0.5f);
            set_all(&c, IN_OFFSET, 0.8f);
            set_all(&c, IN_GAIN, 1.7f);
            run_both(&c, f4, f3);
            /* Not bit-identical: 3.4's SIMD Perlin interpolates as t*b + (1-t)*a, 4.x as
             * a + t*(b-a), a last-bit difference per octave. A wrong Detail offset or
             * Dimension would be off by ~0.1. */
            for (int i = 0; i < NPTS; i++)
                if (fabsf(f4[i] - f3[i]) > 1e-5f * fmaxf(1.0f, fabsf(f4[i])))
                    fail_msg("type %d detail %g point %d: 4.x %.9g, 3.x %.9g", types[t],
                             (double)details[d], i, (double)f4[i], (double)f3[i]);
        }
}

static void test_normalized_fbm_in_unit_range(void **state)
{
    (void)state;
    static const float detail[] = {0.0f, 2.5f, 15.0f};
    static const float rough[] = {0.0f, 0.5f, 1.0f};
    call c;
    for (int b = 0; b < 2; b++)
        for (int d = 0; d < 3; d++)
            for (int r = 0; r < 3; r++) {
                call_init(&c);
                c.blender = b ? SG_BLENDER_3 : SG_BLENDER_4;
                set_all(&c, IN_DETAIL, detail[d]);
                set_all(&c, IN_ROUGHNESS, rough[r]);
                run(&c, true, true);
                for (int i = 0; i < NPTS; i++) {
                    assert_true(c.out[OUT_FAC][i] >= 0.0f && c.out[OUT_FAC][i] <= 1.0f);
                    assert_true(c.out[OUT_COLOR][i] == c.out[OUT_FAC][i]);
                    for (int k = 1; k < 3; k++) {
                        float v = c.out[OUT_COLOR][k * NPTS + i];
                        assert_true(v >= 0.0f && v <= 1.0f);
                    }
                }
            }
}

/* Either output alone is written and the other NULL one left alone (ASan checks the
 * writes); the values do not depend on which outputs are wanted. */
static void test_outputs_optional(void **state)
{
    (void)state;
    call c;
    float fac_alone[NPTS];
    call_init(&c);
    c.prop[P_TYPE] = T_HYBRID;
    set_all(&c, IN_DISTORTION, 1.5f);
    run(&c, true, false);
    memcpy(fac_alone, c.out[OUT_FAC], sizeof fac_alone);
    memset(c.out, 0, sizeof c.out);
    run(&c, false, true);
    for (int i = 0; i < NPTS; i++)
        assert_true(c.out[OUT_FAC][i] == 0.0f && c.out[OUT_COLOR][i] == fac_alone[i]);
}

/* Coordinates beyond int32: 3.4 truncates the cell index to INT32_MIN with a zero
 * fraction, so every gradient is 0 and fBM is exactly 0.5; 4.x wraps them first and
 * still varies. Neither may overflow a conversion (UBSan). */
static void test_huge_coordinates(void **state)
{
    (void)state;
    call c;
    float f4[NPTS], f3[NPTS];
    call_init(&c);
    set_all(&c, IN_SCALE, 1e12f);
    set_all(&c, IN_DETAIL, 1.0f);
    run_both(&c, f4, f3);
    float lo = 1.0f, hi = 0.0f;
    for (int i = 0; i < NPTS; i++) {
        assert_true(f3[i] == 0.5f);
        assert_true(isfinite(f4[i]));
        lo = fminf(lo, f4[i]);
        hi = fmaxf(hi, f4[i]);
    }
    assert_true(hi - lo > 0.05f);
}

/* Sockets Blender hides: Offset for Multifractal/fBM, Gain also for Hetero Terrain; W
 * only in 1D/4D, Vector not in 1D. */
static void test_socket_availability(void **state)
{
    (void)state;
    const sg_node_type *t = sg_node_type_find("ShaderNodeTexNoise");
    assert_non_null(t);
    int prop[3] = {DIMS_3D, T_FBM, 1};
    assert_false(sg_socket_available(&t->inputs[IN_OFFSET], prop));
    assert_false(sg_socket_available(&t->inputs[IN_W], prop));
    assert_true(sg_socket_available(&t->inputs[IN_VECTOR], prop));
    prop[P_TYPE] = T_HETERO;
    assert_true(sg_socket_available(&t->inputs[IN_OFFSET], prop));
    assert_false(sg_socket_available(&t->inputs[IN_GAIN], prop));
    prop[P_TYPE] = T_RIDGED;
    assert_true(sg_socket_available(&t->inputs[IN_GAIN], prop));
    prop[P_DIMS] = DIMS_1D;
    assert_true(sg_socket_available(&t->inputs[IN_W], prop));
    assert_false(sg_socket_available(&t->inputs[IN_VECTOR], prop));
}

/* White Noise: Color's red channel is Value, everything in [0, 1], each dimension count
 * hashes differently, and an unlinked Vector is not Generated coordinates. */
static void test_white_noise(void **state)
{
    (void)state;
    const sg_node_type *t = sg_node_type_find("ShaderNodeTexWhiteNoise");
    assert_non_null(t);
    assert_int_equal(t->inputs[0].implicit, SG_IMPLICIT_NONE);
    float vec[3 * NPTS], w[NPTS], value[4][NPTS], color[3 * NPTS];
    for (int i = 0; i < NPTS; i++) {
        vec[i] = 0.37f * (float)i;
        vec[NPTS + i] = -0.21f * (float)i;
        vec[2 * NPTS + i] = 1.0f / (float)(i + 1);
        w[i] = 3.0f - 0.11f * (float)i;
    }
    for (int dims = DIMS_1D; dims <= DIMS_4D; dims++) {
        const float *in[2] = {vec, w};
        float *out[2] = {value[dims], color};
        int prop[1] = {dims};
        sg_kernel_args a;
        memset(&a, 0, sizeof a);
        a.n = NPTS;
        a.blender = SG_BLENDER_4;
        a.prop = prop;
        a.in = in;
        a.out = out;
        t->kernel(&a);
        for (int i = 0; i < NPTS; i++) {
            assert_true(color[i] == value[dims][i]);
            for (int k = 0; k < 3; k++)
                assert_true(color[k * NPTS + i] >= 0.0f && color[k * NPTS + i] <= 1.0f);
        }
    }
    for (int d = DIMS_1D; d < DIMS_4D; d++)
        assert_true(max_abs_diff(value[d], value[d + 1]) > 0.1f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fbm_versions_agree_below_wrap),
        cmocka_unit_test(test_fbm_versions_differ_past_wrap),
        cmocka_unit_test(test_musgrave_translation_matches_4x),
        cmocka_unit_test(test_normalized_fbm_in_unit_range),
        cmocka_unit_test(test_outputs_optional),
        cmocka_unit_test(test_huge_coordinates),
        cmocka_unit_test(test_socket_availability),
        cmocka_unit_test(test_white_noise),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
