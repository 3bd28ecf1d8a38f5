#!/usr/bin/env python3
"""Reference cases for the structural and geometry nodes: Texture Coordinate, Reroute,
node groups (nested, interface defaults), Bump, Principled BSDF inputs read as inputs, and
the values Blender clamps when it stores them (negative colours).

Run from anywhere: python3 tests/reference/nodes/gen_geometry.py
Then render the missing references with blender/render_node_references.py.

Texture Coordinate: the tc_* cases compare the raw outputs (not snapped). They are linear
in the hit point, and Cycles' one ray per pixel lands within 0.005 px of the pixel centre
(0.01 px filter), which bounds the difference by 3.9e-5 for Generated/UV (1/128 per px)
and 7.8e-5 for Object (2/128 per px), under the 1e-4 tolerance. Measured: 6e-8 and 9e-8
(the one-sample ray is at the centre to float precision). tc_*_snapped check casekit's
snapping itself (exact).

Bump: Cycles evaluates Height at the hit point and at two points offset by the ray
differentials (dP, one pixel's footprint, along an orthonormal pair around Ng), so its
result depends on the image resolution: these references hold for 128 x 128 only, which
is what the comparison evaluates (sg_plane_geometry(128, 128, ...)). Bump's coordinates
are not snapped: snapping would put the offset points on the same pixel centre and make
the height differences vanish. Bump differs between 3.4 and 4.3 (4.3 tilts further), so
the same graphs are compared in both modes: in bump_distance_large 93% of 3.4's normals
sit at its limit z = 0.711 while 4.3's reach z = 0.109.

The comparison's resolution limit for Bump: Blender's hit point is ~6e-8 (Generated
units) off the exact pixel centre, which moves each height sample by gradient x 6e-8 and
the normal by roughly Distance / dP times that (dP = 1/64 m at 128 x 128). Measured: a
Noise of scale 40 at Distance 20 differs by up to 6e-4 on 0.1-0.3% of pixels, scale 5 at
Distance 30 by up to 2e-4 on 0.02%; the cases here stay below 1e-4 everywhere.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from casekit import Graph, write_case  # noqa: E402

BOTH = ("3.4", "4.3")
TEXCOORD_OUTPUTS = ("Generated", "Normal", "UV", "Object", "Camera", "Window", "Reflection")


def tc_cases():
    for out in TEXCOORD_OUTPUTS:
        g = Graph()
        tc = g.texture_coordinate()
        write_case("tc_" + out.lower(), g, socket=(tc, out), versions=BOTH,
                   note="Texture Coordinate %s, raw (not snapped): off by <= 0.005 px of "
                        "the hit point; linear, so within 1e-4" % out)
    for space in ("generated", "object", "uv"):
        g = Graph()
        co = g.pixel_coords(space=space)
        write_case("tc_%s_snapped" % space, g, socket=co, versions=BOTH,
                   note="casekit.pixel_coords(%r): the exact pixel centre in float" % space)


def reroute_cases():
    # A chain of reroutes carrying a vector into Vector Math, and the reroute itself.
    g = Graph()
    co = g.pixel_coords()
    r1 = g.node("NodeReroute")
    r2 = g.node("NodeReroute")
    g.link(co, (r1, "Input"))
    g.link((r1, "Output"), (r2, "Input"))
    vm = g.node("ShaderNodeVectorMath", properties={"operation": "SCALE"},
                inputs={"Scale": -3.0})
    g.link((r2, "Output"), (vm, "Vector"))
    write_case("reroute_chain", g, socket=(vm, "Vector"), versions=BOTH,
               note="snapped Generated -> Reroute -> Reroute -> Vector Math SCALE -3")
    write_case("reroute_output", g, socket=(r2, "Output"), versions=BOTH,
               note="the Output socket of the second reroute of a chain")

    # A vector through a reroute into a float input: converted (average) at the Math input.
    g = Graph()
    co = g.pixel_coords()
    r = g.node("NodeReroute")
    g.link(co, (r, "Input"))
    m = g.node("ShaderNodeMath", properties={"operation": "MULTIPLY"},
               inputs={"Value_001": 4.0})
    g.link((r, "Output"), (m, "Value"))
    write_case("reroute_vector_to_float", g, socket=(m, "Value"), versions=BOTH,
               note="vector (u, v, 0.5) through a reroute into Math: (u + v + 0.5) / 3 * 4")

    # One reroute fanning out to two consumers, a colour into a vector input.
    g = Graph()
    x, y = g.pixel_xy()
    cc = g.node("ShaderNodeCombineColor")
    g.link(x, (cc, "Red"))
    g.link(y, (cc, "Green"))
    g.set_input(cc, "Blue", 0.25)
    r = g.node("NodeReroute")
    g.link((cc, "Color"), (r, "Input"))
    vm = g.node("ShaderNodeVectorMath", properties={"operation": "MULTIPLY"})
    g.link((r, "Output"), (vm, "Vector"))
    g.link((r, "Output"), (vm, "Vector_001"))
    write_case("reroute_fanout_color", g, socket=(vm, "Vector"), versions=BOTH,
               note="Combine Color (u, v, 0.25) -> one reroute -> both inputs of a "
                    "Vector Math MULTIPLY: (u^2, v^2, 1/16)")


def _inner_group(g):
    """Inner(A: float = 0.25, B: vector = (1, 2, 3)) -> Out = A + B . (1, 1, 1), and
    Vec = B * A."""
    inner = g.group("Inner")
    a = inner.add_input("A", "FLOAT", default=0.25, min_value=-10.0, max_value=10.0)
    b = inner.add_input("B", "VECTOR", default=[1.0, 2.0, 3.0])
    out = inner.add_output("Out", "FLOAT")
    vec = inner.add_output("Vec", "VECTOR")
    dot = inner.node("ShaderNodeVectorMath", properties={"operation": "DOT_PRODUCT"},
                     inputs={"Vector_001": [1.0, 1.0, 1.0]})
    inner.link(b, (dot, "Vector"))
    add = inner.node("ShaderNodeMath", properties={"operation": "ADD"})
    inner.link(a, (add, "Value"))
    inner.link((dot, "Value"), (add, "Value_001"))
    inner.link((add, "Value"), out)
    sc = inner.node("ShaderNodeVectorMath", properties={"operation": "SCALE"})
    inner.link(b, (sc, "Vector"))
    inner.link(a, (sc, "Scale"))
    inner.link((sc, "Vector"), vec)
    return inner


def _outer_group(g, inner):
    """Outer(X: float = 0.5, Y: float = 2.0, C: colour = (0.1, 0.2, 0.3)) ->
    Out = Inner(A = X * Y, B unset: its default).Out, Col = C via Inner.Vec."""
    outer = g.group("Outer")
    x = outer.add_input("X", "FLOAT", default=0.5)
    y = outer.add_input("Y", "FLOAT", default=2.0)
    c = outer.add_input("C", "RGBA", default=[0.1, 0.2, 0.3, 1.0])
    out = outer.add_output("Out", "FLOAT")
    vec = outer.add_output("Vec", "VECTOR")
    mul = outer.node("ShaderNodeMath", properties={"operation": "MULTIPLY"})
    outer.link(x, (mul, "Value"))
    outer.link(y, (mul, "Value_001"))
    n1 = g.group_node(inner, tree=outer)               # B left at Inner's default
    outer.link((mul, "Value"), (n1, "A"))
    outer.link((n1, "Out"), out)
    n2 = g.group_node(inner, tree=outer, inputs={"A": 2.0})
    outer.link(c, (n2, "B"))                           # colour into a vector input
    outer.link((n2, "Vec"), vec)
    return outer


def group_cases():
    # Nested groups; the outer instance's X linked, Y left at its interface default.
    g = Graph()
    inner = _inner_group(g)
    outer = _outer_group(g, inner)
    x, _ = g.pixel_xy()
    n = g.group_node(outer)
    g.link(x, (n, "X"))
    write_case("group_nested_defaults", g, socket=(n, "Out"), versions=BOTH,
               note="Outer(X = u, Y default 2) -> Inner(A = X*Y, B default (1,2,3)): "
                    "2u + 6")
    write_case("group_nested_color_default", g, socket=(n, "Vec"), versions=BOTH,
               note="Outer's C default colour (0.1, 0.2, 0.3) into Inner's vector B, "
                    "scaled by A = 2 set on the inner instance")

    # Values set on the group node override the interface defaults.
    g = Graph()
    inner = _inner_group(g)
    outer = _outer_group(g, inner)
    _, y = g.pixel_xy()
    n = g.group_node(outer, inputs={"Y": -3.0, "C": [0.5, 0.25, 4.0, 1.0]})
    g.link(y, (n, "X"))
    write_case("group_nested_values", g, socket=(n, "Out"), versions=BOTH,
               note="Outer(X = v, Y = -3 set on the node) -> -3v + 6")
    write_case("group_nested_values_vec", g, socket=(n, "Vec"), versions=BOTH,
               note="Outer's C set on the node (0.5, 0.25, 4) -> Inner B, times 2")

    # The same group used twice, one instance feeding the other; Group Input read twice.
    g = Graph()
    inner = _inner_group(g)
    co = g.pixel_coords()
    a = g.group_node(inner, inputs={"A": -1.0})
    g.link(co, (a, "B"))
    b = g.group_node(inner)
    g.link((a, "Out"), (b, "A"))
    g.link((a, "Vec"), (b, "B"))
    write_case("group_chained_instances", g, socket=(b, "Vec"), versions=BOTH,
               note="Inner twice: B = -co, then scaled by (-1 + u + v + 0.5)")


def noise_height(g, scale=3.0, detail=2.0):
    tc = g.texture_coordinate()
    n = g.node("ShaderNodeTexNoise", inputs={"Scale": scale, "Detail": detail,
                                             "Roughness": 0.5, "Distortion": 0.0},
               properties={"noise_dimensions": "3D", "noise_type": "FBM", "normalize": True})
    g.link((tc, "Generated"), (n, "Vector"))
    return (n, "Fac")


def bump_cases():
    variants = [
        ("default", {}, {}),
        ("strength_half", {"Strength": 0.5, "Distance": 0.3}, {}),
        ("invert", {"Strength": 0.8, "Distance": 0.5}, {"invert": True}),
        ("distance_large", {"Strength": 1.0, "Distance": 5.0}, {}),
        ("strength_zero", {"Strength": 0.0}, {}),
        ("distance_zero", {"Distance": 0.0}, {}),
        ("negative_distance", {"Distance": -0.7}, {}),
        ("strength_over_one", {"Strength": 2.0, "Distance": 0.5}, {}),
        ("strength_negative", {"Strength": -0.5, "Distance": 0.5}, {}),
    ]
    for name, inputs, props in variants:
        g = Graph()
        h = noise_height(g)
        b = g.node("ShaderNodeBump", inputs=inputs, properties=props)
        g.link(h, (b, "Height"))
        write_case("bump_" + name, g, socket=(b, "Normal"), versions=BOTH,
                   note="Bump of a Noise (scale 3, detail 2) of raw Generated; %s %s; "
                        "128 x 128 only (ray differentials)" % (inputs, props))

    # High-frequency height: the differences across one pixel are large.
    g = Graph()
    h = noise_height(g, scale=40.0, detail=4.0)
    b = g.node("ShaderNodeBump", inputs={"Strength": 1.0, "Distance": 0.1})
    g.link(h, (b, "Height"))
    write_case("bump_high_frequency", g, socket=(b, "Normal"), versions=BOTH,
               note="Bump of Noise scale 40, detail 4: large height steps per pixel")

    # Height unlinked: Bump returns the (implicit) normal.
    g = Graph()
    b = g.node("ShaderNodeBump", inputs={"Height": 0.7, "Strength": 1.0})
    write_case("bump_height_unlinked", g, socket=(b, "Normal"), versions=BOTH,
               note="constant Height: the normal is N")

    # Chained: the second Bump's Normal input is the first one's output.
    g = Graph()
    h = noise_height(g)
    b1 = g.node("ShaderNodeBump", inputs={"Strength": 0.6, "Distance": 1.0})
    g.link(h, (b1, "Height"))
    tc = g.texture_coordinate()
    n2 = g.node("ShaderNodeTexNoise", inputs={"Scale": 7.0, "Detail": 1.0},
                properties={"noise_dimensions": "3D", "noise_type": "FBM", "normalize": True})
    g.link((tc, "Object"), (n2, "Vector"))
    b2 = g.node("ShaderNodeBump", inputs={"Strength": 0.4, "Distance": 0.5})
    g.link((n2, "Fac"), (b2, "Height"))
    g.link((b1, "Normal"), (b2, "Normal"))
    write_case("bump_chained", g, socket=(b2, "Normal"), versions=BOTH,
               note="Bump of Noise(Object, scale 7) on top of Bump of Noise(Generated)")

    # Height from a linear function: its exact gradient shows how Bump scales by distance.
    g = Graph()
    tc = g.texture_coordinate()
    sep = g.node("ShaderNodeSeparateXYZ")
    g.link((tc, "Object"), (sep, "Vector"))
    m = g.node("ShaderNodeMath", properties={"operation": "MULTIPLY_ADD"},
               inputs={"Value_001": 0.3, "Value_002": 1.0})
    g.link((sep, "X"), (m, "Value"))
    b = g.node("ShaderNodeBump", inputs={"Strength": 1.0, "Distance": 1.0})
    g.link((m, "Value"), (b, "Height"))
    write_case("bump_linear_height", g, socket=(b, "Normal"), versions=BOTH,
               note="Height = 0.3 x + 1 (object space): a constant tilt")


def principled_cases():
    def material(g):
        p = g.node("ShaderNodeBsdfPrincipled")
        g.link((p, "BSDF"), (g.output, "Surface"))
        return p

    g = Graph()
    p = material(g)
    co = g.pixel_coords()
    g.link(co, (p, "Base Color"))
    write_case("principled_base_color_linked", g, socket=(p, "Base Color"), versions=BOTH,
               note="Principled BSDF's Base Color input, linked from snapped Generated")

    g = Graph()
    p = material(g)
    g.set_input(p, "Base Color", [0.2, 0.4, 0.6, 1.0])
    write_case("principled_base_color_value", g, socket=(p, "Base Color"), versions=BOTH,
               note="Principled BSDF's unlinked Base Color value (0.2, 0.4, 0.6)")

    g = Graph()
    p = material(g)
    h = noise_height(g)
    b = g.node("ShaderNodeBump", inputs={"Strength": 0.5, "Distance": 1.0})
    g.link(h, (b, "Height"))
    g.link((b, "Normal"), (p, "Normal"))
    write_case("principled_normal_bump", g, socket=(p, "Normal"), versions=BOTH,
               note="Principled BSDF's Normal input linked from a Bump")

    g = Graph()
    p = material(g)
    write_case("principled_normal_unlinked", g, socket=(p, "Normal"), versions=BOTH,
               note="Principled BSDF's unlinked Normal: the shading normal N (render_socket "
                    "reads Geometry Normal there, as Cycles uses N)")


def clamped_value_cases():
    """Blender stores colour socket values (and colour-ramp stops) clamped to >= 0: its
    RNA range for colours starts at 0, so a graph asking for a negative colour component
    gets 0 in Blender. The evaluator must read such a graph as Blender holds it."""
    g = Graph()
    p = g.node("ShaderNodeBsdfPrincipled", inputs={"Base Color": [0.5, -0.25, 2.0, 1.0]})
    g.link((p, "BSDF"), (g.output, "Surface"))
    write_case("clamp_color_socket_value", g, socket=(p, "Base Color"), versions=BOTH,
               note="Base Color (0.5, -0.25, 2) is stored by Blender as (0.5, 0, 2)")

    g = Graph()
    grp = g.group("Tint")
    c = grp.add_input("C", "RGBA", default=[-1.0, 0.5, 3.0, 1.0])
    grp.link(c, grp.add_output("Out", "RGBA"))
    n = g.group_node(grp)
    write_case("clamp_group_color_default", g, socket=(n, "Out"), versions=BOTH,
               note="group colour input default (-1, 0.5, 3) is stored as (0, 0.5, 3)")

    g = Graph()
    grp = g.group("Tint")
    c = grp.add_input("C", "RGBA", default=[0.1, 0.2, 0.3, 1.0])
    grp.link(c, grp.add_output("Out", "RGBA"))
    n = g.group_node(grp, inputs={"C": [0.25, -2.0, 1.5, 1.0]})
    write_case("clamp_group_node_color_value", g, socket=(n, "Out"), versions=BOTH,
               note="group node colour input value (0.25, -2, 1.5) is stored as (0.25, 0, 1.5)")


if __name__ == "__main__":
    tc_cases()
    reroute_cases()
    group_cases()
    bump_cases()
    principled_cases()
    clamped_value_cases()
