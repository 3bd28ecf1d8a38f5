/*
 * The renderer's pieces, each small enough to test alone (tests/unit/test_render.c):
 * sampler (sampler.c), pixel filter and camera (camera.c), sphere light (light.c),
 * scene and Embree geometry (scene.c), shading (integrator.c), tiles and film (render.c).
 * Internal to render/ and its tests; the public interface is render.h.
 */
#ifndef IMSYNTH_RENDER_INTERNAL_H
#define IMSYNTH_RENDER_INTERNAL_H

#include <math.h>
#include <stdint.h>

#include <embree3/rtcore.h>

#include "render/bsdf_principled.h"
#include "render/render.h"

/* ---- vectors ----------------------------------------------------------------------
 * Points, directions and normals are float3 with kernel_math.h's operations (through
 * bsdf_principled.h), each written to round as the per-component expression it
 * replaced; colours and radiances are float[3]; Embree's rays and buffers stay floats. */

/* Cycles' make_orthonormals: the tangent pair around N that Cycles uses to rebuild a
 * compact differential (and therefore where Bump takes its offsets). */
void render_make_orthonormals(float3 N, float3 *a, float3 *b);

/* ---- sampler ----------------------------------------------------------------------- */

/* Dimensions of one sample's random vector. Each is an independent uniform number in
 * [0, 1) derived from (seed, pixel, sample, dimension) by a hash; fast mode stratifies
 * on top of these (integrator.c). */
enum {
    DIM_FILTER_X,
    DIM_FILTER_Y,
    DIM_LIGHT_U,
    DIM_LIGHT_V,
    DIM_BSDF_U,
    DIM_BSDF_V,
    DIM_BSDF_W,
    DIM_STRATUM_PERM, /* fast mode: permutations of strata */
    DIM_COUNT
};
float render_random(uint64_t seed, uint32_t pixel, uint32_t sample, uint32_t dim);
/* A pseudo-random permutation of [0, n), selected by key: where index goes. */
uint32_t render_permute(uint32_t index, uint32_t n, uint64_t key);

/* ---- pixel filter and camera ------------------------------------------------------- */

/* Cycles' Blackman-Harris filter: the window of full width 2 * filter_width pixels
 * (Cycles doubles the user's width for this filter), separable in x and y, sampled by
 * inverting its CDF. The table maps u in [0,1] to an offset from the pixel centre. */
#define FILTER_TABLE_SIZE 1024
typedef struct pixel_filter {
    float width; /* the user's width in pixels (1.5 for the references) */
    float table[FILTER_TABLE_SIZE];
} pixel_filter;

void pixel_filter_init(pixel_filter *f, float width);
float pixel_filter_sample(const pixel_filter *f, float u); /* offset in pixels */
/* The 1D density the table samples: the window divided by its integral, so that
 * integral over x of pixel_filter_density(x) = 1; 0 outside the support. */
float pixel_filter_density(const pixel_filter *f, float x);
/* The integral of the density from the support's start to x. */
double pixel_filter_cdf(const pixel_filter *f, double x);

typedef struct ortho_camera {
    float3 position;
    float3 forward, right, up; /* unit, right-handed: right x up = -forward */
    float ortho_scale;                 /* width of the view of the larger image side, m */
    int width, height;
} ortho_camera;

/* Ray for raster position (rx, ry) in pixels, (0, 0) the top-left corner of the image,
 * so (px + 0.5, py + 0.5) is pixel (px, py)'s centre. Orthographic: D is `forward` for
 * every ray. Also the compact differential (Cycles: mean pixel extent in metres). */
void ortho_camera_ray(const ortho_camera *c, float rx, float ry, float3 *P, float3 *D,
                      float *dP);

/* ---- lights ------------------------------------------------------------------------ */

/* Blender's point light with a radius. The emitted radiance is
 *     L = power * colour / (4 pi) / (pi r^2)
 * (Cycles: the watts of a point light are radiant intensity times 4 pi, spread over the
 * area pi r^2 it presents to any point). With Soft Falloff (4.x default, and the only
 * model of 3.x) Cycles represents the sphere as a disk of radius r centred on the light,
 * facing the shading point; without it (4.x) as a true sphere. */
