//! Parameter sweeps: a scene run over the full grid of `--vary KEY=VALUES` (times
//! `--repeat` noise seeds), in parallel, into one `results.csv` of run metrics.
//!
//! Runs are numbered in grid order (the first `--vary` slowest, the repeat fastest); every
//! run is a pure function of the scene text, its overrides and its seed, so the results do
//! not depend on the number of jobs or the order they finish in. `--shard I/N` runs the
//! I-th of N contiguous slices of that numbering, and [`merge`](merge::merge) joins the
//! shards' folders back into the unsharded result, byte for byte.

mod grid;
mod journal;
pub mod merge;
mod plots;
pub mod results;
pub mod run;
mod runner;

pub use grid::{
    check_size, parse_shard, parse_vary, Grid, RunPoint, Shard, Vary, DEFAULT_MAX_RUNS,
};
pub use merge::merge;
pub use results::{Manifest, MERGE_NOTE};
pub use run::{summarise, RunResult, SweepOptions, Trace};
pub use runner::{previous_outputs, run_sweep, SweepOutput};

use std::path::PathBuf;

/// Errors of a sweep.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// A `--vary` or `--shard` argument that cannot be read.
    #[error("{arg}: {message}")]
    Argument {
        /// The argument.
        arg: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// The scene, or a varied value, does not load.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// A scene whose parameters the simulator refuses (checked before a study's runs).
    #[error(transparent)]
    Sim(#[from] crate::sim::SimError),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A results or manifest file that is not what a sweep writes.
    #[error("{path}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is not as a sweep writes it.
        message: String,
    },
    /// Shard folders that do not belong together or do not cover the sweep.
    #[error("cannot merge: {0}")]
    Merge(String),
    /// Stopped on request (a signal): the finished runs are kept for `--resume`.
    #[error("interrupted: {done} of {total} runs finished, kept in {partial}; run the same command with --resume to continue")]
    Interrupted {
        /// Runs finished.
        done: usize,
        /// Runs in all.
        total: usize,
        /// Where the finished runs are kept.
        partial: PathBuf,
    },
}

/// An I/O error on `path`.
pub fn io_err(path: &std::path::Path) -> impl Fn(std::io::Error) -> SweepError + '_ {
    move |source| SweepError::Io {
        path: path.to_owned(),
        source,
    }
}
