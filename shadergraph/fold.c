/*
 * Folding: Cycles' constant folding of the flat graph, node by node.
 *
 * Blender renders a material after Cycles has constant-folded its graph, and some of
 * those folds are algebraic rather than arithmetic: x * 0 is 0 even where x is
 * infinite, a Mix with factor 1 is B itself rather than a + (b - a). So the folds
 * are part of what a node graph computes, and the folder applies exactly the ones
 * Cycles applies (scene/shader_nodes.cpp and constant_fold.cpp of Blender 3.4 and 4.3),
 * no more: that is what lets a sub-shader equal its super-shader bit for bit, and both
 * equal Blender.
 *
 * As in Cycles, each node type folds itself, beside its kernel (sg_node_type.fold, with
 * the API of fold.h): Math and Vector Math in kernels/math.c, Mix, Mix RGB and Invert
 * in kernels/color.c, Mapping in kernels/convert.c, Bump in kernels/geometry.c. What is
 * generic lives here: a node of an SG_NODE_FOLD_CONSTANT type whose inputs are all
 * constant becomes its value, computed by its own kernel on the host (host_fold). A
 * node without consumers is skipped: folding it could change nothing downstream.
 *
 * Invariants kept: only links and input values change, never the node list (a node
 * bypassed or made constant loses its consumers and is left for extract.c to drop);
 * every replacement value is exactly what the consumer would have read in Cycles.
 */
#include <string.h>

#include "shadergraph/flat.h"
#include "shadergraph/fold.h"
#include "shadergraph/program.h"

struct sg_fold {
    sg_flat *f;
    int node;
    sg_blender_mode mode;
};

static int input_link(const sg_flat *f, int node, int k) { return sg_flat_input_link(f, node, k); }

static bool is_const_input(const sg_flat *f, int node, int k)
{
    const sg_socket *s = &f->t.nodes[node].in[k];
    return input_link(f, node, k) < 0 && s->implicit == SG_IMPLICIT_NONE;
}

/* Gives every consumer of (node, socket) the constant `v` of type t, except where the
 * value cannot be stored: Blender clamps colour sockets at 0, so a negative colour stays
 * computed by its node. Returns how many links were replaced. */
static int replace_output_by_constant(sg_flat *f, int node, int socket, sg_socket_type t, const float *v)
{
    int replaced = 0;
    for (int l = f->first_from[node], next; l >= 0; l = next) {
        next = f->next_from[l];
        sg_link k = f->t.links[l];
        if (k.from_socket != socket)
            continue;
        sg_socket *in = &f->t.nodes[k.to_node].in[k.to_socket];
        float conv[4];
        sg_convert_constant(t, in->type, v, conv);
        if (in->type == SG_SOCKET_COLOR && (conv[0] < 0.0f || conv[1] < 0.0f || conv[2] < 0.0f))
            continue;
        memcpy(in->value, conv, sizeof conv);
        in->implicit = SG_IMPLICIT_NONE;
        int last = f->t.n_links - 1;
        sg_flat_remove_link(f, l);
        if (next == last)
            next = l; /* the successor moved into the removed link's slot */
        replaced++;
    }
    return replaced;
}

/* Every input constant: no implicit input, and no link into the node. */
static bool all_inputs_constant(const sg_flat *f, int node)
{
    const sg_node *n = &f->t.nodes[node];
    for (int k = 0; k < n->n_in; k++)
        if (n->in[k].implicit != SG_IMPLICIT_NONE)
            return false;
    return f->n_into[node] == 0;
}

static bool has_output_consumers(const sg_flat *f, int node, int socket)
{
    for (int l = f->first_from[node]; l >= 0; l = f->next_from[l])
        if (f->t.links[l].from_socket == socket)
            return true;
    return false;
}

static bool has_consumers(const sg_flat *f, int node) { return f->n_from[node] > 0; }

/* ---- the API of fold.h ------------------------------------------------------------ */

sg_blender_mode sg_fold_mode(const sg_fold *x) { return x->mode; }

const int *sg_fold_props(const sg_fold *x) { return x->f->t.nodes[x->node].prop; }

bool sg_fold_input_constant(const sg_fold *x, int k)
{
    return k >= 0 && is_const_input(x->f, x->node, k);
}

