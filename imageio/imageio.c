/*
 * imageio: everything but the OpenImageIO calls (those are in oiio_shim.cpp).
 *
 * Invariants kept by every function here:
 *  - an image handed out has 1, 3 or 4 channels and width, height in [1, IMAGE_MAX_SIDE];
 *  - a writer either renames a complete temporary file onto the target or removes it:
 *    the target is never seen half-written and no temporary file outlives the call;
 *  - every failure message starts with the path it is about.
 */
#include "imageio/imageio.h"
#include "imageio/oiio_shim.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <openexr.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static void set_error(char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

static void set_error(char *err, size_t errlen, const char *fmt, ...)
{
    if (!err || errlen == 0)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
}

/* ---------------------------------------------------------------------------------------
 * Allocation
 */

int image_alloc(image *img, int width, int height, int channels)
{
    memset(img, 0, sizeof *img);
    if (width < 1 || height < 1 || channels < 1 || channels > 4)
        return -1;
    size_t n = (size_t)width * (size_t)height;
    if (n > SIZE_MAX / sizeof(float) / (size_t)channels)
        return -1;
    img->pixels = calloc(n * (size_t)channels, sizeof(float));
    if (!img->pixels)
        return -1;
    img->width = width;
    img->height = height;
    img->channels = channels;
    return 0;
}

void image_free(image *img)
{
    if (!img)
        return;
    free(img->pixels);
    memset(img, 0, sizeof *img);
}

/* ---------------------------------------------------------------------------------------
 * sRGB transfer functions. Computed in double so that the float result is the correctly
 * rounded value of the standard's formula (a float powf can be off by an ulp or two, which
 * would make an 8-bit decode/encode round trip depend on the libm).
 */

float srgb_to_linear(float v)
{
    if (v <= 0.04045f)
        return (float)((double)v / 12.92);
    return (float)pow(((double)v + 0.055) / 1.055, 2.4);
}

float linear_to_srgb(float v)
{
    if (v <= 0.0031308f)
        return (float)((double)v * 12.92);
    return (float)(1.055 * pow((double)v, 1.0 / 2.4) - 0.055);
}

/* ---------------------------------------------------------------------------------------
 * Temporary files beside the target
 */

/* Create an empty file beside path, named .<base>.<pid>.<ns>.tmp, and write its name into
 * tmp. O_EXCL makes the name ours even if several processes or threads write into the same
 * folder; a clash (same nanosecond) just tries the next name. The file gets the target's
 * usual permissions (0666 less the umask), unlike mkstemp's 0600. */
static int create_temp_beside(const char *path, char *tmp, size_t tmplen, char *err,
                              size_t errlen)
{
    const char *slash = strrchr(path, '/');
    int dirlen = slash ? (int)(slash - path + 1) : 0;
    const char *base = slash ? slash + 1 : path;
    if (*base == '\0') {
        set_error(err, errlen, "%s: not a file name (ends in '/')", path);
        return -1;
    }
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    for (int attempt = 0; attempt < 100; attempt++) {
        int n = snprintf(tmp, tmplen, "%.*s.%s.%ld.%ld.tmp", dirlen, path, base, (long)getpid(),
                         (long)now.tv_nsec + attempt);
        if (n < 0 || (size_t)n >= tmplen) {
            set_error(err, errlen, "%s: path too long", path);
            return -1;
        }
        int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            close(fd);
            return 0;
        }
        if (errno != EEXIST) {
            set_error(err, errlen, "%s: cannot create a temporary file beside it: %s", path,
                      strerror(errno));
            return -1;
        }
    }
    set_error(err, errlen, "%s: cannot find a free temporary file name beside it", path);
    return -1;
}

/* Move a complete temporary file onto the target, or remove it. */
static int commit_temp(const char *tmp, const char *path, char *err, size_t errlen)
{
    if (rename(tmp, path) != 0) {
        set_error(err, errlen, "%s: cannot replace it with the written file: %s", path,
                  strerror(errno));
        unlink(tmp);
        return -1;
    }
    return 0;
}

static int check_writable_image(const char *path, const image *img, char *err, size_t errlen)
{
    if (!path) {
        set_error(err, errlen, "(null): no output path");
        return -1;
    }
    if (!img || !img->pixels || img->width < 1 || img->height < 1 ||
        (img->channels != 1 && img->channels != 3 && img->channels != 4)) {
        set_error(err, errlen, "%s: nothing to write (image is empty or has %d channels)", path,
                  img ? img->channels : 0);
        return -1;
    }
    return 0;
}

/* ---------------------------------------------------------------------------------------
 * Reading
 */

/* The limits protect against a corrupt or hostile header asking for gigabytes: 32768 on a
 * side, and 2^28 pixels (a 16384 x 16384 image, 4 GiB as RGBA floats) in all. */
#define IMAGE_MAX_SIDE 32768
#ifndef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
#define IMAGE_MAX_PIXELS ((size_t)1 << 28)
#else
/* Fuzz builds (tests/fuzz, IMSYNTH_FUZZ): a 60-byte file may claim 2^28 pixels, and under
 * AddressSanitizer the refused-later allocation costs 0.5 GiB of shadow memory, so one
 * such input fills the fuzzer's 2 GiB budget. The check is the same with a smaller bound. */
