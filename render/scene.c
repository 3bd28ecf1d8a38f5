/*
 * The scene file (assets/scene.json, format "imsynth-scene/1") and its Embree geometry.
 *
 * Every field is checked; an error names the file and the JSON path of the bad value.
 * Meshes are given in world space (identity object transform), as polygons of 3 or more
 * vertex indices, fanned into triangles. Generated coordinates follow Blender: the
 * mesh's bounding box mapped to [0, 1], a flat axis at 0.5.
 */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "render/render_internal.h"

typedef struct loader {
    const char *source;
    char *err;
    size_t errlen;
} loader;

static int fail(const loader *ld, const char *fmt, ...)
{
    if (ld->err && ld->errlen) {
        int n = snprintf(ld->err, ld->errlen, "%s: ", ld->source);
        if (n < 0 || (size_t)n >= ld->errlen)
            return -1;
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(ld->err + n, ld->errlen - (size_t)n, fmt, ap);
        va_end(ap);
    }
    return -1;
}

/* Reads an array of exactly n finite numbers. */
static int get_floats(const loader *ld, const cJSON *obj, const char *key, const char *where,
                      float *out, int n)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != n)
        return fail(ld, "%s.%s: expected an array of %d numbers", where, key, n);
    for (int i = 0; i < n; i++) {
        const cJSON *v = cJSON_GetArrayItem(a, i);
        if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble))
            return fail(ld, "%s.%s[%d]: expected a finite number", where, key, i);
        out[i] = (float)v->valuedouble;
    }
    return 0;
}

static int get_float(const loader *ld, const cJSON *obj, const char *key, const char *where,
                     float lo, float *out)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble) || v->valuedouble < lo)
        return fail(ld, "%s.%s: expected a finite number >= %g", where, key, (double)lo);
    *out = (float)v->valuedouble;
    return 0;
}

static int expect_string(const loader *ld, const cJSON *obj, const char *key, const char *where,
                         const char *value)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!cJSON_IsString(v) || strcmp(v->valuestring, value))
        return fail(ld, "%s.%s: expected \"%s\"", where, key, value);
    return 0;
}

static int load_camera(const loader *ld, const cJSON *root, render_scene *s)
{
    const cJSON *c = cJSON_GetObjectItemCaseSensitive(root, "camera");
    if (!cJSON_IsObject(c))
        return fail(ld, "camera: missing object");
    if (expect_string(ld, c, "type", "camera", "ORTHO") < 0)
        return -1;
    ortho_camera *cam = &s->camera;
    float position[3], forward[3], up[3], len;
    if (get_floats(ld, c, "location", "camera", position, 3) < 0 ||
        get_floats(ld, c, "forward", "camera", forward, 3) < 0 ||
        get_floats(ld, c, "up", "camera", up, 3) < 0 ||
        get_float(ld, c, "ortho_scale", "camera", 0.0f, &cam->ortho_scale) < 0)
        return -1;
    if (cam->ortho_scale <= 0.0f)
        return fail(ld, "camera.ortho_scale: must be > 0");
    cam->position = f3_from_floats(position);
    cam->forward = f3_normalize_len(f3_from_floats(forward), &len);
    if (len == 0.0f)
        return fail(ld, "camera.forward: zero vector");
    /* Make up orthogonal to forward; right = forward x up. */
    cam->up = f3_from_floats(up);
    cam->up = f3_sub(cam->up, f3_scale(cam->forward, f3_dot(cam->forward, cam->up)));
    cam->up = f3_normalize_len(cam->up, &len);
    if (len < 1e-6f)
        return fail(ld, "camera.up: parallel to camera.forward");
    cam->right = f3_cross(cam->forward, cam->up);
    return 0;
}

/* d_obj = R^T d, for directions and differentials; identity (a copy) without a
 * transform. Not inlined: inlined into render_shading_geometry, GCC 12 (-march=native,
 * AVX-512) merges the no-transform copies into one 256-bit store and returns without
 * vzeroupper, and the dirty upper state then makes every later non-VEX SSE routine
 * (glibc's fminf, called per camera sample in render.c) pay an AVX-SSE transition:
 * 15% of a frame. */
