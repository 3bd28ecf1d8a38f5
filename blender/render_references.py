#!/usr/bin/env python3
"""Render the converged Cycles references of tests/reference/render/<case>/.

    python3 blender/render_references.py [CASE_DIR ...] [--versions 3.4,4.3]
                                         [--samples 2048] [--threads 0]

Each case directory holds graph.json (a material in our format), and scene.json when the case
is rendered in one of our other scene files (the flash scene). For each Blender
version, two halves are rendered with different seeds, each with --samples samples
(default 2048, so the reference has 4096): blender-<ver>-a.exr and blender-<ver>-b.exr
(half float), with blender-<ver>-a.json / -b.json giving the Blender version, samples and
render time. The reference is their mean; half their difference measures its own noise.
Missing halves only are rendered, so the script resumes where it stopped: a half is
written to a temporary name and renamed when complete.

Blender 3.4 is `blender` on PATH; 4.3 runs in the Debian trixie chroot /srv/trixie
(scripts/setup-oracles installs both). Renders run at nice 10. Plain python3.
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROOT = os.path.join(REPO, "tests", "reference", "render")
SCRIPTS = ("render_reference.py", "import_material.py", "compat_noise.py")
CHROOT = "/srv/trixie"
SEEDS = {"a": 1, "b": 2}


def blender_workdir(version, scripts=SCRIPTS):
    """A fresh temporary folder Blender VERSION can read and write, with our Blender
    SCRIPTS copied in: for 4.x it is under the chroot's /tmp. Returns (work, inside, cmd):
    the folder as we see it, a function giving a path as Blender sees it, and the command
    that starts Blender ("chroot /srv/trixie blender" or "blender"). The caller removes
    the folder."""
    chroot = version != "3.4"
    work = tempfile.mkdtemp(dir=os.path.join(CHROOT, "tmp") if chroot else None)
    for s in scripts:
        shutil.copy(os.path.join(REPO, "blender", s), work)
    inside = (lambda p: p[len(CHROOT):]) if chroot else (lambda p: p)
    return work, inside, (["chroot", CHROOT] if chroot else []) + ["blender"]


def render_cycles(graph, version, samples, seed, out_exr, out_timing, threads=0, nice=10):
    """Renders GRAPH (our JSON) in Blender VERSION ("3.4" on PATH, else the trixie chroot's
    4.x) with Cycles: SAMPLES samples, Cycles seed SEED, to OUT_EXR (half float) and
    OUT_TIMING (JSON: Blender version, samples, seed, seconds of the render inside
    Blender). Both are written whole or not at all. Returns None, or what went wrong."""
    work, inside, blender = blender_workdir(version)
    try:
        shutil.copy(graph, os.path.join(work, "graph.json"))
        # A case with its own scene file (e.g. the flash scene) is rendered in that scene.
        scene_file = os.path.join(os.path.dirname(graph), "scene.json")
        if os.path.exists(scene_file):
            shutil.copy(scene_file, os.path.join(work, "scene.json"))
        cmd = blender + ["-b", "--factory-startup", "-noaudio", "-P",
                         inside(os.path.join(work, "render_reference.py")), "--",
                         inside(os.path.join(work, "graph.json")), "--samples", str(samples),
                         "--seed", str(seed), "-o", inside(os.path.join(work, "out.exr")),
                         "--timing", inside(os.path.join(work, "out.json")),
                         "--threads", str(threads)]
        if os.path.exists(scene_file):
            cmd += ["--scene-file", inside(os.path.join(work, "scene.json"))]
        cmd = (["nice", "-n", str(nice)] if nice else []) + cmd
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0 or not os.path.exists(os.path.join(work, "out.exr")):
            return "Blender failed:\n%s\n%s" % (r.stdout[-2000:], r.stderr[-2000:])
        shutil.move(os.path.join(work, "out.exr"), out_exr + ".tmp")
        os.replace(out_exr + ".tmp", out_exr)
        shutil.move(os.path.join(work, "out.json"), out_timing + ".tmp")
        os.replace(out_timing + ".tmp", out_timing)
        return None
    finally:
        shutil.rmtree(work, ignore_errors=True)


def render_half(case, version, half, samples, threads):
    out = os.path.join(case, "blender-%s-%s.exr" % (version, half))
    timing = os.path.join(case, "blender-%s-%s.json" % (version, half))
    if os.path.exists(out) and os.path.exists(timing):
        return True
    err = render_cycles(os.path.join(case, "graph.json"), version, samples, SEEDS[half], out,
                        timing, threads)
    if err:
        sys.stderr.write("%s %s %s: %s\n" % (case, version, half, err))
        return False
    print("%s: Blender %s half %s done" % (os.path.basename(case), version, half), flush=True)
    return True


def main():
    p = argparse.ArgumentParser()
    p.add_argument("cases", nargs="*")
    p.add_argument("--versions", default="3.4,4.3")
    p.add_argument("--samples", type=int, default=2048)
    p.add_argument("--threads", type=int, default=0)
    a = p.parse_args()
    cases = [os.path.abspath(c) for c in a.cases] or sorted(
        os.path.join(ROOT, d) for d in os.listdir(ROOT)
        if os.path.isfile(os.path.join(ROOT, d, "graph.json")))
    ok = True
    # Halves in an order that finishes whole references early: case, version, half.
    for case in cases:
        for version in a.versions.split(","):
            for half in ("a", "b"):
                ok &= render_half(case, version, half, a.samples, a.threads)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
