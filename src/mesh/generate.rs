//! Structured box meshes.

use nalgebra::Vector3;

use super::TetMesh;
use crate::base::error::{Error, Result};
use crate::mesh::geometry::signed_volume;

/// How each cube of a box grid is split into tets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BoxSplit {
    /// The lecture's 6-tet table. With cube corners numbered 1 + ix + 2·iy + 4·iz:
    /// `1 2 4 8 | 1 2 8 5 | 2 8 5 6 | 1 3 4 7 | 1 7 8 5 | 1 8 4 7`. Every cell uses the same
    /// table, and the table uses the same diagonal on opposite faces, so neighbouring cells
    /// conform. Tets 4 and 5 are negatively oriented as written and are stored flipped
    /// (`1 4 3 7`, `1 8 7 5`).
    ///
    /// Bias: all cells share one body diagonal (corner 1 to corner 8), so the mesh has no
    /// mirror plane, and a beam of square section bends sideways under a load along z: at
    /// 40×4×4 cells the tip moves by u_y ≈ 10 % of u_z in a static solve, and up to ±40 % in
    /// the default swing. Prefer [`BoxSplit::Mirrored6`] for bending.
    Lecture6,
    /// The lecture's 6-tet table mirrored in alternate cells: cell (cx, cy, cz) uses the table
    /// reflected across x if cx is odd, across y if cy is odd and across z if cz is odd (corner
    /// c → c XOR (cx mod 2 + 2·(cy mod 2) + 4·(cz mod 2))). The lecture table cuts opposite
    /// faces along the same diagonal, so a reflection across x leaves the diagonals of the x
    /// faces as they were and two neighbouring cells still share their face's diagonal: the
    /// mesh conforms, with 6 tets per cell.
    ///
    /// With an even number of cells along an axis, the mesh is mirror-symmetric about that
    /// axis' mid-plane (reflection maps cell c to n − 1 − c, of the other parity, whose table
    /// is the mirror image); with an odd number it is not (the middle layer of cells has no
    /// mirror partner), though pairs of cells still cancel most of the lean.
    #[default]
    Mirrored6,
    /// Five tets per cube: one central tet and four corner tets. Cells alternate between the
    /// split and its mirror image (by the parity of cx + cy + cz) so that face diagonals of
    /// neighbouring cells match.
    Five,
}

/// The lecture's table, 0-based corners (corner = ix + 2·iy + 4·iz), already positively
/// oriented (tets 4 and 5 have their 2nd and 3rd nodes swapped, as the mesh would do).
const LECTURE6: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 1, 7, 4],
    [1, 7, 4, 5],
    [0, 3, 2, 6],
    [0, 7, 6, 4],
    [0, 7, 3, 6],
];

/// Five-tet split with central tet {0, 3, 5, 6}; the corner tets hold corners 1, 2, 4, 7.
const FIVE_EVEN: [[usize; 4]; 5] = [
    [0, 3, 5, 6],
    [1, 0, 3, 5],
    [2, 0, 3, 6],
    [4, 0, 5, 6],
    [7, 3, 5, 6],
];
/// The mirror image: central tet {1, 2, 4, 7}; corner tets at 0, 3, 5, 6.
const FIVE_ODD: [[usize; 4]; 5] = [
    [1, 2, 4, 7],
    [0, 1, 2, 4],
    [3, 1, 2, 7],
    [5, 1, 4, 7],
    [6, 2, 4, 7],
];

