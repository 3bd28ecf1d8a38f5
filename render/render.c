/*
 * The render loop: tiles over pthreads, camera rays through Embree, the material's maps
 * evaluated in batches, shading, and the film.
 *
 * Film: Cycles importance-samples its pixel filter, so a pixel is the plain mean of its
 * samples; reference mode does the same. fast mode samples cells of the image plane
 * uniformly and lets every shading point serve each pixel its filter reaches, weighted by
 * the filter (see "The film's units" below). A sample's random numbers depend only on
 * (seed, unit, sample, dimension) and each unit's sums are made in sample order by one
 * thread, so the image is the same bits whatever the thread count.
 *
 * Adaptive sampling (fast mode, max_spp > spp). Where the material sparkles (a sharp bump
 * under a glossy highlight) a pixel's value depends on where in the 3 px filter its
 * shading points fall, and only more shading points there reduce that noise; elsewhere
 * spp is plenty. So the render has two phases: phase 1 renders spp shading points in
 * every cell and records each cell's sample variance; phase 2 gives a cell k^2 more
 * shading points (a stratified set of its own) when its neighbours' variance says the
 * pixels are noisier than noise_target. The decision for a cell reads only its
 * neighbours' phase-1 samples (5 x 5 cells), never its own: its own samples are then independent of
 * how many it gets, and its mean is not biased by the choice (a cell deciding from its own
 * samples would keep the ones that happened to miss a rare highlight). A cell's mean is
 * then over all its shading points.
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
    sg_blender_mode blender;
};

render_material *render_material_new(const sg_graph *g, sg_blender_mode blender, char *err, size_t errlen)
{
    char e[SG_ERROR_MAX] = "";
    const char *bsdf = sg_graph_surface_bsdf(g, e, sizeof e);
    if (!bsdf) {
        snprintf(err, errlen, "%s", e);
        return NULL;
    }
    sg_socket_ref refs[IN_COUNT];
    for (int i = 0; i < IN_COUNT; i++) {
        refs[i].node = bsdf;
        refs[i].socket = input_sockets[i];
    }
    sg_compile_options opt = {blender == SG_BLENDER_3 ? SG_BLENDER_3 : SG_BLENDER_4};
    sg_program *p = sg_compile(g, refs, IN_COUNT, &opt, e, sizeof e);
    if (!p) {
        snprintf(err, errlen, "%s", e);
        return NULL;
    }
    render_material *m = calloc(1, sizeof *m);
    if (!m) {
        sg_program_free(p);
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    m->program = p;
    m->blender = blender == SG_BLENDER_3 ? SG_BLENDER_3 : SG_BLENDER_4;
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
    o->blender = SG_BLENDER_4;
    o->threads = 0;
    o->seed = 0;
    o->max_spp = 256;
    o->noise_target = 0.03f;
}

/* ---- tiles ------------------------------------------------------------------------ */

#define TILE 16
#define BATCH 256
#define MAX_SPLAT_RADIUS 3 /* cells: pixel filters up to 3.5 px in fast mode */

/* The film's units. Reference mode: a unit is a pixel; its samples land where the
 * filter's density puts them and each counts 1 in that pixel (Cycles' film).
 *
 * Fast mode: a unit is a cell (the square of a pixel) of the image plane extended by
 * `radius` cells on every side, as far as the filter reaches. Its samples are stratified
 * uniformly over the cell, and each one serves every pixel within the filter's reach, the
 * (2 radius + 1)^2 "taps" around the cell, not just one: a pixel's value is
 *     sum over cells c of  I_c x (sum_j W(x_j) L_j / sum_j W(x_j))
 * where I_c is the exact integral of the filter's density over cell c (closed form), and
 * the ratio is the density-weighted mean of the radiance of c's samples. So a pixel
 * combines the ~9 cells' samples around it (a shading point does the work of ~3), the
 * weights sum to exactly 1 whatever the samples (a plain splat of W / n has ~13% weight
 * noise with 4 samples per cell), and a silhouette on a cell boundary - the plane's edge
 * is the image's - costs no noise, as each cell's integrand is smooth. It converges to the
 * filtered image as the samples per cell grow (the ratio's bias falls as 1/n).
 *
 * A unit keeps, per tap, the weighted sums of R, G, B and the sum of weights; then the
 * plain sums of R, G, B (for a tap whose weights are all 0) and of the samples' channel
 * means and their squares (adaptive sampling). */