typedef struct point_light {
    float3 position;
    float radius;
    float radiance[3];
    int soft_falloff; /* as in the scene file (Blender 4.x's option) */
    int sphere; /* 1 = true sphere (4.x with Soft Falloff off), 0 = facing disk; set per
                   render from soft_falloff and the Blender version */
} point_light;

typedef struct light_sample {
    float3 wi;     /* unit direction from the shading point to the light */
    float t;       /* distance to the sampled point */
    float pdf;     /* solid angle density of wi */
} light_sample;

/* Samples a direction towards the light from P, uniform over its area as seen from P
 * (solid angle for the sphere). Returns 0 when P cannot see the light at all. */
int point_light_sample(const point_light *l, float3 P, float u, float v, light_sample *out);
/* Whether the ray (P, wi) hits the light; if so its distance and the pdf with which
 * point_light_sample would have produced wi. */
int point_light_intersect(const point_light *l, float3 P, float3 wi, float *t, float *pdf);

/* ---- scene ----------------------------------------------------------------------- */

/* A mesh in world space. Its object transform (Blender's matrix_world: world = R o + t,
 * from the scene file's optional "transform") moves its texture space, not its geometry:
 * Object coordinates are R^T (P - t) and Generated coordinates span the object-space
 * bounding box, as in Blender for an object whose mesh was counter-transformed. Without a
 * transform, object space is world space, bit for bit. Triangles only; quads are split
 * on load. */
typedef struct render_mesh {
    int n_vertices, n_triangles;
    float *vertices; /* 3 per vertex, world space */
    float *uv;       /* 2 per vertex, may be NULL (then uv = 0) */
    unsigned *triangles;
    int has_transform;
    float rotation[9];              /* R, row-major */
    float location[3];              /* t */
    float *object_vertices;         /* 3 per vertex, object space (= vertices without one) */
    float bbox_min[3], bbox_max[3]; /* object space, for Generated coordinates */
} render_mesh;

struct render_scene {
    ortho_camera camera;
    float filter_width;
    int n_meshes;
    render_mesh *meshes;
    int n_lights;
    point_light *lights;
    float world[3]; /* uniform world radiance (colour * strength) */
    RTCDevice device;
    RTCScene rtc;
};

/* ---- shading point -------------------------------------------------------------- */

/* Geometry at a camera hit, as the evaluator wants it (sg_geometry_batch fields). */
typedef struct shading_geometry {
    float3 P, dPdx, dPdy, N, Ng, I;
    float3 generated, dgenerated_dx, dgenerated_dy;
    float3 uv, duv_dx, duv_dy;
    float3 object, dobject_dx, dobject_dy, object_normal; /* object space */
} shading_geometry;

/* Fills g for a hit on mesh `mesh`, triangle `prim` at barycentrics (bu, bv) (Embree's:
 * P = (1-bu-bv) v0 + bu v1 + bv v2), for a ray of direction D and compact differential
 * dP. Differentials are rebuilt as Cycles does: dP along make_orthonormals(Ng). */
void render_shading_geometry(const render_scene *s, int mesh, unsigned prim, float bu, float bv,
                             float3 D, float dP, shading_geometry *g);

/* ---- integrator ------------------------------------------------------------------ */

typedef struct shade_setup {
    const render_scene *scene;
    const point_light *light; /* NULL when the scene has none */
    sg_blender_mode blender;
    render_mode mode;
    int light_samples; /* fast mode */
    uint64_t seed;
} shade_setup;

typedef struct shade_counters {
    uint64_t shadow_rays, indirect_hits;
} shade_counters;

/* Radiance leaving shading point g towards the camera (along g->I): direct light from the
 * point light and the world, through the BSDF `in`. `sample` selects the random numbers
 * (reference: one path; fast: one shading point with light_samples pairs); in fast mode
 * the pixel's samples first .. first + strata - 1 form one stratified set. */
void shade_point(const shade_setup *s, const shading_geometry *g, const principled_inputs *in,
                 uint32_t pixel, uint32_t sample, uint32_t first, uint32_t strata, float L[3],
                 shade_counters *cnt);

/* Whether the segment from P (offset along Ng) in direction wi hits scene geometry
 * closer than tmax. */
int render_occluded(const render_scene *s, float3 P, float3 Ng, float3 wi, float tmax);

#endif
