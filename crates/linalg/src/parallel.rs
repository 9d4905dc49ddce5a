//! When to leave rayon's pool alone.

/// Whether rayon's pool has one thread: a parallel loop then runs its chunks in the calling
/// thread. A parallel region entered from outside the pool hands its work to the pool's thread
/// and waits for it (two futex wake-ups, and the worker's spinning before it sleeps again):
/// tens of µs of CPU time a region, against 0.06 ms for a whole block product at 4,410 DOFs
/// (`validation/PERFORMANCE.md`, issue 39 target 1). Callers run the same chunks in the same
/// order either way, so the bits do not depend on it.
pub fn one_thread() -> bool {
    rayon::current_num_threads() == 1
}

/// Runs `work` on one of rayon's pool threads and returns its result, the calling thread
/// waiting: the parallel regions inside it are then entered from within the pool, which hands
/// a region over in a few µs, where a region entered from outside it waits for two futex
/// wake-ups (tens of µs each on this machine) every time. Where the caller has an interrupt
/// test installed ([`crate::interrupt::with_check`], e.g. a Python binding's Ctrl-C), the
/// calling thread keeps calling it every few ms while `work` runs, and `work`'s own polls see
/// its answer. `work` runs in this thread instead where the pool has one thread or this thread
/// is already one of the pool's.
pub fn in_pool<T: Send>(work: impl FnOnce() -> T + Send) -> T {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::time::Duration;
    if one_thread() || rayon::current_thread_index().is_some() {
        return work();
    }
    let forward = crate::interrupt::installed();
    let stop = std::sync::Arc::new(AtomicBool::new(false));
    let mut out = None;
    let (done, finished) = std::sync::mpsc::channel::<()>();
    rayon::in_place_scope(|scope| {
        let (asked, out) = (std::sync::Arc::clone(&stop), &mut out);
        scope.spawn(move |_| {
            let result = match forward {
                true => crate::interrupt::with_check(move || asked.load(Ordering::Relaxed), work),
                false => work(),
            };
            *out = Some(result);
            // The caller may have stopped waiting (a panic elsewhere): nothing to tell.
            let _ = done.send(());
        });
        // Without a test to call the caller waits at the scope's end; a panicking `work`
        // drops `done`, which ends the loop too.
        while forward
            && finished
                .recv_timeout(Duration::from_millis(5))
                .is_err_and(|e| e == std::sync::mpsc::RecvTimeoutError::Timeout)
        {
            if crate::interrupt::says_stop() {
                stop.store(true, Ordering::Relaxed);
            }
        }
    });
    match out {
        Some(result) => result,
        // Unreachable: the scope re-raises a panic of `work` before this.
        None => unreachable!("the pool's work returned no result"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;
    use crate::interrupt::{poll, with_check};
    use std::time::{Duration, Instant};

    /// The work runs on a pool thread where the pool has two or more (in this thread
    /// otherwise), its value comes back, and a caller's interrupt test stops it from there: the
    /// test says stop after 50 ms, and the work, polling in a loop, sees it (well within the
    /// 10 s it would otherwise run).
    #[test]
    fn work_in_the_pool_returns_its_value_and_hears_the_callers_interrupt() {
        let pooled = rayon::current_num_threads() >= 2;
        let here = std::thread::current().id();
        let (value, thread) = in_pool(|| (6 * 7, std::thread::current().id()));
        assert_eq!(value, 42);
        assert_eq!(thread != here, pooled);
        let start = Instant::now();
        let stopped = with_check(
            move || start.elapsed() > Duration::from_millis(50),
            || {
                in_pool(|| -> crate::error::Result<()> {
                    while start.elapsed() < Duration::from_secs(10) {
                        poll(|| "the test's loop".into())?;
                        std::thread::sleep(Duration::from_millis(1));
                    }
                    Ok(())
                })
            },
        );
        assert!(matches!(stopped, Err(Error::Stopped { .. })), "{stopped:?}");
        assert!(start.elapsed() < Duration::from_secs(5));
    }
}
