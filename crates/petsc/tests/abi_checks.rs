//! build.rs's ABI checks on headers: the installed PETSc 3.18 and Open MPI pass (when present);
//! a 64-bit-index, complex, other-version PETSc or an MPICH mpi.h is rejected with a message
//! naming it. Needs no PETSc: the altered headers are written here.

mod checks {
    #![allow(dead_code)]
    include!("../abi_checks.rs");

    pub fn version(text: &str) -> Result<(), String> {
        check_version(text, "petscversion.h")
    }
    pub fn conf(text: &str) -> Result<(), String> {
        check_conf(text, "petscconf.h")
    }
    pub fn mpi(text: &str) -> Result<(String, String), String> {
        check_mpi(text, "mpi.h")
    }
}

const VERSION_3_18: &str =
    "#define PETSC_VERSION_MAJOR      3\n#define PETSC_VERSION_MINOR      18\n";
const CONF_32_REAL: &str = "#define PETSC_SIZEOF_INT 4\n#define PETSC_USE_REAL_DOUBLE 1\n";
const OPEN_MPI_4_1: &str =
    "#define OMPI_MAJOR_VERSION 4\n#define OMPI_MINOR_VERSION 1\n#define OPEN_MPI 1\n";

#[test]
fn the_pinned_abi_passes() {
    assert_eq!(checks::version(VERSION_3_18), Ok(()));
    assert_eq!(checks::conf(CONF_32_REAL), Ok(()));
    assert_eq!(
        checks::mpi(OPEN_MPI_4_1),
        Ok(("4".to_string(), "1".to_string()))
    );
}

#[test]
fn other_petsc_builds_are_named() {
    let other = checks::version(&VERSION_3_18.replace("18", "20")).expect_err("3.20");
    assert!(other.contains("PETSc 3.20") && other.contains("apt-get install -y petsc-dev"));
    let wide = checks::conf(&format!(
        "{CONF_32_REAL}#define PETSC_USE_64BIT_INDICES 1\n"
    ))
    .expect_err("64-bit indices");
    assert!(wide.contains("PETSC_USE_64BIT_INDICES") && wide.contains("32-bit PetscInt"));
    let complex =
        checks::conf(&format!("{CONF_32_REAL}#define PETSC_USE_COMPLEX 1\n")).expect_err("complex");
    assert!(complex.contains("PETSC_USE_COMPLEX"));
    let single = checks::conf("#define PETSC_USE_REAL_SINGLE 1\n").expect_err("single");
    assert!(single.contains("real double-precision"));
}

#[test]
fn mpich_is_named() {
    let mpich = checks::mpi("#define MPICH 1\n#define MPICH_VERSION \"4.0\"\n").expect_err("MPICH");
    assert!(mpich.contains("not Open MPI's mpi.h") && mpich.contains("MPICH uses integers"));
}

#[test]
fn the_installed_headers_pass_where_present() {
    // Debian's petsc-dev paths (build.rs finds them through pkg-config; these are where they
    // lie on Debian 12).
    let include = std::path::Path::new("/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real/include");
    let mpi = std::path::Path::new("/usr/lib/x86_64-linux-gnu/openmpi/include/mpi.h");
    let (Ok(conf), Ok(version), Ok(mpi)) = (
        std::fs::read_to_string(include.join("petscconf.h")),
        std::fs::read_to_string(include.join("petscversion.h")),
        std::fs::read_to_string(mpi),
    ) else {
        println!("SKIPPED: Debian's PETSc 3.18 and Open MPI headers are not installed");
        return;
    };
    assert_eq!(checks::version(&version), Ok(()));
    assert_eq!(checks::conf(&conf), Ok(()));
    assert!(checks::mpi(&mpi).is_ok());
}
