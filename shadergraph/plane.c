/*
 * Geometry of the scene's plane (DESIGN.md) as the orthographic camera sees it:
 * the 2 m x 2 m plane at z = 0 fills the frame exactly, so pixel (px, py) of a
 * width x height image (row 0 at the top) looks at
 *     x = -1 + 2 (px + 0.5) / width,   y = 1 - 2 (py + 0.5) / height.
 * The plane's object transform is the identity, Generated coordinates are its bounding
 * box mapped to [0,1] with the flat z axis at 0.5, and UV spans (0,0)-(1,1).
 *
 * Differentials: Cycles keeps a camera ray's footprint as one "compact" number, the
 * mean pixel size in metres, and when Bump or a texture needs the offsets it rebuilds
 * them as that length along an orthonormal pair around Ng (make_orthonormals). For
 * Ng = +Z that pair is (1,-1,0)/sqrt2 and (1,1,0)/sqrt2: diagonal, not along the
 * pixel axes. We reproduce that, since Bump's result depends on it.
 */
#include <math.h>

#include "shadergraph/shadergraph.h"

enum { F_P, F_DPDX, F_DPDY, F_N, F_NG, F_I, F_GEN, F_DGENX, F_DGENY, F_UV, F_DUVX, F_DUVY,
       F_OBJ, F_DOBJX, F_DOBJY, F_ONORMAL, F_COUNT };

void sg_plane_geometry(int width, int height, int first, int n, float *storage,
                       sg_geometry_batch *geom)
{
    float *f[F_COUNT];
    for (int k = 0; k < F_COUNT; k++)
        f[k] = storage + (size_t)k * 3 * (size_t)n;

    /* Compact differential: mean of the pixel's world extents in x and y. */
    float dx_len = 2.0f / (float)width, dy_len = 2.0f / (float)height;
    float dP = 0.5f * (dx_len + dy_len);
    /* make_orthonormals((0,0,1)): a = normalize((1,-1,0)), b = cross(N, a). */
    float len = sqrtf(2.0f);
    float ax = 1.0f / len, ay = -1.0f / len;
    float bx = -ay, by = ax;
    float ddx[3] = {dP * ax, dP * ay, 0.0f}, ddy[3] = {dP * bx, dP * by, 0.0f};

    for (int i = 0; i < n; i++) {
        int idx = first + i;
        int px = idx % width, py = idx / width;
        float x = -1.0f + 2.0f * ((float)px + 0.5f) / (float)width;
        float y = 1.0f - 2.0f * ((float)py + 0.5f) / (float)height;
        float pos[3] = {x, y, 0.0f};
        float gen[3] = {(x + 1.0f) * 0.5f, (y + 1.0f) * 0.5f, 0.5f};
        float uv[3] = {gen[0], gen[1], 0.0f};
        float up[3] = {0.0f, 0.0f, 1.0f};
        for (int c = 0; c < 3; c++) {
            size_t at = (size_t)c * (size_t)n + (size_t)i;
            f[F_P][at] = pos[c];
            f[F_OBJ][at] = pos[c];
            f[F_DPDX][at] = f[F_DOBJX][at] = ddx[c];
            f[F_DPDY][at] = f[F_DOBJY][at] = ddy[c];
            f[F_N][at] = f[F_NG][at] = f[F_I][at] = f[F_ONORMAL][at] = up[c];
            f[F_GEN][at] = gen[c];
            f[F_UV][at] = uv[c];
            /* Generated and UV are (P + 1) / 2 in x and y: half the P offsets. */
            f[F_DGENX][at] = f[F_DUVX][at] = c < 2 ? 0.5f * ddx[c] : 0.0f;
            f[F_DGENY][at] = f[F_DUVY][at] = c < 2 ? 0.5f * ddy[c] : 0.0f;
        }
    }
    geom->n = n;
    geom->P = f[F_P];
    geom->dPdx = f[F_DPDX];
    geom->dPdy = f[F_DPDY];
    geom->N = f[F_N];
    geom->Ng = f[F_NG];
    geom->I = f[F_I];
    geom->generated = f[F_GEN];
    geom->dgenerated_dx = f[F_DGENX];
    geom->dgenerated_dy = f[F_DGENY];
    geom->uv = f[F_UV];
    geom->duv_dx = f[F_DUVX];
    geom->duv_dy = f[F_DUVY];
    geom->object = f[F_OBJ];
    geom->dobject_dx = f[F_DOBJX];
    geom->dobject_dy = f[F_DOBJY];
    geom->object_normal = f[F_ONORMAL];
}
