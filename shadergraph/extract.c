/*
 * Extraction: the sub-shader of issue 3, and the graph the compiler actually compiles.
 * Graph algorithms only: what any node means is its type's business (node_type.h).
 *
 * 1. Flatten (flatten.c): inline every group into one tree, drop reroutes and Value and
 *    RGB nodes.
 * 2. Repeat until nothing changes: Cycles' constant folding (fold.c: the same folds
 *    Blender applies before rendering, so they are part of what a material computes),
 *    merge nodes that compute the same thing from the same inputs, and (for
 *    extraction) drop nodes that do not reach a Material Output.
 * 3. Compact away the dead nodes; for extraction, lay the result out in columns by
 *    depth from the output.
 *
 * sg_compile compiles the folded graph, and sg_extract returns it: so a sub-shader
 * evaluates to exactly what its super-shader evaluates to, by construction, and
 * tests/unit/test_extract.c checks it on the super-shader anyway. Values are compared
 * with ==: the folds are Cycles' algebraic ones, which may turn -0 into +0.
 */
#include <assert.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shadergraph/flat.h"

/* ---- 2. simplification ------------------------------------------------------------ */

/* Marks nodes that do not reach the Material Output dead. Returns true if any died. */
static bool remove_dead(sg_flat *f)
{
    int n = f->t.n_nodes;
    bool *live = calloc((size_t)n + 1, sizeof *live);
    int *stack = malloc(sizeof(int) * ((size_t)n + 1));
    if (!live || !stack) {
        free(live);
        free(stack);
        sg_flat_oom(f);
        return false;
    }
    int sp = 0;
    for (int i = 0; i < n; i++)
        if (!f->dead[i] && f->t.nodes[i].type->role == SG_ROLE_MATERIAL_OUTPUT) {
            live[i] = true;
            stack[sp++] = i;
        }
    while (sp > 0) {
        int v = stack[--sp];
        for (int k = 0; k < f->t.nodes[v].n_in; k++) {
            int l = sg_flat_input_link(f, v, k);
            if (l >= 0 && !live[f->t.links[l].from_node]) {
                live[f->t.links[l].from_node] = true;
                stack[sp++] = f->t.links[l].from_node;
            }
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
            sg_flat_remove_link(f, l);
    free(live);
    free(stack);
    return changed;
}

/* Two live nodes compute the same thing: same type, properties, ramp, and for each
 * input the same link source or the same constant. */
static bool same_node(const sg_flat *f, int a, int b)
{
    const sg_node *x = &f->t.nodes[a], *y = &f->t.nodes[b];
    if (x->type != y->type || (x->type->flags & SG_NODE_SINK) ||
        memcmp(x->prop, y->prop, sizeof x->prop) != 0)
        return false;
    if ((x->ramp == NULL) != (y->ramp == NULL) || (x->ramp && memcmp(x->ramp, y->ramp, sizeof *x->ramp)))
        return false;
    for (int k = 0; k < x->n_in; k++) {
        int la = sg_flat_input_link(f, a, k), lb = sg_flat_input_link(f, b, k);
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

static uint64_t fnv1a(uint64_t h, const void *p, size_t n)
{
    const unsigned char *c = p;
    for (size_t i = 0; i < n; i++)
        h = (h ^ c[i]) * 1099511628211ull;
    return h;
}

/* A hash of (part of) what same_node compares: equal nodes hash equal. */
static uint64_t node_hash(const sg_flat *f, int a)
{
    const sg_node *x = &f->t.nodes[a];
    uint64_t h = fnv1a(1469598103934665603ull, &x->type, sizeof x->type);
    h = fnv1a(h, x->prop, sizeof x->prop);
    if (x->ramp) /* the stops: the baked table (kilobytes) follows from them */
        h = fnv1a(h, x->ramp, offsetof(sg_color_ramp, baked));
    for (int k = 0; k < x->n_in; k++) {
        int l = sg_flat_input_link(f, a, k);
        if (l >= 0) {
            int src[2] = {f->t.links[l].from_node, f->t.links[l].from_socket};
            h = fnv1a(h, src, sizeof src);
        } else {
            h = fnv1a(h, &x->in[k].implicit, sizeof x->in[k].implicit);
            h = fnv1a(h, x->in[k].value, sizeof x->in[k].value);
        }
    }
    return h;
}

typedef struct hashed_node {
    uint64_t hash;
    int node;
} hashed_node;

static int by_hash_then_index(const void *pa, const void *pb)
{
    const hashed_node *a = pa, *b = pb;
    if (a->hash != b->hash)
        return a->hash < b->hash ? -1 : 1;
    return (a->node > b->node) - (a->node < b->node);
}

/* Merges each set of equal nodes into its first (lowest index): its consumers read that
 * one, the others die with remove_dead. Only nodes of equal hash are compared (the hashes
 * are taken before any merge; a merge can make two consumers equal, and the next round,
 * which a merge always causes, finds them). */
static bool merge_duplicates(sg_flat *f)
{
    int n = f->t.n_nodes, m = 0;
    hashed_node *h = malloc(sizeof *h * ((size_t)n + 1));
    if (!h) {
        sg_flat_oom(f);
        return false;
    }
    for (int i = 0; i < n; i++)
        if (!f->dead[i] && !(f->t.nodes[i].type->flags & SG_NODE_SINK))
            h[m++] = (hashed_node){node_hash(f, i), i};
    qsort(h, (size_t)m, sizeof *h, by_hash_then_index);
    bool changed = false;
    for (int lo = 0, hi; lo < m; lo = hi) {
        for (hi = lo + 1; hi < m && h[hi].hash == h[lo].hash; hi++)
            ;
        for (int i = lo; i < hi; i++) {
            int a = h[i].node;
            for (int j = i + 1; j < hi && !f->dead[a]; j++) {
                int b = h[j].node;
                if (f->dead[b] || !same_node(f, a, b))
                    continue;
                /* Links only change their sources: the index stays valid. */
                for (int k = 0; k < f->t.nodes[b].n_out; k++)
                    sg_flat_redirect_output(f, b, k, a, k);
                f->dead[b] = true;
                changed = true;
            }
        }
    }
    free(h);
    return changed;
}

/* ---- 3. layout -------------------------------------------------------------------- */

/* Columns by longest distance from the output, right to left; rows in order. */
static void layout(sg_flat *f)
{
    int n = f->t.n_nodes;
    int *depth = calloc((size_t)n + 1, sizeof *depth);
    int *row = calloc((size_t)n + 2, sizeof *row);
    if (!depth || !row) {
        free(depth);
        free(row);
        sg_flat_oom(f);
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

/* Links by their input (each input has at most one), then their source. */
static int link_order(const void *pa, const void *pb)
{
    const sg_link *a = pa, *b = pb;
    int ka[4] = {a->to_node, a->to_socket, a->from_node, a->from_socket};
    int kb[4] = {b->to_node, b->to_socket, b->from_node, b->from_socket};
    for (int i = 0; i < 4; i++)
        if (ka[i] != kb[i])
            return ka[i] < kb[i] ? -1 : 1;
    return 0;
}

/* Drops dead nodes, renumbers links and sorts them (link_order). The folds remove and add
 * links in an order that depends on which folds applied, so one sub-shader could come out
 * with its links listed in different orders from two parameter sets whose difference it
 * does not use (an unused pattern's selector): sorted, equal sub-shaders are equal text,
 * which the active-parameter test, the candidates' de-duplication and the loss cache
 * compare (pipeline/material.c, predict.c). */
static void compact(sg_flat *f)
{
    int *remap = malloc(sizeof(int) * ((size_t)f->t.n_nodes + 1));
    if (!remap) {
        sg_flat_oom(f);
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
    if (f->t.n_links > 1)
        qsort(f->t.links, (size_t)f->t.n_links, sizeof *f->t.links, link_order);
}

/* Flattens and folds g; `extract` also drops what reaches no Material Output and lays
 * the result out. Refs are resolved as sg_flatten says; the pseudo consumers' names are
 * looked up once compaction has made them final. */
static sg_graph *flatten_and_fold(const sg_graph *g, sg_blender_mode mode, bool extract,
                                  bool fold_constants, const sg_socket_ref *refs, int n_refs,
                                  sg_socket_ref *resolved, sg_socket_type *types, char *err, size_t errlen)
{
    sg_flat f = {.err = err, .errlen = errlen};
    if (sg_flatten(&f, g, refs, n_refs, resolved, types) && fold_constants)
        sg_flat_index_links(&f);
    for (int round = 0; fold_constants && !f.failed && round < 10000; round++) {
        bool changed = sg_fold_pass(&f, mode);
        changed |= merge_duplicates(&f);
        if (extract)
            changed |= remove_dead(&f);
        assert(f.failed || sg_flat_index_is_true(&f));
        if (!changed)
            break;
    }
    sg_flat_free_index(&f); /* compaction renumbers the nodes */
    if (!f.failed)
        compact(&f);
    if (!f.failed && extract)
        layout(&f);
    sg_graph *out = calloc(1, sizeof *out);
    if (f.failed || !out || !(out->name = strdup(g->name)) || !(out->main.name = strdup(g->name))) {
        if (!f.failed)
            sg_error_set(err, errlen, "out of memory during extraction");
        sg_flat_free(&f);
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

sg_graph *sg_extract(const sg_graph *g, const sg_extract_options *opt, char *err, size_t errlen)
{
    sg_blender_mode mode = opt && opt->blender ? opt->blender : SG_BLENDER_4;
    return flatten_and_fold(g, mode, true, true, NULL, 0, NULL, NULL, err, errlen);
}

sg_graph *sg_fold_for_compile(const sg_graph *g, sg_blender_mode mode, bool fold_constants,
                              const sg_socket_ref *refs, int n_refs, sg_socket_ref *resolved,
                              sg_socket_type *types, char *err, size_t errlen)
{
    return flatten_and_fold(g, mode, false, fold_constants, refs, n_refs, resolved, types, err, errlen);
}
