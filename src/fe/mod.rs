//! The finite element room: what a tet is made of and how it becomes matrices — the material
//! (E, ν, ρ: [`material`]) and a material per tet ([`materials`]), the element seam and its
//! 4- and 10-node tets ([`element`]), quadrature rules ([`quadrature`]), per-tet quality and
//! the mesh's warnings ([`quality`]: it asks the element seam, so it is here and not in
//! `mesh`), and the global stiffness and masses refilled on a pattern built once
//! ([`assembly`]), and the displacement elements' measured volumetric locking ([`locking`]).

pub mod assembly;
pub mod element;
pub mod locking;
pub mod material;
pub mod materials;
pub mod quadrature;
pub mod quality;
