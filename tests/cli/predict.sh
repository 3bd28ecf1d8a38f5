#!/bin/sh
# imsynth predict end to end with a small model: OUTDIR holds every file; material.json is
# the sub-shader of params.json (imsynth extract gives the same bytes); the report's curve
# never rises and the refinement never ends worse than its start; a rerun replaces an
# earlier output, a foreign folder is refused; bad inputs (truncated, 1x1, NaN-filled,
# missing model) are clear errors naming the file, with nothing left behind. Thread counts:
# tests/cli/threads.sh.
# Usage: predict.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"

"$imsynth" datagen --out "$tmp/ds.sqlite" --count 24 --preset draft --quiet
check "a draft dataset" 0 $?
"$imsynth" fit-predictor --dataset "$tmp/ds.sqlite" --components 8 --hidden 16 --batch 8 \
    --val-fraction 0.2 --epochs 3 --quiet -o "$tmp/model"
check "a small model" 0 $?

input="$root/tests/handmade/brick_wall/render.exr"
fast="--model $tmp/model --top-k 2 --nearest 2 --refine 6 --search-preset draft --final-preset draft --quiet"
"$imsynth" predict "$input" -o "$tmp/out1" $fast --threads 1 2> "$tmp/err"
check "predict, 1 thread" 0 $?
grep -q "warning" "$tmp/err" && { echo "FAIL: a warning with the model's own super-shader"; failures=$((failures + 1)); }
py -c "import json,sys; assert json.load(open(sys.argv[1]))['warnings'] == []" "$tmp/out1/report.json"
check "report: no warnings with the model's own super-shader" 0 $?
for f in material.json params.json preview.png compare.png report.json; do
    [ -s "$tmp/out1/$f" ] || { echo "FAIL: OUTDIR lacks $f"; failures=$((failures + 1)); }
done
ls -d "$tmp"/out1.* 2> /dev/null && { echo "FAIL: temporary folders left"; failures=$((failures + 1)); }

turn=$(py -c "import json,sys; print(json.load(open(sys.argv[1]))['texture_rotation'])" "$tmp/out1/report.json")
"$imsynth" extract --params "$tmp/out1/params.json" --texture-rotation "$turn" -o "$tmp/sub.json"
cmp -s "$tmp/sub.json" "$tmp/out1/material.json"
check "material.json is the sub-shader of params.json, turned as report.json says" 0 $?

py - "$tmp/out1/report.json" << 'PY'
import json, sys
r = json.load(open(sys.argv[1]))
assert r["format"] == "imsynth-predict/1", r["format"]
ref = r["refinement"]
c = ref["curve"]
assert len(c) == ref["evaluations"] == ref["budget"] == 6, ref
assert all(b <= a for a, b in zip(c, c[1:])), c
assert c[0] == ref["start_loss"] and c[-1] == ref["best_loss"] <= ref["start_loss"], ref
assert 1 <= len(r["candidates"]) <= 8 and r["final"]["material_nodes"] > 0
assert r["renders_by_stage"]["candidates"] == 2 * len(r["candidates"]) and r["renders"] >= 2
# rotation auto (the default, margin 1): each turn's own candidates, 2 + 2 at most
assert r["rotation_asked"] == "auto" and r["texture_rotation"] in (0, 90), r["texture_rotation"]
assert r["rotation_margin"] == 1, r["rotation_margin"]
for t in (0, 90):
    n = sum(c["texture_rotation"] == t for c in r["candidates"])
    assert 1 <= n <= 4, (t, n)
