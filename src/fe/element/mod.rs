//! Elements: what one tet computes from its rest shape — shape-function gradients, the
//! linear-elastic stiffness, masses and consistent loads.
//!
//! An element type is one file here implementing [`ElementType`] (and, for a new node layout,
//! [`CellType`]); assembly, constraints, loads and outputs take it as a
//! type parameter:
//! - `tet4`: the linear 4-node tet ([`Tet4`], its rest data [`Tet`]), constant strain;
//! - [`tet10`]: the quadratic 10-node tet ([`Tet10`]), linear strain when straight-sided,
//!   isoparametric when curved ([`isoparametric`]: its geometry map);
//! - [`taylor_hood`]: the mixed P2–P1 tet (10-node displacement, corner pressure) for nearly
//!   incompressible materials;
//! - [`stabilized_p1`]: the mixed stabilized P1–P1 tet (4-node displacement and pressure);
//! - the mixed elements' hyperelastic states, one model per file:
//!   [`taylor_hood_neo_hookean`], [`stabilized_p1_neo_hookean`], [`taylor_hood_corotational`],
//!   [`stabilized_p1_corotational`];
//! - [`mixed_element`]: what the mixed solve needs of either ([`MixedElement`]).

mod element_type;
pub mod isoparametric;
pub mod mixed_element;
pub mod pointwise;
pub mod stabilized_p1;
pub mod stabilized_p1_corotational;
pub mod stabilized_p1_neo_hookean;
pub mod taylor_hood;
pub mod taylor_hood_corotational;
pub mod taylor_hood_neo_hookean;
pub mod tet10;
mod tet4;

pub use crate::mesh::{CellType, Tet4};
pub use element_type::{ElementType, Weights};
pub use mixed_element::MixedElement;
pub use pointwise::PointwiseElement;
pub use tet4::{
    FACES, Matrix6x12, Matrix12, Tet, Vector12, rest_shape_matrix, shape_quality, signed_volume,
    von_mises,
};
pub use tet10::Tet10;
