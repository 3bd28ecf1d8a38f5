/*
 * Colour-space conversions as Cycles' node kernels do them (Cycles util/color.h), shared
 * by kernels/color.c (Mix's HUE/SATURATION/VALUE/COLOR blends) and kernels/convert.c
 * (Combine/Separate Color in HSV and HSL). Internal to shadergraph.
 *
 * These are not Blender's BLI conversions (those, used when Blender bakes a colour ramp,
 * live in color.c): the formulas differ, and so do the results outside [0, 1]. Nothing
 * here wraps or clamps a hue: a hue of 1.3 or -0.2 goes through hsv_to_rgb's sextant
 * selection as Cycles lets it (any sextant index other than 0..4 takes the last branch).
 */
#ifndef IMSYNTH_KERNEL_COLOR_UTIL_H
#define IMSYNTH_KERNEL_COLOR_UTIL_H

#include <math.h>

#include "shadergraph/kernels/kernel_util.h"

static inline float3 rgb_to_hsv(float3 rgb)
{
    float cmax = fmaxf(rgb.x, fmaxf(rgb.y, rgb.z));
    float cmin = minf(rgb.x, minf(rgb.y, rgb.z));
    float cdelta = cmax - cmin;
    float h = 0.0f, s = 0.0f, v = cmax;

    if (cmax != 0.0f)
        s = cdelta / cmax;
    if (s != 0.0f) {
        /* Distance of each channel below the maximum, in units of the chroma. */
        float cr = (cmax - rgb.x) / cdelta;
        float cg = (cmax - rgb.y) / cdelta;
        float cb = (cmax - rgb.z) / cdelta;
        if (rgb.x == cmax)
            h = cb - cg;
        else if (rgb.y == cmax)
            h = 2.0f + cr - cb;
        else
            h = 4.0f + cg - cr;
        h /= 6.0f;
        if (h < 0.0f)
            h += 1.0f;
    }
    return make_float3(h, s, v);
}

static inline float3 hsv_to_rgb(float3 hsv)
{
    float h = hsv.x, s = hsv.y, v = hsv.z;
    if (s == 0.0f)
        return make_float3(v, v, v);
    if (h == 1.0f)
        h = 0.0f;
    h *= 6.0f;
    float sextant = floorf(h);
    float f = h - sextant;
    float p = v * (1.0f - s);
    float q = v * (1.0f - (s * f));
    float t = v * (1.0f - (s * (1.0f - f)));
    if (sextant == 0.0f)
        return make_float3(v, t, p);
    if (sextant == 1.0f)
        return make_float3(q, v, p);
    if (sextant == 2.0f)
        return make_float3(p, v, t);
    if (sextant == 3.0f)
        return make_float3(p, q, v);
    if (sextant == 4.0f)
        return make_float3(t, p, v);
    return make_float3(v, p, q);
}

static inline float3 rgb_to_hsl(float3 rgb)
{
    float cmax = fmaxf(rgb.x, fmaxf(rgb.y, rgb.z));
    float cmin = minf(rgb.x, minf(rgb.y, rgb.z));
    float l = minf(1.0f, (cmax + cmin) / 2.0f);
    float h = 0.0f, s = 0.0f;

    if (cmax != cmin) {
        float cdelta = cmax - cmin;
        s = l > 0.5f ? cdelta / (2.0f - cmax - cmin) : cdelta / (cmax + cmin);
        if (cmax == rgb.x)
            h = (rgb.y - rgb.z) / cdelta + (rgb.y < rgb.z ? 6.0f : 0.0f);
        else if (cmax == rgb.y)
            h = (rgb.z - rgb.x) / cdelta + 2.0f;
        else
            h = (rgb.x - rgb.y) / cdelta + 4.0f;
    }
    h /= 6.0f;
    return make_float3(h, s, l);
}

static inline float3 hsl_to_rgb(float3 hsl)
{
    float h = hsl.x, s = hsl.y, l = hsl.z;
    float nr = saturatef(fabsf(h * 6.0f - 3.0f) - 1.0f);
    float ng = saturatef(2.0f - fabsf(h * 6.0f - 2.0f));
    float nb = saturatef(2.0f - fabsf(h * 6.0f - 4.0f));
    float chroma = (1.0f - fabsf(2.0f * l - 1.0f)) * s;
    return make_float3((nr - 0.5f) * chroma + l, (ng - 0.5f) * chroma + l, (nb - 0.5f) * chroma + l);
}

#endif
