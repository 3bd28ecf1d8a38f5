#!/bin/sh
# imsynth forest end to end on the committed scikit-learn fixture: fit, predict (R^2 printed
# and plausible), importance (mask with K ones), same file for any thread count, exit codes,
# errors naming the file, no output left by a failed run. Usage: forest.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
ref="$root/tests/reference/forest"

"$imsynth" forest --help > "$tmp/out"; check "forest --help" 0 $?
expect_stdout "help names the actions" "imsynth forest importance"
"$imsynth" forest 2> "$tmp/err"; check "no action" 2 $?
"$imsynth" forest grow 2> "$tmp/err"; check "unknown action" 2 $?
"$imsynth" forest fit --x "$ref/rf_X_train.npy" -o "$tmp/f.bin" 2> "$tmp/err"; check "fit without --y" 2 $?
"$imsynth" forest fit --x a --y b -o c --max-features half 2> "$tmp/err"; check "bad --max-features" 2 $?
expect_stderr "--max-features message" "expected sqrt, log2, all"
"$imsynth" forest fit --x a --y b -o c --split fast 2> "$tmp/err"; check "bad --split" 2 $?

"$imsynth" forest fit --x "$ref/rf_X_train.npy" --y "$ref/rf_Y_train.npy" -o "$tmp/f.bin" \
    --trees 20 --min-samples-leaf 2 --threads 2 > "$tmp/out" 2> "$tmp/err"; check "fit" 0 $?
expect_stdout "fit summary" "20 trees"
expect_stderr "progress with ETA" "ETA"
"$imsynth" forest fit --x "$ref/rf_X_train.npy" --y "$ref/rf_Y_train.npy" -o "$tmp/g.bin" \
    --trees 20 --min-samples-leaf 2 --threads 1 --quiet > /dev/null; check "fit, 1 thread" 0 $?
cmp -s "$tmp/f.bin" "$tmp/g.bin" && echo "ok: same forest for 1 and 2 threads" || {
    echo "FAIL: thread count changed the forest"; failures=$((failures + 1)); }

"$imsynth" forest predict "$tmp/f.bin" --x "$ref/rf_X_test.npy" --y "$ref/rf_Y_test.npy" \
    -o "$tmp/p.npy" > "$tmp/out"; check "predict" 0 $?
# 300 x 3 float32 after a 128-byte header.
size=$(wc -c < "$tmp/p.npy"); [ "$size" = $((128 + 300 * 3 * 4)) ] && echo "ok: prediction size" || {
    echo "FAIL: prediction file has $size bytes"; failures=$((failures + 1)); }
r2=$(sed -n 's/^R^2 (mean over outputs): //p' "$tmp/out")
awk -v r="$r2" 'BEGIN { exit !(r > 0.6 && r < 0.8) }' && echo "ok: R^2 $r2 near scikit-learn's 0.68" || {
    echo "FAIL: R^2 \"$r2\""; failures=$((failures + 1)); }

"$imsynth" forest importance "$tmp/f.bin" --top-k 3 -o "$tmp/m.npy" --indices "$tmp/i.npy" \
    > "$tmp/out"; check "importance" 0 $?
size=$(wc -c < "$tmp/m.npy"); [ "$size" = $((128 + 8 * 4)) ] && echo "ok: mask size" || {
    echo "FAIL: mask file has $size bytes"; failures=$((failures + 1)); }
"$imsynth" forest importance "$tmp/f.bin" --top-k 3 -o "$tmp/q.npy" --permutation \
    --x "$ref/rf_X_test.npy" --y "$ref/rf_Y_test.npy" --repeats 2 > "$tmp/out"; check "permutation importance" 0 $?
expect_stdout "permutation named" "by permutation importance"
"$imsynth" forest importance "$tmp/f.bin" --top-k 9 -o "$tmp/r.npy" 2> "$tmp/err"; check "--top-k above the features" 1 $?

# Failures name the file and leave nothing behind.
head -c 300 "$tmp/f.bin" > "$tmp/cut.bin"
"$imsynth" forest predict "$tmp/cut.bin" --x "$ref/rf_X_test.npy" -o "$tmp/none.npy" 2> "$tmp/err"
check "truncated forest" 1 $?
expect_stderr "truncation named" "cut.bin: truncated"
[ ! -e "$tmp/none.npy" ] && echo "ok: no output after a failure" || {
    echo "FAIL: output left behind"; failures=$((failures + 1)); }
"$imsynth" forest predict "$tmp/f.bin" --x "$ref/exact_X_test.npy" -o "$tmp/none.npy" 2> "$tmp/err"
check "X with the wrong width" 1 $?
expect_stderr "width named" "exact_X_test.npy: X (features as the forest's) is 60 x 6, expected 60 x 8"
"$imsynth" forest fit --x "$ref/rf_X_train.npy" --y "$ref/rf_Y_test.npy" -o "$tmp/h.bin" --quiet 2> "$tmp/err"
check "Y rows differ from X rows" 1 $?
ls "$tmp" | grep -q tmp && { echo "FAIL: temporary file left"; failures=$((failures + 1)); } || echo "ok: no temporary files"
finish
