//! The scene file's schema: plain serde types, one per TOML table. Every table denies unknown
//! keys. Defaults are listed in [`super::REFERENCE`].

use std::path::PathBuf;
use tetfem::analysis::dynamics::NonlinearSolve;
pub use tetfem::analysis::dynamics::{MassKind, Method};
pub use tetfem::linalg::linear_solver::LinearMethod;

use serde::Deserialize;
use toml::Spanned;

/// The whole scene file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// A title for reports and pictures (default: the file stem).
    #[serde(default)]
    pub title: Option<String>,
    /// Where the mesh comes from.
    pub mesh: Spanned<MeshSpec>,
    /// The material: of every tet, or with `[[materials]]` of the tets none of them claims.
    #[serde(default)]
    pub material: Option<Spanned<MaterialSpec>>,
    /// Materials per region, each with a `where` selection of tets.
    #[serde(default)]
    pub materials: Vec<Spanned<RegionMaterialSpec>>,
    /// Dirichlet conditions, applied in order.
    #[serde(default)]
    pub constraints: Vec<Spanned<ConstraintSpec>>,
    /// Loads, summed.
    #[serde(default)]
    pub loads: Vec<Spanned<LoadSpec>>,
    /// Static or dynamic analysis (default: static).
    #[serde(default)]
    pub analysis: Option<Spanned<AnalysisSpec>>,
    /// What is written where.
    #[serde(default)]
    pub output: Option<Spanned<OutputSpec>>,
    /// Named node sets whose mean displacement is recorded in the time series.
    #[serde(default)]
    pub probes: Vec<Spanned<ProbeSpec>>,
    /// Named amplitudes a(t), referred to by name from constraints and loads.
    #[serde(default)]
    pub amplitudes: Vec<Spanned<NamedAmplitudeSpec>>,
    /// Rigid obstacles the body may touch (contact by the IPC barrier, see
    /// [`tetfem::contact`]).
    #[serde(default)]
    pub obstacles: Vec<Spanned<ObstacleSpec>>,
    /// The barrier's scales (defaults: [`tetfem::contact::ContactParameters::for_mesh`]).
    #[serde(default)]
    pub contact: Option<Spanned<ContactSpec>>,
    /// What solves the scene (default: tetfem itself; see the book's *PETSc and MPI* chapter).
    #[serde(default)]
    pub engine: Option<Spanned<super::engine::EngineKind>>,
    /// The PETSc engine's solver preset and options.
    #[serde(default)]
    pub petsc: Option<Spanned<super::engine::PetscSpec>>,
    /// Several bodies: each its own mesh (or a copy of `[mesh]`) placed by a rigid motion, with
    /// its own initial velocity; they touch through body–body contact (`[self_contact]`, on by
    /// default).
    #[serde(default)]
    pub bodies: Vec<Spanned<BodySpec>>,
    /// Body–body and self-contact on the boundary surface: the barrier's scales.
    #[serde(default)]
    pub self_contact: Option<Spanned<SelfContactSpec>>,
}

/// `[[bodies]]`: a body's mesh (its own `mesh`, or a copy of the scene's `[mesh.box]`) turned
/// by `rotation_angle` about `rotation_axis` (through the mesh's origin), then moved by
/// `translation`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// The body's own mesh: `{ box = {...} }`, `{ gmsh = { file = "..." } }` or
    /// `{ tetgen = { file = "..." } }`, as under `[mesh]` (its element order is `[mesh]`'s);
    /// default a copy of `[mesh]`, which must then be a box.
    #[serde(default)]
    pub mesh: Option<MeshSpec>,
    /// t (m; default 0).
    #[serde(default)]
    pub translation: [f64; 3],
    /// The rotation's axis (default z).
    #[serde(default = "z_axis")]
    pub rotation_axis: [f64; 3],
    /// The rotation's angle (degrees, right-handed; default 0).
    #[serde(default)]
    pub rotation_angle: f64,
    /// The body's initial velocity (m/s; default 0), added to `analysis.initial_velocity`.
    #[serde(default)]
    pub velocity: [f64; 3],
}

fn z_axis() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

/// `[self_contact]`: the surface barrier's scales and the friction between the surfaces.
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelfContactSpec {
    /// d̂ (m, > 0): surface pairs closer than it are pushed apart (default a tenth of the
    /// shortest surface edge at rest).
    #[serde(default)]
    pub distance: Option<f64>,
    /// κ (J/m², > 0): the barrier's stiffness (default E·h̄, the stiffest Young's modulus
    /// times the mean surface edge at rest: a pair's force is then of the order of E over an
    /// h̄ × d̂ strip).
    #[serde(default)]
    pub stiffness: Option<f64>,
    /// Coulomb's friction coefficient μ ≥ 0 between the surfaces (default 0: frictionless):
    /// IPC's lagged smoothed friction, its normal forces and tangent planes frozen at each
    /// backward-Euler or Newmark step's start (static and explicit runs refuse μ > 0).
    #[serde(default)]
    pub friction: Option<f64>,
    /// ε_v (m/s, > 0): friction's stick speed, relative tangential speeds below it creep
    /// (default 10⁻³ × the bounding-box diagonal per second).
    #[serde(default)]
    pub slip_velocity: Option<f64>,
}

