//! Each `agvsim` command as a library job: what the command line asks for (paths and
//! options, as plain values), the defaults decided here (output folders, `--duration` and
//! `--seed` as scene overrides), the work, the files written, and the lines the command
//! prints. `main.rs` parses the arguments, calls one of these and maps its error to the
//! exit status ([`CommandError::exit_code`]).
//!
//! A command prints through `say` (its report, line by line, to standard output) as it
//! goes, so a result is printed before its files are written: a write that fails after
//! the work does not hide the result.

pub mod batch;
pub mod calibrate;
pub mod diagnose;
pub mod experiment;
pub mod flags;
pub mod identify;
pub mod import;
pub mod linearize;
pub mod new;
pub mod replay;
pub mod run;
mod run_commands;
pub mod study;
pub mod sweep;

use std::path::{Path, PathBuf};

use crate::calibrate::CalibrateError;
use crate::experiment::ExperimentError;
use crate::ident::effects::EffectNameError;
use crate::ident::IdentError;
use crate::import::wpilib::SysIdError;
use crate::import::ImportError;
use crate::record::RecordingError;
use crate::replay::ReplayError;
use crate::rig::RigError;
use crate::run::RunError;
use crate::scene::SceneError;
use crate::sim::SimError;
use crate::sweep::SweepError;
use crate::viz::VizError;

/// Where a command's report goes, one piece at a time (each ends with its own newline).
pub type Say<'a> = &'a dyn Fn(&str);

/// What a command said, kept as it says it (for the report written with `--html`).
pub(crate) struct Transcript<'a> {
    say: Say<'a>,
    kept: std::cell::RefCell<String>,
}

impl<'a> Transcript<'a> {
    pub(crate) fn new(say: Say<'a>) -> Self {
        Transcript {
            say,
            kept: Default::default(),
        }
    }

    /// Says `s` and keeps it.
    pub(crate) fn say(&self, s: &str) {
        self.kept.borrow_mut().push_str(s);
        (self.say)(s)
    }

    /// Everything said so far.
    pub(crate) fn text(&self) -> String {
        self.kept.borrow().clone()
    }
}

