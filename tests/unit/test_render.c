/*
 * The renderer's pieces, each against an independent statement of what it must do:
 * - camera + shading geometry: a ray through a pixel centre hits the point, normal,
 *   Generated/UV coordinates and differentials that shadergraph's sg_plane_geometry
 *   (the node references' geometry, checked against Blender) gives for that pixel;
 * - pixel filter: sampled offsets follow the Blackman-Harris density of full width
 *   2 x 1.5 px (Kolmogorov-Smirnov distance to the closed-form CDF);
 * - sampler and permutations: uniform, independent of call order, bijective;
 * - light: the irradiance its samples estimate equals the analytic value (on the axis of
 *   the facing disk exactly; off axis the small-sphere law), and BSDF-sampled hits
 *   estimate the same integral as light samples (pdfs consistent);
 * - scene file errors name the file and the place;
 * - whole renders: identical bits for 1, 2 and 3 threads; fast and reference modes agree
 *   to within their noise.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include <math.h>

#include "render/render_internal.h"

static render_scene *load_scene(void)
{
    char err[512];
    render_scene *s = render_scene_load(IMSYNTH_SOURCE_DIR "/assets/scene.json", err, sizeof err);
    if (!s)
        fail_msg("%s", err);
    return s;
}

/* The scene file's text with `from` replaced by `to` (same length), or fail. */
static size_t edited_scene(char *text, size_t cap, const char *from, const char *to)
{
    FILE *f = fopen(IMSYNTH_SOURCE_DIR "/assets/scene.json", "rb");
    assert_non_null(f);
    size_t len = fread(text, 1, cap - 1, f);
    fclose(f);
    text[len] = 0;
    char *at = strstr(text, from);
    assert_non_null(at);
    assert_int_equal(strlen(from), strlen(to));
    memcpy(at, to, strlen(to));
    return len;
}

static void test_camera_hits_pixel_centres(void **state)
{
    (void)state;
    render_scene *s = load_scene();
    int w = s->camera.width, h = s->camera.height;
    assert_int_equal(w, 256);
    assert_int_equal(h, 256);
    int n = w; /* one row at a time */
    float *storage = malloc(sizeof(float) * 48 * (size_t)n);
    assert_non_null(storage);
    int rows[] = {0, 77, 128, 255};
    for (int r = 0; r < 4; r++) {
        int py = rows[r];
        sg_geometry_batch gb;
        sg_plane_geometry(w, h, py * w, n, storage, &gb);
        for (int px = 0; px < w; px += 5) {
            float3 P, D;
            float dP;
            ortho_camera_ray(&s->camera, (float)px + 0.5f, (float)py + 0.5f, &P, &D, &dP);
            struct RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            struct RTCRayHit rh;
            memset(&rh, 0, sizeof rh);
            rh.ray.org_x = P.x, rh.ray.org_y = P.y, rh.ray.org_z = P.z;
            rh.ray.dir_x = D.x, rh.ray.dir_y = D.y, rh.ray.dir_z = D.z;
            rh.ray.tfar = INFINITY;
            rh.ray.mask = 0xffffffffu;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(s->rtc, &ctx, &rh);
            assert_int_equal(rh.hit.geomID, 0);
            assert_true(fabsf(rh.ray.tfar - 2.0f) < 1e-5f);
            shading_geometry g;
            render_shading_geometry(s, 0, rh.hit.primID, rh.hit.u, rh.hit.v, D, dP, &g);
            const float3 mine3[] = {g.P, g.dPdx, g.dPdy, g.N, g.Ng, g.I, g.generated,
                                    g.dgenerated_dx, g.dgenerated_dy, g.uv, g.duv_dx, g.duv_dy};
            const float *theirs[] = {gb.P, gb.dPdx, gb.dPdy, gb.N, gb.Ng, gb.I, gb.generated,
                                     gb.dgenerated_dx, gb.dgenerated_dy, gb.uv, gb.duv_dx,
                                     gb.duv_dy};
            for (int f = 0; f < 12; f++)
                for (int c = 0; c < 3; c++) {
                    float a = c == 0 ? mine3[f].x : c == 1 ? mine3[f].y : mine3[f].z, b = theirs[f][(size_t)c * (size_t)n + (size_t)px];
                    if (fabsf(a - b) > 2e-6f)
                        fail_msg("pixel (%d,%d) field %d[%d]: ours %.8g, plane %.8g", px, py,
                                 f, c, (double)a, (double)b);
                }
        }
    }
    free(storage);
    render_scene_free(s);
}

