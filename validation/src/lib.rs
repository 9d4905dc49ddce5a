//! tetfem's validation suite and scale study (the `validate` and `scale` programs) and the
//! charts they draw ([`chart`]: error against wall time and the like, PNG and SVG), and the
//! timed static runs of the accuracy-per-second study ([`accuracy`]).
#![warn(missing_docs)]

pub mod accuracy;
pub mod cells;
pub mod chart;
pub mod contact_stress;
pub mod contact_stress_report;
pub mod stability_map;
pub mod watch;
