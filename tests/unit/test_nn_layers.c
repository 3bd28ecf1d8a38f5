/*
 * nn layers: the fast convolutions (Winograd and im2col, every tail and fallback) against
 * a double-precision direct convolution; pooling, Gram and preprocessing against their
 * definitions; the random initialisation's determinism and scale.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>
#include <unistd.h>

#include "nn/conv3x3.h"
#include "test_nn_util.h"

static float frand(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return (float)(*s >> 8) * 0x1p-24f * 2.0f - 1.0f;
}

/* Runs one conv through the chunked engine and checks every output against the exact
 * sum, within 1e-6 (about 16 float ulps) of the sum of the magnitudes of its terms: fp32
 * sums of a few hundred terms in random order err by a few ulps of that sum, and the
 * Winograd transforms add a few exact-coefficient roundings. */
static void check_conv(int N, int C, int K, int H, int W, int winograd, size_t budget)
{
    uint32_t seed = (uint32_t)(N * 131 + C * 17 + K * 7 + H * 3 + W);
    size_t nin = (size_t)N * C * H * W, nout = (size_t)N * K * H * W;
    float *in = malloc(nin * sizeof(float)), *w = malloc((size_t)K * C * 9 * sizeof(float));
    float *b = malloc((size_t)K * sizeof(float)), *out = malloc(nout * sizeof(float));
    float *U = malloc(16 * (size_t)K * C * sizeof(float));
    for (size_t i = 0; i < nin; i++)
        in[i] = frand(&seed);
    for (size_t i = 0; i < (size_t)K * C * 9; i++)
        w[i] = frand(&seed) * 0.3f;
    for (int k = 0; k < K; k++)
        b[k] = frand(&seed);
    winograd_weights(U, w, K, C);
    conv_layer L = {.in = in, .out = out, .N = N, .C = C, .K = K, .H = H, .W = W,
                    .winograd = winograd, .U = U, .weight = w, .bias = b};
    L.chunk = conv_chunk_size(winograd, C, K, W, budget);
    float *scratch = malloc(conv_scratch_floats(winograd, C, K, W, L.chunk) * sizeof(float));
    for (size_t c = 0; c < conv_chunk_count(&L); c++)
        conv_run_chunk(&L, c, scratch);
    if (K % 64 == 0) { /* output channels split in two: not a bit may change */
        float *again = malloc(nout * sizeof(float));
        conv_layer L2 = L;
        L2.out = again;
        L2.kblocks = 2;
        assert_int_equal(conv_chunk_count(&L2), 2 * conv_chunk_count(&L));
        for (size_t c = 0; c < conv_chunk_count(&L2); c++)
            conv_run_chunk(&L2, c, scratch);
        assert_memory_equal(again, out, nout * sizeof(float));
        free(again);
    }

    double worst = 0.0;
    for (int n = 0; n < N; n++)
        for (int k = 0; k < K; k++)
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++) {
                    double s = b[k], mag = fabs(b[k]);
                    for (int c = 0; c < C; c++)
                        for (int dy = -1; dy <= 1; dy++)
                            for (int dx = -1; dx <= 1; dx++) {
                                int yy = y + dy, xx = x + dx;
                                if (yy < 0 || yy >= H || xx < 0 || xx >= W)
                                    continue;
                                double t = (double)w[((size_t)k * C + c) * 9 + (dy + 1) * 3 + dx + 1] *
                                           in[(((size_t)n * C + c) * H + yy) * W + xx];
                                s += t;
                                mag += fabs(t);
                            }
                    double got = out[(((size_t)n * K + k) * H + y) * W + x];
                    worst = fmax(worst, fabs(got - s) / mag);
                }
    printf("conv N%d C%d K%d %dx%d %s chunk %d: worst error / sum|terms| = %.3g\n", N, C, K, H,
           W, winograd ? "winograd" : "im2col", L.chunk, worst);
    assert_true(worst <= 1e-6);
    free(in);
    free(w);
    free(b);
    free(out);
    free(U);
    free(scratch);
}