/// `[[obstacles]]`: a rigid obstacle, of one `kind` with that kind's placement keys.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleSpec {
    /// `"half_space"` (`point`, `normal`), `"sphere"` (`center`, `radius`) or `"box"` (`min`
    /// and `max`, or `center`, `half_extents` and `rotation_deg`).
    pub kind: ObstacleKind,
    /// Its name in outputs (CSV columns `contact_<name>_fx_N`…; default `obstacle<i>`, i its
    /// index from 0).
    #[serde(default)]
    pub name: Option<String>,
    /// Coulomb's friction coefficient μ ≥ 0 (default 0: frictionless).
    #[serde(default)]
    pub friction: Option<f64>,
    /// Half-space: a point on its plane (m).
    #[serde(default)]
    pub point: Option<[f64; 3]>,
    /// Half-space: the normal pointing out of the obstacle, towards the body (any non-zero
    /// length).
    #[serde(default)]
    pub normal: Option<[f64; 3]>,
    /// Sphere and box: the centre (m).
    #[serde(default)]
    pub center: Option<[f64; 3]>,
    /// Sphere: the radius (m, > 0).
    #[serde(default)]
    pub radius: Option<f64>,
    /// Axis-aligned box: the min corner (m).
    #[serde(default)]
    pub min: Option<[f64; 3]>,
    /// Axis-aligned box: the max corner (m), above `min` on every axis.
    #[serde(default)]
    pub max: Option<[f64; 3]>,
    /// Box by centre: the half extents along its axes (m, each > 0).
    #[serde(default)]
    pub half_extents: Option<[f64; 3]>,
    /// Box by centre: its rotation about the z axis (degrees, default 0).
    #[serde(default)]
    pub rotation_deg: Option<f64>,
    /// Dynamic scenes: a constant velocity of the obstacle (m/s); its placement at time t is
    /// the given one moved by velocity·t. Not with `displacement`; refused in static scenes
    /// (a static solve has no seconds: give `displacement`).
    #[serde(default)]
    pub velocity: Option<[f64; 3]>,
    /// A translation of the obstacle (m) scaled by `amplitude`; its placement at time t is the
    /// given one moved by displacement·a(t). Dynamic scenes: t in seconds, `amplitude`
    /// required. Static scenes: t is the pseudo-time t ∈ [0, 1] (load step k of n at t = k/n),
    /// `amplitude` optional (default a ramp from 0 at t = 0 to 1 at t = 1: the whole
    /// displacement at the last load step).
    #[serde(default)]
    pub displacement: Option<[f64; 3]>,
    /// The amplitude a(t) of `displacement`: a name of `[[amplitudes]]` or an inline table.
    #[serde(default)]
    pub amplitude: Option<AmplitudeRef>,
    /// Dynamic scenes: a constant spin, the angular velocity ω (rad/s, a vector along the axis,
    /// right-handed) about the axis through `spin_axis_point`; the surface at x moves at
    /// ω × (x − p) plus the obstacle's translation, and friction's slip is measured against it.
    /// Only spins that leave the shape in place: a `half_space` about an axis along its
    /// `normal` (a turntable), a `sphere` about an axis through its `center` (a roller); a `box`
    /// cannot spin. Refused in static scenes (a static solve has no seconds).
    #[serde(default)]
    pub spin: Option<[f64; 3]>,
    /// The point p the spin's axis passes through (m; default the sphere's `center`, the
    /// half-space's `point`); it moves with the obstacle's translation.
    #[serde(default)]
    pub spin_axis_point: Option<[f64; 3]>,
}

/// The kinds of `[[obstacles]]`.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ObstacleKind {
    /// The half-space behind a plane (the ground).
    HalfSpace,
    /// A solid ball.
    Sphere,
    /// A solid box.
    Box,
}

