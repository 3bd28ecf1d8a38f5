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

/* ================================================================ training ========= */
/*
 * Training in C (issue 13), in llm.c's style: every layer is an explicit *_forward and
 * *_backward over plain float arrays, row-major, B rows (samples) of C features. A
 * backward pass ADDS into parameter gradients (the caller zeroes them once per step) and
 * OVERWRITES the gradient of its input. The MLP (nn_mlp) strings them together with
 * PyTorch-compatible key names and the losses of its heads; nn_optimizer updates it;
 * checkpoints are safetensors with the optimiser state beside the weights.
 *
 * From C, a training run is (error handling left out):
 *     nn_mlp_config cfg;  nn_head heads[NN_MAX_HEADS];  nn_mlp m;  nn_optimizer opt;
 *     nn_mlp_parse_arch("mlp:2000-512-512-59,gelu,ln", &cfg, err, sizeof err);
 *     int nh = nn_heads_parse("sigmoid:0-40,softmax:41/9,softmax:42/9", y_cols, 59,
 *                             NN_LOSS_THESIS, heads, NN_MAX_HEADS, err, sizeof err);
 *     nn_mlp_create(&m, &cfg, heads, nh, seed, err, sizeof err);
 *     m.y_cols = y_cols;  m.threads = 2;
 *     nn_optimizer_config oc = nn_optimizer_defaults(NN_OPT_ADAMW);
 *     nn_optimizer_init(&opt, &oc, m.n_floats);
 *     for each batch: nn_mlp_train_step(&m, &opt, x, y, mask, B, &loss);
 *     nn_mlp_save(&m, &opt, "model.safetensors", err, sizeof err);
 * and later nn_mlp_load(&m, NULL, path, ...) then nn_mlp_predict(&m, x, B, y).
 *
 * Threads: linear layers split their sgemms into blocks fixed by the shapes alone (never
 * along a sum), and the threads take whole blocks, so every result is bit-identical
 * whatever the thread count. OpenBLAS must run single-threaded (openblas_set_num_threads(1)
 * or OPENBLAS_NUM_THREADS=1): its own split could change the order of a sum.
 */

/* ---------------------------------------------------------------- layers ----------- */

/* out (B,OC) = in (B,C) . w^T + b; w (OC,C) as torch stores it, b (OC) or NULL. */
void linear_forward(float *out, const float *in, const float *w, const float *b, int B, int C,
                    int OC, int threads);
/* dw (OC,C) += dout^T . in, db (OC) += column sums of dout (if db), din (B,C) = dout . w
 * (skipped when din is NULL: the first layer's input needs no gradient). */
void linear_backward(float *din, float *dw, float *db, const float *dout, const float *in,
                     const float *w, int B, int C, int OC, int threads);

/* A message when OpenBLAS runs far below this CPU's speed (its detection fell back to
 * generic kernels), else NULL; for commands to print once. */
const char *nn_blas_warning(void);

/* Elementwise activations over n floats, out of place (out may equal in for forward).
 * Backward: din = dout * f'(in), from the forward's input (relu, leaky_relu, gelu) or its
 * output (sigmoid). GELU is the exact erf form (torch's default). */
void relu_backward(float *din, const float *dout, const float *in, size_t n);
void leaky_relu_forward(float *out, const float *in, size_t n, float slope);
void leaky_relu_backward(float *din, const float *dout, const float *in, size_t n, float slope);
void gelu_forward(float *out, const float *in, size_t n);
void gelu_backward(float *din, const float *dout, const float *in, size_t n);
void sigmoid_forward(float *out, const float *in, size_t n);
void sigmoid_backward(float *din, const float *dout, const float *out, size_t n);
/* Softmax over each row of K of B rows: out (B,K) from logits in (B,K); stable (max
 * subtracted). */
void softmax_forward(float *out, const float *in, int B, int K);

