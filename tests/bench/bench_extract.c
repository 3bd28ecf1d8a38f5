/*
 * Sub-shader extraction over many random parametrizations of the super-shader:
 * the distribution of node counts (median, 90th percentile, max) and the time per
 * extraction (binding the parameters included), and a digest of every sub-shader's JSON
 * text (FNV-1a over the seeds in order): two builds that print the same digest extracted
 * the same sub-shaders, byte for byte.
 *
 *   build/tests/bench/bench_extract [count] [graph.json]     (default 1000 seeds)
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "shadergraph/shadergraph.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp_int(const void *a, const void *b) { return *(const int *)a - *(const int *)b; }
static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    int count = argc > 1 ? atoi(argv[1]) : 1000;
    const char *path = argc > 2 ? argv[2] : IMSYNTH_SOURCE_DIR "/assets/supershader.json";
    if (count < 1)
        count = 1;
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(path, err, sizeof err);
    sg_params p;
    if (!g || sg_params_from_graph(g, &p, err, sizeof err) < 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    uint64_t digest = 1469598103934665603ull; /* FNV-1a offset basis */
    int *nodes = malloc(sizeof(int) * (size_t)count);
    double *ms = malloc(sizeof(double) * (size_t)count);
    for (int s = 0; s < count; s++) {
        sg_params_sample(&p, (unsigned long long)s);
        double t0 = now();
        if (sg_graph_bind_params(g, &p, err, sizeof err) < 0) {
            fprintf(stderr, "%s\n", err);
            return 1;
        }
        sg_graph *x = sg_extract(g, NULL, err, sizeof err);
        ms[s] = 1e3 * (now() - t0);
        if (!x) {
            fprintf(stderr, "seed %d: %s\n", s, err);
            return 1;
        }
        nodes[s] = sg_graph_node_count(x);
        char *text = sg_graph_to_json(x);
        if (!text) {
            fprintf(stderr, "seed %d: out of memory\n", s);
            return 1;
        }
        for (size_t i = 0, n = strlen(text); i < n; i++)
            digest = (digest ^ (unsigned char)text[i]) * 1099511628211ull;
        free(text);
        sg_graph_free(x);
    }
    qsort(nodes, (size_t)count, sizeof *nodes, cmp_int);
    qsort(ms, (size_t)count, sizeof *ms, cmp_double);
    printf("super-shader %s: %d nodes, %d parameters\n", path, sg_graph_node_count(g), p.n);
    printf("sub-shaders over %d seeds: median %d nodes, 90th percentile %d, max %d, min %d\n",
           count, nodes[count / 2], nodes[(count * 9) / 10], nodes[count - 1], nodes[0]);
    printf("extraction time: median %.2f ms, 90th percentile %.2f ms, max %.2f ms\n",
           ms[count / 2], ms[(count * 9) / 10], ms[count - 1]);
    printf("sub-shaders' JSON digest: %016llx\n", (unsigned long long)digest);
    free(nodes);
    free(ms);
    sg_params_free(&p);
    sg_graph_free(g);
    return 0;
}
