#!/usr/bin/env python3
"""Writes assets/supershader.json: the super-shader every training sample is made from.

    python3 assets/generate_supershader.py [-o assets/supershader.json]

Plain Python 3, no Blender: the graph is written in our format (shadergraph/FORMAT.md,
imsynth-graph/1, Blender 4.x idnames and socket identifiers), so Blender can build it
with blender/import_material.py and our evaluator can run it as it is.

Design (the thesis's super-shader is lost; this follows its description, thesis.md 5.1):

  RandomValues (group, no inputs: 50 Value nodes -> Group Output; binding a parameter
  set = setting those Value nodes, see shadergraph/params.c)
    |
  Texture Coordinate.Object + Pattern Offset, domain-warped by a fixed noise
    |
  Noise Module A, B, C  (eleven patterns behind an 11-way hard switch, each shaped by
    |                    Scale / Detail / Roughness / Distortion, output in [0, 1])
  Math Module "Structure" = A (op) B, Math Module "Detail" = Structure (op) C
    |                    (add/subtract/multiply/divide/minimum/maximum, renormalised)
  three Value Mapping modules (linear / smootherstep / stepped / ridge ramp) shape the
  signals chosen (by hard switches) for colour, roughness and height
    |
  colour layers (two-tone, grime, accent spots, detail overlay) through a smooth,
  interpolating 4-way switch -> Base Color; metal mode (dielectric / metal / metal
  where there is no accent, like rust) -> Metallic; roughness range -> Roughness;
  height -> Bump -> Normal; Principled BSDF -> Material Output.

So the same three noise signals drive all four maps, and random parameters give
materials whose colour, shine and relief agree.

Multiplexers, as DESIGN.md states them: a hard N-way switch picks input
min(floor(v*N), N-1); the smooth colour switch interpolates neighbours at v*(N-1).
Both are built from Math and Mix nodes only, so any evaluator of Blender nodes runs them.

Node count: every node of the material tree, a group node replaced by the nodes of its
group (its Group Input and Group Output included), recursively, once per group instance
(shadergraph's sg_graph_node_count). Printed on stdout together with the count after
Blender's "Ungroup" (group input/output nodes removed too).
"""

import argparse
import json
import math
import os
import sys
import tempfile

FORMAT = "imsynth-graph/1"

# Rough node heights in Blender's editor units (for a layout without overlaps).
NODE_HEIGHT = {
    "ShaderNodeTexNoise": 330, "ShaderNodeTexVoronoi": 330, "ShaderNodeMapRange": 290,
    "ShaderNodeMath": 170, "ShaderNodeVectorMath": 190, "ShaderNodeMix": 230,
    "ShaderNodeValToRGB": 260, "ShaderNodeValue": 110, "ShaderNodeCombineColor": 170,
    "ShaderNodeClamp": 170, "ShaderNodeBump": 200, "ShaderNodeBsdfPrincipled": 700,
    "ShaderNodeOutputMaterial": 140, "ShaderNodeTexCoord": 260, "NodeReroute": 30,
}
NODE_WIDTH = 240


class Tree:
    """One node tree (the material or a group) under construction."""

    def __init__(self, name, inputs=None, outputs=None):
        self.name = name
        self.nodes = []
        self.by_name = {}
        self.links = []
        self.inputs = inputs or []    # group interface (groups only)
        self.outputs = outputs or []

    def node(self, type_, name, props=None, inputs=None, outputs=None, label=None,
             group=None, ramp=None):
        assert name not in self.by_name, (self.name, name)
        n = {"name": name, "type": type_, "location": [0.0, 0.0]}
        if label:
            n["label"] = label
        if props:
            n["properties"] = props
        if inputs:
            n["inputs"] = inputs
        if outputs:
            n["outputs"] = outputs
        if group:
            n["group"] = group
        if ramp:
            n["color_ramp"] = ramp
        self.nodes.append(n)
        self.by_name[name] = n
        return name

    def link(self, from_node, from_socket, to_node, to_socket):
        assert from_node in self.by_name and to_node in self.by_name, (from_node, to_node)
        for l in self.links:
            assert not (l["to_node"] == to_node and l["to_socket"] == to_socket), (to_node, to_socket)
        self.links.append({"from_node": from_node, "from_socket": from_socket,
                           "to_node": to_node, "to_socket": to_socket})

    # ---- small builders ------------------------------------------------------------
    def math(self, name, op, a=None, b=None, label=None, clamp=False):
        """Math node; a and b are (node, socket) pairs or constants."""
        props = {"operation": op}
        if clamp:
            props["use_clamp"] = True
        n = self.node("ShaderNodeMath", name, props, label=label)
        self._feed(n, "Value", a)
        self._feed(n, "Value_001", b)
        return n

    def map_range(self, name, value, to_min, to_max, from_min=0.0, from_max=1.0,
                  interpolation="LINEAR", label=None, steps=None):
        props = {"interpolation_type": interpolation} if interpolation != "LINEAR" else None
        inputs = {}
        for sock, v in (("From Min", from_min), ("From Max", from_max),
                        ("To Min", to_min), ("To Max", to_max)):
            if not isinstance(v, tuple):
                inputs[sock] = float(v)
        if steps is not None:
            inputs["Steps"] = float(steps)
        n = self.node("ShaderNodeMapRange", name, props, inputs or None, label=label)
        self._feed(n, "Value", value)
        for sock, v in (("From Min", from_min), ("From Max", from_max),
                        ("To Min", to_min), ("To Max", to_max)):
            if isinstance(v, tuple):
                self.link(v[0], v[1], n, sock)
        return n

    def param_range(self, name, value, lo, hi, label=None):
        """lo + value * (hi - lo) for parameters in [0, 1], as Math nodes (Multiply, then
        Add unless lo is 0): unlike Map Range, which Cycles never constant-folds, Math
        nodes with constant inputs fold away once the parameter is bound. Not Multiply
        Add: Cycles fuses it in its AVX2 kernel but folds it on the host unfused, so its
        last bit depends on where it is computed. lo and hi are numbers or (node, socket)
        pairs (then a Subtract node computes hi - lo)."""
        const = not isinstance(lo, tuple) and not isinstance(hi, tuple)
        span = float(hi - lo) if const else (self.math(name + " Span", "SUBTRACT", hi, lo), "Value")
        text = label or ("%g..%g" % (lo, hi) if const else None)
        if const and lo == 0.0:
            return (self.math(name, "MULTIPLY", value, span, label=text), "Value")
        m = self.math(name + " Width", "MULTIPLY", value, span)
        return (self.math(name, "ADD", (m, "Value"), lo, label=text), "Value")

    def mix_float(self, name, fac, a, b, label=None):
        n = self.node("ShaderNodeMix", name, {"data_type": "FLOAT"}, label=label)
        self._feed(n, "Factor_Float", fac)
        self._feed(n, "A_Float", a)
        self._feed(n, "B_Float", b)
        return n

    def mix_color(self, name, fac, a, b, blend="MIX", label=None, clamp_result=False):
        props = {"data_type": "RGBA", "blend_type": blend}
        if clamp_result:
            props["clamp_result"] = True
        n = self.node("ShaderNodeMix", name, props, label=label)
        self._feed(n, "Factor_Float", fac)
        self._feed(n, "A_Color", a)
        self._feed(n, "B_Color", b)
        return n

    def group_node(self, name, group, inputs=None, label=None):
        return self.node("ShaderNodeGroup", name, inputs=inputs, group=group.name, label=label)

    def _feed(self, node, socket, src):
        if src is None:
            return
        if isinstance(src, tuple):
            self.link(src[0], src[1], node, socket)
        else:
            n = self.by_name[node]
            n.setdefault("inputs", {})[socket] = src if isinstance(src, list) else float(src)

    # ---- layout --------------------------------------------------------------------
    def layout(self):
        """Columns by longest distance to the tree's sink, right to left; nodes in a
        column stacked top-down in creation order, spaced by their heights."""
        consumers = {n["name"]: [] for n in self.nodes}
        for l in self.links:
            consumers[l["from_node"]].append(l["to_node"])
        depth = {}

        def d(name):
            if name not in depth:
                depth[name] = 0 if not consumers[name] else 1 + max(d(c) for c in consumers[name])
            return depth[name]

        sys.setrecursionlimit(10000)
        columns = {}
        for n in self.nodes:
            columns.setdefault(d(n["name"]), []).append(n)
        for col, nodes in columns.items():
            heights = [node_height(n, self) for n in nodes]
            total = sum(heights) + 40 * (len(nodes) - 1)
            y = total / 2.0
            for n, h in zip(nodes, heights):
                n["location"] = [float(-col * (NODE_WIDTH + 60)), float(round(y))]
                y -= h + 40

    def to_json(self, as_group):
        self.layout()
        t = {}
        if as_group:
            t["inputs"] = self.inputs
            t["outputs"] = self.outputs
        t["nodes"] = self.nodes
        t["links"] = self.links
        return t


