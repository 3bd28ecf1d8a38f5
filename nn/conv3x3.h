/* Internal to nn: the chunked 3x3 convolution engine (conv3x3.c) used by vgg19.c. */
#ifndef IMSYNTH_NN_CONV3X3_H
#define IMSYNTH_NN_CONV3X3_H

#include <stddef.h>
#include <stdint.h>

/* One conv layer's forward pass over a batch, split into independent chunks of `chunk`
 * tile rows (Winograd) or output pixels (im2col), counted across the batch. */
typedef struct conv_layer {
    const float *in; /* (N,C,H,W) */
    float *out;      /* (N,K,H,W) */
    int N, C, K, H, W;
    int winograd;        /* 1: U is used; 0: weight is used */
    const float *U;      /* (16,K,C) Winograd-transformed weights */
    const uint32_t *Ub;  /* fast path: U as bf16 channel pairs (16,K,C/2), or NULL */
    int amx;             /* fast path may use AMX (conv_enable_amx() succeeded) */
    const float *weight; /* (K,C*9) */
    const float *bias;   /* (K) */
    int relu;            /* apply max(0, .) to the output */
    int chunk;
    /* Output channels split into kblocks equal parts, each its own chunk (K / kblocks a
     * multiple of 32, so every kernel sees the same blocks of 8 or 32 channels and the
     * bits do not change): work for idle threads when a layer has few tile rows. */
    int kblocks;
} conv_layer;

void winograd_weights(float *U, const float *w, int K, int C);
/* U rounded to bf16, channel pairs packed in 32 bits (C even). */
void winograd_weights_bf16(uint32_t *Ub, const float *U, int K, int C);
/* Whether this build has the bf16 kernels (AVX512_BF16); without, Ub is ignored. */
int conv_have_bf16(void);
/* Ask the kernel for the AMX tile state; 1 when AMX kernels may run in this process. */
int conv_enable_amx(void);
/* Chunk size for a buffer budget: tile rows (Winograd) or output pixels (im2col). */
int conv_chunk_size(int winograd, int C, int K, int W, size_t budget);
size_t conv_scratch_floats(int winograd, int C, int K, int W, int chunk);
size_t conv_chunk_count(const conv_layer *L);
/* Compute chunk `chunk` of L; scratch holds conv_scratch_floats() floats. */
void conv_run_chunk(const conv_layer *L, size_t chunk, float *scratch);

#endif
