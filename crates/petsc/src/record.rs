//! What a run records while it goes: probe means, energies and support reactions reduced over
//! the ranks, the CSV series rank 0 writes, and the parallel `.vtu` frames (each rank its piece
//! of the in-process run's arrays).

use std::path::PathBuf;

use tetfem::TetMesh;
use tetfem::analysis::dynamics::InternalForce;
use tetfem::fe::materials::TetMaterials;
use tetfem::post::output::fields::symmetric_components;
use tetfem::post::output::{CsvSeries, CsvValue, FrameArrays, FrameExtras, OriginalIds, VtuFormat};
use tetfem_scene::{
    BuiltScene, EnergyTerms, Probe, ProbeRange, ReactionRow, dynamic_csv_columns,
    dynamic_frame_arrays, reaction_columns, reaction_rows,
};

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

/// The whole displacement (or any distributed vector) `x` in the mesh's numbering (3·node +
/// axis), on every rank. Collective.
pub fn full_values(x: &Vector<'_>, partition: &Partition, dofs: usize) -> Result<Vec<f64>> {
    // Below 3 × node count, which the engine checked fits PetscInt.
    let indices: Vec<i32> = (0..dofs as i32).collect();
    let values = x.entries(&indices)?;
    let mut full = vec![0.0; dofs];
    for (new, value) in values.into_iter().enumerate() {
        full[3 * partition.old_of_new(new / 3) + new % 3] = value;
    }
    Ok(full)
}

/// The tets this rank assembled and their nodes: what its `.vtu` piece shows.
#[derive(Debug, Clone)]
pub struct Piece {
    tets: Vec<usize>,
    nodes: Vec<usize>,
}

impl Piece {
    /// The piece of rank `rank`.
    pub fn new(mesh: &TetMesh, partition: &Partition, rank: usize) -> Self {
        let tets: Vec<usize> = partition.tets_of(rank).collect();
        let mut nodes: Vec<usize> = tets.iter().flat_map(|&t| mesh.tets()[t]).collect();
        nodes.sort_unstable();
        nodes.dedup();
        Piece { tets, nodes }
    }

    /// Writes `arrays` (the whole mesh's frame) restricted to this piece as `files`' piece of
    /// this rank; rank 0 also writes the `.pvtu` declaring them. Then every rank learns whether
    /// all wrote (collective), so a failed write stops every rank alike.
    pub fn write(
        &self,
        petsc: &Petsc,
        mesh: &TetMesh,
        arrays: &FrameArrays,
        files: &PvtuFiles,
    ) -> Result<()> {
        let written = arrays
            .restrict(&self.nodes, &self.tets)
            .map_err(Error::from)
            .and_then(|piece| {
                files.write_piece(petsc.rank(), mesh, &self.tets, &self.nodes, &piece)?;
                match petsc.rank() {
                    0 => files.write_pvtu(petsc.size(), &piece).map(|_| ()),
                    _ => Ok(()),
                }
            });
        petsc.agree(written)
    }
}

/// The support reactions r = K·w − f on the constrained DOFs (zero elsewhere), w = u for a
/// static solution and u + β·v in a dynamic run (Rayleigh's C·v on the supports, where v = a =
/// 0 and the lumped mass is diagonal): the rows of the unconstrained K, which the engine's
/// matrix no longer holds, summed from this rank's tets that touch a constrained node.
#[derive(Debug, Clone)]
pub struct Supports {
    /// This rank's tets with a constrained node.
    tets: Vec<usize>,
    /// Their nodes, ascending, and the PETSc DOFs of those (3 per node).
    nodes: Vec<usize>,
    indices: Vec<i32>,
    /// Every constrained DOF (mesh numbering), ascending.
    constrained: Vec<usize>,
}

