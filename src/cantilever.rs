//! The cantilever benchmark: a box beam clamped at x = 0, loaded by a total end force spread as
//! a uniform traction over the face x = L and, optionally, by gravity.
//!
//! It is the embedded default scene of the command-line tool, the problem of the cross-checks
//! against independent codes, and a convergence benchmark.

use std::time::{Duration, Instant};

use nalgebra::Vector3;

use crate::assembly::Assembler;
use crate::beam_theory::RectangularCantilever;
use crate::constraints::{Constraints, DofMap};
use crate::error::{Error, Result};
use crate::loads::Loads;
use crate::material::Material;
use crate::mesh::{BoxSplit, TetMesh};
use crate::sparse::CscMatrix;
use crate::statics::{StaticSolution, StaticSolver, StaticTimings};

/// A clamped box beam [0, L]×[0, W]×[0, H] under an end load (−z) and gravity (−z).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cantilever {
    /// Length L along x (m in SI).
    pub length: f64,
    /// Width W along y.
    pub width: f64,
    /// Height H along z.
    pub height: f64,
    /// Cells along x, y, z.
    pub cells: [usize; 3],
    /// How each cell is split into tets.
    pub split: BoxSplit,
    /// The material.
    pub material: Material,
    /// Total end force P (N in SI), applied downward (−z) as the uniform traction P/(W·H) on the
    /// face x = L.
    pub end_load: f64,
    /// Gravitational acceleration g (m/s² in SI), acting along −z; 0 for none.
    pub gravity: f64,
}

/// The beam's linear system on its free DOFs: K_ff·u = f (N/m and N in SI).
#[derive(Debug, Clone)]
pub struct FreeSystem {
    /// The free/clamped DOF numbering.
    pub dofs: DofMap,
    /// K_ff, the stiffness restricted to the free DOFs.
    pub stiffness: CscMatrix,
    /// The end load (and gravity) on the free DOFs.
    pub load: Vec<f64>,
}

/// A solved cantilever.
#[derive(Debug, Clone)]
pub struct CantileverSolution {
    /// The mesh that was solved.
    pub mesh: TetMesh,
    /// The static solution.
    pub solution: StaticSolution,
    /// Mean z-displacement of the nodes on x = L (negative: downward).
    pub tip_deflection: f64,
    /// Wall time to generate the mesh.
    pub mesh_time: Duration,
    /// Wall time of the solver's phases.
    pub timings: StaticTimings,
    /// Stored values of the Cholesky factor.
    pub factor_len: usize,
    /// Free DOFs.
    pub free_dofs: usize,
}

impl Cantilever {
    /// The problem of the independent peer codes in `shared/peers`: L = 10, W = H = 1,
    /// E = 1e5, ν = 0.3, ρ = 1000, end load P = 1, no gravity, the lecture's split.
    pub fn peer_benchmark(cells: [usize; 3]) -> Self {
        Cantilever {
            length: 10.0,
            width: 1.0,
            height: 1.0,
            cells,
            split: BoxSplit::Lecture6,
            // Cannot fail: constants inside Material::new's ranges (E > 0, −1 < ν < 0.5, ρ > 0).
            material: Material::new(1e5, 0.3, 1000.0).expect("constant, valid material"),
            end_load: 1.0,
            gravity: 0.0,
        }
    }

    /// The embedded default scene: a 1 m steel beam of 0.1 m × 0.1 m section (E = 200 GPa,
    /// ν = 0.3, ρ = 7850 kg/m³), 100×10×10 cells, a 10 kN end load and gravity 9.81 m/s².
    pub fn steel_default() -> Self {
        Cantilever {
            length: 1.0,
            width: 0.1,
            height: 0.1,
            cells: [100, 10, 10],
            split: BoxSplit::Lecture6,
            material: Material::steel(),
            end_load: 10e3,
            gravity: 9.81,
        }
    }

    /// The mesh.
    pub fn mesh(&self) -> Result<TetMesh> {
        TetMesh::box_grid(
            Vector3::zeros(),
            Vector3::new(self.length, self.width, self.height),
            self.cells,
            self.split,
        )
    }

