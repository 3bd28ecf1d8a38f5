/*
 * Sub-shader extraction: the small graph that computes exactly what a big graph
 * computes for one set of constant inputs (typically: the super-shader with its
 * parameters bound).
 *
 * 1. Inline every group into one flat tree and drop reroutes. Where a group's
 *    interface socket changes a value's type (a colour entering a float socket, say),
 *    a small converter node keeps the conversion Blender would have made there.
 * 2. Repeat until nothing changes:
 *    - fold: a node whose inputs are all constant (and that reads no geometry) is
 *      evaluated once, with the same kernel the evaluator uses, and its consumers get
 *      the values;
 *    - bypass identities whose result is the other operand bit for bit:
 *      x+0, x-0, x*1, x/1, x^1, and a Mix whose factor is 0;
 *    - absorbing cases: x*0 -> 0 when x is known finite, 0/x -> 0, x^0 -> 1;
 *    - merge nodes that compute the same thing from the same inputs;
 *    - drop nodes that do not reach the Material Output.
 * 3. Lay out the result in columns by depth from the output.
 *
 * "Bit for bit" is the contract: every rewrite must give the same float. Where IEEE
 * arithmetic says otherwise (a + (b - a) is not always b, so a Mix with factor 1 is
 * kept), the rewrite is not made. The one liberty taken is the sign of zero: x + 0
 * is +0 for x = -0, x * 0 is -0 for negative x, and the rewrites ignore that. The two
 * zeros compare equal, and the sub-shader test compares values with ==.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shadergraph/graph_internal.h"
#include "shadergraph/program.h"

/* ---- a growable flat tree --------------------------------------------------------- */

typedef struct flat {
    sg_tree t;
    int cap_nodes, cap_links;
    bool *dead;
    int cap_dead;
    sg_error *err;
    bool failed;
    const sg_graph *src;
} flat;

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

static int oom(flat *f)
{
    if (!f->failed)
        sg_error_set(f->err, "out of memory during extraction");
    f->failed = true;
    return -1;
}

/* Appends a copy of typed node `n` named `name`; returns its index. */
static int add_node(flat *f, const sg_node *n, const char *name)
{
    if (f->t.n_nodes == f->cap_nodes) {
        int cap = f->cap_nodes ? 2 * f->cap_nodes : 64;
        sg_node *a = realloc(f->t.nodes, sizeof *a * (size_t)cap);
        bool *d = realloc(f->dead, sizeof *d * (size_t)cap);
        if (!a || !d) {
            if (a)
                f->t.nodes = a;
            if (d)
                f->dead = d;
            return oom(f);
        }
        f->t.nodes = a;
        f->dead = d;
        f->cap_nodes = cap;
    }
    sg_node *m = &f->t.nodes[f->t.n_nodes];
    *m = *n;
    m->name = dup_str(name);
    m->label = n->label ? dup_str(n->label) : NULL;
    m->group = -1;
    m->in = malloc(sizeof *m->in * (size_t)(n->n_in + 1));
    m->out = malloc(sizeof *m->out * (size_t)(n->n_out + 1));
    m->ramp = NULL;
    if (n->ramp && (m->ramp = malloc(sizeof *m->ramp)))
        *m->ramp = *n->ramp;
    if (!m->name || !m->in || !m->out || (n->ramp && !m->ramp)) {
        free(m->name);
        free(m->label);
        free(m->in);
        free(m->out);
        free(m->ramp);
        return oom(f);
    }
    memcpy(m->in, n->in, sizeof *m->in * (size_t)n->n_in);
    memcpy(m->out, n->out, sizeof *m->out * (size_t)n->n_out);
    f->dead[f->t.n_nodes] = false;
    return f->t.n_nodes++;
}

