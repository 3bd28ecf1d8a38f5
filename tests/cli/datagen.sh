#!/bin/sh
# imsynth datagen and dataset end to end: usage errors; the same bytes for any thread
# count, batch size and shard split (3 shards as separate processes, merged, equal one
# unsharded run row for row); kill -9 at random moments and resume equals an uninterrupted
# run; SIGINT stops cleanly; config mismatches, duplicate ids, bad and unwritable files are
# clear errors; export and sheet. Usage: datagen.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
same_digest() { # description, dataset, dataset
    a=$(dataset_digest "$2"); b=$(dataset_digest "$3")
    if [ -n "$a" ] && [ "$a" = "$b" ]; then echo "ok: $1"; else
        echo "FAIL: $1: digests $a and $b"; failures=$((failures + 1)); fi
}
quick=${IMSYNTH_TEST_QUICK:-}
aug="views=1,light=0.1,flash=0.5,exposure=0.5,wb=0.1,rotate=30,shift=0.3"
common="--preset draft --first-id 100 --quiet"

"$imsynth" datagen --help > "$tmp/out"; check "datagen --help" 0 $?
"$imsynth" dataset --help > "$tmp/out"; check "dataset --help" 0 $?
"$imsynth" datagen --count 3 2> "$tmp/err"; check "no --out" 2 $?
"$imsynth" datagen --out "$tmp/x.sqlite" --count 3 --shard 3/3 2> "$tmp/err"; check "shard index out of range" 2 $?
"$imsynth" datagen --out "$tmp/x.sqlite" --count 3 --preset fancy 2> "$tmp/err"; check "unknown preset" 2 $?
expect_stderr "names the presets" "draft, datagen, converged"
"$imsynth" datagen --out "$tmp/x.sqlite" --count 3 --augment views=x 2> "$tmp/err"; check "bad augment" 2 $?
"$imsynth" datagen --out "$tmp/x.sqlite" --count 3 --shard SLURM/4 2> "$tmp/err"; check "SLURM shard without the variable" 2 $?
expect_stderr "names the variable" "SLURM_ARRAY_TASK_ID"

# One run with augmentation and descriptors; the same with other threads and batches.
n=4; [ -n "$quick" ] && n=2
"$imsynth" datagen --out "$tmp/a.sqlite" --count $n $common --augment "$aug" --threads 1 --batch 4
check "datagen, 1 thread" 0 $?
"$imsynth" dataset info "$tmp/a.sqlite" > "$tmp/out"; check "info" 0 $?
expect_stdout "samples counted" "samples          $n ($((2 * n)) rows"
expect_stdout "descriptor size (MobileNetV2, the default)" "38808 floats"
"$imsynth" datagen --out "$tmp/b.sqlite" --count $n $common --augment "$aug" --threads 2 --batch 1
check "datagen, 2 threads, batch 1" 0 $?
same_digest "same bytes for 1 and 2 threads, batch 4 and 1" "$tmp/a.sqlite" "$tmp/b.sqlite"

# Three shards as separate processes at once, merged.
for i in 0 1 2; do
    "$imsynth" datagen --out "$tmp/s$i.sqlite" --count $n $common --augment "$aug" --threads 1 --shard $i/3 &
done
wait
"$imsynth" dataset merge "$tmp/s0.sqlite" "$tmp/s1.sqlite" "$tmp/s2.sqlite" -o "$tmp/m.sqlite"
check "merge 3 shards" 0 $?
same_digest "merge(shards) equals the unsharded run" "$tmp/a.sqlite" "$tmp/m.sqlite"
JOB_COMPLETION_INDEX=1 "$imsynth" datagen --out "$tmp/k1.sqlite" --count $n $common --augment "$aug" --shard JOB_COMPLETION/3
check "shard index from JOB_COMPLETION_INDEX" 0 $?
same_digest "Kubernetes shard 1 equals shard 1" "$tmp/s1.sqlite" "$tmp/k1.sqlite"
"$imsynth" dataset merge "$tmp/a.sqlite" "$tmp/s1.sqlite" -o "$tmp/dup.sqlite" 2> "$tmp/err"
check "merge refuses duplicate ids" 1 $?
expect_stderr "names the id and file" "id 10[0-9] is in .*s1.sqlite"
[ ! -e "$tmp/dup.sqlite" ] && echo "ok: no partial merge output" || { echo "FAIL: partial merge output"; failures=$((failures + 1)); }

