/*
 * render: path tracing of the scene of DESIGN.md (assets/scene.json) with a material
 * graph's Principled BSDF, so that the expected value of every pixel is what Blender's
 * Cycles (3.4 or 4.3) renders for the same material and scene.
 *
 *   render_scene *s = render_scene_load("assets/scene.json", err, sizeof err);
 *   render_material *m = render_material_new(graph, 4, err, sizeof err);
 *   render_options o; render_options_default(&o);
 *   image img; render_image(s, m, &o, &img, NULL, err, sizeof err);
 *
 * Determinism: a pixel is a pure function of (scene, material, options minus threads):
 * every random number derives from (seed, pixel, sample, dimension), so the result does
 * not depend on the thread count or tile order.
 *
 * Nothing here keeps global mutable state; scenes and materials are immutable once
 * built and may be shared by threads.
 */
#ifndef IMSYNTH_RENDER_H
#define IMSYNTH_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "imageio/imageio.h"
#include "shadergraph/shadergraph.h"

typedef struct render_scene render_scene;

/* Load and validate a scene file (format "imsynth-scene/1", see assets/scene.json). On
 * failure returns NULL with a message naming the file and the place. */
render_scene *render_scene_load(const char *path, char *err, size_t errlen);
render_scene *render_scene_load_json(const char *text, size_t len, const char *source_name,
                                     char *err, size_t errlen);
void render_scene_free(render_scene *s);
void render_scene_resolution(const render_scene *s, int *width, int *height);

/* The material: the graph's Principled BSDF inputs compiled for the evaluator. */
typedef struct render_material render_material;
render_material *render_material_new(const sg_graph *g, sg_blender_mode blender, char *err, size_t errlen);
void render_material_free(render_material *m);

typedef enum render_mode {
    RENDER_FAST = 0,     /* default: same expected value, much less noise */
    RENDER_REFERENCE = 1 /* plain Monte Carlo, one path per sample, for verification */
} render_mode;

typedef struct render_options {
    render_mode mode;
    int spp;           /* samples per pixel: paths (reference) or shading points (fast;
                          with adaptive sampling, the first phase's) */
    int light_samples; /* fast mode: light and BSDF sample pairs per shading point */
    sg_blender_mode blender; /* BSDF semantics; the light model follows */
    int threads;       /* 0 = all cores */
    uint64_t seed;
    int width, height; /* 0 = the scene's resolution */
    /* fast mode, adaptive sampling (render.c): cells whose neighbours are noisy get up to
     * max_spp shading points in all (0 or <= spp: off), aiming at a pixel standard error
     * of noise_target x sqrt(local mean x image mean). Defaults: spp 4, max_spp 256,
     * noise_target 0.03. */
    int max_spp;
    float noise_target;
    /* A window: only pixels window_x <= x < window_x + window_w, window_y <= y <
     * window_y + window_h are rendered, each the value a whole render gives it, bit for
     * bit (a cell's samples depend on the cell's place and the seed alone); the others are
     * 0. For a caller that looks at a crop only (predict's search: the descriptors' centre
     * 224 x 224 of 256 x 256 is 77% of the shading points). window_w = 0: the whole image.
     * Not with adaptive sampling, whose plan reads the whole image's mean. */
    int window_x, window_y, window_w, window_h;
} render_options;

void render_options_default(render_options *o);

/* What happened during a render, for tests and the benchmark. */
typedef struct render_stats {
    double seconds;
    uint64_t camera_rays, shading_points, shadow_rays;
    uint64_t extra_shading_points; /* added by adaptive sampling */
    /* Rays leaving a surface that hit geometry again. This integrator stops there (the
     * scene's plane cannot see itself); a scene where this is non-zero needs more bounces
     * and the render is then darker than Cycles'. */
    uint64_t indirect_hits;
    /* Time spent inside the material evaluator (sg_evaluate), summed over the worker
     * threads: the part of a shading point's cost that no integrator can avoid, since
     * every shading point needs the material's values. The benchmark uses it to bound
     * how fast any estimator with the same number of shading points could be. */
    double material_seconds;
} render_stats;

/* Renders an RGB image (allocated here; free with image_free). stats may be NULL.
 * Returns 0, or -1 with a message. */
int render_image(const render_scene *s, const render_material *m, const render_options *o,
                 image *out, render_stats *stats, char *err, size_t errlen);

#endif