/* Inverted dropout: keep[i] = 0 or 1/(1-p), drawn from (seed, i) alone (counter-based, so
 * independent of threads and order); out = in * keep. backward: din = dout * keep. */
void dropout_forward(float *out, float *keep, const float *in, size_t n, float p, uint64_t seed);
void dropout_backward(float *din, const float *dout, const float *keep, size_t n);

/* LayerNorm over the last dimension (torch.nn.LayerNorm(C), eps 1e-5, biased variance):
 * out (B,C) = (in - mean) * rstd * w + b; mean, rstd (B) are saved for backward.
 * backward: dw, db (C) += ..., din (B,C) = ... */
void layernorm_forward(float *out, float *mean, float *rstd, const float *in, const float *w,
                       const float *b, int B, int C);
void layernorm_backward(float *din, float *dw, float *db, const float *dout, const float *in,
                        const float *w, const float *mean, const float *rstd, int B, int C);

/* ---------------------------------------------------------------- losses ----------- */

/* Regression losses over predictions p (B,C) against targets y (B,C), with an optional
 * mask (B,C) (an element with mask 0 contributes neither loss nor gradient; NULL = all 1)
 * and optional per-column weights wcol (C) (NULL = all 1):
 *     loss = sum_ij m_ij wcol_j e(p_ij, y_ij) / max(1, sum_ij m_ij)
 * so that with no mask and no weights it is the mean, as torch's reductions. e is
 *     NN_LOSS_MSE     (p - y)^2
 *     NN_LOSS_L1      |p - y|                   (gradient sign(p - y), 0 at 0 as torch)
 *     NN_LOSS_THESIS  (p - y)^2 + 20 (log(p + 1e-7) - log(y + 1e-7))^2
 *                     (the thesis's MSE(p, y) + 20 * MSE(log(p + 1e-7), log(y + 1e-7)))
 * Returns the loss; dp (B,C) += scale * dloss/dp (dp may be NULL: loss only). */
typedef enum nn_loss { NN_LOSS_MSE, NN_LOSS_L1, NN_LOSS_THESIS } nn_loss;
int nn_loss_parse(const char *s); /* "mse", "l1", "thesis"; -1 when unknown */
double regression_loss_forward_backward(nn_loss kind, float *dp, const float *p, const float *y,
                                        const float *mask, const float *wcol, int B, int C,
                                        double scale);
/* Cross-entropy of softmax(logits) (B,K) against class indices cls (B) (as floats holding
 * integers in [0, K)), optional per-row mask (B): loss = sum_i m_i CE_i / max(1, sum m_i).
 * dlogits (B,K) += scale * dloss/dlogits; probs (B,K) is scratch (the softmax). */
double cross_entropy_forward_backward(float *dlogits, float *probs, const float *logits,
                                      const float *cls, const float *mask, int B, int K,
                                      double scale);

/* ---------------------------------------------------------------- optimisers ------- */

typedef enum nn_optimizer_kind { NN_OPT_SGD, NN_OPT_ADAM, NN_OPT_ADAMW } nn_optimizer_kind;
typedef enum nn_schedule_kind {
    NN_SCHEDULE_CONSTANT,
    NN_SCHEDULE_STEP,   /* lr * gamma^floor(t / step_size) */
    NN_SCHEDULE_COSINE, /* linear warm-up lr (t+1)/warmup, then lr (1 + cos(pi s))/2 with
                           s = (t - warmup) / (total - warmup) clamped to [0, 1] */
} nn_schedule_kind;

/* The update rules are torch 1.13's (torch.optim documentation):
 *   SGD:   g += wd p; buf = g on the first step, else momentum buf + g; p -= lr buf
 *   Adam:  g += wd p; m = b1 m + (1-b1) g; v = b2 v + (1-b2) g^2;
 *          p -= lr/(1-b1^t) * m / (sqrt(v)/sqrt(1-b2^t) + eps)
 *   AdamW: p *= 1 - lr wd; then Adam's update without the g += wd p
 * Gradient clipping (clip_norm > 0) scales all gradients by min(1, clip/(|g|_2 + 1e-6))
 * first, as torch.nn.utils.clip_grad_norm_. */
