//! Which engine runs a scene: tetfem's own solvers (the default) or PETSc (`engine = "petsc"`,
//! the distributed engine of the `tetfem-petsc` crate), and the PETSc settings of `[petsc]`.
//!
//! The scene module only checks and stores these keys: the CLI hands a PETSc scene to the
//! `tetfem-petsc` binary (which reads the same scene), so this crate never links PETSc or MPI.

use serde::Deserialize;
use toml::Spanned;

use super::Scene;
use tetfem::base::error::Result;

/// `engine = …`: what solves the scene.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EngineKind {
    /// tetfem's own solvers, in this process (the default).
    #[default]
    Tetfem,
    /// PETSc on every rank of `mpirun` (the `tetfem-petsc` binary, built with
    /// `cargo build --release -p tetfem-petsc --features petsc`).
    Petsc,
}

impl EngineKind {
    /// `"tetfem"` or `"petsc"`.
    pub fn name(self) -> &'static str {
        match self {
            EngineKind::Tetfem => "tetfem",
            EngineKind::Petsc => "petsc",
        }
    }
}

/// `[petsc]`: the PETSc engine's solver preset and options.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PetscSpec {
    /// `solver = "gamg" | "hypre" | "mumps"` (default `gamg`; `--solver` on the command line
    /// wins).
    #[serde(default)]
    pub solver: Option<Spanned<PetscSolver>>,
    /// `options = "-ksp_rtol 1e-10 -pc_gamg_threshold 0.05"`: PETSc options (names with their
    /// leading `-`, each followed by its value if it takes one). They win over the preset's;
    /// options given on the command line win over them.
    #[serde(default)]
    pub options: Option<Spanned<String>>,
}

/// The PETSc engine's solver presets (`[petsc] solver`).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PetscSolver {
    /// CG preconditioned by GAMG with the rigid-body near-null space (the default).
    #[default]
    Gamg,
    /// CG preconditioned by hypre's BoomerAMG.
    Hypre,
    /// MUMPS's sparse Cholesky (direct).
    Mumps,
}

impl PetscSolver {
    /// `"gamg"`, `"hypre"` or `"mumps"`: the spelling of the key and of `--solver`.
    pub fn name(self) -> &'static str {
        match self {
            PetscSolver::Gamg => "gamg",
            PetscSolver::Hypre => "hypre",
            PetscSolver::Mumps => "mumps",
        }
    }
}

/// The checked engine keys of a scene.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct EngineSettings {
    /// `engine` (default [`EngineKind::Tetfem`]).
    pub kind: EngineKind,
    /// `[petsc] solver`, if given.
    pub petsc_solver: Option<PetscSolver>,
    /// `[petsc] options` as (name, value) pairs in the scene's order; `None` for a flag.
    pub petsc_options: Vec<(String, Option<String>)>,
}

/// Splits PETSc options text into (name, value) pairs: a token starting with `-` is a name
/// unless it reads as a number (a negative value); the token after a name is its value unless
/// it is a name itself. `Err` names the first token that is neither.
pub fn parse_petsc_options(
    text: &str,
) -> std::result::Result<Vec<(String, Option<String>)>, String> {
    let is_name = |token: &str| token.starts_with('-') && token.parse::<f64>().is_err();
    let mut pairs: Vec<(String, Option<String>)> = Vec::new();
    for token in text.split_whitespace() {
        if is_name(token) {
            if token.len() < 2 {
                return Err(format!("'{token}' is not an option name"));
            }
            pairs.push((token.to_string(), None));
            continue;
        }
        match pairs.last_mut() {
            Some((_, value @ None)) => *value = Some(token.to_string()),
            Some((name, Some(_))) => {
                return Err(format!(
                    "'{token}' follows the value of {name}: every option starts with '-'"
                ));
            }
            None => return Err(format!("'{token}' comes before any option name (-name)")),
        }
    }
    Ok(pairs)
}

impl Scene {
    pub(super) fn check_engine(&self) -> Result<EngineSettings> {
        let kind = self
            .spec
            .engine
            .as_ref()
            .map(|e| *e.get_ref())
            .unwrap_or_default();
        let Some(petsc) = &self.spec.petsc else {
            return Ok(EngineSettings {
                kind,
                ..EngineSettings::default()
            });
        };
        let petsc_options = match &petsc.get_ref().options {
            Some(text) => parse_petsc_options(text.get_ref()).map_err(|why| {
                self.error(
                    "petsc.options",
                    &text.span(),
                    format!(
                        "{why}; write PETSc options as on its command line, e.g. \
                         \"-ksp_rtol 1e-10 -ksp_monitor\""
                    ),
                )
            })?,
            None => Vec::new(),
        };
        Ok(EngineSettings {
            kind,
            petsc_solver: petsc.get_ref().solver.as_ref().map(|s| *s.get_ref()),
            petsc_options,
        })
    }

    /// The engine keys (`engine`, `[petsc]`), checked.
    pub fn engine(&self) -> &EngineSettings {
        &self.engine
    }

    /// `Ok` for a scene tetfem runs itself; for `engine = "petsc"` an error naming the key and
    /// line and saying how to run it (the in-process runners call this first, so that such a
    /// scene is never solved by another engine than the one it names).
    pub fn require_tetfem_engine(&self) -> Result<()> {
        let Some(engine) = &self.spec.engine else {
            return Ok(());
        };
        if self.engine.kind == EngineKind::Tetfem {
            return Ok(());
        }
        Err(self.error(
            "engine",
            &engine.span(),
            "engine = \"petsc\": this scene runs on the PETSc engine; run it with `tetfem run \
             SCENE` (alone or under `mpirun -n N`), which hands it to tetfem-petsc, or set \
             engine = \"tetfem\"",
        ))
    }

    /// Overrides the engine (e.g. from `tetfem run --engine`).
    pub fn set_engine(&mut self, kind: EngineKind) {
        self.engine.kind = kind;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_pair_names_with_values_flags_and_negative_numbers() {
        let pairs = parse_petsc_options("-ksp_rtol 1e-10 -ksp_monitor -mat_shift -1.5").unwrap();
        let expected = [
            ("-ksp_rtol", Some("1e-10")),
            ("-ksp_monitor", None),
            ("-mat_shift", Some("-1.5")),
        ];
        assert_eq!(pairs.len(), expected.len());
        for ((name, value), (want_name, want_value)) in pairs.iter().zip(expected) {
            assert_eq!(name, want_name);
            assert_eq!(value.as_deref(), want_value);
        }
        assert!(parse_petsc_options("").unwrap().is_empty());
    }

    #[test]
    fn stray_values_are_named() {
        let why = parse_petsc_options("ksp_rtol 1e-10").unwrap_err();
        assert!(
            why.contains("'ksp_rtol' comes before any option name"),
            "{why}"
        );
        let why = parse_petsc_options("-ksp_rtol 1e-10 1e-8").unwrap_err();
        assert!(
            why.contains("'1e-8' follows the value of -ksp_rtol"),
            "{why}"
        );
    }
}
