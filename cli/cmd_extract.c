/* imsynth extract: the sub-shader of a graph for one parameter set. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

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
    "  --stats           print node counts and extraction time on stderr\n";

int cmd_extract(int argc, char **argv)
{
    const char *sub = "extract";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    cli_graph_args ga;
    const char *out_path = NULL;
    int stats = 0;
    int rc = cli_parse_graph_args(sub, argc, argv, &ga);
    if (rc != EXIT_OK)
        return rc;
    for (int i = 0; i < ga.n_rest; i++) {
        const char *a = ga.rest[i];
        if ((!strcmp(a, "-o") || !strcmp(a, "--output")) && i + 1 < ga.n_rest)
            out_path = ga.rest[++i];
        else if (!strcmp(a, "--stats"))
            stats = 1;
        else {
            cli_error(sub, "unexpected argument \"%s\" (see --help)", a);
            return EXIT_USAGE;
        }
    }
    if (!out_path) {
        cli_error(sub, "need -o SUB.json (see --help)");
        return EXIT_USAGE;
    }
    sg_graph *g = cli_load_bound_graph(sub, &ga);
    if (!g)
        return EXIT_FAILURE_WORK;
    sg_error err;
    sg_extract_options opt = {.blender = ga.blender};
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    sg_graph *x = sg_extract(g, &opt, &err);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    if (!x) {
        cli_error(sub, "%s: %s", ga.graph_path, err.msg);
        sg_graph_free(g);
        return EXIT_FAILURE_WORK;
    }
    if (stats)
        fprintf(stderr, "%s: %d nodes -> %d nodes in %.2f ms\n", ga.graph_path,
                sg_graph_node_count(g), sg_graph_node_count(x),
                1e3 * ((double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec)));
    rc = EXIT_OK;
    if (sg_graph_save_file(x, out_path, &err) < 0) {
        cli_error(sub, "%s", err.msg);
        rc = EXIT_FAILURE_WORK;
    }
    sg_graph_free(x);
    sg_graph_free(g);
    return rc;
}