/// `[contact]`: the barrier's scales, each defaulting to the library's rule.
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// d̂ (m, > 0): gaps below it are pushed open (default 10⁻³ × the bounding-box diagonal).
    #[serde(default)]
    pub activation_distance: Option<f64>,
    /// κ (Pa/m, > 0): the contact pressure is −κ·b′(d) (default E/h, h the mean boundary edge).
    #[serde(default)]
    pub stiffness: Option<f64>,
    /// ε_d (m, > 0): friction's stick distance per load step in static scenes (default d̂/10).
    #[serde(default)]
    pub slip_distance: Option<f64>,
    /// ε_v (m/s, > 0): friction's stick speed in dynamic scenes (default 10⁻³ × the
    /// bounding-box diagonal per second).
    #[serde(default)]
    pub slip_velocity: Option<f64>,
    /// The gap error a static frictionless solve drives the barrier to, in (0, 1) (default
    /// [`tetfem::contact::GAP_TOLERANCE`]; with friction the given d̂ stays).
    #[serde(default)]
    pub gap_tolerance: Option<f64>,
    /// f, a fraction of d̂ (dimensionless, 0 < f < 1; off by default): the impact-aware barrier
    /// stiffness of implicit dynamic scenes (backward_euler, newmark). At each step's start a
    /// boundary node outside d̂ takes its own κᵢ = max(κ, mᵢ·vₙ²/(2·Aᵢ·b(f·d̂))) (Pa/m; mᵢ its
    /// mass, vₙ its approach speed, Aᵢ its area weight) so that a landing node stops near f·d̂,
    /// where a time step resolves the impact; a node within d̂ keeps its κᵢ, so the barrier
    /// stays conservative. Static and explicit scenes keep κ
    /// ([`tetfem::contact::ContactParameters::impact_fraction`]).
    #[serde(default)]
    pub impact_fraction: Option<f64>,
}

/// An amplitude a(t): exactly one of `constant`, `table`, `ramp`, `smooth_step`, `sine`.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AmplitudeSpec {
    /// a(t) = c.
    #[serde(default)]
    pub constant: Option<f64>,
    /// Points `[[t, a], ...]` (t in s, strictly increasing): linear between, constant beyond.
    #[serde(default)]
    pub table: Option<Vec<[f64; 2]>>,
    /// 0 before `start`, linear to 1 at `end`, 1 after.
    #[serde(default)]
    pub ramp: Option<IntervalSpec>,
    /// The quintic (C²) smooth step 10s³ − 15s⁴ + 6s⁵ from 0 at `start` to 1 at `end`.
    #[serde(default)]
    pub smooth_step: Option<IntervalSpec>,
    /// A·sin(2πf(t − start) + φ).
    #[serde(default)]
    pub sine: Option<SineSpec>,
}

/// `[[amplitudes]]`: a named amplitude (the keys of [`AmplitudeSpec`] and `name`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NamedAmplitudeSpec {
    /// The name constraints and loads refer to.
    pub name: String,
    /// a(t) = c.
    #[serde(default)]
    pub constant: Option<f64>,
    /// Points `[[t, a], ...]`.
    #[serde(default)]
    pub table: Option<Vec<[f64; 2]>>,
    /// A ramp.
    #[serde(default)]
    pub ramp: Option<IntervalSpec>,
    /// A smooth step.
    #[serde(default)]
    pub smooth_step: Option<IntervalSpec>,
    /// A sine.
    #[serde(default)]
    pub sine: Option<SineSpec>,
}

impl NamedAmplitudeSpec {
    /// The amplitude keys alone.
    pub fn amplitude(&self) -> AmplitudeSpec {
        AmplitudeSpec {
            constant: self.constant,
            table: self.table.clone(),
            ramp: self.ramp,
            smooth_step: self.smooth_step,
            sine: self.sine,
        }
    }
}

/// A time interval (s).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct IntervalSpec {
    /// Start (s, default 0).
    #[serde(default)]
    pub start: f64,
    /// End (s), after start.
    pub end: f64,
}

/// A sine amplitude A·sin(2πf(t − start) + φ).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SineSpec {
    /// A (default 1).
    #[serde(default = "one")]
    pub amplitude: f64,
    /// f (Hz).
    pub frequency_hz: f64,
    /// φ (radians, default 0).
    #[serde(default)]
    pub phase: f64,
    /// When it starts (s, default 0); a(t) = A·sin(φ) before.
    #[serde(default)]
    pub start: f64,
}

fn one() -> f64 {
    1.0
}

/// `amplitude = "name"` (a `[[amplitudes]]` entry) or an inline amplitude table.
#[derive(Debug, Clone, PartialEq)]
pub enum AmplitudeRef {
    /// The name of an `[[amplitudes]]` entry.
    Named(String),
    /// An amplitude given in place.
    Inline(AmplitudeSpec),
}

/// What an `amplitude` key allows, for its error messages.
const AMPLITUDE_ALLOWED: &str = "the name of an [[amplitudes]] entry, or an inline table of exactly one of constant = a, table = [[t, a], ...] (rows of two numbers: time in s, value), ramp = { start, end }, smooth_step = { start, end }, sine = { frequency_hz, amplitude, phase, start }";

/// The first row of an inline amplitude's `table` that is not two values, described.
fn table_row_error(amplitude: &toml::Table) -> Option<String> {
    let rows = amplitude.get("table")?.as_array()?;
    let (i, row) = rows
        .iter()
        .enumerate()
        .find(|(_, row)| row.as_array().is_none_or(|r| r.len() != 2))?;
    let found = match row.as_array() {
        Some(r) => format!("{} values", r.len()),
        None => format!("a {}", row.type_str()),
    };
    Some(format!(
        "table: row {} ({row}) holds {found}, not two (time in s, value)",
        i + 1
    ))
}

