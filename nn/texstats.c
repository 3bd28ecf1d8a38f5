/*
 * Texture statistics: a few dozen numbers that say directly what the Gram descriptor says
 * only through thousands of correlated values (EVALUATION.md, session 15): the colours at
 * the dark and bright ends of the image, how saturated it is, at which scales its detail
 * lies and whether that detail runs along rows or columns. The predictor reads them beside
 * the descriptor's principal components, where a hue or a pattern's scale is one number
 * instead of a direction the PCA spread over many components.
 *
 * Input: an encoded RGB image (sRGB transfer, values in [0, 1]), HWC. Every statistic is a
 * pure function of the pixels, summed in a fixed order (no threads), so equal images give
 * equal bits. Layout of out (TEXSTATS_N floats):
 *
 *   [ 0, 15)  per channel R, G, B: percentiles 5, 25, 50, 75, 95
 *   [15, 24)  per tone group (darkest quarter, middle half, brightest quarter by luma):
 *             mean luma, mean red-green opponent, mean yellow-blue opponent
 *   [24, 26)  chroma (|opponents|): mean and 90th percentile
 *   [26, 27)  luma: 99.5th percentile (highlights)
 *   [27, 33)  log band energy of a 2x box pyramid of luma, finest band first: level l's
 *             mean squared difference from the next coarser level, the last entry the
 *             coarsest level's variance
 *   [33, 34)  log variance of luma
 *   [34, 38)  log ratio of horizontal to vertical neighbour differences at pyramid levels
 *             0..3 (> 0: detail changes along rows more, e.g. vertical boards)
 */
#include "nn.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define HIST_BINS 4096
#define PYRAMID_LEVELS 6
#define ENERGY_FLOOR 1e-7

/* Rec. 709 luma weights, applied to the encoded channels (a perceptual grey). */
static float luma(const float *rgb) { return 0.2126f * rgb[0] + 0.7152f * rgb[1] + 0.0722f * rgb[2]; }

static int hist_bin(float v)
{
    int b = (int)(v * HIST_BINS);
    return b < 0 ? 0 : b >= HIST_BINS ? HIST_BINS - 1 : b;
}

/* The value below which a fraction q of the histogram's n counts lie, interpolated inside
 * its bin (values in [0, 1]). */
static float hist_percentile(const unsigned *hist, size_t n, double q)
{
    double want = q * (double)n, seen = 0;
    for (int b = 0; b < HIST_BINS; b++) {
        if (hist[b] && seen + hist[b] >= want) {
            double frac = (want - seen) / hist[b];
            return (float)((b + frac) / HIST_BINS);
        }
        seen += hist[b];
    }
    return 1.0f;
}

/* The four pyramid-based statistics of one luma level (w x h) and its 2x box reduction
 * (w/2 x h/2, written to next): returns the band energy; *ex and *ey get the mean squared
 * horizontal and vertical neighbour differences of this level. */
static double pyramid_level(const float *y, int w, int h, float *next, double *ex, double *ey)
{
    int w2 = w / 2, h2 = h / 2;
    for (int j = 0; j < h2; j++)
        for (int i = 0; i < w2; i++) {
            const float *p = y + (size_t)(2 * j) * (size_t)w + (size_t)(2 * i);
            next[(size_t)j * (size_t)w2 + (size_t)i] = 0.25f * (p[0] + p[1] + p[w] + p[w + 1]);
        }
    double band = 0, sx = 0, sy = 0;
    for (int j = 0; j < 2 * h2; j++)
        for (int i = 0; i < 2 * w2; i++) {
            double d = y[(size_t)j * (size_t)w + (size_t)i] -
                       next[(size_t)(j / 2) * (size_t)w2 + (size_t)(i / 2)];
            band += d * d;
        }
    for (int j = 0; j < h; j++)
        for (int i = 0; i + 1 < w; i++) {
            double d = y[(size_t)j * (size_t)w + (size_t)i + 1] - y[(size_t)j * (size_t)w + (size_t)i];
            sx += d * d;
        }
    for (int j = 0; j + 1 < h; j++)
        for (int i = 0; i < w; i++) {
            double d = y[(size_t)(j + 1) * (size_t)w + (size_t)i] - y[(size_t)j * (size_t)w + (size_t)i];
            sy += d * d;
        }
    *ex = sx / ((double)h * (w - 1));
    *ey = sy / ((double)(h - 1) * w);
    return band / (4.0 * w2 * h2);
}

