/*
 * The render loop: tiles over pthreads, camera rays through Embree, the material's maps
 * evaluated in batches, shading, and the film.
 *
 * Film: Cycles importance-samples its pixel filter, so a pixel is the plain mean of its
 * samples. A sample's random numbers depend only on (seed, pixel, sample, dimension) and
 * each pixel's samples are summed in sample order by one thread, so the image is the
 * same bits whatever the thread count.
 *
 * fast mode stratifies the filter positions of a pixel's spp shading points (a Latin
 * hypercube over the filter's two dimensions), which anti-aliases textures with few
 * shading points; reference mode draws them independently.
 *
 * Adaptive sampling (fast mode, max_spp > spp). Where the material sparkles (a sharp bump
 * under a glossy highlight) a pixel's value depends on where in the 3 px filter its
 * shading points fall, and only more shading points there reduce that noise; elsewhere
 * spp is plenty. So the render has two phases: phase 1 renders spp shading points in
 * every pixel and records each pixel's sample variance; phase 2 gives a pixel k^2 more
 * shading points (a stratified set of its own) when its neighbours' variance says its
 * mean is noisier than noise_target. The decision for a pixel reads only its 8
 * neighbours' phase-1 samples, never its own: its own samples are then independent of
 * how many it gets, and the pixel stays unbiased (a pixel deciding from its own samples
 * would keep the ones that happened to miss a rare highlight). The image is the mean of
 * all the pixel's shading points.
 */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "render/render_internal.h"

/* ---- material ------------------------------------------------------------------- */

enum { IN_BASE_COLOR, IN_METALLIC, IN_ROUGHNESS, IN_IOR, IN_ALPHA, IN_NORMAL, IN_SPEC_LEVEL,
       IN_SPEC_TINT, IN_COUNT };
static const char *const input_sockets[IN_COUNT] = {
    "Base Color", "Metallic", "Roughness", "IOR", "Alpha", "Normal", "Specular IOR Level",
    "Specular Tint"};

struct render_material {
    sg_program *program;
    int blender;
};

