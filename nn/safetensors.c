/*
 * safetensors reader (https://github.com/huggingface/safetensors, format described in its
 * README): an 8-byte little-endian header length N, N bytes of JSON mapping tensor names
 * to {"dtype", "shape", "data_offsets": [begin, end]} (offsets relative to the byte after
 * the header) plus an optional "__metadata__" object of strings, then the data.
 *
 * A file is trusted only after every claim in its header has been checked against the
 * file itself, so a truncated or lying file is an error message, never an out-of-bounds
 * read later.
 */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "nn/nn.h"

static void set_err(char *err, size_t errlen, const char *fmt, ...)
{
    if (!err || !errlen)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
}

static size_t dtype_size(nn_dtype t)
{
    return t == NN_F32 ? 4 : 2;
}

static int parse_dtype(const char *s, nn_dtype *t)
{
    if (!strcmp(s, "F32"))
        *t = NN_F32;
    else if (!strcmp(s, "F16"))
        *t = NN_F16;
    else if (!strcmp(s, "BF16"))
        *t = NN_BF16;
    else
        return -1;
    return 0;
}

/* A JSON number that is a non-negative integer below 2^53 (exact in a double). */
static int json_uint(const cJSON *j, uint64_t *v)
{
    if (!cJSON_IsNumber(j))
        return -1;
    double d = j->valuedouble;
    if (!(d >= 0.0) || d > 9007199254740992.0 || floor(d) != d)
        return -1;
    *v = (uint64_t)d;
    return 0;
}

static int cmp_begin(const void *a, const void *b)
{
    const nn_tensor_info *x = a, *y = b;
    return x->begin < y->begin ? -1 : x->begin > y->begin;
}

