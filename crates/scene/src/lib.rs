//! Scenes: a TOML description of a mesh, a material, constraints, loads, an analysis and its
//! outputs, turned into the library's objects by [`Scene::build`] and run by [`run_static`].
//!
//! A scene names only what it needs; everything else takes the default listed in
//! [`REFERENCE`], the one place where defaults are documented (it is itself a valid scene, and a
//! test parses it). Unknown keys, values of the wrong type and invalid values are
//! [`Error::Scene`] errors naming the key and its line.
#![warn(missing_docs)]

mod accuracy;
mod bodies;
mod build;
mod combination;
mod critical;
mod dynamic;
mod dynamic_contact;
mod element;
mod engine;
mod estimate;
mod formulation;
pub mod key_docs;
mod mixed_dynamics;
mod modal;
mod obstacles;
// Without the `png` feature the frames' code is a stand-in that refuses (a scene asking for
// PNGs is refused when read, so it is never reached).
#[cfg_attr(not(feature = "png"), path = "png_frames_off.rs")]
mod png_frames;
mod reactions;
mod region_models;
#[cfg(feature = "png")]
pub mod render;
mod restart;
mod run;
mod spec;
mod statics;
mod units;

pub use accuracy::{
    AccuracyPrediction, AccuracyReport, AccuracyTarget, AccuracyTrial, DEFAULT_COST_EXPONENT,
    DEFAULT_MAX_DOFS, MAX_REFINEMENT_RATIO,
};
pub use bodies::BuiltBodies;
pub use build::{BuiltScene, PointProbe, Probe};
pub use critical::{CriticalStepReport, critical_step_of};
pub use dynamic::{
    DynamicAccuracy, DynamicOutputs, DynamicOverrides, DynamicRun, DynamicSetup, DynamicSummary,
    EnergyTerms, MAX_STEPS, RunLength, TimeStep, TimeStepping, resume_dynamic_scene, run_dynamic,
    run_dynamic_scene,
};
pub use dynamic::{
    STEP_CHECK_DOFS, STEP_CHECK_MODES, csv_columns as dynamic_csv_columns,
    frame_arrays as dynamic_frame_arrays,
};
pub use dynamic_contact::{ContactForceHistory, DynamicContactBarrier};
pub use element::SceneElement;
pub use engine::{EngineKind, EngineSettings, PetscSolver, PetscSpec, parse_petsc_options};
pub use estimate::{
    ESTIMATED_ERROR_DEFINITION, EstimatedError, MODEL_ESTIMATED_ERROR_DEFINITION,
    estimated_error_of, model_estimated_error_of,
};
pub use formulation::Formulation;
pub use modal::{ModalSummary, ModeRow, run_modal_scene};
pub use reactions::{DynamicReactions, ReactionsAt, reaction_columns};
pub use restart::{ProbeRange, RESUMABLE_KEYS, checkpoint_path};
pub use run::{
    ContactForceRow, ProbeValue, ReactionRow, RunOptions, RunSummary, SolvePhases, StaticNewton,
    StaticReport, StaticSolve, reaction_rows, report_static, static_frame_arrays,
    write_static_probe_csv,
};
pub use spec::*;
pub use statics::{run_static, run_static_with};

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use tetfem::analysis::dynamics::StepNewtonOptions;
use tetfem::base::error::{Error, Result, short_number};
use tetfem::mesh::io::MeshFile;

/// Every key a scene may hold, with its default. Paths written in a scene are relative to the
/// scene file's folder; without `output.directory` the outputs go to `out/<scene file stem>` in
/// the working directory. Units SI.
pub const REFERENCE: &str = r#"# tetfem scene reference: every key, with its default where it has one.
title = "reference"                 # default: the scene file's stem
engine = "tetfem"                   # default: tetfem's solvers in this process; "petsc": `tetfem run`
                                    # hands the scene to tetfem-petsc (`mpirun -n N tetfem run SCENE`)

[mesh]
order = 1                           # default 1: 4-node tets; 2: 10-node (quadratic) tets, for
                                    # [mesh.box] meshes: every model (static, dynamic; nonlinear
                                    # ones at 4 quadrature points per tet), modal; no obstacles.
                                    # A mesh file's order is its own (Gmsh type 11 tets, TetGen
                                    # -o2: 2); the key, if given, must equal it

[mesh.box]                          # or [mesh.gmsh] / [mesh.tetgen] with: file = "part.msh"
                                    # (4- or 10-node tets; 3- or 6-node triangles in groups)
min = [0.0, 0.0, 0.0]               # default [0, 0, 0]
max = [1.0, 0.1, 0.1]               # required (m)
cells = [10, 2, 2]                  # required
split = "mirrored6"                 # default "mirrored6"; or "lecture6", "five"

[material]                          # all required (unless [[materials]] cover every tet)
youngs_modulus = 200e9              # Pa
poisson_ratio = 0.3
density = 7850.0                    # kg/m³

# Materials per region: each [[materials]] entry has the keys of [material] and a tet set
# "where": { group = "name or tag" } (Gmsh physical volume) | { box = { min = [..], max = [..] } }
# (tets whose centroid is in the closed box, m) | { attribute = 1 } (TetGen region attribute)
# | { body = 1 } (the tets of [[bodies]] entry 1, numbered from 0).
# [material], if given, covers the tets no entry claims; without it such a tet is an error,
# and so is a tet two entries claim.
# [[materials]]
# youngs_modulus = 70e9
# poisson_ratio = 0.33
# density = 2700.0
# where = { box = { min = [0.5, -1.0, -1.0], max = [2.0, 1.0, 1.0] } }
# model = "neo-hookean"             # default analysis.model: this region's force model (a body's: where = { body = 1 })

# Amplitudes a(t) (t in s), named here and referred to by name, or given in place:
# amplitude = "ramp1" | amplitude = { sine = { frequency_hz = 5.0 } }. Exactly one of
# constant = 1.0 | table = [[0.0, 0.0], [1.0, 1.0]] (t strictly increasing, all finite; linear
# between points, constant beyond the ends) | ramp = { start = 0.0, end = 1.0 } (0 before, linear,
# 1 after; start default 0) | smooth_step = { start = 0.0, end = 1.0 } (quintic 10s³−15s⁴+6s⁵,
# C²) | sine = { amplitude = 1.0, frequency_hz = 5.0, phase = 0.0, start = 0.0 } (A·sin(2πf(t −
# start) + φ) from start on, A·sin φ before; amplitude default 1, phase (rad) and start default 0).
# Static and modal analyses take amplitudes at t = 1 s; dynamic ones at each step's time.
[[amplitudes]]
name = "ramp1"                      # required, unique
ramp = { start = 0.0, end = 1.0 }

