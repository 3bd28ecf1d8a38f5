/*
 * The Noise Texture kernel's batch path (kernels/noise_texture.c evaluates whole groups of
 * points side by side in SIMD lanes) against its one-point path (what a one-point batch
 * runs, as the pointwise evaluator does, and where a lone octave point takes the scalar
 * Perlin of kernels/perlin.c): the same bits for every point, in every dimension
 * count, noise type, Normalize setting and Blender mode, with Fac and Color wanted
 * together or alone.
 *
 * The points are pseudo-random but fixed, and include what takes the rare branches:
 * -0 and integer coordinates, coordinates past 4.x's wrap at 100000 and its half-cell
 * shift at 1e6, past int32 (3.x's INT32_MIN cell), Detail varying from point to point
 * (so lanes run different octave counts) with integer and fractional values and beyond
 * the clamp, Distortion zero on some points and not on others, Lacunarity and Roughness
 * that make Musgrave's octave count and hybrid's early exit differ between lanes. The
 * batch size is not a multiple of the lane count, so the leftover points take the
 * one-point path inside a batch too.
 *
 * Both paths must agree bit for bit (the one-point path is what matches Blender in
 * test_blender_nodes); the only values allowed to differ in their bits are NaNs (from
 * NaN or infinite inputs), whose payload means nothing, and then both must be NaN.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "shadergraph/node_type.h"

#define NPTS 203

enum { IN_VECTOR, IN_W, IN_SCALE, IN_DETAIL, IN_ROUGHNESS, IN_LACUNARITY, IN_OFFSET,
       IN_GAIN, IN_DISTORTION, N_IN };
enum { OUT_FAC, OUT_COLOR, N_OUT };
enum { P_DIMS, P_TYPE, P_NORMALIZE };

/* xorshift32: a fixed sequence, so failures reproduce. */
static uint32_t next_u32(uint32_t *s)
{
    uint32_t x = *s;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    return *s = x;
}

static float uniform(uint32_t *s, float lo, float hi)
{
    return lo + (hi - lo) * ((float)(next_u32(s) >> 8) * (1.0f / 16777216.0f));
}

/* A coordinate: mostly ordinary, sometimes one of the special values. */
static float coordinate(uint32_t *s)
{
    static const float special[] = {-0.0f, 0.0f, 3.0f, -7.0f, 99999.5f, -100000.0f, 100000.25f,
                                    1000000.0f, -2.5e6f, 3.0e9f, -3.0e9f, 1e20f, INFINITY};
    uint32_t r = next_u32(s) % 16u;
    if (r < 2u)
        return special[next_u32(s) % (sizeof special / sizeof special[0])];
    return uniform(s, -20.0f, 20.0f);
}

typedef struct inputs {
    float in[N_IN][3 * NPTS];
} inputs;

/* `varying`: every input differs between points; otherwise Detail, Roughness,
 * Lacunarity, Offset, Gain and Distortion are one value for the batch (the usual case
 * of unlinked sockets), with coordinates still random. */
static void make_inputs(inputs *x, uint32_t seed, bool varying)
{
    uint32_t s = seed;
    memset(x, 0, sizeof *x);
    float detail = uniform(&s, 0.0f, 15.0f), rough = uniform(&s, 0.0f, 1.0f);
    float lac = uniform(&s, 1.5f, 2.5f), offset = uniform(&s, 0.0f, 1.5f);
    float gain = uniform(&s, 0.5f, 2.0f), dist = uniform(&s, 0.0f, 2.0f);
    for (int i = 0; i < NPTS; i++) {
        for (int c = 0; c < 3; c++)
            x->in[IN_VECTOR][c * NPTS + i] = coordinate(&s);
        x->in[IN_W][i] = coordinate(&s);
        x->in[IN_SCALE][i] = uniform(&s, 0.1f, 4.0f);
        if (!varying) {
            x->in[IN_DETAIL][i] = detail;
            x->in[IN_ROUGHNESS][i] = rough;
            x->in[IN_LACUNARITY][i] = lac;
            x->in[IN_OFFSET][i] = offset;
            x->in[IN_GAIN][i] = gain;
            x->in[IN_DISTORTION][i] = dist;
            continue;
        }
        uint32_t r = next_u32(&s) % 4u;
        /* Integer, fractional, out-of-range and tiny fractional Details. */
        x->in[IN_DETAIL][i] = r == 0u   ? (float)(next_u32(&s) % 16u)
                              : r == 1u ? uniform(&s, -2.0f, 18.0f)
                              : r == 2u ? (float)(next_u32(&s) % 15u) + 1e-6f
                                        : uniform(&s, 0.0f, 15.0f);
        x->in[IN_ROUGHNESS][i] = uniform(&s, -0.2f, 1.2f);
        x->in[IN_LACUNARITY][i] = next_u32(&s) % 8u == 0u ? 1.0f : uniform(&s, 0.5f, 3.0f);
        x->in[IN_OFFSET][i] = uniform(&s, -1.0f, 2.0f);
        x->in[IN_GAIN][i] = uniform(&s, 0.0f, 3.0f);
        x->in[IN_DISTORTION][i] = next_u32(&s) % 3u == 0u ? 0.0f : uniform(&s, -2.0f, 2.0f);
    }
}

