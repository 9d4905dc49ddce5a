//! The contact nodes' local problems after each accepted Newton step of a step with rigid
//! obstacles that leaves it short of its tolerance (see `crate::contact::set::relax`): the
//! moves they ask for, taken together where they lower both the step's potential Φ and its
//! residual.

use nalgebra::{Matrix3, Vector3};

use super::node_correction::{Group, block, node_groups};
use super::{NewtonSolver, Pass, StepEquation};
use crate::analysis::dynamics::{LinearSystem, Mass};
use crate::base::error::Result;
use crate::base::vector::norm;

/// The diagonal node blocks of the rest step matrix J₀ = s·M + k·K₀ (the local problems'
/// frozen quadratic), for the scales they were made at.
#[derive(Debug, Default)]
pub(super) struct RestBlocks {
    scales: Option<(f64, f64)>,
    /// Per mesh node: its group of free DOFs and J₀'s block, for a wholly free node.
    nodes: Vec<Option<(Group, Matrix3<f64>)>>,
}

impl NewtonSolver {
    /// Moves the contact nodes of the accepted iterate `u_new` (residual norm `r_norm`) to
    /// their local problems' minimizers when that lowers Φ and ‖r‖; returns the residual norm
    /// of the iterate left. Only with rigid obstacles and no body–body contact; the barrier
    /// weighted as the step equation weighs it ([`StepEquation::contact_weight`]).
    pub(super) fn relax_contact_nodes(
        &mut self,
        system: &LinearSystem,
        equation: &StepEquation,
        u_new: &mut [f64],
        scales: (f64, f64),
        r_norm: f64,
    ) -> Result<f64> {
        if !self.options.relax_contact_nodes
            || self.force.contact().is_none()
            || self.force.surface_contact().is_some()
        {
            return Ok(r_norm);
        }
        self.ensure_rest_blocks(system, scales);
        let blocks = &self.rest_blocks.nodes;
        let residual = &self.residual;
        let moves = self
            .force
            .relax_contact_nodes(u_new, self.contact_weight, |node| {
                let (g, a) = blocks.get(node)?.as_ref()?;
                let r = Vector3::new(
                    residual[g.first],
                    residual[g.first + 1],
                    residual[g.first + 2],
                );
                Some((r, *a))
            })?;
        if moves.is_empty() {
            return Ok(r_norm);
        }
        self.delta.fill(0.0);
        for (node, d) in &moves {
            if let Some(Some((g, _))) = self.rest_blocks.nodes.get(*node) {
                for a in 0..3 {
                    self.delta[g.first + a] = d[a];
                }
            }
        }
        if self.force.contact_step_limit(u_new, &self.delta)? < 1.0 {
            return Ok(r_norm);
        }
        for i in 0..u_new.len() {
            self.trial[i] = u_new[i] + self.delta[i];
        }
        let trial = std::mem::take(&mut self.trial);
        let evaluated = self.residual_by(system, equation, &trial, true, Pass::Near);
        self.trial = trial;
        evaluated?;
        let before = self.potential(system, equation, u_new, self.residual_energy)?;
        let after = self.potential(system, equation, &self.trial, self.trial_energy)?;
        // Both measures must fall: near the solution Φ's round-off can exceed its change (see
        // `Backtracking`), and a move that lowers Φ there by noise alone may raise ‖r‖. A NaN
        // (no decrease known) keeps the iterate too.
        let relaxed_norm = norm(&self.trial_residual);
        let lower = |a: f64, b: f64| a.partial_cmp(&b) == Some(std::cmp::Ordering::Less);
        if !(lower(after, before) && lower(relaxed_norm, r_norm)) {
            return Ok(r_norm);
        }
        u_new.copy_from_slice(&self.trial);
        self.force.note_iterate(u_new);
        std::mem::swap(&mut self.residual, &mut self.trial_residual);
        std::mem::swap(&mut self.residual_energy, &mut self.trial_energy);
        Ok(relaxed_norm)
    }

    /// J₀'s node blocks for `scales` (mass scale, damping stiffness) unless kept already.
    fn ensure_rest_blocks(&mut self, system: &LinearSystem, scales: (f64, f64)) {
        if self.rest_blocks.scales == Some(scales) {
            return;
        }
        let free = self.force.free_dofs();
        let mut nodes = vec![None; self.force.node_count()];
        for g in node_groups(free) {
            if g.count < 3 {
                continue;
            }
            let mass = match system.mass() {
                Mass::Lumped(m) => Matrix3::from_diagonal(&Vector3::new(
                    m[g.first],
                    m[g.first + 1],
                    m[g.first + 2],
                )),
                Mass::Consistent(m) => block(m, g),
            };
            let stiffness = block(system.stiffness(), g);
            nodes[free[g.first] / 3] = Some((g, scales.0 * mass + (1.0 + scales.1) * stiffness));
        }
        self.rest_blocks = RestBlocks {
            scales: Some(scales),
            nodes,
        };
    }
}
