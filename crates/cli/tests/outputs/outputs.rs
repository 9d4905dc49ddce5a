//! Outputs: the .vtu read back (parsed as XML) gives the values written; .pvd and CSV
//! structure; derived fields against closed forms; the PNG renderer; mesh quality and the
//! critical time step.

use crate::common::vtu;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Vector3};
use tetfem::analysis::dynamics::element_step_bound;
use tetfem::fe::quality::tet_quality;
use tetfem::post::output::fields::{
    cell_strain_energy_density, cell_von_mises, displacement_magnitude, von_mises,
};
use tetfem::post::output::{CsvSeries, PvdCollection, write_result_vtu};
use tetfem::{Assembler, BoxSplit, Material, TetMesh};
use tetfem_cli::info::mesh_info;
use tetfem_cli::render::{BACKGROUND, Field, RenderOptions, render};
use tetfem_fixtures::cantilever::Cantilever;

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("outputs");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn small_mesh() -> TetMesh {
    TetMesh::box_grid(
        Vector3::new(0.1, -0.2, 0.0),
        Vector3::new(1.3, 0.4, 0.5),
        [3, 2, 2],
        BoxSplit::Lecture6,
    )
    .unwrap()
}

/// All `<DataArray Name=...>` contents of a `.vtu` (ASCII or appended binary), as numbers
/// (the point coordinates, which have no name, as "Points").
fn data_arrays(path: &Path) -> HashMap<String, Vec<f64>> {
    vtu::read_vtu(path)
        .arrays
        .into_iter()
        .map(|a| (a.name, a.values))
        .collect()
}

#[test]
fn vtu_reads_back_with_the_values_written() {
    let mesh = small_mesh();
    let material = Material::new(2e5, 0.25, 3.0).unwrap();
    // Simple shear u = (γ·y, 0, 0) plus a rigid translation: ε_xy = γ/2, so σ_xy = μγ,
    // von Mises √3·μγ and strain energy density μγ²/2 in every tet.
    let gamma = 1e-3;
    let displacement: Vec<f64> = mesh
        .nodes()
        .iter()
        .flat_map(|p| [gamma * p.y + 0.01, -0.02, 0.003])
        .collect();
    let velocity: Vec<f64> = (0..mesh.dof_count()).map(|i| (i as f64).sin()).collect();
    let path = tmp("shear.vtu");
    write_result_vtu(&path, &mesh, &material, &displacement, Some(&velocity)).unwrap();
    let arrays = data_arrays(&path);
    // Binary f64 (and, in ASCII, Rust's shortest round-trip printing) gives the values back exactly.
    assert_eq!(arrays["displacement"], displacement);
    assert_eq!(arrays["velocity"], velocity);
    assert_eq!(
        arrays["displacement_magnitude"],
        displacement_magnitude(&displacement)
    );
    let points: Vec<f64> = mesh.nodes().iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    assert_eq!(arrays["Points"], points);
    let connectivity: Vec<f64> = mesh.tets().iter().flatten().map(|&n| n as f64).collect();
    assert_eq!(arrays["connectivity"], connectivity);
    assert!(arrays["types"].iter().all(|&t| t == 10.0));
    let mu = material.shear_modulus();
    // Constant-strain tets reproduce a linear field to round-off (relative 1e-9 is generous).
    for &v in &arrays["von_mises"] {
        assert!(
            (v - 3f64.sqrt() * mu * gamma).abs() < 1e-9 * mu * gamma,
            "{v}"
        );
    }
    for &e in &arrays["strain_energy_density"] {
        assert!(
            (e - 0.5 * mu * gamma * gamma).abs() < 1e-9 * mu * gamma * gamma,
            "{e}"
        );
    }
    // Strain energy Σ sedₑ·Vₑ equals ½ uᵀKu from the assembled stiffness.
    let k = Assembler::new(&mesh).stiffness(&mesh, &material).unwrap();
    let ku = k.mul(&displacement).unwrap();
    let half_uku: f64 = 0.5
        * displacement
            .iter()
            .zip(&ku)
            .map(|(a, b)| a * b)
            .sum::<f64>();
    let sed = cell_strain_energy_density(&mesh, &material, &displacement).unwrap();
    let energy: f64 = sed
        .iter()
        .enumerate()
        .map(|(t, e)| e * mesh.element(t).unwrap().volume())
        .sum();
    assert!((energy - half_uku).abs() < 1e-9 * half_uku);
    // A wrong length is an error, not a panic.
    assert!(cell_von_mises(&mesh, &material, &displacement[1..]).is_err());
}

