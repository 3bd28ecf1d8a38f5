/* Reading a dataset (store.c has the schema): info, rows, merge, .npy export, contact sheet. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "nn/nn.h"
#include "pipeline/store.h"
/* Last: OpenBLAS's config defines a macro I (complex.h). */
#include <cblas.h>

struct dataset {
    char *path;
    sqlite3 *db;
    char *config;
    int n_params;
    char **names;
    size_t descriptor_size;
    char tmpdir[512];
};

void dataset_close(dataset *d)
{
    if (!d)
        return;
    sqlite3_close(d->db);
    for (int k = 0; k < d->n_params; k++)
        free(d->names[k]);
    free(d->names);
    free(d->config);
    free(d->path);
    free(d);
}

dataset *dataset_open(const char *path, char *err, size_t errlen)
{
    if (access(path, R_OK) != 0) {
        pipeline_error(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return NULL;
    }
    dataset *d = calloc(1, sizeof *d);
    if (!d || !(d->path = strdup(path))) {
        free(d);
        pipeline_error(err, errlen, "out of memory");
        return NULL;
    }
    const char *t = getenv("TMPDIR");
    snprintf(d->tmpdir, sizeof d->tmpdir, "%s", t && *t ? t : "/tmp");
    char *names = NULL;
    cJSON *arr = NULL, *cfg = NULL;
    if (!(d->db = store_connect(path, SQLITE_OPEN_READONLY, err, errlen)) ||
        store_check_schema(d->db, path, err, errlen) ||
        !(d->config = store_meta_get(d->db, path, "config", err, errlen)) ||
        !(names = store_meta_get(d->db, path, "params", err, errlen)))
        goto fail;
    arr = cJSON_Parse(names);
    cfg = cJSON_Parse(d->config);
    if (!cJSON_IsArray(arr) || !cJSON_IsObject(cfg)) {
        pipeline_error(err, errlen, "%s: meta 'params' or 'config' is not valid JSON", path);
        goto fail;
    }
    d->n_params = cJSON_GetArraySize(arr);
    d->names = calloc((size_t)(d->n_params ? d->n_params : 1), sizeof *d->names);
    if (!d->names)
        goto fail;
    for (int k = 0; k < d->n_params; k++) {
        const char *s = cJSON_GetStringValue(cJSON_GetArrayItem(arr, k));
        if (!s || !(d->names[k] = strdup(s))) {
            pipeline_error(err, errlen, "%s: meta 'params'[%d] is not a string", path, k);
            goto fail;
        }
    }
    const cJSON *desc = cJSON_GetObjectItemCaseSensitive(cfg, "descriptor");
    const cJSON *size = cJSON_GetObjectItemCaseSensitive(desc, "size");
    if (cJSON_IsNumber(size) && size->valuedouble > 0 && size->valuedouble < 1e8)
        d->descriptor_size = (size_t)size->valuedouble;
    cJSON_Delete(arr);
    cJSON_Delete(cfg);
    free(names);
    return d;
fail:
    cJSON_Delete(arr);
    cJSON_Delete(cfg);
    free(names);
    dataset_close(d);
    return NULL;
}

const char *const *dataset_param_names(const dataset *d) { return (const char *const *)d->names; }

static int query_ll(sqlite3 *db, const char *sql, long long *out)
{
    sqlite3_stmt *st = NULL;
    if (sqlite3_prepare_v2(db, sql, -1, &st, NULL) != SQLITE_OK)
        return -1;
    int rc = sqlite3_step(st);
    if (rc == SQLITE_ROW)
        *out = sqlite3_column_type(st, 0) == SQLITE_NULL ? -1 : sqlite3_column_int64(st, 0);
    sqlite3_finalize(st);
    return rc == SQLITE_ROW ? 0 : -1;
}

int dataset_get_info(dataset *d, dataset_info *info, char *err, size_t errlen)
{
    memset(info, 0, sizeof *info);
    if (query_ll(d->db, "SELECT COUNT(DISTINCT id) FROM samples", &info->samples) ||
        query_ll(d->db, "SELECT COUNT(*) FROM samples", &info->rows) ||
        query_ll(d->db, "SELECT MIN(id) FROM samples", &info->min_id) ||
        query_ll(d->db, "SELECT MAX(id) FROM samples", &info->max_id))
        return pipeline_error(err, errlen, "%s: %s", d->path, sqlite3_errmsg(d->db));
    long long pages = 0, page_size = 0;
    query_ll(d->db, "PRAGMA page_count", &pages);
    query_ll(d->db, "PRAGMA page_size", &page_size);
    info->file_bytes = pages * page_size;
    info->n_params = d->n_params;
    info->descriptor_size = d->descriptor_size;
    char *h = store_meta_get(d->db, d->path, "config_hash", err, errlen);
    if (!h)
        return -1;
    snprintf(info->config_hash, sizeof info->config_hash, "%s", h);
    free(h);
    info->config_json = strdup(d->config);
    return info->config_json ? 0 : pipeline_error(err, errlen, "out of memory");
}

void dataset_info_free(dataset_info *info)
{
    free(info->config_json);
    info->config_json = NULL;
}

/* ---------------------------------------------------------------- rows ------------- */

struct dataset_iter {
    dataset *d;
    sqlite3_stmt *st;
    int want_descriptor, want_image;
    float *params, *descriptor;
    uint8_t *active;
    char *view_json;
    image img;
};

dataset_iter *dataset_iter_new(dataset *d, int want_descriptor, int want_image, char *err,
                               size_t errlen)
{
    dataset_iter *it = calloc(1, sizeof *it);
    if (!it) {
        pipeline_error(err, errlen, "out of memory");
        return NULL;
    }
    it->d = d;
    it->want_descriptor = want_descriptor && d->descriptor_size;
    it->want_image = want_image;
    it->params = malloc((size_t)(d->n_params + 1) * sizeof(float));
    it->active = malloc((size_t)d->n_params + 1);
    if (it->want_descriptor)
        it->descriptor = malloc(d->descriptor_size * sizeof(float));
    char sql[256];
    snprintf(sql, sizeof sql,
             "SELECT id, view, params, active, subshader_nodes, view_json, %s, %s FROM samples "
             "ORDER BY id, view",
             want_image ? "image" : "NULL", it->want_descriptor ? "descriptor" : "NULL");
    if (!it->params || !it->active || (it->want_descriptor && !it->descriptor) ||
        sqlite3_prepare_v2(d->db, sql, -1, &it->st, NULL) != SQLITE_OK) {
        pipeline_error(err, errlen, "%s: %s", d->path, sqlite3_errmsg(d->db));
        dataset_iter_free(it);
        return NULL;
    }
    return it;
}

void dataset_iter_free(dataset_iter *it)
{
    if (!it)
        return;
    sqlite3_finalize(it->st);
    free(it->params);
    free(it->active);
    free(it->descriptor);
    free(it->view_json);
    image_free(&it->img);
    free(it);
}

/* Decodes an image blob (PNG or EXR file bytes) through a temporary file. */
static int decode_image(const dataset *d, const void *bytes, int len, image *img, long long id,
                        char *err, size_t errlen)
{
    char path[700];
    snprintf(path, sizeof path, "%s/imsynth-dataset-%ld.%s", d->tmpdir, (long)getpid(),
             len >= 4 && !memcmp(bytes, "\x76\x2f\x31\x01", 4) ? "exr" : "png");
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(bytes, 1, (size_t)len, f) != (size_t)len) {
        if (f)
            fclose(f);
        unlink(path);
        return pipeline_error(err, errlen, "%s: cannot write a temporary file", path);
    }
    fclose(f);
    char msg[768];
    int rc = image_read(path, img, msg, sizeof msg);
    unlink(path);
    if (rc < 0)
        return pipeline_error(err, errlen, "%s: id %lld: stored image: %s", d->path, id, msg);
    return 0;
}

