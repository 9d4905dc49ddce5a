//! The `units` table of the JSON summaries: the unit of every field that carries a quantity,
//! keyed by its path (`dt`, `initial_energy.kinetic`, `probes.last`, `modes.frequency_hz`;
//! array elements share their field's unit). A table rather than suffixes keeps the summaries'
//! keys stable for the Python package and users' scripts; `1` marks a dimensionless ratio.

use serde::Serialize;

/// Units of a dynamic run's summary.
pub(crate) const DYNAMIC: &[(&str, &str)] = &[
    ("dt", "s"),
    ("critical_step", "s"),
    ("dt_over_critical", "1"),
    ("end_time", "s"),
    ("setup_seconds", "s"),
    ("first_step_seconds", "s"),
    ("mean_step_seconds", "s"),
    ("step_seconds", "s"),
    ("output_seconds", "s"),
    ("initial_energy.kinetic", "J"),
    ("initial_energy.elastic", "J"),
    ("initial_energy.gravity_potential", "J"),
    ("initial_energy.load_potential", "J"),
    ("initial_energy.total", "J"),
    ("final_energy.kinetic", "J"),
    ("final_energy.elastic", "J"),
    ("final_energy.gravity_potential", "J"),
    ("final_energy.load_potential", "J"),
    ("final_energy.total", "J"),
    ("probes.last", "m"),
    ("probes.min", "m"),
    ("probes.max", "m"),
    ("reactions.force_n", "N"),
    ("reactions.moment_nm", "N·m"),
    ("reactions.moment_point_m", "m"),
    ("estimated_error.relative", "1"),
    ("estimated_error.eta", "J^1/2"),
    ("estimated_error.energy_norm", "J^1/2"),
    ("estimate_seconds", "s"),
    ("deformation.max_rotation_deg", "deg"),
    ("deformation.max_strain", "1"),
    ("step_resolution.period", "s"),
    ("step_resolution.steps_per_period", "1"),
    ("step_resolution.backward_euler_decay", "1"),
    ("contact_forces.force_n", "N"),
    ("contact_forces.peak_n", "N"),
    ("contact_forces.peak_time_s", "s"),
    ("contact_barrier.activation_distance_m", "m"),
    ("contact_barrier.stiffness", "Pa/m"),
    ("contact_barrier.gap_error_max", "1"),
    ("contact_barrier.gap_error_final", "1"),
    ("contact_barrier.smallest_gap_m", "m"),
    ("time_stepping.tolerance", "1"),
    ("time_stepping.estimated_error", "1"),
    ("time_stepping.dt_min", "s"),
    ("time_stepping.dt_max", "s"),
    ("time_stepping.output_interval", "s"),
    ("volume_change", "1"),
];

/// Units of a static run's summary.
pub(crate) const STATIC: &[(&str, &str)] = &[
    ("max_displacement", "m"),
    ("max_von_mises", "Pa"),
    ("relative_residual", "1"),
    ("probes.displacement", "m"),
    ("probes.stress_pa", "Pa"),
    ("applied_load_n", "N"),
    ("reactions.force_n", "N"),
    ("reactions.moment_nm", "N·m"),
    ("reactions.moment_point_m", "m"),
    ("estimated_error.relative", "1"),
    ("estimated_error.eta", "J^1/2"),
    ("estimated_error.energy_norm", "J^1/2"),
    ("deformation.max_rotation_deg", "deg"),
    ("deformation.max_strain", "1"),
    ("build_seconds", "s"),
    ("solve_seconds", "s"),
    ("output_seconds", "s"),
    ("phases.pattern", "s"),
    ("phases.assembly", "s"),
    ("phases.constraints", "s"),
    ("phases.symbolic", "s"),
    ("phases.factorization", "s"),
    ("phases.solve", "s"),
    ("critical_step.seconds", "s"),
    ("contact_forces.force_n", "N"),
    ("contact_barrier.activation_distance_m", "m"),
    ("contact_barrier.gap_error", "1"),
    ("contact_barrier.gap_tolerance", "1"),
];

