/*
 * The Principled BSDF of Cycles (Blender 4.3 and 3.4) for opaque, non-transmissive,
 * non-coated, non-sheen, non-subsurface materials: the part of the node that the
 * super-shader drives. Written from Cycles' kernel sources (svm/closure.h's
 * PRINCIPLED case, closure/bsdf_microfacet.h, bsdf_diffuse.h, bsdf_principled_diffuse.h,
 * bsdf_util.h, bsdf.h), not copied from them.
 *
 * How Cycles evaluates a Principled BSDF: the node becomes a set of closures (lobes),
 * each with a weight; the surface's BSDF is the weighted sum of the lobes, and BSDF
 * sampling picks one lobe with probability proportional to its sample weight, samples
 * it, and reports the mixture pdf sum_l p_l pdf_l. We do the same with three lobes:
 *
 *   Blender 4.x (the 4.0 rewrite, MULTI_GGX, the default distribution of a new node):
 *     metal     metallic * GGX with F82-tint Fresnel (F0 = base colour, F82 tint =
 *               Specular Tint), multiple-scattering energy compensation;
 *     specular  (1 - metallic) * GGX with the dielectric Fresnel of IOR, F0 scaled by
 *               2 * Specular IOR Level and tinted by Specular Tint, compensated;
 *     diffuse   Lambert, weighted by (1 - metallic) * base colour * (1 - the specular
 *               layer's directional albedo), Cycles' closure_layering_weight.
 *     Energy compensation (Cycles' microfacet_ggx_preserve_energy, after Kulla and
 *     Conty): a lobe with single-scattering albedo E(mu) is scaled by 1 + Fms (1-E)/E,
 *     Fms = Fss Eavg / (1 - Fss (1 - Eavg)), Fss the lobe's hemispherical mean Fresnel.
 *     Tables E, Eavg and the layering factor come from render/microfacet_tables.c.
 *   Blender 3.4 (GGX: what the importer's new node gets in 3.4):
 *     diffuse   (1 - metallic) * base colour * Disney diffuse with retro-reflection;
 *     specular  GGX (separable Smith G) with Fresnel interpolating from
 *               cspec0 = mix(0.08 Specular, base colour, metallic) to white along the
 *               real Fresnel curve of IOR 2/(1 - sqrt(0.08 Specular)) - 1.
 *     Mapping of inputs: 3.x Specular = Specular IOR Level (Blender's 4.0 versioning
 *     keeps the value); 3.x Specular Tint (a float) is taken as 0, its default, since a
 *     4.x tint colour has no 3.x equivalent; IOR only affects 3.x transmission (none).
 *
 * Normals. 4.x: the specular and metal lobes use the shading normal raised so that the
 * view's mirror reflection stays above the surface (maybe_ensure_valid_specular_reflection,
 * applied since "Bump Map Correction" is on by default); the diffuse lobe uses the normal
 * as given, with the bump shadowing term (smoothed) when it differs from Ng. 3.x: every
 * closure's normal goes through ensure_valid_reflection (svm_node_closure_bsdf does this;
 * it leaves a normal that the Bump node already corrected unchanged) and the diffuse gets
 * 3.x's bump shadowing term. The geometry is taken as flat: Cycles' smooth normal sd->N is
 * Ng. Ng must face the viewer (flip it for back faces, as Cycles does); otherwise the BSDF
 * is zero.
 *
 * Self-consistency. Every lobe is zero below Ng, and sample() rejects directions there.
 * Above Ng, eval()'s pdf for a lobe is the density with which its sampler returns the
 * direction, and sample() reports for the direction it returns the very bits eval() gives
 * there (principled_closure_sampled_eval calls the same closures_eval), except in two
 * places where, as in Cycles, they part:
 *   - the sampler-only region (with a bump only): a microfacet sampler also returns
 *     directions above Ng but below its lobe's own hemisphere, where eval() gives 0,
 *     value and pdf, and sample() the sampled lobe's formula and density
 *     (microfacet_sampled_value). So eval()'s pdf integrates to the probability that
 *     sample() returns a direction where eval() is defined, not every direction it
 *     returns;
 *   - near-mirror lobes (alpha^2 below Cycles' threshold) are deltas: eval() gives 0 for
 *     them and sample() adds their f_cos and pdf multiplied by SINGULAR_SCALE = 1e6, as
 *     Cycles does, so that f_cos / pdf is right and MIS gives the delta full weight.
 * test_bsdf_principled checks both statements (test_pdf_integral_*: the integral of
 * eval()'s pdf against the counted success of sample(); test_sample_matches_eval: the
 * same bits outside the sampler-only region, which it reaches).
 */
#include "render/bsdf_principled.h"

#include <math.h>
#include <stdbool.h>
#include <stddef.h>

#include "render/microfacet_tables.h"

#define PI_F 3.14159265358979323846f
#define SINGULAR_SCALE 1e6f
/* Cycles drops closures whose weight is below this. */
#define CLOSURE_WEIGHT_CUTOFF 1e-5f

/* Vectors and scalars use Cycles' helpers as the node kernels do (shadergraph/
 * kernel_math.h: float3 and f3_*, mix, saturatef, sqr, safe_sqrtf, ...). */

/* Cycles' safe_normalize_fallback, rounding alike (a times the reciprocal of its
 * length), but the fallback also for a NaN length, where Cycles tests != 0 and gives
 * NaNs. */
static float3 normalize_or(float3 a, float3 fallback)
{
    float l = sqrtf(f3_dot(a, a));
    return l > 0.0f ? f3_scale(a, 1.0f / l) : fallback;
}

static float average3(const float c[3]) { return (c[0] + c[1] + c[2]) * (1.0f / 3.0f); }

/* Orthonormal tangents of a unit n (Duff et al. 2017). */
static void tangent_frame(float3 n, float3 *t, float3 *b)
{
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float c = n.x * n.y * a;
    *t = make_float3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = make_float3(c, sign + n.y * n.y * a, -n.y);
}

/* ---- Fresnel ---------------------------------------------------------------------- */

/* Unpolarised dielectric reflectance at cos c for relative IOR eta (1 on total internal
 * reflection). */
static float fresnel_dielectric(float c, float eta)
{
    c = fabsf(c);
    float g = eta * eta - 1.0f + c * c;
    if (g <= 0.0f)
        return 1.0f;
    g = sqrtf(g);
    float A = (g - c) / (g + c);
    float B = (c * (g + c) - 1.0f) / (c * (g - c) + 1.0f);
    return 0.5f * A * A * (1.0f + B * B);
}

static float F0_from_ior(float ior) { return sqr((ior - 1.0f) / (ior + 1.0f)); }

