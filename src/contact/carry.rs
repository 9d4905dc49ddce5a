//! Moving obstacles without staging: the body carried with them to a feasible first iterate.
//!
//! An implicit step (or a static load step) moves the obstacles from their placement c to c′ at
//! the step's end. The body's state at the step's start can overlap the obstacles at c′, so it
//! is not a first iterate Newton may start from. Staging ([`super::staging`]) moved the
//! obstacles in collision-free fractions, solving the body at each: with a fast obstacle that is
//! many Newton solves per step (time-of-impact locking: 100 stages were not enough at the
//! explicit critical step).
//!
//! Here the obstacles go to c′ at once, and the body's nodes that they would reach go with them:
//! a node carried by obstacle o moves by Δ_o = c′_o − c_o, so its position relative to the
//! obstacle — its gap, and every point of its path — is unchanged. The other nodes follow a
//! smooth fraction of the move that fades with the distance r from the nearest carried node,
//! w = max(0, 1 − r/R) with R = [`CARRY_REACH`]·|Δ_o|, so that no element is strained by more
//! than about 1/[`CARRY_REACH`] (a carried surface node alone would invert its elements once
//! |Δ| exceeds their size). The joint straight path of body and obstacles from the start to
//! this first iterate is then checked node by node in each obstacle's frame (the exact time of
//! impact of x − c along δ − Δ_o): a node it would bring into a moving obstacle, or within half
//! of the smaller of its start gap and d̂ of it, is carried too, and the field is made again.
//! The result is a first iterate that every obstacle at c′ leaves outside, reached along a
//! collision-free path, from which the Newton line search (itself limited by the time of
//! impact) never leaves the feasible set: one solve per step.
//!
//! When no such start exists — a node pressed between two obstacles, a carried node held by a
//! support against the move, a node the smooth field would push into a still obstacle — the
//! caller falls back to staging.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::Contact;
use crate::base::error::{Error, Result};

/// R/|Δ|: the smooth part of the carry fades over this many times the obstacle's move.
pub const CARRY_REACH: f64 = 3.0;

/// Rounds of "carry the nodes the path would reach, make the field again" before giving up.
const CARRY_ROUNDS: usize = 8;

/// A contact node's part in the carry.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    /// Follows the smooth field.
    Free,
    /// Moves with obstacle o.
    Carried(usize),
    /// Held where it is: the smooth field would push it into a still obstacle.
    Held,
}

impl Contact {
    /// A first iterate for a solve that takes the obstacles from their current offsets to
    /// `target` (length, one per obstacle) from full displacement `u` (length), on a mesh of
    /// rest positions `rest` (every node, length) whose full DOFs are free where `free` is true
    /// (see the module doc): the full displacement u + δ with every boundary node strictly
    /// outside every obstacle at `target`, reached from u along a path that no node crosses an
    /// obstacle on. `None` where no such start is found (the caller stages the move instead);
    /// `Some(u)` when no obstacle moves.
    ///
    /// Errors: lengths that do not match ([`Error::DimensionMismatch`]), a non-finite target.
    pub fn carried_start(
        &self,
        rest: &[Vector3<f64>],
        u: &[f64],
        target: &[Vector3<f64>],
        free: &[bool],
    ) -> Result<Option<Vec<f64>>> {
        Error::check_len("carry displacement", 3 * rest.len(), u.len())?;
        if let Some(&last) = self.nodes().last().filter(|&&n| n >= rest.len()) {
            return Err(Error::invalid_parameter(
                "carry rest positions",
                format!("{} nodes", rest.len()),
                format!("must hold the contact's boundary node {last}"),
            ));
        }
        Error::check_len("carry free DOFs", u.len(), free.len())?;
        Error::check_len("obstacle offsets", self.obstacles().len(), target.len())?;
        if let Some(o) = target.iter().position(|t| !t.iter().all(|v| v.is_finite())) {
            return Err(Error::invalid_parameter(
                format!("target offset of obstacle {}", self.obstacles()[o].name()),
                format!("{:?}", target[o].as_slice()),
                "must be finite",
            ));
        }
        let offsets = self.offsets();
        let shifts: Vec<Vector3<f64>> = target.iter().zip(&offsets).map(|(t, c)| t - c).collect();
        let mut roles = vec![Role::Free; self.nodes().len()];
        for _ in 0..CARRY_ROUNDS {
            let delta = self.carry_field(rest, u, &roles, &shifts, free);
            match self.carry_conflicts(rest, u, &delta, &offsets, &shifts, &mut roles) {
                Conflicts::None => {
                    let mut start = u.to_vec();
                    for (n, d) in delta.iter().enumerate() {
                        for a in 0..3 {
                            start[3 * n + a] += d[a];
                        }
                    }
                    return Ok(Some(start));
                }
                Conflicts::Resolved => continue,
                Conflicts::Unresolvable => return Ok(None),
            }
        }
        Ok(None)
    }

