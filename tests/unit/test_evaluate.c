/*
 * The evaluation's arithmetic (pipeline.h, "evaluation"): the Gram distance (0 for equal,
 * symmetric, scale-free per layer, a small case worked by hand), the colour term, the floor's
 * epsilon, quantiles against numpy's linear rule, R^2 (1 for the truth, 0 for the reference
 * mean, below 0 for any other constant), the spread, a share's 95% interval against scipy's;
 * the contact sheet's font; a stored view's settings and scene (the scene candidates are
 * rendered in).
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "pipeline/pipeline_internal.h"

static void test_gram_distance(void **state)
{
    (void)state;
    /* Two layers: [0, 2) and [2, 5). */
    const size_t off[3] = {0, 2, 5};
    const float a[5] = {3, 4, 1, 2, 2};
    const float b[5] = {3, 4, 1, 2, 2};
    assert_true(evaluate_gram_distance(a, b, off, 2) == 0.0);

    /* Worked by hand. Layer 0: a = (3, 4), c = (0, 4): ||a - c|| = 3, ||a|| = 5, ||c|| = 4:
     * 3/9. Layer 1: a = (1, 2, 2), c = (-1, -2, -2): ||a - c|| = 6, norms 3 and 3: 6/6 = 1
     * (opposite vectors: the largest a layer can give). Mean: (1/3 + 1) / 2 = 2/3. */
    const float c[5] = {0, 4, -1, -2, -2};
    assert_true(fabs(evaluate_gram_distance(a, c, off, 2) - 2.0 / 3.0) < 1e-12);
    assert_true(evaluate_gram_distance(a, c, off, 2) == evaluate_gram_distance(c, a, off, 2));

    /* Scale-free per layer: scaling one layer of both by 1000 and the other by 1e-3 changes
     * nothing (to rounding), while an unnormalised distance would be dominated by layer 1. */
    float as[5], cs[5];
    for (int i = 0; i < 5; i++) {
        float s = i < 2 ? 1e-3f : 1e3f;
        as[i] = a[i] * s;
        cs[i] = c[i] * s;
    }
    assert_true(fabs(evaluate_gram_distance(as, cs, off, 2) - 2.0 / 3.0) < 1e-6);

    /* Zero against zero is 0, zero against anything is 1 per layer. */
    const float z[5] = {0};
    assert_true(evaluate_gram_distance(z, z, off, 2) == 0.0);
    assert_true(fabs(evaluate_gram_distance(z, a, off, 2) - 1.0) < 1e-12);
    assert_true(isnan(evaluate_gram_distance(a, b, off, 0)));
}

static void fill(image *img, float r, float g, float b)
{
    for (int i = 0; i < img->width * img->height; i++) {
        img->pixels[i * img->channels + 0] = r;
        img->pixels[i * img->channels + 1] = g;
        img->pixels[i * img->channels + 2] = b;
    }
}

