//! The rule of what may be combined in one run, said once in the library: a force model, an
//! element order, an analysis, loads that follow amplitudes, supports that move, obstacles with
//! friction, material regions, body–body contact, the element formulation. Every combination
//! the library can compute is allowed; the refusals are the physics' own and what the library
//! does not compute yet, each an [`Error::InvalidParameter`] naming the pair:
//!
//! - a modal analysis with a nonlinear model: K·φ = ω²·M·φ is the eigenproblem of the linear
//!   model about the rest state (every model's tangent at rest is the linear K);
//! - a modal analysis with obstacles: contact is a one-sided, nonlinear constraint, with no
//!   eigenproblem about the rest state;
//! - body–body and self-contact (`surface_contact`) with a modal analysis: the barrier is a
//!   one-sided, nonlinear contact with no eigenproblem about the rest state. Static, backward
//!   Euler and Newmark carry it in their Newton solves with the collision-free line search
//!   (Newmark with the contact force at the step's end, as for obstacles); the explicit method
//!   with the barrier's force and its step bound
//!   ([`crate::analysis::dynamics::surface_step_bound`]), stopping by name at a step that
//!   would leave that bound's range or cross;
//! - the mixed displacement–pressure formulation ([`Formulation::Mixed`]) with what it does not
//!   compute: the explicit method (the pressure has no inertia), a model other than the
//!   linear, the Neo-Hookean and the corotational one, obstacles (but in the Neo-Hookean and
//!   corotational backward Euler), and with a nonlinear model supports that move (its load steps
//!   scale prescribed values by λ); in the implicit dynamic and the modal analyses, a model
//!   other than the linear one (but the Neo-Hookean and corotational ones in backward Euler),
//!   body–body contact, moving supports and loads that follow amplitudes (either mixed element
//!   runs them);
//! - a force model per material region (`region_models`) with a modal analysis where a region
//!   is nonlinear, and with the mixed formulation at all (it solves one model).
//!
//! Combinations that run but whose behaviour the user should know of give a [`Warning`]:
//! Newmark (average acceleration) with obstacles or with body–body contact loses energy at
//! each impact (its contact force taken at the step's end).

use crate::analysis::dynamics::Method;
use crate::base::error::{Error, Result};
use crate::base::warning::Warning;
use crate::model::ModelKind;

/// What Newmark with body–body contact was measured to do (`tests/core/surface_dynamics.rs`).
const SURFACE_NEWMARK_MEASURED: &str = "average acceleration takes the surface barrier's \
     force at the step's end, so it adds no energy where it is convex along the step, but each \
     impact loses some: two rubber blocks meeting head on at 2 m/s part \
     at 0.72 of their approach speed (dt = 1 ms, 24 % of the energy gone)";

/// The analysis of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Analysis {
    /// Equilibrium under the loads (in load steps for a nonlinear model or obstacles).
    Static,
    /// Steps in time with the integrator `Method`.
    Transient(Method),
    /// The lowest natural modes about the rest state.
    Modal,
}

impl Analysis {
    /// The name errors and warnings use: `static`, `dynamic (backward-euler)`, …, `modal`.
    pub fn name(self) -> String {
        match self {
            Analysis::Static => "static".into(),
            Analysis::Transient(method) => format!("dynamic ({})", method_name(method)),
            Analysis::Modal => "modal".into(),
        }
    }
}

/// The name of an integrator as scenes write it.
fn method_name(method: Method) -> &'static str {
    match method {
        Method::BackwardEuler => "backward_euler",
        Method::Newmark => "newmark",
        Method::Explicit => "explicit",
    }
}

/// How the elasticity is discretized.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Formulation {
    /// Displacement only (the default): every element order, analysis and model.
    #[default]
    Displacement,
    /// Displacement and pressure (no volumetric locking as ν → 0.5), static, with the linear
    /// model ([`crate::MixedStaticSolver`]) or the Neo-Hookean or corotational one
    /// ([`crate::analysis::mixed_nonlinear`]): Taylor–Hood P2–P1 on 10-node tets, the
    /// stabilized P1–P1 on 4-node tets.
    Mixed,
}

/// One run's choices, checked together by [`check`](Self::check).
#[derive(Debug, Clone, PartialEq)]
pub struct Combination {
    /// The force model (of every material region `region_models` does not name).
    pub model: ModelKind,
    /// The material regions (by name) whose force model differs from `model`, with theirs
    /// (empty: one model for all; a body takes its model through its region).
    pub region_models: Vec<(String, ModelKind)>,
    /// The element order: 1 (4-node tets) or 2 (10-node tets).
    pub order: usize,
    /// The analysis.
    pub analysis: Analysis,
    /// Some load (or gravity) follows an amplitude in time.
    pub time_varying_loads: bool,
    /// Some support moves (a prescribed displacement that follows time or a motion field).
    pub moving_supports: bool,
    /// Rigid obstacles the body's boundary nodes may touch.
    pub obstacles: bool,
    /// Some obstacle has friction (μ > 0); meaningful with `obstacles` only.
    pub friction: bool,
    /// More than one material region.
    pub regions: bool,
    /// The element formulation.
    pub formulation: Formulation,
    /// Body–body and self-contact on the boundary surface (several bodies, or one that may
    /// fold onto itself).
    pub surface_contact: bool,
    /// Friction between the surfaces (μ > 0); meaningful with `surface_contact` only.
    pub surface_friction: bool,
}

