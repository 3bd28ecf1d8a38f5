"""Hand-made test materials (issue 15): built with Blender's own nodes, NOT the super-shader.

    blender -b --factory-startup -P blender/handmade_materials.py -- --list
    blender -b --factory-startup -P blender/handmade_materials.py -- [NAME ...] --save out.blend [--scene]

Each material is a function that builds a node tree by hand (Noise, Voronoi, Wave, Brick,
Musgrave in 3.4 / Noise's fractal types in 4.x, ColorRamp, Mix, Math, Bump, Principled
BSDF...). They imitate real surfaces (wood planks, marble, rusty metal, ...) at the scale
of DESIGN.md's plane: 2 m x 2 m seen orthographically at 256 x 256 px, so 1 px = 7.8 mm;
patterns are chosen a few pixels to a few tens of pixels wide.

Invariant that the evaluation's floor relies on: every material reads its texture
coordinates through ONE Mapping node (named MAPPING_NAME, scale 1, fed by the Texture
Coordinate node's Object output, i.e. (x, y, 0) in metres on the plane). Whatever a
material does downstream is a function of that node's output, so adding (dx, dy, 0) to
its Location translates the whole pattern by (-dx, -dy) m on the plane: the same material
with its texture moved (render_handmade.py --shift). The Mapping node's base Location has
z = BASE_Z so that 3D textures are sliced off their lattice planes. (brushed_metal also
reads a Tangent from the UV map: a direction, the same everywhere, that a shift leaves.)

--save writes the named materials (all by default) to a .blend (fake users, so they are
kept); --scene also builds DESIGN.md's scene with the first one on the plane.
Blender 3.4 and 4.x differ in: Musgrave (removed in 4.1: Noise has the fractal types),
Principled socket names (Specular -> Specular IOR Level, Clearcoat -> Coat Weight,
Sheen -> Sheen Weight); Tree below hides both. The Mix node (ShaderNodeMix) exists in both.
"""
import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import import_material  # noqa: E402

MAPPING_NAME = "imsynth_mapping"
BASE_Z = 0.537


def _rgba(c):
    return (c[0], c[1], c[2], 1.0) if len(c) == 3 else tuple(c)


