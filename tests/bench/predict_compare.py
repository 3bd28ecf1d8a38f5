"""Two `imsynth predict` settings, input by input: for every input with an output folder
under both A and B (A/NAME and B/NAME, each a predict OUTDIR; the input named in its
report.json), the final loss and its Gram term (the model's descriptor, MobileNetV2 for
the bundled model) from report.json, and an independent judge: the Gram distance of the
random-weight VGG19 descriptor (`imsynth describe`, evaluate's other descriptor) between
the input and preview.png. Counts where B is closer, the two-sided sign test, medians of
B / A, and the inputs where the two settings' winners differ in rotation or light.

    /usr/bin/python3 tests/bench/predict_compare.py IMSYNTH A B [--group PREFIX ...] [--json OUT]

--group splits the counts by input-name prefix (e.g. hm- photo- rot-).

--sheet OUT.png: for every input where B's winner differs from A's in rotation or light, a
row of the input, A's preview and B's preview (from compare.png and preview.png; 128 px
tiles), labelled with the winner's rotation and the final losses.

--sheet-rows differ: the sheet's rows are every input whose two previews differ (not
only where the winner's rotation or light does), labelled with G, not the loss.

Colour, beside the descriptors: between the input as predict saw it (compare.png's first
tile) and preview.png, both 8-bit sRGB decoded to linear, the two colour terms of
`--colour-term` (blocks: mean |a - b| of the 32 x 32 box averages of the centre 224 crop;
sorted: the same with each channel's box averages sorted first). When A and B ran with
different colour terms their final losses are not comparable; G, VGG19 and both colour
columns are.

--margin M (A run with --rotation 0, B with --rotation auto and margin 1): B stands for
`--rotation auto --rotation-margin M`, its output taken where its winner is turned and the
turned candidates' least loss is below M x the unturned ones', else A's. Exact, not an
approximation: auto keeping the unturned winner writes --rotation 0's bytes (checked on
hm-asphalt, session 28).
"""
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile

import numpy as np


def sign_test(wins, losses):
    """Two-sided exact binomial test of wins against wins + losses at p = 1/2."""
    n = wins + losses
    if n == 0:
        return float("nan")
    k = min(wins, losses)
    return min(1.0, 2 * sum(math.comb(n, i) for i in range(k + 1)) / 2 ** n)


def vgg_distances(imsynth, pairs):
    """Gram distance (evaluate_gram_distance: mean over layers of |a-b| / (|a|+|b|)) of
    each (image, image) pair under `imsynth describe` (VGG19, random weights, seed 1)."""
    images = [p for pair in pairs for p in pair]
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "d.npy")
        r = subprocess.run([imsynth, "describe", *images, "-o", out], check=True,
                           capture_output=True, text=True)
        d = np.load(out).astype(np.float64)
    # "  conv1_2  columns 0..2079" per layer: the layers' first and last columns
    spans = [tuple(int(v) for v in m) for m in re.findall(r"columns (\d+)\.\.(\d+)", r.stdout)]
    assert spans and spans[0][0] == 0 and spans[-1][1] == d.shape[1] - 1, (spans, d.shape)
    assert all(a[1] + 1 == b[0] for a, b in zip(spans, spans[1:])), spans
    offsets = [a for a, _ in spans] + [d.shape[1]]
    res = []
    for i in range(len(pairs)):
        a, b = d[2 * i], d[2 * i + 1]
        per = []
        for l in range(len(offsets) - 1):
            x, y = a[offsets[l]:offsets[l + 1]], b[offsets[l]:offsets[l + 1]]
            per.append(np.linalg.norm(x - y) / (np.linalg.norm(x) + np.linalg.norm(y) + 1e-12))
        res.append(float(np.mean(per)))
    return res


def load_linear(path, box=None):
    from PIL import Image
    im = Image.open(path).convert("RGB")
    if box:
        im = im.crop(box)
    assert im.size == (256, 256), (path, im.size)
    a = np.asarray(im).astype(np.float64) / 255.0
    return np.where(a <= 0.04045, a / 12.92, ((a + 0.055) / 1.055) ** 2.4)


