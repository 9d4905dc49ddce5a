//! Obstacles in the PNG frames and contact forces in the dynamic summary (issue 18, item 4):
//! the ground drawn where the camera's projection puts it (pixels below its line are its
//! colour, pixels between it and the body are not), the framing left to the body, a sphere's
//! disc, moving obstacles placed at the frame's time, the scene runners drawing them, and a
//! dynamic run's per-obstacle force at the last step (the CSV's last row, the same numbers),
//! its peak, and a block at rest carrying its weight.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use tetfem::TetMesh;
use tetfem::contact::{Obstacle, ObstacleMotion, Shape};
use tetfem::mesh::BoxSplit;
use tetfem_cli::render::{
    BACKGROUND, Field, GROUND_DEPTH, GROUND_MARGIN, Image, OBSTACLE_CUT, OBSTACLE_FILL,
    ObstacleView, RenderOptions, render, view,
};
use tetfem_cli::scene::{
    DynamicOverrides, DynamicSummary, Scene, resume_dynamic_scene, run_dynamic_scene,
};

/// A 0.2 m cube standing 5 cm above the ground z = 0 (x, y in [0, 0.2], z in [0.05, 0.25]).
fn cube() -> TetMesh {
    TetMesh::box_grid(
        Vector3::new(0.0, 0.0, 0.05),
        Vector3::new(0.2, 0.2, 0.25),
        [2, 2, 2],
        BoxSplit::Lecture6,
    )
    .unwrap()
}

/// The ground z = `level` (m).
fn ground_at(level: f64) -> ObstacleView {
    let obstacle = Obstacle::half_space(
        "ground",
        Vector3::new(0.0, 0.0, level),
        Vector3::new(0.0, 0.0, 1.0),
    )
    .unwrap();
    ObstacleView::at(&obstacle, 0.0)
}

fn ground() -> ObstacleView {
    ground_at(0.0)
}

/// The cube at rest (u = 0) coloured by a constant, with `obstacles`, from azimuth `az` and
/// elevation `el` (degrees).
fn picture(
    mesh: &TetMesh,
    obstacles: Vec<ObstacleView>,
    az: f64,
    el: f64,
) -> (Image, RenderOptions) {
    let options = RenderOptions {
        azimuth_deg: az,
        elevation_deg: el,
        obstacles,
        ..RenderOptions::default()
    };
    let u = vec![0.0; mesh.dof_count()];
    let values = vec![1.0; mesh.node_count()];
    let field = Field::Nodes {
        name: "c",
        values: &values,
    };
    (render(mesh, &u, &field, &options).unwrap(), options)
}

fn pixel(image: &Image, (x, y): (f64, f64)) -> [u8; 3] {
    image
        .pixel(x.floor() as u32, y.floor() as u32)
        .unwrap_or_else(|| panic!("({x}, {y}) is outside the image"))
}

