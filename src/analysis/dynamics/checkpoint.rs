//! Checkpoints of a dynamic run: everything a run needs to continue bit-identically — the
//! [`State`] (u, v, time, step count), what the integrator carries from one step to the next
//! ([`IntegratorHistory`]), the time step — plus a caller-given fingerprint of the problem and
//! caller-given records, in a small self-describing binary file written atomically.
//!
//! The format lives here, next to the types it stores (the state, the divergence guard, Newton's
//! counts), rather than in `output`: those are dynamics' types, and `output` stays free of them.
//!
//! File layout (version 2), all integers u64 and all reals f64, little-endian (reals as their
//! IEEE-754 bits, so every value reads back to the same bits):
//!
//! ```text
//! magic  "TETFEMCP"            8 bytes
//! version                      u32 (2; version 1 files, without the previous
//!                              acceleration, are read too)
//! method                       string (u64 byte length, UTF-8)
//! steps, time, dt              u64, f64, f64
//! displacement, velocity       vector (u64 length, that many f64)
//! guard                        u8 flag; if 1: kinetic, elastic, gravity, load, factor (5 f64)
//! acceleration                 u8 flag; if 1: vector
//! previous acceleration        u8 flag; if 1: vector (version 2 only)
//! newton                       u8 flag; if 1: steps, total, max per step, last (4 u64)
//! fingerprint                  u64 count; each: name string, value string
//! records                      u64 count; each: name string, vector
//! checksum                     u64: FNV-1a 64 of every byte before it
//! ```
//!
//! Every length is checked against the bytes left before anything is allocated, and the
//! checksum catches a damaged file: a bad file is an [`Error::Parse`] naming the byte offset.

use std::path::Path;

use super::{BarrierRecord, DivergenceGuard, Energy, Integrator, NewtonStats, State};
use crate::base::error::{Error, Result};

/// The first 8 bytes of a checkpoint file.
pub const CHECKPOINT_MAGIC: &[u8; 8] = b"TETFEMCP";
/// The name of the caller record that holds a run's [`BarrierRecord`] (see
/// [`Checkpoint::barrier_record`]); a record, so the file's version stays.
pub const BARRIER_RECORD: &str = "contact_barrier";
/// The name of the caller record that holds each contact node's barrier stiffness κᵢ in
/// force (Pa/m, [`NonlinearForce::node_stiffnesses`](super::NonlinearForce::node_stiffnesses))
/// of a run with an impact fraction; absent from other runs' files, which stay as they were.
pub const IMPACT_STIFFNESS_RECORD: &str = "contact_impact_stiffness";
/// The version of the format this code writes and reads.
pub const CHECKPOINT_VERSION: u32 = 2;

/// What an integrator carries from one step to the next beyond the [`State`]: with it and the
/// state, a rebuilt integrator continues with the same bits as the one that took it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct IntegratorHistory {
    /// The integrator's [`name`](Integrator::name) (`backward-euler`, `newmark`, `explicit`);
    /// a restore into another method is refused.
    pub method: String,
    /// The divergence guard, once the first step set it up from that step's energies (every
    /// method; `None` before the first step). Restoring it keeps the run's reference energies:
    /// a new guard built from the checkpoint's state would judge divergence differently.
    pub guard: Option<DivergenceGuard>,
    /// Newmark: the acceleration a (length/time², free DOFs) of the state, from the method's
    /// update a⁺ = 4/dt²·(u⁺ − u) − 4/dt·v − a, which differs from the equation of motion's
    /// M⁻¹(f − K·u − C·v) by round-off (and by more with a nonlinear model). Backward Euler
    /// with a nonlinear model: the last step's (v⁺ − v)/dt, from which the next step's Newton
    /// iterations start (u + dt·v + dt²·(2a − a₋₁)). `None` for the other methods and before
    /// the first step.
    pub acceleration: Option<Vec<f64>>,
    /// Backward Euler with a nonlinear model: the acceleration of the step before
    /// [`acceleration`](Self::acceleration)'s, when known (from its second step on), for the
    /// next iterations' start u + dt·v + dt²·(2a − a₋₁). `None` otherwise, and from a
    /// version 1 checkpoint.
    pub previous_acceleration: Option<Vec<f64>>,
    /// The Newton iteration counts so far of an implicit method with a nonlinear model (`None`
    /// otherwise), so that a resumed run reports the counts of the whole run.
    pub newton: Option<NewtonStats>,
}

