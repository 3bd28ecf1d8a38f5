/* NumPy .npy writer (format version 1.0: magic, header length, a Python dict literal
 * padded with spaces to a multiple of 64 bytes and ended by '\n', then the raw data). */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "nn/nn.h"

struct nn_npy_writer {
    FILE *f;
    char *path, *tmp;
    size_t rows, cols, written;
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
    char header[256];
    int len = snprintf(header, sizeof header,
                       "{'descr': '<f4', 'fortran_order': False, 'shape': (%zu, %zu), }", rows,
                       cols);
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
    if (w->written + rows > w->rows) {
        set_err(err, errlen, "%s: %zu rows appended to an array of %zu", w->path,
                w->written + rows, w->rows);
        return -1;
    }
    /* The data is written as it lies in memory: '<f4' holds on the little-endian
     * machines this project targets. */
    if (fwrite(data, sizeof(float), rows * w->cols, w->f) != rows * w->cols) {
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
