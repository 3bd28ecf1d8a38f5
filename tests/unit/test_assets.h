/*
 * A repository graph for a unit test: IMSYNTH_SOURCE_DIR/rel loaded, the test failed with
 * the loader's message when it cannot be. Static: each test includes this once, after
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

#endif
