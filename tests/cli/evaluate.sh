#!/bin/sh
# imsynth evaluate end to end on tiny data: a draft training set and model, a test set of
# one sample with an augmented (flash, rotated) view, one hand-made material made with our
# renderer (render, shifted, flash). The report folder is complete; every input has every
# method with finite distances; a -topk method is never farther than its first candidate
# under the training descriptor (it picks by it, over the same renders); the mean method's
# R^2 is 0 (R^2 is taken about the training mean); the same report for 1 and 2 threads;
# errors are clear and leave no folder behind. Usage: evaluate.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"

"$imsynth" evaluate --help > "$tmp/out"; check "evaluate --help" 0 $?
expect_stdout "help documents the Gram distance" "||a_l - b_l||"
"$imsynth" evaluate --model m -o r 2> "$tmp/err"; check "no inputs" 2 $?
"$imsynth" evaluate --model m --test t -o r --top-k 0 2> "$tmp/err"; check "bad --top-k" 2 $?
"$imsynth" evaluate --model m --test t -o r --preset fast 2> "$tmp/err"; check "bad --preset" 2 $?
expect_stderr "preset message lists the presets" "draft, datagen, converged"
"$imsynth" evaluate --model m --test t -o r --refine-preset fast 2> "$tmp/err"
check "bad --refine-preset" 2 $?
expect_stderr "refine preset message lists the presets" "draft, datagen, converged"

# Quick runs (the sanitizer's) take 2 inputs: the plain view and a hand-made material
# without flash, and no 1-thread run; the full run takes 4 (an augmented view, a flash one).
quick=${IMSYNTH_TEST_QUICK:-}
augment="--augment views=1,flash=1,rotate=45"; [ -n "$quick" ] && augment=""
n_train=8 comps=4; [ -n "$quick" ] && n_train=5 comps=2
"$imsynth" datagen --out "$tmp/train.sqlite" --count $n_train --preset draft --quiet
check "a draft training set" 0 $?
"$imsynth" datagen --out "$tmp/test.sqlite" --count 1 --first-id 1000000 --preset draft \
    $augment --quiet
check "a test set of one sample" 0 $?
"$imsynth" fit-predictor --dataset "$tmp/train.sqlite" --components $comps --hidden 8 --epochs 2 \
    --batch 4 --val-fraction 0.25 --quiet -o "$tmp/model"
check "a tiny model" 0 $?

# A "hand-made" material: our own renders stand in for Cycles' here.
hm="$tmp/hm/marble"
mkdir -p "$hm"
sed 's/"faces"/"transform": {"location": [0.3, 0.2, 0], "rotation_euler": [0, 0, 0]}, "faces"/' \
    "$root/assets/scene.json" > "$tmp/scene-shifted.json"
r="--spp 1 --max-spp 0 --threads 2"
"$imsynth" render "$root/assets/examples/marble.json" $r -o "$hm/render.exr" > /dev/null &&
    "$imsynth" render "$root/assets/examples/marble.json" $r --scene "$tmp/scene-shifted.json" \
        -o "$hm/shifted.exr" > /dev/null &&
    { [ -n "$quick" ] || "$imsynth" render "$root/assets/examples/marble.json" $r \
        --scene "$root/assets/scene-flash.json" -o "$hm/flash.exr" > /dev/null; }
check "hand-made renders" 0 $?
n_inputs=4; [ -n "$quick" ] && n_inputs=2
cmp -s "$hm/render.exr" "$hm/shifted.exr" && { echo "FAIL: the shifted scene moved nothing"; failures=$((failures + 1)); }

