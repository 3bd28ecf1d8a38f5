/*
 * PLACEHOLDER: a plain Lambert BSDF (base colour / pi, cosine-weighted sampling)
 * standing in for the Principled BSDF so that the renderer can be built against
 * the interface of bsdf_principled.h. It ignores metallic, roughness, IOR and
 * the Blender version. The real implementation replaces this file.
 */
#include "render/bsdf_principled.h"

#include <math.h>

void principled_inputs_default(principled_inputs *in)
{
    in->base_color[0] = in->base_color[1] = in->base_color[2] = 0.8f;
    in->metallic = 0.0f;
    in->roughness = 0.5f;
    in->ior = 1.5f;
    in->specular_ior_level = 0.5f;
    in->specular_tint[0] = in->specular_tint[1] = in->specular_tint[2] = 1.0f;
    in->alpha = 1.0f;
    in->N[0] = 0.0f;
    in->N[1] = 0.0f;
    in->N[2] = 1.0f;
}

static float dot3(const float a[3], const float b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

void principled_eval(const principled_inputs *in, int blender, const float wo[3],
                     const float wi[3], const float Ng[3], float f_cos[3], float *pdf)
{
    (void)blender;
    float cos_i = dot3(wi, in->N);
    if (cos_i <= 0.0f || dot3(wo, Ng) <= 0.0f || dot3(wi, Ng) <= 0.0f) {
        f_cos[0] = f_cos[1] = f_cos[2] = 0.0f;
        *pdf = 0.0f;
        return;
    }
    for (int c = 0; c < 3; c++)
        f_cos[c] = in->base_color[c] * cos_i / (float)M_PI;
    *pdf = cos_i / (float)M_PI;
}

int principled_sample(const principled_inputs *in, int blender, const float wo[3],
                      const float Ng[3], const float u[3], float wi[3], float f_cos[3],
                      float *pdf)
{
    const float *n = in->N;
    /* Duff et al.'s branchless orthonormal basis around n. */
    float sign = copysignf(1.0f, n[2]);
    float a = -1.0f / (sign + n[2]);
    float b = n[0] * n[1] * a;
    float t[3] = {1.0f + sign * n[0] * n[0] * a, sign * b, -sign * n[0]};
    float s[3] = {b, sign + n[1] * n[1] * a, -n[1]};
    float r = sqrtf(u[0]), phi = 2.0f * (float)M_PI * u[1];
    float x = r * cosf(phi), y = r * sinf(phi), z = sqrtf(fmaxf(0.0f, 1.0f - u[0]));
    for (int c = 0; c < 3; c++)
        wi[c] = x * t[c] + y * s[c] + z * n[c];
    principled_eval(in, blender, wo, wi, Ng, f_cos, pdf);
    return *pdf > 0.0f;
}

void principled_albedo(const principled_inputs *in, int blender, const float wo[3],
                       const float Ng[3], float albedo[3])
{
    (void)blender;
    (void)Ng;
    float ok = dot3(wo, in->N) > 0.0f ? 1.0f : 0.0f;
    for (int c = 0; c < 3; c++)
        albedo[c] = in->base_color[c] * ok;
}
