//! Scene → mesh, material, constraints, loads and probes.

use std::ops::Range;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use std::collections::HashMap;

use nalgebra::Matrix3;

use super::{AmplitudeRef, AmplitudeSpec, MeshSpec, RegionSelector, Scene, Selector, SplitSpec};
use tetfem::analysis::dynamics::TimeData;
use tetfem::base::error::{Error, Result};
use tetfem::base::warning::Warning;
use tetfem::bc::amplitude::{Amplitude, STATIC_TIME};
use tetfem::bc::boundary_motion::{BoundaryMotion, Motion, RigidMotion};
use tetfem::bc::constraints::Constraints;
use tetfem::bc::loads::Loads;
use tetfem::fe::element::ElementType;
use tetfem::fe::material::Material;
use tetfem::fe::materials::{MaterialAssignment, MaterialMap, attribute_tets, volume_group_tets};
use tetfem::mesh::io::{ImportedMesh, TET10_KEPT_AS_CORNERS, read_gmsh_as, read_tetgen_as};
use tetfem::mesh::{BoundaryFace, BoxSplit, CellType, Tet4, TetMesh};

use super::SceneElement;
use tetfem::post::output::PointLocation;

/// The CSV column stems of a point probe's stress, in the `.vtu`'s tensor order.
pub(crate) const STRESS_COLUMNS: [&str; 6] = ["sxx", "syy", "szz", "sxy", "syz", "sxz"];

/// A named node set whose mean displacement is recorded, or a point whose displacement (and,
/// in a static run, stress) is.
#[derive(Debug, Clone, PartialEq)]
pub struct Probe {
    /// The probe's name.
    pub name: String,
    /// Its nodes (non-empty): the node set, or for a point probe the nodes of the tet holding
    /// the point.
    pub nodes: Vec<usize>,
    /// For a point probe (`at`): where the point lies and the weights of `nodes` there.
    pub point: Option<PointProbe>,
}

/// A probe at a point: the tet holding it and its shape functions' values there.
#[derive(Debug, Clone, PartialEq)]
pub struct PointProbe {
    /// The point (m).
    pub at: [f64; 3],
    /// Its tet and barycentric coordinates.
    pub location: PointLocation,
    /// The shape functions Nᵢ of the tet's nodes at the point (dimensionless, Σ = 1): u(x) =
    /// Σᵢ Nᵢ uᵢ.
    pub weights: Vec<f64>,
}

impl Probe {
    /// What the probe records of a node-major displacement (length units): the mean of its
    /// nodes' displacements, or for a point probe u(x) = Σᵢ Nᵢ(x) uᵢ of the tet holding it.
    pub fn displacement(&self, displacement: &[f64]) -> Vector3<f64> {
        let Some(point) = &self.point else {
            return self.mean_displacement(displacement);
        };
        let mut sum = Vector3::zeros();
        for (&n, &w) in self.nodes.iter().zip(&point.weights) {
            if let Some(u) = displacement.get(3 * n..3 * n + 3) {
                sum += Vector3::new(u[0], u[1], u[2]) * w;
            }
        }
        sum
    }

    /// Mean displacement of the probe's nodes (length units).
    pub fn mean_displacement(&self, displacement: &[f64]) -> Vector3<f64> {
        let mut sum = Vector3::zeros();
        for &n in &self.nodes {
            if let Some(u) = displacement.get(3 * n..3 * n + 3) {
                sum += Vector3::new(u[0], u[1], u[2]);
            }
        }
        sum / self.nodes.len().max(1) as f64
    }
}

/// Everything a solver needs, built from a scene, on a mesh of cell type `C` (the 4-node tet
/// for `mesh.order = 1`, the 10-node tet for 2).
#[derive(Debug, Clone)]
pub struct BuiltScene<C: CellType = Tet4> {
    /// The mesh.
    pub mesh: TetMesh<C>,
    /// The file's extra information (groups, markers, skipped elements) for imported meshes.
    pub imported: Option<ImportedMesh<C>>,
    /// The boundary faces, outward oriented.
    pub boundary: Vec<BoundaryFace>,
    /// The scene's `[material]`, or without one the first `[[materials]]` entry's: what
    /// single-material consumers (the critical-step report of `tetfem info`) use.
    pub material: Material,
    /// The material of every tet: `[[materials]]` where they claim, `[material]` elsewhere.
    pub materials: MaterialMap,
    /// The constraints.
    pub constraints: Constraints,
    /// The DOFs each `[[constraints]]` entry constrains, in scene order (what its reaction
    /// resultant sums over); a DOF two entries hold is the first one's, so that the entries'
    /// resultants sum to the supports' total.
    pub constraint_dofs: Vec<Vec<usize>>,
    /// The point (m) each `[[constraints]]` entry's reaction moment is taken about, in scene
    /// order (`moment_about`, default the origin).
    pub moment_points: Vec<Vector3<f64>>,
    /// The loads, as one nodal force vector (gravity included).
    pub loads: Loads,
    /// The loads other than gravity (what a dynamic run passes to
    /// [`LinearSystem::new`](tetfem::analysis::dynamics::LinearSystem::new), which tracks gravity apart).
    pub other_loads: Loads,
    /// The sum of the scene's gravity entries (acceleration, m/s² in SI).
    pub gravity: Vector3<f64>,
    /// The probes.
    pub probes: Vec<Probe>,
    /// Warnings about the constraints and the loads (a load on constrained DOFs only, no free
    /// DOF), found while building.
    pub input_warnings: Vec<tetfem::base::warning::Warning>,
    /// What follows time in a dynamic run: the loads with an amplitude (not in `other_loads`
    /// nor `gravity`) and the constraints that move. `constraints` and `loads` hold their
    /// values at the analysis' time: 0 for a dynamic run, [`STATIC_TIME`] otherwise.
    pub time_data: TimeData,
    /// Every `linear_field`, `rigid_motion` and amplitude-scaled `displacement` constraint,
    /// constant or not: what the load steps of a nonlinear static solve follow
    /// ([`solve_nonlinear_static_with_motion`](tetfem::analysis::nonlinear::solve_nonlinear_static_with_motion)).
    pub motions: BoundaryMotion,
    /// The bodies and their surface barrier, with `[[bodies]]` or `[self_contact]`.
    pub bodies: Option<super::bodies::BuiltBodies>,
}

