//! Running the grid: every run in parallel on a pool of `jobs` threads, results in grid
//! order.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use std::ops::Range;

use super::grid::RunPoint;
use super::journal::{self, Journal};
use super::results::{self, Manifest};
use super::run::{run_point, RunResult, SweepOptions};
use super::{io_err, SweepError};

/// What a sweep wrote.
#[derive(Debug, Clone)]
pub struct SweepOutput {
    /// The runs this call ran, in grid order (a resumed sweep's earlier runs are not here).
    pub results: Vec<RunResult>,
    /// Runs an interrupted sweep had finished, kept by `--resume`.
    pub resumed: usize,
    /// The results table written.
    pub results_csv: PathBuf,
    /// The plots written.
    pub plots: Vec<PathBuf>,
}

/// What an earlier sweep left in `dir` (nothing for a folder no sweep wrote): printed
/// before a sweep replaces or resumes it.
pub fn previous_outputs(dir: &Path) -> Vec<String> {
    if !dir.join(results::MANIFEST_FILE).is_file() {
        return vec![];
    }
    let rows = |p: &Path| {
        std::fs::read_to_string(p)
            .map(|t| t.lines().count().saturating_sub(1))
            .unwrap_or(0)
    };
    let mut found = vec![results::MANIFEST_FILE.to_string()];
    let done = dir.join(results::RESULTS_FILE);
    if done.is_file() {
        found.push(format!("{} ({} runs)", results::RESULTS_FILE, rows(&done)));
    }
    let partial = journal::partial_path(dir);
    if partial.is_file() {
        found.push(format!(
            "an interrupted sweep's {} ({} runs finished)",
            partial.file_name().unwrap_or_default().to_string_lossy(),
            rows(&partial)
        ));
    }
    for d in [results::TRACES_DIR, "plots"] {
        if let Ok(entries) = std::fs::read_dir(dir.join(d)) {
            found.push(format!("{d}/ ({} files)", entries.count()));
        }
    }
    found
}

/// Removes what an earlier sweep wrote into the folder (its results, finished or
/// interrupted, manifest, plots and traces, and nothing else), so that no stale file
/// stands beside the new ones: a 10-run sweep with traces followed by a 2-run one used to
/// leave 8 old traces.
fn clear_previous_outputs(dir: &Path) -> Result<(), SweepError> {
    // Only a folder a sweep wrote (it has the manifest): a user's own `plots/` elsewhere is
    // never touched.
    if !dir.join(results::MANIFEST_FILE).is_file() {
        return Ok(());
    }
    for p in [
        dir.join(results::RESULTS_FILE),
        journal::partial_path(dir),
        dir.join(results::MANIFEST_FILE),
    ] {
        if p.is_file() {
            std::fs::remove_file(&p).map_err(io_err(&p))?;
        }
    }
    for d in [results::TRACES_DIR, "plots"] {
        let p = dir.join(d);
        if p.is_dir() {
            std::fs::remove_dir_all(&p).map_err(io_err(&p))?;
        }
    }
    Ok(())
}

/// The results file to write into: a new one (an earlier sweep's outputs removed, the
/// manifest written first, so that an interrupted folder says what it holds), or with
/// `resume` the interrupted one's, after checking it is this sweep. Returns it with the
/// number of runs already finished.
fn open_journal(opts: &SweepOptions, runs: &Range<usize>) -> Result<(Journal, usize), SweepError> {
    let dir = &opts.out_dir;
    let refuse = |message: String| SweepError::Argument {
        arg: format!("--resume --out {}", dir.display()),
        message,
    };
    if !opts.resume {
        clear_previous_outputs(dir)?;
        Manifest::of(opts).write(dir)?;
        return Ok((Journal::create(dir, &opts.grid, runs.start)?, 0));
    }
    if !dir.join(results::MANIFEST_FILE).is_file() {
        return Err(refuse(
            "holds no sweep to resume (no sweep.toml); run without --resume".into(),
        ));
    }
    if Manifest::read(dir)? != Manifest::of(opts) {
        return Err(refuse(
            "holds another sweep (its scene text, --set, --vary, --repeat, --shard, --traces or agvsim version differ from this command's); give the interrupted sweep's own arguments, or run without --resume to replace it".into(),
        ));
    }
    if dir.join(results::RESULTS_FILE).is_file() {
        return Err(refuse(
            "the sweep there is already complete (results.csv); nothing to resume".into(),
        ));
    }
    if !journal::partial_path(dir).is_file() {
        return Ok((Journal::create(dir, &opts.grid, runs.start)?, 0));
    }
    let done = journal::read_prefix(dir, &opts.grid, runs)?;
    Ok((Journal::append(dir, runs.start + done)?, done))
}