typedef struct render_job {
    const render_scene *scene;
    const render_material *material;
    const render_options *opt;
    ortho_camera camera;
    pixel_filter filter;
    point_light light; /* the scene's light with this render's model */
    shade_setup setup;
    int radius;           /* 0 (reference) or the filter's reach in cells (fast) */
    int units_w, units_h; /* unit (ux, uy) is cell (ux - radius, uy - radius) */
    int taps;             /* (2 radius + 1)^2 */
    /* The pixels resolved (the window, or the image) and the units they read: units
     * px0 .. px0 + pw - 1 + 2 radius (and the same in y), which the tiles cover. */
    int px0, py0, pw, ph;
    int tiles_x, tiles_y; /* tiles of TILE x TILE units, from unit (px0, py0) */
    float *sums;          /* units x UNIT_SUMS(taps): see film_add */
    /* Fast mode: cell_weight[d + radius] = the 1D density's integral over the cell d
     * cells from the pixel's; cell_w2 = the sum over taps of the squared 2D weights. */
    double cell_weight[2 * MAX_SPLAT_RADIUS + 1];
    float cell_w2;
    /* Adaptive sampling: phase 1's per-unit sample variance and mean of the shading
     * points' channel mean, and the extra shading points phase 2 renders. */
    float *variance, *mean;
    uint32_t *extra;
    int phase; /* 1 or 2 */
    pthread_mutex_t lock;
    int next_tile;
} render_job;

/* One thread's batch of shading points waiting for the evaluator. */
typedef struct batch {
    int n;
    uint32_t unit[BATCH], sample[BATCH], first[BATCH], strata[BATCH];
    float rx[BATCH], ry[BATCH]; /* raster position */
    shading_geometry geo[BATCH];
    float storage[48 * BATCH]; /* planar geometry fields for sg_geometry_batch */
    float out_color[3 * BATCH], out_metallic[BATCH], out_roughness[BATCH], out_ior[BATCH],
        out_alpha[BATCH], out_normal[3 * BATCH], out_spec[BATCH], out_tint[3 * BATCH];
} batch;

/* Floats per unit: taps x (R, G, B, weight), then R, G, B; a tile's accumulators add the
 * sum and the sum of squares of the samples' channel means. */
#define UNIT_SUMS(taps) (4 * (taps) + 3)
#define TILE_SUMS(taps) (UNIT_SUMS(taps) + 2)

typedef struct tile_film {
    int ux0, uy0, tw;
    float *acc; /* tw x th x TILE_SUMS */
} tile_film;

typedef struct worker {
    render_job *job;
    sg_evaluator *eval;
    batch *b;
    float *tile_acc; /* TILE x TILE x TILE_SUMS(taps) */
    shade_counters counters;
    uint64_t camera_rays, shading_points;
    double material_seconds; /* inside sg_evaluate */
} worker;

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

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
        const float3 src[FIELDS] = {g->P, g->dPdx, g->dPdy, g->N, g->Ng, g->I, g->generated,
                                    g->dgenerated_dx, g->dgenerated_dy, g->uv, g->duv_dx,
                                    g->duv_dy, g->object, g->dobject_dx, g->dobject_dy,
                                    g->object_normal};
        for (int k = 0; k < FIELDS; k++) {
            field[k][i] = src[k].x;
            field[k][n + i] = src[k].y;
            field[k][2 * n + i] = src[k].z;
        }
    }
    gb->n = n;
    gb->P = field[P], gb->dPdx = field[DPX], gb->dPdy = field[DPY];
    gb->N = field[N], gb->Ng = field[NG], gb->I = field[I];
    gb->generated = field[GEN], gb->dgenerated_dx = field[DGX], gb->dgenerated_dy = field[DGY];
    gb->uv = field[UV], gb->duv_dx = field[DUX], gb->duv_dy = field[DUY];
    gb->object = field[OBJ], gb->dobject_dx = field[DOX], gb->dobject_dy = field[DOY];
    gb->object_normal = field[ON];
}

