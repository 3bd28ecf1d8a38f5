/*
 * Graph JSON (FORMAT.md): load with full validation, save losslessly.
 *
 * Loading happens in passes so that each check can assume the previous ones hold:
 * group names and interfaces, then every tree's nodes, then links (which need both
 * ends), then reroute types, cycles and group recursion. Every error names the source
 * and a JSON path such as `groups."Noise Module".nodes[4] "Math.002".inputs.Value`.
 */
#include <cjson/cJSON.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "shadergraph/graph_internal.h"

#define FORMAT_ID "imsynth-graph/1"

/* Everything a loading pass needs to say where it is. */
typedef struct load_ctx {
    const char *source; /* file name for messages */
    char *err; /* the caller\'s message buffer */
    size_t errlen;
    sg_graph *g;
} load_ctx;

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

/* "groups.\"X\"." or "" prefix for the tree being read. */
static void tree_where(const sg_graph *g, const sg_tree *t, char *buf, size_t n)
{
    if (t == &g->main)
        buf[0] = '\0';
    else
        snprintf(buf, n, "groups.\"%s\".", t->name);
}

/* ---- look-ups --------------------------------------------------------------------- */

int sg_tree_find_node(const sg_tree *t, const char *name)
{
    for (int i = 0; i < t->n_nodes; i++)
        if (t->nodes[i].name && strcmp(t->nodes[i].name, name) == 0)
            return i;
    return -1;
}

int sg_tree_input_link(const sg_tree *t, int node, int input)
{
    for (int i = 0; i < t->n_links; i++)
        if (t->links[i].to_node == node && t->links[i].to_socket == input)
            return i;
    return -1;
}

int sg_node_input_index(const sg_node *n, const char *identifier)
{
    for (int i = 0; i < n->n_in; i++)
        if (strcmp(n->in[i].identifier, identifier) == 0)
            return i;
    return -1;
}

int sg_node_output_index(const sg_node *n, const char *identifier)
{
    for (int i = 0; i < n->n_out; i++)
        if (strcmp(n->out[i].identifier, identifier) == 0)
            return i;
    return -1;
}

static int find_group(const sg_graph *g, const char *name)
{
    for (int i = 0; i < g->n_groups; i++)
        if (strcmp(g->groups[i].name, name) == 0)
            return i;
    return -1;
}

/* ---- values ----------------------------------------------------------------------- */

static int read_number(const load_ctx *c, const cJSON *j, const char *where, float *out)
{
    if (!cJSON_IsNumber(j))
        return sg_error_set(c->err, c->errlen, "%s: %s: expected a number", c->source, where);
    /* The bound is FLT_MAX plus half its ulp: every double below it rounds to a finite
     * float. Comparing with FLT_MAX itself refused the 9-digit text we write for FLT_MAX
     * (3.40282347e+38 lies above it), so a saved graph would not load again (fuzz_graph). */
    double v = j->valuedouble;
    if (!isfinite(v) || fabs(v) >= (double)FLT_MAX + 0x1p103)
        return sg_error_set(c->err, c->errlen, "%s: %s: value is not a finite float", c->source, where);
    *out = (float)v;
    return 0;
}

/* A socket value of type t: a number, or an array of 3 (vector) / 3-4 (colour). */
static int read_value(const load_ctx *c, const cJSON *j, sg_socket_type t, const char *where,
                      float out[4])
{
    int width = sg_socket_type_width(t);
    if (t == SG_SOCKET_SHADER)
        return sg_error_set(c->err, c->errlen, "%s: %s: shader sockets have no value", c->source, where);
    if (width == 1)
        return read_number(c, j, where, &out[0]);
    int n = cJSON_GetArraySize(j);
    bool ok = cJSON_IsArray(j) && (n == 3 || (t == SG_SOCKET_COLOR && n == 4));
    if (!ok)
        return sg_error_set(c->err, c->errlen, "%s: %s: expected an array of %s numbers", c->source, where,
                            t == SG_SOCKET_COLOR ? "3 or 4" : "3");
    out[3] = 1.0f;
    for (int i = 0; i < n; i++) {
        char w[600];
        snprintf(w, sizeof w, "%s[%d]", where, i);
        if (read_number(c, cJSON_GetArrayItem(j, i), w, &out[i]) < 0)
            return -1;
        /* Blender stores colours clamped below at 0 (their RNA range is [0, inf)), so a
         * negative channel is 0 in the material Blender builds: do as Blender does. */
        if (t == SG_SOCKET_COLOR && out[i] < 0.0f)
            out[i] = 0.0f;
    }
    return 0;
}

static int parse_socket_type(const load_ctx *c, const cJSON *j, const char *where,
                             sg_socket_type *t)
{
    static const sg_socket_type types[] = {SG_SOCKET_FLOAT, SG_SOCKET_VECTOR, SG_SOCKET_COLOR,
                                           SG_SOCKET_SHADER, SG_SOCKET_INT, SG_SOCKET_BOOL};
    if (cJSON_IsString(j))
        for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
            if (strcmp(j->valuestring, sg_socket_type_name(types[i])) == 0) {
                *t = types[i];
                return 0;
            }
    return sg_error_set(c->err, c->errlen,
                        "%s: %s: socket type must be FLOAT, VECTOR, RGBA, SHADER, INT or BOOLEAN",
                        c->source, where);
}

static int enum_index(const char *const *values, const char *s)
{
    for (int i = 0; values[i]; i++)
        if (strcmp(values[i], s) == 0)
            return i;
    return -1;
}

/* ---- group interfaces ------------------------------------------------------------- */

