//! Handing a scene to the PETSc engine: `tetfem run SCENE` with `engine = "petsc"` in the scene
//! (or `--engine petsc`), and `tetfem export --petsc SCENE DIR`, run the `tetfem-petsc` binary
//! on the same scene in their place.
//!
//! Why a hand-off and not a call: `tetfem-petsc` links PETSc and MPI (a system library behind a
//! cargo feature) and reads scenes through this crate, so this crate cannot link it back. Under
//! `mpirun -n N tetfem run SCENE` every rank's `tetfem` process replaces itself by
//! `tetfem-petsc` (on Unix, `exec`: same process, same MPI environment, same signals), which
//! then initializes MPI; so the command line users type is the same for both engines.

use std::path::{Path, PathBuf};
use std::process::Command;

use tetfem::base::error::{Error, Result};

/// The environment variable that names the `tetfem-petsc` binary to use (default: the one
/// beside the running `tetfem`, else the first on `PATH`).
pub const PETSC_BINARY_VARIABLE: &str = "TETFEM_PETSC_BINARY";

/// How to get the binary, for error messages.
pub const PETSC_BUILD_HINT: &str = "build it with `cargo build --release -p tetfem-petsc \
    --features petsc` (it needs PETSc 3.18 and Open MPI: `apt-get install petsc-dev`), which \
    puts it beside `tetfem` in target/release";

/// What `tetfem run` passes on to the engine.
#[derive(Debug, Clone, Default)]
pub struct PetscHandoff {
    /// The scene file, as given.
    pub scene: PathBuf,
    /// `--out`.
    pub out: Option<PathBuf>,
    /// `--json`.
    pub json: bool,
    /// `--quiet`.
    pub quiet: bool,
    /// `--vtu-format` (`"binary"` or `"ascii"`).
    pub vtu_format: Option<&'static str>,
    /// `--petsc-options`, split into words: PETSc options passed last, so that they win.
    pub petsc_options: Vec<String>,
    /// `tetfem export --petsc SCENE DIR`: write the static system into DIR instead of solving.
    pub export: Option<PathBuf>,
}

impl PetscHandoff {
    /// The `tetfem-petsc` command for this run: the binary found by [`petsc_binary`] with the
    /// scene and the options it shares with `tetfem run`.
    pub fn command(&self) -> Result<Command> {
        let mut command = Command::new(petsc_binary()?);
        command.arg(&self.scene);
        if let Some(out) = &self.out {
            command.arg("--out").arg(out);
        }
        if let Some(directory) = &self.export {
            command.arg("--export").arg(directory);
        }
        if self.json {
            command.arg("--json");
        }
        if self.quiet {
            command.arg("--quiet");
        }
        if let Some(format) = self.vtu_format {
            command.args(["--vtu-format", format]);
        }
        command.args(&self.petsc_options);
        Ok(command)
    }

    /// Runs the engine in place of this process (Unix: `exec`, which returns only on failure);
    /// elsewhere as a child, whose failure becomes an error.
    pub fn run(&self) -> Result<()> {
        let mut command = self.command()?;
        let program = PathBuf::from(command.get_program());
        #[cfg(unix)]
        {
            use std::os::unix::process::CommandExt;
            let source = command.exec();
            Err(Error::Io {
                path: program,
                source,
            })
        }
        #[cfg(not(unix))]
        {
            let status = command.status().map_err(|source| Error::Io {
                path: program.clone(),
                source,
            })?;
            if status.success() {
                Ok(())
            } else {
                Err(Error::invalid_parameter(
                    program.display(),
                    status,
                    "the PETSc engine failed (its messages are above)",
                ))
            }
        }
    }
}

/// The `tetfem-petsc` binary: [`PETSC_BINARY_VARIABLE`] if set (it must exist), else the file
/// beside the running executable, else the first on `PATH`; an error saying how to build it
/// otherwise.
pub fn petsc_binary() -> Result<PathBuf> {
    const NAME: &str = "tetfem-petsc";
    if let Some(path) = std::env::var_os(PETSC_BINARY_VARIABLE) {
        let path = PathBuf::from(path);
        return if path.is_file() {
            Ok(path)
        } else {
            Err(Error::invalid_parameter(
                PETSC_BINARY_VARIABLE,
                path.display(),
                "must name the tetfem-petsc binary (no such file)",
            ))
        };
    }
    let beside = std::env::current_exe()
        .ok()
        .and_then(|exe| exe.parent().map(|dir| dir.join(NAME)))
        .filter(|p| p.is_file());
    let on_path = || {
        std::env::var_os("PATH").and_then(|paths| {
            std::env::split_paths(&paths)
                .map(|dir| dir.join(NAME))
                .find(|p| p.is_file())
        })
    };
    beside.or_else(on_path).ok_or_else(|| {
        Error::invalid_parameter(
            "engine",
            "petsc",
            format!(
                "needs the {NAME} binary beside {} or on PATH: {PETSC_BUILD_HINT}",
                std::env::current_exe()
                    .ok()
                    .as_deref()
                    .and_then(Path::parent)
                    .map_or_else(|| "tetfem".to_string(), |d| d.display().to_string())
            ),
        )
    })
}
