/*
 * What the Noise family's files share; internal to shadergraph/kernels. The family
 * follows Cycles' kernel/svm files:
 *
 *   perlin.c         Perlin noise, the primitive (noise.h there)
 *   fractal.c        fBM and the multifractals built of it (fractal_noise.h of 4.3;
 *                    fractal_noise.h and musgrave.h of 3.4)
 *   noise_texture.c  the Noise Texture node (noisetex.h)
 *   white_noise.c    the White Noise Texture node (white_noise.h)
 *
 * Bit-closeness. Blender's x86-64 builds run Cycles' AVX2 kernel on any CPU that has
 * it, and that kernel is compiled by GCC with FMA enabled and the C++ default of
 * -ffp-contract=fast, so every `a * b + c` whose product feeds the sum directly becomes
 * one fused multiply-add there. The project compiles with -ffp-contract=off, so these
 * files write the fusions out with madd exactly where that kernel has them; everything
 * else is plain float arithmetic in Cycles' order.
 *
 * Speed. A point's fractal octaves (and Color's two extra fractals) are independent
 * Perlin evaluations at points known in advance, so each point first lays out all its
 * octave points, has their noise computed LANES points at a time (noise_mode.perlin_many),
 * and then combines the values serially in Cycles' order. Whole groups of a batch are
 * instead evaluated LANES shading points side by side (noise_mode.perlin_lanes). Lanes
 * do exactly the scalar operations (lanes.h), so every path gives the same bits.
 */
#ifndef IMSYNTH_KERNELS_NOISE_H
#define IMSYNTH_KERNELS_NOISE_H

#include <stdbool.h>

#include "shadergraph/kernels/lanes.h"

/* The noise_dimensions property of both nodes (noise_texture.c). */
extern const char *const noise_dimensions_values[];
enum { DIMS_1D, DIMS_2D, DIMS_3D, DIMS_4D };
#define DIMS_BIT(d) (1u << (d))

/* noise_type, in Blender's RNA order (which is also 3.4's musgrave_type order). */
enum { TYPE_MULTIFRACTAL, TYPE_RIDGED, TYPE_HYBRID, TYPE_FBM, TYPE_HETERO };

/* ---- Perlin noise (perlin.c) ------------------------------------------------------ */

/* A point of 1 to 4 dimensions; 1D uses x only (Blender's W), 2D x and y, 3D x, y, z. */
typedef struct npoint {
    float x, y, z, w;
} npoint;

/* LANES points; unused axes are ignored. */
typedef struct lane_point {
    lane_f x, y, z, w;
} lane_point;

static inline npoint np_scale(npoint p, float s)
{
    npoint r = {p.x * s, p.y * s, p.z * s, p.w * s};
    return r;
}
static inline npoint np_add(npoint a, npoint b)
{
    npoint r = {a.x + b.x, a.y + b.y, a.z + b.z, a.w + b.w};
    return r;
}

/* How a node evaluates noise: dimensions and Blender version, constant per node. */
typedef struct noise_mode {
    int dims;
    bool blender3;
    /* Unscaled Perlin noise of `count` points. */
    void (*perlin_many)(const npoint *pts, int count, float *out);
    /* Unscaled Perlin noise of LANES points side by side. */
    void (*perlin_lanes)(const lane_point *p, lane_f *out);
    float scale; /* Cycles' noise_scale1..4: maps Perlin noise to about [-1, 1] */
} noise_mode;

noise_mode noise_mode_for(int dims, bool blender3);

/* ---- fractals (fractal.c) --------------------------------------------------------- */

/* What a Noise Texture node computes, constant per node. */
typedef struct noise_node {
    noise_mode mode;
    int type;
    bool normalize;
    /* Blender 3.x: which 3.4 node blender/compat_noise.py builds for it (3.4's Noise
     * Texture knows only normalized fBM with lacunarity 2; all else is a Musgrave). */
    bool as_musgrave;
    npoint distortion_seed[4]; /* per axis */
    npoint color_seed[2];      /* green, blue */
} noise_node;

