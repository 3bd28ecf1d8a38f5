/*
 * Fast 3x3 convolutions (stride 1, padding 1) as batched matrix products over chunks of
 * output tiles, so that a chunk's buffers stay in L2 and every chunk is an independent
 * job for a worker thread.
 *
 * Winograd F(2x2,3x3) (Lavin & Gray 2015): a 2x2 output tile is
 *     Y = A^T [ (G g G^T) (.) (B^T d B) ] A
 * for the 4x4 input patch d at (2ty-1, 2tx-1) and the 3x3 filter g; (.) is elementwise.
 * Summed over input channels, each of the 16 elementwise positions is one matrix product
 * U[xi] (K x C) * V[xi] (C x T) over the T tiles of a chunk: 16 multiplies per tile and
 * channel pair instead of 36. B and A hold only 0 and +-1 and G only 0, +-1/2, so the
 * transforms add a few roundings of ordinary fp32 sums and nothing else: this path agrees
 * with direct summation to fp32 rounding (tests/unit/test_nn_layers.c measures it).
 *
 * im2col: for thin inputs (conv1_1 has 3 channels) and tiny planes, where the Winograd
 * products would be too narrow: col (9C x T) and one product W (K x 9C) * col.
 *
 * The products run on our own AVX-512 kernel (gemm_kct: V is written in the layout it
 * reads, so nothing is packed), or, for the fast path, in bf16 on AMX tiles; OpenBLAS
 * sgemm only where AVX-512 is missing or K is not a multiple of 8. Both paths write a
 * chunk's products into scratch and scatter them, plus bias (and ReLU when asked), into
 * the NCHW output.
 */
#include <cblas.h>
#include <stdint.h>
#include <string.h>
#ifdef __AVX512F__
#include <immintrin.h>
#endif

#include "nn/conv3x3.h"

/* ------------------------------------------------------------ weight transform ---- */

void winograd_weights(float *U, const float *w, int K, int C)
{
    // w (K,C,3,3) -> U (16,K,C): U[xi] = (G g G^T)[xi]
    for (int k = 0; k < K; k++)
        for (int c = 0; c < C; c++) {
            const float *g = w + ((size_t)k * C + c) * 9;
            float t[4][3]; /* G g: 4x3 */
            for (int j = 0; j < 3; j++) {
                t[0][j] = g[j];
                t[1][j] = 0.5f * (g[j] + g[3 + j] + g[6 + j]);
                t[2][j] = 0.5f * (g[j] - g[3 + j] + g[6 + j]);
                t[3][j] = g[6 + j];
            }
            for (int i = 0; i < 4; i++) {
                float u[4] = {t[i][0], 0.5f * (t[i][0] + t[i][1] + t[i][2]),
                              0.5f * (t[i][0] - t[i][1] + t[i][2]), t[i][2]};
                for (int j = 0; j < 4; j++)
                    U[((size_t)(4 * i + j) * K + k) * C + c] = u[j];
            }
        }
}

/* Round to bfloat16, nearest-even (what VCVTNE2PS2BF16 does; NaN stays NaN). */
static uint16_t to_bf16(float f)
{
    uint32_t b;
    memcpy(&b, &f, 4);
    if ((b & 0x7fffffffu) > 0x7f800000u)
        return (uint16_t)(b >> 16 | 0x40);
    return (uint16_t)((b + 0x7fffu + (b >> 16 & 1)) >> 16);
}

void winograd_weights_bf16(uint32_t *Ub, const float *U, int K, int C)
{
    // U (16,K,C) -> Ub (16,K,C/2): low half bf16(U[..][2p]), high half bf16(U[..][2p+1])
    for (size_t i = 0; i < 16 * (size_t)K; i++)
        for (int p = 0; p < C / 2; p++)
            Ub[i * (C / 2) + p] = (uint32_t)to_bf16(U[i * C + 2 * p]) |
                                  (uint32_t)to_bf16(U[i * C + 2 * p + 1]) << 16;
}

/* ------------------------------------------------------------ chunk geometry ------ */