static void test_winograd_shapes(void **state)
{
    (void)state;
    check_conv(2, 16, 24, 9, 37, 1, 1 << 20);  /* odd plane: partial tiles at both edges */
    check_conv(1, 16, 16, 6, 70, 1, 1 << 20);  /* 35 tiles a row: two 16-groups + tail */
    check_conv(2, 8, 16, 5, 5, 1, 1);          /* smallest chunk: 96 tiles, spans images */
    check_conv(2, 32, 8, 4, 4, 1, 1 << 22);    /* whole images per chunk */
    check_conv(1, 12, 12, 7, 7, 1, 1 << 20);   /* K not a multiple of 8: sgemm fallback */
    check_conv(1, 64, 64, 20, 20, 1, 1 << 20); /* T = 10 * rows: 48/32/16 blocks */
    check_conv(2, 8, 64, 3, 5, 0, 1 << 20);    /* im2col split in two channel blocks */
}

static void test_im2col_shapes(void **state)
{
    (void)state;
    check_conv(2, 3, 16, 9, 13, 0, 1 << 20); /* chunks span both images */
    check_conv(2, 5, 8, 2, 2, 0, 1);
    check_conv(2, 3, 12, 9, 13, 0, 1 << 12); /* K not a multiple of 8: sgemm, per image */
}

static void test_reference_conv_matches_definition(void **state)
{
    (void)state;
    /* One channel, a centre-tap filter plus a right-neighbour tap: out = 2 x + 3 x_right + 1. */
    float in[12], w[9] = {0, 0, 0, 0, 2, 3, 0, 0, 0}, b[1] = {1}, out[12];
    for (int i = 0; i < 12; i++)
        in[i] = (float)i;
    conv3x3_forward_reference(out, in, w, b, 1, 1, 1, 3, 4);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 4; x++) {
            float right = x + 1 < 4 ? in[y * 4 + x + 1] : 0.0f;
            assert_float_equal(out[y * 4 + x], 2 * in[y * 4 + x] + 3 * right + 1, 0);
        }
}

static void test_pooling(void **state)
{
    (void)state;
    /* 7x7 plane of 0..48: avg3/stride 3 gives 2x2 means of 3x3 blocks (floor mode drops the
     * last row and column); max2 gives 3x3. */
    float in[49], out[9];
    for (int i = 0; i < 49; i++)
        in[i] = (float)i;
    avgpool_forward(out, in, 1, 1, 7, 7, 3, 3);
    assert_float_equal(out[0], 8.0f, 1e-6);  /* centre of rows 0-2, cols 0-2 = 1*7+1 */
    assert_float_equal(out[1], 11.0f, 1e-6); /* cols 3-5 */
    assert_float_equal(out[2], 29.0f, 1e-6); /* rows 3-5 */
    maxpool_forward(out, in, 1, 1, 7, 7, 2, 2);
    assert_float_equal(out[0], 8.0f, 0);
    assert_float_equal(out[8], 40.0f, 0); /* rows 4-5, cols 4-5 -> 5*7+5 */
}

static void test_gram_upper(void **state)
{
    (void)state;
    /* f = [[1,2,3],[4,5,6]]: f f^T / 3 = [[14,32],[32,77]] / 3, upper triangle row-major. */
    float f[6] = {1, 2, 3, 4, 5, 6}, out[3], scratch[4];
    gram_upper_forward(out, f, 2, 3, scratch);
    assert_float_equal(out[0], 14.0f / 3, 1e-6);
    assert_float_equal(out[1], 32.0f / 3, 1e-5);
    assert_float_equal(out[2], 77.0f / 3, 1e-5);
}