static void run_kernel(const sg_node_type *t, const int *prop, sg_blender_mode mode,
                       const float *const *in, float *fac, float *color, int n)
{
    float *out[N_OUT] = {fac, color};
    sg_kernel_args a;
    memset(&a, 0, sizeof a);
    a.n = n;
    a.blender = mode;
    a.prop = prop;
    a.in = in;
    a.out = out;
    t->kernel(&a);
}

static bool same_value(float a, float b)
{
    if (isnan(a) || isnan(b))
        return isnan(a) && isnan(b);
    return memcmp(&a, &b, sizeof a) == 0;
}

/* Batch of NPTS against NPTS one-point batches; returns the number of points compared. */
static int compare_paths(const sg_node_type *t, const int *prop, sg_blender_mode mode,
                         const inputs *x, bool want_fac, bool want_color)
{
    static float fac[NPTS], color[3 * NPTS];
    const float *in[N_IN];
    for (int k = 0; k < N_IN; k++)
        in[k] = x->in[k];
    run_kernel(t, prop, mode, in, want_fac ? fac : NULL, want_color ? color : NULL, NPTS);

    for (int i = 0; i < NPTS; i++) {
        float one_in[N_IN][3];
        const float *one_ptr[N_IN];
        for (int k = 0; k < N_IN; k++) {
            int width = k == IN_VECTOR ? 3 : 1;
            for (int c = 0; c < width; c++)
                one_in[k][c] = x->in[k][c * NPTS + i];
            one_ptr[k] = one_in[k];
        }
        float one_fac = 0.0f, one_color[3] = {0.0f, 0.0f, 0.0f};
        run_kernel(t, prop, mode, one_ptr, want_fac ? &one_fac : NULL,
                   want_color ? one_color : NULL, 1);
        bool ok = !want_fac || same_value(fac[i], one_fac);
        for (int c = 0; want_color && c < 3; c++)
            ok = ok && same_value(color[c * NPTS + i], one_color[c]);
        if (!ok) {
            fprintf(stderr,
                    "point %d (dims %d, type %d, normalize %d, Blender %d): batch %a (%a %a "
                    "%a), one point %a (%a %a %a)\n",
                    i, prop[P_DIMS], prop[P_TYPE], prop[P_NORMALIZE], (int)mode,
                    want_fac ? fac[i] : 0.0f, want_color ? color[i] : 0.0f,
                    want_color ? color[NPTS + i] : 0.0f, want_color ? color[2 * NPTS + i] : 0.0f,
                    one_fac, one_color[0], one_color[1], one_color[2]);
            fail_msg("batch and one-point Noise Texture differ");
        }
    }
    return NPTS;
}

static void check_mode(sg_blender_mode mode)
{
    const sg_node_type *t = sg_node_type_find("ShaderNodeTexNoise");
    assert_non_null(t);
    assert_int_equal(t->n_inputs, N_IN);
    static inputs x;
    int compared = 0;
    uint32_t seed = 12345u + (uint32_t)mode;
    for (int dims = 0; dims < 4; dims++)
        for (int type = 0; type < 5; type++)
            for (int normalize = 0; normalize < 2; normalize++)
                for (int varying = 0; varying < 2; varying++) {
                    int prop[3] = {dims, type, normalize};
                    make_inputs(&x, seed++, varying != 0);
                    compared += compare_paths(t, prop, mode, &x, true, true);
                    compared += compare_paths(t, prop, mode, &x, true, false);
                    compared += compare_paths(t, prop, mode, &x, false, true);
                }
    assert_int_equal(compared, 4 * 5 * 2 * 2 * 3 * NPTS);
}

static void test_batch_matches_pointwise_blender4(void **state)
{
    (void)state;
    check_mode(SG_BLENDER_4);
}

static void test_batch_matches_pointwise_blender3(void **state)
{
    (void)state;
    check_mode(SG_BLENDER_3);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_batch_matches_pointwise_blender4),
        cmocka_unit_test(test_batch_matches_pointwise_blender3),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
