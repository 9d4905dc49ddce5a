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
