//! Element quality and mesh statistics, and the explicit critical time step.
//!
//! Per tet, from the shape-function gradients ∇Nᵢ (∇Nᵢ points from the face opposite node i
//! towards node i, |∇Nᵢ| = Aᵢ/(3V) with Aᵢ that face's area):
//! - dihedral angle at the edge shared by the faces opposite nodes k and l:
//!   cos θ = −∇N_k·∇N_l / (|∇N_k||∇N_l|); 70.53° everywhere for a regular tet;
//! - inradius r = 3V/ΣAᵢ = 1/Σ|∇Nᵢ|, smallest altitude h = 3V/max Aᵢ = 1/max|∇Nᵢ|;
//! - circumradius R from the circumcentre c (relative to x₀) solving 2·Dmᵀc = (|x₁−x₀|², …);
//! - aspect ratio R/(3r): 1 for a regular tet, growing without bound as it flattens.

use nalgebra::Vector3;

use super::TetMesh;
use crate::element::Tet;
use crate::material::Material;

/// Quality measures of one tet.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TetQuality {
    /// Volume (length³).
    pub volume: f64,
    /// Smallest of the six dihedral angles (radians).
    pub min_dihedral: f64,
    /// Largest of the six dihedral angles (radians).
    pub max_dihedral: f64,
    /// Radius ratio R/(3r) ≥ 1 (1 for a regular tet).
    pub aspect_ratio: f64,
    /// Inradius r (length).
    pub inradius: f64,
    /// Smallest altitude 3V/max Aᵢ (length).
    pub min_altitude: f64,
}

/// Quality of the tet with rest positions `x` (must be a valid, positively oriented tet).
pub fn tet_quality(element: &Tet, x: &[Vector3<f64>; 4]) -> TetQuality {
    let g = element.shape_gradients();
    let norms = g.map(|v| v.norm());
    let mut min_dihedral = f64::INFINITY;
    let mut max_dihedral: f64 = 0.0;
    for k in 0..4 {
        for l in k + 1..4 {
            let c = (-g[k].dot(&g[l]) / (norms[k] * norms[l])).clamp(-1.0, 1.0);
            let angle = c.acos();
            min_dihedral = min_dihedral.min(angle);
            max_dihedral = max_dihedral.max(angle);
        }
    }
    let inradius = 1.0 / norms.iter().sum::<f64>();
    let min_altitude = 1.0 / norms.iter().fold(0.0f64, |a, &b| a.max(b));
    let rhs = Vector3::new(
        (x[1] - x[0]).norm_squared(),
        (x[2] - x[0]).norm_squared(),
        (x[3] - x[0]).norm_squared(),
    ) * 0.5;
    // Dm⁻ᵀ = (Dm⁻¹)ᵀ, which the element already holds.
    let centre = element.rest_inverse().transpose() * rhs;
    let circumradius = centre.norm();
    TetQuality {
        volume: element.volume(),
        min_dihedral,
        max_dihedral,
        aspect_ratio: circumradius / (3.0 * inradius),
        inradius,
        min_altitude,
    }
}

/// Smallest, largest and mean of a quantity over the tets, with the tets where the extremes are.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Summary {
    /// Smallest value.
    pub min: f64,
    /// Tet with the smallest value.
    pub min_tet: usize,
    /// Largest value.
    pub max: f64,
    /// Tet with the largest value.
    pub max_tet: usize,
    /// Arithmetic mean.
    pub mean: f64,
}

impl Summary {
    fn of(values: impl Iterator<Item = f64>) -> Summary {
        let mut s = Summary {
            min: f64::INFINITY,
            min_tet: 0,
            max: f64::NEG_INFINITY,
            max_tet: 0,
            mean: 0.0,
        };
        let mut count = 0usize;
        for (i, v) in values.enumerate() {
            if v < s.min {
                s.min = v;
                s.min_tet = i;
            }
            if v > s.max {
                s.max = v;
                s.max_tet = i;
            }
            s.mean += v;
            count += 1;
        }
        s.mean /= count.max(1) as f64;
        s
    }
}