static double variance(const float *v, size_t n)
{
    double s = 0, ss = 0;
    for (size_t i = 0; i < n; i++)
        s += v[i];
    double m = s / (double)n;
    for (size_t i = 0; i < n; i++)
        ss += (v[i] - m) * (v[i] - m);
    return ss / (double)n;
}

int texstats_forward(float *out, const float *rgb, int w, int h)
{
    // the coarsest level (1/32 of a side) needs at least 2 x 2 pixels for a variance
    if (w < (2 << (PYRAMID_LEVELS - 1)) || h < (2 << (PYRAMID_LEVELS - 1)))
        return -1;
    size_t n = (size_t)w * (size_t)h;
    unsigned *hist = calloc(5 * HIST_BINS, sizeof *hist); /* R, G, B, luma, chroma */
    float *y = malloc(n * sizeof *y), *next = malloc((n / 4 + 1) * sizeof *next);
    float *tmp = malloc((n / 4 + 1) * sizeof *tmp);
    if (!hist || !y || !next || !tmp) {
        free(hist);
        free(y);
        free(next);
        free(tmp);
        return -1;
    }
    double chroma_sum = 0;
    for (size_t p = 0; p < n; p++) {
        const float *c = rgb + 3 * p;
        for (int ch = 0; ch < 3; ch++)
            hist[ch * HIST_BINS + hist_bin(c[ch])]++;
        y[p] = luma(c);
        hist[3 * HIST_BINS + hist_bin(y[p])]++;
        float rg = c[0] - c[1], yb = 0.5f * (c[0] + c[1]) - c[2];
        float chroma = sqrtf(rg * rg + yb * yb);
        chroma_sum += chroma;
        hist[4 * HIST_BINS + hist_bin(chroma)]++;
    }
    static const double q[5] = {0.05, 0.25, 0.5, 0.75, 0.95};
    for (int ch = 0; ch < 3; ch++)
        for (int i = 0; i < 5; i++)
            out[ch * 5 + i] = hist_percentile(hist + ch * HIST_BINS, n, q[i]);

    // tone groups split at luma's quartiles; a pixel on a boundary goes to the lower group.
    // sum[3] is the whole image's, which an empty group (a flat image's) takes
    float lo = hist_percentile(hist + 3 * HIST_BINS, n, 0.25);
    float hi = hist_percentile(hist + 3 * HIST_BINS, n, 0.75);
    double sum[4][3] = {{0}}, count[4] = {0};
    for (size_t p = 0; p < n; p++) {
        const float *c = rgb + 3 * p;
        double v[3] = {y[p], c[0] - c[1], 0.5 * (c[0] + c[1]) - c[2]};
        int g = y[p] <= lo ? 0 : y[p] <= hi ? 1 : 2;
        for (int i = 0; i < 3; i++) {
            sum[g][i] += v[i];
            sum[3][i] += v[i];
        }
        count[g]++;
        count[3]++;
    }
    for (int g = 0; g < 3; g++) {
        int from = count[g] ? g : 3;
        for (int i = 0; i < 3; i++)
            out[15 + 3 * g + i] = (float)(sum[from][i] / count[from]);
    }
    out[24] = (float)(chroma_sum / (double)n);
    out[25] = hist_percentile(hist + 4 * HIST_BINS, n, 0.9);
    out[26] = hist_percentile(hist + 3 * HIST_BINS, n, 0.995);

    // bands of levels 0..4, then level 5's own variance (7 x 7 for a 224 crop); each
    // reduced level is copied to tmp to be the next one's input
    const float *level = y;
    int lw = w, lh = h;
    for (int l = 0; l + 1 < PYRAMID_LEVELS; l++) {
        double ex, ey;
        double band = pyramid_level(level, lw, lh, next, &ex, &ey);
        out[27 + l] = (float)log(band + ENERGY_FLOOR);
        if (l < 4)
            out[34 + l] = (float)log((ex + ENERGY_FLOOR) / (ey + ENERGY_FLOOR));
        lw /= 2;
        lh /= 2;
        memcpy(tmp, next, (size_t)lw * (size_t)lh * sizeof *tmp);
        level = tmp;
    }
    out[27 + PYRAMID_LEVELS - 1] = (float)log(variance(level, (size_t)lw * (size_t)lh) + ENERGY_FLOOR);
    out[33] = (float)log(variance(y, n) + ENERGY_FLOOR);
    free(hist);
    free(y);
    free(next);
    free(tmp);
    return 0;
}