/// By hand rather than `#[serde(untagged)]`, whose only error ("data did not match any variant
/// of untagged enum") says neither what was wrong nor what is allowed: a string is a name, a
/// table an inline amplitude whose own error (e.g. a `table` row of 3 numbers) is kept.
impl<'de> Deserialize<'de> for AmplitudeRef {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        match toml::Value::deserialize(deserializer)? {
            toml::Value::String(name) => Ok(AmplitudeRef::Named(name)),
            toml::Value::Table(t) => {
                let message = match table_row_error(&t) {
                    Some(row) => row,
                    None => match AmplitudeSpec::deserialize(toml::Value::Table(t)) {
                        Ok(spec) => return Ok(AmplitudeRef::Inline(spec)),
                        Err(e) => e.message().trim().to_string(),
                    },
                };
                Err(D::Error::custom(format!(
                    "{message}; allowed: {AMPLITUDE_ALLOWED}"
                )))
            }
            other => Err(D::Error::custom(format!(
                "found a {}; allowed: {AMPLITUDE_ALLOWED}",
                other.type_str()
            ))),
        }
    }
}

/// `linear_field = { A = [[..], [..], [..]], b = [..] }`: u = A·x + b (A dimensionless, b in m).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LinearFieldSpec {
    /// A, by rows.
    #[serde(rename = "A")]
    pub matrix: [[f64; 3]; 3],
    /// b (m, default zero).
    #[serde(default)]
    pub b: [f64; 3],
}

/// `rigid_motion = { axis, point, angle_deg, translation, amplitude }`: rotation by
/// θ(t) = angle·a(t) about the line through `point` along `axis`, then translation·a(t).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RigidMotionSpec {
    /// The rotation axis (any non-zero length).
    pub axis: [f64; 3],
    /// A point on the axis (m, default the origin).
    #[serde(default)]
    pub point: [f64; 3],
    /// θ_max (degrees, default 0).
    #[serde(default)]
    pub angle_deg: f64,
    /// d (m, default zero).
    #[serde(default)]
    pub translation: [f64; 3],
    /// a(t) (default constant 1).
    #[serde(default)]
    pub amplitude: Option<AmplitudeRef>,
}

/// `[mesh.box]`, `[mesh.gmsh]` or `[mesh.tetgen]` (exactly one). The `[mesh]` table may also
/// hold `order` (1 or 2), which [`Scene::order`](super::Scene::order) reads and checks.
#[derive(Debug, Clone, Deserialize)]
#[serde(try_from = "MeshTable")]
pub enum MeshSpec {
    /// A structured box grid.
    Box(BoxSpec),
    /// A Gmsh `.msh` file (4.1 ASCII/binary or 2.2 ASCII).
    Gmsh(FileSpec),
    /// TetGen files: `file` is the prefix or the `.node` file.
    Tetgen(FileSpec),
}

/// The `[mesh]` table as written: its source (one of three sub-tables) and `order`, which is
/// read with its line by [`Scene::order`](super::Scene::order) (here only let through).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshTable {
    #[serde(default)]
    order: Option<toml::Value>,
    #[serde(default, rename = "box")]
    grid: Option<BoxSpec>,
    #[serde(default)]
    gmsh: Option<FileSpec>,
    #[serde(default)]
    tetgen: Option<FileSpec>,
}

impl TryFrom<MeshTable> for MeshSpec {
    type Error = String;

    fn try_from(table: MeshTable) -> Result<Self, String> {
        let _ = table.order;
        match (table.grid, table.gmsh, table.tetgen) {
            (Some(b), None, None) => Ok(MeshSpec::Box(b)),
            (None, Some(f), None) => Ok(MeshSpec::Gmsh(f)),
            (None, None, Some(f)) => Ok(MeshSpec::Tetgen(f)),
            _ => Err(
                "[mesh] needs exactly one of [mesh.box], [mesh.gmsh], [mesh.tetgen]".to_string(),
            ),
        }
    }
}

/// `[mesh] order`: the element order (1: 4-node tets, 2: 10-node tets); only the key, with its
/// value unchecked and its position, so that a wrong value is an error naming its line.
#[derive(Debug, Clone, Default, Deserialize)]
pub(crate) struct OrderOnly {
    #[serde(default)]
    pub(crate) mesh: Option<OrderTable>,
}

/// The `order` key of `[mesh]`, the rest of the table ignored.
#[derive(Debug, Clone, Default, Deserialize)]
pub(crate) struct OrderTable {
    #[serde(default)]
    pub(crate) order: Option<Spanned<toml::Value>>,
}

/// A box grid [min, max] with `cells` cells per axis.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    /// Min corner (default: the origin).
    #[serde(default)]
    pub min: [f64; 3],
    /// Max corner.
    pub max: [f64; 3],
    /// Cells along x, y, z.
    pub cells: [usize; 3],
    /// How each cell is split into tets (default: `mirrored6`).
    #[serde(default)]
    pub split: SplitSpec,
}

