//! `[[obstacles]]` in dynamic scenes (issue 18): a block dropped on the ground with backward
//! Euler at over 10× the explicit critical step, the same drop with the explicit method, an
//! obstacle moving at constant velocity and one lowered by an amplitude, and the keys of a
//! moving obstacle checked with their key and line.

use crate::common::vtu;

use std::path::{Path, PathBuf};

use tetfem::Error;
use tetfem_cli::scene::{DynamicOverrides, DynamicSummary, Scene, run_dynamic_scene};

/// A fresh output folder for one test.
fn folder(name: &str) -> PathBuf {
    let dir = crate::common::scratch_dir("contact_dynamic_scenes", name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn run(text: &str) -> tetfem::base::error::Result<DynamicSummary> {
    let scene: Scene = text.parse()?;
    run_dynamic_scene(
        &scene,
        &DynamicOverrides::default(),
        true,
        false,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
}

/// The CSV as a header and rows of numbers.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
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

fn column(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

/// A 0.2 m rubber cube (E = 100 kPa, ν = 0.3, ρ = 1000 kg/m³, 4×4×4 cells) `height` m above the
/// ground z = 0, falling under gravity with no support: only the ground holds it.
fn drop_scene(
    dir: &Path,
    method: &str,
    dt: f64,
    duration: f64,
    height: f64,
    every: usize,
) -> String {
    format!(
        r#"
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
method = "{method}"
dt = {dt}
duration = {duration}
model = "neo-hookean"

[[obstacles]]
kind = "half_space"
name = "ground"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]

[output]
directory = "{dir}"
every = {every}
"#,
        top = height + 0.2,
        dir = dir.display()
    )
}

const WEIGHT: f64 = 1000.0 * 9.81 * 0.008;

/// The smallest `contact_gap` (m) over every node of every `.vtu` frame in `dir`, and the
/// number of frames.
fn smallest_gap(dir: &Path) -> (f64, usize) {
    let mut frames = 0;
    let mut smallest = f64::INFINITY;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "vtu") {
            let frame = vtu::read_vtu(&path);
            let gaps = frame.values("contact_gap");
            assert!(frame.has("contact_pressure"));
            smallest = gaps.iter().copied().fold(smallest, f64::min);
            frames += 1;
        }
    }
    (smallest, frames)
}

#[test]
fn backward_euler_drop_above_10x_the_critical_step_settles_on_the_ground() {
    let dir = folder("be_drop");
    // A 2 cm fall; dt = 0.03 s against a critical step of 2.66e-3 s.
    let summary = run(&drop_scene(&dir, "backward_euler", 0.03, 1.5, 0.02, 1)).unwrap();
    assert!(
        summary.dt_over_critical >= 10.0,
        "{}",
        summary.dt_over_critical
    );
    // The barrier: every node of every frame strictly above the ground (not merely a bound).
    let (gap, frames) = smallest_gap(&dir);
    assert_eq!(frames, summary.steps + 1);
    assert!(gap > 0.0, "a node reached the ground: gap {gap:e} m");

    let (header, rows) = read_csv(&dir.join(format!("{}.csv", summary_stem(&summary))));
    let (total, barrier, fz) = (
        column(&header, "total_J"),
        column(&header, "contact_energy_J"),
        column(&header, "contact_ground_fz_N"),
    );
    let first_contact = rows.iter().position(|r| r[fz] != 0.0).expect("no contact");
    let energy = |r: &Vec<f64>| r[total] + r[barrier];
    let scale = energy(&rows[0]).abs().max(WEIGHT * 0.02);
    let mut rise: f64 = 0.0;
    for pair in rows[first_contact..].windows(2) {
        rise = rise.max(energy(&pair[1]) - energy(&pair[0]));
    }
    // Backward Euler only dissipates; the Newton tolerance (1e-8 of the step's force scale)
    // leaves energy noise far below 1e-7 of the fall's energy scale W·h.
    assert!(
        rise <= 1e-7 * scale,
        "energy rose by {rise:e} J after first contact"
    );
    // At rest the ground carries the weight. What is left of the bounce after 50 strongly
    // damped steps and Newton's 1e-8 tolerance: 1e-6 of W allowed.
    let last = rows.last().unwrap();
    let error = (last[fz] + WEIGHT).abs() / WEIGHT;
    assert!(
        error <= 1e-6,
        "contact force {} N against W = {WEIGHT} N",
        last[fz]
    );
    println!(
        "dt/critical {:.2}, smallest gap {gap:.3e} m, largest energy rise {rise:.3e} J, |F + W|/W = {error:.2e}",
        summary.dt_over_critical
    );
}

/// The stem of the files of a run written to its folder (the scene parsed from a string has
/// the stem `scene`).
fn summary_stem(summary: &DynamicSummary) -> String {
    summary
        .files
        .iter()
        .find(|f| f.extension().is_some_and(|e| e == "csv"))
        .and_then(|f| f.file_stem())
        .map(|s| s.to_string_lossy().into_owned())
        .expect("a CSV")
}

#[test]
fn explicit_drop_below_the_critical_step_stays_above_the_ground_with_bounded_energy() {
    let dir = folder("explicit_drop");
    // A 1 mm fall at a hundredth of the critical step (explicit contact holds at any step up
    // to the critical one since issue 35; the scene kept from when the barrier bounded it).
    let h = 0.001;
    let summary = run(&drop_scene(&dir, "explicit", 2.5e-5, 0.06, h, 200)).unwrap();
    let (gap, _) = smallest_gap(&dir);
    assert!(gap > 0.0, "gap {gap:e} m");
    let (header, rows) = read_csv(&dir.join(format!("{}.csv", summary_stem(&summary))));
    let (total, barrier, fz) = (
        column(&header, "total_J"),
        column(&header, "contact_energy_J"),
        column(&header, "contact_ground_fz_N"),
    );
    assert!(rows.iter().any(|r| r[fz] < 0.0), "the block never touched");
    let energy = |r: &Vec<f64>| r[total] + r[barrier];
    let rise = rows
        .iter()
        .map(|r| energy(r) - energy(&rows[0]))
        .fold(f64::NEG_INFINITY, f64::max);
    let loss = energy(&rows[0]) - energy(&rows[rows.len() - 1]);
    // Explicit contact is an inelastic impulse on the velocity (issue 35): the energy never
    // rises above the start by more than symplectic Euler's shadow-energy oscillation (its
    // velocity lives half a step behind: O(dt)), 1 % of the fall's work W·h, and the impact
    // loses some of it (measured: 8 %), never all.
    assert!(
        rise <= 0.01 * WEIGHT * h,
        "energy rise {rise:e} J of W·h = {:e}",
        WEIGHT * h
    );
    assert!(loss > 0.0 && loss < WEIGHT * h, "lost {loss:e} J");
    println!(
        "explicit: smallest gap {gap:.3e} m, energy rise {rise:.3e} J, lost {loss:.3e} J (W·h = {:.3e} J)",
        WEIGHT * h
    );
}

/// A 0.2 m bar (x from 0 to 0.2, 0.1 × 0.1 section) clamped at x = 0.2, no gravity, with a box
/// obstacle `gap` m to the left of its free face, moving right at `v` m/s.
fn pushed_bar(dir: &Path, motion: &str) -> String {
    format!(
        r#"
[mesh.box]
max = [0.2, 0.1, 0.1]
cells = [8, 4, 4]

[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0

[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.2 }} }}
fix = ["x", "y", "z"]

[analysis]
type = "dynamic"
method = "backward_euler"
dt = 0.01
duration = 0.6
model = "linear"

[[obstacles]]
kind = "box"
name = "pusher"
min = [-0.2, -0.1, -0.1]
max = [-0.001, 0.2, 0.2]
{motion}

[output]
directory = "{dir}"
vtu = false
"#,
        dir = dir.display()
    )
}

