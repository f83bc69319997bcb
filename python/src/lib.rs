//! `agvsim._native`: the library's commands for the `agvsim` Python package.
//!
//! Each function here is one `agvsim` command as the library runs it
//! ([`agvsim::commands`]): the same request, the same files written, the same report. The
//! Python layer (`python/agvsim/__init__.py`) turns the files into Python objects. Nothing
//! here changes what the library does; it only carries values across and:
//!
//! - runs each command on a thread of its own with the GIL released, so that other Python
//!   threads go on and the library's own worker threads (rayon) do the work;
//! - checks for signals while it waits: Ctrl-C raises `KeyboardInterrupt` at once (a sweep
//!   is told to stop and keeps the runs it finished, as the CLI does);
//! - raises the library's typed error text as `agvsim.InputError` (input to mend: the
//!   CLI's exit status 2) or `agvsim.AgvsimError` (a job that failed).

use std::cell::RefCell;
use std::panic::AssertUnwindSafe;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::Duration;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

mod importers;
mod live;
mod machine;
mod recording;
mod studies;

use agvsim::commands::flags::Jobs;
use agvsim::commands::{self, CommandError};

create_exception!(
    agvsim,
    AgvsimError,
    PyException,
    "A command of agvsim that could not be done (the CLI's exit status 1)."
);
create_exception!(
    agvsim,
    InputError,
    AgvsimError,
    "Input to mend: a scene, rig, recording, bag or argument that agvsim cannot use (the CLI's exit status 2)."
);

/// Set when Python is interrupted during a sweep: the sweep finishes the runs in progress,
/// keeps them, and stops (`SweepRequest::stop`).
static STOP: AtomicBool = AtomicBool::new(false);

/// How often a waiting call looks for a signal.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// A command's outcome as it crosses threads: its report, or its error's text and exit
/// status.
type Outcome = Result<String, (String, u8)>;

/// The error as Python sees it.
fn to_py((message, code): (String, u8)) -> PyErr {
    match code {
        2 => InputError::new_err(message),
        _ => AgvsimError::new_err(message),
    }
}

/// An argument the CLI's parser would refuse, named as Python passes it.
fn bad_argument(name: &str, value: impl std::fmt::Display, expected: &str) -> PyErr {
    InputError::new_err(format!("{name}={value}: expected {expected}"))
}

/// A positive, finite number (the CLI's `positive_number`), if given.
fn positive(name: &str, v: Option<f64>) -> PyResult<Option<f64>> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => {
            Err(bad_argument(name, x, "a positive, finite number"))
        }
        _ => Ok(v),
    }
}

