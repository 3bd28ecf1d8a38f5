/* imsynth describe: VGG19 or MobileNetV2 Gram descriptors of images, one .npy row per
 * image. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/cli.h"
#include "imageio/imageio.h"
#include "nn/nn.h"

#include <cblas.h> /* after our headers: its <complex.h> defines I */

/* The default network when no --weights is given (see vgg19_init_random). */
enum { DEFAULT_SEED = 1 };
/* MobileNetV2's weights when no --weights is given: what scripts/get-mobilenetv2 writes. */
static const char default_mnv2_weights[] = "assets/mobilenetv2/mobilenetv2_block10.safetensors";

static const char *const help =
    "usage: imsynth describe IMAGE... -o OUT.npy [options]\n"
    "\n"
    "Computes the VGG19 Gram descriptor of each image (DESIGN.md, seed/facts-from-thesis-code.md;\n"
    "or MobileNetV2's with --features mobilenetv2, below)\n"
    "and writes them as a float32 .npy array, one row per image in argument order.\n"
    "Images are read as linear light (EXR as is; 8/16-bit files are sRGB-decoded unless\n"
    "their metadata says linear). An image that is not 256x256 is first resized so that\n"
    "its shorter side is 256 pixels, keeping its aspect (imageio's tent filter,\n"
    "area-correct when shrinking); then the centre 224x224 is cropped, clamped to [0,1]\n"
    "and ImageNet-normalised.\n"
    "Gram layers in a row: conv1_2, conv2_2, conv3_4, conv4_4, conv5_4 (upper triangles\n"
    "with diagonal); their offsets are printed on stdout.\n"
    "\n"
    "options:\n"
    "  -o, --output OUT.npy       output file (required)\n"
    "  --weights F.safetensors    torchvision VGG19 weights (features.N.weight/bias);\n"
    "                             default: He-normal random weights, seed 1\n"
    "  --seed N                   seed of the random weights (default 1)\n"
    "  --pool avg3|avg2|max2      pooling: avg3 = average 3x3 stride 3 (the thesis, default),\n"
    "                             avg2 = average 2x2, max2 = VGG's max 2x2\n"
    "  --post-relu                Gram after each tapped layer's ReLU (default: before)\n"
    "  --precision fp32|fast      fp32 (default) or the fast path (see BENCHMARKS.md)\n"
    "  --threads N                worker threads (default: online CPUs)\n"
    "  --batch N                  images per forward pass (default 8)\n"
    "\n"
    "  --features vgg19|mobilenetv2\n"
    "                             the network (default vgg19, everything above).\n"
    "                             mobilenetv2: ImageNet MobileNetV2 up to block_10 (nn/nn.h),\n"
    "                             weights from scripts/get-mobilenetv2; the image is resized\n"
    "                             and cropped as above, clamped to [0,1], sRGB-encoded; Grams\n"
    "                             of the --taps, at 224 (and 112 with --scales 2)\n"
    "mobilenetv2 options (--seed, --pool, --post-relu, --precision are VGG19's only):\n"
    "  --weights F.safetensors    default assets/mobilenetv2/mobilenetv2_block10.safetensors\n"
    "  --taps LIST                comma-separated: conv1, block_N_expand (N 1..10),\n"
    "                             block_N_depthwise, block_N_project (N 0..10); default\n"
    "                             conv1,block_1_expand,block_3_expand,block_6_expand,\n"
    "                             block_10_project (38,808 floats)\n"
    "  --scales 1|2               2: also the 224 crop box-averaged to 112 (default 1)\n"
    "  --input-range unit|signed  network input in [0,1] (default; what the weights' BatchNorm\n"
    "                             statistics fit) or 2x-1 (Keras' ImageNet scaling)\n";

static int parse_int(const char *sub, const char *opt, const char *s, long lo, long hi,
                     long *v)
{
    char *end;
    *v = strtol(s, &end, 10);
    if (!*s || *end || *v < lo || *v > hi) {
        cli_error(sub, "%s: expected an integer in [%ld, %ld], got \"%s\"", opt, lo, hi, s);
        return -1;
    }
    return 0;
}