GROUPS = {}  # name -> Tree, in creation order


def node_height(n, tree):
    if n["type"] == "ShaderNodeGroup":
        g = GROUPS[n["group"]]
        return 80 + 24 * (len(g.inputs) + len(g.outputs))
    if n["type"] == "NodeGroupInput":
        return 60 + 24 * len(tree.inputs)
    if n["type"] == "NodeGroupOutput":
        return 60 + 24 * len(tree.outputs)
    return NODE_HEIGHT.get(n["type"], 200)


def new_group(name, inputs, outputs):
    assert name not in GROUPS
    g = Tree(name, inputs, outputs)
    GROUPS[name] = g
    if inputs:
        g.node("NodeGroupInput", "Group Input")
    g.node("NodeGroupOutput", "Group Output")
    return g


def fin(name, default=0.0, lo=0.0, hi=1.0):
    return {"name": name, "type": "FLOAT", "default": default, "min": lo, "max": hi}


def fout(name):
    return {"name": name, "type": "FLOAT"}


GI = "Group Input"
GO = "Group Output"

# ---- multiplexers -------------------------------------------------------------------


def hard_switch(n):
    """Hard N-way switch: Output = Input k, k = min(floor(Selector * N), N - 1), as a
    sum of products: Output = sum over k of Input k * (index == k). Only Math nodes, so
    a constant selector reduces exactly by x*1 = x, x*0 = 0 (finite x) and x+0 = x:
    inputs should come from nodes whose outputs are known finite (clamped Map Range,
    textures, ramps, clamped Math), which every switch input in this graph does."""
    name = "Hard Switch %d" % n
    if name in GROUPS:
        return GROUPS[name]
    g = new_group(name, [fin("Selector")] + [fin("Input %d" % k, 0.0, -1e4, 1e4) for k in range(n)],
                  [fout("Output")])
    g.math("Scale", "MULTIPLY", (GI, "Selector"), float(n), label="v * %d" % n)
    g.math("Floor", "FLOOR", ("Scale", "Value"))
    g.math("Index", "MINIMUM", ("Floor", "Value"), float(n - 1), label="min(floor(v*N), N-1)")
    total = None
    for k in range(n):
        is_k = g.node("ShaderNodeMath", "Is %d" % k, {"operation": "COMPARE"},
                      {"Value_001": float(k), "Value_002": 0.25}, label="index == %d" % k)
        g.link("Index", "Value", is_k, "Value")
        pick = g.math("Pick %d" % k, "MULTIPLY", (GI, "Input %d" % k), (is_k, "Value"))
        if total is None:
            total = (pick, "Value")
        else:
            total = (g.math("Sum %d" % k, "ADD", total, (pick, "Value")), "Value")
    g.link(total[0], total[1], GO, "Output")
    return g


def smooth_switch_color(n):
    """Smooth N-way colour switch: t = Selector * (N-1); Output = lerp(Color j,
    Color j+1, t - j) with j = floor(t), as a chain of Mix nodes with clamped factors
    t - (k-1)."""
    name = "Smooth Switch %d Color" % n
    if name in GROUPS:
        return GROUPS[name]
    g = new_group(name, [fin("Selector")] +
                  [{"name": "Color %d" % k, "type": "RGBA", "default": [0.5, 0.5, 0.5, 1.0]}
                   for k in range(n)],
                  [{"name": "Color", "type": "RGBA"}])
    g.math("Position", "MULTIPLY", (GI, "Selector"), float(n - 1), label="t = v * (N-1)")
    prev = (GI, "Color 0")
    for k in range(1, n):
        if k == 1:
            fac = ("Position", "Value")
        else:
            fac = (g.math("Past %d" % (k - 1), "SUBTRACT", ("Position", "Value"), float(k - 1),
                          label="t - %d" % (k - 1)), "Value")
        m = g.mix_color("Blend %d" % k, fac, prev, (GI, "Color %d" % k))
        prev = (m, "Result_Color")
    g.link(prev[0], prev[1], GO, "Color")
    return g


# ---- modules ------------------------------------------------------------------------

# The eleven patterns of the noise module: (label, Blender type; None for the two built
# from Math nodes). Each gives a value roughly in [0, 1]; the module renormalises with
# clamped Map Range nodes whose input ranges were measured over the plane with our
# evaluator at the parameter extremes (see assets/supershader.md).
NOISE_PATTERNS = [
    ("fBM", "FBM"), ("Ridged", "RIDGED_MULTIFRACTAL"), ("Hybrid", "HYBRID_MULTIFRACTAL"),
    ("Hetero terrain", "HETERO_TERRAIN"), ("Turbulent colour", "FBM_COLOR"),
    ("Cells F1", "F1"), ("Cells F2 - F1 creases", "F2"), ("Cell edges", "DISTANCE_TO_EDGE"),
    ("Cell colour (tiles)", "CELL_COLOR"),
    ("Bricks (tiles, planks)", None), ("Grain bands", None),
]
N_PATTERNS = len(NOISE_PATTERNS)


