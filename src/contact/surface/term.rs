//! The surface barrier as a term of a nonlinear force (issue 36, phase 2): body–body and
//! self-contact inside a Newton solve over a DOF vector u, positions x = X + u.
//!
//! [`SurfaceContact`] holds the [`Surface`], the [`SurfaceBarrier`] and the rest positions X,
//! and gives the barrier's energy B(X + u) (J), its force −∂B/∂u (N), its PSD-projected
//! Hessian on a given sparsity pattern (N/m), and the collision-free step bound along a Newton
//! direction ([`SurfaceContact::max_step`]).
//!
//! The broad phase runs once per Newton iteration, not per evaluation: the candidates found at
//! positions x₀ with boxes inflated by d̂ + 2m hold every pair within d̂ at any x whose surface
//! nodes each lie within m of x₀ (a box moves by at most m per axis). [`SurfaceContact::max_step`]
//! sets x₀ to the iterate and m to the direction's largest nodal move, so every trial of the
//! line search that follows reuses them; an evaluation elsewhere (a step's start) finds new
//! ones with m = d̂.
//!
//! The tangent's pattern: the system's stiffness pattern couples the nodes of a tet only, and
//! a contact pair couples nodes that share no tet (of another body, or far along one). The
//! solvers factor on that fixed pattern (its symbolic analysis made once), so the pairs'
//! entries outside it are moved onto the diagonal: an off-pattern entry v at (r, c) is replaced
//! by |v| at (r, r) (and its mirror by |v| at (c, c)). The change, [[|v|, −v], [−v, |v|]] per
//! entry pair, is positive semi-definite, so this tangent P stays PSD and bounds the exact
//! projected Hessian J from above. Alone it converges linearly (it resists the bodies' common
//! motion that contact transmits: 392 Newton iterations over the 24 steps of the two-block
//! impact test). The entries moved are kept ([`SurfaceContact::lumped_entries`]): the
//! refactoring Newton path of the implicit dynamic step puts them back where they belong and
//! factors the exact J on the stiffness pattern grown by the pairs' couplings (its symbolic
//! analysis redone only when a pair couples two DOFs for the first time,
//! `analysis::nonlinear::lumped::CoupledFactor`); the other paths, and the static Newton,
//! solve with the exact J by conjugate gradients preconditioned by P's factor (P⁻¹J has its
//! spectrum in (0, 1]): 58 iterations over those 24 steps; the coupled factor takes 9 Newton
//! iterations a step at most on a 1,296-DOF impact where that path took 154
//! (`tests/core/surface_tangent_scale.rs`; where the exact J is indefinite it factors the
//! projected one on the same pattern, see `validation/block_stack.md`). [`TangentFill`] counts
//! what went where. The pairs within d̂ at a state are found once for its energy, force,
//! tangent and smallest distance (`ActiveMemo`).
//!
//! Friction between the surfaces ([`super::friction`], μ = [`SurfaceBarrier::friction`] > 0):
//! [`SurfaceContact::begin_friction`] lags it at a time step's start, and until
//! [`SurfaceContact::end_friction`] the energy, force and tangent include its dissipative
//! potential D beside the barrier (its Hessian entries placed on the pattern or lumped as the
//! barrier's are).

use std::sync::{Arc, Mutex};

use nalgebra::Vector3;

use super::audit::IntersectionAudit;
use super::boundary::Surface;
use super::bvh::{Candidates, candidates};
use super::ccd::{SEPARATION_FRACTION, pair_step};
use super::friction::{SurfaceFrictionLag, check_friction};
use super::intersect::surface_intersections;
use super::overlap::overlapping_bodies;
use super::potential::{ActivePair, Pair, SurfaceBarrier, pairs_of};
use crate::base::error::{Error, Result};
use crate::base::warning::Warning;
use crate::mesh::{CellType, TetMesh};
use crate::sparse::CscMatrix;

/// Candidates valid for every position within `margin` of `centre` (see the module docs).
struct Reach {
    centre: Vec<Vector3<f64>>,
    margin: f64,
    found: Arc<Candidates>,
}

/// The pairs within d̂ at one state: what the energy, force, tangent and smallest distance at
/// that state share (a line search's trial point has its energy and force evaluated there, the
/// accepted one its tangent and distance), so the narrow phase over the candidates runs once
/// per state instead of once per quantity.
struct ActiveMemo {
    positions: Vec<Vector3<f64>>,
    found: Arc<Candidates>,
    pairs: Arc<Vec<ActivePair>>,
}

