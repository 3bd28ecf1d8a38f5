#!/usr/bin/env python3
"""Render the missing node references: blender-<version>.exr in each case directory.

    python3 blender/render_node_references.py [CASE_DIR ...] [--versions 3.4,4.3]
                                              [--force] [--check] [--batch N]

Without CASE_DIRs, every directory under tests/reference/nodes holding a case.json.
For each Blender version a case lists (case.json "versions") whose EXR is missing (or all,
with --force), blender/render_socket.py renders the case's socket; many cases share one
Blender start-up (a start-up costs seconds, a 128 x 128 one-sample frame much less).

Where the Blenders are:
- 3.4: `blender` on PATH (Debian bookworm).
- 4.3: the Debian trixie chroot /srv/trixie: the scripts and graphs are copied under
  /srv/trixie/tmp, `chroot /srv/trixie blender` renders there, results are copied back.
Each EXR carries the Blender version, the SHA-256 of the graph.json it was rendered from
and the socket in its header ("Note" attribute); a reference whose graph or socket has
changed since is stale and is rendered again. The driver also checks that the Blender
it ran is the version it was asked for.

Plain python3 (standard library only). Exit status 1 if any case failed; every failure is
printed with the case and Blender's message.
"""

import argparse
import hashlib
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CASES_ROOT = os.path.join(REPO, "tests", "reference", "nodes")
SCRIPTS = ("render_socket.py", "import_material.py", "compat_noise.py")
CHROOT = "/srv/trixie"
ALL_VERSIONS = ("3.4", "4.3")


def find_cases(paths):
    if not paths:
        paths = [os.path.join(CASES_ROOT, d) for d in sorted(os.listdir(CASES_ROOT))]
        return [p for p in paths if os.path.isfile(os.path.join(p, "case.json"))]
    out = []
    for p in paths:
        p = os.path.abspath(p)
        if not os.path.isfile(os.path.join(p, "case.json")):
            sys.exit("render_node_references: %s: no case.json" % p)
        out.append(p)
    return out


def load_case(d):
    path = os.path.join(d, "case.json")
    try:
        with open(path) as f:
            c = json.load(f)
    except ValueError as e:
        sys.exit("render_node_references: %s: bad JSON: %s" % (path, e))
    for k in ("socket", "versions"):
        if k not in c:
            sys.exit("render_node_references: %s: missing %r" % (path, k))
    return c


def exr_note(path):
    """The "Note" string attribute of an EXR header ('' if none)."""
    with open(path, "rb") as f:
        b = f.read(65536)
    p = 8
    while p < len(b):
        e = b.index(b"\0", p)
        name = b[p:e].decode("latin-1")
        if not name:
            break
        t = b.index(b"\0", e + 1)
        typ = b[e + 1:t].decode("latin-1")
        size = struct.unpack("<i", b[t + 1:t + 5])[0]
        value = b[t + 5:t + 5 + size]
        if name == "Note" and typ == "string":
            return value.decode("utf-8", "replace")
        p = t + 5 + size
    return ""


