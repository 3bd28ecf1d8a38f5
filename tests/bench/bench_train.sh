#!/bin/sh
# MLP training benchmark, ours and PyTorch's, in one run (BENCHMARKS.md).
#   sh tests/bench/bench_train.sh BUILD_DIR [THREADS] [STEPS]
# Two models: the 2500-1000-1000-50 ReLU MLP, and a predictor-like 4000-512-512-60
# LayerNorm/GELU trunk; batch 128, AdamW. Ours: OpenBLAS pinned to one thread (our workers
# run their own sgemms in fixed pieces). PyTorch, for THREADS > 1, two ways: THREADS
# intra-op (OpenMP) threads and OpenBLAS (which torch's Linear calls here) with THREADS
# threads, and 1 intra-op thread with OpenBLAS on THREADS (better on a loaded machine,
# where its OpenMP threads spin against other jobs); compare with the better.
# Each twice: with OpenBLAS's own CPU detection (on this host, family 6 model 207, 0.3.21
# falls back to Prescott kernels) and with OPENBLAS_CORETYPE=SkylakeX; both sides load
# the same libopenblas, so each pair is like for like.
build=${1:?build dir}
threads=${2:-2}
steps=${3:-20}
here=$(dirname "$0")
echo "== machine"; nproc; grep -m1 "model name" /proc/cpuinfo; grep -m1 "^model\s" /proc/cpuinfo; uptime
for core in detected SkylakeX; do
    if [ "$core" = detected ]; then unset OPENBLAS_CORETYPE; else export OPENBLAS_CORETYPE=$core; fi
    echo "== OpenBLAS core: $core"
    for arch in "mlp:2500-1000-1000-50,relu" "mlp:4000-512-512-60,gelu,ln"; do
        for t in 1 "$threads"; do
            OPENBLAS_NUM_THREADS=1 "$build/tests/bench/bench_train" --arch "$arch" --threads "$t" --steps "$steps"
            OPENBLAS_NUM_THREADS=$t OMP_NUM_THREADS=$t /usr/bin/python3 "$here/bench_train_torch.py" --arch "$arch" --threads "$t" --steps "$steps"
            if [ "$t" != 1 ]; then
                OPENBLAS_NUM_THREADS=$t OMP_NUM_THREADS=1 /usr/bin/python3 "$here/bench_train_torch.py" --arch "$arch" --threads 1 --steps "$steps"
            fi
        done
    done
done
echo "== after"; uptime
