/* imsynth export: a graph, parameters bound, as a material Blender can load. */
#include <stdio.h>

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
    "  --blender 4|3     semantics used when folding constants (default 4)\n"
    "  --texture-rotation DEG  turn the texture space about the plane's normal (a Mapping\n"
    "                    node; `imsynth predict`'s report.json gives its texture_rotation)\n";

int cmd_export(int argc, char **argv)
{
    const char *sub = "export";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    return cli_write_material(sub, argc, argv, true);
}