/// Runs one command on a thread of its own, the GIL released, and returns what it printed.
/// `stoppable`: the command watches [`STOP`] (a sweep), so an interrupt waits for it to
/// keep what it finished; any other command is left to end on its own thread, its output
/// in the folder it was given.
fn job<F>(py: Python<'_>, stoppable: bool, f: F) -> PyResult<String>
where
    F: FnOnce(&dyn Fn(&str)) -> Result<(), CommandError> + Send + 'static,
{
    let (tx, rx) = mpsc::channel::<Outcome>();
    std::thread::Builder::new()
        .name("agvsim-command".into())
        .spawn(move || {
            let report = RefCell::new(String::new());
            let say = |s: &str| report.borrow_mut().push_str(s);
            let outcome = match std::panic::catch_unwind(AssertUnwindSafe(|| f(&say))) {
                Ok(Ok(())) => Ok(report.into_inner()),
                Ok(Err(e)) => Err((e.to_string(), e.exit_code())),
                Err(_) => Err((
                    "agvsim stopped on an internal error (a bug; the message above says where)"
                        .to_string(),
                    1,
                )),
            };
            let _ = tx.send(outcome);
        })
        .map_err(|e| AgvsimError::new_err(format!("cannot start the command's thread: {e}")))?;
    let mut rx = rx;
    loop {
        // The receiver goes into the GIL-free closure and comes back (it is Send, not Sync).
        let (received, back) = py.allow_threads(move || (rx.recv_timeout(SIGNAL_POLL), rx));
        rx = back;
        match received {
            Ok(outcome) => return outcome.map_err(to_py),
            Err(RecvTimeoutError::Timeout) => {
                if let Err(interrupt) = py.check_signals() {
                    if stoppable {
                        STOP.store(true, Ordering::SeqCst);
                        let _ = py.allow_threads(move || rx.recv());
                    }
                    return Err(interrupt);
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(AgvsimError::new_err(
                    "the command's thread ended without a result",
                ))
            }
        }
    }
}

/// The battery, motor and gear as given (`agvsim new`'s and `import ros2`'s drive flags),
/// each number checked positive and named as Python passes it.
fn drive_of(
    battery_v: Option<f64>,
    rated_v: Option<f64>,
    no_load_rpm: Option<f64>,
    stall_current_a: Option<f64>,
    stall_torque_nm: Option<f64>,
    gear_ratio: Option<f64>,
    backlash_rad: Option<f64>,
) -> PyResult<commands::flags::DriveFlags> {
    Ok(commands::flags::DriveFlags {
        battery_v: positive("battery_v", battery_v)?,
        motor_rated_v: positive("motor_rated_v", rated_v)?,
        motor_no_load_rpm: positive("motor_no_load_rpm", no_load_rpm)?,
        motor_stall_current_a: positive("motor_stall_current_a", stall_current_a)?,
        motor_stall_torque_nm: positive("motor_stall_torque_nm", stall_torque_nm)?,
        gear_ratio: positive("gear_ratio", gear_ratio)?,
        backlash_rad,
    })
}

/// A library error (a request builder's refusal, a scene that does not load) as Python
/// sees it, with the CLI's exit status.
fn failed(e: impl Into<CommandError>) -> PyErr {
    let e = e.into();
    to_py((e.to_string(), e.exit_code()))
}

/// A progress callback that tells nobody (the CLI draws bars; Python callers read the
/// report).
fn quiet(_: &str) {}

/// A numeric scene key: its dotted name, value (`None`: an optional key left out) and unit.
type KeyValue = (String, Option<f64>, String);

/// The scene as the library reads it (every `--set` applied and validated): its
/// plausibility warnings, every numeric key with its value and unit, and the scene as TOML.
#[pyfunction]
#[pyo3(signature = (path, set))]
fn scene_info(path: PathBuf, set: Vec<String>) -> PyResult<(String, Vec<KeyValue>, String)> {
    let checked =
        agvsim::scene::Scene::load_checked(&path, &set).map_err(|e| to_py((e.to_string(), 2)))?;
    let keys = agvsim::scene::keys::table()
        .numbers()
        .map(|(k, _)| (k.key.clone(), k.get(&checked.scene), k.unit.to_string()))
        .collect();
    Ok((checked.render_warnings(), keys, checked.scene.to_toml()))
}

/// `agvsim check SCENE --set ...`.
#[pyfunction]
#[pyo3(signature = (scene, set))]
fn check(py: Python<'_>, scene: PathBuf, set: Vec<String>) -> PyResult<String> {
    job(py, false, move |say| {
        commands::new::check(
            &commands::new::CheckRequest {
                scene,
                set: set.into(),
            },
            say,
        )
    })
}

/// `agvsim new OUT ...`: every number optional, as the flags are.
#[pyfunction]
#[pyo3(signature = (out, command, from_=None, force=false, mass_kg=None, track_m=None,
    wheel_radius_m=None, battery_v=None, motor_rated_v=None, motor_no_load_rpm=None,
    motor_stall_current_a=None, motor_stall_torque_nm=None, gear_ratio=None,
    backlash_rad=None, tyre=None, castors=None, guidance=None, length_m=None, width_m=None,
    description=None))]
#[allow(clippy::too_many_arguments)]
fn new_scene(
    py: Python<'_>,
    out: PathBuf,
    command: String,
    from_: Option<PathBuf>,
    force: bool,
    mass_kg: Option<f64>,
    track_m: Option<f64>,
    wheel_radius_m: Option<f64>,
    battery_v: Option<f64>,
    motor_rated_v: Option<f64>,
    motor_no_load_rpm: Option<f64>,
    motor_stall_current_a: Option<f64>,
    motor_stall_torque_nm: Option<f64>,
    gear_ratio: Option<f64>,
    backlash_rad: Option<f64>,
    tyre: Option<String>,
    castors: Option<bool>,
    guidance: Option<String>,
    length_m: Option<f64>,
    width_m: Option<f64>,
    description: Option<String>,
) -> PyResult<String> {
    let guidance = guidance
        .map(|g| {
            g.parse()
                .map_err(|why: String| bad_argument("guidance", &g, &why))
        })
        .transpose()?;
    let args = commands::new::NewArgs {
        out,
        from: from_,
        mass_kg: positive("mass_kg", mass_kg)?,
        track_m: positive("track_m", track_m)?,
        wheel_radius_m: positive("wheel_radius_m", wheel_radius_m)?,
        drive: drive_of(
            battery_v,
            motor_rated_v,
            motor_no_load_rpm,
            motor_stall_current_a,
            motor_stall_torque_nm,
            gear_ratio,
            backlash_rad,
        )?,
        tyre,
        castors,
        guidance,
        length_m: positive("length_m", length_m)?,
        width_m: positive("width_m", width_m)?,
        description,
        force,
    };
    let request = args.request(command).map_err(failed)?;
    job(py, false, move |say| commands::new::run(&request, say))
}

