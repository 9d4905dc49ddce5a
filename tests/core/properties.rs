//! Property tests (proptest): the element stiffness spectrum, rigid-motion invariance of the
//! nonlinear force models, conformity and mass of box meshes, and the patch test.
//!
//! Every tolerance is round-off relative to the scale of the quantity it bounds. The margins
//! quoted next to each bound were measured over many more random cases than the properties run,
//! with `cargo test --release --test properties -- --ignored --nocapture` (`measure_margins`).

use crate::common;

use std::collections::HashMap;
use std::fmt;

use nalgebra::{Matrix3, Rotation3, SymmetricEigen, Unit, Vector3};
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{FileFailurePersistence, RngAlgorithm, RngSeed, TestRng, TestRunner};
use tetfem::fe::element::{Matrix12, Tet, Vector12, shape_quality, signed_volume};
use tetfem::mesh::box_node_index;
use tetfem::model::{Corotational, ForceModel, LinearModel, NeoHookean};
use tetfem::{
    Assembler, BoxSplit, Constraints, Loads, Material, TetMesh, lumped_mass, solve_static,
};

// ---------------------------------------------------------------------------------------------
// Tolerances. "Measured" numbers come from `measure_margins` (10⁶ random tets, 5 000 meshes);
// each bound keeps a factor of at least 10 to the worst value measured.

/// Random tets poorer than this are rejected before they reach a property.
const MIN_QUALITY: f64 = 0.05;

/// ‖Kₑ − Kₑᵀ‖_F ≤ this·‖Kₑ‖_F. Kₑ is symmetric by construction (each off-diagonal block is
/// stored with its transpose), so any asymmetry is a bug; an evaluation of the two triangles in
/// different orders would still agree to a few ε (2.2e-16). Measured: exactly 0.
const SYMMETRY_TOL: f64 = 1e-14;

/// The six rigid-mode eigenvalues satisfy |λ| ≤ this·λ_max. A 12×12 symmetric eigensolve is
/// backward stable: each eigenvalue is exact to about n·ε·‖Kₑ‖₂ ≈ 3e-15·λ_max, so the zero modes
/// come out at that size. Measured worst: 6.2e-16 (margin 160×).
const ZERO_EIGENVALUE_TOL: f64 = 1e-13;

/// The six deformation eigenvalues satisfy λ ≥ this·λ_max. The ratio is set by the conditioning
/// the generators allow: shape quality down to 0.05 (a thin tet: its smallest height is small
/// against its longest edge, so some deformation costs little strain energy) times the spread of
/// the moduli (ν → 0.49: λ ≈ 50μ, λ_max is volumetric and the softest modes are shear;
/// ν → −0.9: the bulk modulus is 0.024μ and the softest mode is volumetric). Measured worst
/// λ₇/λ_max: 6.3e-5 (ν = 0.49, quality 0.050; 1.2e-4 at ν = −0.9, ≥ 7e-4 for ν ∈ [−0.5, 0.3]).
/// The bound is 12× below that and still 5·10⁷× above the zero tolerance, so the count of
/// zero modes is unambiguous.
const NONZERO_EIGENVALUE_TOL: f64 = 5e-6;

/// ‖Kₑ·m‖ ≤ this·‖Kₑ‖_F·‖m‖ for each rigid mode m: in exact arithmetic the product cancels terms
/// of size ‖Kₑ‖·‖m‖ exactly, so the residual is a few ε of that. Measured worst: 2.6e-16
/// (margin 380×).
const NULL_SPACE_TOL: f64 = 1e-13;

/// Max nodal force under a rigid motion ≤ this·‖Kₑ‖_F·r, r the largest distance of a node from
/// the centroid: the unit-strain force scale (no displacement of size r, i.e. a strain of order
/// one, gives a larger force; ‖Kₑ‖_F ~ E·V/l²). F = Ds·Dm⁻¹ is R up to
/// ε·(|x| + |t|)/l·cond(Dm) (nodes up to ~10 tet sizes from the origin lose digits in the
/// differences Ds), and the stress is linear in F − R near F = R. Measured worst: 2.3e-15 for
/// both models (margin 430×).
const RIGID_FORCE_TOL: f64 = 1e-12;

/// The linear model's max nodal force under a rigid rotation by more than 0.5 rad is at least
/// this times the same scale: the rotation's symmetric part (cos θ − 1)(I − aaᵀ) is a strain of
/// at least 1 − cos 0.5 = 0.12, with strain energy 2V(1 − cos θ)²(λ + μ) > 0 (λ + μ =
/// E/(2(1+ν)(1−2ν)) > 0 for every allowed ν). Measured smallest ratio: 2.2e-4 (θ = 0.5, ν = 0,
/// quality 0.05; 1.1e-3 over the property's own distribution). The bound is 10× below that and
/// 2·10⁷× above [`RIGID_FORCE_TOL`], so the rigid-motion property would catch a model with this
/// artifact.
const LINEAR_ROTATION_MIN: f64 = 2e-5;

