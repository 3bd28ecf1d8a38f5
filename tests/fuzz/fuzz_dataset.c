/* fuzz_dataset: the dataset database (`imsynth datagen --out`; read by dataset info,
 * fit-predictor, forest fit --dataset, search) as a corrupt or hostile SQLite file:
 * dataset_open (schema version, meta 'config' and 'params' JSON), dataset_get_info, then
 * the first rows through dataset_iter with descriptors (float16 blobs whose length must
 * match the config) and stored renders (PNG/EXR blobs decoded by imageio).
 * SQLite itself is the system library (not instrumented): what is fuzzed is our trust in
 * what it returns. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "fuzz_util.h"
#include "pipeline/pipeline.h"

#define FUZZ_ROWS 4

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[512], side[512], err[512];
    fuzz_temp_path(path, sizeof path, "input.sqlite");
    /* A file in WAL mode makes SQLite look for these beside it: none may survive an input. */
    remove(fuzz_temp_path(side, sizeof side, "input.sqlite-wal"));
    remove(fuzz_temp_path(side, sizeof side, "input.sqlite-shm"));
    remove(fuzz_temp_path(side, sizeof side, "input.sqlite-journal"));
    if (fuzz_write_file(path, data, size) != 0)
        return 0;
    dataset *d = dataset_open(path, err, sizeof err);
    if (!d)
        return 0;
    dataset_info info;
    if (dataset_get_info(d, &info, err, sizeof err) == 0) {
        const char *const *names = dataset_param_names(d);
        for (int k = 0; k < info.n_params; k++)
            if (!names[k])
                abort(); /* n_params names, all set */
        dataset_info_free(&info);
    }
    dataset_iter *it = dataset_iter_new(d, 1, 1, err, sizeof err);
    if (it) {
        dataset_row row;
        for (int i = 0; i < FUZZ_ROWS && dataset_iter_next(it, &row, err, sizeof err) == 1; i++) {
        }
        dataset_iter_free(it);
    }
    dataset_close(d);
    return 0;
}