render_material *render_material_new(const sg_graph *g, int blender, char *err, size_t errlen)
{
    sg_error e;
    const char *bsdf = sg_graph_surface_bsdf(g, &e);
    if (!bsdf) {
        snprintf(err, errlen, "%s", e.msg);
        return NULL;
    }
    sg_socket_ref refs[IN_COUNT];
    for (int i = 0; i < IN_COUNT; i++) {
        refs[i].node = bsdf;
        refs[i].socket = input_sockets[i];
    }
    sg_compile_options opt = {blender == 3 ? SG_BLENDER_3 : SG_BLENDER_4};
    sg_program *p = sg_compile(g, refs, IN_COUNT, &opt, &e);
    if (!p) {
        snprintf(err, errlen, "%s", e.msg);
        return NULL;
    }
    render_material *m = calloc(1, sizeof *m);
    if (!m) {
        sg_program_free(p);
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    m->program = p;
    m->blender = blender == 3 ? 3 : 4;
    return m;
}

void render_material_free(render_material *m)
{
    if (!m)
        return;
    sg_program_free(m->program);
    free(m);
}

void render_options_default(render_options *o)
{
    memset(o, 0, sizeof *o);
    o->mode = RENDER_FAST;
    o->spp = 4;
    o->light_samples = 4;
    o->blender = 4;
    o->threads = 0;
    o->seed = 0;
    o->max_spp = 256;
    o->noise_target = 0.05f;
}

/* ---- tiles ------------------------------------------------------------------------ */

#define TILE 16
#define BATCH 256

typedef struct render_job {
    const render_scene *scene;
    const render_material *material;
    const render_options *opt;
    ortho_camera camera;
    pixel_filter filter;
    point_light light; /* the scene's light with this render's model */
    shade_setup setup;
    int tiles_x, tiles_y;
    float *film; /* width * height * 3 */
    /* Adaptive sampling: phase 1's per-pixel sample variance and mean of the shading
     * points' channel mean, and the extra shading points phase 2 renders. */
    float *variance, *mean;
    uint32_t *extra;
    int phase; /* 1 or 2 */
    pthread_mutex_t lock;
    int next_tile;
    render_stats stats;
    int failed;
} render_job;

/* One thread's batch of shading points waiting for the evaluator. */
typedef struct batch {
    int n;
    uint32_t pixel[BATCH], sample[BATCH], first[BATCH], strata[BATCH];
    shading_geometry geo[BATCH];
    float storage[48 * BATCH]; /* planar geometry fields for sg_geometry_batch */
    float out_color[3 * BATCH], out_metallic[BATCH], out_roughness[BATCH], out_ior[BATCH],
        out_alpha[BATCH], out_normal[3 * BATCH], out_spec[BATCH], out_tint[3 * BATCH];
} batch;

typedef struct worker {
    render_job *job;
    sg_evaluator *eval;
    batch *b;
    shade_counters counters;
    uint64_t camera_rays, shading_points;
} worker;

/* Lay out the batch's geometry as the evaluator's planar arrays. */
static void batch_geometry(batch *b, sg_geometry_batch *gb)
{
    int n = b->n;
    float *f = b->storage;
    enum { P, DPX, DPY, N, NG, I, GEN, DGX, DGY, UV, DUX, DUY, OBJ, DOX, DOY, ON, FIELDS };
    float *field[FIELDS];
    for (int k = 0; k < FIELDS; k++)
        field[k] = f + (size_t)k * 3 * (size_t)n;
    for (int i = 0; i < n; i++) {
        const shading_geometry *g = &b->geo[i];
        const float *src[FIELDS] = {g->P, g->dPdx, g->dPdy, g->N, g->Ng, g->I, g->generated,
                                    g->dgenerated_dx, g->dgenerated_dy, g->uv, g->duv_dx,
                                    g->duv_dy, g->P, g->dPdx, g->dPdy, g->N};
        for (int k = 0; k < FIELDS; k++)
            for (int c = 0; c < 3; c++)
                field[k][c * n + i] = src[k][c];
    }
    gb->n = n;
    gb->P = field[P], gb->dPdx = field[DPX], gb->dPdy = field[DPY];
    gb->N = field[N], gb->Ng = field[NG], gb->I = field[I];
    gb->generated = field[GEN], gb->dgenerated_dx = field[DGX], gb->dgenerated_dy = field[DGY];
    gb->uv = field[UV], gb->duv_dx = field[DUX], gb->duv_dy = field[DUY];
    gb->object = field[OBJ], gb->dobject_dx = field[DOX], gb->dobject_dy = field[DOY];
    gb->object_normal = field[ON];
}

/* Evaluate the batch's maps, shade every point and add it to the tile's film. Points
 * arrive in (pixel, sample) order, so each pixel's sum has a fixed order. */
static void batch_flush(worker *w, float *tile_film, float *tile_sq, int x0, int y0, int tw)
{
    batch *b = w->b;
    if (b->n == 0)
        return;
    render_job *job = w->job;
    sg_geometry_batch gb;
    batch_geometry(b, &gb);
    float *outs[IN_COUNT] = {b->out_color, b->out_metallic, b->out_roughness, b->out_ior,
                             b->out_alpha, b->out_normal, b->out_spec, b->out_tint};
    sg_evaluate(w->eval, &gb, outs);
    int n = b->n;
    int width = job->camera.width;
    for (int i = 0; i < n; i++) {
        principled_inputs in;
        principled_inputs_default(&in);
        for (int c = 0; c < 3; c++) {
            in.base_color[c] = b->out_color[c * n + i];
            in.specular_tint[c] = b->out_tint[c * n + i];
            in.N[c] = b->out_normal[c * n + i];
        }
        in.metallic = b->out_metallic[i];
        in.roughness = b->out_roughness[i];
        in.ior = b->out_ior[i];
        in.alpha = b->out_alpha[i];
        in.specular_ior_level = b->out_spec[i];
        /* Cycles normalises the Normal input of a closure (safe_normalize). */
        if (v3_normalize(in.N) == 0.0f)
            memcpy(in.N, b->geo[i].N, sizeof in.N);
        float L[3];
        shade_point(&job->setup, &b->geo[i], &in, b->pixel[i], b->sample[i], b->first[i],
                    b->strata[i], L, &w->counters);
        /* Alpha: Cycles mixes in a transparent BSDF; the camera ray continues through
         * the surface. Behind the surface there is only the world in this scene (an
         * occluded continuation is counted as an indirect hit). */
        float alpha = fminf(fmaxf(in.alpha, 0.0f), 1.0f);
        if (alpha < 1.0f) {
            const shading_geometry *g = &b->geo[i];
            float D[3] = {-g->I[0], -g->I[1], -g->I[2]};
            if (render_occluded(job->scene, g->P, g->Ng, D, INFINITY))
                w->counters.indirect_hits++;
            for (int c = 0; c < 3; c++)
                L[c] = alpha * L[c] + (1.0f - alpha) * job->scene->world[c];
        }
        int px = (int)(b->pixel[i] % (uint32_t)width) - x0;
        int py = (int)(b->pixel[i] / (uint32_t)width) - y0;
        float *dst = &tile_film[3 * (py * tw + px)];
        for (int c = 0; c < 3; c++)
            dst[c] += L[c];
        float v = (L[0] + L[1] + L[2]) * (1.0f / 3.0f);
        tile_sq[py * tw + px] += v * v;
    }
    w->shading_points += (uint64_t)n;
    b->n = 0;
}

/* Filter offset (in pixels, from the pixel centre) of shading point s of the set
 * first .. first + count - 1. fast mode stratifies the set, a jittered grid when count is
 * a square, else a Latin hypercube, and pairs its points antithetically: point k of the
 * second half is point count - 1 - k reflected through the pixel centre (u -> 1 - u in
 * each filter dimension, which the symmetric filter maps to -offset). Each point is still
 * uniform in filter space, so the estimate stays unbiased, and a pair's mean is exact for
 * anything linear across the filter: the light's fall-off across a 3 px footprint was most
 * of a smooth material's noise. On a square grid the reflected point lies in the
 * reflected cell, so the grid's stratification is kept. */
static void filter_offset(const render_job *job, uint32_t pixel, int s, int first, int count,
                          float *dx, float *dy)
{
    const render_options *o = job->opt;
    int k = s - first;
    int mirrored = o->mode == RENDER_FAST && k > count - 1 - k;
    if (mirrored)
        k = count - 1 - k;
    uint32_t sample = (uint32_t)(first + k);
    float fu = render_random(o->seed, pixel, sample, DIM_FILTER_X);
    float fv = render_random(o->seed, pixel, sample, DIM_FILTER_Y);
    if (o->mode == RENDER_FAST) {
        int m = (int)(sqrt((double)count) + 0.5);
        if (m * m == count) {
            fu = fminf(((float)(k % m) + fu) / (float)m, 0x1.fffffep-1f);
            fv = fminf(((float)(k / m) + fv) / (float)m, 0x1.fffffep-1f);
        } else {
            uint64_t key = o->seed * 0x9e3779b97f4a7c15ull + pixel + (uint64_t)first * 0x2545f491ull;
            uint32_t sy = render_permute((uint32_t)k, (uint32_t)count, key);
            fu = fminf(((float)k + fu) / (float)count, 0x1.fffffep-1f);
            fv = fminf(((float)sy + fv) / (float)count, 0x1.fffffep-1f);
        }
    }
    *dx = pixel_filter_sample(&job->filter, fu);
    *dy = pixel_filter_sample(&job->filter, fv);
    if (mirrored) {
        *dx = -*dx;
        *dy = -*dy;
    }
}

static void render_tile(worker *w, int tile)
{
    render_job *job = w->job;
    const render_options *o = job->opt;
    const ortho_camera *cam = &job->camera;
    int x0 = (tile % job->tiles_x) * TILE, y0 = (tile / job->tiles_x) * TILE;
    int tw = cam->width - x0 < TILE ? cam->width - x0 : TILE;
    int th = cam->height - y0 < TILE ? cam->height - y0 : TILE;
    float tile_film[3 * TILE * TILE], tile_sq[TILE * TILE];
    memset(tile_film, 0, sizeof tile_film);
    memset(tile_sq, 0, sizeof tile_sq);
    const int spp = o->spp;
    for (int py = y0; py < y0 + th; py++)
        for (int px = x0; px < x0 + tw; px++) {
            uint32_t pixel = (uint32_t)(py * cam->width + px);
            int first = 0, count = spp;
            if (job->phase == 2) {
                first = spp;
                count = (int)job->extra[pixel];
            }
            for (int s = first; s < first + count; s++) {
                float dx, dy;
                filter_offset(job, pixel, s, first, count, &dx, &dy);
                float rx = (float)px + 0.5f + dx;
                float ry = (float)py + 0.5f + dy;
                float P[3], D[3], dP;
                ortho_camera_ray(cam, rx, ry, P, D, &dP);
                w->camera_rays++;
                struct RTCIntersectContext ctx;
                rtcInitIntersectContext(&ctx);
                struct RTCRayHit rh;
                memset(&rh, 0, sizeof rh);
                rh.ray.org_x = P[0], rh.ray.org_y = P[1], rh.ray.org_z = P[2];
                rh.ray.dir_x = D[0], rh.ray.dir_y = D[1], rh.ray.dir_z = D[2];
                rh.ray.tnear = 0.0f;
                rh.ray.tfar = INFINITY;
                rh.ray.mask = 0xffffffffu;
                rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(job->scene->rtc, &ctx, &rh);
                if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
                    int t = (py - y0) * tw + (px - x0);
                    const float *world = job->scene->world;
                    for (int c = 0; c < 3; c++)
                        tile_film[3 * t + c] += world[c];
                    float v = (world[0] + world[1] + world[2]) * (1.0f / 3.0f);
                    tile_sq[t] += v * v;
                    continue;
                }
                batch *b = w->b;
                render_shading_geometry(job->scene, (int)rh.hit.geomID, rh.hit.primID, rh.hit.u,
                                        rh.hit.v, D, dP, &b->geo[b->n]);
                b->pixel[b->n] = pixel;
                b->sample[b->n] = (uint32_t)s;
                b->first[b->n] = (uint32_t)first;
                b->strata[b->n] = (uint32_t)count;
                if (++b->n == BATCH)
                    batch_flush(w, tile_film, tile_sq, x0, y0, tw);
            }
        }
    batch_flush(w, tile_film, tile_sq, x0, y0, tw);
    /* Tiles do not overlap: no lock needed to write the film. */
    for (int y = 0; y < th; y++)
        for (int x = 0; x < tw; x++) {
            size_t pixel = (size_t)(y0 + y) * (size_t)cam->width + (size_t)(x0 + x);
            const float *sum = &tile_film[3 * (y * tw + x)];
            float *dst = &job->film[3 * pixel];
            if (job->phase == 1) {
                for (int c = 0; c < 3; c++)
                    dst[c] = sum[c] / (float)spp;
                if (job->variance) {
                    double sv = ((double)sum[0] + sum[1] + sum[2]) / 3.0;
                    double mean = sv / spp;
                    double var = spp > 1 ? (tile_sq[y * tw + x] - sv * mean) / (spp - 1) : 0.0;
                    job->variance[pixel] = (float)(var > 0.0 ? var : 0.0);
                    job->mean[pixel] = (float)mean;
                }
            } else {
                uint32_t extra = job->extra[pixel];
                if (extra == 0)
                    continue;
                for (int c = 0; c < 3; c++)
                    dst[c] = (dst[c] * (float)spp + sum[c]) / (float)(spp + (int)extra);
            }
        }
}

