#!/bin/sh
# imsynth fit-predictor and predict-params end to end on a small draft dataset: the model
# directory is complete (thread counts: tests/cli/threads.sh); kill -9 at random moments and
# resume equals an uninterrupted run; SIGINT stops resumably; predictions are valid
# parameter files, hypotheses ordered by probability, retrieval ordered by distance; bad
# models and outputs are clear errors that leave nothing behind.
# Usage: predictor.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
quick=${IMSYNTH_TEST_QUICK:-}
# killed_and_resumed DONE NEW OPTION: a 3-epoch fit with OPTION into $tmp/NEW, killed
# after 0.7 s and rerun; true when its network is $tmp/DONE's (the uninterrupted run's)
killed_and_resumed() {
    "$imsynth" fit-predictor $fit --epochs 3 "$3" --threads 2 -o "$tmp/$2" &
    pid=$!; sleep 0.7; kill -9 $pid 2> /dev/null; wait $pid 2> /dev/null
    [ -d "$tmp/$2" ] || "$imsynth" fit-predictor $fit --epochs 3 "$3" --threads 2 -o "$tmp/$2"
    cmp -s "$tmp/$1/network.safetensors" "$tmp/$2/network.safetensors"
}
# lying_model GOOD BAD STATEMENT: $tmp/BAD = a copy of model $tmp/GOOD whose model.json has
# had the Python STATEMENT applied to it (as m); predict-params with it, stderr in $tmp/err
lying_model() {
    cp -r "$tmp/$1" "$tmp/$2"
    py -c "
import json
m = json.load(open('$tmp/$2/model.json')); $3
json.dump(m, open('$tmp/$2/model.json', 'w'))
"
    "$imsynth" predict-params "$img" --model "$tmp/$2" 2> "$tmp/err"
}

n=32; [ -n "$quick" ] && n=24
"$imsynth" datagen --out "$tmp/ds.sqlite" --count $n --preset draft --quiet
check "a draft dataset of $n samples" 0 $?
fit="--dataset $tmp/ds.sqlite --components 8 --hidden 16 --batch 8 --val-fraction 0.2 --quiet"

"$imsynth" fit-predictor $fit --epochs 6 --threads 1 -o "$tmp/m1"; check "fit, 1 thread" 0 $?
for f in model.json transform.safetensors network.safetensors catalogue.safetensors \
    losses.csv loss.svg; do
    [ -s "$tmp/m1/$f" ] || { echo "FAIL: model lacks $f"; failures=$((failures + 1)); }
done
[ ! -e "$tmp/m1.partial" ] || { echo "FAIL: m1.partial left behind"; failures=$((failures + 1)); }
[ ! -e "$tmp/m1/checkpoint.safetensors" ] || { echo "FAIL: run files left in the model"; failures=$((failures + 1)); }
lines=$(wc -l < "$tmp/m1/losses.csv")
[ "$lines" = 7 ] && echo "ok: losses.csv has a row per epoch" || { echo "FAIL: losses.csv has $lines lines"; failures=$((failures + 1)); }
# the training loss falls (a network that learns nothing would not fit even its training
# set). Without dropout: with the default 0.5 on a 16-wide layer and 3 batches an epoch the
# per-epoch training loss is a noisy sample of the objective, which rose from epoch 1 to 6
# on session 32's graph while the validation loss fell at every epoch.
"$imsynth" fit-predictor $fit --epochs 6 --threads 1 --dropout 0 -o "$tmp/m0"
awk -F, 'NR == 2 { a = $2 } END { if (!($2 < a)) exit 1 }' "$tmp/m0/losses.csv"
check "training loss falls over the epochs" 0 $?

# kill -9 at random moments, then the same command: the model of an uninterrupted run.
kills=5; [ -n "$quick" ] && kills=3
i=0
moments=""
while [ $i -lt $kills ]; do
    "$imsynth" fit-predictor $fit --epochs 6 --threads 2 -o "$tmp/mk" &
    pid=$!
    t=$(awk -v s=$i 'BEGIN { srand(s + 3); printf "%.2f", rand() * 1.2 }')
    moments="$moments $t"
    sleep "$t"
    kill -9 $pid 2> /dev/null
    wait $pid 2> /dev/null
    [ -d "$tmp/mk" ] && break # finished before the kill
    i=$((i + 1))
