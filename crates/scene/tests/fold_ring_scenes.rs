//! The self-contact scenes of issue 36 run with the intersection audit on
//! (`tetfem::contact::surface::audit`): after every accepted Newton iterate of every step, the
//! exact triangle–triangle test over the whole surface (independent of the barrier) finds no
//! intersecting pair. The scenes' own set-up is used (the dynamic ones through
//! [`DynamicSetup::of_scene`] and [`run_dynamic`], the runner's path; the static one through
//! the same Newton solve its runner's `Static` analysis calls), with the audit switched on in the
//! surface contact they build.

use std::ops::ControlFlow;
use std::path::PathBuf;

use tetfem::analysis::dynamics::InternalForce;
use tetfem::analysis::nonlinear::solve_nonlinear_static_with_surface_contact;
use tetfem::contact::surface::{AuditCounts, IntersectionAudit, SurfaceContact};
use tetfem_scene::{
    Analysis, DynamicRun, DynamicSetup, DynamicSummary, RunLength, RunOptions, Scene, TimeStep,
    run_dynamic, run_static_with,
};

fn scene(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    Scene::load(&path).unwrap()
}

/// Runs dynamic `scene` for `duration` (s; its own when `None`) with the audit on.
fn audited_dynamic(scene: &Scene, duration: Option<f64>) -> (DynamicSummary, AuditCounts) {
    let Analysis::Dynamic(settings) = scene.analysis() else {
        panic!("{} is not dynamic", scene.source_name());
    };
    let mut setup = DynamicSetup::of_scene(scene, scene.build().unwrap(), settings).unwrap();
    setup.linear_method = scene.spec().linear_method();
    setup.nonlinear_solve = scene.spec().nonlinear_solve();
    setup.newton.tolerance = settings.newton_tolerance;
    let audit = IntersectionAudit::new();
    let surface = match &setup.force {
        InternalForce::Nonlinear(n) => n.surface_contact().expect("surface contact"),
        InternalForce::Linear => panic!("a scene with self-contact steps through Newton"),
    };
    surface.set_intersection_audit(Some(audit.clone()));
    let run = DynamicRun {
        title: scene.title(),
        source: scene.source_name().to_string(),
        method: settings.method,
        dt: TimeStep::Seconds(settings.dt),
        length: RunLength::Duration(duration.unwrap_or(settings.duration)),
    };
    let summary = run_dynamic(&setup, &run, None, &mut |_, _| ControlFlow::Continue(())).unwrap();
    (summary, audit.counts())
}

/// Asserts the audit saw iterates and no intersection, and that self-contact was active: the
/// smallest distance reached d̂ and stayed > 0.
fn assert_clean(name: &str, counts: &AuditCounts, d_hat: f64) {
    println!("{name}: {counts:?} (d̂ {d_hat:e} m)");
    assert!(counts.checks > 0, "{name}: nothing checked");
    assert_eq!((counts.hits, counts.failed), (0, 0), "{name}: {counts:?}");
    assert!(
        counts.smallest_distance < d_hat && counts.smallest_distance > 0.0,
        "{name}: {counts:?}"
    );
}

#[test]
fn blocks_head_on_never_intersect() {
    let scene = scene("blocks_head_on.toml");
    let (summary, counts) = audited_dynamic(&scene, None);
    let d_hat = scene
        .spec()
        .self_contact
        .as_ref()
        .unwrap()
        .get_ref()
        .distance;
    println!("{} steps, {:?}", summary.steps, summary.newton);
    assert_clean("blocks_head_on", &counts, d_hat.unwrap());
}

#[test]
fn beam_fold_touches_itself_and_never_intersects() {
    let scene = scene("beam_fold.toml");
    // The whole 0.4 s: the halves meet at t ≈ 0.24 s and stay pressed together.
    let (summary, counts) = audited_dynamic(&scene, None);
    let d_hat = scene
        .spec()
        .self_contact
        .as_ref()
        .unwrap()
        .get_ref()
        .distance;
    println!("{} steps, {:?}", summary.steps, summary.newton);
    assert_clean("beam_fold", &counts, d_hat.unwrap());
}

