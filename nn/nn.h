/*
 * nn: the VGG19 Gram descriptor (Gatys et al.), safetensors weights and .npy output.
 *
 * Plain float arrays in, plain float arrays out: every layer is an explicit *_forward
 * function in the style of llm.c, activations are NCHW (one image after another, channels
 * of an image after one another, rows top first). nn knows nothing of graphs, rendering or
 * image files; the caller reads an image (imageio) and hands linear RGB floats to
 * vgg_preprocess().
 *
 * The descriptor (../shared/seed/facts-from-thesis-code.md): the linear image clamped to
 * [0,1], centre-cropped to 224x224, ImageNet-normalised, through torchvision VGG19's
 * `features` up to conv5_4 with every pooling replaced by the selected mode; Gram matrices
 * G = F F^T / (H W) right after conv1_2, conv2_2, conv3_4, conv4_4 and conv5_4 (before
 * their ReLU unless post_relu), upper triangle with diagonal, row by row (G[0][0..C-1],
 * G[1][1..C-1], ...), concatenated: 2080 + 8256 + 32896 + 131328 + 131328 = 305,888 floats.
 *
 * Every call that can fail takes (err, errlen) and writes a message naming the file and
 * the place.
 */
#ifndef IMSYNTH_NN_H
#define IMSYNTH_NN_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------- safetensors ------ */

typedef enum nn_dtype { NN_F32, NN_F16, NN_BF16 } nn_dtype;

typedef struct nn_tensor_info {
    char name[128];
    nn_dtype dtype;
    int ndim;
    int64_t shape[8];
    uint64_t begin, end; /* byte offsets into the data section, end exclusive */
} nn_tensor_info;

/* A safetensors file held in memory with its header validated: the 8-byte header length
 * fits the file, the header is a JSON object, every tensor has a known dtype, a shape whose
 * element count times the dtype size equals its byte range, a range inside the data
 * section, and no two ranges overlap. */
typedef struct nn_safetensors {
    char path[512];
    unsigned char *file; /* whole file */
    size_t file_size;
    const unsigned char *data; /* data section (after the header) */
    size_t data_size;
    int count;
    nn_tensor_info *tensors;
} nn_safetensors;

int nn_safetensors_open(const char *path, nn_safetensors *st, char *err, size_t errlen);
void nn_safetensors_close(nn_safetensors *st);
/* Index of the tensor named `name`, or -1. */
int nn_safetensors_find(const nn_safetensors *st, const char *name);
/* Convert tensor `name` to float32 into out (n floats), checking its shape equals
 * shape[0..ndim-1]. Returns 0, or -1 with a message naming the file and the tensor. */
int nn_safetensors_read_f32(const nn_safetensors *st, const char *name, int ndim,
                            const int64_t *shape, float *out, char *err, size_t errlen);

/* ---------------------------------------------------------------- layers ----------- */

/* 3x3 convolution, stride 1, zero padding 1, with bias. in (N,C,H,W), w (K,C,3,3) as
 * torch stores it, b (K), out (N,K,H,W). Direct summation in a fixed order: the reference
 * the fast kernels are tested against. */
void conv3x3_forward_reference(float *out, const float *in, const float *w, const float *b,
                               int N, int C, int K, int H, int W);
/* x = max(x, 0), in place over n floats. */
void relu_forward(float *x, size_t n);
/* Pooling, no padding, floor mode (torch defaults): in (N,C,H,W), out (N,C,H/s,W/s). */
void avgpool_forward(float *out, const float *in, int N, int C, int H, int W, int kernel,
                     int stride);
void maxpool_forward(float *out, const float *in, int N, int C, int H, int W, int kernel,
                     int stride);
/* Gram of one image's features f (C, HW): writes the upper triangle with diagonal of
 * f f^T / HW, row by row, C(C+1)/2 floats. scratch holds C*C floats. */
void gram_upper_forward(float *out, const float *f, int C, int HW, float *scratch);

/* ---------------------------------------------------------------- VGG19 ------------ */

enum {
    VGG_INPUT_SIZE = 224,
    VGG_CONV_LAYERS = 16,
    VGG_GRAM_LAYERS = 5,
    VGG19_DESCRIPTOR_SIZE = 305888,
};

typedef enum vgg_pool { VGG_POOL_AVG3, VGG_POOL_AVG2, VGG_POOL_MAX2 } vgg_pool;
/* FP32: results equal the direct fp32 convolution to rounding (Winograd F(2x2,3x3),
 * whose transforms are exact in binary: +-1 and 1/2 factors); matches PyTorch within
 * 1e-6 of each Gram layer's largest magnitude.
 * FAST: the Winograd products in bf16 with fp32 sums, on AMX tiles where the CPU and
 * kernel allow (Sapphire Rapids and later), else AVX512_BF16, else the same as FP32.
 * Deviation from FP32 measured at 0.5-0.7% of each layer's largest magnitude, promised
 * below 1% (tests/unit/test_nn_vgg.c, test_nn_torch.c; BENCHMARKS.md). */
typedef enum vgg_precision { VGG_PRECISION_FP32, VGG_PRECISION_FAST } vgg_precision;

/* Parse "avg3" / "avg2" / "max2" and "fp32" / "fast"; -1 when unknown. */
int vgg_pool_parse(const char *s);
int vgg_precision_parse(const char *s);

/* The network's weights. Channel widths are a parameter so that tests can run a reduced
 * VGG19 (same 16 convs, pools and Gram taps, fewer channels); the real one has
 * widths {64, 128, 256, 512, 512} per block. */
