//! Element quality and mesh statistics (the explicit critical step from the elements is in
//! [`crate::analysis::dynamics::element_step_bound`]).
//!
//! Per tet, from the shape-function gradients ∇Nᵢ (∇Nᵢ points from the face opposite node i
//! towards node i, |∇Nᵢ| = Aᵢ/(3V) with Aᵢ that face's area):
//! - dihedral angle at the edge shared by the faces opposite nodes k and l:
//!   cos θ = −∇N_k·∇N_l / (|∇N_k||∇N_l|); 70.53° everywhere for a regular tet;
//! - inradius r = 3V/ΣAᵢ = 1/Σ|∇Nᵢ|, smallest altitude h = 3V/max Aᵢ = 1/max|∇Nᵢ|;
//! - circumradius R from the circumcentre c (relative to x₀) solving 2·Dmᵀc = (|x₁−x₀|², …);
//! - aspect ratio R/(3r): 1 for a regular tet, growing without bound as it flattens.

use nalgebra::Vector3;

use crate::fe::element::Tet;
use crate::mesh::TetMesh;

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
    pub(crate) fn of(values: impl Iterator<Item = f64>) -> Summary {
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

pub use crate::base::warning::POOR_DIHEDRAL_DEG;

impl<C: crate::mesh::CellType> TetMesh<C> {
    /// Quality of every tet (of its corners), in tet order.
    pub fn tet_qualities(&self) -> Vec<TetQuality> {
        (0..self.tet_count())
            .map(|t| tet_quality(&self.element_of(t), &self.corner_positions_of(t)))
            .collect()
    }

    /// Counts, volume, edge lengths and quality statistics.
    pub fn statistics(&self) -> MeshStatistics {
        let q = self.tet_qualities();
        let (lo, hi) = self.bounding_box();
        let mut shortest = f64::INFINITY;
        let mut longest: f64 = 0.0;
        for t in 0..self.tet_count() {
            let x = self.corner_positions_of(t);
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

/// A mesh's warnings live with its quality measures, so that the mesh module knows nothing of
/// them.
impl<C: crate::mesh::CellType> crate::mesh::TetMesh<C> {
    /// Warnings about this mesh: unused nodes, mixed orientation, poor elements (see
    /// [`Warning`](crate::base::warning::Warning)). One pass over the tets, O(tets).
    pub fn warnings(&self) -> Vec<crate::base::warning::Warning> {
        let mut warnings = Vec::new();
        let unused = self.unused_nodes();
        if let Some(&first) = unused.first() {
            warnings.push(crate::base::warning::Warning::UnusedNodes {
                count: unused.len(),
                first,
            });
        }
        if self.reoriented_count() > 0 && self.reoriented_count() < self.tet_count() {
            warnings.push(crate::base::warning::Warning::MixedOrientation {
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
            warnings.push(crate::base::warning::Warning::PoorElements {
                count: poor,
                worst_tet: dihedral.min_tet,
                worst_dihedral_deg: dihedral.min,
                dt_factor: altitudes[0] / altitudes[altitudes.len() / 2],
            });
        }
        warnings
    }
}