/* Adds a sample of radiance L at raster (rx, ry), taken in `unit`, to the tile's film. */
static void film_add(const render_job *job, tile_film *tf, uint32_t unit, float rx, float ry,
                     const float L[3])
{
    int ux = (int)(unit % (uint32_t)job->units_w), uy = (int)(unit / (uint32_t)job->units_w);
    float *a = tf->acc + (size_t)((uy - tf->uy0) * tf->tw + (ux - tf->ux0)) *
                             (size_t)TILE_SUMS(job->taps);
    int r = job->radius;
    if (r == 0) {
        for (int c = 0; c < 3; c++)
            a[c] += L[c];
        a[3] += 1.0f;
    } else {
        /* Tap (dx, dy) is pixel (cx + dx, cy + dy); the density is separable. */
        float wx[2 * MAX_SPLAT_RADIUS + 1], wy[2 * MAX_SPLAT_RADIUS + 1];
        int cx = ux - r, cy = uy - r;
        for (int d = -r; d <= r; d++) {
            wx[d + r] = pixel_filter_density(&job->filter, (float)(cx + d) + 0.5f - rx);
            wy[d + r] = pixel_filter_density(&job->filter, (float)(cy + d) + 0.5f - ry);
        }
        int side = 2 * r + 1;
        for (int j = 0; j < side; j++)
            for (int i = 0; i < side; i++) {
                float wgt = wx[i] * wy[j];
                float *t = a + 4 * (j * side + i);
                for (int c = 0; c < 3; c++)
                    t[c] += wgt * L[c];
                t[3] += wgt;
            }
    }
    float *rest = a + 4 * job->taps;
    for (int c = 0; c < 3; c++)
        rest[c] += L[c];
    float v = (L[0] + L[1] + L[2]) * (1.0f / 3.0f);
    rest[3] += v;
    rest[4] += v * v;
}

/* Evaluate the batch's maps, shade every point and add it to the tile's film. Points
 * arrive in (unit, sample) order, so each unit's sums have a fixed order. */
static void batch_flush(worker *w, tile_film *tf)
{
    batch *b = w->b;
    if (b->n == 0)
        return;
    render_job *job = w->job;
    sg_geometry_batch gb;
    batch_geometry(b, &gb);
    float *outs[IN_COUNT] = {b->out_color, b->out_metallic, b->out_roughness, b->out_ior,
                             b->out_alpha, b->out_normal, b->out_spec, b->out_tint};
    double t0 = now_seconds();
    sg_evaluate(w->eval, &gb, outs);
    w->material_seconds += now_seconds() - t0;
    int n = b->n;
    for (int i = 0; i < n; i++) {
        principled_inputs in;
        principled_inputs_default(&in);
        for (int c = 0; c < 3; c++) {
            in.base_color[c] = b->out_color[c * n + i];
            in.specular_tint[c] = b->out_tint[c * n + i];
        }
        in.N = make_float3(b->out_normal[i], b->out_normal[n + i], b->out_normal[2 * n + i]);
        in.metallic = b->out_metallic[i];
        in.roughness = b->out_roughness[i];
        in.ior = b->out_ior[i];
        in.alpha = b->out_alpha[i];
        in.specular_ior_level = b->out_spec[i];
        /* Cycles normalises the Normal input of a closure (safe_normalize). */
        float len;
        in.N = f3_normalize_len(in.N, &len);
        if (len == 0.0f)
            in.N = b->geo[i].N;
        float L[3];
        shade_point(&job->setup, &b->geo[i], &in, b->unit[i], b->sample[i], b->first[i],
                    b->strata[i], L, &w->counters);
        /* Alpha: Cycles mixes in a transparent BSDF; the camera ray continues through
         * the surface. Behind the surface there is only the world in this scene (an
         * occluded continuation is counted as an indirect hit). */
        float alpha = fminf(fmaxf(in.alpha, 0.0f), 1.0f);
        if (alpha < 1.0f) {
            const shading_geometry *g = &b->geo[i];
            if (render_occluded(job->scene, g->P, g->Ng, f3_neg(g->I), INFINITY))
                w->counters.indirect_hits++;
            for (int c = 0; c < 3; c++)
                L[c] = alpha * L[c] + (1.0f - alpha) * job->scene->world[c];
        }
        film_add(job, tf, b->unit[i], b->rx[i], b->ry[i], L);
    }
    w->shading_points += (uint64_t)n;
    b->n = 0;
}