PY
check "report: the curve never rises" 0 $?
# The default light is auto: every candidate scored in both scenes, the scene the one of
# the least loss of all (candidate, scene) pairs of the rotation (the turned one when its
# least loss is below rotation_margin x the unturned one's); the start the candidate of
# that rotation best there by G + start_colour_weight C (ties: the earlier), refined in
# that scene.
start_check='
import json, sys
r = json.load(open(sys.argv[1]))
w = r["loss"]["start_colour_weight"]
assert w == float(sys.argv[2]), w
assert r["light_asked"] == "auto" and r["light"] in ("scene", "flash"), r["light"]
pairs = [(x[s]["loss"], s, x["texture_rotation"]) for x in r["candidates"] for s in ("scene", "flash")]
least = {t: min(p for p in pairs if p[2] == t) for t in {p[2] for p in pairs}}
turn = 90 if 90 in least and (0 not in least or least[90][0] < r["rotation_margin"] * least[0][0]) else 0
assert least[turn][1:] == (r["light"], r["texture_rotation"]), (least, r["rotation_margin"])
cands = [x for x in r["candidates"] if x["texture_rotation"] == r["texture_rotation"]]
assert not [x for x in r["candidates"] if x["chosen"] and x not in cands]
key = [x[r["light"]]["gram"] + w * x[r["light"]]["colour"] for x in cands]
chosen = [j for j, x in enumerate(cands) if x["chosen"]]
assert chosen == [key.index(min(key))], (chosen, key)
assert abs(cands[chosen[0]][r["light"]]["loss"] - r["refinement"]["start_loss"]) < 1e-12
'
py -c "$start_check" "$tmp/out1/report.json" 4
check "report: the scene of the best loss, the start the best by G + 4 C there" 0 $?
# On the marble the two rankings differ under the box-by-box colour term (G alone: the
# fourth candidate; G + 4 C: the second; of the unturned candidates; under the sorted term
# they agree), so the check tells a weight that is honoured from one that is not.
marble="$root/tests/handmade/marble/render.exr"
"$imsynth" predict "$marble" -o "$tmp/sw0" $fast --refine 1 --start-colour-weight 0 --rotation 0 \
    --colour-term blocks
check "predict --start-colour-weight 0" 0 $?
py -c "$start_check" "$tmp/sw0/report.json" 0
check "--start-colour-weight 0: the start the best by G alone" 0 $?
py -c "
import json, sys
r = json.load(open(sys.argv[1])); s = r['light']
cands = [x for x in r['candidates'] if x['texture_rotation'] == r['texture_rotation']]
l = [x[s]['gram'] + 4 * x[s]['colour'] for x in cands]
assert not cands[l.index(min(l))]['chosen'], 'the rankings agree: no test'
" "$tmp/sw0/report.json"
check "--start-colour-weight 0 starts elsewhere than G + 4 C would on the marble" 0 $?
"$imsynth" predict "$input" -o "$tmp/sw0" $fast --start-colour-weight -1 2> "$tmp/err"
check "bad --start-colour-weight" 2 $?

# --light scene fixes the scene: the candidates are rendered in it alone
"$imsynth" predict "$input" -o "$tmp/scene" $fast --refine 2 --light scene
check "predict --light scene" 0 $?
py - "$tmp/scene/report.json" << 'PY'
import json, sys
r = json.load(open(sys.argv[1]))
assert r["light_asked"] == "scene" and r["light"] == "scene", r["light"]
assert all("flash" not in c for c in r["candidates"]), r["candidates"]
chosen = [c for c in r["candidates"] if c["chosen"]][0]
own = [c for c in r["candidates"] if c["texture_rotation"] == chosen["texture_rotation"]]
assert min(c["scene"]["loss"] for c in own) == chosen["scene"]["loss"]
assert chosen["scene"]["loss"] == r["refinement"]["start_loss"]
assert r["renders_by_stage"]["candidates"] == len(r["candidates"])
PY
check "--light scene: one scene scored, the least loss (of the rotation kept) wins" 0 $?

# --rotation 0 / 90: one way's candidates only; 90 turns the material (a Mapping node in
# material.json, label "Texture Rotation"), 0 leaves it as the super-shader makes it
for turn in 0 90; do
    "$imsynth" predict "$input" -o "$tmp/turn$turn" $fast --refine 2 --light scene --rotation $turn
    check "predict --rotation $turn" 0 $?
