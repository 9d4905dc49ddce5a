//! The bodies of the fuzz targets, shared by `fuzz/fuzz_targets/*.rs` (through `#[path]`) and
//! by the stable regression test `tests/fuzz_regressions.rs`, which replays the files under
//! `fuzz/regressions/<target>/` through these same functions.
//!
//! Each function takes the fuzzer's bytes and returns `Ok(())` when the input was accepted (or
//! deliberately skipped as too expensive) and the library's `Err` when it was rejected. A panic
//! anywhere is a bug: every bad input must come back as an `Err`.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use tetfem::mesh::io::{ImportedMesh, parse_gmsh, parse_tetgen};
use tetfem::{Assembler, Constraints, Loads, Material, Result, TetMesh, solve_static};
use tetfem_cli::Scene;
use tetfem_cli::scene::{Analysis, MeshSpec, RunOptions, run_static_with};

/// Scenes whose box grid has more cells than this are parsed but not built.
pub const SCENE_BUILD_CELLS: usize = 2000;
/// Static scenes with the linear model and at most this many cells are also solved.
pub const SCENE_SOLVE_CELLS: usize = 200;
/// Static scenes with a nonlinear model (Newton with load steps) are solved up to this size.
pub const SCENE_NONLINEAR_CELLS: usize = 8;

/// Target `gmsh`: the bytes are a whole `.msh` file.
pub fn gmsh(data: &[u8]) -> Result<()> {
    let imported = parse_gmsh(Path::new("<fuzz>.msh"), data)?;
    use_imported(&imported)
}

/// Target `tetgen`: the bytes up to the first 0xFF byte are the `.node` file, those after it
/// the `.ele` file (without a 0xFF byte the `.ele` file is empty). 0xFF never occurs in UTF-8
/// text, so the separator cannot collide with valid file contents.
pub fn tetgen(data: &[u8]) -> Result<()> {
    let (node, ele) = split_tetgen(data);
    let imported = parse_tetgen(Path::new("<fuzz>.node"), node, Path::new("<fuzz>.ele"), ele)?;
    use_imported(&imported)
}

/// The `.node` and `.ele` parts of a `tetgen` input.
pub fn split_tetgen(data: &[u8]) -> (&[u8], &[u8]) {
    match data.iter().position(|&b| b == 0xFF) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[]),
    }
}

/// What a caller does with an imported mesh: its boundary and the groups' boundary faces.
fn use_imported(imported: &ImportedMesh) -> Result<()> {
    let boundary = imported.mesh.boundary_faces()?;
    for g in &imported.groups {
        let _ = g.label();
        let _ = g.boundary_faces(&boundary);
        let _ = imported.group(&g.tag.to_string());
    }
    let _ = imported.nodes_with_marker(1);
    let _ = imported.skipped_count();
    Ok(())
}

/// An empty folder for the scenes' relative paths (created once per process).
fn empty_dir() -> &'static Path {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("tetfem-fuzz-empty-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        dir
    })
}

/// Target `scene`: the bytes as UTF-8 scene text (skipped if not UTF-8). A scene that parses is
/// built when its mesh is a box grid of at most [`SCENE_BUILD_CELLS`] cells (mesh files are
/// not read: a path could name a device or a huge file), and a small static one is solved
/// without writing files.
pub fn scene(data: &[u8]) -> Result<()> {
    let Ok(text) = std::str::from_utf8(data) else {
        return Ok(());
    };
    let scene = Scene::parse(text, "<fuzz>", empty_dir())?;
    let cells = match scene.spec().mesh.get_ref() {
        MeshSpec::Box(b) => b.cells.iter().try_fold(1usize, |a, &c| a.checked_mul(c)),
        MeshSpec::Gmsh(_) | MeshSpec::Tetgen(_) => None,
    };
    let Some(cells) = cells.filter(|&c| c <= SCENE_BUILD_CELLS) else {
        return Ok(());
    };
    let built = scene.build()?;
    let _ = built.loads.resultant();
    let limit = match scene.model() {
        tetfem::model::ModelKind::Linear => SCENE_SOLVE_CELLS,
        _ => SCENE_NONLINEAR_CELLS,
    };
    if matches!(scene.analysis(), Analysis::Static) && cells <= limit {
        let options = RunOptions {
            no_files: true,
            ..RunOptions::default()
        };
        run_static_with(&scene, &options)?;
    }
    Ok(())
}

/// Reads the fuzzer's bytes one at a time; zeros once they run out.
struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn byte(&mut self) -> u8 {
        match self.0.split_first() {
            Some((&b, rest)) => {
                self.0 = rest;
                b
            }
            None => 0,
        }
    }

    fn f64(&mut self) -> f64 {
        let mut b = [0u8; 8];
        for slot in &mut b {
            *slot = self.byte();
        }
        f64::from_le_bytes(b)
    }

    fn pick<T: Copy>(&mut self, from: &[T]) -> T {
        from[self.byte() as usize % from.len()]
    }
}