/// The [`Error::InvalidParameter`] of an integrator that cannot take or restore checkpoints.
pub(crate) fn unsupported(method: &str) -> Error {
    Error::invalid_parameter(
        "method",
        method,
        "this integrator does not take or restore checkpoints",
    )
}

impl IntegratorHistory {
    /// Checks that this history can be restored into the integrator `method` with `free_dofs`
    /// free DOFs and the state `state`: the same method, state vectors and acceleration of that
    /// length.
    pub fn check(&self, method: &str, free_dofs: usize, state: &State) -> Result<()> {
        if self.method != method {
            return Err(Error::invalid_parameter(
                "method",
                method,
                format!(
                    "the checkpoint was taken by the {} method; resume with that method",
                    self.method
                ),
            ));
        }
        state.check_len(free_dofs)?;
        if let Some(a) = &self.acceleration {
            Error::check_len("checkpoint acceleration", free_dofs, a.len())?;
        }
        if let Some(a) = &self.previous_acceleration {
            Error::check_len("checkpoint previous acceleration", free_dofs, a.len())?;
        }
        Ok(())
    }
}

/// A checkpoint of a dynamic run. The file format (magic `TETFEMCP`, version, fingerprint, then
/// the state) is documented with the source, `src/analysis/dynamics/checkpoint.rs`, and in the
/// book's Restart chapter.
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    /// The state after [`State::steps`] steps, its time the integrator's own running time.
    pub state: State,
    /// The time step the run was taken with (time units).
    pub dt: f64,
    /// What the integrator carries between steps.
    pub history: IntegratorHistory,
    /// The caller's fingerprint of the problem, as named entries (e.g. a hash of the input
    /// files): stored as given and compared by the caller on resume.
    pub fingerprint: Vec<(String, String)>,
    /// The caller's named arrays of numbers carried across the restart (e.g. the running
    /// extremes of a monitored quantity), stored bit for bit.
    pub records: Vec<(String, Vec<f64>)>,
}

impl Checkpoint {
    /// The checkpoint of `integrator` at `state` (after its last step), with the caller's
    /// `fingerprint` and `records`. Errors: the integrator takes no checkpoints.
    pub fn take(
        integrator: &dyn Integrator,
        state: &State,
        fingerprint: Vec<(String, String)>,
        records: Vec<(String, Vec<f64>)>,
    ) -> Result<Self> {
        Ok(Checkpoint {
            state: state.clone(),
            dt: integrator.time_step(),
            history: integrator.history()?,
            fingerprint,
            records,
        })
    }

    /// Restores the history into `integrator` (built as the checkpointed one was: same system,
    /// force, method and options) and returns the state to continue from. Errors: another
    /// method, another time step (naming both), state vectors of another length.
    pub fn restore(&self, integrator: &mut dyn Integrator) -> Result<State> {
        let dt = integrator.time_step();
        if dt.to_bits() != self.dt.to_bits() {
            return Err(Error::invalid_parameter(
                "dt",
                dt,
                format!(
                    "the checkpoint was taken with dt = {:e}; resume with that time step",
                    self.dt
                ),
            ));
        }
        integrator.restore(&self.state, &self.history)?;
        Ok(self.state.clone())
    }

