//! External loads as a consistent nodal force vector (force units, DOF `3·node + axis`).

use nalgebra::Vector3;

use crate::error::{Error, Result};
use crate::materials::TetMaterials;
use crate::mesh::{BoundaryFace, TetMesh};

/// Accumulated external nodal forces of one mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Loads {
    forces: Vec<f64>,
}

impl Loads {
    /// No load.
    pub fn new(mesh: &TetMesh) -> Self {
        Loads {
            forces: vec![0.0; mesh.dof_count()],
        }
    }

    /// Gravity: body force ρ·g per unit volume (g in m/s² in SI, e.g. (0, 0, −9.81)). For linear
    /// tets the consistent load is ρₑ·g·Vₑ/4 on each node of each tet, ρₑ the density of tet e's
    /// material (one [`Material`](crate::material::Material) for all, or a [`MaterialMap`](crate::materials::MaterialMap)).
    pub fn add_gravity(
        &mut self,
        mesh: &TetMesh,
        materials: &impl TetMaterials,
        gravity: Vector3<f64>,
    ) -> Result<&mut Self> {
        check_finite("gravity", &gravity)?;
        // ρ·g per material, checked as the body force it is (ρ·g can overflow).
        let densities: Vec<Vector3<f64>> = materials
            .material_list()
            .iter()
            .map(|m| gravity * m.density())
            .collect();
        for d in &densities {
            check_finite("body force", d)?;
        }
        self.check_mesh(mesh)?;
        materials.check_tet_count(mesh)?;
        // As add_body_force, with the force density of each tet's material.
        for (t, tet) in mesh.tets().iter().enumerate() {
            let share = densities[materials.index_of(t)] * (mesh.element_of(t).volume() / 4.0);
            for &n in tet {
                self.add_at(n, &share);
            }
        }
        Ok(self)
    }

    /// A uniform body force density b (force per volume, N/m³ in SI): b·V/4 on each node of each
    /// tet.
    pub fn add_body_force(
        &mut self,
        mesh: &TetMesh,
        force_density: Vector3<f64>,
    ) -> Result<&mut Self> {
        check_finite("body force", &force_density)?;
        self.check_mesh(mesh)?;
        for (t, tet) in mesh.tets().iter().enumerate() {
            let share = force_density * (mesh.element_of(t).volume() / 4.0);
            for &n in tet {
                self.add_at(n, &share);
            }
        }
        Ok(self)
    }

    /// A body force density b(x) varying in space (force per volume): the consistent load
    /// ∫ b·Nᵢ dV on each node, by the degree-5 rule of [`crate::quadrature::tet_rule`].
    pub fn add_body_force_field(
        &mut self,
        mesh: &TetMesh,
        force_density: impl Fn(&Vector3<f64>) -> Vector3<f64>,
    ) -> Result<&mut Self> {
        self.check_mesh(mesh)?;
        let rule = crate::quadrature::tet_rule();
        let mut forces = self.forces.clone();
        for (t, tet) in mesh.tets().iter().enumerate() {
            let x = mesh.positions_of(t);
            let element = mesh.element_of(t);
            for q in &rule {
                let n = crate::quadrature::shape_values(&q.barycentric);
                let p = x[0] * n[0] + x[1] * n[1] + x[2] * n[2] + x[3] * n[3];
                let b = force_density(&p);
                check_finite("body force field value", &b)?;
                for (i, &node) in tet.iter().enumerate() {
                    for axis in 0..3 {
                        forces[3 * node + axis] += q.weight * element.volume() * n[i] * b[axis];
                    }
                }
            }
        }
        // Only now, with every value checked, replace the loads: an error leaves them unchanged.
        self.forces = forces;
        Ok(self)
    }

    /// A point force on one node (force units).
    pub fn add_nodal_force(&mut self, node: usize, force: Vector3<f64>) -> Result<&mut Self> {
        check_finite("nodal force", &force)?;
        let node_count = self.forces.len() / 3;
        if node >= node_count {
            return Err(Error::UnknownNode {
                context: "nodal force",
                node,
                node_count,
            });
        }
        self.add_at(node, &force);
        Ok(self)
    }

    /// A uniform traction t (force per area, Pa in SI) on boundary faces: each triangle gives
    /// area/3 · t to each of its nodes (exact for linear shape functions).
    pub fn add_traction(
        &mut self,
        mesh: &TetMesh,
        faces: &[BoundaryFace],
        traction: Vector3<f64>,
    ) -> Result<&mut Self> {
        check_finite("traction", &traction)?;
        self.check_faces(mesh, faces, "traction")?;
        for face in faces {
            let share = traction * (face.area_vector(mesh)?.norm() / 3.0);
            for &n in &face.nodes {
                self.add_at(n, &share);
            }
        }
        Ok(self)
    }

    /// A total force spread as a uniform traction over `faces` (traction = total / Σ area).
    pub fn add_total_force_on_faces(
        &mut self,
        mesh: &TetMesh,
        faces: &[BoundaryFace],
        total: Vector3<f64>,
    ) -> Result<&mut Self> {
        check_finite("total force", &total)?;
        self.check_faces(mesh, faces, "total force on faces")?;
        let mut area = 0.0;
        for face in faces {
            area += face.area_vector(mesh)?.norm();
        }
        self.add_traction(mesh, faces, total / area)
    }

    /// The nodal force vector (length 3·nodes).
    pub fn as_slice(&self) -> &[f64] {
        &self.forces
    }

    /// Sum of all nodal forces (the resultant).
    pub fn resultant(&self) -> Vector3<f64> {
        let mut sum = Vector3::zeros();
        for chunk in self.forces.chunks_exact(3) {
            sum += Vector3::new(chunk[0], chunk[1], chunk[2]);
        }
        sum
    }

    fn add_at(&mut self, node: usize, force: &Vector3<f64>) {
        for axis in 0..3 {
            self.forces[3 * node + axis] += force[axis];
        }
    }

    fn check_mesh(&self, mesh: &TetMesh) -> Result<()> {
        if mesh.dof_count() != self.forces.len() {
            return Err(Error::invalid_parameter(
                "mesh",
                format!("{} nodes", mesh.node_count()),
                format!(
                    "these loads were made for a mesh with {} nodes",
                    self.forces.len() / 3
                ),
            ));
        }
        Ok(())
    }

    fn check_faces(
        &self,
        mesh: &TetMesh,
        faces: &[BoundaryFace],
        context: &'static str,
    ) -> Result<()> {
        self.check_mesh(mesh)?;
        if faces.is_empty() {
            return Err(Error::EmptySelection {
                context: context.to_string(),
            });
        }
        for face in faces {
            if let Some(&node) = face.nodes.iter().find(|&&n| n >= mesh.node_count()) {
                return Err(Error::UnknownNode {
                    context,
                    node,
                    node_count: mesh.node_count(),
                });
            }
        }
        Ok(())
    }
}

fn check_finite(name: &str, v: &Vector3<f64>) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(Error::invalid_parameter(
            name,
            format!("{:?}", v.as_slice()),
            "every component must be finite",
        ))
    }
}
