//! Implicit dynamics of the linear mixed body, on either mixed element ([`MixedElement`]:
//! Taylor–Hood P2–P1 on 10-node tets, the stabilized P1–P1 on 4-node tets): backward Euler and
//! Newmark (average acceleration) on the displacement, with the pressure, which has no inertia,
//! solved with it at every step.
//!
//! Both methods write the step's end as one saddle point in (u⁺, p⁺),
//!
//! ```text
//!   ⎡ c·M + K_dev   −Bᵀ ⎤ ⎡u⁺⎤   ⎡ f + M·(c·u + d·v + e·a) ⎤
//!   ⎣ −B            −C  ⎦ ⎣p⁺⎦ = ⎣ B_c·u_c                 ⎦
//! ```
//!
//! on the free DOFs (u_c the fixed prescribed displacements, whose K_dev,fc·u_c moves to the
//! right; C the element's pressure block, M_p/κ for Taylor–Hood and M_p/κ + (1/μ)(M_p − M_Π)
//! for P1–P1), with mass-proportional damping α·M:
//!
//! - backward Euler: c = 1/dt² + α/dt, d = 1/dt, e = 0; v⁺ = (u⁺ − u)/dt, a⁺ = (v⁺ − v)/dt;
//! - Newmark (β = ¼, γ = ½): c = 4/dt² + 2α/dt, d = 4/dt + α, e = 1;
//!   a⁺ = 4/dt²·(u⁺ − u) − 4/dt·v − a, v⁺ = v + dt/2·(a + a⁺).
//!
//! Eliminating p⁺ gives exactly the displacement methods on K_eff = K_dev + BᵀC⁻¹B
//! ([`MixedOperator`]), so Newmark conserves ½vᵀMv + ½uᵀK_eff·u − fᵀu of the undamped body to
//! round-off, computed here from u and p as ½vᵀMv + ½uᵀK_dev·u + ½pᵀC·p − fᵀu. The
//! matrix is factored once for the fixed dt by the quasi-definite LDLᵀ (the mass makes its
//! first block definite, so no support is needed), then each step is one solve plus the
//! static solve's iterative refinement. Stiffness-proportional damping (β·K would need β·K_eff,
//! whose pressure part is not a sparse matrix) and the explicit method (the pressure has no
//! inertia to step explicitly) are refused by name.

use crate::analysis::dynamics::{Method, Rayleigh, check_time_step};
use crate::analysis::mixed_operator::MixedOperator;
use crate::analysis::statics::RESIDUAL_LIMIT;
use crate::base::error::{Error, Result};
use crate::bc::constraints::Constraints;
use crate::bc::loads::Loads;
use crate::fe::element::{MixedElement, Tet10};
use crate::fe::materials::TetMaterials;
use crate::linalg::QuasiDefiniteLdlt;
use crate::linsolve::SparseCholesky;
use crate::mesh::TetMesh;
use crate::ordering::FillOrdering;
use crate::sparse::CscMatrix;

/// Refinement steps per solve, as the static mixed solve.
const MAX_REFINEMENTS: usize = 3;

/// The energies of a mixed dynamic state (energy units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MixedEnergy {
    /// ½·vᵀM·v.
    pub kinetic: f64,
    /// ½·uᵀK_dev·u + ½·pᵀC·p (C the element's pressure block).
    pub elastic: f64,
    /// −fᵀu, the potential of the constant loads.
    pub load_potential: f64,
}

impl MixedEnergy {
    /// kinetic + elastic + load potential.
    pub fn total(&self) -> f64 {
        self.kinetic + self.elastic + self.load_potential
    }
}

/// A linear mixed body on element `E` (10-node Taylor–Hood by default, or the 4-node
/// stabilized P1–P1) stepped in time with a fixed dt (see the [module](self) docs).
pub struct MixedTransient<E: MixedElement = Tet10> {
    operator: MixedOperator<E>,
    method: Method,
    dt: f64,
    alpha: f64,
    system: CscMatrix,
    ldlt: QuasiDefiniteLdlt,
    /// f_f − K_dev,fc·u_c (force units).
    load: Vec<f64>,
    /// fᵀ on every DOF, for the load potential.
    full_load: Vec<f64>,
    /// B·u_c (the pressure rows' right side).
    pressure_rhs: Vec<f64>,
    u: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    /// Corner pressures (Pa).
    p: Vec<f64>,
    time: f64,
    steps: usize,
}

// By hand: a derive would bound E, not the operator (whose couplings are E's).
impl<E: MixedElement> std::fmt::Debug for MixedTransient<E>
where
    MixedOperator<E>: std::fmt::Debug,
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MixedTransient")
            .field("operator", &self.operator)
            .field("method", &self.method)
            .field("dt", &self.dt)
            .field("alpha", &self.alpha)
            .field("system", &self.system)
            .field("ldlt", &self.ldlt)
            .field("load", &self.load)
            .field("full_load", &self.full_load)
            .field("pressure_rhs", &self.pressure_rhs)
            .field("u", &self.u)
            .field("v", &self.v)
            .field("a", &self.a)
            .field("p", &self.p)
            .field("time", &self.time)
            .field("steps", &self.steps)
            .finish()
    }
}