# Every -refine row ends no worse than its start under predict's loss (G + 4 C, raw, C the
# column of the colour term it minimised: colour-sorted by default, colour for blocks), and
# it spent the 4 renders of --refine. Recomputed from inputs.csv: $1 the file, $2 the column.
refine_never_worse() {
    awk -F, -v col="$2" '$4 == "mobilenetv2" { g[$2 "/" $3] = $5; if ($3 ~ /refine/) n[$2 "/" $3] = $8 }
        $4 == col { c[$2 "/" $3] = $5 }
        END { for (k in n) { split(k, a, "/"); start = a[1] "/" a[2]; sub(/-refine/, "-topk", start)
                l = g[k] + 4 * c[k]; l0 = g[start] + 4 * c[start]
                if (!(l <= l0 * (1 + 1e-9)) || n[k] != 4 || c[k] == "") { print k, l, l0, n[k]; bad = 1 } }
              exit bad }' "$1"
}
ev="--model $tmp/model --test $tmp/test.sqlite --handmade $tmp/hm --top-k 2 --preset draft --refine 4"
"$imsynth" evaluate $ev --threads 2 -o "$tmp/r2/" > "$tmp/out" 2> "$tmp/err"
check "evaluate, 2 threads" 0 $?
expect_stderr "progress with an ETA" "ETA"
for f in report.json summary.csv summary.md inputs.csv sheet-synthetic.png sheet-handmade.png \
    index.html timings.json; do
    [ -s "$tmp/r2/$f" ] || { echo "FAIL: the report lacks $f"; failures=$((failures + 1)); }
done
ls "$tmp" | grep -q '\.tmp\.' && { echo "FAIL: a temporary folder left behind"; failures=$((failures + 1)); }
grep -q 'sheet-handmade.png' "$tmp/r2/index.html" && grep -q '<table>' "$tmp/r2/index.html"
check "index.html shows tables and sheets" 0 $?

# inputs.csv: the inputs (plain, augmented, hand-made, hand-made flash) x 8 methods x 4
# distances, all finite and positive.
csv="$tmp/r2/inputs.csv"
rows=$(($(wc -l < "$csv") - 1))
[ "$rows" = $((n_inputs * 32)) ] && echo "ok: inputs.csv has $n_inputs x 8 x 4 rows" || { echo "FAIL: inputs.csv has $rows rows"; failures=$((failures + 1)); }
# The sorted colour distance is never above the box-by-box one (the same boxes, compared
# as distributions), nor is its floor.
awk -F, '$4 == "colour" { c[$1 $2 $3] = $5; f[$1 $2 $3] = $6 } $4 == "colour-sorted" { s[$1 $2 $3] = $5; t[$1 $2 $3] = $6 }
    END { for (k in c) if (!(k in s) || s[k] > c[k] * (1 + 1e-6) || t[k] > f[k] * (1 + 1e-6)) { print k, c[k], s[k]; bad = 1 }
          exit bad }' "$csv"
check "colour-sorted beside colour, never above it" 0 $?
sets="synthetic handmade"; [ -n "$quick" ] || sets="$sets synthetic-augmented handmade-flash"
for s in $sets; do
    grep -q "^$s," "$csv" || { echo "FAIL: no $s input"; failures=$((failures + 1)); }
done
awk -F, 'NR > 1 && !($5 > 0 && $6 > 0 && $7 > 0 && $7 < 1e6) { print; bad = 1 } END { exit bad }' "$csv"
check "every distance, floor and normalised distance finite and positive" 0 $?
# The training descriptor is MobileNetV2 (datagen's default): each -topk method is at most as
# far as its first candidate, and it had 2 candidates.
awk -F, '$4 == "mobilenetv2" { d[$2 "/" $3] = $7; if ($3 ~ /topk/) n[$2 "/" $3] = $8 }
    END { for (k in n) { split(k, a, "/"); base = a[2]; sub(/-topk/, "", base)
            if (!(d[k] <= d[a[1] "/" base]) || n[k] != 2) { print k, d[k], d[a[1] "/" base], n[k]; bad = 1 } }
          exit bad }' "$csv"
check "top-k picks by the training descriptor (never worse than its first)" 0 $?
refine_never_worse "$csv" colour-sorted
check "refinement never ends worse than its start (the default colour term, sorted)" 0 $?
grep -q '"colour_term":[[:space:]]*"sorted"' "$tmp/r2/report.json"
check "report.json names the colour term the -refine rows minimised" 0 $?
# The mean method's R^2 is 0 wherever defined: R^2 is taken about the training mean.
awk -F, '$2 == "mean" && $4 == "value" && $9 !~ /nan/ && $9 != 0 { print; bad = 1 } END { exit bad }' \
    "$tmp/r2/summary.csv"
