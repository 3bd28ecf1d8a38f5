/*
 * image_read decodes the bytes it checked. A PNG truncated after imageio's completeness
 * check but before OpenImageIO decodes it (a download or copy still being written) once
 * reached OIIO 2.4's short-read path, which longjmps through libpng past a std::string and
 * leaks it (found by tests/cli/faults.sh under AddressSanitizer, by chance of timing). The
 * file is now read once and decoded from that copy.
 *
 * Made deterministic here: this test is linked with -Wl,--wrap=fclose (tests/CMakeLists.txt),
 * so imageio's fclose calls come through __wrap_fclose, which truncates the file right after
 * imageio closes its first handle on it, i.e. after the check and before the decoding. The
 * one piece of mutable state this needs is file-scope and armed per call.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <unistd.h>

#include "imageio/imageio.h"

int __real_fclose(FILE *fp);
int __wrap_fclose(FILE *fp);

/* Armed: the path to cut and the length to cut it to, once, at the next fclose. */
static struct {
    char path[256];
    long length; /* -1: disarmed */
} cut = {"", -1};

int __wrap_fclose(FILE *fp)
{
    int rc = __real_fclose(fp);
    if (cut.length >= 0) {
        long length = cut.length;
        cut.length = -1;
        if (truncate(cut.path, length) != 0)
            fail_msg("truncate %s: failed", cut.path);
    }
    return rc;
}

static long file_length(const char *path)
{
    FILE *fp = fopen(path, "rb");
    assert_non_null(fp);
    assert_int_equal(fseek(fp, 0, SEEK_END), 0);
    long n = ftell(fp);
    fclose(fp);
    return n;
}

static void test_png_cut_while_read(void **state)
{
    (void)state;
    char dir[] = "/tmp/test_imageio_race.XXXXXX";
    assert_non_null(mkdtemp(dir));
    snprintf(cut.path, sizeof cut.path, "%s/cut.png", dir);

    /* Noise compresses badly, so most of the file is image data. */
    image img, ref = {0}, back = {0};
    assert_int_equal(image_alloc(&img, 64, 64, 3), 0);
    uint32_t s = 7;
    for (size_t i = 0; i < (size_t)64 * 64 * 3; i++) {
        s = s * 1664525u + 1013904223u;
        img.pixels[i] = (float)(s >> 8) / 16777216.0f;
    }
    char err[512];
    assert_int_equal(image_write_png(cut.path, &img, err, sizeof err), 0);
    if (image_read(cut.path, &ref, err, sizeof err) != 0)
        fail_msg("%s", err);
    long whole = file_length(cut.path);

    cut.length = whole / 2;
    if (image_read(cut.path, &back, err, sizeof err) != 0)
        fail_msg("the file cut after its check failed to decode: %s", err);
    assert_int_equal(cut.length, -1); /* the cut happened, inside image_read */
    assert_int_equal(file_length(cut.path), whole / 2);
    assert_int_equal(back.width, 64);
    assert_int_equal(back.channels, ref.channels);
    assert_memory_equal(back.pixels, ref.pixels, sizeof(float) * 64 * 64 * (size_t)ref.channels);
    image_free(&back);

    /* Cut before the read, the same file is refused, naming itself. */
    assert_int_equal(image_read(cut.path, &back, err, sizeof err), -1);
    if (!strstr(err, cut.path) || !strstr(err, "truncated PNG"))
        fail_msg("expected the path and 'truncated PNG' in \"%s\"", err);

    image_free(&ref);
    image_free(&img);
    unlink(cut.path);
    rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_png_cut_while_read),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