impl Supports {
    /// The supports of `built` as rank `rank` of `partition` sees them.
    pub fn new(built: &BuiltScene, partition: &Partition, rank: usize) -> Self {
        let mesh = &built.mesh;
        let constrained: Vec<usize> = (0..3 * mesh.node_count())
            .filter(|&d| built.constraints.get(d).is_some())
            .collect();
        let held = |node: usize| (0..3).any(|a| built.constraints.get(3 * node + a).is_some());
        let tets: Vec<usize> = partition
            .tets_of(rank)
            .filter(|&t| mesh.tets()[t].iter().any(|&n| held(n)))
            .collect();
        let mut nodes: Vec<usize> = tets.iter().flat_map(|&t| mesh.tets()[t]).collect();
        nodes.sort_unstable();
        nodes.dedup();
        // Below 3 × node count, which the engine checked fits PetscInt.
        let indices = nodes
            .iter()
            .flat_map(|&n| (0..3).map(move |a| partition.global_dof(n, a) as i32))
            .collect();
        Supports {
            tets,
            nodes,
            indices,
            constrained,
        }
    }

    /// The reactions (N, every DOF in the mesh's numbering) of the distributed `w`, with the
    /// loads `built.loads` taken off. Collective.
    pub fn reactions(&self, petsc: &Petsc, built: &BuiltScene, w: &Vector<'_>) -> Result<Vec<f64>> {
        let values = w.entries(&self.indices)?;
        let mesh = &built.mesh;
        let mut sums = vec![0.0; self.constrained.len()];
        let mut w_e = [0.0; 12];
        for &t in &self.tets {
            let tet = mesh.tets()[t];
            for (a, &node) in tet.iter().enumerate() {
                let i = self.nodes.binary_search(&node).map_err(|_| {
                    Error::invalid(
                        format!("node of tet {t}"),
                        node,
                        "must be in its support set",
                    )
                })?;
                w_e[3 * a..3 * a + 3].copy_from_slice(&values[3 * i..3 * i + 3]);
            }
            let ke = mesh.element(t)?.stiffness(built.materials.material_of(t));
            for (a, &node) in tet.iter().enumerate() {
                for axis in 0..3 {
                    if let Ok(k) = self.constrained.binary_search(&(3 * node + axis)) {
                        let row = 3 * a + axis;
                        sums[k] += (0..12).map(|j| ke[(row, j)] * w_e[j]).sum::<f64>();
                    }
                }
            }
        }
        petsc.sum(&mut sums)?;
        let forces = built.loads.as_slice();
        let mut nodal = vec![0.0; forces.len()];
        for (&dof, sum) in self.constrained.iter().zip(sums) {
            nodal[dof] = sum - forces[dof];
        }
        Ok(nodal)
    }
}

/// The recording of a dynamic run, with the in-process run's layout: a CSV row per step (rank
/// 0; the columns of [`tetfem_scene::dynamic_csv_columns`]) and a `.vtu` frame (each rank
/// its piece of the in-process frame's arrays) every `every` steps and at the last; and what
/// the summary reports: the probes' ranges, the first and last energies, the last reactions.
#[derive(Debug)]
pub struct Recorder<'a> {
    built: &'a BuiltScene,
    partition: &'a Partition,
    supports: Supports,
    piece: Option<Piece>,
    directory: PathBuf,
    stem: String,
    every: usize,
    digits: usize,
    frames: Vec<(f64, PathBuf)>,
    csv: Option<CsvSeries>,
    format: VtuFormat,
    /// ½·d·Σ u_c² over this rank's constrained DOFs: what the zeroed rows add to ½·uᵀK·u.
    constrained_energy: f64,
    /// Gravity's and the other loads' nodal forces (N) on this rank's owned rows, 0 on the
    /// constrained ones (the potentials are over the free DOFs, as tetfem's).
    gravity: Vec<f64>,
    other: Vec<f64>,
    /// Rayleigh's stiffness factor β (s): the supports carry K·(u + β·v).
    beta: f64,
    /// The PETSc DOFs of the point probes' tets' nodes, those DOFs in the mesh's numbering,
    /// and a full-length displacement holding only them (for the points' stress).
    point_indices: Vec<i32>,
    point_dofs: Vec<usize>,
    scratch: Vec<f64>,
    /// What the summary reports.
    pub report: Recorded,
}

