/*
 * Running a compiled program over a batch of shading points.
 *
 * The evaluator owns a register file: one planar array per register, sized for
 * max_batch points. Instructions run one after another, each over the whole batch,
 * so the dispatch cost (building kernel arguments, the indirect call) is paid once per
 * instruction per batch rather than per point, and the kernels' inner loops run over
 * contiguous arrays the compiler can vectorize.
 *
 * Constants are stored broadcast in the planar layout of the current batch size, so
 * they are refilled only when the batch size changes (usually only for the last,
 * partial batch). Geometry registers at offset 0 point straight at the caller's
 * arrays; offset ones are computed per batch (value + differential).
 */
#include <assert.h>
#include <stdlib.h>
#include <string.h>

#include "shadergraph/program.h"

struct sg_evaluator {
    const sg_program *p;
    int max_batch;
    int const_n;    /* batch size the constants are laid out for, 0 = not yet */
    float *storage; /* all registers' arrays */
    float **reg;    /* per register: its array for this batch */
    float **own;    /* per register: its own storage (NULL for geometry at offset 0) */
    /* Scratch for pointwise evaluation: one point's geometry. */
    float *point_geom;
    const float **in_ptrs;
    float **out_ptrs;
    int max_io;
};

sg_evaluator *sg_evaluator_new(const sg_program *p, int max_batch)
{
    if (max_batch < 1)
        return NULL;
    sg_evaluator *e = calloc(1, sizeof *e);
    if (!e)
        return NULL;
    e->p = p;
    e->max_batch = max_batch;
    size_t total = 0;
    for (int r = 0; r < p->n_regs; r++)
        total += (size_t)p->regs[r].width * (size_t)max_batch;
    int max_io = 1;
    for (int i = 0; i < p->n_instr; i++) {
        if (p->instr[i].n_in > max_io)
            max_io = p->instr[i].n_in;
        if (p->instr[i].n_out > max_io)
            max_io = p->instr[i].n_out;
    }
    e->max_io = max_io;
    e->storage = malloc(sizeof(float) * (total + 1));
    e->reg = calloc((size_t)p->n_regs + 1, sizeof *e->reg);
    e->own = calloc((size_t)p->n_regs + 1, sizeof *e->own);
    e->point_geom = malloc(sizeof(float) * 3 * 16);
    e->in_ptrs = calloc((size_t)max_io, sizeof *e->in_ptrs);
    e->out_ptrs = calloc((size_t)max_io, sizeof *e->out_ptrs);
    if (!e->storage || !e->reg || !e->own || !e->point_geom || !e->in_ptrs || !e->out_ptrs) {
        sg_evaluator_free(e);
        return NULL;
    }
    size_t at = 0;
    for (int r = 0; r < p->n_regs; r++) {
        e->own[r] = e->storage + at;
        e->reg[r] = e->own[r];
        at += (size_t)p->regs[r].width * (size_t)max_batch;
    }
    return e;
}

void sg_evaluator_free(sg_evaluator *e)
{
    if (!e)
        return;
    free(e->storage);
    free(e->reg);
    free(e->own);
    free(e->point_geom);
    free(e->in_ptrs);
    free(e->out_ptrs);
    free(e);
}

static void fill_constants(sg_evaluator *e, int n)
{
    const sg_program *p = e->p;
    for (int r = 0; r < p->n_regs; r++) {
        const sg_register *reg = &p->regs[r];
        if (reg->kind != SG_REG_CONST)
            continue;
        for (int c = 0; c < reg->width; c++)
            for (int i = 0; i < n; i++)
                e->own[r][c * n + i] = reg->value[c];
    }
    e->const_n = n;
}

/* Value and differentials of one implicit input in the batch. */
static void geometry_field(const sg_geometry_batch *g, sg_implicit what, const float **v,
                           const float **dx, const float **dy)
{
    *dx = *dy = NULL;
    switch (what) {
    case SG_IMPLICIT_GENERATED:
        *v = g->generated, *dx = g->dgenerated_dx, *dy = g->dgenerated_dy;
        break;
    case SG_IMPLICIT_UV:
        *v = g->uv, *dx = g->duv_dx, *dy = g->duv_dy;
        break;
    case SG_IMPLICIT_POSITION:
        *v = g->P, *dx = g->dPdx, *dy = g->dPdy;
        break;
    case SG_IMPLICIT_NORMAL:
    default:
        *v = g->N;
        break;
    }
}

static void bind_geometry(sg_evaluator *e, const sg_geometry_batch *g)
{
    const sg_program *p = e->p;
    int n = g->n;
    for (int r = 0; r < p->n_regs; r++) {
        const sg_register *reg = &p->regs[r];
        if (reg->kind != SG_REG_GEOMETRY)
            continue;
        const float *v, *dx, *dy;
        geometry_field(g, reg->implicit, &v, &dx, &dy);
        const float *d = reg->offset == 1 ? dx : reg->offset == 2 ? dy : NULL;
        if (!d) {
            e->reg[r] = (float *)v; /* read-only: no instruction writes a geometry register */
            continue;
        }
        e->reg[r] = e->own[r];
        for (int i = 0; i < 3 * n; i++)
            e->own[r][i] = v[i] + d[i];
    }
}