/// Where the barrier's Hessian entries went in the last tangent ([`SurfaceContact::add_tangent`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TangentFill {
    /// Entries added where the pattern stores them.
    pub on_pattern: usize,
    /// Entries outside the pattern, moved onto the diagonal as |v|.
    pub lumped: usize,
}

/// Body–body and self-contact of a mesh's boundary surface as a force term (see the module
/// docs): B(X + u) = κ·Σₖ mₖ·b(dₖ, d̂) over the surface's pairs.
pub struct SurfaceContact {
    surface: Surface,
    barrier: SurfaceBarrier,
    rest: Vec<Vector3<f64>>,
    reach: Mutex<Option<Reach>>,
    /// The active pairs at the last state evaluated.
    active: Mutex<Option<ActiveMemo>>,
    fill: Mutex<TangentFill>,
    /// The entries the last tangent moved onto the diagonal, (row, column, v) over the full
    /// DOFs: what [`lumped_entries`](SurfaceContact::lumped_entries) gives a solver that
    /// corrects for them.
    lumped: Mutex<Vec<(usize, usize, f64)>>,
    /// The intersection audit of accepted iterates, when switched on.
    audit: Mutex<Option<IntersectionAudit>>,
    /// ε_v (m/s), resolved from [`SurfaceBarrier::slip_velocity`].
    slip_velocity: f64,
    /// Friction lagged at the current step's start ([`SurfaceContact::begin_friction`]).
    friction: Mutex<Option<SurfaceFrictionLag>>,
}

impl std::fmt::Debug for SurfaceContact {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SurfaceContact")
            .field("triangles", &self.surface.triangles().len())
            .field("barrier", &self.barrier)
            .finish_non_exhaustive()
    }
}

impl SurfaceContact {
    /// The contact of `mesh`'s boundary surface (on 10-node tets its linear sub-triangles,
    /// [`Surface::from_mesh`]) under `barrier`, the mesh's node positions as rest X.
    /// `body_of_node[n]` is mesh node n's body ([`crate::mesh::Bodies::node_bodies`]; all
    /// zeros for one body).
    ///
    /// Errors: those of [`Surface::from_mesh`] (a surface that is not closed or not manifold,
    /// naming the edge); two surface triangles meeting at rest — [`Error::InvalidParameter`]
    /// naming the two bodies and the pair of triangles ([`overlapping_bodies`]): the barrier is
    /// infinite there and no step can separate them; a friction coefficient that is negative
    /// or not finite, or a slip velocity not finite and > 0 (naming the value).
    ///
    /// Friction's slip velocity ε_v is the barrier's, or by default
    /// [`SLIP_FRACTION`](crate::contact::set::SLIP_FRACTION) of the mesh's bounding-box
    /// diagonal per second (the obstacles' default).
    pub fn new<C: CellType>(
        mesh: &TetMesh<C>,
        body_of_node: &[usize],
        barrier: SurfaceBarrier,
    ) -> Result<Self> {
        check_friction("surface barrier friction", barrier.friction)?;
        let slip_velocity = match barrier.slip_velocity {
            Some(v) => {
                barrier.with_slip_velocity(v)?;
                v
            }
            None => {
                let (min, max) = mesh.bounding_box();
                crate::contact::set::SLIP_FRACTION * (max - min).norm()
            }
        };
        let surface = Surface::from_mesh(mesh)?;
        overlapping_bodies(&surface, mesh.nodes(), body_of_node)?;
        Ok(SurfaceContact {
            slip_velocity,
            friction: Mutex::new(None),
            surface,
            barrier,
            rest: mesh.nodes().to_vec(),
            reach: Mutex::new(None),
            active: Mutex::new(None),
            fill: Mutex::new(TangentFill::default()),
            lumped: Mutex::new(Vec::new()),
            audit: Mutex::new(None),
        })
    }

    /// Switches the intersection audit on (`Some`, see [`super::audit`]) or off (`None`): every
    /// Newton iterate that a solve carrying this contact accepts
    /// ([`note_accepted_iterate`](Self::note_accepted_iterate)) is then tested exactly for
    /// intersecting triangles into `audit`, whose clone the caller keeps to read the counts.
    /// Through a shared reference, so that a force already built (a transient set-up's) can
    /// be audited.
    pub fn set_intersection_audit(&self, audit: Option<IntersectionAudit>) {
        *self.audit.lock().unwrap_or_else(|e| e.into_inner()) = audit;
    }

