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
 * with direct summation to fp32 rounding (tests/unit/test_nn_conv.c measures it).
 *
 * im2col: for thin inputs (conv1_1 has 3 channels) and tiny planes, where the Winograd
 * products would be too narrow: col (9C x T) and one product W (K x 9C) * col.
 *
 * Both write a chunk's product into a scratch buffer and scatter it, plus bias, into the
 * NCHW output: a chunk may span images, which keeps products wide in the deep layers.
 */
#include <cblas.h>
#include <string.h>

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

/* ------------------------------------------------------------ chunk geometry ------ */

/* Tiles of one plane and their total over the batch. */
static void winograd_tiles(const conv_layer *L, int *th, int *tw)
{
    *th = (L->H + 1) / 2;
    *tw = (L->W + 1) / 2;
}

size_t conv_chunk_count(const conv_layer *L)
{
    size_t units;
    if (L->winograd) {
        int th, tw;
        winograd_tiles(L, &th, &tw);
        units = (size_t)L->N * th * tw;
    } else {
        units = (size_t)L->N * L->H * L->W;
    }
    return (units + L->chunk - 1) / L->chunk;
}

/* Columns per chunk so that the chunk's buffers fit in about `budget` bytes; a multiple of
 * 16 (one AVX-512 register of floats) and at least 16. */
int conv_chunk_columns(int winograd, int C, int K, size_t budget)
{
    size_t per_col = winograd ? 16 * (size_t)(C + K) * sizeof(float)
                              : (9 * (size_t)C + (size_t)K) * sizeof(float);
    size_t t = budget / per_col;
    t = t / 16 * 16;
    return t < 16 ? 16 : (int)t;
}

size_t conv_scratch_floats(int winograd, int C, int K, int chunk)
{
    return winograd ? 16 * (size_t)(C + K) * chunk : (9 * (size_t)C + (size_t)K) * chunk;
}

/* ------------------------------------------------------------ Winograd chunk ------ */

static void winograd_chunk(const conv_layer *L, size_t t0, int T, float *scratch)
{
    const int C = L->C, K = L->K, H = L->H, W = L->W;
    int th, tw;
    winograd_tiles(L, &th, &tw);
    const size_t per_image = (size_t)th * tw, plane = (size_t)H * W;
    float *V = scratch;                   // (16, C, T)
    float *M = scratch + 16 * (size_t)C * T; // (16, K, T)

    /* Input transform: V[xi][c][t] = (B^T d B)[xi]. */
    for (int c = 0; c < C; c++) {
        size_t g = t0;
        int n = (int)(g / per_image), rest = (int)(g % per_image);
        int ty = rest / tw, tx = rest % tw;
        for (int t = 0; t < T; t++) {
            const float *x = L->in + ((size_t)n * C + c) * plane;
            int y0 = 2 * ty - 1, x0 = 2 * tx - 1;
            float d[4][4];
            if (y0 >= 0 && x0 >= 0 && y0 + 4 <= H && x0 + 4 <= W) {
                for (int i = 0; i < 4; i++)
                    memcpy(d[i], x + (size_t)(y0 + i) * W + x0, sizeof d[i]);
            } else {
                for (int i = 0; i < 4; i++)
                    for (int j = 0; j < 4; j++) {
                        int yy = y0 + i, xx = x0 + j;
                        d[i][j] = yy >= 0 && yy < H && xx >= 0 && xx < W
                                      ? x[(size_t)yy * W + xx]
                                      : 0.0f;
                    }
            }
            float b[4][4]; /* B^T d */
            for (int j = 0; j < 4; j++) {
                b[0][j] = d[0][j] - d[2][j];
                b[1][j] = d[1][j] + d[2][j];
                b[2][j] = d[2][j] - d[1][j];
                b[3][j] = d[1][j] - d[3][j];
            }
            float *v = V + (size_t)c * T + t;
            const size_t xs = (size_t)C * T;
            for (int i = 0; i < 4; i++) { /* (B^T d) B */
                v[(4 * i + 0) * xs] = b[i][0] - b[i][2];
                v[(4 * i + 1) * xs] = b[i][1] + b[i][2];
                v[(4 * i + 2) * xs] = b[i][2] - b[i][1];
                v[(4 * i + 3) * xs] = b[i][1] - b[i][3];
            }
            if (++tx == tw) {
                tx = 0;
                if (++ty == th) {
                    ty = 0;
                    n++;
                }
            }
        }
    }

    for (int xi = 0; xi < 16; xi++)
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, K, T, C, 1.0f,
                    L->U + (size_t)xi * K * C, C, V + (size_t)xi * C * T, T, 0.0f,
                    M + (size_t)xi * K * T, T);

    /* Output transform: Y = A^T m A + bias, clipped to the plane. */
    const size_t ms = (size_t)K * T;
    for (int k = 0; k < K; k++) {
        const float bias = L->bias[k];
        size_t g = t0;
        int n = (int)(g / per_image), rest = (int)(g % per_image);
        int ty = rest / tw, tx = rest % tw;
        for (int t = 0; t < T; t++) {
            const float *m = M + (size_t)k * T + t;
            float r[2][4]; /* A^T m */
            for (int j = 0; j < 4; j++) {
                float m0 = m[j * ms], m1 = m[(4 + j) * ms], m2 = m[(8 + j) * ms],
                      m3 = m[(12 + j) * ms];
                r[0][j] = m0 + m1 + m2;
                r[1][j] = m1 - m2 - m3;
            }
            float *o = L->out + ((size_t)n * K + k) * plane;
            int y = 2 * ty, x = 2 * tx;
            for (int i = 0; i < 2; i++) {
                if (y + i >= H)
                    break;
                float y0v = r[i][0] + r[i][1] + r[i][2] + bias;
                float y1v = r[i][1] - r[i][2] - r[i][3] + bias;
                o[(size_t)(y + i) * W + x] = y0v;
                if (x + 1 < W)
                    o[(size_t)(y + i) * W + x + 1] = y1v;
            }
            if (++tx == tw) {
                tx = 0;
                if (++ty == th) {
                    ty = 0;
                    n++;
                }
            }
        }
    }
}

