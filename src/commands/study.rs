//! `agvsim study`: a shipped study (sweeps plus an analysis), its summary printed and its
//! files written.

use std::path::PathBuf;

use super::{CommandError, Say};
use crate::study::{run_study, StudyKind, StudyOptions};

/// What `agvsim study` was asked (its command line).
#[derive(Debug, Clone, clap::Args)]
#[command(after_help = StudyKind::listing())]
pub struct StudyRequest {
    /// The study: one of the names listed below.
    #[arg(value_name = "NAME", value_parser = |s: &str| s.parse::<StudyKind>())]
    pub kind: StudyKind,
    /// Output folder [default: runs/study_NAME].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads (`--jobs`).
    #[command(flatten)]
    pub jobs: super::flags::Jobs,
    /// A coarser grid: the same analysis on fewer runs.
    #[arg(long)]
    pub quick: bool,
    /// Told each sweep's progress (runs done, runs in all).
    #[arg(skip = sweeps_done as fn(usize, usize))]
    pub progress: fn(usize, usize),
}

/// Says on standard error when each of a study's sweeps is done.
pub fn sweeps_done(done: usize, total: usize) {
    if done == total {
        eprintln!("study: a sweep of {total} runs done");
    }
}

/// Runs the study and prints its summary and files.
pub fn run(req: &StudyRequest, say: Say) -> Result<(), CommandError> {
    let opts = StudyOptions {
        out_dir: req
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("runs").join(format!("study_{}", req.kind.name()))),
        jobs: req.jobs.count(),
        quick: req.quick,
    };
    let o = run_study(req.kind, &opts, &req.progress)?;
    say(&o.summary);
    for f in &o.files {
        say(&format!("wrote      {}\n", f.display()));
    }
    Ok(())
}