def noise_module():
    g = new_group("Noise Module",
                  [{"name": "Vector", "type": "VECTOR", "default": [0.0, 0.0, 0.0]},
                   fin("Pattern"), fin("Scale", 0.3), fin("Detail", 0.3), fin("Roughness", 0.5),
                   fin("Distortion")],
                  [fout("Value")])
    scale = g.param_range("Scale Range", (GI, "Scale"), 1.0, 14.0, label="Scale 1..14")
    cell_scale = g.param_range("Cell Scale Range", (GI, "Scale"), 1.5, 10.0, label="Cells 1.5..10")
    detail = g.param_range("Detail Range", (GI, "Detail"), 0.0, 8.0, label="Detail 0..8")
    rough = g.param_range("Roughness Range", (GI, "Roughness"), 0.35, 0.75, label="Roughness .35..75")
    dist = g.param_range("Distortion Range", (GI, "Distortion"), 0.0, 1.5, label="Distortion 0..1.5")
    rnd = g.param_range("Randomness Range", (GI, "Distortion"), 1.0, 0.5, label="Randomness 1..0.5")
    vec = (GI, "Vector")
    outs = []

    def noise(name, ntype, **extra):
        inputs = dict(extra)
        n = g.node("ShaderNodeTexNoise", name, {"noise_type": ntype}, inputs or None)
        g.link(vec[0], vec[1], n, "Vector")
        g.link(scale[0], scale[1], n, "Scale")
        g.link(detail[0], detail[1], n, "Detail")
        g.link(rough[0], rough[1], n, "Roughness")
        # Blender 3.x builds the multifractal types as Musgrave nodes, which have no
        # Distortion: leaving it at 0 keeps every extracted sub-shader buildable there.
        if ntype == "FBM":
            g.link(dist[0], dist[1], n, "Distortion")
        return n

    def voronoi(name, feature):
        n = g.node("ShaderNodeTexVoronoi", name, {"feature": feature} if feature != "F1" else None)
        g.link(vec[0], vec[1], n, "Vector")
        g.link(cell_scale[0], cell_scale[1], n, "Scale")
        g.link(rnd[0], rnd[1], n, "Randomness")
        return n

    def norm(k, src, lo, hi, interpolation="LINEAR"):
        label, _ = NOISE_PATTERNS[k]
        return (g.map_range("Normalize %d" % k, src, 0.0, 1.0, lo, hi, interpolation,
                            label="%s -> 0..1" % label), "Result")

    n0 = noise("fBM", "FBM")
    outs.append(norm(0, (n0, "Fac"), 0.25, 0.75))
    # The multifractal types are not normalised by Blender: their range grows with the
    # octaves' total weight M = 1 + r + ... + r^detail = (1 - r^(detail+1)) / (1 - r).
    # Windows below are fractions of M measured over the plane (p1..p99 at the
    # extremes of Detail and Roughness).
    octaves = g.math("Octaves", "ADD", detail, 1.0, label="detail + 1")
    rpow = g.math("Last Weight", "POWER", rough, (octaves, "Value"), label="r^(detail+1)")
    num = g.math("Weight Numerator", "SUBTRACT", 1.0, (rpow, "Value"))
    den = g.math("Weight Denominator", "SUBTRACT", 1.0, rough)
    total = g.math("Octave Weight", "DIVIDE", (num, "Value"), (den, "Value"), label="M")

    def of_total(name, f):
        return (g.math(name, "MULTIPLY", (total, "Value"), f, label="%.2f M" % f), "Value")

    n1 = noise("Ridged", "RIDGED_MULTIFRACTAL", Offset=1.0, Gain=2.0)
    outs.append(norm(1, (n1, "Fac"), of_total("Ridged Low", 0.2), of_total("Ridged High", 0.95)))
    n2 = noise("Hybrid", "HYBRID_MULTIFRACTAL", Offset=0.8, Gain=1.0)
    outs.append(norm(2, (n2, "Fac"), of_total("Hybrid Low", 0.15), of_total("Hybrid High", 0.9)))
    n3 = noise("Hetero Terrain", "HETERO_TERRAIN", Offset=0.6)
    outs.append(norm(3, (n3, "Fac"), 0.0, of_total("Hetero High", 1.3)))
    n4 = noise("Turbulent Colour", "FBM")
    sep = g.node("ShaderNodeSeparateColor", "Colour Channels")
    g.link(n4, "Color", sep, "Color")
    turb = g.math("Channel Difference", "SUBTRACT", (sep, "Red"), (sep, "Blue"))
    absd = g.math("Turbulence", "ABSOLUTE", (turb, "Value"))
    outs.append(norm(4, (absd, "Value"), 0.0, 0.3))
    v5 = voronoi("Cells F1", "F1")
    outs.append(norm(5, (v5, "Distance"), 0.1, 0.9))
    v6a = voronoi("Cells F2", "F2")
    v6b = g.math("F2 - F1", "SUBTRACT", (v6a, "Distance"), (v5, "Distance"))
    outs.append(norm(6, (v6b, "Value"), 0.0, 0.6))
    v7 = voronoi("Cell Edges", "DISTANCE_TO_EDGE")
    outs.append(norm(7, (v7, "Distance"), 0.0, 0.3, "SMOOTHSTEP"))
    v8 = voronoi("Cell Colour", "F1")  # its Color: one random colour per cell
    outs.append(norm(8, (v8, "Color"), 0.0, 1.0))
    axes = g.node("ShaderNodeSeparateXYZ", "Axes")
    g.link(vec[0], vec[1], axes, "Vector")
    outs.append(norm(9, bricks(g, axes, cell_scale), 0.0, 1.0))
    outs.append(norm(10, grain_bands(g, axes, vec, detail, rough), -1.0, 1.0))
    sw = hard_switch(N_PATTERNS)
    s = g.group_node("Pattern Switch", sw, label="Mult %d: pattern" % N_PATTERNS)
    g.link(GI, "Pattern", s, "Selector")
    for k, o in enumerate(outs):
        g.link(o[0], o[1], s, "Input %d" % k)
    g.link(s, "Output", GO, "Value")
    return g


