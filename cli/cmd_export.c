/* imsynth export: a graph, parameters bound, as a material Blender can load. */
#include <stdio.h>
#include <string.h>

#include "cli/cli.h"
#include "shadergraph/shadergraph.h"

static const char *const help =
    "usage: imsynth export GRAPH.json [--params P.json | --seed N] -o MATERIAL.json [--full]\n"
    "\n"
    "Writes a material in the graph format that blender/import_material.py builds in\n"
    "Blender 3.4 or 4.x:\n"
    "  blender -b -P blender/import_material.py -- MATERIAL.json --save out.blend [--scene]\n"
    "With parameters (a super-shader), they are bound first. By default the sub-shader is\n"
    "written (as imsynth extract); --full keeps the whole graph with its groups.\n"
    "\n"
    "options:\n"
    "  --params P.json   parameter values (JSON object keyed by parameter name)\n"
    "  --seed N          frame N's parameters\n"
    "  -o, --output F    the material (required)\n"
    "  --full            no extraction: the graph as it is, parameters bound\n"
    "  --blender 4|3     semantics used when folding constants (default 4)\n";

int cmd_export(int argc, char **argv)
{
    const char *sub = "export";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    cli_graph_args ga;
    const char *out_path = NULL;
    int full = 0;
    int rc = cli_parse_graph_args(sub, argc, argv, &ga);
    if (rc != EXIT_OK)
        return rc;
    for (int i = 0; i < ga.n_rest; i++) {
        const char *a = ga.rest[i];
        if ((!strcmp(a, "-o") || !strcmp(a, "--output")) && i + 1 < ga.n_rest)
            out_path = ga.rest[++i];
        else if (!strcmp(a, "--full"))
            full = 1;
        else {
            cli_error(sub, "unexpected argument \"%s\" (see --help)", a);
            return EXIT_USAGE;
        }
    }
    if (!out_path) {
        cli_error(sub, "need -o MATERIAL.json (see --help)");
        return EXIT_USAGE;
    }
    sg_graph *g = cli_load_bound_graph(sub, &ga);
    if (!g)
        return EXIT_FAILURE_WORK;
    sg_error err;
    sg_graph *x = g;
    if (!full) {
        sg_extract_options opt = {.blender = ga.blender};
        x = sg_extract(g, &opt, &err);
        if (!x) {
            cli_error(sub, "%s: %s", ga.graph_path, err.msg);
            sg_graph_free(g);
            return EXIT_FAILURE_WORK;
        }
    }
    rc = EXIT_OK;
    if (sg_graph_save_file(x, out_path, &err) < 0) {
        cli_error(sub, "%s", err.msg);
        rc = EXIT_FAILURE_WORK;
    }
    if (x != g)
        sg_graph_free(x);
    sg_graph_free(g);
    return rc;
}
