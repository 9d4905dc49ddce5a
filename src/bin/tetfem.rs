//! `tetfem`: the command-line front of the library. It parses arguments, calls the library and
//! reports; no physics lives here.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use clap::{Parser, Subcommand};
use nalgebra::Vector3;
use tetfem::cantilever::Cantilever;
use tetfem::dynamics::{LinearSystem, MassKind, Method, Rayleigh, critical_time_step};
use tetfem::element::{Vector12, von_mises};
use tetfem::output::VtuWriter;
use tetfem::simulate::{ProbeSet, SimulationSettings, simulate};
use tetfem::{Loads, Material};

/// Elastic solids on linear tetrahedra.
///
/// With no subcommand, runs the embedded default scene: a steel cantilever (1 m × 0.1 m × 0.1 m,
/// E = 200 GPa, ν = 0.3, ρ = 7850 kg/m³) clamped at x = 0 under gravity and a 10 kN end load.
/// It solves the static problem (100×10×10 cubes of 6 tets), prints the mesh size, the time of
/// each phase and the tip deflection beside beam theory, and writes `out/cantilever.vtu`. Then it
/// releases the beam from that loaded shape (the end load removed, gravity kept) and integrates
/// a few periods of its vibration on a coarser mesh, writing `out/cantilever_dynamic.pvd` (open
/// it in ParaView as an animation) and `out/cantilever_dynamic.csv` (tip displacement, energies,
/// wall time per step).
#[derive(Debug, Parser)]
#[command(version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// Cells along x, y, z of the static solve (e.g. `200,20,20`).
    #[arg(long, value_parser = parse_cells, default_value = "100,10,10")]
    cells: [usize; 3],
    /// Cells of the dynamic run.
    #[arg(long, value_parser = parse_cells, default_value = "40,4,4")]
    dynamic_cells: [usize; 3],
    /// Time integrator of the dynamic run: backward-euler, newmark or explicit.
    #[arg(long, default_value = "backward-euler")]
    method: String,
    /// Time step of the dynamic run in s (default: 50× the explicit critical step for the
    /// implicit methods, 0.9× for the explicit one).
    #[arg(long)]
    dt: Option<f64>,
    /// Simulated time, in periods of the first vibration mode.
    #[arg(long, default_value_t = 3.0)]
    periods: f64,
    /// Only the static solve.
    #[arg(long)]
    static_only: bool,
    /// Directory for the output files.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Runs a scene file (TOML): static or dynamic, writing what its [output] section asks for.
    Run {
        /// The scene file.
        scene: PathBuf,
        /// Output directory (overrides the scene's).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also render PNG pictures.
        #[arg(long)]
        png: bool,
        /// Print the run summary as one JSON object on stdout.
        #[arg(long)]
        json: bool,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Prints mesh statistics (counts, volume, element quality) and the explicit critical step.
    Info {
        /// A Gmsh `.msh`, a TetGen `.node`/`.ele`, or a scene `.toml`.
        mesh: PathBuf,
        /// Material for the critical step: E,NU,RHO in SI (a scene file gives its own; without
        /// either, no critical step is computed).
        #[arg(long, value_parser = parse_material)]
        material: Option<Material>,
        /// Print as JSON.
        #[arg(long)]
        json: bool,
    },
}

fn parse_cells(text: &str) -> Result<[usize; 3], String> {
    let parts: Vec<&str> = text.split(',').collect();
    let parse = |s: &str| s.trim().parse::<usize>().map_err(|e| format!("'{s}': {e}"));
    match parts.as_slice() {
        [x, y, z] => Ok([parse(x)?, parse(y)?, parse(z)?]),
        _ => Err(format!(
            "expected three comma-separated counts like 100,10,10, got '{text}'"
        )),
    }
}

fn parse_material(text: &str) -> Result<Material, String> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>().map_err(|e| format!("'{s}': {e}")))
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [e, nu, rho] => Material::new(*e, *nu, *rho).map_err(|e| e.to_string()),
        _ => Err(format!("expected E,NU,RHO, got '{text}'")),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        None => run_default(&cli),
        Some(Command::Run {
            scene,
            out,
            png,
            json,
            quiet,
        }) => run_scene(scene, out.as_deref(), *png, *json, *quiet),
        Some(Command::Info {
            mesh,
            material,
            json,
        }) => info(mesh, *material, *json),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error}");
            ExitCode::FAILURE
        }
    }
}