done
py - "$tmp/turn0" "$tmp/turn90" << 'PY'
import json, sys
for d, t in zip(sys.argv[1:3], (0, 90)):
    r = json.load(open(d + "/report.json"))
    assert r["rotation_asked"] == str(t) and r["texture_rotation"] == t, r["texture_rotation"]
    assert all(c["texture_rotation"] == t for c in r["candidates"]), r["candidates"]
    m = json.load(open(d + "/material.json"))
    maps = [n for n in m["nodes"] if n["type"] == "ShaderNodeMapping"]
    if t == 0:
        assert not maps, maps
    else:  # the brick wall's material reads coordinates: the turn is in it
        assert len(maps) == 1 and maps[0]["label"] == "Texture Rotation", maps
        assert abs(maps[0]["inputs"]["Rotation"][2] - 1.5707963) < 1e-6, maps[0]
PY
check "--rotation 0 / 90: one way's candidates, the turn in material.json" 0 $?
# --colour-term blocks: the same candidates rendered alike (G the same), each one's C the
# box-by-box term, never below the default sorted term (evaluate_colour_sorted_distance)
"$imsynth" predict "$input" -o "$tmp/blocks" $fast --refine 2 --light scene --rotation 0 \
    --colour-term blocks
check "predict --colour-term blocks" 0 $?
py - "$tmp/blocks/report.json" "$tmp/turn0/report.json" << 'PY'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
assert a["loss"]["colour_term"] == "blocks" and b["loss"]["colour_term"] == "sorted", b["loss"]
assert len(a["candidates"]) == len(b["candidates"])
lower = 0
for x, y in zip(a["candidates"], b["candidates"]):
    assert (x.get("id"), x.get("rank")) == (y.get("id"), y.get("rank")), (x, y)
    assert x["scene"]["gram"] == y["scene"]["gram"], (x, y)
    assert y["scene"]["colour"] <= x["scene"]["colour"] + 1e-12, (x, y)
    lower += y["scene"]["colour"] < x["scene"]["colour"]
assert lower > 0, "the two terms agree on every candidate: no test"
PY
check "--colour-term blocks: same candidates and G, C never below the sorted term" 0 $?
"$imsynth" predict "$input" -o "$tmp/sorted" $fast --colour-term sideways 2> "$tmp/err"
check "bad --colour-term" 2 $?
grep -q "blocks or sorted" "$tmp/err"
check "bad --colour-term names the choices" 0 $?
"$imsynth" extract --params "$tmp/turn90/params.json" --texture-rotation 90 -o "$tmp/sub90.json"
cmp -s "$tmp/sub90.json" "$tmp/turn90/material.json"
check "--rotation 90: material.json is params.json's sub-shader turned 90" 0 $?
# --rotation-margin M: with auto, the turned candidates win only below M x the unturned
# ones' least loss: 0 never, 10 always (on this input); both sets are scored either way
for m in 0 10; do
    "$imsynth" predict "$input" -o "$tmp/margin$m" $fast --refine 1 --light scene --rotation-margin $m
    check "predict --rotation-margin $m" 0 $?
done
py - "$tmp/margin0/report.json" "$tmp/margin10/report.json" << 'PY'
import json, sys
for f, m, t in zip(sys.argv[1:3], (0, 10), (0, 90)):
    r = json.load(open(f))
    assert r["rotation_margin"] == m and r["texture_rotation"] == t, (m, r["texture_rotation"])
    cands = r["candidates"]
    assert {c["texture_rotation"] for c in cands} == {0, 90}, cands
    own = [c["scene"]["loss"] for c in cands if c["texture_rotation"] == t]
    chosen = [c for c in cands if c["chosen"]]
    assert len(chosen) == 1 and chosen[0]["texture_rotation"] == t, chosen
    assert chosen[0]["scene"]["loss"] == min(own) == r["refinement"]["start_loss"], (chosen, own)
PY
check "--rotation-margin: 0 keeps the unturned, 10 takes the turned" 0 $?
"$imsynth" predict "$input" -o "$tmp/rq" $fast --rotation-margin -1 2> "$tmp/err"
check "bad --rotation-margin" 2 $?
"$imsynth" predict "$input" -o "$tmp/rq" $fast --rotation 45 2> "$tmp/err"
check "bad --rotation" 2 $?
expect_stderr "bad --rotation: says what is expected" '"45" is not 0, 90 or auto'