def bricks(g, axes, rows):
    """Courses of bricks along X from Math nodes, as a Blender user builds them without
    the Brick Texture node (every node here is one the evaluator and the extractor
    already prove): rows per unit from the cell Scale, brick width / height from
    Roughness (1 square tiles .. 6 planks), odd rows shifted by Detail (0 stacked .. half
    a brick: running bond), mortar half-width from Distortion. Returns mortar 0, each
    brick a value 0.4..1 of its own (a White Noise of its column and row).
    Ping-pong with scale 0.5 is the distance to the nearest integer, with scale 1 an
    integer's parity: three nodes each in place of fract / subtract / minimum. Once the
    parameters are bound, the ranges and the ratio rows / aspect fold to constants."""
    aspect = g.param_range("Brick Aspect", (GI, "Roughness"), 1.0, 6.0, label="width / height 1..6")
    across = g.math("Bricks A Unit", "DIVIDE", rows, aspect, label="rows / aspect")
    v = g.math("Course Coordinate", "MULTIPLY", (axes, "Y"), rows, label="y * rows")
    u = g.math("Brick Coordinate", "MULTIPLY", (axes, "X"), (across, "Value"))
    row = g.math("Course", "FLOOR", (v, "Value"))
    odd = g.math("Odd Course", "PINGPONG", (row, "Value"), 1.0, label="0 even, 1 odd")
    half = g.math("Course Shift", "MULTIPLY", (GI, "Detail"), 0.5, label="0..half a brick")
    us = g.node("ShaderNodeMath", "Shifted Brick Coordinate", {"operation": "MULTIPLY_ADD"})
    g.link(odd, "Value", us, "Value")
    g.link(half, "Value", us, "Value_001")
    g.link(u, "Value", us, "Value_002")
    col = g.math("Brick Column", "FLOOR", (us, "Value"))
    du = g.math("Side Distance", "PINGPONG", (us, "Value"), 0.5, label="to the nearest head joint")
    dus = g.math("Side Distance In Rows", "MULTIPLY", (du, "Value"), aspect)
    dv = g.math("Bed Distance", "PINGPONG", (v, "Value"), 0.5, label="to the nearest bed joint")
    d = g.math("Edge Distance", "MINIMUM", (dus, "Value"), (dv, "Value"),
               label="to the nearest joint, in rows")
    w = g.param_range("Mortar Width", (GI, "Distortion"), 0.02, 0.15, label="mortar 0.02..0.15")
    w2 = g.math("Mortar Edge", "ADD", w, 0.04)
    face = g.map_range("Brick Face", (d, "Value"), 0.0, 1.0, w, (w2, "Value"), "SMOOTHSTEP",
                       label="0 mortar, 1 brick")
    cell = g.node("ShaderNodeCombineXYZ", "Brick Cell")
    g.link(col, "Value", cell, "X")
    g.link(row, "Value", cell, "Y")
    rnd = g.node("ShaderNodeTexWhiteNoise", "Brick Shade")
    g.link(cell, "Vector", rnd, "Vector")
    shade = g.node("ShaderNodeMath", "Brick Value", {"operation": "MULTIPLY_ADD"},
                   {"Value_001": 0.6, "Value_002": 0.4}, label="0.4..1")
    g.link(rnd, "Value", shade, "Value")
    return (g.math("Bricks", "MULTIPLY", (face, "Result"), (shade, "Value")), "Value")


def grain_bands(g, axes, vec, detail, rough):
    """Bands along X, as Blender's Wave Texture draws them (sine bands, the phase
    distorted by an fBM) but from Noise and Math nodes: sin(y * frequency + distortion *
    fBM), frequency from Scale (2..28 bands across the plane), the fBM's Detail and
    Roughness the module's, its amplitude from Distortion (up to 3 bands; the fBM's mean
    only shifts the bands, as Pattern Offset does). Returns a value in [-1, 1]."""
    two_pi = 2.0 * math.pi
    freq = g.param_range("Band Frequency", (GI, "Scale"), 1.0 * two_pi, 14.0 * two_pi,
                         label="1..14 bands a unit (radians)")
    amp = g.param_range("Band Distortion", (GI, "Distortion"), 0.0, 6.0 * two_pi,
                        label="0..3 bands (radians, fBM spans about 0.5)")
    n = g.node("ShaderNodeTexNoise", "Band Noise", {"noise_type": "FBM"}, {"Scale": 2.0})
    g.link(vec[0], vec[1], n, "Vector")
    g.link(detail[0], detail[1], n, "Detail")
    g.link(rough[0], rough[1], n, "Roughness")
    y = g.math("Band Phase", "MULTIPLY", (axes, "Y"), freq)
    phase = g.node("ShaderNodeMath", "Distorted Phase", {"operation": "MULTIPLY_ADD"})
    g.link(n, "Fac", phase, "Value")
    g.link(amp[0], amp[1], phase, "Value_001")
    g.link(y, "Value", phase, "Value_002")
    return (g.math("Grain", "SINE", (phase, "Value")), "Value")


MATH_OPS = ["ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MINIMUM", "MAXIMUM"]


def math_module():
    """A (op) B for two signals in [0, 1], renormalised to [0, 1] per operation."""
    g = new_group("Math Module", [fin("A", 0.5), fin("B", 0.5), fin("Operation")], [fout("Value")])
    # Range of each op on [0,1]^2 and the window mapped back to [0,1].
    windows = {"ADD": (0.3, 1.7), "SUBTRACT": (-0.7, 0.7), "MULTIPLY": (0.0, 0.6),
               "DIVIDE": (0.0, 2.5), "MINIMUM": None, "MAXIMUM": None}
    outs = []
    for k, op in enumerate(MATH_OPS):
        # Minimum and maximum of values in [0, 1] stay there: clamping changes nothing
        # but says so (the extraction treats clamped results as finite).
        m = g.math(op.title(), op, (GI, "A"), (GI, "B"), clamp=op in ("MINIMUM", "MAXIMUM"))
        w = windows[op]
        if w:
            outs.append((g.map_range("Normalize " + op.title(), (m, "Value"), 0.0, 1.0, w[0], w[1],
                                     label="%s -> 0..1" % op.lower()), "Result"))
        else:
            outs.append((m, "Value"))
    s = g.group_node("Operation Switch", hard_switch(6), label="Mult 6: operation")
    g.link(GI, "Operation", s, "Selector")
    for k, o in enumerate(outs):
        g.link(o[0], o[1], s, "Input %d" % k)
    g.link(s, "Output", GO, "Value")
    return g


def value_mapping_module():
    """Shapes a signal in [0,1]: window [Low, High] then linear / smootherstep /
    stepped (terraces) / ridge (a Color Ramp folding the window: 0 -> 1 -> 0)."""
    g = new_group("Value Mapping", [fin("Value", 0.5), fin("Mode"), fin("Low", 0.0), fin("High", 1.0)],
                  [fout("Value")])
    lo = g.param_range("Low Range", (GI, "Low"), 0.0, 0.45, label="low 0..0.45")
    hi = g.param_range("High Range", (GI, "High"), 0.55, 1.0, label="high 0.55..1")
    outs = []
    lin = g.map_range("Linear", (GI, "Value"), 0.0, 1.0, lo, hi)
    outs.append((lin, "Result"))
    smo = g.map_range("Smootherstep", (GI, "Value"), 0.0, 1.0, lo, hi,
                      "SMOOTHERSTEP")
    outs.append((smo, "Result"))
    ste = g.map_range("Terraces", (GI, "Value"), 0.0, 1.0, lo, hi,
                      "STEPPED", steps=4.0)
    outs.append((ste, "Result"))
    ramp = g.node("ShaderNodeValToRGB", "Ridge Ramp", ramp={
        "interpolation": "EASE", "color_mode": "RGB", "hue_interpolation": "NEAR",
        "elements": [{"position": 0.0, "color": [0.0, 0.0, 0.0, 0.0]},
                     {"position": 0.5, "color": [1.0, 1.0, 1.0, 1.0]},
                     {"position": 1.0, "color": [0.0, 0.0, 0.0, 0.0]}]})
    g.link(lin, "Result", ramp, "Fac")
    # Alpha carries the same ridge as a float (no colour-to-float conversion).
    outs.append((ramp, "Alpha"))
    s = g.group_node("Mode Switch", hard_switch(4), label="Mult 4: mapping")
    g.link(GI, "Mode", s, "Selector")
    for k, o in enumerate(outs):
        g.link(o[0], o[1], s, "Input %d" % k)
    g.link(s, "Output", GO, "Value")
    return g


