//! Issue 36, the barrier potential of body–body and self-contact: its gradient against central
//! differences of the total potential, its forces internal (zero net force and torque), and its
//! projected Hessian positive semi-definite, on two blocks and on a folded beam.

use nalgebra::{DMatrix, Vector3};
use tetfem::contact::surface::{Surface, SurfaceBarrier};

use crate::self_contact_fixtures::{folded_beam, jitter, two_blocks, two_quadratic_blocks};

/// (name, surface, positions, barrier): each with pairs of every kind within reach.
fn scenes() -> Vec<(&'static str, Surface, Vec<Vector3<f64>>, SurfaceBarrier)> {
    // Blocks 4 mm apart (2 mm jitter) under d̂ = 10 mm; the beam's halves 20 mm apart (2 mm
    // jitter) under d̂ = 30 mm.
    let (blocks, mut x) = two_blocks(2, 0.004, 0.05);
    jitter(&mut x, 1e-3, 1);
    let (beam, mut y) = folded_beam(10, 0.06);
    jitter(&mut y, 1e-3, 2);
    // The same blocks of 10-node tets: contact on the faces' linear sub-triangles.
    let (quadratic, mut z) = two_quadratic_blocks(1, 0.004, 0.05);
    jitter(&mut z, 1e-3, 3);
    vec![
        (
            "two blocks",
            blocks,
            x,
            SurfaceBarrier::new(0.01, 1e4).unwrap(),
        ),
        (
            "two quadratic blocks",
            quadratic,
            z,
            SurfaceBarrier::new(0.01, 1e4).unwrap(),
        ),
        (
            "folded beam",
            beam,
            y,
            SurfaceBarrier::new(0.03, 1e4).unwrap(),
        ),
    ]
}

fn gradient(barrier: &SurfaceBarrier, surface: &Surface, x: &[Vector3<f64>]) -> Vec<f64> {
    let mut g = vec![0.0; 3 * x.len()];
    barrier.add_gradient(surface, x, &mut g).unwrap();
    g
}

#[test]
fn gradient_matches_central_differences_of_the_potential() {
    for (name, surface, x, barrier) in scenes() {
        let active = barrier.active_pairs(&surface, &x).unwrap();
        let edge_pairs = active
            .iter()
            .filter(|p| matches!(p.pair, tetfem::contact::surface::Pair::EdgeEdge { .. }))
            .count();
        assert!(
            active.len() > 20 && edge_pairs > 5,
            "{name}: {} pairs",
            active.len()
        );
        let g = gradient(&barrier, &surface, &x);
        let scale = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let h = 1e-7;
        let mut worst = 0.0f64;
        for &n in surface.vertices() {
            for a in 0..3 {
                let mut y = x.clone();
                y[n][a] += h;
                let plus = barrier.energy(&surface, &y).unwrap();
                y[n][a] -= 2.0 * h;
                let minus = barrier.energy(&surface, &y).unwrap();
                worst = worst.max(((plus - minus) / (2.0 * h) - g[3 * n + a]).abs());
            }
        }
        // Central differences err by (h/d)²·|g| ≈ 1e-10·|g| at d ≥ 1 mm, and by round-off
        // ε·B/h ≈ 1e-9·B with B ≲ d̂·|g|: 1e-6 of the largest gradient entry bounds both.
        println!(
            "{name}: {} active pairs ({edge_pairs} edge–edge), gradient error {worst:.2e} of {scale:.2e}",
            active.len()
        );
        assert!(worst <= 1e-6 * scale, "{name}: {worst} vs {scale}");
    }
}

#[test]
fn barrier_forces_are_internal() {
    for (name, surface, x, barrier) in scenes() {
        let g = gradient(&barrier, &surface, &x);
        let mut force = Vector3::zeros();
        let mut torque = Vector3::zeros();
        let mut size = 0.0;
        let mut moment_size = 0.0;
        for (n, p) in x.iter().enumerate() {
            let f = Vector3::new(g[3 * n], g[3 * n + 1], g[3 * n + 2]);
            force += f;
            torque += p.cross(&f);
            size += f.norm();
            moment_size += p.norm() * f.norm();
        }
        assert!(size > 0.0);
        // Every pair's gradient sums to zero exactly and its moment vanishes exactly in exact
        // arithmetic (distances depend on differences and are rotation invariant): what
        // remains is round-off, ~1e-16 per term times a few hundred terms.
        println!(
            "{name}: |Σf| = {:.2e}, |Σx×f| = {:.2e} (Σ|f| = {size:.2e})",
            force.norm(),
            torque.norm()
        );
        assert!(force.norm() <= 1e-13 * size, "{name}: net force {force}");
        assert!(
            torque.norm() <= 1e-13 * moment_size,
            "{name}: net torque {torque}"
        );
    }
}

