//! The `agvsim` command: parses arguments, calls the library's command, prints.

use std::process::ExitCode;

use clap::Parser;

use cli_args::{BatchAction, Cli, Command, ImportFormat, NewArgs, SweepAction, SweepArgs};

mod cli_args;
mod cli_progress;
mod cli_sweep;

use agvsim::commands::{self, CommandError};
use agvsim::viz::RerunTarget;

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

/// Prints a command's report as it comes, after any live progress line.
fn say(text: &str) {
    cli_progress::finish();
    print!("{text}");
}

fn main() -> ExitCode {
    quiet_on_closed_pipe();
    let cli = Cli::parse();
    let result = dispatch(cli.command);
    cli_progress::finish();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if e.is_notice() {
                eprintln!("{e}");
            } else {
                eprintln!("error: {e}");
            }
            ExitCode::from(e.exit_code())
        }
    }
}

/// Runs the command the arguments name.
fn dispatch(command: Command) -> Result<(), CommandError> {
    match command {
        Command::Run {
            scene,
            out,
            set,
            duration,
            seed,
            save,
            spawn,
            connect,
            rerun_interval,
        } => commands::run::run(
            &commands::run::RunRequest {
                scene,
                out,
                set,
                duration_s: duration,
                seed,
                rerun: match (save, spawn, connect) {
                    (Some(p), _, _) => Some(RerunTarget::Save(p)),
                    (None, true, _) => Some(RerunTarget::Spawn),
                    (None, false, true) => Some(RerunTarget::Connect),
                    _ => None,
                },
                rerun_interval_s: rerun_interval,
            },
            &say,
        ),
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
        } => commands::experiment::run(
            &commands::experiment::ExperimentRequest {
                kind,
                scene,
                options: agvsim::experiment::ExperimentOptions {
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
                    ..Default::default()
                },
            },
            &say,
        ),
        Command::Diagnose {
            rig,
            scene,
            recording,
            validate,
            json,
            report,
            save,
            html,
            effects,
            jobs,
        } => {
            let request = commands::diagnose::DiagnoseRequest {
                rig,
                scene,
                recordings: recording,
                validate,
                json,
                report_dir: report,
                save_rrd: save,
                html,
                command: command_line(),
                options: agvsim::diagnose::DiagnoseOptions {
                    effects: agvsim::ident::effects::Choice::parse(&effects)?,
                    progress: Some(cli_progress::stage),
                    ..Default::default()
                },
                jobs: jobs.unwrap_or(0) as usize,
            };
            cli_progress::start("diagnose");
            commands::diagnose::run(&request, &say)
        }
        Command::Prove {
            out,
            quick,
            seed,
            cases,
            calibrate,
        } => commands::diagnose::prove(
            &commands::diagnose::ProveRequest {
                out,
                quick,
                seed,
                cases,
                calibrate,
            },
            &say,
        ),
        Command::Identify {
            rig,
            recording,
            model,
            free,
            validate,
            json,
            report,
            save,
            html,
            starts,
            max_iterations,
        } => commands::identify::run(
            &commands::identify::IdentifyRequest {
                rig,
                recordings: recording,
                validate,
                options: agvsim::ident::IdentifyOptions {
                    model,
                    free,
                    starts: starts as usize,
                    max_iterations: max_iterations as usize,
                    ..Default::default()
                },
                json,
                plot_dir: report,
                save_rrd: save,
                html,
                command: command_line(),
            },
            &say,
        ),
        Command::Replay {
            scene,
            recording,
            out,
            set,
            save,
        } => commands::replay::run(
            &commands::replay::ReplayRequest {
                scene,
                recording,
                out,
                set,
                save,
            },
            &say,
        ),
        Command::Calibrate {
            scene,
            recording,
            free,
            effects,
            write,
            validate,
            set,
            json,
            report,
            save,
            html,
            jobs,
        } => {
            let request = commands::calibrate::CalibrateRequest {
                scene,
                recording,
                free,
                effects,
                write,
                validate,
                set,
                json,
                report,
                save,
                html,
                command: command_line(),
                jobs: jobs.unwrap_or(0) as usize,
                progress: cli_progress::stage,
            };
            cli_progress::start("calibrate");
            commands::calibrate::run(&request, &say)
        }
        Command::Import { format } => import(format),
        Command::Sweep(args) => sweep(args),
        Command::Linearize { scene, set, export } => commands::linearize::run(
            &commands::linearize::LinearizeRequest { scene, set, export },
            &say,
        ),
        Command::Study {
            name,
            out,
            jobs,
            quick,
        } => commands::study::run(
            &commands::study::StudyRequest {
                kind: name,
                out,
                jobs: jobs.unwrap_or(0) as usize,
                quick,
                progress: |done, total| {
                    if done == total {
                        eprintln!("study: a sweep of {total} runs done");
                    }
                },
            },
            &say,
        ),
        Command::Presets => {
            say(&agvsim::scene::presets_table::render());
            Ok(())
        }
        Command::Keys => {
            say(&agvsim::scene::keys::markdown());
            Ok(())
        }
        Command::New(args) => new(args),
        Command::Batch { action } => batch(action),
        Command::Check { scene, set } => {
            commands::new::check(&commands::new::CheckRequest { scene, set }, &say)
        }
    }
}

