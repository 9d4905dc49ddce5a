//! External loads as a consistent nodal force vector (force units, DOF `3·node + axis`).

use nalgebra::Vector3;

use crate::base::error::{Error, Result};
use crate::fe::element::ElementType;
use crate::fe::element::PointwiseElement;
use crate::fe::materials::TetMaterials;
use crate::mesh::{BoundaryFace, CellType, TetMesh};

/// Accumulated external nodal forces of one mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Loads {
    forces: Vec<f64>,
}

impl Loads {
    /// No load.
    pub fn new<C: CellType>(mesh: &TetMesh<C>) -> Self {
        Loads {
            forces: vec![0.0; mesh.dof_count()],
        }
    }

    /// Gravity: body force ρ·g per unit volume (g in m/s² in SI, e.g. (0, 0, −9.81)). The
    /// consistent load is ρₑ·g·∫Nᵢ dV on node i of tet e ([`ElementType::VOLUME_LOAD`]:
    /// ρₑ·g·Vₑ/4 on each node of a linear tet), ρₑ the density of tet e's material (one
    /// [`Material`](crate::fe::material::Material) for all, or a [`MaterialMap`](crate::fe::materials::MaterialMap)).
    pub fn add_gravity<E: ElementType>(
        &mut self,
        mesh: &TetMesh<E>,
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
        self.add_volume_loads(mesh, |t| densities[materials.index_of(t)]);
        Ok(self)
    }

    /// A uniform body force density b (force per volume, N/m³ in SI): b·∫Nᵢ dV on node i of
    /// each tet ([`ElementType::VOLUME_LOAD`]: b·V/4 on each node of a linear tet).
    pub fn add_body_force<E: ElementType>(
        &mut self,
        mesh: &TetMesh<E>,
        force_density: Vector3<f64>,
    ) -> Result<&mut Self> {
        check_finite("body force", &force_density)?;
        self.check_mesh(mesh)?;
        self.add_volume_loads(mesh, |_| force_density);
        Ok(self)
    }

    /// Adds b(t)·∫Nᵢ dV to node i of every tet t (b constant in each tet).
    fn add_volume_loads<E: ElementType>(
        &mut self,
        mesh: &TetMesh<E>,
        force_density: impl Fn(usize) -> Vector3<f64>,
    ) {
        for (t, tet) in mesh.tets().iter().enumerate() {
            let density = force_density(t);
            let rest = E::rest(mesh, t);
            for (i, &n) in tet.as_ref().iter().enumerate() {
                self.add_at(n, &(density * E::shape_integral(&rest, i)));
            }
        }
    }