/* A Winograd chunk is a run of whole tile rows (global row r = n * th + ty),
 * so that the transforms walk along rows with vector loads; an im2col chunk is a run of
 * output pixels of one image. */
static void winograd_tiles(const conv_layer *L, int *th, int *tw)
{
    *th = (L->H + 1) / 2;
    *tw = (L->W + 1) / 2;
}

/* Chunks are runs of tile rows (Winograd) or pixels (im2col) counted across the batch, so
 * a chunk may hold the end of one image and the start of the next, when our own kernels
 * do the products: each of their output columns is summed in the same order whatever else
 * shares its chunk (gemm_block, AMX tiles), so an image's result does not depend on the
 * batch. When the sgemm fallback runs (no AVX-512, or K not a multiple of 8), which makes
 * no such promise, chunks stay inside one image. */
static size_t units_per_image(const conv_layer *L)
{
    int th, tw;
    winograd_tiles(L, &th, &tw);
    return L->winograd ? (size_t)th : (size_t)L->H * L->W;
}

static int chunks_span_images(const conv_layer *L)
{
#ifdef __AVX512F__
    return L->K % 8 == 0;
#else
    (void)L;
    return 0;
#endif
}

size_t conv_chunk_count(const conv_layer *L)
{
    size_t units = units_per_image(L), kblocks = L->kblocks > 1 ? (size_t)L->kblocks : 1;
    if (chunks_span_images(L))
        return kblocks * (((size_t)L->N * units + L->chunk - 1) / L->chunk);
    return kblocks * (size_t)L->N * ((units + L->chunk - 1) / L->chunk);
}

int conv_chunk_size(int winograd, int C, int K, int W, size_t budget)
{
    if (winograd) {
        size_t tw = (size_t)(W + 1) / 2, per_tile = 16 * (size_t)(C + K) * sizeof(float);
        size_t rows = budget / (per_tile * tw);
        /* At least 96 tiles (two 48-wide kernel blocks): each weight of U is used once
         * per tile of the chunk, so fewer tiles would make the deep layers stream
         * their weights from memory for too little work. */
        size_t min_rows = (96 + tw - 1) / tw;
        rows = rows > min_rows ? rows : min_rows;
        return (int)rows;
    }
    /* A multiple of 16 columns (one AVX-512 register of floats), at least 16. */
    size_t t = budget / ((9 * (size_t)C + (size_t)K) * sizeof(float)) / 16 * 16;
    return t < 16 ? 16 : (int)t;
}

size_t conv_scratch_floats(int winograd, int C, int K, int W, int chunk)
{
    if (winograd) {
        size_t T = ((size_t)chunk * ((W + 1) / 2) + 15) / 16 * 16;
        return 16 * (size_t)(C + K) * T + (size_t)W; /* V, M, a zero row */
    }
    return (9 * (size_t)C + (size_t)K) * chunk;
}

/* ------------------------------------------------------------ Winograd rows ------- */

/* B^T d B for the tiles of one tile row of one channel. src[i] is input row 2ty - 1 + i
 * (W pixels; a row of zeros above or below the plane), so tile tx's patch is columns
 * 2tx-1 .. 2tx+2. Groups of 16 tiles inside the plane read the rows in place; a group
 * touching the left or right edge reads a zero-padded copy. Writes v[xi * xs + tx]. */
