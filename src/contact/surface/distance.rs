//! Squared distances between surface primitives — point–triangle and edge–edge — with the type
//! of their closest pair of features, and the gradient and Hessian with respect to all 12
//! coordinates of the pair's four points.
//!
//! A pair is four points x₀…x₃ (length): point–triangle pairs put the point at x₀ and the
//! triangle at x₁, x₂, x₃; edge–edge pairs put edge a at x₀, x₁ and edge b at x₂, x₃. Every
//! distance type is a least-squares problem over its free parameters θ (none, a segment's t,
//! a plane's (u, v), two lines' (s, t)):
//!
//! s(x) = min_θ f(x, θ), f = |r|², r = Σᵢ wᵢ(θ)·xᵢ, wᵢ affine in θ with Σᵢ wᵢ = 0,
//!
//! so that, at the minimiser θ*, ∇s = ∂f/∂x (envelope theorem; ∂f/∂xᵢ = 2wᵢ·r) and
//! ∇²s = f_xx − f_xθ·f_θθ⁻¹·f_θx (the Hessian of a partial minimum), with
//! f_xᵢxⱼ = 2wᵢwⱼ·I, f_xᵢθₖ = 2(∂wᵢ/∂θₖ)·r + 2wᵢ·gₖ, f_θₖθₗ = 2gₖ·gₗ and gₖ = ∂r/∂θₖ.
//! One formula serves every type, and Σᵢ wᵢ = 0 makes each gradient sum to zero over the
//! points (a translation does not change a distance).
//!
//! Edge–edge distances lose smoothness as the edges turn parallel; IPC's mollifier
//! ([`edge_edge_mollifier`]) multiplies their barrier to zero there.

use nalgebra::{Matrix2, SMatrix, SVector, Vector2, Vector3};

/// The 12 coordinates' gradient (x₀, y₀, z₀, x₁, …).
pub type Gradient12 = SVector<f64, 12>;
/// The 12 coordinates' Hessian.
pub type Hessian12 = SMatrix<f64, 12, 12>;

/// Which features of the pair are closest (local point indices 0..4, see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DistanceType {
    /// Point i to point j: s = |xᵢ − xⱼ|².
    PointPoint(usize, usize),
    /// Point i to the line through points a, b (closest point inside the segment).
    PointEdge(usize, usize, usize),
    /// Point 0 to the plane of triangle (1, 2, 3) (closest point inside the triangle).
    PointPlane,
    /// Line (0, 1) to line (2, 3) (closest points inside both segments).
    EdgeEdge,
}

/// A squared distance s (length²), its gradient (length) and Hessian (dimensionless) over the
/// 12 coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct SquaredDistance {
    /// The squared distance s (length²).
    pub value: f64,
    /// ∂s/∂x (length).
    pub gradient: Gradient12,
    /// ∂²s/∂x² (dimensionless).
    pub hessian: Hessian12,
}

/// Relative size of |a×b|² against |a|²|b|² below which two edges count as parallel for the
/// classification (their line–line minimiser is then ill-conditioned and the clamped
/// point–edge distances are used); far below the mollifier's 1e-3.
const PARALLEL: f64 = 1e-20;

/// The type of the squared distance from point `p` to triangle (`t0`, `t1`, `t2`).
pub fn point_triangle_type(
    p: &Vector3<f64>,
    t0: &Vector3<f64>,
    t1: &Vector3<f64>,
    t2: &Vector3<f64>,
) -> DistanceType {
    let x = [*p, *t0, *t1, *t2];
    if let Some((u, v)) = plane_parameters(&x)
        && u >= 0.0
        && v >= 0.0
        && u + v <= 1.0
    {
        return DistanceType::PointPlane;
    }
    closest_of(&x, &[(0, 1, 2), (0, 2, 3), (0, 3, 1)])
}