static float ior_from_F0(float f0)
{
    float s = sqrtf(fminf(fmaxf(f0, 0.0f), 0.99f));
    return (1.0f + s) / (1.0f - s);
}

/* Where the real Fresnel curve of eta is between its normal-incidence value and 1: the
 * interpolation factor from F0 to F90 of Cycles' Principled specular (both versions). */
static float fresnel_interpolation(float cos_hi, float eta)
{
    float F0 = F0_from_ior(eta);
    float F = fresnel_dielectric(cos_hi, eta);
    return F0 < 1.0f ? (F - F0) / (1.0f - F0) : 1.0f;
}

/* ---- Normals ---------------------------------------------------------------------- */

/* Blender 4.x: if the view's mirror reflection about N points below (or too close to) the
 * surface, rotate N towards Ng, in their common plane, until the reflection sits at the
 * threshold t above the surface. Squaring the condition 2 (N'.I) N'.z - I.z = t gives a
 * quadratic in N'.z^2 with one root of the right sign, chosen by the sign of I.x. */
static float3 valid_specular_normal_4x(float3 Ng, float3 I, float3 N)
{
    if (f3_isequal(N, Ng))
        return N;
    float3 R = f3_sub(f3_scale(N, 2.0f * f3_dot(N, I)), I);
    float Iz = f3_dot(I, Ng);
    float t = fminf(0.9f * Iz, 0.01f);
    if (f3_dot(Ng, R) >= t)
        return N;
    float3 X = normalize_or(f3_sub(N, f3_scale(Ng, f3_dot(N, Ng))), N);
    float Ix = f3_dot(I, X);
    float a = Ix * Ix + Iz * Iz;
    float b = 2.0f * (a + Iz * t);
    float c = sqr(t + Iz);
    float root = safe_sqrtf(b * b - 4.0f * a * c);
    float Nz2 = Ix < 0.0f ? 0.25f * (b + root) / a : 0.25f * (b - root) / a;
    return f3_add(f3_scale(X, safe_sqrtf(1.0f - Nz2)), f3_scale(Ng, safe_sqrtf(Nz2)));
}

/* Blender 3.x's older solution of the same problem: kernel_math.h's
 * ensure_valid_reflection (which 3.4's Bump node uses, shadergraph/kernels/geometry.c),
 * except that the in-plane tangent X is normalised by a reciprocal with N as fallback
 * (normalize_or) where Cycles divides: at most a last-bit difference in X, and so in the
 * corrected normal. Renders depend on those bits, so it stays until a reference render
 * asks for the change (render/NOTES.md). */
static float3 valid_reflection_normal_3x(float3 Ng, float3 I, float3 N)
{
    float t = valid_reflection_threshold(Ng, I);
    if (reflection_is_valid(Ng, I, N, t))
        return N;
    float3 X = normalize_or(f3_sub(N, f3_scale(Ng, f3_dot(N, Ng))), N);
    return valid_reflection_in_plane(Ng, I, X, t);
}

/* Cycles' shadow-terminator term for diffuse closures whose normal N differs from the
 * smooth normal (Chiang, Li and Burley, "Taming the Shadow Terminator"); 4.x smooths it
 * only with Bump Map Correction on (the default), 3.x always. L is the light direction. */
static float bump_shadowing(float3 Ng, float3 N, float3 L)
{
    float cos_nl = f3_dot(N, L);
    if (cos_nl < 0.0f)
        Ng = f3_scale(Ng, -1.0f);
    float den = cos_nl * f3_dot(Ng, N);
    float g = den != 0.0f ? f3_dot(Ng, L) / den : 0.0f;
    if (g >= 1.0f)
        return 1.0f;
    if (g < 0.0f)
        return 0.0f;
    float g2 = g * g;
    return -g2 * g + g2 + g;
}

/* ---- GGX ---------------------------------------------------------------------------- */

/* Smith Lambda of GGX for a direction at cos c to the normal. */
static float ggx_lambda(float alpha2, float c)
{
    float c2 = c * c;
    return 0.5f * (sqrtf(1.0f + alpha2 * fmaxf(1.0f / c2 - 1.0f, 0.0f)) - 1.0f);
}

static float ggx_D(float alpha2, float cos_nh)
{
    float c2 = fminf(cos_nh * cos_nh, 1.0f);
    return alpha2 / (PI_F * sqr(1.0f - c2 + alpha2 * c2));
}

/* Heitz 2018's sampling of the visible normals of isotropic GGX, in the frame where the
 * normal is +z and v (unit, v.z > 0) is the view. */
static float3 ggx_sample_visible_normal(float3 v, float alpha, float u1, float u2)
{
    float3 vh = normalize_or(make_float3(alpha * v.x, alpha * v.y, v.z), make_float3(0, 0, 1));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    float3 t1 = lensq > 1e-7f ? f3_scale(make_float3(-vh.y, vh.x, 0.0f), 1.0f / sqrtf(lensq))
                            : make_float3(1.0f, 0.0f, 0.0f);
    float3 t2 = f3_cross(vh, t1);
    float r = sqrtf(u1), phi = 2.0f * PI_F * u2;
    float px = r * cosf(phi), py = r * sinf(phi);
    float s = 0.5f * (1.0f + vh.z);
    py = (1.0f - s) * safe_sqrtf(1.0f - px * px) + s * py;
    float3 h = f3_add(f3_add(f3_scale(t1, px), f3_scale(t2, py)),
                    f3_scale(vh, safe_sqrtf(1.0f - px * px - py * py)));
    return normalize_or(make_float3(alpha * h.x, alpha * h.y, fmaxf(0.0f, h.z)), make_float3(0, 0, 1));
}

/* ---- Closures ----------------------------------------------------------------------- */

enum {
    LOBE_DIFFUSE = PRINCIPLED_DIFFUSE,
    LOBE_SPECULAR = PRINCIPLED_SPECULAR,
    LOBE_METAL = PRINCIPLED_METAL,
    N_LOBES = PRINCIPLED_LOBES
};
enum { FRESNEL_DIELECTRIC_4X, FRESNEL_F82_TINT, FRESNEL_CSPEC0_3X };

/* The lobe and closure structs are public (bsdf_principled.h) so that callers can hold a
 * prepared closure; only this file reads their fields. */
typedef principled_lobe lobe;
typedef principled_closure closures;

static void lobe_fresnel(const lobe *l, float cos_hi, float F[3])
{
    if (l->fresnel == FRESNEL_F82_TINT) {
        float m = saturatef(1.0f - cos_hi);
        float m5 = sqr(sqr(m)) * m;
        for (int c = 0; c < 3; c++)
            F[c] = saturatef(mix(l->f0[c], 1.0f, m5) - l->b[c] * cos_hi * m5 * m);
        return;
    }
    float s = fresnel_interpolation(cos_hi, l->eta);
    if (l->fresnel == FRESNEL_DIELECTRIC_4X)
        s = saturatef(s);
    for (int c = 0; c < 3; c++)
        F[c] = mix(l->f0[c], 1.0f, s);
}