static int parse_iface(const load_ctx *c, const cJSON *arr, const char *where,
                       sg_iface_socket **out, int *n_out)
{
    if (!arr) {
        *out = NULL;
        *n_out = 0;
        return 0;
    }
    if (!cJSON_IsArray(arr))
        return sg_error_set(c->err, c->errlen, "%s: %s: expected an array", c->source, where);
    int n = cJSON_GetArraySize(arr);
    *out = calloc((size_t)(n ? n : 1), sizeof **out);
    *n_out = n;
    if (!*out)
        return sg_error_set(c->err, c->errlen, "%s: out of memory", c->source);
    for (int i = 0; i < n; i++) {
        const cJSON *s = cJSON_GetArrayItem(arr, i);
        sg_iface_socket *is = &(*out)[i];
        char w[600];
        snprintf(w, sizeof w, "%s[%d]", where, i);
        const cJSON *name = cJSON_GetObjectItemCaseSensitive(s, "name");
        if (!cJSON_IsString(name) || !name->valuestring[0])
            return sg_error_set(c->err, c->errlen, "%s: %s: missing \"name\"", c->source, w);
        for (int k = 0; k < i; k++)
            if (strcmp((*out)[k].name, name->valuestring) == 0)
                return sg_error_set(c->err, c->errlen, "%s: %s: duplicate interface socket \"%s\"", c->source,
                                    w, name->valuestring);
        is->name = dup_str(name->valuestring);
        char wt[640];
        snprintf(wt, sizeof wt, "%s.type", w);
        if (parse_socket_type(c, cJSON_GetObjectItemCaseSensitive(s, "type"), wt, &is->type) < 0)
            return -1;
        const cJSON *def = cJSON_GetObjectItemCaseSensitive(s, "default");
        if (def) {
            snprintf(wt, sizeof wt, "%s.default", w);
            if (read_value(c, def, is->type, wt, is->value) < 0)
                return -1;
        } else if (is->type == SG_SOCKET_COLOR) {
            is->value[3] = 1.0f;
        }
        const cJSON *mn = cJSON_GetObjectItemCaseSensitive(s, "min");
        const cJSON *mx = cJSON_GetObjectItemCaseSensitive(s, "max");
        is->min = -FLT_MAX;
        is->max = FLT_MAX;
        if (mn || mx) {
            is->has_range = true;
            snprintf(wt, sizeof wt, "%s.min", w);
            if (mn && read_number(c, mn, wt, &is->min) < 0)
                return -1;
            snprintf(wt, sizeof wt, "%s.max", w);
            if (mx && read_number(c, mx, wt, &is->max) < 0)
                return -1;
        }
    }
    return 0;
}

/* ---- nodes ------------------------------------------------------------------------ */

static int set_sockets_from_type(sg_node *n)
{
    const sg_node_type *t = n->type;
    n->n_in = t->n_inputs;
    n->n_out = t->n_outputs;
    n->in = calloc((size_t)(t->n_inputs + 1), sizeof *n->in);
    n->out = calloc((size_t)(t->n_outputs + 1), sizeof *n->out);
    if (!n->in || !n->out)
        return -1;
    for (int i = 0; i < t->n_inputs; i++) {
        n->in[i].identifier = t->inputs[i].identifier;
        n->in[i].type = t->inputs[i].type;
        memcpy(n->in[i].value, t->inputs[i].default_value, sizeof n->in[i].value);
        n->in[i].implicit = t->inputs[i].implicit;
    }
    for (int i = 0; i < t->n_outputs; i++) {
        n->out[i].identifier = t->outputs[i].identifier;
        n->out[i].type = t->outputs[i].type;
        memcpy(n->out[i].value, t->outputs[i].default_value, sizeof n->out[i].value);
    }
    return 0;
}

static int set_sockets_from_iface(sg_node *n, const sg_iface_socket *in, int n_in,
                                  const sg_iface_socket *out, int n_out)
{
    n->n_in = n_in;
    n->n_out = n_out;
    n->in = calloc((size_t)(n_in + 1), sizeof *n->in);
    n->out = calloc((size_t)(n_out + 1), sizeof *n->out);
    if (!n->in || !n->out)
        return -1;
    for (int i = 0; i < n_in; i++) {
        n->in[i].identifier = in[i].name;
        n->in[i].type = in[i].type;
        memcpy(n->in[i].value, in[i].value, sizeof n->in[i].value);
        n->in[i].available = true;
    }
    for (int i = 0; i < n_out; i++) {
        n->out[i].identifier = out[i].name;
        n->out[i].type = out[i].type;
        memcpy(n->out[i].value, out[i].value, sizeof n->out[i].value);
        n->out[i].available = true;
    }
    return 0;
}

static void update_availability(sg_node *n)
{
    const sg_node_type *t = n->type;
    bool structural = (t->flags & SG_NODE_STRUCTURAL) != 0; /* sockets not from t's tables */
    for (int i = 0; i < n->n_in; i++)
        n->in[i].available = structural || sg_socket_available(&t->inputs[i], n->prop);
    for (int i = 0; i < n->n_out; i++)
        n->out[i].available = structural || sg_socket_available(&t->outputs[i], n->prop);
}

static int parse_ramp(const load_ctx *c, const cJSON *j, const char *where, sg_color_ramp *r)
{
    if (!cJSON_IsObject(j))
        return sg_error_set(c->err, c->errlen, "%s: %s.color_ramp: expected an object", c->source, where);
    struct {
        const char *key;
        const char *const *values;
        int *dst;
    } enums[] = {{"interpolation", sg_ramp_interpolations, &r->interpolation},
                 {"color_mode", sg_ramp_color_modes, &r->color_mode},
                 {"hue_interpolation", sg_ramp_hue_interpolations, &r->hue_interpolation}};
    r->interpolation = 2; /* LINEAR, Blender's default */
    for (size_t k = 0; k < 3; k++) {
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(j, enums[k].key);
        if (!v)
            continue;
        int idx = cJSON_IsString(v) ? enum_index(enums[k].values, v->valuestring) : -1;
        if (idx < 0)
            return sg_error_set(c->err, c->errlen, "%s: %s.color_ramp.%s: invalid value", c->source, where,
                                enums[k].key);
        *enums[k].dst = idx;
    }
    const cJSON *el = cJSON_GetObjectItemCaseSensitive(j, "elements");
    int n = cJSON_GetArraySize(el);
    if (!cJSON_IsArray(el) || n < 1 || n > SG_RAMP_MAX_ELEMENTS)
        return sg_error_set(c->err, c->errlen, "%s: %s.color_ramp.elements: expected 1 to %d elements",
                            c->source, where, SG_RAMP_MAX_ELEMENTS);
    r->n = n;
    for (int i = 0; i < n; i++) {
        const cJSON *e = cJSON_GetArrayItem(el, i);
        char w[700];
        snprintf(w, sizeof w, "%s.color_ramp.elements[%d].position", where, i);
        if (read_number(c, cJSON_GetObjectItemCaseSensitive(e, "position"), w, &r->position[i]) < 0)
            return -1;
        if (r->position[i] < 0.0f || r->position[i] > 1.0f)
            return sg_error_set(c->err, c->errlen, "%s: %s: must be in [0, 1]", c->source, w);
        snprintf(w, sizeof w, "%s.color_ramp.elements[%d].color", where, i);
        if (read_value(c, cJSON_GetObjectItemCaseSensitive(e, "color"), SG_SOCKET_COLOR, w,
                       r->color[i]) < 0)
            return -1;
    }
    /* Blender keeps elements sorted by position; a stable insertion sort keeps the
     * order of coincident stops as written, as Blender does. */
    for (int i = 1; i < n; i++) {
        float p = r->position[i], col[4];
        memcpy(col, r->color[i], sizeof col);
        int k = i - 1;
        while (k >= 0 && r->position[k] > p) {
            r->position[k + 1] = r->position[k];
            memcpy(r->color[k + 1], r->color[k], sizeof col);
            k--;
        }
        r->position[k + 1] = p;
        memcpy(r->color[k + 1], col, sizeof col);
    }
    return 0;
}

