/*
 * Materials made by hand in Blender evaluate in imsynth as Blender renders them.
 *
 * tests/reference/blender_made/make_materials.py builds each material through Blender's own
 * node API (not our importer), saves NAME.blend, exports it with blender/export_material.py
 * to NAME.json, and renders the hand-made material's four Principled BSDF maps, point-sampled
 * at the 128 x 128 pixel centres as blender/render_socket.py does, to
 * NAME/hand-<version>-<map>.exr. Materials named *_b34 were made in Blender 3.4 (Musgrave
 * nodes and all), the others in 4.3.
 *
 * For each material this test checks that
 * - NAME.blend, NAME.json and the four renders exist (a missing file fails, never skips);
 * - each render varies over the image (a constant map would make the comparison weak: the
 *   materials are built so every map has structure);
 * - our evaluation of NAME.json, compiled in the making version's mode, matches each render
 *   per pixel and channel within 1e-4, after the film rules Cycles applies to a sample
 *   (non-finite components -> 0; a sum overflowing to inf -> black). The materials read raw
 *   (unsnapped) coordinates and Cycles' hit point is within ~1e-7 of the pixel centre, so
 *   at a discontinuity (cell border, Math comparison) a pixel may land on the other side:
 *   up to 0.1% of pixels may exceed the tolerance, as in the node-reference cases;
 * - the node-reference cases tests/reference/nodes/blender_made_NAME_<map> (rendered by
 *   import_material from the JSON, checked by test_blender_nodes) hold this same NAME.json,
 *   so that check and this one are about one exported material.
 */
#include <dirent.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <cmocka.h>
#include <cjson/cJSON.h>

#include "imageio/imageio.h"
#include "shadergraph/shadergraph.h"

enum { RES = 128, BATCH = 1024, MAX_MATERIALS = 32 };

#define MADE_DIR IMSYNTH_SOURCE_DIR "/tests/reference/blender_made"
#define CASES_DIR IMSYNTH_SOURCE_DIR "/tests/reference/nodes"

static const double TOLERANCE = 1e-4;
static const double MAX_BAD_FRACTION = 0.001;

static const struct {
    const char *tag, *socket;
} MAPS[] = {
    {"basecolor", "Principled BSDF:Base Color"},
    {"metallic", "Principled BSDF:Metallic"},
    {"roughness", "Principled BSDF:Roughness"},
    {"normal", "Principled BSDF:Normal"},
};

typedef struct made_material {
    char name[128];
} made_material;

