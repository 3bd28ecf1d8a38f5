/*
 * The fractals of the Noise Texture: fBM, multifractal, hybrid and ridged multifractal
 * and hetero terrain, as Cycles' kernel/svm/fractal_noise.h of Blender 4.3 computes them,
 * and, for SG_BLENDER_3, 3.4's fractal_noise.h (the Noise Texture's fBM) and musgrave.h
 * (the Musgrave Texture that blender/compat_noise.py builds for everything else).
 *
 * Cycles' loops call the noise octave by octave. Here a fractal first lays out its
 * octaves' points exactly as Cycles steps them (fractal_layout, layout_points), has
 * their Perlin noise computed together (noise_mode.perlin_many), then combines the
 * values in Cycles' order (fractal_value). Octaves Cycles would skip (the hybrid's
 * early exit) may be computed and left unused. Lacunarity is therefore no parameter of
 * the combining functions: it has placed the points already, and t[i] holds the
 * unscaled noise at octave i.
 */
#include <math.h>
#include <stdbool.h>

#include "shadergraph/kernels/noise.h"

/* ---- Blender 4.x (fractal_noise.h) ------------------------------------------------ */

static float noise_fbm(const noise_mode *m, const float *t, float detail, float roughness,
                       bool normalize)
{
    int n = (int)detail;
    float rmd = detail - floorf(detail);

    float amp = 1.0f, maxamp = 0.0f, sum = 0.0f;
    for (int i = 0; i <= n; i++) {
        sum = madd(m->scale * t[i], amp, sum);
        maxamp += amp;
        amp *= roughness;
    }
    if (rmd != 0.0f) {
        float sum2 = madd(m->scale * t[n + 1], amp, sum);
        if (normalize)
            return mix_fused(0.5f * sum / maxamp + 0.5f, 0.5f * sum2 / (maxamp + amp) + 0.5f, rmd);
        return mix_fused(sum, sum2, rmd);
    }
    return normalize ? 0.5f * sum / maxamp + 0.5f : sum;
}

/* ---- Blender 3.4's Noise Texture fBM (fractal_noise.h of 3.4) --------------------- */

static float fractal_noise(const noise_mode *m, const float *t, float octaves, float roughness)
{
    octaves = clampf(octaves, 0.0f, 15.0f);
    roughness = clampf(roughness, 0.0f, 1.0f);
    int n = (int)octaves;
    float rmd = octaves - floorf(octaves);

    /* Sums the unsigned noise 0.5 * snoise + 0.5 (fused). */
    float amp = 1.0f, maxamp = 0.0f, sum = 0.0f;
    for (int i = 0; i <= n; i++) {
        sum = madd(madd(0.5f, m->scale * t[i], 0.5f), amp, sum);
        maxamp += amp;
        amp *= roughness;
    }
    if (rmd != 0.0f) {
        float sum2 = madd(madd(0.5f, m->scale * t[n + 1], 0.5f), amp, sum);
        sum /= maxamp;
        sum2 /= maxamp + amp;
        return madd(rmd, sum2, (1.0f - rmd) * sum);
    }
    return sum / maxamp;
}

/* ---- Blender 3.4's Musgrave Texture fBM (musgrave.h of 3.4) ---------------------- */

static float noise_musgrave_fBm(const noise_mode *m, const float *t, float H, float lacunarity,
                                float octaves)
{
    int n = (int)octaves;
    float value = 0.0f, pwr = 1.0f, pwHL = powf(lacunarity, -H);
    for (int i = 0; i < n; i++) {
        value = madd(m->scale * t[i], pwr, value);
        pwr *= pwHL;
    }
    float rmd = octaves - floorf(octaves);
    if (rmd != 0.0f)
        value = madd(rmd * (m->scale * t[n]), pwr, value);
    return value;
}

/* ---- both versions ---------------------------------------------------------------- */