static int parse_node(const load_ctx *c, sg_tree *t, const cJSON *j, int index)
{
    sg_node *n = &t->nodes[index];
    char tw[300], w[600];
    tree_where(c->g, t, tw, sizeof tw);
    n->group = -1;
    if (!cJSON_IsObject(j))
        return sg_error_set(c->err, c->errlen, "%s: %snodes[%d]: expected an object", c->source, tw, index);
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(j, "name");
    if (!cJSON_IsString(name) || !name->valuestring[0])
        return sg_error_set(c->err, c->errlen, "%s: %snodes[%d]: missing \"name\"", c->source, tw, index);
    snprintf(w, sizeof w, "%snodes[%d] \"%s\"", tw, index, name->valuestring);
    if (sg_tree_find_node(t, name->valuestring) >= 0)
        return sg_error_set(c->err, c->errlen, "%s: %s: duplicate node name", c->source, w);
    n->name = dup_str(name->valuestring);

    const cJSON *type = cJSON_GetObjectItemCaseSensitive(j, "type");
    if (!cJSON_IsString(type))
        return sg_error_set(c->err, c->errlen, "%s: %s: missing \"type\"", c->source, w);
    n->type = sg_node_type_find(type->valuestring);
    if (!n->type)
        return sg_error_set(c->err, c->errlen, "%s: %s: unknown node type \"%s\"", c->source, w,
                            type->valuestring);
    const char *id = n->type->idname;
    sg_node_role role = n->type->role;
    bool in_group = t != &c->g->main;
    if (!in_group && (role == SG_ROLE_GROUP_INPUT || role == SG_ROLE_GROUP_OUTPUT))
        return sg_error_set(c->err, c->errlen, "%s: %s: %s is only allowed inside a group", c->source, w, id);

    const cJSON *label = cJSON_GetObjectItemCaseSensitive(j, "label");
    if (label) {
        if (!cJSON_IsString(label))
            return sg_error_set(c->err, c->errlen, "%s: %s.label: expected a string", c->source, w);
        n->label = dup_str(label->valuestring);
    }
    const cJSON *loc = cJSON_GetObjectItemCaseSensitive(j, "location");
    if (loc) {
        if (!cJSON_IsArray(loc) || cJSON_GetArraySize(loc) != 2)
            return sg_error_set(c->err, c->errlen, "%s: %s.location: expected [x, y]", c->source, w);
        char lw[640];
        snprintf(lw, sizeof lw, "%s.location", w);
        if (read_number(c, cJSON_GetArrayItem(loc, 0), lw, &n->location[0]) < 0 ||
            read_number(c, cJSON_GetArrayItem(loc, 1), lw, &n->location[1]) < 0)
            return -1;
    }

    /* Sockets: from the group interface for group nodes, else from the type. */
    int rc;
    if (role == SG_ROLE_GROUP) {
        const cJSON *gname = cJSON_GetObjectItemCaseSensitive(j, "group");
        if (!cJSON_IsString(gname))
            return sg_error_set(c->err, c->errlen, "%s: %s: group node needs \"group\"", c->source, w);
        n->group = find_group(c->g, gname->valuestring);
        if (n->group < 0)
            return sg_error_set(c->err, c->errlen, "%s: %s: unknown group \"%s\"", c->source, w,
                                gname->valuestring);
        const sg_tree *gt = &c->g->groups[n->group];
        rc = set_sockets_from_iface(n, gt->iface_in, gt->n_iface_in, gt->iface_out,
                                    gt->n_iface_out);
    } else if (role == SG_ROLE_GROUP_INPUT) {
        rc = set_sockets_from_iface(n, NULL, 0, t->iface_in, t->n_iface_in);
    } else if (role == SG_ROLE_GROUP_OUTPUT) {
        rc = set_sockets_from_iface(n, t->iface_out, t->n_iface_out, NULL, 0);
    } else {
        rc = set_sockets_from_type(n);
    }
    if (rc < 0)
        return sg_error_set(c->err, c->errlen, "%s: out of memory", c->source);

    /* Properties. */
    for (int p = 0; p < n->type->n_props; p++)
        n->prop[p] = n->type->props[p].default_value;
    const cJSON *props = cJSON_GetObjectItemCaseSensitive(j, "properties");
    if (props && !cJSON_IsObject(props))
        return sg_error_set(c->err, c->errlen, "%s: %s.properties: expected an object", c->source, w);
    const cJSON *p;
    cJSON_ArrayForEach(p, props)
    {
        int k = sg_node_type_prop_index(n->type, p->string);
        const sg_prop_def *pd = k >= 0 ? &n->type->props[k] : NULL;
        if (!pd || pd->kind == SG_PROP_COLOR_RAMP)
            return sg_error_set(c->err, c->errlen, "%s: %s.properties: %s has no property \"%s\"", c->source,
                                w, id, p->string);
        if (pd->kind == SG_PROP_BOOL) {
            if (!cJSON_IsBool(p))
                return sg_error_set(c->err, c->errlen, "%s: %s.properties.%s: expected true or false",
                                    c->source, w, p->string);
            n->prop[k] = cJSON_IsTrue(p);
        } else if (pd->kind == SG_PROP_ENUM) {
            int v = cJSON_IsString(p) ? enum_index(pd->values, p->valuestring) : -1;
            if (v < 0) {
                char allowed[400] = "";
                for (int e = 0; pd->values[e]; e++) {
                    strncat(allowed, e ? ", " : "", sizeof allowed - strlen(allowed) - 1);
                    strncat(allowed, pd->values[e], sizeof allowed - strlen(allowed) - 1);
                }
                return sg_error_set(c->err, c->errlen, "%s: %s.properties.%s: invalid value %s%s%s (one of: %s)",
                                    c->source, w, p->string, cJSON_IsString(p) ? "\"" : "",
                                    cJSON_IsString(p) ? p->valuestring : "(not a string)",
                                    cJSON_IsString(p) ? "\"" : "", allowed);
            }
            n->prop[k] = v;
        } else {
            return sg_error_set(c->err, c->errlen, "%s: %s.properties.%s: unsupported property kind",
                                c->source, w, p->string);
        }
    }
    update_availability(n);

    /* Input values. */
    const cJSON *ins = cJSON_GetObjectItemCaseSensitive(j, "inputs");
    if (ins && !cJSON_IsObject(ins))
        return sg_error_set(c->err, c->errlen, "%s: %s.inputs: expected an object", c->source, w);
    cJSON_ArrayForEach(p, ins)
    {
        int k = sg_node_input_index(n, p->string);
        char vw[700];
        snprintf(vw, sizeof vw, "%s.inputs.%s", w, p->string);
        if (k < 0)
            return sg_error_set(c->err, c->errlen, "%s: %s: %s has no input socket \"%s\"", c->source, vw, id,
                                p->string);
        if (read_value(c, p, n->in[k].type, vw, n->in[k].value) < 0)
            return -1;
    }
    /* Output values: only Value and RGB keep their value on the output. */
    const cJSON *outs = cJSON_GetObjectItemCaseSensitive(j, "outputs");
    bool value_node = role == SG_ROLE_CONSTANT;
    if (outs && (!value_node || !cJSON_IsObject(outs)))
        return sg_error_set(c->err, c->errlen, "%s: %s.outputs: only Value and RGB nodes take an object of "
                            "output values", c->source, w);
    cJSON_ArrayForEach(p, outs)
    {
        int k = sg_node_output_index(n, p->string);
        char vw[700];
        snprintf(vw, sizeof vw, "%s.outputs.%s", w, p->string);
        if (k < 0)
            return sg_error_set(c->err, c->errlen, "%s: %s: %s has no output socket \"%s\"", c->source, vw, id,
                                p->string);
        if (read_value(c, p, n->out[k].type, vw, n->out[k].value) < 0)
            return -1;
    }
    /* Colour ramp. */
    const cJSON *ramp = cJSON_GetObjectItemCaseSensitive(j, "color_ramp");
    bool has_ramp = false;
    for (int k = 0; k < n->type->n_props; k++)
        has_ramp |= n->type->props[k].kind == SG_PROP_COLOR_RAMP;
    if (ramp && !has_ramp)
        return sg_error_set(c->err, c->errlen, "%s: %s: %s has no color_ramp", c->source, w, id);
    if (has_ramp) {
        n->ramp = calloc(1, sizeof *n->ramp);
        if (!n->ramp)
            return sg_error_set(c->err, c->errlen, "%s: out of memory", c->source);
        if (!ramp) { /* Blender's default ramp: black at 0, white at 1. */
            n->ramp->interpolation = 2;
            n->ramp->n = 2;
            n->ramp->position[1] = 1.0f;
            float black[4] = {0, 0, 0, 1}, white[4] = {1, 1, 1, 1};
            memcpy(n->ramp->color[0], black, sizeof black);
            memcpy(n->ramp->color[1], white, sizeof white);
        } else if (parse_ramp(c, ramp, w, n->ramp) < 0) {
            return -1;
        }
    }
    /* Anything else is a typo that would silently be ignored: reject it. */
    static const char *const known[] = {"name", "type", "label", "location", "properties",
                                        "inputs", "outputs", "color_ramp", "group", NULL};
    cJSON_ArrayForEach(p, j)
    {
        if (enum_index(known, p->string) < 0)
            return sg_error_set(c->err, c->errlen, "%s: %s: unknown key \"%s\"", c->source, w, p->string);
    }
    return 0;
}

