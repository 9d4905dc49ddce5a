//! The linear mixed body as one operator for the analyses that add inertia to it, on either
//! mixed element ([`MixedElement`]): the blocks K_dev, B and the pressure block C of the
//! element (Taylor–Hood P2–P1 on 10-node tets, C = M_p/κ; the stabilized P1–P1 on 4-node tets,
//! C = M_p/κ + (1/μ)(M_p − M_Π)) and the consistent mass M on the free displacement DOFs, and
//! the shifted saddle point
//!
//! ```text
//!   A(c) = ⎡ K_dev,ff + c·M_ff   −B_fᵀ ⎤
//!          ⎣ −B_f               −C     ⎦
//! ```
//!
//! which backward Euler (c = 1/dt²), Newmark (c = 4/dt²) and the modal shift-invert (c = −σ)
//! factor once. The pressure has no inertia, so eliminating it exactly leaves the condensed
//! stiffness K_eff = K_dev + BᵀC⁻¹B (force/length): the time methods and the modal
//! iteration act on (K_eff, M) while solving only the sparse A(c). For c > 0 the first block
//! is positive definite without any support (the mass holds the rigid motions) and C is
//! positive definite for every ν < 0.5 (M_p/κ is, the stabilization is semi-definite), so
//! A(c) is symmetric quasi-definite and the LDLᵀ needs no pivoting.

use std::sync::Arc;

use faer::sparse::SymbolicSparseColMat;

use crate::analysis::mixed_statics::{LinearSaddlePoint, nodal_pressure};
use crate::analysis::problem::Problem;
use crate::base::error::{Error, Result};
use crate::base::memory::{SolverMemory, StaticEstimate};
use crate::bc::constraints::{Constraints, DofMap};
use crate::fe::element::taylor_hood::PressureNodes;
use crate::fe::element::{MixedElement, Tet10};
use crate::fe::materials::TetMaterials;
use crate::linsolve::SparseCholesky;
use crate::mesh::TetMesh;
use crate::sparse::CscMatrix;

/// The assembled linear mixed body on element `E` (10-node Taylor–Hood by default, or the
/// 4-node stabilized P1–P1; see the [module](self) docs).
#[derive(Debug)]
pub struct MixedOperator<E: MixedElement = Tet10> {
    dofs: DofMap,
    pressure_nodes: PressureNodes,
    tets: Vec<E::Nodes>,
    couplings: Vec<E::Coupling>,
    node_count: usize,
    /// K_dev on every DOF (force/length).
    deviatoric: CscMatrix,
    /// K_dev,ff.
    free_deviatoric: CscMatrix,
    /// M_ff, consistent, on the pattern of K_dev,ff (mass units).
    mass: CscMatrix,
    /// A(0).
    saddle: CscMatrix,
    /// C on the pressure unknowns (length³/Pa), positive definite.
    pressure_block: CscMatrix,
    /// Its Cholesky factor, for the pressure that u alone implies.
    pressure_factor: SparseCholesky,
}

impl<E: MixedElement> MixedOperator<E> {
    /// Assembles the blocks of `mesh` with `materials` (every ν < 0.5). With `held` the
    /// supports must hold every rigid motion ([`Error::NotConstrained`]), as K_eff alone must
    /// be definite (a modal analysis at shift 0); without it a free body is accepted (a time
    /// step's c·M holds it).
    pub fn new(
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
        held: bool,
    ) -> Result<Self> {
        crate::analysis::problem::ensure_mesh_dofs(mesh, "constraints", constraints.dof_count())?;
        ensure_operator_fits(mesh)?;
        materials.check_tet_count(mesh)?;
        let problem = if held {
            Problem::new(mesh, constraints)?
        } else {
            Problem::with_dofs(mesh, DofMap::new(constraints))?
        };
        let mass = problem.free_consistent_mass(materials)?;
        let LinearSaddlePoint {
            dofs,
            pressure_nodes,
            couplings,
            deviatoric,
            free_deviatoric,
            saddle,
        } = LinearSaddlePoint::assemble(mesh, materials, problem)?;
        if mass.col_ptr() != free_deviatoric.col_ptr()
            || mass.row_idx() != free_deviatoric.row_idx()
        {
            return Err(Error::Solver(
                "mixed operator: the mass and the deviatoric stiffness differ in pattern".into(),
            ));
        }
        let pressure_block = lower_block(&saddle, dofs.free_count())?;
        let mut pressure_factor = SparseCholesky::analyze(&pressure_block)?;
        pressure_factor.factorize(&pressure_block)?;
        Ok(MixedOperator {
            dofs,
            pressure_nodes,
            tets: mesh.tets().to_vec(),
            couplings,
            node_count: mesh.node_count(),
            deviatoric,
            free_deviatoric,
            mass,
            saddle,
            pressure_block,
            pressure_factor,
        })
    }

