/*
 * Colour nodes: Mix (and the legacy MixRGB), Invert, Color Ramp, and the RGB and Value
 * constants.
 *
 * Sources of truth: Cycles' kernel/svm/mix.h, color_util.h (the blend modes), invert.h,
 * ramp.h/ramp_util.h (the ramp lookup), value.h; for the Color Ramp also Blender's
 * BKE_colorband_evaluate (blenkernel colorband), BLI's rgb/hsv/hsl conversions and
 * key_curve_position_weights, because Cycles never evaluates a ramp itself: Blender
 * samples the ramp into a table when it hands the shader to Cycles, and the kernel
 * interpolates that table.
 *
 * Blender 3.4 and 4.3 differ in two places here:
 *   - the EXCLUSION blend exists only in 4.x (3.4 cannot express it; it is computed the
 *     4.x way in both modes);
 *   - the ramp table: 3.4 samples 256 entries at i / 255, 4.3 samples 257 entries at
 *     i / 256 (measured: a CONSTANT ramp with a stop at 0.5 switches at 128/255 in 3.4
 *     and at exactly 0.5 in 4.3).
 */
#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "shadergraph/fold.h"
#include "shadergraph/kernels/color_util.h"
#include "shadergraph/kernels/kernel_util.h"
#include "shadergraph/node_type.h"


/* ---- the blend modes (Cycles' svm_mix) ------------------------------------------- */

/* Blender 4.x RNA order of blend_type (ShaderNodeMix and ShaderNodeMixRGB). */
static const char *const blend_type_values[] = {
    "MIX",          "DARKEN",     "MULTIPLY", "BURN",     "LIGHTEN", "SCREEN",     "DODGE",
    "ADD",          "OVERLAY",    "SOFT_LIGHT", "LINEAR_LIGHT", "DIFFERENCE", "EXCLUSION",
    "SUBTRACT",     "DIVIDE",     "HUE",      "SATURATION", "COLOR", "VALUE",      NULL};
enum {
    BLEND_MIX, BLEND_DARKEN, BLEND_MULTIPLY, BLEND_BURN, BLEND_LIGHTEN, BLEND_SCREEN,
    BLEND_DODGE, BLEND_ADD, BLEND_OVERLAY, BLEND_SOFT_LIGHT, BLEND_LINEAR_LIGHT,
    BLEND_DIFFERENCE, BLEND_EXCLUSION, BLEND_SUBTRACT, BLEND_DIVIDE, BLEND_HUE,
    BLEND_SATURATION, BLEND_COLOR, BLEND_VALUE
};

/* Cycles' interp() of float3s: its SSE operators round the product (mix, not mix_fused). */
static inline float3 lerp3(float3 a, float3 b, float t)
{
    return make_float3(mix(a.x, b.x, t), mix(a.y, b.y, t), mix(a.z, b.z, t));
}
static inline float3 saturate3(float3 a)
{
    return make_float3(saturatef(a.x), saturatef(a.y), saturatef(a.z));
}

static inline float overlay1(float t, float a, float b)
{
    float tm = 1.0f - t;
    if (a < 0.5f)
        return a * (tm + 2.0f * t * b);
    return 1.0f - (tm + 2.0f * t * (1.0f - b)) * (1.0f - a);
}

/* Divide leaves a channel alone where the divisor is 0. */
static inline float divide1(float t, float a, float b)
{
    float tm = 1.0f - t;
    return b != 0.0f ? tm * a + t * a / b : a;
}

static inline float dodge1(float t, float a, float b)
{
    if (a == 0.0f)
        return a;
    float d = 1.0f - t * b;
    if (d <= 0.0f)
        return 1.0f;
    float q = a / d;
    return q > 1.0f ? 1.0f : q;
}

static inline float burn1(float t, float a, float b)
{
    float d = (1.0f - t) + t * b;
    if (d <= 0.0f)
        return 0.0f;
    float q = 1.0f - (1.0f - a) / d;
    if (q < 0.0f)
        return 0.0f;
    return q > 1.0f ? 1.0f : q;
}

/* One function per blend mode, as Cycles' svm_mix_* (kernel/svm/color_util.h). */
static inline float3 blend_mix(float t, float3 a, float3 b) { return lerp3(a, b, t); }
static inline float3 blend_add(float t, float3 a, float3 b) { return lerp3(a, f3_add(a, b), t); }
static inline float3 blend_multiply(float t, float3 a, float3 b) { return lerp3(a, f3_mul(a, b), t); }
static inline float3 blend_subtract(float t, float3 a, float3 b) { return lerp3(a, f3_sub(a, b), t); }

static inline float3 blend_screen(float t, float3 a, float3 b)
{
    float tm = 1.0f - t;
    return make_float3(1.0f - (tm + t * (1.0f - b.x)) * (1.0f - a.x),
                       1.0f - (tm + t * (1.0f - b.y)) * (1.0f - a.y),
                       1.0f - (tm + t * (1.0f - b.z)) * (1.0f - a.z));
}

static inline float3 blend_overlay(float t, float3 a, float3 b)
{
    return make_float3(overlay1(t, a.x, b.x), overlay1(t, a.y, b.y), overlay1(t, a.z, b.z));
}

static inline float3 blend_divide(float t, float3 a, float3 b)
{
    return make_float3(divide1(t, a.x, b.x), divide1(t, a.y, b.y), divide1(t, a.z, b.z));
}

static inline float3 blend_difference(float t, float3 a, float3 b)
{
    return lerp3(a, make_float3(fabsf(a.x - b.x), fabsf(a.y - b.y), fabsf(a.z - b.z)), t);
}

