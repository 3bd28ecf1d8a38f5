/*
 * The Noise Texture node (ShaderNodeTexNoise), as Cycles' kernel/svm/noisetex.h
 * evaluates it: Distortion, then the fractal of noise_type (fractal.c) at the point
 * and, for Color, at two seeded offsets. Blender 4.3 by default; Blender 3.4 for
 * SG_BLENDER_3 (below).
 *
 * Blender 3.x mode. Blender 3.4's Noise Texture knows only normalized fBM with
 * lacunarity 2; the other noise types of our (4.x) vocabulary, and fBM without
 * normalization, are built in 3.4 as a Musgrave Texture by blender/compat_noise.py
 * (Detail + 1, Dimension = -ln(Roughness) / ln(Lacunarity)). In SG_BLENDER_3 this file
 * computes what Blender 3.4 renders for that translated node. What 3.4 cannot express
 * (Distortion or Color on a Musgrave translation, fBM normalized with lacunarity != 2,
 * ...) is listed in compat_noise.py; nothing refuses such nodes in 3.x mode: the kernel
 * returns what 3.4 renders for the translated node (Color = Fac on a Musgrave).
 *
 * Paths. A one-point batch (the pointwise evaluator) and a batch's last few points go
 * through noise_point, whole groups of LANES points through noise_lanes; both give the
 * same bits, which tests/unit/test_noise_batch.c checks.
 */
#include <math.h>
#include <stdbool.h>
#include <stddef.h>

#include "shadergraph/kernels/noise.h"
#include "shadergraph/node_type.h"

const char *const noise_dimensions_values[] = {"1D", "2D", "3D", "4D", NULL};

static const char *const noise_type_values[] = {"MULTIFRACTAL", "RIDGED_MULTIFRACTAL",
                                                "HYBRID_MULTIFRACTAL", "FBM",
                                                "HETERO_TERRAIN", NULL};

enum {
    IN_VECTOR, IN_W, IN_SCALE, IN_DETAIL, IN_ROUGHNESS, IN_LACUNARITY, IN_OFFSET, IN_GAIN,
    IN_DISTORTION
};
enum { PROP_DIMENSIONS, PROP_TYPE, PROP_NORMALIZE };

/* ---- Blender 3.x ------------------------------------------------------------------ */

/* The Musgrave Dimension that blender/compat_noise.py writes for a 4.x Roughness and
 * Lacunarity: the H with Lacunarity^-H = Roughness, computed in double and stored as a
 * float, with the same special cases (keep the two in step). */
static float musgrave_dimension(float roughness, float lacunarity)
{
    if (roughness <= 0.0f)
        return 1e30f; /* Lacunarity^-1e30 is 0 for any lacunarity > 1 */
    if (lacunarity == 1.0f || roughness == 1.0f)
        return 0.0f; /* clamped to 1e-5 by the node: pwHL is (almost) 1 */
    return (float)(-log((double)roughness) / log((double)lacunarity));
}

/* ---- one point ------------------------------------------------------------------- */

