/* Private to pipeline/: the dataset store's schema and connection helpers (store.c). */
#ifndef IMSYNTH_PIPELINE_STORE_H
#define IMSYNTH_PIPELINE_STORE_H

#include <cjson/cJSON.h>
#include <sqlite3.h>

#include "pipeline/pipeline_internal.h"

#define STORE_SCHEMA "imsynth-dataset/1"

sqlite3 *store_connect(const char *path, int flags, char *err, size_t errlen);
int store_exec(sqlite3 *db, const char *path, const char *sql, char *err, size_t errlen);
char *store_meta_get(sqlite3 *db, const char *path, const char *key, char *err, size_t errlen);
int store_check_schema(sqlite3 *db, const char *path, char *err, size_t errlen);
/* Creates the dataset (schema, config, parameter names) or opens it, refusing one made with
 * another config. WAL mode. */
sqlite3 *store_open_for_writing(const char *path, const char *config_json,
                                const char *params_json, char *err, size_t errlen);

#endif
