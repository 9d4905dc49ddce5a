//! Contact in explicit steps, enforced on the velocity: after symplectic Euler has formed the
//! new velocity v⁺, each contact node's velocity relative to each obstacle is limited so that
//! its position at the step's end, x + dt·v⁺, keeps a positive gap to the obstacle's placement
//! at t + dt — an inelastic impulse per node — and Coulomb friction acts from that normal
//! impulse ([`Contact::apply_contact_impulses`]).
//!
//! Why this and not the barrier's force: the barrier's node stiffness κ·Aᵢ·b″(d) grows like
//! κ·Aᵢ·d̂²/d² as the gap d closes, so no fixed step is stable for it — an explicit step that
//! is stable for the body lets a node jump through the barrier (a 2 cm drop crossed a table at
//! 0.075×, 0.02×, 0.01× and 0.005× the critical step with the default κ). A critical step that
//! included the barrier would have to bound b″ over gaps the run has not reached yet, which it
//! cannot do as d → 0. A limit on the velocity has no stiffness: it holds every node outside at
//! every step whatever dt, adds nothing to the stable step (it only removes approaching relative
//! velocity, the way graphics and robotics codes resolve contact), and is what the obstacle
//! feels: the reaction −Σ mᵢ·Δvᵢ/dt of the impulses is the force reported on it.
//!
//! Where the contact surface is: a node that starts a step at least d̂ (the barrier's
//! activation distance) from an obstacle ends it at least d̂ from it, so in explicit runs the
//! barrier's force, energy and stiffness are never active once a node is outside its reach (a
//! resting body sits d̂ above the ground — within the (0, d̂) band where the barrier method
//! holds it in implicit runs). A node that starts inside the reach (a body placed within d̂ of
//! an obstacle) keeps at least its current gap, and there the barrier's force still acts: such
//! a start is refused when the barrier's own stable step 2·√(mᵢ/(κ·Aᵢ·b″(d))) at that gap is
//! below dt ([`Error::InvalidParameter`] naming κ, both steps, the node and the obstacle), so a
//! user-set stiffness cannot make the step unstable silently.
//!
//! Energy: the limit removes only velocity toward the obstacle (relative to its motion), so
//! the kinetic energy in the obstacle's frame never grows from it; the contact is inelastic
//! (the contacting nodes' normal kinetic energy is lost at each impact). Friction shrinks the
//! tangential relative speed by at most μ times the normal velocity change (IPC's smoothed
//! Coulomb law below the stick speed ε_v, as everywhere in the library), never reverses it.
//!
//! Moving obstacles: the end gap is measured against the placement c(t + dt), so a node in the
//! path of a moving obstacle is carried along with it. A spinning obstacle's shape stays in
//! place ([`super::obstacle::Spin`]): its spin enters friction only, whose relative velocity is
//! taken against the mean velocity of the obstacle's material point under the node over the
//! step (the exact turn by |ω|·dt over dt). Fixed DOFs (inverse mass 0) are left
//! alone: the limit acts on a node's free DOFs only, and a node held where an obstacle will be
//! at the step's end is [`Error::Diverged`] naming the step, the node and the obstacle.

use nalgebra::Vector3;

use super::friction::speed_after_friction;
use super::{Contact, barrier};
use crate::base::error::{Error, Result, short_number};

/// Passes of the normal limits over the obstacles per node: one suffices for a single obstacle
/// (each limit is exact for a half-space, a sphere and a box); more let a node between two
/// obstacles settle the limits against each other.
const SWEEPS: usize = 3;

/// The smallest share n·P·n of an obstacle's normal on a node's free DOFs (P the projector on
/// them) for which the node can be pushed along the normal; below it the node is held.
const MIN_FREE_SHARE: f64 = 1e-9;

/// The step an explicit contact acts in: its number, its start time and its length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpulseStep {
    /// The step's number (the one errors name: the step being taken, counted from 1).
    pub step: usize,
    /// The time at the step's start (time units).
    pub time: f64,
    /// The step dt (time units, > 0).
    pub dt: f64,
}

/// One node's contact with one obstacle during a step.
#[derive(Debug, Clone, Copy, Default)]
struct Pair {
    /// The end gap the node must keep (length): min(d̂, the gap at the step's start).
    target: f64,
    /// The normal velocity the step gave the node away from the obstacle (length/time): the
    /// limit's change plus the barrier force's dt·λ/m inside the reach.
    normal_speed: f64,
    /// The normal the contact acts along (unit; zero when there is no contact).
    normal: Vector3<f64>,
    /// The velocity change of the node this obstacle caused (length/time).
    pushed: Vector3<f64>,
}