#define IMAGE_MAX_PIXELS ((size_t)1 << 22)
#endif

/* Reject what we cannot or will not read before touching the file with OIIO: a FIFO would
 * block forever, and missing files and folders get a plainer message than OIIO's. */
static int check_readable_file(const char *path, char *err, size_t errlen)
{
    struct stat st;
    if (stat(path, &st) != 0) {
        set_error(err, errlen, "%s: %s", path, strerror(errno));
        return -1;
    }
    if (S_ISDIR(st.st_mode)) {
        set_error(err, errlen, "%s: is a directory, not an image file", path);
        return -1;
    }
    if (!S_ISREG(st.st_mode)) {
        set_error(err, errlen, "%s: not a regular file", path);
        return -1;
    }
    if (st.st_size == 0) {
        set_error(err, errlen, "%s: empty file", path);
        return -1;
    }
    if (access(path, R_OK) != 0) {
        set_error(err, errlen, "%s: %s", path, strerror(errno));
        return -1;
    }
    return 0;
}

static uint32_t big_endian32(const unsigned char *b)
{
    return (uint32_t)b[0] << 24 | (uint32_t)b[1] << 16 | (uint32_t)b[2] << 8 | (uint32_t)b[3];
}

/* A PNG must run, chunk by chunk, to its IEND chunk. Checking this before OIIO decodes it
 * gives a precise message, and keeps truncated PNGs away from OIIO 2.4's reader, which on
 * a short read longjmps (through libpng) past one of its own std::strings and leaks it.
 * data[0, size) is the whole file as read. */
static int check_png_complete(const char *path, const unsigned char *data, size_t size,
                              char *err, size_t errlen)
{
    size_t at = 8, prev_at = 0;
    char prev_type[5] = "";
    for (;;) {
        if (size < 8 || at > size - 8) {
            if (prev_at > 0 && at > size)
                set_error(err, errlen, "%s: truncated PNG: the file (%zu bytes) ends inside "
                          "its '%s' chunk at byte %zu", path, size, prev_type, prev_at);
            else
                set_error(err, errlen, "%s: truncated PNG: the file (%zu bytes) ends before "
                          "its IEND chunk", path, size);
            return -1;
        }
        uint32_t length = big_endian32(data + at);
        if (length > 0x7fffffffu) {
            set_error(err, errlen, "%s: corrupt PNG: chunk at byte %zu has length %lu", path,
                      at, (unsigned long)length);
            return -1;
        }
        if (memcmp(data + at + 4, "IEND", 4) == 0)
            return 0;
        /* chunk types are 4 ASCII letters in a valid file; show others as '?' */
        for (int k = 0; k < 4; k++) {
            unsigned char c = data[at + 4 + k];
            prev_type[k] = c >= 32 && c < 127 ? (char)c : '?';
        }
        prev_at = at;
        at += 12 + (size_t)length; /* length, type, data, CRC */
    }
}

/* The largest PNG file read: more than any image within IMAGE_MAX_PIXELS can take (16-bit
 * RGBA, stored uncompressed, is 8 bytes a pixel), so a larger one is refused unread. */
#define PNG_MAX_FILE_BYTES (IMAGE_MAX_PIXELS * 8 + ((size_t)1 << 24))

/* A PNG is decoded from one copy of the file read into memory, checked whole first. Were
 * OIIO to read the file itself, a file truncated between the check and the decoding (a
 * download or copy still being written, or tests/cli/faults.sh) would reach the leaking
 * path above. Sets *data to the file's bytes (the caller frees them) when the file starts
 * with the PNG signature, to NULL when it does not; returns -1 with a message on failure. */
static int read_png_snapshot(const char *path, unsigned char **data, size_t *size, char *err,
                             size_t errlen)
{
    static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    *data = NULL;
    *size = 0;
    FILE *fp = fopen(path, "rb");
    if (!fp) {
        set_error(err, errlen, "%s: %s", path, strerror(errno));
        return -1;
    }
    unsigned char head[8];
    struct stat st;
    int status = 0;
    if (fread(head, 1, 8, fp) != 8 || memcmp(head, signature, 8) != 0)
        goto done; /* not a PNG: OIIO reads it from the file */
    if (fstat(fileno(fp), &st) != 0) {
        set_error(err, errlen, "%s: %s", path, strerror(errno));
        status = -1;
        goto done;
    }
    if ((uint64_t)st.st_size > PNG_MAX_FILE_BYTES) {
        set_error(err, errlen, "%s: a PNG of %lld bytes is larger than any image accepted",
                  path, (long long)st.st_size);
        status = -1;
        goto done;
    }
    size_t want = (size_t)st.st_size > 8 ? (size_t)st.st_size : 8;
    unsigned char *buf = malloc(want);
    if (!buf) {
        set_error(err, errlen, "%s: out of memory for a PNG of %zu bytes", path, want);
        status = -1;
        goto done;
    }
    memcpy(buf, head, 8);
    /* A file that shrinks meanwhile reads short, which the chunk walk reports. */
    size_t got = 8 + fread(buf + 8, 1, want - 8, fp);
    if (ferror(fp)) {
        set_error(err, errlen, "%s: %s", path, strerror(errno));
        free(buf);
        status = -1;
        goto done;
    }
    if (check_png_complete(path, buf, got, err, errlen) != 0) {
        free(buf);
        status = -1;
        goto done;
    }
    *data = buf;
    *size = got;
done:
    fclose(fp);
    return status;
}