/* Blender 4.x only; clamped below at 0. */
static inline float3 blend_exclusion(float t, float3 a, float3 b)
{
    float3 e = make_float3(a.x + b.x - 2.0f * a.x * b.x, a.y + b.y - 2.0f * a.y * b.y,
                           a.z + b.z - 2.0f * a.z * b.z);
    float3 r = lerp3(a, e, t);
    return make_float3(maxf(r.x, 0.0f), maxf(r.y, 0.0f), maxf(r.z, 0.0f));
}

static inline float3 blend_darken(float t, float3 a, float3 b)
{
    return lerp3(a, make_float3(minf(a.x, b.x), minf(a.y, b.y), minf(a.z, b.z)), t);
}

static inline float3 blend_lighten(float t, float3 a, float3 b)
{
    return lerp3(a, make_float3(maxf(a.x, b.x), maxf(a.y, b.y), maxf(a.z, b.z)), t);
}

static inline float3 blend_dodge(float t, float3 a, float3 b)
{
    return make_float3(dodge1(t, a.x, b.x), dodge1(t, a.y, b.y), dodge1(t, a.z, b.z));
}

static inline float3 blend_burn(float t, float3 a, float3 b)
{
    return make_float3(burn1(t, a.x, b.x), burn1(t, a.y, b.y), burn1(t, a.z, b.z));
}

/* B's hue on A, only where B has a hue at all. */
static inline float3 blend_hue(float t, float3 a, float3 b)
{
    float3 hsv_b = rgb_to_hsv(b);
    if (hsv_b.y == 0.0f)
        return a;
    float3 hsv = rgb_to_hsv(a);
    hsv.x = hsv_b.x;
    return lerp3(a, hsv_to_rgb(hsv), t);
}

/* A's saturation towards B's; a grey A stays grey. Not an interpolation of colours. */
static inline float3 blend_saturation(float t, float3 a, float3 b)
{
    float3 hsv = rgb_to_hsv(a);
    if (hsv.y == 0.0f)
        return a;
    float3 hsv_b = rgb_to_hsv(b);
    hsv.y = (1.0f - t) * hsv.y + t * hsv_b.y;
    return hsv_to_rgb(hsv);
}

static inline float3 blend_value(float t, float3 a, float3 b)
{
    float3 hsv = rgb_to_hsv(a);
    float3 hsv_b = rgb_to_hsv(b);
    hsv.z = (1.0f - t) * hsv.z + t * hsv_b.z;
    return hsv_to_rgb(hsv);
}

/* B's hue and saturation on A, where B has a hue. */
static inline float3 blend_color(float t, float3 a, float3 b)
{
    float3 hsv_b = rgb_to_hsv(b);
    if (hsv_b.y == 0.0f)
        return a;
    float3 hsv = rgb_to_hsv(a);
    hsv.x = hsv_b.x;
    hsv.y = hsv_b.y;
    return lerp3(a, hsv_to_rgb(hsv), t);
}

static inline float3 blend_soft_light(float t, float3 a, float3 b)
{
    float3 one = make_float3(1.0f, 1.0f, 1.0f);
    float3 screen = f3_sub(one, f3_mul(f3_sub(one, b), f3_sub(one, a)));
    float3 soft = f3_add(f3_mul(f3_mul(f3_sub(one, a), b), a), f3_mul(a, screen));
    return f3_add(f3_scale(a, 1.0f - t), f3_scale(soft, t));
}

static inline float3 blend_linear_light(float t, float3 a, float3 b)
{
    return make_float3(a.x + t * (2.0f * b.x + -1.0f), a.y + t * (2.0f * b.y + -1.0f),
                       a.z + t * (2.0f * b.z + -1.0f));
}

/* out = blend(t, A, B) over a batch, t optionally clamped to [0, 1] first and the result
 * optionally clamped after. The switch is outside the loops: one loop per mode. */
static void blend_batch(int blend, int n, const float *fac, bool clamp_factor, const float *ca,
                        const float *cb, bool clamp_result, float *out)
{
#define BLEND_LOOP(fn)                                                                     \
    for (int i = 0; i < n; i++) {                                                          \
        float t = clamp_factor ? saturatef(fac[i]) : fac[i];                               \
        float3 r = fn(t, f3_load(ca, n, i), f3_load(cb, n, i));                            \
        f3_store(out, n, i, clamp_result ? saturate3(r) : r);                              \
    }                                                                                      \
    break

    switch (blend) {
    case BLEND_MIX: BLEND_LOOP(blend_mix);
    case BLEND_DARKEN: BLEND_LOOP(blend_darken);
    case BLEND_MULTIPLY: BLEND_LOOP(blend_multiply);
    case BLEND_BURN: BLEND_LOOP(blend_burn);
    case BLEND_LIGHTEN: BLEND_LOOP(blend_lighten);
    case BLEND_SCREEN: BLEND_LOOP(blend_screen);
    case BLEND_DODGE: BLEND_LOOP(blend_dodge);
    case BLEND_ADD: BLEND_LOOP(blend_add);
    case BLEND_OVERLAY: BLEND_LOOP(blend_overlay);
    case BLEND_SOFT_LIGHT: BLEND_LOOP(blend_soft_light);
    case BLEND_LINEAR_LIGHT: BLEND_LOOP(blend_linear_light);
    case BLEND_DIFFERENCE: BLEND_LOOP(blend_difference);
    case BLEND_EXCLUSION: BLEND_LOOP(blend_exclusion);
    case BLEND_SUBTRACT: BLEND_LOOP(blend_subtract);
    case BLEND_DIVIDE: BLEND_LOOP(blend_divide);
    case BLEND_HUE: BLEND_LOOP(blend_hue);
    case BLEND_SATURATION: BLEND_LOOP(blend_saturation);
    case BLEND_COLOR: BLEND_LOOP(blend_color);
    case BLEND_VALUE: BLEND_LOOP(blend_value);
    default:
        /* The loader only admits the values above; Cycles' fallback is black. */
        memset(out, 0, sizeof(float) * 3 * (size_t)n);
        break;
    }
#undef BLEND_LOOP
}

