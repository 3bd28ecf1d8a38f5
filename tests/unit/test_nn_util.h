/* Helpers shared by the nn tests: a minimal .npy reader and per-layer comparison. */
#ifndef TEST_NN_UTIL_H
#define TEST_NN_UTIL_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nn/nn.h"

/* Reads a C-order .npy of dtype '<f4' or '|u1' with 1 to 4 dimensions. Returns malloc'd
 * data (floats, or bytes for u1) and the shape, or NULL. */
static inline void *npy_read(const char *path, int *ndim, long shape[4], int *is_u8)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    unsigned char pre[10];
    if (fread(pre, 1, 10, f) != 10 || memcmp(pre, "\x93NUMPY", 6) || pre[6] != 1) {
        fclose(f);
        return NULL;
    }
    size_t hlen = pre[8] | (size_t)pre[9] << 8;
    char *h = calloc(1, hlen + 1);
    if (!h || fread(h, 1, hlen, f) != hlen || strstr(h, "'fortran_order': True")) {
        free(h);
        fclose(f);
        return NULL;
    }
    *is_u8 = strstr(h, "'|u1'") != NULL;
    if (!*is_u8 && !strstr(h, "'<f4'")) {
        free(h);
        fclose(f);
        return NULL;
    }
    const char *s = strstr(h, "'shape': (");
    *ndim = 0;
    size_t count = 1;
    if (s) {
        s += 10;
        while (*s && *s != ')' && *ndim < 4) {
            char *end;
            long v = strtol(s, &end, 10);
            if (end == s)
                break;
            shape[(*ndim)++] = v;
            count *= (size_t)v;
            s = end;
            while (*s == ',' || *s == ' ')
                s++;
        }
    }
    free(h);
    size_t esize = *is_u8 ? 1 : 4;
    void *data = malloc(count * esize);
    if (!data || fread(data, esize, count, f) != count) {
        free(data);
        data = NULL;
    }
    fclose(f);
    return data;
}

/* Worst over layers of max |a - b| / max |b| within each Gram layer of one row. */
static inline double worst_layer_error(const float *a, const float *b, const size_t offsets[6])
{
    double worst = 0.0;
    for (int l = 0; l < 5; l++) {
        double maxref = 0.0, maxdiff = 0.0;
        for (size_t i = offsets[l]; i < offsets[l + 1]; i++) {
            maxref = fmax(maxref, fabs((double)b[i]));
            maxdiff = fmax(maxdiff, fabs((double)a[i] - (double)b[i]));
        }
        double e = maxdiff / (maxref > 0.0 ? maxref : 1.0);
        worst = fmax(worst, e);
    }
    return worst;
}

#endif