    /// All three components of every node on x = 0 fixed.
    pub fn constraints(&self, mesh: &TetMesh) -> Result<Constraints> {
        let mut constraints = Constraints::new(mesh);
        constraints.fix_nodes(&mesh.nodes_on_plane(0, 0.0, self.plane_tolerance()))?;
        Ok(constraints)
    }

    /// End load and gravity as nodal forces.
    pub fn loads(&self, mesh: &TetMesh) -> Result<Loads> {
        let mut loads = Loads::new(mesh);
        if self.end_load != 0.0 {
            let end_faces = mesh.faces_on_plane(
                &mesh.boundary_faces()?,
                0,
                self.length,
                self.plane_tolerance(),
            );
            loads.add_total_force_on_faces(
                mesh,
                &end_faces,
                Vector3::new(0.0, 0.0, -self.end_load),
            )?;
        }
        if self.gravity != 0.0 {
            loads.add_gravity(mesh, &self.material, Vector3::new(0.0, 0.0, -self.gravity))?;
        }
        Ok(loads)
    }

    /// K_ff and f of this beam on `mesh` (one of [`mesh`](Self::mesh)'s), for callers that
    /// solve or precondition the system themselves (benches, solver studies).
    pub fn free_system(&self, mesh: &TetMesh) -> Result<FreeSystem> {
        let dofs = DofMap::new(&self.constraints(mesh)?);
        let k = Assembler::new(mesh).stiffness(mesh, &self.material)?;
        let stiffness = dofs.restriction(k.pattern())?.restrict(&k)?;
        let load = dofs.restrict(self.loads(mesh)?.as_slice())?;
        Ok(FreeSystem {
            dofs,
            stiffness,
            load,
        })
    }

    /// Nodes on the end face x = L, whose mean z-displacement is the tip deflection.
    pub fn tip_nodes(&self, mesh: &TetMesh) -> Vec<usize> {
        mesh.nodes_on_plane(0, self.length, self.plane_tolerance())
    }

    /// Mean z-displacement of the tip nodes (`displacement` full length, 3 per node).
    pub fn tip_deflection(&self, mesh: &TetMesh, displacement: &[f64]) -> Result<f64> {
        Error::check_len("displacement", mesh.dof_count(), displacement.len())?;
        let tip = self.tip_nodes(mesh);
        if tip.is_empty() {
            return Err(Error::EmptySelection {
                context: format!("cantilever tip nodes at x = {}", self.length),
            });
        }
        Ok(tip.iter().map(|&n| displacement[3 * n + 2]).sum::<f64>() / tip.len() as f64)
    }

    /// Meshes, assembles, factors and solves.
    pub fn solve(&self) -> Result<CantileverSolution> {
        let clock = Instant::now();
        let mesh = self.mesh()?;
        let mesh_time = clock.elapsed();
        let constraints = self.constraints(&mesh)?;
        let loads = self.loads(&mesh)?;
        let mut solver = StaticSolver::new(&mesh, &self.material, &constraints)?;
        let solution = solver.solve(&loads)?;
        let tip_deflection = self.tip_deflection(&mesh, &solution.displacement)?;
        Ok(CantileverSolution {
            tip_deflection,
            mesh_time,
            timings: solver.timings(),
            factor_len: solver.factor_len(),
            free_dofs: solver.dofs().free_count(),
            mesh,
            solution,
        })
    }

    /// The beam-theory view of this problem.
    pub fn beam(&self) -> RectangularCantilever {
        RectangularCantilever {
            length: self.length,
            width: self.width,
            height: self.height,
            material: self.material,
        }
    }

    /// Tip deflection (downward negative) by Euler–Bernoulli and by Timoshenko theory: end load
    /// plus gravity as the line load ρ·g·A, superposed.
    pub fn beam_theory_tip(&self) -> (f64, f64) {
        let beam = self.beam();
        let line_load = self.material.density() * self.gravity * beam.area();
        let euler_bernoulli = beam.euler_bernoulli_end_load(self.end_load)
            + beam.euler_bernoulli_uniform_load(line_load);
        let timoshenko =
            beam.timoshenko_end_load(self.end_load) + beam.timoshenko_uniform_load(line_load);
        (-euler_bernoulli, -timoshenko)
    }

    fn plane_tolerance(&self) -> f64 {
        // The generator pins boundary coordinates exactly; this only absorbs round-off.
        1e-9 * self.length.max(self.width).max(self.height)
    }
}
