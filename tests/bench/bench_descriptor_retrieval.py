#!/usr/bin/python3
"""Which texture descriptor serves better: VGG19 (seeded random weights, the default) or
MobileNetV2 (ImageNet, nsfwjs 4.4.0)? Measured on our own renders (BENCHMARKS.md).

    /usr/bin/python3 tests/bench/bench_descriptor_retrieval.py BUILD_DIR WORKDIR \
        [--materials 150] [--stage render|describe|analyse|all]

render   For seeds 1..M: `imsynth sample --seed N`, then the same parameters at a second
         "Pattern Offset" (u + 0.5 mod 1: the pattern moved by 50 units, nothing else
         changed); both rendered (`--max-spp 0 --spp 4`, EXR + PNG). Resumable: existing
         renders are kept. Run it under `nice -n 10` (the machine is shared).
describe Both descriptors of every render with imsynth describe (each timed; the
         MobileNetV2 one also at --scales 2).
analyse  Distance: per Gram layer (tap) squared Euclidean distance divided by that
         layer's mean squared norm over the set, summed over layers (each layer counts
         alike, as in Gatys' loss with equal weights).
         (i)  invariance: for every render, is its nearest other render (of all 2M) the
              same material at the other offset? (chance 1/(2M-1))
         (a)  retrieval: materials split in two halves; for each render of the held-out
              half, its nearest render in the training half: the fraction of the 14
              multiplexer choices ("Mult N ...", index floor(u N)) it shares, against
              the mean over all training renders (chance); and how close its render is,
              by three judges that belong to neither network, on the sRGB PNGs (0..1):
              mean-colour distance (L2 of the per-channel means), spectrum distance (L2
              of log10 radially averaged luminance power spectra, 24 log-spaced bands:
              shift-invariant, like the descriptors) and pixel RMSE (not shift-invariant:
              it mostly measures colour). Each against a random training render and the
              best possible (the training render nearest by that judge). Also
              "vgg19+mnv2": the two distances, each over its mean, summed.
         (c)  agreement: Spearman rank correlation of the descriptors' distances on 20,000
              random pairs, with each other and with each judge.
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, capture_output=True, text=True, **kw)


def render_stage(imsynth, work, m):
    os.makedirs(work, exist_ok=True)
    graph = os.path.join(ROOT, "assets", "supershader.json")
    t0 = time.time()
    done = 0
    for seed in range(1, m + 1):
        p = os.path.join(work, f"s{seed:04d}_a.json")
        if not os.path.exists(p):
            run([imsynth, "sample", "--seed", str(seed), "-o", p])
        q = os.path.join(work, f"s{seed:04d}_b.json")
        if not os.path.exists(q):
            params = json.load(open(p))
            params["Pattern Offset"] = round((params["Pattern Offset"] + 0.5) % 1.0, 6)
            with open(q + ".tmp", "w") as f:
                json.dump(params, f, indent=2)
            os.replace(q + ".tmp", q)
        for tag in ("a", "b"):
            exr = os.path.join(work, f"s{seed:04d}_{tag}.exr")
            png = os.path.join(work, f"s{seed:04d}_{tag}.png")
            if os.path.exists(exr) and os.path.exists(png):
                continue
            run([imsynth, "render", graph, "--params", os.path.join(work, f"s{seed:04d}_{tag}.json"),
                 "-o", exr, "--png", png, "--max-spp", "0", "--spp", "4", "--threads", "1"],
                cwd=ROOT)
            done += 1
    print(f"render: {done} new renders in {time.time() - t0:.0f} s")


def names(work, m):
    return [os.path.join(work, f"s{seed:04d}_{tag}.exr") for seed in range(1, m + 1)
            for tag in ("a", "b")]


def parse_columns(stdout):
    """[(name, begin, end_exclusive)] from describe's column listing."""
    cols = []
    for line in stdout.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[1] == "columns":
            a, b = parts[2].split("..")
            cols.append((parts[0], int(a), int(b) + 1))
    return cols


DESCRIPTORS = {
    "vgg19": ["--features", "vgg19"],
    "mnv2": ["--features", "mobilenetv2"],  # the default taps, conv1 included
    "mnv2x2": ["--features", "mobilenetv2", "--scales", "2"],
    "mnv2-noconv1": ["--features", "mobilenetv2", "--taps",
                     "block_1_expand,block_3_expand,block_6_expand,block_10_project"],
}