typedef struct nn_optimizer_config {
    nn_optimizer_kind kind;
    float lr, weight_decay;
    float beta1, beta2, eps; /* Adam(W) */
    float momentum;          /* SGD */
    float clip_norm;         /* 0: no clipping */
    nn_schedule_kind schedule;
    long long warmup_steps, total_steps; /* cosine */
    long long step_size;                 /* step */
    float gamma;                         /* step */
} nn_optimizer_config;

/* torch's defaults for kind: lr 1e-3 (SGD 1e-2), wd 0 (AdamW 1e-2), betas (0.9, 0.999),
 * eps 1e-8, momentum 0 (SGD), constant schedule. */
nn_optimizer_config nn_optimizer_defaults(nn_optimizer_kind kind);
int nn_optimizer_parse(const char *s); /* "sgd", "adam", "adamw"; -1 when unknown */
/* The learning rate of step t (0-based). */
float nn_schedule_lr(const nn_optimizer_config *cfg, long long t);

typedef struct nn_optimizer {
    nn_optimizer_config cfg;
    size_t n;       /* parameters */
    float *m, *v;   /* Adam moments, or SGD's momentum buffer in m; NULL when unused */
    long long step; /* steps taken */
} nn_optimizer;

int nn_optimizer_init(nn_optimizer *opt, const nn_optimizer_config *cfg, size_t n);
void nn_optimizer_free(nn_optimizer *opt);
/* Global L2 norm of g (n), summed in double in index order. */
double nn_grad_norm(const float *g, size_t n);
/* One update of params (n) from grads (n) (clipped in place when clip_norm > 0);
 * step += 1. Returns the learning rate used. */
float nn_optimizer_step(nn_optimizer *opt, float *params, float *grads);

/* ---------------------------------------------------------------- MLP -------------- */

enum { NN_MLP_MAX_LAYERS = 16, NN_MAX_HEADS = 64 };

typedef enum nn_activation { NN_ACT_RELU, NN_ACT_GELU, NN_ACT_LEAKY_RELU } nn_activation;
typedef enum nn_init { NN_INIT_TORCH, NN_INIT_KAIMING, NN_INIT_XAVIER } nn_init;

/* "mlp:IN-H1-...-OUT[,option...]" (see nn_mlp_parse_arch for the options). The trunk is
 * n_linear linear layers; every one but the last is followed by [LayerNorm], the
 * activation and [dropout]. Without residual its modules are numbered as a torch
 * nn.Sequential (trunk.0 = first Linear, trunk.1 = LayerNorm or activation, ...; only
 * Linear and LayerNorm have parameters: trunk.<i>.weight, trunk.<i>.bias). With residual
 * each hidden layer is one module trunk.<i> = Block(linear, norm) whose output adds its
 * input when the widths agree: trunk.<i>.linear.weight, trunk.<i>.norm.weight, ..., and the
 * last Linear is trunk.<n_linear-1>. */
typedef struct nn_mlp_config {
    int n_linear;
    int width[NN_MLP_MAX_LAYERS + 1]; /* width[0] inputs .. width[n_linear] outputs */
    nn_activation act;
    float leaky_slope; /* default 0.01, torch's */
    int layernorm;
    float dropout; /* probability of zeroing, 0 = none */
    int residual;
    nn_init init;
} nn_mlp_config;

/* Parses an --arch spec. Options after commas: relu (default) | gelu | leaky[=slope],
 * ln, dropout=P, res, init=torch|kaiming|xavier. Returns 0 or -1 with a message. */
int nn_mlp_parse_arch(const char *spec, nn_mlp_config *cfg, char *err, size_t errlen);
/* The canonical spec of cfg (what checkpoints store), into buf. */
void nn_mlp_format_arch(const nn_mlp_config *cfg, char *buf, size_t len);