/// The type of the squared distance between segments (`a0`, `a1`) and (`b0`, `b1`).
pub fn edge_edge_type(
    a0: &Vector3<f64>,
    a1: &Vector3<f64>,
    b0: &Vector3<f64>,
    b1: &Vector3<f64>,
) -> DistanceType {
    let x = [*a0, *a1, *b0, *b1];
    if let Some((s, t)) = line_parameters(&x)
        && (0.0..=1.0).contains(&s)
        && (0.0..=1.0).contains(&t)
    {
        return DistanceType::EdgeEdge;
    }
    closest_of(&x, &[(0, 2, 3), (1, 2, 3), (2, 0, 1), (3, 0, 1)])
}

/// The squared distance (length²) from point `p` to the closed triangle (`t0`, `t1`, `t2`).
pub fn point_triangle_squared_distance(
    p: &Vector3<f64>,
    t0: &Vector3<f64>,
    t1: &Vector3<f64>,
    t2: &Vector3<f64>,
) -> f64 {
    let kind = point_triangle_type(p, t0, t1, t2);
    squared_distance(kind, &[*p, *t0, *t1, *t2])
}

/// The squared distance (length²) between the closed segments (`a0`, `a1`) and (`b0`, `b1`).
pub fn edge_edge_squared_distance(
    a0: &Vector3<f64>,
    a1: &Vector3<f64>,
    b0: &Vector3<f64>,
    b1: &Vector3<f64>,
) -> f64 {
    let kind = edge_edge_type(a0, a1, b0, b1);
    squared_distance(kind, &[*a0, *a1, *b0, *b1])
}

/// The squared distance s = |r|² (length²) of type `kind` between the pair's points `x` (NaN
/// for a type whose local indices are not distinct and below 4).
pub fn squared_distance(kind: DistanceType, x: &[Vector3<f64>; 4]) -> f64 {
    residual(kind, x).0.norm_squared()
}

/// The squared distance of type `kind` with its gradient and Hessian (see the module docs).
pub fn squared_distance_derivatives(kind: DistanceType, x: &[Vector3<f64>; 4]) -> SquaredDistance {
    let (r, w, dw, m) = residual(kind, x);
    let mut gradient = Gradient12::zeros();
    let mut hessian = Hessian12::zeros();
    for i in 0..4 {
        gradient
            .fixed_rows_mut::<3>(3 * i)
            .copy_from(&(2.0 * w[i] * r));
        for j in 0..4 {
            for a in 0..3 {
                hessian[(3 * i + a, 3 * j + a)] = 2.0 * w[i] * w[j];
            }
        }
    }
    if m > 0 {
        // g_k = ∂r/∂θ_k; the columns f_xθ_k; f_θθ = 2G.
        let g: Vec<Vector3<f64>> = (0..m)
            .map(|k| (0..4).map(|j| dw[j][k] * x[j]).sum())
            .collect();
        let columns: Vec<Gradient12> = (0..m)
            .map(|k| {
                let mut c = Gradient12::zeros();
                for i in 0..4 {
                    let block = 2.0 * dw[i][k] * r + 2.0 * w[i] * g[k];
                    c.fixed_rows_mut::<3>(3 * i).copy_from(&block);
                }
                c
            })
            .collect();
        let mut ftt = Matrix2::identity();
        for k in 0..m {
            for l in 0..m {
                ftt[(k, l)] = 2.0 * g[k].dot(&g[l]);
            }
        }
        let inverse = ftt.try_inverse().unwrap_or_else(Matrix2::zeros);
        for k in 0..m {
            for l in 0..m {
                hessian -= inverse[(k, l)] * columns[k] * columns[l].transpose();
            }
        }
    }
    SquaredDistance {
        value: r.norm_squared(),
        gradient,
        hessian,
    }
}