# Node and face sets ("where"): "all" | "boundary" (nodes of the boundary faces)
# | { plane = { axis = "x", at = 0.0, tolerance = 1e-9 } }
# (tolerance default: 1e-6 × the bounding-box diagonal) | { box = { min = [..], max = [..] } }
# | { group = "name or tag" } (Gmsh physical group) | { marker = 1 } (TetGen node marker)
# | { face_marker = 3 } (TetGen .face marker: those boundary faces, or their nodes)
# | { nodes = [0, 1, 2] } | { body = 1 } (the nodes of [[bodies]] entry 1, numbered from 0;
# with [self_contact] alone the one body is 0). A face set holds the boundary faces whose three nodes are selected
# (of a group or face_marker: the boundary faces among its triangles).
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
fix = ["x", "y", "z"]               # default all three
displacement = [0.0, 0.0, 0.0]      # default zero (m), for the fixed axes
moment_about = [0.0, 0.0, 0.0]      # the point (m) its reaction moment is reported about; default the origin
# amplitude = "ramp1"               # default constant 1: scales displacement or linear_field
# Instead of displacement (one of the three), for the fixed axes:
# linear_field = { A = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]], b = [0.0, 0.0, 0.0] }
#                                   # u = (A·x + b)·a(t); A dimensionless, b (m) default zero
# rigid_motion = { axis = [1.0, 0.0, 0.0], point = [0.0, 0.0, 0.0], angle_deg = 0.0,
#                  translation = [0.0, 0.0, 0.0], amplitude = "ramp1" }
#                                   # exact rotation by angle_deg·a(t) about the axis (non-zero
#                                   # length) through point (m), then translation·a(t) (m);
#                                   # defaults: point and translation zero, angle 0, amplitude 1

# Loads: exactly one of gravity (m/s²), body_force (N/m³), total_force (N over the faces'
# area), traction (Pa), pressure (Pa, against the outward normal), nodal_force (N per node).
[[loads]]
gravity = [0.0, 0.0, -9.81]
# amplitude = "ramp1"               # any load: default constant 1 (the load times a(t))

[[loads]]
where = { plane = { axis = "x", at = 1.0 } }
total_force = [0.0, 0.0, -1000.0]

[[probes]]                          # mean displacement of a node set, in the CSV series
name = "tip"
where = { plane = { axis = "x", at = 1.0 } }

[[probes]]                          # or at a point inside the mesh (instead of where): u there
name = "inside"                     # from the shape functions of the tet holding it (columns
at = [0.5, 0.05, 0.05]              # <name>_ux_m..), and its stress σ there (every analysis), that
                                    # tet's own (linear in a 10-node tet; <name>_sxx_pa, _syy_pa,
                                    # _szz_pa, _sxy_pa, _syz_pa, _sxz_pa; summary stress_pa); m

[analysis]
type = "static"                     # default "static"; or "dynamic", which needs dt, duration:
# method = "backward_euler"         # default; or "explicit", "newmark"
# dt = 1e-4                         # s, > 0
# duration = 0.1                    # s, ≥ dt, at most 1e9 steps (⌈duration/dt⌉)
# time_tolerance = 1e-3             # dynamic, backward_euler or newmark: the relative trajectory
                                    # error asked for, in (0, 1); dt is then the first step, each
                                    # step's dt chosen from its local error estimate, and frames
                                    # land exactly on multiples of [output] every × dt (no step
                                    # is longer: no other bound is needed). Summary:
                                    # time_stepping (the run's own error estimate, accepted and
                                    # rejected steps, dt_min, dt_max). Not with explicit,
                                    # checkpoint_every, --resume or --steps. Default: none (fixed dt)
# damping = { mass = 0.0, stiffness = 0.0 }   # Rayleigh α (1/s), β (s); default none
# mass = "lumped"                   # default; or "consistent"
# initial_velocity = [0.0, 0.0, 0.0]          # m/s, default zero
# model = "linear"                 # default; or "corotational", "neo-hookean", "st-venant-kirchhoff" (static and every dynamic method; a [[materials]] entry may name its own model)
# formulation = "displacement"      # default; or "mixed": displacement–pressure, no locking
                                    # as ν → 0.5 (P2–P1 on 10-node tets, stabilized P1–P1 on
                                    # 4-node ones; static with the linear, the Neo-Hookean or
                                    # the corotational model; dynamic (backward_euler, newmark,
                                    # consistent mass) and modal with the linear model, and
                                    # backward_euler with the Neo-Hookean or the corotational
                                    # model (undamped, still [[obstacles]] allowed), on either);
                                    # the .vtu gets the point field "pressure" (Pa)
# linear_solver = "auto"            # default: the Cholesky factorization when its factor fits the
                                    # memory budget and is predicted faster; or "direct",
                                    # "iterative" (multigrid-preconditioned CG). Static (linear
                                    # model) and the implicit dynamic methods
# nonlinear_solver = "auto"         # default; or "rest_lbfgs", "rest_preconditioned", "refactor": how
                                    # the implicit dynamic methods solve each step with a nonlinear
                                    # model (tangent-free L-BFGS on the rest-state factor turned by the
                                    # nodes' rotations; CG on the tangent preconditioned by that factor,
                                    # falling back to a factorization; or a factorization per Newton
                                    # iteration; auto: refactor below 1,000 free DOFs, rest_lbfgs from
                                    # there, with obstacles holding the contact nodes' stiffness,
                                    # refactor at every size with [[bodies]] or [self_contact]).
                                    # All stop at the same Newton tolerance, but auto's
                                    # rest_lbfgs path at no less than 1e-3, or once the
                                    # correction left is under 1e-4 of the step's motion, and
                                    # with obstacles at no less than 1e-4 (its trajectories
                                    # within 1e-4 of tight ones on the book's swinging beam and
                                    # dropped block; name rest_lbfgs for a tighter stop).
                                    # Ignored by static, explicit, linear
