//! Runs a static scene file and prints its summary (until the `tetfem run` command lands):
//! `cargo run --release --example run_scene -- scenes/cantilever_static.toml [--png] [--json]`.

use std::path::Path;

use tetfem_cli::scene::{RunOptions, Scene, run_static_with};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.iter().find(|a| !a.starts_with("--")) else {
        eprintln!("usage: run_scene SCENE.toml [--png] [--json]");
        std::process::exit(2);
    };
    let options = RunOptions {
        force_png: args.iter().any(|a| a == "--png"),
        ..RunOptions::default()
    };
    let clock = std::time::Instant::now();
    let result = Scene::load(Path::new(path)).and_then(|scene| run_static_with(&scene, &options));
    match result {
        Ok(summary) if args.iter().any(|a| a == "--json") => println!("{}", summary.to_json()),
        Ok(summary) => {
            println!(
                "{}: {} nodes, {} tets; max |u| {:.4e} m, max von Mises {:.4e} Pa; {:.3} s",
                summary.title,
                summary.nodes,
                summary.tets,
                summary.max_displacement,
                summary.max_von_mises,
                clock.elapsed().as_secs_f64()
            );
            for p in &summary.probes {
                println!("  probe {}: mean u = {:?} m", p.name, p.displacement);
            }
            for f in &summary.files {
                println!("  wrote {}", f.display());
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
