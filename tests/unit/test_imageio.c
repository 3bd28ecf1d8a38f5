/*
 * imageio: EXR (float, half, metadata) and PNG round trips, the sRGB transfer functions,
 * the metadata rule for linear 8-bit files, grey+alpha expansion, resizing, and the
 * failure paths: truncated, corrupt, empty, missing, oversized files and folders give an
 * error naming the file; failed writes leave neither the target nor a temporary file.
 *
 * Files are written into a fresh folder under /tmp, removed at the end.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include <dirent.h>
#include <float.h>
#include <math.h>
#include <sys/stat.h>
#include <unistd.h>

#include "imageio/imageio.h"

typedef struct fixture {
    char dir[64];
} fixture;

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof *f);
    if (!f)
        return -1;
    snprintf(f->dir, sizeof f->dir, "/tmp/test_imageio.XXXXXX");
    if (!mkdtemp(f->dir)) {
        free(f);
        return -1;
    }
    *state = f;
    return 0;
}

/* Remove everything in dir (files and empty folders, one level deep), then dir. */
static int teardown(void **state)
{
    fixture *f = *state;
    DIR *d = opendir(f->dir);
    if (d) {
        struct dirent *e;
        char p[512];
        while ((e = readdir(d)) != NULL) {
            if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
                continue;
            snprintf(p, sizeof p, "%s/%s", f->dir, e->d_name);
            if (unlink(p) != 0)
                rmdir(p);
        }
        closedir(d);
    }
    rmdir(f->dir);
    free(f);
    return 0;
}

static void path_in(const fixture *f, const char *name, char *out, size_t outlen)
{
    snprintf(out, outlen, "%s/%s", f->dir, name);
}

/* Deterministic values in [lo, hi). */
static float next_uniform(uint32_t *s, float lo, float hi)
{
    *s = *s * 1664525u + 1013904223u;
    return lo + (hi - lo) * (float)(*s >> 8) / 16777216.0f;
}

static void fill_random(image *img, uint32_t seed, float lo, float hi)
{
    size_t n = (size_t)img->width * img->height * img->channels;
    for (size_t i = 0; i < n; i++)
        img->pixels[i] = next_uniform(&seed, lo, hi);
}

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *fp = fopen(path, "wb");
    assert_non_null(fp);
    assert_int_equal(fwrite(data, 1, n, fp), n);
    assert_int_equal(fclose(fp), 0);
}

static size_t file_size(const char *path)
{
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    return (size_t)st.st_size;
}

/* Keep the first half of a file. */
static void truncate_half(const char *path)
{
    size_t n = file_size(path);
    assert_true(n > 16);
    assert_int_equal(truncate(path, (off_t)(n / 2)), 0);
}

/* Number of entries in dir whose name contains ".tmp". */
static int count_temp_files(const char *dir)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strstr(e->d_name, ".tmp"))
            n++;
    closedir(d);
    return n;
}

/* image_read must fail, with a message naming the file. */
static void expect_read_error(const char *path)
{
    image img = {0};
    char err[512] = "";
    assert_int_equal(image_read(path, &img, err, sizeof err), -1);
    assert_null(img.pixels);
    if (!strstr(err, path))
        fail_msg("error for %s does not name it: \"%s\"", path, err);
}

/* ---------------------------------------------------------------------------------------
 * A minimal PNG writer (stored, uncompressed deflate), so that the tests can make files
 * our writer never makes: grey+alpha, a gAMA chunk, absurd sizes.
 */

