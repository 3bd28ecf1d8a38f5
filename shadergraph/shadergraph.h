/*
 * shadergraph: Blender-compatible shader node graphs.
 *
 * A graph is loaded from (and saved to) the JSON format of FORMAT.md, validated on
 * load, compiled into a flat program for a chosen set of sockets, and evaluated over
 * batches of shading points with Blender's (Cycles SVM) node semantics.
 *
 *   sg_graph   *g = sg_graph_load_file("material.json", &err);
 *   sg_program *p = sg_compile(g, refs, n_refs, &opts, &err);
 *   sg_evaluator *e = sg_evaluator_new(p, 256);
 *   sg_evaluate(e, &geometry_batch, outputs);
 *
 * Nothing here keeps global mutable state: a program is immutable once compiled and may
 * be shared by threads; each thread owns its evaluator (its register file).
 */
#ifndef IMSYNTH_SHADERGRAPH_H
#define IMSYNTH_SHADERGRAPH_H

#include <stddef.h>
#include <stdbool.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- errors ---------------------------------------------------------------------- */

/* Every fallible call takes (char *err, size_t errlen), as every library of imsynth does,
 * and writes a message naming the file (or source name) and the place into it:
 * "material.json: nodes[3] \"Math.001\": unknown operation \"ADDD\"". err may be NULL.
 * SG_ERROR_MAX holds any message this library writes. */
enum { SG_ERROR_MAX = 512 };

