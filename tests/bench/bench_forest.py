#!/usr/bin/python3
"""imsynth forest against scikit-learn 1.2's RandomForestRegressor, side by side in one run.

Both fit the same .npy data with the same hyper-parameters (100 trees, max_features sqrt,
bootstrap, fully grown); the table gives fit time (wall and CPU), held-out R^2 (mean over
outputs, sklearn.metrics.r2_score), peak RSS and the overlap of the top-2,500 impurity
importances with scikit-learn's (seed 0), next to scikit-learn seed 1's overlap with seed 0
(the ceiling a different random forest can reach). Then how our time grows with rows,
features and outputs, and the masked-target study (exclude vs impute vs no mask).

usage: /usr/bin/python3 tests/bench/bench_forest.py [--imsynth build/cli/imsynth] [--quick]
       [--exact] [--skip-main] [--skip-scaling] [--skip-mask] [--npy-dir EXPORT_DIR]
"""
import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np
import sklearn
from sklearn.ensemble import RandomForestRegressor
from sklearn.metrics import r2_score

LATENT = 25


def make_descriptor_like(n, d, k, seed, informative=4000):
    """Features 0..informative-1 are noisy copies of 25 latent factors with weights that
    fall with the index (so importance has a long, graded head); the rest are noise.
    Outputs are smooth non-linear functions of the factors."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(-1, 1, (n, LATENT)).astype(np.float32)
    X = rng.standard_normal((n, d), dtype=np.float32) * 0.5
    inf = min(informative, d)
    j = np.arange(inf)
    w = (1.0 / (1.0 + j / 400.0)).astype(np.float32)
    X[:, :inf] += z[:, j % LATENT] * w
    o = np.arange(k)
    Y = (np.sin(2.0 * z[:, o % LATENT]) + z[:, (o * 7 + 3) % LATENT] * z[:, (o * 5 + 1) % LATENT]
         + 0.1 * rng.standard_normal((n, k)))
    return X, Y.astype(np.float32)


def load_average():
    return " ".join(open("/proc/loadavg").read().split()[:3])


class Child:
    """Runs a command and measures its wall time, CPU time and peak RSS via wait4."""

    def __init__(self, cmd):
        t0 = time.perf_counter()
        pid = os.fork()
        if pid == 0:
            fd = os.open(os.devnull, os.O_WRONLY)
            os.dup2(fd, 1)
            os.dup2(fd, 2)
            os.execv(cmd[0], cmd)
        _, status, ru = os.wait4(pid, 0)
        self.wall = time.perf_counter() - t0
        if status != 0:
            sys.exit(f"failed ({status}): {' '.join(cmd)}")
        self.cpu = ru.ru_utime + ru.ru_stime
        self.rss_gb = ru.ru_maxrss / 1024 / 1024


def ours_fit(imsynth, work, X_path, Y_path, trees, seed, split="binned", extra=()):
    model = os.path.join(work, f"forest_{split}_{seed}.bin")
    c = Child([imsynth, "forest", "fit", "--x", X_path, "--y", Y_path, "-o", model,
               "--trees", str(trees), "--max-features", "sqrt", "--seed", str(seed),
               "--threads", "2", "--split", split, "--quiet", *extra])
    return c, model


def ours_predict_and_importance(imsynth, work, model, Xt_path):
    pred = os.path.join(work, "pred.npy")
    scores = os.path.join(work, "scores.npy")
    mask = os.path.join(work, "mask.npy")
    subprocess.run([imsynth, "forest", "predict", model, "--x", Xt_path, "-o", pred],
                   check=True, stdout=subprocess.DEVNULL)
    subprocess.run([imsynth, "forest", "importance", model, "--top-k", "1", "-o", mask,
                    "--scores", scores], check=True, stdout=subprocess.DEVNULL)
    return np.load(pred), np.load(scores).ravel()


def top(scores, k):
    # Highest first, ties by lower index (as forest_top_k).
    return set(np.lexsort((np.arange(len(scores)), -scores))[:k].tolist())


def sklearn_fit(X, Y, trees, seed, jobs=2):
    m = RandomForestRegressor(n_estimators=trees, max_features="sqrt", n_jobs=jobs,
                              random_state=seed)
    t0, c0 = time.perf_counter(), time.process_time()
    m.fit(X, Y)
    return m, time.perf_counter() - t0, time.process_time() - c0


def main_comparison(a, work):
    n, nt, d, k, trees, topk = a.rows, a.test_rows, a.features, a.outputs, a.trees, a.top
    if a.npy_dir:
        # Case (b): a dataset's descriptors and parameters (`imsynth dataset export --npy`):
        # the last test_rows rows are held out.
        X = np.load(os.path.join(a.npy_dir, "descriptors.npy")).astype(np.float32)
        Y = np.load(os.path.join(a.npy_dir, "params.npy")).astype(np.float32)
        nt = min(nt, len(X) // 4)
        n, d, k = len(X) - nt, X.shape[1], Y.shape[1]
        topk = min(topk, d // 4)
    else:
        X, Y = make_descriptor_like(n + nt, d, k, seed=1)
    Xtr, Ytr, Xt, Yt = X[:n], Y[:n], X[n:], Y[n:]
    paths = {}
    for name, arr in (("X", Xtr), ("Y", Ytr), ("Xt", Xt)):
        paths[name] = os.path.join(work, name + ".npy")
        np.save(paths[name], arr)
    print(f"## {n} x {d} -> {k} outputs ({nt} held-out rows), {trees} trees, max_features sqrt,"
          f" 2 jobs/threads; load average before: {load_average()}\n")
    rows = []
    m0, w0, c0 = sklearn_fit(Xtr, Ytr, trees, 0)
    r2_0 = r2_score(Yt, m0.predict(Xt))
    imp0 = m0.feature_importances_
    top0 = top(imp0, topk)
    rss_sk = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024 / 1024
    del m0
    rows.append(("scikit-learn seed 0", w0, c0, r2_0, "-", f"{rss_sk:.2f} (process)"))
    if not a.quick:
        m1, w1, c1 = sklearn_fit(Xtr, Ytr, trees, 1)
        r2_1 = r2_score(Yt, m1.predict(Xt))
        ov = len(top(m1.feature_importances_, topk) & top0) / topk
        del m1
        rows.append(("scikit-learn seed 1", w1, c1, r2_1, f"{ov:.3f}", "-"))
    modes = ["binned"] + (["exact"] if a.exact else [])
    ours_top = {}
    for split in modes:
        for seed in ([0, 1] if split == "binned" and not a.quick else [0]):
            c, model = ours_fit(a.imsynth, work, paths["X"], paths["Y"], trees, seed, split)
            P, s = ours_predict_and_importance(a.imsynth, work, model, paths["Xt"])
            ours_top[(split, seed)] = top(s, topk)
            ov = len(ours_top[(split, seed)] & top0) / topk
            rows.append((f"imsynth {split} seed {seed}", c.wall, c.cpu, r2_score(Yt, P),
                         f"{ov:.3f}", f"{c.rss_gb:.2f}"))
    print(f"| fit | wall s | CPU s | held-out R^2 | top-{topk} overlap with sklearn seed 0 |"
          " peak RSS GB |")
    print("|---|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r[0]} | {r[1]:.1f} | {r[2]:.1f} | {r[3]:.4f} | {r[4]} | {r[5]} |")
    if ("binned", 1) in ours_top:
        ov = len(ours_top[("binned", 0)] & ours_top[("binned", 1)]) / topk
        print(f"\nimsynth seed 0 vs seed 1 top-{topk} overlap: {ov:.3f}")
    print(f"\nspeed-up (wall, sklearn seed 0 / imsynth binned seed 0): "
          f"{rows[0][1] / [r for r in rows if r[0] == 'imsynth binned seed 0'][0][1]:.1f}x;"
          f" load average after: {load_average()}\n")


def scaling(a, work):
    trees = 20
    print(f"## How imsynth's fit time grows (binned, {trees} trees, sqrt, 2 threads; wall / CPU s)\n")
    base = (2000, 20000, 50)
    grid = [("rows", 0, [500, 1000, 2000, 4000]), ("features", 1, [5000, 10000, 20000, 40000]),
            ("outputs", 2, [10, 25, 50, 100])]
    if a.quick:
        grid = [(g[0], g[1], g[2][:2]) for g in grid]
    for label, axis, values in grid:
        cells = []
        for v in values:
            shape = list(base)
            shape[axis] = v
            n, d, k = shape
            X, Y = make_descriptor_like(n, d, k, seed=3)
            xp, yp = os.path.join(work, "sx.npy"), os.path.join(work, "sy.npy")
            np.save(xp, X)
            np.save(yp, Y)
            c, _ = ours_fit(a.imsynth, work, xp, yp, trees, 0)
            cells.append(f"{v}: {c.wall:.2f} / {c.cpu:.2f}")
        print(f"- {label} (others {base}): " + ", ".join(cells))
    print(f"\nload average after: {load_average()}\n")


def mask_study(a, work):
    """Outputs 0-4 always active; output j >= 5 active only for rows of category j % 3
    (like the parameters of a node a material does not use). Inactive targets hold a
    default (0), as a dataset would store them. X shows the category and 5 latent factors
    (noisily) among 20 noise features."""
    n, nt, k = 3000, 1000, 20
    rng = np.random.default_rng(5)
    N = n + nt
    cat = rng.integers(0, 3, N)
    z = rng.uniform(-1, 1, (N, 5))
    X = np.concatenate([cat[:, None] + 0.1 * rng.standard_normal((N, 1)),
                        z + 0.05 * rng.standard_normal((N, 5)),
                        rng.standard_normal((N, 20))], axis=1).astype(np.float32)
    d = X.shape[1]
    o = np.arange(k)
    Y = np.sin(2 * z[:, o % 5]) + 0.5 * z[:, (o + 1) % 5] + 0.5 * cat[:, None] \
        + 0.1 * rng.standard_normal((N, k))
    M = np.ones((N, k), dtype=np.float32)
    for j in range(5, k):
        M[:, j] = cat == j % 3
    Y = np.where(M > 0, Y, 0.0).astype(np.float32)
    files = {}
    for name, arr in (("mX", X[:n]), ("mY", Y[:n]), ("mM", M[:n]), ("mXt", X[n:]),
                      ("mYt", Y[n:]), ("mMt", M[n:])):
        files[name] = os.path.join(work, name + ".npy")
        np.save(files[name], arr)
    print(f"## Masked targets: {n} x {d} -> {k} outputs, 15 of them active on a third of the"
          f" rows; held-out R^2 over active entries only ({nt} rows, 100 trees, sqrt)\n")
    print("| handling | R^2 (all outputs) | R^2 (the 15 partly masked outputs) | fit wall s |")
    print("|---|---:|---:|---:|")
    Mt, Yt = M[n:] > 0, Y[n:]

    def r2_active(P, cols):
        vals = []
        for j in cols:
            a_ = Mt[:, j]
            vals.append(r2_score(Yt[a_, j], P[a_, j]))
        return np.mean(vals)

    for label, extra in (("exclude (default)", ["--mask", files["mM"]]),
                         ("impute (output mean)", ["--mask", files["mM"], "--mask-mode", "impute"]),
                         ("no mask (defaults as targets)", [])):
        c, model = ours_fit(a.imsynth, work, files["mX"], files["mY"], 100, 0, "binned", extra)
        pred = os.path.join(work, "mpred.npy")
        subprocess.run([a.imsynth, "forest", "predict", model, "--x", files["mXt"], "-o", pred],
                       check=True, stdout=subprocess.DEVNULL)
        P = np.load(pred)
        print(f"| {label} | {r2_active(P, range(k)):.4f} | {r2_active(P, range(5, k)):.4f} |"
              f" {c.wall:.1f} |")
    print()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--imsynth", default=os.path.join(os.path.dirname(__file__), "..", "..",
                                                      "build", "cli", "imsynth"))
    ap.add_argument("--rows", type=int, default=2000)
    ap.add_argument("--test-rows", type=int, default=500)
    ap.add_argument("--features", type=int, default=20000)
    ap.add_argument("--outputs", type=int, default=50)
    ap.add_argument("--trees", type=int, default=100)
    ap.add_argument("--top", type=int, default=2500)
    ap.add_argument("--quick", action="store_true", help="smaller grids, one seed each")
    ap.add_argument("--npy-dir", help="compare on a dataset export (descriptors.npy, params.npy) "
                    "instead of the synthetic problem")
    ap.add_argument("--exact", action="store_true", help="also fit imsynth in exact mode")
    ap.add_argument("--skip-main", action="store_true")
    ap.add_argument("--skip-scaling", action="store_true")
    ap.add_argument("--skip-mask", action="store_true")
    a = ap.parse_args()
    a.imsynth = os.path.abspath(a.imsynth)
    print(f"scikit-learn {sklearn.__version__}, numpy {np.__version__}; "
          f"{os.cpu_count()} CPUs; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}\n")
    with tempfile.TemporaryDirectory() as work:
        if not a.skip_main:
            main_comparison(a, work)
        if not a.skip_scaling:
            scaling(a, work)
        if not a.skip_mask:
            mask_study(a, work)


if __name__ == "__main__":
    main()