static uint32_t crc32_png(const uint8_t *p, size_t n, uint32_t crc)
{
    crc = ~crc;
    for (size_t i = 0; i < n; i++) {
        crc ^= p[i];
        for (int k = 0; k < 8; k++)
            crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

static uint8_t *put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
    return p + 4;
}

static uint8_t *put_chunk(uint8_t *p, const char *type, const uint8_t *data, uint32_t n)
{
    p = put32(p, n);
    uint8_t *crc_start = p;
    memcpy(p, type, 4);
    p += 4;
    if (n)
        memcpy(p, data, n);
    p += n;
    return put32(p, crc32_png(crc_start, n + 4, 0));
}

/* 8- or 16-bit PNG of colour type 0 (grey), 2 (RGB) or 4 (grey+alpha); gamma_1 adds a
 * gAMA chunk of 1.0; orientation (1..8) adds an eXIf chunk; 16-bit samples are big-endian
 * in pixels.
 * pixels may be NULL for a file whose IDAT holds only a zlib header: enough for a reader
 * to accept the header. Returns the byte count written to out. */
static size_t make_png_full(uint8_t *out, uint32_t w, uint32_t h, int colour_type,
                            int bit_depth, int gamma_1, int orientation, const uint8_t *pixels)
{
    static const uint8_t signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    int channels = colour_type == 0 ? 1 : colour_type == 4 ? 2 : 3;
    uint8_t *p = out;
    memcpy(p, signature, 8);
    p += 8;
    uint8_t ihdr[13];
    put32(ihdr, w);
    put32(ihdr + 4, h);
    ihdr[8] = (uint8_t)bit_depth;
    ihdr[9] = (uint8_t)colour_type;
    ihdr[10] = ihdr[11] = ihdr[12] = 0;
    p = put_chunk(p, "IHDR", ihdr, 13);
    if (gamma_1) {
        uint8_t gama[4];
        put32(gama, 100000);
        p = put_chunk(p, "gAMA", gama, 4);
    }
    if (orientation) {
        /* eXIf: a big-endian TIFF header and one IFD holding Orientation (0x0112, SHORT). */
        uint8_t exif[26] = {'M', 'M', 0, 42, 0, 0, 0, 8, 0, 1, 0x01, 0x12, 0, 3, 0, 0, 0, 1,
                            0, (uint8_t)orientation, 0, 0, 0, 0, 0, 0};
        p = put_chunk(p, "eXIf", exif, sizeof exif);
    }
    if (pixels) {
        /* zlib stream: header, one stored block of filter-byte-prefixed rows, Adler-32. */
        size_t row = (size_t)w * channels * (bit_depth / 8);
        size_t raw_n = (row + 1) * h;
        assert_true(raw_n < 65536);
        uint8_t *z = malloc(raw_n + 11);
        assert_non_null(z);
        z[0] = 0x78;
        z[1] = 0x01;
        z[2] = 1; /* final block, stored */
        z[3] = (uint8_t)raw_n;
        z[4] = (uint8_t)(raw_n >> 8);
        z[5] = (uint8_t)~raw_n;
        z[6] = (uint8_t)(~raw_n >> 8);
        uint8_t *r = z + 7;
        for (uint32_t y = 0; y < h; y++) {
            *r++ = 0;
            memcpy(r, pixels + y * row, row);
            r += row;
        }
        uint32_t a = 1, b = 0;
        for (size_t i = 0; i < raw_n; i++) {
            a = (a + z[7 + i]) % 65521u;
            b = (b + a) % 65521u;
        }
        put32(r, (b << 16) | a);
        p = put_chunk(p, "IDAT", z, (uint32_t)(raw_n + 11));
        free(z);
    } else {
        static const uint8_t zlib_header[2] = {0x78, 0x01};
        p = put_chunk(p, "IDAT", zlib_header, 2);
    }
    p = put_chunk(p, "IEND", NULL, 0);
    return (size_t)(p - out);
}

static size_t make_png(uint8_t *out, uint32_t w, uint32_t h, int colour_type, int gamma_1,
                       const uint8_t *pixels)
{
    return make_png_full(out, w, h, colour_type, 8, gamma_1, 0, pixels);
}

/* A 32 x 32 baseline JPEG (quality 60, noisy gradient): header up to byte 294, scan data
 * after, so cutting it in half cuts the entropy-coded data. */
static const uint8_t small_jpeg[] = {
    0xff, 0xd8, 0xff, 0xe0, 0x00, 0x10, 0x4a, 0x46, 0x49, 0x46, 0x00, 0x01, 0x01, 0x00, 0x00, 0x01,
    0x00, 0x01, 0x00, 0x00, 0xff, 0xdb, 0x00, 0x43, 0x00, 0x0d, 0x09, 0x0a, 0x0b, 0x0a, 0x08, 0x0d,
    0x0b, 0x0a, 0x0b, 0x0e, 0x0e, 0x0d, 0x0f, 0x13, 0x20, 0x15, 0x13, 0x12, 0x12, 0x13, 0x27, 0x1c,
    0x1e, 0x17, 0x20, 0x2e, 0x29, 0x31, 0x30, 0x2e, 0x29, 0x2d, 0x2c, 0x33, 0x3a, 0x4a, 0x3e, 0x33,
    0x36, 0x46, 0x37, 0x2c, 0x2d, 0x40, 0x57, 0x41, 0x46, 0x4c, 0x4e, 0x52, 0x53, 0x52, 0x32, 0x3e,
    0x5a, 0x61, 0x5a, 0x50, 0x60, 0x4a, 0x51, 0x52, 0x4f, 0xff, 0xdb, 0x00, 0x43, 0x01, 0x0e, 0x0e,
    0x0e, 0x13, 0x11, 0x13, 0x26, 0x15, 0x15, 0x26, 0x4f, 0x35, 0x2d, 0x35, 0x4f, 0x4f, 0x4f, 0x4f,
    0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f,
    0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f,
    0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0x4f, 0xff, 0xc0,
    0x00, 0x11, 0x08, 0x00, 0x20, 0x00, 0x20, 0x03, 0x01, 0x22, 0x00, 0x02, 0x11, 0x01, 0x03, 0x11,
    0x01, 0xff, 0xc4, 0x00, 0x17, 0x00, 0x01, 0x01, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04, 0x03, 0x05, 0x06, 0xff, 0xc4, 0x00, 0x26, 0x10, 0x00,
    0x02, 0x02, 0x01, 0x04, 0x01, 0x04, 0x03, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01,
    0x02, 0x03, 0x11, 0x21, 0x00, 0x04, 0x12, 0x31, 0x51, 0x13, 0x22, 0x41, 0x61, 0x23, 0x71, 0x81,
    0x14, 0x91, 0xff, 0xc4, 0x00, 0x18, 0x01, 0x00, 0x02, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04, 0x06, 0x02, 0x05, 0x07, 0xff, 0xc4, 0x00, 0x18,
    0x11, 0x00, 0x03, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x03, 0x04, 0x02, 0x21, 0xff, 0xda, 0x00, 0x0c, 0x03, 0x01, 0x00, 0x02, 0x11, 0x03,
    0x11, 0x00, 0x3f, 0x00, 0xe4, 0x57, 0x68, 0x59, 0x62, 0x86, 0x48, 0xd8, 0xf2, 0x24, 0x2a, 0x1c,
    0x5d, 0x67, 0xae, 0xfa, 0x3e, 0x7f, 0x67, 0xc5, 0xf6, 0x88, 0xad, 0x39, 0x56, 0xe0, 0x03, 0x00,
    0x80, 0x1b, 0x23, 0x90, 0xa1, 0x92, 0x73, 0xf3, 0xd0, 0xf2, 0x2e, 0xb5, 0x58, 0x61, 0xfc, 0x6c,
    0xdf, 0x92, 0x23, 0x12, 0xb0, 0x60, 0xf4, 0xd6, 0x2f, 0x27, 0x35, 0x90, 0x48, 0xbf, 0xe7, 0x77,
    0xa7, 0x6d, 0x76, 0xc1, 0xe7, 0x31, 0x7a, 0x71, 0x19, 0xc1, 0x54, 0x3c, 0x70, 0x4d, 0x5e, 0x7d,
    0xdd, 0xe2, 0xcd, 0x82, 0x3e, 0x3a, 0x1a, 0xb3, 0xdb, 0x88, 0x4c, 0xfe, 0x87, 0x86, 0x15, 0x88,
    0x34, 0x60, 0xa4, 0xbc, 0x56, 0xe8, 0x31, 0x52, 0xa4, 0x1a, 0x24, 0xe2, 0xbe, 0x7b, 0xfa, 0xfa,
    0xd2, 0x80, 0x49, 0x24, 0x90, 0xa3, 0x01, 0x21, 0x24, 0xa9, 0xba, 0xa1, 0x5f, 0xbf, 0x03, 0xc6,
    0x31, 0x9e, 0xb4, 0xad, 0x8e, 0xde, 0x25, 0x8e, 0x57, 0x79, 0x1d, 0x64, 0x0d, 0xee, 0x72, 0x96,
    0x7b, 0xf7, 0x29, 0x03, 0xec, 0x1e, 0xfe, 0x3a, 0xeb, 0x4b, 0x1b, 0x64, 0x7e, 0x14, 0x91, 0xca,
    0x57, 0x93, 0x20, 0x5c, 0x03, 0x62, 0xc0, 0x03, 0xb3, 0x56, 0xbe, 0x2a, 0xbe, 0xb4, 0x1e, 0xdc,
    0x31, 0xcb, 0x47, 0x03, 0x41, 0xb3, 0x9c, 0x44, 0xa1, 0x51, 0xe9, 0x00, 0x16, 0x84, 0xa6, 0x05,
    0x75, 0xe7, 0x07, 0xc0, 0x16, 0x74, 0x88, 0x22, 0x02, 0x10, 0x5c, 0x2c, 0xca, 0x63, 0x62, 0xca,
    0x61, 0x0a, 0x63, 0x7c, 0xd5, 0x8f, 0xe0, 0x1a, 0xd1, 0x82, 0x21, 0x0c, 0x61, 0xd4, 0xf2, 0x75,
    0x14, 0x0b, 0x0e, 0x4c, 0x72, 0x7a, 0xc8, 0x1d, 0x1e, 0x87, 0x8d, 0x23, 0x69, 0x17, 0x26, 0x05,
    0x02, 0x90, 0xd6, 0x4b, 0x35, 0x82, 0xe4, 0xe6, 0xc9, 0xfb, 0x07, 0xe3, 0xab, 0x3a, 0x0f, 0x6e,
    0x33, 0xe9, 0xa8, 0xe8, 0x48, 0xf6, 0x2a, 0xf3, 0xac, 0xd1, 0x46, 0xe0, 0xb8, 0x3e, 0xba, 0xc6,
    0x0f, 0x9a, 0xaf, 0x3f, 0x7f, 0xf3, 0x1a, 0x4f, 0xf9, 0xa1, 0x6d, 0xc9, 0x5e, 0x52, 0x10, 0xad,
    0x7c, 0x7d, 0x3b, 0xe6, 0x2f, 0x89, 0x19, 0x3d, 0x9c, 0x0f, 0x81, 0x9c, 0x67, 0x4e, 0x1b, 0x57,
    0x0a, 0xb1, 0xb2, 0x80, 0x8c, 0x28, 0x91, 0x84, 0x5f, 0x70, 0xa3, 0x57, 0xd9, 0xb2, 0x08, 0xbc,
    0xde, 0x93, 0x1e, 0xda, 0x41, 0xe9, 0x99, 0x19, 0x38, 0xa0, 0x21, 0xb9, 0x1c, 0x33, 0x60, 0x64,
    0x66, 0xf3, 0xf3, 0xe4, 0xf5, 0xe4, 0x4d, 0xb8, 0x64, 0x96, 0x83, 0xff, 0xd9,
};

/* ---------------------------------------------------------------------------------------
 * sRGB
 */

static void test_srgb_known_values(void **state)
{
    (void)state;
    /* Reference values from the IEC 61966-2-1 formulas evaluated in double by hand. */
    struct { float srgb, linear; } cases[] = {
        {0.0f, 0.0f},
        {1.0f, 1.0f},
        {0.5f, 0.214041140482232f},
        {0.735356983052449f, 0.5f},
        {0.461356129500442f, 0.18f},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        float lin = srgb_to_linear(cases[i].srgb);
        float enc = linear_to_srgb(cases[i].linear);
        if (fabsf(lin - cases[i].linear) > FLT_EPSILON * fabsf(cases[i].linear) ||
            fabsf(enc - cases[i].srgb) > FLT_EPSILON * fabsf(cases[i].srgb))
            fail_msg("case %zu: srgb %.9g -> %.9g (want %.9g), linear %.9g -> %.9g (want %.9g)",
                     i, cases[i].srgb, lin, cases[i].linear, cases[i].linear, enc,
                     cases[i].srgb);
    }
    /* The knees belong to the straight parts. The standard's two pieces do not quite meet
     * (0.04045 / 12.92 is above 0.0031308), so the knee values are not each other's
     * images and are checked one way only. */
    assert_true(srgb_to_linear(0.04045f) == (float)(0.04045f / 12.92));
    assert_true(linear_to_srgb(0.0031308f) == (float)(0.0031308f * 12.92));
    /* Below the knees the curves are straight lines through 0. */
    assert_true(srgb_to_linear(0.02f) == (float)(0.02f / 12.92));
    assert_true(linear_to_srgb(0.001f) == (float)(0.001f * 12.92));
}

static void test_srgb_inverse(void **state)
{
    (void)state;
    /* Each direction rounds once to float and neither amplifies relative error (the log
     * slope of both curves is at most 1), so the round trip is within 2 ulp-ish. */
    for (int i = 0; i <= 10000; i++) {
        float v = (float)i / 10000.0f;
        float back = linear_to_srgb(srgb_to_linear(v));
        assert_true(fabsf(back - v) <= 2.0f * FLT_EPSILON * v);
        float back2 = srgb_to_linear(linear_to_srgb(v));
        assert_true(fabsf(back2 - v) <= 4.0f * FLT_EPSILON * v);
    }
    /* Every 8-bit code survives decode then encode. */
    for (int k = 0; k < 256; k++) {
        float s = linear_to_srgb(srgb_to_linear((float)k / 255.0f));
        assert_int_equal((int)lrintf(s * 255.0f), k);
    }
}

/* ---------------------------------------------------------------------------------------
 * EXR
 */

/* Width and height not multiples of the 16-line ZIP chunk, so the last chunk is partial;
 * values signed, tiny and huge; each channel different so a swap would show. */
static void exr_round_trip_float(const fixture *f, int channels)
{
    image img, back = {0};
    assert_int_equal(image_alloc(&img, 37, 23, channels), 0);
    fill_random(&img, 7u + (uint32_t)channels, -2.0f, 3.0f);
    img.pixels[0] = 1e-30f;
    img.pixels[1 % channels] = -6.5e20f;
    char path[256], err[512];
    path_in(f, "float.exr", path, sizeof path);
    assert_int_equal(image_write_exr(path, &img, IMAGE_EXR_FLOAT, err, sizeof err), 0);
    if (image_read(path, &back, err, sizeof err) != 0)
        fail_msg("%s", err);
    assert_int_equal(back.width, 37);
    assert_int_equal(back.height, 23);
    assert_int_equal(back.channels, channels);
    assert_memory_equal(back.pixels, img.pixels, sizeof(float) * 37 * 23 * channels);
    image_free(&back);
    image_free(&img);
}

static void test_exr_float_round_trip(void **state)
{
    exr_round_trip_float(*state, 1);
    exr_round_trip_float(*state, 3);
    exr_round_trip_float(*state, 4);
}

/* Round to half precision (11 significant bits, ties to even) for values in half's normal
 * range; an independent statement of what the file must hold. */
static float to_half_precision(float v)
{
    if (v == 0.0f)
        return v;
    int e;
    double m = frexp((double)v, &e); /* v = m * 2^e, 0.5 <= |m| < 1 */
    return (float)ldexp(nearbyint(ldexp(m, 11)), e - 11);
}

static void test_exr_half_round_trip(void **state)
{
    const fixture *f = *state;
    for (int channels = 1; channels <= 4; channels += (channels == 1 ? 2 : 1)) {
        image img, back = {0};
        assert_int_equal(image_alloc(&img, 41, 19, channels), 0);
        fill_random(&img, 99u + (uint32_t)channels, -100.0f, 100.0f);
        /* keep values in half's normal range, away from its subnormals */
        for (size_t i = 0; i < (size_t)41 * 19 * channels; i++)
            if (fabsf(img.pixels[i]) < 1e-3f)
                img.pixels[i] = 1e-3f;
        img.pixels[0] = 0.1f; /* not representable in half: proves the file holds halves */
        char path[256], err[512];
        path_in(f, "half.exr", path, sizeof path);
        assert_int_equal(image_write_exr(path, &img, IMAGE_EXR_HALF, err, sizeof err), 0);
        if (image_read(path, &back, err, sizeof err) != 0)
            fail_msg("%s", err);
        assert_int_equal(back.channels, channels);
        assert_true(back.pixels[0] == 0.0999755859375f);
        for (size_t i = 0; i < (size_t)41 * 19 * channels; i++)
            if (back.pixels[i] != to_half_precision(img.pixels[i]))
                fail_msg("value %zu: wrote %.9g, read %.9g, half is %.9g", i, img.pixels[i],
                         back.pixels[i], to_half_precision(img.pixels[i]));
        image_free(&back);
        image_free(&img);
    }
}

static void test_exr_metadata(void **state)
{
    const fixture *f = *state;
    image img, back = {0};
    assert_int_equal(image_alloc(&img, 8, 8, 3), 0);
    fill_random(&img, 5, 0.0f, 1.0f);
    const char *json = "{\"params\": [0.25, 0.5, 1.0], \"seed\": 12}";
    const char *const meta[] = {"imsynth:params", json, "imsynth:note", "", NULL};
    char path[256], err[512], value[256];
    path_in(f, "meta.exr", path, sizeof path);
    assert_int_equal(image_write_exr_meta(path, &img, IMAGE_EXR_FLOAT, meta, err, sizeof err),
                     0);
    assert_int_equal(image_exr_get_string(path, "imsynth:params", value, sizeof value, err,
                                          sizeof err), 0);
    assert_string_equal(value, json);
    assert_int_equal(image_exr_get_string(path, "imsynth:note", value, sizeof value, err,
                                          sizeof err), 0);
    assert_string_equal(value, "");
    assert_int_equal(image_exr_get_string(path, "imsynth:absent", NULL, 0, err, sizeof err), 1);
    /* too small a buffer is an error, not a truncated value */
    assert_int_equal(image_exr_get_string(path, "imsynth:params", value, 8, err, sizeof err),
                     -1);
    assert_non_null(strstr(err, path));
    if (image_read(path, &back, err, sizeof err) != 0)
        fail_msg("%s", err);
    assert_memory_equal(back.pixels, img.pixels, sizeof(float) * 64 * 3);
    image_free(&back);
    image_free(&img);
}

/* ---------------------------------------------------------------------------------------
 * PNG
 */

static void test_png_round_trip(void **state)
{
    const fixture *f = *state;
    for (int channels = 1; channels <= 4; channels += (channels == 1 ? 2 : 1)) {
        image img, back = {0};
        assert_int_equal(image_alloc(&img, 29, 17, channels), 0);
        fill_random(&img, 3u + (uint32_t)channels, 0.0f, 1.0f);
        img.pixels[0] = -0.5f; /* clamped to 0 */
        img.pixels[channels] = 7.0f; /* clamped to 1 */
        img.pixels[2 * channels] = NAN; /* written as 0 */
        char path[256], err[512];
        path_in(f, "rt.png", path, sizeof path);
        if (image_write_png(path, &img, err, sizeof err) != 0)
            fail_msg("%s", err);
        if (image_read(path, &back, err, sizeof err) != 0)
            fail_msg("%s", err);
        assert_int_equal(back.width, 29);
        assert_int_equal(back.height, 17);
        assert_int_equal(back.channels, channels);
        for (size_t i = 0; i < (size_t)29 * 17 * channels; i++) {
            float v = img.pixels[i];
            v = isnan(v) ? 0.0f : v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
            int is_alpha = channels == 4 && i % 4 == 3;
            /* quantisation happens in the encoded space: at most half a step there */
            float enc_in = is_alpha ? v : linear_to_srgb(v);
            float enc_back = is_alpha ? back.pixels[i] : linear_to_srgb(back.pixels[i]);
            if (fabsf(enc_back - enc_in) > 0.5f / 255.0f + 1e-6f)
                fail_msg("value %zu: wrote %.7g, read %.7g", i, img.pixels[i], back.pixels[i]);
            /* and the value read is exactly a decoded 8-bit code */
            int code = (int)lrintf(enc_back * 255.0f);
            float expect = is_alpha ? (float)code / 255.0f : srgb_to_linear((float)code / 255.0f);
            assert_true(back.pixels[i] == expect);
        }
        assert_true(back.pixels[0] == 0.0f);
        assert_true(back.pixels[channels] == 1.0f);
        assert_true(back.pixels[2 * channels] == 0.0f);
        image_free(&back);
        image_free(&img);
    }
}

/* A PNG is known by its signature, not its name: the same bytes under a name without .png,
 * or a wrong one, read to the same pixels (the in-memory decoding is told the format). The
 * file changing while it is read: test_imageio_race.c. */
static void test_png_whatever_its_name(void **state)
{
    const fixture *f = *state;
    image img, ref = {0};
    assert_int_equal(image_alloc(&img, 23, 11, 3), 0);
    fill_random(&img, 5, 0.0f, 1.0f);
    char path[256], err[512];
    path_in(f, "named.png", path, sizeof path);
    assert_int_equal(image_write_png(path, &img, err, sizeof err), 0);
    if (image_read(path, &ref, err, sizeof err) != 0)
        fail_msg("%s", err);
    size_t n = file_size(path);
    unsigned char *bytes = malloc(n);
    assert_non_null(bytes);
    FILE *fp = fopen(path, "rb");
    assert_non_null(fp);
    assert_int_equal(fread(bytes, 1, n, fp), n);
    fclose(fp);
    const char *names[] = {"no_extension", "mislabelled.exr", "mislabelled.jpg"};
    for (size_t k = 0; k < sizeof names / sizeof names[0]; k++) {
        image back = {0};
        path_in(f, names[k], path, sizeof path);
        write_bytes(path, bytes, n);
        if (image_read(path, &back, err, sizeof err) != 0)
            fail_msg("%s: %s", names[k], err);
        assert_int_equal(back.width, ref.width);
        assert_int_equal(back.height, ref.height);
        assert_int_equal(back.channels, ref.channels);
        assert_memory_equal(back.pixels, ref.pixels,
                            sizeof(float) * 23 * 11 * (size_t)ref.channels);
        image_free(&back);
    }
    free(bytes);
    image_free(&ref);
    image_free(&img);
}

/* A PNG saying gAMA 1.0 is linear: its bytes are divided by 255, not sRGB-decoded; the
 * same bytes without gAMA are decoded. */
static void test_png_linear_metadata(void **state)
{
    const fixture *f = *state;
    uint8_t px[4 * 2 * 3], buf[512];
    for (int i = 0; i < (int)sizeof px; i++)
        px[i] = (uint8_t)(i * 11);
    char path[256], err[512];
    image img = {0};
    for (int gamma_1 = 0; gamma_1 <= 1; gamma_1++) {
        path_in(f, gamma_1 ? "linear.png" : "srgb.png", path, sizeof path);
        write_bytes(path, buf, make_png(buf, 4, 2, 2, gamma_1, px));
        if (image_read(path, &img, err, sizeof err) != 0)
            fail_msg("%s", err);
        assert_int_equal(img.channels, 3);
        for (int i = 0; i < (int)sizeof px; i++) {
            float k = (float)px[i] / 255.0f;
            assert_true(img.pixels[i] == (gamma_1 ? k : srgb_to_linear(k)));
        }
        image_free(&img);
    }
}

/* 16-bit files take the float path: scaled to [0,1] by OIIO, then decoded. One ulp of
 * scaling error grows by at most the decode curve's log slope (2.4), plus its own
 * rounding: 4 ulp covers it. */
static void test_png_16bit(void **state)
{
    const fixture *f = *state;
    uint8_t px[5 * 3 * 2], buf[512];
    const int codes[15] = {0, 1, 2, 100, 2651, 2652, 9000, 30000, 32768, 40000, 50000, 60000,
                           65000, 65534, 65535};
    for (int i = 0; i < 15; i++) {
        px[2 * i] = (uint8_t)(codes[i] >> 8);
        px[2 * i + 1] = (uint8_t)codes[i];
    }
    char path[256], err[512];
    path_in(f, "deep16.png", path, sizeof path);
    write_bytes(path, buf, make_png_full(buf, 5, 1, 2, 16, 0, 0, px));
    image img = {0};
    if (image_read(path, &img, err, sizeof err) != 0)
        fail_msg("%s", err);
    assert_int_equal(img.channels, 3);
    for (int i = 0; i < 15; i++) {
        float expect = (float)srgb_to_linear((float)((double)codes[i] / 65535.0));
        if (fabsf(img.pixels[i] - expect) > 4.0f * FLT_EPSILON * expect)
            fail_msg("code %d: read %.9g, want %.9g", codes[i], img.pixels[i], expect);
    }
    image_free(&img);
}

/* Radiance HDR is float data: linear as stored, RGBE decoded as mantissa * 2^(e - 136).
 * Width 4 (< 8) makes the scanlines flat, not run-length encoded. */
static void test_hdr_is_linear(void **state)
{
    const fixture *f = *state;
    const char header[] = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 4\n";
    const uint8_t rgbe[16] = {128, 64, 32, 129, 200, 10, 1, 120, 255, 255, 255, 140,
                              0, 0, 0, 0};
    uint8_t buf[128];
    memcpy(buf, header, sizeof header - 1);
    memcpy(buf + sizeof header - 1, rgbe, sizeof rgbe);
    char path[256], err[512];
    path_in(f, "flat.hdr", path, sizeof path);
    write_bytes(path, buf, sizeof header - 1 + sizeof rgbe);
    image img = {0};
    if (image_read(path, &img, err, sizeof err) != 0)
        fail_msg("%s", err);
    assert_int_equal(img.width, 4);
    assert_int_equal(img.channels, 3);
    for (int p = 0; p < 4; p++)
        for (int c = 0; c < 3; c++) {
            float expect = rgbe[4 * p + 3] ? ldexpf((float)rgbe[4 * p + c], rgbe[4 * p + 3] - 136)
                                           : 0.0f;
            if (img.pixels[3 * p + c] != expect)
                fail_msg("pixel %d channel %d: read %.9g, want %.9g", p, c,
                         img.pixels[3 * p + c], expect);
        }
    image_free(&img);
}

/* EXIF orientation, checked against the standard's wording: for each value, the visual
 * sides of the stored row 0 and column 0. Corners: 0 top-left, 1 top-right, 2 bottom-left,
 * 3 bottom-right of the displayed image. */
static void test_exif_orientation(void **state)
{
    const fixture *f = *state;
    enum { TL, TR, BL, BR };
    /* where stored (0, 0) and stored (W-1, 0) are displayed */
    const int corners[9][2] = {
        {0, 0},
        {TL, TR}, /* 1: row 0 top, column 0 left */
        {TR, TL}, /* 2: row 0 top, column 0 right */
        {BR, BL}, /* 3: row 0 bottom, column 0 right */
        {BL, BR}, /* 4: row 0 bottom, column 0 left */
        {TL, BL}, /* 5: row 0 left, column 0 top */
        {TR, BR}, /* 6: row 0 right, column 0 top */
        {BR, TR}, /* 7: row 0 right, column 0 bottom */
        {BL, TL}, /* 8: row 0 left, column 0 bottom */
    };
    const int w = 3, h = 2;
    uint8_t px[3 * 2 * 3], buf[512];
    for (int i = 0; i < (int)sizeof px; i++)
        px[i] = (uint8_t)(10 + 13 * i);
    char path[256], err[512];
    for (int o = 1; o <= 8; o++) {
        path_in(f, "oriented.png", path, sizeof path);
        write_bytes(path, buf, make_png_full(buf, (uint32_t)w, (uint32_t)h, 2, 8, 0, o, px));
        image img = {0};
        if (image_read(path, &img, err, sizeof err) != 0)
            fail_msg("%s", err);
        int dw = o >= 5 ? h : w, dh = o >= 5 ? w : h;
        assert_int_equal(img.width, dw);
        assert_int_equal(img.height, dh);
        const int stored[2] = {0, w - 1}; /* x of the two stored pixels, both in row 0 */
        for (int k = 0; k < 2; k++) {
            int corner = corners[o][k];
            int dx = (corner == TR || corner == BR) ? dw - 1 : 0;
            int dy = (corner == BL || corner == BR) ? dh - 1 : 0;
            for (int c = 0; c < 3; c++) {
                float expect = srgb_to_linear((float)px[3 * stored[k] + c] / 255.0f);
                if (img.pixels[3 * (dy * dw + dx) + c] != expect)
                    fail_msg("orientation %d: stored (%d, 0) not at displayed (%d, %d)", o,
                             stored[k], dx, dy);
            }
        }
        image_free(&img);
    }
}

/* Grey + alpha becomes RGBA with grey decoded in R, G, B and alpha as stored. */
static void test_grey_alpha_becomes_rgba(void **state)
{
    const fixture *f = *state;
    uint8_t px[3 * 2 * 2], buf[512];
    for (int i = 0; i < (int)sizeof px; i++)
        px[i] = (uint8_t)(20 + i * 17);
    char path[256], err[512];
    path_in(f, "ya.png", path, sizeof path);
    write_bytes(path, buf, make_png(buf, 3, 2, 4, 0, px));
    image img = {0};
    if (image_read(path, &img, err, sizeof err) != 0)
        fail_msg("%s", err);
    assert_int_equal(img.channels, 4);
    for (int p = 0; p < 6; p++) {
        float grey = srgb_to_linear((float)px[2 * p] / 255.0f);
        assert_true(img.pixels[4 * p + 0] == grey);
        assert_true(img.pixels[4 * p + 1] == grey);
        assert_true(img.pixels[4 * p + 2] == grey);
        assert_true(img.pixels[4 * p + 3] == (float)px[2 * p + 1] / 255.0f);
    }
    image_free(&img);

    /* and plain grey stays one channel */
    path_in(f, "y.png", path, sizeof path);
    write_bytes(path, buf, make_png(buf, 3, 2, 0, 0, px));
    if (image_read(path, &img, err, sizeof err) != 0)
        fail_msg("%s", err);
    assert_int_equal(img.channels, 1);
    assert_true(img.pixels[5] == srgb_to_linear((float)px[5] / 255.0f));
    image_free(&img);
}

/* ---------------------------------------------------------------------------------------
 * Resize
 */

static double mean_of(const image *img, int channel)
{
    double sum = 0.0;
    size_t n = (size_t)img->width * img->height;
    for (size_t p = 0; p < n; p++)
        sum += img->pixels[p * img->channels + channel];
    return sum / (double)n;
}

static void test_resize_constant(void **state)
{
    (void)state;
    const int sizes[][2] = {{37, 23}, {250, 150}, {100, 60}, {1, 1}, {3, 200}};
    image src, dst;
    assert_int_equal(image_alloc(&src, 100, 60, 3), 0);
    for (size_t p = 0; p < 100 * 60; p++) {
        src.pixels[3 * p + 0] = 0.25f;
        src.pixels[3 * p + 1] = 0.6f;
        src.pixels[3 * p + 2] = 3.0f;
    }
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        assert_int_equal(image_resize(&src, sizes[s][0], sizes[s][1], &dst), 0);
        assert_int_equal(dst.width, sizes[s][0]);
        assert_int_equal(dst.height, sizes[s][1]);
        for (size_t i = 0; i < (size_t)dst.width * dst.height * 3; i++) {
            /* weights sum to 1 up to a few float roundings per pass */
            float expect = src.pixels[i % 3];
            assert_true(fabsf(dst.pixels[i] - expect) <= 8.0f * FLT_EPSILON * expect);
        }
        image_free(&dst);
    }
    image_free(&src);
    assert_int_equal(image_resize(&src, 4, 4, &dst), -1); /* empty source */
}

