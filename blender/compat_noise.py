"""Build a Blender 4.x Noise Texture node (our JSON vocabulary) for Blender 3.x.

Plain Python, no bpy: blender/import_material.py calls noise_node_for_blender3() when it
runs in Blender 3.x, and shadergraph/kernels/noise_texture.c computes, in its Blender 3.x
mode, exactly what Blender 3.4 renders for the node this returns. Keep the two in step
(musgrave_dimension() here and in noise_texture.c).

What Blender 3.4 has:
- ShaderNodeTexNoise: normalized fBM only, lacunarity fixed at 2, Roughness clamped to
  [0, 1] by the kernel; Vector/W, Scale, Detail, Roughness, Distortion; Fac and Color.
- ShaderNodeTexMusgrave: fBM, Multifractal, Hybrid/Ridged Multifractal, Hetero Terrain,
  unnormalized, no Distortion, Fac only. Blender 4.1 turned Musgrave nodes into Noise
  nodes by versioning (versioning_400.cc, versioning_replace_musgrave_texture_node):
  Noise Detail = Musgrave Detail - 1 (Musgrave's loops run `i < octaves`, Noise's
  `i <= detail`), Roughness = Lacunarity ^ -Dimension, normalize off. We invert that.

So a 4.x node translates as:
- noise_type FBM, normalize on, Lacunarity 2      -> ShaderNodeTexNoise (as it is)
- any other noise_type, or FBM with normalize off -> ShaderNodeTexMusgrave with
  musgrave_type = noise_type, Detail + 1, Dimension = -ln(Roughness) / ln(Lacunarity)
  (Roughness 0 -> Dimension 1e30, i.e. Lacunarity^-Dimension = 0), Offset and Gain as
  they are.

What Blender 3.4 cannot express (noise_node_for_blender3 raises Blender3Unsupported):
- FBM with normalize on and Lacunarity != 2 (3.4's Noise has no Lacunarity; the
  normalization of a Musgrave fBM would need extra Math nodes), or Lacunarity linked.
- FBM with normalize on and Roughness outside [0, 1] (3.4 clamps it, 4.x does not clamp
  above 1). A linked Roughness is accepted: it matches while its values stay in [0, 1].
- Musgrave translations with Distortion != 0 or linked, with the Color output linked
  (Musgrave has only Fac), with Detail > 14 (4.x Detail 15 would need Musgrave 16; 3.4
  clamps at 15), or with Detail, Roughness or Lacunarity linked (Detail + 1 and
  Dimension are computed here from constants; Blender's own versioning inserts Math
  nodes for links, which a single node cannot).
- Musgrave translations whose Roughness 3.4 cannot reproduce: 3.4 clamps Dimension to
  >= 1e-5 and Lacunarity to >= 1e-5, so Roughness 1 is reproduced only as
  Lacunarity^-1e-5 (accepted while within 1e-5 relative: Lacunarity <= ~2.7), Roughness
  < 1 needs Lacunarity > 1, and Roughness 0 needs Lacunarity^-1e30 to underflow to 0.
"""

import math
import struct

NOISE_TYPES = ("MULTIFRACTAL", "RIDGED_MULTIFRACTAL", "HYBRID_MULTIFRACTAL", "FBM",
               "HETERO_TERRAIN")

# Blender's defaults for ShaderNodeTexNoise (4.3) sockets we translate.
_DEFAULTS = {"Scale": 5.0, "Detail": 2.0, "Roughness": 0.5, "Lacunarity": 2.0,
             "Offset": 0.0, "Gain": 1.0, "Distortion": 0.0}

# How close Lacunarity^-Dimension (as Blender 3.4 computes it, in float) must come to the
# requested Roughness, relative.
ROUGHNESS_TOLERANCE = 1e-5


class Blender3Unsupported(ValueError):
    """A 4.x Noise Texture setting that Blender 3.x cannot render the same way."""


def _f32(x):
    """x rounded to float32, as Blender stores a socket value."""
    try:
        return struct.unpack("f", struct.pack("f", x))[0]
    except OverflowError:
        return math.copysign(math.inf, x)


def musgrave_dimension(roughness, lacunarity):
    """The Musgrave Dimension H with lacunarity^-H == roughness (noise_texture.c mirrors it).

    From the float32 values of both, as noise_texture.c reads its sockets: the two then
    compute the same float Dimension for any decimal in the JSON."""
    roughness, lacunarity = _f32(roughness), _f32(lacunarity)
    if roughness <= 0.0:
        return 1e30
    if lacunarity == 1.0 or roughness == 1.0:
        return 0.0
    return -math.log(roughness) / math.log(lacunarity)


def _musgrave_roughness(dimension, lacunarity):
    """What Blender 3.4's Musgrave uses as the per-octave amplitude factor."""
    h = max(_f32(dimension), 1e-5)
    lac = max(_f32(lacunarity), 1e-5)
    try:
        return _f32(lac ** -h)
    except OverflowError:
        return math.inf