/* The multifractals of both versions. Blender 4.1 turned 3.4's Musgrave Texture into
 * these by versioning: Detail = Musgrave Detail - 1, Roughness = Lacunarity^-Dimension.
 * Both loops are the same function of `whole`, the number of whole octaves (4.x:
 * Detail + 1; 3.4: the Musgrave's Detail), `rmd`, the weight of the fractional octave
 * t[whole], and `rough`, the amplitude factor from octave to octave (4.x: Roughness;
 * 3.4: Lacunarity^-H). */

static float noise_multi_fractal(const noise_mode *m, const float *t, int whole, float rmd,
                                 float rough)
{
    float value = 1.0f, pwr = 1.0f;
    for (int i = 0; i < whole; i++) {
        value *= madd(pwr, m->scale * t[i], 1.0f);
        pwr *= rough;
    }
    if (rmd != 0.0f)
        value *= madd(rmd * pwr, m->scale * t[whole], 1.0f);
    return value;
}

static float noise_hetero_terrain(const noise_mode *m, const float *t, int whole, float rmd,
                                  float rough, float offset)
{
    /* The first octave is unscaled, and evaluated even with no whole octave; later ones
     * are scaled by the value so far. In snoise + offset the noise's scaling product
     * fuses into the sum. */
    float pwr = rough;
    float value = madd(m->scale, t[0], offset);
    for (int i = 1; i < whole; i++) {
        float increment = madd(m->scale, t[i], offset) * pwr;
        value = madd(increment, value, value);
        pwr *= rough;
    }
    if (rmd != 0.0f) {
        float increment = madd(m->scale, t[whole < 1 ? 1 : whole], offset) * pwr * value;
        value = madd(rmd, increment, value);
    }
    return value;
}

static float noise_hybrid_multi_fractal(const noise_mode *m, const float *t, int whole,
                                        float rmd, float rough, float offset, float gain)
{
    float pwr = 1.0f, value = 0.0f, weight = 1.0f;
    for (int i = 0; weight > 0.001f && i < whole; i++) {
        if (weight > 1.0f)
            weight = 1.0f;
        float signal = madd(m->scale, t[i], offset) * pwr;
        pwr *= rough;
        value = madd(weight, signal, value);
        weight *= gain * signal;
    }
    if (rmd != 0.0f && weight > 0.001f) {
        if (weight > 1.0f)
            weight = 1.0f;
        float signal = madd(m->scale, t[whole], offset) * pwr;
        value = madd(rmd * weight, signal, value);
    }
    return value;
}

/* No fractional octave; the first octave is evaluated even with no whole one. */
static float noise_ridged_multi_fractal(const noise_mode *m, const float *t, int whole,
                                        float rough, float offset, float gain)
{
    float pwr = rough;
    float signal = offset - fabsf(m->scale * t[0]);
    signal *= signal;
    float value = signal, weight = 1.0f;
    for (int i = 1; i < whole; i++) {
        weight = clampf(signal * gain, 0.0f, 1.0f);
        signal = offset - fabsf(m->scale * t[i]);
        signal *= signal;
        signal *= weight;
        value = madd(signal, pwr, value);
        pwr *= rough;
    }
    return value;
}

