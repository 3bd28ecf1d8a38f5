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

#include "kernel_call.h"

#define NPTS 64

/* The Voronoi Texture at NPTS scattered points (a fixed, irregular pattern), every other
 * input and property at its default. */
static void voronoi_init(kernel_call *c)
{
    kc_init(c, "ShaderNodeTexVoronoi", NPTS);
    float *v = kc_in(c, "Vector"), *w = kc_in(c, "W");
    for (int i = 0; i < NPTS; i++) {
        v[i] = -1.3f + 0.173f * (float)i;
        v[NPTS + i] = 0.9f - 0.061f * (float)((i * 7) % 31);
        v[2 * NPTS + i] = 0.25f + 0.037f * (float)((i * 13) % 17);
        w[i] = 0.5f - 0.091f * (float)i;
    }
}

static void set_all(kernel_call *c, const char *input, float v) { kc_set_all(c, input, v, v, v); }

static void test_f1_not_above_f2(void **state)
{
    (void)state;
    for (int mode = 0; mode < 2; mode++)
        for (int dims = 0; dims < 4; dims++)
            for (int metric = 0; metric < 4; metric++) {
                kernel_call f1, f2;
                voronoi_init(&f1);
                f1.blender = mode ? SG_BLENDER_3 : SG_BLENDER_4;
                kc_set_prop_index(&f1, "voronoi_dimensions", dims);
                kc_set_prop_index(&f1, "distance", metric);
                set_all(&f1, "Exponent", 1.7f);
                f2 = f1;
                kc_set_prop(&f2, "feature", "F2");
                kc_run(&f1);
                kc_run(&f2);
                for (int i = 0; i < NPTS; i++)
                    assert_true(kc_out(&f1, "Distance", i, 0) <= kc_out(&f2, "Distance", i, 0));
            }
}

/* Randomness 0 puts every point on a lattice corner: at a lattice point the F1 distance
 * is 0 and the position is the point itself. */
static void test_lattice_at_randomness_0(void **state)
{
    (void)state;
    kernel_call c;
    voronoi_init(&c);
    set_all(&c, "Randomness", 0.0f);
    set_all(&c, "Scale", 2.0f);
    float *v = kc_in(&c, "Vector");
    for (int i = 0; i < NPTS; i++)
        for (int d = 0; d < 3; d++)
            v[d * NPTS + i] = 0.5f * (float)((i * (d + 3)) % 11 - 5);
    kc_run(&c);
    for (int i = 0; i < NPTS; i++) {
        assert_float_equal(kc_out(&c, "Distance", i, 0), 0.0f, 0.0f);
        for (int d = 0; d < 3; d++)
            assert_float_equal(kc_out(&c, "Position", i, d), v[d * NPTS + i], 0.0f);
    }
}

/* Normalize divides one octave's F1 by the largest F1 distance in a cell: the distance
 * from a cell's centre to its corner in the metric, sqrt(3) / 2 * (1 + randomness) for
 * Euclidean; F2's by twice that. */
static void test_normalize_divisor(void **state)
{
    (void)state;
    for (int feature = 0; feature < 2; feature++) {
        kernel_call plain, norm;
        voronoi_init(&plain);
        kc_set_prop_index(&plain, "feature", feature);
        set_all(&plain, "Randomness", 0.6f);
        norm = plain;
        kc_set_prop(&norm, "normalize", "true");
        kc_run(&plain);
        kc_run(&norm);
        const float max_distance = sqrtf(3.0f) * 0.8f * (feature ? 2.0f : 1.0f);
        for (int i = 0; i < NPTS; i++)
            assert_float_equal(kc_out(&norm, "Distance", i, 0) * max_distance,
                               kc_out(&plain, "Distance", i, 0), 1e-6);
    }
}

/* 3.4 has no Detail / Roughness / Lacunarity / Normalize: setting them changes nothing
 * in 3.x mode, and changes the 4.x result. */