int dataset_iter_next(dataset_iter *it, dataset_row *row, char *err, size_t errlen)
{
    memset(row, 0, sizeof *row);
    int rc = sqlite3_step(it->st);
    if (rc == SQLITE_DONE)
        return 0;
    const dataset *d = it->d;
    if (rc != SQLITE_ROW)
        return pipeline_error(err, errlen, "%s: %s", d->path, sqlite3_errmsg(d->db));
    row->id = sqlite3_column_int64(it->st, 0);
    row->view = sqlite3_column_int(it->st, 1);
    int np = sqlite3_column_bytes(it->st, 2), na = sqlite3_column_bytes(it->st, 3);
    if (np != d->n_params * (int)sizeof(float) || na != d->n_params)
        return pipeline_error(err, errlen,
                              "%s: id %lld view %d: params/active blobs of %d/%d bytes, "
                              "expected %d/%d",
                              d->path, row->id, row->view, np, na,
                              d->n_params * (int)sizeof(float), d->n_params);
    memcpy(it->params, sqlite3_column_blob(it->st, 2), (size_t)np);
    memcpy(it->active, sqlite3_column_blob(it->st, 3), (size_t)na);
    row->params = it->params;
    row->active = it->active;
    row->subshader_nodes = sqlite3_column_int(it->st, 4);
    free(it->view_json);
    const char *vj = (const char *)sqlite3_column_text(it->st, 5);
    it->view_json = strdup(vj ? vj : "{}");
    row->view_json = it->view_json;
    if (it->want_descriptor) {
        int nd = sqlite3_column_bytes(it->st, 7);
        const unsigned char *p = sqlite3_column_blob(it->st, 7);
        if (!p || nd != (int)(d->descriptor_size * 2))
            return pipeline_error(err, errlen,
                                  "%s: id %lld view %d: descriptor of %d bytes, expected %zu",
                                  d->path, row->id, row->view, nd, d->descriptor_size * 2);
        for (size_t i = 0; i < d->descriptor_size; i++)
            it->descriptor[i] = nn_half_to_float((uint16_t)(p[2 * i] | p[2 * i + 1] << 8));
        row->descriptor = it->descriptor;
    }
    if (it->want_image) {
        image_free(&it->img);
        int ni = sqlite3_column_bytes(it->st, 6);
        const void *p = sqlite3_column_blob(it->st, 6);
        if (!p)
            return pipeline_error(err, errlen, "%s: id %lld: no image stored (--images none)",
                                  d->path, row->id);
        if (decode_image(d, p, ni, &it->img, row->id, err, errlen))
            return -1;
        row->img = it->img;
    }
    return 1;
}

