/*
 * image_compare on synthetic images whose answers follow from the definitions in
 * imageio.h: a constant offset, two noisy halves of a known image, one block off (and
 * errors in partial blocks ignored), black channels and blocks, extra channels ignored,
 * and the errors: mismatched sizes, too few channels, NaN and infinity named by image,
 * pixel and channel.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include <math.h>

#include "imageio/imageio.h"

/* A smooth, everywhere-positive test pattern, different in each channel. */
static float pattern(int x, int y, int c)
{
    return 0.2f + 0.1f * (float)c + 0.003f * (float)x + 0.002f * (float)y;
}

static void fill_pattern(image *im)
{
    for (int y = 0; y < im->height; y++)
        for (int x = 0; x < im->width; x++)
            for (int c = 0; c < im->channels; c++)
                im->pixels[((size_t)y * im->width + x) * im->channels + c] = pattern(x, y, c);
}

static float *px(image *im, int x, int y, int c)
{
    return &im->pixels[((size_t)y * im->width + x) * im->channels + c];
}

static void new_image(image *im, int w, int h, int channels)
{
    assert_int_equal(image_alloc(im, w, h, channels), 0);
    fill_pattern(im);
}

/* SplitMix64: a reproducible noise source, so the statistical checks cannot flake. */
static uint64_t next_random(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static void assert_close(double got, double want, double tol)
{
    if (!(fabs(got - want) <= tol))
        fail_msg("got %.12g, expected %.12g (tolerance %g)", got, want, tol);
}

static void test_constant_offset(void **state)
{
    (void)state;
    image ref, img;
    new_image(&ref, 40, 36, 3);
    new_image(&img, 40, 36, 3);
    const float offset = 0.0625f; /* exact in float, so img - ref is exact too */
    double mean[3] = {0};
    for (int y = 0; y < 36; y++)
        for (int x = 0; x < 40; x++)
            for (int c = 0; c < 3; c++) {
                *px(&img, x, y, c) += offset;
                mean[c] += *px(&ref, x, y, c) / (40.0 * 36.0);
            }
    image_comparison m;
    char err[256];
    assert_int_equal(image_compare(&img, &ref, NULL, &m, err, sizeof err), 0);
    /* Float rounding of pattern + offset: a few ulps of 0.5 at most. */
    assert_close(m.rmse, offset, 1e-7);
    assert_close(m.mae, offset, 1e-7);
    assert_close(m.ref_mean, (mean[0] + mean[1] + mean[2]) / 3, 1e-9);
    for (int c = 0; c < 3; c++)
        assert_close(m.bias[c], offset / mean[c], 1e-6);
    /* Every block is off by the offset relative to its own mean: the worst is the one
     * with the darkest reference, the top-left (the pattern grows with x and y). */
    assert_int_equal(m.worst_block_x, 0);
    assert_int_equal(m.worst_block_y, 0);
    double block_mean = 0;
    for (int y = 0; y < 16; y++)
        for (int x = 0; x < 16; x++)
            for (int c = 0; c < 3; c++)
                block_mean += *px(&ref, x, y, c) / 768.0;
    assert_close(m.worst_block, offset / block_mean, 1e-6);
    assert_int_equal(m.has_b, 0);
    assert_true(m.ref_noise_rmse < 0 && m.rmse_converged < 0);

    /* Against itself: every metric is exactly 0. */
    assert_int_equal(image_compare(&ref, &ref, &ref, &m, err, sizeof err), 0);
    assert_true(m.rmse == 0 && m.mae == 0 && m.worst_block == 0 && m.ref_noise_rmse == 0 &&
                m.rmse_converged == 0);
    for (int c = 0; c < 3; c++)
        assert_true(m.bias[c] == 0);
    image_free(&ref);
    image_free(&img);
}

static void test_noisy_halves(void **state)
{
    (void)state;
    const int w = 128, h = 128;
    const double noise = 0.1, offset = 0.05;
    image truth, a, b, img;
    new_image(&truth, w, h, 3);
    new_image(&a, w, h, 3);
    new_image(&b, w, h, 3);
    new_image(&img, w, h, 3);
    /* a and b: truth plus independent +-noise; img: truth plus a constant offset. */
    uint64_t rng = 42;
    double sum_sq = 0, sum_half_sq = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) {
                *px(&a, x, y, c) += (next_random(&rng) >> 63) ? (float)noise : (float)-noise;
                *px(&b, x, y, c) += (next_random(&rng) >> 63) ? (float)noise : (float)-noise;
                *px(&img, x, y, c) += (float)offset;
                double va = *px(&a, x, y, c), vb = *px(&b, x, y, c), v = *px(&img, x, y, c);
                double d = v - 0.5 * (va + vb), half = 0.5 * (va - vb);
                sum_sq += d * d;
                sum_half_sq += half * half;
            }
    double terms = 3.0 * w * h;
    image_comparison m;
    char err[256];
    assert_int_equal(image_compare(&img, &a, &b, &m, err, sizeof err), 0);
    assert_int_equal(m.has_b, 1);
    /* The definitions, evaluated here. */
    assert_close(m.rmse, sqrt(sum_sq / terms), 1e-9);
    assert_close(m.ref_noise_rmse, sqrt(sum_half_sq / terms), 1e-9);
    assert_close(m.rmse_converged, sqrt(fmax(sum_sq / terms - sum_half_sq / terms, 0)), 1e-9);
    /* And what they are for: the noise of the mean of two halves with noise s is
     * s / sqrt(2); with it taken out, the RMSE is the offset from the truth. */
    assert_close(m.ref_noise_rmse, noise / sqrt(2.0), 0.02 * noise);
    assert_true(m.rmse > 1.5 * offset);
    assert_close(m.rmse_converged, offset, 0.003);

    /* img equal to the truth: the converged estimate is near 0 though the RMSE is not. */
    image_comparison t;
    assert_int_equal(image_compare(&truth, &a, &b, &t, err, sizeof err), 0);
    assert_true(t.rmse > 0.6 * noise);
    assert_true(t.rmse_converged < 0.2 * noise);
    image_free(&truth);
    image_free(&a);
    image_free(&b);
    image_free(&img);
}

