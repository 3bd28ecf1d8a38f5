/*
 * Perlin noise in 1 to 4 dimensions, as Cycles' kernel/svm/noise.h computes it (Blender
 * 4.3; 3.4 for SG_BLENDER_3): first one point at a time, the readable specification,
 * then the same operations on LANES points side by side, the fast path. The two must
 * stay in step; tests/unit/test_noise_batch.c checks that they give the same bits.
 *
 * Rounding (noise.h of this folder: madd where Blender's AVX2 kernel fuses). Cycles
 * computes 2D to 4D noise with its SIMD types, so those interpolate along x, then y,
 * then z (4D: w first), with the SIMD mix (simd_mix) and the SIMD form (t*t)*(t*b) of
 * the fade polynomial; 1D is scalar code throughout.
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "shadergraph/kernels/noise.h"

/* ---- one point ------------------------------------------------------------------- */

/* Cycles' float4 mix of 4.x is a + t * (b - a), fused; 3.4's ssef mix was
 * madd(t, b, (1 - t) * a). */
static inline float simd_mix(float a, float b, float t, bool blender3)
{
    return blender3 ? madd(t, b, (1.0f - t) * a) : mix_fused(a, b, t);
}

static inline float fade_scalar(float t)
{
    return t * t * t * madd(t, madd(t, 6.0f, -15.0f), 10.0f);
}

static inline float fade_simd(float t)
{
    float b = madd(t, madd(t, 6.0f, -15.0f), 10.0f);
    return (t * t) * (t * b);
}

/* Flipping the sign bit is exactly negation (also of 0 and NaN). */
static inline float negate_if(float v, uint32_t condition)
{
    uint32_t u = float_bits(v) ^ ((uint32_t)(condition != 0u) << 31);
    float r;
    memcpy(&r, &u, sizeof r);
    return r;
}

/* The gradients: the hash picks the coordinates and their signs. */
static inline float grad1(uint32_t hash, float x)
{
    uint32_t h = hash & 15u;
    float g = (float)(1u + (h & 7u));
    return negate_if(g, h & 8u) * x;
}

static inline float grad2(uint32_t hash, float x, float y)
{
    uint32_t h = hash & 7u;
    float u = h < 4u ? x : y;
    float v = 2.0f * (h < 4u ? y : x);
    return negate_if(u, h & 1u) + negate_if(v, h & 2u);
}

static inline float grad3(uint32_t hash, float x, float y, float z)
{
    uint32_t h = hash & 15u;
    float u = h < 8u ? x : y;
    float vt = (h == 12u || h == 14u) ? x : z;
    float v = h < 4u ? y : vt;
    return negate_if(u, h & 1u) + negate_if(v, h & 2u);
}

static inline float grad4(uint32_t hash, float x, float y, float z, float w)
{
    uint32_t h = hash & 31u;
    float u = h < 24u ? x : y;
    float v = h < 16u ? y : z;
    float s = h < 8u ? z : w;
    return negate_if(u, h & 1u) + negate_if(v, h & 2u) + negate_if(s, h & 4u);
}

static inline float perlin_1d(float x)
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

static inline float perlin_2d(float x, float y, bool b3)
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

static inline float perlin_3d(float x, float y, float z, bool b3)
{
    int32_t ix, iy, iz;
    float fx = floor_frac(x, &ix), fy = floor_frac(y, &iy), fz = floor_frac(z, &iz);
    uint32_t X = (uint32_t)ix, Y = (uint32_t)iy, Z = (uint32_t)iz;
    float u = fade_simd(fx), v = fade_simd(fy), w = fade_simd(fz);
    float fx1 = fx - 1.0f, fy1 = fy - 1.0f, fz1 = fz - 1.0f;

    /* g[c] is corner c = (dx, dy, dz) with c = 4 dx + 2 dy + dz. */
    float g[8];
    for (uint32_t c = 0; c < 8; c++) {
        uint32_t dx = c >> 2, dy = (c >> 1) & 1u, dz = c & 1u;
        g[c] = grad3(hash_uint3(X + dx, Y + dy, Z + dz), dx ? fx1 : fx, dy ? fy1 : fy,
                     dz ? fz1 : fz);
    }
    /* x first, then y, then z. */
    float s00 = simd_mix(g[0], g[4], u, b3), s01 = simd_mix(g[1], g[5], u, b3);
    float s10 = simd_mix(g[2], g[6], u, b3), s11 = simd_mix(g[3], g[7], u, b3);
    return simd_mix(simd_mix(s00, s10, v, b3), simd_mix(s01, s11, v, b3), w, b3);
}

