/*
 * Flattening and folding graphs: the sub-shader extraction of issue 3, and the graph
 * the compiler actually compiles.
 *
 * 1. Inline every group into one flat tree and drop reroutes and Value/RGB nodes.
 *    Where a group's interface socket changes a value's type (a colour entering a
 *    float socket, say), a small converter node keeps the conversion Blender makes.
 * 2. Repeat until nothing changes: apply Cycles' constant folding (see "Cycles'
 *    constant folding" below: the same folds Blender applies before rendering, so
 *    they are part of what a material computes), merge nodes that compute the same
 *    thing from the same inputs, and (for extraction) drop nodes that do not reach
 *    the Material Output.
 * 3. For extraction, lay out the result in columns by depth from the output.
 *
 * sg_compile compiles the folded graph, and sg_extract returns it: so a sub-shader
 * evaluates to exactly what its super-shader evaluates to, by construction, and
 * tests/unit/test_extract.c checks it on the super-shader anyway. Values are compared
 * with ==: the folds are Cycles' algebraic ones, which may turn -0 into +0.
 */
#include <limits.h>
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
    int n_contexts; /* group instances made so far: bounded like nodes */
    int depth;      /* resolve_out calls on the stack: at most SG_MAX_RESOLVE_DEPTH */
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
    /* Groups nested in groups multiply: a few kilobytes of JSON can inline to billions
     * of nodes. */
    if (f->t.n_nodes >= SG_MAX_FLAT_NODES) {
        if (!f->failed)
            sg_error_set(f->err, "more than %d nodes once the groups are inlined (FORMAT.md, Limits)",
                         SG_MAX_FLAT_NODES);
        f->failed = true;
        return -1;
    }
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

static source resolve_out_step(flat *f, context *c, int node, int socket);

/* What feeds output `socket` of `node`: a node of the flat graph or a constant. The
 * walk recurses through reroutes and group interfaces (a typed node is looked up, not
 * walked), so its depth is how many of those one link path crosses: bounded, as SQLite
 * bounds expression depth, so that the stack is (a chain of 20,000 pass-through groups
 * overflowed it in a debug build). */
static source resolve_out(flat *f, context *c, int node, int socket)
{
    source none = {.is_const = true, .node = -1};
    if (f->failed)
        return none;
    if (f->depth >= SG_MAX_RESOLVE_DEPTH) {
        sg_error_set(f->err, "a link path crosses more than %d reroutes and group interfaces "
                             "(FORMAT.md, Limits)", SG_MAX_RESOLVE_DEPTH);
        f->failed = true;
        return none;
    }
    f->depth++;
    source s = resolve_out_step(f, c, node, socket);
    f->depth--;
    return s;
}

static source resolve_out_step(flat *f, context *c, int node, int socket)
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
    /* A group of nothing but nested groups inlines to no nodes, but its instances
     * multiply all the same. */
    if (++f->n_contexts > SG_MAX_FLAT_NODES) {
        if (!f->failed)
            sg_error_set(f->err, "more than %d group instances once the groups are inlined "
                         "(FORMAT.md, Limits)", SG_MAX_FLAT_NODES);
        f->failed = true;
        return NULL;
    }
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

static bool has_output_consumers(const flat *f, int node, int socket)
{
    for (int l = 0; l < f->t.n_links; l++)
        if (f->t.links[l].from_node == node && f->t.links[l].from_socket == socket)
            return true;
    return false;
}

static bool has_consumers(const flat *f, int node)
{
    for (int l = 0; l < f->t.n_links; l++)
        if (f->t.links[l].from_node == node)
            return true;
    return false;
}

