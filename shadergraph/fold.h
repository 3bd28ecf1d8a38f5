/*
 * Internal to shadergraph: what a node type's fold hook (sg_node_type.fold) may ask
 * and do, the counterpart of Cycles' ConstantFolder (scene/constant_fold.cpp). The
 * folder (fold.c) implements it over the flat graph; a hook lives beside its node's
 * kernel and knows its own socket and property indices.
 *
 * A hook sees one node. Inputs and outputs are indexed as in the type's socket tables.
 * "Constant" means unlinked and not an implicit geometry input; a constant's value is
 * what a link would have carried, already converted to the input's type. A hook only
 * runs on a node that has consumers and is not entirely constant (sg_node_type.fold).
 */
#ifndef IMSYNTH_SHADERGRAPH_FOLD_H
#define IMSYNTH_SHADERGRAPH_FOLD_H

#include "shadergraph/node_type.h"

sg_blender_mode sg_fold_mode(const sg_fold *x);
/* The node's property values (enum index or bool), as sg_kernel_args.prop. */
const int *sg_fold_props(const sg_fold *x);

bool sg_fold_input_constant(const sg_fold *x, int k);
bool sg_fold_input_linked(const sg_fold *x, int k);
/* Input k's stored value (4 floats; meaningful when constant). */
const float *sg_fold_input_value(const sg_fold *x, int k);
/* Cycles' is_zero / is_one: constant and every component (of 1 or 3) equal to v. So
 * -0 equals 0, and NaN never equals anything. */
bool sg_fold_input_equals(const sg_fold *x, int k, float v);
/* Inputs a and b are both linked, from the same output socket. */
bool sg_fold_inputs_same_link(const sg_fold *x, int a, int b);

/* Gives the consumers of output `out` the constant v (4 floats, in the output's type;
 * a colour's alpha is 1). A consumer that cannot store it (a colour socket cannot hold
 * a negative value) keeps its link. Returns whether any consumer changed. */
bool sg_fold_make_constant(sg_fold *x, int out, const float v[4]);
/* The same with v broadcast to every component. */
bool sg_fold_make_value(sg_fold *x, int out, float v);
/* Cycles' try_bypass_or_make_constant: output `out` becomes input `in` (same socket
 * type): its constant (saturated if `clamp`), or its link when not clamping. With
 * `clamp` and a linked input Cycles keeps the node but cuts its other links, so they
 * read their stored values (a quirk reproduced). Returns whether the graph changed. */
bool sg_fold_try_bypass(sg_fold *x, int in, int out, bool clamp);

#endif