static void run_convert(const sg_instruction *ins, const float *a, float *out, int n)
{
    switch (ins->convert) {
    case SG_CONVERT_FLOAT_TO_VECTOR:
        for (int c = 0; c < 3; c++)
            memcpy(out + c * n, a, sizeof(float) * (size_t)n);
        break;
    case SG_CONVERT_COLOR_TO_FLOAT:
        for (int i = 0; i < n; i++)
            out[i] = a[i] * SG_LUMA_R + a[n + i] * SG_LUMA_G + a[2 * n + i] * SG_LUMA_B;
        break;
    case SG_CONVERT_VECTOR_TO_FLOAT:
        for (int i = 0; i < n; i++)
            out[i] = (a[i] + a[n + i] + a[2 * n + i]) * (1.0f / 3.0f);
        break;
    default:
        break;
    }
}

static void run_program(sg_evaluator *e, const sg_geometry_batch *g)
{
    const sg_program *p = e->p;
    int n = g->n;
    if (e->const_n != n)
        fill_constants(e, n);
    bind_geometry(e, g);
    for (int i = 0; i < p->n_instr; i++) {
        const sg_instruction *ins = &p->instr[i];
        if (!ins->type) {
            run_convert(ins, e->reg[ins->in[0]], e->reg[ins->out[0]], n);
            continue;
        }
        for (int k = 0; k < ins->n_in; k++)
            e->in_ptrs[k] = e->reg[ins->in[k]];
        for (int k = 0; k < ins->n_out; k++)
            e->out_ptrs[k] = ins->out[k] >= 0 ? e->reg[ins->out[k]] : NULL;
        sg_kernel_args a = {
            .n = n,
            .blender = p->blender,
            .prop = ins->prop,
            .ramp = ins->ramp >= 0 ? &p->ramps[ins->ramp] : NULL,
            .in = e->in_ptrs,
            .out = e->out_ptrs,
            .geom = g,
            .offset = ins->offset,
        };
        ins->type->kernel(&a);
    }
}

static void copy_outputs(const sg_evaluator *e, int n, float *const *out, int at, int out_n)
{
    const sg_program *p = e->p;
    for (int k = 0; k < p->n_outputs; k++) {
        int w = sg_socket_type_width(p->output_type[k]);
        const float *src = e->reg[p->output_reg[k]];
        for (int c = 0; c < w; c++)
            memcpy(out[k] + (size_t)c * (size_t)out_n + (size_t)at, src + (size_t)c * (size_t)n,
                   sizeof(float) * (size_t)n);
    }
}

void sg_evaluate(sg_evaluator *e, const sg_geometry_batch *geom, float *const *out)
{
    /* The registers hold max_batch points (sg_evaluator_new). */
    assert(geom->n >= 0 && geom->n <= e->max_batch);
    run_program(e, geom);
    copy_outputs(e, geom->n, out, 0, geom->n);
}

/* Copies point i of a batch's planar vector field into a one-point field. */
static const float *pick(const float *v, int n, int i, float *dst)
{
    dst[0] = v[i];
    dst[1] = v[n + i];
    dst[2] = v[2 * n + i];
    return dst;
}

void sg_evaluate_pointwise(sg_evaluator *e, const sg_geometry_batch *geom, float *const *out)
{
    int n = geom->n;
    float *s = e->point_geom;
    for (int i = 0; i < n; i++) {
        sg_geometry_batch one = {
            .n = 1,
            .P = pick(geom->P, n, i, s + 0),
            .dPdx = pick(geom->dPdx, n, i, s + 3),
            .dPdy = pick(geom->dPdy, n, i, s + 6),
            .N = pick(geom->N, n, i, s + 9),
            .Ng = pick(geom->Ng, n, i, s + 12),
            .I = pick(geom->I, n, i, s + 15),
            .generated = pick(geom->generated, n, i, s + 18),
            .dgenerated_dx = pick(geom->dgenerated_dx, n, i, s + 21),
            .dgenerated_dy = pick(geom->dgenerated_dy, n, i, s + 24),
            .uv = pick(geom->uv, n, i, s + 27),
            .duv_dx = pick(geom->duv_dx, n, i, s + 30),
            .duv_dy = pick(geom->duv_dy, n, i, s + 33),
            .object = pick(geom->object, n, i, s + 36),
            .dobject_dx = pick(geom->dobject_dx, n, i, s + 39),
            .dobject_dy = pick(geom->dobject_dy, n, i, s + 42),
            .object_normal = pick(geom->object_normal, n, i, s + 45),
        };
        run_program(e, &one);
        copy_outputs(e, 1, out, i, n);
    }
}
