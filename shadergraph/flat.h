/*
 * Internal to shadergraph: the flat graph that flattening (flatten.c) builds, folding
 * (fold.c) simplifies and extraction (extract.c) prunes, lays out and hands over.
 *
 * Invariants between the three steps:
 *   - one tree, no groups: every node has a typed, non-structural type and no Value or
 *     RGB node remains (their values sit on the inputs they fed);
 *   - links join output sockets to input sockets of live nodes; an input has at most one;
 *   - dead[i] marks a removed node; it stays in the arrays (indices stay stable) until
 *     extract.c compacts them;
 *   - after `failed` is set (err holds why) nothing more is built and the result is
 *     discarded.
 */
#ifndef IMSYNTH_SHADERGRAPH_FLAT_H
#define IMSYNTH_SHADERGRAPH_FLAT_H

#include "shadergraph/graph_internal.h"

typedef struct sg_flat {
    sg_tree t;
    int cap_nodes, cap_links;
    bool *dead; /* per node, cap_nodes entries */
    char *err; /* the caller\'s message buffer */
    size_t errlen;
    bool failed;
    const sg_graph *src;
    int n_contexts; /* group instances made so far: bounded like nodes */
    int depth;      /* resolve_out calls on the stack: at most SG_MAX_RESOLVE_DEPTH */
    /* The link index, so that folding and extraction never scan every link to answer
     * "what feeds this input", "does anything read this node" or "which links read this
     * output": built once the tree is flat (sg_flat_index_links; no node or link is added
     * after), then kept true by the two edits below. in_link[slot0[i] + k] is the link
     * into input k of node i, or -1; n_from[i] and n_into[i] count the links leaving and
     * entering node i. The links leaving node i form a doubly linked list through link
     * indices: first_from[i], then next_from[l] (prev_from[l] back), -1 at either end, in
     * no particular order. NULL before it is built. */
    int *slot0, *in_link, *n_from, *n_into;
    int *first_from, *next_from, *prev_from;
} sg_flat;

/* Inlines g's groups into f (zero-initialised but for err): see flatten.c. With refs,
 * each output-socket ref gets a pseudo consumer, a Material Output named "\x01output K"
 * whose Displacement (vectors, colours) or Thickness (floats) reads it; `resolved[k]`
 * gets its socket (node NULL, to be named once the graph is final) and `types[k]` the
 * ref's value type. An input-socket ref is passed through as it is. Returns false on
 * failure (f->failed, f->err, f->errlen). */
bool sg_flatten(sg_flat *f, const sg_graph *g, const sg_socket_ref *refs, int n_refs,
                sg_socket_ref *resolved, sg_socket_type *types);

/* One pass of Cycles' constant folding over every live node with consumers (fold.c), on
 * an indexed graph (sg_flat_index_links). Returns whether anything changed. */
bool sg_fold_pass(sg_flat *f, sg_blender_mode mode);

/* Frees every live node's allocations and the arrays (on failure). */
void sg_flat_free(sg_flat *f);

/* Sets the out-of-memory error (once) and fails f. Returns -1. */
int sg_flat_oom(sg_flat *f);

static inline bool sg_is_vec_type(sg_socket_type t)
{
    return t == SG_SOCKET_VECTOR || t == SG_SOCKET_COLOR;
}

/* Builds the link index (flatten.c). Returns false on failure (out of memory: f fails). */
bool sg_flat_index_links(sg_flat *f);
/* Whether the index describes the links exactly (debug builds assert it after each
 * simplification round). */
bool sg_flat_index_is_true(const sg_flat *f);
void sg_flat_free_index(sg_flat *f);

static inline int sg_flat_input_link(const sg_flat *f, int node, int k)
{
    return f->in_link[f->slot0[node] + k];
}

/* Link edits, the only ones once the index is built (flatten.c).
 * Removing link l moves the last link into slot l, keeping its place in its source's
 * list: a walk of one list that removes the link it stands on continues from the
 * removed link's successor, or from l if that successor was the moved link. */
void sg_flat_remove_link(sg_flat *f, int l);
/* Relinks every consumer of (node, socket) to (src, src_socket). */
void sg_flat_redirect_output(sg_flat *f, int node, int socket, int src, int src_socket);

#endif