/* Raster position of sample s of the unit's set first .. first + count - 1.
 * Reference mode: the pixel centre plus an independent draw from the filter's density.
 * Fast mode: a point of the cell, the set stratified - a jittered grid when count is a
 * square, else a Latin hypercube - and paired antithetically: point k of the second half
 * is point count - 1 - k reflected through the cell's centre. Each point is still uniform
 * over the cell, so every unit's sums stay unbiased, and a pair's mean is exact for
 * anything linear across the cell. On a square grid the reflected point lies in the
 * reflected stratum, so the grid's stratification is kept. */
static void sample_position(const render_job *job, uint32_t unit, int s, int first, int count,
                            float *rx, float *ry)
{
    const render_options *o = job->opt;
    int ux = (int)(unit % (uint32_t)job->units_w), uy = (int)(unit / (uint32_t)job->units_w);
    if (o->mode != RENDER_FAST) {
        float fu = render_random(o->seed, unit, (uint32_t)s, DIM_FILTER_X);
        float fv = render_random(o->seed, unit, (uint32_t)s, DIM_FILTER_Y);
        *rx = (float)ux + 0.5f + pixel_filter_sample(&job->filter, fu);
        *ry = (float)uy + 0.5f + pixel_filter_sample(&job->filter, fv);
        return;
    }
    int k = s - first;
    int mirrored = k > count - 1 - k;
    if (mirrored)
        k = count - 1 - k;
    uint32_t sample = (uint32_t)(first + k);
    float fu = render_random(o->seed, unit, sample, DIM_FILTER_X);
    float fv = render_random(o->seed, unit, sample, DIM_FILTER_Y);
    int m = (int)(sqrt((double)count) + 0.5);
    if (m * m == count) {
        fu = fminf(((float)(k % m) + fu) / (float)m, 0x1.fffffep-1f);
        fv = fminf(((float)(k / m) + fv) / (float)m, 0x1.fffffep-1f);
    } else {
        uint64_t key = o->seed * 0x9e3779b97f4a7c15ull + unit + (uint64_t)first * 0x2545f491ull;
        uint32_t sy = render_permute((uint32_t)k, (uint32_t)count, key);
        fu = fminf(((float)k + fu) / (float)count, 0x1.fffffep-1f);
        fv = fminf(((float)sy + fv) / (float)count, 0x1.fffffep-1f);
    }
    if (mirrored) {
        fu = 1.0f - fu;
        fv = 1.0f - fv;
    }
    *rx = (float)(ux - job->radius) + fu;
    *ry = (float)(uy - job->radius) + fv;
}

