//! Warnings: input that is valid but likely to give a poor or surprising answer.
//!
//! The library never prints; it returns these from [`TetMesh::warnings`](crate::mesh::TetMesh::warnings)
//! (in `quality.rs`, beside the measures it reads), [`Material::warnings`](crate::fe::material::Material::warnings)
//! and the scenes' `BuiltScene::warnings` (constraints and loads), and the scene runner and the
//! command-line tool print them (`warning: …` on standard error) and list them in `--json`.
//! This module is a base every layer may use: it knows only the error module's number format.

use std::fmt;

/// Smallest dihedral angle (degrees) of a tet that is not reported as poor by
/// [`Warning::PoorElements`]: below it stiffness and stresses are unreliable.
pub const POOR_DIHEDRAL_DEG: f64 = 5.0;

/// Poisson's ratio above which [`Warning::NearlyIncompressible`] is raised: λ/μ = 2ν/(1−2ν) = 9
/// at ν = 0.45, and linear tets lock volumetrically as λ/μ grows (too stiff in bending).
pub const NEARLY_INCOMPRESSIBLE_POISSON: f64 = 0.45;

/// One warning about a mesh, a material, the constraints or the loads.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[non_exhaustive]
pub enum Warning {
    /// Nodes that no tet uses. They are kept (their numbering is the caller's), carry no
    /// stiffness and no mass, and are left out of every solve (their displacement is zero).
    UnusedNodes {
        /// How many.
        count: usize,
        /// The first one.
        first: usize,
    },
    /// Some tets, not all, were given with negative orientation and were reoriented; in a mesh
    /// from one generator that usually means the connectivity was edited by hand.
    MixedOrientation {
        /// Tets reoriented.
        reoriented: usize,
        /// Tets in the mesh.
        tets: usize,
    },
    /// Tets with a dihedral angle below [`POOR_DIHEDRAL_DEG`]
    /// (slivers, needles, caps): their stiffness is poorly conditioned, their stresses
    /// unreliable, and the smallest altitude sets the explicit critical step.
    PoorElements {
        /// How many tets are poor.
        count: usize,
        /// The tet with the smallest dihedral angle.
        worst_tet: usize,
        /// Its smallest dihedral angle (degrees).
        worst_dihedral_deg: f64,
        /// Smallest altitude over all tets divided by the median tet's smallest altitude: the
        /// explicit critical step h/c_p is this factor of what the typical tets would allow.
        dt_factor: f64,
    },
    /// ν > [`NEARLY_INCOMPRESSIBLE_POISSON`]: linear tets lock volumetrically (displacements too
    /// small, stresses oscillating), increasingly so as ν → 0.5.
    NearlyIncompressible {
        /// The material's ν.
        poisson_ratio: f64,
        /// The share of the displacement (0–1) 4-node and 10-node displacement tets are
        /// expected to lose to locking at this ν
        /// ([`expected_locking_loss`](crate::fe::locking::expected_locking_loss), measured on
        /// Lamé's tube); the mixed element loses none.
        expected_loss: [f64; 2],
    },
    /// A load whose every non-zero nodal force lies on a constrained DOF: it changes only the
    /// reactions, never the displacement (usually a load put on the clamped face by mistake).
    LoadOnFixedDofs {
        /// Which load (a scene key such as `loads[1]`).
        load: String,
        /// DOFs it loads (all constrained).
        dofs: usize,
    },
    /// Every DOF is constrained: nothing is solved, the displacement is the prescription and
    /// the loads only change the reactions.
    NoFreeDofs {
        /// DOFs of the mesh (all constrained).
        dofs: usize,
    },
    /// A linear-model result rotates its elements so far that the linear model's expected
    /// error (the measured curve of [`adequacy::rotation`](crate::post::adequacy::rotation)) passes
    /// [`LINEAR_MODEL_ERROR_THRESHOLD`](crate::post::adequacy::rotation::LINEAR_MODEL_ERROR_THRESHOLD).
    LinearModelRotation {
        /// The largest element rotation (degrees).
        max_rotation_deg: f64,
        /// The tet where it occurs.
        tet: usize,
        /// The linear model's expected relative error there (dimensionless).
        expected_error: f64,
        /// The model to use (a scene's `model` value).
        suggested_model: &'static str,
    },
    /// An amplitude that is zero over the run's whole time span: the data it scales never act
    /// (a table before or after the run's times, a ramp starting after it, a 0 Hz sine).
    AmplitudeVanishes {
        /// The amplitude's scene key (e.g. `loads[0].amplitude`).
        key: String,
        /// The run's first time (s).
        from: f64,
        /// The run's last time (s).
        to: f64,
    },
    /// A static analysis takes a time-varying amplitude at [`STATIC_TIME`](crate::bc::amplitude::STATIC_TIME):
    /// what a static scene applies may not be what its author meant.
    StaticAmplitude {
        /// The amplitude's scene key.
        key: String,
        /// The time it is sampled at (s).
        time: f64,
        /// a(time) (dimensionless).
        value: f64,
    },
    /// A sine amplitude above the Nyquist frequency 1/(2·dt) of the run's step: the run samples
    /// it fewer than twice per period and sees an aliased, slower load.
    AliasedAmplitude {
        /// The amplitude's scene key.
        key: String,
        /// Its frequency (Hz).
        frequency_hz: f64,
        /// The run's step (s).
        dt: f64,
    },
    /// A combination that runs, but whose integrator loses energy at each impact on an
    /// obstacle (see [`Combination::check`](crate::analysis::Combination::check)).
    ImpactLosesEnergy {
        /// The integrator (a scene's `method` value).
        method: &'static str,
        /// What the impacts are with: "obstacles" or "body–body contact".
        contact: &'static str,
        /// The measured behaviour.
        measured: String,
    },
    /// Backward Euler's step resolves the lowest excited mode so coarsely that its numerical
    /// damping removes more than [`DECAY_WARNING`](crate::post::adequacy::time_step::DECAY_WARNING) of
    /// the amplitude per period.
    BackwardEulerDecay {
        /// The mode's period (time units).
        period: f64,
        /// Steps per period, T/Δt.
        steps_per_period: f64,
        /// Amplitude lost per period (dimensionless).
        decay: f64,
        /// The level it passed (dimensionless).
        limit: f64,
    },
    /// A dynamic run's contact barrier held pushed nodes so far off the obstacles that its
    /// contact forces may be off the exact contact of the mesh by more than 1 % of the run's
    /// largest: its gap error ε = (Σλd/Σλ)/max|u|, each step's weighted by its contact force
    /// over the largest, passed `limit` (the contact module's `GAP_ERROR_WARNING`, from the
    /// force error measured per unit of gap error).
    BarrierGapError {
        /// The run's largest gap error (dimensionless).
        gap_error: f64,
        /// The level it passed (dimensionless).
        limit: f64,
        /// The measured bound on the force error per unit of gap error (dimensionless; the
        /// contact module's `FORCE_ERROR_PER_GAP_ERROR`).
        force_error_per_gap_error: f64,
        /// The barrier's activation distance d̂ (length).
        activation_distance: f64,
    },
    /// The body–body / self-contact barrier's activation distance d̂ exceeds the shortest edge
    /// of the contact surface at rest: a node's barrier then reaches past its neighbours'
    /// triangles, and pairs on one curved face push each other apart where nothing touches.
    SurfaceBarrierReach {
        /// d̂ (length).
        activation_distance: f64,
        /// The shortest surface edge at rest (length).
        shortest_edge: f64,
    },
    /// No tet of a Taylor–Hood P2–P1 mesh has a corner inside the body (every corner on a
    /// boundary face, as in a mesh one tet thick): the element's sufficient stability condition
    /// (every tet with an interior corner, Boffi 1997) does not hold, and the pressure may
    /// oscillate. The stabilized P1–P1 element has no such condition.
    MixedWithoutInteriorCorner {
        /// Tets in the mesh, none with an interior corner.
        tets: usize,
    },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::UnusedNodes { count, first } => write!(
                f,
                "{count} nodes are used by no tet (first: node {first}); they are left out of the solve"
            ),
            Warning::MixedOrientation { reoriented, tets } => write!(
                f,
                "{reoriented} of {tets} tets were negatively oriented and have been reoriented"
            ),
            Warning::PoorElements {
                count,
                worst_tet,
                worst_dihedral_deg,
                dt_factor,
            } => write!(
                f,
                "{count} tets have a dihedral angle under {}° (worst: tet {worst_tet}, {worst_dihedral_deg:.2}°); \
                 their stresses are unreliable, and the smallest altitude makes the explicit critical step \
                 {dt_factor:.2e} of what the median tet would allow",
                POOR_DIHEDRAL_DEG
            ),
            Warning::NearlyIncompressible {
                poisson_ratio,
                expected_loss: [four, ten],
            } => write!(
                f,
                "Poisson's ratio {poisson_ratio} is close to 0.5 (λ/μ = {:.0}): displacement tets lock \
                 volumetrically and come out too stiff (measured on Lamé's tube at this ν, 6 cells \
                 through its wall: 4-node tets lose {:.2} % of the displacement, 10-node tets \
                 {:.2} %); use the mixed displacement–pressure element on 10-node tets \
                 (`formulation = \"mixed\"`, `solve_static_mixed`), which does not lock, or \
                 ν ≤ {NEARLY_INCOMPRESSIBLE_POISSON}",
                2.0 * poisson_ratio / (1.0 - 2.0 * poisson_ratio),
                100.0 * four,
                100.0 * ten
            ),
            Warning::LoadOnFixedDofs { load, dofs } => write!(
                f,
                "{load} acts only on constrained DOFs ({dofs} of them): it changes the reactions, \
                 not the displacement; move it off the constrained nodes"
            ),
            Warning::LinearModelRotation {
                max_rotation_deg,
                tet,
                expected_error,
                suggested_model,
            } => write!(
                f,
                "largest rotation {max_rotation_deg:.1}° (tet {tet}): the linear model's error is ≈ {:.0} % here \
                 (measured on a bent cantilever); use model = \"{suggested_model}\"",
                100.0 * expected_error
            ),
            Warning::BackwardEulerDecay {
                period,
                steps_per_period,
                decay,
                limit,
            } => write!(
                f,
                "dt resolves the lowest excited mode (period {period:.3e}) with {steps_per_period:.0} steps: \
                 backward Euler's numerical damping removes {:.0} % of its amplitude per period; use a \
                 dt below period/190 for at most {:.0} %, or method = \"newmark\" (no numerical damping)",
                100.0 * decay,
                100.0 * limit
            ),
            Warning::ImpactLosesEnergy {
                method,
                contact,
                measured,
            } => write!(f, "method \"{method}\" with {contact}: {measured}"),
            Warning::AmplitudeVanishes { key, from, to } => write!(
                f,
                "{key} is 0 over the whole run (t = {} to {} s): what it scales never acts; \
                 check its times (a table before or after the run, a ramp starting after it, a 0 Hz sine)",
                crate::base::error::short_number(*from),
                crate::base::error::short_number(*to)
            ),
            Warning::StaticAmplitude { key, time, value } => write!(
                f,
                "{key} varies in time, and a static analysis takes it at t = {time} s, where it is {}; \
                 give the factor as a constant if that is not what you meant",
                crate::base::error::short_number(*value)
            ),
            Warning::AliasedAmplitude {
                key,
                frequency_hz,
                dt,
            } => write!(
                f,
                "{key} oscillates at {} Hz, above the Nyquist frequency 1/(2·dt) = {} Hz of dt = {} s: \
                 the run samples it {:.2} times per period and sees an aliased, slower load; use dt ≤ 1/(20·f) = {} s",
                crate::base::error::short_number(*frequency_hz),
                crate::base::error::short_number(0.5 / dt),
                crate::base::error::short_number(*dt),
                1.0 / (frequency_hz * dt),
                crate::base::error::short_number(0.05 / frequency_hz)
            ),
            Warning::BarrierGapError {
                gap_error,
                limit,
                force_error_per_gap_error,
                activation_distance,
            } => write!(
                f,
                "the contact barrier's gap error reached {gap_error:.2e} (its pushed nodes' force-weighted gap \
                 over the largest displacement, each step's weighted by its contact force over the run's \
                 largest), above {limit:.2e}: its contact forces may be off the exact contact by up to {:.1} % \
                 of the largest (at most {} times the gap error, measured); a smaller [contact] \
                 activation_distance than {} lowers it",
                100.0 * gap_error * force_error_per_gap_error,
                force_error_per_gap_error,
                crate::base::error::short_number(*activation_distance)
            ),
            Warning::NoFreeDofs { dofs } => write!(
                f,
                "all {dofs} DOFs are constrained: nothing is solved, the displacement is the \
                 prescribed one and the loads change only the reactions"
            ),
            Warning::SurfaceBarrierReach {
                activation_distance,
                shortest_edge,
            } => write!(
                f,
                "the self-contact barrier's activation distance {} exceeds the contact surface's \
                 shortest edge {}: neighbouring triangles of one face push each other apart where \
                 nothing touches; choose a distance below the shortest edge",
                crate::base::error::short_number(*activation_distance),
                crate::base::error::short_number(*shortest_edge)
            ),
            Warning::MixedWithoutInteriorCorner { tets } => write!(
                f,
                "formulation = \"mixed\": none of the {tets} tets has a corner inside the body (a \
                 mesh one tet thick), so the P2–P1 element's stability condition (every tet with an \
                 interior corner, Boffi 1997) does not hold and the pressure may oscillate; mesh at \
                 least two tets through the thinnest part"
            ),
        }
    }
}
