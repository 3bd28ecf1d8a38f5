/*
 * The kernel math vocabulary: the few helpers of Cycles' util/math*.h that the node
 * kernels (shadergraph/kernels/) and the path tracer (render/) both need, under Cycles'
 * names and with the rounding Blender's x86-64 Cycles gives them. Everything is static
 * inline and pure.
 *
 * Why a second header in shadergraph/. Each folder has one public header (DESIGN.md);
 * this one is not part of the graph API (shadergraph.h) but the arithmetic that the
 * graph kernels and the renderer must share so that the same Cycles function rounds the
 * same way in both. render already depends on shadergraph, so it lives here; it knows
 * nothing of graphs, and nothing in it may depend on the rest of the library.
 *
 * Names. Where a Cycles function has one rounding, it keeps its Cycles name (for floats,
 * with Cycles' `f` suffix where C needs one: min/max/clamp become minf/maxf/clampf).
 * Where the same Cycles source rounds two ways in Blender's build, the name says which:
 *
 *   mix(a, b, t)        a + t * (b - a), the product rounded before the sum: Cycles'
 *                       mix() and interp() as written, and as its SSE float3 operators
 *                       compute them (the Mix node's blends; the Principled BSDF).
 *   mix_fused(a, b, t)  fmaf(t, b - a, a): the same mix() where Blender's AVX2 kernel
 *                       (GCC, -ffp-contract=fast) contracts the product into the sum
 *                       (scalar code: Noise, Voronoi).
 *   madd(a, b, c)       fmaf(a, b, c): any `a * b + c` that the AVX2 kernel fuses.
 *
 * This project compiles with -ffp-contract=off, so nothing here is fused unless it says
 * so. Which variant a kernel needs is a property of the Cycles code it reproduces and is
 * proved by the Blender references (tests/reference/nodes), not chosen for accuracy.
 *
 * NaN. Cycles' min/max/clamp are comparisons, so a NaN first operand yields the second
 * (maxf(NaN, 0) = 0, and clampf(NaN, lo, hi) = lo), unlike fminf/fmaxf, which ignore a
 * quiet NaN in either operand and return a NaN for a signalling one. With finite bounds
 * the two agree on every input except signalling NaNs, which no arithmetic produces
 * and no graph, parameter or scene file can hold (JSON has no NaN), and zeros of
 * opposite signs: maxf(-0, +0) is its second operand, +0, while fmaxf may return either
 * (GCC's inline expansion gives -0 here, glibc's function +0), so clampf(-0, 0, 1) is +0
 * where fminf(fmaxf(-0, 0), 1) can be -0. Hence neither replaces the other unproved.
 *
 * Vectors. float3 is the one vector type of the kernels, the BSDF and the renderer's
 * geometry (points, directions, normals, texture coordinates); colours stay float[3]
 * arrays, worked on channel by channel, and so do the planar batches of the evaluator
 * and the float arrays of Embree's API. The f3_* operations are Cycles' float3
 * operators spelt as C functions (f3_dot = dot, f3_length = len, f3_neg = unary -),
 * unfused, with dot's sum (x + y) + z as _mm_dp_ps rounds it. A chain of them rounds
 * as the same expression written per component: f3_add(f3_add(a, f3_scale(b, s)), c) is
 * (a + b s) + c in each channel.
 */
#ifndef IMSYNTH_KERNEL_MATH_H
#define IMSYNTH_KERNEL_MATH_H

#include <math.h>
#include <stdbool.h>

/* ---- scalars ----------------------------------------------------------------------- */

static inline float madd(float a, float b, float c) { return fmaf(a, b, c); }

static inline float mix(float a, float b, float t) { return a + t * (b - a); }
static inline float mix_fused(float a, float b, float t) { return madd(t, b - a, a); }

static inline float minf(float a, float b) { return (a < b) ? a : b; }
static inline float maxf(float a, float b) { return (a > b) ? a : b; }
static inline float clampf(float a, float lo, float hi) { return minf(maxf(a, lo), hi); }
static inline float saturatef(float a) { return clampf(a, 0.0f, 1.0f); }

static inline float sqr(float a) { return a * a; }
static inline float safe_sqrtf(float a) { return sqrtf(maxf(a, 0.0f)); }
static inline float safe_divide(float a, float b) { return b != 0.0f ? a / b : 0.0f; }
/* Cycles' signf: -1 for negative numbers, 1 otherwise (0, -0 and NaN included). */
static inline float signf(float a) { return a < 0.0f ? -1.0f : 1.0f; }
static inline float fractf(float a) { return a - floorf(a); }

/* ---- float3 ------------------------------------------------------------------------ */

typedef struct float3 {
    float x, y, z;
} float3;