/* The microfacet formula (f * |cos| without weight, and pdf) for the direction L wherever
 * it is relative to the lobe's normal: Lambda depends on cos^2 only. The callers below
 * decide where it applies. */
static void microfacet_formula(const closures *cl, const lobe *l, float3 L, float cos_nv,
                               float cos_nl, float f[3], float *pdf)
{
    float3 H = normalize_or(f3_add(cl->V, L), l->N);
    float alpha2 = l->alpha * l->alpha;
    float D = ggx_D(alpha2, f3_dot(l->N, H));
    float common = D * 0.25f / cos_nv;
    float G, G1v;
    if (cl->blender == SG_BLENDER_3) {
        /* 3.x: separable Smith, G1 = 2 / (1 + sqrt(1 + alpha^2 tan^2)) = 1 / (1 + Lambda). */
        G1v = 1.0f / (1.0f + ggx_lambda(alpha2, cos_nv));
        G = G1v / (1.0f + ggx_lambda(alpha2, cos_nl));
    } else {
        /* 4.x: height-correlated Smith. */
        float lv = ggx_lambda(alpha2, cos_nv), ll = ggx_lambda(alpha2, cos_nl);
        G1v = 1.0f / (1.0f + lv);
        G = 1.0f / (1.0f + lv + ll);
    }
    float F[3];
    /* 3.x evaluates its Fresnel at dot(L, H), 4.x at dot(V, H): equal for reflection. */
    lobe_fresnel(l, f3_dot(H, cl->V), F);
    for (int c = 0; c < 3; c++)
        f[c] = F[c] * common * G;
    *pdf = common * G1v;
}

/* f * |cos| (without weight) and pdf of a microfacet lobe over its own hemisphere, as
 * if the geometric surface did not cut it; 0 if invalid or singular. */
static void microfacet_eval_uncut(const closures *cl, const lobe *l, float3 L, float f[3],
                                  float *pdf)
{
    f[0] = f[1] = f[2] = 0.0f;
    *pdf = 0.0f;
    float cos_nv = f3_dot(l->N, cl->V), cos_nl = f3_dot(l->N, L);
    if (l->singular || cos_nv <= 0.0f || cos_nl <= 0.0f)
        return;
    microfacet_formula(cl, l, L, cos_nv, cos_nl, f, pdf);
}

/* What Cycles' microfacet sampler reports for a direction it sampled, which is more than
 * the lobe's eval: the sampler (3.4 and 4.3 alike) rejects a reflection only when it
 * points below Ng, so with a bumped normal a direction above Ng but below the lobe's
 * own hemisphere (cos_nl < 0: the "sampler-only" region) keeps the value of the formula
 * (F D G / (4 cos_nv), Lambda of |cos_nl|), while eval gives such a direction 0. That is
 * the world's contribution there, as Cycles does not light-sample a uniform world; a
 * render that dropped it was 0.75% dark in its world term on supershader_s4. Equal to
 * microfacet_eval_uncut where cos_nl > 0. */
static void microfacet_sampled_value(const closures *cl, const lobe *l, float3 L, float f[3],
                                     float *pdf)
{
    f[0] = f[1] = f[2] = 0.0f;
    *pdf = 0.0f;
    float cos_nv = f3_dot(l->N, cl->V), cos_nl = f3_dot(l->N, L);
    if (l->singular || cos_nv <= 0.0f || cos_nl == 0.0f)
        return;
    microfacet_formula(cl, l, L, cos_nv, cos_nl, f, pdf);
}

/* The same, zero below Ng: the lobe as the BSDF has it. */
static void microfacet_eval(const closures *cl, const lobe *l, float3 L, float f[3], float *pdf)
{
    if (f3_dot(cl->Ng, L) <= 0.0f) {
        f[0] = f[1] = f[2] = 0.0f;
        *pdf = 0.0f;
        return;
    }
    microfacet_eval_uncut(cl, l, L, f, pdf);
}

/* Density with which microfacet_sample_direction() produces L, wherever L is (also below
 * the lobe's hemisphere, where the lobe is zero): D G1(V) / (4 cos_nv). */
static float microfacet_sample_pdf(const closures *cl, const lobe *l, float3 L)
{
    float cos_nv = f3_dot(l->N, cl->V);
    if (l->singular || cos_nv <= 0.0f)
        return 0.0f;
    float3 H = normalize_or(f3_add(cl->V, L), l->N);
    if (f3_dot(H, cl->V) <= 0.0f)
        return 0.0f;
    float alpha2 = l->alpha * l->alpha;
    float lv = ggx_lambda(alpha2, cos_nv);
    return ggx_D(alpha2, f3_dot(l->N, H)) * 0.25f / cos_nv / (1.0f + lv);
}

/* A microfacet lobe's sampled direction (the view mirrored about a visible normal),
 * wherever it points; false only if the lobe cannot be sampled for this view. */
static bool microfacet_sample_direction(const closures *cl, const lobe *l, float u1, float u2,
                                        float3 *L)
{
    float cos_nv = f3_dot(l->N, cl->V);
    if (cos_nv <= 0.0f)
        return false;
    float3 H;
    if (l->singular) {
        H = l->N;
    } else {
        float3 t, b;
        tangent_frame(l->N, &t, &b);
        float3 v = make_float3(f3_dot(t, cl->V), f3_dot(b, cl->V), cos_nv);
        float3 h = ggx_sample_visible_normal(v, l->alpha, u1, u2);
        H = f3_add(f3_add(f3_scale(t, h.x), f3_scale(b, h.y)), f3_scale(l->N, h.z));
    }
    float cos_hv = f3_dot(H, cl->V);
    *L = f3_sub(f3_scale(H, 2.0f * cos_hv), cl->V);
    return true;
}

/* Whether direction L lies below the hemisphere of lobe i, a microfacet lobe with a
 * density: for a direction above Ng, the sampler-only region (microfacet_sampled_value). */
static bool below_lobe_hemisphere(const closures *cl, int i, float3 L)
{
    const lobe *l = &cl->lobe[i];
    return i != LOBE_DIFFUSE && l->active && !l->singular && !(f3_dot(l->N, L) > 0.0f);
}

/* Samples a microfacet lobe's direction; false if none. As in Cycles, only a reflection
 * below the geometric surface is rejected, not one below the lobe's own hemisphere (see
 * microfacet_sampled_value). */