static bool is_file(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

static bool is_dir(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

static bool ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    return n >= k && strcmp(s + n - k, suffix) == 0;
}

static cJSON *read_json(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *s = n >= 0 ? malloc((size_t)n + 1) : NULL;
    cJSON *j = NULL;
    if (s && fread(s, 1, (size_t)n, f) == (size_t)n) {
        s[n] = '\0';
        j = cJSON_Parse(s);
    }
    free(s);
    fclose(f);
    return j;
}

/* Cycles' film on one sample (see tests/unit/test_blender_nodes.c). */
static void film_sample(float rgb[3])
{
    for (int c = 0; c < 3; c++)
        if (!isfinite(rgb[c]))
            rgb[c] = 0.0f;
    float sum = fabsf(rgb[0]) + fabsf(rgb[1]);
    sum += fabsf(rgb[2]);
    if (isinf(sum))
        rgb[0] = rgb[1] = rgb[2] = 0.0f;
}

/* Compares our evaluation of `graph_path`'s socket with the render `exr`. Returns 0 when it
 * passes, else writes why. */
static int compare_map(const char *graph_path, const char *socket, sg_blender_mode mode,
                       const char *exr, char *why, size_t whylen)
{
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(graph_path, err, sizeof err);
    if (!g) {
        snprintf(why, whylen, "%s", err);
        return -1;
    }
    char refbuf[128];
    snprintf(refbuf, sizeof refbuf, "%s", socket);
    sg_socket_ref ref;
    if (sg_socket_ref_parse(refbuf, &ref, err, sizeof err) != 0) {
        snprintf(why, whylen, "%s", err);
        sg_graph_free(g);
        return -1;
    }
    sg_compile_options opt = {.blender = mode};
    sg_program *p = sg_compile(g, &ref, 1, &opt, err, sizeof err);
    sg_graph_free(g);
    if (!p) {
        snprintf(why, whylen, "%.500s: %.1000s", graph_path, err);
        return -1;
    }
    int width = sg_socket_type_width(sg_program_output_type(p, 0));
    image img = {0};
    char ierr[512];
    if (image_read(exr, &img, ierr, sizeof ierr) != 0) {
        snprintf(why, whylen, "%s", ierr);
        sg_program_free(p);
        return -1;
    }
    int rc = 0;
    if (img.width != RES || img.height != RES || img.channels < 3) {
        snprintf(why, whylen, "%s: %dx%d with %d channels, expected %dx%d RGB", exr, img.width,
                 img.height, img.channels, RES, RES);
        rc = -1;
    }
    sg_evaluator *e = rc == 0 ? sg_evaluator_new(p, BATCH) : NULL;
    float *storage = malloc(sizeof(float) * 48 * BATCH);
    float *out = malloc(sizeof(float) * 3 * BATCH);
    if (rc == 0 && (!e || !storage || !out)) {
        snprintf(why, whylen, "out of memory");
        rc = -1;
    }
    double max_err = 0.0;
    float lo = INFINITY, hi = -INFINITY;
    int bad = 0, worst = 0;
    for (int first = 0; rc == 0 && first < RES * RES; first += BATCH) {
        int n = RES * RES - first < BATCH ? RES * RES - first : BATCH;
        sg_geometry_batch geom;
        sg_plane_geometry(RES, RES, first, n, storage, &geom);
        float *outs[1] = {out};
        sg_evaluate(e, &geom, outs);
        for (int i = 0; i < n; i++) {
            const float *r = img.pixels + (size_t)(first + i) * (size_t)img.channels;
            float ours[3];
            for (int c = 0; c < 3; c++)
                ours[c] = out[(size_t)(width == 3 ? c : 0) * (size_t)n + (size_t)i];
            film_sample(ours);
            bool is_bad = false;
            for (int c = 0; c < 3; c++) {
                double d = fabs((double)ours[c] - (double)r[c]);
                if (isnan(d))
                    d = INFINITY;
                is_bad |= d > TOLERANCE;
                if (d > max_err) {
                    max_err = d;
                    worst = first + i;
                }
                lo = fminf(lo, r[c]);
                hi = fmaxf(hi, r[c]);
            }
            bad += is_bad;
        }
    }
    if (rc == 0) {
        double frac = (double)bad / (double)(RES * RES);
        printf("  %-60s max err %.3g  bad %d px  range [%.4g, %.4g]\n", exr + strlen(MADE_DIR) + 1,
               max_err, bad, (double)lo, (double)hi);
        if (!(hi > lo)) {
            snprintf(why, whylen, "%s: the map is constant (%g): the material should give "
                     "every map structure", exr, (double)lo);
            rc = -1;
        } else if (frac > MAX_BAD_FRACTION) {
            snprintf(why, whylen, "%s: %d pixels differ by more than %g (allowed %.2f%%); max "
                     "error %.3g at row %d col %d", exr, bad, TOLERANCE,
                     100.0 * MAX_BAD_FRACTION, max_err, worst / RES, worst % RES);
            rc = -1;
        }
    }
    free(out);
    free(storage);
    sg_evaluator_free(e);
    image_free(&img);
    sg_program_free(p);
    return rc;
}

static void test_material(void **state)
{
    const made_material *m = *state;
    char path[512], exr[512], why[2048];
    const bool made_in_3 = ends_with(m->name, "_b34");
    const char *version = made_in_3 ? "3.4" : "4.3";
    sg_blender_mode mode = made_in_3 ? SG_BLENDER_3 : SG_BLENDER_4;

    snprintf(path, sizeof path, "%s/%s.blend", MADE_DIR, m->name);
    if (!is_file(path))
        fail_msg("%s missing (make_materials.py writes it)", path);
    char json_path[512];
    snprintf(json_path, sizeof json_path, "%s/%s.json", MADE_DIR, m->name);
    cJSON *exported = read_json(json_path);
    if (!exported)
        fail_msg("%s: missing or not JSON (export_material.py writes it)", json_path);

    int failures = 0;
    for (size_t k = 0; k < sizeof MAPS / sizeof MAPS[0]; k++) {
        snprintf(exr, sizeof exr, "%s/%s/hand-%s-%s.exr", MADE_DIR, m->name, version,
                 MAPS[k].tag);
        if (!is_file(exr)) {
            print_error("%s missing (render it with make_materials.py and commit it)\n", exr);
            failures++;
        } else if (compare_map(json_path, MAPS[k].socket, mode, exr, why, sizeof why) != 0) {
            print_error("%s\n", why);
            failures++;
        }
        snprintf(path, sizeof path, "%s/blender_made_%s_%s/graph.json", CASES_DIR, m->name,
                 MAPS[k].tag);
        cJSON *case_graph = read_json(path);
        if (!case_graph || !cJSON_Compare(case_graph, exported, true)) {
            print_error("%s: missing or not the same graph as %s (rerun "
                        "tests/reference/nodes/gen_roundtrip.py)\n", path, json_path);
            failures++;
        }
        cJSON_Delete(case_graph);
    }
    cJSON_Delete(exported);
    assert_int_equal(failures, 0);
}

static int by_name(const void *a, const void *b)
{
    return strcmp(((const made_material *)a)->name, ((const made_material *)b)->name);
}

int main(void)
{
    DIR *d = opendir(MADE_DIR);
    if (!d) {
        fprintf(stderr, "%s: cannot open\n", MADE_DIR);
        return 1;
    }
    made_material mats[MAX_MATERIALS];
    int n = 0;
    struct dirent *de;
    while ((de = readdir(d)) != NULL) {
        char sub[512];
        if (de->d_name[0] == '.' || strlen(de->d_name) >= sizeof mats[0].name)
            continue;
        snprintf(sub, sizeof sub, "%s/%s", MADE_DIR, de->d_name);
        if (!is_dir(sub))
            continue;
        if (n == MAX_MATERIALS) {
            fprintf(stderr, "%s: more than %d materials\n", MADE_DIR, MAX_MATERIALS);
            closedir(d);
            return 1;
        }
        memcpy(mats[n].name, de->d_name, strlen(de->d_name) + 1); /* length checked above */
        n++;
    }
    closedir(d);
    /* Three materials, each made in 3.4 and in 4.3: fewer means files went missing. */
    if (n < 6) {
        fprintf(stderr, "%s: %d hand-made materials, expected 6\n", MADE_DIR, n);
        return 1;
    }
    qsort(mats, (size_t)n, sizeof mats[0], by_name);
    struct CMUnitTest tests[MAX_MATERIALS];
    for (int i = 0; i < n; i++) {
        tests[i] = (struct CMUnitTest){.name = mats[i].name, .test_func = test_material,
                                       .initial_state = &mats[i]};
    }
    return _cmocka_run_group_tests("blender_made", tests, (size_t)n, NULL, NULL);
}