/// The command line as typed (`agvsim` and its arguments; a word with a space quoted), for
/// the headers and reports that say what made them.
pub fn command_line() -> String {
    std::iter::once("agvsim".to_string())
        .chain(std::env::args().skip(1))
        .map(|w| if w.contains(' ') { format!("{w:?}") } else { w })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Why a command stopped. Input a user must mend (a scene, rig, recording, map, log or
/// option) exits with status 2, a failed job with 1, an interrupted one with 130.
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    /// A scene that does not load.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// Numbers for `agvsim new` that cannot make a scene.
    #[error(transparent)]
    Robot(#[from] crate::scene::robot::RobotError),
    /// A batch that could not run.
    #[error(transparent)]
    Batch(#[from] crate::batch::BatchError),
    /// A rig that does not load.
    #[error(transparent)]
    Rig(#[from] RigError),
    /// A recording that does not load.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// An `--effects` word that is not the vocabulary's.
    #[error(transparent)]
    Effects(#[from] EffectNameError),
    /// A map or a file to import that cannot be converted.
    #[error(transparent)]
    Import(#[from] ImportError),
    /// A SysId log that cannot be imported.
    #[error(transparent)]
    SysId(#[from] SysIdError),
    #[error(transparent)]
    /// A ROS 2 bag cannot be imported.
    Ros2(#[from] crate::import::ros2::Ros2Error),
    /// An option's value or path that cannot be used (the message names the option).
    #[error("{option} {value}: {message}")]
    Option {
        /// The option (`--json`).
        option: String,
        /// What was given.
        value: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// The proof that could not be run.
    #[error(transparent)]
    Prove(#[from] crate::diagnose::prove::ProveError),
    /// An identification or diagnosis that could not be done.
    #[error(transparent)]
    Ident(#[from] IdentError),
    /// A calibration that could not be done.
    #[error(transparent)]
    Calibrate(#[from] CalibrateError),
    /// A replay that could not be done.
    #[error(transparent)]
    Replay(#[from] ReplayError),
    /// A run that stopped.
    #[error(transparent)]
    Run(#[from] RunError),
    /// An experiment that stopped.
    #[error(transparent)]
    Experiment(#[from] ExperimentError),
    /// A simulation that cannot be set up or stopped.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A plant that cannot be linearised.
    #[error(transparent)]
    Linearize(#[from] crate::sim::linearize::LinearizeError),
    /// A sweep or study that stopped (or was interrupted).
    #[error(transparent)]
    Sweep(#[from] SweepError),
    /// A Rerun recording that could not be written.
    #[error(transparent)]
    Viz(#[from] VizError),
    /// A file that could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A converted recording or rig that does not read back as the contract's.
    #[error("{what} breaks the contract: {message}")]
    Contract {
        /// What was converted.
        what: String,
        /// The reader's complaint.
        message: String,
    },
    /// The calibrated scene does not load (a bug: it is refused, not written).
    #[error("the calibrated scene does not load: {0}")]
    WrittenScene(String),
    /// The proof's cases did not all pass (its table was printed).
    #[error("the proof failed: {failed} of {total} cases")]
    ProofFailed {
        /// Cases that failed.
        failed: usize,
        /// Cases run.
        total: usize,
    },
}

impl CommandError {
    /// The exit status: 2 for input to mend, 130 for an interrupted sweep, 1 otherwise.
    pub fn exit_code(&self) -> u8 {
        match self {
            CommandError::Scene(_)
            | CommandError::Robot(_)
            | CommandError::Batch(crate::batch::BatchError::Items { .. })
            | CommandError::Rig(_)
            | CommandError::Recording(_)
            | CommandError::Effects(_)
            | CommandError::Import(_)
            | CommandError::SysId(_)
            | CommandError::Ros2(_)
            | CommandError::Contract { .. }
            | CommandError::Option { .. } => 2,
            CommandError::Replay(ReplayError::Recording { .. }) => 2,
            CommandError::Experiment(ExperimentError::Setup(_)) => 2,
            CommandError::Ident(IdentError::Rig(_) | IdentError::Recording(_)) => 2,
            // The shell's code for a process ended by SIGINT.
            CommandError::Sweep(SweepError::Interrupted { .. }) => 130,
            CommandError::Sweep(SweepError::Argument { .. } | SweepError::Scene(_)) => 2,
            _ => 1,
        }
    }

    /// Whether the message is a report of its own, printed without `error:` (an
    /// interrupted sweep says what was kept and how to go on).
    pub fn is_notice(&self) -> bool {
        matches!(self, CommandError::Sweep(SweepError::Interrupted { .. }))
    }
}

/// An I/O error on `path`.
pub(crate) fn io(path: &Path) -> impl Fn(std::io::Error) -> CommandError + '_ {
    move |source| CommandError::Io {
        path: path.to_owned(),
        source,
    }
}

/// The paths as the user gave them, joined by ` + ` (several tests of one machine).
pub(crate) fn joined_names(paths: &[PathBuf]) -> String {
    paths
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(" + ")
}

/// Checks, before any work, that each given output path can be written (`true`: a
/// folder), naming the option at fault.
pub(crate) fn check_targets(targets: &[(&str, Option<&Path>, bool)]) -> Result<(), CommandError> {
    for (option, path, folder) in targets {
        if let Some(p) = path {
            crate::output::check_target(p, *folder).map_err(|e| CommandError::Option {
                option: option.to_string(),
                value: p.display().to_string(),
                message: e.to_string(),
            })?;
        }
    }
    Ok(())
}

/// Checks the output paths (as [`check_targets`]) and takes each one's lock (a folder's
/// as `--out`'s, a file's beside it: [`crate::output::FolderLock::acquire_file`]), held
/// until the returned locks are dropped: a second command writing any of them stops
/// before its work, naming the option and the process that holds it, instead of one
/// result silently replacing the other (or a TOML from one run beside a JSON from another).
pub(crate) fn lock_targets(
    targets: &[(&str, Option<&Path>, bool)],
) -> Result<Vec<crate::output::FolderLock>, CommandError> {
    check_targets(targets)?;
    let mut locks = vec![];
    for (option, path, folder) in targets {
        let Some(p) = path else { continue };
        let lock = if *folder {
            crate::output::FolderLock::acquire(p)
        } else {
            crate::output::FolderLock::acquire_file(p)
        };
        locks.push(lock.map_err(|e| CommandError::Option {
            option: option.to_string(),
            value: p.display().to_string(),
            message: e.to_string(),
        })?);
    }
    Ok(locks)
}

/// Writes a file whole or not at all, creating its folder.
pub(crate) fn write_file(path: &Path, bytes: impl AsRef<[u8]>) -> Result<(), CommandError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io(dir))?;
    }
    crate::output::write_atomically(path, bytes).map_err(io(path))
}

/// Takes the output folder's lock (see [`crate::output::FolderLock`]) for the command's
/// writes, after checking the folder can be written; the lock goes when it is dropped.
pub(crate) fn lock_out(
    option: &str,
    dir: &Path,
) -> Result<crate::output::FolderLock, CommandError> {
    check_targets(&[(option, Some(dir), true)])?;
    crate::output::FolderLock::acquire(dir).map_err(|e| CommandError::Option {
        option: option.to_string(),
        value: dir.display().to_string(),
        message: e.to_string(),
    })
}

/// Runs `work` on `jobs` worker threads (0: one per core).
pub(crate) fn on_workers<R: Send>(
    jobs: usize,
    work: impl FnOnce() -> Result<R, CommandError> + Send,
) -> Result<R, CommandError> {
    crate::jobs::with_jobs(jobs, work).map_err(|e| CommandError::Option {
        option: "--jobs".into(),
        value: jobs.to_string(),
        message: e.to_string(),
    })?
}

/// A scene error about a `--set` the command made from its own option (`--duration`,
/// `--seed`) named by that option, not as a `--set` the user never typed.
pub(crate) fn name_own_options(
    e: crate::scene::SceneError,
    user_set: &[String],
    duration_s: Option<f64>,
    seed: Option<u64>,
) -> crate::scene::SceneError {
    use crate::scene::{Origin, SceneError};
    let own = |arg: &str| -> Option<String> {
        if user_set.iter().any(|s| s == arg) {
            return None;
        }
        match (duration_s, seed) {
            (Some(d), _) if arg == format!("sim.duration_s={d}") => {
                Some(format!("--duration {}", crate::param::plain_number(d)))
            }
            (_, Some(s)) if arg == format!("sim.seed={s}") => Some(format!("--seed {s}")),
            _ => None,
        }
    };
    match e {
        SceneError::Invalid {
            origin: Origin::Set(arg),
            key,
            value,
            expected,
        } => SceneError::Invalid {
            origin: own(&arg).map_or(Origin::Set(arg), Origin::Flag),
            key,
            value,
            expected,
        },
        other => other,
    }
}

/// The scene overrides a command's `--duration` and `--seed` stand for, after its `--set`.
pub(crate) fn overrides(set: &[String], duration_s: Option<f64>, seed: Option<u64>) -> Vec<String> {
    let mut set = set.to_vec();
    if let Some(d) = duration_s {
        set.push(format!("sim.duration_s={d}"));
    }
    if let Some(s) = seed {
        set.push(format!("sim.seed={s}"));
    }
    set
}

impl From<crate::import::ImportFailure> for CommandError {
    /// Each importer's error as before importers shared a shape: the format's own, the
    /// numbers' error, or the contract's (the same words and exit status).
    fn from(e: crate::import::ImportFailure) -> Self {
        use crate::import::ImportFailure;
        match e {
            ImportFailure::Mapped(e) => CommandError::Import(e),
            ImportFailure::SysId(e) => CommandError::SysId(e),
            ImportFailure::Ros2(e) => CommandError::Ros2(e),
            ImportFailure::Robot(e) => CommandError::Robot(e),
            ImportFailure::Contract { what, message } => CommandError::Contract { what, message },
        }
    }
}
