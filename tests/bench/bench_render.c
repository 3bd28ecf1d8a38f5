/*
 * Renderer benchmark (run by hand; results go to BENCHMARKS.md):
 *   1. every reference case under tests/reference/render with a Cycles reference: time per
 *      frame in fast mode (256x256, default options: adaptive sampling) and RMSE against
 *      the reference (mean of the two halves) with the reference's own noise taken out
 *      (sqrt(RMSE^2 - noise^2)), next to that noise's RMSE ((a - b) / 2);
 *   2. the super-shader (assets/supershader.json) over N random parametrizations
 *      (sg_params_sample frames 0..N-1): frames per second, counting binding the
 *      parameters and compiling the material as well as rendering;
 *   3. scaling of one frame of the super-shader with resolution (default options) and
 *      with samples per pixel (fixed, adaptive sampling off; and the default).
 *
 * usage: bench_render [--frames N] [--threads N] [--blender 3|4]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <time.h>
#include <unistd.h>

#include "render/render.h"

#define CASES IMSYNTH_SOURCE_DIR "/tests/reference/render"

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static double wall_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* What one render cost: wall seconds, CPU seconds of the whole process (all threads: on
 * a shared, loaded machine steadier than wall time) and shading points. */
typedef struct cost {
    double wall, cpu;
    uint64_t points;
} cost;

static cost render_once(const render_scene *s, const render_material *m,
                        const render_options *o, image *out)
{
    char err[1024];
    render_stats st;
    double c0 = cpu_seconds();
    if (render_image(s, m, o, out, &st, err, sizeof err) < 0) {
        fprintf(stderr, "bench_render: %s\n", err);
        exit(1);
    }
    cost c = {st.seconds, cpu_seconds() - c0, st.shading_points};
    return c;
}

