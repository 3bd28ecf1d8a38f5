/* fuzz_model: a model directory (`imsynth fit-predictor -o`; read by predict-params,
 * evaluate, predict, search) through predictor_load, which cross-checks model.json (the
 * parameter layout, descriptor size, components, network) against three safetensors
 * files: transform, network (an nn checkpoint) and catalogue.
 *
 * The input is the whole directory: its four files in that order, separated by the line
 * FUZZ_SEPARATOR (tests/fuzz/make_corpus.sh joins a real model so). A missing part is a
 * missing file, so truncations test that too. Mutations can thus make the files disagree
 * with each other, which a single-file harness (fuzz_safetensors) cannot. A model that
 * loads predicts and retrieves for an all-zero descriptor. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "fuzz_util.h"
#include "pipeline/pipeline.h"

#define FUZZ_SEPARATOR "\n--imsynth-fuzz-next-file--\n"

static const char *const files[4] = {"model.json", "transform.safetensors",
                                     "network.safetensors", "catalogue.safetensors"};

/* The first occurrence of needle (n bytes) in hay (len bytes), or NULL. */
static const uint8_t *find(const uint8_t *hay, size_t len, const char *needle, size_t n)
{
    for (size_t i = 0; i + n <= len; i++)
        if (hay[i] == (uint8_t)needle[0] && memcmp(hay + i, needle, n) == 0)
            return hay + i;
    return NULL;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char dir[512], path[600], err[1024];
    fuzz_temp_path(dir, sizeof dir, "model");
    mkdir(dir, 0700);
    const size_t sep = strlen(FUZZ_SEPARATOR);
    const uint8_t *at = data, *end = data + size;
    for (int i = 0; i < 4; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, files[i]);
        remove(path);
        if (!at)
            continue; /* fewer parts than files: this one is missing */
        const uint8_t *next = find(at, (size_t)(end - at), FUZZ_SEPARATOR, sep);
        size_t n = next ? (size_t)(next - at) : (size_t)(end - at);
        if (fuzz_write_file(path, at, n) != 0)
            return 0;
        at = next ? next + sep : NULL;
    }
    predictor *p = predictor_load(dir, err, sizeof err);
    if (!p)
        return 0;
    size_t d = predictor_descriptor_size(p);
    int np = predictor_n_params(p);
    float *desc = calloc(d ? d : 1, sizeof *desc);
    float *params = malloc(2 * (size_t)(np > 0 ? np : 1) * sizeof *params);
    double prob[2], dist[2];
    size_t index[2];
    if (desc && params) {
        float stats[PIPELINE_TEXSTATS_N] = {0}; /* what a flat grey image would give is not needed:
                                        * any finite statistics exercise the path */
        predictor_predict(p, desc, stats, 2, params, prob, err, sizeof err);
        int n = predictor_nearest(p, desc, 2, index, dist, err, sizeof err);
        for (int i = 0; i < n; i++)
            if (index[i] >= predictor_catalogue_size(p))
                abort(); /* retrieval returns catalogue indices */
    }
    free(desc);
    free(params);
    predictor_free(p);
    return 0;
}