def stale_reason(case_dir, case, version):
    """Why an existing reference no longer matches its case, or None. References made
    before the header carried the graph's hash cannot be checked and count as current."""
    path = os.path.join(case_dir, "blender-%s.exr" % version)
    note = exr_note(path)
    m = re.search(r"graph sha256 ([0-9a-f]{64}); socket (.*)$", note)
    if not m:
        return None
    with open(os.path.join(case_dir, "graph.json"), "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    if m.group(1) != digest:
        return "graph.json changed since it was rendered"
    if m.group(2) != case["socket"]:
        return "socket changed (%s -> %s)" % (m.group(2), case["socket"])
    return None


def blender_command(version, script, jobs):
    base = ["blender", "-b", "--factory-startup", "--python-exit-code", "1", "-P", script,
            "--", jobs]
    if version == "3.4":
        return ["nice", "-n", "5"] + base
    return ["nice", "-n", "5", "chroot", CHROOT] + base


def run_batch(version, cases, verbose, check_only=False):
    """Render one batch in one Blender; returns a list of (case_dir, error)."""
    in_chroot = version != "3.4"
    tmp_parent = os.path.join(CHROOT, "tmp") if in_chroot else None
    tmp = tempfile.mkdtemp(prefix="imsynth-refs-", dir=tmp_parent)
    inside = (lambda p: p[len(CHROOT):]) if in_chroot else (lambda p: p)
    try:
        sdir = os.path.join(tmp, "blender")
        os.mkdir(sdir)
        for s in SCRIPTS:
            src = os.path.join(REPO, "blender", s)
            if os.path.exists(src):
                shutil.copy(src, sdir)
        jobs, outs = [], []
        for k, (d, c) in enumerate(cases):
            cdir = os.path.join(tmp, "case%04d" % k)
            os.mkdir(cdir)
            graph = os.path.join(cdir, "graph.json")
            shutil.copy(os.path.join(d, "graph.json"), graph)
            out = os.path.join(cdir, "out.exr")
            jobs.append({"graph": inside(graph), "socket": c["socket"], "out": inside(out),
                         "case": os.path.basename(d)})
            outs.append(out)
        results = os.path.join(tmp, "results.json")
        jobs_path = os.path.join(tmp, "jobs.json")
        with open(jobs_path, "w") as f:
            json.dump({"jobs": jobs, "results": inside(results), "check_only": check_only},
                      f, indent=1)
        cmd = blender_command(version, inside(os.path.join(sdir, "render_socket.py")),
                              inside(jobs_path))
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           universal_newlines=True)
        log = p.stdout
        if verbose:
            print(log)
        errors = {}
        ran = None
        if os.path.exists(results):
            with open(results) as f:
                r = json.load(f)
            ran = r.get("version", "")
            for fl in r.get("failures", []):
                errors[fl["graph"]] = fl["error"]
            names = {j["graph"]: os.path.relpath(os.path.join(d, "graph.json"), REPO)
                     for (d, _), j in zip(cases, jobs)}
            for w in r.get("warnings", []):
                print("  warning: %s" % w["warning"].replace(w["graph"], names[w["graph"]]),
                      flush=True)
        if ran is None:
            tail = "\n".join(log.splitlines()[-15:])
            return [(d, "Blender %s did not finish (exit %d):\n%s" % (version, p.returncode,
                                                                      tail))
                    for d, _ in cases]
        if not ran.startswith(version + "."):
            return [(d, "asked for Blender %s but ran %s" % (version, ran)) for d, _ in cases]
        failed = []
        for (d, c), job, out in zip(cases, jobs, outs):
            if job["graph"] in errors:
                # Name the case's own graph.json, not its temporary copy.
                failed.append((d, errors[job["graph"]].replace(
                    job["graph"], os.path.relpath(os.path.join(d, "graph.json"), REPO))))
                continue
            if check_only:
                continue
            if not os.path.exists(out):
                failed.append((d, "no image written"))
                continue
            dest = os.path.join(d, "blender-%s.exr" % version)
            shutil.copy(out, dest + ".tmp")
            os.replace(dest + ".tmp", dest)
            print("  %s: blender-%s.exr (Blender %s)" % (os.path.basename(d), version, ran),
                  flush=True)
        return failed
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("cases", nargs="*", help="case directories (default: all)")
    ap.add_argument("--versions", default=",".join(ALL_VERSIONS),
                    help="comma-separated Blender versions to render (default 3.4,4.3)")
    ap.add_argument("--force", action="store_true", help="re-render existing references")
    ap.add_argument("--check", action="store_true",
                    help="only build every case's material in each Blender (render nothing)")
    ap.add_argument("--batch", type=int, default=150, help="cases per Blender start-up")
    ap.add_argument("-v", "--verbose", action="store_true", help="print Blender's output")
    a = ap.parse_args()
    versions = [v for v in a.versions.split(",") if v]
    for v in versions:
        if v not in ALL_VERSIONS:
            sys.exit("render_node_references: unknown version %r (have %s)"
                     % (v, ", ".join(ALL_VERSIONS)))
    cases = [(d, load_case(d)) for d in find_cases(a.cases)]
    failures = []
    for v in versions:
        todo = []
        for d, c in cases:
            if v not in c["versions"]:
                continue
            exists = os.path.exists(os.path.join(d, "blender-%s.exr" % v))
            why = stale_reason(d, c, v) if exists else None
            if why:
                print("  %s: blender-%s.exr is stale (%s): rendering it again"
                      % (os.path.basename(d), v, why))
            if a.force or a.check or not exists or why:
                todo.append((d, c))
        print("Blender %s: %d case(s) to %s" % (v, len(todo), "check" if a.check else "render"),
              flush=True)
        for i in range(0, len(todo), max(1, a.batch)):
            failures += [(v, d, e) for d, e in run_batch(v, todo[i:i + a.batch], a.verbose,
                                                         a.check)]
    for v, d, e in failures:
        print("FAILED %s (Blender %s): %s" % (os.path.relpath(d, REPO), v, e.strip()),
              file=sys.stderr)
    if failures:
        print("%d reference(s) failed" % len(failures), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