# --refine-preset apart from --search-preset: the start is rendered again at it (the
# cache key holds the preset), so the curve starts from its loss there, not the candidate's
"$imsynth" predict "$input" -o "$tmp/rp" --model "$tmp/model" --top-k 2 --nearest 2 --refine 2 \
    --search-preset datagen --refine-preset draft --final-preset draft --light scene --quiet
check "predict --refine-preset apart" 0 $?
py - "$tmp/rp/report.json" << 'PY'
import json, sys
r = json.load(open(sys.argv[1]))
assert r["loss"]["search_preset"] == "datagen" and r["loss"]["refine_preset"] == "draft", r["loss"]
chosen = [c for c in r["candidates"] if c["chosen"]][0]
assert chosen["scene"]["loss"] != r["refinement"]["start_loss"], (chosen, r["refinement"])
assert r["renders_by_stage"]["refine"] >= 1, r["renders_by_stage"]
PY
check "the refinement's start scored at the refine preset" 0 $?
# By default the candidates are scored at the refine preset (draft): the refinement starts
# from the winner's own render, so its curve starts at the winner's loss, one render saved.
"$imsynth" predict "$input" -o "$tmp/rd" --model "$tmp/model" --top-k 2 --nearest 2 --refine 2 \
    --final-preset draft --light scene --quiet
check "predict with the default search preset" 0 $?
py - "$tmp/rd/report.json" << 'PY'
import json, sys
r = json.load(open(sys.argv[1]))
assert r["loss"]["search_preset"] == "draft" == r["loss"]["refine_preset"], r["loss"]
chosen = [c for c in r["candidates"] if c["chosen"]][0]
assert chosen["scene"]["loss"] == r["refinement"]["start_loss"], (chosen, r["refinement"])
assert r["renders_by_stage"]["refine"] == 1, r["renders_by_stage"]
PY
check "default: candidates at draft, the refinement starts from the winner's render" 0 $?
# The same graph with one more byte is another file to the model's hash: predict still
# runs, but says so on stderr (with --quiet too) and in report.json (out1, made with the
# model's own super-shader, has no warning).
{ cat "$root/assets/supershader.json"; echo; } > "$tmp/other-supershader.json"
"$imsynth" predict "$input" -o "$tmp/ow" $fast --refine 1 --light scene --rotation 0 \
    --graph "$tmp/other-supershader.json" 2> "$tmp/err"
check "predict with another super-shader than the model's" 0 $?
expect_stderr "the warning names the graph and the model" \
    "warning: $tmp/other-supershader.json (sha256 [0-9a-f]*) is not the super-shader the model $tmp/model was trained on"
py - "$tmp/ow/report.json" << 'PY'
import hashlib, json, sys
r = json.load(open(sys.argv[1]))
assert len(r["warnings"]) == 1 and "is not the super-shader" in r["warnings"][0], r["warnings"]
assert r["supershader_sha256"] == hashlib.sha256(open(r["supershader"], "rb").read()).hexdigest()
PY
check "report: the warning and the graph's sha256" 0 $?
"$imsynth" predict "$input" -o "$tmp/rq" $fast --refine-preset fast 2> "$tmp/err"
check "bad --refine-preset" 2 $?
"$imsynth" predict "$input" -o "$tmp/rq" $fast --method cma 2> "$tmp/err"
check "bad --method" 2 $?
grep -q 'expected one of coordinate, .*coordinate-sweep.*, got "cma"' "$tmp/err"
check "bad --method: the message lists the methods" 0 $?
"$imsynth" predict "$input" -o "$tmp/rq" $fast --nearest-metric cosine 2> "$tmp/err"
check "bad --nearest-metric" 2 $?
expect_stderr "bad --nearest-metric: says what is expected" 'expected pca or whitened, got "cosine"'

