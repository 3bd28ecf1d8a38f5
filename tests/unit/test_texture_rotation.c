/*
 * A turned texture space (sg_graph_rotate_texture) and a turned image (image_rotate_ccw)
 * must agree, since `imsynth predict --rotation 90` shows the predictor the input turned
 * counterclockwise and renders the super-shader turned by +90 degrees: the turned
 * material's maps, turned counterclockwise, are the unturned material's maps.
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

#include "imageio/imageio.h"
#include "shadergraph/shadergraph.h"
#include "test_assets.h"

enum { RES = 64 };

static void test_rotate_ccw_moves_pixels(void **state)
{
    (void)state;
    /* 3 wide, 2 high, 2 channels would be refused by image_alloc: use 1 channel
     * then 3. */
    image a;
    assert_int_equal(image_alloc(&a, 3, 2, 1), 0);
    for (int i = 0; i < 6; i++)
        a.pixels[i] = (float)i; /* rows: 0 1 2 / 3 4 5 */
    image b;
    assert_int_equal(image_rotate_ccw(&a, &b), 0);
    assert_int_equal(b.width, 2);
    assert_int_equal(b.height, 3);
    /* Counterclockwise: the right column comes up as the top row. */
    const float want[6] = {2, 5, 1, 4, 0, 3};
    for (int i = 0; i < 6; i++)
        assert_true(b.pixels[i] == want[i]);
    image_free(&a);
    image_free(&b);

    /* Four quarter turns are no turn, channel by channel. */
    image c, t[4];
    assert_int_equal(image_alloc(&c, 5, 3, 3), 0);
    for (int i = 0; i < 45; i++)
        c.pixels[i] = (float)(i * 7 % 11);
    const image *src = &c;
    for (int k = 0; k < 4; k++) {
        assert_int_equal(image_rotate_ccw(src, &t[k]), 0);
        src = &t[k];
    }
    assert_int_equal(t[3].width, 5);
    assert_int_equal(t[3].height, 3);
    assert_memory_equal(t[3].pixels, c.pixels, 45 * sizeof(float));
    assert_int_equal(t[1].width, 5); /* a half turn: the pixel order reversed */
    for (int i = 0; i < 15; i++)
        for (int ch = 0; ch < 3; ch++)
            assert_true(t[1].pixels[i * 3 + ch] == c.pixels[(14 - i) * 3 + ch]);
    for (int k = 0; k < 4; k++)
        image_free(&t[k]);
    image_free(&c);
}

/* Map k (0 Base Color, 1 Roughness) of g over a RES x RES view of the plane, as an RGB
 * image (a float map in all three channels). */
static void eval_map(const sg_graph *g, int k, image *out)
{
    static const sg_socket_ref maps[2] = {{"Principled BSDF", "Base Color"},
                                          {"Principled BSDF", "Roughness"}};
    char err[SG_ERROR_MAX] = "";
    sg_program *p = sg_compile(g, &maps[k], 1, NULL, err, sizeof err);
    if (!p)
        fail_msg("compile: %s", err);
    enum { B = 256 };
    sg_evaluator *e = sg_evaluator_new(p, B);
    static float geom[48 * B], tmp[3 * B];
    assert_int_equal(image_alloc(out, RES, RES, 3), 0);
    int w = sg_socket_type_width(sg_program_output_type(p, 0));
    for (int first = 0; first < RES * RES; first += B) {
        sg_geometry_batch gb;
        sg_plane_geometry(RES, RES, first, B, geom, &gb);
        float *o[1] = {tmp};
        sg_evaluate(e, &gb, o);
        for (int i = 0; i < B; i++)
            for (int c = 0; c < 3; c++)
                out->pixels[(size_t)(first + i) * 3 + (size_t)c] = tmp[(w == 1 ? 0 : c) * B + i];
    }
    sg_evaluator_free(e);
    sg_program_free(p);
}

/* The share of values of a and b within 1e-3 of each other. */
static double agreement(const image *a, const image *b)
{
    size_t n = (size_t)a->width * (size_t)a->height * 3, same = 0;
    for (size_t i = 0; i < n; i++)
        same += fabsf(a->pixels[i] - b->pixels[i]) <= 1e-3f;
    return (double)same / (double)n;
}

/* The super-shader at 24 frames: the turned material's maps turned back counterclockwise
 * agree with the unturned ones, up to the float rounding of a quarter turn (cos(pi/2) is
 * -4.4e-8 in float, so edges of bricks and cells may flip a pixel); turned the other way
 * they do not, on frames that have a pattern. */
