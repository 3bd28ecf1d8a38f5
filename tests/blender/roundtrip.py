#!/usr/bin/env python3
"""Round trip through Blender: every node-reference case graph is built in Blender
(import_material) and exported again (export_material); our evaluator must then compute
the same values from the exported graph as from the original, bit for bit.

    python3 tests/blender/roundtrip.py IMSYNTH REPO_ROOT [--versions 3.4,4.3]

IMSYNTH is the imsynth binary (eval-graph). Blender 3.4 is `blender`; 4.3 runs in the
/srv/trixie chroot and is skipped (with a message) when that does not exist. Exit 0 when
every case round-trips, 1 otherwise (each failure named), 77 when no Blender is found.
"""
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

CHROOT = "/srv/trixie"


def read_exr(path):
    """Float/half scanline EXR, NONE/ZIPS/ZIP: returns (width, height, {channel: floats})."""
    with open(path, "rb") as f:
        b = f.read()
    if b[:4] != b"\x76\x2f\x31\x01":
        raise ValueError("%s: not an EXR" % path)
    p, hdr = 8, {}
    while True:
        e = b.index(b"\0", p)
        name = b[p:e].decode()
        p = e + 1
        if not name:
            break
        e = b.index(b"\0", p)
        p = e + 1
        size = struct.unpack("<i", b[p:p + 4])[0]
        hdr[name] = b[p + 4:p + 4 + size]
        p += 4 + size
    chans, q, cl = [], 0, hdr["channels"]
    while cl[q] != 0:
        e = cl.index(b"\0", q)
        chans.append((cl[q:e].decode(), struct.unpack("<i", cl[e + 1:e + 5])[0]))
        q = e + 17
    comp = hdr["compression"][0]
    x0, y0, x1, y1 = struct.unpack("<4i", hdr["dataWindow"])
    w, h = x1 - x0 + 1, y1 - y0 + 1
    lines = {0: 1, 2: 1, 3: 16}.get(comp)
    if lines is None:
        raise ValueError("%s: compression %d not supported here" % (path, comp))
    n_chunks = (h + lines - 1) // lines
    offsets = struct.unpack("<%dQ" % n_chunks, b[p:p + 8 * n_chunks])
    out = {c: [0.0] * (w * h) for c, _ in chans}
    for o in offsets:
        y, size = struct.unpack("<ii", b[o:o + 8])
        raw = b[o + 8:o + 8 + size]
        nl = min(lines, y1 + 1 - y)
        expect = sum(w * (4 if t == 2 else 2) for _, t in chans) * nl
        if comp != 0 and len(raw) < expect:
            t = bytearray(zlib.decompress(raw))
            for i in range(1, len(t)):
                t[i] = (t[i - 1] + t[i] - 128) & 255
            half = (len(t) + 1) // 2
            un = bytearray(len(t))
            un[0::2], un[1::2] = t[:half], t[half:]
            raw = bytes(un)
        q = 0
        for line in range(nl):
            row = y - y0 + line
            for c, t in chans:
                fmt, sz = ("<%df" % w, 4) if t == 2 else ("<%de" % w, 2)
                out[c][row * w:(row + 1) * w] = struct.unpack(fmt, raw[q:q + sz * w])
                q += sz * w
    return w, h, out


def export_in_blender(version, repo, out_dir):
    """Runs tests/blender/export_cases.py in that Blender; returns its version string."""
    cases = os.path.join(repo, "tests", "reference", "nodes")
    if version == "3.4":
        cmd = ["blender", "-b", "--factory-startup", "--python-exit-code", "1", "-P",
               os.path.join(repo, "tests", "blender", "export_cases.py"), "--",
               os.path.join(repo, "blender"), cases, out_dir]
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           universal_newlines=True)
        log = r.stdout
    else:
        tmp = tempfile.mkdtemp(prefix="imsynth-rt-", dir=os.path.join(CHROOT, "tmp"))
        try:
            shutil.copytree(os.path.join(repo, "blender"), os.path.join(tmp, "blender"))
            shutil.copy(os.path.join(repo, "tests", "blender", "export_cases.py"), tmp)
            for c in os.listdir(cases):
                src = os.path.join(cases, c)
                if os.path.isfile(os.path.join(src, "case.json")):
                    os.makedirs(os.path.join(tmp, "cases", c))
                    for f in ("graph.json", "case.json"):
                        shutil.copy(os.path.join(src, f), os.path.join(tmp, "cases", c))
            os.mkdir(os.path.join(tmp, "out"))
            inside = tmp[len(CHROOT):]
            cmd = ["chroot", CHROOT, "blender", "-b", "--factory-startup",
                   "--python-exit-code", "1", "-P", inside + "/export_cases.py", "--",
                   inside + "/blender", inside + "/cases", inside + "/out"]
            r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               universal_newlines=True)
            log = r.stdout
            for f in os.listdir(os.path.join(tmp, "out")):
                shutil.copy(os.path.join(tmp, "out", f), out_dir)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    vpath = os.path.join(out_dir, "VERSION")
    if not os.path.exists(vpath):
        raise RuntimeError("Blender %s did not finish:\n%s" % (version, log[-2000:]))
    with open(vpath) as f:
        return f.read().strip()


