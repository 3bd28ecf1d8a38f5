/*
 * texstats_forward on images whose statistics are known in closed form: a flat colour,
 * two colours in tone groups, stripes along either axis, stripes of two periods, and the
 * refusal of images too small for the pyramid.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "nn/nn.h"

enum { S = 224 };

/* Layout offsets (nn/texstats.c's table). */
enum { PCT = 0, TONE = 15, CHROMA = 24, HIGHLIGHT = 26, BANDS = 27, VAR = 33, ORIENT = 34 };

static float *flat(float r, float g, float b)
{
    float *im = malloc(sizeof(float) * 3 * S * S);
    for (int p = 0; p < S * S; p++) {
        im[3 * p] = r;
        im[3 * p + 1] = g;
        im[3 * p + 2] = b;
    }
    return im;
}

/* Grey stripes: value 0.2 or 0.8 by (x / half_period) % 2 (or y's, when along_y). */
static float *stripes(int half_period, int along_y)
{
    float *im = flat(0, 0, 0);
    for (int y = 0; y < S; y++)
        for (int x = 0; x < S; x++) {
            float v = (((along_y ? y : x) / half_period) % 2) ? 0.8f : 0.2f;
            for (int c = 0; c < 3; c++)
                im[3 * (y * S + x) + c] = v;
        }
    return im;
}

static void test_flat_colour(void **state)
{
    (void)state;
    float *im = flat(0.6f, 0.4f, 0.2f), out[TEXSTATS_N];
    assert_int_equal(texstats_forward(out, im, S, S), 0);
    const float rgb[3] = {0.6f, 0.4f, 0.2f};
    for (int c = 0; c < 3; c++)
        for (int i = 0; i < 5; i++) /* every percentile inside the value's histogram bin */
            assert_true(fabsf(out[PCT + 5 * c + i] - rgb[c]) <= 1.0f / 4096);
    // one tone: every pixel falls in one group, and the empty ones take the image's means,
    // so all three say the same
    float luma = 0.2126f * 0.6f + 0.7152f * 0.4f + 0.0722f * 0.2f;
    for (int g = 0; g < 3; g++) {
        assert_true(fabsf(out[TONE + 3 * g] - luma) < 1e-5);
        assert_true(fabsf(out[TONE + 3 * g + 1] - 0.2f) < 1e-5);          /* red - green */
        assert_true(fabsf(out[TONE + 3 * g + 2] - (0.5f - 0.2f)) < 1e-5); /* yellow - blue */
    }
    assert_true(fabsf(out[CHROMA] - sqrtf(0.04f + 0.09f)) < 1e-5);
    for (int l = 0; l < 6; l++) /* no detail at any scale: the energy floor */
        assert_true(out[BANDS + l] < -15);
    for (int l = 0; l < 4; l++)
        assert_true(fabsf(out[ORIENT + l]) < 1e-6);
    free(im);
}

static void test_tone_groups_keep_their_colours(void **state)
{
    (void)state;
    // the top quarter dark red, the rest pale blue: the darkest group is the red, the
    // brightest the blue
    float *im = flat(0.7f, 0.75f, 0.9f), out[TEXSTATS_N];
    for (int p = 0; p < S * S / 4; p++) {
        im[3 * p] = 0.3f;
        im[3 * p + 1] = 0.05f;
        im[3 * p + 2] = 0.05f;
    }
    assert_int_equal(texstats_forward(out, im, S, S), 0);
    assert_true(out[TONE + 1] > 0.2f);      /* dark group: red over green */
    assert_true(out[TONE + 6 + 2] < -0.1f); /* bright group: blue over yellow */
    assert_true(out[TONE + 0] < out[TONE + 6]);
    free(im);
}

static void test_orientation(void **state)
{
    (void)state;
    float a[TEXSTATS_N], b[TEXSTATS_N];
    float *cols = stripes(4, 0), *rows = stripes(4, 1);
    assert_int_equal(texstats_forward(a, cols, S, S), 0);
    assert_int_equal(texstats_forward(b, rows, S, S), 0);
    // stripes that change along x (vertical boards) have horizontal differences only
    assert_true(a[ORIENT] > 5);
    assert_true(b[ORIENT] < -5);
    // and a transposed image has the same statistics otherwise
    for (int i = 0; i < ORIENT; i++)
        assert_true(fabsf(a[i] - b[i]) < 1e-5);
    free(cols);
    free(rows);
}

static int argmax_band(const float *out)
{
    int best = 0;
    for (int l = 1; l < 5; l++)
        if (out[BANDS + l] > out[BANDS + best])
            best = l;
    return best;
}

static void test_scale_moves_the_energy(void **state)
{
    (void)state;
    float fine[TEXSTATS_N], coarse[TEXSTATS_N];
    float *a = stripes(1, 0), *b = stripes(8, 0);
    assert_int_equal(texstats_forward(fine, a, S, S), 0);
    assert_int_equal(texstats_forward(coarse, b, S, S), 0);
    // 1-pixel stripes live in the finest band; 8-pixel ones three octaves coarser
    assert_int_equal(argmax_band(fine), 0);
    assert_int_equal(argmax_band(coarse), 3);
    // the same two values in both: same percentiles and variance
    for (int i = 0; i < 15; i++)
        assert_true(fabsf(fine[i] - coarse[i]) < 1.0f / 4096);
    assert_true(fabsf(fine[VAR] - coarse[VAR]) < 1e-4);
    free(a);
    free(b);
}

static void test_too_small_and_deterministic(void **state)
{
    (void)state;
    float out[TEXSTATS_N], again[TEXSTATS_N];
    float *im = stripes(3, 1);
    assert_int_equal(texstats_forward(out, im, 63, 63), -1);
    assert_int_equal(texstats_forward(out, im, 64, 64), 0);
    assert_int_equal(texstats_forward(out, im, S, S), 0);
    assert_int_equal(texstats_forward(again, im, S, S), 0);
    assert_memory_equal(out, again, sizeof out);
    free(im);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_flat_colour),
        cmocka_unit_test(test_tone_groups_keep_their_colours),
        cmocka_unit_test(test_orientation),
        cmocka_unit_test(test_scale_moves_the_energy),
        cmocka_unit_test(test_too_small_and_deterministic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
