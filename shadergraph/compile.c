/*
 * Compiling a flat graph into a program.
 *
 * sg_compile first flattens and folds the graph (extract.c: groups inlined, reroutes and
 * Value/RGB nodes gone, Cycles' constant folding applied), then compiles that one tree:
 * so every node seen here is a typed node with a kernel or a sink, and there are no
 * groups (compile_flat asserts it). Compilation resolves each requested socket
 * backwards, on demand: an output socket becomes the register of the instruction that
 * computes its node (emitted after the instructions of its inputs, so the list is in
 * dependency order), an unlinked input becomes a constant or an implicit geometry
 * register. Nodes that no requested socket reaches are never visited, so they cost
 * nothing.
 *
 * Bump (SG_NODE_HEIGHT_OFFSETS) needs its Height at the shading point and one pixel
 * over in x and in y, as Cycles does. The tree therefore exists in three "variants"
 * (geometry offset 0, +dx, +dy). A node resolved in an offset variant whose inputs do
 * not depend on the offset is shared with variant 0, so only the part of the Height
 * subgraph that reads geometry is duplicated.
 */
#include <assert.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shadergraph/graph_internal.h"
#include "shadergraph/program.h"

typedef struct source {
    bool is_const;
    sg_socket_type type;
    float value[4]; /* is_const */
    int reg;        /* !is_const */
} source;

/* The tree in one variant. Variant instances are reached through base->variants. */
typedef struct instance {
    const sg_tree *tree;
    int variant;
    struct instance *base;
    struct instance *variants[3];
    int *memo; /* per node: instruction index + 1, 0 = not yet emitted */
    int *busy; /* per node: being resolved (guards against cycles) */
} instance;

typedef struct compiler {
    sg_program *p;
    char *err; /* the caller\'s message buffer */
    size_t errlen;
    instance **all;
    int n_all, cap_all;
    int cap_regs, cap_instr;
    int depth;
    bool failed;
} compiler;

#define MAX_DEPTH 10000

static int fail(compiler *c, const char *fmt, const char *a, const char *b)
{
    if (!c->failed) {
        char msg[400];
        snprintf(msg, sizeof msg, fmt, a, b);
        sg_error_set(c->err, c->errlen, "%s", msg);
    }
    c->failed = true;
    return -1;
}

static instance *new_instance(compiler *c, const sg_tree *t, int variant, instance *base)
{
    if (c->n_all == c->cap_all) {
        int cap = c->cap_all ? 2 * c->cap_all : 16;
        instance **a = realloc(c->all, sizeof *a * (size_t)cap);
        if (!a)
            return NULL;
        c->all = a;
        c->cap_all = cap;
    }
    instance *in = calloc(1, sizeof *in);
    if (!in)
        return NULL;
    in->tree = t;
    in->variant = variant;
    in->base = base ? base : in;
    in->memo = calloc((size_t)t->n_nodes + 1, sizeof *in->memo);
    in->busy = calloc((size_t)t->n_nodes + 1, sizeof *in->busy);
    if (!in->memo || !in->busy) {
        free(in->memo);
        free(in->busy);
        free(in);
        return NULL;
    }
    in->base->variants[variant] = in;
    c->all[c->n_all++] = in;
    return in;
}

static instance *get_variant(compiler *c, instance *in, int variant)
{
    instance *b = in->base;
    if (!b->variants[variant]) {
        if (!new_instance(c, b->tree, variant, b)) {
            fail(c, "out of memory%s%s", "", "");
            return NULL;
        }
    }
    return b->variants[variant];
}

static int new_reg(compiler *c, sg_reg_kind kind, int width)
{
    sg_program *p = c->p;
    if (p->n_regs == c->cap_regs) {
        int cap = c->cap_regs ? 2 * c->cap_regs : 64;
        sg_register *r = realloc(p->regs, sizeof *r * (size_t)cap);
        if (!r)
            return fail(c, "out of memory%s%s", "", "");
        p->regs = r;
        c->cap_regs = cap;
    }
    sg_register *r = &p->regs[p->n_regs];
    memset(r, 0, sizeof *r);
    r->kind = kind;
    r->width = width;
    return p->n_regs++;
}

static sg_instruction *new_instr(compiler *c)
{
    sg_program *p = c->p;
    if (p->n_instr == c->cap_instr) {
        int cap = c->cap_instr ? 2 * c->cap_instr : 64;
        sg_instruction *a = realloc(p->instr, sizeof *a * (size_t)cap);
        if (!a) {
            fail(c, "out of memory%s%s", "", "");
            return NULL;
        }
        p->instr = a;
        c->cap_instr = cap;
    }
    sg_instruction *in = &p->instr[p->n_instr++];
    memset(in, 0, sizeof *in);
    in->ramp = -1;
    return in;
}

