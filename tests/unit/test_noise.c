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

#include "kernel_call.h"

#define NPTS 96

static const char *const dims_names[] = {"1D", "2D", "3D", "4D"};

/* The Noise Texture at NPTS scattered points of [-1, 2]^3 (a fixed, irregular pattern),
 * every other input and property at its default. */
static void noise_init(kernel_call *c)
{
    kc_init(c, "ShaderNodeTexNoise", NPTS);
    float *v = kc_in(c, "Vector"), *w = kc_in(c, "W");
    for (int i = 0; i < NPTS; i++) {
        v[i] = -1.0f + 0.0311f * (float)i;
        v[NPTS + i] = 2.0f - 0.0297f * (float)((i * 7) % NPTS);
        v[2 * NPTS + i] = 0.25f + 0.0413f * (float)((i * 13) % 41);
        w[i] = 0.5f - 0.091f * (float)i;
    }
}

static void set_all(kernel_call *c, const char *input, float v) { kc_set_all(c, input, v, v, v); }

/* Fac of the same node in both modes. */
static void run_both(kernel_call *c, float *fac4, float *fac3)
{
    kc_want(c, "Color", false);
    c->blender = SG_BLENDER_4;
    kc_run(c);
    memcpy(fac4, kc_outputs(c, "Fac"), sizeof(float) * NPTS);
    c->blender = SG_BLENDER_3;
    kc_run(c);
    memcpy(fac3, kc_outputs(c, "Fac"), sizeof(float) * NPTS);
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
    kernel_call c;
    float f4[NPTS], f3[NPTS];
    for (int dims = 0; dims < 4; dims++) {
        noise_init(&c);
        kc_set_prop(&c, "noise_dimensions", dims_names[dims]);
        set_all(&c, "Detail", 4.5f);
        set_all(&c, "Roughness", 0.6f);
        set_all(&c, "Distortion", 0.7f);
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
    kernel_call c;
    float f4[NPTS], f3[NPTS];
    noise_init(&c);
    set_all(&c, "Scale", 40.0f);
    set_all(&c, "Detail", 15.0f);
    set_all(&c, "Roughness", 0.8f);
    run_both(&c, f4, f3);
    assert_true(max_abs_diff(f4, f3) > 1e-4f);
}

/* The 3.x mode evaluates the Musgrave Texture compat_noise.py builds: Detail + 1 and
 * Dimension -log(Roughness)/log(Lacunarity). With Lacunarity 2 and Roughness a power of
 * two, Lacunarity^-Dimension is exact, so each type must reproduce 4.x. */
static void test_musgrave_translation_matches_4x(void **state)
{
    (void)state;
    static const char *const types[] = {"MULTIFRACTAL", "RIDGED_MULTIFRACTAL", "HYBRID_MULTIFRACTAL",
                                        "HETERO_TERRAIN", "FBM"};
    static const float details[] = {0.0f, 1.0f, 3.5f, 14.0f};
    kernel_call c;
    float f4[NPTS], f3[NPTS];
    for (size_t t = 0; t < sizeof types / sizeof types[0]; t++)
        for (size_t d = 0; d < sizeof details / sizeof details[0]; d++) {
            noise_init(&c);
            kc_set_prop(&c, "noise_type", types[t]);
            kc_set_prop(&c, "normalize", "false"); /* fBM: the unnormalized one is a Musgrave fBM */
            set_all(&c, "Scale", 1.5f);
            set_all(&c, "Detail", details[d]);
            set_all(&c, "Roughness", 0.5f);
            set_all(&c, "Offset", 0.8f);
            set_all(&c, "Gain", 1.7f);
            run_both(&c, f4, f3);
            /* Not bit-identical: 3.4's SIMD Perlin interpolates as t*b + (1-t)*a, 4.x as
             * a + t*(b-a), a last-bit difference per octave. A wrong Detail offset or
             * Dimension would be off by ~0.1. */
            for (int i = 0; i < NPTS; i++)
                if (fabsf(f4[i] - f3[i]) > 1e-5f * fmaxf(1.0f, fabsf(f4[i])))
                    fail_msg("type %s detail %g point %d: 4.x %.9g, 3.x %.9g", types[t],
                             (double)details[d], i, (double)f4[i], (double)f3[i]);
        }
}

static void test_normalized_fbm_in_unit_range(void **state)
{
    (void)state;
    static const float detail[] = {0.0f, 2.5f, 15.0f};
    static const float rough[] = {0.0f, 0.5f, 1.0f};
    kernel_call c;
    for (int b = 0; b < 2; b++)
        for (int d = 0; d < 3; d++)
            for (int r = 0; r < 3; r++) {
                noise_init(&c);
                c.blender = b ? SG_BLENDER_3 : SG_BLENDER_4;
                set_all(&c, "Detail", detail[d]);
                set_all(&c, "Roughness", rough[r]);
                kc_run(&c);
                for (int i = 0; i < NPTS; i++) {
                    float fac = kc_out(&c, "Fac", i, 0);
                    assert_true(fac >= 0.0f && fac <= 1.0f);
                    assert_true(kc_out(&c, "Color", i, 0) == fac);
                    for (int k = 1; k < 3; k++) {
                        float v = kc_out(&c, "Color", i, k);
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
    kernel_call c;
    float fac_alone[NPTS];
    noise_init(&c);
    kc_set_prop(&c, "noise_type", "HYBRID_MULTIFRACTAL");
    set_all(&c, "Distortion", 1.5f);
    kc_want(&c, "Color", false);
    kc_run(&c);
    memcpy(fac_alone, kc_outputs(&c, "Fac"), sizeof fac_alone);
    memset(c.out, 0, sizeof c.out);
    kc_want(&c, "Color", true);
    kc_want(&c, "Fac", false);
    kc_run(&c);
    for (int i = 0; i < NPTS; i++)
        assert_true(kc_out(&c, "Fac", i, 0) == 0.0f && kc_out(&c, "Color", i, 0) == fac_alone[i]);
}

/* Coordinates beyond int32: 3.4 truncates the cell index to INT32_MIN with a zero
 * fraction, so every gradient is 0 and fBM is exactly 0.5; 4.x wraps them first and
 * still varies. Neither may overflow a conversion (UBSan). */
static void test_huge_coordinates(void **state)
{
    (void)state;
    kernel_call c;
    float f4[NPTS], f3[NPTS];
    noise_init(&c);
    set_all(&c, "Scale", 1e12f);
    set_all(&c, "Detail", 1.0f);
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
    kernel_call c;
    kc_init(&c, "ShaderNodeTexNoise", 1); /* 3D fBM, normalized */
    assert_false(kc_available(&c, "Offset"));
    assert_false(kc_available(&c, "W"));
    assert_true(kc_available(&c, "Vector"));
    kc_set_prop(&c, "noise_type", "HETERO_TERRAIN");
    assert_true(kc_available(&c, "Offset"));
    assert_false(kc_available(&c, "Gain"));
    kc_set_prop(&c, "noise_type", "RIDGED_MULTIFRACTAL");
    assert_true(kc_available(&c, "Gain"));
    kc_set_prop(&c, "noise_dimensions", "1D");
    assert_true(kc_available(&c, "W"));
    assert_false(kc_available(&c, "Vector"));
}

/* White Noise: Color's red channel is Value, everything in [0, 1], each dimension count
 * hashes differently, and an unlinked Vector is not Generated coordinates. */
static void test_white_noise(void **state)
{
    (void)state;
    kernel_call c;
    float value[4][NPTS];
    for (int dims = 0; dims < 4; dims++) {
        kc_init(&c, "ShaderNodeTexWhiteNoise", NPTS);
        assert_int_equal(c.type->inputs[kc_input(&c, "Vector")].implicit, SG_IMPLICIT_NONE);
        kc_set_prop(&c, "noise_dimensions", dims_names[dims]);
        for (int i = 0; i < NPTS; i++) {
            kc_set(&c, "Vector", i, 0.37f * (float)i, -0.21f * (float)i, 1.0f / (float)(i + 1));
            kc_set(&c, "W", i, 3.0f - 0.11f * (float)i, 0, 0);
        }
        kc_run(&c);
        memcpy(value[dims], kc_outputs(&c, "Value"), sizeof value[dims]);
        for (int i = 0; i < NPTS; i++) {
            assert_true(kc_out(&c, "Color", i, 0) == value[dims][i]);
            for (int k = 0; k < 3; k++)
                assert_true(kc_out(&c, "Color", i, k) >= 0.0f && kc_out(&c, "Color", i, k) <= 1.0f);
        }
    }
    for (int d = 0; d < 3; d++)
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