impl<C: CellType> BuiltScene<C> {
    /// The mesh's, the material's, the constraints' and the loads' warnings (see
    /// [`tetfem::base::warning`]).
    pub fn warnings(&self) -> Vec<tetfem::base::warning::Warning> {
        let mut warnings = self.mesh.warnings();
        warnings.extend(self.materials.warnings());
        warnings.extend(self.input_warnings.iter().cloned());
        warnings
    }
}

/// What the `[[constraints]]` entries build (see [`BuiltScene`]'s fields of these names).
struct BuiltConstraints {
    constraints: Constraints,
    constraint_dofs: Vec<Vec<usize>>,
    moment_points: Vec<Vector3<f64>>,
    motions: BoundaryMotion,
}

/// What the `[[loads]]` entries build: the loads at the analysis' time, the constant ones
/// other than gravity, the summed gravity (see [`BuiltScene`]), the loads with an amplitude
/// (for [`TimeData::loads`]: a dynamic run scales each by a(t) at every step) and the warnings
/// about them, in scene order.
struct BuiltLoads {
    loads: Loads,
    other_loads: Loads,
    gravity: Vector3<f64>,
    timed: Vec<(Loads, Amplitude)>,
    warnings: Vec<Warning>,
}

impl Scene {
    /// The probe `name` at the point `at` of a `[[probes]]` entry (`key`, `span`): the tet
    /// holding it and its shape functions' values there; a point outside the mesh is an error
    /// naming `<key>.at`.
    fn point_probe<E: SceneElement>(
        &self,
        mesh: &TetMesh<E>,
        name: &str,
        at: [f64; 3],
        key: &str,
        span: &Range<usize>,
    ) -> Result<Probe> {
        let location = PointLocation::find(mesh, &Vector3::from(at)).map_err(|e| {
            let message = match e {
                Error::InvalidParameter { requirement, .. } => requirement,
                other => other.to_string(),
            };
            self.error(&format!("{key}.at"), span, format!("{at:?} {message}"))
        })?;
        let mut weights = vec![0.0; E::NODES];
        E::shape_values_at(&location.barycentric, &mut weights);
        Ok(Probe {
            name: name.to_string(),
            nodes: mesh.tets()[location.tet].as_ref().to_vec(),
            point: Some(PointProbe {
                at,
                location,
                weights,
            }),
        })
    }

    /// Builds the mesh (generating or reading it), the material, the constraints, the loads and
    /// the probes. Selections that match nothing are errors naming the scene entry and line.
    /// A scene of `mesh.order = 2` is an error here (naming the key): build it with
    /// [`build_as::<Tet10>`](Self::build_as).
    pub fn build(&self) -> Result<BuiltScene> {
        self.build_as::<Tet4>()
    }

    /// [`build`](Self::build) on the element `E` of the scene's `mesh.order` (a box mesh's
    /// 10-node tets get their edge nodes at the edges' midpoints; node selections pick them
    /// up as any other node, and a face set holds the faces whose three corners are
    /// selected). Another element type than the scene's order is an error naming `mesh.order`.
    pub fn build_as<E: SceneElement>(&self) -> Result<BuiltScene<E>> {
        self.check_element_order::<E>()?;
        let (mesh, imported) = self.build_mesh::<E>()?;
        // Several bodies: their meshes placed in one, the barrier's scale from their materials.
        let (mesh, imported, placed) = self.place_bodies(mesh, imported)?;
        let body_of_node = placed.as_ref().map(|p| p.body_of_node.clone());
        let body_of_tet = placed.as_ref().map(|p| p.body_of_tet.as_slice());
        let (materials, default) = self.materials(&mesh, imported.as_ref(), body_of_tet)?;
        let bodies = placed
            .map(|p| self.finish_bodies(p, &mesh, materials.stiffest_youngs_modulus()))
            .transpose()?;
        let boundary = mesh.boundary_faces()?;
        let material = default.unwrap_or(materials.materials()[0]);
        let ctx = Context {
            scene: self,
            mesh: &mesh,
            imported: imported.as_ref(),
            boundary: &boundary,
            body_of_node: body_of_node.as_deref(),
        };
        let named = self.named_amplitudes()?;
        // Static and modal analyses take the data at STATIC_TIME, a dynamic run starts at 0.
        let time = match self.analysis() {
            super::Analysis::Dynamic(_) => 0.0,
            _ => STATIC_TIME,
        };
        let mut time_data = TimeData::default();
        // What the scene combines runs, some of it with a warning (checked when parsed).
        let mut input_warnings = self.check_combination()?;
        let built =
            self.build_constraints(&ctx, &named, time, &mut time_data, &mut input_warnings)?;
        let built_loads = self.build_loads(&ctx, &materials, &named, time, &built.constraints)?;
        input_warnings.extend(built_loads.warnings);
        time_data.loads.extend(built_loads.timed);
        let probes = self.build_probes(&ctx)?;
        Ok(BuiltScene {
            mesh,
            imported,
            boundary,
            material,
            materials,
            constraints: built.constraints,
            constraint_dofs: built.constraint_dofs,
            moment_points: built.moment_points,
            loads: built_loads.loads,
            other_loads: built_loads.other_loads,
            gravity: built_loads.gravity,
            probes,
            input_warnings,
            time_data,
            motions: built.motions,
            bodies,
        })
    }

    /// An error naming `mesh.order` unless `E` is the element of the scene's order: a runner
    /// built for one order must not silently run a scene written for the other.
    fn check_element_order<E: SceneElement>(&self) -> Result<()> {
        if E::ORDER == self.order() {
            return Ok(());
        }
        Err(self.error(
            "mesh.order",
            &self.spec().mesh.span(),
            format!(
                "the scene asks for order {} but this runner builds it with {} cells \
                 (order {}); it does not run order {} scenes",
                self.order(),
                E::NAME,
                E::ORDER,
                self.order()
            ),
        ))
    }

    /// The mesh of `[mesh]` with `E`'s cells: a generated box (its memory estimate checked
    /// first), or a Gmsh or TetGen file with what the import kept of it (regions, original
    /// ids) for the selections that name them.
    fn build_mesh<E: SceneElement>(&self) -> Result<(TetMesh<E>, Option<ImportedMesh<E>>)> {
        let spec = self.spec();
        self.mesh_of(spec.mesh.get_ref(), "mesh", &spec.mesh.span())
    }