typedef struct vgg19 {
    int width[5];             /* output channels of blocks 1..5 */
    int cin[VGG_CONV_LAYERS]; /* input channels of each conv */
    int cout[VGG_CONV_LAYERS];
    float *weight[VGG_CONV_LAYERS]; /* (cout, cin, 3, 3) */
    float *bias[VGG_CONV_LAYERS];   /* (cout) */
} vgg19;

extern const int vgg19_standard_width[5];

/* Seeded random initialisation (see vgg19.c for which and why): He-normal weights,
 * std sqrt(2 / (9 cin)), zero bias, from a counter-based generator so the weights are a
 * pure function of (seed, layer, index). Returns 0 or -1 (out of memory). */
int vgg19_init_random(vgg19 *net, const int width[5], uint64_t seed);
/* Load torchvision key names features.{0,2,5,7,10,...,34}.{weight,bias}; widths from the
 * file's shapes (which must chain like VGG19's). Returns 0 or -1 with a message. */
int vgg19_load(vgg19 *net, const char *path, char *err, size_t errlen);
void vgg19_free(vgg19 *net);

/* Descriptor length and where each Gram layer starts in it (offsets[5] = total). */
size_t vgg19_descriptor_size(const vgg19 *net);
void vgg19_descriptor_offsets(const vgg19 *net, size_t offsets[VGG_GRAM_LAYERS + 1]);

typedef struct vgg_options {
    vgg_pool pool;
    int post_relu; /* Gram after the ReLU instead of before */
    vgg_precision precision;
    /* Worker threads (conv, Gram and pooling run on them); 0 = 1. The results do not
     * depend on it, nor on the batch size: every chunk of work is summed in a fixed
     * order. With threads > 1 pin OpenBLAS to one thread (OPENBLAS_NUM_THREADS=1 or
     * openblas_set_num_threads(1)): its own threads would only fight ours. */
    int threads;
} vgg_options;

/* Everything a forward pass needs, allocated once for up to max_batch images: the hot
 * loop allocates nothing. Not shareable between threads; one per caller thread. It keeps
 * a pointer to net, which must outlive it. */
typedef struct vgg_workspace vgg_workspace;

vgg_workspace *vgg_workspace_create(const vgg19 *net, const vgg_options *opt, int max_batch);
void vgg_workspace_free(vgg_workspace *ws);
/* Bytes the workspace holds (buffers + transformed weights), for memory reports. */
size_t vgg_workspace_bytes(const vgg_workspace *ws);

/* Linear RGB(A) or grey pixels (height x width x channels, top row first) with
 * width, height >= 224: clamp to [0,1], centre crop 224x224 (rows and columns from
 * (h-224)/2, (w-224)/2), ImageNet-normalise, write CHW (3,224,224) to out. */
int vgg_preprocess(float *out, const float *pixels, int width, int height, int channels);

/* Descriptors of n <= max_batch preprocessed images in (n,3,224,224): out is n rows of
 * vgg19_descriptor_size() floats. */
void vgg_describe(vgg_workspace *ws, const float *in, int n, float *out);

/* ---------------------------------------------------------------- .npy ------------- */

/* Write a C-order float32 array of shape (rows, cols) as NumPy .npy (format 1.0),
 * through a temporary file renamed into place. Returns 0 or -1 with a message. */
int nn_npy_write_f32(const char *path, const float *data, size_t rows, size_t cols,
                     char *err, size_t errlen);

/* The same, streamed: begin (creates the temporary file, writes the header), append rows,
 * then commit (checks that exactly `rows` rows came, renames into place) or abort
 * (removes the temporary file). begin returns NULL with a message on failure; commit and
 * append return 0 or -1 with a message, and a failed commit has already cleaned up. */
typedef struct nn_npy_writer nn_npy_writer;
nn_npy_writer *nn_npy_begin(const char *path, size_t rows, size_t cols, char *err,
                            size_t errlen);
int nn_npy_append(nn_npy_writer *w, const float *data, size_t rows, char *err, size_t errlen);
/* The same for any dtype: descr is NumPy's ("<i8", "|u1", "<f2", ...), itemsize its bytes;
 * append_raw takes rows x cols items as they lie in memory (little-endian). */
nn_npy_writer *nn_npy_begin_dtype(const char *path, const char *descr, size_t itemsize,
                                  size_t rows, size_t cols, char *err, size_t errlen);
int nn_npy_append_raw(nn_npy_writer *w, const void *data, size_t rows, char *err,
                      size_t errlen);
int nn_npy_commit(nn_npy_writer *w, char *err, size_t errlen);
void nn_npy_abort(nn_npy_writer *w);

/* IEEE binary16 <-> float: round to nearest even, overflow to infinity, NaN kept. */
uint16_t nn_float_to_half(float f);
float nn_half_to_float(uint16_t h);

/* Read a 0-, 1- or 2-D C-order .npy array (format 1.0-3.0) of float16/32/64, signed or
 * unsigned integers or bool, converted to float32: *data (malloc'd, caller frees) holds
 * rows x cols floats (a 1-D array of n is n x 1, a scalar 1 x 1). The data section must be
 * exactly the size the header claims, checked before anything is allocated. Returns 0,
 * or -1 with a message naming the file (then *data is NULL). */
int nn_npy_read_f32(const char *path, float **data, size_t *rows, size_t *cols, char *err,
                    size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
