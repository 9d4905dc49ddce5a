//! What the mixed formulation's dynamic and modal scenes share (`formulation = "mixed"` with
//! `type = "dynamic"`, backward Euler or Newmark with the linear model and the consistent mass
//! on 4-node (stabilized P1–P1) or 10-node (Taylor–Hood P2–P1) tets, backward Euler with the
//! Neo-Hookean or the corotational model and still obstacles, or `type = "modal"`): the scene's
//! refusal of
//! what their
//! runners do not run and the warnings they report. The runners are `dynamic::mixed` and
//! `modal::mixed`, children of the runners that dispatch to them, so that neither depends on
//! the other's module.

use tetfem::base::error::Result;
use tetfem::mesh::CellType;

use super::Scene;

/// The mesh's and materials' warnings without the displacement element's locking warning
/// (the mixed element does not lock).
pub(crate) fn mixed_warnings<C: CellType>(
    scene: &Scene,
    built: &super::BuiltScene<C>,
) -> Result<Vec<String>> {
    let _ = scene;
    Ok(built
        .warnings()
        .iter()
        .filter(|w| {
            !matches!(
                w,
                tetfem::base::warning::Warning::NearlyIncompressible { .. }
            )
        })
        .map(ToString::to_string)
        .collect())
}

impl Scene {
    /// What a mixed dynamic or modal scene asks that this front end does not run, named for
    /// the error of `analysis.formulation` (`None` for a static scene or a runnable one): a
    /// lumped mass (the mixed element's inertia is the consistent mass), and in a dynamic run
    /// Rayleigh damping with a hyperelastic model, an error-controlled step and checkpoints
    /// (the models and methods that combine are the library's
    /// [`Combination`](tetfem::analysis::combination::Combination), checked before this).
    pub(crate) fn mixed_dynamics_refusal(&self) -> Option<String> {
        let mass = match self.analysis() {
            super::Analysis::Static => return None,
            super::Analysis::Modal(m) => m.mass,
            super::Analysis::Dynamic(d) => d.mass,
        };
        if mass == tetfem::analysis::dynamics::MassKind::Lumped {
            return Some(
                "mass = \"lumped\" (the mixed element's inertia is the consistent mass: set \
                 mass = \"consistent\")"
                    .into(),
            );
        }
        if !matches!(self.analysis(), super::Analysis::Dynamic(_)) {
            return None;
        }
        let tolerance = (self.spec.analysis.as_ref()).and_then(|a| a.get_ref().time_tolerance);
        let damped = matches!(self.analysis(), super::Analysis::Dynamic(d)
            if d.damping.mass != 0.0 || d.damping.stiffness != 0.0);
        let hyperelastic = matches!(
            self.model(),
            tetfem::model::ModelKind::NeoHookean | tetfem::model::ModelKind::Corotational
        );
        if hyperelastic && damped {
            // MixedNonlinearEuler steps the undamped body (backward Euler's own dissipation).
            Some(format!(
                "[analysis.damping] with model = \"{}\" (the mixed hyperelastic run is undamped)",
                self.model().name()
            ))
        } else if tolerance.is_some() {
            Some("analysis.time_tolerance (the mixed run takes a fixed dt)".into())
        } else if self.output().checkpoint_every > 0 {
            Some("[output] checkpoint_every".into())
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use std::ops::ControlFlow;
    use std::path::Path;

    use super::*;
    use crate::{DynamicOverrides, run_dynamic_scene, run_modal_scene};

    /// A rubber cantilever 1 × 0.2 × 0.2 m (E = 1e7 Pa), clamped at x = 0, under gravity.
    const BEAM: &str = r#"
[mesh]
order = 2
[mesh.box]
max = [1.0, 0.2, 0.2]
cells = [6, 2, 2]
split = "lecture6"
[material]
youngs_modulus = 1e7
poisson_ratio = 0.4999
density = 1000.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
[[loads]]
gravity = [0.0, 0.0, -9.81]
[[probes]]
name = "tip"
where = { plane = { axis = "x", at = 1.0 } }
[analysis]
type = "dynamic"
formulation = "mixed"
method = "newmark"
mass = "consistent"
dt = 0.005
duration = 0.4
[output]
every = 20
vtu_format = "ascii"
"#;

    fn parse(text: &str) -> Result<Scene> {
        Scene::parse(text, "beam.toml", Path::new("."))
    }

    #[test]
    fn a_mixed_newmark_scene_conserves_energy_and_writes_the_pressure() {
        let directory =
            std::env::temp_dir().join(format!("tetfem_mixed_swing_{}", std::process::id()));
        let mut scene = parse(BEAM).unwrap();
        scene.set_output_directory(directory.clone());
        let summary = run_dynamic_scene(
            &scene,
            &DynamicOverrides::default(),
            true,
            false,
            &mut |_, _| ControlFlow::Continue(()),
        )
        .unwrap();
        let end = &summary.final_energy;
        println!(
            "mixed swing: {} steps, end energies kinetic {:.4e}, elastic {:.4e}, gravity {:.4e}, \
             total {:.2e} J; tip u_z in [{:.4e}, {:.4e}] m",
            summary.steps,
            end.kinetic,
            end.elastic,
            end.gravity_potential,
            end.total,
            summary.probes[0].min[2],
            summary.probes[0].max[2]
        );
        assert_eq!(summary.steps, 80);
        // Average acceleration conserves kinetic + elastic − fᵀu of the linear undamped body
        // from its start at 0: round-off of the solves against the energies exchanged.
        assert!(end.total.abs() < 1e-9 * end.gravity_potential.abs());
        assert!(end.kinetic > 0.0 && end.elastic > 0.0);
        // The tip falls (gravity along −z) and stays below its start but for the swing's
        // small overshoot.
        assert!(summary.probes[0].min[2] < 0.0);
        let vtu = summary
            .files
            .iter()
            .find(|f| f.extension().is_some_and(|e| e == "vtu"))
            .unwrap();
        let text = std::fs::read_to_string(vtu).unwrap();
        assert!(text.contains("Name=\"pressure\""), "{vtu:?}");
        let csv = summary
            .files
            .iter()
            .find(|f| f.extension().is_some_and(|e| e == "csv"))
            .unwrap();
        let header = std::fs::read_to_string(csv).unwrap();
        assert!(header.starts_with("time_s,kinetic_J") && header.contains("tip_uz_m"));
        let _ = std::fs::remove_dir_all(directory);
    }

    #[test]
    fn a_mixed_modal_scene_matches_the_displacement_one_where_neither_locks() {
        // ν = 0.3: the displacement P2 modes are accurate, so the mixed ones must agree with
        // them to the discretisation difference (measured 0.4 % on the library's beam test).
        let modal = BEAM
            .replace("poisson_ratio = 0.4999", "poisson_ratio = 0.3")
            .replace("type = \"dynamic\"", "type = \"modal\"\nmodes = 4")
            .replace("method = \"newmark\"\n", "")
            .replace("dt = 0.005\nduration = 0.4\n", "")
            .replace("[[loads]]\ngravity = [0.0, 0.0, -9.81]\n", "")
            .replace(
                "[[probes]]\nname = \"tip\"\nwhere = { plane = { axis = \"x\", at = 1.0 } }\n",
                "",
            );
        let mixed = run_modal_scene(&parse(&modal).unwrap(), true).unwrap();
        let plain = run_modal_scene(
            &parse(&modal.replace("formulation = \"mixed\"", "formulation = \"displacement\""))
                .unwrap(),
            true,
        )
        .unwrap();
        assert_eq!(mixed.analysis, "modal (mixed)");
        for (m, d) in mixed.modes.iter().zip(&plain.modes) {
            println!(
                "mode {}: mixed {:.5} Hz, displacement P2 {:.5} Hz",
                m.mode, m.frequency_hz, d.frequency_hz
            );
            assert!((m.frequency_hz / d.frequency_hz - 1.0).abs() < 0.01);
        }
    }

    #[test]
    fn the_shipped_rubber_ball_drop_keeps_its_volume_and_bounces() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/rubber_ball_drop.toml");
        let scene = Scene::load(&path).unwrap();
        // 30 of the 60 steps: the impact (the ball leaves the ground after 27 ms).
        let summary = run_dynamic_scene(
            &scene,
            &DynamicOverrides {
                length: Some(tetfem::analysis::transient::RunLength::Steps(30)),
                ..DynamicOverrides::default()
            },
            false,
            false,
            &mut |_, _| ControlFlow::Continue(()),
        )
        .unwrap();
        let change = summary.volume_change.unwrap();
        let peak = summary.contact_forces.as_ref().unwrap()[0].peak_n;
        let (start, end) = (summary.initial_energy.total, summary.final_energy.total);
        println!(
            "ball drop, 30 steps: |V/V0 − 1| ≤ {change:.3e}, peak ground force {peak:.4e} N, \
             energy {start:.4e} → {end:.4e} J, {:?}",
            summary.newton
        );
        // The issue's 1 % (the library's test measures 5.0e-5 on this mesh).
        assert!(change < 0.01);
        // The impact: far more than the ball's weight (3.92 kg·9.81 = 38 N) on the ground.
        assert!(peak > 10.0 * 38.0);
        // Backward Euler dissipates; the ball is in the air at 30 ms (no barrier energy left
        // out of the total).
        assert!(end < start);
        // Rayleigh damping with the Neo-Hookean mixed run: refused by name.
        let text = std::fs::read_to_string(&path).unwrap().replace(
            "mass = \"consistent\"",
            "mass = \"consistent\"\ndamping = { mass = 1.0 }",
        );
        let message = Scene::parse(&text, "ball.toml", path.parent().unwrap())
            .unwrap_err()
            .to_string();
        assert!(message.contains("analysis.damping"), "{message}");
    }

    #[test]
    fn mixed_dynamics_refuses_what_it_does_not_run_naming_the_key() {
        for (from, to, culprit) in [
            (
                "mass = \"consistent\"",
                "mass = \"lumped\"",
                "mass = \"lumped\"",
            ),
            (
                "method = \"newmark\"",
                "method = \"explicit\"",
                "method = \"explicit\"",
            ),
            (
                "duration = 0.4",
                "duration = 0.4\ntime_tolerance = 1e-3",
                "time_tolerance",
            ),
            (
                "model = \"linear\"",
                "model = \"neo-hookean\"",
                "model = \"neo-hookean\"",
            ),
        ] {
            let text = BEAM.replace(
                "mass = \"consistent\"",
                "mass = \"consistent\"\nmodel = \"linear\"",
            );
            let message = parse(&text.replace(from, to)).unwrap_err().to_string();
            assert!(
                message.contains("analysis.formulation") && message.contains(culprit),
                "{culprit}: {message}"
            );
        }
    }
}
