//! Which form of K·u should an explicit step use? Times, side by side and interleaved (best of
//! 20), the product with K_ff in the scalar CSC format, in full 3×3 node blocks (with the AVX2
//! kernel and with the scalar one), in upper node blocks (what the integrators use), and a
//! matrix-free element loop that keeps per tet only its shape gradients and λ·V, μ·V
//! (104 bytes per tet, about half the bytes of K), and checks that all three agree.
//!
//! Then, in a second interleaved table, the node-block product with 1, 2, 4 and 8 concurrent
//! streams per parallel task (1 is the former single-stream kernel) against the floor of any
//! format: reading the same number of values (8 B each) once, as one sequential stream per
//! thread and as four.
//!
//! `cargo bench --bench explicit_product -- 100,20,20` (cells; RAYON_NUM_THREADS sets
//! the threads of the two matrix products; the element loop is serial, as a scatter-add needs
//! coloring to run in parallel).

use std::time::Instant;

use tetfem::Tet;
use tetfem::linalg::block_sparse::{BlockMatrix3, SymmetricBlockMatrix3};
use tetfem_fixtures::cantilever::{Cantilever, FreeSystem};

/// Per tet: the free index of each node's x DOF (u32::MAX for a clamped node) and the data of
/// f_a = V·σ(u)·∇N_a with σ = λ·tr(∇u)·I + μ·(∇u + ∇uᵀ): ∇N_1..3 (∇N_0 = −their sum), λV, μV.
struct ElementLoop {
    nodes: Vec<[u32; 4]>,
    data: Vec<[f64; 11]>,
}

impl ElementLoop {
    fn product(&self, x: &[f64], y: &mut [f64]) {
        y.fill(0.0);
        for (nodes, d) in self.nodes.iter().zip(&self.data) {
            let g1 = [d[0], d[1], d[2]];
            let g2 = [d[3], d[4], d[5]];
            let g3 = [d[6], d[7], d[8]];
            let g0 = [0, 1, 2].map(|j| -(g1[j] + g2[j] + g3[j]));
            let g = [g0, g1, g2, g3];
            let mut h = [[0.0f64; 3]; 3];
            for (a, &base) in nodes.iter().enumerate() {
                if base != u32::MAX {
                    let u = &x[base as usize..base as usize + 3];
                    for i in 0..3 {
                        for j in 0..3 {
                            h[i][j] += u[i] * g[a][j];
                        }
                    }
                }
            }
            let trace = h[0][0] + h[1][1] + h[2][2];
            let mut stress = [[0.0f64; 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    stress[i][j] = d[10] * (h[i][j] + h[j][i]);
                }
                stress[i][i] += d[9] * trace;
            }
            for (a, &base) in nodes.iter().enumerate() {
                if base != u32::MAX {
                    let f = &mut y[base as usize..base as usize + 3];
                    for i in 0..3 {
                        f[i] += stress[i][0] * g[a][0]
                            + stress[i][1] * g[a][1]
                            + stress[i][2] * g[a][2];
                    }
                }
            }
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // `cargo bench` appends `--bench` to a harness-less target's arguments: not one of ours.
    let cells: Vec<usize> = std::env::args()
        .skip(1)
        .find(|a| a != "--bench")
        .unwrap_or_else(|| "100,20,20".into())
        .split(',')
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let problem = Cantilever::peer_benchmark(cells.try_into().map_err(|_| "cells: NX,NY,NZ")?);
    let mesh = problem.mesh()?;
    let FreeSystem {
        dofs, stiffness: k, ..
    } = problem.free_system(&mesh)?;
    let blocks = BlockMatrix3::from_free_matrix(&k, dofs.free_dofs())?;
    let mut scalar_blocks = blocks.clone();
    scalar_blocks.set_simd(false);
    let upper = SymmetricBlockMatrix3::from_blocks(&blocks);
    let mut upper_work = upper.workspace();
    // The element loop below assumes each node is either free or clamped (true of this beam).
    let base: Vec<u32> = (0..mesh.node_count())
        .map(|node| dofs.free_index(3 * node).map_or(u32::MAX, |i| i as u32))
        .collect();
    let (lambda, mu) = (
        problem.material.lame_lambda(),
        problem.material.shear_modulus(),
    );
    let mut element_loop = ElementLoop {
        nodes: Vec::with_capacity(mesh.tet_count()),
        data: Vec::with_capacity(mesh.tet_count()),
    };
    for t in mesh.tets() {
        let tet = Tet::new(&t.map(|n| mesh.nodes()[n]))?;
        let (g, v) = (tet.shape_gradients(), tet.volume());
        element_loop.nodes.push(t.map(|n| base[n]));
        element_loop.data.push([
            g[1].x,
            g[1].y,
            g[1].z,
            g[2].x,
            g[2].y,
            g[2].z,
            g[3].x,
            g[3].y,
            g[3].z,
            v * lambda,
            v * mu,
        ]);
    }
    let n = k.dim();
    let x: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64 - 50.0).collect();
    let (mut y_csc, mut y_blocks, mut y_loop) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut y_scalar, mut y_upper) = (vec![0.0; n], vec![0.0; n]);
    let mut best = [f64::INFINITY; 5];
    for _ in 0..20 {
        let clock = Instant::now();
        k.mul_vec(&x, &mut y_csc)?;
        best[0] = best[0].min(clock.elapsed().as_secs_f64());
        let clock = Instant::now();
        blocks.mul_vec(&x, &mut y_blocks)?;
        best[1] = best[1].min(clock.elapsed().as_secs_f64());
        let clock = Instant::now();
        element_loop.product(&x, &mut y_loop);
        best[2] = best[2].min(clock.elapsed().as_secs_f64());
        let clock = Instant::now();
        scalar_blocks.mul_vec(&x, &mut y_scalar)?;
        best[3] = best[3].min(clock.elapsed().as_secs_f64());
        let clock = Instant::now();
        upper.mul_vec_with(&x, &mut y_upper, &mut upper_work)?;
        best[4] = best[4].min(clock.elapsed().as_secs_f64());
    }
    streams_table(&blocks, &x, &y_blocks)?;
    let scale = y_csc.iter().fold(0.0f64, |m, y| m.max(y.abs()));
    let differs = |y: &[f64]| {
        y.iter()
            .zip(&y_csc)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
            / scale
    };
    println!(
        "{n} free DOFs, {} tets, nnz(K_ff) {}, {} thread(s)",
        mesh.tet_count(),
        k.nnz(),
        rayon::current_num_threads()
    );
    println!("| form | bytes read | time [ms] | max rel. difference from CSC |");
    println!("|---|---|---|---|");
    let csc_bytes = k.nnz() * 16 + (n + 1) * 8;
    let loop_bytes = mesh.tet_count() * (16 + 88);
    for (name, bytes, time, y) in [
        ("CSC (8 B value + 8 B index)", csc_bytes, best[0], &y_csc),
        ("3×3 node blocks", blocks.matrix_bytes(), best[1], &y_blocks),
        (
            "3×3 node blocks, scalar kernel",
            blocks.matrix_bytes(),
            best[3],
            &y_scalar,
        ),
        (
            "upper 3×3 node blocks",
            upper.matrix_bytes(),
            best[4],
            &y_upper,
        ),
        ("element loop, serial", loop_bytes, best[2], &y_loop),
    ] {
        println!(
            "| {name} | {:.1} MB | {:.2} | {:.1e} |",
            bytes as f64 / 1e6,
            time * 1e3,
            differs(y)
        );
    }
    Ok(())
}

