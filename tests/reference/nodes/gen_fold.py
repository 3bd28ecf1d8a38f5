#!/usr/bin/env python3
"""Cases for Cycles' constant folding, which Blender applies before it renders and which
imsynth's compiler therefore reproduces (shadergraph/fold.c and each node type's fold
beside its kernel). Each case is built so that the folded and the unfolded evaluation differ far
beyond the tolerance, so the reference tells which one Blender computes. Plain python3.

- fold_host_multiply_add: a Multiply Add with constant inputs is folded on Blender's
  host CPU, without the fused multiply-add the render kernel uses. a = b = 1 + 2^-12,
  c = -(1 + 2^-11): unfused a*b + c is 0, fused it is 2^-24; a constant Multiply by
  2^24 (also folded) makes that 0 versus 1.
- fold_multiply_by_zero_of_inf: x * 0 with a constant 0 is 0 even where x is infinite
  (exp of a large value); evaluated, inf * 0 would be NaN (which the film writes as 0:
  so the case adds 0.5 after it to make 0.5 versus film-zeroed NaN).
- fold_mix_factor_one: a float Mix with factor 1 is B itself (Blender 4.x folds it;
  3.x does not, so the case lists 4.3 only). A = 1e8 from a Map Range (never folded),
  B = 1: evaluated, a + 1 * (b - a) is 0 in float; folded it is 1.
- fold_mix_color_factor_one: the same for a colour Mix (folded in 3.4 and 4.3).
"""
from casekit import Graph, write_case


def host_multiply_add():
    g = Graph()
    x, _ = g.pixel_xy()
    a = 1.0 + 2.0 ** -12
    c = -(1.0 + 2.0 ** -11)
    m = g.node("ShaderNodeMath", properties={"operation": "MULTIPLY_ADD"},
               inputs={"Value": a, "Value_001": a, "Value_002": c})
    s = g.node("ShaderNodeMath", properties={"operation": "MULTIPLY"},
               inputs={"Value_001": 2.0 ** 24})
    g.link((m, "Value"), (s, "Value"))
    write_case("fold_host_multiply_add", g, socket=(s, "Value"),
               note="all-constant Multiply Add folds unfused on the host: 0, not 1")


def multiply_by_zero_of_inf():
    g = Graph()
    x, _ = g.pixel_xy()
    big = g.map_range(x, 100.0, 200.0)
    e = g.node("ShaderNodeMath", properties={"operation": "EXPONENT"})
    g.link(big, (e, "Value"))
    z = g.node("ShaderNodeMath", properties={"operation": "MULTIPLY"}, inputs={"Value_001": 0.0})
    g.link((e, "Value"), (z, "Value"))
    h = g.node("ShaderNodeMath", properties={"operation": "ADD"}, inputs={"Value_001": 0.5})
    g.link((z, "Value"), (h, "Value"))
    write_case("fold_multiply_by_zero_of_inf", g, socket=(h, "Value"),
               note="exp(>=100) is inf; x * constant 0 folds to 0, so 0.5 everywhere")


def mix_factor_one():
    g = Graph()
    x, _ = g.pixel_xy()
    a = g.map_range(x, 1e8, 1e8)
    m = g.node("ShaderNodeMix", properties={"data_type": "FLOAT"},
               inputs={"Factor_Float": 1.0, "B_Float": 1.0})
    g.link(a, (m, "A_Float"))
    write_case("fold_mix_factor_one", g, socket=(m, "Result_Float"), versions=("4.3",),
               note="4.x folds a float Mix with factor 1 to B: 1, where a + (b - a) = 0")


def mix_color_factor_one():
    g = Graph()
    x, _ = g.pixel_xy()
    a = g.map_range(x, 1e8, 1e8)
    m = g.node("ShaderNodeMix", properties={"data_type": "RGBA", "blend_type": "MIX"},
               inputs={"Factor_Float": 1.0, "B_Color": [1.0, 1.0, 1.0, 1.0]})
    g.link(a, (m, "A_Color"))
    write_case("fold_mix_color_factor_one", g, socket=(m, "Result_Color"),
               note="a colour Mix (MIX) with factor 1 folds to B in 3.4 and 4.3")


if __name__ == "__main__":
    host_multiply_add()
    multiply_by_zero_of_inf()
    mix_factor_one()
    mix_color_factor_one()