static void input_transform_row(float *v, size_t xs, const float *const src[4], int tw, int W)
{
    int tx = 0;
#ifdef __AVX512F__
    const __m512i even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26,
                                           28, 30);
    const __m512i odd = _mm512_add_epi32(even, _mm512_set1_epi32(1));
    for (; tx < tw; tx += 16) {
        __mmask16 m = tw - tx >= 16 ? 0xffff : (__mmask16)((1u << (tw - tx)) - 1);
        __m512 d[4][4];
        float edge[4][48]; /* columns 2tx-1 .. 2tx+32, zero outside the plane */
        const int interior = 2 * tx - 1 >= 0 && 2 * tx + 32 <= W - 1;
        if (!interior)
            for (int i = 0; i < 4; i++)
                for (int j = 0; j < 34; j++) {
                    int x = 2 * tx - 1 + j;
                    edge[i][j] = x >= 0 && x < W ? src[i][x] : 0.0f;
                }
        for (int i = 0; i < 4; i++) {
            const float *base = interior ? src[i] + 2 * tx - 1 : edge[i];
            __m512 lo = _mm512_loadu_ps(base), hi = _mm512_loadu_ps(base + 16);
            __m512 lo2 = _mm512_loadu_ps(base + 2), hi2 = _mm512_loadu_ps(base + 18);
            d[i][0] = _mm512_permutex2var_ps(lo, even, hi);
            d[i][1] = _mm512_permutex2var_ps(lo, odd, hi);
            d[i][2] = _mm512_permutex2var_ps(lo2, even, hi2);
            d[i][3] = _mm512_permutex2var_ps(lo2, odd, hi2);
        }
        for (int i = 0; i < 4; i++) { /* rows of B^T d, then times B */
            __m512 b0, b1, b2, b3;
            if (i == 0) {
                b0 = _mm512_sub_ps(d[0][0], d[2][0]); b1 = _mm512_sub_ps(d[0][1], d[2][1]);
                b2 = _mm512_sub_ps(d[0][2], d[2][2]); b3 = _mm512_sub_ps(d[0][3], d[2][3]);
            } else if (i == 1) {
                b0 = _mm512_add_ps(d[1][0], d[2][0]); b1 = _mm512_add_ps(d[1][1], d[2][1]);
                b2 = _mm512_add_ps(d[1][2], d[2][2]); b3 = _mm512_add_ps(d[1][3], d[2][3]);
            } else if (i == 2) {
                b0 = _mm512_sub_ps(d[2][0], d[1][0]); b1 = _mm512_sub_ps(d[2][1], d[1][1]);
                b2 = _mm512_sub_ps(d[2][2], d[1][2]); b3 = _mm512_sub_ps(d[2][3], d[1][3]);
            } else {
                b0 = _mm512_sub_ps(d[1][0], d[3][0]); b1 = _mm512_sub_ps(d[1][1], d[3][1]);
                b2 = _mm512_sub_ps(d[1][2], d[3][2]); b3 = _mm512_sub_ps(d[1][3], d[3][3]);
            }
            float *o = v + (size_t)(4 * i) * xs + tx;
            _mm512_mask_storeu_ps(o, m, _mm512_sub_ps(b0, b2));
            _mm512_mask_storeu_ps(o + xs, m, _mm512_add_ps(b1, b2));
            _mm512_mask_storeu_ps(o + 2 * xs, m, _mm512_sub_ps(b2, b1));
            _mm512_mask_storeu_ps(o + 3 * xs, m, _mm512_sub_ps(b1, b3));
        }
    }
#endif
    for (; tx < tw; tx++) {
        float d[4][4], b[4][4];
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 4; j++)
            {
                int x = 2 * tx - 1 + j;
                d[i][j] = x >= 0 && x < W ? src[i][x] : 0.0f;
            }
        for (int j = 0; j < 4; j++) {
            b[0][j] = d[0][j] - d[2][j];
            b[1][j] = d[1][j] + d[2][j];
            b[2][j] = d[2][j] - d[1][j];
            b[3][j] = d[1][j] - d[3][j];
        }
        for (int i = 0; i < 4; i++) {
            v[(4 * i + 0) * xs + tx] = b[i][0] - b[i][2];
            v[(4 * i + 1) * xs + tx] = b[i][1] + b[i][2];
            v[(4 * i + 2) * xs + tx] = b[i][2] - b[i][1];
            v[(4 * i + 3) * xs + tx] = b[i][1] - b[i][3];
        }
    }
}

/* A^T m A + bias for one tile row of one output channel: m[xi * ms + tx] -> output rows
 * o0 (2ty) and o1 (2ty+1, NULL past the plane), W columns; then max(0, .) if relu. */
