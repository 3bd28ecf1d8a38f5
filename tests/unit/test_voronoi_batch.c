/*
 * The Voronoi Texture kernel over a batch against the same points one at a time (a
 * one-point batch, as the pointwise evaluator runs it): the same bits for every output
 * of every point, in every dimension count, metric, feature, Normalize setting and
 * Blender mode. The batch path evaluates groups of points side by side in SIMD lanes
 * where it can (F1 or F2 with one octave); this is what proves it changes nothing.
 *
 * The points are pseudo-random but fixed, and include what takes rare branches: -0 and
 * integer coordinates, large ones, Scale 0, Randomness outside [0, 1], Detail 0 on most
 * points (one octave: the lanes path) but not all (the group falls back to one point at a
 * time), ties (Randomness 0 puts every feature point on a lattice). The batch size is not
 * a multiple of the lane count. NaNs may differ in their bits only (from infinite
 * inputs), and then both must be NaN.
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

enum { IN_VECTOR, IN_W, IN_SCALE, IN_DETAIL, IN_ROUGHNESS, IN_LACUNARITY, IN_SMOOTHNESS,
       IN_EXPONENT, IN_RANDOMNESS, N_IN };
enum { OUT_DISTANCE, OUT_COLOR, OUT_POSITION, OUT_W, OUT_RADIUS, N_OUT };
static const int out_width[N_OUT] = {1, 3, 3, 1, 1};
enum { P_DIMS, P_METRIC, P_FEATURE, P_NORMALIZE };

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

static float coordinate(uint32_t *s)
{
    static const float special[] = {-0.0f, 0.0f, 1.0f, -3.0f, 0.5f, 12345.678f, -2.5e6f,
                                    3.0e9f, INFINITY};
    if (next_u32(s) % 16u < 2u)
        return special[next_u32(s) % (sizeof special / sizeof special[0])];
    return uniform(s, -8.0f, 8.0f);
}

typedef struct inputs {
    float in[N_IN][3 * NPTS];
} inputs;

/* `varying`: Detail, Roughness, Smoothness, Exponent, Randomness differ between points;
 * otherwise they are one value for the batch, Detail 0 (the node's default). */
static void make_inputs(inputs *x, uint32_t seed, bool varying)
{
    uint32_t s = seed;
    memset(x, 0, sizeof *x);
    float rough = uniform(&s, 0.0f, 1.0f), smooth = uniform(&s, 0.0f, 1.0f);
    float exponent = uniform(&s, 0.5f, 4.0f), randomness = uniform(&s, 0.0f, 1.0f);
    if (next_u32(&s) % 4u == 0u)
        randomness = 0.0f; /* a lattice: every distance ties with its mirror image */
    for (int i = 0; i < NPTS; i++) {
        for (int c = 0; c < 3; c++)
            x->in[IN_VECTOR][c * NPTS + i] = coordinate(&s);
        x->in[IN_W][i] = coordinate(&s);
        x->in[IN_SCALE][i] = next_u32(&s) % 32u == 0u ? 0.0f : uniform(&s, 0.1f, 4.0f);
        x->in[IN_LACUNARITY][i] = uniform(&s, 1.5f, 3.0f);
        if (!varying) {
            x->in[IN_DETAIL][i] = 0.0f;
            x->in[IN_ROUGHNESS][i] = rough;
            x->in[IN_SMOOTHNESS][i] = smooth;
            x->in[IN_EXPONENT][i] = exponent;
            x->in[IN_RANDOMNESS][i] = randomness;
            continue;
        }
        /* Mostly one octave, so that most groups take the lanes path. */
        x->in[IN_DETAIL][i] = next_u32(&s) % 64u == 0u ? uniform(&s, 0.0f, 3.0f) : 0.0f;
        x->in[IN_ROUGHNESS][i] = uniform(&s, -0.2f, 1.2f);
        x->in[IN_SMOOTHNESS][i] = uniform(&s, 0.0f, 1.2f);
        x->in[IN_EXPONENT][i] = uniform(&s, 0.3f, 4.0f);
        x->in[IN_RANDOMNESS][i] = uniform(&s, -0.3f, 1.3f);
    }
}

static void run_kernel(const sg_node_type *t, const int *prop, sg_blender_mode mode,
                       const float *const *in, float *const *out, int n)
{
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

/* `wanted`: bit k set = output k is asked for. */
static void compare_paths(const sg_node_type *t, const int *prop, sg_blender_mode mode,
                          const inputs *x, unsigned wanted)
{
    static float batch[N_OUT][3 * NPTS];
    const float *in[N_IN];
    float *out[N_OUT];
    for (int k = 0; k < N_IN; k++)
        in[k] = x->in[k];
    for (int k = 0; k < N_OUT; k++)
        out[k] = (wanted >> k) & 1u ? batch[k] : NULL;
    run_kernel(t, prop, mode, in, out, NPTS);

    for (int i = 0; i < NPTS; i++) {
        float one_in[N_IN][3], one_out[N_OUT][3];
        const float *one_ptr[N_IN];
        float *one_out_ptr[N_OUT];
        for (int k = 0; k < N_IN; k++) {
            for (int c = 0; c < (k == IN_VECTOR ? 3 : 1); c++)
                one_in[k][c] = x->in[k][c * NPTS + i];
            one_ptr[k] = one_in[k];
        }
        for (int k = 0; k < N_OUT; k++)
            one_out_ptr[k] = (wanted >> k) & 1u ? one_out[k] : NULL;
        run_kernel(t, prop, mode, one_ptr, one_out_ptr, 1);
        for (int k = 0; k < N_OUT; k++)
            for (int c = 0; (wanted >> k) & 1u && c < out_width[k]; c++)
                if (!same_value(batch[k][c * NPTS + i], one_out[k][c])) {
                    fprintf(stderr,
                            "point %d output %d[%d] (dims %d, metric %d, feature %d, "
                            "normalize %d, Blender %d): batch %a, one point %a\n",
                            i, k, c, prop[P_DIMS], prop[P_METRIC], prop[P_FEATURE],
                            prop[P_NORMALIZE], (int)mode, batch[k][c * NPTS + i],
                            one_out[k][c]);
                    fail_msg("batch and one-point Voronoi Texture differ");
                }
    }
}

static void check_mode(sg_blender_mode mode)
{
    const sg_node_type *t = sg_node_type_find("ShaderNodeTexVoronoi");
    assert_non_null(t);
    assert_int_equal(t->n_inputs, N_IN);
    assert_int_equal(t->n_outputs, N_OUT);
    static inputs x;
    uint32_t seed = 777u + (uint32_t)mode;
    int cases = 0;
    for (int dims = 0; dims < 4; dims++)
        for (int metric = 0; metric < 4; metric++)
            for (int feature = 0; feature < 5; feature++)
                for (int normalize = 0; normalize < 2; normalize++)
                    for (int varying = 0; varying < 2; varying++) {
                        int prop[4] = {dims, metric, feature, normalize};
                        make_inputs(&x, seed++, varying != 0);
                        compare_paths(t, prop, mode, &x, 0x1fu);
                        compare_paths(t, prop, mode, &x, 1u << OUT_DISTANCE);
                        compare_paths(t, prop, mode, &x, (1u << OUT_COLOR) | (1u << OUT_W));
                        cases += 3;
                    }
    assert_int_equal(cases, 4 * 4 * 5 * 2 * 2 * 3);
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