static bool microfacet_sample(const closures *cl, const lobe *l, float u1, float u2, float3 *L)
{
    return microfacet_sample_direction(cl, l, u1, u2, L) && f3_dot(cl->Ng, *L) > 0.0f;
}

/* f * cos (without weight) and pdf of the diffuse lobe over its own hemisphere, without
 * the geometric surface's cut and without the bump shadowing term. */
static void diffuse_eval_uncut(const closures *cl, const lobe *l, float3 L, float *f, float *pdf)
{
    *f = *pdf = 0.0f;
    float cos_nl = f3_dot(l->N, L);
    if (cos_nl <= 0.0f)
        return;
    *pdf = cos_nl / PI_F;
    float shape = 1.0f;
    if (cl->blender == SG_BLENDER_3) {
        /* Disney diffuse: Lambert with Schlick-shaped entry and exit, plus retro-reflection
         * growing with roughness. */
        float cos_nv = f3_dot(l->N, cl->V);
        float m_v = saturatef(1.0f - cos_nv), m_l = saturatef(1.0f - cos_nl);
        float FV = sqr(sqr(m_v)) * m_v, FL = sqr(sqr(m_l)) * m_l;
        float RR = cl->diffuse_roughness * (f3_dot(L, cl->V) + 1.0f);
        shape = (1.0f - 0.5f * FV) * (1.0f - 0.5f * FL) + RR * (FL + FV + FL * FV * (RR - 1.0f));
    }
    *f = *pdf * shape;
}

/* f * cos (without weight) and pdf of the diffuse lobe. */
static void diffuse_eval(const closures *cl, const lobe *l, float3 L, float *f, float *pdf)
{
    if (f3_dot(cl->Ng, L) <= 0.0f) {
        *f = *pdf = 0.0f;
        return;
    }
    diffuse_eval_uncut(cl, l, L, f, pdf);
    if (*pdf > 0.0f && !f3_isequal(l->N, cl->Ng))
        *f *= bump_shadowing(cl->Ng, l->N, L);
}

/* Cosine-weighted direction about the diffuse lobe's normal (pdf cos_nl / pi). */
static float3 diffuse_sample_direction(const lobe *l, float u1, float u2)
{
    float3 t, b;
    tangent_frame(l->N, &t, &b);
    float r = sqrtf(u1), phi = 2.0f * PI_F * u2;
    return f3_add(f3_add(f3_scale(t, r * cosf(phi)), f3_scale(b, r * sinf(phi))),
                  f3_scale(l->N, safe_sqrtf(1.0f - u1)));
}

/* Sum over lobes of weight * f_cos, and the mixture pdf. */
static void closures_eval(const closures *cl, float3 L, float f_cos[3], float *pdf)
{
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0f;
    *pdf = 0.0f;
    for (int i = 0; i < N_LOBES; i++) {
        const lobe *l = &cl->lobe[i];
        if (!l->active)
            continue;
        float f[3], p;
        if (i == LOBE_DIFFUSE) {
            diffuse_eval(cl, l, L, &f[0], &p);
            f[1] = f[2] = f[0];
        } else {
            microfacet_eval(cl, l, L, f, &p);
        }
        for (int c = 0; c < 3; c++)
            f_cos[c] += l->weight[c] * f[c];
        *pdf += l->prob * p;
    }
}

/* Kulla-Conty compensation factor of Cycles' microfacet_ggx_preserve_energy: the
 * single-scattering lobe times 1 + Fms (1 - E) / E. */
static void energy_compensation(float roughness, float mu, const float Fss[3], float out[3])
{
    float E = microfacet_table_2d(microfacet_ggx_E, roughness, mu, 32, 32);
    float Eavg = microfacet_table_1d(microfacet_ggx_Eavg, roughness, 32);
    float missing = (1.0f - E) / E;
    for (int c = 0; c < 3; c++) {
        float Fms = Fss[c] * Eavg / (1.0f - Fss[c] * (1.0f - Eavg));
        out[c] = 1.0f + Fms * missing;
    }
}

/* Single-scattering directional albedo of a 4.x microfacet lobe from the tables (N = Ng);
 * without its weight. */
static void microfacet_albedo_4x(const lobe *l, float roughness, float mu, float alb[3])
{
    float y = sqrtf(fmaxf(mu, 0.0f));
    float E = microfacet_table_2d(microfacet_alb4_E, roughness, y, 32, 32);
    if (l->fresnel == FRESNEL_F82_TINT) {
        float S5 = microfacet_table_2d(microfacet_alb4_S5, roughness, y, 32, 32);
        float S6 = microfacet_table_2d(microfacet_alb4_S6, roughness, y, 32, 32);
        for (int c = 0; c < 3; c++)
            alb[c] = l->f0[c] * E + (1.0f - l->f0[c]) * S5 - l->b[c] * S6;
        return;
    }
    float z = sqrtf(fabsf((l->eta - 1.0f) / (l->eta + 1.0f)));
    float S = microfacet_table_3d(microfacet_alb4_S, roughness, y, z, 32, 32, 16);
    for (int c = 0; c < 3; c++)
        alb[c] = l->f0[c] * E + (1.0f - l->f0[c]) * S;
}

static void microfacet_albedo_3x(const lobe *l, float roughness, float mu, float alb[3])
{
    float y = sqrtf(fmaxf(mu, 0.0f));
    float E = microfacet_table_2d(microfacet_alb3_E, roughness, y, 32, 32);
    float z = sqrtf(fabsf((l->eta - 1.0f) / (l->eta + 1.0f)));
    float S = microfacet_table_3d(microfacet_alb3_S, roughness, y, z, 32, 32, 16);
    for (int c = 0; c < 3; c++)
        alb[c] = l->f0[c] * E + (1.0f - l->f0[c]) * S;
}

static float diffuse_albedo_3x(float roughness, float mu)
{
    const float *D = microfacet_alb3_D;
    return microfacet_table_1d(D, mu, 64) + roughness * microfacet_table_1d(D + 64, mu, 64) +
           roughness * roughness * microfacet_table_1d(D + 128, mu, 64);
}

/* Sets the selection probabilities from per-lobe estimates of their albedo. */
static void set_probabilities(closures *cl, const float estimate[N_LOBES])
{
    /* A lobe with a zero estimate has (next to) no albedo; it stays in eval() but is
     * never picked. If every estimate is zero, pick uniformly. */
    float sum = 0.0f;
    int n_active = 0;
    for (int i = 0; i < N_LOBES; i++) {
        if (cl->lobe[i].active) {
            sum += fmaxf(estimate[i], 0.0f);
            n_active++;
        }
    }
    for (int i = 0; i < N_LOBES; i++) {
        lobe *l = &cl->lobe[i];
        if (!l->active)
            l->prob = 0.0f;
        else
            l->prob = sum > 0.0f ? fmaxf(estimate[i], 0.0f) / sum : 1.0f / (float)n_active;
    }
}

