//! The `agvsim` command: parses arguments, calls the library, prints.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;

use cli_args::{Cli, Command, ImportFormat};

mod cli_args;
mod cli_progress;
mod cli_recordings;
mod cli_sweep;

use agvsim::experiment::{run_experiment, ExperimentOptions};
use agvsim::ident::job::{self, IdentifyJob};
use agvsim::ident::{report, IdentifyOptions};
use agvsim::model::tyre_presets as presets;
use agvsim::run::{run_scene, RunOptions};
use agvsim::scene::Scene;
use agvsim::viz::RerunTarget;

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
                recordings: recording,
                validate,
                json,
                report_dir: report,
                save_rrd: save,
                options: agvsim::diagnose::DiagnoseOptions {
                    effects,
                    progress: Some(cli_progress::stage),
                    ..Default::default()
                },
            };
            cli_progress::start("diagnose");
            on_workers(jobs, || {
                let result = agvsim::diagnose::job::run(&job);
                cli_progress::finish();
                match result {
                    Ok((d, written)) => {
                        print!("{}", agvsim::diagnose::job::render(&d));
                        for f in &written {
                            println!("wrote      {}", f.display());
                        }
                        ExitCode::SUCCESS
                    }
                    Err(e) => fail(e),
                }
            })
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
                recordings: recording,
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
            effects,
            write,
            validate,
            set,
            json,
            report,
            save,
            jobs,
        } => on_workers(jobs, || {
            cli_recordings::calibrate_command(
                &scene,
                &recording,
                &free,
                &effects,
                cli_recordings::CalibrateOutputs {
                    write,
                    json,
                    report,
                    save,
                },
                validate,
                &set,
            )
        }),
        Command::Import {
            format: ImportFormat::Csv { file, map, out },
        } => cli_recordings::import_mapped_command(&file, &map, out, false),
        Command::Import {
            format:
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
                },
        } => {
            let choice = agvsim::import::wpilib::wpilog::Choice {
                routine,
                motors,
                mechanism,
            };
            let assumed = agvsim::import::wpilib::Assumptions {
                wheel_radius_m,
                resistance_ohm,
                track_width_m,
                supply_v,
            };
            cli_recordings::import_wpilib_command(&file, &choice, &assumed, out)
        }
        Command::Sweep(args) => cli_sweep::sweep_command(args),
        Command::Import {
            format: ImportFormat::Mat { file, map, out },
        } => cli_recordings::import_mapped_command(&file, &map, out, true),
        Command::Linearize { scene, set, export } => {
            let loaded = match Scene::load(&scene, &set) {
                Ok(s) => s,
                Err(e) => return bad_input(e),
            };
            match agvsim::sim::linearize::linearise(&loaded) {
                Ok(l) => {
                    if let Some(path) = &export {
                        if let Err(e) = cli_recordings::export_linearisation(&l, path) {
                            return fail(e);
                        }
                    }
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
            print!("{}", agvsim::scene::keys::markdown());
            ExitCode::SUCCESS
        }
    }
}

/// Runs a command on `--jobs` worker threads (default: one per core).
fn on_workers(jobs: Option<u32>, command: impl FnOnce() -> ExitCode + Send) -> ExitCode {
    agvsim::jobs::with_jobs(jobs.unwrap_or(0) as usize, command).unwrap_or_else(|e| {
        eprintln!("error: {e}");
        ExitCode::FAILURE
    })
}