/// The dense Hessian over the DOFs of surface nodes (small scenes only).
fn dense(triplets: &[(usize, usize, f64)], dofs: usize) -> DMatrix<f64> {
    let mut h = DMatrix::zeros(dofs, dofs);
    for &(r, c, v) in triplets {
        h[(r, c)] += v;
    }
    h
}

#[test]
fn projected_hessian_is_positive_semi_definite_and_the_full_one_matches_differences() {
    for (name, surface, x, barrier) in scenes() {
        let dofs = 3 * x.len();
        let projected = dense(&barrier.hessian_triplets(&surface, &x, true).unwrap(), dofs);
        let eigen = projected.clone().symmetric_eigen();
        let (lo, hi) = eigen
            .eigenvalues
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), &l| {
                (lo.min(l), hi.max(l))
            });
        // A sum of PSD blocks is PSD; the eigen-solver's round-off is ~1e-15 of the largest.
        assert!(
            lo >= -1e-12 * hi,
            "{name}: smallest eigenvalue {lo} of {hi}"
        );
        let full = dense(
            &barrier.hessian_triplets(&surface, &x, false).unwrap(),
            dofs,
        );
        let full_eigen = full.clone().symmetric_eigen();
        let full_lo = full_eigen
            .eigenvalues
            .iter()
            .fold(f64::INFINITY, |m, &l| m.min(l));
        println!(
            "{name}: projected eigenvalues in [{lo:.3e}, {hi:.3e}], unprojected smallest {full_lo:.3e}"
        );
        let h = 1e-8;
        let mut worst = 0.0f64;
        for &n in surface.vertices() {
            for a in 0..3 {
                let mut y = x.clone();
                y[n][a] += h;
                let plus = gradient(&barrier, &surface, &y);
                y[n][a] -= 2.0 * h;
                let minus = gradient(&barrier, &surface, &y);
                for r in 0..dofs {
                    worst =
                        worst.max(((plus[r] - minus[r]) / (2.0 * h) - full[(r, 3 * n + a)]).abs());
                }
            }
        }
        let scale = full.amax();
        // As for the gradient, one derivative up: (h/d)² ≈ 1e-10 and round-off ε·|g|/h with
        // |g| ≲ d̂·|H|: 1e-6 of the largest entry.
        println!("{name}: Hessian error {worst:.2e} of {scale:.2e}");
        assert!(
            worst <= 1e-6 * scale,
            "{name}: Hessian off by {worst} of {scale}"
        );
    }
}

#[test]
fn candidates_swept_along_a_step_serve_every_point_of_it() {
    for (name, surface, x, barrier) in scenes() {
        let mut rng = crate::common::Rng::new(43);
        let dx: Vec<Vector3<f64>> = x.iter().map(|_| rng.vector(-2e-3, 2e-3)).collect();
        let d_hat = barrier.activation_distance;
        let found = tetfem::contact::surface::candidates(&surface, &x, Some(&dx), d_hat).unwrap();
        for alpha in [0.0, 0.3, 1.0] {
            let y: Vec<Vector3<f64>> = x.iter().zip(&dx).map(|(p, d)| p + alpha * d).collect();
            let direct = barrier.energy(&surface, &y).unwrap();
            let among = barrier.energy_among(&surface, &y, &found).unwrap();
            let (mut g1, mut g2) = (vec![0.0; 3 * y.len()], vec![0.0; 3 * y.len()]);
            barrier.add_gradient(&surface, &y, &mut g1).unwrap();
            barrier
                .add_gradient_among(&surface, &y, &found, &mut g2)
                .unwrap();
            let h1 = barrier.hessian_triplets(&surface, &y, true).unwrap();
            let h2 = barrier
                .hessian_triplets_among(&surface, &y, &found, true)
                .unwrap();
            // The same pairs summed in another order: equal up to round-off of the sums.
            assert!(
                (direct - among).abs() <= 1e-13 * direct.abs(),
                "{name}: {direct} vs {among}"
            );
            let scale = g1.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(
                g1.iter()
                    .zip(&g2)
                    .all(|(a, b)| (a - b).abs() <= 1e-12 * scale),
                "{name}"
            );
            let total = |h: &[(usize, usize, f64)]| h.iter().map(|t| t.2.abs()).sum::<f64>();
            assert!(
                (total(&h1) - total(&h2)).abs() <= 1e-12 * total(&h1),
                "{name}"
            );
        }
    }
}