/// What a [`Recorder`] keeps for the summary.
#[derive(Debug, Clone, Default)]
pub struct Recorded {
    /// Each probe's last value and range over the run (m).
    pub probes: Vec<ProbeRange>,
    /// The energies (J) at time 0 and at the last step recorded.
    pub initial_energy: EnergyTerms,
    /// The energies (J) at the last step recorded.
    pub final_energy: EnergyTerms,
    /// The support reactions per `[[constraints]]` entry at the last step recorded.
    pub reactions: Vec<ReactionRow>,
    /// `.vtu` frames written.
    pub frames: usize,
    /// Wall time of the first step (s).
    pub first_step_seconds: f64,
    /// Wall time of all steps (s).
    pub step_seconds: f64,
}

/// The state a [`Recorder::record`] records: after `step` steps, at `time` (s), the step's
/// wall time `wall` (s), displacement `u` and velocity `v`.
pub struct StepState<'s, 'p> {
    /// Steps taken (0: the initial state).
    pub step: usize,
    /// Time (s).
    pub time: f64,
    /// Wall time of the step (s; 0 for the initial state).
    pub wall: f64,
    /// Displacement (m).
    pub u: &'s Vector<'p>,
    /// Velocity (m/s).
    pub v: &'s Vector<'p>,
    /// The last state of the run.
    pub last: bool,
}

