//! Several bodies in a scene (`[[bodies]]`) and their body–body contact (`[self_contact]`):
//! the bodies' mesh (copies of `[mesh]` placed by [`tetfem::mesh::Bodies`]), their initial
//! velocities, and the surface barrier with its defaults. The physics — what the barrier is,
//! which analyses may carry it — is the library's; the scene only reads the keys.

use nalgebra::Vector3;
use tetfem::base::error::Result;
use tetfem::contact::surface::{Surface, SurfaceBarrier};
use tetfem::mesh::{Bodies, Placement};
use tetfem::{CellType, TetMesh};

use super::Scene;

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

impl Scene {
    /// Whether the scene has body–body or self-contact: `[[bodies]]` or `[self_contact]`.
    pub fn has_surface_contact(&self) -> bool {
        !self.spec().bodies.is_empty() || self.spec().self_contact.is_some()
    }

    /// The bodies' mesh (each `[[bodies]]` entry a copy of `body`, the mesh of `[mesh]`, placed)
    /// and what the run keeps of them; `body` itself (one body) with only `[self_contact]`;
    /// `None` when the scene has neither. `imported` says whether `[mesh]` is a file: the
    /// bodies place copies of a box only (a file's regions and ids would repeat), an error
    /// naming `bodies` otherwise. `stiffest` is the largest Young's modulus (Pa), the scale of
    /// κ's default.
    pub(crate) fn build_bodies<C: CellType>(
        &self,
        body: TetMesh<C>,
        imported: bool,
        stiffest: f64,
    ) -> Result<(TetMesh<C>, Option<BuiltBodies>)> {
        if !self.has_surface_contact() {
            return Ok((body, None));
        }
        let spec = self.spec();
        let first = spec.bodies.first().map(|b| b.span());
        if let (true, Some(span)) = (imported, &first) {
            return Err(self.error(
                "bodies",
                span,
                "bodies place copies of a [mesh.box] only; a mesh file's regions and ids \
                 would repeat in each copy",
            ));
        }
        let (mesh, velocities) = match spec.bodies.is_empty() {
            true => (
                Bodies::new(vec![(body, Placement::identity())])?,
                vec![Vector3::zeros()],
            ),
            false => {
                let mut parts = Vec::new();
                let mut velocities = Vec::new();
                for (i, spanned) in spec.bodies.iter().enumerate() {
                    let b = spanned.get_ref();
                    let at = |e: tetfem::Error| {
                        self.error(&format!("bodies[{i}]"), &spanned.span(), e.to_string())
                    };
                    let placement = Placement::translated(b.translation.into())
                        .and_then(|p| match b.rotation_angle == 0.0 {
                            true => Ok(p),
                            false => {
                                p.rotated(b.rotation_axis.into(), b.rotation_angle.to_radians())
                            }
                        })
                        .map_err(at)?;
                    let velocity = Vector3::from(b.velocity);
                    if !velocity.iter().all(|v| v.is_finite()) {
                        return Err(self.error(
                            &format!("bodies[{i}].velocity"),
                            &spanned.span(),
                            format!("{:?} must be finite (m/s)", b.velocity),
                        ));
                    }
                    parts.push((body.clone(), placement));
                    velocities.push(velocity);
                }
                (Bodies::new(parts)?, velocities)
            }
        };
        let barrier = self.surface_barrier(mesh.mesh(), stiffest)?;
        let built = BuiltBodies {
            body_of_node: mesh.node_bodies(),
            body_of_tet: mesh.tet_bodies(),
            velocities,
            barrier,
        };
        Ok((mesh.mesh().clone(), Some(built)))
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
        let edges = surface.edges().len();
        let mean = (0..edges)
            .filter_map(|e| surface.rest_edge_length2(e))
            .map(f64::sqrt)
            .sum::<f64>()
            / edges.max(1) as f64;
        let given = self.spec().self_contact.as_ref();
        let span = given.map(|s| s.span()).unwrap_or_default();
        let given = given.map(|s| *s.get_ref()).unwrap_or_default();
        let distance = given.distance.unwrap_or(0.1 * surface.shortest_rest_edge());
        let stiffness = given.stiffness.unwrap_or(stiffest * mean);
        let barrier = SurfaceBarrier::new(distance, stiffness).map_err(|e| {
            let key = match distance.is_finite() && distance > 0.0 {
                true => "self_contact.stiffness",
                false => "self_contact.distance",
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
