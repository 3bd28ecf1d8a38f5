/*
 * Voronoi Texture (ShaderNodeTexVoronoi), as Cycles evaluates it (kernel/svm/voronoi.h of
 * Blender 3.4 and 4.3), in 1, 2, 3 and 4 dimensions.
 *
 * Space is cut into unit cells; each cell holds one feature point, placed by hashing the
 * cell's integer coordinates (as float bit patterns) and scaled by Randomness. The
 * features are found by scanning the 3^d neighbouring cells (5^d for Smooth F1):
 *
 *   F1               distance to, colour of and position of the closest point
 *   F2               the same for the second closest point
 *   SMOOTH_F1        a smooth minimum over all points (Inigo Quilez' smooth Voronoi)
 *   DISTANCE_TO_EDGE distance to the nearest cell border (always Euclidean)
 *   N_SPHERE_RADIUS  half the distance from the closest point to its own closest point
 *
 * Blender 4.x layers octaves of this, like fBM noise (Detail, Roughness, Lacunarity,
 * Normalize); Blender 3.x has no such sockets and evaluates one octave. The two releases
 * also differ in small ways that show: 3.x starts its searches from a distance of 8 (so
 * Minkowski distances beyond 8 are never found), 4.x from FLT_MAX; 3.x's smooth F1 blends
 * its first point into that 8 and divides by a zero smoothness (which 4.x avoids by falling
 * back to F1). Both behaviours are reproduced, selected by a->blender.
 *
 * The cell scan visits offsets with the first coordinate varying fastest, as Cycles does;
 * the order matters where two points are at exactly the same distance (the first wins).
 *
 * Bit-exactness: float operations follow Cycles' order and rounding as Blender's x86-64
 * builds run it (the AVX2 kernel, GCC, -ffp-contract=fast): a product that feeds a sum
 * directly is fused there, so it is written with fmaf() here (this project compiles with
 * -ffp-contract=off); float3 and float4 dot products are _mm_dp_ps (products rounded,
 * summed pairwise, never fused), float2 ones plain C (first product fused); a float2 or
 * float4 divided by a scalar is multiplied by its reciprocal, a float3 is divided. With
 * these, every reference case (tests/reference/nodes/voronoi_*) is bit-identical to
 * Blender 3.4 and 4.3.
 */
#include "shadergraph/node_type.h"
#include "shadergraph/kernels/lanes.h"

#include <float.h>
#include <stdbool.h>

/* Property indices (order of voronoi_props). */
enum { PROP_DIMENSIONS, PROP_DISTANCE, PROP_FEATURE, PROP_NORMALIZE };

/* Enum values, in Blender's RNA order. */
enum { DIM_1D, DIM_2D, DIM_3D, DIM_4D };
enum { METRIC_EUCLIDEAN, METRIC_MANHATTAN, METRIC_CHEBYCHEV, METRIC_MINKOWSKI };
enum { FEATURE_F1, FEATURE_F2, FEATURE_SMOOTH_F1, FEATURE_DISTANCE_TO_EDGE, FEATURE_N_SPHERE_RADIUS };

/* Input and output indices (order of the socket tables). */
enum { IN_VECTOR, IN_W, IN_SCALE, IN_DETAIL, IN_ROUGHNESS, IN_LACUNARITY, IN_SMOOTHNESS,
       IN_EXPONENT, IN_RANDOMNESS };
enum { OUT_DISTANCE, OUT_COLOR, OUT_POSITION, OUT_W, OUT_RADIUS };

/* A point of up to 4 dimensions; components past the dimension count are unused. */
typedef struct vpoint {
    float v[4];
} vpoint;

typedef struct voronoi_params {
    int dims; /* 1..4 */
    int feature;
    int metric;
    bool blender3; /* 3.x semantics: search sentinel 8, 3.x smooth F1, no octaves */
    float detail, roughness, lacunarity; /* 4.x only */
    float smoothness;                    /* already halved and clamped to [0, 0.5] */
    float exponent;
    float randomness; /* clamped to [0, 1] */
    float max_distance;
    bool normalize;
    bool want_color; /* the Color output is used (smooth F1 skips its hashes if not) */
} voronoi_params;

typedef struct voronoi_result {
    float distance;
    float color[3];
    vpoint position; /* x, y, z and W, laid out as Cycles' float4 position */
} voronoi_result;

/* ---- small helpers ----------------------------------------------------------------- */

/* Cycles' mix as its AVX2 build fuses it (mix_fused) and its min/max/clamp, whose NaN
 * behaviour differs from fminf/fmaxf (minf, maxf, clampf): shadergraph/kernel_math.h. */

/* x / f for a component of a Cycles float<dims>: float2 and float4 divide by a scalar
 * through its reciprocal, float3 (SSE) and float divide directly. */
static inline float div_component(float x, float f, int dims)
{
    return (dims == 2 || dims == 4) ? x * (1.0f / f) : x / f;
}

static inline float smoothstepf(float edge0, float edge1, float x)
{
    /* Cycles' smoothstep; note a NaN x falls through to the polynomial and stays NaN. */
    if (x < edge0)
        return 0.0f;
    if (x >= edge1)
        return 1.0f;
    float t = (x - edge0) / (edge1 - edge0);
    return fmaf(-2.0f, t, 3.0f) * (t * t); /* (3 - 2t) t^2, 3 - 2t fused */
}

static inline float dot_n(const vpoint *a, const vpoint *b, int dims)
{
    switch (dims) {
    case 1:
        return a->v[0] * b->v[0];
    case 2: /* plain C in Cycles: GCC fuses the first product */
        return fmaf(a->v[0], b->v[0], a->v[1] * b->v[1]);
    case 3: /* _mm_dp_ps: (x + y) + z, unfused */
        return a->v[0] * b->v[0] + a->v[1] * b->v[1] + a->v[2] * b->v[2];
    default: /* _mm_dp_ps sums pairwise */
        return (a->v[0] * b->v[0] + a->v[1] * b->v[1]) + (a->v[2] * b->v[2] + a->v[3] * b->v[3]);
    }
}

/* Distance between a and b in the node's metric (1D: always |b - a|). */
static inline float voronoi_distance(const vpoint *a, const vpoint *b, const voronoi_params *p)
{
    const int dims = p->dims;
    if (dims == 1)
        return fabsf(b->v[0] - a->v[0]);
    vpoint d = {{0.0f, 0.0f, 0.0f, 0.0f}};
    for (int c = 0; c < dims; c++)
        d.v[c] = a->v[c] - b->v[c];
    switch (p->metric) {
    case METRIC_EUCLIDEAN:
        return sqrtf(dot_n(&d, &d, dims));
    case METRIC_MANHATTAN: {
        float s = fabsf(d.v[0]);
        for (int c = 1; c < dims; c++)
            s += fabsf(d.v[c]);
        return s;
    }
    case METRIC_CHEBYCHEV: {
        /* Cycles nests max from the last component outwards; max is exact either way. */
        float m = fabsf(d.v[dims - 1]);
        for (int c = dims - 2; c >= 0; c--)
            m = maxf(fabsf(d.v[c]), m);
        return m;
    }
    case METRIC_MINKOWSKI: {
        float s = powf(fabsf(d.v[0]), p->exponent);
        for (int c = 1; c < dims; c++)
            s += powf(fabsf(d.v[c]), p->exponent);
        return powf(s, 1.0f / p->exponent);
    }
    default:
        return 0.0f;
    }
}

