/* imsynth: dispatch to one subcommand. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "pipeline/pipeline.h"

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
    {"describe", cmd_describe, "VGG19 Gram descriptors of images, as .npy"},
    {"datagen", cmd_datagen, "make a training dataset: sample, render, describe, store (resumable)"},
    {"dataset", cmd_dataset, "inspect, merge, export or view a dataset (info|merge|export|sheet)"},
    {"train", cmd_train, "train an MLP with heads on X.npy -> Y.npy (safetensors checkpoint)"},
    {"infer", cmd_infer, "predictions of a trained model for X.npy, as .npy"},
    {"forest", cmd_forest, "fit a multi-output random forest, rank features, predict (.npy)"},
    {"fit-predictor", cmd_fit_predictor, "train the parameter predictor on a dataset (model dir)"},
    {"predict", cmd_predict, "an image in, a Blender material out (the main job)"},
    {"predict-params", cmd_predict_params, "super-shader parameters for an image (top-k, JSON)"},
    {"search", cmd_search, "the materials nearest an image (catalogue or dataset), as a contact sheet"},
    {"evaluate", cmd_evaluate, "a model against test inputs: every method, parameter and image space"},
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

int cli_parse_ll(const char *sub, const char *opt, const char *s, long long lo, long long hi,
                 long long *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (errno || *end || !*s || v < lo || v > hi) {
        cli_error(sub, "%s: expected an integer in [%lld, %lld], got \"%s\"", opt, lo, hi, s);
        return -1;
    }
    *out = v;
    return 0;
}

const datagen_preset *cli_parse_preset(const char *sub, const char *opt, const char *s)
{
    const datagen_preset *p = datagen_preset_find(s);
    if (!p)
        cli_error(sub, "%s: expected one of %s, got \"%s\"", opt, datagen_preset_names(), s);
    return p;
}

int cli_parse_refine_option(const char *sub, const char *opt, const char *val,
                            refine_options *ro)
{
    long long n;
    double d;
    if (!strcmp(opt, "--refine")) {
        if (cli_parse_ll(sub, opt, val, 1, 100000, &n))
            return -1;
        ro->budget = (int)n;
    } else if (!strcmp(opt, "--method")) {
        int m = refine_method_parse(val);
        if (m < 0) {
            cli_error(sub, "%s: expected one of %s, got \"%s\"", opt, refine_method_list(), val);
            return -1;
        }
        ro->method = (refine_method)m;
    } else if (!strcmp(opt, "--colour-weight")) {
        if (cli_parse_double(sub, opt, val, 0.0, 1e6, &d))
            return -1;
        ro->colour_weight = d;
    } else if (!strcmp(opt, "--colour-term")) {
        int t = cli_name_index(val, pipeline_colour_term_names, PIPELINE_N_COLOUR_TERMS);
        if (t < 0) {
            cli_error(sub, "%s: expected blocks or sorted, got \"%s\"", opt, val);
            return -1;
        }
        ro->colour_term = (pipeline_colour_term)t;
    } else if (!strcmp(opt, "--colour-phase")) {
        if (cli_parse_ll(sub, opt, val, 0, 100000, &n))
            return -1;
        ro->colour_phase = (int)n;
    } else if (!strcmp(opt, "--colour-phase-weight")) {
        if (cli_parse_double(sub, opt, val, 0.0, 1e6, &d))
            return -1;
        ro->colour_phase_weight = d;
    } else if (!strcmp(opt, "--start-colour-weight")) {
        if (cli_parse_double(sub, opt, val, 0.0, 1e6, &d))
            return -1;
        ro->start_colour_weight = d;
    } else if (!strcmp(opt, "--starts")) {
        if (cli_parse_ll(sub, opt, val, 1, 64, &n))
            return -1;
        ro->starts = (int)n;
    } else
        return 0;
    return 1;
}

int cli_parse_double(const char *sub, const char *opt, const char *s, double lo, double hi,
                     double *out)
{
    char *end;
    double v = strtod(s, &end);
    if (*end || !*s || !isfinite(v) || v < lo || v > hi) {
        cli_error(sub, "%s: expected a number in [%g, %g], got \"%s\"", opt, lo, hi, s);
        return -1;
    }
    *out = v;
    return 0;
}

int cli_parse_sample_hypotheses(const char *sub, const char *opt, const char *s, double *out)
{
    double t;
    if (cli_parse_double(sub, opt, s, 0, 100, &t))
        return -1;
    if (t > 0 && t < 0.01) {
        cli_error(sub, "%s: expected 0 (the likeliest) or a temperature in [0.01, 100], got \"%s\"",
                  opt, s);
        return -1;
    }
    *out = t;
    return 0;
}

int cli_name_index(const char *s, const char *const *names, int n)
{
    for (int j = 0; j < n; j++)
        if (!strcmp(s, names[j]))
            return j;
    return -1;
}

int cli_parse_nearest_metric(const char *sub, const char *opt, const char *s, int *out)
{
    int m = cli_name_index(s, predictor_metric_names, 2);
    if (m >= 0) {
        *out = m;
        return 0;
    }
    cli_error(sub, "%s: expected pca or whitened, got \"%s\"", opt, s);
    return -1;
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
    fprintf(f, "usage: imsynth [--data DIR] <command> [options]   (imsynth <command> --help)\n"
               "       imsynth --version   (and where the data files are found)\n\n"
               "--data DIR: the directory holding assets/ and blender/ (also $IMSYNTH_DATA);\n"
               "by default the installation's share/imsynth, else the source tree built from.\n"
               "\ncommands:\n");
    for (size_t i = 0; i < sizeof subcommands / sizeof subcommands[0]; i++)
        fprintf(f, "  %-12s %s\n", subcommands[i].name, subcommands[i].summary);
}

int main(int argc, char **argv)
{
    /* --data DIR says where the data files are, for this run and the commands it runs:
     * it sets IMSYNTH_DATA, which pipeline_find_data reads first. */
    if (argc >= 3 && !strcmp(argv[1], "--data")) {
        setenv("IMSYNTH_DATA", argv[2], 1);
        argc -= 2;
        argv += 2;
    }
    if (argc < 2) {
        usage(stderr);
        return EXIT_USAGE;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("imsynth %s\n", IMSYNTH_VERSION);
        char path[1024], err[1024];
        if (pipeline_find_data("assets/supershader.json", path, sizeof path, err, sizeof err) == 0)
            printf("data: %s\n", path);
        else
            printf("data: %s\n", err);
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
