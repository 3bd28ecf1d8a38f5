/*
 * A repository graph for a unit test: IMSYNTH_SOURCE_DIR/rel loaded, the test failed with
 * the loader's message when it cannot be; the super-shader with its parameters. Static: each test includes this once, after
 * cmocka.h.
 */
#ifndef IMSYNTH_TESTS_TEST_ASSETS_H
#define IMSYNTH_TESTS_TEST_ASSETS_H

#include <stdio.h>

#include "shadergraph/shadergraph.h"

static sg_graph *load_asset(const char *rel)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", IMSYNTH_SOURCE_DIR, rel);
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(path, err, sizeof err);
    if (!g)
        fail_msg("%s", err);
    return g;
}

/* The bundled super-shader and its parameter set (free both). */
static sg_graph *load_supershader(sg_params *params)
{
    sg_graph *g = load_asset("assets/supershader.json");
    char err[SG_ERROR_MAX] = "";
    if (sg_params_from_graph(g, params, err, sizeof err) < 0)
        fail_msg("%s", err);
    return g;
}

#endif
