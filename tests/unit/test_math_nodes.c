/*
 * Properties of the Math family kernels (kernels/math.c) that do not need Blender to
 * check: Cycles' safe_* conventions (what an operation returns where the plain
 * function is undefined), the 3.x / 4.x differences, NaN through the clamps, and which
 * sockets Blender shows for which operation (the availability lists below were read
 * from Blender 4.3's UI, socket.enabled for every operation). Agreement with Blender's
 * rendered values is tested by test_blender_nodes on the gen_math.py references.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "kernel_call.h"

#define MAXN 8

/* Math `op` on up to MAXN (a, b, c) triples; results in r. */
static void math_op(const char *op, int clamp, int n, const float (*abc)[3], float *r,
                    sg_blender_mode mode)
{
    kernel_call c;
    kc_init(&c, "ShaderNodeMath", n);
    c.blender = mode;
    kc_set_prop(&c, "operation", op);
    kc_set_prop(&c, "use_clamp", clamp ? "true" : "false");
    for (int i = 0; i < n; i++) {
        kc_set(&c, "Value", i, abc[i][0], 0, 0);
        kc_set(&c, "Value_001", i, abc[i][1], 0, 0);
        kc_set(&c, "Value_002", i, abc[i][2], 0, 0);
    }
    kc_run(&c);
    for (int i = 0; i < n; i++)
        r[i] = kc_out(&c, "Value", i, 0);
}

/* ---- safe conventions -------------------------------------------------------------- */

typedef struct expectation {
    const char *op;
    float a, b, c;
    float want;
} expectation;

static void test_math_safe_conventions(void **state)
{
    (void)state;
    const float pi = 3.14159265358979f;
    const expectation cases[] = {
        {"DIVIDE", 3.0f, 0.0f, 0.0f, 0.0f},
        {"DIVIDE", -3.0f, -0.0f, 0.0f, 0.0f},
        {"MODULO", 3.0f, 0.0f, 0.0f, 0.0f},
        {"MODULO", -7.0f, 3.0f, 0.0f, -1.0f},          /* fmod keeps the sign of a */
        {"FLOORED_MODULO", -7.0f, 3.0f, 0.0f, 2.0f},    /* floored keeps the sign of b */
        {"FLOORED_MODULO", 5.0f, 0.0f, 0.0f, 0.0f},
        {"SNAP", 5.0f, 0.0f, 0.0f, 0.0f},
        {"PINGPONG", 5.0f, 0.0f, 0.0f, 0.0f},
        {"POWER", -2.0f, 0.5f, 0.0f, 0.0f},             /* negative base, fractional exponent */
        {"POWER", -2.0f, 3.0f, 0.0f, -8.0f},            /* integer exponent is fine */
        {"POWER", -2.0f, 1e10f, 0.0f, 0.0f},            /* (int)1e10 is INT_MIN on x86 */
        {"LOGARITHM", -1.0f, 2.0f, 0.0f, 0.0f},
        {"LOGARITHM", 8.0f, 0.0f, 0.0f, 0.0f},
        {"LOGARITHM", 8.0f, 1.0f, 0.0f, 0.0f},          /* log(1) = 0: safe division */
        {"SQRT", -4.0f, 0.0f, 0.0f, 0.0f},
        {"INVERSE_SQRT", 0.0f, 0.0f, 0.0f, 0.0f},
        {"ARCSINE", 2.0f, 0.0f, 0.0f, pi / 2.0f},
        {"ARCCOSINE", -2.0f, 0.0f, 0.0f, pi},
        {"SIGN", 0.0f, 0.0f, 0.0f, 0.0f},
        {"SIGN", -0.25f, 0.0f, 0.0f, -1.0f},
        {"COMPARE", 1.0f, 1.0f + 1e-7f, -1.0f, 1.0f},   /* epsilon is at least FLT_EPSILON */
        {"COMPARE", 1.0f, 1.5f, 0.5f, 1.0f},
        {"COMPARE", 1.0f, 1.5f, 0.4f, 0.0f},
        {"WRAP", 7.0f, 2.0f, 2.0f, 2.0f},               /* empty range gives min */
        {"WRAP", 7.0f, 3.0f, 1.0f, 1.0f},
        {"ROUND", -2.5f, 0.0f, 0.0f, -2.0f},            /* floor(a + 0.5) */
        {"TRUNC", -2.5f, 0.0f, 0.0f, -2.0f},
        {"SMOOTH_MIN", 1.0f, 2.0f, 0.0f, 1.0f},         /* k = 0: plain min */
        {"SMOOTH_MAX", 1.0f, 2.0f, 0.0f, 2.0f},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        const float abc[1][3] = {{cases[k].a, cases[k].b, cases[k].c}};
        float r;
        math_op(cases[k].op, 0, 1, abc, &r, SG_BLENDER_4);
        if (fabsf(r - cases[k].want) > 1e-6f)
            fail_msg("%s(%g, %g, %g) = %g, want %g", cases[k].op, (double)cases[k].a,
                     (double)cases[k].b, (double)cases[k].c, (double)r, (double)cases[k].want);
    }
}

