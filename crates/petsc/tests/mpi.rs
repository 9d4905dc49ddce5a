//! The PETSc engine under `mpirun`, against tetfem's single-process direct solve.
//!
//! Each test runs `mpirun -n N tetfem-petsc SCENE --displacement FILE --json` and compares the
//! gathered displacement with `StaticSolver` (sparse Cholesky) on the same scene. Without the
//! `petsc` feature, or without `mpirun` on PATH, every test prints that it skipped and passes
//! (run with `-- --nocapture` to see it, and the iteration counts).

#[cfg(not(feature = "petsc"))]
#[test]
fn mpi_tests_skipped_without_the_petsc_feature() {
    println!(
        "SKIPPED: tetfem-petsc was built without the `petsc` feature; run \
         `cargo test --release -p tetfem-petsc --features petsc` where PETSc is installed"
    );
}

#[cfg(feature = "petsc")]
mod with_petsc {
    use std::io::Read;
    use std::path::{Path, PathBuf};
    use std::process::{Command, Stdio};
    use std::sync::Mutex;
    use std::time::{Duration, Instant};

    use serde_json::Value;
    use tetfem::linalg::linear_solver::SolverOptions;
    use tetfem::{LinearMethod, StaticSolver};
    use tetfem_petsc::pvtu::read_array;
    use tetfem_scene::Scene;

    /// The 1e-8 relative agreement issue 20 asks for (2-norm over every DOF). The direct solve
    /// is backward stable (residual ~1e-15); the iterative presets stop at a true relative
    /// residual near 1e-11 (measured 5.6e-11 on the cantilever), which on these matrices moves
    /// the displacement by far less than 1e-8.
    const AGREEMENT: f64 = 1e-8;

    /// One mpirun at a time: the machine has 2 cores, and the tests' timings are reported.
    static MPIRUN: Mutex<()> = Mutex::new(());

    fn mpirun() -> Option<PathBuf> {
        std::env::var_os("PATH").and_then(|path| {
            std::env::split_paths(&path)
                .map(|dir| dir.join("mpirun"))
                .find(|p| p.is_file())
        })
    }

