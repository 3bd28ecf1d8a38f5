"""Two refinement methods, input by input: for each -refine row and distance of two
`imsynth evaluate` reports made with the same model and inputs (e.g. --method es against
--method es-split), on how many inputs B's refined distance is below A's, and the median of
B / A. The medians of the reports' own tables compare different inputs' values; this pairs
them.

    python3 tests/bench/refine_compare.py [--methods M1,M2] REPORT_A REPORT_B [REPORT_A2 REPORT_B2 ...]

With more pairs (one per input set, say), the counts are summed over the pairs. --methods
compares those rows instead of the -refine ones (e.g. predictor,predictor-topk for two
models evaluated on the same inputs).

"sign test p": the two-sided exact sign test of "B is closer as often as A", inputs where
the two are equal left out: the chance of a count at least this far from half if B and A
were interchangeable. It asks nothing of the size of the differences.
"""
import csv
import math
import statistics
import sys


def load(report):
    out = {}
    with open(f"{report}/inputs.csv") as f:
        for r in csv.DictReader(f):
            out[(r["set"], r["input"], r["method"], r["distance"])] = float(r["normalised"])
    return out


def sign_test(wins, losses):
    """Two-sided exact binomial test of wins against wins + losses at p = 1/2."""
    n = wins + losses
    if n == 0:
        return float("nan")
    k = min(wins, losses)
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2 ** n
    return min(1.0, 2 * tail)


def main(argv):
    methods = None
    if argv[:1] == ["--methods"] and len(argv) > 1:
        methods = set(argv[1].split(","))
        argv = argv[2:]
    if len(argv) < 2 or len(argv) % 2:
        sys.exit(__doc__)
    ratios = {}
    for a_dir, b_dir in zip(argv[0::2], argv[1::2]):
        a, b = load(a_dir), load(b_dir)
        for key, va in a.items():
            s, name, m, d = key
            wanted = m in methods if methods else m.endswith("-refine")
            if wanted and key in b and va > 0:
                ratios.setdefault((m, d), []).append(b[key] / va)
    print(f"B = {' '.join(argv[1::2])} against A = {' '.join(argv[0::2])}")
    print("| row | distance | inputs | B better | median B / A | sign test p |")
    print("|---|---|---:|---:|---:|---:|")
    for (m, d), v in sorted(ratios.items()):
        better, worse = sum(x < 1 for x in v), sum(x > 1 for x in v)
        print(f"| {m} | {d} | {len(v)} | {better} | {statistics.median(v):.3f} "
              f"| {sign_test(better, worse):.3g} |")


if __name__ == "__main__":
    main(sys.argv[1:])
