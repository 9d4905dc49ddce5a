//! The hand-written PETSc and MPI declarations and their safe wrappers: the crate's only FFI.
//!
//! Pinned to the ABI `build.rs` checks: PETSc 3.18 (`PetscInt` = i32, `PetscScalar` =
//! `PetscReal` = f64, `PetscErrorCode` = i32, `PetscBool` and the enums C `int`s) built with
//! Open MPI 4 (`MPI_Comm`, `MPI_Datatype` and `MPI_Op` are pointers; the predefined datatypes
//! and operations are the addresses of Open MPI's globals `ompi_mpi_double`, `ompi_mpi_op_sum`,
//! ...). The signatures and enum values are those of 3.18's `petscmat.h`, `petscvec.h`,
//! `petscksp.h` and `petscsystypes.h` and Open MPI 4.1's `mpi.h`.
//!
//! Every PETSc object is wrapped in a struct that destroys it on drop and borrows the [`Petsc`]
//! session, so that none outlives `PetscFinalize`. Every non-zero `PetscErrorCode` becomes an
//! [`Error::Petsc`] naming the function.

use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::marker::PhantomData;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::{Error, Result};

type PetscInt = i32;
type PetscErrorCode = c_int;
type PetscBool = c_int;
type MpiComm = *mut c_void;

macro_rules! opaque {
    ($($name:ident),*) => {$(
        #[repr(C)]
        struct $name {
            _private: [u8; 0],
        }
    )*};
}
opaque!(
    PMat, PVec, PKsp, PPc, PNullSpace, PScatter, POptions, PIs, PViewer
);

/// `InsertMode` of petscsystypes.h 3.18.
const INSERT_VALUES: c_int = 1;
const ADD_VALUES: c_int = 2;
/// `MatAssemblyType`.
const MAT_FINAL_ASSEMBLY: c_int = 0;
/// `ScatterMode`.
const SCATTER_FORWARD: c_int = 0;
/// `NormType`.
const NORM_2: c_int = 1;
/// `MatDuplicateOption`.
const MAT_COPY_VALUES: c_int = 1;
/// `PetscFileMode`.
const FILE_MODE_WRITE: c_int = 1;
/// `PetscCopyMode`.
const PETSC_COPY_VALUES: c_int = 0;
/// The longest error message one rank shares with the others in [`Petsc::agree`] (bytes).
const MESSAGE_BYTES: usize = 1024;

/// The `MatOption`s the engine sets (values of petscmat.h 3.18).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(i32)]
pub enum MatOption {
    /// The matrix is symmetric.
    Symmetric = 1,
    /// The symmetry stays through later changes of values.
    SymmetryEternal = 10,
    /// Symmetric positive definite.
    Spd = 15,
    /// Inserting outside the preallocation is an error (catches a wrong preallocation).
    NewNonzeroAllocationErr = 19,
}

// libmpi is linked by build.rs.
unsafe extern "C" {
    /// MPI_COMM_SELF (= PETSC_COMM_SELF) is the address of this global.
    static ompi_mpi_comm_self: u8;
    static ompi_mpi_double: u8;
    static ompi_mpi_unsigned_long: u8;
    static ompi_mpi_op_sum: u8;
    static ompi_mpi_op_max: u8;
    static ompi_mpi_op_min: u8;
    fn MPI_Comm_rank(comm: MpiComm, rank: *mut c_int) -> c_int;
    fn MPI_Comm_size(comm: MpiComm, size: *mut c_int) -> c_int;
    fn MPI_Allreduce(
        send: *const c_void,
        recv: *mut c_void,
        count: c_int,
        datatype: *const c_void,
        op: *const c_void,
        comm: MpiComm,
    ) -> c_int;
}