    fn scenes() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
    }

    fn scratch(name: &str) -> PathBuf {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
            .join("petsc-tests")
            .join(name);
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch folder");
        dir
    }

    struct Run {
        success: bool,
        stdout: String,
        stderr: String,
        summary: Value,
        displacement: Vec<f64>,
    }

    /// `mpirun -n ranks tetfem-petsc scene args...`, killed after 300 s (a hung collective
    /// must fail the test, not CI's clock). `None` (after printing SKIPPED) without mpirun.
    fn run(name: &str, ranks: usize, scene: &Path, args: &[&str]) -> Option<Run> {
        let Some(mpirun) = mpirun() else {
            println!("SKIPPED {name}: no mpirun on PATH (apt-get install -y petsc-dev)");
            return None;
        };
        let _one = MPIRUN.lock().unwrap_or_else(|p| p.into_inner());
        let dir = scratch(name);
        let displacement = dir.join("u.txt");
        let mut command = Command::new(mpirun);
        command
            .args(["--oversubscribe", "--bind-to", "none", "-n"])
            .arg(ranks.to_string())
            .arg(env!("CARGO_BIN_EXE_tetfem-petsc"))
            .arg(scene)
            .args(["--json", "--out"])
            .arg(&dir)
            .arg("--displacement")
            .arg(&displacement)
            .args(args);
        let (status, stdout, stderr) = finish(name, ranks, command);
        let summary = serde_json::from_str(&stdout).unwrap_or(Value::Null);
        let displacement = std::fs::read_to_string(&displacement)
            .map(|text| {
                text.lines()
                    .map(|l| l.parse().expect("a number per line"))
                    .collect()
            })
            .unwrap_or_default();
        Some(Run {
            success: status.success(),
            stdout,
            stderr,
            summary,
            displacement,
        })
    }

    /// Runs `command` (an mpirun line) to the end with root allowed and the output captured,
    /// killed after 300 s (a hung collective must fail the test, not CI's clock).
    fn finish(
        name: &str,
        ranks: usize,
        mut command: Command,
    ) -> (std::process::ExitStatus, String, String) {
        let mut child = command
            .stdin(Stdio::null())
            // Root in containers and CI; harmless otherwise.
            .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
            .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("mpirun starts");
        let clock = Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().expect("mpirun status") {
                break status;
            }
            if clock.elapsed() > Duration::from_secs(300) {
                let _ = child.kill();
                panic!("{name}: mpirun -n {ranks} did not finish in 300 s");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        let (mut stdout, mut stderr) = (String::new(), String::new());
        child
            .stdout
            .take()
            .map(|mut s| s.read_to_string(&mut stdout));
        child
            .stderr
            .take()
            .map(|mut s| s.read_to_string(&mut stderr));
        (status, stdout, stderr)
    }

    /// tetfem's single-process Cholesky solve: the displacement, the reaction summed per axis
    /// and the applied loads' resultant.
    fn direct(scene: &Path) -> (Vec<f64>, [f64; 3], [f64; 3]) {
        let built = Scene::load(scene).expect("scene").build().expect("built");
        let options = SolverOptions {
            method: LinearMethod::Direct,
            ..Default::default()
        };
        let solution =
            StaticSolver::with_options(&built.mesh, &built.materials, &built.constraints, options)
                .expect("factored")
                .solve(&built.loads)
                .expect("solved");
        let mut reaction = [0.0; 3];
        for (dof, r) in solution.reactions.iter().enumerate() {
            reaction[dof % 3] += r;
        }
        let resultant = built.loads.resultant();
        (
            solution.displacement,
            reaction,
            [resultant.x, resultant.y, resultant.z],
        )
    }

    fn relative_difference(a: &[f64], b: &[f64]) -> f64 {
        assert_eq!(a.len(), b.len(), "displacement lengths");
        let diff: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
        let norm: f64 = b.iter().map(|y| y * y).sum();
        (diff / norm).sqrt()
    }

    /// Runs, checks success and agreement with the direct solve; returns the summary.
    fn agrees(name: &str, ranks: usize, scene: &Path, args: &[&str]) -> Option<Value> {
        let run = run(name, ranks, scene, args)?;
        assert!(
            run.success,
            "{name}: mpirun failed\nstdout: {}\nstderr: {}",
            run.stdout, run.stderr
        );
        let (reference, reaction, resultant) = direct(scene);
        let difference = relative_difference(&run.displacement, &reference);
        let s = &run.summary;
        println!(
            "{name}: {} ranks, {} + {}, {} iterations, true relative residual {:.2e}, \
             relative difference to the direct solve {difference:.2e}, set-up {:.3} s, solve {:.3} s",
            s["petsc"]["ranks"],
            s["petsc"]["ksp_type"],
            s["petsc"]["pc_type"],
            s["petsc"]["iterations"],
            s["petsc"]["relative_residual"].as_f64().unwrap_or(f64::NAN),
            s["petsc"]["seconds"]["setup"],
            s["petsc"]["seconds"]["solve"]
        );
        assert!(
            difference <= AGREEMENT,
            "{name}: relative difference {difference:e} to the direct solve"
        );
        assert_eq!(s["petsc"]["ranks"], ranks);
        // Each constraint entry's reaction as the in-process run's (a DOF in two entries counts
        // in both, so the rows need not sum to the load), and with disjoint entries the rows
        // summed as tetfem's reactions summed; to 1e-8 of the largest force (the solves'
        // accuracy, with margin).
        let theirs = tetfem_scene::run_static_with(
            &Scene::load(scene).expect("scene"),
            &tetfem_scene::RunOptions {
                no_files: true,
                ..Default::default()
            },
        )
        .expect("in-process run");
        let rows = s["reactions"].as_array().expect("reaction rows");
        assert_eq!(
            rows.len(),
            theirs.reactions.as_ref().map_or(0, Vec::len),
            "{name}"
        );
        let largest = theirs
            .reactions
            .iter()
            .flatten()
            .flat_map(|r| r.force_n)
            .chain(resultant)
            .fold(0.0, |m: f64, f| m.max(f.abs()));
        for (row, their) in rows.iter().zip(theirs.reactions.iter().flatten()) {
            for axis in 0..3 {
                let got = row["force_n"][axis].as_f64().expect("reaction");
                assert!(
                    (got - their.force_n[axis]).abs() <= 1e-8 * largest,
                    "{name}: {} {got:e} against the in-process {:e} on axis {axis}",
                    their.constraint,
                    their.force_n[axis]
                );
            }
        }
        let total: Vec<f64> = (0..3)
            .map(|axis| {
                rows.iter()
                    .map(|r| r["force_n"][axis].as_f64().expect("reaction"))
                    .sum()
            })
            .collect();
        if rows.len() == 1 {
            for axis in 0..3 {
                assert!(
                    (total[axis] + resultant[axis]).abs() <= 1e-8 * largest,
                    "{name}: reaction {:e} against load {:e} on axis {axis}",
                    total[axis],
                    resultant[axis]
                );
                assert!(
                    (total[axis] - reaction[axis]).abs() <= 1e-8 * largest,
                    "{name}: reaction {:e} against tetfem's {:e} on axis {axis}",
                    total[axis],
                    reaction[axis]
                );
            }
        }
        Some(run.summary)
    }

    /// The shipped scene `name` with `png = false`: the engine writes no pictures and
    /// refuses a scene that asks for them. Written once per process under a name of its own,
    /// then renamed into place (tests running at once write the same bytes).
    fn without_png(name: &str) -> PathBuf {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("petsc-tests-scenes");
        std::fs::create_dir_all(&dir).expect("scene folder");
        let path = dir.join(name);
        let text = std::fs::read_to_string(scenes().join(name))
            .expect("scene")
            .replace("png = true", "png = false");
        let partial = dir.join(format!(
            "{name}.{}.{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        std::fs::write(&partial, text).expect("scene written");
        std::fs::rename(&partial, &path).expect("scene renamed");
        path
    }

    fn cantilever() -> PathBuf {
        without_png("cantilever_static.toml")
    }

    #[test]
    fn cantilever_gamg_one_rank_matches_the_direct_solve() {
        let Some(s) = agrees("cantilever_gamg_1", 1, &cantilever(), &[]) else {
            return;
        };
        assert_eq!(s["petsc"]["ksp_type"], "cg");
        assert_eq!(s["petsc"]["pc_type"], "gamg");
        // Measured 32 (1 rank) and 34 (2 ranks) to a 1e-12 residual; GAMG without the
        // rigid-body near-null space needs several times as many on this slender beam, so 60
        // catches a lost near-null space while leaving room for PETSc's heuristics.
        let iterations = s["petsc"]["iterations"].as_i64().expect("iterations");
        assert!(iterations <= 60, "{iterations} GAMG iterations");
    }

    #[test]
    fn cantilever_gamg_two_ranks_matches_the_direct_solve_with_the_work_split() {
        let Some(s) = agrees("cantilever_gamg_2", 2, &cantilever(), &[]) else {
            return;
        };
        let iterations = s["petsc"]["iterations"].as_i64().expect("iterations");
        // As on one rank (measured 34); the partition changes GAMG's aggregates a little.
        assert!(iterations <= 60, "{iterations} GAMG iterations");
        // Distributed: each rank assembled some tets and owns some rows, none all of them.
        let list = |key: &str| -> Vec<u64> {
            s["petsc"][key]
                .as_array()
                .expect(key)
                .iter()
                .map(|v| v.as_u64().expect("count"))
                .collect()
        };
        let (tets, rows, nonzeros) = (
            list("tets_per_rank"),
            list("rows_per_rank"),
            list("nonzeros_per_rank"),
        );
        assert_eq!(tets.iter().sum::<u64>(), s["tets"].as_u64().expect("tets"));
        assert_eq!(
            rows.iter().sum::<u64>(),
            s["petsc"]["dofs"].as_u64().expect("dofs")
        );
        let total_nonzeros: u64 = nonzeros.iter().sum();
        for rank in 0..2 {
            assert!(tets[rank] > 0 && rows[rank] > 0, "rank {rank} has no work");
            // METIS balances within a few percent; 0.7 of the whole is far from "one rank
            // holds the matrix" and far from a balanced split's 0.5.
            assert!(
                (nonzeros[rank] as f64) < 0.7 * total_nonzeros as f64,
                "rank {rank} holds {} of {total_nonzeros} non-zeros",
                nonzeros[rank]
            );
        }
    }

    #[test]
    fn cantilever_mumps_and_hypre_two_ranks_match_the_direct_solve() {
        let Some(s) = agrees(
            "cantilever_mumps_2",
            2,
            &cantilever(),
            &["--solver", "mumps"],
        ) else {
            return;
        };
        assert_eq!(s["petsc"]["pc_type"], "cholesky");
        let Some(s) = agrees(
            "cantilever_hypre_2",
            2,
            &cantilever(),
            &["--solver", "hypre"],
        ) else {
            return;
        };
        assert_eq!(s["petsc"]["pc_type"], "hypre");
    }

    #[test]
    fn materials_per_region_and_the_analytic_stretch_on_two_ranks() {
        let scene = without_png("bimaterial_bar.toml");
        let Some(s) = agrees("bimaterial_2", 2, &scene, &[]) else {
            return;
        };
        // Two springs in series: F·(L₁/(E₁A) + L₂/(E₂A)) = 9.642857e-5 m, exact for linear tets
        // with ν = 0 (the scene's comment); 1e-8 relative is the solve's accuracy, not the
        // discretization's.
        let end = s["probes"][0]["displacement"][0].as_f64().expect("probe");
        let exact = 1e5 * (0.5 / (200e9 * 0.01) + 0.5 / (70e9 * 0.01));
        assert!(
            ((end - exact) / exact).abs() < 1e-8,
            "end stretch {end:e}, exact {exact:e}"
        );
    }

    #[test]
    fn gmsh_mesh_with_two_regions_on_two_ranks() {
        let dir = scratch("gmsh_regions_scene");
        let msh = scenes()
            .join("l_bracket.msh")
            .canonicalize()
            .expect("l_bracket.msh");
        let scene = dir.join("l_bracket_regions.toml");
        std::fs::write(
            &scene,
            format!(
                r#"[mesh.gmsh]
file = "{}"

[material]
youngs_modulus = 200e9
poisson_ratio = 0.3
density = 7850.0

[[materials]]
youngs_modulus = 70e9
poisson_ratio = 0.33
density = 2700.0
where = {{ box = {{ min = [0.05, -1.0, -1.0], max = [1.0, 1.0, 1.0] }} }}

[[constraints]]
where = {{ group = "clamp" }}

[[loads]]
where = {{ group = "load" }}
total_force = [0.0, -2000.0, 0.0]

[[probes]]
name = "load_face"
where = {{ group = "load" }}
"#,
                msh.display()
            ),
        )
        .expect("scene written");
        // Two materials really present: the region box claims some tets, not all.
        let built = Scene::load(&scene).expect("scene").build().expect("built");
        let counts = built.materials.counts();
        assert!(
            counts.len() == 2 && counts.iter().all(|&c| c > 0),
            "{counts:?}"
        );
        agrees("gmsh_regions_2", 2, &scene, &[]);
    }

    /// A soft block: rollers on x = 0 (x fixed), a line and a node holding the rest, the far
    /// end pulled by prescribed x and z displacements, gravity along −y.
    const PULLED_BLOCK: &str = r#"[mesh.box]
max = [0.4, 0.1, 0.1]
cells = [12, 3, 3]

[material]
youngs_modulus = 1e7
poisson_ratio = 0.45
density = 1000.0

[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
fix = ["x"]

[[constraints]]
where = { nodes = [0] }
fix = ["x", "y", "z"]

[[constraints]]
where = { box = { min = [-1.0, -1.0, -1.0], max = [0.01, 0.01, 1.0] } }
fix = ["y"]

[[constraints]]
where = { plane = { axis = "x", at = 0.4 } }
fix = ["x", "z"]
displacement = [0.004, 0.0, -0.002]

[[loads]]
gravity = [0.0, -9.81, 0.0]
"#;

    #[test]
    fn prescribed_displacements_and_rollers_on_two_ranks() {
        // Non-zero prescribed values enter the right-hand side through MatZeroRowsColumns, and
        // roller nodes (one axis fixed) keep their other two DOFs free inside a 3-block.
        let dir = scratch("prescribed_scene");
        let scene = dir.join("pulled_block.toml");
        std::fs::write(&scene, PULLED_BLOCK).expect("scene written");
        let Some(s) = agrees("prescribed_2", 2, &scene, &[]) else {
            return;
        };
        assert!(s["petsc"]["constrained_dofs"].as_u64().expect("count") > 0);
        // The prescribed values come back exactly (the engine sets them after the solve; the
        // free rows' equations K_ff·u_f = f_f − K_fc·u_c never depended on them).
        let run = run("prescribed_2_values", 2, &scene, &[]).expect("ran before");
        let built = Scene::load(&scene).expect("scene").build().expect("built");
        for (dof, u) in run.displacement.iter().enumerate() {
            if let Some(value) = built.constraints.get(dof) {
                // Exact: written from the constraints, printed with `{:e}` (shortest round-trip).
                assert_eq!(*u, value, "DOF {dof}");
            }
        }
    }

    /// tetfem's single-process integrator of the scene's method (direct solves) over the
    /// scene's steps: the displacement of every DOF and the kinetic and elastic energy at the
    /// end.
    fn integrate_in_tetfem(scene: &Path) -> (Vec<f64>, [f64; 2]) {
        use tetfem_scene::{Analysis, DynamicSetup};
        let scene = Scene::load(scene).expect("scene");
        let Analysis::Dynamic(settings) = *scene.analysis() else {
            panic!("a dynamic scene");
        };
        let setup =
            DynamicSetup::from_scene(scene.build().expect("built"), &settings).expect("set up");
        let mut state = setup.initial.clone();
        let mut integrator = settings
            .method
            .integrator(std::sync::Arc::clone(&setup.system), settings.dt)
            .expect("ready");
        for _ in 0..settings.steps() {
            integrator.step(&mut state).expect("step");
        }
        let energy = setup.system.energy(&state).expect("energy");
        let u = setup
            .system
            .dofs()
            .expand(&state.displacement)
            .expect("full");
        (u, [energy.kinetic, energy.elastic])
    }

    #[test]
    fn fifty_newmark_steps_match_tetfem_on_one_and_two_ranks() {
        let dir = scratch("newmark_scenes");
        // The shipped cantilever released from rest under its step load (the scene's
        // backward Euler replaced by Newmark), 50 steps of 1e-4 s; undamped, and damped with
        // an initial velocity.
        let base = std::fs::read_to_string(scenes().join("cantilever_dynamic.toml"))
            .expect("scene")
            .replace("duration = 0.03", "duration = 0.005")
            .replace("png = true", "png = false")
            .replace("\"backward_euler\"", "\"newmark\"");
        assert!(base.contains("\"newmark\""), "the scene names its method");
        let damped = base.replace(
            "duration = 0.005",
            "duration = 0.005\ndamping = { mass = 20.0, stiffness = 1e-5 }\ninitial_velocity = [0.0, 0.1, 0.0]",
        );
        for (name, text, ranks) in [
            ("newmark", &base, 1),
            ("newmark", &base, 2),
            ("newmark_damped", &damped, 2),
        ] {
            let scene = dir.join(format!("{name}.toml"));
            std::fs::write(&scene, text).expect("scene written");
            let label = format!("{name}_{ranks}");
            let Some(run) = run(&label, ranks, &scene, &[]) else {
                return;
            };
            assert!(run.success, "{label}: {}", run.stderr);
            let s = &run.summary;
            assert_eq!(s["petsc"]["analysis"], "newmark");
            assert_eq!(s["steps"], 50);
            let (reference, energies) = integrate_in_tetfem(&scene);
            let difference = relative_difference(&run.displacement, &reference);
            println!(
                "{label}: 50 Newmark steps, GAMG {} iterations in all, at most {} per step, \
                 relative difference to tetfem {difference:.2e}",
                s["petsc"]["iterations"], s["petsc"]["max_step_iterations"]
            );
            // 50 solves to a 1e-12 residual of the well-conditioned 4/dt²·M + K: as for the
            // static solves and backward Euler.
            assert!(difference <= AGREEMENT, "{label}: {difference:e}");
            let out = Path::new(env!("CARGO_TARGET_TMPDIR"))
                .join("petsc-tests")
                .join(&label);
            let csv = std::fs::read_to_string(out.join(format!("{name}_petsc.csv"))).expect("csv");
            let rows: Vec<Vec<f64>> = csv
                .lines()
                .skip(1)
                .map(|l| l.split(',').map(|v| v.parse().expect("number")).collect())
                .collect();
            let last = rows.last().expect("rows");
            // Columns: time, step, wall, tip (3), kinetic, elastic, ….
            for (got, want) in last[6..8].iter().zip(energies) {
                // Reduced over the ranks from displacements that agree to ~1e-12.
                assert!(
                    ((got - want) / want).abs() <= AGREEMENT,
                    "{label}: energy {got:e} vs tetfem {want:e}"
                );
            }
            same_as_in_process(&label, &scene, s, &csv);
        }
    }

    #[test]
    fn fifty_backward_euler_steps_match_tetfem_on_one_and_two_ranks() {
        let dir = scratch("dynamic_scenes");
        // The shipped step-load cantilever, 50 steps of 1e-4 s; once undamped from rest, once
        // with Rayleigh damping and an initial velocity.
        let base = std::fs::read_to_string(scenes().join("cantilever_dynamic.toml"))
            .expect("scene")
            .replace("duration = 0.03", "duration = 0.005")
            .replace("png = true", "png = false");
        let damped = base.replace(
            "duration = 0.005",
            "duration = 0.005\ndamping = { mass = 20.0, stiffness = 1e-5 }\ninitial_velocity = [0.0, 0.1, 0.0]",
        );
        for (name, text, ranks) in [
            ("undamped", &base, 1),
            ("undamped", &base, 2),
            ("damped", &damped, 2),
        ] {
            let scene = dir.join(format!("{name}.toml"));
            std::fs::write(&scene, text).expect("scene written");
            let label = format!("euler_{name}_{ranks}");
            let Some(run) = run(&label, ranks, &scene, &[]) else {
                return;
            };
            assert!(run.success, "{label}: {}", run.stderr);
            let s = &run.summary;
            assert_eq!(s["petsc"]["analysis"], "backward_euler");
            assert_eq!(s["steps"], 50);
            let (reference, energies) = integrate_in_tetfem(&scene);
            let difference = relative_difference(&run.displacement, &reference);
            println!(
                "{label}: 50 steps, GAMG {} iterations in all, at most {} per step, last step's \
                 relative residual {:.2e}, relative difference to tetfem {difference:.2e}",
                s["petsc"]["iterations"],
                s["petsc"]["max_step_iterations"],
                s["petsc"]["relative_residual"].as_f64().unwrap_or(f64::NAN)
            );
            // 50 solves, each to a 1e-12 residual, of a well-conditioned M + dt²K: the same
            // 1e-8 as the static solves.
            assert!(difference <= AGREEMENT, "{label}: {difference:e}");

            // The outputs: a frame every 10 steps (the scene's output.every) and the CSV.
            let out = Path::new(env!("CARGO_TARGET_TMPDIR"))
                .join("petsc-tests")
                .join(&label);
            let pvd = std::fs::read_to_string(out.join(format!("{name}_petsc.pvd"))).expect("pvd");
            for step in (0..=50).step_by(10) {
                let pvtu = format!("{name}_petsc_{step:04}.pvtu");
                assert!(pvd.contains(&pvtu), "{label}: {pvtu} listed");
                for rank in 0..ranks {
                    let piece = out.join(format!("{name}_petsc/{name}_{step:04}_{rank}.vtu"));
                    assert!(piece.is_file(), "{}", piece.display());
                }
            }
            assert_eq!(
                pvd.matches("<DataSet").count(),
                6,
                "{label}: frames 0, 10, …, 50"
            );
            let csv = std::fs::read_to_string(out.join(format!("{name}_petsc.csv"))).expect("csv");
            let rows: Vec<&str> = csv.lines().collect();
            assert_eq!(
                rows.len(),
                52,
                "{label}: header, the initial state and 50 steps"
            );
            assert_eq!(rows[51].split(',').nth(1), Some("50"), "step as digits");
            let last = numbers(rows[51]);
            // Columns: time, step, wall, tip (3), kinetic, elastic, …. The energies reduced over
            // the ranks against tetfem's; both O(1e-1) J or more here, computed from
            // displacements that agree to ~1e-12.
            for (got, want) in last[6..8].iter().zip(energies) {
                assert!(
                    ((got - want) / want).abs() <= AGREEMENT,
                    "{label}: energy {got:e} vs tetfem {want:e}"
                );
            }
            // The tip probe's CSV value is the summary's.
            let tip_z = s["probes"][0]["last"][2].as_f64().expect("probe");
            assert_eq!(last[5], tip_z, "{label}");
            same_as_in_process(&label, &scene, s, &csv);
        }
    }

    /// The values of a CSV row.
    fn numbers(row: &str) -> Vec<f64> {
        row.split(',').map(|v| v.parse().expect("number")).collect()
    }

    /// The in-process run of the dynamic `scene` (`tetfem run`'s library call) against the
    /// engine's summary `s` and CSV `csv`: the same top-level keys, the same CSV header, and every
    /// row's values (the wall time apart) equal to 1e-8 of the largest magnitude of the columns
    /// of their unit (the displacements agree to ~1e-12, AGREEMENT leaves the margin of the
    /// static tests).
    fn same_as_in_process(label: &str, scene: &Path, s: &Value, csv: &str) {
        use tetfem_scene::{DynamicOverrides, run_dynamic_scene};
        let out = scratch(&format!("{label}_in_process"));
        let mut scene = Scene::load(scene).expect("scene");
        scene.set_output_directory(out.clone());
        let stem = scene.output().stem.clone();
        run_dynamic_scene(
            &scene,
            &DynamicOverrides::default(),
            true,
            false,
            &mut |_, _| std::ops::ControlFlow::Continue(()),
        )
        .expect("in-process run");
        let summary: Value = serde_json::from_str(
            &std::fs::read_to_string(out.join(format!("{stem}_summary.json"))).expect("summary"),
        )
        .expect("JSON");
        let mut keys = top_level_keys(s);
        assert!(keys.remove("petsc"), "{label}: the engine's group");
        assert_eq!(keys, top_level_keys(&summary), "{label}: summary keys");
        let theirs = std::fs::read_to_string(out.join(format!("{stem}.csv"))).expect("csv");
        let (ours, theirs): (Vec<&str>, Vec<&str>) =
            (csv.lines().collect(), theirs.lines().collect());
        assert_eq!(ours[0], theirs[0], "{label}: CSV header");
        assert_eq!(ours.len(), theirs.len(), "{label}: CSV rows");
        let (ours, theirs): (Vec<Vec<f64>>, Vec<Vec<f64>>) = (
            ours[1..].iter().map(|r| numbers(r)).collect(),
            theirs[1..].iter().map(|r| numbers(r)).collect(),
        );
        let columns: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
        for (c, column) in columns.iter().enumerate() {
            if *column == "wall_seconds_per_step" {
                continue;
            }
            // Relative to the largest value of any column of the same unit (a component that
            // stays at round-off, e.g. the tip's u_x ~1e-18 m, is compared at the tip's scale).
            let unit = |name: &str| name.rsplit('_').next().unwrap_or_default().to_string();
            let scale = columns
                .iter()
                .enumerate()
                .filter(|(_, other)| unit(other) == unit(column))
                .flat_map(|(k, _)| theirs.iter().map(move |r| r[k].abs()))
                .fold(0.0, f64::max);
            let worst = ours
                .iter()
                .zip(&theirs)
                .map(|(a, b)| (a[c] - b[c]).abs())
                .fold(0.0, f64::max);
            assert!(
                worst <= AGREEMENT * scale.max(1e-300),
                "{label}: column {column} differs by {worst:e} (scale {scale:e})"
            );
            println!("{label}: {column}: worst difference {worst:.2e} of {scale:.2e}");
        }
    }

    /// The top-level keys of a summary.
    fn top_level_keys(summary: &Value) -> std::collections::BTreeSet<String> {
        summary
            .as_object()
            .expect("an object")
            .keys()
            .cloned()
            .collect()
    }

    /// The names of the point and cell arrays a `.vtu` or `.pvtu` declares (the points' and
    /// cells' own arrays apart).
    fn array_names(text: &str) -> std::collections::BTreeSet<String> {
        text.split("Name=\"")
            .skip(1)
            .filter_map(|rest| rest.split('"').next())
            .filter(|n| !["Points", "connectivity", "offsets", "types", "TimeValue"].contains(n))
            .map(str::to_string)
            .collect()
    }

    #[test]
    fn static_outputs_match_the_in_process_run_on_one_and_two_ranks() {
        use tetfem_scene::{RunOptions, run_static_with};
        // The in-process run of the same scene: its summary JSON and .vtu.
        let out = scratch("static_in_process");
        let mut scene = Scene::load(&cantilever()).expect("scene");
        scene.set_output_directory(out.clone());
        let stem = scene.output().stem.clone();
        run_static_with(&scene, &RunOptions::default()).expect("in-process run");
        let theirs: Value = serde_json::from_str(
            &std::fs::read_to_string(out.join(format!("{stem}_summary.json"))).expect("json"),
        )
        .expect("JSON");
        let vtu = std::fs::read(out.join(format!("{stem}.vtu"))).expect("vtu");
        let their_von_mises = read_array(&vtu, "von_mises").expect("von_mises");
        let their_stress = read_array(&vtu, "stress").expect("stress");
        for ranks in [1, 2] {
            let label = format!("static_parity_{ranks}");
            let Some(run) = run(&label, ranks, &cantilever(), &[]) else {
                return;
            };
            assert!(run.success, "{label}: {}", run.stderr);
            let ours = &run.summary;
            let mut keys = top_level_keys(ours);
            assert!(keys.remove("petsc"), "{label}: the engine's group");
            assert_eq!(keys, top_level_keys(&theirs), "{label}: summary keys");
            for key in ["nodes", "tets", "free_dofs", "analysis", "title", "units"] {
                assert_eq!(ours[key], theirs[key], "{label}: {key}");
            }
            // Both solves reach their own floor: Cholesky ~1e-15, CG + GAMG ~1e-11 (the
            // preset's 1e-12 recursive residual, measured 5.5e-11 true).
            for s in [ours, &theirs] {
                let r = s["relative_residual"].as_f64().expect("residual");
                assert!(r <= 1e-10, "{label}: relative residual {r:e}");
            }
            // Quantities of the displacement, which agrees to ~1e-11 (the static tests'
            // AGREEMENT = 1e-8 leaves the margin), each relative to its own size.
            let close = |path: &[&str], scale: f64| {
                let pick = |s: &Value| {
                    path.iter()
                        .fold(s, |v, k| match k.parse::<usize>() {
                            Ok(i) => &v[i],
                            Err(_) => &v[*k],
                        })
                        .as_f64()
                        .unwrap_or_else(|| panic!("{label}: {path:?} is a number"))
                };
                let (a, b) = (pick(ours), pick(&theirs));
                assert!(
                    (a - b).abs() <= AGREEMENT * scale.max(b.abs()),
                    "{label}: {path:?} {a:e} against the in-process {b:e}"
                );
                println!("{label}: {path:?} {a:e} (in-process {b:e})");
            };
            close(&["max_displacement"], 0.0);
            close(&["max_von_mises"], 0.0);
            close(&["estimated_error", "relative"], 0.0);
            close(&["estimated_error", "eta"], 0.0);
            close(&["deformation", "max_rotation_deg"], 0.0);
            let load = theirs["applied_load_n"][2].as_f64().expect("load").abs();
            for axis in ["0", "1", "2"] {
                close(&["applied_load_n", axis], load);
                close(&["reactions", "0", "force_n", axis], load);
                close(&["probes", "0", "displacement", axis], 1e-3);
            }
            // The pieces: the in-process .vtu's arrays plus the engine's own, and each tet's
            // von Mises stress and stress tensor as the in-process run's, to 1e-8 of the
            // largest von Mises stress (the stresses are linear in u).
            let pvtu =
                std::fs::read_to_string(run_dir(&label).join("cantilever_static_petsc.pvtu"))
                    .expect("pvtu");
            let mut expected = array_names(&String::from_utf8_lossy(&vtu));
            expected.extend(["node", "rank", "tet"].map(String::from));
            assert_eq!(array_names(&pvtu), expected, "{label}: declared arrays");
            let scale = their_von_mises.iter().fold(0.0, |m: f64, v| m.max(v.abs()));
            let mut worst = 0.0f64;
            let mut cells = 0;
            for rank in 0..ranks {
                let piece = std::fs::read(run_dir(&label).join(format!(
                    "cantilever_static_petsc/cantilever_static_{rank}.vtu"
                )))
                .expect("piece");
                assert_eq!(
                    array_names(&String::from_utf8_lossy(&piece)),
                    expected,
                    "{label}: piece {rank}'s arrays"
                );
                let tets = read_array(&piece, "tet").expect("tet");
                let von_mises = read_array(&piece, "von_mises").expect("von_mises");
                let stress = read_array(&piece, "stress").expect("stress");
                for (i, &t) in tets.iter().enumerate() {
                    let t = t as usize;
                    worst = worst.max((von_mises[i] - their_von_mises[t]).abs());
                    for k in 0..6 {
                        worst = worst.max((stress[6 * i + k] - their_stress[6 * t + k]).abs());
                    }
                }
                cells += tets.len();
            }
            assert_eq!(
                cells,
                their_von_mises.len(),
                "{label}: every tet in one piece"
            );
            println!("{label}: per-tet stress differs by at most {worst:.2e} Pa of {scale:.2e}");
            assert!(
                worst <= AGREEMENT * scale,
                "{label}: stress {worst:e} of {scale:e}"
            );
        }
    }

    /// Where [`run`] put the outputs of the run `name`.
    fn run_dir(name: &str) -> PathBuf {
        Path::new(env!("CARGO_TARGET_TMPDIR"))
            .join("petsc-tests")
            .join(name)
    }

    #[test]
    fn each_rank_writes_its_piece_of_the_parallel_output() {
        let dir = scratch("pvtu_scene");
        let scene = dir.join("bar.toml");
        // The bimaterial bar with its outputs on (no PNG: the engine does not render).
        let text = std::fs::read_to_string(scenes().join("bimaterial_bar.toml"))
            .expect("scene")
            .replace("png = true", "vtu = true");
        std::fs::write(&scene, text).expect("scene written");
        let Some(run) = run("pvtu_2", 2, &scene, &[]) else {
            return;
        };
        assert!(run.success, "{}", run.stderr);
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("petsc-tests/pvtu_2");
        let pvtu = std::fs::read_to_string(out.join("bar_petsc.pvtu")).expect("pvtu");
        assert!(
            std::fs::read_to_string(out.join("bar_petsc.pvd"))
                .expect("pvd")
                .contains("bar_petsc.pvtu")
        );
        let mut cells = 0;
        let mut nodes_seen = vec![false; run.displacement.len() / 3];
        for rank in 0..2 {
            assert!(pvtu.contains(&format!("bar_petsc/bar_{rank}.vtu")));
            // The pieces are binary (the default encoding); `read_array` decodes them.
            let piece =
                std::fs::read(out.join(format!("bar_petsc/bar_{rank}.vtu"))).expect("piece");
            let block = |name: &str| read_array(&piece, name).expect(name);
            let ranks = block("rank");
            assert!(!ranks.is_empty(), "rank {rank} wrote no cell");
            assert!(ranks.iter().all(|&r| r == rank as f64));
            cells += ranks.len();
            let node_ids: Vec<usize> = block("node").iter().map(|&v| v as usize).collect();
            let values = block("displacement");
            // Each piece's values, ghost nodes included, are the gathered solution's, bit for
            // bit (both are the same f64s of PETSc's vector, written as raw bits).
            for (i, &n) in node_ids.iter().enumerate() {
                nodes_seen[n] = true;
                assert_eq!(values[3 * i..3 * i + 3], run.displacement[3 * n..3 * n + 3]);
            }
        }
        assert_eq!(cells as u64, run.summary["tets"].as_u64().expect("tets"));
        assert!(nodes_seen.iter().all(|&s| s), "every node in some piece");
    }

    /// `mpirun -n 2 tetfem run SCENE …` (the CLI, which hands a scene with `engine = "petsc"`
    /// to tetfem-petsc): the JSON summary, or `None` where the CLI binary is not beside
    /// tetfem-petsc (it is after the workspace's `cargo test --release`, which CI runs first).
    fn run_through_cli(name: &str, scene: &Path, args: &[&str]) -> Option<(bool, Value, String)> {
        let tetfem = Path::new(env!("CARGO_BIN_EXE_tetfem-petsc")).with_file_name("tetfem");
        if !tetfem.is_file() {
            println!(
                "SKIPPED {name}: no {} (cargo build --release first)",
                tetfem.display()
            );
            return None;
        }
        let Some(mpirun) = mpirun() else {
            println!("SKIPPED {name}: no mpirun on PATH (apt-get install -y petsc-dev)");
            return None;
        };
        let _one = MPIRUN.lock().unwrap_or_else(|p| p.into_inner());
        let dir = scratch(name);
        let mut command = Command::new(mpirun);
        command
            .args(["--oversubscribe", "--bind-to", "none", "-n", "2"])
            .arg(&tetfem)
            .arg("run")
            .arg(scene)
            .args(["--json", "--out"])
            .arg(&dir)
            .args(args)
            // The binary beside the CLI, not one a developer may have on PATH or named.
            .env_remove("TETFEM_PETSC_BINARY");
        let (status, stdout, stderr) = finish(name, 2, command);
        Some((
            status.success(),
            serde_json::from_str(&stdout).unwrap_or(Value::Null),
            stderr,
        ))
    }

    #[test]
    fn tetfem_run_hands_a_petsc_scene_to_the_engine_with_the_scenes_solver_and_options() {
        let dir = scratch("handoff_scenes");
        let text = std::fs::read_to_string(cantilever()).expect("scene");
        let (want, _, _) = direct(&cantilever());
        let tip = |s: &Value| -> f64 { s["probes"][0]["displacement"][2].as_f64().expect("tip") };
        // The scene names the engine and a direct solver.
        let direct_scene = dir.join("mumps.toml");
        std::fs::write(
            &direct_scene,
            format!("engine = \"petsc\"\n{text}\n[petsc]\nsolver = \"mumps\"\n"),
        )
        .expect("scene written");
        let Some((success, s, stderr)) = run_through_cli("handoff_mumps", &direct_scene, &[])
        else {
            return;
        };
        assert!(success, "{stderr}");
        assert_eq!(
            s["petsc"]["ranks"], 2,
            "both ranks of mpirun ran the engine"
        );
        assert_eq!(
            s["petsc"]["pc_type"], "cholesky",
            "the scene's [petsc] solver"
        );
        // The tip probe (mean uz of its nodes) against tetfem's direct solve: both direct, so to
        // the issue's 1e-8.
        let built = Scene::load(&cantilever())
            .expect("scene")
            .build()
            .expect("built");
        let nodes = &built.probes[0].nodes;
        let want_tip = nodes.iter().map(|&n| want[3 * n + 2]).sum::<f64>() / nodes.len() as f64;
        assert!(
            ((tip(&s) - want_tip) / want_tip).abs() < AGREEMENT,
            "{} vs {want_tip}",
            tip(&s)
        );
        // GAMG with the scene's loose -ksp_rtol 1e-4 stops sooner than at the preset's 1e-12;
        // the command line's -ksp_rtol wins over the scene's and gives the preset's count.
        let loose_scene = dir.join("loose.toml");
        std::fs::write(
            &loose_scene,
            format!("engine = \"petsc\"\n{text}\n[petsc]\noptions = \"-ksp_rtol 1e-4\"\n"),
        )
        .expect("scene written");
        let iterations = |s: &Value| s["petsc"]["iterations"].as_i64().expect("iterations");
        let (ok, loose, stderr) =
            run_through_cli("handoff_loose", &loose_scene, &[]).expect("ran before");
        assert!(ok, "{stderr}");
        let (ok, tight, stderr) = run_through_cli(
            "handoff_tight",
            &loose_scene,
            &["--petsc-options", "-ksp_rtol 1e-12"],
        )
        .expect("ran before");
        assert!(ok, "{stderr}");
        let (ok, preset, stderr) =
            run_through_cli("handoff_preset", &cantilever(), &["--engine", "petsc"])
                .expect("ran before");
        assert!(ok, "{stderr}");
        assert_eq!(preset["petsc"]["pc_type"], "gamg");
        assert!(
            iterations(&loose) < iterations(&preset),
            "rtol 1e-4: {} iterations, 1e-12: {}",
            iterations(&loose),
            iterations(&preset)
        );
        assert_eq!(
            iterations(&tight),
            iterations(&preset),
            "the command line wins"
        );
    }

    #[test]
    fn a_failure_of_one_rank_stops_every_rank_instead_of_hanging() {
        let Some(mpirun) = mpirun() else {
            println!("SKIPPED a_failure_of_one_rank: no mpirun on PATH");
            return;
        };
        let _one = MPIRUN.lock().unwrap_or_else(|p| p.into_inner());
        let binary = env!("CARGO_BIN_EXE_tetfem-petsc");
        let missing = scenes().join("no_such_scene_on_rank_1.toml");
        // MPMD: rank 0 gets the cantilever, rank 1 a file that does not exist.
        let mut child = Command::new(mpirun)
            .stdin(Stdio::null())
            .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
            .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
            .args(["--oversubscribe", "--bind-to", "none", "-n", "1", binary])
            .arg(cantilever())
            .args(["--no-files", ":", "-n", "1", binary])
            .arg(&missing)
            .arg("--no-files")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("mpirun starts");
        let clock = Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().expect("mpirun status") {
                break status;
            }
            // Rank 0 alone would wait forever in its first collective call.
            if clock.elapsed() > Duration::from_secs(120) {
                let _ = child.kill();
                panic!("rank 0 hung after rank 1 failed");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        let mut stderr = String::new();
        child
            .stderr
            .take()
            .map(|mut s| s.read_to_string(&mut stderr));
        assert!(!status.success());
        // Rank 0 carries rank 1's own words: mpirun may end the job before rank 1's line
        // reaches stderr, so the culprit must not depend on it.
        let rank0 = stderr
            .lines()
            .find(|line| line.starts_with("error (rank 0 of 2)"))
            .unwrap_or_else(|| panic!("rank 0 reports: {stderr}"));
        assert!(
            rank0.contains("rank(s) [1] failed") && rank0.contains("no_such_scene_on_rank_1.toml"),
            "rank 0 names rank 1 and its file: {stderr}"
        );
    }

    fn big_endian_i32(bytes: &[u8], at: &mut usize) -> i32 {
        let value = i32::from_be_bytes(bytes[*at..*at + 4].try_into().expect("4 bytes"));
        *at += 4;
        value
    }

    fn big_endian_f64(bytes: &[u8], at: &mut usize) -> f64 {
        let value = f64::from_be_bytes(bytes[*at..*at + 8].try_into().expect("8 bytes"));
        *at += 8;
        value
    }

    #[test]
    fn export_writes_k_ff_and_the_right_hand_side_in_petsc_binary_format() {
        let Some(mpirun) = mpirun() else {
            println!("SKIPPED export: no mpirun on PATH");
            return;
        };
        let dir = scratch("export");
        let scene = dir.join("pulled_block.toml");
        std::fs::write(&scene, PULLED_BLOCK).expect("scene written");
        let out = dir.join("system");
        {
            let _one = MPIRUN.lock().unwrap_or_else(|p| p.into_inner());
            let status = Command::new(mpirun)
                .stdin(Stdio::null())
                .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
                .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
                .args(["--oversubscribe", "--bind-to", "none", "-n", "2"])
                .arg(env!("CARGO_BIN_EXE_tetfem-petsc"))
                .arg(&scene)
                .arg("--export")
                .arg(&out)
                .status()
                .expect("mpirun runs");
            assert!(status.success());
        }
        // The DOF map: PETSc row → mesh DOF, free or not.
        let map: Vec<(usize, bool)> = std::fs::read_to_string(out.join("dofs.txt"))
            .expect("dofs.txt")
            .lines()
            .skip(1)
            .map(|l| {
                let f: Vec<&str> = l.split(' ').collect();
                let node: usize = f[1].parse().expect("node");
                let axis: usize = f[2].parse().expect("axis");
                (3 * node + axis, f[3] == "free")
            })
            .collect();
        assert!(
            std::fs::read_to_string(out.join("K.petsc.info"))
                .expect("info")
                .contains("-matload_block_size 3")
        );
        // K: int32 classid, M, N, nnz; row lengths; columns; f64 values (big-endian).
        let bytes = std::fs::read(out.join("K.petsc")).expect("K.petsc");
        let mut at = 0;
        assert_eq!(big_endian_i32(&bytes, &mut at), 1211216, "Mat classid");
        let rows = big_endian_i32(&bytes, &mut at) as usize;
        assert_eq!(rows, map.len());
        assert_eq!(big_endian_i32(&bytes, &mut at) as usize, rows);
        let nnz = big_endian_i32(&bytes, &mut at) as usize;
        let lengths: Vec<usize> = (0..rows)
            .map(|_| big_endian_i32(&bytes, &mut at) as usize)
            .collect();
        let columns: Vec<usize> = (0..nnz)
            .map(|_| big_endian_i32(&bytes, &mut at) as usize)
            .collect();
        let values: Vec<f64> = (0..nnz).map(|_| big_endian_f64(&bytes, &mut at)).collect();
        assert_eq!(at, bytes.len(), "nothing after the values");

        let built = Scene::load(&scene).expect("scene").build().expect("built");
        let options = SolverOptions {
            method: LinearMethod::Direct,
            ..Default::default()
        };
        let solver =
            StaticSolver::with_options(&built.mesh, &built.materials, &built.constraints, options)
                .expect("assembled");
        let k = solver.stiffness();
        let largest = k.values().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        // Element sums in another order: round-off of a few ulps of the largest entry.
        let tolerance = 1e-12 * largest;
        let mut start = 0;
        let mut diagonal = f64::NAN;
        let mut free_entries = 0;
        for (row, &length) in lengths.iter().enumerate() {
            let (p, p_free) = map[row];
            for k_at in start..start + length {
                let (q, q_free) = map[columns[k_at]];
                let value = values[k_at];
                match (p_free, q_free) {
                    (true, true) => {
                        let want = k.get(p, q).unwrap_or(0.0);
                        assert!(
                            (value - want).abs() <= tolerance,
                            "K[{p}][{q}]: {value:e} vs {want:e}"
                        );
                        free_entries += usize::from(want != 0.0);
                    }
                    _ if row == columns[k_at] => diagonal = value,
                    _ => assert_eq!(value, 0.0, "zeroed row/column {row}"),
                }
            }
            start += length;
        }
        assert!(diagonal > 0.0, "d on the constrained diagonal");
        // Every stored non-zero of K_ff is in the file (counted once per (p, q)).
        let k_ff_nonzeros = solver
            .free_stiffness()
            .values()
            .iter()
            .filter(|v| **v != 0.0)
            .count();
        assert_eq!(free_entries, k_ff_nonzeros);

        // b: f − K·u_c on the free rows, d·u_c on the constrained ones.
        let bytes = std::fs::read(out.join("b.petsc")).expect("b.petsc");
        let mut at = 0;
        assert_eq!(big_endian_i32(&bytes, &mut at), 1211214, "Vec classid");
        assert_eq!(big_endian_i32(&bytes, &mut at) as usize, rows);
        let prescribed: Vec<f64> = (0..map.len())
            .map(|d| built.constraints.get(d).unwrap_or(0.0))
            .collect();
        let coupling = k.mul(&prescribed).expect("K·u_c");
        let rhs: Vec<f64> = built
            .loads
            .as_slice()
            .iter()
            .zip(&coupling)
            .map(|(f, c)| f - c)
            .collect();
        let rhs_scale = rhs.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for row in 0..rows {
            let value = big_endian_f64(&bytes, &mut at);
            let (p, free) = map[row];
            if free {
                // The same sums in another order (PETSc subtracts the columns rank by rank).
                assert!(
                    (value - rhs[p]).abs() <= 1e-12 * rhs_scale,
                    "b[{row}]: {value:e} vs {:e}",
                    rhs[p]
                );
            } else {
                assert_eq!(value, diagonal * prescribed[p], "b[{row}] = d·u_c");
            }
        }
    }

    #[test]
    fn command_line_petsc_options_win_over_the_preset() {
        let Some(run) = run(
            "petsc_options",
            1,
            &cantilever(),
            &["-pc_type", "jacobi", "-ksp_rtol", "1e-6"],
        ) else {
            return;
        };
        assert!(run.success, "{}", run.stderr);
        assert_eq!(run.summary["petsc"]["pc_type"], "jacobi");
        // Loosened to 1e-6: the true residual is near it, far above the preset's 1e-12.
        let residual = run.summary["petsc"]["relative_residual"]
            .as_f64()
            .expect("residual");
        assert!(residual > 1e-9 && residual < 1e-5, "{residual:e}");
    }

    #[test]
    fn a_solve_that_does_not_converge_is_a_named_error() {
        let Some(run) = run("not_converged", 2, &cantilever(), &["-ksp_max_it", "3"]) else {
            return;
        };
        assert!(!run.success, "3 iterations cannot reach 1e-12");
        assert!(run.stderr.contains("KSP_DIVERGED_ITS"), "{}", run.stderr);
        assert!(run.stderr.contains("after 3 iterations"), "{}", run.stderr);
    }

    #[test]
    fn bad_input_names_the_culprit() {
        // The explicit method (its steps need no solve to distribute) is refused by name.
        let dir = scratch("explicit_scene_file");
        let explicit = dir.join("explicit.toml");
        std::fs::write(
            &explicit,
            std::fs::read_to_string(scenes().join("cantilever_dynamic.toml"))
                .expect("scene")
                .replace("\"backward_euler\"", "\"explicit\""),
        )
        .expect("scene written");
        let Some(run_explicit) = run("explicit_scene", 1, &explicit, &[]) else {
            return;
        };
        assert!(!run_explicit.success);
        assert!(
            run_explicit.stderr.contains("analysis.method")
                && run_explicit.stderr.contains("Explicit")
                && run_explicit.stderr.contains("newmark"),
            "{}",
            run_explicit.stderr
        );
        // No constraint: the core's rigid-mode check, before anything is assembled.
        let floating = dir.join("floating.toml");
        std::fs::write(
            &floating,
            "[mesh.box]\nmax = [1.0, 0.1, 0.1]\ncells = [4, 1, 1]\n\n[material]\n\
             youngs_modulus = 1e9\npoisson_ratio = 0.3\ndensity = 1000.0\n\n[[loads]]\n\
             gravity = [0.0, 0.0, -9.81]\n",
        )
        .expect("scene written");
        let run_floating = run("floating_scene", 2, &floating, &[]).expect("ran before");
        assert!(!run_floating.success);
        assert!(
            run_floating.stderr.contains("not fully constrained")
                && run_floating.stderr.contains("6 of the 6 rigid-body modes"),
            "{}",
            run_floating.stderr
        );
        let missing = scenes().join("no_such_scene.toml");
        let run_missing = run("missing_scene", 1, &missing, &[]).expect("ran before");
        assert!(!run_missing.success);
        assert!(
            run_missing.stderr.contains("no_such_scene.toml"),
            "{}",
            run_missing.stderr
        );
        // A key the engine would ignore is refused (issue 33): a run asked for PNG frames must
        // not end without them looking complete.
        let with_png = scenes().join("cantilever_static.toml");
        let run_png = run("png_scene", 1, &with_png, &[]).expect("ran before");
        assert!(!run_png.success);
        assert!(
            run_png.stderr.contains("output.png") && run_png.stderr.contains("png = false"),
            "{}",
            run_png.stderr
        );
        // The other keys it would ignore, each named in the error.
        let base = std::fs::read_to_string(cantilever()).expect("scene");
        for (label, text, key) in [
            (
                "order_2",
                base.replacen("[mesh", "[mesh]\norder = 2\n\n[mesh", 1),
                "mesh.order",
            ),
            (
                "linear_solver",
                format!("{base}\n[analysis]\nlinear_solver = \"direct\"\n"),
                "analysis.linear_solver",
            ),
            (
                "checkpoint",
                // A dynamic scene: a static one refuses the key when parsed already.
                std::fs::read_to_string(scenes().join("cantilever_dynamic.toml"))
                    .expect("scene")
                    .replace("png = true", "png = false")
                    .replace("[output]", "[output]\ncheckpoint_every = 5"),
                "the PETSc engine writes no checkpoints",
            ),
        ] {
            let scene = dir.join(format!("{label}.toml"));
            std::fs::write(&scene, text).expect("scene written");
            let refused = run(label, 1, &scene, &[]).expect("ran before");
            assert!(!refused.success, "{label}");
            assert!(refused.stderr.contains(key), "{label}: {}", refused.stderr);
            assert!(
                refused.stderr.contains("engine"),
                "{label}: {}",
                refused.stderr
            );
        }
        let run_solver =
            run("bad_solver", 1, &cantilever(), &["--solver", "lu"]).expect("ran before");
        assert!(!run_solver.success);
        assert!(
            run_solver.stderr.contains("lu") && run_solver.stderr.contains("gamg"),
            "{}",
            run_solver.stderr
        );
    }
}