int main(int argc, char **argv)
{
    int frames = 100, threads = 0, blender = 4;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (!strcmp(argv[i], "--frames"))
            frames = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--threads"))
            threads = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--blender"))
            blender = atoi(argv[i + 1]);
    }
    const char *tag = blender == 3 ? "3.4" : "4.3";
    char err[1024];
    render_scene *s = render_scene_load(IMSYNTH_SOURCE_DIR "/assets/scene.json", err, sizeof err);
    if (!s) {
        fprintf(stderr, "bench_render: %s\n", err);
        return 1;
    }
    render_options o;
    render_options_default(&o);
    o.threads = threads;
    o.blender = blender;
    printf("# bench_render: Blender %s semantics, fast mode spp %d (adaptive up to %d, noise "
           "target %.3f) x %d light samples, threads %d (0 = all)\n",
           tag, o.spp, o.max_spp, (double)o.noise_target, o.light_samples, threads);

    /* 1. reference cases */
    DIR *dir = opendir(CASES);
    char *names[256];
    int n_names = 0;
    struct dirent *de;
    while (dir && (de = readdir(dir)) && n_names < 256)
        if (de->d_name[0] != '.')
            names[n_names++] = strdup(de->d_name);
    if (dir)
        closedir(dir);
    qsort(names, (size_t)n_names, sizeof *names, cmp_str);
    printf("\n| case | wall s/frame | CPU s/frame | shading points/pixel | RMSE vs Cycles %s "
           "(4096 spp, its noise out) | reference's own noise RMSE |\n|---|---|---|---|---|---|\n",
           tag);
    for (int i = 0; i < n_names; i++) {
        char pa[1024], pb[1024], gp[1024];
        snprintf(gp, sizeof gp, "%s/%s/graph.json", CASES, names[i]);
        snprintf(pa, sizeof pa, "%s/%s/blender-%s-a.exr", CASES, names[i], tag);
        snprintf(pb, sizeof pb, "%s/%s/blender-%s-b.exr", CASES, names[i], tag);
        if (access(gp, R_OK) != 0)
            continue;
        char e[SG_ERROR_MAX] = "";
        sg_graph *g = sg_graph_load_file(gp, e, sizeof e);
        render_material *m = g ? render_material_new(g, blender, err, sizeof err) : NULL;
        sg_graph_free(g);
        if (!m)
            continue;
        image img;
        cost run = render_once(s, m, &o, &img);
        image a, b;
        if (access(pa, R_OK) == 0 && access(pb, R_OK) == 0 &&
            image_read(pa, &a, err, sizeof err) == 0 && image_read(pb, &b, err, sizeof err) == 0) {
            double se = 0, sn = 0;
            int n = a.width * a.height;
            for (int p = 0; p < n; p++)
                for (int c = 0; c < 3; c++) {
                    double ra = a.pixels[p * a.channels + c], rb = b.pixels[p * b.channels + c];
                    double d = img.pixels[3 * p + c] - 0.5 * (ra + rb);
                    se += d * d;
                    sn += 0.25 * (ra - rb) * (ra - rb);
                }
            double mse = se / (3.0 * n), noise = sn / (3.0 * n);
            printf("| %s | %.3f | %.3f | %.1f | %.5f | %.5f |\n", names[i], run.wall, run.cpu,
                   (double)run.points / n, sqrt(mse > noise ? mse - noise : 0.0), sqrt(noise));
            image_free(&a);
            image_free(&b);
        } else {
            printf("| %s | %.3f | %.3f | %.1f | (no reference) | |\n", names[i], run.wall, run.cpu,
                   (double)run.points / (img.width * img.height));
        }
        image_free(&img);
        render_material_free(m);
    }
    for (int i = 0; i < n_names; i++)
        free(names[i]);

    /* 2. super-shader frames */
    char e[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(IMSYNTH_SOURCE_DIR "/assets/supershader.json", e, sizeof e);
    sg_params p;
    if (!g || sg_params_from_graph(g, &p, e, sizeof e) < 0) {
        fprintf(stderr, "bench_render: %s\n", e);
        return 1;
    }
    double total = 0, worst = 0, total_cpu = 0, total_all = 0, points = 0;
    for (int f = 0; f < frames; f++) {
        double t0 = wall_seconds();
        sg_params_sample(&p, (unsigned long long)f);
        if (sg_graph_bind_params(g, &p, e, sizeof e) < 0) {
            fprintf(stderr, "bench_render: %s\n", e);
            return 1;
        }
        render_material *m = render_material_new(g, blender, err, sizeof err);
        if (!m) {
            fprintf(stderr, "bench_render: %s\n", err);
            return 1;
        }
        image img;
        cost run = render_once(s, m, &o, &img);
        total_all += wall_seconds() - t0;
        points += (double)run.points / (img.width * img.height);
        total += run.wall;
        total_cpu += run.cpu;
        worst = run.wall > worst ? run.wall : worst;
        image_free(&img);
        render_material_free(m);
    }
    printf("\nsuper-shader, %d random parametrizations (frames 0..%d): render %.3f s/frame mean "
           "(%.3f CPU s), %.3f s worst, %.1f shading points/pixel mean; with binding and "
           "compiling %.3f s/frame, %.2f frames/s\n",
           frames, frames - 1, total / frames, total_cpu / frames, worst, points / frames,
           total_all / frames, frames / total_all);

    /* 3. scaling, frame 0 of the super-shader */
    sg_params_sample(&p, 0);
    sg_graph_bind_params(g, &p, e, sizeof e);
    render_material *m = render_material_new(g, blender, err, sizeof err);
    if (!m) {
        fprintf(stderr, "bench_render: %s\n", err);
        return 1;
    }
    printf("\n| resolution | spp | wall s/frame | CPU s/frame |\n|---|---|---|---|\n");
    int res[] = {64, 128, 256, 512};
    for (int r = 0; r < 4; r++) {
        render_options q = o;
        q.width = q.height = res[r];
        image img;
        cost run = render_once(s, m, &q, &img);
        printf("| %d | %d | %.3f | %.3f |\n", res[r], q.spp, run.wall, run.cpu);
        image_free(&img);
    }
    int spps[] = {1, 4, 16, 64};
    for (int k = 0; k < 4; k++) {
        render_options q = o;
        q.spp = spps[k];
        q.max_spp = 0;
        image img;
        cost run = render_once(s, m, &q, &img);
        printf("| 256 | %d | %.3f | %.3f |\n", q.spp, run.wall, run.cpu);
        image_free(&img);
    }
    render_material_free(m);
    sg_params_free(&p);
    sg_graph_free(g);
    render_scene_free(s);
    return 0;
}