/* CDF of the Blackman-Harris window of full width W at offset x (closed form). */
static double bh_cdf(double x, double W)
{
    double v = 2.0 * M_PI * (x / W + 0.5);
    double F = 0.35875 * v - 0.48829 * sin(v) + 0.14128 * sin(2 * v) / 2 -
               0.01168 * sin(3 * v) / 3;
    return F / (0.35875 * 2.0 * M_PI);
}

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

static void test_filter_distribution(void **state)
{
    (void)state;
    pixel_filter f;
    pixel_filter_init(&f, 1.5f);
    enum { N = 200000 };
    float *x = malloc(sizeof(float) * N);
    assert_non_null(x);
    for (int i = 0; i < N; i++)
        x[i] = pixel_filter_sample(&f, render_random(7, (uint32_t)i, 0, DIM_FILTER_X));
    qsort(x, N, sizeof(float), cmp_float);
    assert_true(x[0] >= -1.5f && x[N - 1] <= 1.5f);
    double ks = 0.0;
    for (int i = 0; i < N; i++) {
        double F = bh_cdf(x[i], 3.0);
        ks = fmax(ks, fmax(fabs(F - (double)i / N), fabs(F - (double)(i + 1) / N)));
    }
    /* 1.63 / sqrt(N) is the 1% critical value of the KS statistic. */
    if (ks > 1.63 / sqrt((double)N))
        fail_msg("KS distance %.5f", ks);
    /* A narrower window (width not doubled) would put ~all samples within +-0.75 px. */
    int outside = 0;
    for (int i = 0; i < N; i++)
        outside += fabsf(x[i]) > 0.75f;
    double expect = 2.0 * bh_cdf(-0.75, 3.0);
    assert_true(fabs((double)outside / N - expect) < 0.01);
    /* Symmetric, centred, monotone table. */
    assert_true(fabsf(pixel_filter_sample(&f, 0.5f)) < 1e-4f);
    for (int i = 1; i < FILTER_TABLE_SIZE; i++)
        assert_true(f.table[i] >= f.table[i - 1]);
    /* The window (the density times its integral, a0 x the full width) peaks at 1. */
    assert_true(pixel_filter_density(&f, 0.0f) * (0.35875f * 3.0f) > 0.99f &&
                pixel_filter_density(&f, 1.6f) == 0.0f);
    free(x);
}

/* The fast mode's film weights: the density integrates to 1 and its CDF is the closed
 * form's. */
static void test_filter_density(void **state)
{
    (void)state;
    pixel_filter f;
    pixel_filter_init(&f, 1.5f);
    enum { N = 30000 };
    double sum = 0.0;
    for (int i = 0; i < N; i++) {
        double x = -2.0 + (i + 0.5) * 4.0 / N;
        float d = pixel_filter_density(&f, (float)x);
        assert_true(d >= 0.0f);
        assert_true(fabsf(d - pixel_filter_density(&f, (float)-x)) < 1e-6f);
        sum += d * 4.0 / N;
        if (i % 1000 == 0) /* the running integral is the CDF */
            assert_true(fabs(pixel_filter_cdf(&f, x + 2.0 / N) - sum) < 1e-5);
    }
    assert_true(fabs(sum - 1.0) < 1e-5);
    for (double x = -1.6; x <= 1.6; x += 0.1)
        assert_true(fabs(pixel_filter_cdf(&f, x) - (fabs(x) >= 1.5 ? (x > 0) : bh_cdf(x, 3.0))) <
                    1e-9);
}