/* A head maps network outputs to Y columns and owns their loss.
 *   NN_HEAD_SIGMOID / NN_HEAD_LINEAR: Y columns y_first..y_first+count-1 are regression
 *     targets of outputs out_first..out_first+count-1, through a sigmoid (or none).
 *   NN_HEAD_SOFTMAX: Y column y_first holds a class index 0..classes-1 (or, with
 *     unit_selector, a selector value v in [0,1] meaning class round(v (classes-1)));
 *     outputs out_first..out_first+classes-1 are its logits; cross-entropy.
 * The mask column of a softmax head is its Y column's. weight scales the head's loss. */
typedef enum nn_head_kind { NN_HEAD_SIGMOID, NN_HEAD_LINEAR, NN_HEAD_SOFTMAX } nn_head_kind;
typedef struct nn_head {
    nn_head_kind kind;
    int y_first, count;  /* count = 1 for softmax */
    int classes;         /* softmax */
    int unit_selector;   /* softmax: Y holds k/(classes-1) instead of k */
    int out_first;       /* first network output */
    float weight;        /* loss weight, default 1 */
    nn_loss loss;        /* regression heads */
} nn_head;

/* "--heads" spec: comma-separated heads, each
 *     sigmoid:A-B[@W]  linear:A-B[@W]  (Y columns A..B inclusive, or a single column A)
 *     softmax:C/K[@W]  softmax:C/K:unit[@W]
 * W = loss weight. Outputs are given out in spec order. Every Y column may belong to at
 * most one head; columns of no head are ignored. NULL or "" means one linear head over
 * all y_cols columns. default_loss is the regression heads' loss. Checks that the heads'
 * outputs total out_width. Returns the number of heads or -1 with a message. */
int nn_heads_parse(const char *spec, int y_cols, int out_width, nn_loss default_loss,
                   nn_head *heads, int max_heads, char *err, size_t errlen);
void nn_heads_format(const nn_head *heads, int n, char *buf, size_t len);

/* A named parameter tensor inside the model's one parameter array. */
typedef struct nn_param {
    char name[64];
    int ndim;
    int64_t shape[2];
    size_t offset, size; /* floats */
} nn_param;

typedef struct nn_mlp {
    nn_mlp_config cfg;
    nn_head heads[NN_MAX_HEADS];
    int n_heads;
    int y_cols; /* Y columns the heads read (max column + 1) */
    int n_params;
    nn_param params[4 * NN_MLP_MAX_LAYERS];
    size_t n_floats;
    float *weights, *grads; /* n_floats each, one block: the optimiser sees one array */
    /* params[] index of linear layer l's weight (its bias follows) and of its LayerNorm's
     * weight (bias follows), or -1 */
    int linear_param[NN_MLP_MAX_LAYERS], norm_param[NN_MLP_MAX_LAYERS];
    int threads;            /* worker threads of the linear layers (>= 1) */
    uint64_t dropout_seed;
    /* Per-output loss weights, one per Y column (y_cols floats, caller-owned; NULL = all
     * 1): a regression element's term is multiplied by its column's weight (the mean's
     * denominator stays the count of unmasked elements), a softmax head's loss by its
     * column's. A training setting: checkpoints do not store it. */
    const float *column_weights;
    /* Activations for up to cap_batch rows, (re)allocated by the first bigger batch. */
    int cap_batch;
    float *acts;
    size_t acts_floats;
} nn_mlp;

/* A model with seeded initial weights (cfg.init: torch's nn.Linear default, uniform
 * +-1/sqrt(fan_in) for weights and biases; kaiming = normal std sqrt(2/fan_in), zero
 * bias; xavier = uniform +-sqrt(6/(fan_in+fan_out)), zero bias; LayerNorm 1 and 0).
 * The weights are a pure function of (seed, tensor, index). Returns 0 or -1. */
