/*
 * MobileNetV2 (Conv1 .. block_10) and its Gram descriptor against PyTorch: the committed
 * converted weights (assets/mobilenetv2/) through tests/reference/nn/mobilenetv2/
 * make_fixture.py's float64 torch forward. Ours must match within 1e-4 of each tap's
 * largest Gram magnitude, per tap, at both scales, for the default taps and for ten
 * more covering every tap kind, both strides, residual blocks, another input size (64)
 * and the signed input scaling. Also: the result does not depend on the thread count or
 * the batch, tap lists parse and reject what they should, and a broken weight file is an
 * error naming the file and the tensor.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "test_nn_util.h"

#define WEIGHTS IMSYNTH_SOURCE_DIR "/assets/mobilenetv2/mobilenetv2_block10.safetensors"
#define FIXTURES IMSYNTH_SOURCE_DIR "/tests/reference/nn/mobilenetv2/"
#define TOLERANCE 1e-4

static const char *const taps64 =
    "conv1,expanded_conv_depthwise,expanded_conv_project,block_1_depthwise,block_2_project,"
    "block_4_expand,block_5_project,block_6_depthwise,block_9_project,block_10_project";

static mobilenetv2 load_net(void)
{
    mobilenetv2 net;
    char err[512];
    if (mnv2_load(&net, WEIGHTS, err, sizeof err))
        fail_msg("%s", err);
    return net;
}

/* The two images of tests/reference/nn/images_u8.npy as linear light (image 1 stretched
 * past [0,1]), preprocessed: (2,3,224,224). */
static float *fixture_inputs(void)
{
    int ndim = 0, u8 = 0;
    long shape[4];
    unsigned char *img = npy_read(IMSYNTH_SOURCE_DIR "/tests/reference/nn/images_u8.npy",
                                  &ndim, shape, &u8);
    assert_non_null(img);
    assert_true(u8 && ndim == 4 && shape[0] == 2 && shape[3] == 3);
    size_t npix = (size_t)shape[1] * shape[2] * 3;
    float *lin = malloc(npix * sizeof(float)), *input = malloc(2 * 3 * 224 * 224 * 4);
    assert_non_null(lin);
    assert_non_null(input);
    for (int k = 0; k < 2; k++) {
        for (size_t i = 0; i < npix; i++) {
            float v = (float)img[k * npix + i] / 255.0f;
            lin[i] = k == 0 ? v : v * 1.5f - 0.25f;
        }
        assert_int_equal(mnv2_preprocess(input + (size_t)k * 3 * 224 * 224, lin, (int)shape[2],
                                         (int)shape[1], 3), 0);
    }
    free(lin);
    free(img);
    return input;
}

/* Worst over the row's segments of max |got - want| / max |want|. */
static double worst_tap_error(const float *got, const float *want, const size_t *off, int nseg,
                              int *worst_seg)
{
    double worst = 0.0;
    for (int s = 0; s < nseg; s++) {
        double maxref = 0.0, maxdiff = 0.0;
        for (size_t i = off[s]; i < off[s + 1]; i++) {
            maxref = fmax(maxref, fabs((double)want[i]));
            maxdiff = fmax(maxdiff, fabs((double)got[i] - (double)want[i]));
        }
        double e = maxdiff / (maxref > 0.0 ? maxref : 1.0);
        if (e > worst) {
            worst = e;
            *worst_seg = s;
        }
    }
    return worst;
}

static mnv2_options options(const char *taps, int scales, int signed_input, int threads)
{
    mnv2_options opt = {.scales = scales, .signed_input = signed_input, .threads = threads};
    char err[256];
    opt.ntaps = mnv2_taps_parse(taps, opt.taps, err, sizeof err);
    if (opt.ntaps < 0)
        fail_msg("%s", err);
    return opt;
}