static void setup_4x(closures *cl, const principled_inputs *in, float3 N)
{
    float metallic = saturatef(in->metallic);
    float roughness = saturatef(in->roughness);
    float level = fmaxf(in->specular_ior_level, 0.0f);
    float ior = fmaxf(in->ior, 1e-5f);
    float tint[3], base[3];
    for (int c = 0; c < 3; c++) {
        tint[c] = fmaxf(in->specular_tint[c], 0.0f);
        base[c] = fmaxf(in->base_color[c], 0.0f);
    }
    float3 N_spec = valid_specular_normal_4x(cl->Ng, cl->V, N);
    float mu = f3_dot(cl->V, N_spec);
    float estimate[N_LOBES] = {0};
    float weight = 1.0f;  /* Alpha is the caller's: see bsdf_principled.h. */

    lobe *m = &cl->lobe[LOBE_METAL];
    if (metallic * weight > CLOSURE_WEIGHT_CUTOFF) {
        m->active = true;
        m->N = N_spec;
        m->alpha = roughness * roughness;
        m->singular = m->alpha * m->alpha <= 2e-10f;
        m->fresnel = FRESNEL_F82_TINT;
        /* F82-tint (Kutz et al.): Schlick minus b cos (1-cos)^6, with b chosen so that the
         * value at cos = 1/7 is Schlick's times the tint. */
        const float f = 6.0f / 7.0f, f5 = sqr(sqr(f)) * f;
        float Fss[3];
        for (int c = 0; c < 3; c++) {
            m->f0[c] = fminf(base[c], 1.0f);
            float f82 = fminf(tint[c], 1.0f);
            m->b[c] = mix(m->f0[c], 1.0f, f5) * (7.0f / (f5 * f)) * (1.0f - f82);
            Fss[c] = mix(m->f0[c], 1.0f, 1.0f / 21.0f) - m->b[c] * (1.0f / 126.0f);
        }
        float comp[3], alb[3];
        energy_compensation(roughness, mu, Fss, comp);
        microfacet_albedo_4x(m, roughness, mu, alb);
        for (int c = 0; c < 3; c++) {
            m->weight[c] = metallic * weight * comp[c];
            alb[c] *= m->weight[c];
        }
        estimate[LOBE_METAL] = average3(alb);
    }
    weight *= 1.0f - metallic;

    /* Specular IOR Level scales F0 (0.5 keeps the IOR's own F0). */
    float eta = ior, f0 = F0_from_ior(ior);
    if (level != 0.5f) {
        f0 *= 2.0f * level;
        eta = ior_from_F0(f0);
        if (ior < 1.0f)
            eta = 1.0f / eta;
    }
    lobe *s = &cl->lobe[LOBE_SPECULAR];
    if (eta != 1.0f && weight > CLOSURE_WEIGHT_CUTOFF) {
        s->active = true;
        s->N = N_spec;
        s->alpha = roughness * roughness;
        s->singular = s->alpha * s->alpha <= 2e-10f;
        s->fresnel = FRESNEL_DIELECTRIC_4X;
        s->eta = eta;
        /* Hemispherical mean of the real Fresnel curve (Kulla and Conty's fit), mapped to
         * the interpolation factor between F0 and 1. */
        float real_Fss = eta < 1.0f
                             ? 0.997118f + eta * (0.1014f - eta * (0.965241f + eta * 0.130607f))
                             : (eta - 1.0f) / (4.08567f + 1.00071f * eta);
        float real_F0 = F0_from_ior(eta);
        float s_avg = saturatef((real_Fss - real_F0) / (1.0f - real_F0));
        float Fss[3];
        for (int c = 0; c < 3; c++) {
            s->f0[c] = saturatef(f0 * tint[c]);
            Fss[c] = mix(s->f0[c], 1.0f, s_avg);
        }
        float comp[3];
        energy_compensation(roughness, mu, Fss, comp);
        /* Cycles attenuates the layers below by the specular layer's albedo estimate:
         * E * comp * mix(F0, 1, s) with s its table of the VNDF-mean interpolation factor
         * (bsdf_albedo; the E factor is the darkening that its energy preservation moves
         * into the closure weight). */
        float E = microfacet_table_2d(microfacet_ggx_E, roughness, mu, 32, 32);
        float z = sqrtf(fabsf((eta - 1.0f) / (eta + 1.0f)));
        float s_tab = microfacet_table_3d(microfacet_ggx_gen_schlick_ior_s, roughness, mu, z,
                                          16, 16, 16);
        float layer_max = 0.0f, alb[3];
        microfacet_albedo_4x(s, roughness, mu, alb);
        for (int c = 0; c < 3; c++) {
            s->weight[c] = weight * comp[c];
            layer_max = fmaxf(layer_max, E * comp[c] * mix(s->f0[c], 1.0f, s_tab));
            alb[c] *= s->weight[c];
        }
        estimate[LOBE_SPECULAR] = average3(alb);
        weight *= saturatef(1.0f - layer_max);
    }

    lobe *d = &cl->lobe[LOBE_DIFFUSE];
    for (int c = 0; c < 3; c++)
        d->weight[c] = base[c] * weight;
    if (average3(d->weight) > CLOSURE_WEIGHT_CUTOFF) {
        d->active = true;
        d->N = N;
        estimate[LOBE_DIFFUSE] = average3(d->weight);
    }
    set_probabilities(cl, estimate);
}

