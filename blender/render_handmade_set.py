#!/usr/bin/env python3
"""Render the hand-made test materials of issue 15 into tests/handmade/<name>/.

    python3 blender/render_handmade_set.py [NAME ...] [--samples 128] [--blender 4.3]
                                           [--out tests/handmade] [--threads 0]

For each material of blender/handmade_materials.py (all by default), in Blender 4.3 (the
trixie chroot /srv/trixie; --blender 3.4: `blender` on PATH) with Cycles:
- render.exr   our scene (assets/scene.json, DESIGN.md), seed 1; and preview.png, the
               same render as sRGB 8-bit (for people);
- shifted.exr  the same scene and material with the texture coordinates moved by SHIFT
               (added to the material's one Mapping node Location; the pattern moves by
               -SHIFT m on the 2 m plane), seed 2: the evaluation's floor is the distance
               between render.exr and shifted.exr (same material, other arrangement,
               other noise);
- flash.exr    assets/scene-flash.json (point light beside the camera, as a phone flash),
               seed 3;
- render-b.exr render.exr again with seed 4: render.exr against it is the Monte Carlo
               noise alone, the part of the floor that is not the pattern moving;
- render.json  Blender version, samples, seeds, shift and seconds of each render.
Then tests/handmade/sheet.png: the previews, 128 px each, in the order of --list.
Existing files are kept, so a stopped run resumes (every file is written to a temporary
name and renamed). Renders run at nice 10. Plain python3.
"""
import argparse
import ast
import json
import os
import shutil
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPTS = ("render_handmade.py", "handmade_materials.py", "import_material.py",
           "compat_noise.py")
CHROOT = "/srv/trixie"
# (0.37, 0.23) m: 47 x 29 px, far more than any material's grain yet well under the
# plane, and commensurate with none of the periodic layouts (tiles 0.25, bricks 0.24 in
# rows of 0.085, planks 0.14, weave 0.05), so the shifted image is the same material in
# another arrangement, never the same picture.
SHIFT = (0.37, 0.23)
# file -> (seed, shift or None, scene file or None)
RENDERS = {"render": (1, None, None), "shifted": (2, SHIFT, None),
           "flash": (3, None, os.path.join(REPO, "assets", "scene-flash.json")),
           "render-b": (4, None, None)}


class Blender:
    """Runs our scripts in one Blender: 3.4 on PATH or 4.x in the chroot, from a scratch
    directory that holds copies of the scripts (inside the chroot when needed)."""

    def __init__(self, version, threads):
        self.chroot = version != "3.4"
        self.threads = threads
        self.work = tempfile.mkdtemp(dir=os.path.join(CHROOT, "tmp") if self.chroot else None)
        for s in SCRIPTS:
            shutil.copy(os.path.join(REPO, "blender", s), self.work)

    def inside(self, path):
        return path[len(CHROOT):] if self.chroot else path

    def run(self, script, args):
        cmd = ["nice", "-n", "10"] + (["chroot", CHROOT] if self.chroot else []) + [
            "blender", "-b", "--factory-startup", "-noaudio", "-P",
            self.inside(os.path.join(self.work, script)), "--"] + args
        return subprocess.run(cmd, capture_output=True, text=True)

    def render(self, name, samples, seed, shift, scene_file, out_exr, out_png):
        """Renders NAME to OUT_EXR (and OUT_PNG if given); returns (seconds, version) or
        raises RuntimeError with Blender's output."""
        w = lambda f: os.path.join(self.work, f)  # noqa: E731
        args = [name, "--samples", str(samples), "--seed", str(seed), "-o",
                self.inside(w("out.exr")), "--timing", self.inside(w("out.json")),
                "--threads", str(self.threads)]
        if shift:
            args += ["--shift", repr(shift[0]), repr(shift[1])]
        if scene_file:
            # Under its own name: render_handmade.py records the scene file's basename.
            shutil.copy(scene_file, w(os.path.basename(scene_file)))
            args += ["--scene-file", self.inside(w(os.path.basename(scene_file)))]
        if out_png:
            args += ["--png", self.inside(w("out.png"))]
        r = self.run("render_handmade.py", args)
        if r.returncode != 0 or not os.path.exists(w("out.exr")):
            raise RuntimeError("Blender failed:\n%s\n%s" % (r.stdout[-2000:], r.stderr[-2000:]))
        with open(w("out.json")) as f:
            timing = json.load(f)
        if out_png:
            shutil.move(w("out.png"), out_png + ".tmp")
            os.replace(out_png + ".tmp", out_png)
        shutil.move(w("out.exr"), out_exr + ".tmp")
        os.replace(out_exr + ".tmp", out_exr)
        os.remove(w("out.json"))
        return timing

    def sheet(self, pngs, out, tile=128, columns=4):
        w = lambda f: os.path.join(self.work, f)  # noqa: E731
        for i, p in enumerate(pngs):
            shutil.copy(p, w("in%02d.png" % i))
        r = self.run("render_handmade.py", ["--sheet", self.inside(w("sheet.png")),
                                            "--tile", str(tile), "--columns", str(columns)]
                     + [self.inside(w("in%02d.png" % i)) for i in range(len(pngs))])
        if r.returncode != 0 or not os.path.exists(w("sheet.png")):
            raise RuntimeError("Blender failed:\n%s\n%s" % (r.stdout[-2000:], r.stderr[-2000:]))
        shutil.move(w("sheet.png"), out + ".tmp")
        os.replace(out + ".tmp", out)

    def close(self):
        shutil.rmtree(self.work, ignore_errors=True)