# newton_tolerance = 1e-8           # default; in (0, 1): each implicit step's Newton tolerance
                                    # with a nonlinear model, ‖r‖ ≤ t·max(‖r₀‖, ‖f‖); 1e-2 is
                                    # interactive (see the README's large-deformation step).
                                    # Static (nonlinear model or obstacles): each load step's,
                                    # ‖r_f‖ ≤ t·‖f_f‖, default 1e-10
# relax_contact_nodes = true        # default; dynamic, implicit, with [[obstacles]]: after each
                                    # Newton step move each node in contact to its own barrier's
                                    # and friction's minimum (fewer iterations, the same solution)
# load_steps = 10                   # static, nonlinear model or obstacles: load increments, each
                                    # solved by Newton, in 1..=100000 (more rescue a failed solve);
                                    # load step k of n is at the pseudo-time t = k/n that moving
                                    # [[obstacles]] follow
# accuracy = 0.01                  # static: a target relative energy-norm error in (0, 1) instead
                                    # of a mesh resolution: box meshes get the element order and cells
                                    # predicted cheapest (from the scene's cells, refined ≤ 2× per axis
                                    # until the ZZ estimate meets it); file meshes a report of whether
                                    # it is met and what would meet it (box: mesh.order and
                                    # cells are the start, both orders are tried). Summary: "accuracy".
                                    # Dynamic (backward_euler, newmark): half for space (that search on
                                    # the scene's static equilibrium under its loads), half for time
                                    # (time_tolerance = accuracy/2, so not both keys)
# max_dofs = 300000                 # with accuracy: cap on 3 × nodes of the meshes tried (≥ 1000)
# Or type = "modal": the lowest natural frequencies and mode shapes (linear model only).
# modes = 6                         # default 6; at most the free DOF count
# mass = "lumped"                   # default; or "consistent"

# Rigid obstacles the body must stay outside of (IPC barrier contact; static and dynamic
# scenes — backward_euler or explicit, not newmark —, 4-node tets; every model, the linear one
# through Newton; a dynamic body may have no [[constraints]]: the obstacles may hold it). kind = "half_space" (point, normal: the
# normal points out of the obstacle, towards the body; non-zero) | "sphere" (center, radius > 0)
# | "box" (min, max with max > min on every axis; or center, half_extents > 0 and rotation_deg
# about z, default 0). The body must start strictly outside every obstacle.
# [[obstacles]]
# kind = "half_space"
# point = [0.0, 0.0, -0.01]         # m
# normal = [0.0, 0.0, 1.0]
# name = "ground"                   # default "obstacle<i>"; letters, digits, '_', '-'
# friction = 0.0                    # Coulomb μ ≥ 0, default 0 (static, backward_euler, explicit)
# velocity = [0.0, 0.0, 0.0]        # dynamic only: m/s, moves the obstacle at constant velocity
                                    # (refused in static scenes: no seconds; give displacement)
# displacement = [0.0, 0.0, -0.01]  # instead: m, moved by displacement·a(t) with amplitude (a
# amplitude = "press"               #   name of [[amplitudes]] or an inline table). Static: t is
                                    #   the pseudo-time k/n at load step k of n (load_steps),
                                    #   amplitude optional (default a ramp 0 → 1 over t ∈ [0, 1]:
                                    #   all of it at the last load step); each load step moves it
                                    #   at once, the body carried with it (where it cannot be: in
                                    #   stages, too far for them an error asking for more
                                    #   load_steps); friction's slip is relative
                                    #   to it (a body carried along its surface by friction alone
                                    #   needs each load step's move along it below slip_distance)
# spin = [0.0, 0.0, 2.0]            # dynamic only: rad/s, a constant spin about the axis through
# spin_axis_point = [0.0, 0.0, 0.0] #   spin_axis_point (m; default the sphere's center or the
                                    #   half-space's point): the surface at x moves at
                                    #   ω × (x − p) (plus velocity); friction's slip is relative to
                                    #   it. Only spins that leave the shape in place: a half_space
                                    #   about its normal (a turntable), a sphere about its centre
                                    #   (a roller); not a box, not in static scenes
# CSV: contact_energy_J, contact_<name>_fx_N/_fy_N/_fz_N (force on the obstacle); .vtu frames:
# contact_gap (m), contact_pressure (Pa) per node; summary: contact_forces per obstacle (static:
# force_n, N; dynamic: force_n at the last step, peak_n = the largest |F| (N) at peak_time_s (s));
# PNG frames draw every obstacle where it is at the frame's time, named in a legend
# [contact]                         # only with [[obstacles]]
# activation_distance = 1e-3        # m; default 1e-3 × the bounding-box diagonal
# stiffness = 1e9                   # Pa/m; default E/h (stiffest E, h the mean boundary edge)
# slip_distance = 1e-5              # m; static friction: slip per load step below it sticks
                                    # (creeps); default d̂/10
# slip_velocity = 1e-4              # m/s; dynamic friction: slip speed below it sticks (creeps);
                                    # default 1e-3 × the bounding-box diagonal per second
# gap_tolerance = 1e-8              # static, frictionless: the barrier's gap error Σλd/Σλ/max|u|
                                    # (the pushed nodes' force-weighted gap over the largest
                                    # displacement) is driven below it by shrinking d̂ ÷10 per
                                    # stage (≤ 6 stages, stopped where gaps near the coordinates'
                                    # round-off); with friction d̂ stays; the summary's
                                    # contact_barrier gives the d̂ reached and the error
# impact_fraction = 0.25            # a fraction of d̂, 0 < f < 1; off by default. Implicit
                                    # dynamic scenes: a boundary node outside d̂ takes its own
                                    # κᵢ = max(κ, mᵢvₙ²/(2Aᵢb(f·d̂))) at each step's start, so a
                                    # landing node stops near f·d̂ where dt resolves the impact;
                                    # within d̂ it keeps κᵢ (conservative). Static and explicit
                                    # scenes keep κ

