/*
 * Noise Texture and White Noise Texture, as Cycles evaluates them.
 *
 * Sources of truth: Cycles' kernel/svm/noise.h (Perlin noise), fractal_noise.h and
 * noisetex.h (the Noise Texture node) and white_noise.h, in Blender 4.3 for the default
 * mode; in Blender 3.4 for SG_BLENDER_3, plus 3.4's musgrave.h (see below).
 *
 * Bit-closeness. Blender's x86-64 builds run Cycles' AVX2 kernel on any CPU that has
 * it, and that kernel is compiled by GCC with FMA enabled and the C++ default of
 * -ffp-contract=fast, so every `a * b + c` whose product feeds the sum directly becomes
 * one fused multiply-add there. The project compiles with -ffp-contract=off, so the
 * fusions are written out here with fmaf() (madd) exactly where that kernel has them;
 * everything else is plain float arithmetic in Cycles' order. The SIMD Perlin code
 * interpolates along x, then y, then z (4D: w first); the fade polynomial uses the
 * SIMD form (t*t)*(t*b) for 2D-4D and the scalar form for 1D, as Cycles does.
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
 * Speed. A point's fractal octaves (and Color's two extra fractals) are independent
 * Perlin evaluations at points known in advance, so each point first lays out all its
 * octave points, has their noise computed eight points to an AVX vector (3D), and then
 * combines the values serially in Cycles' order. Lanes do exactly the scalar operations,
 * so results are the same bits as one point at a time. That is the path of one-point
 * batches (the pointwise evaluator) and of a batch's last few points; whole groups of a
 * batch are evaluated 16 shading points side by side instead (8 without AVX-512: see
 * noise_lanes), again with the scalar operations per lane, which tests/unit/
 * test_noise_batch.c checks bit for bit.
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>
#if (defined(__FMA__) && defined(__AVX__)) || defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "shadergraph/kernels/kernel_util.h"
#include "shadergraph/node_type.h"

/* Without AVX, GCC warns (-Wpsabi) that functions taking or returning 32-byte vectors
 * have no agreed ABI; every such function here is static, so no call crosses the file.
 * The pragma must precede the first of them. */
#if defined(__GNUC__) && !defined(__clang__) && !defined(__AVX__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

/* ---- properties ------------------------------------------------------------------ */

static const char *const noise_dimensions_values[] = {"1D", "2D", "3D", "4D", NULL};
enum { DIMS_1D, DIMS_2D, DIMS_3D, DIMS_4D };

/* Blender's RNA order (which is also 3.4's musgrave_type order). */
static const char *const noise_type_values[] = {"MULTIFRACTAL", "RIDGED_MULTIFRACTAL",
                                                "HYBRID_MULTIFRACTAL", "FBM",
                                                "HETERO_TERRAIN", NULL};
enum { TYPE_MULTIFRACTAL, TYPE_RIDGED, TYPE_HYBRID, TYPE_FBM, TYPE_HETERO };

/* ---- float helpers with Cycles' rounding ----------------------------------------- */

/* madd (a product that the AVX2 kernel fuses into the following sum), mix_fused (Cycles'
 * mix(a, b, t) = a + t * (b - a) as that kernel fuses it) and clampf (Cycles' clamp) are
 * shadergraph/kernel_math.h's. */

/* The SIMD mix of Cycles' vector Perlin code: 4.x's float4 mix is a + t * (b - a), fused;
 * 3.4's ssef mix was madd(t, b, (1 - t) * a). */
static inline float simd_mix(float a, float b, float t, bool blender3)
{
    return blender3 ? madd(t, b, (1.0f - t) * a) : mix_fused(a, b, t);
}

/* floor and fraction; the integer part is what cvttss2si/cvttps2dq produce, which is
 * INT32_MIN ("integer indefinite") for NaN and anything outside int32 range. Blender
 * 3.4 has no wrapping of large coordinates, so that case is reachable there. */
static inline float floor_frac(float x, int32_t *i)
{
    float f = floorf(x);
    *i = (f >= -2147483648.0f && f < 2147483648.0f) ? (int32_t)f : INT32_MIN;
    return x - f;
}

/* ---- Perlin noise ---------------------------------------------------------------- */

static inline float fade_scalar(float t)
{
    return t * t * t * madd(t, madd(t, 6.0f, -15.0f), 10.0f);
}

static inline float fade_simd(float t)
{
    float b = madd(t, madd(t, 6.0f, -15.0f), 10.0f);
    return (t * t) * (t * b);
}

/* The gradient functions pick and negate by hash bits, which are random: written as
 * bit operations (as Cycles' SIMD code does) rather than branches the CPU would mispredict
 * half the time. Flipping the sign bit is exactly negation. */
static inline float negate_if(float v, uint32_t condition)
{
    uint32_t u = float_bits(v) ^ ((uint32_t)(condition != 0u) << 31);
    float r;
    memcpy(&r, &u, sizeof r);
    return r;
}

static inline float select_if(uint32_t condition, float a, float b)
{
    uint32_t mask = 0u - (uint32_t)(condition != 0u);
    uint32_t u = (float_bits(a) & mask) | (float_bits(b) & ~mask);
    float r;
    memcpy(&r, &u, sizeof r);
    return r;
}

static inline float grad1(uint32_t hash, float x)
{
    uint32_t h = hash & 15u;
    float g = (float)(1u + (h & 7u));
    return negate_if(g, h & 8u) * x;
}

static inline float grad2(uint32_t hash, float x, float y)
{
    uint32_t h = hash & 7u;
    float u = select_if(h < 4u, x, y);
    float v = 2.0f * select_if(h < 4u, y, x);
    return negate_if(u, h & 1u) + negate_if(v, h & 2u);
}

/* Always inlined into the per-version wrappers below, so that `b3` is a
 * constant in each. */
#if defined(__GNUC__)
#define NOISE_INLINE static inline __attribute__((always_inline))
#else
#define NOISE_INLINE static inline
#endif

NOISE_INLINE float perlin_1d(float x)
{
    int32_t ix;
    float fx = floor_frac(x, &ix);
    uint32_t X = (uint32_t)ix;
    float u = fade_scalar(fx);
    /* mix(a, b, u) = a + u * (b - a) with a = g0 * fx and b = g1 * (fx - 1): the product
     * a fuses into both of its sums, b stays a product. */
    float g0 = grad1(hash_uint(X), 1.0f), g1 = grad1(hash_uint(X + 1u), 1.0f);
    float b = g1 * (fx - 1.0f);
    return madd(g0, fx, u * madd(-g0, fx, b));
}

NOISE_INLINE float perlin_2d(float x, float y, bool b3)
{
    int32_t ix, iy;
    float fx = floor_frac(x, &ix), fy = floor_frac(y, &iy);
    uint32_t X = (uint32_t)ix, Y = (uint32_t)iy;
    float u = fade_simd(fx), v = fade_simd(fy);
    float fx1 = fx - 1.0f, fy1 = fy - 1.0f;

    float g00 = grad2(hash_uint2(X, Y), fx, fy);
    float g01 = grad2(hash_uint2(X, Y + 1u), fx, fy1);
    float g10 = grad2(hash_uint2(X + 1u, Y), fx1, fy);
    float g11 = grad2(hash_uint2(X + 1u, Y + 1u), fx1, fy1);
    return simd_mix(simd_mix(g00, g10, u, b3), simd_mix(g01, g11, u, b3), v, b3);
}

