#!/usr/bin/env python3
"""Render the six super-shader frames of tests/reference/render/supershader_s0..s5 with
Cycles at 252 samples (the thesis's dataset setting), one render each (seed 3, unlike the
4096-sample reference's halves, seeds 1 and 2), in Blender 4.3 (the trixie chroot):

    python3 tests/bench/cycles_252_references.py [--versions 4.3] [--cases s0,s1,...]

Writes tests/reference/render/supershader_sN/blender-<ver>-252.exr and .json (version,
samples, seed, seconds inside Blender). Missing files only; each written whole or not at
all (render_references.render_cycles). Used by tests/bench/bench_datagen_preset (is our
datagen preset's descriptor as close to the converged reference as Cycles-252's?) and by
the datagen throughput comparison (Blender's seconds per frame). Plain python3.
"""
import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(REPO, "blender"))
import render_references  # noqa: E402

p = argparse.ArgumentParser()
p.add_argument("--versions", default="4.3")
p.add_argument("--cases", default="s0,s1,s2,s3,s4,s5")
p.add_argument("--samples", type=int, default=252)
p.add_argument("--seed", type=int, default=3)
a = p.parse_args()
for case in a.cases.split(","):
    d = os.path.join(REPO, "tests", "reference", "render", "supershader_" + case)
    for v in a.versions.split(","):
        out = os.path.join(d, "blender-%s-%d.exr" % (v, a.samples))
        if os.path.exists(out):
            continue
        print("rendering", case, v, flush=True)
        why = render_references.render_cycles(os.path.join(d, "graph.json"), v, a.samples, a.seed,
                                              out, out[:-4] + ".json", threads=0, nice=0)
        if why:
            sys.exit("%s %s: %s" % (case, v, why))