static inline float euclidean_distance(const vpoint *a, const vpoint *b, int dims)
{
    if (dims == 1)
        return fabsf(a->v[0] - b->v[0]);
    vpoint d = {{0.0f, 0.0f, 0.0f, 0.0f}};
    for (int c = 0; c < dims; c++)
        d.v[c] = a->v[c] - b->v[c];
    return sqrtf(dot_n(&d, &d, dims));
}

/* Where a cell's feature point sits inside it, in [0, 1]^d before Randomness: Cycles'
 * hash_float{,2,3,4}_to_float{,2,3,4} of the cell's coordinates. */
static inline vpoint cell_jitter(const vpoint *cell, int dims)
{
    const float *k = cell->v;
    vpoint h = {{0.0f, 0.0f, 0.0f, 0.0f}};
    switch (dims) {
    case 1:
        h.v[0] = hash_float_to_float(k[0]);
        break;
    case 2:
        h.v[0] = hash_float2_to_float(k[0], k[1]);
        h.v[1] = hash_float3_to_float(make_float3(k[0], k[1], 1.0f));
        break;
    case 3: {
        float3 r = hash_float3_to_float3(make_float3(k[0], k[1], k[2]));
        h.v[0] = r.x;
        h.v[1] = r.y;
        h.v[2] = r.z;
        break;
    }
    default:
        h.v[0] = hash_float4_to_float(k[0], k[1], k[2], k[3]);
        h.v[1] = hash_float4_to_float(k[3], k[0], k[1], k[2]);
        h.v[2] = hash_float4_to_float(k[2], k[3], k[0], k[1]);
        h.v[3] = hash_float4_to_float(k[1], k[2], k[3], k[0]);
        break;
    }
    return h;
}

/* A cell's colour: Cycles' hash_float{,2,3,4}_to_float3 of its coordinates. */
static inline void cell_color(const vpoint *cell, int dims, float out[3])
{
    const float *k = cell->v;
    switch (dims) {
    case 1:
        out[0] = hash_float_to_float(k[0]);
        out[1] = hash_float2_to_float(k[0], 1.0f);
        out[2] = hash_float2_to_float(k[0], 2.0f);
        break;
    case 2:
        out[0] = hash_float2_to_float(k[0], k[1]);
        out[1] = hash_float3_to_float(make_float3(k[0], k[1], 1.0f));
        out[2] = hash_float3_to_float(make_float3(k[0], k[1], 2.0f));
        break;
    case 3: {
        float3 r = hash_float3_to_float3(make_float3(k[0], k[1], k[2]));
        out[0] = r.x;
        out[1] = r.y;
        out[2] = r.z;
        break;
    }
    default:
        out[0] = hash_float4_to_float(k[0], k[1], k[2], k[3]);
        out[1] = hash_float4_to_float(k[2], k[0], k[3], k[1]);
        out[2] = hash_float4_to_float(k[3], k[2], k[1], k[0]);
        break;
    }
}

/* Offset number `idx` of a scan over [-radius, radius]^dims, first coordinate fastest. */
static inline vpoint scan_offset(int idx, int radius, int dims)
{
    const int side = 2 * radius + 1;
    vpoint o = {{0.0f, 0.0f, 0.0f, 0.0f}};
    for (int c = 0; c < dims; c++) {
        o.v[c] = (float)(idx % side - radius);
        idx /= side;
    }
    return o;
}

static inline int scan_count(int radius, int dims)
{
    int side = 2 * radius + 1, n = 1;
    for (int c = 0; c < dims; c++)
        n *= side;
    return n;
}

static inline void split_cell(const vpoint *coord, int dims, vpoint *cell, vpoint *local)
{
    *cell = *local = (vpoint){{0.0f, 0.0f, 0.0f, 0.0f}};
    for (int c = 0; c < dims; c++) {
        cell->v[c] = floorf(coord->v[c]);
        local->v[c] = coord->v[c] - cell->v[c];
    }
}

/* The feature point of the cell at `offset` from `cell`, relative to `cell`; the cell's
 * coordinates go to *neighbour. */
static inline vpoint feature_point(const vpoint *cell, const vpoint *offset, float randomness,
                                   int dims, vpoint *neighbour)
{
    for (int c = 0; c < dims; c++)
        neighbour->v[c] = cell->v[c] + offset->v[c];
    vpoint h = cell_jitter(neighbour, dims);
    vpoint pt = {{0.0f, 0.0f, 0.0f, 0.0f}};
    for (int c = 0; c < dims; c++)
        pt.v[c] = fmaf(h.v[c], randomness, offset->v[c]);
    return pt;
}

/* ---- the hashes of a whole scan window, LANES cells at a time -----------------------
 *
 * Hashing dominates the cost (3 to 4 lookup3 hashes per cell, 27 to 625 cells), and the
 * cells of a window are independent, so they are hashed LANES cells to a vector
 * (lanes.h: the same bits as the scalar hashes). */

/* cell_jitter of each lane's cell (keys: the cell coordinates' bits) and, if color is
 * not NULL, cell_color, which shares the jitter's hashes. */
LANE_INLINE void lane_cell_hashes(const lane_u *k, int dims, lane_f *j, lane_f *color)
{
    const lane_u one = lane_splat_u(float_bits(1.0f)), two = lane_splat_u(float_bits(2.0f));
#define UNIT(h) lane_uint_to_unit_float(h)
    switch (dims) {
    case 1:
        j[0] = UNIT(lane_hash_uint(k[0]));
        if (color) {
            color[0] = j[0];
            color[1] = UNIT(lane_hash_uint2(k[0], one));
            color[2] = UNIT(lane_hash_uint2(k[0], two));
        }
        break;
    case 2:
        j[0] = UNIT(lane_hash_uint2(k[0], k[1]));
        j[1] = UNIT(lane_hash_uint3(k[0], k[1], one));
        if (color) {
            color[0] = j[0];
            color[1] = j[1];
            color[2] = UNIT(lane_hash_uint3(k[0], k[1], two));
        }
        break;
    case 3:
        j[0] = UNIT(lane_hash_uint3(k[0], k[1], k[2]));
        j[1] = UNIT(lane_hash_uint4(k[0], k[1], k[2], one));
        j[2] = UNIT(lane_hash_uint4(k[0], k[1], k[2], two));
        if (color)
            for (int c = 0; c < 3; c++)
                color[c] = j[c];
        break;
    default:
        j[0] = UNIT(lane_hash_uint4(k[0], k[1], k[2], k[3]));
        j[1] = UNIT(lane_hash_uint4(k[3], k[0], k[1], k[2]));
        j[2] = UNIT(lane_hash_uint4(k[2], k[3], k[0], k[1]));
        j[3] = UNIT(lane_hash_uint4(k[1], k[2], k[3], k[0]));
        if (color) {
            color[0] = j[0];
            color[1] = UNIT(lane_hash_uint4(k[2], k[0], k[3], k[1]));
            color[2] = UNIT(lane_hash_uint4(k[3], k[2], k[1], k[0]));
        }
        break;
    }
#undef UNIT
}