/* The value size OpenEXR's C++ reader consumes for an attribute type whose values all have
 * one size (it reads that many bytes, whatever size the header declares), or -1. */
static long exr_fixed_size(const char *type)
{
    static const struct {
        const char *type;
        long size;
    } sizes[] = {
        {"box2i", 16},   {"box2f", 16},   {"chromaticities", 32}, {"compression", 1},
        {"deepImageState", 1}, {"double", 8}, {"envmap", 1},     {"float", 4},
        {"int", 4},      {"keycode", 28}, {"lineOrder", 1},      {"m33f", 36},
        {"m33d", 72},    {"m44f", 64},    {"m44d", 128},         {"rational", 8},
        {"tiledesc", 9}, {"timecode", 8}, {"v2i", 8},            {"v2f", 8},
        {"v2d", 16},     {"v3i", 12},     {"v3f", 12},           {"v3d", 24},
    };
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        if (strcmp(type, sizes[i].type) == 0)
            return sizes[i].size;
    return -1;
}

static uint32_t little_endian32(const unsigned char *b)
{
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}

/* Whether the value v (n bytes) of a chlist, preview or stringvector attribute is exactly
 * what its own contents say, which is what OpenEXR reads: a channel list up to its empty
 * name (each channel: name, NUL, 16 bytes), a preview's 8 + 4 * width * height bytes, a
 * string vector's (int32 length, bytes) entries. */
static int exr_value_consistent(const char *type, const unsigned char *v, size_t n)
{
    size_t at = 0;
    if (strcmp(type, "chlist") == 0) {
        for (;;) {
            size_t len = 0;
            while (at + len < n && v[at + len] != 0)
                len++;
            if (at + len >= n || len > 255)
                return 0;
            if (len == 0)
                return at + 1 == n; /* the empty name ends the list */
            at += len + 1 + 16;
            if (at > n)
                return 0;
        }
    }
    if (strcmp(type, "preview") == 0)
        return n >= 8 &&
               (uint64_t)little_endian32(v) * little_endian32(v + 4) * 4 == (uint64_t)(n - 8);
    if (strcmp(type, "stringvector") == 0) {
        while (at < n) {
            if (n - at < 4 || little_endian32(v + at) > n - at - 4)
                return 0;
            at += 4 + little_endian32(v + at);
        }
        return 1;
    }
    return 1;
}

/* Bookworm's OpenEXR 3.1 sizes strings by the lengths a header declares and fills them
 * before reading: a 773-byte EXR declaring a 2 GB string made the reader allocate and
 * touch 2 GB (found by tests/fuzz/fuzz_image). So before OpenImageIO sees an EXR (the
 * magic, whatever the extension: OIIO probes by content too), walk its header
 * attributes, name\0 type\0 int32 size value, in every part of a multi-part file, as
 * OpenEXR will, and refuse one whose size is beyond the file's end or disagrees with its
 * value: fixed-size types must declare their size, and a channel list, preview or string
 * vector must fill its declared size exactly. Otherwise OpenEXR, which reads those by
 * their contents, would read the next attribute from elsewhere than this walk did. */
static int check_exr_header(const char *path, char *err, size_t errlen)
{
    static const unsigned char magic[4] = {0x76, 0x2f, 0x31, 0x01};
    FILE *fp = fopen(path, "rb");
    if (!fp) {
        set_error(err, errlen, "%s: %s", path, strerror(errno));
        return -1;
    }
    unsigned char head[8];
    if (fread(head, 1, 8, fp) != 8 || memcmp(head, magic, 4) != 0) {
        fclose(fp);
        return 0; /* not an EXR: nothing to check */
    }
    long size = fseek(fp, 0, SEEK_END) == 0 ? ftell(fp) : -1;
    int multipart = (head[5] & 0x10) != 0; /* version field bit 12 */
    long at = 8;
    int status = size < 0 || fseek(fp, at, SEEK_SET) != 0 ? -1 : 0;
    unsigned char *value = NULL;
    while (status == 0) {
        /* One attribute, or the NUL that ends a header (two in a row end a multi-part
         * file's header list). */
        int c = fgetc(fp);
        if (c == EOF) {
            status = -1;
            break;
        }
        if (c == 0) {
            at++;
            if (!multipart)
                break;
            c = fgetc(fp);
            if (c == 0 || c == EOF) /* end of the list; EOF: let OpenEXR report it */
                break;
            ungetc(c, fp);
            continue;
        }
        ungetc(c, fp);
        char field[2][256]; /* name, type name */
        int ok = 1;
        for (int f = 0; f < 2 && ok; f++) {
            size_t n = 0;
            while ((c = fgetc(fp)) > 0 && n < sizeof field[f] - 1)
                field[f][n++] = (char)c;
            field[f][n] = '\0';
            ok = c == 0;
            at += (long)n + 1;
        }
        unsigned char b[4];
        if (!ok || fread(b, 1, 4, fp) != 4) {
            status = -1;
            break;
        }
        at += 4;
        uint32_t length = little_endian32(b);
        long fixed = exr_fixed_size(field[1]);
        if (length > 0x7fffffffu || (long)length > size - at) {
            set_error(err, errlen, "%s: corrupt EXR: header attribute '%.64s' claims %lu "
                      "bytes, %ld are left in the file", path, field[0], (unsigned long)length,
                      size - at);
            status = -2;
            break;
        }
        int consistent = fixed < 0 || (long)length == fixed;
        if (consistent && fixed < 0 && (!strcmp(field[1], "chlist") ||
                                        !strcmp(field[1], "preview") ||
                                        !strcmp(field[1], "stringvector"))) {
            free(value);
            value = malloc(length ? length : 1);
            if (!value || fread(value, 1, length, fp) != length) {
                status = -1;
                break;
            }
            consistent = exr_value_consistent(field[1], value, length);
        }
        if (!consistent) {
            set_error(err, errlen, "%s: corrupt EXR: header attribute '%.64s' of type "
                      "'%.32s' declares %lu bytes, which its value does not fill", path,
                      field[0], field[1], (unsigned long)length);
            status = -2;
            break;
        }
        at += (long)length;
        if (fseek(fp, at, SEEK_SET) != 0)
            status = -1;
    }
    free(value);
    fclose(fp);
    if (status == -1)
        set_error(err, errlen, "%s: corrupt EXR: the file (%ld bytes) ends inside its header, or "
                  "an attribute name is longer than 255 bytes", path, size);
    return status == 0 ? 0 : -1;
}