/// Cube split of a box grid.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SplitSpec {
    /// The lecture's 6-tet table in every cell (leans sideways in bending, see
    /// [`tetfem::BoxSplit::Lecture6`]).
    Lecture6,
    /// The lecture's table mirrored in alternate cells: mirror-symmetric for even cell counts.
    #[default]
    Mirrored6,
    /// Five tets per cube, alternating.
    Five,
}

/// A mesh file, relative to the scene file's folder.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileSpec {
    /// The path.
    pub file: PathBuf,
}

/// `[material]`: an isotropic linear elastic material (SI in the shipped scenes).
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Young's modulus E (Pa).
    pub youngs_modulus: f64,
    /// Poisson's ratio ν.
    pub poisson_ratio: f64,
    /// Density ρ (kg/m³).
    pub density: f64,
}

/// `[[materials]]`: a material (the keys of `[material]`) for the tets of a region.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionMaterialSpec {
    /// Young's modulus E (Pa).
    pub youngs_modulus: f64,
    /// Poisson's ratio ν.
    pub poisson_ratio: f64,
    /// Density ρ (kg/m³).
    pub density: f64,
    /// The region's force model (default `analysis.model`): `"linear"`, `"corotational"`,
    /// `"neo-hookean"` or `"st-venant-kirchhoff"`. A model is a material region's (the library
    /// holds one per material), so a body takes its own through a region `where = { body = N }`
    /// — a linear block beside a Neo-Hookean one. Every analysis but a modal one (linear
    /// regions only) and the mixed formulation (one model for all).
    #[serde(default)]
    pub model: Option<String>,
    /// The tets it covers.
    #[serde(rename = "where")]
    pub select: RegionSelector,
}

impl RegionMaterialSpec {
    /// The material keys alone.
    pub fn material(&self) -> MaterialSpec {
        MaterialSpec {
            youngs_modulus: self.youngs_modulus,
            poisson_ratio: self.poisson_ratio,
            density: self.density,
        }
    }
}

/// A set of tets for `[[materials]]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum RegionSelector {
    /// `{ group = "steel" }` or `{ group = "3" }`: a Gmsh physical volume by name or tag.
    Group(String),
    /// `{ box = { min = [..], max = [..] } }`: the tets whose centroid lies in the closed box
    /// (m).
    Box {
        /// Min corner.
        min: [f64; 3],
        /// Max corner.
        max: [f64; 3],
    },
    /// `{ attribute = 2 }`: TetGen tets with this region attribute.
    Attribute(f64),
    /// `{ body = 1 }`: the tets of `[[bodies]]` entry 1 (numbered from 0).
    Body(usize),
}

/// A coordinate axis.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    /// x
    X,
    /// y
    Y,
    /// z
    Z,
}

impl Axis {
    /// 0, 1 or 2.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

/// A set of nodes (or, for face loads, of boundary faces).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Selector {
    /// Every node / every boundary face: `"all"`.
    All,
    /// The nodes on the boundary (of some boundary face) / every boundary face: `"boundary"`.
    Boundary,
    /// `{ plane = { axis = "x", at = 0.0 } }`: nodes with |x\[axis\] − at| ≤ tolerance
    /// (default 1e-6 × the mesh's bounding-box diagonal); faces with all three nodes so.
    Plane {
        /// The axis normal to the plane.
        axis: Axis,
        /// The plane's coordinate.
        at: f64,
        /// Distance tolerance (length units).
        #[serde(default)]
        tolerance: Option<f64>,
    },
    /// `{ box = { min = [..], max = [..] } }`: nodes inside the closed box; faces with all
    /// three nodes inside.
    Box {
        /// Min corner.
        min: [f64; 3],
        /// Max corner.
        max: [f64; 3],
    },
    /// `{ group = "clamp" }` or `{ group = "3" }`: a Gmsh physical group by name or tag.
    Group(String),
    /// `{ marker = 1 }`: TetGen nodes with this boundary marker (`.node` file).
    Marker(i64),
    /// `{ face_marker = 3 }`: the TetGen `.face` triangles with this boundary marker (as a
    /// face set: those that are boundary faces; as a node set: their nodes).
    FaceMarker(i64),
    /// `{ nodes = [0, 5, 9] }`: explicit node indices.
    Nodes(Vec<usize>),
    /// `{ body = 1 }`: the nodes of `[[bodies]]` entry 1 (numbered from 0); faces: the boundary
    /// faces of that body.
    Body(usize),
}

/// `[[constraints]]`: fix (or prescribe) displacement components on a node set.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstraintSpec {
    /// The nodes.
    #[serde(rename = "where")]
    pub select: Selector,
    /// Which axes (default: all three).
    #[serde(default)]
    pub fix: Option<Vec<Axis>>,
    /// Prescribed displacement (length units) for the fixed axes (default: zero).
    #[serde(default)]
    pub displacement: Option<[f64; 3]>,
    /// The point (m) the reported moment of this entry's reactions is taken about (default:
    /// the origin).
    #[serde(default)]
    pub moment_about: Option<[f64; 3]>,
    /// u = A·x + b on the nodes (instead of `displacement`).
    #[serde(default)]
    pub linear_field: Option<LinearFieldSpec>,
    /// A rigid motion of the nodes (instead of `displacement`).
    #[serde(default)]
    pub rigid_motion: Option<RigidMotionSpec>,
    /// a(t) scaling `displacement` or `linear_field` (default constant 1).
    #[serde(default)]
    pub amplitude: Option<AmplitudeRef>,
}

