/*
 * Turning a material's texture space about the plane's normal (shadergraph.h,
 * sg_graph_rotate_texture), as an artist turns a procedural material in Blender: a
 * Mapping node (Point, Rotation Z) between the Texture Coordinate node and what reads it.
 *
 * Done on the graph's JSON rather than on the in-memory graph, so that the loader checks
 * the result as it checks any file (unique names, linkable sockets, no cycles) and no
 * second way of building nodes exists. It runs once per predict, on a few hundred nodes.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "shadergraph/shadergraph.h"

/* The Texture Coordinate outputs that are positions on the surface: the ones a turn moves.
 * Normal, Camera, Window and Reflection are directions or screen positions: left alone. */
static const char *const turned_outputs[] = {"Generated", "UV", "Object"};
enum { MAX_TURNED = 16 }; /* (Texture Coordinate node, output) pairs a tree may have */

static const cJSON *node_named(const cJSON *nodes, const char *name)
{
    const cJSON *n;
    cJSON_ArrayForEach(n, nodes)
    {
        const cJSON *nm = cJSON_GetObjectItemCaseSensitive(n, "name");
        if (cJSON_IsString(nm) && !strcmp(nm->valuestring, name))
            return n;
    }
    return NULL;
}

static const char *str_item(const cJSON *o, const char *key)
{
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(o, key);
    return cJSON_IsString(s) ? s->valuestring : NULL;
}

/* Adds the Mapping node `name` at `at` turning by `radians`; NULL when out of memory. */
static cJSON *add_mapping(cJSON *nodes, const char *name, const float at[2], double radians)
{
    cJSON *m = cJSON_CreateObject();
    if (!m)
        return NULL;
    cJSON_AddItemToArray(nodes, m);
    cJSON *props = NULL, *inputs = NULL, *rot = NULL, *loc = NULL;
    if (!cJSON_AddStringToObject(m, "name", name) ||
        !cJSON_AddStringToObject(m, "type", "ShaderNodeMapping") ||
        !cJSON_AddStringToObject(m, "label", "Texture Rotation") ||
        !(loc = cJSON_AddArrayToObject(m, "location")) ||
        !(props = cJSON_AddObjectToObject(m, "properties")) ||
        !cJSON_AddStringToObject(props, "vector_type", "POINT") ||
        !(inputs = cJSON_AddObjectToObject(m, "inputs")) ||
        !(rot = cJSON_AddArrayToObject(inputs, "Rotation")))
        return NULL;
    double r[3] = {0.0, 0.0, (float)radians}; /* the float the socket will hold */
    for (int k = 0; k < 3; k++)
        cJSON_AddItemToArray(rot, cJSON_CreateNumber(r[k]));
    cJSON_AddItemToArray(loc, cJSON_CreateNumber(at[0]));
    cJSON_AddItemToArray(loc, cJSON_CreateNumber(at[1]));
    return m;
}

