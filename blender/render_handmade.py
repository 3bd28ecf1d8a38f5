"""Runs inside Blender: render one hand-made material (handmade_materials.py) in our scene.

    blender -b --factory-startup -P blender/render_handmade.py -- NAME --samples N --seed S \
        -o OUT.exr [--shift DX DY] [--scene-file S.json] [--timing OUT.json] [--png OUT.png]

Builds material NAME on the plane of DESIGN.md's scene exactly as render_reference.py does
for a graph (import_material.build_scene: point light, world 0.0509, Cycles CPU,
Blackman-Harris 1.5 px, no adaptive sampling, denoising or clamping; --scene-file: one of
our other scene files, e.g. assets/scene-flash.json), renders N samples with Cycles' seed
S and writes a half-float linear RGB EXR (ZIP). --shift adds (DX, DY, 0) to the material's
Mapping node Location, which translates its whole pattern by (-DX, -DY) m on the plane.
--timing writes the Blender version, samples, seed, shift and the render's wall time;
--png also saves the render as an sRGB 8-bit PNG (view transform Standard), for people.
Every file is written to a temporary name and renamed.

    blender -b --factory-startup -P blender/render_handmade.py -- --sheet OUT.png \
        [--tile 128] [--columns 4] IN.png ...

makes a contact sheet: the PNGs (square, a multiple of --tile wide) box-filtered down to
--tile px, left to right and top to bottom, on black (render_handmade_set.py's sheet).
"""
import json
import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import handmade_materials  # noqa: E402
import import_material  # noqa: E402


def sheet(argv):
    """Pure Python (Debian's Blender 4.3 has no numpy): 14 tiles take a few seconds."""
    import argparse
    p = argparse.ArgumentParser(prog="render_handmade.py --sheet")
    p.add_argument("--sheet", required=True, metavar="OUT.png")
    p.add_argument("--tile", type=int, default=128)
    p.add_argument("--columns", type=int, default=4)
    p.add_argument("inputs", nargs="+")
    a = p.parse_args(argv)
    n, t = len(a.inputs), a.tile
    cols = min(a.columns, n)
    rows = (n + cols - 1) // cols
    width, height = cols * t, rows * t
    out = [0.0, 0.0, 0.0, 1.0] * (width * height)  # Blender's order: bottom row first
    for i, path in enumerate(a.inputs):
        im = bpy.data.images.load(path)
        w, h = im.size
        if w != h or w % t:
            raise SystemExit("render_handmade: %s: %d x %d is not a square multiple of %d"
                             % (path, w, h, t))
        px = im.pixels[:]  # values as stored: sRGB bytes / 255
        f = w // t
        r, c = divmod(i, cols)
        y0 = (rows - 1 - r) * t  # tile row r from the top, in bottom-first rows
        for ty in range(t):
            for tx in range(t):
                acc = [0.0, 0.0, 0.0]
                for y in range(ty * f, ty * f + f):
                    base = (y * w + tx * f) * 4
                    for x in range(f):
                        k = base + 4 * x
                        acc[0] += px[k]
                        acc[1] += px[k + 1]
                        acc[2] += px[k + 2]
                o = ((y0 + ty) * width + c * t + tx) * 4
                out[o:o + 3] = [v / (f * f) for v in acc]
        bpy.data.images.remove(im)
    img = bpy.data.images.new("sheet", width, height, alpha=False)
    img.pixels[:] = out
    img.filepath_raw = a.sheet + ".tmp.png"
    img.file_format = "PNG"
    img.save()
    os.replace(a.sheet + ".tmp.png", a.sheet)


def main(argv):
    import argparse
    p = argparse.ArgumentParser(prog="render_handmade.py")
    p.add_argument("name", choices=sorted(handmade_materials.MATERIALS))
    p.add_argument("--samples", type=int, required=True)
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--shift", type=float, nargs=2, default=(0.0, 0.0), metavar=("DX", "DY"))
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--timing")
    p.add_argument("--png")
    p.add_argument("--threads", type=int, default=0, help="0: all cores")
    p.add_argument("--scene-file", help="one of our scene files instead of DESIGN.md's scene")
    a = p.parse_args(argv)
    mat = handmade_materials.build_material(a.name)
    loc = handmade_materials.mapping_node(mat).inputs["Location"]
    loc.default_value = (loc.default_value[0] + a.shift[0], loc.default_value[1] + a.shift[1],
                         loc.default_value[2])
    scene = bpy.context.scene
    settings = import_material.load_scene_file(a.scene_file) if a.scene_file else None
    import_material.build_scene(scene, material=mat, res=256, light=True, samples=a.samples,
                                filter_width=1.5, settings=settings)
    scene.cycles.seed = a.seed
    if a.threads:
        scene.render.threads_mode = "FIXED"
        scene.render.threads = a.threads
    import_material.set_exr_output(scene, a.output + ".tmp.exr")
    scene.render.image_settings.color_depth = "16"
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    seconds = time.time() - t0
    os.replace(a.output + ".tmp.exr", a.output)
    if a.png:
        s = scene.render.image_settings
        s.file_format = "PNG"
        s.color_mode = "RGB"
        s.color_depth = "8"
        bpy.data.images["Render Result"].save_render(a.png + ".tmp.png", scene=scene)
        os.replace(a.png + ".tmp.png", a.png)
    if a.timing:
        with open(a.timing + ".tmp", "w") as f:
            json.dump({"blender": bpy.app.version_string, "material": a.name,
                       "samples": a.samples, "seed": a.seed, "shift": list(a.shift),
                       "scene_file": os.path.basename(a.scene_file) if a.scene_file else None,
                       "seconds": round(seconds, 2)}, f, indent=1)
        os.replace(a.timing + ".tmp", a.timing)


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    (sheet if "--sheet" in args else main)(args)