static void output_transform_row(float *o0, float *o1, const float *m, size_t ms, int tw,
                                 int W, float bias, int relu)
{
    int tx = 0;
#ifdef __AVX512F__
    const __m512i lo_idx = _mm512_setr_epi32(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22,
                                             7, 23);
    const __m512i hi_idx = _mm512_add_epi32(lo_idx, _mm512_set1_epi32(8));
    const __m512 vb = _mm512_set1_ps(bias);
    for (; tx < tw; tx += 16) {
        __mmask16 mt = tw - tx >= 16 ? 0xffff : (__mmask16)((1u << (tw - tx)) - 1);
        __m512 r0[4], r1[4];
        for (int j = 0; j < 4; j++) {
            __m512 m0 = _mm512_maskz_loadu_ps(mt, m + (size_t)j * ms + tx);
            __m512 m1 = _mm512_maskz_loadu_ps(mt, m + (size_t)(4 + j) * ms + tx);
            __m512 m2 = _mm512_maskz_loadu_ps(mt, m + (size_t)(8 + j) * ms + tx);
            __m512 m3 = _mm512_maskz_loadu_ps(mt, m + (size_t)(12 + j) * ms + tx);
            r0[j] = _mm512_add_ps(_mm512_add_ps(m0, m1), m2);
            r1[j] = _mm512_sub_ps(_mm512_sub_ps(m1, m2), m3);
        }
        int left = W - 2 * tx; /* output columns from 2tx to the plane's edge */
        __mmask16 mlo = left >= 16 ? 0xffff : (__mmask16)((1u << left) - 1);
        __mmask16 mhi = left >= 32 ? 0xffff : left <= 16 ? 0 : (__mmask16)((1u << (left - 16)) - 1);
        for (int i = 0; i < 2; i++) {
            float *o = i ? o1 : o0;
            if (!o)
                break;
            const __m512 *r = i ? r1 : r0;
            __m512 y0 = _mm512_add_ps(_mm512_add_ps(_mm512_add_ps(r[0], r[1]), r[2]), vb);
            __m512 y1 = _mm512_add_ps(_mm512_sub_ps(_mm512_sub_ps(r[1], r[2]), r[3]), vb);
            if (relu) {
                y0 = _mm512_max_ps(y0, _mm512_setzero_ps());
                y1 = _mm512_max_ps(y1, _mm512_setzero_ps());
            }
            _mm512_mask_storeu_ps(o + 2 * tx, mlo, _mm512_permutex2var_ps(y0, lo_idx, y1));
            _mm512_mask_storeu_ps(o + 2 * tx + 16, mhi, _mm512_permutex2var_ps(y0, hi_idx, y1));
        }
    }
#endif
    for (; tx < tw; tx++) {
        float r[2][4];
        for (int j = 0; j < 4; j++) {
            float m0 = m[j * ms + tx], m1 = m[(4 + j) * ms + tx], m2 = m[(8 + j) * ms + tx],
                  m3 = m[(12 + j) * ms + tx];
            r[0][j] = m0 + m1 + m2;
            r[1][j] = m1 - m2 - m3;
        }
        for (int i = 0; i < 2; i++) {
            float *o = i ? o1 : o0;
            if (!o)
                break;
            float y0 = r[i][0] + r[i][1] + r[i][2] + bias;
            float y1 = r[i][1] - r[i][2] - r[i][3] + bias;
            o[2 * tx] = relu && !(y0 > 0.0f) ? 0.0f : y0;
            if (2 * tx + 1 < W)
                o[2 * tx + 1] = relu && !(y1 > 0.0f) ? 0.0f : y1;
        }
    }
}

#ifdef __AVX512F__
static __mmask16 lanes(int left)
{
    return left >= 16 ? 0xffff : left <= 0 ? 0 : (__mmask16)((1u << left) - 1);
}

/* One 8 x (16 nv) block of M = U V: acc[r][j] += U[k0 + r][c] * V[c][t0 + 16 j + lane].
 * nv is a compile-time constant at every call, so the accumulators live in registers. */