class Tree:
    """A material's node tree under construction. self.p is the Mapping node's output (the
    only texture coordinates a material may use). Methods return output sockets; any
    argument that is a socket is linked, anything else is set as the input's value."""

    def __init__(self, mat, major):
        mat.use_nodes = True
        self.nt = mat.node_tree
        self.major = major
        for n in list(self.nt.nodes):
            self.nt.nodes.remove(n)
        self.output = self.nt.nodes.new("ShaderNodeOutputMaterial")
        tc = self.nt.nodes.new("ShaderNodeTexCoord")
        m = self.nt.nodes.new("ShaderNodeMapping")
        m.name = MAPPING_NAME
        m.vector_type = "POINT"
        m.inputs["Location"].default_value = (0.0, 0.0, BASE_Z)
        self.nt.links.new(tc.outputs["Object"], m.inputs["Vector"])
        self.p = m.outputs["Vector"]

    # ---- plumbing -------------------------------------------------------------------
    def set(self, sock, v):
        if isinstance(v, bpy.types.NodeSocket):
            self.nt.links.new(v, sock)
        elif sock.type == "RGBA":
            sock.default_value = _rgba(v if isinstance(v, (tuple, list)) else (v, v, v))
        else:
            sock.default_value = v

    def node(self, kind, inputs=None, **props):
        n = self.nt.nodes.new(kind)
        for k, v in props.items():
            setattr(n, k, v)
        for key, v in (inputs or {}).items():
            if v is None:
                continue
            self.set(n.inputs[key] if isinstance(key, int) else n.inputs[key], v)
        return n

    @staticmethod
    def by_id(sockets, identifier):
        for s in sockets:
            if s.identifier == identifier:
                return s
        raise KeyError(identifier)

    # ---- textures -------------------------------------------------------------------
    def noise(self, vec, scale, detail=2.0, roughness=0.5, distortion=0.0, out="Fac"):
        """Normalized fBM Noise (the same node in 3.4 and 4.x)."""
        n = self.node("ShaderNodeTexNoise", {"Vector": vec, "Scale": scale, "Detail": detail,
                                             "Roughness": roughness, "Distortion": distortion})
        return n.outputs[out]

    def fractal(self, kind, vec, scale, detail, roughness, lacunarity=2.0, offset=1.0,
                gain=1.0):
        """Musgrave (3.4) / Noise with a fractal type (4.x), translated as Blender 4.1's own
        versioning does (compat_noise.py): Detail - 1, Roughness = Lacunarity^-Dimension.
        KIND: RIDGED_MULTIFRACTAL, HYBRID_MULTIFRACTAL, MULTIFRACTAL, HETERO_TERRAIN, FBM."""
        if self.major >= 4:
            n = self.node("ShaderNodeTexNoise", {
                "Vector": vec, "Scale": scale, "Detail": detail, "Roughness": roughness,
                "Lacunarity": lacunarity, "Offset": offset, "Gain": gain},
                noise_type=kind, normalize=False)
        else:
            n = self.node("ShaderNodeTexMusgrave", {
                "Vector": vec, "Scale": scale, "Detail": detail + 1.0,
                "Dimension": -math.log(roughness) / math.log(lacunarity),
                "Lacunarity": lacunarity, "Offset": offset, "Gain": gain},
                musgrave_type=kind)
        return n.outputs["Fac"]

    def voronoi(self, vec, scale, feature="F1", randomness=1.0, distance="EUCLIDEAN"):
        """Returns the node (outputs Distance, Color, Position)."""
        return self.node("ShaderNodeTexVoronoi", {"Vector": vec, "Scale": scale,
                                                  "Randomness": randomness},
                         feature=feature, distance=distance)

    def wave(self, vec, scale, distortion=0.0, detail=2.0, detail_scale=1.0,
             detail_roughness=0.5, kind="BANDS", direction="X", profile="SIN"):
        props = {"wave_type": kind, "wave_profile": profile}
        props["bands_direction" if kind == "BANDS" else "rings_direction"] = direction
        n = self.node("ShaderNodeTexWave", {
            "Vector": vec, "Scale": scale, "Distortion": distortion, "Detail": detail,
            "Detail Scale": detail_scale, "Detail Roughness": detail_roughness}, **props)
        return n.outputs["Fac"]

    def brick(self, vec, scale, width, height, mortar, color1=(0, 0, 0), color2=(1, 1, 1),
              mortar_color=(0, 0, 0), smooth=0.1, bias=0.0, offset=0.5, frequency=2):
        """Returns the node: Color (per-brick mix of color1/color2), Fac (1 in mortar)."""
        return self.node("ShaderNodeTexBrick", {
            "Vector": vec, "Scale": scale, "Brick Width": width, "Row Height": height,
            "Mortar Size": mortar, "Mortar Smooth": smooth, "Bias": bias,
            "Color1": color1, "Color2": color2, "Mortar": mortar_color},
            offset=offset, offset_frequency=frequency)

    # ---- colour and maths -------------------------------------------------------------
    def ramp(self, fac, stops, interpolation="LINEAR", out="Color"):
        """STOPS: [(position, (r, g, b) or grey value)], positions increasing."""
        n = self.node("ShaderNodeValToRGB", {"Fac": fac})
        cr = n.color_ramp
        cr.interpolation = interpolation
        while len(cr.elements) < len(stops):
            cr.elements.new(1.0)
        for e, (pos, col) in zip(cr.elements, stops):
            e.position = pos
            e.color = _rgba(col if isinstance(col, (tuple, list)) else (col, col, col))
        return n.outputs[out]

    def mix(self, fac, a, b, blend="MIX", clamp=False):
        """Colour mix (ShaderNodeMix, RGBA): a where fac = 0, b where fac = 1."""
        n = self.node("ShaderNodeMix", data_type="RGBA", blend_type=blend, clamp_result=clamp)
        self.set(self.by_id(n.inputs, "Factor_Float"), fac)
        self.set(self.by_id(n.inputs, "A_Color"), a)
        self.set(self.by_id(n.inputs, "B_Color"), b)
        return self.by_id(n.outputs, "Result_Color")

    def math(self, op, a, b=0.0, c=0.0, clamp=False):
        n = self.node("ShaderNodeMath", operation=op, use_clamp=clamp)
        for i, v in enumerate((a, b, c)):
            self.set(n.inputs[i], v)
        return n.outputs[0]

    def vmath(self, op, a, b=(0.0, 0.0, 0.0), scale=1.0):
        n = self.node("ShaderNodeVectorMath", operation=op)
        self.set(n.inputs[0], a)
        self.set(n.inputs[1], b)
        if op == "SCALE":
            self.set(n.inputs[3], scale)
        return n.outputs["Value" if op in ("LENGTH", "DOT_PRODUCT", "DISTANCE") else "Vector"]

    def stretch(self, vec, sx, sy, sz=1.0):
        """Anisotropic scaling of coordinates (after the Mapping node)."""
        return self.vmath("MULTIPLY", vec, (sx, sy, sz))

    def warp(self, vec, scale, amount, detail=3.0):
        """vec + amount * (noise colour - 0.5): organic wobble of a pattern."""
        c = self.noise(vec, scale, detail, 0.5, out="Color")
        d = self.vmath("SUBTRACT", c, (0.5, 0.5, 0.5))
        return self.vmath("ADD", vec, self.vmath("SCALE", d, scale=amount))

    def smoothstep(self, x, lo, hi):
        """0 below lo, 1 above hi, smooth between (a two-stop ramp, its Fac output)."""
        return self.ramp(x, [(lo, 0.0), (hi, 1.0)], "EASE", out="Color")

    def bump(self, height, strength, distance, normal=None):
        n = self.node("ShaderNodeBump", {"Height": height, "Strength": strength,
                                         "Distance": distance, "Normal": normal})
        return n.outputs["Normal"]

    # ---- the surface -------------------------------------------------------------------
    def principled(self, base_color, roughness, metallic=0.0, normal=None, specular=0.5,
                   coat=0.0, coat_roughness=0.03, sheen=0.0, anisotropic=0.0):
        names = ({"specular": "Specular IOR Level", "coat": "Coat Weight",
                  "coat_roughness": "Coat Roughness", "sheen": "Sheen Weight"}
                 if self.major >= 4 else
                 {"specular": "Specular", "coat": "Clearcoat",
                  "coat_roughness": "Clearcoat Roughness", "sheen": "Sheen"})
        n = self.node("ShaderNodeBsdfPrincipled", {
            "Base Color": base_color, "Roughness": roughness, "Metallic": metallic,
            "Normal": normal, "Anisotropic": anisotropic,
            names["specular"]: specular, names["coat"]: coat,
            names["coat_roughness"]: coat_roughness, names["sheen"]: sheen})
        # 3.4's default IOR is 1.45, 4.x's 1.5 (import_material does the same).
        n.inputs["IOR"].default_value = import_material.PRINCIPLED_4X_IOR_DEFAULT
        self.nt.links.new(n.outputs["BSDF"], self.output.inputs["Surface"])
        return n