def colour_terms(a_dir, name, out_dir):
    """(blocks, sorted) colour distances of out_dir/name/preview.png to the input tile."""
    def boxes(a):
        return a[16:240, 16:240].clip(0, 1).reshape(32, 7, 32, 7, 3).mean(axis=(1, 3)).reshape(-1, 3)
    x = boxes(load_linear(os.path.join(a_dir, name, "compare.png"), (0, 20, 256, 276)))
    y = boxes(load_linear(os.path.join(out_dir, name, "preview.png")))
    return float(np.abs(x - y).mean()), float(np.abs(np.sort(x, 0) - np.sort(y, 0)).mean())


def write_sheet(path, a_dir, rows, label_g=False):
    from PIL import Image, ImageDraw
    tile, head = 128, 14
    img = Image.new("RGB", (3 * tile, len(rows) * (tile + head)), (0, 0, 0))
    d = ImageDraw.Draw(img)
    for i, r in enumerate(rows):
        y = i * (tile + head)
        # the input as predict saw it: compare.png's first tile
        small = lambda im: im.convert("RGB").resize((tile, tile), Image.LANCZOS)
        img.paste(small(Image.open(os.path.join(a_dir, r["name"], "compare.png")).crop((0, 20, 256, 276))),
                  (0, y + head))
        img.paste(small(Image.open(os.path.join(a_dir, r["name"], "preview.png"))), (tile, y + head))
        img.paste(small(Image.open(os.path.join(r["b_dir"], r["name"], "preview.png"))), (2 * tile, y + head))
        a, b = r["a"], r["b"]
        d.text((2, y + 1), r["name"][:21], fill=(255, 255, 255))
        key, what = ("gram", "G") if label_g else ("loss", "loss")
        d.text((tile + 2, y + 1), f"A {a.get('texture_rotation', 0):g}: {what} {a['final'][key]:.3f}", fill=(255, 255, 255))
        d.text((2 * tile + 2, y + 1), f"B {b.get('texture_rotation', 0):g}: {what} {b['final'][key]:.3f}", fill=(255, 255, 255))
    img.save(path)