__attribute__((noinline)) static float3 world_to_object_vector(const render_mesh *m, float3 d)
{
    if (!m->has_transform)
        return d;
    const float *R = m->rotation;
    return make_float3(R[0] * d.x + R[3] * d.y + R[6] * d.z, R[1] * d.x + R[4] * d.y + R[7] * d.z,
                       R[2] * d.x + R[5] * d.y + R[8] * d.z);
}

/* o = R^T (p - t). */
static float3 world_to_object_point(const render_mesh *m, float3 p)
{
    if (!m->has_transform)
        return p;
    return world_to_object_vector(m, f3_sub(p, f3_from_floats(m->location)));
}

/* "transform": {"location": [x, y, z], "rotation_euler": [rx, ry, rz]} (radians, Blender's
 * XYZ order: R = Rz Ry Rx), both optional. */
static int load_transform(const loader *ld, const cJSON *o, const char *where, render_mesh *m)
{
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(o, "transform");
    m->has_transform = 0;
    if (!t)
        return 0;
    char w[96];
    snprintf(w, sizeof w, "%s.transform", where);
    if (!cJSON_IsObject(t))
        return fail(ld, "%s: expected an object with location and rotation_euler", w);
    float loc[3] = {0, 0, 0}, rot[3] = {0, 0, 0};
    if (cJSON_GetObjectItemCaseSensitive(t, "location") &&
        get_floats(ld, t, "location", w, loc, 3) < 0)
        return -1;
    if (cJSON_GetObjectItemCaseSensitive(t, "rotation_euler") &&
        get_floats(ld, t, "rotation_euler", w, rot, 3) < 0)
        return -1;
    double cx = cos(rot[0]), sx = sin(rot[0]), cy = cos(rot[1]), sy = sin(rot[1]);
    double cz = cos(rot[2]), sz = sin(rot[2]);
    double R[9] = {cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx,
                   sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx,
                   -sy,     cy * sx,                cy * cx};
    for (int k = 0; k < 9; k++)
        m->rotation[k] = (float)R[k];
    memcpy(m->location, loc, sizeof loc);
    m->has_transform = 1;
    return 0;
}