static void test_one_block_off(void **state)
{
    (void)state;
    /* 70 x 50: 4 x 3 whole blocks, plus a partial column (x 64-69) and row (y 48-49). */
    image ref, img;
    new_image(&ref, 70, 50, 3);
    new_image(&img, 70, 50, 3);
    const int bx = 2, by = 1;
    double block_ref = 0, block_img = 0;
    for (int y = 16 * by; y < 16 * by + 16; y++)
        for (int x = 16 * bx; x < 16 * bx + 16; x++)
            for (int c = 0; c < 3; c++) {
                *px(&img, x, y, c) *= 1.1f;
                block_ref += *px(&ref, x, y, c);
                block_img += *px(&img, x, y, c);
            }
    /* Far larger errors in the partial blocks, which the measure ignores. */
    for (int y = 0; y < 50; y++)
        for (int c = 0; c < 3; c++)
            *px(&img, 66, y, c) *= 3.0f;
    for (int x = 0; x < 70; x++)
        for (int c = 0; c < 3; c++)
            *px(&img, x, 49, c) *= 3.0f;
    image_comparison m;
    char err[256];
    assert_int_equal(image_compare(&img, &ref, NULL, &m, err, sizeof err), 0);
    assert_int_equal(m.worst_block_x, bx);
    assert_int_equal(m.worst_block_y, by);
    assert_close(m.worst_block, fabs(block_img - block_ref) / block_ref, 1e-9);
    assert_close(m.worst_block, 0.1, 1e-6);
    image_free(&ref);
    image_free(&img);

    /* Smaller than one block: no block, reported as position -1. */
    new_image(&ref, 15, 40, 3);
    assert_int_equal(image_compare(&ref, &ref, NULL, &m, err, sizeof err), 0);
    assert_int_equal(m.worst_block_x, -1);
    assert_int_equal(m.worst_block_y, -1);
    image_free(&ref);
}

