/*
 * Shading points per second per core for a representative graph (eval_graph.json:
 * 3 fBM noises at Detail 8, one Voronoi F1, 12 Math nodes, Map Range, Mapping, Color
 * Ramp, Mix), batch evaluator versus one point at a time through the same program.
 *
 *   build/tests/bench/bench_eval [graph.json] [seconds]
 *
 * Single-threaded: the figure is per core.
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "shadergraph/shadergraph.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

enum { W = 256, BATCH = 256 };

/* Evaluates the whole 256x256 plane repeatedly for about `seconds`; returns points/s. */
static double run(sg_evaluator *e, float **out, float *geom_storage, int pointwise,
                  double seconds)
{
    long points = 0;
    double t0 = now(), t;
    do {
        for (int first = 0; first < W * W; first += BATCH) {
            sg_geometry_batch g;
            sg_plane_geometry(W, W, first, BATCH, geom_storage, &g);
            if (pointwise)
                sg_evaluate_pointwise(e, &g, out);
            else
                sg_evaluate(e, &g, out);
            points += BATCH;
        }
        t = now();
    } while (t - t0 < seconds);
    return (double)points / (t - t0);
}

int main(int argc, char **argv)
{
    const char *path = argc > 1 ? argv[1] : IMSYNTH_SOURCE_DIR "/tests/bench/eval_graph.json";
    double seconds = argc > 2 ? atof(argv[2]) : 3.0;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(path, err, sizeof err);
    if (!g) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    sg_socket_ref refs[2] = {{"Principled BSDF", "Base Color"}, {"Principled BSDF", "Roughness"}};
    sg_program *p = sg_compile(g, refs, 2, NULL, err, sizeof err);
    if (!p) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    sg_evaluator *e = sg_evaluator_new(p, BATCH);
    float *geom = malloc(sizeof(float) * 48 * BATCH);
    float *o0 = malloc(sizeof(float) * 3 * BATCH), *o1 = malloc(sizeof(float) * BATCH);
    float *out[2] = {o0, o1};
    /* Both ways must compute the same values, bit for bit. */
    float *q0 = malloc(sizeof(float) * 3 * BATCH), *q1 = malloc(sizeof(float) * BATCH);
    float *outq[2] = {q0, q1};
    sg_geometry_batch gb;
    sg_plane_geometry(W, W, 12345, BATCH, geom, &gb);
    sg_evaluate(e, &gb, out);
    sg_evaluate_pointwise(e, &gb, outq);
    for (int i = 0; i < BATCH; i++)
        if (o0[i] != q0[i] || o0[2 * BATCH + i] != q0[2 * BATCH + i] || o1[i] != q1[i]) {
            fprintf(stderr, "batch and pointwise results differ at point %d\n", i);
            return 1;
        }
    free(q0);
    free(q1);
    double batch = run(e, out, geom, 0, seconds);
    double point = run(e, out, geom, 1, seconds);
    printf("graph: %s (%d instructions)\n", path, sg_program_instruction_count(p));
    printf("batch (%d points):  %10.0f points/s per core\n", BATCH, batch);
    printf("one point at a time: %10.0f points/s per core\n", point);
    printf("batch / pointwise:   %10.2fx\n", batch / point);
    free(geom);
    free(o0);
    free(o1);
    sg_evaluator_free(e);
    sg_program_free(p);
    sg_graph_free(g);
    return 0;
}
