/*
 * Node references: our evaluator against Blender, pixel by pixel.
 *
 * Every directory under tests/reference/nodes with a case.json is one cmocka test. For
 * each Blender version the case lists, blender-<version>.exr must exist (references are
 * committed; a missing one is a failure, never a skip). The case's socket is compiled in
 * that version's mode, evaluated at the pixel centres of the 128 x 128 plane view
 * (sg_plane_geometry: the same points blender/render_socket.py renders), passed through
 * the rules Cycles' film applies to a sample, and compared with the EXR per pixel and
 * channel: a pixel is bad when any channel differs by more than the case's tolerance; a
 * case passes when at most max_bad_fraction of its pixels are bad.
 *
 * Cycles' film (kernel/film/light_passes.h, film_clamp_light): each non-finite component
 * of a sample becomes 0; then, with clamping off (limit FLT_MAX), a sample whose
 * |R| + |G| + |B| exceeds the limit is scaled by limit / sum, which is 0 when the sum
 * overflows to inf. Finite sums never exceed FLT_MAX, so only the overflow matters.
 *
 * A float socket reaches the film as (v, v, v): it is compared with R, and the reference
 * itself must have G = B = R (else the EXR is not what the case says it is).
 *
 * IMSYNTH_CASES=<substring> restricts the run to cases whose name contains it.
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

enum { RES = 128, BATCH = 1024 };

#define CASES_DIR IMSYNTH_SOURCE_DIR "/tests/reference/nodes"

typedef struct node_case {
    char name[256];
    char dir[512];
} node_case;

static char *read_text(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *s = n >= 0 ? malloc((size_t)n + 1) : NULL;
    if (s && fread(s, 1, (size_t)n, f) != (size_t)n) {
        free(s);
        s = NULL;
    }
    if (s)
        s[n] = '\0';
    fclose(f);
    return s;
}

static bool file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

/* The film's treatment of one sample (see the file comment). */
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

typedef struct comparison {
    double max_err;
    int bad;
    int worst_px;         /* pixel index of max_err */
    float ours[3], ref[3]; /* at worst_px */
} comparison;

/* Compares one version's reference. Returns 0 when it passes; otherwise writes why in
 * `why`. Prints the one-line summary either way. */