/// The shipped 8-block stack, whole (50 steps: the landings and the settling), every accepted
/// Newton iterate audited over all eight blocks' surfaces.
#[test]
fn block_stack_never_intersects() {
    let scene = scene("block_stack.toml");
    let (summary, counts) = audited_dynamic(&scene, None);
    let d_hat = scene
        .spec()
        .self_contact
        .as_ref()
        .unwrap()
        .get_ref()
        .distance;
    println!("{} steps, {:?}", summary.steps, summary.newton);
    assert_clean("block_stack", &counts, d_hat.unwrap());
    // Every step's iterates were checked, not the first ones only.
    assert!(counts.checks >= summary.steps, "{counts:?}");
}

#[test]
fn ring_squeeze_touches_itself_and_never_intersects() {
    let scene = scene("ring_squeeze.toml");
    let built = scene.build().unwrap();
    let contact = scene
        .contact(&built.mesh, built.material.youngs_modulus())
        .unwrap();
    let definition = built.definition(scene.model(), contact).unwrap();
    let data = definition.surface_contact.as_ref().unwrap();
    let surface = SurfaceContact::new(&definition.mesh, &data.body_of_node, data.barrier).unwrap();
    let audit = IntersectionAudit::new();
    surface.set_intersection_audit(Some(audit.clone()));
    // The solve `tetfem::analysis::Static` makes of this definition (its surface contact
    // audited): the model per material, the static load, the supports' motions, the plates.
    let report = solve_nonlinear_static_with_surface_contact(
        &definition.mesh,
        &definition.model.build_map(&definition.materials),
        &definition.constraints,
        &definition.static_load().unwrap(),
        &definition.motions,
        definition.contact.as_ref(),
        &surface,
        scene.static_newton(),
    )
    .unwrap();
    println!("ring_squeeze: {} Newton iterations", report.iterations);
    assert_clean(
        "ring_squeeze",
        &audit.counts(),
        data.barrier.activation_distance,
    );
    assert!(audit.counts().checks >= report.iterations);
    // The audited solve is the scene runner's (the audit observes, it changes no number): the
    // probes' mean displacements agree to the last bit.
    let summary = run_static_with(
        &scene,
        &RunOptions {
            no_files: true,
            ..RunOptions::default()
        },
    )
    .unwrap();
    // The balance through the scene's own outputs: the rollers' reactions (what the
    // supports exert on the ring, the barrier's push on a supported node included) and the
    // plates' contact forces (what the ring exerts on them) sum to zero up to the sum of the
    // free residual components where Newton stopped. The scene's [contact] gap_tolerance = 1e-6
    // ends the plates' barrier continuation where each pushed node's force is resolved to a few
    // 1e-9 N (see tests/core/self_contact_iterates.rs: at the default 1e-8 the last stage's
    // gaps of 3e-11 m resolve them to ~6e-7 N, a balance of 3e-8).
    let supports = summary
        .reactions
        .as_ref()
        .unwrap()
        .iter()
        .fold(nalgebra::Vector3::zeros(), |s, r| {
            s + nalgebra::Vector3::from(r.force_n)
        });
    let plates: Vec<_> = summary
        .contact_forces
        .as_ref()
        .unwrap()
        .iter()
        .map(|c| nalgebra::Vector3::from(c.force_n))
        .collect();
    let on_ring = -plates.iter().sum::<nalgebra::Vector3<f64>>();
    let scale = plates.iter().map(|p| p.norm()).fold(0.0, f64::max);
    let imbalance = (supports + on_ring).norm();
    println!(
        "plates {plates:?} N, supports {supports:?} N: imbalance {imbalance:.3e} N, {:.3e} of \
         the plate force",
        imbalance / scale
    );
    // The 1e-8 of the plate force (21.6 N): measured 2.5e-12.
    assert!(scale > 20.0 && imbalance <= 1e-8 * scale);
    for probe in &summary.probes {
        let nodes = built.probes.iter().find(|p| p.name == probe.name).unwrap();
        let mean = |a: usize| {
            nodes
                .nodes
                .iter()
                .map(|&n| report.displacement[3 * n + a])
                .sum::<f64>()
                / nodes.nodes.len() as f64
        };
        println!("probe {}: {:?}", probe.name, probe.displacement);
        assert_eq!(
            probe.displacement,
            [mean(0), mean(1), mean(2)],
            "{}",
            probe.name
        );
    }
}