/// Counts, size and element quality of a mesh (what `tetfem info` prints).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MeshStatistics {
    /// Number of nodes.
    pub nodes: usize,
    /// Number of tets.
    pub tets: usize,
    /// Total volume (length³).
    pub volume: f64,
    /// Bounding box min corner.
    pub bbox_min: [f64; 3],
    /// Bounding box max corner.
    pub bbox_max: [f64; 3],
    /// Shortest and longest edge lengths over all tets (length).
    pub edge_length: (f64, f64),
    /// Tet volumes (length³).
    pub tet_volume: Summary,
    /// Smallest dihedral angle of each tet, in degrees (70.53° for a regular tet).
    pub min_dihedral_deg: Summary,
    /// Largest dihedral angle of each tet, in degrees.
    pub max_dihedral_deg: Summary,
    /// Aspect ratio R/(3r) of each tet (1 for a regular tet).
    pub aspect_ratio: Summary,
    /// Tets with a smallest dihedral angle under 5° (slivers and needles).
    pub poor_tets: usize,
}

/// Dihedral angle (degrees) under which [`MeshStatistics::poor_tets`] counts a tet.
pub const POOR_DIHEDRAL_DEG: f64 = 5.0;

impl TetMesh {
    /// Quality of every tet, in tet order.
    pub fn tet_qualities(&self) -> Vec<TetQuality> {
        (0..self.tet_count())
            .map(|t| tet_quality(&self.element_of(t), &self.positions_of(t)))
            .collect()
    }

    /// Warnings about this mesh: unused nodes, mixed orientation, poor elements (see
    /// [`Warning`](crate::warning::Warning)). One pass over the tets, O(tets).
    pub fn warnings(&self) -> Vec<crate::warning::Warning> {
        use crate::warning::Warning;
        let mut warnings = Vec::new();
        let unused = self.unused_nodes();
        if let Some(&first) = unused.first() {
            warnings.push(Warning::UnusedNodes {
                count: unused.len(),
                first,
            });
        }
        if self.reoriented_count() > 0 && self.reoriented_count() < self.tet_count() {
            warnings.push(Warning::MixedOrientation {
                reoriented: self.reoriented_count(),
                tets: self.tet_count(),
            });
        }
        let q = self.tet_qualities();
        let deg = 180.0 / std::f64::consts::PI;
        let poor = q
            .iter()
            .filter(|q| q.min_dihedral * deg < POOR_DIHEDRAL_DEG)
            .count();
        if poor > 0 {
            let dihedral = Summary::of(q.iter().map(|q| q.min_dihedral * deg));
            let mut altitudes: Vec<f64> = q.iter().map(|q| q.min_altitude).collect();
            altitudes.sort_unstable_by(f64::total_cmp);
            warnings.push(Warning::PoorElements {
                count: poor,
                worst_tet: dihedral.min_tet,
                worst_dihedral_deg: dihedral.min,
                dt_factor: altitudes[0] / altitudes[altitudes.len() / 2],
            });
        }
        warnings
    }

    /// Counts, volume, edge lengths and quality statistics.
    pub fn statistics(&self) -> MeshStatistics {
        let q = self.tet_qualities();
        let (lo, hi) = self.bounding_box();
        let mut shortest = f64::INFINITY;
        let mut longest: f64 = 0.0;
        for t in 0..self.tet_count() {
            let x = self.positions_of(t);
            for i in 0..4 {
                for j in i + 1..4 {
                    let l = (x[j] - x[i]).norm();
                    shortest = shortest.min(l);
                    longest = longest.max(l);
                }
            }
        }
        let deg = 180.0 / std::f64::consts::PI;
        MeshStatistics {
            nodes: self.node_count(),
            tets: self.tet_count(),
            volume: self.volume(),
            bbox_min: [lo.x, lo.y, lo.z],
            bbox_max: [hi.x, hi.y, hi.z],
            edge_length: (shortest, longest),
            tet_volume: Summary::of(q.iter().map(|q| q.volume)),
            min_dihedral_deg: Summary::of(q.iter().map(|q| q.min_dihedral * deg)),
            max_dihedral_deg: Summary::of(q.iter().map(|q| q.max_dihedral * deg)),
            aspect_ratio: Summary::of(q.iter().map(|q| q.aspect_ratio)),
            poor_tets: q
                .iter()
                .filter(|q| q.min_dihedral * deg < POOR_DIHEDRAL_DEG)
                .count(),
        }
    }
}

