#!/bin/sh
# imsynth compare end to end on a committed Cycles reference (its two halves): exit codes,
# --json parses and its numbers are consistent (rmse > 0, rmse_converged <= rmse, an image
# against itself 0), errors name the file. Usage: compare.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
# json_true description, python expression over the parsed object j (stdout in $tmp/out)
# and ab (the A against B result, once saved)
json_true() {
    if python3 -c 'import json, math, sys
j = json.load(open(sys.argv[1]))
ab = json.load(open(sys.argv[3])) if len(sys.argv) > 3 else None
sys.exit(0 if eval(sys.argv[2]) else 1)' "$tmp/out" "$2" $(ls "$tmp/ab.json" 2> /dev/null); then echo "ok: $1"; else
        echo "FAIL: $1: not $2 in:"; cat "$tmp/out"; failures=$((failures + 1)); fi
}
a="$root/tests/reference/render/diffuse_grey/blender-4.3-a.exr"
b="$root/tests/reference/render/diffuse_grey/blender-4.3-b.exr"

"$imsynth" compare --help > "$tmp/out"; check "compare --help" 0 $?
"$imsynth" compare "$a" 2> "$tmp/err"; check "one image" 2 $?
"$imsynth" compare "$a" "$b" "$a" "$b" 2> "$tmp/err"; check "four images" 2 $?
"$imsynth" compare "$a" "$b" --frobnicate 2> "$tmp/err"; check "unknown option" 2 $?
expect_stderr "names the option" "frobnicate"
"$imsynth" compare "$a" "$tmp/missing.exr" 2> "$tmp/err"; check "missing reference" 1 $?
expect_stderr "names the missing file" "missing.exr"
"$imsynth" compare "$tmp/missing.exr" "$a" "$b" 2> "$tmp/err"; check "missing image" 1 $?
expect_stderr "names the missing image" "missing.exr"
"$imsynth" compare "$a" "$root/tests/reference/render/diffuse_grey/graph.json" 2> "$tmp/err"
check "not an image" 1 $?
expect_stderr "names the non-image" "graph.json"
"$imsynth" eval-graph "$root/assets/examples/marble.json" --socket "Principled BSDF:Base Color" \
    --size 16 -o "$tmp/small.exr" > /dev/null; check "a 16 x 16 image" 0 $?
"$imsynth" compare "$tmp/small.exr" "$a" 2> "$tmp/err"; check "sizes differ" 1 $?
expect_stderr "gives the sizes and names the files" "16 x 16 with 3 channels.*small.exr"

"$imsynth" compare "$a" "$b" > "$tmp/out"; check "A against B" 0 $?
expect_stdout "text has rmse" "^rmse  "
expect_stdout "text has the worst block" "^worst block .*at block"
"$imsynth" compare "$a" "$a" "$b" > "$tmp/out"; check "A against A + B" 0 $?
expect_stdout "text has rmse converged with B" "^rmse converged"

if command -v python3 > /dev/null; then
    "$imsynth" compare "$a" "$b" --json > "$tmp/out"; check "--json" 0 $?
    python3 -c 'import json, sys; json.load(sys.stdin)' < "$tmp/out"; check "JSON parses" 0 $?
    json_true "rmse > 0 between the halves" 'j["rmse"] > 0 and j["mae"] > 0'
    json_true "all keys, no B keys without B" \
        'set(j) == {"ref_mean", "rmse", "mae", "bias", "worst_block", "worst_block_x", "worst_block_y"} and len(j["bias"]) == 3'
    json_true "mae <= rmse" 'j["mae"] <= j["rmse"]'
    cp "$tmp/out" "$tmp/ab.json"

    # A third independent image (the 3.4 render of the same case) against the mean of the
    # 4.3 halves: the converged estimate takes the reference's noise out.
    c="$root/tests/reference/render/diffuse_grey/blender-3.4-a.exr"
    "$imsynth" compare --json "$c" "$a" "$b" > "$tmp/out"; check "--json with B" 0 $?
    json_true "B keys present" '"ref_noise_rmse" in j and "rmse_converged" in j'
    json_true "0 <= rmse_converged <= rmse" '0 <= j["rmse_converged"] <= j["rmse"]'
    json_true "ref noise is half the RMS of A - B" \
        'j["ref_noise_rmse"] > 0 and math.isclose(j["ref_noise_rmse"], ab["rmse"] / 2, rel_tol=1e-6)'
    json_true "rmse^2 = converged^2 + noise^2 (when not clamped)" \
        'j["rmse_converged"] == 0 or math.isclose(j["rmse"]**2, j["rmse_converged"]**2 + j["ref_noise_rmse"]**2, rel_tol=1e-6)'

    "$imsynth" compare "$a" "$a" --json > "$tmp/out"; check "an image against itself" 0 $?
    json_true "itself: rmse 0" 'j["rmse"] == 0 and j["mae"] == 0 and j["worst_block"] == 0 and j["bias"] == [0, 0, 0]'
    json_true "ref_mean > 0" 'j["ref_mean"] > 0'
fi

finish
