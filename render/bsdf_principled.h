/*
 * The Principled BSDF of Blender's Cycles as pure functions, for the path tracer.
 *
 * Two semantics: blender == 4 (default) is the 4.0 rewrite (dielectric Fresnel
 * from IOR and Specular IOR Level, multiple-scattering GGX, F82-tint metal,
 * albedo-scaled layering of the specular layer over the diffuse base);
 * blender == 3 is the Disney-based Principled BSDF of Blender 3.4.
 *
 * Inputs use Blender 4.x names and defaults (shadergraph/kernels/structural.c);
 * in 3.x mode they map to 3.x sockets as Blender's versioning does (see
 * bsdf_principled.c).
 *
 * Conventions: all directions in world space, unit length, pointing away from
 * the surface, as kernel_math.h's float3 (colours are float[3]). N is the shading
 * normal, Ng the geometric normal. f_cos is
 * BSDF * |cos(wi, N)| per RGB channel; pdf is the solid-angle density with
 * which principled_sample() would produce wi, except where eval() is 0 but Cycles'
 * sampler still returns wi (a bumped normal's sampler-only region, bsdf_principled.c).
 * No hidden state: every function is safe to call from any thread.
 *
 * Alpha is NOT applied here: these functions give the opaque part of the surface, and
 * the caller mixes it with the transparent pass-through, L = alpha L_bsdf +
 * (1 - alpha) L_behind, as Cycles' transparent closure of weight 1 - alpha does (alpha
 * scales every closure weight linearly, so factoring it out is exact).
 *
 * Ng must face wo (flip it for back faces, as Cycles does); the geometry is taken as
 * flat (Cycles' smooth normal is Ng). Directions below Ng get nothing. Mirror-like lobes
 * (roughness below ~0.004 in 4.x, ~0.018 in 3.x) are deltas: eval() leaves them out and
 * sample() returns them with f_cos and pdf both scaled by 1e6 (Cycles' convention, so
 * f_cos / pdf is right and MIS gives them full weight).
 */
#ifndef IMSYNTH_RENDER_BSDF_PRINCIPLED_H
#define IMSYNTH_RENDER_BSDF_PRINCIPLED_H

#include "shadergraph/kernel_math.h"
#include "shadergraph/shadergraph.h" /* sg_blender_mode */

typedef struct principled_inputs {
    float base_color[3];
    float metallic;
    float roughness;
    float ior;
    float specular_ior_level;
    float specular_tint[3];
    float alpha;
    float3 N;
} principled_inputs;

/* Blender 4.3's defaults for everything but N, which the caller sets. */
void principled_inputs_default(principled_inputs *in);

void principled_eval(const principled_inputs *in, sg_blender_mode blender, float3 wo, float3 wi,
                     float3 Ng, float f_cos[3], float *pdf);

/* u in [0,1)^3. Returns 0 if no direction was produced (then f_cos and pdf are 0). */
int principled_sample(const principled_inputs *in, sg_blender_mode blender, float3 wo, float3 Ng,
                      const float u[3], float3 *wi, float f_cos[3], float *pdf);

/* Directional albedo: the integral of f_cos over all wi for this wo. Where the shading
 * normal is Ng (no bump) it comes from tables (~1 us, within ~0.1% of the integral);
 * with a bumped normal the lobes are cut by the geometric surface and it is computed by
 * quadrature (~30 us of CPU, within 0.5%, 0.03% on average). A renderer with many bumped
 * shading points uses principled_albedo_uncut() + principled_albedo_cut_estimate()
 * instead (below). */
void principled_albedo(const principled_inputs *in, sg_blender_mode blender, float3 wo, float3 Ng,
                       float albedo[3]);

/* ---- Prepared closures ------------------------------------------------------------
 * The functions above set the BSDF up (lobes, weights, energy compensation, sampling
 * probabilities: table look-ups) on every call. A renderer that evaluates and samples
 * one shading point several times prepares it once and uses the principled_closure_*
 * functions, which give the same results bit for bit. */