static void test_sampler(void **state)
{
    (void)state;
    /* Uniform: mean and variance of many draws across all coordinates. */
    double sum = 0, sum2 = 0;
    int n = 0;
    for (uint32_t p = 0; p < 200; p++)
        for (uint32_t s = 0; s < 50; s++)
            for (uint32_t d = 0; d < DIM_COUNT; d++) {
                float u = render_random(3, p, s, d);
                assert_true(u >= 0.0f && u < 1.0f);
                sum += u, sum2 += (double)u * u, n++;
            }
    double mean = sum / n, var = sum2 / n - mean * mean;
    assert_true(fabs(mean - 0.5) < 0.01);
    assert_true(fabs(var - 1.0 / 12) < 0.003);
    /* Pure function of the coordinates; seeds differ. */
    assert_true(render_random(3, 10, 2, 1) == render_random(3, 10, 2, 1));
    assert_true(render_random(3, 10, 2, 1) != render_random(4, 10, 2, 1));
    /* Adjacent dimensions are uncorrelated. */
    double c = 0;
    for (uint32_t p = 0; p < 20000; p++)
        c += (render_random(1, p, 0, 0) - 0.5) * (render_random(1, p, 0, 1) - 0.5);
    assert_true(fabs(c / 20000) < 0.005);
    /* Permutations are bijections of [0, n). */
    for (uint32_t m = 1; m <= 70; m += 3) {
        int seen[70] = {0};
        for (uint32_t i = 0; i < m; i++) {
            uint32_t j = render_permute(i, m, 12345 + m);
            assert_true(j < m);
            seen[j]++;
        }
        for (uint32_t i = 0; i < m; i++)
            assert_int_equal(seen[i], 1);
    }
}

static void test_light_irradiance(void **state)
{
    (void)state;
    point_light l = {{0.45f, 0.35f, 0.55f}, 0.1f, {1.0f, 1.0f, 1.0f}, 1, 0};
    float Le = 9.25f / (4.0f * (float)M_PI * (float)M_PI * 0.01f);
    for (int k = 0; k < 3; k++)
        l.radiance[k] = Le;
    for (int sphere = 0; sphere < 2; sphere++) {
        l.sphere = sphere;
        /* Directly below: the facing disk's irradiance is Le pi r^2 / (d^2 + r^2); the
         * sphere's is Le pi r^2 / d^2 (its cone, sin^2 = r^2/d^2). */
        float3 P = make_float3(0.45f, 0.35f, 0.0f), N = make_float3(0, 0, 1);
        double E = 0.0;
        enum { S = 200000 };
        for (int i = 0; i < S; i++) {
            light_sample ls;
            if (point_light_sample(&l, P, render_random(1, 0, (uint32_t)i, 0),
                                   render_random(1, 0, (uint32_t)i, 1), &ls))
                E += Le * fmaxf(0.0f, f3_dot(ls.wi, N)) / ls.pdf;
        }
        E /= S;
        double d2 = 0.55 * 0.55, r2 = 0.01;
        double exact = sphere ? Le * M_PI * r2 / d2 : Le * M_PI * r2 / (d2 + r2);
        /* (Both are Le pi sin^2(alpha) cos(theta) for the cone of half-angle alpha the
         * light subtends; the disk faces the point, so the point is on its axis.) */
        if (fabs(E - exact) > 1e-3 * exact)
            fail_msg("%s: irradiance %.6f, analytic %.6f", sphere ? "sphere" : "disk", E,
                     exact);
        /* Power convention: far away the light is a point of intensity P / (4 pi). */
        double point = 9.25 / (4 * M_PI) / d2;
        assert_true(fabs(E - point) < 0.04 * point);

        /* Off axis: light sampling and cosine-sampled BSDF rays that hit the light
         * estimate the same integral. */
        float3 Q = make_float3(-0.3f, 0.1f, 0.0f);
        double El = 0, Eb = 0;
        for (int i = 0; i < S; i++) {
            light_sample ls;
            if (point_light_sample(&l, Q, render_random(2, 0, (uint32_t)i, 0),
                                   render_random(2, 0, (uint32_t)i, 1), &ls))
                El += Le * fmaxf(0.0f, f3_dot(ls.wi, N)) / ls.pdf;
        }
        enum { SB = 4000000 };
        for (int i = 0; i < SB; i++) {
            float u1 = render_random(3, 0, (uint32_t)i, 0), u2 = render_random(3, 0, (uint32_t)i, 1);
            float rr = sqrtf(u1), phi = 2.0f * (float)M_PI * u2;
            float3 wi = make_float3(rr * cosf(phi), rr * sinf(phi), sqrtf(fmaxf(0.0f, 1.0f - u1)));
            float t, pdf;
            if (point_light_intersect(&l, Q, wi, &t, &pdf))
                Eb += Le * M_PI; /* f_cos / pdf for cosine sampling is pi */
        }
        El /= S, Eb /= SB;
        /* Exact: a uniform cone of half-angle alpha around axis a, wholly above the
         * surface, gives integral of cos = pi sin^2(alpha) (a . N). */
        float3 dv = f3_sub(l.position, Q);
        double dd = f3_dot(dv, dv), cosq = dv.z / sqrt(dd);
        double sin2 = sphere ? r2 / dd : r2 / (dd + r2);
        double exact_q = Le * M_PI * sin2 * cosq;
        if (fabs(El - exact_q) > 2e-3 * exact_q || fabs(Eb - El) > 0.01 * El)
            fail_msg("%s off axis: light %.6f, bsdf %.6f, analytic %.6f",
                     sphere ? "sphere" : "disk", El, Eb, exact_q);
    }
}

