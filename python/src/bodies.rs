//! Several bodies for Python: `Mesh.bodies` places meshes by rigid motions into one mesh (the
//! library's [`tetfem::mesh::Bodies`]: rotation about the origin, then translation), keeping
//! each node's and tet's body; a Simulation's `self_contact` puts the library's surface barrier
//! ([`tetfem::contact::surface`]) between them and inside each. The physics and its defaults
//! are the library's ([`SurfaceBarrier::scaled_to`]); this module only converts.

use nalgebra::Vector3;
use pyo3::prelude::*;
use tetfem::contact::surface::{Surface, SurfaceBarrier};
use tetfem::fe::materials::MaterialMap;
use tetfem::mesh::{Bodies, CellType, Placement, TetMesh};

use crate::arrays;
use crate::cells::{AnyMesh, Cells, on_cells};
use crate::errors::{OrRaise, invalid};

/// Each body's rotation `(axis, degrees)`, or `None` for none, as Python gives them.
pub type Rotations<'py> = Option<Vec<Option<(Bound<'py, PyAny>, f64)>>>;

/// Which body each node and tet of a placed mesh belongs to (bodies numbered from 0 in the
/// order they were given).
#[derive(Debug, Clone)]
pub struct BodyIds {
    /// The body of each node.
    pub of_node: Vec<usize>,
    /// The body of each tet.
    pub of_tet: Vec<usize>,
}

/// The placement of body `i`: its rotation `(axis, degrees)` if given, then its translation (m).
fn placement(
    py: Python<'_>,
    i: usize,
    translation: Vector3<f64>,
    rotation: Option<&(Bound<'_, PyAny>, f64)>,
) -> PyResult<Placement> {
    let moved = Placement::translated(translation).or_raise(py)?;
    match rotation {
        None => Ok(moved),
        Some((axis, degrees)) => {
            let axis = arrays::vector3(py, axis, &format!("rotations[{i}] axis"))?;
            moved.rotated(axis, degrees.to_radians()).or_raise(py)
        }
    }
}

/// The meshes `meshes` (all of one order) placed into one: body i turned by `rotations[i]`
/// (`(axis, degrees)`, right-handed, about the origin; `None` for none) then moved by
/// `translations[i]` (m). Errors name the argument: counts that differ, meshes of two orders,
/// bodies that overlap (the library's message names both bodies and a pair of triangles).
pub fn place(
    py: Python<'_>,
    meshes: &[&AnyMesh],
    translations: Option<&Bound<'_, PyAny>>,
    rotations: Rotations<'_>,
) -> PyResult<(AnyMesh, BodyIds)> {
    let count = meshes.len();
    if count == 0 {
        return Err(invalid(py, "meshes", "[]", "must hold at least one Mesh"));
    }
    let translations = match translations {
        Some(t) => {
            let (values, rows) = arrays::floats(py, t, "translations", Some(3), false)?;
            if rows != count {
                let shape = format!("({rows}, 3)");
                let wanted = format!("must be ({count}, 3): one row per mesh");
                return Err(invalid(py, "translations.shape", shape, &wanted));
            }
            values
                .chunks_exact(3)
                .map(|t| Vector3::new(t[0], t[1], t[2]))
                .collect()
        }
        None => vec![Vector3::zeros(); count],
    };
    let rotations = rotations.unwrap_or_else(|| (0..count).map(|_| None).collect());
    if rotations.len() != count {
        let wanted = format!("must give one entry (or None) per mesh: {count}");
        return Err(invalid(py, "len(rotations)", rotations.len(), &wanted));
    }
    let mut placements = Vec::with_capacity(count);
    for i in 0..count {
        placements.push(placement(py, i, translations[i], rotations[i].as_ref())?);
    }
    let order = meshes[0].order();
    if let Some(i) = meshes.iter().position(|m| m.order() != order) {
        let wanted = format!("must be {order}, the order of meshes[0]: place bodies of one order");
        return Err(invalid(
            py,
            &format!("meshes[{i}] order"),
            meshes[i].order(),
            &wanted,
        ));
    }
    py.detach(|| match order {
        2 => joined(meshes, placements, |m| match m {
            Cells::P2(m) => Some(m),
            Cells::P1(_) => None,
        })
        .map(|(m, ids)| (Cells::P2(m), ids)),
        _ => joined(meshes, placements, |m| match m {
            Cells::P1(m) => Some(m),
            Cells::P2(_) => None,
        })
        .map(|(m, ids)| (Cells::P1(m), ids)),
    })
    .or_raise(py)
}

/// The library's placement of meshes of one cell type (`cells` picks it from each mesh).
fn joined<C: CellType>(
    meshes: &[&AnyMesh],
    placements: Vec<Placement>,
    cells: impl Fn(&AnyMesh) -> Option<&TetMesh<C>>,
) -> tetfem::Result<(TetMesh<C>, BodyIds)> {
    let parts = meshes
        .iter()
        .zip(placements)
        .filter_map(|(m, p)| cells(m).map(|m| (m.clone(), p)))
        .collect();
    let bodies = Bodies::new(parts)?;
    let ids = BodyIds {
        of_node: bodies.node_bodies(),
        of_tet: bodies.tet_bodies(),
    };
    Ok((bodies.mesh().clone(), ids))
}

/// The surface barrier of `mesh` and each node's body (`bodies`, or all body 0 for a mesh not
/// made by `Mesh.bodies`): d̂ = `distance` and κ = `stiffness` where given, the library's defaults
/// from the surface and the stiffest of `materials` otherwise; Coulomb's μ = `friction`
/// between the surfaces (0: none).
pub fn surface_contact_of(
    py: Python<'_>,
    (mesh, bodies): (&AnyMesh, Option<&BodyIds>),
    materials: &MaterialMap,
    (distance, stiffness): (Option<f64>, Option<f64>),
    friction: f64,
) -> PyResult<(SurfaceBarrier, Vec<usize>)> {
    let stiffest = materials.stiffest_youngs_modulus();
    let barrier = py
        .detach(|| {
            let surface = on_cells!(mesh, m => Surface::from_mesh(m))?;
            SurfaceBarrier::scaled_to(&surface, stiffest, distance, stiffness)?
                .with_friction(friction)
        })
        .or_raise(py)?;
    let body_of_node = match bodies {
        Some(ids) => ids.of_node.clone(),
        None => vec![0; mesh.node_count()],
    };
    Ok((barrier, body_of_node))
}