static int load_mesh(const loader *ld, const cJSON *o, int index, render_mesh *m)
{
    char where[64];
    snprintf(where, sizeof where, "objects[%d]", index);
    if (expect_string(ld, o, "type", where, "MESH") < 0)
        return -1;
    const cJSON *verts = cJSON_GetObjectItemCaseSensitive(o, "vertices");
    const cJSON *uvs = cJSON_GetObjectItemCaseSensitive(o, "uv");
    const cJSON *faces = cJSON_GetObjectItemCaseSensitive(o, "faces");
    if (!cJSON_IsArray(verts) || cJSON_GetArraySize(verts) < 3)
        return fail(ld, "%s.vertices: expected an array of at least 3 [x, y, z]", where);
    if (!cJSON_IsArray(faces) || cJSON_GetArraySize(faces) < 1)
        return fail(ld, "%s.faces: expected an array of polygons", where);
    int nv = cJSON_GetArraySize(verts);
    if (uvs && (!cJSON_IsArray(uvs) || cJSON_GetArraySize(uvs) != nv))
        return fail(ld, "%s.uv: expected one [u, v] per vertex (%d)", where, nv);
    m->n_vertices = nv;
    m->vertices = malloc(sizeof(float) * 3 * (size_t)nv);
    m->uv = uvs ? malloc(sizeof(float) * 2 * (size_t)nv) : NULL;
    if (!m->vertices || (uvs && !m->uv))
        return fail(ld, "out of memory");
    for (int i = 0; i < nv; i++) {
        char w[96];
        snprintf(w, sizeof w, "%s.vertices[%d]", where, i);
        const cJSON *e = cJSON_GetArrayItem(verts, i);
        if (!cJSON_IsArray(e) || cJSON_GetArraySize(e) != 3)
            return fail(ld, "%s: expected [x, y, z]", w);
        for (int k = 0; k < 3; k++) {
            const cJSON *v = cJSON_GetArrayItem(e, k);
            if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble))
                return fail(ld, "%s[%d]: expected a finite number", w, k);
            m->vertices[3 * i + k] = (float)v->valuedouble;
        }
        if (uvs) {
            e = cJSON_GetArrayItem(uvs, i);
            if (!cJSON_IsArray(e) || cJSON_GetArraySize(e) != 2)
                return fail(ld, "%s.uv[%d]: expected [u, v]", where, i);
            for (int k = 0; k < 2; k++) {
                const cJSON *v = cJSON_GetArrayItem(e, k);
                if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble))
                    return fail(ld, "%s.uv[%d][%d]: expected a finite number", where, i, k);
                m->uv[2 * i + k] = (float)v->valuedouble;
            }
        }
    }
    int nf = cJSON_GetArraySize(faces), nt = 0;
    for (int f = 0; f < nf; f++) {
        const cJSON *poly = cJSON_GetArrayItem(faces, f);
        if (!cJSON_IsArray(poly) || cJSON_GetArraySize(poly) < 3)
            return fail(ld, "%s.faces[%d]: expected at least 3 vertex indices", where, f);
        nt += cJSON_GetArraySize(poly) - 2;
    }
    m->n_triangles = nt;
    m->triangles = malloc(sizeof(unsigned) * 3 * (size_t)nt);
    if (!m->triangles)
        return fail(ld, "out of memory");
    int t = 0;
    for (int f = 0; f < nf; f++) {
        const cJSON *poly = cJSON_GetArrayItem(faces, f);
        int n = cJSON_GetArraySize(poly);
        unsigned idx[3];
        for (int i = 0; i < n; i++) {
            const cJSON *v = cJSON_GetArrayItem(poly, i);
            /* The range first: converting a double outside int's range is undefined. */
            if (!cJSON_IsNumber(v) || !(v->valuedouble >= 0 && v->valuedouble < nv) ||
                v->valuedouble != floor(v->valuedouble))
                return fail(ld, "%s.faces[%d][%d]: expected a vertex index in [0, %d)", where,
                            f, i, nv);
            unsigned vi = (unsigned)v->valueint;
            if (i == 0)
                idx[0] = vi;
            else if (i == 1)
                idx[1] = vi;
            else {
                /* Fan: (0, i-1, i), Blender's split for a convex quad along 0-2. */
                idx[2] = vi;
                memcpy(&m->triangles[3 * t], idx, sizeof idx);
                t++;
                idx[1] = vi;
            }
        }
    }
    if (load_transform(ld, o, where, m) < 0)
        return -1;
    m->object_vertices = malloc(sizeof(float) * 3 * (size_t)nv);
    if (!m->object_vertices)
        return fail(ld, "out of memory");
    for (int i = 0; i < nv; i++)
        f3_to_floats(world_to_object_point(m, f3_from_floats(&m->vertices[3 * i])),
                     &m->object_vertices[3 * i]);
    for (int k = 0; k < 3; k++) {
        m->bbox_min[k] = INFINITY;
        m->bbox_max[k] = -INFINITY;
    }
    for (int i = 0; i < nv; i++)
        for (int k = 0; k < 3; k++) {
            m->bbox_min[k] = fminf(m->bbox_min[k], m->object_vertices[3 * i + k]);
            m->bbox_max[k] = fmaxf(m->bbox_max[k], m->object_vertices[3 * i + k]);
        }
    return 0;
}

