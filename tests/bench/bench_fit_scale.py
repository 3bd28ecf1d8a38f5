#!/usr/bin/python3
"""Predictor training time at the issue's 50k samples (issue 15: "< 1 hour on this machine"):

    /usr/bin/python3 tests/bench/bench_fit_scale.py [--imsynth build/cli/imsynth]
        [--base 256] [--rows 50000] [--epochs 30] [--work DIR]

A 50k-sample dataset takes ~13 hours of datagen here, so this measures the training on a
dataset of that size made from a small real one: `imsynth datagen --count BASE` (the default
preset and descriptor), then its rows copied under new ids until there are ROWS samples
(images left out of the copies: fit-predictor reads descriptors, parameters and masks).
What the time depends on is the same as for real data: the rows read and decoded, the
randomized PCA (a fixed number of passes over a rows x 38,808 matrix, whatever its values),
and 30 epochs over the rows. What is not real is the model: copies make its validation loss
meaningless, and it is deleted. Prints the wall and CPU time, the peak memory, and the
stage times from fit-predictor's progress lines. The load average is printed before and
after (the machine may be shared).
"""
import os
import re
import shutil
import sqlite3
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
from bench_common import loadavg  # noqa: E402

args = sys.argv[1:]


def opt(name, default):
    return args[args.index(name) + 1] if name in args else default


imsynth = os.path.abspath(opt("--imsynth", os.path.join(REPO, "build", "cli", "imsynth")))
base = int(opt("--base", "256"))
rows = int(opt("--rows", "50000"))
epochs = opt("--epochs", "30")
work = os.path.abspath(opt("--work", "/tmp/bench_fit_scale"))
os.makedirs(work, exist_ok=True)
print("load average before:", " ".join(loadavg()), flush=True)

base_db = os.path.join(work, "base%d.sqlite" % base)
if not os.path.exists(base_db):
    t0 = time.time()
    subprocess.run([imsynth, "datagen", "--out", base_db, "--count", str(base)], check=True)
    print("datagen of %d samples: %.0f s" % (base, time.time() - t0), flush=True)

big = os.path.join(work, "rows%d.sqlite" % rows)
if not os.path.exists(big):
    t0 = time.time()
    tmp = big + ".tmp"
    shutil.copyfile(base_db, tmp)
    db = sqlite3.connect(tmp)
    (n_ids, lo, hi) = db.execute("SELECT COUNT(DISTINCT id), MIN(id), MAX(id) FROM samples").fetchone()
    if n_ids != base or lo != 0 or hi != base - 1:
        sys.exit("%s: expected ids 0..%d, found %d ids in %d..%d" % (base_db, base - 1, n_ids, lo, hi))
    copies = (rows + base - 1) // base
    for k in range(1, copies):
        db.execute("INSERT INTO samples(id, view, params, active, subshader_nodes, view_json, image, descriptor) "
                   "SELECT id + ?, view, params, active, subshader_nodes, view_json, NULL, descriptor "
                   "FROM samples WHERE id < ? AND id + ? < ?", (k * base, base, k * base, rows))
        db.commit()
    db.close()
    os.rename(tmp, big)
    print("copied to %d samples: %.0f s, %.2f GB" % (rows, time.time() - t0, os.path.getsize(big) / 1e9), flush=True)

model = os.path.join(work, "model%d" % rows)
shutil.rmtree(model, ignore_errors=True)
shutil.rmtree(model + ".partial", ignore_errors=True)
cmd = ["/usr/bin/time", "-v", imsynth, "fit-predictor", "--dataset", big, "--epochs", epochs,
       "--half", "--catalogue", "4096", "-o", model]
print("$", " ".join(cmd), flush=True)
t0 = time.time()
p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
wall = time.time() - t0
out = p.stdout
sys.stdout.write(out)
if p.returncode != 0:
    sys.exit("fit-predictor failed (exit %d)" % p.returncode)


def field(name):
    m = re.search(r"^\s*" + re.escape(name) + r": (.*)$", out, re.M)
    return m.group(1).strip() if m else "?"


cpu = float(field("User time (seconds)")) + float(field("System time (seconds)"))
rss_gb = int(field("Maximum resident set size (kbytes)")) / 1e6
print("\n| samples | epochs | wall | CPU | peak RSS |")
print("|---:|---:|---:|---:|---:|")
print("| %d | %s | %.0f s (%.1f min) | %.0f s | %.1f GB |" % (rows, epochs, wall, wall / 60, cpu, rss_gb))
print("load average after:", " ".join(loadavg()), flush=True)
shutil.rmtree(model, ignore_errors=True)
