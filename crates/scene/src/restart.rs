//! Restart of dynamic scenes: `[output] checkpoint_every = N` writes
//! `<output dir>/<stem>_checkpoint.bin` every N steps (and at an interrupt), replacing the
//! previous one atomically; `tetfem run SCENE --resume` continues from it with the same bits as
//! one uninterrupted run.
//!
//! A checkpoint carries a fingerprint of what determines the trajectory: the scene, read as
//! TOML and written canonically (key order, comments and number spelling do not matter) without
//! the keys a resume may change — `analysis.duration` (the run's end: a resume may go further)
//! and `output.checkpoint_every` — and the mesh actually built (node coordinates and cells, bit
//! for bit, whatever file they came from). A resume refuses a checkpoint whose fingerprint
//! differs, naming the first scene key that differs and its line, or the mesh.
//!
//! On resume the CSV keeps its rows up to the checkpoint's step and the `.pvd` its frames up to
//! it (rows and frames the interrupted run wrote after the checkpoint are dropped, those
//! frames' `.vtu` files removed), and the run appends from there.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use tetfem::analysis::dynamics::{
    BARRIER_RECORD, Checkpoint, IMPACT_STIFFNESS_RECORD, Integrator, InternalForce, State,
    fingerprint_hash,
};
use tetfem::base::error::{Error, Result};
use tetfem::mesh::{CellType, TetMesh};

use super::{OutputSettings, Scene};

/// The scene keys a resume may change (every other key must be as the checkpoint saw it).
pub const RESUMABLE_KEYS: [&str; 2] = ["analysis.duration", "output.checkpoint_every"];

/// The checkpoint file of a run's outputs: `<directory>/<stem>_checkpoint.bin`.
pub fn checkpoint_path(settings: &OutputSettings) -> PathBuf {
    settings
        .directory
        .join(format!("{}_checkpoint.bin", settings.stem))
}

/// Where a run's checkpoints go and what they are stamped with; with the checkpoint to
/// continue from on a resume.
#[derive(Debug)]
pub(crate) struct Restart {
    path: PathBuf,
    every: usize,
    fingerprint: Vec<(String, String)>,
    /// The checkpoint a resume continues from (`None`: a fresh run).
    pub(crate) resume: Option<Checkpoint>,
}

impl Restart {
    /// The restart of a run of `scene` on `mesh`: for a fresh run (`resume` `None`) a
    /// checkpoint left in the folder by an earlier run is removed (it would describe other
    /// outputs); on a resume the checkpoint's mesh must be this one.
    pub(crate) fn new<C: CellType>(
        scene: &Scene,
        mesh: &TetMesh<C>,
        resume: Option<Checkpoint>,
    ) -> Result<Self> {
        let path = checkpoint_path(scene.output());
        let mut fingerprint = scene_fingerprint(scene)?;
        let mesh_now = mesh_hash(mesh);
        fingerprint.push(("mesh_hash".into(), mesh_now.clone()));
        if let Some(checkpoint) = &resume {
            let found = checkpoint.fingerprint_entry("mesh_hash").unwrap_or("none");
            if found != mesh_now {
                return Err(Error::Scene {
                    source_name: scene.source_name().to_string(),
                    key: "mesh".into(),
                    line: key_line(scene.text(), "mesh").unwrap_or(0),
                    message: format!(
                        "the mesh differs from the one checkpoint {} was taken on (mesh hash {} there, {} now): the mesh file or its settings changed; run again without --resume",
                        path.display(),
                        found,
                        mesh_now
                    ),
                });
            }
        } else if path.exists() {
            std::fs::remove_file(&path).map_err(|source| Error::Io {
                path: path.clone(),
                source,
            })?;
        }
        Ok(Restart {
            path,
            every: scene.output().checkpoint_every,
            fingerprint,
            resume,
        })
    }