/* The 3D and 4D gradients of a cell's corners, eight lanes at once as Cycles' AVX2 code
 * computes them (GCC/Clang vector extensions; the lane arithmetic is exactly the scalar
 * arithmetic, so this is only faster, not different). */
typedef uint32_t u32x8 __attribute__((vector_size(32)));
typedef float f32x8 __attribute__((vector_size(32)));

NOISE_INLINE u32x8 hash_uint3_x8(u32x8 kx, u32x8 ky, u32x8 kz)
{
    u32x8 a, b, c;
    a = b = c = (u32x8){0} + (0xdeadbeefu + (3u << 2) + 13u);
    c += kz;
    b += ky;
    a += kx;
    HASH_FINAL(a, b, c);
    return c;
}

NOISE_INLINE f32x8 select8(u32x8 mask, f32x8 a, f32x8 b)
{
    return (f32x8)(((u32x8)a & mask) | ((u32x8)b & ~mask));
}

/* Cycles' 3D gradient (hash picks two of x, y, z and their signs), per lane. */
NOISE_INLINE f32x8 grad3_x8(u32x8 hash, f32x8 x, f32x8 y, f32x8 z)
{
    u32x8 h = hash & 15u;
    f32x8 u = select8((u32x8)(h < 8u), x, y);
    f32x8 vt = select8((u32x8)((h == 12u) | (h == 14u)), x, z);
    f32x8 v = select8((u32x8)(h < 4u), y, vt);
    u32x8 su = (h & 1u) << 31, sv = (h & 2u) << 30;
    return (f32x8)((u32x8)u ^ su) + (f32x8)((u32x8)v ^ sv);
}

NOISE_INLINE u32x8 hash_uint4_x8(u32x8 kx, u32x8 ky, u32x8 kz, u32x8 kw)
{
    u32x8 a, b, c;
    a = b = c = (u32x8){0} + (0xdeadbeefu + (4u << 2) + 13u);
    a += kx;
    b += ky;
    c += kz;
    HASH_MIX(a, b, c);
    a += kw;
    HASH_FINAL(a, b, c);
    return c;
}

NOISE_INLINE f32x8 grad4_x8(u32x8 hash, f32x8 x, f32x8 y, f32x8 z, f32x8 w)
{
    u32x8 h = hash & 31u;
    f32x8 u = select8((u32x8)(h < 24u), x, y);
    f32x8 v = select8((u32x8)(h < 16u), y, z);
    f32x8 s = select8((u32x8)(h < 8u), z, w);
    return (f32x8)((u32x8)u ^ ((h & 1u) << 31)) + (f32x8)((u32x8)v ^ ((h & 2u) << 30)) +
           (f32x8)((u32x8)s ^ ((h & 4u) << 29));
}

NOISE_INLINE float perlin_3d(float x, float y, float z, bool b3)
{
    int32_t ix, iy, iz;
    float fx = floor_frac(x, &ix), fy = floor_frac(y, &iy), fz = floor_frac(z, &iz);
    uint32_t X = (uint32_t)ix, Y = (uint32_t)iy, Z = (uint32_t)iz;
    float u = fade_simd(fx), v = fade_simd(fy), w = fade_simd(fz);
    float fx1 = fx - 1.0f, fy1 = fy - 1.0f, fz1 = fz - 1.0f;

    /* Lane k is corner (k >> 2, (k >> 1) & 1, k & 1). */
    u32x8 cx = {X, X, X, X, X + 1u, X + 1u, X + 1u, X + 1u};
    u32x8 cy = {Y, Y, Y + 1u, Y + 1u, Y, Y, Y + 1u, Y + 1u};
    u32x8 cz = {Z, Z + 1u, Z, Z + 1u, Z, Z + 1u, Z, Z + 1u};
    f32x8 px = {fx, fx, fx, fx, fx1, fx1, fx1, fx1};
    f32x8 py = {fy, fy, fy1, fy1, fy, fy, fy1, fy1};
    f32x8 pz = {fz, fz1, fz, fz1, fz, fz1, fz, fz1};
    f32x8 g = grad3_x8(hash_uint3_x8(cx, cy, cz), px, py, pz);

    /* x first, then y, then z. */
    float s00 = simd_mix(g[0], g[4], u, b3);
    float s01 = simd_mix(g[1], g[5], u, b3);
    float s10 = simd_mix(g[2], g[6], u, b3);
    float s11 = simd_mix(g[3], g[7], u, b3);
    return simd_mix(simd_mix(s00, s10, v, b3), simd_mix(s01, s11, v, b3), w, b3);
}

NOISE_INLINE float perlin_4d(float x, float y, float z, float w, bool b3)
{
    int32_t ix, iy, iz, iw;
    float fx = floor_frac(x, &ix), fy = floor_frac(y, &iy), fz = floor_frac(z, &iz),
          fw = floor_frac(w, &iw);
    uint32_t X = (uint32_t)ix, Y = (uint32_t)iy, Z = (uint32_t)iz, W = (uint32_t)iw;
    float u = fade_simd(fx), v = fade_simd(fy), s = fade_simd(fz), t = fade_simd(fw);
    float fx1 = fx - 1.0f, fy1 = fy - 1.0f, fz1 = fz - 1.0f, fw1 = fw - 1.0f;

    /* Lane k of both vectors is corner (k >> 2, (k >> 1) & 1, k & 1) in x, y, z; the
     * first vector at W, the second at W + 1. */
    u32x8 cx = {X, X, X, X, X + 1u, X + 1u, X + 1u, X + 1u};
    u32x8 cy = {Y, Y, Y + 1u, Y + 1u, Y, Y, Y + 1u, Y + 1u};
    u32x8 cz = {Z, Z + 1u, Z, Z + 1u, Z, Z + 1u, Z, Z + 1u};
    f32x8 px = {fx, fx, fx, fx, fx1, fx1, fx1, fx1};
    f32x8 py = {fy, fy, fy1, fy1, fy, fy, fy1, fy1};
    f32x8 pz = {fz, fz1, fz, fz1, fz, fz1, fz, fz1};
    f32x8 g0 = grad4_x8(hash_uint4_x8(cx, cy, cz, (u32x8){0} + W), px, py, pz,
                        (f32x8){0} + fw);
    f32x8 g1 = grad4_x8(hash_uint4_x8(cx, cy, cz, (u32x8){0} + (W + 1u)), px, py, pz,
                        (f32x8){0} + fw1);

    /* w first, then x, y, z (Cycles' AVX quad_mix). */
    float m[8];
    for (int k = 0; k < 8; k++)
        m[k] = simd_mix(g0[k], g1[k], t, b3);
    float s00 = simd_mix(m[0], m[4], u, b3);
    float s01 = simd_mix(m[1], m[5], u, b3);
    float s10 = simd_mix(m[2], m[6], u, b3);
    float s11 = simd_mix(m[3], m[7], u, b3);
    return simd_mix(simd_mix(s00, s10, v, b3), simd_mix(s01, s11, v, b3), s, b3);
}

/* ---- signed noise of a 1-4D point, per Blender version --------------------------- */

/* A point of 1 to 4 dimensions; 1D uses x only (Blender's W), 2D x and y, 3D x, y, z. */
typedef struct npoint {
    float x, y, z, w;
} npoint;

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

