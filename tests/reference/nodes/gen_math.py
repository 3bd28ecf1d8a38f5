#!/usr/bin/env python3
"""Reference cases for the Math family: Math, Vector Math, Clamp and Map Range.

Run from anywhere: python3 tests/reference/nodes/gen_math.py
Then render the missing references with blender/render_node_references.py.

How the inputs are laid out. casekit's pixel_xy() gives the snapped pixel-centre
coordinates u = (i + 0.5) / 128, v = (j + 0.5) / 128. sweep() maps them onto an exact
grid: value = start + i * step, with step a power of two, so every case sees exact
zeros, exact integers and halves, negatives and (in the y sweep) a row where the second
operand is exactly 0 (division, modulo, snap, ping-pong and logarithm by zero). fine()
adds a y sweep 128 times finer to an x sweep, so a one-operand op is seen at 16384
distinct points. Several operations share a case graph: their float results go to the
X, Y and Z of a Combine XYZ whose Vector is the compared socket (Cycles' film handles
the three channels independently, except for the overflow rule below).

Non-finite results: Cycles' film replaces any non-finite component of a sample by 0
(kernel/film/light_passes.h, film_clamp_light -> ensure_finite), so Blender's EXR holds
0 where the node produced inf or NaN; the comparison applies the same rule to our
values. Cases marked "non-finite" exercise that on purpose (exp overflow, sinh of huge
values, 0^-1, 3.4's REFLECT/REFRACT with a zero normal). The same function then applies
the sample clamp: with clamping off the limit is FLT_MAX, and it scales the sample by
limit / (|R| + |G| + |B|); when that sum overflows to inf the whole pixel becomes 0
even though each component is finite (measured in 3.4 and 4.3: (1.0e38, 1.1e38,
1.7e38) reads (0, 0, 0), (0.9e38, 1.05e38, 0.86e38) passes unchanged). A float socket
reaches the film as (v, v, v), so |v| > FLT_MAX / 3 reads 0. math_film_overflow shows it.

What is left: Blender 3.4 agrees with our kernels bit for bit on every case. Blender 4.3
runs in a Debian trixie chroot whose glibc (2.41) rounds a few transcendental functions
(tanf, asinf, acosf, atanf, atan2f, sinhf, coshf, tanhf) differently in the last bit
from the host's glibc 2.36 that our build uses; those cases differ from 4.3 by at most
1.5e-5 (sinh near 1e2), well inside the tolerance. The notes of those cases say so.

Magnitudes: the comparison is absolute (1e-4), so the transcendental functions that 4.3
rounds differently keep their outputs below about 1e3 (tangent stays away from its
poles); exactly rounded operations (arithmetic, fmod, powf, which agree bit for bit)
may go higher. Huge inputs (1e30) are fed only to operations whose outputs are bounded,
or overflow to inf on purpose.

Also measured, not a case (the 1e-4 tolerance cannot see it): the float Map Range's
clamp is a Clamp node Cycles appends for every interpolation, so SMOOTHSTEP with To
(-1.32, 1.5) reads exactly 1.5 at factor 1, while the vector Map Range ignores clamp for
the smooth interpolations and reads 1.5000001 there; the kernels do the same.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from casekit import Graph, write_case  # noqa: E402

BOTH = ("3.4", "4.3")
N = 128  # pixels per side of a reference image


# Which operands Blender shows for an operation (checked in Blender 4.3's UI); linking a
# hidden socket is an error in our loader, so the helpers below leave them unlinked.
MATH_UNARY = {"SQRT", "INVERSE_SQRT", "ABSOLUTE", "EXPONENT", "SIGN", "ROUND", "FLOOR", "CEIL",
              "TRUNC", "FRACT", "SINE", "COSINE", "TANGENT", "ARCSINE", "ARCCOSINE",
              "ARCTANGENT", "SINH", "COSH", "TANH", "RADIANS", "DEGREES"}
MATH_TERNARY = {"MULTIPLY_ADD", "COMPARE", "SMOOTH_MIN", "SMOOTH_MAX", "WRAP"}
VMATH_UNARY = {"LENGTH", "SCALE", "NORMALIZE", "ABSOLUTE", "FLOOR", "CEIL", "FRACTION", "SINE",
               "COSINE", "TANGENT"}
VMATH_TERNARY = {"MULTIPLY_ADD", "FACEFORWARD", "WRAP"}
VMATH_SCALE = {"SCALE", "REFRACT"}


# Functions whose last bit differs between the host glibc (2.36) and Blender 4.3's
# (trixie, 2.41); see the module docstring.
LIBM_DIFFERS = ("TANGENT", "ARCSINE", "ARCCOSINE", "ARCTANGENT", "ARCTAN2", "SINH", "COSH",
                "TANH", "SINH(")
LIBM_NOTE = ("In 4.3 a few results differ in the last bit (glibc 2.41 in Blender 4.3's "
             "chroot vs 2.36 here): max error about 1e-6 relative, under the tolerance.")


def sweep(g, s, start, step):
    """Value start + i * step at pixel i of coordinate socket s (exact for step 2^-k)."""
    lo = start - 0.5 * step
    return g.map_range(s, lo, lo + N * step)


class Case:
    """A graph with x, y sweeps and helpers to build Math / Vector Math nodes."""

    def __init__(self):
        self.g = Graph()
        self.x, self.y = self.g.pixel_xy()

    def sx(self, start, step):
        return sweep(self.g, self.x, start, step)

    def sy(self, start, step):
        return sweep(self.g, self.y, start, step)

    def fine(self, start, step):
        """x sweep of `step` plus a y sweep of step/128: 16384 distinct values."""
        return self.math("ADD", self.sx(start, step), self.sy(0.0, step / N))

    def _set(self, node, socket, value):
        if isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], str):
            self.g.link(value, (node, socket))
        else:
            self.g.set_input(node, socket, value)

    def math(self, op, a, b=None, c=None, clamp=False):
        n = self.g.node("ShaderNodeMath", properties={"operation": op, "use_clamp": clamp})
        if op in MATH_UNARY:
            b = None
        if op not in MATH_TERNARY:
            c = None
        for sock, v in (("Value", a), ("Value_001", b), ("Value_002", c)):
            if v is not None:
                self._set(n, sock, v)
        return (n, "Value")

    def vmath(self, op, a, b=None, c=None, scale=None, out="Vector"):
        n = self.g.node("ShaderNodeVectorMath", properties={"operation": op})
        if op in VMATH_UNARY:
            b = None
        if op not in VMATH_TERNARY:
            c = None
        if op not in VMATH_SCALE:
            scale = None
        for sock, v in (("Vector", a), ("Vector_001", b), ("Vector_002", c), ("Scale", scale)):
            if v is not None:
                self._set(n, sock, v)
        return (n, out)

    def combine(self, x, y=0.0, z=0.0):
        n = self.g.node("ShaderNodeCombineXYZ")
        for sock, v in (("X", x), ("Y", y), ("Z", z)):
            self._set(n, sock, v)
        return (n, "Vector")

    def separate(self, v, comp):
        n = self.g.node("ShaderNodeSeparateXYZ")
        self.g.link(v, (n, "Vector"))
        return (n, comp)

    def map_range(self, value, from_min, from_max, to_min, to_max, steps=None,
                  interpolation="LINEAR", clamp=True, vector=False):
        n = self.g.node("ShaderNodeMapRange", properties={
            "data_type": "FLOAT_VECTOR" if vector else "FLOAT",
            "interpolation_type": interpolation, "clamp": clamp})
        if vector:
            names = ("Vector", "From_Min_FLOAT3", "From_Max_FLOAT3", "To_Min_FLOAT3",
                     "To_Max_FLOAT3", "Steps_FLOAT3")
        else:
            names = ("Value", "From Min", "From Max", "To Min", "To Max", "Steps")
        for sock, v in zip(names, (value, from_min, from_max, to_min, to_max, steps)):
            if v is not None:
                self._set(n, sock, v)
        return (n, "Vector" if vector else "Result")

    def write(self, name, socket, note, versions=BOTH):
        if any(f in note.upper() for f in LIBM_DIFFERS) and "4.3" in versions:
            note += " " + LIBM_NOTE
        write_case(name, self.g, socket=socket, versions=versions, tolerance=1e-4,
                   max_bad_fraction=0.0, note=note)


def math3(name, ops, a_range, b_range=None, c=None, clamp=False, versions=BOTH, note="",
          fine=False):
    """Up to three Math operations over a = x sweep (or fine sweep), b = y sweep."""
    k = Case()
    a = k.fine(*a_range) if fine else k.sx(*a_range)
    b = k.sy(*b_range) if b_range else None
    outs = [k.math(op, a, b, c, clamp=clamp) for op in ops]
    while len(outs) < 3:
        outs.append(0.0)
    k.write(name, k.combine(*outs),
            "Math %s; a = %s sweep %s, b = y sweep %s, c = %s, use_clamp %s. %s" %
            ("/".join(ops), "fine" if fine else "x", a_range, b_range, c, clamp, note),
            versions)


def math_cases():
    grid8 = (-8.0, 1.0 / 8.0)      # [-8, 8): zeros, integers, halves, negatives
    grid4 = (-4.0, 1.0 / 16.0)     # [-4, 4)
    math3("math_add_sub_mul", ["ADD", "SUBTRACT", "MULTIPLY"], grid8, grid8)
    math3("math_divide_power_log", ["DIVIDE", "POWER", "LOGARITHM"], grid4, grid4,
          note="b = 0 row: division by zero gives 0; negative base with fractional "
               "exponent gives 0; 0^negative is inf (film writes 0); log of a <= 0 or "
               "base <= 0 gives 0.")
    math3("math_sqrt_invsqrt_abs", ["SQRT", "INVERSE_SQRT", "ABSOLUTE"], grid8, fine=True,
          note="sqrt/inverse sqrt of <= 0 give 0.")
    math3("math_exp_min_max", ["EXPONENT", "MINIMUM", "MAXIMUM"], (-6.0, 1.0 / 16.0), grid8)
    math3("math_less_greater_sign", ["LESS_THAN", "GREATER_THAN", "SIGN"], grid8, grid8,
          note="the diagonal a == b is exact; sign(0) = 0.")
    math3("math_compare_eps", ["COMPARE"], grid8, grid8, c=0.5)
    math3("math_compare_zero_eps", ["COMPARE"], grid8, grid8, c=-1.0,
          note="epsilon below FLT_EPSILON: exact equality only.")
    math3("math_smooth_min_max", ["SMOOTH_MIN", "SMOOTH_MAX"], grid8, grid8, c=1.5)
    math3("math_smooth_min_max_k0", ["SMOOTH_MIN", "SMOOTH_MAX"], grid8, grid8, c=0.0,
          note="k = 0 falls back to min/max.")
    math3("math_round_floor_ceil", ["ROUND", "FLOOR", "CEIL"], grid8, fine=True,
          note="exact .5 values included.")
    math3("math_trunc_fract_modulo", ["TRUNC", "FRACT", "MODULO"], grid8, grid4,
          note="modulo by 0 gives 0; fmod keeps the sign of a.")
    math3("math_wrap_snap_pingpong", ["WRAP", "SNAP", "PINGPONG"], grid8, grid4, c=-1.5,
          note="wrap(a, max=b, min=-1.5): empty range at b = -1.5 gives min; snap and "
               "ping-pong by 0 give 0.")
    math3("math_floored_modulo", ["FLOORED_MODULO"], grid8, grid4, versions=("4.3",),
          note="FLOORED_MODULO exists only in Blender 4.x.")
    k = Case()
    a = k.fine(-4.0, 1.0 / 16.0)
    coarse = k.sx(-4.0, 1.0 / 16.0)
    k.write("math_sin_cos_tan",
            k.combine(k.math("SINE", a), k.math("COSINE", a), k.math("TANGENT", coarse)),
            "Math SINE / COSINE over the fine sweep [-4, 4); TANGENT over the x sweep "
            "[-4, 4) step 1/16, whose points stay >= 0.008 from the poles (|tan| < 130): "
            "near a pole tanf's last-bit differences between C libraries exceed 1e-4.")
    math3("math_asin_acos_atan", ["ARCSINE", "ARCCOSINE", "ARCTANGENT"], (-2.0, 1.0 / 32.0),
          fine=True, note="arcsine/arccosine clamp their argument to [-1, 1].")
    math3("math_atan2_sinh_tanh", ["ARCTAN2", "SINH", "TANH"], grid4, grid4, note="atan2(0, 0) = 0 in both versions for +0.")
    math3("math_cosh_radians_degrees", ["COSH", "RADIANS", "DEGREES"], grid4)
    math3("math_multiply_add", ["MULTIPLY_ADD"], grid8, grid8, c=0.375,
          note="fused in Cycles' AVX2 kernel.")
    math3("math_clamped", ["SUBTRACT", "DIVIDE", "TANGENT"], grid4, grid4, clamp=True,
          note="use_clamp: Cycles appends a Clamp node (0..1).")

    # Signed zeros: a * 1e-30 * 1e-30 underflows to a zero with a's sign (constant-free,
    # so Cycles cannot fold it away).
    k = Case()
    a = k.sx(-4.0, 1.0 / 16.0)
    b = k.sy(-4.0, 1.0 / 16.0)

    def signed_zero(v):
        return k.math("MULTIPLY", k.math("MULTIPLY", v, 1e-30), 1e-30)

    k.write("math_atan2_signed_zero",
            k.combine(k.math("ARCTAN2", signed_zero(a), signed_zero(b)),
                      k.math("ARCTAN2", signed_zero(a), b),
                      k.math("ARCTAN2", a, signed_zero(b))),
            "ARCTAN2 at signed zeros: 3.4's atan2f gives 0, -0, pi or -pi at the origin by "
            "the zeros' signs; 4.3's compatible_atan2 gives 0 there.")

    # Non-finite and huge inputs.
    k = Case()
    huge = k.g.map_range(k.x, -1e30, 1e30)
    b = k.sy(-4.0, 1.0 / 16.0)
    k.write("math_huge_bounded",
            k.combine(k.math("SINE", huge), k.math("MODULO", huge, b), k.math("ARCTAN2", b, huge)),
            "Huge a in [-1e30, 1e30] (x), b = y sweep: sin(a), fmod(a, b) (b = 0 gives 0), "
            "atan2(b, a); bounded outputs.")
    k = Case()
    a = k.sx(-128.0, 2.0)
    b = k.sy(-4.0, 1.0 / 16.0)
    k.write("math_nonfinite",
            k.combine(k.math("EXPONENT", a), k.math("SINH", a),
                      k.math("SINE", k.math("EXPONENT", a), clamp=True)),
            "non-finite: exp(a) and sinh(a) overflow to inf for |a| > 88.7 (Blender's film "
            "writes 0 there); sin(inf) = NaN, which use_clamp's Clamp node turns into 0 "
            "(Cycles' max(NaN, 0) is 0).")
    k = Case()
    a = k.sx(-4.0, 1.0 / 16.0)
    b = k.sy(-4.0, 1.0 / 16.0)
    k.write("math_pow_zero_negative",
            k.combine(k.math("POWER", k.math("MULTIPLY", a, 0.0), b),
                      k.math("DIVIDE", b, k.math("POWER", a, 40.0)),
                      k.math("LOGARITHM", a, b, clamp=True)),
            "non-finite: 0^b is inf for b < 0 (film 0), 1 for b = 0; b / a^40 with "
            "a^40 overflowing / underflowing.")


def film_cases():
    k = Case()
    big_x = k.g.map_range(k.x, 0.0, 1.7e38)
    big_y = k.g.map_range(k.y, 0.0, 1.7e38)
    k.write("math_film_overflow",
            k.combine(k.math("ADD", big_x, 0.0), k.math("ADD", big_y, 0.0), 0.0),
            "Film: components up to 1.7e38 are finite, but where |R| + |G| + |B| overflows "
            "Cycles' sample clamp (limit FLT_MAX) scales the pixel by FLT_MAX / inf = 0.")


def vector_cases():
    def vectors(k):
        """A = (x sweep, y sweep, 0.5 x sweep - 1) and B = (y sweep, -x sweep, 1 - y):
        both are exactly zero somewhere only in their first two components; A has
        negative and zero components across the image."""
        ax = k.sx(-4.0, 1.0 / 16.0)
        ay = k.sy(-4.0, 1.0 / 16.0)
        a = k.combine(ax, ay, k.math("MULTIPLY_ADD", ax, 0.5, -1.0))
        b = k.combine(k.sy(-2.0, 1.0 / 32.0), k.sx(3.0, -1.0 / 32.0), k.sy(1.0, -1.0 / 64.0))
        return a, b

    def componentwise(name, ops, c=None, scale=None, note=""):
        k = Case()
        a, b = vectors(k)
        cv = None
        if c is not None:
            cv = k.combine(*c)
        comps = []
        for op, comp in zip(ops, ("X", "Y", "Z")):
            comps.append(k.separate(k.vmath(op, a, b, cv, scale), comp))
        while len(comps) < 3:
            comps.append(0.0)
        k.write(name, k.combine(*comps),
                "Vector Math %s (component %s of each, in that order); A, B as in "
                "vectors(); %s" % ("/".join(ops), "X/Y/Z", note))

    componentwise("vmath_add_sub_mul", ["ADD", "SUBTRACT", "MULTIPLY"])
    componentwise("vmath_div_min_max", ["DIVIDE", "MINIMUM", "MAXIMUM"],
                  note="division by a zero component gives 0.")
    componentwise("vmath_floor_ceil_fraction", ["FLOOR", "CEIL", "FRACTION"])
    componentwise("vmath_abs_modulo_snap", ["ABSOLUTE", "MODULO", "SNAP"],
                  note="modulo/snap by 0 give 0.")
    componentwise("vmath_wrap_sin_cos", ["WRAP", "SINE", "COSINE"], c=(-1.0, 0.5, 2.0),
                  note="wrap(A, max=B, min=C), C = (-1, 0.5, 2).")
    componentwise("vmath_tan_muladd_scale", ["TANGENT", "MULTIPLY_ADD", "SCALE"],
                  c=(0.25, -0.5, 3.0), scale=-2.5)

    def whole(name, op, c=None, scale=None, versions=BOTH, note="", b_zero=False):
        k = Case()
        a, b = vectors(k)
        if b_zero:
            # B's first two components vanish at the centre; make the whole vector
            # vanish along a line so REFLECT/REFRACT see a zero normal.
            b = k.combine(k.sy(-2.0, 1.0 / 32.0), k.sx(3.0, -1.0 / 32.0),
                          k.math("MULTIPLY", k.sy(1.0, -1.0 / 64.0), 0.0))
        cv = k.combine(*c) if c is not None else None
        k.write(name, k.vmath(op, a, b, cv, scale),
                "Vector Math %s; A, B as in vectors(). %s" % (op, note), versions)

    whole("vmath_cross", "CROSS_PRODUCT", note="msub is fused on AVX2.")
    whole("vmath_project", "PROJECT")
    whole("vmath_reflect", "REFLECT", versions=("4.3",),
          note="4.3 normalizes B with safe_normalize.")
    whole("vmath_reflect_zero_normal_34", "REFLECT", b_zero=True, versions=("3.4",),
          note="non-finite: 3.4 divides by |B| = 0 at one pixel (NaN; film 0).")
    whole("vmath_reflect_zero_normal_43", "REFLECT", b_zero=True, versions=("4.3",),
          note="4.3 leaves a zero B as it is: reflect(A, 0) = A.")
    whole("vmath_reflect_34", "REFLECT", versions=("3.4",), note="3.4 normalizes by division.")
    whole("vmath_refract", "REFRACT", scale=0.75, note="eta 0.75; total internal "
          "reflection gives 0.")
    whole("vmath_refract_eta_large", "REFRACT", scale=1.6)
    whole("vmath_faceforward", "FACEFORWARD", c=(0.3, -0.2, 0.1))
    whole("vmath_normalize", "NORMALIZE", note="zero vector stays zero.")

    k = Case()
    a, b = vectors(k)
    k.write("vmath_dot_distance_length",
            k.combine(k.vmath("DOT_PRODUCT", a, b, out="Value"),
                      k.vmath("DISTANCE", a, b, out="Value"),
                      k.vmath("LENGTH", a, out="Value")),
            "Vector Math DOT_PRODUCT / DISTANCE / LENGTH (Value output).")


def clamp_cases():
    k = Case()
    v = k.sx(-4.0, 1.0 / 16.0)
    lo = k.sy(-2.0, 1.0 / 32.0)

    def clamp(kind, value, mn, mx):
        n = k.g.node("ShaderNodeClamp", properties={"clamp_type": kind})
        k._set(n, "Value", value)
        k._set(n, "Min", mn)
        k._set(n, "Max", mx)
        return (n, "Result")

    k.write("clamp_minmax_range",
            k.combine(clamp("MINMAX", v, lo, 0.5), clamp("RANGE", v, lo, 0.5),
                      clamp("MINMAX", v, 0.5, lo)),
            "Clamp MINMAX and RANGE with Min sweeping across Max (min > max in the upper "
            "rows): RANGE swaps reversed bounds, MINMAX yields Max.")


def map_range_cases():
    # Float Map Range: value sweeps beyond the source range on both sides.
    def float_case(name, specs, note):
        k = Case()
        v = k.sx(-1.0, 1.0 / 32.0)     # [-1, 3)
        s = k.sy(-1.0, 1.0 / 16.0)     # [-1, 7): steps / a moving bound
        outs = []
        for interp, clamp, fmin, fmax, tmin, tmax, steps in specs:
            sub = {"s": s}
            outs.append(k.map_range(v, sub.get(fmin, fmin), sub.get(fmax, fmax),
                                    sub.get(tmin, tmin), sub.get(tmax, tmax),
                                    sub.get(steps, steps), interpolation=interp, clamp=clamp))
        k.write(name, k.combine(*outs), note)

    float_case("maprange_float_linear", [
        ("LINEAR", False, 0.25, 1.5, -2.0, 3.0, None),
        ("LINEAR", True, 0.25, "s", 3.0, -2.0, None),
        ("LINEAR", True, 1.0, 1.0, -2.0, 3.0, None)],
        "Float LINEAR: unclamped; clamped with reversed To range and From Max sweeping "
        "through From Min (y); From Min == From Max gives 0 (then clamped).")
    float_case("maprange_float_stepped", [
        ("STEPPED", False, 0.0, 2.0, -1.0, 1.0, "s"),
        ("STEPPED", True, 2.0, 0.0, -1.0, 1.0, 4.0),
        ("STEPPED", True, 0.0, 2.0, 1.0, -1.0, 0.0)],
        "Float STEPPED: Steps sweeping [-1, 7) (<= 0 gives factor 0); reversed From; "
        "Steps 0.")
    float_case("maprange_float_smoothstep", [
        ("SMOOTHSTEP", False, 0.25, 1.5, -2.0, 3.0, None),
        ("SMOOTHSTEP", True, 1.5, 0.25, -2.0, 3.0, None),
        ("SMOOTHSTEP", True, 0.5, "s", 3.0, -2.0, None)],
        "Float SMOOTHSTEP: plain, reversed From, From Max sweeping through From Min.")
    float_case("maprange_float_smootherstep", [
        ("SMOOTHERSTEP", False, 0.25, 1.5, -2.0, 3.0, None),
        ("SMOOTHERSTEP", True, 1.5, 0.25, -2.0, 3.0, None),
        ("SMOOTHERSTEP", True, 0.5, "s", 3.0, -2.0, None)],
        "Float SMOOTHERSTEP: plain, reversed From, From Max sweeping through From Min.")

    def vector_case(name, interp, clamp, steps, note):
        k = Case()
        vx = k.sx(-1.0, 1.0 / 32.0)
        vy = k.sy(-1.0, 1.0 / 32.0)
        vec = k.combine(vx, vy, k.math("ADD", vx, vy))
        s = k.sy(-1.0, 1.0 / 16.0)
        from_min = k.combine(0.25, 1.5, 0.5)
        from_max = k.combine(1.5, 0.25, 0.5)          # z: empty source range
        to_min = k.combine(-2.0, 3.0, 1.0)
        to_max = k.combine(3.0, -2.0, -1.0)
        st = k.combine(s, 4.0, 2.5) if steps else None
        k.write(name, k.map_range(vec, from_min, from_max, to_min, to_max, st,
                                  interpolation=interp, clamp=clamp, vector=True),
                "Vector Map Range %s clamp %s: x plain, y reversed From and To, z empty "
                "From range (safe division gives factor 0). %s" % (interp, clamp, note))

    vector_case("maprange_vector_linear", "LINEAR", True, False, "")
    vector_case("maprange_vector_linear_noclamp", "LINEAR", False, False, "")
    vector_case("maprange_vector_stepped", "STEPPED", True, True, "Steps x sweeps [-1, 7).")
    vector_case("maprange_vector_smoothstep", "SMOOTHSTEP", True, False,
                "clamp is ignored for smooth interpolations.")
    vector_case("maprange_vector_smootherstep", "SMOOTHERSTEP", False, False, "")


if __name__ == "__main__":
    math_cases()
    film_cases()
    vector_cases()
    clamp_cases()
    map_range_cases()
