//! The manufactured smooth solution on the unit cube shared by the convergence tests.

use std::f64::consts::PI;

use nalgebra::{Matrix3, Vector3};
use tetfem::fe::quadrature::tet_rule;
use tetfem::post::estimate::PointwiseElement;
use tetfem::{Loads, Material, Tet, TetMesh};

/// Manufactured field u = α·φ·(1, 1, 1) + A·x + c with φ = sin πx sin πy sin πz: smooth, not
/// zero on the boundary (the linear part gives non-homogeneous Dirichlet data), and with a body
/// force b = −∇·σ(u) = −α[μ Δφ (1,1,1) + (λ+μ) ∇∇φ·(1,1,1)] (the linear part adds none).
pub struct Manufactured {
    alpha: f64,
    a: Matrix3<f64>,
    c: Vector3<f64>,
}

impl Manufactured {
    pub fn new() -> Self {
        Manufactured {
            alpha: 1e-3,
            a: Matrix3::new(2e-4, -1e-4, 0.5e-4, 0.3e-4, -2e-4, 1e-4, 0.0, 1.5e-4, 1e-4),
            c: Vector3::new(1e-4, -2e-4, 0.5e-4),
        }
    }

    fn trig(p: &Vector3<f64>) -> ([f64; 3], [f64; 3]) {
        (
            [(PI * p.x).sin(), (PI * p.y).sin(), (PI * p.z).sin()],
            [(PI * p.x).cos(), (PI * p.y).cos(), (PI * p.z).cos()],
        )
    }

    pub fn displacement(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let (s, _) = Self::trig(p);
        Vector3::repeat(self.alpha * s[0] * s[1] * s[2]) + self.a * p + self.c
    }

    pub fn gradient(&self, p: &Vector3<f64>) -> Matrix3<f64> {
        let (s, c) = Self::trig(p);
        let grad_phi =
            Vector3::new(c[0] * s[1] * s[2], s[0] * c[1] * s[2], s[0] * s[1] * c[2]) * PI;
        // ∂uᵢ/∂xⱼ = α ∂φ/∂xⱼ for every i, plus Aᵢⱼ.
        Matrix3::from_fn(|_, j| self.alpha * grad_phi[j]) + self.a
    }

    pub fn body_force(&self, p: &Vector3<f64>, material: &Material) -> Vector3<f64> {
        let (s, c) = Self::trig(p);
        let phi = s[0] * s[1] * s[2];
        let pi2 = PI * PI;
        // Hessian of φ: diagonal −π²φ, off-diagonal π² cᵢcⱼsₖ.
        let hessian = Matrix3::new(
            -pi2 * phi,
            pi2 * c[0] * c[1] * s[2],
            pi2 * c[0] * s[1] * c[2],
            pi2 * c[0] * c[1] * s[2],
            -pi2 * phi,
            pi2 * s[0] * c[1] * c[2],
            pi2 * c[0] * s[1] * c[2],
            pi2 * s[0] * c[1] * c[2],
            -pi2 * phi,
        );
        let (lambda, mu) = (material.lame_lambda(), material.shear_modulus());
        let laplacian = -3.0 * pi2 * phi;
        -(Vector3::repeat(mu * laplacian) + hessian * Vector3::repeat(lambda + mu)) * self.alpha
    }
}

/// Tet `t`'s corner positions and its straight-sided geometry.
pub fn corners<E: PointwiseElement>(mesh: &TetMesh<E>, t: usize) -> ([Vector3<f64>; 4], Tet) {
    let tet = mesh.tets()[t].as_ref();
    let x: [Vector3<f64>; 4] = std::array::from_fn(|i| mesh.nodes()[tet[i]]);
    (x, Tet::new(&x).expect("mesh tets are valid"))
}

/// Consistent nodal loads ∫ b Nᵢ dV of a body-force field, by the degree-5 rule.
pub fn body_loads<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    b: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> Loads {
    let mut loads = Loads::new(mesh);
    let rule = tet_rule();
    let mut n = vec![0.0; E::NODES];
    for t in 0..mesh.tet_count() {
        let (x, tet) = corners(mesh, t);
        for q in &rule {
            let l = barycentric(&q.barycentric);
            let p = x[0] * l[0] + x[1] * l[1] + x[2] * l[2] + x[3] * l[3];
            let force = b(&p) * (q.weight * tet.volume());
            E::shape_values_at(&l, &mut n);
            for (i, &node) in mesh.tets()[t].as_ref().iter().enumerate() {
                loads
                    .add_nodal_force(node, force * n[i])
                    .expect("node in range");
            }
        }
    }
    loads
}

/// L₀…L₃ of a quadrature point given by (L₁, L₂, L₃).
pub fn barycentric(b: &Vector3<f64>) -> [f64; 4] {
    [1.0 - b.x - b.y - b.z, b.x, b.y, b.z]
}