/// Mesh totals (volume, surface area, |Σ area vectors| / area, lumped and consistent mass)
/// relative to the exact box values. Each of up to 3 000 terms is exact to a few ε relative to
/// its size, and node coordinates (up to 20 in magnitude, cells down to 0.02) are rounded to
/// ε·|x|, i.e. up to 2e-13 of a cell; the totals see that only through the boundary (the
/// interior terms telescope). Measured worst: 3.5e-14 (consistent mass; volume 1.9e-14), margin
/// 30×.
const MESH_SUM_TOL: f64 = 1e-12;

/// Patch test: nodal displacement error ≤ this·(‖A‖_F·d + |c|), d the box diagonal, i.e.
/// relative to the size of the prescribed field. A backward-stable Cholesky solve gives a
/// relative error of at most about cond(K_ff)·ε, and cond(K_ff) ≤ 102 was measured for these
/// meshes (≤ 4 cells per axis, cell aspect up to 200:1, ν up to 0.49): ≈ 2e-14. Measured worst:
/// 5.9e-15 (margin 1 700×).
const PATCH_DISPLACEMENT_TOL: f64 = 1e-11;

/// Patch test: element strain error ≤ this·(displacement scale / h_min), h_min the smallest cell
/// size: the strain is a difference quotient of nodal displacements over lengths of order
/// h_min (a perturbed tet keeps ≥ 5 % of its unperturbed volume), so a displacement error δ
/// gives a strain error of order δ/h_min. Measured worst: 5.2e-15 (margin 1 900×).
const PATCH_STRAIN_TOL: f64 = 1e-11;

// ---------------------------------------------------------------------------------------------
// Strategies.

/// A generated value that proptest's failure report prints on one line: it prints inputs with
/// `{:#?}`, which spreads every nalgebra vector over five lines.
#[derive(Clone, Copy)]
struct Compact<T>(T);

impl<T: fmt::Debug> fmt::Debug for Compact<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.0)
    }
}

