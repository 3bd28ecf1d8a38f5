/*
 * Flattening: the graph Cycles receives from Blender, as one tree.
 *
 * Every group instance is inlined (its nodes copied with "Group/" name prefixes, one
 * copy per instance), reroutes are followed to what feeds them, and Value and RGB nodes
 * become the constants on the inputs they fed. Where a group's interface socket changes
 * a value's type (a colour entering a float socket, say), a small converter node keeps
 * the conversion Blender makes there; where a constant cannot sit on a colour input (it
 * is negative), a Combine Color node builds it.
 *
 * Invariants of the result are flat.h's. Inlining multiplies nodes, so both the nodes
 * and the group instances are bounded (SG_MAX_FLAT_NODES), and so is the recursion
 * through reroutes and interfaces (SG_MAX_RESOLVE_DEPTH): a few kilobytes of JSON must
 * not exhaust memory or the stack.
 */
#include <assert.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shadergraph/flat.h"
#include "shadergraph/program.h"

/* ---- a growable flat tree --------------------------------------------------------- */

int sg_flat_oom(sg_flat *f)
{
    if (!f->failed)
        sg_error_set(f->err, f->errlen, "out of memory during extraction");
    f->failed = true;
    return -1;
}

/* Appends a copy of typed node `n` named `name`; returns its index. */
static int add_node(sg_flat *f, const sg_node *n, const char *name)
{
    /* Groups nested in groups multiply: a few kilobytes of JSON can inline to billions
     * of nodes. */
    if (f->t.n_nodes >= SG_MAX_FLAT_NODES) {
        if (!f->failed)
            sg_error_set(f->err, f->errlen, "more than %d nodes once the groups are inlined (FORMAT.md, Limits)",
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
            return sg_flat_oom(f);
        }
        f->t.nodes = a;
        f->dead = d;
        f->cap_nodes = cap;
    }
    sg_node *m = &f->t.nodes[f->t.n_nodes];
    *m = *n;
    m->name = strdup(name);
    m->label = n->label ? strdup(n->label) : NULL;
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
        return sg_flat_oom(f);
    }
    memcpy(m->in, n->in, sizeof *m->in * (size_t)n->n_in);
    memcpy(m->out, n->out, sizeof *m->out * (size_t)n->n_out);
    f->dead[f->t.n_nodes] = false;
    return f->t.n_nodes++;
}

/* A fresh node of type idname with Blender's defaults. */
static int add_typed_node(sg_flat *f, const char *idname, const char *name)
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

static void add_link(sg_flat *f, int from, int from_socket, int to, int to_socket)
{
    if (f->t.n_links == f->cap_links) {
        int cap = f->cap_links ? 2 * f->cap_links : 128;
        sg_link *a = realloc(f->t.links, sizeof *a * (size_t)cap);
        if (!a) {
            sg_flat_oom(f);
            return;
        }
        f->t.links = a;
        f->cap_links = cap;
    }
    f->t.links[f->t.n_links++] = (sg_link){from, from_socket, to, to_socket};
}

/* The link into each input of t's nodes without a scan of the links: in_link[slot0[i] +
 * k] is sg_tree_input_link(t, i, k) (the first such link; a loaded or flat tree has at
 * most one), or -1. Returns false when out of memory (whatever was allocated is in the
 * outputs, for the caller to free). */
static bool index_tree_inputs(const sg_tree *t, int **slot0, int **in_link)
{
    int n_in = 0;
    for (int i = 0; i < t->n_nodes; i++)
        n_in += t->nodes[i].n_in;
    *slot0 = malloc(sizeof(int) * ((size_t)t->n_nodes + 1));
    *in_link = malloc(sizeof(int) * ((size_t)n_in + 1));
    if (!*slot0 || !*in_link)
        return false;
    for (int i = 0, slot = 0; i < t->n_nodes; slot += t->nodes[i++].n_in)
        (*slot0)[i] = slot;
    for (int k = 0; k < n_in; k++)
        (*in_link)[k] = -1;
    for (int l = t->n_links - 1; l >= 0; l--)
        (*in_link)[(*slot0)[t->links[l].to_node] + t->links[l].to_socket] = l;
    return true;
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
    int *slot0, *in_link;  /* tree's link into input k of node i: in_link[slot0[i] + k],
                            * or -1 (sg_tree_input_link without a scan of the links) */
} context;

static source resolve_out(sg_flat *f, context *c, int node, int socket);

static context *new_context(sg_flat *f, const sg_tree *t, context *parent, int parent_node,
                            const char *prefix);