# Several bodies: each [[bodies]] entry its own mesh (or a copy of the [mesh.box]) placed by a
# rigid motion, all in one DOF space, numbered from 0 in [[bodies]] order; they touch through body–body contact (the IPC surface barrier, with
# continuous collision detection in every Newton line search: no iterate intersects). The
# library runs it in static analyses (Newton over load_steps; a body the supports leave free
# must start within d̂ of the one it rests on) and every dynamic method (newmark warns that
# impacts lose energy; explicit steps within the barrier's own step bound and stops, naming the
# step, if a pair would cross); modal analyses refuse it, naming the key.
# [[bodies]]
# mesh = { box = { min = [0.0, 0.0, 0.0], max = [0.1, 0.1, 0.1], cells = [4, 4, 4] } }
#                                   # the body's own mesh, as under [mesh] (box, gmsh or tetgen;
#                                   # the order is [mesh]'s); default a copy of [mesh] (a box)
# translation = [0.0, 0.0, 0.0]     # m; default 0
# rotation_axis = [0.0, 0.0, 1.0]   # default z; the turn is about the mesh's origin, before
# rotation_angle = 0.0              #   the translation (degrees, right-handed; default 0)
# velocity = [0.0, 0.0, 0.0]        # m/s, added to analysis.initial_velocity; default 0
# CSV: body<b>_kinetic_J, body<b>_px_Ns/_py_Ns/_pz_Ns (momentum) per body, surface_energy_J,
# min_surface_distance_m (the smallest distance within d̂, inf when none); .vtu: body_id per tet
# [self_contact]                    # on with [[bodies]]; alone: one body's self-contact
# distance = 1e-3                   # m, d̂; default a tenth of the shortest surface edge
# stiffness = 1e3                   # J/m², κ; default E·h̄ (stiffest E, h̄ the mean surface edge)
# friction = 0.0                    # Coulomb μ ≥ 0 between the surfaces, default 0; lagged per
                                    #   backward_euler or newmark step (static and explicit runs
                                    #   refuse μ > 0: nothing there would lag it)
# slip_velocity = 1e-4              # m/s; slip speed below it sticks (creeps); default 1e-3 ×
                                    #   the bounding-box diagonal per second

[petsc]                             # read by the PETSc engine only (engine = "petsc")
solver = "gamg"                     # default "gamg" (CG + GAMG); "hypre" (CG + BoomerAMG); "mumps" (direct)
options = ""                        # PETSc options, e.g. "-ksp_rtol 1e-10 -ksp_monitor": they win over
                                    # the preset's; options on the command line win over them

[output]
directory = "out/reference"         # default "out/<scene file stem>" in the working directory
vtu = true                          # .vtu frames + .pvd collection; default true
every = 1                           # dynamic: a frame every N steps; default 1
csv = true                          # probes time series; default true
png = false                         # default false
png_field = "displacement"          # default; or "von_mises"
png_size = [960, 600]               # default [960, 600]
deformation_scale = 0.0             # 0 (default): automatic
critical_step = false               # static and modal: also report the explicit critical step (s); default false
vtu_format = "binary"               # default (appended raw binary); or "ascii"
checkpoint_every = 0                # dynamic: write <stem>_checkpoint.bin every N steps (and at Ctrl-C) for `tetfem run --resume`; 0 (default): none
"#;

/// The settings of a modal scene, validated.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ModalSettings {
    /// How many of the lowest modes, ≥ 1 (checked against the free DOFs when the scene is built).
    pub modes: usize,
    /// Mass matrix kind.
    pub mass: MassKind,
}

/// Modes a modal scene asks for when it does not say.
pub const DEFAULT_MODES: usize = 6;

/// The most load steps a static scene may ask for (`analysis.load_steps`): each is at least
/// one Newton solve, and more than this is a typing slip rather than a rescue.
pub const MAX_LOAD_STEPS: usize = 100_000;

/// The time integration settings of a dynamic scene, validated.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct DynamicSettings {
    /// The method.
    pub method: Method,
    /// Time step (s), finite and > 0.
    pub dt: f64,
    /// Simulated time (s), finite, ≥ dt and at most [`MAX_STEPS`] steps of dt.
    pub duration: f64,
    /// Rayleigh damping, both coefficients finite and ≥ 0.
    pub damping: DampingSpec,
    /// Mass matrix kind.
    pub mass: MassKind,
    /// Initial velocity of every node (m/s).
    pub initial_velocity: [f64; 3],
    /// The implicit methods' Newton tolerance per step with a nonlinear model (relative, in
    /// (0, 1); default 1e-8).
    pub newton_tolerance: f64,
    /// With rigid obstacles, the implicit methods relax the nodes in contact to their own
    /// barrier's and friction's minimum after each Newton step (default `true`).
    pub relax_contact_nodes: bool,
}

impl DynamicSettings {
    /// Number of steps: ⌈duration/dt⌉ (the last step may end past `duration` by under one dt).
    pub fn steps(&self) -> usize {
        (self.duration / self.dt - 1e-9).ceil().max(1.0) as usize
    }
}

/// The analysis a scene asks for.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub enum Analysis {
    /// Static equilibrium.
    Static,
    /// Time integration.
    Dynamic(DynamicSettings),
    /// Natural frequencies and mode shapes.
    Modal(ModalSettings),
}

/// Output settings with the defaults filled in.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OutputSettings {
    /// Output folder (absolute, or relative to the working directory).
    pub directory: PathBuf,
    /// File stem of the outputs (the scene file's stem).
    pub stem: String,
    /// Write `.vtu` + `.pvd`.
    pub vtu: bool,
    /// Frame every N steps.
    pub every: usize,
    /// Write the CSV series.
    pub csv: bool,
    /// Render PNGs.
    pub png: bool,
    /// Field that colours the PNGs.
    pub png_field: PngField,
    /// PNG size (pixels).
    pub png_size: [u32; 2],
    /// Displacement magnification (0: automatic).
    pub deformation_scale: f64,
    /// Static and modal runs: also find the explicit critical step (lumped mass) for the
    /// summary (dynamic runs always report it).
    pub critical_step: bool,
    /// Encoding of the `.vtu` files.
    pub vtu_format: VtuEncoding,
    /// Dynamic: write a checkpoint every this many steps for a resume (0: none).
    pub checkpoint_every: usize,
}