def describe_stage(imsynth, work, m, threads, only=None):
    files = names(work, m)
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    tpath = os.path.join(work, "timing.json")
    timing = json.load(open(tpath)) if os.path.exists(tpath) else {}
    for key, args in DESCRIPTORS.items():
        out = os.path.join(work, f"desc_{key}.npy")
        if only and key not in only:
            continue
        t0 = time.time()
        r = run([imsynth, "describe", *files, "-o", out, "--threads", str(threads), *args],
                cwd=ROOT, env=env)
        dt = time.time() - t0
        timing[key] = dt / len(files)
        with open(os.path.join(work, f"desc_{key}.columns.json"), "w") as f:
            json.dump(parse_columns(r.stdout), f)
        print(f"describe {key}: {len(files)} images in {dt:.1f} s, {1000 * dt / len(files):.1f} ms "
              f"per image (threads {threads}, including image reading)")
    json.dump(timing, open(tpath, "w"))


def mult_choices(path):
    p = json.load(open(path))
    out = []
    for k in sorted(p):
        if k.startswith("Mult "):
            n = int(k.split()[1])
            out.append(min(int(p[k] * n), n - 1))
    return np.array(out)


def normalised_sqdist(desc, cols, by="variance"):
    """(n, n) sum over layers of ||a_l - b_l||^2 / s_l, s_l the layer's total variance
    over the set (mean squared distance to its mean: every layer then spreads the set
    alike) or, by="norm", its mean squared norm (Gatys' loss with equal weights, where a
    layer whose Grams share a large common part counts little)."""
    n = desc.shape[0]
    total = np.zeros((n, n))
    for _, a, b in cols:
        x = desc[:, a:b].astype(np.float64)
        if by == "variance":
            scale = np.mean(np.sum((x - x.mean(0)) ** 2, axis=1))
        else:
            scale = np.mean(np.sum(x * x, axis=1))
        sq = np.sum(x * x, axis=1)
        d = sq[:, None] + sq[None, :] - 2 * x @ x.T
        total += np.maximum(d, 0) / scale
    return total


def spearman(a, b):
    from scipy.stats import spearmanr
    return float(spearmanr(a, b).correlation)


