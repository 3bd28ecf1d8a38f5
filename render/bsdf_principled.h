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
 * the surface. N is the shading normal, Ng the geometric normal. f_cos is
 * BSDF * |cos(wi, N)| per RGB channel; pdf is the solid-angle density with
 * which principled_sample() would produce wi. No hidden state: every function
 * is safe to call from any thread.
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

typedef struct principled_inputs {
    float base_color[3];
    float metallic;
    float roughness;
    float ior;
    float specular_ior_level;
    float specular_tint[3];
    float alpha;
    float N[3];
} principled_inputs;

/* Blender 4.3's defaults for everything but N, which the caller sets. */
void principled_inputs_default(principled_inputs *in);

void principled_eval(const principled_inputs *in, int blender /* 3 or 4 */, const float wo[3],
                     const float wi[3], const float Ng[3], float f_cos[3], float *pdf);

/* u in [0,1)^3. Returns 0 if no direction was produced (then f_cos and pdf are 0). */
int principled_sample(const principled_inputs *in, int blender, const float wo[3],
                      const float Ng[3], const float u[3], float wi[3], float f_cos[3],
                      float *pdf);

/* Directional albedo: the integral of f_cos over all wi for this wo. Where the shading
 * normal is Ng (no bump) it comes from tables (~1 us, within ~0.1% of the integral);
 * with a bumped normal the lobes are cut by the geometric surface and it is computed by
 * quadrature (~30 us of CPU, within 0.5%, 0.03% on average): a renderer with many bumped
 * shading points may prefer to estimate that part with its BSDF samples. */
void principled_albedo(const principled_inputs *in, int blender, const float wo[3],
                       const float Ng[3], float albedo[3]);

#endif