/* Blender 4.x repeats noise every 100000 on each axis to keep float precision, and
 * shifts coordinates at or beyond 1e6 by half a cell (Cycles: "precision correction"). */
static inline float wrap_coordinate(float p)
{
    if (fabsf(p) < 100000.0f)
        return p; /* what fmodf returns, without the call */
    float correction = 0.5f * (float)(fabsf(p) >= 1000000.0f);
    return fmodf(p, 100000.0f) + correction;
}

/* Blender 3.x replaces a non-finite Perlin value (from non-finite coordinates) by 0. */
static inline float finite_or_zero(float v) { return isfinite(v) ? v : 0.0f; }

/* Unscaled Perlin noise of a point, one function per dimensions and Blender version so
 * that the version's choices are constants inside each. */
static float perlin_1d_v4(npoint p) { return perlin_1d(wrap_coordinate(p.x)); }
static float perlin_2d_v4(npoint p)
{
    return perlin_2d(wrap_coordinate(p.x), wrap_coordinate(p.y), false);
}
static float perlin_3d_v4(npoint p)
{
    return perlin_3d(wrap_coordinate(p.x), wrap_coordinate(p.y), wrap_coordinate(p.z), false);
}
static float perlin_4d_v4(npoint p)
{
    return perlin_4d(wrap_coordinate(p.x), wrap_coordinate(p.y), wrap_coordinate(p.z),
                     wrap_coordinate(p.w), false);
}
static float perlin_1d_v3(npoint p) { return finite_or_zero(perlin_1d(p.x)); }
static float perlin_2d_v3(npoint p) { return finite_or_zero(perlin_2d(p.x, p.y, true)); }
static float perlin_3d_v3(npoint p) { return finite_or_zero(perlin_3d(p.x, p.y, p.z, true)); }
static float perlin_4d_v3(npoint p)
{
    return finite_or_zero(perlin_4d(p.x, p.y, p.z, p.w, true));
}

/* ---- Perlin noise of eight points at once (3D) ------------------------------------
 *
 * A fractal's octaves are independent evaluations at known points (the coordinates are
 * scaled serially, the values combined afterwards), so their Perlin noise is computed
 * eight points to a vector. Each lane performs exactly the scalar operations above. */

typedef int32_t i32x8 __attribute__((vector_size(32)));

NOISE_INLINE f32x8 splat8(float v) { return (f32x8){0} + v; }

NOISE_INLINE f32x8 fma8(f32x8 a, f32x8 b, f32x8 c)
{
#if defined(__FMA__) && defined(__AVX__)
    return (f32x8)_mm256_fmadd_ps((__m256)a, (__m256)b, (__m256)c);
#else
    f32x8 r;
    for (int k = 0; k < 8; k++)
        r[k] = fmaf(a[k], b[k], c[k]);
    return r;
#endif
}

/* floor_frac of each lane (see there): conversions are clamped into range first, and
 * selections are masks, so no lane has undefined behaviour. */
NOISE_INLINE f32x8 floor_frac8(f32x8 x, u32x8 *cell)
{
    const f32x8 two23 = splat8(8388608.0f);
    f32x8 xc = select8((u32x8)(x >= -two23), x, -two23);
    xc = select8((u32x8)(xc > two23), two23, xc);
    f32x8 t = __builtin_convertvector(__builtin_convertvector(xc, i32x8), f32x8);
    f32x8 fl = t + __builtin_convertvector((i32x8)(t > xc), f32x8); /* -1 where t > xc */
    f32x8 ax = (f32x8)((u32x8)x & 0x7fffffffu);
    f32x8 f = select8((u32x8)(ax < two23), fl, x);
    f32x8 fc = select8((u32x8)(f >= splat8(-2147483648.0f)), f, splat8(-2147483648.0f));
    fc = select8((u32x8)(fc > splat8(2147483520.0f)), splat8(2147483520.0f), fc);
    u32x8 k = (u32x8)__builtin_convertvector(fc, i32x8);
    u32x8 above = (u32x8)(f >= splat8(2147483648.0f));
    *cell = (k & ~above) | (0x80000000u & above);
    return x - f;
}

NOISE_INLINE f32x8 fade8(f32x8 t)
{
    f32x8 b = fma8(t, fma8(t, splat8(6.0f), splat8(-15.0f)), splat8(10.0f));
    return (t * t) * (t * b);
}

NOISE_INLINE f32x8 simd_mix8(f32x8 a, f32x8 b, f32x8 t, bool b3)
{
    return b3 ? fma8(t, b, (splat8(1.0f) - t) * a) : fma8(t, b - a, a);
}

NOISE_INLINE f32x8 perlin_3d_x8(f32x8 x, f32x8 y, f32x8 z, bool b3)
{
    u32x8 X, Y, Z;
    f32x8 fx = floor_frac8(x, &X), fy = floor_frac8(y, &Y), fz = floor_frac8(z, &Z);
    f32x8 u = fade8(fx), v = fade8(fy), w = fade8(fz);
    f32x8 fx1 = fx - 1.0f, fy1 = fy - 1.0f, fz1 = fz - 1.0f;
    f32x8 g[8];
    for (uint32_t c = 0; c < 8; c++) {
        uint32_t dx = c >> 2, dy = (c >> 1) & 1u, dz = c & 1u;
        g[c] = grad3_x8(hash_uint3_x8(X + dx, Y + dy, Z + dz), dx ? fx1 : fx, dy ? fy1 : fy,
                        dz ? fz1 : fz);
    }
    f32x8 s00 = simd_mix8(g[0], g[4], u, b3), s01 = simd_mix8(g[1], g[5], u, b3);
    f32x8 s10 = simd_mix8(g[2], g[6], u, b3), s11 = simd_mix8(g[3], g[7], u, b3);
    return simd_mix8(simd_mix8(s00, s10, v, b3), simd_mix8(s01, s11, v, b3), w, b3);
}

/* Perlin noise of `count` 3D points, eight at a time (the last group padded with copies
 * of its first point). A group of fewer than 4 points costs less one point at a time
 * (whose corners are vectorized instead). */
NOISE_INLINE void perlin_3d_many(const npoint *pts, int count, float *out, bool b3)
{
    for (int first = 0; first < count; first += 8) {
        if (count - first < 4) {
            for (int i = first; i < count; i++)
                out[i] = b3 ? perlin_3d_v3(pts[i]) : perlin_3d_v4(pts[i]);
            break;
        }
        f32x8 x, y, z;
        for (int k = 0; k < 8; k++) {
            npoint q = pts[first + k < count ? first + k : first];
            x[k] = b3 ? q.x : wrap_coordinate(q.x);
            y[k] = b3 ? q.y : wrap_coordinate(q.y);
            z[k] = b3 ? q.z : wrap_coordinate(q.z);
        }
        f32x8 r = perlin_3d_x8(x, y, z, b3);
        for (int k = 0; k < 8 && first + k < count; k++)
            out[first + k] = b3 ? finite_or_zero(r[k]) : r[k];
    }
}

static void perlin_3d_many_v4(const npoint *pts, int count, float *out)
{
    perlin_3d_many(pts, count, out, false);
}
static void perlin_3d_many_v3(const npoint *pts, int count, float *out)
{
    perlin_3d_many(pts, count, out, true);
}