typedef int (*preprocess_fn)(float *out, const float *pixels, int width, int height,
                             int channels);

/* Read one image and write its preprocessed (3,224,224) tensor to out. */
static int load_image(const char *sub, const char *path, preprocess_fn preprocess, float *out)
{
    char err[512];
    image img = {0}, resized = {0};
    if (image_read(path, &img, err, sizeof err)) {
        cli_error(sub, "%s", err);
        return -1;
    }
    const image *use = &img;
    if (img.width != 256 || img.height != 256) {
        int w, h;
        if (img.width <= img.height) {
            w = 256;
            h = (int)((double)img.height * 256.0 / img.width + 0.5);
        } else {
            h = 256;
            w = (int)((double)img.width * 256.0 / img.height + 0.5);
        }
        if (image_resize(&img, w < 256 ? 256 : w, h < 256 ? 256 : h, &resized)) {
            cli_error(sub, "%s: out of memory resizing %dx%d", path, img.width, img.height);
            image_free(&img);
            return -1;
        }
        use = &resized;
    }
    int rc = preprocess(out, use->pixels, use->width, use->height, use->channels);
    if (rc)
        cli_error(sub, "%s: unsupported image (%dx%d, %d channels)", path, use->width,
                  use->height, use->channels);
    image_free(&img);
    image_free(&resized);
    return rc;
}

/* One network behind one interface: which, its weights, its workspace. */
typedef struct features {
    int mobilenet; /* 0: VGG19, 1: MobileNetV2 */
    vgg19 vgg;
    vgg_workspace *vgg_ws;
    mobilenetv2 mnv2;
    mnv2_options mnv2_opt;
    mnv2_workspace *mnv2_ws;
    size_t row;
} features;

static void print_columns(const features *f, const char *out_path, int n_inputs)
{
    printf("%s: %d x %zu float32\n", out_path, n_inputs, f->row);
    if (!f->mobilenet) {
        size_t off[VGG_GRAM_LAYERS + 1];
        vgg19_descriptor_offsets(&f->vgg, off);
        static const char *const names[VGG_GRAM_LAYERS] = {"conv1_2", "conv2_2", "conv3_4",
                                                           "conv4_4", "conv5_4"};
        for (int l = 0; l < VGG_GRAM_LAYERS; l++)
            printf("  %s  columns %zu..%zu\n", names[l], off[l], off[l + 1] - 1);
        return;
    }
    size_t off[2 * MNV2_MAX_TAPS + 1];
    mnv2_descriptor_offsets(&f->mnv2, &f->mnv2_opt, off);
    for (int s = 0, k = 0; s < f->mnv2_opt.scales; s++)
        for (int t = 0; t < f->mnv2_opt.ntaps; t++, k++) {
            char name[64];
            mnv2_tap_name(f->mnv2_opt.taps[t], name, sizeof name);
            printf("  %s@%d  columns %zu..%zu\n", name, s ? MNV2_INPUT_SIZE / 2 : MNV2_INPUT_SIZE,
                   off[k], off[k + 1] - 1);
        }
}