static void test_colour_distance(void **state)
{
    (void)state;
    image a, b, grey, small;
    char err[256];
    double d = -1;
    assert_int_equal(image_alloc(&a, 256, 240, 3), 0);
    assert_int_equal(image_alloc(&b, 224, 224, 4), 0);
    assert_int_equal(image_alloc(&grey, 230, 230, 1), 0);
    assert_int_equal(image_alloc(&small, 200, 256, 3), 0);
    fill(&a, 0.2f, 0.4f, 0.6f);
    for (int i = 0; i < 224 * 224; i++) {
        b.pixels[i * 4 + 0] = 0.2f;
        b.pixels[i * 4 + 1] = 0.4f;
        b.pixels[i * 4 + 2] = 0.6f;
        b.pixels[i * 4 + 3] = 0.0f; /* alpha is not a colour */
    }
    assert_int_equal(evaluate_colour_distance(&a, &b, &d, err, sizeof err), 0);
    assert_true(fabs(d) < 1e-7);

    /* Outside the centre crop nothing counts: paint a's border (16 columns each side, 8
     * rows top and bottom) and the distance stays 0. */
    for (int y = 0; y < 240; y++)
        for (int x = 0; x < 256; x++)
            if (x < 16 || x >= 240 || y < 8 || y >= 232)
                a.pixels[(y * 256 + x) * 3] = 5.0f;
    assert_int_equal(evaluate_colour_distance(&a, &b, &d, err, sizeof err), 0);
    assert_true(fabs(d) < 1e-7);

    /* Values are clamped to [0, 1]: 7 against 1 is the same as 1 against 1. Then a known
     * difference: b's red + 0.3 everywhere in the crop is 0.3 / 3 = 0.1 over R, G and B. */
    fill(&a, 7.0f, 0.4f, 0.6f);
    for (int i = 0; i < 224 * 224; i++)
        b.pixels[i * 4 + 0] = 1.0f;
    assert_int_equal(evaluate_colour_distance(&a, &b, &d, err, sizeof err), 0);
    assert_true(fabs(d) < 1e-7);
    for (int i = 0; i < 224 * 224; i++)
        b.pixels[i * 4 + 0] = 0.7f;
    assert_int_equal(evaluate_colour_distance(&a, &b, &d, err, sizeof err), 0);
    assert_true(fabs(d - 0.1) < 1e-6);

    /* Pooling: a checkerboard of 1-pixel squares pools to 0.5 in every 7 x 7 box except
     * for the odd pixel (25 of 49 against 24): |25/49 - 0.5| = 1/98 per box and channel. */
    image cb;
    assert_int_equal(image_alloc(&cb, 224, 224, 3), 0);
    for (int y = 0; y < 224; y++)
        for (int x = 0; x < 224; x++)
            for (int c = 0; c < 3; c++)
                cb.pixels[(y * 224 + x) * 3 + c] = (float)((x + y + 1) % 2 == 0);
    fill(&a, 0.5f, 0.5f, 0.5f);
    assert_int_equal(evaluate_colour_distance(&cb, &a, &d, err, sizeof err), 0);
    /* A box holds 25 pixels of its corner's parity and 24 of the other: 25 or 24 ones of
     * 49, 1/98 from 0.5 either way. */
    assert_true(fabs(d - 1.0 / 98.0) < 1e-7);
    image_free(&cb);

    /* Grey counts as R = G = B. */
    for (int i = 0; i < 230 * 230; i++)
        grey.pixels[i] = 0.5f;
    assert_int_equal(evaluate_colour_distance(&grey, &a, &d, err, sizeof err), 0);
    assert_true(fabs(d) < 1e-7);

    /* Too small: a clear error. */
    assert_int_equal(evaluate_colour_distance(&a, &small, &d, err, sizeof err), -1);
    assert_non_null(strstr(err, "image 2 is 200 x 256"));
    image_free(&a);
    image_free(&b);
    image_free(&grey);
    image_free(&small);
}

/* Vertical bars of 1 and 0, each two boxes (14 pixels) wide, moved right by `phase` boxes. */
static void fill_bars(image *img, int phase)
{
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++)
            for (int c = 0; c < 3; c++)
                img->pixels[(y * img->width + x) * 3 + c] = (float)(((x / 7 + 2 - phase) / 2) % 2);
}

