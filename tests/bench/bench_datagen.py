#!/usr/bin/python3
"""Datagen throughput against the thesis's pipeline, side by side in one run:

    /usr/bin/python3 tests/bench/bench_datagen.py [--frames 2] [--count 200] [--imsynth build/cli/imsynth]

The thesis made a sample by rendering a frame in Blender Cycles at 252 samples and describing
it with the PyTorch VGG19 descriptor. Here, on the same samples (super-shader frames 0..F-1,
whose sub-shaders are tests/reference/render/supershader_s0..), this measures:
  - Blender 4.3 (trixie chroot) Cycles at 252 samples, 256x256, 2 threads: the seconds inside
    Blender's render call (start-up and scene building excluded, in Blender's favour);
  - PyTorch 1.13 VGG19 descriptor (avg3, random weights), 2 threads, seconds per image;
  - imsynth datagen on the same ids, each preset, 2 threads: samples/s, the time split and
    peak RSS; then longer runs of --count ids for the steady rate, with each descriptor.
Prints a markdown table; the load average is printed before and after (the machine may be
shared). Needs scripts/setup-oracles.
"""
import json
import os
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(REPO, "blender"))
import render_references  # noqa: E402
from bench_common import loadavg as load  # noqa: E402

args = sys.argv[1:]
def opt(name, default):
    return args[args.index(name) + 1] if name in args else default
frames = int(opt("--frames", "2"))
count = int(opt("--count", "200"))
imsynth = os.path.abspath(opt("--imsynth", os.path.join(REPO, "build", "cli", "imsynth")))

print("load average before:", " ".join(load()), flush=True)
work = tempfile.mkdtemp()

# Blender: the frames at 252 samples, one after the other.
blender = []
for f in range(frames):
    graph = os.path.join(REPO, "tests", "reference", "render", "supershader_s%d" % f, "graph.json")
    exr, js = os.path.join(work, "c%d.exr" % f), os.path.join(work, "c%d.json" % f)
    t0 = time.time()
    why = render_references.render_cycles(graph, "4.3", 252, 3, exr, js, threads=2, nice=0)
    wall = time.time() - t0
    if why:
        sys.exit(why)
    inside = json.load(open(js))["seconds"]
    blender.append((inside, wall))
    print("Blender frame %d: %.1f s inside, %.1f s with start-up" % (f, inside, wall), flush=True)

# PyTorch descriptor, 2 threads, batch 1 (a sample at a time, as datagen).
r = subprocess.run(["/usr/bin/python3", os.path.join(HERE, "bench_vgg_torch.py"), "--threads", "2",
                    "--reps", "3", "--quick"], capture_output=True, text=True)
m = re.search(r"avg3\s+1\s+([0-9.]+)", r.stdout)
torch_s = float(m.group(1)) if m else float("nan")
print("PyTorch descriptor: %s s/image" % torch_s, flush=True)
if not m:
    print(r.stdout[-2000:], r.stderr[-2000:])

def datagen(first, n, preset, tag, descriptor="mobilenetv2"):
    out = os.path.join(work, "%s.sqlite" % tag)
    t0 = time.time()
    r = subprocess.run([imsynth, "datagen", "--out", out, "--first-id", str(first), "--count",
                        str(n), "--preset", preset, "--threads", "2", "--descriptor", descriptor],
                       capture_output=True, text=True, env=dict(os.environ))
    wall = time.time() - t0
    if r.returncode:
        sys.exit(r.stderr)
    lines = [l for l in r.stderr.splitlines() if l.startswith("datagen:")]
    split = re.search(r"\((sample.*)\)", lines[-2]).group(1) if len(lines) > 1 else ""
    rss = re.search(r"peak RSS (\d+) MB", lines[-1]).group(1)
    return wall / n, split, rss

rows = []
for preset in ("draft", "datagen", "converged"):
    per, split, rss = datagen(0, frames, preset, "same-" + preset)
    rows.append((preset + ", mobilenetv2", "frames 0-%d" % (frames - 1), per, split, rss))
for preset in ("draft", "datagen"):
    for desc in ("mobilenetv2", "vgg19"):
        per, split, rss = datagen(1000000, count, preset, "long-%s-%s" % (preset, desc), desc)
        rows.append((preset + ", " + desc, "%d ids from 1000000" % count, per, split, rss))

b_inside = sum(b[0] for b in blender) / frames
b_wall = sum(b[1] for b in blender) / frames
thesis = b_inside + torch_s
print()
print("Blender 4.3 Cycles-252 + PyTorch descriptor (the thesis's pipeline), frames 0-%d: "
      "%.1f s render inside Blender (%.1f s with start-up) + %.3f s descriptor = %.1f s a sample"
      % (frames - 1, b_inside, b_wall, torch_s, thesis))
print()
print("| imsynth preset, descriptor | samples | s/sample (wall, 2 threads) | samples/s | vs Blender+PyTorch | time split | peak RSS MB |")
print("|---|---|---|---|---|---|---|")
for preset, what, per, split, rss in rows:
    print("| %s | %s | %.3f | %.2f | %.0fx | %s | %s |" % (preset, what, per, 1 / per, thesis / per, split, rss))
print()
print("load average after:", " ".join(load()))
