/*
 * Internal to shadergraph: the in-memory graph that graph.c loads and saves and
 * flatten.c flattens. Invariants after a successful load (graph.c checks them all):
 *   - every node has a known type, every link joins existing, available sockets,
 *     an input has at most one link, no tree has a cycle, no group contains itself;
 *   - every value is finite; enum properties are valid indices;
 *   - node and group names are unique within their tree / the graph.
 */
#ifndef IMSYNTH_SHADERGRAPH_GRAPH_INTERNAL_H
#define IMSYNTH_SHADERGRAPH_GRAPH_INTERNAL_H

#include "shadergraph/node_type.h"

/* One socket of one node. For typed nodes the identifier points into the type's
 * table; for group nodes and group input/output nodes into the group's interface. */
typedef struct sg_socket {
    const char *identifier;
    sg_socket_type type;
    float value[4];
    bool available;
    sg_implicit implicit;
} sg_socket;

typedef struct sg_node {
    char *name;
    char *label; /* NULL when none */
    const sg_node_type *type;
    float location[2];
    int prop[SG_MAX_PROPS];
    sg_color_ramp *ramp; /* ShaderNodeValToRGB only */
    int group;           /* ShaderNodeGroup: index into sg_graph.groups; else -1 */
    int n_in, n_out;
    sg_socket *in, *out;
} sg_node;

typedef struct sg_link {
    int from_node, from_socket; /* output socket index */
    int to_node, to_socket;     /* input socket index */
} sg_link;

/* A group's interface socket. */
typedef struct sg_iface_socket {
    char *name; /* also its identifier */
    sg_socket_type type;
    float value[4];
    float min, max;
    bool has_range;
} sg_iface_socket;

typedef struct sg_tree {
    char *name;
    int n_nodes, n_links;
    sg_node *nodes;
    sg_link *links;
    /* Groups only. */
    int n_iface_in, n_iface_out;
    sg_iface_socket *iface_in, *iface_out;
} sg_tree;

struct sg_graph {
    char *name;
    sg_tree main;
    int n_groups;
    sg_tree *groups;
};

/* Index of the node named `name` in `t`, or -1. */
int sg_tree_find_node(const sg_tree *t, const char *name);
/* Index of the link into (node, input), or -1. */
int sg_tree_input_link(const sg_tree *t, int node, int input);
int sg_node_input_index(const sg_node *n, const char *identifier);
int sg_node_output_index(const sg_node *n, const char *identifier);

/* The graph Cycles would render (extract.c): groups inlined, reroutes and Value/RGB
 * nodes gone, constant-folded with Cycles' rules for Blender `mode`. Each ref is
 * resolved to a socket of the result (`resolved`, names pointing into the result) and
 * its value type (`types`). Unreachable nodes are kept. Free with sg_graph_free.
 * fold_constants = false: inlined and resolved only (sg_compile_options.unfolded). */
sg_graph *sg_fold_for_compile(const sg_graph *g, sg_blender_mode mode, bool fold_constants,
                              const sg_socket_ref *refs, int n_refs, sg_socket_ref *resolved,
                              sg_socket_type *types, char *err, size_t errlen);

#endif