static void render_tile(worker *w, int tile)
{
    render_job *job = w->job;
    const render_options *o = job->opt;
    const ortho_camera *cam = &job->camera;
    tile_film tf;
    /* the window's units end here (exclusive) */
    int ux1 = job->px0 + job->pw + 2 * job->radius, uy1 = job->py0 + job->ph + 2 * job->radius;
    tf.ux0 = job->px0 + (tile % job->tiles_x) * TILE;
    tf.uy0 = job->py0 + (tile / job->tiles_x) * TILE;
    tf.tw = ux1 - tf.ux0 < TILE ? ux1 - tf.ux0 : TILE;
    tf.acc = w->tile_acc;
    int th = uy1 - tf.uy0 < TILE ? uy1 - tf.uy0 : TILE;
    const int stride = TILE_SUMS(job->taps), keep = UNIT_SUMS(job->taps);
    memset(tf.acc, 0, sizeof(float) * (size_t)(TILE * TILE * stride));
    const int spp = o->spp;
    for (int uy = tf.uy0; uy < tf.uy0 + th; uy++)
        for (int ux = tf.ux0; ux < tf.ux0 + tf.tw; ux++) {
            uint32_t unit = (uint32_t)(uy * job->units_w + ux);
            int first = 0, count = spp;
            if (job->phase == 2) {
                first = spp;
                count = (int)job->extra[unit];
            }
            for (int s = first; s < first + count; s++) {
                float rx, ry;
                sample_position(job, unit, s, first, count, &rx, &ry);
                float3 P, D;
                float dP;
                ortho_camera_ray(cam, rx, ry, &P, &D, &dP);
                w->camera_rays++;
                struct RTCIntersectContext ctx;
                rtcInitIntersectContext(&ctx);
                struct RTCRayHit rh;
                memset(&rh, 0, sizeof rh);
                rh.ray.org_x = P.x, rh.ray.org_y = P.y, rh.ray.org_z = P.z;
                rh.ray.dir_x = D.x, rh.ray.dir_y = D.y, rh.ray.dir_z = D.z;
                rh.ray.tnear = 0.0f;
                rh.ray.tfar = INFINITY;
                rh.ray.mask = 0xffffffffu;
                rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(job->scene->rtc, &ctx, &rh);
                if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
                    film_add(job, &tf, unit, rx, ry, job->scene->world);
                    continue;
                }
                batch *b = w->b;
                render_shading_geometry(job->scene, (int)rh.hit.geomID, rh.hit.primID, rh.hit.u,
                                        rh.hit.v, D, dP, &b->geo[b->n]);
                b->unit[b->n] = unit;
                b->sample[b->n] = (uint32_t)s;
                b->first[b->n] = (uint32_t)first;
                b->strata[b->n] = (uint32_t)count;
                b->rx[b->n] = rx;
                b->ry[b->n] = ry;
                if (++b->n == BATCH)
                    batch_flush(w, &tf);
            }
        }
    batch_flush(w, &tf);
    /* Tiles do not overlap: no lock needed to write the units' sums. */
    for (int y = 0; y < th; y++)
        for (int x = 0; x < tf.tw; x++) {
            size_t unit = (size_t)(tf.uy0 + y) * (size_t)job->units_w + (size_t)(tf.ux0 + x);
            const float *a = tf.acc + (size_t)(y * tf.tw + x) * (size_t)stride;
            float *dst = &job->sums[(size_t)keep * unit];
            if (job->phase == 1) {
                memcpy(dst, a, sizeof(float) * (size_t)keep);
                if (job->variance) {
                    double sv = a[keep], mean = sv / spp;
                    double var = spp > 1 ? (a[keep + 1] - sv * mean) / (spp - 1) : 0.0;
                    job->variance[unit] = (float)(var > 0.0 ? var : 0.0);
                    job->mean[unit] = (float)mean;
                }
            } else if (job->extra[unit] > 0) {
                for (int k = 0; k < keep; k++)
                    dst[k] += a[k];
            }
        }
}

/* The window's pixels from the units' sums (see the top of the tiles section); the rest
 * of film is left as it is. */