/* A symmetric filter reproduces a linear function at each output centre, and output centres
 * average to the source's centre, so the mean of a gradient is kept (edge renormalisation
 * biases the two ends oppositely and cancels). */
static void test_resize_gradient_mean(void **state)
{
    (void)state;
    const int from[][2] = {{100, 60}, {37, 23}, {64, 64}};
    const int to[][2] = {{37, 23}, {100, 61}, {17, 90}};
    for (int k = 0; k < 3; k++) {
        image src, dst;
        assert_int_equal(image_alloc(&src, from[k][0], from[k][1], 1), 0);
        for (int y = 0; y < src.height; y++)
            for (int x = 0; x < src.width; x++)
                src.pixels[y * src.width + x] = 0.1f + 0.03f * x + 0.011f * y;
        assert_int_equal(image_resize(&src, to[k][0], to[k][1], &dst), 0);
        double a = mean_of(&src, 0), b = mean_of(&dst, 0);
        if (fabs(a - b) > 1e-5 * a)
            fail_msg("%dx%d -> %dx%d: mean %.9g became %.9g", from[k][0], from[k][1], to[k][0],
                     to[k][1], a, b);
        image_free(&dst);
        image_free(&src);
    }
}

/* Shrinking averages: 1-pixel stripes halved become flat grey (point sampling or bilinear
 * with a fixed 2-tap support would give stripes or 0/1 values). Enlarging is bilinear. */
