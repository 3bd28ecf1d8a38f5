/*
 * MobileNetV2 Gram descriptor speed against the VGG19 path, in one run: seconds per image
 * for the default taps at one and two scales, batch 1 and 8, beside VGG19 (random
 * weights, avg3, fp32 and fast) on the same inputs and threads; the ratios are printed.
 *
 *   OPENBLAS_NUM_THREADS=1 ./tests/bench/bench_mobilenet [--threads 2] [--reps 3]
 *                          [--weights F.safetensors]
 *
 * FLOPs: 2 K C (k^2) H W per conv (depthwise: 2 * 9 * C * H W) plus each Gram's C^2 HW,
 * as bench_vgg counts. Wall and process CPU time (all threads) both reported.
 */
#include <cblas.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "nn/nn.h"

static double now(clockid_t id)
{
    struct timespec ts;
    clock_gettime(id, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static double mnv2_gflop(const mobilenetv2 *net, const mnv2_options *opt)
{
    double flop = 0.0;
    for (int s = 0; s < opt->scales; s++) {
        double h = (224 >> s) / 2;
        flop += 2.0 * 32 * 27 * h * h;
        double tap_hw[MNV2_MAX_TAPS] = {0};
        for (int t = 0; t < opt->ntaps; t++)
            if (opt->taps[t].point == MNV2_CONV1)
                tap_hw[t] = h * h;
        for (int b = 0; b < MNV2_BLOCKS; b++) {
            double oh = h / net->stride[b];
            if (net->expand_w[b])
                flop += 2.0 * net->cexp[b] * net->cin[b] * h * h;
            flop += 2.0 * 9 * net->cexp[b] * oh * oh + 2.0 * net->cout[b] * net->cexp[b] * oh * oh;
            for (int t = 0; t < opt->ntaps; t++)
                if (opt->taps[t].point != MNV2_CONV1 && opt->taps[t].block == b)
                    tap_hw[t] = opt->taps[t].point == MNV2_EXPAND ? h * h : oh * oh;
            h = oh;
        }
        for (int t = 0; t < opt->ntaps; t++) {
            double c = mnv2_tap_channels(net, opt->taps[t]);
            flop += c * c * tap_hw[t];
        }
    }
    return flop * 1e-9;
}

typedef struct timing {
    double wall, cpu;
} timing;

static timing time_mnv2(const mobilenetv2 *net, mnv2_options opt, const float *in, int n,
                        int reps, float *out)
{
    mnv2_workspace *ws = mnv2_workspace_create(net, &opt, 224, n);
    if (!ws)
        exit(1);
    mnv2_describe(ws, in, n, out); /* warm-up */
    timing best = {1e30, 1e30};
    for (int r = 0; r < reps; r++) {
        double t = now(CLOCK_MONOTONIC), c = now(CLOCK_PROCESS_CPUTIME_ID);
        mnv2_describe(ws, in, n, out);
        t = now(CLOCK_MONOTONIC) - t;
        c = now(CLOCK_PROCESS_CPUTIME_ID) - c;
        best.wall = t < best.wall ? t : best.wall;
        best.cpu = c < best.cpu ? c : best.cpu;
    }
    mnv2_workspace_free(ws);
    best.wall /= n;
    best.cpu /= n;
    return best;
}

static timing time_vgg(const vgg19 *net, vgg_precision prec, int threads, const float *in,
                       int n, int reps, float *out)
{
    vgg_options opt = {.pool = VGG_POOL_AVG3, .precision = prec, .threads = threads};
    vgg_workspace *ws = vgg_workspace_create(net, &opt, n);
    if (!ws)
        exit(1);
    vgg_describe(ws, in, n, out);
    timing best = {1e30, 1e30};
    for (int r = 0; r < reps; r++) {
        double t = now(CLOCK_MONOTONIC), c = now(CLOCK_PROCESS_CPUTIME_ID);
        vgg_describe(ws, in, n, out);
        t = now(CLOCK_MONOTONIC) - t;
        c = now(CLOCK_PROCESS_CPUTIME_ID) - c;
        best.wall = t < best.wall ? t : best.wall;
        best.cpu = c < best.cpu ? c : best.cpu;
    }
    vgg_workspace_free(ws);
    best.wall /= n;
    best.cpu /= n;
    return best;
}

int main(int argc, char **argv)
{
    int threads = 2, reps = 3;
    const char *weights = IMSYNTH_SOURCE_DIR "/assets/mobilenetv2/mobilenetv2_block10.safetensors";
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--reps") && i + 1 < argc)
            reps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--weights") && i + 1 < argc)
            weights = argv[++i];
    }
    char err[512];
    mobilenetv2 mnet;
    if (mnv2_load(&mnet, weights, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    vgg19 vnet;
    if (vgg19_init_random(&vnet, vgg19_standard_width, 1))
        return 1;
    const int nmax = 8;
    const size_t img = 3 * 224 * 224;
    float *in = malloc(nmax * img * sizeof(float));
    float *out = malloc(nmax * vgg19_descriptor_size(&vnet) * sizeof(float));
    for (size_t i = 0; i < nmax * img; i++) /* [0,1], as both networks' callers feed */
        in[i] = (float)((i * 2654435761u) % 1000) / 1000.0f;
    printf("openblas threads %d, our threads %d, reps %d (best of)\n",
           openblas_get_num_threads(), threads, reps);
    printf("%-26s %5s %10s %12s %8s %14s\n", "descriptor", "batch", "ms/image", "cpu-ms/image",
           "GFLOP/s", "VGG-fp32/this");
    timing vgg32[2], vggfast[2];
    const int batches[2] = {1, nmax};
    for (int b = 0; b < 2; b++) {
        vgg32[b] = time_vgg(&vnet, VGG_PRECISION_FP32, threads, in, batches[b], reps, out);
        vggfast[b] = time_vgg(&vnet, VGG_PRECISION_FAST, threads, in, batches[b], reps, out);
    }
    for (int b = 0; b < 2; b++) {
        printf("%-26s %5d %10.1f %12.1f %8s %14s\n", "vgg19 avg3 fp32", batches[b],
               1e3 * vgg32[b].wall, 1e3 * vgg32[b].cpu, "", "1.0");
        printf("%-26s %5d %10.1f %12.1f %8s %14.1f\n", "vgg19 avg3 fast", batches[b],
               1e3 * vggfast[b].wall, 1e3 * vggfast[b].cpu, "", vgg32[b].wall / vggfast[b].wall);
    }
    for (int scales = 1; scales <= 2; scales++)
        for (int b = 0; b < 2; b++) {
            mnv2_options opt = {.scales = scales, .threads = threads};
            opt.ntaps = mnv2_taps_parse(mnv2_default_taps, opt.taps, err, sizeof err);
            timing t = time_mnv2(&mnet, opt, in, batches[b], reps, out);
            char name[64];
            snprintf(name, sizeof name, "mobilenetv2 default x%d", scales);
            printf("%-26s %5d %10.2f %12.2f %8.1f %14.1f\n", name, batches[b], 1e3 * t.wall,
                   1e3 * t.cpu, mnv2_gflop(&mnet, &opt) / t.wall, vgg32[b].wall / t.wall);
        }
    /* the forward alone: one cheap tap (block_10_project, 96 ch at 14x14) */
    mnv2_options opt = {.scales = 1, .threads = threads};
    opt.ntaps = mnv2_taps_parse("block_10_project", opt.taps, err, sizeof err);
    timing t = time_mnv2(&mnet, opt, in, nmax, reps, out);
    printf("%-26s %5d %10.2f %12.2f %8.1f %14.1f\n", "mobilenetv2 forward only", nmax,
           1e3 * t.wall, 1e3 * t.cpu, mnv2_gflop(&mnet, &opt) / t.wall, vgg32[1].wall / t.wall);
    mnv2_free(&mnet);
    vgg19_free(&vnet);
    free(in);
    free(out);
    return 0;
}