int dataset_digest(dataset *d, char out[65], char *err, size_t errlen)
{
    sqlite3_stmt *st = NULL;
    if (sqlite3_prepare_v2(d->db,
                           "SELECT id, view, params, active, subshader_nodes, view_json, image, "
                           "descriptor FROM samples ORDER BY id, view",
                           -1, &st, NULL) != SQLITE_OK)
        return pipeline_error(err, errlen, "%s: %s", d->path, sqlite3_errmsg(d->db));
    sha256_ctx c;
    sha256_init(&c);
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        for (int k = 0; k < 8; k++) {
            /* Each column as its type, its length and its bytes: no two rows collide by
             * moving bytes between columns. */
            int64_t v[2] = {sqlite3_column_type(st, k), 0};
            const void *p = NULL;
            if (v[0] == SQLITE_INTEGER)
                v[1] = sqlite3_column_int64(st, k);
            else if (v[0] != SQLITE_NULL) {
                p = v[0] == SQLITE_TEXT ? (const void *)sqlite3_column_text(st, k)
                                        : sqlite3_column_blob(st, k);
                v[1] = sqlite3_column_bytes(st, k);
            }
            sha256_update(&c, v, sizeof v);
            if (p)
                sha256_update(&c, p, (size_t)v[1]);
        }
    }
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE)
        return pipeline_error(err, errlen, "%s: %s", d->path, sqlite3_errmsg(d->db));
    sha256_final_hex(&c, out);
    return 0;
}

