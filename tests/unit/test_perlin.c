/*
 * Perlin noise's lane form against its scalar form (kernels/perlin.c), directly.
 *
 * The scalar Perlin is the specification (it follows Cycles' noise.h line by line and is
 * what test_blender_nodes proves against Blender); the lane form computes LANES points at
 * once and must give the same bits. perlin_many takes the scalar path for a lone point
 * and the lane path for two or more, so a point alone and the same point among
 * LANES - 1 others compare the two, for every dimension count and both Blender modes.
 * test_noise_batch reaches the scalar form only through leftover octave points; here every
 * point takes both.
 *
 * Points: pseudo-random at several magnitudes, and the coordinates that take the rare
 * branches: -0 and integers (the cell boundary), halves, 4.x's wrap at 100000 and its
 * half-cell shift past 1e6, beyond int32 (3.x's INT32_MIN cell), and the non-finite
 * values (3.x returns 0 for a non-finite result, 4.x wraps the coordinate).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "shadergraph/kernels/noise.h"

#define NPTS 4096

static uint64_t rng_next(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* One coordinate: mostly random at a random magnitude, sometimes a special value. */
static float coordinate(uint64_t *s)
{
    static const float special[] = {0.0f, -0.0f, 1.0f, -1.0f, 0.5f, -0.5f, 3.0f, -7.0f,
                                    99999.5f, 100000.0f, 100000.5f, -100000.0f, 1e6f,
                                    1.5e6f, -2.5e6f, 3e9f, -3e9f, 1e20f, -1e20f, INFINITY,
                                    -INFINITY, NAN};
    uint64_t r = rng_next(s);
    if (r % 8 == 0)
        return special[(r >> 8) % (sizeof special / sizeof special[0])];
    static const float magnitude[] = {1.0f, 10.0f, 1000.0f, 1e5f, 2e6f};
    double u = (double)(rng_next(s) >> 11) * 0x1p-53 * 2.0 - 1.0;
    return (float)(u * magnitude[(r >> 8) % 5]);
}

static int same_bits(float a, float b)
{
    if (isnan(a) || isnan(b))
        return isnan(a) && isnan(b); /* a NaN's payload means nothing */
    uint32_t ua, ub;
    memcpy(&ua, &a, 4);
    memcpy(&ub, &b, 4);
    return ua == ub;
}

/* dims: DIMS_1D .. DIMS_4D */
static void check_mode(int dims, bool blender3)
{
    noise_mode m = noise_mode_for(dims, blender3);
    uint64_t s = 0x5eed0000u + (uint64_t)dims * 2 + blender3;
    npoint pts[NPTS];
    for (int i = 0; i < NPTS; i++)
        pts[i] = (npoint){coordinate(&s), coordinate(&s), coordinate(&s), coordinate(&s)};

    int lane_path_used = 0;
    for (int i = 0; i < NPTS; i += LANES) {
        float lanes[LANES];
        m.perlin_many(pts + i, LANES, lanes);
        for (int k = 0; k < LANES; k++) {
            float one;
            m.perlin_many(pts + i + k, 1, &one);
            if (!same_bits(one, lanes[k]))
                fail_msg("%dD %s: point (%a, %a, %a, %a): scalar %a, lane %d of %d: %a", dims + 1,
                         blender3 ? "3.x" : "4.x", (double)pts[i + k].x, (double)pts[i + k].y,
                         (double)pts[i + k].z, (double)pts[i + k].w, (double)one, k, LANES,
                         (double)lanes[k]);
            lane_path_used += one != 0.0f;
        }
    }
    /* Not a degenerate comparison of zeros: most points have noise. */
    assert_true(lane_path_used > NPTS / 2);

    /* perlin_lanes (whole shading points side by side) is the same function. */
    lane_point q;
    for (int k = 0; k < LANES; k++) {
        q.x[k] = pts[k].x;
        q.y[k] = pts[k].y;
        q.z[k] = pts[k].z;
        q.w[k] = pts[k].w;
    }
    lane_f r;
    m.perlin_lanes(&q, &r);
    for (int k = 0; k < LANES; k++) {
        float one;
        m.perlin_many(pts + k, 1, &one);
        assert_true(same_bits(one, r[k]));
    }
}

static void test_perlin_lanes_equal_scalar_4x(void **state)
{
    (void)state;
    for (int d = DIMS_1D; d <= DIMS_4D; d++)
        check_mode(d, false);
}

static void test_perlin_lanes_equal_scalar_3x(void **state)
{
    (void)state;
    for (int d = DIMS_1D; d <= DIMS_4D; d++)
        check_mode(d, true);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_perlin_lanes_equal_scalar_4x),
        cmocka_unit_test(test_perlin_lanes_equal_scalar_3x),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