# ---- the materials ---------------------------------------------------------------------
# Colours are linear (Base Color), chosen against photographs; the plane is 2 m across.

def wood_planks(t):
    """Varnished oak floor: staggered planks 14 cm x 1.2 m, growth rings and fine grain."""
    planks = t.brick(t.p, 1.0, 1.2, 0.14, 0.005, offset=0.37, frequency=1, smooth=0.2)
    # Each plank's own random grey moves its rings (a different cut of the log) and tints it.
    per_plank = planks.outputs["Color"]
    q = t.vmath("ADD", t.p, t.vmath("SCALE", per_plank, scale=1.5))
    rings = t.wave(t.stretch(q, 0.2, 1.0), 6.0, distortion=5.0, detail=3.0,
                   detail_scale=1.5, kind="RINGS", direction="SPHERICAL")
    grain = t.noise(t.stretch(q, 1.5, 60.0), 1.0, detail=3.0, roughness=0.6)
    grain = t.math("MULTIPLY", grain, t.smoothstep(t.noise(q, 3.0, 2.0, 0.5), 0.4, 0.7))
    wood = t.ramp(rings, [(0.0, (0.30, 0.14, 0.055)), (0.55, (0.20, 0.09, 0.035)),
                          (1.0, (0.11, 0.045, 0.017))])
    wood = t.mix(t.math("MULTIPLY", grain, 0.5), wood, (0.10, 0.04, 0.015), "MIX")
    tint = t.ramp(per_plank, [(0.0, 0.75), (1.0, 1.15)])
    wood = t.mix(1.0, wood, tint, "MULTIPLY")
    gap = planks.outputs["Fac"]
    color = t.mix(gap, wood, (0.02, 0.012, 0.006))
    height = t.math("SUBTRACT", t.math("MULTIPLY", grain, 0.15), gap)
    normal = t.bump(height, 0.6, 0.01)
    t.principled(color, t.math("ADD", 0.35, t.math("MULTIPLY", gap, 0.5)), normal=normal,
                 coat=0.4, coat_roughness=0.15)


def marble(t):
    """Polished white Carrara marble: turbulent grey veins, fine secondary veins."""
    veins = t.wave(t.p, 1.1, distortion=9.0, detail=8.0, detail_scale=1.2,
                   detail_roughness=0.62, kind="BANDS", direction="DIAGONAL")
    fine = t.wave(t.warp(t.p, 2.0, 0.5), 2.3, distortion=6.0, detail=6.0, detail_scale=2.0,
                  detail_roughness=0.6, kind="BANDS", direction="Y")
    base = t.ramp(t.noise(t.p, 2.5, 6.0, 0.6),
                  [(0.3, (0.62, 0.62, 0.60)), (0.7, (0.78, 0.77, 0.74))])
    vein_mask = t.ramp(veins, [(0.0, 1.0), (0.09, 0.0)], "EASE", out="Color")
    color = t.mix(vein_mask, base, (0.20, 0.21, 0.23))
    fine_mask = t.ramp(fine, [(0.0, 1.0), (0.04, 0.0)], "EASE", out="Color")
    color = t.mix(t.math("MULTIPLY", fine_mask, 0.5), color, (0.30, 0.31, 0.33))
    t.principled(color, 0.06, specular=0.5, coat=0.3, coat_roughness=0.02)


def rusty_metal(t):
    """Steel plate half eaten by rust: orange-brown scaly rust over grey metal."""
    patches = t.noise(t.p, 2.2, 10.0, 0.65, distortion=0.3)
    rust_mask = t.smoothstep(patches, 0.47, 0.55)
    scale = t.noise(t.p, 22.0, 6.0, 0.7)
    rust = t.ramp(scale, [(0.3, (0.06, 0.02, 0.008)), (0.5, (0.25, 0.07, 0.02)),
                          (0.7, (0.45, 0.16, 0.04))])
    steel = t.ramp(t.noise(t.p, 6.0, 4.0, 0.5), [(0.3, (0.38, 0.38, 0.39)),
                                                (0.7, (0.55, 0.55, 0.56))])
    color = t.mix(rust_mask, steel, rust)
    metallic = t.math("SUBTRACT", 1.0, rust_mask)
    roughness = t.math("ADD", 0.3, t.math("MULTIPLY", rust_mask, 0.6))
    height = t.math("MULTIPLY", rust_mask, t.math("ADD", 0.5, t.math("MULTIPLY", scale, 0.5)))
    t.principled(color, roughness, metallic=metallic, normal=t.bump(height, 0.5, 0.01))