static void test_resize_filter_shape(void **state)
{
    (void)state;
    image src, dst;
    assert_int_equal(image_alloc(&src, 64, 4, 1), 0);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 64; x++)
            src.pixels[y * 64 + x] = (float)(x & 1);
    assert_int_equal(image_resize(&src, 32, 4, &dst), 0);
    /* Interior only: an edge pixel's filter sees the stripes on one side alone. */
    for (int y = 0; y < 4; y++)
        for (int x = 1; x < 31; x++)
            assert_true(fabsf(dst.pixels[y * 32 + x] - 0.5f) <= 1e-6f);
    image_free(&dst);
    image_free(&src);

    assert_int_equal(image_alloc(&src, 2, 1, 1), 0);
    src.pixels[1] = 1.0f;
    assert_int_equal(image_resize(&src, 4, 1, &dst), 0);
    const float expect[4] = {0.0f, 0.25f, 0.75f, 1.0f};
    for (int i = 0; i < 4; i++)
        assert_true(fabsf(dst.pixels[i] - expect[i]) <= 1e-7f);
    image_free(&dst);
    image_free(&src);
}

/* ---------------------------------------------------------------------------------------
 * Bad input
 */

static void test_truncated_files(void **state)
{
    const fixture *f = *state;
    image img;
    assert_int_equal(image_alloc(&img, 64, 64, 3), 0);
    fill_random(&img, 11, 0.0f, 1.0f); /* noise: compresses badly, so data dominates */
    char path[256], err[512];

    path_in(f, "cut.png", path, sizeof path);
    assert_int_equal(image_write_png(path, &img, err, sizeof err), 0);
    truncate_half(path);
    expect_read_error(path);

    for (int half = 0; half <= 1; half++) {
        path_in(f, half ? "cut_half.exr" : "cut_float.exr", path, sizeof path);
        assert_int_equal(image_write_exr(path, &img, half ? IMAGE_EXR_HALF : IMAGE_EXR_FLOAT,
                                         err, sizeof err),
                         0);
        truncate_half(path);
        expect_read_error(path);
    }

    /* Complete but corrupt: one byte changed inside the PNG's image data. */
    path_in(f, "corrupt.png", path, sizeof path);
    assert_int_equal(image_write_png(path, &img, err, sizeof err), 0);
    FILE *fp = fopen(path, "r+b");
    assert_non_null(fp);
    assert_int_equal(fseek(fp, (long)(file_size(path) / 2), SEEK_SET), 0);
    int byte = fgetc(fp);
    assert_int_equal(fseek(fp, -1, SEEK_CUR), 0);
    fputc(byte ^ 0x5a, fp);
    assert_int_equal(fclose(fp), 0);
    expect_read_error(path);
    image_free(&img);

    /* The JPEG reads whole, so it is the cut that fails. */
    path_in(f, "whole.jpg", path, sizeof path);
    write_bytes(path, small_jpeg, sizeof small_jpeg);
    if (image_read(path, &img, err, sizeof err) != 0)
        fail_msg("%s", err);
    assert_int_equal(img.width, 32);
    assert_int_equal(img.channels, 3);
    image_free(&img);
    path_in(f, "cut.jpg", path, sizeof path);
    write_bytes(path, small_jpeg, sizeof small_jpeg / 2);
    expect_read_error(path);
    /* cut inside the header too */
    path_in(f, "cut_header.jpg", path, sizeof path);
    write_bytes(path, small_jpeg, 100);
    expect_read_error(path);
}