    /// The mesh `source` describes (`[mesh]`, or a body's own `mesh`, named `key` in errors)
    /// with `E`'s cells; see [`build_mesh`](Self::build_mesh).
    pub(crate) fn mesh_of<E: SceneElement>(
        &self,
        source: &MeshSpec,
        key: &str,
        span: &Range<usize>,
    ) -> Result<(TetMesh<E>, Option<ImportedMesh<E>>)> {
        // `[mesh]`'s file was parsed with the scene (for its order); a body's is read now.
        let parsed = match key {
            "mesh" => self.take_mesh_file(),
            _ => None,
        };
        Ok(match source {
            MeshSpec::Box(b) => {
                let split = match b.split {
                    SplitSpec::Lecture6 => BoxSplit::Lecture6,
                    SplitSpec::Mirrored6 => BoxSplit::Mirrored6,
                    SplitSpec::Five => BoxSplit::Five,
                };
                // The whole run's estimate, before the mesh is allocated.
                // A modal run holds K, M and a factor of K, like a dynamic one.
                let dynamic = matches!(
                    self.analysis(),
                    super::Analysis::Dynamic(_) | super::Analysis::Modal(_)
                );
                let at = |e: Error| self.error(&format!("{key}.box"), span, e.to_string());
                tetfem::base::memory::check_box_run(
                    b.cells,
                    split.tets_per_cell(),
                    E::NODES,
                    dynamic,
                    self.run_path(),
                )
                .map_err(at)?;
                let linear =
                    TetMesh::box_grid(b.min.into(), b.max.into(), b.cells, split).map_err(at)?;
                (E::from_linear(linear).map_err(at)?, None)
            }
            // The file's order is the scene's (`Scene::parse` read it): E's cells are the file's.
            // The file as parsed for the order, or (taken by an earlier build, or unreadable
            // then, or a body's) read now.
            MeshSpec::Gmsh(f) => {
                let imported = match parsed {
                    Some(file) => file.build_as::<E>()?,
                    None => read_gmsh_as::<E>(&self.resolve(&f.file))?,
                };
                self.check_kept_order(&imported)?;
                (imported.mesh.clone(), Some(imported))
            }
            MeshSpec::Tetgen(f) => {
                let imported = match parsed {
                    Some(file) => file.build_as::<E>()?,
                    None => read_tetgen_as::<E>(&tetgen_prefix(&self.resolve(&f.file)))?,
                };
                self.check_kept_order(&imported)?;
                (imported.mesh.clone(), Some(imported))
            }
        })
    }

    /// The `[[constraints]]` entries, in scene order: fixed axes, prescribed displacements and
    /// motions at `time` into the constraints, the moving ones also into `time_data.motion`,
    /// and each entry's DOFs and moment point for its reaction. A DOF constrained twice is an
    /// error naming both entries.
    fn build_constraints<E: SceneElement>(
        &self,
        ctx: &Context<'_, E>,
        named: &HashMap<String, Amplitude>,
        time: f64,
        time_data: &mut TimeData,
        input_warnings: &mut Vec<Warning>,
    ) -> Result<BuiltConstraints> {
        let spec = self.spec();
        let mesh = ctx.mesh;
        let mut motions = BoundaryMotion::new();
        let mut constraints = Constraints::new(mesh);
        // Which scene entry constrained each DOF, to name both entries of a conflict.
        let mut constrained_by: Vec<Option<usize>> = vec![None; mesh.dof_count()];
        let mut constraint_dofs = Vec::with_capacity(spec.constraints.len());
        let mut moment_points = Vec::with_capacity(spec.constraints.len());
        for (i, c) in spec.constraints.iter().enumerate() {
            let key = format!("constraints[{i}]");
            let span = c.span();
            let c = c.get_ref();
            input_warnings.extend(self.constraint_amplitude_warnings(c, named, &key, &span)?);
            let nodes = ctx.nodes(&c.select, &key, &span)?;
            moment_points.push(self.moment_point(c, &key, &span)?);
            let axes = self.constrained_axes(c, &key, &span)?;
            let at = |e: Error| match &e {
                Error::ConflictingConstraint { node, axis, .. } => {
                    let earlier = constrained_by[3 * node + axis]
                        .map_or("an earlier constraint".to_string(), |j| {
                            format!("constraints[{j}]")
                        });
                    self.error(&key, &span, format!("{e} (the first is {earlier})"))
                }
                _ => self.error(&key, &span, e.to_string()),
            };
            match self.motion_of(c, named, &key, &span)? {
                Some(motion) => {
                    let mut single = BoundaryMotion::new();
                    single.add(&nodes, axes, motion.clone()).map_err(at)?;
                    single
                        .prescribe_at(mesh.nodes(), time, &mut constraints)
                        .map_err(at)?;
                    if !motion.is_constant() {
                        time_data
                            .motion
                            .add(&nodes, axes, motion.clone())
                            .map_err(at)?;
                    }
                    motions.add(&nodes, axes, motion).map_err(at)?;
                }
                None => match c.displacement {
                    None => {
                        constraints.fix_axes(&nodes, axes).map_err(at)?;
                    }
                    Some(d) => {
                        for &n in &nodes {
                            for axis in (0..3).filter(|&a| axes[a]) {
                                constraints.prescribe_axis(n, axis, d[axis]).map_err(at)?;
                            }
                        }
                    }
                },
            }
            let mut dofs = Vec::with_capacity(3 * nodes.len());
            for &n in &nodes {
                for axis in (0..3).filter(|&a| axes[a]) {
                    // A DOF two entries hold (a clamp's edge on a roller's plane) is counted
                    // under the first only, so that the rows' reactions sum to the total.
                    if constrained_by[3 * n + axis].is_none() {
                        constrained_by[3 * n + axis] = Some(i);
                        dofs.push(3 * n + axis);
                    }
                }
            }
            constraint_dofs.push(dofs);
        }
        if constraints.count() == mesh.dof_count() {
            input_warnings.push(tetfem::base::warning::Warning::NoFreeDofs {
                dofs: mesh.dof_count(),
            });
        }
        Ok(BuiltConstraints {
            constraints,
            constraint_dofs,
            moment_points,
            motions,
        })
    }

    /// The warnings about a constraint's amplitudes (its own and its rigid motion's); an
    /// amplitude that names nothing is an error at `<key>.amplitude`.
    fn constraint_amplitude_warnings(
        &self,
        c: &super::ConstraintSpec,
        named: &HashMap<String, Amplitude>,
        key: &str,
        span: &Range<usize>,
    ) -> Result<Vec<Warning>> {
        let mut warnings = Vec::new();
        let given = [
            c.amplitude.as_ref(),
            c.rigid_motion.as_ref().and_then(|r| r.amplitude.as_ref()),
        ];
        for r in given.into_iter().flatten() {
            let amplitude_key = format!("{key}.amplitude");
            let amplitude = self.amplitude_of(r, named, &amplitude_key, span)?;
            warnings.extend(self.amplitude_warnings(&amplitude_key, &amplitude));
        }
        Ok(warnings)
    }