fn vector(lo: f64, hi: f64) -> impl Strategy<Value = Vector3<f64>> {
    (lo..hi, lo..hi, lo..hi).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

/// A positively oriented tet of shape quality ≥ [`MIN_QUALITY`]: four vertices uniform in
/// [−1, 1]³, shifted by an offset in [−2, 2]³ and scaled by 10ˢ, s ∈ [−3, 3] (so the tolerances
/// are tested as relative ones). Shrinks towards scale 1 and offset 0.
fn valid_tet() -> impl Strategy<Value = Compact<[Vector3<f64>; 4]>> {
    let corner = || vector(-1.0, 1.0);
    (
        [corner(), corner(), corner(), corner()],
        vector(-2.0, 2.0),
        -3.0..3.0f64,
    )
        .prop_filter("shape quality below 0.05", |(x, _, _)| {
            shape_quality(x) >= MIN_QUALITY
        })
        .prop_map(|(mut x, offset, exponent)| {
            if signed_volume(&x) < 0.0 {
                x.swap(1, 2);
            }
            let scale = 10f64.powf(exponent);
            Compact(x.map(|p| (p + offset) * scale))
        })
}

/// E log-uniform in [1e2, 1e11], ν uniform in [−0.9, 0.49), ρ log-uniform in [1, 1e4].
fn material() -> impl Strategy<Value = Material> {
    (2.0..11.0f64, -0.9..0.49f64, 0.0..4.0f64).prop_map(|(e, nu, rho)| {
        Material::new(10f64.powf(e), nu, 10f64.powf(rho)).expect("valid ranges")
    })
}

/// A rotation, kept as axis and angle so that a failure report reads as one.
#[derive(Debug, Clone, Copy)]
struct AxisAngle {
    axis: Vector3<f64>,
    angle: f64,
}

impl AxisAngle {
    fn matrix(&self) -> Rotation3<f64> {
        Rotation3::from_axis_angle(&Unit::new_normalize(self.axis), self.angle)
    }
}

/// A rotation by `angle` (radians) about a random axis.
fn rotation(angle: std::ops::Range<f64>) -> impl Strategy<Value = Compact<AxisAngle>> {
    (
        vector(-1.0, 1.0).prop_filter("axis too short", |a| a.norm() > 0.1),
        angle,
    )
        .prop_map(|(axis, angle)| Compact(AxisAngle { axis, angle }))
}

/// A box [min, min + extent] (extent per axis log-uniform in [0.1, 10], min in [−10, 10]³).
#[derive(Debug, Clone)]
struct BoxSpec {
    min: Vector3<f64>,
    extent: Vector3<f64>,
    cells: [usize; 3],
    split: BoxSplit,
}

impl BoxSpec {
    fn mesh(&self) -> TetMesh {
        TetMesh::box_grid(self.min, self.min + self.extent, self.cells, self.split)
            .expect("valid box")
    }

    fn volume(&self) -> f64 {
        self.extent.product()
    }

    fn surface_area(&self) -> f64 {
        let [a, b, c] = [self.extent.x, self.extent.y, self.extent.z];
        2.0 * (a * b + b * c + c * a)
    }

    /// Grid nodes on the box's surface.
    fn boundary_nodes(&self) -> Vec<usize> {
        let [nx, ny, nz] = self.cells;
        let mut nodes = Vec::new();
        for iz in 0..=nz {
            for iy in 0..=ny {
                for ix in 0..=nx {
                    if ix % nx == 0 || iy % ny == 0 || iz % nz == 0 {
                        nodes.push(box_node_index(self.cells, ix, iy, iz));
                    }
                }
            }
        }
        nodes
    }

    fn cell_size(&self) -> Vector3<f64> {
        self.extent
            .component_div(&Vector3::from(self.cells.map(|n| n as f64)))
    }
}

fn box_spec(cells: std::ops::RangeInclusive<usize>) -> impl Strategy<Value = BoxSpec> {
    (
        vector(-10.0, 10.0),
        vector(-1.0, 1.0),
        [cells.clone(), cells.clone(), cells],
        prop_oneof![Just(BoxSplit::Lecture6), Just(BoxSplit::Five)],
    )
        .prop_map(|(min, exponent, cells, split)| BoxSpec {
            min,
            extent: exponent.map(|e| 10f64.powf(e)),
            cells,
            split,
        })
}

/// The patch test's input: a box whose interior nodes move by up to `amplitude` of the cell
/// size per axis (pseudo-random from `seed`, so a failure prints two numbers rather than a list
/// of node offsets, and shrinks towards the unperturbed grid), and u(x) = A·x + c.
#[derive(Debug, Clone)]
struct PatchCase {
    spec: BoxSpec,
    amplitude: f64,
    seed: u64,
    a: Matrix3<f64>,
    c: Vector3<f64>,
    material: Material,
}

fn patch_case() -> impl Strategy<Value = Compact<PatchCase>> {
    (
        box_spec(2..=4),
        0.0..0.2f64,
        any::<u64>(),
        [
            vector(-0.01, 0.01),
            vector(-0.01, 0.01),
            vector(-0.01, 0.01),
        ],
        vector(-0.1, 0.1),
        material(),
    )
        .prop_map(|(spec, amplitude, seed, rows, c, material)| {
            Compact(PatchCase {
                spec,
                amplitude,
                seed,
                a: Matrix3::from_rows(&rows.map(|r| r.transpose())),
                c,
                material,
            })
        })
}

// ---------------------------------------------------------------------------------------------
// Property 1: the element stiffness spectrum.

/// The 6 rigid modes of a tet's nodes: 3 translations, 3 infinitesimal rotations e_k × x.
fn rigid_modes(x: &[Vector3<f64>; 4]) -> [Vector12; 6] {
    std::array::from_fn(|mode| {
        Vector12::from_fn(|dof, _| {
            let (node, axis) = (dof / 3, dof % 3);
            if mode < 3 {
                if axis == mode { 1.0 } else { 0.0 }
            } else {
                Vector3::ith(mode - 3, 1.0).cross(&x[node])[axis]
            }
        })
    })
}

/// Measured properties of Kₑ, each relative to its scale.
#[derive(Debug, Clone, Copy)]
struct Spectrum {
    /// ‖K − Kᵀ‖_F / ‖K‖_F.
    asymmetry: f64,
    /// Eigenvalues ascending, divided by λ_max.
    ratios: [f64; 12],
    /// max over rigid modes m of ‖K·m‖ / (‖K‖_F·‖m‖).
    null_residual: f64,
}

fn spectrum(x: &[Vector3<f64>; 4], material: &Material) -> Spectrum {
    let k: Matrix12 = Tet::new(x).expect("valid tet").stiffness(material);
    let norm = k.norm();
    let mut eigenvalues: Vec<f64> = SymmetricEigen::new(k).eigenvalues.iter().copied().collect();
    eigenvalues.sort_by(f64::total_cmp);
    let largest = eigenvalues[11];
    let null_residual = rigid_modes(x)
        .iter()
        .map(|m| (k * m).norm() / (norm * m.norm()))
        .fold(0.0, f64::max);
    Spectrum {
        asymmetry: (k - k.transpose()).norm() / norm,
        ratios: std::array::from_fn(|i| eigenvalues[i] / largest),
        null_residual,
    }
}

// ---------------------------------------------------------------------------------------------
// Property 2: rigid motions.

/// Forces of the three models after a rigid motion x ↦ R·x + t, as max |fᵢ| divided by the
/// unit-strain force scale ‖Kₑ‖_F·r: [corotational, Neo-Hookean, linear].
fn rigid_motion_forces(
    x: &[Vector3<f64>; 4],
    material: &Material,
    rotation: &Rotation3<f64>,
    translation: &Vector3<f64>,
) -> [f64; 3] {
    let tet = Tet::new(x).expect("valid tet");
    let centroid = (x[0] + x[1] + x[2] + x[3]) / 4.0;
    let radius = x.iter().map(|p| (p - centroid).norm()).fold(0.0, f64::max);
    let scale = tet.stiffness(material).norm() * radius;
    let moved = x.map(|p| rotation * p + translation);
    let models: [Box<dyn ForceModel>; 3] = [
        Box::new(Corotational::new(material)),
        Box::new(NeoHookean::new(material)),
        Box::new(LinearModel::new(material)),
    ];
    models.map(|model| model.force(&tet, x, &moved).amax() / scale)
}

// ---------------------------------------------------------------------------------------------
// Property 3: box meshes.

/// Outward faces of a positively oriented tet [0, 1, 2, 3]: (n₁−n₀)×(n₂−n₀) points away from
/// the fourth node. Checked geometrically in [`mesh_errors`].
const OUTWARD_FACES: [([usize; 3], usize); 4] = [
    ([0, 2, 1], 3),
    ([0, 1, 3], 2),
    ([0, 3, 2], 1),
    ([1, 2, 3], 0),
];

/// The same cyclic triangle, rotated so that its smallest node comes first.
fn canonical(face: [usize; 3]) -> [usize; 3] {
    let first = (0..3).min_by_key(|&i| face[i]).unwrap_or(0);
    [face[first], face[(first + 1) % 3], face[(first + 2) % 3]]
}

/// Relative errors of a box mesh's totals against the exact box.
#[derive(Debug, Clone, Copy, Default)]
struct MeshErrors {
    volume: f64,
    surface_area: f64,
    area_vector_sum: f64,
    lumped_mass: f64,
    consistent_mass: f64,
}

impl MeshErrors {
    fn worst(&self) -> f64 {
        [
            self.volume,
            self.surface_area,
            self.area_vector_sum,
            self.lumped_mass,
            self.consistent_mass,
        ]
        .into_iter()
        .fold(0.0, f64::max)
    }
}

/// Checks the invariants of a box mesh (positive tets, outward face table, interior faces
/// shared by two tets with opposite orientations, boundary faces outward on the box surface,
/// agreement with [`TetMesh::face_topology`]): the first one broken is the error. Otherwise
/// returns the errors of its totals.
fn mesh_errors(spec: &BoxSpec, density: f64) -> Result<MeshErrors, String> {
    let mesh = spec.mesh();
    let nodes = mesh.nodes();
    let [nx, ny, nz] = spec.cells;

    // Every stored tet positively oriented, every face listed outward.
    let mut faces: HashMap<[usize; 3], Vec<[usize; 3]>> = HashMap::new();
    for (t, tet) in mesh.tets().iter().enumerate() {
        let p = tet.map(|n| nodes[n]);
        if signed_volume(&p) <= 0.0 {
            return Err(format!("tet {t} {tet:?} is not positively oriented"));
        }
        for (face, opposite) in OUTWARD_FACES {
            let area = (p[face[1]] - p[face[0]]).cross(&(p[face[2]] - p[face[0]]));
            if area.dot(&(p[opposite] - p[face[0]])) >= 0.0 {
                return Err(format!("face {face:?} of tet {t} is not outward"));
            }
            let oriented = face.map(|i| tet[i]);
            let mut key = oriented;
            key.sort_unstable();
            faces.entry(key).or_default().push(oriented);
        }
    }

    // Interior faces: exactly two tets, opposite orientations; boundary faces: one tet.
    let mut interior = 0;
    let mut boundary = 0;
    for (key, sides) in &faces {
        match sides.as_slice() {
            [_] => boundary += 1,
            [a, b] => {
                if canonical(*a) != canonical([b[0], b[2], b[1]]) {
                    return Err(format!(
                        "face {key:?} has the same orientation in both tets"
                    ));
                }
                interior += 1;
            }
            _ => return Err(format!("face {key:?} is shared by {} tets", sides.len())),
        }
    }
    // Two triangles per cell face on the surface.
    let expected_boundary = 4 * (nx * ny + ny * nz + nz * nx);
    if boundary != expected_boundary {
        return Err(format!(
            "{boundary} boundary faces, expected {expected_boundary}"
        ));
    }

    // The library's topology agrees.
    let topology = mesh.face_topology().map_err(|e| e.to_string())?;
    if topology.boundary.len() != boundary || topology.neighbours.len() != interior {
        return Err(format!(
            "face_topology: {} boundary / {} interior, expected {boundary} / {interior}",
            topology.boundary.len(),
            topology.neighbours.len()
        ));
    }

    // Boundary faces lie on the box surface, with outward normals along the face's axis.
    let max = spec.min + spec.extent;
    let mut area_sum = Vector3::zeros();
    let mut area_total = 0.0;
    for face in mesh.boundary_faces().map_err(|e| e.to_string())? {
        let area = face.area_vector(&mesh).unwrap();
        let centroid = face.centroid(&mesh).unwrap();
        let axis = area.iamax();
        let on_side = if area[axis] > 0.0 {
            max[axis]
        } else {
            spec.min[axis]
        };
        let normal_error = (area.norm() - area[axis].abs()) / area.norm();
        let plane_error = (centroid[axis] - on_side).abs() / spec.extent[axis];
        if normal_error > MESH_SUM_TOL || plane_error > MESH_SUM_TOL {
            return Err(format!(
                "boundary face {:?} (area vector {area:?}) is not an outward piece of the box surface",
                face.nodes
            ));
        }
        area_sum += area;
        area_total += area.norm();
    }

    let material = Material::new(1.0, 0.3, density).expect("valid material");
    let mass = spec.volume() * density;
    let lumped = lumped_mass(&mesh, &material);
    let lumped_error = (0..3)
        .map(|axis| {
            let total: f64 = lumped.iter().skip(axis).step_by(3).sum();
            (total - mass).abs() / mass
        })
        .fold(0.0, f64::max);
    // Σ of all entries, split by (row axis, column axis): the translation modes give ρV·I₃, so
    // the whole sum is 3ρV and the cross-axis sums vanish. Both triangles are stored.
    let consistent = Assembler::new(&mesh)
        .consistent_mass(&mesh, &material)
        .unwrap();
    let mut sums = Matrix3::zeros();
    for col in 0..consistent.dim() {
        for k in consistent.col_ptr()[col]..consistent.col_ptr()[col + 1] {
            sums[(consistent.row_idx()[k] % 3, col % 3)] += consistent.values()[k];
        }
    }
    Ok(MeshErrors {
        volume: (mesh.volume() - spec.volume()).abs() / spec.volume(),
        surface_area: (area_total - spec.surface_area()).abs() / spec.surface_area(),
        area_vector_sum: area_sum.norm() / spec.surface_area(),
        lumped_mass: lumped_error,
        consistent_mass: (sums - Matrix3::identity() * mass).amax() / mass,
    })
}

// ---------------------------------------------------------------------------------------------
// Property 4: the patch test.

/// The perturbed mesh of a patch case, or `None` when a tet lost more than 95 % of its volume
/// (or inverted: [`TetMesh::new`] would silently reorient it and the mesh would overlap).
fn perturbed_mesh(case: &PatchCase) -> Option<TetMesh> {
    let grid = case.spec.mesh();
    let [nx, ny, nz] = case.spec.cells;
    let h = case.spec.cell_size();
    let mut rng = common::Rng::new(case.seed);
    let mut nodes = grid.nodes().to_vec();
    for iz in 1..nz {
        for iy in 1..ny {
            for ix in 1..nx {
                let offset = rng.vector(-case.amplitude, case.amplitude);
                nodes[box_node_index(case.spec.cells, ix, iy, iz)] += offset.component_mul(&h);
            }
        }
    }
    // Volume ratios are invariant under the per-axis scaling, so this is a scale-free check.
    let keeps_shape = grid.tets().iter().all(|tet| {
        signed_volume(&tet.map(|n| nodes[n])) > 0.05 * signed_volume(&tet.map(|n| grid.nodes()[n]))
    });
    keeps_shape.then(|| grid.with_nodes(nodes).expect("valid perturbed mesh"))
}

/// Errors of the patch test: (max nodal |u − (A·x + c)| / (‖A‖_F·d + |c|),
/// max element ‖ε − sym A‖ / (displacement scale / h_min)).
fn patch_errors(case: &PatchCase, mesh: &TetMesh) -> (f64, f64) {
    let exact = |p: &Vector3<f64>| case.a * p + case.c;
    let mut constraints = Constraints::new(mesh);
    for node in case.spec.boundary_nodes() {
        constraints
            .prescribe(node, exact(&mesh.nodes()[node]))
            .expect("valid node");
    }
    let solution = solve_static(mesh, &case.material, &constraints, &Loads::new(mesh))
        .expect("the boundary holds every rigid mode");
    let u = &solution.displacement;
    let scale = case.a.norm() * case.spec.extent.norm() + case.c.norm();
    let displacement_error = mesh
        .nodes()
        .iter()
        .enumerate()
        .map(|(n, p)| (Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]) - exact(p)).norm())
        .fold(0.0, f64::max);

    let strain = (case.a + case.a.transpose()) * 0.5;
    let strain_error = mesh
        .elements()
        .iter()
        .zip(mesh.tets())
        .map(|(element, tet)| {
            let ue = Vector12::from_fn(|i, _| u[3 * tet[i / 3] + i % 3]);
            (element.strain(&ue) - strain).norm()
        })
        .fold(0.0, f64::max);
    let strain_scale = scale / case.spec.cell_size().min();
    (
        ratio(displacement_error, scale),
        ratio(strain_error, strain_scale),
    )
}