impl<E: MixedElement> MixedTransient<E> {
    /// The body of `mesh` with `materials` (ν < 0.5), `constraints` (fixed in time; none is
    /// needed), constant `loads` (gravity included), stepped by `method` (backward Euler or
    /// Newmark) with time step `dt` and `damping` (mass-proportional only: β must be 0). It
    /// starts at rest in the undeformed state ([`start`](Self::start) sets another).
    pub fn new(
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
        loads: &Loads,
        (method, dt, damping): (Method, f64, Rayleigh),
    ) -> Result<Self> {
        let dt = check_time_step(dt)?;
        let (c, _, _) = coefficients::<E>(method, dt, damping.alpha)?;
        if damping.beta != 0.0 {
            return Err(Error::invalid_parameter(
                "formulation mixed with damping beta",
                damping.beta,
                "the mixed element takes mass-proportional damping (alpha) only: β·K would \
                 need the pressure's condensed stiffness, which is not sparse; set beta = 0",
            ));
        }
        Error::check_len("loads", mesh.dof_count(), loads.as_slice().len())?;
        let operator = MixedOperator::new(mesh, materials, constraints, false)?;
        let system = operator.shifted(c);
        let dofs = operator.dofs();
        let mut ldlt =
            QuasiDefiniteLdlt::analyze(&system, dofs.free_count(), FillOrdering::NestedDissection)?;
        ldlt.factorize(&system)?;
        let coupled = operator.deviatoric().mul(dofs.prescribed())?;
        let full: Vec<f64> = loads
            .as_slice()
            .iter()
            .zip(&coupled)
            .map(|(f, k)| f - k)
            .collect();
        let load = dofs.restrict(&full)?;
        let pressure_rhs = operator.divergence(dofs.prescribed())?;
        let n = dofs.free_count();
        let mut transient = MixedTransient {
            method,
            dt,
            alpha: damping.alpha,
            system,
            ldlt,
            load,
            full_load: loads.as_slice().to_vec(),
            pressure_rhs,
            u: vec![0.0; n],
            v: vec![0.0; n],
            a: vec![0.0; n],
            p: Vec::new(),
            time: 0.0,
            steps: 0,
            operator,
        };
        transient.start(vec![0.0; n], vec![0.0; n])?;
        Ok(transient)
    }

    /// Sets the state at time 0: free displacement `u` and velocity `v` (length, length/time);
    /// the pressure is the one u implies and the acceleration solves the equation of motion,
    /// M·a = f − K_dev·u + Bᵀp.
    pub fn start(&mut self, u: Vec<f64>, v: Vec<f64>) -> Result<()> {
        let n = self.operator.dofs().free_count();
        Error::check_len("displacement", n, u.len())?;
        Error::check_len("velocity", n, v.len())?;
        let full = self.operator.dofs().expand(&u)?;
        self.p = self.operator.implied_pressure(&full)?;
        let elastic = self.operator.deviatoric().mul(&full)?;
        let pressure_force = self.operator.pressure_force(&self.p)?;
        let mut a: Vec<f64> = self
            .operator
            .dofs()
            .free_dofs()
            .iter()
            .zip(self.operator.dofs().restrict(self.full_load.as_slice())?)
            .map(|(&dof, f)| f - elastic[dof] + pressure_force[dof])
            .collect();
        let mass = self.operator.mass();
        let mut cholesky = SparseCholesky::analyze(mass)?;
        cholesky.factorize(mass)?;
        cholesky.solve_in_place(&mut a)?;
        (self.u, self.v, self.a) = (u, v, a);
        (self.time, self.steps) = (0.0, 0);
        Ok(())
    }

    /// Advances one step of dt.
    pub fn step(&mut self) -> Result<()> {
        let (c, d, e) = coefficients::<E>(self.method, self.dt, self.alpha)?;
        let combined: Vec<f64> = (0..self.u.len())
            .map(|i| c * self.u[i] + d * self.v[i] + e * self.a[i])
            .collect();
        let inertia = self.operator.mass().mul(&combined)?;
        let mut rhs: Vec<f64> = self.load.iter().zip(&inertia).map(|(f, m)| f + m).collect();
        rhs.extend_from_slice(&self.pressure_rhs);
        let mut x = self.solve(&rhs)?;
        let p = x.split_off(self.u.len());
        let dt = self.dt;
        let (u, v, a) = (&self.u, &self.v, &self.a);
        let (v_new, a_new): (Vec<f64>, Vec<f64>) = match self.method {
            Method::Newmark => (0..u.len())
                .map(|i| {
                    let acc = 4.0 / (dt * dt) * (x[i] - u[i]) - 4.0 / dt * v[i] - a[i];
                    (v[i] + 0.5 * dt * (a[i] + acc), acc)
                })
                .unzip(),
            _ => (0..u.len())
                .map(|i| {
                    let vel = (x[i] - u[i]) / dt;
                    (vel, (vel - v[i]) / dt)
                })
                .unzip(),
        };
        (self.u, self.v, self.a, self.p) = (x, v_new, a_new, p);
        self.time += dt;
        self.steps += 1;
        Ok(())
    }

