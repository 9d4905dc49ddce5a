//! The problem definition every analysis runs: what the body is (mesh, materials per region,
//! force model), how it is held (constraints and their motion), what acts on it (loads with
//! their time functions, gravity) and what it may touch (obstacles with their contact
//! parameters). Front ends (scenes, Python, the PETSc engine) build one with
//! [`Definition::builder`]; [`Definition::check`] says once, in the library, whether an analysis
//! may run it ([`Combination::check`]).
//!
//! Time: static analyses evaluate amplitudes and motions at the pseudo-time
//! [`STATIC_TIME`](crate::bc::amplitude::STATIC_TIME) (load steps follow t ∈ (0, 1]); transient
//! ones from t = 0.

use nalgebra::Vector3;

use crate::analysis::dynamics::TimeData;
use crate::base::error::{Error, Result};
use crate::base::warning::Warning;
use crate::bc::boundary_motion::BoundaryMotion;
use crate::bc::constraints::Constraints;
use crate::bc::loads::Loads;
use crate::contact::Contact;
use crate::contact::surface::{Surface, SurfaceBarrier};
use crate::fe::element::Tet4;
use crate::fe::materials::MaterialMap;
use crate::mesh::{CellType, TetMesh};
use crate::model::{ModelKind, ModelMap};

use super::combination::{Analysis, Combination};

/// A whole problem: body, supports, loads and obstacles, on a mesh of cell type `C` (4-node
/// tets by default, or 10-node ones).
///
/// Units: those of the mesh (length, m in SI) and the materials (stress Pa, density kg/m³);
/// loads in force units (N), gravity in length/time² (m/s²).
#[derive(Debug, Clone)]
pub struct Definition<C: CellType = Tet4> {
    /// The mesh.
    pub mesh: TetMesh<C>,
    /// The material of every tet (one region or several).
    pub materials: MaterialMap,
    /// The force model: [`ModelKind::Linear`] (small strain, the linear fast path) or a
    /// large-deformation one; with [`region_models`](Self::region_models) the model of every
    /// material they leave to it.
    pub model: ModelKind,
    /// A model per material (`Some`: one kind per material of
    /// [`materials`](Self::materials), in its order), e.g. a linear body beside a Neo-Hookean
    /// one; `None`: every material takes [`model`](Self::model).
    pub region_models: Option<Vec<ModelKind>>,
    /// The constraints, with their prescribed values at the analysis' start (t = 0 for a
    /// transient run, [`STATIC_TIME`](crate::bc::amplitude::STATIC_TIME) for a static one).
    pub constraints: Constraints,
    /// The constant loads other than gravity (N, every DOF of the mesh).
    pub loads: Loads,
    /// The gravity acceleration (m/s²); its load ρ·g over the volume is assembled by each
    /// analysis (a transient one tracks it apart, to follow `time_data.gravity`).
    pub gravity: Vector3<f64>,
    /// What follows time: loads with amplitudes, gravity's amplitude, supports that move.
    pub time_data: TimeData,
    /// Every prescribed motion of the supports (constant ones too): what the load steps of a
    /// nonlinear static solve follow.
    pub motions: BoundaryMotion,
    /// The rigid obstacles and their contact parameters, if any.
    pub contact: Option<Contact>,
    /// Body–body and self-contact of the boundary surface, if any.
    pub surface_contact: Option<SurfaceContactData>,
}

/// Body–body and self-contact as a definition holds it: the barrier and the body of each mesh
/// node ([`crate::mesh::Bodies::node_bodies`]); a transient run builds its
/// [`SurfaceContact`](crate::contact::surface::SurfaceContact) from them.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceContactData {
    /// d̂ (m) and κ (J/m²).
    pub barrier: SurfaceBarrier,
    /// The body of each mesh node (names the bodies of an overlap at the start).
    pub body_of_node: Vec<usize>,
}