static inline __attribute__((always_inline)) void
gemm_block(float *M, const float *U, const float *V, int C, int T, int k0, int t0, int nv)
{
    __mmask16 m[3];
    for (int j = 0; j < 3; j++)
        m[j] = lanes(T - t0 - 16 * j);
    __m512 acc[8][3];
    for (int r = 0; r < 8; r++)
        for (int j = 0; j < nv; j++)
            acc[r][j] = _mm512_setzero_ps();
    const float *u = U + (size_t)k0 * C;
    const float *v = V + t0;
    for (int c = 0; c < C; c++, v += T, u++) {
        __m512 vv[3];
        for (int j = 0; j < nv; j++)
            vv[j] = _mm512_maskz_loadu_ps(m[j], v + 16 * j);
        for (int r = 0; r < 8; r++) {
            __m512 b = _mm512_set1_ps(u[(size_t)r * C]);
            for (int j = 0; j < nv; j++)
                acc[r][j] = _mm512_fmadd_ps(b, vv[j], acc[r][j]);
        }
    }
    float *o = M + (size_t)k0 * T + t0;
    for (int r = 0; r < 8; r++)
        for (int j = 0; j < nv; j++)
            _mm512_mask_storeu_ps(o + (size_t)r * T + 16 * j, m[j], acc[r][j]);
}
#endif

/* M (K x T, row stride T) = U (K x C) * V (C x T, row stride T).
 * Register tile: 8 output channels x 48 tiles (24 accumulators); each step over c loads
 * three vectors of V and broadcasts 8 weights for 24 FMAs. The remainder of T takes a
 * 32- or 16-wide block. No packing: V is already laid out as the kernel reads it, and
 * its panel is reused from L1 across all K. The sum over c runs in order 0..C-1 for every
 * output, whatever T or the thread. */
static void gemm_kct(float *M, const float *U, const float *V, int K, int C, int T)
{
#ifdef __AVX512F__
    if (K % 8 == 0) {
        int t0 = 0;
        for (; T - t0 > 32; t0 += 48)
            for (int k0 = 0; k0 < K; k0 += 8)
                gemm_block(M, U, V, C, T, k0, t0, 3);
        if (T - t0 > 16)
            for (int k0 = 0; k0 < K; k0 += 8)
                gemm_block(M, U, V, C, T, k0, t0, 2);
        else if (T - t0 > 0)
            for (int k0 = 0; k0 < K; k0 += 8)
                gemm_block(M, U, V, C, T, k0, t0, 1);
        return;
    }
#endif
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, K, T, C, 1.0f, U, C, V, T, 0.0f, M, T);
}

#if defined(__AVX512F__) && defined(__AVX512BF16__)
/* The fast path's product: the same blocking as gemm_block over channel pairs, one
 * VDPBF16PS doing both channels' multiply-adds (bf16 products, fp32 sums). */
static inline __attribute__((always_inline)) void
gemm_block_bf16(float *M, const uint32_t *Ub, const uint32_t *Vb, int C2, int T, int k0, int t0,
                int nv)
{
    __mmask16 m[3];
    for (int j = 0; j < 3; j++)
        m[j] = lanes(T - t0 - 16 * j);
    __m512 acc[8][3];
    for (int r = 0; r < 8; r++)
        for (int j = 0; j < nv; j++)
            acc[r][j] = _mm512_setzero_ps();
    const uint32_t *u = Ub + (size_t)k0 * C2;
    const uint32_t *v = Vb + t0;
    for (int p = 0; p < C2; p++, v += T, u++) {
        __m512bh vv[3];
        for (int j = 0; j < nv; j++)
            vv[j] = (__m512bh)_mm512_maskz_loadu_epi32(m[j], v + 16 * j);
        for (int r = 0; r < 8; r++) {
            __m512bh b = (__m512bh)_mm512_set1_epi32((int)u[(size_t)r * C2]);
            for (int j = 0; j < nv; j++)
                acc[r][j] = _mm512_dpbf16_ps(acc[r][j], b, vv[j]);
        }
    }
    float *o = M + (size_t)k0 * T + t0;
    for (int r = 0; r < 8; r++)
        for (int j = 0; j < nv; j++)
            _mm512_mask_storeu_ps(o + (size_t)r * T + 16 * j, m[j], acc[r][j]);
}

/* V (C, T) floats -> channel pairs of bf16 (C/2, T) in place: pair p's row lands where
 * float row p was, which pairs 0..p-1 (rows 0..2p-1) have already been read from. */