#[test]
fn the_ground_is_drawn_below_its_line_and_nowhere_above_it_seen_edge_on() {
    let mesh = cube();
    // From −y, level: screen x is world x, screen up is world z; the ground's plane is edge-on,
    // so it shows as its line with the slab's cut side, OBSTACLE_CUT, below it.
    let (image, options) = picture(&mesh, vec![ground()], -90.0, 0.0);
    let u = vec![0.0; mesh.dof_count()];
    let camera = view(&mesh, &u, &options).unwrap();
    let without = |obstacles: Vec<ObstacleView>| RenderOptions {
        obstacles,
        ..options.clone()
    };
    let alone = view(&mesh, &u, &without(Vec::new())).unwrap();
    // Framed on the body alone (95 % of the plot's 510 px height for its 0.2 m), the ground
    // 5 cm below it would fall under the plot: the view grows to hold its slab.
    assert_ne!(camera, alone);
    let bottom = alone.screen(&Vector3::new(0.1, -0.5, 0.0)).1;
    assert!(bottom > options.height as f64 - 20.0, "{bottom}");
    // A ground 2 mm under the body crosses its view: the framing stays the body's.
    let touching = view(&mesh, &u, &without(vec![ground_at(0.048)])).unwrap();
    assert_eq!(touching, alone);
    // The tile reaches GROUND_MARGIN of the framed box's diagonal past the body on each side;
    // the slab is GROUND_DEPTH of it deep.
    let diagonal = (0.2f64 * 0.2 * 3.0).sqrt();
    let (margin, depth) = (GROUND_MARGIN * diagonal, GROUND_DEPTH * diagonal);
    let at = |x: f64, z: f64| camera.screen(&Vector3::new(x, -0.5, z));
    // Two pixels inside the slab's front face on every side (its edges are outlined), at its
    // middle depth: across the body's width and the margins.
    let mut checked = 0;
    for k in 0..=20 {
        let x = -margin + (0.2 + 2.0 * margin) * k as f64 / 20.0;
        let (sx, sy) = at(x, -0.5 * depth);
        let (left, _) = at(-margin, 0.0);
        let (right, _) = at(0.2 + margin, 0.0);
        assert!(
            sy < options.height as f64 - 20.0,
            "the slab is in the plot: {sy}"
        );
        if sx < left + 2.0 || sx > right - 2.0 {
            continue;
        }
        assert_eq!(
            pixel(&image, (sx, sy)),
            OBSTACLE_CUT,
            "below the ground at x = {x}"
        );
        checked += 1;
    }
    assert!(checked >= 15, "{checked} points checked");
    // Two pixels below the line, under the body's middle.
    let (sx, sy) = at(0.1, 0.0);
    assert_eq!(pixel(&image, (sx, sy + 2.0)), OBSTACLE_CUT);
    // Between the ground and the body (z from 0 to 0.05): nothing drawn, the background.
    for z in [0.01, 0.025, 0.04] {
        assert_eq!(pixel(&image, at(0.1, z)), BACKGROUND, "z = {z}");
    }
    // Past the tile's end, below the ground line: background.
    let (sx, sy) = at(0.2 + margin, -0.5 * depth);
    assert_eq!(pixel(&image, (sx + 3.0, sy)), BACKGROUND);
    // The body is drawn over everything: its middle is neither obstacle nor background.
    let body = pixel(&image, at(0.1, 0.15));
    assert!(
        ![BACKGROUND, OBSTACLE_CUT, OBSTACLE_FILL].contains(&body),
        "{body:?}"
    );
}

#[test]
fn from_above_the_ground_tile_shows_beside_the_body_in_its_own_colour() {
    let mesh = cube();
    let (image, options) = picture(&mesh, vec![ground()], -60.0, 25.0);
    let u = vec![0.0; mesh.dof_count()];
    let camera = view(&mesh, &u, &options).unwrap();
    let diagonal = (0.2f64 * 0.2 * 3.0).sqrt();
    let margin = GROUND_MARGIN * diagonal;
    // On the plane, a third of a margin out from the face x = 0.2, at its back edge y = 0.2:
    // the ray to the eye, along (cos 25° cos −60°, cos 25° sin −60°, sin 25°), moves to larger
    // x, so nothing of the body (x ≤ 0.2) lies between.
    let point = Vector3::new(0.2 + margin / 3.0, 0.2, 0.0);
    let (sx, sy) = camera.screen(&point);
    // Within the obstacles' clip: left of the colour bar, below the subtitle.
    assert!(
        (0.0..815.0).contains(&sx) && (64.0..600.0).contains(&sy),
        "({sx}, {sy}) is outside the drawn area"
    );
    assert_eq!(pixel(&image, (sx, sy)), OBSTACLE_FILL);
    // Above the plane at the same spot, 3 cm up, there is nothing: the background.
    let above = camera.screen(&(point + Vector3::new(0.0, 0.0, 0.03)));
    assert_eq!(pixel(&image, above), BACKGROUND);
    // Without the ground the same pixel is background: the obstacle put it there.
    let (bare, _) = picture(&mesh, Vec::new(), -60.0, 25.0);
    assert_eq!(pixel(&bare, (sx, sy)), BACKGROUND);
}