bool sg_fold_input_linked(const sg_fold *x, int k) { return input_link(x->f, x->node, k) >= 0; }

const float *sg_fold_input_value(const sg_fold *x, int k) { return x->f->t.nodes[x->node].in[k].value; }

bool sg_fold_inputs_same_link(const sg_fold *x, int a, int b)
{
    int la = input_link(x->f, x->node, a), lb = input_link(x->f, x->node, b);
    return la >= 0 && lb >= 0 && x->f->t.links[la].from_node == x->f->t.links[lb].from_node &&
           x->f->t.links[la].from_socket == x->f->t.links[lb].from_socket;
}

bool sg_fold_input_equals(const sg_fold *x, int k, float v)
{
    if (!sg_fold_input_constant(x, k))
        return false;
    const sg_socket *s = &x->f->t.nodes[x->node].in[k];
    int w = sg_is_vec_type(s->type) ? 3 : 1;
    for (int c = 0; c < w; c++)
        if (!(s->value[c] == v))
            return false;
    return true;
}

bool sg_fold_make_constant(sg_fold *x, int out, const float v[4])
{
    return replace_output_by_constant(x->f, x->node, out, x->f->t.nodes[x->node].out[out].type, v) > 0;
}

bool sg_fold_make_value(sg_fold *x, int out, float value)
{
    float v[4] = {value, value, value, 1.0f};
    return sg_fold_make_constant(x, out, v);
}

bool sg_fold_try_bypass(sg_fold *x, int in, int out, bool clamp)
{
    sg_flat *f = x->f;
    sg_node *n = &f->t.nodes[x->node];
    if (in < 0 || out < 0 || n->in[in].type != n->out[out].type)
        return false;
    if (sg_fold_input_constant(x, in)) {
        float v[4];
        memcpy(v, n->in[in].value, sizeof v);
        if (clamp)
            for (int c = 0; c < 3; c++)
                v[c] = v[c] > 0.0f ? (v[c] < 1.0f ? v[c] : 1.0f) : 0.0f;
        return sg_fold_make_constant(x, out, v);
    }
    int l = input_link(f, x->node, in);
    if (l < 0)
        return false; /* implicit geometry input: not a link we can point at */
    if (clamp) {
        bool cut = false;
        for (int k = 0; k < n->n_in; k++) {
            int lk = k == in ? -1 : input_link(f, x->node, k);
            if (lk >= 0) {
                sg_flat_remove_link(f, lk);
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
    if (src != n->in[in].type && sg_is_vec_type(src))
        return false;
    bool any = has_output_consumers(f, x->node, out);
    sg_flat_redirect_output(f, x->node, out, lk->from_node, lk->from_socket);
    return any;
}

/* ---- the generic fold and the pass --------------------------------------------------- */

/* All inputs constant: the node's value, computed by its own kernel as Cycles' host
 * code would (host_fold). */
static bool fold_all_constant(sg_fold *x)
{
    sg_flat *f = x->f;
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
    if (n->ramp && n->ramp->baked_steps == 0)
        sg_color_ramp_bake(n->ramp, x->mode);
    t->kernel(&a);
    int replaced = 0;
    for (int k = 0; k < n->n_out; k++)
        replaced += sg_fold_make_constant(x, k, outv[k]);
    return replaced > 0;
}

static bool fold_node(sg_flat *f, int node, sg_blender_mode mode)
{
    sg_fold x = {f, node, mode};
    const sg_node *n = &f->t.nodes[node];
    const sg_node_type *t = n->type;
    if (!t->kernel || (t->flags & (SG_NODE_READS_GEOMETRY | SG_NODE_SINK)))
        return false;
    if ((t->flags & SG_NODE_FOLD_CONSTANT) && all_inputs_constant(f, node))
        return fold_all_constant(&x);
    return t->fold && t->fold(&x);
}

bool sg_fold_pass(sg_flat *f, sg_blender_mode mode)
{
    bool changed = false;
    for (int i = 0; i < f->t.n_nodes && !f->failed; i++)
        if (!f->dead[i] && has_consumers(f, i))
            changed |= fold_node(f, i, mode);
    return changed;
}
