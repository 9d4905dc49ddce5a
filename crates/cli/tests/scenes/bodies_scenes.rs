//! Several bodies in a scene (issue 36): the shipped `blocks_head_on` scene — two rubber
//! blocks thrown at each other, `[[bodies]]` and `[self_contact]` — run for a few steps past
//! first contact, checked from its CSV (momentum, smallest distance) and its last frame
//! (`body_id`); and the combinations the library refuses, named at the scene's key.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use tetfem_cli::scene::{
    DynamicOverrides, RunLength, RunOptions, Scene, run_dynamic_scene, run_static_with,
};

fn out_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("bodies_scenes")
        .join(name)
}

/// The CSV's header and rows.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|s| s.to_string())
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.trim().parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn blocks_head_on_keep_momentum_and_never_touch() {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes"));
    let mut scene = Scene::load(&root.join("blocks_head_on.toml")).unwrap();
    let dir = out_dir("blocks_head_on");
    scene.set_output_directory(dir.clone());
    // 24 steps of 0.5 ms: contact begins at 4.5 ms (1 cm closing at 2 m/s, less d̂), so the
    // last 15 steps are in contact.
    let overrides = DynamicOverrides {
        length: Some(RunLength::Steps(24)),
        ..DynamicOverrides::default()
    };
    run_dynamic_scene(&scene, &overrides, true, false, &mut |_, _| {
        ControlFlow::Continue(())
    })
    .unwrap();
    let (header, rows) = read_csv(&dir.join("blocks_head_on.csv"));
    let column = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (p0, p1) = (column("body0_px_Ns"), column("body1_px_Ns"));
    let distance = column("min_surface_distance_m");
    let start = rows[0][p0].abs() + rows[0][p1].abs();
    let mut drift: f64 = 0.0;
    let mut smallest = f64::INFINITY;
    for row in &rows {
        drift = drift.max((row[p0] + row[p1]).abs() / start);
        smallest = smallest.min(row[distance]);
    }
    let last = rows.last().unwrap();
    println!(
        "blocks_head_on, {} rows: momentum drift {drift:.2e}, smallest distance {smallest:.3e} m, \
         body 0 px {:.4} → {:.4} N·s",
        rows.len(),
        rows[0][p0],
        last[p0]
    );
    // The barrier's forces are internal: the total momentum moves only by the Newton
    // residual's sum, dt·Σr per step at the scene's default tolerance (1e-8 of the step's
    // inertial residual ~ M·v/dt), 1e-8 of the bodies' momentum per step at most.
    assert!(drift < 1e-6, "momentum drift {drift:e}");
    // Contact happened (a pair within d̂ = 2 mm) and no step reached distance 0.
    assert!(smallest > 0.0 && smallest < 2e-3, "{smallest:e}");
    // Body 0 was slowed by the contact: its momentum (1 kg at 1 m/s) dropped.
    assert!(
        last[p0] < 0.9 * rows[0][p0],
        "{} → {}",
        rows[0][p0],
        last[p0]
    );
    // The frame's XML header (its data may be binary) names the cell field.
    let frame = std::fs::read(dir.join("blocks_head_on_0024.vtu")).unwrap();
    let name = b"Name=\"body_id\"";
    assert!(frame.windows(name.len()).any(|w| w == name));
}

/// The shipped `blocks_head_on` scene with `method = "newmark"` (the library's rule admits it
/// with a warning that impacts lose energy): 24 steps of 0.5 ms, as above, through the
/// scene's run — momentum kept, contact reached, no distance 0.
#[test]
fn blocks_head_on_run_with_newmark() {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes"));
    let text = std::fs::read_to_string(root.join("blocks_head_on.toml")).unwrap();
    let text = text.replace("method = \"backward_euler\"", "method = \"newmark\"");
    assert!(text.contains("method = \"newmark\""));
    let mut scene: Scene = text.parse().unwrap();
    let dir = out_dir("blocks_head_on_newmark");
    scene.set_output_directory(dir.clone());
    let overrides = DynamicOverrides {
        length: Some(RunLength::Steps(24)),
        ..DynamicOverrides::default()
    };
    run_dynamic_scene(&scene, &overrides, true, false, &mut |_, _| {
        ControlFlow::Continue(())
    })
    .unwrap();
    let (header, rows) = read_csv(&dir.join("scene.csv"));
    let column = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (p0, p1) = (column("body0_px_Ns"), column("body1_px_Ns"));
    let distance = column("min_surface_distance_m");
    let start = rows[0][p0].abs() + rows[0][p1].abs();
    let drift = rows
        .iter()
        .map(|row| (row[p0] + row[p1]).abs() / start)
        .fold(0.0, f64::max);
    let smallest = rows
        .iter()
        .map(|row| row[distance])
        .fold(f64::INFINITY, f64::min);
    println!(
        "blocks_head_on with newmark, {} rows: momentum drift {drift:.2e}, smallest distance \
         {smallest:.3e} m",
        rows.len()
    );
    // As for backward Euler above: the Newton residual's sum alone moves the momentum, 1e-8
    // of the bodies' momentum per step at most at the scene's default tolerance.
    assert!(drift < 1e-6, "momentum drift {drift:e}");
    assert!(smallest > 0.0 && smallest < 2e-3, "{smallest:e}");
}