def ceramic_tiles(t):
    """Glazed teal wall tiles 25 cm square, light grout, faint glaze variation."""
    tiles = t.brick(t.p, 1.0, 0.25, 0.25, 0.012, color1=(0.025, 0.16, 0.18),
                    color2=(0.04, 0.22, 0.23), smooth=0.3, offset=0.0, frequency=1)
    glaze = t.noise(t.p, 9.0, 4.0, 0.5)
    tile = t.mix(t.math("MULTIPLY", glaze, 0.35), tiles.outputs["Color"], (0.08, 0.28, 0.28))
    grout = tiles.outputs["Fac"]
    color = t.mix(grout, tile, (0.50, 0.48, 0.44))
    roughness = t.math("ADD", 0.05, t.math("MULTIPLY", grout, 0.8))
    height = t.math("ADD", t.math("SUBTRACT", 1.0, grout), t.math("MULTIPLY", glaze, 0.02))
    t.principled(color, roughness, normal=t.bump(height, 1.0, 0.004), specular=0.6)


def leather(t):
    """Brown pebbled leather: irregular rounded grains with dark creases, soft sheen."""
    cells = t.voronoi(t.warp(t.p, 6.0, 0.08), 16.0, feature="DISTANCE_TO_EDGE")
    grain = t.smoothstep(cells.outputs["Distance"], 0.0, 0.22)
    mottle = t.noise(t.p, 3.0, 5.0, 0.6)
    base = t.ramp(mottle, [(0.35, (0.055, 0.022, 0.010)), (0.65, (0.12, 0.05, 0.022))])
    color = t.mix(t.math("SUBTRACT", 1.0, grain), base, (0.02, 0.008, 0.004))
    roughness = t.math("SUBTRACT", 0.75, t.math("MULTIPLY", grain, 0.3))
    t.principled(color, roughness, normal=t.bump(grain, 0.7, 0.006), sheen=0.3)


def concrete(t):
    """Cast concrete: grey mottling, fine aggregate speckle and small air holes."""
    mottle = t.noise(t.p, 1.8, 8.0, 0.7)
    speckle = t.noise(t.p, 40.0, 3.0, 0.7)
    base = t.ramp(mottle, [(0.3, (0.17, 0.165, 0.15)), (0.7, (0.36, 0.35, 0.33))])
    base = t.mix(t.smoothstep(speckle, 0.45, 0.7), base, (0.10, 0.095, 0.09))
    stains = t.smoothstep(t.noise(t.p, 4.0, 6.0, 0.6, distortion=0.5), 0.55, 0.7)
    base = t.mix(t.math("MULTIPLY", stains, 0.5), base, (0.13, 0.12, 0.10))
    holes = t.voronoi(t.p, 9.0)
    # A hole around a third of the cells' centres (those whose random red is high).
    red = t.node("ShaderNodeSeparateColor", {0: holes.outputs["Color"]}).outputs[0]
    is_hole = t.math("GREATER_THAN", red, 0.6)
    hole = t.math("MULTIPLY", t.ramp(holes.outputs["Distance"], [(0.09, 1.0), (0.13, 0.0)],
                                      "EASE", out="Color"), is_hole)
    color = t.mix(hole, base, (0.04, 0.04, 0.035))
    height = t.math("SUBTRACT", t.math("MULTIPLY", speckle, 0.3), hole)
    t.principled(color, 0.9, normal=t.bump(height, 0.5, 0.006), specular=0.3)


def brick_wall(t):
    """Red clay brick wall in running bond, grey recessed mortar, dirt and surface pits."""
    bricks = t.brick(t.p, 1.0, 0.24, 0.085, 0.012, color1=(0.20, 0.05, 0.025),
                     color2=(0.38, 0.11, 0.05), smooth=0.15, offset=0.5, frequency=2)
    dirt = t.noise(t.p, 10.0, 6.0, 0.65)
    face = t.mix(t.math("MULTIPLY", dirt, 0.6), bricks.outputs["Color"], (0.10, 0.05, 0.03))
    mortar = bricks.outputs["Fac"]
    grit = t.noise(t.p, 60.0, 2.0, 0.5)
    color = t.mix(mortar, face, t.mix(grit, (0.30, 0.29, 0.27), (0.45, 0.44, 0.41)))
    height = t.math("ADD", t.math("SUBTRACT", 1.0, mortar), t.math("MULTIPLY", dirt, 0.15))
    t.principled(color, 0.85, normal=t.bump(height, 0.8, 0.008), specular=0.3)


def woven_fabric(t):
    """Plain-weave cotton: blue warp over lighter weft in alternate cells, 5 cm threads
    (coarse, so that the weave is resolved at 7.8 mm a pixel)."""
    q = t.warp(t.p, 3.0, 0.02)
    xyz = t.node("ShaderNodeSeparateXYZ", {"Vector": q})
    u = t.math("MULTIPLY", xyz.outputs["X"], 20.0)
    v = t.math("MULTIPLY", xyz.outputs["Y"], 20.0)
    # Cross-sections: sin(pi * fract(u)) is 0 between threads, 1 on a thread's axis.
    across_warp = t.math("SINE", t.math("MULTIPLY", t.math("FRACT", u), math.pi))
    across_weft = t.math("SINE", t.math("MULTIPLY", t.math("FRACT", v), math.pi))
    # Plain weave: the warp is on top where floor(u) + floor(v) is odd.
    parity = t.math("MULTIPLY", t.math("FRACT", t.math("MULTIPLY", t.math(
        "ADD", t.math("FLOOR", u), t.math("FLOOR", v)), 0.5)), 2.0)
    height = t.mix(parity, across_weft, across_warp)
    fibre = t.noise(t.stretch(q, 12.0, 12.0), 6.0, 3.0, 0.6)
    thread_color = t.mix(parity, (0.20, 0.24, 0.34), (0.035, 0.06, 0.16))
    shade = t.ramp(height, [(0.0, 0.25), (0.6, 0.85), (1.0, 1.0)])
    color = t.mix(1.0, t.mix(t.math("MULTIPLY", fibre, 0.3), thread_color, (0.5, 0.5, 0.5),
                             "OVERLAY"), shade, "MULTIPLY")
    t.principled(color, 0.85, normal=t.bump(height, 0.7, 0.01), sheen=0.6, specular=0.3)