# A different config against the same file, and merging different configs.
"$imsynth" datagen --out "$tmp/a.sqlite" --count $n $common 2> "$tmp/err"
check "another config against the same file" 1 $?
expect_stderr "says which setting differs" "another config (.* there, .* here)"
"$imsynth" datagen --out "$tmp/c.sqlite" --count 2 --first-id 500 --preset draft --descriptor none --quiet
check "a dataset without descriptors" 0 $?
"$imsynth" dataset merge "$tmp/a.sqlite" "$tmp/c.sqlite" -o "$tmp/mix.sqlite" 2> "$tmp/err"
check "merge refuses mismatched configs" 1 $?
expect_stderr "names both files" "a.sqlite and .*c.sqlite"
# A dataset begun before the active rule was recorded (its masks could mark an unused
# selector active) is not resumed under the new rule
cp "$tmp/c.sqlite" "$tmp/old.sqlite"
/usr/bin/python3 - "$tmp/old.sqlite" << 'PY'
import hashlib, json, sqlite3, sys
db = sqlite3.connect(sys.argv[1])
c = json.loads(db.execute("SELECT value FROM meta WHERE key = 'config'").fetchone()[0])
del c["active_rule"]
text = json.dumps(c)
db.execute("UPDATE meta SET value = ? WHERE key = 'config'", (text,))
db.execute("UPDATE meta SET value = ? WHERE key = 'config_hash'",
           (hashlib.sha256(text.encode()).hexdigest(),))
db.commit()
PY
"$imsynth" datagen --out "$tmp/old.sqlite" --count 3 --first-id 500 --preset draft --descriptor none --quiet 2> "$tmp/err"
check "a dataset of the old active rule is not resumed" 1 $?
expect_stderr "says the rule is missing there" '"active_rule" is missing there, 2 here'

# kill -9 at random moments, then resume: equal to an uninterrupted run.
kills=20; [ -n "$quick" ] && kills=5
kn=8; [ -n "$quick" ] && kn=4
kopt="--count $kn --preset draft --descriptor none --batch 1 --threads 2 --quiet"
"$imsynth" datagen --out "$tmp/ref.sqlite" $kopt; check "uninterrupted run" 0 $?
i=0
moments=""
while [ $i -lt $kills ]; do
    "$imsynth" datagen --out "$tmp/killed.sqlite" $kopt &
    pid=$!
    t=$(awk -v s=$i 'BEGIN { srand(s + 7); printf "%.2f", rand() * 0.6 }')
    moments="$moments $t"
    sleep "$t"
    kill -9 $pid 2> /dev/null
    wait $pid 2> /dev/null
    i=$((i + 1))
done
echo "killed at:$moments s"
"$imsynth" datagen --out "$tmp/killed.sqlite" $kopt; check "resume after $kills kills" 0 $?
same_digest "killed and resumed equals uninterrupted" "$tmp/ref.sqlite" "$tmp/killed.sqlite"

# SIGINT stops after the batch in progress; the file is sound and resumable.
"$imsynth" datagen --out "$tmp/int.sqlite" $kopt &
pid=$!
sleep 0.6
kill -INT $pid
wait $pid; rc=$?
if [ $rc = 130 ] || [ $rc = 0 ]; then echo "ok: SIGINT exit $rc"; else echo "FAIL: SIGINT exit $rc"; failures=$((failures + 1)); fi
"$imsynth" datagen --out "$tmp/int.sqlite" $kopt; check "resume after SIGINT" 0 $?
same_digest "interrupted and resumed equals uninterrupted" "$tmp/ref.sqlite" "$tmp/int.sqlite"

# Export and sheet.
"$imsynth" dataset export "$tmp/a.sqlite" --npy "$tmp/npy"; check "export" 0 $?
for f in ids views params active descriptors; do
    if [ -s "$tmp/npy/$f.npy" ]; then echo "ok: $f.npy"; else echo "FAIL: no $f.npy"; failures=$((failures + 1)); fi
done
grep -a -q "'shape': ($((2 * n)), 38808)" "$tmp/npy/descriptors.npy" && echo "ok: descriptors shape" || { echo "FAIL: descriptors shape"; failures=$((failures + 1)); }
grep -a -q "'descr': '|u1'.*'shape': ($((2 * n)), 50)" "$tmp/npy/active.npy" && echo "ok: active mask shape" || { echo "FAIL: active shape"; failures=$((failures + 1)); }
"$imsynth" dataset sheet "$tmp/a.sqlite" -o "$tmp/sheet.png" --cols 4 --tile 64; check "sheet" 0 $?
"$imsynth" compare "$tmp/sheet.png" "$tmp/sheet.png" > /dev/null; check "sheet is a readable image" 0 $?