// The PETSc library is linked by build.rs (its name differs between builds: petsc_real on
// Debian, petsc from a PETSC_DIR build).
unsafe extern "C" {
    static PETSC_COMM_WORLD: MpiComm;
    fn PetscInitialize(
        argc: *mut c_int,
        args: *mut *mut *mut c_char,
        file: *const c_char,
        help: *const c_char,
    ) -> PetscErrorCode;
    fn PetscFinalize() -> PetscErrorCode;
    fn PetscErrorMessage(
        code: c_int,
        text: *mut *const c_char,
        specific: *mut *mut c_char,
    ) -> PetscErrorCode;
    fn PetscGetVersion(version: *mut c_char, len: usize) -> PetscErrorCode;
    fn PetscOptionsSetValue(
        options: *mut POptions,
        name: *const c_char,
        value: *const c_char,
    ) -> PetscErrorCode;
    fn PetscOptionsHasName(
        options: *mut POptions,
        prefix: *const c_char,
        name: *const c_char,
        set: *mut PetscBool,
    ) -> PetscErrorCode;

    fn MatCreate(comm: MpiComm, mat: *mut *mut PMat) -> PetscErrorCode;
    fn MatSetSizes(
        mat: *mut PMat,
        m: PetscInt,
        n: PetscInt,
        big_m: PetscInt,
        big_n: PetscInt,
    ) -> PetscErrorCode;
    fn MatSetBlockSize(mat: *mut PMat, bs: PetscInt) -> PetscErrorCode;
    fn MatSetType(mat: *mut PMat, kind: *const c_char) -> PetscErrorCode;
    fn MatMPIAIJSetPreallocation(
        mat: *mut PMat,
        d_nz: PetscInt,
        d_nnz: *const PetscInt,
        o_nz: PetscInt,
        o_nnz: *const PetscInt,
    ) -> PetscErrorCode;
    fn MatSetOption(mat: *mut PMat, option: c_int, flag: PetscBool) -> PetscErrorCode;
    fn MatSetValues(
        mat: *mut PMat,
        m: PetscInt,
        rows: *const PetscInt,
        n: PetscInt,
        cols: *const PetscInt,
        values: *const f64,
        mode: c_int,
    ) -> PetscErrorCode;
    fn MatAssemblyBegin(mat: *mut PMat, kind: c_int) -> PetscErrorCode;
    fn MatAssemblyEnd(mat: *mut PMat, kind: c_int) -> PetscErrorCode;
    fn MatZeroRowsColumns(
        mat: *mut PMat,
        count: PetscInt,
        rows: *const PetscInt,
        diag: f64,
        x: *mut PVec,
        b: *mut PVec,
    ) -> PetscErrorCode;
    fn MatGetDiagonal(mat: *mut PMat, diagonal: *mut PVec) -> PetscErrorCode;
    fn MatCreateVecs(mat: *mut PMat, right: *mut *mut PVec, left: *mut *mut PVec)
    -> PetscErrorCode;
    fn MatMult(mat: *mut PMat, x: *mut PVec, y: *mut PVec) -> PetscErrorCode;
    fn MatDuplicate(mat: *mut PMat, option: c_int, out: *mut *mut PMat) -> PetscErrorCode;
    fn MatScale(mat: *mut PMat, alpha: f64) -> PetscErrorCode;
    fn MatDiagonalSet(mat: *mut PMat, diagonal: *mut PVec, mode: c_int) -> PetscErrorCode;
    fn MatSetNearNullSpace(mat: *mut PMat, space: *mut PNullSpace) -> PetscErrorCode;
    fn MatDestroy(mat: *mut *mut PMat) -> PetscErrorCode;
    fn MatNullSpaceCreateRigidBody(
        coords: *mut PVec,
        space: *mut *mut PNullSpace,
    ) -> PetscErrorCode;
    fn MatNullSpaceDestroy(space: *mut *mut PNullSpace) -> PetscErrorCode;

    fn VecSetValues(
        vec: *mut PVec,
        n: PetscInt,
        idx: *const PetscInt,
        values: *const f64,
        mode: c_int,
    ) -> PetscErrorCode;
    fn VecAssemblyBegin(vec: *mut PVec) -> PetscErrorCode;
    fn VecAssemblyEnd(vec: *mut PVec) -> PetscErrorCode;
    fn VecGetLocalSize(vec: *mut PVec, n: *mut PetscInt) -> PetscErrorCode;
    fn VecGetArrayRead(vec: *mut PVec, array: *mut *const f64) -> PetscErrorCode;
    fn VecRestoreArrayRead(vec: *mut PVec, array: *mut *const f64) -> PetscErrorCode;
    fn VecDuplicate(vec: *mut PVec, out: *mut *mut PVec) -> PetscErrorCode;
    fn VecSum(vec: *mut PVec, sum: *mut f64) -> PetscErrorCode;
    fn VecAXPY(y: *mut PVec, alpha: f64, x: *mut PVec) -> PetscErrorCode;
    fn VecWAXPY(w: *mut PVec, alpha: f64, x: *mut PVec, y: *mut PVec) -> PetscErrorCode;
    fn VecPointwiseMult(w: *mut PVec, x: *mut PVec, y: *mut PVec) -> PetscErrorCode;
    fn VecScale(x: *mut PVec, alpha: f64) -> PetscErrorCode;
    fn VecSet(x: *mut PVec, alpha: f64) -> PetscErrorCode;
    fn VecNorm(vec: *mut PVec, kind: c_int, norm: *mut f64) -> PetscErrorCode;
    fn VecDestroy(vec: *mut *mut PVec) -> PetscErrorCode;
    fn VecScatterCreateToZero(
        vec: *mut PVec,
        scatter: *mut *mut PScatter,
        out: *mut *mut PVec,
    ) -> PetscErrorCode;
    fn VecScatterBegin(
        scatter: *mut PScatter,
        x: *mut PVec,
        y: *mut PVec,
        mode: c_int,
        direction: c_int,
    ) -> PetscErrorCode;
    fn VecScatterEnd(
        scatter: *mut PScatter,
        x: *mut PVec,
        y: *mut PVec,
        mode: c_int,
        direction: c_int,
    ) -> PetscErrorCode;
    fn VecScatterDestroy(scatter: *mut *mut PScatter) -> PetscErrorCode;
    fn VecScatterCreate(
        x: *mut PVec,
        ix: *mut PIs,
        y: *mut PVec,
        iy: *mut PIs,
        scatter: *mut *mut PScatter,
    ) -> PetscErrorCode;
    fn VecCreateSeq(comm: MpiComm, n: PetscInt, vec: *mut *mut PVec) -> PetscErrorCode;
    fn ISCreateGeneral(
        comm: MpiComm,
        n: PetscInt,
        idx: *const PetscInt,
        mode: c_int,
        is: *mut *mut PIs,
    ) -> PetscErrorCode;
    fn ISDestroy(is: *mut *mut PIs) -> PetscErrorCode;

    fn PetscViewerBinaryOpen(
        comm: MpiComm,
        name: *const c_char,
        mode: c_int,
        viewer: *mut *mut PViewer,
    ) -> PetscErrorCode;
    fn PetscViewerDestroy(viewer: *mut *mut PViewer) -> PetscErrorCode;
    fn MatView(mat: *mut PMat, viewer: *mut PViewer) -> PetscErrorCode;
    fn VecView(vec: *mut PVec, viewer: *mut PViewer) -> PetscErrorCode;

    fn KSPCreate(comm: MpiComm, ksp: *mut *mut PKsp) -> PetscErrorCode;
    fn KSPSetOperators(ksp: *mut PKsp, a: *mut PMat, p: *mut PMat) -> PetscErrorCode;
    fn KSPSetFromOptions(ksp: *mut PKsp) -> PetscErrorCode;
    fn KSPSetUp(ksp: *mut PKsp) -> PetscErrorCode;
    fn KSPSolve(ksp: *mut PKsp, b: *mut PVec, x: *mut PVec) -> PetscErrorCode;
    fn KSPGetIterationNumber(ksp: *mut PKsp, its: *mut PetscInt) -> PetscErrorCode;
    fn KSPGetConvergedReason(ksp: *mut PKsp, reason: *mut c_int) -> PetscErrorCode;
    fn KSPGetResidualNorm(ksp: *mut PKsp, norm: *mut f64) -> PetscErrorCode;
    fn KSPGetType(ksp: *mut PKsp, kind: *mut *const c_char) -> PetscErrorCode;
    fn KSPGetPC(ksp: *mut PKsp, pc: *mut *mut PPc) -> PetscErrorCode;
    fn PCGetType(pc: *mut PPc, kind: *mut *const c_char) -> PetscErrorCode;
    fn KSPDestroy(ksp: *mut *mut PKsp) -> PetscErrorCode;
}