int dataset_read_arrays(dataset *d, float **X, float **Y, uint8_t **M, size_t *rows,
                        size_t *x_cols, size_t *y_cols, char *err, size_t errlen)
{
    *X = *Y = NULL;
    *M = NULL;
    dataset_info info;
    if (dataset_get_info(d, &info, err, errlen))
        return -1;
    dataset_info_free(&info);
    size_t n = (size_t)info.rows, nd = d->descriptor_size, np = (size_t)d->n_params;
    if (!nd)
        return pipeline_error(err, errlen, "%s: no descriptors stored (made with --descriptor "
                                           "none; add them with `imsynth dataset describe`)",
                              d->path);
    if (n == 0)
        return pipeline_error(err, errlen, "%s: no samples", d->path);
    float *x = malloc(n * nd * sizeof *x), *y = malloc(n * np * sizeof *y);
    uint8_t *m = malloc(n * np);
    dataset_iter *it = x && y && m ? dataset_iter_new(d, 1, 0, err, errlen) : NULL;
    if (!it) {
        if (!(x && y && m))
            pipeline_error(err, errlen, "%s: out of memory for %zu rows x %zu features", d->path,
                           n, nd);
        free(x);
        free(y);
        free(m);
        return -1;
    }
    size_t i = 0;
    dataset_row row;
    int got;
    while ((got = dataset_iter_next(it, &row, err, errlen)) == 1 && i < n) {
        memcpy(x + i * nd, row.descriptor, nd * sizeof *x);
        memcpy(y + i * np, row.params, np * sizeof *y);
        memcpy(m + i * np, row.active, np);
        i++;
    }
    dataset_iter_free(it);
    if (got < 0 || i != n) {
        if (got >= 0)
            pipeline_error(err, errlen, "%s: %zu rows read, %zu counted", d->path, i, n);
        free(x);
        free(y);
        free(m);
        return -1;
    }
    *X = x;
    *Y = y;
    *M = m;
    *rows = n;
    *x_cols = nd;
    *y_cols = np;
    return 0;
}

/* A failed merge or describe: roll back, close, and remove the temporary database with
 * its WAL and shared-memory files, so nothing half-written remains. */
static void discard_temporary(sqlite3 *db, const char *tmp)
{
    if (db) {
        sqlite3_exec(db, "ROLLBACK", NULL, NULL, NULL);
        sqlite3_close(db);
    }
    unlink(tmp);
    char side[1200];
    snprintf(side, sizeof side, "%s-wal", tmp);
    unlink(side);
    snprintf(side, sizeof side, "%s-shm", tmp);
    unlink(side);
}

/* ---------------------------------------------------------------- merge ------------ */

int dataset_merge(const char *const *inputs, int n_inputs, const char *out_path, char *err,
                  size_t errlen)
{
    if (n_inputs < 1)
        return pipeline_error(err, errlen, "merge: no input datasets");
    char tmp[1100];
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", out_path, (long)getpid());
    unlink(tmp);
    /* The first input fixes the config; every other must have the same hash. */
    char *hash0 = NULL, *cfg0 = NULL, *names0 = NULL;
    int rc = -1;
    sqlite3 *out = NULL;
    for (int i = 0; i < n_inputs; i++) {
        dataset *d = dataset_open(inputs[i], err, errlen);
        if (!d)
            goto done;
        char *h = store_meta_get(d->db, inputs[i], "config_hash", err, errlen);
        if (!h) {
            dataset_close(d);
            goto done;
        }
        if (i == 0) {
            hash0 = h;
            cfg0 = strdup(d->config);
            names0 = store_meta_get(d->db, inputs[i], "params", err, errlen);
        } else {
            int same = !strcmp(h, hash0);
            free(h);
            if (!same) {
                pipeline_error(err, errlen,
                               "merge: %s and %s were made with different configs (hashes "
                               "differ); refusing to mix them",
                               inputs[0], inputs[i]);
                dataset_close(d);
                goto done;
            }
        }
        dataset_close(d);
    }
    if (!cfg0 || !names0) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    if (!(out = store_open_for_writing(tmp, cfg0, names0, err, errlen)))
        goto done;
    for (int i = 0; i < n_inputs; i++) {
        char *sql = sqlite3_mprintf("ATTACH DATABASE %Q AS src", inputs[i]);
        int bad = store_exec(out, tmp, sql, err, errlen);
        sqlite3_free(sql);
        if (bad)
            goto done;
        long long dup = -1;
        query_ll(out, "SELECT s.id FROM src.samples s JOIN main.samples m USING(id, view) LIMIT 1",
                 &dup);
        if (dup >= 0) {
            pipeline_error(err, errlen, "merge: id %lld is in %s and in an earlier input", dup,
                           inputs[i]);
            goto done;
        }
        if (store_exec(out, tmp,
                       "BEGIN; INSERT INTO main.samples SELECT id, view, params, active, "
                       "subshader_nodes, view_json, image, descriptor FROM src.samples ORDER BY "
                       "id, view; COMMIT;",
                       err, errlen) ||
            store_exec(out, tmp, "DETACH DATABASE src", err, errlen))
            goto done;
    }
    /* One self-contained file: fold the WAL back in before the rename. */
    if (store_exec(out, tmp, "PRAGMA wal_checkpoint(TRUNCATE); PRAGMA journal_mode=DELETE;", err,
                   errlen))
        goto done;
    if (sqlite3_close(out) != SQLITE_OK) {
        out = NULL;
        pipeline_error(err, errlen, "%s: close failed", tmp);
        goto done;
    }
    out = NULL;
    if (rename(tmp, out_path) != 0) {
        pipeline_error(err, errlen, "%s: rename failed: %s", out_path, strerror(errno));
        goto done;
    }
    rc = 0;
done:
    if (rc)
        discard_temporary(out, tmp);
    free(hash0);
    free(cfg0);
    free(names0);
    return rc;
}