    /// Cross-checks the resume's checkpoint against the run's start (`start_time` s after
    /// `start_steps` steps) and the CSV `csv` it continues (if any): its step count, time and
    /// dt must agree ([`Checkpoint::check_clock`]), and the CSV row of its step must hold that
    /// step and its time, t₀ + (steps − steps₀)·dt as the run writes it. A checkpoint whose
    /// step count was shifted would otherwise resume a trajectory shifted in time. Errors name
    /// the file, the field, its value and what was expected. Nothing to check on a fresh run;
    /// a CSV without the row is left to [`CsvSeries::reopen`](tetfem::post::output::CsvSeries::reopen)
    /// to refuse.
    pub(crate) fn check_clock(
        &self,
        start_time: f64,
        start_steps: usize,
        csv: Option<&Path>,
    ) -> Result<()> {
        let Some(checkpoint) = &self.resume else {
            return Ok(());
        };
        checkpoint
            .check_clock(start_time, start_steps)
            .map_err(|e| Error::Parse {
                path: self.path.clone(),
                line: 1,
                message: e.to_string(),
            })?;
        let Some(csv) = csv.filter(|p| p.exists()) else {
            return Ok(());
        };
        let steps = checkpoint.state.steps;
        let time = start_time + (steps - start_steps) as f64 * checkpoint.dt;
        // A FIFO or a link to /dev/zero in the CSV's place would block or read without end.
        let text = tetfem::base::input_file::read_regular_text(csv, "a CSV time series")?;
        // Line 1 is the header, the row of step k (counted from the start) line k + 2.
        let Some(row) = text.lines().nth(steps - start_steps + 1) else {
            return Ok(());
        };
        let mut fields = row.split(',');
        let (found_time, found_step) = (fields.next(), fields.next());
        let parsed_time = found_time.and_then(|t| t.parse::<f64>().ok());
        let parsed_step = found_step.and_then(|s| s.parse::<usize>().ok());
        if parsed_time != Some(time) || parsed_step != Some(steps) {
            return Err(Error::Parse {
                path: csv.to_path_buf(),
                line: steps - start_steps + 2,
                message: format!(
                    "time_s = {}, step = {}: checkpoint {} is at step {steps}, t = {time:e} s, so this row must hold them; the CSV belongs to another run (run again without --resume)",
                    found_time.unwrap_or("(missing)"),
                    found_step.unwrap_or("(missing)"),
                    self.path.display()
                ),
            });
        }
        Ok(())
    }

    /// The step of the checkpoint a resume continues from.
    pub(crate) fn resumed_at(&self) -> Option<usize> {
        self.resume.as_ref().map(|c| c.state.steps)
    }

    /// The checkpoint file, when checkpoints are written and one is there.
    pub(crate) fn written(&self) -> Option<PathBuf> {
        (self.enabled() && self.path.exists()).then(|| self.path.clone())
    }

    /// Whether a checkpoint is due after `step` steps.
    pub(crate) fn due(&self, step: usize) -> bool {
        self.every > 0 && step.is_multiple_of(self.every)
    }

    /// Whether checkpoints are written at all (`checkpoint_every` > 0).
    pub(crate) fn enabled(&self) -> bool {
        self.every > 0
    }

    /// Writes the checkpoint of `integrator` at `state`, with the probes' running extremes and
    /// the contact forces' peaks (record `contact_peak`: |F| (N) and its time (s) per
    /// obstacle) and, with contact, the barrier's record (record `contact_barrier`, see
    /// [`Checkpoint::barrier_record`]) and, with an impact fraction, each contact node's
    /// barrier stiffness (record `contact_impact_stiffness`), over the previous one
    /// (atomically). The caller has written out the CSV rows
    /// up to `state`.
    pub(crate) fn write(
        &self,
        integrator: &dyn Integrator,
        state: &State,
        probes: &[ProbeRange],
        (contact, barrier, stiffnesses): (
            &[super::ContactForceHistory],
            Option<tetfem::analysis::dynamics::BarrierRecord>,
            Option<Vec<f64>>,
        ),
    ) -> Result<()> {
        let mut records = vec![
            (
                "probe_min".into(),
                probes.iter().flat_map(|p| p.min).collect(),
            ),
            (
                "probe_max".into(),
                probes.iter().flat_map(|p| p.max).collect(),
            ),
        ];
        if !contact.is_empty() {
            records.push((
                "contact_peak".into(),
                contact
                    .iter()
                    .flat_map(|c| [c.peak_n, c.peak_time_s])
                    .collect(),
            ));
        }
        if let Some(b) = barrier {
            records.push((BARRIER_RECORD.into(), b.to_values()));
        }
        if let Some(k) = stiffnesses {
            records.push((IMPACT_STIFFNESS_RECORD.into(), k));
        }
        Checkpoint::take(integrator, state, self.fingerprint.clone(), records)?.write(&self.path)
    }