#define MAX_SCAN 625 /* 5^4: smooth F1 in 4D */

/* Per cell of a scan window, in scan order (first coordinate fastest): its offset from
 * the centre cell, its feature point relative to the centre cell (offset + jitter *
 * randomness, as Cycles computes it) and, when asked for, its colour (cell_color). */
typedef struct cell_table {
    int n;
    vpoint offset[MAX_SCAN];
    vpoint point[MAX_SCAN];
    float color[MAX_SCAN][3];
} cell_table;

static inline __attribute__((always_inline)) void cell_table_fill(cell_table *t, const vpoint *cell, int radius, int dims,
                                   float randomness, bool with_color)
{
    const int n = scan_count(radius, dims);
    t->n = n;
    /* The cells' coordinates as hash keys, padded to whole vectors. Nested loops, one
     * per dimension (first coordinate fastest), so that the offsets live in registers:
     * an odometer over an array of counters was most of this function's time. */
    uint32_t keys[4][MAX_SCAN + LANES];
    const int side = 2 * radius + 1;
    const int n1 = dims > 1 ? side : 1, n2 = dims > 2 ? side : 1, n3 = dims > 3 ? side : 1;
    int idx = 0;
    for (int w = 0; w < n3; w++) {
        const float ow = dims > 3 ? (float)(w - radius) : 0.0f;
        for (int z = 0; z < n2; z++) {
            const float oz = dims > 2 ? (float)(z - radius) : 0.0f;
            for (int y = 0; y < n1; y++) {
                const float oy = dims > 1 ? (float)(y - radius) : 0.0f;
                for (int x = 0; x < side; x++, idx++) {
                    const float ox = (float)(x - radius);
                    t->offset[idx] = (vpoint){{ox, oy, oz, ow}};
                    keys[0][idx] = float_bits(cell->v[0] + ox);
                    if (dims > 1)
                        keys[1][idx] = float_bits(cell->v[1] + oy);
                    if (dims > 2)
                        keys[2][idx] = float_bits(cell->v[2] + oz);
                    if (dims > 3)
                        keys[3][idx] = float_bits(cell->v[3] + ow);
                }
            }
        }
    }
    for (int c = 0; c < 4; c++)
        for (int pad = n; pad < n + LANES; pad++)
            keys[c][pad] = 0u;

    for (int s = 0; s < n; s += LANES) {
        lane_u k[4];
        for (int c = 0; c < dims; c++)
            memcpy(&k[c], &keys[c][s], sizeof k[c]);
        lane_f j[4], col[3];
        lane_cell_hashes(k, dims, j, with_color ? col : NULL);
        const int m = n - s < LANES ? n - s : LANES;
        for (int l = 0; l < m; l++) {
            vpoint *pt = &t->point[s + l];
            const vpoint *off = &t->offset[s + l];
            *pt = (vpoint){{0.0f, 0.0f, 0.0f, 0.0f}};
            for (int c = 0; c < dims; c++)
                pt->v[c] = fmaf(j[c][l], randomness, off->v[c]);
            if (with_color)
                for (int c = 0; c < 3; c++)
                    t->color[s + l][c] = col[c][l];
        }
    }
}

/* Cycles' voronoi_position(): 1D puts the coordinate in W, 3D sets W to 1. */
static inline vpoint to_position(const vpoint *x, int dims)
{
    vpoint r = {{0.0f, 0.0f, 0.0f, 0.0f}};
    switch (dims) {
    case 1:
        r.v[3] = x->v[0];
        break;
    case 2:
        r.v[0] = x->v[0];
        r.v[1] = x->v[1];
        break;
    case 3:
        r = *x;
        r.v[3] = 1.0f;
        break;
    default:
        r = *x;
        break;
    }
    return r;
}

/* Sentinel the nearest-point searches start from. */
static inline float search_start(const voronoi_params *p) { return p->blender3 ? 8.0f : FLT_MAX; }

/* ---- one octave -------------------------------------------------------------------- */

/* VORONOI_DIMS_DISPATCH: the hot searches take the dimension count as a parameter and
 * are always inlined into a switch that passes it as a constant, so that each dimension
 * gets its own copy with the per-coordinate loops unrolled and the points in registers
 * (with a run-time count the points went through the stack on every step). Same
 * arithmetic, same bits. */
#define VORONOI_DIMS_DISPATCH(fn, p, coord)                                               \
    switch ((p)->dims) {                                                                  \
    case 1:                                                                               \
        return fn((p), (coord), 1);                                                       \
    case 2:                                                                               \
        return fn((p), (coord), 2);                                                       \
    case 3:                                                                               \
        return fn((p), (coord), 3);                                                       \
    default:                                                                              \
        return fn((p), (coord), 4);                                                       \
    }

/* Specialised per dimension count (VORONOI_DIMS_DISPATCH). */
static inline __attribute__((always_inline)) voronoi_result voronoi_f1_n(const voronoi_params *p,
        const vpoint *coord, const int dims)
{
    vpoint cell, local, neighbour = {{0.0f, 0.0f, 0.0f, 0.0f}};
    split_cell(coord, dims, &cell, &local);

    float min_distance = search_start(p);
    vpoint target_offset = {{0.0f, 0.0f, 0.0f, 0.0f}}, target_point = target_offset;
    cell_table table;
    cell_table_fill(&table, &cell, 1, dims, p->randomness, false);
    const int n = scan_count(1, dims);
    for (int idx = 0; idx < n; idx++) {
        const vpoint offset = table.offset[idx];
        const vpoint pt = table.point[idx];
        float d = voronoi_distance(&pt, &local, p);
        if (d < min_distance) {
            target_offset = offset;
            min_distance = d;
            target_point = pt;
        }
    }

    voronoi_result r;
    r.distance = min_distance;
    for (int c = 0; c < dims; c++)
        neighbour.v[c] = cell.v[c] + target_offset.v[c];
    cell_color(&neighbour, dims, r.color);
    vpoint abs_point = {{0.0f, 0.0f, 0.0f, 0.0f}};
    for (int c = 0; c < dims; c++)
        abs_point.v[c] = target_point.v[c] + cell.v[c];
    r.position = to_position(&abs_point, dims);
    return r;
}