/// The residual r = Σ wᵢxᵢ at the minimiser of `kind`, with the weights w, their derivatives
/// ∂wᵢ/∂θₖ and the number of parameters.
fn residual(
    kind: DistanceType,
    x: &[Vector3<f64>; 4],
) -> (Vector3<f64>, [f64; 4], [[f64; 2]; 4], usize) {
    let mut w = [0.0; 4];
    let mut dw = [[0.0; 2]; 4];
    let in_range = match kind {
        DistanceType::PointPoint(i, j) => i.max(j) < 4 && i != j,
        DistanceType::PointEdge(i, a, b) => i.max(a).max(b) < 4 && i != a && i != b && a != b,
        _ => true,
    };
    if !in_range {
        // A type built with local indices outside the pair's four points: no distance.
        return (Vector3::repeat(f64::NAN), w, dw, 0);
    }
    let m = match kind {
        DistanceType::PointPoint(i, j) => {
            w[i] = 1.0;
            w[j] = -1.0;
            0
        }
        DistanceType::PointEdge(i, a, b) => {
            let t = segment_parameter(&x[i], &x[a], &x[b]);
            w[i] = 1.0;
            w[a] = -(1.0 - t);
            w[b] = -t;
            dw[a][0] = 1.0;
            dw[b][0] = -1.0;
            1
        }
        DistanceType::PointPlane => {
            let (u, v) = plane_parameters(x).unwrap_or((0.0, 0.0));
            w = [1.0, -(1.0 - u - v), -u, -v];
            dw = [[0.0, 0.0], [1.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
            2
        }
        DistanceType::EdgeEdge => {
            let (s, t) = line_parameters(x).unwrap_or((0.0, 0.0));
            w = [1.0 - s, s, -(1.0 - t), -t];
            dw = [[-1.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, -1.0]];
            2
        }
    };
    let r = (0..4).map(|i| w[i] * x[i]).sum();
    (r, w, dw, m)
}

/// t of the point on the line a + t(b − a) closest to p (unclamped); 0 for a = b.
fn segment_parameter(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let e = b - a;
    let ee = e.norm_squared();
    if ee > 0.0 { (p - a).dot(&e) / ee } else { 0.0 }
}

/// (u, v) of the point x₁ + u(x₂ − x₁) + v(x₃ − x₁) of the plane closest to x₀, or `None`
/// for a degenerate triangle.
fn plane_parameters(x: &[Vector3<f64>; 4]) -> Option<(f64, f64)> {
    let (e1, e2, d) = (x[2] - x[1], x[3] - x[1], x[0] - x[1]);
    let g = Matrix2::new(e1.dot(&e1), e1.dot(&e2), e1.dot(&e2), e2.dot(&e2));
    if e1.cross(&e2).norm_squared() <= PARALLEL * g[(0, 0)] * g[(1, 1)] {
        return None;
    }
    let uv = g.try_inverse()? * Vector2::new(e1.dot(&d), e2.dot(&d));
    Some((uv[0], uv[1]))
}

/// (s, t) of the closest points x₀ + s(x₁ − x₀), x₂ + t(x₃ − x₂) of the two lines, or `None`
/// for (nearly) parallel lines.
fn line_parameters(x: &[Vector3<f64>; 4]) -> Option<(f64, f64)> {
    let (a, b, d) = (x[1] - x[0], x[3] - x[2], x[2] - x[0]);
    let n = a.cross(&b);
    let nn = n.norm_squared();
    if nn <= PARALLEL * a.dot(&a) * b.dot(&b) {
        return None;
    }
    // s = ((x₂ − x₀)×b)·n/|n|², t = ((x₂ − x₀)×a)·n/|n|² with n = a×b: the normal equations'
    // determinant |a|²|b|² − (a·b)² is |n|², taken from the cross product itself. Formed by
    // that difference it cancelled to noise for nearly collinear edges (sin²θ ≈ 1e-19 on two
    // blocks' coplanar sides) and put both parameters of two disjoint segments inside [0, 1]:
    // a line–line distance of 1e-11 m for edges 1.9 mm apart, which stopped the continuous
    // collision detection at a fraction of the step.
    Some((d.cross(&b).dot(&n) / nn, d.cross(&a).dot(&n) / nn))
}

/// The closest of the point–segment distances (point, segment end, segment end), each typed
/// point–point where the segment's parameter clamps and point–edge inside.
fn closest_of(x: &[Vector3<f64>; 4], candidates: &[(usize, usize, usize)]) -> DistanceType {
    let mut best = (f64::INFINITY, DistanceType::PointPoint(0, 1));
    for &(p, a, b) in candidates {
        let t = segment_parameter(&x[p], &x[a], &x[b]);
        let kind = if t <= 0.0 {
            DistanceType::PointPoint(p, a)
        } else if t >= 1.0 {
            DistanceType::PointPoint(p, b)
        } else {
            DistanceType::PointEdge(p, a, b)
        };
        let s = squared_distance(kind, x);
        if s < best.0 {
            best = (s, kind);
        }
    }
    best.1
}

/// The edge–edge mollifier's threshold ε× = 10⁻³·|a|²·|b|² from the edges' rest squared
/// lengths (length⁴; IPC's choice).
pub fn mollifier_threshold(rest_a2: f64, rest_b2: f64) -> f64 {
    1e-3 * rest_a2 * rest_b2
}

/// IPC's edge–edge mollifier m(c) with c = |(x₁ − x₀) × (x₃ − x₂)|² (length⁴):
/// m = (2 − c/ε×)·c/ε× for c < ε×, 1 beyond — C¹ in c, zero for parallel edges, where the
/// edge–edge distance is not smooth and the point–triangle pairs carry the contact. Returns
/// m (dimensionless) with its gradient and Hessian over the 12 coordinates.
pub fn edge_edge_mollifier(x: &[Vector3<f64>; 4], threshold: f64) -> (f64, Gradient12, Hessian12) {
    let (a, b) = (x[1] - x[0], x[3] - x[2]);
    let c = a.cross(&b).norm_squared();
    if c >= threshold {
        return (1.0, Gradient12::zeros(), Hessian12::zeros());
    }
    let q = c / threshold;
    let m = (2.0 - q) * q;
    let m1 = 2.0 * (1.0 - q) / threshold;
    let m2 = -2.0 / (threshold * threshold);
    let (c_grad, c_hess) = cross_squared_derivatives(&a, &b);
    (
        m,
        m1 * c_grad,
        m2 * c_grad * c_grad.transpose() + m1 * c_hess,
    )
}

/// Gradient and Hessian over the 12 coordinates of c = |a×b|² = |a|²|b|² − (a·b)² with
/// a = x₁ − x₀, b = x₃ − x₂.
fn cross_squared_derivatives(a: &Vector3<f64>, b: &Vector3<f64>) -> (Gradient12, Hessian12) {
    let ab = a.dot(b);
    let ca = 2.0 * b.norm_squared() * a - 2.0 * ab * b;
    let cb = 2.0 * a.norm_squared() * b - 2.0 * ab * a;
    let i3 = nalgebra::Matrix3::identity();
    let caa = 2.0 * b.norm_squared() * i3 - 2.0 * b * b.transpose();
    let cbb = 2.0 * a.norm_squared() * i3 - 2.0 * a * a.transpose();
    let cab = 4.0 * a * b.transpose() - 2.0 * b * a.transpose() - 2.0 * ab * i3;
    // x₀ enters a with −1, x₁ with +1; x₂ enters b with −1, x₃ with +1.
    let sign = [-1.0, 1.0, -1.0, 1.0];
    let mut gradient = Gradient12::zeros();
    let mut hessian = Hessian12::zeros();
    for i in 0..4 {
        let gi = if i < 2 { ca } else { cb };
        gradient
            .fixed_rows_mut::<3>(3 * i)
            .copy_from(&(sign[i] * gi));
        for j in 0..4 {
            let block = match (i < 2, j < 2) {
                (true, true) => caa,
                (false, false) => cbb,
                (true, false) => cab,
                (false, true) => cab.transpose(),
            };
            hessian
                .fixed_view_mut::<3, 3>(3 * i, 3 * j)
                .copy_from(&(sign[i] * sign[j] * block));
        }
    }
    (gradient, hessian)
}