    /// The point (m) a constraint's reaction moment is taken about (`moment_about`, default the
    /// origin); a non-finite coordinate is an error naming the key, not a NaN moment later.
    fn moment_point(
        &self,
        c: &super::ConstraintSpec,
        key: &str,
        span: &Range<usize>,
    ) -> Result<Vector3<f64>> {
        let point = c.moment_about.unwrap_or_default();
        if point.iter().any(|v| !v.is_finite()) {
            return Err(self.error(
                &format!("{key}.moment_about"),
                span,
                format!("{point:?} must be three finite coordinates (m)"),
            ));
        }
        Ok(Vector3::from(point))
    }

    /// The axes a constraint holds: those of `fix`, or all three without it. An empty `fix`
    /// is an error: it would constrain nothing, surely not what was meant.
    fn constrained_axes(
        &self,
        c: &super::ConstraintSpec,
        key: &str,
        span: &Range<usize>,
    ) -> Result<[bool; 3]> {
        let mut axes = [false; 3];
        match &c.fix {
            Some(list) if list.is_empty() => {
                return Err(self.error(&format!("{key}.fix"), span, "lists no axis"));
            }
            Some(list) => list.iter().for_each(|a| axes[a.index()] = true),
            None => axes = [true; 3],
        }
        Ok(axes)
    }

    /// The `[[loads]]` entries at `time` (see [`BuiltLoads`]); `constraints` are there to warn
    /// about a load that only acts on constrained DOFs.
    fn build_loads<E: SceneElement>(
        &self,
        ctx: &Context<'_, E>,
        materials: &MaterialMap,
        named: &HashMap<String, Amplitude>,
        time: f64,
        constraints: &Constraints,
    ) -> Result<BuiltLoads> {
        let mesh = ctx.mesh;
        let mut loads = Loads::new(mesh);
        let mut other_loads = Loads::new(mesh);
        let mut gravity = Vector3::zeros();
        let mut timed = Vec::new();
        let mut input_warnings = Vec::new();
        for (i, l) in self.spec().loads.iter().enumerate() {
            let key = format!("loads[{i}]");
            let before = loads.as_slice().to_vec();
            let amplitude = match &l.get_ref().amplitude {
                Some(r) => self.amplitude_of(r, named, &format!("{key}.amplitude"), &l.span())?,
                None => Amplitude::default(),
            };
            input_warnings.extend(self.amplitude_warnings(&format!("{key}.amplitude"), &amplitude));
            if !amplitude.is_one() {
                // Kept apart: the dynamic system scales it by a(t) at each step.
                let mut single = Loads::new(mesh);
                ctx.add_load(&mut single, materials, l.get_ref(), &key, &l.span())?;
                loads
                    .add_scaled(&single, amplitude.value(time))
                    .map_err(|e| self.error(&key, &l.span(), e.to_string()))?;
                // The load itself, not its value at this time (a ramp is 0 at the start).
                let zero = vec![0.0; single.as_slice().len()];
                if let Some(warning) =
                    on_fixed_dofs_only(&key, &zero, single.as_slice(), constraints)
                {
                    input_warnings.push(warning);
                }
                timed.push((single, amplitude));
                continue;
            }
            ctx.add_load(&mut loads, materials, l.get_ref(), &key, &l.span())?;
            if let Some(warning) = on_fixed_dofs_only(&key, &before, loads.as_slice(), constraints)
            {
                input_warnings.push(warning);
            }
            match l.get_ref().gravity {
                Some(g) => gravity += Vector3::from(g),
                None => ctx.add_load(&mut other_loads, materials, l.get_ref(), &key, &l.span())?,
            }
        }
        Ok(BuiltLoads {
            loads,
            other_loads,
            gravity,
            timed,
            warnings: input_warnings,
        })
    }

    /// The `[[probes]]` entries: a node set (`where`) or a point (`at`), each under a unique
    /// name that can head a CSV column.
    fn build_probes<E: SceneElement>(&self, ctx: &Context<'_, E>) -> Result<Vec<Probe>> {
        let mut probes: Vec<Probe> = Vec::new();
        for (i, p) in self.spec().probes.iter().enumerate() {
            let key = format!("probes[{i}]");
            let span = p.span();
            let p = p.get_ref();
            if p.name.is_empty() || p.name.contains([',', '"', '\n']) {
                return Err(self.error(
                    &format!("{key}.name"),
                    &span,
                    "must be non-empty, without commas or quotes",
                ));
            }
            // Two probes of one name would write two CSV columns of one name and two summary
            // entries nobody can tell apart.
            if let Some(j) = probes.iter().position(|q| q.name == p.name) {
                return Err(self.error(
                    &format!("{key}.name"),
                    &span,
                    format!(
                        "duplicate probe name '{}' (probes[{j}] has it already); names must be unique",
                        p.name
                    ),
                ));
            }
            probes.push(match (&p.select, p.at) {
                (Some(select), None) => Probe {
                    name: p.name.clone(),
                    nodes: ctx.nodes(select, &key, &span)?,
                    point: None,
                },
                (None, Some(at)) => self.point_probe(ctx.mesh, &p.name, at, &key, &span)?,
                _ => {
                    return Err(self.error(
                        &key,
                        &span,
                        "needs exactly one of `where` (a node set: their mean displacement) \
                         and `at` (a point [x, y, z] in m: u and σ there)",
                    ));
                }
            });
        }
        Ok(probes)
    }

    /// Warnings about the amplitude at `key` for this scene's analysis: zero over a dynamic
    /// run's whole span [0, steps·dt] ([`Warning::AmplitudeVanishes`]), a sine above the
    /// Nyquist frequency 1/(2·dt) ([`Warning::AliasedAmplitude`]), or a time-varying one that a
    /// static analysis takes at [`STATIC_TIME`] ([`Warning::StaticAmplitude`]).
    fn amplitude_warnings(&self, key: &str, amplitude: &Amplitude) -> Vec<Warning> {
        let mut warnings = Vec::new();
        match self.analysis() {
            super::Analysis::Dynamic(d) => {
                let end = d.steps() as f64 * d.dt;
                if amplitude.vanishes_on(0.0, end) {
                    warnings.push(Warning::AmplitudeVanishes {
                        key: key.to_string(),
                        from: 0.0,
                        to: end,
                    });
                }
                if let Some(f) = amplitude.frequency_hz().filter(|f| f * d.dt > 0.5) {
                    warnings.push(Warning::AliasedAmplitude {
                        key: key.to_string(),
                        frequency_hz: f,
                        dt: d.dt,
                    });
                }
            }
            super::Analysis::Static if !amplitude.is_constant() => {
                warnings.push(Warning::StaticAmplitude {
                    key: key.to_string(),
                    time: STATIC_TIME,
                    value: amplitude.value(STATIC_TIME),
                });
            }
            _ => {}
        }
        warnings
    }