static void test_default_taps_against_torch(void **state)
{
    (void)state;
    mobilenetv2 net = load_net();
    mnv2_options opt = options(mnv2_default_taps, 2, 0, 2);
    size_t off[2 * MNV2_MAX_TAPS + 1];
    size_t row = mnv2_descriptor_offsets(&net, &opt, off);
    assert_int_equal(row, 2 * MNV2_DEFAULT_DESCRIPTOR_SIZE);
    assert_int_equal(off[5], MNV2_DEFAULT_DESCRIPTOR_SIZE);

    int ndim = 0, u8 = 0;
    long shape[4];
    float *want = npy_read(FIXTURES "expected_default.npy", &ndim, shape, &u8);
    assert_non_null(want);
    assert_true(ndim == 2 && shape[0] == 2 && (size_t)shape[1] == row);

    float *input = fixture_inputs();
    float *got = malloc(2 * row * sizeof(float));
    mnv2_workspace *ws = mnv2_workspace_create(&net, &opt, 224, 2);
    assert_non_null(ws);
    mnv2_describe(ws, input, 2, got);
    for (int k = 0; k < 2; k++) {
        int seg = -1;
        double e = worst_tap_error(got + k * row, want + k * row, off, 10, &seg);
        printf("default taps, image %d: worst per-tap relative error %.3g (segment %d)\n", k,
               e, seg);
        assert_true(e <= TOLERANCE);
    }
    mnv2_workspace_free(ws);
    free(got);
    free(input);
    free(want);
    mnv2_free(&net);
}

static void test_every_tap_kind_at_64_signed(void **state)
{
    (void)state;
    mobilenetv2 net = load_net();
    mnv2_options opt = options(taps64, 1, 1, 1);
    assert_int_equal(opt.ntaps, 10);
    size_t off[2 * MNV2_MAX_TAPS + 1];
    size_t row = mnv2_descriptor_offsets(&net, &opt, off);
    int ndim = 0, u8 = 0;
    long shape[4];
    float *want = npy_read(FIXTURES "expected_taps64.npy", &ndim, shape, &u8);
    assert_non_null(want);
    assert_true(ndim == 2 && shape[0] == 1 && (size_t)shape[1] == row);

    float *input = fixture_inputs();
    /* image 1's crop rows/cols 80..143 */
    float *x64 = malloc(3 * 64 * 64 * sizeof(float));
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < 64; y++)
            for (int x = 0; x < 64; x++)
                x64[(c * 64 + y) * 64 + x] =
                    input[3 * 224 * 224 + ((size_t)c * 224 + 80 + y) * 224 + 80 + x];
    float *got = malloc(row * sizeof(float));
    mnv2_workspace *ws = mnv2_workspace_create(&net, &opt, 64, 1);
    assert_non_null(ws);
    mnv2_describe(ws, x64, 1, got);
    int seg = -1;
    double e = worst_tap_error(got, want, off, opt.ntaps, &seg);
    char name[64];
    mnv2_tap_name(opt.taps[seg < 0 ? 0 : seg], name, sizeof name);
    printf("ten taps at 64x64, signed input: worst per-tap relative error %.3g (%s)\n", e, name);
    assert_true(e <= TOLERANCE);
    mnv2_workspace_free(ws);
    free(got);
    free(x64);
    free(input);
    free(want);
    mnv2_free(&net);
}

/* Threads and batch only change who computes an image, never its bits. */
static void test_bits_independent_of_threads_and_batch(void **state)
{
    (void)state;
    mobilenetv2 net = load_net();
    float *two = fixture_inputs();
    int n = getenv("IMSYNTH_TEST_QUICK") ? 3 : 5;
    size_t img = 3 * 224 * 224;
    float *in = malloc((size_t)n * img * sizeof(float));
    for (int k = 0; k < n; k++) /* distinct images: mixtures of the two */
        for (size_t i = 0; i < img; i++)
            in[k * img + i] = two[i] * (float)(k + 1) / (float)(n + 1) +
                              two[img + i] * (float)(n - k) / (float)(n + 1);
    mnv2_options one = options(mnv2_default_taps, 2, 0, 1), many = one;
    many.threads = 3;
    size_t off[2 * MNV2_MAX_TAPS + 1];
    size_t row = mnv2_descriptor_offsets(&net, &one, off);
    float *a = malloc((size_t)n * row * sizeof(float)), *b = malloc((size_t)n * row * sizeof(float));
    mnv2_workspace *ws1 = mnv2_workspace_create(&net, &one, 224, 1);
    mnv2_workspace *wsn = mnv2_workspace_create(&net, &many, 224, n);
    assert_non_null(ws1);
    assert_non_null(wsn);
    for (int k = 0; k < n; k++)
        mnv2_describe(ws1, in + k * img, 1, a + k * row);
    mnv2_describe(wsn, in, n, b);
    assert_memory_equal(a, b, (size_t)n * row * sizeof(float));
    /* and the images do differ, so the comparison means something */
    assert_true(memcmp(a, a + row, row * sizeof(float)) != 0);
    mnv2_workspace_free(ws1);
    mnv2_workspace_free(wsn);
    free(a);
    free(b);
    free(in);
    free(two);
    mnv2_free(&net);
}