static int parse_header(nn_safetensors *st, const char *json, size_t len, char *err,
                        size_t errlen)
{
    const char *path = st->path;
    cJSON *root = cJSON_ParseWithLength(json, len);
    if (!root) {
        set_err(err, errlen, "%s: header is not valid JSON (near byte %ld of the header)", path,
                (long)(cJSON_GetErrorPtr() ? cJSON_GetErrorPtr() - json : 0));
        return -1;
    }
    if (!cJSON_IsObject(root)) {
        set_err(err, errlen, "%s: header is not a JSON object", path);
        cJSON_Delete(root);
        return -1;
    }
    int n = 0;
    for (const cJSON *it = root->child; it; it = it->next)
        n += strcmp(it->string, "__metadata__") != 0;
    st->tensors = calloc(n ? (size_t)n : 1, sizeof *st->tensors);
    if (!st->tensors) {
        set_err(err, errlen, "%s: out of memory", path);
        cJSON_Delete(root);
        return -1;
    }
    int i = 0;
    for (const cJSON *it = root->child; it; it = it->next) {
        const char *name = it->string;
        if (!strcmp(name, "__metadata__")) {
            if (!cJSON_IsObject(it)) {
                set_err(err, errlen, "%s: \"__metadata__\" is not an object", path);
                goto fail;
            }
            continue;
        }
        nn_tensor_info *t = &st->tensors[i];
        if (strlen(name) >= sizeof t->name) {
            set_err(err, errlen, "%s: tensor name \"%.40s...\" is longer than %zu bytes", path,
                    name, sizeof t->name - 1);
            goto fail;
        }
        strcpy(t->name, name);
        const cJSON *dt = cJSON_GetObjectItemCaseSensitive(it, "dtype");
        const cJSON *sh = cJSON_GetObjectItemCaseSensitive(it, "shape");
        const cJSON *off = cJSON_GetObjectItemCaseSensitive(it, "data_offsets");
        if (!cJSON_IsObject(it) || !cJSON_IsString(dt) || !cJSON_IsArray(sh) ||
            !cJSON_IsArray(off)) {
            set_err(err, errlen,
                    "%s: tensor \"%s\": expected an object with \"dtype\" (string), \"shape\" "
                    "and \"data_offsets\" (arrays)",
                    path, name);
            goto fail;
        }
        if (parse_dtype(dt->valuestring, &t->dtype)) {
            set_err(err, errlen, "%s: tensor \"%s\": dtype \"%s\" is not supported (F32, F16, BF16)",
                    path, name, dt->valuestring);
            goto fail;
        }
        int nd = cJSON_GetArraySize(sh);
        if (nd > 8) {
            set_err(err, errlen, "%s: tensor \"%s\": %d dimensions (at most 8)", path, name, nd);
            goto fail;
        }
        t->ndim = nd;
        /* Element count, refusing overflow: each dimension < 2^53 and the running product
         * checked before it can exceed the file size. */
        uint64_t count = 1;
        for (int d = 0; d < nd; d++) {
            uint64_t v;
            if (json_uint(cJSON_GetArrayItem(sh, d), &v)) {
                set_err(err, errlen, "%s: tensor \"%s\": shape[%d] is not a non-negative integer",
                        path, name, d);
                goto fail;
            }
            t->shape[d] = (int64_t)v;
            if (v && count > st->data_size / v) {
                set_err(err, errlen, "%s: tensor \"%s\": shape is larger than the file", path,
                        name);
                goto fail;
            }
            count *= v;
        }
        uint64_t b, e;
        if (cJSON_GetArraySize(off) != 2 || json_uint(cJSON_GetArrayItem(off, 0), &b) ||
            json_uint(cJSON_GetArrayItem(off, 1), &e) || e < b) {
            set_err(err, errlen,
                    "%s: tensor \"%s\": data_offsets must be [begin, end] with 0 <= begin <= end",
                    path, name);
            goto fail;
        }
        if (e > st->data_size) {
            set_err(err, errlen,
                    "%s: tensor \"%s\": data_offsets [%llu, %llu] run past the end of the data "
                    "(%zu bytes)",
                    path, name, (unsigned long long)b, (unsigned long long)e, st->data_size);
            goto fail;
        }
        if (e - b != count * dtype_size(t->dtype)) {
            set_err(err, errlen,
                    "%s: tensor \"%s\": data_offsets span %llu bytes but dtype %s and its shape "
                    "need %llu",
                    path, name, (unsigned long long)(e - b), dt->valuestring,
                    (unsigned long long)(count * dtype_size(t->dtype)));
            goto fail;
        }
        t->begin = b;
        t->end = e;
        i++;
    }
    st->count = n;
    cJSON_Delete(root);

    /* Non-overlapping: sort a copy by begin and compare neighbours. Empty tensors occupy
     * no bytes and overlap nothing. */
    nn_tensor_info *sorted = malloc((n ? (size_t)n : 1) * sizeof *sorted);
    if (!sorted) {
        set_err(err, errlen, "%s: out of memory", path);
        return -1;
    }
    memcpy(sorted, st->tensors, (size_t)n * sizeof *sorted);
    qsort(sorted, (size_t)n, sizeof *sorted, cmp_begin);
    const nn_tensor_info *prev = NULL;
    for (int k = 0; k < n; k++) {
        if (sorted[k].begin == sorted[k].end)
            continue;
        if (prev && sorted[k].begin < prev->end) {
            set_err(err, errlen, "%s: tensors \"%s\" and \"%s\" overlap in the data section", path,
                    prev->name, sorted[k].name);
            free(sorted);
            return -1;
        }
        prev = &sorted[k];
    }
    free(sorted);
    return 0;
fail:
    cJSON_Delete(root);
    return -1;
}

int nn_safetensors_open(const char *path, nn_safetensors *st, char *err, size_t errlen)
{
    memset(st, 0, sizeof *st);
    snprintf(st->path, sizeof st->path, "%s", path);
    FILE *f = fopen(path, "rb");
    if (!f) {
        set_err(err, errlen, "%s: %s", path, strerror(errno));
        return -1;
    }
    if (fseek(f, 0, SEEK_END) || ftell(f) < 0) {
        set_err(err, errlen, "%s: cannot determine the file size", path);
        fclose(f);
        return -1;
    }
    st->file_size = (size_t)ftell(f);
    rewind(f);
    st->file = malloc(st->file_size ? st->file_size : 1);
    if (!st->file) {
        set_err(err, errlen, "%s: out of memory for %zu bytes", path, st->file_size);
        fclose(f);
        return -1;
    }
    if (fread(st->file, 1, st->file_size, f) != st->file_size) {
        set_err(err, errlen, "%s: read error", path);
        fclose(f);
        nn_safetensors_close(st);
        return -1;
    }
    fclose(f);
    if (st->file_size < 8) {
        set_err(err, errlen, "%s: %zu bytes, too short for a safetensors header length", path,
                st->file_size);
        nn_safetensors_close(st);
        return -1;
    }
    uint64_t hlen = 0;
    for (int k = 7; k >= 0; k--)
        hlen = hlen << 8 | st->file[k];
    if (hlen > st->file_size - 8) {
        set_err(err, errlen, "%s: header length %llu runs past the end of the file (%zu bytes)",
                path, (unsigned long long)hlen, st->file_size);
        nn_safetensors_close(st);
        return -1;
    }
    st->data = st->file + 8 + hlen;
    st->data_size = st->file_size - 8 - (size_t)hlen;
    if (parse_header(st, (const char *)st->file + 8, (size_t)hlen, err, errlen)) {
        nn_safetensors_close(st);
        return -1;
    }
    return 0;
}

