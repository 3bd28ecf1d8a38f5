/*
 * Texture Coordinate and Bump: the nodes that read the shading point's geometry.
 *
 * Texture Coordinate reads the batch geometry at the instruction's offset (centre,
 * +dx, +dy: see compile.c), which is how a Bump's Height subgraph sees the
 * neighbouring points. Bump turns the three heights into a perturbed normal the way
 * Cycles' svm_node_set_bump does: a surface gradient from the height differences along
 * the two differential directions, Rx = dPdy x N and Ry = N x dPdx.
 */
#include "shadergraph/fold.h"
#include "shadergraph/kernels/kernel_util.h"
#include "shadergraph/node_type.h"


/* ---- Texture Coordinate ----------------------------------------------------------- */

enum { TEXCO_GENERATED, TEXCO_NORMAL, TEXCO_UV, TEXCO_OBJECT, TEXCO_CAMERA, TEXCO_WINDOW,
       TEXCO_REFLECTION };

static const sg_socket_def tex_coord_out[] = {
    {"Generated", "Generated", SG_SOCKET_VECTOR, {0}},
    {"Normal", "Normal", SG_SOCKET_VECTOR, {0}},
    {"UV", "UV", SG_SOCKET_VECTOR, {0}},
    {"Object", "Object", SG_SOCKET_VECTOR, {0}},
    {"Camera", "Camera", SG_SOCKET_VECTOR, {0}},
    {"Window", "Window", SG_SOCKET_VECTOR, {0}},
    {"Reflection", "Reflection", SG_SOCKET_VECTOR, {0}},
};
static const sg_prop_def tex_coord_props[] = {{"from_instancer", SG_PROP_BOOL, NULL, 0}};

/* out = v + d (d may be NULL: no offset). */
static void copy_offset(float *out, const float *v, const float *d, int n)
{
    for (int i = 0; i < 3 * n; i++)
        out[i] = d ? v[i] + d[i] : v[i];
}

static void tex_coord_kernel(const sg_kernel_args *a)
{
    const sg_geometry_batch *g = a->geom;
    int n = a->n;
    const float *dgen = a->offset == 1 ? g->dgenerated_dx : a->offset == 2 ? g->dgenerated_dy : NULL;
    const float *duv = a->offset == 1 ? g->duv_dx : a->offset == 2 ? g->duv_dy : NULL;
    const float *dobj = a->offset == 1 ? g->dobject_dx : a->offset == 2 ? g->dobject_dy : NULL;
    const float *dP = a->offset == 1 ? g->dPdx : a->offset == 2 ? g->dPdy : NULL;
    if (a->out[TEXCO_GENERATED])
        copy_offset(a->out[TEXCO_GENERATED], g->generated, dgen, n);
    if (a->out[TEXCO_NORMAL])
        copy_offset(a->out[TEXCO_NORMAL], g->object_normal, NULL, n);
    if (a->out[TEXCO_UV])
        copy_offset(a->out[TEXCO_UV], g->uv, duv, n);
    if (a->out[TEXCO_OBJECT])
        copy_offset(a->out[TEXCO_OBJECT], g->object, dobj, n);
    /* The scene's orthographic camera sits at (0, 0, 2) looking down -Z with +Y up:
     * Cycles' camera space (+Z forward) maps world (x, y, z) to (x, y, 2 - z), and its
     * window (normalised device) coordinates over the 2 m frame are ((x+1)/2, (y+1)/2). */
    for (int i = 0; i < n; i++) {
        float3 P = f3_load(g->P, n, i);
        if (dP)
            P = f3_add(P, f3_load(dP, n, i));
        if (a->out[TEXCO_CAMERA])
            f3_store(a->out[TEXCO_CAMERA], n, i, make_float3(P.x, P.y, 2.0f - P.z));
        if (a->out[TEXCO_WINDOW])
            f3_store(a->out[TEXCO_WINDOW], n, i,
                     make_float3((P.x + 1.0f) * 0.5f, (P.y + 1.0f) * 0.5f, 0.0f));
        if (a->out[TEXCO_REFLECTION]) {
            /* Reflection of the view direction about N, in object space (identity). */
            float3 N = f3_load(g->N, n, i), I = f3_load(g->I, n, i);
            f3_store(a->out[TEXCO_REFLECTION], n, i, f3_sub(f3_scale(N, 2.0f * f3_dot(N, I)), I));
        }
    }
}

