#!/usr/bin/python3
"""Refinement speed against a Blender-in-the-loop search, both sides in one run (issue 16):

    python3 tests/bench/bench_refine_speed.py --model MODEL_DIR [--frame 0] [--candidates 10]
        [--matched 4] [--blender 4.3] [--imsynth build/cli/imsynth] [--no-pause] [--keep]
    python3 tests/bench/bench_refine_speed.py --report WORK/results.json

A Blender-in-the-loop search (VLMaterial's way) keeps one Blender running and, for each
candidate parameter set, changes the material and renders it with Cycles. Here, on super-
shader frame F:
  - Blender (4.3 in the trixie chroot by default; 3.4 with --blender 3.4): one process
    (blender/render_server.py) builds the FULL super-shader once in our scene; then each of
    N candidates, frame F's parameters with 1-3 of them moved as one step of our coordinate
    search moves them, sets the group's Value nodes and renders Cycles 256x256, 2 threads,
    at 4 samples a pixel (our datagen preset's camera rays), again at 1 (our draft's), and
    the first --matched candidates at 16 (our datagen preset's light samples, 4 x 4). The
    start-up and the first (compile) render are timed apart, not in the per-candidate
    figure. No descriptor or loss is computed on this side: the ratio is in Blender's
    favour by that much.
  - Blender again, on frame F's extracted sub-shader (a small graph, as a VLMaterial program
    is), rendered as it is N times at 4 and at 1 spp: what the loop would cost if Blender
    rendered only what the material uses.
  - imsynth render, one process per candidate, on the same N candidates at the datagen
    preset (4 shading points a pixel, 4 light samples each, no adaptive sampling) and the
    draft preset (1 shading point): the render itself, from --stats, and the process's wall
    time (start, load, bind, extract, compile).
  - imsynth predict on frame F's render (imsynth render, default quality, made before the
    measured part): everything default (candidates at draft since session 30, at datagen
    before; the default budget of refinement evaluations, 350 since session 31, 224 before,
    at the draft refine preset, final preset converged), then the refinement at datagen with 64
    (--refine-preset datagen --refine 64, the default before session 18). Evaluations/s =
    refinement.evaluations / seconds.refine; cached evaluations (a move that leaves the
    sub-shader unchanged) count, report["renders"] says how many renders were made.
The measured part runs with the background datagen (pgrep -f "datagen --out
/work/data/ds20k") stopped, for at most --pause-limit seconds (9.5 minutes; a watchdog
continues it, and the report says so); load
averages are printed before and after. Prints a markdown table.
"""
import argparse
import hashlib
import json
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(REPO, "blender"))
import render_references  # noqa: E402
from bench_common import loadavg, paused  # noqa: E402

BACKGROUND = "datagen --out /work/data/ds20k"
SERVER_SCRIPTS = ("render_server.py", "import_material.py", "compat_noise.py")