static void test_colour_sorted_distance(void **state)
{
    (void)state;
    image bars, moved, flat, small;
    char err[256];
    double blocks = -1, sorted = -1;
    assert_int_equal(image_alloc(&bars, 224, 224, 3), 0);
    assert_int_equal(image_alloc(&moved, 224, 224, 3), 0);
    assert_int_equal(image_alloc(&flat, 224, 224, 3), 0);
    assert_int_equal(image_alloc(&small, 224, 100, 3), 0);
    fill_bars(&bars, 0);
    fill_bars(&moved, 2); /* the bars moved by their width: every box flips */
    fill(&flat, 0.5f, 0.5f, 0.5f);

    /* What the sorted term is for: compared box by box, the bars moved by their width are
     * farther from the bars (1) than a flat field of their mean (0.5); compared as
     * distributions, the moved bars are the same (0) and the flat field away by 0.5 along
     * R, G and B and 0 along the three hue differences (all grey): 0.25. */
    assert_int_equal(evaluate_colour_distance(&bars, &moved, &blocks, err, sizeof err), 0);
    assert_int_equal(evaluate_colour_sorted_distance(&bars, &moved, &sorted, err, sizeof err), 0);
    assert_true(fabs(blocks - 1.0) < 1e-9);
    assert_true(fabs(sorted) < 1e-12);
    assert_int_equal(evaluate_colour_distance(&bars, &flat, &blocks, err, sizeof err), 0);
    assert_int_equal(evaluate_colour_sorted_distance(&bars, &flat, &sorted, err, sizeof err), 0);
    assert_true(fabs(blocks - 0.5) < 1e-9);
    assert_true(fabs(sorted - 0.25) < 1e-9);

    /* Random images: sorted pairing is the optimal 1-D matching, so never above the
     * box-by-box pairing. */
    uint64_t st = 12345;
    for (int trial = 0; trial < 4; trial++) {
        for (int i = 0; i < 224 * 224 * 3; i++) {
            st = st * 6364136223846793005ULL + 1442695040888963407ULL;
            moved.pixels[i] = (float)((st >> 40) & 0xffff) / 65535.0f;
        }
        fill_bars(&bars, trial);
        assert_int_equal(evaluate_colour_distance(&bars, &moved, &blocks, err, sizeof err), 0);
        assert_int_equal(
            evaluate_colour_term(PIPELINE_COLOUR_SORTED, &bars, &moved, &sorted, err, sizeof err),
            0);
        assert_true(sorted <= blocks + 1e-12);
        assert_true(sorted > 0.1); /* bars of 0 and 1 against values near 0.5 */
    }
    /* Red + 0.3 everywhere: 0.3 / 3 box by box; sorted, 0.3 along R and 0.15 along R - G
     * and B - R, over six directions: the same 0.1. */
    fill(&bars, 0.1f, 0.3f, 0.5f);
    fill(&moved, 0.4f, 0.3f, 0.5f);
    assert_int_equal(evaluate_colour_term(PIPELINE_COLOUR_BLOCKS, &bars, &moved, &blocks, err,
                                          sizeof err),
                     0);
    assert_int_equal(evaluate_colour_sorted_distance(&bars, &moved, &sorted, err, sizeof err), 0);
    assert_true(fabs(blocks - 0.1) < 1e-6 && fabs(sorted - 0.1) < 1e-6);
    /* Red and cyan boxes where white and black ones were: R, G and B each half 1 and half
     * 0 in both, so channel by channel the two are the same; the hue differences see it.
     * R - G and B - R: 0 everywhere against +-0.5 in halves, 0.5 each; G - B: 0 in both. */
    for (int i = 0; i < 224 * 224; i++) {
        int odd = (i % 224) / 7 % 2;
        float *p = bars.pixels + (size_t)i * 3, *q = moved.pixels + (size_t)i * 3;
        p[0] = p[1] = p[2] = odd ? 1.0f : 0.0f;
        q[0] = odd ? 1.0f : 0.0f;
        q[1] = q[2] = odd ? 0.0f : 1.0f;
    }
    assert_int_equal(evaluate_colour_sorted_distance(&bars, &moved, &sorted, err, sizeof err), 0);
    assert_true(fabs(sorted - 1.0 / 6) < 1e-9);

    assert_int_equal(evaluate_colour_sorted_distance(&bars, &small, &sorted, err, sizeof err), -1);
    assert_non_null(strstr(err, "image 2 is 224 x 100"));
    image_free(&bars);
    image_free(&moved);
    image_free(&flat);
    image_free(&small);
}

