/*
 * Internal to shadergraph: how a node type is described and evaluated.
 *
 * Each node family lives under kernels/ (like Cycles' kernel/svm/), in one file or, as
 * the noise family, a few sharing an internal header (noise.h); lanes.h is the one SIMD
 * layer (noise, Voronoi). A node is pure scalar functions of its inputs, a batch loop
 * over them (whole groups of points side by side in lanes where that pays), and the
 * table that describes the node to the loader and the compiler (its Blender idname,
 * sockets with Blender's identifiers and defaults, enum properties, flags, its role if
 * it is more than a kernel, and its constant folding). The registry in node_registry.c
 * lists every type; nothing else needs to change to add one.
 */
#ifndef IMSYNTH_SHADERGRAPH_NODE_TYPE_H
#define IMSYNTH_SHADERGRAPH_NODE_TYPE_H

#include "shadergraph/shadergraph.h"

/* What an unlinked input reads instead of its default value (Blender's implicit
 * inputs: texture nodes read Generated coordinates, Bump/BSDF normals read N). */
typedef enum sg_implicit {
    SG_IMPLICIT_NONE = 0,
    SG_IMPLICIT_GENERATED,
    SG_IMPLICIT_NORMAL, /* shading normal N (world) */
    SG_IMPLICIT_UV,
    SG_IMPLICIT_POSITION
} sg_implicit;

typedef struct sg_socket_def {
    const char *identifier; /* Blender's socket identifier, e.g. "Value_001" */
    const char *name;       /* Blender's UI name, e.g. "Value" */
    sg_socket_type type;
    float default_value[4]; /* Blender's default; colours carry alpha in [3] */
    sg_implicit implicit;
    /* Bitmask of the values of property `avail_prop` for which this socket exists
     * (Blender hides the others: links to them are errors). 0 = always available.
     * A second condition (avail_mask2 on avail_prop2) must hold too when non-zero.
     * 64 bits: the Math node's operation enum has 41 values. */
    unsigned long long avail_mask;
    int avail_prop;
    unsigned long long avail_mask2;
    int avail_prop2;
} sg_socket_def;

typedef enum sg_prop_kind {
    SG_PROP_ENUM, /* one of `values` (Blender enum identifiers) */
    SG_PROP_BOOL,
    SG_PROP_FLOAT, /* e.g. Value node's value is a socket; kept for completeness */
    SG_PROP_COLOR_RAMP
} sg_prop_kind;

/* Upper bound on properties per node type (kernels index a->prop up to this). */
#define SG_MAX_PROPS 8

typedef struct sg_prop_def {
    const char *name; /* Blender RNA property name, e.g. "operation" */
    sg_prop_kind kind;
    const char *const *values; /* enum: NULL-terminated identifiers */
    int default_value;         /* enum index or bool */
} sg_prop_def;

/* A colour ramp as stored on the node (ColorRamp in Blender). */
#define SG_RAMP_MAX_ELEMENTS 32
#define SG_RAMP_TABLE_MAX 257
typedef struct sg_color_ramp {
    int interpolation;     /* index into sg_ramp_interpolations: EASE, CARDINAL, LINEAR, B_SPLINE, CONSTANT */
    int color_mode;        /* RGB, HSV, HSL */
    int hue_interpolation; /* NEAR, FAR, CW, CCW */
    int n;                 /* elements, sorted by position on load */
    float position[SG_RAMP_MAX_ELEMENTS];
    float color[SG_RAMP_MAX_ELEMENTS][4];
    /* The lookup table Blender bakes from the stops (steps + 1 entries), filled by
     * sg_color_ramp_bake when a program is compiled; baked_steps is 0 in graphs. */
    int baked_steps;
    float baked[SG_RAMP_TABLE_MAX][4];
} sg_color_ramp;

/* Bakes the ramp's lookup table as Blender `mode` does (kernels/color.c). */
void sg_color_ramp_bake(sg_color_ramp *r, sg_blender_mode mode);

extern const char *const sg_ramp_interpolations[];
extern const char *const sg_ramp_color_modes[];
extern const char *const sg_ramp_hue_interpolations[];

/* Everything a kernel sees for one batch. Inputs and outputs follow the order of the
 * type's socket tables; each is a planar SoA array of width * n floats. An output the
 * program does not use may be NULL: a kernel must check before writing. */
