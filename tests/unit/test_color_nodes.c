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

#include "shadergraph/node_type.h"

#define MAXN 8

/* One kernel call on n points. Inputs are given per socket as planar arrays (NULL: use
 * the socket's default, broadcast); all outputs are requested. */
typedef struct call {
    const sg_node_type *type;
    int n;
    int prop[8];
    sg_blender_mode blender;
    const sg_color_ramp *ramp;
    float in[12][3 * MAXN];
    float out[6][3 * MAXN];
} call;

static int width(sg_socket_type t)
{
    return (t == SG_SOCKET_VECTOR || t == SG_SOCKET_COLOR) ? 3 : 1;
}

static void call_init(call *c, const char *idname, int n)
{
    memset(c, 0, sizeof *c);
    c->type = sg_node_type_find(idname);
    assert_non_null(c->type);
    c->n = n;
    c->blender = SG_BLENDER_4;
    for (int p = 0; p < c->type->n_props; p++)
        c->prop[p] = c->type->props[p].default_value;
    for (int k = 0; k < c->type->n_inputs; k++) {
        const sg_socket_def *s = &c->type->inputs[k];
        for (int ch = 0; ch < width(s->type); ch++)
            for (int i = 0; i < n; i++)
                c->in[k][ch * n + i] = s->default_value[ch];
    }
}

static void set_input(call *c, const char *identifier, int i, float x, float y, float z)
{
    int k = sg_node_type_input_index(c->type, identifier);
    assert_true(k >= 0);
    c->in[k][i] = x;
    if (width(c->type->inputs[k].type) == 3) {
        c->in[k][c->n + i] = y;
        c->in[k][2 * c->n + i] = z;
    }
}

static void set_prop(call *c, const char *name, const char *value)
{
    int p = sg_node_type_prop_index(c->type, name);
    assert_true(p >= 0);
    const sg_prop_def *d = &c->type->props[p];
    if (d->kind == SG_PROP_BOOL) {
        c->prop[p] = strcmp(value, "true") == 0;
        return;
    }
    for (int v = 0; d->values[v]; v++)
        if (strcmp(d->values[v], value) == 0) {
            c->prop[p] = v;
            return;
        }
    fail_msg("no value %s for %s", value, name);
}

static void run(call *c)
{
    const float *in[12];
    float *out[6];
    for (int k = 0; k < 12; k++)
        in[k] = c->in[k];
    for (int k = 0; k < 6; k++)
        out[k] = c->out[k];
    sg_kernel_args a = {.n = c->n, .blender = c->blender, .prop = c->prop, .ramp = c->ramp,
                        .in = in, .out = out};
    c->type->kernel(&a);
}