/* ---------------------------------------------------------------- describe --------- */

int dataset_describe(const char *src_path, const char *out_path, datagen_descriptor kind,
                     const char *mask_path, int threads, char *err, size_t errlen)
{
    dataset *d = dataset_open(src_path, err, errlen);
    if (!d)
        return -1;
    char tmp[1100];
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", out_path, (long)getpid());
    unlink(tmp);
    descriptor_config dc;
    descriptor_worker dw = {0};
    int rc = -1, have_dc = 0;
    sqlite3 *out = NULL;
    sqlite3_stmt *rd = NULL, *wr = NULL;
    cJSON *cfg = cJSON_Parse(d->config);
    char *cfg_text = NULL, *names = store_meta_get(d->db, src_path, "params", err, errlen);
    if (!cfg || !names)
        goto done;
    if (kind == DATAGEN_DESC_NONE) {
        pipeline_error(err, errlen, "describe: no descriptor asked for");
        goto done;
    }
    if (descriptor_config_init(&dc, kind, mask_path, err, errlen))
        goto done;
    have_dc = 1;
    dc.vgg.threads = threads > 0 ? threads : 1;
    /* As datagen: our own workers, OpenBLAS single-threaded (a threaded OpenBLAS splits its
     * sums differently, and the descriptor must be datagen's to the bit). */
    openblas_set_num_threads(1);
    if (descriptor_worker_init(&dw, &dc)) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    cJSON *desc = cJSON_CreateObject();
    descriptor_config_json(&dc, desc);
    cJSON_ReplaceItemInObjectCaseSensitive(cfg, "descriptor", desc);
    if (!(cfg_text = cJSON_PrintUnformatted(cfg)) ||
        !(out = store_open_for_writing(tmp, cfg_text, names, err, errlen)))
        goto done;
    if (sqlite3_prepare_v2(d->db,
                           "SELECT id, view, params, active, subshader_nodes, view_json, image "
                           "FROM samples ORDER BY id, view",
                           -1, &rd, NULL) != SQLITE_OK ||
        sqlite3_prepare_v2(out,
                           "INSERT INTO samples(id, view, params, active, subshader_nodes, "
                           "view_json, image, descriptor) VALUES(?,?,?,?,?,?,?,?)",
                           -1, &wr, NULL) != SQLITE_OK) {
        pipeline_error(err, errlen, "%s: %s", src_path, sqlite3_errmsg(d->db));
        goto done;
    }
    if (store_exec(out, tmp, "BEGIN", err, errlen))
        goto done;
    int step;
    long long rows = 0;
    while ((step = sqlite3_step(rd)) == SQLITE_ROW) {
        long long id = sqlite3_column_int64(rd, 0);
        const void *blob = sqlite3_column_blob(rd, 6);
        if (!blob) {
            pipeline_error(err, errlen, "%s: id %lld has no stored image (made with --images "
                                        "none): nothing to describe",
                           src_path, id);
            goto done;
        }
        image img;
        if (decode_image(d, blob, sqlite3_column_bytes(rd, 6), &img, id, err, errlen))
            goto done;
        uint16_t *h = descriptor_compute_f16(&dc, &dw, &img);
        image_free(&img);
        if (!h) {
            pipeline_error(err, errlen, "%s: id %lld: image too small to describe", src_path, id);
            goto done;
        }
        sqlite3_reset(wr);
        for (int k = 0; k < 7; k++)
            sqlite3_bind_value(wr, k + 1, sqlite3_column_value(rd, k));
        sqlite3_bind_blob(wr, 8, h, (int)(dc.n_stored * 2), free);
        if (sqlite3_step(wr) != SQLITE_DONE) {
            pipeline_error(err, errlen, "%s: %s", tmp, sqlite3_errmsg(out));
            goto done;
        }
        /* Commit every 64 rows: a long run keeps its WAL small. The temporary file is
         * only renamed into place when complete. */
        if (++rows % 64 == 0 &&
            (store_exec(out, tmp, "COMMIT", err, errlen) || store_exec(out, tmp, "BEGIN", err, errlen)))
            goto done;
    }
    if (step != SQLITE_DONE) {
        pipeline_error(err, errlen, "%s: %s", src_path, sqlite3_errmsg(d->db));
        goto done;
    }
    sqlite3_finalize(wr);
    wr = NULL;
    if (store_exec(out, tmp, "COMMIT; PRAGMA wal_checkpoint(TRUNCATE); PRAGMA journal_mode=DELETE;",
                   err, errlen))
        goto done;
    int closed = sqlite3_close(out) == SQLITE_OK;
    out = NULL;
    if (!closed || rename(tmp, out_path)) {
        pipeline_error(err, errlen, "%s: %s failed", out_path, closed ? "rename" : "close");
        goto done;
    }
    rc = 0;
done:
    sqlite3_finalize(rd);
    sqlite3_finalize(wr);
    if (rc)
        discard_temporary(out, tmp);
    descriptor_worker_free(&dw);
    if (have_dc)
        descriptor_config_free(&dc);
    cJSON_Delete(cfg);
    free(cfg_text);
    free(names);
    dataset_close(d);
    return rc;
}