/// `Ok` for 0, else [`Error::Petsc`] with PETSc's text for the code.
fn check(function: &'static str, code: PetscErrorCode) -> Result<()> {
    if code == 0 {
        return Ok(());
    }
    let mut text: *const c_char = std::ptr::null();
    // SAFETY: PetscErrorMessage writes a pointer to a static string (or leaves it null) into
    // `text`; a null `specific` asks for no second string.
    let found = unsafe { PetscErrorMessage(code, &mut text, std::ptr::null_mut()) };
    let message = if found == 0 && !text.is_null() {
        // SAFETY: a non-null `text` is a NUL-terminated static string owned by PETSc.
        unsafe { CStr::from_ptr(text) }
            .to_string_lossy()
            .into_owned()
    } else {
        "no message".to_string()
    };
    Err(Error::Petsc {
        function,
        code,
        message,
    })
}

fn check_mpi(function: &'static str, code: c_int) -> Result<()> {
    if code == 0 {
        Ok(())
    } else {
        Err(Error::Mpi { function, code })
    }
}

/// A count or index as `PetscInt`, or an error naming it.
pub fn petsc_int(what: &str, value: usize) -> Result<i32> {
    i32::try_from(value).map_err(|_| {
        Error::invalid(
            what,
            value,
            "must fit PETSc's 32-bit PetscInt (at most 2147483647); a 64-bit-index PETSc is not supported by this build",
        )
    })
}

fn c_string(what: &str, text: &str) -> Result<CString> {
    CString::new(text).map_err(|_| Error::invalid(what, text, "must not contain a NUL byte"))
}

static INITIALIZED: AtomicBool = AtomicBool::new(false);

/// A PETSc (and MPI) session: `PetscInitialize` on creation, `PetscFinalize` on drop. One per
/// process; every PETSc object borrows it.
#[derive(Debug)]
pub struct Petsc {
    comm: MpiComm,
    rank: usize,
    size: usize,
    // PETSc keeps pointers into argv: the strings live as long as the session.
    _args: Vec<CString>,
    _argv: Vec<*mut c_char>,
}

impl Petsc {
    /// Initializes PETSc and MPI with `args` (the program name first, then PETSc options such as
    /// `-ksp_monitor`, which enter PETSc's options database). A second session in one process
    /// is an error.
    pub fn initialize(args: &[String]) -> Result<Self> {
        if INITIALIZED.swap(true, Ordering::SeqCst) {
            return Err(Error::invalid(
                "PETSc sessions in this process",
                2,
                "only one may be opened (PETSc cannot be initialized again after PetscFinalize)",
            ));
        }
        let args: Vec<CString> = args
            .iter()
            .map(|a| c_string("command-line argument", a))
            .collect::<Result<_>>()?;
        let mut argv: Vec<*mut c_char> = args.iter().map(|a| a.as_ptr().cast_mut()).collect();
        argv.push(std::ptr::null_mut());
        let mut argc = petsc_int("argument count", args.len())?;
        let mut argv_ptr = argv.as_mut_ptr();
        // SAFETY: argc/argv describe `args.len()` NUL-terminated strings followed by a null
        // pointer, all owned by the returned session (PETSc may keep pointers to them); PETSc
        // may rewrite argc and argv_ptr (its own copies). Null file and help are allowed.
        check("PetscInitialize", unsafe {
            PetscInitialize(&mut argc, &mut argv_ptr, std::ptr::null(), std::ptr::null())
        })?;
        // SAFETY: PETSC_COMM_WORLD is set by PetscInitialize and not changed afterwards.
        let comm = unsafe { PETSC_COMM_WORLD };
        let (mut rank, mut size) = (0, 0);
        // SAFETY: comm is a valid communicator after PetscInitialize; the outputs are locals.
        check_mpi("MPI_Comm_rank", unsafe { MPI_Comm_rank(comm, &mut rank) })?;
        // SAFETY: as above.
        check_mpi("MPI_Comm_size", unsafe { MPI_Comm_size(comm, &mut size) })?;
        Ok(Petsc {
            comm,
            rank: rank.max(0) as usize,
            size: size.max(1) as usize,
            _args: args,
            _argv: argv,
        })
    }

    /// This process's rank in PETSC_COMM_WORLD.
    pub fn rank(&self) -> usize {
        self.rank
    }

    /// The number of ranks.
    pub fn size(&self) -> usize {
        self.size
    }

    /// PETSc's version string.
    pub fn version(&self) -> Result<String> {
        let mut buffer = [0 as c_char; 256];
        // SAFETY: the buffer holds `len` bytes; PETSc writes a NUL-terminated string into it.
        check("PetscGetVersion", unsafe {
            PetscGetVersion(buffer.as_mut_ptr(), buffer.len())
        })?;
        // SAFETY: NUL-terminated by PetscGetVersion within the buffer.
        Ok(unsafe { CStr::from_ptr(buffer.as_ptr()) }
            .to_string_lossy()
            .into_owned())
    }

    /// Whether option `name` (e.g. `-pc_type`) is in the options database.
    pub fn has_option(&self, name: &str) -> Result<bool> {
        let name = c_string("PETSc option name", name)?;
        let mut set: PetscBool = 0;
        // SAFETY: null options = the global database, null prefix; name is NUL-terminated.
        check("PetscOptionsHasName", unsafe {
            PetscOptionsHasName(
                std::ptr::null_mut(),
                std::ptr::null(),
                name.as_ptr(),
                &mut set,
            )
        })?;
        Ok(set != 0)
    }

    /// Sets option `name` to `value` unless the command line set it already; returns whether it
    /// was set here.
    pub fn set_default_option(&self, name: &str, value: &str) -> Result<bool> {
        self.set_default_option_or_flag(name, Some(value))
    }

