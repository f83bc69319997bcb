//! The thesis's laboratory experiments, run on the simulated AGV, written as recordings and
//! rig files in the exchange format so that `identify` treats them like anyone's data.
//!
//! - `lifted-random-demand`: wheels lifted, random forward and turn demands into the DCMC,
//!   motor speeds through 1024-count encoders at a chosen interval.
//! - `falling-weight`: motor off the vehicle, a weight on a pulley; speed and open-circuit
//!   back-EMF until the weight lands and the rotor coasts to rest.
//! - `coast-down`: wheels lifted, full voltage, power cut; speed from the cut.
//! - `floor-run`: the scene as run, plus the pen trace (dash starts at a fixed rate).
//!
//! The rig file states the scene's values as the experimenter's beliefs, optionally off by
//! a seeded random error of up to `rig_error` (a fraction) in every uncertain value.
//! Each experiment's procedure is in `procedures`, its rig file in `rigs`.

mod procedures;
mod rigs;

use std::f64::consts::TAU;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use rand::SeedableRng;
use rand_pcg::Pcg64;

use crate::run::{run_scene, RunError, RunOptions};
use crate::scene::Scene;
use crate::sim::SimError;
use procedures::{coast_down, falling_weight, lifted_random_demand, pen_trace};
use rigs::{axis_rig, falling_weight_rig, pair_rig, perturb, vehicle_rig};

/// Which experiment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExperimentKind {
    /// The thesis's lifted-wheel identification runs: random forward and turn demands into the DCMC.
    LiftedRandomDemand,
    /// The motor off the vehicle, a weight falling on a pulley on its shaft, open circuit.
    FallingWeight,
    /// A lifted wheel run up at full voltage, the power then cut.
    CoastDown,
    /// The scene run on the floor, with the pen trace.
    FloorRun,
}

impl ExperimentKind {
    /// Every experiment's name, as the command line takes it.
    pub const NAMES: [&'static str; 4] = [
        "lifted-random-demand",
        "falling-weight",
        "coast-down",
        "floor-run",
    ];

    /// The experiment's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ExperimentKind::LiftedRandomDemand => Self::NAMES[0],
            ExperimentKind::FallingWeight => Self::NAMES[1],
            ExperimentKind::CoastDown => Self::NAMES[2],
            ExperimentKind::FloorRun => Self::NAMES[3],
        }
    }

    /// Default sample interval, s.
    pub fn default_interval_s(self) -> f64 {
        match self {
            ExperimentKind::LiftedRandomDemand => 0.025,
            ExperimentKind::FallingWeight => 0.002,
            ExperimentKind::CoastDown => 0.005,
            ExperimentKind::FloorRun => 0.25,
        }
    }
}

impl FromStr for ExperimentKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ExperimentKind::NAMES
            .iter()
            .position(|n| *n == s)
            .map(|i| {
                [
                    ExperimentKind::LiftedRandomDemand,
                    ExperimentKind::FallingWeight,
                    ExperimentKind::CoastDown,
                    ExperimentKind::FloorRun,
                ][i]
            })
            .ok_or_else(|| {
                format!(
                    "unknown experiment `{s}`: expected one of {}",
                    ExperimentKind::NAMES.join(", ")
                )
            })
    }
}

/// Demand signal of the lifted-wheel runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DemandPattern {
    /// The microcontroller's pulses: random levels held for random whole numbers of
    /// intervals (4 to 16 unless set).
    Pulses,
    /// A joystick-like random walk, bounded by the peak demand.
    Walk,
}

impl FromStr for DemandPattern {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "pulses" => Ok(DemandPattern::Pulses),
            "walk" => Ok(DemandPattern::Walk),
            _ => Err(format!(
                "unknown demand pattern `{s}`: expected pulses or walk"
            )),
        }
    }
}

/// Largest encoder speed noise an experiment adds, rad/s RMS (the simulator's speed limit).
pub const MAX_SPEED_NOISE_RAD_S: f64 = 1.0e4;