static bool is_vec(sg_socket_type t) { return t == SG_SOCKET_VECTOR || t == SG_SOCKET_COLOR; }

/* Converts a source to type `to` the way Blender converts across a link. */
static source convert(compiler *c, source s, sg_socket_type to)
{
    sg_convert kind = SG_CONVERT_NONE;
    if (is_vec(to) && !is_vec(s.type))
        kind = SG_CONVERT_FLOAT_TO_VECTOR;
    else if (!is_vec(to) && s.type == SG_SOCKET_COLOR)
        kind = SG_CONVERT_COLOR_TO_FLOAT;
    else if (!is_vec(to) && s.type == SG_SOCKET_VECTOR)
        kind = SG_CONVERT_VECTOR_TO_FLOAT;
    source r = s;
    r.type = to;
    if (kind == SG_CONVERT_NONE)
        return r;
    if (s.is_const) {
        sg_convert_constant(s.type, to, s.value, r.value);
        return r;
    }
    int reg = new_reg(c, SG_REG_TEMP, is_vec(to) ? 3 : 1);
    sg_instruction *in = new_instr(c);
    if (reg < 0 || !in || !(in->in = malloc(sizeof(int))) || !(in->out = malloc(sizeof(int)))) {
        fail(c, "out of memory%s%s", "", "");
        return r;
    }
    in->convert = kind;
    in->n_in = in->n_out = 1;
    in->in[0] = s.reg;
    in->out[0] = reg;
    c->p->regs[reg].varies = c->p->regs[s.reg].varies;
    r.reg = reg;
    return r;
}

void sg_convert_constant(sg_socket_type from, sg_socket_type to, const float in[4], float out[4])
{
    float v[4];
    memcpy(v, in, sizeof v);
    if (is_vec(to) && !is_vec(from)) {
        v[1] = v[2] = v[0];
        v[3] = 1.0f;
    } else if (!is_vec(to) && from == SG_SOCKET_COLOR) {
        v[0] = v[0] * SG_LUMA_R + v[1] * SG_LUMA_G + v[2] * SG_LUMA_B;
    } else if (!is_vec(to) && from == SG_SOCKET_VECTOR) {
        v[0] = (v[0] + v[1] + v[2]) * (1.0f / 3.0f);
    }
    memcpy(out, v, sizeof v);
}

static source resolve_output(compiler *c, instance *in, int node, int socket);

static source geometry_source(compiler *c, sg_implicit what, int variant)
{
    source s = {.is_const = false, .type = SG_SOCKET_VECTOR};
    /* One register per (what, offset): look for an existing one. */
    for (int r = 0; r < c->p->n_regs; r++) {
        const sg_register *reg = &c->p->regs[r];
        if (reg->kind == SG_REG_GEOMETRY && reg->implicit == what && reg->offset == variant) {
            s.reg = r;
            return s;
        }
    }
    s.reg = new_reg(c, SG_REG_GEOMETRY, 3);
    if (s.reg >= 0) {
        sg_register *reg = &c->p->regs[s.reg];
        reg->implicit = what;
        reg->offset = variant;
        reg->varies = variant != 0 && what != SG_IMPLICIT_NORMAL;
    }
    return s;
}

/* The value flowing into input `k` of node `node`, converted to the input's type. */
static source resolve_input(compiler *c, instance *in, int node, int k)
{
    const sg_tree *t = in->tree;
    const sg_socket *sock = &t->nodes[node].in[k];
    int l = sg_tree_input_link(t, node, k);
    source s;
    if (l >= 0) {
        s = resolve_output(c, in, t->links[l].from_node, t->links[l].from_socket);
    } else if (sock->implicit != SG_IMPLICIT_NONE) {
        s = geometry_source(c, sock->implicit, in->variant);
    } else {
        s.is_const = true;
        s.type = sock->type;
        memcpy(s.value, sock->value, sizeof s.value);
        s.reg = -1;
    }
    if (c->failed)
        return s;
    return convert(c, s, sock->type);
}

static source emit_node(compiler *c, instance *in, int node, int socket);

static source resolve_output(compiler *c, instance *in, int node, int socket)
{
    source none = {.is_const = true, .reg = -1};
    if (c->failed)
        return none;
    if (++c->depth > MAX_DEPTH) {
        fail(c, "graph too deep to compile (over %s nested links)%s", "10000", "");
        return none;
    }
    const sg_node *n = &in->tree->nodes[node];
    /* Flattening left no reroute, group or Value/RGB node to resolve through. */
    assert(!(n->type->flags & SG_NODE_STRUCTURAL) && n->type->role != SG_ROLE_CONSTANT);
    source s;
    if (n->out[socket].type == SG_SOCKET_SHADER || !n->type->kernel) {
        fail(c, "node \"%s\": output \"%s\" is a shader or has no value to evaluate",
             n->name, n->out[socket].identifier);
        s = none;
    } else {
        s = emit_node(c, in, node, socket);
    }
    c->depth--;
    return s;
}