static void pack_bf16_pairs(float *V, int C, int T)
{
    const __m512i lo_idx = _mm512_setr_epi32(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22,
                                             7, 23);
    const __m512i hi_idx = _mm512_add_epi32(lo_idx, _mm512_set1_epi32(8));
    uint32_t *out = (uint32_t *)V;
    for (int p = 0; p < C / 2; p++) {
        const float *a = V + (size_t)(2 * p) * T, *b = a + T;
        uint32_t *o = out + (size_t)p * T;
        for (int t = 0; t < T; t += 16) {
            __mmask16 m = lanes(T - t);
            __m512 x = _mm512_maskz_loadu_ps(m, a + t), y = _mm512_maskz_loadu_ps(m, b + t);
            __m512 first = _mm512_permutex2var_ps(x, lo_idx, y);  /* tiles t..t+7 */
            __m512 second = _mm512_permutex2var_ps(x, hi_idx, y); /* tiles t+8..t+15 */
            __m512i packed = (__m512i)_mm512_cvtne2ps_pbh(second, first);
            _mm512_mask_storeu_epi32(o + t, m, packed);
        }
    }
}

static void gemm_kct_bf16(float *M, const uint32_t *Ub, float *V, int K, int C, int T)
{
    pack_bf16_pairs(V, C, T);
    const uint32_t *Vb = (const uint32_t *)V;
    int t0 = 0, C2 = C / 2;
    for (; T - t0 > 32; t0 += 48)
        for (int k0 = 0; k0 < K; k0 += 8)
            gemm_block_bf16(M, Ub, Vb, C2, T, k0, t0, 3);
    if (T - t0 > 16)
        for (int k0 = 0; k0 < K; k0 += 8)
            gemm_block_bf16(M, Ub, Vb, C2, T, k0, t0, 2);
    else if (T - t0 > 0)
        for (int k0 = 0; k0 < K; k0 += 8)
            gemm_block_bf16(M, Ub, Vb, C2, T, k0, t0, 1);
}
#endif

int conv_have_bf16(void)
{
#if defined(__AVX512F__) && defined(__AVX512BF16__)
    return 1;
#else
    return 0;
#endif
}

#if defined(__AMX_TILE__) && defined(__AMX_BF16__) && defined(__AVX512BF16__) && defined(__linux__)
#define HAVE_AMX 1
#include <sys/syscall.h>
#include <unistd.h>

typedef struct amx_tile_config {
    uint8_t palette, start_row, reserved[14];
    uint16_t colsb[16];
    uint8_t rows[16];
} __attribute__((packed)) amx_tile_config;

/* Linux hands out the 8 KB AMX tile state only on request (ARCH_REQ_XCOMP_PERM for
 * XFEATURE_XTILEDATA); without it the first tile instruction faults. */
int conv_enable_amx(void)
{
    return syscall(SYS_arch_prctl, 0x1023 /* ARCH_REQ_XCOMP_PERM */, 18) == 0;
}

/* M (K x Tp) = U (K x C) * V (C x Tp) on AMX: tiles of 16 rows x 64 bytes. A (tmm4/5):
 * 16 output channels x 32 input channels of Ub; B (tmm6/7): 16 channel pairs x 16 tiles
 * of Vb, already in the pair-interleaved (VNNI) layout AMX wants; C (tmm0-3): 2 x 2
 * blocks of 16 x 16 fp32 sums. K % 32 == 0, C % 32 == 0, Tp % 16 == 0. */
