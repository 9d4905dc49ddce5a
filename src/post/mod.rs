//! The post-processing room: what is made of a solution — the ZZ a-posteriori error estimate
//! ([`estimate`]), model adequacy advice ([`adequacy`]), convergence rates ([`convergence`]),
//! error norms against a reference ([`error_norms`]) and the writers of `.vtu`, `.pvd` and CSV
//! files ([`output`]).

pub mod adequacy;
pub mod convergence;
pub mod error_norms;
pub mod estimate;
pub mod output;
pub mod static_results;