/* ---- links ------------------------------------------------------------------------ */

static bool types_linkable(sg_socket_type from, sg_socket_type to)
{
    return (from == SG_SOCKET_SHADER) == (to == SG_SOCKET_SHADER);
}

static int parse_link(const load_ctx *c, sg_tree *t, const cJSON *j, int index)
{
    char tw[300], w[400];
    tree_where(c->g, t, tw, sizeof tw);
    snprintf(w, sizeof w, "%slinks[%d]", tw, index);
    const char *keys[4] = {"from_node", "from_socket", "to_node", "to_socket"};
    const char *v[4];
    for (int k = 0; k < 4; k++) {
        const cJSON *s = cJSON_GetObjectItemCaseSensitive(j, keys[k]);
        if (!cJSON_IsString(s))
            return sg_error_set(c->err, c->errlen, "%s: %s: missing \"%s\"", c->source, w, keys[k]);
        v[k] = s->valuestring;
    }
    sg_link *l = &t->links[index];
    l->from_node = sg_tree_find_node(t, v[0]);
    l->to_node = sg_tree_find_node(t, v[2]);
    if (l->from_node < 0)
        return sg_error_set(c->err, c->errlen, "%s: %s: no node named \"%s\"", c->source, w, v[0]);
    if (l->to_node < 0)
        return sg_error_set(c->err, c->errlen, "%s: %s: no node named \"%s\"", c->source, w, v[2]);
    const sg_node *from = &t->nodes[l->from_node], *to = &t->nodes[l->to_node];
    l->from_socket = sg_node_output_index(from, v[1]);
    l->to_socket = sg_node_input_index(to, v[3]);
    if (l->from_socket < 0)
        return sg_error_set(c->err, c->errlen, "%s: %s: node \"%s\" (%s) has no output socket \"%s\"",
                            c->source, w, v[0], from->type->idname, v[1]);
    if (l->to_socket < 0)
        return sg_error_set(c->err, c->errlen, "%s: %s: node \"%s\" (%s) has no input socket \"%s\"",
                            c->source, w, v[2], to->type->idname, v[3]);
    if (!from->out[l->from_socket].available)
        return sg_error_set(c->err, c->errlen, "%s: %s: output \"%s\" of \"%s\" is hidden for its settings",
                            c->source, w, v[1], v[0]);
    if (!to->in[l->to_socket].available)
        return sg_error_set(c->err, c->errlen, "%s: %s: input \"%s\" of \"%s\" is hidden for its settings",
                            c->source, w, v[3], v[2]);
    for (int k = 0; k < index; k++)
        if (t->links[k].to_node == l->to_node && t->links[k].to_socket == l->to_socket)
            return sg_error_set(c->err, c->errlen, "%s: %s: input \"%s\" of \"%s\" already has a link (%slinks[%d])",
                                c->source, w, v[3], v[2], tw, k);
    bool reroute = from->type->role == SG_ROLE_REROUTE || to->type->role == SG_ROLE_REROUTE;
    if (!reroute && !types_linkable(from->out[l->from_socket].type, to->in[l->to_socket].type))
        return sg_error_set(c->err, c->errlen, "%s: %s: cannot link %s socket \"%s\" to %s socket \"%s\"",
                            c->source, w, sg_socket_type_name(from->out[l->from_socket].type), v[1],
                            sg_socket_type_name(to->in[l->to_socket].type), v[3]);
    static const char *const known[] = {"from_node", "from_socket", "to_node", "to_socket", NULL};
    const cJSON *p;
    cJSON_ArrayForEach(p, j)
    {
        if (enum_index(known, p->string) < 0)
            return sg_error_set(c->err, c->errlen, "%s: %s: unknown key \"%s\"", c->source, w, p->string);
    }
    return 0;
}