/* ---- Cycles' constant folding ------------------------------------------------------
 *
 * Blender renders a material after Cycles has constant-folded its graph, and some of
 * those folds are algebraic rather than arithmetic: x * 0 is 0 even where x is
 * infinite, a Mix with factor 1 is B itself rather than a + (b - a). So the folds
 * are part of what a node graph computes, and this evaluator applies exactly the ones
 * Cycles applies (scene/shader_nodes.cpp and constant_fold.cpp of Blender 3.4 and 4.3),
 * no more: that is what lets a sub-shader equal its super-shader bit for bit, and both
 * equal Blender. The rules, per node:
 *   - all inputs constant: the node becomes its value (Map Range, textures, Texture
 *     Coordinate and Bump never do);
 *   - Math: x+0, 0+x, x-0, x*1, 1*x, x/1, x^1 -> x; x*0, 0*x, 0/x -> 0; 1^x, x^0 -> 1
 *     (use_clamp is a Clamp node after the Math in Cycles: we keep the node instead of
 *     bypassing, which computes the same clamp(x));
 *   - Vector Math: the same for ADD, SUBTRACT, MULTIPLY, DIVIDE (x/0 -> 0 too), SCALE,
 *     and zero for DOT/CROSS with a zero operand, LENGTH/ABSOLUTE of zero;
 *   - Mix (colour) and Mix RGB: factor 0 -> A (except Lighten, Dodge, Burn), and per
 *     blend mode the rules of fold_mix; Mix float/vector: factor 0 -> A, factor 1 -> B,
 *     A and B the same -> A (Blender 4.x only; 3.x folds them only when all constant);
 *   - Mapping: zero scale -> 0; an identity transform -> the vector;
 *   - Invert: factor 0 -> the colour;
 *   - Bump: no Height link -> the Normal input.
 * "Constant 0" means an unlinked input equal to 0 (so -0 too; NaN never). */

typedef struct fold {
    flat *f;
    int node;
    sg_blender_mode mode;
} fold;

static bool is_vec_type(sg_socket_type t) { return t == SG_SOCKET_VECTOR || t == SG_SOCKET_COLOR; }

static bool input_constant(const fold *x, int k)
{
    return k >= 0 && is_const_input(x->f, x->node, k);
}

/* Cycles' is_zero / is_one: unlinked and every component equal. */
static bool input_equals(const fold *x, int k, float v)
{
    if (!input_constant(x, k))
        return false;
    const sg_socket *s = &x->f->t.nodes[x->node].in[k];
    int w = is_vec_type(s->type) ? 3 : 1;
    for (int c = 0; c < w; c++)
        if (!(s->value[c] == v))
            return false;
    return true;
}

static int in_index(const fold *x, const char *id) { return sg_node_input_index(&x->f->t.nodes[x->node], id); }
static int out_index(const fold *x, const char *id) { return sg_node_output_index(&x->f->t.nodes[x->node], id); }

/* Gives the consumers of output `out` the constant v (in the output's type). */
static bool make_constant(fold *x, int out, const float *v)
{
    return replace_output_by_constant(x->f, x->node, out, x->f->t.nodes[x->node].out[out].type, v) > 0;
}

static bool make_value(fold *x, int out, float value)
{
    float v[4] = {value, value, value, 1.0f};
    return make_constant(x, out, v);
}

/* Cycles' try_bypass_or_make_constant for input `in` standing in for output `out`
 * (same socket type): the input's constant (saturated if `clamp`), or its link when
 * not clamping. With `clamp` and a linked input Cycles keeps the node but cuts the
 * node's other links, so they read their stored values (a quirk we reproduce). */
static bool try_bypass(fold *x, int in, int out, bool clamp)
{
    flat *f = x->f;
    sg_node *n = &f->t.nodes[x->node];
    if (in < 0 || out < 0 || n->in[in].type != n->out[out].type)
        return false;
    if (input_constant(x, in)) {
        float v[4];
        memcpy(v, n->in[in].value, sizeof v);
        if (clamp)
            for (int c = 0; c < 3; c++)
                v[c] = v[c] > 0.0f ? (v[c] < 1.0f ? v[c] : 1.0f) : 0.0f;
        return make_constant(x, out, v);
    }
    int l = input_link(f, x->node, in);
    if (l < 0)
        return false; /* implicit geometry input: not a link we can point at */
    if (clamp) {
        bool cut = false;
        for (int k = 0; k < n->n_in; k++) {
            int lk = k == in ? -1 : input_link(f, x->node, k);
            if (lk >= 0) {
                remove_link(f, lk);
                cut = true;
            }
        }
        return cut;
    }
    /* Our links convert implicitly (Cycles inserts convert nodes). Relinking the
     * consumers straight to the source is exact when no conversion happened at this
     * input, or when the source is a float (a broadcast composes with any conversion
     * after it, and Cycles folds float -> colour -> float back to the float). */
    const sg_link *lk = &f->t.links[l];
    sg_socket_type src = f->t.nodes[lk->from_node].out[lk->from_socket].type;
    if (src != n->in[in].type && is_vec_type(src))
        return false;
    bool any = has_output_consumers(f, x->node, out);
    redirect_output(f, x->node, out, lk->from_node, lk->from_socket);
    return any;
}

