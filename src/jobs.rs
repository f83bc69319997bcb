//! Worker threads of the commands that fit (diagnose, calibrate): their parallel work
//! (candidate effects, Jacobian columns) runs on a pool of a chosen size.

/// The worker threads could not be started (the system refused them).
#[derive(Debug, thiserror::Error)]
#[error("cannot start the worker threads: {0}")]
pub struct WorkersError(#[from] rayon::ThreadPoolBuildError);

/// Runs `work` on a pool of `jobs` worker threads (0: one per core). Parallel results are
/// collected in a fixed order, so what `work` returns does not depend on the count.
pub(crate) fn with_jobs<R: Send>(
    jobs: usize,
    work: impl FnOnce() -> R + Send,
) -> Result<R, WorkersError> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(jobs).build()?;
    Ok(pool.install(work))
}