    /// The `[[amplitudes]]` entries by name; errors name the entry and its line (a bad
    /// amplitude, an empty or duplicate name).
    pub(super) fn named_amplitudes(&self) -> Result<HashMap<String, Amplitude>> {
        let mut named = HashMap::new();
        for (i, a) in self.spec().amplitudes.iter().enumerate() {
            let key = format!("amplitudes[{i}]");
            let span = a.span();
            let spec = a.get_ref();
            if spec.name.is_empty() {
                return Err(self.error(&format!("{key}.name"), &span, "must not be empty"));
            }
            if named.contains_key(&spec.name) {
                return Err(self.error(
                    &format!("{key}.name"),
                    &span,
                    format!("duplicate amplitude name '{}'", spec.name),
                ));
            }
            let amplitude = self.amplitude_from(&spec.amplitude(), &key, &span)?;
            named.insert(spec.name.clone(), amplitude);
        }
        Ok(named)
    }

    /// The amplitude `r` refers to (a name of `named`, or given in place at `key`).
    pub(super) fn amplitude_of(
        &self,
        r: &AmplitudeRef,
        named: &HashMap<String, Amplitude>,
        key: &str,
        span: &Range<usize>,
    ) -> Result<Amplitude> {
        match r {
            AmplitudeRef::Inline(spec) => self.amplitude_from(spec, key, span),
            AmplitudeRef::Named(name) => named.get(name).cloned().ok_or_else(|| {
                let mut known: Vec<&str> = named.keys().map(String::as_str).collect();
                known.sort_unstable();
                self.error(
                    key,
                    span,
                    format!(
                        "unknown amplitude '{name}' (the [[amplitudes]] entries are: {})",
                        if known.is_empty() {
                            "none".to_string()
                        } else {
                            known.join(", ")
                        }
                    ),
                )
            }),
        }
    }

    /// The amplitude of the keys at `key`: exactly one of constant, table, ramp, smooth_step,
    /// sine, each checked (errors name `key.<kind>` and the line).
    fn amplitude_from(
        &self,
        spec: &AmplitudeSpec,
        key: &str,
        span: &Range<usize>,
    ) -> Result<Amplitude> {
        let given: Vec<&str> = [
            ("constant", spec.constant.is_some()),
            ("table", spec.table.is_some()),
            ("ramp", spec.ramp.is_some()),
            ("smooth_step", spec.smooth_step.is_some()),
            ("sine", spec.sine.is_some()),
        ]
        .iter()
        .filter(|(_, set)| *set)
        .map(|(k, _)| *k)
        .collect();
        if given.len() != 1 {
            return Err(self.error(
                key,
                span,
                format!(
                    "an amplitude needs exactly one of constant, table, ramp, smooth_step, sine (found: {})",
                    if given.is_empty() { "none".into() } else { given.join(", ") }
                ),
            ));
        }
        let at = |e: Error| self.error(&format!("{key}.{}", given[0]), span, e.to_string());
        if let Some(c) = spec.constant {
            if !c.is_finite() {
                return Err(at(Error::invalid_parameter(
                    "constant",
                    c,
                    "must be finite",
                )));
            }
            return Ok(Amplitude::Constant(c));
        }
        if let Some(points) = &spec.table {
            let (times, values) = points.iter().map(|p| (p[0], p[1])).unzip();
            return Amplitude::table(times, values).map_err(at);
        }
        if let Some(r) = spec.ramp {
            return Amplitude::ramp(r.start, r.end).map_err(at);
        }
        if let Some(r) = spec.smooth_step {
            return Amplitude::smooth_step(r.start, r.end).map_err(at);
        }
        match spec.sine {
            Some(s) => Amplitude::sine(s.amplitude, s.frequency_hz, s.phase, s.start).map_err(at),
            None => Ok(Amplitude::default()),
        }
    }

    /// The motion of a `[[constraints]]` entry with `linear_field`, `rigid_motion` or a
    /// `displacement` with an amplitude (`None` for a plain fixed or prescribed one). Errors
    /// name the key and line: two kinds at once, an amplitude with nothing to scale, a
    /// non-finite linear field, a rigid-motion axis of zero length.
    fn motion_of(
        &self,
        c: &super::ConstraintSpec,
        named: &HashMap<String, Amplitude>,
        key: &str,
        span: &Range<usize>,
    ) -> Result<Option<Motion>> {
        let kinds: Vec<&str> = [
            ("displacement", c.displacement.is_some()),
            ("linear_field", c.linear_field.is_some()),
            ("rigid_motion", c.rigid_motion.is_some()),
        ]
        .iter()
        .filter(|(_, set)| *set)
        .map(|(k, _)| *k)
        .collect();
        if kinds.len() > 1 {
            return Err(self.error(
                key,
                span,
                format!(
                    "give one of displacement, linear_field, rigid_motion (found: {})",
                    kinds.join(", ")
                ),
            ));
        }
        let amplitude = match &c.amplitude {
            Some(r) => Some(self.amplitude_of(r, named, &format!("{key}.amplitude"), span)?),
            None => None,
        };
        if let Some(field) = &c.linear_field {
            let key = format!("{key}.linear_field");
            let matrix = Matrix3::from_fn(|i, j| field.matrix[i][j]);
            let motion =
                Motion::linear_field(matrix, field.b.into(), amplitude.unwrap_or_default())
                    .map_err(|e| {
                        let entry = match &e {
                            Error::InvalidParameter { name, .. } => format!("{key}.{name}"),
                            _ => key.clone(),
                        };
                        self.error(&entry, span, e.to_string())
                    })?;
            return Ok(Some(motion));
        }
        if let Some(rigid) = &c.rigid_motion {
            let key = format!("{key}.rigid_motion");
            let inner = match &rigid.amplitude {
                Some(r) => Some(self.amplitude_of(r, named, &format!("{key}.amplitude"), span)?),
                None => None,
            };
            if inner.is_some() && amplitude.is_some() {
                return Err(self.error(
                    &format!("{key}.amplitude"),
                    span,
                    "the amplitude is given twice (inside rigid_motion and next to it); keep one",
                ));
            }
            let axis = Vector3::from(rigid.axis);
            if axis.norm() == 0.0 || !axis.norm().is_finite() {
                return Err(self.error(
                    &format!("{key}.axis"),
                    span,
                    format!(
                        "[{}, {}, {}] must be finite with a non-zero length",
                        axis.x, axis.y, axis.z
                    ),
                ));
            }
            let motion = RigidMotion::new(
                axis,
                rigid.point.into(),
                rigid.angle_deg.to_radians(),
                rigid.translation.into(),
                inner.or(amplitude).unwrap_or_default(),
            )
            .map_err(|e| {
                let entry = match &e {
                    Error::InvalidParameter { name, .. } if name.ends_with("angle") => {
                        format!("{key}.angle_deg")
                    }
                    _ => key.clone(),
                };
                self.error(&entry, span, e.to_string())
            })?;
            return Ok(Some(Motion::Rigid(motion)));
        }
        match (c.displacement, amplitude) {
            (Some(d), Some(amplitude)) if !amplitude.is_one() => Ok(Some(Motion::Uniform {
                displacement: d.into(),
                amplitude,
            })),
            (None, Some(_)) => Err(self.error(
                &format!("{key}.amplitude"),
                span,
                "scales nothing: give displacement, linear_field or rigid_motion with it",
            )),
            _ => Ok(None),
        }
    }
}

