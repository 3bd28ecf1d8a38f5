#!/bin/sh
# MLP training benchmark, ours and PyTorch's, in one run (BENCHMARKS.md).
#   sh tests/bench/bench_train.sh BUILD_DIR [THREADS] [STEPS]
# Two models: the 2500-1000-1000-50 ReLU MLP, and a predictor-like 4000-512-512
# LayerNorm/GELU trunk. OpenBLAS is pinned to one thread (our workers run their own
# sgemms in fixed pieces); PyTorch gets THREADS intra-op threads.
build=${1:?build dir}
threads=${2:-2}
steps=${3:-30}
here=$(dirname "$0")
echo "== machine"; nproc; grep -m1 "model name" /proc/cpuinfo; uptime
for arch in "mlp:2500-1000-1000-50,relu" "mlp:4000-512-512-60,gelu,ln"; do
    for t in 1 "$threads"; do
        OPENBLAS_NUM_THREADS=1 "$build/tests/bench/bench_train" --arch "$arch" --threads "$t" --steps "$steps"
        OMP_NUM_THREADS=$t /usr/bin/python3 "$here/bench_train_torch.py" --arch "$arch" --threads "$t" --steps "$steps"
    done
done
echo "== after"; uptime
