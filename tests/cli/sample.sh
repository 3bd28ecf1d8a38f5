#!/bin/sh
# imsynth sample end to end, and the super-shader asset in step with its generator:
# exit codes, 50 parameters a frame, determinism, -o equal to stdout, --bound-graph
# evaluates, errors naming the file. Usage: sample.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
same() { # description, file, file
    if cmp -s "$2" "$3"; then echo "ok: $1"; else
        echo "FAIL: $1: $2 and $3 differ"; failures=$((failures + 1)); fi
}
graph="$root/assets/supershader.json"

"$imsynth" sample --help > "$tmp/out"; check "sample --help" 0 $?
"$imsynth" sample --graph "$graph" 2> "$tmp/err"; check "no --seed" 2 $?
"$imsynth" sample --seed -3 --graph "$graph" 2> "$tmp/err"; check "negative seed" 2 $?
expect_stderr "seed message" "expected an integer"
"$imsynth" sample --seed 12x --graph "$graph" 2> "$tmp/err"; check "bad seed" 2 $?
"$imsynth" sample --seed 1 --frobnicate 2> "$tmp/err"; check "unknown option" 2 $?
"$imsynth" sample --seed 1 --graph "$root/assets/examples/marble.json" 2> "$tmp/err"
check "graph without parameters" 1 $?
expect_stderr "names the file and the group" "marble.json.*RandomValues"
"$imsynth" sample --seed 1 --graph "$tmp/missing.json" 2> "$tmp/err"; check "missing graph" 1 $?
expect_stderr "names the missing file" "missing.json"

"$imsynth" sample --seed 5 --graph "$graph" > "$tmp/a.json"; check "frame 5" 0 $?
n=$(grep -c '^  "' "$tmp/a.json")
if [ "$n" = 50 ]; then echo "ok: 50 parameters"; else
    echo "FAIL: $n parameters, expected 50"; failures=$((failures + 1)); fi
"$imsynth" sample --seed 5 --graph "$graph" > "$tmp/b.json"
same "frame 5 twice" "$tmp/a.json" "$tmp/b.json"
"$imsynth" sample --seed 5 --graph "$graph" -o "$tmp/c.json"; check "-o" 0 $?
same "-o equals stdout" "$tmp/a.json" "$tmp/c.json"
"$imsynth" sample --seed 6 --graph "$graph" > "$tmp/d.json"
if cmp -s "$tmp/a.json" "$tmp/d.json"; then
    echo "FAIL: frames 5 and 6 are the same"; failures=$((failures + 1)); else echo "ok: frames differ"; fi
"$imsynth" sample --seed 5 --graph "$graph" -o "$tmp/nodir/p.json" 2> "$tmp/err"
check "unwritable -o" 1 $?
expect_stderr "names the output" "nodir/p.json"

"$imsynth" sample --seed 5 --graph "$graph" -o "$tmp/p.json" --bound-graph "$tmp/g.json"
check "--bound-graph" 0 $?
"$imsynth" eval-graph "$tmp/g.json" --socket "Principled BSDF:Base Color" --size 16 \
    -o "$tmp/g.exr" > /dev/null; check "bound graph evaluates" 0 $?
if grep -q '"Mult 11 Noise A Pattern"' "$tmp/g.json"; then echo "ok: bound graph keeps names"; else
    echo "FAIL: bound graph lacks the parameter group"; failures=$((failures + 1)); fi
ls "$tmp" | grep -q 'tmp' && { echo "FAIL: temporary file left"; failures=$((failures + 1)); }

# The committed asset is what its generator writes (change the generator, not the JSON).
if command -v python3 > /dev/null; then
    python3 "$root/assets/generate_supershader.py" -o "$tmp/s.json" --markdown "$tmp/s.md" > /dev/null
    check "generator runs" 0 $?
    same "assets/supershader.json is generated" "$graph" "$tmp/s.json"
    same "assets/supershader.md is generated" "$root/assets/supershader.md" "$tmp/s.md"
fi

finish
