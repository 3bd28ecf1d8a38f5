/* fuzz_safetensors: safetensors files (VGG19 / MobileNetV2 weights, training checkpoints,
 * model directories) through nn_safetensors_open, which validates the header (length,
 * JSON, dtypes, shapes against byte ranges, overlaps) before anything reads a tensor.
 * A file that opens is then read the way loaders read it: every tensor converted to
 * float32 with the shape it declares, a metadata lookup, and nn_mlp_load as a checkpoint
 * (whose metadata names the architecture the tensors must fit). */
#include <stdint.h>
#include <stdlib.h>

#include "fuzz_util.h"
#include "nn/nn.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[512], err[512];
    fuzz_temp_path(path, sizeof path, "input.safetensors");
    if (fuzz_write_file(path, data, size) != 0)
        return 0;
    nn_safetensors st;
    if (nn_safetensors_open(path, &st, err, sizeof err) != 0)
        return 0;
    for (int i = 0; i < st.count; i++) {
        const nn_tensor_info *t = &st.tensors[i];
        size_t n = 1;
        for (int d = 0; d < t->ndim; d++)
            n *= (size_t)t->shape[d];
        /* Validated above: n elements fit in the file, so this allocation is bounded. */
        float *out = malloc((n ? n : 1) * sizeof *out);
        if (out)
            nn_safetensors_read_f32(&st, t->name, t->ndim, t->shape, out, err, sizeof err);
        free(out);
    }
    char value[256];
    nn_safetensors_metadata(&st, "imsynth.arch", value, sizeof value);
    nn_safetensors_close(&st);

    nn_mlp m;
    nn_optimizer opt;
    if (nn_mlp_load(&m, &opt, path, err, sizeof err) == 0) {
        nn_optimizer_free(&opt);
        nn_mlp_free(&m);
    }
    return 0;
}