static voronoi_result voronoi_f1(const voronoi_params *p, const vpoint *coord)
{
    VORONOI_DIMS_DISPATCH(voronoi_f1_n, p, coord);
}

/* Smooth F1. 4.x takes the first point as it is (h = 1); 3.x blends it into a start
 * distance of 8 like every other point, and evaluates smoothness 0 as a division by zero
 * (which amounts to F1, or NaN on an exact tie) rather than switching to F1. */
static voronoi_result voronoi_smooth_f1(const voronoi_params *p, const vpoint *coord)
{
    const int dims = p->dims;
    const float smoothness = p->smoothness;
    vpoint cell, local;
    split_cell(coord, dims, &cell, &local);

    float smooth_distance = p->blender3 ? 8.0f : 0.0f;
    float smooth_color[3] = {0.0f, 0.0f, 0.0f};
    vpoint smooth_point = {{0.0f, 0.0f, 0.0f, 0.0f}};
    cell_table table;
    cell_table_fill(&table, &cell, 2, dims, p->randomness, p->want_color);
    const int n = scan_count(2, dims);
    for (int idx = 0; idx < n; idx++) {
        const vpoint pt = table.point[idx];
        float d = voronoi_distance(&pt, &local, p);
        float h = (idx == 0 && !p->blender3) ?
                      1.0f :
                      smoothstepf(0.0f, 1.0f, 0.5f + 0.5f * (smooth_distance - d) / smoothness);
        float correction = smoothness * h * (1.0f - h);
        smooth_distance = mix_fused(smooth_distance, d, h) - correction;
        correction /= fmaf(3.0f, smoothness, 1.0f);
        if (p->want_color)
            for (int c = 0; c < 3; c++)
                smooth_color[c] = mix_fused(smooth_color[c], table.color[idx][c], h) - correction;
        for (int c = 0; c < dims; c++)
            smooth_point.v[c] = mix_fused(smooth_point.v[c], pt.v[c], h) - correction;
    }

    voronoi_result r;
    r.distance = smooth_distance;
    for (int c = 0; c < 3; c++)
        r.color[c] = smooth_color[c];
    vpoint abs_point = {{0.0f, 0.0f, 0.0f, 0.0f}};
    for (int c = 0; c < dims; c++)
        abs_point.v[c] = cell.v[c] + smooth_point.v[c];
    r.position = to_position(&abs_point, dims);
    return r;
}

/* Specialised per dimension count (VORONOI_DIMS_DISPATCH). */
static inline __attribute__((always_inline)) voronoi_result voronoi_f2_n(const voronoi_params *p,
        const vpoint *coord, const int dims)
{
    vpoint cell, local, neighbour = {{0.0f, 0.0f, 0.0f, 0.0f}};
    split_cell(coord, dims, &cell, &local);

    float distance_f1 = search_start(p), distance_f2 = search_start(p);
    const vpoint zero = {{0.0f, 0.0f, 0.0f, 0.0f}};
    vpoint offset_f1 = zero, point_f1 = zero, offset_f2 = zero, point_f2 = zero;
    cell_table table;
    cell_table_fill(&table, &cell, 1, dims, p->randomness, false);
    const int n = scan_count(1, dims);
    for (int idx = 0; idx < n; idx++) {
        const vpoint offset = table.offset[idx];
        const vpoint pt = table.point[idx];
        float d = voronoi_distance(&pt, &local, p);
        if (d < distance_f1) {
            distance_f2 = distance_f1;
            distance_f1 = d;
            offset_f2 = offset_f1;
            offset_f1 = offset;
            point_f2 = point_f1;
            point_f1 = pt;
        }
        else if (d < distance_f2) {
            distance_f2 = d;
            offset_f2 = offset;
            point_f2 = pt;
        }
    }

    voronoi_result r;
    r.distance = distance_f2;
    for (int c = 0; c < dims; c++)
        neighbour.v[c] = cell.v[c] + offset_f2.v[c];
    cell_color(&neighbour, dims, r.color);
    vpoint abs_point = zero;
    for (int c = 0; c < dims; c++)
        abs_point.v[c] = point_f2.v[c] + cell.v[c];
    r.position = to_position(&abs_point, dims);
    return r;
}

static voronoi_result voronoi_f2(const voronoi_params *p, const vpoint *coord)
{
    VORONOI_DIMS_DISPATCH(voronoi_f2_n, p, coord);
}

/* 1D has its own closed form: the borders are the midpoints to the two neighbours. */
static float voronoi_distance_to_edge_1d(const voronoi_params *p, float w)
{
    float cell = floorf(w);
    float local = w - cell;
    /* Every product here feeds a sum, and Cycles' AVX2 build fuses each of them. */
    float mid_hash = hash_float_to_float(cell);
    float left = fmaf(hash_float_to_float(cell - 1.0f), p->randomness, -1.0f);
    float right = fmaf(hash_float_to_float(cell + 1.0f), p->randomness, 1.0f);
    float to_left = fabsf(fmaf(mid_hash, p->randomness, left) / 2.0f - local);
    float to_right = fabsf(fmaf(mid_hash, p->randomness, right) / 2.0f - local);
    return minf(to_left, to_right);
}

/* Distance from the point to the nearest border of its cell: the border with each other
 * point is the bisecting plane; project onto its normal. Points closer than 1e-2 to the
 * closest one (in practice: the closest one itself) are skipped. */
/* Specialised per dimension count (VORONOI_DIMS_DISPATCH). */
static inline __attribute__((always_inline)) float voronoi_distance_to_edge_n(const voronoi_params *p,
        const vpoint *coord, const int dims)
{
    if (dims == 1)
        return voronoi_distance_to_edge_1d(p, coord->v[0]);
    vpoint cell, local;
    split_cell(coord, dims, &cell, &local);

    /* Both passes visit the same points: keep them from the first (3^4 at most). */
    vpoint to_points[81];
    cell_table table;
    cell_table_fill(&table, &cell, 1, dims, p->randomness, false);
    const int n = scan_count(1, dims);
    vpoint to_closest = {{0.0f, 0.0f, 0.0f, 0.0f}};
    float min_distance = search_start(p);
    for (int idx = 0; idx < n; idx++) {
        vpoint to_point = table.point[idx];
        for (int c = 0; c < dims; c++)
            to_point.v[c] -= local.v[c];
        to_points[idx] = to_point;
        float d = dot_n(&to_point, &to_point, dims);
        if (d < min_distance) {
            min_distance = d;
            to_closest = to_point;
        }
    }

    min_distance = search_start(p);
    for (int idx = 0; idx < n; idx++) {
        const vpoint to_point = to_points[idx];
        vpoint perpendicular = {{0.0f, 0.0f, 0.0f, 0.0f}};
        for (int c = 0; c < dims; c++)
            perpendicular.v[c] = to_point.v[c] - to_closest.v[c];
        float perpendicular_sq = dot_n(&perpendicular, &perpendicular, dims);
        if (perpendicular_sq > 0.0001f) {
            float len = sqrtf(perpendicular_sq);
            vpoint midpoint = {{0.0f, 0.0f, 0.0f, 0.0f}}, normal = midpoint;
            for (int c = 0; c < dims; c++) {
                midpoint.v[c] = (to_closest.v[c] + to_point.v[c]) / 2.0f;
                normal.v[c] = div_component(perpendicular.v[c], len, dims);
            }
            min_distance = minf(min_distance, dot_n(&midpoint, &normal, dims));
        }
    }
    return min_distance;
}