/// Settings of an experiment; `None` takes the experiment's default.
#[derive(Debug, Clone)]
pub struct ExperimentOptions {
    /// Folder for the recording and rig.
    pub out_dir: PathBuf,
    /// File stem [default: the experiment's name].
    pub name: Option<String>,
    /// Seed of noise and random demands (overrides `sim.seed`).
    pub seed: Option<u64>,
    /// Sample (or, for floor runs, dash) interval, s.
    pub interval_s: Option<f64>,
    /// Length of a lifted-wheel run, s.
    pub duration_s: f64,
    /// Lifted-wheel demands: pulses or a random walk.
    pub pattern: DemandPattern,
    /// Peak forward demand, pct (turn demand peaks at half of it).
    pub peak_demand_pct: f64,
    /// Pulses: each level is held a random whole number of samples in this range.
    pub hold_samples: (usize, usize),
    /// RMS of white noise on encoder speeds (electrical noise, timing jitter), rad/s.
    pub speed_noise_rad_s: f64,
    /// RMS noise of the back-EMF voltage reading, V.
    pub voltage_noise_v: f64,
    /// Largest relative error of the rig's beliefs (0: the scene's values).
    pub rig_error: f64,
    /// Falling weight: the mass, kg.
    pub weight_mass_kg: f64,
    /// Falling weight: the pulley's radius on the motor shaft, m.
    pub pulley_radius_m: f64,
    /// Falling weight: how far the mass falls before it lands, m.
    pub drop_m: f64,
    /// Peak-to-peak pen play of a floor run, m.
    pub pen_play_m: f64,
}

impl Default for ExperimentOptions {
    fn default() -> Self {
        ExperimentOptions {
            out_dir: PathBuf::from("runs/experiments"),
            name: None,
            seed: None,
            interval_s: None,
            duration_s: 15.0,
            pattern: DemandPattern::Pulses,
            peak_demand_pct: 40.0,
            hold_samples: (4, 16),
            speed_noise_rad_s: 0.5,
            voltage_noise_v: 0.01,
            rig_error: 0.0,
            weight_mass_kg: 0.5,
            pulley_radius_m: 0.015,
            drop_m: 1.0,
            pen_play_m: 0.002,
        }
    }
}

/// What an experiment wrote.
#[derive(Debug, Clone)]
pub struct ExperimentOutput {
    /// The recording written.
    pub recording: PathBuf,
    /// The rig file written.
    pub rig: PathBuf,
    /// Further files (the pen trace of a floor run).
    pub extra: Vec<PathBuf>,
    /// Rows recorded.
    pub samples: usize,
}

/// Why an experiment could not be run.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// The simulation could not be set up, or stopped.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A floor run stopped.
    #[error(transparent)]
    Run(#[from] RunError),
    /// A file could not be written.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// An option's value that cannot be used (the message names it).
    #[error("{0}")]
    Setup(String),
}

fn write(path: &Path, text: &str) -> Result<(), ExperimentError> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|source| ExperimentError::Io {
            path: dir.to_owned(),
            source,
        })?;
    }
    crate::output::write_atomically(path, text).map_err(|source| ExperimentError::Io {
        path: path.to_owned(),
        source,
    })
}

/// 1024-count quadrature encoder: whole counts of a shaft angle.
pub(crate) fn encoder_counts(angle_rad: f64, counts_per_rev: f64) -> f64 {
    (angle_rad * counts_per_rev / TAU).floor()
}

pub(crate) const ENCODER_COUNTS: f64 = 1024.0;

/// A shaft speed as the logger derives it from a 1024-count encoder read at a fixed
/// interval: the whole counts since the last read over the interval.
#[derive(Debug, Clone, Copy)]
pub(crate) struct EncoderSpeed {
    last_counts: f64,
}

impl EncoderSpeed {
    /// An encoder last read at `angle_rad`.
    pub(crate) fn new(angle_rad: f64) -> Self {
        EncoderSpeed {
            last_counts: encoder_counts(angle_rad, ENCODER_COUNTS),
        }
    }

    /// Reads the shaft at `angle_rad`, `interval_s` after the last read: speed, rad/s.
    pub(crate) fn read(&mut self, angle_rad: f64, interval_s: f64) -> f64 {
        let counts = encoder_counts(angle_rad, ENCODER_COUNTS);
        let speed = (counts - self.last_counts) * TAU / ENCODER_COUNTS / interval_s;
        self.last_counts = counts;
        speed
    }
}

