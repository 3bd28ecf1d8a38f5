#!/bin/sh
# imsynth describe end to end: .npy shape and size, exit codes, errors naming the file,
# no output (nor temporary file) left by a failed run. Usage: describe.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
expect_size() { # description, file, bytes
    size=$(wc -c < "$2" 2>/dev/null || echo missing)
    if [ "$size" = "$3" ]; then echo "ok: $1"; else
        echo "FAIL: $1: $2 has $size bytes, expected $3"; failures=$((failures + 1)); fi
}
fixture="$root/tests/reference/nn/weights.safetensors"

"$imsynth" describe --help > "$tmp/out"; check "describe --help" 0 $?
"$imsynth" describe 2> "$tmp/err"; check "no arguments" 2 $?
"$imsynth" describe a.png -o x.npy --pool avg4 2> "$tmp/err"; check "bad --pool" 2 $?
expect_stderr "--pool message" "expected avg3, avg2 or max2"
"$imsynth" describe a.png -o x.npy --precision half 2> "$tmp/err"; check "bad --precision" 2 $?

# Two images, one 256x256 and one that must be resized (48x40 -> 307x256), through the
# reduced fixture network: 4860 floats a row; .npy = 128-byte header + 2 * 4860 * 4.
"$imsynth" eval-graph "$root/assets/examples/marble.json" --socket "Principled BSDF:Base Color" \
    -o "$tmp/a.exr" --size 256 > /dev/null; check "make a 256x256 EXR" 0 $?
"$imsynth" eval-graph "$root/assets/examples/marble.json" --socket "Principled BSDF:Base Color" \
    -o "$tmp/b.exr" --png "$tmp/b.png" --size 40 > /dev/null; check "make a small PNG" 0 $?
"$imsynth" describe "$tmp/a.exr" "$tmp/b.png" -o "$tmp/d.npy" --weights "$fixture" \
    --threads 2 --batch 2 > "$tmp/out"; check "describe two images" 0 $?
expect_size "descriptor file size" "$tmp/d.npy" $((128 + 2 * 4860 * 4))
grep -q "conv5_4  columns 2780..4859" "$tmp/out" || { echo "FAIL: layer offsets"; cat "$tmp/out"; failures=$((failures + 1)); }
# Batch and thread count do not change a bit.
"$imsynth" describe "$tmp/a.exr" "$tmp/b.png" -o "$tmp/e.npy" --weights "$fixture" \
    --threads 1 --batch 1 > /dev/null; check "describe, 1 thread, batch 1" 0 $?
cmp -s "$tmp/d.npy" "$tmp/e.npy" && echo "ok: same bits" || { echo "FAIL: batch/threads changed the output"; failures=$((failures + 1)); }

# Default network: 305,888 floats a row.
"$imsynth" describe "$tmp/a.exr" -o "$tmp/r.npy" --pool max2 --post-relu > /dev/null; check "random weights" 0 $?
expect_size "full descriptor size" "$tmp/r.npy" $((128 + 305888 * 4))

# Failures leave no output behind and name the culprit.
"$imsynth" describe "$tmp/a.exr" "$tmp/missing.png" -o "$tmp/f.npy" --weights "$fixture" 2> "$tmp/err"
check "missing image" 1 $?
expect_stderr "message names the image" "missing.png"
"$imsynth" describe "$tmp/a.exr" -o "$tmp/g.npy" --weights "$root/tests/cli/describe.sh" 2> "$tmp/err"
check "not a safetensors file" 1 $?
expect_stderr "message names the weights file" "describe.sh: header length"
[ -e "$tmp/f.npy" ] || [ -e "$tmp/g.npy" ] && { echo "FAIL: output written by a failed run"; failures=$((failures + 1)); }
ls "$tmp" | grep -q '\.tmp\.' && { echo "FAIL: temporary file left behind"; failures=$((failures + 1)); }

[ "$failures" = 0 ] && echo "all describe checks passed"
exit $((failures > 0))