/* A fresh node of type idname with Blender's defaults. */
static int add_typed_node(flat *f, const char *idname, const char *name)
{
    const sg_node_type *t = sg_node_type_find(idname);
    sg_node n = {0};
    sg_socket in[8], out[8];
    n.type = t;
    n.group = -1;
    n.n_in = t->n_inputs;
    n.n_out = t->n_outputs;
    n.in = in;
    n.out = out;
    for (int k = 0; k < t->n_props; k++)
        n.prop[k] = t->props[k].default_value;
    for (int k = 0; k < t->n_inputs && k < 8; k++) {
        in[k] = (sg_socket){t->inputs[k].identifier, t->inputs[k].type, {0}, true, t->inputs[k].implicit};
        memcpy(in[k].value, t->inputs[k].default_value, sizeof in[k].value);
    }
    for (int k = 0; k < t->n_outputs && k < 8; k++)
        out[k] = (sg_socket){t->outputs[k].identifier, t->outputs[k].type, {0}, true, SG_IMPLICIT_NONE};
    int idx = add_node(f, &n, name);
    if (idx >= 0)
        for (int k = 0; k < t->n_inputs; k++)
            f->t.nodes[idx].in[k].available = sg_socket_available(&t->inputs[k], f->t.nodes[idx].prop);
    return idx;
}

static void add_link(flat *f, int from, int from_socket, int to, int to_socket)
{
    if (f->t.n_links == f->cap_links) {
        int cap = f->cap_links ? 2 * f->cap_links : 128;
        sg_link *a = realloc(f->t.links, sizeof *a * (size_t)cap);
        if (!a) {
            oom(f);
            return;
        }
        f->t.links = a;
        f->cap_links = cap;
    }
    f->t.links[f->t.n_links++] = (sg_link){from, from_socket, to, to_socket};
}

/* ---- 1. inlining ------------------------------------------------------------------ */

typedef struct source {
    bool is_const;
    sg_socket_type type;
    float value[4];
    int node, socket; /* in the flat tree */
} source;

typedef struct context {
    const sg_tree *tree;
    struct context *parent;
    int parent_node;
    char *prefix;          /* "Group/" path of names */
    int *map;              /* per node of tree: flat index (typed nodes), -1 otherwise */
    struct context **child; /* per group node, lazily */
} context;

static source resolve_out(flat *f, context *c, int node, int socket);

static context *new_context(flat *f, const sg_tree *t, context *parent, int parent_node,
                            const char *prefix);

static source resolve_in(flat *f, context *c, int node, int k)
{
    const sg_tree *t = c->tree;
    int l = sg_tree_input_link(t, node, k);
    if (l >= 0)
        return resolve_out(f, c, t->links[l].from_node, t->links[l].from_socket);
    source s = {.is_const = true, .type = t->nodes[node].in[k].type, .node = -1};
    memcpy(s.value, t->nodes[node].in[k].value, sizeof s.value);
    return s;
}

static void set_enum(sg_node *n, const char *prop, const char *value)
{
    int k = sg_node_type_prop_index(n->type, prop);
    for (int v = 0; k >= 0 && n->type->props[k].values[v]; v++)
        if (!strcmp(n->type->props[k].values[v], value))
            n->prop[k] = v;
}

/* Keeps the conversion Blender makes at a group interface socket of type `to`. */
static source convert_at_interface(flat *f, source s, sg_socket_type to, const char *name)
{
    bool vec_from = s.type == SG_SOCKET_VECTOR || s.type == SG_SOCKET_COLOR;
    bool vec_to = to == SG_SOCKET_VECTOR || to == SG_SOCKET_COLOR;
    if (s.type == to || (!vec_from && !vec_to))
        return s;
    if (s.is_const) {
        sg_convert_constant(s.type, to, s.value, s.value);
        s.type = to;
        return s;
    }
    char nm[600];
    source r = s;
    r.type = to;
    if (!vec_to) {
        /* colour/vector -> float: Math x*1 converts at its float input, exactly. */
        snprintf(nm, sizeof nm, "%s (to float)", name);
        int m = add_typed_node(f, "ShaderNodeMath", nm);
        if (m < 0)
            return r;
        sg_node *n = &f->t.nodes[m];
        set_enum(n, "operation", "MULTIPLY");
        n->in[1].value[0] = 1.0f;
        add_link(f, s.node, s.socket, m, 0);
        r.node = m;
        r.socket = 0;
        return r;
    }
    /* float -> vector/colour broadcasts, colour <-> vector copies: rebuild with a
     * Combine node of the target type, fed by the float or by a Separate node. */
    const char *combine = to == SG_SOCKET_COLOR ? "ShaderNodeCombineColor" : "ShaderNodeCombineXYZ";
    snprintf(nm, sizeof nm, "%s (to %s)", name, sg_socket_type_name(to));
    int cnode = add_typed_node(f, combine, nm);
    if (cnode < 0)
        return r;
    if (!vec_from) {
        for (int k = 0; k < 3; k++)
            add_link(f, s.node, s.socket, cnode, k);
    } else {
        const char *separate = s.type == SG_SOCKET_COLOR ? "ShaderNodeSeparateColor" : "ShaderNodeSeparateXYZ";
        snprintf(nm, sizeof nm, "%s (split)", name);
        int snode = add_typed_node(f, separate, nm);
        if (snode < 0)
            return r;
        add_link(f, s.node, s.socket, snode, 0);
        for (int k = 0; k < 3; k++)
            add_link(f, snode, k, cnode, k);
    }
    r.node = cnode;
    r.socket = 0;
    return r;
}