/// A parsed and checked scene file.
#[derive(Debug, Clone)]
pub struct Scene {
    spec: SceneSpec,
    text: String,
    source_name: String,
    base_dir: PathBuf,
    stem: String,
    analysis: Analysis,
    model: tetfem::model::ModelKind,
    /// Each `[[materials]]` entry's own force model (`materials[i].model`), `None` where it
    /// takes `model`.
    region_models: Vec<Option<tetfem::model::ModelKind>>,
    /// A static run's Newton settings (`load_steps`, `newton_tolerance`), checked.
    static_newton: tetfem::analysis::nonlinear::NewtonOptions,
    order: usize,
    accuracy: Option<AccuracyTarget>,
    output: OutputSettings,
    /// `[[obstacles]]`, checked.
    obstacles: Vec<tetfem::contact::Obstacle>,
    /// `engine`, `[petsc]`, checked.
    engine: EngineSettings,
    /// The mesh file as parsed for its order, kept for the first build (which takes it), so
    /// that a scene parses its mesh file once; shared by clones (a clone's build after
    /// another's reads the file again).
    mesh_file: Arc<Mutex<Option<MeshFile>>>,
}

impl std::str::FromStr for Scene {
    type Err = Error;

    /// Parses a scene from text; relative paths are taken from the working directory.
    fn from_str(text: &str) -> Result<Scene> {
        Scene::parse(text, "<string>", Path::new("."))
    }
}

impl Scene {
    /// Reads and parses a scene file; relative paths in it are taken from its folder.
    pub fn load(path: &Path) -> Result<Scene> {
        let text = tetfem::base::input_file::read_regular_text(path, "a scene file")?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut scene = Scene::parse(&text, &path.display().to_string(), base)?;
        if let Some(stem) = path.file_stem() {
            scene.stem = stem.to_string_lossy().into_owned();
            scene.output = scene.output_settings()?;
        }
        Ok(scene)
    }

    /// Parses scene text; `source_name` is named in errors, `base_dir` resolves relative paths.
    pub fn parse(text: &str, source_name: &str, base_dir: &Path) -> Result<Scene> {
        let spec: SceneSpec = toml::from_str(text).map_err(|e| {
            // An integer beyond TOML's range comes without a span: find it in the text.
            if e.span().is_none()
                && let Some((line, key, value)) = integer_out_of_range(text)
            {
                return Error::Scene {
                    source_name: source_name.to_string(),
                    key,
                    line,
                    message: format!(
                        "{value} is beyond the integers a scene can hold (at most {}): {}",
                        i64::MAX,
                        e.message().trim()
                    ),
                };
            }
            let span = e.span().unwrap_or(0..0);
            let key = error_key(e.message(), text, &span);
            Error::Scene {
                source_name: source_name.to_string(),
                key,
                line: line_of(text, span.start),
                message: e.message().trim().to_string(),
            }
        })?;
        let mut scene = Scene {
            spec,
            text: text.to_string(),
            source_name: source_name.to_string(),
            base_dir: base_dir.to_path_buf(),
            stem: "scene".to_string(),
            analysis: Analysis::Static,
            model: tetfem::model::ModelKind::default(),
            region_models: Vec::new(),
            static_newton: tetfem::analysis::nonlinear::NewtonOptions::default(),
            order: 1,
            accuracy: None,
            output: OutputSettings {
                directory: PathBuf::new(),
                stem: String::new(),
                vtu: true,
                every: 1,
                csv: true,
                png: false,
                png_field: PngField::Displacement,
                png_size: [960, 600],
                deformation_scale: 0.0,
                critical_step: false,
                vtu_format: VtuEncoding::Binary,
                checkpoint_every: 0,
            },
            obstacles: Vec::new(),
            engine: EngineSettings::default(),
            mesh_file: Arc::default(),
        };
        scene.analysis = scene.check_analysis()?;
        scene.order = scene.check_order()?;
        scene.model = scene.check_model()?;
        scene.region_models = scene.check_region_models()?;
        scene.check_combination()?;
        scene.accuracy = accuracy::check_accuracy(&scene, text)?;
        scene.output = scene.output_settings()?;
        scene.obstacles = scene.check_obstacles()?;
        scene.engine = scene.check_engine()?;
        scene.static_newton = scene.check_static_newton()?;
        scene.check_formulation()?;
        Ok(scene)
    }

    /// How the scene's run solves, for the memory check: explicit steps factor nothing, a
    /// modal run factors K, and the others follow `analysis.linear_solver` (auto counts as
    /// iterative: it factors only what fits beside the dense kernels' buffers).
    pub fn run_path(&self) -> tetfem::base::memory::RunPath {
        use tetfem::base::memory::RunPath;
        match &self.analysis {
            Analysis::Dynamic(d) if d.method == tetfem::analysis::dynamics::Method::Explicit => {
                RunPath::Explicit
            }
            Analysis::Modal(_) => RunPath::Direct,
            _ => match self.spec.linear_method() {
                LinearMethod::Direct => RunPath::Direct,
                LinearMethod::Iterative | LinearMethod::Auto => RunPath::Iterative,
            },
        }
    }

    /// The schema-level content.
    pub fn spec(&self) -> &SceneSpec {
        &self.spec
    }

    /// The scene's text, as read.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The title (the `title` key or the file stem).
    pub fn title(&self) -> String {
        self.spec.title.clone().unwrap_or_else(|| self.stem.clone())
    }

    /// The name errors use for this scene (its path, or `<string>`).
    pub fn source_name(&self) -> &str {
        &self.source_name
    }

    /// The folder relative paths are resolved against.
    pub fn base_dir(&self) -> &Path {
        &self.base_dir
    }

    /// The validated analysis.
    pub fn analysis(&self) -> &Analysis {
        &self.analysis
    }

    /// The force model (`analysis.model`; linear by default).
    pub fn model(&self) -> tetfem::model::ModelKind {
        self.model
    }

    /// A static run's Newton settings: `analysis.load_steps` and `analysis.newton_tolerance`
    /// over [`NewtonOptions::default`](tetfem::analysis::nonlinear::NewtonOptions::default) (used with a
    /// nonlinear model, obstacles or body–body contact).
    pub fn static_newton(&self) -> tetfem::analysis::nonlinear::NewtonOptions {
        self.static_newton
    }

