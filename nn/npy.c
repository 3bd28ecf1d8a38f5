/* NumPy .npy reader and writer (writer: format version 1.0: magic, header length, a Python dict literal
 * padded with spaces to a multiple of 64 bytes and ended by '\n', then the raw data). */
#include <errno.h>
#include <stdint.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "nn/nn.h"

struct nn_npy_writer {
    FILE *f;
    char *path, *tmp;
    size_t rows, cols, written, itemsize;
};

static void set_err(char *err, size_t errlen, const char *fmt, ...)
{
    if (!err || !errlen)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
}

void nn_npy_abort(nn_npy_writer *w)
{
    if (!w)
        return;
    if (w->f)
        fclose(w->f);
    if (w->tmp)
        remove(w->tmp);
    free(w->path);
    free(w->tmp);
    free(w);
}

nn_npy_writer *nn_npy_begin(const char *path, size_t rows, size_t cols, char *err,
                            size_t errlen)
{
    return nn_npy_begin_dtype(path, "<f4", 4, rows, cols, err, errlen);
}

nn_npy_writer *nn_npy_begin_dtype(const char *path, const char *descr, size_t itemsize,
                                  size_t rows, size_t cols, char *err, size_t errlen)
{
    char header[256];
    int len = snprintf(header, sizeof header,
                       "{'descr': '%s', 'fortran_order': False, 'shape': (%zu, %zu), }", descr,
                       rows, cols);
    /* 10 bytes of preamble + header + padding + '\n' is a multiple of 64. */
    size_t hlen = ((size_t)10 + (size_t)len + 1 + 63) / 64 * 64 - 10;
    memset(header + len, ' ', hlen - 1 - (size_t)len);
    header[hlen - 1] = '\n';

    nn_npy_writer *w = calloc(1, sizeof *w);
    size_t tlen = strlen(path) + 32;
    if (!w || !(w->path = strdup(path)) || !(w->tmp = malloc(tlen))) {
        set_err(err, errlen, "%s: out of memory", path);
        if (w) {
            free(w->path);
            free(w);
        }
        return NULL;
    }
    snprintf(w->tmp, tlen, "%s.tmp.%ld", path, (long)getpid());
    w->rows = rows;
    w->cols = cols;
    w->itemsize = itemsize;
    w->f = fopen(w->tmp, "wb");
    if (!w->f) {
        set_err(err, errlen, "%s: cannot create: %s", w->tmp, strerror(errno));
        free(w->tmp);
        w->tmp = NULL; /* nothing to remove */
        nn_npy_abort(w);
        return NULL;
    }
    unsigned char pre[10] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0,
                             (unsigned char)(hlen & 0xff), (unsigned char)(hlen >> 8)};
    if (fwrite(pre, 1, 10, w->f) != 10 || fwrite(header, 1, hlen, w->f) != hlen) {
        set_err(err, errlen, "%s: write failed: %s", w->tmp, strerror(errno));
        nn_npy_abort(w);
        return NULL;
    }
    return w;
}

int nn_npy_append(nn_npy_writer *w, const float *data, size_t rows, char *err, size_t errlen)
{
    return nn_npy_append_raw(w, data, rows, err, errlen);
}

int nn_npy_append_raw(nn_npy_writer *w, const void *data, size_t rows, char *err,
                      size_t errlen)
{
    if (w->written + rows > w->rows) {
        set_err(err, errlen, "%s: %zu rows appended to an array of %zu", w->path,
                w->written + rows, w->rows);
        return -1;
    }
    /* The data is written as it lies in memory: '<' (little-endian) holds on the
     * machines this project targets. */
    if (fwrite(data, w->itemsize, rows * w->cols, w->f) != rows * w->cols) {
        set_err(err, errlen, "%s: write failed: %s", w->tmp, strerror(errno));
        return -1;
    }
    w->written += rows;
    return 0;
}

int nn_npy_commit(nn_npy_writer *w, char *err, size_t errlen)
{
    if (w->written != w->rows) {
        set_err(err, errlen, "%s: %zu of %zu rows written", w->path, w->written, w->rows);
        nn_npy_abort(w);
        return -1;
    }
    int closed = fclose(w->f) == 0;
    w->f = NULL;
    if (!closed || rename(w->tmp, w->path)) {
        set_err(err, errlen, "%s: %s failed: %s", w->path, closed ? "rename" : "write",
                strerror(errno));
        nn_npy_abort(w);
        return -1;
    }
    free(w->tmp);
    w->tmp = NULL;
    nn_npy_abort(w); /* frees what is left; the file is in place */
    return 0;
}

int nn_npy_write_f32(const char *path, const float *data, size_t rows, size_t cols, char *err,
                     size_t errlen)
{
    nn_npy_writer *w = nn_npy_begin(path, rows, cols, err, errlen);
    if (!w)
        return -1;
    if (nn_npy_append(w, data, rows, err, errlen)) {
        nn_npy_abort(w);
        return -1;
    }
    return nn_npy_commit(w, err, errlen);
}

