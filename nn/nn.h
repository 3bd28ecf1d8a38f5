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

/* ================================================================ MobileNetV2 ====== */
/*
 * An ImageNet-trained texture descriptor beside VGG19's: MobileNetV2 (width 1.0, Keras'
 * layer names and padding) from Conv1 to block_10, its weights converted by
 * scripts/get-mobilenetv2 from nsfwjs 4.4.0 (assets/mobilenetv2/, BatchNorm folded into
 * every conv). Per block i (0 = Keras' "expanded_conv", no expand layer):
 *   expand    1x1 conv cin -> cexp = 6 cin, ReLU6              (block_i_expand_relu)
 *   depthwise 3x3 per channel, stride 1 ('same': pad 1) or 2 (pad 0 top/left, 1
 *             bottom/right: Keras' ZeroPadding2D ((0,1),(0,1)) + 'valid'), ReLU6
 *   project   1x1 conv cexp -> cout, no activation, + the block's input when stride 1
 *             and cin == cout                                   (block_i_add)
 * Spatial sizes for a 224 input: Conv1 112; blocks 1-2 56; 3-5 28; 6-10 14. Any input
 * side that is a multiple of 16 works (every stride-2 layer then sees an even size).
 *
 * The descriptor: Gram G = F F^T / (H W) of each tapped activation, upper triangle with
 * diagonal row by row (gram_upper_forward's layout, as VGG19's), concatenated in tap order,
 * then the same again for the second scale if asked (the 224 input box-averaged 2x2 to
 * 112). Default taps: conv1 (32 ch at 112: the colours, which the deeper taps barely
 * keep), then one per resolution, each the widest activation there: block_1_expand (96
 * ch at 112), block_3_expand (144 at 56), block_6_expand (192 at 28), block_10_project
 * (96 at 14): 528 + 4656 + 10440 + 18528 + 4656 = 38,808 floats per scale. Why these:
 * BENCHMARKS.md, "MobileNetV2 descriptor" (conv1 halves the colour error of retrieval at
 * no cost in offset invariance).
 *
 * Input: the linear image clamped to [0,1], sRGB-encoded (the network was trained on
 * sRGB photos), centre-cropped to 224 like VGG's, in [0,1]: the scaling nsfwjs feeds
 * and the one the stored BatchNorm statistics fit (scripts/get-mobilenetv2 measures it:
 * the frozen blocks' moving means were re-estimated on [0,1] inputs), or 2x - 1 if
 * mnv2_options.signed_input (Keras' ImageNet preprocess_input).
 *
 * Results do not depend on the thread count: every image is computed by one worker
 * from start to end, with sgemms in a fixed order, provided OpenBLAS itself runs
 * single-threaded (OPENBLAS_NUM_THREADS=1 or openblas_set_num_threads(1)): a threaded
 * OpenBLAS splits its sums differently (measured: other bits).
 */

enum {
    MNV2_INPUT_SIZE = 224,
    MNV2_BLOCKS = 11,              /* expanded_conv (block 0) .. block_10 */
    MNV2_MAX_TAPS = 1 + 2 + 3 * 10, /* conv1; block 0 has no expand; three per block after */
    MNV2_DEFAULT_DESCRIPTOR_SIZE = 38808,
};

/* Where a tap reads: after Conv1's ReLU6 ("conv1"), after block i's expand ReLU6
 * ("block_i_expand"; block 0 has none), after its depthwise ReLU6 ("block_i_depthwise"),
 * or its output ("block_i_project": the projection plus the residual if any). Block 0 is
 * also accepted as "expanded_conv_depthwise" / "expanded_conv_project". */
typedef enum mnv2_point { MNV2_CONV1, MNV2_EXPAND, MNV2_DEPTHWISE, MNV2_PROJECT } mnv2_point;
typedef struct mnv2_tap {
    int block; /* 0..10; ignored for MNV2_CONV1 */
    mnv2_point point;
} mnv2_tap;

extern const char mnv2_default_taps[]; /* "conv1,block_1_expand,block_3_expand,..." */

/* The network's folded weights and shapes (read from the file, checked to chain). */
typedef struct mobilenetv2 {
    int cin[MNV2_BLOCKS], cexp[MNV2_BLOCKS], cout[MNV2_BLOCKS], stride[MNV2_BLOCKS];
    float *conv1_w, *conv1_b;                          /* (32,3,3,3), (32) */
    float *expand_w[MNV2_BLOCKS], *expand_b[MNV2_BLOCKS]; /* (cexp,cin); NULL in block 0 */
    float *dw_w[MNV2_BLOCKS], *dw_b[MNV2_BLOCKS];         /* (cexp,3,3), (cexp) */
    float *project_w[MNV2_BLOCKS], *project_b[MNV2_BLOCKS]; /* (cout,cexp), (cout) */
} mobilenetv2;

/* Tensors Conv1.{weight,bias}, expanded_conv_{depthwise,project}.{weight,bias},
 * block_N_{expand,depthwise,project}.{weight,bias} for N = 1..10, F32/F16/BF16, shapes
 * as above with the strides of Keras' MobileNetV2; every value finite. Returns 0, or -1
 * with a message naming the file and the tensor. */
int mnv2_load(mobilenetv2 *net, const char *path, char *err, size_t errlen);
void mnv2_free(mobilenetv2 *net);

/* Parse a comma-separated tap list into taps[MNV2_MAX_TAPS]; a name twice is an error.
 * Returns the count, or -1 with a message. */
int mnv2_taps_parse(const char *list, mnv2_tap *taps, char *err, size_t errlen);
/* "conv1", "block_3_expand", ... into buf. */
void mnv2_tap_name(mnv2_tap tap, char *buf, size_t len);
int mnv2_tap_channels(const mobilenetv2 *net, mnv2_tap tap);

typedef struct mnv2_options {
    int ntaps;
    mnv2_tap taps[MNV2_MAX_TAPS];
    int scales;       /* 1: the 224 crop; 2: also the crop box-averaged to 112 */
    int signed_input; /* feed 2x - 1 instead of x (see above) */
    int threads;      /* workers, each one image at a time; 0 = 1. Pin OpenBLAS to one
                       * thread whatever this is (see above). */
} mnv2_options;

/* Where each (scale, tap) Gram starts in a row, offsets[scales * ntaps] = row length. */
size_t mnv2_descriptor_offsets(const mobilenetv2 *net, const mnv2_options *opt,
                               size_t offsets[2 * MNV2_MAX_TAPS + 1]);

/* Linear RGB(A)/grey pixels (width, height >= 224): clamp to [0,1], sRGB-encode, centre
 * crop 224 (as vgg_preprocess), CHW (3,224,224) in [0,1]. */
int mnv2_preprocess(float *out, const float *pixels, int width, int height, int channels);

/* Buffers for one worker per thread and up to max_batch images of side `size` (a
 * multiple of 16; 224 for the descriptor). Keeps a pointer to net. NULL when out of
 * memory or size is not a multiple of 16. */
typedef struct mnv2_workspace mnv2_workspace;
mnv2_workspace *mnv2_workspace_create(const mobilenetv2 *net, const mnv2_options *opt,
                                      int size, int max_batch);
void mnv2_workspace_free(mnv2_workspace *ws);

/* Descriptors of n <= max_batch preprocessed images in (n,3,size,size) ([0,1]; the
 * signed mapping is applied here): out is n rows of mnv2_descriptor_offsets() floats. */
void mnv2_describe(mnv2_workspace *ws, const float *in, int n, float *out);

#ifdef __cplusplus
}
#endif
#endif