    /// δ of every mesh node (see the module doc) for the contact nodes' `roles`: Δ_o on a node
    /// carried by o, zero on a held one, elsewhere w·Δ of the nearest carried node; zero on
    /// DOFs that are not `free`.
    fn carry_field(
        &self,
        rest: &[Vector3<f64>],
        u: &[f64],
        roles: &[Role],
        shifts: &[Vector3<f64>],
        free: &[bool],
    ) -> Vec<Vector3<f64>> {
        let position = |n: usize| rest[n] + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
        let carriers: Vec<(Vector3<f64>, Vector3<f64>)> = roles
            .iter()
            .enumerate()
            .filter_map(|(k, role)| match role {
                Role::Carried(o) => Some((position(self.nodes()[k]), shifts[*o])),
                _ => None,
            })
            .collect();
        let mut delta = vec![Vector3::zeros(); rest.len()];
        if carriers.is_empty() {
            return delta;
        }
        // A node farther than the longest reach from the carriers' bounding box along an axis
        // is beyond every carrier's reach (r ≥ that axis's distance): most of a body under a
        // small obstacle, which the scan over the carriers below would visit for nothing (with
        // a margin for the rounding of r).
        let (mut low, mut high) = (carriers[0].0, carriers[0].0);
        for (y, _) in &carriers {
            low = low.inf(y);
            high = high.sup(y);
        }
        let margin = (carriers.iter())
            .map(|(_, shift)| 1.001 * CARRY_REACH * shift.norm())
            .fold(0.0, f64::max);
        let beyond =
            |x: &Vector3<f64>| (0..3).any(|a| x[a] < low[a] - margin || x[a] > high[a] + margin);
        delta.par_iter_mut().enumerate().for_each(|(n, d)| {
            let x = position(n);
            if beyond(&x) {
                return;
            }
            let mut best = (f64::INFINITY, Vector3::zeros());
            for (y, shift) in &carriers {
                let reach = CARRY_REACH * shift.norm();
                let r = (x - y).norm();
                if r < reach && r / reach < best.0 {
                    best = (r / reach, *shift);
                }
            }
            if best.0 < 1.0 {
                *d = (1.0 - best.0) * best.1;
            }
        });
        for (k, role) in roles.iter().enumerate() {
            let n = self.nodes()[k];
            match role {
                Role::Carried(o) => delta[n] = shifts[*o],
                Role::Held => delta[n] = Vector3::zeros(),
                Role::Free => {}
            }
        }
        for (n, d) in delta.iter_mut().enumerate() {
            for a in 0..3 {
                if !free[3 * n + a] {
                    d[a] = 0.0;
                }
            }
        }
        delta
    }