/// The library's rule, named at the scene's key: several bodies in a modal analysis (no
/// contact about the rest state).
#[test]
fn bodies_in_a_modal_scene_are_refused_at_their_key() {
    let text = "[mesh.box]\nmax = [0.1, 0.1, 0.1]\ncells = [2, 2, 2]\n\n[material]\n\
                youngs_modulus = 1e6\npoisson_ratio = 0.3\ndensity = 1000.0\n\n\
                [[bodies]]\n\n[[bodies]]\ntranslation = [0.2, 0.0, 0.0]\n\n\
                [analysis]\ntype = \"modal\"\n";
    let err = text.parse::<Scene>().unwrap_err().to_string();
    println!("{err}");
    assert!(err.contains("bodies") && err.contains("modal"), "{err}");
}

/// A static `[[bodies]]` scene: a rubber block resting on another, the lower one clamped at
/// z = 0, the upper one on rollers (u_x = 0 on x = 0, u_y = 0 on y = 0: its lateral
/// translations and turn about z; they carry no z force) and pressed by 50 N on its top. The
/// load reaches the clamp only through the surface barrier, so the clamp's z reaction is F.
#[test]
fn a_block_resting_on_a_clamped_block_runs_statically() {
    let text = r#"
[mesh.box]
max = [0.1, 0.1, 0.1]
cells = [2, 2, 2]
split = "lecture6"

[material]
youngs_modulus = 1e6
poisson_ratio = 0.3
density = 1000.0

[[bodies]]

[[bodies]]
translation = [0.0, 0.0, 0.101]

[self_contact]
distance = 2e-3
stiffness = 1e3

[[constraints]]
where = { plane = { axis = "z", at = 0.0 } }

[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
fix = ["x"]

[[constraints]]
where = { plane = { axis = "y", at = 0.0 } }
fix = ["y"]

[[loads]]
where = { plane = { axis = "z", at = 0.201 } }
total_force = [0.0, 0.0, -50.0]

[analysis]
type = "static"
model = "neo-hookean"
load_steps = 4
"#;
    let mut scene: Scene = text.parse().unwrap();
    let dir = out_dir("static_bodies");
    scene.set_output_directory(dir.clone());
    let summary = run_static_with(&scene, &RunOptions::default()).unwrap();
    // Each tet's body is in the result's .vtu, as in a dynamic run's frames.
    let frame = std::fs::read(dir.join("scene.vtu")).unwrap();
    let name = b"Name=\"body_id\"";
    assert!(frame.windows(name.len()).any(|w| w == name));
    let rows = summary.reactions.clone().unwrap();
    let z: Vec<f64> = rows.iter().map(|r| r.force_n[2]).collect();
    println!(
        "static bodies scene: residual {:.3e}, reactions z {z:?} N, max displacement {:.4e} m",
        summary.relative_residual, summary.max_displacement
    );
    // Newton stops at 1e-10 of the load; a support's z sum misses F by at most the free z
    // residuals' sum (√n_f·‖r_f‖ ≈ 20·1e-10·F here): 1e-8 holds it with room.
    assert!((z[0] - 50.0).abs() <= 1e-8 * 50.0, "clamp z {} N", z[0]);
    // The rollers hold x or y only: their z reaction is none.
    assert!(z[1] == 0.0 && z[2] == 0.0, "{z:?}");
}

/// Two bodies of their own meshes and materials: body 0 a copy of `[mesh]` (a 0.1 m cube,
/// ρ = 1000 kg/m³), body 1 its own 0.05 × 0.1 × 0.1 m box with ρ = 3000 kg/m³ from a
/// `[[materials]]` entry `where = { body = 1 }`, thrown at each other at ±1 m/s.
const UNEQUAL_BODIES: &str = r#"
[mesh.box]
max = [0.1, 0.1, 0.1]
cells = [2, 2, 2]
split = "lecture6"

[material]
youngs_modulus = 1e6
poisson_ratio = 0.3
density = 1000.0

[[materials]]
where = { body = 1 }
youngs_modulus = 2e6
poisson_ratio = 0.3
density = 3000.0

[[bodies]]
velocity = [1.0, 0.0, 0.0]

[[bodies]]
mesh = { box = { max = [0.05, 0.1, 0.1], cells = [1, 2, 2], split = "lecture6" } }
translation = [0.11, 0.0, 0.0]
velocity = [-1.0, 0.0, 0.0]

[[probes]]
name = "light"
where = { body = 0 }

[self_contact]
distance = 2e-3
stiffness = 1e3

[analysis]
type = "dynamic"
method = "backward_euler"
model = "neo-hookean"
dt = 5e-4
duration = 0.012
"#;

#[test]
fn bodies_of_their_own_meshes_and_materials_carry_their_own_momentum() {
    let mut scene: Scene = UNEQUAL_BODIES.parse().unwrap();
    let dir = out_dir("unequal_bodies");
    scene.set_output_directory(dir.clone());
    run_dynamic_scene(
        &scene,
        &DynamicOverrides::default(),
        true,
        false,
        &mut |_, _| ControlFlow::Continue(()),
    )
    .unwrap();
    let (header, rows) = read_csv(&dir.join("scene.csv"));
    let column = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (p0, p1) = (column("body0_px_Ns"), column("body1_px_Ns"));
    let distance = column("min_surface_distance_m");
    // Each body's momentum at rest state is ρ·V·v: 1000·1e-3·1 = 1 N·s and
    // 3000·5e-4·(−1) = −1.5 N·s (the mass matrix's rows sum to ρ·V exactly up to round-off;
    // 1e-12 is a few hundred ulps of the sums over the nodes).
    assert!(
        (rows[0][p0] - 1.0).abs() < 1e-12,
        "body 0: {} N·s",
        rows[0][p0]
    );
    assert!(
        (rows[0][p1] + 1.5).abs() < 1e-12,
        "body 1: {} N·s",
        rows[0][p1]
    );
    let total = rows[0][p0] + rows[0][p1];
    let mut drift: f64 = 0.0;
    let mut smallest = f64::INFINITY;
    for row in &rows {
        drift = drift.max((row[p0] + row[p1] - total).abs() / 2.5);
        smallest = smallest.min(row[distance]);
    }
    let last = rows.last().unwrap();
    println!(
        "unequal bodies, {} rows: momentum drift {drift:.2e} of 2.5 N·s, smallest distance \
         {smallest:.3e} m, px {:.4} / {:.4} → {:.4} / {:.4} N·s",
        rows.len(),
        rows[0][p0],
        rows[0][p1],
        last[p0],
        last[p1]
    );
    // As in the head-on scene: the barrier is internal, the drift is Newton's residual.
    assert!(drift < 1e-6, "momentum drift {drift:e}");
    assert!(smallest > 0.0 && smallest < 2e-3, "{smallest:e}");
    // The heavier body wins: the light one (1 N·s forward) is pushed back past rest.
    assert!(last[p0] < 0.0, "body 0 ends at {} N·s", last[p0]);
    // The probe over body 0's nodes moved forward first (+x at 1 m/s).
    let ux = column("light_ux_m");
    assert!(rows[4][ux] > 0.0, "{}", rows[4][ux]);
}

/// Friction between bodies in a static scene (where nothing lags it) is refused at its key.
#[test]
fn friction_between_bodies_in_a_static_scene_is_refused_at_its_key() {
    let text = "[mesh.box]\nmax = [0.1, 0.1, 0.1]\ncells = [2, 2, 2]\n\n[material]\n\
                youngs_modulus = 1e6\npoisson_ratio = 0.3\ndensity = 1000.0\n\n\
                [[bodies]]\n\n[[bodies]]\ntranslation = [0.0, 0.0, 0.101]\n\n\
                [self_contact]\nfriction = 0.3\n\n\
                [[constraints]]\nwhere = { plane = { axis = \"z\", at = 0.0 } }\n\n\
                [analysis]\ntype = \"static\"\nmodel = \"neo-hookean\"\n";
    let err = text.parse::<Scene>().unwrap_err().to_string();
    println!("{err}");
    assert!(
        err.contains("self_contact.friction") && err.contains("static"),
        "{err}"
    );
}

#[test]
fn a_body_selection_names_the_bodies_there_are() {
    let text = UNEQUAL_BODIES.replace("where = { body = 1 }", "where = { body = 2 }");
    let err = text.parse::<Scene>().and_then(|s| s.build().map(|_| ()));
    let err = err.unwrap_err().to_string();
    println!("{err}");
    assert!(
        err.contains("materials[0].where.body") && err.contains("the scene has 2"),
        "{err}"
    );
}