def log_spectrum(img, bands=24):
    """img (H,W,3) sRGB 0..1 -> log10 radially averaged power spectrum of luminance,
    `bands` log-spaced radius bands from 1 cycle to Nyquist."""
    lum = img @ np.array([0.2126, 0.7152, 0.0722])
    f = np.fft.fftshift(np.abs(np.fft.fft2(lum - lum.mean())) ** 2)
    h, w = lum.shape
    yy, xx = np.indices((h, w))
    r = np.hypot(yy - h // 2, xx - w // 2)
    edges = np.geomspace(1.0, min(h, w) / 2, bands + 1)
    idx = np.digitize(r, edges) - 1
    out = np.zeros(bands)
    for b in range(bands):
        sel = idx == b
        out[b] = np.log10(f[sel].mean() / (h * w) + 1e-12) if sel.any() else -12.0
    return out


def pairwise_l2(x):
    x = x.astype(np.float64)
    sq = np.sum(x * x, axis=1)
    return np.sqrt(np.maximum(sq[:, None] + sq[None, :] - 2 * x @ x.T, 0))


def analyse_stage(work, m, seed=0, by="variance"):
    from PIL import Image
    files = names(work, m)
    n = len(files)
    material = np.repeat(np.arange(m), 2)
    choices = np.stack([mult_choices(f[:-4] + ".json") for f in files])
    imgs = [np.asarray(Image.open(f[:-4] + ".png").convert("RGB"), dtype=np.float64) / 255.0
            for f in files]
    pixels = np.stack([im.reshape(-1) for im in imgs])
    pix_rmse = pairwise_l2(pixels) / np.sqrt(pixels.shape[1])
    pix_d = pix_rmse ** 2
    judges = {"colour": pairwise_l2(np.stack([im.reshape(-1, 3).mean(0) for im in imgs])),
              "spectrum": pairwise_l2(np.stack([log_spectrum(im) for im in imgs])),
              "RMSE": pix_rmse}
    D = {}
    for key in DESCRIPTORS:
        desc = np.load(os.path.join(work, f"desc_{key}.npy"))
        cols = json.load(open(os.path.join(work, f"desc_{key}.columns.json")))
        D[key] = normalised_sqdist(desc, cols, by)
    # both networks at once: each distance over its mean, summed (equal say)
    D["vgg19+mnv2"] = D["vgg19"] / D["vgg19"].mean() + D["mnv2"] / D["mnv2"].mean()
    D["pixels"] = pix_d
    timing = json.load(open(os.path.join(work, "timing.json")))
    rng = np.random.default_rng(seed)
    train_mat = rng.permutation(m)[: m // 2]
    is_train = np.isin(material, train_mat)
    train, held = np.where(is_train)[0], np.where(~is_train)[0]
    agree_all = (choices[held][:, None, :] == choices[train][None, :, :]).mean(axis=2)  # (h, t)
    chance_agree = agree_all.mean()
    pairs = rng.integers(0, n, size=(20000, 2))
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    mult_dis = (choices[pairs[:, 0]] != choices[pairs[:, 1]]).sum(axis=1)
    print(f"{m} materials x 2 offsets = {n} renders; held-out {len(held)}, training {len(train)} "
          f"renders; {choices.shape[1]} multiplexers")
    print(f"chance: invariance 1/{n - 1} = {1 / (n - 1):.4f}; multiplexer agreement "
          f"{chance_agree:.3f} (+- {np.sqrt(chance_agree * (1 - chance_agree) / (len(held) * choices.shape[1])):.3f} "
          "one standard error of a retrieval's mean)")
    for j, J in judges.items():
        sub = J[np.ix_(held, train)]
        print(f"judge {j:8s}: random training render {sub.mean():.4f}, best possible "
              f"{sub.min(axis=1).mean():.4f}")
    print("| descriptor | invariance | NN multiplexer agreement | NN colour | NN spectrum | NN RMSE |")
    print("|---|---|---|---|---|---|")
    res = {}
    for key in list(DESCRIPTORS) + ["vgg19+mnv2", "pixels"]:
        d = D[key].copy()
        np.fill_diagonal(d, np.inf)
        nn_all = d.argmin(axis=1)
        partner = np.arange(n) ^ 1
        inv = float(np.mean(nn_all == partner))
        dt = d[np.ix_(held, train)]
        nn = train[dt.argmin(axis=1)]
        agree = float((choices[held] == choices[nn]).mean())
        r = dict(invariance=inv, agree=agree)
        for j, J in judges.items():
            r[j] = float(J[held, nn].mean())
        r["rho"] = {j: spearman(D[key][pairs[:, 0], pairs[:, 1]], J[pairs[:, 0], pairs[:, 1]])
                    for j, J in judges.items()}
        r["rho"]["multiplexers"] = spearman(D[key][pairs[:, 0], pairs[:, 1]], mult_dis)
        res[key] = r
        print(f"| {key} | {inv:.3f} | {agree:.3f} | {r['colour']:.4f} | {r['spectrum']:.4f} | "
              f"{r['RMSE']:.4f} |")
    print("Spearman rho of each descriptor's distance with: the other descriptors and the "
          f"judges, on {len(pairs)} random pairs")
    keys = list(DESCRIPTORS)
    print("| descriptor | " + " | ".join(keys) + " | colour | spectrum | RMSE | multiplexer disagreements |")
    print("|---" * (len(keys) + 5) + "|")
    for a in keys:
        da = D[a][pairs[:, 0], pairs[:, 1]]
        cells = [f"{spearman(da, D[b][pairs[:, 0], pairs[:, 1]]):.3f}" for b in keys]
        cells += [f"{res[a]['rho'][j]:.3f}" for j in ("colour", "spectrum", "RMSE", "multiplexers")]
        print(f"| {a} | " + " | ".join(cells) + " |")
    res["timing_ms_per_image"] = {k: 1000 * v for k, v in timing.items()}
    json.dump(res, open(os.path.join(work, "results.json"), "w"), indent=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("build")
    ap.add_argument("work")
    ap.add_argument("--materials", type=int, default=150)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--stage", choices=["render", "describe", "analyse", "all"], default="all")
    ap.add_argument("--normalise", choices=["variance", "norm"], default="variance",
                    help="per-layer scale of the distance (see normalised_sqdist)")
    ap.add_argument("--only", nargs="*", help="describe only these descriptors (keys)")
    args = ap.parse_args()
    imsynth = os.path.abspath(os.path.join(args.build, "cli", "imsynth"))
    work = os.path.abspath(args.work)
    if args.stage in ("render", "all"):
        render_stage(imsynth, work, args.materials)
    if args.stage in ("describe", "all"):
        describe_stage(imsynth, work, args.materials, args.threads, args.only)
    if args.stage in ("analyse", "all"):
        analyse_stage(work, args.materials, by=args.normalise)


if __name__ == "__main__":
    sys.exit(main())