# Hues of real surfaces (stone, earth, wood, rust, brick, slate, patina, plastics),
# as a Color Ramp the Hue parameter walks along: uniform hue over the whole circle
# gives mostly implausible greens and purples. Leaf green and blue are the two vivid
# entries (HSV saturation 0.84 and 0.81, the others 0.16-0.84): without them grass,
# plants and blue paint were out of reach (EVALUATION.md, session 20: the grass photo's
# mean saturation is 0.82, moss and olive reached 0.6 at most).
PALETTE_COLOURS = [
    ((0.50, 0.46, 0.42), "warm grey"), ((0.76, 0.62, 0.44), "sand"),
    ((0.80, 0.56, 0.22), "ochre"), ((0.72, 0.32, 0.10), "rust"),
    ((0.62, 0.16, 0.10), "brick"), ((0.42, 0.26, 0.15), "brown"),
    ((0.46, 0.45, 0.22), "olive"), ((0.26, 0.42, 0.22), "moss"),
    ((0.24, 0.50, 0.08), "leaf green"), ((0.26, 0.31, 0.46), "slate"),
    ((0.12, 0.26, 0.62), "blue"), ((0.15, 0.42, 0.46), "patina"),
    ((0.42, 0.20, 0.36), "plum"),
]
# (position, linear RGB, name): evenly spaced stops from 0 to 1.
PALETTE = [(k / (len(PALETTE_COLOURS) - 1), c, name) for k, (c, name) in enumerate(PALETTE_COLOURS)]
PALETTE_NAMES = ", ".join(name for _, _, name in PALETTE)


def hsv_color_module():
    """A colour from three parameters: Hue picks a hue from PALETTE, Saturation scales
    the palette's saturation (squared: most materials muted, a few vivid), Value is
    mapped to [Value Min, Value Max]; ranges are inputs so one group serves the two
    pattern colours and the accent."""
    g = new_group("Parameter Colour",
                  [fin("Hue"), fin("Saturation"), fin("Value"),
                   fin("Saturation Max", 1.0), fin("Value Min", 0.0), fin("Value Max", 1.0)],
                  [{"name": "Color", "type": "RGBA"}])
    ramp = g.node("ShaderNodeValToRGB", "Palette", ramp={
        "interpolation": "LINEAR", "color_mode": "RGB", "hue_interpolation": "NEAR",
        "elements": [{"position": pos, "color": list(c) + [1.0]} for pos, c, _ in PALETTE]})
    g.link(GI, "Hue", ramp, "Fac")
    hsv = g.node("ShaderNodeSeparateColor", "Palette HSV", {"mode": "HSV"})
    g.link(ramp, "Color", hsv, "Color")
    sat = g.math("Saturation Range", "MULTIPLY", (GI, "Saturation"), (GI, "Saturation Max"))
    sq = g.math("Mostly Muted", "MULTIPLY", (sat, "Value"), (GI, "Saturation"))
    amt = g.math("Saturation", "MULTIPLY", (sq, "Value"), (hsv, "Green"), clamp=True)
    val = g.param_range("Value Range", (GI, "Value"), (GI, "Value Min"), (GI, "Value Max"))
    c = g.node("ShaderNodeCombineColor", "HSV", {"mode": "HSV"})
    g.link(hsv, "Red", c, "Red")
    g.link(amt, "Value", c, "Green")
    g.link(val[0], val[1], c, "Blue")
    g.link(c, "Color", GO, "Color")
    return g


# ---- the 50 parameters --------------------------------------------------------------
# (name, module, what it does, range after mapping / choices). The order is the
# order of RandomValues' outputs, hence of sampling (shadergraph/params.c).
PATTERN_CHOICES = ", ".join("%d %s" % (k, p[0]) for k, p in enumerate(NOISE_PATTERNS))
OP_CHOICES = ", ".join("%d %s" % (k, o.lower()) for k, o in enumerate(MATH_OPS))
MAP_CHOICES = "0 linear, 1 smootherstep, 2 terraces (4 steps), 3 ridge (0-1-0 ramp)"


def noise_params(letter):
    return [
        ("Mult %d Noise %s Pattern" % (N_PATTERNS, letter), "Noise %s" % letter, "pattern",
         PATTERN_CHOICES),
        ("Noise %s Scale" % letter, "Noise %s" % letter, "feature scale",
         "Scale 1..14 (noise), 1.5..10 (cells)"),
        ("Noise %s Detail" % letter, "Noise %s" % letter, "octaves", "Detail 0..8"),
        ("Noise %s Roughness" % letter, "Noise %s" % letter, "octave falloff", "Roughness 0.35..0.75"),
        ("Noise %s Distortion" % letter, "Noise %s" % letter,
         "noise distortion / cell jitter",
         "Distortion 0..1.5 (fBM patterns); cell Randomness 1..0.5"),
    ]


PARAMS = (noise_params("A") + noise_params("B") + noise_params("C") + [
    ("Pattern Offset", "Coordinates", "moves all patterns (a seed)", "offset 0..100 on X and Y"),
    ("Warp Amount", "Coordinates", "domain warp by a fixed fBM", "0..0.5 (squared)"),
    ("Mult 6 Structure Operation", "Math: Structure", "Structure = A (op) B", OP_CHOICES),
    ("Mult 6 Detail Operation", "Math: Detail", "Detail = Structure (op) C", OP_CHOICES),
    ("Mult 3 Color Source", "Colour", "signal that drives colour",
     "0 Structure, 1 Detail, 2 Noise B"),
    ("Mult 4 Color Mapping", "Colour mapping", "shape of the colour signal", MAP_CHOICES),
    ("Color Mapping Low", "Colour mapping", "window start", "0..0.45"),
    ("Color Mapping High", "Colour mapping", "window end", "0.55..1"),
    ("Color 1 Hue", "Colour", "hue on the pattern's low side", "palette hue (" + PALETTE_NAMES + ")"),
    ("Color 1 Saturation", "Colour", "saturation on the low side", "palette saturation x 0..1.3 x parameter"),
    ("Color 1 Value", "Colour", "value on the low side", "0.02..0.95"),
    ("Color 2 Hue", "Colour", "hue on the pattern's high side", "palette hue (" + PALETTE_NAMES + ")"),
    ("Color 2 Saturation", "Colour", "saturation on the high side", "palette saturation x 0..1 x parameter"),
    ("Color 2 Value", "Colour", "value on the high side", "0.02..0.95"),
    ("Accent Hue", "Colour", "accent (spots, rust) hue", "palette hue (" + PALETTE_NAMES + ")"),
    ("Accent Saturation", "Colour", "accent saturation", "palette saturation x 0..1.5 x parameter"),
    ("Accent Value", "Colour", "accent value", "0.05..0.8"),
    ("Accent Coverage", "Colour", "share of the surface under accent spots",
     "threshold on Noise C, 0.85..0.15"),
    ("Grime Amount", "Colour", "darkening by Noise C", "factor 0..1"),
    ("Overlay Strength", "Colour", "Detail overlaid on the colour", "factor 0..1"),
    ("Mult 4 Color Layer", "Colour (smooth switch)", "colour layer, interpolated",
     "t = v*3 between 0 two-tone, 1 grime, 2 accent spots, 3 detail overlay"),
    ("Mult 4 Metal Mode", "Metallic", "metalness",
     "0 dielectric, 1 metal, 2 metal except under accent spots (rust), "
     "3 dielectric with metal under accent spots (inlays, flakes)"),
    ("Mult 3 Roughness Source", "Roughness", "signal that drives roughness",
     "0 Detail, 1 Noise C, 2 colour signal"),
    ("Mult 4 Roughness Mapping", "Roughness mapping", "shape of the roughness signal", MAP_CHOICES),
    ("Roughness Mapping Low", "Roughness mapping", "window start", "0..0.45"),
    ("Roughness Mapping High", "Roughness mapping", "window end", "0.55..1"),
    ("Roughness Base", "Roughness", "lowest roughness", "0.05..0.8"),
    ("Roughness Variation", "Roughness", "roughness added by the signal", "0..0.6, clamped to 1"),
    ("Mult 3 Bump Source", "Normal", "signal that drives height",
     "0 Structure, 1 Detail, 2 colour signal"),
    ("Mult 4 Bump Mapping", "Height mapping", "shape of the height signal", MAP_CHOICES),
    ("Bump Mapping Low", "Height mapping", "window start", "0..0.45"),
    ("Bump Mapping High", "Height mapping", "window end", "0.55..1"),
    ("Mult 2 Bump Invert", "Normal", "invert height", "0 as is, 1 inverted (1 - h)"),
    ("Bump Strength", "Normal", "Bump Strength", "0.05..1"),
    ("Bump Distance", "Normal", "Bump Distance", "0.002..0.05"),
])
assert len(PARAMS) == 50, len(PARAMS)
assert len({p[0] for p in PARAMS}) == 50