/* ---------------------------------------------------------------- export ----------- */

int dataset_export_npy(dataset *d, const char *dir, char *err, size_t errlen)
{
    if (mkdir(dir, 0777) != 0 && errno != EEXIST)
        return pipeline_error(err, errlen, "%s: cannot create: %s", dir, strerror(errno));
    dataset_info info;
    if (dataset_get_info(d, &info, err, errlen))
        return -1;
    dataset_info_free(&info);
    size_t rows = (size_t)info.rows, np = (size_t)d->n_params, nd = d->descriptor_size;
    char path[5][1200];
    const char *names[5] = {"ids.npy", "views.npy", "params.npy", "active.npy", "descriptors.npy"};
    for (int k = 0; k < 5; k++)
        snprintf(path[k], sizeof path[k], "%s/%s", dir, names[k]);
    nn_npy_writer *w[5] = {0};
    w[0] = nn_npy_begin_dtype(path[0], "<i8", 8, rows, 1, err, errlen);
    w[1] = w[0] ? nn_npy_begin_dtype(path[1], "<i4", 4, rows, 1, err, errlen) : NULL;
    w[2] = w[1] ? nn_npy_begin_dtype(path[2], "<f4", 4, rows, np, err, errlen) : NULL;
    w[3] = w[2] ? nn_npy_begin_dtype(path[3], "|u1", 1, rows, np, err, errlen) : NULL;
    int ok = w[3] != NULL;
    if (ok && nd)
        ok = (w[4] = nn_npy_begin_dtype(path[4], "<f2", 2, rows, nd, err, errlen)) != NULL;
    /* Descriptors go out as stored (float16), straight from the blobs. */
    sqlite3_stmt *st = NULL;
    if (ok && sqlite3_prepare_v2(d->db,
                                 "SELECT id, view, params, active, descriptor FROM samples "
                                 "ORDER BY id, view",
                                 -1, &st, NULL) != SQLITE_OK) {
        pipeline_error(err, errlen, "%s: %s", d->path, sqlite3_errmsg(d->db));
        ok = 0;
    }
    while (ok) {
        int rc = sqlite3_step(st);
        if (rc == SQLITE_DONE)
            break;
        if (rc != SQLITE_ROW) {
            ok = !pipeline_error(err, errlen, "%s: %s", d->path, sqlite3_errmsg(d->db));
            break;
        }
        int64_t id = sqlite3_column_int64(st, 0);
        int32_t view = sqlite3_column_int(st, 1);
        if (sqlite3_column_bytes(st, 2) != (int)(np * 4) || sqlite3_column_bytes(st, 3) != (int)np ||
            (nd && sqlite3_column_bytes(st, 4) != (int)(nd * 2))) {
            ok = !pipeline_error(err, errlen, "%s: id %lld: malformed row", d->path, (long long)id);
            break;
        }
        ok = !nn_npy_append_raw(w[0], &id, 1, err, errlen) &&
             !nn_npy_append_raw(w[1], &view, 1, err, errlen) &&
             !nn_npy_append_raw(w[2], sqlite3_column_blob(st, 2), 1, err, errlen) &&
             !nn_npy_append_raw(w[3], sqlite3_column_blob(st, 3), 1, err, errlen) &&
             (!nd || !nn_npy_append_raw(w[4], sqlite3_column_blob(st, 4), 1, err, errlen));
    }
    sqlite3_finalize(st);
    for (int k = 0; k < 5; k++) {
        if (!w[k])
            continue;
        if (ok) {
            if (nn_npy_commit(w[k], err, errlen))
                ok = 0;
        } else
            nn_npy_abort(w[k]);
    }
    if (!ok)
        return -1;
    /* Parameter names, one a line, in column order. */
    char names_path[1200], tmp[1300];
    snprintf(names_path, sizeof names_path, "%s/params.txt", dir);
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", names_path, (long)getpid());
    FILE *f = fopen(tmp, "w");
    if (!f)
        return pipeline_error(err, errlen, "%s: cannot create: %s", tmp, strerror(errno));
    for (size_t k = 0; k < np; k++)
        fprintf(f, "%s\n", d->names[k]);
    if (fclose(f) != 0 || rename(tmp, names_path) != 0) {
        int e = errno;
        unlink(tmp);
        return pipeline_error(err, errlen, "%s: write failed: %s", names_path, strerror(e));
    }
    return 0;
}

