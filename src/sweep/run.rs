//! One run of a sweep: what to sweep (the options every run reads), a grid point's run to
//! the end of the scene's duration, and its outcome (metrics, trace).

use crate::sensing::coil::SensorParams;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use super::grid::{Grid, RunPoint, Shard};
use super::SweepError;
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
    /// The grid of varied values.
    pub grid: Grid,
    /// The slice this call runs.
    pub shard: Shard,
    /// Worker threads; 0: one per core.
    pub jobs: usize,
    /// Also write each run's path and lateral error (`traces/run_NNNNN.csv`).
    pub traces: bool,
    /// The output folder.
    pub out_dir: PathBuf,
    /// Continue the interrupted sweep in `out_dir` (its finished runs are kept) instead of
    /// replacing it.
    pub resume: bool,
    /// Set (for example by a signal handler) to stop: runs in progress finish, their rows
    /// are written, and the sweep returns [`SweepError::Interrupted`].
    pub stop: Option<&'static AtomicBool>,
    /// Where the shard came from (`--shard 2/4`, or the scheduler's variables), for the
    /// report.
    pub shard_source: Option<String>,
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
        let scene_text = crate::scene::read_scene_text(scene_path)?;
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
                    crate::scene::SceneError::Invalid {
                        origin: crate::scene::Origin::Set(a),
                        expected,
                        ..
                    } if a == arg => SweepError::Argument {
                        arg: format!("--vary {}", v.key),
                        message: format!("value `{x}`: expected {expected}"),
                    },
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
            shard_source: None,
            stop: None,
        })
    }
}

/// Scene keys whose values make runs differ from seed to seed: the random inputs.
pub const NOISE_KEYS: [&str; 1] = [SensorParams::noise_adc.key()];

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
    /// Times, s.
    pub t_s: Vec<f64>,
    /// Distance along the path, m.
    pub distance_m: Vec<f64>,
    /// Axle position, world x, m.
    pub x_m: Vec<f64>,
    /// Axle position, world y, m.
    pub y_m: Vec<f64>,
    /// The sensor pair's lateral error, m.
    pub lateral_error_m: Vec<f64>,
}

/// Why a run of a sweep stopped, as `results.csv` states it (its error kept as text: a
/// run's result is cloned and written, its error only read).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RunFailure {
    /// The grid point's values make no valid scene.
    #[error("{0}")]
    Scene(String),
    /// The simulation stopped (it diverged, or could not be set up).
    #[error("{0}")]
    Simulation(String),
}

/// One run's outcome.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// The grid point.
    pub point: RunPoint,
    /// The metrics, or why the run stopped (a diverged simulation, a bad combination of
    /// values).
    pub outcome: Result<RunSummary, RunFailure>,
    /// Its trace, when asked for.
    pub trace: Option<Trace>,
}

/// Runs one grid point to the end of the scene's duration.
pub fn run_point(opts: &SweepOptions, point: &RunPoint) -> RunResult {
    let mut overrides = opts.set.clone();
    overrides.extend(point.overrides(&opts.grid.varies));
    let mut trace = opts.traces.then(Trace::default);
    let outcome = Scene::from_toml(&opts.scene_text, &opts.scene_path, &overrides)
        .map_err(|e| RunFailure::Scene(e.to_string()))
        .and_then(|scene| {
            simulate(&scene, trace.as_mut()).map_err(|e| RunFailure::Simulation(e.to_string()))
        });
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
