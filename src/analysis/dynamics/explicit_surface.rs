//! The explicit method with body–body and self-contact: the surface barrier's force enters
//! symplectic Euler's f_int, its stiffness enters the step bound, and each step is checked for
//! what CCD cannot filter in an explicit step.
//!
//! The barrier B = κ·Σₖ mₖ·b(dₖ) ([`crate::contact::surface::potential`]) has the stiffness
//! κ·mₖ·b″(dₖ)·∇dₖ∇dₖᵀ along each pair (plus κ·mₖ·b′·∇²dₖ, the distance's own curvature),
//! unbounded as dₖ → 0: no step is stable for every distance. The bound is therefore taken at
//! the smallest distance the run may reach, d_min = [`EXPLICIT_SURFACE_DISTANCE_FRACTION`]·d̂,
//! and the run stops by name at a step that brings a pair below it (where the bound would no
//! longer hold) — the barrier then was too soft to stop the bodies in time, and a stiffer κ or
//! an implicit method is the remedy.
//!
//! The bound ([`surface_step_bound`]): for y any mass-normalised vector, yᵀM^{-1/2}(Σₖ cₖ
//! gₖgₖᵀ)M^{-1/2}y ≤ Σₖ cₖ·|gₖ|²_{M⁻¹}·|y over the pair's nodes|² ≤ c_max·(2/m_min)·P·|y|²,
//! with cₖ = κ·mₖ·b″(dₖ) ≤ κ·b″(d_min) (mₖ ≤ 1, b″ decreasing), |∇d|² ≤ 2 over a pair's
//! nodes (the point's unit normal and the triangle's barycentric weights, or the two edges'
//! ones, whose squares sum to at most 1 per side), m_min the lightest free surface node's
//! lumped mass and P the most pairs one node can take part in. So the barrier adds at most
//! ω_B² = 2·P·κ·b″(d_min)/m_min to the body's ω_max² (Weyl: the sum's largest eigenvalue is at
//! most the sum of the largest ones), and the step bound is
//!
//! dt_B = 2/√(ω_max² + ω_B²),  ω_max = 2/dt_body.
//!
//! P from the surface's topology: a node meets the triangles around the other side's nearest
//! vertex (at most T_max, the most triangles at a surface vertex) as a point, the points near
//! each of its own triangles (T_max, one each) as a triangle vertex, and as an edge end E_max
//! edges against E_max edges: P = 2·T_max + E_max² — with d̂ below the shortest surface edge
//! ([`crate::base::warning::Warning::SurfaceBarrierReach`] warns otherwise), where a pair's
//! nearest features are those. The curvature term κ·mₖ·b′·∇²dₖ is left out: b′ < 0, and for
//! the point–point and point–edge distances ∇²d is positive semi-definite, so the term only
//! softens; for point–plane it is of order |b′|/L (L an edge) ≪ b″ at d_min ≪ L.
//!
//! What CCD cannot filter: an explicit step is not searched along, so each step's motion
//! u → u + dt·v⁺ is run through the additive CCD ([`SurfaceContact::max_step`]); a fraction
//! below 1 (some pair would close to less than
//! [`SEPARATION_FRACTION`](crate::contact::surface::SEPARATION_FRACTION) of its distance within
//! the step, crossing not excluded) stops the run with [`Error::Diverged`] naming the step.

use super::{LinearSystem, Mass};
use crate::base::error::{Error, Result, short_number};
use crate::contact::barrier;
use crate::contact::surface::SurfaceContact;

/// d_min/d̂: the smallest surface distance, as a fraction of the activation distance d̂, at
/// which the explicit step bound holds ([`surface_step_bound`]); an explicit step that brings a
/// pair closer stops the run. At a tenth of d̂, b″ = 2·ln 10 + 18 + 99 ≈ 121.6; the two-block
/// impact of `tests/core/surface_dynamics.rs` (κ = 1 kJ/m², 1 m/s each) turned back above it.
pub const EXPLICIT_SURFACE_DISTANCE_FRACTION: f64 = 0.1;

/// The explicit step bound with the surface barrier ([`surface_step_bound`]) and its parts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceStepBound {
    /// dt_B = 2/√(ω_max² + ω_B²) (time units): the explicit method is stable below it while
    /// every surface distance stays at or above `smallest_distance`.
    pub dt: f64,
    /// The body's own critical step 2/ω_max (time units), barrier left out.
    pub body_dt: f64,
    /// d_min = [`EXPLICIT_SURFACE_DISTANCE_FRACTION`]·d̂ (length).
    pub smallest_distance: f64,
    /// P: the most contact pairs one surface node can take part in (2·T_max + E_max²).
    pub pairs_per_node: usize,
    /// m_min: the lightest free surface node's lumped mass (mass units).
    pub lightest_mass: f64,
    /// ω_B² = 2·P·κ·b″(d_min)/m_min (1/time²).
    pub barrier_omega2: f64,
}

