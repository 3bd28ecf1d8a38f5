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
 *     hypercube strata; the world term is L_world * directional albedo (valid because
 *     the world is uniform and unoccluded, which indirect_hits == 0 in reference mode
 *     confirms for a scene): exact from tables where the normal is Ng; with a bump, the
 *     tables' uncut albedo plus an estimate, from the BSDF samples' numbers, of what the
 *     geometric surface cuts off (principled_albedo_cut_estimate: zero except for
 *     samples that land below Ng, so noise only where the bump tilts lobes over the
 *     horizon, instead of a ~30 us quadrature per shading point).
 *
 * The BSDF is prepared once per shading point (principled_prepare) and then evaluated
 * and sampled 2 x light_samples times.
 */
#include "render/render_internal.h"

#include <assert.h>

static float power_heuristic(float a, float b)
{
    float a2 = a * a, b2 = b * b;
    return a2 / (a2 + b2);
}

int render_occluded(const render_scene *s, float3 P, float3 Ng, float3 wi, float tmax)
{
    /* Offset the origin off the surface, to the side wi leaves on; scaled to the
     * position's magnitude as float precision is relative. */
    float mag = fmaxf(fmaxf(fabsf(P.x), fabsf(P.y)), fmaxf(fabsf(P.z), 1.0f));
    float eps = 1e-5f * mag;
    float side = f3_dot(wi, Ng) >= 0.0f ? eps : -eps;
    float3 org = f3_add(P, f3_scale(Ng, side));
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay ray = {0};
    ray.org_x = org.x, ray.org_y = org.y, ray.org_z = org.z;
    ray.dir_x = wi.x, ray.dir_y = wi.y, ray.dir_z = wi.z;
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

/* A set of a pixel's fast-mode sub-samples, all strata x n of them (the pixel's spp shading
 * points, or the extra ones adaptive sampling adds), share one stratification of each
 * 2D sampling domain (light, BSDF): sub-sample g = sample * n + j gets cell
 * permute(g) of a jittered m x m grid when spp x n = m^2, else a Latin hypercube
 * (independent permutations per dimension). Permutations are random per pixel, so every
 * sub-sample is marginally uniform over [0,1)^2 whichever shading point it belongs to:
 * the estimate stays unbiased although shading points differ, and the pixel's samples
 * cover the domain evenly - which is what tames small-light highlights on glossy
 * surfaces (a hit-or-miss integrand). */
static void stratified_2d(const shade_setup *s, uint32_t pixel, uint32_t g, uint32_t total,
                          uint32_t salt, float r1, float r2, float out[2])
{
    uint64_t key = (s->seed * 0x9e3779b97f4a7c15ull) ^ ((uint64_t)pixel << 20) ^ salt;
    uint32_t m = (uint32_t)(sqrt((double)total) + 0.5);
    if (m * m == total) {
        uint32_t c = render_permute(g, total, key);
        out[0] = stratum((int)(c % m), (int)m, r1);
        out[1] = stratum((int)(c / m), (int)m, r2);
    } else {
        out[0] = stratum((int)render_permute(g, total, key), (int)total, r1);
        out[1] = stratum((int)render_permute(g, total, key ^ 0x5bd1e995u), (int)total, r2);
    }
}

/* Light sampling: Le f_cos / pdf_light, MIS-weighted against BSDF sampling. */
static void light_estimate(const shade_setup *s, const shading_geometry *g,
                           const principled_closure *bsdf, float u, float v, float L[3],
                           shade_counters *cnt)
{
    const point_light *l = s->light;
    light_sample ls;
    if (!point_light_sample(l, g->P, u, v, &ls))
        return;
    float f[3], pdf_bsdf;
    principled_closure_eval(bsdf, ls.wi, f, &pdf_bsdf);
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
 * the world (not light-sampled, so weight 1). The BSDF's value is computed only for
 * directions that contribute: without the world (fast mode) most miss the small light. */
static void bsdf_estimate(const shade_setup *s, const shading_geometry *g,
                          const principled_closure *bsdf, const principled_sampled *smp,
                          int with_world, float L[3], shade_counters *cnt)
{
    if (!smp->usable)
        return;
    const float3 wi = smp->raw;
    float t = INFINITY, pdf_light = 0.0f;
    int hits_light = s->light && point_light_intersect(s->light, g->P, wi, &t, &pdf_light);
    if (!with_world && !hits_light)
        return;
    float f[3], pdf;
    principled_closure_sampled_eval(bsdf, smp, f, &pdf);
    if (!(pdf > 0.0f))
        return;
    /* Without the world (fast mode) only a ray that finds the light matters, and only
     * geometry in front of the light can block it. */
    float tmax = with_world ? INFINITY : t * 0.9999f;
    if (render_occluded(s->scene, g->P, g->Ng, wi, tmax)) {
        cnt->indirect_hits++;
        return;
    }
    if (with_world)
        for (int k = 0; k < 3; k++)
            L[k] += s->scene->world[k] * f[k] / pdf;
    if (hits_light) {
        float w = power_heuristic(pdf, pdf_light) / pdf;
        for (int k = 0; k < 3; k++)
            L[k] += s->light->radiance[k] * f[k] * w;
    }
}

void shade_point(const shade_setup *s, const shading_geometry *g, const principled_inputs *in,
                 uint32_t pixel, uint32_t sample, uint32_t first, uint32_t strata, float L[3],
                 shade_counters *cnt)
{
    L[0] = L[1] = L[2] = 0.0f;
    principled_closure bsdf;
    if (!principled_prepare(in, s->blender, g->I, g->Ng, &bsdf))
        return; /* seen from below Ng: black, as every term would be */
    if (s->mode == RENDER_REFERENCE) {
        if (s->light)
            light_estimate(s, g, &bsdf, render_random(s->seed, pixel, sample, DIM_LIGHT_U),
                           render_random(s->seed, pixel, sample, DIM_LIGHT_V), L, cnt);
        float u[3] = {render_random(s->seed, pixel, sample, DIM_BSDF_U),
                      render_random(s->seed, pixel, sample, DIM_BSDF_V),
                      render_random(s->seed, pixel, sample, DIM_BSDF_W)};
        principled_sampled smp;
        principled_closure_sample_direction(&bsdf, u, &smp);
        bsdf_estimate(s, g, &bsdf, &smp, 1, L, cnt);
        return;
    }

    float albedo[3];
    principled_albedo_uncut(&bsdf, albedo);
    int n = s->light_samples > 0 ? s->light_samples : 1;
    /* Sample j's sub-index below is sample * 64 + j: render.c refuses more light samples. */
    assert(n <= 64);
    float acc[3] = {0, 0, 0}, cut[3] = {0, 0, 0};
    for (int j = 0; j < n; j++) {
        uint32_t sub = sample * 64u + (uint32_t)j; /* n <= 64 */
        /* This shading point's set of samples (first .. first + strata - 1) is stratified
         * on its own; its permutations differ from other sets' (salted by first). */
        uint32_t gi = (sample - first) * (uint32_t)n + (uint32_t)j, total = strata * (uint32_t)n;
        uint32_t set_salt = first * 0x9e3779b9u;
        float lu[2], bu2[2];
        stratified_2d(s, pixel, gi, total, 1u ^ set_salt,
                      render_random(s->seed, pixel, sub, DIM_LIGHT_U),
                      render_random(s->seed, pixel, sub, DIM_LIGHT_V), lu);
        if (s->light)
            light_estimate(s, g, &bsdf, lu[0], lu[1], acc, cnt);
        stratified_2d(s, pixel, gi, total, 2u ^ set_salt,
                      render_random(s->seed, pixel, sub, DIM_BSDF_U),
                      render_random(s->seed, pixel, sub, DIM_BSDF_V), bu2);
        float bw = stratum((int)render_permute(gi, total, s->seed ^ ((uint64_t)pixel << 24) ^
                                                              (3u ^ set_salt)),
                           (int)total, render_random(s->seed, pixel, sub, DIM_BSDF_W));
        float bu[3] = {bu2[0], bu2[1], bw};
        principled_sampled smp;
        principled_closure_sample_direction(&bsdf, bu, &smp);
        if (s->light)
            bsdf_estimate(s, g, &bsdf, &smp, 0, acc, cnt);
        if (bsdf.bumped) {
            float c[3];
            principled_albedo_cut_estimate_shared(&bsdf, bu, &smp, c);
            for (int k = 0; k < 3; k++)
                cut[k] += c[k];
        }
    }
    for (int k = 0; k < 3; k++)
        L[k] = s->scene->world[k] * (albedo[k] + cut[k] / (float)n) + acc[k] / (float)n;
}