static void test_tap_lists(void **state)
{
    (void)state;
    mnv2_tap taps[MNV2_MAX_TAPS];
    char err[256], name[64];
    assert_int_equal(mnv2_taps_parse(mnv2_default_taps, taps, err, sizeof err), 5);
    assert_int_equal(taps[0].point, MNV2_CONV1);
    assert_int_equal(taps[1].block, 1);
    assert_int_equal(taps[1].point, MNV2_EXPAND);
    assert_int_equal(taps[4].block, 10);
    assert_int_equal(taps[4].point, MNV2_PROJECT);
    /* every tap, in the names mnv2_tap_name gives, parses back to itself */
    char all[2048] = "conv1";
    for (int b = 0; b < MNV2_BLOCKS; b++)
        for (int p = MNV2_EXPAND; p <= MNV2_PROJECT; p++) {
            if (b == 0 && p == MNV2_EXPAND)
                continue;
            mnv2_tap_name((mnv2_tap){b, (mnv2_point)p}, name, sizeof name);
            strcat(all, ",");
            strcat(all, name);
        }
    int n = mnv2_taps_parse(all, taps, err, sizeof err);
    assert_int_equal(n, MNV2_MAX_TAPS);
    for (int i = 0; i < n; i++) {
        mnv2_tap_name(taps[i], name, sizeof name);
        assert_non_null(strstr(all, name));
    }
    assert_int_equal(mnv2_taps_parse("expanded_conv_project", taps, err, sizeof err), 1);
    assert_int_equal(taps[0].block, 0);
    static const char *const bad[] = {"",          "conv1,",           "block_0_expand",
                                      "block_11_project", "block_3_relu", "block_x_expand",
                                      "block_3_expand,block_3_expand", "conv1,conv1",
                                      "block_-1_project"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        err[0] = 0;
        assert_int_equal(mnv2_taps_parse(bad[i], taps, err, sizeof err), -1);
        assert_true(err[0] != 0);
    }
}

/* Copy the weight file with `patch` applied at byte offset `at` (or truncated to `at`
 * when patch is NULL). */
static void write_variant(const char *path, size_t at, const void *patch, size_t len)
{
    FILE *f = fopen(WEIGHTS, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    size_t n = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *buf = malloc(n);
    assert_int_equal(fread(buf, 1, n, f), n);
    fclose(f);
    if (patch)
        memcpy(buf + at, patch, len);
    else
        n = at;
    f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(buf, 1, n, f), n);
    fclose(f);
    free(buf);
}

static size_t find_in_file(const char *needle)
{
    FILE *f = fopen(WEIGHTS, "rb");
    assert_non_null(f);
    unsigned char head[8];
    assert_int_equal(fread(head, 1, 8, f), 8);
    size_t hlen = 0;
    for (int i = 7; i >= 0; i--)
        hlen = hlen << 8 | head[i];
    char *h = calloc(1, hlen + 1);
    assert_int_equal(fread(h, 1, hlen, f), hlen);
    fclose(f);
    char *p = strstr(h, needle);
    assert_non_null(p);
    size_t at = 8 + (size_t)(p - h);
    free(h);
    return at;
}

