/*
 * Linear layer on BLAS sgemm, in fixed blocks.
 *
 * Every sgemm is cut into at most LINEAR_BLOCKS pieces along a dimension that is NOT
 * summed over (output columns for the forward and the input gradient, output rows of the
 * weight gradient), and the cut depends only on the shapes. Threads take whole pieces, so
 * each output element is computed by the same sgemm call on the same operands whatever
 * the thread count: results are bit-identical for 1, 2 or 64 threads. Small products are
 * not cut (one call), again decided from the shapes alone.
 */
#include <assert.h>
#include <cblas.h>
#include <pthread.h>
#include <string.h>

#include "nn/nn.h"

enum {
    LINEAR_BLOCKS = 8,
    /* Below this many multiply-adds a product is one sgemm: thread start-up (~20 us)
     * would cost more than it saves. */
    LINEAR_SPLIT_MIN_MACS = 1 << 21,
    /* Pieces are multiples of this many columns, keeping the sgemm kernels on full
     * vector widths. */
    LINEAR_BLOCK_ALIGN = 32,
    /* ... and at least this wide: every piece packs the whole other operand again (the
     * (B, C) input for a forward piece), so thin pieces spend their time copying (pieces
     * of 64 columns packed as long as they multiplied, measured). */
    LINEAR_MIN_PIECE = 256,
};

typedef enum gemm_kind { GEMM_FORWARD, GEMM_DINPUT, GEMM_DWEIGHT } gemm_kind;

typedef struct gemm_job {
    gemm_kind kind;
    float *out;
    const float *a, *b; /* see run_piece */
    int B, C, OC;
    int split;          /* extent of the split dimension */
    int piece;          /* columns (or rows) per piece */
    int n_pieces;
    int first, stride;  /* this worker's pieces: first, first + stride, ... */
} gemm_job;

/* One piece [lo, hi) of the split dimension. */
static void run_piece(const gemm_job *j, int lo, int hi)
{
    int n = hi - lo;
    switch (j->kind) {
    case GEMM_FORWARD:
        // out[:, lo:hi] (B,n) = in (B,C) . w[lo:hi, :]^T   (a = in, b = w)
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, j->B, n, j->C, 1.0f, j->a, j->C,
                    j->b + (size_t)lo * j->C, j->C, 0.0f, j->out + lo, j->OC);
        break;
    case GEMM_DINPUT:
        // din[:, lo:hi] (B,n) = dout (B,OC) . w[:, lo:hi]   (a = dout, b = w)
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, j->B, n, j->OC, 1.0f, j->a,
                    j->OC, j->b + lo, j->C, 0.0f, j->out + lo, j->C);
        break;
    case GEMM_DWEIGHT:
        // dw[lo:hi, :] (n,C) += dout[:, lo:hi]^T . in (B,C)   (a = dout, b = in)
        cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, n, j->C, j->B, 1.0f, j->a + lo,
                    j->OC, j->b, j->C, 1.0f, j->out + (size_t)lo * j->C, j->C);
        break;
    }
}

static void *run_pieces(void *arg)
{
    const gemm_job *j = arg;
    for (int p = j->first; p < j->n_pieces; p += j->stride) {
        int lo = p * j->piece, hi = lo + j->piece < j->split ? lo + j->piece : j->split;
        run_piece(j, lo, hi);
    }
    return NULL;
}

static void run_gemm(gemm_kind kind, float *out, const float *a, const float *b, int B, int C,
                     int OC, int threads)
{
    gemm_job job = {.kind = kind, .out = out, .a = a, .b = b, .B = B, .C = C, .OC = OC};
    job.split = kind == GEMM_DINPUT ? C : OC;
    double macs = (double)B * C * OC;
    int pieces = macs < LINEAR_SPLIT_MIN_MACS ? 1 : LINEAR_BLOCKS;
    int piece = (job.split + pieces - 1) / pieces;
    if (piece < LINEAR_MIN_PIECE)
        piece = LINEAR_MIN_PIECE;
    piece = (piece + LINEAR_BLOCK_ALIGN - 1) / LINEAR_BLOCK_ALIGN * LINEAR_BLOCK_ALIGN;
    if (piece > job.split)
        piece = job.split;
    job.piece = piece > 0 ? piece : 1;
    job.n_pieces = (job.split + job.piece - 1) / job.piece;
    int workers = threads < job.n_pieces ? threads : job.n_pieces;
    if (workers < 1)
        workers = 1;
    gemm_job jobs[LINEAR_BLOCKS];
    pthread_t tid[LINEAR_BLOCKS];
    int started[LINEAR_BLOCKS] = {0};
    for (int w = 0; w < workers; w++) {
        jobs[w] = job;
        jobs[w].first = w;
        jobs[w].stride = workers;
    }
    for (int w = 1; w < workers; w++)
        started[w] = pthread_create(&tid[w], NULL, run_pieces, &jobs[w]) == 0;
    run_pieces(&jobs[0]);
    for (int w = 1; w < workers; w++) {
        if (started[w])
            pthread_join(tid[w], NULL);
        else /* no thread to be had: do its pieces here, same calls, same bits */
            run_pieces(&jobs[w]);
    }
}

void linear_forward(float *out, const float *in, const float *w, const float *b, int B, int C,
                    int OC, int threads)
{
    // out (B,OC) = in (B,C) . w^T (OC,C) + b (OC)
    run_gemm(GEMM_FORWARD, out, in, w, B, C, OC, threads);
    if (b)
        for (int i = 0; i < B; i++) {
            float *o = out + (size_t)i * OC;
            for (int k = 0; k < OC; k++)
                o[k] += b[k];
        }
}

void linear_backward(float *din, float *dw, float *db, const float *dout, const float *in,
                     const float *w, int B, int C, int OC, int threads)
{
    // backward of out = in . w^T + b
    // dw (OC,C) += dout^T (OC,B) . in (B,C)
    run_gemm(GEMM_DWEIGHT, dw, dout, in, B, C, OC, threads);
    // db (OC) += sum over rows of dout, rows in order
    if (db)
        for (int i = 0; i < B; i++) {
            const float *d = dout + (size_t)i * OC;
            for (int k = 0; k < OC; k++)
                db[k] += d[k];
        }
    // din (B,C) = dout (B,OC) . w (OC,C)
    if (din)
        run_gemm(GEMM_DINPUT, din, dout, w, B, C, OC, threads);
}

const char *nn_blas_warning(void)
{
    // OpenBLAS picks its kernels from the CPU model at load time; a model newer than the
    // library knows falls back to "Prescott" (SSE3), several times slower than the
    // AVX-512 kernels the CPU can run (seen: OpenBLAS 0.3.21 on family 6 model 207).
    const char *core = openblas_get_corename();
    if (core && !strcmp(core, "Prescott") && __builtin_cpu_supports("avx512f"))
        return "OpenBLAS runs its generic Prescott kernels on this AVX-512 CPU (a model it "
               "does not know): set OPENBLAS_CORETYPE=SkylakeX for ~6x faster training";
    return NULL;
}