static void test_preprocess_crop_clamp_normalise(void **state)
{
    (void)state;
    /* 230x226 RGB: crop starts at ((226-224)/2, (230-224)/2) = (1, 3). */
    int w = 230, h = 226;
    float *px = malloc((size_t)w * h * 3 * sizeof(float)), *out = malloc(3 * 224 * 224 * 4);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++)
                px[((size_t)y * w + x) * 3 + c] = (float)(x + y) / 100.0f - 1.0f + 0.1f * c;
    assert_int_equal(vgg_preprocess(out, px, w, h, 3), 0);
    const float mean[3] = {0.485f, 0.456f, 0.406f}, sd[3] = {0.229f, 0.224f, 0.225f};
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < 224; y += 37)
            for (int x = 0; x < 224; x += 41) {
                float v = px[((size_t)(y + 1) * w + x + 3) * 3 + c];
                v = v < 0 ? 0 : v > 1 ? 1 : v;
                assert_float_equal(out[(c * 224 + y) * 224 + x], (v - mean[c]) / sd[c], 1e-6);
            }
    assert_int_equal(vgg_preprocess(out, px, 200, 300, 3), -1); /* too narrow */
    free(px);
    free(out);
}

static void test_random_init(void **state)
{
    (void)state;
    vgg19 a, b;
    const int width[5] = {8, 16, 16, 16, 16};
    assert_int_equal(vgg19_init_random(&a, width, 7), 0);
    assert_int_equal(vgg19_init_random(&b, width, 7), 0);
    for (int l = 0; l < VGG_CONV_LAYERS; l++)
        assert_memory_equal(a.weight[l], b.weight[l],
                            (size_t)a.cout[l] * a.cin[l] * 9 * sizeof(float));
    /* He scale: sample variance of the largest layer within 10% of 2 / (9 cin). */
    int l = 15;
    size_t n = (size_t)a.cout[l] * a.cin[l] * 9;
    double s2 = 0;
    for (size_t i = 0; i < n; i++)
        s2 += (double)a.weight[l][i] * a.weight[l][i];
    double want = 2.0 / (9.0 * a.cin[l]);
    assert_true(fabs(s2 / n / want - 1.0) < 0.1);
    vgg19_free(&b);
    assert_int_equal(vgg19_init_random(&b, width, 8), 0);
    assert_true(memcmp(a.weight[0], b.weight[0], 8 * 3 * 9 * sizeof(float)) != 0);
    vgg19_free(&a);
    vgg19_free(&b);
}

/* A texture: oriented stripes of period `period` at angle `angle` plus a finer cross
 * pattern, shifted by (dx, dy), in [0,1], RGB with per-channel phase. */
static void texture(float *px, int size, double period, double angle, int dx, int dy)
{
    for (int y = 0; y < size; y++)
        for (int x = 0; x < size; x++)
            for (int c = 0; c < 3; c++) {
                double u = (x + dx) * cos(angle) + (y + dy) * sin(angle);
                double v = 0.5 + 0.35 * sin(6.283185 * u / period + c) +
                           0.1 * sin(6.283185 * (x + dx) / 5.0) * sin(6.283185 * (y + dy) / 7.0);
                px[((size_t)y * size + x) * 3 + c] = (float)v;
            }
}

/* What "usable texture statistics" means for the default random network: a Gram
 * descriptor barely moves when the same texture is shifted, and moves far more for a
 * different texture, at every layer. */