static float out_at(const call *c, const char *identifier, int i, int ch)
{
    int k = sg_node_type_output_index(c->type, identifier);
    assert_true(k >= 0);
    return c->out[k][ch * c->n + i];
}

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
        call c;
        call_init(&c, "ShaderNodeValToRGB", 4);
        c.ramp = &ramp;
        c.blender = mode ? SG_BLENDER_3 : SG_BLENDER_4;
        for (int i = 0; i < 4; i++)
            set_input(&c, "Fac", i, fac[i], 0, 0);
        run(&c);
        for (int i = 0; i < 4; i++) {
            float want = mode ? white3[i] : white4[i];
            assert_float_equal(out_at(&c, "Color", i, 0), want, 0.0f);
            assert_float_equal(out_at(&c, "Alpha", i, 0), 1.0f, 0.0f);
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
        call c;
        call_init(&c, "ShaderNodeValToRGB", 6);
        c.ramp = &ramp;
        c.blender = mode ? SG_BLENDER_3 : SG_BLENDER_4;
        for (int i = 0; i < 6; i++)
            set_input(&c, "Fac", i, fac[i], 0, 0);
        run(&c);
        for (int i = 0; i < 6; i++) {
            float want = fminf(fmaxf(fac[i], 0.0f), 1.0f);
            for (int ch = 0; ch < 3; ch++)
                assert_float_equal(out_at(&c, "Color", i, ch), want, 1e-6f);
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
    call c;
    call_init(&c, "ShaderNodeValToRGB", 1);
    c.ramp = &ramp;
    set_input(&c, "Fac", 0, 0.5f, 0, 0);
    run(&c);
    assert_float_equal(out_at(&c, "Color", 0, 0), 0.0f, 1e-3f);
    assert_float_equal(out_at(&c, "Color", 0, 1), 1.0f, 1e-3f);
    assert_float_equal(out_at(&c, "Color", 0, 2), 1.0f, 1e-3f);
}

/* Blender stores ramp colours clamped below at 0: a negative channel acts as 0. */
static void test_ramp_negative_colour_is_zero(void **state)
{
    (void)state;
    sg_color_ramp ramp = two_stop_ramp(2, 1.0f);
    ramp.color[0][0] = -2.0f;
    ramp.color[1][0] = -1.0f;
    ramp.color[1][1] = 3.0f;
    call c;
    call_init(&c, "ShaderNodeValToRGB", 1);
    c.ramp = &ramp;
    set_input(&c, "Fac", 0, 0.5f, 0, 0);
    run(&c);
    assert_float_equal(out_at(&c, "Color", 0, 0), 0.0f, 0.0f);
    assert_float_equal(out_at(&c, "Color", 0, 1), 1.5f, 1e-6f);
}

/* ---- Mix ---------------------------------------------------------------------------- */

/* The new Mix node leaves the factor alone when clamp_factor is off (extrapolates);
 * legacy MixRGB always clamps it (Cycles' svm_mix_clamped_factor). */
static void test_mix_factor_clamping(void **state)
{
    (void)state;
    call c;
    call_init(&c, "ShaderNodeMix", 1);
    set_prop(&c, "data_type", "RGBA");
    set_prop(&c, "clamp_factor", "false");
    set_input(&c, "Factor_Float", 0, 2.0f, 0, 0);
    set_input(&c, "A_Color", 0, 0.25f, 0.5f, 0.0f);
    set_input(&c, "B_Color", 0, 0.5f, 0.5f, 1.0f);
    run(&c);
    assert_float_equal(out_at(&c, "Result_Color", 0, 0), 0.75f, 1e-6f);
    assert_float_equal(out_at(&c, "Result_Color", 0, 2), 2.0f, 1e-6f);

    set_prop(&c, "clamp_result", "true");
    run(&c);
    assert_float_equal(out_at(&c, "Result_Color", 0, 2), 1.0f, 0.0f);

    call l;
    call_init(&l, "ShaderNodeMixRGB", 1);
    set_input(&l, "Fac", 0, 2.0f, 0, 0);
    set_input(&l, "Color1", 0, 0.25f, 0.5f, 0.0f);
    set_input(&l, "Color2", 0, 0.5f, 0.5f, 1.0f);
    run(&l);
    assert_float_equal(out_at(&l, "Color", 0, 0), 0.5f, 1e-6f);
    assert_float_equal(out_at(&l, "Color", 0, 2), 1.0f, 1e-6f);
}

static void test_mix_vector_non_uniform(void **state)
{
    (void)state;
    call c;
    call_init(&c, "ShaderNodeMix", 1);
    set_prop(&c, "data_type", "VECTOR");
    set_prop(&c, "factor_mode", "NON_UNIFORM");
    set_input(&c, "Factor_Vector", 0, 0.0f, 0.5f, 1.0f);
    set_input(&c, "A_Vector", 0, 1.0f, 1.0f, 1.0f);
    set_input(&c, "B_Vector", 0, 3.0f, 3.0f, 3.0f);
    run(&c);
    assert_float_equal(out_at(&c, "Result_Vector", 0, 0), 1.0f, 0.0f);
    assert_float_equal(out_at(&c, "Result_Vector", 0, 1), 2.0f, 0.0f);
    assert_float_equal(out_at(&c, "Result_Vector", 0, 2), 3.0f, 0.0f);
}

/* ---- Invert, Combine/Separate Color --------------------------------------------------- */

static void test_invert(void **state)
{
    (void)state;
    call c;
    call_init(&c, "ShaderNodeInvert", 2);
    set_input(&c, "Color", 0, 0.2f, 1.5f, -1.0f);
    set_input(&c, "Color", 1, 0.2f, 1.5f, -1.0f);
    set_input(&c, "Fac", 1, 0.5f, 0, 0);
    run(&c);
    assert_float_equal(out_at(&c, "Color", 0, 0), 0.8f, 1e-6f);
    assert_float_equal(out_at(&c, "Color", 0, 1), -0.5f, 1e-6f);
    assert_float_equal(out_at(&c, "Color", 0, 2), 2.0f, 1e-6f);
    for (int ch = 0; ch < 3; ch++)
        assert_float_equal(out_at(&c, "Color", 1, ch), 0.5f, 1e-6f);
}

/* Separate then Combine in HSV and HSL gives the colour back (in gamut). Cycles' HSV
 * does not wrap hues: h = 1.25 lands in the "sextant >= 5" branch, not at h = 0.25. */
static void test_color_round_trip_and_unwrapped_hue(void **state)
{
    (void)state;
    const float rgb[3][3] = {{0.9f, 0.2f, 0.4f}, {0.1f, 0.7f, 0.3f}, {0.25f, 0.25f, 0.8f}};
    for (int mode = 1; mode <= 2; mode++) {
        const char *mode_name = mode == 1 ? "HSV" : "HSL";
        call s;
        call_init(&s, "ShaderNodeSeparateColor", 3);
        set_prop(&s, "mode", mode_name);
        for (int i = 0; i < 3; i++)
            set_input(&s, "Color", i, rgb[i][0], rgb[i][1], rgb[i][2]);
        run(&s);
        call c;
        call_init(&c, "ShaderNodeCombineColor", 3);
        set_prop(&c, "mode", mode_name);
        for (int i = 0; i < 3; i++) {
            set_input(&c, "Red", i, out_at(&s, "Red", i, 0), 0, 0);
            set_input(&c, "Green", i, out_at(&s, "Green", i, 0), 0, 0);
            set_input(&c, "Blue", i, out_at(&s, "Blue", i, 0), 0, 0);
        }
        run(&c);
        for (int i = 0; i < 3; i++)
            for (int ch = 0; ch < 3; ch++)
                assert_float_equal(out_at(&c, "Color", i, ch), rgb[i][ch], 1e-5f);
    }
    call c;
    call_init(&c, "ShaderNodeCombineColor", 1);
    set_prop(&c, "mode", "HSV");
    set_input(&c, "Red", 0, 1.25f, 0, 0);
    set_input(&c, "Green", 0, 1.0f, 0, 0);
    set_input(&c, "Blue", 0, 1.0f, 0, 0);
    run(&c);
    assert_float_equal(out_at(&c, "Color", 0, 0), 1.0f, 1e-6f);
    assert_float_equal(out_at(&c, "Color", 0, 1), 0.0f, 1e-6f);
    assert_float_equal(out_at(&c, "Color", 0, 2), 0.5f, 1e-6f);
}

/* ---- Mapping ---------------------------------------------------------------------------- */

/* TEXTURE undoes POINT; NORMAL gives unit vectors; VECTOR ignores Location. */
static void test_mapping_inverse(void **state)
{
    (void)state;
    const float v[3] = {0.3f, -1.2f, 2.5f};
    call p;
    call_init(&p, "ShaderNodeMapping", 1);
    set_input(&p, "Vector", 0, v[0], v[1], v[2]);
    set_input(&p, "Location", 0, 1.0f, -2.0f, 0.5f);
    set_input(&p, "Rotation", 0, 0.4f, -1.1f, 2.3f);
    set_input(&p, "Scale", 0, 2.0f, 0.5f, -3.0f);
    run(&p);
    call t = p;
    set_prop(&t, "vector_type", "TEXTURE");
    set_input(&t, "Vector", 0, out_at(&p, "Vector", 0, 0), out_at(&p, "Vector", 0, 1),
              out_at(&p, "Vector", 0, 2));
    run(&t);
    for (int ch = 0; ch < 3; ch++)
        assert_float_equal(out_at(&t, "Vector", 0, ch), v[ch], 1e-5f);

    call nrm = p;
    set_prop(&nrm, "vector_type", "NORMAL");
    run(&nrm);
    float len2 = 0.0f;
    for (int ch = 0; ch < 3; ch++)
        len2 += out_at(&nrm, "Vector", 0, ch) * out_at(&nrm, "Vector", 0, ch);
    assert_float_equal(len2, 1.0f, 1e-5f);

    call vec = p;
    set_prop(&vec, "vector_type", "VECTOR");
    run(&vec);
    set_input(&vec, "Location", 0, 0.0f, 0.0f, 0.0f);
    call vec0 = vec;
    run(&vec0);
    for (int ch = 0; ch < 3; ch++)
        assert_float_equal(out_at(&vec, "Vector", 0, ch), out_at(&vec0, "Vector", 0, ch), 0.0f);
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
