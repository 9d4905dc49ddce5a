//! Timing harness for the refill of the global stiffness K (values only, on an existing
//! pattern): the library's `Assembler::refill_stiffness` and `Assembler::stiffness` (fresh
//! matrix) against a verbatim copy of the previous implementation (a generic 12×12 element
//! matrix per tet scattered entry by entry, a separate zeroing pass),
//! interleaved in one process so that machine noise hits both alike.
//!
//! Usage: `RAYON_NUM_THREADS=1 cargo bench --bench refill -- 200 20 20 [rounds]`.
//! Prints the best of `rounds` runs of each (ns per tet) and their ratio, and checks that both
//! give the same values bit for bit.

use std::hint::black_box;
use std::time::Instant;

use std::sync::Arc;
use tetfem::fe::assembly::Assembler;
use tetfem::fe::element::{Matrix12, Tet};
use tetfem::fe::material::Material;
use tetfem::linalg::sparse::CscMatrix;
use tetfem::mesh::TetMesh;
use tetfem_fixtures::cantilever::Cantilever;

/// The previous refill, reconstructed from the public pattern: per tet and local node pair the
/// start of its 3×3 block, per node the column stride, and node-range partitions.
struct OldRefill {
    block_start: Vec<usize>,
    column_stride: Vec<usize>,
    partitions: Vec<(std::ops::Range<usize>, std::ops::Range<usize>, Vec<usize>)>,
}

impl OldRefill {
    fn new(mesh: &TetMesh, col_ptr: &[usize], row_idx: &[usize]) -> Self {
        let nodes = mesh.node_count();
        let column_stride: Vec<usize> = (0..nodes)
            .map(|n| col_ptr[3 * n + 1] - col_ptr[3 * n])
            .collect();
        let mut block_start = Vec::with_capacity(16 * mesh.tet_count());
        for tet in mesh.tets() {
            for &row_node in tet {
                for &col_node in tet {
                    let column = col_ptr[3 * col_node]..col_ptr[3 * col_node + 1];
                    let pos = row_idx[column.clone()]
                        .binary_search(&(3 * row_node))
                        .unwrap();
                    block_start.push(column.start + pos);
                }
            }
        }
        // Same split as the old `partition`.
        let nnz = col_ptr[3 * nodes];
        let count = if nnz < 200_000 {
            1
        } else {
            (4 * rayon::current_num_threads()).clamp(1, nodes)
        };
        let mut bounds = vec![0usize];
        for n in 0..nodes {
            let filled = col_ptr[3 * (n + 1)];
            if filled * count >= bounds.len() * nnz && bounds.len() < count {
                bounds.push(n + 1);
            }
        }
        if *bounds.last().unwrap() != nodes {
            bounds.push(nodes);
        }
        let mut part_of = vec![0usize; nodes];
        for p in 0..bounds.len() - 1 {
            part_of[bounds[p]..bounds[p + 1]].fill(p);
        }
        let mut tets = vec![Vec::new(); bounds.len() - 1];
        for (t, tet) in mesh.tets().iter().enumerate() {
            let mut seen = [usize::MAX; 4];
            for (k, &n) in tet.iter().enumerate() {
                let p = part_of[n];
                if !seen[..k].contains(&p) {
                    tets[p].push(t);
                }
                seen[k] = p;
            }
        }
        let partitions = tets
            .into_iter()
            .enumerate()
            .map(|(p, tets)| {
                (
                    bounds[p]..bounds[p + 1],
                    col_ptr[3 * bounds[p]]..col_ptr[3 * bounds[p + 1]],
                    tets,
                )
            })
            .collect();
        OldRefill {
            block_start,
            column_stride,
            partitions,
        }
    }

    fn reassemble(
        &self,
        mesh: &TetMesh,
        element_matrix: impl Fn(usize) -> Matrix12 + Sync,
        values: &mut [f64],
    ) {
        use rayon::prelude::*;
        let mut rest = values;
        let mut slices = Vec::with_capacity(self.partitions.len());
        for part in &self.partitions {
            let (head, tail) = rest.split_at_mut(part.1.len());
            slices.push(head);
            rest = tail;
        }
        self.partitions
            .par_iter()
            .zip(slices)
            .for_each(|((nodes, range, tets), values)| {
                values.fill(0.0);
                let offset = range.start;
                for &t in tets {
                    let ke = element_matrix(t);
                    let tet = &mesh.tets()[t];
                    for j in 0..4 {
                        if !nodes.contains(&tet[j]) {
                            continue;
                        }
                        let stride = self.column_stride[tet[j]];
                        for i in 0..4 {
                            let start = self.block_start[16 * t + 4 * i + j] - offset;
                            for a in 0..3 {
                                let column = start + a * stride;
                                for b in 0..3 {
                                    values[column + b] += ke[(3 * i + b, 3 * j + a)];
                                }
                            }
                        }
                    }
                }
            });
    }
}

