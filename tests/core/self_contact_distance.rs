//! Issue 36, the distances of body–body and self-contact: point–triangle and edge–edge squared
//! distances against brute-force sampling, their types, and their gradients and Hessians (and
//! the edge–edge mollifier's) against central differences over random configurations.

use nalgebra::Vector3;
use tetfem::contact::surface::distance::{
    DistanceType, Gradient12, Hessian12, edge_edge_mollifier, edge_edge_squared_distance,
    edge_edge_type, point_triangle_squared_distance, point_triangle_type, squared_distance,
    squared_distance_derivatives,
};

use crate::common::Rng;

const SAMPLES: usize = 200;

#[test]
fn point_triangle_distance_is_the_sampled_minimum() {
    let mut rng = Rng::new(36);
    for _ in 0..200 {
        let [p, a, b, c] = [0; 4].map(|_| rng.vector(-1.0, 1.0));
        let exact = point_triangle_squared_distance(&p, &a, &b, &c).sqrt();
        let mut sampled = f64::INFINITY;
        for i in 0..=SAMPLES {
            for j in 0..=SAMPLES - i {
                let (u, v) = (i as f64 / SAMPLES as f64, j as f64 / SAMPLES as f64);
                sampled = sampled.min((p - (a + u * (b - a) + v * (c - a))).norm());
            }
        }
        // The exact minimum is below every sample (round-off 1e-14), and the closest point is
        // within one grid cell (longest edge / SAMPLES) of a sample: distance is 1-Lipschitz.
        let h = [(b - a).norm(), (c - b).norm(), (a - c).norm()]
            .into_iter()
            .fold(0.0, f64::max)
            / SAMPLES as f64;
        assert!(exact <= sampled + 1e-14, "{exact} > {sampled}");
        assert!(sampled - exact <= h, "{sampled} − {exact} > {h}");
    }
}

#[test]
fn edge_edge_distance_is_the_sampled_minimum() {
    let mut rng = Rng::new(37);
    for k in 0..300 {
        let [a0, a1, b0, mut b1] = [0; 4].map(|_| rng.vector(-1.0, 1.0));
        if k % 3 == 0 {
            // Exactly parallel edges: the classification's special case.
            b1 = b0 + 0.7 * (a1 - a0);
        }
        let exact = edge_edge_squared_distance(&a0, &a1, &b0, &b1).sqrt();
        let mut sampled = f64::INFINITY;
        let n = 4 * SAMPLES;
        for i in 0..=n {
            let p = a0 + (i as f64 / n as f64) * (a1 - a0);
            for j in 0..=n {
                sampled = sampled.min((p - (b0 + (j as f64 / n as f64) * (b1 - b0))).norm());
            }
        }
        // As above: below every sample, within one grid step of each segment of the closest pair.
        let h = ((a1 - a0).norm() + (b1 - b0).norm()) / n as f64;
        assert!(exact <= sampled + 1e-14, "{exact} > {sampled}");
        assert!(sampled - exact <= h, "{sampled} − {exact} > {h}");
    }
}

/// Central differences of s and ∇s at step `h`, checked against the analytic ∇s and ∇²s.
fn check_derivatives(kind: DistanceType, x: &[Vector3<f64>; 4]) {
    let h = 1e-6;
    let exact = squared_distance_derivatives(kind, x);
    assert!((exact.value - squared_distance(kind, x)).abs() <= 1e-15 * (1.0 + exact.value));
    let mut fd_gradient = Gradient12::zeros();
    let mut fd_hessian = Hessian12::zeros();
    for k in 0..12 {
        let shifted = |sign: f64| {
            let mut y = *x;
            y[k / 3][k % 3] += sign * h;
            y
        };
        let (plus, minus) = (shifted(1.0), shifted(-1.0));
        fd_gradient[k] =
            (squared_distance(kind, &plus) - squared_distance(kind, &minus)) / (2.0 * h);
        let column = (squared_distance_derivatives(kind, &plus).gradient
            - squared_distance_derivatives(kind, &minus).gradient)
            / (2.0 * h);
        fd_hessian.set_column(k, &column);
    }
    // Central differences err by h²·|s‴|/6 ≈ 1e-12·|s‴| plus round-off ε·|s|/h ≈ 1e-10 on
    // coordinates of size 1 (s‴ grows like 1/d for the plane and line types, d ≥ 0.05 here):
    // 1e-6 relative to the largest entry bounds both with room.
    let g_scale = 1.0 + exact.gradient.amax();
    assert!(
        (fd_gradient - exact.gradient).amax() <= 1e-6 * g_scale,
        "{kind:?}: gradient off by {}",
        (fd_gradient - exact.gradient).amax()
    );
    let h_scale = 1.0 + exact.hessian.amax();
    assert!(
        (fd_hessian - exact.hessian).amax() <= 1e-6 * h_scale,
        "{kind:?}: Hessian off by {}",
        (fd_hessian - exact.hessian).amax()
    );
    // The gradient of a distance sums to zero over the points (translation invariance).
    for a in 0..3 {
        let sum: f64 = (0..4).map(|i| exact.gradient[3 * i + a]).sum();
        assert!(sum.abs() <= 1e-14 * g_scale);
    }
}

