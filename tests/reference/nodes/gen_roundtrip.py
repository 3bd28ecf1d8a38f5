#!/usr/bin/env python3
"""Round-trip reference cases: the super-shader and its sub-shaders, built in Blender.

    python3 tests/reference/nodes/gen_roundtrip.py [--imsynth PATH] [--seeds 0-10,19,23]

Writes, for each seed N (frame N's parameters, `imsynth sample --seed N`) and each of the
four maps the renderer reads from the Principled BSDF (Base Color, Metallic, Roughness,
Normal):

- roundtrip_sN_super_<map>: graph.json = `imsynth export assets/supershader.json --seed N
  --full` (the whole super-shader, groups and all, parameters bound);
- roundtrip_sN_sub_<map>: graph.json = `imsynth export assets/supershader.json --seed N`
  (the sub-shader the extractor keeps);

and, for each material made by hand in Blender (tests/reference/blender_made/*.json, written
by blender/export_material.py from the .blend that tests/reference/blender_made/
make_materials.py builds), blender_made_<name>_<map> with graph.json = that exported JSON.

blender/render_node_references.py then renders each socket in Blender through
import_material.py (point samples at the pixel centres) and tests/unit/test_blender_nodes.c
compares our evaluation of the same graph.json: so the super-shader built in Blender, the
sub-shader built in Blender and a hand-made Blender material all give our four maps.

Hand-made materials: NAME.json was made and exported in Blender 4.3 and is rendered in 4.3
only (its exporter writes every 4.x Principled input, which 3.x cannot build); NAME_b34.json
was made (3.x Musgrave nodes and all) and exported in Blender 3.4, and is rendered in both.

The imsynth binary: --imsynth, else $IMSYNTH, else build*/cli/imsynth under the repository
root, else `imsynth` on PATH (`make references` runs every gen_*.py without arguments).

Versions. The super-shader is rendered in 4.3 only: its Noise Module has a Ridged
Multifractal whose Detail is linked (a parameter), which Blender 3.x's Musgrave cannot take
(3.x's Detail is 4.x's + 1; blender/compat_noise.py translates constants only, and
import_material refuses). The sub-shaders fold that Detail to a constant and build in 3.4
too; they are exported with 4.x folding, so their 3.4 references check our 3.x evaluation
of that same graph, not a 3.x extraction.

Tolerance 1e-4 everywhere. The super-shader's coordinates are the raw Object / Generated
coordinates (not casekit's snapped pixel centres: the graph is the real one), and Cycles'
hit point is within ~1e-7 of the pixel centre, so wherever a map is discontinuous (Voronoi
cell borders, the extractor's hard switches, Math comparisons) a pixel may fall on the other
side: such cases allow 0.1% of pixels (16 of 16384) past the tolerance, and say so.

Measured (frames 0-10, 19 and 23 of the 11-pattern, 13-colour assets/supershader.json whose
two pattern colours share one value range, session 32; frames 0, 6, 10, 19 and 23 draw its
bricks or grain bands): every pixel of every case is within 5.9e-5 except a few on
discontinuities: 3 pixels at up to 2.2e-4 in the Normal of frame 6 (3.4 and 4.3) and, in 3.4
only, the Normal of frames 19 (12 pixels, 0.073%, 5.6e-4) and 23 (8 pixels, 2.1e-4), the Base
Color of frame 23 (3 pixels, 1.3e-3) and one Roughness pixel of frame 19. Sessions 14 and 21's
graphs (other colour ranges) had the same cases.
Not traced pixel by pixel this time; on the 9-pattern super-shader (at 8594f79) frame 6's
Normal had 10 such pixels, and moving our pixel centres by one float step of the
coordinate moved exactly those 10 by exactly their error against Blender: its Bump height
was (F2 - F1) divided by a smoothstep of the distance to the cell edge (a steep quotient
near an edge), and Bump (Distance 0.0235 over a 1/64 pixel footprint) magnifies a shift of
Cycles' hit point. Snapping the coordinates would remove such pixels but would no longer
be the material.

Regenerating after assets/supershader.json changed: the graphs change while rendered EXRs
exist, which casekit refuses; run with CASEKIT_FORCE=1 (the stale EXRs are deleted and the
driver renders them again).
"""

import argparse
import glob
import json
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(os.path.dirname(HERE)))
from casekit import write_case  # noqa: E402
from imsynth_binary import find_imsynth  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
SUPERSHADER = os.path.join(REPO, "assets", "supershader.json")
BLENDER_MADE = os.path.join(REPO, "tests", "reference", "blender_made")
PRINCIPLED = "Principled BSDF"
MAPS = (("basecolor", "Base Color"), ("metallic", "Metallic"),
        ("roughness", "Roughness"), ("normal", "Normal"))