def brushed_metal(t):
    """Brushed aluminium: fine streaks along x, anisotropic highlight."""
    streaks = t.noise(t.stretch(t.p, 1.5, 60.0), 1.0, 6.0, 0.6)
    coarse = t.noise(t.stretch(t.p, 0.6, 8.0), 1.0, 3.0, 0.5)
    s = t.math("ADD", t.math("MULTIPLY", streaks, 0.7), t.math("MULTIPLY", coarse, 0.3))
    color = t.ramp(s, [(0.3, (0.48, 0.49, 0.50)), (0.7, (0.66, 0.66, 0.67))])
    roughness = t.math("ADD", 0.18, t.math("MULTIPLY", s, 0.15))
    bsdf = t.principled(color, roughness, metallic=1.0, normal=t.bump(streaks, 0.15, 0.003),
                        anisotropic=0.7)
    # Without a tangent Cycles uses a radial one (a ring-shaped highlight): brush along x.
    tangent = t.node("ShaderNodeTangent", direction_type="UV_MAP", uv_map="UVMap")
    t.set(bsdf.inputs["Tangent"], tangent.outputs["Tangent"])


def terrazzo(t):
    """Polished terrazzo: cream cement with marble chips of several colours and sizes."""
    cement = t.ramp(t.noise(t.p, 20.0, 3.0, 0.5), [(0.3, (0.50, 0.47, 0.41)),
                                                  (0.7, (0.58, 0.55, 0.49))])
    palette = [(0.0, (0.75, 0.74, 0.70)), (0.3, (0.03, 0.03, 0.03)), (0.5, (0.35, 0.09, 0.05)),
               (0.7, (0.12, 0.22, 0.13)), (0.85, (0.30, 0.30, 0.31))]
    color = cement
    for scale, radius, amount in ((9.0, 0.38, 0.15), (28.0, 0.32, 0.08)):
        chips = t.voronoi(t.warp(t.p, scale * 0.5, amount), scale)
        # Voronoi's random cell colour -> a palette entry (constant ramp over its green).
        green = t.node("ShaderNodeSeparateColor", {0: chips.outputs["Color"]}).outputs[1]
        chip_color = t.ramp(green, palette, "CONSTANT")
        inside = t.ramp(chips.outputs["Distance"], [(radius - 0.02, 1.0), (radius, 0.0)],
                        out="Color")
        color = t.mix(inside, color, chip_color)
    t.principled(color, 0.12, specular=0.5, coat=0.2, coat_roughness=0.05)


def tree_bark(t):
    """Pine-like bark: vertical plates split by deep dark cracks, some green lichen."""
    q = t.warp(t.stretch(t.p, 1.0, 0.28), 4.0, 0.12)
    plates = t.voronoi(q, 7.0, feature="DISTANCE_TO_EDGE")
    crack = t.ramp(plates.outputs["Distance"], [(0.0, 1.0), (0.2, 0.0)], "EASE", out="Color")
    ridges = t.fractal("RIDGED_MULTIFRACTAL", t.stretch(t.p, 3.0, 0.6), 4.0, 5.0, 0.5,
                       lacunarity=2.0, offset=1.0, gain=2.0)
    base = t.ramp(t.noise(t.p, 8.0, 5.0, 0.6), [(0.3, (0.07, 0.05, 0.035)),
                                               (0.7, (0.20, 0.15, 0.10))])
    lichen = t.smoothstep(t.noise(t.p, 2.5, 6.0, 0.6), 0.58, 0.64)
    base = t.mix(lichen, base, (0.17, 0.20, 0.09))
    color = t.mix(crack, base, (0.012, 0.009, 0.006))
    height = t.math("SUBTRACT", t.math("MULTIPLY", ridges, 0.3), crack)
    t.principled(color, 0.9, normal=t.bump(height, 0.9, 0.02), specular=0.3)


def rocky_ground(t):
    """Gravel and stones on dark soil: rounded stones of varied grey-brown, sand between."""
    stones = t.voronoi(t.warp(t.p, 3.0, 0.1), 7.0, feature="DISTANCE_TO_EDGE")
    cells = t.voronoi(t.warp(t.p, 3.0, 0.1), 7.0)
    edge = stones.outputs["Distance"]
    stone_mask = t.smoothstep(edge, 0.04, 0.08)
    shade = t.node("ShaderNodeSeparateColor", {0: cells.outputs["Color"]}).outputs[0]
    stone = t.ramp(shade, [(0.0, (0.12, 0.11, 0.10)), (0.5, (0.30, 0.28, 0.25)),
                           (1.0, (0.24, 0.18, 0.12))])
    speck = t.noise(t.p, 90.0, 2.0, 0.5)
    soil = t.ramp(speck, [(0.3, (0.04, 0.03, 0.02)), (0.7, (0.14, 0.11, 0.07))])
    color = t.mix(stone_mask, soil, stone)
    height = t.math("ADD", t.ramp(edge, [(0.03, 0.0), (0.3, 1.0)], "EASE", out="Color"),
                    t.math("MULTIPLY", speck, 0.05))
    t.principled(color, 0.85, normal=t.bump(height, 0.9, 0.03), specular=0.3)