static source resolve_out(flat *f, context *c, int node, int socket)
{
    source none = {.is_const = true, .node = -1};
    if (f->failed)
        return none;
    const sg_tree *t = c->tree;
    const sg_node *n = &t->nodes[node];
    const char *id = n->type->idname;
    if (!strcmp(id, "NodeReroute"))
        return resolve_in(f, c, node, 0);
    if (!strcmp(id, "NodeGroupInput")) {
        source s = resolve_in(f, c->parent, c->parent_node, socket);
        return convert_at_interface(f, s, n->out[socket].type, n->out[socket].identifier);
    }
    if (n->group >= 0) {
        if (!c->child[node]) {
            char *prefix = malloc(strlen(c->prefix) + strlen(n->name) + 2);
            if (!prefix)
                return oom(f), none;
            sprintf(prefix, "%s%s/", c->prefix, n->name);
            c->child[node] = new_context(f, &f->src->groups[n->group], c, node, prefix);
            free(prefix);
            if (!c->child[node])
                return none;
        }
        context *ch = c->child[node];
        for (int i = 0; i < ch->tree->n_nodes; i++)
            if (!strcmp(ch->tree->nodes[i].type->idname, "NodeGroupOutput")) {
                source s = resolve_in(f, ch, i, socket);
                return convert_at_interface(f, s, n->out[socket].type, n->out[socket].identifier);
            }
        source s = {.is_const = true, .type = n->out[socket].type, .node = -1};
        memcpy(s.value, n->out[socket].value, sizeof s.value);
        return s;
    }
    if (!strcmp(id, "ShaderNodeValue") || !strcmp(id, "ShaderNodeRGB")) {
        source s = {.is_const = true, .type = n->out[socket].type, .node = -1};
        memcpy(s.value, n->out[socket].value, sizeof s.value);
        return s;
    }
    source s = {.is_const = false, .type = n->out[socket].type, .node = c->map[node], .socket = socket};
    return s;
}