/* ---- Perlin noise of many shading points at once ----------------------------------
 *
 * The batch kernel evaluates NOISE_LANES shading points side by side: lane k holds point
 * k's coordinates and performs exactly the scalar operations of perlin_1d..perlin_4d
 * (the same fused multiply-adds, nothing else contracted, the same order), so each
 * lane's value has the bits of its point evaluated alone. 16 lanes with AVX-512, else 8;
 * without AVX the compiler lowers the vector types to scalar code. */
#if defined(__AVX512F__)
#define NOISE_LANES 16
#else
#define NOISE_LANES 8
#endif
typedef float lane_f __attribute__((vector_size(4 * NOISE_LANES)));
typedef uint32_t lane_u __attribute__((vector_size(4 * NOISE_LANES)));
typedef int32_t lane_i __attribute__((vector_size(4 * NOISE_LANES)));

/* Coordinates of NOISE_LANES points; unused axes are ignored. */
typedef struct lane_point {
    lane_f x, y, z, w;
} lane_point;

NOISE_INLINE lane_f lane_splat(float v) { return (lane_f){0} + v; }
NOISE_INLINE lane_u lane_splat_u(uint32_t v) { return (lane_u){0} + v; }

NOISE_INLINE lane_f lane_fma(lane_f a, lane_f b, lane_f c)
{
#if NOISE_LANES == 16
    return (lane_f)_mm512_fmadd_ps((__m512)a, (__m512)b, (__m512)c);
#elif defined(__FMA__) && defined(__AVX__)
    return (lane_f)_mm256_fmadd_ps((__m256)a, (__m256)b, (__m256)c);
#else
    lane_f r;
    for (int k = 0; k < NOISE_LANES; k++)
        r[k] = fmaf(a[k], b[k], c[k]);
    return r;
#endif
}

/* Lanes of a where mask is all ones, of b where it is zero. */
NOISE_INLINE lane_f lane_select(lane_u mask, lane_f a, lane_f b)
{
    return (lane_f)(((lane_u)a & mask) | ((lane_u)b & ~mask));
}

/* floor_frac of each lane: floor rounds as floorf (keeping -0 and NaN), and the
 * truncating conversion yields INT32_MIN for NaN and out-of-range values, as the scalar
 * code's explicit test does. */
