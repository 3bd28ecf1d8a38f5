"""Compact tables for EVALUATION.md from one or more `imsynth evaluate` report folders.

    python3 tests/bench/evaluation_table.py REPORT_DIR [REPORT_DIR ...]

Prints, per input set, every method's normalised distances as "median [p10, p90]" and the
shares of inputs on which it beats the mean / nearest, then the targets of each report (a share's with its 95% interval).
Reads report.json only (its "sets" and "targets"), so the figures are the report's own.
"""
import json
import sys


def cell(d):
    return "%.2f [%.2f, %.2f] %d%% / %d%%" % (d["median"], d["p10"], d["p90"],
                                           round(100 * d["beats_mean"]),
                                           round(100 * d["beats_nearest"]))


def main(dirs):
    print("| set | method | MobileNetV2 (train) | VGG19 (judge) | colour |")
    print("|---|---|---|---|---|")
    targets = []
    for d in dirs:
        r = json.load(open(d + "/report.json"))
        for name, s in r["sets"].items():
            first = True
            for method, m in s["image_space"].items():
                label = "%s (%d)" % (name, s["inputs"]) if first else ""
                first = False
                print("| %s | %s | %s | %s | %s |" % (label, method, cell(m["mobilenetv2"]),
                                                      cell(m["vgg19"]), cell(m["colour"])))
        targets += r.get("targets", [])
    print()
    print("| target | figure | 95% interval | needed | status |")
    print("|---|---|---|---|---|")
    for t in targets:
        fig = t.get("figure")
        if fig is None:
            continue
        ci = "%.3f - %.3f" % tuple(t["interval95"]) if t.get("interval95") else ""
        print("| %s | %.3f | %s | %.2f | %s |" % (t["what"], fig, ci, t["threshold"],
                                                  t["status"]))


if __name__ == "__main__":
    main(sys.argv[1:])