    /// As [`set_default_option`](Self::set_default_option), with `None` for an option that
    /// takes no value (a flag such as `-ksp_monitor`).
    pub fn set_default_option_or_flag(&self, name: &str, value: Option<&str>) -> Result<bool> {
        if self.has_option(name)? {
            return Ok(false);
        }
        let name = c_string("PETSc option name", name)?;
        let value = value
            .map(|v| c_string("PETSc option value", v))
            .transpose()?;
        // SAFETY: null options = the global database; the strings are NUL-terminated (PETSc
        // copies them) and a null value is PETSc's "no value".
        check("PetscOptionsSetValue", unsafe {
            PetscOptionsSetValue(
                std::ptr::null_mut(),
                name.as_ptr(),
                value.as_ref().map_or(std::ptr::null(), |v| v.as_ptr()),
            )
        })?;
        Ok(true)
    }

    /// `result` on every rank if it is `Ok` on every rank; otherwise this rank's own error, or
    /// [`Error::OtherRanksFailed`] (carrying the failed ranks' messages) on the ranks that
    /// succeeded. Collective: what makes a failure of one rank (before a collective call) an
    /// error on all instead of a hang.
    pub fn agree<T>(&self, result: Result<T>) -> Result<T> {
        let own = result.as_ref().err().map(ToString::to_string);
        let messages = self.share_messages(own.as_deref())?;
        let failed: Vec<(usize, String)> = messages
            .into_iter()
            .enumerate()
            .filter_map(|(rank, message)| message.map(|m| (rank, m)))
            .collect();
        match result {
            Err(e) => Err(e),
            Ok(_) if !failed.is_empty() => Err(Error::OtherRanksFailed {
                ranks: failed.iter().map(|(rank, _)| *rank).collect(),
                messages: failed.into_iter().map(|(_, m)| m).collect(),
            }),
            Ok(value) => Ok(value),
        }
    }

    /// Every rank's `message` (`None` where a rank has none), on every rank. Each rank's
    /// message travels in its own slot of [`MESSAGE_BYTES`] bytes, one byte per `u64`, so
    /// an element-wise maximum over the ranks is a gather; a longer message is cut at a
    /// character boundary. The culprit's words then reach the ranks that stop with it: under
    /// mpirun the first rank to exit with an error ends the job, and a failed rank's own
    /// line on stderr may be lost with it.
    fn share_messages(&self, message: Option<&str>) -> Result<Vec<Option<String>>> {
        // Slot layout: byte 0 says whether the rank failed (1) or not (0), then the text.
        let mut slots = vec![0u64; self.size * (MESSAGE_BYTES + 1)];
        if let Some(text) = message {
            let slot = &mut slots[self.rank * (MESSAGE_BYTES + 1)..][..MESSAGE_BYTES + 1];
            slot[0] = 1;
            let mut end = text.len().min(MESSAGE_BYTES);
            while !text.is_char_boundary(end) {
                end -= 1;
            }
            for (cell, byte) in slot[1..].iter_mut().zip(text[..end].bytes()) {
                *cell = u64::from(byte);
            }
        }
        self.max_u64(&mut slots)?;
        Ok(slots
            .chunks(MESSAGE_BYTES + 1)
            .map(|slot| {
                (slot[0] == 1).then(|| {
                    let bytes: Vec<u8> = slot[1..]
                        .iter()
                        .take_while(|&&b| b != 0)
                        .map(|&b| b as u8)
                        .collect();
                    String::from_utf8_lossy(&bytes).into_owned()
                })
            })
            .collect())
    }

    /// Element-wise sum of `values` over all ranks (in place).
    pub fn sum(&self, values: &mut [f64]) -> Result<()> {
        // The addresses of Open MPI's predefined globals are its MPI_SUM / MPI_DOUBLE (taking
        // an extern static's address reads nothing, so it needs no unsafe).
        let (op, kind) = (
            (&raw const ompi_mpi_op_sum).cast(),
            (&raw const ompi_mpi_double).cast(),
        );
        self.allreduce(values, kind, op, "MPI_Allreduce(MPI_SUM)")
    }

    /// Element-wise maximum of `values` over all ranks (in place).
    pub fn max(&self, values: &mut [f64]) -> Result<()> {
        // As in `sum`: MPI_MAX / MPI_DOUBLE.
        let (op, kind) = (
            (&raw const ompi_mpi_op_max).cast(),
            (&raw const ompi_mpi_double).cast(),
        );
        self.allreduce(values, kind, op, "MPI_Allreduce(MPI_MAX)")
    }

    /// Element-wise maximum of `values` over all ranks (in place).
    fn max_u64(&self, values: &mut [u64]) -> Result<()> {
        // MPI_MAX / MPI_UNSIGNED_LONG (u64 on the 64-bit Linux this targets).
        let (op, kind) = (
            (&raw const ompi_mpi_op_max).cast(),
            (&raw const ompi_mpi_unsigned_long).cast(),
        );
        self.allreduce(values, kind, op, "MPI_Allreduce(MPI_MAX)")
    }

    /// The least and the greatest of `value` over all ranks.
    pub fn min_max_u64(&self, value: u64) -> Result<(u64, u64)> {
        let mut low = [value];
        let mut high = [value];
        // MPI_MIN / MPI_MAX / MPI_UNSIGNED_LONG (u64 on the 64-bit Linux this targets).
        let (min, max, kind) = (
            (&raw const ompi_mpi_op_min).cast(),
            (&raw const ompi_mpi_op_max).cast(),
            (&raw const ompi_mpi_unsigned_long).cast(),
        );
        self.allreduce(&mut low, kind, min, "MPI_Allreduce(MPI_MIN)")?;
        self.allreduce(&mut high, kind, max, "MPI_Allreduce(MPI_MAX)")?;
        Ok((low[0], high[0]))
    }

    fn allreduce<T: Copy>(
        &self,
        values: &mut [T],
        kind: *const c_void,
        op: *const c_void,
        function: &'static str,
    ) -> Result<()> {
        let send = values.to_vec();
        let count = petsc_int("reduced values", values.len())?;
        // SAFETY: send and values both hold `count` elements of the datatype `kind` describes
        // (f64 for MPI_DOUBLE, u64 for MPI_UNSIGNED_LONG); distinct buffers; valid comm.
        check_mpi(function, unsafe {
            MPI_Allreduce(
                send.as_ptr().cast(),
                values.as_mut_ptr().cast(),
                count,
                kind,
                op,
                self.comm,
            )
        })
    }
}