static float voronoi_distance_to_edge(const voronoi_params *p, const vpoint *coord)
{
    VORONOI_DIMS_DISPATCH(voronoi_distance_to_edge_n, p, coord);
}

/* Half the distance between the closest point and the point closest to it (always
 * Euclidean), searched around the closest point's cell. */
static float voronoi_n_sphere_radius(const voronoi_params *p, const vpoint *coord)
{
    const int dims = p->dims;
    vpoint cell, local, neighbour;
    split_cell(coord, dims, &cell, &local);

    const int n = scan_count(1, dims);
    const vpoint zero = {{0.0f, 0.0f, 0.0f, 0.0f}};
    vpoint closest = zero, closest_offset = zero;
    float min_distance = search_start(p);
    cell_table table;
    cell_table_fill(&table, &cell, 1, dims, p->randomness, false);
    for (int idx = 0; idx < n; idx++) {
        const vpoint offset = table.offset[idx];
        const vpoint pt = table.point[idx];
        float d = euclidean_distance(&pt, &local, dims);
        if (d < min_distance) {
            min_distance = d;
            closest = pt;
            closest_offset = offset;
        }
    }

    min_distance = search_start(p);
    vpoint closest_to_closest = zero;
    for (int idx = 0; idx < n; idx++) {
        vpoint offset = scan_offset(idx, 1, dims);
        bool centre = true;
        for (int c = 0; c < dims; c++) {
            centre = centre && offset.v[c] == 0.0f;
            offset.v[c] += closest_offset.v[c];
        }
        if (centre)
            continue;
        vpoint pt = feature_point(&cell, &offset, p->randomness, dims, &neighbour);
        float d = euclidean_distance(&closest, &pt, dims);
        if (d < min_distance) {
            min_distance = d;
            closest_to_closest = pt;
        }
    }
    return euclidean_distance(&closest_to_closest, &closest, dims) / 2.0f;
}

static voronoi_result voronoi_octave(const voronoi_params *p, const vpoint *coord)
{
    if (p->feature == FEATURE_F2)
        return voronoi_f2(p, coord);
    /* 4.x falls back to F1 when smoothness is 0; 3.x divides by it (see above). */
    if (p->feature == FEATURE_SMOOTH_F1 && (p->blender3 || p->smoothness != 0.0f))
        return voronoi_smooth_f1(p, coord);
    return voronoi_f1(p, coord);
}

/* ---- octaves (4.x) ----------------------------------------------------------------- */

static inline vpoint scaled(const vpoint *x, float s)
{
    vpoint r = *x;
    for (int c = 0; c < 4; c++)
        r.v[c] = x->v[c] * s;
    return r;
}

/* fBM over octaves, with the positions blended rather than summed. A fractional Detail
 * blends in the last octave by its fraction. Detail 0 or Roughness 0 is one octave. */
static voronoi_result fractal_voronoi(const voronoi_params *p, const vpoint *coord)
{
    float amplitude = 1.0f, max_amplitude = 0.0f, scale = 1.0f;
    voronoi_result out = {0.0f, {0.0f, 0.0f, 0.0f}, {{0.0f, 0.0f, 0.0f, 0.0f}}};
    const bool one_octave = p->blender3 || p->detail == 0.0f || p->roughness == 0.0f;

    for (int i = 0; (float)i <= ceilf(p->detail); ++i) {
        vpoint x = scaled(coord, scale);
        voronoi_result octave = voronoi_octave(p, &x);
        if (one_octave) {
            max_amplitude = 1.0f;
            out = octave;
            break;
        }
        if ((float)i <= p->detail) {
            max_amplitude += amplitude;
            out.distance = fmaf(octave.distance, amplitude, out.distance);
            for (int c = 0; c < 3; c++)
                out.color[c] = fmaf(octave.color[c], amplitude, out.color[c]);
            for (int c = 0; c < 4; c++)
                out.position.v[c] = mix_fused(out.position.v[c],
                                              octave.position.v[c] * (1.0f / scale), amplitude);
            scale *= p->lacunarity;
            amplitude *= p->roughness;
        }
        else {
            float remainder = p->detail - floorf(p->detail);
            if (remainder != 0.0f) {
                max_amplitude = mix_fused(max_amplitude, max_amplitude + amplitude, remainder);
                out.distance = mix_fused(out.distance,
                                         fmaf(octave.distance, amplitude, out.distance), remainder);
                for (int c = 0; c < 3; c++)
                    out.color[c] = mix_fused(out.color[c],
                                             fmaf(octave.color[c], amplitude, out.color[c]),
                                             remainder);
                for (int c = 0; c < 4; c++)
                    out.position.v[c] = mix_fused(
                        out.position.v[c],
                        mix_fused(out.position.v[c], octave.position.v[c] * (1.0f / scale),
                                  amplitude),
                        remainder);
            }
        }
    }

    if (p->normalize && !p->blender3) {
        out.distance /= max_amplitude * p->max_distance;
        /* Cycles' float3 /= multiplies by the reciprocal. */
        const float inv_max_amplitude = 1.0f / max_amplitude;
        for (int c = 0; c < 3; c++)
            out.color[c] *= inv_max_amplitude;
    }
    return out;
}

/* The same fBM for the distance to edges: octaves can only bring edges closer. */
static float fractal_distance_to_edge(const voronoi_params *p, const vpoint *coord)
{
    if (p->blender3)
        return voronoi_distance_to_edge(p, coord);

    float amplitude = 1.0f, max_amplitude = p->max_distance, scale = 1.0f, distance = 8.0f;
    const bool one_octave = p->detail == 0.0f || p->roughness == 0.0f;

    for (int i = 0; (float)i <= ceilf(p->detail); ++i) {
        vpoint x = scaled(coord, scale);
        const float octave_distance = voronoi_distance_to_edge(p, &x);
        if (one_octave) {
            distance = octave_distance;
            break;
        }
        if ((float)i <= p->detail) {
            max_amplitude = mix_fused(max_amplitude, p->max_distance / scale, amplitude);
            distance = mix_fused(distance, minf(distance, octave_distance / scale), amplitude);
            scale *= p->lacunarity;
            amplitude *= p->roughness;
        }
        else {
            float remainder = p->detail - floorf(p->detail);
            if (remainder != 0.0f) {
                float lerp_amplitude = mix_fused(max_amplitude, p->max_distance / scale, amplitude);
                max_amplitude = mix_fused(max_amplitude, lerp_amplitude, remainder);
                float lerp_distance = mix_fused(distance, minf(distance, octave_distance / scale),
                                                amplitude);
                distance = mix_fused(distance, minf(distance, lerp_distance), remainder);
            }
        }
    }

    if (p->normalize)
        distance /= max_amplitude;
    return distance;
}