static void test_supershader_turned_is_image_turned(void **state)
{
    (void)state;
    sg_params params;
    sg_graph *g = load_supershader(&params);
    char err[SG_ERROR_MAX] = "";
    int patterned = 0, told_apart = 0;
    for (unsigned seed = 0; seed < 24; seed++) {
        sg_params_sample(&params, seed);
        if (sg_graph_bind_params(g, &params, err, sizeof err) < 0)
            fail_msg("%s", err);
        sg_graph *t = sg_graph_rotate_texture(g, 90.0, err, sizeof err);
        if (!t)
            fail_msg("seed %u: %s", seed, err);
        for (int k = 0; k < 2; k++) {
            image a, b, back, wrong, w2;
            eval_map(g, k, &a);
            eval_map(t, k, &b);
            assert_int_equal(image_rotate_ccw(&b, &back), 0);
            double right = agreement(&a, &back);
            if (right < 0.99)
                fail_msg("seed %u map %d: only %.4f of values agree turned back", seed, k, right);
            /* clockwise: three counterclockwise turns */
            assert_int_equal(image_rotate_ccw(&back, &wrong), 0);
            assert_int_equal(image_rotate_ccw(&wrong, &w2), 0);
            double other = agreement(&a, &w2);
            image_free(&wrong);
            assert_int_equal(image_rotate_ccw(&w2, &wrong), 0); /* = b turned ccw 4x = b */
            assert_memory_equal(wrong.pixels, b.pixels, sizeof(float) * 3 * RES * RES);
            double spread = 0; /* does the map vary at all? */
            for (int i = 3; i < 3 * RES * RES; i++)
                spread = fmax(spread, fabs(a.pixels[i] - a.pixels[0]));
            if (k == 0 && spread > 0.05) {
                patterned++;
                told_apart += other < 0.5;
            }
            image_free(&a);
            image_free(&b);
            image_free(&back);
            image_free(&wrong);
            image_free(&w2);
        }
        sg_graph_free(t);
    }
    /* Most frames have a visible pattern, and a pattern turned the wrong way is another
     * image: the check above could fail. */
    assert_true(patterned >= 16);
    assert_true(told_apart >= patterned * 3 / 4);
    sg_params_free(&params);
    sg_graph_free(g);
}

/* What a turn adds: one Mapping node per (Texture Coordinate, position output) used, its
 * rotation the float of pi/2, kept by extraction; a graph without texture coordinates is
 * unchanged; a turn of 0 or 360 degrees changes no value; NaN is refused. */
static void test_turn_adds_one_mapping_node(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = load_asset("assets/supershader.json");
    sg_graph *t = sg_graph_rotate_texture(g, 90.0, err, sizeof err);
    assert_non_null(t);
    char *gj = sg_graph_to_json(g), *tj = sg_graph_to_json(t);
    assert_int_equal(sg_graph_node_count(t), sg_graph_node_count(g) + 1);
    const char *m = strstr(tj, "\"ShaderNodeMapping\"");
    assert_non_null(m);
    assert_null(strstr(m + 1, "\"ShaderNodeMapping\"")); /* the only one */
    assert_null(strstr(gj, "\"ShaderNodeMapping\""));
    assert_non_null(strstr(tj, "\"Texture Rotation\""));
    /* Its Rotation: 1.57079637 (float pi/2), however cJSON writes it. */
    const char *rot = strstr(m, "\"Rotation\"");
    assert_non_null(rot);
    rot = strchr(rot, '[');
    assert_non_null(rot);
    float x = 1, y = 1, z = 0;
    assert_int_equal(sscanf(rot, "[%f,%f,%f]", &x, &y, &z), 3);
    assert_true(x == 0.0f && y == 0.0f && z == (float)(M_PI / 2));

    /* Extraction keeps it: the sub-shader of a frame with a pattern reads turned
     * coordinates. */
    sg_params params;
    if (sg_params_from_graph(t, &params, err, sizeof err) < 0)
        fail_msg("%s", err);
    sg_params_sample(&params, 3);
    if (sg_graph_bind_params(t, &params, err, sizeof err) < 0)
        fail_msg("%s", err);
    sg_graph *x3 = sg_extract(t, NULL, err, sizeof err);
    assert_non_null(x3);
    char *xj = sg_graph_to_json(x3);
    assert_non_null(strstr(xj, "\"ShaderNodeMapping\""));
    free(xj);
    sg_graph_free(x3);
    sg_params_free(&params);

    /* Two turns: two Mapping nodes in a row, uniquely named. */
    sg_graph *tt = sg_graph_rotate_texture(t, 90.0, err, sizeof err);
    assert_non_null(tt);
    assert_int_equal(sg_graph_node_count(tt), sg_graph_node_count(g) + 2);
    sg_graph_free(tt);

    /* No texture coordinates: nothing to turn. */
    sg_graph *plain = load_asset("tests/reference/nodes/blender_made_noise_ramp_bump_b34_basecolor/graph.json");
    char *pj = sg_graph_to_json(plain);
    assert_null(strstr(pj, "ShaderNodeTexCoord"));
    sg_graph *pt = sg_graph_rotate_texture(plain, 90.0, err, sizeof err);
    assert_non_null(pt);
    char *ptj = sg_graph_to_json(pt);
    assert_string_equal(ptj, pj);
    free(ptj);
    free(pj);
    sg_graph_free(pt);
    sg_graph_free(plain);

    /* 0 and 360 degrees: the same values as no turn (a rotation of exactly 0). */
    sg_graph *z0 = sg_graph_rotate_texture(g, 360.0, err, sizeof err);
    assert_non_null(z0);
    image a, b;
    eval_map(g, 0, &a);
    eval_map(z0, 0, &b);
    assert_memory_equal(a.pixels, b.pixels, sizeof(float) * 3 * RES * RES);
    image_free(&a);
    image_free(&b);
    sg_graph_free(z0);

    assert_null(sg_graph_rotate_texture(g, NAN, err, sizeof err));
    assert_non_null(strstr(err, "not finite"));
    free(gj);
    free(tj);
    sg_graph_free(t);
    sg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rotate_ccw_moves_pixels),
        cmocka_unit_test(test_supershader_turned_is_image_turned),
        cmocka_unit_test(test_turn_adds_one_mapping_node),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