static void test_black_reference(void **state)
{
    (void)state;
    /* Reference black in G everywhere and black in all channels in block (1, 0); the
     * image equals it but for 0.01 in every channel of that block. */
    image ref, img;
    new_image(&ref, 32, 16, 3);
    new_image(&img, 32, 16, 3);
    double mean = 0;
    for (int y = 0; y < 16; y++)
        for (int x = 0; x < 32; x++)
            for (int c = 0; c < 3; c++) {
                if (c == 1 || x >= 16)
                    *px(&ref, x, y, c) = 0;
                *px(&img, x, y, c) = x >= 16 ? 0.01f : *px(&ref, x, y, c);
                mean += *px(&ref, x, y, c) / (3.0 * 32 * 16);
            }
    image_comparison m;
    char err[256];
    assert_int_equal(image_compare(&img, &ref, NULL, &m, err, sizeof err), 0);
    assert_true(m.bias[1] == 0);
    assert_true(m.bias[0] > 0 && m.bias[2] > 0);
    /* The black block is measured against the overall reference mean. */
    assert_int_equal(m.worst_block_x, 1);
    assert_close(m.worst_block, 0.01 / mean, 1e-6);
    for (int c = 0; c < 3; c++)
        assert_false(isnan(m.bias[c]));
    image_free(&ref);
    image_free(&img);
}

static void test_extra_channels_ignored(void **state)
{
    (void)state;
    image rgba, rgb;
    new_image(&rgba, 20, 20, 4);
    new_image(&rgb, 20, 20, 3);
    for (int y = 0; y < 20; y++)
        for (int x = 0; x < 20; x++)
            *px(&rgba, x, y, 3) = NAN; /* alpha is not compared, so not checked */
    image_comparison m;
    char err[256];
    assert_int_equal(image_compare(&rgba, &rgb, NULL, &m, err, sizeof err), 0);
    assert_true(m.rmse == 0 && m.mae == 0);
    image_free(&rgba);
    image_free(&rgb);
}

static void expect_error(const image *img, const image *a, const image *b, const char *part1,
                         const char *part2)
{
    image_comparison m;
    char err[256] = "";
    m.rmse = 123;
    assert_int_equal(image_compare(img, a, b, &m, err, sizeof err), -1);
    if (!strstr(err, part1) || !strstr(err, part2))
        fail_msg("error \"%s\" lacks \"%s\" or \"%s\"", err, part1, part2);
    assert_true(m.rmse == 0);
}

static void test_errors(void **state)
{
    (void)state;
    image img, small, grey, a, b;
    new_image(&img, 64, 48, 3);
    new_image(&small, 32, 48, 4);
    new_image(&grey, 64, 48, 1);
    new_image(&a, 64, 48, 3);
    new_image(&b, 64, 48, 3);
    expect_error(&img, &small, NULL, "64 x 48 with 3 channels", "32 x 48 with 4 channels");
    expect_error(&img, &a, &small, "reference B", "32 x 48");
    expect_error(&img, &grey, NULL, "reference has 1 channel", "RGB");

    *px(&b, 5, 3, 1) = NAN;
    *px(&b, 9, 7, 0) = NAN; /* later in scan order: not the one named */
    expect_error(&img, &a, &b, "reference B has NaN", "pixel (5, 3) channel 1");
    *px(&img, 63, 47, 2) = -INFINITY;
    expect_error(&img, &a, &b, "image has -inf", "pixel (63, 47) channel 2");
    expect_error(&a, &img, NULL, "reference has -inf", "(63, 47)");
    image_free(&img);
    image_free(&small);
    image_free(&grey);
    image_free(&a);
    image_free(&b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_constant_offset),
        cmocka_unit_test(test_noisy_halves),
        cmocka_unit_test(test_one_block_off),
        cmocka_unit_test(test_black_reference),
        cmocka_unit_test(test_extra_channels_ignored),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
