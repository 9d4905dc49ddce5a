"""Chart and table of the factor size study (issue 39, target 3) from the CSVs that
validation/factor_side_by_side.sh writes: nnz(L) and numeric factorization time against DOFs,
tetfem (default relaxation and the exact, unpadded factor) beside PARDISO and CHOLMOD.

  /work/peers-venv/bin/python validation/factor_chart.py target/factor_size

Writes validation/report/factor_size.csv (one row per matrix, code, setting, threads) and
validation/report/factor_size.png.
"""

from __future__ import annotations

import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


TETFEM = ("beam,dofs,variant,stored_len,nnz_lower,nnz_exact,flops,symbolic_s,threads,numeric_s,"
          "solve_s,residual").split(",")


def read(folder):
    """tetfem's and the peers' rows (comment lines and repeated headers skipped)."""
    out = []
    with open(os.path.join(folder, "tetfem.csv")) as f:
        for ln in f:
            if ln.startswith("#") or ln.startswith("beam,"):
                continue
            r = dict(zip(TETFEM, ln.strip().split(",")))
            out.append(dict(dofs=int(r["dofs"]), code="tetfem", setting=r["variant"],
                            threads=int(r["threads"]), nnz_L=int(r["nnz_lower"]),
                            stored=int(r["stored_len"]), flops=float(r["flops"]),
                            numeric_s=float(r["numeric_s"]), solve_s=float(r["solve_s"]),
                            residual=float(r["residual"])))
    with open(os.path.join(folder, "peers.csv")) as f:
        for ln in f:
            if ln.startswith("#") or ln.startswith("matrix,"):
                continue
            _m, dofs, code, t, nnz, flops, _ta, tn, ts, res = ln.strip().split(",")
            out.append(dict(dofs=int(dofs), code=code, setting="metis", threads=int(t),
                            nnz_L=int(nnz), stored=int(nnz), flops=float(flops),
                            numeric_s=float(tn), solve_s=float(ts), residual=float(res)))
    return sorted(out, key=lambda r: (r["dofs"], r["code"], r["setting"], r["threads"]))


def print_table(data):
    """The markdown table of validation/PERFORMANCE.md: each row against PARDISO on the same
    matrix and thread count (nnz(L) ratio, numeric factorization ratio)."""
    pardiso = {(r["dofs"], r["threads"]): r for r in data if r["code"] == "pardiso"}
    print("| DOFs | code (setting) | threads | nnz(L) lower | / PARDISO | stored | flops | numeric [s] "
          "| / PARDISO | solve [s] | / PARDISO | residual |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in data:
        p = pardiso.get((r["dofs"], r["threads"]))
        ratio = (lambda k: f"{r[k] / p[k]:.3f}") if p else (lambda k: "–")
        print(f"| {r['dofs']} | {r['code']} ({r['setting']}) | {r['threads']} | {r['nnz_L'] / 1e6:.2f}M "
              f"| {ratio('nnz_L')} | {r['stored'] / 1e6:.2f}M | {r['flops']:.3e} | {r['numeric_s']:.3f} "
              f"| {ratio('numeric_s')} | {r['solve_s']:.4f} | {ratio('solve_s')} | {r['residual']:.1e} |")


def main(folder):
    data = read(folder)
    keys = ["dofs", "code", "setting", "threads", "nnz_L", "stored", "flops", "numeric_s", "solve_s",
            "residual"]
    with open(os.path.join(HERE, "report", "factor_size.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(data)
    print_table(data)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 5))
    series = {}
    for r in data:
        series.setdefault((r["code"], r["setting"]), []).append(r)
    styles = {("tetfem", "default"): ("C0", "o"), ("tetfem", "exact"): ("C2", "s"),
              ("pardiso", "metis"): ("C3", "^"), ("cholmod", "metis"): ("C1", "v")}
    for (code, setting), rs in series.items():
        color, marker = styles[(code, setting)]
        one = [r for r in rs if r["threads"] == 1]
        label = f"{code} ({setting})" if code == "tetfem" else f"{code} (METIS)"
        ax1.plot([r["dofs"] for r in one], [r["nnz_L"] / r["dofs"] for r in one], marker=marker, color=color,
                 label=f"{label}: lower triangle")
        if code == "tetfem":
            ax1.plot([r["dofs"] for r in one], [r["stored"] / r["dofs"] for r in one], marker=marker,
                     color=color, linestyle=":", label=f"{label}: as stored (+ upper tri. of diag. blocks)")
        for t, ls in [(1, "-"), (2, "--")]:
            tr = [r for r in rs if r["threads"] == t]
            if tr:
                ax2.plot([r["dofs"] for r in tr], [r["numeric_s"] for r in tr], marker=marker, color=color,
                         linestyle=ls, label=f"{label}, {t} thread{'s' if t > 1 else ''}")
    ax2.set_yscale("log")
    for ax in (ax1, ax2):
        ax.set_xscale("log")
        ax.set_xlabel("free DOFs of the box beam K_ff")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    ax1.set_ylabel("nnz(L) / DOFs [entries of L per unknown]")
    ax1.set_title("Cholesky factor size (METIS orderings)")
    ax2.set_ylabel("numeric factorization [s] (best of 2, warm)")
    ax2.set_title("Numeric factorization, same K, one run (2 cores, shared)")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "report", "factor_size.png"), dpi=110)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "target/factor_size")