#[test]
fn a_mesh_file_may_be_one_placed_body_but_not_two() {
    let base = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let text = "[mesh.gmsh]\nfile = \"ring_squeeze.msh\"\n\n[material]\nyoungs_modulus = 1e6\n\
                poisson_ratio = 0.3\ndensity = 1100.0\n\n[self_contact]\n\n[analysis]\n\
                type = \"dynamic\"\nmethod = \"backward_euler\"\nmodel = \"neo-hookean\"\n\
                dt = 1e-3\nduration = 1e-3\n";
    let plain = Scene::parse(text, "plain.toml", &base)
        .unwrap()
        .build()
        .unwrap();
    let one = format!(
        "{text}\n[[bodies]]\ntranslation = [0.0, 0.0, 0.001]\nvelocity = [0.0, 0.0, -1.0]\n"
    );
    let built = Scene::parse(&one, "one.toml", &base)
        .unwrap()
        .build()
        .unwrap();
    // Placed as given: every node moved by the translation, exactly as x + t rounds.
    for (a, b) in built.mesh.nodes().iter().zip(plain.mesh.nodes()) {
        assert_eq!(*a, b + nalgebra::Vector3::new(0.0, 0.0, 0.001));
    }
    assert_eq!(built.bodies.as_ref().unwrap().count(), 1);
    let two = format!("{one}\n[[bodies]]\ntranslation = [0.1, 0.0, 0.0]\n");
    let error = Scene::parse(&two, "two.toml", &base)
        .and_then(|s| s.build().map(|_| ()))
        .unwrap_err()
        .to_string();
    println!("{error}");
    assert!(
        error.contains("bodies") && error.contains("copies"),
        "{error}"
    );
}

/// Two 0.1 m rubber cubes 5 cm apart along x (bodies 0 and 1, far out of each other's reach),
/// each clamped on its face at its own x start and pulled sideways at its far face by
/// 500 N, with `materials` the `[[materials]]` entries and `model` analysis.model.
fn two_cantilevers(materials: &str, model: &str) -> String {
    format!(
        "[mesh.box]\nmax = [0.1, 0.1, 0.1]\ncells = [2, 2, 2]\nsplit = \"lecture6\"\n\n\
         {materials}\n\
         [[bodies]]\n\n[[bodies]]\ntranslation = [0.15, 0.0, 0.0]\n\n\
         [self_contact]\ndistance = 2e-3\nstiffness = 1e3\n\n\
         [[constraints]]\nwhere = {{ plane = {{ axis = \"x\", at = 0.0 }} }}\n\n\
         [[constraints]]\nwhere = {{ plane = {{ axis = \"x\", at = 0.15 }} }}\n\n\
         [[loads]]\nwhere = {{ plane = {{ axis = \"x\", at = 0.1 }} }}\ntotal_force = [0.0, 0.0, 500.0]\n\n\
         [[loads]]\nwhere = {{ plane = {{ axis = \"x\", at = 0.25 }} }}\ntotal_force = [0.0, 0.0, 500.0]\n\n\
         [[probes]]\nname = \"tip0\"\nwhere = {{ plane = {{ axis = \"x\", at = 0.1 }} }}\n\n\
         [[probes]]\nname = \"tip1\"\nwhere = {{ plane = {{ axis = \"x\", at = 0.25 }} }}\n\n\
         [analysis]\nmodel = \"{model}\"\nload_steps = 4\nnewton_tolerance = 1e-13\n"
    )
}

