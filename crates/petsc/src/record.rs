//! What a run records while it goes: probe means and energies reduced over the ranks, the CSV
//! series rank 0 writes, and the parallel `.vtu` frames (each rank its piece).

use std::path::PathBuf;

use tetfem::TetMesh;
use tetfem::output::{CsvSeries, CsvValue, VtuFormat};
use tetfem_scene::Probe;

use crate::error::{Error, Result};
use crate::ffi::{Matrix, Petsc, Vector};
use crate::partition::Partition;
use crate::pvtu::PvtuFiles;

/// What each probe records (3 per probe): the mean displacement of its nodes, or for a point
/// probe Σᵢ Nᵢ uᵢ over the nodes of the tet holding the point ([`Probe::displacement`]), from
/// this rank's entries `local` of a distributed vector (its owned DOFs, in PETSc order),
/// summed over the ranks. Collective.
pub fn probe_means(
    petsc: &Petsc,
    partition: &Partition,
    probes: &[Probe],
    local: &[f64],
) -> Result<Vec<[f64; 3]>> {
    let nodes = partition.owned_nodes(petsc.rank());
    let mut sums: Vec<f64> = Vec::with_capacity(3 * probes.len());
    for probe in probes {
        let mut sum = [0.0; 3];
        for (j, &old) in probe.nodes.iter().enumerate() {
            let new = partition.new_of_old(old);
            if nodes.contains(&new) {
                // A node set's nodes count alike (their mean below); a point's by its shape
                // function there.
                let weight = probe.point.as_ref().map_or(1.0, |p| p.weights[j]);
                let i = 3 * (new - nodes.start);
                for k in 0..3 {
                    sum[k] += weight * local[i + k];
                }
            }
        }
        sums.extend(sum);
    }
    petsc.sum(&mut sums)?;
    Ok(probes
        .iter()
        .zip(sums.chunks_exact(3))
        .map(|(probe, sum)| {
            let count = match probe.point {
                Some(_) => 1.0,
                None => probe.nodes.len().max(1) as f64,
            };
            [sum[0] / count, sum[1] / count, sum[2] / count]
        })
        .collect())
}

/// The nodes of this rank's tets and their PETSc DOFs: what its `.vtu` piece shows.
#[derive(Debug, Clone)]
pub struct Piece {
    tets: Vec<usize>,
    nodes: Vec<usize>,
    indices: Vec<i32>,
}

impl Piece {
    /// The piece of rank `rank`.
    pub fn new(mesh: &TetMesh, partition: &Partition, rank: usize) -> Self {
        let tets: Vec<usize> = partition.tets_of(rank).collect();
        let mut nodes: Vec<usize> = tets.iter().flat_map(|&t| mesh.tets()[t]).collect();
        nodes.sort_unstable();
        nodes.dedup();
        // Below 3 × node count, which the engine checked fits PetscInt.
        let indices = nodes
            .iter()
            .flat_map(|&n| (0..3).map(move |a| partition.global_dof(n, a) as i32))
            .collect();
        Piece {
            tets,
            nodes,
            indices,
        }
    }

    /// The tets of the piece (this rank's).
    pub fn tets(&self) -> &[usize] {
        &self.tets
    }

    /// The PETSc DOFs of the piece's nodes (3 per node, in the order of the nodes).
    pub fn indices(&self) -> &[i32] {
        &self.indices
    }

    /// The position of mesh node `node` among the piece's nodes.
    pub fn position(&self, node: usize) -> Option<usize> {
        self.nodes.binary_search(&node).ok()
    }

    /// Fetches this piece's values of `u` (collective) and writes it as `files`' piece of this
    /// rank; rank 0 also writes the `.pvtu`. Then every rank learns whether all wrote
    /// (collective), so a failed write stops every rank alike.
    pub fn write(
        &self,
        petsc: &Petsc,
        mesh: &TetMesh,
        u: &Vector<'_>,
        files: &PvtuFiles,
    ) -> Result<()> {
        let values = u.entries(&self.indices)?;
        let written = files
            .write_piece(petsc.rank(), mesh, &self.tets, &self.nodes, &values)
            .and_then(|_| match petsc.rank() {
                0 => files.write_pvtu(petsc.size()).map(|_| ()),
                _ => Ok(()),
            });
        petsc.agree(written)
    }
}

/// The recording of a dynamic run: a CSV row per step (rank 0) and a `.vtu` frame every
/// `every` steps and at the last.
#[derive(Debug)]
pub struct Recorder<'a> {
    mesh: &'a TetMesh,
    partition: &'a Partition,
    probes: &'a [Probe],
    piece: Option<Piece>,
    directory: PathBuf,
    stem: String,
    every: usize,
    digits: usize,
    frames: Vec<(f64, PathBuf)>,
    /// Rank 0's CSV (column names with units, as the CLI's: `time_s`, `step`,
    /// `<probe>_ux_m`…, `kinetic_J`, `elastic_J`).
    csv: Option<CsvSeries>,
    format: VtuFormat,
    /// ½·d·Σ u_c² over this rank's constrained DOFs: what the zeroed rows add to ½·uᵀK·u.
    constrained_energy: f64,
    /// The last row: time, step, probe means, kinetic and elastic energy.
    last_row: Vec<f64>,
}