/* Phase 2's plan: for each pixel, from its 8 neighbours' phase-1 statistics (never its
 * own: see the top of the file), the number of extra shading points that brings the
 * standard error of its mean to noise_target x the neighbours' mean (at least 0.01: dark
 * pixels need no relative precision), as a square k^2 (a stratified set), with
 * spp + k^2 <= max_spp. Returns the total number of extra shading points. */
static uint64_t plan_extra_samples(render_job *job)
{
    const render_options *o = job->opt;
    int w = job->camera.width, h = job->camera.height;
    int kmax = (int)sqrt((double)(o->max_spp - o->spp));
    uint64_t total = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double var = 0.0, mean = 0.0;
            int n = 0;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    int nx = x + dx, ny = y + dy;
                    if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= w || ny >= h)
                        continue;
                    size_t q = (size_t)ny * (size_t)w + (size_t)nx;
                    if (job->variance[q] > var)
                        var = job->variance[q];
                    mean += job->mean[q];
                    n++;
                }
            mean = n > 0 ? mean / n : 0.0;
            double eps = o->noise_target * (mean > 0.01 ? mean : 0.01);
            double need = var / (eps * eps) - o->spp; /* shading points beyond phase 1 */
            int k = 0;
            if (need > 0.0) {
                k = (int)ceil(sqrt(need));
                if (k > kmax)
                    k = kmax;
            }
            job->extra[(size_t)y * (size_t)w + (size_t)x] = (uint32_t)(k * k);
            total += (uint64_t)(k * k);
        }
    return total;
}

