#!/usr/bin/env python3
"""Contact sheet of random super-shader parametrizations, with plain Python 3 and our CLI.

    python3 scripts/contact_sheet.py --imsynth build/cli/imsynth \
        [--graph assets/supershader.json] [--first 0] [--count 64] [--columns 8] \
        [--size 128] [-o assets/supershader-contact-sheet.png]

For frame N = first .. first+count-1: `imsynth sample --seed N --bound-graph` binds the
frame's parameters, the script adds a few nodes to the bound graph's material tree that
shade Base Color by a Lambert term of the Bump normal (light from the upper left), and
`imsynth eval-graph` evaluates that colour over the scene's plane to a PNG. The tiles
are then laid out row-major, frame `first` at the top left, with 4 px white gutters.

This is a preview of the maps, not a render: no specular, no metal, no shadows.

With --render, each frame is instead extracted (`imsynth extract --seed N`: the
sub-shader, which evaluates bit for bit like the super-shader and is far cheaper) and
rendered with the path tracer (`imsynth render`, the scene of DESIGN.md, 256 x 256,
--spp samples, one thread), and the tile is the render halved by 2 x 2 averaging.
"""

import argparse
import json
import os
import struct
import subprocess
import sys
import tempfile
import zlib

LIGHT = (-0.45, 0.45, 0.77)  # towards the light, roughly unit


def preview_nodes(doc):
    """Adds Preview = Base Color * (0.3 + 0.7 * max(N . L, 0)) to the material tree."""
    nodes, links = doc["nodes"], doc["links"]

    def node(name, type_, props=None, inputs=None):
        n = {"name": name, "type": type_, "location": [400.0, -900.0 - 200 * len(extra)]}
        if props:
            n["properties"] = props
        if inputs:
            n["inputs"] = inputs
        extra.append(n)
        return name

    def link(a, sa, b, sb):
        links.append({"from_node": a, "from_socket": sa, "to_node": b, "to_socket": sb})

    def source_of(node_name, socket):
        for l in links:
            if l["to_node"] == node_name and l["to_socket"] == socket:
                return l["from_node"], l["from_socket"]
        raise SystemExit("contact_sheet: the graph has no link into %s:%s" % (node_name, socket))

    extra = []
    color = source_of("Principled BSDF", "Base Color")
    normal = source_of("Principled BSDF", "Normal")
    dot = node("Preview Light", "ShaderNodeVectorMath", {"operation": "DOT_PRODUCT"},
               {"Vector_001": list(LIGHT)})
    link(normal[0], normal[1], dot, "Vector")
    lam = node("Preview Lambert", "ShaderNodeMath", {"operation": "MAXIMUM"}, {"Value_001": 0.0})
    link(dot, "Value", lam, "Value")
    shade = node("Preview Shade", "ShaderNodeMath", {"operation": "MULTIPLY_ADD"},
                 {"Value_001": 0.7, "Value_002": 0.3})
    link(lam, "Value", shade, "Value")
    mix = node("Preview", "ShaderNodeMix", {"data_type": "RGBA", "blend_type": "MULTIPLY"},
               {"Factor_Float": 1.0})
    link(color[0], color[1], mix, "A_Color")
    link(shade, "Value", mix, "B_Color")
    nodes.extend(extra)


# ---- minimal PNG reading and writing (8-bit RGB/RGBA, non-interlaced) -----------------

