/* The evaluation's arithmetic (pipeline.h, "evaluation"): distances between descriptors and
 * images, the floor's normalisation, quantiles, R^2, spread and correlation. Kept apart from evaluate.c
 * (which drives the predictor and the renderer) so that each piece is tested on known
 * values, and so that a benchmark can link it alone. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline/pipeline_internal.h"

double evaluate_gram_distance(const float *a, const float *b, const size_t *offsets,
                              int n_layers)
{
    if (n_layers <= 0)
        return NAN;
    double sum = 0.0;
    for (int l = 0; l < n_layers; l++) {
        double diff = 0.0, na = 0.0, nb = 0.0;
        for (size_t i = offsets[l]; i < offsets[l + 1]; i++) {
            double x = a[i], y = b[i];
            diff += (x - y) * (x - y);
            na += x * x;
            nb += y * y;
        }
        /* Triangle inequality: ||a - b|| <= ||a|| + ||b||, so each term is in [0, 1]. */
        sum += sqrt(diff) / (sqrt(na) + sqrt(nb) + 1e-12);
    }
    return sum / n_layers;
}

enum { CROP = PIPELINE_CROP, GRID = 32, BOX = CROP / GRID };
_Static_assert(GRID * BOX == CROP, "the grid's boxes tile the crop");

/* The 32 x 32 x 3 box averages of img's centre crop, clamped to [0, 1]. */
static void box_averages(const image *img, double out[GRID * GRID * 3])
{
    int x0 = (img->width - CROP) / 2, y0 = (img->height - CROP) / 2;
    size_t nc = (size_t)img->channels;
    memset(out, 0, sizeof(double) * GRID * GRID * 3);
    for (int y = 0; y < CROP; y++)
        for (int x = 0; x < CROP; x++) {
            const float *px =
                img->pixels + ((size_t)(y0 + y) * (size_t)img->width + (size_t)(x0 + x)) * nc;
            double *box = out + ((size_t)(y / BOX) * GRID + (size_t)(x / BOX)) * 3;
            for (int c = 0; c < 3; c++) {
                float v = px[nc >= 3 ? (size_t)c : 0];
                box[c] += v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; /* NaN counts 0 */
            }
        }
    for (int i = 0; i < GRID * GRID * 3; i++)
        out[i] /= BOX * BOX;
}

static int cmp_double(const void *pa, const void *pb);

/* Both images' box averages into avg (2 x GRID x GRID x 3, a's first): 0, or -1 with a
 * message when an image is too small or has two channels. */
static int box_averages_of_pair(const image *a, const image *b, double *avg, char *err,
                                size_t errlen)
{
    const image *im[2] = {a, b};
    for (int k = 0; k < 2; k++)
        if (im[k]->width < CROP || im[k]->height < CROP ||
            (im[k]->channels != 1 && im[k]->channels < 3))
            return pipeline_error(err, errlen,
                                  "colour distance: image %d is %d x %d with %d channels; needs "
                                  "at least %d x %d, grey or RGB(A)",
                                  k + 1, im[k]->width, im[k]->height, im[k]->channels, CROP, CROP);
    box_averages(a, avg);
    box_averages(b, avg + GRID * GRID * 3);
    return 0;
}

int evaluate_colour_distance(const image *a, const image *b, double *out, char *err,
                             size_t errlen)
{
    double *avg = malloc(sizeof(double) * GRID * GRID * 3 * 2);
    if (!avg)
        return pipeline_error(err, errlen, "out of memory");
    if (box_averages_of_pair(a, b, avg, err, errlen)) {
        free(avg);
        return -1;
    }
    double sum = 0.0;
    for (int i = 0; i < GRID * GRID * 3; i++)
        sum += fabs(avg[i] - avg[GRID * GRID * 3 + i]);
    free(avg);
    *out = sum / (GRID * GRID * 3);
    return 0;
}

const char *const pipeline_colour_term_names[PIPELINE_N_COLOUR_TERMS] = {"blocks", "sorted"};

/* The sorted term's directions in RGB: the three channels, and half the difference of each
 * pair, so that a colour's hue is compared and not only its channels one at a time (boxes
 * of blue lines can match the channels of boxes of white highlight beside dark wood, not
 * their differences). Over the six, each channel's weights add up to 2 in absolute value
 * (1 alone, 1/2 in each of its two differences): paired box by box instead of sorted, the
 * average over directions is at most evaluate_colour_distance, and sorting, the optimal
 * pairing, can only lower each direction's. */
static const double sorted_directions[6][3] = {
    {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.5, -0.5, 0}, {0, 0.5, -0.5}, {-0.5, 0, 0.5},
};