static context *new_context(flat *f, const sg_tree *t, context *parent, int parent_node,
                            const char *prefix)
{
    context *c = calloc(1, sizeof *c);
    if (!c || !(c->map = malloc(sizeof(int) * (size_t)(t->n_nodes + 1))) ||
        !(c->child = calloc((size_t)t->n_nodes + 1, sizeof *c->child)) ||
        !(c->prefix = dup_str(prefix))) {
        if (c) {
            free(c->map);
            free(c->child);
            free(c);
        }
        oom(f);
        return NULL;
    }
    c->tree = t;
    c->parent = parent;
    c->parent_node = parent_node;
    /* Typed nodes first, so links inside this tree can point at any of them. */
    for (int i = 0; i < t->n_nodes; i++) {
        const sg_node *n = &t->nodes[i];
        c->map[i] = -1;
        if ((n->type->flags & SG_NODE_STRUCTURAL) || !strcmp(n->type->idname, "ShaderNodeValue") ||
            !strcmp(n->type->idname, "ShaderNodeRGB"))
            continue;
        char *name = malloc(strlen(prefix) + strlen(n->name) + 1);
        if (!name)
            return oom(f), c;
        sprintf(name, "%s%s", prefix, n->name);
        c->map[i] = add_node(f, n, name);
        free(name);
    }
    for (int i = 0; i < t->n_nodes && !f->failed; i++) {
        if (c->map[i] < 0)
            continue;
        for (int k = 0; k < t->nodes[i].n_in; k++) {
            if (sg_tree_input_link(t, i, k) < 0)
                continue;
            source s = resolve_in(f, c, i, k);
            if (f->failed)
                break;
            sg_socket *in = &f->t.nodes[c->map[i]].in[k];
            float conv[4];
            if (s.is_const)
                sg_convert_constant(s.type, in->type, s.value, conv);
            if (s.is_const && in->type == SG_SOCKET_COLOR &&
                (conv[0] < 0.0f || conv[1] < 0.0f || conv[2] < 0.0f)) {
                /* A colour socket cannot hold a negative value (Blender clamps it), but
                 * a link can carry one: build it with Combine Color from floats. */
                char nm[600];
                snprintf(nm, sizeof nm, "%s%s (%s)", prefix, t->nodes[i].name, in->identifier);
                int cc = add_typed_node(f, "ShaderNodeCombineColor", nm);
                if (cc < 0)
                    break;
                for (int ch = 0; ch < 3; ch++)
                    f->t.nodes[cc].in[ch].value[0] = conv[ch];
                add_link(f, cc, 0, c->map[i], k);
            } else if (s.is_const) {
                memcpy(in->value, conv, sizeof conv);
                /* A constant now sits where a link was: an implicit input must not
                 * fall back to geometry. */
                in->implicit = SG_IMPLICIT_NONE;
            } else {
                add_link(f, s.node, s.socket, c->map[i], k);
            }
        }
    }
    return c;
}

static void free_context(context *c)
{
    if (!c)
        return;
    for (int i = 0; i < c->tree->n_nodes; i++)
        free_context(c->child[i]);
    free(c->child);
    free(c->map);
    free(c->prefix);
    free(c);
}

/* ---- 2. simplification ------------------------------------------------------------ */

static int input_link(const flat *f, int node, int k) { return sg_tree_input_link(&f->t, node, k); }

static void remove_link(flat *f, int l) { f->t.links[l] = f->t.links[--f->t.n_links]; }

static bool is_const_input(const flat *f, int node, int k)
{
    const sg_socket *s = &f->t.nodes[node].in[k];
    return input_link(f, node, k) < 0 && s->implicit == SG_IMPLICIT_NONE;
}

static int prop_of(const sg_node *n, const char *name)
{
    int k = sg_node_type_prop_index(n->type, name);
    return k >= 0 ? n->prop[k] : -1;
}

static bool prop_is(const sg_node *n, const char *name, const char *value)
{
    int k = sg_node_type_prop_index(n->type, name);
    return k >= 0 && n->type->props[k].values && !strcmp(n->type->props[k].values[n->prop[k]], value);
}

/* Gives every consumer of (node, socket) the constant `v` of type t, except where the
 * value cannot be stored: Blender clamps colour sockets at 0, so a negative colour stays
 * computed by its node. Returns how many links were replaced. */
static int replace_output_by_constant(flat *f, int node, int socket, sg_socket_type t, const float *v)
{
    int replaced = 0;
    for (int l = f->t.n_links - 1; l >= 0; l--) {
        sg_link k = f->t.links[l];
        if (k.from_node != node || k.from_socket != socket)
            continue;
        sg_socket *in = &f->t.nodes[k.to_node].in[k.to_socket];
        float conv[4];
        sg_convert_constant(t, in->type, v, conv);
        if (in->type == SG_SOCKET_COLOR && (conv[0] < 0.0f || conv[1] < 0.0f || conv[2] < 0.0f))
            continue;
        memcpy(in->value, conv, sizeof conv);
        in->implicit = SG_IMPLICIT_NONE;
        remove_link(f, l);
        replaced++;
    }
    return replaced;
}

/* Relinks every consumer of (node, socket) to (src, src_socket). */
static void redirect_output(flat *f, int node, int socket, int src, int src_socket)
{
    for (int l = 0; l < f->t.n_links; l++) {
        sg_link *k = &f->t.links[l];
        if (k->from_node == node && k->from_socket == socket) {
            k->from_node = src;
            k->from_socket = src_socket;
        }
    }
}

static bool has_consumers(const flat *f, int node)
{
    for (int l = 0; l < f->t.n_links; l++)
        if (f->t.links[l].from_node == node)
            return true;
    return false;
}