NOISE_INLINE lane_f lane_floor_frac(lane_f x, lane_u *cell)
{
#if NOISE_LANES == 16
    lane_f f = (lane_f)_mm512_roundscale_ps((__m512)x, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    *cell = (lane_u)_mm512_cvttps_epi32((__m512)f);
#elif defined(__AVX__)
    lane_f f = (lane_f)_mm256_floor_ps((__m256)x);
    *cell = (lane_u)_mm256_cvttps_epi32((__m256)f);
#else
    lane_f f;
    for (int k = 0; k < NOISE_LANES; k++) {
        int32_t i;
        (void)floor_frac(x[k], &i);
        (*cell)[k] = (uint32_t)i;
        f[k] = floorf(x[k]);
    }
#endif
    return x - f;
}

NOISE_INLINE lane_f lane_fade_scalar(lane_f t)
{
    return t * t * t * lane_fma(t, lane_fma(t, lane_splat(6.0f), lane_splat(-15.0f)),
                                lane_splat(10.0f));
}

NOISE_INLINE lane_f lane_fade_simd(lane_f t)
{
    lane_f b = lane_fma(t, lane_fma(t, lane_splat(6.0f), lane_splat(-15.0f)), lane_splat(10.0f));
    return (t * t) * (t * b);
}

NOISE_INLINE lane_f lane_mix(lane_f a, lane_f b, lane_f t, bool b3)
{
    return b3 ? lane_fma(t, b, (lane_splat(1.0f) - t) * a) : lane_fma(t, b - a, a);
}

/* hash_uint .. hash_uint4 of kernel_util.h, per lane. */
NOISE_INLINE lane_u lane_hash1(lane_u kx)
{
    lane_u a, b, c;
    a = b = c = lane_splat_u(0xdeadbeefu + (1u << 2) + 13u);
    a += kx;
    HASH_FINAL(a, b, c);
    return c;
}

NOISE_INLINE lane_u lane_hash2(lane_u kx, lane_u ky)
{
    lane_u a, b, c;
    a = b = c = lane_splat_u(0xdeadbeefu + (2u << 2) + 13u);
    b += ky;
    a += kx;
    HASH_FINAL(a, b, c);
    return c;
}

NOISE_INLINE lane_u lane_hash3(lane_u kx, lane_u ky, lane_u kz)
{
    lane_u a, b, c;
    a = b = c = lane_splat_u(0xdeadbeefu + (3u << 2) + 13u);
    c += kz;
    b += ky;
    a += kx;
    HASH_FINAL(a, b, c);
    return c;
}

NOISE_INLINE lane_u lane_hash4(lane_u kx, lane_u ky, lane_u kz, lane_u kw)
{
    lane_u a, b, c;
    a = b = c = lane_splat_u(0xdeadbeefu + (4u << 2) + 13u);
    a += kx;
    b += ky;
    c += kz;
    HASH_MIX(a, b, c);
    a += kw;
    HASH_FINAL(a, b, c);
    return c;
}

/* The gradients of grad1 .. grad4 (sign flips as sign-bit xors). */
NOISE_INLINE lane_f lane_grad1(lane_u hash)
{
    lane_u h = hash & 15u;
    lane_f g = __builtin_convertvector((lane_i)(1u + (h & 7u)), lane_f);
    return (lane_f)((lane_u)g ^ ((h & 8u) << 28));
}

NOISE_INLINE lane_f lane_grad2(lane_u hash, lane_f x, lane_f y)
{
    lane_u h = hash & 7u;
    lane_u first = (lane_u)(h < 4u);
    lane_f u = lane_select(first, x, y);
    lane_f v = 2.0f * lane_select(first, y, x);
    return (lane_f)((lane_u)u ^ ((h & 1u) << 31)) + (lane_f)((lane_u)v ^ ((h & 2u) << 30));
}

NOISE_INLINE lane_f lane_grad3(lane_u hash, lane_f x, lane_f y, lane_f z)
{
#if NOISE_LANES == 16
    /* The same selections with AVX-512 mask registers: a compare and a blend each, where
     * the generic form needs the mask widened into a vector first. */
    const __m512i h = _mm512_and_epi32((__m512i)hash, _mm512_set1_epi32(15));
    const __m512 sign = _mm512_castsi512_ps(_mm512_set1_epi32((int)0x80000000u));
    __m512 u = _mm512_mask_blend_ps(_mm512_cmplt_epu32_mask(h, _mm512_set1_epi32(8)),
                                    (__m512)y, (__m512)x);
    /* h == 12 or h == 14 */
    __mmask16 x_for_v = _mm512_cmpeq_epi32_mask(_mm512_and_epi32(h, _mm512_set1_epi32(13)),
                                                 _mm512_set1_epi32(12));
    __m512 v = _mm512_mask_blend_ps(x_for_v, (__m512)z, (__m512)x);
    v = _mm512_mask_blend_ps(_mm512_cmplt_epu32_mask(h, _mm512_set1_epi32(4)), v, (__m512)y);
    u = _mm512_mask_xor_ps(u, _mm512_test_epi32_mask(h, _mm512_set1_epi32(1)), u, sign);
    v = _mm512_mask_xor_ps(v, _mm512_test_epi32_mask(h, _mm512_set1_epi32(2)), v, sign);
    return (lane_f)u + (lane_f)v;
#else
    lane_u h = hash & 15u;
    lane_f u = lane_select((lane_u)(h < 8u), x, y);
    lane_f vt = lane_select((lane_u)((h == 12u) | (h == 14u)), x, z);
    lane_f v = lane_select((lane_u)(h < 4u), y, vt);
    return (lane_f)((lane_u)u ^ ((h & 1u) << 31)) + (lane_f)((lane_u)v ^ ((h & 2u) << 30));
#endif
}

NOISE_INLINE lane_f lane_grad4(lane_u hash, lane_f x, lane_f y, lane_f z, lane_f w)
{
    lane_u h = hash & 31u;
    lane_f u = lane_select((lane_u)(h < 24u), x, y);
    lane_f v = lane_select((lane_u)(h < 16u), y, z);
    lane_f s = lane_select((lane_u)(h < 8u), z, w);
    return (lane_f)((lane_u)u ^ ((h & 1u) << 31)) + (lane_f)((lane_u)v ^ ((h & 2u) << 30)) +
           (lane_f)((lane_u)s ^ ((h & 4u) << 29));
}

NOISE_INLINE lane_f lane_perlin_1d(lane_f x)
{
    lane_u X;
    lane_f fx = lane_floor_frac(x, &X);
    lane_f u = lane_fade_scalar(fx);
    lane_f g0 = lane_grad1(lane_hash1(X)), g1 = lane_grad1(lane_hash1(X + 1u));
    lane_f b = g1 * (fx - 1.0f);
    return lane_fma(g0, fx, u * lane_fma(-g0, fx, b));
}

NOISE_INLINE lane_f lane_perlin_2d(lane_f x, lane_f y, bool b3)
{
    lane_u X, Y;
    lane_f fx = lane_floor_frac(x, &X), fy = lane_floor_frac(y, &Y);
    lane_f u = lane_fade_simd(fx), v = lane_fade_simd(fy);
    lane_f fx1 = fx - 1.0f, fy1 = fy - 1.0f;
    lane_f g00 = lane_grad2(lane_hash2(X, Y), fx, fy);
    lane_f g01 = lane_grad2(lane_hash2(X, Y + 1u), fx, fy1);
    lane_f g10 = lane_grad2(lane_hash2(X + 1u, Y), fx1, fy);
    lane_f g11 = lane_grad2(lane_hash2(X + 1u, Y + 1u), fx1, fy1);
    return lane_mix(lane_mix(g00, g10, u, b3), lane_mix(g01, g11, u, b3), v, b3);
}

NOISE_INLINE lane_f lane_perlin_3d(lane_f x, lane_f y, lane_f z, bool b3)
{
    lane_u X, Y, Z;
    lane_f fx = lane_floor_frac(x, &X), fy = lane_floor_frac(y, &Y), fz = lane_floor_frac(z, &Z);
    lane_f u = lane_fade_simd(fx), v = lane_fade_simd(fy), w = lane_fade_simd(fz);
    lane_f fx1 = fx - 1.0f, fy1 = fy - 1.0f, fz1 = fz - 1.0f;
    /* Corner c is (c >> 2, (c >> 1) & 1, c & 1), as in perlin_3d. Unrolled, the eight
     * gradients stay in registers (about 10% faster). */
    lane_f g[8];
#pragma GCC unroll 8
    for (uint32_t c = 0; c < 8; c++) {
        uint32_t dx = c >> 2, dy = (c >> 1) & 1u, dz = c & 1u;
        g[c] = lane_grad3(lane_hash3(X + dx, Y + dy, Z + dz), dx ? fx1 : fx, dy ? fy1 : fy,
                          dz ? fz1 : fz);
    }
    lane_f s00 = lane_mix(g[0], g[4], u, b3), s01 = lane_mix(g[1], g[5], u, b3);
    lane_f s10 = lane_mix(g[2], g[6], u, b3), s11 = lane_mix(g[3], g[7], u, b3);
    return lane_mix(lane_mix(s00, s10, v, b3), lane_mix(s01, s11, v, b3), w, b3);
}

NOISE_INLINE lane_f lane_perlin_4d(lane_f x, lane_f y, lane_f z, lane_f w, bool b3)
{
    lane_u X, Y, Z, W;
    lane_f fx = lane_floor_frac(x, &X), fy = lane_floor_frac(y, &Y), fz = lane_floor_frac(z, &Z),
           fw = lane_floor_frac(w, &W);
    lane_f u = lane_fade_simd(fx), v = lane_fade_simd(fy), s = lane_fade_simd(fz),
           t = lane_fade_simd(fw);
    lane_f fx1 = fx - 1.0f, fy1 = fy - 1.0f, fz1 = fz - 1.0f, fw1 = fw - 1.0f;
    /* Corner c in x, y, z as in perlin_4d, mixed along w first. */
    lane_f m[8];
#pragma GCC unroll 8
    for (uint32_t c = 0; c < 8; c++) {
        uint32_t dx = c >> 2, dy = (c >> 1) & 1u, dz = c & 1u;
        lane_u cx = X + dx, cy = Y + dy, cz = Z + dz;
        lane_f px = dx ? fx1 : fx, py = dy ? fy1 : fy, pz = dz ? fz1 : fz;
        lane_f g0 = lane_grad4(lane_hash4(cx, cy, cz, W), px, py, pz, fw);
        lane_f g1 = lane_grad4(lane_hash4(cx, cy, cz, W + 1u), px, py, pz, fw1);
        m[c] = lane_mix(g0, g1, t, b3);
    }
    lane_f s00 = lane_mix(m[0], m[4], u, b3), s01 = lane_mix(m[1], m[5], u, b3);
    lane_f s10 = lane_mix(m[2], m[6], u, b3), s11 = lane_mix(m[3], m[7], u, b3);
    return lane_mix(lane_mix(s00, s10, v, b3), lane_mix(s01, s11, v, b3), s, b3);
}

/* wrap_coordinate per lane; the fmodf of the rare far lanes is done one at a time. */
NOISE_INLINE lane_f lane_wrap(lane_f p)
{
    lane_f magnitude = (lane_f)((lane_u)p & 0x7fffffffu);
#if NOISE_LANES == 16
    if (_mm512_cmp_ps_mask((__m512)magnitude, _mm512_set1_ps(100000.0f), _CMP_LT_OQ) == 0xffff)
        return p;
#else
    lane_u near = (lane_u)(magnitude < 100000.0f);
    uint32_t all_near = ~0u;
    for (int k = 0; k < NOISE_LANES; k++)
        all_near &= near[k];
    if (all_near)
        return p;
#endif
    for (int k = 0; k < NOISE_LANES; k++)
        p[k] = wrap_coordinate(p[k]);
    return p;
}

NOISE_INLINE lane_f lane_finite_or_zero(lane_f v)
{
    lane_f magnitude = (lane_f)((lane_u)v & 0x7fffffffu);
    return lane_select((lane_u)(magnitude < __builtin_inff()), v, lane_splat(0.0f));
}

/* Unscaled Perlin noise of NOISE_LANES points, per dimensions and Blender version (as
 * perlin_1d_v4 .. perlin_4d_v3). */
static void lane_perlin_1d_v4(const lane_point *p, lane_f *out)
{
    *out = lane_perlin_1d(lane_wrap(p->x));
}
static void lane_perlin_2d_v4(const lane_point *p, lane_f *out)
{
    *out = lane_perlin_2d(lane_wrap(p->x), lane_wrap(p->y), false);
}
static void lane_perlin_3d_v4(const lane_point *p, lane_f *out)
{
    *out = lane_perlin_3d(lane_wrap(p->x), lane_wrap(p->y), lane_wrap(p->z), false);
}
static void lane_perlin_4d_v4(const lane_point *p, lane_f *out)
{
    *out = lane_perlin_4d(lane_wrap(p->x), lane_wrap(p->y), lane_wrap(p->z), lane_wrap(p->w),
                          false);
}
static void lane_perlin_1d_v3(const lane_point *p, lane_f *out)
{
    *out = lane_finite_or_zero(lane_perlin_1d(p->x));
}
static void lane_perlin_2d_v3(const lane_point *p, lane_f *out)
{
    *out = lane_finite_or_zero(lane_perlin_2d(p->x, p->y, true));
}
static void lane_perlin_3d_v3(const lane_point *p, lane_f *out)
{
    *out = lane_finite_or_zero(lane_perlin_3d(p->x, p->y, p->z, true));
}
static void lane_perlin_4d_v3(const lane_point *p, lane_f *out)
{
    *out = lane_finite_or_zero(lane_perlin_4d(p->x, p->y, p->z, p->w, true));
}

/* The other dimensions, one point at a time. */
#define PERLIN_MANY(name, one)                                                             \
    static void name(const npoint *pts, int count, float *out)                             \
    {                                                                                      \
        for (int i = 0; i < count; i++)                                                    \
            out[i] = one(pts[i]);                                                          \
    }
PERLIN_MANY(perlin_1d_many_v4, perlin_1d_v4)
PERLIN_MANY(perlin_2d_many_v4, perlin_2d_v4)
PERLIN_MANY(perlin_4d_many_v4, perlin_4d_v4)
PERLIN_MANY(perlin_1d_many_v3, perlin_1d_v3)
PERLIN_MANY(perlin_2d_many_v3, perlin_2d_v3)
PERLIN_MANY(perlin_4d_many_v3, perlin_4d_v3)
#undef PERLIN_MANY

/* How a noise evaluation is done: dimensions and Blender version. Constant per node. */
typedef struct noise_mode {
    int dims;
    bool blender3;
    /* Unscaled Perlin noise of `count` points. */
    void (*perlin_many)(const npoint *pts, int count, float *out);
    /* Unscaled Perlin noise of NOISE_LANES points side by side (the batch path). */
    void (*perlin_lanes)(const lane_point *p, lane_f *out);
    float scale; /* Cycles' noise_scale1..4: maps Perlin noise to about [-1, 1] */
} noise_mode;

static noise_mode noise_mode_for(int dims, bool blender3)
{
    static void (*const many_v4[4])(const npoint *, int, float *) = {
        perlin_1d_many_v4, perlin_2d_many_v4, perlin_3d_many_v4, perlin_4d_many_v4};
    static void (*const many_v3[4])(const npoint *, int, float *) = {
        perlin_1d_many_v3, perlin_2d_many_v3, perlin_3d_many_v3, perlin_4d_many_v3};
    static void (*const lanes_v4[4])(const lane_point *, lane_f *) = {
        lane_perlin_1d_v4, lane_perlin_2d_v4, lane_perlin_3d_v4, lane_perlin_4d_v4};
    static void (*const lanes_v3[4])(const lane_point *, lane_f *) = {
        lane_perlin_1d_v3, lane_perlin_2d_v3, lane_perlin_3d_v3, lane_perlin_4d_v3};
    static const float scales[4] = {0.2500f, 0.6616f, 0.9820f, 0.8344f};
    noise_mode m = {dims, blender3, blender3 ? many_v3[dims] : many_v4[dims],
                    blender3 ? lanes_v3[dims] : lanes_v4[dims], scales[dims]};
    return m;
}

/* ---- fractals ---------------------------------------------------------------------
 *
 * Each fractal first lays out its octaves' points exactly as Cycles steps them, has their
 * Perlin noise computed together (noise_mode.perlin_many), then combines the values in
 * Cycles' order. Octaves Cycles would skip (the hybrid's early exit) may be computed and
 * left unused. */

/* 4.x: Detail <= 15, so at most 16 octaves and a fractional one; 3.x: at most 16. */
#define MAX_OCTAVES 17

/* p, p * lacunarity, (p * lacunarity) * lacunarity, ...: Cycles' `p *= lacunarity`. */
static void octave_points(npoint p, float lacunarity, int count, npoint *pts)
{
    for (int i = 0; i < count; i++) {
        pts[i] = p;
        p = np_scale(p, lacunarity);
    }
}

/* fscale * p with fscale = 1, f, f * f, ...: Cycles' fBM loops. */
static void scaled_points(npoint p, float factor, int count, npoint *pts)
{
    float fscale = 1.0f;
    for (int i = 0; i < count; i++) {
        pts[i] = np_scale(p, fscale);
        fscale *= factor;
    }
}

/* ---- Blender 4.x (fractal_noise.h) ------------------------------------------------ */

/* Lacunarity is not a parameter here: it has placed the octave points already
 * (layout_points), and t holds the noise values there. */

static float fbm4(const noise_mode *m, const float *t, float detail, float roughness,
                  bool normalize)
{
    int n = (int)detail;
    float rmd = detail - floorf(detail);

    float amp = 1.0f, maxamp = 0.0f, sum = 0.0f;
    for (int i = 0; i <= n; i++) {
        sum = madd(m->scale * t[i], amp, sum);
        maxamp += amp;
        amp *= roughness;
    }
    if (rmd != 0.0f) {
        float sum2 = madd(m->scale * t[n + 1], amp, sum);
        if (normalize)
            return mix_fused(0.5f * sum / maxamp + 0.5f, 0.5f * sum2 / (maxamp + amp) + 0.5f, rmd);
        return mix_fused(sum, sum2, rmd);
    }
    return normalize ? 0.5f * sum / maxamp + 0.5f : sum;
}

static float multi_fractal4(const noise_mode *m, const float *t, float detail, float roughness)
{
    int n = (int)detail;
    float rmd = detail - floorf(detail);

    float value = 1.0f, pwr = 1.0f;
    for (int i = 0; i <= n; i++) {
        value *= madd(pwr, m->scale * t[i], 1.0f);
        pwr *= roughness;
    }
    if (rmd != 0.0f)
        value *= madd(rmd * pwr, m->scale * t[n + 1], 1.0f);
    return value;
}

static float hetero_terrain4(const noise_mode *m, const float *t, float detail, float roughness,
                             float offset)
{
    int n = (int)detail;
    float rmd = detail - floorf(detail);

    /* The first octave is unscaled; later ones are scaled by the value so far. In
     * snoise + offset the noise's scaling product fuses into the sum. */
    float pwr = roughness;
    float value = madd(m->scale, t[0], offset);
    for (int i = 1; i <= n; i++) {
        float increment = madd(m->scale, t[i], offset) * pwr;
        value = madd(increment, value, value);
        pwr *= roughness;
    }
    if (rmd != 0.0f) {
        float increment = madd(m->scale, t[n + 1], offset) * pwr * value;
        value = madd(rmd, increment, value);
    }
    return value;
}

static float hybrid_multi_fractal4(const noise_mode *m, const float *t, float detail, float roughness,
                                   float offset, float gain)
{
    int n = (int)detail;
    float rmd = detail - floorf(detail);

    float pwr = 1.0f, value = 0.0f, weight = 1.0f;
    for (int i = 0; weight > 0.001f && i <= n; i++) {
        if (weight > 1.0f)
            weight = 1.0f;
        float signal = madd(m->scale, t[i], offset) * pwr;
        pwr *= roughness;
        value = madd(weight, signal, value);
        weight *= gain * signal;
    }
    if (rmd != 0.0f && weight > 0.001f) {
        if (weight > 1.0f)
            weight = 1.0f;
        float signal = madd(m->scale, t[n + 1], offset) * pwr;
        value = madd(rmd * weight, signal, value);
    }
    return value;
}

static float ridged_multi_fractal4(const noise_mode *m, const float *t, float detail, float roughness,
                                   float offset, float gain)
{
    int n = (int)detail;

    float pwr = roughness;
    float signal = offset - fabsf(m->scale * t[0]);
    signal *= signal;
    float value = signal, weight = 1.0f;
    for (int i = 1; i <= n; i++) {
        weight = clampf(signal * gain, 0.0f, 1.0f);
        signal = offset - fabsf(m->scale * t[i]);
        signal *= signal;
        signal *= weight;
        value = madd(signal, pwr, value);
        pwr *= roughness;
    }
    return value;
}

/* ---- Blender 3.4's Noise Texture fBM (fractal_noise.h of 3.4) --------------------- */

static float fractal_noise3(const noise_mode *m, const float *t, float octaves, float roughness)
{
    octaves = clampf(octaves, 0.0f, 15.0f);
    roughness = clampf(roughness, 0.0f, 1.0f);
    int n = (int)octaves;
    float rmd = octaves - floorf(octaves);

    /* Sums the unsigned noise 0.5 * snoise + 0.5 (fused). */
    float amp = 1.0f, maxamp = 0.0f, sum = 0.0f;
    for (int i = 0; i <= n; i++) {
        sum = madd(madd(0.5f, m->scale * t[i], 0.5f), amp, sum);
        maxamp += amp;
        amp *= roughness;
    }
    if (rmd != 0.0f) {
        float sum2 = madd(madd(0.5f, m->scale * t[n + 1], 0.5f), amp, sum);
        sum /= maxamp;
        sum2 /= maxamp + amp;
        return madd(rmd, sum2, (1.0f - rmd) * sum);
    }
    return sum / maxamp;
}

/* ---- Blender 3.4's Musgrave Texture (musgrave.h of 3.4) -------------------------- */

static float musgrave_fbm3(const noise_mode *m, const float *t, float H, float lacunarity, float octaves)
{
    int n = (int)octaves;
    float value = 0.0f, pwr = 1.0f, pwHL = powf(lacunarity, -H);
    for (int i = 0; i < n; i++) {
        value = madd(m->scale * t[i], pwr, value);
        pwr *= pwHL;
    }
    float rmd = octaves - floorf(octaves);
    if (rmd != 0.0f)
        value = madd(rmd * (m->scale * t[n]), pwr, value);
    return value;
}

static float musgrave_multi_fractal3(const noise_mode *m, const float *t, float H, float lacunarity,
                                     float octaves)
{
    int n = (int)octaves;
    float value = 1.0f, pwr = 1.0f, pwHL = powf(lacunarity, -H);
    for (int i = 0; i < n; i++) {
        value *= madd(pwr, m->scale * t[i], 1.0f);
        pwr *= pwHL;
    }
    float rmd = octaves - floorf(octaves);
    if (rmd != 0.0f)
        value *= madd(rmd * pwr, m->scale * t[n], 1.0f);
    return value;
}

static float musgrave_hetero_terrain3(const noise_mode *m, const float *t, float H, float lacunarity,
                                      float octaves, float offset)
{
    int n = (int)octaves;
    float pwHL = powf(lacunarity, -H), pwr = pwHL;
    float value = madd(m->scale, t[0], offset);
    for (int i = 1; i < n; i++) {
        float increment = madd(m->scale, t[i], offset) * pwr;
        value = madd(increment, value, value);
        pwr *= pwHL;
    }
    float rmd = octaves - floorf(octaves);
    if (rmd != 0.0f) {
        float increment = madd(m->scale, t[n < 1 ? 1 : n], offset) * pwr * value;
        value = madd(rmd, increment, value);
    }
    return value;
}

static float musgrave_hybrid_multi_fractal3(const noise_mode *m, const float *t, float H,
                                            float lacunarity, float octaves, float offset,
                                            float gain)
{
    int n = (int)octaves;
    float pwHL = powf(lacunarity, -H), pwr = 1.0f, value = 0.0f, weight = 1.0f;
    for (int i = 0; weight > 0.001f && i < n; i++) {
        if (weight > 1.0f)
            weight = 1.0f;
        float signal = madd(m->scale, t[i], offset) * pwr;
        pwr *= pwHL;
        value = madd(weight, signal, value);
        weight *= gain * signal;
    }
    float rmd = octaves - floorf(octaves);
    if (rmd != 0.0f && weight > 0.001f) {
        if (weight > 1.0f)
            weight = 1.0f;
        float signal = madd(m->scale, t[n], offset) * pwr;
        value = madd(rmd * weight, signal, value);
    }
    return value;
}

static float musgrave_ridged_multi_fractal3(const noise_mode *m, const float *t, float H,
                                            float lacunarity, float octaves, float offset,
                                            float gain)
{
    int n = (int)octaves;
    float pwHL = powf(lacunarity, -H), pwr = pwHL;
    float signal = offset - fabsf(m->scale * t[0]);
    signal *= signal;
    float value = signal, weight = 1.0f;
    for (int i = 1; i < n; i++) {
        weight = clampf(signal * gain, 0.0f, 1.0f);
        signal = offset - fabsf(m->scale * t[i]);
        signal *= signal;
        signal *= weight;
        value = madd(signal, pwr, value);
        pwr *= pwHL;
    }
    return value;
}

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

/* ---- Noise Texture --------------------------------------------------------------- */

enum {
    IN_VECTOR, IN_W, IN_SCALE, IN_DETAIL, IN_ROUGHNESS, IN_LACUNARITY, IN_OFFSET, IN_GAIN,
    IN_DISTORTION
};
enum { PROP_DIMENSIONS, PROP_TYPE, PROP_NORMALIZE };

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

typedef struct noise_node {
    noise_mode mode;
    int type;
    bool normalize;
    /* Blender 3.x: which 3.4 node the translation builds. */
    bool as_musgrave;
    npoint distortion_seed[4]; /* per axis */
    npoint color_seed[2];      /* green, blue */
} noise_node;

typedef struct noise_inputs {
    float detail, roughness, lacunarity, offset, gain, distortion;
    /* Blender 3.x, Musgrave translation: the translated node's inputs after 3.4's own
     * clamps (compat_noise.py: Detail + 1, Dimension from Roughness and Lacunarity). */
    float musgrave_octaves, musgrave_H, musgrave_lacunarity;
} noise_inputs;

/* Where a fractal's octaves are evaluated: `count` points, either fscale * p with
 * fscale = 1, factor, factor^2, ... (the fBMs) or p, p * factor, ... (the others). */
typedef struct octave_layout {
    int count;
    bool fbm;
    float factor;
} octave_layout;

static octave_layout fractal_layout(const noise_node *nn, const noise_inputs *in)
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

static void layout_points(const octave_layout *l, npoint p, npoint *pts)
{
    if (l->fbm)
        scaled_points(p, l->factor, l->count, pts);
    else
        octave_points(p, l->factor, l->count, pts);
}

/* The node's fractal from the Perlin values t of its octave points. */
static float fractal_value(const noise_node *nn, const noise_inputs *in, const float *t)
{
    const noise_mode *m = &nn->mode;
    if (!m->blender3) {
        switch (nn->type) {
        case TYPE_MULTIFRACTAL:
            return multi_fractal4(m, t, in->detail, in->roughness);
        case TYPE_RIDGED:
            return ridged_multi_fractal4(m, t, in->detail, in->roughness, in->offset, in->gain);
        case TYPE_HYBRID:
            return hybrid_multi_fractal4(m, t, in->detail, in->roughness, in->offset, in->gain);
        case TYPE_HETERO:
            return hetero_terrain4(m, t, in->detail, in->roughness, in->offset);
        default:
            return fbm4(m, t, in->detail, in->roughness, nn->normalize);
        }
    }
    if (!nn->as_musgrave)
        return fractal_noise3(m, t, in->detail, in->roughness);

    float octaves = in->musgrave_octaves, H = in->musgrave_H, lac = in->musgrave_lacunarity;
    switch (nn->type) {
    case TYPE_MULTIFRACTAL: return musgrave_multi_fractal3(m, t, H, lac, octaves);
    case TYPE_RIDGED:
        return musgrave_ridged_multi_fractal3(m, t, H, lac, octaves, in->offset, in->gain);
    case TYPE_HYBRID:
        return musgrave_hybrid_multi_fractal3(m, t, H, lac, octaves, in->offset, in->gain);
    case TYPE_HETERO: return musgrave_hetero_terrain3(m, t, H, lac, octaves, in->offset);
    default: return musgrave_fbm3(m, t, H, lac, octaves);
    }
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
    if (!nn->mode.blender3) {
        in->detail = clampf(in->detail, 0.0f, 15.0f);
        in->roughness = fmaxf(in->roughness, 0.0f);
    } else if (nn->as_musgrave) {
        in->musgrave_octaves = clampf(clampf(in->detail, 0.0f, 15.0f) + 1.0f, 0.0f, 15.0f);
        in->musgrave_H = fmaxf(musgrave_dimension(in->roughness, in->lacunarity), 1e-5f);
        in->musgrave_lacunarity = fmaxf(in->lacunarity, 1e-5f);
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

/* fbm4 (4.x) or fractal_noise3 (3.x's Noise Texture) of every lane at once, from the
 * Perlin values t[i] of octaves i < most: lane k sums its own octaves i <= n_k with the
 * scalar code's operations and takes its fractional octave from t[n_k + 1]; both
 * endings are computed and each lane keeps the one its Detail selects. */
static void lane_fbm(const noise_node *nn, const noise_inputs *in, const lane_f *t, int most,
                     lane_f *value)
{
    const noise_mode *m = &nn->mode;
    lane_i n;
    lane_f rmd, roughness;
    for (int k = 0; k < NOISE_LANES; k++) {
        /* The clamps fractal_noise3 applies (4.x's were applied on reading). */
        float octaves = m->blender3 ? clampf(in[k].detail, 0.0f, 15.0f) : in[k].detail;
        roughness[k] = m->blender3 ? clampf(in[k].roughness, 0.0f, 1.0f) : in[k].roughness;
        n[k] = (int)octaves;
        rmd[k] = octaves - floorf(octaves);
    }

    lane_f amp = lane_splat(1.0f), maxamp = lane_splat(0.0f), sum = lane_splat(0.0f);
    lane_f next = lane_splat(0.0f); /* the fractional octave's term */
    /* Octaves every lane sums need no masks (usually all of them: Detail is constant). */
    int fewest = n[0];
    for (int k = 1; k < NOISE_LANES; k++)
        fewest = n[k] < fewest ? n[k] : fewest;
    int i = 0;
    for (; i <= fewest && i < most; i++) {
        lane_f v = m->scale * t[i];
        if (m->blender3)
            v = lane_fma(lane_splat(0.5f), v, lane_splat(0.5f));
        sum = lane_fma(v, amp, sum);
        maxamp = maxamp + amp;
        amp = amp * roughness;
    }
    for (; i < most; i++) {
        lane_f v = m->scale * t[i];
        if (m->blender3)
            v = lane_fma(lane_splat(0.5f), v, lane_splat(0.5f)); /* unsigned noise */
        lane_u summed = (lane_u)(n >= i);
        next = lane_select((lane_u)(n + 1 == i), v, next);
        sum = lane_select(summed, lane_fma(v, amp, sum), sum);
        maxamp = lane_select(summed, maxamp + amp, maxamp);
        amp = lane_select(summed, amp * roughness, amp);
    }

    lane_f sum2 = lane_fma(next, amp, sum), whole, with_fraction;
    if (m->blender3) {
        whole = sum / maxamp;
        with_fraction = lane_fma(rmd, sum2 / (maxamp + amp), (1.0f - rmd) * whole);
    } else if (nn->normalize) {
        whole = 0.5f * sum / maxamp + 0.5f;
        lane_f part = 0.5f * sum2 / (maxamp + amp) + 0.5f;
        with_fraction = lane_fma(rmd, part - whole, whole);
    } else {
        whole = sum;
        with_fraction = lane_fma(rmd, sum2 - sum, sum);
    }
    *value = lane_select((lane_u)(rmd != 0.0f), with_fraction, whole);
}

/* The NOISE_LANES points first, first + 1, ... of the batch side by side: what
 * noise_point does for each, with every Perlin evaluation done for all lanes at once.
 * Lanes may have different octave counts (Detail is an input): each octave up to the
 * largest count is evaluated for all lanes, and each lane's fractal combines only its
 * own, serially in Cycles' order, so that every lane's result has the bits of
 * noise_point's. */
static void noise_lanes(const noise_node *nn, const sg_kernel_args *a, int first,
                        float *fac_out, float *color_out)
{
    enum { L = NOISE_LANES };
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
    /* Whole groups of NOISE_LANES points side by side; the rest (and a one-point batch,
     * as the pointwise evaluator runs) one at a time. Both give the same bits. */
    for (; i + NOISE_LANES <= n; i += NOISE_LANES)
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

#define DIMS_BIT(d) (1u << (d))
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
    (int)(sizeof tex_noise_inputs / sizeof tex_noise_inputs[0]),
    tex_noise_outputs,
    (int)(sizeof tex_noise_outputs / sizeof tex_noise_outputs[0]),
    tex_noise_props,
    (int)(sizeof tex_noise_props / sizeof tex_noise_props[0]),
    tex_noise_kernel,
    0,
};

/* ---- White Noise Texture --------------------------------------------------------- */

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
    (int)(sizeof tex_white_noise_inputs / sizeof tex_white_noise_inputs[0]),
    tex_white_noise_outputs,
    (int)(sizeof tex_white_noise_outputs / sizeof tex_white_noise_outputs[0]),
    tex_white_noise_props,
    (int)(sizeof tex_white_noise_props / sizeof tex_white_noise_props[0]),
    tex_white_noise_kernel,
    0,
};