static void test_random_init_separates_textures(void **state)
{
    (void)state;
    vgg19 net;
    assert_int_equal(vgg19_init_random(&net, vgg19_standard_width, 1), 0);
    const int size = 256;
    float *px = malloc((size_t)size * size * 3 * sizeof(float));
    float *in = malloc(4 * 3 * 224 * 224 * sizeof(float));
    const double spec[4][4] = {{9, 0.3, 0, 0}, {9, 0.3, 17, 29}, {23, 1.2, 0, 0}, {23, 1.2, 17, 29}};
    for (int i = 0; i < 4; i++) {
        texture(px, size, spec[i][0], spec[i][1], (int)spec[i][2], (int)spec[i][3]);
        vgg_preprocess(in + (size_t)i * 3 * 224 * 224, px, size, size, 3);
    }
    size_t row = vgg19_descriptor_size(&net), off[6];
    vgg19_descriptor_offsets(&net, off);
    float *d = malloc(4 * row * sizeof(float));
    vgg_options opt = {.pool = VGG_POOL_AVG3, .threads = 2};
    vgg_workspace *ws = vgg_workspace_create(&net, &opt, 4);
    assert_non_null(ws);
    vgg_describe(ws, in, 4, d);
    for (int l = 0; l < 5; l++) {
        double same = 0, other = 0, norm = 0;
        for (size_t i = off[l]; i < off[l + 1]; i++) {
            double a0 = d[i], a1 = d[row + i], b0 = d[2 * row + i];
            same += (a0 - a1) * (a0 - a1);
            other += (a0 - b0) * (a0 - b0);
            norm += a0 * a0;
        }
        printf("layer %d: |A - A shifted| = %.3g, |A - B| = %.3g (relative to |A|)\n", l,
               sqrt(same / norm), sqrt(other / norm));
        assert_true(sqrt(same) * 10 < sqrt(other));
    }
    vgg_workspace_free(ws);
    vgg19_free(&net);
    free(px);
    free(in);
    free(d);
}

static void test_npy_roundtrip(void **state)
{
    (void)state;
    char path[] = "/tmp/test_nn_npy_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    float data[6] = {1, 2, 3, 4, 5, -6.5f};
    char err[256];
    assert_int_equal(nn_npy_write_f32(path, data, 2, 3, err, sizeof err), 0);
    int ndim, u8;
    long shape[4];
    float *back = npy_read(path, &ndim, shape, &u8);
    assert_non_null(back);
    assert_int_equal(ndim, 2);
    assert_int_equal(shape[0], 2);
    assert_int_equal(shape[1], 3);
    assert_memory_equal(back, data, sizeof data);
    free(back);
    /* A writer that does not get all its rows leaves nothing behind. */
    remove(path);
    nn_npy_writer *w = nn_npy_begin(path, 3, 3, err, sizeof err);
    assert_non_null(w);
    assert_int_equal(nn_npy_append(w, data, 2, err, sizeof err), 0);
    assert_int_equal(nn_npy_commit(w, err, sizeof err), -1);
    assert_non_null(strstr(err, "2 of 3 rows"));
    assert_int_equal(access(path, F_OK), -1);
    /* Unwritable place: an error naming it. */
    assert_int_equal(nn_npy_write_f32("/nonexistent-dir/x.npy", data, 2, 3, err, sizeof err), -1);
    assert_non_null(strstr(err, "/nonexistent-dir/x.npy"));
}

/* Writes a .npy file with the given header dict and raw data bytes. */
static void write_raw_npy(const char *path, const char *dict, const void *bytes, size_t n)
{
    char header[128];
    int len = snprintf(header, sizeof header, "%s", dict);
    size_t hlen = ((size_t)10 + (size_t)len + 1 + 63) / 64 * 64 - 10;
    memset(header + len, ' ', hlen - 1 - (size_t)len);
    header[hlen - 1] = '\n';
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    unsigned char pre[10] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, (unsigned char)hlen, 0};
    fwrite(pre, 1, 10, f);
    fwrite(header, 1, hlen, f);
    fwrite(bytes, 1, n, f);
    fclose(f);
}

