#!/usr/bin/env python3
"""Reference cases for the colour and converter nodes (kernels/color.c, kernels/convert.c):
Mix (FLOAT, VECTOR uniform / non-uniform, RGBA with every blend mode and both clamps),
legacy MixRGB, Invert, Color Ramp (every interpolation, colour mode and hue path),
Combine/Separate XYZ, Combine/Separate Color (RGB, HSV, HSL) and Mapping (all types).

Run from anywhere: python3 tests/reference/nodes/gen_color.py
Then render the missing references with blender/render_node_references.py.

Inputs. casekit's pixel_xy() gives snapped pixel-centre coordinates u = (i + 0.5) / 128,
v = (j + 0.5) / 128; sweep() maps one onto start + i * step with step a power of two, so
the sweeps hit exact 0, 0.5 and 1 (the branch points of Overlay, Dodge, Divide, HSV ...)
and go beyond [0, 1] on both sides. Factors sweep across x + y, outside [0, 1], with
clamp_factor off unless a case says otherwise.

Color Ramp. Cycles never evaluates a ramp: Blender samples it into a table (3.4: 256
entries at i / 255; 4.3: 257 entries at i / 256) and Cycles interpolates the table
linearly (not at all for CONSTANT). The ramp's Fac here is a fine sweep (x sweep plus a
128 times finer y sweep) over [-0.1, 1.1], so every table interval is seen many times.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from casekit import Graph, write_case  # noqa: E402

BOTH = ("3.4", "4.3")
N = 128  # pixels per side of a reference image

BLEND_TYPES = ["MIX", "DARKEN", "MULTIPLY", "BURN", "LIGHTEN", "SCREEN", "DODGE", "ADD",
               "OVERLAY", "SOFT_LIGHT", "LINEAR_LIGHT", "DIFFERENCE", "EXCLUSION", "SUBTRACT",
               "DIVIDE", "HUE", "SATURATION", "COLOR", "VALUE"]
ONLY_4X_BLENDS = {"EXCLUSION"}


def sweep(g, s, start, step):
    """Value start + i * step at pixel i of coordinate socket s (exact for step 2^-k)."""
    lo = start - 0.5 * step
    return g.map_range(s, lo, lo + N * step)


class Case:
    def __init__(self):
        self.g = Graph()
        self.x, self.y = self.g.pixel_xy()

    def set(self, node, socket, value):
        """Link a socket reference, or set a constant."""
        if isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], str):
            self.g.link(value, (node, socket))
        else:
            self.g.set_input(node, socket, value)

    def node(self, idname, properties=None, **inputs):
        n = self.g.node(idname, properties=properties or {})
        for sock, v in inputs.items():
            self.set(n, sock, v)
        return n

    def sx(self, start, step):
        return sweep(self.g, self.x, start, step)

    def sy(self, start, step):
        return sweep(self.g, self.y, start, step)

    def math(self, op, a, b):
        n = self.node("ShaderNodeMath", {"operation": op})
        self.set(n, "Value", a)
        self.set(n, "Value_001", b)
        return (n, "Value")

    def diagonal(self, start, step):
        """start + (i + j) * step: varies along both axes."""
        return self.math("ADD", self.sx(start, step), self.sy(0.0, step))

    def fine(self, start, step):
        """x sweep of `step` plus a y sweep of step/128: 16384 distinct values."""
        return self.math("ADD", self.sx(start, step), self.sy(0.0, step / N))

    def xyz(self, x, y, z):
        n = self.node("ShaderNodeCombineXYZ")
        for sock, v in (("X", x), ("Y", y), ("Z", z)):
            self.set(n, sock, v)
        return (n, "Vector")

    def write(self, name, socket, note, versions=BOTH):
        write_case(name, self.g, socket=socket, versions=versions, tolerance=1e-4,
                   max_bad_fraction=0.0, note=note)


# ---- Mix ------------------------------------------------------------------------------

def mix_rgba_case(blend, clamp_factor=False, clamp_result=False, suffix=""):
    k = Case()
    a = k.sx(-0.25, 1.0 / 64)     # [-0.25, 1.73): exact 0, 0.5, 1
    b = k.sy(-0.25, 1.0 / 64)
    fac = k.diagonal(-0.5, 1.0 / 128)  # [-0.5, 1.5)
    n = k.node("ShaderNodeMix", {"data_type": "RGBA", "blend_type": blend,
                                 "clamp_factor": clamp_factor, "clamp_result": clamp_result})
    k.set(n, "Factor_Float", fac)
    k.set(n, "A_Color", k.xyz(a, b, 0.5))
    k.set(n, "B_Color", k.xyz(b, a, 0.0))
    versions = ("4.3",) if blend in ONLY_4X_BLENDS else BOTH
    k.write("mix_rgba_%s%s" % (blend.lower(), suffix), (n, "Result_Color"),
            "Mix RGBA %s, clamp_factor %s, clamp_result %s; A = (a, b, 0.5), B = (b, a, 0) with "
            "a = x sweep, b = y sweep over [-0.25, 1.73); factor = diagonal sweep [-0.5, 1.5).%s"
            % (blend, clamp_factor, clamp_result,
               " EXCLUSION exists only in Blender 4.x." if blend in ONLY_4X_BLENDS else ""),
            versions)


def mix_cases():
    for blend in BLEND_TYPES:
        mix_rgba_case(blend)
    for blend in ("ADD", "LINEAR_LIGHT", "DODGE", "HUE"):
        mix_rgba_case(blend, clamp_factor=True, clamp_result=True, suffix="_clamped")

    k = Case()
    a = k.sx(-2.0, 1.0 / 32)
    b = k.sy(-1.0, 1.0 / 64)
    fac = k.diagonal(-0.5, 1.0 / 128)
    free = k.node("ShaderNodeMix", {"data_type": "FLOAT", "clamp_factor": False})
    clamped = k.node("ShaderNodeMix", {"data_type": "FLOAT", "clamp_factor": True})
    for n in (free, clamped):
        k.set(n, "Factor_Float", fac)
        k.set(n, "A_Float", a)
        k.set(n, "B_Float", b)
    k.write("mix_float", k.xyz((free, "Result_Float"), (clamped, "Result_Float"), fac),
            "Mix FLOAT with clamp_factor off (X) and on (Y); Z is the factor itself.")

    k = Case()
    a = k.sx(-2.0, 1.0 / 32)
    b = k.sy(-1.0, 1.0 / 64)
    fac = k.diagonal(-0.5, 1.0 / 128)
    n = k.node("ShaderNodeMix", {"data_type": "VECTOR", "factor_mode": "UNIFORM",
                                 "clamp_factor": False})
    k.set(n, "Factor_Float", fac)
    k.set(n, "A_Vector", k.xyz(a, b, 1.0))
    k.set(n, "B_Vector", k.xyz(b, a, -2.0))
    k.write("mix_vector_uniform", (n, "Result_Vector"),
            "Mix VECTOR, uniform factor (diagonal sweep [-0.5, 1.5)), clamp_factor off.")

    for clamp in (False, True):
        k = Case()
        a = k.sx(-2.0, 1.0 / 32)
        b = k.sy(-1.0, 1.0 / 64)
        fac = k.diagonal(-0.5, 1.0 / 128)
        n = k.node("ShaderNodeMix", {"data_type": "VECTOR", "factor_mode": "NON_UNIFORM",
                                     "clamp_factor": clamp})
        k.set(n, "Factor_Vector", k.xyz(fac, b, a))
        k.set(n, "A_Vector", k.xyz(a, b, 1.0))
        k.set(n, "B_Vector", k.xyz(b, 3.0, -2.0))
        k.write("mix_vector_non_uniform%s" % ("_clamped" if clamp else ""), (n, "Result_Vector"),
                "Mix VECTOR, non-uniform factor (fac, b, a) outside [0, 1], clamp_factor %s."
                % clamp)

    for blend, use_clamp in (("MIX", False), ("OVERLAY", True), ("SOFT_LIGHT", False),
                             ("COLOR", True), ("BURN", False)):
        k = Case()
        a = k.sx(-0.25, 1.0 / 64)
        b = k.sy(-0.25, 1.0 / 64)
        fac = k.diagonal(-0.5, 1.0 / 128)
        n = k.node("ShaderNodeMixRGB", {"blend_type": blend, "use_clamp": use_clamp})
        k.set(n, "Fac", fac)
        k.set(n, "Color1", k.xyz(a, b, 0.5))
        k.set(n, "Color2", k.xyz(b, a, 0.0))
        k.write("mixrgb_%s" % blend.lower(), (n, "Color"),
                "Legacy MixRGB %s, use_clamp %s: Cycles clamps this node's factor to [0, 1] "
                "always (factor sweeps [-0.5, 1.5))." % (blend, use_clamp))

    k = Case()
    a = k.sx(-0.25, 1.0 / 64)
    fac = k.diagonal(-0.5, 1.0 / 128)
    n = k.node("ShaderNodeMixRGB", {"blend_type": "ADD", "use_alpha": True})
    k.set(n, "Fac", fac)
    k.set(n, "Color1", k.xyz(a, 0.25, 0.5))
    k.set(n, "Color2", [0.9, 0.2, 0.1, 0.3])
    k.write("mixrgb_use_alpha", (n, "Color"),
            "Legacy MixRGB ADD with use_alpha and an unlinked Color2 of alpha 0.3: Cycles "
            "has no alpha in colour values and ignores use_alpha.")


# ---- Invert ---------------------------------------------------------------------------

def invert_cases():
    k = Case()
    a = k.sx(-0.25, 1.0 / 64)
    b = k.sy(-0.25, 1.0 / 64)
    fac = k.diagonal(-0.5, 1.0 / 128)
    n = k.node("ShaderNodeInvert")
    k.set(n, "Fac", fac)
    k.set(n, "Color", k.xyz(a, b, 2.0))
    k.write("invert", (n, "Color"), "Invert with Fac over [-0.5, 1.5) and colours outside [0, 1].")


# ---- Color Ramp -------------------------------------------------------------------------

def el(position, r, g, b, a=1.0):
    return {"position": position, "color": [r, g, b, a]}


# Stops at both ends and a coincident pair (a step) in the middle.
RAMP_ENDS = [el(0.0, 0.05, 0.1, 0.9, 1.0), el(0.3, 0.9, 0.2, 0.1, 0.6),
             el(0.55, 0.2, 0.95, 0.3, 0.2), el(0.55, 1.0, 1.0, 0.0, 0.9),
             el(1.0, 0.1, 0.0, 0.3, 0.4)]
# Interior stops only: the ends extend (LINEAR/EASE/CONSTANT clamp, the splines reach
# past the first and last stop).
RAMP_INTERIOR = [el(0.15, 0.8, 0.1, 0.1, 0.3), el(0.4, 0.1, 0.7, 0.9, 1.0),
                 el(0.7, 0.95, 0.9, 0.2, 0.5), el(0.85, 0.0, 0.3, 0.1, 0.8)]
# Distinct hues, a grey stop and two stops of the same hue (FAR goes round the circle).
RAMP_HUES = [el(0.05, 1.0, 0.1, 0.1), el(0.3, 0.2, 0.3, 1.0), el(0.5, 0.5, 0.5, 0.5, 0.5),
             el(0.6, 0.1, 0.9, 0.3), el(0.8, 0.9, 0.8, 0.1), el(0.95, 0.6, 0.2, 0.2, 0.2)]


# Channels outside [0, 1] (Blender clamps the negative ones to 0 when it stores them).
RAMP_HDR = [el(0.1, 2.5, 0.2, -0.4, 1.0), el(0.35, 0.3, 1.8, 0.6, 3.0),
            el(0.6, -1.0, 0.5, 4.0, -0.5), el(0.9, 1.2, 1.2, 0.9, 0.7)]


def _ramp_32():
    """32 stops with positions from a fixed quadratic sequence, two of them coincident."""
    els = []
    for i in range(32):
        pos = round((i * i) / (31.0 * 31.0), 6)
        if i == 17:
            pos = els[-1]["position"]
        els.append(el(pos, (i * 7 % 11) / 10.0, (i * 5 % 13) / 12.0, (i * 3 % 7) / 6.0,
                      (i % 4) / 3.0))
    return els


RAMP_32 = _ramp_32()


def ramp_case(name, interpolation, elements, color_mode="RGB", hue="NEAR", socket="Color",
              note=""):
    k = Case()
    fac = k.fine(-0.1, 1.2 / N)   # [-0.1, 1.1) in 16384 steps
    n = k.node("ShaderNodeValToRGB")
    k.g.set_color_ramp(n, {"interpolation": interpolation, "color_mode": color_mode,
                           "hue_interpolation": hue, "elements": elements})
    k.set(n, "Fac", fac)
    k.write(name, (n, socket),
            "Color Ramp %s, %s, hue %s, output %s; Fac a fine sweep over [-0.1, 1.1). %s"
            % (interpolation, color_mode, hue, socket, note))


def ramp_cases():
    for interp in ("EASE", "CARDINAL", "LINEAR", "B_SPLINE", "CONSTANT"):
        ramp_case("ramp_%s_ends" % interp.lower(), interp, RAMP_ENDS,
                  note="Stops at 0 and 1 and a coincident pair at 0.55.")
        ramp_case("ramp_%s_interior" % interp.lower(), interp, RAMP_INTERIOR,
                  note="Stops in (0, 1) only.")
    for mode in ("HSV", "HSL"):
        for hue in ("NEAR", "FAR", "CW", "CCW"):
            ramp_case("ramp_%s_%s" % (mode.lower(), hue.lower()), "LINEAR", RAMP_HUES, mode, hue)
    ramp_case("ramp_hsv_constant", "CONSTANT", RAMP_HUES, "HSV", "FAR",
              note="HSV ramps blend linearly whatever the interpolation, but CONSTANT still "
                   "stops Cycles interpolating the table.")
    ramp_case("ramp_hsl_ease", "EASE", RAMP_HUES, "HSL", "CW",
              note="EASE is ignored by HSV/HSL ramps.")
    ramp_case("ramp_b_spline_alpha", "B_SPLINE", RAMP_INTERIOR, socket="Alpha")
    ramp_case("ramp_hsv_alpha", "LINEAR", RAMP_HUES, "HSV", "CCW", socket="Alpha")
    ramp_case("ramp_single_stop", "LINEAR", [el(0.4, 0.3, 0.6, 0.9, 0.5)],
              note="One stop: constant colour.")
    for interp, mode in (("LINEAR", "RGB"), ("B_SPLINE", "RGB"), ("CARDINAL", "RGB"),
                         ("LINEAR", "HSV"), ("LINEAR", "HSL")):
        ramp_case("ramp_hdr_%s_%s" % (interp.lower(), mode.lower()), interp, RAMP_HDR, mode,
                  "NEAR", note="Stop colours above 1 and below 0: Blender stores negative "
                  "channels as 0; B_SPLINE and CARDINAL clamp their result to [0, 1].")
    ramp_case("ramp_32_stops", "EASE", RAMP_32,
              note="The most stops Blender allows (32), unevenly spaced, two coincident.")
    ramp_case("ramp_32_stops_constant", "CONSTANT", RAMP_32, socket="Alpha")


# ---- Combine / Separate -------------------------------------------------------------------

def convert_cases():
    k = Case()
    a = k.sx(-2.0, 1.0 / 32)
    b = k.sy(-1.0, 1.0 / 64)
    v = k.xyz(a, b, k.math("MULTIPLY", a, b))
    sep = k.node("ShaderNodeSeparateXYZ")
    k.set(sep, "Vector", v)
    k.write("combine_separate_xyz", k.xyz((sep, "Z"), (sep, "X"), (sep, "Y")),
            "Combine XYZ (a, b, a*b), Separate XYZ, recombined as (z, x, y).")

    for mode in ("RGB", "HSV", "HSL"):
        k = Case()
        h = k.sx(-0.5, 1.0 / 64)          # hue [-0.5, 1.5): wraps both ways
        s = k.sy(-0.25, 1.0 / 64)         # saturation [-0.25, 1.73)
        val = k.diagonal(-0.25, 1.0 / 128)  # value / lightness [-0.25, 1.75)
        n = k.node("ShaderNodeCombineColor", {"mode": mode})
        k.set(n, "Red", h)
        k.set(n, "Green", s)
        k.set(n, "Blue", val)
        k.write("combine_color_%s" % mode.lower(), (n, "Color"),
                "Combine Color %s: first channel [-0.5, 1.5) (hues outside [0, 1] are not "
                "wrapped by Cycles), second [-0.25, 1.73), third [-0.25, 1.75)." % mode)

        k = Case()
        r = k.sx(-0.25, 1.0 / 64)
        g = k.sy(-0.25, 1.0 / 64)
        bl = k.math("SUBTRACT", 1.0, k.diagonal(0.0, 1.0 / 128))  # (-1, 1]
        n = k.node("ShaderNodeSeparateColor", {"mode": mode})
        k.set(n, "Color", k.xyz(r, g, bl))
        k.write("separate_color_%s" % mode.lower(),
                k.xyz((n, "Red"), (n, "Green"), (n, "Blue")),
                "Separate Color %s of (r, g, 1 - diagonal) with channels outside [0, 1], "
                "recombined as XYZ." % mode)


# ---- Mapping -------------------------------------------------------------------------------

def mapping_case(name, vector_type, location, rotation, scale, note=""):
    k = Case()
    a = k.sx(-2.0, 1.0 / 32)
    b = k.sy(-2.0, 1.0 / 32)
    n = k.node("ShaderNodeMapping", {"vector_type": vector_type})
    k.set(n, "Vector", k.xyz(a, b, 0.7))
    if location is not None:
        k.set(n, "Location", location)
    k.set(n, "Rotation", rotation(k, a, b) if callable(rotation) else rotation)
    k.set(n, "Scale", scale)
    k.write(name, (n, "Vector"),
            "Mapping %s of (a, b, 0.7), a, b in [-2, 2); location %s, scale %s. %s"
            % (vector_type, location, scale, note))


def mapping_cases():
    loc, rot, scale = [0.3, -0.7, 1.1], [0.5, -1.2, 2.1], [1.5, -0.75, 2.0]
    mapping_case("mapping_point", "POINT", loc, rot, scale)
    mapping_case("mapping_texture", "TEXTURE", loc, rot, scale)
    mapping_case("mapping_vector", "VECTOR", None, rot, scale)
    mapping_case("mapping_normal", "NORMAL", None, rot, scale)
    mapping_case("mapping_texture_zero_scale", "TEXTURE", loc, rot, [0.0, 2.0, -1.0],
                 "A zero scale component divides to 0 (safe_divide).")
    mapping_case("mapping_normal_zero_scale", "NORMAL", None, rot, [0.0, 2.0, -1.0],
                 "A zero scale component divides to 0 before normalising.")
    mapping_case("mapping_point_varying_rotation", "POINT", loc,
                 lambda k, a, b: k.xyz(b, a, 0.3), scale,
                 "Rotation linked: (b, a, 0.3) radians.")
    mapping_case("mapping_texture_large_rotation", "TEXTURE", loc,
                 lambda k, a, b: k.xyz(k.math("MULTIPLY", a, 25.0), k.math("MULTIPLY", b, -20.0),
                                       k.math("ADD", a, b)), scale,
                 "Rotation linked, angles up to 50 radians.")


if __name__ == "__main__":
    mix_cases()
    invert_cases()
    ramp_cases()
    convert_cases()
    mapping_cases()
