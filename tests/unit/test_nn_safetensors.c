/*
 * safetensors reader: dtype conversion of a valid file, and every kind of broken or lying
 * file refused with a message naming the file and, where there is one, the tensor.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>
#include <unistd.h>

#include "test_nn_util.h"

static char dir[] = "/tmp/test_nn_st_XXXXXX";

/* Writes [u64 header length][header][data] to dir/name and returns the path. */
static const char *write_file(const char *name, const char *header, const void *data,
                              size_t ndata, int64_t lie_hlen)
{
    static char path[256];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    uint64_t hlen = lie_hlen >= 0 ? (uint64_t)lie_hlen : strlen(header);
    unsigned char len[8];
    for (int i = 0; i < 8; i++)
        len[i] = (unsigned char)(hlen >> (8 * i));
    fwrite(len, 1, 8, f);
    fwrite(header, 1, strlen(header), f);
    if (ndata)
        fwrite(data, 1, ndata, f);
    fclose(f);
    return path;
}

static int setup(void **state)
{
    (void)state;
    return mkdtemp(dir) ? 0 : -1;
}

/* F32 1.0, -2.5; F16 1.5 (0x3E00), a subnormal 2^-24 (0x0001), -0 (0x8000);
 * BF16 -2.0 (0xC000), 3.140625 (0x4049). */
static const unsigned char good_data[] = {0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x20, 0xc0,
                                          0x00, 0x3e, 0x01, 0x00, 0x00, 0x80, 0x00, 0xc0,
                                          0x49, 0x40};
static const char *good_header =
    "{\"__metadata__\":{\"k\":\"v\"},"
    "\"a\":{\"dtype\":\"F32\",\"shape\":[2],\"data_offsets\":[0,8]},"
    "\"h\":{\"dtype\":\"F16\",\"shape\":[3],\"data_offsets\":[8,14]},"
    "\"b\":{\"dtype\":\"BF16\",\"shape\":[1,2],\"data_offsets\":[14,18]}}";

static void test_valid_file_all_dtypes(void **state)
{
    (void)state;
    const char *path = write_file("good.safetensors", good_header, good_data, sizeof good_data, -1);
    nn_safetensors st;
    char err[512];
    assert_int_equal(nn_safetensors_open(path, &st, err, sizeof err), 0);
    assert_int_equal(st.count, 3);
    float v[3];
    int64_t s2[1] = {2}, s3[1] = {3}, s12[2] = {1, 2};
    assert_int_equal(nn_safetensors_read_f32(&st, "a", 1, s2, v, err, sizeof err), 0);
    assert_true(v[0] == 1.0f && v[1] == -2.5f);
    assert_int_equal(nn_safetensors_read_f32(&st, "h", 1, s3, v, err, sizeof err), 0);
    assert_true(v[0] == 1.5f && v[1] == 0x1p-24f && v[2] == 0.0f && signbit(v[2]));
    assert_int_equal(nn_safetensors_read_f32(&st, "b", 2, s12, v, err, sizeof err), 0);
    assert_true(v[0] == -2.0f && v[1] == 3.140625f);
    /* Wrong expected shape, missing tensor. */
    assert_int_equal(nn_safetensors_read_f32(&st, "a", 1, s3, v, err, sizeof err), -1);
    assert_non_null(strstr(err, path));
    assert_non_null(strstr(err, "\"a\" has shape (2), expected (3)"));
    assert_int_equal(nn_safetensors_read_f32(&st, "zz", 1, s3, v, err, sizeof err), -1);
    assert_non_null(strstr(err, "no tensor \"zz\""));
    nn_safetensors_close(&st);
}

/* The writer: F32 and F16 tensors side by side; read back, F32 exactly and F16 as
 * nn_float_to_half rounds (a value between two halves goes to the nearer); the F16 tensor
 * takes 2 bytes a value. */
static void test_write_f32_f16(void **state)
{
    (void)state;
    const float a[3] = {1.0f, -2.5f, 3.1f};
    const float h[4] = {1.5f, 0.1f, -65504.0f, 1e-7f};
    nn_tensor_out t[2] = {
        {"a", 1, {3}, a, NN_F32},
        {"h", 2, {2, 2}, h, NN_F16},
    };
    char path[256], err[512];
    snprintf(path, sizeof path, "%s/written.safetensors", dir);
    const char *meta[] = {"format", "test"};
    assert_int_equal(nn_safetensors_write(path, t, 2, meta, 1, err, sizeof err), 0);
    nn_safetensors st;
    assert_int_equal(nn_safetensors_open(path, &st, err, sizeof err), 0);
    assert_int_equal(st.count, 2);
    float v[4];
    int64_t s3[1] = {3}, s22[2] = {2, 2};
    assert_int_equal(nn_safetensors_read_f32(&st, "a", 1, s3, v, err, sizeof err), 0);
    assert_memory_equal(v, a, sizeof a);
    assert_int_equal(nn_safetensors_read_f32(&st, "h", 2, s22, v, err, sizeof err), 0);
    for (int i = 0; i < 4; i++) {
        assert_true(v[i] == nn_half_to_float(nn_float_to_half(h[i])));
        assert_true(fabsf(v[i] - h[i]) <= fabsf(h[i]) * 0x1p-11f + 0x1p-25f);
    }
    int hi = nn_safetensors_find(&st, "h");
    assert_true(hi >= 0 && st.tensors[hi].dtype == NN_F16);
    assert_int_equal(st.tensors[hi].end - st.tensors[hi].begin, 8);
    nn_safetensors_close(&st);
}