impl Contact {
    /// Contact in an explicit step at the velocity level (see [`super::velocity`]): for each
    /// contact node and obstacle o, with x the node's position at full displacement `u` (the
    /// step's start), v its new velocity in `velocity` and c_o the obstacle's offset, the end
    /// position x + dt·v relative to c_o(t + dt) must keep the gap g = min(d̂, d_o(x − c_o(t))):
    /// where it would not, v changes along the normal n (at the end point, or at the first
    /// point of impact when the straight relative path enters the obstacle), on the node's free
    /// DOFs w = P·n, by Δ = (g − gap)/(dt·n·w). Then friction with μ_o > 0 shrinks the
    /// tangential velocity relative to the obstacle, speed s to the root of
    /// s⁺ + μ·Δv_n·f₁(s⁺) = s (f₁ smoothed below ε_v), Δv_n the normal velocity the step gave
    /// the node (the limit's, plus dt·κ·Aᵢ·|b′(d)|/m of the barrier inside its reach).
    ///
    /// `u`, `velocity` (length/time) and `inverse_mass` (1/mass; 0 on fixed DOFs) are full
    /// length, 3 per node; `velocity` on fixed DOFs holds their prescribed velocity over the
    /// step. Returns the force the body exerted on each obstacle over the step (force units,
    /// the obstacles' order): −Σᵢ mᵢ·Δvᵢ/dt of the changes it made.
    ///
    /// Errors: lengths; dt not finite and > 0; a node on or inside an obstacle at `u`
    /// ([`check_state`](Self::check_state)); a node inside an obstacle's reach whose barrier
    /// is too stiff for dt ([`Error::InvalidParameter`] on the contact stiffness, naming both
    /// steps); a node held by fixed DOFs where an obstacle will be ([`Error::Diverged`]).
    pub fn apply_contact_impulses(
        &self,
        u: &[f64],
        velocity: &mut [f64],
        inverse_mass: &[f64],
        step: ImpulseStep,
    ) -> Result<Vec<Vector3<f64>>> {
        Error::check_len("contact velocity", u.len(), velocity.len())?;
        Error::check_len("contact inverse mass", u.len(), inverse_mass.len())?;
        if !(step.dt.is_finite() && step.dt > 0.0) {
            return Err(Error::invalid_parameter(
                "contact time step",
                step.dt,
                "must be finite and > 0",
            ));
        }
        self.check_full(u)?;
        let offsets = (
            self.offsets_at(step.time),
            self.offsets_at(step.time + step.dt),
        );
        let mut forces = vec![Vector3::zeros(); self.obstacles().len()];
        let mut pairs = vec![Pair::default(); self.obstacles().len()];
        for k in 0..self.nodes().len() {
            let n = self.nodes()[k];
            let dofs = 3 * n..3 * n + 3;
            let (rest, area) = self.rest_and_area(k);
            let x = rest + Vector3::from_column_slice(&u[dofs.clone()]);
            let inverse = Vector3::from_column_slice(&inverse_mass[dofs.clone()]);
            let before = Vector3::from_column_slice(&velocity[dofs.clone()]);
            let node = NodeStep {
                n,
                x,
                area,
                inverse,
            };
            self.start_pairs(&node, &offsets, step, &mut pairs)?;
            let v = self.limit_node(&node, before, &offsets, step, &mut pairs)?;
            for (o, pair) in pairs.iter().enumerate() {
                for a in 0..3 {
                    if inverse[a] > 0.0 {
                        forces[o][a] -= pair.pushed[a] / (inverse[a] * step.dt);
                    }
                }
            }
            for a in 0..3 {
                if inverse[a] > 0.0 {
                    velocity[3 * n + a] = v[a];
                }
            }
        }
        Ok(forces)
    }

    /// Each obstacle's pair of node `node` at the step's start: its target gap, and inside the
    /// barrier's reach the barrier's normal speed dt·κ·A·|b′(d)|/m and the check that its
    /// stiffness leaves dt stable. [`Error::InvalidParameter`] naming the obstacle and the
    /// node when a gap is not positive, or the stiffness when it is too stiff for dt.
    fn start_pairs(
        &self,
        node: &NodeStep,
        (start, _): &(Vec<Vector3<f64>>, Vec<Vector3<f64>>),
        step: ImpulseStep,
        pairs: &mut [Pair],
    ) -> Result<()> {
        let (d_hat, kappa) = (
            self.parameters().activation_distance,
            self.parameters().stiffness,
        );
        let inverse = node.inverse.max();
        for (o, obstacle) in self.obstacles().iter().enumerate() {
            let relative = node.x - start[o];
            let d = obstacle.distance(&relative);
            if d.is_nan() || d <= 0.0 {
                return Err(Error::invalid_parameter(
                    format!("obstacle {}", obstacle.name()),
                    format!("node {} at {d:.3e}", node.n),
                    "a contact node must start each step strictly outside every obstacle \
                     (signed distance > 0)",
                ));
            }
            pairs[o] = Pair {
                target: d.min(d_hat),
                ..Pair::default()
            };
            if d >= d_hat || inverse <= 0.0 {
                continue;
            }
            let stiffness = kappa * node.area * barrier::second_derivative(d, d_hat);
            let stable = 2.0 / (stiffness * inverse).sqrt();
            if step.dt > stable {
                return Err(Error::invalid_parameter(
                    "contact stiffness",
                    short_number(kappa),
                    format!(
                        "makes the explicit step unstable: node {} starts step {} at gap {:.3e} \
                         within the barrier's reach d̂ = {:.3e} of obstacle {}, where the \
                         barrier's stiffness κ·A·b″(d) = {:.3e} N/m is stable only for \
                         dt < {:.3e}, and dt = {:.3e}. Explicit steps hold contact by velocity \
                         at the reach d̂ (no barrier force) for nodes outside it: start the body \
                         at least d̂ from every obstacle, or lower the stiffness or dt",
                        node.n,
                        step.step,
                        d,
                        d_hat,
                        obstacle.name(),
                        stiffness,
                        stable,
                        step.dt
                    ),
                ));
            }
            let normal_force = kappa * node.area * barrier::derivative(d, d_hat).abs();
            pairs[o].normal_speed = step.dt * normal_force * inverse;
            pairs[o].normal = obstacle.gradient(&relative);
        }
        Ok(())
    }