/* A reroute takes the type of what feeds it (through chains of reroutes); then the
 * links out of it are checked as if they came from the source. */
static int resolve_reroutes(const load_ctx *c, sg_tree *t)
{
    char tw[300];
    tree_where(c->g, t, tw, sizeof tw);
    for (int i = 0; i < t->n_nodes; i++) {
        sg_node *n = &t->nodes[i];
        if (n->type->role != SG_ROLE_REROUTE)
            continue;
        int cur = i, hops = 0;
        sg_socket_type type = SG_SOCKET_COLOR;
        for (;;) {
            int l = sg_tree_input_link(t, cur, 0);
            if (l < 0)
                break;
            const sg_node *src = &t->nodes[t->links[l].from_node];
            if (src->type->role != SG_ROLE_REROUTE) {
                type = src->out[t->links[l].from_socket].type;
                break;
            }
            cur = t->links[l].from_node;
            if (++hops > t->n_nodes)
                return sg_error_set(c->err, c->errlen, "%s: %snodes \"%s\": reroutes form a cycle", c->source,
                                    tw, n->name);
        }
        n->in[0].type = n->out[0].type = type;
    }
    for (int k = 0; k < t->n_links; k++) {
        const sg_link *l = &t->links[k];
        sg_socket_type a = t->nodes[l->from_node].out[l->from_socket].type;
        sg_socket_type b = t->nodes[l->to_node].in[l->to_socket].type;
        if (!types_linkable(a, b))
            return sg_error_set(c->err, c->errlen, "%s: %slinks[%d]: cannot link %s to %s (through reroutes)",
                                c->source, tw, k, sg_socket_type_name(a), sg_socket_type_name(b));
    }
    return 0;
}

/* Depth-first search for a cycle; colour 0 unvisited, 1 on the stack, 2 done. */
static int find_cycle(const sg_tree *t, int node, unsigned char *colour)
{
    colour[node] = 1;
    for (int k = 0; k < t->n_links; k++) {
        if (t->links[k].from_node != node)
            continue;
        int next = t->links[k].to_node;
        if (colour[next] == 1)
            return next;
        if (colour[next] == 0) {
            int r = find_cycle(t, next, colour);
            if (r >= 0)
                return r;
        }
    }
    colour[node] = 2;
    return -1;
}

static int check_cycles(const load_ctx *c, const sg_tree *t)
{
    unsigned char *colour = calloc((size_t)t->n_nodes + 1, 1);
    if (!colour)
        return sg_error_set(c->err, c->errlen, "%s: out of memory", c->source);
    int bad = -1;
    for (int i = 0; i < t->n_nodes && bad < 0; i++)
        if (!colour[i])
            bad = find_cycle(t, i, colour);
    free(colour);
    if (bad >= 0) {
        char tw[300];
        tree_where(c->g, t, tw, sizeof tw);
        return sg_error_set(c->err, c->errlen, "%s: %snodes: the links form a cycle through \"%s\"", c->source,
                            tw, t->nodes[bad].name);
    }
    return 0;
}

/* A group must not contain itself, directly or through other groups. */
static int group_recursion(const sg_graph *g, int group, unsigned char *state)
{
    if (state[group] == 1)
        return group;
    if (state[group] == 2)
        return -1;
    state[group] = 1;
    const sg_tree *t = &g->groups[group];
    for (int i = 0; i < t->n_nodes; i++)
        if (t->nodes[i].group >= 0) {
            int r = group_recursion(g, t->nodes[i].group, state);
            if (r >= 0)
                return r;
        }
    state[group] = 2;
    return -1;
}

static int parse_tree(const load_ctx *c, sg_tree *t, const cJSON *j, const char *where)
{
    const cJSON *nodes = cJSON_GetObjectItemCaseSensitive(j, "nodes");
    const cJSON *links = cJSON_GetObjectItemCaseSensitive(j, "links");
    if (!cJSON_IsArray(nodes))
        return sg_error_set(c->err, c->errlen, "%s: %snodes: missing or not an array", c->source, where);
    if (!cJSON_IsArray(links))
        return sg_error_set(c->err, c->errlen, "%s: %slinks: missing or not an array", c->source, where);
    int nn = cJSON_GetArraySize(nodes), nl = cJSON_GetArraySize(links);
    if (nn > SG_MAX_TREE_NODES)
        return sg_error_set(c->err, c->errlen, "%s: %snodes: %d nodes, more than the %d a tree may have",
                            c->source, where, nn, SG_MAX_TREE_NODES);
    if (nl > SG_MAX_TREE_LINKS)
        return sg_error_set(c->err, c->errlen, "%s: %slinks: %d links, more than the %d a tree may have",
                            c->source, where, nl, SG_MAX_TREE_LINKS);
    t->nodes = calloc((size_t)nn + 1, sizeof *t->nodes);
    t->links = calloc((size_t)nl + 1, sizeof *t->links);
    if (!t->nodes || !t->links)
        return sg_error_set(c->err, c->errlen, "%s: out of memory", c->source);
    /* Walked as lists: cJSON_GetArrayItem(i) starts from the head each time. */
    const cJSON *item = nodes->child;
    for (int i = 0; i < nn; i++, item = item->next) {
        t->n_nodes = i + 1; /* so that a failed node is freed */
        t->nodes[i].group = -1;
        if (parse_node(c, t, item, i) < 0)
            return -1;
    }
    t->n_nodes = nn;
    item = links->child;
    for (int i = 0; i < nl; i++, item = item->next) {
        if (parse_link(c, t, item, i) < 0)
            return -1;
        t->n_links = i + 1;
    }
    if (resolve_reroutes(c, t) < 0 || check_cycles(c, t) < 0)
        return -1;
    return 0;
}