/// `agvsim run SCENE --out OUT`.
#[pyfunction]
#[pyo3(signature = (scene, set, out, duration_s=None, seed=None))]
fn run(
    py: Python<'_>,
    scene: PathBuf,
    set: Vec<String>,
    out: PathBuf,
    duration_s: Option<f64>,
    seed: Option<u64>,
) -> PyResult<String> {
    let duration_s = positive("duration_s", duration_s)?;
    job(py, false, move |say| {
        commands::run::run(
            &commands::run::RunRequest {
                scene,
                out: Some(out),
                set: set.into(),
                duration_s,
                seed,
                rerun: Default::default(),
                rerun_interval_s: 0.02,
            },
            say,
        )
    })
}

/// `agvsim replay --scene SCENE --recording REC --out OUT`.
#[pyfunction]
#[pyo3(signature = (scene, set, recording, out))]
fn replay(
    py: Python<'_>,
    scene: PathBuf,
    set: Vec<String>,
    recording: PathBuf,
    out: PathBuf,
) -> PyResult<String> {
    job(py, false, move |say| {
        commands::replay::run(
            &commands::replay::ReplayRequest {
                scene,
                recording,
                out: Some(out),
                set: set.into(),
                save: None,
            },
            say,
        )
    })
}

/// `agvsim calibrate --scene SCENE --recording REC... --json J --write W`.
#[pyfunction]
#[pyo3(signature = (scene, set, recordings, free, effects, json, write, validate, report=None, jobs=0, html=None, command=String::new()))]
#[allow(clippy::too_many_arguments)]
fn calibrate(
    py: Python<'_>,
    scene: PathBuf,
    set: Vec<String>,
    recordings: Vec<PathBuf>,
    free: Vec<String>,
    effects: Vec<String>,
    json: PathBuf,
    write: PathBuf,
    validate: Vec<PathBuf>,
    report: Option<PathBuf>,
    jobs: usize,
    html: Option<PathBuf>,
    command: String,
) -> PyResult<String> {
    job(py, false, move |say| {
        commands::calibrate::run(
            &commands::calibrate::CalibrateRequest {
                scene,
                recording: recordings,
                free,
                effects: effects.into(),
                write: Some(write),
                validate,
                set: set.into(),
                json: Some(json),
                report,
                save: None,
                html,
                jobs: Jobs::of(jobs),
                command,
                progress: quiet,
            },
            say,
        )
    })
}

/// `agvsim diagnose --rig RIG | --scene SCENE --recording REC... --json J`.
#[pyfunction]
#[pyo3(signature = (rig, scene, recordings, effects, json, validate=None, report=None, jobs=0, html=None, command=String::new()))]
#[allow(clippy::too_many_arguments)]
fn diagnose(
    py: Python<'_>,
    rig: Option<PathBuf>,
    scene: Option<PathBuf>,
    recordings: Vec<PathBuf>,
    effects: Vec<String>,
    json: PathBuf,
    validate: Option<PathBuf>,
    report: Option<PathBuf>,
    jobs: usize,
    html: Option<PathBuf>,
    command: String,
) -> PyResult<String> {
    job(py, false, move |say| {
        commands::diagnose::run(
            &commands::diagnose::DiagnoseRequest {
                rig,
                scene,
                recordings,
                validate,
                json: Some(json),
                report_dir: report,
                save_rrd: None,
                html,
                command,
                effects: effects.into(),
                jobs: Jobs::of(jobs),
                progress: None,
            },
            say,
        )
    })
}

/// `agvsim identify --rig RIG --recording REC... --json J`.
#[pyfunction]
#[pyo3(signature = (rig, recordings, json, model=None, free=None, validate=None, report=None, starts=3, max_iterations=100, html=None, command=String::new()))]
#[allow(clippy::too_many_arguments)]
fn identify(
    py: Python<'_>,
    rig: PathBuf,
    recordings: Vec<PathBuf>,
    json: PathBuf,
    model: Option<String>,
    free: Option<Vec<String>>,
    validate: Option<PathBuf>,
    report: Option<PathBuf>,
    starts: usize,
    max_iterations: usize,
    html: Option<PathBuf>,
    command: String,
) -> PyResult<String> {
    let model = model
        .map(|m| {
            m.parse::<agvsim::ident::ModelChoice>()
                .map_err(|e| bad_argument("model", &m, &e.to_string()))
        })
        .transpose()?;
    if !(1..=50).contains(&starts) {
        return Err(bad_argument("starts", starts, "1 to 50"));
    }
    if !(1..=10_000).contains(&max_iterations) {
        return Err(bad_argument("max_iterations", max_iterations, "1 to 10000"));
    }
    job(py, false, move |say| {
        commands::identify::run(
            &commands::identify::IdentifyRequest {
                rig,
                recordings,
                validate,
                model,
                free,
                starts: starts as u32,
                max_iterations: max_iterations as u32,
                json: Some(json),
                plot_dir: report,
                save_rrd: None,
                html,
                command,
            },
            say,
        )
    })
}