static inline float perlin_4d(float x, float y, float z, float w, bool b3)
{
    int32_t ix, iy, iz, iw;
    float fx = floor_frac(x, &ix), fy = floor_frac(y, &iy), fz = floor_frac(z, &iz),
          fw = floor_frac(w, &iw);
    uint32_t X = (uint32_t)ix, Y = (uint32_t)iy, Z = (uint32_t)iz, W = (uint32_t)iw;
    float u = fade_simd(fx), v = fade_simd(fy), s = fade_simd(fz), t = fade_simd(fw);
    float fx1 = fx - 1.0f, fy1 = fy - 1.0f, fz1 = fz - 1.0f, fw1 = fw - 1.0f;

    /* m[c]: corner c in x, y, z as in perlin_3d, mixed along w first (Cycles' AVX
     * quad_mix), then x, y, z. */
    float m[8];
    for (uint32_t c = 0; c < 8; c++) {
        uint32_t dx = c >> 2, dy = (c >> 1) & 1u, dz = c & 1u;
        uint32_t cx = X + dx, cy = Y + dy, cz = Z + dz;
        float px = dx ? fx1 : fx, py = dy ? fy1 : fy, pz = dz ? fz1 : fz;
        float g0 = grad4(hash_uint4(cx, cy, cz, W), px, py, pz, fw);
        float g1 = grad4(hash_uint4(cx, cy, cz, W + 1u), px, py, pz, fw1);
        m[c] = simd_mix(g0, g1, t, b3);
    }
    float s00 = simd_mix(m[0], m[4], u, b3), s01 = simd_mix(m[1], m[5], u, b3);
    float s10 = simd_mix(m[2], m[6], u, b3), s11 = simd_mix(m[3], m[7], u, b3);
    return simd_mix(simd_mix(s00, s10, v, b3), simd_mix(s01, s11, v, b3), s, b3);
}

/* ---- LANES points side by side: the operations above, lane by lane -------------- */

LANE_INLINE lane_f lane_simd_mix(lane_f a, lane_f b, lane_f t, bool b3)
{
    return b3 ? lane_madd(t, b, (lane_splat(1.0f) - t) * a) : lane_madd(t, b - a, a);
}

LANE_INLINE lane_f lane_fade_scalar(lane_f t)
{
    return t * t * t *
           lane_madd(t, lane_madd(t, lane_splat(6.0f), lane_splat(-15.0f)), lane_splat(10.0f));
}

LANE_INLINE lane_f lane_fade_simd(lane_f t)
{
    lane_f b = lane_madd(t, lane_madd(t, lane_splat(6.0f), lane_splat(-15.0f)), lane_splat(10.0f));
    return (t * t) * (t * b);
}

/* negate_if per lane: `sign` holds the sign bit to flip (bit 31) or 0. */
LANE_INLINE lane_f lane_negate_if(lane_f v, lane_u sign) { return (lane_f)((lane_u)v ^ sign); }

LANE_INLINE lane_f lane_grad1(lane_u hash)
{
    lane_u h = hash & 15u;
    lane_f g = __builtin_convertvector((lane_i)(1u + (h & 7u)), lane_f);
    return lane_negate_if(g, (h & 8u) << 28);
}

LANE_INLINE lane_f lane_grad2(lane_u hash, lane_f x, lane_f y)
{
    lane_u h = hash & 7u;
    lane_u first = (lane_u)(h < 4u);
    lane_f u = lane_select(first, x, y);
    lane_f v = 2.0f * lane_select(first, y, x);
    return lane_negate_if(u, (h & 1u) << 31) + lane_negate_if(v, (h & 2u) << 30);
}

LANE_INLINE lane_f lane_grad3(lane_u hash, lane_f x, lane_f y, lane_f z)
{
#if LANES == 16
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
    return lane_negate_if(u, (h & 1u) << 31) + lane_negate_if(v, (h & 2u) << 30);
#endif
}

LANE_INLINE lane_f lane_grad4(lane_u hash, lane_f x, lane_f y, lane_f z, lane_f w)
{
    lane_u h = hash & 31u;
    lane_f u = lane_select((lane_u)(h < 24u), x, y);
    lane_f v = lane_select((lane_u)(h < 16u), y, z);
    lane_f s = lane_select((lane_u)(h < 8u), z, w);
    return lane_negate_if(u, (h & 1u) << 31) + lane_negate_if(v, (h & 2u) << 30) +
           lane_negate_if(s, (h & 4u) << 29);
}