/// Times the node-block product per stream count against plain reads of as many values.
fn streams_table(
    blocks: &BlockMatrix3,
    x: &[f64],
    reference: &[f64],
) -> Result<(), Box<dyn std::error::Error>> {
    const STREAMS: [usize; 4] = [1, 2, 4, 8];
    let values = vec![1.0f64; 9 * blocks.stored_blocks()];
    let mut y = vec![0.0; x.len()];
    let mut best = [f64::INFINITY; STREAMS.len() + 2];
    for _ in 0..20 {
        for (k, &streams) in STREAMS.iter().enumerate() {
            let clock = Instant::now();
            blocks.mul_vec_with_streams(x, &mut y, streams)?;
            best[k] = best[k].min(clock.elapsed().as_secs_f64());
            if y != reference {
                return Err(format!("{streams} streams: not the bits of mul_vec").into());
            }
        }
        for (k, read) in [read_one_stream as fn(&[f64]) -> f64, read_four_streams]
            .into_iter()
            .enumerate()
        {
            let clock = Instant::now();
            std::hint::black_box(read(std::hint::black_box(&values)));
            best[STREAMS.len() + k] = best[STREAMS.len() + k].min(clock.elapsed().as_secs_f64());
        }
    }
    let bytes = 8.0 * values.len() as f64;
    println!(
        "\nnode-block product by streams per task (default {}), against reading its {:.1} MB of values",
        tetfem::linalg::block_sparse::STREAMS,
        bytes / 1e6
    );
    println!("| kernel | time [ms] | values GB/s | ÷ 4-stream read |");
    println!("|---|---|---|---|");
    let names = STREAMS
        .iter()
        .map(|s| format!("product, {s} stream(s)"))
        .chain([
            "read, 1 stream per thread".into(),
            "read, 4 streams per thread".into(),
        ]);
    for (name, time) in names.zip(best) {
        println!(
            "| {name} | {:.3} | {:.1} | {:.2} |",
            time * 1e3,
            bytes / time / 1e9,
            time / best[STREAMS.len() + 1]
        );
    }
    Ok(())
}

/// Sum of `values`, one sequential stream per rayon task.
fn read_one_stream(values: &[f64]) -> f64 {
    use rayon::prelude::*;
    values
        .par_chunks(1 << 16)
        .map(|c| {
            let mut s = [0.0; 4];
            for q in c.chunks_exact(4) {
                for k in 0..4 {
                    s[k] += q[k];
                }
            }
            s.iter().sum::<f64>()
        })
        .sum()
}

/// Sum of `values`, each rayon task reading four quarters of its chunk side by side.
fn read_four_streams(values: &[f64]) -> f64 {
    use rayon::prelude::*;
    values
        .par_chunks(1 << 18)
        .map(|c| {
            let q = c.len() / 4;
            let mut s = [[0.0; 4]; 4];
            let (a, rest) = c.split_at(q);
            let (b, rest) = rest.split_at(q);
            let (d, e) = rest.split_at(q);
            for (((a, b), d), e) in a
                .chunks_exact(4)
                .zip(b.chunks_exact(4))
                .zip(d.chunks_exact(4))
                .zip(e.chunks_exact(4))
            {
                for k in 0..4 {
                    s[0][k] += a[k];
                    s[1][k] += b[k];
                    s[2][k] += d[k];
                    s[3][k] += e[k];
                }
            }
            s.iter().flatten().sum::<f64>()
        })
        .sum()
}
