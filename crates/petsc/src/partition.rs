//! The mesh cut into one part per MPI rank, and the global DOF numbering PETSc uses.
//!
//! - **Tets**: METIS (`METIS_PartMeshDual`, parts sharing faces, i.e. 3 common nodes) splits
//!   the tets into `parts` parts; rank r assembles the tets of part r and no other.
//! - **Nodes**: a node is owned by the lowest part among the tets that use it (a node no tet
//!   uses goes to part 0). Owned nodes are renumbered part by part, ascending in the mesh's
//!   order within a part, so that rank r owns the contiguous PETSc rows
//!   `3·node_starts[r] .. 3·node_starts[r+1]`: whole nodes, as block size 3 needs.
//! - **Global DOF** of mesh node n, axis a: `3·new_of_old[n] + a`.
//!
//! Every rank computes the same partition from the same mesh: METIS is deterministic with its
//! default options (a fixed seed), and [`Partition::checksum`] lets the ranks check that they
//! agree.

use std::ops::Range;

use tetfem::TetMesh;

use crate::error::{Error, Result};

/// The tets and nodes of a mesh split into parts, with the part-contiguous node numbering.
#[derive(Debug, Clone, PartialEq)]
pub struct Partition {
    parts: usize,
    tet_part: Vec<u32>,
    new_of_old: Vec<usize>,
    old_of_new: Vec<usize>,
    node_starts: Vec<usize>,
}

/// Preallocation of one rank's rows of the matrix: for each owned row, the non-zeros in the
/// columns the rank owns (`diagonal`) and in the others (`off_diagonal`), as PETSc's
/// `MatMPIAIJSetPreallocation` takes them.
#[derive(Debug, Clone, PartialEq)]
pub struct Preallocation {
    /// Non-zeros of each owned row in owned columns.
    pub diagonal: Vec<i32>,
    /// Non-zeros of each owned row in other ranks' columns.
    pub off_diagonal: Vec<i32>,
}

impl Partition {
    /// Splits `mesh` into `parts` parts (1 ≤ parts ≤ tet count; 1 needs no METIS call).
    ///
    /// Errors: `parts` out of range, a mesh too large for METIS's 32-bit indices, or METIS
    /// failing (its status is named).
    pub fn new(mesh: &TetMesh, parts: usize) -> Result<Self> {
        let tets = mesh.tets();
        if parts == 0 || parts > tets.len().max(1) {
            return Err(Error::invalid(
                "ranks (parts of the mesh)",
                parts,
                format!("must be between 1 and the tet count ({})", tets.len()),
            ));
        }
        let tet_part = if parts == 1 {
            vec![0u32; tets.len()]
        } else {
            metis_parts(mesh, parts)?
        };
        // Owner of a node: the lowest part among its tets.
        let mut owner = vec![u32::MAX; mesh.node_count()];
        for (tet, &part) in tets.iter().zip(&tet_part) {
            for &n in tet {
                owner[n] = owner[n].min(part);
            }
        }
        for o in &mut owner {
            if *o == u32::MAX {
                *o = 0;
            }
        }
        let mut counts = vec![0usize; parts];
        for &o in &owner {
            counts[o as usize] += 1;
        }
        let mut node_starts = Vec::with_capacity(parts + 1);
        node_starts.push(0);
        for c in &counts {
            node_starts.push(node_starts.last().copied().unwrap_or(0) + c);
        }
        let mut next = node_starts[..parts].to_vec();
        let mut new_of_old = vec![0usize; mesh.node_count()];
        let mut old_of_new = vec![0usize; mesh.node_count()];
        for (old, &o) in owner.iter().enumerate() {
            let new = next[o as usize];
            next[o as usize] += 1;
            new_of_old[old] = new;
            old_of_new[new] = old;
        }
        Ok(Partition {
            parts,
            tet_part,
            new_of_old,
            old_of_new,
            node_starts,
        })
    }

    /// Number of parts.
    pub fn parts(&self) -> usize {
        self.parts
    }

    /// The part of each tet.
    pub fn tet_parts(&self) -> &[u32] {
        &self.tet_part
    }