/* Opens a broken file and checks the message names the file and contains `expect`. */
static void expect_refused(const char *name, const char *header, size_t ndata, int64_t lie_hlen,
                           const char *expect)
{
    const char *path = write_file(name, header, good_data, ndata, lie_hlen);
    nn_safetensors st;
    char err[512] = "";
    assert_int_equal(nn_safetensors_open(path, &st, err, sizeof err), -1);
    printf("%s -> %s\n", name, err);
    assert_non_null(strstr(err, path));
    assert_non_null(strstr(err, expect));
}

static void test_lying_files(void **state)
{
    (void)state;
    expect_refused("hlen.safetensors", good_header, sizeof good_data, 1 << 30,
                   "header length 1073741824 runs past the end of the file");
    expect_refused("json.safetensors", "{\"a\":{\"dtype\":", 0, -1, "not valid JSON");
    expect_refused("array.safetensors", "[1,2]", 0, -1, "not a JSON object");
    expect_refused("dtype.safetensors",
                   "{\"a\":{\"dtype\":\"I32\",\"shape\":[2],\"data_offsets\":[0,8]}}", 8, -1,
                   "tensor \"a\": dtype \"I32\" is not supported");
    expect_refused("past.safetensors",
                   "{\"a\":{\"dtype\":\"F32\",\"shape\":[4],\"data_offsets\":[0,16]}}", 8, -1,
                   "tensor \"a\": data_offsets [0, 16] run past the end of the data (8 bytes)");
    expect_refused("span.safetensors",
                   "{\"a\":{\"dtype\":\"F32\",\"shape\":[3],\"data_offsets\":[0,8]}}", 8, -1,
                   "tensor \"a\": data_offsets span 8 bytes but dtype F32 and its shape need 12");
    expect_refused("overlap.safetensors",
                   "{\"a\":{\"dtype\":\"F32\",\"shape\":[2],\"data_offsets\":[0,8]},"
                   "\"b\":{\"dtype\":\"F16\",\"shape\":[2],\"data_offsets\":[6,10]}}",
                   10, -1, "tensors \"a\" and \"b\" overlap");
    expect_refused("negative.safetensors",
                   "{\"a\":{\"dtype\":\"F32\",\"shape\":[-2],\"data_offsets\":[0,8]}}", 8, -1,
                   "tensor \"a\": shape[0] is not a non-negative integer");
    expect_refused("reversed.safetensors",
                   "{\"a\":{\"dtype\":\"F32\",\"shape\":[2],\"data_offsets\":[8,0]}}", 8, -1,
                   "tensor \"a\": data_offsets must be [begin, end]");
    expect_refused("huge.safetensors",
                   "{\"a\":{\"dtype\":\"F32\",\"shape\":[4294967296,4294967296],"
                   "\"data_offsets\":[0,8]}}",
                   8, -1, "tensor \"a\": shape is larger than the file");
    expect_refused("fields.safetensors", "{\"a\":{\"shape\":[2],\"data_offsets\":[0,8]}}", 8,
                   -1, "tensor \"a\": expected an object with \"dtype\"");

    /* Too short to hold the header length at all. */
    char path[256];
    snprintf(path, sizeof path, "%s/short.safetensors", dir);
    FILE *f = fopen(path, "wb");
    fwrite("abc", 1, 3, f);
    fclose(f);
    nn_safetensors st;
    char err[512];
    assert_int_equal(nn_safetensors_open(path, &st, err, sizeof err), -1);
    assert_non_null(strstr(err, "too short"));
    assert_int_equal(nn_safetensors_open("/nonexistent.safetensors", &st, err, sizeof err), -1);
    assert_non_null(strstr(err, "/nonexistent.safetensors"));
}

/* vgg19_load on a valid safetensors without VGG keys, and with a wrongly shaped conv. */
static void test_vgg_load_errors(void **state)
{
    (void)state;
    const char *path = write_file("novgg.safetensors", good_header, good_data, sizeof good_data, -1);
    vgg19 net;
    char err[512];
    assert_int_equal(vgg19_load(&net, path, err, sizeof err), -1);
    assert_non_null(strstr(err, path));
    assert_non_null(strstr(err, "features.2.weight"));
}

static int teardown(void **state)
{
    (void)state;
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_valid_file_all_dtypes),
        cmocka_unit_test(test_lying_files),
        cmocka_unit_test(test_write_f32_f16),
        cmocka_unit_test(test_vgg_load_errors),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
