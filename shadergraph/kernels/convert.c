/*
 * Converter nodes: Combine/Separate XYZ, Combine/Separate Color and Mapping.
 *
 * Sources of truth: Cycles' kernel/svm/sepcomb_vector.h, sepcomb_color.h, mapping.h and
 * mapping_util.h, with util/color.h and util/transform.h. Blender 3.4 and 4.3 agree on all
 * of these, so a->blender is not consulted.
 *
 * Combine/Separate Color convert with Cycles' HSV/HSL formulas (kernels/color_util.h), which
 * neither wrap hues nor clamp channels: out-of-range inputs give what Blender gives.
 */
#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "shadergraph/fold.h"
#include "shadergraph/kernels/color_util.h"
#include "shadergraph/kernels/kernel_util.h"
#include "shadergraph/node_type.h"


/* ---- Combine XYZ / Separate XYZ --------------------------------------------------- */

static void combine_xyz_kernel(const sg_kernel_args *a)
{
    float *out = a->out[0];
    if (!out)
        return;
    const int n = a->n;
    for (int c = 0; c < 3; c++)
        memcpy(out + (size_t)c * (size_t)n, a->in[c], (size_t)n * sizeof(float));
}

static void separate_xyz_kernel(const sg_kernel_args *a)
{
    const int n = a->n;
    for (int c = 0; c < 3; c++)
        if (a->out[c])
            memcpy(a->out[c], a->in[0] + (size_t)c * (size_t)n, (size_t)n * sizeof(float));
}

