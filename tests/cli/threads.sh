#!/bin/sh
# Determinism across thread counts (issue 17): render, describe (VGG19 and MobileNetV2),
# datagen, forest, train, fit-predictor and predict each run with 1, 2 and 8 worker threads
# on small inputs, and every output is compared byte for byte (a dataset by its content
# digest, since SQLite's page layout may differ). 8 threads on this 2-core machine also
# checks that oversubscription changes nothing: work is split by item, never by timing.
# Usage: threads.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
# Under the sanitizers (IMSYNTH_TEST_QUICK) 1 and 8 threads only.
counts="1 2 8"; [ -n "${IMSYNTH_TEST_QUICK:-}" ] && counts="1 8"
same_for_counts() { # description, file pattern with @ for the thread count
    a=$(echo "$2" | sed 's/@/1/'); bad=""
    for t in ${counts#1 }; do
        b=$(echo "$2" | sed "s/@/$t/")
        cmp -s "$a" "$b" || bad="$bad $t"
    done
    if [ -z "$bad" ] && [ -s "$a" ]; then echo "ok: $1: the same bytes for $counts threads"; else
        echo "FAIL: $1: differs from 1 thread at$bad threads"; failures=$((failures + 1)); fi
}

# A 48 x 48 scene: the same plane, camera and light, fewer pixels.
sed 's/"resolution": *\[256, *256\]/"resolution": [48, 48]/' "$root/assets/scene.json" > "$tmp/scene.json"
grep -q '"resolution": \[48, 48\]' "$tmp/scene.json"; check "a small scene" 0 $?

"$imsynth" sample --seed 7 > "$tmp/p.json" && "$imsynth" extract --params "$tmp/p.json" -o "$tmp/g.json"
check "a sub-shader to render" 0 $?
for t in $counts; do
    "$imsynth" render "$tmp/g.json" --scene "$tmp/scene.json" --spp 2 --max-spp 16 --float \
        --threads $t -o "$tmp/r$t.exr" || { echo "FAIL: render, $t threads"; failures=$((failures + 1)); }
done
same_for_counts "render (adaptive sampling)" "$tmp/r@.exr"

img="$root/assets/examples/handmade-marble.png"
for t in $counts; do
    "$imsynth" describe "$img" "$tmp/r1.exr" --batch 2 --threads $t -o "$tmp/d$t.npy" > /dev/null &&
    "$imsynth" describe "$img" --features mobilenetv2 --threads $t -o "$tmp/m$t.npy" > /dev/null ||
        { echo "FAIL: describe, $t threads"; failures=$((failures + 1)); }
done
same_for_counts "describe, VGG19" "$tmp/d@.npy"
same_for_counts "describe, MobileNetV2" "$tmp/m@.npy"

for t in $counts; do
    "$imsynth" datagen --out "$tmp/ds$t.sqlite" --count 12 --preset draft --batch 3 --threads $t --quiet ||
        { echo "FAIL: datagen, $t threads"; failures=$((failures + 1)); }
    dataset_digest "$tmp/ds$t.sqlite" > "$tmp/ds$t.digest"
done
same_for_counts "datagen (content digest)" "$tmp/ds@.digest"

for t in $counts; do
    "$imsynth" forest fit --dataset "$tmp/ds1.sqlite" --trees 6 --threads $t --quiet -o "$tmp/f$t.bin" > /dev/null ||
        { echo "FAIL: forest fit, $t threads"; failures=$((failures + 1)); }
done
same_for_counts "forest fit" "$tmp/f@.bin"

ref="$root/tests/reference/nn_train"
for t in $counts; do
    "$imsynth" train --x "$ref/x.npy" --y "$ref/y.npy" --mask "$ref/mask.npy" --loss thesis -q \
        --arch "mlp:16-24-24-13,gelu,ln,dropout=0.1" --heads "sigmoid:0-5,softmax:6/4,softmax:7/3:unit@0.5" \
        --epochs 3 --threads $t -o "$tmp/t$t.safetensors" > /dev/null 2>&1 ||
        { echo "FAIL: train, $t threads"; failures=$((failures + 1)); }
done
same_for_counts "train" "$tmp/t@.safetensors"

fit="--dataset $tmp/ds1.sqlite --components 6 --hidden 16 --batch 4 --val-fraction 0.25 --epochs 2 --quiet"
for t in $counts; do
    "$imsynth" fit-predictor $fit --threads $t -o "$tmp/model$t" ||
        { echo "FAIL: fit-predictor, $t threads"; failures=$((failures + 1)); }
done
for f in network transform catalogue; do
    same_for_counts "fit-predictor, $f" "$tmp/model@/$f.safetensors"
done

fast="--model $tmp/model1 --top-k 2 --nearest 2 --refine 4 --search-preset draft --final-preset draft --quiet"
for t in $counts; do
    "$imsynth" predict "$img" $fast --threads $t -o "$tmp/out$t" ||
        { echo "FAIL: predict, $t threads"; failures=$((failures + 1)); }
done
for f in params.json material.json preview.png; do
    same_for_counts "predict, $f" "$tmp/out@/$f"
done
finish
