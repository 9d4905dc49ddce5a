//! Closed-form tip deflections of a cantilever with a solid rectangular section, for checking
//! the finite element answers.
//!
//! Beam along x of length L, section width W (along y) and height H (along z), bending about y:
//! I = W·H³/12, A = W·H. Timoshenko's shear term uses Cowper's coefficient for a rectangle,
//! κ = 10(1+ν)/(12+11ν).

use crate::material::Material;

/// Geometry and material of a clamped–free rectangular beam.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RectangularCantilever {
    /// Length L (along x).
    pub length: f64,
    /// Width W (along y).
    pub width: f64,
    /// Height H (along z, the bending direction).
    pub height: f64,
    /// The material (E and ν are used).
    pub material: Material,
}

impl RectangularCantilever {
    /// Second moment of area about the y axis, I = W·H³/12 (length⁴).
    pub fn second_moment(&self) -> f64 {
        self.width * self.height.powi(3) / 12.0
    }

    /// Cross-section area A = W·H.
    pub fn area(&self) -> f64 {
        self.width * self.height
    }

    /// Cowper's shear coefficient for a rectangle, κ = 10(1+ν)/(12+11ν).
    pub fn shear_coefficient(&self) -> f64 {
        let nu = self.material.poisson_ratio();
        10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)
    }

    /// Euler–Bernoulli tip deflection under an end load P: P·L³/(3EI) (length units, in the
    /// direction of P).
    pub fn euler_bernoulli_end_load(&self, load: f64) -> f64 {
        load * self.length.powi(3) / (3.0 * self.material.youngs_modulus() * self.second_moment())
    }

    /// Timoshenko tip deflection under an end load P: P·L³/(3EI) + P·L/(κ·G·A).
    pub fn timoshenko_end_load(&self, load: f64) -> f64 {
        self.euler_bernoulli_end_load(load) + load * self.length / self.shear_stiffness()
    }

    /// Euler–Bernoulli tip deflection under a uniform line load q (force/length): q·L⁴/(8EI).
    pub fn euler_bernoulli_uniform_load(&self, line_load: f64) -> f64 {
        line_load * self.length.powi(4)
            / (8.0 * self.material.youngs_modulus() * self.second_moment())
    }

    /// Timoshenko tip deflection under a uniform line load q: q·L⁴/(8EI) + q·L²/(2κGA).
    pub fn timoshenko_uniform_load(&self, line_load: f64) -> f64 {
        self.euler_bernoulli_uniform_load(line_load)
            + line_load * self.length.powi(2) / (2.0 * self.shear_stiffness())
    }

    fn shear_stiffness(&self) -> f64 {
        self.shear_coefficient() * self.material.shear_modulus() * self.area()
    }
}