/* One closure of the BSDF (Cycles' term): diffuse, dielectric specular or metal. */
typedef struct principled_lobe {
    int active;
    float3 N;
    float weight[3];    /* closure weight per channel, incl. 4.x energy compensation */
    float prob;         /* selection probability (sum 1 over active lobes) */
    float alpha;        /* microfacet lobes: roughness^2 */
    int singular;       /* a mirror: a delta, not in eval() */
    int fresnel;        /* which Fresnel model (bsdf_principled.c) */
    float f0[3];        /* F0 (4.x specular: F0 * tint; 3.x: cspec0) */
    float b[3];         /* F82-tint factor */
    float eta;          /* IOR of the real Fresnel curve (dielectric and 3.x models) */
} principled_lobe;

enum { PRINCIPLED_DIFFUSE, PRINCIPLED_SPECULAR, PRINCIPLED_METAL, PRINCIPLED_LOBES };

typedef struct principled_closure {
    sg_blender_mode blender;
    float3 V, Ng;
    float roughness;            /* as the albedo tables take it */
    float diffuse_roughness;    /* 3.x retro-reflection */
    int bumped;                 /* some active lobe's normal is not Ng */
    principled_lobe lobe[PRINCIPLED_LOBES];
} principled_closure;

/* Returns 0 if the BSDF is zero for this view (wo below Ng); then the closure has no
 * active lobe and the functions below give zeros. */
int principled_prepare(const principled_inputs *in, sg_blender_mode blender, float3 wo, float3 Ng,
                       principled_closure *c);
void principled_closure_eval(const principled_closure *c, float3 wi, float f_cos[3], float *pdf);
int principled_closure_sample(const principled_closure *c, const float u[3], float3 *wi,
                              float f_cos[3], float *pdf);

/* principled_closure_sample() in two steps, for an integrator that needs the value only
 * for some directions (fast mode: those that find the light): the direction, then its
 * value. Same bits as principled_closure_sample(). `raw` is the chosen lobe's sampler's
 * direction wherever it points (principled_albedo_cut_estimate_shared() reuses it);
 * `usable` says it is the direction principled_closure_sample() returns (above Ng; as
 * in Cycles, possibly below the lobe's own hemisphere, where eval() is 0 and
 * sampled_eval() gives the sampled lobe's value); sampled_eval() gives zeros otherwise. */
typedef struct principled_sampled {
    int lobe;   /* the lobe u[2] picked, -1 if none is active */
    int raw_ok; /* the lobe's sampler gave a direction */
    int usable;
    float3 raw;
} principled_sampled;
void principled_closure_sample_direction(const principled_closure *c, const float u[3],
                                         principled_sampled *s);
void principled_closure_sampled_eval(const principled_closure *c, const principled_sampled *s,
                                     float f_cos[3], float *pdf);
void principled_closure_albedo(const principled_closure *c, float albedo[3]);

/* The directional albedo in two parts, for bumped normals. principled_albedo_uncut() is
 * the albedo the lobes would have if the geometric surface did not cut them (each lobe's
 * table at its own normal; delta lobes exactly): equal to principled_albedo() when
 * c->bumped is 0. principled_albedo_cut_estimate() is a one-sample estimate, from u in
 * [0,1)^3 (use the BSDF samples' numbers, stratified as they are), of what the cut
 * removes: albedo = uncut + E[cut_estimate], exactly in expectation. It samples the
 * lobes as principled_closure_sample() does but keeps directions below Ng, so only
 * samples that fall where the surface cuts a lobe are non-zero: noise only where the
 * bump tilts the lobes over the horizon. ~0.1 us instead of the quadrature's ~30. */
void principled_albedo_uncut(const principled_closure *c, float albedo[3]);
void principled_albedo_cut_estimate(const principled_closure *c, const float u[3],
                                    float cut[3]);
/* The same, reusing the direction principled_closure_sample_direction() sampled from the
 * same u (NULL: sample it here); same bits. */
void principled_albedo_cut_estimate_shared(const principled_closure *c, const float u[3],
                                           const principled_sampled *sampled, float cut[3]);

#endif