static void test_scene_errors(void **state)
{
    (void)state;
    char err[512];
    const char *bad[][2] = {
        {"{\"format\": \"imsynth-scene/1\"}", "resolution"},
        {"{\"format\": \"x\"}", "format"},
        {"[1,", "invalid JSON"},
    };
    for (int i = 0; i < 3; i++) {
        render_scene *s = render_scene_load_json(bad[i][0], strlen(bad[i][0]), "bad.json", err,
                                                 sizeof err);
        assert_null(s);
        assert_non_null(strstr(err, "bad.json"));
        assert_non_null(strstr(err, bad[i][1]));
    }
    /* A bad face index deep inside is named by its path. */
    char text[4096];
    size_t len = edited_scene(text, sizeof text, "[[0, 1, 2, 3]]", "[[0, 1, 2, 9]]");
    render_scene *s = render_scene_load_json(text, len, "scene.json", err, sizeof err);
    assert_null(s);
    assert_non_null(strstr(err, "objects[0].faces[0][3]"));
    assert_null(render_scene_load("/nonexistent/scene.json", err, sizeof err));
    assert_non_null(strstr(err, "/nonexistent/scene.json"));
}

static const char *const graph_json =
    "{\"format\": \"imsynth-graph/1\", \"name\": \"t\", \"nodes\": ["
    "{\"name\": \"Noise\", \"type\": \"ShaderNodeTexNoise\", \"location\": [-300, 0],"
    " \"inputs\": {\"Scale\": 8.0}},"
    "{\"name\": \"Principled BSDF\", \"type\": \"ShaderNodeBsdfPrincipled\","
    " \"location\": [0, 0], \"inputs\": {\"Roughness\": 0.4}},"
    "{\"name\": \"Material Output\", \"type\": \"ShaderNodeOutputMaterial\","
    " \"location\": [300, 0]}],"
    " \"links\": [{\"from_node\": \"Noise\", \"from_socket\": \"Color\","
    " \"to_node\": \"Principled BSDF\", \"to_socket\": \"Base Color\"},"
    "{\"from_node\": \"Principled BSDF\", \"from_socket\": \"BSDF\","
    " \"to_node\": \"Material Output\", \"to_socket\": \"Surface\"}]}";

