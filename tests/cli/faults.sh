#!/bin/sh
# Fault injection (issue 17): every command that writes (render, describe, datagen, forest,
# train, fit-predictor, predict, evaluate) on a full disk and on a read-only filesystem
# gives a clear error naming its output, exit status 1, and leaves nothing behind: no
# output, no temp file (fit-predictor's OUT.partial excepted: its resume state). Inputs truncated or deleted while a run reads them give a clean
# error or a complete result, never a crash. Headers claiming hostile sizes (a 10^5 x 10^5
# PNG, a million-node graph, safetensors and .npy claiming 10^12 and 4 x 10^10 bytes) are
# refused under `ulimit -v` before anything of their size is allocated.
# The disks are tmpfs mounts, so those checks need root (CI runs as root); the ulimit -v
# checks are skipped under AddressSanitizer, which reserves terabytes of address space.
# Usage: faults.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
hostile=$root/tests/cli/lib/make_hostile.py

# Small inputs for every command.
sed 's/"resolution": *\[256, *256\]/"resolution": [32, 32]/' "$root/assets/scene.json" > "$tmp/scene.json"
img="$root/assets/examples/handmade-marble.png"
ref="$root/tests/reference/nn_train"
"$imsynth" sample --seed 3 > "$tmp/p.json" && "$imsynth" extract --params "$tmp/p.json" -o "$tmp/g.json" &&
    "$imsynth" datagen --out "$tmp/ds.sqlite" --count 12 --preset draft --quiet &&
    "$imsynth" datagen --out "$tmp/test.sqlite" --count 1 --first-id 1000000 --preset draft --quiet &&
    "$imsynth" fit-predictor --dataset "$tmp/ds.sqlite" --components 4 --hidden 8 --batch 4 \
        --val-fraction 0.25 --epochs 2 --quiet -o "$tmp/model"
check "inputs: a sub-shader, a 12-sample dataset, a test sample, a model" 0 $?

# One command per output kind; OUT is the directory it writes into.
run_writer() { # name OUT
    o=$2
    case $1 in
    render) "$imsynth" render "$tmp/g.json" --scene "$tmp/scene.json" --spp 1 --max-spp 0 -o "$o/r.exr" ;;
    describe) "$imsynth" describe "$img" --features mobilenetv2 -o "$o/d.npy" ;;
    datagen) "$imsynth" datagen --out "$o/x.sqlite" --count 2 --preset draft --quiet ;;
    forest) "$imsynth" forest fit --dataset "$tmp/ds.sqlite" --trees 2 --quiet -o "$o/f.bin" ;;
    train) "$imsynth" train --x "$ref/x.npy" --y "$ref/y.npy" --mask "$ref/mask.npy" -q \
        --arch "mlp:16-8-13" --heads "sigmoid:0-5,softmax:6/4,softmax:7/3:unit@0.5" --epochs 1 \
        -o "$o/t.safetensors" ;;
    fit-predictor) "$imsynth" fit-predictor --dataset "$tmp/ds.sqlite" --components 4 --hidden 8 \
        --batch 4 --val-fraction 0.25 --epochs 1 --quiet -o "$o/model" ;;
    predict) "$imsynth" predict "$img" --model "$tmp/model" --top-k 1 --nearest 1 --refine 2 \
        --search-preset draft --final-preset draft --quiet -o "$o/pred" ;;
    evaluate) "$imsynth" evaluate --model "$tmp/model" --test "$tmp/test.sqlite" --top-k 1 \
        --refine 2 --preset draft -o "$o/report" ;;
    esac
}
writers="render describe datagen forest train fit-predictor predict evaluate"

# What is in DIR besides the filler and fit-predictor's documented resume state
# (OUT.partial, its checkpoints: the same command resumes from them), if anything.
leftovers() { ls -A "$1" | grep -v -x -e filler -e model.partial; }
clean() { rm -rf "$1/model.partial"; }

if [ "$(id -u)" = 0 ] && mkdir "$tmp/full" "$tmp/ro" &&
    mount -t tmpfs -o size=256k tmpfs "$tmp/full" 2> /dev/null &&
    mount -t tmpfs -o ro,size=256k tmpfs "$tmp/ro" 2> /dev/null; then
    trap 'umount "$tmp/full" "$tmp/ro" 2> /dev/null; rm -rf "$tmp"' EXIT
    # Fill the disk: files can still be created there, but not one byte written.
    dd if=/dev/zero of="$tmp/full/filler" bs=4k 2> /dev/null
    for w in $writers; do
        run_writer $w "$tmp/full" > /dev/null 2> "$tmp/err"; rc=$?
        check "$w on a full disk" 1 $rc
        expect_stderr "$w: the error names the output's place" "$tmp/full"
        # SQLite says it its own way.
        full="No space left on device"; [ $w = datagen ] && full="database or disk is full"
        expect_stderr "$w: the error says the disk is full" "$full"
        left=$(leftovers "$tmp/full")
        [ -z "$left" ] && echo "ok: $w: nothing left on the full disk" ||
            { echo "FAIL: $w left on the full disk: $left"; failures=$((failures + 1)); }
        clean "$tmp/full"

        run_writer $w "$tmp/ro" > /dev/null 2> "$tmp/err"; rc=$?
        check "$w on a read-only filesystem" 1 $rc
        expect_stderr "$w: the error names the output's place" "$tmp/ro"
        expect_stderr "$w: the error says it is read-only" "Read-only file system"
    done
    umount "$tmp/full" "$tmp/ro"