/// A platen (a half-space above the body, its normal down) seen from above is in front of the
/// body: the body's top face shows through it, blended with the platen's colour; a floor under
/// the body seen from above is behind it: the same pixel is the bare body's. Before the fix
/// every half-space was drawn before the body, so the platen vanished behind the top face.
#[test]
fn a_platen_above_the_body_seen_from_above_is_drawn_over_it() {
    let mesh = cube();
    let platen = {
        let obstacle = Obstacle::half_space(
            "platen",
            Vector3::new(0.0, 0.0, 0.26),
            Vector3::new(0.0, 0.0, -1.0),
        )
        .unwrap();
        ObstacleView::at(&obstacle, 0.0)
    };
    let (bare, options) = picture(&mesh, Vec::new(), -60.0, 25.0);
    let (pressed, _) = picture(&mesh, vec![platen], -60.0, 25.0);
    let (on_floor, _) = picture(&mesh, vec![ground()], -60.0, 25.0);
    let u = vec![0.0; mesh.dof_count()];
    // The centre of the top face: the body, nearest the eye there among its faces.
    let top = view(&mesh, &u, &options)
        .unwrap()
        .screen(&Vector3::new(0.1, 0.1, 0.25));
    let body = pixel(&bare, top);
    assert_ne!(body, BACKGROUND, "the top face is at {top:?}");
    // The floor does not change the body's pixel (the same camera: the framing is the body's).
    assert_eq!(pixel(&on_floor, top), body);
    // The platen covers it partly: neither the bare body's colour nor the opaque fill.
    let covered = pixel(&pressed, top);
    assert_ne!(covered, body);
    assert_ne!(covered, OBSTACLE_FILL);
}

#[test]
fn a_sphere_is_a_disc_of_its_projected_radius_and_a_far_one_is_brought_into_view() {
    let mesh = cube();
    let sphere = |center: Vector3<f64>| {
        ObstacleView::at(&Obstacle::sphere("ball", center, 0.05).unwrap(), 0.0)
    };
    // Centred on the body's left edge x = 0, in front of it.
    let near = sphere(Vector3::new(0.0, -0.1, 0.15));
    let (image, options) = picture(&mesh, vec![near.clone()], -90.0, 0.0);
    let camera = view(&mesh, &vec![0.0; mesh.dof_count()], &options).unwrap();
    let Shape::Sphere { center, radius } = near.shape else {
        unreachable!()
    };
    // Its disc is drawn over the background in front of the body (the body stays on top, so
    // look beside it: the disc's part left of x = 0, at 0.8 R from the centre).
    let inside = camera.screen(&(center - Vector3::new(0.8 * radius, 0.0, 0.0)));
    let outside = camera.screen(&(center - Vector3::new(1.3 * radius, 0.0, 0.0)));
    assert_ne!(pixel(&image, inside), BACKGROUND);
    assert_eq!(pixel(&image, outside), BACKGROUND);
    // The disc's radius in pixels is R·zoom: on its left, the pixel 2 px inside the rim is
    // drawn, 2 px outside is not.
    let (cx, cy) = camera.screen(&center);
    let r = radius * camera.zoom;
    assert_ne!(pixel(&image, (cx - r + 2.0, cy)), BACKGROUND);
    assert_eq!(pixel(&image, (cx - r - 2.0, cy)), BACKGROUND);

    // Where the disc overlaps the body it is nearer the eye (y < 0, the body's y ≥ 0): the body
    // shows through, dimmed, neither its own colour nor the obstacle's. A sphere behind the
    // body (y from 0.25 to 0.35) leaves the body's pixels as they are.
    let (bare, _) = picture(&mesh, Vec::new(), -90.0, 0.0);
    let over_body = camera.screen(&(center + Vector3::new(0.5 * radius, 0.0, 0.0)));
    let (plain, covered) = (pixel(&bare, over_body), pixel(&image, over_body));
    assert_ne!(covered, plain);
    assert_ne!(covered, BACKGROUND);
    let (hidden, _) = picture(
        &mesh,
        vec![sphere(Vector3::new(0.0, 0.3, 0.15))],
        -90.0,
        0.0,
    );
    assert_eq!(pixel(&hidden, over_body), plain);

    // A sphere 10 m away would be wholly outside the body's framing: the view grows to hold it.
    let far = sphere(Vector3::new(10.0, 0.1, 0.15));
    let (image, options) = picture(&mesh, vec![far.clone()], -90.0, 0.0);
    let camera = view(&mesh, &vec![0.0; mesh.dof_count()], &options).unwrap();
    let (fx, fy) = camera.screen(&Vector3::new(10.0, 0.1, 0.15));
    assert!((20.0..810.0).contains(&fx) && (70.0..580.0).contains(&fy));
    assert_ne!(pixel(&image, (fx, fy)), BACKGROUND);
}