static int parse_graph(const load_ctx *c, const cJSON *root)
{
    sg_graph *g = c->g;
    if (!cJSON_IsObject(root))
        return sg_error_set(c->err, c->errlen, "%s: top level: expected an object", c->source);
    const cJSON *fmt = cJSON_GetObjectItemCaseSensitive(root, "format");
    if (!cJSON_IsString(fmt))
        return sg_error_set(c->err, c->errlen, "%s: format: missing (expected \"%s\")", c->source, FORMAT_ID);
    if (strcmp(fmt->valuestring, FORMAT_ID) != 0)
        return sg_error_set(c->err, c->errlen, "%s: format: \"%s\" is not supported (expected \"%s\")",
                            c->source, fmt->valuestring, FORMAT_ID);
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(root, "name");
    if (name && !cJSON_IsString(name))
        return sg_error_set(c->err, c->errlen, "%s: name: expected a string", c->source);
    g->name = dup_str(name ? name->valuestring : "Material");
    g->main.name = dup_str(g->name);

    const cJSON *groups = cJSON_GetObjectItemCaseSensitive(root, "groups");
    if (groups && !cJSON_IsObject(groups))
        return sg_error_set(c->err, c->errlen, "%s: groups: expected an object", c->source);
    int ng = cJSON_GetArraySize(groups);
    if (ng > SG_MAX_GROUPS)
        return sg_error_set(c->err, c->errlen, "%s: groups: %d groups, more than the %d a graph may have",
                            c->source, ng, SG_MAX_GROUPS);
    g->groups = calloc((size_t)ng + 1, sizeof *g->groups);
    if (!g->groups)
        return sg_error_set(c->err, c->errlen, "%s: out of memory", c->source);
    /* Pass 1: names and interfaces, so group nodes anywhere can refer to any group. */
    const cJSON *gj;
    int gi = 0;
    cJSON_ArrayForEach(gj, groups)
    {
        sg_tree *t = &g->groups[gi];
        g->n_groups = gi + 1;
        t->name = dup_str(gj->string);
        if (find_group(g, gj->string) != gi)
            return sg_error_set(c->err, c->errlen, "%s: groups.\"%s\": duplicate group name", c->source,
                                gj->string);
        if (!cJSON_IsObject(gj))
            return sg_error_set(c->err, c->errlen, "%s: groups.\"%s\": expected an object", c->source,
                                gj->string);
        char w[400];
        snprintf(w, sizeof w, "groups.\"%s\".inputs", gj->string);
        if (parse_iface(c, cJSON_GetObjectItemCaseSensitive(gj, "inputs"), w, &t->iface_in,
                        &t->n_iface_in) < 0)
            return -1;
        snprintf(w, sizeof w, "groups.\"%s\".outputs", gj->string);
        if (parse_iface(c, cJSON_GetObjectItemCaseSensitive(gj, "outputs"), w, &t->iface_out,
                        &t->n_iface_out) < 0)
            return -1;
        gi++;
    }
    /* Pass 2: trees. */
    gi = 0;
    cJSON_ArrayForEach(gj, groups)
    {
        char w[400];
        snprintf(w, sizeof w, "groups.\"%s\".", gj->string);
        if (parse_tree(c, &g->groups[gi], gj, w) < 0)
            return -1;
        gi++;
    }
    if (parse_tree(c, &g->main, root, "") < 0)
        return -1;
    unsigned char *state = calloc((size_t)ng + 1, 1);
    if (!state)
        return sg_error_set(c->err, c->errlen, "%s: out of memory", c->source);
    for (int i = 0; i < ng; i++) {
        int r = group_recursion(g, i, state);
        if (r >= 0) {
            free(state);
            return sg_error_set(c->err, c->errlen, "%s: groups.\"%s\": the group contains itself", c->source,
                                g->groups[r].name);
        }
    }
    free(state);
    bool has_output = false;
    for (int i = 0; i < g->main.n_nodes; i++)
        has_output |= g->main.nodes[i].type->role == SG_ROLE_MATERIAL_OUTPUT;
    if (!has_output)
        return sg_error_set(c->err, c->errlen, "%s: nodes: no Material Output node (ShaderNodeOutputMaterial)",
                            c->source);
    static const char *const known[] = {"format", "name", "nodes", "links", "groups", NULL};
    const cJSON *p;
    cJSON_ArrayForEach(p, root)
    {
        if (enum_index(known, p->string) < 0)
            return sg_error_set(c->err, c->errlen, "%s: top level: unknown key \"%s\"", c->source, p->string);
    }
    return 0;
}

/* Line and column (1-based) of byte offset `pos` in text. */
static void line_col(const char *text, size_t pos, int *line, int *col)
{
    *line = 1;
    *col = 1;
    for (size_t i = 0; i < pos && text[i]; i++) {
        if (text[i] == '\n') {
            (*line)++;
            *col = 1;
        } else {
            (*col)++;
        }
    }
}

sg_graph *sg_graph_load_json(const char *text, size_t len, const char *source_name, char *err, size_t errlen)
{
    load_ctx c = {source_name ? source_name : "<graph>", err, errlen, NULL};
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, len, &end, false);
    if (!root) {
        int line, col;
        size_t pos = end && end >= text ? (size_t)(end - text) : 0;
        line_col(text, pos < len ? pos : len, &line, &col);
        sg_error_set(err, errlen, "%s:%d:%d: invalid JSON", c.source, line, col);
        return NULL;
    }
    /* Trailing non-space garbage is an error too. */
    if (end) {
        while ((size_t)(end - text) < len && (*end == ' ' || *end == '\n' || *end == '\r' ||
                                               *end == '\t'))
            end++;
        if ((size_t)(end - text) < len && *end) {
            int line, col;
            line_col(text, (size_t)(end - text), &line, &col);
            cJSON_Delete(root);
            sg_error_set(err, errlen, "%s:%d:%d: unexpected text after the JSON value", c.source, line, col);
            return NULL;
        }
    }
    c.g = calloc(1, sizeof *c.g);
    if (!c.g) {
        cJSON_Delete(root);
        sg_error_set(err, errlen, "%s: out of memory", c.source);
        return NULL;
    }
    int rc = parse_graph(&c, root);
    cJSON_Delete(root);
    if (rc < 0) {
        sg_graph_free(c.g);
        return NULL;
    }
    return c.g;
}