    /// Restores the resume's integrator history, the barrier's record into `force` (none in a
    /// checkpoint written before it existed: the resumed run then measures from the resume),
    /// the probes' running extremes and the contact forces' peaks (a checkpoint without the `contact_peak` record, written before it
    /// existed, leaves them at zero: the peaks are then those since the resume); returns the
    /// state to continue from (`None` for a fresh run).
    pub(crate) fn restore(
        &self,
        (integrator, force): (&mut dyn Integrator, &InternalForce),
        probes: &mut [ProbeRange],
        contact: &mut [super::ContactForceHistory],
    ) -> Result<Option<State>> {
        let Some(checkpoint) = &self.resume else {
            return Ok(None);
        };
        let state = checkpoint.restore(integrator)?;
        if let (InternalForce::Nonlinear(f), Some(record)) =
            (force, checkpoint.barrier_record(&self.path)?)
        {
            f.set_barrier_record(Some(record));
        }
        // Each node's barrier stiffness, after the record (which sets them all to its one).
        if let (InternalForce::Nonlinear(f), Some(values)) =
            (force, checkpoint.record(IMPACT_STIFFNESS_RECORD))
        {
            f.set_node_stiffnesses(values)
                .map_err(|error| Error::Parse {
                    path: self.path.clone(),
                    line: 1,
                    message: format!("the {IMPACT_STIFFNESS_RECORD} record: {error}"),
                })?;
        }
        let bad = || Error::Parse {
            path: self.path.clone(),
            line: 1,
            message: format!(
                "the probe records do not hold 3 values for each of the {} probes",
                probes.len()
            ),
        };
        let min = checkpoint.record("probe_min").ok_or_else(bad)?;
        let max = checkpoint.record("probe_max").ok_or_else(bad)?;
        if min.len() != 3 * probes.len() || max.len() != 3 * probes.len() {
            return Err(bad());
        }
        for (i, p) in probes.iter_mut().enumerate() {
            p.min.copy_from_slice(&min[3 * i..3 * i + 3]);
            p.max.copy_from_slice(&max[3 * i..3 * i + 3]);
        }
        if let Some(peaks) = checkpoint.record("contact_peak") {
            if peaks.len() != 2 * contact.len() {
                return Err(Error::Parse {
                    path: self.path.clone(),
                    line: 1,
                    message: format!(
                        "the contact_peak record holds {} values, not 2 for each of the {} obstacles",
                        peaks.len(),
                        contact.len()
                    ),
                });
            }
            for (c, p) in contact.iter_mut().zip(peaks.chunks_exact(2)) {
                (c.peak_n, c.peak_time_s) = (p[0], p[1]);
            }
        }
        Ok(Some(state))
    }
}

/// Reads the checkpoint a resume of `scene` continues from and checks its scene fingerprint,
/// before any expensive work. Errors: no checkpoint (naming the path looked for), an unreadable
/// or damaged one, one taken on a scene that differs (naming the first differing key and its
/// line in the scene).
pub(crate) fn checkpoint_for_resume(scene: &Scene) -> Result<Checkpoint> {
    let path = checkpoint_path(scene.output());
    if !path.exists() {
        return Err(Error::Scene {
            source_name: scene.source_name().to_string(),
            key: "output.checkpoint_every".into(),
            line: key_line(scene.text(), "output.checkpoint_every").unwrap_or(0),
            message: format!(
                "--resume: no checkpoint at {} (a run with output.checkpoint_every > 0 writes one there)",
                path.display()
            ),
        });
    }
    let checkpoint = Checkpoint::read(&path)?;
    let now = scene_fingerprint(scene)?;
    if checkpoint.fingerprint_entry("scene_hash") != Some(now[0].1.as_str()) {
        let before = checkpoint.fingerprint_entry("scene").unwrap_or("");
        let (key, message) = match first_difference(before, &now[1].1) {
            Some((key, was, is)) => (
                key.clone(),
                format!(
                    "the scene differs from the one checkpoint {} was taken with: {key} is {is} now, was {was}; only {} may change on a resume (or run again without --resume)",
                    path.display(),
                    RESUMABLE_KEYS.join(" and ")
                ),
            ),
            None => (
                "(scene)".to_string(),
                format!(
                    "the scene's fingerprint differs from checkpoint {}'s; run again without --resume",
                    path.display()
                ),
            ),
        };
        return Err(Error::Scene {
            source_name: scene.source_name().to_string(),
            line: key_line(scene.text(), &key).unwrap_or(0),
            key,
            message,
        });
    }
    Ok(checkpoint)
}