def painted_metal(t):
    """Red painted steel, scratched in two directions and chipped to rusty bare metal."""
    chips = t.noise(t.p, 3.5, 10.0, 0.65, distortion=0.2)
    bare = t.smoothstep(chips, 0.59, 0.61)
    scratches = None
    for angle, seed in ((0.35, 0.0), (-0.9, 11.0)):
        rot = t.node("ShaderNodeVectorRotate", {"Vector": t.p, "Angle": angle},
                     rotation_type="Z_AXIS").outputs["Vector"]
        n = t.noise(t.vmath("ADD", t.stretch(rot, 0.6, 14.0), (seed, seed, 0.0)), 1.0,
                    2.0, 0.5)
        line = t.ramp(t.math("ABSOLUTE", t.math("SUBTRACT", n, 0.5)), [(0.0, 1.0),
                                                                      (0.012, 0.0)],
                      out="Color")
        patchy = t.smoothstep(t.noise(t.p, 2.0, 2.0, 0.5), 0.5, 0.6)
        line = t.math("MULTIPLY", line, patchy)
        scratches = line if scratches is None else t.math("MAXIMUM", scratches, line)
    metal_mask = t.math("MAXIMUM", bare, scratches)
    paint = t.ramp(t.noise(t.p, 5.0, 3.0, 0.5), [(0.3, (0.30, 0.025, 0.015)),
                                                (0.7, (0.38, 0.04, 0.02))])
    rust_edge = t.math("MULTIPLY", t.smoothstep(chips, 0.57, 0.6),
                       t.math("SUBTRACT", 1.0, t.smoothstep(chips, 0.61, 0.68)))
    metal = t.mix(rust_edge, (0.45, 0.45, 0.46), (0.22, 0.07, 0.02))
    color = t.mix(metal_mask, paint, metal)
    metallic = t.math("MULTIPLY", metal_mask, t.math("SUBTRACT", 1.0, rust_edge))
    roughness = t.mix(metal_mask, 0.3, 0.45)
    height = t.math("SUBTRACT", 1.0, metal_mask)
    t.principled(color, roughness, metallic=metallic, normal=t.bump(height, 0.4, 0.003),
                 coat=0.2, coat_roughness=0.1)


def sand(t):
    """Wind-rippled beach sand: ripples 17 cm apart, grainy speckle."""
    ripples = t.wave(t.warp(t.p, 1.5, 0.25), 1.8, distortion=3.0, detail=2.0,
                     detail_scale=1.0, kind="BANDS", direction="X", profile="SIN")
    speck = t.noise(t.p, 80.0, 2.0, 0.6)
    base = t.ramp(t.noise(t.p, 2.0, 4.0, 0.5), [(0.3, (0.40, 0.30, 0.17)),
                                               (0.7, (0.50, 0.39, 0.23))])
    color = t.mix(t.math("MULTIPLY", speck, 0.4), base, (0.22, 0.16, 0.09))
    height = t.math("ADD", ripples, t.math("MULTIPLY", speck, 0.08))
    t.principled(color, 0.95, normal=t.bump(height, 1.0, 0.04), specular=0.3)


# ---- a second set (session 14), written before any model was run on it --------------
# Held out from every design decision that followed: the evaluation reports it apart.

def cobblestone(t):
    """Rounded grey-brown cobbles 12-20 cm across in dark sandy joints, worn tops."""
    q = t.warp(t.p, 2.5, 0.06)
    cells = t.voronoi(q, 6.5, feature="DISTANCE_TO_EDGE", randomness=0.8)
    ids = t.voronoi(q, 6.5, randomness=0.8)
    edge = cells.outputs["Distance"]
    stone = t.smoothstep(edge, 0.03, 0.09)
    shade = t.node("ShaderNodeSeparateColor", {0: ids.outputs["Color"]}).outputs[1]
    base = t.ramp(shade, [(0.0, (0.10, 0.095, 0.085)), (0.6, (0.22, 0.20, 0.17)),
                          (1.0, (0.28, 0.22, 0.16))])
    wear = t.noise(t.p, 25.0, 4.0, 0.6)
    base = t.mix(t.math("MULTIPLY", wear, 0.35), base, (0.06, 0.055, 0.05))
    joint = t.ramp(t.noise(t.p, 70.0, 2.0, 0.5), [(0.3, (0.05, 0.04, 0.03)),
                                                 (0.7, (0.12, 0.10, 0.07))])
    color = t.mix(stone, joint, base)
    dome = t.ramp(edge, [(0.02, 0.0), (0.35, 1.0)], "EASE", out="Color")
    height = t.math("ADD", dome, t.math("MULTIPLY", wear, 0.08))
    t.principled(color, t.math("SUBTRACT", 0.9, t.math("MULTIPLY", stone, 0.3)),
                 normal=t.bump(height, 0.9, 0.03), specular=0.35)