/* Evaluates a node whose inputs are all constant, with its own kernel. */
static bool fold_node(flat *f, int node, sg_blender_mode mode)
{
    sg_node *n = &f->t.nodes[node];
    const sg_node_type *t = n->type;
    if (!t->kernel || (t->flags & (SG_NODE_READS_GEOMETRY | SG_NODE_SINK)) ||
        !strcmp(t->idname, "ShaderNodeBump"))
        return false;
    for (int k = 0; k < n->n_in; k++)
        if (n->in[k].available && !is_const_input(f, node, k))
            return false;
    float inv[16][4], outv[16][4];
    const float *in[16];
    float *out[16];
    if (n->n_in > 16 || n->n_out > 16)
        return false;
    for (int k = 0; k < n->n_in; k++) {
        /* n = 1: a planar vector is just x, y, z. */
        memcpy(inv[k], n->in[k].value, sizeof inv[k]);
        in[k] = inv[k];
    }
    for (int k = 0; k < n->n_out; k++)
        out[k] = outv[k];
    sg_kernel_args a = {.n = 1, .blender = mode, .prop = n->prop, .ramp = n->ramp,
                        .in = in, .out = out, .geom = NULL, .offset = 0};
    t->kernel(&a);
    int replaced = 0;
    for (int k = 0; k < n->n_out; k++)
        replaced += replace_output_by_constant(f, node, k, n->out[k].type, outv[k]);
    return replaced > 0;
}

/* Values that are certainly finite, for the x*0 rule: textures, ramps and anything
 * clamped. Conservative: false when unsure. */
static bool known_finite(const flat *f, int node, int socket)
{
    const sg_node *n = &f->t.nodes[node];
    const char *id = n->type->idname;
    if (!strcmp(id, "ShaderNodeTexNoise") || !strcmp(id, "ShaderNodeTexWhiteNoise") ||
        !strcmp(id, "ShaderNodeValToRGB") || !strcmp(id, "ShaderNodeTexCoord"))
        return true;
    if (!strcmp(id, "ShaderNodeTexVoronoi"))
        return strcmp(n->out[socket].identifier, "Position") != 0;
    if (!strcmp(id, "ShaderNodeMath") || !strcmp(id, "ShaderNodeMapRange"))
        return prop_of(n, !strcmp(id, "ShaderNodeMath") ? "use_clamp" : "clamp") == 1;
    if (!strcmp(id, "ShaderNodeClamp"))
        return true;
    return false;
}

/* Math identities and absorbing elements. Returns true if the graph changed. */
static bool simplify_math(flat *f, int node)
{
    sg_node *n = &f->t.nodes[node];
    if (strcmp(n->type->idname, "ShaderNodeMath") != 0 || prop_of(n, "use_clamp") == 1)
        return false;
    bool c0 = is_const_input(f, node, 0), c1 = is_const_input(f, node, 1);
    float v0 = n->in[0].value[0], v1 = n->in[1].value[0];
    /* The varying operand, if it can stand for the result: only when no type
     * conversion happened at the input (a colour's luminance is not the colour). */
    int l0 = input_link(f, node, 0), l1 = input_link(f, node, 1);
    bool pass0 = l0 >= 0 && f->t.nodes[f->t.links[l0].from_node].out[f->t.links[l0].from_socket].type == SG_SOCKET_FLOAT;
    bool pass1 = l1 >= 0 && f->t.nodes[f->t.links[l1].from_node].out[f->t.links[l1].from_socket].type == SG_SOCKET_FLOAT;
    int pass = -1;
    float constant = 0.0f;
    bool absorb = false;
    if (prop_is(n, "operation", "ADD")) {
        if (c1 && v1 == 0.0f && pass0)
            pass = 0;
        else if (c0 && v0 == 0.0f && pass1)
            pass = 1;
    } else if (prop_is(n, "operation", "SUBTRACT")) {
        if (c1 && v1 == 0.0f && pass0)
            pass = 0;
    } else if (prop_is(n, "operation", "MULTIPLY")) {
        if (c1 && v1 == 1.0f && pass0)
            pass = 0;
        else if (c0 && v0 == 1.0f && pass1)
            pass = 1;
        else if ((c1 && v1 == 0.0f && l0 >= 0 && known_finite(f, f->t.links[l0].from_node, f->t.links[l0].from_socket)) ||
                 (c0 && v0 == 0.0f && l1 >= 0 && known_finite(f, f->t.links[l1].from_node, f->t.links[l1].from_socket)))
            absorb = true, constant = 0.0f;
    } else if (prop_is(n, "operation", "DIVIDE")) {
        if (c1 && v1 == 1.0f && pass0)
            pass = 0;
        else if (c0 && v0 == 0.0f)
            absorb = true, constant = 0.0f; /* safe division: 0/x is 0 (or -0), and 0 for x = 0 */
    } else if (prop_is(n, "operation", "POWER")) {
        if (c1 && v1 == 1.0f && pass0)
            pass = 0;
        else if (c1 && v1 == 0.0f)
            absorb = true, constant = 1.0f; /* pow(x, 0) = 1 for every x */
    }
    if (pass >= 0) {
        const sg_link *l = &f->t.links[pass == 0 ? l0 : l1];
        redirect_output(f, node, 0, l->from_node, l->from_socket);
        return true;
    }
    if (absorb) {
        float v[4] = {constant, 0, 0, 0};
        return replace_output_by_constant(f, node, 0, SG_SOCKET_FLOAT, v) > 0;
    }
    return false;
}