/* Emit (once per instance) the instruction computing node `node`, and return the
 * source for its output `socket`. */
static source emit_node(compiler *c, instance *in, int node, int socket)
{
    source none = {.is_const = true, .reg = -1};
    const sg_node *n = &in->tree->nodes[node];
    const sg_node_type *t = n->type;
    sg_program *p = c->p;
    if (!in->memo[node]) {
        if (in->busy[node])
            return fail(c, "node \"%s\": cycle%s", n->name, ""), none;
        in->busy[node] = 1;
        bool bump = (t->flags & SG_NODE_HEIGHT_OFFSETS) != 0;
        int n_in = t->n_inputs + (bump ? 2 : 0);
        int *regs_in = malloc(sizeof(int) * (size_t)(n_in + 1));
        if (!regs_in)
            return fail(c, "out of memory%s%s", "", ""), none;
        bool varies = false;
        for (int k = 0; k < t->n_inputs && !c->failed; k++) {
            source s = resolve_input(c, in, node, k);
            if (s.is_const) {
                s.reg = new_reg(c, SG_REG_CONST, sg_socket_type_width(s.type));
                if (s.reg >= 0)
                    memcpy(p->regs[s.reg].value, s.value, sizeof p->regs[s.reg].value);
            }
            regs_in[k] = s.reg;
            if (s.reg >= 0)
                varies |= p->regs[s.reg].varies;
        }
        if (bump && !c->failed) {
            int h = sg_node_type_input_index(t, "Height");
            for (int v = 1; v <= 2 && !c->failed; v++) {
                instance *vi = get_variant(c, in, v);
                source s = vi ? resolve_input(c, vi, node, h) : none;
                if (s.is_const) {
                    s.reg = new_reg(c, SG_REG_CONST, 1);
                    if (s.reg >= 0)
                        p->regs[s.reg].value[0] = s.value[0];
                }
                regs_in[t->n_inputs + v - 1] = s.reg;
            }
        }
        if (c->failed) {
            free(regs_in);
            return none;
        }
        bool reads_geometry = (t->flags & SG_NODE_READS_GEOMETRY) != 0;
        if (in->variant != 0 && !varies && !reads_geometry) {
            /* Same value at every offset: share variant 0's instruction. The inputs
             * resolved here were themselves shared, so nothing was emitted twice. */
            free(regs_in);
            in->busy[node] = 0;
            instance *v0 = get_variant(c, in, 0);
            return v0 ? emit_node(c, v0, node, socket) : none;
        }
        sg_instruction *ins = new_instr(c);
        int *regs_out = malloc(sizeof(int) * (size_t)(t->n_outputs + 1));
        if (!ins || !regs_out) {
            free(regs_in);
            free(regs_out);
            return fail(c, "out of memory%s%s", "", ""), none;
        }
        int index = p->n_instr - 1;
        ins->type = t;
        memcpy(ins->prop, n->prop, sizeof ins->prop);
        ins->offset = in->variant;
        ins->n_in = n_in;
        ins->n_out = t->n_outputs;
        ins->in = regs_in;
        ins->out = regs_out;
        for (int k = 0; k < t->n_outputs; k++)
            regs_out[k] = -1;
        if (n->ramp) {
            sg_color_ramp *r = realloc(p->ramps, sizeof *r * (size_t)(p->n_ramps + 1));
            if (!r)
                return fail(c, "out of memory%s%s", "", ""), none;
            p->ramps = r;
            p->ramps[p->n_ramps] = *n->ramp;
            sg_color_ramp_bake(&p->ramps[p->n_ramps], p->blender);
            ins->ramp = p->n_ramps++;
        }
        in->memo[node] = index + 1;
        in->busy[node] = 0;
    }
    /* Allocate the output register on first use. */
    sg_instruction *ins = &p->instr[in->memo[node] - 1];
    if (ins->out[socket] < 0) {
        int reg = new_reg(c, SG_REG_TEMP, sg_socket_type_width(t->outputs[socket].type));
        if (reg < 0)
            return none;
        ins = &p->instr[in->memo[node] - 1]; /* new_reg does not move instructions */
        ins->out[socket] = reg;
        bool varies = ins->offset != 0;
        p->regs[reg].varies = varies;
    }
    source s = {.is_const = false, .type = t->outputs[socket].type, .reg = ins->out[socket]};
    return s;
}