/* The node's fractal from the Perlin values t of its octave points. */
float fractal_value(const noise_node *nn, const noise_inputs *in, const float *t)
{
    const noise_mode *m = &nn->mode;
    if (!m->blender3 && nn->type == TYPE_FBM)
        return noise_fbm(m, t, in->detail, in->roughness, nn->normalize);
    if (m->blender3 && !nn->as_musgrave)
        return fractal_noise(m, t, in->detail, in->roughness);
    if (m->blender3 && nn->type == TYPE_FBM)
        return noise_musgrave_fBm(m, t, in->musgrave_H, in->musgrave_lacunarity,
                                  in->musgrave_octaves);

    float octaves = m->blender3 ? in->musgrave_octaves : in->detail;
    int whole = (int)octaves + (m->blender3 ? 0 : 1);
    float rmd = octaves - floorf(octaves);
    float rough = m->blender3 ? powf(in->musgrave_lacunarity, -in->musgrave_H) : in->roughness;
    switch (nn->type) {
    case TYPE_MULTIFRACTAL: return noise_multi_fractal(m, t, whole, rmd, rough);
    case TYPE_RIDGED:
        return noise_ridged_multi_fractal(m, t, whole, rough, in->offset, in->gain);
    case TYPE_HYBRID:
        return noise_hybrid_multi_fractal(m, t, whole, rmd, rough, in->offset, in->gain);
    default: return noise_hetero_terrain(m, t, whole, rmd, rough, in->offset);
    }
}

/* ---- LANES points at once --------------------------------------------------------- */

/* noise_fbm (4.x) or fractal_noise (3.x's Noise Texture) of every lane at once, from the
 * Perlin values t[i] of octaves i < most: lane k sums its own octaves i <= n_k with the
 * scalar code's operations and takes its fractional octave from t[n_k + 1]; both
 * endings are computed and each lane keeps the one its Detail selects. */
void lane_fbm(const noise_node *nn, const noise_inputs *in, const lane_f *t, int most,
              lane_f *value)
{
    const noise_mode *m = &nn->mode;
    lane_i n;
    lane_f rmd, roughness;
    for (int k = 0; k < LANES; k++) {
        /* The clamps fractal_noise applies (4.x's were applied on reading). */
        float octaves = m->blender3 ? clampf(in[k].detail, 0.0f, 15.0f) : in[k].detail;
        roughness[k] = m->blender3 ? clampf(in[k].roughness, 0.0f, 1.0f) : in[k].roughness;
        n[k] = (int)octaves;
        rmd[k] = octaves - floorf(octaves);
    }

    lane_f amp = lane_splat(1.0f), maxamp = lane_splat(0.0f), sum = lane_splat(0.0f);
    lane_f next = lane_splat(0.0f); /* the fractional octave's term */
    /* Octaves every lane sums need no masks (usually all of them: Detail is constant). */
    int fewest = n[0];
    for (int k = 1; k < LANES; k++)
        fewest = n[k] < fewest ? n[k] : fewest;
    int i = 0;
    for (; i <= fewest && i < most; i++) {
        lane_f v = m->scale * t[i];
        if (m->blender3)
            v = lane_madd(lane_splat(0.5f), v, lane_splat(0.5f));
        sum = lane_madd(v, amp, sum);
        maxamp = maxamp + amp;
        amp = amp * roughness;
    }
    for (; i < most; i++) {
        lane_f v = m->scale * t[i];
        if (m->blender3)
            v = lane_madd(lane_splat(0.5f), v, lane_splat(0.5f)); /* unsigned noise */
        lane_u summed = (lane_u)(n >= i);
        next = lane_select((lane_u)(n + 1 == i), v, next);
        sum = lane_select(summed, lane_madd(v, amp, sum), sum);
        maxamp = lane_select(summed, maxamp + amp, maxamp);
        amp = lane_select(summed, amp * roughness, amp);
    }

    lane_f sum2 = lane_madd(next, amp, sum), whole, with_fraction;
    if (m->blender3) {
        whole = sum / maxamp;
        with_fraction = lane_madd(rmd, sum2 / (maxamp + amp), (1.0f - rmd) * whole);
    } else if (nn->normalize) {
        whole = 0.5f * sum / maxamp + 0.5f;
        lane_f part = 0.5f * sum2 / (maxamp + amp) + 0.5f;
        with_fraction = lane_madd(rmd, part - whole, whole);
    } else {
        whole = sum;
        with_fraction = lane_madd(rmd, sum2 - sum, sum);
    }
    *value = lane_select((lane_u)(rmd != 0.0f), with_fraction, whole);
}

