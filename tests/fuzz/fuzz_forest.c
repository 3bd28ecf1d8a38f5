/* fuzz_forest: forest files (`imsynth forest fit -o`, read by forest predict/importance)
 * through forest_load: magic, version, header sizes against the file's length, per-tree
 * node counts, every node's children and feature, finite values, trailing bytes, and the
 * FNV-1a checksum in the last 8 bytes (forest/io.c).
 *
 * A mutated file almost never keeps its checksum, which would stop every input at the
 * last check and leave the code after a successful load unfuzzed. So the harness seals
 * each input first: when it is long enough, its last 8 bytes are replaced by the FNV-1a
 * hash of the rest (the file format, not a copy of io.c's code). A forest that loads is
 * then used: predictions for two rows, importances. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "forest/forest.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > ((size_t)64 << 20))
        return 0;
    uint8_t *buf = malloc(size ? size : 1);
    if (!buf)
        return 0;
    memcpy(buf, data, size);
    if (size >= 16) {
        uint64_t h = 0xcbf29ce484222325ull; /* FNV-1a 64: offset basis, prime 2^40 + 435 */
        for (size_t i = 0; i < size - 8; i++)
            h = (h ^ buf[i]) * 0x100000001b3ull;
        memcpy(buf + size - 8, &h, 8); /* little-endian hosts, as the writer */
    }
    char path[512], err[512];
    fuzz_temp_path(path, sizeof path, "input.forest");
    int wrote = fuzz_write_file(path, buf, size);
    free(buf);
    if (wrote != 0)
        return 0;
    forest *f = NULL;
    if (forest_load(path, &f, err, sizeof err) != 0) {
        if (f)
            abort(); /* the loader promises *out == NULL on error */
        return 0;
    }
    size_t d = forest_n_features(f), k = forest_n_outputs(f);
    /* d and k are bounded by the loader; skip forests too wide to predict cheaply. */
    if (d <= (1u << 16) && k <= (1u << 16)) {
        float *x = calloc(2 * d, sizeof *x), *y = malloc(2 * k * sizeof *y);
        double *imp = malloc(d * sizeof *imp);
        if (x && y && imp) {
            for (size_t j = 0; j < d; j++)
                x[d + j] = (float)j - 0.5f; /* row 0 all zeros, row 1 a ramp */
            forest_predict(f, x, 2, y, 1);
            forest_feature_importances(f, imp);
        }
        free(x);
        free(y);
        free(imp);
    }
    forest_free(f);
    return 0;
}