    /// The static Newton keys, checked: only a static run that Newton solves (a nonlinear model,
    /// obstacles or body–body contact) takes them; `load_steps` in 1..=[`MAX_LOAD_STEPS`], `newton_tolerance` in
    /// (0, 1).
    fn check_static_newton(&self) -> Result<tetfem::analysis::nonlinear::NewtonOptions> {
        let mut options = tetfem::analysis::nonlinear::NewtonOptions::default();
        let Some(spanned) = &self.spec.analysis else {
            return Ok(options);
        };
        let (a, span) = (spanned.get_ref(), spanned.span());
        if a.kind != AnalysisKind::Static {
            return Ok(options);
        }
        let err = |key: &str, msg: String| self.error(&format!("analysis.{key}"), &span, msg);
        let newton = !self.is_linear() || !self.obstacles.is_empty() || self.has_surface_contact();
        for (key, set) in [
            ("load_steps", a.load_steps.is_some()),
            ("newton_tolerance", a.newton_tolerance.is_some()),
        ] {
            if set && !newton {
                return Err(err(
                    key,
                    "a linear static solve without obstacles takes no Newton setting (it is one \
                     linear solve); set model = \"corotational\" (or another nonlinear model), \
                     add [[obstacles]], or remove the key"
                        .into(),
                ));
            }
        }
        if let Some(steps) = a.load_steps {
            if !(1..=MAX_LOAD_STEPS).contains(&steps) {
                return Err(err(
                    "load_steps",
                    format!("load_steps = {steps} must be in 1..={MAX_LOAD_STEPS}"),
                ));
            }
            options.load_steps = steps;
        }
        if let Some(tolerance) = a.newton_tolerance {
            if !(tolerance > 0.0 && tolerance < 1.0) {
                return Err(err(
                    "newton_tolerance",
                    format!(
                        "newton_tolerance = {} must be finite, > 0 and < 1",
                        short_number(tolerance)
                    ),
                ));
            }
            options.tolerance = tolerance;
        }
        Ok(options)
    }

    /// The element order (`mesh.order`): 1 (4-node tets, the default) or 2 (10-node tets).
    pub fn order(&self) -> usize {
        self.order
    }

    /// The accuracy target (`analysis.accuracy`, `max_dofs`), if the scene gives one.
    pub fn accuracy(&self) -> Option<AccuracyTarget> {
        self.accuracy
    }

    fn check_order(&self) -> Result<usize> {
        let only: OrderOnly = toml::from_str(&self.text).unwrap_or_default();
        let Some(order) = only.mesh.and_then(|m| m.order) else {
            // Without the key: a mesh file's own order, a box mesh's default 1.
            return Ok(self.file_order().unwrap_or(1));
        };
        let span = order.span();
        let value = match order.get_ref() {
            toml::Value::Integer(v @ (1 | 2)) => *v as usize,
            other => {
                return Err(self.error(
                    "mesh.order",
                    &span,
                    format!(
                        "order = {other}: use 1 (4-node linear tets, the default) or 2 (10-node \
                         quadratic tets)"
                    ),
                ));
            }
        };
        match self.file_order() {
            Some(file) if file != value => Err(self.error(
                "mesh.order",
                &span,
                format!(
                    "order = {value}, but the mesh file holds {} (order {file}): a mesh file's \
                     order is its own; remove the key, or mesh the file at order {value} \
                     ({})",
                    if file == 2 {
                        "10-node tets"
                    } else {
                        "4-node tets"
                    },
                    if value == 2 {
                        "gmsh -3 -order 2, tetgen -o2"
                    } else {
                        "gmsh -3 -order 1, tetgen without -o2"
                    }
                ),
            )),
            _ => Ok(value),
        }
    }

    /// The element order of the scene's mesh file: 2 if it holds 10-node tets, else 1; `None`
    /// for a box mesh, or when the file cannot be read now (building the scene reads it again
    /// and reports why). The parsed file is kept for [`take_mesh_file`](Self::take_mesh_file).
    fn file_order(&self) -> Option<usize> {
        let path = self.mesh_path()?;
        let file = MeshFile::read(&path).ok()?;
        let order = file.order();
        if let Ok(mut slot) = self.mesh_file.lock() {
            *slot = Some(file);
        }
        Some(order)
    }

    /// The path of the scene's mesh file (of a TetGen pair the `.ele` file); `None` for a box.
    fn mesh_path(&self) -> Option<PathBuf> {
        match self.spec.mesh.get_ref() {
            MeshSpec::Box(_) => None,
            MeshSpec::Gmsh(f) => Some(self.resolve(&f.file)),
            MeshSpec::Tetgen(f) => {
                let mut ele = build::tetgen_prefix(&self.resolve(&f.file)).into_os_string();
                ele.push(".ele");
                Some(PathBuf::from(ele))
            }
        }
    }

    /// The mesh file as parsed when the scene was, if no build has taken it yet: building
    /// from it does not parse the file a second time.
    pub(crate) fn take_mesh_file(&self) -> Option<MeshFile> {
        self.mesh_file.lock().ok()?.take()
    }

    fn check_model(&self) -> Result<tetfem::model::ModelKind> {
        let Some(spanned) = &self.spec.analysis else {
            return Ok(tetfem::model::ModelKind::default());
        };
        let Some(name) = &spanned.get_ref().model else {
            return Ok(tetfem::model::ModelKind::default());
        };
        let kind: tetfem::model::ModelKind = name.parse().map_err(|_| {
            self.error(
                "analysis.model",
                &spanned.span(),
                format!(
                    "unknown model '{name}': use one of {}",
                    tetfem::model::ModelKind::listed_names()
                ),
            )
        })?;
        Ok(kind)
    }

    /// The output settings, defaults filled in.
    pub fn output(&self) -> &OutputSettings {
        &self.output
    }

    /// Names the outputs of a scene that has no file (an embedded one): `<stem>.vtu`, … in the
    /// default folder `out/<stem>` (what [`load`](Self::load) takes from the file name).
    pub fn set_stem(&mut self, stem: &str) -> Result<()> {
        self.stem = stem.to_string();
        self.output = self.output_settings()?;
        Ok(())
    }

    /// Overrides the output folder (e.g. from a command-line option).
    pub fn set_output_directory(&mut self, directory: PathBuf) {
        self.output.directory = directory;
    }

    /// Overrides the encoding of the `.vtu` files (e.g. from a command-line option).
    pub fn set_vtu_format(&mut self, format: VtuEncoding) {
        self.output.vtu_format = format;
    }

