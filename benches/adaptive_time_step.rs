//! Error-controlled time stepping against fixed steps, side by side in one run (issue 37,
//! item 3: "at ≤ 2× the wall time of the cheapest fixed dt that meets the same tolerance").
//! The swing of `tests/core/adaptive_time_step.rs` — a cantilever 0.5 × 0.05 × 0.05 m,
//! E = 10 MPa, ν = 0.3, ρ = 1000 kg/m³, 10 × 1 × 1 cells, released from rest under gravity,
//! linear model — run to `end` s by `Transient::run_adaptive` at `tolerance`, then at fixed
//! steps interval/2^k (k = 0, 1, …) until one meets the tolerance. Every error is the true one,
//! max over the landings k·interval of √((‖Δu‖/S_u)² + (‖Δv‖/S_v)²) against a fixed-step
//! reference at 1/16 of the adaptive run's smallest step; wall times are the stepping alone.
//!
//! `cargo bench --bench adaptive_time_step -- [method] [tolerance] [end] [beta]`
//! (default `newmark 1e-3 0.6 0`; method `newmark` or `backward-euler`; beta the Rayleigh
//! stiffness damping, s).

use std::time::Instant;

use nalgebra::Vector3;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::{Method, Rayleigh, State};
use tetfem::analysis::transient::{
    AdaptiveStep, Flow, StepView, TimeStep, Transient, TransientOptions,
};
use tetfem::fe::materials::MaterialMap;
use tetfem::{BoxSplit, Constraints, Material, Result, TetMesh};

const INTERVAL: f64 = 0.01;

fn swing() -> Result<Definition> {
    let size = Vector3::new(0.5, 0.05, 0.05);
    let mesh = TetMesh::box_grid(Vector3::zeros(), size, [10, 1, 1], BoxSplit::Mirrored6)?;
    let materials = MaterialMap::uniform(Material::new(1e7, 0.3, 1000.0)?, mesh.tet_count());
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))?;
    Definition::builder(mesh, materials)
        .constraints(constraints)?
        .gravity(Vector3::new(0.0, 0.0, -9.81))?
        .build()
}

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The states at the landings (index k for k·INTERVAL) and the largest ‖u‖, ‖v‖.
#[derive(Default)]
struct Samples {
    at: Vec<(usize, Vec<f64>, Vec<f64>)>,
    scale: (f64, f64),
}

impl Samples {
    fn keep(&mut self, k: Option<usize>, state: &State) {
        self.scale.0 = self.scale.0.max(norm(&state.displacement));
        self.scale.1 = self.scale.1.max(norm(&state.velocity));
        if let Some(k) = k {
            let sample = (k, state.displacement.clone(), state.velocity.clone());
            self.at.push(sample);
        }
    }

    /// The error of `run` against `self`, the reference.
    fn error_of(&self, run: &Samples) -> f64 {
        let (su, sv) = self.scale;
        let mut worst: f64 = 0.0;
        for (k, u, v) in &run.at {
            let Some((_, ur, vr)) = self.at.iter().find(|(j, ..)| j == k) else {
                continue;
            };
            let du: Vec<f64> = u.iter().zip(ur).map(|(a, b)| a - b).collect();
            let dv: Vec<f64> = v.iter().zip(vr).map(|(a, b)| a - b).collect();
            worst = worst.max((norm(&du) / su).hypot(norm(&dv) / sv));
        }
        worst
    }
}

fn options(method: Method, dt: f64, beta: f64) -> Result<TransientOptions> {
    let mut options = TransientOptions::new(method, TimeStep::Seconds(dt));
    options.damping = Rayleigh::new(0.0, beta)?;
    Ok(options)
}

/// A fixed-step run of `per_interval` steps per interval to `end`: its samples and wall time.
fn fixed(
    definition: &Definition,
    method: Method,
    per_interval: usize,
    end: f64,
    beta: f64,
) -> Result<(Samples, f64)> {
    let dt = INTERVAL / per_interval as f64;
    let steps = (end / INTERVAL).round() as usize * per_interval;
    let mut run = Transient::new(definition, options(method, dt, beta)?)?;
    let mut samples = Samples::default();
    let clock = Instant::now();
    let mut observing = 0.0;
    run.run((0, steps), &mut |view: &StepView<'_>| -> Result<Flow> {
        let watch = Instant::now();
        let k = view
            .step
            .is_multiple_of(per_interval)
            .then_some(view.step / per_interval);
        samples.keep(k, view.state);
        observing += watch.elapsed().as_secs_f64();
        Ok(Flow::Continue)
    })?;
    Ok((samples, clock.elapsed().as_secs_f64() - observing))
}

fn main() -> Result<()> {
    // `cargo bench` appends `--bench` to a harness-less target's arguments: not one of ours.
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let method: Method = args.first().map_or("newmark", String::as_str).parse()?;
    let number = |i: usize, default: f64| -> f64 {
        args.get(i).and_then(|a| a.parse().ok()).unwrap_or(default)
    };
    let (tolerance, end, beta) = (number(1, 1e-3), number(2, 0.6), number(3, 0.0));
    let definition = swing()?;

    let mut run = Transient::new(&definition, options(method, 1e-3, beta)?)?;
    let mut control = AdaptiveStep::new(tolerance)?;
    control.output_interval = Some(INTERVAL);
    let mut samples = Samples::default();
    let clock = Instant::now();
    let mut observing = 0.0;
    let report = run.run_adaptive(end, &control, &mut |view: &StepView<'_>| -> Result<Flow> {
        let watch = Instant::now();
        let k = (view.state.time / INTERVAL).round();
        let on = (view.state.time - k * INTERVAL).abs() < 1e-12;
        samples.keep(on.then_some(k as usize), view.state);
        observing += watch.elapsed().as_secs_f64();
        Ok(Flow::Continue)
    })?;
    let adaptive_wall = clock.elapsed().as_secs_f64() - observing;
    let per_interval = (16.0 * INTERVAL / report.dt_range.0).ceil() as usize;
    let (reference, _) = fixed(&definition, method, per_interval, end, beta)?;
    println!(
        "{} swing to {end} s, tolerance {tolerance:e}, β = {beta} s; reference dt = {:.3e} s",
        run.integrator().name(),
        INTERVAL / per_interval as f64
    );
    println!(
        "{:<28} {:>9} {:>12} {:>12} {:>10}",
        "run", "steps", "true error", "estimate", "wall (s)"
    );
    println!(
        "{:<28} {:>9} {:>12.3e} {:>12.3e} {:>10.4}",
        format!("adaptive ({} rejected)", report.rejected),
        report.accepted,
        reference.error_of(&samples),
        report.estimated_error,
        adaptive_wall
    );
    for k in 0..16 {
        let n = 1usize << k;
        let (run, wall) = fixed(&definition, method, n, end, beta)?;
        let error = reference.error_of(&run);
        println!(
            "{:<28} {:>9} {:>12.3e} {:>12} {:>10.4}",
            format!("fixed dt = {:.3e}", INTERVAL / n as f64),
            n * (end / INTERVAL).round() as usize,
            error,
            "",
            wall
        );
        if error <= tolerance {
            println!(
                "cheapest fixed dt meeting {tolerance:e}: wall {wall:.4} s; adaptive / fixed = {:.2}",
                adaptive_wall / wall
            );
            break;
        }
    }
    Ok(())
}