/// The TetGen file prefix a scene's `file` names: the path without a `.node` or `.ele`
/// extension, any other path as it is (`bar.1` for `bar.1.node`).
pub(crate) fn tetgen_prefix(path: &Path) -> PathBuf {
    match path.extension().and_then(|e| e.to_str()) {
        Some("node") | Some("ele") => path.with_extension(""),
        _ => path.to_path_buf(),
    }
}

impl Scene {
    /// A quadratic file read as 4-node tets (its corners) means the file changed since the
    /// scene was parsed (which took the order from it): an error naming `mesh.order`.
    fn check_kept_order<C: CellType>(&self, imported: &ImportedMesh<C>) -> Result<()> {
        match imported.skipped_elements.get(TET10_KEPT_AS_CORNERS) {
            Some(&count) => Err(self.error(
                "mesh.order",
                &self.spec().mesh.span(),
                format!(
                    "the mesh file holds {count} 10-node tets (order 2), but the scene was \
                     read for order 1: was the file replaced? Load the scene again"
                ),
            )),
            None => Ok(()),
        }
    }

    /// The material of every tet: each `[[materials]]` entry claims the tets of its `where`
    /// (a Gmsh volume group, a box over tet centroids or a TetGen region attribute), and
    /// `[material]`, if given, covers the rest (and is returned too). Errors name the entry and its line: an invalid
    /// material value, a selection holding no tet, a tet two entries claim, or (without
    /// `[material]`) a tet none claims.
    fn materials<C: CellType>(
        &self,
        mesh: &TetMesh<C>,
        imported: Option<&ImportedMesh<C>>,
        body_of_tet: Option<&[usize]>,
    ) -> Result<(MaterialMap, Option<Material>)> {
        let spec = self.spec();
        let material_at = |m: &super::MaterialSpec, key: &str, span: &Range<usize>| {
            Material::new(m.youngs_modulus, m.poisson_ratio, m.density).map_err(|e| {
                let key = match &e {
                    Error::InvalidMaterial { field, .. } => format!("{key}.{field}"),
                    _ => key.to_string(),
                };
                self.error(&key, span, e.to_string())
            })
        };
        let default = match &spec.material {
            Some(m) => Some(material_at(m.get_ref(), "material", &m.span())?),
            None if spec.materials.is_empty() => {
                return Err(self.error(
                    "material",
                    &(0..0),
                    "the scene has no material: add [material] (every tet) or [[materials]] \
                     entries with a 'where' (per region)",
                ));
            }
            None => None,
        };
        let mut assignment = MaterialAssignment::new(mesh.tet_count());
        for (i, r) in spec.materials.iter().enumerate() {
            let key = format!("materials[{i}]");
            let span = r.span();
            let r = r.get_ref();
            let material = material_at(&r.material(), &key, &span)?;
            let at = |e: Error| self.error(&format!("{key}.where"), &span, e.to_string());
            let claimed = match &r.select {
                RegionSelector::Group(name) => {
                    let Some(imported) = imported.filter(|i| !i.groups.is_empty()) else {
                        return Err(self.error(
                            &format!("{key}.where"),
                            &span,
                            "a group selection needs a Gmsh mesh with physical volumes",
                        ));
                    };
                    let tets = volume_group_tets(imported, name).map_err(at)?;
                    assignment.assign(key.clone(), material, tets.iter().copied())
                }
                RegionSelector::Box { min, max } => {
                    assignment.assign_box(mesh, key.clone(), material, (*min).into(), (*max).into())
                }
                RegionSelector::Body(b) => {
                    let tets = items_of_body(body_of_tet, *b)
                        .map_err(|e| self.error(&format!("{key}.where.body"), &span, e))?;
                    assignment.assign(key.clone(), material, tets)
                }
                RegionSelector::Attribute(value) => {
                    let Some(imported) = imported else {
                        return Err(self.error(
                            &format!("{key}.where"),
                            &span,
                            "an attribute selection needs a TetGen mesh with tet attributes",
                        ));
                    };
                    let tets = attribute_tets(imported, *value).map_err(at)?;
                    if tets.is_empty() {
                        let known: Vec<String> = imported
                            .attribute_counts()
                            .iter()
                            .map(|(a, n)| format!("{a} ({n} tets)"))
                            .collect();
                        return Err(self.error(
                            &format!("{key}.where.attribute"),
                            &span,
                            format!(
                                "the mesh has no tet with region attribute {value} (it has: {})",
                                known.join(", ")
                            ),
                        ));
                    }
                    assignment.assign(key.clone(), material, tets)
                }
            }
            .map_err(|e| self.error(&key, &span, e.to_string()))?;
            if claimed == 0 {
                return Err(self.error(
                    &format!("{key}.where"),
                    &span,
                    "the selection holds no tet",
                ));
            }
        }
        let (last_key, last_span) = match spec.materials.last() {
            Some(r) => (format!("materials[{}]", spec.materials.len() - 1), r.span()),
            None => ("material".to_string(), 0..0),
        };
        let map = assignment.finish(default).map_err(|e| {
            self.error(
                &last_key,
                &last_span,
                format!("{e} (no [material] covers the tets no [[materials]] entry claims)"),
            )
        })?;
        Ok((map, default))
    }
}