/// A progress line on stderr with percentage and ETA, only on a terminal and for runs longer
/// than a second.
fn progress_reporter(quiet: bool) -> impl FnMut(usize, usize) {
    let show = !quiet && std::io::stderr().is_terminal();
    let start = std::time::Instant::now();
    let mut last = 0.0;
    move |step, total| {
        let elapsed = start.elapsed().as_secs_f64();
        if !show || elapsed < 1.0 || (elapsed - last < 0.2 && step != total) {
            return;
        }
        last = elapsed;
        let eta = elapsed / step as f64 * (total - step) as f64;
        eprint!(
            "\r  step {step}/{total} ({:.0}%), ETA {eta:.1} s   ",
            100.0 * step as f64 / total as f64
        );
        if step == total {
            eprintln!();
        }
    }
}

fn run_default(cli: &Cli) -> tetfem::Result<()> {
    let scene = Cantilever {
        cells: cli.cells,
        ..Cantilever::steel_default()
    };
    let material = scene.material;
    println!("tetfem: static cantilever (default scene)");
    println!(
        "  beam {} m × {} m × {} m, E = {:.3e} Pa, ν = {}, ρ = {} kg/m³, end load {} N, g = {} m/s²",
        scene.length,
        scene.width,
        scene.height,
        material.youngs_modulus(),
        material.poisson_ratio(),
        material.density(),
        scene.end_load,
        scene.gravity
    );
    let solved = scene.solve()?;
    let mesh = &solved.mesh;
    println!(
        "  mesh {}×{}×{} cells: {} nodes, {} tets, {} DOFs ({} free), nnz(L) = {}",
        cli.cells[0],
        cli.cells[1],
        cli.cells[2],
        mesh.node_count(),
        mesh.tet_count(),
        mesh.dof_count(),
        solved.free_dofs,
        solved.factor_len
    );
    let t = solved.timings;
    println!("  time per phase:");
    for (phase, time) in [
        ("mesh", solved.mesh_time),
        ("pattern", t.pattern),
        ("assembly", t.assembly),
        ("constraints", t.constraints),
        ("symbolic", t.symbolic),
        ("factorization", t.factorization),
        ("solve", t.solve),
    ] {
        println!("    {phase:<14} {}", format_duration(time));
    }
    let (euler_bernoulli, timoshenko) = scene.beam_theory_tip();
    let tip = solved.tip_deflection;
    println!("  tip deflection (mean u_z on x = L):");
    println!("    tetfem           {tip:+.6e} m");
    println!(
        "    Euler–Bernoulli  {euler_bernoulli:+.6e} m  (tetfem / EB = {:.4})",
        tip / euler_bernoulli
    );
    println!(
        "    Timoshenko       {timoshenko:+.6e} m  (tetfem / Timoshenko = {:.4})",
        tip / timoshenko
    );
    println!(
        "    (linear tets are stiff in bending: at {} cells through the height they reach this ratio; refine with --cells)",
        cli.cells[2]
    );
    println!(
        "  relative residual ‖K_ff·u − f‖/‖f‖ = {:.2e}",
        solved.solution.relative_residual
    );
    let displacement = &solved.solution.displacement;
    let stress: Vec<f64> = (0..mesh.tet_count())
        .map(|t| {
            let nodes = mesh.tets()[t];
            let u = Vector12::from_fn(|i, _| displacement[3 * nodes[i / 3] + i % 3]);
            von_mises(&mesh.element(t).stress(&material, &u))
        })
        .collect();
    let path = cli.out.join("cantilever.vtu");
    VtuWriter::new(mesh)
        .point_field("displacement", 3, displacement)?
        .cell_field("von_mises_stress", 1, &stress)?
        .write(&path)?;
    println!(
        "  wrote {} (displacement [m] per node, von Mises stress [Pa] per tet)",
        path.display()
    );
    if cli.static_only {
        return Ok(());
    }
    run_default_dynamic(cli, &scene)
}