def first_difference(a, b):
    """None when the two images hold the same float bits; else (|diff|, channel, pixel)
    of the largest difference (inf when a side is NaN or the channels differ)."""
    if a.keys() != b.keys():
        return (float("inf"), "/".join(sorted(a)) + " vs " + "/".join(sorted(b)), 0)
    worst = None
    for c in sorted(a):
        for i, (x, y) in enumerate(zip(a[c], b[c])):
            if struct.pack("<f", x) == struct.pack("<f", y):
                continue
            d = abs(x - y)
            d = float("inf") if d != d else d
            if worst is None or d > worst[0]:
                worst = (d, c, i)
    return worst


def evaluate(imsynth, graph, socket, mode, out):
    r = subprocess.run([imsynth, "eval-graph", graph, "--socket", socket, "-o", out,
                        "--size", "128", "--blender", mode],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       universal_newlines=True)
    return r.returncode, r.stdout.strip()


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--versions")]
    versions = ["3.4", "4.3"]
    for a in sys.argv[1:]:
        if a.startswith("--versions="):
            versions = a.split("=", 1)[1].split(",")
    if len(args) != 2:
        sys.exit(__doc__)
    imsynth, repo = os.path.abspath(args[0]), os.path.abspath(args[1])
    if shutil.which("blender") is None:
        print("no blender on PATH: skipped")
        return 77
    failures, checked = [], 0
    work = tempfile.mkdtemp(prefix="imsynth-roundtrip-")
    try:
        for v in versions:
            if v != "3.4" and not os.path.exists(os.path.join(CHROOT, "usr", "bin", "blender")):
                print("Blender %s: no chroot at %s, skipped" % (v, CHROOT))
                continue
            out = os.path.join(work, v)
            os.mkdir(out)
            ran = export_in_blender(v, repo, out)
            if not ran.startswith(v + "."):
                failures.append("asked for Blender %s, ran %s" % (v, ran))
                continue
            mode = "3" if v == "3.4" else "4"
            for f in sorted(os.listdir(out)):
                case, ext = os.path.splitext(f)
                if ext == ".error":
                    with open(os.path.join(out, f)) as fh:
                        failures.append("%s (Blender %s): export failed: %s"
                                        % (case, ran, fh.read().strip()))
                    continue
                if ext != ".json":
                    continue
                case_dir = os.path.join(repo, "tests", "reference", "nodes", case)
                with open(os.path.join(case_dir, "case.json")) as fh:
                    socket = json.load(fh)["socket"]
                a_exr, b_exr = os.path.join(out, case + ".a.exr"), os.path.join(out, case + ".b.exr")
                ra, ma = evaluate(imsynth, os.path.join(case_dir, "graph.json"), socket, mode, a_exr)
                rb, mb = evaluate(imsynth, os.path.join(out, f), socket, mode, b_exr)
                if ra != 0:
                    continue  # the original does not evaluate: test_blender_nodes reports it
                if rb != 0:
                    failures.append("%s (Blender %s): exported graph does not evaluate: %s"
                                    % (case, ran, mb))
                    continue
                with open(a_exr, "rb") as fa, open(b_exr, "rb") as fb:
                    same_bytes = fa.read() == fb.read()
                # Identical files hold identical floats; decode only to explain a difference.
                worst = None if same_bytes else first_difference(read_exr(a_exr)[2],
                                                                 read_exr(b_exr)[2])
                checked += 1
                if worst is not None:
                    failures.append("%s (Blender %s): exported graph evaluates differently "
                                    "(max diff %g, channel %s, pixel %d)"
                                    % (case, ran, worst[0], worst[1], worst[2]))
            print("Blender %s: %d cases exported" % (ran, len([f for f in os.listdir(out)
                                                               if f.endswith(".json")])))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    for f in failures:
        print("FAIL: " + f)
    print("%d round trips compared, %d failures" % (checked, len(failures)))
    return 1 if failures or checked == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