    /// An [`Error::Scene`] at byte `span` of the text.
    pub(crate) fn error(
        &self,
        key: &str,
        span: &Range<usize>,
        message: impl Into<String>,
    ) -> Error {
        Error::Scene {
            source_name: self.source_name.clone(),
            key: key.to_string(),
            line: line_of(&self.text, span.start),
            message: message.into(),
        }
    }

    /// A path from the scene, resolved against its folder.
    pub(crate) fn resolve(&self, path: &Path) -> PathBuf {
        if path.is_absolute() {
            path.to_path_buf()
        } else {
            self.base_dir.join(path)
        }
    }

    fn check_analysis(&self) -> Result<Analysis> {
        let Some(spanned) = &self.spec.analysis else {
            return Ok(Analysis::Static);
        };
        let span = spanned.span();
        let a = spanned.get_ref();
        let err = |key: &str, msg: String| self.error(&format!("analysis.{key}"), &span, msg);
        if a.kind != AnalysisKind::Modal && a.modes.is_some() {
            return Err(err(
                "modes",
                "only a modal analysis takes this key; set type = \"modal\" or remove it".into(),
            ));
        }
        if a.kind != AnalysisKind::Static && a.load_steps.is_some() {
            return Err(err(
                "load_steps",
                "only a static analysis takes this key (a dynamic one steps in time: dt)".into(),
            ));
        }
        match a.kind {
            AnalysisKind::Modal => {
                if let Some(key) = Self::dynamic_only_key(a, false) {
                    return Err(err(
                        key,
                        "only a dynamic analysis takes this key; a modal one takes modes and mass"
                            .into(),
                    ));
                }
                let modes = a.modes.unwrap_or(DEFAULT_MODES);
                if modes == 0 {
                    return Err(err("modes", "modes = 0: ask for at least one mode".into()));
                }
                Ok(Analysis::Modal(ModalSettings {
                    modes,
                    mass: a.mass.unwrap_or_default(),
                }))
            }
            AnalysisKind::Static => {
                if let Some(key) = Self::dynamic_only_key(a, true) {
                    return Err(err(
                        key,
                        "only a dynamic analysis takes this key; set type = \"dynamic\" or remove it".into(),
                    ));
                }
                Ok(Analysis::Static)
            }
            AnalysisKind::Dynamic => Self::check_dynamic_analysis(a, err).map(Analysis::Dynamic),
        }
    }

    /// The first key of `[analysis]` that only a dynamic analysis takes, if one is set in `a`
    /// (`mass` a modal one takes too: `with_mass` false leaves it out; `newton_tolerance` a static
    /// one takes too, so it only counts against a modal analysis). Named so that a key set for
    /// the wrong analysis is an error rather than silently unused.
    fn dynamic_only_key(a: &spec::AnalysisSpec, with_mass: bool) -> Option<&'static str> {
        [
            ("method", a.method.is_some()),
            ("dt", a.dt.is_some()),
            ("time_tolerance", a.time_tolerance.is_some()),
            ("duration", a.duration.is_some()),
            ("damping", a.damping.is_some()),
            ("mass", with_mass && a.mass.is_some()),
            ("initial_velocity", a.initial_velocity.is_some()),
            (
                "newton_tolerance",
                a.kind == AnalysisKind::Modal && a.newton_tolerance.is_some(),
            ),
            ("relax_contact_nodes", a.relax_contact_nodes.is_some()),
        ]
        .into_iter()
        .find(|(_, set)| *set)
        .map(|(key, _)| key)
    }

    /// The settings of a dynamic `[analysis]`, every value checked (`err` makes the error at
    /// `analysis.<key>`): dt and duration required, finite and > 0 with a step count that fits,
    /// damping ≥ 0, a finite initial velocity, a Newton tolerance in (0, 1).
    fn check_dynamic_analysis(
        a: &spec::AnalysisSpec,
        err: impl Fn(&str, String) -> Error,
    ) -> Result<DynamicSettings> {
        let dt =
            a.dt.ok_or_else(|| err("dt", "a dynamic analysis needs a time step dt (s)".into()))?;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(err(
                "dt",
                format!("dt = {} must be finite and > 0", short_number(dt)),
            ));
        }
        let duration = a
            .duration
            .ok_or_else(|| err("duration", "a dynamic analysis needs a duration (s)".into()))?;
        if !(duration.is_finite() && duration >= dt) {
            return Err(err(
                "duration",
                format!(
                    "duration = {} must be finite and at least dt = {}",
                    short_number(duration),
                    short_number(dt)
                ),
            ));
        }
        if let Err(Error::InvalidParameter { requirement, .. }) =
            RunLength::Duration(duration).steps(dt)
        {
            return Err(err(
                "duration",
                format!("duration = {} {requirement}", short_number(duration)),
            ));
        }
        let damping = a.damping.unwrap_or_default();
        for (key, v) in [
            ("damping.mass", damping.mass),
            ("damping.stiffness", damping.stiffness),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(err(
                    key,
                    format!("{} must be finite and ≥ 0", short_number(v)),
                ));
            }
        }
        let initial_velocity = a.initial_velocity.unwrap_or([0.0; 3]);
        if initial_velocity.iter().any(|v| !v.is_finite()) {
            return Err(err(
                "initial_velocity",
                "every component must be finite".into(),
            ));
        }
        let newton_tolerance = a
            .newton_tolerance
            .unwrap_or(StepNewtonOptions::default().tolerance);
        if !(newton_tolerance > 0.0 && newton_tolerance < 1.0) {
            return Err(err(
                "newton_tolerance",
                format!("newton_tolerance = {newton_tolerance} must be finite, > 0 and < 1"),
            ));
        }
        Ok(DynamicSettings {
            method: a.method.unwrap_or_default(),
            dt,
            duration,
            damping,
            mass: a.mass.unwrap_or_default(),
            initial_velocity,
            newton_tolerance,
            relax_contact_nodes: a
                .relax_contact_nodes
                .unwrap_or(StepNewtonOptions::default().relax_contact_nodes),
        })
    }

    fn output_settings(&self) -> Result<OutputSettings> {
        let default = OutputSpec::default();
        let (o, span) = match &self.spec.output {
            Some(s) => (s.get_ref(), s.span()),
            None => (&default, 0..0),
        };
        let every = o.every.unwrap_or(1);
        if every == 0 {
            return Err(self.error("output.every", &span, "must be at least 1"));
        }
        if o.checkpoint_every.is_some_and(|n| n > 0)
            && !matches!(self.analysis, Analysis::Dynamic(_))
        {
            return Err(Error::Scene {
                source_name: self.source_name.clone(),
                key: "output.checkpoint_every".into(),
                line: restart::key_line(&self.text, "output.checkpoint_every").unwrap_or(0),
                message: "only a dynamic analysis writes checkpoints; remove the key".into(),
            });
        }
        if o.png == Some(true) && !cfg!(feature = "png") {
            return Err(Error::Scene {
                source_name: self.source_name.clone(),
                key: "output.png".into(),
                line: restart::key_line(&self.text, "output.png").unwrap_or(0),
                message: "this build of tetfem-scene has no PNG frames (its `png` feature is \
                          off); set png = false, or build with the feature"
                    .into(),
            });
        }
        let png_size = o.png_size.unwrap_or([960, 600]);
        if png_size[0] < 200 || png_size[1] < 150 || png_size[0] > 8192 || png_size[1] > 8192 {
            return Err(self.error(
                "output.png_size",
                &span,
                format!("{png_size:?} must be within [200, 8192] × [150, 8192] pixels"),
            ));
        }
        let deformation_scale = o.deformation_scale.unwrap_or(0.0);
        if !(deformation_scale.is_finite() && deformation_scale >= 0.0) {
            return Err(self.error("output.deformation_scale", &span, "must be finite and ≥ 0"));
        }
        let directory = match &o.directory {
            Some(d) => self.resolve(d),
            None => PathBuf::from("out").join(&self.stem),
        };
        // Counts a scene may hold but TOML cannot write back (a checkpoint's fingerprint is the
        // scene as TOML): beyond i64, refused here at their line rather than later at "line 0".
        for (key, value) in [
            ("output.every", Some(every)),
            ("output.checkpoint_every", o.checkpoint_every),
        ] {
            if value.is_some_and(|v| i64::try_from(v).is_err()) {
                return Err(Error::Scene {
                    source_name: self.source_name.clone(),
                    key: key.into(),
                    line: restart::key_line(&self.text, key).unwrap_or(0),
                    message: format!(
                        "{} is beyond the integers a scene can hold (at most {})",
                        value.unwrap_or_default(),
                        i64::MAX
                    ),
                });
            }
        }
        Ok(OutputSettings {
            directory,
            stem: self.stem.clone(),
            vtu: o.vtu.unwrap_or(true),
            every,
            csv: o.csv.unwrap_or(true),
            png: o.png.unwrap_or(false),
            png_field: o.png_field.unwrap_or_default(),
            png_size,
            deformation_scale,
            critical_step: o.critical_step.unwrap_or(false),
            vtu_format: o.vtu_format.unwrap_or_default(),
            checkpoint_every: o.checkpoint_every.unwrap_or(0),
        })
    }
}