impl Default for Combination {
    /// The linear model on 4-node tets, static, constant loads, fixed supports, no obstacles,
    /// one material.
    fn default() -> Self {
        Combination {
            model: ModelKind::Linear,
            region_models: Vec::new(),
            order: 1,
            analysis: Analysis::Static,
            time_varying_loads: false,
            moving_supports: false,
            obstacles: false,
            friction: false,
            regions: false,
            formulation: Formulation::Displacement,
            surface_contact: false,
            surface_friction: false,
        }
    }
}

impl Combination {
    /// The surface-contact rules: no modal analysis; friction between surfaces only where it
    /// is lagged, at the steps of the implicit dynamic methods (a static solve and the explicit
    /// step would ignore μ, so they refuse it rather than drop it silently).
    fn check_surface(&self) -> Result<()> {
        if self.surface_contact && self.analysis == Analysis::Modal {
            return Err(Error::invalid_parameter(
                format!("surface_contact with analysis {}", self.analysis.name()),
                "surface contact",
                "a modal analysis has no contact (it is linear about the rest state); \
                 body–body and self-contact runs in a static or a dynamic analysis",
            ));
        }
        let lagged = matches!(
            self.analysis,
            Analysis::Transient(Method::BackwardEuler | Method::Newmark)
        );
        if self.surface_contact && self.surface_friction && !lagged {
            return Err(Error::invalid_parameter(
                format!(
                    "surface_contact friction with analysis {}",
                    self.analysis.name()
                ),
                "friction > 0",
                "friction between bodies is lagged at the steps of the implicit dynamic \
                 methods (backward_euler, newmark) only; a static solve or an explicit step \
                 would ignore it: set it to 0 or use one of those methods",
            ));
        }
        Ok(())
    }

    /// Checks the combination: `Ok` with the warnings of combinations that run but behave in a
    /// way the user should know of, or [`Error::InvalidParameter`] naming the pair the physics
    /// cannot compute (see the [module](self) docs), or an order other than 1 or 2.
    pub fn check(&self) -> Result<Vec<Warning>> {
        if !matches!(self.order, 1 | 2) {
            return Err(Error::invalid_parameter(
                "element order",
                self.order,
                "must be 1 (4-node tets) or 2 (10-node tets)",
            ));
        }
        self.check_surface()?;
        self.check_region_models()?;
        if self.analysis == Analysis::Modal {
            if self.model != ModelKind::Linear {
                return Err(Error::invalid_parameter(
                    "model with analysis modal",
                    self.model.name(),
                    "modal analysis is linear only (K·φ = ω²·M·φ with the linear model's K, \
                     every model's tangent at rest); use the linear model",
                ));
            }
            if self.obstacles {
                return Err(Error::invalid_parameter(
                    "obstacles with analysis modal",
                    "obstacles",
                    "a modal analysis has no contact (it is linear about the rest state); \
                     remove the obstacles",
                ));
            }
        }
        if self.formulation == Formulation::Mixed {
            self.check_mixed()?;
        }
        let mut warnings = Vec::new();
        if self.obstacles && self.analysis == Analysis::Transient(Method::Newmark) {
            warnings.push(Warning::ImpactLosesEnergy {
                method: method_name(Method::Newmark),
                contact: "obstacles",
                measured: "average acceleration takes the contact force at the step's end, so \
                           contact never adds energy, but each impact removes some at every step \
                           size: a frictionless rubber block dropped on the ground rebounds to \
                           about 0.56 of its height at 0.02–1× the critical step"
                    .into(),
            });
        }
        if self.surface_contact && self.analysis == Analysis::Transient(Method::Newmark) {
            warnings.push(Warning::ImpactLosesEnergy {
                method: method_name(Method::Newmark),
                contact: "body–body contact",
                measured: SURFACE_NEWMARK_MEASURED.into(),
            });
        }
        Ok(warnings)
    }

    /// The rules of a model per region: a modal analysis refuses a nonlinear one (as it does
    /// the run's `model`), the mixed formulation a mix (its saddle-point solve takes one model),
    /// each naming the region and its model.
    fn check_region_models(&self) -> Result<()> {
        let Some((name, kind)) = self.region_models.first() else {
            return Ok(());
        };
        let nonlinear = self.region_models.iter().find(|(_, k)| !k.is_linear());
        if self.analysis == Analysis::Modal
            && let Some((name, kind)) = nonlinear
        {
            return Err(Error::invalid_parameter(
                format!("model of {name} with analysis modal"),
                kind.name(),
                "modal analysis is linear only (K·φ = ω²·M·φ with the linear model's K, \
                 every model's tangent at rest); give every region the linear model",
            ));
        }
        if self.formulation == Formulation::Mixed {
            return Err(Error::invalid_parameter(
                format!("formulation mixed with the model of {name}"),
                format!("{} beside {}", kind.name(), self.model.name()),
                format!(
                    "the mixed element ({}) solves one model for every region; give every \
                     region the same model",
                    mixed_element_name(self.order)
                ),
            ));
        }
        Ok(())
    }