int evaluate_colour_sorted_distance(const image *a, const image *b, double *out, char *err,
                                    size_t errlen)
{
    enum { N = GRID * GRID, N_DIR = sizeof sorted_directions / sizeof sorted_directions[0] };
    double *avg = malloc(sizeof(double) * N * 3 * 2), *v = malloc(sizeof(double) * N * 2);
    if (!avg || !v) {
        free(avg);
        free(v);
        return pipeline_error(err, errlen, "out of memory");
    }
    if (box_averages_of_pair(a, b, avg, err, errlen)) {
        free(avg);
        free(v);
        return -1;
    }
    /* Along each direction, the i-th smallest box of a against the i-th smallest of b: the
     * 1-D optimal transport between two equal-sized samples pairs them in sorted order. */
    double sum = 0.0;
    for (int d = 0; d < N_DIR; d++) {
        const double *w = sorted_directions[d];
        for (int k = 0; k < 2; k++)
            for (int i = 0; i < N; i++) {
                const double *box = avg + (size_t)k * N * 3 + (size_t)i * 3;
                v[k * N + i] = w[0] * box[0] + w[1] * box[1] + w[2] * box[2];
            }
        qsort(v, N, sizeof *v, cmp_double);
        qsort(v + N, N, sizeof *v, cmp_double);
        for (int i = 0; i < N; i++)
            sum += fabs(v[i] - v[N + i]);
    }
    free(avg);
    free(v);
    *out = sum / (N * N_DIR);
    return 0;
}

int evaluate_colour_term(pipeline_colour_term term, const image *a, const image *b,
                         double *out, char *err, size_t errlen)
{
    return term == PIPELINE_COLOUR_SORTED ? evaluate_colour_sorted_distance(a, b, out, err, errlen)
                                          : evaluate_colour_distance(a, b, out, err, errlen);
}

double evaluate_normalise(double distance, double floor)
{
    return distance / (floor > EVALUATE_FLOOR_EPSILON ? floor : EVALUATE_FLOOR_EPSILON);
}

static int cmp_double(const void *pa, const void *pb)
{
    double a = *(const double *)pa, b = *(const double *)pb;
    return (a > b) - (a < b);
}

double evaluate_quantile(const double *v, size_t n, double q)
{
    double *s = malloc((n ? n : 1) * sizeof *s);
    if (!s)
        return NAN;
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (!isnan(v[i]))
            s[m++] = v[i];
    double r = NAN;
    if (m) {
        qsort(s, m, sizeof *s, cmp_double);
        q = q < 0.0 ? 0.0 : q > 1.0 ? 1.0 : q;
        double pos = q * (double)(m - 1);
        size_t lo = (size_t)pos;
        size_t hi = lo + 1 < m ? lo + 1 : lo;
        double t = pos - (double)lo;
        r = s[lo] + t * (s[hi] - s[lo]);
    }
    free(s);
    return r;
}

double evaluate_r2(const double *pred, const double *truth, size_t n, double reference_mean)
{
    double sse = 0.0, sst = 0.0;
    for (size_t i = 0; i < n; i++) {
        sse += (pred[i] - truth[i]) * (pred[i] - truth[i]);
        sst += (truth[i] - reference_mean) * (truth[i] - reference_mean);
    }
    return sst > 0.0 ? 1.0 - sse / sst : NAN;
}

/* Population covariance, two passes (the means first: no cancellation). n > 0. */
static double covariance(const double *a, const double *b, size_t n)
{
    double ma = 0.0, mb = 0.0, s = 0.0;
    for (size_t i = 0; i < n; i++) {
        ma += a[i];
        mb += b[i];
    }
    ma /= (double)n;
    mb /= (double)n;
    for (size_t i = 0; i < n; i++)
        s += (a[i] - ma) * (b[i] - mb);
    return s / (double)n;
}

static double variance(const double *v, size_t n) { return covariance(v, v, n); }

double evaluate_correlation(const double *pred, const double *truth, size_t n)
{
    if (n == 0)
        return NAN;
    double vp = variance(pred, n), vt = variance(truth, n);
    return vp > 0.0 && vt > 0.0 ? covariance(pred, truth, n) / sqrt(vp * vt) : NAN;
}

double evaluate_spread(const double *pred, const double *truth, size_t n)
{
    if (n == 0)
        return NAN;
    double vt = variance(truth, n);
    return vt > 0.0 ? sqrt(variance(pred, n) / vt) : NAN;
}

void evaluate_share_interval(size_t k, size_t n, double *lo, double *hi)
{
    if (n == 0) {
        *lo = *hi = NAN;
        return;
    }
    /* Solving |k/n - p| = z sqrt(p (1 - p) / n) for p: a quadratic whose two roots are
     * centre -+ half. z: the standard normal's 0.975 quantile. */
    const double z = 1.959963984540054;
    double nn = (double)n, p = (double)k / nn, z2n = z * z / nn;
    double centre = (p + z2n / 2.0) / (1.0 + z2n);
    double half = z / (1.0 + z2n) * sqrt(p * (1.0 - p) / nn + z2n / (4.0 * nn));
    *lo = k == 0 ? 0.0 : centre - half; /* exact ends: no rounding past them */
    *hi = k == n ? 1.0 : centre + half;
}