/// [`Warning::LoadOnFixedDofs`](tetfem::base::warning::Warning::LoadOnFixedDofs) if the load that
/// turned the force vector `before` into `after` is non-zero only on constrained DOFs.
fn on_fixed_dofs_only(
    key: &str,
    before: &[f64],
    after: &[f64],
    constraints: &Constraints,
) -> Option<tetfem::base::warning::Warning> {
    let loaded: Vec<usize> = (0..after.len())
        .filter(|&d| after[d] != before[d])
        .collect();
    let all_fixed = loaded.iter().all(|&d| constraints.get(d).is_some());
    (!loaded.is_empty() && all_fixed).then(|| tetfem::base::warning::Warning::LoadOnFixedDofs {
        load: key.to_string(),
        dofs: loaded.len(),
    })
}

/// The items (tets or nodes) of body `body` given each item's body (`None` without bodies);
/// a scene without bodies, or a body it does not have, is a message saying what there is.
fn items_of_body(
    body_of: Option<&[usize]>,
    body: usize,
) -> std::result::Result<Vec<usize>, String> {
    let Some(body_of) = body_of else {
        return Err(format!(
            "body {body}: the scene has no [[bodies]] or [self_contact] to number"
        ));
    };
    let count = body_of.iter().max().map_or(0, |&b| b + 1);
    if body >= count {
        return Err(format!(
            "body {body} does not exist (the scene has {count}, numbered from 0 in \
             [[bodies]] order)"
        ));
    }
    Ok((0..body_of.len()).filter(|&i| body_of[i] == body).collect())
}

/// `Ok` if `marker` is among `counts` (a marker → count table of `what` markers), else a
/// message listing the markers there are, with their counts.
fn known_marker(
    marker: i64,
    counts: &std::collections::BTreeMap<i64, usize>,
    what: &str,
) -> std::result::Result<(), String> {
    if counts.contains_key(&marker) {
        return Ok(());
    }
    let known: Vec<String> = counts
        .iter()
        .map(|(m, n)| format!("{m} ({n} {what}s)"))
        .collect();
    Err(format!(
        "the mesh has no {what} marker {marker} (it has: {})",
        if known.is_empty() {
            "none".into()
        } else {
            known.join(", ")
        }
    ))
}

struct Context<'a, E: ElementType> {
    scene: &'a Scene,
    mesh: &'a TetMesh<E>,
    imported: Option<&'a ImportedMesh<E>>,
    boundary: &'a [BoundaryFace],
    /// Each node's body, with `[[bodies]]` or `[self_contact]`.
    body_of_node: Option<&'a [usize]>,
}