/// Refuses a resume from step `at` of a run of `steps` steps in all: nothing is left to run.
/// The error names the run's length: `--steps`/`--duration` when `overridden`, else
/// `analysis.duration` and its line.
pub(crate) fn check_remaining(
    scene: &Scene,
    at: usize,
    steps: usize,
    overridden: bool,
) -> Result<()> {
    if at < steps {
        return Ok(());
    }
    let message = format!(
        "the checkpoint is at step {at}, and the run ends at step {steps}: nothing left to resume; ask for a longer run"
    );
    Err(match overridden {
        true => Error::invalid_parameter("--steps or --duration", steps, message),
        false => Error::Scene {
            source_name: scene.source_name().to_string(),
            key: "analysis.duration".into(),
            line: key_line(scene.text(), "analysis.duration").unwrap_or(0),
            message,
        },
    })
}

/// `[("scene_hash", hex), ("scene", canonical text)]` of `scene`: its keys but the resumable
/// ones, one `path = value` line each in key order, values as TOML writes them.
fn scene_fingerprint(scene: &Scene) -> Result<Vec<(String, String)>> {
    let table: toml::Table = toml::from_str(scene.text()).map_err(|e| Error::Scene {
        source_name: scene.source_name().to_string(),
        key: "(scene)".into(),
        line: 0,
        message: e.message().to_string(),
    })?;
    let mut leaves = BTreeMap::new();
    flatten("", &toml::Value::Table(table), &mut leaves);
    for key in RESUMABLE_KEYS {
        leaves.remove(key);
    }
    let canonical: String = leaves.iter().map(|(k, v)| format!("{k} = {v}\n")).collect();
    Ok(vec![
        (
            "scene_hash".into(),
            format!("{:016x}", fingerprint_hash(canonical.as_bytes())),
        ),
        ("scene".into(), canonical),
    ])
}

/// Every leaf of `value` under `path`: tables by dotted keys, arrays of tables by `[i]`, other
/// arrays and scalars as one value each.
fn flatten(path: &str, value: &toml::Value, out: &mut BTreeMap<String, String>) {
    let join = |key: &str| match path {
        "" => key.to_string(),
        _ => format!("{path}.{key}"),
    };
    match value {
        toml::Value::Table(t) => {
            for (k, v) in t {
                flatten(&join(k), v, out);
            }
        }
        toml::Value::Array(items) if items.iter().any(toml::Value::is_table) => {
            for (i, v) in items.iter().enumerate() {
                flatten(&format!("{path}[{i}]"), v, out);
            }
        }
        other => {
            out.insert(path.to_string(), other.to_string());
        }
    }
}

/// The first key (in key order) whose value differs between two canonical texts, with its value
/// before and now (`absent` where it is missing).
fn first_difference(before: &str, now: &str) -> Option<(String, String, String)> {
    let parse = |text: &str| -> BTreeMap<String, String> {
        text.lines()
            .filter_map(|l| l.split_once(" = "))
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    };
    let (before, now) = (parse(before), parse(now));
    let keys: std::collections::BTreeSet<&String> = before.keys().chain(now.keys()).collect();
    keys.into_iter().find_map(|k| {
        let (was, is) = (before.get(k), now.get(k));
        (was != is).then(|| {
            let show = |v: Option<&String>| v.cloned().unwrap_or_else(|| "absent".into());
            (k.clone(), show(was), show(is))
        })
    })
}