/// a / b, with 0/0 = 0 (a shrunk case with A = 0 and c = 0 has no error and no scale).
fn ratio(a: f64, b: f64) -> f64 {
    if a == 0.0 { 0.0 } else { a / b }
}

// ---------------------------------------------------------------------------------------------
// The properties.

/// The seed of every property run: the same `cases` on every run and machine, so that a CI
/// failure reproduces locally and a pass is not luck of the draw. Set `PROPTEST_RNG_SEED` to
/// explore other cases (a failure found so is saved as below).
const PROPERTY_SEED: u64 = 0x7e7f_e3a1;

/// `cases` pseudo-random cases from [`PROPERTY_SEED`] (or `PROPTEST_RNG_SEED` when set); a
/// failure's seed is saved to `tests/properties.proptest-regressions` (commit it: the case is
/// then replayed first on every run).
fn config(cases: u32) -> ProptestConfig {
    let defaults = ProptestConfig::default();
    // `default()` reads PROPTEST_RNG_SEED; without it, the seed would be fresh on every run.
    let rng_seed = match defaults.rng_seed {
        RngSeed::Random => RngSeed::Fixed(PROPERTY_SEED),
        chosen => chosen,
    };
    ProptestConfig {
        cases,
        rng_seed,
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource(
            "proptest-regressions",
        ))),
        ..defaults
    }
}