impl<'a> Recorder<'a> {
    /// A recorder of the scene `built` writing into `directory` with `stem` (`.vtu` frames
    /// when `vtu`, the CSV `<stem>_petsc.csv` when `csv`; rank 0 creates it now), its pieces
    /// encoded as `format`, a frame every `every` of `steps` steps. `constrained_energy`:
    /// ½·d·Σ u_c² of this rank's constrained rows; `beta`: Rayleigh's stiffness factor (s).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        petsc: &Petsc,
        built: &'a BuiltScene,
        partition: &'a Partition,
        directory: PathBuf,
        stem: String,
        vtu: bool,
        csv: bool,
        format: VtuFormat,
        every: usize,
        steps: usize,
        constrained_energy: f64,
        beta: f64,
    ) -> Result<Self> {
        let mesh = &built.mesh;
        let rank = petsc.rank();
        // Created on rank 0, then agreed on: a rank 0 that cannot create it stops every rank.
        let create = || -> Result<Option<CsvSeries>> {
            if !(csv && rank == 0) {
                return Ok(None);
            }
            let columns =
                dynamic_csv_columns(&built.probes, reaction_columns(built.constraint_dofs.len()));
            let path = directory.join(format!("{stem}_petsc.csv"));
            Ok(Some(CsvSeries::new(path, columns)?))
        };
        let csv = petsc.agree(create())?;
        let (all, other) = (built.loads.as_slice(), built.other_loads.as_slice());
        let owned_rows = |values: &dyn Fn(usize) -> f64| -> Vec<f64> {
            partition
                .owned_dofs(rank)
                .map(|d| 3 * partition.old_of_new(d / 3) + d % 3)
                .map(|dof| match built.constraints.get(dof) {
                    Some(_) => 0.0,
                    None => values(dof),
                })
                .collect()
        };
        let gravity = owned_rows(&|dof| all[dof] - other[dof]);
        let other = owned_rows(&|dof| other[dof]);
        let mut point_dofs: Vec<usize> = built
            .probes
            .iter()
            .filter(|p| p.point.is_some())
            .flat_map(|p| p.nodes.iter().flat_map(|&n| (0..3).map(move |a| 3 * n + a)))
            .collect();
        point_dofs.sort_unstable();
        point_dofs.dedup();
        let point_indices = point_dofs
            .iter()
            .map(|&d| partition.global_dof(d / 3, d % 3) as i32)
            .collect();
        let probes = built
            .probes
            .iter()
            .map(|p| ProbeRange {
                name: p.name.clone(),
                last: [0.0; 3],
                min: [f64::INFINITY; 3],
                max: [f64::NEG_INFINITY; 3],
            })
            .collect();
        Ok(Recorder {
            built,
            partition,
            supports: Supports::new(built, partition, rank),
            piece: vtu.then(|| Piece::new(mesh, partition, rank)),
            directory,
            stem,
            every: every.max(1),
            digits: steps.to_string().len().max(4),
            frames: Vec::new(),
            csv,
            format,
            constrained_energy,
            gravity,
            other,
            beta,
            point_indices,
            point_dofs,
            scratch: vec![0.0; 3 * mesh.node_count()],
            report: Recorded {
                probes,
                ..Recorded::default()
            },
        })
    }

    /// Records `state`: the CSV row, and a frame when its step is a multiple of `every` or it
    /// is the last. `stiffness` is the engine's K (constrained rows and columns zeroed), `mass`
    /// the lumped mass, `work` scratch. Collective.
    pub fn record<'p>(
        &mut self,
        petsc: &'p Petsc,
        state: StepState<'_, 'p>,
        stiffness: &Matrix<'p>,
        mass: &Vector<'p>,
        work: &mut Vector<'p>,
    ) -> Result<()> {
        let StepState {
            step,
            time,
            wall,
            u,
            v,
            last,
        } = state;
        if step == 1 {
            self.report.first_step_seconds = wall;
        }
        self.report.step_seconds += wall;
        let local = u.local_values()?;
        let means = probe_means(petsc, self.partition, &self.built.probes, &local)?;
        for (range, mean) in self.report.probes.iter_mut().zip(&means) {
            range.last = *mean;
            for a in 0..3 {
                range.min[a] = range.min[a].min(mean[a]);
                range.max[a] = range.max[a].max(mean[a]);
            }
        }
        let energy = self.energy(petsc, &local, u, v, stiffness, mass, work)?;
        if step == 0 {
            self.report.initial_energy = energy;
        }
        self.report.final_energy = energy;
        work.waxpy(self.beta, v, u)?;
        let nodal = self.supports.reactions(petsc, self.built, work)?;
        self.report.reactions = reaction_rows(self.built, &nodal)?;
        let stresses = self.point_stresses(u)?;
        let written = match &mut self.csv {
            Some(csv) => {
                let mut row: Vec<CsvValue> = vec![
                    CsvValue::Real(time),
                    CsvValue::from(step),
                    CsvValue::Real(wall),
                ];
                let mut stress = stresses.iter();
                for (probe, mean) in self.built.probes.iter().zip(&means) {
                    row.extend(mean.map(CsvValue::Real));
                    if probe.point.is_some() {
                        row.extend(
                            stress
                                .next()
                                .into_iter()
                                .flatten()
                                .map(|&s| CsvValue::Real(s)),
                        );
                    }
                }
                row.extend(
                    [
                        energy.kinetic,
                        energy.elastic,
                        energy.gravity_potential,
                        energy.load_potential,
                        energy.total,
                    ]
                    .map(CsvValue::Real),
                );
                row.extend(
                    self.report
                        .reactions
                        .iter()
                        .flat_map(|r| r.force_n.into_iter().chain(r.moment_nm))
                        .map(CsvValue::Real),
                );
                csv.push_values(&row).map_err(Error::from)
            }
            None => Ok(()),
        };
        petsc.agree(written)?;
        if !(step.is_multiple_of(self.every) || last) {
            return Ok(());
        }
        // Whole rows only: CsvSeries writes its buffer at row boundaries.
        let flushed = match &mut self.csv {
            Some(csv) => csv.write().map_err(Error::from),
            None => Ok(()),
        };
        petsc.agree(flushed)?;
        self.frame(petsc, step, time, u, v, &nodal)
    }

    /// The energies (J) of the state `u` (this rank's entries `local`), `v`: kinetic ½·vᵀM·v,
    /// elastic ½·u_fᵀK_ff·u_f (the zeroed rows' part taken off), and the potentials −f·u_f of
    /// gravity and of the other loads, reduced over the ranks. Collective.
    #[allow(clippy::too_many_arguments)]
    fn energy<'p>(
        &self,
        petsc: &'p Petsc,
        local: &[f64],
        u: &Vector<'p>,
        v: &Vector<'p>,
        stiffness: &Matrix<'p>,
        mass: &Vector<'p>,
        work: &mut Vector<'p>,
    ) -> Result<EnergyTerms> {
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        stiffness.mult(u, work)?;
        let kinetic: f64 = v
            .local_values()?
            .iter()
            .zip(mass.local_values()?)
            .map(|(v, m)| m * v * v)
            .sum();
        let mut energies = [
            0.5 * kinetic,
            0.5 * dot(local, &work.local_values()?) - self.constrained_energy,
            -dot(&self.gravity, local),
            -dot(&self.other, local),
        ];
        petsc.sum(&mut energies)?;
        let [kinetic, elastic, gravity_potential, load_potential] = energies;
        Ok(EnergyTerms {
            kinetic,
            elastic,
            gravity_potential,
            load_potential,
            total: kinetic + elastic + gravity_potential + load_potential,
        })
    }

    /// Each point probe's Cauchy stress (Pa; XX, YY, ZZ, XY, YZ, XZ) at its point, from the
    /// displacement of its tet's nodes (fetched from their ranks). Collective.
    fn point_stresses(&mut self, u: &Vector<'_>) -> Result<Vec<[f64; 6]>> {
        let values = u.entries(&self.point_indices)?;
        for (&dof, value) in self.point_dofs.iter().zip(values) {
            self.scratch[dof] = value;
        }
        let built = self.built;
        built
            .probes
            .iter()
            .filter_map(|p| p.point.as_ref())
            .map(|point| {
                let s = point
                    .location
                    .stress(&built.mesh, &built.materials, &self.scratch)?;
                Ok(symmetric_components(&s))
            })
            .collect()
    }

    /// Writes the frame of `step` (each rank its piece of the in-process frame's arrays:
    /// velocity, the nodal `reactions` (N), the time, stresses, error indicators…) and rank 0
    /// the `.pvd`. Collective.
    fn frame(
        &mut self,
        petsc: &Petsc,
        step: usize,
        time: f64,
        u: &Vector<'_>,
        v: &Vector<'_>,
        reactions: &[f64],
    ) -> Result<()> {
        let Some(piece) = &self.piece else {
            return Ok(());
        };
        let built = self.built;
        let dofs = 3 * built.mesh.node_count();
        let u = full_values(u, self.partition, dofs)?;
        let velocity = full_values(v, self.partition, dofs)?;
        let extras = FrameExtras {
            velocity: Some(&velocity),
            reactions: Some(reactions),
            time: Some(time),
            format: self.format,
            original_ids: built.imported.as_ref().map(OriginalIds::of),
            ..FrameExtras::default()
        };
        let arrays = petsc.agree(
            dynamic_frame_arrays(
                &built.mesh,
                &built.materials,
                // The engine runs the linear model only (its set-up refuses the others).
                &InternalForce::default(),
                &u,
                extras,
            )
            .map_err(Error::from),
        )?;
        let files = PvtuFiles::frame(&self.directory, &self.stem, step, self.digits)
            .with_format(self.format);
        piece.write(petsc, &built.mesh, &arrays, &files)?;
        self.frames.push((time, files.pvtu()));
        self.report.frames = self.frames.len();
        let listed = match petsc.rank() {
            0 => files.write_pvd(&self.frames).map(|_| ()),
            _ => Ok(()),
        };
        petsc.agree(listed)
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