    /// The normal limits and friction of one node (see
    /// [`apply_contact_impulses`](Self::apply_contact_impulses)) from its new velocity
    /// `before`: the velocity it ends the step with, each pair's share recorded in `pairs`.
    fn limit_node(
        &self,
        node: &NodeStep,
        before: Vector3<f64>,
        (start, end): &(Vec<Vector3<f64>>, Vec<Vector3<f64>>),
        step: ImpulseStep,
        pairs: &mut [Pair],
    ) -> Result<Vector3<f64>> {
        let free = node.inverse.map(|m| if m > 0.0 { 1.0 } else { 0.0 });
        let mut v = before;
        for _ in 0..SWEEPS {
            let mut moved = false;
            for (o, obstacle) in self.obstacles().iter().enumerate() {
                let q0 = node.x - start[o];
                let p = node.x + step.dt * v - end[o];
                let Some((normal, shortfall)) = shortfall(obstacle, q0, p, pairs[o].target) else {
                    continue;
                };
                let w = free.component_mul(&normal);
                let share = normal.dot(&w);
                if share < MIN_FREE_SHARE {
                    if obstacle.distance(&p) <= 0.0 {
                        return Err(Error::Diverged {
                            step: step.step,
                            time: step.time,
                            reason: format!(
                                "node {} is held by its supports where obstacle {} will be at \
                                 t = {:e}: a supported node in an obstacle's path cannot be \
                                 pushed aside (free the node, or move the obstacle or the support)",
                                node.n,
                                obstacle.name(),
                                step.time + step.dt
                            ),
                        });
                    }
                    continue;
                }
                let change = shortfall / (step.dt * share);
                v += change * w;
                pairs[o].pushed += change * w;
                pairs[o].normal_speed += change * share;
                pairs[o].normal = normal;
                moved = true;
            }
            if !moved {
                break;
            }
        }
        for (o, obstacle) in self.obstacles().iter().enumerate() {
            let mu = obstacle.friction();
            let pair = &mut pairs[o];
            if mu <= 0.0 || pair.normal_speed <= 0.0 {
                continue;
            }
            // The mean velocity of the obstacle's material point under the node over the step:
            // its translation and its spin's exact turn.
            let surface = (end[o] - start[o]
                + obstacle.surface_turn(&(node.x - start[o]), step.dt))
                / step.dt;
            let relative = v - surface;
            let tangential = relative - pair.normal * pair.normal.dot(&relative);
            let speed = tangential.norm();
            if speed == 0.0 {
                continue;
            }
            let after = speed_after_friction(speed, mu * pair.normal_speed, self.slip_velocity());
            let change = ((after / speed - 1.0) * tangential).component_mul(&free);
            v += change;
            pair.pushed += change;
        }
        Ok(v)
    }
}

/// One contact node in a step: its number, position at the step's start (length), area share
/// (length²) and inverse masses per DOF (1/mass; 0 on fixed DOFs).
struct NodeStep {
    n: usize,
    x: Vector3<f64>,
    area: f64,
    inverse: Vector3<f64>,
}

/// Whether a node moving from `q0` to `p` (positions relative to the obstacle at the step's
/// start and end) ends closer than `target` to `obstacle`: the normal to push it along and by
/// how much (length), or `None`. When the straight path enters the obstacle (time of impact
/// s ≤ 1) the gap is measured from the tangent plane at the point of impact, n·(p − x_s): the
/// obstacle is convex, so a point that far beyond that plane is at least that far from it, and
/// the path from `q0` (on the plane's outer side) to the pushed end point stays outside; else
/// the gap is d(p) along ∇d(p), exact for a half-space, a sphere and a box.
fn shortfall(
    obstacle: &super::Obstacle,
    q0: Vector3<f64>,
    p: Vector3<f64>,
    target: f64,
) -> Option<(Vector3<f64>, f64)> {
    let path = p - q0;
    let (normal, gap) = match obstacle.time_of_impact(&q0, &path) {
        Some(s) if s <= 1.0 => {
            let hit = q0 + s * path;
            let normal = obstacle.gradient(&hit);
            (normal, normal.dot(&(p - hit)))
        }
        _ => (obstacle.gradient(&p), obstacle.distance(&p)),
    };
    (gap < target).then_some((normal, target - gap))
}
