//! Binary `.vtu` (appended raw, the default) read back through the tests' own reader
//! (tests/core/common/vtu.rs: roxmltree for the XML, the appended block decoded by hand): every array
//! bit for bit as written, for the library's writer (linear and quadratic cells) and for static,
//! dynamic and modal scene outputs; the stress and strain tensors every frame carries; the
//! `.pvd` times t = n·dt without a running sum's drift; and, where Python has meshio, meshio
//! reading the same files.

use crate::common::vtu;

use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Vector3};
use tetfem::model::{Corotational, NeoHookean};
use tetfem::post::output::{
    FrameExtras, VtuFormat, VtuWriter, write_model_result_vtu, write_result_frame,
    write_static_result_vtu,
};
use tetfem::{BoxSplit, Material, TetMesh};
use tetfem_cli::scene::{
    DynamicOverrides, RunOptions, Scene, VtuEncoding, run_dynamic_scene, run_modal_scene,
    run_static_with,
};

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("binary_vtu")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn mesh() -> TetMesh {
    TetMesh::box_grid(
        Vector3::new(0.1, -0.2, 0.0),
        Vector3::new(1.3, 0.4, 0.5),
        [3, 2, 2],
        BoxSplit::Lecture6,
    )
    .unwrap()
}

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn the_writer_s_arrays_read_back_bit_for_bit_in_both_formats() {
    let mesh = mesh();
    // Values a text format could lose: −0, subnormals, huge and tiny magnitudes, π's last bit.
    let point: Vec<f64> = (0..3 * mesh.node_count())
        .map(|i| match i % 5 {
            0 => -0.0,
            1 => f64::MIN_POSITIVE / 3.0,
            2 => 1.0e300 * (i as f64),
            3 => std::f64::consts::PI * (i as f64),
            _ => -1.0e-300 / (i as f64),
        })
        .collect();
    let cell: Vec<f64> = (0..mesh.tet_count()).map(|t| (t as f64).sin()).collect();
    let dir = tmp("writer");
    for format in [VtuFormat::Binary, VtuFormat::Ascii] {
        let path = dir.join(format!("{}.vtu", format.name()));
        VtuWriter::new(&mesh)
            .format(format)
            .field_data("TimeValue", 0.1 + 0.2)
            .unwrap()
            .point_field("p", 3, &point)
            .unwrap()
            .cell_field("c", 1, &cell)
            .unwrap()
            .write(&path)
            .unwrap();
        let file = vtu::read_vtu(&path);
        assert_eq!(file.binary, format == VtuFormat::Binary);
        assert_eq!(
            (file.points, file.cells),
            (mesh.node_count(), mesh.tet_count())
        );
        assert_eq!(bits(file.values("p")), bits(&point), "{format:?}");
        assert_eq!(bits(file.values("c")), bits(&cell), "{format:?}");
        assert_eq!(file.values("TimeValue"), [0.1 + 0.2]);
        let points: Vec<f64> = mesh.nodes().iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        assert_eq!(bits(file.values("Points")), bits(&points));
        let connectivity: Vec<f64> = mesh.tets().iter().flatten().map(|&n| n as f64).collect();
        assert_eq!(file.values("connectivity"), connectivity.as_slice());
        let offsets: Vec<f64> = (1..=mesh.tet_count()).map(|c| (4 * c) as f64).collect();
        assert_eq!(file.values("offsets"), offsets.as_slice());
        assert!(file.values("types").iter().all(|&t| t == 10.0));
        if format == VtuFormat::Binary {
            // The stored bytes are the little-endian f64s themselves.
            let raw: Vec<u8> = point.iter().flat_map(|v| v.to_le_bytes()).collect();
            assert_eq!(file.array("p").raw, raw);
            assert_eq!(
                (
                    file.array("connectivity").vtk_type.as_str(),
                    file.array("types").vtk_type.as_str()
                ),
                ("Int64", "UInt8")
            );
        }
    }
}

/// A small bar clamped at x = 0 and pulled at x = 1.2 (scene text; `analysis` and `output`
/// appended by the caller).
fn scene_text(model: &str, analysis: &str, output: &str) -> String {
    format!(
        r#"
title = "bar"
[mesh.box]
max = [1.2, 0.3, 0.3]
cells = [4, 1, 1]
[material]
youngs_modulus = 1e6
poisson_ratio = 0.3
density = 1000.0
[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}
[[loads]]
where = {{ plane = {{ axis = "x", at = 1.2 }} }}
total_force = [300.0, 0.0, -200.0]
[[probes]]
name = "tip"
where = {{ plane = {{ axis = "x", at = 1.2 }} }}
[analysis]
model = "{model}"
{analysis}
[output]
{output}
"#
    )
}