impl Drop for Petsc {
    fn drop(&mut self) {
        // SAFETY: every PETSc object borrows this session, so all are destroyed by now.
        // A failing finalize cannot be reported from drop; PETSc prints its own message.
        let _ = unsafe { PetscFinalize() };
    }
}

/// Runs `view` with a binary viewer writing `path` (PETSc's binary format, and PETSc's
/// `<path>.info` beside it); collective.
fn with_binary_viewer(
    petsc: &Petsc,
    path: &std::path::Path,
    view: impl FnOnce(*mut PViewer) -> Result<()>,
) -> Result<()> {
    let name = c_string("file name", &path.to_string_lossy())?;
    let mut viewer = std::ptr::null_mut();
    // SAFETY: a valid communicator and NUL-terminated name; PETSc writes a new viewer handle,
    // destroyed below on every path.
    check("PetscViewerBinaryOpen", unsafe {
        PetscViewerBinaryOpen(petsc.comm, name.as_ptr(), FILE_MODE_WRITE, &mut viewer)
    })?;
    let viewed = view(viewer);
    // SAFETY: the live viewer created above, not used after.
    let destroyed = check("PetscViewerDestroy", unsafe {
        PetscViewerDestroy(&mut viewer)
    });
    viewed.and(destroyed)
}

/// A distributed PETSc matrix (`Mat`).
#[derive(Debug)]
pub struct Matrix<'p> {
    raw: *mut PMat,
    _session: PhantomData<&'p Petsc>,
}

impl<'p> Matrix<'p> {
    /// An MPIAIJ matrix of `global` rows and columns with block size `block`, this rank owning
    /// `diagonal.len()` of them, preallocated with `diagonal` / `off_diagonal` non-zeros per
    /// owned row; inserting outside the preallocation is an error.
    pub fn mpiaij(
        petsc: &'p Petsc,
        global: usize,
        block: usize,
        diagonal: &[i32],
        off_diagonal: &[i32],
    ) -> Result<Self> {
        if diagonal.len() != off_diagonal.len() {
            return Err(Error::invalid(
                "off-diagonal preallocation rows",
                off_diagonal.len(),
                format!("must equal the diagonal ones ({})", diagonal.len()),
            ));
        }
        let local = petsc_int("owned rows", diagonal.len())?;
        let global = petsc_int("global rows", global)?;
        let block = petsc_int("block size", block)?;
        let mut raw = std::ptr::null_mut();
        // SAFETY: a valid communicator; PETSc writes the new handle into `raw`.
        check("MatCreate", unsafe { MatCreate(petsc.comm, &mut raw) })?;
        let matrix = Matrix {
            raw,
            _session: PhantomData,
        };
        // SAFETY (this block): `raw` is a live Mat; the type name is a static C string; the
        // preallocation arrays hold one entry per owned row, as MatSetSizes declared.
        unsafe {
            check(
                "MatSetSizes",
                MatSetSizes(raw, local, local, global, global),
            )?;
            check("MatSetBlockSize", MatSetBlockSize(raw, block))?;
            check("MatSetType", MatSetType(raw, c"mpiaij".as_ptr()))?;
            check(
                "MatMPIAIJSetPreallocation",
                MatMPIAIJSetPreallocation(raw, 0, diagonal.as_ptr(), 0, off_diagonal.as_ptr()),
            )?;
        }
        let mut matrix = matrix;
        matrix.set_option(MatOption::NewNonzeroAllocationErr, true)?;
        Ok(matrix)
    }

    /// Sets a `MatOption`.
    pub fn set_option(&mut self, option: MatOption, value: bool) -> Result<()> {
        // SAFETY: live Mat; option is a valid MatOption value of 3.18.
        check("MatSetOption", unsafe {
            MatSetOption(self.raw, option as c_int, c_int::from(value))
        })
    }

    /// Adds the dense square block `values` (row-major, `indices.len()`² entries) at the global
    /// rows and columns `indices` (rows of other ranks are sent to them at assembly).
    pub fn add_block(&mut self, indices: &[i32], values: &[f64]) -> Result<()> {
        if values.len() != indices.len() * indices.len() {
            return Err(Error::invalid(
                "block values",
                values.len(),
                format!("must be {}² = {}", indices.len(), indices.len().pow(2)),
            ));
        }
        let n = petsc_int("block size", indices.len())?;
        // SAFETY: indices has n entries and values n² (checked), read-only for PETSc.
        check("MatSetValues", unsafe {
            MatSetValues(
                self.raw,
                n,
                indices.as_ptr(),
                n,
                indices.as_ptr(),
                values.as_ptr(),
                ADD_VALUES,
            )
        })
    }

    /// Final assembly (collective): off-rank entries are communicated.
    pub fn assemble(&mut self) -> Result<()> {
        // SAFETY: live Mat.
        unsafe {
            check(
                "MatAssemblyBegin",
                MatAssemblyBegin(self.raw, MAT_FINAL_ASSEMBLY),
            )?;
            check(
                "MatAssemblyEnd",
                MatAssemblyEnd(self.raw, MAT_FINAL_ASSEMBLY),
            )
        }
    }

    /// Two vectors with this matrix's row layout (and block size), zero.
    pub fn vectors(&self) -> Result<(Vector<'p>, Vector<'p>)> {
        let (mut right, mut left) = (std::ptr::null_mut(), std::ptr::null_mut());
        // SAFETY: live, assembled-layout Mat; PETSc writes two new Vec handles.
        check("MatCreateVecs", unsafe {
            MatCreateVecs(self.raw, &mut right, &mut left)
        })?;
        Ok((Vector::from_raw(right), Vector::from_raw(left)))
    }

    /// The diagonal into `out` (collective).
    pub fn diagonal(&self, out: &mut Vector<'p>) -> Result<()> {
        // SAFETY: live Mat and Vec of matching layout.
        check("MatGetDiagonal", unsafe {
            MatGetDiagonal(self.raw, out.raw)
        })
    }