static void test_floor_epsilon(void **state)
{
    (void)state;
    assert_true(evaluate_normalise(0.5, 0.25) == 2.0);
    /* A floor of 0 (a material nothing moves) divides by the epsilon, never by 0. */
    assert_true(evaluate_normalise(0.5, 0.0) == 0.5 / EVALUATE_FLOOR_EPSILON);
    assert_true(evaluate_normalise(0.5, EVALUATE_FLOOR_EPSILON / 10) ==
                0.5 / EVALUATE_FLOOR_EPSILON);
    assert_true(isfinite(evaluate_normalise(1.0, -1.0)));
}

static void test_quantiles(void **state)
{
    (void)state;
    /* numpy.percentile([7, 1, 3, 5, 9], [0, 10, 50, 90, 100]) = 1, 1.8, 5, 8.2, 9. */
    const double v[5] = {7, 1, 3, 5, 9};
    assert_true(fabs(evaluate_quantile(v, 5, 0.0) - 1.0) < 1e-12);
    assert_true(fabs(evaluate_quantile(v, 5, 0.1) - 1.8) < 1e-12);
    assert_true(fabs(evaluate_quantile(v, 5, 0.5) - 5.0) < 1e-12);
    assert_true(fabs(evaluate_quantile(v, 5, 0.9) - 8.2) < 1e-12);
    assert_true(fabs(evaluate_quantile(v, 5, 1.0) - 9.0) < 1e-12);
    assert_true(v[0] == 7 && v[1] == 1); /* not sorted in place */
    /* An even count: the median is the midpoint; NaNs are left out. */
    const double w[5] = {4, NAN, 1, 3, 2};
    assert_true(fabs(evaluate_quantile(w, 5, 0.5) - 2.5) < 1e-12);
    assert_true(fabs(evaluate_quantile(w, 5, 0.9) - 3.7) < 1e-12);
    const double one = 42;
    assert_true(evaluate_quantile(&one, 1, 0.1) == 42);
    assert_true(isnan(evaluate_quantile(v, 0, 0.5)));
    const double nans[2] = {NAN, NAN};
    assert_true(isnan(evaluate_quantile(nans, 2, 0.5)));
}

static void test_share_interval(void **state)
{
    (void)state;
    /* scipy.stats.binomtest(k, n).proportion_ci(0.95, method="wilson") (scipy 1.10). */
    const struct {
        size_t k, n;
        double lo, hi;
    } ref[] = {
        {35, 48, 0.5900303501775939, 0.8343404237254355},
        {46, 48, 0.8602434412954456, 0.9884981065106133},
        {18, 22, 0.6148339256287346, 0.9269311541657795},
        {0, 10, 0.0, 0.27753279986288926},
        {10, 10, 0.7224672001371109, 1.0},
    };
    for (size_t i = 0; i < sizeof ref / sizeof ref[0]; i++) {
        double lo, hi;
        evaluate_share_interval(ref[i].k, ref[i].n, &lo, &hi);
        assert_true(fabs(lo - ref[i].lo) < 1e-12);
        assert_true(fabs(hi - ref[i].hi) < 1e-12);
        double p = (double)ref[i].k / (double)ref[i].n;
        assert_true(lo <= p && p <= hi);
    }
    /* More inputs, the same share: a narrower interval. */
    double lo1, hi1, lo2, hi2;
    evaluate_share_interval(7, 10, &lo1, &hi1);
    evaluate_share_interval(70, 100, &lo2, &hi2);
    assert_true(hi2 - lo2 < hi1 - lo1);
    evaluate_share_interval(0, 0, &lo1, &hi1);
    assert_true(isnan(lo1) && isnan(hi1));
}

