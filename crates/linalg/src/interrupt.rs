//! A caller's "stop now?" test, polled by long computations between their iterations, so
//! that a front end can honour Ctrl-C inside one solve (a Python binding cannot otherwise see
//! the interpreter's signals while a Rust loop runs with the interpreter released).
//!
//! The test is installed for the current thread by [`with_check`] around the work; the
//! loops call [`poll`] once per iteration (conjugate gradients, tetfem's Newton and L-BFGS
//! iterations). Without an installed test, `poll` costs one thread-local read and never
//! stops anything, so the library's results and timings are unchanged for every other caller.
//! When the test says stop, `poll` returns [`Error::Stopped`] naming where it stopped; the
//! computation returns at once without writing its result (a solve's output vector, a time
//! step's state), so the caller keeps its state from before the call.
//!
//! The test is per thread: work that the loop hands to other threads (rayon's parallel
//! kernels) does not poll, and concurrent solves on other threads are unaffected.

use std::cell::RefCell;
use std::rc::Rc;

use crate::error::{Error, Result};

/// The installed test: `true` means stop.
type Check = Rc<dyn Fn() -> bool>;

thread_local! {
    /// The test of the current thread's innermost [`with_check`], if any.
    static CHECK: RefCell<Option<Check>> = const { RefCell::new(None) };
}

/// Restores the test that was installed before a [`with_check`] when it ends, also when its
/// work unwinds.
struct Restore(Option<Check>);

impl Drop for Restore {
    fn drop(&mut self) {
        let previous = self.0.take();
        CHECK.with(|slot| *slot.borrow_mut() = previous);
    }
}

/// Runs `work` with `check` installed as this thread's interrupt test: every [`poll`] inside
/// it calls `check` and stops the computation with [`Error::Stopped`] when it returns `true`.
/// `check` is called once per iteration of the polling loops (thousands of times per second
/// in a small CG solve), so an expensive test should rate-limit itself. Nested calls install
/// the inner test for their duration and then restore the outer one.
pub fn with_check<T>(check: impl Fn() -> bool + 'static, work: impl FnOnce() -> T) -> T {
    let previous = CHECK.with(|slot| slot.borrow_mut().replace(Rc::new(check)));
    let _restore = Restore(previous);
    work()
}

/// `Ok(())`, or [`Error::Stopped`] if this thread's installed test (see [`with_check`]) says
/// stop; `during` names the place (e.g. "conjugate gradient iteration 12") and is only
/// formed on a stop. Without an installed test: always `Ok(())`.
pub fn poll(during: impl FnOnce() -> String) -> Result<()> {
    match says_stop() {
        true => Err(Error::Stopped { during: during() }),
        false => Ok(()),
    }
}

/// Whether this thread has a test installed and it says stop now (the test called once).
pub(crate) fn says_stop() -> bool {
    // The test is cloned out first: it may run code (a Python signal handler) that polls or
    // installs a test itself, which must not find the slot borrowed.
    let check = CHECK.with(|slot| slot.borrow().clone());
    check.is_some_and(|check| check())
}

/// Whether this thread has a test installed ([`with_check`]).
pub(crate) fn installed() -> bool {
    CHECK.with(|slot| slot.borrow().is_some())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    #[test]
    fn poll_stops_only_inside_a_check_that_says_stop() {
        assert!(poll(|| "outside".into()).is_ok());
        let calls = Rc::new(Cell::new(0));
        let counted = Rc::clone(&calls);
        // Stops at the third poll: the first two pass.
        let results: Vec<bool> = with_check(
            move || {
                counted.set(counted.get() + 1);
                counted.get() >= 3
            },
            || {
                (0..4)
                    .map(|i| poll(|| format!("poll {i}")).is_ok())
                    .collect()
            },
        );
        assert_eq!(results, [true, true, false, false]);
        assert_eq!(calls.get(), 4);
        // Removed on return.
        assert!(poll(|| "after".into()).is_ok());
        match with_check(|| true, || poll(|| "iteration 7".into())) {
            Err(Error::Stopped { during }) => assert_eq!(during, "iteration 7"),
            other => panic!("expected Stopped, got {other:?}"),
        }
    }

    #[test]
    fn nested_checks_restore_the_outer_one() {
        let outer = with_check(
            || true,
            || {
                let inner = with_check(|| false, || poll(|| "inner".into()));
                (inner.is_ok(), poll(|| "outer".into()).is_err())
            },
        );
        assert_eq!(outer, (true, true));
    }
}
