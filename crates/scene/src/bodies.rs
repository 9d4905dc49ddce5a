//! Several bodies in a scene (`[[bodies]]`) and their body–body contact (`[self_contact]`):
//! the bodies' mesh (each its own or a copy of `[mesh]`, placed by [`tetfem::mesh::Bodies`]), their initial
//! velocities, and the surface barrier with its defaults. The physics — what the barrier is,
//! which analyses may carry it — is the library's; the scene only reads the keys.

use nalgebra::Vector3;
use tetfem::base::error::Result;
use tetfem::contact::surface::{Surface, SurfaceBarrier};
use tetfem::mesh::io::ImportedMesh;
use tetfem::mesh::{Bodies, Placement};
use tetfem::{CellType, TetMesh};

use super::{Scene, SceneElement};

/// What a built scene keeps of its bodies.
#[derive(Debug, Clone, PartialEq)]
pub struct BuiltBodies {
    /// The body of each mesh node.
    pub body_of_node: Vec<usize>,
    /// The body of each tet (the `.vtu` cell field `body_id`).
    pub body_of_tet: Vec<usize>,
    /// Each body's initial velocity (m/s), before `analysis.initial_velocity` is added.
    pub velocities: Vec<Vector3<f64>>,
    /// The surface barrier (d̂ m, κ J/m²).
    pub barrier: SurfaceBarrier,
}

impl BuiltBodies {
    /// The number of bodies.
    pub fn count(&self) -> usize {
        self.velocities.len()
    }
}

/// Where [`Scene::place_bodies`] put each node and tet, and each body's initial velocity
/// (m/s): a [`BuiltBodies`] before its barrier.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PlacedBodies {
    /// The body of each mesh node.
    pub body_of_node: Vec<usize>,
    /// The body of each tet.
    pub body_of_tet: Vec<usize>,
    /// Each body's initial velocity (m/s).
    pub velocities: Vec<Vector3<f64>>,
}

impl PlacedBodies {
    fn of<C: CellType>(bodies: &Bodies<C>, velocities: Vec<Vector3<f64>>) -> Self {
        Self {
            body_of_node: bodies.node_bodies(),
            body_of_tet: bodies.tet_bodies(),
            velocities,
        }
    }
}

/// The mesh with its bodies placed, what the import kept of it, and where the bodies went.
pub(crate) type PlacedMesh<E> = (TetMesh<E>, Option<ImportedMesh<E>>, Option<PlacedBodies>);

impl Scene {
    /// Whether the scene has body–body or self-contact: `[[bodies]]` or `[self_contact]`.
    pub fn has_surface_contact(&self) -> bool {
        !self.spec().bodies.is_empty() || self.spec().self_contact.is_some()
    }

    /// The bodies' mesh (each `[[bodies]]` entry its own `mesh` or a copy of `body`, the mesh
    /// of `[mesh]`, placed), what the import kept of it (a file's regions and ids: `[mesh]`'s
    /// own when its file is the one body; none beside other bodies) and where each node and
    /// tet went; `body` itself (one
    /// body) with only `[self_contact]`; `None` when the scene has neither. A second copy of a
    /// `[mesh]` file is an error naming its `bodies` entry (its ids would repeat).
    pub(crate) fn place_bodies<E: SceneElement>(
        &self,
        body: TetMesh<E>,
        imported: Option<ImportedMesh<E>>,
    ) -> Result<PlacedMesh<E>> {
        if !self.has_surface_contact() {
            return Ok((body, imported, None));
        }
        let spec = self.spec();
        if spec.bodies.is_empty() {
            let one = Bodies::new(vec![(body, Placement::identity())])?;
            let placed = PlacedBodies::of(&one, vec![Vector3::zeros()]);
            return Ok((one.mesh().clone(), imported, Some(placed)));
        }
        let mut parts = Vec::new();
        let mut velocities = Vec::new();
        let mut file_copies = 0;
        for (i, spanned) in spec.bodies.iter().enumerate() {
            let (b, span) = (spanned.get_ref(), spanned.span());
            let key = format!("bodies[{i}]");
            let mesh = match &b.mesh {
                Some(own) => self.mesh_of::<E>(own, &format!("{key}.mesh"), &span)?.0,
                None if imported.is_some() && file_copies > 0 => {
                    return Err(self.error(
                        &key,
                        &span,
                        "copies [mesh] a second time: bodies place copies of a [mesh.box] \
                         only (a mesh file may be one body); a file's regions and ids would \
                         repeat in each copy: give the body its own mesh (bodies.mesh)",
                    ));
                }
                None => {
                    file_copies += usize::from(imported.is_some());
                    body.clone()
                }
            };
            let at = |e: tetfem::Error| self.error(&key, &span, e.to_string());
            let placement = Placement::translated(b.translation.into())
                .and_then(|p| match b.rotation_angle == 0.0 {
                    true => Ok(p),
                    false => p.rotated(b.rotation_axis.into(), b.rotation_angle.to_radians()),
                })
                .map_err(at)?;
            let velocity = Vector3::from(b.velocity);
            if !velocity.iter().all(|v| v.is_finite()) {
                return Err(self.error(
                    &format!("{key}.velocity"),
                    &span,
                    format!("{:?} must be finite (m/s)", b.velocity),
                ));
            }
            parts.push((mesh, placement));
            velocities.push(velocity);
        }
        let all = Bodies::new(parts)?;
        let placed = PlacedBodies::of(&all, velocities);
        // The file's regions and ids stay the mesh's when the file is the one body (its nodes
        // and tets keep their numbers); beside other bodies the mesh is no longer the file's.
        let alone = spec.bodies.len() == 1 && spec.bodies[0].get_ref().mesh.is_none();
        let imported = imported.filter(|_| alone);
        Ok((all.mesh().clone(), imported, Some(placed)))
    }