static int load_light(const loader *ld, const cJSON *o, int index, point_light *l)
{
    char where[64];
    snprintf(where, sizeof where, "lights[%d]", index);
    if (expect_string(ld, o, "type", where, "POINT") < 0)
        return -1;
    float power = 0.0f, color[3] = {0, 0, 0}, position[3];
    if (get_floats(ld, o, "location", where, position, 3) < 0 ||
        get_float(ld, o, "radius", where, 0.0f, &l->radius) < 0 ||
        get_float(ld, o, "power", where, 0.0f, &power) < 0 ||
        get_floats(ld, o, "color", where, color, 3) < 0)
        return -1;
    if (l->radius <= 0.0f)
        return fail(ld, "%s.radius: must be > 0 (a point light without size is not supported)",
                    where);
    l->position = f3_from_floats(position);
    for (int k = 0; k < 3; k++) {
        if (color[k] < 0.0f)
            return fail(ld, "%s.color[%d]: must be >= 0", where, k);
        /* Watts -> radiance: intensity power / (4 pi) over the area pi r^2. */
        l->radiance[k] = power * color[k] /
                         (4.0f * (float)M_PI * (float)M_PI * l->radius * l->radius);
    }
    const cJSON *sf = cJSON_GetObjectItemCaseSensitive(o, "soft_falloff");
    if (sf && !cJSON_IsBool(sf))
        return fail(ld, "%s.soft_falloff: expected true or false", where);
    l->soft_falloff = sf ? cJSON_IsTrue(sf) : 1; /* Blender's default */
    l->sphere = 0;
    return 0;
}

static int build_embree(const loader *ld, render_scene *s)
{
    s->device = rtcNewDevice("threads=1");
    if (!s->device)
        return fail(ld, "Embree: cannot create a device (error %d)", (int)rtcGetDeviceError(NULL));
    s->rtc = rtcNewScene(s->device);
    for (int i = 0; i < s->n_meshes; i++) {
        const render_mesh *m = &s->meshes[i];
        RTCGeometry geom = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_TRIANGLE);
        float *vb = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                            3 * sizeof(float), (size_t)m->n_vertices);
        unsigned *ib = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                               3 * sizeof(unsigned), (size_t)m->n_triangles);
        if (!vb || !ib) {
            rtcReleaseGeometry(geom);
            return fail(ld, "Embree: cannot allocate buffers for objects[%d]", i);
        }
        memcpy(vb, m->vertices, sizeof(float) * 3 * (size_t)m->n_vertices);
        memcpy(ib, m->triangles, sizeof(unsigned) * 3 * (size_t)m->n_triangles);
        rtcCommitGeometry(geom);
        rtcAttachGeometryByID(s->rtc, geom, (unsigned)i); /* geomID = mesh index */
        rtcReleaseGeometry(geom);
    }
    rtcCommitScene(s->rtc);
    if (rtcGetDeviceError(s->device) != RTC_ERROR_NONE)
        return fail(ld, "Embree: error building the scene");
    return 0;
}

static int load_root(const loader *ld, const cJSON *root, render_scene *s)
{
    if (!cJSON_IsObject(root))
        return fail(ld, "not a JSON object");
    if (expect_string(ld, root, "format", "(top level)", "imsynth-scene/1") < 0)
        return -1;
    float res[2];
    if (get_floats(ld, root, "resolution", "(top level)", res, 2) < 0)
        return -1;
    if (res[0] < 1 || res[1] < 1 || res[0] > 16384 || res[1] > 16384 || res[0] != (int)res[0] ||
        res[1] != (int)res[1])
        return fail(ld, "resolution: expected two integers in [1, 16384]");
    s->camera.width = (int)res[0];
    s->camera.height = (int)res[1];
    if (load_camera(ld, root, s) < 0)
        return -1;

    const cJSON *film = cJSON_GetObjectItemCaseSensitive(root, "film");
    s->filter_width = 1.5f;
    if (film) {
        if (expect_string(ld, film, "filter", "film", "BLACKMAN_HARRIS") < 0 ||
            get_float(ld, film, "filter_width", "film", 0.0f, &s->filter_width) < 0)
            return -1;
        if (s->filter_width < 0.01f)
            return fail(ld, "film.filter_width: must be >= 0.01 px");
    }

    const cJSON *objs = cJSON_GetObjectItemCaseSensitive(root, "objects");
    if (!cJSON_IsArray(objs) || cJSON_GetArraySize(objs) < 1)
        return fail(ld, "objects: expected a non-empty array");
    s->n_meshes = cJSON_GetArraySize(objs);
    s->meshes = calloc((size_t)s->n_meshes, sizeof *s->meshes);
    if (!s->meshes)
        return fail(ld, "out of memory");
    for (int i = 0; i < s->n_meshes; i++)
        if (load_mesh(ld, cJSON_GetArrayItem(objs, i), i, &s->meshes[i]) < 0)
            return -1;

    const cJSON *lights = cJSON_GetObjectItemCaseSensitive(root, "lights");
    if (lights && !cJSON_IsArray(lights))
        return fail(ld, "lights: expected an array");
    s->n_lights = lights ? cJSON_GetArraySize(lights) : 0;
    if (s->n_lights > 1)
        return fail(ld, "lights: at most one light is supported (got %d)", s->n_lights);
    s->lights = calloc((size_t)s->n_lights + 1, sizeof *s->lights);
    if (!s->lights)
        return fail(ld, "out of memory");
    for (int i = 0; i < s->n_lights; i++)
        if (load_light(ld, cJSON_GetArrayItem(lights, i), i, &s->lights[i]) < 0)
            return -1;

    const cJSON *world = cJSON_GetObjectItemCaseSensitive(root, "world");
    if (!cJSON_IsObject(world))
        return fail(ld, "world: missing object");
    float color[3] = {0, 0, 0}, strength = 0.0f;
    if (get_floats(ld, world, "color", "world", color, 3) < 0 ||
        get_float(ld, world, "strength", "world", 0.0f, &strength) < 0)
        return -1;
    for (int k = 0; k < 3; k++) {
        if (color[k] < 0.0f)
            return fail(ld, "world.color[%d]: must be >= 0", k);
        s->world[k] = color[k] * strength;
    }
    return build_embree(ld, s);
}

