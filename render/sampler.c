/*
 * Random numbers as a pure function of (seed, pixel, sample, dimension).
 *
 * Why a hash and not a stream: a stream's values depend on how many numbers were drawn
 * before, so they would change with tiling and thread count. Hashing the coordinates
 * makes every number addressable. The mixer is SplitMix64's finaliser (Stafford's
 * variant 13), applied once per coordinate so that nearby coordinates decorrelate; the
 * top 24 bits become a float in [0, 1) exactly (no rounding up to 1).
 */
#include "render/render_internal.h"

static uint64_t mix64(uint64_t x)
{
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ull;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebull;
    x ^= x >> 31;
    return x;
}

float render_random(uint64_t seed, uint32_t pixel, uint32_t sample, uint32_t dim)
{
    uint64_t h = mix64(seed + 0x9e3779b97f4a7c15ull);
    h = mix64(h ^ ((uint64_t)pixel + 0x632be59bd9b4e019ull));
    h = mix64(h ^ (((uint64_t)sample << 32) | dim));
    return (float)(h >> 40) * (1.0f / 16777216.0f);
}

/* A bijection of [0, 2^k) (k = bits of mask): xor with a key, multiply by an odd number,
 * xor-shift right - each step is invertible modulo 2^k. Cycle-walking restricts it to
 * [0, n): apply until the value lands below n (Kensler's "Correlated Multi-Jittered
 * Sampling" trick), which stays a bijection of [0, n). */
uint32_t render_permute(uint32_t index, uint32_t n, uint64_t key)
{
    if (n <= 1)
        return 0;
    uint32_t mask = n - 1;
    mask |= mask >> 1;
    mask |= mask >> 2;
    mask |= mask >> 4;
    mask |= mask >> 8;
    mask |= mask >> 16;
    uint64_t h = mix64(key + 0x2545f4914f6cdd1dull);
    uint32_t k1 = (uint32_t)h, k2 = (uint32_t)(h >> 32) | 1u;
    uint32_t x = index;
    do {
        x ^= k1 & mask;
        x = (x * k2) & mask;
        x ^= (x & mask) >> 3;
        x = (x * 0x2c1b3c6du) & mask; /* odd */
        x ^= (x & mask) >> 5;
        x = (x ^ (k1 >> 16)) & mask;
    } while (x >= n);
    return x;
}