def run(cmd, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode:
        sys.exit("%s failed (%d):\n%s%s" % (" ".join(cmd), r.returncode, r.stdout[-2000:],
                                           r.stderr[-2000:]))
    return r


def perturb(params, rng, step=0.25):
    """One candidate as our coordinate search makes them (pipeline/refine.c): 1-3 parameters
    changed; a selector ("Mult N ...") to another of its N choices (the centre of its bin),
    a hue moved by +-step around the circle, another value by +-step clamped to [0, 1];
    "Pattern Offset" stays (refine_space_for_params marks it fixed)."""
    out = dict(params)
    names = [n for n in params if "Pattern Offset" not in n]
    for name in rng.sample(names, rng.randint(1, 3)):
        m = re.match(r"Mult (\d+) ", name)
        if m:
            n = int(m.group(1))
            c = min(int(params[name] * n), n - 1)
            r = rng.randrange(n - 1)
            out[name] = ((r + 1 if r >= c else r) + 0.5) / n
        else:
            v = params[name] + rng.choice((-step, step))
            out[name] = v % 1.0 if "Hue" in name else min(1.0, max(0.0, v))
    return out


class BlenderServer:
    """One Blender process running blender/render_server.py: requests on its stdin,
    replies on a pipe, its own output in a log file."""

    def __init__(self, version, full_json, threads):
        self.work, self.inside, blender = render_references.blender_workdir(version,
                                                                            SERVER_SCRIPTS)
        shutil.copy(full_json, os.path.join(self.work, "full.json"))
        self.log = open(os.path.join(self.work, "blender.log"), "w")
        r, w = os.pipe()
        t0 = time.time()
        self.p = subprocess.Popen(
            blender + ["-b", "--factory-startup", "-noaudio", "-P",
                       self.inside(os.path.join(self.work, "render_server.py")), "--",
                       self.inside(os.path.join(self.work, "full.json")), "--reply-fd", str(w),
                       "--threads", str(threads)],
            stdin=subprocess.PIPE, stdout=self.log, stderr=subprocess.STDOUT, text=True,
            pass_fds=(w,))
        os.close(w)
        self.replies = os.fdopen(r)
        self.hello = self._reply()
        self.hello["wall_to_ready_s"] = time.time() - t0

    def _reply(self):
        line = self.replies.readline()
        if not line:
            self.log.flush()
            tail = open(self.log.name).read()[-3000:]
            raise RuntimeError("Blender stopped:\n" + tail)
        return json.loads(line)

    def render(self, params, samples, name, seed=0):
        """Renders; returns (round-trip wall seconds, the reply) and the EXR's path."""
        out = os.path.join(self.work, name + ".exr")
        t0 = time.time()
        self.p.stdin.write(json.dumps({"params": params, "samples": samples, "seed": seed,
                                       "out": self.inside(out)}) + "\n")
        self.p.stdin.flush()
        rep = self._reply()
        wall = time.time() - t0
        if not os.path.exists(out):
            raise RuntimeError("Blender wrote no %s" % out)
        return wall, rep, out

    def close(self):
        try:
            self.p.stdin.write(json.dumps({"quit": True}) + "\n")
            self.p.stdin.close()
            self.p.wait(timeout=30)
        except (OSError, subprocess.TimeoutExpired):
            self.p.kill()
        self.log.close()
        shutil.rmtree(self.work, ignore_errors=True)


def mean(xs):
    return sum(xs) / len(xs) if xs else float("nan")


def report(R):
    """Prints what main measured (R, as main stores it in results.json)."""
    a = argparse.Namespace(**R["args"])
    threads, n_nodes, changed, res, pause = (R[k] for k in ("threads", "n_nodes", "changed",
                                                             "res", "pause"))
    first, first_wall, ims, preds = R["first"], R["first_wall"], R["ims"], R["preds"]
    bl = {int(k): v for k, v in R["bl"].items()}
    h = R["hello"]
    print("frame %d: sub-shader %d nodes; candidates change %s parameters" %
          (a.frame, n_nodes, ",".join(map(str, changed))))
    print("load average before: %s, after: %s; measured part %.0f s; background datagen %s"
          % (" ".join(res["load_before"]), " ".join(res["load_after"]), res["measured_s"],
             "not paused" if a.no_pause else "paused %.0f s (pids %s)%s" % (
                 pause["seconds"], pause["pids"],
                 ", WATCHDOG CONTINUED IT EARLY" if pause["watchdog"] else "")))
    print("other imsynth/Blender processes at the start:")
    for l in res["other_processes"]:
        print("   ", l[:150])
    print("Blender %s: %.1f s from the process start to ready (of which building the material, "
          "%d nodes at the top level, %d parameters, and the scene %.2f s); first render (4 spp, "
          "loads the kernels and compiles the shader) %.2f s inside, %.2f s round trip"
          % (h["blender"], h["wall_to_ready_s"], h["nodes"], h["parameters"], h["build_s"],
             first["render_s"], first_wall))
    for spp in (4, 1, 16):
        print("Blender %d spp per candidate, round trip: %s (%d distinct images)" %
              (spp, " ".join("%.2f" % w for w in bl[spp]["wall"]), bl[spp]["distinct"]))
    for preset in ims:
        print("imsynth render, %s preset, per candidate (render / process wall): %s; material "
              "evaluator %.0f%% of the render's thread time" % (
                  preset, " ".join("%.2f/%.2f" % x for x in zip(ims[preset]["render"],
                                                                ims[preset]["wall"])),
                  100 * sum(ims[preset]["material"]) / (a.threads * sum(ims[preset]["render"]))))
    for tag, rep in preds.items():
        s, rf = rep["seconds"], rep["refinement"]
        print("predict %s: wall %.1f s; seconds %s; renders %d; refinement %d evaluations "
              "(budget %d), %d accepted, loss %.4f -> %.4f; final loss %.4f"
              % (tag, rep["wall"], json.dumps({k: round(v, 2) for k, v in s.items()}),
                 rep["renders"], rf["evaluations"], rf["budget"], rf["accepted"],
                 rf["start_loss"], rf["best_loss"], rep["final"]["loss"]))

    b4 = mean(bl[4]["wall"])
    print()
    print("| side | renderer | samples | per candidate s | candidates/s | ratio to Blender 4 spp |")
    print("|---|---|---|---:|---:|---:|")
    print("| Blender %s in the loop | Cycles CPU, %s threads | 4 spp | %.2f (render call %.2f) | %.2f | 1x |"
          % (h["blender"], threads, b4, mean(bl[4]["render"]), 1 / b4))
    for spp in (1, 16):
        b = mean(bl[spp]["wall"])
        print("| Blender %s in the loop | Cycles CPU, %s threads | %d spp | %.2f (render call %.2f) | %.2f | %.2fx |"
              % (h["blender"], threads, spp, b, mean(bl[spp]["render"]), 1 / b, b4 / b))
    for preset in ims:
        iw = mean(ims[preset]["wall"])
        print("| imsynth render, same candidates, a process each | ours, %s threads | %s (%s x 4) | %.2f (render %.2f) | %.2f | %.1fx |"
              % (threads, preset, "4" if preset == "datagen" else "1", iw,
                 mean(ims[preset]["render"]), 1 / iw, b4 / iw))
    for tag, rep in preds.items():
        s, rf = rep["seconds"], rep["refinement"]
        per = s["refine"] / rf["evaluations"]
        rp = rep["loss"]["refine_preset"]
        print("| imsynth predict refinement, %s refine preset | ours, %s threads | %s | %.3f | %.2f | %.1fx |"
              % (rp, threads, "1 x 4" if rp == "draft" else "4 x 4", per, 1 / per, b4 / per))
    sub = R.get("bl_sub")  # absent from runs before the sub-shader rows existed
    if sub:
        print()
        print("Blender on the extracted sub-shader (%d nodes at the top level), unchanged between "
              "renders; first render %.2f s round trip:" % (sub["nodes"], sub["first_wall"]))
        print()
        print("| Blender, sub-shader | per render s (render call) | our draft refinement's evaluation, ratio | our datagen refinement's, ratio |")
        print("|---|---:|---:|---:|")
        per = {rep["loss"]["refine_preset"]: rep["seconds"]["refine"] / rep["refinement"]["evaluations"]
               for rep in preds.values()}
        for spp in ("4", "1"):
            b = mean(sub[spp]["wall"])
            print("| %s spp | %.2f (%.2f) | %s | %s |" % (
                spp, b, mean(sub[spp]["render"]),
                "%.1fx" % (b / per["draft"]) if "draft" in per else "-",
                "%.1fx" % (b / per["datagen"]) if "datagen" in per else "-"))
    print()
    print("| predict | evaluations (refine) | renders (refine, about) | non-render s an evaluation | render s a refine evaluation | refine s |")
    print("|---|---:|---:|---:|---:|---:|")
    for tag, rep in preds.items():
        s, rf = rep["seconds"], rep["refinement"]
        # renders counts every render: the candidates' (each distinct), the refinement's
        # (a cache hit renders nothing) and the final one. seconds.render sums them all;
        # the final one is in seconds.final (with its descriptor and the extraction,
        # milliseconds), so render - final is the search's rendering. What is not rendering
        # (descriptor, colour term, bind, extraction, compile) costs about the same for any
        # material, so it is averaged over the candidates' and the refinement's evaluations;
        # the rendering of the refinement is what is left of its time.
        n_c = len(rep["candidates"])
        refine_renders = rep["renders"] - 1 - n_c
        nonrender = (s["candidates"] + s["refine"] - (s["render"] - s["final"])) / (n_c + rf["evaluations"])
        print("| %s | %d | %d | %.3f | %.3f | %.1f |"
              % (tag, rf["evaluations"], refine_renders, nonrender,
                 s["refine"] / rf["evaluations"] - nonrender, s["refine"]))
    print()
    print("whole predict, default budget: %.1f s wall (report total %.1f s)"
          % (preds["default"]["wall"], preds["default"]["seconds"]["total"]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", help="a model from imsynth fit-predictor (required to measure)")
    ap.add_argument("--frame", type=int, default=0)
    ap.add_argument("--candidates", type=int, default=10)
    ap.add_argument("--matched", type=int, default=4,
                    help="candidates Blender also renders at 16 spp")
    ap.add_argument("--blender", default="4.3")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--imsynth", default=os.path.join(REPO, "build", "cli", "imsynth"))
    ap.add_argument("--no-pause", action="store_true", help="leave the background datagen running")
    ap.add_argument("--pause-limit", type=float, default=570,
                    help="seconds after which the watchdog continues the background datagen")
    ap.add_argument("--keep", action="store_true", help="keep the work folder (printed)")
    ap.add_argument("--report", metavar="RESULTS.json", help="print a kept run's results again")
    a = ap.parse_args()
    if a.report:
        with open(a.report) as f:
            report(json.load(f))
        return
    if not a.model:
        ap.error("--model is required")
    imsynth = os.path.abspath(a.imsynth)
    graph = os.path.join(REPO, "assets", "supershader.json")
    work = tempfile.mkdtemp(prefix="bench_refine_speed.")
    threads = str(a.threads)

    # Before the measured part: the material (whole and extracted), its parameters, the
    # input image and the candidates.
    full, sub = os.path.join(work, "full.json"), os.path.join(work, "sub.json")
    run([imsynth, "export", graph, "--seed", str(a.frame), "--full", "-o", full])
    run([imsynth, "export", graph, "--seed", str(a.frame), "-o", sub])
    base = json.loads(run([imsynth, "sample", "--seed", str(a.frame), "--graph", graph]).stdout)
    target = os.path.join(work, "target.exr")
    run(["nice", imsynth, "render", sub, "-o", target, "--threads", "1"])
    rng = random.Random(a.frame)
    cands = [perturb(base, rng) for _ in range(a.candidates)]
    cand_files = []
    for i, c in enumerate(cands):
        cand_files.append(os.path.join(work, "cand%d.json" % i))
        with open(cand_files[-1], "w") as f:
            json.dump(c, f)
    changed = [sum(1 for k in c if c[k] != base[k]) for c in cands]
    n_nodes = len(json.load(open(sub))["nodes"])

    res = {"load_before": loadavg()}
    others = subprocess.run(["pgrep", "-af", "imsynth|blender"], capture_output=True,
                            text=True).stdout
    res["other_processes"] = [l for l in others.splitlines() if str(os.getpid()) not in l]
    t_measure = time.time()
    with (paused(BACKGROUND, a.pause_limit) if not a.no_pause else _nopause()) as pause:
        # Blender in the loop.
        srv = BlenderServer(a.blender, full, a.threads)
        try:
            first_wall, first, _ = srv.render(base, 4, "first")
            bl = {}
            # 4 spp: as many camera rays a pixel as our datagen preset; 1 spp: as our draft;
            # 16 spp (first --matched candidates only, it is slow): as many light samples
            # a pixel as our datagen preset's 4 x 4.
            for spp in (4, 1, 16):
                some = cands if spp != 16 else cands[:a.matched]
                rows = [srv.render(c, spp, "c%d_%d" % (spp, i)) for i, c in enumerate(some)]
                # Distinct images among the candidates (by the EXR's bytes; Cycles' seed is
                # fixed): a moved parameter the material does not use changes nothing.
                digests = {hashlib.sha256(open(r[2], "rb").read()).hexdigest() for r in rows}
                bl[spp] = {"wall": [r[0] for r in rows], "render": [r[1]["render_s"] for r in rows],
                           "set": [r[1]["set_s"] for r in rows], "distinct": len(digests)}
        finally:
            srv.close()

        # Blender on the extracted sub-shader (what a VLMaterial program is: a small graph),
        # rendered as it is --candidates times at 4 and at 1 spp. Nothing changes between
        # the renders, so Cycles may skip re-syncing the shader: in Blender's favour (on the
        # full graph the sync and compile measured no fixed cost a candidate).
        srv_sub = BlenderServer(a.blender, sub, a.threads)
        try:
            sub_first_wall, _, _ = srv_sub.render({}, 4, "sub_first")
            bl_sub = {}
            for spp in (4, 1):
                rows = [srv_sub.render({}, spp, "s%d_%d" % (spp, i)) for i in range(a.candidates)]
                bl_sub[spp] = {"wall": [r[0] for r in rows], "render": [r[1]["render_s"] for r in rows]}
            bl_sub["first_wall"] = sub_first_wall
            bl_sub["nodes"] = srv_sub.hello["nodes"]
        finally:
            srv_sub.close()

        # imsynth render on the same candidates, a process each.
        # The presets' settings (pipeline/datagen.c): datagen 4 shading points a pixel,
        # draft 1, each with 4 light samples, no adaptive sampling.
        ims = {}
        for preset, spp in (("datagen", "4"), ("draft", "1")):
            ims[preset] = {"wall": [], "render": [], "material": []}
            for i, cf in enumerate(cand_files):
                t0 = time.time()
                r = run([imsynth, "render", graph, "--params", cf, "-o",
                         os.path.join(work, "i%s%d.exr" % (preset, i)), "--spp", spp,
                         "--light-samples", "4", "--max-spp", "0", "--seed", "1",
                         "--threads", threads, "--stats"])
                ims[preset]["wall"].append(time.time() - t0)
                m = re.search(r"imsynth render: ([0-9.]+) s.* ([0-9.]+) s in the material", r.stderr)
                ims[preset]["render"].append(float(m.group(1)))
                ims[preset]["material"].append(float(m.group(2)))

        # imsynth predict: the defaults (refinement at draft), then the refinement at datagen.
        preds = {}
        for tag, extra in (("default", []),
                           ("datagen", ["--refine-preset", "datagen", "--refine", "64"])):
            out = os.path.join(work, "predict-" + tag)
            t0 = time.time()
            run([imsynth, "predict", target, "-o", out, "--model", a.model, "--quiet"] + extra)
            wall = time.time() - t0
            rep = json.load(open(os.path.join(out, "report.json")))
            rep["wall"] = wall
            preds[tag] = rep
    res["load_after"] = loadavg()
    res["measured_s"] = time.time() - t_measure

    # Kept whole before the report is printed, so it can be printed again (--report).
    R = {"args": vars(a), "threads": threads, "n_nodes": n_nodes, "changed": changed, "res": res,
         "pause": pause, "hello": srv.hello, "first": first, "first_wall": first_wall,
         "bl": {str(k): v for k, v in bl.items()}, "ims": ims, "preds": preds,
         "bl_sub": {str(k): v for k, v in bl_sub.items()}}
    with open(os.path.join(work, "results.json"), "w") as f:
        json.dump(R, f, indent=1)
    report(R)
    if a.keep:
        print("work folder:", work)
    else:
        shutil.rmtree(work, ignore_errors=True)


class _nopause:
    def __enter__(self):
        return {"pids": [], "seconds": 0.0, "watchdog": False}

    def __exit__(self, *exc):
        return False


if __name__ == "__main__":
    main()
