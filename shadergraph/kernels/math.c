/*
 * Math, Vector Math, Clamp and Map Range, as Cycles evaluates them.
 *
 * Sources of truth: Cycles' kernel/svm/math.h, math_util.h, clamp.h and map_range.h and
 * the safe_* helpers of util/math*.h, in Blender 4.3 for the default mode and 3.4 for
 * SG_BLENDER_3. The two differ only in Vector Math REFLECT and REFRACT (3.4 normalizes
 * the normal with a plain division, NaN for a zero normal; 4.3 uses safe_normalize),
 * in ARCTAN2 (4.3 returns 0 for atan2(+-0, +-0) whatever the signs) and in Math
 * FLOORED_MODULO, which 3.4 does not have (it is computed the 4.3 way in both modes).
 *
 * The "safe" conventions are Cycles': division, modulo, snap and ping-pong by zero give
 * 0; POWER of a negative base to a non-integer exponent gives 0; LOGARITHM of a
 * non-positive argument or base gives 0; SQRT and INVERSE_SQRT of a non-positive value
 * give 0; ARCSINE and ARCCOSINE clamp their argument to [-1, 1]. Cycles' min/max are
 * `a < b ? a : b` (not fminf), so a NaN fed to a clamp comes out as the clamp's lower
 * bound; the Math node's MINIMUM/MAXIMUM do use fminf/fmaxf.
 *
 * Bit-closeness: Blender's x86-64 builds run Cycles' AVX2 kernel, compiled by GCC with
 * FMA and -ffp-contract=fast, so a product that feeds an addition or subtraction
 * directly is fused there (this includes float3 operators, which are plain SSE vector
 * arithmetic). This project compiles with -ffp-contract=off, so those fusions are
 * written out with fmaf() (madd/nmadd below) exactly where that kernel has them; all
 * other arithmetic is plain float in Cycles' order. Dot products and lengths use
 * _mm_dp_ps there, which rounds each product and sums (x + y) + z: no fusion. Where
 * two products meet in one subtraction (REFRACT's eta*I - s*N) GCC fuses the second;
 * inlining makes Map Range's reversed-range `1 - smoothstep(...)` one fused operation.
 * Both were settled by measurement. With these, every reference case and a stress
 * sweep over +-1.37 * 2^k (k in [-64, 63]) through every operation is bit-identical to
 * Blender 3.4; Blender 4.3 differs only where its glibc (2.41) rounds a transcendental
 * function differently from ours.
 *
 * Non-finite results are returned as computed (Cycles' film later writes 0 for any
 * non-finite sample component; the reference comparison accounts for that). Cycles'
 * compile-time folds (scene/constant_fold.cpp), which turn x * 0 and 0 / x with a
 * constant 0 into 0 even when x is inf or NaN at run time, are math_fold and
 * vector_math_fold below; the kernels themselves never see them.
 */
#include <float.h>
#include <math.h>
#include <stdint.h>

#include "shadergraph/fold.h"
#include "shadergraph/kernels/kernel_util.h"
#include "shadergraph/node_type.h"

/* ---- float helpers with Cycles' rounding and NaN behaviour ------------------------ */

#define PI_F 3.14159265358979323846f /* Cycles' M_PI_F */

/* madd(a, b, c) (kernel_math.h): a * b + c where the AVX2 kernel fuses it.
 * nmadd: c - a * b, fused (GCC's fnmadd). */
static inline float nmadd(float a, float b, float c) { return fmaf(-a, b, c); }

/* The same, fused only when `fused`: Cycles evaluates Math and Vector Math on the
 * render kernel (fused) but constant-folds them on the host CPU, whose code has no
 * FMA (sg_kernel_args.host_fold). Map Range is never folded and always fuses. */
static inline float madd_f(bool fused, float a, float b, float c)
{
    return fused ? fmaf(a, b, c) : a * b + c;
}
static inline float nmadd_f(bool fused, float a, float b, float c)
{
    return fused ? fmaf(-a, b, c) : c - a * b;
}

/* What (float)(int)b gives on x86: cvttss2si returns INT32_MIN for NaN and for
 * anything outside the int32 range (C leaves that undefined, so spell it out). */
static inline float float_to_int_to_float(float b)
{
    return (b >= -2147483648.0f && b < 2147483648.0f) ? (float)(int32_t)b : -2147483648.0f;
}

static inline float safe_powf(float a, float b)
{
    if (a < 0.0f && b != float_to_int_to_float(b))
        return 0.0f;
    return powf(a, b);
}

/* Cycles' min/max/clamp (minf, maxf, clampf), safe_divide, safe_sqrtf and fractf are
 * shadergraph/kernel_math.h's. */

static inline float safe_logf(float a, float b)
{
    if (a <= 0.0f || b <= 0.0f)
        return 0.0f;
    return safe_divide(logf(a), logf(b));
}

static inline float inverse_sqrtf(float a) { return a > 0.0f ? 1.0f / sqrtf(a) : 0.0f; }
static inline float safe_asinf(float a) { return asinf(clampf(a, -1.0f, 1.0f)); }
static inline float safe_acosf(float a) { return acosf(clampf(a, -1.0f, 1.0f)); }
static inline float safe_modulo(float a, float b) { return b != 0.0f ? fmodf(a, b) : 0.0f; }

static inline float safe_floored_modulo(bool fused, float a, float b)
{
    return b != 0.0f ? nmadd_f(fused, floorf(a / b), b, a) : 0.0f;
}

/* wrapf(fused, value, max, min): value wrapped into [min, max). */
static inline float wrapf(bool fused, float value, float hi, float lo)
{
    float range = hi - lo;
    return range != 0.0f ? nmadd_f(fused, range, floorf((value - lo) / range), value) : lo;
}

