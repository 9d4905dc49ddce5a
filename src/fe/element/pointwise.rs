//! What the estimator needs of an element beyond the assembly seam: shape values and the
//! displacement gradient at any point, and where its nodes sit.

use nalgebra::{Matrix3, Vector3};

use crate::fe::element::isoparametric::{CurvedMap, ElementShape};
use crate::fe::element::tet10::{self, EDGES};
use crate::fe::element::{ElementType, Tet, Tet4, Tet10};

/// An element whose displacement can be evaluated at any barycentric point `l` = (L₀…L₃) of
/// its tet, whose geometry is an [`ElementShape`]: the corners' affine map, bent for a curved
/// 10-node tet.
pub trait PointwiseElement: ElementType {
    /// Polynomial degree of the displacement (1 for P1, 2 for P2): the recovered stress is
    /// interpolated with the same shape functions, so (σ* − σ_h):C⁻¹:(σ* − σ_h) has degree 2p.
    const DEGREE: usize;

    /// Barycentric coordinates of local node `i`.
    fn node_barycentric(i: usize) -> [f64; 4];

    /// The shape functions' values at `l`, one per node, written into `values` (length
    /// [`NODES`](crate::mesh::CellType::NODES)).
    fn shape_values_at(l: &[f64; 4], values: &mut [f64]);

    /// Displacement gradient ∇u (row i, column j: ∂uᵢ/∂xⱼ, dimensionless) at `l` for the
    /// element's node-major displacement `u`.
    fn displacement_gradient_at(shape: &ElementShape, l: &[f64; 4], u: &[f64]) -> Matrix3<f64>;
}

fn node_vector(u: &[f64], i: usize) -> Vector3<f64> {
    Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2])
}

impl PointwiseElement for Tet4 {
    const DEGREE: usize = 1;

    fn node_barycentric(i: usize) -> [f64; 4] {
        std::array::from_fn(|k| if k == i { 1.0 } else { 0.0 })
    }

    fn shape_values_at(l: &[f64; 4], values: &mut [f64]) {
        values.copy_from_slice(l);
    }

    fn displacement_gradient_at(shape: &ElementShape, _l: &[f64; 4], u: &[f64]) -> Matrix3<f64> {
        let mut grad = Matrix3::zeros();
        for (i, g) in shape.shape_gradients().iter().enumerate() {
            grad += node_vector(u, i) * g.transpose();
        }
        grad
    }
}

impl PointwiseElement for Tet10 {
    const DEGREE: usize = 2;

    fn node_barycentric(i: usize) -> [f64; 4] {
        let mut l = [0.0; 4];
        if i < 4 {
            l[i] = 1.0;
        } else {
            let (a, b) = EDGES[i - 4];
            l[a] = 0.5;
            l[b] = 0.5;
        }
        l
    }

    fn shape_values_at(l: &[f64; 4], values: &mut [f64]) {
        values.copy_from_slice(&tet10::shape_values(l));
    }

    /// On a curved tet ∇N = G⁻ᵀ∇_X N at `l` ([`ElementShape::curve_gradients`]).
    fn displacement_gradient_at(shape: &ElementShape, l: &[f64; 4], u: &[f64]) -> Matrix3<f64> {
        let mut grad = Matrix3::zeros();
        let gradients =
            shape.curve_gradients(l, tet10::shape_gradients(l, shape.shape_gradients()));
        for (i, g) in gradients.iter().enumerate() {
            grad += node_vector(u, i) * g.transpose();
        }
        grad
    }
}

/// The geometry of tet `t`: its corners' straight tet, bent when it is a curved 10-node tet
/// (edge nodes off their midpoints).
pub(crate) fn corners_of<C: crate::mesh::CellType>(
    mesh: &crate::mesh::TetMesh<C>,
    t: usize,
) -> ElementShape {
    // Cannot fail: `from_cells` rejected degenerate corners and reoriented negative ones.
    let corners = Tet::new(&mesh.corner_positions_of(t))
        .expect("TetMesh invariant: every tet is positively oriented and non-degenerate");
    let nodes = mesh.tets()[t];
    let nodes = nodes.as_ref();
    let map = if nodes.len() == 10 {
        let x: [Vector3<f64>; 10] = std::array::from_fn(|a| mesh.nodes()[nodes[a]]);
        CurvedMap::of(&x)
    } else {
        None
    };
    ElementShape::new(corners, map)
}