    /// A(c): the saddle point with c·M_ff (c in 1/time²) added to its first block.
    pub fn shifted(&self, c: f64) -> CscMatrix {
        let mut out = self.saddle.clone();
        let (k_ptr, m_values) = (self.free_deviatoric.col_ptr(), self.mass.values());
        let a_ptr = out.col_ptr().to_vec();
        let values = out.values_mut();
        // Each of the first n_f columns of A(0) begins with K_dev,ff's entries of that
        // column (same rows as M_ff's): the pressure rows follow them.
        for j in 0..self.dofs.free_count() {
            for e in 0..k_ptr[j + 1] - k_ptr[j] {
                values[a_ptr[j] + e] += c * m_values[k_ptr[j] + e];
            }
        }
        out
    }

    /// The free/constrained displacement DOF numbering.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// The pressure unknowns (the tets' corner nodes).
    pub fn pressure_nodes(&self) -> &PressureNodes {
        &self.pressure_nodes
    }

    /// M_ff, the consistent mass of the free DOFs (mass units).
    pub fn mass(&self) -> &CscMatrix {
        &self.mass
    }

    /// K_dev on every DOF (force/length).
    pub fn deviatoric(&self) -> &CscMatrix {
        &self.deviatoric
    }

    /// K_dev,ff (force/length).
    pub fn free_deviatoric(&self) -> &CscMatrix {
        &self.free_deviatoric
    }

    /// C on the pressure unknowns (length³/Pa): M_p/κ for Taylor–Hood, M_p/κ + (1/μ)(M_p − M_Π)
    /// for the stabilized P1–P1.
    pub fn pressure_block(&self) -> &CscMatrix {
        &self.pressure_block
    }

    /// B·u per pressure unknown for a full displacement `u`: ∫ L_k div u dV (length³).
    pub fn divergence(&self, u: &[f64]) -> Result<Vec<f64>> {
        Error::check_len("displacement", 3 * self.node_count, u.len())?;
        let mut out = vec![0.0; self.pressure_nodes.count()];
        for (tet, b) in self.tets.iter().zip(&self.couplings) {
            let corners = self.pressure_nodes.of_tet(tet.as_ref());
            for (k, &p) in corners.iter().enumerate() {
                for (i, &n) in tet.as_ref().iter().enumerate() {
                    for a in 0..3 {
                        out[p] += E::coupling_entry(b, k, i, a) * u[3 * n + a];
                    }
                }
            }
        }
        Ok(out)
    }

    /// Bᵀ·p on every DOF: the nodal forces ∫ p div v dV of the corner pressures `corner`
    /// (force units).
    pub fn pressure_force(&self, corner: &[f64]) -> Result<Vec<f64>> {
        Error::check_len(
            "corner pressures",
            self.pressure_nodes.count(),
            corner.len(),
        )?;
        let mut out = vec![0.0; 3 * self.node_count];
        for (tet, b) in self.tets.iter().zip(&self.couplings) {
            let corners = self.pressure_nodes.of_tet(tet.as_ref());
            for (k, &p) in corners.iter().enumerate() {
                for (i, &n) in tet.as_ref().iter().enumerate() {
                    for a in 0..3 {
                        out[3 * n + a] += E::coupling_entry(b, k, i, a) * corner[p];
                    }
                }
            }
        }
        Ok(out)
    }

    /// The pressure the full displacement `u` implies, p = −C⁻¹·B·u (Pa; the second
    /// row of the saddle point), per corner unknown.
    pub fn implied_pressure(&mut self, u: &[f64]) -> Result<Vec<f64>> {
        let mut p: Vec<f64> = self.divergence(u)?.iter().map(|d| -d).collect();
        self.pressure_factor.solve_in_place(&mut p)?;
        Ok(p)
    }

    /// The elastic energy ½·uᵀK_dev·u + ½·pᵀC·p (energy units) of a full displacement
    /// `u` and its corner pressures `corner`: ½·uᵀK_eff·u when p is the implied pressure.
    pub fn elastic_energy(&self, u: &[f64], corner: &[f64]) -> Result<f64> {
        Error::check_len(
            "corner pressures",
            self.pressure_nodes.count(),
            corner.len(),
        )?;
        Ok(0.5
            * (self.deviatoric.quadratic_form(u)? + self.pressure_block.quadratic_form(corner)?))
    }

