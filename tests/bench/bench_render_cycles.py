#!/usr/bin/env python3
"""Side by side, in one run: Blender's Cycles at 252 samples against imsynth's default
(fast) mode, on the random super-shader parametrizations that have a converged Cycles
reference (tests/reference/render/supershader_s*/, 2 x 2048 samples).

    python3 tests/bench/bench_render_cycles.py [--versions 4.3,3.4] [--samples 252]
        [--cases supershader_s0,...] [--imsynth PATH] [--repeat 3] [--out results.json]
        [--config "imsynth render options"]...
    python3 tests/bench/bench_render_cycles.py --table results.json   # reprint a run

Each --config is one imsynth configuration to time against the same Cycles render (e.g.
--config "" for the defaults, --config "--max-spp 0 --spp 16"); default: the defaults.

Per case and Blender version:
  Cycles   one render of `samples` samples (seed 3, independent of the reference's seeds 1
           and 2) by blender/render_reference.py: seconds is the render inside Blender,
           excluding Blender's start-up and the scene building; Cycles uses every core.
  imsynth  `imsynth render GRAPH --blender 3|4` with each configuration's options,
           `repeat` times: seconds is the render inside the process (imsynth
           --stats: excluding start-up, graph loading and compiling), the best of the
           repeats; every core.
  RMSE     `imsynth compare IMAGE REF_A REF_B --json`: rmse_converged, the RMSE against the
           4096-sample reference with the reference's own noise taken out (both images are
           independent of the reference's samples).
  equal-RMSE speed-up  (Cycles seconds x Cycles RMSE^2) / (imsynth seconds x imsynth
           RMSE^2): how much faster imsynth would be at Cycles' RMSE if both errors fell as
           1 / sqrt(time), as Monte Carlo errors do; compares configurations that land at
           different RMSEs.
  material-only ceiling  the same, with imsynth's time replaced by the time its workers
           spent inside the material evaluator (imsynth --stats, divided by the cores):
           an upper bound on the speed-up at Cycles' RMSE of that configuration's
           estimator if camera rays, BSDF, light samples and film cost nothing. Given only
           where imsynth's RMSE is below Cycles' (see material_ceiling()).
Prints a Markdown table (for BENCHMARKS.md) and, with --out, writes the numbers as JSON.
Plain python3; Blender 3.4 on PATH and 4.3 in /srv/trixie (scripts/setup-oracles). Run
it on an otherwise idle machine: both renderers use all cores.
"""
import argparse
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CASES = os.path.join(REPO, "tests", "reference", "render")
sys.path.insert(0, os.path.join(REPO, "blender"))
from render_references import render_cycles  # noqa: E402
sys.path.insert(0, os.path.join(REPO, "tests"))
from imsynth_binary import find_imsynth  # noqa: E402


def compare(imsynth, image, case, version):
    ref = [os.path.join(case, "blender-%s-%s.exr" % (version, h)) for h in "ab"]
    r = subprocess.run([imsynth, "compare", image] + ref + ["--json"], capture_output=True,
                       text=True)
    if r.returncode != 0:
        raise SystemExit("bench_render_cycles: imsynth compare failed: %s" % r.stderr)
    return json.loads(r.stdout)


def imsynth_render(imsynth, graph, version, out, extra):
    cmd = [imsynth, "render", graph, "--blender", version[0], "-o", out, "--stats"] + extra
    r = subprocess.run(cmd, capture_output=True, text=True)
    m = re.search(r"imsynth render: ([0-9.]+) s", r.stderr)
    mat = re.search(r"([0-9.]+) s in the material evaluator", r.stderr)
    if r.returncode != 0 or not m or not mat:
        raise SystemExit("bench_render_cycles: %s failed:\n%s" % (" ".join(cmd), r.stderr))
    return float(m.group(1)), float(mat.group(1))


def main():
    argv = sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--config", action="append")
    p.add_argument("--versions", default="4.3")
    p.add_argument("--samples", type=int, default=252)
    p.add_argument("--cases")
    p.add_argument("--imsynth")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--out")
    p.add_argument("--table", help="print the tables of an earlier --out file; render nothing")
    a = p.parse_args(argv)
    if a.table:
        with open(a.table) as f:
            rows = json.load(f)
        labels = list(dict.fromkeys(r["imsynth_options"] for r in rows))
        print_tables(rows, rows[0]["cycles_samples"] if rows else a.samples, labels)
        return
    configs = a.config if a.config else [""]
    rows = measure(a, configs)
    print_tables(rows, a.samples, [c or "defaults" for c in configs])
    if a.out:
        with open(a.out + ".tmp", "w") as f:
            json.dump(rows, f, indent=1)
        os.replace(a.out + ".tmp", a.out)


