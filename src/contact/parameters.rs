//! The barrier's two scales: the activation distance d̂ and the stiffness κ.

use crate::base::error::{Error, Result};
use crate::mesh::{CellType, TetMesh};

/// The scales of the contact barrier E_c = κ·Σᵢ Aᵢ·Σ_o b(d_o(xᵢ)) (see [`super::Contact`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactParameters {
    /// d̂ (length): gaps below it are pushed open; every resting gap lies in (0, d̂).
    pub activation_distance: f64,
    /// κ (pressure per length, Pa/m): the contact pressure is p = −κ·b′(d). With an
    /// [`impact_fraction`](Self::impact_fraction) it is κ₀, the floor of the stiffness in force.
    pub stiffness: f64,
    /// f (dimensionless, 0 < f < 1), or `None` (the default: κ stays κ₀). With f, each
    /// contact node i gets its own barrier stiffness, set at an implicit step's start so that
    /// the barrier takes the node's impact kinetic energy at a gap of about f·d̂, where a time
    /// step can resolve the barrier's mode:
    ///
    /// κᵢ = max(κ₀, max_o mᵢ·v_n,ᵢ,ₒ²/(2·Aᵢ·b(f·d̂)))  (Pa/m)
    ///
    /// for a node outside d̂ of every obstacle at the step's start (v_n,ᵢ,ₒ > 0 its normal
    /// approach speed to obstacle o relative to the obstacle's mean velocity over the step,
    /// length/time; mᵢ its lumped mass, the largest row sum of M over its free DOFs; Aᵢ its
    /// area weight; b the barrier); a node within d̂ keeps its κᵢ. The barrier energy
    /// E_c = Σᵢ κᵢ·Aᵢ·Σ_o b(d_o(xᵢ)) is then conservative: a node's κᵢ changes only where its
    /// barrier holds no energy. Friction's normal force takes κᵢ too. See
    /// [`Contact::update_impact_stiffness`](super::Contact::update_impact_stiffness) and
    /// [`super::impact`].
    pub impact_fraction: Option<f64>,
}

/// d̂ as a fraction of the body's bounding-box diagonal (the default rule).
pub const ACTIVATION_FRACTION: f64 = 1e-3;

impl ContactParameters {
    /// The default for a body `mesh` of Young's modulus `youngs_modulus` (Pa):
    /// d̂ = 10⁻³ × the bounding-box diagonal, and κ = E/h with h the mean edge length of the
    /// boundary triangles — the barrier's pressure stiffness κ·b″ at d = d̂/2 (≈ 6.4·κ) is then
    /// a few times the stiffness E/h of the surface layer of elements, so the barrier neither
    /// dominates the Newton matrix nor lets the gap close to round-off.
    ///
    /// On 10-node tets h is that of the contact triangles ([`super::set::contact_faces`]:
    /// each face split at its mid-edge nodes), the spacing of the contact points.
    ///
    /// Errors: the modulus is not finite and > 0; the mesh's faces cannot be found.
    pub fn for_mesh<C: CellType>(mesh: &TetMesh<C>, youngs_modulus: f64) -> Result<Self> {
        if !(youngs_modulus.is_finite() && youngs_modulus > 0.0) {
            return Err(Error::invalid_parameter(
                "contact youngs_modulus",
                youngs_modulus,
                "must be finite and > 0",
            ));
        }
        let (min, max) = mesh.bounding_box();
        let faces = super::set::contact_faces(mesh)?;
        let nodes = mesh.nodes();
        let mut total = 0.0;
        for face in &faces {
            for k in 0..3 {
                total += (nodes[face.nodes[k]] - nodes[face.nodes[(k + 1) % 3]]).norm();
            }
        }
        let h = total / (3 * faces.len().max(1)) as f64;
        let parameters = ContactParameters {
            activation_distance: ACTIVATION_FRACTION * (max - min).norm(),
            stiffness: youngs_modulus / h,
            impact_fraction: None,
        };
        parameters.check()?;
        Ok(parameters)
    }

    /// The same scales with the impact-aware stiffness of [`impact_fraction`](Self::impact_fraction)
    /// at the fraction `fraction` of d̂ (e.g. 0.25). Errors: `fraction` not in (0, 1).
    pub fn with_impact_fraction(mut self, fraction: f64) -> Result<Self> {
        self.impact_fraction = Some(fraction);
        self.check()?;
        Ok(self)
    }

    /// [`Error::InvalidParameter`] unless both scales are finite and > 0 and the impact
    /// fraction, if any, is in (0, 1).
    pub fn check(&self) -> Result<()> {
        for (name, value) in [
            ("contact activation_distance", self.activation_distance),
            ("contact stiffness", self.stiffness),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(Error::invalid_parameter(
                    name,
                    value,
                    "must be finite and > 0",
                ));
            }
        }
        if let Some(f) = self.impact_fraction
            && !(f > 0.0 && f < 1.0)
        {
            return Err(Error::invalid_parameter(
                "contact impact_fraction",
                f,
                "must be a fraction of the activation distance in (0, 1), e.g. 0.25",
            ));
        }
        Ok(())
    }
}