static int compare_version(const node_case *nc, const char *socket, const char *version,
                           double tolerance, double max_bad_fraction, char *why,
                           size_t whylen)
{
    char exr[640];
    snprintf(exr, sizeof exr, "%s/blender-%s.exr", nc->dir, version);
    if (!file_exists(exr)) {
        snprintf(why, whylen, "%s missing (render it with blender/render_node_references.py "
                 "and commit it)", exr);
        return -1;
    }
    sg_blender_mode mode;
    if (strcmp(version, "3.4") == 0)
        mode = SG_BLENDER_3;
    else if (strcmp(version, "4.3") == 0)
        mode = SG_BLENDER_4;
    else {
        snprintf(why, whylen, "%s/case.json: unknown version \"%s\"", nc->dir, version);
        return -1;
    }

    char graph_path[640];
    snprintf(graph_path, sizeof graph_path, "%s/graph.json", nc->dir);
    char err[SG_ERROR_MAX] = "";
    sg_graph *g = sg_graph_load_file(graph_path, err, sizeof err);
    if (!g) {
        snprintf(why, whylen, "%s", err);
        return -1;
    }
    char refbuf[512];
    snprintf(refbuf, sizeof refbuf, "%s", socket);
    sg_socket_ref ref;
    if (sg_socket_ref_parse(refbuf, &ref, err, sizeof err) != 0) {
        snprintf(why, whylen, "%s/case.json: %s", nc->dir, err);
        sg_graph_free(g);
        return -1;
    }
    sg_compile_options opt = {.blender = mode};
    sg_program *p = sg_compile(g, &ref, 1, &opt, err, sizeof err);
    sg_graph_free(g);
    if (!p) {
        snprintf(why, whylen, "%s (Blender %s mode): %s", graph_path, version, err);
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
        snprintf(why, whylen, "%s: %dx%d with %d channels, expected %dx%d RGB", exr,
                 img.width, img.height, img.channels, RES, RES);
        rc = -1;
    }

    sg_evaluator *e = rc == 0 ? sg_evaluator_new(p, BATCH) : NULL;
    float *storage = malloc(sizeof(float) * 48 * BATCH);
    float *out = malloc(sizeof(float) * 3 * BATCH);
    comparison cmp = {.max_err = 0.0, .bad = 0, .worst_px = -1};
    int grey_mismatch = -1;
    if (rc == 0 && (!e || !storage || !out)) {
        snprintf(why, whylen, "out of memory");
        rc = -1;
    }
    for (int first = 0; rc == 0 && first < RES * RES; first += BATCH) {
        int n = RES * RES - first < BATCH ? RES * RES - first : BATCH;
        sg_geometry_batch geom;
        sg_plane_geometry(RES, RES, first, n, storage, &geom);
        float *outs[1] = {out};
        sg_evaluate(e, &geom, outs);
        for (int i = 0; i < n; i++) {
            int px = first + i;
            const float *r = img.pixels + (size_t)px * (size_t)img.channels;
            float ours[3];
            for (int c = 0; c < 3; c++)
                ours[c] = out[(size_t)(width == 3 ? c : 0) * (size_t)n + (size_t)i];
            film_sample(ours);
            if (width == 1 && grey_mismatch < 0 && (r[1] != r[0] || r[2] != r[0]))
                grey_mismatch = px;
            bool bad = false;
            for (int c = 0; c < 3; c++) {
                double d = fabs((double)ours[c] - (double)r[c]);
                if (isnan(d))
                    d = INFINITY;
                if (d > tolerance)
                    bad = true;
                if (d > cmp.max_err || cmp.worst_px < 0) {
                    if (d > cmp.max_err)
                        cmp.max_err = d;
                    cmp.worst_px = px;
                    memcpy(cmp.ours, ours, sizeof ours);
                    memcpy(cmp.ref, r, sizeof cmp.ref);
                }
            }
            cmp.bad += bad;
        }
    }
    double frac = (double)cmp.bad / (double)(RES * RES);
    if (rc == 0) {
        printf("  %-40s %s  max err %.3g  bad %.4f%% (%d px)", nc->name, version, cmp.max_err,
               100.0 * frac, cmp.bad);
        if (cmp.bad > 0)
            printf("  worst px (row %d, col %d): ours (%.9g %.9g %.9g) blender (%.9g %.9g %.9g)",
                   cmp.worst_px / RES, cmp.worst_px % RES, cmp.ours[0], cmp.ours[1],
                   cmp.ours[2], cmp.ref[0], cmp.ref[1], cmp.ref[2]);
        printf("\n");
        if (grey_mismatch >= 0) {
            snprintf(why, whylen, "%s: float socket but the reference is not grey at pixel "
                     "(row %d, col %d)", exr, grey_mismatch / RES, grey_mismatch % RES);
            rc = -1;
        } else if (frac > max_bad_fraction) {
            snprintf(why, whylen, "Blender %s: %d pixels (%.4f%%) differ by more than %g "
                     "(allowed %.4f%%); max error %.3g at row %d col %d",
                     version, cmp.bad, 100.0 * frac, tolerance, 100.0 * max_bad_fraction,
                     cmp.max_err, cmp.worst_px / RES, cmp.worst_px % RES);
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

static void test_case(void **state)
{
    const node_case *nc = *state;
    char path[640];
    snprintf(path, sizeof path, "%s/case.json", nc->dir);
    char *text = read_text(path);
    if (!text)
        fail_msg("%s: cannot read", path);
    cJSON *c = cJSON_Parse(text);
    free(text);
    if (!c)
        fail_msg("%s: bad JSON", path);
    const cJSON *socket = cJSON_GetObjectItemCaseSensitive(c, "socket");
    const cJSON *versions = cJSON_GetObjectItemCaseSensitive(c, "versions");
    const cJSON *tol = cJSON_GetObjectItemCaseSensitive(c, "tolerance");
    const cJSON *bad = cJSON_GetObjectItemCaseSensitive(c, "max_bad_fraction");
    if (!cJSON_IsString(socket) || !cJSON_IsArray(versions) || cJSON_GetArraySize(versions) == 0
        || !cJSON_IsNumber(tol) || (bad && !cJSON_IsNumber(bad))) {
        cJSON_Delete(c);
        fail_msg("%s: needs \"socket\" (string), \"versions\" (non-empty array), "
                 "\"tolerance\" (number), optional \"max_bad_fraction\" (number)", path);
    }
    char failures[8192] = "";
    const cJSON *v;
    cJSON_ArrayForEach(v, versions)
    {
        char why[2048] = "";
        if (!cJSON_IsString(v))
            snprintf(why, sizeof why, "%s: versions must be strings", path);
        else if (compare_version(nc, socket->valuestring, v->valuestring, tol->valuedouble,
                                 bad ? bad->valuedouble : 0.0, why, sizeof why) == 0)
            continue;
        size_t used = strlen(failures);
        snprintf(failures + used, sizeof failures - used, "\n    %s", why);
    }
    cJSON_Delete(c);
    if (failures[0])
        fail_msg("case %s failed:%s", nc->name, failures);
}

static int by_name(const void *a, const void *b)
{
    return strcmp(((const node_case *)a)->name, ((const node_case *)b)->name);
}

int main(void)
{
    DIR *d = opendir(CASES_DIR);
    if (!d) {
        fprintf(stderr, "%s: cannot open\n", CASES_DIR);
        return 1;
    }
    const char *filter = getenv("IMSYNTH_CASES");
    node_case *cases = NULL;
    int n = 0, cap = 0;
    struct dirent *de;
    while ((de = readdir(d)) != NULL) {
        if (de->d_name[0] == '.' || strlen(de->d_name) >= sizeof cases[0].name)
            continue;
        if (filter && *filter && !strstr(de->d_name, filter))
            continue;
        char probe[1024];
        snprintf(probe, sizeof probe, "%s/%s/case.json", CASES_DIR, de->d_name);
        if (!file_exists(probe))
            continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            node_case *grown = realloc(cases, sizeof *cases * (size_t)cap);
            if (!grown) {
                fprintf(stderr, "out of memory\n");
                return 1;
            }
            cases = grown;
        }
        snprintf(cases[n].name, sizeof cases[n].name, "%s", de->d_name);
        snprintf(cases[n].dir, sizeof cases[n].dir, "%s/%s", CASES_DIR, de->d_name);
        n++;
    }
    closedir(d);
    if (n == 0) {
        fprintf(stderr, "%s: no cases%s%s\n", CASES_DIR, filter ? " matching " : "",
                filter ? filter : "");
        free(cases);
        return 1;
    }
    qsort(cases, (size_t)n, sizeof *cases, by_name);
    struct CMUnitTest *tests = calloc((size_t)n, sizeof *tests);
    if (!tests) {
        free(cases);
        return 1;
    }
    for (int i = 0; i < n; i++) {
        tests[i].name = cases[i].name;
        tests[i].test_func = test_case;
        tests[i].initial_state = &cases[i];
    }
    int failed = _cmocka_run_group_tests("blender_nodes", tests, (size_t)n, NULL, NULL);
    free(tests);
    free(cases);
    return failed;
}