/* All inputs constant: the node's value, computed by its own kernel. */
static bool fold_all_constant(fold *x)
{
    flat *f = x->f;
    sg_node *n = &f->t.nodes[x->node];
    const sg_node_type *t = n->type;
    float inv[16][4], outv[16][4];
    const float *in[16];
    float *out[16];
    if (n->n_in > 16 || n->n_out > 16)
        return false;
    for (int k = 0; k < n->n_in; k++) {
        memcpy(inv[k], n->in[k].value, sizeof inv[k]); /* n = 1: planar is x, y, z */
        in[k] = inv[k];
    }
    /* Kernels write width-many floats; a colour constant's alpha is 1, as Blender's. */
    for (int k = 0; k < n->n_out; k++) {
        outv[k][0] = outv[k][1] = outv[k][2] = 0.0f;
        outv[k][3] = 1.0f;
        out[k] = outv[k];
    }
    sg_kernel_args a = {.n = 1, .blender = x->mode, .prop = n->prop, .ramp = n->ramp,
                        .in = in, .out = out, .geom = NULL, .offset = 0, .host_fold = true};
    if (!strcmp(t->idname, "ShaderNodeInvert")) {
        /* Cycles folds Invert as interp(c, 1 - c, fac), not the kernel's
         * fac * (1 - c) + (1 - fac) * c: the last bit can differ. */
        float fac = n->in[0].value[0];
        for (int c = 0; c < 3; c++) {
            float col = n->in[1].value[c];
            outv[0][c] = col + fac * ((1.0f - col) - col);
        }
        outv[0][3] = 1.0f;
    } else {
        if (n->ramp && n->ramp->baked_steps == 0)
            sg_color_ramp_bake(n->ramp, x->mode);
        t->kernel(&a);
    }
    int replaced = 0;
    for (int k = 0; k < n->n_out; k++)
        replaced += make_constant(x, k, outv[k]);
    return replaced > 0;
}

static bool fold_math(fold *x)
{
    sg_node *n = &x->f->t.nodes[x->node];
    bool clamp = prop_of(n, "use_clamp") == 1;
    int v1 = 0, v2 = 1, out = 0;
    /* With use_clamp, Cycles' Clamp node follows: constants are saturated, and a
     * bypass would leave clamp(x), which the node itself computes. */
    float zero = 0.0f, one = 1.0f;
    if (prop_is(n, "operation", "ADD")) {
        if (input_equals(x, v1, 0.0f))
            return !clamp && try_bypass(x, v2, out, false);
        if (input_equals(x, v2, 0.0f))
            return !clamp && try_bypass(x, v1, out, false);
    } else if (prop_is(n, "operation", "SUBTRACT")) {
        if (input_equals(x, v2, 0.0f))
            return !clamp && try_bypass(x, v1, out, false);
    } else if (prop_is(n, "operation", "MULTIPLY")) {
        if (input_equals(x, v1, 1.0f))
            return !clamp && try_bypass(x, v2, out, false);
        if (input_equals(x, v2, 1.0f))
            return !clamp && try_bypass(x, v1, out, false);
        if (input_equals(x, v1, 0.0f) || input_equals(x, v2, 0.0f))
            return make_value(x, out, zero);
    } else if (prop_is(n, "operation", "DIVIDE")) {
        if (input_equals(x, v2, 1.0f))
            return !clamp && try_bypass(x, v1, out, false);
        if (input_equals(x, v1, 0.0f))
            return make_value(x, out, zero);
    } else if (prop_is(n, "operation", "POWER")) {
        if (input_equals(x, v1, 1.0f) || input_equals(x, v2, 0.0f))
            return make_value(x, out, one);
        if (input_equals(x, v2, 1.0f))
            return !clamp && try_bypass(x, v1, out, false);
    }
    return false;
}

