#!/bin/sh
# VGG19 descriptor benchmark, ours and PyTorch's, in one run (BENCHMARKS.md).
#   sh tests/bench/bench_vgg.sh BUILD_DIR [THREADS] [REPS]
# OpenBLAS is pinned to one thread: our workers run their own sgemms (describe does the
# same); PyTorch gets THREADS intra-op threads.
build=${1:?build dir}
threads=${2:-2}
reps=${3:-3}
here=$(dirname "$0")
echo "== machine"; nproc; grep -m1 "model name" /proc/cpuinfo; uptime
echo "== imsynth (threads $threads)"
OPENBLAS_NUM_THREADS=1 "$build/tests/bench/bench_vgg" --threads "$threads" --reps "$reps"
echo "== PyTorch (threads $threads)"
OMP_NUM_THREADS=$threads /usr/bin/python3 "$here/bench_vgg_torch.py" --threads "$threads" --reps "$reps"
echo "== after"; uptime
