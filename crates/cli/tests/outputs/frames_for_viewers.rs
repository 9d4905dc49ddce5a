//! Frames that say what they show (issue 33, item 13 and the ParaView outputs): the PNG frames
//! of a run on moving supports had their colour range and magnification from the static shape
//! ("deformation ×3508", a colour bar to 2.9e-5 m while |u| reached 9.3e-4 m); and obstacles
//! were only in the PNGs, not in files ParaView opens.

use crate::common;

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use tetfem_cli::render::{PNG_TEXT_RANGE, PNG_TEXT_SCALE};
use tetfem_cli::scene::{DynamicOverrides, RunOptions, Scene, run_dynamic_scene, run_static_with};

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("frames_for_viewers")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn go(_: usize, _: usize) -> ControlFlow<()> {
    ControlFlow::Continue(())
}

/// The `iTXt` entry `keyword` of the PNG at `path`.
fn png_text(path: &Path, keyword: &str) -> String {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let reader = decoder.read_info().unwrap();
    reader
        .info()
        .utf8_text
        .iter()
        .find(|t| t.keyword == keyword)
        .unwrap_or_else(|| panic!("{}: no {keyword}", path.display()))
        .get_text()
        .unwrap()
}

/// The largest |u| (m) of a `.vtu` frame.
fn largest_u(path: &Path) -> f64 {
    let vtu = common::parse_vtu(std::fs::read(path).unwrap());
    let (_, _, _, values) = vtu.array("displacement_magnitude").unwrap();
    values.iter().copied().fold(0.0, f64::max)
}

/// `scenes/shaken_base.toml` with PNG frames: each frame's colour bar reaches at least the
/// largest |u| of that frame (read from its `.vtu`), and its magnification draws that |u| no
/// larger than a tenth of the body's size (the magnification rule) times the headroom, so
/// that the body is not flung off its frame.
#[test]
fn shaken_base_frames_have_a_colour_bar_covering_their_displacement() {
    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/shaken_base.toml");
    let mut scene = Scene::load(&scene_path).unwrap();
    let out = out_dir("shaken_base");
    scene.set_output_directory(out.clone());
    let summary =
        run_dynamic_scene(&scene, &DynamicOverrides::default(), true, true, &mut go).unwrap();
    let pngs: Vec<&PathBuf> = summary
        .files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "png"))
        .collect();
    assert_eq!(
        pngs.len(),
        101,
        "a frame every 10 of 1000 steps, and step 0"
    );
    // The body's bounding-box diagonal: 1 × 0.2 × 0.1 m.
    let size = (1.0f64 + 0.04 + 0.01).sqrt();
    let (mut largest, mut lowest_top) = (0.0f64, f64::INFINITY);
    for png in pngs {
        let u = largest_u(&png.with_extension("vtu"));
        let range: Vec<f64> = png_text(png, PNG_TEXT_RANGE)
            .split(' ')
            .map(|v| v.parse().unwrap())
            .collect();
        let scale: f64 = png_text(png, PNG_TEXT_SCALE).parse().unwrap();
        assert!(
            range[1] >= u,
            "{}: colour bar to {:e}, |u| up to {u:e}",
            png.display(),
            range[1]
        );
        // Drawn at most 0.1·size (the rule), with the 1.25 headroom's slack none is needed
        // here: a frame's |u| is at most what the scale was chosen for.
        assert!(
            scale * u <= 0.1 * size * (1.0 + 1e-12),
            "{}: ×{scale} of {u:e}",
            png.display()
        );
        largest = largest.max(u);
        lowest_top = lowest_top.min(range[1]);
    }
    println!("largest |u| {largest:.3e} m; lowest colour-bar top {lowest_top:.3e} m");
    // The base alone moves 1 mm·sin(2π·100 Hz·t): from the first frame on the range holds
    // its largest value at the frame times (every 1 ms: sin(0.4π) = 0.951, so 9.51e-4 m) plus
    // the static sag — the prescribed motion is foreseen — not the 2.9e-5 m of twice the sag.
    assert!(lowest_top >= 9.5e-4, "{lowest_top:e}");
}