/// The 1-based line of the dotted `key` (`analysis.method`, `loads[1].value`) in the scene
/// `text`, or of its nearest enclosing table that is there.
pub(crate) fn key_line(text: &str, key: &str) -> Option<usize> {
    let table = toml::de::DeTable::parse(text).ok()?;
    let mut span: Option<Range<usize>> = None;
    let mut current: Option<&toml::de::DeValue> = None;
    let root = table.get_ref();
    for part in key.split('.') {
        let (name, index) = match part.split_once('[') {
            Some((name, rest)) => (name, rest.trim_end_matches(']').parse::<usize>().ok()),
            None => (part, None),
        };
        let entry = match current {
            None => root.get(name),
            Some(toml::de::DeValue::Table(t)) => t.get(name),
            _ => None,
        };
        let Some(entry) = entry else { break };
        span = Some(entry.span());
        current = Some(entry.get_ref());
        if let Some(i) = index {
            let Some(toml::de::DeValue::Array(items)) = current else {
                break;
            };
            let Some(item) = items.get(i) else { break };
            span = Some(item.span());
            current = Some(item.get_ref());
        }
    }
    span.map(|s| {
        1 + text.as_bytes()[..s.start.min(text.len())]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
    })
}

/// A hash (hex) of the mesh: node count, cell count, every coordinate's bits and every cell's
/// node indices.
fn mesh_hash<C: CellType>(mesh: &TetMesh<C>) -> String {
    let mut bytes = Vec::with_capacity(24 * mesh.node_count() + 8 * C::NODES * mesh.tet_count());
    bytes.extend_from_slice(&(mesh.node_count() as u64).to_le_bytes());
    bytes.extend_from_slice(&(mesh.tet_count() as u64).to_le_bytes());
    for x in mesh.nodes() {
        for c in x.iter() {
            bytes.extend_from_slice(&c.to_bits().to_le_bytes());
        }
    }
    for cell in mesh.tets() {
        for &n in cell.as_ref() {
            bytes.extend_from_slice(&(n as u64).to_le_bytes());
        }
    }
    format!("{:016x}", fingerprint_hash(&bytes))
}

/// Keeps the `.pvd` frames of `pvd_path` up to the checkpoint time `time` (a frame at exactly
/// that time only when `keep_at_time`: the uninterrupted run writes one there only on its
/// frame interval), removes the `.vtu` files of the frames dropped, rewrites the collection and
/// returns it. The run wrote `expected` frames up to there: a collection that is missing, or
/// lists another number of frames up to there (damaged, or written by hand), or a listed frame
/// file that is missing, is an error naming the file (continuing would silently drop frames).
pub(crate) fn truncate_frames(
    pvd_path: &Path,
    time: f64,
    keep_at_time: bool,
    expected: usize,
) -> Result<tetfem::post::output::PvdCollection> {
    let refuse = |path: &Path, what: String| Error::Parse {
        path: path.to_path_buf(),
        line: 1,
        message: format!(
            "--resume: {what}; the frames of the run before its checkpoint cannot be continued (restore the file, or run again without --resume)"
        ),
    };
    if !pvd_path.exists() {
        return match expected {
            0 => Ok(tetfem::post::output::PvdCollection::new(pvd_path)),
            n => Err(refuse(
                pvd_path,
                format!("the collection is missing; the run wrote {n} frames up to its checkpoint"),
            )),
        };
    }
    let mut pvd = tetfem::post::output::PvdCollection::read(pvd_path)?;
    let dir = pvd_path.parent().unwrap_or(Path::new("")).to_path_buf();
    let dropped = pvd.retain(|t, _| t < time || (t == time && keep_at_time));
    if pvd.frames().len() != expected {
        return Err(refuse(
            pvd_path,
            format!(
                "the collection lists {} frames up to the checkpoint (t = {time:e} s), the run wrote {expected} there: it is damaged",
                pvd.frames().len()
            ),
        ));
    }
    if let Some((_, name)) = pvd.frames().iter().find(|(_, f)| !dir.join(f).is_file()) {
        return Err(refuse(
            &dir.join(name),
            format!("this frame, listed in {}, is missing", pvd_path.display()),
        ));
    }
    for name in dropped {
        let file = dir.join(name);
        if file.exists() {
            std::fs::remove_file(&file).map_err(|source| Error::Io { path: file, source })?;
        }
    }
    pvd.write()?;
    Ok(pvd)
}

/// A probe's mean displacement at the end of the run and its range over the run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ProbeRange {
    /// The probe's name.
    pub name: String,
    /// Mean displacement (length units) at the last step.
    pub last: [f64; 3],
    /// Smallest value of each component over the run (the initial state included).
    pub min: [f64; 3],
    /// Largest value of each component over the run.
    pub max: [f64; 3],
}
