/*
 * The SIMD lane layer of the node kernels: LANES independent evaluations (shading points,
 * octaves, Voronoi cells) side by side in GCC/Clang vector types. Internal to
 * shadergraph; everything is static inline and pure.
 *
 * Invariant: every lane operation here rounds exactly as the scalar operation it stands
 * for (kernel_math.h, kernel_util.h), so a lane's result has the bits of the scalar code
 * run on that lane's inputs. Kernels rely on that to mix both paths freely (whole groups
 * of a batch in lanes, the rest one by one); tests/unit/test_*_batch.c check it. Nothing
 * is fused unless it says madd, as in kernel_math.h.
 *
 * 16 lanes with AVX-512, else 8; without AVX the compiler lowers the vector types to
 * scalar code, and the few operations that need an instruction (floor, sqrt, fma) fall
 * back to one lane at a time.
 */
#ifndef IMSYNTH_KERNELS_LANES_H
#define IMSYNTH_KERNELS_LANES_H

#include <math.h>
#include <stdint.h>
#if defined(__AVX__) || defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "shadergraph/kernels/kernel_util.h"

/* Without AVX, GCC warns (-Wpsabi) that functions taking or returning 32-byte vectors
 * have no agreed ABI. Every function taking lane types is static or internal to
 * shadergraph, which is compiled with one set of flags, so no call crosses an ABI. The
 * pragma must precede the first such function, and stays in force for the including
 * file. */
#if defined(__GNUC__) && !defined(__clang__) && !defined(__AVX__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

#if defined(__AVX512F__)
#define LANES 16
#else
#define LANES 8
#endif
typedef float lane_f __attribute__((vector_size(4 * LANES)));
typedef uint32_t lane_u __attribute__((vector_size(4 * LANES)));
typedef int32_t lane_i __attribute__((vector_size(4 * LANES)));

/* The kernels' hot loops are written as calls to these and to their own lane functions;
 * forced inlining keeps the vectors in registers and lets constant arguments (Blender
 * version, dimensions) fold. */
#if defined(__GNUC__)
#define LANE_INLINE static inline __attribute__((always_inline))
#else
#define LANE_INLINE static inline
#endif

LANE_INLINE lane_f lane_splat(float v) { return (lane_f){0} + v; }
LANE_INLINE lane_u lane_splat_u(uint32_t v) { return (lane_u){0} + v; }

/* kernel_math.h's madd per lane: fmaf(a, b, c), rounded once. */
LANE_INLINE lane_f lane_madd(lane_f a, lane_f b, lane_f c)
{
#if LANES == 16
    return (lane_f)_mm512_fmadd_ps((__m512)a, (__m512)b, (__m512)c);
#elif defined(__FMA__) && defined(__AVX__)
    return (lane_f)_mm256_fmadd_ps((__m256)a, (__m256)b, (__m256)c);
#else
    lane_f r;
    for (int k = 0; k < LANES; k++)
        r[k] = fmaf(a[k], b[k], c[k]);
    return r;
#endif
}

/* Lanes of a where mask is all ones, of b where it is zero (masks are comparisons). */
LANE_INLINE lane_f lane_select(lane_u mask, lane_f a, lane_f b)
{
    return (lane_f)(((lane_u)a & mask) | ((lane_u)b & ~mask));
}

/* Cycles' min/max as kernel_math.h's minf/maxf: comparisons, so a NaN in a yields b. */
LANE_INLINE lane_f lane_minf(lane_f a, lane_f b) { return lane_select((lane_u)(a < b), a, b); }
LANE_INLINE lane_f lane_maxf(lane_f a, lane_f b) { return lane_select((lane_u)(a > b), a, b); }

LANE_INLINE lane_f lane_abs(lane_f x) { return (lane_f)((lane_u)x & 0x7fffffffu); }

/* floorf and sqrtf per lane: both are exact operations, so every implementation agrees. */
LANE_INLINE lane_f lane_floor(lane_f x)
{
#if LANES == 16
    return (lane_f)_mm512_roundscale_ps((__m512)x, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
#elif defined(__AVX__)
    return (lane_f)_mm256_floor_ps((__m256)x);
#else
    for (int k = 0; k < LANES; k++)
        x[k] = floorf(x[k]);
    return x;
#endif
}

LANE_INLINE lane_f lane_sqrt(lane_f x)
{
#if LANES == 16
    return (lane_f)_mm512_sqrt_ps((__m512)x);
#elif defined(__AVX__)
    return (lane_f)_mm256_sqrt_ps((__m256)x);
#else
    for (int k = 0; k < LANES; k++)
        x[k] = sqrtf(x[k]);
    return x;
#endif
}

/* floor_frac (kernel_util.h) per lane: the truncating conversion gives INT32_MIN for NaN
 * and out-of-range values, as the scalar code's explicit test does. */
LANE_INLINE lane_f lane_floor_frac(lane_f x, lane_u *cell)
{
#if LANES == 16
    lane_f f = lane_floor(x);
    *cell = (lane_u)_mm512_cvttps_epi32((__m512)f);
#elif defined(__AVX__)
    lane_f f = lane_floor(x);
    *cell = (lane_u)_mm256_cvttps_epi32((__m256)f);
#else
    lane_f f;
    for (int k = 0; k < LANES; k++) {
        int32_t i;
        (void)floor_frac(x[k], &i);
        (*cell)[k] = (uint32_t)i;
        f[k] = floorf(x[k]);
    }
#endif
    return x - f;
}

/* Jenkins lookup3 per lane: kernel_util.h's hash_uint .. hash_uint4, the same text. */
LOOKUP3_HASHES(LANE_INLINE, lane_u, lane_hash_uint, lane_hash_uint2, lane_hash_uint3,
               lane_hash_uint4)

/* uint_to_unit_float per lane: the unsigned conversion rounds once, as the scalar cast. */
LANE_INLINE lane_f lane_uint_to_unit_float(lane_u n)
{
    return __builtin_convertvector(n, lane_f) * (1.0f / (float)0xFFFFFFFFu);
}

#endif