/* An EXR header attribute claiming more bytes than the file has (found by fuzz_image: the
 * system OpenEXR allocated and filled the claimed 2 GB string) is refused before OpenEXR
 * reads it, for a single-part and a multi-part file; a real EXR's header still passes. */
static void test_exr_lying_attribute(void **state)
{
    const fixture *f = *state;
    char path[256], err[512];
    /* magic, version 2 (flags in byte 5: 0x10 multi-part), then name\0 type\0 size value */
    static const unsigned char lie[] = {0x76, 0x2f, 0x31, 0x01, 0x02, 0x00, 0x00, 0x00,
                                        'N', 'o', 't', 'e', 0, 's', 't', 'r', 'i', 'n', 'g', 0,
                                        0x00, 0x00, 0x00, 0x70, 'x', 'y', 0};
    for (int multipart = 0; multipart <= 1; multipart++) {
        unsigned char bytes[sizeof lie];
        memcpy(bytes, lie, sizeof lie);
        bytes[5] = multipart ? 0x10 : 0x00;
        path_in(f, multipart ? "lie_multipart.exr" : "lie.exr", path, sizeof path);
        write_bytes(path, bytes, sizeof bytes);
        image img = {0};
        assert_int_equal(image_read(path, &img, err, sizeof err), -1);
        if (!strstr(err, "claims"))
            fail_msg("expected the attribute's claim in \"%s\"", err);
    }
    /* A channel list declaring fewer bytes than its channels take: OpenEXR reads it to its
     * end anyway, so a walk by declared sizes would go out of step with it. */
    static const unsigned char chlist[] = {0x76, 0x2f, 0x31, 0x01, 0x02, 0x00, 0x00, 0x00,
                                           'c', 'h', 'a', 'n', 'n', 'e', 'l', 's', 0,
                                           'c', 'h', 'l', 'i', 's', 't', 0, 10, 0, 0, 0,
                                           'R', 0, 1, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0,
                                           0, 0, 0, 0};
    path_in(f, "lie_chlist.exr", path, sizeof path);
    write_bytes(path, chlist, sizeof chlist);
    image bad = {0};
    assert_int_equal(image_read(path, &bad, err, sizeof err), -1);
    if (!strstr(err, "does not fill"))
        fail_msg("expected the channel list's size in \"%s\"", err);
    image img;
    assert_int_equal(image_alloc(&img, 4, 3, 4), 0);
    path_in(f, "true.exr", path, sizeof path);
    assert_int_equal(image_write_exr(path, &img, IMAGE_EXR_HALF, err, sizeof err), 0);
    image_free(&img);
    if (image_read(path, &img, err, sizeof err) != 0)
        fail_msg("%s", err);
    image_free(&img);
}

