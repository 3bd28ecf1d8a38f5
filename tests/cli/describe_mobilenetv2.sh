#!/bin/sh
# imsynth describe --features mobilenetv2 end to end: row length of the default and a
# custom tap set at one and two scales, the printed columns, thread/batch independence,
# usage errors for options of the other network, a missing weight file naming itself.
# Usage: describe_mobilenetv2.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
expect_size() { # description, file, bytes
    size=$(wc -c < "$2" 2>/dev/null || echo missing)
    if [ "$size" = "$3" ]; then echo "ok: $1"; else
        echo "FAIL: $1: $2 has $size bytes, expected $3"; failures=$((failures + 1)); fi
}
weights="$root/assets/mobilenetv2/mobilenetv2_block10.safetensors"

"$imsynth" eval-graph "$root/assets/examples/marble.json" --socket "Principled BSDF:Base Color" \
    -o "$tmp/a.exr" --size 256 > /dev/null; check "make a 256x256 EXR" 0 $?
"$imsynth" eval-graph "$root/assets/examples/marble.json" --socket "Principled BSDF:Base Color" \
    -o "$tmp/b.exr" --png "$tmp/b.png" --size 40 > /dev/null; check "make a small PNG" 0 $?

# Default taps: 38,808 floats a row; .npy = 128-byte header + rows * 38808 * 4.
"$imsynth" describe "$tmp/a.exr" "$tmp/b.png" -o "$tmp/d.npy" --features mobilenetv2 \
    --weights "$weights" --threads 2 --batch 2 > "$tmp/out"; check "describe two images" 0 $?
expect_size "default descriptor size" "$tmp/d.npy" $((128 + 2 * 38808 * 4))
expect_stdout "tap columns" "block_10_project@224  columns 34152..38807"
"$imsynth" describe "$tmp/a.exr" "$tmp/b.png" -o "$tmp/e.npy" --features mobilenetv2 \
    --weights "$weights" --threads 1 --batch 1 > /dev/null; check "1 thread, batch 1" 0 $?
cmp -s "$tmp/d.npy" "$tmp/e.npy" && echo "ok: same bits" || { echo "FAIL: batch/threads changed the output"; failures=$((failures + 1)); }

# conv1 (32 ch: 528) + block_2_project (24 ch: 300) at two scales: 1656 floats.
"$imsynth" describe "$tmp/a.exr" -o "$tmp/t.npy" --features mobilenetv2 --weights "$weights" \
    --taps conv1,block_2_project --scales 2 --input-range signed > "$tmp/out"; check "taps, two scales" 0 $?
expect_size "two-scale size" "$tmp/t.npy" $((128 + 1656 * 4))
expect_stdout "second-scale columns" "block_2_project@112  columns 1356..1655"

# Usage errors: exit 2, nothing written.
"$imsynth" describe "$tmp/a.exr" -o "$tmp/u.npy" --features mobilenetv2 --pool avg2 2> "$tmp/err"
check "--pool with mobilenetv2" 2 $?
expect_stderr "names the option" "\-\-pool is a VGG19 option"
"$imsynth" describe "$tmp/a.exr" -o "$tmp/u.npy" --taps conv1 2> "$tmp/err"; check "--taps with vgg19" 2 $?
"$imsynth" describe "$tmp/a.exr" -o "$tmp/u.npy" --features resnet 2> "$tmp/err"; check "bad --features" 2 $?
"$imsynth" describe "$tmp/a.exr" -o "$tmp/u.npy" --features mobilenetv2 --taps block_11_expand 2> "$tmp/err"
check "bad tap" 2 $?
expect_stderr "names the tap" "block_11_expand"
"$imsynth" describe "$tmp/a.exr" -o "$tmp/u.npy" --features mobilenetv2 --scales 3 2> "$tmp/err"; check "bad --scales" 2 $?
# Work failures: exit 1, the file named.
"$imsynth" describe "$tmp/a.exr" -o "$tmp/u.npy" --features mobilenetv2 --weights "$tmp/none.safetensors" 2> "$tmp/err"
check "missing weights" 1 $?
expect_stderr "names the weights file" "none.safetensors"
"$imsynth" describe "$tmp/a.exr" -o "$tmp/u.npy" --features mobilenetv2 \
    --weights "$root/tests/reference/nn/weights.safetensors" 2> "$tmp/err"
check "VGG weights given to mobilenetv2" 1 $?
expect_stderr "names the tensor" "Conv1.weight"
[ -e "$tmp/u.npy" ] && { echo "FAIL: output written by a failed run"; failures=$((failures + 1)); }
ls "$tmp" | grep -q '\.tmp\.' && { echo "FAIL: temporary file left behind"; failures=$((failures + 1)); }

[ "$failures" = 0 ] && echo "all describe mobilenetv2 checks passed"
exit $((failures > 0))