/* Turns one tree (the material's or a group's) in place. */
static int rotate_tree(cJSON *tree, double radians, const char *where, char *err, size_t errlen)
{
    cJSON *nodes = cJSON_GetObjectItemCaseSensitive(tree, "nodes");
    cJSON *links = cJSON_GetObjectItemCaseSensitive(tree, "links");
    if (!cJSON_IsArray(nodes) || !cJSON_IsArray(links))
        return sg_error_set(err, errlen, "%s: no nodes or links", where);
    /* The links made here join the array's end: only the first n_links are looked at. */
    int n_links = cJSON_GetArraySize(links);
    struct { const char *from, *socket; char name[256]; } made[MAX_TURNED];
    int n_made = 0;
    for (int i = 0; i < n_links; i++) {
        cJSON *l = cJSON_GetArrayItem(links, i);
        const char *from = str_item(l, "from_node"), *socket = str_item(l, "from_socket");
        const cJSON *src = from ? node_named(nodes, from) : NULL;
        const char *type = src ? str_item(src, "type") : NULL;
        if (!type || strcmp(type, "ShaderNodeTexCoord"))
            continue;
        int turned = 0;
        for (size_t k = 0; k < sizeof turned_outputs / sizeof turned_outputs[0]; k++)
            turned |= socket && !strcmp(socket, turned_outputs[k]);
        if (!turned)
            continue;
        /* One Mapping node per (Texture Coordinate, output), made at its first link:
         * "<node> <output> Rotation", with a number after it if the graph has that name. */
        char name[256];
        int c = 0;
        while (c < n_made && (strcmp(made[c].from, from) || strcmp(made[c].socket, socket)))
            c++;
        if (c < n_made) {
            snprintf(name, sizeof name, "%s", made[c].name);
        } else {
            if (n_made == MAX_TURNED)
                return sg_error_set(err, errlen, "%s: more than %d texture coordinates", where,
                                    MAX_TURNED);
            int len = snprintf(name, sizeof name, "%s %s Rotation", from, socket);
            if (len < 0 || (size_t)len + 12 >= sizeof name)
                return sg_error_set(err, errlen, "%s: node name \"%s\" too long", where, from);
            for (int k = 2; node_named(nodes, name); k++)
                snprintf(name + len, sizeof name - (size_t)len, " %d", k);
            float at[2] = {0.0f, 0.0f};
            const cJSON *loc = cJSON_GetObjectItemCaseSensitive(src, "location");
            if (cJSON_IsArray(loc) && cJSON_GetArraySize(loc) == 2) {
                at[0] = (float)cJSON_GetArrayItem(loc, 0)->valuedouble + 200.0f;
                at[1] = (float)cJSON_GetArrayItem(loc, 1)->valuedouble - 200.0f;
            }
            cJSON *in = add_mapping(nodes, name, at, radians) ? cJSON_CreateObject() : NULL;
            if (!in)
                return sg_error_set(err, errlen, "%s: out of memory", where);
            cJSON_AddItemToArray(links, in); /* owned by the tree from here */
            if (!cJSON_AddStringToObject(in, "from_node", from) ||
                !cJSON_AddStringToObject(in, "from_socket", socket) ||
                !cJSON_AddStringToObject(in, "to_node", name) ||
                !cJSON_AddStringToObject(in, "to_socket", "Vector"))
                return sg_error_set(err, errlen, "%s: out of memory", where);
            made[n_made].from = str_item(in, "from_node");
            made[n_made].socket = str_item(in, "from_socket");
            snprintf(made[n_made].name, sizeof made[n_made].name, "%s", name);
            n_made++;
        }
        /* The link now leaves the Mapping node. (from and socket point into l: the
         * replacements are made last.) */
        if (!cJSON_ReplaceItemInObjectCaseSensitive(l, "from_socket", cJSON_CreateString("Vector")) ||
            !cJSON_ReplaceItemInObjectCaseSensitive(l, "from_node", cJSON_CreateString(name)))
            return sg_error_set(err, errlen, "%s: out of memory", where);
    }
    return 0;
}

sg_graph *sg_graph_rotate_texture(const sg_graph *g, double degrees, char *err, size_t errlen)
{
    if (!isfinite(degrees))
        return sg_error_set(err, errlen, "texture rotation: %g degrees is not finite", degrees),
               NULL;
    char *text = sg_graph_to_json(g);
    cJSON *root = text ? cJSON_Parse(text) : NULL;
    free(text);
    if (!root)
        return sg_error_set(err, errlen, "texture rotation: out of memory"), NULL;
    /* fmod keeps the radians of 450 degrees those of 90: the same turn, the same bits. */
    double radians = fmod(degrees, 360.0) * (M_PI / 180.0);
    sg_graph *out = NULL;
    int rc = rotate_tree(root, radians, "texture rotation: the material", err, errlen);
    cJSON *groups = cJSON_GetObjectItemCaseSensitive(root, "groups");
    cJSON *gt;
    cJSON_ArrayForEach(gt, groups)
    {
        if (rc)
            break;
        char where[300];
        snprintf(where, sizeof where, "texture rotation: group \"%s\"", gt->string);
        rc = rotate_tree(gt, radians, where, err, errlen);
    }
    if (!rc) {
        char *turned = cJSON_PrintUnformatted(root);
        if (!turned)
            sg_error_set(err, errlen, "texture rotation: out of memory");
        else
            out = sg_graph_load_json(turned, strlen(turned), "texture rotation", err, errlen);
        free(turned);
    }
    cJSON_Delete(root);
    return out;
}