fn scene(text: &str, dir: &Path, format: VtuEncoding) -> Scene {
    let mut scene = Scene::parse(text, "bar", dir).unwrap();
    scene.set_output_directory(dir.to_path_buf());
    scene.set_vtu_format(format);
    scene
}

fn vtus(files: &[PathBuf]) -> Vec<PathBuf> {
    files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "vtu"))
        .cloned()
        .collect()
}

/// The same scene written in binary and in ASCII: the same arrays, bit for bit (ASCII prints
/// the shortest round-trip form, so it is an independent decoding of the same numbers).
fn assert_same_files(binary: &[PathBuf], ascii: &[PathBuf], what: &str) {
    assert_eq!(binary.len(), ascii.len(), "{what}");
    assert!(!binary.is_empty(), "{what}");
    for (b, a) in binary.iter().zip(ascii) {
        let (b_file, a_file) = (vtu::read_vtu(b), vtu::read_vtu(a));
        assert!(b_file.binary && !a_file.binary, "{what}");
        let names: Vec<&str> = b_file.arrays.iter().map(|x| x.name.as_str()).collect();
        let a_names: Vec<&str> = a_file.arrays.iter().map(|x| x.name.as_str()).collect();
        assert_eq!(names, a_names, "{what}");
        for (x, y) in b_file.arrays.iter().zip(&a_file.arrays) {
            assert_eq!(bits(&x.values), bits(&y.values), "{what}: {}", x.name);
        }
    }
}