def main():
    args = sys.argv[1:]
    groups, json_out = [], None
    while "--group" in args:
        i = args.index("--group")
        groups.append(args[i + 1])
        del args[i:i + 2]
    margin = None
    sheet = None
    if "--sheet" in args:
        i = args.index("--sheet")
        sheet = args[i + 1]
        del args[i:i + 2]
    sheet_rows = "winner"
    if "--sheet-rows" in args:
        i = args.index("--sheet-rows")
        sheet_rows = args[i + 1]
        assert sheet_rows in ("winner", "differ"), sheet_rows
        del args[i:i + 2]
    if "--margin" in args:
        i = args.index("--margin")
        margin = float(args[i + 1])
        del args[i:i + 2]
    if "--json" in args:
        i = args.index("--json")
        json_out = args[i + 1]
        del args[i:i + 2]
    imsynth, a_dir, b_dir = args
    names = sorted(n for n in os.listdir(a_dir)
                   if os.path.exists(os.path.join(a_dir, n, "report.json"))
                   and os.path.exists(os.path.join(b_dir, n, "report.json")))
    rows = []
    for n in names:
        ra = json.load(open(os.path.join(a_dir, n, "report.json")))
        rb = json.load(open(os.path.join(b_dir, n, "report.json")))
        assert ra["image"] == rb["image"], (ra["image"], rb["image"])
        b_from = b_dir
        if margin is not None:
            best = {}
            for c in rb["candidates"]:
                for sc in ("scene", "flash"):
                    if sc in c and c[sc]["loss"] is not None:
                        t = c["texture_rotation"]
                        best[t] = min(best.get(t, math.inf), c[sc]["loss"])
            if not (rb["texture_rotation"] == 90 and best[90] < margin * best[0]):
                rb, b_from = ra, a_dir
        rows.append({"name": n, "image": ra["image"], "a": ra, "b": rb, "b_dir": b_from})
    pairs = []
    for r in rows:
        pairs.append((r["image"], os.path.join(a_dir, r["name"], "preview.png")))
        pairs.append((r["image"], os.path.join(r["b_dir"], r["name"], "preview.png")))
    vgg = vgg_distances(imsynth, pairs)
    for i, r in enumerate(rows):
        r["vgg_a"], r["vgg_b"] = vgg[2 * i], vgg[2 * i + 1]
        r["blocks_a"], r["sorted_a"] = colour_terms(a_dir, r["name"], a_dir)
        r["blocks_b"], r["sorted_b"] = colour_terms(a_dir, r["name"], r["b_dir"])
        with open(os.path.join(a_dir, r["name"], "preview.png"), "rb") as fa, \
                open(os.path.join(r["b_dir"], r["name"], "preview.png"), "rb") as fb:
            r["same_preview"] = fa.read() == fb.read()
    print(f"{len(rows)} inputs; A = {a_dir}, B = {b_dir}")
    print(f"{'input':34} {'loss A':>7} {'loss B':>7} {'G A':>6} {'G B':>6} {'VGG A':>6} {'VGG B':>6} "
          f"{'blk A':>6} {'blk B':>6} {'srt A':>6} {'srt B':>6}  winner A / B")
    for r in rows:
        a, b = r["a"], r["b"]
        wa = f"{a.get('texture_rotation', 0):g}/{a['light']}"
        wb = f"{b.get('texture_rotation', 0):g}/{b['light']}"
        print(f"{r['name']:34} {a['final']['loss']:7.4f} {b['final']['loss']:7.4f} "
              f"{a['final']['gram']:6.4f} {b['final']['gram']:6.4f} {r['vgg_a']:6.4f} {r['vgg_b']:6.4f} "
              f"{r['blocks_a']:6.4f} {r['blocks_b']:6.4f} {r['sorted_a']:6.4f} {r['sorted_b']:6.4f}  {wa} {wb}"
              + ("" if not r["same_preview"] else "  (same preview)"))
    summary = {}
    for g in [""] + groups:
        sel = [r for r in rows if r["name"].startswith(g)]
        if not sel:
            continue
        out = {"inputs": len(sel)}
        for key, get in (("loss", lambda r, s: r[s]["final"]["loss"]),
                         ("gram", lambda r, s: r[s]["final"]["gram"]),
                         ("vgg19", lambda r, s: r["vgg_" + s]),
                         ("blocks", lambda r, s: r["blocks_" + s]),
                         ("sorted", lambda r, s: r["sorted_" + s])):
            av = [get(r, "a") for r in sel]
            bv = [get(r, "b") for r in sel]
            wins = sum(y < x for x, y in zip(av, bv))
            losses = sum(y > x for x, y in zip(av, bv))
            out[key] = {"b_closer": wins, "b_farther": losses, "sign_p": sign_test(wins, losses),
                        "median_a": statistics.median(av), "median_b": statistics.median(bv),
                        "median_ratio": statistics.median(y / x for x, y in zip(av, bv) if x > 0)}
        out["winner_differs"] = sum(r["a"].get("texture_rotation", 0) != r["b"].get("texture_rotation", 0)
                                    or r["a"]["light"] != r["b"]["light"] for r in sel)
        summary[g or "all"] = out
        print(f"\n[{g or 'all'}] {len(sel)} inputs; winner's rotation or light differs on {out['winner_differs']}")
        out["same_preview"] = sum(r["same_preview"] for r in sel)
        print(f"  same preview on {out['same_preview']}")
        for key in ("loss", "gram", "vgg19", "blocks", "sorted"):
            o = out[key]
            print(f"  {key:6} B closer {o['b_closer']:2}, farther {o['b_farther']:2} (sign p {o['sign_p']:.3f}); "
                  f"medians {o['median_a']:.4f} -> {o['median_b']:.4f}, median B/A {o['median_ratio']:.3f}")
    if sheet:
        if sheet_rows == "differ":
            write_sheet(sheet, a_dir, [r for r in rows if not r["same_preview"]], label_g=True)
        else:
            write_sheet(sheet, a_dir, [r for r in rows if r["a"].get("texture_rotation", 0) != r["b"].get("texture_rotation", 0)
                                       or r["a"]["light"] != r["b"]["light"]])
    if json_out:
        with open(json_out, "w") as f:
            json.dump({"rows": [{k: v for k, v in r.items() if k not in ("a", "b", "b_dir")} |
                                {"a": {"final": r["a"]["final"], "texture_rotation": r["a"].get("texture_rotation", 0), "light": r["a"]["light"]},
                                 "b": {"final": r["b"]["final"], "texture_rotation": r["b"].get("texture_rotation", 0), "light": r["b"]["light"]}}
                                for r in rows], "summary": summary}, f, indent=1)


if __name__ == "__main__":
    main()
