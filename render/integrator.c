/*
 * Direct lighting at a shading point: the point light by next-event estimation and by
 * BSDF sampling, combined with the power heuristic (as Cycles does), and the uniform
 * world.
 *
 * The expected value is the integral over the hemisphere of f_cos (L_light + L_world):
 * Cycles treats lights as transparent to the rays that find them (a ray hitting the
 * light also continues to the world), so the world is seen in every direction and the
 * light adds on top. Rays leaving the surface that hit geometry again would need another
 * bounce; this integrator counts them (shade_counters.indirect_hits) and stops, which is
 * exact for the scene's plane (it cannot see itself) and visibly wrong otherwise.
 *
 * reference: one light sample, one BSDF sample per call, plain Monte Carlo; the world
 *     through the BSDF sample only (it is not light-sampled).
 * fast: light_samples light samples and as many BSDF samples per call, in Latin
 *     hypercube strata; the world term is exact: L_world * directional albedo (valid
 *     because the world is uniform and unoccluded, which indirect_hits == 0 in
 *     reference mode confirms for a scene).
 */
#include "render/render_internal.h"

static float power_heuristic(float a, float b)
{
    float a2 = a * a, b2 = b * b;
    return a2 / (a2 + b2);
}

int render_occluded(const render_scene *s, const float P[3], const float Ng[3],
                    const float wi[3], float tmax)
{
    /* Offset the origin off the surface, to the side wi leaves on; scaled to the
     * position's magnitude as float precision is relative. */
    float mag = fmaxf(fmaxf(fabsf(P[0]), fabsf(P[1])), fmaxf(fabsf(P[2]), 1.0f));
    float eps = 1e-5f * mag;
    float side = v3_dot(wi, Ng) >= 0.0f ? eps : -eps;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay ray = {0};
    ray.org_x = P[0] + side * Ng[0];
    ray.org_y = P[1] + side * Ng[1];
    ray.org_z = P[2] + side * Ng[2];
    ray.dir_x = wi[0], ray.dir_y = wi[1], ray.dir_z = wi[2];
    ray.tnear = 0.0f;
    ray.tfar = tmax;
    ray.mask = 0xffffffffu;
    rtcOccluded1(s->rtc, &ctx, &ray);
    return ray.tfar < 0.0f;
}

/* Point in stratum k of n from jitter r in [0, 1), kept below 1 where rounding would
 * reach it. */
static float stratum(int k, int n, float r)
{
    return fminf(((float)k + r) / (float)n, 0x1.fffffep-1f);
}

/* Stratum of sub-sample j for dimension pair `salt`: a permutation per shading point. */
static int permuted(int j, int n, const shade_setup *s, uint32_t pixel, uint32_t sample,
                    uint32_t salt)
{
    uint64_t key = s->seed ^ ((uint64_t)pixel << 32) ^ ((uint64_t)sample << 8) ^ salt;
    key = key * 0x9e3779b97f4a7c15ull + pixel;
    return (int)render_permute((uint32_t)j, (uint32_t)n, key);
}

/* Light sampling: Le f_cos / pdf_light, MIS-weighted against BSDF sampling. */
static void light_estimate(const shade_setup *s, const shading_geometry *g,
                           const principled_inputs *in, float u, float v, float L[3],
                           shade_counters *cnt)
{
    const point_light *l = s->light;
    light_sample ls;
    if (!point_light_sample(l, g->P, u, v, &ls))
        return;
    float f[3], pdf_bsdf;
    principled_eval(in, s->blender, g->I, ls.wi, g->Ng, f, &pdf_bsdf);
    if (f[0] == 0.0f && f[1] == 0.0f && f[2] == 0.0f)
        return;
    cnt->shadow_rays++;
    if (render_occluded(s->scene, g->P, g->Ng, ls.wi, ls.t * 0.9999f))
        return;
    float w = power_heuristic(ls.pdf, pdf_bsdf) / ls.pdf;
    for (int k = 0; k < 3; k++)
        L[k] += l->radiance[k] * f[k] * w;
}

/* BSDF sampling: the light where the ray finds it (MIS-weighted) and, when with_world,
 * the world (not light-sampled, so weight 1). */
static void bsdf_estimate(const shade_setup *s, const shading_geometry *g,
                          const principled_inputs *in, const float u[3], int with_world,
                          float L[3], shade_counters *cnt)
{
    float wi[3], f[3], pdf;
    if (!principled_sample(in, s->blender, g->I, g->Ng, u, wi, f, &pdf) || pdf <= 0.0f)
        return;
    if (render_occluded(s->scene, g->P, g->Ng, wi, INFINITY)) {
        cnt->indirect_hits++;
        return;
    }
    if (with_world)
        for (int k = 0; k < 3; k++)
            L[k] += s->scene->world[k] * f[k] / pdf;
    float t, pdf_light;
    if (s->light && point_light_intersect(s->light, g->P, wi, &t, &pdf_light)) {
        float w = power_heuristic(pdf, pdf_light) / pdf;
        for (int k = 0; k < 3; k++)
            L[k] += s->light->radiance[k] * f[k] * w;
    }
}

void shade_point(const shade_setup *s, const shading_geometry *g, const principled_inputs *in,
                 uint32_t pixel, uint32_t sample, float L[3], shade_counters *cnt)
{
    L[0] = L[1] = L[2] = 0.0f;
    if (s->mode == RENDER_REFERENCE) {
        if (s->light)
            light_estimate(s, g, in, render_random(s->seed, pixel, sample, DIM_LIGHT_U),
                           render_random(s->seed, pixel, sample, DIM_LIGHT_V), L, cnt);
        float u[3] = {render_random(s->seed, pixel, sample, DIM_BSDF_U),
                      render_random(s->seed, pixel, sample, DIM_BSDF_V),
                      render_random(s->seed, pixel, sample, DIM_BSDF_W)};
        bsdf_estimate(s, g, in, u, 1, L, cnt);
        return;
    }

    float albedo[3];
    principled_albedo(in, s->blender, g->I, g->Ng, albedo);
    for (int k = 0; k < 3; k++)
        L[k] = s->scene->world[k] * albedo[k];
    if (!s->light)
        return;
    int n = s->light_samples > 0 ? s->light_samples : 1;
    float acc[3] = {0, 0, 0};
    for (int j = 0; j < n; j++) {
        /* Sub-sample j of this shading point: its own random numbers, strata chosen by
         * permutations so that (u, v) pairs form a Latin hypercube. */
        uint32_t sub = sample * 64u + (uint32_t)j;
        float lu = stratum(j, n, render_random(s->seed, pixel, sub, DIM_LIGHT_U));
        float lv = stratum(permuted(j, n, s, pixel, sample, 1), n,
                           render_random(s->seed, pixel, sub, DIM_LIGHT_V));
        light_estimate(s, g, in, lu, lv, acc, cnt);
        float bu[3] = {stratum(permuted(j, n, s, pixel, sample, 2), n,
                               render_random(s->seed, pixel, sub, DIM_BSDF_U)),
                       stratum(permuted(j, n, s, pixel, sample, 3), n,
                               render_random(s->seed, pixel, sub, DIM_BSDF_V)),
                       render_random(s->seed, pixel, sub, DIM_BSDF_W)};
        bsdf_estimate(s, g, in, bu, 0, acc, cnt);
    }
    for (int k = 0; k < 3; k++)
        L[k] += acc[k] / (float)n;
}