void nn_safetensors_close(nn_safetensors *st)
{
    free(st->file);
    free(st->tensors);
    st->file = NULL;
    st->tensors = NULL;
    st->count = 0;
}

int nn_safetensors_find(const nn_safetensors *st, const char *name)
{
    for (int i = 0; i < st->count; i++)
        if (!strcmp(st->tensors[i].name, name))
            return i;
    return -1;
}

int nn_safetensors_read_f32(const nn_safetensors *st, const char *name, int ndim,
                            const int64_t *shape, float *out, char *err, size_t errlen)
{
    int i = nn_safetensors_find(st, name);
    if (i < 0) {
        set_err(err, errlen, "%s: no tensor \"%s\"", st->path, name);
        return -1;
    }
    const nn_tensor_info *t = &st->tensors[i];
    int same = t->ndim == ndim;
    for (int d = 0; same && d < ndim; d++)
        same = t->shape[d] == shape[d];
    if (!same) {
        char want[128] = "", got[128] = "";
        for (int d = 0; d < ndim; d++)
            snprintf(want + strlen(want), sizeof want - strlen(want), "%s%lld", d ? "," : "",
                     (long long)shape[d]);
        for (int d = 0; d < t->ndim; d++)
            snprintf(got + strlen(got), sizeof got - strlen(got), "%s%lld", d ? "," : "",
                     (long long)t->shape[d]);
        set_err(err, errlen, "%s: tensor \"%s\" has shape (%s), expected (%s)", st->path, name,
                got, want);
        return -1;
    }
    const unsigned char *p = st->data + t->begin;
    size_t n = (t->end - t->begin) / dtype_size(t->dtype);
    for (size_t k = 0; k < n; k++) {
        uint32_t bits;
        switch (t->dtype) {
        case NN_F32:
            bits = (uint32_t)p[4 * k] | (uint32_t)p[4 * k + 1] << 8 |
                   (uint32_t)p[4 * k + 2] << 16 | (uint32_t)p[4 * k + 3] << 24;
            memcpy(&out[k], &bits, 4);
            break;
        case NN_F16:
            out[k] = nn_half_to_float((uint16_t)(p[2 * k] | p[2 * k + 1] << 8));
            break;
        case NN_BF16:
            bits = ((uint32_t)p[2 * k] | (uint32_t)p[2 * k + 1] << 8) << 16;
            memcpy(&out[k], &bits, 4);
            break;
        }
    }
    return 0;
}

/* ---------------------------------------------------------------- writer ---------- */

/* JSON-escape s into f (names are ours, but metadata values may hold anything). */
static void write_json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(f, "\\%c", c);
        else if (c < 0x20)
            fprintf(f, "\\u%04x", c);
        else
            fputc(c, f);
    }
    fputc('"', f);
}

