#!/bin/sh
# `cmake --install` lays out a prefix whose imsynth finds its data from any directory:
# the installed binary uses P/share/imsynth, not the source tree; --data and $IMSYNTH_DATA
# override it. Usage: install.sh IMSYNTH REPO_ROOT (the build tree is IMSYNTH's ../..)
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
build=$(cd "$(dirname "$imsynth")/.." && pwd)
cmake --install "$build" --prefix "$tmp/prefix" > "$tmp/install.log" 2>&1; check "cmake --install" 0 $?
p="$tmp/prefix"
for f in bin/imsynth lib/imsynth/libimsynth_oiio.so share/imsynth/assets/supershader.json share/imsynth/assets/scene.json \
         share/imsynth/assets/scene-flash.json share/imsynth/blender/import_material.py; do
    if [ -e "$p/$f" ]; then echo "ok: installs $f"; else echo "FAIL: no $f"; failures=$((failures + 1)); fi
done
(cd / && "$p/bin/imsynth" --version) > "$tmp/out"; check "installed --version" 0 $?
expect_stdout "the installed binary uses the installed data" "data: $p/bin/../share/imsynth/assets/supershader.json"
(cd / && "$p/bin/imsynth" sample --seed 3) > "$tmp/out"; check "installed sample from /" 0 $?
expect_stdout "a parameter set" "Mult 11 Noise A Pattern"
(cd / && "$p/bin/imsynth" --data "$root" --version) > "$tmp/out"
expect_stdout "--data overrides" "data: $root/assets/supershader.json"
(cd / && IMSYNTH_DATA="$tmp/nowhere" "$p/bin/imsynth" sample --seed 3) 2> "$tmp/err" > /dev/null
check "a wrong IMSYNTH_DATA falls back to the installation" 0 $?
(cd "$tmp" && "$p/bin/imsynth" datagen --out ds.sqlite --count 1 --preset draft --descriptor none --quiet)
check "installed datagen from another directory" 0 $?
# OpenImageIO is a module loaded at the first image read (imageio/oiio_module.c): a command
# that reads no image does not load it, one that does loads the installed module.
(cd / && LD_DEBUG=files "$p/bin/imsynth" sample --seed 3) > /dev/null 2> "$tmp/ld"
check "installed sample" 0 $?
grep -q 'libOpenImageIO' "$tmp/ld" && { echo "FAIL: sample loaded OpenImageIO"; failures=$((failures + 1)); } ||
    echo "ok: a command without images does not load OpenImageIO"
(cd / && LD_DEBUG=files "$p/bin/imsynth" compare "$root/assets/examples/handmade-marble.png" \
    "$root/assets/examples/handmade-marble.png") > /dev/null 2> "$tmp/ld"
check "installed compare of two PNGs" 0 $?
grep -q "file=$p/bin/../lib/imsynth/libimsynth_oiio.so" "$tmp/ld"
check "the installed binary loads the installed module" 0 $?
(cd / && "$p/bin/imsynth" predict "$root/assets/examples/handmade-wood_planks.png" -o "$tmp/pred" \
    --refine 1 --top-k 1 --nearest 1 --search-preset draft --final-preset draft --quiet)
check "installed predict from / with the bundled model" 0 $?
grep -q "\"model\":.*$p/bin/../share/imsynth/assets/model" "$tmp/pred/report.json"
check "the installed predict uses the installed model" 0 $?
finish