def vertical_boards(t):
    """Painted pine cladding: vertical boards 11 cm wide, dark joints, grain along y."""
    xyz = t.node("ShaderNodeSeparateXYZ", {"Vector": t.p})
    # The boards run along y: swap the axes before the brick pattern (rows along x).
    turned = t.node("ShaderNodeCombineXYZ", {"X": xyz.outputs["Y"], "Y": xyz.outputs["X"],
                                             "Z": xyz.outputs["Z"]}).outputs["Vector"]
    boards = t.brick(turned, 1.0, 2.5, 0.11, 0.004, offset=0.0, frequency=1, smooth=0.3)
    per_board = boards.outputs["Color"]
    q = t.vmath("ADD", t.p, t.vmath("SCALE", per_board, scale=2.0))
    grain = t.wave(t.stretch(q, 1.0, 0.12), 9.0, distortion=4.0, detail=2.0,
                   detail_scale=1.0, kind="BANDS", direction="X")
    paint = t.ramp(grain, [(0.0, (0.46, 0.52, 0.50)), (1.0, (0.36, 0.43, 0.42))])
    tint = t.ramp(per_board, [(0.0, 0.85), (1.0, 1.1)])
    paint = t.mix(1.0, paint, tint, "MULTIPLY")
    gap = boards.outputs["Fac"]
    color = t.mix(gap, paint, (0.04, 0.045, 0.045))
    height = t.math("SUBTRACT", t.math("MULTIPLY", grain, 0.1), gap)
    t.principled(color, 0.55, normal=t.bump(height, 0.6, 0.008), specular=0.4)


def granite(t):
    """Polished pink granite: feldspar, quartz and black mica grains 1-3 cm."""
    coarse = t.voronoi(t.warp(t.p, 8.0, 0.03), 38.0)
    fine = t.voronoi(t.p, 90.0)
    g1 = t.node("ShaderNodeSeparateColor", {0: coarse.outputs["Color"]}).outputs[0]
    g2 = t.node("ShaderNodeSeparateColor", {0: fine.outputs["Color"]}).outputs[2]
    mineral = t.ramp(g1, [(0.0, (0.42, 0.25, 0.20)), (0.45, (0.55, 0.36, 0.30)),
                          (0.7, (0.60, 0.58, 0.55)), (0.85, (0.02, 0.02, 0.02))], "CONSTANT")
    mica = t.math("GREATER_THAN", g2, 0.82)
    color = t.mix(mica, mineral, (0.015, 0.015, 0.015))
    cloud = t.noise(t.p, 1.5, 3.0, 0.5)
    color = t.mix(t.math("MULTIPLY", cloud, 0.25), color, (0.30, 0.22, 0.20))
    t.principled(color, 0.08, specular=0.5, coat=0.3, coat_roughness=0.03)


def slate_tiles(t):
    """Dark slate floor tiles 30 x 30 cm in a stacked grid, each its own grey, riven face."""
    tiles = t.brick(t.p, 1.0, 0.30, 0.30, 0.008, color1=(0.035, 0.038, 0.042),
                    color2=(0.09, 0.095, 0.10), smooth=0.2, offset=0.0, frequency=1)
    cleft = t.fractal("RIDGED_MULTIFRACTAL", t.stretch(t.p, 1.0, 2.5), 5.0, 4.0, 0.55,
                      lacunarity=2.0, offset=1.0, gain=2.0)
    face = t.mix(t.math("MULTIPLY", t.noise(t.p, 12.0, 4.0, 0.6), 0.4),
                 tiles.outputs["Color"], (0.13, 0.13, 0.14))
    grout = tiles.outputs["Fac"]
    color = t.mix(grout, face, (0.20, 0.19, 0.17))
    height = t.math("ADD", t.math("SUBTRACT", 1.0, grout), t.math("MULTIPLY", cleft, 0.05))
    t.principled(color, t.math("ADD", 0.45, t.math("MULTIPLY", grout, 0.4)),
                 normal=t.bump(height, 0.7, 0.01), specular=0.4)


def corrugated_metal(t):
    """Galvanised corrugated steel: ribs along y, 7.9 cm apart, zinc spangle, white rust."""
    # Wave bands: period 2 pi / (20 scale) m; 4.0 puts the floor's 0.37 m shift 0.29 of a
    # period off a rib (4.2 would land within 0.05 of one: the ribs would not move).
    ribs = t.wave(t.p, 4.0, kind="BANDS", direction="X", profile="SIN")
    spangle = t.voronoi(t.p, 14.0)
    sp = t.node("ShaderNodeSeparateColor", {0: spangle.outputs["Color"]}).outputs[0]
    zinc = t.ramp(sp, [(0.0, (0.50, 0.52, 0.53)), (1.0, (0.66, 0.67, 0.68))])
    stain = t.smoothstep(t.noise(t.p, 3.0, 6.0, 0.6), 0.6, 0.68)
    color = t.mix(stain, zinc, (0.55, 0.55, 0.52))
    metallic = t.math("SUBTRACT", 1.0, stain)
    roughness = t.math("ADD", 0.25, t.math("MULTIPLY", sp, 0.15))
    roughness = t.math("ADD", roughness, t.math("MULTIPLY", stain, 0.5))
    t.principled(color, roughness, metallic=metallic, normal=t.bump(ribs, 1.0, 0.03))