    /// Checks the joint path from (u, offsets) to (u + δ, offsets + shifts) node by node in
    /// each obstacle's frame, updating `roles` where a node must be carried or held.
    fn carry_conflicts(
        &self,
        rest: &[Vector3<f64>],
        u: &[f64],
        delta: &[Vector3<f64>],
        offsets: &[Vector3<f64>],
        shifts: &[Vector3<f64>],
        roles: &mut [Role],
    ) -> Conflicts {
        let d_hat = self.parameters().activation_distance;
        let mut outcome = Conflicts::None;
        for (k, &n) in self.nodes().iter().enumerate() {
            let x = rest[n] + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
            for (o, obstacle) in self.obstacles().iter().enumerate() {
                let relative = x - offsets[o];
                let motion = delta[n] - shifts[o];
                if roles[k] == Role::Carried(o) && motion == Vector3::zeros() {
                    continue;
                }
                let hit = obstacle
                    .time_of_impact(&relative, &motion)
                    .is_some_and(|t| t <= 1.0);
                let moving = shifts[o] != Vector3::zeros();
                let squeezed = moving && {
                    let start = obstacle.distance(&relative);
                    obstacle.distance(&(relative + motion)) < 0.5 * start.min(d_hat)
                };
                if !(hit || squeezed) {
                    continue;
                }
                roles[k] = match (roles[k], moving) {
                    // The smooth field pushes it into a still obstacle: hold it.
                    (Role::Free, false) => Role::Held,
                    (Role::Free, true) => Role::Carried(o),
                    // Carried into another obstacle, held in a moving one's way, or carried by
                    // a support-bound DOF into its own: no feasible carry.
                    _ => return Conflicts::Unresolvable,
                };
                outcome = Conflicts::Resolved;
            }
        }
        outcome
    }
}

/// What [`Contact::carry_conflicts`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Conflicts {
    /// The path is collision-free: the field is the start.
    None,
    /// Nodes changed role: make the field again.
    Resolved,
    /// A node no role can free.
    Unresolvable,
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::{CARRY_REACH, Role};
    use crate::contact::{Contact, ContactParameters, Obstacle};
    use crate::mesh::{BoxSplit, TetMesh};

    /// The smooth part of the carry under a small obstacle: each node's δ is w·Δ of its nearest
    /// carried node, w = 1 − r/R, searched over every carrier (the carriers' bounding box only
    /// skips nodes that none of them reaches): the same bits as the search over all of them
    /// for every node, a part of Δ on the nodes near the carriers and none on most of the body.
    #[test]
    fn the_field_moves_the_nodes_near_the_carried_ones_alone() {
        let mesh = TetMesh::box_grid(
            Vector3::zeros(),
            Vector3::new(1.0, 1.0, 1.0),
            [8, 8, 8],
            BoxSplit::Mirrored6,
        )
        .unwrap();
        let sphere = Obstacle::sphere("sphere", Vector3::new(0.5, 0.5, 1.26), 0.25).unwrap();
        let parameters = ContactParameters::for_mesh(&mesh, 1e5).unwrap();
        let contact = Contact::new(&mesh, vec![sphere], parameters).unwrap();
        let rest = mesh.nodes();
        let u: Vec<f64> = (0..3 * rest.len())
            .map(|i| 1e-3 * (i as f64 * 0.37).sin())
            .collect();
        let position = |n: usize| rest[n] + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
        let near = |n: usize| {
            let x = position(n);
            x.z > 0.99 && (x.x - 0.5).hypot(x.y - 0.5) < 0.2
        };
        let roles: Vec<Role> = (contact.nodes().iter())
            .map(|&n| match near(n) {
                true => Role::Carried(0),
                false => Role::Free,
            })
            .collect();
        let shifts = [Vector3::new(0.0, 0.0, -0.05)];
        let delta = contact.carry_field(rest, &u, &roles, &shifts, &vec![true; u.len()]);
        let reach = CARRY_REACH * shifts[0].norm();
        let carriers: Vec<Vector3<f64>> = (contact.nodes().iter())
            .filter(|&&n| near(n))
            .map(|&n| position(n))
            .collect();
        assert!(carriers.len() >= 4, "{} carriers", carriers.len());
        let mut moved = 0;
        for (n, d) in delta.iter().enumerate() {
            let x = position(n);
            let nearest = (carriers.iter())
                .map(|y| (x - y).norm())
                .filter(|&r| r < reach)
                .fold(f64::INFINITY, |best, r| best.min(r / reach));
            let expected = match near(n) {
                true => shifts[0],
                false if nearest < 1.0 => (1.0 - nearest) * shifts[0],
                false => Vector3::zeros(),
            };
            assert_eq!(*d, expected, "node {n} at {x:?}");
            moved += usize::from(*d != Vector3::zeros());
        }
        assert!(
            moved > carriers.len() && moved < rest.len() / 4,
            "{moved} of {} nodes moved",
            rest.len()
        );
    }
}