int cmd_describe(int argc, char **argv)
{
    const char *sub = "describe";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    const char *out_path = NULL, *weights = NULL, *taps = NULL, *vgg_only = NULL,
               *mnv2_only = NULL;
    long seed = DEFAULT_SEED, threads = sysconf(_SC_NPROCESSORS_ONLN), batch = 8, scales = 1;
    vgg_options opt = {.pool = VGG_POOL_AVG3, .precision = VGG_PRECISION_FP32};
    features f = {0};
    f.mnv2_opt.scales = 1;
    const char **inputs = calloc((size_t)argc, sizeof *inputs);
    int n_inputs = 0, rc = EXIT_USAGE;
    if (!inputs) {
        cli_error(sub, "out of memory");
        return EXIT_FAILURE_WORK;
    }
    int only_files = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (only_files || a[0] != '-' || !a[1]) {
            inputs[n_inputs++] = a;
            continue;
        }
        if (!strcmp(a, "--")) {
            only_files = 1;
            continue;
        }
        int takes = !strcmp(a, "-o") || !strcmp(a, "--output") || !strcmp(a, "--weights") ||
                    !strcmp(a, "--seed") || !strcmp(a, "--pool") || !strcmp(a, "--precision") ||
                    !strcmp(a, "--threads") || !strcmp(a, "--batch") ||
                    !strcmp(a, "--features") || !strcmp(a, "--taps") ||
                    !strcmp(a, "--scales") || !strcmp(a, "--input-range");
        if (takes && i + 1 >= argc) {
            cli_error(sub, "%s needs a value", a);
            goto done;
        }
        if (!strcmp(a, "--seed") || !strcmp(a, "--pool") || !strcmp(a, "--precision") ||
            !strcmp(a, "--post-relu"))
            vgg_only = a;
        if (!strcmp(a, "--taps") || !strcmp(a, "--scales") || !strcmp(a, "--input-range"))
            mnv2_only = a;
        if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            out_path = argv[++i];
        else if (!strcmp(a, "--weights"))
            weights = argv[++i];
        else if (!strcmp(a, "--seed")) {
            if (parse_int(sub, a, argv[++i], 0, INT32_MAX, &seed))
                goto done;
        } else if (!strcmp(a, "--pool")) {
            int p = vgg_pool_parse(argv[++i]);
            if (p < 0) {
                cli_error(sub, "--pool: expected avg3, avg2 or max2, got \"%s\"", argv[i]);
                goto done;
            }
            opt.pool = (vgg_pool)p;
        } else if (!strcmp(a, "--precision")) {
            int p = vgg_precision_parse(argv[++i]);
            if (p < 0) {
                cli_error(sub, "--precision: expected fp32 or fast, got \"%s\"", argv[i]);
                goto done;
            }
            opt.precision = (vgg_precision)p;
        } else if (!strcmp(a, "--threads")) {
            if (parse_int(sub, a, argv[++i], 1, 256, &threads))
                goto done;
        } else if (!strcmp(a, "--batch")) {
            if (parse_int(sub, a, argv[++i], 1, 256, &batch))
                goto done;
        } else if (!strcmp(a, "--post-relu"))
            opt.post_relu = 1;
        else if (!strcmp(a, "--features")) {
            const char *v = argv[++i];
            if (!strcmp(v, "vgg19"))
                f.mobilenet = 0;
            else if (!strcmp(v, "mobilenetv2"))
                f.mobilenet = 1;
            else {
                cli_error(sub, "--features: expected vgg19 or mobilenetv2, got \"%s\"", v);
                goto done;
            }
        } else if (!strcmp(a, "--taps"))
            taps = argv[++i];
        else if (!strcmp(a, "--scales")) {
            if (parse_int(sub, a, argv[++i], 1, 2, &scales))
                goto done;
        } else if (!strcmp(a, "--input-range")) {
            const char *v = argv[++i];
            if (strcmp(v, "unit") && strcmp(v, "signed")) {
                cli_error(sub, "--input-range: expected unit or signed, got \"%s\"", v);
                goto done;
            }
            f.mnv2_opt.signed_input = !strcmp(v, "signed");
        } else {
            cli_error(sub, "unknown option \"%s\"", a);
            goto done;
        }
    }
    if (!n_inputs || !out_path) {
        cli_error(sub, "need at least one IMAGE and -o OUT.npy (see --help)");
        goto done;
    }
    if (f.mobilenet && vgg_only) {
        cli_error(sub, "%s is a VGG19 option (not with --features mobilenetv2)", vgg_only);
        goto done;
    }
    if (!f.mobilenet && mnv2_only) {
        cli_error(sub, "%s needs --features mobilenetv2", mnv2_only);
        goto done;
    }
    char err[1024];
    if (f.mobilenet) {
        f.mnv2_opt.ntaps = mnv2_taps_parse(taps ? taps : mnv2_default_taps, f.mnv2_opt.taps,
                                           err, sizeof err);
        if (f.mnv2_opt.ntaps < 0) {
            cli_error(sub, "--taps: %s", err);
            goto done;
        }
        f.mnv2_opt.scales = (int)scales;
    }
    opt.threads = threads < 1 ? 1 : (int)threads;
    f.mnv2_opt.threads = opt.threads;
    /* Our workers each run single-threaded sgemms; OpenBLAS's own threads would only
     * fight them for the same cores. Pinned with one worker too: a threaded OpenBLAS
     * splits its sums differently on some CPUs (VGG19's Grams from conv3 on differed
     * between --threads 1 and 2 on an AVX-512 machine), and the bits must not depend on
     * --threads. datagen, evaluate and predict pin it the same way. */
    openblas_set_num_threads(1);

    rc = EXIT_FAILURE_WORK;
    if (f.mobilenet) {
        char wbuf[1024];
        int default_weights = !weights;
        if (!(weights = cli_data_path(sub, weights, default_mnv2_weights, wbuf, sizeof wbuf)))
            goto done;
        if (mnv2_load(&f.mnv2, weights, err, sizeof err)) {
            cli_error(sub, "%s%s", err,
                      default_weights ? " (run scripts/get-mobilenetv2, or give --weights)" : "");
            goto done;
        }
    } else if (weights) {
        if (vgg19_load(&f.vgg, weights, err, sizeof err)) {
            cli_error(sub, "%s", err);
            goto done;
        }
    } else if (vgg19_init_random(&f.vgg, vgg19_standard_width, (uint64_t)seed)) {
        cli_error(sub, "out of memory");
        goto done;
    }
    if (batch > n_inputs)
        batch = n_inputs;
    if (f.mobilenet) {
        size_t off[2 * MNV2_MAX_TAPS + 1];
        f.row = mnv2_descriptor_offsets(&f.mnv2, &f.mnv2_opt, off);
        f.mnv2_ws = mnv2_workspace_create(&f.mnv2, &f.mnv2_opt, MNV2_INPUT_SIZE, (int)batch);
    } else {
        f.row = vgg19_descriptor_size(&f.vgg);
        f.vgg_ws = vgg_workspace_create(&f.vgg, &opt, (int)batch);
    }
    preprocess_fn preprocess = f.mobilenet ? mnv2_preprocess : vgg_preprocess;
    size_t image_floats = 3 * (size_t)VGG_INPUT_SIZE * VGG_INPUT_SIZE;
    _Static_assert((int)VGG_INPUT_SIZE == (int)MNV2_INPUT_SIZE, "one input buffer serves both");
    float *in = malloc((size_t)batch * image_floats * sizeof(float));
    float *desc = malloc((size_t)batch * f.row * sizeof(float));
    nn_npy_writer *w = NULL;
    if ((f.mobilenet ? !f.mnv2_ws : !f.vgg_ws) || !in || !desc) {
        cli_error(sub, "out of memory");
        goto cleanup;
    }
    w = nn_npy_begin(out_path, (size_t)n_inputs, f.row, err, sizeof err);
    if (!w) {
        cli_error(sub, "%s", err);
        goto cleanup;
    }
    for (int first = 0; first < n_inputs; first += (int)batch) {
        int n = n_inputs - first < batch ? n_inputs - first : (int)batch;
        for (int k = 0; k < n; k++)
            if (load_image(sub, inputs[first + k], preprocess, in + (size_t)k * image_floats))
                goto cleanup;
        if (f.mobilenet)
            mnv2_describe(f.mnv2_ws, in, n, desc);
        else
            vgg_describe(f.vgg_ws, in, n, desc);
        if (nn_npy_append(w, desc, (size_t)n, err, sizeof err)) {
            cli_error(sub, "%s", err);
            goto cleanup;
        }
    }
    if (nn_npy_commit(w, err, sizeof err)) {
        w = NULL;
        cli_error(sub, "%s", err);
        goto cleanup;
    }
    w = NULL;
    print_columns(&f, out_path, n_inputs);
    rc = EXIT_OK;
cleanup:
    nn_npy_abort(w);
    vgg_workspace_free(f.vgg_ws);
    mnv2_workspace_free(f.mnv2_ws);
    free(in);
    free(desc);
    vgg19_free(&f.vgg);
    mnv2_free(&f.mnv2);
done:
    free(inputs);
    return rc;
}
