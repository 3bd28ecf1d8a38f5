#!/usr/bin/python3
"""PyTorch side of the training benchmark (see bench_train.c, BENCHMARKS.md).

    /usr/bin/python3 tests/bench/bench_train_torch.py [--arch mlp:2500-1000-1000-50,relu]
        [--batch 128] [--steps 30] [--threads 2]

The same MLP (nn.Sequential of Linear / [LayerNorm] / activation), sigmoid head, MSE,
AdamW with torch's defaults (single-tensor and foreach implementations both timed), random
data of 8 batches; training samples/s after 3 warm-up steps and the median latency of
one-sample inference under torch.no_grad().
"""
import os
import sys
import time

import torch
import torch.nn as nn

args = sys.argv[1:]


def opt(name, default):
    return type(default)(args[args.index(name) + 1]) if name in args else default


arch = opt("--arch", "mlp:2500-1000-1000-50,relu")
batch, steps, threads = opt("--batch", 128), opt("--steps", 30), opt("--threads", 2)
torch.set_num_threads(threads)
body = arch[4:].split(",")
widths = [int(w) for w in body[0].split("-")]
mods = []
for l in range(len(widths) - 1):
    mods.append(nn.Linear(widths[l], widths[l + 1]))
    if l < len(widths) - 2:
        if "ln" in body:
            mods.append(nn.LayerNorm(widths[l + 1]))
        mods.append(nn.GELU() if "gelu" in body else nn.ReLU())
model = nn.Sequential(*mods)
rows = batch * 8
x = torch.rand(rows, widths[0]) * 2 - 1
y = torch.rand(rows, widths[-1])

for foreach in (False, True):
    o = torch.optim.AdamW(model.parameters(), foreach=foreach)

    def step(t):
        b = (t % 8) * batch
        o.zero_grad()
        loss = ((torch.sigmoid(model(x[b:b + batch])) - y[b:b + batch]) ** 2).mean()
        loss.backward()
        o.step()
        return loss.item()

    for t in range(3):
        step(t)
    t0 = time.perf_counter()
    for t in range(steps):
        loss = step(t)
    dt = time.perf_counter() - t0
    lat = []
    with torch.no_grad():
        for r in range(200):
            a = time.perf_counter()
            torch.sigmoid(model(x[r % rows:r % rows + 1]))
            lat.append(time.perf_counter() - a)
    lat.sort()
    print("pytorch  %s batch %d threads %d, OpenBLAS threads %s (AdamW foreach=%s): train "
          "%.1f samples/s (%.2f ms/step), infer 1 sample %.3f ms (median of 200), last loss %.5f"
          % (arch, batch, threads, os.environ.get("OPENBLAS_NUM_THREADS", "default"), foreach,
             steps * batch / dt, 1e3 * dt / steps, 1e3 * lat[100], loss))