static render_material *test_material(int blender)
{
    char e[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_json(graph_json, strlen(graph_json), "test", e, sizeof e);
    if (!g)
        fail_msg("%s", e);
    char err[512];
    render_material *m = render_material_new(g, blender, err, sizeof err);
    sg_graph_free(g);
    if (!m)
        fail_msg("%s", err);
    return m;
}

static void test_threads_do_not_change_bits(void **state)
{
    (void)state;
    render_scene *s = load_scene();
    render_material *m = test_material(4);
    char err[512];
    /* mode 2: fast with adaptive sampling, whose second phase reads neighbours across
     * tiles rendered by other threads. */
    for (int mode = 0; mode < 3; mode++) {
        image img[3];
        for (int t = 0; t < 3; t++) {
            render_options o;
            render_options_default(&o);
            o.mode = mode == 1 ? RENDER_REFERENCE : RENDER_FAST;
            o.width = o.height = 40; /* not a multiple of the tile size */
            o.spp = 4;
            o.max_spp = mode == 2 ? 64 : 0;
            o.threads = t + 1;
            o.seed = 11;
            render_stats st;
            if (render_image(s, m, &o, &img[t], &st, err, sizeof err) < 0)
                fail_msg("%s", err);
            if (mode == 2)
                assert_true(st.extra_shading_points > 0);
            else
                assert_true(st.extra_shading_points == 0);
            /* The evaluator's time is part of the workers' time. */
            assert_true(st.material_seconds > 0.0);
            assert_true(st.material_seconds <= st.seconds * o.threads);
        }
        size_t bytes = sizeof(float) * 3 * 40 * 40;
        assert_memory_equal(img[0].pixels, img[1].pixels, bytes);
        assert_memory_equal(img[0].pixels, img[2].pixels, bytes);
        for (int t = 0; t < 3; t++)
            image_free(&img[t]);
    }
    render_material_free(m);
    render_scene_free(s);
}

/* A window's pixels are the whole render's, bit for bit, whatever the window (the tiles,
 * and so the batches the evaluator sees, move with it); the rest are 0, and only the
 * window's cells are shaded. Windows that leave the image, or ask for adaptive sampling,
 * are refused. */
static void test_window_matches_whole_render(void **state)
{
    (void)state;
    render_scene *s = load_scene();
    render_material *m = test_material(4);
    char err[512];
    enum { W = 40, H = 36 };
    static const int windows[][4] = {{8, 6, 24, 24}, {0, 0, 1, 1}, {39, 35, 1, 1},
                                     {3, 0, 17, 36}, {0, 0, W, H}};
    for (int mode = 0; mode < 2; mode++) {
        render_options o;
        render_options_default(&o);
        o.mode = mode ? RENDER_REFERENCE : RENDER_FAST;
        o.width = W, o.height = H;
        o.spp = 2;
        o.max_spp = 0;
        o.threads = 2;
        o.seed = 5;
        image whole;
        render_stats ws;
        if (render_image(s, m, &o, &whole, &ws, err, sizeof err) < 0)
            fail_msg("%s", err);
        for (size_t k = 0; k < sizeof windows / sizeof windows[0]; k++) {
            render_options wo = o;
            wo.window_x = windows[k][0], wo.window_y = windows[k][1];
            wo.window_w = windows[k][2], wo.window_h = windows[k][3];
            image part;
            render_stats ps;
            if (render_image(s, m, &wo, &part, &ps, err, sizeof err) < 0)
                fail_msg("%s", err);
            assert_int_equal(part.width, W);
            assert_int_equal(part.height, H);
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++) {
                    int in = x >= wo.window_x && x < wo.window_x + wo.window_w &&
                             y >= wo.window_y && y < wo.window_y + wo.window_h;
                    const float *a = part.pixels + 3 * (y * W + x);
                    const float *b = whole.pixels + 3 * (y * W + x);
                    for (int c = 0; c < 3; c++)
                        if (in ? memcmp(&a[c], &b[c], sizeof(float)) : a[c] != 0.0f)
                            fail_msg("mode %d, window %zu: pixel (%d, %d) channel %d is %g, "
                                     "the whole render's %g", mode, k, x, y, c, (double)a[c],
                                     (double)b[c]);
                }
            /* Reference mode shades the window's pixels; fast mode its cells and the
             * filter's reach around them (1 cell for the scene's 1.5 px filter). */
            int r = mode ? 0 : 1;
            uint64_t cells = (uint64_t)(wo.window_w + 2 * r) * (uint64_t)(wo.window_h + 2 * r);
            assert_true(ps.camera_rays == cells * (uint64_t)o.spp);
            assert_true(ps.camera_rays <= ws.camera_rays);
            image_free(&part);
        }
        image_free(&whole);
    }
    static const int bad[][4] = {{-1, 0, 4, 4}, {0, 0, 0, 4}, {30, 0, 11, 4}, {0, 33, 4, 4}};
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        render_options o;
        render_options_default(&o);
        o.width = W, o.height = H;
        o.max_spp = 0;
        o.window_x = bad[k][0], o.window_y = bad[k][1];
        o.window_w = bad[k][2], o.window_h = bad[k][3];
        image img;
        assert_int_equal(render_image(s, m, &o, &img, NULL, err, sizeof err), -1);
        assert_non_null(strstr(err, "is not inside the 40 x 36 image"));
        assert_null(img.pixels);
    }
    render_options o;
    render_options_default(&o); /* adaptive sampling on */
    o.width = W, o.height = H;
    o.window_w = o.window_h = 8;
    image img;
    assert_int_equal(render_image(s, m, &o, &img, NULL, err, sizeof err), -1);
    assert_non_null(strstr(err, "adaptive sampling"));
    render_material_free(m);
    render_scene_free(s);
}