/// The first `key = <integer>` line of a scene text whose integer does not fit TOML's 64-bit
/// signed integers: (1-based line, dotted key within its table, the integer as written).
pub(crate) fn integer_out_of_range(text: &str) -> Option<(usize, String, String)> {
    let mut start = 0;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let before = &text[..start];
        start += line.len();
        let Some((key, value)) = line.split('#').next().unwrap_or("").split_once('=') else {
            continue;
        };
        let value = value.trim();
        let digits: String = value.chars().filter(|&c| c != '_').collect();
        let unsigned = digits.strip_prefix(['+', '-']).unwrap_or(&digits);
        let integer = !unsigned.is_empty() && unsigned.bytes().all(|b| b.is_ascii_digit());
        if integer && digits.parse::<i64>().is_err() {
            let key = within_table(before, key.trim().trim_matches('"').to_string());
            return Some((i + 1, key, value.to_string()));
        }
    }
    None
}

/// 1-based line of byte `offset` in `text` (0 when the text is empty).
fn line_of(text: &str, offset: usize) -> usize {
    if text.is_empty() {
        return 0;
    }
    let end = offset.min(text.len());
    1 + text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

/// The key a TOML error is about: the one named in "unknown field `x`" or "missing field `x`"
/// messages, else the text under the error's span when it is a short single line.
/// `key` prefixed with the table it sits in (`petsc.solver`), from the last `[table]` or
/// `[[array]]` header in `before`; `key` alone at the top level or when it is dotted already.
fn within_table(before: &str, key: String) -> String {
    if key.contains('.') {
        return key;
    }
    // A header is `[name]` or `[[name]]` with a bare dotted name (not a row of a multi-line
    // array such as `[0.0, 1.0],`).
    let header = |line: &str| -> Option<String> {
        let inner = line.strip_prefix('[')?;
        let inner = inner.strip_prefix('[').unwrap_or(inner);
        let name = inner.split(']').next()?.trim();
        let bare = name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c));
        (bare && name.starts_with(|c: char| c.is_ascii_alphabetic())).then(|| name.to_string())
    };
    let table = before.lines().rev().map(str::trim).find_map(header);
    match table {
        Some(table) if !table.is_empty() => format!("{table}.{key}"),
        _ => key,
    }
}

fn error_key(message: &str, text: &str, span: &Range<usize>) -> String {
    // An unknown variant is a value error: its key is found on the line below (the variant
    // itself is in the message).
    for marker in ["unknown field `", "missing field `"] {
        if let Some(start) = message.find(marker) {
            let rest = &message[start + marker.len()..];
            if let Some(end) = rest.find('`') {
                return rest[..end].to_string();
            }
        }
    }
    // A value error: the key is what precedes the `=` before the value on its line.
    let start = span.start.min(text.len());
    if let Some(before) = text.get(..start) {
        let line = &before[before.rfind('\n').map_or(0, |i| i + 1)..];
        if let Some(eq) = line.rfind('=') {
            let key: String = line[..eq]
                .trim_end()
                .chars()
                .rev()
                .take_while(|c| c.is_alphanumeric() || "_-.\"".contains(*c))
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect();
            if !key.is_empty() {
                return within_table(before, key);
            }
        }
    }
    let under = text.get(span.clone()).unwrap_or("").trim();
    if !under.is_empty() && under.len() <= 60 && !under.contains('\n') {
        under.to_string()
    } else {
        "(scene)".to_string()
    }
}