# --colour-phase: the first N evaluations weigh the colour term --colour-phase-weight (12):
# the curve starts from the start's terms under 12, start_loss and best_loss are under 4
"$imsynth" predict "$input" -o "$tmp/cp" $fast --light scene --colour-phase 3
check "predict --colour-phase 3" 0 $?
py - "$tmp/cp/report.json" << 'PY'
import json, sys
r = json.load(open(sys.argv[1]))
ref, loss = r["refinement"], r["loss"]
assert loss["colour_phase"] == 3 and loss["colour_phase_weight"] == 12 and loss["colour_weight"] == 4, loss
chosen = [c for c in r["candidates"] if c["chosen"]][0]["scene"]
assert abs(ref["curve"][0] - (chosen["gram"] + 12 * chosen["colour"])) < 1e-12, (ref, chosen)
assert abs(ref["start_loss"] - (chosen["gram"] + 4 * chosen["colour"])) < 1e-12, (ref, chosen)
c = ref["curve"]
assert len(c) == 6 and all(b <= a for a, b in zip(c, c[1:])), c
assert c[-1] == ref["best_loss"] <= ref["start_loss"], ref
PY
check "the colour phase: the curve under 12 first, the losses reported under 4" 0 $?
"$imsynth" predict "$input" -o "$tmp/rq" $fast --colour-phase -1 2> "$tmp/err"
check "bad --colour-phase" 2 $?

# --sample-hypotheses T: the predictor's candidates are its likeliest combination and drawn
# ones: the same first one as the beam's, and less probable others; report.json says so
# (the default, T = 0.5) against the beam (--sample-hypotheses 0)
"$imsynth" predict "$input" -o "$tmp/sb" $fast --light scene --nearest 0 --top-k 3 --refine 1 \
    --sample-hypotheses 0 --nearest-metric pca --rotation 0 &&
    "$imsynth" predict "$input" -o "$tmp/ss" $fast --light scene --nearest 0 --top-k 3 --refine 1 \
    --rotation 0
check "predict --sample-hypotheses 0, and the default" 0 $?
py - "$tmp/sb/report.json" "$tmp/ss/report.json" << 'PY'
import json, sys
b, s = (json.load(open(f)) for f in sys.argv[1:3])
assert b["sample_hypotheses"] == 0 and s["sample_hypotheses"] == 0.5, (b, s)
assert b["nearest_metric"] == "pca" and s["nearest_metric"] == "whitened", (b, s)
pb = sorted((c["probability"] for c in b["candidates"]), reverse=True)
ps = sorted((c["probability"] for c in s["candidates"]), reverse=True)
assert len(pb) == len(ps) == 3 and ps[0] == pb[0], (pb, ps)
assert sum(ps) < sum(pb), (pb, ps)
PY
check "sampled candidates: the likeliest first, the others drawn" 0 $?

# --starts K: the K best scored candidates are raced (refine_race); the winner's search may
# come from any of them, the curve is the best over all, the budget theirs together
"$imsynth" predict "$input" -o "$tmp/st" $fast --light scene --refine 9 --starts 3
check "predict --starts 3" 0 $?
py - "$tmp/st/report.json" << 'PY'
import json, sys
r = json.load(open(sys.argv[1]))
ref = r["refinement"]
cands = [c for c in r["candidates"] if c["texture_rotation"] == r["texture_rotation"]]
assert not [c for c in r["candidates"] if c["refined"] and c not in cands]
k = min(3, len(cands))
assert ref["starts"] == k and ref["evaluations"] == 9, ref
raced = sorted(c["scene"]["loss"] for c in cands if c["refined"])
assert raced == sorted(c["scene"]["loss"] for c in cands)[:k], cands
chosen = [c for c in cands if c["chosen"]]
assert len(chosen) == 1 and chosen[0]["refined"], chosen
# search and refine preset are both draft here: the starts' losses are the candidates'
assert ref["start_loss"] == raced[0], (ref, raced)
c = ref["curve"]
assert all(b <= a for a, b in zip(c, c[1:])) and c[-1] == ref["best_loss"] <= ref["start_loss"], ref
assert 1 <= ref["winner_evaluations"] <= 9, ref
searches = [c["search"] for c in cands if c["refined"]]
assert sum(x["evaluations"] for x in searches) == 9, searches
assert chosen[0]["search"]["reached"] == min(x["reached"] for x in searches) == ref["best_loss"], searches
assert chosen[0]["search"]["evaluations"] == ref["winner_evaluations"], (chosen, ref)
PY
check "--starts: the best scored raced, the winner among them" 0 $?
"$imsynth" predict "$input" -o "$tmp/rq" $fast --starts 0 2> "$tmp/err"
check "bad --starts" 2 $?