/* With nothing in view every sample sees the world, so every pixel must be the world's
 * radiance: the fast film's weights per pixel sum to exactly 1 whatever the samples
 * (density-weighted splatting with W / n has ~13% weight noise at 4 samples a cell). */
static void test_fast_film_weights(void **state)
{
    (void)state;
    char text[4096];
    size_t len = edited_scene(text, sizeof text, "[[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]",
                              "[[5, 5, 0], [7, 5, 0], [7, 7, 0], [5, 7, 0]]    ");
    char err[512];
    render_scene *s = render_scene_load_json(text, len, "empty.json", err, sizeof err);
    if (!s)
        fail_msg("%s", err);
    render_material *m = test_material(4);
    int spps[] = {1, 4, 5};
    for (int i = 0; i < 3; i++) {
        render_options o;
        render_options_default(&o);
        o.width = o.height = 24;
        o.spp = spps[i];
        o.max_spp = 0;
        image img;
        render_stats st;
        if (render_image(s, m, &o, &img, &st, err, sizeof err) < 0)
            fail_msg("%s", err);
        assert_true(st.shading_points == 0 && st.camera_rays > 0);
        for (size_t k = 0; k < (size_t)24 * 24 * 3; k++)
            if (fabsf(img.pixels[k] - s->world[k % 3]) > 1e-6f * s->world[k % 3])
                fail_msg("spp %d: value %zu is %.7f, the world %.7f", spps[i], k,
                         (double)img.pixels[k], (double)s->world[k % 3]);
        image_free(&img);
    }
    render_material_free(m);
    render_scene_free(s);
}

/* The fast film keeps (2 radius + 1)^2 sums per cell, so it takes filters up to 3.5 px;
 * a wider one is a clear error pointing at reference mode, which takes any. */
static void test_fast_film_filter_limit(void **state)
{
    (void)state;
    char text[4096], err[512];
    size_t len = edited_scene(text, sizeof text, "\"filter_width\": 1.5", "\"filter_width\": 4.0");
    render_scene *s = render_scene_load_json(text, len, "wide.json", err, sizeof err);
    if (!s)
        fail_msg("%s", err);
    render_material *m = test_material(4);
    render_options o;
    render_options_default(&o);
    o.width = o.height = 8;
    image img;
    assert_int_equal(render_image(s, m, &o, &img, NULL, err, sizeof err), -1);
    assert_non_null(strstr(err, "3.5 px"));
    assert_non_null(strstr(err, "reference mode"));
    assert_null(img.pixels);
    o.mode = RENDER_REFERENCE;
    o.spp = 4;
    if (render_image(s, m, &o, &img, NULL, err, sizeof err) < 0)
        fail_msg("%s", err);
    image_free(&img);
    render_material_free(m);
    render_scene_free(s);
}

/* Fast and reference modes estimate the same image: compare 8x8-pixel block means,
 * each against the two modes' combined noise measured from two seeds. Fast mode with
 * adaptive sampling too: its extra shading points depend on the neighbours' noise, and
 * must not bias a pixel. */
