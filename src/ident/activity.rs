//! Counters of the fitting work this process has done: model evaluations (one simulation
//! of a record) and solver iterations. Progress displays read them while a diagnosis or a
//! calibration runs; nothing reads them to decide anything, so results do not depend on
//! them (or on how many threads add to them).

use std::sync::atomic::{AtomicU64, Ordering};

static EVALUATIONS: AtomicU64 = AtomicU64::new(0);
static ITERATIONS: AtomicU64 = AtomicU64::new(0);

/// The work done so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Activity {
    /// Simulations of a record (by a fitting model or the simulator) for a fit or a scan.
    pub evaluations: u64,
    /// Iterations of the least-squares solver, over every fit.
    pub iterations: u64,
}

/// Counts one evaluation of a model over a record.
pub fn count_evaluation() {
    EVALUATIONS.fetch_add(1, Ordering::Relaxed);
}

/// Counts one solver iteration.
pub fn count_iteration() {
    ITERATIONS.fetch_add(1, Ordering::Relaxed);
}

/// The totals so far in this process.
pub fn totals() -> Activity {
    Activity {
        evaluations: EVALUATIONS.load(Ordering::Relaxed),
        iterations: ITERATIONS.load(Ordering::Relaxed),
    }
}
