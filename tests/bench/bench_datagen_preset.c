/*
 * Which render preset does datagen need? The criterion (issue 11): the descriptor of a
 * preset's render must be at least as close to the descriptor of the converged Cycles
 * reference (4096 samples: the mean of blender-4.3-a/b.exr) as the descriptor of Cycles'
 * own 252-sample render (blender-4.3-252.exr, tests/bench/cycles_252_references.py) is,
 * on the six super-shader frames of tests/reference/render/supershader_s0..s5.
 *
 *   build/tests/bench/bench_datagen_preset [--seeds K]
 *
 * Descriptor: datagen's (VGG19, random weights seed 1, avg3 pooling, fp32). Distance
 * between descriptors x and y measured against reference r: the mean over the 5 Gram
 * layers of ||G_l(x) - G_l(y)|| / ||G_l(r)|| (Frobenius over the stored upper triangle),
 * so each layer counts the same whatever its scale. Printed per frame: the reference's own
 * noise (half a against half b), Cycles-252, each preset (mean over K seeds, and its
 * render time), and the distance to the nearest other frame's reference (how far apart two
 * different materials are).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nn/nn.h"
#include "pipeline/pipeline.h"

#include <cblas.h> /* after shadergraph.h: OpenBLAS defines a macro I */

enum { FRAMES = 6, MAX_SEEDS = 8 };

typedef struct ctx {
    vgg19 net;
    vgg_workspace *ws;
    size_t size, off[VGG_GRAM_LAYERS + 1];
    float *in;
} ctx;

static void describe(ctx *c, const image *img, float *out)
{
    if (vgg_preprocess(c->in, img->pixels, img->width, img->height, img->channels)) {
        fprintf(stderr, "image too small\n");
        exit(1);
    }
    vgg_describe(c->ws, c->in, 1, out);
}

static double layer_norm(const ctx *c, const float *r, int l)
{
    double s = 0;
    for (size_t i = c->off[l]; i < c->off[l + 1]; i++)
        s += (double)r[i] * r[i];
    return sqrt(s);
}

static double distance(const ctx *c, const float *x, const float *y, const float *r)
{
    double total = 0;
    for (int l = 0; l < VGG_GRAM_LAYERS; l++) {
        double s = 0;
        for (size_t i = c->off[l]; i < c->off[l + 1]; i++) {
            double d = (double)x[i] - y[i];
            s += d * d;
        }
        total += sqrt(s) / layer_norm(c, r, l);
    }
    return total / VGG_GRAM_LAYERS;
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
    ctx c;
    vgg19_init_random(&c.net, vgg19_standard_width, 1);
    vgg_options vo = {.pool = VGG_POOL_AVG3, .precision = VGG_PRECISION_FP32, .threads = 2};
    c.ws = vgg_workspace_create(&c.net, &vo, 1);
    c.size = vgg19_descriptor_size(&c.net);
    vgg19_descriptor_offsets(&c.net, c.off);
    c.in = malloc(3 * VGG_INPUT_SIZE * VGG_INPUT_SIZE * sizeof(float));
    char err[1024];
    render_scene *scene = render_scene_load(IMSYNTH_SOURCE_DIR "/assets/scene.json", err, sizeof err);
    if (!scene) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    static const char *const names[3] = {"draft", "datagen", "converged"};
    float *ref[FRAMES];
    float *tmp_a = malloc(c.size * sizeof(float)), *tmp_b = malloc(c.size * sizeof(float));
    double own[FRAMES], cyc[FRAMES], pre[FRAMES][3], pre_sd[FRAMES][3], secs[FRAMES][3];
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
        ref[f] = malloc(c.size * sizeof(float));
        describe(&c, &mean, ref[f]);
        describe(&c, &a, tmp_a);
        describe(&c, &b, tmp_b);
        own[f] = distance(&c, tmp_a, tmp_b, ref[f]);
        describe(&c, &cy, tmp_a);
        cyc[f] = distance(&c, tmp_a, ref[f], ref[f]);
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
        for (int p = 0; p < 3; p++) {
            const datagen_preset *ps = datagen_preset_find(names[p]);
            double sum = 0, sum2 = 0;
            secs[f][p] = 0;
            for (int k = 0; k < seeds; k++) {
                render_options o;
                render_options_default(&o);
                o.spp = ps->spp;
                o.max_spp = ps->max_spp;
                o.light_samples = ps->light_samples;
                o.noise_target = ps->noise_target;
                o.seed = 100 + (uint64_t)k;
                image img;
                render_stats st;
                if (render_image(scene, m, &o, &img, &st, err, sizeof err)) {
                    fprintf(stderr, "%s\n", err);
                    return 1;
                }
                secs[f][p] += st.seconds / seeds;
                describe(&c, &img, tmp_a);
                double d = distance(&c, tmp_a, ref[f], ref[f]);
                sum += d;
                sum2 += d * d;
                image_free(&img);
            }
            pre[f][p] = sum / seeds;
            pre_sd[f][p] = seeds > 1 ? sqrt(fmax(sum2 / seeds - pre[f][p] * pre[f][p], 0)) : 0;
        }
        render_material_free(m);
        fprintf(stderr, "frame %d done\n", f);
    }
    printf("| frame | reference's own noise (a vs b) | Cycles-252 | draft (1 spp) | datagen (4 spp) "
           "| converged (adaptive) | nearest other frame | draft s | datagen s | converged s |\n"
           "|---|---|---|---|---|---|---|---|---|---|\n");
    int draft_ok = 0, datagen_ok = 0;
    for (int f = 0; f < FRAMES; f++) {
        double nearest = INFINITY;
        for (int j = 0; j < FRAMES; j++)
            if (j != f)
                nearest = fmin(nearest, distance(&c, ref[j], ref[f], ref[f]));
        draft_ok += pre[f][0] <= cyc[f];
        datagen_ok += pre[f][1] <= cyc[f];
        printf("| s%d | %.5f | %.5f | %.5f (sd %.5f) | %.5f (sd %.5f) | %.5f (sd %.5f) | %.3f | %.3f "
               "| %.3f | %.3f |\n",
               f, own[f], cyc[f], pre[f][0], pre_sd[f][0], pre[f][1], pre_sd[f][1], pre[f][2],
               pre_sd[f][2], nearest, secs[f][0], secs[f][1], secs[f][2]);
    }
    printf("\nat least as close as Cycles-252: draft on %d of %d frames, datagen on %d of %d "
           "(%d seeds each)\n",
           draft_ok, FRAMES, datagen_ok, FRAMES, seeds);
    return 0;
}
