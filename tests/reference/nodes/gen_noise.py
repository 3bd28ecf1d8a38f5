#!/usr/bin/env python3
"""Reference cases for the Noise Texture (ShaderNodeTexNoise) and White Noise Texture
(ShaderNodeTexWhiteNoise).

Run from anywhere: python3 tests/reference/nodes/gen_noise.py
Then render the missing references with blender/render_node_references.py.

Coverage: every noise_type (FBM, MULTIFRACTAL, HYBRID_MULTIFRACTAL,
RIDGED_MULTIFRACTAL, HETERO_TERRAIN) with Normalize on and off; Detail 0, fractional
(2.5, 2.7, 3.3, 4.5), 14 and 15; Roughness 0, 1 and 2; Lacunarity 0, 1.5, 2.5 and 3;
Offset and Gain (including a Gain low enough to stop the hybrid's octaves early);
Distortion 0, 0.5, 2 and 1000; huge (1e4, 1e12), negative and zero scales; coordinates
beyond 1e6 (4.x's wrapping and half-cell precision correction; 3.4 has neither and
loses its fraction there); the Fac and Color outputs; 1D, 2D and 4D; an unlinked Vector
(Generated coordinates). White Noise: 1D-4D, Value and Color, and an unlinked Vector,
which Blender reads as (0, 0, 0).

Versions. Blender 3.4 has no noise_type, Lacunarity or Normalize: the importer builds a
4.x node for 3.4 through blender/compat_noise.py (a Musgrave Texture for the other noise
types and for unnormalized fBM). A case is rendered in 3.4 exactly when that translation
accepts the node (this script asks it); imsynth's 3.x mode must then match what 3.4
renders for the translated node. Fractal noise at high Detail differs between the two
versions (4.x wraps coordinates at 100000), so each version has its own reference.

Tolerance 1e-4 everywhere and no pixel may exceed it: the kernels reproduce Cycles'
float operations (fused multiply-adds included), so even the discontinuities (the 4.x
wrap at multiples of 100000, the hybrid's weight threshold) land on the same pixels.
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "..", "..", "blender"))
from casekit import Graph, write_case  # noqa: E402
from compat_noise import Blender3Unsupported, noise_node_for_blender3  # noqa: E402

BOTH = ("3.4", "4.3")
W_RANGE = (-7.3, 11.9)  # a non-power-of-two span: W is not dyadic either


def versions_for(name, props, inputs, vector_linked, w_linked, socket):
    """4.3 always; 3.4 when blender/compat_noise.py can build the node there."""
    linked = [k for k, on in (("Vector", vector_linked), ("W", w_linked)) if on]
    node = {"name": name, "type": "ShaderNodeTexNoise", "properties": props,
            "inputs": inputs}
    try:
        noise_node_for_blender3(node, linked_inputs=linked, linked_outputs=[socket])
    except Blender3Unsupported:
        return ("4.3",)
    return BOTH


def coords(g, mul_add):
    """Snapped Generated coordinates, optionally remapped as co * mul + add."""
    co = g.pixel_coords(space="generated")
    if mul_add is None:
        return co
    mul, add = mul_add
    m = g.node("ShaderNodeVectorMath", properties={"operation": "MULTIPLY"},
               inputs={"Vector_001": list(mul)})
    g.link(co, (m, "Vector"))
    a = g.node("ShaderNodeVectorMath", properties={"operation": "ADD"},
               inputs={"Vector_001": list(add)})
    g.link((m, "Vector"), (a, "Vector"))
    return (a, "Vector")


# Pixel centres are dyadic fractions ((i + 0.5) / 128): scaled by a power of two, from
# about the 8th octave on, they land on lattice points, where Perlin noise is 0, and
# upper octaves would go untested. A non-dyadic remap gives every octave full mantissas.
GENERIC_REMAP = ((1.37, 1.29, 1.0), (0.123, -0.217, 0.311))


def noise_case(name, *, socket="Fac", noise_type="FBM", normalize=True, dims="3D",
               remap=GENERIC_REMAP, link_vector=True, note="", **inputs):
    """One Noise Texture fed with snapped Generated coordinates, remapped as co * mul + add
    (remap=(mul, add)); W, for 1D and 4D, runs over W_RANGE along the image's x."""
    g = Graph()
    props = {"noise_dimensions": dims, "noise_type": noise_type, "normalize": normalize}
    n = g.node("ShaderNodeTexNoise", inputs=inputs, properties=props)
    vector_linked = link_vector and dims != "1D"
    if vector_linked:
        g.link(coords(g, remap), (n, "Vector"))
    w_linked = dims in ("1D", "4D")
    if w_linked:
        x, _ = g.pixel_xy()
        g.link(g.map_range(x, W_RANGE[0], W_RANGE[1]), (n, "W"))
    versions = versions_for(name, props, inputs, vector_linked, w_linked, socket)
    write_case("noise_" + name, g, socket=(n, socket), versions=versions, tolerance=1e-4,
               max_bad_fraction=0.0, note=note)


