"""Per-input gain of the refinement in an `imsynth evaluate` report: for each input and
distance, the -refine method's raw distance over its start's (the -topk pick it refined),
and the median of that ratio over the inputs of each set. A ratio of 0.7 is a 30% cut.

    python3 tests/bench/refine_gain.py REPORT_DIR [REPORT_DIR...]
"""
import csv
import statistics
import sys


def gains(report):
    raw = {}
    with open(f"{report}/inputs.csv") as f:
        for r in csv.DictReader(f):
            raw[(r["set"], r["input"], r["method"], r["distance"])] = float(r["raw"])
    out = {}
    for (s, name, m, d), v in raw.items():
        if not m.endswith("-refine"):
            continue
        start = raw.get((s, name, m.replace("-refine", "-topk"), d))
        if start:
            out.setdefault((s, m, d), []).append(v / start)
    return out


for report in sys.argv[1:]:
    print(f"## {report}")
    print("| set | method | distance | inputs | median refined / start | share improved |")
    print("|---|---|---|---:|---:|---:|")
    for (s, m, d), v in sorted(gains(report).items()):
        better = sum(x < 1 for x in v) / len(v)
        print(f"| {s} | {m} | {d} | {len(v)} | {statistics.median(v):.3f} | {better:.0%} |")
