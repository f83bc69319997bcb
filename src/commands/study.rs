//! `agvsim study`: a shipped study (sweeps plus an analysis), its summary printed and its
//! files written.

use std::path::PathBuf;

use super::{CommandError, Say};
use crate::study::{run_study, StudyKind, StudyOptions};

/// What `agvsim study` was asked.
#[derive(Debug, Clone)]
pub struct StudyRequest {
    /// Which study.
    pub kind: StudyKind,
    /// Output folder (default `runs/study_NAME`).
    pub out: Option<PathBuf>,
    /// Parallel runs (0: one per core).
    pub jobs: usize,
    /// The coarser grid.
    pub quick: bool,
    /// Told each sweep's progress (runs done, runs in all).
    pub progress: fn(usize, usize),
}

/// Runs the study and prints its summary and files.
pub fn run(req: &StudyRequest, say: Say) -> Result<(), CommandError> {
    let opts = StudyOptions {
        out_dir: req
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("runs").join(format!("study_{}", req.kind.name()))),
        jobs: req.jobs,
        quick: req.quick,
    };
    let o = run_study(req.kind, &opts, &req.progress)?;
    say(&o.summary);
    for f in &o.files {
        say(&format!("wrote      {}\n", f.display()));
    }
    Ok(())
}