static void film_resolve(const render_job *job, float *film)
{
    int r = job->radius, side = 2 * r + 1;
    int width = job->camera.width;
    for (int py = job->py0; py < job->py0 + job->ph; py++)
        for (int px = job->px0; px < job->px0 + job->pw; px++) {
            float v[3] = {0, 0, 0};
            for (int dy = -r; dy <= r; dy++)
                for (int dx = -r; dx <= r; dx++) {
                    /* The unit of cell (px - dx, py - dy) reaches this pixel by tap (dx, dy). */
                    size_t unit = (size_t)(py - dy + r) * (size_t)job->units_w +
                                  (size_t)(px - dx + r);
                    const float *u = &job->sums[(size_t)UNIT_SUMS(job->taps) * unit];
                    const float *t = u + 4 * ((dy + r) * side + (dx + r));
                    /* The tap's weighted mean (reference mode: weights 1, I 1: the
                     * samples' mean), or where every weight is 0 (points on the edge of
                     * the support) the cell's plain mean. */
                    float I = (float)(job->cell_weight[dx + r] * job->cell_weight[dy + r]);
                    const float *mean = t[3] > 0.0f ? t : u + 4 * job->taps;
                    float norm = t[3] > 0.0f ? t[3]
                                             : (float)job->opt->spp +
                                                   (float)(job->extra ? job->extra[unit] : 0);
                    for (int c = 0; c < 3; c++)
                        v[c] += I * (mean[c] / norm);
                }
            memcpy(&film[3 * ((size_t)py * (size_t)width + (size_t)px)], v, sizeof v);
        }
}

/* Phase 2's plan: for each unit, from the phase-1 statistics of the 24 others in the 5 x 5
 * cells around it (never its own: see the top of the file), the number of extra shading
 * points that brings the standard error its samples give a pixel to noise_target x
 * sqrt(the neighbours' mean (at least 0.01) x the image's mean), as a square k^2 (a
 * stratified set), with spp + k^2 <= max_spp.
 * Why that scale: relative to the local mean alone, dark regions of a dark image were
 * sampled far beyond what the image's RMSE needed, and smooth frames stayed noisier than
 * Cycles-252 while costing more; relative to the image's mean alone, glints in dark
 * regions were left heavy-tailed and 16x16 blocks 15-20% off. The geometric mean of the
 * two was the most RMSE-efficient on the six super-shader frames (render/NOTES.md).
 * Why 5 x 5: glints are small; with 3 x 3 a cell whose neighbours' few samples missed a
 * glint region kept 4 samples, and a rare hit on the light's reflection (radiance ~20)
 * then put whole 16x16 blocks 15-25% off. 5 x 5 sees the region sooner: lower RMSE on
 * all six frames at 1.1-1.7x the time (the larger cost is in sparkling frames).
 * A pixel is a weighted sum of the means of the ~9 cells around it, so n samples of
 * variance v in each give it a variance of about v / n times the sum of the squared
 * weights (cell_w2, 0.29 for 1.5 px Blackman-Harris): it needs that fraction of the
 * samples an importance-sampled pixel would.
 * Returns the total number of extra shading points. */