static void test_fast_matches_reference(void **state)
{
    (void)state;
    render_scene *s = load_scene();
    for (int variant = 0; variant < 4; variant++) {
        int blender = variant % 2 ? 3 : 4, adaptive = variant >= 2;
        render_material *m = test_material(blender);
        char err[512];
        enum { W = 32, B = 8, NB = (W / B) * (W / B) };
        image fast[2], ref[2];
        for (int k = 0; k < 2; k++) {
            render_options o;
            render_options_default(&o);
            o.blender = blender;
            o.width = o.height = W;
            o.seed = (uint64_t)k + 1;
            o.spp = adaptive ? 4 : 16;
            o.max_spp = adaptive ? 64 : 0;
            o.noise_target = 0.05f;
            if (render_image(s, m, &o, &fast[k], NULL, err, sizeof err) < 0)
                fail_msg("%s", err);
            o.mode = RENDER_REFERENCE;
            o.spp = 512;
            if (render_image(s, m, &o, &ref[k], NULL, err, sizeof err) < 0)
                fail_msg("%s", err);
        }
        /* Block means of each half; the noise of a block's difference between modes is
         * estimated from the halves' differences, pooled over blocks as a relative
         * variance (one pair per block alone is too few to estimate it). */
        double mf[NB][2], mr[NB][2];
        memset(mf, 0, sizeof mf);
        memset(mr, 0, sizeof mr);
        for (int b = 0; b < NB; b++) {
            int bx = (b % (W / B)) * B, by = (b / (W / B)) * B;
            for (int y = by; y < by + B; y++)
                for (int x = bx; x < bx + B; x++)
                    for (int c = 0; c < 3; c++)
                        for (int k = 0; k < 2; k++) {
                            mf[b][k] += fast[k].pixels[3 * (y * W + x) + c];
                            mr[b][k] += ref[k].pixels[3 * (y * W + x) + c];
                        }
        }
        double rel_var = 0;
        for (int b = 0; b < NB; b++) {
            double df = mf[b][0] - mf[b][1], dr = mr[b][0] - mr[b][1];
            double scale = 0.5 * (mr[b][0] + mr[b][1]);
            /* Var(mean of two halves) = Var(half) / 2 = E[(h0 - h1)^2] / 4, per mode. */
            rel_var += (df * df + dr * dr) / 4.0 / (scale * scale) / NB;
        }
        int bad = 0;
        double total_f = 0, total_r = 0, total_var = 0;
        for (int b = 0; b < NB; b++) {
            double f = 0.5 * (mf[b][0] + mf[b][1]), r = 0.5 * (mr[b][0] + mr[b][1]);
            double sigma = r * sqrt(rel_var);
            total_f += f;
            total_r += r;
            total_var += sigma * sigma;
            if (fabs(f - r) > 4.5 * sigma + 1e-5 * r) {
                print_message("blender %d%s block %d: fast %.4f ref %.4f sigma %.4f\n", blender,
                              adaptive ? " adaptive" : "", b, f, r, sigma);
                bad++;
            }
        }
        assert_int_equal(bad, 0);
        /* Whole image: within 4 sigma, and noise small enough to mean something. */
        double sig = sqrt(total_var);
        assert_true(sig < 0.01 * total_r);
        if (fabs(total_f - total_r) > 4.0 * sig)
            fail_msg("blender %d%s image: fast %.4f ref %.4f sigma %.4f", blender,
                     adaptive ? " adaptive" : "", total_f, total_r, sig);
        for (int k = 0; k < 2; k++) {
            image_free(&fast[k]);
            image_free(&ref[k]);
        }
        render_material_free(m);
    }
    render_scene_free(s);
}

/* An object transform moves the texture space (Blender: matrix_world with the mesh
 * counter-transformed), not the geometry: Object coordinates are R^T (P - t), the object
 * normal R^T N, Generated spans the object-space bounding box; P, N and UV are untouched.
 * Without a transform, object space is world space bit for bit. */
