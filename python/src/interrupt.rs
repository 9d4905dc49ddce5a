//! Ctrl-C (SIGINT, Jupyter's "interrupt kernel") inside long calls. Python runs its signal
//! handlers only between bytecodes of the main thread; while the main thread is inside Rust
//! with the GIL released, a signal only sets a flag. So the long loops poll the library's
//! interrupt test ([`tetfem::linalg::interrupt`]: each conjugate-gradient, Newton and L-BFGS
//! iteration), and the test installed here takes the GIL at most every [`CHECK_INTERVAL`] to
//! run Python's handlers ([`Python::check_signals`]); the exception a handler raises
//! (`KeyboardInterrupt`) stops the computation and is raised by the call, the caller's state
//! left as before the interrupted solve or step.

use std::cell::Cell;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use pyo3::prelude::*;

use crate::errors::library_error;

/// Time between two checks of Python's signal flags inside a computation: Ctrl-C is honoured
/// within this and one iteration. Each check takes the GIL, which can wait for another Python
/// thread up to its switch interval (5 ms by default): at 50 ms that costs at most 10 % when
/// other threads run Python meanwhile, nothing measurable when none do.
const CHECK_INTERVAL: Duration = Duration::from_millis(50);

/// Whether the calling thread is Python's main thread, the only one where signal handlers
/// run (elsewhere a check could never see one, and is not installed).
fn on_main_thread(py: Python<'_>) -> PyResult<bool> {
    let threading = py.import("threading")?;
    let main = threading.call_method0("main_thread")?;
    let current = threading.call_method0("current_thread")?;
    Ok(main.is(&current))
}

/// The exception a Python signal handler raised during a check, kept for the caller.
type Pending = Arc<Mutex<Option<PyErr>>>;

/// Runs `work` with the GIL released and Ctrl-C honoured inside it (see the module's doc):
/// its value; or the exception a signal handler raised while it ran (`KeyboardInterrupt`),
/// also when `work` finished regardless; or `work`'s error as its Python exception.
pub fn detach_interruptible<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    F: Send + FnOnce() -> tetfem::Result<T>,
    T: Send,
{
    let main = on_main_thread(py)?;
    let pending: Pending = Arc::new(Mutex::new(None));
    let stash = Arc::clone(&pending);
    let result = py.detach(move || {
        if !main {
            return work();
        }
        let last = Cell::new(Instant::now());
        tetfem::linalg::interrupt::with_check(move || signalled(&last, &stash), work)
    });
    let raised = pending
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .take();
    match (raised, result) {
        (Some(error), _) => Err(error),
        (None, Ok(value)) => Ok(value),
        (None, Err(error)) => Err(library_error(py, error)),
    }
}

/// The interrupt test: every [`CHECK_INTERVAL`], runs Python's signal handlers; `true` (stop)
/// when one raised, its exception kept in `pending`.
fn signalled(last: &Cell<Instant>, pending: &Pending) -> bool {
    if last.get().elapsed() < CHECK_INTERVAL {
        return false;
    }
    last.set(Instant::now());
    Python::attach(|py| match py.check_signals() {
        Ok(()) => false,
        Err(error) => {
            *pending.lock().unwrap_or_else(PoisonError::into_inner) = Some(error);
            true
        }
    })
}