    /// x = A(c)⁻¹·rhs, refined as the static mixed solve ([`RESIDUAL_LIMIT`]).
    fn solve(&mut self, rhs: &[f64]) -> Result<Vec<f64>> {
        let mut x = rhs.to_vec();
        self.ldlt.solve_in_place(&mut x)?;
        let mut residual = relative_residual(&self.system, &x, rhs)?;
        let mut refinements = 0;
        while residual > RESIDUAL_LIMIT && refinements < MAX_REFINEMENTS {
            refinements += 1;
            let product = self.system.mul(&x)?;
            let mut correction: Vec<f64> = rhs.iter().zip(&product).map(|(r, a)| r - a).collect();
            self.ldlt.solve_in_place(&mut correction)?;
            let refined: Vec<f64> = x.iter().zip(&correction).map(|(u, d)| u + d).collect();
            let refined_residual = relative_residual(&self.system, &refined, rhs)?;
            if refined_residual >= residual || refined_residual.is_nan() {
                break;
            }
            (x, residual) = (refined, refined_residual);
        }
        if residual > RESIDUAL_LIMIT || !residual.is_finite() {
            return Err(Error::InaccurateSolve {
                relative_residual: residual,
                limit: RESIDUAL_LIMIT,
                refinements,
                cause: format!(
                    "the mixed step at t = {:e}: a time step or material scales of wildly \
                     different sizes",
                    self.time + self.dt
                ),
            });
        }
        Ok(x)
    }

    /// The energies of the current state (see [`MixedEnergy`]).
    pub fn energy(&self) -> Result<MixedEnergy> {
        let full = self.displacement()?;
        Ok(MixedEnergy {
            kinetic: 0.5 * self.operator.mass().quadratic_form(&self.v)?,
            elastic: self.operator.elastic_energy(&full, &self.p)?,
            load_potential: -self
                .full_load
                .iter()
                .zip(&full)
                .map(|(f, u)| f * u)
                .sum::<f64>(),
        })
    }

    /// Displacement of every DOF (length), prescribed values included.
    pub fn displacement(&self) -> Result<Vec<f64>> {
        self.operator.dofs().expand(&self.u)
    }

    /// Velocity of the free DOFs (length/time).
    pub fn velocity(&self) -> &[f64] {
        &self.v
    }

    /// The pressure at every node (Pa, positive in compression), linear along edges.
    pub fn pressure(&self) -> Vec<f64> {
        self.operator.nodal_pressure(&self.p)
    }

    /// The corner pressures (Pa), one per [`PressureNodes`](crate::fe::element::taylor_hood::PressureNodes) unknown.
    pub fn corner_pressure(&self) -> &[f64] {
        &self.p
    }

    /// Time reached (time units).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Steps taken.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// The assembled body.
    pub fn operator(&self) -> &MixedOperator<E> {
        &self.operator
    }

    /// Number of stored values of the LDLᵀ factor.
    pub fn factor_len(&self) -> usize {
        self.ldlt.factor_len()
    }
}

/// (c, d, e) of the step's right side (see the [module](self) docs); the explicit method is
/// refused by name, with element `E`'s.
fn coefficients<E: MixedElement>(method: Method, dt: f64, alpha: f64) -> Result<(f64, f64, f64)> {
    match method {
        Method::BackwardEuler => Ok((1.0 / (dt * dt) + alpha / dt, 1.0 / dt, 0.0)),
        Method::Newmark => Ok((4.0 / (dt * dt) + 2.0 * alpha / dt, 4.0 / dt + alpha, 1.0)),
        Method::Explicit => Err(Error::invalid_parameter(
            "formulation mixed with method",
            "explicit",
            format!(
                "the mixed ({}) element steps implicitly only (its pressure has no inertia to \
                 step explicitly); use backward_euler or newmark",
                E::MIXED_NAME
            ),
        )),
    }
}

/// ‖A·x − r‖ / ‖r‖ (‖A·x − r‖ when r = 0).
fn relative_residual(system: &CscMatrix, x: &[f64], rhs: &[f64]) -> Result<f64> {
    let product = system.mul(x)?;
    let residual: f64 = product
        .iter()
        .zip(rhs)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    let scale: f64 = rhs.iter().map(|r| r * r).sum::<f64>().sqrt();
    Ok(if scale > 0.0 {
        residual / scale
    } else {
        residual
    })
}