/// A block dropped onto the ground and a sphere, a few explicit steps with a frame every 5:
/// `<stem>_obstacles.pvd` lists one `.vtp` per body frame at the same times, each a PolyData
/// file with the ground's tile on z = 0 under the body and the sphere's points at its radius.
#[test]
fn obstacles_are_written_as_their_own_frames_for_paraview() {
    let text = r#"title = "drop"
[mesh.box]
min = [0.0, 0.0, 0.05]
max = [0.2, 0.2, 0.25]
cells = [2, 2, 2]
[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0
[[loads]]
gravity = [0.0, 0.0, -9.81]
[analysis]
type = "dynamic"
method = "explicit"
dt = 1e-4
duration = 2e-3
[[obstacles]]
kind = "half_space"
name = "ground"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[[obstacles]]
kind = "sphere"
name = "ball"
center = [0.1, 0.1, 0.5]
radius = 0.1
[output]
every = 5
"#;
    let mut scene: Scene = text.parse().unwrap();
    let out = out_dir("obstacles");
    scene.set_output_directory(out.clone());
    run_dynamic_scene(&scene, &DynamicOverrides::default(), true, false, &mut go).unwrap();
    let frames = |pvd: &str| -> Vec<(f64, String)> {
        let text = std::fs::read_to_string(out.join(pvd)).unwrap();
        let doc = roxmltree::Document::parse(&text).unwrap();
        doc.descendants()
            .filter(|n| n.has_tag_name("DataSet"))
            .map(|n| {
                (
                    n.attribute("timestep").unwrap().parse().unwrap(),
                    n.attribute("file").unwrap().to_string(),
                )
            })
            .collect()
    };
    let body = frames("scene.pvd");
    let obstacles = frames("scene_obstacles.pvd");
    assert_eq!(body.len(), 5, "steps 0, 5, 10, 15, 20");
    let times = |f: &[(f64, String)]| f.iter().map(|(t, _)| *t).collect::<Vec<_>>();
    assert_eq!(times(&body), times(&obstacles));
    for (_, file) in &obstacles {
        let text = std::fs::read_to_string(out.join(file)).unwrap();
        let doc = roxmltree::Document::parse(&text).unwrap();
        let piece = doc.descendants().find(|n| n.has_tag_name("Piece")).unwrap();
        let polys: usize = piece.attribute("NumberOfPolys").unwrap().parse().unwrap();
        let points: Vec<f64> = doc
            .descendants()
            .find(|n| n.has_tag_name("Points"))
            .and_then(|p| p.descendants().find(|n| n.has_tag_name("DataArray")))
            .and_then(|a| a.text())
            .unwrap()
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        // The ground: one quad, 4 points on z = 0 around the body's centre (0.1, 0.1).
        let ground = &points[..12];
        assert!(ground.chunks(3).all(|p| p[2] == 0.0), "{ground:?}");
        let mean_x = ground.chunks(3).map(|p| p[0]).sum::<f64>() / 4.0;
        assert!((mean_x - 0.1).abs() < 1e-12, "{mean_x}");
        // The ball: every point at its radius from its centre, to round-off.
        for p in points[12..].chunks(3) {
            let r = ((p[0] - 0.1).powi(2) + (p[1] - 0.1).powi(2) + (p[2] - 0.5).powi(2)).sqrt();
            assert!((r - 0.1).abs() < 1e-12, "{r}");
        }
        // One quad of ground; 24 segments × 12 rings of the sphere.
        assert_eq!(polys, 1 + 24 * 12);
        let ids: Vec<i64> = doc
            .descendants()
            .find(|n| n.attribute("Name") == Some("obstacle"))
            .and_then(|a| a.text())
            .unwrap()
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(ids.len(), polys);
        assert_eq!((ids[0], ids[1], ids[polys - 1]), (0, 1, 1));
    }

    // A static scene with obstacles (the block of `contact_scenes.rs` resting on the ground,
    // held sideways by symmetry planes) writes `<stem>_obstacles.vtp`.
    let text = r#"
[mesh.box]
max = [0.2, 0.2, 0.2]
cells = [2, 2, 2]
[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
fix = ["x"]
[[constraints]]
where = { plane = { axis = "y", at = 0.0 } }
fix = ["y"]
[[loads]]
gravity = [0.0, 0.0, -9.81]
[[obstacles]]
kind = "half_space"
name = "ground"
point = [0.0, 0.0, -1e-4]
normal = [0.0, 0.0, 1.0]
"#;
    let mut scene: Scene = text.parse().unwrap();
    let out = out_dir("obstacles_static");
    scene.set_output_directory(out.clone());
    let summary = run_static_with(&scene, &RunOptions::default()).unwrap();
    let vtp = out.join("scene_obstacles.vtp");
    assert!(summary.files.contains(&vtp), "{:?}", summary.files);
    assert!(roxmltree::Document::parse(&std::fs::read_to_string(&vtp).unwrap()).is_ok());
}
