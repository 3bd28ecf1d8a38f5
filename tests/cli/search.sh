#!/bin/sh
# imsynth search: from a dataset, a render of sample 5's parameters finds sample 5 first
# (under another noise seed); from a model's catalogue, k hits ordered by distance, each
# with its export command; the sheet is written; bad sources are clear errors.
# Usage: search.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"

"$imsynth" datagen --out "$tmp/ds.sqlite" --count 16 --preset draft --quiet
check "a draft dataset with renders" 0 $?
"$imsynth" sample --seed 5 -o "$tmp/p5.json" && "$imsynth" render "$root/assets/supershader.json" \
    --params "$tmp/p5.json" --spp 1 --max-spp 0 --seed 99 -o "$tmp/r5.exr" > /dev/null
check "a render of sample 5 (another noise seed)" 0 $?

"$imsynth" search "$tmp/r5.exr" --dataset "$tmp/ds.sqlite" -k 3 -o "$tmp/sheet.png" \
    --json "$tmp/hits.json" > "$tmp/out"
check "search a dataset" 0 $?
[ -s "$tmp/sheet.png" ]; check "the sheet is written" 0 $?
[ "$(head -1 "$tmp/out" | cut -f1)" = 5 ]; check "sample 5 is the nearest" 0 $?
py - "$tmp/hits.json" << 'PY'
import json, sys
h = json.load(open(sys.argv[1]))["hits"]
d = [x["distance"] for x in h]
assert len(h) == 3 and d == sorted(d) and d[0] < d[1], d
assert h[0]["export"].endswith("--seed 5 -o m.json") and len(h[0]["params"]) == 50
PY
check "hits ordered, with export commands and parameters" 0 $?

"$imsynth" fit-predictor --dataset "$tmp/ds.sqlite" --components 4 --hidden 8 --batch 4 \
    --val-fraction 0.2 --epochs 1 --quiet -o "$tmp/model"
check "a small model" 0 $?
"$imsynth" search "$tmp/r5.exr" --model "$tmp/model" -k 4 --preset draft -o "$tmp/s2.png" \
    --json "$tmp/h2.json" --quiet > "$tmp/out"
check "search a catalogue" 0 $?
[ -s "$tmp/s2.png" ] && [ ! -s "$tmp/out" ]; check "catalogue sheet written, --quiet prints nothing" 0 $?
py -c "import json,sys; d=[x['distance'] for x in json.load(open(sys.argv[1]))['hits']]; assert len(d)==4 and d==sorted(d), d" "$tmp/h2.json"
check "catalogue hits ordered" 0 $?
"$imsynth" search "$tmp/r5.exr" --catalogue "$tmp/model" -k 4 --preset draft -o "$tmp/s3.png" \
    --json "$tmp/h3.json" --quiet
check "--catalogue names the same source" 0 $?
cmp -s "$tmp/h2.json" "$tmp/h3.json"; check "--catalogue finds what --model finds" 0 $?
"$imsynth" search "$tmp/r5.exr" --model "$tmp/model" -k 16 --preset draft -o "$tmp/s4.png" \
    --json "$tmp/hp.json" --nearest-metric pca --quiet &&
"$imsynth" search "$tmp/r5.exr" --model "$tmp/model" -k 16 --preset draft -o "$tmp/s5.png" \
    --json "$tmp/hw.json" --nearest-metric whitened --quiet
check "--nearest-metric pca and whitened" 0 $?
# The PCA distance weighs each whitened component's difference by its variance, so per hit
# min(var) dw^2 <= dp^2 <= max(var) dw^2; and the model's leading components vary far more
# than their unit-variance whitened forms, so the two rankings' distances differ.
py - "$tmp/hp.json" "$tmp/hw.json" "$tmp/model/transform.safetensors" "$tmp/h2.json" << 'PY'
import json, struct, sys
hp, hw = (json.load(open(f)) for f in sys.argv[1:3])
raw = open(sys.argv[3], "rb").read()
n = struct.unpack("<Q", raw[:8])[0]
t = json.loads(raw[8:8 + n])["pca.variance"]
a, b = t["data_offsets"]
assert t["dtype"] == "F32", t
var = struct.unpack("<%df" % ((b - a) // 4), raw[8 + n + a:8 + n + b])
assert len(var) == 4 and min(var) > 1, var
assert "PCA scores" in hp["distance"] and "whitened" in hw["distance"], (hp["distance"], hw["distance"])
assert hp["hits"][:4] == json.load(open(sys.argv[4]))["hits"], "the default is not pca"
dp = {x["id"]: x["distance"] for x in hp["hits"]}
dw = {x["id"]: x["distance"] for x in hw["hits"]}
assert len(dp) > 8 and set(dp) == set(dw), (dp, dw)  # k 16: the whole catalogue, both ways
assert dp != dw
for i in dp:
    assert min(var) * dw[i] ** 2 * (1 - 1e-4) <= dp[i] ** 2 <= max(var) * dw[i] ** 2 * (1 + 1e-4), (i, dp[i], dw[i], var)
assert sorted(dp.values()) == [x["distance"] for x in hp["hits"]]
PY
check "the PCA distance is the whitened one scaled by the components' variances" 0 $?
cp -r "$tmp/model" "$tmp/negvar"
py - "$tmp/negvar/transform.safetensors" << 'PY'
import json, struct, sys
raw = bytearray(open(sys.argv[1], "rb").read())
n = struct.unpack("<Q", raw[:8])[0]
a = json.loads(raw[8:8 + n])["pca.variance"]["data_offsets"][0]
raw[8 + n + a + 4:8 + n + a + 8] = struct.pack("<f", -2.0)
open(sys.argv[1], "wb").write(raw)
PY
"$imsynth" search "$tmp/r5.exr" --model "$tmp/negvar" -o "$tmp/x.png" 2> "$tmp/err"
check "a model with a negative component variance" 1 $?
expect_stderr "names the file and the component" "negvar/transform.safetensors: principal component 1 has a negative"

"$imsynth" datagen --out "$tmp/nodesc.sqlite" --count 2 --preset draft --descriptor none --quiet
"$imsynth" search "$tmp/r5.exr" --dataset "$tmp/nodesc.sqlite" -o "$tmp/x.png" 2> "$tmp/err"
check "a dataset without descriptors" 1 $?
expect_stderr "says why" "nodesc.sqlite: stores no whole"
[ ! -e "$tmp/x.png" ]; check "no sheet left" 0 $?
"$imsynth" search "$tmp/r5.exr" --dataset "$tmp/ds.sqlite" --model "$tmp/model" -o "$tmp/x.png" 2> "$tmp/err"
check "two sources is a usage error" 2 $?
"$imsynth" search "$tmp/r5.exr" --dataset "$tmp/ds.sqlite" --catalogue "$tmp/model" -o "$tmp/x.png" 2> "$tmp/err"
check "--catalogue with --dataset too" 2 $?
finish
