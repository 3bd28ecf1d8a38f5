/*
 * Prediction latency in one process (issue 15's "prediction < 100 ms"): a model directory
 * loaded once, then per input image the descriptor (the model's network on a 256 x 256
 * render), the top-k hypotheses, and retrieval in the catalogue, each timed apart.
 *
 *     bench_predict MODEL_DIR DATASET.sqlite [N] [K]
 *
 * The inputs are the first N stored renders of the dataset (decoded PNG16, as a user's
 * image would be after image_read).
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "pipeline/pipeline.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: bench_predict MODEL_DIR DATASET.sqlite [N] [K]\n");
        return 2;
    }
    int n = argc > 3 ? atoi(argv[3]) : 50, k = argc > 4 ? atoi(argv[4]) : 8;
    char err[1024];
    double t0 = now();
    predictor *p = predictor_load(argv[1], err, sizeof err);
    if (!p) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    double t_load = now() - t0;
    pipeline_descriptor *pd = pipeline_descriptor_create(predictor_descriptor_kind(p), err,
                                                         sizeof err);
    dataset *ds = dataset_open(argv[2], err, sizeof err);
    dataset_iter *it = ds ? dataset_iter_new(ds, 0, 1, err, sizeof err) : NULL;
    if (!pd || !it) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    int np = predictor_n_params(p);
    float *desc = malloc(predictor_descriptor_size(p) * sizeof *desc);
    float *params = malloc((size_t)k * (size_t)np * sizeof *params);
    size_t *index = malloc((size_t)k * sizeof *index);
    double t_desc = 0, t_top1 = 0, t_topk = 0, t_near = 0;
    int done = 0;
    dataset_row row;
    while (done < n && dataset_iter_next(it, &row, err, sizeof err) == 1) {
        double a = now();
        float stats[PIPELINE_TEXSTATS_N];
        if (pipeline_descriptor_compute(pd, &row.img, desc, err, sizeof err) ||
            pipeline_texstats(&row.img, stats, err, sizeof err)) {
            fprintf(stderr, "%s\n", err);
            return 1;
        }
        double b = now();
        predictor_predict(p, desc, stats, 1, params, NULL, err, sizeof err);
        double c = now();
        predictor_predict(p, desc, stats, k, params, NULL, err, sizeof err);
        double d = now();
        predictor_nearest(p, desc, k, index, NULL, err, sizeof err);
        double e = now();
        t_desc += b - a;
        t_top1 += c - b;
        t_topk += d - c;
        t_near += e - d;
        done++;
    }
    printf("model load %.1f ms (catalogue %zu, %zu features)\n", 1e3 * t_load,
           predictor_catalogue_size(p), predictor_descriptor_size(p));
    printf("per image over %d: descriptor %.2f ms, predict top-1 %.2f ms, top-%d %.2f ms, "
           "nearest %d %.2f ms; descriptor + top-%d %.2f ms\n",
           done, 1e3 * t_desc / done, 1e3 * t_top1 / done, k, 1e3 * t_topk / done, k,
           1e3 * t_near / done, k, 1e3 * (t_desc + t_topk) / done);
    free(desc);
    free(params);
    free(index);
    dataset_iter_free(it);
    dataset_close(ds);
    pipeline_descriptor_free(pd);
    predictor_free(p);
    return 0;
}