LANE_INLINE lane_f lane_perlin_1d(lane_f x)
{
    lane_u X;
    lane_f fx = lane_floor_frac(x, &X);
    lane_f u = lane_fade_scalar(fx);
    lane_f g0 = lane_grad1(lane_hash_uint(X)), g1 = lane_grad1(lane_hash_uint(X + 1u));
    lane_f b = g1 * (fx - 1.0f);
    return lane_madd(g0, fx, u * lane_madd(-g0, fx, b));
}

LANE_INLINE lane_f lane_perlin_2d(lane_f x, lane_f y, bool b3)
{
    lane_u X, Y;
    lane_f fx = lane_floor_frac(x, &X), fy = lane_floor_frac(y, &Y);
    lane_f u = lane_fade_simd(fx), v = lane_fade_simd(fy);
    lane_f fx1 = fx - 1.0f, fy1 = fy - 1.0f;
    lane_f g00 = lane_grad2(lane_hash_uint2(X, Y), fx, fy);
    lane_f g01 = lane_grad2(lane_hash_uint2(X, Y + 1u), fx, fy1);
    lane_f g10 = lane_grad2(lane_hash_uint2(X + 1u, Y), fx1, fy);
    lane_f g11 = lane_grad2(lane_hash_uint2(X + 1u, Y + 1u), fx1, fy1);
    return lane_simd_mix(lane_simd_mix(g00, g10, u, b3), lane_simd_mix(g01, g11, u, b3), v, b3);
}

LANE_INLINE lane_f lane_perlin_3d(lane_f x, lane_f y, lane_f z, bool b3)
{
    lane_u X, Y, Z;
    lane_f fx = lane_floor_frac(x, &X), fy = lane_floor_frac(y, &Y), fz = lane_floor_frac(z, &Z);
    lane_f u = lane_fade_simd(fx), v = lane_fade_simd(fy), w = lane_fade_simd(fz);
    lane_f fx1 = fx - 1.0f, fy1 = fy - 1.0f, fz1 = fz - 1.0f;
    /* Unrolled, the eight gradients stay in registers (about 10% faster). */
    lane_f g[8];
#pragma GCC unroll 8
    for (uint32_t c = 0; c < 8; c++) {
        uint32_t dx = c >> 2, dy = (c >> 1) & 1u, dz = c & 1u;
        g[c] = lane_grad3(lane_hash_uint3(X + dx, Y + dy, Z + dz), dx ? fx1 : fx,
                          dy ? fy1 : fy, dz ? fz1 : fz);
    }
    lane_f s00 = lane_simd_mix(g[0], g[4], u, b3), s01 = lane_simd_mix(g[1], g[5], u, b3);
    lane_f s10 = lane_simd_mix(g[2], g[6], u, b3), s11 = lane_simd_mix(g[3], g[7], u, b3);
    return lane_simd_mix(lane_simd_mix(s00, s10, v, b3), lane_simd_mix(s01, s11, v, b3), w, b3);
}

LANE_INLINE lane_f lane_perlin_4d(lane_f x, lane_f y, lane_f z, lane_f w, bool b3)
{
    lane_u X, Y, Z, W;
    lane_f fx = lane_floor_frac(x, &X), fy = lane_floor_frac(y, &Y), fz = lane_floor_frac(z, &Z),
           fw = lane_floor_frac(w, &W);
    lane_f u = lane_fade_simd(fx), v = lane_fade_simd(fy), s = lane_fade_simd(fz),
           t = lane_fade_simd(fw);
    lane_f fx1 = fx - 1.0f, fy1 = fy - 1.0f, fz1 = fz - 1.0f, fw1 = fw - 1.0f;
    lane_f m[8];
#pragma GCC unroll 8
    for (uint32_t c = 0; c < 8; c++) {
        uint32_t dx = c >> 2, dy = (c >> 1) & 1u, dz = c & 1u;
        lane_u cx = X + dx, cy = Y + dy, cz = Z + dz;
        lane_f px = dx ? fx1 : fx, py = dy ? fy1 : fy, pz = dz ? fz1 : fz;
        lane_f g0 = lane_grad4(lane_hash_uint4(cx, cy, cz, W), px, py, pz, fw);
        lane_f g1 = lane_grad4(lane_hash_uint4(cx, cy, cz, W + 1u), px, py, pz, fw1);
        m[c] = lane_simd_mix(g0, g1, t, b3);
    }
    lane_f s00 = lane_simd_mix(m[0], m[4], u, b3), s01 = lane_simd_mix(m[1], m[5], u, b3);
    lane_f s10 = lane_simd_mix(m[2], m[6], u, b3), s11 = lane_simd_mix(m[3], m[7], u, b3);
    return lane_simd_mix(lane_simd_mix(s00, s10, v, b3), lane_simd_mix(s01, s11, v, b3), s, b3);
}