/* ------------------------------------------------------------ im2col chunk -------- */

static void im2col_chunk(const conv_layer *L, size_t p0, int T, float *scratch)
{
    const int C = L->C, K = L->K, H = L->H, W = L->W;
    const size_t plane = (size_t)H * W;
    float *col = scratch;                 // (9C, T)
    float *M = scratch + 9 * (size_t)C * T; // (K, T)
    for (int c = 0; c < C; c++)
        for (int r = 0; r < 9; r++) {
            int dy = r / 3 - 1, dx = r % 3 - 1;
            float *dst = col + ((size_t)c * 9 + r) * T;
            size_t g = p0;
            for (int t = 0; t < T; t++, g++) {
                size_t n = g / plane, p = g % plane;
                int y = (int)(p / W) + dy, x = (int)(p % W) + dx;
                dst[t] = y >= 0 && y < H && x >= 0 && x < W
                             ? L->in[(n * C + c) * plane + (size_t)y * W + x]
                             : 0.0f;
            }
        }
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, K, T, 9 * C, 1.0f, L->weight, 9 * C,
                col, T, 0.0f, M, T);
    for (int k = 0; k < K; k++) {
        size_t g = p0;
        for (int t = 0; t < T; t++, g++) {
            size_t n = g / plane, p = g % plane;
            L->out[(n * K + k) * plane + p] = M[(size_t)k * T + t] + L->bias[k];
        }
    }
}

void conv_run_chunk(const conv_layer *L, size_t chunk, float *scratch)
{
    size_t units;
    if (L->winograd) {
        int th, tw;
        winograd_tiles(L, &th, &tw);
        units = (size_t)L->N * th * tw;
    } else {
        units = (size_t)L->N * L->H * L->W;
    }
    size_t begin = chunk * L->chunk;
    int T = (int)(units - begin < (size_t)L->chunk ? units - begin : (size_t)L->chunk);
    if (L->winograd)
        winograd_chunk(L, begin, T, scratch);
    else
        im2col_chunk(L, begin, T, scratch);
}