static void gemm_amx(float *M, const uint32_t *Ub, const uint32_t *Vb, int K, int C, int Tp)
{
    const int C2 = C / 2;
    const size_t lda = (size_t)C2 * 4, ldb = (size_t)Tp * 4;
    for (int k0 = 0; k0 < K; k0 += 32)
        for (int t0 = 0; t0 < Tp; t0 += 32) {
            const int two = t0 + 16 < Tp;
            _tile_zero(0);
            _tile_zero(1);
            _tile_zero(2);
            _tile_zero(3);
            for (int p0 = 0; p0 < C2; p0 += 16) {
                _tile_loadd(4, Ub + (size_t)k0 * C2 + p0, lda);
                _tile_loadd(5, Ub + (size_t)(k0 + 16) * C2 + p0, lda);
                _tile_loadd(6, Vb + (size_t)p0 * Tp + t0, ldb);
                _tile_dpbf16ps(0, 4, 6);
                _tile_dpbf16ps(2, 5, 6);
                if (two) {
                    _tile_loadd(7, Vb + (size_t)p0 * Tp + t0 + 16, ldb);
                    _tile_dpbf16ps(1, 4, 7);
                    _tile_dpbf16ps(3, 5, 7);
                }
            }
            _tile_stored(0, M + (size_t)k0 * Tp + t0, ldb);
            _tile_stored(2, M + (size_t)(k0 + 16) * Tp + t0, ldb);
            if (two) {
                _tile_stored(1, M + (size_t)k0 * Tp + t0 + 16, ldb);
                _tile_stored(3, M + (size_t)(k0 + 16) * Tp + t0 + 16, ldb);
            }
        }
}

static void amx_configure(void)
{
    amx_tile_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.palette = 1;
    for (int i = 0; i < 8; i++) {
        cfg.colsb[i] = 64;
        cfg.rows[i] = 16;
    }
    _tile_loadconfig(&cfg);
}
#else
int conv_enable_amx(void)
{
    return 0;
}
#endif

/* Columns of a chunk's V and M are padded to Tp, a multiple of 16, so every kernel works
 * on whole vectors and tiles; the padding columns are zeroed in V and never read in M. */
static void winograd_chunk(const conv_layer *L, size_t row0, int rows_in_chunk, int k0, int k1,
                           float *scratch)
{
    const int C = L->C, K = L->K, H = L->H, W = L->W;
    int th, tw;
    winograd_tiles(L, &th, &tw);
    const size_t plane = (size_t)H * W, T = (size_t)rows_in_chunk * tw, Tp = (T + 15) / 16 * 16;
    float *V = scratch;                      // (16, C, Tp)
    float *M = V + 16 * (size_t)C * Tp;      // (16, K, Tp)
    float *zeros = M + 16 * (size_t)K * Tp; // a row of W zeros, above and below the plane
    memset(zeros, 0, (size_t)W * sizeof(float));

    for (int q = 0; q < rows_in_chunk; q++) {
        size_t r = row0 + (size_t)q;
        int n = (int)(r / th), ty = (int)(r % th);
        for (int c = 0; c < C; c++) {
            const float *x = L->in + ((size_t)n * C + c) * plane;
            const float *src[4];
            for (int i = 0; i < 4; i++) {
                int y = 2 * ty - 1 + i;
                src[i] = y >= 0 && y < H ? x + (size_t)y * W : zeros;
            }
            input_transform_row(V + (size_t)c * Tp + (size_t)q * tw, (size_t)C * Tp, src, tw, W);
        }
    }
    if (Tp > T)
        for (size_t i = 0; i < 16 * (size_t)C; i++)
            memset(V + i * Tp + T, 0, (Tp - T) * sizeof(float));

    /* Output channels k0..k1 only: rows k0..k1 of each U[xi] and M[xi]. */
    const int Ks = k1 - k0;
#ifdef HAVE_AMX
    if (L->Ub && L->amx && Ks % 32 == 0 && C % 32 == 0) {
        amx_configure();
        for (int xi = 0; xi < 16; xi++) {
            float *v = V + (size_t)xi * C * Tp;
            pack_bf16_pairs(v, C, (int)Tp);
            gemm_amx(M + ((size_t)xi * K + k0) * Tp, L->Ub + ((size_t)xi * K + k0) * (C / 2),
                     (const uint32_t *)v, Ks, C, (int)Tp);
        }
        _tile_release();
    } else
#endif
#if defined(__AVX512F__) && defined(__AVX512BF16__)
    if (L->Ub && Ks % 8 == 0 && C % 2 == 0) {
        for (int xi = 0; xi < 16; xi++)
            gemm_kct_bf16(M + ((size_t)xi * K + k0) * Tp, L->Ub + ((size_t)xi * K + k0) * (C / 2),
                          V + (size_t)xi * C * Tp, Ks, C, (int)Tp);
    } else
#endif
        for (int xi = 0; xi < 16; xi++)
            gemm_kct(M + ((size_t)xi * K + k0) * Tp, L->U + ((size_t)xi * K + k0) * C,
                     V + (size_t)xi * C * Tp, Ks, C, (int)Tp);

    for (int q = 0; q < rows_in_chunk; q++) {
        size_t r = row0 + (size_t)q;
        int n = (int)(r / th), ty = (int)(r % th);
        for (int k = k0; k < k1; k++) {
            float *o = L->out + ((size_t)n * K + k) * plane + (size_t)(2 * ty) * W;
            output_transform_row(o, 2 * ty + 1 < H ? o + W : NULL,
                                 M + (size_t)k * Tp + (size_t)q * tw, (size_t)K * Tp, tw, W,
                                 L->bias[k], L->relu);
        }
    }
}

