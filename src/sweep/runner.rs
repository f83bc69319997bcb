//! Running the grid: every run in parallel on a pool of `jobs` threads, results in grid
//! order.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

use std::ops::Range;

use super::grid::{Grid, RunPoint, Shard};
use super::journal::{self, Journal};
use super::results::{self, Manifest};
use super::{io_err, SweepError};
use crate::scene::Scene;
use crate::sim::metrics::{MetricsObserver, RunSummary};
use crate::sim::{Sim, SimError};

/// Metrics are sampled every this many simulation steps (10 ms at the default 1 ms step),
/// as `agvsim run` does.
const METRICS_EVERY_STEPS: u64 = 10;

/// What to sweep and where to write it.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    /// The scene file (named in messages and in the manifest).
    pub scene_path: PathBuf,
    /// Its text, read once so every run sees the same scene.
    pub scene_text: String,
    /// `--set` overrides applied to every run before the varied keys.
    pub set: Vec<String>,
    pub grid: Grid,
    pub shard: Shard,
    /// Worker threads; 0: one per core.
    pub jobs: usize,
    /// Also write each run's path and lateral error (`traces/run_NNNNN.csv`).
    pub traces: bool,
    pub out_dir: PathBuf,
    /// Continue the interrupted sweep in `out_dir` (its finished runs are kept) instead of
    /// replacing it.
    pub resume: bool,
    /// Set (for example by a signal handler) to stop: runs in progress finish, their rows
    /// are written, and the sweep returns [`SweepError::Interrupted`].
    pub stop: Option<&'static AtomicBool>,
}

impl SweepOptions {
    /// Reads the scene and checks every varied value against it before any run starts, so
    /// that a misspelt key or value fails at once with the scene's own message.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        scene_path: &Path,
        set: Vec<String>,
        varies: Vec<super::Vary>,
        repeat: usize,
        shard: Shard,
        jobs: usize,
        traces: bool,
        out_dir: PathBuf,
    ) -> Result<SweepOptions, SweepError> {
        let scene_text = std::fs::read_to_string(scene_path).map_err(|source| {
            crate::scene::SceneError::Read {
                file: scene_path.to_owned(),
                source,
            }
        })?;
        let mut o = SweepOptions::from_text(scene_path, scene_text, set, varies, repeat)?;
        o.shard = shard;
        o.jobs = jobs;
        o.traces = traces;
        o.out_dir = out_dir;
        Ok(o)
    }

    /// As [`SweepOptions::new`] from scene text (`scene_path` names it in messages): the
    /// whole grid, one job per core, no traces, output in `runs/sweep`.
    pub fn from_text(
        scene_path: &Path,
        scene_text: String,
        set: Vec<String>,
        varies: Vec<super::Vary>,
        repeat: usize,
    ) -> Result<SweepOptions, SweepError> {
        // A key both set and varied: the varied values would silently win over the set one.
        for v in &varies {
            if let Some(s) = set
                .iter()
                .find(|s| s.split_once('=').map(|(k, _)| k.trim()) == Some(v.key.as_str()))
            {
                return Err(SweepError::Argument {
                    arg: format!("--set {s}"),
                    message: format!(
                        "`{}` is also varied (--vary {}=...): a run takes the varied value, so drop one of them",
                        v.key, v.key
                    ),
                });
            }
        }
        let base = Scene::from_toml(&scene_text, scene_path, &set)?;
        for v in &varies {
            for x in &v.values {
                let mut o = set.clone();
                let arg = format!("{}={x}", v.key);
                o.push(arg.clone());
                Scene::from_toml(&scene_text, scene_path, &o).map_err(|e| match e {
                    // A varied value, not a --set the user typed.
                    crate::scene::SceneError::Override { arg: a, message } if a == arg => {
                        SweepError::Argument {
                            arg: format!("--vary {}", v.key),
                            message: format!("value `{x}`: {message}"),
                        }
                    }
                    other => other.into(),
                })?;
            }
        }
        check_repeat_has_noise(&base, &varies, repeat)?;
        let grid = Grid::new(varies, repeat, base.sim.seed)?;
        Ok(SweepOptions {
            scene_path: scene_path.to_owned(),
            scene_text,
            set,
            grid,
            shard: Shard::WHOLE,
            jobs: 0,
            traces: false,
            out_dir: PathBuf::from("runs/sweep"),
            resume: false,
            stop: None,
        })
    }
}