/* Copy the raw pixels (file_channels as read, interleaved) into img, which has out_channels.
 * Colour is sRGB-decoded when decode is set; alpha never is. A 2-channel file is grey and
 * alpha, spread to RGBA. */
static void convert_pixels(const void *raw, int as_uint8, int file_channels, int decode,
                           image *img)
{
    size_t npix = (size_t)img->width * (size_t)img->height;
    int out_channels = img->channels;
    int has_alpha = out_channels == 4;
    float lut[256];
    if (as_uint8)
        for (int k = 0; k < 256; k++)
            lut[k] = decode ? srgb_to_linear((float)k / 255.0f) : (float)k / 255.0f;
    const uint8_t *raw8 = raw;
    const float *rawf = raw;
    for (size_t p = 0; p < npix; p++) {
        float *out = img->pixels + p * (size_t)out_channels;
        size_t in = p * (size_t)file_channels;
        int colour_channels = has_alpha ? out_channels - 1 : out_channels;
        for (int c = 0; c < colour_channels; c++) {
            size_t src = in + (file_channels == 2 ? 0 : (size_t)c);
            if (as_uint8)
                out[c] = lut[raw8[src]];
            else
                out[c] = decode ? srgb_to_linear(rawf[src]) : rawf[src];
        }
        if (has_alpha) {
            size_t src = in + (file_channels == 2 ? 1 : 3);
            out[3] = as_uint8 ? (float)raw8[src] / 255.0f : rawf[src];
        }
    }
}

/* Turn img the way EXIF orientation o (2..8) says a viewer shows it. For each displayed
 * pixel (dx, dy) the stored pixel is (sx, sy); orientations 5..8 swap width and height.
 * E.g. 6 ("row 0 is the visual right side, column 0 the visual top") is a quarter turn
 * clockwise: displayed (0, 0) is stored (0, H - 1). Returns 0, or -1 out of memory. */
static int apply_orientation(image *img, int o)
{
    const int w = img->width, h = img->height, ch = img->channels;
    const int swap = o >= 5;
    image out;
    if (image_alloc(&out, swap ? h : w, swap ? w : h, ch) != 0)
        return -1;
    for (int dy = 0; dy < out.height; dy++)
        for (int dx = 0; dx < out.width; dx++) {
            int sx, sy;
            switch (o) {
            case 2: sx = w - 1 - dx; sy = dy; break;
            case 3: sx = w - 1 - dx; sy = h - 1 - dy; break;
            case 4: sx = dx; sy = h - 1 - dy; break;
            case 5: sx = dy; sy = dx; break;
            case 6: sx = dy; sy = h - 1 - dx; break;
            case 7: sx = w - 1 - dy; sy = h - 1 - dx; break;
            case 8: sx = w - 1 - dy; sy = dx; break;
            default: sx = dx; sy = dy; break;
            }
            memcpy(out.pixels + ((size_t)dy * (size_t)out.width + (size_t)dx) * (size_t)ch,
                   img->pixels + ((size_t)sy * (size_t)w + (size_t)sx) * (size_t)ch,
                   (size_t)ch * sizeof(float));
        }
    image_free(img);
    *img = out;
    return 0;
}