    /// y = A·x (collective).
    pub fn mult(&self, x: &Vector<'p>, y: &mut Vector<'p>) -> Result<()> {
        // SAFETY: live Mat and distinct Vecs of matching layout.
        check("MatMult", unsafe { MatMult(self.raw, x.raw, y.raw) })
    }

    /// Writes the matrix to `path` in PETSc's binary format (collective; what `MatLoad` reads).
    pub fn write_binary(&self, petsc: &Petsc, path: &std::path::Path) -> Result<()> {
        // SAFETY: live Mat and viewer.
        with_binary_viewer(petsc, path, |viewer| {
            check("MatView", unsafe { MatView(self.raw, viewer) })
        })
    }

    /// A copy of this matrix (pattern and values).
    pub fn duplicate(&self) -> Result<Matrix<'p>> {
        let mut raw = std::ptr::null_mut();
        // SAFETY: live, assembled Mat; PETSc writes a new handle.
        check("MatDuplicate", unsafe {
            MatDuplicate(self.raw, MAT_COPY_VALUES, &mut raw)
        })?;
        Ok(Matrix {
            raw,
            _session: PhantomData,
        })
    }

    /// A ← alpha·A (collective).
    pub fn scale(&mut self, alpha: f64) -> Result<()> {
        // SAFETY: live Mat.
        check("MatScale", unsafe { MatScale(self.raw, alpha) })
    }

    /// Adds `diagonal` to the diagonal (collective; the diagonal is in the pattern).
    pub fn add_diagonal(&mut self, diagonal: &Vector<'p>) -> Result<()> {
        // SAFETY: live Mat and a Vec of its row layout.
        check("MatDiagonalSet", unsafe {
            MatDiagonalSet(self.raw, diagonal.raw, ADD_VALUES)
        })
    }

    /// Zeroes the rows and columns `rows` (global, owned by this rank), puts `diagonal` on their
    /// diagonal, sets `b[rows] = diagonal·x[rows]` and subtracts the zeroed columns times `x[rows]`
    /// from the other rows of b (collective): the prescribed values `x` enter the right-hand
    /// side, and the matrix stays symmetric.
    pub fn zero_rows_columns(
        &mut self,
        rows: &[i32],
        diagonal: f64,
        x: &Vector<'p>,
        b: &mut Vector<'p>,
    ) -> Result<()> {
        let n = petsc_int("constrained rows", rows.len())?;
        // SAFETY: rows has n entries; x and b are live Vecs of the matrix's layout; PETSc only
        // reads x.
        check("MatZeroRowsColumns", unsafe {
            MatZeroRowsColumns(self.raw, n, rows.as_ptr(), diagonal, x.raw, b.raw)
        })
    }

    /// Attaches the six rigid-body modes of the node coordinates `coordinates` (block size 3,
    /// this matrix's layout) as the near-null space that GAMG builds its coarse spaces from.
    pub fn set_rigid_body_near_null_space(&mut self, coordinates: &Vector<'p>) -> Result<()> {
        let mut space = std::ptr::null_mut();
        // SAFETY: a live coordinates Vec; PETSc writes a new MatNullSpace handle, which the
        // matrix references (MatSetNearNullSpace takes a reference), so destroying ours after
        // is PETSc's documented pattern.
        unsafe {
            check(
                "MatNullSpaceCreateRigidBody",
                MatNullSpaceCreateRigidBody(coordinates.raw, &mut space),
            )?;
            let attached = check("MatSetNearNullSpace", MatSetNearNullSpace(self.raw, space));
            let destroyed = check("MatNullSpaceDestroy", MatNullSpaceDestroy(&mut space));
            attached.and(destroyed)
        }
    }
}

impl Drop for Matrix<'_> {
    fn drop(&mut self) {
        // SAFETY: the handle is live (or null, which PETSc accepts) and not used after.
        let _ = unsafe { MatDestroy(&mut self.raw) };
    }
}

/// A distributed PETSc vector (`Vec`).
#[derive(Debug)]
pub struct Vector<'p> {
    raw: *mut PVec,
    _session: PhantomData<&'p Petsc>,
}

impl<'p> Vector<'p> {
    fn from_raw(raw: *mut PVec) -> Self {
        Vector {
            raw,
            _session: PhantomData,
        }
    }

