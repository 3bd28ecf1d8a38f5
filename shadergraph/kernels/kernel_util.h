/*
 * Planar float3 access and Blender's hash functions, shared by the node kernels (the
 * float3 type and Cycles' math helpers are shadergraph/kernel_math.h). Internal to
 * shadergraph. Everything is static inline and pure.
 *
 * The hashes are Bob Jenkins' lookup3 final mix, seeded as Cycles seeds them, so that
 * noise and Voronoi cells land exactly where Blender puts them. Float inputs are hashed
 * by their bit patterns.
 */
#ifndef IMSYNTH_KERNEL_UTIL_H
#define IMSYNTH_KERNEL_UTIL_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "shadergraph/kernel_math.h"

/* Read/write point i of a planar vector array of n points. */
static inline float3 f3_load(const float *v, int n, int i)
{
    return make_float3(v[i], v[n + i], v[2 * n + i]);
}
static inline void f3_store(float *v, int n, int i, float3 a)
{
    v[i] = a.x;
    v[n + i] = a.y;
    v[2 * n + i] = a.z;
}

static inline uint32_t float_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

/* Cycles' floorfrac: floor and fraction; the integer part is what cvttss2si/cvttps2dq
 * produce, which is INT32_MIN ("integer indefinite") for NaN and anything outside int32
 * range (Blender 3.4 does not wrap large noise coordinates, so that case is reachable). */
static inline float floor_frac(float x, int32_t *i)
{
    float f = floorf(x);
    *i = (f >= -2147483648.0f && f < 2147483648.0f) ? (int32_t)f : INT32_MIN;
    return x - f;
}

/* ---- Jenkins lookup3 ------------------------------------------------------------- */

/* lookup3's rotate, mix and final as macros, so that one definition serves uint32_t and
 * GCC/Clang vectors of uint32_t alike (the operators are the same): the scalar hashes
 * below and the lane ones of lanes.h. Arguments are plain variables;
 * they are evaluated more than once. */
#define HASH_ROT(x, k) (((x) << (k)) | ((x) >> (32 - (k))))

#define HASH_MIX(a, b, c)                                                                  \
    do {                                                                                   \
        a -= c; a ^= HASH_ROT(c, 4);  c += b;                                               \
        b -= a; b ^= HASH_ROT(a, 6);  a += c;                                               \
        c -= b; c ^= HASH_ROT(b, 8);  b += a;                                               \
        a -= c; a ^= HASH_ROT(c, 16); c += b;                                               \
        b -= a; b ^= HASH_ROT(a, 19); a += c;                                               \
        c -= b; c ^= HASH_ROT(b, 4);  b += a;                                               \
    } while (0)

#define HASH_FINAL(a, b, c)                                                                \
    do {                                                                                   \
        c ^= b; c -= HASH_ROT(b, 14);                                                       \
        a ^= c; a -= HASH_ROT(c, 11);                                                       \
        b ^= a; b -= HASH_ROT(a, 25);                                                       \
        c ^= b; c -= HASH_ROT(b, 16);                                                       \
        a ^= c; a -= HASH_ROT(c, 4);                                                        \
        b ^= a; b -= HASH_ROT(a, 14);                                                       \
        c ^= b; c -= HASH_ROT(b, 24);                                                       \
    } while (0)

/* hash_uint .. hash_uint4: lookup3 of 1 to 4 words, seeded as Cycles seeds it. Defined
 * by a macro so that the scalar functions here and the lane ones of lanes.h are one text
 * over two types (T is uint32_t or a vector of it; (T){0} + x broadcasts x). */
#define LOOKUP3_HASHES(QUALIFIER, T, hash1, hash2, hash3, hash4)                          \
    QUALIFIER T hash1(T kx)                                                                \
    {                                                                                      \
        T a, b, c;                                                                         \
        a = b = c = (T){0} + (0xdeadbeefu + (1u << 2) + 13u);                              \
        a += kx;                                                                           \
        HASH_FINAL(a, b, c);                                                               \
        return c;                                                                          \
    }                                                                                      \
    QUALIFIER T hash2(T kx, T ky)                                                          \
    {                                                                                      \
        T a, b, c;                                                                         \
        a = b = c = (T){0} + (0xdeadbeefu + (2u << 2) + 13u);                              \
        b += ky;                                                                           \
        a += kx;                                                                           \
        HASH_FINAL(a, b, c);                                                               \
        return c;                                                                          \
    }                                                                                      \
    QUALIFIER T hash3(T kx, T ky, T kz)                                                    \
    {                                                                                      \
        T a, b, c;                                                                         \
        a = b = c = (T){0} + (0xdeadbeefu + (3u << 2) + 13u);                              \
        c += kz;                                                                           \
        b += ky;                                                                           \
        a += kx;                                                                           \
        HASH_FINAL(a, b, c);                                                               \
        return c;                                                                          \
    }                                                                                      \
    QUALIFIER T hash4(T kx, T ky, T kz, T kw)                                              \
    {                                                                                      \
        T a, b, c;                                                                         \
        a = b = c = (T){0} + (0xdeadbeefu + (4u << 2) + 13u);                              \
        a += kx;                                                                           \
        b += ky;                                                                           \
        c += kz;                                                                           \
        HASH_MIX(a, b, c);                                                                 \
        a += kw;                                                                           \
        HASH_FINAL(a, b, c);                                                               \
        return c;                                                                          \
    }

LOOKUP3_HASHES(static inline, uint32_t, hash_uint, hash_uint2, hash_uint3, hash_uint4)

/* A 32-bit value to [0, 1] inclusive, rounding as Cycles does: n * (1 / (2^32 - 1)). */
static inline float uint_to_unit_float(uint32_t n) { return (float)n * (1.0f / (float)0xFFFFFFFFu); }

static inline float hash_float_to_float(float k) { return uint_to_unit_float(hash_uint(float_bits(k))); }
static inline float hash_float2_to_float(float x, float y)
{
    return uint_to_unit_float(hash_uint2(float_bits(x), float_bits(y)));
}
static inline float hash_float3_to_float(float3 k)
{
    return uint_to_unit_float(hash_uint3(float_bits(k.x), float_bits(k.y), float_bits(k.z)));
}
static inline float hash_float4_to_float(float x, float y, float z, float w)
{
    return uint_to_unit_float(hash_uint4(float_bits(x), float_bits(y), float_bits(z), float_bits(w)));
}
static inline float3 hash_float3_to_float3(float3 k)
{
    return make_float3(hash_float3_to_float(k), hash_float4_to_float(k.x, k.y, k.z, 1.0f),
                       hash_float4_to_float(k.x, k.y, k.z, 2.0f));
}

#endif
