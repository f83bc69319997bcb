//! The `agvsim` command: parses arguments, calls the library, prints.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

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
    /// List the tyre compounds and floor surfaces and the tyre values they combine into.
    Presets,
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

fn main() -> ExitCode {
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
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::from(2);
                }
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
                    let s = &o.summary;
                    println!(
                        "scene      {} ({}, fidelity {})",
                        scene.display(),
                        loaded.description,
                        loaded.sim.fidelity.name()
                    );
                    println!(
                        "simulated  {:.2} s, {:.2} m travelled",
                        s.duration_s, s.distance_m
                    );
                    match s.settling_distance_m {
                        Some(d) => println!(
                            "settled    after {:.2} m (lateral error within {:.0} mm from then on)",
                            d,
                            1000.0 * agvsim::sim::metrics::SETTLED_BAND_M
                        ),
                        None => println!(
                            "settled    no (lateral error never stayed within {:.0} mm)",
                            1000.0 * agvsim::sim::metrics::SETTLED_BAND_M
                        ),
                    }
                    println!(
                        "RMS error  {:.1} mm lateral (after settling), peak {:.1} mm",
                        1000.0 * s.rms_lateral_error_m,
                        1000.0 * s.peak_lateral_error_after_settling_m
                    );
                    println!(
                        "peak slip  {:.3} (slip ratio), sliding {:.1} % of the time",
                        s.peak_abs_slip_ratio,
                        100.0 * s.sliding_fraction
                    );
                    println!("energy     {:.0} J from the battery", s.battery_energy_j);
                    if !s.faults.is_empty() {
                        println!("DCMC fault {}", s.faults.join(", "));
                    }
                    if s.bumper_stop {
                        println!("bumper     stopped on contact with an obstacle");
                    }
                    println!("recording  {}", o.recording.display());
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        Command::Presets => {
            println!(
                "{:<20} {:>8} {:>8} {:>10} {:>10} {:>9}",
                "compound / surface", "peak_mu", "slide_mu", "Cx per N", "Cy per N", "sigma_m"
            );
            for c in &presets::COMPOUNDS {
                for s in &presets::SURFACES {
                    let t = presets::combine(c, s);
                    println!(
                        "{:<20} {:>8.3} {:>8.3} {:>10.1} {:>10.1} {:>9.3}",
                        format!("{} / {}", c.name, s.name),
                        t.peak_mu,
                        t.sliding_mu,
                        t.long_stiffness_per_N,
                        t.lat_stiffness_per_N,
                        t.relaxation_length_m
                    );
                }
            }
            ExitCode::SUCCESS
        }
    }
}