    /// The bodies a run keeps: `placed` with the barrier of `[self_contact]` on `mesh`;
    /// `stiffest` is the largest Young's modulus of the bodies' materials (Pa), the scale of
    /// κ's default.
    pub(crate) fn finish_bodies<C: CellType>(
        &self,
        placed: PlacedBodies,
        mesh: &TetMesh<C>,
        stiffest: f64,
    ) -> Result<BuiltBodies> {
        Ok(BuiltBodies {
            barrier: self.surface_barrier(mesh, stiffest)?,
            body_of_node: placed.body_of_node,
            body_of_tet: placed.body_of_tet,
            velocities: placed.velocities,
        })
    }

    /// The barrier of `[self_contact]` on `mesh`: d̂ (default a tenth of the shortest surface
    /// edge at rest) and κ (default `stiffest`·h̄, h̄ the mean surface edge at rest), friction's
    /// μ (default 0) and ε_v (default the library's). A d̂, κ or ε_v that is not finite and
    /// > 0, or a μ that is negative or not finite, is an error naming its key.
    fn surface_barrier<C: CellType>(
        &self,
        mesh: &TetMesh<C>,
        stiffest: f64,
    ) -> Result<SurfaceBarrier> {
        let surface = Surface::from_mesh(mesh)?;
        let given = self.spec().self_contact.as_ref();
        let span = given.map(|s| s.span()).unwrap_or_default();
        let given = given.map(|s| *s.get_ref()).unwrap_or_default();
        let (distance, stiffness) = (given.distance, given.stiffness);
        let barrier =
            SurfaceBarrier::scaled_to(&surface, stiffest, distance, stiffness).map_err(|e| {
                let key = match &e {
                    tetfem::Error::InvalidParameter { name, .. } if name.ends_with("stiffness") => {
                        "self_contact.stiffness"
                    }
                    _ => "self_contact.distance",
                };
                self.error(key, &span, e.to_string())
            })?;
        let barrier = barrier
            .with_friction(given.friction.unwrap_or(0.0))
            .map_err(|e| self.error("self_contact.friction", &span, e.to_string()))?;
        match given.slip_velocity {
            Some(v) => barrier
                .with_slip_velocity(v)
                .map_err(|e| self.error("self_contact.slip_velocity", &span, e.to_string())),
            None => Ok(barrier),
        }
    }
}

/// Adds the cell field `body_id` (each tet's body) to a frame's `arrays`, with bodies.
pub(crate) fn add_body_id(
    arrays: &mut tetfem::post::output::FrameArrays,
    bodies: Option<&BuiltBodies>,
) {
    if let Some(bodies) = bodies {
        let ids = bodies.body_of_tet.iter().map(|&b| b as i32).collect();
        arrays.cell_indices.push(("body_id".into(), ids));
    }
}

