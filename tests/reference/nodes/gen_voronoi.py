#!/usr/bin/env python3
"""Reference cases for the Voronoi Texture (ShaderNodeTexVoronoi).

Run from anywhere: python3 tests/reference/nodes/gen_voronoi.py
Then render the missing references with blender/render_node_references.py.

Coverage: every feature x distance metric in 3D; every output (Distance, Color, Position,
W, Radius); Randomness 0 (points on the lattice corners: exact distance ties everywhere,
so the scan order decides) and 1; Smoothness 0 (4.x falls back to F1, 3.x divides by
zero) and 1; Minkowski exponents 0, 0.05 and 32; Blender 4.x's octaves (Detail 0, 3.5
and 15, Roughness 0 and 1, Normalize on and off, fractional Detail) for the fractal
features; huge, negative and zero scales and negative coordinates; and 1D, 2D and 4D.

Versions. 3.4's Voronoi has no Detail / Roughness / Lacunarity / Normalize, and the
importer does not drop them for 3.x, so cases that set them are rendered in 4.3 only;
that 3.x mode ignores them is checked by tests/unit/test_voronoi.c.

Tolerance. Cells are chosen by comparing distances, so at cell borders a last-bit
difference can pick the other cell: Color, Position, W and Radius jump there, and F1/F2
distances of the fractal sum jump through their colour / position. Cases whose socket
is discontinuous allow 0.1% of pixels past the tolerance (max_bad_fraction 0.001, said
so in their note); continuous ones (distances, smooth F1, distance to edge) allow none.

Huge values: 4.3 starts its searches at FLT_MAX, and a Minkowski exponent of 0 makes
every distance inf, so 4.3's Distance is FLT_MAX; as a grey sample its |R|+|G|+|B|
overflows and Cycles' film writes 0 (test_blender_nodes applies the same rule). 3.4's
search starts at 8 and returns 8.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from casekit import Graph, write_case  # noqa: E402

BOTH = ("3.4", "4.3")
V4 = ("4.3",)
METRICS = ("EUCLIDEAN", "MANHATTAN", "CHEBYCHEV", "MINKOWSKI")
FEATURES = ("F1", "F2", "SMOOTH_F1", "DISTANCE_TO_EDGE", "N_SPHERE_RADIUS")
BORDER_NOTE = ("Discontinuous at Voronoi cell borders: up to 0.1% of pixels may pick the "
               "neighbouring cell (max_bad_fraction 0.001).")


def voronoi_case(name, *, socket="Distance", versions=BOTH, dims="3D", metric="EUCLIDEAN",
                 feature="F1", normalize=None, coords=None, w_range=None, jumps=None,
                 note="", **inputs):
    """One Voronoi node fed with snapped Generated coordinates (Scale sets the cell count
    across the image), compared on `socket`. coords=(mul, add) remaps the coordinates with
    Vector Math; w_range=(lo, hi) feeds W from the image's x coordinate."""
    g = Graph()
    props = {"voronoi_dimensions": dims, "distance": metric, "feature": feature}
    if normalize is not None:
        props["normalize"] = normalize
    n = g.node("ShaderNodeTexVoronoi", inputs=inputs, properties=props)
    co = g.pixel_coords(space="generated")
    if coords is not None:
        mul, add = coords
        m = g.node("ShaderNodeVectorMath", properties={"operation": "MULTIPLY"},
                   inputs={"Vector_001": list(mul)})
        g.link(co, (m, "Vector"))
        a = g.node("ShaderNodeVectorMath", properties={"operation": "ADD"},
                   inputs={"Vector_001": list(add)})
        g.link((m, "Vector"), (a, "Vector"))
        co = (a, "Vector")
    if dims != "1D":
        g.link(co, (n, "Vector"))
    if w_range is not None:
        x, _ = g.pixel_xy()
        g.link(g.map_range(x, w_range[0], w_range[1]), (n, "W"))
    if jumps is None:
        # Colour, position, W and radius come from a chosen cell (except smooth F1's).
        jumps = socket in ("Color", "Position", "W", "Radius") and feature != "SMOOTH_F1"
    text = " ".join(t for t in (note, BORDER_NOTE if jumps else "") if t)
    write_case("voronoi_" + name, g, socket=(n, socket), versions=versions, tolerance=1e-4,
               max_bad_fraction=0.001 if jumps else 0.0, note=text)


