"""PARDISO (MKL, via pypardiso's library) and CHOLMOD (scikit-sparse) on the Matrix Market
K_ff files that `factor_size --export DIR` writes: nnz(L), flops, analysis / numeric
factorization / solve times, side by side with the same matrices tetfem factors.

  /work/peers-venv/bin/python validation/factor_peers.py target/factor_size/beam_160x16x16_K.mtx \
      --threads 1,2 --repeat 3

Each thread count runs in a fresh subprocess (MKL and OpenBLAS read MKL_NUM_THREADS /
OPENBLAS_NUM_THREADS when they load). Prints one CSV row per (matrix, code, threads):

  PARDISO: mtype 2 (real SPD), default iparm (METIS nested dissection, iparm[1] = 2), upper
  triangle in CSR; nnz(L) is iparm[17] (1-based 18) after the analysis, flops iparm[18] (MFLOP,
  1-based 19); numeric = phase 22, solve = phase 33 (forward + backward + its refinement
  steps, iparm[7] = 0: none requested), each best of --repeat.
  CHOLMOD: supernodal, METIS ordering; nnz(L) of the factor's lower triangle (supernodal padding
  included), flops Σ_j c_j² (c_j the entries of column j), numeric = cholesky_inplace.
"""

from __future__ import annotations

import argparse
import ctypes
import os
import subprocess
import sys
import time

HEADER = "matrix,dofs,code,threads,nnz_L,flops,analyze_s,numeric_s,solve_s,residual"


def load(path):
    import numpy as np
    import scipy.io as sio
    import scipy.sparse as sp

    full = sp.csc_matrix(sio.mmread(path))  # a `symmetric` file is read with both triangles
    fpath = path.replace("_K.mtx", "_f.mtx")
    f = np.asarray(sio.mmread(fpath)).ravel() if os.path.exists(fpath) else full @ np.ones(full.shape[0])
    return full, f


def best(repeat, run):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = run()
        times.append(time.perf_counter() - t0)
    return min(times), out


def pardiso(path, repeat):
    import numpy as np
    import scipy.sparse as sp
    from pypardiso import PyPardisoSolver

    A, f = load(path)
    upper = sp.triu(A, format="csr")
    upper.sort_indices()
    n = A.shape[0]
    ps = PyPardisoSolver(mtype=2)
    ia = (upper.indptr + 1).astype(np.int32)
    ja = (upper.indices + 1).astype(np.int32)
    data = np.ascontiguousarray(upper.data)
    b = np.ascontiguousarray(f.astype(np.float64))
    x = np.zeros_like(b)
    i32p, f64p = ctypes.POINTER(ctypes.c_int32), ctypes.POINTER(ctypes.c_double)

    def call(phase):
        err = ctypes.c_int32(0)
        ps._mkl_pardiso(
            ps.pt.ctypes.data_as(ctypes.POINTER(ps._pt_type[0])),
            ctypes.byref(ctypes.c_int32(1)), ctypes.byref(ctypes.c_int32(1)),
            ctypes.byref(ctypes.c_int32(2)), ctypes.byref(ctypes.c_int32(phase)),
            ctypes.byref(ctypes.c_int32(n)), data.ctypes.data_as(f64p),
            ia.ctypes.data_as(i32p), ja.ctypes.data_as(i32p), ps.perm.ctypes.data_as(i32p),
            ctypes.byref(ctypes.c_int32(1)), ps.iparm.ctypes.data_as(i32p),
            ctypes.byref(ctypes.c_int32(0)), b.ctypes.data_as(f64p), x.ctypes.data_as(f64p),
            ctypes.byref(err))
        if err.value != 0:
            raise RuntimeError(f"PARDISO phase {phase}: error {err.value}")

    t_analyze, _ = best(1, lambda: call(11))
    nnz_l, mflops = int(ps.iparm[17]), float(ps.iparm[18])
    call(22)  # first touch of the factor's pages, not timed (as on tetfem's side)
    t_num, _ = best(repeat, lambda: call(22))
    t_solve, _ = best(max(repeat, 3), lambda: call(33))
    res = np.linalg.norm(A @ x - f) / np.linalg.norm(f)
    call(-1)
    return n, nnz_l, mflops * 1e6, t_analyze, t_num, t_solve, res


def cholmod(path, repeat):
    import numpy as np
    from sksparse.cholmod import analyze

    A, f = load(path)
    t_analyze, fac = best(1, lambda: analyze(A, mode="supernodal", ordering_method="metis"))
    fac.cholesky_inplace(A)
    t_num, _ = best(repeat, lambda: fac.cholesky_inplace(A))
    t_solve, x = best(max(repeat, 3), lambda: fac(f))
    L = fac.L().tocsc()
    cnt = np.diff(L.indptr).astype(np.float64)
    res = np.linalg.norm(A @ x - f) / np.linalg.norm(f)
    return A.shape[0], int(L.nnz), float((cnt ** 2).sum()), t_analyze, t_num, t_solve, res


def worker(path, code, threads, repeat):
    n, nnz, flops, ta, tn, ts, res = {"pardiso": pardiso, "cholmod": cholmod}[code](path, repeat)
    name = os.path.basename(path).replace("_K.mtx", "")
    print(f"{name},{n},{code},{threads},{nnz},{flops:.6e},{ta:.4f},{tn:.4f},{ts:.5f},{res:.2e}",
          flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mtx", nargs="*")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--codes", default="pardiso,cholmod")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--worker", nargs=3, metavar=("PATH", "CODE", "THREADS"), help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        worker(a.worker[0], a.worker[1], int(a.worker[2]), a.repeat)
        return
    print(f"# {os.popen('uptime').read().strip()}")
    print(HEADER, flush=True)
    for path in a.mtx:
        for code in a.codes.split(","):
            for t in a.threads.split(","):
                env = dict(os.environ, MKL_NUM_THREADS=t, OPENBLAS_NUM_THREADS=t, OMP_NUM_THREADS=t)
                subprocess.run([sys.executable, __file__, "--worker", path, code, t,
                                "--repeat", str(a.repeat)], env=env, check=True)


if __name__ == "__main__":
    main()
