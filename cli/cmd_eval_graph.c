/* imsynth eval-graph: a socket's value over the scene's plane, at pixel centres. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "imageio/imageio.h"
#include "shadergraph/shadergraph.h"

static const char *const help =
    "usage: imsynth eval-graph GRAPH.json --socket NODE:SOCKET -o OUT.exr [options]\n"
    "\n"
    "Evaluates one socket of a node graph at the pixel centres of the scene's\n"
    "orthographic view of its plane (DESIGN.md) and writes a linear float EXR.\n"
    "SOCKET is an output socket identifier, or an input socket identifier (its linked\n"
    "value or default), e.g. \"Principled BSDF:Base Color\".\n"
    "\n"
    "options:\n"
    "  --socket NODE:SOCKET  the socket to evaluate (required)\n"
    "  -o, --output OUT.exr  output EXR, float32, ZIP (required)\n"
    "  --png OUT.png         also write an sRGB PNG for people\n"
    "  --size N              image width and height in pixels (default 256)\n"
    "  --blender 4|3         node semantics of Blender 4.x (default) or 3.x\n"
    "  --pointwise           evaluate one point at a time (slow; for comparison)\n";

int cmd_eval_graph(int argc, char **argv)
{
    const char *sub = "eval-graph";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    const char *graph_path = NULL, *out_path = NULL, *png_path = NULL;
    char *socket_arg = NULL;
    int size = 256, blender = 4, pointwise = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *val = i + 1 < argc ? argv[i + 1] : NULL;
        bool takes = !strcmp(a, "--socket") || !strcmp(a, "-o") || !strcmp(a, "--output") ||
                     !strcmp(a, "--png") || !strcmp(a, "--size") || !strcmp(a, "--blender");
        if (takes && !val) {
            cli_error(sub, "%s needs a value", a);
            return EXIT_USAGE;
        }
        if (!strcmp(a, "--socket"))
            socket_arg = argv[++i];
        else if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            out_path = argv[++i];
        else if (!strcmp(a, "--png"))
            png_path = argv[++i];
        else if (!strcmp(a, "--size")) {
            char *end;
            long v = strtol(argv[++i], &end, 10);
            if (*end || v < 1 || v > 8192) {
                cli_error(sub, "--size: expected an integer in [1, 8192], got \"%s\"", argv[i]);
                return EXIT_USAGE;
            }
            size = (int)v;
        } else if (!strcmp(a, "--blender")) {
            const char *v = argv[++i];
            if (strcmp(v, "3") && strcmp(v, "4")) {
                cli_error(sub, "--blender: expected 3 or 4, got \"%s\"", v);
                return EXIT_USAGE;
            }
            blender = v[0] - '0';
        } else if (!strcmp(a, "--pointwise"))
            pointwise = 1;
        else if (a[0] == '-' && a[1]) {
            cli_error(sub, "unknown option \"%s\"", a);
            return EXIT_USAGE;
        } else if (!graph_path)
            graph_path = a;
        else {
            cli_error(sub, "unexpected argument \"%s\"", a);
            return EXIT_USAGE;
        }
    }
    if (!graph_path || !socket_arg || !out_path) {
        cli_error(sub, "need GRAPH.json, --socket and -o (see --help)");
        return EXIT_USAGE;
    }

    char err[SG_ERROR_MAX] = "";
    sg_socket_ref ref;
    if (sg_socket_ref_parse(socket_arg, &ref, err, sizeof err) < 0) {
        cli_error(sub, "--socket %s", err);
        return EXIT_USAGE;
    }
    sg_graph *g = sg_graph_load_file(graph_path, err, sizeof err);
    if (!g) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    sg_compile_options opt = {.blender = blender == 3 ? SG_BLENDER_3 : SG_BLENDER_4};
    sg_program *p = sg_compile(g, &ref, 1, &opt, err, sizeof err);
    sg_graph_free(g);
    if (!p) {
        cli_error(sub, "%s: %s", graph_path, err);
        return EXIT_FAILURE_WORK;
    }
    enum { BATCH = 256 };
    int width = sg_socket_type_width(sg_program_output_type(p, 0));
    sg_evaluator *e = sg_evaluator_new(p, BATCH);
    float *geom_storage = malloc(sizeof(float) * 48 * BATCH);
    float *values = malloc(sizeof(float) * 3 * BATCH);
    image img = {0};
    int rc = EXIT_OK;
    if (!e || !geom_storage || !values || image_alloc(&img, size, size, 3) < 0) {
        cli_error(sub, "out of memory");
        rc = EXIT_FAILURE_WORK;
        goto done;
    }
    int total = size * size;
    for (int first = 0; first < total; first += BATCH) {
        int n = total - first < BATCH ? total - first : BATCH;
        sg_geometry_batch geom;
        sg_plane_geometry(size, size, first, n, geom_storage, &geom);
        float *out[1] = {values};
        if (pointwise)
            sg_evaluate_pointwise(e, &geom, out);
        else
            sg_evaluate(e, &geom, out);
        for (int i = 0; i < n; i++)
            for (int c = 0; c < 3; c++)
                img.pixels[(size_t)(first + i) * 3 + (size_t)c] =
                    width == 1 ? values[i] : values[(size_t)c * (size_t)n + (size_t)i];
    }
    char msg[600];
    if (image_write_exr(out_path, &img, IMAGE_EXR_FLOAT, msg, sizeof msg) < 0 ||
        (png_path && image_write_png(png_path, &img, msg, sizeof msg) < 0)) {
        cli_error(sub, "%s", msg);
        rc = EXIT_FAILURE_WORK;
    }
done:
    image_free(&img);
    free(values);
    free(geom_storage);
    sg_evaluator_free(e);
    sg_program_free(p);
    return rc;
}
