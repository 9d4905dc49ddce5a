//! The core's integration tests, one binary (linked once) with a module per subject: each
//! module is what was one test file, its tests unchanged. Shared helpers are `common`.
//!
//! Run one subject with `cargo test --release --test core -- MODULE::` (e.g. `statics::`).

mod adaptive_time_step;
mod amg;
mod analysis_static_modal;
mod analysis_transient;
mod assembly;
mod atomic_writes;
mod beam_theory;
mod block_sparse;
mod combinations;
mod common;
mod contact_at_rest;
mod contact_bad_input;
mod contact_drop;
mod contact_exact;
mod contact_friction;
mod contact_hertz;
mod contact_static_friction;
mod contact_static_moving;
mod convergence;
mod conveyor;
mod corotational_step;
mod critical_step;
mod critical_step_damping;
mod dynamics;
mod element;
mod error_estimate;
mod explicit_contact;
mod gmsh_element_lines;
mod gravity;
mod large_deformation_robustness;
mod memory_tet10;
mod mesh;
mod mesh_io;
mod mesh_trust;
mod mms_rates;
mod modal;
mod model_adequacy;
mod moving_obstacle_steps;
mod moving_supports;
mod nonlinear_tet10;
mod nonlinear_time_varying;
mod p2_stress;
mod properties;
mod quadratic_mesh_io;
mod restart;
mod solver_choice;
mod solvers;
mod st_venant_kirchhoff;
mod statics;
mod supernodal;
mod tet10;
mod tet10_critical_step;
mod turntable;