    /// Checks that the checkpoint's step count, time and time step agree for a run that
    /// started at `start_time` after `start_steps` steps: its time must be
    /// t₀ + (steps − steps₀)·dt up to the round-off of the integrators' running sum t += dt,
    /// at most (n + 2)·ε·(|t₀| + n·dt) after n steps (each addition rounds by at most ε/2 of
    /// the running time, which stays below |t₀| + n·dt). A step count shifted by one step is
    /// caught while n²·ε < 1 (n below 6.7e7 steps). Errors: [`Error::InvalidParameter`]
    /// naming the field (`steps` before the start, or `time`), its value and the time expected.
    pub fn check_clock(&self, start_time: f64, start_steps: usize) -> Result<()> {
        let (steps, time, dt) = (self.state.steps, self.state.time, self.dt);
        let Some(n) = steps.checked_sub(start_steps) else {
            return Err(Error::invalid_parameter(
                "checkpoint steps",
                steps,
                format!(
                    "the run starts after {start_steps} steps; a checkpoint cannot be before its start"
                ),
            ));
        };
        let n = n as f64;
        let expected = start_time + n * dt;
        let tolerance = (n + 2.0) * f64::EPSILON * (start_time.abs() + n * dt);
        // Written so that a NaN time (which compares false) is refused too.
        let within = (time - expected).abs() <= tolerance;
        if !within {
            return Err(Error::invalid_parameter(
                "checkpoint time",
                format!("{time:e} s"),
                format!(
                    "step {steps} of dt = {dt:e} s from t = {start_time:e} s is at t = {expected:e} s (± {tolerance:.1e} s of round-off): the checkpoint's step count, time and time step disagree; run again without --resume"
                ),
            ));
        }
        Ok(())
    }

