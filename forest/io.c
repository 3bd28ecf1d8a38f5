/*
 * Saving and loading a fitted forest.
 *
 * Format (little-endian, version 1):
 *   "IMSYFRST" | u32 version | u32 0 | u64 d | u64 k | u64 n_trees
 *   per tree: u64 n_nodes | n_nodes nodes of 48 bytes (i32 left, right, feature,
 *             n_samples; f64 threshold, weighted_n, impurity, wimpurity) |
 *             n_nodes x k f32 values
 *   u64 FNV-1a hash of every byte before it
 * A loader trusts nothing: every count is checked against the bytes that remain before
 * anything is allocated, every child index must point forward inside its tree, every
 * split feature must exist, and the hash must match.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "forest/forest_impl.h"

/* Fields are written as they lie in memory, which is the format's little-endian order. */
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "forest/io.c writes native byte order; add byte swapping for big-endian hosts"
#endif

#define FO_MAGIC "IMSYFRST"
enum { FO_VERSION = 1, FO_HEADER_BYTES = 40, FO_NODE_BYTES = 48 };

static uint64_t fnv1a(uint64_t h, const unsigned char *p, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}
#define FNV_OFFSET 0xcbf29ce484222325ull

typedef struct writer {
    FILE *fp;
    uint64_t hash;
    int failed;
} writer;

static void put(writer *w, const void *p, size_t n)
{
    if (w->failed)
        return;
    w->hash = fnv1a(w->hash, p, n);
    if (fwrite(p, 1, n, w->fp) != n)
        w->failed = 1;
}

static void put_u64(writer *w, uint64_t v) { put(w, &v, sizeof v); }

int forest_save(const forest *f, const char *path, char *err, size_t errlen)
{
    size_t plen = strlen(path);
    char *tmp = malloc(plen + 16);
    if (!tmp) {
        snprintf(err, errlen, "%s: out of memory", path);
        return -1;
    }
    snprintf(tmp, plen + 16, "%s.tmpXXXXXX", path);
    int fd = mkstemp(tmp);
    if (fd < 0) {
        snprintf(err, errlen, "%s: cannot create a temporary file: %s", path, strerror(errno));
        free(tmp);
        return -1;
    }
    writer w = {fdopen(fd, "wb"), FNV_OFFSET, 0};
    if (!w.fp) {
        close(fd);
        unlink(tmp);
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        free(tmp);
        return -1;
    }
    uint32_t version = FO_VERSION, zero = 0;
    put(&w, FO_MAGIC, 8);
    put(&w, &version, 4);
    put(&w, &zero, 4);
    put_u64(&w, f->d);
    put_u64(&w, f->k);
    put_u64(&w, (uint64_t)f->n_trees);
    for (int t = 0; t < f->n_trees && !w.failed; t++) {
        const fo_tree *tr = &f->trees[t];
        put_u64(&w, (uint64_t)tr->n_nodes);
        for (int32_t i = 0; i < tr->n_nodes; i++) {
            const fo_node *nd = &tr->nodes[i];
            unsigned char b[FO_NODE_BYTES];
            memcpy(b, &nd->left, 4);
            memcpy(b + 4, &nd->right, 4);
            memcpy(b + 8, &nd->feature, 4);
            memcpy(b + 12, &nd->n_samples, 4);
            memcpy(b + 16, &nd->threshold, 8);
            memcpy(b + 24, &nd->weighted_n, 8);
            memcpy(b + 32, &nd->impurity, 8);
            memcpy(b + 40, &nd->wimpurity, 8);
            put(&w, b, sizeof b);
        }
        put(&w, tr->values, (size_t)tr->n_nodes * f->k * sizeof *tr->values);
    }
    uint64_t h = w.hash;
    put(&w, &h, 8);
    int bad = w.failed;
    if (fflush(w.fp) || fsync(fileno(w.fp)))
        bad = 1;
    if (fclose(w.fp))
        bad = 1;
    if (bad || rename(tmp, path)) {
        snprintf(err, errlen, "%s: write failed: %s", path, strerror(errno));
        unlink(tmp);
        free(tmp);
        return -1;
    }
    free(tmp);
    return 0;
}

typedef struct reader {
    const unsigned char *p;
    size_t size, at;
} reader;

static int take(reader *r, void *out, size_t n)
{
    if (r->size - r->at < n)
        return -1;
    memcpy(out, r->p + r->at, n);
    r->at += n;
    return 0;
}