static void setup_3x(closures *cl, const principled_inputs *in, float3 N)
{
    float metallic = in->metallic;
    float roughness = in->roughness;
    float specular = in->specular_ior_level;
    const float specular_tint = 0.0f;
    float estimate[N_LOBES] = {0};
    N = valid_reflection_normal_3x(cl->Ng, cl->V, N);
    float weight = 1.0f;  /* Alpha is the caller's: see bsdf_principled.h. */

    float diffuse_weight = 1.0f - saturatef(metallic);
    lobe *d = &cl->lobe[LOBE_DIFFUSE];
    if (fabsf(average3(in->base_color)) > CLOSURE_WEIGHT_CUTOFF &&
        diffuse_weight > CLOSURE_WEIGHT_CUTOFF) {
        for (int c = 0; c < 3; c++)
            d->weight[c] = weight * in->base_color[c] * diffuse_weight;
        d->active = true;
        d->N = N;
        cl->diffuse_roughness = roughness;
        estimate[LOBE_DIFFUSE] = fabsf(average3(d->weight));
    }

    lobe *s = &cl->lobe[LOBE_SPECULAR];
    if (specular > CLOSURE_WEIGHT_CUTOFF || metallic > CLOSURE_WEIGHT_CUTOFF) {
        s->active = true;
        s->N = N;
        s->alpha = saturatef(roughness * roughness);
        s->singular = s->alpha * s->alpha <= 1e-7f;
        s->fresnel = FRESNEL_CSPEC0_3X;
        s->eta = 2.0f / (1.0f - safe_sqrtf(0.08f * specular)) - 1.0f;
        const float *bc = in->base_color;
        float lum = 0.3f * bc[0] + 0.6f * bc[1] + 0.1f * bc[2];
        for (int c = 0; c < 3; c++) {
            float tinted = lum > 0.0f ? bc[c] / lum : 1.0f;
            float tmp = 1.0f - specular_tint + tinted * specular_tint;
            s->f0[c] = saturatef(specular * 0.08f * tmp * (1.0f - metallic) + bc[c] * metallic);
            s->weight[c] = weight;
        }
        /* Cycles' sample weight: the Fresnel colour at the view angle. */
        float F[3];
        lobe_fresnel(s, f3_dot(cl->V, N), F);
        estimate[LOBE_SPECULAR] = weight * average3(F);
    }
    set_probabilities(cl, estimate);
}

/* ---- Interface ---------------------------------------------------------------------- */

void principled_inputs_default(principled_inputs *in)
{
    in->base_color[0] = in->base_color[1] = in->base_color[2] = 0.8f;
    in->metallic = 0.0f;
    in->roughness = 0.5f;
    in->ior = 1.5f;
    in->specular_ior_level = 0.5f;
    in->specular_tint[0] = in->specular_tint[1] = in->specular_tint[2] = 1.0f;
    in->alpha = 1.0f;
    in->N = make_float3(0.0f, 0.0f, 1.0f);
}

int principled_prepare(const principled_inputs *in, sg_blender_mode blender, float3 wo, float3 Ng,
                       closures *cl)
{
    *cl = (closures){0};
    cl->blender = blender == SG_BLENDER_3 ? SG_BLENDER_3 : SG_BLENDER_4;
    cl->V = wo;
    cl->Ng = Ng;
    if (f3_dot(cl->V, cl->Ng) <= 0.0f)
        return 0;
    float3 N = normalize_or(in->N, cl->Ng);
    if (cl->blender == SG_BLENDER_3)
        setup_3x(cl, in, N);
    else
        setup_4x(cl, in, N);
    cl->roughness = cl->blender == SG_BLENDER_3 ? in->roughness : saturatef(in->roughness);
    for (int i = 0; i < N_LOBES; i++)
        if (cl->lobe[i].active && !f3_isequal(cl->lobe[i].N, cl->Ng))
            cl->bumped = 1;
    return 1;
}

void principled_closure_eval(const closures *cl, float3 wi, float f_cos[3], float *pdf)
{
    closures_eval(cl, wi, f_cos, pdf);
}

void principled_closure_sample_direction(const closures *cl, const float u[3],
                                         principled_sampled *s)
{
    s->lobe = -1;
    s->raw_ok = s->usable = 0;
    s->raw = make_float3(0.0f, 0.0f, 0.0f);
    /* Pick a lobe by u[2]. */
    int pick = -1;
    float acc = 0.0f;
    for (int i = 0; i < N_LOBES; i++) {
        if (!cl->lobe[i].active)
            continue;
        pick = i;
        acc += cl->lobe[i].prob;
        if (u[2] < acc)
            break;
    }
    if (pick < 0)
        return;
    const lobe *l = &cl->lobe[pick];
    s->lobe = pick;
    float3 L;
    if (pick == LOBE_DIFFUSE) {
        L = diffuse_sample_direction(l, u[0], u[1]);
        s->raw_ok = 1;
        s->usable = f3_dot(cl->Ng, L) > 0.0f && safe_sqrtf(1.0f - u[0]) > 0.0f;
    } else {
        s->raw_ok = microfacet_sample_direction(cl, l, u[0], u[1], &L);
        s->usable = s->raw_ok && f3_dot(cl->Ng, L) > 0.0f;
    }
    if (s->raw_ok)
        s->raw = L;
}

void principled_closure_sampled_eval(const closures *cl, const principled_sampled *s,
                                     float f_cos[3], float *pdf)
{
    f_cos[0] = f_cos[1] = f_cos[2] = 0.0f;
    *pdf = 0.0f;
    if (!s->usable)
        return;
    const lobe *l = &cl->lobe[s->lobe];
    closures_eval(cl, s->raw, f_cos, pdf);
    if (below_lobe_hemisphere(cl, s->lobe, s->raw)) {
        /* The sampler-only region: eval gave this lobe nothing (nor the others, which
         * share its normal); Cycles counts the sampled lobe's own value and density. */
        float f[3], p;
        microfacet_sampled_value(cl, l, s->raw, f, &p);
        for (int c = 0; c < 3; c++)
            f_cos[c] += l->weight[c] * f[c];
        *pdf += l->prob * p;
    }
    if (l->singular) {
        /* A delta lobe: its own term, scaled as Cycles does, on top of the others. */
        float F[3];
        lobe_fresnel(l, f3_dot(l->N, cl->V), F);
        for (int c = 0; c < 3; c++)
            f_cos[c] += SINGULAR_SCALE * l->weight[c] * F[c];
        *pdf += SINGULAR_SCALE * l->prob;
    }
}

int principled_closure_sample(const closures *cl, const float u[3], float3 *wi,
                              float f_cos[3], float *pdf)
{
    principled_sampled s;
    principled_closure_sample_direction(cl, u, &s);
    if (!s.usable) {
        f_cos[0] = f_cos[1] = f_cos[2] = 0.0f;
        *pdf = 0.0f;
        *wi = make_float3(0.0f, 0.0f, 0.0f);
        return 0;
    }
    *wi = s.raw;
    principled_closure_sampled_eval(cl, &s, f_cos, pdf);
    return *pdf > 0.0f;
}

void principled_eval(const principled_inputs *in, sg_blender_mode blender, float3 wo, float3 wi, float3 Ng,
                     float f_cos[3], float *pdf)
{
    closures cl;
    principled_prepare(in, blender, wo, Ng, &cl);
    principled_closure_eval(&cl, wi, f_cos, pdf);
}

int principled_sample(const principled_inputs *in, sg_blender_mode blender, float3 wo, float3 Ng,
                      const float u[3], float3 *wi, float f_cos[3], float *pdf)
{
    closures cl;
    principled_prepare(in, blender, wo, Ng, &cl);
    return principled_closure_sample(&cl, u, wi, f_cos, pdf);
}