    /// A new vector of the same layout (values unset until written).
    pub fn duplicate(&self) -> Result<Vector<'p>> {
        let mut raw = std::ptr::null_mut();
        // SAFETY: live Vec; PETSc writes a new handle.
        check("VecDuplicate", unsafe { VecDuplicate(self.raw, &mut raw) })?;
        Ok(Vector::from_raw(raw))
    }

    /// Sets entries `indices` (global) to `values`, then assembles (collective).
    pub fn set_and_assemble(&mut self, indices: &[i32], values: &[f64]) -> Result<()> {
        if indices.len() != values.len() {
            return Err(Error::invalid(
                "vector values",
                values.len(),
                format!("must be one per index ({})", indices.len()),
            ));
        }
        let n = petsc_int("vector entries", indices.len())?;
        // SAFETY: both arrays hold n entries; live Vec.
        unsafe {
            check(
                "VecSetValues",
                VecSetValues(
                    self.raw,
                    n,
                    indices.as_ptr(),
                    values.as_ptr(),
                    INSERT_VALUES,
                ),
            )?;
            check("VecAssemblyBegin", VecAssemblyBegin(self.raw))?;
            check("VecAssemblyEnd", VecAssemblyEnd(self.raw))
        }
    }

    /// A copy of this rank's entries.
    pub fn local_values(&self) -> Result<Vec<f64>> {
        let mut n: PetscInt = 0;
        let mut array: *const f64 = std::ptr::null();
        // SAFETY: live Vec; VecGetArrayRead gives a pointer to its `n` local entries, valid
        // until VecRestoreArrayRead, which is called on every path after the copy.
        unsafe {
            check("VecGetLocalSize", VecGetLocalSize(self.raw, &mut n))?;
            check("VecGetArrayRead", VecGetArrayRead(self.raw, &mut array))?;
            let values = if n > 0 && !array.is_null() {
                std::slice::from_raw_parts(array, n as usize).to_vec()
            } else {
                Vec::new()
            };
            check(
                "VecRestoreArrayRead",
                VecRestoreArrayRead(self.raw, &mut array),
            )?;
            Ok(values)
        }
    }

    /// The sum of all entries (collective).
    pub fn sum(&self) -> Result<f64> {
        let mut sum = 0.0;
        // SAFETY: live Vec.
        check("VecSum", unsafe { VecSum(self.raw, &mut sum) })?;
        Ok(sum)
    }

    /// The 2-norm (collective).
    pub fn norm(&self) -> Result<f64> {
        let mut norm = 0.0;
        // SAFETY: live Vec.
        check("VecNorm", unsafe { VecNorm(self.raw, NORM_2, &mut norm) })?;
        Ok(norm)
    }

    /// Writes the vector to `path` in PETSc's binary format (collective; what `VecLoad` reads).
    pub fn write_binary(&self, petsc: &Petsc, path: &std::path::Path) -> Result<()> {
        // SAFETY: live Vec and viewer.
        with_binary_viewer(petsc, path, |viewer| {
            check("VecView", unsafe { VecView(self.raw, viewer) })
        })
    }

    /// self ← alpha·x + y (collective; self distinct from x and y).
    pub fn waxpy(&mut self, alpha: f64, x: &Vector<'p>, y: &Vector<'p>) -> Result<()> {
        // SAFETY: live Vecs of one layout, the output distinct from the inputs.
        check("VecWAXPY", unsafe {
            VecWAXPY(self.raw, alpha, x.raw, y.raw)
        })
    }

    /// self ← x ∘ y, entry by entry (self distinct from x and y).
    pub fn pointwise_mult(&mut self, x: &Vector<'p>, y: &Vector<'p>) -> Result<()> {
        // SAFETY: live Vecs of one layout.
        check("VecPointwiseMult", unsafe {
            VecPointwiseMult(self.raw, x.raw, y.raw)
        })
    }

    /// self ← alpha·self.
    pub fn scale(&mut self, alpha: f64) -> Result<()> {
        // SAFETY: live Vec.
        check("VecScale", unsafe { VecScale(self.raw, alpha) })
    }

    /// Every entry ← alpha.
    pub fn fill(&mut self, alpha: f64) -> Result<()> {
        // SAFETY: live Vec.
        check("VecSet", unsafe { VecSet(self.raw, alpha) })
    }

    /// Adds `values` at global `indices` (any rank's; sent at assembly), then assembles
    /// (collective).
    pub fn add_and_assemble(&mut self, indices: &[i32], values: &[f64]) -> Result<()> {
        if indices.len() != values.len() {
            return Err(Error::invalid(
                "vector values",
                values.len(),
                format!("must be one per index ({})", indices.len()),
            ));
        }
        let n = petsc_int("vector entries", indices.len())?;
        // SAFETY: both arrays hold n entries; live Vec.
        unsafe {
            check(
                "VecSetValues",
                VecSetValues(self.raw, n, indices.as_ptr(), values.as_ptr(), ADD_VALUES),
            )?;
            check("VecAssemblyBegin", VecAssemblyBegin(self.raw))?;
            check("VecAssemblyEnd", VecAssemblyEnd(self.raw))
        }
    }

    /// self ← self + alpha·x (collective).
    pub fn axpy(&mut self, alpha: f64, x: &Vector<'p>) -> Result<()> {
        // SAFETY: live, distinct Vecs of one layout.
        check("VecAXPY", unsafe { VecAXPY(self.raw, alpha, x.raw) })
    }

    /// Every entry, in global order, on rank 0 (`None` on the other ranks); collective.
    pub fn gather_to_zero(&self, petsc: &Petsc) -> Result<Option<Vec<f64>>> {
        let mut scatter = std::ptr::null_mut();
        let mut all = std::ptr::null_mut();
        // SAFETY: live Vec; PETSc writes a scatter and a sequential Vec (full length on rank 0,
        // empty elsewhere), both destroyed below on every path.
        unsafe {
            check(
                "VecScatterCreateToZero",
                VecScatterCreateToZero(self.raw, &mut scatter, &mut all),
            )?;
            let all = Vector::from_raw(all);
            let moved = check(
                "VecScatterBegin",
                VecScatterBegin(scatter, self.raw, all.raw, INSERT_VALUES, SCATTER_FORWARD),
            )
            .and_then(|()| {
                check(
                    "VecScatterEnd",
                    VecScatterEnd(scatter, self.raw, all.raw, INSERT_VALUES, SCATTER_FORWARD),
                )
            });
            let destroyed = check("VecScatterDestroy", VecScatterDestroy(&mut scatter));
            moved.and(destroyed)?;
            let values = all.local_values()?;
            Ok((petsc.rank() == 0).then_some(values))
        }
    }
}

impl<'p> Vector<'p> {
    /// The entries at global `indices` (any rank's), on this rank; collective (every rank
    /// calls it, each with its own indices).
    pub fn entries(&self, indices: &[i32]) -> Result<Vec<f64>> {
        let n = petsc_int("gathered entries", indices.len())?;
        let self_comm: MpiComm = (&raw const ompi_mpi_comm_self).cast_mut().cast();
        let mut is = std::ptr::null_mut();
        let mut local = std::ptr::null_mut();
        let mut scatter = std::ptr::null_mut();
        // SAFETY: indices holds n entries (copied by PETSc: PETSC_COPY_VALUES); self_comm is
        // Open MPI's MPI_COMM_SELF; every handle created here is destroyed before returning
        // (the Vector wrapper destroys `local`; IS and scatter explicitly, on every path).
        unsafe {
            check(
                "ISCreateGeneral",
                ISCreateGeneral(self_comm, n, indices.as_ptr(), PETSC_COPY_VALUES, &mut is),
            )?;
            let created = check("VecCreateSeq", VecCreateSeq(self_comm, n, &mut local));
            let local = Vector::from_raw(local);
            let moved = created
                .and_then(|()| {
                    check(
                        "VecScatterCreate",
                        VecScatterCreate(
                            self.raw,
                            is,
                            local.raw,
                            std::ptr::null_mut(),
                            &mut scatter,
                        ),
                    )
                })
                .and_then(|()| {
                    check(
                        "VecScatterBegin",
                        VecScatterBegin(
                            scatter,
                            self.raw,
                            local.raw,
                            INSERT_VALUES,
                            SCATTER_FORWARD,
                        ),
                    )
                })
                .and_then(|()| {
                    check(
                        "VecScatterEnd",
                        VecScatterEnd(scatter, self.raw, local.raw, INSERT_VALUES, SCATTER_FORWARD),
                    )
                });
            let scatter_destroyed = check("VecScatterDestroy", VecScatterDestroy(&mut scatter));
            let is_destroyed = check("ISDestroy", ISDestroy(&mut is));
            moved.and(scatter_destroyed).and(is_destroyed)?;
            local.local_values()
        }
    }
}