static inline float pingpongf(bool fused, float a, float b)
{
    /* (fract * b) * 2 - b: the last product feeds the subtraction and is fused. */
    return b != 0.0f ? fabsf(madd_f(fused, fractf((a - b) / (b * 2.0f)) * b, 2.0f, -b)) : 0.0f;
}

static inline float smoothminf(bool fused, float a, float b, float k)
{
    if (k != 0.0f) {
        float h = fmaxf(k - fabsf(a - b), 0.0f) / k;
        return nmadd_f(fused, h * h * h * k, 1.0f / 6.0f, fminf(a, b));
    }
    return fminf(a, b);
}

static inline float signum(float a)
{
    if (a == 0.0f)
        return 0.0f;
    return a < 0.0f ? -1.0f : 1.0f;
}

static inline float truncate_toward_zero(float a) { return a >= 0.0f ? floorf(a) : ceilf(a); }

static inline float compare(float a, float b, float epsilon)
{
    return (a == b || fabsf(a - b) <= fmaxf(epsilon, FLT_EPSILON)) ? 1.0f : 0.0f;
}

/* 4.3's compatible_atan2: 0 at the origin whatever the zeros' signs. */
static inline float atan2_4(float y, float x) { return (x == 0.0f && y == 0.0f) ? 0.0f : atan2f(y, x); }

/* ---- float3 helpers (f3_dot, f3_length, normalize, safe_normalize: kernel_math.h) ---- */

/* Cycles' SSE cross: msub(a, b.yzx, a.yzx * b), shuffled; msub is an FMA on AVX2. */
static inline float3 cross3(bool fused, float3 a, float3 b)
{
    return make_float3(madd_f(fused, a.y, b.z, -(a.z * b.y)), madd_f(fused, a.z, b.x, -(a.x * b.z)),
                       madd_f(fused, a.x, b.y, -(a.y * b.x)));
}

static inline float3 reflect3(bool fused, float3 incident, float3 unit_normal)
{
    float d = f3_dot(incident, unit_normal);
    float3 n2 = f3_scale(unit_normal, 2.0f);
    return make_float3(nmadd_f(fused, n2.x, d, incident.x), nmadd_f(fused, n2.y, d, incident.y),
                       nmadd_f(fused, n2.z, d, incident.z));
}

static inline float3 refract3(bool fused, float3 incident, float3 normal, float eta)
{
    float d = f3_dot(normal, incident);
    float k = nmadd_f(fused, eta * eta, nmadd_f(fused, d, d, 1.0f), 1.0f);
    if (k < 0.0f)
        return make_float3(0.0f, 0.0f, 0.0f);
    float s = madd_f(fused, eta, d, sqrtf(k));
    return make_float3(nmadd_f(fused, s, normal.x, eta * incident.x), nmadd_f(fused, s, normal.y, eta * incident.y),
                       nmadd_f(fused, s, normal.z, eta * incident.z));
}

static inline float3 project3(float3 v, float3 onto)
{
    float len_squared = f3_dot(onto, onto);
    return len_squared != 0.0f ? f3_scale(onto, f3_dot(v, onto) / len_squared)
                               : make_float3(0.0f, 0.0f, 0.0f);
}

/* ==== Math ========================================================================= */

/* Blender's RNA order of ShaderNodeMath.operation (4.3; 3.4 lacks FLOORED_MODULO). */
static const char *const math_operation_values[] = {
    "ADD",        "SUBTRACT",     "MULTIPLY",       "DIVIDE",  "MULTIPLY_ADD", "POWER",
    "LOGARITHM",  "SQRT",         "INVERSE_SQRT",   "ABSOLUTE", "EXPONENT",    "MINIMUM",
    "MAXIMUM",    "LESS_THAN",    "GREATER_THAN",   "SIGN",    "COMPARE",      "SMOOTH_MIN",
    "SMOOTH_MAX", "ROUND",        "FLOOR",          "CEIL",    "TRUNC",        "FRACT",
    "MODULO",     "FLOORED_MODULO", "WRAP",         "SNAP",    "PINGPONG",     "SINE",
    "COSINE",     "TANGENT",      "ARCSINE",        "ARCCOSINE", "ARCTANGENT", "ARCTAN2",
    "SINH",       "COSH",         "TANH",           "RADIANS", "DEGREES",      NULL};
enum {
    M_ADD, M_SUBTRACT, M_MULTIPLY, M_DIVIDE, M_MULTIPLY_ADD, M_POWER,
    M_LOGARITHM, M_SQRT, M_INVERSE_SQRT, M_ABSOLUTE, M_EXPONENT, M_MINIMUM,
    M_MAXIMUM, M_LESS_THAN, M_GREATER_THAN, M_SIGN, M_COMPARE, M_SMOOTH_MIN,
    M_SMOOTH_MAX, M_ROUND, M_FLOOR, M_CEIL, M_TRUNC, M_FRACT,
    M_MODULO, M_FLOORED_MODULO, M_WRAP, M_SNAP, M_PINGPONG, M_SINE,
    M_COSINE, M_TANGENT, M_ARCSINE, M_ARCCOSINE, M_ARCTANGENT, M_ARCTAN2,
    M_SINH, M_COSH, M_TANH, M_RADIANS, M_DEGREES
};
#define OP(x) (1ull << (x))

/* Operations with a second / third operand (Blender hides the sockets otherwise). */
#define MATH_THREE_OPERANDS                                                                \
    (OP(M_MULTIPLY_ADD) | OP(M_COMPARE) | OP(M_SMOOTH_MIN) | OP(M_SMOOTH_MAX) | OP(M_WRAP))