static const sg_socket_def combine_xyz_inputs[] = {
    {"X", "X", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Y", "Y", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Z", "Z", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};
static const sg_socket_def combine_xyz_outputs[] = {
    {"Vector", "Vector", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

const sg_node_type node_type_combine_xyz = {
    "ShaderNodeCombineXYZ",
    combine_xyz_inputs,  SG_COUNT(combine_xyz_inputs),
    combine_xyz_outputs, SG_COUNT(combine_xyz_outputs),
    NULL,                0,
    combine_xyz_kernel,  SG_NODE_FOLD_CONSTANT,
};

static const sg_socket_def separate_xyz_inputs[] = {
    {"Vector", "Vector", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};
static const sg_socket_def separate_xyz_outputs[] = {
    {"X", "X", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Y", "Y", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Z", "Z", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

const sg_node_type node_type_separate_xyz = {
    "ShaderNodeSeparateXYZ",
    separate_xyz_inputs,  SG_COUNT(separate_xyz_inputs),
    separate_xyz_outputs, SG_COUNT(separate_xyz_outputs),
    NULL,                 0,
    separate_xyz_kernel,  SG_NODE_FOLD_CONSTANT,
};

/* ---- Combine Color / Separate Color ----------------------------------------------- */

static const char *const color_mode_values[] = {"RGB", "HSV", "HSL", NULL};
enum { COLOR_MODE_RGB, COLOR_MODE_HSV, COLOR_MODE_HSL };

static void combine_color_kernel(const sg_kernel_args *a)
{
    float *out = a->out[0];
    if (!out)
        return;
    const int n = a->n;
    const float *r = a->in[0], *g = a->in[1], *b = a->in[2];
    switch (a->prop[0]) {
    case COLOR_MODE_HSV:
        for (int i = 0; i < n; i++)
            f3_store(out, n, i, hsv_to_rgb(make_float3(r[i], g[i], b[i])));
        break;
    case COLOR_MODE_HSL:
        for (int i = 0; i < n; i++)
            f3_store(out, n, i, hsl_to_rgb(make_float3(r[i], g[i], b[i])));
        break;
    default:
        for (int i = 0; i < n; i++)
            f3_store(out, n, i, make_float3(r[i], g[i], b[i]));
        break;
    }
}

static void separate_color_kernel(const sg_kernel_args *a)
{
    const int n = a->n;
    float *const *out = a->out;
#define SEPARATE_LOOP(convert)                                                             \
    for (int i = 0; i < n; i++) {                                                          \
        float3 c = convert(f3_load(a->in[0], n, i));                                       \
        if (out[0])                                                                        \
            out[0][i] = c.x;                                                               \
        if (out[1])                                                                        \
            out[1][i] = c.y;                                                               \
        if (out[2])                                                                        \
            out[2][i] = c.z;                                                               \
    }
    switch (a->prop[0]) {
    case COLOR_MODE_HSV:
        SEPARATE_LOOP(rgb_to_hsv)
        break;
    case COLOR_MODE_HSL:
        SEPARATE_LOOP(rgb_to_hsl)
        break;
    default:
        for (int c = 0; c < 3; c++)
            if (out[c])
                memcpy(out[c], a->in[0] + (size_t)c * (size_t)n, (size_t)n * sizeof(float));
        break;
    }
#undef SEPARATE_LOOP
}

static const sg_prop_def color_mode_props[] = {
    {"mode", SG_PROP_ENUM, color_mode_values, COLOR_MODE_RGB},
};

static const sg_socket_def combine_color_inputs[] = {
    {"Red", "Red", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Green", "Green", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Blue", "Blue", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};
static const sg_socket_def combine_color_outputs[] = {
    {"Color", "Color", SG_SOCKET_COLOR, {0.8f, 0.8f, 0.8f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

const sg_node_type node_type_combine_color = {
    "ShaderNodeCombineColor",
    combine_color_inputs,  SG_COUNT(combine_color_inputs),
    combine_color_outputs, SG_COUNT(combine_color_outputs),
    color_mode_props,      SG_COUNT(color_mode_props),
    combine_color_kernel,  SG_NODE_FOLD_CONSTANT,
};

static const sg_socket_def separate_color_inputs[] = {
    {"Color", "Color", SG_SOCKET_COLOR, {0.8f, 0.8f, 0.8f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};
static const sg_socket_def separate_color_outputs[] = {
    {"Red", "Red", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Green", "Green", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Blue", "Blue", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

const sg_node_type node_type_separate_color = {
    "ShaderNodeSeparateColor",
    separate_color_inputs,  SG_COUNT(separate_color_inputs),
    separate_color_outputs, SG_COUNT(separate_color_outputs),
    color_mode_props,       SG_COUNT(color_mode_props),
    separate_color_kernel,  SG_NODE_FOLD_CONSTANT,
};

/* ---- Mapping ---------------------------------------------------------------------- */

static const char *const vector_type_values[] = {"POINT", "TEXTURE", "VECTOR", "NORMAL", NULL};
enum { MAPPING_POINT, MAPPING_TEXTURE, MAPPING_VECTOR, MAPPING_NORMAL };

/* Rows of the rotation matrix Cycles builds from Euler angles (X, then Y, then Z, about
 * fixed axes): R = Rz * Ry * Rx. */
typedef struct rotation3 {
    float3 row[3];
} rotation3;

static rotation3 euler_to_rotation(float3 euler)
{
    float cx = cosf(euler.x), cy = cosf(euler.y), cz = cosf(euler.z);
    float sx = sinf(euler.x), sy = sinf(euler.y), sz = sinf(euler.z);
    rotation3 r;
    r.row[0] = make_float3(cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz);
    r.row[1] = make_float3(cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz);
    r.row[2] = make_float3(-sy, cy * sx, cy * cx);
    return r;
}

/* R v */
static float3 rotate(const rotation3 *r, float3 v)
{
    return make_float3(f3_dot(r->row[0], v), f3_dot(r->row[1], v), f3_dot(r->row[2], v));
}

/* R^T v: the inverse rotation. */
static float3 rotate_inverse(const rotation3 *r, float3 v)
{
    float3 x = f3_scale(r->row[0], v.x);
    float3 y = f3_scale(r->row[1], v.y);
    float3 z = f3_scale(r->row[2], v.z);
    return f3_add(f3_add(x, y), z);
}

/* Component-wise a / b, 0 where b is 0 (Cycles' safe_divide of float3s). */
static float3 safe_divide3(float3 a, float3 b)
{
    return make_float3(safe_divide(a.x, b.x), safe_divide(a.y, b.y), safe_divide(a.z, b.z));
}

static float3 svm_mapping(int type, const rotation3 *r, float3 v, float3 location, float3 scale)
{
    switch (type) {
    case MAPPING_POINT:
        return f3_add(rotate(r, f3_mul(v, scale)), location);
    case MAPPING_TEXTURE:
        return safe_divide3(rotate_inverse(r, f3_sub(v, location)), scale);
    case MAPPING_VECTOR:
        return rotate(r, f3_mul(v, scale));
    case MAPPING_NORMAL:
        return safe_normalize(rotate(r, safe_divide3(v, scale)));
    default:
        return make_float3(0.0f, 0.0f, 0.0f);
    }
}

/* Whether all n values of a planar vector equal the first (bitwise, so -0 and NaN are
 * not folded into a neighbour's value). */
static bool vector_is_uniform(const float *v, int n)
{
    for (int c = 0; c < 3; c++) {
        const float *p = v + (size_t)c * (size_t)n;
        for (int i = 1; i < n; i++)
            if (memcmp(&p[i], &p[0], sizeof(float)) != 0)
                return false;
    }
    return true;
}

static void mapping_kernel(const sg_kernel_args *a)
{
    float *out = a->out[0];
    if (!out || a->n <= 0)
        return;
    const int n = a->n;
    const int type = a->prop[0];
    const float *rot = a->in[2];
    /* The rotation is nearly always a constant: then its matrix (six sines and cosines)
     * is built once per batch rather than per point. Same bits either way. */
    if (vector_is_uniform(rot, n)) {
        rotation3 r = euler_to_rotation(f3_load(rot, n, 0));
        for (int i = 0; i < n; i++)
            f3_store(out, n, i,
                     svm_mapping(type, &r, f3_load(a->in[0], n, i), f3_load(a->in[1], n, i),
                                 f3_load(a->in[3], n, i)));
        return;
    }
    for (int i = 0; i < n; i++) {
        rotation3 r = euler_to_rotation(f3_load(rot, n, i));
        f3_store(out, n, i,
                 svm_mapping(type, &r, f3_load(a->in[0], n, i), f3_load(a->in[1], n, i),
                             f3_load(a->in[3], n, i)));
    }
}

#define MAPPING_BIT(t) (1u << (t))

static const sg_socket_def mapping_inputs[] = {
    {"Vector", "Vector", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    /* Blender hides Location for directions. */
    {"Location", "Location", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE,
     MAPPING_BIT(MAPPING_POINT) | MAPPING_BIT(MAPPING_TEXTURE), 0, 0, 0},
    {"Rotation", "Rotation", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Scale", "Scale", SG_SOCKET_VECTOR, {1.0f, 1.0f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};
static const sg_socket_def mapping_outputs[] = {
    {"Vector", "Vector", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};
static const sg_prop_def mapping_props[] = {
    {"vector_type", SG_PROP_ENUM, vector_type_values, MAPPING_POINT},
};

/* Cycles' MappingNode::constant_fold: a zero scale maps everything to 0; an identity
 * transform (no rotation, unit scale, and no translation or a direction) passes the
 * vector through, for every vector type but NORMAL. */
static bool mapping_fold(sg_fold *x)
{
    enum { vec = 0, loc = 1, rot = 2, sc = 3 };
    int type = sg_fold_props(x)[0];
    if (sg_fold_input_equals(x, sc, 0.0f))
        return sg_fold_make_value(x, 0, 0.0f);
    if (type != MAPPING_NORMAL && (sg_fold_input_equals(x, loc, 0.0f) || type == MAPPING_VECTOR) &&
        sg_fold_input_equals(x, rot, 0.0f) && sg_fold_input_equals(x, sc, 1.0f))
        return sg_fold_try_bypass(x, vec, 0, false);
    return false;
}

const sg_node_type node_type_mapping = {
    "ShaderNodeMapping",
    mapping_inputs,  SG_COUNT(mapping_inputs),
    mapping_outputs, SG_COUNT(mapping_outputs),
    mapping_props,   SG_COUNT(mapping_props),
    mapping_kernel,  SG_NODE_FOLD_CONSTANT,
    mapping_fold,
};
