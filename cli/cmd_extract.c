/* imsynth extract: the sub-shader of a graph for one parameter set. */
#include <stdio.h>

#include "cli/cli.h"
#include "shadergraph/shadergraph.h"

static const char *const help =
    "usage: imsynth extract [GRAPH.json] (--params P.json | --seed N) -o SUB.json [options]\n"
    "\n"
    "Binds a parameter set to a super-shader (default assets/supershader.json) and writes\n"
    "the sub-shader: groups inlined, constants folded, identities bypassed, duplicates\n"
    "merged, dead nodes removed. It evaluates to the same values as the super-shader.\n"
    "\n"
    "options:\n"
    "  --params P.json   parameter values, a JSON object keyed by parameter name\n"
    "  --seed N          instead of --params: frame N's parameters (as imsynth sample)\n"
    "  -o, --output F    the sub-shader, in the graph format (required)\n"
    "  --blender 4|3     semantics used when folding constants (default 4)\n"
    "  --texture-rotation DEG  turn the texture space about the plane's normal (a Mapping\n"
    "                    node; `imsynth predict`'s report.json gives its texture_rotation)\n"
    "  --stats           print node counts and extraction time on stderr\n";

int cmd_extract(int argc, char **argv)
{
    const char *sub = "extract";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    return cli_write_material(sub, argc, argv, false);
}