    /// The audit's record, when it is on.
    pub fn intersection_audit(&self) -> Option<IntersectionAudit> {
        self.audit.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// What a solver calls on each Newton iterate it accepts, at full displacement `u`: the
    /// audit's exact intersection test when it is on, nothing otherwise (a run without the
    /// audit pays nothing and its numbers are unchanged).
    pub fn note_accepted_iterate(&self, u: &[f64]) {
        if let Some(audit) = self.intersection_audit() {
            match self.positions(u) {
                Ok(x) => audit.check(&self.surface, &x),
                // The positions' length is the only failure: recorded as a failed check.
                Err(_) => audit.check(&self.surface, &[]),
            }
            if let Ok(d) = self.smallest_distance(u) {
                audit.note_distance(d);
            }
        }
    }

    /// [`Warning::SurfaceBarrierReach`] when d̂ exceeds the shortest surface edge at rest: a
    /// node's barrier then reaches past its neighbours' triangles and pushes on pairs of one
    /// face's own curvature, stiffening the surface where nothing touches.
    pub fn warnings(&self) -> Vec<Warning> {
        let shortest = self.surface.shortest_rest_edge();
        let d_hat = self.barrier.activation_distance;
        match d_hat > shortest {
            true => vec![Warning::SurfaceBarrierReach {
                activation_distance: d_hat,
                shortest_edge: shortest,
            }],
            false => Vec::new(),
        }
    }

    /// The surface.
    pub fn surface(&self) -> &Surface {
        &self.surface
    }

    /// The barrier's d̂ (m) and κ (J/m²).
    pub fn barrier(&self) -> SurfaceBarrier {
        self.barrier
    }

    /// Mesh nodes (the length of the full displacement is 3 times it).
    pub fn node_count(&self) -> usize {
        self.rest.len()
    }

    /// The positions X + u (m) of full displacement `u` (3 per mesh node, node-major).
    pub fn positions(&self, u: &[f64]) -> Result<Vec<Vector3<f64>>> {
        Error::check_len("surface contact displacement", 3 * self.rest.len(), u.len())?;
        Ok(self
            .rest
            .iter()
            .enumerate()
            .map(|(n, x)| x + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]))
            .collect())
    }

    /// Candidates valid at `x`: the kept ones when `x` is within their reach, else new ones
    /// with a margin of d̂ (kept for the evaluations that follow).
    fn candidates_at(&self, x: &[Vector3<f64>]) -> Result<Arc<Candidates>> {
        let mut reach = self.reach.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(r) = reach.as_ref().filter(|r| self.within(r, x)) {
            return Ok(Arc::clone(&r.found));
        }
        let margin = self.barrier.activation_distance;
        let kept = self.find(x, margin)?;
        let found = Arc::clone(&kept.found);
        *reach = Some(kept);
        Ok(found)
    }

    /// The pairs within d̂ at `x` among the candidates valid there: the kept ones when `x` and
    /// the candidates are those of the last call, else found anew (and kept).
    fn active_at(&self, x: &[Vector3<f64>]) -> Result<Arc<Vec<ActivePair>>> {
        let found = self.candidates_at(x)?;
        let mut memo = self.active.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(m) = memo
            .as_ref()
            .filter(|m| Arc::ptr_eq(&m.found, &found) && m.positions.as_slice() == x)
        {
            return Ok(Arc::clone(&m.pairs));
        }
        let pairs = Arc::new(self.barrier.active_among(&self.surface, x, &found)?);
        *memo = Some(ActiveMemo {
            positions: x.to_vec(),
            found,
            pairs: Arc::clone(&pairs),
        });
        Ok(pairs)
    }

    fn within(&self, reach: &Reach, x: &[Vector3<f64>]) -> bool {
        let m2 = reach.margin * reach.margin;
        self.surface
            .vertices()
            .iter()
            .all(|&n| (x[n] - reach.centre[n]).norm_squared() <= m2)
    }

    fn find(&self, x: &[Vector3<f64>], margin: f64) -> Result<Reach> {
        let inflation = self.barrier.activation_distance + 2.0 * margin;
        Ok(Reach {
            centre: x.to_vec(),
            margin,
            found: Arc::new(candidates(&self.surface, x, None, inflation)?),
        })
    }

    /// B(X + u) (J): +∞ where a pair touches (d = 0); plus friction's D(X + u) while a step's
    /// friction is lagged ([`begin_friction`](Self::begin_friction)).
    pub fn energy(&self, u: &[f64]) -> Result<f64> {
        let x = self.positions(u)?;
        let active = self.active_at(&x)?;
        let barrier = self.barrier.energy_of_active(&self.surface, &x, &active);
        Ok(barrier + self.friction_lock().as_ref().map_or(0.0, |l| l.energy(&x)))
    }

    /// Whether the surfaces have friction (μ > 0).
    pub fn has_friction(&self) -> bool {
        self.barrier.friction > 0.0
    }

    /// Friction's slip velocity ε_v (m/s).
    pub fn slip_velocity(&self) -> f64 {
        self.slip_velocity
    }

    /// Starts a time step of `dt` (s) from full displacement `u`: with μ > 0, lags each pair's
    /// normal force, closest points and tangent plane there, smoothing distance ε = ε_v·`dt`
    /// ([`SurfaceFrictionLag::new`]); the energy, force and tangent include friction until
    /// [`end_friction`](Self::end_friction) or the next call. Without friction it does nothing.
    /// Errors: lengths, `dt` not finite and > 0, a pair at distance 0.
    pub fn begin_friction(&self, u: &[f64], dt: f64) -> Result<()> {
        if !self.has_friction() {
            return Ok(());
        }
        let x = self.positions(u)?;
        let found = self.candidates_at(&x)?;
        let lag = SurfaceFrictionLag::new(
            &self.barrier,
            &self.surface,
            &x,
            &found,
            self.barrier.friction,
            self.slip_velocity * dt,
        )?;
        *self.friction_lock() = Some(lag);
        Ok(())
    }

    /// Drops the lagged friction (what evaluations between steps see).
    pub fn end_friction(&self) {
        *self.friction_lock() = None;
    }

    /// The current step's lagged friction, if any.
    pub fn friction_lag(&self) -> Option<SurfaceFrictionLag> {
        self.friction_lock().clone()
    }

    fn friction_lock(&self) -> std::sync::MutexGuard<'_, Option<SurfaceFrictionLag>> {
        // A poisoned lock only means a panic elsewhere while holding plain data: keep it.
        self.friction.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Adds the barrier's force −∂B/∂u (N) into `force` (full DOFs, 3 per mesh node), and
    /// friction's −∂D/∂u while lagged.
    /// Errors: a length mismatch; a pair at distance 0 (see
    /// [`SurfaceBarrier::add_gradient`]).
    pub fn add_force(&self, u: &[f64], force: &mut [f64]) -> Result<()> {
        let x = self.positions(u)?;
        Error::check_len("surface contact force", u.len(), force.len())?;
        let active = self.active_at(&x)?;
        let mut gradient = vec![0.0; u.len()];
        self.barrier
            .add_gradient_of_active(&self.surface, &x, &active, &mut gradient)?;
        if let Some(lag) = self.friction_lock().as_ref() {
            lag.add_gradient(&x, &mut gradient)?;
        }
        force.iter_mut().zip(&gradient).for_each(|(f, g)| *f -= g);
        Ok(())
    }

    /// Adds ∂²B/∂u² (N/m), each pair's block projected to PSD when `project`, and friction's
    /// ∂²D/∂u² while lagged, into `matrix`
    /// (full DOFs, both triangles stored): entries the pattern stores are added, the others
    /// moved onto the diagonal as |v| (see the module docs); returns the counts.
    /// Errors: a dimension mismatch, a pair at distance 0, a diagonal the pattern lacks.
    pub fn add_tangent(
        &self,
        u: &[f64],
        project: bool,
        matrix: &mut CscMatrix,
    ) -> Result<TangentFill> {
        let x = self.positions(u)?;
        Error::check_len("surface contact tangent", u.len(), matrix.dim())?;
        let active = self.active_at(&x)?;
        let mut triplets =
            self.barrier
                .hessian_triplets_of_active(&self.surface, &x, &active, project)?;
        if let Some(lag) = self.friction_lock().as_ref() {
            // Friction's Hessian is PSD as it stands: `project` does not change it.
            triplets.extend(lag.hessian_triplets(&x));
        }
        let mut fill = TangentFill::default();
        let mut lumped = Vec::new();
        for (r, c, v) in triplets {
            match entry(matrix, r, c) {
                Some(k) => {
                    matrix.values_mut()[k] += v;
                    fill.on_pattern += 1;
                }
                None => {
                    let k = entry(matrix, r, r).ok_or_else(|| {
                        Error::invalid_parameter(
                            "surface contact tangent",
                            format!("no diagonal entry ({r}, {r})"),
                            "the pattern must store every diagonal entry",
                        )
                    })?;
                    matrix.values_mut()[k] += v.abs();
                    fill.lumped += 1;
                    lumped.push((r, c, v));
                }
            }
        }
        *self.fill.lock().unwrap_or_else(|e| e.into_inner()) = fill;
        *self.lumped.lock().unwrap_or_else(|e| e.into_inner()) = lumped;
        Ok(fill)
    }

    /// The entries (row, column, v) over the full DOFs that the last
    /// [`add_tangent`](Self::add_tangent) found outside the pattern and moved onto the diagonal
    /// as |v| at (row, row): the exact Hessian is that tangent plus, per entry, v at
    /// (row, column) less |v| at (row, row).
    pub fn lumped_entries(&self) -> Vec<(usize, usize, f64)> {
        self.lumped
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// Where the last tangent's entries went ([`TangentFill`]).
    pub fn last_fill(&self) -> TangentFill {
        *self.fill.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The largest fraction α ∈ (0, 1] of the step `du` from `u` (full DOFs) along which no
    /// pair of the surface meets and each keeps [`SEPARATION_FRACTION`] of its start distance
    /// (additive CCD per pair, [`pair_step`]). Finds the candidates for the whole segment
    /// (margin: the largest nodal move of `du`) and keeps them for the line search's
    /// evaluations along it: the one broad phase of a Newton iteration.
    ///
    /// Errors: lengths; a non-finite entry of `du`; a pair at distance 0 at `u`.
    pub fn max_step(&self, u: &[f64], du: &[f64]) -> Result<f64> {
        let x = self.positions(u)?;
        Error::check_len("surface contact step", u.len(), du.len())?;
        if let Some(dof) = du.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid_parameter(
                format!("surface contact step du[{dof}]"),
                du[dof],
                "must be finite to bound the step by the first time of impact",
            ));
        }
        let dx: Vec<Vector3<f64>> = (0..self.rest.len())
            .map(|n| Vector3::new(du[3 * n], du[3 * n + 1], du[3 * n + 2]))
            .collect();
        let margin = self
            .surface
            .vertices()
            .iter()
            .fold(0.0_f64, |m, &n| m.max(dx[n].norm()));
        // A relative 1e-9 over the largest move: a trial at α = 1 rounds X + u + du within it,
        // so the line search's last trial does not miss the kept candidates by an ulp.
        let margin = margin * (1.0 + 1e-9);
        let kept = self.find(&x, margin)?;
        let mut alpha: f64 = 1.0;
        for pair in pairs_of(&kept.found) {
            let nodes = pair.nodes(&self.surface);
            let (xs, dxs) = (nodes.map(|n| x[n]), nodes.map(|n| dx[n]));
            alpha = alpha.min(certified_step(pair, &xs, &dxs)?);
        }
        *self.reach.lock().unwrap_or_else(|e| e.into_inner()) = Some(kept);
        Ok(alpha)
    }

    /// The smallest distance (m) between two non-adjacent surface primitives at `u` within
    /// d̂ (+∞ when none is within d̂).
    pub fn smallest_distance(&self, u: &[f64]) -> Result<f64> {
        let x = self.positions(u)?;
        Ok(self
            .active_at(&x)?
            .iter()
            .fold(f64::INFINITY, |d, p| d.min(p.distance)))
    }

    /// The pairs of surface triangles that intersect at `u` (the exact test,
    /// [`surface_intersections`], independent of the barrier).
    pub fn intersections(&self, u: &[f64]) -> Result<Vec<(usize, usize)>> {
        surface_intersections(&self.surface, &self.positions(u)?)
    }
}