/* use_clamp is Cycles' Clamp node, min(max(x, 0), 1) by comparisons: NaN becomes 0,
 * inf becomes 1. */
static void test_math_clamp_non_finite(void **state)
{
    (void)state;
    const float abc[2][3] = {{1e30f, 0, 0}, {100.0f, 0, 0}};
    float r[2];
    math_op("EXPONENT", 1, 2, abc, r, SG_BLENDER_4); /* inf */
    assert_float_equal(r[0], 1.0f, 0.0f);
    const float nan_in[1][3] = {{INFINITY, 0, 0}};
    math_op("SINE", 1, 1, nan_in, r, SG_BLENDER_4); /* sin(inf) = NaN */
    assert_float_equal(r[0], 0.0f, 0.0f);
    math_op("SINE", 0, 1, nan_in, r, SG_BLENDER_4);
    assert_true(isnan(r[0]));
}

/* 4.3's compatible_atan2 returns 0 at the origin whatever the signs of the zeros;
 * 3.4 calls atan2f directly (atan2(+0, -0) = pi). */
static void test_math_atan2_modes(void **state)
{
    (void)state;
    const float abc[1][3] = {{0.0f, -0.0f, 0.0f}};
    float r;
    math_op("ARCTAN2", 0, 1, abc, &r, SG_BLENDER_4);
    assert_float_equal(r, 0.0f, 0.0f);
    math_op("ARCTAN2", 0, 1, abc, &r, SG_BLENDER_3);
    assert_float_equal(r, 3.14159265f, 1e-6f);
}

/* ---- Vector Math ------------------------------------------------------------------ */

static void vector_op(kernel_call *c, const char *op, sg_blender_mode mode, float ax, float ay, float az,
                      float bx, float by, float bz)
{
    kc_init(c, "ShaderNodeVectorMath", 1);
    c->blender = mode;
    kc_set_prop(c, "operation", op);
    kc_set(c, "Vector", 0, ax, ay, az);
    kc_set(c, "Vector_001", 0, bx, by, bz);
    kc_run(c);
}

static void test_vector_reflect_refract_modes(void **state)
{
    (void)state;
    kernel_call c;
    /* A unit normal reflects the same way in both versions. */
    for (int m = 0; m < 2; m++) {
        vector_op(&c, "REFLECT", m ? SG_BLENDER_3 : SG_BLENDER_4, 1.0f, -2.0f, 3.0f, 0.0f, 0.0f, 4.0f);
        assert_float_equal(kc_out(&c, "Vector", 0, 0), 1.0f, 1e-6f);
        assert_float_equal(kc_out(&c, "Vector", 0, 1), -2.0f, 1e-6f);
        assert_float_equal(kc_out(&c, "Vector", 0, 2), -3.0f, 1e-6f);
    }
    /* A zero normal: 4.3's safe_normalize keeps it zero (A passes through); 3.4
     * divides by |B| = 0. */
    vector_op(&c, "REFLECT", SG_BLENDER_4, 1.0f, -2.0f, 3.0f, 0.0f, 0.0f, 0.0f);
    assert_float_equal(kc_out(&c, "Vector", 0, 1), -2.0f, 0.0f);
    vector_op(&c, "REFLECT", SG_BLENDER_3, 1.0f, -2.0f, 3.0f, 0.0f, 0.0f, 0.0f);
    assert_true(isnan(kc_out(&c, "Vector", 0, 0)));
    vector_op(&c, "REFRACT", SG_BLENDER_3, 1.0f, -2.0f, 3.0f, 0.0f, 0.0f, 0.0f);
    assert_true(isnan(kc_out(&c, "Vector", 0, 0)));
}