static void test_npy_read(void **state)
{
    (void)state;
    char path[] = "/tmp/test_nn_npy_read_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    char err[256];
    float *x;
    size_t r, c;
    /* Our own writer's output reads back bit for bit. */
    float data[6] = {1, 2, 3, 4, 5, -6.5f};
    assert_int_equal(nn_npy_write_f32(path, data, 2, 3, err, sizeof err), 0);
    assert_int_equal(nn_npy_read_f32(path, &x, &r, &c, err, sizeof err), 0);
    assert_int_equal(r, 2);
    assert_int_equal(c, 3);
    assert_memory_equal(x, data, sizeof data);
    free(x);
    /* float64, int16 (negative), bool and float16 convert; 1-D is n x 1. */
    double d[3] = {0.5, -2.0, 1e-3};
    write_raw_npy(path, "{'descr': '<f8', 'fortran_order': False, 'shape': (3,), }", d, sizeof d);
    assert_int_equal(nn_npy_read_f32(path, &x, &r, &c, err, sizeof err), 0);
    assert_int_equal(r, 3);
    assert_int_equal(c, 1);
    assert_true(x[0] == 0.5f && x[1] == -2.0f && x[2] == (float)1e-3);
    free(x);
    int16_t i16[2] = {-3, 300};
    write_raw_npy(path, "{'descr': '<i2', 'fortran_order': False, 'shape': (1, 2), }", i16,
                  sizeof i16);
    assert_int_equal(nn_npy_read_f32(path, &x, &r, &c, err, sizeof err), 0);
    assert_true(x[0] == -3.0f && x[1] == 300.0f);
    free(x);
    unsigned char b[3] = {1, 0, 1};
    write_raw_npy(path, "{'descr': '|b1', 'fortran_order': False, 'shape': (3,), }", b, 3);
    assert_int_equal(nn_npy_read_f32(path, &x, &r, &c, err, sizeof err), 0);
    assert_true(x[0] == 1.0f && x[1] == 0.0f && x[2] == 1.0f);
    free(x);
    uint16_t h[3] = {0x3c00, 0xc000, 0x0001}; /* 1, -2, smallest subnormal */
    write_raw_npy(path, "{'descr': '<f2', 'fortran_order': False, 'shape': (3,), }", h, 6);
    assert_int_equal(nn_npy_read_f32(path, &x, &r, &c, err, sizeof err), 0);
    assert_true(x[0] == 1.0f && x[1] == -2.0f && x[2] == ldexpf(1.0f, -24));
    free(x);
    /* A header that claims more data than the file holds: an error, no allocation of
     * the claim. */
    write_raw_npy(path, "{'descr': '<f4', 'fortran_order': False, 'shape': (100000, 100000), }",
                  data, sizeof data);
    assert_int_equal(nn_npy_read_f32(path, &x, &r, &c, err, sizeof err), -1);
    assert_null(x);
    assert_non_null(strstr(err, path));
    assert_non_null(strstr(err, "header"));
    write_raw_npy(path, "{'descr': '<c8', 'fortran_order': False, 'shape': (3,), }", data, 24);
    assert_int_equal(nn_npy_read_f32(path, &x, &r, &c, err, sizeof err), -1);
    assert_non_null(strstr(err, "dtype"));
    write_raw_npy(path, "{'descr': '<f4', 'fortran_order': True, 'shape': (2, 3), }", data, 24);
    assert_int_equal(nn_npy_read_f32(path, &x, &r, &c, err, sizeof err), -1);
    write_raw_npy(path, "{'descr': '<f4', 'fortran_order': False, 'shape': (1, 2, 3), }", data, 24);
    assert_int_equal(nn_npy_read_f32(path, &x, &r, &c, err, sizeof err), -1);
    FILE *f = fopen(path, "wb");
    fputs("not numpy", f);
    fclose(f);
    assert_int_equal(nn_npy_read_f32(path, &x, &r, &c, err, sizeof err), -1);
    assert_non_null(strstr(err, "magic"));
    remove(path);
    assert_int_equal(nn_npy_read_f32(path, &x, &r, &c, err, sizeof err), -1);
    assert_non_null(strstr(err, "cannot open"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_winograd_shapes),
        cmocka_unit_test(test_im2col_shapes),
        cmocka_unit_test(test_reference_conv_matches_definition),
        cmocka_unit_test(test_pooling),
        cmocka_unit_test(test_gram_upper),
        cmocka_unit_test(test_preprocess_crop_clamp_normalise),
        cmocka_unit_test(test_random_init),
        cmocka_unit_test(test_random_init_separates_textures),
        cmocka_unit_test(test_npy_roundtrip),
        cmocka_unit_test(test_npy_read),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
