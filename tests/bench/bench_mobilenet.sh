#!/bin/sh
# MobileNetV2 descriptor speed: ours beside our VGG19 path and PyTorch's MobileNetV2, one
# run (BENCHMARKS.md, "MobileNetV2 descriptor").
#   sh tests/bench/bench_mobilenet.sh BUILD_DIR [THREADS] [REPS]
# Ours twice: with OpenBLAS's own CPU detection, and with OPENBLAS_CORETYPE=SkylakeX
# (OpenBLAS 0.3.21 takes this CPU, family 6 model 207, for a Prescott: SSE3 kernels).
build=${1:?build dir}
threads=${2:-2}
reps=${3:-3}
here=$(dirname "$0")
echo "== machine"; nproc; grep -m1 "model name" /proc/cpuinfo; uptime
echo "== imsynth, OpenBLAS as detected (threads $threads)"
OPENBLAS_VERBOSE=2 OPENBLAS_NUM_THREADS=1 "$build/tests/bench/bench_mobilenet" --threads "$threads" --reps "$reps"
echo "== imsynth, OPENBLAS_CORETYPE=SkylakeX (threads $threads)"
OPENBLAS_CORETYPE=SkylakeX OPENBLAS_VERBOSE=2 OPENBLAS_NUM_THREADS=1 "$build/tests/bench/bench_mobilenet" --threads "$threads" --reps "$reps"
echo "== PyTorch (threads $threads)"
OMP_NUM_THREADS=$threads /usr/bin/python3 "$here/bench_mobilenet_torch.py" --threads "$threads" --reps "$reps"
echo "== after"; uptime