static source resolve_in(sg_flat *f, context *c, int node, int k)
{
    const sg_tree *t = c->tree;
    int l = c->in_link[c->slot0[node] + k];
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
static source convert_at_interface(sg_flat *f, source s, sg_socket_type to, const char *name)
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

static source resolve_out_step(sg_flat *f, context *c, int node, int socket);

/* What feeds output `socket` of `node`: a node of the flat graph or a constant. The
 * walk recurses through reroutes and group interfaces (a typed node is looked up, not
 * walked), so its depth is how many of those one link path crosses: bounded, as SQLite
 * bounds expression depth, so that the stack is (a chain of 20,000 pass-through groups
 * overflowed it in a debug build). */
static source resolve_out(sg_flat *f, context *c, int node, int socket)
{
    source none = {.is_const = true, .node = -1};
    if (f->failed)
        return none;
    if (f->depth >= SG_MAX_RESOLVE_DEPTH) {
        sg_error_set(f->err, f->errlen, "a link path crosses more than %d reroutes and group interfaces "
                             "(FORMAT.md, Limits)", SG_MAX_RESOLVE_DEPTH);
        f->failed = true;
        return none;
    }
    f->depth++;
    source s = resolve_out_step(f, c, node, socket);
    f->depth--;
    return s;
}

static source resolve_out_step(sg_flat *f, context *c, int node, int socket)
{
    source none = {.is_const = true, .node = -1};
    if (f->failed)
        return none;
    const sg_tree *t = c->tree;
    const sg_node *n = &t->nodes[node];
    sg_node_role role = n->type->role;
    if (role == SG_ROLE_REROUTE)
        return resolve_in(f, c, node, 0);
    if (role == SG_ROLE_GROUP_INPUT) {
        source s = resolve_in(f, c->parent, c->parent_node, socket);
        return convert_at_interface(f, s, n->out[socket].type, n->out[socket].identifier);
    }
    if (n->group >= 0) {
        if (!c->child[node]) {
            char *prefix = malloc(strlen(c->prefix) + strlen(n->name) + 2);
            if (!prefix)
                return sg_flat_oom(f), none;
            sprintf(prefix, "%s%s/", c->prefix, n->name);
            c->child[node] = new_context(f, &f->src->groups[n->group], c, node, prefix);
            free(prefix);
            if (!c->child[node])
                return none;
        }
        context *ch = c->child[node];
        /* The first Group Output node is the active one (Blender marks one active; our
         * format keeps one). Without one, the output is the interface default. */
        for (int i = 0; i < ch->tree->n_nodes; i++)
            if (ch->tree->nodes[i].type->role == SG_ROLE_GROUP_OUTPUT) {
                source s = resolve_in(f, ch, i, socket);
                return convert_at_interface(f, s, n->out[socket].type, n->out[socket].identifier);
            }
        source s = {.is_const = true, .type = n->out[socket].type, .node = -1};
        memcpy(s.value, n->out[socket].value, sizeof s.value);
        return s;
    }
    if (role == SG_ROLE_CONSTANT) {
        source s = {.is_const = true, .type = n->out[socket].type, .node = -1};
        memcpy(s.value, n->out[socket].value, sizeof s.value);
        return s;
    }
    source s = {.is_const = false, .type = n->out[socket].type, .node = c->map[node], .socket = socket};
    return s;
}

static context *new_context(sg_flat *f, const sg_tree *t, context *parent, int parent_node,
                            const char *prefix)
{
    /* A group of nothing but nested groups inlines to no nodes, but its instances
     * multiply all the same. */
    if (++f->n_contexts > SG_MAX_FLAT_NODES) {
        if (!f->failed)
            sg_error_set(f->err, f->errlen, "more than %d group instances once the groups are inlined "
                         "(FORMAT.md, Limits)", SG_MAX_FLAT_NODES);
        f->failed = true;
        return NULL;
    }
    context *c = calloc(1, sizeof *c);
    if (!c || !(c->map = malloc(sizeof(int) * (size_t)(t->n_nodes + 1))) ||
        !(c->child = calloc((size_t)t->n_nodes + 1, sizeof *c->child)) ||
        !index_tree_inputs(t, &c->slot0, &c->in_link) || !(c->prefix = strdup(prefix))) {
        if (c) {
            free(c->map);
            free(c->child);
            free(c->slot0);
            free(c->in_link);
            free(c);
        }
        sg_flat_oom(f);
        return NULL;
    }
    c->tree = t;
    c->parent = parent;
    c->parent_node = parent_node;
    /* Typed nodes first, so links inside this tree can point at any of them. */
    for (int i = 0; i < t->n_nodes; i++) {
        const sg_node *n = &t->nodes[i];
        c->map[i] = -1;
        if ((n->type->flags & SG_NODE_STRUCTURAL) || n->type->role == SG_ROLE_CONSTANT)
            continue;
        char *name = malloc(strlen(prefix) + strlen(n->name) + 1);
        if (!name)
            return sg_flat_oom(f), c;
        sprintf(name, "%s%s", prefix, n->name);
        c->map[i] = add_node(f, n, name);
        free(name);
    }
    for (int i = 0; i < t->n_nodes && !f->failed; i++) {
        if (c->map[i] < 0)
            continue;
        for (int k = 0; k < t->nodes[i].n_in; k++) {
            if (c->in_link[c->slot0[i] + k] < 0)
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
    free(c->slot0);
    free(c->in_link);
    free(c->prefix);
    free(c);
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

/* The pseudo consumers keep a ref's value alive and let every fold apply to it as to
 * any consumer's input. */
bool sg_flatten(sg_flat *f, const sg_graph *g, const sg_socket_ref *refs, int n_refs,
                sg_socket_ref *resolved, sg_socket_type *types)
{
    f->src = g;
    context *root = new_context(f, &g->main, NULL, -1, "");
    for (int k = 0; k < n_refs && root && !f->failed; k++) {
        int node = sg_tree_find_node(&g->main, refs[k].node);
        if (node < 0) {
            sg_error_set(f->err, f->errlen, "no node named \"%s\"", refs[k].node);
            f->failed = true;
            break;
        }
        const sg_node *n = &g->main.nodes[node];
        int out = sg_node_output_index(n, refs[k].socket);
        int inp = sg_node_input_index(n, refs[k].socket);
        if (out < 0 && inp < 0) {
            sg_error_set(f->err, f->errlen, "node \"%s\" has no socket \"%s\"", n->name, refs[k].socket);
            f->failed = true;
            break;
        }
        if (out < 0) {
            if (root->map[node] < 0) {
                sg_error_set(f->err, f->errlen, "node \"%s\": input \"%s\" cannot be evaluated", n->name, refs[k].socket);
                f->failed = true;
                break;
            }
            resolved[k] = refs[k];
            types[k] = n->in[inp].type;
            continue;
        }
        if (n->out[out].type == SG_SOCKET_SHADER) {
            sg_error_set(f->err, f->errlen, "node \"%s\": output \"%s\" is a shader and has no value", n->name,
                         refs[k].socket);
            f->failed = true;
            break;
        }
        source src = resolve_out(f, root, node, out);
        char name[64];
        snprintf(name, sizeof name, "\x01output %d", k);
        int sink = add_typed_node(f, "ShaderNodeOutputMaterial", name);
        if (sink < 0)
            break;
        bool vec = sg_is_vec_type(src.type);
        int socket = sg_node_input_index(&f->t.nodes[sink], vec ? "Displacement" : "Thickness");
        if (src.is_const)
            sg_convert_constant(src.type, f->t.nodes[sink].in[socket].type, src.value,
                                f->t.nodes[sink].in[socket].value);
        else
            add_link(f, src.node, src.socket, sink, socket);
        resolved[k].node = NULL; /* filled after compaction, when names are final */
        resolved[k].socket = vec ? "Displacement" : "Thickness";
        types[k] = src.type;
    }
    free_context(root);
    return !f->failed;
}

/* Puts link l at the head of its source's list. */
static void push_from(sg_flat *f, int l)
{
    int node = f->t.links[l].from_node, head = f->first_from[node];
    f->prev_from[l] = -1;
    f->next_from[l] = head;
    if (head >= 0)
        f->prev_from[head] = l;
    f->first_from[node] = l;
}

/* Takes link l out of its source's list. */
static void unlink_from(sg_flat *f, int l)
{
    int prev = f->prev_from[l], next = f->next_from[l];
    if (prev >= 0)
        f->next_from[prev] = next;
    else
        f->first_from[f->t.links[l].from_node] = next;
    if (next >= 0)
        f->prev_from[next] = prev;
}

bool sg_flat_index_links(sg_flat *f)
{
    int n = f->t.n_nodes, n_links = f->t.n_links;
    f->n_from = calloc((size_t)n + 1, sizeof(int));
    f->n_into = calloc((size_t)n + 1, sizeof(int));
    f->first_from = malloc(sizeof(int) * ((size_t)n + 1));
    f->next_from = malloc(sizeof(int) * ((size_t)n_links + 1));
    f->prev_from = malloc(sizeof(int) * ((size_t)n_links + 1));
    if (!index_tree_inputs(&f->t, &f->slot0, &f->in_link) || !f->n_from || !f->n_into ||
        !f->first_from || !f->next_from || !f->prev_from) {
        sg_flat_free_index(f);
        sg_flat_oom(f);
        return false;
    }
    for (int i = 0; i < n; i++)
        f->first_from[i] = -1;
    for (int l = n_links - 1; l >= 0; l--) { /* so that each list runs in link order */
        f->n_from[f->t.links[l].from_node]++;
        f->n_into[f->t.links[l].to_node]++;
        push_from(f, l);
    }
    return true;
}

/* Each node's list holds exactly the links from it, n_from of them, with its back
 * pointers true; together the lists hold every link once. */
static bool from_lists_are_true(const sg_flat *f)
{
    int listed = 0;
    for (int i = 0; i < f->t.n_nodes; i++) {
        int count = 0;
        for (int l = f->first_from[i], prev = -1; l >= 0; prev = l, l = f->next_from[l]) {
            if (l >= f->t.n_links || f->t.links[l].from_node != i || f->prev_from[l] != prev ||
                ++count > f->n_from[i])
                return false;
        }
        if (count != f->n_from[i])
            return false;
        listed += count;
    }
    return listed == f->t.n_links;
}

bool sg_flat_index_is_true(const sg_flat *f)
{
    sg_flat fresh = {.t = f->t};
    if (!sg_flat_index_links(&fresh))
        return true; /* out of memory: nothing to say */
    int n = f->t.n_nodes;
    int n_in = n ? f->slot0[n - 1] + f->t.nodes[n - 1].n_in : 0;
    bool same = !memcmp(fresh.in_link, f->in_link, sizeof(int) * (size_t)n_in) &&
                !memcmp(fresh.n_from, f->n_from, sizeof(int) * (size_t)n) &&
                !memcmp(fresh.n_into, f->n_into, sizeof(int) * (size_t)n) && from_lists_are_true(f);
    sg_flat_free_index(&fresh);
    return same;
}

void sg_flat_free_index(sg_flat *f)
{
    free(f->slot0);
    free(f->in_link);
    free(f->n_from);
    free(f->n_into);
    free(f->first_from);
    free(f->next_from);
    free(f->prev_from);
    f->slot0 = f->in_link = f->n_from = f->n_into = NULL;
    f->first_from = f->next_from = f->prev_from = NULL;
}

void sg_flat_remove_link(sg_flat *f, int l)
{
    assert(f->in_link && l >= 0 && l < f->t.n_links);
    int last = f->t.n_links - 1;
    sg_link *k = &f->t.links[l];
    f->in_link[f->slot0[k->to_node] + k->to_socket] = -1;
    f->n_from[k->from_node]--;
    f->n_into[k->to_node]--;
    unlink_from(f, l);
    if (l < last) {
        /* The last link moves into slot l: its input and its neighbours follow it. */
        int prev = f->prev_from[last], next = f->next_from[last];
        *k = f->t.links[last];
        f->prev_from[l] = prev;
        f->next_from[l] = next;
        if (prev >= 0)
            f->next_from[prev] = l;
        else
            f->first_from[k->from_node] = l;
        if (next >= 0)
            f->prev_from[next] = l;
        f->in_link[f->slot0[k->to_node] + k->to_socket] = l;
    }
    f->t.n_links = last;
}

void sg_flat_redirect_output(sg_flat *f, int node, int socket, int src, int src_socket)
{
    assert(f->in_link);
    for (int l = f->first_from[node], next; l >= 0; l = next) {
        next = f->next_from[l];
        sg_link *k = &f->t.links[l];
        if (k->from_socket != socket)
            continue;
        unlink_from(f, l);
        k->from_node = src;
        k->from_socket = src_socket;
        push_from(f, l);
        f->n_from[node]--;
        f->n_from[src]++;
    }
}

void sg_flat_free(sg_flat *f)
{
    for (int i = 0; i < f->t.n_nodes; i++)
        if (!f->dead[i]) {
            free(f->t.nodes[i].name);
            free(f->t.nodes[i].label);
            free(f->t.nodes[i].ramp);
            free(f->t.nodes[i].in);
            free(f->t.nodes[i].out);
        }
    free(f->t.nodes);
    free(f->t.links);
    free(f->dead);
    sg_flat_free_index(f);
    f->t.nodes = NULL;
    f->t.links = NULL;
    f->dead = NULL;
    f->t.n_nodes = f->t.n_links = 0;
}