done
echo "killed at:$moments s"
[ -d "$tmp/mk" ] || "$imsynth" fit-predictor $fit --epochs 6 --threads 2 -o "$tmp/mk"
check "resume after kills" 0 $?
cmp -s "$tmp/m1/network.safetensors" "$tmp/mk/network.safetensors"
check "killed and resumed equals uninterrupted" 0 $?

# a partial run with other settings is refused, and kept, unless --restart
mkdir -p "$tmp/mo.partial"
echo '{"settings": {"other": 1}, "epochs_done": 0, "best_epoch": 0, "best_val_loss": 1, "history": []}' > "$tmp/mo.partial/state.json"
"$imsynth" fit-predictor $fit --epochs 2 -o "$tmp/mo" 2> "$tmp/err"
check "another run's partial directory is refused" 1 $?
expect_stderr "says how to go on" "restart"
"$imsynth" fit-predictor $fit --epochs 2 --restart -o "$tmp/mo"; check "--restart discards it" 0 $?
"$imsynth" fit-predictor $fit --epochs 2 -o "$tmp/m1" 2> "$tmp/err"
check "an existing model directory is not overwritten" 1 $?
expect_stderr "names it" "m1: exists"

# two runs on one output: the second is refused while the first holds the run's lock
"$imsynth" fit-predictor $fit --epochs 5000 -o "$tmp/ml" &
pid=$!
i=0
while [ ! -e "$tmp/ml.partial/state.json" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
"$imsynth" fit-predictor $fit --epochs 5000 -o "$tmp/ml" 2> "$tmp/err"
check "a second run on the same output is refused" 1 $?
expect_stderr "says why" "another imsynth fit-predictor is writing this run"
kill -9 $pid 2> /dev/null
wait $pid 2> /dev/null

# predictions
img="$root/tests/reference/render/supershader_s1/blender-4.3-a.exr"
"$imsynth" predict-params "$img" --model "$tmp/m1" -o "$tmp/p.json" --top-k 5 \
    --sample-hypotheses 0 --hypotheses "$tmp/h.json" --nearest 4
check "predict-params" 0 $?
"$imsynth" render "$root/assets/supershader.json" --params "$tmp/p.json" --spp 1 -o "$tmp/p.exr" > /dev/null 2>&1
check "the prediction is a parameter file render takes" 0 $?
py -c "
import json, sys
p = json.load(open('$tmp/p.json')); h = json.load(open('$tmp/h.json'))
assert len(p) == 50 and all(0 <= v <= 1 for v in p.values()), p
hyp = h['hypotheses']; pr = [x['probability'] for x in hyp]
assert len(hyp) == 5 and pr == sorted(pr, reverse=True) and 0 < sum(pr) <= 1 + 1e-9, pr
assert hyp[0]['params'] == p
sel = [k for k in p if k.startswith('Mult ')]
combos = {tuple(x['params'][k] for k in sel) for x in hyp}
assert len(combos) == 5, 'hypotheses must differ in their selectors'
vals = [k for k in p if not k.startswith('Mult ')]
assert all(x['params'][k] == p[k] for x in hyp for k in vals)
nd = [x['distance'] for x in h['nearest']]
assert len(nd) == 4 and nd == sorted(nd) and len({x['id'] for x in h['nearest']}) == 4, nd
print('hypotheses', pr)
"
check "hypotheses: ordered, distinct, same values; nearest: ordered, distinct" 0 $?

# --sample-hypotheses: the likeliest combination first (the beam's answer), then distinct
# drawn ones, most probable first; the same image gives the same draws
"$imsynth" predict-params "$img" --model "$tmp/m1" --top-k 6 --sample-hypotheses 0.5 \
    --hypotheses "$tmp/hs1.json" -o "$tmp/ps1.json" &&
    "$imsynth" predict-params "$img" --model "$tmp/m1" --top-k 6 --sample-hypotheses 0.5 \
        --hypotheses "$tmp/hs2.json" -o "$tmp/ps2.json"
check "predict-params --sample-hypotheses" 0 $?
cmp -s "$tmp/hs1.json" "$tmp/hs2.json"
check "sampled hypotheses: the same draws on a rerun" 0 $?
py -c "
import json
p = json.load(open('$tmp/p.json')); hyp = json.load(open('$tmp/hs1.json'))['hypotheses']
beam = json.load(open('$tmp/h.json'))['hypotheses']
assert json.load(open('$tmp/ps1.json')) == p and hyp[0]['params'] == p
pr = [x['probability'] for x in hyp]
assert len(hyp) == 6 and pr == sorted(pr, reverse=True), pr
sel = [k for k in p if k.startswith('Mult ')]
combos = [tuple(x['params'][k] for k in sel) for x in hyp]
assert len(set(combos)) == 6
# the beam's 5 are the 5 likeliest: a drawn set is no likelier, and differs from it
assert sum(pr[:5]) <= sum(x['probability'] for x in beam) + 1e-12
assert set(combos[:5]) != {tuple(x['params'][k] for k in sel) for x in beam}
"
check "sampled: likeliest first, distinct, ordered, not the beam's" 0 $?
# The default is T = 0.5 (predict's); 0 asked for the beam above
"$imsynth" predict-params "$img" --model "$tmp/m1" --top-k 6 --hypotheses "$tmp/hd.json" \
    -o "$tmp/pd.json"
check "predict-params, default hypotheses" 0 $?
cmp -s "$tmp/hd.json" "$tmp/hs1.json" && cmp -s "$tmp/pd.json" "$tmp/ps1.json"
check "the default hypotheses are --sample-hypotheses 0.5's" 0 $?
"$imsynth" predict-params "$img" --model "$tmp/m1" --sample-hypotheses 0.001 2> "$tmp/err"
check "--sample-hypotheses below 0.01 (not 0) is a usage error" 2 $?
# bad models: clear errors naming the file
"$imsynth" predict-params "$img" --model "$tmp/nothing" 2> "$tmp/err"
check "a missing model directory" 1 $?
expect_stderr "names it" "nothing: not a model directory"
cp -r "$tmp/m1" "$tmp/bad"
head -c 1000 "$tmp/m1/network.safetensors" > "$tmp/bad/network.safetensors"
"$imsynth" predict-params "$img" --model "$tmp/bad" 2> "$tmp/err"
check "a truncated network file" 1 $?
expect_stderr "names the file" "bad/network.safetensors"
cp "$tmp/m1/network.safetensors" "$tmp/bad/network.safetensors"
echo '{"format": "imsynth-model/1", "parameters": [' > "$tmp/bad/model.json"
"$imsynth" predict-params "$img" --model "$tmp/bad" 2> "$tmp/err"
check "a broken model.json" 1 $?
expect_stderr "names the file" "bad/model.json: not valid JSON"
"$imsynth" predict-params "$tmp/ds.sqlite" --model "$tmp/m1" 2> "$tmp/err"
check "an input that is not an image" 1 $?
"$imsynth" fit-predictor --dataset "$tmp/none.sqlite" -o "$tmp/x" 2> "$tmp/err"
check "a missing dataset" 1 $?
[ ! -e "$tmp/x" ] && [ ! -e "$tmp/x.partial" ]
check "a failed fit leaves nothing" 0 $?
"$imsynth" fit-predictor $fit --components 4000 -o "$tmp/x" 2> "$tmp/err"
check "more components than rows" 1 $?
expect_stderr "says the limit" "at most min(rows - 1, features)"
# --half --catalogue: the basis, the catalogue and the network in float16, the catalogue
# cut to its first ids; the model still predicts and retrieves
"$imsynth" fit-predictor $fit --epochs 6 --threads 2 --half --catalogue 5 -o "$tmp/mh"
check "fit --half --catalogue 5" 0 $?
py -c "
import json, struct
def header(p):
    b = open(p, 'rb').read(); n = struct.unpack('<Q', b[:8])[0]; return json.loads(b[8:8 + n])
t32, t16 = header('$tmp/m1/transform.safetensors'), header('$tmp/mh/transform.safetensors')
assert t32['pca.components']['dtype'] == 'F32' and t16['pca.components']['dtype'] == 'F16'
assert t16['pca.components']['shape'] == t32['pca.components']['shape']
c = header('$tmp/mh/catalogue.safetensors')
assert c['catalogue.z']['dtype'] == 'F16' and c['catalogue.z']['shape'][0] == 5, c['catalogue.z']
assert c['catalogue.params']['shape'][0] == 5
n32, n16 = header('$tmp/m1/network.safetensors'), header('$tmp/mh/network.safetensors')
w = [k for k in n16 if k != '__metadata__']
assert w and sorted(w) == sorted(k for k in n32 if k != '__metadata__')
assert all(n16[k]['dtype'] == 'F16' and n32[k]['dtype'] == 'F32' for k in w), n16
assert all(n16[k]['shape'] == n32[k]['shape'] for k in w)
"
check "float16 basis, catalogue (5 rows) and network" 0 $?
"$imsynth" predict-params "$img" --model "$tmp/mh" --top-k 3 --nearest 5 --hypotheses "$tmp/hh.json" > /dev/null
check "a --half model predicts and retrieves" 0 $?
# --per-tap: each of the 5 MobileNetV2 taps gets its share of the 8 components (2,2,2,1,1),
# each component zero outside its own tap's values and not zero inside them
"$imsynth" fit-predictor $fit --epochs 2 --per-tap -o "$tmp/mt"; check "fit --per-tap" 0 $?
py -c "
import json, struct
b = open('$tmp/mt/transform.safetensors', 'rb').read(); n = struct.unpack('<Q', b[:8])[0]
h = json.loads(b[8:8 + n]); t = h['pca.components']
assert t['dtype'] == 'F32' and t['shape'] == [8, 38808], t
lo, hi = t['data_offsets']; c = struct.unpack('<%df' % (8 * 38808), b[8 + n + lo:8 + n + hi])
taps = [0, 528, 5184, 15624, 34152, 38808]; owner = [0, 0, 1, 1, 2, 2, 3, 4]
for k in range(8):
    row = c[k * 38808:(k + 1) * 38808]; a, z = taps[owner[k]], taps[owner[k] + 1]
    assert any(row[a:z]) and not any(row[:a]) and not any(row[z:]), k
assert json.load(open('$tmp/mt/model.json'))['training']['reduction'] == 'per-tap'
"
check "per-tap basis: each component within its own tap" 0 $?
"$imsynth" predict-params "$img" --model "$tmp/mt" -o "$tmp/pt.json"
check "a --per-tap model predicts" 0 $?
# --feature-mask: the PCA sees only the features a forest kept (forest importance's mask)
"$imsynth" forest fit --dataset "$tmp/ds.sqlite" --trees 4 --quiet -o "$tmp/f.bin" &&
    "$imsynth" forest importance "$tmp/f.bin" --top-k 64 -o "$tmp/fmask.npy"
check "a forest's mask of 64 features" 0 $?
"$imsynth" fit-predictor $fit --epochs 2 --feature-mask "$tmp/fmask.npy" -o "$tmp/mf"
check "fit --feature-mask" 0 $?
py -c "
import json, struct
def npy(p):
    b = open(p, 'rb').read(); n = struct.unpack('<H', b[8:10])[0]
    return struct.unpack('<%df' % ((len(b) - 10 - n) // 4), b[10 + n:])
m = npy('$tmp/fmask.npy'); keep = [j for j, v in enumerate(m) if v == 1]
assert len(m) == 38808 and len(keep) == 64, (len(m), len(keep))
b = open('$tmp/mf/transform.safetensors', 'rb').read(); n = struct.unpack('<Q', b[:8])[0]
t = json.loads(b[8:8 + n])['pca.components']; lo, hi = t['data_offsets']
c = struct.unpack('<%df' % (8 * 38808), b[8 + n + lo:8 + n + hi]); ks = set(keep)
for k in range(8):
    row = c[k * 38808:(k + 1) * 38808]
    assert any(row[j] for j in keep) and not any(v for j, v in enumerate(row) if j not in ks), k
tr = json.load(open('$tmp/mf/model.json'))['training']
assert tr['reduction'] == 'feature mask' and len(tr['feature_mask_sha256']) == 64, tr
"
check "masked basis: each component within the mask's features" 0 $?
"$imsynth" predict-params "$img" --model "$tmp/mf" -o "$tmp/pf.json"
check "a --feature-mask model predicts" 0 $?
py -c "
import struct
def npy(p, shape, vals):
    h = \"{'descr': '<f4', 'fortran_order': False, 'shape': %s, }\" % (shape,)
    h += ' ' * (63 - len(h)) + '\\n'
    open(p, 'wb').write(b'\\x93NUMPY\\x01\\x00' + struct.pack('<H', len(h)) + h.encode() + struct.pack('<%df' % len(vals), *vals))
npy('$tmp/short.npy', '(1, 100)', [1.0] * 100)
npy('$tmp/two.npy', '(1, 38808)', [2.0] + [1.0] * 38807)
npy('$tmp/few.npy', '(1, 38808)', [1.0] * 3 + [0.0] * 38805)
"
check "bad masks made" 0 $?
for bad in "short.npy:100 values, the descriptors have 38808" "two.npy:value 0 is 2, not 0 or 1" \
    "few.npy:keeps 3 features, fewer than the 8 components"; do
    f=${bad%%:*}
    "$imsynth" fit-predictor $fit --epochs 1 --feature-mask "$tmp/$f" -o "$tmp/mb" 2> "$tmp/err"
    check "--feature-mask $f refused" 1 $?
    expect_stderr "names the file and why" "$f: ${bad#*:}"
    [ ! -e "$tmp/mb" ] || { echo "FAIL: mb written"; failures=$((failures + 1)); }
done
"$imsynth" fit-predictor $fit --per-tap --feature-mask "$tmp/fmask.npy" -o "$tmp/mb" 2> "$tmp/err"
check "--per-tap with --feature-mask is a usage error" 2 $?
# --texstats: the network reads 8 components and 38 texture statistics; the transform
# keeps their standardisation; the model predicts, and its predictions depend on the image
# (two images, two answers); kill -9 and resume still gives the uninterrupted bytes
"$imsynth" fit-predictor $fit --epochs 3 --texstats --threads 1 -o "$tmp/ms"; check "fit --texstats" 0 $?
py -c "
import json, struct
b = open('$tmp/ms/transform.safetensors', 'rb').read(); n = struct.unpack('<Q', b[:8])[0]
h = json.loads(b[8:8 + n])
assert h['texstats.mean']['shape'] == [38] and h['texstats.std']['shape'] == [38], h.keys()
m = json.load(open('$tmp/ms/model.json'))
assert m['transform']['texstats'] == 38 and m['network']['arch'].startswith('mlp:46-'), m['network']
"
check "texture statistics in the transform, 8 + 38 network inputs" 0 $?
killed_and_resumed ms mk2 --texstats
check "--texstats: killed and resumed equals uninterrupted" 0 $?
"$imsynth" fit-predictor $fit --epochs 5000 --texstats -o "$tmp/mx" &
pid=$!
i=0
while [ ! -e "$tmp/mx.partial/state.json" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
kill -9 $pid 2> /dev/null
wait $pid 2> /dev/null
"$imsynth" fit-predictor $fit --epochs 5000 -o "$tmp/mx" 2> "$tmp/err"
check "a run without --texstats does not continue one with it" 1 $?
expect_stderr "says how to go on" "restart"
# A kill after the transform is written but before the first epoch ends leaves a state
# with no best validation loss yet (null): that run resumes, and equals the uninterrupted
# one. The window is too short to hit with a timed kill: the killed run's state is put back
# to it (and to 3 epochs), as a kill there would have left it.
py -c "
import json
p = '$tmp/mx.partial/state.json'; s = json.load(open(p))
s['settings']['epochs'] = 3; s.update(epochs_done=0, best_epoch=0, best_val_loss=None, history=[])
json.dump(s, open(p, 'w'))
"
"$imsynth" fit-predictor $fit --epochs 3 --texstats --threads 2 -o "$tmp/mx" 2> "$tmp/err" &&
    cmp -s "$tmp/ms/network.safetensors" "$tmp/mx/network.safetensors"
check "killed before the first epoch ended: resumed equals uninterrupted" 0 $?
img2="$root/tests/reference/render/supershader_s2/blender-4.3-a.exr"
"$imsynth" predict-params "$img" --model "$tmp/ms" -o "$tmp/ps1.json" &&
    "$imsynth" predict-params "$img2" --model "$tmp/ms" -o "$tmp/ps2.json"
check "a --texstats model predicts" 0 $?
cmp -s "$tmp/ps1.json" "$tmp/ps2.json"
check "two images, two predictions" 1 $?
lying_model ms bs "m['transform']['texstats'] = 12"
check "a model claiming 12 texture statistics" 1 $?
expect_stderr "names the file and the field" "bs/model.json: \"transform\".\"texstats\" must be 0 or 38"
# --conditional: the network reads 8 components and the 76 one-hot selector classes; each
# hypothesis gets values of its own (the first hypothesis's are predict-params' answer);
# kill -9 and resume gives the uninterrupted bytes; a model.json whose one-hot width is
# not the selectors' classes is refused
"$imsynth" fit-predictor $fit --epochs 3 --conditional --threads 1 -o "$tmp/mc"
check "fit --conditional" 0 $?
killed_and_resumed mc mc2 --conditional
check "--conditional: killed and resumed equals uninterrupted" 0 $?
"$imsynth" predict-params "$img" --model "$tmp/mc" -o "$tmp/pc.json" --top-k 4 \
    --hypotheses "$tmp/hc.json"
check "a --conditional model predicts" 0 $?
py -c "
import json
m = json.load(open('$tmp/mc/model.json'))
assert m['network']['arch'].startswith('mlp:84-') and m['network']['selector_inputs'] == 76, m['network']
assert m['training']['conditional'] is True
assert -1 < m['result']['val_median_value_r2_given_true_selectors'] <= 1, m['result']
p = json.load(open('$tmp/pc.json')); hyp = json.load(open('$tmp/hc.json'))['hypotheses']
assert len(hyp) == 4 and hyp[0]['params'] == p
vals = [k for k in p if not k.startswith('Mult ') and k != 'Pattern Offset']
assert all(0 <= x['params'][k] <= 1 for x in hyp for k in vals)
differ = sum(any(x['params'][k] != hyp[0]['params'][k] for k in vals) for x in hyp[1:])
assert differ == 3, 'each hypothesis has values given its own selectors: %d of 3 differ' % differ
"
check "one-hot inputs in model.json; each hypothesis its own values" 0 $?
lying_model mc bc "m['network']['selector_inputs'] = 75"
check "a model claiming 75 one-hot inputs" 1 $?
expect_stderr "names the file and the field" "bc/model.json: \"network\".\"selector_inputs\" must be 76"
# --members 3: an ensemble of three networks on one transform. Member 1 is the single
# network of the same settings (seed + 0), the others differ; predictions average the
# three (so differ from member 1's alone); kill -9 in the second member and resume gives
# the uninterrupted bytes; a model.json naming a member outside its folder, or one that is
# missing, is refused
"$imsynth" fit-predictor $fit --epochs 3 --threads 2 -o "$tmp/m3" &&
    "$imsynth" fit-predictor $fit --epochs 3 --members 3 --threads 2 -o "$tmp/me"
check "fit --members 3" 0 $?
cmp -s "$tmp/m3/network.safetensors" "$tmp/me/network.safetensors" &&
    cmp -s "$tmp/m3/transform.safetensors" "$tmp/me/transform.safetensors"
check "the first member is the single network of the same settings" 0 $?
cmp -s "$tmp/me/network.safetensors" "$tmp/me/network-2.safetensors"
check "the second member differs from the first" 1 $?
py -c "
import json
m = json.load(open('$tmp/me/model.json'))
assert m['network']['members'] == ['network.safetensors', 'network-2.safetensors', 'network-3.safetensors'], m['network']
assert m['training']['members'] == 3 and len(m['result']['members_best_epoch']) == 3, m['result']
assert 0 <= m['result']['first_member_val_mean_selector_accuracy'] <= 1
s = json.load(open('$tmp/m3/model.json'))
assert 'members' not in s['network'] and 'members' not in s['training']
assert s['result']['val_mean_selector_accuracy'] == m['result']['first_member_val_mean_selector_accuracy']
"
check "model.json lists the members; the first member's figures are the single network's" 0 $?
"$imsynth" predict-params "$img" --model "$tmp/m3" -o "$tmp/p3.json" &&
    "$imsynth" predict-params "$img" --model "$tmp/me" -o "$tmp/pe.json"
check "an ensemble predicts" 0 $?
cmp -s "$tmp/p3.json" "$tmp/pe.json"
check "the ensemble's prediction is not its first member's" 1 $?
# (300 epochs of a wider network: long enough for the kill to land in the second member)
long="--epochs 300 --hidden 256 --members 2 --threads 2"
"$imsynth" fit-predictor $fit $long -o "$tmp/mel" &&
    "$imsynth" fit-predictor $fit $long -o "$tmp/mk3" &
pid=$!
i=0
while ! grep -q '"member":.1' "$tmp/mk3.partial/state.json" 2> /dev/null && [ $i -lt 1000 ]; do
    sleep 0.02; i=$((i + 1))
done
sleep 0.3; pkill -9 -f "$tmp/mk3" 2> /dev/null; wait $pid 2> /dev/null
grep -q '"member":.1' "$tmp/mk3.partial/state.json" && [ ! -e "$tmp/mk3" ] ||
    echo "note: the kill did not land in the second member"
"$imsynth" fit-predictor $fit $long -o "$tmp/mk3"
same=$?
for f in network.safetensors network-2.safetensors losses.csv; do
    cmp -s "$tmp/mel/$f" "$tmp/mk3/$f" || same=1
done
[ $same = 0 ]
check "an ensemble killed in its second member resumes to the uninterrupted bytes" 0 $?
ls "$tmp/mk3" | grep -q "checkpoint\|best\|member"
check "no run files left in the ensemble's folder" 1 $?
# A kill after the last member's finishing state, while the model is written, leaves a
# state naming every member done: the same command completes it (for one network as for
# three). The window is too short to hit with a timed kill: the state is made from the
# finished model, as such a kill would have left it.
for pair in "m3 1" "me 3"; do
    set -- $pair
    rm -rf "$tmp/w.partial" "$tmp/w"
    cp -r "$tmp/$1" "$tmp/w.partial"
    rm "$tmp/w.partial/model.json" "$tmp/w.partial/catalogue.safetensors"
    py -c "
import json
m = json.load(open('$tmp/$1/model.json')); r = m['result']
epochs = r.get('members_best_epoch', [r['best_epoch']])
json.dump({'settings': m['training'], 'member': $2, 'members_done': [[e, 2.5] for e in epochs],
           'epochs_done': 0, 'best_epoch': 0, 'best_val_loss': None, 'history': []},
          open('$tmp/w.partial/state.json', 'w'))
"
    sed -i "s|$tmp/$1|$tmp/w|g" "$tmp/w.partial/state.json"
    "$imsynth" fit-predictor $fit --epochs 3 $([ $2 = 3 ] && echo --members 3) --threads 2 -o "$tmp/w" &&
        cmp -s "$tmp/$1/network.safetensors" "$tmp/w/network.safetensors" &&
        cmp -s "$tmp/$1/catalogue.safetensors" "$tmp/w/catalogue.safetensors" && [ ! -e "$tmp/w/state.json" ]
    check "killed while writing the model ($2 network(s)): the rerun completes it" 0 $?
done
lying_model me be1 "m['network']['members'][1] = '../m3/network.safetensors'"
check "a model naming a member outside its folder" 1 $?
expect_stderr "names the file and the field" "be1/model.json: \"network\".\"members\"\\[1\\] must be a file"
cp -r "$tmp/me" "$tmp/be2" && rm "$tmp/be2/network-3.safetensors"
"$imsynth" predict-params "$img" --model "$tmp/be2" 2> "$tmp/err"
check "a model missing a member" 1 $?
expect_stderr "names the missing file" "be2/network-3.safetensors"
"$imsynth" fit-predictor $fit --members 17 -o "$tmp/bm" 2> "$tmp/err"
check "--members 17 is a usage error" 2 $?
# without --model: the bundled model, as predict and search use it
"$imsynth" predict-params "$img" --top-k 2 --hypotheses "$tmp/hb.json" -o "$tmp/pb.json"
check "predict-params without --model" 0 $?
py -c "
import json
h = json.load(open('$tmp/hb.json'))
assert h['model'].endswith('assets/model'), h['model']
assert len(json.load(open('$tmp/pb.json'))) == 50
"
check "the bundled model, named in the hypotheses file" 0 $?
finish
