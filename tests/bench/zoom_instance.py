"""How rugged the refinement's loss is along a noise's Scale (refine.c, es-split): from the
parameters an `imsynth evaluate` report picked for an input, small moves of the Scales
alone and of every other value alone, each rendered and described with MobileNetV2 (the
training descriptor), then the Gram distance of each to the start's render and to the
input. A Scale multiplies coordinates that Pattern Offset shifted by up to 100, so a small
Scale move draws a new pattern instance: its render is as far from the start's as another
instance is; a value move of the same sigma changes the image smoothly. A third row renders
the start itself at other render seeds: the Monte Carlo noise of the search preset, the
part of every loss difference that no parameter explains.

    /usr/bin/python3 tests/bench/zoom_instance.py REPORT_DIR INPUT_NAME INPUT_IMAGE OUT_DIR \\
        [--method predictor-topk] [--sigma 0.01] [--draws 6]

Renders use predict's search preset ("datagen": 4 spp, no adaptive sampling, 4 light
samples).

Needs numpy (Debian's python3-numpy, under /usr/bin/python3) and build/cli/imsynth.
"""
import argparse
import json
import os
import random
import re
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
IMSYNTH = os.path.join(ROOT, "build", "cli", "imsynth")


def run(*args):
    return subprocess.run([IMSYNTH, "--data", ROOT, *args], check=True, capture_output=True,
                          text=True).stdout


def gram_distance(a, b, spans):
    """evaluate_gram_distance's definition (pipeline/evaluate_metrics.c): per layer
    ||a - b|| / (||a|| + ||b||), averaged over the layers."""
    s = 0.0
    for lo, hi in spans:
        x, y = a[lo:hi], b[lo:hi]
        s += np.linalg.norm(x - y) / (np.linalg.norm(x) + np.linalg.norm(y) + 1e-12)
    return s / len(spans)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("report")
    ap.add_argument("input_name")
    ap.add_argument("input_image")
    ap.add_argument("out")
    ap.add_argument("--method", default="predictor-topk")
    ap.add_argument("--sigma", type=float, default=0.01)
    ap.add_argument("--draws", type=int, default=6)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)

    sample = os.path.join(a.out, "names.json")
    run("sample", "--seed", "1", "-o", sample)
    with open(sample) as f:
        names = list(json.load(f))
    with open(os.path.join(a.report, "report.json")) as f:
        rep = json.load(f)
    row = [i for i in rep["inputs"] if i["name"] == a.input_name]
    if not row:
        sys.exit(f"{a.report}/report.json: no input named {a.input_name}")
    start = dict(zip(names, row[0]["methods"][a.method]["params"]))
    zooms = [n for n in names if n.startswith("Noise ") and n.endswith(" Scale")]
    values = [n for n in names if n not in zooms and not n.startswith("Mult ")
              and n != "Pattern Offset"]

    rng = random.Random(1)
    sets = [("start", dict(start), 0)]
    for kind, moved in (("scales", zooms), ("values", values)):
        for k in range(a.draws):
            p = dict(start)
            for n in moved:
                p[n] = min(1.0, max(0.0, p[n] + rng.gauss(0.0, a.sigma)))
            sets.append((f"{kind}{k}", p, 0))
    for k in range(a.draws):
        sets.append((f"seeds{k}", dict(start), k + 1))
    images = []
    for label, p, seed in sets:
        pj = os.path.join(a.out, f"{label}.json")
        with open(pj, "w") as f:
            json.dump(p, f)
        img = os.path.join(a.out, f"{label}.exr")
        run("render", os.path.join(ROOT, "assets", "supershader.json"), "--params", pj,
            "--spp", "4", "--max-spp", "0", "--light-samples", "4", "--seed", str(seed),
            "-o", img)
        images.append(img)
    npy = os.path.join(a.out, "desc.npy")
    out = run("describe", "--features", "mobilenetv2", a.input_image, *images, "-o", npy)
    spans = [(int(lo), int(hi) + 1) for lo, hi in re.findall(r"columns (\d+)\.\.(\d+)", out)]
    d = np.load(npy).astype(np.float64)
    to_start = {}
    to_input = {}
    for j, (label, _, _) in enumerate(sets):
        to_start[label] = gram_distance(d[1], d[1 + j], spans)
        to_input[label] = gram_distance(d[0], d[1 + j], spans)
    print(f"{a.input_name}, {a.method}'s parameters, sigma {a.sigma}, {a.draws} draws each, "
          "the datagen preset; MobileNetV2 Gram distances")
    print(f"start to input: {to_input['start']:.5f}")
    print("| moved | to the start's render: mean (min-max) | to the input: mean (min-max) |")
    print("|---|---|---|")
    for kind, n in (("scales", len(zooms)), ("values", len(values)), ("seeds", 0)):
        s = [to_start[f"{kind}{k}"] for k in range(a.draws)]
        i = [to_input[f"{kind}{k}"] for k in range(a.draws)]
        what = f"the {n} {kind}" if n else "nothing (other render seeds)"
        print(f"| {what} | {np.mean(s):.4f} ({min(s):.4f}-{max(s):.4f}) | "
              f"{np.mean(i):.4f} ({min(i):.4f}-{max(i):.4f}) |")


if __name__ == "__main__":
    main()
