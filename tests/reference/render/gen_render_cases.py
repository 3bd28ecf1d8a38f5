#!/usr/bin/env python3
"""Writes the materials whose converged Cycles renders are the renderer's references:
tests/reference/render/<case>/graph.json. Plain python3. The renders are made by
blender/render_references.py; a graph that changes invalidates its renders (delete them).

Cases (issue 4): plain diffuse-looking white and grey (Principled, metallic 0), pure metal
at roughness 0.05 / 0.3 / 0.8, dielectric at roughness 0.05 / 0.5 / 1.0, a coloured metal,
a strong bump, and noise-driven base colour / roughness / metallic; and six random
super-shader parametrizations, supershader_sN for frames N = 0..5 (`imsynth sample --seed N`):
graph.json is `imsynth export assets/supershader.json --seed N`, the sub-shader, which
evaluates to the same maps as the bound super-shader (test_extract) and builds in Blender 3.4
as well as 4.3 (the whole super-shader builds in 4.x only; tests/reference/nodes/
gen_roundtrip.py says why). Frames 0..5 are also round-trip cases there, so their maps are
already proven equal to Blender's.

    python3 tests/reference/render/gen_render_cases.py [--imsynth PATH]

The imsynth binary: --imsynth, else $IMSYNTH, else the newest build*/cli/imsynth.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
SUPERSHADER_SEEDS = range(6)
sys.path.insert(0, os.path.join(REPO, "tests"))
from imsynth_binary import find_imsynth  # noqa: E402


def material(name, bsdf_inputs, extra_nodes=(), extra_links=()):
    nodes = list(extra_nodes) + [
        {"name": "Principled BSDF", "type": "ShaderNodeBsdfPrincipled", "location": [0, 0],
         "inputs": bsdf_inputs},
        {"name": "Material Output", "type": "ShaderNodeOutputMaterial", "location": [300, 0]},
    ]
    links = list(extra_links) + [
        {"from_node": "Principled BSDF", "from_socket": "BSDF",
         "to_node": "Material Output", "to_socket": "Surface"}]
    return {"format": "imsynth-graph/1", "name": name, "nodes": nodes, "links": links}


def link(a, sa, b, sb):
    return {"from_node": a, "from_socket": sa, "to_node": b, "to_socket": sb}


def cases():
    c = {}
    c["diffuse_white"] = material("diffuse_white", {"Base Color": [1, 1, 1, 1], "Roughness": 1.0})
    c["diffuse_grey"] = material("diffuse_grey", {"Base Color": [0.18, 0.18, 0.18, 1], "Roughness": 1.0})
    for r in (0.05, 0.3, 0.8):
        n = "metal_r%03d" % round(r * 100)
        c[n] = material(n, {"Base Color": [0.9, 0.9, 0.9, 1], "Metallic": 1.0, "Roughness": r})
    for r in (0.05, 0.5, 1.0):
        n = "dielectric_r%03d" % round(r * 100)
        c[n] = material(n, {"Base Color": [0.5, 0.5, 0.5, 1], "Metallic": 0.0, "Roughness": r})
    c["gold"] = material("gold", {"Base Color": [1.0, 0.766, 0.336, 1], "Metallic": 1.0,
                                  "Roughness": 0.25})
    c["strong_bump"] = material(
        "strong_bump", {"Base Color": [0.6, 0.6, 0.6, 1], "Roughness": 0.4},
        [{"name": "Noise", "type": "ShaderNodeTexNoise", "location": [-500, -200],
          "inputs": {"Scale": 6.0, "Detail": 4.0}},
         {"name": "Bump", "type": "ShaderNodeBump", "location": [-250, -200],
          "inputs": {"Strength": 1.0, "Distance": 0.3}}],
        [link("Noise", "Fac", "Bump", "Height"), link("Bump", "Normal", "Principled BSDF", "Normal")])
    c["noise_driven"] = material(
        "noise_driven", {},
        [{"name": "Noise", "type": "ShaderNodeTexNoise", "location": [-800, 100],
          "inputs": {"Scale": 4.0, "Detail": 6.0, "Roughness": 0.55}},
         {"name": "Voronoi", "type": "ShaderNodeTexVoronoi", "location": [-800, -300],
          "inputs": {"Scale": 5.0}},
         {"name": "Ramp", "type": "ShaderNodeValToRGB", "location": [-500, 200],
          "color_ramp": {"interpolation": "LINEAR", "color_mode": "RGB", "hue_interpolation": "NEAR",
                         "elements": [{"position": 0.3, "color": [0.35, 0.12, 0.05, 1]},
                                      {"position": 0.7, "color": [0.85, 0.7, 0.45, 1]}]}},
         {"name": "Rough", "type": "ShaderNodeMapRange", "location": [-500, 0],
          "inputs": {"From Min": 0.2, "From Max": 0.8, "To Min": 0.15, "To Max": 0.85}},
         {"name": "Metal", "type": "ShaderNodeMath", "location": [-500, -250],
          "properties": {"operation": "LESS_THAN"}, "inputs": {"Value_001": 0.35}}],
        [link("Noise", "Fac", "Ramp", "Fac"), link("Noise", "Fac", "Rough", "Value"),
         link("Voronoi", "Distance", "Metal", "Value"),
         link("Ramp", "Color", "Principled BSDF", "Base Color"),
         link("Rough", "Result", "Principled BSDF", "Roughness"),
         link("Metal", "Value", "Principled BSDF", "Metallic")])
    return c


def supershader_cases(imsynth):
    c = {}
    for seed in SUPERSHADER_SEEDS:
        fd, tmp = tempfile.mkstemp(prefix="gen_render_cases-", suffix=".json")
        os.close(fd)
        try:
            subprocess.run([imsynth, "export", os.path.join(REPO, "assets", "supershader.json"),
                            "--seed", str(seed), "-o", tmp], check=True)
            with open(tmp) as f:
                g = json.load(f)
        finally:
            os.unlink(tmp)
        g["name"] = "supershader_s%d" % seed
        c[g["name"]] = g
    return c


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--imsynth")
    a = ap.parse_args()
    all_cases = cases()
    all_cases.update(supershader_cases(find_imsynth(a.imsynth, "gen_render_cases")))
    for name, g in all_cases.items():
        d = os.path.join(HERE, name)
        os.makedirs(d, exist_ok=True)
        path = os.path.join(d, "graph.json")
        text = json.dumps(g, indent=1) + "\n"
        if os.path.exists(path) and open(path).read() != text and any(
                f.endswith(".exr") for f in os.listdir(d)):
            raise SystemExit("%s changed but has renders: delete them first" % d)
        with open(path + ".tmp", "w") as f:
            f.write(text)
        os.replace(path + ".tmp", path)
    print("%d cases" % len(all_cases))


if __name__ == "__main__":
    main()
