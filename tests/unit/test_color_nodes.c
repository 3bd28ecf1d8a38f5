/*
 * Properties of the colour and converter node kernels (kernels/color.c, convert.c) that
 * do not need Blender to check: where a CONSTANT ramp steps in each Blender mode (the
 * table sizes differ), identities of Mix, Invert and Mapping, and Cycles' unwrapped HSV.
 * Agreement with Blender itself is tested by test_blender_nodes on rendered references.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "kernel_call.h"

/* ---- Color Ramp ------------------------------------------------------------------- */

static sg_color_ramp two_stop_ramp(int interpolation, float second_position)
{
    sg_color_ramp r;
    memset(&r, 0, sizeof r);
    r.interpolation = interpolation;
    r.n = 2;
    r.position[0] = 0.0f;
    r.color[0][3] = 1.0f;
    r.position[1] = second_position;
    for (int ch = 0; ch < 4; ch++)
        r.color[1][ch] = 1.0f;
    return r;
}

/* Blender 3.4 samples 256 entries at i/255, 4.3 257 entries at i/256; a CONSTANT ramp
 * reads the entry at floor(f * (size - 1)), so a step at 0.5 lands at 128/255 in 3.4
 * and at 0.5 in 4.3 (both measured in Blender). */
static void test_ramp_constant_step(void **state)
{
    (void)state;
    sg_color_ramp ramp = two_stop_ramp(4 /* CONSTANT */, 0.5f);
    const float fac[4] = {0.4999f, 0.5f, 0.5019f, 0.502f};
    const float white4[4] = {0.0f, 1.0f, 1.0f, 1.0f};
    const float white3[4] = {0.0f, 0.0f, 0.0f, 1.0f};
    for (int mode = 0; mode < 2; mode++) {
        kernel_call c;
        kc_init(&c, "ShaderNodeValToRGB", 4);
        c.ramp = &ramp;
        c.blender = mode ? SG_BLENDER_3 : SG_BLENDER_4;
        for (int i = 0; i < 4; i++)
            kc_set(&c, "Fac", i, fac[i], 0, 0);
        kc_run(&c);
        for (int i = 0; i < 4; i++) {
            float want = mode ? white3[i] : white4[i];
            assert_float_equal(kc_out(&c, "Color", i, 0), want, 0.0f);
            assert_float_equal(kc_out(&c, "Alpha", i, 0), 1.0f, 0.0f);
        }
    }
}

/* A linear ramp from black to white is the identity, whatever the table size; outside
 * [0, 1] the lookup clamps. */
static void test_ramp_linear_identity(void **state)
{
    (void)state;
    sg_color_ramp ramp = two_stop_ramp(2 /* LINEAR */, 1.0f);
    const float fac[6] = {-0.5f, 0.0f, 0.123f, 0.5f, 0.987f, 3.0f};
    for (int mode = 0; mode < 2; mode++) {
        kernel_call c;
        kc_init(&c, "ShaderNodeValToRGB", 6);
        c.ramp = &ramp;
        c.blender = mode ? SG_BLENDER_3 : SG_BLENDER_4;
        for (int i = 0; i < 6; i++)
            kc_set(&c, "Fac", i, fac[i], 0, 0);
        kc_run(&c);
        for (int i = 0; i < 6; i++) {
            float want = fminf(fmaxf(fac[i], 0.0f), 1.0f);
            for (int ch = 0; ch < 3; ch++)
                assert_float_equal(kc_out(&c, "Color", i, ch), want, 1e-6f);
        }
    }
}

/* HSV blending with FAR hue interpolation between two stops of the same hue goes once
 * round the colour circle: half way, the hue is opposite. */
static void test_ramp_hsv_far(void **state)
{
    (void)state;
    sg_color_ramp ramp = two_stop_ramp(2, 1.0f);
    ramp.color_mode = 1;        /* HSV */
    ramp.hue_interpolation = 1; /* FAR */
    for (int s = 0; s < 2; s++) {
        ramp.color[s][0] = 1.0f; /* pure red at both ends */
        ramp.color[s][1] = 0.0f;
        ramp.color[s][2] = 0.0f;
    }
    kernel_call c;
    kc_init(&c, "ShaderNodeValToRGB", 1);
    c.ramp = &ramp;
    kc_set(&c, "Fac", 0, 0.5f, 0, 0);
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Color", 0, 0), 0.0f, 1e-3f);
    assert_float_equal(kc_out(&c, "Color", 0, 1), 1.0f, 1e-3f);
    assert_float_equal(kc_out(&c, "Color", 0, 2), 1.0f, 1e-3f);
}