/// The explicit (central-difference, lumped-mass, undamped) critical time step of a mesh and
/// material.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CriticalStep {
    /// Element bound 2/max ωₑ (time units): ωₑ² = λ_max(Kₑ)/(ρVₑ/4) is the largest eigenvalue
    /// of the tet's own lumped-mass problem. By the element eigenvalue theorem the assembled
    /// ω_max ≤ maxₑ ωₑ, so a step below this is stable for the undamped linear system (Dirichlet
    /// constraints only lower ω_max).
    pub dt_element: f64,
    /// The tet that sets `dt_element`.
    pub tet: usize,
    /// The geometric estimate minₑ hₑ/c_p, hₑ the smallest altitude of tet e and
    /// c_p = √((λ+2μ)/ρ) the P-wave speed; the usual rule of thumb, shown for comparison
    /// (it is not a bound: `dt_element` is typically 0.3–0.6 of it on linear tets).
    pub dt_geometric: f64,
    /// The P-wave speed c_p (length/time).
    pub p_wave_speed: f64,
}

/// Computes [`CriticalStep`] for `mesh` made of `material`: one 12×12 symmetric eigenvalue
/// problem per tet.
pub fn critical_time_step(mesh: &TetMesh, material: &Material) -> CriticalStep {
    critical_step_by(mesh, material)
}

/// [`critical_time_step`] with each tet's own material: ωₑ and hₑ/c_p,e per tet;
/// `p_wave_speed` is then the largest c_p of the materials.
///
/// Errors: `materials` do not cover the mesh's tets.
pub fn critical_time_step_of(
    mesh: &TetMesh,
    materials: &impl crate::materials::TetMaterials,
) -> crate::error::Result<CriticalStep> {
    materials.check_tet_count(mesh)?;
    Ok(critical_step_by(mesh, materials))
}

/// [`critical_time_step_of`] for materials checked against the mesh.
fn critical_step_by(
    mesh: &TetMesh,
    materials: &impl crate::materials::TetMaterials,
) -> CriticalStep {
    let speeds: Vec<f64> = materials
        .material_list()
        .iter()
        .map(|m| m.p_wave_speed())
        .collect();
    let c_p = speeds.iter().copied().fold(0.0, f64::max);
    let mut worst_omega_sq: f64 = 0.0;
    let mut tet = 0;
    let mut dt_geometric = f64::INFINITY;
    for t in 0..mesh.tet_count() {
        let material = materials.material_of(t);
        let element = mesh.element_of(t);
        let k = element.stiffness(material);
        let lambda_max = k
            .symmetric_eigenvalues()
            .iter()
            .fold(0.0f64, |a, &b| a.max(b));
        let omega_sq = lambda_max / element.lumped_mass(material.density());
        if omega_sq > worst_omega_sq {
            worst_omega_sq = omega_sq;
            tet = t;
        }
        let q = tet_quality(&element, &mesh.positions_of(t));
        dt_geometric = dt_geometric.min(q.min_altitude / speeds[materials.index_of(t)]);
    }
    CriticalStep {
        dt_element: 2.0 / worst_omega_sq.sqrt(),
        tet,
        dt_geometric,
        p_wave_speed: c_p,
    }
}