check "the mean method's R^2 is 0" 0 $?
# A share of inputs comes with its 95% interval around it; other figures have none.
py -c "
import json, sys
r = json.load(open(sys.argv[1]))
shares = [t for t in r['targets'] if 'beats' in t['what']]
assert shares and all(t['interval95'][0] <= t['figure'] <= t['interval95'][1] for t in shares)
assert all('interval95' not in t for t in r['targets'] if 'R^2' in t['what'])
s = r['sets']['synthetic']['image_space']['predictor']['vgg19']
assert s['beats_mean_interval95'][0] <= s['beats_mean'] <= s['beats_mean_interval95'][1]
" "$tmp/r2/report.json"
check "shares of inputs with their 95% intervals" 0 $?
grep -q '"sample_hypotheses":[[:space:]]*0.5' "$tmp/r2/report.json"
check "report.json names the hypotheses' temperature (predict's default, 0.5)" 0 $?
grep -q '"nearest_metric":[[:space:]]*"pca"' "$tmp/r2/report.json"
check "report.json names the retrieval's metric (evaluate's default, pca)" 0 $?
if [ -z "$quick" ]; then
    grep -q 'render.exr vs shifted.exr' "$tmp/r2/report.json"
    check "the flash input takes the plain pair's floor" 0 $?
    "$imsynth" evaluate $ev --threads 1 -o "$tmp/r1" > /dev/null 2>&1; check "evaluate, 1 thread" 0 $?
    for f in report.json summary.csv inputs.csv summary.md sheet-synthetic.png sheet-handmade.png; do
        cmp -s "$tmp/r1/$f" "$tmp/r2/$f" || { echo "FAIL: $f differs between 1 and 2 threads"; failures=$((failures + 1)); }
    done
    echo "ok: 1 and 2 threads compared"
    # --refine-preset: the refinement's renders only. Naming the evaluation's own preset
    # changes nothing; another changes at most the -refine rows, which still spend --refine.
    "$imsynth" evaluate $ev --refine-preset draft -o "$tmp/rs" > /dev/null 2>&1
    check "evaluate, --refine-preset as --preset" 0 $?
    cmp -s "$tmp/rs/inputs.csv" "$tmp/r2/inputs.csv"; check "the same rows" 0 $?
    grep -q '"refine_preset":[[:space:]]*"draft"' "$tmp/rs/report.json"; check "report.json names the refine preset" 0 $?
    "$imsynth" evaluate $ev --refine-preset datagen -o "$tmp/rd" > /dev/null 2>&1
    check "evaluate, --refine-preset datagen" 0 $?
    grep -v -e '-refine,' "$tmp/rd/inputs.csv" > "$tmp/rd.rest"; grep -v -e '-refine,' "$csv" > "$tmp/r2.rest"
    cmp -s "$tmp/rd.rest" "$tmp/r2.rest"; check "only the -refine rows depend on the refine preset" 0 $?
    awk -F, '$3 ~ /refine/ && $4 == "mobilenetv2" && $8 != 4 { print; bad = 1 } END { exit bad }' \
        "$tmp/rd/inputs.csv"
    check "a datagen search spends --refine renders" 0 $?
    # The loss options are predict's: only the -refine rows depend on them, and the
    # report names them
    "$imsynth" evaluate $ev --colour-phase 2 --colour-weight 0 --start-colour-weight 0 \
        -o "$tmp/rc" > /dev/null 2>&1
    check "evaluate, --colour-phase 2 --colour-weight 0 --start-colour-weight 0" 0 $?
    grep -v -e '-refine,' "$tmp/rc/inputs.csv" > "$tmp/rc.rest"
    cmp -s "$tmp/rc.rest" "$tmp/r2.rest"; check "only the -refine rows depend on the loss options" 0 $?
    grep -q '"colour_phase":[[:space:]]*2' "$tmp/rc/report.json" &&
        grep -q '"colour_weight":[[:space:]]*0' "$tmp/rc/report.json" &&
        grep -q '"start_colour_weight":[[:space:]]*0' "$tmp/rc/report.json"
    check "report.json names the loss options" 0 $?
    # A -refine row starts from the candidate predict would pick, by G + w C (w =
    # --start-colour-weight): with w = 0 that is the -topk row's pick (by G), and it is
    # always one of the -topk candidates.
    start_check='
