//! `agvsim experiment`: one of the thesis's lab experiments on a simulated machine, its
//! recording and rig file written.

use std::path::PathBuf;

use super::flags::{demand_pct, hold_range, non_negative, positive_seconds};
use super::{CommandError, Say};
use crate::experiment::{run_experiment, DemandPattern, ExperimentKind, ExperimentOptions};
use crate::scene::Scene;

/// What `agvsim experiment` was asked (its command line).
#[derive(Debug, Clone, clap::Args)]
pub struct ExperimentRequest {
    /// lifted-random-demand, falling-weight, coast-down or floor-run.
    #[arg(value_parser = |s: &str| s.parse::<ExperimentKind>())]
    pub kind: ExperimentKind,
    /// Scene file (TOML) giving the machine, e.g. scenes/lab_offset_120mm.toml.
    pub scene: PathBuf,
    /// Scene overrides (`--set`).
    #[command(flatten)]
    pub set: super::flags::Overrides,
    /// Output folder.
    #[arg(long, default_value = "runs/experiments")]
    pub out: PathBuf,
    /// File stem of the outputs [default: the experiment's name].
    #[arg(long)]
    pub name: Option<String>,
    /// Seed of noise and random demands (overrides sim.seed).
    #[arg(long, value_parser = super::flags::seed)]
    pub seed: Option<u64>,
    /// Sample interval, s (floor-run: dash interval) [default: 0.025 lifted, 0.002
    /// falling weight, 0.005 coast-down, 0.25 floor-run].
    #[arg(long = "interval", value_name = "INTERVAL", value_parser = positive_seconds)]
    pub interval_s: Option<f64>,
    /// Length of a lifted-wheel run, s.
    #[arg(long = "duration", value_name = "DURATION", default_value_t = 15.0, value_parser = positive_seconds)]
    pub duration_s: f64,
    /// Lifted-wheel demand: pulses (microcontroller pattern) or walk (joystick-like).
    #[arg(long, default_value = "pulses", value_parser = |s: &str| s.parse::<DemandPattern>())]
    pub pattern: DemandPattern,
    /// Peak forward demand, pct (turn peaks at half).
    #[arg(long = "peak-demand", value_name = "PEAK_DEMAND", default_value_t = 40.0, value_parser = demand_pct)]
    pub peak_demand_pct: f64,
    /// Pulses: each demand level is held a random whole number of samples in MIN..MAX
    /// (both included); 20..60 is joystick-like at 25 ms.
    #[arg(long = "hold", value_name = "HOLD", default_value = "4..16", value_parser = hold_range)]
    pub hold_samples: (usize, usize),
    /// RMS white noise on encoder speeds, rad/s.
    #[arg(long = "speed-noise", value_name = "SPEED_NOISE", default_value_t = 0.5, value_parser = non_negative)]
    pub speed_noise_rad_s: f64,
    /// Largest relative error of the rig file's beliefs, e.g. 0.2 for up to 20 %.
    #[arg(long, default_value_t = 0.0, value_parser = non_negative)]
    pub rig_error: f64,
}

impl ExperimentRequest {
    /// The experiment's settings; what the command line does not set is the default.
    pub fn options(&self) -> ExperimentOptions {
        ExperimentOptions {
            out_dir: self.out.clone(),
            name: self.name.clone(),
            seed: self.seed,
            interval_s: self.interval_s,
            duration_s: self.duration_s,
            pattern: self.pattern,
            peak_demand_pct: self.peak_demand_pct,
            hold_samples: self.hold_samples,
            speed_noise_rad_s: self.speed_noise_rad_s,
            rig_error: self.rig_error,
            ..Default::default()
        }
    }
}

/// Runs the experiment and prints what it wrote.
pub fn run(req: &ExperimentRequest, say: Say) -> Result<(), CommandError> {
    let scene = Scene::load(&req.scene, &req.set)?;
    let options = req.options();
    let _lock = super::lock_out("--out", &options.out_dir)?;
    let o = run_experiment(req.kind, &scene, &options)?;
    say(&format!(
        "experiment {} on {}: {} samples\n",
        req.kind.name(),
        req.scene.display(),
        o.samples
    ));
    say(&format!("recording  {}\n", o.recording.display()));
    say(&format!("rig        {}\n", o.rig.display()));
    for f in &o.extra {
        say(&format!("also       {}\n", f.display()));
    }
    Ok(())
}