# Default values written into the asset: a pleasant stone, so that the plain asset
# renders something sensible before any parameters are bound.
def _bin_centre(k, n):
    return round((k + 0.5) / n, 3)


# fBM for A and C, Cells F1 for B (the selector at its bin centre).
DEFAULTS = {"Mult %d Noise A Pattern" % N_PATTERNS: _bin_centre(0, N_PATTERNS),
            "Mult %d Noise B Pattern" % N_PATTERNS: _bin_centre(5, N_PATTERNS),
            "Mult %d Noise C Pattern" % N_PATTERNS: _bin_centre(0, N_PATTERNS)}


def random_values():
    g = new_group("RandomValues", [], [
        {"name": p[0], "type": "FLOAT", "default": DEFAULTS.get(p[0], 0.5), "min": 0.0, "max": 1.0}
        for p in PARAMS])
    for p in PARAMS:
        g.node("ShaderNodeValue", p[0], outputs={"Value": DEFAULTS.get(p[0], 0.5)})
        g.link(p[0], "Value", GO, p[0])
    return g


def build():
    rv = random_values()
    nm, mm, vm, pc = noise_module(), math_module(), value_mapping_module(), hsv_color_module()
    ss = smooth_switch_color(4)
    t = Tree("Super Shader")
    P = t.group_node("RandomValues", rv, label="Parameters")

    def p(name):
        assert any(q[0] == name for q in PARAMS), name
        return (P, name)

    # Coordinates: object space (the plane spans -1..1), shifted by Pattern Offset and
    # warped by a fixed fBM (marble-like swirls when Warp Amount is high).
    tc = t.node("ShaderNodeTexCoord", "Texture Coordinate")
    off = t.param_range("Offset Range", p("Pattern Offset"), 0.0, 100.0, label="offset 0..100")
    offv = t.node("ShaderNodeCombineXYZ", "Offset Vector")
    t.link(off[0], off[1], offv, "X")
    t.link(off[0], off[1], offv, "Y")
    shifted = t.node("ShaderNodeVectorMath", "Shift", {"operation": "ADD"})
    t.link(tc, "Object", shifted, "Vector")
    t.link(offv, "Vector", shifted, "Vector_001")
    warpn = t.node("ShaderNodeTexNoise", "Warp Noise", inputs={"Scale": 1.5, "Detail": 3.0})
    t.link(shifted, "Vector", warpn, "Vector")
    # coords = shifted + amount * warp colour: one node. The warp colour's mean (0.5)
    # only translates every pattern by a constant, as Pattern Offset does.
    wsq = t.math("Warp Squared", "MULTIPLY", p("Warp Amount"), p("Warp Amount"))
    wamt = t.param_range("Warp Range", (wsq, "Value"), 0.0, 0.5, label="warp 0..0.5")
    coords = t.node("ShaderNodeVectorMath", "Warped Coordinates", {"operation": "MULTIPLY_ADD"})
    t.link(warpn, "Color", coords, "Vector")
    t.link(wamt[0], wamt[1], coords, "Vector_001")
    t.link(shifted, "Vector", coords, "Vector_002")

    # Three noise modules on the same coordinates: Pattern Offset (up to 100) times
    # their different scales keeps them apart.
    signals = {}
    for letter in "ABC":
        src = (coords, "Vector")
        m = t.group_node("Noise %s" % letter, nm)
        t.link(src[0], src[1], m, "Vector")
        for sock, pn in (("Pattern", "Mult %d Noise %%s Pattern" % N_PATTERNS), ("Scale", "Noise %s Scale"),
                         ("Detail", "Noise %s Detail"), ("Roughness", "Noise %s Roughness"),
                         ("Distortion", "Noise %s Distortion")):
            t.link(P, pn % letter, m, sock)
        signals[letter] = (m, "Value")

    st = t.group_node("Structure", mm)
    t.link(*signals["A"], st, "A")
    t.link(*signals["B"], st, "B")
    t.link(P, "Mult 6 Structure Operation", st, "Operation")
    de = t.group_node("Detail", mm)
    t.link(st, "Value", de, "A")
    t.link(*signals["C"], de, "B")
    t.link(P, "Mult 6 Detail Operation", de, "Operation")

    def switch3(name, selector, inputs):
        s = t.group_node(name, hard_switch(3))
        t.link(P, selector, s, "Selector")
        for k, src in enumerate(inputs):
            t.link(src[0], src[1], s, "Input %d" % k)
        return (s, "Output")

    def mapping(name, src, prefix):
        m = t.group_node(name, vm)
        t.link(src[0], src[1], m, "Value")
        t.link(P, "Mult 4 %s Mapping" % prefix, m, "Mode")
        t.link(P, "%s Mapping Low" % prefix, m, "Low")
        t.link(P, "%s Mapping High" % prefix, m, "High")
        return (m, "Value")

    # Colour.
    csrc = switch3("Color Source", "Mult 3 Color Source", [(st, "Value"), (de, "Value"), signals["B"]])
    cfac = mapping("Color Mapping", csrc, "Color")

    def colour(name, prefix, sat_max, vmin, vmax):
        c = t.group_node(name, pc, inputs={"Saturation Max": sat_max, "Value Min": vmin,
                                           "Value Max": vmax})
        t.link(P, prefix + " Hue", c, "Hue")
        t.link(P, prefix + " Saturation", c, "Saturation")
        t.link(P, prefix + " Value", c, "Value")
        return (c, "Color")

    # The two pattern colours share one value range, so either side can be the darker:
    # dark bricks in pale mortar as well as pale stones in dark joints (session 32; with
    # Color 1 at 0.02..0.45 and Color 2 at 0.3..0.95 the pattern's low side was always the
    # darker, and no mapping mode inverts the signal).
    c1 = colour("Color 1", "Color 1", 1.3, 0.02, 0.95)
    c2 = colour("Color 2", "Color 2", 1.0, 0.02, 0.95)
    c3 = colour("Accent Color", "Accent", 1.5, 0.05, 0.8)
    two_tone = t.mix_color("Two-tone", cfac, c1, c2)
    # On a varying signal (never folded), so one Multiply Add node.
    grime = t.node("ShaderNodeMath", "Grime Shade", {"operation": "MULTIPLY_ADD"},
                   {"Value_001": 0.85, "Value_002": 0.15}, label="grime 0.15..1")
    t.link(signals["C"][0], signals["C"][1], grime, "Value")
    grime_sig = (grime, "Value")
    grime = t.mix_color("Grime", p("Grime Amount"), (two_tone, "Result_Color"),
                        grime_sig, "MULTIPLY")
    thr = t.param_range("Accent Threshold", p("Accent Coverage"), 0.85, 0.15)
    thr2 = t.math("Accent Edge", "ADD", thr, 0.08)
    mask = t.map_range("Accent Mask", signals["C"], 0.0, 1.0, thr, (thr2, "Value"),
                       "SMOOTHSTEP")
    accent = t.mix_color("Accent Spots", (mask, "Result"), (grime, "Result_Color"), c3)
    overlay = t.mix_color("Detail Overlay", p("Overlay Strength"), (accent, "Result_Color"),
                          (de, "Value"), "OVERLAY", clamp_result=True)
    layer = t.group_node("Color Layer", ss, label="Mult 4 (smooth): colour layer")
    t.link(P, "Mult 4 Color Layer", layer, "Selector")
    for k, src in enumerate([(two_tone, "Result_Color"), (grime, "Result_Color"),
                             (accent, "Result_Color"), (overlay, "Result_Color")]):
        t.link(src[0], src[1], layer, "Color %d" % k)

    # Metallic: dielectric, metal, metal except under the accent (rust on steel), or
    # metal only under the accent (inlays, flakes).
    bare = t.math("Bare Metal", "SUBTRACT", 1.0, (mask, "Result"), clamp=True)
    metal = t.group_node("Metal Mode", hard_switch(4), inputs={"Input 0": 0.0, "Input 1": 1.0})
    t.link(P, "Mult 4 Metal Mode", metal, "Selector")
    t.link(bare, "Value", metal, "Input 2")
    t.link(mask, "Result", metal, "Input 3")

    # Roughness.
    rsrc = switch3("Roughness Source", "Mult 3 Roughness Source", [(de, "Value"), signals["C"], csrc])
    rsig = mapping("Roughness Mapping", rsrc, "Roughness")
    rbase = t.param_range("Roughness Base Range", p("Roughness Base"), 0.05, 0.8)
    rvar = t.param_range("Roughness Variation Range", p("Roughness Variation"), 0.0, 0.6)
    rtop = t.math("Roughness Top", "ADD", rbase, rvar, clamp=True)
    rough = t.map_range("Roughness", rsig, rbase, (rtop, "Value"))

    # Height -> Bump.
    hsrc = switch3("Bump Source", "Mult 3 Bump Source", [(st, "Value"), (de, "Value"), csrc])
    hsig = mapping("Bump Mapping", hsrc, "Bump")
    inv = t.math("Inverted Height", "SUBTRACT", 1.0, hsig, clamp=True)
    hsw = t.group_node("Bump Invert", hard_switch(2))
    t.link(P, "Mult 2 Bump Invert", hsw, "Selector")
    t.link(*hsig, hsw, "Input 0")
    t.link(inv, "Value", hsw, "Input 1")
    bstr = t.param_range("Bump Strength Range", p("Bump Strength"), 0.05, 1.0)
    bdist = t.param_range("Bump Distance Range", p("Bump Distance"), 0.002, 0.05)
    bump = t.node("ShaderNodeBump", "Bump")
    t.link(hsw, "Output", bump, "Height")
    t.link(bstr[0], bstr[1], bump, "Strength")
    t.link(bdist[0], bdist[1], bump, "Distance")

    bsdf = t.node("ShaderNodeBsdfPrincipled", "Principled BSDF")
    t.link(layer, "Color", bsdf, "Base Color")
    t.link(metal, "Output", bsdf, "Metallic")
    t.link(rough, "Result", bsdf, "Roughness")
    t.link(bump, "Normal", bsdf, "Normal")
    out = t.node("ShaderNodeOutputMaterial", "Material Output")
    t.link(bsdf, "BSDF", out, "Surface")
    return t