else
    echo "skipped: full-disk and read-only checks (need root to mount tmpfs)"
fi

# Truncated or deleted while read: the run either read it first (a complete output) or
# fails cleanly naming the file (no output); never a signal. Each at a few moments.
during() { # description, victim file, action (truncate|delete), output path, command...
    d=$1 victim=$2 act=$3 out=$4; shift 4
    for delay in 0.05 0.3 1; do
        cp "$victim.orig" "$victim"
        rm -rf "$out"
        "$@" > /dev/null 2> "$tmp/err" &
        pid=$!
        sleep $delay
        if [ "$act" = truncate ]; then
            size=$(wc -c < "$victim")
            truncate -s $((size / 2)) "$victim"
        else
            rm -f "$victim"
        fi
        wait $pid; rc=$?
        if [ $rc = 0 ] && [ -s "$out" ]; then
            echo "ok: $d, ${act}d after ${delay}s: read first, complete output"
        elif [ $rc = 1 ] && grep -q "$(basename "$victim")" "$tmp/err" && [ ! -e "$out" ]; then
            echo "ok: $d, ${act}d after ${delay}s: a clear error, no output"
        else
            echo "FAIL: $d, ${act}d after ${delay}s: exit $rc, output $(ls -d "$out" 2> /dev/null):"
            cat "$tmp/err"; failures=$((failures + 1))
        fi
    done
}
cp "$tmp/ds.sqlite" "$tmp/in.sqlite.orig"
during "fit-predictor reading a dataset" "$tmp/in.sqlite" truncate "$tmp/m2" \
    "$imsynth" fit-predictor --dataset "$tmp/in.sqlite" --components 4 --hidden 8 --batch 4 \
    --val-fraction 0.25 --epochs 1 --quiet -o "$tmp/m2"
during "forest fit reading a dataset" "$tmp/in.sqlite" delete "$tmp/f2.bin" \
    "$imsynth" forest fit --dataset "$tmp/in.sqlite" --trees 2 --quiet -o "$tmp/f2.bin"
cp "$root/assets/examples/handmade-marble.png" "$tmp/in.png.orig"
during "predict reading its image" "$tmp/in.png" truncate "$tmp/pred2" \
    "$imsynth" predict "$tmp/in.png" --model "$tmp/model" --top-k 1 --nearest 1 --refine 2 \
    --search-preset draft --final-preset draft --quiet -o "$tmp/pred2"

# Hostile sizes, under a 2 GiB address-space limit: each is refused, naming its file.
if ldd "$imsynth" 2> /dev/null | grep -q libasan; then
    echo "skipped: ulimit -v checks (AddressSanitizer reserves more address space than the limit)"
else
    py "$root/tests/cli/lib/make_images.py" png-claim "$tmp/huge.png" 100000 100000 &&
        py "$hostile" graph "$tmp/million.json" 1000000 &&
        py "$hostile" graph "$tmp/wide.json" 100000 &&
        py "$hostile" safetensors-data "$tmp/claim.safetensors" &&
        py "$hostile" safetensors-hlen "$tmp/hlen.safetensors" &&
        py "$hostile" npy "$tmp/claim.npy"
    check "hostile inputs made" 0 $?
    # refused WHAT STDERR_FRAGMENT CMD...: under the limit, CMD exits 1 and says FRAGMENT
    refused() {
        what=$1 fragment=$2
        shift 2
        (ulimit -v 2097152 && exec "$@") 2> "$tmp/err"
        check "$what" 1 $?
        expect_stderr "names the file and the claim" "$fragment"
    }
    refused "describe: a PNG claiming 100000 x 100000 pixels" "huge.png: image size 100000 x 100000" \
        "$imsynth" describe "$tmp/huge.png" -o "$tmp/h.npy"
    refused "predict: the same PNG" "huge.png: image size 100000 x 100000" \
        "$imsynth" predict "$tmp/huge.png" --model "$tmp/model" -o "$tmp/h"
    refused "render: a graph of a million nodes (124 MiB)" "million.json: larger than the 16777216 bytes" \
        "$imsynth" render "$tmp/million.json" -o "$tmp/h.exr"
    refused "render: 100,000 nodes in 12 MiB" "wide.json: nodes: 100002 nodes, more than the 10000" \
        "$imsynth" render "$tmp/wide.json" -o "$tmp/h.exr"
    refused "infer: a safetensors tensor claiming 10^12 bytes" \
        "claim.safetensors: tensor \"w\": shape is larger than the file" \
        "$imsynth" infer "$tmp/claim.safetensors" --x "$ref/x.npy" -o "$tmp/h.npy"
    refused "infer: a safetensors header length of 10^12 bytes" \
        "hlen.safetensors: header length 1000000000000 runs past" \
        "$imsynth" infer "$tmp/hlen.safetensors" --x "$ref/x.npy" -o "$tmp/h.npy"
    refused "train: an .npy claiming 100000 x 100000 floats" \
        "claim.npy: data is 64 bytes, header (shape 100000 x 100000, '<f4') says 40000000000" \
        "$imsynth" train --x "$tmp/claim.npy" --y "$ref/y.npy" --arch "mlp:16-8-13" -o "$tmp/h.safetensors"
    for f in h.npy h h.exr h.safetensors; do
        [ ! -e "$tmp/$f" ] || { echo "FAIL: $f written"; failures=$((failures + 1)); }
    done
fi
finish