/// `[[loads]]`: exactly one of `gravity`, `body_force`, `total_force`, `traction`, `pressure`,
/// `nodal_force`; all but the first two need `where`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadSpec {
    /// The faces (surface loads) or nodes (nodal forces).
    #[serde(default, rename = "where")]
    pub select: Option<Selector>,
    /// Gravitational acceleration (m/s²), e.g. `[0, 0, -9.81]`.
    #[serde(default)]
    pub gravity: Option<[f64; 3]>,
    /// Body force density (N/m³).
    #[serde(default)]
    pub body_force: Option<[f64; 3]>,
    /// A total force (N) spread uniformly over the selected faces' area.
    #[serde(default)]
    pub total_force: Option<[f64; 3]>,
    /// A uniform traction (Pa) on the selected faces.
    #[serde(default)]
    pub traction: Option<[f64; 3]>,
    /// A pressure (Pa) on the selected faces, pushing against their outward normal.
    #[serde(default)]
    pub pressure: Option<f64>,
    /// A force (N) on each selected node.
    #[serde(default)]
    pub nodal_force: Option<[f64; 3]>,
    /// a(t) scaling the load (default constant 1).
    #[serde(default)]
    pub amplitude: Option<AmplitudeRef>,
}

/// `[analysis]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnalysisSpec {
    /// `"static"` (default), `"dynamic"` or `"modal"`.
    #[serde(default, rename = "type")]
    pub kind: AnalysisKind,
    /// Modal: how many of the lowest modes (default 6; at most the free DOF count).
    #[serde(default)]
    pub modes: Option<usize>,
    /// Dynamic: `"backward_euler"` (default), `"explicit"` or `"newmark"`.
    #[serde(default)]
    pub method: Option<Method>,
    /// Dynamic: the time step (s); with `time_tolerance` the first step.
    #[serde(default)]
    pub dt: Option<f64>,
    /// Dynamic, implicit methods: the relative error of the trajectory asked for (0 < tol < 1):
    /// the step is chosen from an estimate of each step's local error
    /// ([`tetfem::analysis::transient::AdaptiveStep`]), `dt` is the first step, frames land on
    /// the multiples of `[output] every`·dt, and the summary reports the run's own error
    /// estimate. Unset (default): every step is `dt`.
    #[serde(default)]
    pub time_tolerance: Option<f64>,
    /// Dynamic: the simulated time (s).
    #[serde(default)]
    pub duration: Option<f64>,
    /// Dynamic: Rayleigh damping C = α·M + β·K (default: none).
    #[serde(default)]
    pub damping: Option<DampingSpec>,
    /// Dynamic and modal: `"lumped"` (default) or `"consistent"` mass.
    #[serde(default)]
    pub mass: Option<MassKind>,
    /// Dynamic: initial velocity of every node (m/s, default zero).
    #[serde(default)]
    pub initial_velocity: Option<[f64; 3]>,
    /// The force model, `"linear"` (default), `"corotational"`, `"neo-hookean"` or
    /// `"st-venant-kirchhoff"`. Static: the nonlinear ones are solved by Newton with load
    /// steps. Dynamic (every method): the implicit
    /// methods solve each step by Newton (iterations in the summary), the explicit one evaluates
    /// the nonlinear force; fixed constraints must be zero-valued. Each `[[materials]]` region
    /// gets its own model of this kind (static and dynamic) unless it names its own `model`.
    #[serde(default)]
    pub model: Option<String>,
    /// `"displacement"` (default) or `"mixed"`: the mixed displacement–pressure element
    /// (Taylor–Hood P2–P1 on 10-node tets, the stabilized P1–P1 on 4-node tets), which does not
    /// lock as Poisson's ratio approaches 0.5 (rubber: ν up to 0.4999…) and writes the pressure
    /// (Pa, positive in compression) as the `.vtu` point field `pressure`. Mixed: static scenes
    /// with the linear, the Neo-Hookean or the corotational model on either order; dynamic
    /// (`backward_euler`, `newmark`, `mass = "consistent"`) and modal scenes with the linear
    /// model, and `backward_euler` with the Neo-Hookean or the corotational model (undamped,
    /// still obstacles allowed), on either order; tetfem's own engine only, without
    /// `accuracy` or point probes; solved by a
    /// sparse LDLᵀ whatever `linear_solver` says.
    #[serde(default)]
    pub formulation: Option<String>,
    /// Static (linear model) and dynamic (implicit methods): how the linear systems are solved,
    /// `"auto"` (default: the Cholesky factorization when its factor fits the memory budget and
    /// is predicted faster), `"direct"` or `"iterative"` (multigrid-preconditioned CG).
    #[serde(default)]
    pub linear_solver: Option<LinearMethod>,
    /// Dynamic, implicit methods with a nonlinear model: how each Newton iteration solves,
    /// `"auto"` (default: `"refactor"` below 1,000 free DOFs, `"rest_lbfgs"` above, stopping
    /// no tighter than a `newton_tolerance` of 1e-3, with obstacles of 1e-4), `"rest_lbfgs"`
    /// (tangent-free L-BFGS whose initial inverse Hessian is the rest-state factor turned by
    /// the nodes' rotations, with obstacles also holding the contact nodes' barrier and
    /// friction stiffness, going on with `"rest_preconditioned"` when it runs out of
    /// iterations), `"rest_preconditioned"` (CG on
    /// the tangent preconditioned by that factor, with a fallback to factoring) or `"refactor"`
    /// (a factorization per Newton iteration).
    #[serde(default)]
    pub nonlinear_solver: Option<NonlinearSolverName>,
    /// Dynamic, implicit methods with a nonlinear model: each step's Newton tolerance,
    /// ‖r‖ ≤ t·max(‖r₀‖, ‖f‖), finite, > 0 and < 1 (default 1e-8: the steps of every
    /// `nonlinear_solver` agree to it). A loose one buys speed with accuracy; `"auto"`'s
    /// L-BFGS path already stops at no tighter than 1e-3 (1e-4 with obstacles), or once the
    /// correction left is under 1e-4 of the step's motion (on the swinging beam of the cost
    /// table in the book's *Large deformation* chapter, 1.8–2.0× a linear step's cost at
    /// 132,300 DOFs, the trajectory within 1e-4 of the refactoring one). Static, with a
    /// nonlinear model or obstacles: the Newton tolerance of each load step, ‖r_f‖ ≤ t·‖f_f‖
    /// (default 1e-10).
    #[serde(default)]
    pub newton_tolerance: Option<f64>,
    /// Dynamic, implicit methods with rigid obstacles: after each accepted Newton step that
    /// leaves the step short of its tolerance, move every node that touches an obstacle to the minimum of its own barrier and friction under
    /// the rest of the body's pull, where that lowers the step's potential and residual
    /// (default `true`, the library's
    /// [`StepNewtonOptions::relax_contact_nodes`](tetfem::analysis::dynamics::StepNewtonOptions::relax_contact_nodes)).
    /// The converged step solves the same equation to the same tolerance either way; `false`
    /// leaves the iterates to Newton alone (more iterations with contact).
    #[serde(default)]
    pub relax_contact_nodes: Option<bool>,
    /// Static, with a nonlinear model or obstacles: the loads and prescribed displacements are
    /// applied in this many equal increments, each solved by Newton (default 10, at most
    /// 100 000). More steps rescue a solve whose Newton fails (a large load, a first contact).
    #[serde(default)]
    pub load_steps: Option<usize>,
    /// Static: the target relative energy-norm error (0 < a < 1) tetfem chooses the element
    /// order and cells for (checked with its line by the accuracy module; here only let through).
    #[serde(default)]
    pub accuracy: Option<toml::Value>,
    /// Static with `accuracy`: the cap on 3 × nodes of the meshes tried (here only let through).
    #[serde(default)]
    pub max_dofs: Option<toml::Value>,
}