/* Cycles' random_float{,2,3,4}_offset: seeds that decorrelate distortion and colour. */
static npoint random_offset(int dims, float seed)
{
    npoint r = {0.0f, 0.0f, 0.0f, 0.0f};
    if (dims == DIMS_1D) {
        r.x = 100.0f + hash_float_to_float(seed) * 100.0f;
        return r;
    }
    /* Components of the axes the point has; the others stay 0. */
    float c[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    for (int k = 0; k <= dims; k++)
        c[k] = 100.0f + hash_float2_to_float(seed, (float)k) * 100.0f;
    r.x = c[0];
    r.y = c[1];
    r.z = c[2];
    r.w = c[3];
    return r;
}

static void noise_point(const noise_node *nn, npoint p, const noise_inputs *in, float *fac,
                        float3 *color)
{
    int dims = nn->mode.dims;
    /* 3.4's Musgrave has no Distortion. */
    if (in->distortion != 0.0f && !nn->as_musgrave) {
        npoint pts[4];
        float d[4] = {0.0f, 0.0f, 0.0f, 0.0f};
        for (int k = 0; k <= dims; k++)
            pts[k] = np_add(p, nn->distortion_seed[k]);
        nn->mode.perlin_many(pts, dims + 1, d);
        for (int k = 0; k <= dims; k++)
            d[k] = nn->mode.scale * d[k] * in->distortion;
        npoint offset = {d[0], d[1], d[2], d[3]};
        p = np_add(p, offset);
    }

    /* Fac, and Color's green and blue at seeded offsets: all their octaves at once. */
    bool three = color && !nn->as_musgrave;
    octave_layout l = fractal_layout(nn, in);
    npoint pts[3 * MAX_OCTAVES];
    float t[3 * MAX_OCTAVES];
    layout_points(&l, p, pts);
    if (three) {
        layout_points(&l, np_add(p, nn->color_seed[0]), pts + l.count);
        layout_points(&l, np_add(p, nn->color_seed[1]), pts + 2 * l.count);
    }
    nn->mode.perlin_many(pts, three ? 3 * l.count : l.count, t);

    *fac = fractal_value(nn, in, t);
    if (color) {
        if (!three)
            *color = make_float3(*fac, *fac, *fac); /* 3.4's Musgrave: Fac only */
        else
            *color = make_float3(*fac, fractal_value(nn, in, t + l.count),
                                 fractal_value(nn, in, t + 2 * l.count));
    }
}

/* Reads point i's inputs, clamped as the node clamps them, and its noise coordinates.
 * Only the sockets the dimensions make available are read. */
static void read_point(const noise_node *nn, const sg_kernel_args *a, int i, noise_inputs *in,
                       npoint *p)
{
    in->detail = a->in[IN_DETAIL][i];
    in->roughness = a->in[IN_ROUGHNESS][i];
    in->lacunarity = a->in[IN_LACUNARITY][i];
    in->offset = a->in[IN_OFFSET][i];
    in->gain = a->in[IN_GAIN][i];
    in->distortion = a->in[IN_DISTORTION][i];
    /* maxf, not fmaxf: equal for these finite bounds, and inline. The libm call is SSE
     * code that, run after the AVX-512 lanes, cost a fifth of the one-point path. */
    if (!nn->mode.blender3) {
        in->detail = clampf(in->detail, 0.0f, 15.0f);
        in->roughness = maxf(in->roughness, 0.0f);
    } else if (nn->as_musgrave) {
        in->musgrave_octaves = clampf(clampf(in->detail, 0.0f, 15.0f) + 1.0f, 0.0f, 15.0f);
        in->musgrave_H = maxf(musgrave_dimension(in->roughness, in->lacunarity), 1e-5f);
        in->musgrave_lacunarity = maxf(in->lacunarity, 1e-5f);
    }

    int n = a->n, dims = nn->mode.dims;
    float s = a->in[IN_SCALE][i];
    npoint q = {0.0f, 0.0f, 0.0f, 0.0f};
    if (dims == DIMS_1D) {
        q.x = a->in[IN_W][i] * s;
    } else {
        float3 v = f3_load(a->in[IN_VECTOR], n, i);
        q.x = v.x * s;
        q.y = v.y * s;
        if (dims >= DIMS_3D)
            q.z = v.z * s;
        if (dims == DIMS_4D)
            q.w = a->in[IN_W][i] * s;
    }
    *p = q;
}

/* ---- LANES points side by side --------------------------------------------------- */

static inline lane_point lp_add(lane_point p, npoint o)
{
    lane_point r = {p.x + o.x, p.y + o.y, p.z + o.z, p.w + o.w};
    return r;
}

static inline lane_point lp_scale(lane_point p, lane_f s)
{
    lane_point r = {p.x * s, p.y * s, p.z * s, p.w * s};
    return r;
}

/* The LANES points first, first + 1, ... of the batch side by side: what
 * noise_point does for each, with every Perlin evaluation done for all lanes at once.
 * Lanes may have different octave counts (Detail is an input): each octave up to the
 * largest count is evaluated for all lanes, and each lane's fractal combines only its
 * own, serially in Cycles' order, so that every lane's result has the bits of
 * noise_point's. */
static void noise_lanes(const noise_node *nn, const sg_kernel_args *a, int first,
                        float *fac_out, float *color_out)
{
    enum { L = LANES };
    const noise_mode *m = &nn->mode;
    int dims = m->dims, n = a->n;
    noise_inputs in[L];
    lane_point p;
    lane_f distortion;
    for (int k = 0; k < L; k++) {
        npoint q;
        read_point(nn, a, first + k, &in[k], &q);
        p.x[k] = q.x;
        p.y[k] = q.y;
        p.z[k] = q.z;
        p.w[k] = q.w;
        distortion[k] = in[k].distortion;
    }

    /* Distortion: lanes without it keep their point unchanged (noise_point skips it). */
    lane_u distorted = (lane_u)(distortion != 0.0f);
    bool any_distorted = false;
    for (int k = 0; k < L; k++)
        any_distorted |= distorted[k] != 0u;
    if (any_distorted && !nn->as_musgrave) {
        lane_f d[4] = {lane_splat(0.0f), lane_splat(0.0f), lane_splat(0.0f), lane_splat(0.0f)};
        for (int k = 0; k <= dims; k++) {
            lane_point q = lp_add(p, nn->distortion_seed[k]);
            m->perlin_lanes(&q, &d[k]);
            d[k] = m->scale * d[k] * distortion;
        }
        p.x = lane_select(distorted, p.x + d[0], p.x);
        p.y = lane_select(distorted, p.y + d[1], p.y);
        p.z = lane_select(distorted, p.z + d[2], p.z);
        p.w = lane_select(distorted, p.w + d[3], p.w);
    }

    lane_f factor;
    int count[L], most = 0;
    bool fbm = false; /* the same for every lane: a property of the node */
    for (int k = 0; k < L; k++) {
        octave_layout lk = fractal_layout(nn, &in[k]);
        count[k] = lk.count;
        factor[k] = lk.factor;
        fbm = lk.fbm;
        most = lk.count > most ? lk.count : most;
    }

    /* Octave i of set s (Fac; Color's green and blue at their seeds) is t[s][i]. */
    bool three = color_out && !nn->as_musgrave;
    int sets = three ? 3 : 1;
    lane_f t[3][MAX_OCTAVES];
    for (int s = 0; s < sets; s++) {
        lane_point base = s == 0 ? p : lp_add(p, nn->color_seed[s - 1]);
        lane_f fscale = lane_splat(1.0f);
        for (int i = 0; i < most; i++) {
            /* As scaled_points and octave_points step them. */
            lane_point q = fbm ? lp_scale(base, fscale) : base;
            m->perlin_lanes(&q, &t[s][i]);
            if (fbm)
                fscale *= factor;
            else
                base = lp_scale(base, factor);
        }
    }

    /* fBM, the usual case: combined in vector form. */
    if (nn->mode.blender3 ? !nn->as_musgrave : nn->type == TYPE_FBM) {
        lane_f fac, channel;
        lane_fbm(nn, in, t[0], most, &fac);
        for (int k = 0; fac_out && k < L; k++)
            fac_out[first + k] = fac[k];
        for (int s = 0; color_out && s < 3; s++) {
            if (s == 0)
                channel = fac;
            else
                lane_fbm(nn, in, t[s], most, &channel);
            for (int k = 0; k < L; k++)
                color_out[(size_t)s * (size_t)n + (size_t)(first + k)] = channel[k];
        }
        return;
    }

    /* The other fractals, lane by lane with the scalar code. */
    for (int k = 0; k < L; k++) {
        int c = count[k];
        float tk[3 * MAX_OCTAVES];
        for (int s = 0; s < sets; s++)
            for (int i = 0; i < c; i++)
                tk[s * c + i] = t[s][i][k];
        float fac = fractal_value(nn, &in[k], tk);
        if (fac_out)
            fac_out[first + k] = fac;
        if (color_out) {
            float3 color = three ? make_float3(fac, fractal_value(nn, &in[k], tk + c),
                                               fractal_value(nn, &in[k], tk + 2 * c))
                                 : make_float3(fac, fac, fac);
            f3_store(color_out, n, first + k, color);
        }
    }
}

static void tex_noise_kernel(const sg_kernel_args *a)
{
    noise_node nn;
    int dims = a->prop[PROP_DIMENSIONS];
    nn.mode = noise_mode_for(dims, a->blender == SG_BLENDER_3);
    nn.type = a->prop[PROP_TYPE];
    nn.normalize = a->prop[PROP_NORMALIZE] != 0;
    nn.as_musgrave = nn.mode.blender3 && !(nn.type == TYPE_FBM && nn.normalize);

    /* 1D has a single distortion axis and its colour seeds follow it. */
    int n_axes = dims + 1;
    for (int k = 0; k < 4; k++)
        nn.distortion_seed[k] = random_offset(dims, (float)k);
    nn.color_seed[0] = random_offset(dims, (float)n_axes);
    nn.color_seed[1] = random_offset(dims, (float)(n_axes + 1));

    float *fac_out = a->out[0], *color_out = a->out[1];
    int n = a->n, i = 0;
    /* Whole groups of LANES points side by side; the rest (and a one-point batch,
     * as the pointwise evaluator runs) one at a time. Both give the same bits. */
    for (; i + LANES <= n; i += LANES)
        noise_lanes(&nn, a, i, fac_out, color_out);
    for (; i < n; i++) {
        noise_inputs in;
        npoint p;
        read_point(&nn, a, i, &in, &p);
        float fac;
        float3 color;
        noise_point(&nn, p, &in, &fac, color_out ? &color : NULL);
        if (fac_out)
            fac_out[i] = fac;
        if (color_out)
            f3_store(color_out, n, i, color);
    }
}

#define TYPE_BIT(t) (1u << (t))

static const sg_socket_def tex_noise_inputs[] = {
    {"Vector", "Vector", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f, 0.0f}, SG_IMPLICIT_GENERATED,
     DIMS_BIT(DIMS_2D) | DIMS_BIT(DIMS_3D) | DIMS_BIT(DIMS_4D), PROP_DIMENSIONS, 0, 0},
    {"W", "W", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, DIMS_BIT(DIMS_1D) | DIMS_BIT(DIMS_4D),
     PROP_DIMENSIONS, 0, 0},
    {"Scale", "Scale", SG_SOCKET_FLOAT, {5.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Detail", "Detail", SG_SOCKET_FLOAT, {2.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Roughness", "Roughness", SG_SOCKET_FLOAT, {0.5f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Lacunarity", "Lacunarity", SG_SOCKET_FLOAT, {2.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Offset", "Offset", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE,
     TYPE_BIT(TYPE_RIDGED) | TYPE_BIT(TYPE_HYBRID) | TYPE_BIT(TYPE_HETERO), PROP_TYPE, 0, 0},
    {"Gain", "Gain", SG_SOCKET_FLOAT, {1.0f}, SG_IMPLICIT_NONE,
     TYPE_BIT(TYPE_RIDGED) | TYPE_BIT(TYPE_HYBRID), PROP_TYPE, 0, 0},
    {"Distortion", "Distortion", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

static const sg_socket_def tex_noise_outputs[] = {
    {"Fac", "Fac", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Color", "Color", SG_SOCKET_COLOR, {0.0f, 0.0f, 0.0f, 1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

static const sg_prop_def tex_noise_props[] = {
    {"noise_dimensions", SG_PROP_ENUM, noise_dimensions_values, DIMS_3D},
    {"noise_type", SG_PROP_ENUM, noise_type_values, TYPE_FBM},
    {"normalize", SG_PROP_BOOL, NULL, 1},
};

const sg_node_type node_type_tex_noise = {
    "ShaderNodeTexNoise",
    tex_noise_inputs,
    SG_COUNT(tex_noise_inputs),
    tex_noise_outputs,
    SG_COUNT(tex_noise_outputs),
    tex_noise_props,
    SG_COUNT(tex_noise_props),
    tex_noise_kernel,
    0,
};