/* ---- Mix (ShaderNodeMix) ---------------------------------------------------------- */

static const char *const mix_data_type_values[] = {"FLOAT", "VECTOR", "RGBA", NULL};
enum { DATA_FLOAT, DATA_VECTOR, DATA_RGBA };
static const char *const mix_factor_mode_values[] = {"UNIFORM", "NON_UNIFORM", NULL};
enum { FACTOR_UNIFORM, FACTOR_NON_UNIFORM };
enum { MIX_PROP_DATA_TYPE, MIX_PROP_FACTOR_MODE, MIX_PROP_BLEND_TYPE, MIX_PROP_CLAMP_FACTOR,
       MIX_PROP_CLAMP_RESULT };
enum { MIX_IN_FACTOR_FLOAT, MIX_IN_FACTOR_VECTOR, MIX_IN_A_FLOAT, MIX_IN_B_FLOAT,
       MIX_IN_A_VECTOR, MIX_IN_B_VECTOR, MIX_IN_A_COLOR, MIX_IN_B_COLOR };
enum { MIX_OUT_FLOAT, MIX_OUT_VECTOR, MIX_OUT_COLOR };

static void mix_float(const sg_kernel_args *a, bool clamp_factor)
{
    float *out = a->out[MIX_OUT_FLOAT];
    if (!out)
        return;
    const float *fac = a->in[MIX_IN_FACTOR_FLOAT];
    const float *x = a->in[MIX_IN_A_FLOAT], *y = a->in[MIX_IN_B_FLOAT];
    for (int i = 0; i < a->n; i++) {
        float t = clamp_factor ? saturatef(fac[i]) : fac[i];
        out[i] = x[i] * (1.0f - t) + y[i] * t;
    }
}

static void mix_vector(const sg_kernel_args *a, bool clamp_factor, bool non_uniform)
{
    float *out = a->out[MIX_OUT_VECTOR];
    if (!out)
        return;
    const int n = a->n;
    const float *x = a->in[MIX_IN_A_VECTOR], *y = a->in[MIX_IN_B_VECTOR];
    for (int c = 0; c < 3; c++) {
        /* A uniform factor is one float per point; a non-uniform one has a component per
         * axis. Either way the arithmetic is per component. */
        const float *fac = non_uniform ? a->in[MIX_IN_FACTOR_VECTOR] + (size_t)c * (size_t)n
                                       : a->in[MIX_IN_FACTOR_FLOAT];
        const float *xc = x + (size_t)c * (size_t)n, *yc = y + (size_t)c * (size_t)n;
        float *oc = out + (size_t)c * (size_t)n;
        for (int i = 0; i < n; i++) {
            float t = clamp_factor ? saturatef(fac[i]) : fac[i];
            oc[i] = xc[i] * (1.0f - t) + yc[i] * t;
        }
    }
}

static void mix_color(const sg_kernel_args *a, int blend, bool clamp_factor, bool clamp_result)
{
    float *out = a->out[MIX_OUT_COLOR];
    if (out)
        blend_batch(blend, a->n, a->in[MIX_IN_FACTOR_FLOAT], clamp_factor,
                    a->in[MIX_IN_A_COLOR], a->in[MIX_IN_B_COLOR], clamp_result, out);
}

static void mix_kernel(const sg_kernel_args *a)
{
    const bool clamp_factor = a->prop[MIX_PROP_CLAMP_FACTOR] != 0;
    switch (a->prop[MIX_PROP_DATA_TYPE]) {
    case DATA_FLOAT:
        mix_float(a, clamp_factor);
        break;
    case DATA_VECTOR:
        mix_vector(a, clamp_factor, a->prop[MIX_PROP_FACTOR_MODE] == FACTOR_NON_UNIFORM);
        break;
    default:
        mix_color(a, a->prop[MIX_PROP_BLEND_TYPE], clamp_factor,
                  a->prop[MIX_PROP_CLAMP_RESULT] != 0);
        break;
    }
}

#define DATA_BIT(d) (1u << (d))

/* Blender shows the sockets of the current data_type only. Factor_Float also disappears
 * for VECTOR with NON_UNIFORM factors; one mask per property cannot say "unless both",
 * so Factor_Float is declared always available (a link to it there is accepted, and
 * ignored, where Blender would refuse it). */
