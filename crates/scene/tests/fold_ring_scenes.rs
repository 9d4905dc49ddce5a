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
    // The first 0.3 s of its 0.4: the halves meet at t ≈ 0.24 s.
    let (summary, counts) = audited_dynamic(&scene, Some(0.3));
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