/* Largest F1 distance within a cell for this metric (F2: twice that), used by Normalize. */
static float voronoi_max_distance(const voronoi_params *p)
{
    const float half = fmaf(0.5f, p->randomness, 0.5f);
    const float factor = p->feature == FEATURE_F2 ? 2.0f : 1.0f;
    if (p->dims == 1)
        return half * factor;
    const vpoint zero = {{0.0f, 0.0f, 0.0f, 0.0f}};
    const vpoint corner = {{half, half, half, half}};
    return voronoi_distance(&zero, &corner, p) * factor;
}

/* ---- batch ------------------------------------------------------------------------- */

/* Point i's parameters (clamped as the node clamps them), coordinates and Scale. */
static inline void read_point(const sg_kernel_args *a, const voronoi_params *base, int i,
                              voronoi_params *params, vpoint *coordinates, float *scale_out)
{
    const int n = a->n, dims = base->dims;
    const float *const *in = a->in;
    voronoi_params p = *base;
    const float scale = in[IN_SCALE][i];
    p.detail = clampf(in[IN_DETAIL][i], 0.0f, 15.0f);
    p.roughness = clampf(in[IN_ROUGHNESS][i], 0.0f, 1.0f);
    p.lacunarity = in[IN_LACUNARITY][i];
    p.smoothness = clampf(in[IN_SMOOTHNESS][i] / 2.0f, 0.0f, 0.5f);
    p.exponent = in[IN_EXPONENT][i];
    p.randomness = clampf(in[IN_RANDOMNESS][i], 0.0f, 1.0f);
    p.max_distance = 0.0f;

    /* The vector is read for 2D-4D, W for 1D and 4D. */
    vpoint coord = {{0.0f, 0.0f, 0.0f, 0.0f}};
    const float w = in[IN_W][i] * scale;
    if (dims == 1) {
        coord.v[0] = w;
    }
    else {
        float3 v = f3_load(in[IN_VECTOR], n, i);
        coord.v[0] = v.x * scale;
        coord.v[1] = v.y * scale;
        if (dims >= 3)
            coord.v[2] = v.z * scale;
        if (dims == 4)
            coord.v[3] = w;
    }
    *params = p;
    *coordinates = coord;
    *scale_out = scale;
}

/* Point i alone. Inlined once per dimension count, so that `dims` is a constant. */
static inline void voronoi_point(const sg_kernel_args *a, const voronoi_params *base, int i)
{
    const int n = a->n, dims = base->dims;
    float *const *out = a->out;
    voronoi_params p;
    vpoint coord;
    float scale;
    read_point(a, base, i, &p, &coord, &scale);
    const bool blender3 = p.blender3;

    float distance = 0.0f, radius = 0.0f;
    float color[3] = {0.0f, 0.0f, 0.0f};
    vpoint position = {{0.0f, 0.0f, 0.0f, 0.0f}};
    if (p.feature == FEATURE_DISTANCE_TO_EDGE) {
        p.max_distance = fmaf(0.5f, p.randomness, 0.5f);
        distance = fractal_distance_to_edge(&p, &coord);
    }
    else if (p.feature == FEATURE_N_SPHERE_RADIUS) {
        radius = voronoi_n_sphere_radius(&p, &coord);
    }
    else {
        p.max_distance = voronoi_max_distance(&p);
        voronoi_result r = fractal_voronoi(&p, &coord);
        distance = r.distance;
        for (int c = 0; c < 3; c++)
            color[c] = r.color[c];
        /* safe_divide by the scale, of the float4 position in 4.x, of the
         * dimension's own vector type in 3.x (which rounds differently). */
        const int as_dims = blender3 ? dims : 4;
        for (int c = 0; c < 4; c++)
            position.v[c] = scale != 0.0f ? div_component(r.position.v[c], scale, as_dims) :
                                            0.0f;
    }

    if (out[OUT_DISTANCE])
        out[OUT_DISTANCE][i] = distance;
    if (out[OUT_COLOR])
        f3_store(out[OUT_COLOR], n, i, make_float3(color[0], color[1], color[2]));
    if (out[OUT_POSITION])
        f3_store(out[OUT_POSITION], n, i,
                 make_float3(position.v[0], position.v[1], position.v[2]));
    if (out[OUT_W])
        out[OUT_W][i] = position.v[3];
    if (out[OUT_RADIUS])
        out[OUT_RADIUS][i] = radius;
}

/* ---- F1 and F2 of many points at once ----------------------------------------------
 *
 * The batch kernel evaluates F1 or F2 for LANES points side by side when every one of
 * them needs a single octave (Blender 3.x, or Detail or Roughness 0: the node's
 * defaults). Lane k scans point k's cells in the scalar order with the scalar
 * operations (the same hashes, distance sums in the same order, a strict `<` so the
 * first of equal distances wins), so its results are the bits of voronoi_batch's for
 * that point alone (lanes.h). */
/* voronoi_distance(a, b) per lane; Minkowski's powf one lane at a time. */
static inline lane_f lane_distance(const lane_f *a, const lane_f *b, int dims, int metric,
                                   const float *exponent)
{
    if (dims == 1)
        return lane_abs(b[0] - a[0]);
    lane_f d[4];
    for (int c = 0; c < dims; c++)
        d[c] = a[c] - b[c];
    switch (metric) {
    case METRIC_EUCLIDEAN: {
        /* dot_n's orders: 2D fuses its first product, 3D and 4D do not. */
        lane_f s;
        if (dims == 2)
            s = lane_madd(d[0], d[0], d[1] * d[1]);
        else if (dims == 3)
            s = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        else
            s = (d[0] * d[0] + d[1] * d[1]) + (d[2] * d[2] + d[3] * d[3]);
        return lane_sqrt(s);
    }
    case METRIC_MANHATTAN: {
        lane_f s = lane_abs(d[0]);
        for (int c = 1; c < dims; c++)
            s += lane_abs(d[c]);
        return s;
    }
    case METRIC_CHEBYCHEV: {
        lane_f m = lane_abs(d[dims - 1]);
        for (int c = dims - 2; c >= 0; c--) {
            m = lane_maxf(lane_abs(d[c]), m);
        }
        return m;
    }
    case METRIC_MINKOWSKI: {
        lane_f r;
        for (int k = 0; k < LANES; k++) {
            float s = powf(fabsf(d[0][k]), exponent[k]);
            for (int c = 1; c < dims; c++)
                s += powf(fabsf(d[c][k]), exponent[k]);
            r[k] = powf(s, 1.0f / exponent[k]);
        }
        return r;
    }
    default:
        return lane_splat(0.0f);
    }
}