int nn_mlp_create(nn_mlp *m, const nn_mlp_config *cfg, const nn_head *heads, int n_heads,
                  uint64_t seed, char *err, size_t errlen);
void nn_mlp_free(nn_mlp *m);
const nn_param *nn_mlp_find_param(const nn_mlp *m, const char *name);

/* Network outputs after the heads' activations (sigmoid, softmax probabilities), (B,OUT),
 * in eval mode (no dropout). */
int nn_mlp_forward(nn_mlp *m, const float *x, int B, float *out);
/* An ensemble's outputs: the mean of n networks' nn_mlp_forward (same layers and heads),
 * summed in member order, so that every caller gets the same bits. n = 1 is
 * nn_mlp_forward. Returns 0 or -1 (out of memory). */
int nn_mlp_forward_mean(nn_mlp *nets, int n, const float *x, int B, float *out);
/* Y-shaped predictions (B, y_cols): regression values; for softmax heads the argmax class
 * (or k/(classes-1) with unit_selector); columns of no head are 0. */
int nn_mlp_predict(nn_mlp *m, const float *x, int B, float *y);
/* nn_mlp_predict's second half: outputs as nn_mlp_forward gives them (B,OUT) -> Y-shaped
 * predictions (B, y_cols). An ensemble decodes its members' averaged outputs with it. */
void nn_mlp_decode(const nn_mlp *m, const float *probs, int B, float *y);
/* Training forward (dropout drawn from dropout_seed and step) and backward over one
 * batch: grads are zeroed, then hold dloss/dweights. x (B,IN), y and mask (B,y_cols),
 * mask may be NULL. *loss = the weighted sum of head losses. Returns 0 or -1 (out of
 * memory). */
int nn_mlp_forward_backward(nn_mlp *m, const float *x, const float *y, const float *mask,
                            int B, long long step, double *loss);
/* The loss over a batch in eval mode (no dropout), without touching grads: for
 * validation sets. Returns 0 or -1 (out of memory). */
int nn_mlp_evaluate(nn_mlp *m, const float *x, const float *y, const float *mask, int B,
                    double *loss);
/* forward_backward then one optimiser step. */
int nn_mlp_train_step(nn_mlp *m, nn_optimizer *opt, const float *x, const float *y,
                      const float *mask, int B, double *loss);
/* Checks a data set for training: x (N,IN) finite; y finite where the mask is non-zero;
 * softmax targets valid classes; mask values 0 or 1. Message names the row and column. */
int nn_mlp_check_data(const nn_mlp *m, const float *x, const float *y, const float *mask,
                      size_t N, char *err, size_t errlen);

/* ---------------------------------------------------------------- batches ---------- */

/* splitmix64's finaliser (a bijection): counter-based random bits for initialisation,
 * dropout and shuffling, so every draw is a pure function of (seed, counter). */
uint64_t nn_mix64(uint64_t z);
/* order (n) = the rows of an epoch: 0..n-1, or with shuffle a permutation that is a pure
 * function of (seed, epoch). */
void nn_epoch_order(uint64_t seed, long long epoch, int shuffle, size_t n, size_t *order);
/* dst (n, cols) = rows[0..n-1] of src. */
void nn_gather_rows(float *dst, const float *src, size_t cols, const size_t *rows, size_t n);
/* Which batch global step `step` trains on: epoch, first position in the epoch's order,
 * and row count (batch, or fewer for an epoch's last batch). */
void nn_step_batch(long long step, size_t n_rows, int batch, long long *epoch, size_t *first,
                   int *count);

/* ---------------------------------------------------------------- PCA -------------- */