#[test]
fn an_obstacle_at_constant_velocity_compresses_a_clamped_bar_with_its_axial_stiffness() {
    let dir = folder("pushed");
    let v = 0.01;
    let summary = run(&pushed_bar(&dir, &format!("velocity = [{v}, 0.0, 0.0]"))).unwrap();
    let (header, rows) = read_csv(&dir.join(format!("{}.csv", summary_stem(&summary))));
    let (time, fx) = (
        column(&header, "time_s"),
        column(&header, "contact_pusher_fx_N"),
    );
    // The force on the pusher is along −x (the bar pushes back) and grows as it advances.
    let last = rows.last().unwrap();
    let advance = v * last[time] - 0.001;
    let force = -last[fx];
    assert!(force > 0.0);
    // Quasi-static (the bar's axial period 4L/c = 0.08 s is a seventh of the push): F = k·δ,
    // δ the advance past first touch less the final gap (0 < gap < d̂ = 2.4e-4 m, 1 % of δ),
    // k between the free-sided bar EA/L and the laterally confined one
    // E(1−ν)/((1+ν)(1−2ν))·A/L = 1.346·EA/L (the clamp holds the far end's section, the
    // frictionless pusher lets the near end expand). 3 % more either way for the gap, backward
    // Euler's numerical damping (k·v·dt/2 relative to k·δ: 1 %) and the coarse mesh.
    let ea_over_l = 1e5 * 0.01 / 0.2;
    let k = force / advance;
    assert!(
        k >= 0.97 * ea_over_l && k <= 1.03 * 1.346 * ea_over_l,
        "k = {k:.4e} N/m against EA/L = {ea_over_l:.4e} N/m"
    );
    // The force never falls while the pusher advances into the bar (after first touch).
    let forces: Vec<f64> = rows.iter().map(|r| -r[fx]).collect();
    let touch = forces.iter().position(|f| *f > 0.0).unwrap();
    for pair in forces[touch..].windows(2) {
        // Relative round-off of the Newton solve: 1e-6 of the force.
        assert!(pair[1] >= pair[0] * (1.0 - 1e-6), "{pair:?}");
    }
    println!("pushed bar: k = {:.4} EA/L", k / ea_over_l);
}

