//! One static cantilever solve on linear (P1) or quadratic (P2) tets, timed from the mesh to the
//! solution: the unit of the accuracy-per-second study (`validate`'s "Accuracy per second" case,
//! and the `accuracy` program that `validation/side_by_side.py` runs beside the peers).
//!
//! The problem is the peers' cantilever (`Cantilever::peer_benchmark`: L = 10, W = H = 1,
//! E = 1e5, ν = 0.3, clamped at x = 0, end load P = 1 as a uniform traction on x = L) on the
//! lecture's 6-tet split of n × n/10 × n/10 cells. The quadratic mesh puts a node at the middle of
//! every edge of the same linear mesh (`TetMesh::<Tet10>::from_linear`, as scikit-fem's and
//! MFEM's P2 spaces do), so the three codes solve on identical meshes.

use std::time::Instant;

use tetfem::fe::element::ElementType;
use tetfem::{Result, Tet10, TetMesh, solve_static};
use tetfem_fixtures::cantilever::Cantilever;

/// What one run measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticRun {
    /// Polynomial degree of the elements: 1 (4-node tets) or 2 (10-node tets).
    pub order: usize,
    /// Cells of the box grid (6 tets each).
    pub cells: [usize; 3],
    /// Free degrees of freedom of the solve.
    pub free_dofs: usize,
    /// Tip deflection \[m\]: the mean z-displacement of the mesh *vertices* on x = L, for both
    /// orders (so P1 and P2 answer the same question on the same node set, and the peers'
    /// harness reports the same quantity).
    pub tip: f64,
    /// Wall time \[s\] from generating the mesh to holding the displacement: mesh (and its
    /// mid-edge nodes for P2), constraints, loads, assembly, ordering, factorization, solve.
    pub seconds: f64,
}

/// Solves the peers' cantilever of `cells` with elements of `order` (1 or 2) and times it.
///
/// Errors: an order other than 1 or 2, or whatever the solve reports.
pub fn static_cantilever(order: usize, cells: [usize; 3]) -> Result<StaticRun> {
    let problem = Cantilever::peer_benchmark(cells);
    let clock = Instant::now();
    let linear = problem.mesh()?;
    let (free_dofs, displacement) = match order {
        1 => solve(&problem, &linear)?,
        2 => solve(&problem, &TetMesh::<Tet10>::from_linear(&linear)?)?,
        other => {
            return Err(tetfem::Error::invalid_parameter(
                "order",
                other,
                "must be 1 (linear tets) or 2 (quadratic tets)",
            ));
        }
    };
    let seconds = clock.elapsed().as_secs_f64();
    // The quadratic mesh keeps the linear mesh's vertex numbering for its corners, so the
    // vertices' displacements are the first 3·(vertex count) entries of either solution.
    let tip = problem.tip_deflection(&linear, &displacement[..linear.dof_count()])?;
    Ok(StaticRun {
        order,
        cells,
        free_dofs,
        tip,
        seconds,
    })
}

/// Free DOF count and full displacement of one static solve on `mesh`.
fn solve<E: ElementType>(problem: &Cantilever, mesh: &TetMesh<E>) -> Result<(usize, Vec<f64>)> {
    let constraints = problem.constraints(mesh)?;
    let loads = problem.loads(mesh)?;
    let solution = solve_static(mesh, &problem.material, &constraints, &loads)?;
    Ok((
        mesh.dof_count() - constraints.count(),
        solution.displacement,
    ))
}