/// The explicit step bound of `system` (lumped mass) with the surface barrier of `surface`,
/// `body_dt` the body's own critical step 2/ω_max (time units):
///
/// dt_B = 2/√(ω_max² + ω_B²),  ω_B² = 2·P·κ·b″(d_min)/m_min,
///
/// d_min = [`EXPLICIT_SURFACE_DISTANCE_FRACTION`]·d̂ the smallest distance the run may reach,
/// κ (J/m²) the barrier's stiffness, b″ the barrier's second derivative
/// ([`crate::contact::barrier::second_derivative`]), m_min the lightest free surface node's
/// lumped mass and P = 2·T_max + E_max² the most pairs one surface node can take part in
/// (T_max, E_max the most triangles and edges at a surface vertex). ω_B² bounds the largest
/// eigenvalue of M⁻¹ times the barrier's stiffness along its pairs (|∇d|² ≤ 2 over a pair's
/// nodes, each node in at most P pairs), added to the body's by Weyl's inequality; the
/// distance's own curvature is left out (it only softens point–point and point–edge pairs,
/// and is of order |b′|/L ≪ b″ for point–plane ones). Derivation in
/// `src/analysis/dynamics/explicit_surface.rs`. A surface without a free node gives `body_dt`
/// itself (ω_B = 0).
///
/// Errors: a consistent mass (the explicit method needs a lumped one), `body_dt` not finite and
/// > 0, a surface node beyond the system's DOFs.
pub fn surface_step_bound(
    system: &LinearSystem,
    surface: &SurfaceContact,
    body_dt: f64,
) -> Result<SurfaceStepBound> {
    if !(body_dt.is_finite() && body_dt > 0.0) {
        return Err(Error::invalid_parameter(
            "body critical step",
            body_dt,
            "must be finite and > 0",
        ));
    }
    let Mass::Lumped(masses) = system.mass() else {
        return Err(Error::invalid_parameter(
            "mass",
            "consistent",
            "the explicit step bound with surface contact is for the lumped mass the explicit \
             method uses",
        ));
    };
    let dofs = system.dofs();
    let geometry = surface.surface();
    let mut lightest = f64::INFINITY;
    for &node in geometry.vertices() {
        for axis in 0..3 {
            if let Some(k) = dofs.free_index(3 * node + axis) {
                let m = masses.get(k).copied().ok_or_else(|| {
                    Error::invalid_parameter(
                        format!("surface node {node}"),
                        3 * node + axis,
                        "must be a DOF of the system",
                    )
                })?;
                lightest = lightest.min(m);
            }
        }
    }
    let mut edges_at = vec![0usize; surface.node_count()];
    for &[a, b] in geometry.edges() {
        edges_at[a] += 1;
        edges_at[b] += 1;
    }
    let triangles_max = geometry
        .vertices()
        .iter()
        .map(|&n| geometry.triangles_around(n).len())
        .max()
        .unwrap_or(0);
    let edges_max = edges_at.iter().copied().max().unwrap_or(0);
    let pairs = 2 * triangles_max + edges_max * edges_max;
    let parameters = surface.barrier();
    let d_hat = parameters.activation_distance;
    let d_min = EXPLICIT_SURFACE_DISTANCE_FRACTION * d_hat;
    let barrier_omega2 = match lightest.is_finite() {
        true => {
            2.0 * pairs as f64 * parameters.stiffness * barrier::second_derivative(d_min, d_hat)
                / lightest
        }
        false => 0.0,
    };
    let omega = 2.0 / body_dt;
    Ok(SurfaceStepBound {
        dt: 2.0 / (omega * omega + barrier_omega2).sqrt(),
        body_dt,
        smallest_distance: d_min,
        pairs_per_node: pairs,
        lightest_mass: lightest,
        barrier_omega2,
    })
}

impl SurfaceStepBound {
    /// [`Error::InvalidParameter`] on `dt` naming it and the bound (both in s) when
    /// dt > the bound: the barrier at d_min would make the explicit step unstable.
    pub fn check(&self, dt: f64) -> Result<()> {
        if dt <= self.dt {
            return Ok(());
        }
        Err(Error::invalid_parameter(
            "dt",
            short_number(dt),
            format!(
                "must be at most {} s, the explicit step bound with the surface barrier \
                 (2/√(ω_max² + ω_B²): the body's own critical step {} s, and the barrier's \
                 stiffness at the smallest distance the run may reach, {} m = {} of d̂, over \
                 {} pairs per node of mass {} kg); choose dt below it, or an implicit method",
                short_number(self.dt),
                short_number(self.body_dt),
                short_number(self.smallest_distance),
                EXPLICIT_SURFACE_DISTANCE_FRACTION,
                self.pairs_per_node,
                short_number(self.lightest_mass)
            ),
        ))
    }
}

/// The checks of one explicit step with surface contact (see the module docs): the
/// motion from full displacement `start` by `step` (full DOFs, dt·v⁺ with the supports'
/// motion) must pass the CCD whole, and the end `end` must keep every pair at or above d_min.
/// [`Error::Diverged`] naming `step_number`, `time` and the culprit otherwise.
pub(crate) fn check_surface_step(
    surface: &SurfaceContact,
    (start, step, end): (&[f64], &[f64], &[f64]),
    (step_number, time): (usize, f64),
) -> Result<()> {
    let fraction = surface.max_step(start, step)?;
    if fraction < 1.0 {
        return Err(Error::Diverged {
            step: step_number,
            time,
            reason: format!(
                "the explicit step would bring two parts of the contact surface within {} of \
                 their distance (continuous collision detection allows {:.3e} of the step): \
                 an explicit step cannot be searched along, so crossing is not excluded; \
                 choose a smaller dt, a stiffer surface barrier, or an implicit method",
                crate::contact::surface::SEPARATION_FRACTION,
                fraction
            ),
        });
    }
    let d = surface.smallest_distance(end)?;
    let d_hat = surface.barrier().activation_distance;
    let d_min = EXPLICIT_SURFACE_DISTANCE_FRACTION * d_hat;
    if d < d_min {
        return Err(Error::Diverged {
            step: step_number,
            time,
            reason: format!(
                "two parts of the contact surface came within {} m, below {} m = {} of d̂, \
                 the smallest distance the explicit step bound holds at: the surface barrier \
                 (κ = {} J/m²) is too soft to stop the bodies in time; raise its stiffness, or \
                 choose an implicit method",
                short_number(d),
                short_number(d_min),
                EXPLICIT_SURFACE_DISTANCE_FRACTION,
                short_number(surface.barrier().stiffness)
            ),
        });
    }
    Ok(())
}