#[test]
fn von_mises_closed_forms() {
    let uniaxial = Matrix3::new(-7.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    assert!((von_mises(&uniaxial) - 7.0).abs() < 1e-12);
    assert!(von_mises(&(Matrix3::identity() * 5.0)).abs() < 1e-12);
    let shear = Matrix3::new(0.0, 2.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    assert!((von_mises(&shear) - 2.0 * 3f64.sqrt()).abs() < 1e-12);
}

#[test]
fn pvd_lists_frames_in_order_and_refuses_going_back() {
    let dir = tmp("pvd_run");
    let _ = std::fs::remove_dir_all(&dir);
    let mut pvd = PvdCollection::new(dir.join("run.pvd"));
    for (i, t) in [0.0, 0.5, 1.25].iter().enumerate() {
        pvd.push(*t, &dir.join(format!("frames/run_{i:04}.vtu")))
            .unwrap();
    }
    assert!(pvd.push(1.0, &dir.join("late.vtu")).is_err());
    assert!(pvd.push(f64::NAN, &dir.join("nan.vtu")).is_err());
    let xml = std::fs::read_to_string(dir.join("run.pvd")).unwrap();
    let doc = roxmltree::Document::parse(&xml).unwrap();
    let frames: Vec<(f64, String)> = doc
        .descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| {
            (
                n.attribute("timestep").unwrap().parse().unwrap(),
                n.attribute("file").unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(
        frames,
        vec![
            (0.0, "frames/run_0000.vtu".to_string()),
            (0.5, "frames/run_0001.vtu".to_string()),
            (1.25, "frames/run_0002.vtu".to_string()),
        ]
    );
    // Atomic writes leave no temporary file behind.
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn csv_series_round_trip() {
    let path = tmp("series.csv");
    let mut csv = CsvSeries::new(&path, vec!["time".into(), "tip, z".into()]).unwrap();
    csv.push(&[0.0, -1.5e-4]).unwrap();
    csv.push(&[0.1, 2.0 / 3.0]).unwrap();
    assert!(csv.push(&[1.0]).is_err());
    csv.write().unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "time,\"tip, z\"");
    let row: Vec<f64> = lines[2].split(',').map(|v| v.parse().unwrap()).collect();
    assert_eq!(row, vec![0.1, 2.0 / 3.0]);
    assert_eq!(lines.len(), 3);
}

#[test]
fn png_of_the_cantilever_has_the_size_asked_and_a_picture() {
    let mut beam = Cantilever::steel_default();
    beam.cells = [20, 2, 2];
    let solved = beam.solve().unwrap();
    let u = &solved.solution.displacement;
    let magnitude = displacement_magnitude(u);
    let (w, h) = (640, 400);
    let image = render(
        &solved.mesh,
        u,
        &Field::Nodes {
            name: "|u| (m)",
            values: &magnitude,
        },
        &RenderOptions {
            width: w,
            height: h,
            title: "Cantilever".into(),
            subtitle: "t = 0 s".into(),
            deformation_scale: 50.0,
            ..RenderOptions::default()
        },
    )
    .unwrap();
    let path = tmp("cantilever.png");
    image.write_png(&path).unwrap();
    // Decode the file itself.
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buffer = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buffer).unwrap();
    assert_eq!((info.width, info.height), (w, h));
    assert_eq!(&buffer[..info.buffer_size()], &image.pixels[..]);
    // The plot area (left of the colour bar, below the title) is substantially covered.
    let mut covered = 0;
    let mut total = 0;
    for y in 70..h - 20 {
        for x in 20..w - 150 {
            total += 1;
            if image.pixel(x, y) != Some(BACKGROUND) {
                covered += 1;
            }
        }
    }
    let fraction = covered as f64 / total as f64;
    assert!(fraction > 0.05 && fraction < 0.9, "covered {fraction}");
    // The colour bar runs from viridis' dark purple (bottom) to yellow (top).
    let bottom = image.pixel(w - 120, h - 42).unwrap();
    let top = image.pixel(w - 120, 72).unwrap();
    assert!(
        bottom[2] > bottom[1] && top[0] > 200 && top[1] > 200,
        "{bottom:?} {top:?}"
    );
    // The title was drawn: dark pixels in the title band.
    let dark = (0..300)
        .flat_map(|x| (10..40).map(move |y| (x, y)))
        .filter(|&(x, y)| image.pixel(x, y).unwrap()[0] < 100)
        .count();
    assert!(dark > 50, "{dark}");
    // Wrong field length: an error, not a panic.
    let bad = render(
        &solved.mesh,
        u,
        &Field::Cells {
            name: "x",
            values: &magnitude,
        },
        &RenderOptions::default(),
    );
    assert!(bad.is_err());
}

#[test]
fn regular_tet_quality_and_critical_step_scaling() {
    let s = 1.0 / 2f64.sqrt();
    let x = [
        Vector3::new(1.0, 0.0, -s),
        Vector3::new(-1.0, 0.0, -s),
        Vector3::new(0.0, 1.0, s),
        Vector3::new(0.0, -1.0, s),
    ];
    let mesh = TetMesh::new(x.to_vec(), vec![[0, 1, 2, 3]]).unwrap();
    let q = tet_quality(&mesh.element(0).unwrap(), &mesh.tet_positions(0).unwrap());
    let regular = (1.0f64 / 3.0).acos();
    assert!((q.min_dihedral - regular).abs() < 1e-12 && (q.max_dihedral - regular).abs() < 1e-12);
    assert!((q.aspect_ratio - 1.0).abs() < 1e-12);
    // Inradius of a regular tet of edge a = 2: a/√24.
    assert!((q.inradius - 2.0 / 24f64.sqrt()).abs() < 1e-12);

    // dt scales with the element size and with 1/√E (c_p ∝ √(E/ρ)).
    let material = Material::new(1e6, 0.3, 1000.0).unwrap();
    let box_mesh = |size: f64| {
        TetMesh::box_grid(
            Vector3::zeros(),
            Vector3::new(size, size, 2.0 * size),
            [2, 2, 4],
            BoxSplit::Lecture6,
        )
        .unwrap()
    };
    let base = element_step_bound(&box_mesh(1.0), &material);
    let doubled = element_step_bound(&box_mesh(2.0), &material);
    assert!((doubled.dt_element / base.dt_element - 2.0).abs() < 1e-9);
    let stiff = Material::new(4e6, 0.3, 1000.0).unwrap();
    let stiffer = element_step_bound(&box_mesh(1.0), &stiff);
    assert!((stiffer.dt_element / base.dt_element - 0.5).abs() < 1e-9);
    // The element bound sits below the geometric rule of thumb h_min/c_p, within a factor 3.
    assert!(base.dt_element < base.dt_geometric && base.dt_element > base.dt_geometric / 3.0);
}

#[test]
fn mesh_info_of_the_gmsh_bracket() {
    let path =
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../..")).join("scenes/l_bracket.msh");
    let info = mesh_info(&path, Some(Material::steel())).unwrap();
    let s = &info.statistics;
    assert!((s.volume - 7.2e-5).abs() < 1e-12);
    // Gmsh's Delaunay meshes have no slivers on this simple shape.
    assert!(s.min_dihedral_deg.min > 5.0 && s.min_dihedral_deg.min < 70.6);
    assert!(s.aspect_ratio.min >= 1.0 - 1e-12);
    assert_eq!(info.groups.len(), 3);
    let text = info.to_string();
    assert!(
        text.contains("explicit critical step") && text.contains("\"clamp\""),
        "{text}"
    );
    let json: serde_json::Value = serde_json::from_str(&info.to_json()).unwrap();
    assert_eq!(json["statistics"]["tets"].as_u64(), Some(s.tets as u64));
    // From a scene: its mesh and material.
    let scene =
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../..")).join("scenes/hanging_bar.toml");
    let info = mesh_info(&scene, None).unwrap();
    assert_eq!(info.statistics.tets, 2 * 2 * 20 * 6);
    assert!(info.critical_step.is_some());
}

#[test]
fn result_files_hold_stress_tensors_principal_and_nodal_stresses() {
    // Simple shear u = (γ·y, 0, 0): σ_xy = μγ is the only stress, in every tet and so at every
    // node; its principal stresses are (μγ, 0, −μγ).
    let mesh = small_mesh();
    let material = Material::new(2e5, 0.25, 3.0).unwrap();
    let gamma = 1e-3;
    let displacement: Vec<f64> = mesh
        .nodes()
        .iter()
        .flat_map(|p| [gamma * p.y, 0.0, 0.0])
        .collect();
    let path = tmp("shear_fields.vtu");
    tetfem::post::output::write_result_frame(
        &path,
        &mesh,
        &material,
        &displacement,
        tetfem::post::output::FrameExtras {
            time: Some(0.25),
            stress_tensors: true,
            ..Default::default()
        },
    )
    .unwrap();
    let arrays = data_arrays(&path);
    let tau = material.shear_modulus() * gamma;
    // Constant-strain tets reproduce the field to round-off of the gradients (1e-9 of τ).
    let close = |a: f64, b: f64| (a - b).abs() < 1e-9 * tau;
    for (name, expected) in [
        ("stress", [0.0, 0.0, 0.0, tau, 0.0, 0.0].as_slice()),
        ("stress_nodal", [0.0, 0.0, 0.0, tau, 0.0, 0.0].as_slice()),
        ("principal_stress_1", [tau].as_slice()),
        ("principal_stress_2", [0.0].as_slice()),
        ("principal_stress_3", [-tau].as_slice()),
    ] {
        let values = &arrays[name];
        assert_eq!(values.len() % expected.len(), 0, "{name}");
        for chunk in values.chunks(expected.len()) {
            for (v, e) in chunk.iter().zip(expected) {
                assert!(close(*v, *e), "{name}: {chunk:?}");
            }
        }
    }
    assert_eq!(arrays["stress"].len(), 6 * mesh.tet_count());
    assert_eq!(arrays["stress_nodal"].len(), 6 * mesh.node_count());
    for &v in &arrays["von_mises_nodal"] {
        assert!(close(v, 3f64.sqrt() * tau), "{v}");
    }
    assert!(arrays["material_id"].iter().all(|&id| id == 0.0));
    assert_eq!(arrays["TimeValue"], vec![0.25]);
    // For ParaView: the material an integer (coloured by category), the principal stresses
    // three named scalars (a 3-vector would offer a meaningless magnitude).
    let file = vtu::read_vtu(&path);
    assert_eq!(file.array("material_id").vtk_type, "Int32");
    assert!(!file.has("principal_stress"));
    for k in 1..=3 {
        let array = file.array(&format!("principal_stress_{k}"));
        assert_eq!(
            (array.components, array.values.len()),
            (1, mesh.tet_count())
        );
    }
}
