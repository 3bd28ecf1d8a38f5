/*
 * image_compare: error metrics of an image against a reference that may be the mean of two
 * independent halves (see imageio.h for the definitions).
 *
 * Everything is accumulated in double: a 2048 x 2048 image has 12.6 M terms, and float
 * sums would lose the small differences these metrics exist to measure. The pixel data
 * is checked for NaN and infinity first, so a broken render gives an error that says
 * where, rather than a NaN metric that says nothing.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "imageio/imageio.h"

enum { COMPARE_BLOCK = 16 };

/* Reference value of pixel i, channel c: a, or the mean of a and b. The mean is taken in
 * double, as the render-reference test does, so both agree to the last bit. */
static double reference_value(const image *ref_a, const image *ref_b, size_t i, int c)
{
    double a = ref_a->pixels[i * (size_t)ref_a->channels + (size_t)c];
    if (!ref_b)
        return a;
    return 0.5 * (a + ref_b->pixels[i * (size_t)ref_b->channels + (size_t)c]);
}

static double image_value(const image *img, size_t i, int c)
{
    return img->pixels[i * (size_t)img->channels + (size_t)c];
}

static int check_shape(const image *im, const char *name, const image *img, char *err,
                       size_t errlen)
{
    if (!im->pixels || im->width <= 0 || im->height <= 0) {
        snprintf(err, errlen, "the %s is empty (%d x %d)", name, im->width, im->height);
        return -1;
    }
    if (im->channels < 3) {
        snprintf(err, errlen, "the %s has %d channel%s; comparing needs RGB (3 or more)", name,
                 im->channels, im->channels == 1 ? "" : "s");
        return -1;
    }
    if (im != img && (im->width != img->width || im->height != img->height)) {
        snprintf(err, errlen,
                 "sizes differ: the image is %d x %d with %d channels, the %s %d x %d "
                 "with %d channels",
                 img->width, img->height, img->channels, name, im->width, im->height,
                 im->channels);
        return -1;
    }
    return 0;
}

/* The first NaN or infinite RGB value in scan order, named by pixel and channel. */
static int check_finite(const image *im, const char *name, char *err, size_t errlen)
{
    size_t n = (size_t)im->width * (size_t)im->height;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            float v = im->pixels[i * (size_t)im->channels + (size_t)c];
            if (!isfinite(v)) {
                snprintf(err, errlen, "the %s has %s at pixel (%zu, %zu) channel %d (%c)", name,
                         isnan(v) ? "NaN" : v > 0 ? "+inf" : "-inf", i % (size_t)im->width,
                         i / (size_t)im->width, c, "RGB"[c]);
                return -1;
            }
        }
    return 0;
}

/* The block measure of imageio.h, over whole blocks only. */
static void find_worst_block(const image *img, const image *ref_a, const image *ref_b,
                             double ref_mean, image_comparison *out)
{
    int w = img->width, h = img->height;
    out->worst_block = 0;
    out->worst_block_x = out->worst_block_y = -1;
    for (int by = 0; by + COMPARE_BLOCK <= h; by += COMPARE_BLOCK)
        for (int bx = 0; bx + COMPARE_BLOCK <= w; bx += COMPARE_BLOCK) {
            double diff = 0, ref = 0;
            for (int y = by; y < by + COMPARE_BLOCK; y++)
                for (int x = bx; x < bx + COMPARE_BLOCK; x++) {
                    size_t i = (size_t)y * (size_t)w + (size_t)x;
                    for (int c = 0; c < 3; c++) {
                        double r = reference_value(ref_a, ref_b, i, c);
                        diff += image_value(img, i, c) - r;
                        ref += r;
                    }
                }
            /* Both sums have 3 * 16 * 16 terms, so their ratio is the ratio of the
             * block means (taken as the test takes it, to agree to the last bit). A black
             * reference block has no scale of its own: the reference's overall mean
             * stands in for it. */
            double terms = 3.0 * COMPARE_BLOCK * COMPARE_BLOCK, rel = 0;
            if (ref != 0)
                rel = fabs(diff) / fabs(ref);
            else if (ref_mean != 0)
                rel = fabs(diff) / terms / fabs(ref_mean);
            if (out->worst_block_x < 0 || rel > out->worst_block) {
                out->worst_block = rel;
                out->worst_block_x = bx / COMPARE_BLOCK;
                out->worst_block_y = by / COMPARE_BLOCK;
            }
        }
}

int image_compare(const image *img, const image *ref_a, const image *ref_b,
                  image_comparison *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    const char *name_a = ref_b ? "reference A" : "reference";
    if (check_shape(img, "image", img, err, errlen) < 0 ||
        check_shape(ref_a, name_a, img, err, errlen) < 0 ||
        (ref_b && check_shape(ref_b, "reference B", img, err, errlen) < 0))
        return -1;
    if (check_finite(img, "image", err, errlen) < 0 ||
        check_finite(ref_a, name_a, err, errlen) < 0 ||
        (ref_b && check_finite(ref_b, "reference B", err, errlen) < 0))
        return -1;

    size_t n = (size_t)img->width * (size_t)img->height;
    double sum_img[3] = {0}, sum_ref[3] = {0}, sum_sq = 0, sum_abs = 0, sum_noise_sq = 0;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            double v = image_value(img, i, c), r = reference_value(ref_a, ref_b, i, c);
            double d = v - r;
            sum_img[c] += v;
            sum_ref[c] += r;
            sum_sq += d * d;
            sum_abs += fabs(d);
            if (ref_b) {
                /* (a - b) / 2 has the variance of the mean's noise, (s^2/2), when a and
                 * b are independent with equal noise s. */
                double half = 0.5 * ((double)ref_a->pixels[i * (size_t)ref_a->channels + (size_t)c] -
                                     ref_b->pixels[i * (size_t)ref_b->channels + (size_t)c]);
                sum_noise_sq += half * half;
            }
        }
    double terms = 3.0 * (double)n;
    out->ref_mean = (sum_ref[0] + sum_ref[1] + sum_ref[2]) / terms;
    out->rmse = sqrt(sum_sq / terms);
    out->mae = sum_abs / terms;
    for (int c = 0; c < 3; c++)
        out->bias[c] = sum_ref[c] != 0 ? (sum_img[c] - sum_ref[c]) / sum_ref[c] : 0;
    find_worst_block(img, ref_a, ref_b, out->ref_mean, out);
    out->has_b = ref_b != NULL;
    if (ref_b) {
        /* The squared error against a noisy reference is the error against the converged
         * image plus the reference's noise variance: subtract the latter. Clamped at 0,
         * as the estimate can undershoot when img is close to converged. */
        double noise_sq = sum_noise_sq / terms;
        out->ref_noise_rmse = sqrt(noise_sq);
        double excess = sum_sq / terms - noise_sq;
        out->rmse_converged = excess > 0 ? sqrt(excess) : 0;
    } else {
        out->ref_noise_rmse = out->rmse_converged = -1;
    }
    return 0;
}
