/* bench_forest: the memory case of issue 12 -- a forest on ROWS x FEATURES synthetic
 * descriptors (default 5,000 x 305,888, the full Gram descriptor) in binned mode, with
 * peak RSS. The data are made in memory (a 6 GB .npy would only measure the disk); the
 * CLI's path differs only by reading X with nn_npy_read_f32 into the same float array.
 *
 * usage: bench_forest [ROWS [FEATURES [OUTPUTS [TREES [THREADS]]]]]
 * Speed against scikit-learn is bench_forest.py's job. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <time.h>

#include "forest/forest.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static double cpu_seconds(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return (double)u.ru_utime.tv_sec + 1e-6 * (double)u.ru_utime.tv_usec +
           (double)u.ru_stime.tv_sec + 1e-6 * (double)u.ru_stime.tv_usec;
}

static double peak_rss_gb(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return (double)u.ru_maxrss / (1024.0 * 1024.0); /* ru_maxrss is in KiB on Linux */
}

/* Gram-like features: every feature a noisy mix of 16 latent factors (so many features
 * carry signal, as Gram entries do), outputs smooth functions of the factors. */
static void make_rows(size_t n, size_t d, size_t k, uint64_t seed, float *X, float *Y)
{
    enum { LATENT = 16 };
    uint64_t s = seed;
#define NEXT() (s = s * 6364136223846793005ull + 1442695040888963407ull, \
                (float)((double)(s >> 11) / 9007199254740992.0))
    for (size_t i = 0; i < n; i++) {
        float z[LATENT];
        for (int l = 0; l < LATENT; l++)
            z[l] = NEXT() * 2.0f - 1.0f;
        float *x = X + i * d;
        for (size_t j = 0; j < d; j++) {
            /* feature j loads on factor j % LATENT with a weight falling with j */
            float w = 1.0f / (1.0f + (float)(j / LATENT) * 0.001f);
            x[j] = w * z[j % LATENT] + 0.5f * (NEXT() - 0.5f);
        }
        for (size_t o = 0; o < k; o++)
            Y[i * k + o] = sinf(2.0f * z[o % LATENT]) + z[(o * 7 + 3) % LATENT] *
                           z[(o * 5 + 1) % LATENT];
    }
#undef NEXT
}

int main(int argc, char **argv)
{
    size_t n = argc > 1 ? strtoul(argv[1], NULL, 10) : 5000;
    size_t d = argc > 2 ? strtoul(argv[2], NULL, 10) : 305888;
    size_t k = argc > 3 ? strtoul(argv[3], NULL, 10) : 50;
    int trees = argc > 4 ? atoi(argv[4]) : 20;
    int threads = argc > 5 ? atoi(argv[5]) : 2;
    size_t nt = 500;
    double t0 = now();
    float *X = malloc(n * d * sizeof *X), *Y = malloc(n * k * sizeof *Y);
    float *Xt = malloc(nt * d * sizeof *Xt), *Yt = malloc(nt * k * sizeof *Yt);
    if (!X || !Y || !Xt || !Yt) {
        fprintf(stderr, "bench_forest: out of memory for %zu x %zu floats\n", n, d);
        return 1;
    }
    make_rows(n, d, k, 1, X, Y);
    make_rows(nt, d, k, 2, Xt, Yt);
    double t_data = now() - t0;
    printf("data: %zu x %zu (+%zu held out) -> %zu outputs, %.1f s, float X %.2f GB\n", n, d,
           nt, k, t_data, (double)n * d * 4 / 1e9);
    fflush(stdout);
    forest_params p = forest_default_params();
    p.n_estimators = trees;
    p.max_features = FOREST_MAXF_SQRT;
    p.n_threads = threads;
    char err[512];
    forest *f = NULL;
    double c0 = cpu_seconds(), t1 = now();
    if (forest_fit(X, n, d, Y, k, NULL, &p, &f, err, sizeof err)) {
        fprintf(stderr, "bench_forest: %s\n", err);
        return 1;
    }
    double t_fit = now() - t1, c_fit = cpu_seconds() - c0;
    double r2 = forest_score(f, Xt, Yt, NULL, nt, threads);
    printf("fit: %d trees, max_features sqrt, %d threads: %.1f s wall, %.1f s CPU; %zu nodes\n",
           trees, threads, t_fit, c_fit, forest_n_nodes(f));
    printf("held-out R^2 (mean over outputs): %.4f\n", r2);
    printf("peak RSS: %.2f GB (float X %.2f GB + uint8 bins %.2f GB + the rest)\n",
           peak_rss_gb(), (double)n * d * 4 / 1e9, (double)n * d / 1e9);
    forest_free(f);
    free(X);
    free(Y);
    free(Xt);
    free(Yt);
    return 0;
}