proptest! {
    #![proptest_config(config(256))]

    /// Kₑ is symmetric, positive semi-definite with exactly six zero eigenvalues, and the six
    /// rigid modes are in its null space.
    #[test]
    fn element_stiffness_is_symmetric_psd_with_six_rigid_modes(
        Compact(x) in valid_tet(),
        material in material(),
    ) {
        let s = spectrum(&x, &material);
        prop_assert!(s.asymmetry <= SYMMETRY_TOL, "asymmetry {:e}", s.asymmetry);
        for (i, &r) in s.ratios.iter().enumerate() {
            if i < 6 {
                prop_assert!(r.abs() <= ZERO_EIGENVALUE_TOL, "λ{i}/λmax = {r:e} should vanish");
            } else {
                prop_assert!(r >= NONZERO_EIGENVALUE_TOL, "λ{i}/λmax = {r:e} should be positive");
            }
        }
        prop_assert!(
            s.null_residual <= NULL_SPACE_TOL,
            "a rigid mode is not in the null space: {:e}",
            s.null_residual
        );
    }

    /// Any rigid motion (rotation up to π about any axis, then a translation) leaves the
    /// corotational and Neo-Hookean forces at zero.
    #[test]
    fn rigid_motion_gives_no_corotational_or_neo_hookean_force(
        Compact(x) in valid_tet(),
        material in material(),
        Compact(rotation) in rotation(0.0..std::f64::consts::PI),
        Compact(translation) in vector(-10.0, 10.0).prop_map(Compact),
    ) {
        // Translations of the tet's own size or larger: scale them with it.
        let size = (x[1] - x[0]).norm();
        let [corotational, neo_hookean, _] =
            rigid_motion_forces(&x, &material, &rotation.matrix(), &(translation * size));
        prop_assert!(corotational <= RIGID_FORCE_TOL, "corotational: {corotational:e}");
        prop_assert!(neo_hookean <= RIGID_FORCE_TOL, "Neo-Hookean: {neo_hookean:e}");
    }

    /// The lecture's artifact: the linear model resists a large rigid rotation. Shows that the
    /// rigid-motion property above measures something that can fail.
    #[test]
    fn rigid_rotation_beyond_half_a_radian_gives_a_linear_force(
        Compact(x) in valid_tet(),
        material in material(),
        Compact(rotation) in rotation(0.5..std::f64::consts::PI),
    ) {
        let [_, _, linear] =
            rigid_motion_forces(&x, &material, &rotation.matrix(), &Vector3::zeros());
        prop_assert!(linear >= LINEAR_ROTATION_MIN, "linear: {linear:e}");
    }
}

