#!/bin/sh
# imsynth train / infer end to end: exit codes, errors naming the file and place, outputs
# of the documented shapes, thread count and resuming change no bit, a failed run leaves
# no output. Usage: train.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
ref="$root/tests/reference/nn_train"
same() { # description, file, file
    if cmp -s "$2" "$3"; then echo "ok: $1"; else
        echo "FAIL: $1: $2 and $3 differ"; failures=$((failures + 1)); fi
}
absent() { # description, file
    if [ -e "$2" ]; then echo "FAIL: $1: $2 exists"; failures=$((failures + 1)); else echo "ok: $1"; fi
}
common="--x $ref/x.npy --y $ref/y.npy --mask $ref/mask.npy --loss thesis -q --schedule cosine --warmup 3"
arch="mlp:16-24-24-13,gelu,ln,dropout=0.1"
heads="sigmoid:0-5,softmax:6/4,softmax:7/3:unit@0.5"

"$imsynth" train --help > "$tmp/out"; check "train --help" 0 $?
expect_stdout "--help documents --heads" "softmax:C/K:unit"
"$imsynth" train 2> "$tmp/err"; check "no arguments" 2 $?
"$imsynth" train $common --arch "mlp:16-x-13" -o "$tmp/m.safetensors" 2> "$tmp/err"; check "bad --arch" 2 $?
expect_stderr "--arch message" "width 1"
"$imsynth" train $common --arch "$arch" --heads "sigmoid:0-5,softmax:6/4" -o "$tmp/m.safetensors" 2> "$tmp/err"
check "heads not matching the outputs" 2 $?
expect_stderr "--heads message" "need 10 network outputs but the network has 13"

# Data errors: exit 1, the file named, nothing written.
"$imsynth" train --x "$ref/x.npy" --y "$ref/mask.npy" --arch "mlp:15-4-8" -o "$tmp/m.safetensors" 2> "$tmp/err"
check "X columns != IN" 1 $?
expect_stderr "names the inputs" "takes 15 inputs"
"$imsynth" train --x "$ref/x.npy" --y "$ref/y.npy" --arch "mlp:16-8-8" --heads "linear:0-5,softmax:7/2" -o "$tmp/m2.safetensors" 2> "$tmp/err"
check "a selector value is not a class index" 1 $?
expect_stderr "names row and column" "Y row 2 column 7 is 0.5"
absent "no checkpoint after a failed run" "$tmp/m2.safetensors"
head -c 100 "$ref/x.npy" > "$tmp/short.npy"
"$imsynth" train --x "$tmp/short.npy" --y "$ref/y.npy" --arch "mlp:16-8-8" -o "$tmp/m2.safetensors" 2> "$tmp/err"
check "truncated X" 1 $?
expect_stderr "names the file" "short.npy"

# Train, log, infer: shapes and files as documented.
"$imsynth" train $common --arch "$arch" --heads "$heads" --batch 16 --steps 12 --threads 1 \
    --val-x "$ref/x.npy" --val-y "$ref/y.npy" --val-mask "$ref/mask.npy" \
    --log "$tmp/loss.csv" -o "$tmp/a.safetensors" > "$tmp/out"; check "train" 0 $?
[ "$(wc -l < "$tmp/loss.csv")" = 13 ] && echo "ok: 12 logged steps" || { echo "FAIL: loss.csv"; failures=$((failures + 1)); }
# 64 rows in batches of 16: epochs end at steps 3, 7, 11, where the validation loss is
[ "$(grep -c ',[0-9][0-9.e+-]*$' "$tmp/loss.csv")" = 3 ] && grep -q '^11,2,.*,[0-9]' "$tmp/loss.csv" \
    && echo "ok: validation loss at each epoch's end" || { echo "FAIL: val_loss column"; cat "$tmp/loss.csv"; failures=$((failures + 1)); }
grep -q "<polyline" "$tmp/loss.svg" && echo "ok: loss curve SVG" || { echo "FAIL: loss.svg"; failures=$((failures + 1)); }
"$imsynth" infer "$tmp/a.safetensors" --x "$ref/x.npy" -o "$tmp/p.npy" > "$tmp/out"; check "infer" 0 $?
expect_stdout "Y-shaped predictions" "64 x 8 float32"
"$imsynth" infer "$tmp/a.safetensors" --x "$ref/x.npy" --probs -o "$tmp/q.npy" > "$tmp/out"; check "infer --probs" 0 $?
expect_stdout "head outputs" "64 x 13 float32"

# Threads change no bit; nor does stopping and resuming.
"$imsynth" train $common --arch "$arch" --heads "$heads" --batch 16 --steps 12 --threads 2 \
    -o "$tmp/b.safetensors"; check "train, 2 threads" 0 $?
same "1 and 2 threads: the same checkpoint" "$tmp/a.safetensors" "$tmp/b.safetensors"
"$imsynth" train $common --arch "$arch" --heads "$heads" --batch 16 --steps 5 \
    --schedule-steps 12 -o "$tmp/half.safetensors"; check "first 5 steps" 0 $?
"$imsynth" train $common --resume "$tmp/half.safetensors" --batch 16 --steps 7 \
    -o "$tmp/c.safetensors"; check "resume for 7 more" 0 $?
same "5 + 7 steps resumed = 12 straight" "$tmp/a.safetensors" "$tmp/c.safetensors"

# A damaged checkpoint is an error naming it, and leaves no output.
head -c 2000 "$tmp/a.safetensors" > "$tmp/cut.safetensors"
"$imsynth" infer "$tmp/cut.safetensors" --x "$ref/x.npy" -o "$tmp/r.npy" 2> "$tmp/err"
check "truncated checkpoint" 1 $?
expect_stderr "names the checkpoint" "cut.safetensors"
absent "no predictions from a bad checkpoint" "$tmp/r.npy"
finish
