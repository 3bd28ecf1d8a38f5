#!/bin/sh
# The Blender add-on (blender/imsynth_addon.py) installed from its zip and run headless by
# tests/blender/test_addon.py in each Blender there is:
# - 3.4 (`blender` on PATH): the operator runs this build's imsynth predict on an example
#   photo with a tiny model, after two errors it must report (no active mesh object, an
#   unreadable image named in imsynth's stderr);
# - 4.3 (the Debian trixie chroot /srv/trixie, when present): the host's imsynth cannot
#   run there (the chroot lacks its libraries, libembree3 among them; probed below) nor
#   see the build tree, so imsynth predicts OUTDIR here (--blender 4) and the add-on's
#   import_result, the operator's last step, imports it inside the chroot.
# Both check the material's node count against import_material, the comparison image and
# a tiny Cycles render. With xvfb-run, tests/blender/test_addon_ui.py also runs the
# operator in 3.4 with a window, as a user does. Also: make_addon_zip.py is deterministic and packs the 3 files.
# Without any Blender: "skip" and exit 0 (CI machines may have none).
# Usage: addon.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
chroot_root=/srv/trixie

have34=0; have43=0
command -v blender > /dev/null 2>&1 && have34=1
if [ -x "$chroot_root/usr/bin/blender" ]; then
    if [ "$(id -u)" = 0 ]; then have43=1; else echo "skip: Blender 4.3: chroot needs root"; fi
fi
if [ $have34 = 0 ] && [ $have43 = 0 ]; then
    echo "skip: no Blender (neither blender on PATH nor $chroot_root/usr/bin/blender)"
    exit 0
fi

py "$root/blender/make_addon_zip.py" -o "$tmp/imsynth_addon.zip" > /dev/null
check "make_addon_zip.py writes the zip" 0 $?
py "$root/blender/make_addon_zip.py" -o "$tmp/again.zip" > /dev/null
cmp -s "$tmp/imsynth_addon.zip" "$tmp/again.zip"
check "the zip is the same bytes when made again" 0 $?
py - "$tmp/imsynth_addon.zip" << 'PY'
import sys, zipfile
names = sorted(zipfile.ZipFile(sys.argv[1]).namelist())
want = sorted("imsynth_addon/" + n for n in ("__init__.py", "import_material.py", "compat_noise.py"))
assert names == want, names
PY
check "the zip holds imsynth_addon/{__init__,import_material,compat_noise}.py" 0 $?

"$imsynth" datagen --out "$tmp/ds.sqlite" --count 24 --preset draft --quiet
check "a draft dataset" 0 $?
"$imsynth" fit-predictor --dataset "$tmp/ds.sqlite" --components 8 --hidden 16 --batch 8 \
    --val-fraction 0.2 --epochs 3 --quiet -o "$tmp/model"
check "a small model" 0 $?

image="$root/assets/examples/handmade-wood_planks.png"
fast="--refine 2 --top-k 1 --nearest 1 --search-preset draft --final-preset draft"
# A Blender's output is kept in a log and shown only when its test fails.
run_blender() { # description, log, command...
    what=$1; log=$2; shift 2
    "$@" > "$log" 2>&1
    rc=$?
    check "$what" 0 $rc
    [ $rc = 0 ] || { grep -v '^Fra:' "$log" | tail -40; }
}

if [ $have34 = 1 ]; then
    mkdir "$tmp/w34"
    run_blender "blender on PATH: install, enable, Material from image on a plane" "$tmp/b34.log" \
        env BLENDER_USER_SCRIPTS="$tmp/scripts34" \
        blender -b --factory-startup --python-exit-code 1 \
        -P "$root/tests/blender/test_addon.py" -- --zip "$tmp/imsynth_addon.zip" \
        --image "$image" --work "$tmp/w34" --imsynth "$imsynth" --model "$tmp/model" \
        --extra "$fast"
    # The interactive path (the operator goes modal, polls imsynth from a timer, opens a
    # window for compare.png) needs a display: a virtual one, when xvfb-run is there.
    # TMPDIR keeps Blender's session files (quit.blend) in the scratch folder.
    if command -v xvfb-run > /dev/null 2>&1; then
        mkdir "$tmp/wui" "$tmp/tmpui"
        TMPDIR="$tmp/tmpui" BLENDER_USER_SCRIPTS="$tmp/scriptsui" timeout 180 \
            xvfb-run -a -s "-screen 0 1280x800x24" blender --factory-startup \
            -P "$root/tests/blender/test_addon_ui.py" -- --zip "$tmp/imsynth_addon.zip" \
            --image "$image" --work "$tmp/wui" --imsynth "$imsynth" --model "$tmp/model" \
            --extra "$fast" > "$tmp/ui.log" 2>&1
        grep -q "^test_addon_ui: all ok" "$tmp/ui.log"
        rc=$?
        check "blender on PATH, with a window: modal run, compare.png in a new window" 0 $rc
        [ $rc = 0 ] || tail -40 "$tmp/ui.log"
    else
        echo "skip: no xvfb-run: the interactive path (modal run, image window) is untested"
    fi
else
    echo "skip: no blender on PATH"
fi

if [ $have43 = 1 ]; then
    # Everything the chroot's Blender reads must be under the chroot (as in
    # blender/render_node_references.py); removed on exit with $tmp.
    ctmp=$(mktemp -d "$chroot_root/tmp/imsynth-addon-XXXXXX")
    trap 'rm -rf "$tmp" "$ctmp"' EXIT
    inside=${ctmp#"$chroot_root"}
    cp "$imsynth" "$ctmp/imsynth"
    if chroot "$chroot_root" "$inside/imsynth" --version > /dev/null 2>&1; then
        echo "note: the host's imsynth runs in the chroot; 4.3 still imports a host OUTDIR"
    fi
    rm -f "$ctmp/imsynth"
    "$imsynth" predict "$image" -o "$ctmp/predicted" --model "$tmp/model" $fast --blender 4 \
        --quiet 2> "$tmp/err"
    check "imsynth predict for Blender 4 (on the host)" 0 $?
    cp "$tmp/imsynth_addon.zip" "$root/tests/blender/test_addon.py" "$image" "$ctmp/"
    mkdir "$ctmp/w43"
    run_blender "Blender 4.3: install, enable, import_result of a prediction on a plane" \
        "$tmp/b43.log" chroot "$chroot_root" env BLENDER_USER_SCRIPTS="$inside/scripts" \
        blender -b --factory-startup --python-exit-code 1 -P "$inside/test_addon.py" -- \
        --zip "$inside/imsynth_addon.zip" --image "$inside/$(basename "$image")" \
        --work "$inside/w43" --outdir "$inside/predicted"
fi
finish
