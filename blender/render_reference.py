"""Runs inside Blender: render one converged-reference half of a material in the scene.

    blender -b --factory-startup -P blender/render_reference.py -- \
        GRAPH.json --samples N --seed S -o OUT.exr [--timing OUT.json] [--scene-file S.json]

Builds the material from our JSON (import_material.build_material) on the plane of
DESIGN.md's scene (import_material.build_scene: point light, world 0.0509, Cycles CPU,
Blackman-Harris 1.5 px, no adaptive sampling, no denoising, no clamping), renders N
samples with Cycles' seed S, and writes a half-float RGB EXR (linear). Two halves with
different seeds make a reference and a measure of its own noise. --timing writes the
render's wall time (excluding start-up and scene building) and the Blender version.
"""
import json
import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import import_material  # noqa: E402


def main(argv):
    import argparse
    p = argparse.ArgumentParser(prog="render_reference.py")
    p.add_argument("graph")
    p.add_argument("--samples", type=int, required=True)
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--timing")
    p.add_argument("--threads", type=int, default=0, help="0: all cores")
    p.add_argument("--scene-file", help="one of our scene files instead of DESIGN.md's scene")
    a = p.parse_args(argv)
    data = import_material.load_json(a.graph)
    major = import_material.blender_major()
    mat = import_material.build_material(data, major, source=a.graph)
    scene = bpy.context.scene
    settings = import_material.load_scene_file(a.scene_file) if a.scene_file else None
    import_material.build_scene(scene, material=mat, res=256, light=True, samples=a.samples,
                                filter_width=1.5, settings=settings)
    scene.cycles.seed = a.seed
    if a.threads:
        scene.render.threads_mode = "FIXED"
        scene.render.threads = a.threads
    import_material.set_exr_output(scene, a.output + ".tmp.exr")
    s = scene.render.image_settings
    s.color_depth = "16"
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    seconds = time.time() - t0
    os.replace(a.output + ".tmp.exr", a.output)
    if a.timing:
        with open(a.timing + ".tmp", "w") as f:
            json.dump({"blender": bpy.app.version_string, "samples": a.samples, "seed": a.seed,
                       "seconds": round(seconds, 2)}, f, indent=1)
        os.replace(a.timing + ".tmp", a.timing)


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    main(argv)