# Descriptors recomputed from the stored renders equal datagen's, whole or masked (a
# mask is an index list: c.sqlite's ids.npy, [500, 501], serves as one).
"$imsynth" datagen --out "$tmp/nd.sqlite" --count $n $common --augment "$aug" --descriptor none
check "datagen without descriptors" 0 $?
"$imsynth" dataset describe "$tmp/nd.sqlite" -o "$tmp/re.sqlite"; check "dataset describe" 0 $?
same_digest "describe recomputes datagen's descriptors bit for bit" "$tmp/a.sqlite" "$tmp/re.sqlite"
"$imsynth" dataset export "$tmp/c.sqlite" --npy "$tmp/cnpy"; check "export without descriptors" 0 $?
"$imsynth" dataset describe "$tmp/nd.sqlite" -o "$tmp/rm.sqlite" --descriptor-mask "$tmp/cnpy/ids.npy"
check "describe with a feature list" 0 $?
"$imsynth" datagen --out "$tmp/dm.sqlite" --count $n $common --augment "$aug" --descriptor-mask "$tmp/cnpy/ids.npy"
check "datagen with a feature list" 0 $?
same_digest "masked datagen equals masked describe" "$tmp/dm.sqlite" "$tmp/rm.sqlite"
"$imsynth" dataset info "$tmp/dm.sqlite" > "$tmp/out"; expect_stdout "2 features stored" "descriptor       2 floats"
"$imsynth" datagen --out "$tmp/bm.sqlite" --count 1 $common --descriptor-mask "$tmp/npy/ids.npy" 2> "$tmp/err"
check "a mask that is not ascending" 1 $?
expect_stderr "names the mask and the entry" "ids.npy: entry 1"
"$imsynth" datagen --out "$tmp/v.sqlite" --count 1 $common --descriptor vgg19
check "datagen with the VGG19 descriptor" 0 $?
"$imsynth" dataset info "$tmp/v.sqlite" > "$tmp/out"; expect_stdout "VGG19 size" "305888 floats"
"$imsynth" datagen --out "$tmp/noimg.sqlite" --count 1 --first-id 700 --preset draft --images none --descriptor none --quiet
"$imsynth" dataset describe "$tmp/noimg.sqlite" -o "$tmp/x.sqlite" 2> "$tmp/err"
check "describe of a dataset without images" 1 $?
expect_stderr "says there is nothing to describe" "no stored image"

# The forest reads a dataset directly: descriptors in, parameters out, inactive ones masked.
"$imsynth" forest fit --dataset "$tmp/a.sqlite" -o "$tmp/f.bin" --trees 4 --quiet > "$tmp/out"
check "forest fit --dataset" 0 $?
expect_stdout "38808 features, 50 outputs" "38808 features -> 50 outputs"
"$imsynth" forest fit --dataset "$tmp/noimg.sqlite" -o "$tmp/f2.bin" --quiet 2> "$tmp/err"
check "forest fit on a dataset without descriptors" 1 $?
expect_stderr "says so" "no descriptors stored"

# Bad files and places.
echo "not a database" > "$tmp/text.sqlite"
"$imsynth" dataset info "$tmp/text.sqlite" 2> "$tmp/err"; check "not a database" 1 $?
expect_stderr "names the file" "text.sqlite"
head -c 3000 "$tmp/c.sqlite" > "$tmp/trunc.sqlite"
"$imsynth" dataset info "$tmp/trunc.sqlite" 2> "$tmp/err"; check "truncated database" 1 $?
expect_stderr "names the truncated file" "trunc.sqlite"
"$imsynth" dataset info "$tmp/missing.sqlite" 2> "$tmp/err"; check "missing dataset" 1 $?
"$imsynth" datagen --out "$tmp/text.sqlite" --count 1 --preset draft --quiet 2> "$tmp/err"
check "datagen into a non-dataset" 1 $?
expect_stderr "names it" "text.sqlite"
mkdir "$tmp/ro"; chmod 555 "$tmp/ro"
if [ "$(id -u)" != 0 ]; then
    "$imsynth" datagen --out "$tmp/ro/x.sqlite" --count 1 --preset draft --quiet 2> "$tmp/err"
    check "read-only directory" 1 $?
    expect_stderr "names the place" "ro/x.sqlite"
fi
# A full disk: a 1 MB tmpfs (root only). Nothing half-stored; resumable elsewhere.
if [ "$(id -u)" = 0 ] && mkdir "$tmp/full" && mount -t tmpfs -o size=1m tmpfs "$tmp/full" 2> /dev/null; then
    "$imsynth" datagen --out "$tmp/full/x.sqlite" --count 4 --preset draft --quiet 2> "$tmp/err"
    check "full disk" 1 $?
    expect_stderr "says the disk is full" "full"
    umount "$tmp/full"
fi

# From another directory, with no --graph or --scene: the data is found.
(cd "$tmp" && "$imsynth" datagen --out here.sqlite --count 1 --preset draft --descriptor none --quiet)
check "run from another directory" 0 $?
finish