proptest! {
    #![proptest_config(config(64))]

    /// Box meshes are conforming and watertight, and their volume and mass are exact.
    #[test]
    fn box_meshes_conform_and_carry_the_box_volume_and_mass(
        Compact(spec) in box_spec(1..=5).prop_map(Compact),
        density_exponent in 0.0..4.0f64,
    ) {
        let density = 10f64.powf(density_exponent);
        let errors = mesh_errors(&spec, density).map_err(TestCaseError::fail)?;
        prop_assert!(errors.worst() <= MESH_SUM_TOL, "{errors:?}");
    }

    /// The patch test: boundary values of a linear field u = A·x + c give that field, exactly,
    /// at every node of a perturbed mesh, and the strain sym(A) in every tet.
    #[test]
    fn patch_test_reproduces_linear_fields(Compact(case) in patch_case()) {
        let Some(mesh) = perturbed_mesh(&case) else {
            return Err(TestCaseError::reject("the perturbation (nearly) inverted a tet"));
        };
        let (displacement, strain) = patch_errors(&case, &mesh);
        prop_assert!(displacement <= PATCH_DISPLACEMENT_TOL, "displacement error {displacement:e}");
        prop_assert!(strain <= PATCH_STRAIN_TOL, "strain error {strain:e}");
    }
}

