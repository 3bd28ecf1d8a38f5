#!/usr/bin/python3
"""PyTorch side of the VGG19 descriptor benchmark (see bench_vgg.c, BENCHMARKS.md).

    /usr/bin/python3 tests/bench/bench_vgg_torch.py [--threads 2] [--reps 3] [--quick]

torchvision VGG19 `features` up to conv5_4 (random weights: speed does not depend on
them), pooling replaced as in the descriptor, Gram matrices after conv1_2 ... conv5_4,
upper triangles concatenated; seconds per image (best of reps) for batch 1 and 8, wall
and process CPU time (all threads).
"""
import sys
import time

import torch
from torchvision.models.vgg import cfgs, make_layers

args = sys.argv[1:]
threads = int(args[args.index("--threads") + 1]) if "--threads" in args else 2
reps = int(args[args.index("--reps") + 1]) if "--reps" in args else 3
quick = "--quick" in args
torch.set_num_threads(threads)
GRAM_AFTER = [2, 7, 16, 25, 34]


def build(pool):
    feats = make_layers(cfgs["E"], batch_norm=False)[:35]
    for i, m in enumerate(feats):
        if isinstance(m, torch.nn.MaxPool2d):
            feats[i] = torch.nn.AvgPool2d(3) if pool == "avg3" else torch.nn.MaxPool2d(2)
        elif isinstance(m, torch.nn.ReLU):
            feats[i] = torch.nn.ReLU(inplace=False)
    return feats.eval()


def describe(feats, x):
    out = []
    for i, m in enumerate(feats):
        x = m(x)
        if i in GRAM_AFTER:
            n, c, h, w = x.shape
            f = x.reshape(n, c, h * w)
            g = torch.bmm(f, f.transpose(1, 2)) / (h * w)
            iu = torch.triu_indices(c, c)
            out.append(g[:, iu[0], iu[1]])
    return torch.cat(out, 1)


def gflop(pool):
    widths, convs = [64, 128, 256, 512, 512], [2, 2, 4, 4, 4]
    flop, s, cin = 0.0, 224, 3
    for b in range(5):
        for _ in range(convs[b]):
            flop += 2.0 * widths[b] * cin * 9 * s * s
            cin = widths[b]
        flop += widths[b] * widths[b] * s * s
        s = (s - 3) // 3 + 1 if pool == "avg3" else s // 2
    return flop * 1e-9


def sgemm_gflops():
    a = torch.randn(1024, 1024)
    b = torch.randn(1024, 1024)
    torch.mm(a, b)
    best = 1e30
    for _ in range(reps):
        t = time.perf_counter()
        torch.mm(a, b)
        best = min(best, time.perf_counter() - t)
    return 2 * 1024 ** 3 / best * 1e-9


print(f"torch {torch.__version__}, threads {torch.get_num_threads()}, reps {reps} (best of)")
print(f"torch.mm 1024^3: {sgemm_gflops():.1f} GFLOP/s")
print(f"{'pool':5} {'batch':>5} {'s/image':>10} {'GFLOP/s':>8} {'cpu-s/image':>12}")
with torch.no_grad():
    for pool in (["avg3"] if quick else ["avg3", "max2"]):
        feats = build(pool)
        for n in (1, 8):
            x = torch.randn(n, 3, 224, 224)
            describe(feats, x)
            best, best_cpu = 1e30, 1e30
            for _ in range(reps):
                t, c = time.perf_counter(), time.process_time()
                describe(feats, x)
                best = min(best, time.perf_counter() - t)
                best_cpu = min(best_cpu, time.process_time() - c)
            per = best / n
            print(f"{pool:5} {n:5d} {per:10.4f} {gflop(pool) / per:8.1f} {best_cpu / n:12.4f}",
                  flush=True)
