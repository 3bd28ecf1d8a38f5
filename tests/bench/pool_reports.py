"""Pools the inputs of several `imsynth evaluate` reports made with the same model and
settings on disjoint inputs (e.g. test ids 1,000,000-15 in one run and 1,000,016-47 in
another) and prints, per set, method and distance: the median normalised distance over all
inputs, the shares of inputs on which the method beats the mean and nearest rows, and for
the -refine rows the median per-input cut from their start (refined / start raw distance).

    python3 tests/bench/pool_reports.py REPORT_DIR [REPORT_DIR ...]

An input name that appears in two reports is an error: pooled inputs must be disjoint.
"""
import csv
import statistics
import sys


def main(dirs):
    norm, raw = {}, {}
    seen = {}
    for d in dirs:
        with open(f"{d}/inputs.csv") as f:
            for r in csv.DictReader(f):
                key = (r["set"], r["input"])
                if seen.setdefault(key, d) != d:
                    sys.exit(f"{d}: input {r['input']} of set {r['set']} is also in {seen[key]}")
                norm[(r["set"], r["input"], r["method"], r["distance"])] = float(r["normalised"])
                raw[(r["set"], r["input"], r["method"], r["distance"])] = float(r["raw"])
    sets = sorted({k[0] for k in norm})
    methods = list(dict.fromkeys(k[2] for k in norm))
    dists = list(dict.fromkeys(k[3] for k in norm))
    for s in sets:
        inputs = sorted({k[1] for k in norm if k[0] == s})
        print(f"### {s} ({len(inputs)} inputs from {len(dirs)} reports)")
        print("| method | distance | median | beats mean | beats nearest | median refined / start |")
        print("|---|---|---:|---:|---:|---:|")
        for m in methods:
            for d in dists:
                v = [norm[(s, i, m, d)] for i in inputs if (s, i, m, d) in norm]
                if not v:
                    continue
                bm = sum(norm[(s, i, m, d)] < norm[(s, i, "mean", d)] for i in inputs
                         if (s, i, m, d) in norm) / len(v)
                bn = sum(norm[(s, i, m, d)] < norm[(s, i, "nearest", d)] for i in inputs
                         if (s, i, m, d) in norm) / len(v)
                cut = ""
                if m.endswith("-refine"):
                    start = m.replace("-refine", "-topk")
                    g = [raw[(s, i, m, d)] / raw[(s, i, start, d)] for i in inputs
                         if (s, i, m, d) in raw and raw.get((s, i, start, d))]
                    cut = f"{statistics.median(g):.3f}"
                print(f"| {m} | {d} | {statistics.median(v):.3f} | {bm:.0%} | {bn:.0%} | {cut} |")


if __name__ == "__main__":
    if not sys.argv[1:]:
        sys.exit(__doc__)
    main(sys.argv[1:])
