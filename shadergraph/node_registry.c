/* The list of node types imsynth understands, and look-ups into their tables. */
#include <string.h>

#include "shadergraph/node_type.h"

/* One line per node type; each is defined in the kernels/ file of its family. */
#define SG_NODE_TYPES(X)                                                                   \
    /* kernels/math.c */                                                                   \
    X(node_type_math) X(node_type_vector_math) X(node_type_clamp) X(node_type_map_range)   \
    /* kernels/color.c */                                                                  \
    X(node_type_mix) X(node_type_mix_rgb) X(node_type_invert) X(node_type_color_ramp)      \
    X(node_type_rgb) X(node_type_value)                                                    \
    /* kernels/convert.c */                                                                \
    X(node_type_combine_xyz) X(node_type_separate_xyz) X(node_type_combine_color)          \
    X(node_type_separate_color) X(node_type_mapping)                                       \
    /* kernels/noise_texture.c, kernels/white_noise.c */                                   \
    X(node_type_tex_noise) X(node_type_tex_white_noise)                                    \
    /* kernels/voronoi.c */                                                                \
    X(node_type_tex_voronoi)                                                               \
    /* kernels/geometry.c */                                                               \
    X(node_type_tex_coord) X(node_type_bump)                                               \
    /* kernels/structural.c: inlined or collected by the compiler */                       \
    X(node_type_group) X(node_type_group_input) X(node_type_group_output)                  \
    X(node_type_reroute) X(node_type_bsdf_principled) X(node_type_output_material)

#define SG_DECLARE(sym) extern const sg_node_type sym;
SG_NODE_TYPES(SG_DECLARE)
#undef SG_DECLARE

#define SG_ADDRESS(sym) &sym,
static const sg_node_type *const registry[] = {SG_NODE_TYPES(SG_ADDRESS)};
#undef SG_ADDRESS

const char *const sg_ramp_interpolations[] = {"EASE", "CARDINAL", "LINEAR", "B_SPLINE", "CONSTANT", NULL};
const char *const sg_ramp_color_modes[] = {"RGB", "HSV", "HSL", NULL};
const char *const sg_ramp_hue_interpolations[] = {"NEAR", "FAR", "CW", "CCW", NULL};

int sg_node_type_count(void) { return (int)(sizeof registry / sizeof registry[0]); }

const sg_node_type *sg_node_type_at(int i) { return registry[i]; }

const sg_node_type *sg_node_type_find(const char *idname)
{
    for (int i = 0; i < sg_node_type_count(); i++)
        if (strcmp(registry[i]->idname, idname) == 0)
            return registry[i];
    return NULL;
}

static int socket_index(const sg_socket_def *s, int n, const char *identifier)
{
    for (int i = 0; i < n; i++)
        if (strcmp(s[i].identifier, identifier) == 0)
            return i;
    return -1;
}

int sg_node_type_input_index(const sg_node_type *t, const char *identifier)
{
    return socket_index(t->inputs, t->n_inputs, identifier);
}

int sg_node_type_output_index(const sg_node_type *t, const char *identifier)
{
    return socket_index(t->outputs, t->n_outputs, identifier);
}

int sg_node_type_prop_index(const sg_node_type *t, const char *name)
{
    for (int i = 0; i < t->n_props; i++)
        if (strcmp(t->props[i].name, name) == 0)
            return i;
    return -1;
}

bool sg_socket_available(const sg_socket_def *s, const int *prop)
{
    if (s->avail_mask && !(s->avail_mask & (1ull << (unsigned)prop[s->avail_prop])))
        return false;
    if (s->avail_mask2 && !(s->avail_mask2 & (1ull << (unsigned)prop[s->avail_prop2])))
        return false;
    return true;
}