/// Runs an experiment on a scene.
pub fn run_experiment(
    kind: ExperimentKind,
    scene: &Scene,
    opts: &ExperimentOptions,
) -> Result<ExperimentOutput, ExperimentError> {
    let interval = checked_settings(kind, scene, opts)?;
    let mut scene = scene.clone();
    if let Some(seed) = opts.seed {
        scene.sim.seed = seed;
    }
    let name = opts
        .name
        .clone()
        .unwrap_or_else(|| kind.name().replace('-', "_"));
    if name.is_empty() || name == "." || name == ".." || name.contains(['/', '\\']) {
        return Err(ExperimentError::Setup(format!(
            "--name `{name}`: expected a plain file stem (no `/`, `\\`, `.` or `..`), so that the files stay inside --out"
        )));
    }
    let recording = opts.out_dir.join(format!("{name}.csv"));
    let rig_path = opts.out_dir.join(format!("{name}.rig.toml"));
    let mut rng = Pcg64::seed_from_u64(scene.sim.seed ^ 0xe4e1);
    let (csv, rig, extra, samples) = match kind {
        ExperimentKind::LiftedRandomDemand => {
            let (csv, n) = lifted_random_demand(&scene, opts, interval, &mut rng)?;
            (csv, pair_rig(&scene), vec![], n)
        }
        ExperimentKind::FallingWeight => {
            let (csv, n) = falling_weight(&scene, opts, interval, &mut rng);
            (csv, falling_weight_rig(&scene, opts), vec![], n)
        }
        ExperimentKind::CoastDown => {
            let (csv, n) = coast_down(&scene, opts, interval, &mut rng)?;
            (csv, axis_rig(&scene), vec![], n)
        }
        ExperimentKind::FloorRun => {
            let out = run_scene(
                &scene,
                &RunOptions {
                    out_dir: opts.out_dir.clone(),
                    name: name.clone(),
                    manoeuvre: None,
                },
                None,
            )?;
            let (dashes, n) = pen_trace(&out.recording, interval, opts.pen_play_m, &mut rng)?;
            let dash_path = opts.out_dir.join(format!("{name}.dashes.csv"));
            write(&dash_path, &dashes)?;
            let csv =
                std::fs::read_to_string(&out.recording).map_err(|source| ExperimentError::Io {
                    path: out.recording.clone(),
                    source,
                })?;
            (csv, vehicle_rig(&scene), vec![dash_path, out.scene_used], n)
        }
    };
    let rig = perturb(rig, opts.rig_error, &mut rng);
    write(&recording, &csv)?;
    let mut rig_text = format!(
        "# Written by `agvsim experiment {}` from scene values{}.\n",
        kind.name(),
        if opts.rig_error > 0.0 {
            format!(
                ", each uncertain value off by up to {:.0} %",
                100.0 * opts.rig_error
            )
        } else {
            String::new()
        }
    );
    rig_text.push_str(&rig.to_toml());
    write(&rig_path, &rig_text)?;
    Ok(ExperimentOutput {
        recording,
        rig: rig_path,
        extra,
        samples,
    })
}

/// The settings checked before any work (the interval, the rig error, the encoder noise,
/// the duration against the step budget); the sample interval, s.
fn checked_settings(
    kind: ExperimentKind,
    scene: &Scene,
    opts: &ExperimentOptions,
) -> Result<f64, ExperimentError> {
    let interval = opts.interval_s.unwrap_or(kind.default_interval_s());
    if !(interval > 0.0 && interval.is_finite()) {
        return Err(ExperimentError::Setup(format!(
            "--interval {}: expected a positive number of seconds",
            crate::param::plain_number(interval)
        )));
    }
    if !(0.0..1.0).contains(&opts.rig_error) {
        return Err(ExperimentError::Setup(format!(
            "--rig-error {}: expected a fraction from 0 up to (not including) 1; beliefs off by 100 % or more can turn a resistance, an inertia or a gain negative",
            crate::param::plain_number(opts.rig_error)
        )));
    }
    // An encoder's noise is a fraction of the speeds it reads; beyond the simulator's own
    // speed limit it is no encoder (and 1e308 would write infinite cells).
    if !(0.0..=MAX_SPEED_NOISE_RAD_S).contains(&opts.speed_noise_rad_s) {
        return Err(ExperimentError::Setup(format!(
            "--speed-noise {}: expected an RMS noise from 0 to {MAX_SPEED_NOISE_RAD_S} rad/s",
            crate::param::plain_number(opts.speed_noise_rad_s)
        )));
    }
    {
        let d = opts.duration_s;
        // The budget up front, as `run` checks it: a typo of days never starts.
        let steps = d / scene.sim.dt_s;
        if !(d.is_finite() && d > 0.0 && steps <= scene.sim.max_steps as f64) {
            return Err(ExperimentError::Setup(format!(
                "--duration {}: expected a positive length of at most sim.max_steps = {} physics steps of sim.dt_s = {} s ({} s); raise sim.max_steps in the scene if it is meant",
                crate::param::plain_number(d),
                scene.sim.max_steps,
                scene.sim.dt_s,
                crate::param::plain_number(scene.sim.max_steps as f64 * scene.sim.dt_s)
            )));
        }
    }
    Ok(interval)
}

fn lifted_scene(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    s.sim.wheels_lifted = true;
    s
}

fn steps_per(interval: f64, dt: f64) -> Result<u64, ExperimentError> {
    let n = (interval / dt).round();
    if n < 1.0 || ((n * dt) - interval).abs() > 1e-9 * interval.max(1.0) {
        return Err(ExperimentError::Setup(format!(
            "the sample interval {interval} s must be a whole number of simulation steps (sim.dt_s = {dt} s)"
        )));
    }
    Ok(n as u64)
}