/// Checks, before any run, that the output folder can take files.
fn check_out_dir(dir: &Path) -> Result<(), SweepError> {
    if dir.exists() && !dir.is_dir() {
        return Err(SweepError::Argument {
            arg: format!("--out {}", dir.display()),
            message: "this is a file, not a folder; give a folder for the sweep's outputs".into(),
        });
    }
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let probe = dir.join(".agvsim-write-test");
    std::fs::write(&probe, b"").map_err(io_err(dir))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Runs the shard's runs (those an interrupted sweep left, with `resume`) on `jobs`
/// threads, taking them in run order, and appends each row to the results file as soon as
/// the rows before it are in, so that a kill leaves a valid prefix. Calls
/// `progress(done, total)` as runs finish (from worker threads). At the end the results
/// file becomes `results.csv`, and the plots are drawn.
pub fn run_sweep(
    opts: &SweepOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<SweepOutput, SweepError> {
    check_out_dir(&opts.out_dir)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.jobs)
        .build()
        .map_err(|e| SweepError::Argument {
            arg: format!("--jobs {}", opts.jobs),
            message: format!("cannot start the worker threads: {e}"),
        })?;
    let runs = opts.shard.range(opts.grid.total());
    let (journal, resumed) = open_journal(opts, &runs)?;
    let points: Vec<RunPoint> = opts.grid.points(opts.shard).split_off(resumed);
    let total = runs.len();
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(resumed);
    let journal = Mutex::new(journal);
    let finished = Mutex::new(Vec::with_capacity(points.len()));
    let failure: Mutex<Option<SweepError>> = Mutex::new(None);
    let stopping = || opts.stop.is_some_and(|s| s.load(Ordering::SeqCst));
    // Every worker takes the next run in grid order, so the finished runs form a prefix
    // but for those in progress.
    pool.broadcast(|_| loop {
        if stopping() || lock(&failure).is_some() {
            break;
        }
        let i = next.fetch_add(1, Ordering::SeqCst);
        let Some(point) = points.get(i) else { break };
        let r = run_point(opts, point);
        let written =
            results::write_trace(&opts.out_dir, &r).and_then(|()| lock(&journal).push(&r));
        if let Err(e) = written {
            lock(&failure).get_or_insert(e);
            break;
        }
        progress(done.fetch_add(1, Ordering::SeqCst) + 1, total);
        lock(&finished).push(r);
    });
    if let Some(e) = lock(&failure).take() {
        return Err(e);
    }
    let journal = journal.into_inner().unwrap_or_else(|p| p.into_inner());
    if journal.next() < runs.end {
        return Err(SweepError::Interrupted {
            done: journal.next() - runs.start,
            total,
            partial: journal::partial_path(&opts.out_dir),
        });
    }
    let results_csv = journal.finish()?;
    let mut results = finished.into_inner().unwrap_or_else(|p| p.into_inner());
    results.sort_by_key(|r| r.point.index);
    let csv = std::fs::read_to_string(&results_csv).map_err(io_err(&results_csv))?;
    let table = results::Table::parse(&csv, &results_csv)?;
    let plots = super::plots::write(&opts.out_dir, &opts.grid, &table)?;
    Ok(SweepOutput {
        results,
        resumed,
        results_csv,
        plots,
    })
}

/// A mutex's contents, also after a worker panicked holding it (the data stay valid: each
/// critical section is one push).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}
