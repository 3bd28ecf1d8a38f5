/* imsynth sample: the super-shader parameter set of one frame (the thesis's convention). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "shadergraph/shadergraph.h"

static const char *const help =
    "usage: imsynth sample --seed N [-o PARAMS.json] [options]\n"
    "\n"
    "Prints the parameter set of frame N of a super-shader as JSON keyed by parameter\n"
    "name: the generator is seeded with N, each parameter is uniform in [0, 1) rounded to\n"
    "3 decimals, and \"Mult K ...\" selectors are moved to the centre of their bin,\n"
    "min((floor(u*K) + 0.5) / K, 1). The generator is SplitMix64, so frames differ from\n"
    "the thesis's (Python's Mersenne Twister) but are the same on every machine.\n"
    "\n"
    "options:\n"
    "  --seed N               frame number, an integer in [0, 2^64) (required)\n"
    "  -o, --output P.json    write the parameters here (atomically) instead of stdout\n"
    "  --graph GRAPH.json     the super-shader whose parameters to sample\n"
    "                         (default: assets/supershader.json of the installation,\n"
    "                         the source tree, or $IMSYNTH_DATA)\n"
    "  --bound-graph OUT.json also write GRAPH with these parameters bound (its\n"
    "                         RandomValues group set), ready for eval-graph or Blender\n";

int cmd_sample(int argc, char **argv)
{
    const char *sub = "sample";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    const char *graph_path = NULL, *out_path = NULL, *bound_path = NULL;
    const char *seed_arg = NULL;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        bool takes = !strcmp(a, "--seed") || !strcmp(a, "-o") || !strcmp(a, "--output") ||
                     !strcmp(a, "--graph") || !strcmp(a, "--bound-graph");
        if (takes && i + 1 >= argc) {
            cli_error(sub, "%s needs a value", a);
            return EXIT_USAGE;
        }
        if (!strcmp(a, "--seed"))
            seed_arg = argv[++i];
        else if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            out_path = argv[++i];
        else if (!strcmp(a, "--graph"))
            graph_path = argv[++i];
        else if (!strcmp(a, "--bound-graph"))
            bound_path = argv[++i];
        else if (a[0] == '-' && a[1]) {
            cli_error(sub, "unknown option \"%s\"", a);
            return EXIT_USAGE;
        } else {
            cli_error(sub, "unexpected argument \"%s\"", a);
            return EXIT_USAGE;
        }
    }
    if (!seed_arg) {
        cli_error(sub, "need --seed N (see --help)");
        return EXIT_USAGE;
    }
    char *end;
    errno = 0;
    unsigned long long seed = strtoull(seed_arg, &end, 10);
    if (errno || *end || !*seed_arg || seed_arg[0] == '-' || seed_arg[0] == '+' ||
        seed_arg[0] == ' ') {
        cli_error(sub, "--seed: expected an integer in [0, 2^64), got \"%s\"", seed_arg);
        return EXIT_USAGE;
    }

    char err[SG_ERROR_MAX] = "";
    char graph_buf[1024];
    if (!(graph_path = cli_data_path(sub, graph_path, "assets/supershader.json", graph_buf,
                                     sizeof graph_buf)))
        return EXIT_FAILURE_WORK;
    sg_graph *g = sg_graph_load_file(graph_path, err, sizeof err);
    if (!g) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    sg_params p;
    if (sg_params_from_graph(g, &p, err, sizeof err) < 0) {
        cli_error(sub, "%s: %s", graph_path, err);
        sg_graph_free(g);
        return EXIT_FAILURE_WORK;
    }
    sg_params_sample(&p, seed);
    int rc = EXIT_OK;
    if (out_path) {
        if (sg_params_write_file(out_path, &p, err, sizeof err) < 0) {
            cli_error(sub, "%s", err);
            rc = EXIT_FAILURE_WORK;
        }
    } else {
        char *text = sg_params_to_json(&p);
        if (!text || fputs(text, stdout) == EOF || fflush(stdout) != 0) {
            cli_error(sub, "cannot write the parameters to stdout");
            rc = EXIT_FAILURE_WORK;
        }
        free(text);
    }
    if (rc == EXIT_OK && bound_path) {
        if (sg_graph_bind_params(g, &p, err, sizeof err) < 0 ||
            sg_graph_save_file(g, bound_path, err, sizeof err) < 0) {
            cli_error(sub, "%s", err);
            rc = EXIT_FAILURE_WORK;
        }
    }
    sg_params_free(&p);
    sg_graph_free(g);
    return rc;
}
