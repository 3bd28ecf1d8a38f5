/*
 * VGG19 Gram descriptor speed: seconds per image and GFLOP/s for batch 1 and 8, pooling
 * avg3 and max2, fp32 and fast; OpenBLAS sgemm GFLOP/s on the same machine for scale.
 *
 *   OPENBLAS_NUM_THREADS=1 ./tests/bench/bench_vgg [--threads 2] [--reps 3] [--quick]
 *
 * Run beside tests/bench/bench_vgg_torch.py (same input sizes, same FLOP count); the
 * numbers go to BENCHMARKS.md. FLOPs are the direct convolutions' 2*K*C*9*H*W per layer
 * plus the Grams' C*C*H*W (what PyTorch executes at batch 1), whatever algorithm runs.
 * Wall time and process CPU time (all threads) are both reported: on a shared machine
 * the CPU time is the steadier of the two.
 */
#include <cblas.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "nn/nn.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static double vgg_gflop(vgg_pool pool)
{
    const int width[5] = {64, 128, 256, 512, 512}, convs[5] = {2, 2, 4, 4, 4};
    double flop = 0.0;
    int s = 224, cin = 3;
    for (int b = 0; b < 5; b++) {
        for (int i = 0; i < convs[b]; i++) {
            flop += 2.0 * width[b] * cin * 9.0 * s * s;
            cin = width[b];
        }
        flop += (double)width[b] * width[b] * s * s; /* Gram (symmetric half: C*C*HW) */
        s = pool == VGG_POOL_AVG3 ? (s - 3) / 3 + 1 : s / 2;
    }
    return flop * 1e-9;
}

static double sgemm_gflops(int reps)
{
    const int n = 1024;
    float *a = malloc(sizeof(float) * n * n), *b = malloc(sizeof(float) * n * n),
          *c = malloc(sizeof(float) * n * n);
    for (int i = 0; i < n * n; i++)
        a[i] = b[i] = (float)(i % 7) * 0.1f;
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, n, n, n, 1, a, n, b, n, 0, c, n);
    double best = 1e30;
    for (int r = 0; r < reps; r++) {
        double t = now();
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, n, n, n, 1, a, n, b, n, 0, c, n);
        t = now() - t;
        best = t < best ? t : best;
    }
    free(a);
    free(b);
    free(c);
    return 2.0 * n * n * n / best * 1e-9;
}

int main(int argc, char **argv)
{
    int threads = 2, reps = 3, quick = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--reps") && i + 1 < argc)
            reps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--quick"))
            quick = 1;
    }
    vgg19 net;
    if (vgg19_init_random(&net, vgg19_standard_width, 1))
        return 1;
    const size_t row = vgg19_descriptor_size(&net), img = 3 * 224 * 224;
    float *in = malloc(8 * img * sizeof(float)), *out = malloc(8 * row * sizeof(float));
    for (size_t i = 0; i < 8 * img; i++)
        in[i] = (float)((i * 2654435761u) % 1000) / 500.0f - 1.0f;

    printf("openblas threads %d, our threads %d, reps %d (best of)\n", openblas_get_num_threads(),
           threads, reps);
    /* sgemm at 1 thread and at the OpenBLAS default, for scale. */
    printf("sgemm 1024^3: %.1f GFLOP/s (openblas %d threads)\n", sgemm_gflops(reps),
           openblas_get_num_threads());

    const vgg_pool pools[2] = {VGG_POOL_AVG3, VGG_POOL_MAX2};
    const char *pool_names[3] = {"avg3", "avg2", "max2"};
    const int batches[2] = {1, 8};
    const vgg_precision precs[2] = {VGG_PRECISION_FP32, VGG_PRECISION_FAST};
    printf("%-5s %-5s %5s %10s %8s %12s %10s\n", "pool", "prec", "batch", "s/image", "GFLOP/s",
           "cpu-s/image", "workspace");
    for (int p = 0; p < (quick ? 1 : 2); p++)
        for (int q = 0; q < 2; q++)
            for (int b = 0; b < 2; b++) {
                vgg_options opt = {.pool = pools[p], .precision = precs[q], .threads = threads};
                int n = batches[b];
                vgg_workspace *ws = vgg_workspace_create(&net, &opt, n);
                if (!ws)
                    return 1;
                vgg_describe(ws, in, n, out); /* warm-up: page in buffers */
                double best = 1e30, best_cpu = 1e30;
                for (int r = 0; r < reps; r++) {
                    double t = now(), c = cpu_now();
                    vgg_describe(ws, in, n, out);
                    t = now() - t;
                    c = cpu_now() - c;
                    best = t < best ? t : best;
                    best_cpu = c < best_cpu ? c : best_cpu;
                }
                double per = best / n;
                printf("%-5s %-5s %5d %10.4f %8.1f %12.4f %8.1f MB\n", pool_names[pools[p]],
                       precs[q] == VGG_PRECISION_FP32 ? "fp32" : "fast", n, per,
                       vgg_gflop(pools[p]) / per, best_cpu / n,
                       vgg_workspace_bytes(ws) / 1048576.0);
                fflush(stdout);
                vgg_workspace_free(ws);
            }
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("peak RSS of the whole run: %.1f MB\n", ru.ru_maxrss / 1024.0);
    vgg19_free(&net);
    free(in);
    free(out);
    return 0;
}