static void test_not_images(void **state)
{
    const fixture *f = *state;
    char path[256];
    const char text[] = "this is not an image\n";
    path_in(f, "text.png", path, sizeof path);
    write_bytes(path, text, sizeof text - 1);
    expect_read_error(path);
    path_in(f, "text.dat", path, sizeof path);
    write_bytes(path, text, sizeof text - 1);
    expect_read_error(path);
    path_in(f, "empty.exr", path, sizeof path);
    write_bytes(path, "", 0);
    expect_read_error(path);
    path_in(f, "missing.png", path, sizeof path);
    expect_read_error(path);
    path_in(f, "folder.png", path, sizeof path);
    assert_int_equal(mkdir(path, 0777), 0);
    expect_read_error(path);
    /* a valid PNG header claiming 100000 x 2 pixels is refused before any allocation */
    uint8_t buf[256];
    path_in(f, "huge.png", path, sizeof path);
    write_bytes(path, buf, make_png(buf, 100000, 2, 2, 0, NULL));
    expect_read_error(path);
    image img;
    char err[512];
    assert_int_equal(image_read(path, &img, err, sizeof err), -1);
    assert_non_null(strstr(err, "32768"));
    /* each side acceptable, 4e8 pixels in all is not */
    path_in(f, "big.png", path, sizeof path);
    write_bytes(path, buf, make_png(buf, 20000, 20000, 0, 0, NULL));
    expect_read_error(path);
    assert_int_equal(image_read(path, &img, err, sizeof err), -1);
    assert_non_null(strstr(err, "pixels accepted"));
}

