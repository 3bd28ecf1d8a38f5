/*
 * VGG19 Gram descriptors against PyTorch, through the committed fixture
 * (tests/reference/nn/make_fixture.py: a reduced VGG19 with F32/F16/BF16 weights, two
 * images, expected descriptors from torch for avg3, avg2 and max2 + post-ReLU).
 * Tolerance: 1e-4 of each Gram layer's largest magnitude, per layer.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "test_nn_util.h"

#define FIXTURE IMSYNTH_SOURCE_DIR "/tests/reference/nn/"

typedef struct fixture {
    vgg19 net;
    float *input; /* (2, 3, 224, 224) preprocessed */
} fixture;

static int setup(void **state)
{
    fixture *fx = calloc(1, sizeof *fx);
    char err[512];
    if (vgg19_load(&fx->net, FIXTURE "weights.safetensors", err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    int ndim, u8;
    long shape[4];
    unsigned char *img = npy_read(FIXTURE "images_u8.npy", &ndim, shape, &u8);
    if (!img || !u8 || ndim != 4 || shape[0] != 2 || shape[3] != 3)
        return -1;
    size_t npix = (size_t)shape[1] * shape[2] * 3;
    float *lin = malloc(npix * sizeof(float));
    fx->input = malloc(2 * 3 * 224 * 224 * sizeof(float));
    for (int k = 0; k < 2; k++) {
        /* As the fixture script: image 0 is u8/255, image 1 u8/255*1.5-0.25. */
        for (size_t i = 0; i < npix; i++) {
            float v = (float)img[k * npix + i] / 255.0f;
            lin[i] = k == 0 ? v : v * 1.5f - 0.25f;
        }
        if (vgg_preprocess(fx->input + (size_t)k * 3 * 224 * 224, lin, (int)shape[2],
                           (int)shape[1], 3))
            return -1;
    }
    free(lin);
    free(img);
    *state = fx;
    return 0;
}

static int teardown(void **state)
{
    fixture *fx = *state;
    vgg19_free(&fx->net);
    free(fx->input);
    free(fx);
    return 0;
}

static void check_config_precision(fixture *fx, const char *expected_file, vgg_pool pool,
                                   int post_relu, int threads, int batch, vgg_precision precision,
                                   double tol)
{
    int ndim, u8;
    long shape[4];
    char path[1024];
    snprintf(path, sizeof path, FIXTURE "%s", expected_file);
    float *want = npy_read(path, &ndim, shape, &u8);
    assert_non_null(want);
    size_t row = vgg19_descriptor_size(&fx->net);
    assert_int_equal(ndim, 2);
    assert_int_equal(shape[0], 2);
    assert_int_equal((size_t)shape[1], row);

    vgg_options opt = {.pool = pool, .post_relu = post_relu, .threads = threads,
                       .precision = precision};
    vgg_workspace *ws = vgg_workspace_create(&fx->net, &opt, batch);
    assert_non_null(ws);
    float *got = malloc(2 * row * sizeof(float));
    for (int i = 0; i < 2; i += batch)
        vgg_describe(ws, fx->input + (size_t)i * 3 * 224 * 224, batch, got + i * row);
    size_t off[6];
    vgg19_descriptor_offsets(&fx->net, off);
    for (int k = 0; k < 2; k++) {
        double e = worst_layer_error(got + k * row, want + k * row, off);
        printf("%s %s image %d threads %d batch %d: worst per-layer relative error %.3g\n",
               expected_file, precision == VGG_PRECISION_FP32 ? "fp32" : "fast", k, threads,
               batch, e);
        assert_true(e <= tol);
    }
    vgg_workspace_free(ws);
    free(got);
    free(want);
}

static void check_config(fixture *fx, const char *expected_file, vgg_pool pool, int post_relu,
                         int threads, int batch)
{
    check_config_precision(fx, expected_file, pool, post_relu, threads, batch,
                           VGG_PRECISION_FP32, 1e-4);
}

/* The fast path (bf16 products: AMX where the CPU and kernel allow, else AVX512_BF16, else
 * fp32): within 1% of each layer's largest magnitude, its documented promise (see
 * test_nn_torch.c for the full network's measured deviation). */
static void test_fast_path(void **state)
{
    check_config_precision(*state, "expected_avg3_pre.npy", VGG_POOL_AVG3, 0, 2, 2,
                           VGG_PRECISION_FAST, 1e-2);
    check_config_precision(*state, "expected_max2_post.npy", VGG_POOL_MAX2, 1, 1, 1,
                           VGG_PRECISION_FAST, 1e-2);
}

static void test_widths_from_file(void **state)
{
    fixture *fx = *state;
    const int want[5] = {8, 16, 32, 64, 64};
    for (int b = 0; b < 5; b++)
        assert_int_equal(fx->net.width[b], want[b]);
    assert_int_equal(vgg19_descriptor_size(&fx->net), 36 + 136 + 528 + 2080 + 2080);
}

static void test_avg3_pre_relu(void **state)
{
    check_config(*state, "expected_avg3_pre.npy", VGG_POOL_AVG3, 0, 1, 1);
}

static void test_avg3_batched_threaded(void **state)
{
    check_config(*state, "expected_avg3_pre.npy", VGG_POOL_AVG3, 0, 2, 2);
}

static void test_avg2_pre_relu(void **state)
{
    check_config(*state, "expected_avg2_pre.npy", VGG_POOL_AVG2, 0, 2, 2);
}

static void test_max2_post_relu(void **state)
{
    check_config(*state, "expected_max2_post.npy", VGG_POOL_MAX2, 1, 1, 2);
}

/* Thread count and batching must not change a single bit (DESIGN: determinism). */
static void test_thread_and_batch_invariance(void **state)
{
    fixture *fx = *state;
    size_t row = vgg19_descriptor_size(&fx->net);
    float *a = malloc(2 * row * sizeof(float)), *b = malloc(2 * row * sizeof(float));
    vgg_options o1 = {.pool = VGG_POOL_AVG3, .threads = 1}, o2 = {.pool = VGG_POOL_AVG3, .threads = 2};
    vgg_workspace *w1 = vgg_workspace_create(&fx->net, &o1, 1);
    vgg_workspace *w2 = vgg_workspace_create(&fx->net, &o2, 2);
    vgg_describe(w1, fx->input, 1, a);
    vgg_describe(w1, fx->input + 3 * 224 * 224, 1, a + row);
    vgg_describe(w2, fx->input, 2, b);
    /* Chunks span images when batched, so bits can differ only if a chunk's sums
     * depended on its neighbours; they do not. */
    assert_memory_equal(a, b, 2 * row * sizeof(float));
    vgg_workspace_free(w1);
    vgg_workspace_free(w2);
    free(a);
    free(b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_widths_from_file),
        cmocka_unit_test(test_avg3_pre_relu),
        cmocka_unit_test(test_avg3_batched_threaded),
        cmocka_unit_test(test_avg2_pre_relu),
        cmocka_unit_test(test_max2_post_relu),
        cmocka_unit_test(test_thread_and_batch_invariance),
        cmocka_unit_test(test_fast_path),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