/* The k leading principal components of the rows of X (n, d), which the caller has
 * centred (each column mean 0), by randomized SVD: a Gaussian test matrix of k + 16
 * columns from seed, power_iters power iterations (2 is plenty for decaying spectra),
 * then the exact SVD of the projected problem. components (k, d): orthonormal rows,
 * largest variance first, each signed so its largest |entry| is positive; variance (k):
 * X's variance along each (eigenvalue / (n - 1)). Bit-identical for any thread count.
 * Returns 0, or -1 with a message (k > min(n, d), out of memory). */
int nn_pca_fit(const float *X, int n, int d, int k, int power_iters, uint64_t seed, int threads,
               float *components, float *variance, char *err, size_t errlen);
/* out (n, k) = X (n, d) . components^T, divided by sqrt(variance) per component when
 * whiten (a component of variance 0 gives 0). */
void nn_pca_transform(float *out, const float *X, const float *components,
                      const float *variance, int n, int d, int k, int whiten, int threads);

/* ---------------------------------------------------------------- texture stats ---- */

/* Texture statistics (texstats.c): colour percentiles, the colours of the dark and bright
 * ends, chroma, highlight level, band energies of a luma pyramid and horizontal / vertical
 * detail ratios: TEXSTATS_N floats (the layout is in texstats.c) of an sRGB-encoded RGB
 * image (h, w, 3) in [0, 1]. Deterministic. Returns 0, or -1 when a side is under 64
 * pixels or out of memory. */
#define TEXSTATS_N 38
int texstats_forward(float *out, const float *rgb, int w, int h);

/* ---------------------------------------------------------------- checkpoints ------ */

/* Tensor writer: n tensors (shapes up to 2-D) and string metadata pairs into a
 * safetensors file, through a temporary file renamed into place. A tensor is stored as F32
 * (dtype NN_F32, the zero value) or, halving its bytes, as F16 (NN_F16: each value rounded
 * to nearest even by nn_float_to_half; the caller rounds what it keeps in memory alike if
 * it must agree with a reader). */
typedef struct nn_tensor_out {
    const char *name;
    int ndim;
    int64_t shape[2];
    const float *data;
    nn_dtype dtype; /* NN_F32 or NN_F16 */
} nn_tensor_out;
int nn_safetensors_write(const char *path, const nn_tensor_out *tensors, int n,
                         const char *const *meta_kv, int n_meta, char *err, size_t errlen);
/* The string value of "__metadata__"."key" of an opened file into value (len bytes):
 * 0, or -1 when absent, not a string or too long. */
int nn_safetensors_metadata(const nn_safetensors *st, const char *key, char *value, size_t len);

/* Model checkpoint: the weights under their torch names; metadata "imsynth.arch",
 * "imsynth.heads", "imsynth.y_cols"; with opt also "optimizer.<config field>" and
 * "optimizer.step" metadata and tensors "optimizer.exp_avg.<name>" and
 * "optimizer.exp_avg_sq.<name>" (Adam) or "optimizer.momentum_buffer.<name>" (SGD). */
int nn_mlp_save(const nn_mlp *m, const nn_optimizer *opt, const char *path, char *err,
                size_t errlen);
/* The same file without optimiser state, its weights as dtype: NN_F32 (nn_mlp_save's
 * bytes with opt NULL) or NN_F16, half the bytes, each weight rounded to the nearest half
 * (|w| < 65504 and relative error <= 2^-11 for normal halves; a model to ship, not to
 * resume). nn_mlp_load reads either. */
int nn_mlp_save_weights(const nn_mlp *m, nn_dtype dtype, const char *path, char *err,
                        size_t errlen);
/* A model from a checkpoint's metadata and weights; with opt (may be NULL) the optimiser
 * state too (opt->n == 0 when the file has none). */
int nn_mlp_load(nn_mlp *m, nn_optimizer *opt, const char *path, char *err, size_t errlen);
/* Weights only, into an existing model whose every parameter must be in the file with
 * its shape (torch's strict load_state_dict); other tensors are ignored. */
int nn_mlp_load_weights(nn_mlp *m, const char *path, char *err, size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
