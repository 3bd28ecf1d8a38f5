/* Private to pipeline/: the dataset store's schema and connection helpers (store.c). */
#ifndef IMSYNTH_PIPELINE_STORE_H
#define IMSYNTH_PIPELINE_STORE_H

#include <cjson/cJSON.h>
#include <sqlite3.h>

#include "nn/nn.h"
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

/* The dataset's descriptor (describe.c): network, options and feature selection. */
typedef struct descriptor_config {
    int mobilenet; /* 0: VGG19 (random weights, seed 1, avg3, fp32); 1: MobileNetV2 */
    vgg19 net;
    vgg_options vgg;
    mobilenetv2 mnv2;
    mnv2_options mnv2_opt;
    char weights_hash[65]; /* MobileNetV2's weights file */
    size_t full_size, n_stored;
    uint32_t *index; /* stored features, ascending; NULL = all */
    char mask_hash[65];
} descriptor_config;
typedef struct descriptor_worker {
    vgg_workspace *ws;
    mnv2_workspace *mws;
    float *in, *full;
} descriptor_worker;
/* kind: DATAGEN_DESC_VGG19_F16 or DATAGEN_DESC_MOBILENETV2_F16. */
int descriptor_config_init(descriptor_config *dc, int kind, const char *mask_path, char *err,
                           size_t errlen);
void descriptor_config_free(descriptor_config *dc);
/* Adds the descriptor's settings to a config's "descriptor" object. */
void descriptor_config_json(const descriptor_config *dc, cJSON *d);
int descriptor_worker_init(descriptor_worker *dw, const descriptor_config *dc);
void descriptor_worker_free(descriptor_worker *dw);
/* The stored descriptor of a linear RGB image (at least 224 x 224): n_stored halves,
 * malloc'd; NULL when the image is too small or out of memory. */
uint16_t *descriptor_compute_f16(const descriptor_config *dc, descriptor_worker *dw,
                                 const image *img);

#endif
