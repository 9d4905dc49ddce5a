// The ABI checks of build.rs on the text of PETSc's and MPI's headers, kept apart so that
// tests/abi_checks.rs runs them on real and altered headers. Each returns the build error's
// message: what was found and what the hand-written FFI (src/ffi.rs) needs.

/// How to get a PETSc the FFI fits.
const INSTALL_HINT: &str = "install Debian's PETSc with `apt-get update && apt-get install -y petsc-dev` \
     (it brings Open MPI), or set PETSC_DIR (and PETSC_ARCH) to a PETSc 3.18 build with 32-bit \
     indices, real double scalars and Open MPI; or build without the `petsc` feature";

/// petscversion.h (at `path`) must say 3.18: the declarations follow 3.18's headers.
fn check_version(text: &str, path: &str) -> Result<(), String> {
    let major = define_value(text, "PETSC_VERSION_MAJOR");
    let minor = define_value(text, "PETSC_VERSION_MINOR");
    if major.as_deref() != Some("3") || minor.as_deref() != Some("18") {
        return Err(format!(
            "PETSc {}.{} found ({path}), but the FFI declarations are pinned to PETSc 3.18; {INSTALL_HINT}",
            major.unwrap_or_default(),
            minor.unwrap_or_default(),
        ));
    }
    Ok(())
}

/// petscconf.h (at `path`) must give 32-bit PetscInt and real double scalars.
fn check_conf(text: &str, path: &str) -> Result<(), String> {
    if defined(text, "PETSC_USE_64BIT_INDICES") {
        return Err(format!(
            "{path} defines PETSC_USE_64BIT_INDICES (64-bit PetscInt), but the FFI declarations are \
             pinned to 32-bit PetscInt (i32); use a PETSc built without --with-64-bit-indices \
             (Debian: petsc-dev, not petsc64-dev)"
        ));
    }
    if !defined(text, "PETSC_USE_REAL_DOUBLE") || defined(text, "PETSC_USE_COMPLEX") {
        return Err(format!(
            "{path} is not a real double-precision PETSc (PetscScalar must be f64: \
             PETSC_USE_REAL_DOUBLE and no PETSC_USE_COMPLEX); Debian: petsc-dev, not the complex \
             variant"
        ));
    }
    Ok(())
}

/// mpi.h (at `path`) must be Open MPI's; returns its major and minor version.
fn check_mpi(text: &str, path: &str) -> Result<(String, String), String> {
    if define_value(text, "OPEN_MPI").as_deref() != Some("1") {
        return Err(format!(
            "{path} is not Open MPI's mpi.h (no `#define OPEN_MPI 1`): the FFI declarations take \
             MPI_Comm, MPI_Datatype and MPI_Op as Open MPI's pointers (MPICH uses integers); \
             build PETSc with Open MPI"
        ));
    }
    Ok((
        define_value(text, "OMPI_MAJOR_VERSION").unwrap_or_default(),
        define_value(text, "OMPI_MINOR_VERSION").unwrap_or_default(),
    ))
}

/// The value of `#define NAME VALUE` (first token), if defined.
fn define_value(text: &str, name: &str) -> Option<String> {
    text.lines().find_map(|line| {
        let mut tokens = line.split_whitespace();
        (tokens.next() == Some("#define") && tokens.next() == Some(name))
            .then(|| tokens.next().unwrap_or("").to_string())
    })
}

fn defined(text: &str, name: &str) -> bool {
    define_value(text, name).is_some()
}