impl Drop for Vector<'_> {
    fn drop(&mut self) {
        // SAFETY: live (or null) handle, not used after.
        let _ = unsafe { VecDestroy(&mut self.raw) };
    }
}

/// A PETSc Krylov solver (`KSP`) with its preconditioner, configured from the options database.
#[derive(Debug)]
pub struct Krylov<'p> {
    raw: *mut PKsp,
    _session: PhantomData<&'p Petsc>,
}

impl<'p> Krylov<'p> {
    /// A solver for `matrix` (operator and preconditioning matrix), with the options database
    /// applied (`KSPSetFromOptions`: `-ksp_type`, `-pc_type`, ...).
    pub fn new(petsc: &'p Petsc, matrix: &Matrix<'p>) -> Result<Self> {
        let mut raw = std::ptr::null_mut();
        // SAFETY: valid communicator; PETSc writes a new handle.
        check("KSPCreate", unsafe { KSPCreate(petsc.comm, &mut raw) })?;
        let ksp = Krylov {
            raw,
            _session: PhantomData,
        };
        // SAFETY: live KSP and Mat (the KSP takes its own reference to the Mat).
        unsafe {
            check(
                "KSPSetOperators",
                KSPSetOperators(raw, matrix.raw, matrix.raw),
            )?;
            check("KSPSetFromOptions", KSPSetFromOptions(raw))?;
        }
        Ok(ksp)
    }

    /// Builds the preconditioner (GAMG's hierarchy, hypre's, MUMPS's factor): collective.
    pub fn set_up(&mut self) -> Result<()> {
        // SAFETY: live KSP with operators set.
        check("KSPSetUp", unsafe { KSPSetUp(self.raw) })
    }

    /// Solves A·x = b (collective); the outcome is read with [`outcome`](Self::outcome).
    pub fn solve(&mut self, b: &Vector<'p>, x: &mut Vector<'p>) -> Result<()> {
        // SAFETY: live KSP and distinct Vecs of the operator's layout.
        check("KSPSolve", unsafe { KSPSolve(self.raw, b.raw, x.raw) })
    }

    /// Iterations, the `KSPConvergedReason` value and the last residual norm of the last solve.
    pub fn outcome(&self) -> Result<(i32, i32, f64)> {
        let (mut its, mut reason, mut norm) = (0, 0, 0.0);
        // SAFETY: live KSP; outputs are locals.
        unsafe {
            check(
                "KSPGetIterationNumber",
                KSPGetIterationNumber(self.raw, &mut its),
            )?;
            check(
                "KSPGetConvergedReason",
                KSPGetConvergedReason(self.raw, &mut reason),
            )?;
            check(
                "KSPGetResidualNorm",
                KSPGetResidualNorm(self.raw, &mut norm),
            )?;
        }
        Ok((its, reason, norm))
    }

    /// The Krylov method's and the preconditioner's type names (`cg`, `gamg`, ...).
    pub fn types(&self) -> Result<(String, String)> {
        let mut ksp_type: *const c_char = std::ptr::null();
        let mut pc: *mut PPc = std::ptr::null_mut();
        let mut pc_type: *const c_char = std::ptr::null();
        // SAFETY: live KSP; the type names are static strings owned by PETSc (or null before
        // set-up, handled below); the PC is borrowed, not owned.
        unsafe {
            check("KSPGetType", KSPGetType(self.raw, &mut ksp_type))?;
            check("KSPGetPC", KSPGetPC(self.raw, &mut pc))?;
            check("PCGetType", PCGetType(pc, &mut pc_type))?;
            let name = |p: *const c_char| {
                if p.is_null() {
                    "unset".to_string()
                } else {
                    CStr::from_ptr(p).to_string_lossy().into_owned()
                }
            };
            Ok((name(ksp_type), name(pc_type)))
        }
    }
}

impl Drop for Krylov<'_> {
    fn drop(&mut self) {
        // SAFETY: live (or null) handle, not used after.
        let _ = unsafe { KSPDestroy(&mut self.raw) };
    }
}

/// PETSc's name of a `KSPConvergedReason` value (petscksp.h 3.18).
pub fn reason_name(reason: i32) -> &'static str {
    match reason {
        1 => "KSP_CONVERGED_RTOL_NORMAL",
        9 => "KSP_CONVERGED_ATOL_NORMAL",
        2 => "KSP_CONVERGED_RTOL",
        3 => "KSP_CONVERGED_ATOL",
        4 => "KSP_CONVERGED_ITS",
        5 => "KSP_CONVERGED_CG_NEG_CURVE",
        6 => "KSP_CONVERGED_CG_CONSTRAINED",
        7 => "KSP_CONVERGED_STEP_LENGTH",
        8 => "KSP_CONVERGED_HAPPY_BREAKDOWN",
        0 => "KSP_CONVERGED_ITERATING",
        -2 => "KSP_DIVERGED_NULL",
        -3 => "KSP_DIVERGED_ITS",
        -4 => "KSP_DIVERGED_DTOL",
        -5 => "KSP_DIVERGED_BREAKDOWN",
        -6 => "KSP_DIVERGED_BREAKDOWN_BICG",
        -7 => "KSP_DIVERGED_NONSYMMETRIC",
        -8 => "KSP_DIVERGED_INDEFINITE_PC",
        -9 => "KSP_DIVERGED_NANORINF",
        -10 => "KSP_DIVERGED_INDEFINITE_MAT",
        -11 => "KSP_DIVERGED_PC_FAILED",
        _ => "unknown KSPConvergedReason",
    }
}