static void test_vector_safe_conventions(void **state)
{
    (void)state;
    kernel_call c;
    vector_op(&c, "DIVIDE", SG_BLENDER_4, 1.0f, 2.0f, 3.0f, 0.0f, 4.0f, 0.0f);
    assert_float_equal(kc_out(&c, "Vector", 0, 0), 0.0f, 0.0f);
    assert_float_equal(kc_out(&c, "Vector", 0, 1), 0.5f, 0.0f);
    vector_op(&c, "NORMALIZE", SG_BLENDER_4, 0.0f, 0.0f, 0.0f, 0, 0, 0);
    assert_float_equal(kc_out(&c, "Vector", 0, 0), 0.0f, 0.0f);
    vector_op(&c, "PROJECT", SG_BLENDER_4, 1.0f, 2.0f, 3.0f, 0.0f, 0.0f, 0.0f);
    assert_float_equal(kc_out(&c, "Vector", 0, 2), 0.0f, 0.0f);
    vector_op(&c, "LENGTH", SG_BLENDER_4, 3.0f, 4.0f, 12.0f, 0, 0, 0);
    assert_float_equal(kc_out(&c, "Value", 0, 0), 13.0f, 0.0f);
    /* Total internal reflection gives the zero vector. */
    kc_init(&c, "ShaderNodeVectorMath", 1);
    kc_set_prop(&c, "operation", "REFRACT");
    kc_set(&c, "Vector", 0, 1.0f, 0.0f, -0.1f);
    kc_set(&c, "Vector_001", 0, 0.0f, 0.0f, 1.0f);
    kc_set(&c, "Scale", 0, 1.6f, 0, 0);
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Vector", 0, 0), 0.0f, 0.0f);
}

/* ---- Clamp and Map Range ---------------------------------------------------------- */

static void test_clamp_reversed_bounds(void **state)
{
    (void)state;
    kernel_call c;
    kc_init(&c, "ShaderNodeClamp", 2);
    kc_set(&c, "Value", 0, 0.5f, 0, 0);
    kc_set(&c, "Min", 0, 2.0f, 0, 0);
    kc_set(&c, "Max", 0, -1.0f, 0, 0);
    kc_set(&c, "Value", 1, NAN, 0, 0);
    kc_set(&c, "Min", 1, 0.25f, 0, 0);
    kc_set(&c, "Max", 1, 1.0f, 0, 0);
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Result", 0, 0), -1.0f, 0.0f); /* MINMAX: max wins */
    assert_float_equal(kc_out(&c, "Result", 1, 0), 0.25f, 0.0f); /* NaN -> lower bound */
    kc_set_prop(&c, "clamp_type", "RANGE");
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Result", 0, 0), 0.5f, 0.0f); /* bounds swapped */
}

static void test_map_range_empty_source(void **state)
{
    (void)state;
    kernel_call c;
    kc_init(&c, "ShaderNodeMapRange", 1);
    kc_set(&c, "Value", 0, 0.7f, 0, 0);
    kc_set(&c, "From Min", 0, 0.5f, 0, 0);
    kc_set(&c, "From Max", 0, 0.5f, 0, 0);
    kc_set(&c, "To Min", 0, 2.0f, 0, 0);
    kc_set(&c, "To Max", 0, 3.0f, 0, 0);
    kc_set_prop(&c, "clamp", "false");
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Result", 0, 0), 0.0f, 0.0f); /* Cycles writes 0 */
    kc_set_prop(&c, "clamp", "true");
    kc_run(&c);
    assert_float_equal(kc_out(&c, "Result", 0, 0), 2.0f, 0.0f); /* ... then clamps it */

    kc_init(&c, "ShaderNodeMapRange", 1);
    kc_set_prop(&c, "data_type", "FLOAT_VECTOR");
    kc_set(&c, "Vector", 0, 0.7f, 0.7f, 0.7f);
    kc_set(&c, "From_Min_FLOAT3", 0, 0.5f, 0.5f, 0.0f);
    kc_set(&c, "From_Max_FLOAT3", 0, 0.5f, 0.5f, 1.0f);
    kc_set(&c, "To_Min_FLOAT3", 0, 2.0f, 2.0f, 2.0f);
    kc_set(&c, "To_Max_FLOAT3", 0, 3.0f, 3.0f, 3.0f);
    kc_run(&c);
    /* Vector: safe division gives factor 0, so To Min. */
    assert_float_equal(kc_out(&c, "Vector", 0, 0), 2.0f, 0.0f);
    assert_float_equal(kc_out(&c, "Vector", 0, 2), 2.7f, 1e-6f);
}