typedef struct sg_kernel_args {
    int n;
    sg_blender_mode blender;
    const int *prop;           /* per property of the type: enum index or bool */
    const sg_color_ramp *ramp; /* the node's ramp, for SG_PROP_COLOR_RAMP types */
    const float *const *in;
    float *const *out;
    const sg_geometry_batch *geom; /* for nodes that read geometry (Texture Coordinate) */
    /* Where geometry is read: 0 at the shading point, 1 one pixel over in x (P + dPdx),
     * 2 one pixel over in y. The compiler evaluates a Bump node's Height subgraph three
     * times, once per offset, and passes the two offset heights as extra inputs after
     * the Bump type's declared ones. */
    int offset;
    /* Set when the folder (fold.c) computes a node whose inputs are all constant.
     * Cycles does that on the host CPU, whose code has no fused multiply-adds, while
     * its render kernel fuses some: a kernel that writes fmaf() where Blender's kernel
     * fuses must compute unfused when host_fold is set (kernels/math.c), and one whose
     * host fold uses another formula computes that one (Invert, kernels/color.c). */
    bool host_fold;
} sg_kernel_args;

typedef void (*sg_kernel_fn)(const sg_kernel_args *a);

/* A node type's constant folding (Cycles' ShaderNode::constant_fold): the algebraic
 * simplifications Cycles makes to a node with some constant inputs, x * 0 = 0, Mix
 * with factor 1 = B, ... (the API is shadergraph/fold.h). Returns whether the graph
 * changed. Folding every input constant into the kernel's value is not the hook's
 * business: SG_NODE_FOLD_CONSTANT asks for it, and the hook then only sees nodes with
 * at least one input that is not constant. */
typedef struct sg_fold sg_fold;
typedef bool (*sg_fold_fn)(sg_fold *x);

/* What a node is to the graph algorithms (loading, flattening, extraction), for the
 * types that are more than a kernel; SG_ROLE_NONE for the rest. Code outside kernels/
 * asks these, never idnames. */
typedef enum sg_node_role {
    SG_ROLE_NONE = 0,
    SG_ROLE_GROUP,        /* an instance of a group tree (sg_node.group) */
    SG_ROLE_GROUP_INPUT,  /* inside a group: the group node's inputs */
    SG_ROLE_GROUP_OUTPUT, /* inside a group: the group node's outputs; the first is active */
    SG_ROLE_REROUTE,      /* passes input 0 through; takes the type of what feeds it */
    SG_ROLE_CONSTANT,     /* Value, RGB: the value is stored on output 0 */
    SG_ROLE_MATERIAL_OUTPUT, /* a root: what reaches it is the material */
    SG_ROLE_BSDF          /* the surface shader the renderer understands */
} sg_node_role;

/* The length of a node type's socket or property table (a static array). */
#define SG_COUNT(a) ((int)(sizeof(a) / sizeof((a)[0])))

typedef struct sg_node_type {
    const char *idname; /* Blender bl_idname, e.g. "ShaderNodeMath" */
    const sg_socket_def *inputs;
    int n_inputs;
    const sg_socket_def *outputs;
    int n_outputs;
    const sg_prop_def *props;
    int n_props;
    sg_kernel_fn kernel; /* NULL for structural nodes handled by the flattener (groups,
                            reroutes) and for sinks */
    unsigned flags;
    sg_fold_fn fold; /* NULL: nothing to fold beyond SG_NODE_FOLD_CONSTANT */
    sg_node_role role;
} sg_node_type;

enum {
    SG_NODE_SINK = 1u << 0,      /* Principled BSDF, Material Output: only collects inputs */
    SG_NODE_STRUCTURAL = 1u << 1, /* group, group input/output, reroute: inlined away */
    SG_NODE_READS_GEOMETRY = 1u << 2, /* reads a->geom at a->offset (Texture Coordinate) */
    /* With every input constant, Cycles computes the node on the host and the node
     * becomes its value (its all_inputs_constant fold): the folder runs the kernel with
     * host_fold set. Textures, Map Range and Bump lack it: Cycles never folds them. */
    SG_NODE_FOLD_CONSTANT = 1u << 3,
    /* Reads its input "Height" also one pixel over in x and in y (Bump): the compiler
     * evaluates that input's subgraph at geometry offsets 1 and 2 and passes the two
     * values as extra inputs after the declared ones. */
    SG_NODE_HEIGHT_OFFSETS = 1u << 4
};

/* Registry (node_registry.c). */
const sg_node_type *sg_node_type_find(const char *idname);
int sg_node_type_count(void);
const sg_node_type *sg_node_type_at(int i);

/* Index of a socket/property by identifier/name, or -1. */
int sg_node_type_input_index(const sg_node_type *t, const char *identifier);
int sg_node_type_output_index(const sg_node_type *t, const char *identifier);
int sg_node_type_prop_index(const sg_node_type *t, const char *name);
/* Whether socket def `s` exists (is not hidden) on a node with these property values. */
bool sg_socket_available(const sg_socket_def *s, const int *prop);

/* Helpers for kernels reading planar vectors. */
#define SG_V3(arr, n, i, c) ((arr)[(size_t)(c) * (size_t)(n) + (size_t)(i)])

#endif