def count_nodes(tree, groups):
    """(count with groups expanded, count after ungrouping) for `tree`. Expanded: every
    node, a group node replaced by its group's nodes (Group Input and Group Output
    included), recursively, once per instance; this is sg_graph_node_count's count.
    Ungrouped: Group Input/Output nodes gone too, as after Blender's Ungroup."""
    shown = ungrouped = 0
    for n in tree.nodes:
        if n["type"] == "ShaderNodeGroup":
            s, u = count_nodes(groups[n["group"]], groups)
            shown += s
            ungrouped += u
        else:
            shown += 1
            ungrouped += n["type"] not in ("NodeGroupInput", "NodeGroupOutput")
    return shown, ungrouped


MARKDOWN = """# The super-shader

`assets/supershader.json` (format `imsynth-graph/1`, Blender 4.x vocabulary) is the
material every training sample is made from. It is written by
`assets/generate_supershader.py` (plain Python 3: `python3 assets/generate_supershader.py`);
change the generator, not the JSON. The thesis's own super-shader is lost (only a Git LFS
pointer survives), so this one follows its description (thesis.md 5.1, 5.1.1).

**Size.** {shown} nodes, counted with every group expanded in place: each node of the
material tree, a group node replaced by the nodes of its group (Group Input and Group
Output included), recursively, once per group instance (`sg_graph_node_count`). After
Blender's *Ungroup* (group input/output nodes gone too) {ungrouped} remain.
The thesis's super-shader had 507. Groups, with their instance counts: {groups}.

**Parameters.** 50 floats in [0, 1], the outputs of the group `RandomValues` (no inputs;
each output is fed by a Value node of the same name: binding a parameter set means setting
those Value nodes, `sg_graph_bind_params` in `shadergraph/params.c`). Every mapping to a
node's own range is done by nodes inside the graph (Map Range, Math). `Mult N ...` names
are N-way multiplexer selectors. `imsynth sample --seed N` prints frame N's set: seeded
with N, uniform, rounded to 3 decimals, selectors moved to their bin centre
`min((floor(u*N) + 0.5) / N, 1)`. The generator is SplitMix64, not Python's Mersenne
Twister, so frame N here is not the thesis's frame N (reproducing MT19937 and CPython's
float conversion bit for bit was not worth it: the thesis's renders are lost too).

**Modules** (node groups, as a Blender user would build them):
- *Noise Module* (3 instances, A, B, C): eleven patterns behind a hard 11-way switch:
  {patterns}. Scale, Detail, Roughness and Distortion shape them (Distortion also sets the
  cells' Randomness). The last two are built from Math nodes (no Brick or Wave Texture
  node, so every node is one the evaluator already proves against Blender): *bricks*
  (courses along X; Scale sets the rows, Roughness the width / height 1..6 from square
  tiles to planks, Detail the odd rows' shift up to half a brick, Distortion the mortar;
  each brick a White Noise shade of its column and row) and *grain bands* (Blender's
  Wave Texture's sine bands along X, their phase distorted by an fBM whose Detail and
  Roughness are the module's: wood grain, strata). Each pattern is renormalised to about [0, 1] by a clamped Map Range
  whose input window was measured over the plane with our evaluator at the extremes of
  Detail and Roughness; the multifractal types, which Blender does not normalise, use
  windows proportional to their total octave weight M = (1 - r^(detail+1)) / (1 - r),
  computed by Math nodes in the module.
- *Math Module* (2 instances): A (op) B with op in {ops}, renormalised per operation.
  Structure = A (op) B; Detail = Structure (op) C.
- *Value Mapping* (3 instances: colour, roughness, height): a window [Low, High] of the
  signal, then linear, smootherstep, terraces (stepped Map Range) or a ridge (Color Ramp
  0 -> 1 -> 0), chosen by a hard 4-way switch.
- *Parameter Colour* (3 instances: the pattern's low and high sides, accent): Hue walks a Color Ramp of real
  surface hues ({palette}); saturation is the palette's, scaled by the parameter squared
  (most materials muted, a few vivid); value is mapped per colour.
- *Hard Switch N* (N = 2, 3, 4, 6, 11): `index = min(floor(v*N), N-1)`, then
  `sum_k Input k * (index == k)`, Math nodes only (Compare, Multiply, Add). For a bound
  selector the extraction reduces it exactly (x*1 = x, x*0 = 0 for finite x, x+0 = x), so
  every switch input comes from a node whose output is known finite (a clamped Map Range
  or Math node, a texture, a ramp).
- *Smooth Switch 4 Color*: `t = v*3`; a chain of colour Mix nodes with clamped factors
  `t - (k-1)` gives `lerp(Color j, Color j+1, t - j)`, j = floor(t). With selectors at bin
  centres (t = 0.375, 1.125, 1.875, 2.625) every choice is a blend of two neighbouring
  layers.

**Maps.** The three noise signals drive all four maps of the Principled BSDF, so colour,
shine and relief agree: Base Color = colour layer (two-tone by the colour signal; times a
grime shade from Noise C; accent spots where Noise C passes a threshold; Detail overlaid)
through the smooth switch; Metallic = dielectric, metal, metal except under the accent
spots (rust), or metal only under them (inlays, flakes); Roughness = base + variation x
a mapped signal; Normal = Bump of a mapped (optionally inverted) height. Coordinates are
Object coordinates (the plane spans -1..1) shifted by Pattern Offset and domain-warped by
a fixed fBM.

**Blender.** The JSON builds in Blender 4.3 (`blender/import_material.py`, checked).
Blender 3.4 cannot build the super-shader itself: its Musgrave node (which the 4.x
Ridged / Hybrid / Hetero noise types become) computes Detail and Dimension from
constants, and the importer cannot translate a linked Detail or Roughness. A sub-shader
extracted for a parameter set has those inputs constant (and Distortion, which Musgrave
lacks, is never used by those types here), so sub-shaders are the thing to open in 3.4.

**Checked** (when this design was committed): the round-trip references
(`tests/reference/nodes/gen_roundtrip.py`, frames 0-10, 19 and 23: the whole super-shader
in Blender 4.3 and its sub-shader in 3.4 and 4.3, point-sampled through Emission at
128 x 128) equal our evaluator on Base Color, Metallic, Roughness and Normal within 1e-4
(`test_blender_nodes`; frames 0, 6, 10, 19 and 23 draw bricks or grain bands); the
extractor (`sg_extract`, which applies exactly Cycles' constant folds) reduces frames
0-299 to 19-60 nodes (median 31, 90th percentile 45; bricks cost about 17 nodes), and the
sub-shader's four maps equal the super-shader's bit for bit (frames 0-9, 64 x 64 points).
Parameters are
mapped to node ranges with Math nodes (Multiply, Add), not Map Range, because Cycles
never folds a Map Range, even one with constant inputs. Evaluating the whole super-shader is expensive (every
pattern of every module is computed, then switched): render the extracted sub-shader.

**Contact sheet.** `supershader-contact-sheet.png`: frames 0-63 (`imsynth sample --seed
0..63`), row-major from the top left, 128 x 128 each, made by `scripts/contact_sheet.py`
with our CLI. It is a preview, not a render: Base Color times a Lambert term of the
Bump normal (light from the upper left) - no specular, so metals look like their albedo.
`scripts/contact_sheet.py --render` path-traces each frame's extracted sub-shader
instead (about 10 s of CPU a frame at 16 spp here).

## The 50 parameters

In sampling order (the order of RandomValues' outputs).

| # | name | module | what it does | range after mapping / choices |
|---|---|---|---|---|
{table}
"""