    /// The refusals of [`Formulation::Mixed`] (see the [module](self) docs), each naming
    /// `formulation mixed with <the other key>`.
    fn check_mixed(&self) -> Result<()> {
        let refuse = |what: &str, value: String, why: &str| {
            Err(Error::invalid_parameter(
                format!("formulation mixed with {what}"),
                value,
                format!(
                    "the mixed element ({}) {why}",
                    mixed_element_name(self.order)
                ),
            ))
        };
        if self.analysis == Analysis::Transient(Method::Explicit) {
            return refuse(
                "analysis",
                self.analysis.name(),
                "steps implicitly only (its pressure has no inertia to step explicitly); use \
                 backward_euler or newmark",
            );
        }
        if self.analysis != Analysis::Static {
            self.check_mixed_dynamics()?;
        }
        if !matches!(
            self.model,
            ModelKind::Linear | ModelKind::NeoHookean | ModelKind::Corotational
        ) {
            return refuse(
                "model",
                self.model.name().to_string(),
                "has the linear, the Neo-Hookean and the corotational model only",
            );
        }
        // Obstacles meet the hyperelastic backward Euler only
        // (crate::analysis::mixed_nonlinear_dynamics: its barrier is in the displacements
        // alone, whatever the law), with or without friction.
        let euler = self.analysis == Analysis::Transient(Method::BackwardEuler);
        let hyperelastic = matches!(self.model, ModelKind::NeoHookean | ModelKind::Corotational);
        if self.obstacles && !(euler && hyperelastic) {
            return refuse(
                "obstacles",
                "obstacles".into(),
                "meets rigid obstacles in the Neo-Hookean and corotational backward Euler only \
                 (dynamic, method backward_euler, model neo_hookean or corotational)",
            );
        }
        if self.moving_supports && self.model != ModelKind::Linear {
            let name = match self.model {
                ModelKind::NeoHookean => "Neo-Hookean",
                other => other.name(),
            };
            let why = format!(
                "with the {name} model scales prescribed displacements by the load factor (a \
                 chord, not a rotation); hold the supports fixed"
            );
            return refuse("moving supports", "moving supports".into(), &why);
        }
        Ok(())
    }

    /// The refusals of [`Formulation::Mixed`] in the implicit dynamic and the modal analyses
    /// ([`crate::analysis::mixed_dynamics`], [`crate::analysis::mixed_modal`],
    /// [`crate::analysis::mixed_nonlinear_dynamics`]): the linear model, and the Neo-Hookean
    /// and corotational ones in backward Euler, on either mixed element, with fixed supports
    /// and constant loads, without surface contact.
    fn check_mixed_dynamics(&self) -> Result<()> {
        let refuse = |what: &str, value: String, why: &str| {
            Err(Error::invalid_parameter(
                format!("formulation mixed with {what}"),
                value,
                format!(
                    "the mixed ({}) element in a {} analysis {why}",
                    mixed_element_name(self.order),
                    self.analysis.name()
                ),
            ))
        };
        // Both mixed elements run both models here (MixedTransient, lowest_mixed_modes and
        // MixedNonlinearEuler are generic over the element): no order to refuse.
        let euler = self.analysis == Analysis::Transient(Method::BackwardEuler);
        let hyperelastic = matches!(self.model, ModelKind::NeoHookean | ModelKind::Corotational);
        if hyperelastic && !euler {
            return refuse(
                "model",
                self.model.name().to_string(),
                "has the Neo-Hookean and corotational models in backward Euler only (Newmark \
                 and the modes are the linear model's); use method backward_euler or the \
                 linear model",
            );
        }
        if !(hyperelastic || self.model == ModelKind::Linear) {
            return refuse(
                "model",
                self.model.name().to_string(),
                "has the linear model (and the Neo-Hookean and corotational ones in backward \
                 Euler) only",
            );
        }
        if self.surface_contact {
            return refuse(
                "surface_contact",
                "surface contact".into(),
                "has no contact",
            );
        }
        if self.moving_supports {
            return refuse(
                "moving supports",
                "moving supports".into(),
                "holds its supports fixed",
            );
        }
        if self.time_varying_loads {
            return refuse(
                "loads that follow an amplitude",
                "time-varying loads".into(),
                "takes constant loads and gravity only",
            );
        }
        Ok(())
    }
}

/// The mixed element of an element order: Taylor–Hood P2–P1 on 10-node tets, the stabilized
/// P1–P1 on 4-node ones.
fn mixed_element_name(order: usize) -> &'static str {
    match order {
        1 => "stabilized P1–P1",
        _ => "Taylor–Hood P2–P1",
    }
}