static void test_broken_weight_files(void **state)
{
    (void)state;
    mobilenetv2 net;
    char err[512];
    const char *path = IMSYNTH_BINARY_DIR "/mnv2_broken.safetensors";

    assert_int_equal(mnv2_load(&net, IMSYNTH_BINARY_DIR "/no-such.safetensors", err, sizeof err), -1);
    assert_non_null(strstr(err, "no-such.safetensors"));

    write_variant(path, 100000, NULL, 0); /* truncated inside the data */
    assert_int_equal(mnv2_load(&net, path, err, sizeof err), -1);
    assert_non_null(strstr(err, "mnv2_broken.safetensors"));

    /* a tensor renamed (same length, so the header stays valid) */
    size_t at = find_in_file("\"block_10_project.weight\"");
    write_variant(path, at, "\"block_10_projecX.weight\"", 25);
    assert_int_equal(mnv2_load(&net, path, err, sizeof err), -1);
    assert_non_null(strstr(err, "block_10_project.weight"));

    /* a NaN in Conv1's weight: its data offset from the header */
    at = find_in_file("\"Conv1.weight\"");
    FILE *f = fopen(WEIGHTS, "rb");
    unsigned char head[8];
    assert_int_equal(fread(head, 1, 8, f), 8);
    size_t hlen = 0;
    for (int i = 7; i >= 0; i--)
        hlen = hlen << 8 | head[i];
    char *h = calloc(1, hlen + 1);
    assert_int_equal(fread(h, 1, hlen, f), hlen);
    fclose(f);
    const char *offs = strstr(h + (at - 8), "\"data_offsets\":[");
    assert_non_null(offs);
    size_t begin = strtoul(offs + 16, NULL, 10);
    free(h);
    const float nan = NAN;
    write_variant(path, 8 + hlen + begin + 5 * sizeof(float), &nan, sizeof nan);
    assert_int_equal(mnv2_load(&net, path, err, sizeof err), -1);
    assert_non_null(strstr(err, "Conv1.weight"));
    assert_non_null(strstr(err, "non-finite"));
    remove(path);

    /* and the workspace refuses a side that is not a multiple of 16 */
    net = load_net();
    mnv2_options opt = options(mnv2_default_taps, 1, 0, 1);
    assert_null(mnv2_workspace_create(&net, &opt, 200, 1));
    opt.scales = 2;
    assert_null(mnv2_workspace_create(&net, &opt, 48, 1));
    mnv2_free(&net);
}

/* Preprocessing: clamp (NaN to 0), the sRGB curve at known points, centre crop, grey
 * replicated, alpha dropped, too small refused. */
static void test_preprocess(void **state)
{
    (void)state;
    const int W = 230, H = 226; /* crop origin: x0 = 3, y0 = 1 */
    float *px = malloc((size_t)W * H * 4 * sizeof(float)), *out = malloc(3 * 224 * 224 * 4);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 4; c++)
                px[((size_t)y * W + x) * 4 + c] = c == 3 ? 0.5f : (float)(x + y + c) / 400.0f;
    px[((size_t)2 * W + 3) * 4 + 0] = NAN;   /* output row 1, column 0, channel 0 */
    px[((size_t)1 * W + 3) * 4 + 1] = 2.0f;  /* output row 0, column 0, channel 1 */
    px[((size_t)1 * W + 4) * 4 + 2] = -1.0f; /* output row 0, column 1, channel 2 */
    assert_int_equal(mnv2_preprocess(out, px, W, H, 4), 0);
    const size_t plane = 224 * 224;
    assert_true(out[224] == 0.0f);          /* NaN -> 0 */
    assert_true(fabs(out[plane] - 1.0) < 1e-6); /* 2 -> 1 -> sRGB 1 (to rounding) */
    assert_true(out[2 * plane + 1] == 0.0f); /* -1 -> 0 */
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < 50; k++) {
            int y = 10 + k * 4, x = 7 + k * 3;
            double v = (double)((x + 3) + (y + 1) + c) / 400.0;
            double want = v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1 / 2.4) - 0.055;
            assert_true(fabs(out[c * plane + (size_t)y * 224 + x] - want) < 1e-6);
        }
    /* grey: channel 0 replicated */
    assert_int_equal(mnv2_preprocess(out, px, W, H / 4, 1), -1); /* 57 rows: too small */
    float *grey = malloc(224 * 224 * sizeof(float));
    for (size_t i = 0; i < plane; i++)
        grey[i] = 0.25f;
    assert_int_equal(mnv2_preprocess(out, grey, 224, 224, 1), 0);
    for (int c = 0; c < 3; c++)
        assert_true(fabs(out[c * plane + 1000] - (1.055 * pow(0.25, 1 / 2.4) - 0.055)) < 1e-6);
    assert_int_equal(mnv2_preprocess(out, grey, 224, 224, 5), -1);
    free(grey);
    free(px);
    free(out);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_default_taps_against_torch),
        cmocka_unit_test(test_every_tap_kind_at_64_signed),
        cmocka_unit_test(test_bits_independent_of_threads_and_batch),
        cmocka_unit_test(test_tap_lists),
        cmocka_unit_test(test_broken_weight_files),
        cmocka_unit_test(test_preprocess),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