def measure(a, configs):
    imsynth = find_imsynth(a.imsynth, "bench_render_cycles")
    names = a.cases.split(",") if a.cases else sorted(
        os.path.basename(d) for d in glob.glob(os.path.join(CASES, "supershader_s*")))
    # imsynth renders on every core; its material time is summed over them.
    cores = len(os.sched_getaffinity(0))
    rows = []
    work = tempfile.mkdtemp(prefix="bench_render_cycles-")
    try:
        for version in a.versions.split(","):
            for name in names:
                case = os.path.join(CASES, name)
                graph = os.path.join(case, "graph.json")
                if not all(os.path.exists(os.path.join(case, "blender-%s-%s.exr" % (version, h)))
                           for h in "ab"):
                    print("%s %s: no reference, skipped" % (name, version), file=sys.stderr)
                    continue
                cyc_exr = os.path.join(work, "cycles.exr")
                cyc_json = os.path.join(work, "cycles.json")
                err = render_cycles(graph, version, a.samples, 3, cyc_exr, cyc_json, nice=0)
                if err:
                    raise SystemExit("bench_render_cycles: %s %s: %s" % (name, version, err))
                with open(cyc_json) as f:
                    cyc_seconds = json.load(f)["seconds"]
                cyc = compare(imsynth, cyc_exr, case, version)
                for config in configs:
                    extra = config.split()
                    ours_exr = os.path.join(work, "ours.exr")
                    ours_seconds, material_seconds = min(
                        imsynth_render(imsynth, graph, version, ours_exr, extra)
                        for _ in range(a.repeat))
                    ours = compare(imsynth, ours_exr, case, version)
                    row = {"case": name, "blender": version, "cycles_samples": a.samples,
                           "cycles_seconds": cyc_seconds, "cycles_rmse": cyc["rmse_converged"],
                           "imsynth_seconds": ours_seconds,
                           "material_seconds": material_seconds / cores,
                           "imsynth_rmse": ours["rmse_converged"], "ref_mean": ours["ref_mean"],
                           "ref_noise_rmse": ours["ref_noise_rmse"],
                           "imsynth_options": config or "defaults"}
                    rows.append(row)
                    print("%s %s [%s]: Cycles %.2f s rmse %.5f | imsynth %.3f s rmse %.5f" % (
                        name, version, row["imsynth_options"], cyc_seconds, row["cycles_rmse"],
                        ours_seconds, row["imsynth_rmse"]), file=sys.stderr, flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return rows


def print_tables(rows, samples, labels):
    def equal_rmse(r):
        ours = r["imsynth_seconds"] * r["imsynth_rmse"] ** 2
        return r["cycles_seconds"] * r["cycles_rmse"] ** 2 / ours if ours > 0 else float("nan")

    def material_ceiling(r):
        # The speed-up at Cycles' RMSE if a frame cost nothing but its material
        # evaluations: the same estimator, with camera rays, BSDF, light samples and film
        # free, and its shading points cut to land at Cycles' RMSE. Cutting them by
        # (RMSE ratio)^2 assumes the error grows as 1/sqrt(points) when they are cut;
        # ours grows more slowly (stratified cells: ~points^-0.9 on smooth frames), so
        # fewer can be cut and the true figure is lower: an upper bound - but only from
        # below Cycles' RMSE. From above it the same rule would overstate the points
        # needed, so those rows get none.
        if not r["imsynth_rmse"] <= r["cycles_rmse"]:
            return None
        floor = r["material_seconds"] * (r["imsynth_rmse"] / r["cycles_rmse"]) ** 2
        return r["cycles_seconds"] / floor if floor > 0 else None

    print("| case | Blender | imsynth options | Cycles-%d s/frame | imsynth s/frame | speed-up "
          "| Cycles-%d RMSE | imsynth RMSE | imsynth / Cycles RMSE | equal-RMSE speed-up "
          "| material s/frame | material-only ceiling |" % (samples, samples))
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print("| %s | %s | %s | %.2f | %.3f | %.1fx | %.5f | %.5f | %.2f | %.1fx | %.3f | %s |" % (
            r["case"], r["blender"], r["imsynth_options"], r["cycles_seconds"],
            r["imsynth_seconds"],
            r["cycles_seconds"] / r["imsynth_seconds"], r["cycles_rmse"], r["imsynth_rmse"],
            r["imsynth_rmse"] / r["cycles_rmse"] if r["cycles_rmse"] > 0 else float("nan"),
            equal_rmse(r), r["material_seconds"],
            "-" if material_ceiling(r) is None else "%.0fx" % material_ceiling(r)))
    for label in labels:
        sel = [r for r in rows if r["imsynth_options"] == label]
        if not sel:
            continue
        geo = geo_equal = 1.0
        for r in sel:
            geo *= r["cycles_seconds"] / r["imsynth_seconds"]
            geo_equal *= equal_rmse(r)
        print("\nimsynth [%s]: geometric-mean speed-up %.1fx over %d frames; RMSE below "
              "Cycles-%d's in %d of %d; equal-RMSE speed-up %.1fx (geometric mean)." % (
                  label, geo ** (1.0 / len(sel)), len(sel), samples,
                  sum(r["imsynth_rmse"] < r["cycles_rmse"] for r in sel), len(sel),
                  geo_equal ** (1.0 / len(sel))))


if __name__ == "__main__":
    main()