sg_graph *sg_graph_load_file(const char *path, char *err, size_t errlen)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        sg_error_set(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return NULL;
    }
    /* Read up to one byte past the limit, whatever the file claims to be (a pipe, or a
     * file growing while read): more than the limit is refused, not truncated. */
    size_t cap = 1 << 16, len = 0;
    char *buf = malloc(cap);
    bool too_large = false;
    while (buf) {
        size_t want = cap - len, room = (size_t)SG_MAX_GRAPH_FILE_BYTES + 1 - len;
        size_t got = fread(buf + len, 1, want < room ? want : room, f);
        len += got;
        if (len > SG_MAX_GRAPH_FILE_BYTES) {
            too_large = true;
            break;
        }
        if (got < want || len < cap)
            break;
        char *nb = realloc(buf, cap * 2);
        if (!nb) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = nb;
        cap *= 2;
    }
    bool read_error = ferror(f);
    fclose(f);
    if (too_large) {
        free(buf);
        sg_error_set(err, errlen, "%s: larger than the %u bytes a graph file may have", path,
                     SG_MAX_GRAPH_FILE_BYTES);
        return NULL;
    }
    if (!buf || read_error) {
        free(buf);
        sg_error_set(err, errlen, "%s: %s", path, buf ? "read error" : "out of memory");
        return NULL;
    }
    sg_graph *g = sg_graph_load_json(buf, len, path, err, errlen);
    free(buf);
    return g;
}

/* ---- queries ---------------------------------------------------------------------- */

const char *sg_graph_surface_bsdf(const sg_graph *g, char *err, size_t errlen)
{
    const sg_tree *t = &g->main;
    int out = -1;
    /* The active output: Blender marks one; with several, the first marked wins. */
    for (int i = 0; i < t->n_nodes; i++) {
        const sg_node *n = &t->nodes[i];
        if (n->type->role != SG_ROLE_MATERIAL_OUTPUT)
            continue;
        int k = sg_node_type_prop_index(n->type, "is_active_output");
        if (out < 0 || (k >= 0 && n->prop[k]))
            out = i;
        if (k >= 0 && n->prop[k])
            break;
    }
    if (out < 0) {
        sg_error_set(err, errlen, "%s: no Material Output", g->name);
        return NULL;
    }
    int node = out, socket = sg_node_input_index(&t->nodes[out], "Surface");
    for (int hops = 0; hops <= t->n_nodes; hops++) {
        int l = sg_tree_input_link(t, node, socket);
        if (l < 0) {
            sg_error_set(err, errlen, "%s: nothing is linked to the Material Output's Surface", g->name);
            return NULL;
        }
        const sg_node *from = &t->nodes[t->links[l].from_node];
        if (from->type->role == SG_ROLE_REROUTE) {
            node = t->links[l].from_node;
            socket = 0;
            continue;
        }
        if (from->type->role != SG_ROLE_BSDF) {
            sg_error_set(err, errlen, "%s: the Surface shader is \"%s\" (%s); only a Principled BSDF "
                         "can be rendered", g->name, from->name, from->type->idname);
            return NULL;
        }
        return from->name;
    }
    sg_error_set(err, errlen, "%s: reroutes form a cycle", g->name);
    return NULL;
}

/* ---- freeing ---------------------------------------------------------------------- */

static void free_tree(sg_tree *t)
{
    for (int i = 0; i < t->n_nodes; i++) {
        free(t->nodes[i].name);
        free(t->nodes[i].label);
        free(t->nodes[i].ramp);
        free(t->nodes[i].in);
        free(t->nodes[i].out);
    }
    free(t->nodes);
    free(t->links);
    for (int i = 0; i < t->n_iface_in; i++)
        free(t->iface_in[i].name);
    for (int i = 0; i < t->n_iface_out; i++)
        free(t->iface_out[i].name);
    free(t->iface_in);
    free(t->iface_out);
    free(t->name);
}

void sg_graph_free(sg_graph *g)
{
    if (!g)
        return;
    free_tree(&g->main);
    for (int i = 0; i < g->n_groups; i++)
        free_tree(&g->groups[i]);
    free(g->groups);
    free(g->name);
    free(g);
}

/* ---- saving ----------------------------------------------------------------------- */

/* The shortest decimal that reads back as the same float: keeps files readable
 * (0.1, not 0.100000001490116) and the round trip exact. */
static cJSON *float_json(float v)
{
    char buf[32];
    for (int prec = 6; prec <= 9; prec++) {
        snprintf(buf, sizeof buf, "%.*g", prec, (double)v);
        if (strtof(buf, NULL) == v)
            break;
    }
    if (v == 0.0f)
        snprintf(buf, sizeof buf, signbit(v) ? "-0.0" : "0.0");
    return cJSON_CreateRaw(buf);
}

static cJSON *value_json(const float *v, sg_socket_type t)
{
    int w = sg_socket_type_width(t);
    if (w == 1)
        return float_json(v[0]);
    cJSON *a = cJSON_CreateArray();
    int n = t == SG_SOCKET_COLOR ? 4 : 3;
    for (int i = 0; i < n; i++)
        cJSON_AddItemToArray(a, float_json(v[i]));
    return a;
}

static bool same_value(const float *a, const float *b, sg_socket_type t)
{
    int n = t == SG_SOCKET_COLOR ? 4 : sg_socket_type_width(t);
    return memcmp(a, b, sizeof(float) * (size_t)n) == 0;
}

static cJSON *ramp_json(const sg_color_ramp *r)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "interpolation", sg_ramp_interpolations[r->interpolation]);
    cJSON_AddStringToObject(o, "color_mode", sg_ramp_color_modes[r->color_mode]);
    cJSON_AddStringToObject(o, "hue_interpolation", sg_ramp_hue_interpolations[r->hue_interpolation]);
    cJSON *el = cJSON_AddArrayToObject(o, "elements");
    for (int i = 0; i < r->n; i++) {
        cJSON *e = cJSON_CreateObject();
        cJSON_AddItemToObject(e, "position", float_json(r->position[i]));
        cJSON_AddItemToObject(e, "color", value_json(r->color[i], SG_SOCKET_COLOR));
        cJSON_AddItemToArray(el, e);
    }
    return o;
}

