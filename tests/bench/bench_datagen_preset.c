/*
 * Which render preset does datagen need? The criterion (issue 11): the descriptor of a
 * preset's render must be at least as close to the descriptor of the converged Cycles
 * reference (4096 samples: the mean of blender-4.3-a/b.exr) as the descriptor of Cycles'
 * own 252-sample render (blender-4.3-252.exr, tests/bench/cycles_252_references.py) is,
 * on the six super-shader frames of tests/reference/render/supershader_s0..s5.
 *
 *   build/tests/bench/bench_datagen_preset [--seeds K]
 *
 * Both of datagen's descriptors: MobileNetV2 (default taps) and VGG19 (random weights,
 * seed 1, avg3, fp32). Distance between descriptors x and y measured against reference r:
 * the mean over the Gram layers (taps) of ||G_l(x) - G_l(y)|| / ||G_l(r)|| (Frobenius over
 * the stored upper triangle), so each layer counts the same whatever its scale. Printed
 * per frame and descriptor: the reference's own noise (half a against half b), Cycles-252,
 * each render configuration (mean over K seeds), the distance to the nearest other frame's
 * reference (how far apart two different materials are), and each configuration's time.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nn/nn.h"
#include "pipeline/pipeline.h"

#include <cblas.h> /* after shadergraph.h: OpenBLAS defines a macro I */

enum { FRAMES = 6, MAX_SEEDS = 8, CONFIGS = 6, DESCS = 2 };

/* The render settings compared: the three presets and three in between. */
typedef struct config {
    const char *name;
    int spp, max_spp;
    float noise_target;
} config;
static const config configs[CONFIGS] = {
    {"draft (1 spp)", 1, 0, 0.03f},         {"datagen (4 spp)", 4, 0, 0.03f},
    {"16 spp", 16, 0, 0.03f},               {"adaptive 64 / 0.1", 4, 64, 0.1f},
    {"adaptive 256 / 0.06", 4, 256, 0.06f}, {"converged (adaptive 256 / 0.03)", 4, 256, 0.03f},
};

/* One descriptor: its network and where its layers start. */
typedef struct desc {
    const char *name;
    int mobilenet;
    vgg19 vgg;
    vgg_workspace *vws;
    mobilenetv2 mnv2;
    mnv2_options mopt;
    mnv2_workspace *mws;
    size_t size, n_layers, off[2 * MNV2_MAX_TAPS + 1];
    float *in;
} desc;

static void describe(desc *d, const image *img, float *out)
{
    int bad = d->mobilenet ? mnv2_preprocess(d->in, img->pixels, img->width, img->height, img->channels)
                           : vgg_preprocess(d->in, img->pixels, img->width, img->height, img->channels);
    if (bad) {
        fprintf(stderr, "image too small\n");
        exit(1);
    }
    if (d->mobilenet)
        mnv2_describe(d->mws, d->in, 1, out);
    else
        vgg_describe(d->vws, d->in, 1, out);
}

static double distance(const desc *d, const float *x, const float *y, const float *r)
{
    double total = 0;
    for (size_t l = 0; l < d->n_layers; l++) {
        double s = 0, n = 0;
        for (size_t i = d->off[l]; i < d->off[l + 1]; i++) {
            double e = (double)x[i] - y[i];
            s += e * e;
            n += (double)r[i] * r[i];
        }
        total += sqrt(s / n);
    }
    return total / (double)d->n_layers;
}

