/* fuzz_graph: graph JSON (imsynth-graph/1, shadergraph/FORMAT.md) through
 * sg_graph_load_json, the parser every command runs on user files.
 *
 * A graph that loads is a validated graph, so what follows must not fail: the harness
 * saves it and loads the text again (FORMAT.md promises a lossless round trip: the second
 * save must equal the first), reads its parameters when it has the parameter group,
 * compiles the Principled BSDF's Base Color when there is one and evaluates it at 4
 * points of the scene plane. A broken invariant aborts, which libFuzzer reports. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shadergraph/shadergraph.h"

#define FUZZ_POINTS 4

static void evaluate_base_color(const sg_graph *g)
{
    char err[SG_ERROR_MAX] = "";
    const char *bsdf = sg_graph_surface_bsdf(g, err, sizeof err);
    if (!bsdf)
        return;
    sg_socket_ref ref = {bsdf, "Base Color"};
    sg_program *p = sg_compile(g, &ref, 1, NULL, err, sizeof err);
    if (!p)
        return; /* e.g. a group cycle or an unsupported node: reported, not crashed */
    sg_evaluator *e = sg_evaluator_new(p, FUZZ_POINTS);
    if (e) {
        float storage[48 * FUZZ_POINTS];
        float out[4 * FUZZ_POINTS];
        float *outs[1] = {out};
        sg_geometry_batch geom;
        sg_plane_geometry(2, 2, 0, FUZZ_POINTS, storage, &geom);
        sg_evaluate(e, &geom, outs);
        sg_evaluator_free(e);
    }
    sg_program_free(p);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_json((const char *)data, size, "fuzz.json", err, sizeof err);
    if (!g)
        return 0;
    char *text = sg_graph_to_json(g);
    if (text) {
        sg_graph *again = sg_graph_load_json(text, strlen(text), "fuzz-resaved.json", err, sizeof err);
        if (!again) { /* a graph we wrote is one we must read */
            fprintf(stderr, "resaved graph refused: %s\n", err);
            abort();
        }
        char *text2 = sg_graph_to_json(again);
        if (text2 && strcmp(text, text2) != 0)
            abort(); /* the round trip lost or changed something */
        free(text2);
        sg_graph_free(again);
        free(text);
    }
    sg_params params;
    if (sg_params_from_graph(g, &params, err, sizeof err) == 0)
        sg_params_free(&params);
    evaluate_base_color(g);
    sg_graph_free(g);
    return 0;
}