/* Default value of input k of node n, as a freshly loaded node would have it. */
static const float *input_default(const sg_graph *g, const sg_tree *t, const sg_node *n, int k)
{
    if (n->group >= 0)
        return g->groups[n->group].iface_in[k].value;
    if (n->type->role == SG_ROLE_GROUP_OUTPUT)
        return t->iface_out[k].value;
    if (n->type->flags & SG_NODE_STRUCTURAL)
        return NULL;
    return n->type->inputs[k].default_value;
}

static cJSON *node_json(const sg_graph *g, const sg_tree *t, const sg_node *n)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", n->name);
    cJSON_AddStringToObject(o, "type", n->type->idname);
    if (n->label)
        cJSON_AddStringToObject(o, "label", n->label);
    cJSON *loc = cJSON_AddArrayToObject(o, "location");
    cJSON_AddItemToArray(loc, float_json(n->location[0]));
    cJSON_AddItemToArray(loc, float_json(n->location[1]));
    if (n->group >= 0)
        cJSON_AddStringToObject(o, "group", g->groups[n->group].name);
    cJSON *props = NULL;
    for (int p = 0; p < n->type->n_props; p++) {
        const sg_prop_def *pd = &n->type->props[p];
        if (pd->kind == SG_PROP_COLOR_RAMP || n->prop[p] == pd->default_value)
            continue;
        if (!props)
            props = cJSON_AddObjectToObject(o, "properties");
        if (pd->kind == SG_PROP_BOOL)
            cJSON_AddBoolToObject(props, pd->name, n->prop[p]);
        else
            cJSON_AddStringToObject(props, pd->name, pd->values[n->prop[p]]);
    }
    cJSON *ins = NULL;
    for (int k = 0; k < n->n_in; k++) {
        const float *def = input_default(g, t, n, k);
        if (n->in[k].type == SG_SOCKET_SHADER || (def && same_value(def, n->in[k].value, n->in[k].type)))
            continue;
        if (!def && n->type->role == SG_ROLE_REROUTE)
            continue;
        if (!ins)
            ins = cJSON_AddObjectToObject(o, "inputs");
        cJSON_AddItemToObject(ins, n->in[k].identifier, value_json(n->in[k].value, n->in[k].type));
    }
    if (n->type->role == SG_ROLE_CONSTANT) {
        cJSON *outs = cJSON_AddObjectToObject(o, "outputs");
        cJSON_AddItemToObject(outs, n->out[0].identifier, value_json(n->out[0].value, n->out[0].type));
    }
    if (n->ramp)
        cJSON_AddItemToObject(o, "color_ramp", ramp_json(n->ramp));
    return o;
}

static void tree_json(const sg_graph *g, const sg_tree *t, cJSON *o)
{
    cJSON *nodes = cJSON_AddArrayToObject(o, "nodes");
    for (int i = 0; i < t->n_nodes; i++)
        cJSON_AddItemToArray(nodes, node_json(g, t, &t->nodes[i]));
    cJSON *links = cJSON_AddArrayToObject(o, "links");
    for (int i = 0; i < t->n_links; i++) {
        const sg_link *l = &t->links[i];
        cJSON *lj = cJSON_CreateObject();
        cJSON_AddStringToObject(lj, "from_node", t->nodes[l->from_node].name);
        cJSON_AddStringToObject(lj, "from_socket", t->nodes[l->from_node].out[l->from_socket].identifier);
        cJSON_AddStringToObject(lj, "to_node", t->nodes[l->to_node].name);
        cJSON_AddStringToObject(lj, "to_socket", t->nodes[l->to_node].in[l->to_socket].identifier);
        cJSON_AddItemToArray(links, lj);
    }
}

static cJSON *iface_json(const sg_iface_socket *s, int n)
{
    cJSON *a = cJSON_CreateArray();
    for (int i = 0; i < n; i++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", s[i].name);
        cJSON_AddStringToObject(o, "type", sg_socket_type_name(s[i].type));
        if (s[i].type != SG_SOCKET_SHADER)
            cJSON_AddItemToObject(o, "default", value_json(s[i].value, s[i].type));
        if (s[i].has_range) {
            cJSON_AddItemToObject(o, "min", float_json(s[i].min));
            cJSON_AddItemToObject(o, "max", float_json(s[i].max));
        }
        cJSON_AddItemToArray(a, o);
    }
    return a;
}

char *sg_graph_to_json(const sg_graph *g)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "format", FORMAT_ID);
    cJSON_AddStringToObject(root, "name", g->name);
    tree_json(g, &g->main, root);
    cJSON *groups = cJSON_AddObjectToObject(root, "groups");
    for (int i = 0; i < g->n_groups; i++) {
        const sg_tree *t = &g->groups[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToObject(o, "inputs", iface_json(t->iface_in, t->n_iface_in));
        cJSON_AddItemToObject(o, "outputs", iface_json(t->iface_out, t->n_iface_out));
        tree_json(g, t, o);
        cJSON_AddItemToObject(groups, t->name, o);
    }
    char *text = cJSON_Print(root);
    cJSON_Delete(root);
    return text;
}

int sg_graph_save_file(const sg_graph *g, const char *path, char *err, size_t errlen)
{
    char *text = sg_graph_to_json(g);
    if (!text)
        return sg_error_set(err, errlen, "%s: out of memory", path);
    size_t n = strlen(path) + 32;
    char *tmp = malloc(n);
    if (!tmp) {
        free(text);
        return sg_error_set(err, errlen, "%s: out of memory", path);
    }
    snprintf(tmp, n, "%s.tmp.%ld", path, (long)getpid());
    FILE *f = fopen(tmp, "wb");
    int rc = 0;
    if (!f) {
        rc = sg_error_set(err, errlen, "%s: cannot write: %s", path, strerror(errno));
    } else {
        size_t len = strlen(text);
        bool ok = fwrite(text, 1, len, f) == len && fputc('\n', f) != EOF;
        ok = (fclose(f) == 0) && ok;
        if (!ok || rename(tmp, path) != 0) {
            rc = sg_error_set(err, errlen, "%s: cannot write: %s", path, strerror(errno));
            remove(tmp);
        }
    }
    free(tmp);
    free(text);
    return rc;
}