    /// A body force density b(x) varying in space (force per volume, N/m³ in SI): the consistent
    /// load ∫ b·Nᵢ dV on node i of each tet, for the linear or the quadratic tet
    /// ([`PointwiseElement`]), by the degree-5 rule of [`crate::fe::quadrature::tet_rule`] (b·Nᵢ is
    /// integrated exactly where b is a polynomial of degree ≤ 5 − p, p the element's degree).
    /// A non-finite b(x) is an error and leaves the loads unchanged.
    pub fn add_body_force_field<E: PointwiseElement>(
        &mut self,
        mesh: &TetMesh<E>,
        force_density: impl Fn(&Vector3<f64>) -> Vector3<f64>,
    ) -> Result<&mut Self> {
        self.check_mesh(mesh)?;
        let rule = crate::fe::quadrature::tet_rule();
        let mut forces = self.forces.clone();
        let mut shape = vec![0.0; E::NODES];
        for (t, tet) in mesh.tets().iter().enumerate() {
            let x = mesh.corner_positions_of(t);
            let element = crate::fe::element::pointwise::corners_of(mesh, t);
            let straight_volume = crate::fe::element::Tet::volume(&element);
            for q in &rule {
                let b3 = q.barycentric;
                let l = [1.0 - b3.x - b3.y - b3.z, b3.x, b3.y, b3.z];
                E::shape_values_at(&l, &mut shape);
                // On a straight tet the affine point and V (ratio 1); on a curved one x(L), det G.
                let p = element.position(&x, &l);
                let volume = straight_volume * element.volume_ratio(&l);
                let b = force_density(&p);
                check_finite("body force field value", &b)?;
                for (i, &node) in tet.as_ref().iter().enumerate() {
                    for axis in 0..3 {
                        forces[3 * node + axis] += q.weight * volume * shape[i] * b[axis];
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

    /// A uniform traction t (force per area, Pa in SI) on boundary faces: each face gives
    /// t·∫Nᵢ dA to its nodes ([`ElementType::FACE_LOAD`]: area/3 · t to each node of a 3-node
    /// triangle; on a 6-node face nothing to the corners and area/3 · t to each edge node).
    /// Exact for the element's shape functions.
    pub fn add_traction<E: ElementType>(
        &mut self,
        mesh: &TetMesh<E>,
        faces: &[BoundaryFace],
        traction: Vector3<f64>,
    ) -> Result<&mut Self> {
        check_finite("traction", &traction)?;
        self.check_faces(mesh, faces, "traction")?;
        let mut forces = self.forces.clone();
        for face in faces {
            let area = face.area_vector(mesh)?.norm();
            let nodes = face.element_nodes(mesh)?;
            let curved = curved_face(mesh, &nodes);
            for (i, &n) in nodes.iter().enumerate() {
                let share = match &curved {
                    // A curved 6-node face: ∫Nᵢ dA over the quadratic surface.
                    Some(w) => traction * w[i],
                    None => traction * E::FACE_LOAD.share(i, area),
                };
                for axis in 0..3 {
                    forces[3 * n + axis] += share[axis];
                }
            }
        }
        // Only now, with every face checked, replace the loads: an error leaves them unchanged.
        self.forces = forces;
        Ok(self)
    }

    /// A total force spread as a uniform traction over `faces` (traction = total / Σ area).
    pub fn add_total_force_on_faces<E: ElementType>(
        &mut self,
        mesh: &TetMesh<E>,
        faces: &[BoundaryFace],
        total: Vector3<f64>,
    ) -> Result<&mut Self> {
        check_finite("total force", &total)?;
        self.check_faces(mesh, faces, "total force on faces")?;
        let mut area = 0.0;
        for face in faces {
            area += match curved_face(mesh, &face.element_nodes(mesh)?) {
                Some(w) => w.iter().sum(),
                None => face.area_vector(mesh)?.norm(),
            };
        }
        self.add_traction(mesh, faces, total / area)
    }

    /// Adds `factor` times `other` (loads of the same mesh: [`Error::DimensionMismatch`]
    /// otherwise): a load scaled by its amplitude's value.
    pub fn add_scaled(&mut self, other: &Loads, factor: f64) -> Result<&mut Self> {
        Error::check_len("loads", self.forces.len(), other.forces.len())?;
        for (f, g) in self.forces.iter_mut().zip(&other.forces) {
            *f += factor * g;
        }
        Ok(self)
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

    fn check_mesh<C: CellType>(&self, mesh: &TetMesh<C>) -> Result<()> {
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

    fn check_faces<C: CellType>(
        &self,
        mesh: &TetMesh<C>,
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

/// ∫Nᵢ dA of a curved 6-node face of `mesh` (its element nodes `nodes`), `None` for a 3-node
/// face or a straight one (whose closed-form weights apply).
fn curved_face<C: crate::mesh::CellType>(mesh: &TetMesh<C>, nodes: &[usize]) -> Option<[f64; 6]> {
    let x: [Vector3<f64>; 6] = match nodes {
        [a, b, c, d, e, f] => [*a, *b, *c, *d, *e, *f].map(|n| mesh.nodes()[n]),
        _ => return None,
    };
    crate::fe::element::tet10::curved_face_integrals(&x)
}
