//! Running parallel passes on rayon's pool.

/// Runs `f` on a thread of rayon's pool. Called from outside the pool (the editor's solver
/// thread, the command line's main thread), every parallel pass inside `f` would otherwise be
/// handed to the pool and waited for by a sleeping caller, two thread switches per pass; on a
/// worker, `join` runs one half itself and the other may be taken by the second worker. On a
/// 2,000-vertex coarse level (Cheburashka's) an iteration took 0.30–0.35 ms instead of
/// 0.41–0.45, the rhs 0.026–0.035 ms instead of 0.050–0.057 (BENCHMARKS.md, "Eighth round").
pub(crate) fn in_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() { f() } else { rayon::scope(|_| f()) }
}
