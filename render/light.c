/*
 * Blender's point light with a radius, as Cycles 3.4 and 4.3 treat it.
 *
 * Facing disk (3.4 always; 4.3 with Soft Falloff, Blender's default): a disk of radius r
 * at the light's centre whose normal points at the shading point. Sampled uniformly by
 * area, so the solid-angle pdf is (1 / (pi r^2)) * t^2 / cos, cos between the disk normal
 * and the direction back to the shading point. A ray hits it where it crosses that disk.
 *
 * Sphere (4.3 with Soft Falloff off): the cone the sphere subtends, sampled uniformly.
 *
 * Either way the radiance is the same constant (render_internal.h), which is what makes
 * next-event estimation and BSDF sampling two estimators of one integral, combined with
 * MIS in integrator.c.
 */
#include "render/render_internal.h"

/* The unit direction n from the light's centre to P, and their distance. */
static float3 disk_frame(const point_light *l, float3 P, float *dist)
{
    return f3_normalize_len(f3_sub(P, l->position), dist);
}

int point_light_sample(const point_light *l, float3 P, float u, float v, light_sample *out)
{
    float d;
    float3 n = disk_frame(l, P, &d);
    if (d <= l->radius || l->radius <= 0.0f)
        return 0; /* inside the light: not a case of this scene */
    if (l->sphere) {
        float sin2 = (l->radius * l->radius) / (d * d);
        float cos_max = sqrtf(fmaxf(0.0f, 1.0f - sin2));
        float cos_t = 1.0f - u * (1.0f - cos_max);
        float sin_t = sqrtf(fmaxf(0.0f, 1.0f - cos_t * cos_t));
        float phi = 2.0f * (float)M_PI * v;
        float3 a, b, axis = f3_neg(n);
        render_make_orthonormals(axis, &a, &b);
        out->wi = f3_add(f3_add(f3_scale(a, sin_t * cosf(phi)), f3_scale(b, sin_t * sinf(phi))),
                         f3_scale(axis, cos_t));
        /* Distance to the sphere's near side along wi (law of cosines). */
        out->t = d * cos_t - sqrtf(fmaxf(0.0f, l->radius * l->radius - d * d * sin_t * sin_t));
        out->pdf = 1.0f / (2.0f * (float)M_PI * (1.0f - cos_max));
        return 1;
    }
    /* Uniform point in the unit disk (Shirley-Chiu concentric map: area preserving). */
    float sx = 2.0f * u - 1.0f, sy = 2.0f * v - 1.0f, r, phi;
    if (sx == 0.0f && sy == 0.0f) {
        r = 0.0f, phi = 0.0f;
    } else if (fabsf(sx) > fabsf(sy)) {
        r = sx, phi = (float)M_PI / 4.0f * (sy / sx);
    } else {
        r = sy, phi = (float)M_PI / 2.0f - (float)M_PI / 4.0f * (sx / sy);
    }
    float3 a, b;
    render_make_orthonormals(n, &a, &b);
    float3 offset = f3_scale(f3_add(f3_scale(a, cosf(phi)), f3_scale(b, sinf(phi))), l->radius * r);
    out->wi = f3_normalize_len(f3_sub(f3_add(l->position, offset), P), &out->t);
    float cos_l = -f3_dot(n, out->wi);
    if (cos_l <= 0.0f)
        return 0;
    out->pdf = out->t * out->t / (cos_l * (float)M_PI * l->radius * l->radius);
    return 1;
}

int point_light_intersect(const point_light *l, float3 P, float3 wi, float *t, float *pdf)
{
    float d;
    float3 n = disk_frame(l, P, &d);
    if (d <= l->radius || l->radius <= 0.0f)
        return 0;
    if (l->sphere) {
        float3 oc = f3_sub(P, l->position);
        float bq = f3_dot(oc, wi), c = f3_dot(oc, oc) - l->radius * l->radius;
        float disc = bq * bq - c;
        if (disc < 0.0f)
            return 0;
        float th = -bq - sqrtf(disc);
        if (th <= 0.0f)
            return 0;
        float sin2 = (l->radius * l->radius) / (d * d);
        float cos_max = sqrtf(fmaxf(0.0f, 1.0f - sin2));
        *t = th;
        *pdf = 1.0f / (2.0f * (float)M_PI * (1.0f - cos_max));
        return 1;
    }
    /* The disk through the centre with normal n (towards P): P + t wi meets its plane at
     * t = d / cos, cos = -n.wi; inside when within r of the centre. */
    float cos_l = -f3_dot(n, wi);
    if (cos_l <= 0.0f)
        return 0;
    float th = d / cos_l;
    float3 q = f3_sub(f3_add(P, f3_scale(wi, th)), l->position);
    if (f3_dot(q, q) >= l->radius * l->radius)
        return 0;
    *t = th;
    *pdf = th * th / (cos_l * (float)M_PI * l->radius * l->radius);
    return 1;
}
