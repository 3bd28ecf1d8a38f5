/*
 * One node kernel called on a few points, with sockets and properties named as Blender
 * names them: the harness of the kernel tests (test_math_nodes, test_color_nodes, ...).
 *
 *     kernel_call c;
 *     kc_init(&c, "ShaderNodeMath", 2);           every input at its socket's default,
 *     kc_set_prop(&c, "operation", "POWER");      every property at its default
 *     kc_set(&c, "Value", 0, 2.0f, 0, 0);         input "Value" at point 0
 *     kc_run(&c);
 *     float r = kc_out(&c, "Value", 0, 0);        output "Value", point 0, channel 0
 *
 * Sockets are planar, as kernels take them (sg_kernel_args): channel ch of point i of a
 * socket of width w is at [ch * n + i]. An output can be left unrequested (kc_want), as
 * the compiler does for unlinked outputs, to test that a kernel skips it. Everything is
 * static: each test includes this once. Uses cmocka's assertions, so a misspelt socket
 * or property name fails the test instead of reading socket -1.
 */
#ifndef IMSYNTH_TESTS_KERNEL_CALL_H
#define IMSYNTH_TESTS_KERNEL_CALL_H

#include <stdbool.h>
#include <string.h>

#include "shadergraph/node_type.h"

enum { KC_MAX_POINTS = 128, KC_MAX_SOCKETS = 24 };

typedef struct kernel_call {
    const sg_node_type *type;
    int n;
    int prop[SG_MAX_PROPS];
    sg_blender_mode blender;          /* SG_BLENDER_4 after kc_init */
    const sg_color_ramp *ramp;        /* Color Ramp's stops; NULL elsewhere */
    float in[KC_MAX_SOCKETS][3 * KC_MAX_POINTS];
    float out[KC_MAX_SOCKETS][3 * KC_MAX_POINTS];
    bool unwanted[KC_MAX_SOCKETS];    /* outputs passed to the kernel as NULL */
} kernel_call;

static inline void kc_init(kernel_call *c, const char *idname, int n)
{
    memset(c, 0, sizeof *c);
    c->type = sg_node_type_find(idname);
    assert_non_null(c->type);
    assert_true(n >= 1 && n <= KC_MAX_POINTS);
    assert_true(c->type->n_inputs <= KC_MAX_SOCKETS && c->type->n_outputs <= KC_MAX_SOCKETS);
    assert_true(c->type->n_props <= SG_MAX_PROPS);
    c->n = n;
    c->blender = SG_BLENDER_4;
    for (int p = 0; p < c->type->n_props; p++)
        c->prop[p] = c->type->props[p].default_value;
    for (int k = 0; k < c->type->n_inputs; k++) {
        const sg_socket_def *s = &c->type->inputs[k];
        for (int ch = 0; ch < sg_socket_type_width(s->type); ch++)
            for (int i = 0; i < n; i++)
                c->in[k][ch * n + i] = s->default_value[ch];
    }
}

static inline int kc_input(const kernel_call *c, const char *identifier)
{
    int k = sg_node_type_input_index(c->type, identifier);
    if (k < 0) {
        fail_msg("%s has no input %s", c->type->idname, identifier);
        return 0; /* not reached (fail_msg longjmps); tells the compiler k >= 0 */
    }
    return k;
}

static inline int kc_output(const kernel_call *c, const char *identifier)
{
    int k = sg_node_type_output_index(c->type, identifier);
    if (k < 0) {
        fail_msg("%s has no output %s", c->type->idname, identifier);
        return 0; /* not reached (fail_msg longjmps); tells the compiler k >= 0 */
    }
    return k;
}

/* Input `identifier` at point i; y and z are ignored for a scalar socket. */
static inline void kc_set(kernel_call *c, const char *identifier, int i, float x, float y,
                          float z)
{
    int k = kc_input(c, identifier);
    assert_true(i >= 0 && i < c->n);
    c->in[k][i] = x;
    if (sg_socket_type_width(c->type->inputs[k].type) == 3) {
        c->in[k][c->n + i] = y;
        c->in[k][2 * c->n + i] = z;
    }
}

static inline void kc_set_all(kernel_call *c, const char *identifier, float x, float y, float z)
{
    for (int i = 0; i < c->n; i++)
        kc_set(c, identifier, i, x, y, z);
}

/* The planar array of input `identifier` (width x n floats), to fill directly. */
static inline float *kc_in(kernel_call *c, const char *identifier)
{
    return c->in[kc_input(c, identifier)];
}

/* A property by its RNA name: an enum by its value's identifier ("POWER"), a boolean by
 * "true" / "false". */
static inline void kc_set_prop(kernel_call *c, const char *name, const char *value)
{
    int p = sg_node_type_prop_index(c->type, name);
    if (p < 0)
        fail_msg("%s has no property %s", c->type->idname, name);
    const sg_prop_def *d = &c->type->props[p];
    if (d->kind == SG_PROP_BOOL) {
        assert_true(!strcmp(value, "true") || !strcmp(value, "false"));
        c->prop[p] = !strcmp(value, "true");
        return;
    }
    for (int v = 0; d->values[v]; v++)
        if (!strcmp(d->values[v], value)) {
            c->prop[p] = v;
            return;
        }
    fail_msg("%s.%s has no value %s", c->type->idname, name, value);
}

/* An enum property by the index of its value (to loop over every value). */
static inline void kc_set_prop_index(kernel_call *c, const char *name, int v)
{
    int p = sg_node_type_prop_index(c->type, name);
    if (p < 0)
        fail_msg("%s has no property %s", c->type->idname, name);
    assert_true(c->type->props[p].kind == SG_PROP_ENUM && v >= 0);
    for (int k = 0; k <= v; k++)
        assert_non_null(c->type->props[p].values[k]);
    c->prop[p] = v;
}

static inline void kc_want(kernel_call *c, const char *output, bool wanted)
{
    c->unwanted[kc_output(c, output)] = !wanted;
}

static inline void kc_run(kernel_call *c)
{
    const float *in[KC_MAX_SOCKETS];
    float *out[KC_MAX_SOCKETS];
    for (int k = 0; k < KC_MAX_SOCKETS; k++) {
        in[k] = c->in[k];
        out[k] = c->unwanted[k] ? NULL : c->out[k];
    }
    sg_kernel_args a;
    memset(&a, 0, sizeof a);
    a.n = c->n;
    a.blender = c->blender;
    a.prop = c->prop;
    a.ramp = c->ramp;
    a.in = in;
    a.out = out;
    c->type->kernel(&a);
}

/* Does Blender show input `identifier` with the call's current properties? */
static inline bool kc_available(const kernel_call *c, const char *identifier)
{
    return sg_socket_available(&c->type->inputs[kc_input(c, identifier)], c->prop);
}

/* Does Blender show output `identifier` with the call's current properties? */
static inline bool kc_output_available(const kernel_call *c, const char *identifier)
{
    return sg_socket_available(&c->type->outputs[kc_output(c, identifier)], c->prop);
}

/* The planar array of output `identifier` (width x n floats). */
static inline const float *kc_outputs(const kernel_call *c, const char *identifier)
{
    return c->out[kc_output(c, identifier)];
}

/* Output `identifier`, point i, channel ch. */
static inline float kc_out(const kernel_call *c, const char *identifier, int i, int ch)
{
    return c->out[kc_output(c, identifier)][ch * c->n + i];
}

#endif