impl<'a> Recorder<'a> {
    /// A recorder writing into `directory` with `stem` (`.vtu` frames when `vtu`, the CSV
    /// when `csv`; rank 0 creates the CSV file now), its pieces encoded as `format`.
    /// `constrained_energy`: ½·d·Σ u_c² of this rank's constrained rows.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        petsc: &Petsc,
        mesh: &'a TetMesh,
        partition: &'a Partition,
        probes: &'a [Probe],
        directory: PathBuf,
        stem: String,
        vtu: bool,
        csv: bool,
        format: VtuFormat,
        every: usize,
        steps: usize,
        constrained_energy: f64,
    ) -> Result<Self> {
        // Created on rank 0, then agreed on: a rank 0 that cannot create it stops every rank.
        let create = || -> Result<Option<CsvSeries>> {
            if !(csv && petsc.rank() == 0) {
                return Ok(None);
            }
            let mut columns = vec!["time_s".to_string(), "step".to_string()];
            for p in probes {
                for c in ["ux", "uy", "uz"] {
                    columns.push(format!("{}_{c}_m", p.name));
                }
            }
            columns.extend(["kinetic_J".to_string(), "elastic_J".to_string()]);
            let path = directory.join(format!("{stem}_petsc.csv"));
            Ok(Some(CsvSeries::new(path, columns)?))
        };
        let csv = petsc.agree(create())?;
        Ok(Recorder {
            mesh,
            partition,
            probes,
            piece: vtu.then(|| Piece::new(mesh, partition, petsc.rank())),
            directory,
            stem,
            every: every.max(1),
            digits: steps.to_string().len().max(4),
            frames: Vec::new(),
            csv,
            format,
            constrained_energy,
            last_row: Vec::new(),
        })
    }

    /// Records the state after `step` steps (0: the initial state) at `time`: the CSV row, and
    /// a frame when `step` is a multiple of `every` or `last`. Collective.
    #[allow(clippy::too_many_arguments)]
    pub fn record<'p>(
        &mut self,
        petsc: &'p Petsc,
        step: usize,
        time: f64,
        u: &Vector<'p>,
        v: &Vector<'p>,
        stiffness: &Matrix<'p>,
        mass: &Vector<'p>,
        work: &mut Vector<'p>,
        last: bool,
    ) -> Result<()> {
        let local = u.local_values()?;
        let probes = probe_means(petsc, self.partition, self.probes, &local)?;
        // Kinetic ½·vᵀM·v, elastic ½·u_fᵀK_ff·u_f (the zeroed rows' part taken off).
        stiffness.mult(u, work)?;
        let elastic_local: f64 = local
            .iter()
            .zip(work.local_values()?)
            .map(|(a, b)| a * b)
            .sum();
        let kinetic_local: f64 = v
            .local_values()?
            .iter()
            .zip(mass.local_values()?)
            .map(|(v, m)| m * v * v)
            .sum();
        let mut energies = [
            0.5 * kinetic_local,
            0.5 * elastic_local - self.constrained_energy,
        ];
        petsc.sum(&mut energies)?;
        let mut row = vec![time, step as f64];
        row.extend(probes.iter().flatten());
        row.extend(energies);
        let written = match &mut self.csv {
            Some(csv) => {
                // The step is an integer column (digits, not `1e0`).
                let values: Vec<CsvValue> = [CsvValue::Real(time), CsvValue::from(step)]
                    .into_iter()
                    .chain(row[2..].iter().map(|&v| CsvValue::Real(v)))
                    .collect();
                csv.push_values(&values).map_err(Error::from)
            }
            None => Ok(()),
        };
        self.last_row = row;
        petsc.agree(written)?;
        if !(step.is_multiple_of(self.every) || last) {
            return Ok(());
        }
        if let Some(csv) = &mut self.csv {
            // Whole rows only: CsvSeries writes its buffer at row boundaries.
            let flushed = csv.write().map_err(Error::from);
            petsc.agree(flushed)?;
        } else {
            petsc.agree(Ok(()))?;
        }
        if let Some(piece) = &self.piece {
            let files = PvtuFiles::frame(&self.directory, &self.stem, step, self.digits)
                .with_format(self.format);
            piece.write(petsc, self.mesh, u, &files)?;
            self.frames.push((time, files.pvtu()));
            let listed = match petsc.rank() {
                0 => files.write_pvd(&self.frames).map(|_| ()),
                _ => Ok(()),
            };
            petsc.agree(listed)?;
        }
        Ok(())
    }

    /// The last row recorded: time, step, each probe's mean (3 each), kinetic and elastic
    /// energy.
    pub fn last_row(&self) -> &[f64] {
        &self.last_row
    }

    /// The files written (rank 0's view: the `.pvd` and the CSV).
    pub fn files(&self) -> Vec<PathBuf> {
        let mut files = Vec::new();
        if self.piece.is_some() {
            files.push(PvtuFiles::new(&self.directory, &self.stem).pvd());
        }
        if let Some(csv) = &self.csv {
            files.push(csv.path().to_path_buf());
        }
        files
    }
}