/* ---------------------------------------------------------------- reading ---------- */

/* The dtypes a reader accepts, all little-endian (or byte-sized), converted to float. */
typedef enum npy_kind { NPY_F4, NPY_F8, NPY_F2, NPY_I, NPY_U, NPY_BOOL } npy_kind;

uint16_t nn_float_to_half(float f)
{
    uint32_t x;
    memcpy(&x, &f, 4);
    uint32_t sign = (x >> 16) & 0x8000u, e = (x >> 23) & 0xffu, man = x & 0x7fffffu;
    if (e == 0xff) /* inf, nan (keep nan a nan) */
        return (uint16_t)(sign | 0x7c00u | (man ? 0x200u : 0));
    int exp = (int)e - 127 + 15;
    if (exp >= 31)
        return (uint16_t)(sign | 0x7c00u);
    if (exp <= 0) { /* subnormal half or zero */
        if (exp < -10)
            return (uint16_t)sign;
        man |= 0x800000u;
        int shift = 14 - exp;
        uint32_t h = man >> shift, rem = man & ((1u << shift) - 1), half = 1u << (shift - 1);
        if (rem > half || (rem == half && (h & 1)))
            h++;
        return (uint16_t)(sign | h);
    }
    uint32_t h = ((uint32_t)exp << 10) | (man >> 13), rem = man & 0x1fffu;
    if (rem > 0x1000u || (rem == 0x1000u && (h & 1)))
        h++; /* may carry into the exponent, and up to infinity: both correct */
    return (uint16_t)(sign | h);
}

float nn_half_to_float(uint16_t h)
{
    uint32_t sign = (uint32_t)(h >> 15) << 31, exp = (h >> 10) & 31u, man = h & 1023u, bits;
    if (exp == 0) {
        if (man == 0) {
            bits = sign;
        } else { /* subnormal: exactly man * 2^-24 */
            float v = (float)man * 0x1p-24f;
            return sign ? -v : v;
        }
    } else if (exp == 31) {
        bits = sign | 0x7f800000u | man << 13;
    } else {
        bits = sign | (exp + 112) << 23 | man << 13;
    }
    float f;
    memcpy(&f, &bits, 4);
    return f;
}

/* Finds 'key': in the header dict and returns a pointer just past the colon, or NULL. */
static const char *dict_value(const char *h, const char *key)
{
    char pat[32];
    snprintf(pat, sizeof pat, "'%s'", key);
    const char *p = strstr(h, pat);
    if (!p)
        return NULL;
    p += strlen(pat);
    while (*p == ' ')
        p++;
    if (*p != ':')
        return NULL;
    p++;
    while (*p == ' ')
        p++;
    return p;
}