int forest_load(const char *path, forest **out, char *err, size_t errlen)
{
    *out = NULL;
    FILE *fp = fopen(path, "rb");
    if (!fp) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        return -1;
    }
    unsigned char *buf = NULL;
    forest *f = NULL;
    int rc = -1;
    long size = -1;
    if (fseek(fp, 0, SEEK_END) == 0)
        size = ftell(fp);
    if (size < 0 || fseek(fp, 0, SEEK_SET)) {
        snprintf(err, errlen, "%s: cannot determine the file's size", path);
        goto done;
    }
    if (size < FO_HEADER_BYTES + 8) {
        snprintf(err, errlen, "%s: truncated: %ld bytes, a forest file has at least %d", path,
                 size, FO_HEADER_BYTES + 8);
        goto done;
    }
    buf = malloc((size_t)size);
    if (!buf) {
        snprintf(err, errlen, "%s: out of memory reading %ld bytes", path, size);
        goto done;
    }
    if (fread(buf, 1, (size_t)size, fp) != (size_t)size) {
        snprintf(err, errlen, "%s: read error", path);
        goto done;
    }
    if (memcmp(buf, FO_MAGIC, 8)) {
        snprintf(err, errlen, "%s: not an imsynth forest (bad magic at byte 0)", path);
        goto done;
    }
    reader r = {buf, (size_t)size - 8, 8}; /* the last 8 bytes are the hash */
    uint32_t version, zero;
    uint64_t d, k, n_trees;
    take(&r, &version, 4);
    take(&r, &zero, 4);
    take(&r, &d, 8);
    take(&r, &k, 8);
    take(&r, &n_trees, 8);
    if (version != FO_VERSION) {
        snprintf(err, errlen, "%s: format version %u, this build reads version %d", path,
                 version, FO_VERSION);
        goto done;
    }
    if (d < 1 || d > INT32_MAX || k < 1 || k > (1u << 20) || n_trees < 1 ||
        n_trees > (1u << 24)) {
        snprintf(err, errlen,
                 "%s: header at byte 16 claims %llu features, %llu outputs, %llu trees", path,
                 (unsigned long long)d, (unsigned long long)k, (unsigned long long)n_trees);
        goto done;
    }
    /* Every tree needs at least 8 + one node: a lying count shows before allocation. */
    if (n_trees > (r.size - r.at) / (8 + FO_NODE_BYTES + 4 * k)) {
        snprintf(err, errlen, "%s: truncated: header claims %llu trees, only %zu bytes follow",
                 path, (unsigned long long)n_trees, r.size - r.at);
        goto done;
    }
    uint64_t h_stored, h = fnv1a(FNV_OFFSET, buf, (size_t)size - 8);
    memcpy(&h_stored, buf + size - 8, 8);
    f = calloc(1, sizeof *f);
    if (!f || !(f->trees = calloc((size_t)n_trees, sizeof *f->trees))) {
        snprintf(err, errlen, "%s: out of memory", path);
        goto done;
    }
    f->d = (size_t)d;
    f->k = (size_t)k;
    for (uint64_t t = 0; t < n_trees; t++) {
        uint64_t nn;
        size_t at = r.at;
        if (take(&r, &nn, 8)) {
            snprintf(err, errlen, "%s: truncated at byte %zu (tree %llu of %llu)", path, at,
                     (unsigned long long)t, (unsigned long long)n_trees);
            goto done;
        }
        size_t per_node = FO_NODE_BYTES + 4 * (size_t)k;
        if (nn < 1 || nn > INT32_MAX || nn > (r.size - r.at) / per_node) {
            snprintf(err, errlen,
                     "%s: truncated: tree %llu at byte %zu claims %llu nodes (%zu bytes each), "
                     "only %zu bytes follow",
                     path, (unsigned long long)t, at, (unsigned long long)nn, per_node,
                     r.size - r.at);
            goto done;
        }
        fo_tree *tr = &f->trees[t];
        f->n_trees = (int)t + 1; /* so forest_free frees what was allocated */
        tr->nodes = malloc((size_t)nn * sizeof *tr->nodes);
        tr->values = malloc((size_t)nn * (size_t)k * sizeof *tr->values);
        if (!tr->nodes || !tr->values) {
            snprintf(err, errlen, "%s: out of memory (tree %llu)", path, (unsigned long long)t);
            goto done;
        }
        tr->n_nodes = (int32_t)nn;
        for (int32_t i = 0; i < tr->n_nodes; i++) {
            fo_node *nd = &tr->nodes[i];
            size_t node_at = r.at;
            take(&r, &nd->left, 4);
            take(&r, &nd->right, 4);
            take(&r, &nd->feature, 4);
            take(&r, &nd->n_samples, 4);
            take(&r, &nd->threshold, 8);
            take(&r, &nd->weighted_n, 8);
            take(&r, &nd->impurity, 8);
            take(&r, &nd->wimpurity, 8);
            int leaf_ok = nd->left == -1 && nd->right == -1 && nd->feature == -1;
            int split_ok = nd->left > i && nd->left < tr->n_nodes && nd->right > i &&
                           nd->right < tr->n_nodes && nd->feature >= 0 &&
                           (uint64_t)nd->feature < d && isfinite(nd->threshold);
            if (!leaf_ok && !split_ok) {
                snprintf(err, errlen,
                         "%s: tree %llu node %d at byte %zu is invalid (children %d, %d, "
                         "feature %d of %llu)",
                         path, (unsigned long long)t, i, node_at, nd->left, nd->right,
                         nd->feature, (unsigned long long)d);
                goto done;
            }
        }
        size_t vbytes = (size_t)nn * (size_t)k * sizeof *tr->values;
        size_t values_at = r.at;
        take(&r, tr->values, vbytes);
        for (size_t i = 0; i < (size_t)nn * (size_t)k; i++)
            if (!isfinite(tr->values[i])) {
                snprintf(err, errlen, "%s: tree %llu: value at byte %zu is not finite", path,
                         (unsigned long long)t, values_at + 4 * i);
                goto done;
            }
    }
    if (r.at != r.size) {
        snprintf(err, errlen, "%s: %zu unexpected bytes after the last tree (byte %zu)", path,
                 r.size - r.at, r.at);
        goto done;
    }
    if (h != h_stored) {
        snprintf(err, errlen, "%s: checksum mismatch (the file is corrupt)", path);
        goto done;
    }
    *out = f;
    f = NULL;
    rc = 0;
done:
    forest_free(f);
    free(buf);
    fclose(fp);
    return rc;
}