def material_names():
    """The names in handmade_materials.MATERIALS, in order, read from the source (plain
    python has no bpy to import it): the tuple of functions its comprehension iterates."""
    path = os.path.join(REPO, "blender", "handmade_materials.py")
    with open(path) as f:
        tree = ast.parse(f.read(), path)
    for node in tree.body:
        if (isinstance(node, ast.Assign) and getattr(node.targets[0], "id", None) == "MATERIALS"
                and isinstance(node.value, ast.DictComp)):
            return [e.id for e in node.value.generators[0].iter.elts]
    sys.exit("render_handmade_set: %s: no MATERIALS = {f.__name__: f for f in (...)}" % path)


def update_json(path, key, value):
    """render.json[KEY] = VALUE, rewritten whole (temporary name, rename)."""
    data = {}
    if os.path.exists(path):
        with open(path) as f:
            data = json.load(f)
    data[key] = value
    with open(path + ".tmp", "w") as f:
        json.dump(data, f, indent=1, sort_keys=True)
        f.write("\n")
    os.replace(path + ".tmp", path)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("names", nargs="*")
    p.add_argument("--samples", type=int, default=128)
    p.add_argument("--blender", default="4.3", help="3.4 (on PATH) or 4.3 (the chroot)")
    p.add_argument("--out", default=os.path.join(REPO, "tests", "handmade"))
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--only", default=",".join(RENDERS),
                   help="which renders, comma-separated (default all: %s); the evaluation's "
                   "floor needs render and shifted, its flash rows flash" % ",".join(RENDERS))
    a = p.parse_args()
    only = [k for k in a.only.split(",") if k]
    unknown = [k for k in only if k not in RENDERS]
    if unknown:
        p.error("--only: unknown render(s) %s" % ", ".join(unknown))
    blender = Blender(a.blender, a.threads)
    ok = True
    try:
        names = a.names or material_names()
        for name in names:
            d = os.path.join(a.out, name)
            os.makedirs(d, exist_ok=True)
            for kind, (seed, shift, scene_file) in RENDERS.items():
                if kind not in only:
                    continue
                exr = os.path.join(d, kind + ".exr")
                png = os.path.join(d, "preview.png") if kind == "render" else None
                if os.path.exists(exr) and (png is None or os.path.exists(png)):
                    continue
                try:
                    t = blender.render(name, a.samples, seed, shift, scene_file, exr, png)
                except RuntimeError as e:
                    sys.stderr.write("%s %s: %s\n" % (name, kind, e))
                    ok = False
                    continue
                update_json(os.path.join(d, "render.json"), kind, {
                    "blender": t["blender"], "samples": t["samples"], "seed": t["seed"],
                    "shift": t["shift"], "scene_file": t["scene_file"] or "scene.json (DESIGN.md's, built in)",
                    "seconds": t["seconds"]})
                print("%s %s: %.1f s" % (name, kind, t["seconds"]), flush=True)
        if not a.names:
            pngs = [os.path.join(a.out, n, "preview.png") for n in names]
            if all(os.path.exists(q) for q in pngs):
                blender.sheet(pngs, os.path.join(a.out, "sheet.png"))
                print("sheet.png: %d previews" % len(pngs))
    finally:
        blender.close()
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