/* One point of a lobe's sampling domain: f_cos / pdf (without the weight) for the
 * direction u maps to; false where the lobe gives no direction there. With also >= 0, a
 * second microfacet lobe with the same normal and roughness (so the same sampled
 * directions and pdf) is evaluated at that direction into r2. */
static bool lobe_ratio(const closures *cl, int i, int also, float u1, float u2, float r[3],
                       float r2[3])
{
    const lobe *l = &cl->lobe[i];
    float3 L;
    float f[3], p;
    r[0] = r[1] = r[2] = 0.0f;
    r2[0] = r2[1] = r2[2] = 0.0f;
    if (i == LOBE_DIFFUSE) {
        L = diffuse_sample_direction(l, u1, u2);
        diffuse_eval(cl, l, L, &f[0], &p);
        f[1] = f[2] = f[0];
    } else {
        if (!microfacet_sample(cl, l, u1, u2, &L))
            return false;
        if (l->singular) {
            lobe_fresnel(l, f3_dot(l->N, cl->V), f);
            p = 1.0f;
            if (also >= 0)
                lobe_fresnel(&cl->lobe[also], f3_dot(l->N, cl->V), r2);
        } else {
            /* microfacet_sample keeps L above Ng; the value is the sampler's. */
            microfacet_sampled_value(cl, l, L, f, &p);
            if (also >= 0 && p > 0.0f) {
                float p2;
                microfacet_sampled_value(cl, &cl->lobe[also], L, r2, &p2);
                for (int c = 0; c < 3; c++)
                    r2[c] /= p;
            }
        }
    }
    if (!(p > 0.0f))
        return false;
    for (int c = 0; c < 3; c++)
        r[c] = f[c] / p;
    return true;
}

/* Directional albedo of one lobe whose normal is not Ng (bump), by a midpoint rule over
 * its sampling domain: the mean of f_cos / pdf. Two things would make a plain midpoint
 * rule converge slowly (about 1 / side): both samplers map u1 -> 1 to the rim of a disk
 * where the integrand behaves like sqrt(1 - u1), which the substitution
 * u1 = 1 - (1 - t)^2 (weight 2 (1 - t)) makes smooth; and the integrand jumps to 0 where
 * the sampled direction falls below Ng, so cells on that edge (where a neighbour differs
 * in validity; u2 is periodic) are refined SUB x SUB. */
static void lobe_albedo_quadrature(const closures *cl, int i, int also, float alb[3],
                                   float alb2[3])
{
    /* The microfacet lobes' integrands are smooth away from the refined edge: 8 x 8 cells
     * are within 0.5% of a 64 x 64 / 16 x 16 quadrature (0.03% on average); 3.x's Disney
     * diffuse has kinks where the bump term saturates and needs 16 x 16 (0.2%). */
    enum { MAX_SIDE = 16, SUB = 4 };
    const int side = i == LOBE_DIFFUSE ? 16 : 8;
    float val[MAX_SIDE][MAX_SIDE][3], val2[MAX_SIDE][MAX_SIDE][3];
    bool ok[MAX_SIDE][MAX_SIDE];
    for (int a = 0; a < side; a++) {
        float t = (a + 0.5f) / side, w = 2.0f * (1.0f - t);
        for (int b = 0; b < side; b++) {
            ok[a][b] = lobe_ratio(cl, i, also, 1.0f - sqr(1.0f - t), (b + 0.5f) / side,
                                  val[a][b], val2[a][b]);
            for (int c = 0; c < 3; c++) {
                val[a][b][c] *= w;
                val2[a][b][c] *= w;
            }
        }
    }
    double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0};
    for (int a = 0; a < side; a++) {
        for (int b = 0; b < side; b++) {
            /* The diffuse lobe fades to 0 at Ng's horizon (the bump shadowing term), so
             * only the microfacet lobes have an edge to refine. */
            bool edge = i != LOBE_DIFFUSE && (ok[a][(b + 1) % side] != ok[a][b] ||
                        ok[a][(b + side - 1) % side] != ok[a][b] ||
                        (a > 0 && ok[a - 1][b] != ok[a][b]) ||
                        (a + 1 < side && ok[a + 1][b] != ok[a][b]));
            if (!edge) {
                for (int c = 0; c < 3; c++) {
                    sum[c] += val[a][b][c];
                    sum2[c] += val2[a][b][c];
                }
                continue;
            }
            double cell[3] = {0, 0, 0}, cell2[3] = {0, 0, 0};
            for (int p = 0; p < SUB; p++) {
                for (int q = 0; q < SUB; q++) {
                    float r[3], r2[3], t = (a + (p + 0.5f) / SUB) / side, w = 2.0f * (1.0f - t);
                    lobe_ratio(cl, i, also, 1.0f - sqr(1.0f - t), (b + (q + 0.5f) / SUB) / side,
                               r, r2);
                    for (int c = 0; c < 3; c++) {
                        cell[c] += w * r[c];
                        cell2[c] += w * r2[c];
                    }
                }
            }
            for (int c = 0; c < 3; c++) {
                sum[c] += cell[c] / (SUB * SUB);
                sum2[c] += cell2[c] / (SUB * SUB);
            }
        }
    }
    for (int c = 0; c < 3; c++) {
        alb[c] = (float)(sum[c] / (side * side)) * cl->lobe[i].weight[c];
        if (also >= 0)
            alb2[c] = (float)(sum2[c] / (side * side)) * cl->lobe[also].weight[c];
    }
}

/* A lobe's directional albedo (with its weight) from the tables at its own normal: exact
 * (to the tables' accuracy) where the normal is Ng; with a bump, what the lobe would
 * reflect if Ng did not cut it, except 4.x's diffuse, whose table is of the cut lobe with
 * its shadowing term, and delta lobes, cut exactly. */
static void lobe_albedo_uncut(const closures *cl, int i, float alb[3])
{
    const lobe *l = &cl->lobe[i];
    float mu = f3_dot(cl->V, l->N);
    if (i == LOBE_DIFFUSE) {
        float d = 1.0f;
        if (cl->blender == SG_BLENDER_3) {
            d = diffuse_albedo_3x(cl->diffuse_roughness, mu);
        } else if (!f3_isequal(l->N, cl->Ng)) {
            /* Lambert under the bump shadowing term depends on the tilt only. */
            float tilt = acosf(fminf(fmaxf(f3_dot(l->N, cl->Ng), -1.0f), 1.0f));
            d = microfacet_table_1d(microfacet_bump_lambert, tilt / (0.5f * PI_F), 65);
        }
        alb[0] = alb[1] = alb[2] = d;
    } else if (l->singular) {
        lobe_fresnel(l, mu, alb);
        float3 R = f3_sub(f3_scale(l->N, 2.0f * mu), cl->V);
        if (!(f3_dot(cl->Ng, R) > 0.0f && f3_dot(l->N, R) > 0.0f))
            alb[0] = alb[1] = alb[2] = 0.0f;
    } else if (cl->blender == SG_BLENDER_3) {
        microfacet_albedo_3x(l, cl->roughness, mu, alb);
    } else {
        microfacet_albedo_4x(l, cl->roughness, mu, alb);
    }
    for (int c = 0; c < 3; c++)
        alb[c] *= l->weight[c];
}