/// Two runs of the properties' configuration draw the same cases: the seed is fixed (with a
/// fresh random seed, two runs of 16 tets would agree with probability ~0).
#[test]
fn property_runs_draw_the_same_cases_every_time() {
    let draw = || {
        let mut runner = TestRunner::new(config(16));
        (0..16)
            .map(|_| {
                let Compact(x) = valid_tet().new_tree(&mut runner).expect("sample").current();
                x
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(draw(), draw());
}

// ---------------------------------------------------------------------------------------------
// Re-measuring the margins.

/// Prints the extremes of every measured ratio over many more cases than the properties run.
/// Not a test: run it when a tolerance above needs re-justifying.
#[test]
#[ignore = "measurement: cargo test --release --test properties -- --ignored --nocapture"]
fn measure_margins() {
    let cases: usize = std::env::var("MARGIN_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000);
    // The quality filter rejects some tets, and the runner counts rejections over all samples:
    // lift its limit.
    let config = ProptestConfig {
        max_local_rejects: u32::MAX,
        ..ProptestConfig::default()
    };
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha));

    let element = (valid_tet(), material(), rotation(0.0..std::f64::consts::PI));
    let (mut asym, mut zero, mut null) = (0.0f64, 0.0f64, 0.0f64);
    // (ratio, shape quality, ν) of the worst case seen.
    let mut gap = (f64::INFINITY, 0.0, 0.0);
    let (mut corot, mut neo) = (0.0f64, 0.0f64);
    // (ratio, angle, ν) of the smallest linear force seen.
    let mut linear = (f64::INFINITY, 0.0, 0.0);
    for _ in 0..cases {
        let (Compact(x), m, Compact(r)) = element.new_tree(&mut runner).expect("sample").current();
        let r = r.matrix();
        let s = spectrum(&x, &m);
        asym = asym.max(s.asymmetry);
        zero = zero.max(s.ratios[..6].iter().map(|r| r.abs()).fold(0.0, f64::max));
        null = null.max(s.null_residual);
        if s.ratios[6] < gap.0 {
            gap = (s.ratios[6], shape_quality(&x), m.poisson_ratio());
        }
        let size = (x[1] - x[0]).norm();
        let t = Vector3::new(10.0, -10.0, 10.0) * size;
        let [c, n, _] = rigid_motion_forces(&x, &m, &r, &t);
        corot = corot.max(c);
        neo = neo.max(n);
        if r.angle() > 0.5 {
            let l = rigid_motion_forces(&x, &m, &r, &Vector3::zeros())[2];
            if l < linear.0 {
                linear = (l, r.angle(), m.poisson_ratio());
            }
        }
    }
    println!(
        "element ({cases} cases): asymmetry {asym:.2e}, zero eigenvalues <= {zero:.2e}, null-space residual {null:.2e}"
    );
    println!(
        "  smallest nonzero λ/λmax {:.2e} (quality {:.3}, ν {:.3})",
        gap.0, gap.1, gap.2
    );
    println!("rigid motion: corotational {corot:.2e}, Neo-Hookean {neo:.2e}");
    println!(
        "  linear, θ > 0.5: smallest {:.2e} (θ {:.3}, ν {:.3})",
        linear.0, linear.1, linear.2
    );

    // The spectral gap and the linear rotation force at the ends of the ν range, where they are
    // smallest: the uniform ν above rarely lands there.
    for nu in [-0.9, -0.5, 0.0, 0.3, 0.4899] {
        let m = Material::new(1.0, nu, 1.0).expect("valid material");
        let mut worst_gap = (f64::INFINITY, 0.0);
        let mut worst_linear = f64::INFINITY;
        for _ in 0..cases {
            let (Compact(x), Compact(r)) = (valid_tet(), rotation(0.5..0.5001))
                .new_tree(&mut runner)
                .expect("sample")
                .current();
            let r = r.matrix();
            let g = spectrum(&x, &m).ratios[6];
            if g < worst_gap.0 {
                worst_gap = (g, shape_quality(&x));
            }
            worst_linear = worst_linear.min(rigid_motion_forces(&x, &m, &r, &Vector3::zeros())[2]);
        }
        println!(
            "  ν = {nu}: smallest λ₇/λmax {:.2e} (quality {:.3}), linear force at θ = 0.5 >= {worst_linear:.2e}",
            worst_gap.0, worst_gap.1
        );
    }

    let meshes = cases / 200;
    let boxes = (box_spec(1..=5), 0.0..4.0f64);
    let mut worst = MeshErrors::default();
    for _ in 0..meshes {
        let (spec, rho) = boxes.new_tree(&mut runner).expect("sample").current();
        let e = mesh_errors(&spec, 10f64.powf(rho)).expect("conforming mesh");
        worst.volume = worst.volume.max(e.volume);
        worst.surface_area = worst.surface_area.max(e.surface_area);
        worst.area_vector_sum = worst.area_vector_sum.max(e.area_vector_sum);
        worst.lumped_mass = worst.lumped_mass.max(e.lumped_mass);
        worst.consistent_mass = worst.consistent_mass.max(e.consistent_mass);
    }
    println!("box meshes ({meshes} cases): {worst:?}");

    let (mut displacement, mut strain, mut rejected) = (0.0f64, 0.0f64, 0);
    let mut condition = 0.0f64;
    for i in 0..meshes {
        let Compact(case) = patch_case()
            .new_tree(&mut runner)
            .expect("sample")
            .current();
        match perturbed_mesh(&case) {
            Some(mesh) => {
                let (d, s) = patch_errors(&case, &mesh);
                displacement = displacement.max(d);
                strain = strain.max(s);
                if i % 10 == 0 {
                    condition = condition.max(free_stiffness_condition(&case, &mesh));
                }
            }
            None => rejected += 1,
        }
    }
    println!(
        "patch test ({meshes} cases, {rejected} rejected): displacement {displacement:.2e}, strain {strain:.2e}, cond(K_ff) <= {condition:.2e}"
    );
}

/// Condition number of K_ff of a patch case (interior nodes free), by a dense eigensolve.
fn free_stiffness_condition(case: &PatchCase, mesh: &TetMesh) -> f64 {
    let mut constraints = Constraints::new(mesh);
    for node in case.spec.boundary_nodes() {
        constraints
            .prescribe(node, Vector3::zeros())
            .expect("valid node");
    }
    let solver = tetfem::StaticSolver::new(mesh, &case.material, &constraints).expect("held");
    let k = solver.free_stiffness();
    let mut dense = nalgebra::DMatrix::zeros(k.dim(), k.dim());
    for col in 0..k.dim() {
        for p in k.col_ptr()[col]..k.col_ptr()[col + 1] {
            dense[(k.row_idx()[p], col)] = k.values()[p];
        }
    }
    let eigenvalues = nalgebra::SymmetricEigen::new(dense).eigenvalues;
    eigenvalues.max() / eigenvalues.min()
}