/// The CSV columns a run with surface contact adds: per body `body<b>_kinetic_J` (½vᵀMv of its
/// nodes) and `body<b>_px_Ns`, `_py_Ns`, `_pz_Ns` (its linear momentum M·v summed per axis),
/// then `surface_energy_J` (the barrier's B, which `total_J` leaves out) and
/// `min_surface_distance_m` (the smallest distance between surface primitives within d̂; `inf`
/// when none is that close).
pub(crate) fn csv_columns(bodies: &BuiltBodies) -> Vec<String> {
    let mut columns: Vec<String> = Vec::new();
    for b in 0..bodies.count() {
        columns.push(format!("body{b}_kinetic_J"));
        for c in ["px", "py", "pz"] {
            columns.push(format!("body{b}_{c}_Ns"));
        }
    }
    columns.push("surface_energy_J".into());
    columns.push("min_surface_distance_m".into());
    columns
}

/// The values of [`csv_columns`] at `state` (free DOFs) with full displacement `u`.
pub(crate) fn csv_values(
    system: &tetfem::analysis::dynamics::LinearSystem,
    force: &tetfem::analysis::dynamics::InternalForce,
    bodies: &BuiltBodies,
    state: &tetfem::analysis::dynamics::State,
    u: &[f64],
) -> Result<Vec<f64>> {
    let free = system.dofs().free_dofs();
    let mut values = Vec::with_capacity(4 * bodies.count() + 2);
    let mut masked = vec![0.0; state.velocity.len()];
    let mut mv = vec![0.0; state.velocity.len()];
    for b in 0..bodies.count() {
        for ((m, &v), &d) in masked.iter_mut().zip(&state.velocity).zip(free) {
            *m = if bodies.body_of_node[d / 3] == b {
                v
            } else {
                0.0
            };
        }
        system.mass().mul_vec(&masked, &mut mv)?;
        values.push(0.5 * masked.iter().zip(&mv).map(|(a, b)| a * b).sum::<f64>());
        let mut momentum = [0.0; 3];
        for (&p, &d) in mv.iter().zip(free) {
            momentum[d % 3] += p;
        }
        values.extend(momentum);
    }
    let surface = match force {
        tetfem::analysis::dynamics::InternalForce::Nonlinear(n) => n.surface_contact(),
        tetfem::analysis::dynamics::InternalForce::Linear => None,
    };
    match surface {
        Some(s) => {
            values.push(s.energy(u)?);
            values.push(s.smallest_distance(u)?);
        }
        None => values.extend([f64::NAN, f64::NAN]),
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use tetfem::Error;

    use crate::Scene;

    /// Two blocks, the second beside the first, with `keys` under `[self_contact]`.
    fn scene(keys: &str) -> Scene {
        format!(
            "[mesh.box]\nmax = [0.1, 0.1, 0.1]\ncells = [1, 1, 1]\n\
             [material]\nyoungs_modulus = 1e6\npoisson_ratio = 0.3\ndensity = 1000.0\n\
             [[bodies]]\n[[bodies]]\ntranslation = [0.2, 0.0, 0.0]\n\
             [self_contact]\n{keys}\n\
             [analysis]\ntype = \"dynamic\"\nmethod = \"backward_euler\"\ndt = 1e-3\n\
             duration = 0.01\n"
        )
        .parse()
        .unwrap()
    }

    /// The key and message of the scene's build error.
    fn build_error(keys: &str) -> (String, String) {
        match scene(keys).build() {
            Err(Error::Scene { key, message, .. }) => (key, message),
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("{keys} built"),
        }
    }

    #[test]
    fn friction_reaches_the_barrier_and_defaults_to_none() {
        let barrier = |keys: &str| scene(keys).build().unwrap().bodies.unwrap().barrier;
        let none = barrier("");
        assert_eq!((none.friction, none.slip_velocity), (0.0, None));
        let given = barrier("friction = 0.4\nslip_velocity = 1e-4");
        assert_eq!((given.friction, given.slip_velocity), (0.4, Some(1e-4)));
    }

    #[test]
    fn bad_friction_is_an_error_naming_its_key_and_value() {
        for (keys, key, value) in [
            ("friction = -0.1", "self_contact.friction", "-0.1"),
            ("friction = nan", "self_contact.friction", "NaN"),
            ("slip_velocity = 0.0", "self_contact.slip_velocity", "0"),
        ] {
            let (k, message) = build_error(keys);
            assert_eq!(k, key, "{message}");
            assert!(message.contains(value), "{keys}: {message}");
        }
    }
}
