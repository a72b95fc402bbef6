//! Running parallel passes on rayon's pool.

/// Runs `f` on a thread of rayon's pool. Called from outside the pool (the editor's solver
/// thread, the command line's main thread), every parallel pass inside `f` would otherwise be
/// handed to the pool and waited for by a sleeping caller, two thread switches per pass; on a
/// worker, `join` runs one half itself and the other may be taken by the second worker. This
/// matters most for small systems such as a coarse level, where a parallel pass takes tens of
/// microseconds and the caller's sleep and wake-up were a large share of it (docs/DESIGN.md,
/// "The iteration"; measured in commit 08eb979).
pub(crate) fn in_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() { f() } else { rayon::scope(|_| f()) }
}