const sg_node_type node_type_tex_coord = {
    .idname = "ShaderNodeTexCoord",
    .outputs = tex_coord_out, .n_outputs = SG_COUNT(tex_coord_out),
    .props = tex_coord_props, .n_props = SG_COUNT(tex_coord_props),
    .kernel = tex_coord_kernel,
    .flags = SG_NODE_READS_GEOMETRY};

/* ---- Bump ------------------------------------------------------------------------- */

enum { BUMP_STRENGTH, BUMP_DISTANCE, BUMP_HEIGHT, BUMP_NORMAL, BUMP_HEIGHT_DX, BUMP_HEIGHT_DY };

static const sg_socket_def bump_in[] = {
    {"Strength", "Strength", SG_SOCKET_FLOAT, {1.0f}},
    {"Distance", "Distance", SG_SOCKET_FLOAT, {1.0f}},
    {"Height", "Height", SG_SOCKET_FLOAT, {1.0f}},
    {"Normal", "Normal", SG_SOCKET_VECTOR, {0}, SG_IMPLICIT_NORMAL},
};
static const sg_socket_def bump_out[] = {{"Normal", "Normal", SG_SOCKET_VECTOR, {0}}};
static const sg_prop_def bump_props[] = {{"invert", SG_PROP_BOOL, NULL, 0}};

static float3 bump_normal(float3 normal_in, float3 dPdx, float3 dPdy, float h_c, float h_x,
                          float h_y, float strength, float scale)
{
    float3 Rx = f3_cross(dPdy, normal_in);
    float3 Ry = f3_cross(normal_in, dPdx);
    float det = f3_dot(dPdx, Rx);
    float3 surfgrad = f3_add(f3_scale(Rx, h_x - h_c), f3_scale(Ry, h_y - h_c));
    float absdet = fabsf(det);
    strength = fmaxf(strength, 0.0f);
    float3 out = safe_normalize(f3_sub(f3_scale(normal_in, absdet),
                                       f3_scale(surfgrad, scale * signf(det))));
    if (out.x == 0.0f && out.y == 0.0f && out.z == 0.0f)
        return normal_in;
    return normalize(f3_add(f3_scale(out, strength), f3_scale(normal_in, 1.0f - strength)));
}

static void bump_kernel(const sg_kernel_args *a)
{
    const sg_geometry_batch *g = a->geom;
    int n = a->n;
    float *out = a->out[0];
    if (!out)
        return;
    bool invert = a->prop[0] != 0;
    for (int i = 0; i < n; i++) {
        float scale = a->in[BUMP_DISTANCE][i];
        if (invert)
            scale = -scale;
        float3 N = bump_normal(f3_load(a->in[BUMP_NORMAL], n, i), f3_load(g->dPdx, n, i),
                               f3_load(g->dPdy, n, i), a->in[BUMP_HEIGHT][i],
                               a->in[BUMP_HEIGHT_DX][i], a->in[BUMP_HEIGHT_DY][i],
                               a->in[BUMP_STRENGTH][i], scale);
        if (a->blender == SG_BLENDER_3)
            N = ensure_valid_reflection(f3_load(g->Ng, n, i), f3_load(g->I, n, i), N);
        f3_store(out, n, i, N);
    }
}

/* Cycles' BumpNode::constant_fold: without a Height link the normal is the Normal
 * input's (when that is linked: an implicit N is not a link to point at). Bump is
 * never folded to a constant. */
static bool bump_fold(sg_fold *x)
{
    if (!sg_fold_input_linked(x, BUMP_HEIGHT) && sg_fold_input_linked(x, BUMP_NORMAL))
        return sg_fold_try_bypass(x, BUMP_NORMAL, 0, false);
    return false;
}

const sg_node_type node_type_bump = {
    .idname = "ShaderNodeBump",
    .inputs = bump_in, .n_inputs = SG_COUNT(bump_in),
    .outputs = bump_out, .n_outputs = SG_COUNT(bump_out),
    .props = bump_props, .n_props = SG_COUNT(bump_props),
    .kernel = bump_kernel,
    .flags = SG_NODE_HEIGHT_OFFSETS,
    .fold = bump_fold};
