/*
 * Training throughput and inference latency of an MLP (BENCHMARKS.md; run beside the
 * PyTorch side by bench_train.sh):
 *     bench_train [--arch SPEC] [--batch 128] [--steps 30] [--threads 2]
 * Default the 2500-1000-1000-50 ReLU MLP, AdamW, MSE on a sigmoid head, random
 * data of 8 batches. Reports training samples/s (wall, after 3 warm-up steps) and the
 * median latency of one-sample inference.
 */
#include <cblas.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "nn/nn.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv)
{
    const char *arch = "mlp:2500-1000-1000-50,relu";
    int batch = 128, steps = 30, threads = 2;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (!strcmp(argv[i], "--arch"))
            arch = argv[i + 1];
        else if (!strcmp(argv[i], "--batch"))
            batch = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--steps"))
            steps = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--threads"))
            threads = atoi(argv[i + 1]);
    }
    openblas_set_num_threads(1);
    char err[512], heads_spec[64];
    nn_mlp_config cfg;
    if (nn_mlp_parse_arch(arch, &cfg, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return 2;
    }
    int in = cfg.width[0], out = cfg.width[cfg.n_linear];
    snprintf(heads_spec, sizeof heads_spec, "sigmoid:0-%d", out - 1);
    nn_head heads[1];
    if (nn_heads_parse(heads_spec, out, out, NN_LOSS_MSE, heads, 1, err, sizeof err) != 1) {
        fprintf(stderr, "%s\n", err);
        return 2;
    }
    nn_mlp m;
    if (nn_mlp_create(&m, &cfg, heads, 1, 1, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    m.threads = threads;
    nn_optimizer_config oc = nn_optimizer_defaults(NN_OPT_ADAMW);
    nn_optimizer opt;
    if (nn_optimizer_init(&opt, &oc, m.n_floats))
        return 1;
    enum { BATCHES = 8 };
    size_t rows = (size_t)batch * BATCHES;
    float *x = malloc(rows * in * sizeof(float)), *y = malloc(rows * out * sizeof(float));
    uint64_t s = 42;
    for (size_t i = 0; i < rows * in; i++) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        x[i] = (float)((double)(s >> 11) * 0x1p-53 * 2 - 1);
    }
    for (size_t i = 0; i < rows * out; i++) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        y[i] = (float)((double)(s >> 11) * 0x1p-53);
    }
    double loss = 0;
    for (int t = 0; t < 3; t++)
        nn_mlp_train_step(&m, &opt, x, y, NULL, batch, &loss);
    double t0 = now();
    for (int t = 0; t < steps; t++) {
        size_t b = (size_t)(t % BATCHES) * batch;
        nn_mlp_train_step(&m, &opt, x + b * in, y + b * out, NULL, batch, &loss);
    }
    double dt = now() - t0;
    // inference, one sample (threads as given; small products run as one sgemm)
    enum { REPS = 200 };
    double lat[REPS];
    float *pred = malloc((size_t)out * sizeof(float));
    for (int r = 0; r < REPS; r++) {
        double a = now();
        nn_mlp_forward(&m, x + (size_t)(r % rows) * in, 1, pred);
        lat[r] = now() - a;
    }
    qsort(lat, REPS, sizeof lat[0], cmp_double);
    printf("imsynth  %s batch %d threads %d: %zu params, train %.1f samples/s (%.2f ms/step), "
           "infer 1 sample %.3f ms (median of %d), last loss %.5f\n",
           arch, batch, threads, m.n_floats, steps * batch / dt, 1e3 * dt / steps,
           1e3 * lat[REPS / 2], REPS, loss);
    free(x);
    free(y);
    free(pred);
    nn_optimizer_free(&opt);
    nn_mlp_free(&m);
    return 0;
}
