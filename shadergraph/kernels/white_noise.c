/*
 * The White Noise Texture node (ShaderNodeTexWhiteNoise), as Cycles' kernel/svm/
 * white_noise.h evaluates it: the lookup3 hash of the coordinates' bits (kernel_util.h)
 * as a float in [0, 1], and as a colour of three such hashes.
 */
#include <stddef.h>

#include "shadergraph/kernels/noise.h"
#include "shadergraph/node_type.h"

enum { WN_IN_VECTOR, WN_IN_W };

static float3 hash_float_to_float3(float k)
{
    return make_float3(hash_float_to_float(k), hash_float2_to_float(k, 1.0f),
                       hash_float2_to_float(k, 2.0f));
}

static float3 hash_float2_to_float3(float x, float y)
{
    return make_float3(hash_float2_to_float(x, y), hash_float3_to_float(make_float3(x, y, 1.0f)),
                       hash_float3_to_float(make_float3(x, y, 2.0f)));
}

static float3 hash_float4_to_float3(float x, float y, float z, float w)
{
    return make_float3(hash_float4_to_float(x, y, z, w), hash_float4_to_float(z, x, w, y),
                       hash_float4_to_float(w, z, y, x));
}

static void tex_white_noise_kernel(const sg_kernel_args *a)
{
    int dims = a->prop[0];
    const float *vec = a->in[WN_IN_VECTOR], *w = a->in[WN_IN_W];
    float *value_out = a->out[0], *color_out = a->out[1];
    int n = a->n;
    for (int i = 0; i < n; i++) {
        float3 v = dims == DIMS_1D ? make_float3(0.0f, 0.0f, 0.0f) : f3_load(vec, n, i);
        float value;
        float3 color;
        switch (dims) {
        case DIMS_1D:
            value = hash_float_to_float(w[i]);
            color = hash_float_to_float3(w[i]);
            break;
        case DIMS_2D:
            value = hash_float2_to_float(v.x, v.y);
            color = hash_float2_to_float3(v.x, v.y);
            break;
        case DIMS_3D:
            value = hash_float3_to_float(v);
            color = hash_float3_to_float3(v);
            break;
        default:
            value = hash_float4_to_float(v.x, v.y, v.z, w[i]);
            color = hash_float4_to_float3(v.x, v.y, v.z, w[i]);
            break;
        }
        if (value_out)
            value_out[i] = value;
        if (color_out)
            f3_store(color_out, n, i, color);
    }
}

/* Unlike the other textures, an unlinked Vector is (0, 0, 0) here, not Generated
 * coordinates (checked in Blender 3.4 and 4.3). */
static const sg_socket_def tex_white_noise_inputs[] = {
    {"Vector", "Vector", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f, 0.0f}, SG_IMPLICIT_NONE,
     DIMS_BIT(DIMS_2D) | DIMS_BIT(DIMS_3D) | DIMS_BIT(DIMS_4D), 0, 0, 0},
    {"W", "W", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, DIMS_BIT(DIMS_1D) | DIMS_BIT(DIMS_4D),
     0, 0, 0},
};

static const sg_socket_def tex_white_noise_outputs[] = {
    {"Value", "Value", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Color", "Color", SG_SOCKET_COLOR, {0.0f, 0.0f, 0.0f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

static const sg_prop_def tex_white_noise_props[] = {
    {"noise_dimensions", SG_PROP_ENUM, noise_dimensions_values, DIMS_3D},
};

const sg_node_type node_type_tex_white_noise = {
    "ShaderNodeTexWhiteNoise",
    tex_white_noise_inputs,
    SG_COUNT(tex_white_noise_inputs),
    tex_white_noise_outputs,
    SG_COUNT(tex_white_noise_outputs),
    tex_white_noise_props,
    SG_COUNT(tex_white_noise_props),
    tex_white_noise_kernel,
    0,
};