int image_read(const char *path, image *img, char *err, size_t errlen)
{
    memset(img, 0, sizeof *img);
    if (!path) {
        set_error(err, errlen, "(null): no input path");
        return -1;
    }
    unsigned char *png = NULL;
    size_t png_size = 0;
    if (check_readable_file(path, err, errlen) != 0 ||
        read_png_snapshot(path, &png, &png_size, err, errlen) != 0)
        return -1;
    if (!png && check_exr_header(path, err, errlen) != 0)
        return -1;

    char msg[512];
    oiio_image_info info;
    oiio_reader *reader = png ? oiio_reader_open_memory(path, "png", png, png_size, &info, msg,
                                                        sizeof msg)
                              : oiio_reader_open(path, &info, msg, sizeof msg);
    if (!reader) {
        set_error(err, errlen, "%s: not a readable image: %s", path, msg);
        free(png);
        return -1;
    }
    int status = -1;
    void *raw = NULL;
    if (info.is_deep || info.depth > 1) {
        set_error(err, errlen, "%s: %s images are not supported", path,
                  info.is_deep ? "deep" : "volume");
        goto done;
    }
    if (info.width < 1 || info.height < 1 || info.width > IMAGE_MAX_SIDE ||
        info.height > IMAGE_MAX_SIDE) {
        set_error(err, errlen, "%s: image size %d x %d is outside 1..%d per side", path,
                  info.width, info.height, IMAGE_MAX_SIDE);
        goto done;
    }
    if ((size_t)info.width * (size_t)info.height > IMAGE_MAX_PIXELS) {
        set_error(err, errlen, "%s: image size %d x %d is more than the %zu pixels accepted",
                  path, info.width, info.height, IMAGE_MAX_PIXELS);
        goto done;
    }
    if (info.channels < 1) {
        set_error(err, errlen, "%s: image has no channels", path);
        goto done;
    }

    /* Channel mapping, see imageio.h. OIIO lists R, G, B, A first and marks alpha, so
     * "is the 2nd / 4th channel alpha" decides grey+alpha and RGBA; a 4th channel that is
     * not alpha (an EXR's Z, say) is dropped, like any channel after the 4th. */
    int file_channels, out_channels;
    if (info.channels == 1 || (info.channels == 2 && info.alpha_channel != 1)) {
        file_channels = out_channels = 1;
    } else if (info.channels == 2) {
        file_channels = 2;
        out_channels = 4;
    } else {
        file_channels = out_channels = info.channels >= 4 && info.alpha_channel == 3 ? 4 : 3;
    }
    /* 8-bit files are read as bytes so that decoding is one table lookup per value and
     * exact; everything else as float (integers scaled to [0,1] by OIIO). */
    int as_uint8 = !info.is_float && info.bits <= 8;
    int decode = !info.is_float && !info.metadata_linear;
    size_t nvalues = (size_t)info.width * (size_t)info.height * (size_t)file_channels;
    raw = malloc(nvalues * (as_uint8 ? 1 : sizeof(float)));
    if (!raw || image_alloc(img, info.width, info.height, out_channels) != 0) {
        set_error(err, errlen, "%s: out of memory for a %d x %d image", path, info.width,
                  info.height);
        goto done;
    }
    if (oiio_reader_read(reader, file_channels, as_uint8, raw, msg, sizeof msg) != 0) {
        set_error(err, errlen, "%s: cannot read %s image data: %s", path, info.format_name, msg);
        goto done;
    }
    convert_pixels(raw, as_uint8, file_channels, decode, img);
    if (info.orientation != 1 && apply_orientation(img, info.orientation) != 0) {
        set_error(err, errlen, "%s: out of memory for a %d x %d image", path, info.width,
                  info.height);
        goto done;
    }
    status = 0;
done:
    free(raw);
    oiio_reader_close(reader);
    free(png);
    if (status != 0)
        image_free(img);
    return status;
}

/* ---------------------------------------------------------------------------------------
 * EXR writing with OpenEXRCore
 */

/* OpenEXRCore reports errors through a callback, per context; keep the first message (the
 * later ones are usually consequences of it). */
typedef struct exr_error_sink {
    char message[256];
    int fd;          /* writing: the temp file, written by exr_write_to_fd */
    int write_errno; /* writing: errno of the first failed write, else 0 */
} exr_error_sink;

/* Writing streams through our own file descriptor, for two reasons: the error of a
 * failed write (a full disk) reaches the message, and the error handler below is never
 * needed while writing. OpenEXR Core locks a write context for the whole of each call
 * and exr_get_user_data takes that lock again, so a handler that asks for its user data
 * during exr_write_header deadlocks (found by tests/cli/faults.sh on a full disk). */