static inline float3 make_float3(float x, float y, float z)
{
    float3 r = {x, y, z};
    return r;
}
static inline float3 f3_add(float3 a, float3 b) { return make_float3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline float3 f3_sub(float3 a, float3 b) { return make_float3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline float3 f3_mul(float3 a, float3 b) { return make_float3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline float3 f3_scale(float3 a, float s) { return make_float3(a.x * s, a.y * s, a.z * s); }
static inline float3 f3_neg(float3 a) { return make_float3(-a.x, -a.y, -a.z); }
/* Cycles' isequal: every component compares equal (so -0 equals 0, and NaN nothing). */
static inline bool f3_isequal(float3 a, float3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
static inline float f3_dot(float3 a, float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline float3 f3_cross(float3 a, float3 b)
{
    return make_float3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float f3_length(float3 a) { return sqrtf(f3_dot(a, a)); }

/* Cycles' normalize with SSE4.1: a divided by its length (NaN for a zero vector). */
static inline float3 normalize(float3 a)
{
    float l = f3_length(a);
    return make_float3(a.x / l, a.y / l, a.z / l);
}

/* Cycles' safe_normalize: a times the reciprocal of its length, or a if that is 0. */
static inline float3 safe_normalize(float3 a)
{
    float l = f3_length(a);
    return l != 0.0f ? f3_scale(a, 1.0f / l) : a;
}

/* Cycles' safe_normalize_len, rounding alike (a divided by its length, which *len gets),
 * but a stays as it is unless the length is positive: Cycles tests != 0, so a NaN length
 * (a NaN component) would make every component NaN there. */
static inline float3 f3_normalize_len(float3 a, float *len)
{
    float l = f3_length(a);
    *len = l;
    return l > 0.0f ? make_float3(a.x / l, a.y / l, a.z / l) : a;
}

/* Between float3 and the float[3] of interfaces that keep arrays (colour-like data,
 * scene files, Embree's buffers). */
static inline float3 f3_from_floats(const float a[3]) { return make_float3(a[0], a[1], a[2]); }
static inline void f3_to_floats(float3 v, float a[3])
{
    a[0] = v.x;
    a[1] = v.y;
    a[2] = v.z;
}

/* ---- ensure_valid_reflection (Blender 3.x) --------------------------------------------
 * Cycles 3.x keeps a shading normal N from reflecting the view direction I below the
 * surface: if the mirror reflection R of I about N dips below a small threshold above
 * the geometric normal Ng, N is rotated towards Ng, in the plane of N and Ng, just far
 * enough that dot(Ng, R) reaches the threshold. Solving that for the rotated normal
 * gives up to two candidates; the valid one whose reflection is shallower wins, and Ng
 * if neither is valid. 3.4's Bump node applies it (kernels/geometry.c), and so does its
 * closure setup for every BSDF normal (render/bsdf_principled.c). */

/* R's height above the surface that N must give, or a value >= it when N is fine. */
static inline float valid_reflection_threshold(float3 Ng, float3 I)
{
    return fminf(0.9f * f3_dot(Ng, I), 0.01f);
}
static inline bool reflection_is_valid(float3 Ng, float3 I, float3 N, float threshold)
{
    float3 R = f3_sub(f3_scale(N, 2.0f * f3_dot(N, I)), I);
    return f3_dot(Ng, R) >= threshold;
}

/* The rotated normal, given X: the unit vector along N's component perpendicular to Ng. */
static inline float3 valid_reflection_in_plane(float3 Ng, float3 I, float3 X, float threshold)
{
    float Ix = f3_dot(I, X), Iz = f3_dot(I, Ng);
    float Ix2 = Ix * Ix, Iz2 = Iz * Iz;
    float a = Ix2 + Iz2;
    float b = safe_sqrtf(Ix2 * (a - threshold * threshold));
    float c = Iz * threshold + a;
    float fac = 0.5f / a;
    float N1_z2 = fac * (b + c), N2_z2 = fac * (-b + c);
    bool valid1 = N1_z2 > 1e-5f && N1_z2 <= 1.0f + 1e-5f;
    bool valid2 = N2_z2 > 1e-5f && N2_z2 <= 1.0f + 1e-5f;
    float nx, nz;
    if (valid1 && valid2) {
        float n1x = safe_sqrtf(1.0f - N1_z2), n1z = safe_sqrtf(N1_z2);
        float n2x = safe_sqrtf(1.0f - N2_z2), n2z = safe_sqrtf(N2_z2);
        float R1 = 2.0f * (n1x * Ix + n1z * Iz) * n1z - Iz;
        float R2 = 2.0f * (n2x * Ix + n2z * Iz) * n2z - Iz;
        valid1 = R1 >= 1e-5f;
        valid2 = R2 >= 1e-5f;
        bool pick1 = (valid1 && valid2) ? (R1 < R2) : (R1 > R2);
        nx = pick1 ? n1x : n2x;
        nz = pick1 ? n1z : n2z;
    } else if (valid1 || valid2) {
        float z2 = valid1 ? N1_z2 : N2_z2;
        nx = safe_sqrtf(1.0f - z2);
        nz = safe_sqrtf(z2);
    } else {
        return Ng;
    }
    return f3_add(f3_scale(X, nx), f3_scale(Ng, nz));
}

/* Cycles 3.4's ensure_valid_reflection, bit for bit (its SSE4.1 normalize divides). */
static inline float3 ensure_valid_reflection(float3 Ng, float3 I, float3 N)
{
    float threshold = valid_reflection_threshold(Ng, I);
    if (reflection_is_valid(Ng, I, N, threshold))
        return N;
    float3 X = normalize(f3_sub(N, f3_scale(Ng, f3_dot(N, Ng))));
    return valid_reflection_in_plane(Ng, I, X, threshold);
}

#endif