impl SceneSpec {
    /// `analysis.linear_solver` as the library's method ([`LinearMethod::Auto`] when unset).
    pub fn linear_method(&self) -> LinearMethod {
        self.analysis
            .as_ref()
            .and_then(|a| a.get_ref().linear_solver)
            .unwrap_or_default()
    }

    /// `analysis.nonlinear_solver` as the library's option ([`NonlinearSolve::default`] when
    /// unset).
    pub fn nonlinear_solve(&self) -> NonlinearSolve {
        self.analysis
            .as_ref()
            .and_then(|a| a.get_ref().nonlinear_solver)
            .unwrap_or_default()
            .solve()
    }
}

/// `analysis.nonlinear_solver`: the name of a [`NonlinearSolve`] (its default settings).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NonlinearSolverName {
    /// [`NonlinearSolve::Auto`]: refactoring on small meshes, L-BFGS on larger ones, stopping at
    /// no tighter than
    /// [`AUTO_LBFGS_TOLERANCE`](tetfem::analysis::dynamics::AUTO_LBFGS_TOLERANCE) without
    /// contact (or earlier when the correction left is below
    /// [`AUTO_LBFGS_CORRECTION`](tetfem::analysis::dynamics::AUTO_LBFGS_CORRECTION) of the
    /// step's motion) and
    /// [`AUTO_CONTACT_LBFGS_TOLERANCE`](tetfem::analysis::dynamics::AUTO_CONTACT_LBFGS_TOLERANCE)
    /// with obstacles; refactoring at every size with body–body contact.
    #[default]
    Auto,
    /// [`NonlinearSolve::RestPreconditionedCg`]: CG preconditioned by the rest-state factor
    /// turned by the nodes' rotations.
    RestPreconditioned,
    /// [`NonlinearSolve::RestPreconditionedLbfgs`]: tangent-free L-BFGS, its initial inverse
    /// Hessian the turned rest factor (with obstacles, holding the contact nodes' blocks).
    RestLbfgs,
    /// [`NonlinearSolve::Refactor`]: a factorization per Newton iteration.
    Refactor,
}