impl<C: CellType> Definition<C> {
    /// A builder on `mesh` with `materials`: the linear model, no constraint, no load, no
    /// gravity, nothing following time, no obstacle.
    pub fn builder(mesh: TetMesh<C>, materials: MaterialMap) -> DefinitionBuilder<C> {
        let constraints = Constraints::new(&mesh);
        let loads = Loads::new(&mesh);
        DefinitionBuilder {
            definition: Definition {
                mesh,
                materials,
                model: ModelKind::Linear,
                region_models: None,
                constraints,
                loads,
                gravity: Vector3::zeros(),
                time_data: TimeData::default(),
                motions: BoundaryMotion::new(),
                contact: None,
                surface_contact: None,
            },
        }
    }

    /// The choices of this definition under `analysis`, as [`Combination::check`] takes them.
    pub fn combination(&self, analysis: Analysis) -> Combination {
        let friction = self
            .contact
            .as_ref()
            .is_some_and(|c| c.obstacles().iter().any(|o| o.friction() > 0.0));
        let (model, region_models) = self.combined_models();
        Combination {
            model,
            region_models,
            order: if C::NODES == 10 { 2 } else { 1 },
            analysis,
            time_varying_loads: !self.time_data.loads.is_empty()
                || !self.time_data.gravity.is_one(),
            moving_supports: !self.time_data.motion.is_empty() || !self.motions.is_constant(),
            obstacles: self.contact.is_some(),
            friction,
            regions: self.materials.materials().len() > 1,
            formulation: crate::analysis::combination::Formulation::Displacement,
            surface_contact: self.surface_contact.is_some(),
            surface_friction: self
                .surface_contact
                .as_ref()
                .is_some_and(|s| s.barrier.friction > 0.0),
        }
    }

    /// The kind of each material's model, in the materials' order.
    pub fn model_kinds(&self) -> Vec<ModelKind> {
        match &self.region_models {
            Some(kinds) => kinds.clone(),
            None => vec![self.model; self.materials.materials().len()],
        }
    }

    /// The force models of a run: each material's ([`model_kinds`](Self::model_kinds)).
    ///
    /// Errors: [`region_models`](Self::region_models) not one kind per material
    /// ([`ModelMap::with_kinds`]).
    pub fn model_map(&self) -> Result<ModelMap> {
        match &self.region_models {
            Some(kinds) => ModelMap::with_kinds(kinds.clone(), &self.materials),
            None => Ok(ModelMap::new(self.model, &self.materials)),
        }
    }

    /// Whether every material takes the linear model (the linear fast paths' question).
    pub fn is_linear(&self) -> bool {
        self.model_kinds().iter().all(|k| k.is_linear())
    }

    /// The models as [`Combination`] takes them: the first material's kind (the run's model
    /// when every material takes it), and the materials (by name) whose kind differs from it.
    fn combined_models(&self) -> (ModelKind, Vec<(String, ModelKind)>) {
        let kinds = self.model_kinds();
        let first = kinds.first().copied().unwrap_or(self.model);
        let differing = self
            .materials
            .names()
            .iter()
            .zip(kinds)
            .filter(|&(_, kind)| kind != first)
            .map(|(name, kind)| (name.clone(), kind))
            .collect();
        (first, differing)
    }

    /// Whether `analysis` may run this definition: its warnings, or the library's one error
    /// naming the pair that clashes ([`Combination::check`]); first, region models that are
    /// not one kind per material ([`model_map`](Self::model_map)).
    ///
    /// With body–body and self-contact, also the surface's own checks (closed and manifold,
    /// naming the edge) and [`Warning::SurfaceBarrierReach`] when d̂ exceeds its shortest edge.
    pub fn check(&self, analysis: Analysis) -> Result<Vec<Warning>> {
        self.model_map()?;
        let mut warnings = self.combination(analysis).check()?;
        if let Some(data) = &self.surface_contact {
            let surface = Surface::from_mesh(&self.mesh)?;
            let (d_hat, shortest) = (
                data.barrier.activation_distance,
                surface.shortest_rest_edge(),
            );
            if d_hat > shortest {
                warnings.push(Warning::SurfaceBarrierReach {
                    activation_distance: d_hat,
                    shortest_edge: shortest,
                });
            }
        }
        Ok(warnings)
    }
}

/// Builds a [`Definition`], checking each part against the mesh as it is given (a part made
/// for another mesh is an [`Error::InvalidParameter`] naming it).
#[derive(Debug, Clone)]
pub struct DefinitionBuilder<C: CellType = Tet4> {
    definition: Definition<C>,
}