static void read_or_die(const char *path, image *img)
{
    char err[1024];
    if (image_read(path, img, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        exit(1);
    }
}

int main(int argc, char **argv)
{
    int seeds = 3;
    for (int i = 1; i < argc; i++)
        if (!strcmp(argv[i], "--seeds") && i + 1 < argc)
            seeds = atoi(argv[++i]);
    if (seeds < 1 || seeds > MAX_SEEDS)
        seeds = 3;
    openblas_set_num_threads(1);
    char err[1024];
    desc D[DESCS];
    memset(D, 0, sizeof D);
    D[0].name = "MobileNetV2";
    D[0].mobilenet = 1;
    if (mnv2_load(&D[0].mnv2, IMSYNTH_SOURCE_DIR "/assets/mobilenetv2/mobilenetv2_block10.safetensors",
                  err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    D[0].mopt.ntaps = mnv2_taps_parse(mnv2_default_taps, D[0].mopt.taps, err, sizeof err);
    D[0].mopt.scales = 1;
    D[0].mopt.threads = 1;
    D[0].size = mnv2_descriptor_offsets(&D[0].mnv2, &D[0].mopt, D[0].off);
    D[0].n_layers = (size_t)D[0].mopt.ntaps;
    D[0].mws = mnv2_workspace_create(&D[0].mnv2, &D[0].mopt, MNV2_INPUT_SIZE, 1);
    D[1].name = "VGG19";
    vgg19_init_random(&D[1].vgg, vgg19_standard_width, 1);
    vgg_options vo = {.pool = VGG_POOL_AVG3, .precision = VGG_PRECISION_FP32, .threads = 2};
    D[1].vws = vgg_workspace_create(&D[1].vgg, &vo, 1);
    D[1].size = vgg19_descriptor_size(&D[1].vgg);
    vgg19_descriptor_offsets(&D[1].vgg, D[1].off);
    D[1].n_layers = VGG_GRAM_LAYERS;
    for (int k = 0; k < DESCS; k++)
        D[k].in = malloc(3 * VGG_INPUT_SIZE * VGG_INPUT_SIZE * sizeof(float));

    render_scene *scene = render_scene_load(IMSYNTH_SOURCE_DIR "/assets/scene.json", err, sizeof err);
    if (!scene) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    float *ref[DESCS][FRAMES];
    double own[DESCS][FRAMES], cyc[DESCS][FRAMES], dist[DESCS][FRAMES][CONFIGS];
    double secs[FRAMES][CONFIGS];
    float *ta = malloc(D[1].size * sizeof(float)), *tb = malloc(D[1].size * sizeof(float));
    for (int f = 0; f < FRAMES; f++) {
        char dir[512], pa[600], pb[600], pc[600], gp[600];
        snprintf(dir, sizeof dir, "%s/tests/reference/render/supershader_s%d", IMSYNTH_SOURCE_DIR, f);
        snprintf(pa, sizeof pa, "%s/blender-4.3-a.exr", dir);
        snprintf(pb, sizeof pb, "%s/blender-4.3-b.exr", dir);
        snprintf(pc, sizeof pc, "%s/blender-4.3-252.exr", dir);
        snprintf(gp, sizeof gp, "%s/graph.json", dir);
        image a, b, cy, mean;
        read_or_die(pa, &a);
        read_or_die(pb, &b);
        read_or_die(pc, &cy);
        image_alloc(&mean, a.width, a.height, a.channels);
        for (size_t i = 0; i < (size_t)a.width * a.height * a.channels; i++)
            mean.pixels[i] = 0.5f * (a.pixels[i] + b.pixels[i]);
        for (int k = 0; k < DESCS; k++) {
            ref[k][f] = malloc(D[k].size * sizeof(float));
            describe(&D[k], &mean, ref[k][f]);
            describe(&D[k], &a, ta);
            describe(&D[k], &b, tb);
            own[k][f] = distance(&D[k], ta, tb, ref[k][f]);
            describe(&D[k], &cy, ta);
            cyc[k][f] = distance(&D[k], ta, ref[k][f], ref[k][f]);
        }
        image_free(&a);
        image_free(&b);
        image_free(&cy);
        image_free(&mean);
        sg_graph *g = pipeline_load_graph(gp, NULL, -1, err, sizeof err);
        render_material *m = g ? pipeline_render_material(g, gp, 4, err, sizeof err) : NULL;
        sg_graph_free(g);
        if (!m) {
            fprintf(stderr, "%s\n", err);
            return 1;
        }
        for (int c = 0; c < CONFIGS; c++) {
            double sum[DESCS] = {0};
            secs[f][c] = 0;
            for (int s = 0; s < seeds; s++) {
                render_options o;
                render_options_default(&o);
                o.spp = configs[c].spp;
                o.max_spp = configs[c].max_spp;
                o.noise_target = configs[c].noise_target;
                o.seed = 100 + (uint64_t)s;
                image img;
                render_stats st;
                if (render_image(scene, m, &o, &img, &st, err, sizeof err)) {
                    fprintf(stderr, "%s\n", err);
                    return 1;
                }
                secs[f][c] += st.seconds / seeds;
                for (int k = 0; k < DESCS; k++) {
                    describe(&D[k], &img, ta);
                    sum[k] += distance(&D[k], ta, ref[k][f], ref[k][f]);
                }
                image_free(&img);
            }
            for (int k = 0; k < DESCS; k++)
                dist[k][f][c] = sum[k] / seeds;
        }
        render_material_free(m);
        fprintf(stderr, "frame %d done\n", f);
    }
    for (int k = 0; k < DESCS; k++) {
        printf("\n%s descriptor: distance to the converged reference (mean over %d seeds)\n\n",
               D[k].name, seeds);
        printf("| frame | reference's own noise | Cycles-252 |");
        for (int c = 0; c < CONFIGS; c++)
            printf(" %s |", configs[c].name);
        printf(" nearest other frame |\n|---|---|---|");
        for (int c = 0; c < CONFIGS; c++)
            printf("---|");
        printf("---|\n");
        int ok[CONFIGS] = {0};
        for (int f = 0; f < FRAMES; f++) {
            double nearest = INFINITY;
            for (int j = 0; j < FRAMES; j++)
                if (j != f)
                    nearest = fmin(nearest, distance(&D[k], ref[k][j], ref[k][f], ref[k][f]));
            printf("| s%d | %.2e | %.2e |", f, own[k][f], cyc[k][f]);
            for (int c = 0; c < CONFIGS; c++) {
                printf(" %.2e |", dist[k][f][c]);
                ok[c] += dist[k][f][c] <= cyc[k][f];
            }
            printf(" %.3f |\n", nearest);
        }
        printf("| at least as close as Cycles-252 | | |");
        for (int c = 0; c < CONFIGS; c++)
            printf(" %d of %d |", ok[c], FRAMES);
        printf(" |\n");
    }
    printf("\nRender seconds per frame (wall, 2 threads)\n\n| frame |");
    for (int c = 0; c < CONFIGS; c++)
        printf(" %s |", configs[c].name);
    printf("\n|---|");
    for (int c = 0; c < CONFIGS; c++)
        printf("---|");
    printf("\n");
    for (int f = 0; f < FRAMES; f++) {
        printf("| s%d |", f);
        for (int c = 0; c < CONFIGS; c++)
            printf(" %.2f |", secs[f][c]);
        printf("\n");
    }
    return 0;
}
