/* fuzz_params: parameter files (`imsynth render --params`, predict-params' output read
 * back) through sg_params_read_json, against the names of the bundled super-shader
 * (assets/supershader.json), so inputs that name real parameters reach the value checks.
 * The contract checked: on error the values are left unchanged; on success every value
 * is finite and in [0, 1]. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shadergraph/shadergraph.h"

/* The super-shader's parameter names and values, read once; each input works on a copy. */
static sg_params names;

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(IMSYNTH_SOURCE_DIR "/assets/supershader.json", err, sizeof err);
    if (!g || sg_params_from_graph(g, &names, err, sizeof err) != 0) {
        fprintf(stderr, "fuzz_params: %s\n", err);
        exit(1);
    }
    sg_graph_free(g);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    sg_params p;
    if (sg_params_copy(&names, &p) != 0)
        return 0;
    char err[SG_ERROR_MAX] = "";
    if (sg_params_read_json((const char *)data, size, "fuzz-params.json", &p, err, sizeof err) == 0) {
        for (int i = 0; i < p.n; i++)
            if (!(p.values[i] >= 0.0f && p.values[i] <= 1.0f))
                abort(); /* the reader promises values in [0, 1] */
    } else if (memcmp(p.values, names.values, sizeof(float) * (size_t)p.n) != 0) {
        abort(); /* an error must leave the values as they were */
    }
    sg_params_free(&p);
    return 0;
}