/* Writes a formatted message into err (if err is not NULL). Returns -1 for chaining. */
int sg_error_set(char *err, size_t errlen, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* ---- semantics ------------------------------------------------------------------- */

/* Which Blender release's node semantics to reproduce where 3.x and 4.x differ. */
typedef enum sg_blender_mode {
    SG_BLENDER_4 = 4, /* default: Blender 4.x (checked against 4.3) */
    SG_BLENDER_3 = 3  /* compatibility: Blender 3.x (checked against 3.4) */
} sg_blender_mode;

/* ---- socket and node types ------------------------------------------------------- */

typedef enum sg_socket_type {
    SG_SOCKET_FLOAT,  /* 1 float */
    SG_SOCKET_VECTOR, /* 3 floats */
    SG_SOCKET_COLOR,  /* 3 floats (RGB; alpha is carried in JSON but not evaluated) */
    SG_SOCKET_SHADER, /* a closure: never evaluated, only collected by sinks */
    SG_SOCKET_INT,    /* 1 float holding an integer value (Blender integer sockets) */
    SG_SOCKET_BOOL    /* 1 float, 0 or 1 */
} sg_socket_type;

/* Number of floats a value of this type occupies (0 for shader). */
int sg_socket_type_width(sg_socket_type t);
const char *sg_socket_type_name(sg_socket_type t); /* "FLOAT", "VECTOR", "RGBA", ... */

/* ---- graphs ---------------------------------------------------------------------- */

typedef struct sg_graph sg_graph;

/* Limits (FORMAT.md, "Limits"), like SQLite's: past them a graph is refused with an error
 * before anything is allocated for it, so that a hostile file costs bounded time and
 * memory. Validation, folding and compilation do passes over all links per node, so
 * their cost grows with nodes x links: at the limits a graph loads and compiles in
 * seconds; the super-shader has 670 nodes. */
#define SG_MAX_GRAPH_FILE_BYTES (16u << 20) /* a graph file's size */
#define SG_MAX_TREE_NODES 10000             /* nodes in the main tree or in one group */
#define SG_MAX_TREE_LINKS 40000             /* links in one tree */
#define SG_MAX_GROUPS 4096                  /* groups in a graph */
#define SG_MAX_RESOLVE_DEPTH 1000           /* reroutes and group interfaces on one path */
#define SG_MAX_FLAT_NODES 20000             /* nodes (and group instances) once every
                                             * group is inlined */

/* Load and validate. On failure returns NULL and explains in err. `source_name` is used
 * in messages (usually the file path). */
sg_graph *sg_graph_load_file(const char *path, char *err, size_t errlen);
sg_graph *sg_graph_load_json(const char *text, size_t len, const char *source_name,
                             char *err, size_t errlen);

/* Serialise to JSON text (caller frees with free()). Saving and loading round-trips
 * losslessly: load(save(g)) saves to the same text. */
char *sg_graph_to_json(const sg_graph *g);
/* Write atomically: temp file in the same directory, then rename. */
int sg_graph_save_file(const sg_graph *g, const char *path, char *err, size_t errlen);

void sg_graph_free(sg_graph *g);

/* The name of the Principled BSDF node feeding the active Material Output's Surface
 * (through reroutes), which is where a renderer reads the material's maps. NULL with a
 * message when there is none (an unlinked Surface, another shader, a group). */
const char *sg_graph_surface_bsdf(const sg_graph *g, char *err, size_t errlen);

/* ---- compiling ------------------------------------------------------------------- */

/* A socket to evaluate: node name and socket identifier, either an output socket of the
 * node or an input socket (then its linked value, or its default when unlinked). Sinks
 * such as Principled BSDF are reached through their inputs: {"Principled BSDF",
 * "Base Color"}. Names inside groups are not addressable; groups are inlined. */
typedef struct sg_socket_ref {
    const char *node;
    const char *socket;
} sg_socket_ref;

/* Parses "NODE:SOCKET" (the last ':' splits, so node names may contain ':').
 * Points into `text`, which must outlive the ref; writes a NUL over the ':'. */
int sg_socket_ref_parse(char *text, sg_socket_ref *ref, char *err, size_t errlen);

typedef struct sg_compile_options {
    sg_blender_mode blender; /* 0 means SG_BLENDER_4 */
    /* Groups inlined, reroutes and Value/RGB nodes resolved, and nothing else: no
     * constant folding, bypasses or merging. Slower; the reference that folding and
     * extraction are tested against (test_extract). */
    bool unfolded;
} sg_compile_options;

typedef struct sg_program sg_program;

/* Inline groups, drop nodes that do not reach the requested sockets, and order the rest
 * into a flat instruction list. The program does not reference the graph afterwards. */
sg_program *sg_compile(const sg_graph *g, const sg_socket_ref *refs, int n_refs,
                       const sg_compile_options *opt, char *err, size_t errlen);
void sg_program_free(sg_program *p);

/* Type of requested output k (its width is the number of floats per point). */
sg_socket_type sg_program_output_type(const sg_program *p, int k);
int sg_program_output_count(const sg_program *p);
int sg_program_instruction_count(const sg_program *p);

/* ---- evaluating ------------------------------------------------------------------ */

/* Geometry of a batch of shading points, planar structure-of-arrays: a vector field
 * `v` holds n x values, then n y values, then n z values (3n floats).
 * All fields are required. Differentials (dx, dy) are the change of each quantity across
 * one pixel in x and y; Bump evaluates its Height input at the offset points. */
typedef struct sg_geometry_batch {
    int n;
    const float *P, *dPdx, *dPdy;      /* world position, 3n each */
    const float *N;                    /* shading normal (world), 3n */
    const float *Ng;                   /* geometric normal (world), 3n */
    const float *I;                    /* direction towards the viewer, unit, 3n */
    const float *generated, *dgenerated_dx, *dgenerated_dy; /* 3n each */
    const float *uv, *duv_dx, *duv_dy;                      /* 3n each (z = 0) */
    const float *object, *dobject_dx, *dobject_dy;          /* object-space P, 3n each */
    const float *object_normal;                             /* object-space N, 3n */
} sg_geometry_batch;

typedef struct sg_evaluator sg_evaluator;

/* Allocates the register file for batches of up to max_batch points. */
sg_evaluator *sg_evaluator_new(const sg_program *p, int max_batch);
void sg_evaluator_free(sg_evaluator *e);

/* Evaluate the program's outputs for geom->n <= max_batch points. out[k] receives
 * width(k) * n floats, planar. */
void sg_evaluate(sg_evaluator *e, const sg_geometry_batch *geom, float *const *out);

/* The same program, one point at a time through the same instructions: each instruction
 * is dispatched once per point. Exists to measure what batching buys (tests/bench). */
void sg_evaluate_pointwise(sg_evaluator *e, const sg_geometry_batch *geom,
                           float *const *out);

/* ---- sub-shader extraction ------------------------------------------------------- */

typedef struct sg_extract_options {
    sg_blender_mode blender; /* semantics used when folding constants; 0 = SG_BLENDER_4 */
} sg_extract_options;

/* The smallest graph we can prove computes what `g` computes, for g's constant values
 * (bind parameters first): groups inlined, constants folded, identities bypassed,
 * duplicates merged, dead nodes removed, laid out in columns. Returns a new graph
 * without groups (free with sg_graph_free), or NULL with a message. */
sg_graph *sg_extract(const sg_graph *g, const sg_extract_options *opt, char *err, size_t errlen);

/* A copy of g with its texture space turned by `degrees` about +Z (the plane's normal),
 * as an artist turns a procedural material in Blender: every link from a Texture
 * Coordinate node's Generated, UV or Object output (in the material and in its groups)
 * goes through a new Mapping node (type Point, Rotation (0, 0, degrees in radians),
 * label "Texture Rotation"). A material that read position p now reads R p (R the turn
 * by `degrees`): what its render showed at R p now shows at p, so the render turns by
 * -degrees (clockwise as the camera sees it, for positive degrees). Normal, Camera,
 * Window and Reflection are left alone. Returns a new graph (free with sg_graph_free), or NULL with
 * a message. */
sg_graph *sg_graph_rotate_texture(const sg_graph *g, double degrees, char *err, size_t errlen);

/* Nodes as Blender shows them with every group expanded in place: a group node counts
 * as its group's nodes (recursively), not as one. Saturates at INT_MAX; -1 when out of
 * memory. */
int sg_graph_node_count(const sg_graph *g);

/* ---- the scene's plane, for eval-graph and tests ---------------------------------- */

/* Fills a geometry batch for pixel centres of a width x height orthographic view of the
 * scene plane (DESIGN.md): pixels [first, first+n) in row-major order, row 0 at the top.
 * `storage` must hold 48*n floats (16 vector fields); geom's pointers point into it. */
void sg_plane_geometry(int width, int height, int first, int n, float *storage,
                       sg_geometry_batch *geom);

/* ---- parameters (params.c) --------------------------------------------------------- */

/* A super-shader reads its parameters from one group, SG_PARAMS_GROUP: a group with no
 * inputs whose outputs are the parameters, each fed by a Value node (the parameter's
 * value) inside the group. Binding a parameter set means setting those Value nodes
 * (and the matching interface defaults), so the evaluator, a saved graph and Blender
 * all see the same values. Parameters are floats in [0, 1]; a name "Mult N ..." marks
 * an N-way multiplexer selector (DESIGN.md). */
#define SG_PARAMS_GROUP "RandomValues"

typedef struct sg_params {
    int n;
    char **names;  /* in the group's output order (the sampling order) */
    float *values; /* n values in [0, 1] */
} sg_params;

/* The parameters of g (names and current values) from its SG_PARAMS_GROUP group.
 * Errors when the group is missing, has inputs, or an output is not fed by a Value
 * node. On success the caller frees with sg_params_free. */
int sg_params_from_graph(const sg_graph *g, sg_params *out, char *err, size_t errlen);
/* A deep copy (names and values); returns -1 when out of memory. */
int sg_params_copy(const sg_params *src, sg_params *dst);
void sg_params_free(sg_params *p);
/* Index of the parameter named `name`, or -1. */
int sg_params_index(const sg_params *p, const char *name);

/* N for a name "Mult N ..." (N >= 2), else 0. */
int sg_param_mult_choices(const char *name);

/* Frame `frame`'s parameter set, the thesis's convention with our own generator: the
 * generator is seeded with the frame number, each parameter in order draws u uniform in
 * [0, 1), u is rounded to 3 decimals, and "Mult N" selectors are moved to the centre of
 * their bin, min((floor(u*N) + 0.5) / N, 1). The generator is SplitMix64 (documented in
 * params.c), not Python's Mersenne Twister, so values differ from the thesis's frames.
 * Overwrites p->values (the names give the count and which are selectors). */
void sg_params_sample(sg_params *p, unsigned long long frame);

/* Parameter files: one JSON object keyed by parameter name, values in [0, 1]:
 *   {"Noise A Scale": 0.25, "Mult 11 Noise A Pattern": 0.045, ...}
 * Reading fills p->values for the names already in p (from the graph); a missing,
 * unknown, duplicated, non-number, non-finite or out-of-range entry is an error naming
 * the file and the parameter. On error p->values is left unchanged. */
int sg_params_read_file(const char *path, sg_params *p, char *err, size_t errlen);
int sg_params_read_json(const char *text, size_t len, const char *source_name, sg_params *p,
                        char *err, size_t errlen);
/* JSON text in the same format, in p's order (caller frees with free()); each value in
 * the shortest form that reads back as the same float. */
char *sg_params_to_json(const sg_params *p);
/* Write atomically (temp file in the same directory, then rename). */
int sg_params_write_file(const char *path, const sg_params *p, char *err, size_t errlen);

/* Set g's parameters to p's values (matched by name: every parameter of g must be in p
 * and every entry of p must be a parameter of g; values in [0, 1]). */
int sg_graph_bind_params(sg_graph *g, const sg_params *p, char *err, size_t errlen);

#ifdef __cplusplus
}
#endif
#endif