V4 = ("4.3",)
BOTH = ("3.4", "4.3")

POINT_NOTE = ("Raw (unsnapped) coordinates, as the real material uses them; Cycles' hit "
              "point is within ~1e-7 of the pixel centre, so where the map is discontinuous "
              "(Voronoi cell borders, hard switches, Math comparisons) a pixel may land on "
              "the other side: up to 0.1% of pixels may differ (max_bad_fraction 0.001).")
SUPER_NOTE = ("Blender 4.3 only: the Noise Module's Ridged Multifractal has Detail linked "
              "to a parameter, which 3.x's Musgrave (Detail + 1) cannot be built with.")
MADE4_NOTE = ("4.3 only: 4.3's exporter writes every Principled BSDF input (Coat, Sheen, "
              "... at their 4.x defaults), which import_material refuses to build in 3.x.")
SUB_NOTE = ("Exported with 4.x constant folding (imsynth export's default); the 3.4 "
            "reference checks our 3.x evaluation of this same graph.")


class JsonGraph:
    """A ready-made graph JSON in the shape casekit.write_case takes (to_json, _get)."""

    def __init__(self, data, source):
        if not isinstance(data, dict) or data.get("format") != "imsynth-graph/1":
            raise SystemExit("gen_roundtrip: %s: not an imsynth-graph/1 graph" % source)
        self.data = data
        self.source = source

    def to_json(self):
        return self.data

    def _get(self, name):
        for n in self.data.get("nodes", []):
            if n.get("name") == name:
                return n
        raise SystemExit("gen_roundtrip: %s: no node named %r in the material tree"
                         % (self.source, name))


def export(imsynth, seed, full):
    """The exported material of frame `seed`, as parsed JSON."""
    fd, tmp = tempfile.mkstemp(prefix="gen_roundtrip-", suffix=".json")
    os.close(fd)
    try:
        cmd = [imsynth, "export", SUPERSHADER, "--seed", str(seed), "-o", tmp]
        if full:
            cmd.append("--full")
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           universal_newlines=True)
        if p.returncode != 0:
            raise SystemExit("gen_roundtrip: %s failed (exit %d):\n%s"
                             % (" ".join(cmd), p.returncode, p.stdout))
        with open(tmp) as f:
            return json.load(f)
    finally:
        os.remove(tmp)


def parse_seeds(text):
    seeds = []
    for part in text.split(","):
        m = re.fullmatch(r"(\d+)(?:-(\d+))?", part.strip())
        if not m:
            raise SystemExit("gen_roundtrip: bad --seeds %r (e.g. 0-9 or 1,4,7)" % text)
        lo, hi = int(m.group(1)), int(m.group(2) or m.group(1))
        seeds.extend(range(lo, hi + 1))
    return seeds


def write_map_cases(prefix, graph, versions, note):
    for tag, socket in MAPS:
        write_case("%s_%s" % (prefix, tag), graph, socket=(PRINCIPLED, socket),
                   versions=versions, tolerance=1e-4, max_bad_fraction=0.001, note=note)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--imsynth", help="the imsynth binary (default: see the module doc)")
    ap.add_argument("--seeds", default="0-10,19,23",
                    help="frames to export (default 0-10,19,23: 0, 6, 10, 19 and 23 draw the "
                    "bricks or grain bands)")
    a = ap.parse_args()
    imsynth = find_imsynth(a.imsynth, "gen_roundtrip")
    for seed in parse_seeds(a.seeds):
        src = "%s --seed %d" % (os.path.relpath(SUPERSHADER, REPO), seed)
        write_map_cases("roundtrip_s%d_super" % seed,
                        JsonGraph(export(imsynth, seed, True), src + " --full"),
                        V4, POINT_NOTE + " " + SUPER_NOTE)
        write_map_cases("roundtrip_s%d_sub" % seed, JsonGraph(export(imsynth, seed, False), src),
                        BOTH, POINT_NOTE + " " + SUB_NOTE)
    made = sorted(glob.glob(os.path.join(BLENDER_MADE, "*.json")))
    for path in made:
        name = os.path.splitext(os.path.basename(path))[0]
        with open(path) as f:
            data = json.load(f)
        made_in_3 = name.endswith("_b34")
        versions = BOTH if made_in_3 else V4
        write_map_cases("blender_made_%s" % name,
                        JsonGraph(data, os.path.relpath(path, REPO)), versions,
                        "Made by hand in Blender (tests/reference/blender_made/"
                        "make_materials.py), exported by blender/export_material.py from Blender "
                        + ("3.4. " if made_in_3 else "4.3. " + MADE4_NOTE + " ") + POINT_NOTE)
    return 0


if __name__ == "__main__":
    sys.exit(main())