    /// The fingerprint entry `name`, if stored.
    pub fn fingerprint_entry(&self, name: &str) -> Option<&str> {
        self.fingerprint
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    /// The record `name`, if stored.
    pub fn record(&self, name: &str) -> Option<&[f64]> {
        self.records
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    /// The contact barrier's record of the run ([`BarrierRecord`], stored as the record
    /// [`BARRIER_RECORD`] by [`BarrierRecord::to_values`]), so that a resumed run reports the
    /// gap errors and smallest gaps of the whole run. `Ok(None)` when the checkpoint has none
    /// (a run without contact, or a checkpoint written before the record existed: the resumed
    /// run then reports what it measures after the resume); [`Error::Parse`] naming `path` and
    /// the record for another count of values.
    pub fn barrier_record(&self, path: &Path) -> Result<Option<BarrierRecord>> {
        let Some(values) = self.record(BARRIER_RECORD) else {
            return Ok(None);
        };
        BarrierRecord::from_values(values)
            .map(Some)
            .ok_or_else(|| Error::Parse {
                path: path.to_path_buf(),
                line: 1,
                message: format!(
                    "the {BARRIER_RECORD} record holds {} values, not {} or {}",
                    values.len(),
                    BarrierRecord::VALUES,
                    BarrierRecord::VALUES + 1
                ),
            })
    }

    /// Writes the checkpoint to `path` atomically (a temporary file renamed over it once
    /// complete and synced: a signal leaves the previous checkpoint or this one, never half).
    pub fn write(&self, path: &Path) -> Result<()> {
        let bytes = self.to_bytes();
        crate::base::atomic_file::write_atomically(path, |out| out.write_all(&bytes))
    }

    /// Reads a checkpoint file. Errors: [`Error::Io`] naming the path (e.g. no such file), an
    /// [`Error::Parse`] for a path that is not a regular file (a FIFO, a link to `/dev/zero`:
    /// refused before reading, see [`crate::base::input_file::read_regular_file`]),
    /// [`Error::Parse`] for a file that is not a checkpoint of this version, truncated or
    /// damaged (naming the byte offset).
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = crate::base::input_file::read_regular_file(path, "a checkpoint")?;
        Self::from_bytes(&bytes, path)
    }

    /// The file's bytes, in the format of [`Checkpoint`].
    pub fn to_bytes(&self) -> Vec<u8> {
        let s = &self.state;
        let mut out = Vec::with_capacity(64 + 16 * s.displacement.len());
        out.extend_from_slice(CHECKPOINT_MAGIC);
        out.extend_from_slice(&CHECKPOINT_VERSION.to_le_bytes());
        put_str(&mut out, &self.history.method);
        put_u64(&mut out, s.steps as u64);
        put_f64(&mut out, s.time);
        put_f64(&mut out, self.dt);
        put_reals(&mut out, &s.displacement);
        put_reals(&mut out, &s.velocity);
        match &self.history.guard {
            Some(guard) => {
                let (e, factor) = guard.reference();
                out.push(1);
                for v in [
                    e.kinetic,
                    e.elastic,
                    e.gravity_potential,
                    e.load_potential,
                    factor,
                ] {
                    put_f64(&mut out, v);
                }
            }
            None => out.push(0),
        }
        for vector in [
            &self.history.acceleration,
            &self.history.previous_acceleration,
        ] {
            match vector {
                Some(a) => {
                    out.push(1);
                    put_reals(&mut out, a);
                }
                None => out.push(0),
            }
        }
        match &self.history.newton {
            Some(n) => {
                out.push(1);
                for v in [
                    n.steps,
                    n.total_iterations,
                    n.max_per_step,
                    n.last_step,
                    n.factorizations,
                    n.cg_iterations,
                    n.fallbacks,
                ] {
                    put_u64(&mut out, v as u64);
                }
            }
            None => out.push(0),
        }
        put_u64(&mut out, self.fingerprint.len() as u64);
        for (name, value) in &self.fingerprint {
            put_str(&mut out, name);
            put_str(&mut out, value);
        }
        put_u64(&mut out, self.records.len() as u64);
        for (name, values) in &self.records {
            put_str(&mut out, name);
            put_reals(&mut out, values);
        }
        let checksum = fingerprint_hash(&out);
        put_u64(&mut out, checksum);
        out
    }

    /// Parses the bytes of a checkpoint file (`path` is named in errors).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let mut r = Reader { bytes, at: 0, path };
        if r.take(8)? != CHECKPOINT_MAGIC {
            return Err(r.error(
                0,
                "not a tetfem checkpoint (the file does not start with TETFEMCP)",
            ));
        }
        let version = u32::from_le_bytes(r.take(4)?.try_into().unwrap_or_default());
        if !(1..=CHECKPOINT_VERSION).contains(&version) {
            return Err(r.error(
                8,
                format!(
                    "checkpoint version {version}; this build reads versions 1 to {CHECKPOINT_VERSION}"
                ),
            ));
        }
        // The checksum first: a damaged file is reported as such, not as whatever field the
        // damage happens to break.
        if bytes.len() < 20 {
            return Err(r.error(bytes.len(), "truncated: no checksum"));
        }
        let (payload, stored) = bytes.split_at(bytes.len() - 8);
        let stored = u64::from_le_bytes(stored.try_into().unwrap_or_default());
        if fingerprint_hash(payload) != stored {
            return Err(r.error(
                payload.len(),
                "the checksum does not match: the file is damaged or truncated",
            ));
        }
        r.bytes = payload;
        let method = r.string()?;
        let steps = r.count()?;
        let at = r.at;
        let time = r.real()?;
        if !time.is_finite() {
            return Err(r.error(at, format!("time = {time}: must be finite")));
        }
        let at = r.at;
        let dt = r.real()?;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(r.error(at, format!("dt = {dt:e}: must be finite and > 0")));
        }
        let displacement = r.reals()?;
        let velocity = r.reals()?;
        let guard = match r.flag()? {
            true => {
                let at = r.at;
                let e = Energy {
                    kinetic: r.real()?,
                    elastic: r.real()?,
                    gravity_potential: r.real()?,
                    load_potential: r.real()?,
                };
                let factor = r.real()?;
                Some(
                    DivergenceGuard::from_reference(e, factor)
                        .map_err(|e| r.error(at, format!("divergence guard: {e}")))?,
                )
            }
            false => None,
        };
        let acceleration = match r.flag()? {
            true => Some(r.reals()?),
            false => None,
        };
        let previous_acceleration = match version >= 2 && r.flag()? {
            true => Some(r.reals()?),
            false => None,
        };
        let newton = match r.flag()? {
            true => Some(NewtonStats {
                steps: r.count()?,
                total_iterations: r.count()?,
                max_per_step: r.count()?,
                last_step: r.count()?,
                factorizations: r.count()?,
                cg_iterations: r.count()?,
                fallbacks: r.count()?,
            }),
            false => None,
        };
        let entries = r.count()?;
        let mut fingerprint = Vec::new();
        for _ in 0..entries {
            fingerprint.push((r.string()?, r.string()?));
        }
        let entries = r.count()?;
        let mut records = Vec::new();
        for _ in 0..entries {
            records.push((r.string()?, r.reals()?));
        }
        if r.at != payload.len() {
            return Err(r.error(r.at, "unexpected bytes after the records"));
        }
        let state = State {
            displacement,
            velocity,
            time,
            steps,
        };
        if state.displacement.len() != state.velocity.len() {
            return Err(r.error(
                0,
                format!(
                    "{} displacements but {} velocities",
                    state.displacement.len(),
                    state.velocity.len()
                ),
            ));
        }
        Ok(Checkpoint {
            state,
            dt,
            history: IntegratorHistory {
                method,
                guard,
                acceleration,
                previous_acceleration,
                newton,
            },
            fingerprint,
            records,
        })
    }
}