/* ---------------------------------------------------------------- contact sheet ---- */

/* A 3x5 pixel font for the labels. Each glyph is 5 rows of 3 bits (4 = left column). Letters
 * are drawn as capitals whatever their case, except 'v', the small v of "12v3" labels. */
static const unsigned char digit_glyphs[10][5] = {
    {7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7}, {5, 5, 7, 1, 1},
    {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 1, 1, 1}, {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7},
};
static const unsigned char letter_glyphs[26][5] = {
    {2, 5, 7, 5, 5}, {6, 5, 6, 5, 6}, {3, 4, 4, 4, 3}, {6, 5, 5, 5, 6}, {7, 4, 6, 4, 7}, /* A-E */
    {7, 4, 6, 4, 4}, {3, 4, 5, 5, 3}, {5, 5, 7, 5, 5}, {7, 2, 2, 2, 7}, {1, 1, 1, 5, 2}, /* F-J */
    {5, 5, 6, 5, 5}, {4, 4, 4, 4, 7}, {5, 7, 7, 5, 5}, {6, 5, 5, 5, 5}, {2, 5, 5, 5, 2}, /* K-O */
    {6, 5, 6, 4, 4}, {2, 5, 5, 6, 3}, {6, 5, 6, 5, 5}, {3, 4, 2, 1, 6}, {7, 2, 2, 2, 2}, /* P-T */
    {5, 5, 5, 5, 7}, {0, 0, 5, 5, 2}, {5, 5, 7, 7, 5}, {5, 5, 2, 5, 5}, {5, 5, 2, 2, 2}, /* U-Y */
    {7, 1, 2, 4, 7},                                                                     /* Z */
};

/* The glyph of c; NULL draws nothing (a space or an unknown character). */
static const unsigned char *glyph(char c)
{
    static const unsigned char minus[5] = {0, 0, 7, 0, 0}, dot[5] = {0, 0, 0, 0, 2},
                               underscore[5] = {0, 0, 0, 0, 7}, slash[5] = {1, 1, 2, 4, 4},
                               plus[5] = {0, 2, 7, 2, 0}, percent[5] = {5, 1, 2, 4, 5};
    if (c >= '0' && c <= '9')
        return digit_glyphs[c - '0'];
    if (c >= 'a' && c <= 'z')
        return letter_glyphs[c - 'a'];
    if (c >= 'A' && c <= 'Z')
        return letter_glyphs[c == 'V' ? 'v' - 'a' : c - 'A'];
    switch (c) {
    case '-': return minus;
    case '.': return dot;
    case '_': return underscore;
    case '/': return slash;
    case '+': return plus;
    case '%': return percent;
    default: return NULL;
    }
}