/* Blender stores ramp colours clamped below at 0: a negative channel acts as 0. */
static void test_ramp_negative_colour_is_zero(void **state)
{
    (void)state;
    sg_color_ramp ramp = two_stop_ramp(2, 1.0f);
    ramp.color[0][0] = -2.0f;
    ramp.color[1][0] = -1.0f;
    ramp.color[1][1] = 3.0f;
    kernel_call c;
    kc_init(&c, "ShaderNodeValToRGB", 1);
    c.ramp = &ramp;
    kc_set(&c, "Fac", 0, 0.5f, 0, 0);
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Color", 0, 0), 0.0f, 0.0f);
    assert_float_equal(kc_out(&c, "Color", 0, 1), 1.5f, 1e-6f);
}

/* ---- Mix ---------------------------------------------------------------------------- */

/* The new Mix node leaves the factor alone when clamp_factor is off (extrapolates);
 * legacy MixRGB always clamps it (Cycles' svm_mix_clamped_factor). */
static void test_mix_factor_clamping(void **state)
{
    (void)state;
    kernel_call c;
    kc_init(&c, "ShaderNodeMix", 1);
    kc_set_prop(&c, "data_type", "RGBA");
    kc_set_prop(&c, "clamp_factor", "false");
    kc_set(&c, "Factor_Float", 0, 2.0f, 0, 0);
    kc_set(&c, "A_Color", 0, 0.25f, 0.5f, 0.0f);
    kc_set(&c, "B_Color", 0, 0.5f, 0.5f, 1.0f);
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Result_Color", 0, 0), 0.75f, 1e-6f);
    assert_float_equal(kc_out(&c, "Result_Color", 0, 2), 2.0f, 1e-6f);

    kc_set_prop(&c, "clamp_result", "true");
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Result_Color", 0, 2), 1.0f, 0.0f);

    kernel_call l;
    kc_init(&l, "ShaderNodeMixRGB", 1);
    kc_set(&l, "Fac", 0, 2.0f, 0, 0);
    kc_set(&l, "Color1", 0, 0.25f, 0.5f, 0.0f);
    kc_set(&l, "Color2", 0, 0.5f, 0.5f, 1.0f);
    kc_run(&l);
    assert_float_equal(kc_out(&l, "Color", 0, 0), 0.5f, 1e-6f);
    assert_float_equal(kc_out(&l, "Color", 0, 2), 1.0f, 1e-6f);
}

static void test_mix_vector_non_uniform(void **state)
{
    (void)state;
    kernel_call c;
    kc_init(&c, "ShaderNodeMix", 1);
    kc_set_prop(&c, "data_type", "VECTOR");
    kc_set_prop(&c, "factor_mode", "NON_UNIFORM");
    kc_set(&c, "Factor_Vector", 0, 0.0f, 0.5f, 1.0f);
    kc_set(&c, "A_Vector", 0, 1.0f, 1.0f, 1.0f);
    kc_set(&c, "B_Vector", 0, 3.0f, 3.0f, 3.0f);
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Result_Vector", 0, 0), 1.0f, 0.0f);
    assert_float_equal(kc_out(&c, "Result_Vector", 0, 1), 2.0f, 0.0f);
    assert_float_equal(kc_out(&c, "Result_Vector", 0, 2), 3.0f, 0.0f);
}

/* ---- Invert, Combine/Separate Color --------------------------------------------------- */

static void test_invert(void **state)
{
    (void)state;
    kernel_call c;
    kc_init(&c, "ShaderNodeInvert", 2);
    kc_set(&c, "Color", 0, 0.2f, 1.5f, -1.0f);
    kc_set(&c, "Color", 1, 0.2f, 1.5f, -1.0f);
    kc_set(&c, "Fac", 1, 0.5f, 0, 0);
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Color", 0, 0), 0.8f, 1e-6f);
    assert_float_equal(kc_out(&c, "Color", 0, 1), -0.5f, 1e-6f);
    assert_float_equal(kc_out(&c, "Color", 0, 2), 2.0f, 1e-6f);
    for (int ch = 0; ch < 3; ch++)
        assert_float_equal(kc_out(&c, "Color", 1, ch), 0.5f, 1e-6f);
}

/* Separate then Combine in HSV and HSL gives the colour back (in gamut). Cycles' HSV
 * does not wrap hues: h = 1.25 lands in the "sextant >= 5" branch, not at h = 0.25. */
