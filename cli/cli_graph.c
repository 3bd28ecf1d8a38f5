/* Shared by the subcommands that take a graph and a parameter set. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cli/cli.h"
#include "pipeline/pipeline.h"
#include "shadergraph/shadergraph.h"

int cli_parse_graph_args(const char *sub, int argc, char **argv, cli_graph_args *ga)
{
    memset(ga, 0, sizeof *ga);
    ga->graph_path = NULL; /* the super-shader, found by cli_load_bound_graph */
    ga->blender = SG_BLENDER_4;
    ga->seed = -1;
    bool have_graph = false;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *val = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--texture-rotation")) {
            if (!val) {
                cli_error(sub, "%s needs a value", a);
                return EXIT_USAGE;
            }
            i++;
            if (cli_parse_double(sub, a, val, -360.0, 360.0, &ga->texture_rotation))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--params") || !strcmp(a, "--seed") || !strcmp(a, "--blender")) {
            if (!val) {
                cli_error(sub, "%s needs a value", a);
                return EXIT_USAGE;
            }
            i++;
            if (!strcmp(a, "--params")) {
                ga->params_path = val;
            } else if (!strcmp(a, "--seed")) {
                char *end;
                long long v = strtoll(val, &end, 10);
                if (*end || v < 0) {
                    cli_error(sub, "--seed: expected a non-negative integer, got \"%s\"", val);
                    return EXIT_USAGE;
                }
                ga->seed = v;
            } else {
                if (strcmp(val, "3") && strcmp(val, "4")) {
                    cli_error(sub, "--blender: expected 3 or 4, got \"%s\"", val);
                    return EXIT_USAGE;
                }
                ga->blender = val[0] == '3' ? SG_BLENDER_3 : SG_BLENDER_4;
            }
        } else if (a[0] != '-' && !have_graph && ga->n_rest == 0) {
            ga->graph_path = a;
            have_graph = true;
        } else {
            if (ga->n_rest < (int)(sizeof ga->rest / sizeof ga->rest[0]))
                ga->rest[ga->n_rest++] = argv[i];
            else {
                cli_error(sub, "too many arguments");
                return EXIT_USAGE;
            }
        }
    }
    if (ga->params_path && ga->seed >= 0) {
        cli_error(sub, "give --params or --seed, not both");
        return EXIT_USAGE;
    }
    return EXIT_OK;
}

const char *cli_data_path(const char *sub, const char *given, const char *rel, char *buf,
                          size_t buflen)
{
    if (given)
        return given;
    char err[1024];
    if (pipeline_find_data(rel, buf, buflen, err, sizeof err)) {
        cli_error(sub, "%s", err);
        return NULL;
    }
    return buf;
}

sg_graph *cli_load_bound_graph(const char *sub, cli_graph_args *ga)
{
    ga->graph_path = cli_data_path(sub, ga->graph_path, "assets/supershader.json", ga->graph_buf,
                                   sizeof ga->graph_buf);
    if (!ga->graph_path)
        return NULL;
    char err[1024];
    sg_graph *g = pipeline_load_graph(ga->graph_path, ga->params_path, ga->seed, err, sizeof err);
    if (!g)
        cli_error(sub, "%s", err);
    if (g && ga->texture_rotation != 0.0) {
        sg_graph *turned = sg_graph_rotate_texture(g, ga->texture_rotation, err, sizeof err);
        sg_graph_free(g);
        if (!(g = turned))
            cli_error(sub, "%s: %s", ga->graph_path, err);
    }
    return g;
}

int cli_write_material(const char *sub, int argc, char **argv, bool export_mode)
{
    cli_graph_args ga;
    const char *out_path = NULL;
    int full = 0, stats = 0;
    int rc = cli_parse_graph_args(sub, argc, argv, &ga);
    if (rc != EXIT_OK)
        return rc;
    for (int i = 0; i < ga.n_rest; i++) {
        const char *a = ga.rest[i];
        if ((!strcmp(a, "-o") || !strcmp(a, "--output")) && i + 1 < ga.n_rest)
            out_path = ga.rest[++i];
        else if (export_mode && !strcmp(a, "--full"))
            full = 1;
        else if (!export_mode && !strcmp(a, "--stats"))
            stats = 1;
        else {
            cli_error(sub, "unexpected argument \"%s\" (see --help)", a);
            return EXIT_USAGE;
        }
    }
    if (!out_path) {
        cli_error(sub, "need -o OUTPUT.json (see --help)");
        return EXIT_USAGE;
    }
    sg_graph *g = cli_load_bound_graph(sub, &ga);
    if (!g)
        return EXIT_FAILURE_WORK;
    char err[SG_ERROR_MAX] = "";
    sg_graph *x = g;
    if (!full) {
        sg_extract_options opt = {.blender = ga.blender};
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        x = sg_extract(g, &opt, err, sizeof err);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        if (!x) {
            cli_error(sub, "%s: %s", ga.graph_path, err);
            sg_graph_free(g);
            return EXIT_FAILURE_WORK;
        }
        if (stats)
            fprintf(stderr, "%s: %d nodes -> %d nodes in %.2f ms\n", ga.graph_path,
                    sg_graph_node_count(g), sg_graph_node_count(x),
                    1e3 * ((double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec)));
    }
    rc = EXIT_OK;
    if (sg_graph_save_file(x, out_path, err, sizeof err) < 0) {
        cli_error(sub, "%s", err);
        rc = EXIT_FAILURE_WORK;
    }
    if (x != g)
        sg_graph_free(x);
    sg_graph_free(g);
    return rc;
}