/* ------------------------------------------------------------ im2col chunk -------- */

static void im2col_chunk(const conv_layer *L, size_t p0, int T, int k0, int k1, float *scratch)
{
    const int C = L->C, K = L->K, H = L->H, W = L->W;
    const size_t plane = (size_t)H * W;
    const int n0 = (int)(p0 / plane), y0 = (int)(p0 % plane / W), x0 = (int)(p0 % W);
    float *col = scratch;                   // (9C, T)
    float *M = scratch + 9 * (size_t)C * T; // (K, T)
    for (int c = 0; c < C; c++)
        for (int r = 0; r < 9; r++) {
            int dy = r / 3 - 1, dx = r % 3 - 1;
            float *dst = col + ((size_t)c * 9 + r) * T;
            int n = n0, y = y0, x = x0;
            for (int t = 0; t < T; t++) {
                int sy = y + dy, sx = x + dx;
                dst[t] = sy >= 0 && sy < H && sx >= 0 && sx < W
                             ? L->in[((size_t)n * C + c) * plane + (size_t)sy * W + sx]
                             : 0.0f;
                if (++x == W) {
                    x = 0;
                    if (++y == H) {
                        y = 0;
                        n++;
                    }
                }
            }
        }
    gemm_kct(M + (size_t)k0 * T, L->weight + (size_t)k0 * 9 * C, col, k1 - k0, 9 * C, T);
    for (int k = k0; k < k1; k++) {
        const float *m = M + (size_t)k * T;
        const float b = L->bias[k];
        size_t g = p0;
        for (int t = 0; t < T;) {
            /* One run of pixels within an image. */
            size_t n = g / plane, p = g % plane;
            int run = (int)(plane - p < (size_t)(T - t) ? plane - p : (size_t)(T - t));
            float *o = L->out + (n * K + k) * plane + p;
            for (int i = 0; i < run; i++) {
                float v = m[t + i] + b;
                o[i] = L->relu && !(v > 0.0f) ? 0.0f : v;
            }
            t += run;
            g += (size_t)run;
        }
    }
}

void conv_run_chunk(const conv_layer *L, size_t chunk, float *scratch)
{
    const int kblocks = L->kblocks > 1 ? L->kblocks : 1;
    const int kb = (int)(chunk % kblocks), k0 = L->K / kblocks * kb, k1 = k0 + L->K / kblocks;
    chunk /= kblocks;
    size_t units = units_per_image(L), begin;
    int count;
    if (chunks_span_images(L)) {
        size_t total = (size_t)L->N * units;
        begin = chunk * L->chunk;
        count = (int)(total - begin < (size_t)L->chunk ? total - begin : (size_t)L->chunk);
    } else {
        size_t per_image = (units + L->chunk - 1) / L->chunk;
        size_t n = chunk / per_image, first = (chunk % per_image) * L->chunk;
        count = (int)(units - first < (size_t)L->chunk ? units - first : (size_t)L->chunk);
        begin = n * units + first;
    }
    if (L->winograd)
        winograd_chunk(L, begin, count, k0, k1, scratch);
    else
        im2col_chunk(L, begin, count, k0, k1, scratch);
}