int nn_npy_read_f32(const char *path, float **data, size_t *rows, size_t *cols, char *err,
                    size_t errlen)
{
    *data = NULL;
    *rows = *cols = 0;
    FILE *f = fopen(path, "rb");
    if (!f) {
        set_err(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    unsigned char pre[12];
    char *header = NULL;
    unsigned char *raw = NULL;
    float *out = NULL;
    int rc = -1;
    if (fread(pre, 1, 10, f) != 10 || memcmp(pre, "\x93NUMPY", 6)) {
        set_err(err, errlen, "%s: not a .npy file (bad magic)", path);
        goto done;
    }
    size_t hlen, pre_len = 10;
    if (pre[6] == 1)
        hlen = (size_t)pre[8] | (size_t)pre[9] << 8;
    else if (pre[6] == 2 || pre[6] == 3) {
        if (fread(pre + 10, 1, 2, f) != 2) {
            set_err(err, errlen, "%s: truncated header", path);
            goto done;
        }
        hlen = (size_t)pre[8] | (size_t)pre[9] << 8 | (size_t)pre[10] << 16 |
               (size_t)pre[11] << 24;
        pre_len = 12;
    } else {
        set_err(err, errlen, "%s: unsupported .npy version %d.%d", path, pre[6], pre[7]);
        goto done;
    }
    if (hlen > (1u << 20) || !(header = malloc(hlen + 1)) || fread(header, 1, hlen, f) != hlen) {
        set_err(err, errlen, "%s: truncated or oversized header (%zu bytes)", path, hlen);
        goto done;
    }
    header[hlen] = 0;
    const char *d = dict_value(header, "descr"), *fo = dict_value(header, "fortran_order"),
               *sh = dict_value(header, "shape");
    if (!d || !fo || !sh || *d != '\'' || *sh != '(') {
        set_err(err, errlen, "%s: header lacks descr, fortran_order or shape: %.100s", path,
                header);
        goto done;
    }
    if (strncmp(fo, "False", 5)) {
        set_err(err, errlen, "%s: Fortran-order arrays are not supported", path);
        goto done;
    }
    /* descr: '<f4', '|b1', '<i8', '|u1', ... ('=' and '|' mean native / not applicable). */
    /* The dtype text between the quotes: at least an order, a kind and a size, and
     * closed within the header (d[1], d[2] and atoi read no further than it). */
    int dlen = (int)strcspn(d + 1, "'");
    if (dlen < 3 || d[1 + dlen] != '\'') {
        set_err(err, errlen, "%s: header has a bad descr: %.100s", path, header);
        goto done;
    }
    if (dlen > 16)
        dlen = 16; /* for messages */
    char order = d[1], type = d[2];
    int size = atoi(d + 3);
    npy_kind kind;
    if (type == 'f' && size == 4)
        kind = NPY_F4;
    else if (type == 'f' && size == 8)
        kind = NPY_F8;
    else if (type == 'f' && size == 2)
        kind = NPY_F2;
    else if ((type == 'i' || type == 'u') && (size == 1 || size == 2 || size == 4 || size == 8))
        kind = type == 'i' ? NPY_I : NPY_U;
    else if (type == 'b' && size == 1)
        kind = NPY_BOOL;
    else {
        set_err(err, errlen, "%s: unsupported dtype '%.*s' (float16/32/64, int, uint, bool)",
                path, dlen, d + 1);
        goto done;
    }
    if (order == '>' && size > 1) {
        set_err(err, errlen, "%s: big-endian data is not supported", path);
        goto done;
    }
    /* shape: (), (n,), (r, c) */
    size_t dims[2] = {1, 1};
    int ndim = 0;
    const char *p = sh + 1;
    for (;;) {
        while (*p == ' ' || *p == ',')
            p++;
        if (*p == ')')
            break;
        char *end;
        errno = 0;
        unsigned long long v = strtoull(p, &end, 10);
        if (end == p || errno || ndim == 2 || v > ((size_t)1 << 40)) {
            set_err(err, errlen, "%s: unsupported shape %.60s (1-D or 2-D only)", path, sh);
            goto done;
        }
        dims[ndim++] = (size_t)v;
        p = end;
    }
    size_t r = ndim ? dims[0] : 1, c = ndim == 2 ? dims[1] : 1;
    if (c && r > ((size_t)1 << 40) / c) {
        set_err(err, errlen, "%s: shape too large", path);
        goto done;
    }
    size_t n = r * c, nbytes = n * (size_t)size;
    /* The data must be exactly what the header says: check the file size before
     * allocating, so a lying header is an error rather than an allocation of its claim. */
    long here = ftell(f);
    if (fseek(f, 0, SEEK_END) || ftell(f) < 0) {
        set_err(err, errlen, "%s: cannot seek", path);
        goto done;
    }
    size_t fsize = (size_t)ftell(f);
    if (here < 0 || (size_t)here != pre_len + hlen || fsize - (size_t)here != nbytes) {
        set_err(err, errlen, "%s: data is %zu bytes, header (shape %zu x %zu, '%.*s') says %zu",
                path, fsize - (size_t)here, r, c, dlen, d + 1, nbytes);
        goto done;
    }
    fseek(f, here, SEEK_SET);
    out = malloc((n ? n : 1) * sizeof(float));
    raw = kind == NPY_F4 ? (unsigned char *)out : malloc(nbytes ? nbytes : 1);
    if (!out || !raw) {
        set_err(err, errlen, "%s: out of memory for %zu x %zu", path, r, c);
        goto done;
    }
    if (fread(raw, 1, nbytes, f) != nbytes) {
        set_err(err, errlen, "%s: read failed", path);
        goto done;
    }
    for (size_t i = 0; i < n && kind != NPY_F4; i++) {
        const unsigned char *q = raw + i * (size_t)size;
        if (kind == NPY_F8) {
            double v;
            memcpy(&v, q, 8);
            out[i] = (float)v;
        } else if (kind == NPY_F2) {
            uint16_t h;
            memcpy(&h, q, 2);
            out[i] = nn_half_to_float(h);
        } else if (kind == NPY_BOOL)
            out[i] = q[0] ? 1.0f : 0.0f;
        else {
            uint64_t u = 0;
            memcpy(&u, q, (size_t)size); /* little-endian */
            if (kind == NPY_I && size < 8 && (u >> (8 * size - 1)) & 1)
                u |= ~(uint64_t)0 << (8 * size); /* sign-extend */
            out[i] = kind == NPY_I ? (float)(int64_t)u : (float)u;
        }
    }
    *data = out;
    out = NULL;
    *rows = r;
    *cols = c;
    rc = 0;
done:
    if (raw != (unsigned char *)out && raw != (unsigned char *)*data)
        free(raw);
    free(out);
    free(header);
    fclose(f);
    return rc;
}