static const sg_socket_def mix_inputs[] = {
    {"Factor_Float", "Factor", SG_SOCKET_FLOAT, {0.5f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Factor_Vector", "Factor", SG_SOCKET_VECTOR, {0.5f, 0.5f, 0.5f}, SG_IMPLICIT_NONE,
     DATA_BIT(DATA_VECTOR), MIX_PROP_DATA_TYPE, 1u << FACTOR_NON_UNIFORM, MIX_PROP_FACTOR_MODE},
    {"A_Float", "A", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, DATA_BIT(DATA_FLOAT),
     MIX_PROP_DATA_TYPE, 0, 0},
    {"B_Float", "B", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, DATA_BIT(DATA_FLOAT),
     MIX_PROP_DATA_TYPE, 0, 0},
    {"A_Vector", "A", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE,
     DATA_BIT(DATA_VECTOR), MIX_PROP_DATA_TYPE, 0, 0},
    {"B_Vector", "B", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE,
     DATA_BIT(DATA_VECTOR), MIX_PROP_DATA_TYPE, 0, 0},
    {"A_Color", "A", SG_SOCKET_COLOR, {0.5f, 0.5f, 0.5f, 1.0f}, SG_IMPLICIT_NONE,
     DATA_BIT(DATA_RGBA), MIX_PROP_DATA_TYPE, 0, 0},
    {"B_Color", "B", SG_SOCKET_COLOR, {0.5f, 0.5f, 0.5f, 1.0f}, SG_IMPLICIT_NONE,
     DATA_BIT(DATA_RGBA), MIX_PROP_DATA_TYPE, 0, 0},
};
static const sg_socket_def mix_outputs[] = {
    {"Result_Float", "Result", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, DATA_BIT(DATA_FLOAT),
     MIX_PROP_DATA_TYPE, 0, 0},
    {"Result_Vector", "Result", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE,
     DATA_BIT(DATA_VECTOR), MIX_PROP_DATA_TYPE, 0, 0},
    {"Result_Color", "Result", SG_SOCKET_COLOR, {0.8f, 0.8f, 0.8f, 1.0f}, SG_IMPLICIT_NONE,
     DATA_BIT(DATA_RGBA), MIX_PROP_DATA_TYPE, 0, 0},
};
static const sg_prop_def mix_props[] = {
    {"data_type", SG_PROP_ENUM, mix_data_type_values, DATA_FLOAT},
    {"factor_mode", SG_PROP_ENUM, mix_factor_mode_values, FACTOR_UNIFORM},
    {"blend_type", SG_PROP_ENUM, blend_type_values, BLEND_MIX},
    {"clamp_factor", SG_PROP_BOOL, NULL, 1},
    {"clamp_result", SG_PROP_BOOL, NULL, 0},
};

/* Cycles' fold_mix / fold_mix_color, for Mix RGB and the colour Mix; also the blend
 * rules the 4.x vector Mix uses (as BLEND_MIX). fac0/fac1: an unlinked factor equal to
 * 0 / 1 after the factor clamp (if any). `clamp`: the result is saturated. */
static bool mix_blend_fold(sg_fold *x, int blend, int fac, int a, int b, int out, bool clamp_factor,
                           bool clamp)
{
    float fv = sg_fold_input_value(x, fac)[0];
    if (clamp_factor)
        fv = fv > 0.0f ? (fv < 1.0f ? fv : 1.0f) : 0.0f; /* NaN -> 0, as saturatef */
    bool fac0 = sg_fold_input_constant(x, fac) && fv == 0.0f;
    bool fac1 = sg_fold_input_constant(x, fac) && fv == 1.0f;
    if (fac0 && blend != BLEND_LIGHTEN && blend != BLEND_DODGE && blend != BLEND_BURN) {
        if (sg_fold_try_bypass(x, a, out, clamp))
            return true;
    }
    bool same_link = sg_fold_inputs_same_link(x, a, b);
    switch (blend) {
    case BLEND_MIX: {
        const float *va = sg_fold_input_value(x, a), *vb = sg_fold_input_value(x, b);
        if (same_link)
            return sg_fold_try_bypass(x, a, out, clamp);
        if (sg_fold_input_constant(x, a) && sg_fold_input_constant(x, b) && va[0] == vb[0] &&
            va[1] == vb[1] && va[2] == vb[2])
            return sg_fold_try_bypass(x, a, out, clamp);
        if (fac1)
            return sg_fold_try_bypass(x, b, out, clamp);
        break;
    }
    case BLEND_ADD:
        if (sg_fold_input_equals(x, a, 0.0f) && fac1)
            return sg_fold_try_bypass(x, b, out, clamp);
        if (sg_fold_input_equals(x, b, 0.0f))
            return sg_fold_try_bypass(x, a, out, clamp);
        break;
    case BLEND_SUBTRACT:
        if (sg_fold_input_equals(x, b, 0.0f))
            return sg_fold_try_bypass(x, a, out, clamp);
        if (same_link && fac1)
            return sg_fold_make_value(x, out, 0.0f);
        break;
    case BLEND_MULTIPLY:
        if (sg_fold_input_equals(x, a, 1.0f) && fac1)
            return sg_fold_try_bypass(x, b, out, clamp);
        if (sg_fold_input_equals(x, b, 1.0f))
            return sg_fold_try_bypass(x, a, out, clamp);
        if (sg_fold_input_equals(x, a, 0.0f) || (sg_fold_input_equals(x, b, 0.0f) && fac1))
            return sg_fold_make_value(x, out, 0.0f);
        break;
    case BLEND_DIVIDE:
        if (sg_fold_input_equals(x, b, 1.0f))
            return sg_fold_try_bypass(x, a, out, clamp);
        if (sg_fold_input_equals(x, a, 0.0f))
            return sg_fold_make_value(x, out, 0.0f);
        break;
    }
    return false;
}

/* Cycles' MixNode / MixColorNode / MixFloatNode / MixVectorNode::constant_fold. Blender
 * 3.x folds the float and vector Mix only when all inputs are constant. */
static bool mix_fold(sg_fold *x)
{
    const int *prop = sg_fold_props(x);
    bool clamp_factor = prop[MIX_PROP_CLAMP_FACTOR] == 1;
    const int fac = MIX_IN_FACTOR_FLOAT;
    if (prop[MIX_PROP_DATA_TYPE] == DATA_RGBA)
        return mix_blend_fold(x, prop[MIX_PROP_BLEND_TYPE], fac, MIX_IN_A_COLOR, MIX_IN_B_COLOR,
                              MIX_OUT_COLOR, clamp_factor, prop[MIX_PROP_CLAMP_RESULT] == 1);
    if (sg_fold_mode(x) == SG_BLENDER_3)
        return false;
    if (prop[MIX_PROP_DATA_TYPE] == DATA_VECTOR) {
        if (prop[MIX_PROP_FACTOR_MODE] == FACTOR_NON_UNIFORM)
            return false;
        return mix_blend_fold(x, BLEND_MIX, fac, MIX_IN_A_VECTOR, MIX_IN_B_VECTOR, MIX_OUT_VECTOR,
                              clamp_factor, false);
    }
    /* FLOAT: factor 0 -> A; A, B the same link or equal constants -> A; factor 1 -> B. */
    const int a = MIX_IN_A_FLOAT, b = MIX_IN_B_FLOAT, out = MIX_OUT_FLOAT;
    float fv = sg_fold_input_value(x, fac)[0];
    if (clamp_factor)
        fv = fv > 0.0f ? (fv < 1.0f ? fv : 1.0f) : 0.0f;
    bool fac_const = sg_fold_input_constant(x, fac);
    if (fac_const && fv == 0.0f)
        return sg_fold_try_bypass(x, a, out, false);
    if (sg_fold_inputs_same_link(x, a, b))
        return sg_fold_try_bypass(x, a, out, false);
    if (sg_fold_input_constant(x, a) && sg_fold_input_constant(x, b) &&
        sg_fold_input_value(x, a)[0] == sg_fold_input_value(x, b)[0])
        return sg_fold_try_bypass(x, a, out, false);
    if (fac_const && fv == 1.0f)
        return sg_fold_try_bypass(x, b, out, false);
    return false;
}

const sg_node_type node_type_mix = {
    "ShaderNodeMix",
    mix_inputs,  SG_COUNT(mix_inputs),
    mix_outputs, SG_COUNT(mix_outputs),
    mix_props,   SG_COUNT(mix_props),
    mix_kernel,  SG_NODE_FOLD_CONSTANT,
    mix_fold,
};

/* ---- MixRGB (legacy ShaderNodeMixRGB) --------------------------------------------- */

/* Cycles always clamps this node's factor to [0, 1] (svm_mix_clamped_factor); use_clamp
 * clamps the result. use_alpha is a compositor option that Cycles ignores. */
static void mix_rgb_kernel(const sg_kernel_args *a)
{
    if (a->out[0])
        blend_batch(a->prop[0], a->n, a->in[0], true, a->in[1], a->in[2], a->prop[2] != 0,
                    a->out[0]);
}

static const sg_socket_def mix_rgb_inputs[] = {
    {"Fac", "Fac", SG_SOCKET_FLOAT, {0.5f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Color1", "Color1", SG_SOCKET_COLOR, {0.5f, 0.5f, 0.5f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Color2", "Color2", SG_SOCKET_COLOR, {0.5f, 0.5f, 0.5f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};
static const sg_socket_def mix_rgb_outputs[] = {
    {"Color", "Color", SG_SOCKET_COLOR, {0.8f, 0.8f, 0.8f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};
static const sg_prop_def mix_rgb_props[] = {
    {"blend_type", SG_PROP_ENUM, blend_type_values, BLEND_MIX},
    {"use_alpha", SG_PROP_BOOL, NULL, 0},
    {"use_clamp", SG_PROP_BOOL, NULL, 0},
};

static bool mix_rgb_fold(sg_fold *x)
{
    const int *prop = sg_fold_props(x);
    return mix_blend_fold(x, prop[0], 0, 1, 2, 0, true, prop[2] == 1);
}

const sg_node_type node_type_mix_rgb = {
    "ShaderNodeMixRGB",
    mix_rgb_inputs,  SG_COUNT(mix_rgb_inputs),
    mix_rgb_outputs, SG_COUNT(mix_rgb_outputs),
    mix_rgb_props,   SG_COUNT(mix_rgb_props),
    mix_rgb_kernel,  SG_NODE_FOLD_CONSTANT,
    mix_rgb_fold,
};

/* ---- Invert ----------------------------------------------------------------------- */

/* Cycles' kernel computes fac * (1 - c) + (1 - fac) * c, but its host fold computes
 * interp(c, 1 - c, fac) = c + fac * ((1 - c) - c): the last bit can differ. */
static void invert_kernel(const sg_kernel_args *a)
{
    float *out = a->out[0];
    if (!out)
        return;
    const int n = a->n;
    const float *fac = a->in[0];
    for (int c = 0; c < 3; c++) {
        const float *col = a->in[1] + (size_t)c * (size_t)n;
        float *o = out + (size_t)c * (size_t)n;
        if (a->host_fold)
            for (int i = 0; i < n; i++)
                o[i] = col[i] + fac[i] * ((1.0f - col[i]) - col[i]);
        else
            for (int i = 0; i < n; i++)
                o[i] = fac[i] * (1.0f - col[i]) + (1.0f - fac[i]) * col[i];
    }
}

/* Cycles' InvertNode::constant_fold: factor 0 -> the colour. */
static bool invert_fold(sg_fold *x)
{
    if (sg_fold_input_constant(x, 0) && sg_fold_input_value(x, 0)[0] == 0.0f)
        return sg_fold_try_bypass(x, 1, 0, false);
    return false;
}

static const sg_socket_def invert_inputs[] = {
    {"Fac", "Fac", SG_SOCKET_FLOAT, {1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Color", "Color", SG_SOCKET_COLOR, {0.0f, 0.0f, 0.0f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};
static const sg_socket_def invert_outputs[] = {
    {"Color", "Color", SG_SOCKET_COLOR, {0.8f, 0.8f, 0.8f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

const sg_node_type node_type_invert = {
    "ShaderNodeInvert",
    invert_inputs,  SG_COUNT(invert_inputs),
    invert_outputs, SG_COUNT(invert_outputs),
    NULL,           0,
    invert_kernel,  SG_NODE_FOLD_CONSTANT,
    invert_fold,
};

/* ---- Color Ramp ------------------------------------------------------------------- */

/* Index order of sg_ramp_interpolations / _color_modes / _hue_interpolations. */
enum { RAMP_EASE, RAMP_CARDINAL, RAMP_LINEAR, RAMP_B_SPLINE, RAMP_CONSTANT };
enum { RAMP_RGB, RAMP_HSV, RAMP_HSL };
enum { HUE_NEAR, HUE_FAR, HUE_CW, HUE_CCW };

/* Entries of the table Blender hands to Cycles, at most. */
#define RAMP_TABLE_MAX SG_RAMP_TABLE_MAX

/* Blender's BLI colour conversions (not Cycles'): the ramp is sampled on Blender's side. */
static void bli_rgb_to_hsv(const float rgb[3], float hsv[3])
{
    float r = rgb[0], g = rgb[1], b = rgb[2];
    float k = 0.0f;
    if (g < b) {
        float s = g;
        g = b;
        b = s;
        k = -1.0f;
    }
    float min_gb = b;
    if (r < g) {
        float s = r;
        r = g;
        g = s;
        k = -2.0f / 6.0f - k;
        min_gb = fminf(g, b);
    }
    float chroma = r - min_gb;
    hsv[0] = fabsf(k + (g - b) / (6.0f * chroma + 1e-20f));
    hsv[1] = chroma / (r + 1e-20f);
    hsv[2] = r;
}

static void bli_rgb_to_hsl(const float rgb[3], float hsl[3])
{
    float r = rgb[0], g = rgb[1], b = rgb[2];
    float cmax = fmaxf(fmaxf(r, g), b);
    float cmin = fminf(fminf(r, g), b);
    float h = 0.0f, s = 0.0f, l = fminf(1.0f, (cmax + cmin) / 2.0f);
    if (cmax != cmin) {
        float d = cmax - cmin;
        s = l > 0.5f ? d / (2.0f - cmax - cmin) : d / (cmax + cmin);
        if (cmax == r)
            h = (g - b) / d + (g < b ? 6.0f : 0.0f);
        else if (cmax == g)
            h = (b - r) / d + 2.0f;
        else
            h = (r - g) / d + 4.0f;
    }
    hsl[0] = h / 6.0f;
    hsl[1] = s;
    hsl[2] = l;
}

/* The three "sextant ramps" both of BLI's hue-to-rgb conversions start from. */
static void bli_hue_ramps(float h, float n[3])
{
    n[0] = fminf(fmaxf(fabsf(h * 6.0f - 3.0f) - 1.0f, 0.0f), 1.0f);
    n[1] = fminf(fmaxf(2.0f - fabsf(h * 6.0f - 2.0f), 0.0f), 1.0f);
    n[2] = fminf(fmaxf(2.0f - fabsf(h * 6.0f - 4.0f), 0.0f), 1.0f);
}

static void bli_hsv_to_rgb(const float hsv[3], float rgb[3])
{
    float n[3];
    bli_hue_ramps(hsv[0], n);
    for (int c = 0; c < 3; c++)
        rgb[c] = ((n[c] - 1.0f) * hsv[1] + 1.0f) * hsv[2];
}

static void bli_hsl_to_rgb(const float hsl[3], float rgb[3])
{
    float n[3];
    bli_hue_ramps(hsl[0], n);
    float chroma = (1.0f - fabsf(2.0f * hsl[2] - 1.0f)) * hsl[1];
    for (int c = 0; c < 3; c++)
        rgb[c] = (n[c] - 0.5f) * chroma + hsl[2];
}

/* Hue blend between two stops: weight `fac` on h2, `mfac` on h1, going round the hue
 * circle the way the ramp's hue_interpolation asks (Blender's colorband_hue_interp). */
static float ramp_hue_interp(int mode, float mfac, float fac, float h1, float h2)
{
    h1 = h1 < 1.0f ? h1 : h1 - 1.0f;
    h2 = h2 < 1.0f ? h2 : h2 - 1.0f;
    int wrap = 0; /* 0: straight; 1: h1 + 1; 2: h2 + 1 */
    switch (mode) {
    case HUE_NEAR:
        if (h1 < h2 && h2 - h1 > 0.5f)
            wrap = 1;
        else if (h1 > h2 && h2 - h1 < -0.5f)
            wrap = 2;
        break;
    case HUE_FAR:
        /* Equal hues go once round the circle. */
        if (h1 == h2)
            wrap = 1;
        else if (h1 < h2 && h2 - h1 < 0.5f)
            wrap = 1;
        else if (h1 > h2 && h2 - h1 > -0.5f)
            wrap = 2;
        break;
    case HUE_CCW:
        if (h1 > h2)
            wrap = 2;
        break;
    case HUE_CW:
        if (h1 < h2)
            wrap = 1;
        break;
    default:
        break;
    }
    float h;
    if (wrap == 1)
        h = mfac * (h1 + 1.0f) + fac * h2;
    else if (wrap == 2)
        h = mfac * h1 + fac * (h2 + 1.0f);
    else
        return mfac * h1 + fac * h2;
    return h < 1.0f ? h : h - 1.0f;
}

/* Blender's cubic weights for the four stops around a span (key_curve_position_weights):
 * w[0] for the stop after the right one, w[1] right, w[2] left, w[3] the one before. */
static void ramp_cubic_weights(float t, bool cardinal, float w[4])
{
    float t2 = t * t, t3 = t2 * t;
    if (cardinal) {
        const float fc = 0.71f;
        w[0] = -fc * t3 + 2.0f * fc * t2 - fc * t;
        w[1] = (2.0f - fc) * t3 + (fc - 3.0f) * t2 + 1.0f;
        w[2] = (fc - 2.0f) * t3 + (3.0f - 2.0f * fc) * t2 + fc * t;
        w[3] = fc * t3 - fc * t2;
    } else {
        w[0] = -0.16666666f * t3 + 0.5f * t2 - 0.5f * t + 0.16666666f;
        w[1] = 0.5f * t3 - t2 + 0.66666666f;
        w[2] = -0.5f * t3 + 0.5f * t2 + 0.5f * t + 0.16666666f;
        w[3] = 0.16666666f * t3;
    }
}

static void copy4(float dst[4], const float src[4])
{
    for (int c = 0; c < 4; c++)
        dst[c] = src[c];
}

/*
 * The ramp's RGBA at `in`, as Blender's BKE_colorband_evaluate computes it, given
 * a = ramp_span(ramp, in, 0). The stops are sorted by position. Notes on what it does, since it is not what one would guess:
 *  - HSV and HSL ramps ignore the interpolation setting and blend linearly (only the hue
 *    path is configurable); but the Cycles lookup still treats CONSTANT as "do not
 *    interpolate the table".
 *  - the search finds the first stop strictly right of `in`: `right` is that stop and
 *    `left` the one before. Past the last stop a copy of it at position 1 plays `right`;
 *    before the first, a copy at position 0 plays `left`. Coincident stops make a step.
 *  - `fac` is the weight of the LEFT stop: (in - right.pos) / (left.pos - right.pos).
 *  - CARDINAL and B_SPLINE reach one stop further on each side (repeating the end stops)
 *    and clamp the result to [0, 1].
 */
/* Index of the first stop strictly right of `in`, searching from `from` (a lower bound:
 * for increasing `in` the index never decreases, which the table bake exploits). */
static int ramp_span(const sg_color_ramp *ramp, float in, int from)
{
    int a = from;
    while (a < ramp->n && !(ramp->position[a] > in))
        a++;
    return a;
}

static void ramp_evaluate(const sg_color_ramp *ramp, float in, int a, float out[4])
{
    const int n = ramp->n;
    if (n <= 0) {
        out[0] = out[1] = out[2] = out[3] = 0.0f;
        return;
    }
    const int ipo = ramp->color_mode == RAMP_RGB ? ramp->interpolation : RAMP_LINEAR;
    const bool clamps_at_ends = ipo == RAMP_LINEAR || ipo == RAMP_EASE || ipo == RAMP_CONSTANT;

    if (n == 1 || (in <= ramp->position[0] && clamps_at_ends)) {
        copy4(out, ramp->color[0]);
        return;
    }

    /* right/left as position + colour; the end copies are local. */
    float right_pos, left_pos;
    const float *right, *left;
    if (a == n) {
        left = ramp->color[n - 1];
        left_pos = ramp->position[n - 1];
        right = left;
        right_pos = 1.0f;
        if (clamps_at_ends) {
            copy4(out, left);
            return;
        }
    } else if (a == 0) {
        right = ramp->color[0];
        right_pos = ramp->position[0];
        left = right;
        left_pos = 0.0f;
    } else {
        right = ramp->color[a];
        right_pos = ramp->position[a];
        left = ramp->color[a - 1];
        left_pos = ramp->position[a - 1];
    }

    if (ipo == RAMP_CONSTANT) {
        copy4(out, left);
        return;
    }

    float fac;
    if (left_pos != right_pos)
        fac = (in - right_pos) / (left_pos - right_pos);
    else
        fac = (a != n) ? 0.0f : 1.0f;

    if (ipo == RAMP_B_SPLINE || ipo == RAMP_CARDINAL) {
        const float *next = (a >= n - 1) ? right : ramp->color[a + 1];
        const float *prev = (a < 2) ? left : ramp->color[a - 2];
        float w[4];
        fac = fminf(fmaxf(fac, 0.0f), 1.0f);
        ramp_cubic_weights(fac, ipo == RAMP_CARDINAL, w);
        for (int c = 0; c < 4; c++) {
            float v = w[3] * prev[c] + w[2] * left[c] + w[1] * right[c] + w[0] * next[c];
            out[c] = fminf(fmaxf(v, 0.0f), 1.0f);
        }
        return;
    }

    if (ipo == RAMP_EASE) {
        float fac2 = fac * fac;
        fac = 3.0f * fac2 - 2.0f * fac2 * fac;
    }
    const float mfac = 1.0f - fac;

    if (ramp->color_mode == RAMP_HSV || ramp->color_mode == RAMP_HSL) {
        float c1[3], c2[3], mixed[3];
        if (ramp->color_mode == RAMP_HSV) {
            bli_rgb_to_hsv(right, c1);
            bli_rgb_to_hsv(left, c2);
        } else {
            bli_rgb_to_hsl(right, c1);
            bli_rgb_to_hsl(left, c2);
        }
        mixed[0] = ramp_hue_interp(ramp->hue_interpolation, mfac, fac, c1[0], c2[0]);
        mixed[1] = mfac * c1[1] + fac * c2[1];
        mixed[2] = mfac * c1[2] + fac * c2[2];
        out[3] = mfac * right[3] + fac * left[3];
        if (ramp->color_mode == RAMP_HSV)
            bli_hsv_to_rgb(mixed, out);
        else
            bli_hsl_to_rgb(mixed, out);
        return;
    }
    for (int c = 0; c < 4; c++)
        out[c] = mfac * right[c] + fac * left[c];
}

/* Cycles' rgb_ramp_lookup on a table of `size` RGBA entries spanning [0, 1]. */
static void ramp_lookup(const float (*table)[4], int size, bool interpolate, float f,
                        float out[4])
{
    f = saturatef(f) * (float)(size - 1);
    int i = (int)f;
    /* NaN: the conversion above is undefined behaviour in C, so test first. */
    if (!(f >= 0.0f))
        i = 0;
    if (i > size - 1)
        i = size - 1;
    float t = f - (float)i;
    copy4(out, table[i]);
    if (interpolate && t > 0.0f)
        for (int c = 0; c < 4; c++)
            out[c] = (1.0f - t) * out[c] + t * table[i + 1][c];
}

void sg_color_ramp_bake(sg_color_ramp *r, sg_blender_mode mode)
{
    /* Blender stores a stop's RGBA clamped below at 0 (RNA range [0, inf)): a negative
     * channel written in the JSON is 0 in Blender's ramp. Above 1 is kept. */
    sg_color_ramp ramp = *r;
    for (int s = 0; s < ramp.n && s < SG_RAMP_MAX_ELEMENTS; s++)
        for (int ch = 0; ch < 4; ch++)
            ramp.color[s][ch] = fmaxf(ramp.color[s][ch], 0.0f);

    /* Blender 3.x: 256 entries at i / 255; 4.x: 257 at i / 256. */
    const int steps = mode == SG_BLENDER_3 ? 255 : 256;
    for (int i = 0, span = 0; i <= steps; i++) {
        float x = (float)i / (float)steps;
        span = ramp_span(&ramp, x, span);
        ramp_evaluate(&ramp, x, span, r->baked[i]);
    }
    r->baked_steps = steps;
}

static void color_ramp_kernel(const sg_kernel_args *a)
{
    float *color = a->out[0], *alpha = a->out[1];
    const int n = a->n;
    if (!color && !alpha)
        return;

    /* Compiled programs carry the baked table; bake here only for a ramp that was not
     * (a kernel called directly, as the unit tests do). */
    const int steps = a->blender == SG_BLENDER_3 ? 255 : 256;
    const sg_color_ramp *ramp = a->ramp;
    sg_color_ramp local;
    if (ramp->baked_steps != steps) {
        local = *ramp;
        sg_color_ramp_bake(&local, a->blender);
        ramp = &local;
    }
    const float(*table)[4] = (const float(*)[4])ramp->baked;
    const bool interpolate = ramp->interpolation != RAMP_CONSTANT;

    const float *fac = a->in[0];
    for (int i = 0; i < n; i++) {
        float rgba[4];
        ramp_lookup(table, steps + 1, interpolate, fac[i], rgba);
        if (color)
            f3_store(color, n, i, make_float3(rgba[0], rgba[1], rgba[2]));
        if (alpha)
            alpha[i] = rgba[3];
    }
}

static const sg_socket_def color_ramp_inputs[] = {
    {"Fac", "Fac", SG_SOCKET_FLOAT, {0.5f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};
static const sg_socket_def color_ramp_outputs[] = {
    {"Color", "Color", SG_SOCKET_COLOR, {0.8f, 0.8f, 0.8f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Alpha", "Alpha", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};
static const sg_prop_def color_ramp_props[] = {
    {"color_ramp", SG_PROP_COLOR_RAMP, NULL, 0},
};

const sg_node_type node_type_color_ramp = {
    "ShaderNodeValToRGB",
    color_ramp_inputs,  SG_COUNT(color_ramp_inputs),
    color_ramp_outputs, SG_COUNT(color_ramp_outputs),
    color_ramp_props,   SG_COUNT(color_ramp_props),
    color_ramp_kernel,  SG_NODE_FOLD_CONSTANT,
};

/* ---- RGB and Value ---------------------------------------------------------------- */

/* These hold their value on the output socket ("outputs" in the JSON). Flattening
 * (flatten.c, SG_ROLE_CONSTANT) turns them into constants on the inputs they feed; the
 * kernels below would only run if it did not, and then could only give Blender's
 * default value (grey 0.5 / 0). */
static void rgb_kernel(const sg_kernel_args *a)
{
    if (a->out[0])
        for (int i = 0; i < 3 * a->n; i++)
            a->out[0][i] = 0.5f;
}

static void value_kernel(const sg_kernel_args *a)
{
    if (a->out[0])
        for (int i = 0; i < a->n; i++)
            a->out[0][i] = 0.0f;
}

static const sg_socket_def rgb_outputs[] = {
    {"Color", "Color", SG_SOCKET_COLOR, {0.5f, 0.5f, 0.5f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

const sg_node_type node_type_rgb = {
    "ShaderNodeRGB", NULL, 0, rgb_outputs, SG_COUNT(rgb_outputs), NULL, 0, rgb_kernel, 0,
    .role = SG_ROLE_CONSTANT,
};

static const sg_socket_def value_outputs[] = {
    {"Value", "Value", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

const sg_node_type node_type_value = {
    "ShaderNodeValue", NULL, 0, value_outputs, SG_COUNT(value_outputs), NULL, 0, value_kernel, 0,
    .role = SG_ROLE_CONSTANT,
};