static bool fold_vector_math(fold *x)
{
    sg_node *n = &x->f->t.nodes[x->node];
    int v1 = in_index(x, "Vector"), v2 = in_index(x, "Vector_001"), sc = in_index(x, "Scale");
    int ov = out_index(x, "Vector"), of = out_index(x, "Value");
    bool zero = false;
    int pass = -1;
    if (prop_is(n, "operation", "ADD")) {
        pass = input_equals(x, v1, 0.0f) ? v2 : input_equals(x, v2, 0.0f) ? v1 : -1;
    } else if (prop_is(n, "operation", "SUBTRACT")) {
        pass = input_equals(x, v2, 0.0f) ? v1 : -1;
    } else if (prop_is(n, "operation", "MULTIPLY")) {
        zero = input_equals(x, v1, 0.0f) || input_equals(x, v2, 0.0f);
        pass = zero ? -1 : input_equals(x, v1, 1.0f) ? v2 : input_equals(x, v2, 1.0f) ? v1 : -1;
    } else if (prop_is(n, "operation", "DIVIDE")) {
        zero = input_equals(x, v1, 0.0f) || input_equals(x, v2, 0.0f);
        pass = zero ? -1 : input_equals(x, v2, 1.0f) ? v1 : -1;
    } else if (prop_is(n, "operation", "DOT_PRODUCT") || prop_is(n, "operation", "CROSS_PRODUCT")) {
        zero = input_equals(x, v1, 0.0f) || input_equals(x, v2, 0.0f);
    } else if (prop_is(n, "operation", "LENGTH") || prop_is(n, "operation", "ABSOLUTE")) {
        zero = input_equals(x, v1, 0.0f);
    } else if (prop_is(n, "operation", "SCALE")) {
        zero = input_equals(x, v1, 0.0f) || input_equals(x, sc, 0.0f);
        pass = zero ? -1 : input_equals(x, sc, 1.0f) ? v1 : -1;
    }
    bool changed = false;
    if (zero) {
        changed |= make_value(x, ov, 0.0f);
        changed |= make_value(x, of, 0.0f);
    } else if (pass >= 0) {
        changed |= try_bypass(x, pass, ov, false); /* the Value output has another type */
    }
    return changed;
}

/* Cycles' fold_mix / fold_mix_color, for Mix RGB and the colour Mix; also the blend
 * rules the 4.x vector Mix uses. fac0/fac1: an unlinked factor equal to 0 / 1 after
 * the factor clamp (if any). */
