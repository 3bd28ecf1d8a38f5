/*
 * The imsynth command line: one cmd_<name>.c per subcommand, dispatched by main.c.
 *
 * Exit codes (every subcommand):
 *   0  success
 *   1  the work failed (bad input file, invalid graph, I/O error): message on stderr
 *   2  usage error (unknown option, missing argument): message and usage on stderr
 */
#ifndef IMSYNTH_CLI_H
#define IMSYNTH_CLI_H

#include <stdbool.h>
#include <stddef.h>

#include "shadergraph/shadergraph.h" /* sg_blender_mode */

struct datagen_preset;
struct refine_options;

enum { EXIT_OK = 0, EXIT_FAILURE_WORK = 1, EXIT_USAGE = 2 };

/* Each takes the arguments after the subcommand name (argv[0] is the subcommand). */
int cmd_eval_graph(int argc, char **argv);
int cmd_describe(int argc, char **argv);
int cmd_sample(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_extract(int argc, char **argv);
int cmd_export(int argc, char **argv);
int cmd_compare(int argc, char **argv);
int cmd_datagen(int argc, char **argv);
int cmd_dataset(int argc, char **argv);
int cmd_train(int argc, char **argv);
int cmd_infer(int argc, char **argv);
int cmd_forest(int argc, char **argv);
int cmd_fit_predictor(int argc, char **argv);
int cmd_predict(int argc, char **argv);
int cmd_search(int argc, char **argv);
int cmd_predict_params(int argc, char **argv);
int cmd_evaluate(int argc, char **argv);

/* Options shared by subcommands that take a graph and a parameter set (cli_graph.c):
 * [GRAPH.json] [--params P.json | --seed N] [--blender 3|4]; everything else lands in
 * `rest` for the subcommand. The graph defaults to assets/supershader.json. */
typedef struct cli_graph_args {
    const char *graph_path;
    const char *params_path; /* NULL: none */
    long long seed;          /* -1: none */
    sg_blender_mode blender;
    double texture_rotation; /* degrees about +Z (sg_graph_rotate_texture); 0: none */
    const char *rest[32];
    int n_rest;
    char graph_buf[1024]; /* the default graph's resolved path */
} cli_graph_args;

/* Returns EXIT_OK or EXIT_USAGE (after printing why). */
int cli_parse_graph_args(const char *sub, int argc, char **argv, cli_graph_args *ga);
/* Loads the graph (the super-shader found by pipeline_find_data when none was given; then
 * ga->graph_path is set to it), binds --params / --seed if given and turns its texture
 * space by --texture-rotation; NULL after printing why. */
struct sg_graph *cli_load_bound_graph(const char *sub, cli_graph_args *ga);
/* `given` if not NULL, else data file `rel` found by pipeline_find_data (into buf); NULL
 * after printing why. */
const char *cli_data_path(const char *sub, const char *given, const char *rel, char *buf,
                          size_t buflen);

/* extract and export: load, bind, extract (unless export's --full), write -o. */
int cli_write_material(const char *sub, int argc, char **argv, bool export_mode);

/* Prints "imsynth <sub>: <message>" to stderr. */
void cli_error(const char *sub, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Option values: an integer in [lo, hi] / a finite number in [lo, hi]; -1 after printing
 * "imsynth <sub>: <opt>: expected ..." (a usage error). */
int cli_parse_ll(const char *sub, const char *opt, const char *s, long long lo, long long hi,
                 long long *out);
int cli_parse_double(const char *sub, const char *opt, const char *s, double lo, double hi,
                     double *out);
/* A render preset by name (datagen_preset_find); NULL after printing "imsynth <sub>: <opt>:
 * expected one of <names>, got ..." (a usage error). */
const struct datagen_preset *cli_parse_preset(const char *sub, const char *opt, const char *s);
/* The refinement's options, predict's and evaluate's alike: --refine N, --method M,
 * --colour-weight W, --colour-phase N, --colour-phase-weight W, --start-colour-weight W,
 * --starts K into *ro. 1 when opt was one of them, 0 when not, -1 after printing
 * "imsynth <sub>: <opt>: expected ..." (a usage error). */
int cli_parse_refine_option(const char *sub, const char *opt, const char *val,
                            struct refine_options *ro);
/* --sample-hypotheses T: 0 (the predictor's k likeliest combinations) or a temperature in
 * [0.01, 100] (below it p^(1/T) underflows); -1 after printing the usage error. */
int cli_parse_sample_hypotheses(const char *sub, const char *opt, const char *s, double *out);
/* --nearest-metric pca|whitened: *out the predictor_metric (predictor_nearest_metric);
 * -1 after printing the usage error. */
/* The index of s in names[0..n), or -1. */
int cli_name_index(const char *s, const char *const *names, int n);
int cli_parse_nearest_metric(const char *sub, const char *opt, const char *s, int *out);
/* True if argv has -h or --help before any "--". */
int cli_wants_help(int argc, char **argv);

#endif