/* Mix with a constant factor of 0 returns A: a + 0 * (b - a) is a when b - a is
 * finite and a is not -0. We require both operands known finite (so b - a cannot
 * overflow... it can: finite - finite may overflow only beyond 1.7e38, which known
 * finite sources never reach) and accept the -0 liberty stated at the top. */
static bool simplify_mix(flat *f, int node)
{
    sg_node *n = &f->t.nodes[node];
    if (strcmp(n->type->idname, "ShaderNodeMix") != 0)
        return false;
    int dt = prop_of(n, "data_type"); /* FLOAT, VECTOR, RGBA */
    if (dt == 1 && prop_is(n, "factor_mode", "NON_UNIFORM"))
        return false;
    if (dt == 2 && (prop_of(n, "clamp_result") == 1 || !prop_is(n, "blend_type", "MIX")))
        return false;
    const char *fac = dt == 1 ? "Factor_Float" : "Factor_Float";
    const char *a_id = dt == 0 ? "A_Float" : dt == 1 ? "A_Vector" : "A_Color";
    const char *b_id = dt == 0 ? "B_Float" : dt == 1 ? "B_Vector" : "B_Color";
    const char *r_id = dt == 0 ? "Result_Float" : dt == 1 ? "Result_Vector" : "Result_Color";
    int kf = sg_node_input_index(n, fac), ka = sg_node_input_index(n, a_id),
        kb = sg_node_input_index(n, b_id), kr = sg_node_output_index(n, r_id);
    if (kf < 0 || ka < 0 || kb < 0 || kr < 0 || !is_const_input(f, node, kf) || n->in[kf].value[0] != 0.0f)
        return false;
    int la = input_link(f, node, ka), lb = input_link(f, node, kb);
    bool b_finite = lb < 0 || known_finite(f, f->t.links[lb].from_node, f->t.links[lb].from_socket);
    if (!b_finite)
        return false;
    if (la < 0) {
        if (!isfinite(n->in[ka].value[0]))
            return false;
        return replace_output_by_constant(f, node, kr, n->in[ka].type, n->in[ka].value) > 0;
    }
    const sg_link *l = &f->t.links[la];
    if (f->t.nodes[l->from_node].out[l->from_socket].type != n->in[ka].type ||
        !known_finite(f, l->from_node, l->from_socket))
        return false;
    redirect_output(f, node, kr, l->from_node, l->from_socket);
    return true;
}

