#!/bin/sh
# imsynth extract / export end to end. Usage: extract.sh IMSYNTH REPO_ROOT
set -u
imsynth=$1
root=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$root" || exit 1
passed=0
failed=0
check() { # description, expected exit code, actual exit code
    if [ "$2" = "$3" ]; then passed=$((passed + 1)); else
        echo "FAIL: $1: exit $3, expected $2"; cat "$tmp/err" 2>/dev/null; failed=$((failed + 1)); fi
}

"$imsynth" extract --seed 7 -o "$tmp/sub.json" --stats 2> "$tmp/err"; check "extract --seed" 0 $?
# The sub-shader is a small valid graph that evaluates like the super-shader.
nodes=$(sed -n 's/.*-> \([0-9]*\) nodes.*/\1/p' "$tmp/err")
[ -n "$nodes" ] && [ "$nodes" -le 60 ] && passed=$((passed + 1)) || { echo "FAIL: node count '$nodes'"; failed=$((failed + 1)); }
"$imsynth" export assets/supershader.json --seed 7 --full -o "$tmp/super.json" 2> "$tmp/err"; check "export --full" 0 $?
for g in sub super; do
    "$imsynth" eval-graph "$tmp/$g.json" --socket "Principled BSDF:Base Color" -o "$tmp/$g.exr" --size 16 2> "$tmp/err"
    check "eval $g" 0 $?
done
cmp -s "$tmp/sub.exr" "$tmp/super.exr" && passed=$((passed + 1)) || { echo "FAIL: sub-shader and super-shader images differ"; failed=$((failed + 1)); }

"$imsynth" sample --seed 7 -o "$tmp/p.json" 2> "$tmp/err"; check "sample" 0 $?
"$imsynth" extract --params "$tmp/p.json" -o "$tmp/sub2.json" 2> "$tmp/err"; check "extract --params" 0 $?
cmp -s "$tmp/sub.json" "$tmp/sub2.json" && passed=$((passed + 1)) || { echo "FAIL: --params and --seed differ"; failed=$((failed + 1)); }

printf '{"nope": 0.5}' > "$tmp/bad.json"
"$imsynth" extract --params "$tmp/bad.json" -o "$tmp/x.json" 2> "$tmp/err"; check "bad params file" 1 $?
grep -q "bad.json" "$tmp/err" && passed=$((passed + 1)) || { echo "FAIL: message lacks the file name"; failed=$((failed + 1)); }
[ -e "$tmp/x.json" ] && { echo "FAIL: output written for bad params"; failed=$((failed + 1)); }
"$imsynth" extract --seed 1 --params "$tmp/p.json" -o "$tmp/x.json" 2> "$tmp/err"; check "--seed and --params" 2 $?
"$imsynth" export --seed 1 2> "$tmp/err"; check "missing -o" 2 $?

# --texture-rotation: the same material turned (one Mapping node more, evaluating to the
# unturned image turned clockwise: tests/unit/test_texture_rotation.c); 360 is no turn
"$imsynth" extract --seed 7 --texture-rotation 90 -o "$tmp/turned.json" 2> "$tmp/err"; check "extract --texture-rotation 90" 0 $?
[ "$(grep -c '"ShaderNodeMapping"' "$tmp/turned.json")" = 1 ] && ! grep -q '"ShaderNodeMapping"' "$tmp/sub.json" &&
    passed=$((passed + 1)) || { echo "FAIL: the turn is not one Mapping node"; failed=$((failed + 1)); }
"$imsynth" export --seed 7 --texture-rotation 360 -o "$tmp/t360.json" 2> "$tmp/err"; check "export --texture-rotation 360" 0 $?
"$imsynth" eval-graph "$tmp/t360.json" --socket "Principled BSDF:Base Color" -o "$tmp/t360.exr" --size 16 2> "$tmp/err"
cmp -s "$tmp/t360.exr" "$tmp/sub.exr" && passed=$((passed + 1)) || { echo "FAIL: a turn of 360 changed the material"; failed=$((failed + 1)); }
for bad in abc nan 400; do
    "$imsynth" extract --seed 7 --texture-rotation $bad -o "$tmp/x.json" 2> "$tmp/err"; check "--texture-rotation $bad" 2 $?
done

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
