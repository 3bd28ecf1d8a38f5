/*
 * The dataset store: one SQLite file per dataset (or shard).
 *
 * Schema "imsynth-dataset/1":
 *   meta(key, value)   'schema' = "imsynth-dataset/1", 'config' = the config JSON,
 *                      'config_hash' = its SHA-256, 'params' = JSON array of parameter names
 *   samples            one row per (id, view): params (n float32, little-endian), active
 *                      (n uint8), subshader_nodes, view_json (the view's scene settings),
 *                      image (PNG or EXR file bytes, or NULL), descriptor (float16 LE, or NULL)
 *
 * Invariants, which every writer keeps and dataset_open relies on:
 *   - all rows of one id are written in one transaction: an id present is complete;
 *   - a row's bytes are a pure function of (id, view, config): no times, no hostnames;
 *   - the config never changes once written (a different config is refused at open).
 * WAL journaling: a kill -9 at any moment loses at most the open transaction.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sqlite3.h>
#include <unistd.h>

#include "pipeline/store.h"

static const char *const schema_sql =
    "CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);"
    "CREATE TABLE IF NOT EXISTS samples("
    " id INTEGER NOT NULL, view INTEGER NOT NULL, params BLOB NOT NULL, active BLOB NOT NULL,"
    " subshader_nodes INTEGER NOT NULL, view_json TEXT NOT NULL, image BLOB, descriptor BLOB,"
    " PRIMARY KEY(id, view));";

int store_exec(sqlite3 *db, const char *path, const char *sql, char *err, size_t errlen)
{
    char *msg = NULL;
    if (sqlite3_exec(db, sql, NULL, NULL, &msg) != SQLITE_OK) {
        pipeline_error(err, errlen, "%s: %s", path, msg ? msg : sqlite3_errmsg(db));
        sqlite3_free(msg);
        return -1;
    }
    return 0;
}

/* The value of meta key `key` (malloc'd), or NULL (missing, or error with a message). */
char *store_meta_get(sqlite3 *db, const char *path, const char *key, char *err, size_t errlen)
{
    sqlite3_stmt *st = NULL;
    char *v = NULL;
    if (sqlite3_prepare_v2(db, "SELECT value FROM meta WHERE key = ?", -1, &st, NULL) != SQLITE_OK) {
        pipeline_error(err, errlen, "%s: not an imsynth dataset (%s)", path, sqlite3_errmsg(db));
        return NULL;
    }
    sqlite3_bind_text(st, 1, key, -1, SQLITE_STATIC);
    int rc = sqlite3_step(st);
    if (rc == SQLITE_ROW) {
        const char *t = (const char *)sqlite3_column_text(st, 0);
        v = strdup(t ? t : "");
    } else if (rc == SQLITE_DONE)
        pipeline_error(err, errlen, "%s: meta table has no '%s'", path, key);
    else
        pipeline_error(err, errlen, "%s: %s", path, sqlite3_errmsg(db));
    sqlite3_finalize(st);
    return v;
}

static int meta_put(sqlite3 *db, const char *path, const char *key, const char *value,
                    char *err, size_t errlen)
{
    sqlite3_stmt *st = NULL;
    if (sqlite3_prepare_v2(db, "INSERT INTO meta(key, value) VALUES(?, ?)", -1, &st, NULL) !=
        SQLITE_OK)
        return pipeline_error(err, errlen, "%s: %s", path, sqlite3_errmsg(db));
    sqlite3_bind_text(st, 1, key, -1, SQLITE_STATIC);
    sqlite3_bind_text(st, 2, value, -1, SQLITE_STATIC);
    int rc = sqlite3_step(st);
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE)
        return pipeline_error(err, errlen, "%s: %s", path, sqlite3_errmsg(db));
    return 0;
}

/* Opens path (SQLITE_OPEN_* flags), with the settings every connection uses. */
sqlite3 *store_connect(const char *path, int flags, char *err, size_t errlen)
{
    sqlite3 *db = NULL;
    int rc = sqlite3_open_v2(path, &db, flags, NULL);
    if (rc != SQLITE_OK) {
        /* SQLite's "unable to open database file" does not say why; the OS does. */
        int os = db ? sqlite3_system_errno(db) : 0;
        pipeline_error(err, errlen, "%s: cannot open: %s%s%s%s", path,
                       db ? sqlite3_errmsg(db) : sqlite3_errstr(rc), os ? " (" : "",
                       os ? strerror(os) : "", os ? ")" : "");
        sqlite3_close(db);
        return NULL;
    }
    sqlite3_busy_timeout(db, 10000);
    sqlite3_extended_result_codes(db, 1);
    return db;
}

