//! Counters of the fitting work this process has done: model evaluations (one simulation
//! of a record) and solver iterations. Progress displays read them while a diagnosis or a
//! calibration runs; nothing reads them to decide anything, so results do not depend on
//! them (or on how many threads add to them).

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Instant;

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

/// A fit under way, as a display sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunningFit {
    /// Time since it started, s.
    pub elapsed_s: f64,
    /// Iterations done.
    pub done: u64,
    /// The most it may take.
    pub max: u64,
}

impl RunningFit {
    /// The time its remaining iterations would take at its pace so far, s (`None` before
    /// its first iteration ends). An estimate: a fit stops early once it converges, and
    /// its later iterations may cost more than its first.
    pub fn most_left_s(&self) -> Option<f64> {
        (self.done > 0)
            .then(|| self.max.saturating_sub(self.done) as f64 * self.elapsed_s / self.done as f64)
    }
}

static NEXT_FIT: AtomicU64 = AtomicU64::new(0);
static RUNNING: Mutex<BTreeMap<u64, (Instant, u64, u64)>> = Mutex::new(BTreeMap::new());

/// A fit registered while it runs (several may run at once on worker threads): its
/// iterations are counted through it, and it leaves the register when dropped.
pub struct FitUnderWay {
    id: u64,
}

/// Registers a fit of at most `max_iterations` iterations.
pub fn begin_fit(max_iterations: usize) -> FitUnderWay {
    let id = NEXT_FIT.fetch_add(1, Ordering::Relaxed);
    if let Ok(mut r) = RUNNING.lock() {
        r.insert(id, (Instant::now(), 0, max_iterations as u64));
    }
    FitUnderWay { id }
}

impl FitUnderWay {
    /// Counts one iteration of this fit (and in the process's totals).
    pub fn iteration(&self) {
        count_iteration();
        if let Ok(mut r) = RUNNING.lock() {
            if let Some(f) = r.get_mut(&self.id) {
                f.1 += 1;
            }
        }
    }
}

impl Drop for FitUnderWay {
    fn drop(&mut self) {
        if let Ok(mut r) = RUNNING.lock() {
            r.remove(&self.id);
        }
    }
}

/// The fits under way now.
pub fn running_fits() -> Vec<RunningFit> {
    RUNNING
        .lock()
        .map(|r| {
            r.values()
                .map(|(start, done, max)| RunningFit {
                    elapsed_s: start.elapsed().as_secs_f64(),
                    done: *done,
                    max: *max,
                })
                .collect()
        })
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fit_is_registered_while_it_runs_and_its_time_left_follows_its_pace() {
        let f = RunningFit {
            elapsed_s: 10.0,
            done: 4,
            max: 30,
        };
        // 2.5 s an iteration, 26 left.
        assert_eq!(f.most_left_s(), Some(65.0));
        assert_eq!(RunningFit { done: 0, ..f }.most_left_s(), None);
        // A budget no other fit of the tests has, to tell this one apart.
        let fit = begin_fit(7919);
        fit.iteration();
        let now = running_fits();
        assert!(now.iter().any(|r| r.max == 7919 && r.done == 1), "{now:?}");
        drop(fit);
        assert!(!running_fits().iter().any(|r| r.max == 7919));
    }
}