#define MATH_TWO_OPERANDS                                                                  \
    (MATH_THREE_OPERANDS | OP(M_ADD) | OP(M_SUBTRACT) | OP(M_MULTIPLY) | OP(M_DIVIDE) |   \
     OP(M_POWER) | OP(M_LOGARITHM) | OP(M_MINIMUM) | OP(M_MAXIMUM) | OP(M_LESS_THAN) |    \
     OP(M_GREATER_THAN) | OP(M_MODULO) | OP(M_FLOORED_MODULO) | OP(M_SNAP) |              \
     OP(M_PINGPONG) | OP(M_ARCTAN2))

enum { MATH_PROP_OPERATION, MATH_PROP_USE_CLAMP };

static const sg_socket_def math_inputs[] = {
    {"Value", "Value", SG_SOCKET_FLOAT, {0.5f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Value_001", "Value", SG_SOCKET_FLOAT, {0.5f}, SG_IMPLICIT_NONE, MATH_TWO_OPERANDS,
     MATH_PROP_OPERATION, 0, 0},
    {"Value_002", "Value", SG_SOCKET_FLOAT, {0.5f}, SG_IMPLICIT_NONE, MATH_THREE_OPERANDS,
     MATH_PROP_OPERATION, 0, 0},
};

static const sg_socket_def math_outputs[] = {
    {"Value", "Value", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

static const sg_prop_def math_props[] = {
    {"operation", SG_PROP_ENUM, math_operation_values, M_ADD},
    {"use_clamp", SG_PROP_BOOL, NULL, 0},
};

/* One loop per operation so that each vectorizes; a, b, c are the three operands. */
#define MATH_LOOP(expr)                                                                    \
    for (int i = 0; i < n; i++) {                                                          \
        float a_ = in_a[i], b_ = in_b[i], c_ = in_c[i];                                    \
        (void)b_;                                                                          \
        (void)c_;                                                                          \
        out[i] = (expr);                                                                   \
    }                                                                                      \
    break

static void math_kernel(const sg_kernel_args *a)
{
    const int n = a->n;
    const bool fused = !a->host_fold;
    const float *in_a = a->in[0], *in_b = a->in[1], *in_c = a->in[2];
    float *out = a->out[0];
    if (!out)
        return;
    const bool blender3 = a->blender == SG_BLENDER_3;

    switch (a->prop[MATH_PROP_OPERATION]) {
    case M_ADD: MATH_LOOP(a_ + b_);
    case M_SUBTRACT: MATH_LOOP(a_ - b_);
    case M_MULTIPLY: MATH_LOOP(a_ * b_);
    case M_DIVIDE: MATH_LOOP(safe_divide(a_, b_));
    case M_MULTIPLY_ADD: MATH_LOOP(madd_f(fused, a_, b_, c_));
    case M_POWER: MATH_LOOP(safe_powf(a_, b_));
    case M_LOGARITHM: MATH_LOOP(safe_logf(a_, b_));
    case M_SQRT: MATH_LOOP(safe_sqrtf(a_));
    case M_INVERSE_SQRT: MATH_LOOP(inverse_sqrtf(a_));
    case M_ABSOLUTE: MATH_LOOP(fabsf(a_));
    case M_EXPONENT: MATH_LOOP(expf(a_));
    case M_MINIMUM: MATH_LOOP(fminf(a_, b_));
    case M_MAXIMUM: MATH_LOOP(fmaxf(a_, b_));
    case M_LESS_THAN: MATH_LOOP(a_ < b_ ? 1.0f : 0.0f);
    case M_GREATER_THAN: MATH_LOOP(a_ > b_ ? 1.0f : 0.0f);
    case M_SIGN: MATH_LOOP(signum(a_));
    case M_COMPARE: MATH_LOOP(compare(a_, b_, c_));
    case M_SMOOTH_MIN: MATH_LOOP(smoothminf(fused, a_, b_, c_));
    case M_SMOOTH_MAX: MATH_LOOP(-smoothminf(fused, -a_, -b_, c_));
    case M_ROUND: MATH_LOOP(floorf(a_ + 0.5f));
    case M_FLOOR: MATH_LOOP(floorf(a_));
    case M_CEIL: MATH_LOOP(ceilf(a_));
    case M_TRUNC: MATH_LOOP(truncate_toward_zero(a_));
    case M_FRACT: MATH_LOOP(fractf(a_));
    case M_MODULO: MATH_LOOP(safe_modulo(a_, b_));
    case M_FLOORED_MODULO: MATH_LOOP(safe_floored_modulo(fused, a_, b_));
    case M_WRAP: MATH_LOOP(wrapf(fused, a_, b_, c_));
    case M_SNAP: MATH_LOOP(floorf(safe_divide(a_, b_)) * b_);
    case M_PINGPONG: MATH_LOOP(pingpongf(fused, a_, b_));
    case M_SINE: MATH_LOOP(sinf(a_));
    case M_COSINE: MATH_LOOP(cosf(a_));
    case M_TANGENT: MATH_LOOP(tanf(a_));
    case M_ARCSINE: MATH_LOOP(safe_asinf(a_));
    case M_ARCCOSINE: MATH_LOOP(safe_acosf(a_));
    case M_ARCTANGENT: MATH_LOOP(atanf(a_));
    case M_ARCTAN2:
        if (blender3) {
            MATH_LOOP(atan2f(a_, b_));
        }
        MATH_LOOP(atan2_4(a_, b_));
    case M_SINH: MATH_LOOP(sinhf(a_));
    case M_COSH: MATH_LOOP(coshf(a_));
    case M_TANH: MATH_LOOP(tanhf(a_));
    case M_RADIANS: MATH_LOOP(a_ * (PI_F / 180.0f));
    case M_DEGREES: MATH_LOOP(a_ * (180.0f / PI_F));
    default:
        for (int i = 0; i < n; i++)
            out[i] = 0.0f;
        break;
    }

    /* use_clamp: Cycles appends a Clamp node (MINMAX, 0..1); NaN becomes 0. */
    if (a->prop[MATH_PROP_USE_CLAMP])
        for (int i = 0; i < n; i++)
            out[i] = clampf(out[i], 0.0f, 1.0f);
}

#undef MATH_LOOP

/* Cycles' fold_math (MathNode::constant_fold once not every input is constant):
 * x+0, 0+x, x-0, x*1, 1*x, x/1, x^1 -> x; x*0, 0*x, 0/x -> 0; 1^x, x^0 -> 1. With
 * use_clamp, Cycles' Clamp node follows: constants are saturated, and a bypass would
 * leave clamp(x), which the node itself computes, so the node is kept instead. */
static bool math_fold(sg_fold *x)
{
    const int *prop = sg_fold_props(x);
    bool clamp = prop[MATH_PROP_USE_CLAMP] == 1;
    enum { v1 = 0, v2 = 1, out = 0 };
    switch (prop[MATH_PROP_OPERATION]) {
    case M_ADD:
        if (sg_fold_input_equals(x, v1, 0.0f))
            return !clamp && sg_fold_try_bypass(x, v2, out, false);
        if (sg_fold_input_equals(x, v2, 0.0f))
            return !clamp && sg_fold_try_bypass(x, v1, out, false);
        break;
    case M_SUBTRACT:
        if (sg_fold_input_equals(x, v2, 0.0f))
            return !clamp && sg_fold_try_bypass(x, v1, out, false);
        break;
    case M_MULTIPLY:
        if (sg_fold_input_equals(x, v1, 1.0f))
            return !clamp && sg_fold_try_bypass(x, v2, out, false);
        if (sg_fold_input_equals(x, v2, 1.0f))
            return !clamp && sg_fold_try_bypass(x, v1, out, false);
        if (sg_fold_input_equals(x, v1, 0.0f) || sg_fold_input_equals(x, v2, 0.0f))
            return sg_fold_make_value(x, out, 0.0f);
        break;
    case M_DIVIDE:
        if (sg_fold_input_equals(x, v2, 1.0f))
            return !clamp && sg_fold_try_bypass(x, v1, out, false);
        if (sg_fold_input_equals(x, v1, 0.0f))
            return sg_fold_make_value(x, out, 0.0f);
        break;
    case M_POWER:
        if (sg_fold_input_equals(x, v1, 1.0f) || sg_fold_input_equals(x, v2, 0.0f))
            return sg_fold_make_value(x, out, 1.0f);
        if (sg_fold_input_equals(x, v2, 1.0f))
            return !clamp && sg_fold_try_bypass(x, v1, out, false);
        break;
    }
    return false;
}

const sg_node_type node_type_math = {
    .idname = "ShaderNodeMath",
    .inputs = math_inputs, .n_inputs = SG_COUNT(math_inputs),
    .outputs = math_outputs, .n_outputs = SG_COUNT(math_outputs),
    .props = math_props, .n_props = SG_COUNT(math_props),
    .kernel = math_kernel,
    .flags = SG_NODE_FOLD_CONSTANT,
    .fold = math_fold,
};

/* ==== Vector Math ================================================================== */

/* Blender's RNA order of ShaderNodeVectorMath.operation (the same in 3.4 and 4.3). */
static const char *const vector_math_operation_values[] = {
    "ADD",      "SUBTRACT", "MULTIPLY", "DIVIDE",   "MULTIPLY_ADD", "CROSS_PRODUCT",
    "PROJECT",  "REFLECT",  "REFRACT",  "FACEFORWARD", "DOT_PRODUCT", "DISTANCE",
    "LENGTH",   "SCALE",    "NORMALIZE", "ABSOLUTE", "MINIMUM",     "MAXIMUM",
    "FLOOR",    "CEIL",     "FRACTION", "MODULO",   "WRAP",         "SNAP",
    "SINE",     "COSINE",   "TANGENT",  NULL};
enum {
    V_ADD, V_SUBTRACT, V_MULTIPLY, V_DIVIDE, V_MULTIPLY_ADD, V_CROSS_PRODUCT,
    V_PROJECT, V_REFLECT, V_REFRACT, V_FACEFORWARD, V_DOT_PRODUCT, V_DISTANCE,
    V_LENGTH, V_SCALE, V_NORMALIZE, V_ABSOLUTE, V_MINIMUM, V_MAXIMUM,
    V_FLOOR, V_CEIL, V_FRACTION, V_MODULO, V_WRAP, V_SNAP,
    V_SINE, V_COSINE, V_TANGENT, V_COUNT
};

#define VMATH_ALL ((1ull << V_COUNT) - 1ull)
#define VMATH_VALUE_OUT (OP(V_DOT_PRODUCT) | OP(V_DISTANCE) | OP(V_LENGTH))
#define VMATH_THREE_VECTORS (OP(V_MULTIPLY_ADD) | OP(V_FACEFORWARD) | OP(V_WRAP))
#define VMATH_ONE_VECTOR                                                                   \
    (OP(V_LENGTH) | OP(V_SCALE) | OP(V_NORMALIZE) | OP(V_ABSOLUTE) | OP(V_FLOOR) |         \
     OP(V_CEIL) | OP(V_FRACTION) | OP(V_SINE) | OP(V_COSINE) | OP(V_TANGENT))

enum { VMATH_PROP_OPERATION };

static const sg_socket_def vector_math_inputs[] = {
    {"Vector", "Vector", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Vector_001", "Vector", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE,
     VMATH_ALL & ~VMATH_ONE_VECTOR, VMATH_PROP_OPERATION, 0, 0},
    {"Vector_002", "Vector", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE,
     VMATH_THREE_VECTORS, VMATH_PROP_OPERATION, 0, 0},
    {"Scale", "Scale", SG_SOCKET_FLOAT, {1.0f}, SG_IMPLICIT_NONE, OP(V_SCALE) | OP(V_REFRACT),
     VMATH_PROP_OPERATION, 0, 0},
};

static const sg_socket_def vector_math_outputs[] = {
    {"Vector", "Vector", SG_SOCKET_VECTOR, {0.0f}, SG_IMPLICIT_NONE, VMATH_ALL & ~VMATH_VALUE_OUT,
     VMATH_PROP_OPERATION, 0, 0},
    {"Value", "Value", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, VMATH_VALUE_OUT,
     VMATH_PROP_OPERATION, 0, 0},
};

static const sg_prop_def vector_math_props[] = {
    {"operation", SG_PROP_ENUM, vector_math_operation_values, V_ADD},
};

/* Per-component float3 maps. */
static inline float3 map3(float3 a, float (*f)(float))
{
    return make_float3(f(a.x), f(a.y), f(a.z));
}

static inline float3 reflect_versioned(bool fused, float3 a, float3 b, bool blender3)
{
    return reflect3(fused, a, blender3 ? normalize(b) : safe_normalize(b));
}

static inline float3 refract_versioned(bool fused, float3 a, float3 b, float eta, bool blender3)
{
    return refract3(fused, a, blender3 ? normalize(b) : safe_normalize(b), eta);
}

/* One loop per operation, like MATH_LOOP: a_, b_, c_ are the three vectors, s_ the
 * Scale input; the statement sets v_ (Vector output) or value_ (Value output). The
 * output an operation does not produce is written as 0 (Cycles leaves it unset; Blender
 * hides it). */
#define VECTOR_LOOP(stmt)                                                                  \
    for (int i = 0; i < n; i++) {                                                          \
        const float3 a_ = f3_load(in_a, n, i), b_ = f3_load(in_b, n, i),                   \
                     c_ = f3_load(in_c, n, i);                                             \
        const float s_ = in_scale[i];                                                      \
        float3 v_ = make_float3(0.0f, 0.0f, 0.0f);                                         \
        float value_ = 0.0f;                                                               \
        (void)b_;                                                                          \
        (void)c_;                                                                          \
        (void)s_;                                                                          \
        stmt;                                                                              \
        if (out_vector)                                                                    \
            f3_store(out_vector, n, i, v_);                                                \
        if (out_value)                                                                     \
            out_value[i] = value_;                                                         \
    }                                                                                      \
    break

#define COMPONENTWISE2(f) make_float3(f(a_.x, b_.x), f(a_.y, b_.y), f(a_.z, b_.z))

static void vector_math_kernel(const sg_kernel_args *a)
{
    const int n = a->n;
    const bool fused = !a->host_fold;
    const bool blender3 = a->blender == SG_BLENDER_3;
    const float *in_a = a->in[0], *in_b = a->in[1], *in_c = a->in[2], *in_scale = a->in[3];
    float *out_vector = a->out[0], *out_value = a->out[1];

    switch (a->prop[VMATH_PROP_OPERATION]) {
    case V_ADD: VECTOR_LOOP(v_ = f3_add(a_, b_));
    case V_SUBTRACT: VECTOR_LOOP(v_ = f3_sub(a_, b_));
    case V_MULTIPLY: VECTOR_LOOP(v_ = f3_mul(a_, b_));
    case V_DIVIDE: VECTOR_LOOP(v_ = COMPONENTWISE2(safe_divide));
    case V_MULTIPLY_ADD:
        VECTOR_LOOP(v_ = make_float3(madd_f(fused, a_.x, b_.x, c_.x), madd_f(fused, a_.y, b_.y, c_.y),
                                     madd_f(fused, a_.z, b_.z, c_.z)));
    case V_CROSS_PRODUCT: VECTOR_LOOP(v_ = cross3(fused, a_, b_));
    case V_PROJECT: VECTOR_LOOP(v_ = project3(a_, b_));
    case V_REFLECT: VECTOR_LOOP(v_ = reflect_versioned(fused, a_, b_, blender3));
    case V_REFRACT: VECTOR_LOOP(v_ = refract_versioned(fused, a_, b_, s_, blender3));
    case V_FACEFORWARD: VECTOR_LOOP(v_ = f3_dot(c_, b_) < 0.0f ? a_ : f3_scale(a_, -1.0f));
    case V_DOT_PRODUCT: VECTOR_LOOP(value_ = f3_dot(a_, b_));
    case V_DISTANCE: VECTOR_LOOP(value_ = f3_length(f3_sub(a_, b_)));
    case V_LENGTH: VECTOR_LOOP(value_ = f3_length(a_));
    case V_SCALE: VECTOR_LOOP(v_ = f3_scale(a_, s_));
    case V_NORMALIZE: VECTOR_LOOP(v_ = safe_normalize(a_));
    case V_ABSOLUTE: VECTOR_LOOP(v_ = map3(a_, fabsf));
    case V_MINIMUM: VECTOR_LOOP(v_ = COMPONENTWISE2(minf));
    case V_MAXIMUM: VECTOR_LOOP(v_ = COMPONENTWISE2(maxf));
    case V_FLOOR: VECTOR_LOOP(v_ = map3(a_, floorf));
    case V_CEIL: VECTOR_LOOP(v_ = map3(a_, ceilf));
    case V_FRACTION: VECTOR_LOOP(v_ = map3(a_, fractf));
    case V_MODULO: VECTOR_LOOP(v_ = COMPONENTWISE2(safe_modulo));
    case V_WRAP:
        VECTOR_LOOP(v_ = make_float3(wrapf(fused, a_.x, b_.x, c_.x), wrapf(fused, a_.y, b_.y, c_.y),
                                     wrapf(fused, a_.z, b_.z, c_.z)));
    case V_SNAP:
        VECTOR_LOOP(v_ = make_float3(floorf(safe_divide(a_.x, b_.x)) * b_.x,
                                     floorf(safe_divide(a_.y, b_.y)) * b_.y,
                                     floorf(safe_divide(a_.z, b_.z)) * b_.z));
    case V_SINE: VECTOR_LOOP(v_ = map3(a_, sinf));
    case V_COSINE: VECTOR_LOOP(v_ = map3(a_, cosf));
    case V_TANGENT: VECTOR_LOOP(v_ = map3(a_, tanf));
    default: VECTOR_LOOP((void)a_);
    }
}

#undef VECTOR_LOOP
#undef COMPONENTWISE2

/* Cycles' fold_vector_math: the Math rules for ADD, SUBTRACT, MULTIPLY, DIVIDE (x/0 ->
 * 0 too) and SCALE; zero for DOT and CROSS with a zero operand, LENGTH and ABSOLUTE of
 * zero. A bypass feeds the Vector output only: the Value output has another type. */
static bool vector_math_fold(sg_fold *x)
{
    enum { v1 = 0, v2 = 1, sc = 3, ov = 0, of = 1 };
    bool zero = false;
    int pass = -1;
    switch (sg_fold_props(x)[VMATH_PROP_OPERATION]) {
    case V_ADD:
        pass = sg_fold_input_equals(x, v1, 0.0f) ? v2 : sg_fold_input_equals(x, v2, 0.0f) ? v1 : -1;
        break;
    case V_SUBTRACT:
        pass = sg_fold_input_equals(x, v2, 0.0f) ? v1 : -1;
        break;
    case V_MULTIPLY:
        zero = sg_fold_input_equals(x, v1, 0.0f) || sg_fold_input_equals(x, v2, 0.0f);
        pass = zero ? -1
               : sg_fold_input_equals(x, v1, 1.0f) ? v2
               : sg_fold_input_equals(x, v2, 1.0f) ? v1
                                                   : -1;
        break;
    case V_DIVIDE:
        zero = sg_fold_input_equals(x, v1, 0.0f) || sg_fold_input_equals(x, v2, 0.0f);
        pass = zero ? -1 : sg_fold_input_equals(x, v2, 1.0f) ? v1 : -1;
        break;
    case V_DOT_PRODUCT:
    case V_CROSS_PRODUCT:
        zero = sg_fold_input_equals(x, v1, 0.0f) || sg_fold_input_equals(x, v2, 0.0f);
        break;
    case V_LENGTH:
    case V_ABSOLUTE:
        zero = sg_fold_input_equals(x, v1, 0.0f);
        break;
    case V_SCALE:
        zero = sg_fold_input_equals(x, v1, 0.0f) || sg_fold_input_equals(x, sc, 0.0f);
        pass = zero ? -1 : sg_fold_input_equals(x, sc, 1.0f) ? v1 : -1;
        break;
    }
    bool changed = false;
    if (zero) {
        changed |= sg_fold_make_value(x, ov, 0.0f);
        changed |= sg_fold_make_value(x, of, 0.0f);
    } else if (pass >= 0) {
        changed |= sg_fold_try_bypass(x, pass, ov, false);
    }
    return changed;
}

const sg_node_type node_type_vector_math = {
    .idname = "ShaderNodeVectorMath",
    .inputs = vector_math_inputs,
    .n_inputs = SG_COUNT(vector_math_inputs),
    .outputs = vector_math_outputs,
    .n_outputs = SG_COUNT(vector_math_outputs),
    .props = vector_math_props,
    .n_props = SG_COUNT(vector_math_props),
    .kernel = vector_math_kernel,
    .flags = SG_NODE_FOLD_CONSTANT,
    .fold = vector_math_fold,
};

/* ==== Clamp ======================================================================== */

static const char *const clamp_type_values[] = {"MINMAX", "RANGE", NULL};
enum { CLAMP_MINMAX, CLAMP_RANGE };

static const sg_socket_def clamp_inputs[] = {
    {"Value", "Value", SG_SOCKET_FLOAT, {1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Min", "Min", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Max", "Max", SG_SOCKET_FLOAT, {1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

static const sg_socket_def clamp_outputs[] = {
    {"Result", "Result", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

static const sg_prop_def clamp_props[] = {
    {"clamp_type", SG_PROP_ENUM, clamp_type_values, CLAMP_MINMAX},
};

/* RANGE swaps reversed bounds; MINMAX applies max first, then min (so min > max gives
 * max). */
static inline float clamp_node(float value, float lo, float hi, bool range)
{
    if (range && lo > hi)
        return clampf(value, hi, lo);
    return clampf(value, lo, hi);
}

static void clamp_kernel(const sg_kernel_args *a)
{
    const int n = a->n;
    const bool range = a->prop[0] == CLAMP_RANGE;
    float *out = a->out[0];
    if (!out)
        return;
    for (int i = 0; i < n; i++)
        out[i] = clamp_node(a->in[0][i], a->in[1][i], a->in[2][i], range);
}

const sg_node_type node_type_clamp = {
    "ShaderNodeClamp",
    clamp_inputs,
    SG_COUNT(clamp_inputs),
    clamp_outputs,
    SG_COUNT(clamp_outputs),
    clamp_props,
    SG_COUNT(clamp_props),
    clamp_kernel,
    SG_NODE_FOLD_CONSTANT,
};

/* ==== Map Range ==================================================================== */

static const char *const map_range_data_type_values[] = {"FLOAT", "FLOAT_VECTOR", NULL};
static const char *const map_range_interpolation_values[] = {"LINEAR", "STEPPED", "SMOOTHSTEP",
                                                             "SMOOTHERSTEP", NULL};
enum { MR_FLOAT, MR_VECTOR };
enum { MR_LINEAR, MR_STEPPED, MR_SMOOTHSTEP, MR_SMOOTHERSTEP };
enum { MR_PROP_DATA_TYPE, MR_PROP_INTERPOLATION, MR_PROP_CLAMP };

#define MR_FLOAT_ONLY OP(MR_FLOAT)
#define MR_VECTOR_ONLY OP(MR_VECTOR)

static const sg_socket_def map_range_inputs[] = {
    {"Value", "Value", SG_SOCKET_FLOAT, {1.0f}, SG_IMPLICIT_NONE, MR_FLOAT_ONLY, MR_PROP_DATA_TYPE, 0, 0},
    {"From Min", "From Min", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, MR_FLOAT_ONLY, MR_PROP_DATA_TYPE, 0, 0},
    {"From Max", "From Max", SG_SOCKET_FLOAT, {1.0f}, SG_IMPLICIT_NONE, MR_FLOAT_ONLY, MR_PROP_DATA_TYPE, 0, 0},
    {"To Min", "To Min", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, MR_FLOAT_ONLY, MR_PROP_DATA_TYPE, 0, 0},
    {"To Max", "To Max", SG_SOCKET_FLOAT, {1.0f}, SG_IMPLICIT_NONE, MR_FLOAT_ONLY, MR_PROP_DATA_TYPE, 0, 0},
    {"Steps", "Steps", SG_SOCKET_FLOAT, {4.0f}, SG_IMPLICIT_NONE, MR_FLOAT_ONLY, MR_PROP_DATA_TYPE,
     OP(MR_STEPPED), MR_PROP_INTERPOLATION},
    {"Vector", "Vector", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE, MR_VECTOR_ONLY,
     MR_PROP_DATA_TYPE, 0, 0},
    {"From_Min_FLOAT3", "From Min", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE,
     MR_VECTOR_ONLY, MR_PROP_DATA_TYPE, 0, 0},
    {"From_Max_FLOAT3", "From Max", SG_SOCKET_VECTOR, {1.0f, 1.0f, 1.0f}, SG_IMPLICIT_NONE,
     MR_VECTOR_ONLY, MR_PROP_DATA_TYPE, 0, 0},
    {"To_Min_FLOAT3", "To Min", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE,
     MR_VECTOR_ONLY, MR_PROP_DATA_TYPE, 0, 0},
    {"To_Max_FLOAT3", "To Max", SG_SOCKET_VECTOR, {1.0f, 1.0f, 1.0f}, SG_IMPLICIT_NONE,
     MR_VECTOR_ONLY, MR_PROP_DATA_TYPE, 0, 0},
    {"Steps_FLOAT3", "Steps", SG_SOCKET_VECTOR, {4.0f, 4.0f, 4.0f}, SG_IMPLICIT_NONE,
     MR_VECTOR_ONLY, MR_PROP_DATA_TYPE, OP(MR_STEPPED), MR_PROP_INTERPOLATION},
};
enum { MR_IN_VALUE, MR_IN_FROM_MIN, MR_IN_FROM_MAX, MR_IN_TO_MIN, MR_IN_TO_MAX, MR_IN_STEPS,
       MR_IN_VECTOR, MR_IN_FROM_MIN3, MR_IN_FROM_MAX3, MR_IN_TO_MIN3, MR_IN_TO_MAX3,
       MR_IN_STEPS3 };

static const sg_socket_def map_range_outputs[] = {
    {"Result", "Result", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, MR_FLOAT_ONLY, MR_PROP_DATA_TYPE, 0, 0},
    {"Vector", "Vector", SG_SOCKET_VECTOR, {0.0f}, SG_IMPLICIT_NONE, MR_VECTOR_ONLY, MR_PROP_DATA_TYPE, 0, 0},
};

static const sg_prop_def map_range_props[] = {
    {"data_type", SG_PROP_ENUM, map_range_data_type_values, MR_FLOAT},
    {"interpolation_type", SG_PROP_ENUM, map_range_interpolation_values, MR_LINEAR},
    {"clamp", SG_PROP_BOOL, NULL, 1},
};

/* Cycles' smoothstep(edge0, edge1, x), and 1 - smoothstep(...) as the reversed-range
 * branch of Map Range computes it: there the final product feeds the subtraction from 1
 * and the AVX2 kernel fuses the two. */
static inline float smoothstep_edges(float edge0, float edge1, float x, bool complement)
{
    if (x < edge0)
        return complement ? 1.0f : 0.0f;
    if (x >= edge1)
        return complement ? 0.0f : 1.0f;
    float t = (x - edge0) / (edge1 - edge0);
    float p = nmadd(2.0f, t, 3.0f);
    return complement ? nmadd(p, t * t, 1.0f) : p * (t * t);
}

/* t^3 (t (6t - 15) + 10) for t already in [0, 1]. */
static inline float smootherstep_unit(float t)
{
    return t * t * t * madd(t, madd(t, 6.0f, -15.0f), 10.0f);
}

static inline float smootherstep_edges(float edge0, float edge1, float x, bool complement)
{
    float t = clampf(safe_divide(x - edge0, edge1 - edge0), 0.0f, 1.0f);
    if (complement)
        return nmadd(t * t * t, madd(t, madd(t, 6.0f, -15.0f), 10.0f), 1.0f);
    return smootherstep_unit(t);
}

/* Float Map Range. Blender's clamp option is a Clamp node (RANGE on To Min/To Max)
 * that Cycles appends after the map, whatever the interpolation. */
static inline float map_range_float(int interpolation, bool clamp, float value, float from_min,
                                    float from_max, float to_min, float to_max, float steps)
{
    float result = 0.0f; /* Cycles' value for an empty source range */
    if (from_max != from_min) {
        float factor;
        switch (interpolation) {
        case MR_STEPPED:
            factor = (value - from_min) / (from_max - from_min);
            factor = steps > 0.0f ? floorf(factor * (steps + 1.0f)) / steps : 0.0f;
            break;
        case MR_SMOOTHSTEP:
            factor = from_min > from_max ? smoothstep_edges(from_max, from_min, value, true)
                                         : smoothstep_edges(from_min, from_max, value, false);
            break;
        case MR_SMOOTHERSTEP:
            factor = from_min > from_max ? smootherstep_edges(from_max, from_min, value, true)
                                         : smootherstep_edges(from_min, from_max, value, false);
            break;
        default:
            factor = (value - from_min) / (from_max - from_min);
            break;
        }
        result = madd(factor, to_max - to_min, to_min);
    }
    return clamp ? clamp_node(result, to_min, to_max, true) : result;
}

/* One component of Vector Map Range; Cycles clamps only LINEAR and STEPPED here. */
static inline float map_range_component(int interpolation, bool clamp, float value, float from_min,
                                        float from_max, float to_min, float to_max, float steps)
{
    float factor = safe_divide(value - from_min, from_max - from_min);
    switch (interpolation) {
    case MR_STEPPED:
        factor = steps > 0.0f ? floorf(factor * (steps + 1.0f)) / steps : 0.0f;
        break;
    case MR_SMOOTHSTEP:
        factor = clampf(factor, 0.0f, 1.0f);
        factor = nmadd(2.0f, factor, 3.0f) * (factor * factor);
        break;
    case MR_SMOOTHERSTEP:
        factor = smootherstep_unit(clampf(factor, 0.0f, 1.0f));
        break;
    default:
        break;
    }
    float result = madd(factor, to_max - to_min, to_min);
    if (clamp && (interpolation == MR_LINEAR || interpolation == MR_STEPPED))
        result = clamp_node(result, to_min, to_max, true);
    return result;
}

static void map_range_kernel(const sg_kernel_args *a)
{
    const int n = a->n;
    const int interpolation = a->prop[MR_PROP_INTERPOLATION];
    const bool clamp = a->prop[MR_PROP_CLAMP] != 0;

    if (a->prop[MR_PROP_DATA_TYPE] == MR_FLOAT) {
        float *out = a->out[0];
        if (!out)
            return;
        /* The interpolation is a literal in each loop so that the inlined switch folds. */
#define MAP_RANGE_FLOAT_LOOP(interp)                                                       \
    for (int i = 0; i < n; i++)                                                            \
        out[i] = map_range_float(interp, clamp, a->in[MR_IN_VALUE][i], a->in[MR_IN_FROM_MIN][i], \
                                 a->in[MR_IN_FROM_MAX][i], a->in[MR_IN_TO_MIN][i],         \
                                 a->in[MR_IN_TO_MAX][i], a->in[MR_IN_STEPS][i]);           \
    break
        switch (interpolation) {
        case MR_STEPPED: MAP_RANGE_FLOAT_LOOP(MR_STEPPED);
        case MR_SMOOTHSTEP: MAP_RANGE_FLOAT_LOOP(MR_SMOOTHSTEP);
        case MR_SMOOTHERSTEP: MAP_RANGE_FLOAT_LOOP(MR_SMOOTHERSTEP);
        default: MAP_RANGE_FLOAT_LOOP(MR_LINEAR);
        }
#undef MAP_RANGE_FLOAT_LOOP
        return;
    }

    float *out = a->out[1];
    if (!out)
        return;
    for (int c = 0; c < 3; c++) {
        const size_t off = (size_t)c * (size_t)n;
        for (int i = 0; i < n; i++)
            out[off + i] = map_range_component(
                interpolation, clamp, a->in[MR_IN_VECTOR][off + i], a->in[MR_IN_FROM_MIN3][off + i],
                a->in[MR_IN_FROM_MAX3][off + i], a->in[MR_IN_TO_MIN3][off + i],
                a->in[MR_IN_TO_MAX3][off + i], a->in[MR_IN_STEPS3][off + i]);
    }
}

const sg_node_type node_type_map_range = {
    "ShaderNodeMapRange",
    map_range_inputs,
    SG_COUNT(map_range_inputs),
    map_range_outputs,
    SG_COUNT(map_range_outputs),
    map_range_props,
    SG_COUNT(map_range_props),
    map_range_kernel,
    0, /* Cycles folds no Map Range, not even an all-constant one */
};