static void test_3x_ignores_octaves(void **state)
{
    (void)state;
    for (int feature = 0; feature < 4; feature++) {
        kernel_call base, oct, oct4;
        voronoi_init(&base);
        base.blender = SG_BLENDER_3;
        kc_set_prop_index(&base, "feature", feature);
        oct = base;
        set_all(&oct, "Detail", 3.5f);
        set_all(&oct, "Roughness", 0.8f);
        set_all(&oct, "Lacunarity", 2.5f);
        kc_set_prop(&oct, "normalize", "true");
        oct4 = oct;
        oct4.blender = SG_BLENDER_4;
        kc_run(&base);
        kc_run(&oct);
        kc_run(&oct4);
        assert_memory_equal(base.out, oct.out, sizeof base.out);
        assert_memory_not_equal(kc_outputs(&base, "Distance"), kc_outputs(&oct4, "Distance"),
                                NPTS * sizeof(float));
    }
}

/* A Minkowski exponent of 0.05 makes distances of thousands. 3.x's search starts at 8
 * and finds nothing, 4.x's starts at FLT_MAX. */
static void test_search_start(void **state)
{
    (void)state;
    kernel_call c3, c4;
    voronoi_init(&c3);
    kc_set_prop(&c3, "distance", "MINKOWSKI");
    set_all(&c3, "Exponent", 0.05f);
    c3.blender = SG_BLENDER_3;
    c4 = c3;
    c4.blender = SG_BLENDER_4;
    kc_run(&c3);
    kc_run(&c4);
    for (int i = 0; i < NPTS; i++) {
        assert_float_equal(kc_out(&c3, "Distance", i, 0), 8.0f, 0.0f);
        assert_true(kc_out(&c4, "Distance", i, 0) > 8.0f);
    }
}

/* Smoothness 0: 4.x evaluates plain F1, bit for bit. */
static void test_smoothness_0_is_f1(void **state)
{
    (void)state;
    kernel_call f1, smooth;
    voronoi_init(&f1);
    smooth = f1;
    kc_set_prop(&smooth, "feature", "SMOOTH_F1");
    set_all(&smooth, "Smoothness", 0.0f);
    kc_run(&f1);
    kc_run(&smooth);
    assert_memory_equal(f1.out, smooth.out, sizeof f1.out);
}

/* Unused outputs are NULL: only the requested one is written. */
static void test_null_outputs(void **state)
{
    (void)state;
    kernel_call c;
    voronoi_init(&c);
    kc_set_prop(&c, "feature", "N_SPHERE_RADIUS");
    for (int k = 0; k < c.type->n_outputs; k++)
        c.unwanted[k] = true;
    kc_want(&c, "Radius", true);
    kc_run(&c);
    for (int i = 0; i < NPTS; i++)
        assert_true(kc_out(&c, "Radius", i, 0) > 0.0f && kc_out(&c, "Radius", i, 0) < 1.0f);
}

/* Input or output `socket` shown for these dimensions, metric and feature (indices)? */
static bool available(const char *socket, bool output, int dims, int metric, int feature)
{
    kernel_call c;
    kc_init(&c, "ShaderNodeTexVoronoi", 1);
    kc_set_prop_index(&c, "voronoi_dimensions", dims);
    kc_set_prop_index(&c, "distance", metric);
    kc_set_prop_index(&c, "feature", feature);
    return output ? kc_output_available(&c, socket) : kc_available(&c, socket);
}

/* Socket availability as Blender 4.3 shows it (bpy: socket.enabled). Dimensions 0-3 are
 * 1D-4D, metric 3 Minkowski; features F1, F2, SMOOTH_F1, DISTANCE_TO_EDGE,
 * N_SPHERE_RADIUS. */
static void test_availability(void **state)
{
    (void)state;
    assert_false(available("Vector", false, 0, 0, 0));
    assert_true(available("W", false, 0, 0, 0));
    assert_false(available("W", false, 2, 0, 0));
    assert_true(available("W", false, 3, 0, 0));
    assert_true(available("Exponent", false, 2, 3, 2));
    assert_false(available("Exponent", false, 2, 0, 0));
    assert_false(available("Exponent", false, 2, 3, 3));
    assert_false(available("Detail", false, 2, 0, 4));
    assert_true(available("Detail", false, 2, 0, 3));
    assert_true(available("Smoothness", false, 0, 0, 2));
    assert_false(available("Position", true, 0, 0, 0));
    assert_true(available("W", true, 0, 0, 1));
    assert_false(available("W", true, 2, 0, 1));
    assert_false(available("Color", true, 2, 0, 3));
    assert_true(available("Radius", true, 2, 0, 4));
    assert_false(available("Distance", true, 2, 0, 4));
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