    /// The tets part `part` assembles.
    pub fn tets_of(&self, part: usize) -> impl Iterator<Item = usize> + '_ {
        self.tet_part
            .iter()
            .enumerate()
            .filter(move |&(_, &p)| p as usize == part)
            .map(|(t, _)| t)
    }

    /// The new (PETSc) index of mesh node `old`.
    pub fn new_of_old(&self, old: usize) -> usize {
        self.new_of_old[old]
    }

    /// The mesh node of new (PETSc) index `new`.
    pub fn old_of_new(&self, new: usize) -> usize {
        self.old_of_new[new]
    }

    /// The new indices of the nodes part `part` owns.
    pub fn owned_nodes(&self, part: usize) -> Range<usize> {
        self.node_starts[part]..self.node_starts[part + 1]
    }

    /// The PETSc rows (global DOFs) part `part` owns.
    pub fn owned_dofs(&self, part: usize) -> Range<usize> {
        let nodes = self.owned_nodes(part);
        3 * nodes.start..3 * nodes.end
    }

    /// The PETSc index of DOF `axis` of mesh node `old`.
    pub fn global_dof(&self, old: usize, axis: usize) -> usize {
        3 * self.new_of_old[old] + axis
    }

    /// Exact non-zero counts of part `part`'s rows: a row of node a has a 3-wide block for every
    /// node sharing a tet with a (itself included), whichever part assembles that tet.
    pub fn preallocation(&self, mesh: &TetMesh, part: usize) -> Preallocation {
        let owned = self.owned_nodes(part);
        let mut neighbours: Vec<Vec<usize>> = vec![Vec::new(); owned.len()];
        for tet in mesh.tets() {
            for &a in tet {
                let new_a = self.new_of_old[a];
                if owned.contains(&new_a) {
                    neighbours[new_a - owned.start].extend(tet.iter().map(|&b| self.new_of_old[b]));
                }
            }
        }
        let mut diagonal = Vec::with_capacity(3 * owned.len());
        let mut off_diagonal = Vec::with_capacity(3 * owned.len());
        for list in &mut neighbours {
            list.sort_unstable();
            list.dedup();
            let inside = list.iter().filter(|b| owned.contains(b)).count();
            let (d, o) = (3 * inside, 3 * (list.len() - inside));
            for _ in 0..3 {
                // At most 3 × the node count of the mesh's largest star: far below i32::MAX
                // for any mesh whose DOF count fits PetscInt (checked by the engine).
                diagonal.push(i32::try_from(d).unwrap_or(i32::MAX));
                off_diagonal.push(i32::try_from(o).unwrap_or(i32::MAX));
            }
        }
        Preallocation {
            diagonal,
            off_diagonal,
        }
    }

    /// A hash of the partition (FNV-1a over the tet parts), for the ranks to check that they
    /// computed the same one.
    pub fn checksum(&self) -> u64 {
        let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
        for &p in &self.tet_part {
            for byte in p.to_le_bytes() {
                hash ^= u64::from(byte);
                hash = hash.wrapping_mul(0x0100_0000_01b3);
            }
        }
        hash
    }
}