/// [`pair_step`] up to the whole step, each pair on its own (not capped by the fraction other
/// pairs allowed: a cap that the pair's first certified step passes by a few ulps returns 0
/// when the distance at the cap rounds to just below the kept separation, as a head-on
/// approach closing exactly (1 − s)·d₀ over the cap does). A 0 from round-off at the limit
/// is retried at half the limit, where the first step's bound keeps the pair well apart.
fn certified_step(pair: Pair, x: &[Vector3<f64>; 4], dx: &[Vector3<f64>; 4]) -> Result<f64> {
    let mut limit = 1.0;
    // 60 halvings reach 1e-18 of the step: below that no motion is representable.
    for _ in 0..60 {
        let t = pair_step(pair, x, dx, SEPARATION_FRACTION, limit)?;
        if t > 0.0 {
            return Ok(t);
        }
        limit *= 0.5;
    }
    Ok(0.0)
}

/// The index in `matrix`'s values of entry (row, col), `None` where the pattern has none.
fn entry(matrix: &CscMatrix, row: usize, col: usize) -> Option<usize> {
    let range = matrix.col_ptr()[col]..matrix.col_ptr()[col + 1];
    matrix.row_idx()[range.clone()]
        .binary_search(&row)
        .ok()
        .map(|k| range.start + k)
}