/* Marks nodes that do not reach the Material Output dead. Returns true if any died. */
static bool remove_dead(flat *f)
{
    int n = f->t.n_nodes;
    bool *live = calloc((size_t)n + 1, sizeof *live);
    int *stack = malloc(sizeof(int) * ((size_t)n + 1));
    if (!live || !stack) {
        free(live);
        free(stack);
        oom(f);
        return false;
    }
    int sp = 0;
    for (int i = 0; i < n; i++)
        if (!f->dead[i] && !strcmp(f->t.nodes[i].type->idname, "ShaderNodeOutputMaterial")) {
            live[i] = true;
            stack[sp++] = i;
        }
    while (sp > 0) {
        int v = stack[--sp];
        for (int l = 0; l < f->t.n_links; l++)
            if (f->t.links[l].to_node == v && !live[f->t.links[l].from_node]) {
                live[f->t.links[l].from_node] = true;
                stack[sp++] = f->t.links[l].from_node;
            }
    }
    bool changed = false;
    for (int i = 0; i < n; i++)
        if (!f->dead[i] && !live[i]) {
            f->dead[i] = true;
            changed = true;
        }
    for (int l = f->t.n_links - 1; l >= 0; l--)
        if (f->dead[f->t.links[l].from_node] || f->dead[f->t.links[l].to_node])
            remove_link(f, l);
    free(live);
    free(stack);
    return changed;
}

/* Two live nodes compute the same thing: same type, properties, ramp, and for each
 * input the same link source or the same constant. `src` holds, per node, the
 * first input's slot in `link_of` (the link into each input, or -1). */
static bool same_node(const flat *f, const int *first_in, const int *link_of, int a, int b)
{
    const sg_node *x = &f->t.nodes[a], *y = &f->t.nodes[b];
    if (x->type != y->type || (x->type->flags & SG_NODE_SINK) ||
        memcmp(x->prop, y->prop, sizeof x->prop) != 0)
        return false;
    if ((x->ramp == NULL) != (y->ramp == NULL) || (x->ramp && memcmp(x->ramp, y->ramp, sizeof *x->ramp)))
        return false;
    for (int k = 0; k < x->n_in; k++) {
        int la = link_of[first_in[a] + k], lb = link_of[first_in[b] + k];
        if ((la < 0) != (lb < 0))
            return false;
        if (la >= 0) {
            if (f->t.links[la].from_node != f->t.links[lb].from_node ||
                f->t.links[la].from_socket != f->t.links[lb].from_socket)
                return false;
        } else if (x->in[k].implicit != y->in[k].implicit ||
                   memcmp(x->in[k].value, y->in[k].value, sizeof x->in[k].value)) {
            return false;
        }
    }
    return true;
}

static bool merge_duplicates(flat *f)
{
    int n = f->t.n_nodes;
    int *first_in = malloc(sizeof(int) * ((size_t)n + 1));
    int total = 0;
    for (int i = 0; first_in && i < n; i++) {
        first_in[i] = total;
        total += f->t.nodes[i].n_in;
    }
    int *link_of = malloc(sizeof(int) * ((size_t)total + 1));
    if (!first_in || !link_of) {
        free(first_in);
        free(link_of);
        oom(f);
        return false;
    }
    for (int i = 0; i < total; i++)
        link_of[i] = -1;
    for (int l = 0; l < f->t.n_links; l++)
        link_of[first_in[f->t.links[l].to_node] + f->t.links[l].to_socket] = l;
    bool changed = false;
    for (int a = 0; a < n; a++) {
        if (f->dead[a])
            continue;
        for (int b = a + 1; b < n; b++) {
            if (f->dead[b] || !same_node(f, first_in, link_of, a, b))
                continue;
            /* b's consumers now read a; b dies with remove_dead. Links only change
             * their sources, so link_of stays valid. */
            for (int k = 0; k < f->t.nodes[b].n_out; k++)
                redirect_output(f, b, k, a, k);
            f->dead[b] = true;
            changed = true;
        }
    }
    free(first_in);
    free(link_of);
    return changed;
}

/* ---- 3. layout -------------------------------------------------------------------- */

/* Columns by longest distance from the output, right to left; rows in order. */
static void layout(flat *f)
{
    int n = f->t.n_nodes;
    int *depth = calloc((size_t)n + 1, sizeof *depth);
    int *row = calloc((size_t)n + 2, sizeof *row);
    if (!depth || !row) {
        free(depth);
        free(row);
        oom(f);
        return;
    }
    /* Longest path from each node to the output: relax n times at most (a DAG). */
    for (bool changed = true; changed;) {
        changed = false;
        for (int l = 0; l < f->t.n_links; l++) {
            const sg_link *k = &f->t.links[l];
            if (depth[k->from_node] < depth[k->to_node] + 1) {
                depth[k->from_node] = depth[k->to_node] + 1;
                changed = true;
            }
        }
    }
    for (int i = 0; i < n; i++) {
        f->t.nodes[i].location[0] = -300.0f * (float)depth[i];
        f->t.nodes[i].location[1] = -250.0f * (float)row[depth[i]]++;
    }
    free(depth);
    free(row);
}