/// METIS's k-way partition of the tets' dual graph (tets sharing a face are neighbours).
fn metis_parts(mesh: &TetMesh, parts: usize) -> Result<Vec<u32>> {
    let tets = mesh.tets();
    let too_large = |what: &str, value: usize| {
        Error::invalid(
            what,
            value,
            "must fit METIS's 32-bit idx_t (at most 2147483647)",
        )
    };
    let mut ne = i32::try_from(tets.len()).map_err(|_| too_large("tet count", tets.len()))?;
    let mut nn =
        i32::try_from(mesh.node_count()).map_err(|_| too_large("node count", mesh.node_count()))?;
    let mut nparts = i32::try_from(parts).map_err(|_| too_large("parts", parts))?;
    if 4 * tets.len() > i32::MAX as usize {
        return Err(too_large("4 × tet count", 4 * tets.len()));
    }
    // Node indices are below node_count, which fits i32 (checked above).
    let mut eptr: Vec<i32> = (0..=tets.len()).map(|t| 4 * t as i32).collect();
    let mut eind: Vec<i32> = tets.iter().flatten().map(|&n| n as i32).collect();
    let mut ncommon = 3i32;
    let mut options = [0i32; metis_sys::METIS_NOPTIONS as usize];
    let mut objval = 0i32;
    let mut epart = vec![0i32; tets.len()];
    let mut npart = vec![0i32; mesh.node_count()];
    // METIS's random state is process-wide: one call at a time in this process, under the
    // same lock as the orderings of the linear algebra.
    let _one_at_a_time = tetfem::linalg::ordering::metis_lock();
    // SAFETY: every pointer refers to a live buffer of the size METIS_PartMeshDual reads or
    // writes for these arguments (eptr: ne + 1, eind: eptr[ne] = 4·ne, epart: ne, npart: nn,
    // options: METIS_NOPTIONS); the null vwgt, vsize and tpwgts ask for unit weights and equal
    // parts; the lock keeps other threads of this process out of METIS's global state.
    let status = unsafe {
        metis_sys::METIS_SetDefaultOptions(options.as_mut_ptr());
        metis_sys::METIS_PartMeshDual(
            &mut ne,
            &mut nn,
            eptr.as_mut_ptr(),
            eind.as_mut_ptr(),
            std::ptr::null_mut(),
            std::ptr::null_mut(),
            &mut ncommon,
            &mut nparts,
            std::ptr::null_mut(),
            options.as_mut_ptr(),
            &mut objval,
            epart.as_mut_ptr(),
            npart.as_mut_ptr(),
        )
    };
    if status != metis_sys::rstatus_et_METIS_OK {
        return Err(Error::invalid(
            "METIS_PartMeshDual status",
            status,
            format!(
                "must be METIS_OK ({}) partitioning {} tets into {parts} parts",
                metis_sys::rstatus_et_METIS_OK,
                tets.len()
            ),
        ));
    }
    epart
        .into_iter()
        .enumerate()
        .map(|(t, p)| {
            u32::try_from(p)
                .ok()
                .filter(|&p| (p as usize) < parts)
                .ok_or_else(|| {
                    Error::invalid(
                        format!("METIS part of tet {t}"),
                        p,
                        format!("must be in 0..{parts}"),
                    )
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use tetfem::{BoxSplit, TetMesh};

    fn bar() -> TetMesh {
        TetMesh::box_grid(
            [0.0, 0.0, 0.0].into(),
            [1.0, 0.1, 0.1].into(),
            [20, 2, 2],
            BoxSplit::Mirrored6,
        )
        .expect("a valid box")
    }

    #[test]
    fn numbering_is_a_permutation_with_contiguous_owned_ranges() {
        let mesh = bar();
        for parts in [1, 2, 3] {
            let p = Partition::new(&mesh, parts).expect("partition");
            let mut seen = vec![false; mesh.node_count()];
            for old in 0..mesh.node_count() {
                let new = p.new_of_old(old);
                assert!(!seen[new], "{parts} parts: new index {new} given twice");
                seen[new] = true;
                assert_eq!(p.old_of_new(new), old);
            }
            assert_eq!(p.owned_nodes(parts - 1).end, mesh.node_count());
            for part in 0..parts {
                // Each part owns some nodes and assembles some tets (METIS balances a 480-tet
                // bar into 2 or 3 parts of roughly equal size).
                assert!(!p.owned_nodes(part).is_empty(), "part {part} owns no node");
                assert!(p.tets_of(part).count() > 0, "part {part} has no tet");
            }
        }
    }

    #[test]
    fn owner_is_the_lowest_part_touching_the_node() {
        let mesh = bar();
        let p = Partition::new(&mesh, 2).expect("partition");
        for (t, tet) in mesh.tets().iter().enumerate() {
            for &n in tet {
                let owner = (0..2)
                    .find(|&r| p.owned_nodes(r).contains(&p.new_of_old(n)))
                    .expect("an owner");
                assert!(owner as u32 <= p.tet_parts()[t]);
            }
        }
    }

    #[test]
    fn preallocation_counts_match_the_assembled_pattern() {
        let mesh = bar();
        let p = Partition::new(&mesh, 2).expect("partition");
        // The global pattern from the core's assembler, in the new numbering: row nnz of each
        // DOF, split by owner of the column.
        let assembler = tetfem::Assembler::new(&mesh);
        let pattern = assembler.pattern();
        let total: usize = (0..2)
            .map(|part| {
                let pre = p.preallocation(&mesh, part);
                let dofs = p.owned_dofs(part);
                assert_eq!(pre.diagonal.len(), dofs.len());
                for (i, new_dof) in dofs.clone().enumerate() {
                    let old_dof = 3 * p.old_of_new(new_dof / 3) + new_dof % 3;
                    // The pattern is symmetric: column old_dof holds the rows of row old_dof.
                    let rows = &pattern.row_idx()
                        [pattern.col_ptr()[old_dof]..pattern.col_ptr()[old_dof + 1]];
                    let inside = rows
                        .iter()
                        .filter(|&&r| dofs.contains(&p.global_dof(r / 3, r % 3)))
                        .count();
                    assert_eq!(pre.diagonal[i] as usize, inside, "DOF {new_dof}");
                    assert_eq!(pre.off_diagonal[i] as usize, rows.len() - inside);
                }
                pre.diagonal
                    .iter()
                    .chain(&pre.off_diagonal)
                    .map(|&c| c as usize)
                    .sum::<usize>()
            })
            .sum();
        assert_eq!(total, assembler.nnz());
    }

    #[test]
    fn same_mesh_same_partition() {
        let mesh = bar();
        let a = Partition::new(&mesh, 2).expect("partition");
        let b = Partition::new(&mesh, 2).expect("partition");
        assert_eq!(a.checksum(), b.checksum());
        assert_eq!(a, b);
        // A different split gives a different checksum (else the ranks' check proves nothing).
        let c = Partition::new(&mesh, 3).expect("partition");
        assert_ne!(a.checksum(), c.checksum());
    }

    #[test]
    fn bad_part_counts_name_the_range() {
        let mesh = bar();
        for parts in [0, mesh.tet_count() + 1] {
            let message = Partition::new(&mesh, parts)
                .expect_err("out of range")
                .to_string();
            assert!(message.contains(&parts.to_string()), "{message}");
            assert!(message.contains("between 1 and"), "{message}");
        }
    }
}