# a rerun into an earlier output replaces it; a folder of other files is refused and kept.
# The rerun also removes what a killed run left (OUT.tmp.PID of a process that is gone),
# and keeps a live run's
dead=999999; while kill -0 $dead 2> /dev/null; do dead=$((dead + 1)); done
mkdir "$tmp/out1.tmp.$dead" "$tmp/out1.tmp.$$"
touch "$tmp/out1.tmp.$dead/preview.png" "$tmp/out1.tmp.$$/preview.png"
"$imsynth" predict "$input" -o "$tmp/out1" $fast --refine 1
check "rerun into an earlier output" 0 $?
[ ! -e "$tmp/out1.tmp.$dead" ] && [ -e "$tmp/out1.tmp.$$/preview.png" ]
check "a killed run's temporary folder removed, a live one's kept" 0 $?
rm -r "$tmp/out1.tmp.$$"
py -c "import json,sys; r=json.load(open(sys.argv[1])); assert r['refinement']['evaluations'] == 1" \
    "$tmp/out1/report.json"
check "the earlier output was replaced" 0 $?
mkdir "$tmp/foreign" && echo keep > "$tmp/foreign/notes.txt"
"$imsynth" predict "$input" -o "$tmp/foreign" $fast 2> "$tmp/err"
check "a foreign folder is refused" 1 $?
expect_stderr "the refusal names the folder" "foreign: exists and is not an earlier"
[ "$(cat "$tmp/foreign/notes.txt")" = keep ] && [ "$(ls "$tmp/foreign")" = notes.txt ]
check "the foreign folder is untouched" 0 $?

# bad inputs: clear errors naming the file; no OUTDIR, no temporary folder
head -c 300 "$root/tests/handmade/brick_wall/preview.png" > "$tmp/truncated.png"
py "$root/tests/cli/lib/make_images.py" png "$tmp/one.png" 1 1
py "$root/tests/cli/lib/make_images.py" nan-exr "$tmp/nan.exr" 40 40
for bad in truncated.png one.png nan.exr missing.png; do
    "$imsynth" predict "$tmp/$bad" -o "$tmp/bad" $fast 2> "$tmp/err"
    check "$bad is an error" 1 $?
    expect_stderr "$bad: the message names it" "$bad"
    ls -d "$tmp"/bad* 2> /dev/null && { echo "FAIL: $bad left an output"; failures=$((failures + 1)); }
    [ $bad = nan.exr ] && expect_stderr "NaN input: says what is wrong" "are NaN"
    [ $bad = one.png ] && expect_stderr "1x1 input: says what is wrong" "at least 32 x 32"
done
"$imsynth" predict "$input" -o "$tmp/bad" --model "$tmp/nomodel" --quiet 2> "$tmp/err"
check "a missing model is an error" 1 $?
expect_stderr "the message names the model" "nomodel"
# --blend: Blender missing is an error that keeps Blender's output and nothing else
IMSYNTH_BLENDER=/nonexistent "$imsynth" predict "$input" -o "$tmp/bl" $fast --blend 2> "$tmp/err"
check "--blend without Blender is an error" 1 $?
expect_stderr "says where Blender's output is" "bl.blender.log"
[ ! -e "$tmp/bl" ] && [ -s "$tmp/bl.blender.log" ] && ! ls -d "$tmp"/bl.tmp.* 2> /dev/null
check "--blend failure: no OUTDIR, the log kept" 0 $?
if command -v blender > /dev/null 2>&1; then
    "$imsynth" predict "$input" -o "$tmp/bl" $fast --blend
    check "--blend with Blender" 0 $?
    [ -s "$tmp/bl/material.blend" ]; check "material.blend written" 0 $?
else
    echo "skip: no blender on PATH (--blend with Blender untested here)"
fi
"$imsynth" predict "$input" -o "$tmp/bad" --light sideways 2> "$tmp/err"
check "a bad --light is a usage error" 2 $?
finish