render_scene *render_scene_load_json(const char *text, size_t len, const char *source_name,
                                     char *err, size_t errlen)
{
    loader ld = {source_name ? source_name : "(scene)", err, errlen};
    cJSON *root = cJSON_ParseWithLength(text, len);
    if (!root) {
        const char *at = cJSON_GetErrorPtr();
        long off = at && at >= text && at <= text + len ? (long)(at - text) : -1;
        fail(&ld, "invalid JSON near byte %ld", off);
        return NULL;
    }
    render_scene *s = calloc(1, sizeof *s);
    if (!s) {
        cJSON_Delete(root);
        fail(&ld, "out of memory");
        return NULL;
    }
    int rc = load_root(&ld, root, s);
    cJSON_Delete(root);
    if (rc < 0) {
        render_scene_free(s);
        return NULL;
    }
    return s;
}

render_scene *render_scene_load(const char *path, char *err, size_t errlen)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return NULL;
    }
    char *buf = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (len + 4096 > cap) {
            cap = cap ? 2 * cap : 65536;
            char *nb = realloc(buf, cap);
            if (!nb) {
                free(buf);
                fclose(f);
                snprintf(err, errlen, "%s: out of memory", path);
                return NULL;
            }
            buf = nb;
        }
        size_t n = fread(buf + len, 1, cap - len, f);
        len += n;
        if (n == 0)
            break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        snprintf(err, errlen, "%s: read error", path);
        return NULL;
    }
    render_scene *s = render_scene_load_json(buf, len, path, err, errlen);
    free(buf);
    return s;
}

void render_scene_free(render_scene *s)
{
    if (!s)
        return;
    if (s->rtc)
        rtcReleaseScene(s->rtc);
    if (s->device)
        rtcReleaseDevice(s->device);
    for (int i = 0; i < s->n_meshes; i++) {
        free(s->meshes[i].vertices);
        free(s->meshes[i].object_vertices);
        free(s->meshes[i].uv);
        free(s->meshes[i].triangles);
    }
    free(s->meshes);
    free(s->lights);
    free(s);
}

void render_scene_resolution(const render_scene *s, int *width, int *height)
{
    *width = s->camera.width;
    *height = s->camera.height;
}

/* Derivative of a per-vertex attribute along a world-space offset on the triangle:
 * solve offset = a e1 + b e2 in the triangle's plane (least squares), then the attribute
 * changes by a (A1 - A0) + b (A2 - A0). */
