/*
 * blender/node_vocabulary.json must describe exactly the node types shadergraph knows.
 *
 * blender/export_material.py runs inside Blender, far from our C code, and uses that
 * file to decide which nodes, sockets and properties it may write (FORMAT.md's loader
 * rejects anything else). This test rebuilds the vocabulary from the registry and
 * compares it with the committed file, so the two cannot drift apart.
 *
 *   test_blender_vocabulary --write blender/node_vocabulary.json    regenerates it
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <cjson/cJSON.h>

#include "shadergraph/node_type.h"
#include "shadergraph/shadergraph.h"

#define VOCABULARY_PATH IMSYNTH_SOURCE_DIR "/blender/node_vocabulary.json"

static const char *prop_kind_name(sg_prop_kind k)
{
    switch (k) {
    case SG_PROP_ENUM: return "enum";
    case SG_PROP_BOOL: return "bool";
    case SG_PROP_FLOAT: return "float";
    case SG_PROP_COLOR_RAMP: return "color_ramp";
    }
    return "?";
}

static cJSON *sockets_json(const sg_socket_def *s, int n)
{
    cJSON *arr = cJSON_CreateArray();
    for (int i = 0; i < n; i++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "identifier", s[i].identifier);
        cJSON_AddStringToObject(o, "type", sg_socket_type_name(s[i].type));
        cJSON_AddBoolToObject(o, "implicit", s[i].implicit != SG_IMPLICIT_NONE);
        cJSON_AddItemToArray(arr, o);
    }
    return arr;
}

/* The vocabulary as the registry defines it. */
static cJSON *registry_vocabulary(void)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "format", "imsynth-vocabulary/1");
    cJSON_AddStringToObject(root, "note",
                            "Generated from shadergraph's node registry by "
                            "test_blender_vocabulary --write; do not edit.");
    cJSON *nodes = cJSON_AddObjectToObject(root, "nodes");
    for (int i = 0; i < sg_node_type_count(); i++) {
        const sg_node_type *t = sg_node_type_at(i);
        cJSON *o = cJSON_AddObjectToObject(nodes, t->idname);
        cJSON_AddItemToObject(o, "inputs", sockets_json(t->inputs, t->n_inputs));
        cJSON_AddItemToObject(o, "outputs", sockets_json(t->outputs, t->n_outputs));
        cJSON *props = cJSON_AddObjectToObject(o, "properties");
        for (int k = 0; k < t->n_props; k++) {
            const sg_prop_def *p = &t->props[k];
            cJSON *po = cJSON_AddObjectToObject(props, p->name);
            cJSON_AddStringToObject(po, "kind", prop_kind_name(p->kind));
            if (p->kind == SG_PROP_ENUM && p->values) {
                cJSON *vals = cJSON_AddArrayToObject(po, "values");
                for (const char *const *v = p->values; *v; v++)
                    cJSON_AddItemToArray(vals, cJSON_CreateString(*v));
            }
        }
    }
    return root;
}

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

static void test_vocabulary_matches_registry(void **state)
{
    (void)state;
    char *text = read_text(VOCABULARY_PATH);
    if (!text)
        fail_msg("%s: cannot read (regenerate it with test_blender_vocabulary --write PATH)",
                 VOCABULARY_PATH);
    cJSON *file = cJSON_Parse(text);
    free(text);
    if (!file)
        fail_msg("%s: bad JSON", VOCABULARY_PATH);
    cJSON *want = registry_vocabulary();
    const cJSON *fnodes = cJSON_GetObjectItemCaseSensitive(file, "nodes");
    const cJSON *wnodes = cJSON_GetObjectItemCaseSensitive(want, "nodes");
    int mismatches = 0;
    const cJSON *w;
    cJSON_ArrayForEach(w, wnodes)
    {
        const cJSON *f = cJSON_GetObjectItemCaseSensitive(fnodes, w->string);
        if (!f || !cJSON_Compare(f, w, true)) {
            print_error("%s: node type %s %s\n", VOCABULARY_PATH, w->string,
                        f ? "differs from the registry" : "is missing");
            mismatches++;
        }
    }
    const cJSON *f;
    cJSON_ArrayForEach(f, fnodes)
    {
        if (!cJSON_GetObjectItemCaseSensitive(wnodes, f->string)) {
            print_error("%s: node type %s is not in the registry\n", VOCABULARY_PATH,
                        f->string);
            mismatches++;
        }
    }
    cJSON_Delete(want);
    cJSON_Delete(file);
    if (mismatches)
        fail_msg("%s is stale (%d node types); regenerate it with "
                 "test_blender_vocabulary --write %s", VOCABULARY_PATH, mismatches,
                 VOCABULARY_PATH);
}

/* Every type export_material.py may meet has an idname and well-formed sockets. */
static void test_registry_sockets_named(void **state)
{
    (void)state;
    assert_true(sg_node_type_count() > 0);
    for (int i = 0; i < sg_node_type_count(); i++) {
        const sg_node_type *t = sg_node_type_at(i);
        assert_non_null(t->idname);
        for (int k = 0; k < t->n_inputs; k++)
            assert_true(t->inputs[k].identifier && t->inputs[k].identifier[0]);
        for (int k = 0; k < t->n_outputs; k++)
            assert_true(t->outputs[k].identifier && t->outputs[k].identifier[0]);
    }
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--write") == 0) {
        cJSON *v = registry_vocabulary();
        char *s = cJSON_Print(v);
        cJSON_Delete(v);
        char tmp[4096];
        snprintf(tmp, sizeof tmp, "%s.tmp", argv[2]);
        FILE *out = fopen(tmp, "w");
        if (!s || !out || fputs(s, out) < 0 || fputc('\n', out) < 0 || fclose(out) != 0 ||
            rename(tmp, argv[2]) != 0) {
            fprintf(stderr, "%s: cannot write\n", argv[2]);
            free(s);
            return 1;
        }
        free(s);
        return 0;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_vocabulary_matches_registry),
        cmocka_unit_test(test_registry_sockets_named),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