#define NEIGHBOURHOOD 2 /* cells on each side */
static uint64_t plan_extra_samples(render_job *job)
{
    const render_options *o = job->opt;
    int w = job->units_w, h = job->units_h;
    int kmax = (int)sqrt((double)(o->max_spp - o->spp));
    uint64_t total = 0;
    int r = job->radius, width = job->camera.width, height = job->camera.height;
    double image_mean = 0.0;
    for (int y = r; y < r + height; y++)
        for (int x = r; x < r + width; x++)
            image_mean += job->mean[(size_t)y * (size_t)w + (size_t)x];
    image_mean /= (double)width * height;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double var = 0.0, mean = 0.0;
            int n = 0;
            for (int dy = -NEIGHBOURHOOD; dy <= NEIGHBOURHOOD; dy++)
                for (int dx = -NEIGHBOURHOOD; dx <= NEIGHBOURHOOD; dx++) {
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
            double eps = o->noise_target * sqrt((mean > 0.01 ? mean : 0.01) * image_mean);
            /* shading points beyond phase 1 */
            double need = job->cell_w2 * var / (eps * eps) - o->spp;
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
    if (o->blender != SG_BLENDER_3 && o->blender != SG_BLENDER_4) {
        snprintf(err, errlen, "Blender version must be 3 or 4 (got %d)", (int)o->blender);
        return -1;
    }
    if (o->blender != m->blender) {
        snprintf(err, errlen, "material compiled for Blender %d, render asks for %d", (int)m->blender,
                 (int)o->blender);
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
        job->light.sphere = o->blender == SG_BLENDER_4 && !job->light.soft_falloff;
        job->setup.light = &job->light;
    }
    int width = job->camera.width, height = job->camera.height;
    if (o->mode == RENDER_FAST) {
        /* A cell's points reach the pixels whose centres lie within the filter's
         * half-width (its support is +-filter_width px). */
        job->radius = (int)ceilf(s->filter_width - 0.5f);
        if (job->radius < 1)
            job->radius = 1;
        if (job->radius > MAX_SPLAT_RADIUS) {
            free(job);
            snprintf(err, errlen,
                     "fast mode handles pixel filters up to %.1f px (the scene's is %g px); "
                     "use reference mode", MAX_SPLAT_RADIUS + 0.5, (double)s->filter_width);
            return -1;
        }
        double w2 = 0.0;
        for (int d = -job->radius; d <= job->radius; d++) {
            double I = pixel_filter_cdf(&job->filter, d + 0.5) -
                       pixel_filter_cdf(&job->filter, d - 0.5);
            job->cell_weight[d + job->radius] = I;
            w2 += I * I;
        }
        job->cell_w2 = (float)(w2 * w2);
    } else {
        job->cell_weight[0] = 1.0; /* a unit is its pixel */
    }
    int side = 2 * job->radius + 1;
    job->taps = side * side;
    job->units_w = width + 2 * job->radius;
    job->units_h = height + 2 * job->radius;
    /* Adaptive sampling needs room for at least one extra 1x1 set. */
    int adaptive = o->mode == RENDER_FAST && o->max_spp > o->spp;
    if (o->window_w || o->window_h || o->window_x || o->window_y) {
        if (o->window_x < 0 || o->window_y < 0 || o->window_w < 1 || o->window_h < 1 ||
            o->window_w > width - o->window_x || o->window_h > height - o->window_y) {
            snprintf(err, errlen, "window %d x %d at (%d, %d) is not inside the %d x %d image",
                     o->window_w, o->window_h, o->window_x, o->window_y, width, height);
            free(job);
            return -1;
        }
        if (adaptive) {
            snprintf(err, errlen, "a window needs adaptive sampling off (max spp <= spp): "
                                  "its plan reads the whole image");
            free(job);
            return -1;
        }
        job->px0 = o->window_x, job->py0 = o->window_y;
        job->pw = o->window_w, job->ph = o->window_h;
    } else {
        job->pw = width, job->ph = height;
    }
    job->tiles_x = (job->pw + 2 * job->radius + TILE - 1) / TILE;
    job->tiles_y = (job->ph + 2 * job->radius + TILE - 1) / TILE;
    if (image_alloc(out, width, height, 3) < 0) {
        free(job);
        snprintf(err, errlen, "out of memory for a %dx%d image", width, height);
        return -1;
    }
    size_t nunits = (size_t)job->units_w * (size_t)job->units_h;
    job->sums = malloc(nunits * (size_t)UNIT_SUMS(job->taps) * sizeof *job->sums);
    if (adaptive) {
        job->variance = malloc(nunits * sizeof *job->variance);
        job->mean = malloc(nunits * sizeof *job->mean);
        job->extra = malloc(nunits * sizeof *job->extra);
    }
    if (!job->sums || (adaptive && (!job->variance || !job->mean || !job->extra))) {
        free(job->sums);
        free(job->variance);
        free(job->mean);
        free(job->extra);
        free(job);
        image_free(out);
        snprintf(err, errlen, "out of memory for a %dx%d image", width, height);
        return -1;
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
        workers[i].tile_acc = malloc(sizeof(float) * TILE * TILE * (size_t)TILE_SUMS(job->taps));
        if (!workers[i].eval || !workers[i].b || !workers[i].tile_acc)
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
        st.material_seconds += workers[i].material_seconds;
        if (workers[i].eval)
            sg_evaluator_free(workers[i].eval);
        free(workers[i].b);
        free(workers[i].tile_acc);
    }
    if (ok)
        film_resolve(job, out->pixels);
    free(workers);
    free(tids);
    pthread_mutex_destroy(&job->lock);
    free(job->sums);
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