/// FNV-1a 64 of `bytes`: the checksum of a checkpoint file, and a cheap fingerprint of input
/// data (not cryptographic: it detects changes, it does not resist forgery).
pub fn fingerprint_hash(bytes: &[u8]) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        hash ^= u64::from(b);
        hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
    }
    hash
}

fn put_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_f64(out: &mut Vec<u8>, v: f64) {
    out.extend_from_slice(&v.to_bits().to_le_bytes());
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    put_u64(out, s.len() as u64);
    out.extend_from_slice(s.as_bytes());
}

fn put_reals(out: &mut Vec<u8>, values: &[f64]) {
    put_u64(out, values.len() as u64);
    for &v in values {
        put_f64(out, v);
    }
}

/// Reads the fields in order, every length checked against the bytes left.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    path: &'a Path,
}

impl Reader<'_> {
    fn error(&self, at: usize, message: impl std::fmt::Display) -> Error {
        // A binary file's "line": the line count up to the offset (see `Error::Parse`).
        let before = &self.bytes[..at.min(self.bytes.len())];
        Error::Parse {
            path: self.path.to_path_buf(),
            line: 1 + before.iter().filter(|&&b| b == b'\n').count(),
            message: format!("byte {at}: {message}"),
        }
    }

    fn take(&mut self, n: usize) -> Result<&[u8]> {
        if n > self.bytes.len() - self.at {
            return Err(self.error(
                self.at,
                format!(
                    "truncated: {n} bytes needed, {} left",
                    self.bytes.len() - self.at
                ),
            ));
        }
        let slice = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(slice)
    }

    fn u64(&mut self) -> Result<u64> {
        let bytes = self.take(8)?;
        Ok(u64::from_le_bytes(bytes.try_into().unwrap_or_default()))
    }

    fn count(&mut self) -> Result<usize> {
        let at = self.at;
        let v = self.u64()?;
        usize::try_from(v).map_err(|_| self.error(at, format!("count {v} does not fit")))
    }

    fn real(&mut self) -> Result<f64> {
        Ok(f64::from_bits(self.u64()?))
    }

    fn flag(&mut self) -> Result<bool> {
        let at = self.at;
        match self.take(1)?[0] {
            0 => Ok(false),
            1 => Ok(true),
            other => Err(self.error(at, format!("flag {other}: must be 0 or 1"))),
        }
    }

    /// A length, checked to leave `unit`-byte items within the bytes left.
    fn length(&mut self, unit: usize) -> Result<usize> {
        let at = self.at;
        let n = self.count()?;
        let left = self.bytes.len() - self.at;
        if n.checked_mul(unit).is_none_or(|bytes| bytes > left) {
            return Err(self.error(
                at,
                format!("length {n} runs past the end ({left} bytes left)"),
            ));
        }
        Ok(n)
    }

    fn string(&mut self) -> Result<String> {
        let n = self.length(1)?;
        let at = self.at;
        let bytes = self.take(n)?.to_vec();
        String::from_utf8(bytes).map_err(|_| self.error(at, "a name is not UTF-8"))
    }

    fn reals(&mut self) -> Result<Vec<f64>> {
        let n = self.length(8)?;
        (0..n).map(|_| self.real()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The clock check accepts the running sum t += dt of a long run from a nonzero start
    /// (its round-off is inside the bound) and refuses a step count shifted by one step, or a
    /// checkpoint before the start, naming the field, its value and the time expected.
    #[test]
    fn the_clock_check_accepts_round_off_and_refuses_a_shifted_step_count() {
        let (start, dt, n) = (0.3, 1e-3 / 3.0, 200_000);
        let mut time = start;
        for _ in 0..n {
            time += dt;
        }
        let checkpoint = |steps: usize| Checkpoint {
            state: State {
                displacement: vec![],
                velocity: vec![],
                time,
                steps,
            },
            dt,
            history: IntegratorHistory::default(),
            fingerprint: vec![],
            records: vec![],
        };
        // The round-off of 2e5 additions is well above one ulp: the check needs its bound.
        assert_ne!(time, start + n as f64 * dt);
        checkpoint(n + 5).check_clock(start, 5).unwrap();
        for shifted in [n - 1, n + 1] {
            let e = checkpoint(shifted).check_clock(start, 0).unwrap_err();
            let text = e.to_string();
            assert!(text.contains("checkpoint time"), "{text}");
            assert!(text.contains(&format!("step {shifted} of dt")), "{text}");
        }
        let e = checkpoint(3).check_clock(start, 5).unwrap_err();
        assert!(e.to_string().contains("checkpoint steps = 3"), "{e}");
    }

    /// A version 1 file (written before the previous acceleration was kept) still reads, every
    /// field the same and the previous acceleration absent; a version beyond this build's is
    /// refused naming both versions.
    #[test]
    fn version_1_files_read_without_the_previous_acceleration() {
        let checkpoint = Checkpoint {
            state: State {
                displacement: vec![1.0, -2.0],
                velocity: vec![0.5, 0.25],
                time: 0.125,
                steps: 3,
            },
            dt: 1e-3,
            history: IntegratorHistory {
                method: "backward-euler".into(),
                acceleration: Some(vec![3.0, 4.0]),
                ..IntegratorHistory::default()
            },
            fingerprint: vec![("scene".into(), "abc".into())],
            records: vec![],
        };
        let current = checkpoint.to_bytes();
        // The previous acceleration's flag follows the acceleration: magic, version, the
        // method (length and bytes), steps, time, dt, u and v (length and 2 values each), the
        // guard's flag, the acceleration's flag, length and 2 values.
        let at = 8 + 4 + (8 + 14) + 3 * 8 + 2 * (8 + 16) + 1 + (1 + 8 + 16);
        assert_eq!(current[at], 0, "the previous acceleration's absent flag");
        let mut old = current[..current.len() - 8].to_vec();
        old.remove(at);
        old[8..12].copy_from_slice(&1_u32.to_le_bytes());
        old.extend_from_slice(&fingerprint_hash(&old).to_le_bytes());
        let read = Checkpoint::from_bytes(&old, Path::new("v1.bin")).unwrap();
        assert_eq!(read, checkpoint);

        let mut future = current[..current.len() - 8].to_vec();
        future[8..12].copy_from_slice(&(CHECKPOINT_VERSION + 1).to_le_bytes());
        future.extend_from_slice(&fingerprint_hash(&future).to_le_bytes());
        let refused = Checkpoint::from_bytes(&future, Path::new("v3.bin")).unwrap_err();
        assert!(
            refused
                .to_string()
                .contains("version 3; this build reads versions 1 to 2"),
            "{refused}"
        );
    }
}
