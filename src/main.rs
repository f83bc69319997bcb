//! The `agvsim` command: parses arguments, calls the library, prints.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cli_recordings;
mod cli_sweep;

use agvsim::experiment::{run_experiment, DemandPattern, ExperimentKind, ExperimentOptions};
use agvsim::ident::job::{self, IdentifyJob};
use agvsim::ident::{report, IdentifyOptions, ModelChoice};
use agvsim::run::{run_scene, RunOptions};
use agvsim::scene::{presets, Scene};
use agvsim::viz::RerunTarget;

#[derive(Parser)]
#[command(
    name = "agvsim",
    version,
    about = "Simulate, identify and diagnose wire-guided AGVs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum ImportFormat {
    /// Any CSV whose columns have other names or units, by a map file (see the README):
    /// the time and each contract column with its source column and unit or scale.
    Csv {
        /// The CSV file (a header row, then data).
        file: PathBuf,
        /// The map file (TOML).
        #[arg(long, value_name = "MAP.toml")]
        map: PathBuf,
        /// Output folder [default: runs/import]; the recording is FILE_STEM.csv there.
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a scene and write its recording (CSV, exchange format) and summary.
    Run {
        /// Scene file (TOML), e.g. scenes/lab_offset_120mm.toml.
        scene: PathBuf,
        /// Output folder [default: runs/SCENE_NAME].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override a scene value, e.g. --set controller.kp_num=-2 (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Simulated time, s (overrides sim.duration_s).
        #[arg(long, value_parser = positive_seconds)]
        duration: Option<f64>,
        /// Seed of the sensor noise (overrides sim.seed).
        #[arg(long)]
        seed: Option<u64>,
        /// Write a Rerun recording to this .rrd file.
        #[arg(long, value_name = "FILE.rrd")]
        save: Option<PathBuf>,
        /// Open the Rerun viewer and stream to it.
        #[arg(long, conflicts_with_all = ["save", "connect"])]
        spawn: bool,
        /// Stream to a running Rerun viewer.
        #[arg(long, conflicts_with_all = ["save"])]
        connect: bool,
        /// Interval between Rerun frames, s.
        #[arg(long, default_value_t = 0.02, value_parser = positive_seconds)]
        rerun_interval: f64,
    },
    /// Drive the simulator (the scene, at its fidelity) with a recording's inputs instead of
    /// its firmware and compare its outputs with the recording's: fit per output, the
    /// simulated recording beside the measured one, a plot per output.
    Replay {
        /// Scene file (TOML): the machine to replay on.
        #[arg(long)]
        scene: PathBuf,
        /// Recording (exchange format) whose inputs drive the simulator.
        #[arg(long)]
        recording: PathBuf,
        /// Output folder [default: runs/replay_RECORDING_NAME].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override a scene value, e.g. --set chassis.mass_kg=300 (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Also write the measured and simulated outputs to this Rerun .rrd file.
        #[arg(long, value_name = "FILE.rrd")]
        save: Option<PathBuf>,
    },
    /// Fit the scene's uncertain keys to a recording through the simulator itself, print
    /// each key before and after and the replay fit on the original and calibrated scene,
    /// and write the calibrated scene.
    Calibrate {
        /// Scene file (TOML): its values are the beliefs.
        #[arg(long)]
        scene: PathBuf,
        /// Recording (exchange format) to fit.
        #[arg(long)]
        recording: PathBuf,
        /// Comma-separated scene keys to fit [default: the recording kind's set: motor
        /// resistance, torque constant, rotor inertia, viscous friction for a lifted drive;
        /// torque constant, resistance, chassis mass and yaw inertia for a vehicle].
        #[arg(long, value_delimiter = ',')]
        free: Vec<String>,
        /// Write the calibrated scene here (the original text with the fitted keys
        /// replaced and commented).
        #[arg(long, value_name = "CALIBRATED.toml")]
        write: Option<PathBuf>,
        /// A second recording to compare the original and calibrated scenes on.
        #[arg(long, value_name = "OTHER.csv")]
        validate: Option<PathBuf>,
        /// Override a scene value before fitting (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Write the result (keys, fits) as JSON here.
        #[arg(long, value_name = "OUT.json")]
        json: Option<PathBuf>,
        /// Write a plot per fitted output (measured, original and calibrated replays) here.
        #[arg(long, value_name = "DIR")]
        report: Option<PathBuf>,
        /// Worker threads [default: one per core]; the result is the same for any count.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
        jobs: Option<u32>,
    },
    /// Convert a recording kept in another format into the exchange format.
    Import {
        #[command(subcommand)]
        format: ImportFormat,
    },
    /// Run a scene over a grid of values in parallel and tabulate the metrics of every run
    /// (results.csv, plots); `sweep merge` joins shard folders.
    Sweep(cli_sweep::SweepArgs),
    /// Run a shipped study (sweeps plus an analysis): tyre-compounds, thesis-figures,
    /// backlash-tolerance or reversing. Writes summary.md, plots and the sweeps' results.
    Study {
        /// tyre-compounds, thesis-figures, backlash-tolerance or reversing.
        #[arg(value_parser = |s: &str| s.parse::<agvsim::study::StudyKind>())]
        name: agvsim::study::StudyKind,
        /// Output folder [default: runs/study_NAME].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Parallel runs [default: one per core].
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
        jobs: Option<u32>,
        /// A coarser grid: the same analysis on fewer runs.
        #[arg(long)]
        quick: bool,
    },
    /// Linearise the scene's plant (drivetrains and chassis) about straight running on the
    /// wire and report controllability from the motor voltages and observability from the
    /// coil pair (ranks, and which states the coils cannot see), then close the P-D loop
    /// around it and report its poles and stability. The full level is linearised as its
    /// no-slip counterpart.
    Linearize {
        /// Scene file (TOML), e.g. scenes/lab_offset_120mm.toml.
        scene: PathBuf,
        /// Override a scene value, e.g. --set controller.reverse=true (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// List the tyre compounds and floor surfaces and the tyre values they combine into.
    Presets,
    /// Print the scene reference: every key, the values it allows and its default (the
    /// table the scene is validated against, in Markdown).
    Keys,
    /// Run one of the thesis's lab experiments on a simulated AGV; write the recording and
    /// its rig file (exchange format).
    Experiment {
        /// lifted-random-demand, falling-weight, coast-down or floor-run.
        #[arg(value_parser = |s: &str| s.parse::<ExperimentKind>())]
        kind: ExperimentKind,
        /// Scene file (TOML) giving the machine, e.g. scenes/lab_offset_120mm.toml.
        scene: PathBuf,
        /// Output folder.
        #[arg(long, default_value = "runs/experiments")]
        out: PathBuf,
        /// File stem of the outputs [default: the experiment's name].
        #[arg(long)]
        name: Option<String>,
        /// Seed of noise and random demands (overrides sim.seed).
        #[arg(long)]
        seed: Option<u64>,
        /// Sample interval, s (floor-run: dash interval) [default: 0.025 lifted, 0.002
        /// falling weight, 0.005 coast-down, 0.25 floor-run].
        #[arg(long, value_parser = positive_seconds)]
        interval: Option<f64>,
        /// Length of a lifted-wheel run, s.
        #[arg(long, default_value_t = 15.0, value_parser = positive_seconds)]
        duration: f64,
        /// Lifted-wheel demand: pulses (microcontroller pattern) or walk (joystick-like).
        #[arg(long, default_value = "pulses", value_parser = |s: &str| s.parse::<DemandPattern>())]
        pattern: DemandPattern,
        /// Peak forward demand, pct (turn peaks at half).
        #[arg(long, default_value_t = 40.0, value_parser = demand_pct)]
        peak_demand: f64,
        /// Pulses: each demand level is held a random whole number of samples in MIN..MAX
        /// (both included); 20..60 is joystick-like at 25 ms.
        #[arg(long, default_value = "4..16", value_parser = hold_range)]
        hold: (usize, usize),
        /// RMS white noise on encoder speeds, rad/s.
        #[arg(long, default_value_t = 0.5, value_parser = non_negative)]
        speed_noise: f64,
        /// Largest relative error of the rig file's beliefs, e.g. 0.2 for up to 20 %.
        #[arg(long, default_value_t = 0.0, value_parser = non_negative)]
        rig_error: f64,
    },
    /// Find what physics the rig's model leaves out: fit the nominal model, locate the
    /// residual by regime, fit each candidate effect, keep what is significant.
    Diagnose {
        /// Rig file (NAME.rig.toml).
        #[arg(long)]
        rig: PathBuf,
        /// Recording (NAME.csv, exchange format).
        #[arg(long)]
        recording: PathBuf,
        /// A second recording to check the diagnosed model on.
        #[arg(long)]
        validate: Option<PathBuf>,
        /// Write the diagnosis JSON (contract format) here.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Write a report folder (text, SVG plots of baseline and diagnosed fits).
        #[arg(long)]
        report: Option<PathBuf>,
        /// Save measured, baseline and diagnosed outputs to a Rerun .rrd file.
        #[arg(long, value_name = "FILE.rrd")]
        save: Option<PathBuf>,
        /// Only try these effects (vocabulary names, comma-separated); by default every
        /// effect that applies to the rig.
        #[arg(long, value_delimiter = ',', value_name = "NAME,...")]
        effects: Option<Vec<String>>,        /// Worker threads [default: one per core]; the result is the same for any count.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
        jobs: Option<u32>,
    },
    /// Prove the diagnosis on agvsim's own recordings with concealed effects (and a clean
    /// one): each effect must be found within 15 % and nothing on the clean case.
    Prove {
        /// Output folder for the recordings, rigs and diagnoses.
        #[arg(long, default_value = "runs/prove")]
        out: PathBuf,
        /// The small version (clean, Coulomb friction, voltage saturation; 8 s records).
        #[arg(long)]
        quick: bool,
        /// Seed of inputs, noise and rig errors.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Run only these cases (comma-separated names, e.g. `backlash,vehicle_clean`).
        #[arg(long = "case", value_delimiter = ',', value_name = "NAME,...")]
        cases: Vec<String>,
    },
    /// Fit a rig's model to a recording: parameters with standard deviations, loss, FPE,
    /// AIC, fit per output and residual checks.
    Identify {
        /// Rig file (NAME.rig.toml).
        #[arg(long)]
        rig: PathBuf,
        /// Recording (NAME.csv, exchange format).
        #[arg(long)]
        recording: PathBuf,
        /// Model structure: drive-axis, falling-weight, coast-down, gain, p or pi
        /// [default: from the recording's experiment, else the rig kind].
        #[arg(long, value_parser = |s: &str| s.parse::<ModelChoice>())]
        model: Option<ModelChoice>,
        /// Comma-separated parameters to fit [default: the structure's identifiable set].
        #[arg(long, value_delimiter = ',')]
        free: Option<Vec<String>>,
        /// A second recording to check the identified model on.
        #[arg(long)]
        validate: Option<PathBuf>,
        /// Write the report as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Write SVG plots (fit, residual checks) into this folder.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Save measured and simulated outputs to a Rerun .rrd file.
        #[arg(long, value_name = "FILE.rrd")]
        save: Option<PathBuf>,
        /// Number of solver starts (rig values, then perturbed within a factor 2).
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=50))]
        starts: u32,
        /// Iteration limit of each start.
        #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=10000))]
        max_iterations: u32,
    },
}