fn run_default_dynamic(cli: &Cli, scene: &Cantilever) -> tetfem::Result<()> {
    let method: Method = cli.method.parse()?;
    let dynamic = Cantilever {
        cells: cli.dynamic_cells,
        ..*scene
    };
    let mesh = dynamic.mesh()?;
    let constraints = dynamic.constraints(&mesh)?;
    let gravity = Vector3::new(0.0, 0.0, -dynamic.gravity);
    let end_load = Cantilever {
        gravity: 0.0,
        ..dynamic
    }
    .loads(&mesh)?;
    // The loaded static shape (end load + gravity) is the initial condition; the first mode's
    // period sets the duration.
    let loaded = LinearSystem::new(
        &mesh,
        &dynamic.material,
        &constraints,
        &end_load,
        gravity,
        MassKind::Lumped,
        Rayleigh::default(),
    )?;
    let start = loaded.static_displacement()?;
    let period = 2.0 * std::f64::consts::PI / tetfem::modal::lowest_modes(&loaded, 1)?.omega[0];
    let dt_crit = critical_time_step(&Arc::new(loaded))?.dt;
    let dt = cli.dt.unwrap_or(if method == Method::Explicit {
        0.9 * dt_crit
    } else {
        50.0 * dt_crit
    });
    let steps = ((cli.periods * period / dt).ceil() as usize).max(1);
    let tip = dynamic.tip_nodes(&mesh);
    let settings = SimulationSettings {
        method,
        dt,
        steps,
        damping: Rayleigh::default(),
        mass: MassKind::Lumped,
        gravity,
        every: (steps / 60).max(1),
        directory: cli.out.clone(),
        stem: "cantilever_dynamic".into(),
        vtu: true,
        csv: true,
        png: false,
    };
    println!(
        "tetfem: dynamic cantilever, released from the loaded shape (end load removed, gravity kept)"
    );
    println!(
        "  mesh {}×{}×{} cells ({} DOFs), first-mode period {period:.4e} s, {} over {:.1} periods",
        cli.dynamic_cells[0],
        cli.dynamic_cells[1],
        cli.dynamic_cells[2],
        mesh.dof_count(),
        cli.method,
        cli.periods
    );
    println!(
        "  dt = {dt:.3e} s = {:.1}× the explicit critical step {dt_crit:.3e} s (2/ω_max), {steps} steps",
        dt / dt_crit
    );
    let summary = simulate(
        &mesh,
        &dynamic.material,
        &constraints,
        &Loads::new(&mesh),
        &[ProbeSet {
            name: "tip".into(),
            nodes: tip,
        }],
        Vector3::zeros(),
        Some(start),
        &settings,
        progress_reporter(cli.quiet),
    )?;
    println!(
        "  wall time {:.3} s, {:.3} ms per step; tip u_z at the end {:+.4e} m; total energy {:.4e} J → {:.4e} J",
        summary.stepping_seconds,
        1e3 * summary.seconds_per_step,
        summary.probes[0].1.z,
        summary.energy.0,
        summary.energy.1
    );
    println!(
        "  wrote {} and {} ({} frames)",
        cli.out.join("cantilever_dynamic.pvd").display(),
        cli.out.join("cantilever_dynamic.csv").display(),
        summary.files.len() - 2
    );
    Ok(())
}