void pipeline_sheet_label(image *sheet, int x, int y, const char *text, int scale)
{
    int n = (int)strlen(text), w = (4 * n + 1) * scale, h = 7 * scale;
    for (int py = y; py < y + h && py < sheet->height; py++)
        for (int px = x; px < x + w && px < sheet->width; px++)
            for (int c = 0; c < 3; c++)
                sheet->pixels[((size_t)py * (size_t)sheet->width + (size_t)px) * 3 + (size_t)c] = 0.0f;
    for (int i = 0; i < n; i++) {
        const unsigned char *g = glyph(text[i]);
        if (!g)
            continue;
        for (int r = 0; r < 5; r++)
            for (int b = 0; b < 3; b++) {
                if (!(g[r] >> (2 - b) & 1))
                    continue;
                for (int sy = 0; sy < scale; sy++)
                    for (int sx = 0; sx < scale; sx++) {
                        int px = x + (1 + 4 * i + b) * scale + sx, py = y + (1 + r) * scale + sy;
                        if (px < sheet->width && py < sheet->height)
                            for (int c = 0; c < 3; c++)
                                sheet->pixels[((size_t)py * (size_t)sheet->width + (size_t)px) * 3 +
                                              (size_t)c] = 1.0f;
                    }
            }
    }
}

int pipeline_sheet_paste(image *sheet, const image *img, int ox, int oy, int tile)
{
    image small;
    if (image_resize(img, tile, tile, &small))
        return -1;
    for (int y = 0; y < tile && oy + y < sheet->height; y++)
        for (int x = 0; x < tile && ox + x < sheet->width; x++)
            for (int c = 0; c < 3; c++)
                sheet->pixels[((size_t)(oy + y) * (size_t)sheet->width + (size_t)(ox + x)) * 3 +
                              (size_t)c] =
                    small.pixels[((size_t)y * (size_t)tile + (size_t)x) * (size_t)small.channels +
                                 (size_t)(c < small.channels ? c : 0)];
    image_free(&small);
    return 0;
}

int dataset_contact_sheet(dataset *d, const char *png_path, int count, int cols, int tile,
                          char *err, size_t errlen)
{
    dataset_info info;
    if (dataset_get_info(d, &info, err, errlen))
        return -1;
    dataset_info_free(&info);
    if (count <= 0 || count > info.rows)
        count = (int)info.rows;
    if (count == 0)
        return pipeline_error(err, errlen, "%s: no samples", d->path);
    if (cols > count)
        cols = count;
    int rows = (count + cols - 1) / cols;
    image sheet;
    if (image_alloc(&sheet, cols * tile, rows * tile, 3))
        return pipeline_error(err, errlen, "out of memory for a %dx%d sheet", cols * tile,
                              rows * tile);
    dataset_iter *it = dataset_iter_new(d, 0, 1, err, errlen);
    int rc = it ? 0 : -1;
    dataset_row row;
    for (int i = 0; rc == 0 && i < count; i++) {
        int got = dataset_iter_next(it, &row, err, errlen);
        if (got <= 0) {
            rc = got < 0 ? -1 : 0;
            break;
        }
        int ox = (i % cols) * tile, oy = (i / cols) * tile;
        if (pipeline_sheet_paste(&sheet, &row.img, ox, oy, tile)) {
            rc = pipeline_error(err, errlen, "out of memory");
            break;
        }
        char label[40];
        if (row.view)
            snprintf(label, sizeof label, "%lldv%d", row.id, row.view);
        else
            snprintf(label, sizeof label, "%lld", row.id);
        pipeline_sheet_label(&sheet, ox + 2, oy + 2, label, tile >= 128 ? 2 : 1);
    }
    dataset_iter_free(it);
    char msg[768];
    if (rc == 0 && image_write_png(png_path, &sheet, msg, sizeof msg))
        rc = pipeline_error(err, errlen, "%s", msg);
    image_free(&sheet);
    return rc;
}
