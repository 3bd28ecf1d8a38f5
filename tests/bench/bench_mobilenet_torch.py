#!/usr/bin/python3
"""PyTorch's time for the MobileNetV2 descriptor (default taps, one scale), float32, the
forward of tests/reference/nn/mobilenetv2/make_fixture.py: the oracle beside
bench_mobilenet (tests/bench/bench_mobilenet.sh runs both).

    /usr/bin/python3 tests/bench/bench_mobilenet_torch.py [--threads 2] [--reps 3]
"""
import argparse
import importlib.util
import os
import time

import torch

HERE = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location(
    "make_fixture", os.path.join(HERE, "..", "reference", "nn", "mobilenetv2", "make_fixture.py"))
fixture = importlib.util.module_from_spec(spec)
spec.loader.exec_module(fixture)

TAPS = ["conv1", "block_1_expand", "block_3_expand", "block_6_expand", "block_10_project"]


def describe(W, x):
    rows = []
    for k in range(x.shape[0]):
        f = fixture.features(W, x[k:k + 1], set(TAPS))
        parts = []
        for t in TAPS:
            g = (f[t] @ f[t].T) / f[t].shape[1]
            iu = torch.triu_indices(g.shape[0], g.shape[0])
            parts.append(g[iu[0], iu[1]])
        rows.append(torch.cat(parts))
    return torch.stack(rows)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reps", type=int, default=3)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    W = {k: v.float() for k, v in fixture.read_safetensors(fixture.WEIGHTS).items()}
    print(f"torch {torch.__version__}, threads {args.threads}")
    with torch.no_grad():
        for batch in (1, 8):
            x = torch.rand(batch, 3, 224, 224)
            describe(W, x)
            best = best_cpu = 1e30
            for _ in range(args.reps):
                t, c = time.perf_counter(), time.process_time()
                describe(W, x)
                best = min(best, time.perf_counter() - t)
                best_cpu = min(best_cpu, time.process_time() - c)
            print(f"torch mobilenetv2 default x1  batch {batch}: {1e3 * best / batch:.2f} ms/image "
                  f"({1e3 * best_cpu / batch:.2f} cpu-ms)")


if __name__ == "__main__":
    main()