static int64_t exr_write_to_fd(exr_const_context_t ctxt, void *user, const void *buffer,
                               uint64_t size, uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    (void)ctxt;
    (void)error_cb; /* it would call the error handler: the errno is kept instead */
    exr_error_sink *sink = user;
    const char *p = buffer;
    uint64_t done = 0;
    while (done < size) {
        ssize_t n = pwrite(sink->fd, p + done, (size_t)(size - done), (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            if (!sink->write_errno)
                sink->write_errno = n < 0 ? errno : EIO;
            return -1;
        }
        done += (uint64_t)n;
    }
    return (int64_t)size;
}

/* Write contexts only: must not touch ctxt (see above). */
static void exr_error_ignored(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    (void)code;
    (void)msg;
}

static void exr_error_to_sink(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    void *user = NULL;
    if (exr_get_user_data(ctxt, &user) != EXR_ERR_SUCCESS || !user)
        return;
    exr_error_sink *sink = user;
    if (sink->message[0] == '\0')
        snprintf(sink->message, sizeof sink->message, "%s", msg ? msg :
                 exr_get_default_error_message(code));
}

static const char *exr_message(const exr_error_sink *sink, exr_result_t code)
{
    if (sink->write_errno)
        return strerror(sink->write_errno);
    return sink->message[0] ? sink->message : exr_get_default_error_message(code);
}

/* Write img as one scanline part into tmp (an existing empty file). The encoder reads the
 * interleaved pixels in place through per-channel pointers and strides; OpenEXR stores
 * channels sorted by name (A, B, G, R), so each of the encoder's channels is matched to
 * ours by name, not by position. */
static exr_result_t write_exr_file(const char *tmp, const image *img, exr_pixel_type_t ptype,
                                   const char *const *meta, exr_error_sink *sink)
{
    static const char *const names_y[] = {"Y"};
    static const char *const names_rgba[] = {"R", "G", "B", "A"};
    const char *const *names = img->channels == 1 ? names_y : names_rgba;

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_error_ignored;
    init.write_fn = exr_write_to_fd;
    init.user_data = sink;
    sink->fd = open(tmp, O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (sink->fd < 0) {
        sink->write_errno = errno;
        return EXR_ERR_FILE_ACCESS;
    }
    exr_context_t ctxt = NULL;
    exr_result_t rv = exr_start_write(&ctxt, tmp, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS) {
        close(sink->fd);
        return rv;
    }

    exr_encode_pipeline_t encoder;
    int encoder_live = 0;
    int part = 0;
    rv = exr_add_part(ctxt, NULL, EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctxt, part, img->width, img->height,
                                                 EXR_COMPRESSION_ZIP);
    for (int c = 0; c < img->channels && rv == EXR_ERR_SUCCESS; c++) {
        /* The perceptual hint only matters to lossy B44; alpha is linear, colour is not. */
        exr_perceptual_treatment_t percept =
            c == 3 ? EXR_PERCEPTUALLY_LINEAR : EXR_PERCEPTUALLY_LOGARITHMIC;
        rv = exr_add_channel(ctxt, part, names[c], ptype, percept, 1, 1);
    }
    for (int i = 0; meta && meta[i] && rv == EXR_ERR_SUCCESS; i += 2) {
        if (!meta[i + 1]) {
            rv = EXR_ERR_INVALID_ARGUMENT;
            snprintf(sink->message, sizeof sink->message, "metadata '%s' has no value", meta[i]);
            break;
        }
        if (strlen(meta[i]) > 31)
            rv = exr_set_longname_support(ctxt, 1);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_attr_set_string(ctxt, part, meta[i], meta[i + 1]);
    }
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_write_header(ctxt);
    int32_t lines_per_chunk = 0;
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_scanlines_per_chunk(ctxt, part, &lines_per_chunk);
    if (rv == EXR_ERR_SUCCESS && lines_per_chunk < 1)
        rv = EXR_ERR_INVALID_ATTR;

    const size_t pixel_bytes = (size_t)img->channels * sizeof(float);
    const size_t row_bytes = (size_t)img->width * pixel_bytes;
    for (int y = 0; y < img->height && rv == EXR_ERR_SUCCESS; y += lines_per_chunk) {
        exr_chunk_info_t chunk;
        rv = exr_write_scanline_chunk_info(ctxt, part, y, &chunk);
        if (rv != EXR_ERR_SUCCESS)
            break;
        if (!encoder_live) {
            memset(&encoder, 0, sizeof encoder);
            rv = exr_encoding_initialize(ctxt, part, &chunk, &encoder);
            if (rv != EXR_ERR_SUCCESS)
                break;
            encoder_live = 1;
        } else {
            rv = exr_encoding_update(ctxt, part, &chunk, &encoder);
            if (rv != EXR_ERR_SUCCESS)
                break;
        }
        const uint8_t *rows = (const uint8_t *)img->pixels + (size_t)(chunk.start_y) * row_bytes;
        for (int16_t k = 0; k < encoder.channel_count; k++) {
            exr_coding_channel_info_t *ch = &encoder.channels[k];
            int c = 0;
            while (c < img->channels && strcmp(names[c], ch->channel_name) != 0)
                c++;
            if (c == img->channels) {
                rv = EXR_ERR_INVALID_ATTR;
                break;
            }
            ch->encode_from_ptr = rows + (size_t)c * sizeof(float);
            ch->user_pixel_stride = (int32_t)pixel_bytes;
            ch->user_line_stride = (int32_t)row_bytes;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_bytes_per_element = sizeof(float);
        }
        if (rv != EXR_ERR_SUCCESS)
            break;
        if (y == 0)
            rv = exr_encoding_choose_default_routines(ctxt, part, &encoder);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_run(ctxt, part, &encoder);
    }
    if (encoder_live)
        exr_encoding_destroy(ctxt, &encoder);
    /* exr_finish writes the chunk offset table: its failure is a failed write too. */
    exr_result_t finished = exr_finish(&ctxt);
    if (close(sink->fd) != 0 && !sink->write_errno) {
        sink->write_errno = errno;
        finished = EXR_ERR_WRITE_IO;
    }
    return rv != EXR_ERR_SUCCESS ? rv : finished;
}

int image_write_exr_meta(const char *path, const image *img, image_exr_pixel pixel_type,
                         const char *const *meta, char *err, size_t errlen)
{
    if (check_writable_image(path, img, err, errlen) != 0)
        return -1;
    if ((size_t)img->width * (size_t)img->channels * sizeof(float) > INT32_MAX) {
        set_error(err, errlen, "%s: image too wide for EXR (%d pixels)", path, img->width);
        return -1;
    }
    char tmp[PATH_MAX];
    if (create_temp_beside(path, tmp, sizeof tmp, err, errlen) != 0)
        return -1;
    exr_error_sink sink = {{0}};
    exr_pixel_type_t ptype = pixel_type == IMAGE_EXR_HALF ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT;
    exr_result_t rv = write_exr_file(tmp, img, ptype, meta, &sink);
    if (rv != EXR_ERR_SUCCESS) {
        set_error(err, errlen, "%s: cannot write EXR: %s", path, exr_message(&sink, rv));
        unlink(tmp);
        return -1;
    }
    return commit_temp(tmp, path, err, errlen);
}

int image_write_exr(const char *path, const image *img, image_exr_pixel pixel_type, char *err,
                    size_t errlen)
{
    return image_write_exr_meta(path, img, pixel_type, NULL, err, errlen);
}

int image_exr_get_string(const char *path, const char *name, char *value, size_t valuelen,
                         char *err, size_t errlen)
{
    if (!path || !name) {
        set_error(err, errlen, "%s: no path or attribute name", path ? path : "(null)");
        return -1;
    }
    if (check_readable_file(path, err, errlen) != 0)
        return -1;
    exr_error_sink sink = {{0}};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_error_to_sink;
    init.user_data = &sink;
    exr_context_t ctxt = NULL;
    exr_result_t rv = exr_start_read(&ctxt, path, &init);
    if (rv != EXR_ERR_SUCCESS) {
        set_error(err, errlen, "%s: not a readable EXR: %s", path, exr_message(&sink, rv));
        exr_finish(&ctxt);
        return -1;
    }
    int32_t length = 0;
    const char *s = NULL;
    int status;
    rv = exr_attr_get_string(ctxt, 0, name, &length, &s);
    if (rv == EXR_ERR_NO_ATTR_BY_NAME) {
        status = 1;
    } else if (rv != EXR_ERR_SUCCESS) {
        set_error(err, errlen, "%s: attribute '%s': %s", path, name, exr_message(&sink, rv));
        status = -1;
    } else if (value && (size_t)length >= valuelen) {
        set_error(err, errlen, "%s: attribute '%s' is %d bytes, more than the %zu given", path,
                  name, (int)length, valuelen);
        status = -1;
    } else {
        if (value) {
            memcpy(value, s, (size_t)length);
            value[length] = '\0';
        }
        status = 0;
    }
    exr_finish(&ctxt);
    return status;
}

/* ---------------------------------------------------------------------------------------
 * PNG writing
 */

/* 8-bit sRGB (for people) or 16-bit linear (lossless enough to be a dataset's ground truth). */
static int write_png(const char *path, const image *img, int bits16, char *err, size_t errlen)
{
    if (check_writable_image(path, img, err, errlen) != 0)
        return -1;
    size_t nvalues = (size_t)img->width * (size_t)img->height * (size_t)img->channels;
    void *buf = malloc(nvalues * (bits16 ? 2 : 1));
    if (!buf) {
        set_error(err, errlen, "%s: out of memory", path);
        return -1;
    }
    /* Clamp, encode colour (not alpha; never in 16-bit linear), round to nearest. NaN fails
     * both comparisons and would reach the cast, which is undefined: it is mapped to 0 first. */
    int alpha = img->channels == 4 ? 3 : -1;
    for (size_t i = 0; i < nvalues; i++) {
        float v = img->pixels[i];
        if (!(v > 0.0f))
            v = 0.0f;
        if (v > 1.0f)
            v = 1.0f;
        if (bits16)
            ((uint16_t *)buf)[i] = (uint16_t)(v * 65535.0f + 0.5f);
        else {
            if ((int)(i % (size_t)img->channels) != alpha)
                v = linear_to_srgb(v);
            ((uint8_t *)buf)[i] = (uint8_t)(v * 255.0f + 0.5f);
        }
    }
    char tmp[PATH_MAX];
    if (create_temp_beside(path, tmp, sizeof tmp, err, errlen) != 0) {
        free(buf);
        return -1;
    }
    char msg[512];
    int rv = oiio_write_png(tmp, img->width, img->height, img->channels, bits16 ? 16 : 8,
                            bits16, buf, msg, sizeof msg);
    free(buf);
    if (rv != 0) {
        set_error(err, errlen, "%s: cannot write PNG: %s", path, msg);
        unlink(tmp);
        return -1;
    }
    return commit_temp(tmp, path, err, errlen);
}

int image_write_png(const char *path, const image *img, char *err, size_t errlen)
{
    return write_png(path, img, 0, err, errlen);
}

int image_write_png16_linear(const char *path, const image *img, char *err, size_t errlen)
{
    return write_png(path, img, 1, err, errlen);
}

/* ---------------------------------------------------------------------------------------
 * Resizing
 */

/* The taps of one output sample along one axis: source indices [first, first + count) with
 * weights summing to 1. */
typedef struct resize_taps {
    int first, count;
    size_t weight_offset; /* into the axis' weight array */
} resize_taps;

/* Tent filter for n_src -> n_dst samples. Output i's centre sits at (i + 0.5) * scale - 0.5
 * in source pixels (pixel centres at integers, edges aligned). The tent's half-width is the
 * scale when shrinking, so every source pixel contributes to the output pixels it overlaps
 * (area-correct, no aliasing of fine detail), and 1 when enlarging, which is bilinear
 * interpolation. Taps falling outside the image are dropped and the rest renormalised. */
static int make_taps(int n_src, int n_dst, resize_taps **taps_out, float **weights_out)
{
    double scale = (double)n_src / (double)n_dst;
    double radius = scale > 1.0 ? scale : 1.0;
    int max_taps = (int)ceil(2.0 * radius) + 1;
    resize_taps *taps = malloc((size_t)n_dst * sizeof *taps);
    float *weights = malloc((size_t)n_dst * (size_t)max_taps * sizeof *weights);
    if (!taps || !weights) {
        free(taps);
        free(weights);
        return -1;
    }
    for (int i = 0; i < n_dst; i++) {
        double centre = (i + 0.5) * scale - 0.5;
        int lo = (int)ceil(centre - radius);
        int hi = (int)floor(centre + radius);
        if (lo < 0)
            lo = 0;
        if (hi > n_src - 1)
            hi = n_src - 1;
        float *w = weights + (size_t)i * (size_t)max_taps;
        double sum = 0.0;
        int count = 0;
        for (int s = lo; s <= hi && count < max_taps; s++) {
            double t = 1.0 - fabs((double)s - centre) / radius;
            w[count++] = (float)(t > 0.0 ? t : 0.0);
            sum += t > 0.0 ? t : 0.0;
        }
        /* sum > 0: centres lie in [-0.5, n_src - 0.5], so the nearest source pixel is at
         * most 0.5 away, inside the radius (>= 1). */
        for (int k = 0; k < count; k++)
            w[k] = (float)(w[k] / sum);
        taps[i].first = lo;
        taps[i].count = count;
        taps[i].weight_offset = (size_t)i * (size_t)max_taps;
    }
    *taps_out = taps;
    *weights_out = weights;
    return 0;
}

int image_rotate_ccw(const image *src, image *dst)
{
    if (image_alloc(dst, src->height, src->width, src->channels))
        return -1;
    size_t ch = (size_t)src->channels;
    for (int r = 0; r < dst->height; r++)
        for (int c = 0; c < dst->width; c++)
            memcpy(dst->pixels + ((size_t)r * (size_t)dst->width + (size_t)c) * ch,
                   src->pixels + ((size_t)c * (size_t)src->width + (size_t)(src->width - 1 - r)) * ch,
                   ch * sizeof(float));
    return 0;
}

int image_resize(const image *src, int width, int height, image *dst)
{
    memset(dst, 0, sizeof *dst);
    if (!src || !src->pixels || src->width < 1 || src->height < 1 || src->channels < 1 ||
        src->channels > 4 || width < 1 || height < 1)
        return -1;
    const int ch = src->channels;
    resize_taps *xtaps = NULL, *ytaps = NULL;
    float *xw = NULL, *yw = NULL, *rows = NULL;
    int status = -1;
    if (make_taps(src->width, width, &xtaps, &xw) != 0 ||
        make_taps(src->height, height, &ytaps, &yw) != 0)
        goto done;
    /* Horizontal pass over every source row, then vertical: src->height x width x ch. */
    rows = malloc((size_t)src->height * (size_t)width * (size_t)ch * sizeof *rows);
    if (!rows || image_alloc(dst, width, height, ch) != 0)
        goto done;
    for (int y = 0; y < src->height; y++) {
        const float *in = src->pixels + (size_t)y * (size_t)src->width * (size_t)ch;
        float *out = rows + (size_t)y * (size_t)width * (size_t)ch;
        for (int x = 0; x < width; x++) {
            const resize_taps *t = &xtaps[x];
            const float *w = xw + t->weight_offset;
            for (int c = 0; c < ch; c++) {
                float acc = 0.0f;
                for (int k = 0; k < t->count; k++)
                    acc += w[k] * in[(size_t)(t->first + k) * (size_t)ch + (size_t)c];
                out[(size_t)x * (size_t)ch + (size_t)c] = acc;
            }
        }
    }
    const size_t row_values = (size_t)width * (size_t)ch;
    for (int y = 0; y < height; y++) {
        const resize_taps *t = &ytaps[y];
        const float *w = yw + t->weight_offset;
        float *out = dst->pixels + (size_t)y * row_values;
        for (int k = 0; k < t->count; k++) {
            const float *in = rows + (size_t)(t->first + k) * row_values;
            for (size_t v = 0; v < row_values; v++)
                out[v] += w[k] * in[v];
        }
    }
    status = 0;
done:
    free(xtaps);
    free(ytaps);
    free(xw);
    free(yw);
    free(rows);
    if (status != 0)
        image_free(dst);
    return status;
}
