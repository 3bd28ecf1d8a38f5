/*
 * Cycles' pixel filter and the orthographic camera.
 *
 * Filter: Cycles does not weight samples by the filter; it distributes the camera rays'
 * positions with the filter's density, separably in x and y, by reading an inverted CDF
 * table, and every sample then counts equally in the pixel's mean. For Blackman-Harris it
 * doubles the user's width first, so "1.5 px" is a window 3 px wide (support +-1.5 px).
 * We build our own table from the window's closed-form integral, inverted by bisection,
 * and read it with linear interpolation as Cycles reads its table.
 */
#include "render/render_internal.h"

#define BH_A0 0.35875
#define BH_A1 0.48829
#define BH_A2 0.14128
#define BH_A3 0.01168

/* Integral of the window over phase [0, v] (v = 2 pi (x / W + 1/2), W the full width). */
static double bh_integral(double v)
{
    return BH_A0 * v - BH_A1 * sin(v) + BH_A2 * sin(2.0 * v) / 2.0 - BH_A3 * sin(3.0 * v) / 3.0;
}

void pixel_filter_init(pixel_filter *f, float width)
{
    f->width = width;
    double full = 2.0 * (double)width; /* Cycles' doubling for Blackman-Harris */
    double total = bh_integral(2.0 * M_PI);
    for (int i = 0; i < FILTER_TABLE_SIZE; i++) {
        double target = (double)i / (FILTER_TABLE_SIZE - 1) * total;
        double lo = 0.0, hi = 2.0 * M_PI;
        for (int it = 0; it < 60; it++) { /* the integral increases: the window is >= 0 */
            double mid = 0.5 * (lo + hi);
            if (bh_integral(mid) < target)
                lo = mid;
            else
                hi = mid;
        }
        double v = 0.5 * (lo + hi);
        f->table[i] = (float)((v / (2.0 * M_PI) - 0.5) * full);
    }
}

float pixel_filter_sample(const pixel_filter *f, float u)
{
    float x = fminf(fmaxf(u, 0.0f), 1.0f) * (FILTER_TABLE_SIZE - 1);
    int i = (int)x;
    if (i >= FILTER_TABLE_SIZE - 1)
        return f->table[FILTER_TABLE_SIZE - 1];
    float t = x - (float)i;
    return (1.0f - t) * f->table[i] + t * f->table[i + 1];
}

float pixel_filter_density(const pixel_filter *f, float x)
{
    /* The window's cosine terms integrate to 0 over the support, so its integral is
     * a0 x the full width. cos 2v and cos 3v from cos v (Chebyshev): one cosine per call,
     * as the fast mode's film calls this six times per shading point. */
    float full = 2.0f * f->width;
    if (fabsf(x) > 0.5f * full)
        return 0.0f;
    float c = cosf(2.0f * (float)M_PI * (x / full + 0.5f));
    float c2 = 2.0f * c * c - 1.0f, c3 = (4.0f * c * c - 3.0f) * c;
    float w = (float)BH_A0 - (float)BH_A1 * c + (float)BH_A2 * c2 - (float)BH_A3 * c3;
    return w / ((float)BH_A0 * full);
}

double pixel_filter_cdf(const pixel_filter *f, double x)
{
    double full = 2.0 * (double)f->width;
    if (x <= -0.5 * full)
        return 0.0;
    if (x >= 0.5 * full)
        return 1.0;
    return bh_integral(2.0 * M_PI * (x / full + 0.5)) / bh_integral(2.0 * M_PI);
}

void ortho_camera_ray(const ortho_camera *c, float rx, float ry, float3 *P, float3 *D,
                      float *dP)
{
    /* Blender's ortho_scale spans the larger side; pixels are square. */
    int side = c->width > c->height ? c->width : c->height;
    float pixel = c->ortho_scale / (float)side;
    float sx = (rx - 0.5f * (float)c->width) * pixel;
    float sy = (0.5f * (float)c->height - ry) * pixel; /* row 0 at the top */
    *P = f3_add(f3_add(c->position, f3_scale(c->right, sx)), f3_scale(c->up, sy));
    *D = c->forward;
    /* Cycles' compact differential: the mean of the x and y pixel extents. */
    *dP = pixel;
}

/* Cycles' make_orthonormals, rounding alike; a zero N gives zero tangents where Cycles'
 * normalize gives NaNs (f3_normalize_len). */
void render_make_orthonormals(float3 N, float3 *a, float3 *b)
{
    float3 t = N.x != N.y || N.x != N.z ? make_float3(N.z - N.y, N.x - N.z, N.y - N.x)
                                        : make_float3(N.z - N.y, N.x + N.z, -N.y - N.x);
    float len;
    *a = f3_normalize_len(t, &len);
    *b = f3_cross(N, *a);
}