def stucco(t):
    """Off-white sprayed stucco wall: soft lumps, flattened tops, faint dirt."""
    lumps = t.noise(t.p, 18.0, 5.0, 0.6)
    flat = t.math("MINIMUM", lumps, 0.58)
    dirt = t.noise(t.p, 1.2, 4.0, 0.5)
    base = t.ramp(lumps, [(0.35, (0.52, 0.50, 0.46)), (0.6, (0.66, 0.64, 0.60))])
    color = t.mix(t.smoothstep(dirt, 0.55, 0.8), base, (0.42, 0.39, 0.34))
    t.principled(color, 0.9, normal=t.bump(flat, 0.7, 0.02), specular=0.3)


def asphalt(t):
    """Worn asphalt: black binder, grey aggregate chips 5-15 mm, light wear patches."""
    chips = t.voronoi(t.p, 60.0)
    c = t.node("ShaderNodeSeparateColor", {0: chips.outputs["Color"]}).outputs[0]
    inside = t.ramp(chips.outputs["Distance"], [(0.25, 1.0), (0.45, 0.0)], out="Color")
    stone = t.ramp(c, [(0.0, (0.05, 0.05, 0.05)), (1.0, (0.22, 0.21, 0.20))])
    binder = (0.02, 0.02, 0.02)
    color = t.mix(inside, binder, stone)
    wear = t.smoothstep(t.noise(t.p, 2.0, 5.0, 0.6), 0.5, 0.7)
    color = t.mix(t.math("MULTIPLY", wear, 0.5), color, (0.16, 0.15, 0.14))
    height = t.math("ADD", inside, t.math("MULTIPLY", t.noise(t.p, 150.0, 2.0, 0.5), 0.2))
    t.principled(color, 0.85, normal=t.bump(height, 0.8, 0.006), specular=0.3)


def moss(t):
    """Moss cushion on stone: green tufts, brown dry patches, stone showing through."""
    tufts = t.noise(t.p, 30.0, 6.0, 0.65)
    patches = t.noise(t.p, 2.0, 5.0, 0.6, distortion=0.4)
    green = t.ramp(tufts, [(0.3, (0.03, 0.06, 0.01)), (0.7, (0.12, 0.20, 0.03))])
    dry = t.ramp(tufts, [(0.3, (0.08, 0.06, 0.02)), (0.7, (0.22, 0.16, 0.06))])
    col = t.mix(t.smoothstep(patches, 0.55, 0.65), green, dry)
    bare = t.smoothstep(patches, 0.3, 0.34)
    color = t.mix(bare, (0.16, 0.16, 0.15), col)
    height = t.math("MULTIPLY", tufts, bare)
    t.principled(color, 0.95, normal=t.bump(height, 1.0, 0.02), specular=0.2, sheen=0.3)



# name -> builder; the docstring's first line is the description (README, --list).
MATERIALS = {f.__name__: f for f in (
    wood_planks, marble, rusty_metal, ceramic_tiles, leather, concrete, brick_wall,
    woven_fabric, brushed_metal, terrazzo, tree_bark, rocky_ground, painted_metal, sand,
    # the second set (session 14)
    cobblestone, vertical_boards, granite, slate_tiles, corrugated_metal, stucco, asphalt,
    moss)}


def build_material(name, major=None):
    """A new material NAME built by its function; raises KeyError for an unknown name."""
    fn = MATERIALS[name]
    mat = bpy.data.materials.new(name)
    fn(Tree(mat, major or import_material.blender_major()))
    return mat


def mapping_node(mat):
    """The material's one Mapping node (the texture coordinates' only way in)."""
    return mat.node_tree.nodes[MAPPING_NAME]


def describe(name):
    return " ".join(MATERIALS[name].__doc__.split())


def _main(argv):
    import argparse
    p = argparse.ArgumentParser(prog="handmade_materials.py")
    p.add_argument("names", nargs="*", help="materials (default: all)")
    p.add_argument("--list", action="store_true", help="print the names and descriptions")
    p.add_argument("--save", help="write the materials to this .blend")
    p.add_argument("--scene", action="store_true",
                   help="with --save: also build DESIGN.md's scene, the first material on the plane")
    a = p.parse_args(argv)
    unknown = [n for n in a.names if n not in MATERIALS]
    if unknown:
        print("handmade_materials: error: unknown material(s) %s; --list gives the names"
              % ", ".join(unknown), file=sys.stderr)
        sys.exit(2)
    names = a.names or list(MATERIALS)
    if a.list:
        for n in names:
            print("%-14s %s" % (n, describe(n)))
    if a.save:
        for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.lights,
                     bpy.data.cameras):
            for block in list(coll):
                coll.remove(block)
        mats = [build_material(n) for n in names]
        for m in mats:
            m.use_fake_user = True
        if a.scene:
            import_material.build_scene(bpy.context.scene, mats[0])
        tmp = os.path.abspath(a.save) + ".tmp.blend"
        bpy.ops.wm.save_as_mainfile(filepath=tmp)
        os.replace(tmp, os.path.abspath(a.save))
        print("handmade_materials: wrote %s (%d materials, Blender %s)"
              % (a.save, len(mats), bpy.app.version_string))
    if not a.list and not a.save:
        print("handmade_materials: nothing to do (--list or --save)", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    _main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