/* One point's inputs, clamped as the node clamps them. */
typedef struct noise_inputs {
    float detail, roughness, lacunarity, offset, gain, distortion;
    /* Blender 3.x, Musgrave translation: the translated node's inputs after 3.4's own
     * clamps (compat_noise.py: Detail + 1, Dimension from Roughness and Lacunarity). */
    float musgrave_octaves, musgrave_H, musgrave_lacunarity;
} noise_inputs;

/* 4.x: Detail <= 15, so at most 16 octaves and a fractional one; 3.x: at most 16. */
#define MAX_OCTAVES 17

/* Where a fractal's octaves are evaluated: `count` points, either fscale * p with
 * fscale = 1, factor, factor^2, ... (the fBMs) or p, p * factor, ... (the others). */
typedef struct octave_layout {
    int count;
    bool fbm;
    float factor;
} octave_layout;

/* p, p * lacunarity, (p * lacunarity) * lacunarity, ...: Cycles' `p *= lacunarity`. */
static inline void octave_points(npoint p, float lacunarity, int count, npoint *pts)
{
    for (int i = 0; i < count; i++) {
        pts[i] = p;
        p = np_scale(p, lacunarity);
    }
}

/* fscale * p with fscale = 1, f, f * f, ...: Cycles' fBM loops. */
static inline void scaled_points(npoint p, float factor, int count, npoint *pts)
{
    float fscale = 1.0f;
    for (int i = 0; i < count; i++) {
        pts[i] = np_scale(p, fscale);
        fscale *= factor;
    }
}

/* The octaves fractal_value reads for one point's inputs: the points where Cycles' loops
 * call the noise, so it must agree with fractal.c's loop bounds. Inline because it is
 * found per point (Detail is an input). */
static inline octave_layout fractal_layout(const noise_node *nn, const noise_inputs *in)
{
    octave_layout l = {0, false, in->lacunarity};
    if (!nn->mode.blender3) {
        int n = (int)in->detail;
        bool frac = in->detail - floorf(in->detail) != 0.0f;
        l.fbm = nn->type == TYPE_FBM;
        l.count = n + 1 + (frac && nn->type != TYPE_RIDGED);
        return l;
    }
    if (!nn->as_musgrave) {
        float octaves = clampf(in->detail, 0.0f, 15.0f);
        l.fbm = true;
        l.factor = 2.0f;
        l.count = (int)octaves + 1 + (octaves - floorf(octaves) != 0.0f);
        return l;
    }
    /* Musgrave loops run `i < octaves` and evaluate the fractional octave at the next
     * point; hetero terrain and ridged always evaluate the first octave, and ridged has
     * no fractional one. */
    float octaves = in->musgrave_octaves;
    int n = (int)octaves;
    bool frac = octaves - floorf(octaves) != 0.0f;
    bool first_always = nn->type == TYPE_HETERO || nn->type == TYPE_RIDGED;
    l.factor = in->musgrave_lacunarity;
    l.count = (first_always && n < 1 ? 1 : n) + (frac && nn->type != TYPE_RIDGED);
    return l;
}

static inline void layout_points(const octave_layout *l, npoint p, npoint *pts)
{
    if (l->fbm)
        scaled_points(p, l->factor, l->count, pts);
    else
        octave_points(p, l->factor, l->count, pts);
}

/* The node's fractal from the Perlin values t of its layout's points. */
float fractal_value(const noise_node *nn, const noise_inputs *in, const float *t);

/* The fBM of fractal_value (4.x's, or 3.4's Noise Texture's) for LANES points at once,
 * lane k from in[k] and the values t[i][k] of octaves i < most. */
void lane_fbm(const noise_node *nn, const noise_inputs *in, const lane_f *t, int most,
              lane_f *value);

#endif