/* voronoi_f1 (second: voronoi_f2) of each lane's coordinates; position as to_position
 * lays it out. F2 keeps the scalar order of updates: a closer point demotes F1 to F2, a
 * point between the two replaces F2 (strict `<` both times, so ties resolve alike). */
static inline void lane_voronoi_nearest(const voronoi_params *p, const lane_f *coord,
                                        lane_f randomness, const float *exponent, bool second,
                                        lane_f *distance, lane_f *color, lane_f *position)
{
    const int dims = p->dims;
    lane_f cell[4], local[4], zero = lane_splat(0.0f);
    for (int c = 0; c < dims; c++) {
        cell[c] = lane_floor(coord[c]);
        local[c] = coord[c] - cell[c];
    }

    lane_f min_distance = lane_splat(search_start(p)), f2_distance = min_distance;
    lane_f target_offset[4] = {zero, zero, zero, zero}, target_point[4] = {zero, zero, zero, zero};
    lane_f f2_offset[4] = {zero, zero, zero, zero}, f2_point[4] = {zero, zero, zero, zero};
    int o[4] = {-1, -1, -1, -1};
    const int n = scan_count(1, dims);
    for (int idx = 0; idx < n; idx++) {
        lane_f offset[4], pt[4], j[4];
        lane_u key[4];
        for (int c = 0; c < dims; c++) {
            offset[c] = lane_splat((float)o[c]);
            key[c] = (lane_u)(cell[c] + offset[c]);
        }
        lane_cell_hashes(key, dims, j, NULL);
        for (int c = 0; c < dims; c++)
            pt[c] = lane_madd(j[c], randomness, offset[c]);
        lane_f d = lane_distance(pt, local, dims, p->metric, exponent);
        lane_u closer = (lane_u)(d < min_distance);
        if (second) {
            /* voronoi_f2_n's else-if: between F1 and F2, and not closer than F1 */
            lane_u between = (lane_u)(d < f2_distance) & ~closer;
            f2_distance = lane_select(closer, min_distance, lane_select(between, d, f2_distance));
            for (int c = 0; c < dims; c++) {
                f2_offset[c] = lane_select(closer, target_offset[c],
                                           lane_select(between, offset[c], f2_offset[c]));
                f2_point[c] = lane_select(closer, target_point[c],
                                          lane_select(between, pt[c], f2_point[c]));
            }
        }
        min_distance = lane_select(closer, d, min_distance);
        for (int c = 0; c < dims; c++) {
            target_offset[c] = lane_select(closer, offset[c], target_offset[c]);
            target_point[c] = lane_select(closer, pt[c], target_point[c]);
        }
        for (int c = 0; c < dims && ++o[c] > 1; c++)
            o[c] = -1;
    }
    if (second) {
        min_distance = f2_distance;
        for (int c = 0; c < dims; c++) {
            target_offset[c] = f2_offset[c];
            target_point[c] = f2_point[c];
        }
    }

    *distance = min_distance;
    lane_u key[4];
    lane_f abs_point[4] = {zero, zero, zero, zero};
    for (int c = 0; c < dims; c++) {
        key[c] = (lane_u)(cell[c] + target_offset[c]);
        abs_point[c] = target_point[c] + cell[c];
    }
    if (color) {
        lane_f jitter[4];
        lane_cell_hashes(key, dims, jitter, color);
    }
    switch (dims) {
    case 1:
        position[0] = position[1] = position[2] = zero;
        position[3] = abs_point[0];
        break;
    case 2:
        position[0] = abs_point[0];
        position[1] = abs_point[1];
        position[2] = position[3] = zero;
        break;
    case 3:
        for (int c = 0; c < 3; c++)
            position[c] = abs_point[c];
        position[3] = lane_splat(1.0f);
        break;
    default:
        for (int c = 0; c < 4; c++)
            position[c] = abs_point[c];
        break;
    }
}

/* Points first .. first + LANES - 1 of the batch side by side, if they all need
 * F1 or F2 with a single octave; false (nothing written) otherwise. What voronoi_batch computes
 * for each of them. */
static inline bool voronoi_lanes(const sg_kernel_args *a, const voronoi_params *base, int first)
{
    enum { L = LANES };
    const int n = a->n, dims = base->dims;
    if (base->feature != FEATURE_F1 && base->feature != FEATURE_F2)
        return false;
    lane_f coord[4] = {lane_splat(0.0f), lane_splat(0.0f), lane_splat(0.0f), lane_splat(0.0f)};
    lane_f randomness, scale, max_distance;
    float exponent[L];
    for (int k = 0; k < L; k++) {
        voronoi_params p;
        vpoint x;
        float s;
        read_point(a, base, first + k, &p, &x, &s);
        if (!(p.blender3 || p.detail == 0.0f || p.roughness == 0.0f))
            return false; /* several octaves */
        for (int c = 0; c < dims; c++)
            coord[c][k] = x.v[c];
        randomness[k] = p.randomness;
        exponent[k] = p.exponent;
        scale[k] = s;
        max_distance[k] = voronoi_max_distance(&p);
    }

    lane_f distance, color[3], position[4];
    lane_voronoi_nearest(base, coord, randomness, exponent, base->feature == FEATURE_F2,
                         &distance, a->out[OUT_COLOR] ? color : NULL, position);
    /* fractal_voronoi's single octave: max_amplitude 1. */
    if (base->normalize && !base->blender3)
        distance /= 1.0f * max_distance;
    const int as_dims = base->blender3 ? dims : 4;
    const lane_u scaled = (lane_u)(scale != 0.0f);
    for (int c = 0; c < 4; c++) {
        lane_f divided = (as_dims == 2 || as_dims == 4) ? position[c] * (1.0f / scale)
                                                        : position[c] / scale;
        position[c] = lane_select(scaled, divided, lane_splat(0.0f));
    }

    float *const *out = a->out;
    for (int k = 0; k < L; k++) {
        int i = first + k;
        if (out[OUT_DISTANCE])
            out[OUT_DISTANCE][i] = distance[k];
        if (out[OUT_COLOR])
            f3_store(out[OUT_COLOR], n, i, make_float3(color[0][k], color[1][k], color[2][k]));
        if (out[OUT_POSITION])
            f3_store(out[OUT_POSITION], n, i,
                     make_float3(position[0][k], position[1][k], position[2][k]));
        if (out[OUT_W])
            out[OUT_W][i] = position[3][k];
        if (out[OUT_RADIUS])
            out[OUT_RADIUS][i] = 0.0f;
    }
    return true;
}

