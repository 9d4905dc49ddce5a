//! Finds the system PETSc and its MPI when the `petsc` feature is on, checks that they have the
//! ABI the hand-written declarations of `src/ffi.rs` are pinned to, and links them.
//!
//! Where PETSc is looked for, in order: `PETSC_DIR` (with `PETSC_ARCH` if set: the headers in
//! `$PETSC_DIR/include` and `$PETSC_DIR/$PETSC_ARCH/include`, the library in
//! `$PETSC_DIR/$PETSC_ARCH/lib`), then pkg-config's `PETSc` (Debian's `petsc-dev` installs
//! `PETSc.pc`). MPI's `mpi.h`: `MPI_INCLUDE_DIR` if set, else pkg-config's `mpi`, else `ompi`.
//!
//! Checked, each a build error naming what was found and what is needed:
//! - PETSc 3.18 (`petscversion.h`): the declarations follow 3.18's headers;
//! - 32-bit `PetscInt` (no `PETSC_USE_64BIT_INDICES` in `petscconf.h`): `PetscInt` is `i32`;
//! - real double scalars (`PETSC_USE_REAL_DOUBLE`, no `PETSC_USE_COMPLEX`): `PetscScalar` is `f64`;
//! - Open MPI (`#define OPEN_MPI 1` in `mpi.h`): `MPI_Comm` and the predefined datatypes and
//!   operations are pointers to Open MPI's globals (under MPICH they are integers).

use std::path::{Path, PathBuf};
use std::process::Command;

// The ABI checks, shared with tests/abi_checks.rs.
include!("abi_checks.rs");

struct Found {
    include_dirs: Vec<PathBuf>,
    lib_dirs: Vec<PathBuf>,
    libs: Vec<String>,
    source: String,
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    for var in [
        "PETSC_DIR",
        "PETSC_ARCH",
        "MPI_INCLUDE_DIR",
        "PKG_CONFIG_PATH",
    ] {
        println!("cargo:rerun-if-env-changed={var}");
    }
    if std::env::var_os("CARGO_FEATURE_PETSC").is_none() {
        return;
    }
    if let Err(message) = configure() {
        // Cargo prints a failed build script's stderr: this line is the build error.
        eprintln!("error: tetfem-petsc (feature `petsc`): {message}");
        std::process::exit(1);
    }
}

fn configure() -> Result<(), String> {
    let petsc = find_petsc()?;
    let conf = find_header(&petsc.include_dirs, "petscconf.h").ok_or_else(|| {
        format!(
            "petscconf.h not found in {:?} (PETSc from {}); {INSTALL_HINT}",
            petsc.include_dirs, petsc.source
        )
    })?;
    let conf_text = read(&conf)?;
    let version = find_header(&petsc.include_dirs, "petscversion.h")
        .ok_or_else(|| format!("petscversion.h not found in {:?}", petsc.include_dirs))?;
    let version_text = read(&version)?;
    check_version(&version_text, &version.display().to_string())?;
    check_conf(&conf_text, &conf.display().to_string())?;
    let mpi_dirs = mpi_include_dirs(&petsc.include_dirs);
    let mpi_h = find_header(&mpi_dirs, "mpi.h").ok_or_else(|| {
        format!(
            "mpi.h not found in {mpi_dirs:?} (set MPI_INCLUDE_DIR, or install libopenmpi-dev); {INSTALL_HINT}"
        )
    })?;
    let mpi_text = read(&mpi_h)?;
    let (ompi_major, ompi_minor) = check_mpi(&mpi_text, &mpi_h.display().to_string())?;

    for dir in &petsc.lib_dirs {
        println!("cargo:rustc-link-search=native={}", dir.display());
        // The binary and the tests find the library where it was linked, also outside the
        // loader's default path (a PETSC_DIR build).
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", dir.display());
    }
    for lib in &petsc.libs {
        println!("cargo:rustc-link-lib=dylib={lib}");
    }
    // MPI_Comm_rank, MPI_Allreduce and Open MPI's predefined globals are called directly.
    for dir in pkg_config(&["--libs-only-L", "mpi"]).unwrap_or_default() {
        if let Some(dir) = dir.strip_prefix("-L") {
            println!("cargo:rustc-link-search=native={dir}");
        }
    }
    println!("cargo:rustc-link-lib=dylib=mpi");
    println!("cargo:rerun-if-changed={}", conf.display());
    println!("cargo:rerun-if-changed={}", mpi_h.display());
    println!(
        "cargo:rustc-env=TETFEM_PETSC_BUILT_AGAINST=PETSc 3.18 ({}; 32-bit PetscInt, real f64) with Open MPI {ompi_major}.{ompi_minor} ({})",
        petsc.source,
        mpi_h.display()
    );
    Ok(())
}