impl TetMesh {
    /// A box [min, max] cut into `cells = [nx, ny, nz]` equal cubes (cuboids), each split by
    /// `split`.
    ///
    /// Node (ix, iy, iz) has index `ix + (nx+1)·(iy + (ny+1)·iz)` (x fastest), see
    /// [`box_node_index`]; the tets of cell `cx + nx·(cy + ny·cz)` are consecutive, in table
    /// order.
    pub fn box_grid(
        min: Vector3<f64>,
        max: Vector3<f64>,
        cells: [usize; 3],
        split: BoxSplit,
    ) -> Result<Self> {
        for axis in 0..3 {
            if cells[axis] == 0 {
                return Err(Error::invalid_parameter(
                    format!("cells[{axis}]"),
                    0,
                    "every axis needs at least one cell",
                ));
            }
            if !(min[axis].is_finite() && max[axis].is_finite() && max[axis] > min[axis]) {
                return Err(Error::invalid_parameter(
                    format!("box extent along axis {axis}"),
                    format!("[{}, {}]", min[axis], max[axis]),
                    "must be finite with max > min",
                ));
            }
        }
        let [nx, ny, nz] = cells;
        let too_many = || {
            Error::invalid_parameter("cells", format!("{cells:?}"), "too many nodes to allocate")
        };
        let node_count = [nx, ny, nz]
            .iter()
            .try_fold(1usize, |n, &c| n.checked_mul(c.checked_add(1)?))
            .ok_or_else(too_many)?;
        check_box_mesh_size(cells, split)
            .map_err(|e| Error::invalid_parameter("cells", format!("{cells:?}"), e.to_string()))?;
        let mut nodes = Vec::new();
        nodes
            .try_reserve_exact(node_count)
            .map_err(|_| too_many())?;
        let step = (max - min).component_div(&Vector3::new(nx as f64, ny as f64, nz as f64));
        for iz in 0..=nz {
            for iy in 0..=ny {
                for ix in 0..=nx {
                    // Pin the far faces exactly to `max` so that plane selections are exact.
                    let coord = |i: usize, n: usize, axis: usize| {
                        if i == n {
                            max[axis]
                        } else {
                            min[axis] + i as f64 * step[axis]
                        }
                    };
                    nodes.push(Vector3::new(
                        coord(ix, nx, 0),
                        coord(iy, ny, 1),
                        coord(iz, nz, 2),
                    ));
                }
            }
        }
        let per_cell = split.tets_per_cell();
        // nx·ny·nz < node_count, which fit; ×6 may not.
        let tet_count = (nx * ny * nz).checked_mul(per_cell).ok_or_else(too_many)?;
        let mut tets = Vec::new();
        tets.try_reserve_exact(tet_count).map_err(|_| too_many())?;
        for cz in 0..nz {
            for cy in 0..ny {
                for cx in 0..nx {
                    // The mirrored split reflects corner c by flipping its bits per axis.
                    let mirror = match split {
                        BoxSplit::Mirrored6 => (cx & 1) | (cy & 1) << 1 | (cz & 1) << 2,
                        _ => 0,
                    };
                    let corner = |c: usize| {
                        let c = c ^ mirror;
                        box_node_index(
                            cells,
                            cx + (c & 1),
                            cy + ((c >> 1) & 1),
                            cz + ((c >> 2) & 1),
                        )
                    };
                    let table: &[[usize; 4]] = match split {
                        BoxSplit::Lecture6 | BoxSplit::Mirrored6 => &LECTURE6,
                        BoxSplit::Five if (cx + cy + cz) % 2 == 0 => &FIVE_EVEN,
                        BoxSplit::Five => &FIVE_ODD,
                    };
                    tets.extend(table.iter().map(|t| t.map(corner)));
                }
            }
        }
        // Orient here what the tables leave negative (the mirrored cells of the five-tet and
        // the mirrored 6-tet splits), exactly as `TetMesh::new` would, so that its mixed-orientation warning is
        // kept for input meshes.
        for t in &mut tets {
            if signed_volume(&t.map(|n| nodes[n])) < 0.0 {
                t.swap(1, 2);
            }
        }
        TetMesh::new(nodes, tets)
    }
}

impl BoxSplit {
    /// Tets per cube.
    pub fn tets_per_cell(self) -> usize {
        match self {
            BoxSplit::Lecture6 | BoxSplit::Mirrored6 => 6,
            BoxSplit::Five => 5,
        }
    }
}

/// Before anything is allocated: [`Error::InsufficientMemory`] (turned into
/// [`Error::InvalidParameter`] on `cells` by [`TetMesh::box_grid`]) if the box mesh itself (24 bytes
/// per node, 32 per tet) does not fit in the memory available now (see
/// [`MemoryLimits`](crate::base::memory::MemoryLimits)). Counts in u128: any `cells` is answered
/// at once.
fn check_box_mesh_size(cells: [usize; 3], split: BoxSplit) -> Result<()> {
    let (nodes, tets) = crate::base::memory::box_counts(cells, split.tets_per_cell());
    let bytes = nodes
        .saturating_mul(24)
        .saturating_add(tets.saturating_mul(32));
    Ok(crate::base::memory::MemoryLimits::current().ensure_fits(
        format!(
            "the box mesh of {}×{}×{} cells ({nodes} nodes, {tets} tets)",
            cells[0], cells[1], cells[2]
        ),
        bytes,
    )?)
}

/// Index of grid node (ix, iy, iz) in a [`TetMesh::box_grid`] mesh with `cells = [nx, ny, nz]`:
/// `ix + (nx+1)·(iy + (ny+1)·iz)`.
pub fn box_node_index(cells: [usize; 3], ix: usize, iy: usize, iz: usize) -> usize {
    ix + (cells[0] + 1) * (iy + (cells[1] + 1) * iz)
}