int nn_safetensors_write(const char *path, const nn_tensor_out *tensors, int n,
                         const char *const *meta_kv, int n_meta, char *err, size_t errlen)
{
    // The header is built in memory first (its length comes before it), padded with
    // spaces to a multiple of 8 bytes as the reference implementation does, so the data
    // section starts aligned.
    char *json = NULL;
    size_t json_len = 0;
    FILE *h = open_memstream(&json, &json_len);
    if (!h) {
        set_err(err, errlen, "%s: out of memory for the header", path);
        return -1;
    }
    fputc('{', h);
    if (n_meta) {
        fputs("\"__metadata__\":{", h);
        for (int k = 0; k < n_meta; k++) {
            if (k)
                fputc(',', h);
            write_json_string(h, meta_kv[2 * k]);
            fputc(':', h);
            write_json_string(h, meta_kv[2 * k + 1]);
        }
        fputc('}', h);
    }
    uint64_t offset = 0;
    for (int i = 0; i < n; i++) {
        const nn_tensor_out *t = &tensors[i];
        uint64_t count = 1;
        if (n_meta || i)
            fputc(',', h);
        write_json_string(h, t->name);
        unsigned size = t->dtype == NN_F16 ? 2 : 4;
        fprintf(h, ":{\"dtype\":\"%s\",\"shape\":[", size == 2 ? "F16" : "F32");
        for (int d = 0; d < t->ndim; d++) {
            fprintf(h, "%s%lld", d ? "," : "", (long long)t->shape[d]);
            count *= (uint64_t)t->shape[d];
        }
        fprintf(h, "],\"data_offsets\":[%llu,%llu]}", (unsigned long long)offset,
                (unsigned long long)(offset + size * count));
        offset += size * count;
    }
    fputc('}', h);
    if (fclose(h)) {
        free(json);
        set_err(err, errlen, "%s: out of memory for the header", path);
        return -1;
    }
    size_t padded = (json_len + 7) / 8 * 8;

    char tmp[1024];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *f = fopen(tmp, "wb");
    if (!f) {
        set_err(err, errlen, "%s: %s", tmp, strerror(errno));
        free(json);
        return -1;
    }
    unsigned char len8[8];
    for (int k = 0; k < 8; k++)
        len8[k] = (unsigned char)((uint64_t)padded >> (8 * k));
    int ok = fwrite(len8, 1, 8, f) == 8 && fwrite(json, 1, json_len, f) == json_len;
    for (size_t k = json_len; ok && k < padded; k++)
        ok = fputc(' ', f) != EOF;
    free(json);
    for (int i = 0; ok && i < n; i++) {
        const nn_tensor_out *t = &tensors[i];
        size_t count = 1;
        for (int d = 0; d < t->ndim; d++)
            count *= (size_t)t->shape[d];
        // little-endian float32 or float16, byte by byte so the file is the same on any host
        unsigned char buf[4096];
        size_t k = 0, size = t->dtype == NN_F16 ? 2 : 4;
        while (ok && k < count) {
            size_t chunk = count - k < sizeof buf / size ? count - k : sizeof buf / size;
            for (size_t q = 0; q < chunk; q++) {
                uint32_t bits;
                if (size == 2)
                    bits = nn_float_to_half(t->data[k + q]);
                else
                    memcpy(&bits, &t->data[k + q], 4);
                for (size_t b = 0; b < size; b++)
                    buf[size * q + b] = (unsigned char)(bits >> (8 * b));
            }
            ok = fwrite(buf, size, chunk, f) == chunk;
            k += chunk;
        }
    }
    /* fwrite's failure sets errno, and fclose fails again flushing the rest. */
    if (fclose(f) || !ok) {
        set_err(err, errlen, "%s: write error: %s", tmp, strerror(errno ? errno : EIO));
        remove(tmp);
        return -1;
    }
    if (rename(tmp, path)) {
        set_err(err, errlen, "%s: cannot rename %s into place: %s", path, tmp, strerror(errno));
        remove(tmp);
        return -1;
    }
    return 0;
}

int nn_safetensors_metadata(const nn_safetensors *st, const char *key, char *value, size_t len)
{
    // The reader validated the header; here it is parsed again for one string of
    // "__metadata__" (checkpoints read a handful of keys once, so no cache is kept).
    uint64_t hlen = 0;
    for (int k = 7; k >= 0; k--)
        hlen = hlen << 8 | st->file[k];
    cJSON *root = cJSON_ParseWithLength((const char *)st->file + 8, (size_t)hlen);
    const cJSON *meta = root ? cJSON_GetObjectItemCaseSensitive(root, "__metadata__") : NULL;
    const cJSON *v = meta ? cJSON_GetObjectItemCaseSensitive(meta, key) : NULL;
    int rc = -1;
    if (cJSON_IsString(v) && strlen(v->valuestring) < len) {
        strcpy(value, v->valuestring);
        rc = 0;
    }
    cJSON_Delete(root);
    return rc;
}