/* ---- per Blender version --------------------------------------------------------- */

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

/* wrap_coordinate per lane; the fmodf of the rare far lanes is done one at a time. */
LANE_INLINE lane_f lane_wrap_coordinate(lane_f p)
{
    lane_f magnitude = lane_abs(p);
#if LANES == 16
    if (_mm512_cmp_ps_mask((__m512)magnitude, _mm512_set1_ps(100000.0f), _CMP_LT_OQ) == 0xffff)
        return p;
#else
    lane_u near = (lane_u)(magnitude < 100000.0f);
    uint32_t all_near = ~0u;
    for (int k = 0; k < LANES; k++)
        all_near &= near[k];
    if (all_near)
        return p;
#endif
    for (int k = 0; k < LANES; k++)
        p[k] = wrap_coordinate(p[k]);
    return p;
}

LANE_INLINE lane_f lane_finite_or_zero(lane_f v)
{
    return lane_select((lane_u)(lane_abs(v) < __builtin_inff()), v, lane_splat(0.0f));
}

/* Unscaled Perlin noise of a point and of LANES points, one function per dimensions and
 * Blender version, so that the version's choices are constants inside each. */
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

static void lane_perlin_1d_v4(const lane_point *p, lane_f *out)
{
    *out = lane_perlin_1d(lane_wrap_coordinate(p->x));
}
static void lane_perlin_2d_v4(const lane_point *p, lane_f *out)
{
    *out = lane_perlin_2d(lane_wrap_coordinate(p->x), lane_wrap_coordinate(p->y), false);
}
static void lane_perlin_3d_v4(const lane_point *p, lane_f *out)
{
    *out = lane_perlin_3d(lane_wrap_coordinate(p->x), lane_wrap_coordinate(p->y),
                          lane_wrap_coordinate(p->z), false);
}
static void lane_perlin_4d_v4(const lane_point *p, lane_f *out)
{
    *out = lane_perlin_4d(lane_wrap_coordinate(p->x), lane_wrap_coordinate(p->y),
                          lane_wrap_coordinate(p->z), lane_wrap_coordinate(p->w), false);
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

/* Perlin noise of `count` points (one point's octaves): LANES at a time, the last group
 * padded with copies of its first point; a last single point alone, which costs less
 * than a vector of lanes. */
LANE_INLINE void perlin_many(const npoint *pts, int count, float *out,
                               float (*one)(npoint), void (*lanes)(const lane_point *, lane_f *))
{
    for (int first = 0; first < count; first += LANES) {
        if (count - first == 1) {
            out[first] = one(pts[first]);
            break;
        }
        // gathered in plain arrays, then copied into the vectors whole: GCC 12 (AVX2, 8
        // lanes) takes per-element stores into a vector for reads of uninitialised lanes
        float a[4][LANES];
        for (int k = 0; k < LANES; k++) {
            npoint pk = pts[first + k < count ? first + k : first];
            a[0][k] = pk.x;
            a[1][k] = pk.y;
            a[2][k] = pk.z;
            a[3][k] = pk.w;
        }
        lane_point q;
        memcpy(&q.x, a[0], sizeof q.x);
        memcpy(&q.y, a[1], sizeof q.y);
        memcpy(&q.z, a[2], sizeof q.z);
        memcpy(&q.w, a[3], sizeof q.w);
        lane_f r;
        lanes(&q, &r);
        for (int k = 0; k < LANES && first + k < count; k++)
            out[first + k] = r[k];
    }
}

#define PERLIN_MANY(dims, v)                                                               \
    static void perlin_##dims##_many_##v(const npoint *pts, int count, float *out)         \
    {                                                                                      \
        perlin_many(pts, count, out, perlin_##dims##_##v, lane_perlin_##dims##_##v);       \
    }
PERLIN_MANY(1d, v4)
PERLIN_MANY(2d, v4)
PERLIN_MANY(3d, v4)
PERLIN_MANY(4d, v4)
PERLIN_MANY(1d, v3)
PERLIN_MANY(2d, v3)
PERLIN_MANY(3d, v3)
PERLIN_MANY(4d, v3)
#undef PERLIN_MANY

noise_mode noise_mode_for(int dims, bool blender3)
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