#[test]
fn an_obstacle_lowered_by_an_amplitude_presses_harder_as_it_goes_down() {
    let dir = folder("lowered");
    // A box 1 mm above the free half of the bar's top face z = 0.1, lowered by 6 mm over the
    // run's 0.6 s on a ramp: it touches at t ≈ 0.1 s and then presses the clamped bar down
    // ever harder.
    let text = pushed_bar(&dir, "")
        .replace(
            "min = [-0.2, -0.1, -0.1]\nmax = [-0.001, 0.2, 0.2]",
            "min = [-0.1, -0.1, 0.101]\nmax = [0.1, 0.2, 0.3]\ndisplacement = [0.0, 0.0, -0.006]\namplitude = { ramp = { start = 0.0, end = 0.6 } }",
        );
    let summary = run(&text).unwrap();
    let (header, rows) = read_csv(&dir.join(format!("{}.csv", summary_stem(&summary))));
    let fz = column(&header, "contact_pusher_fz_N");
    let forces: Vec<f64> = rows.iter().map(|r| r[fz]).collect();
    let touch = forces.iter().position(|f| *f > 0.0).expect("no contact");
    assert!(forces.last().unwrap() > &0.0);
    // The touch rings the bar (measured: the force overshoots and dips for 3 steps while
    // backward Euler damps the ringing); from 5 steps after it the press is quasi-static.
    for pair in forces[touch + 5..].windows(2) {
        // Relative round-off of the Newton solve: 1e-6 of the force.
        assert!(pair[1] >= pair[0] * (1.0 - 1e-6), "{pair:?}");
    }
    println!("lowered box: final force {:.4e} N", forces.last().unwrap());
}

fn scene_error(text: &str) -> (String, usize, String) {
    match run(text) {
        Err(Error::Scene {
            key, line, message, ..
        }) => (key, line, message),
        other => panic!("expected a scene error, got {other:?}"),
    }
}

#[test]
fn bad_moving_obstacle_keys_are_errors_naming_key_and_line() {
    let dir = folder("bad");
    let base = pushed_bar(&dir, "MOTION");
    let line = base.lines().position(|l| l == "[[obstacles]]").unwrap() + 1;
    for (motion, key, words) in [
        (
            "velocity = [1.0, 0.0, 0.0]\ndisplacement = [1.0, 0.0, 0.0]",
            "obstacles[0].displacement",
            "not both",
        ),
        (
            "displacement = [1.0, 0.0, 0.0]",
            "obstacles[0].displacement",
            "needs an amplitude",
        ),
        (
            "amplitude = { ramp = { start = 0.0, end = 1.0 } }",
            "obstacles[0].amplitude",
            "scales nothing",
        ),
        (
            "displacement = [1.0, 0.0, 0.0]\namplitude = \"nowhere\"",
            "obstacles[0].amplitude",
            "unknown amplitude",
        ),
        (
            "velocity = [nan, 0.0, 0.0]",
            "obstacles[0].velocity",
            "finite",
        ),
    ] {
        let (k, l, message) = scene_error(&base.replace("MOTION", motion));
        assert_eq!(k, key, "{message}");
        assert_eq!(l, line, "{message}");
        assert!(message.contains(words), "{message}");
    }
    // A static scene has no seconds: a velocity there is refused at its key, naming the key
    // to give instead (a displacement over the load steps' pseudo-time is taken, see
    // static_moving_obstacle.rs).
    let static_scene = base
        .replace("MOTION", "velocity = [1.0, 0.0, 0.0]")
        .replace(
            "type = \"dynamic\"\nmethod = \"backward_euler\"\ndt = 0.01\nduration = 0.6\n",
            "",
        );
    match static_scene.parse::<Scene>() {
        Err(Error::Scene { key, message, .. }) => {
            assert_eq!(key, "obstacles[0].velocity");
            assert!(message.contains("no seconds"), "{message}");
            assert!(message.contains("give displacement"), "{message}");
            assert!(message.contains("last load step"), "{message}");
        }
        other => panic!("expected a scene error, got {other:?}"),
    }
    // A modal scene has no contact: the library's combination rule refuses the pair, which
    // the scene names at the obstacle's entry.
    let modal_scene = base
        .replace(
            "MOTION",
            "displacement = [1.0, 0.0, 0.0]\namplitude = { ramp = { start = 0.0, end = 1.0 } }",
        )
        .replace(
            "type = \"dynamic\"\nmethod = \"backward_euler\"\ndt = 0.01\nduration = 0.6\n",
            "type = \"modal\"\n",
        );
    match modal_scene.parse::<Scene>() {
        Err(Error::Scene { key, message, .. }) => {
            assert_eq!(key, "obstacles[0].kind");
            assert!(
                message.contains("modal analysis has no contact"),
                "{message}"
            );
        }
        other => panic!("expected a scene error, got {other:?}"),
    }
}