fn positive_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("`{s}`: expected a positive number of seconds"))
    }
}

fn non_negative(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("`{s}`: expected a number >= 0")),
    }
}

/// `MIN..MAX` whole samples, 1 <= MIN <= MAX.
fn hold_range(s: &str) -> Result<(usize, usize), String> {
    let bad =
        || format!("`{s}`: expected MIN..MAX whole samples with 1 <= MIN <= MAX, e.g. 20..60");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let (a, b): (usize, usize) = (
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    );
    if a >= 1 && a <= b {
        Ok((a, b))
    } else {
        Err(bad())
    }
}

fn demand_pct(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v <= 100.0 => Ok(v),
        _ => Err(format!("`{s}`: expected a demand in percent, 0 < d <= 100")),
    }
}

/// A failure of the job: the library's error, exit status 1.
fn fail(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::FAILURE
}

/// Input that cannot be used (a scene that does not load): exit status 2.
fn bad_input(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(2)
}

/// Piped into `head` or a pager that quits, the program ends quietly when the reader
/// closes, as command-line tools do, instead of panicking on the failed write (Rust
/// ignores SIGPIPE by default).
#[cfg(unix)]
fn quiet_on_closed_pipe() {
    // SAFETY: setting a signal's disposition to the default at start-up, before any thread
    // exists, has no preconditions.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

#[cfg(not(unix))]
fn quiet_on_closed_pipe() {}

fn main() -> ExitCode {
    quiet_on_closed_pipe();
    let cli = Cli::parse();
    match cli.command {
        Command::Run {
            scene,
            out,
            mut set,
            duration,
            seed,
            save,
            spawn,
            connect,
            rerun_interval,
        } => {
            if let Some(d) = duration {
                set.push(format!("sim.duration_s={d}"));
            }
            if let Some(s) = seed {
                set.push(format!("sim.seed={s}"));
            }
            let loaded = match Scene::load(&scene, &set) {
                Ok(s) => s,
                Err(e) => return bad_input(e),
            };
            let name = scene
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "run".into());
            let rerun = match (save, spawn, connect) {
                (Some(p), _, _) => Some(RerunTarget::Save(p)),
                (None, true, _) => Some(RerunTarget::Spawn),
                (None, false, true) => Some(RerunTarget::Connect),
                _ => None,
            };
            let opts = RunOptions {
                out_dir: out.unwrap_or_else(|| PathBuf::from("runs").join(&name)),
                name: name.clone(),
                rerun,
                rerun_interval_s: rerun_interval,
            };
            match run_scene(&loaded, &opts) {
                Ok(o) => {
                    print!(
                        "{}",
                        agvsim::run::render_summary(&scene, &loaded, &o.summary)
                    );
                    print!(
                        "{}",
                        agvsim::run::render_expectations(&loaded, &o.summary, !set.is_empty())
                    );
                    println!("recording  {}", o.recording.display());
                    if let Some(RerunTarget::Save(p)) = &opts.rerun {
                        println!("rerun      {}", p.display());
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
        Command::Experiment {
            kind,
            scene,
            out,
            name,
            seed,
            interval,
            duration,
            pattern,
            peak_demand,
            hold,
            speed_noise,
            rig_error,
        } => {
            let loaded = match Scene::load(&scene, &[]) {
                Ok(s) => s,
                Err(e) => return bad_input(e),
            };
            let opts = ExperimentOptions {
                out_dir: out,
                name,
                seed,
                interval_s: interval,
                duration_s: duration,
                pattern,
                peak_demand_pct: peak_demand,
                hold_samples: hold,
                speed_noise_rad_s: speed_noise,
                rig_error,
                ..ExperimentOptions::default()
            };
            match run_experiment(kind, &loaded, &opts) {
                Ok(o) => {
                    println!(
                        "experiment {} on {}: {} samples",
                        kind.name(),
                        scene.display(),
                        o.samples
                    );
                    println!("recording  {}", o.recording.display());
                    println!("rig        {}", o.rig.display());
                    for f in &o.extra {
                        println!("also       {}", f.display());
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
        Command::Diagnose {
            rig,
            recording,
            validate,
            json,
            report,
            save,
            effects,
            jobs,
        } => {
            let effects = match effects.map(|names| agvsim::diagnose::parse_effects(&names)) {
                Some(Err(e)) => {
                    eprintln!("error: --effects: {e}");
                    return ExitCode::FAILURE;
                }
                Some(Ok(v)) => Some(v),
                None => None,
            };
            let job = agvsim::diagnose::job::DiagnoseJob {
                rig,
                recording,
                validate,
                json,
                report_dir: report,
                save_rrd: save,
                options: agvsim::diagnose::DiagnoseOptions {
                    effects,
                    // Progress on standard error, a line per stage: the report on standard
                    // output stays clean for pipes.
                    progress: Some(|stage: &str| eprintln!("diagnose   {stage}")),
                    ..Default::default()
                },
            };
            let ran = agvsim::jobs::with_jobs(jobs.unwrap_or(0) as usize, || {
                agvsim::diagnose::job::run(&job)
            });
            match ran {
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
                Ok(Ok((d, written))) => {
                    print!("{}", agvsim::diagnose::job::render(&d));
                    for f in &written {
                        println!("wrote      {}", f.display());
                    }
                    ExitCode::SUCCESS
                }
                Ok(Err(e)) => fail(e),
            }
        }
        Command::Prove {
            out,
            quick,
            seed,
            cases,
        } => match agvsim::diagnose::prove::prove(&out, quick, seed, &cases) {
            Ok(cases) => {
                print!("{}", agvsim::diagnose::prove::render(&cases));
                if cases.iter().all(|c| c.passed) {
                    ExitCode::SUCCESS
                } else {
                    ExitCode::FAILURE
                }
            }
            Err(e) => fail(e),
        },
        Command::Identify {
            rig,
            recording,
            model,
            free,
            validate,
            json,
            plot,
            save,
            starts,
            max_iterations,
        } => {
            let job = IdentifyJob {
                rig,
                recording,
                validate,
                options: IdentifyOptions {
                    model,
                    free,
                    starts: starts as usize,
                    max_iterations: max_iterations as usize,
                    ..IdentifyOptions::default()
                },
                json,
                plot_dir: plot,
                save_rrd: save,
            };
            match job::run(&job) {
                Ok(o) => {
                    print!("{}", report::render(&o.identification));
                    for f in &o.written {
                        println!("wrote      {}", f.display());
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
        Command::Replay {
            scene,
            recording,
            out,
            set,
            save,
        } => cli_recordings::replay_command(&scene, &recording, out, &set, save),
        Command::Calibrate {
            scene,
            recording,
            free,
            write,
            validate,
            set,
            json,
            report,
            jobs,
        } => {
            let ran = agvsim::jobs::with_jobs(jobs.unwrap_or(0) as usize, || {
                cli_recordings::calibrate_command(
                    &scene,
                    &recording,
                    &free,
                    cli_recordings::CalibrateOutputs {
                        write,
                        json,
                        report,
                    },
                    validate,
                    &set,
                )
            });
            ran.unwrap_or_else(|e| {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            })
        }
        Command::Import {
            format: ImportFormat::Csv { file, map, out },
        } => cli_recordings::import_csv_command(&file, &map, out),
        Command::Sweep(args) => cli_sweep::sweep_command(args),
        Command::Linearize { scene, set } => {
            let loaded = match Scene::load(&scene, &set) {
                Ok(s) => s,
                Err(e) => return bad_input(e),
            };
            match agvsim::sim::linearize::linearise(&loaded) {
                Ok(l) => {
                    println!("scene            {}", scene.display());
                    print!(
                        "{}",
                        agvsim::sim::linearize::render(&l, &agvsim::sim::linearize::analyse(&l))
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
        Command::Study {
            name,
            out,
            jobs,
            quick,
        } => {
            let opts = agvsim::study::StudyOptions {
                out_dir: out.unwrap_or_else(|| {
                    PathBuf::from("runs").join(format!("study_{}", name.name()))
                }),
                jobs: jobs.unwrap_or(0) as usize,
                quick,
            };
            let progress = |done: usize, total: usize| {
                if done == total {
                    eprintln!("study: a sweep of {total} runs done");
                }
            };
            match agvsim::study::run_study(name, &opts, &progress) {
                Ok(o) => {
                    print!("{}", o.summary);
                    for f in &o.files {
                        println!("wrote      {}", f.display());
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
        Command::Presets => {
            print!("{}", presets::render_table());
            ExitCode::SUCCESS
        }
        Command::Keys => {
            print!("{}", agvsim::scene::ranges::markdown());
            ExitCode::SUCCESS
        }
    }
}