static bool fold_mix_blend(fold *x, const char *blend, int fac, int a, int b, int out, bool clamp_factor,
                           bool clamp)
{
    sg_node *n = &x->f->t.nodes[x->node];
    float fv = n->in[fac].value[0];
    if (clamp_factor)
        fv = fv > 0.0f ? (fv < 1.0f ? fv : 1.0f) : 0.0f; /* NaN -> 0, as saturatef */
    bool fac0 = input_constant(x, fac) && fv == 0.0f;
    bool fac1 = input_constant(x, fac) && fv == 1.0f;
    if (fac0 && strcmp(blend, "LIGHTEN") && strcmp(blend, "DODGE") && strcmp(blend, "BURN")) {
        if (try_bypass(x, a, out, clamp))
            return true;
    }
    int la = input_link(x->f, x->node, a), lb = input_link(x->f, x->node, b);
    const sg_link *LA = la >= 0 ? &x->f->t.links[la] : NULL, *LB = lb >= 0 ? &x->f->t.links[lb] : NULL;
    bool same_link = LA && LB && LA->from_node == LB->from_node && LA->from_socket == LB->from_socket;
    if (!strcmp(blend, "MIX")) {
        if (same_link)
            return try_bypass(x, a, out, clamp);
        if (input_constant(x, a) && input_constant(x, b) && n->in[a].value[0] == n->in[b].value[0] &&
            n->in[a].value[1] == n->in[b].value[1] && n->in[a].value[2] == n->in[b].value[2])
            return try_bypass(x, a, out, clamp);
        if (fac1)
            return try_bypass(x, b, out, clamp);
    } else if (!strcmp(blend, "ADD")) {
        if (input_equals(x, a, 0.0f) && fac1)
            return try_bypass(x, b, out, clamp);
        if (input_equals(x, b, 0.0f))
            return try_bypass(x, a, out, clamp);
    } else if (!strcmp(blend, "SUBTRACT")) {
        if (input_equals(x, b, 0.0f))
            return try_bypass(x, a, out, clamp);
        if (same_link && fac1)
            return make_value(x, out, 0.0f);
    } else if (!strcmp(blend, "MULTIPLY")) {
        if (input_equals(x, a, 1.0f) && fac1)
            return try_bypass(x, b, out, clamp);
        if (input_equals(x, b, 1.0f))
            return try_bypass(x, a, out, clamp);
        if (input_equals(x, a, 0.0f) || (input_equals(x, b, 0.0f) && fac1))
            return make_value(x, out, 0.0f);
    } else if (!strcmp(blend, "DIVIDE")) {
        if (input_equals(x, b, 1.0f))
            return try_bypass(x, a, out, clamp);
        if (input_equals(x, a, 0.0f))
            return make_value(x, out, 0.0f);
    }
    return false;
}

static const char *enum_name(const sg_node *n, const char *prop)
{
    int k = sg_node_type_prop_index(n->type, prop);
    return k >= 0 ? n->type->props[k].values[n->prop[k]] : "";
}

static bool fold_mix(fold *x)
{
    sg_node *n = &x->f->t.nodes[x->node];
    const char *dt = enum_name(n, "data_type");
    bool clamp_factor = prop_of(n, "clamp_factor") == 1;
    int fac = in_index(x, "Factor_Float");
    if (!strcmp(dt, "RGBA"))
        return fold_mix_blend(x, enum_name(n, "blend_type"), fac, in_index(x, "A_Color"),
                              in_index(x, "B_Color"), out_index(x, "Result_Color"), clamp_factor,
                              prop_of(n, "clamp_result") == 1);
    if (x->mode == SG_BLENDER_3)
        return false; /* 3.x folds float and vector Mix only when all inputs are constant */
    if (!strcmp(dt, "VECTOR")) {
        if (prop_is(n, "factor_mode", "NON_UNIFORM"))
            return false;
        return fold_mix_blend(x, "MIX", fac, in_index(x, "A_Vector"), in_index(x, "B_Vector"),
                              out_index(x, "Result_Vector"), clamp_factor, false);
    }
    /* FLOAT: factor 0 -> A; A, B the same link or equal constants -> A; factor 1 -> B. */
    int a = in_index(x, "A_Float"), b = in_index(x, "B_Float"), out = out_index(x, "Result_Float");
    float fv = n->in[fac].value[0];
    if (clamp_factor)
        fv = fv > 0.0f ? (fv < 1.0f ? fv : 1.0f) : 0.0f;
    bool fac_const = input_constant(x, fac);
    if (fac_const && fv == 0.0f)
        return try_bypass(x, a, out, false);
    int la = input_link(x->f, x->node, a), lb = input_link(x->f, x->node, b);
    if (la >= 0 && lb >= 0 && x->f->t.links[la].from_node == x->f->t.links[lb].from_node &&
        x->f->t.links[la].from_socket == x->f->t.links[lb].from_socket)
        return try_bypass(x, a, out, false);
    if (input_constant(x, a) && input_constant(x, b) && n->in[a].value[0] == n->in[b].value[0])
        return try_bypass(x, a, out, false);
    if (fac_const && fv == 1.0f)
        return try_bypass(x, b, out, false);
    return false;
}