/// Scene keys whose values make runs differ from seed to seed: the random inputs.
pub const NOISE_KEYS: [&str; 1] = ["sensors.noise_adc"];

/// Repeats differ only through the seeded noise: with every noise source at zero (and
/// none varied) `--repeat N` would write N identical rows, so it is refused, naming the
/// keys that add noise.
fn check_repeat_has_noise(
    base: &Scene,
    varies: &[super::Vary],
    repeat: usize,
) -> Result<(), SweepError> {
    let noisy =
        base.sensors.noise_adc > 0.0 || varies.iter().any(|v| NOISE_KEYS.contains(&v.key.as_str()));
    if repeat > 1 && !noisy {
        return Err(SweepError::Argument {
            arg: format!("--repeat {repeat}"),
            message: format!(
                "every repeat would give the same result: the scene adds no noise ({} = 0); \
                 set a noise source, e.g. --set sensors.noise_adc=2, or drop --repeat",
                NOISE_KEYS.join(", ")
            ),
        });
    }
    Ok(())
}

/// A run's path: time, distance along the path, axle position and the sensor pair's
/// lateral error, at the scene's record interval.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    pub t_s: Vec<f64>,
    pub distance_m: Vec<f64>,
    pub x_m: Vec<f64>,
    pub y_m: Vec<f64>,
    pub lateral_error_m: Vec<f64>,
}

/// One run's outcome.
#[derive(Debug, Clone)]
pub struct RunResult {
    pub point: RunPoint,
    /// The metrics, or why the run stopped (a diverged simulation, a bad combination of
    /// values).
    pub outcome: Result<RunSummary, String>,
    pub trace: Option<Trace>,
}

/// What a sweep wrote.
#[derive(Debug, Clone)]
pub struct SweepOutput {
    /// The runs this call ran, in grid order (a resumed sweep's earlier runs are not here).
    pub results: Vec<RunResult>,
    /// Runs an interrupted sweep had finished, kept by `--resume`.
    pub resumed: usize,
    pub results_csv: PathBuf,
    pub plots: Vec<PathBuf>,
}

/// Runs one grid point to the end of the scene's duration.
pub fn run_point(opts: &SweepOptions, point: &RunPoint) -> RunResult {
    let mut overrides = opts.set.clone();
    overrides.extend(point.overrides(&opts.grid.varies));
    let mut trace = opts.traces.then(Trace::default);
    let outcome = Scene::from_toml(&opts.scene_text, &opts.scene_path, &overrides)
        .map_err(|e| e.to_string())
        .and_then(|scene| simulate(&scene, trace.as_mut()).map_err(|e| e.to_string()));
    RunResult {
        point: point.clone(),
        outcome,
        trace,
    }
}

/// Runs a scene to its end and summarises it (the sweep's metrics, no trace).
pub fn summarise(scene: &Scene) -> Result<RunSummary, SimError> {
    simulate(scene, None)
}

fn simulate(scene: &Scene, mut trace: Option<&mut Trace>) -> Result<RunSummary, SimError> {
    let mut sim = Sim::new(scene)?;
    let dt = sim.params().sim.dt_s;
    let steps = (sim.params().sim.duration_s / dt).round() as u64;
    let trace_every = ((scene.sim.record_interval_s / dt).round() as u64).max(1);
    let mut metrics = MetricsObserver::default();
    let mut distance = 0.0;
    let mut last_xy: Option<[f64; 2]> = None;
    for k in 0..=steps {
        if k > 0 {
            sim.step()?;
        }
        let want_trace = trace.is_some() && k % trace_every == 0;
        if k % METRICS_EVERY_STEPS == 0 || want_trace {
            let s = sim.snapshot();
            if k % METRICS_EVERY_STEPS == 0 {
                metrics.observe(&s);
            }
            if let (true, Some(t)) = (want_trace, trace.as_deref_mut()) {
                let xy = [s.pose.x_m, s.pose.y_m];
                if let Some(l) = last_xy {
                    distance += (xy[0] - l[0]).hypot(xy[1] - l[1]);
                }
                last_xy = Some(xy);
                t.t_s.push(s.t_s);
                t.distance_m.push(distance);
                t.x_m.push(xy[0]);
                t.y_m.push(xy[1]);
                t.lateral_error_m.push(s.lateral_error_m);
            }
        }
    }
    Ok(metrics.summary())
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