static void test_object_transform(void **state)
{
    (void)state;
    char text[4096], err[512];
    FILE *f = fopen(IMSYNTH_SOURCE_DIR "/assets/scene.json", "rb");
    assert_non_null(f);
    char base[4096];
    size_t n = fread(base, 1, sizeof base - 1, f);
    fclose(f);
    base[n] = 0;
    const char *anchor = "\"faces\": [[0, 1, 2, 3]]";
    char *at = strstr(base, anchor);
    assert_non_null(at);
    size_t head = (size_t)(at - base) + strlen(anchor);
    snprintf(text, sizeof text, "%.*s, \"transform\": {\"location\": [0.3, -0.2, 0], "
             "\"rotation_euler\": [0, 0, 0.5]}%s", (int)head, base, base + head);
    render_scene *t = render_scene_load_json(text, strlen(text), "rotated.json", err, sizeof err);
    if (!t)
        fail_msg("%s", err);
    render_scene *s = render_scene_load(IMSYNTH_SOURCE_DIR "/assets/scene.json", err, sizeof err);
    assert_non_null(s);
    const double c = cos(0.5), sn = sin(0.5);
    double bmin[2] = {INFINITY, INFINITY}, bmax[2] = {-INFINITY, -INFINITY};
    const double corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int k = 0; k < 4; k++) { /* the object-space bounding box of the counter-rotated plane */
        double dx = corners[k][0] - 0.3, dy = corners[k][1] + 0.2;
        double ox = c * dx + sn * dy, oy = -sn * dx + c * dy;
        bmin[0] = fmin(bmin[0], ox), bmax[0] = fmax(bmax[0], ox);
        bmin[1] = fmin(bmin[1], oy), bmax[1] = fmax(bmax[1], oy);
    }
    const float hits[3][2] = {{0.25f, 0.25f}, {0.4f, 0.1f}, {0.7f, 0.9f}};
    for (int i = 0; i < 3; i++) {
        float3 D = make_float3(0, 0, -1);
        shading_geometry g, h;
        render_shading_geometry(t, 0, 0, hits[i][0], hits[i][1], D, 0.01f, &g);
        render_shading_geometry(s, 0, 0, hits[i][0], hits[i][1], D, 0.01f, &h);
        assert_memory_equal(&g.P, &h.P, sizeof g.P);
        assert_memory_equal(&g.N, &h.N, sizeof g.N);
        assert_memory_equal(&g.uv, &h.uv, sizeof g.uv);
        /* Identity: object space is world space, bit for bit. */
        assert_memory_equal(&h.object, &h.P, sizeof h.P);
        assert_memory_equal(&h.dobject_dx, &h.dPdx, sizeof h.P);
        assert_memory_equal(&h.object_normal, &h.N, sizeof h.N);
        double dx = g.P.x - 0.3, dy = g.P.y + 0.2;
        double ox = c * dx + sn * dy, oy = -sn * dx + c * dy;
        assert_true(fabs(g.object.x - ox) < 1e-6 && fabs(g.object.y - oy) < 1e-6);
        assert_true(fabs(g.object.z - g.P.z) < 1e-6);
        double ddx = c * g.dPdx.x + sn * g.dPdx.y, ddy = -sn * g.dPdx.x + c * g.dPdx.y;
        assert_true(fabs(g.dobject_dx.x - ddx) < 1e-7 && fabs(g.dobject_dx.y - ddy) < 1e-7);
        assert_true(fabs(g.object_normal.z - 1.0) < 1e-6);
        for (int k = 0; k < 2; k++) {
            double o = k == 0 ? g.object.x : g.object.y;
            double gen = (o - bmin[k]) / (bmax[k] - bmin[k]);
            assert_true(fabs((k == 0 ? g.generated.x : g.generated.y) - gen) < 1e-5);
        }
    }
    /* A bad transform is named by its path. */
    snprintf(text, sizeof text, "%.*s, \"transform\": {\"location\": [0, 0]}%s", (int)head,
             base, base + head);
    assert_null(render_scene_load_json(text, strlen(text), "bad.json", err, sizeof err));
    assert_non_null(strstr(err, "objects[0].transform"));
    render_scene_free(t);
    render_scene_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_camera_hits_pixel_centres),
        cmocka_unit_test(test_filter_distribution),
        cmocka_unit_test(test_filter_density),
        cmocka_unit_test(test_sampler),
        cmocka_unit_test(test_light_irradiance),
        cmocka_unit_test(test_scene_errors),
        cmocka_unit_test(test_object_transform),
        cmocka_unit_test(test_threads_do_not_change_bits),
        cmocka_unit_test(test_window_matches_whole_render),
        cmocka_unit_test(test_fast_film_weights),
        cmocka_unit_test(test_fast_film_filter_limit),
        cmocka_unit_test(test_fast_matches_reference),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