fn find_petsc() -> Result<Found, String> {
    if let Some(dir) = std::env::var_os("PETSC_DIR").map(PathBuf::from) {
        let arch = std::env::var_os("PETSC_ARCH").map(PathBuf::from);
        let mut include_dirs = vec![dir.join("include")];
        let mut lib_dirs = vec![dir.join("lib")];
        if let Some(arch) = &arch {
            include_dirs.insert(0, dir.join(arch).join("include"));
            lib_dirs.insert(0, dir.join(arch).join("lib"));
        }
        let lib = ["petsc", "petsc_real"]
            .into_iter()
            .find(|name| {
                lib_dirs
                    .iter()
                    .any(|d| d.join(format!("lib{name}.so")).exists())
            })
            .ok_or_else(|| {
                format!(
                    "PETSC_DIR={} (PETSC_ARCH={:?}) has no libpetsc.so or libpetsc_real.so in {lib_dirs:?}; {INSTALL_HINT}",
                    dir.display(),
                    arch
                )
            })?;
        return Ok(Found {
            include_dirs,
            lib_dirs,
            libs: vec![lib.to_string()],
            source: format!("PETSC_DIR={}", dir.display()),
        });
    }
    let cflags = pkg_config(&["--cflags-only-I", "PETSc"]).map_err(|e| {
        format!("PETSc not found: PETSC_DIR is not set and pkg-config cannot find `PETSc` ({e}); {INSTALL_HINT}")
    })?;
    let libs = pkg_config(&["--libs", "PETSc"])?;
    Ok(Found {
        include_dirs: cflags
            .iter()
            .filter_map(|f| f.strip_prefix("-I").map(PathBuf::from))
            .collect(),
        lib_dirs: libs
            .iter()
            .filter_map(|f| f.strip_prefix("-L").map(PathBuf::from))
            .collect(),
        libs: libs
            .iter()
            .filter_map(|f| f.strip_prefix("-l").map(str::to_string))
            .collect(),
        source: "pkg-config PETSc".to_string(),
    })
}

/// Where mpi.h may be: `MPI_INCLUDE_DIR`, pkg-config's `mpi` or `ompi`, and PETSc's own folders.
fn mpi_include_dirs(petsc_dirs: &[PathBuf]) -> Vec<PathBuf> {
    let mut dirs = Vec::new();
    if let Some(dir) = std::env::var_os("MPI_INCLUDE_DIR") {
        dirs.push(PathBuf::from(dir));
    }
    for package in ["mpi", "ompi"] {
        if let Ok(flags) = pkg_config(&["--cflags-only-I", package]) {
            dirs.extend(
                flags
                    .iter()
                    .filter_map(|f| f.strip_prefix("-I").map(PathBuf::from)),
            );
        }
    }
    dirs.extend(petsc_dirs.iter().cloned());
    dirs
}

fn pkg_config(args: &[&str]) -> Result<Vec<String>, String> {
    let output = Command::new("pkg-config")
        .args(args)
        .output()
        .map_err(|e| format!("pkg-config could not be run: {e}"))?;
    if !output.status.success() {
        return Err(format!(
            "`pkg-config {}` failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&output.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&output.stdout)
        .split_whitespace()
        .map(str::to_string)
        .collect())
}

fn find_header(dirs: &[PathBuf], name: &str) -> Option<PathBuf> {
    dirs.iter().map(|d| d.join(name)).find(|p| p.is_file())
}

fn read(path: &Path) -> Result<String, String> {
    std::fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))
}