    /// K_eff·x on the free DOFs (x zero on the supports): K_dev,ff·x − B_fᵀ·p with
    /// p = −C⁻¹·B_f·x; also returns the two terms' magnitude bound
    /// |K_dev,ff|·|x| + |B_fᵀ|·|p| (entry-wise), the scale of its round-off.
    pub fn condensed_product(&mut self, x: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
        Error::check_len("x", self.dofs.free_count(), x.len())?;
        let mut full = vec![0.0; 3 * self.node_count];
        for (value, &dof) in x.iter().zip(self.dofs.free_dofs()) {
            full[dof] = *value;
        }
        let p = self.implied_pressure(&full)?;
        let force = self.pressure_force(&p)?;
        let abs_p: Vec<f64> = p.iter().map(|v| v.abs()).collect();
        let abs_force = self.abs_pressure_force(&abs_p);
        let k = &self.free_deviatoric;
        let mut product = k.mul(x)?;
        let mut bound = vec![0.0; x.len()];
        let (col_ptr, row_idx, values) = (k.col_ptr(), k.row_idx(), k.values());
        for j in 0..x.len() {
            for e in col_ptr[j]..col_ptr[j + 1] {
                bound[row_idx[e]] += values[e].abs() * x[j].abs();
            }
        }
        for (f, &dof) in self.dofs.free_dofs().iter().enumerate() {
            product[f] -= force[dof];
            bound[f] += abs_force[dof];
        }
        Ok((product, bound))
    }

    /// |Bᵀ|·|p| on every DOF.
    fn abs_pressure_force(&self, abs_corner: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; 3 * self.node_count];
        for (tet, b) in self.tets.iter().zip(&self.couplings) {
            let corners = self.pressure_nodes.of_tet(tet.as_ref());
            for (k, &p) in corners.iter().enumerate() {
                for (i, &n) in tet.as_ref().iter().enumerate() {
                    for a in 0..3 {
                        out[3 * n + a] += E::coupling_entry(b, k, i, a).abs() * abs_corner[p];
                    }
                }
            }
        }
        out
    }

    /// The pressure at every node (Pa) from the corner values, linear along edges.
    pub fn nodal_pressure(&self, corner: &[f64]) -> Vec<f64> {
        nodal_pressure::<E>(&self.tets, &self.pressure_nodes, self.node_count, corner)
    }
}

/// Before any allocation: the blocks of the static mixed solve (the estimate of
/// [`MixedStaticSolver`](crate::MixedStaticSolver), the element's pattern (10- or 4-node) with
/// its LDLᵀ taken as the multigrid hierarchy's bytes) plus the consistent mass and A(c) (each
/// on K_ff's pattern) and the state vectors ([`StaticEstimate::dynamic_extra`]), against the
/// bounds of a factorizing run ([`Error::InsufficientMemory`] naming the size and the bound).
fn ensure_operator_fits<E: MixedElement>(mesh: &TetMesh<E>) -> Result<()> {
    let extra = StaticEstimate::for_element(
        mesh.node_count(),
        mesh.tet_count(),
        E::NODES,
        SolverMemory::Iterative,
    )
    .dynamic_extra();
    crate::analysis::mixed_statics::ensure_mixed_fits(
        mesh,
        "the mixed dynamic or modal operator",
        Some(("for the mass and the shifted saddle point", extra)),
    )
}

/// C: minus the lower-right block of A(0) (the rows and columns from `free_count` on).
fn lower_block(saddle: &CscMatrix, free_count: usize) -> Result<CscMatrix> {
    let dim = saddle.dim() - free_count;
    let mut col_ptr = vec![0usize];
    let (mut row_idx, mut values) = (Vec::new(), Vec::new());
    for j in free_count..saddle.dim() {
        for e in saddle.col_ptr()[j]..saddle.col_ptr()[j + 1] {
            let row = saddle.row_idx()[e];
            if row >= free_count {
                row_idx.push(row - free_count);
                values.push(-saddle.values()[e]);
            }
        }
        col_ptr.push(row_idx.len());
    }
    // Sorted rows of a square block by construction.
    let pattern = SymbolicSparseColMat::new_checked(dim, dim, col_ptr, None, row_idx);
    Ok(CscMatrix::from_values(Arc::new(pattern), values)?)
}