static void test_r2_and_spread(void **state)
{
    (void)state;
    const double truth[6] = {0.1, 0.9, 0.4, 0.6, 0.2, 0.8};
    const double mean = 0.5; /* the "training" mean */
    double constant[6], other[6], half[6];
    for (int i = 0; i < 6; i++) {
        constant[i] = mean;
        other[i] = 0.45;
        half[i] = mean + 0.5 * (truth[i] - mean);
    }
    assert_true(evaluate_r2(truth, truth, 6, mean) == 1.0);
    assert_true(evaluate_r2(constant, truth, 6, mean) == 0.0);
    assert_true(evaluate_r2(other, truth, 6, mean) < 0.0);
    /* Shrinking halfway to the mean: SSE = SST / 4, R^2 = 0.75, spread 0.5. */
    assert_true(fabs(evaluate_r2(half, truth, 6, mean) - 0.75) < 1e-12);
    assert_true(fabs(evaluate_spread(half, truth, 6) - 0.5) < 1e-12);
    assert_true(evaluate_spread(constant, truth, 6) == 0.0);
    assert_true(fabs(evaluate_spread(truth, truth, 6) - 1.0) < 1e-12);
    assert_true(isnan(evaluate_r2(truth, constant, 6, mean))); /* SST = 0 */
    assert_true(isnan(evaluate_spread(truth, constant, 6)));
    assert_true(isnan(evaluate_spread(truth, truth, 0)));
    /* Correlation: 1 for any increasing affine map, -1 reversed, NAN for a constant. */
    double flipped[6], noisy[6];
    const double wiggle[6] = {0.3, -0.2, 0.1, -0.3, 0.2, -0.1};
    for (int i = 0; i < 6; i++) {
        flipped[i] = 1.0 - truth[i];
        noisy[i] = half[i] + 0.2 * wiggle[i];
    }
    assert_true(fabs(evaluate_correlation(half, truth, 6) - 1.0) < 1e-12);
    assert_true(fabs(evaluate_correlation(flipped, truth, 6) + 1.0) < 1e-12);
    assert_true(isnan(evaluate_correlation(constant, truth, 6)));
    assert_true(isnan(evaluate_correlation(truth, truth, 0)));
    /* The identity the report's bound rests on: with equal means, R^2 = 2 s r - s^2. */
    double m_noisy = 0.0;
    for (int i = 0; i < 6; i++)
        m_noisy += noisy[i] / 6.0;
    for (int i = 0; i < 6; i++)
        noisy[i] += mean - m_noisy;
    double s = evaluate_spread(noisy, truth, 6), r = evaluate_correlation(noisy, truth, 6);
    assert_true(r > 0.0 && r < 1.0);
    assert_true(fabs(evaluate_r2(noisy, truth, 6, mean) - (2.0 * s * r - s * s)) < 1e-12);
}

/* The shared sheet font: every letter, digit and sign in the label alphabet draws some
 * dots, and a space draws none (only the dark box). */
static void test_sheet_label(void **state)
{
    (void)state;
    const char *alphabet = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-._/+%";
    image sheet;
    assert_int_equal(image_alloc(&sheet, 16, 16, 3), 0);
    for (const char *p = alphabet; *p; p++) {
        char text[2] = {*p, 0};
        for (int i = 0; i < 16 * 16 * 3; i++)
            sheet.pixels[i] = 0.5f;
        pipeline_sheet_label(&sheet, 1, 1, text, 1);
        int lit = 0, dark = 0;
        for (int i = 0; i < 16 * 16 * 3; i++) {
            lit += sheet.pixels[i] == 1.0f;
            dark += sheet.pixels[i] == 0.0f;
        }
        assert_true(lit > 0);
        assert_int_equal(lit + dark, 5 * 7 * 3); /* the box: (4 n + 1) x 7 */
    }
    for (int i = 0; i < 16 * 16 * 3; i++)
        sheet.pixels[i] = 0.5f;
    pipeline_sheet_label(&sheet, 10, 10, "  ", 2); /* clipped at the edge, no dots */
    int lit = 0;
    for (int i = 0; i < 16 * 16 * 3; i++)
        lit += sheet.pixels[i] == 1.0f;
    assert_int_equal(lit, 0);
    assert_true(sheet.pixels[(15 * 16 + 15) * 3] == 0.0f);
    image_free(&sheet);
}