/* Failed writes: nothing at the target, no temporary file left anywhere. */
static void test_failed_writes_leave_nothing(void **state)
{
    const fixture *f = *state;
    image img;
    assert_int_equal(image_alloc(&img, 8, 8, 3), 0);
    char path[256], err[512];

    path_in(f, "no_such_dir/out.exr", path, sizeof path);
    assert_int_equal(image_write_exr(path, &img, IMAGE_EXR_HALF, err, sizeof err), -1);
    assert_non_null(strstr(err, path));
    path_in(f, "no_such_dir/out.png", path, sizeof path);
    assert_int_equal(image_write_png(path, &img, err, sizeof err), -1);
    assert_non_null(strstr(err, path));
    assert_int_equal(count_temp_files(f->dir), 0);

    /* target is a folder: the temporary file is written, the rename fails, it must go */
    path_in(f, "a_folder", path, sizeof path);
    assert_int_equal(mkdir(path, 0777), 0);
    assert_int_equal(image_write_exr(path, &img, IMAGE_EXR_FLOAT, err, sizeof err), -1);
    assert_non_null(strstr(err, path));
    assert_int_equal(image_write_png(path, &img, err, sizeof err), -1);
    assert_non_null(strstr(err, path));
    assert_int_equal(count_temp_files(f->dir), 0);

    /* not a writable image */
    path_in(f, "two.exr", path, sizeof path);
    image bad = img;
    bad.channels = 2;
    assert_int_equal(image_write_exr(path, &bad, IMAGE_EXR_FLOAT, err, sizeof err), -1);
    assert_int_equal(access(path, F_OK), -1);

    /* a metadata name without a value: refused after the temporary file exists */
    const char *const odd[] = {"imsynth:params", NULL};
    path_in(f, "odd.exr", path, sizeof path);
    assert_int_equal(image_write_exr_meta(path, &img, IMAGE_EXR_FLOAT, odd, err, sizeof err),
                     -1);
    assert_non_null(strstr(err, path));
    assert_int_equal(access(path, F_OK), -1);
    assert_int_equal(count_temp_files(f->dir), 0);
    image_free(&img);
}

