//! Isotropic linear elastic material: Young's modulus, Poisson's ratio, density.

use nalgebra::SMatrix;

use crate::base::error::{Error, Result};

/// 6×6 matrix acting on Voigt vectors `[xx, yy, zz, xy, yz, zx]`.
pub type Matrix6 = SMatrix<f64, 6, 6>;

/// An isotropic, homogeneous, linear elastic material.
///
/// Units are the caller's but must be consistent; in SI: `youngs_modulus` in Pa,
/// `poisson_ratio` dimensionless, `density` in kg/m³.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    youngs_modulus: f64,
    poisson_ratio: f64,
    density: f64,
}

impl Material {
    /// Validates and builds a material.
    ///
    /// Requirements: E > 0, −1 < ν < 0.5, ρ > 0, all finite. ν = 0.5 (incompressible) is
    /// excluded because λ = Eν/((1+ν)(1−2ν)) is infinite there; values close to it are accepted
    /// but lock volumetrically on linear tets.
    pub fn new(youngs_modulus: f64, poisson_ratio: f64, density: f64) -> Result<Self> {
        if !(youngs_modulus.is_finite() && youngs_modulus > 0.0) {
            return Err(Error::InvalidMaterial {
                field: "youngs_modulus",
                value: youngs_modulus,
                requirement: "must be finite and > 0",
            });
        }
        if poisson_ratio == 0.5 {
            // The incompressible limit itself: λ and κ are infinite, in every formulation; the
            // mixed one reaches ν as close to it as wanted without locking.
            return Err(Error::InvalidMaterial {
                field: "poisson_ratio",
                value: poisson_ratio,
                requirement: "must be below 0.5 (ν = 0.5 makes the bulk modulus infinite): for \
                              rubber use ν = 0.4999 with the mixed formulation (scene key \
                              [analysis] formulation = \"mixed\", on 4-node tets the \
                              stabilized P1–P1 element and on 10-node tets Taylor–Hood \
                              P2–P1; library: solve_static_mixed), which does not lock",
            });
        }
        if !(poisson_ratio.is_finite() && poisson_ratio > -1.0 && poisson_ratio < 0.5) {
            return Err(Error::InvalidMaterial {
                field: "poisson_ratio",
                value: poisson_ratio,
                requirement: "must be finite and in the open interval (-1, 0.5)",
            });
        }
        if !(density.is_finite() && density > 0.0) {
            return Err(Error::InvalidMaterial {
                field: "density",
                value: density,
                requirement: "must be finite and > 0",
            });
        }
        Ok(Material {
            youngs_modulus,
            poisson_ratio,
            density,
        })
    }

    /// Structural steel: E = 200 GPa, ν = 0.3, ρ = 7850 kg/m³ (SI).
    pub fn steel() -> Self {
        Material {
            youngs_modulus: 200e9,
            poisson_ratio: 0.3,
            density: 7850.0,
        }
    }

    /// Young's modulus E (Pa in SI).
    pub fn youngs_modulus(&self) -> f64 {
        self.youngs_modulus
    }

    /// Poisson's ratio ν (dimensionless).
    pub fn poisson_ratio(&self) -> f64 {
        self.poisson_ratio
    }

    /// Mass density ρ (kg/m³ in SI).
    pub fn density(&self) -> f64 {
        self.density
    }

    /// First Lamé parameter λ = Eν / ((1+ν)(1−2ν)).
    pub fn lame_lambda(&self) -> f64 {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    }

    /// Shear modulus μ = G = E / (2(1+ν)) (the second Lamé parameter).
    pub fn shear_modulus(&self) -> f64 {
        self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))
    }

    /// Bulk modulus K = E / (3(1−2ν)).
    pub fn bulk_modulus(&self) -> f64 {
        self.youngs_modulus / (3.0 * (1.0 - 2.0 * self.poisson_ratio))
    }

    /// P-wave (dilatational) speed c_p = √((λ + 2μ)/ρ), which sets the explicit critical time step.
    pub fn p_wave_speed(&self) -> f64 {
        ((self.lame_lambda() + 2.0 * self.shear_modulus()) / self.density).sqrt()
    }

    /// The lecture's constitutive matrix D, mapping the *tensor* strain
    /// `[ε_xx, ε_yy, ε_zz, ε_xy, ε_yz, ε_zx]` to the stress `[σ_xx, σ_yy, σ_zz, σ_xy, σ_yz, σ_zx]`:
    ///
    /// ```text
    ///              E          ⎡1−ν  ν   ν            ⎤
    /// D = ─────────────────── ⎢ ν  1−ν  ν            ⎥
    ///     (1+ν)(1−2ν)         ⎢ ν   ν  1−ν           ⎥
    ///                         ⎢            1−2ν      ⎥
    ///                         ⎢               1−2ν   ⎥
    ///                         ⎣                  1−2ν⎦
    /// ```
    ///
    /// The shear diagonal E(1−2ν)/((1+ν)(1−2ν)) = 2μ, so σ_xy = 2μ·ε_xy as Hooke's law requires.
    pub fn tensor_stiffness(&self) -> Matrix6 {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        let scale = e / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mut d = Matrix6::zeros();
        for i in 0..3 {
            for j in 0..3 {
                d[(i, j)] = scale * if i == j { 1.0 - nu } else { nu };
            }
            d[(i + 3, i + 3)] = scale * (1.0 - 2.0 * nu);
        }
        d
    }

    /// The constitutive matrix for *engineering* shear strains γ = 2ε (the usual FE convention,
    /// and what [`crate::fe::element::Tet::strain_displacement`] produces): the lecture's
    /// [`tensor_stiffness`](Self::tensor_stiffness) with the shear diagonal halved to μ.
    ///
    /// With it, the strain energy density is ½ γᵀ·D_eng·γ = ½ σ:ε, so Kₑ = V·Bᵀ·D_eng·B.
    pub fn engineering_stiffness(&self) -> Matrix6 {
        let mut d = self.tensor_stiffness();
        for i in 3..6 {
            d[(i, i)] *= 0.5;
        }
        d
    }
}

impl Material {
    /// Warnings about values that are valid but give poor answers on linear tets:
    /// [`Warning::NearlyIncompressible`](crate::base::warning::Warning::NearlyIncompressible) for
    /// ν > [`NEARLY_INCOMPRESSIBLE_POISSON`](crate::base::warning::NEARLY_INCOMPRESSIBLE_POISSON).
    pub fn warnings(&self) -> Vec<crate::base::warning::Warning> {
        if self.poisson_ratio() > crate::base::warning::NEARLY_INCOMPRESSIBLE_POISSON {
            let loss = |order| {
                crate::fe::locking::expected_locking_loss(self.poisson_ratio(), order)
                    .unwrap_or(f64::NAN)
            };
            vec![crate::base::warning::Warning::NearlyIncompressible {
                poisson_ratio: self.poisson_ratio(),
                expected_loss: [loss(1), loss(2)],
            }]
        } else {
            Vec::new()
        }
    }
}