/// A `[[materials]]` entry of rubber for body `body`, with its own `model` line if given.
fn rubber_of_body(body: usize, model: Option<&str>) -> String {
    let model = model.map_or(String::new(), |m| format!("model = \"{m}\"\n"));
    format!(
        "[[materials]]\nyoungs_modulus = 1e6\npoisson_ratio = 0.3\ndensity = 1000.0\n\
         where = {{ body = {body} }}\n{model}\n"
    )
}

fn tips(text: &str) -> [[f64; 3]; 2] {
    let base = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let scene = Scene::parse(text, "regions.toml", &base).unwrap();
    let summary = run_static_with(
        &scene,
        &RunOptions {
            no_files: true,
            ..RunOptions::default()
        },
    )
    .unwrap();
    let tip = |name: &str| {
        summary
            .probes
            .iter()
            .find(|p| p.name == name)
            .unwrap()
            .displacement
    };
    [tip("tip0"), tip("tip1")]
}

#[test]
fn each_material_region_takes_its_own_model_key() {
    // Body 0 linear by its region's key, body 1 Neo-Hookean by analysis.model.
    let regions = format!(
        "{}{}",
        rubber_of_body(0, Some("linear")),
        rubber_of_body(1, None)
    );
    let mixed = tips(&two_cantilevers(&regions, "neo-hookean"));
    let both = format!("{}{}", rubber_of_body(0, None), rubber_of_body(1, None));
    let linear = tips(&two_cantilevers(&both, "linear"));
    let neo = tips(&two_cantilevers(&both, "neo-hookean"));
    println!("tips: per region {mixed:?}, all linear {linear:?}, all neo-hookean {neo:?}");
    let gap = |a: [f64; 3], b: [f64; 3]| (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max);
    let scale = mixed[1][2].abs();
    // The two models differ by percents at this load: each region ran its own.
    assert!(gap(linear[1], neo[1]) > 1e-2 * scale);
    // Each body as under its own model for all: the bodies share no tet and no barrier pair
    // (5 cm apart, d̂ 2 mm), so each body's equations are those of the run with its model;
    // Newton (tolerance 1e-13) stops at the round-off of the forces in all three runs, so
    // 1e-10 of |u| (10⁶ ε, a soft cube's conditioning with margin) holds what differs.
    assert!(gap(mixed[0], linear[0]) <= 1e-10 * scale);
    assert!(gap(mixed[1], neo[1]) <= 1e-10 * scale);
}

#[test]
fn a_region_model_is_refused_by_its_key() {
    let base = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let parse = |text: &str| Scene::parse(text, "regions.toml", &base).map(|_| ());
    let unknown = format!(
        "{}{}",
        rubber_of_body(0, None),
        rubber_of_body(1, Some("rubbery"))
    );
    let error = parse(&two_cantilevers(&unknown, "linear"))
        .unwrap_err()
        .to_string();
    println!("{error}");
    assert!(
        error.contains("materials[1].model") && error.contains("rubbery"),
        "{error}"
    );
    // A modal analysis of a nonlinear region: the library's rule, at the region's key.
    let modal = "[mesh.box]\nmax = [0.2, 0.1, 0.1]\ncells = [2, 1, 1]\n\n\
                 [material]\nyoungs_modulus = 1e6\npoisson_ratio = 0.3\ndensity = 1000.0\n\n\
                 [[materials]]\nyoungs_modulus = 2e6\npoisson_ratio = 0.3\ndensity = 1000.0\n\
                 where = { box = { min = [0.1, 0.0, 0.0], max = [0.2, 0.1, 0.1] } }\n\
                 model = \"corotational\"\n\n\
                 [[constraints]]\nwhere = { plane = { axis = \"x\", at = 0.0 } }\n\n\
                 [analysis]\ntype = \"modal\"\nmodes = 2\n";
    let error = parse(modal).unwrap_err().to_string();
    println!("{error}");
    assert!(
        error.contains("materials[0].model") && error.contains("corotational"),
        "{error}"
    );
    // The same regions statically: Newton's keys are taken (a region is nonlinear).
    let static_scene = modal.replace("type = \"modal\"\nmodes = 2\n", "load_steps = 4\n");
    parse(&static_scene).unwrap();
}