def musgrave_roughness_for_export(dimension, lacunarity):
    """The Roughness to write for a 3.4 Musgrave with this Dimension and Lacunarity (the
    Lacunarity as it is written beside it: the importer translates with that value).

    Not Lacunarity^-Dimension as computed (0.45 comes back as 0.45000002: the float
    Dimension lost the last bits), but the shortest decimal whose translation
    (musgrave_dimension) stores the same float Dimension: importing it builds the same 3.4
    node, and a material written by us comes back with the numbers it was written with.
    Falls back to the computed value when no decimal of up to 9 digits does."""
    stored = _f32(dimension)
    for digits in range(1, 10):
        r = float("%.*g" % (digits, _musgrave_roughness(dimension, lacunarity)))
        if 0.0 < r <= 1.0 and _f32(musgrave_dimension(r, lacunarity)) == stored:
            return r
    return _musgrave_roughness(dimension, lacunarity)


def noise_node_for_blender3(node, linked_inputs=(), linked_outputs=()):
    """Translate one ShaderNodeTexNoise node dict (FORMAT.md) for Blender 3.x.

    linked_inputs / linked_outputs: socket identifiers of this node that have links in
    the tree (the importer knows them; the node dict alone does not). Returns a new node
    dict (type ShaderNodeTexNoise or ShaderNodeTexMusgrave, 3.4 properties and inputs;
    name, location and label kept). Raises Blender3Unsupported naming the node and the
    setting when Blender 3.4 cannot render it as 4.x does.
    """
    if node.get("type") != "ShaderNodeTexNoise":
        raise ValueError("noise_node_for_blender3: not a ShaderNodeTexNoise: %r"
                         % node.get("type"))
    name = node.get("name", "?")
    props = node.get("properties", {})
    inputs = node.get("inputs", {})
    linked_inputs = set(linked_inputs)
    linked_outputs = set(linked_outputs)

    def fail(why):
        raise Blender3Unsupported("node %r (ShaderNodeTexNoise): %s cannot be built in "
                                  "Blender 3.x" % (name, why))

    def value(identifier):
        return float(inputs.get(identifier, _DEFAULTS[identifier]))

    dims = props.get("noise_dimensions", "3D")
    noise_type = props.get("noise_type", "FBM")
    normalize = bool(props.get("normalize", True))
    if noise_type not in NOISE_TYPES:
        raise ValueError("node %r: unknown noise_type %r" % (name, noise_type))

    out = {k: node[k] for k in ("name", "location", "label") if k in node}
    passthrough = {k: inputs[k] for k in ("Vector", "W", "Scale") if k in inputs}

    if noise_type == "FBM" and normalize:
        if "Lacunarity" in linked_inputs or value("Lacunarity") != 2.0:
            fail("normalized fBM with Lacunarity %g (3.4's Noise Texture has lacunarity 2)"
                 % value("Lacunarity"))
        if "Roughness" not in linked_inputs and not 0.0 <= value("Roughness") <= 1.0:
            fail("Roughness %g outside [0, 1] (3.4 clamps it)" % value("Roughness"))
        out["type"] = "ShaderNodeTexNoise"
        out["properties"] = {"noise_dimensions": dims}
        out["inputs"] = dict(passthrough)
        for k in ("Detail", "Roughness", "Distortion"):
            if k in inputs:
                out["inputs"][k] = inputs[k]
        return out

    what = "%s%s" % (noise_type, " (unnormalized)" if noise_type == "FBM" else "")
    for k in ("Detail", "Roughness", "Lacunarity", "Distortion"):
        if k in linked_inputs:
            fail("%s with %s linked" % (what, k))
    if "Color" in linked_outputs:
        fail("%s with its Color output used (3.4's Musgrave has Fac only)" % what)
    if value("Distortion") != 0.0:
        fail("%s with Distortion %g (3.4's Musgrave has none)" % (what, value("Distortion")))
    detail = min(max(value("Detail"), 0.0), 15.0)
    if detail > 14.0:
        fail("%s with Detail %g > 14 (3.4's Musgrave stops at 15 octaves)" % (what, detail))
    roughness = max(value("Roughness"), 0.0)
    lacunarity = value("Lacunarity")
    if lacunarity < 1e-5:
        fail("%s with Lacunarity %g < 1e-5 (3.4 clamps it)" % (what, lacunarity))
    dimension = musgrave_dimension(roughness, lacunarity)
    achieved = _musgrave_roughness(dimension, lacunarity)
    if not abs(achieved - roughness) <= ROUGHNESS_TOLERANCE * max(roughness, 1e-30):
        fail("%s with Roughness %g and Lacunarity %g (3.4's Musgrave reaches %g)"
             % (what, roughness, lacunarity, achieved))

    out["type"] = "ShaderNodeTexMusgrave"
    out["properties"] = {"musgrave_dimensions": dims, "musgrave_type": noise_type}
    out["inputs"] = dict(passthrough)
    out["inputs"].update({"Detail": detail + 1.0, "Dimension": dimension,
                          "Lacunarity": lacunarity, "Offset": value("Offset"),
                          "Gain": value("Gain")})
    return out