#[test]
fn static_dynamic_and_modal_scene_outputs_read_back_identically_in_both_formats() {
    let static_text = scene_text("linear", r#"type = "static""#, "");
    let dynamic_text = scene_text(
        "corotational",
        "type = \"dynamic\"\nmethod = \"newmark\"\ndt = 1e-3\nduration = 5e-3",
        "every = 2",
    );
    let modal_text = scene_text("linear", "type = \"modal\"\nmodes = 3", "");
    let mut written = Vec::new();
    for encoding in [VtuEncoding::Binary, VtuEncoding::Ascii] {
        let name = format!("{encoding:?}");
        let s = scene(&static_text, &tmp(&format!("static_{name}")), encoding);
        let statics = run_static_with(&s, &RunOptions::default()).unwrap().files;
        let d = scene(&dynamic_text, &tmp(&format!("dynamic_{name}")), encoding);
        let dynamics = run_dynamic_scene(
            &d,
            &DynamicOverrides::default(),
            true,
            false,
            &mut |_, _| std::ops::ControlFlow::Continue(()),
        )
        .unwrap()
        .files;
        let m = scene(&modal_text, &tmp(&format!("modal_{name}")), encoding);
        let modals = run_modal_scene(&m, false).unwrap().files;
        written.push([vtus(&statics), vtus(&dynamics), vtus(&modals)]);
    }
    for (k, what) in ["static", "dynamic", "modal"].iter().enumerate() {
        assert_same_files(&written[0][k], &written[1][k], what);
    }
    // Frames 0, 2, 4 and the last (5): each a dynamic frame with the static results' tensors.
    let frames = &written[0][1];
    assert_eq!(frames.len(), 4);
    for frame in frames {
        let file = vtu::read_vtu(frame);
        for name in [
            "stress",
            "strain",
            "principal_stress_1",
            "principal_stress_2",
            "principal_stress_3",
            "stress_nodal",
            "von_mises_nodal",
            "velocity",
        ] {
            assert!(file.has(name), "{}: no {name}", frame.display());
        }
    }
}

/// u = (F − I)·X with the same F everywhere: a homogeneous state.
fn homogeneous(mesh: &TetMesh, f: &Matrix3<f64>) -> Vec<f64> {
    let g = f - Matrix3::identity();
    mesh.nodes()
        .iter()
        .flat_map(|x| (g * x).iter().copied().collect::<Vec<_>>())
        .collect()
}

/// The six components XX, YY, ZZ, XY, YZ, XZ.
fn six(m: &Matrix3<f64>) -> [f64; 6] {
    [
        m[(0, 0)],
        m[(1, 1)],
        m[(2, 2)],
        m[(0, 1)],
        m[(1, 2)],
        m[(0, 2)],
    ]
}

#[test]
fn a_homogeneous_strain_gives_the_imposed_strain_and_stress_c_eps_in_every_tet() {
    let mesh = mesh();
    let material = Material::new(2e5, 0.25, 3.0).unwrap();
    // A general (non-symmetric) displacement gradient: its symmetric part is the strain, its
    // skew part a small rotation that must not show.
    let grad = Matrix3::new(1.0, 2.0, -0.5, -1.5, 0.7, 0.3, 0.9, -0.4, -1.1) * 1e-3;
    let f = Matrix3::identity() + grad;
    let u = homogeneous(&mesh, &f);
    let strain = (grad + grad.transpose()) * 0.5;
    let stress = Matrix3::identity() * (material.lame_lambda() * strain.trace())
        + strain * (2.0 * material.shear_modulus());
    let dir = tmp("homogeneous");
    let linear = dir.join("linear.vtu");
    write_static_result_vtu(&linear, &mesh, &material, &u, &vec![0.0; u.len()]).unwrap();
    let file = vtu::read_vtu(&linear);
    // Constant-strain tets reproduce a linear field up to the round-off of the shape gradients
    // (node coordinates ~1, so ~1e-16 relative to |∇u| ~ 1e-3: 1e-12 absolute on ε, 1e-12·E on σ).
    for (name, expected, scale) in [
        ("strain", six(&strain), 1.0),
        ("stress", six(&stress), material.youngs_modulus()),
    ] {
        for chunk in file.values(name).chunks(6) {
            for (v, e) in chunk.iter().zip(expected) {
                assert!(
                    (v - e).abs() < 1e-12 * scale,
                    "{name}: {chunk:?} vs {expected:?}"
                );
            }
        }
    }
    // The nonlinear models report the Green–Lagrange strain ½(FᵀF − I), which holds the
    // second-order term the linear strain drops.
    let green_lagrange = (f.transpose() * f - Matrix3::identity()) * 0.5;
    assert!(
        (green_lagrange - strain).abs().max() > 1e-7,
        "the two strains must differ here"
    );
    let nonlinear = dir.join("neo_hookean.vtu");
    let extras = FrameExtras {
        stress_tensors: true,
        ..FrameExtras::default()
    };
    write_model_result_vtu(
        &nonlinear,
        &mesh,
        &NeoHookean::new(&material),
        &material,
        &u,
        extras,
    )
    .unwrap();
    for chunk in vtu::read_vtu(&nonlinear).values("strain").chunks(6) {
        for (v, e) in chunk.iter().zip(six(&green_lagrange)) {
            // F from the tet's edge vectors, ~1e-16 relative: 1e-12 absolute is generous.
            assert!((v - e).abs() < 1e-12, "{chunk:?} vs {green_lagrange}");
        }
    }
}

#[test]
fn a_dynamic_frame_s_tensors_equal_the_static_writer_s_for_the_same_u() {
    for model in ["linear", "corotational"] {
        let dir = tmp(&format!("frame_vs_static_{model}"));
        let text = scene_text(
            model,
            "type = \"dynamic\"\nmethod = \"backward_euler\"\ndt = 1e-3\nduration = 3e-3",
            "",
        );
        let s = scene(&text, &dir, VtuEncoding::Binary);
        let summary = run_dynamic_scene(
            &s,
            &DynamicOverrides::default(),
            true,
            false,
            &mut |_, _| std::ops::ControlFlow::Continue(()),
        )
        .unwrap();
        let last = vtus(&summary.files).pop().unwrap();
        let frame = vtu::read_vtu(&last);
        let u = frame.values("displacement").to_vec();
        assert!(u.iter().any(|&x| x != 0.0));
        let built = s.build().unwrap();
        let again = dir.join("static_writer.vtu");
        match model {
            "linear" => write_static_result_vtu(
                &again,
                &built.mesh,
                &built.materials,
                &u,
                &vec![0.0; u.len()],
            )
            .unwrap(),
            _ => {
                let material = built.materials.materials()[0];
                write_model_result_vtu(
                    &again,
                    &built.mesh,
                    &Corotational::new(&material),
                    &built.materials,
                    &u,
                    FrameExtras {
                        stress_tensors: true,
                        ..FrameExtras::default()
                    },
                )
                .unwrap()
            }
        }
        let reference = vtu::read_vtu(&again);
        for name in [
            "stress",
            "strain",
            "principal_stress_1",
            "principal_stress_2",
            "principal_stress_3",
            "stress_nodal",
            "von_mises_nodal",
            "von_mises",
        ] {
            assert_eq!(
                bits(frame.values(name)),
                bits(reference.values(name)),
                "{model}: {name}"
            );
        }
        assert!(frame.values("strain").iter().any(|&e| e != 0.0), "{model}");
    }
}

#[test]
fn pvd_and_csv_times_are_step_times_without_drift() {
    let dir = tmp("times");
    let text = scene_text(
        "linear",
        "type = \"dynamic\"\nmethod = \"backward_euler\"\ndt = 0.1\nduration = 100.0",
        "every = 500",
    );
    let s = scene(&text, &dir, VtuEncoding::Binary);
    let summary = run_dynamic_scene(
        &s,
        &DynamicOverrides::default(),
        true,
        false,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
    .unwrap();
    assert_eq!(summary.steps, 1000);
    // The running sum the integrators keep drifts: 1000 additions of 0.1 give 99.9999999999986.
    let running: f64 = (0..1000).fold(0.0, |t, _| t + 0.1);
    assert_ne!(running, 100.0);
    assert_eq!(summary.end_time, 100.0);
    let file = |ext: &str| {
        summary
            .files
            .iter()
            .find(|f| f.extension().is_some_and(|e| e == ext))
            .unwrap()
            .clone()
    };
    let pvd = std::fs::read_to_string(file("pvd")).unwrap();
    let doc = roxmltree::Document::parse(&pvd).unwrap();
    let times: Vec<&str> = doc
        .descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| n.attribute("timestep").unwrap())
        .collect();
    // Steps 0, 500, 1000: printed exactly as 0, 50 and 100.
    assert_eq!(times, ["0e0", "5e1", "1e2"]);
    let last = vtus(&summary.files).pop().unwrap();
    assert_eq!(vtu::read_vtu(&last).values("TimeValue"), [100.0]);
    // The CSV's time column: row n holds n·dt, exactly (its last row 100).
    let csv = std::fs::read_to_string(file("csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    assert_eq!(header[..2], ["time_s", "step"]);
    for (n, row) in csv.lines().skip(1).enumerate() {
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells[0].parse::<f64>().unwrap(), n as f64 * 0.1, "{row}");
        // `step` is an integer column: digits, not `1e3`.
        assert_eq!(cells[1], n.to_string(), "{row}");
        // No `-0` anywhere (a clamped probe's and the initial state's zeros).
        assert!(cells.iter().all(|c| *c != "-0" && *c != "-0e0"), "{row}");
    }
    assert_eq!(csv.lines().count(), 1002);
}

/// meshio (the Python mesh I/O library) reads the binary files: a static result, a dynamic
/// frame and a quadratic mesh. Skipped, with a message, where `python3` (or `$TETFEM_PYTHON`)
/// has no meshio.
#[test]
fn meshio_reads_the_binary_files() {
    let python = std::env::var("TETFEM_PYTHON").unwrap_or_else(|_| "python3".into());
    let has_meshio = std::process::Command::new(&python)
        .args(["-c", "import meshio"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_meshio {
        println!("skipped: {python} cannot import meshio (set TETFEM_PYTHON to a Python that can)");
        return;
    }
    let dir = tmp("meshio");
    let mesh = mesh();
    let material = Material::new(2e5, 0.25, 3.0).unwrap();
    let u = homogeneous(&mesh, &(Matrix3::identity() * 1.001));
    let linear = dir.join("tet4.vtu");
    write_result_frame(
        &linear,
        &mesh,
        &material,
        &u,
        FrameExtras {
            velocity: Some(&u),
            time: Some(0.5),
            stress_tensors: true,
            ..FrameExtras::default()
        },
    )
    .unwrap();
    let quadratic = dir.join("tet10.vtu");
    let mesh10 = TetMesh::<tetfem::Tet10>::from_linear(&mesh).unwrap();
    let u10 = vec![0.25; mesh10.dof_count()];
    VtuWriter::new(&mesh10)
        .point_field("displacement", 3, &u10)
        .unwrap()
        .write(&quadratic)
        .unwrap();
    // meshio's arrays against the same ones read by our reader: equal as float64, exactly.
    let script = r#"
import sys, meshio, numpy
for path, kind, cells in [(sys.argv[1], "tetra", int(sys.argv[3])), (sys.argv[2], "tetra10", int(sys.argv[3]))]:
    m = meshio.read(path)
    assert m.cells[0].type == kind, (path, m.cells[0].type)
    assert len(m.cells[0].data) == cells, (path, len(m.cells[0].data))
    print(path, m.points.shape[0], repr(float(numpy.asarray(m.point_data["displacement"]).ravel()[-1])))
"#;
    let output = std::process::Command::new(&python)
        .args(["-c", script])
        .arg(&linear)
        .arg(&quadratic)
        .arg(mesh.tet_count().to_string())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 2, "{stdout}");
    for (line, (nodes, last)) in lines.iter().zip([
        (mesh.node_count(), *u.last().unwrap()),
        (mesh10.node_count(), 0.25),
    ]) {
        let parts: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(parts[1].parse::<usize>().unwrap(), nodes, "{line}");
        assert_eq!(parts[2].parse::<f64>().unwrap(), last, "{line}");
    }
}