static void *worker_main(void *arg)
{
    worker *w = arg;
    render_job *job = w->job;
    for (;;) {
        pthread_mutex_lock(&job->lock);
        int tile = job->next_tile++;
        pthread_mutex_unlock(&job->lock);
        if (tile >= job->tiles_x * job->tiles_y)
            break;
        render_tile(w, tile);
    }
    return NULL;
}

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int render_image(const render_scene *s, const render_material *m, const render_options *o,
                 image *out, render_stats *stats, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (o->spp < 1 || o->spp > (1 << 20)) {
        snprintf(err, errlen, "samples per pixel must be in [1, 2^20] (got %d)", o->spp);
        return -1;
    }
    if (o->max_spp > (1 << 20)) {
        snprintf(err, errlen, "maximum samples per pixel must be at most 2^20 (got %d)",
                 o->max_spp);
        return -1;
    }
    if (!(o->noise_target > 0.0f) || !isfinite(o->noise_target)) {
        snprintf(err, errlen, "noise target must be a positive number (got %g)",
                 (double)o->noise_target);
        return -1;
    }
    if (o->mode == RENDER_FAST && (o->light_samples < 1 || o->light_samples > 64)) {
        snprintf(err, errlen, "light samples must be in [1, 64] (got %d)", o->light_samples);
        return -1;
    }
    if (o->blender != 3 && o->blender != 4) {
        snprintf(err, errlen, "Blender version must be 3 or 4 (got %d)", o->blender);
        return -1;
    }
    if (o->blender != m->blender) {
        snprintf(err, errlen, "material compiled for Blender %d, render asks for %d", m->blender,
                 o->blender);
        return -1;
    }
    double t0 = now_seconds();
    render_job *job = calloc(1, sizeof *job);
    if (!job) {
        snprintf(err, errlen, "out of memory");
        return -1;
    }
    job->scene = s;
    job->material = m;
    job->opt = o;
    job->camera = s->camera;
    if (o->width > 0 && o->height > 0) {
        job->camera.width = o->width;
        job->camera.height = o->height;
    }
    pixel_filter_init(&job->filter, s->filter_width);
    job->setup.scene = s;
    job->setup.blender = o->blender;
    job->setup.mode = o->mode;
    job->setup.light_samples = o->light_samples;
    job->setup.seed = o->seed;
    if (s->n_lights > 0) {
        job->light = s->lights[0];
        /* 3.4 has only the facing disk; 4.x uses it with Soft Falloff. */
        job->light.sphere = o->blender == 4 && !job->light.soft_falloff;
        job->setup.light = &job->light;
    }
    int width = job->camera.width, height = job->camera.height;
    job->tiles_x = (width + TILE - 1) / TILE;
    job->tiles_y = (height + TILE - 1) / TILE;
    if (image_alloc(out, width, height, 3) < 0) {
        free(job);
        snprintf(err, errlen, "out of memory for a %dx%d image", width, height);
        return -1;
    }
    job->film = out->pixels;
    /* Adaptive sampling needs room for at least one extra 1x1 set. */
    int adaptive = o->mode == RENDER_FAST && o->max_spp > o->spp;
    size_t npix = (size_t)width * (size_t)height;
    if (adaptive) {
        job->variance = malloc(npix * sizeof *job->variance);
        job->mean = malloc(npix * sizeof *job->mean);
        job->extra = malloc(npix * sizeof *job->extra);
        if (!job->variance || !job->mean || !job->extra) {
            free(job->variance);
            free(job->mean);
            free(job->extra);
            free(job);
            image_free(out);
            snprintf(err, errlen, "out of memory for a %dx%d image", width, height);
            return -1;
        }
    }
    pthread_mutex_init(&job->lock, NULL);

    int nthreads = o->threads;
    if (nthreads <= 0) {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        nthreads = n > 0 ? (int)n : 1;
    }
    if (nthreads > 256)
        nthreads = 256;
    worker *workers = calloc((size_t)nthreads, sizeof *workers);
    pthread_t *tids = calloc((size_t)nthreads, sizeof *tids);
    int ok = workers && tids;
    for (int i = 0; ok && i < nthreads; i++) {
        workers[i].job = job;
        workers[i].eval = sg_evaluator_new(m->program, BATCH);
        workers[i].b = malloc(sizeof(batch));
        if (!workers[i].eval || !workers[i].b)
            ok = 0;
        else
            workers[i].b->n = 0;
    }
    render_stats st = {0};
    for (int phase = 1; ok && phase <= (adaptive ? 2 : 1); phase++) {
        job->phase = phase;
        job->next_tile = 0;
        if (phase == 2)
            st.extra_shading_points = plan_extra_samples(job);
        int started;
        for (started = 1; started < nthreads; started++)
            if (pthread_create(&tids[started], NULL, worker_main, &workers[started]) != 0)
                break;
        worker_main(&workers[0]); /* the calling thread works too */
        for (int i = 1; i < started; i++)
            pthread_join(tids[i], NULL);
    }
    for (int i = 0; workers && i < nthreads; i++) {
        st.camera_rays += workers[i].camera_rays;
        st.shading_points += workers[i].shading_points;
        st.shadow_rays += workers[i].counters.shadow_rays;
        st.indirect_hits += workers[i].counters.indirect_hits;
        if (workers[i].eval)
            sg_evaluator_free(workers[i].eval);
        free(workers[i].b);
    }
    free(workers);
    free(tids);
    pthread_mutex_destroy(&job->lock);
    free(job->variance);
    free(job->mean);
    free(job->extra);
    free(job);
    st.seconds = now_seconds() - t0;
    if (stats)
        *stats = st;
    if (!ok) {
        image_free(out);
        snprintf(err, errlen, "out of memory for the render's workers");
        return -1;
    }
    return 0;
}