static bool fold_node(flat *f, int node, sg_blender_mode mode)
{
    fold x = {f, node, mode};
    sg_node *n = &f->t.nodes[node];
    const sg_node_type *t = n->type;
    const char *id = t->idname;
    if (!t->kernel || (t->flags & (SG_NODE_READS_GEOMETRY | SG_NODE_SINK)))
        return false;
    bool textures = !strncmp(id, "ShaderNodeTex", 13);
    bool never = textures || !strcmp(id, "ShaderNodeMapRange") || !strcmp(id, "ShaderNodeBump");
    if (!never) {
        bool all = true;
        for (int k = 0; k < n->n_in && all; k++)
            all = is_const_input(f, node, k);
        if (all)
            return fold_all_constant(&x);
    }
    if (!strcmp(id, "ShaderNodeMath"))
        return fold_math(&x);
    if (!strcmp(id, "ShaderNodeVectorMath"))
        return fold_vector_math(&x);
    if (!strcmp(id, "ShaderNodeMix"))
        return fold_mix(&x);
    if (!strcmp(id, "ShaderNodeMixRGB"))
        return fold_mix_blend(&x, enum_name(n, "blend_type"), 0, 1, 2, 0, true,
                              prop_of(n, "use_clamp") == 1);
    if (!strcmp(id, "ShaderNodeMapping")) {
        int vec = in_index(&x, "Vector"), loc = in_index(&x, "Location"),
            rot = in_index(&x, "Rotation"), sc = in_index(&x, "Scale");
        if (input_equals(&x, sc, 0.0f))
            return make_value(&x, 0, 0.0f);
        const char *vt = enum_name(n, "vector_type");
        if (strcmp(vt, "NORMAL") && (input_equals(&x, loc, 0.0f) || !strcmp(vt, "VECTOR")) &&
            input_equals(&x, rot, 0.0f) && input_equals(&x, sc, 1.0f))
            return try_bypass(&x, vec, 0, false);
        return false;
    }
    if (!strcmp(id, "ShaderNodeInvert")) {
        if (input_constant(&x, 0) && n->in[0].value[0] == 0.0f)
            return try_bypass(&x, 1, 0, false);
        return false;
    }
    if (!strcmp(id, "ShaderNodeBump")) {
        int h = in_index(&x, "Height"), nrm = in_index(&x, "Normal");
        if (input_link(f, node, h) < 0 && input_link(f, node, nrm) >= 0)
            return try_bypass(&x, nrm, 0, false);
        return false;
    }
    return false;
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

/* Memoised, since a group may be used many times and nested groups multiply; counts
 * saturate at INT_MAX (a few kilobytes of nested groups expand past it). Recursion
 * depth is at most the number of groups (SG_MAX_GROUPS); the load refused cycles. */
static int group_node_count(const sg_graph *g, int group, int *memo)
{
    if (memo[group] >= 0)
        return memo[group];
    long long count = 0;
    const sg_tree *t = &g->groups[group];
    for (int i = 0; i < t->n_nodes && count < INT_MAX; i++) {
        const sg_node *n = &t->nodes[i];
        count += n->group >= 0 ? group_node_count(g, n->group, memo) : 1;
    }
    return memo[group] = count < INT_MAX ? (int)count : INT_MAX;
}

int sg_graph_node_count(const sg_graph *g)
{
    /* Nodes as a user sees them in Blender with every group expanded: a group
     * instance counts its group's nodes, recursively, in place of itself. */
    int *memo = malloc(sizeof *memo * (size_t)(g->n_groups + 1));
    if (!memo)
        return -1;
    for (int i = 0; i < g->n_groups; i++)
        memo[i] = -1;
    long long count = 0;
    for (int i = 0; i < g->main.n_nodes && count < INT_MAX; i++) {
        const sg_node *n = &g->main.nodes[i];
        count += n->group >= 0 ? group_node_count(g, n->group, memo) : 1;
    }
    free(memo);
    return count < INT_MAX ? (int)count : INT_MAX;
}

/* Flattens and folds g. With `sinks`, output-socket refs get a pseudo consumer each (a
 * Material Output whose Displacement or Thickness reads the socket), so the folds apply
 * to them as to any consumer; their resolved refs are written to `resolved`. */
static sg_graph *flatten_and_fold(const sg_graph *g, sg_blender_mode mode, bool extract,
                                  bool fold_constants, const sg_socket_ref *refs, int n_refs,
                                  sg_socket_ref *resolved, sg_socket_type *types, sg_error *err)
{
    flat f = {.err = err, .src = g};
    context *root = new_context(&f, &g->main, NULL, -1, "");
    for (int k = 0; k < n_refs && root && !f.failed; k++) {
        int node = sg_tree_find_node(&g->main, refs[k].node);
        if (node < 0) {
            sg_error_set(err, "no node named \"%s\"", refs[k].node);
            f.failed = true;
            break;
        }
        const sg_node *n = &g->main.nodes[node];
        int out = sg_node_output_index(n, refs[k].socket);
        int inp = sg_node_input_index(n, refs[k].socket);
        if (out < 0 && inp < 0) {
            sg_error_set(err, "node \"%s\" has no socket \"%s\"", n->name, refs[k].socket);
            f.failed = true;
            break;
        }
        if (out < 0) {
            if (root->map[node] < 0) {
                sg_error_set(err, "node \"%s\": input \"%s\" cannot be evaluated", n->name, refs[k].socket);
                f.failed = true;
                break;
            }
            resolved[k] = refs[k];
            types[k] = n->in[inp].type;
            continue;
        }
        if (n->out[out].type == SG_SOCKET_SHADER) {
            sg_error_set(err, "node \"%s\": output \"%s\" is a shader and has no value", n->name,
                         refs[k].socket);
            f.failed = true;
            break;
        }
        source src = resolve_out(&f, root, node, out);
        char name[64];
        snprintf(name, sizeof name, "\x01output %d", k);
        int sink = add_typed_node(&f, "ShaderNodeOutputMaterial", name);
        if (sink < 0)
            break;
        bool vec = is_vec_type(src.type);
        int socket = sg_node_input_index(&f.t.nodes[sink], vec ? "Displacement" : "Thickness");
        if (src.is_const)
            sg_convert_constant(src.type, f.t.nodes[sink].in[socket].type, src.value,
                                f.t.nodes[sink].in[socket].value);
        else
            add_link(&f, src.node, src.socket, sink, socket);
        resolved[k].node = NULL; /* filled after compaction, when names are final */
        resolved[k].socket = vec ? "Displacement" : "Thickness";
        types[k] = src.type;
    }
    free_context(root);
    for (int round = 0; fold_constants && !f.failed && round < 10000; round++) {
        bool changed = false;
        for (int i = 0; i < f.t.n_nodes && !f.failed; i++)
            if (!f.dead[i] && has_consumers(&f, i))
                changed |= fold_node(&f, i, mode);
        changed |= merge_duplicates(&f);
        if (extract)
            changed |= remove_dead(&f);
        if (!changed)
            break;
    }
    if (!f.failed)
        compact(&f);
    if (!f.failed && extract)
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
    for (int k = 0; k < n_refs; k++)
        if (!resolved[k].node) {
            char name[64];
            snprintf(name, sizeof name, "\x01output %d", k);
            int i = sg_tree_find_node(&out->main, name);
            resolved[k].node = out->main.nodes[i].name;
        }
    return out;
}

sg_graph *sg_extract(const sg_graph *g, const sg_extract_options *opt, sg_error *err)
{
    sg_blender_mode mode = opt && opt->blender ? opt->blender : SG_BLENDER_4;
    return flatten_and_fold(g, mode, true, true, NULL, 0, NULL, NULL, err);
}

sg_graph *sg_fold_for_compile(const sg_graph *g, sg_blender_mode mode, bool fold_constants,
                              const sg_socket_ref *refs, int n_refs, sg_socket_ref *resolved,
                              sg_socket_type *types, sg_error *err)
{
    return flatten_and_fold(g, mode, false, fold_constants, refs, n_refs, resolved, types, err);
}
