#!/bin/sh
# Runs every libFuzzer harness for SECONDS on a copy of its seed corpus, one after another,
# and prints per harness: executions, coverage (libFuzzer's final "cov:" edges), result.
# Builds nothing: give it a tree configured with -DIMSYNTH_FUZZ=ON (tests/fuzz/README.md).
#
# Usage: sh tests/fuzz/run.sh SECONDS [BUILD_DIR] [HARNESS...]
#   BUILD_DIR  default $IMSYNTH_FUZZ_BUILD, else build-fuzz
#   HARNESS    e.g. graph npy (default: all nine)
# Exit status: 0 when no harness crashed, leaked, timed out or ran out of memory; else 1,
# with each failing input saved as BUILD_DIR/fuzz-artifacts/<harness>/<kind>-<sha1> and the
# fuzzer's log beside it. The corpus copy is discarded, so runs never add files to the repo.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
[ $# -ge 1 ] || { echo "usage: run.sh SECONDS [BUILD_DIR] [HARNESS...]" >&2; exit 2; }
seconds=$1
shift
build=${IMSYNTH_FUZZ_BUILD:-$root/build-fuzz}
if [ $# -ge 1 ] && [ -d "$1" ]; then
    build=$(cd "$1" && pwd)
    shift
fi
harnesses=${*:-graph params safetensors npy image forest dataset model scene}
art=$build/fuzz-artifacts
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT INT TERM

# Leaks are failures; UB already aborts (compiled with -fno-sanitize-recover).
# intercept_tls_get_addr=0: scripts/test says why (the leak scan's dynamic-TLS bug, hit by
# harnesses that dlopen the OpenImageIO module).
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1:intercept_tls_get_addr=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"

failed=0
printf '%-12s %8s %10s %8s  %s\n' harness seconds execs cov result
for h in $harnesses; do
    bin=$build/tests/fuzz/fuzz_$h
    if [ ! -x "$bin" ]; then
        echo "run.sh: $bin missing: configure with -DIMSYNTH_FUZZ=ON and build" >&2
        exit 2
    fi
    # The harnesses' input files go under TMPDIR; a crashing process cannot remove its
    # own, so each run gets one inside this script's temporary directory.
    mkdir -p "$tmp/$h" "$tmp/tmpdir-$h" "$art/$h"
    cp "$root/tests/fuzz/corpus/$h"/* "$tmp/$h/" 2> /dev/null || true
    log=$art/$h/last-run.log
    rc=0
    dict=""
    [ -f "$root/tests/fuzz/$h.dict" ] && dict="-dict=$root/tests/fuzz/$h.dict"
    # -timeout: an input taking 10 s is a hang; -rss_limit_mb also bounds single mallocs.
    # -close_fd_mask=3: libraries under the parsers (libpng through OpenImageIO) print
    # their own complaints; libFuzzer and the sanitizers still report on a saved stderr.
    TMPDIR="$tmp/tmpdir-$h" "$bin" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 -close_fd_mask=3 $dict \
        -artifact_prefix="$art/$h/" "$tmp/$h" > "$log" 2>&1 || rc=$?
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | cut -d' ' -f2)
    if [ "$rc" -eq 0 ]; then
        result=ok
    else
        failed=1
        input=$(sed -n 's/.*Test unit written to //p' "$log" | tail -n 1)
        kind=$(grep -o 'ERROR: [A-Za-z]*: [a-z-]*\|ERROR: libFuzzer: [a-z-]*\|runtime error' "$log" \
               | head -n 1 || true)
        result="FAILED (${kind:-exit $rc}): ${input:-no input saved}; log $log"
    fi
    printf '%-12s %8s %10s %8s  %s\n' "$h" "$seconds" "${execs:-?}" "${cov:-?}" "$result"
done
exit $failed
