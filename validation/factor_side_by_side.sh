#!/usr/bin/env bash
# Issue 39, target 3: tetfem's factor against PARDISO's and CHOLMOD's on the same K_ff, one size
# after the other in one run (tetfem, then PARDISO, then CHOLMOD on each size), with the load.
# Writes target/factor_size/{tetfem,peers}.csv; validation/factor_chart.py draws the chart.
#   validation/factor_side_by_side.sh [CELLS ...]   (default 80,8,8 160,16,16 200,20,20)
# Needs `cargo build --release -p tetfem-validation --bin factor_size` and the peers venv
# (validation/setup_peers.sh, plus `pip install pypardiso`). CHOLMOD runs on MKL's BLAS
# (LD_PRELOAD of the venv's libmkl_rt): Debian's CHOLMOD links the reference BLAS here, and
# the OpenBLAS alternative is not installed system-wide. One thread only for CHOLMOD: with two
# MKL threads under CHOLMOD the run did not finish in 10 minutes at 19k DOFs.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=target/factor_size
PY=${TETFEM_PEERS_VENV:-/work/peers-venv}/bin/python
mkdir -p "$OUT"
if [ $# -gt 0 ]; then SIZES=("$@"); else SIZES=(80,8,8 160,16,16 200,20,20); fi
: > "$OUT/tetfem.csv"; : > "$OUT/peers.csv"
for cells in "${SIZES[@]}"; do
    name="beam_${cells//,/x}"
    echo "# $(uptime)" | tee -a "$OUT/tetfem.csv"
    ./target/release/factor_size --cells "$cells" --variants default,exact --reps 2 \
        --export "$OUT" | tee -a "$OUT/tetfem.csv"
    "$PY" validation/factor_peers.py "$OUT/${name}_K.mtx" --codes pardiso --threads 1,2 \
        --repeat 2 | tee -a "$OUT/peers.csv"
    LD_PRELOAD=${TETFEM_PEERS_VENV:-/work/peers-venv}/lib/libmkl_rt.so.3 \
        "$PY" validation/factor_peers.py "$OUT/${name}_K.mtx" --codes cholmod --threads 1 \
        --repeat 2 | tee -a "$OUT/peers.csv"
    rm -f "$OUT/${name}_K.mtx"
done