fn element(mesh: &TetMesh, t: usize, material: &Material) -> Matrix12 {
    let tet = mesh.tets()[t];
    Tet::new(&tet.map(|n| mesh.nodes()[n]))
        .unwrap()
        .stiffness(material)
}

fn main() {
    // `cargo bench` appends `--bench` to a harness-less target's arguments: not one of ours.
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .map(|a| a.parse().expect("numbers: nx ny nz [rounds]"))
        .collect();
    let cells = [
        *args.first().unwrap_or(&200),
        *args.get(1).unwrap_or(&20),
        *args.get(2).unwrap_or(&20),
    ];
    let rounds = *args.get(3).unwrap_or(&7);
    let problem = Cantilever::peer_benchmark(cells);
    let mesh = problem.mesh().unwrap();
    let material = problem.material;
    let assembler = Assembler::new(&mesh);
    let mut k_new = assembler.stiffness(&mesh, &material).unwrap();
    let mut k_old = k_new.clone();
    let reference = k_new.clone();
    let old = OldRefill::new(&mesh, k_new.col_ptr(), k_new.row_idx());
    let tets = mesh.tet_count() as f64;
    // For profiling one path alone: REFILL_ONLY=new runs `refill_stiffness` in a loop and exits.
    if std::env::var("REFILL_ONLY").is_ok_and(|v| v == "new") {
        for _ in 0..rounds {
            assembler
                .refill_stiffness(&mesh, &material, &mut k_new)
                .unwrap();
        }
        return;
    }
    let pattern = std::sync::Arc::clone(assembler.pattern());
    let labels = [
        "old refill, in place",
        "new refill, in place",
        "old fresh K (vec![0.0] + old refill)",
        "new fresh K (Assembler::stiffness)",
    ];
    let mut best = [f64::INFINITY; 4];
    let mut time = |slot: usize, run: &mut dyn FnMut()| {
        let clock = Instant::now();
        run();
        best[slot] = best[slot].min(clock.elapsed().as_secs_f64());
    };
    for _ in 0..rounds {
        time(0, &mut || {
            old.reassemble(&mesh, |t| element(&mesh, t, &material), k_old.values_mut())
        });
        time(1, &mut || {
            assembler
                .refill_stiffness(&mesh, &material, &mut k_new)
                .unwrap()
        });
        let mut fresh = None;
        time(2, &mut || {
            let mut k =
                CscMatrix::from_values(Arc::clone(&pattern), vec![0.0; pattern.row_idx().len()])
                    .unwrap();
            old.reassemble(&mesh, |t| element(&mesh, t, &material), k.values_mut());
            fresh = Some(black_box(k));
        });
        drop(fresh.take());
        time(3, &mut || {
            fresh = Some(black_box(assembler.stiffness(&mesh, &material).unwrap()));
        });
        drop(fresh);
    }
    let fresh = assembler.stiffness(&mesh, &material).unwrap();
    let same = [k_new.values(), k_old.values(), fresh.values()]
        .iter()
        .all(|v| *v == reference.values());
    let ns = |s: f64| s * 1e9 / tets;
    println!(
        "cells {cells:?}: {} DOFs, {} tets, nnz {}, threads {}, best of {rounds}",
        mesh.dof_count(),
        mesh.tet_count(),
        k_new.nnz(),
        rayon::current_num_threads()
    );
    for (slot, label) in labels.iter().enumerate() {
        let ratio = if slot % 2 == 1 {
            format!("  old/new {:.2}", best[slot - 1] / best[slot])
        } else {
            String::new()
        };
        println!(
            "{label:<38} {:.4} s {:6.1} ns/tet{ratio}",
            best[slot],
            ns(best[slot])
        );
    }
    println!("all bit-identical to the old refill: {same}");
}