import json, sys
r = json.load(open(sys.argv[1]))
same = sys.argv[2] == "same"
for i in r["inputs"]:
    m = i["methods"]
    for t in ("nearest", "predictor"):
        start, pick = m[t + "-refine"]["start"], m[t + "-topk"]
        assert 0 <= start < pick["candidates"], (i, t)
        assert not same or start == pick["chosen"], (i, t, start, pick["chosen"])
'
    py -c "$start_check" "$tmp/rc/report.json" same
    check "with start colour weight 0 the refinement starts from the -topk pick" 0 $?
    py -c "$start_check" "$tmp/r2/report.json" any
    check "the refinement starts from a -topk candidate" 0 $?
    # --colour-term blocks: only the -refine rows move, and they minimise the box-by-box column
    "$imsynth" evaluate $ev --colour-term blocks -o "$tmp/rb" > /dev/null 2>&1
    check "evaluate, --colour-term blocks" 0 $?
    grep -v -e '-refine,' "$tmp/rb/inputs.csv" > "$tmp/rb.rest"
    cmp -s "$tmp/rb.rest" "$tmp/r2.rest"; check "only the -refine rows depend on --colour-term" 0 $?
    refine_never_worse "$tmp/rb/inputs.csv" colour
    check "refinement never ends worse than its start (--colour-term blocks)" 0 $?
    grep -q '"colour_term":[[:space:]]*"blocks"' "$tmp/rb/report.json"
    check "report.json names --colour-term blocks" 0 $?
    # --starts: the -refine rows race their -topk method's best picks, within --refine
    "$imsynth" evaluate $ev --starts 2 -o "$tmp/rk" > /dev/null 2>&1
    check "evaluate, --starts 2" 0 $?
    grep -v -e '-refine,' "$tmp/rk/inputs.csv" > "$tmp/rk.rest"
    cmp -s "$tmp/rk.rest" "$tmp/r2.rest"; check "only the -refine rows depend on --starts" 0 $?
    awk -F, '$3 ~ /refine/ && $4 == "mobilenetv2" && $8 != 4 { print; bad = 1 } END { exit bad }' \
        "$tmp/rk/inputs.csv"
    check "a race spends --refine renders in all" 0 $?
    grep -q '"starts":[[:space:]]*2' "$tmp/rk/report.json"; check "report.json names --starts" 0 $?
fi
"$imsynth" evaluate $ev --colour-weight -1 -o "$tmp/rw" 2> "$tmp/err"
check "bad --colour-weight" 2 $?
expect_stderr "message names the option" "colour-weight"

# Errors: clear, naming the culprit, and no report folder (nor temporary) left.
"$imsynth" evaluate --model "$tmp/no-model" --test "$tmp/test.sqlite" -o "$tmp/rx" 2> "$tmp/err"
check "missing model" 1 $?
expect_stderr "message names the model" "no-model"
"$imsynth" evaluate $ev -o "$tmp/r2" 2> "$tmp/err"; check "existing report folder" 1 $?
expect_stderr "message says it exists" "already exists"
"$imsynth" evaluate --model "$tmp/model" --test "$tmp/train.sqlite" -o "$tmp/ry" 2> "$tmp/err"
check "a test set overlapping the training set" 1 $?
expect_stderr "message says overlap" "overlap the model's catalogue"
mkdir -p "$tmp/hm2/x" && cp "$hm/render.exr" "$tmp/hm2/x/"
"$imsynth" evaluate --model "$tmp/model" --handmade "$tmp/hm2" -o "$tmp/rz" 2> "$tmp/err"
check "a hand-made material without shifted.exr" 1 $?
expect_stderr "message names the missing file" "x/shifted.exr"
for d in rx ry rz; do
    [ -e "$tmp/$d" ] && { echo "FAIL: $d left by a failed run"; failures=$((failures + 1)); }
done
ls "$tmp" | grep -q '\.tmp\.' && { echo "FAIL: a temporary folder left behind"; failures=$((failures + 1)); }
finish
