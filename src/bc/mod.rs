//! The boundary-condition room: what the user prescribes on the body — Dirichlet data and the
//! free-DOF map ([`constraints`]), gravity, body, nodal and surface loads ([`loads`]), time
//! functions a(t) with ȧ, ä ([`amplitude`]) and prescribed motions of node sets
//! ([`boundary_motion`]).

pub mod amplitude;
pub mod boundary_motion;
pub mod constraints;
pub mod loads;