def white_noise_case(name, *, socket="Value", dims="3D", remap=((10.0, 10.0, 1.0),
                                                                  (0.0, 0.0, 0.0)),
                     link_vector=True, note=""):
    g = Graph()
    n = g.node("ShaderNodeTexWhiteNoise", properties={"noise_dimensions": dims})
    if link_vector and dims != "1D":
        g.link(coords(g, remap), (n, "Vector"))
    if dims in ("1D", "4D"):
        x, _ = g.pixel_xy()
        g.link(g.map_range(x, W_RANGE[0], W_RANGE[1]), (n, "W"))
    write_case("white_noise_" + name, g, socket=(n, socket), versions=BOTH, tolerance=1e-4,
               max_bad_fraction=0.0, note=note)


def main():
    # fBM (the Noise Texture of both versions).
    noise_case("fbm_default", note="Blender's defaults: Scale 5, Detail 2, Roughness 0.5.")
    noise_case("fbm_detail0_color", socket="Color", Detail=0.0,
               note="One octave; colour channels from offset seeds.")
    noise_case("fbm_detail2p5_rough1", Detail=2.5, Roughness=1.0,
               note="Fractional Detail blends in a fourth octave; Roughness 1.")
    noise_case("fbm_detail15_rough0p7", Detail=15.0, Roughness=0.7,
               note="16 octaves: coordinates pass 100000, where 4.x wraps and 3.4 does not.")
    noise_case("fbm_rough0", Detail=3.0, Roughness=0.0, note="Roughness 0: one octave counts.")
    noise_case("fbm_rough2", Detail=3.0, Roughness=2.0,
               note="Roughness above 1: 4.x uses it, 3.4 would clamp (4.3 only).")
    noise_case("fbm_lacunarity1p5", Detail=4.0, Lacunarity=1.5,
               note="Normalized fBM with Lacunarity 1.5 (4.3 only).")
    noise_case("fbm_unnormalized_lac3", normalize=False, Detail=3.5, Lacunarity=3.0,
               Roughness=0.6, note="Unnormalized fBM: a Musgrave fBM in 3.4.")
    noise_case("fbm_unnormalized_detail14", normalize=False, Detail=14.0, Roughness=0.8,
               note="Detail 14, the most a 3.4 Musgrave (15 octaves) can express.")
    noise_case("fbm_distortion2_color", socket="Color", Detail=2.0, Distortion=2.0,
               note="Distortion moves the point by noise of three offset seeds.")
    noise_case("fbm_distortion1000", Detail=1.0, Distortion=1000.0, note="Huge distortion.")
    noise_case("fbm_negative_scale", Scale=-7.0, Detail=1.5, note="Negative scale.")
    noise_case("fbm_scale0_color", socket="Color", Scale=0.0,
               note="Scale 0: every pixel evaluates the origin (plus colour seeds).")
    noise_case("fbm_scale1e4_detail5", Scale=10000.0, Detail=5.0,
               note="Scale 1e4 with 6 octaves: 4.x wraps the upper octaves at 100000.")
    noise_case("fbm_scale1e12", Scale=1e12, Detail=1.0,
               note="Coordinates beyond int32: 3.4's cells collapse (constant 0.5), 4.x "
                    "wraps them with its half-cell precision correction.")
    noise_case("fbm_offset_2e6", remap=((1.0, 1.0, 1.0), (2000000.0, -3000000.0, 0.0)),
               Scale=1.0, Detail=2.0,
               note="Coordinates around 2e6 / -3e6: 4.x wraps and shifts by half a cell; "
                    "3.4 evaluates them with their coarse float spacing.")
    noise_case("fbm_offset_negative", remap=((1.0, 1.0, 1.0), (-1234567.0, 99999.0, -5e5)),
               Scale=3.0, Detail=3.0, note="Negative large coordinates and the 1e5 wrap.")
    noise_case("fbm_unlinked_vector", socket="Color", link_vector=False, Scale=0.5,
               Detail=1.0,
               note="Unlinked Vector reads Generated coordinates at the (unsnapped) hit "
                    "point; Scale 0.5 keeps the 0.01 px filter jitter below 1e-4.")

    # The former Musgrave types.
    noise_case("multifractal_detail2", noise_type="MULTIFRACTAL", Detail=2.0,
               note="Multifractal, defaults.")
    noise_case("multifractal_detail4p5_lac2p5", noise_type="MULTIFRACTAL", Detail=4.5,
               Lacunarity=2.5, Roughness=0.4, note="Fractional Detail, Lacunarity 2.5.")
    noise_case("multifractal_color", noise_type="MULTIFRACTAL", socket="Color", Detail=2.0,
               note="Colour of a Multifractal (4.3 only: 3.4's Musgrave has Fac only).")
    noise_case("multifractal_lacunarity0", noise_type="MULTIFRACTAL", Detail=3.0,
               Lacunarity=0.0, note="Lacunarity 0: upper octaves at the origin (4.3 only).")
    noise_case("ridged_detail3", noise_type="RIDGED_MULTIFRACTAL", Detail=3.0, Offset=1.0,
               Gain=2.0, note="Ridged multifractal, Offset 1, Gain 2.")
    noise_case("ridged_detail0", noise_type="RIDGED_MULTIFRACTAL", Detail=0.0, Offset=0.8,
               note="Ridged, single octave.")
    noise_case("ridged_rough1_detail5", noise_type="RIDGED_MULTIFRACTAL", Detail=5.0,
               Roughness=1.0, Offset=1.0, Gain=1.0,
               note="Roughness 1 (3.4: Dimension clamped to 1e-5, within 1e-5 of it).")
    noise_case("ridged_distortion", noise_type="RIDGED_MULTIFRACTAL", Detail=2.0, Offset=1.0,
               Gain=2.0, Distortion=0.5, note="Distorted ridged multifractal (4.3 only).")
    noise_case("hybrid_detail3p3", noise_type="HYBRID_MULTIFRACTAL", Detail=3.3, Offset=0.7,
               Gain=1.3, note="Hybrid multifractal, fractional Detail.")
    noise_case("hybrid_gain0p05", noise_type="HYBRID_MULTIFRACTAL", Detail=6.0, Offset=0.0,
               Gain=0.05, note="Low Gain: the weight drops below 0.001 and octaves stop.")
    noise_case("hybrid_detail15", noise_type="HYBRID_MULTIFRACTAL", Detail=15.0, Offset=0.5,
               note="Detail 15 (4.3 only: 3.4's Musgrave stops at 15 octaves).")
    noise_case("multifractal_unnormalized", noise_type="MULTIFRACTAL", normalize=False,
               Detail=3.0, Roughness=0.7, Lacunarity=2.2,
               note="Normalize off: no effect on Multifractal.")
    noise_case("ridged_unnormalized", noise_type="RIDGED_MULTIFRACTAL", normalize=False,
               Detail=2.5, Offset=0.9, Gain=1.5, note="Normalize off: no effect on Ridged.")
    noise_case("hybrid_unnormalized", noise_type="HYBRID_MULTIFRACTAL", normalize=False,
               Detail=4.0, Roughness=1.0, Offset=0.3, Gain=2.0,
               note="Normalize off: no effect on Hybrid; Roughness 1.")
    noise_case("hetero_detail2p7", noise_type="HETERO_TERRAIN", Detail=2.7, Offset=0.4,
               note="Hetero terrain, fractional Detail.")
    noise_case("hetero_rough0_unnormalized", noise_type="HETERO_TERRAIN", normalize=False,
               Detail=4.0, Roughness=0.0, Offset=0.5,
               note="Roughness 0 (3.4: Dimension 1e30); Normalize has no effect here.")

    # Other dimensions.
    noise_case("1d_detail3", dims="1D", Detail=3.0, note="1D noise of W.")
    noise_case("2d_distortion_color", dims="2D", socket="Color", Detail=3.0, Distortion=1.0,
               note="2D, distorted, colour.")
    noise_case("4d_distortion_color", dims="4D", socket="Color", Detail=3.0, Distortion=1.0,
               note="4D with W along x, distorted, colour.")
    noise_case("4d_multifractal", dims="4D", noise_type="MULTIFRACTAL", Detail=2.5,
               note="4D multifractal.")

    # White Noise.
    white_noise_case("3d_value", note="3D white noise of coordinates x10.")
    white_noise_case("3d_color", socket="Color", note="3D white noise colour.")
    white_noise_case("1d_color", socket="Color", dims="1D", note="1D white noise of W.")
    white_noise_case("2d_color", socket="Color", dims="2D", note="2D white noise colour.")
    white_noise_case("4d_value", dims="4D", note="4D white noise value.")
    white_noise_case("unlinked_color", socket="Color", link_vector=False,
                     note="Unlinked Vector is (0, 0, 0) for White Noise: a constant colour.")


if __name__ == "__main__":
    main()