impl<E: ElementType> Context<'_, E> {
    fn default_tolerance(&self) -> f64 {
        let (lo, hi) = self.mesh.bounding_box();
        1e-6 * (hi - lo).norm()
    }

    fn group(
        &self,
        name: &str,
        key: &str,
        span: &Range<usize>,
    ) -> Result<&tetfem::mesh::io::PhysicalGroup> {
        let Some(imported) = self.imported else {
            return Err(self
                .scene
                .error(key, span, "a group selection needs a Gmsh mesh"));
        };
        imported.group(name).ok_or_else(|| {
            let known: Vec<String> = imported.groups.iter().map(|g| g.label()).collect();
            self.scene.error(
                key,
                span,
                format!(
                    "the mesh has no physical group '{name}' (it has: {})",
                    if known.is_empty() {
                        "none".into()
                    } else {
                        known.join(", ")
                    }
                ),
            )
        })
    }

    /// The imported mesh if it has `.face` markers and `marker` among them; else an error at
    /// `key` listing the markers it has.
    fn face_marker(&self, marker: i64, key: &str, span: &Range<usize>) -> Result<&ImportedMesh<E>> {
        match self.imported {
            Some(i) if i.face_markers.is_some() => {
                known_marker(marker, &i.face_marker_counts(), "face")
                    .map_err(|e| self.scene.error(&format!("{key}.face_marker"), span, e))?;
                Ok(i)
            }
            _ => Err(self.scene.error(
                key,
                span,
                "a face_marker selection needs a TetGen mesh with a .face file that has markers",
            )),
        }
    }

    /// The selected nodes, ascending; empty → error.
    fn nodes(&self, select: &Selector, key: &str, span: &Range<usize>) -> Result<Vec<usize>> {
        let key = format!("{key}.where");
        let nodes = match select {
            Selector::All => (0..self.mesh.node_count()).collect(),
            Selector::Boundary => {
                let mut nodes: Vec<usize> = self.boundary.iter().flat_map(|f| f.nodes).collect();
                nodes.sort_unstable();
                nodes.dedup();
                nodes
            }
            Selector::Plane {
                axis,
                at,
                tolerance,
            } => {
                let tol = tolerance.unwrap_or_else(|| self.default_tolerance());
                self.mesh
                    .try_nodes_on_plane(axis.index(), *at, tol)
                    .map_err(|e| {
                        self.scene
                            .error(&format!("{key}.plane"), span, e.to_string())
                    })?
            }
            Selector::Box { min, max } => self.mesh.nodes_in_box((*min).into(), (*max).into()),
            Selector::Group(name) => self.group(name, &key, span)?.nodes.clone(),
            Selector::Marker(m) => match self.imported {
                Some(i) if i.node_markers.is_some() => {
                    known_marker(*m, &i.node_marker_counts(), "node")
                        .map_err(|e| self.scene.error(&format!("{key}.marker"), span, e))?;
                    i.nodes_with_marker(*m)
                }
                _ => {
                    return Err(self.scene.error(
                        &key,
                        span,
                        "a marker selection needs a TetGen mesh with node markers",
                    ));
                }
            },
            Selector::FaceMarker(m) => {
                self.face_marker(*m, &key, span)?;
                self.imported
                    .map(|i| i.nodes_with_face_marker(*m))
                    .unwrap_or_default()
            }
            Selector::Body(b) => items_of_body(self.body_of_node, *b)
                .map_err(|e| self.scene.error(&format!("{key}.body"), span, e))?,
            Selector::Nodes(list) => {
                if let Some(&bad) = list.iter().find(|&&n| n >= self.mesh.node_count()) {
                    return Err(self.scene.error(
                        &key,
                        span,
                        format!(
                            "node {bad} does not exist (the mesh has {} nodes)",
                            self.mesh.node_count()
                        ),
                    ));
                }
                let mut l = list.clone();
                l.sort_unstable();
                l.dedup();
                l
            }
        };
        if nodes.is_empty() {
            return Err(self
                .scene
                .error(&key, span, "the selection matches no node"));
        }
        Ok(nodes)
    }

    /// The selected boundary faces; empty → error.
    fn faces(
        &self,
        select: &Selector,
        key: &str,
        span: &Range<usize>,
    ) -> Result<Vec<BoundaryFace>> {
        let faces = match select {
            Selector::Group(name) => {
                let group = self.group(name, &format!("{key}.where"), span)?;
                group.boundary_faces(self.boundary)
            }
            Selector::FaceMarker(m) => {
                let imported = self.face_marker(*m, &format!("{key}.where"), span)?;
                imported.faces_with_marker(*m, self.boundary)
            }
            other => {
                let mut selected = vec![false; self.mesh.node_count()];
                for n in self.nodes(other, key, span)? {
                    selected[n] = true;
                }
                self.boundary
                    .iter()
                    .filter(|f| f.nodes.iter().all(|&n| selected[n]))
                    .copied()
                    .collect()
            }
        };
        if faces.is_empty() {
            return Err(self.scene.error(
                &format!("{key}.where"),
                span,
                "the selection holds no boundary face",
            ));
        }
        Ok(faces)
    }

    fn add_load(
        &self,
        loads: &mut Loads,
        materials: &MaterialMap,
        l: &super::LoadSpec,
        key: &str,
        span: &Range<usize>,
    ) -> Result<()> {
        let given: Vec<&str> = [
            ("gravity", l.gravity.is_some()),
            ("body_force", l.body_force.is_some()),
            ("total_force", l.total_force.is_some()),
            ("traction", l.traction.is_some()),
            ("pressure", l.pressure.is_some()),
            ("nodal_force", l.nodal_force.is_some()),
        ]
        .iter()
        .filter(|(_, set)| *set)
        .map(|(k, _)| *k)
        .collect();
        if given.len() != 1 {
            return Err(self.scene.error(
                key,
                span,
                format!(
                    "a load needs exactly one of gravity, body_force, total_force, traction, pressure, nodal_force (found: {})",
                    if given.is_empty() { "none".into() } else { given.join(", ") }
                ),
            ));
        }
        let at = |e: Error| self.scene.error(key, span, e.to_string());
        let needs_where = || {
            l.select.as_ref().ok_or_else(|| {
                self.scene
                    .error(key, span, format!("{} needs a 'where' selection", given[0]))
            })
        };
        if let Some(g) = l.gravity {
            if l.select.is_some() {
                return Err(self.scene.error(
                    &format!("{key}.where"),
                    span,
                    "gravity acts on the whole body; remove 'where'",
                ));
            }
            loads
                .add_gravity(self.mesh, materials, g.into())
                .map_err(at)?;
        } else if let Some(b) = l.body_force {
            if l.select.is_some() {
                return Err(self.scene.error(
                    &format!("{key}.where"),
                    span,
                    "a body force acts on the whole body; remove 'where'",
                ));
            }
            loads.add_body_force(self.mesh, b.into()).map_err(at)?;
        } else if let Some(f) = l.total_force {
            let faces = self.faces(needs_where()?, key, span)?;
            loads
                .add_total_force_on_faces(self.mesh, &faces, f.into())
                .map_err(at)?;
        } else if let Some(t) = l.traction {
            let faces = self.faces(needs_where()?, key, span)?;
            loads
                .add_traction(self.mesh, &faces, t.into())
                .map_err(at)?;
        } else if let Some(p) = l.pressure {
            if !p.is_finite() {
                return Err(self
                    .scene
                    .error(&format!("{key}.pressure"), span, "must be finite"));
            }
            let faces = self.faces(needs_where()?, key, span)?;
            for face in &faces {
                let normal = face.area_vector(self.mesh).map_err(at)?.normalize();
                loads
                    .add_traction(self.mesh, std::slice::from_ref(face), -normal * p)
                    .map_err(at)?;
            }
        } else if let Some(f) = l.nodal_force {
            let nodes = self.nodes(needs_where()?, key, span)?;
            for n in nodes {
                loads.add_nodal_force(n, f.into()).map_err(at)?;
            }
        }
        Ok(())
    }
}

impl<C: tetfem::ElementType> BuiltScene<C> {
    /// The load a static solve of this scene takes: the library's sum
    /// ([`tetfem::analysis::static_load_of`]) of `other_loads`, `gravity` and the amplitude
    /// loads of `time_data` at [`STATIC_TIME`] (N, every DOF). Equal to `loads` of a static
    /// scene up to round-off (`loads` is summed in the scene's order). For engines that
    /// assemble their own system (PETSc); the in-process run takes it through its
    /// [`definition`](Self::definition).
    pub fn static_load(&self) -> Result<Loads> {
        tetfem::analysis::static_load_of(
            &self.mesh,
            &self.materials,
            &self.other_loads,
            self.gravity,
            &self.time_data,
        )
    }
}

impl<C: CellType> BuiltScene<C> {
    /// The problem definition of this scene for the library's analyses
    /// ([`tetfem::analysis::Static`], [`tetfem::analysis::Modal`], …): its mesh, materials,
    /// constraints, loads, gravity, time data and motions, with the force model `model` and the
    /// obstacles' `contact`. A static run solves for the library's sum of these
    /// ([`Definition::static_load`](tetfem::analysis::Definition::static_load)), not `loads`.
    pub fn definition(
        &self,
        model: tetfem::model::ModelKind,
        contact: Option<tetfem::contact::Contact>,
    ) -> Result<tetfem::analysis::Definition<C>> {
        let builder =
            tetfem::analysis::Definition::builder(self.mesh.clone(), self.materials.clone())
                .model(model)
                .constraints(self.constraints.clone())?
                .loads(self.other_loads.clone())?
                .gravity(self.gravity)?
                .time_data(self.time_data.clone())
                .motions(self.motions.clone());
        let builder = match &self.bodies {
            Some(b) => builder.surface_contact(b.barrier, b.body_of_node.clone())?,
            None => builder,
        };
        match contact {
            Some(contact) => builder.contact(contact).build(),
            None => builder.build(),
        }
    }
}