void principled_closure_albedo(const closures *cl, float albedo[3])
{
    albedo[0] = albedo[1] = albedo[2] = 0.0f;
    bool done[N_LOBES] = {false};
    for (int i = 0; i < N_LOBES; i++) {
        const lobe *l = &cl->lobe[i];
        if (!l->active || done[i])
            continue;
        float alb[3], alb2[3];
        if (!f3_isequal(l->N, cl->Ng) && !(i == LOBE_DIFFUSE && cl->blender == SG_BLENDER_4)) {
            /* 4.x's specular and metal lobes share normal and roughness: one pass. */
            int also = -1;
            if (i == LOBE_SPECULAR && cl->lobe[LOBE_METAL].active) {
                also = LOBE_METAL;
                done[LOBE_METAL] = true;
            }
            lobe_albedo_quadrature(cl, i, also, alb, alb2);
            if (also >= 0)
                for (int c = 0; c < 3; c++)
                    albedo[c] += alb2[c];
        } else {
            lobe_albedo_uncut(cl, i, alb);
        }
        for (int c = 0; c < 3; c++)
            albedo[c] += alb[c];
    }
}

void principled_albedo(const principled_inputs *in, sg_blender_mode blender, float3 wo, float3 Ng,
                       float albedo[3])
{
    closures cl;
    principled_prepare(in, blender, wo, Ng, &cl);
    principled_closure_albedo(&cl, albedo);
}

void principled_albedo_uncut(const closures *cl, float albedo[3])
{
    albedo[0] = albedo[1] = albedo[2] = 0.0f;
    for (int i = 0; i < N_LOBES; i++) {
        if (!cl->lobe[i].active)
            continue;
        float alb[3];
        lobe_albedo_uncut(cl, i, alb);
        for (int c = 0; c < 3; c++)
            albedo[c] += alb[c];
    }
}

void principled_albedo_cut_estimate(const closures *cl, const float u[3], float cut[3])
{
    principled_albedo_cut_estimate_shared(cl, u, NULL, cut);
}

void principled_albedo_cut_estimate_shared(const closures *cl, const float u[3],
                                           const principled_sampled *sampled, float cut[3])
{
    cut[0] = cut[1] = cut[2] = 0.0f;
    if (!cl->bumped)
        return;
    /* Sample among the lobes with a density (singular lobes have none: their cut is
     * exact in lobe_albedo_uncut). */
    float total = 0.0f;
    for (int i = 0; i < N_LOBES; i++)
        if (cl->lobe[i].active && !cl->lobe[i].singular)
            total += cl->lobe[i].prob;
    if (!(total > 0.0f))
        return;
    int pick = -1;
    float acc = 0.0f;
    for (int i = 0; i < N_LOBES; i++) {
        if (!cl->lobe[i].active || cl->lobe[i].singular || !(cl->lobe[i].prob > 0.0f))
            continue;
        pick = i;
        acc += cl->lobe[i].prob;
        if (u[2] * total < acc)
            break;
    }
    if (pick < 0)
        return;
    float3 L;
    if (sampled && sampled->lobe == pick) {
        /* The same lobe at the same (u[0], u[1]): the same direction. */
        if (!sampled->raw_ok)
            return;
        L = sampled->raw;
    } else if (pick == LOBE_DIFFUSE) {
        L = diffuse_sample_direction(&cl->lobe[pick], u[0], u[1]);
    } else if (!microfacet_sample_direction(cl, &cl->lobe[pick], u[0], u[1], &L)) {
        return;
    }
    /* Above Ng and inside the lobes' hemisphere nothing differs from the tables but 3.x's
     * diffuse (its bump shadowing term): there the microfacet lobes' values are the
     * tables' integrands, and 4.x's diffuse is exact in its table. Most samples end
     * here. Above Ng but below the lobes' hemisphere Cycles' sampler still counts the
     * microfacet value (microfacet_sampled_value), which the tables leave out. */
    const bool above = f3_dot(cl->Ng, L) > 0.0f;
    const bool diffuse_3x = cl->blender == SG_BLENDER_3 && cl->lobe[LOBE_DIFFUSE].active;
    bool sampler_only = false;
    for (int i = 0; above && i < N_LOBES; i++)
        sampler_only |= below_lobe_hemisphere(cl, i, L);
    if (above && !diffuse_3x && !sampler_only)
        return;
    /* The mixture density of that sampling, wherever L points. */
    float q = 0.0f;
    for (int i = 0; i < N_LOBES; i++) {
        const lobe *l = &cl->lobe[i];
        if (!l->active || l->singular)
            continue;
        float p = i == LOBE_DIFFUSE ? fmaxf(f3_dot(l->N, L), 0.0f) / PI_F
                                    : microfacet_sample_pdf(cl, l, L);
        q += l->prob / total * p;
    }
    if (!(q > 0.0f))
        return;
    for (int i = 0; i < N_LOBES; i++) {
        const lobe *l = &cl->lobe[i];
        /* 4.x's diffuse table already includes the cut and the shadowing term; above Ng
         * only 3.x's diffuse differs from its uncut value. */
        if (!l->active || l->singular || (i == LOBE_DIFFUSE && cl->blender == SG_BLENDER_4) ||
            (above && i != LOBE_DIFFUSE && !below_lobe_hemisphere(cl, i, L)))
            continue;
        float f[3] = {0, 0, 0}, g[3], p;
        if (i == LOBE_DIFFUSE) {
            diffuse_eval(cl, l, L, &f[0], &p);
            diffuse_eval_uncut(cl, l, L, &g[0], &p);
            f[1] = f[2] = f[0];
            g[1] = g[2] = g[0];
        } else {
            /* Cycles' value: the sampler's above Ng (also below the lobe's hemisphere,
             * where the table has 0), nothing below. */
            if (above)
                microfacet_sampled_value(cl, l, L, f, &p);
            microfacet_eval_uncut(cl, l, L, g, &p);
        }
        for (int c = 0; c < 3; c++)
            cut[c] += l->weight[c] * (f[c] - g[c]) / q;
    }
}