impl<C: CellType> DefinitionBuilder<C> {
    /// The force model (default [`ModelKind::Linear`]).
    pub fn model(mut self, model: ModelKind) -> Self {
        self.definition.model = model;
        self
    }

    /// A force model per material (`kinds[i]` for material `i` of the definition's
    /// materials), over [`model`](Self::model).
    ///
    /// Errors ([`Error::InvalidParameter`]): not one kind per material, naming both counts.
    pub fn region_models(mut self, kinds: Vec<ModelKind>) -> Result<Self> {
        let count = self.definition.materials.materials().len();
        if kinds.len() != count {
            return Err(Error::invalid_parameter(
                "region models",
                format!("{} kinds", kinds.len()),
                format!("must give one per material ({count} materials)"),
            ));
        }
        self.definition.region_models = Some(kinds);
        Ok(self)
    }

    /// The constraints (made for the mesh's nodes).
    pub fn constraints(mut self, constraints: Constraints) -> Result<Self> {
        ensure_dofs(
            "constraints",
            constraints.dof_count(),
            &self.definition.mesh,
        )?;
        self.definition.constraints = constraints;
        Ok(self)
    }

    /// The constant loads other than gravity (made for the mesh's nodes).
    pub fn loads(mut self, loads: Loads) -> Result<Self> {
        ensure_dofs("loads", loads.as_slice().len(), &self.definition.mesh)?;
        self.definition.loads = loads;
        Ok(self)
    }

    /// The gravity acceleration (m/s²; finite).
    pub fn gravity(mut self, gravity: Vector3<f64>) -> Result<Self> {
        if !gravity.iter().all(|g| g.is_finite()) {
            return Err(Error::invalid_parameter(
                "gravity",
                format!("{gravity:?}"),
                "must be finite (m/s²)",
            ));
        }
        self.definition.gravity = gravity;
        Ok(self)
    }

    /// Loads with amplitudes, gravity's amplitude and supports that move in time.
    pub fn time_data(mut self, time_data: TimeData) -> Self {
        self.definition.time_data = time_data;
        self
    }

    /// Every prescribed motion of the supports (what nonlinear static load steps follow).
    pub fn motions(mut self, motions: BoundaryMotion) -> Self {
        self.definition.motions = motions;
        self
    }

    /// The obstacles with their contact parameters.
    pub fn contact(mut self, contact: Contact) -> Self {
        self.definition.contact = Some(contact);
        self
    }

    /// Body–body and self-contact under `barrier`, `body_of_node[n]` the body of mesh node n.
    /// Errors: not one body per node of the mesh ([`Error::InvalidParameter`] naming both
    /// counts).
    pub fn surface_contact(
        mut self,
        barrier: SurfaceBarrier,
        body_of_node: Vec<usize>,
    ) -> Result<Self> {
        let nodes = self.definition.mesh.node_count();
        if body_of_node.len() != nodes {
            return Err(Error::invalid_parameter(
                "surface contact body of each node",
                body_of_node.len(),
                format!("must give a body for each of the mesh's {nodes} nodes"),
            ));
        }
        self.definition.surface_contact = Some(SurfaceContactData {
            barrier,
            body_of_node,
        });
        Ok(self)
    }

    /// The definition, with the materials checked to cover every tet.
    pub fn build(self) -> Result<Definition<C>> {
        let tets = self.definition.mesh.tet_count();
        if self.definition.materials.tet_count() != tets {
            return Err(Error::invalid_parameter(
                "materials",
                self.definition.materials.tet_count(),
                format!("must give a material for each of the mesh's {tets} tets"),
            ));
        }
        Ok(self.definition)
    }
}

/// [`Error::InvalidParameter`] naming `what` unless it holds 3 values per node of `mesh`.
fn ensure_dofs<C: CellType>(what: &str, len: usize, mesh: &TetMesh<C>) -> Result<()> {
    if len == mesh.dof_count() {
        return Ok(());
    }
    Err(Error::invalid_parameter(
        what,
        len,
        format!(
            "must hold 3 values per node of the mesh ({} DOFs)",
            mesh.dof_count()
        ),
    ))
}