/// Whether every coordinate's ±h move keeps the type (central differences straddle no switch).
fn type_is_stable(
    x: &[Vector3<f64>; 4],
    classify: impl Fn(&[Vector3<f64>; 4]) -> DistanceType,
) -> bool {
    let kind = classify(x);
    (0..12).all(|k| {
        [-1e-4, 1e-4].iter().all(|&h| {
            let mut y = *x;
            y[k / 3][k % 3] += h;
            classify(&y) == kind
        })
    })
}

fn kind_name(kind: DistanceType) -> usize {
    match kind {
        DistanceType::PointPoint(..) => 0,
        DistanceType::PointEdge(..) => 1,
        DistanceType::PointPlane => 2,
        DistanceType::EdgeEdge => 3,
    }
}

#[test]
fn point_triangle_derivatives_match_central_differences_for_every_type() {
    let mut rng = Rng::new(38);
    let classify = |x: &[Vector3<f64>; 4]| point_triangle_type(&x[0], &x[1], &x[2], &x[3]);
    let mut seen = [0; 4];
    for _ in 0..400 {
        let x = [0; 4].map(|_| rng.vector(-1.0, 1.0));
        let kind = classify(&x);
        if squared_distance(kind, &x) < 0.05f64.powi(2) || !type_is_stable(&x, classify) {
            continue;
        }
        seen[kind_name(kind)] += 1;
        check_derivatives(kind, &x);
    }
    // Random configurations reach point–point, point–edge and point–plane types.
    assert!(seen[0] >= 10 && seen[1] >= 10 && seen[2] >= 10, "{seen:?}");
}

#[test]
fn edge_edge_derivatives_match_central_differences_for_every_type() {
    let mut rng = Rng::new(39);
    let classify = |x: &[Vector3<f64>; 4]| edge_edge_type(&x[0], &x[1], &x[2], &x[3]);
    let mut seen = [0; 4];
    for _ in 0..400 {
        let x = [0; 4].map(|_| rng.vector(-1.0, 1.0));
        let kind = classify(&x);
        if squared_distance(kind, &x) < 0.05f64.powi(2) || !type_is_stable(&x, classify) {
            continue;
        }
        seen[kind_name(kind)] += 1;
        check_derivatives(kind, &x);
    }
    assert!(seen[0] >= 10 && seen[1] >= 10 && seen[3] >= 10, "{seen:?}");
}

#[test]
fn mollifier_derivatives_match_central_differences() {
    let mut rng = Rng::new(40);
    for _ in 0..50 {
        let a0 = rng.vector(-1.0, 1.0);
        let a = rng.vector(-1.0, 1.0);
        let b0 = rng.vector(-1.0, 1.0);
        // Nearly parallel: b = 0.8·a + a small tilt, so c = |a×b|² falls below ε×.
        let b = 0.8 * a + 0.01 * rng.vector(-1.0, 1.0);
        let x = [a0, a0 + a, b0, b0 + b];
        let threshold = 1e-3 * a.norm_squared() * b.norm_squared();
        let (m, g, hess) = edge_edge_mollifier(&x, threshold);
        assert!(m > 0.0 && m < 1.0, "{m}");
        let h = 1e-7;
        for k in 0..12 {
            let shifted = |sign: f64| {
                let mut y = x;
                y[k / 3][k % 3] += sign * h;
                edge_edge_mollifier(&y, threshold)
            };
            let (plus, minus) = (shifted(1.0), shifted(-1.0));
            // m is a quadratic in c, c a quartic in x: the central difference's h² error is
            // ~1e-14·|m‴| and round-off ε/h ≈ 1e-9; 1e-6 relative to the largest entry.
            let fd = (plus.0 - minus.0) / (2.0 * h);
            assert!(
                (fd - g[k]).abs() <= 1e-6 * (1.0 + g.amax()),
                "{fd} vs {}",
                g[k]
            );
            let column = (plus.1 - minus.1) / (2.0 * h);
            assert!((column - hess.column(k)).amax() <= 1e-6 * (1.0 + hess.amax()));
        }
    }
}