/// `agvsim import csv|mat|wpilib`.
fn import(format: ImportFormat) -> Result<(), CommandError> {
    use commands::import::{mapped, ros2, wpilib, MappedImport, Ros2Import, WpilibImport};
    match format {
        ImportFormat::Ros2 {
            bag,
            map,
            out,
            wheel_radius_m,
            track_m,
            mass_kg,
            controller_yaml,
            drive,
        } => ros2(
            &Ros2Import {
                bag,
                map,
                geometry: agvsim::import::ros2::Geometry {
                    wheel_radius_m,
                    track_m,
                },
                mass_kg,
                motor: motor_of(&drive)?,
                battery_v: drive.battery_v,
                gear_ratio: drive.gear_ratio,
                backlash_rad: drive.backlash_rad,
                controller_yaml,
                out,
                command: std::env::args().collect::<Vec<_>>().join(" "),
            },
            &say,
        ),
        ImportFormat::Csv { file, map, out } => mapped(
            &MappedImport {
                file,
                map,
                out,
                mat: false,
            },
            &say,
        ),
        ImportFormat::Mat { file, map, out } => mapped(
            &MappedImport {
                file,
                map,
                out,
                mat: true,
            },
            &say,
        ),
        ImportFormat::Wpilib {
            file,
            out,
            routine,
            motors,
            mechanism,
            wheel_radius_m,
            resistance_ohm,
            track_width_m,
            supply_v,
        } => wpilib(
            &WpilibImport {
                file,
                choice: agvsim::import::wpilib::wpilog::Choice {
                    routine,
                    motors,
                    mechanism,
                },
                assumed: agvsim::import::wpilib::Assumptions {
                    wheel_radius_m,
                    resistance_ohm,
                    track_width_m,
                    supply_v,
                },
                out,
            },
            &say,
        ),
    }
}

/// `agvsim sweep` and `agvsim sweep merge`.
fn sweep(args: SweepArgs) -> Result<(), CommandError> {
    if let Some(SweepAction::Merge { shards, out }) = args.action {
        return commands::sweep::merge(&shards, &out, &say);
    }
    let progress = cli_sweep::sweep_progress();
    commands::sweep::run(
        &commands::sweep::SweepRequest {
            // clap requires the scene unless merging.
            scene: args.scene.unwrap_or_default(),
            vary: args.vary,
            repeat: args.repeat as usize,
            jobs: args.jobs.unwrap_or(0) as usize,
            shard: args.shard,
            out: args.out,
            set: args.set,
            duration_s: args.duration,
            traces: args.traces,
            max_runs: args.max_runs,
            resume: args.resume,
            progress: &progress,
            stop: cli_sweep::stop_on_signals(),
        },
        &say,
    )
}

/// The motor's datasheet point the flags give, if any.
fn motor_of(
    d: &cli_args::DriveArgs,
) -> Result<Option<agvsim::scene::robot::MotorDatasheet>, CommandError> {
    commands::new::motor_datasheet(&commands::new::MotorFlags {
        rated_v: d.motor_rated_v,
        no_load_rpm: d.motor_no_load_rpm,
        stall_current_a: d.motor_stall_current_a,
        stall_torque_nm: d.motor_stall_torque_nm,
        battery_v: d.battery_v,
    })
}

/// The command line as typed (`agvsim` and its arguments; a word with a space quoted), for
/// the headers and reports that say what made them.
fn command_line() -> String {
    std::iter::once("agvsim".to_string())
        .chain(std::env::args().skip(1))
        .map(|w| if w.contains(' ') { format!("{w:?}") } else { w })
        .collect::<Vec<_>>()
        .join(" ")
}

/// `agvsim new`: the flags as the robot's numbers.
fn new(a: NewArgs) -> Result<(), CommandError> {
    use agvsim::scene::robot::{Guidance, RobotSpec};
    let motor = motor_of(&a.drive)?;
    let command = command_line();
    commands::new::run(
        &commands::new::NewRequest {
            out: a.out,
            from: a.from,
            force: a.force,
            command,
            spec: RobotSpec {
                mass_kg: a.mass_kg,
                track_m: a.track_m,
                wheel_radius_m: a.wheel_radius_m,
                battery_v: a.drive.battery_v,
                motor,
                gear_ratio: a.drive.gear_ratio,
                backlash_rad: a.drive.backlash_rad,
                tyre: a.tyre,
                castors: a.castors,
                guidance: a.guidance.map(|g| match g.as_str() {
                    "wire" => Guidance::Wire,
                    "open-loop" => Guidance::OpenLoop,
                    _ => Guidance::None,
                }),
                length_m: a.length_m,
                width_m: a.width_m,
                description: a.description,
                configured_geometry: false,
                origins: vec![],
            },
        },
        &say,
    )
}

/// `agvsim batch diagnose|calibrate|merge`.
fn batch(action: BatchAction) -> Result<(), CommandError> {
    let (common, rig, scene) = match action {
        BatchAction::Merge { shards, out } => return commands::batch::merge(&shards, &out, &say),
        BatchAction::Diagnose { common, rig } => (common, rig, None),
        BatchAction::Calibrate { common, scene } => (common, None, Some(scene)),
    };
    commands::batch::run(
        &commands::batch::BatchRequest {
            recordings: common.recordings,
            rig,
            scene,
            effects: common.effects,
            shard: common.shard,
            out: common.out,
            jobs: common.jobs.unwrap_or(0) as usize,
            progress: |line| eprintln!("{line}"),
        },
        &say,
    )
}