fn run_scene(
    path: &Path,
    out: Option<&Path>,
    png: bool,
    json: bool,
    quiet: bool,
) -> tetfem::Result<()> {
    let mut scene = tetfem::scene::Scene::load(path)?;
    if let Some(dir) = out {
        scene.set_output_directory(dir.to_path_buf());
    }
    match *scene.analysis() {
        tetfem::scene::Analysis::Static => {
            let summary = tetfem::scene::run_static_with(
                &scene,
                &tetfem::scene::RunOptions {
                    force_png: png,
                    no_files: false,
                },
            )?;
            if json {
                println!("{}", summary.to_json());
            } else {
                println!(
                    "{}: static, {} tets, {} free DOFs, max |u| = {:.4e} m, max von Mises = {:.4e} Pa, residual {:.1e}",
                    summary.title,
                    summary.tets,
                    summary.free_dofs,
                    summary.max_displacement,
                    summary.max_von_mises,
                    summary.relative_residual
                );
                for p in &summary.probes {
                    println!(
                        "  probe {}: u = ({:+.4e}, {:+.4e}, {:+.4e}) m",
                        p.name, p.displacement[0], p.displacement[1], p.displacement[2]
                    );
                }
                for f in &summary.files {
                    println!("  wrote {}", f.display());
                }
            }
            Ok(())
        }
        tetfem::scene::Analysis::Dynamic(d) => {
            let built = scene.build()?;
            let output = scene.output().clone();
            let settings = SimulationSettings {
                method: match d.method {
                    tetfem::scene::Method::BackwardEuler => Method::BackwardEuler,
                    tetfem::scene::Method::Newmark => Method::Newmark,
                    tetfem::scene::Method::Explicit => Method::Explicit,
                },
                dt: d.dt,
                steps: d.steps(),
                damping: Rayleigh::new(d.damping.mass, d.damping.stiffness)?,
                mass: match d.mass {
                    tetfem::scene::MassKind::Lumped => MassKind::Lumped,
                    tetfem::scene::MassKind::Consistent => MassKind::Consistent,
                },
                gravity: Vector3::zeros(),
                every: output.every,
                directory: output.directory.clone(),
                stem: output.stem.clone(),
                vtu: output.vtu,
                csv: output.csv,
                png: output.png || png,
            };
            let probes: Vec<ProbeSet> = built
                .probes
                .iter()
                .map(|p| ProbeSet {
                    name: p.name.clone(),
                    nodes: p.nodes.clone(),
                })
                .collect();
            let summary = simulate(
                &built.mesh,
                &built.material,
                &built.constraints,
                &built.loads,
                &probes,
                Vector3::from(d.initial_velocity),
                None,
                &settings,
                progress_reporter(quiet || json),
            )?;
            if json {
                let probes: Vec<String> = summary
                    .probes
                    .iter()
                    .map(|(n, u)| {
                        format!(
                            "{{\"name\":{:?},\"displacement\":[{:e},{:e},{:e}]}}",
                            n, u.x, u.y, u.z
                        )
                    })
                    .collect();
                println!(
                    "{{\"title\":{:?},\"analysis\":\"dynamic\",\"method\":{:?},\"dt\":{:e},\"steps\":{},\"time\":{:e},\"critical_step\":{},\"seconds_per_step\":{:e},\"energy_start\":{:e},\"energy_end\":{:e},\"probes\":[{}],\"files\":{}}}",
                    scene.title(),
                    format!("{:?}", settings.method),
                    settings.dt,
                    summary.steps,
                    summary.time,
                    summary
                        .critical_step
                        .map_or("null".into(), |c| format!("{c:e}")),
                    summary.seconds_per_step,
                    summary.energy.0,
                    summary.energy.1,
                    probes.join(","),
                    summary.files.len()
                );
            } else {
                println!(
                    "{}: dynamic, {} steps of {:.3e} s (explicit critical step {}), {:.3} ms per step",
                    scene.title(),
                    summary.steps,
                    settings.dt,
                    summary
                        .critical_step
                        .map_or("n/a".into(), |c| format!("{c:.3e} s")),
                    1e3 * summary.seconds_per_step
                );
                for (name, u) in &summary.probes {
                    println!(
                        "  probe {name} at t = {:.4e} s: u = ({:+.4e}, {:+.4e}, {:+.4e}) m",
                        summary.time, u.x, u.y, u.z
                    );
                }
                println!(
                    "  wrote {} files under {}",
                    summary.files.len(),
                    settings.directory.display()
                );
            }
            Ok(())
        }
    }
}

fn info(path: &Path, material: Option<Material>, json: bool) -> tetfem::Result<()> {
    let info = tetfem::info::mesh_info(path, material)?;
    if json {
        println!("{}", info.to_json());
    } else {
        println!("{info}");
    }
    Ok(())
}

fn format_duration(time: Duration) -> String {
    let seconds = time.as_secs_f64();
    if seconds >= 1.0 {
        format!("{seconds:.3} s")
    } else {
        format!("{:.3} ms", seconds * 1e3)
    }
}