int store_check_schema(sqlite3 *db, const char *path, char *err, size_t errlen)
{
    char *schema = store_meta_get(db, path, "schema", err, errlen);
    if (!schema)
        return -1;
    int ok = !strcmp(schema, STORE_SCHEMA);
    if (!ok)
        pipeline_error(err, errlen, "%s: schema \"%s\", this imsynth reads \"%s\"", path, schema,
                       STORE_SCHEMA);
    free(schema);
    return ok ? 0 : -1;
}

/* Names the first top-level config key whose value differs, for the mismatch message: one
 * of a's keys, else a key only b has. */
static void describe_config_difference(const char *a, const char *b, char *out, size_t outlen)
{
    cJSON *ja = cJSON_Parse(a), *jb = cJSON_Parse(b);
    snprintf(out, outlen, "the configs differ");
    int found = 0;
    if (ja && jb) {
        const cJSON *x;
        cJSON_ArrayForEach(x, ja)
        {
            const cJSON *y = cJSON_GetObjectItemCaseSensitive(jb, x->string);
            char *sx = cJSON_PrintUnformatted(x), *sy = y ? cJSON_PrintUnformatted(y) : NULL;
            int same = sx && sy && !strcmp(sx, sy);
            if (!same)
                snprintf(out, outlen, "\"%s\" is %.200s there, %.200s here", x->string,
                         sx ? sx : "?", sy ? sy : "missing");
            free(sx);
            free(sy);
            if (!same) {
                found = 1;
                break;
            }
        }
        cJSON_ArrayForEach(x, jb)
        {
            if (found || cJSON_GetObjectItemCaseSensitive(ja, x->string))
                continue;
            char *sx = cJSON_PrintUnformatted(x);
            snprintf(out, outlen, "\"%s\" is missing there, %.200s here", x->string,
                     sx ? sx : "?");
            free(sx);
            found = 1;
        }
    }
    cJSON_Delete(ja);
    cJSON_Delete(jb);
}

/* Removes a database this process created and could not set up, with SQLite's side
 * files, so that a failure (a full disk) leaves no file that is not a dataset. */
static void remove_new_database(const char *path)
{
    char side[1200];
    unlink(path);
    snprintf(side, sizeof side, "%s-wal", path);
    unlink(side);
    snprintf(side, sizeof side, "%s-shm", path);
    unlink(side);
}

sqlite3 *store_open_for_writing(const char *path, const char *config_json,
                                const char *params_json, char *err, size_t errlen)
{
    /* A new file is created here rather than by SQLite, whose error for a read-only
     * directory ("unable to open database file") does not say why. An empty file is an
     * empty database. O_EXCL: if another writer creates it first, it is theirs. */
    bool created = false;
    int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd >= 0) {
        close(fd);
        created = true;
    } else if (errno != EEXIST) {
        pipeline_error(err, errlen, "%s: cannot create: %s", path, strerror(errno));
        return NULL;
    }
    sqlite3 *db = store_connect(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, err, errlen);
    if (!db) {
        if (created)
            remove_new_database(path);
        return NULL;
    }
    char hash[65];
    pipeline_sha256_hex(config_json, strlen(config_json), hash);
    if (store_exec(db, path, "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;", err, errlen) ||
        store_exec(db, path, "BEGIN IMMEDIATE", err, errlen))
        goto fail;
    if (store_exec(db, path, schema_sql, err, errlen))
        goto fail_rollback;
    char *have = store_meta_get(db, path, "config_hash", NULL, 0);
    if (!have) {
        if (meta_put(db, path, "schema", STORE_SCHEMA, err, errlen) ||
            meta_put(db, path, "config", config_json, err, errlen) ||
            meta_put(db, path, "config_hash", hash, err, errlen) ||
            meta_put(db, path, "params", params_json, err, errlen))
            goto fail_rollback;
    } else {
        int same = !strcmp(have, hash);
        free(have);
        if (store_check_schema(db, path, err, errlen))
            goto fail_rollback;
        if (!same) {
            char *cfg = store_meta_get(db, path, "config", NULL, 0);
            char why[600];
            describe_config_difference(cfg ? cfg : "{}", config_json, why, sizeof why);
            free(cfg);
            pipeline_error(err, errlen,
                           "%s: made with another config (%s); refusing to mix datasets: use "
                           "a new file, or the same options as before",
                           path, why);
            goto fail_rollback;
        }
    }
    if (store_exec(db, path, "COMMIT", err, errlen))
        goto fail;
    return db;
fail_rollback:
    sqlite3_exec(db, "ROLLBACK", NULL, NULL, NULL);
fail:
    sqlite3_close(db);
    if (created)
        remove_new_database(path);
    return NULL;
}