static void test_color_round_trip_and_unwrapped_hue(void **state)
{
    (void)state;
    const float rgb[3][3] = {{0.9f, 0.2f, 0.4f}, {0.1f, 0.7f, 0.3f}, {0.25f, 0.25f, 0.8f}};
    for (int mode = 1; mode <= 2; mode++) {
        const char *mode_name = mode == 1 ? "HSV" : "HSL";
        kernel_call s;
        kc_init(&s, "ShaderNodeSeparateColor", 3);
        kc_set_prop(&s, "mode", mode_name);
        for (int i = 0; i < 3; i++)
            kc_set(&s, "Color", i, rgb[i][0], rgb[i][1], rgb[i][2]);
        kc_run(&s);
        kernel_call c;
        kc_init(&c, "ShaderNodeCombineColor", 3);
        kc_set_prop(&c, "mode", mode_name);
        for (int i = 0; i < 3; i++) {
            kc_set(&c, "Red", i, kc_out(&s, "Red", i, 0), 0, 0);
            kc_set(&c, "Green", i, kc_out(&s, "Green", i, 0), 0, 0);
            kc_set(&c, "Blue", i, kc_out(&s, "Blue", i, 0), 0, 0);
        }
        kc_run(&c);
        for (int i = 0; i < 3; i++)
            for (int ch = 0; ch < 3; ch++)
                assert_float_equal(kc_out(&c, "Color", i, ch), rgb[i][ch], 1e-5f);
    }
    kernel_call c;
    kc_init(&c, "ShaderNodeCombineColor", 1);
    kc_set_prop(&c, "mode", "HSV");
    kc_set(&c, "Red", 0, 1.25f, 0, 0);
    kc_set(&c, "Green", 0, 1.0f, 0, 0);
    kc_set(&c, "Blue", 0, 1.0f, 0, 0);
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Color", 0, 0), 1.0f, 1e-6f);
    assert_float_equal(kc_out(&c, "Color", 0, 1), 0.0f, 1e-6f);
    assert_float_equal(kc_out(&c, "Color", 0, 2), 0.5f, 1e-6f);
}

/* ---- Mapping ---------------------------------------------------------------------------- */

/* TEXTURE undoes POINT; NORMAL gives unit vectors; VECTOR ignores Location. */
static void test_mapping_inverse(void **state)
{
    (void)state;
    const float v[3] = {0.3f, -1.2f, 2.5f};
    kernel_call p;
    kc_init(&p, "ShaderNodeMapping", 1);
    kc_set(&p, "Vector", 0, v[0], v[1], v[2]);
    kc_set(&p, "Location", 0, 1.0f, -2.0f, 0.5f);
    kc_set(&p, "Rotation", 0, 0.4f, -1.1f, 2.3f);
    kc_set(&p, "Scale", 0, 2.0f, 0.5f, -3.0f);
    kc_run(&p);
    kernel_call t = p;
    kc_set_prop(&t, "vector_type", "TEXTURE");
    kc_set(&t, "Vector", 0, kc_out(&p, "Vector", 0, 0), kc_out(&p, "Vector", 0, 1),
              kc_out(&p, "Vector", 0, 2));
    kc_run(&t);
    for (int ch = 0; ch < 3; ch++)
        assert_float_equal(kc_out(&t, "Vector", 0, ch), v[ch], 1e-5f);

    kernel_call nrm = p;
    kc_set_prop(&nrm, "vector_type", "NORMAL");
    kc_run(&nrm);
    float len2 = 0.0f;
    for (int ch = 0; ch < 3; ch++)
        len2 += kc_out(&nrm, "Vector", 0, ch) * kc_out(&nrm, "Vector", 0, ch);
    assert_float_equal(len2, 1.0f, 1e-5f);

    kernel_call vec = p;
    kc_set_prop(&vec, "vector_type", "VECTOR");
    kc_run(&vec);
    kc_set(&vec, "Location", 0, 0.0f, 0.0f, 0.0f);
    kernel_call vec0 = vec;
    kc_run(&vec0);
    for (int ch = 0; ch < 3; ch++)
        assert_float_equal(kc_out(&vec, "Vector", 0, ch), kc_out(&vec0, "Vector", 0, ch), 0.0f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ramp_constant_step),
        cmocka_unit_test(test_ramp_linear_identity),
        cmocka_unit_test(test_ramp_hsv_far),
        cmocka_unit_test(test_ramp_negative_colour_is_zero),
        cmocka_unit_test(test_mix_factor_clamping),
        cmocka_unit_test(test_mix_vector_non_uniform),
        cmocka_unit_test(test_invert),
        cmocka_unit_test(test_color_round_trip_and_unwrapped_hue),
        cmocka_unit_test(test_mapping_inverse),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
