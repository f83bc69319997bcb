//! Studies that ship with agvsim: sweeps over shipped scenes with an analysis of their
//! own, written as `summary.md` beside the sweeps' `results.csv` and plots.
//!
//! - [`tyres`]: tyre compound x floor x payload x gain: where slip and slip-driven limit
//!   cycles start, and how far the soft compound moves that boundary.
//! - [`thesis`]: the thesis's gain sweeps at each fidelity level, paths like its
//!   Figs 6.1-6.5, and the `full` level beside them.
//! - [`backlash`]: limit-cycle amplitude against gear play and gain.
//! - [`reversing`]: reversing on the front coil pair only against a rear pair.
//! - [`thesis_dcmc`]: the thesis's identified DCMC, a reference recording made from it,
//!   the scene's DCMC keys fitted to it through the simulator, and the machine's own
//!   lifted-wheel identification beside the thesis's.

mod backlash;
pub mod reversing;
pub mod thesis;
pub mod thesis_dcmc;
pub mod tyres;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::sweep::{self, RunResult, SweepError, SweepOptions};

/// The shipped studies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StudyKind {
    /// See [`StudyKind::describe`].
    TyreCompounds,
    /// See [`StudyKind::describe`].
    ThesisFigures,
    /// See [`StudyKind::describe`].
    BacklashTolerance,
    /// See [`StudyKind::describe`].
    Reversing,
    /// See [`StudyKind::describe`].
    ThesisDcmc,
}

impl StudyKind {
    /// Every study.
    pub const ALL: [StudyKind; 5] = [
        StudyKind::TyreCompounds,
        StudyKind::ThesisFigures,
        StudyKind::BacklashTolerance,
        StudyKind::Reversing,
        StudyKind::ThesisDcmc,
    ];

    /// What the study does, in a line (its variant's doc).
    pub fn describe(self) -> &'static str {
        match self {
            StudyKind::TyreCompounds => {
                "tyre compounds and floors against gain: where slip starts and cycles"
            }
            StudyKind::ThesisFigures => "the thesis's simulation figures at each fidelity level",
            StudyKind::BacklashTolerance => "limit cycles against gear play and gain",
            StudyKind::Reversing => "reversing on the front pair, swing away, or a rear pair",
            StudyKind::ThesisDcmc => {
                "the thesis's DCMC as identified, and the shipped machine matched to it"
            }
        }
    }

    /// Every study with its line, as `study --help` lists them.
    pub fn listing() -> String {
        let mut s = String::from("Studies:\n");
        for k in StudyKind::ALL {
            s += &format!("  {:<20} {}\n", k.name(), k.describe());
        }
        s
    }

    /// The study's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            StudyKind::TyreCompounds => "tyre-compounds",
            StudyKind::ThesisFigures => "thesis-figures",
            StudyKind::BacklashTolerance => "backlash-tolerance",
            StudyKind::Reversing => "reversing",
            StudyKind::ThesisDcmc => "thesis-dcmc",
        }
    }
}

impl std::str::FromStr for StudyKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        StudyKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                format!(
                    "`{s}`: unknown study; expected one of {}",
                    StudyKind::ALL.map(|k| k.name()).join(", ")
                )
            })
    }
}

/// How to run a study.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    /// Folder for the summary, plots and sweeps.
    pub out_dir: PathBuf,
    /// Parallel runs; 0: one per core.
    pub jobs: usize,
    /// A coarser grid (the tests' version): the same analysis on fewer runs.
    pub quick: bool,
}

/// What a study wrote: its summary (Markdown) and files.
#[derive(Debug, Clone)]
pub struct StudyOutput {
    /// The summary (Markdown).
    pub summary: String,
    /// Every file written.
    pub files: Vec<PathBuf>,
}

/// Runs a study; `progress(done, total)` follows each of its sweeps.
pub fn run_study(
    kind: StudyKind,
    opts: &StudyOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<StudyOutput, SweepError> {
    let out = match kind {
        StudyKind::TyreCompounds => tyres::run(opts, progress)?.1,
        StudyKind::ThesisFigures => thesis::run(opts, progress)?.1,
        StudyKind::BacklashTolerance => backlash::run(opts, progress)?.1,
        StudyKind::Reversing => reversing::run(opts, progress)?.1,
        StudyKind::ThesisDcmc => thesis_dcmc::run(opts)?.1,
    };
    Ok(out)
}

/// One sweep of a study over a shipped scene, into `opts.out_dir/sub`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn study_sweep(
    opts: &StudyOptions,
    sub: &str,
    scene_label: &str,
    scene_text: &str,
    set: &[&str],
    varies: &[String],
    traces: bool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(SweepOptions, Vec<RunResult>), SweepError> {
    let varies = varies
        .iter()
        .map(|v| sweep::parse_vary(v))
        .collect::<Result<Vec<_>, _>>()?;
    let mut o = SweepOptions::from_text(
        Path::new(scene_label),
        scene_text.to_string(),
        set.iter().map(|s| s.to_string()).collect(),
        varies,
        1,
    )?;
    o.jobs = opts.jobs;
    o.traces = traces;
    o.out_dir = opts.out_dir.join(sub);
    let r = sweep::run_sweep(&o, progress)?;
    Ok((o, r.results))
}

/// The value of key `key` in a run.
pub(crate) fn value_of<'a>(o: &SweepOptions, r: &'a RunResult, key: &str) -> &'a str {
    o.grid
        .varies
        .iter()
        .position(|v| v.key == key)
        .map(|i| r.point.values[i].as_str())
        .unwrap_or("")
}

/// A Markdown table.
pub(crate) fn md_table(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut s = format!(
        "| {} |\n|{}\n",
        header.join(" | "),
        "---|".repeat(header.len())
    );
    for r in rows {
        let _ = writeln!(s, "| {} |", r.join(" | "));
    }
    s
}

/// A gain (or any value) or "-" for none.
pub(crate) fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".into(), |x| format!("{x:.digits$}"))
}

pub(crate) fn write_summary(dir: &Path, text: &str) -> Result<PathBuf, SweepError> {
    std::fs::create_dir_all(dir).map_err(crate::sweep::io_err(dir))?;
    let p = dir.join("summary.md");
    crate::output::write_atomically(&p, text).map_err(crate::sweep::io_err(&p))?;
    Ok(p)
}
