//! Where the free DOFs sit, and the near-null space B of the stiffness matrix built from it: the
//! rigid-body modes, which K·b ≈ 0 leaves nearly unresisted and which multigrid must therefore
//! represent exactly on every coarse level.

use nalgebra::Vector3;

use crate::error::{Error, Result};
use crate::sparse::CscMatrix;

/// Node, axis and position of each unknown (free DOF) of a matrix whose rows are node
/// displacements: what smoothed aggregation needs beyond the matrix to build the rigid-body
/// modes. Plain coordinates and a DOF layout, nothing of a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct DofGeometry {
    node: Vec<usize>,
    axis: Vec<u8>,
    position: Vec<[f64; 3]>,
}

impl DofGeometry {
    /// The unknowns `free_dofs` (ascending or not; unknown i is full DOF `free_dofs[i]` =
    /// 3·node + axis) of a body whose nodes sit at `nodes`. [`Error::InvalidParameter`] naming
    /// the first DOF that is not below 3·`nodes.len()`.
    pub fn new(nodes: &[Vector3<f64>], free_dofs: &[usize]) -> Result<Self> {
        if let Some(&dof) = free_dofs.iter().find(|&&d| d >= 3 * nodes.len()) {
            return Err(Error::invalid_parameter(
                "free DOF",
                dof,
                format!(
                    "must be below 3 × {} nodes = {} (DOF 3·node + axis)",
                    nodes.len(),
                    3 * nodes.len()
                ),
            ));
        }
        Ok(DofGeometry {
            node: free_dofs.iter().map(|d| d / 3).collect(),
            axis: free_dofs.iter().map(|d| (d % 3) as u8).collect(),
            position: free_dofs
                .iter()
                .map(|d| {
                    let x = nodes[d / 3];
                    [x.x, x.y, x.z]
                })
                .collect(),
        })
    }

    /// Number of free DOFs described.
    pub fn len(&self) -> usize {
        self.node.len()
    }

    /// Whether there are no free DOFs.
    pub fn is_empty(&self) -> bool {
        self.node.is_empty()
    }
}

/// The near-null space B (n × m, row-major) of a matrix, with the node blocks of its rows: block
/// b is the DOFs `starts[b]..starts[b + 1]` (a node's free DOFs on the fine level, an
/// aggregate's coarse DOFs below).
#[derive(Debug, Clone, PartialEq)]
pub struct NearNullSpace {
    starts: Vec<usize>,
    modes: usize,
    values: Vec<f64>,
}

impl NearNullSpace {
    /// The six rigid-body modes of free DOFs at `geometry`: the translations e_x, e_y, e_z and
    /// the rotations e_c × (x − x₀)/ℓ (c = x, y, z), with x₀ the centre and ℓ the half-diagonal
    /// of the bounding box, so that all six columns are O(1) and B is well conditioned.
    /// [`Error::InvalidParameter`] if one node's DOFs are not consecutive (consecutive free DOFs of a node are)
    /// or a position is not finite.
    pub fn rigid_body(geometry: &DofGeometry) -> Result<Self> {
        let n = geometry.len();
        let mut starts = vec![0];
        let mut seen = std::collections::HashSet::new();
        let scattered = |node: usize| {
            Error::invalid_parameter(
                "DofGeometry",
                format!("node {node}"),
                "each node's DOFs must be consecutive",
            )
        };
        for i in 1..n {
            if geometry.node[i] != geometry.node[i - 1] {
                if !seen.insert(geometry.node[i - 1]) {
                    return Err(scattered(geometry.node[i - 1]));
                }
                starts.push(i);
            }
        }
        if n > 0 && seen.contains(&geometry.node[n - 1]) {
            return Err(scattered(geometry.node[n - 1]));
        }
        if n > 0 {
            starts.push(n);
        }
        if let Some(i) = geometry
            .position
            .iter()
            .position(|p| p.iter().any(|v| !v.is_finite()))
        {
            return Err(Error::invalid_parameter(
                "DofGeometry position",
                format!("free DOF {i}"),
                "must be finite",
            ));
        }
        let (mut low, mut high) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in &geometry.position {
            for c in 0..3 {
                low[c] = low[c].min(p[c]);
                high[c] = high[c].max(p[c]);
            }
        }
        let centre: Vec<f64> = (0..3).map(|c| 0.5 * (low[c] + high[c])).collect();
        let half_diagonal = 0.5
            * (0..3)
                .map(|c| (high[c] - low[c]).powi(2))
                .sum::<f64>()
                .sqrt();
        let scale = if half_diagonal > 0.0 {
            1.0 / half_diagonal
        } else {
            1.0
        };
        let mut values = vec![0.0; 6 * n];
        for i in 0..n {
            let axis = geometry.axis[i] as usize;
            let x: Vec<f64> = (0..3)
                .map(|c| (geometry.position[i][c] - centre[c]) * scale)
                .collect();
            let row = &mut values[6 * i..6 * i + 6];
            row[axis] = 1.0;
            // (e_c × x)_axis for the rotation about axis c: e_x × x = (0, −z, y),
            // e_y × x = (z, 0, −x), e_z × x = (−y, x, 0).
            let rotation = match axis {
                0 => [0.0, x[2], -x[1]],
                1 => [-x[2], 0.0, x[0]],
                _ => [x[1], -x[0], 0.0],
            };
            row[3..].copy_from_slice(&rotation);
        }
        Ok(NearNullSpace {
            starts,
            modes: 6,
            values,
        })
    }

    /// Without geometry: the three translations, on node blocks guessed from the matrix's
    /// supervariables (up to three consecutive columns with identical patterns; DOF k of a
    /// block is taken as axis k, which is right for every node whose three DOFs are free).
    pub fn translations(matrix: &CscMatrix) -> Self {
        let n = matrix.dim();
        let mut starts = crate::sparse::supervariable_starts(matrix);
        let mut values = vec![0.0; 3 * n];
        for b in 0..starts.len() - 1 {
            for (k, i) in (starts[b]..starts[b + 1]).enumerate() {
                values[3 * i + k] = 1.0;
            }
        }
        if n == 0 {
            starts = vec![0];
        }
        NearNullSpace {
            starts,
            modes: 3,
            values,
        }
    }

    /// A near-null space from its parts: `starts` the node blocks (0 first, n last, increasing)
    /// and `values` row-major n × `modes`.
    pub fn from_parts(starts: Vec<usize>, modes: usize, values: Vec<f64>) -> Result<Self> {
        let n = starts.last().copied().unwrap_or(0);
        if starts.first() != Some(&0) || starts.windows(2).any(|w| w[0] >= w[1]) {
            return Err(Error::invalid_parameter(
                "starts",
                format!("{} entries", starts.len()),
                "must begin at 0 and strictly increase",
            ));
        }
        Error::check_len("near-null-space values", n * modes, values.len())?;
        Ok(NearNullSpace {
            starts,
            modes,
            values,
        })
    }

    /// Number of rows (DOFs).
    pub fn dim(&self) -> usize {
        self.starts.last().copied().unwrap_or(0)
    }

    /// Number of columns (modes).
    pub fn modes(&self) -> usize {
        self.modes
    }

    /// Block boundaries: block b is DOFs `starts[b]..starts[b + 1]`.
    pub fn starts(&self) -> &[usize] {
        &self.starts
    }

    /// B row-major: entry (i, m) is `values[i·modes + m]`.
    pub fn values(&self) -> &[f64] {
        &self.values
    }
}
