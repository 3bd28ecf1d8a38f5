/*
 * Internal to shadergraph: a compiled program (compile.c) as the evaluator
 * (evaluate.c) runs it. Registers are planar SoA arrays of width * n floats.
 * Instructions are in dependency order: every register is written before it is read.
 */
#ifndef IMSYNTH_SHADERGRAPH_PROGRAM_H
#define IMSYNTH_SHADERGRAPH_PROGRAM_H

#include "shadergraph/node_type.h"

typedef enum sg_reg_kind {
    SG_REG_TEMP,    /* written by an instruction */
    SG_REG_CONST,   /* a constant, broadcast to every point */
    SG_REG_GEOMETRY /* an implicit geometry input (generated, N, ...) at an offset */
} sg_reg_kind;

typedef struct sg_register {
    sg_reg_kind kind;
    int width;            /* 1 or 3 */
    float value[3];       /* SG_REG_CONST */
    sg_implicit implicit; /* SG_REG_GEOMETRY */
    int offset;           /* SG_REG_GEOMETRY: 0 centre, 1 +dx, 2 +dy */
    bool varies;          /* depends on the geometry offset (see compile.c) */
} sg_register;

typedef enum sg_convert {
    SG_CONVERT_NONE,
    SG_CONVERT_FLOAT_TO_VECTOR, /* broadcast */
    SG_CONVERT_COLOR_TO_FLOAT,  /* luminance */
    SG_CONVERT_VECTOR_TO_FLOAT  /* average */
} sg_convert;

typedef struct sg_instruction {
    const sg_node_type *type; /* NULL for a conversion */
    sg_convert convert;
    int prop[SG_MAX_PROPS];
    int ramp;   /* index into program ramps, or -1 */
    int offset; /* geometry offset for nodes that read geometry */
    int n_in, n_out;
    int *in;  /* register per input (n_in entries; Bump has 2 extra) */
    int *out; /* register per output, -1 when unused */
} sg_instruction;

struct sg_program {
    sg_blender_mode blender;
    int n_regs, n_instr, n_outputs, n_ramps;
    sg_register *regs;
    sg_instruction *instr;
    int *output_reg;
    sg_socket_type *output_type;
    sg_color_ramp *ramps;
};

/* Rec. 709 luminance, as Blender's colour-management config declares it (its
 * `luma` line); Cycles converts colour to float with these weights. */
#define SG_LUMA_R 0.2126729f
#define SG_LUMA_G 0.7151522f
#define SG_LUMA_B 0.0721750f

/* Converts a constant of type `from` to type `to` exactly as a link between such
 * sockets converts values (compile.c). `in` and `out` may alias. */
void sg_convert_constant(sg_socket_type from, sg_socket_type to, const float in[4], float out[4]);

#endif