/// Units of a static summary's `accuracy` (with `[analysis] accuracy` only: every unit names a
/// field that is there).
pub(crate) const ACCURACY: &[(&str, &str)] = &[
    ("accuracy.target", "1"),
    ("accuracy.trials.estimate", "1"),
    ("accuracy.trials.seconds", "s"),
    ("accuracy.predictions.refinement", "1"),
    ("accuracy.predictions.dofs", "1"),
    ("accuracy.predictions.seconds", "s"),
    ("accuracy.cost_exponent", "1"),
    ("accuracy.estimated_error", "1"),
    ("accuracy.locking_loss", "1"),
];

/// Units of a dynamic summary's `accuracy` (with `[analysis] accuracy` only).
pub(crate) const DYNAMIC_ACCURACY: &[(&str, &str)] = &[
    ("accuracy.target", "1"),
    ("accuracy.space.target", "1"),
    ("accuracy.space.trials.estimate", "1"),
    ("accuracy.space.trials.seconds", "s"),
    ("accuracy.space.predictions.refinement", "1"),
    ("accuracy.space.predictions.dofs", "1"),
    ("accuracy.space.predictions.seconds", "s"),
    ("accuracy.space.cost_exponent", "1"),
    ("accuracy.space.estimated_error", "1"),
    ("accuracy.space.locking_loss", "1"),
    ("accuracy.time_tolerance", "1"),
    ("accuracy.time_estimate", "1"),
    ("accuracy.estimated_error", "1"),
];

/// Units of a modal run's summary.
pub(crate) const MODAL: &[(&str, &str)] = &[
    ("modes.frequency_hz", "Hz"),
    ("modes.period_s", "s"),
    ("modes.omega_rad_per_s", "rad/s"),
    ("modes.effective_mass_fraction", "1"),
    ("modes.residual", "1"),
    ("cumulative_mass_fraction", "1"),
    ("build_seconds", "s"),
    ("solve_seconds", "s"),
    ("output_seconds", "s"),
    ("critical_step.seconds", "s"),
];

/// `summary` as one JSON object with a `units` object added (`{"dt": "s", …}`) for the fields
/// this summary has (an optional part that is absent or null, e.g. a nonlinear run's
/// `estimated_error`, has no entry); NaN becomes null. Serializing plain numbers, strings and paths cannot fail; if it did, the error is the
/// JSON.
pub(crate) fn to_json_with_units(summary: &impl Serialize, units: &[(&str, &str)]) -> String {
    let mut value = match serde_json::to_value(summary) {
        Ok(value) => value,
        Err(e) => return format!("{{\"error\":\"{e}\"}}"),
    };
    if let Some(object) = value.as_object_mut() {
        let present = |key: &str| {
            let parts: Vec<&str> = key.split('.').collect();
            has_path(&*object, &parts)
        };
        let table: serde_json::Map<String, serde_json::Value> = units
            .iter()
            .filter(|(key, _)| present(key))
            .map(|(key, unit)| (key.to_string(), serde_json::Value::from(*unit)))
            .collect();
        object.insert("units".into(), serde_json::Value::Object(table));
    }
    value.to_string()
}

/// Whether `parts` leads to a non-null value under `map`; array fields (probes, reactions,
/// modes) count if any of their elements has it (a node-set probe has no `stress_pa`, a point
/// probe after it has).
fn has_path(map: &serde_json::Map<String, serde_json::Value>, parts: &[&str]) -> bool {
    fn value_has(value: &serde_json::Value, rest: &[&str]) -> bool {
        match value {
            serde_json::Value::Array(items) => items.iter().any(|v| value_has(v, rest)),
            serde_json::Value::Object(m) if !rest.is_empty() => has_path(m, rest),
            v => rest.is_empty() && !v.is_null(),
        }
    }
    match parts.split_first() {
        Some((first, rest)) => map.get(*first).is_some_and(|v| value_has(v, rest)),
        None => false,
    }
}