static float3 attribute_differential(float3 e1, float3 e2, float3 dA1, float3 dA2, float3 off)
{
    float a11 = f3_dot(e1, e1), a12 = f3_dot(e1, e2), a22 = f3_dot(e2, e2);
    float b1 = f3_dot(e1, off), b2 = f3_dot(e2, off);
    float det = a11 * a22 - a12 * a12;
    float a = 0.0f, b = 0.0f;
    if (det != 0.0f) {
        a = (b1 * a22 - b2 * a12) / det;
        b = (a11 * b2 - a12 * b1) / det;
    }
    return f3_add(f3_scale(dA1, a), f3_scale(dA2, b));
}

/* The barycentric interpolation bw A0 + bu A1 + bv A2, summed in that order. */
static float3 interpolate(float bw, float bu, float bv, float3 a0, float3 a1, float3 a2)
{
    return f3_add(f3_add(f3_scale(a0, bw), f3_scale(a1, bu)), f3_scale(a2, bv));
}

void render_shading_geometry(const render_scene *s, int mesh, unsigned prim, float bu, float bv,
                             float3 D, float dP, shading_geometry *g)
{
    const render_mesh *m = &s->meshes[mesh];
    const unsigned *tri = &m->triangles[3 * prim];
    float3 v0 = f3_from_floats(&m->vertices[3 * tri[0]]),
           v1 = f3_from_floats(&m->vertices[3 * tri[1]]),
           v2 = f3_from_floats(&m->vertices[3 * tri[2]]);
    float bw = 1.0f - bu - bv, len;
    g->P = interpolate(bw, bu, bv, v0, v1, v2);
    float3 e1 = f3_sub(v1, v0), e2 = f3_sub(v2, v0);
    g->Ng = f3_normalize_len(f3_cross(e1, e2), &len);
    /* Cycles flips nothing for a single-sided view here: the plane faces the camera.
     * A back-facing hit keeps its geometric normal; the BSDF sees wo below it. */
    g->N = g->Ng;
    g->I = f3_neg(D);
    float3 a, b;
    render_make_orthonormals(g->Ng, &a, &b);
    g->dPdx = f3_scale(a, dP);
    g->dPdy = f3_scale(b, dP);
    /* Object space: the transform's inverse (a copy without one). */
    g->object = world_to_object_point(m, g->P);
    g->dobject_dx = world_to_object_vector(m, g->dPdx);
    g->dobject_dy = world_to_object_vector(m, g->dPdy);
    g->object_normal = world_to_object_vector(m, g->N);
    /* Generated: the object-space bounding box to [0, 1], a flat axis at 0.5. */
    float gen[3][3], uv[3][3];
    const float *vs[3] = {&m->object_vertices[3 * tri[0]], &m->object_vertices[3 * tri[1]],
                          &m->object_vertices[3 * tri[2]]};
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < 3; k++) {
            float ext = m->bbox_max[k] - m->bbox_min[k];
            gen[c][k] = ext > 0.0f ? (vs[c][k] - m->bbox_min[k]) / ext : 0.5f;
            uv[c][k] = (m->uv && k < 2) ? m->uv[2 * tri[c] + k] : 0.0f;
        }
    float3 gen0 = f3_from_floats(gen[0]), gen1 = f3_from_floats(gen[1]),
           gen2 = f3_from_floats(gen[2]);
    float3 uv0 = f3_from_floats(uv[0]), uv1 = f3_from_floats(uv[1]), uv2 = f3_from_floats(uv[2]);
    g->generated = interpolate(bw, bu, bv, gen0, gen1, gen2);
    g->uv = interpolate(bw, bu, bv, uv0, uv1, uv2);
    float3 dgen1 = f3_sub(gen1, gen0), dgen2 = f3_sub(gen2, gen0);
    float3 duv1 = f3_sub(uv1, uv0), duv2 = f3_sub(uv2, uv0);
    g->dgenerated_dx = attribute_differential(e1, e2, dgen1, dgen2, g->dPdx);
    g->dgenerated_dy = attribute_differential(e1, e2, dgen1, dgen2, g->dPdy);
    g->duv_dx = attribute_differential(e1, e2, duv1, duv2, g->dPdx);
    g->duv_dy = attribute_differential(e1, e2, duv1, duv2, g->dPdy);
}