/* Writing over an existing file replaces it. */
static void test_overwrite(void **state)
{
    const fixture *f = *state;
    image a, b, back;
    assert_int_equal(image_alloc(&a, 4, 4, 1), 0);
    assert_int_equal(image_alloc(&b, 6, 5, 3), 0);
    fill_random(&b, 1, 0.0f, 1.0f);
    char path[256], err[512];
    path_in(f, "over.exr", path, sizeof path);
    assert_int_equal(image_write_exr(path, &a, IMAGE_EXR_FLOAT, err, sizeof err), 0);
    assert_int_equal(image_write_exr(path, &b, IMAGE_EXR_FLOAT, err, sizeof err), 0);
    assert_int_equal(image_read(path, &back, err, sizeof err), 0);
    assert_int_equal(back.width, 6);
    assert_int_equal(back.channels, 3);
    assert_memory_equal(back.pixels, b.pixels, sizeof(float) * 6 * 5 * 3);
    image_free(&back);
    image_free(&a);
    image_free(&b);
    assert_int_equal(count_temp_files(f->dir), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_srgb_known_values),
        cmocka_unit_test(test_srgb_inverse),
        cmocka_unit_test(test_exr_float_round_trip),
        cmocka_unit_test(test_exr_half_round_trip),
        cmocka_unit_test(test_exr_metadata),
        cmocka_unit_test(test_png_round_trip),
        cmocka_unit_test(test_png_whatever_its_name),
        cmocka_unit_test(test_png_linear_metadata),
        cmocka_unit_test(test_grey_alpha_becomes_rgba),
        cmocka_unit_test(test_png_16bit),
        cmocka_unit_test(test_exif_orientation),
        cmocka_unit_test(test_hdr_is_linear),
        cmocka_unit_test(test_resize_constant),
        cmocka_unit_test(test_resize_gradient_mean),
        cmocka_unit_test(test_resize_filter_shape),
        cmocka_unit_test(test_truncated_files),
        cmocka_unit_test(test_exr_lying_attribute),
        cmocka_unit_test(test_not_images),
        cmocka_unit_test(test_failed_writes_leave_nothing),
        cmocka_unit_test(test_overwrite),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