def write_markdown(path, shown, ungrouped, tree):
    inst = {}

    def walk(t):
        for n in t.nodes:
            if n["type"] == "ShaderNodeGroup":
                inst[n["group"]] = inst.get(n["group"], 0) + 1
                walk(GROUPS[n["group"]])
    walk(tree)
    rows = "\n".join("| %d | `%s` | %s | %s | %s |" % (i, p[0], p[1], p[2], p[3])
                     for i, p in enumerate(PARAMS))
    text = MARKDOWN.format(
        shown=shown, ungrouped=ungrouped,
        groups=", ".join("%s x%d" % (k, v) for k, v in inst.items()),
        patterns=", ".join("%d %s" % (k, p[0]) for k, p in enumerate(NOISE_PATTERNS)),
        ops=", ".join(o.lower() for o in MATH_OPS),
        palette=", ".join(c[2] for c in PALETTE), table=rows)
    write_atomic(path, text)


def write_atomic(path, text):
    d = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".supershader.", dir=d)
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-o", "--output", default=os.path.join(here, "supershader.json"))
    ap.add_argument("--markdown", default=os.path.join(here, "supershader.md"),
                    help="where to write the parameter table ('' for nowhere)")
    args = ap.parse_args()
    GROUPS.clear()
    t = build()
    doc = {"format": FORMAT, "name": "Super Shader",
           "nodes": None, "links": None, "groups": {}}
    main_json = t.to_json(False)
    doc["nodes"], doc["links"] = main_json["nodes"], main_json["links"]
    for name, g in GROUPS.items():
        doc["groups"][name] = g.to_json(True)
    shown, ungrouped = count_nodes(t, GROUPS)
    write_atomic(args.output, json.dumps(doc, indent=1) + "\n")
    if args.markdown:
        write_markdown(args.markdown, shown, ungrouped, t)
    print("%s: %d nodes (groups expanded, once per instance), %d after ungrouping, "
          "%d parameters, %d groups" % (args.output, shown, ungrouped, len(PARAMS), len(GROUPS)))


if __name__ == "__main__":
    main()