impl NonlinearSolverName {
    /// The library's option of this name.
    pub fn solve(self) -> NonlinearSolve {
        match self {
            NonlinearSolverName::Auto => NonlinearSolve::Auto,
            NonlinearSolverName::RestPreconditioned => NonlinearSolve::Auto
                .for_problem(tetfem::analysis::dynamics::AUTO_REFACTOR_BELOW, true),
            NonlinearSolverName::RestLbfgs => NonlinearSolve::RestPreconditionedLbfgs {
                history: tetfem::analysis::dynamics::AUTO_LBFGS_HISTORY,
            },
            NonlinearSolverName::Refactor => NonlinearSolve::Refactor,
        }
    }
}

/// Static, dynamic or modal.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AnalysisKind {
    /// Static equilibrium K·u = f.
    #[default]
    Static,
    /// Time integration of M·ü + C·u̇ + K·u = f.
    Dynamic,
    /// Natural frequencies and mode shapes, K·φ = ω²·M·φ.
    Modal,
}

/// Rayleigh damping coefficients.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct DampingSpec {
    /// α (1/s), the mass-proportional coefficient.
    #[serde(default)]
    pub mass: f64,
    /// β (s), the stiffness-proportional coefficient.
    #[serde(default)]
    pub stiffness: f64,
}

/// `[output]`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Output folder, relative to the scene file's folder (default: `out/<scene file stem>` in
    /// the working directory).
    #[serde(default)]
    pub directory: Option<PathBuf>,
    /// Write `.vtu` frames and a `.pvd` collection (default true).
    #[serde(default)]
    pub vtu: Option<bool>,
    /// Dynamic: write a frame every this many steps (default 1; the last step always).
    #[serde(default)]
    pub every: Option<usize>,
    /// Write the probes' time series as CSV (default true).
    #[serde(default)]
    pub csv: Option<bool>,
    /// Render PNG pictures of the deformed body (default false).
    #[serde(default)]
    pub png: Option<bool>,
    /// What colours the picture: `"displacement"` (default) or `"von_mises"`.
    #[serde(default)]
    pub png_field: Option<PngField>,
    /// Picture size in pixels (default [960, 600]).
    #[serde(default)]
    pub png_size: Option<[u32; 2]>,
    /// Displacement magnification in pictures; 0 (default) picks one that shows the largest
    /// displacement as 10 % of the body's size (never below 1).
    #[serde(default)]
    pub deformation_scale: Option<f64>,
    /// Static and modal runs: also find the explicit critical step for the summary (default
    /// false: it costs a Lanczos iteration and a factorization; dynamic runs always report it).
    #[serde(default)]
    pub critical_step: Option<bool>,
    /// Encoding of every `.vtu` written: `"binary"` (default, appended raw) or `"ascii"`.
    #[serde(default)]
    pub vtu_format: Option<VtuEncoding>,
    /// Dynamic: write `<stem>_checkpoint.bin` every this many steps (and at an interrupt),
    /// for `tetfem run --resume` (default 0: none; a non-negative integer).
    #[serde(default)]
    pub checkpoint_every: Option<usize>,
}

/// The encoding of the `.vtu` files (`[output] vtu_format`).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum VtuEncoding {
    /// Appended raw binary ([`tetfem::post::output::VtuFormat::Binary`]).
    #[default]
    Binary,
    /// Numbers as text ([`tetfem::post::output::VtuFormat::Ascii`]).
    Ascii,
}

impl VtuEncoding {
    /// The library's format.
    pub fn format(self) -> tetfem::post::output::VtuFormat {
        match self {
            VtuEncoding::Binary => tetfem::post::output::VtuFormat::Binary,
            VtuEncoding::Ascii => tetfem::post::output::VtuFormat::Ascii,
        }
    }
}

/// The field a picture is coloured by.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PngField {
    /// |u| per node.
    #[default]
    Displacement,
    /// Von Mises stress per tet.
    VonMises,
}

/// `[[probes]]`: the mean displacement of a node set (`where`), or the displacement and the
/// stress at a point (`at`), recorded in the time series. Exactly one of the two.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeSpec {
    /// Column prefix in the CSV (`<name>_ux`, `<name>_uy`, `<name>_uz`).
    pub name: String,
    /// The nodes.
    #[serde(rename = "where")]
    pub select: Option<Selector>,
    /// A point (m) inside the mesh: u and σ from the shape functions of the tet holding it.
    pub at: Option<[f64; 3]>,
}