/* Drops dead nodes and renumbers links. */
static void compact(flat *f)
{
    int *remap = malloc(sizeof(int) * ((size_t)f->t.n_nodes + 1));
    if (!remap) {
        oom(f);
        return;
    }
    int m = 0;
    for (int i = 0; i < f->t.n_nodes; i++) {
        if (f->dead[i]) {
            sg_node *d = &f->t.nodes[i];
            free(d->name);
            free(d->label);
            free(d->ramp);
            free(d->in);
            free(d->out);
            remap[i] = -1;
            continue;
        }
        remap[i] = m;
        f->t.nodes[m] = f->t.nodes[i];
        f->dead[m] = false;
        m++;
    }
    f->t.n_nodes = m;
    for (int l = 0; l < f->t.n_links; l++) {
        f->t.links[l].from_node = remap[f->t.links[l].from_node];
        f->t.links[l].to_node = remap[f->t.links[l].to_node];
    }
    free(remap);
}

static int group_node_count(const sg_graph *g, int group)
{
    int count = 0;
    const sg_tree *t = &g->groups[group];
    for (int i = 0; i < t->n_nodes; i++) {
        const sg_node *n = &t->nodes[i];
        count += n->group >= 0 ? group_node_count(g, n->group) : 1;
    }
    return count;
}

int sg_graph_node_count(const sg_graph *g)
{
    /* Nodes as a user sees them in Blender with every group expanded: a group
     * instance counts its group's nodes, recursively, in place of itself. */
    int count = 0;
    for (int i = 0; i < g->main.n_nodes; i++) {
        const sg_node *n = &g->main.nodes[i];
        count += n->group >= 0 ? group_node_count(g, n->group) : 1;
    }
    return count;
}

sg_graph *sg_extract(const sg_graph *g, const sg_extract_options *opt, sg_error *err)
{
    sg_blender_mode mode = opt && opt->blender ? opt->blender : SG_BLENDER_4;
    flat f = {.err = err, .src = g};
    context *root = new_context(&f, &g->main, NULL, -1, "");
    free_context(root);
    /* Material Output nodes other than the active one do not matter; keep them all:
     * remove_dead keeps whatever reaches any of them. */
    for (int round = 0; !f.failed && round < 10000; round++) {
        bool changed = false;
        for (int i = 0; i < f.t.n_nodes && !f.failed; i++) {
            if (f.dead[i])
                continue;
            if (has_consumers(&f, i) && fold_node(&f, i, mode)) {
                changed = true;
                continue;
            }
            changed |= simplify_math(&f, i);
            changed |= simplify_mix(&f, i);
        }
        changed |= merge_duplicates(&f);
        changed |= remove_dead(&f);
        if (!changed)
            break;
    }
    if (!f.failed)
        compact(&f);
    if (!f.failed)
        layout(&f);
    sg_graph *out = calloc(1, sizeof *out);
    if (f.failed || !out || !(out->name = dup_str(g->name)) || !(out->main.name = dup_str(g->name))) {
        if (!f.failed)
            sg_error_set(err, "out of memory during extraction");
        for (int i = 0; i < f.t.n_nodes; i++)
            if (!f.dead[i]) {
                free(f.t.nodes[i].name);
                free(f.t.nodes[i].label);
                free(f.t.nodes[i].ramp);
                free(f.t.nodes[i].in);
                free(f.t.nodes[i].out);
            }
        free(f.t.nodes);
        free(f.t.links);
        free(f.dead);
        if (out) {
            free(out->name);
            free(out);
        }
        return NULL;
    }
    out->main.nodes = f.t.nodes;
    out->main.n_nodes = f.t.n_nodes;
    out->main.links = f.t.links;
    out->main.n_links = f.t.n_links;
    free(f.dead);
    return out;
}