/* ---- socket availability ---------------------------------------------------------- */

static int available(const kernel_call *c, const char *identifier, int is_input)
{
    const sg_socket_def *defs = is_input ? c->type->inputs : c->type->outputs;
    int k = is_input ? sg_node_type_input_index(c->type, identifier)
                     : sg_node_type_output_index(c->type, identifier);
    assert_true(k >= 0);
    return sg_socket_available(&defs[k], c->prop);
}

static int listed(const char *const *list, const char *op)
{
    for (int i = 0; list[i]; i++)
        if (strcmp(list[i], op) == 0)
            return 1;
    return 0;
}

static void test_availability(void **state)
{
    (void)state;
    /* Blender 4.3: operations showing only the first operand / all three. */
    static const char *const math_unary[] = {
        "SQRT", "INVERSE_SQRT", "ABSOLUTE", "EXPONENT", "SIGN", "ROUND", "FLOOR", "CEIL",
        "TRUNC", "FRACT", "SINE", "COSINE", "TANGENT", "ARCSINE", "ARCCOSINE", "ARCTANGENT",
        "SINH", "COSH", "TANH", "RADIANS", "DEGREES", NULL};
    static const char *const math_ternary[] = {"MULTIPLY_ADD", "COMPARE", "SMOOTH_MIN",
                                               "SMOOTH_MAX", "WRAP", NULL};
    kernel_call c;
    kc_init(&c, "ShaderNodeMath", 1);
    const sg_prop_def *op = &c.type->props[sg_node_type_prop_index(c.type, "operation")];
    int n_ops = 0;
    for (int v = 0; op->values[v]; v++, n_ops++) {
        c.prop[0] = v;
        assert_int_equal(available(&c, "Value_001", 1), !listed(math_unary, op->values[v]));
        assert_int_equal(available(&c, "Value_002", 1), listed(math_ternary, op->values[v]));
    }
    assert_int_equal(n_ops, 41);

    static const char *const vector_unary[] = {"LENGTH", "SCALE", "NORMALIZE", "ABSOLUTE",
                                               "FLOOR", "CEIL", "FRACTION", "SINE",
                                               "COSINE", "TANGENT", NULL};
    static const char *const vector_ternary[] = {"MULTIPLY_ADD", "FACEFORWARD", "WRAP", NULL};
    static const char *const vector_value[] = {"DOT_PRODUCT", "DISTANCE", "LENGTH", NULL};
    static const char *const vector_scale[] = {"SCALE", "REFRACT", NULL};
    kc_init(&c, "ShaderNodeVectorMath", 1);
    op = &c.type->props[0];
    n_ops = 0;
    for (int v = 0; op->values[v]; v++, n_ops++) {
        c.prop[0] = v;
        const char *name = op->values[v];
        assert_int_equal(available(&c, "Vector_001", 1), !listed(vector_unary, name));
        assert_int_equal(available(&c, "Vector_002", 1), listed(vector_ternary, name));
        assert_int_equal(available(&c, "Scale", 1), listed(vector_scale, name));
        assert_int_equal(available(&c, "Value", 0), listed(vector_value, name));
        assert_int_equal(available(&c, "Vector", 0), !listed(vector_value, name));
    }
    assert_int_equal(n_ops, 27);

    kc_init(&c, "ShaderNodeMapRange", 1);
    assert_true(available(&c, "Value", 1));
    assert_false(available(&c, "Steps", 1));
    assert_false(available(&c, "Vector", 1));
    kc_set_prop(&c, "interpolation_type", "STEPPED");
    assert_true(available(&c, "Steps", 1));
    assert_false(available(&c, "Steps_FLOAT3", 1));
    kc_set_prop(&c, "data_type", "FLOAT_VECTOR");
    assert_true(available(&c, "Steps_FLOAT3", 1));
    assert_false(available(&c, "Steps", 1));
    assert_true(available(&c, "Vector", 0));
    assert_false(available(&c, "Result", 0));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_math_safe_conventions),
        cmocka_unit_test(test_math_clamp_non_finite),
        cmocka_unit_test(test_math_atan2_modes),
        cmocka_unit_test(test_vector_reflect_refract_modes),
        cmocka_unit_test(test_vector_safe_conventions),
        cmocka_unit_test(test_clamp_reversed_bounds),
        cmocka_unit_test(test_map_range_empty_source),
        cmocka_unit_test(test_availability),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