def main():
    # Every feature x metric in 3D (the metric is ignored by distance to edge and
    # n-sphere radius, which are always Euclidean: checked here too).
    for feature in FEATURES:
        for metric in METRICS:
            socket = "Radius" if feature == "N_SPHERE_RADIUS" else "Distance"
            voronoi_case(f"{feature.lower()}_{metric.lower()}", socket=socket, metric=metric,
                         feature=feature, Scale=7.0,
                         note=f"3D {feature}, {metric} metric, Scale 7.")

    # Every output.
    for feature in ("F1", "F2", "SMOOTH_F1"):
        for socket in ("Color", "Position"):
            voronoi_case(f"{feature.lower()}_{socket.lower()}", socket=socket, feature=feature,
                         Scale=6.0, note=f"3D {feature} {socket} output.")
    voronoi_case("f2_position_chebychev", socket="Position", feature="F2", metric="CHEBYCHEV",
                 Scale=6.0, note="F2 Position under the Chebychev metric.")

    # Randomness 0: points on lattice corners, exact ties decided by scan order.
    for feature, socket in (("F1", "Distance"), ("F1", "Color"), ("F2", "Distance"),
                            ("SMOOTH_F1", "Distance"), ("DISTANCE_TO_EDGE", "Distance"),
                            ("N_SPHERE_RADIUS", "Radius")):
        voronoi_case(f"random0_{feature.lower()}_{socket.lower()}", socket=socket,
                     feature=feature, Randomness=0.0, Scale=5.5,
                     note=f"Randomness 0 ({feature} {socket}): regular lattice, exact ties.")
    voronoi_case("random_above1_f1", Randomness=3.0, Scale=5.0,
                 note="Randomness 3 is clamped to 1.")
    # Fractional randomness: the jitter product no longer exact (Cycles fuses it).
    for name, kw in (("random037_f1_distance", dict()),
                     ("random037_f1_position", dict(socket="Position")),
                     ("random06_smooth_color", dict(socket="Color", feature="SMOOTH_F1",
                                                    Smoothness=0.45)),
                     ("random03_edge", dict(feature="DISTANCE_TO_EDGE")),
                     ("random05_radius", dict(socket="Radius", feature="N_SPHERE_RADIUS")),
                     ("2d_random045_edge", dict(dims="2D", feature="DISTANCE_TO_EDGE")),
                     ("1d_random07_edge", dict(dims="1D", feature="DISTANCE_TO_EDGE",
                                               w_range=(-3.0, 5.0))),
                     ("4d_random05_f1", dict(dims="4D", w_range=(-3.0, 5.0)))):
        r = float("0." + name.split("random")[1].split("_")[0][1:])
        voronoi_case(name, Randomness=r, Scale=5.0,
                     note=f"Randomness {r}: {kw.get('feature', 'F1')} "
                          f"{kw.get('socket', 'Distance')} ({kw.get('dims', '3D')}).", **kw)
    voronoi_case("random03_edge_detail35_normalize", versions=V4, feature="DISTANCE_TO_EDGE",
                 Randomness=0.3, Detail=3.5, normalize=True, Scale=4.0,
                 note="Randomness 0.3 in 4.x octaves of distance to edge, normalized.")
    voronoi_case("random045_f2_detail2_normalize", versions=V4, feature="F2", Randomness=0.45,
                 Detail=2.0, normalize=True, Scale=4.0,
                 note="Randomness 0.45: Normalize's max distance (0.5 + 0.5 r) * 2 * sqrt 3.")

    # Smoothness: 0 (4.x: F1; 3.x: division by zero, which amounts to F1), 1, and a metric.
    voronoi_case("smooth0_distance", feature="SMOOTH_F1", Smoothness=0.0, Scale=6.0,
                 note="Smooth F1 with Smoothness 0.")
    voronoi_case("smooth0_color", socket="Color", feature="SMOOTH_F1", Smoothness=0.0,
                 Scale=6.0, jumps=True, note="Smooth F1 with Smoothness 0 is F1: its colour jumps.")
    voronoi_case("smooth1_color", socket="Color", feature="SMOOTH_F1", Smoothness=1.0,
                 Scale=6.0, note="Smooth F1 with Smoothness 1.")
    voronoi_case("smooth_minkowski3", feature="SMOOTH_F1", metric="MINKOWSKI", Smoothness=0.6,
                 Exponent=3.0, Scale=6.0, note="Smooth F1, Minkowski exponent 3.")

    # Minkowski exponent extremes.
    voronoi_case("minkowski_e0_distance", metric="MINKOWSKI", Exponent=0.0, Scale=6.0,
                 note="Exponent 0: every distance is inf, no point is found: 3.4 returns its "
                      "start distance 8, 4.3 FLT_MAX (the film turns that grey pixel to 0).")
    for socket in ("Color", "Position"):
        voronoi_case(f"minkowski_e0_{socket.lower()}", socket=socket, metric="MINKOWSKI",
                     Exponent=0.0, Scale=6.0,
                     note="Exponent 0: no point is ever found, the cell's own hash is used.")
    voronoi_case("minkowski_e005", metric="MINKOWSKI", Exponent=0.05, Scale=6.0,
                 note="Exponent 0.05: distances beyond 8, where 3.4's search from 8 misses "
                      "points that 4.3 finds.")
    voronoi_case("minkowski_e32", metric="MINKOWSKI", Exponent=32.0, Scale=6.0,
                 note="Exponent 32: powf underflows to 0 for small components.")
    voronoi_case("minkowski_e05_f2_color", socket="Color", feature="F2", metric="MINKOWSKI",
                 Exponent=0.5, Scale=6.0, note="F2 colour, Minkowski 0.5.")

    # Scales and coordinates.
    voronoi_case("scale_1e3", Scale=1000.0, note="Scale 1000: about 8 cells per pixel.")
    voronoi_case("scale_1e5_color", socket="Color", Scale=100000.0,
                 note="Scale 1e5: a different cell at every pixel.")
    voronoi_case("scale_negative_position", socket="Position", Scale=-7.5,
                 note="Negative scale: position divided back by it.")
    voronoi_case("scale0_position", socket="Position", Scale=0.0,
                 note="Scale 0: all points in cell 0, position safe-divided to 0.")
    voronoi_case("negative_coordinates", coords=((8.0, 8.0, 1.0), (-6.0, -5.0, -3.3)),
                 Scale=1.0, note="Coordinates in [-6, 2] x [-5, 3], z = -2.8.")
    voronoi_case("negative_coordinates_color", socket="Color",
                 coords=((8.0, 8.0, 1.0), (-6.0, -5.0, -3.3)), Scale=1.0,
                 note="Colour for coordinates in [-6, 2] x [-5, 3].")

    # Blender 4.x octaves (4.3 only).
    fractal = [
        ("detail35", dict(Detail=3.5), False),
        ("detail35_normalize", dict(Detail=3.5), True),
        ("detail15_rough1", dict(Detail=15.0, Roughness=1.0), False),
        ("detail15_rough1_normalize", dict(Detail=15.0, Roughness=1.0), True),
        ("detail35_rough0_normalize", dict(Detail=3.5, Roughness=0.0), True),
        ("detail0_normalize", dict(Detail=0.0), True),
        ("detail15_rough05_lac17", dict(Detail=15.0, Roughness=0.5, Lacunarity=1.7), False),
        ("detail_above15", dict(Detail=40.0, Roughness=0.6), True),
    ]
    for name, inputs, normalize in fractal:
        voronoi_case(f"f1_{name}", versions=V4, normalize=normalize, Scale=4.0,
                     note=f"4.x octaves, F1 Distance: {inputs}, normalize {normalize}.",
                     **inputs)
        voronoi_case(f"edge_{name}", versions=V4, feature="DISTANCE_TO_EDGE",
                     normalize=normalize, Scale=4.0,
                     note=f"4.x octaves, distance to edge: {inputs}, normalize {normalize}.",
                     **inputs)
    voronoi_case("f2_manhattan_detail35_normalize", versions=V4, feature="F2",
                 metric="MANHATTAN", normalize=True, Detail=3.5, Scale=4.0,
                 note="4.x octaves of F2 / Manhattan, normalized.")
    voronoi_case("f1_minkowski_detail35_normalize", versions=V4, metric="MINKOWSKI",
                 Exponent=1.5, normalize=True, Detail=3.5, Scale=4.0,
                 note="4.x octaves, Minkowski 1.5 (max distance per metric), normalized.")
    voronoi_case("smooth_detail35", versions=V4, feature="SMOOTH_F1", Detail=3.5,
                 Lacunarity=2.7, Scale=4.0, note="4.x octaves of smooth F1.")
    voronoi_case("smooth_detail35_position", versions=V4, socket="Position",
                 feature="SMOOTH_F1", Detail=3.5, Scale=4.0,
                 note="4.x octaves of smooth F1: blended positions.")
    voronoi_case("f1_detail35_color_normalize", versions=V4, socket="Color", normalize=True,
                 Detail=3.5, Scale=4.0, note="4.x octaves: colours summed and normalized.")
    voronoi_case("f1_detail35_position", versions=V4, socket="Position", Detail=3.5,
                 Scale=4.0, note="4.x octaves: positions blended by amplitude.")
    voronoi_case("f1_detail15_rough1_color", versions=V4, socket="Color", Detail=15.0,
                 Roughness=1.0, Scale=4.0, note="16 equal octaves of colour.")

    # Other dimensions.
    W = (-3.0, 5.0)
    voronoi_case("1d_f1", dims="1D", w_range=W, Scale=1.5, note="1D F1 along x.")
    voronoi_case("1d_f1_w", socket="W", dims="1D", w_range=W, Scale=1.5, note="1D F1 W output.")
    voronoi_case("1d_f2_color", socket="Color", dims="1D", feature="F2", w_range=W, Scale=1.5,
                 note="1D F2 colour.")
    voronoi_case("1d_smooth_w", socket="W", dims="1D", feature="SMOOTH_F1", w_range=W,
                 Scale=1.5, note="1D smooth F1 W output.")
    voronoi_case("1d_edge", dims="1D", feature="DISTANCE_TO_EDGE", w_range=W, Scale=1.5,
                 note="1D distance to edge (closed form).")
    voronoi_case("1d_radius", socket="Radius", dims="1D", feature="N_SPHERE_RADIUS", w_range=W,
                 Scale=1.5, note="1D n-sphere radius.")
    voronoi_case("1d_detail35_normalize", versions=V4, dims="1D", w_range=W, Detail=3.5,
                 normalize=True, Scale=1.5, note="1D octaves, normalized.")
    voronoi_case("2d_f1_manhattan", dims="2D", metric="MANHATTAN", Scale=6.0, note="2D F1.")
    voronoi_case("2d_f2_position", socket="Position", dims="2D", feature="F2", Scale=6.0,
                 note="2D F2 position (z is 0).")
    voronoi_case("2d_smooth_color", socket="Color", dims="2D", feature="SMOOTH_F1", Scale=6.0,
                 note="2D smooth F1 colour.")
    voronoi_case("2d_edge", dims="2D", feature="DISTANCE_TO_EDGE", Scale=6.0,
                 note="2D distance to edge.")
    voronoi_case("2d_radius", socket="Radius", dims="2D", feature="N_SPHERE_RADIUS", Scale=6.0,
                 note="2D n-sphere radius.")
    voronoi_case("2d_minkowski_detail2_normalize", versions=V4, dims="2D", metric="MINKOWSKI",
                 Exponent=0.7, Detail=2.0, normalize=True, Scale=6.0,
                 note="2D octaves, Minkowski 0.7, normalized.")
    voronoi_case("4d_f1", dims="4D", w_range=W, Scale=3.0, note="4D F1, W along x.")
    voronoi_case("4d_f1_w", socket="W", dims="4D", w_range=W, Scale=3.0, note="4D F1 W output.")
    voronoi_case("4d_f2_color", socket="Color", dims="4D", feature="F2", w_range=W, Scale=3.0,
                 note="4D F2 colour.")
    voronoi_case("4d_smooth_position", socket="Position", dims="4D", feature="SMOOTH_F1",
                 w_range=W, Scale=3.0, note="4D smooth F1 position.")
    voronoi_case("4d_edge", dims="4D", feature="DISTANCE_TO_EDGE", w_range=W, Scale=3.0,
                 note="4D distance to edge.")
    voronoi_case("4d_radius", socket="Radius", dims="4D", feature="N_SPHERE_RADIUS", w_range=W,
                 Scale=3.0, note="4D n-sphere radius.")
    voronoi_case("4d_chebychev_detail1p5_normalize", versions=V4, dims="4D", metric="CHEBYCHEV",
                 w_range=W, Detail=1.5, normalize=True, Scale=3.0,
                 note="4D octaves, Chebychev, normalized.")


if __name__ == "__main__":
    main()