int sg_socket_ref_parse(char *text, sg_socket_ref *ref, char *err, size_t errlen)
{
    char *colon = strrchr(text, ':');
    if (!colon || colon == text || !colon[1])
        return sg_error_set(err, errlen, "\"%s\": expected NODE:SOCKET", text);
    *colon = '\0';
    ref->node = text;
    ref->socket = colon + 1;
    return 0;
}

static sg_program *compile_flat(const sg_graph *g, const sg_socket_ref *refs, int n_refs,
                                const sg_compile_options *opt, char *err, size_t errlen)
{
    compiler c = {.err = err, .errlen = errlen};
    sg_program *p = calloc(1, sizeof *p);
    if (!p) {
        sg_error_set(err, errlen, "out of memory");
        return NULL;
    }
    c.p = p;
    p->blender = opt && opt->blender ? opt->blender : SG_BLENDER_4;
    p->n_outputs = n_refs;
    p->output_reg = calloc((size_t)n_refs + 1, sizeof *p->output_reg);
    p->output_type = calloc((size_t)n_refs + 1, sizeof *p->output_type);
    /* The only caller passes sg_fold_for_compile's result: one flat tree. */
    assert(g->n_groups == 0);
    instance *main = new_instance(&c, &g->main, 0, NULL);
    if (!p->output_reg || !p->output_type || !main)
        fail(&c, "out of memory%s%s", "", "");
    for (int k = 0; k < n_refs && !c.failed; k++) {
        int node = sg_tree_find_node(&g->main, refs[k].node);
        if (node < 0) {
            fail(&c, "no node named \"%s\"%s", refs[k].node, "");
            break;
        }
        const sg_node *n = &g->main.nodes[node];
        int out = sg_node_output_index(n, refs[k].socket);
        int inp = sg_node_input_index(n, refs[k].socket);
        source s;
        if (out >= 0) {
            s = resolve_output(&c, main, node, out);
        } else if (inp >= 0) {
            if (n->in[inp].type == SG_SOCKET_SHADER) {
                fail(&c, "node \"%s\": input \"%s\" is a shader socket", n->name, refs[k].socket);
                break;
            }
            s = resolve_input(&c, main, node, inp);
        } else {
            fail(&c, "node \"%s\" has no socket \"%s\"", n->name, refs[k].socket);
            break;
        }
        if (c.failed)
            break;
        if (s.is_const) {
            s.reg = new_reg(&c, SG_REG_CONST, sg_socket_type_width(s.type));
            if (s.reg >= 0)
                memcpy(p->regs[s.reg].value, s.value, sizeof p->regs[s.reg].value);
        }
        p->output_reg[k] = s.reg;
        p->output_type[k] = s.type;
    }
    for (int i = 0; i < c.n_all; i++) {
        free(c.all[i]->memo);
        free(c.all[i]->busy);
        free(c.all[i]);
    }
    free(c.all);
    if (c.failed) {
        sg_program_free(p);
        return NULL;
    }
    return p;
}

void sg_program_free(sg_program *p)
{
    if (!p)
        return;
    for (int i = 0; i < p->n_instr; i++) {
        free(p->instr[i].in);
        free(p->instr[i].out);
    }
    free(p->instr);
    free(p->regs);
    free(p->output_reg);
    free(p->output_type);
    free(p->ramps);
    free(p);
}

/* Compiles what Cycles would run: the graph after Cycles' constant folding (extract.c),
 * whose algebraic folds (x * 0 = 0, Mix with factor 1 = B, ...) are part of what a
 * Blender material computes. */
sg_program *sg_compile(const sg_graph *g, const sg_socket_ref *refs, int n_refs,
                       const sg_compile_options *opt, char *err, size_t errlen)
{
    sg_blender_mode mode = opt && opt->blender ? opt->blender : SG_BLENDER_4;
    sg_socket_ref *resolved = calloc((size_t)n_refs + 1, sizeof *resolved);
    sg_socket_type *types = calloc((size_t)n_refs + 1, sizeof *types);
    sg_graph *folded = resolved && types
                           ? sg_fold_for_compile(g, mode, !(opt && opt->unfolded), refs, n_refs,
                                                 resolved, types, err, errlen)
                           : NULL;
    sg_program *p = NULL;
    if (folded) {
        sg_compile_options o = {.blender = mode};
        p = compile_flat(folded, resolved, n_refs, &o, err, errlen);
        for (int k = 0; p && k < n_refs; k++)
            p->output_type[k] = types[k];
    } else if (!resolved || !types) {
        sg_error_set(err, errlen, "out of memory");
    }
    sg_graph_free(folded);
    free(resolved);
    free(types);
    return p;
}

sg_socket_type sg_program_output_type(const sg_program *p, int k) { return p->output_type[k]; }
int sg_program_output_count(const sg_program *p) { return p->n_outputs; }
int sg_program_instruction_count(const sg_program *p) { return p->n_instr; }