/* Inlined once per dimension count, so the per-point code sees `dims` as a constant. */
static inline void voronoi_batch(const sg_kernel_args *a, int dims)
{
    const int n = a->n;
    float *const *out = a->out;
    const bool blender3 = a->blender == SG_BLENDER_3;

    voronoi_params base;
    base.dims = dims;
    base.feature = a->prop[PROP_FEATURE];
    base.metric = a->prop[PROP_DISTANCE];
    base.blender3 = blender3;
    base.normalize = a->prop[PROP_NORMALIZE] != 0;
    base.want_color = out[OUT_COLOR] != NULL;

    /* Whole groups side by side where the lanes path applies, the rest point by point;
     * both give the same bits (test_voronoi_batch). A one-point batch, as the pointwise
     * evaluator runs, takes the point path. */
    int i = 0;
    for (; i + LANES <= n; i += LANES)
        if (!voronoi_lanes(a, &base, i))
            for (int k = i; k < i + LANES; k++)
                voronoi_point(a, &base, k);
    for (; i < n; i++)
        voronoi_point(a, &base, i);
}

static void voronoi_kernel_1d(const sg_kernel_args *a) { voronoi_batch(a, 1); }
static void voronoi_kernel_2d(const sg_kernel_args *a) { voronoi_batch(a, 2); }
static void voronoi_kernel_3d(const sg_kernel_args *a) { voronoi_batch(a, 3); }
static void voronoi_kernel_4d(const sg_kernel_args *a) { voronoi_batch(a, 4); }

static void voronoi_kernel(const sg_kernel_args *a)
{
    switch (a->prop[PROP_DIMENSIONS]) {
    case DIM_1D:
        voronoi_kernel_1d(a);
        break;
    case DIM_2D:
        voronoi_kernel_2d(a);
        break;
    case DIM_4D:
        voronoi_kernel_4d(a);
        break;
    default:
        voronoi_kernel_3d(a);
        break;
    }
}

/* ---- node description -------------------------------------------------------------- */

#define BIT(x) (1u << (x))
#define DIMS_VECTOR (BIT(DIM_2D) | BIT(DIM_3D) | BIT(DIM_4D))
#define DIMS_W (BIT(DIM_1D) | BIT(DIM_4D))
#define FEATURES_CELL (BIT(FEATURE_F1) | BIT(FEATURE_F2) | BIT(FEATURE_SMOOTH_F1))
#define FEATURES_FRACTAL (FEATURES_CELL | BIT(FEATURE_DISTANCE_TO_EDGE))

/* Blender 4.3's sockets. Exponent also needs dimensions != 1D in Blender, a third
 * condition the table cannot express; in 1D it is ignored by the kernel anyway. */
static const sg_socket_def voronoi_inputs[] = {
    {"Vector", "Vector", SG_SOCKET_VECTOR, {0.0f, 0.0f, 0.0f, 0.0f}, SG_IMPLICIT_GENERATED,
     DIMS_VECTOR, PROP_DIMENSIONS, 0, 0},
    {"W", "W", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, DIMS_W, PROP_DIMENSIONS, 0, 0},
    {"Scale", "Scale", SG_SOCKET_FLOAT, {5.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
    {"Detail", "Detail", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, FEATURES_FRACTAL,
     PROP_FEATURE, 0, 0},
    {"Roughness", "Roughness", SG_SOCKET_FLOAT, {0.5f}, SG_IMPLICIT_NONE, FEATURES_FRACTAL,
     PROP_FEATURE, 0, 0},
    {"Lacunarity", "Lacunarity", SG_SOCKET_FLOAT, {2.0f}, SG_IMPLICIT_NONE, FEATURES_FRACTAL,
     PROP_FEATURE, 0, 0},
    {"Smoothness", "Smoothness", SG_SOCKET_FLOAT, {1.0f}, SG_IMPLICIT_NONE,
     BIT(FEATURE_SMOOTH_F1), PROP_FEATURE, 0, 0},
    {"Exponent", "Exponent", SG_SOCKET_FLOAT, {0.5f}, SG_IMPLICIT_NONE, BIT(METRIC_MINKOWSKI),
     PROP_DISTANCE, FEATURES_CELL, PROP_FEATURE},
    {"Randomness", "Randomness", SG_SOCKET_FLOAT, {1.0f}, SG_IMPLICIT_NONE, 0, 0, 0, 0},
};

static const sg_socket_def voronoi_outputs[] = {
    {"Distance", "Distance", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, FEATURES_FRACTAL,
     PROP_FEATURE, 0, 0},
    {"Color", "Color", SG_SOCKET_COLOR, {0.0f, 0.0f, 0.0f, 1.0f}, SG_IMPLICIT_NONE,
     FEATURES_CELL, PROP_FEATURE, 0, 0},
    {"Position", "Position", SG_SOCKET_VECTOR, {0.0f}, SG_IMPLICIT_NONE, FEATURES_CELL,
     PROP_FEATURE, DIMS_VECTOR, PROP_DIMENSIONS},
    {"W", "W", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE, FEATURES_CELL, PROP_FEATURE, DIMS_W,
     PROP_DIMENSIONS},
    {"Radius", "Radius", SG_SOCKET_FLOAT, {0.0f}, SG_IMPLICIT_NONE,
     BIT(FEATURE_N_SPHERE_RADIUS), PROP_FEATURE, 0, 0},
};

static const char *const voronoi_dimensions[] = {"1D", "2D", "3D", "4D", NULL};
static const char *const voronoi_metrics[] = {"EUCLIDEAN", "MANHATTAN", "CHEBYCHEV", "MINKOWSKI",
                                              NULL};
static const char *const voronoi_features[] = {"F1", "F2", "SMOOTH_F1", "DISTANCE_TO_EDGE",
                                               "N_SPHERE_RADIUS", NULL};

static const sg_prop_def voronoi_props[] = {
    [PROP_DIMENSIONS] = {"voronoi_dimensions", SG_PROP_ENUM, voronoi_dimensions, DIM_3D},
    [PROP_DISTANCE] = {"distance", SG_PROP_ENUM, voronoi_metrics, METRIC_EUCLIDEAN},
    [PROP_FEATURE] = {"feature", SG_PROP_ENUM, voronoi_features, FEATURE_F1},
    [PROP_NORMALIZE] = {"normalize", SG_PROP_BOOL, NULL, 0},
};

const sg_node_type node_type_tex_voronoi = {
    "ShaderNodeTexVoronoi",
    voronoi_inputs,
    SG_COUNT(voronoi_inputs),
    voronoi_outputs,
    SG_COUNT(voronoi_outputs),
    voronoi_props,
    SG_COUNT(voronoi_props),
    voronoi_kernel,
    0,
};
