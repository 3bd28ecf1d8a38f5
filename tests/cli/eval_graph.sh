#!/bin/sh
# imsynth eval-graph end to end: output files, exit codes, and error messages that
# name the file and the place. Usage: eval_graph.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"

"$imsynth" --version > "$tmp/out"; check "--version" 0 $?
grep -q "^imsynth [0-9]" "$tmp/out" || { echo "FAIL: version text"; failures=$((failures + 1)); }
"$imsynth" eval-graph --help > "$tmp/out"; check "eval-graph --help" 0 $?
"$imsynth" nonsense 2> "$tmp/err"; check "unknown command" 2 $?
"$imsynth" eval-graph 2> "$tmp/err"; check "missing arguments" 2 $?
"$imsynth" eval-graph x.json --socket A:B -o x.exr --size 0 2> "$tmp/err"; check "bad --size" 2 $?

"$imsynth" eval-graph "$root/assets/examples/marble.json" --socket "Principled BSDF:Base Color" \
    -o "$tmp/m.exr" --png "$tmp/m.png" --size 32; check "marble" 0 $?
[ -s "$tmp/m.exr" ] && [ -s "$tmp/m.png" ] || { echo "FAIL: outputs missing"; failures=$((failures + 1)); }
ls "$tmp" | grep -q tmp && { echo "FAIL: temporary file left behind"; failures=$((failures + 1)); }

printf '{"format": "imsynth-graph/1", "nodes": [\n  {"name": "M", "type": "ShaderNodeMathh"}], "links": []}' > "$tmp/bad.json"
"$imsynth" eval-graph "$tmp/bad.json" --socket M:Value -o "$tmp/b.exr" 2> "$tmp/err"; check "unknown node type" 1 $?
expect_stderr "message names the file" "bad.json"
expect_stderr "message names the node" 'nodes\[0\] "M"'
[ -e "$tmp/b.exr" ] && { echo "FAIL: output written for a bad graph"; failures=$((failures + 1)); }

printf '{"format": "imsynth-graph/1", "nodes": [' > "$tmp/trunc.json"
"$imsynth" eval-graph "$tmp/trunc.json" --socket M:Value -o "$tmp/b.exr" 2> "$tmp/err"; check "truncated JSON" 1 $?
expect_stderr "line and column" "trunc.json:1:"

"$imsynth" eval-graph "$root/assets/examples/marble.json" --socket "Nope:Fac" -o "$tmp/b.exr" 2> "$tmp/err"
check "unknown socket node" 1 $?
expect_stderr "names the missing node" "Nope"

"$imsynth" eval-graph "$root/assets/examples/marble.json" --socket "Principled BSDF:Base Color" \
    -o "$tmp/no/such/dir/m.exr" 2> "$tmp/err"; check "unwritable output" 1 $?

echo "$failures failed"
[ "$failures" -eq 0 ]