def read_png(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit("contact_sheet: %s: not a PNG" % path)
    pos, idat, ihdr = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    w, h, depth, ctype, _, _, interlace = ihdr
    if depth != 8 or ctype not in (2, 6) or interlace:
        raise SystemExit("contact_sheet: %s: only 8-bit RGB(A) non-interlaced PNGs" % path)
    bpp = 3 if ctype == 2 else 4
    raw = zlib.decompress(idat)
    stride = w * bpp
    rows, prev = [], bytearray(stride)
    for y in range(h):
        ftype = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if ftype == 1:
                line[i] = (line[i] + a) & 255
            elif ftype == 2:
                line[i] = (line[i] + b) & 255
            elif ftype == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif ftype == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        rows.append(bytes(line) if bpp == 3 else
                    bytes(v for i, v in enumerate(line) if i % 4 != 3))
        prev = line
    return w, h, rows


def halve(w, h, rows):
    """2 x 2 box average of 8-bit RGB rows (on the sRGB values: a preview)."""
    out = []
    for y in range(0, h - 1, 2):
        a, b = rows[y], rows[y + 1]
        out.append(bytes((a[3 * x + c] + a[3 * x + 3 + c] + b[3 * x + c] + b[3 * x + 3 + c] + 2) // 4
                         for x in range(0, w - 1, 2) for c in range(3)))
    return w // 2, h // 2, out


def write_png(path, w, h, rows):
    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body +
                struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))
    raw = b"".join(b"\x00" + r for r in rows)
    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
           chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    d = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".contact.", suffix=".png", dir=d)
    with os.fdopen(fd, "wb") as f:
        f.write(png)
    os.replace(tmp, path)


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode:
        raise SystemExit("contact_sheet: %s failed (%d): %s" % (cmd[1], r.returncode, r.stderr.strip()))


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--imsynth", default=os.path.join(root, "build", "cli", "imsynth"))
    ap.add_argument("--graph", default=os.path.join(root, "assets", "supershader.json"))
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--count", type=int, default=64)
    ap.add_argument("--columns", type=int, default=8)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--render", action="store_true",
                    help="path-trace the extracted sub-shader instead of the preview")
    ap.add_argument("--spp", type=int, default=16, help="samples per pixel with --render")
    ap.add_argument("--scene", default=os.path.join(root, "assets", "scene.json"))
    ap.add_argument("-o", "--output", default=os.path.join(root, "assets", "supershader-contact-sheet.png"))
    args = ap.parse_args()
    if args.count < 1 or args.columns < 1 or args.size < 1:
        ap.error("--count, --columns and --size must be positive")
    gutter = 4
    cols = min(args.columns, args.count)
    nrows = (args.count + cols - 1) // cols
    W = cols * args.size + (cols + 1) * gutter
    H = nrows * args.size + (nrows + 1) * gutter
    sheet = [bytearray(b"\xff" * (3 * W)) for _ in range(H)]
    with tempfile.TemporaryDirectory(prefix="contact_sheet.") as tmp:
        for k in range(args.count):
            frame = args.first + k
            png = os.path.join(tmp, "tile.png")
            if args.render:
                sub = os.path.join(tmp, "sub.json")
                run([args.imsynth, "extract", args.graph, "--seed", str(frame), "-o", sub])
                run([args.imsynth, "render", sub, "--spp", str(args.spp), "--threads", "1",
                     "--seed", str(frame), "--scene", args.scene,
                     "-o", os.path.join(tmp, "tile.exr"), "--png", png])
                w, h, rows = halve(*read_png(png))
            else:
                bound = os.path.join(tmp, "bound.json")
                run([args.imsynth, "sample", "--seed", str(frame), "--graph", args.graph,
                     "-o", os.path.join(tmp, "params.json"), "--bound-graph", bound])
                with open(bound) as f:
                    doc = json.load(f)
                preview_nodes(doc)
                with open(bound, "w") as f:
                    json.dump(doc, f)
                run([args.imsynth, "eval-graph", bound, "--socket", "Preview:Result_Color",
                     "--size", str(args.size), "-o", os.path.join(tmp, "tile.exr"), "--png", png])
                w, h, rows = read_png(png)
            if (w, h) != (args.size, args.size):
                raise SystemExit("contact_sheet: frame %d: got a %d x %d tile, expected %d x %d "
                                 "(--render makes 128 x 128 tiles)" % (frame, w, h, args.size, args.size))
            r, c = divmod(k, cols)
            x0 = gutter + c * (args.size + gutter)
            y0 = gutter + r * (args.size + gutter)
            for y in range(h):
                sheet[y0 + y][3 * x0:3 * (x0 + w)] = rows[y]
            print("frame %d done" % frame, file=sys.stderr)
    write_png(args.output, W, H, [bytes(r) for r in sheet])
    print("%s: %d frames from %d, %d x %d tiles" % (args.output, args.count, args.first,
                                                    args.size, args.size))


if __name__ == "__main__":
    main()
