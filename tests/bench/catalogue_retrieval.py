#!/usr/bin/python3
"""How close the catalogue's nearest sample is to a target, by retrieval metric and by
catalogue size, without rendering anything (EVALUATION.md, session 27).

    /usr/bin/python3 tests/bench/catalogue_retrieval.py MODEL_DIR TRAIN.sqlite TEST.sqlite

MODEL_DIR a model from `imsynth fit-predictor` (assets/model); TRAIN.sqlite a dataset
holding its catalogue's ids with their MobileNetV2 descriptors (the one it was fitted on,
or any of the same config and ids); TEST.sqlite the targets (view 0 of every row).

For each target: G, the Gram distance `imsynth evaluate` uses (evaluate_gram_distance:
the mean over the descriptor's five taps of ||a - b|| / (||a|| + ||b||)), between its
stored descriptor and a catalogue sample's stored one, for the sample retrieved
- over the PCA scores (`--nearest-metric pca`, predict's default since session 27),
- over the whitened components (`--nearest-metric whitened`, before),
- each metric's 8 nearest, the best of them by G (what the nearest-topk row's renders
  choose among, up to render noise),
- the oracle: the catalogue sample of least G (a search over every stored descriptor),
over the first 500, 1,000, 2,000 and all catalogue rows. Prints the medians over targets.
The targets' and the catalogue's descriptors are both stored renders (the test set's at its
own preset), so G here is not the normalised distance of the evaluation's tables.
"""
import json
import sqlite3
import struct
import sys

import numpy as np

TAPS = (528, 4656, 10440, 18528, 4656)  # MobileNetV2 Gram upper triangles (nn/nn.h)


def safetensors(path):
    raw = open(path, "rb").read()
    n = struct.unpack("<Q", raw[:8])[0]
    out = {}
    for name, t in json.loads(raw[8:8 + n]).items():
        if name == "__metadata__":
            continue
        a, b = t["data_offsets"]
        dtype = {"F16": np.float16, "F32": np.float32}[t["dtype"]]
        out[name] = np.frombuffer(raw[8 + n + a:8 + n + b], dtype=dtype).reshape(t["shape"]).astype(np.float32)
    return out


def descriptors(db):
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    rows = con.execute("select id, descriptor from samples where view = 0 order by id")
    return {i: np.frombuffer(d, dtype=np.float16).astype(np.float32) for i, d in rows}


def gram_distance(a, B):
    """G between one descriptor a (d) and each row of B (n, d)."""
    off = np.cumsum((0,) + TAPS)
    s = 0
    for l in range(len(TAPS)):
        x, Y = a[off[l]:off[l + 1]], B[:, off[l]:off[l + 1]]
        s = s + np.sqrt(((Y - x) ** 2).sum(1)) / (np.sqrt((x * x).sum()) + np.sqrt((Y * Y).sum(1)) + 1e-12)
    return s / len(TAPS)


def main(model, train, test):
    T = safetensors(f"{model}/transform.safetensors")
    C = safetensors(f"{model}/catalogue.safetensors")
    ids = (C["catalogue.id_low24"] + C["catalogue.id_high"] * 2 ** 24).astype(np.int64)
    sd = np.sqrt(T["pca.variance"])
    scores = C["catalogue.z"] * sd  # stored whitened; times the deviation = the PCA scores

    def reduce(X):  # the model's input transform, before whitening (predictor.c, reduce)
        x = np.sign(X) * np.log1p(np.abs(X) / T["signed_log.scale"])
        x = (x - T["standardise.mean"]) / T["standardise.std"]
        return x @ T["pca.components"].T

    have = descriptors(train)
    missing = [int(i) for i in ids if int(i) not in have]
    if missing:
        sys.exit(f"{train}: lacks {len(missing)} catalogue ids (first {missing[0]})")
    D = np.stack([have[int(i)] for i in ids])
    # the transform above must be the model's: its scores of the catalogue's own
    # descriptors equal the stored ones (up to float16)
    err = np.abs(reduce(D[:32]) - scores[:32]).max() / np.abs(scores[:32]).max()
    assert err < 2e-3, f"the transform does not reproduce the catalogue (relative error {err})"

    sizes = [n for n in (500, 1000, 2000) if n < len(ids)] + [len(ids)]
    ways = ("whitened", "pca", "whitened top 8", "pca top 8", "oracle")
    res = {(n, w): [] for n in sizes for w in ways}
    targets = descriptors(test)
    for d in targets.values():
        z = reduce(d[None])[0]
        g = gram_distance(d, D)
        for n in sizes:
            dp = ((scores[:n] - z) ** 2).sum(1)
            dw = (((scores[:n] - z) / sd) ** 2).sum(1)
            res[(n, "pca")].append(g[np.argmin(dp)])
            res[(n, "whitened")].append(g[np.argmin(dw)])
            res[(n, "pca top 8")].append(g[np.argsort(dp, kind="stable")[:8]].min())
            res[(n, "whitened top 8")].append(g[np.argsort(dw, kind="stable")[:8]].min())
            res[(n, "oracle")].append(g[:n].min())
    print(f"median G to the {len(targets)} targets of {test}, catalogue of {model}")
    print("| catalogue rows | " + " | ".join(ways) + " |")
    print("|---:|" + "---:|" * len(ways))
    for n in sizes:
        print(f"| {n:,} | " + " | ".join(f"{np.median(res[(n, w)]):.4f}" for w in ways) + " |")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