/// `agvsim sweep SCENE --vary ... --out OUT`.
#[pyfunction]
#[pyo3(signature = (scene, set, vary, out, repeat=1, jobs=0, shard=None, duration_s=None, traces=false, resume=false, max_runs=None))]
#[allow(clippy::too_many_arguments)]
fn sweep(
    py: Python<'_>,
    scene: PathBuf,
    set: Vec<String>,
    vary: Vec<String>,
    out: PathBuf,
    repeat: usize,
    jobs: usize,
    shard: Option<String>,
    duration_s: Option<f64>,
    traces: bool,
    resume: bool,
    max_runs: Option<usize>,
) -> PyResult<String> {
    if !(1..=10_000).contains(&repeat) {
        return Err(bad_argument("repeat", repeat, "1 to 10000"));
    }
    let duration_s = positive("duration_s", duration_s)?;
    STOP.store(false, Ordering::SeqCst);
    job(py, true, move |say| {
        commands::sweep::run(
            &commands::sweep::SweepRequest {
                flags: commands::sweep::SweepFlags {
                    scene: Some(scene),
                    vary,
                    repeat: repeat as u32,
                    jobs: Jobs::of(jobs),
                    shard,
                    out: Some(out),
                    set: set.into(),
                    duration_s,
                    traces,
                    max_runs: max_runs.unwrap_or(agvsim::sweep::DEFAULT_MAX_RUNS),
                    resume,
                },
                progress: &|_, _| {},
                stop: Some(&STOP),
            },
            say,
        )
    })
}

/// `agvsim sweep merge SHARD... --out OUT`.
#[pyfunction]
fn sweep_merge(py: Python<'_>, shards: Vec<PathBuf>, out: PathBuf) -> PyResult<String> {
    job(py, false, move |say| {
        commands::sweep::merge(&shards, &out, say)
    })
}

/// `agvsim batch diagnose|calibrate RECORDINGS --out OUT`.
#[pyfunction]
#[pyo3(signature = (recordings, out, rig=None, scene=None, effects=vec!["all".to_string()], shard=None, jobs=0))]
#[allow(clippy::too_many_arguments)]
fn batch(
    py: Python<'_>,
    recordings: PathBuf,
    out: PathBuf,
    rig: Option<PathBuf>,
    scene: Option<PathBuf>,
    effects: Vec<String>,
    shard: Option<String>,
    jobs: usize,
) -> PyResult<String> {
    job(py, false, move |say| {
        commands::batch::run(
            &commands::batch::BatchRequest {
                recordings,
                rig,
                scene,
                effects: effects.into(),
                shard,
                out: Some(out),
                jobs: Jobs::of(jobs),
                progress: quiet,
            },
            say,
        )
    })
}

/// `agvsim batch merge SHARD... --out OUT`.
#[pyfunction]
fn batch_merge(py: Python<'_>, shards: Vec<PathBuf>, out: PathBuf) -> PyResult<String> {
    job(py, false, move |say| {
        commands::batch::merge(&shards, &out, say)
    })
}

/// The scene reference (`agvsim keys`) as Markdown.
#[pyfunction]
fn keys_markdown() -> String {
    agvsim::scene::keys::markdown()
}

/// The `agvsim` package's native module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("AgvsimError", m.py().get_type::<AgvsimError>())?;
    m.add("InputError", m.py().get_type::<InputError>())?;
    m.add_function(wrap_pyfunction!(scene_info, m)?)?;
    m.add_function(wrap_pyfunction!(check, m)?)?;
    m.add_function(wrap_pyfunction!(new_scene, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(replay, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_merge, m)?)?;
    m.add_function(wrap_pyfunction!(batch, m)?)?;
    m.add_function(wrap_pyfunction!(batch_merge, m)?)?;
    m.add_function(wrap_pyfunction!(importers::import_ros2, m)?)?;
    m.add_function(wrap_pyfunction!(importers::import_wpilib, m)?)?;
    m.add_function(wrap_pyfunction!(recording::read_recording, m)?)?;
    m.add_function(wrap_pyfunction!(recording::write_recording, m)?)?;
    m.add_function(wrap_pyfunction!(keys_markdown, m)?)?;
    m.add_function(wrap_pyfunction!(machine::linearize, m)?)?;
    m.add_function(wrap_pyfunction!(machine::presets, m)?)?;
    m.add_function(wrap_pyfunction!(studies::experiment, m)?)?;
    m.add_function(wrap_pyfunction!(studies::study, m)?)?;
    m.add_class::<live::NativeSim>()?;
    m.add_class::<live::NativeVecSim>()?;
    m.add_class::<live::NativeSaved>()?;
    Ok(())
}
