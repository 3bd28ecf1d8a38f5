/* imsynth: dispatch to one subcommand. */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "cli/cli.h"

typedef struct subcommand {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
} subcommand;

static const subcommand subcommands[] = {
    {"eval-graph", cmd_eval_graph, "evaluate a node socket over the scene's plane into an image"},
    {"render", cmd_render, "path-trace a material on the scene's plane as Cycles would (EXR, PNG)"},
    {"sample", cmd_sample, "the super-shader parameter set of frame N, as JSON"},
    {"extract", cmd_extract, "the sub-shader of a super-shader for one parameter set"},
    {"export", cmd_export, "a material (sub-shader by default) for blender/import_material.py"},
    {"compare", cmd_compare, "RMSE, bias and worst block of an image against a reference"},
#ifdef IMSYNTH_HAVE_NN
    {"describe", cmd_describe, "VGG19 Gram descriptors of images, as .npy"},
    {"forest", cmd_forest, "fit a multi-output random forest, rank features, predict (.npy)"},
#endif
};

void cli_error(const char *sub, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "imsynth %s: ", sub);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

int cli_wants_help(int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--"))
            return 0;
        if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help"))
            return 1;
    }
    return 0;
}

static void usage(FILE *f)
{
    fprintf(f, "usage: imsynth <command> [options]   (imsynth <command> --help for its options)\n"
               "       imsynth --version\n\ncommands:\n");
    for (size_t i = 0; i < sizeof subcommands / sizeof subcommands[0]; i++)
        fprintf(f, "  %-12s %s\n", subcommands[i].name, subcommands[i].summary);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return EXIT_USAGE;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("imsynth %s\n", IMSYNTH_VERSION);
        return EXIT_OK;
    }
    if (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return EXIT_OK;
    }
    for (size_t i = 0; i < sizeof subcommands / sizeof subcommands[0]; i++)
        if (!strcmp(argv[1], subcommands[i].name))
            return subcommands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "imsynth: unknown command \"%s\"\n", argv[1]);
    usage(stderr);
    return EXIT_USAGE;
}