/// Coordinates a quantized byte ≥ 0xF0 stands for: the values that break naive numerics.
const SPECIAL: [f64; 16] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    1e308,
    -1e308,
    f64::MAX,
    f64::MIN_POSITIVE,
    5e-324,
    -0.0,
    1e154,
    1e-154,
    1e20,
    -1e20,
    1e-20,
    1.0 + f64::EPSILON,
    0.0,
];

/// Target `mesh`: nodes and tets decoded from the bytes (see the layout below) →
/// [`TetMesh::new`]; a valid mesh then goes through topology, statistics, assembly of K and a
/// static solve under gravity with its lowest-x plane clamped.
///
/// Layout: byte 0: bits 0–3 → 4 + n nodes, bits 4–5 → coordinate coding (0, 1: one byte per
/// coordinate on a 4×4 grid of quarter steps in [0, 3.75], bytes ≥ 0xF0 special values;
/// 2: the same times a scale 10^(k − 20); 3: raw little-endian f64, 8 bytes each); byte 1 →
/// 1 + (b mod 24) tets; then the scale byte (coding 2), the coordinates, four index bytes per
/// tet (b mod (nodes + 2), so some are out of range; bytes ≥ 0xF8 → near `usize::MAX`), a
/// material byte and a gravity byte. Missing bytes read as zero.
pub fn mesh(data: &[u8]) -> Result<()> {
    let (nodes, tets, material, gravity) = decode_mesh(data);
    let mesh = TetMesh::new(nodes, tets)?;
    let topology = mesh.face_topology()?;
    let _ = topology.boundary.len();
    let boundary = mesh.boundary_faces()?;
    let _ = mesh.statistics();
    let _ = mesh.volume();
    for f in &boundary {
        let _ = f.area_vector(&mesh);
    }
    let assembler = Assembler::new(&mesh);
    let _ = assembler.stiffness(&mesh, &material);
    let _ = tetfem::lumped_mass(&mesh, &material);
    let (lo, hi) = mesh.bounding_box();
    let tolerance = 1e-6 * (hi - lo).norm();
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_nodes(&mesh.nodes_on_plane(0, lo.x, tolerance))?;
    let mut loads = Loads::new(&mesh);
    loads.add_gravity(&mesh, &material, gravity)?;
    solve_static(&mesh, &material, &constraints, &loads)?;
    Ok(())
}

/// The nodes, tets, material and gravity a `mesh` input stands for.
#[allow(clippy::type_complexity)]
pub fn decode_mesh(data: &[u8]) -> (Vec<Vector3<f64>>, Vec<[usize; 4]>, Material, Vector3<f64>) {
    let mut r = Bytes(data);
    let head = r.byte();
    let node_count = 4 + (head & 0x0f) as usize;
    let coding = (head >> 4) & 3;
    let tet_count = 1 + r.byte() as usize % 24;
    let scale = if coding == 2 {
        10f64.powi(i32::from(r.byte() % 41) - 20)
    } else {
        1.0
    };
    let coordinate = |r: &mut Bytes| -> f64 {
        if coding == 3 {
            return r.f64();
        }
        let b = r.byte();
        if b >= 0xF0 {
            SPECIAL[(b - 0xF0) as usize]
        } else {
            ((b & 3) as f64 + ((b >> 2) & 3) as f64 * 0.25) * scale
        }
    };
    let nodes: Vec<Vector3<f64>> = (0..node_count)
        .map(|_| {
            let x = coordinate(&mut r);
            let y = coordinate(&mut r);
            let z = coordinate(&mut r);
            Vector3::new(x, y, z)
        })
        .collect();
    let tets: Vec<[usize; 4]> = (0..tet_count)
        .map(|_| {
            [(); 4].map(|_| {
                let b = r.byte();
                if b >= 0xF8 {
                    usize::MAX - (b - 0xF8) as usize
                } else {
                    b as usize % (node_count + 2)
                }
            })
        })
        .collect();
    let (e, nu, rho) = r.pick(&[
        (200e9, 0.3, 7850.0),
        (5e6, 0.49, 1100.0),
        (1.0, 0.0, 1.0),
        (1e300, 0.4999999, 1e300),
        (1e-300, -0.99, 1e-300),
        (70e9, 0.33, 2700.0),
    ]);
    let material = Material::new(e, nu, rho).expect("the harness's materials are valid");
    let gravity = r.pick(&[
        Vector3::new(0.0, 0.0, -9.81),
        Vector3::new(0.0, -9.81, 0.0),
        Vector3::new(1e300, 0.0, 0.0),
        Vector3::zeros(),
    ]);
    (nodes, tets, material, gravity)
}