/* A stored row's view (what datagen writes as view_json) parses back to its settings, and
 * its exposure and white balance scale a linear image; a malformed one is a clear error. */
static void test_view_parse(void **state)
{
    (void)state;
    pipeline_view v;
    char err[512];
    const char *json = "{\"scene\":\"flash\",\"light\":[0.08,0.06,2],\"exposure\":1,"
                       "\"wb\":[2,1,0.5],\"rotation_z\":0.25,\"shift\":[0.5,-0.25]}";
    assert_int_equal(pipeline_view_parse(json, &v, err, sizeof err), 0);
    assert_int_equal(v.flash, 1);
    assert_true(v.light[0] == 0.08 && v.light[1] == 0.06 && v.light[2] == 2.0);
    assert_true(v.exposure == 1.0 && v.wb[0] == 2.0 && v.wb[2] == 0.5);
    assert_true(v.rotate == 0.25 && v.shift[0] == 0.5 && v.shift[1] == -0.25);
    image img;
    assert_int_equal(image_alloc(&img, 1, 1, 3), 0);
    img.pixels[0] = img.pixels[1] = img.pixels[2] = 0.25f;
    pipeline_view_apply_gain(&v, &img); /* x 2^1 x (2, 1, 0.5) */
    assert_true(img.pixels[0] == 1.0f && img.pixels[1] == 0.5f && img.pixels[2] == 0.25f);
    image_free(&img);

    /* Rows made before rotate/shift existed: no texture transform. */
    const char *old = "{\"scene\":\"plain\",\"light\":[0.45,0.35,0.55],\"exposure\":0,"
                      "\"wb\":[1,1,1]}";
    assert_int_equal(pipeline_view_parse(old, &v, err, sizeof err), 0);
    assert_true(v.flash == 0 && v.rotate == 0.0 && v.shift[0] == 0.0 && v.light[2] == 0.55);

    /* The scene of a view: the light moved, the texture transform set. */
    const char *scene = "{\"lights\":[{\"location\":[0,0,1]}],\"objects\":[{\"name\":\"Plane\"}]}";
    assert_int_equal(pipeline_view_parse(json, &v, err, sizeof err), 0);
    char *text = pipeline_scene_for_view(scene, &v);
    assert_non_null(text);
    assert_non_null(strstr(text, "\"location\":[0.08,0.06,2]"));
    assert_non_null(strstr(text, "\"transform\":{\"location\":[0.5,-0.25,0]"));
    free(text);
    assert_null(pipeline_scene_for_view("{\"lights\":[]}", &v));

    assert_int_equal(pipeline_view_parse("{\"scene\":\"studio\"}", &v, err, sizeof err), -1);
    assert_non_null(strstr(err, "studio"));
    assert_int_equal(pipeline_view_parse("not json", &v, err, sizeof err), -1);
    assert_int_equal(pipeline_view_parse(NULL, &v, err, sizeof err), -1);
}

static void test_insert_by_key(void **state)
{
    (void)state;
    /* Ascending, NaN after every number, ties in index order (a stable sort): the order
     * predict's starts and evaluate's -topk / -refine picks rely on. */
    const double key[7] = {3, NAN, 1, 3, -INFINITY, NAN, 1};
    const int want[7] = {4, 2, 6, 0, 3, 1, 5};
    int order[7];
    for (int j = 0; j < 7; j++)
        pipeline_insert_by_key(order, j, key);
    for (int j = 0; j < 7; j++)
        assert_int_equal(order[j], want[j]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_gram_distance),  cmocka_unit_test(test_colour_distance),
        cmocka_unit_test(test_colour_sorted_distance),
        cmocka_unit_test(test_floor_epsilon),  cmocka_unit_test(test_quantiles),
        cmocka_unit_test(test_r2_and_spread),  cmocka_unit_test(test_sheet_label),
        cmocka_unit_test(test_view_parse),     cmocka_unit_test(test_share_interval),
        cmocka_unit_test(test_insert_by_key),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