#[test]
fn a_moving_obstacle_is_drawn_where_it_is_at_the_frames_time() {
    let v = Vector3::new(0.3, -0.2, 0.1);
    let ball = Obstacle::sphere("ball", Vector3::new(1.0, 2.0, 3.0), 0.5)
        .unwrap()
        .with_motion(ObstacleMotion::Velocity(v))
        .unwrap();
    for t in [0.0, 0.25, 2.0] {
        match ObstacleView::at(&ball, t).shape {
            // c(t) = v·t exactly (one product, one sum per component).
            Shape::Sphere { center, radius } => {
                assert_eq!(center, Vector3::new(1.0, 2.0, 3.0) + v * t);
                assert_eq!(radius, 0.5);
            }
            other => panic!("{other:?}"),
        }
    }
}

/// A fresh output folder for one test.
fn folder(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("obstacle_frames")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The 0.2 m rubber cube (E = 100 kPa, ν = 0.3, ρ = 1000 kg/m³, 4×4×4 cells, no support)
/// `height` m above the ground z = 0, with backward Euler at dt = 0.03 s for `duration` s.
fn block_on_ground(dir: &Path, height: f64, duration: f64, png: bool) -> String {
    format!(
        r#"
title = "block on the ground"
[mesh.box]
min = [0.0, 0.0, {height}]
max = [0.2, 0.2, {top}]
cells = [4, 4, 4]

[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0

[[loads]]
gravity = [0.0, 0.0, -9.81]

[analysis]
type = "dynamic"
method = "backward_euler"
dt = 0.03
duration = {duration}
model = "neo-hookean"

[[obstacles]]
kind = "half_space"
name = "ground"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]

[output]
directory = "{dir}"
vtu = false
every = 1000
png = {png}
"#,
        top = height + 0.2,
        dir = dir.display()
    )
}

fn run(text: &str) -> DynamicSummary {
    let scene: Scene = text.parse().unwrap();
    run_dynamic_scene(
        &scene,
        &DynamicOverrides::default(),
        true,
        false,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
    .unwrap()
}

/// The CSV of a run as its header and rows of numbers.
fn read_csv(summary: &DynamicSummary) -> (Vec<String>, Vec<Vec<f64>>) {
    let path = summary
        .files
        .iter()
        .find(|f| f.extension().is_some_and(|e| e == "csv"))
        .expect("a CSV");
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

/// ρ·g·V of the cube (N).
const WEIGHT: f64 = 1000.0 * 9.81 * 0.008;

#[test]
fn the_dynamic_summary_has_each_obstacles_last_force_as_in_the_csv_and_its_peak() {
    let dir = folder("drop");
    // Dropped 2 cm: it lands, bounces and settles over 50 steps (1.5 s).
    let summary = run(&block_on_ground(&dir, 0.02, 1.5, true));
    let forces = summary.contact_forces.as_ref().expect("contact_forces");
    assert_eq!(forces.len(), 1);
    let ground = &forces[0];
    assert_eq!(ground.obstacle, "ground");
    let (header, rows) = read_csv(&summary);
    let column = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (time, fx, fy, fz) = (
        column("time_s"),
        column("contact_ground_fx_N"),
        column("contact_ground_fy_N"),
        column("contact_ground_fz_N"),
    );
    let last = rows.last().unwrap();
    // The same numbers: the CSV writes the shortest text that reads back to the same f64.
    assert_eq!(ground.force_n, [last[fx], last[fy], last[fz]]);
    // The peak is the largest |F| of the CSV's rows, at that row's time.
    let (peak_row, peak) = rows
        .iter()
        .map(|r| (r, (r[fx] * r[fx] + r[fy] * r[fy] + r[fz] * r[fz]).sqrt()))
        .fold(
            (&rows[0], 0.0),
            |best, (r, m)| if m > best.1 { (r, m) } else { best },
        );
    // |F| summed in another order: a few roundings, 1e-14 relative.
    assert!(
        (ground.peak_n - peak).abs() <= 1e-14 * peak,
        "{} against {peak}",
        ground.peak_n
    );
    assert_eq!(ground.peak_time_s, peak_row[time]);
    // The landing's impact exceeds the resting weight.
    assert!(ground.peak_n > WEIGHT, "{}", ground.peak_n);
    // At rest at the end: the ground carries the weight. The bounce left after 50 strongly
    // damped backward-Euler steps and Newton's 1e-8 tolerance: 1e-6 of W (the drop test of
    // contact_dynamic_scenes.rs measures 2.8e-9).
    let error = (ground.force_n[2] + WEIGHT).abs() / WEIGHT;
    assert!(
        error <= 1e-6,
        "F = {:?} N against W = {WEIGHT} N",
        ground.force_n
    );
    // The JSON summary carries them with their units.
    let json: serde_json::Value = serde_json::from_str(&summary.to_json()).unwrap();
    assert_eq!(json["contact_forces"][0]["peak_n"], ground.peak_n);
    assert_eq!(json["units"]["contact_forces.force_n"], "N");
    assert_eq!(json["units"]["contact_forces.peak_n"], "N");
    assert_eq!(json["units"]["contact_forces.peak_time_s"], "s");
    // Its PNG frames show the ground: its exact fill colour covers part of the last frame.
    let png = summary
        .files
        .iter()
        .rfind(|f| f.extension().is_some_and(|e| e == "png"))
        .expect("a PNG frame");
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(png).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buffer = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buffer).unwrap();
    let ground_pixels = buffer[..info.buffer_size()]
        .chunks_exact(3)
        .filter(|p| *p == OBSTACLE_FILL)
        .count();
    // The tile is wider than the block's footprint: thousands of pixels at 960 × 600.
    assert!(ground_pixels > 1000, "{ground_pixels} ground pixels");
    println!(
        "last F = {:?} N, |F + W|/W = {error:.2e}, peak {:.4e} N at t = {} s, {ground_pixels} ground pixels",
        ground.force_n, ground.peak_n, ground.peak_time_s
    );
}

#[test]
fn a_dynamic_run_without_obstacles_has_no_contact_forces() {
    let dir = folder("free");
    let text = block_on_ground(&dir, 0.02, 0.06, false);
    let start = text.find("[[obstacles]]").unwrap();
    let end = text.find("[output]").unwrap();
    let free = format!("{}{}", &text[..start], &text[end..]).replace(
        "[[loads]]",
        "[[constraints]]\nwhere = { plane = { axis = \"z\", at = 0.02 } }\n\n[[loads]]",
    );
    let summary = run(&free);
    assert_eq!(summary.contact_forces, None);
    let json: serde_json::Value = serde_json::from_str(&summary.to_json()).unwrap();
    assert!(json["contact_forces"].is_null());
    assert!(json["units"].get("contact_forces.force_n").is_none());
}

#[test]
fn a_resumed_run_keeps_the_peak_reached_before_its_checkpoint() {
    // The landing's peak (t = 0.09 s, step 3) lies before the checkpoint at step 10: the
    // resumed run takes it from the checkpoint's record.
    let whole = run(&block_on_ground(&folder("whole"), 0.02, 0.9, false));
    let dir = folder("resumed");
    let first = block_on_ground(&dir, 0.02, 0.3, false)
        .replace("[output]", "[output]\ncheckpoint_every = 10");
    run(&first);
    let rest: Scene = first
        .replace("duration = 0.3", "duration = 0.9")
        .parse()
        .unwrap();
    let resumed = resume_dynamic_scene(&rest, &DynamicOverrides::default(), false, &mut |_, _| {
        std::ops::ControlFlow::Continue(())
    })
    .unwrap();
    assert_eq!(resumed.resumed_from_step, Some(10));
    // A resume continues bit for bit (the restart tests' guarantee): the same forces and peak.
    assert_eq!(resumed.contact_forces, whole.contact_forces);
    let peak = &whole.contact_forces.as_ref().unwrap()[0];
    assert!(peak.peak_time_s < 0.3, "{}", peak.peak_time_s);
    // The barrier's record too (the checkpoint's `contact_barrier` record): the landing's
    // gap errors and smallest gap before the checkpoint are the whole run's.
    assert_eq!(resumed.contact_barrier, whole.contact_barrier);
    let barrier = whole.contact_barrier.unwrap();
    assert!(barrier.gap_error_max > 0.0, "{barrier:?}");
    assert!(
        barrier.smallest_gap_m.is_some_and(|g| g > 0.0),
        "{barrier:?}"
    );
}
